"""The core pipeline as plain functions: load -> map -> detect -> synthesize -> write.

This is the Python API behind the ``auralize`` command; each CLI sub-command
is a thin wrapper over one of these.

Examples
--------
>>> import auralize.pipeline as ap
>>> vol = ap.load("dataset:monopole", size=16, steps=40)
>>> path = ap.ListenerPath.point(vol.center + [1.0, 0, 0], duration=0.02)
>>> out, series = ap.auralize(vol, path, thresholds=ap.Thresholds(monopole="1%"))
>>> out.audio.shape
(1, 882)
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from auralize.datasets import DEFAULT_MAPPING, make_dataset
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.mapping import AcousticMapping, get_mapping
from auralize.progress import progress_step
from auralize.sources import SourceSeries, Thresholds, detect
from auralize.synthesis import C0, Rendered, render
from auralize.volume import TimeVolume

__all__ = [
    "ListenerPath",
    "Thresholds",
    "auralize",
    "auto_mapping",
    "detect_sources",
    "load",
    "save_rendered",
]


def load(spec: str | Path | TimeVolume, *, size: int | None = None, steps: int | None = None,
         seed: int = 0, fields: dict[str, str] | None = None,
         resolution: int | tuple[int, int, int] | None = None) -> TimeVolume:  # fmt: skip
    """Open a volume file, or generate a built-in dataset with ``"dataset:NAME"``."""
    if isinstance(spec, TimeVolume):
        return spec
    s = str(spec)
    if s.startswith("dataset:"):
        return make_dataset(s.split(":", 1)[1], size=size, steps=steps, seed=seed)
    from auralize.io import open_volume

    return open_volume(s, fields=fields, resolution=resolution)


def auto_mapping(volume: TimeVolume) -> str:
    """The mapping preset a volume most likely wants.

    Built-in datasets name theirs; a ``log10_density`` field means the paper's
    mapping; a ``momentum`` field means ``cfd``; otherwise ``identity``.
    """
    ds = volume.attrs.get("dataset")
    if isinstance(ds, str) and ds in DEFAULT_MAPPING:
        return DEFAULT_MAPPING[ds]
    names = set(volume.field_names)
    if "log10_density" in names:
        return "paper-density"
    if "momentum" in names and "density" in names:
        return "cfd"
    return "identity"


def detect_sources(volume: TimeVolume, *, mapping: str | AcousticMapping | None = None,
                   thresholds: Thresholds | None = None, progress_bar: bool = False,
                   **mapping_fields: str) -> SourceSeries:  # fmt: skip
    """Detect sources with ``mapping`` (default :func:`auto_mapping`)."""
    m = get_mapping(mapping or auto_mapping(volume), **mapping_fields)
    return detect(volume, mapping=m, thresholds=thresholds, progress_bar=progress_bar)


def auralize(volume: TimeVolume, path: ListenerPath, *,
             mapping: str | AcousticMapping | None = None, thresholds: Thresholds | None = None,
             rate: int = 44100, time_scale: float = 1.0, interp: str = "cubic",
             layout: str = "mono", c0: float = C0, duration: float | None = None,
             series: SourceSeries | None = None, progress_bar: bool = False,
             **mapping_fields: str) -> tuple[Rendered, SourceSeries]:  # fmt: skip
    """Detect sources (unless ``series`` is given) and render the sound along ``path``.

    The listener path must stay inside the grid.
    """
    if series is None:
        series = detect_sources(volume, mapping=mapping, thresholds=thresholds,
                                progress_bar=progress_bar, **mapping_fields)  # fmt: skip
    with progress_step("render", enabled=progress_bar):
        out = render(series.tracks(), path, rate=rate, time_scale=time_scale, interp=interp,
                     layout=layout, c0=c0, duration=duration, bounds=volume.bounds)  # fmt: skip
    out.meta.update({"volume": volume.source, "mapping": series.meta.get("mapping"),
                     "thresholds": series.thresholds.tolist()})  # fmt: skip
    return out, series


def save_rendered(rendered: Rendered, out: str | Path, *, normalize: str = "peak",
                  limit_pa: float | None = None, extra: dict[str, Any] | None = None,
                  subtype: str | None = None) -> float:  # fmt: skip
    """Write a render to WAV/FLAC (atomic) with its sidecar JSON; returns the gain.

    ``subtype``: sample format, ``float32``, ``pcm16`` or ``pcm24`` (see
    :func:`auralize.audio.write_audio`)."""
    from auralize.audio import write_audio

    if normalize not in ("peak", "none"):
        raise ParameterError(f"normalize must be 'peak' or 'none', got {normalize!r}")
    return write_audio(
        out, rendered.audio, rendered.rate, channel_mask=rendered.layout.channel_mask,
        normalize=normalize, limit_pa=limit_pa, subtype=subtype,
        sidecar={"layout": rendered.layout.describe(), "time_scale": rendered.time_scale,
                 **rendered.meta, **(extra or {})},
    )  # fmt: skip
