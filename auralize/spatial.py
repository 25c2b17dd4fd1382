"""Speaker layouts and panning gains.

Azimuths are degrees counter-clockwise from the listener's forward direction
(0 front, +90 left, -90 right); elevation degrees up from the horizontal
plane.  ``ring8`` (DESIGN.md) is eight speakers at 45°·k, channel k.

The synthesis kernel pans each source from its direction in the listener's
frame with pairwise 2-D VBAP between adjacent speakers of the horizontal
ring (power-normalised: Σ g² = 1).  :func:`vbap_gains` is the same law in
numpy, used by tests and by the brute-force reference.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from auralize.errors import FormatError, ParameterError


@dataclass(frozen=True)
class Speaker:
    name: str
    azimuth_deg: float | None  # None: not panned to (LFE)
    elevation_deg: float = 0.0
    distance_m: float | None = None


@dataclass(frozen=True)
class Layout:
    """An ordered set of output channels.

    ``fold_front``: for two-speaker layouts, rear directions are mirrored to
    the front (stereo cannot place sounds behind).
    """

    name: str
    speakers: tuple[Speaker, ...]
    fold_front: bool = False
    channel_mask: int | None = None
    meta: dict[str, object] = field(default_factory=dict, compare=False)

    @property
    def n_channels(self) -> int:
        return len(self.speakers)

    @property
    def channel_names(self) -> list[str]:
        return [s.name for s in self.speakers]

    def panning_arrays(self) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Sorted azimuths (radians, in (-π, π]) and their channel indices (mono: empty)."""
        if self.n_channels == 1:
            return np.zeros(0), np.zeros(0, dtype=np.int64)
        az, ch = [], []
        for c, s in enumerate(self.speakers):
            if s.azimuth_deg is None:
                continue
            a = np.deg2rad(((s.azimuth_deg + 180.0) % 360.0) - 180.0)
            if a <= -np.pi:
                a += 2 * np.pi
            az.append(a)
            ch.append(c)
        order = np.argsort(az)
        return np.asarray(az)[order], np.asarray(ch, dtype=np.int64)[order]

    def describe(self) -> dict[str, object]:
        return {
            "name": self.name,
            "channels": [
                {"name": s.name, "azimuth_deg": s.azimuth_deg, "elevation_deg": s.elevation_deg}
                for s in self.speakers
            ],
        }


def _sp(name: str, az: float | None, el: float = 0.0) -> Speaker:
    return Speaker(name, az, el)


BUILTIN_LAYOUTS: dict[str, Layout] = {
    "mono": Layout("mono", (_sp("M", 0.0),), channel_mask=0x4),
    "stereo": Layout(
        "stereo", (_sp("L", 30.0), _sp("R", -30.0)), fold_front=True, channel_mask=0x3
    ),
    "ring8": Layout("ring8", tuple(_sp(f"S{k}", 45.0 * k) for k in range(8))),
    # WAVE/SMPTE order: FL FR FC LFE BL BR (ITU-R BS.775 angles)
    "5.1": Layout(
        "5.1",
        (
            _sp("FL", 30.0),
            _sp("FR", -30.0),
            _sp("FC", 0.0),
            _sp("LFE", None),
            _sp("BL", 110.0),
            _sp("BR", -110.0),
        ),
        channel_mask=0x3F,
    ),  # fmt: skip
    # WAVE order: FL FR FC LFE BL BR SL SR
    "7.1": Layout(
        "7.1",
        (
            _sp("FL", 30.0),
            _sp("FR", -30.0),
            _sp("FC", 0.0),
            _sp("LFE", None),
            _sp("BL", 150.0),
            _sp("BR", -150.0),
            _sp("SL", 90.0),
            _sp("SR", -90.0),
        ),
        channel_mask=0x63F,
    ),  # fmt: skip
}


def get_layout(spec: str | Path | Layout) -> Layout:
    """A built-in layout by name, or a custom one from a JSON file.

    Custom JSON: ``{"name": "...", "speakers": [{"azimuth": deg, "elevation": deg,
    "name": "...", "distance": m}, ...]}`` or a bare list of such objects.
    """
    if isinstance(spec, Layout):
        return spec
    s = str(spec)
    if s in BUILTIN_LAYOUTS:
        return BUILTIN_LAYOUTS[s]
    if s.lower().endswith(".json"):
        return load_layout_json(Path(s))
    raise ParameterError(
        f"unknown layout {s!r}; choose one of {sorted(BUILTIN_LAYOUTS)} or a JSON file"
    )


