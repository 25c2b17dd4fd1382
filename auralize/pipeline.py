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
from auralize.mapping import ROLE_NAMES, AcousticMapping, get_mapping, match_field
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
    "resolve_mapping",
    "save_rendered",
]


def load(spec: str | Path | TimeVolume, *, size: int | None = None, steps: int | None = None,
         seed: int = 0, fields: dict[str, str] | None = None,
         resolution: int | tuple[int, int, int] | None = None, nan: str = "mask") -> TimeVolume:  # fmt: skip
    """Open a volume file, or generate a built-in dataset with ``"dataset:NAME"``.

    ``nan`` (``"mask"`` or ``"error"``) is what NaN, fill values and masked
    cells in a file are; see :func:`auralize.io.open_volume`.
    """
    if isinstance(spec, TimeVolume):
        return spec
    s = str(spec)
    if s.startswith("dataset:"):
        return make_dataset(s.split(":", 1)[1], size=size, steps=steps, seed=seed)
    from auralize.io import open_volume

    return open_volume(s, fields=fields, resolution=resolution, nan=nan)


def auto_mapping(volume: TimeVolume) -> str:
    """The mapping preset a volume most likely wants.

    Built-in datasets name theirs; a log10-density field means the paper's
    mapping; density plus momentum means ``cfd``; pressure without density
    (incompressible CFD such as OpenFOAM's ``p`` and ``U``) means
    ``incompressible``; otherwise ``identity``.  Field roles are found by
    :func:`auralize.mapping.match_field`.
    """
    ds = volume.attrs.get("dataset")
    if isinstance(ds, str) and ds in DEFAULT_MAPPING:
        return DEFAULT_MAPPING[ds]
    role = {r: match_field(volume, r) for r in ROLE_NAMES}
    if role["log10_density"] is not None and role["density"] is None:
        return "paper-density"
    if role["density"] is not None and role["momentum"] is not None:
        return "cfd"
    if role["density"] is None and role["pressure"] is not None:
        return "incompressible"
    return "identity"


#: The field-name options of each preset and the role each one plays.
PRESET_ROLES = {
    "identity": {"density": "density", "velocity": "velocity"},
    "cfd": {"density": "density", "momentum": "momentum", "velocity": "velocity"},
    "incompressible": {"pressure": "pressure", "velocity": "velocity"},
    "paper-density": {"field": "log10_density"},
}


def resolve_mapping(volume: TimeVolume, mapping: str | AcousticMapping | None = None,
                    **mapping_fields: str) -> AcousticMapping:  # fmt: skip
    """The mapping for ``volume``: the preset (default :func:`auto_mapping`) with its
    field names matched to the volume's fields where not given."""
    if isinstance(mapping, AcousticMapping) or callable(mapping):
        return get_mapping(mapping, **mapping_fields)
    name = mapping or auto_mapping(volume)
    names = {k: v for k, v in mapping_fields.items() if v}
    for option, role in PRESET_ROLES.get(name, {}).items():
        if option not in names:
            found = match_field(volume, role)
            if found is not None:
                names[option] = found
    return get_mapping(name, **names)


def detect_sources(volume: TimeVolume, *, mapping: str | AcousticMapping | None = None,
                   thresholds: Thresholds | None = None, progress_bar: bool = False,
                   **mapping_fields: str) -> SourceSeries:  # fmt: skip
    """Detect sources with ``mapping`` (default :func:`auto_mapping`).

    Source types the mapping cannot compute (e.g. no velocity field: no
    dipoles or quadrupoles) are listed in ``series.meta["unavailable"]``
    (``{type: reason}``), and the volume's valid-point ratio in
    ``series.meta["valid_ratio"]``.
    """
    m = resolve_mapping(volume, mapping, **mapping_fields)
    series = detect(volume, mapping=m, thresholds=thresholds, progress_bar=progress_bar)
    unavailable = m.unavailable(volume)
    if unavailable:
        series.meta["unavailable"] = unavailable
    series.meta["valid_ratio"] = volume.valid_ratio
    return series


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
    out = render(series.tracks(), path, rate=rate, time_scale=time_scale, interp=interp,
                 layout=layout, c0=c0, duration=duration, bounds=volume.bounds)  # fmt: skip
    out.meta.update({"volume": volume.source, "mapping": series.meta.get("mapping"),
                     "thresholds": series.thresholds.tolist()})  # fmt: skip
    if series.meta.get("unavailable"):
        out.meta["unavailable"] = series.meta["unavailable"]
    return out, series


def save_rendered(rendered: Rendered, out: str | Path, *, normalize: str = "peak",
                  limit_pa: float | None = None, extra: dict[str, Any] | None = None) -> float:  # fmt: skip
    """Write a render to WAV/FLAC (atomic) with its sidecar JSON; returns the gain."""
    from auralize.audio import write_audio

    if normalize not in ("peak", "none"):
        raise ParameterError(f"normalize must be 'peak' or 'none', got {normalize!r}")
    return write_audio(
        out, rendered.audio, rendered.rate, channel_mask=rendered.layout.channel_mask,
        normalize=normalize, limit_pa=limit_pa,
        sidecar={"layout": rendered.layout.describe(), "time_scale": rendered.time_scale,
                 **rendered.meta, **(extra or {})},
    )  # fmt: skip