def load_layout_json(path: Path) -> Layout:
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise FormatError(f"layout file {str(path)!r} does not exist") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise FormatError(f"{path}: not valid JSON ({exc})") from None
    items = data.get("speakers") if isinstance(data, dict) else data
    name = data.get("name", Path(path).stem) if isinstance(data, dict) else Path(path).stem
    if not isinstance(items, list) or not items:
        raise FormatError(f"{path}: expected a non-empty list 'speakers' of {{azimuth, elevation}}")
    speakers = []
    for i, it in enumerate(items):
        if not isinstance(it, dict) or "azimuth" not in it:
            raise FormatError(f"{path}: speaker {i} needs an 'azimuth' in degrees, got {it!r}")
        try:
            az = float(it["azimuth"])
            el = float(it.get("elevation", 0.0))
            dist = None if it.get("distance") is None else float(it["distance"])
        except (TypeError, ValueError):
            raise FormatError(f"{path}: speaker {i} has non-numeric angles: {it!r}") from None
        if not np.isfinite(az) or not -90 <= el <= 90:
            raise FormatError(
                f"{path}: speaker {i}: azimuth must be finite and elevation in [-90, 90]"
            )
        speakers.append(Speaker(str(it.get("name", f"S{i}")), az, el, dist))
    if len(speakers) < 2:
        raise FormatError(f"{path}: panning needs at least 2 speakers, got {len(speakers)}")
    azs = [round(s.azimuth_deg % 360.0, 6) for s in speakers if s.azimuth_deg is not None]
    if len(set(azs)) != len(azs):
        raise FormatError(f"{path}: two speakers share the same azimuth: {sorted(azs)}")
    names = [s.name for s in speakers]
    if len(set(names)) != len(names):
        raise FormatError(f"{path}: duplicate speaker names {names}")
    return Layout(str(name), tuple(speakers), fold_front=len(speakers) == 2)


def vbap_gains(layout: Layout, azimuth_rad: NDArray[np.floating]) -> NDArray[np.float64]:
    """Pairwise 2-D VBAP gains ``(n_channels, N)`` for source azimuths (radians, listener frame).

    Power-normalised: the squared gains of each direction sum to 1.
    """
    az, ch = layout.panning_arrays()
    phi = np.atleast_1d(np.asarray(azimuth_rad, dtype=np.float64))
    out = np.zeros((layout.n_channels, phi.size))
    if az.size == 0:
        out[0] = 1.0
        return out
    if layout.fold_front:
        phi = np.arctan2(np.sin(phi), np.abs(np.cos(phi)))
    phi = np.angle(np.exp(1j * phi))
    n = az.size
    i0 = np.searchsorted(az, phi, side="right") - 1
    i0 = np.where(i0 < 0, n - 1, i0)
    i1 = (i0 + 1) % n
    two_pi = 2 * np.pi
    span = np.mod(az[i1] - az[i0], two_pi)
    span = np.where(span == 0, two_pi, span)
    rel = np.mod(phi - az[i0], two_pi)
    wide = span > np.pi
    rel = np.where(wide, np.where(rel < 0.5 * span, 0.0, span), np.minimum(rel, span))
    s = np.sin(span)
    with np.errstate(divide="ignore", invalid="ignore"):
        g0 = np.where(np.abs(s) < 1e-12, np.cos(rel * np.pi / (2 * span)), np.sin(span - rel) / s)
        g1 = np.where(np.abs(s) < 1e-12, np.sin(rel * np.pi / (2 * span)), np.sin(rel) / s)
    g0, g1 = np.clip(g0, 0, None), np.clip(g1, 0, None)
    norm = np.hypot(g0, g1)
    norm = np.where(norm > 0, norm, 1)
    cols = np.arange(phi.size)
    np.add.at(out, (ch[i0], cols), g0 / norm)
    np.add.at(out, (ch[i1], cols), g1 / norm)
    return out


def listener_frame_azimuth(direction: NDArray[np.floating], forward: NDArray[np.floating],
                           up: NDArray[np.floating]) -> NDArray[np.float64]:  # fmt: skip
    """Azimuth (radians, counter-clockwise from forward) of ``direction (N,3)``."""
    d = np.asarray(direction, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(forward, dtype=np.float64).reshape(-1, 3)
    u = np.asarray(up, dtype=np.float64).reshape(-1, 3)
    left = np.cross(u, f)
    return np.arctan2(np.sum(d * left, axis=1), np.sum(d * f, axis=1))
