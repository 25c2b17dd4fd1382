"""The sound engine: every model's sound reaches the listener through here.

A sound model (:class:`auralize.plugins.SoundModel`) describes what it
*emits*; the engine does the propagation (retarded time, distance law,
Doppler), the panning to any layout, and the summation of several models
along one listener path.  Three kinds of parts make up a :class:`Sound`:

:class:`Emitters`
    point emitters with emitted signals sampled at any rate (audio-rate
    textures of vortex and aerodynamic sound, a fire's pressure, a moving
    object), monopole ``(S, n)`` or dipole ``(S, 3, n)``;
:class:`FieldSources`
    the monopole/dipole/quadrupole sources detected in a volume
    (:class:`auralize.sources.detection.SourceTracks`), sampled at the data's steps and
    rendered by the piecewise-Hermite kernels of :mod:`auralize.emitters.synthesis`;
a model's own part
    any object with ``name`` and ``render_part(path, *, rate, layout,
    duration, start, c0, backend) -> Rendered`` for closed forms that are
    faster than sampled emission (spark's WM-wave accumulation); it takes its
    arrival times, distances and panning gains from the engine.

Emitter times are seconds of playback from the listener path's first
capture: output sample ``n`` is heard at ``start + n / rate``.

For emitter ``s`` at position ``x_s(τ)`` and a listener at ``L(t)`` the
received pressure is (paper 003 §3.2.4.2 for the retarded time; the
far-field point-source law of paper 000 §6, Eq. 5 and paper 004 §6, Eq. 4):

    p(t) = Σ_s  a_s(τ_s) · g(D_s),   t − τ_s = D_s / c0,   D_s = |L(t) − x_s(τ_s)|

with ``a_s = q_s`` for a monopole, ``a_s = û_s · G_s`` for a dipole (û the
unit vector from the emitter to the listener), ``g(D) = 1/D^e`` (``e = 1``,
"physical"; ``e = 3``, "paper" for paper 000's 1/r³ erratum), and D clamped
to the emitter's radius.  Panning uses the layout's own law on the
emitter's direction in the listener's frame (:func:`auralize.spatial.layouts.pan_gains`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import ParameterError

#: speed of sound in air (m/s): the one default of the core and the plugins
C0 = 343.0
LAWS = {"physical": 1.0, "paper": 3.0}


def law_exponent(law: str | float) -> float:
    """Distance-law exponent e of ``g(D) = 1/D^e``: "physical" 1, "paper" 3, or a number."""
    if isinstance(law, str) and law in LAWS:
        return LAWS[law]
    try:
        e = float(law)
    except (TypeError, ValueError):
        raise ParameterError(
            f"distance law must be 'physical', 'paper' or an exponent, got {law!r}"
        ) from None
    if not (np.isfinite(e) and 0.0 <= e <= 6.0):
        raise ParameterError(f"distance-law exponent must be in [0, 6], got {law!r}")
    return e


@dataclass
class Emitters:
    """Point emitters with emitted signals.

    Parameters
    ----------
    signals : (S, n) or (S, 3, n) float
        Emitted pressure at 1 m in Pa (monopoles), or the world-frame vector
        ``G`` of dipoles whose pressure toward unit direction û is ``û · G``.
        Values outside ``[t0, t0 + n / rate)`` are zero.
    rate : float
        Samples per second of ``signals`` (any rate: the engine interpolates).
    positions : (S, 3) or (S, m, 3) float
        Static positions (m), or trajectories sampled at ``pos_rate`` from
        ``t0`` (held at their ends); moving emitters get their Doppler shift
        from the retarded time.
    t0 : float
        Playback seconds (since the listener path's first capture) of sample 0.
    pos_rate : float, optional
        Samples per second of trajectories (default ``rate``).
    radius : float or (S,)
        Distances are clamped here (m): a listener at an emitter gets no 1/0.
    law : "physical" (1/D), "paper" (1/D³) or an exponent.
    name : str
        The model that made them (reports, scene listings).
    """

    signals: NDArray[np.float64]
    rate: float
    positions: NDArray[np.float64]
    t0: float = 0.0
    pos_rate: float | None = None
    radius: float | NDArray[np.float64] = 0.05
    law: str | float = "physical"
    name: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        sig = np.asarray(self.signals, dtype=np.float64)
        if sig.ndim == 1:
            sig = sig[None]
        if sig.ndim not in (2, 3) or (sig.ndim == 3 and sig.shape[1] != 3):
            raise ParameterError(
                f"emitter signals must be (S, n) monopoles or (S, 3, n) dipoles, got {sig.shape}"
            )
        if not np.all(np.isfinite(sig)):
            raise ParameterError(f"{self.name or 'emitter'} signals contain NaN or Inf")
        pos = np.asarray(self.positions, dtype=np.float64)
        if pos.ndim == 1:
            pos = pos[None]
        S = sig.shape[0]
        if pos.shape[0] != S or pos.shape[-1] != 3 or pos.ndim not in (2, 3):
            raise ParameterError(
                f"emitter positions must be (S, 3) or (S, m, 3) for S={S} signals, got {pos.shape}"
            )
        if not np.all(np.isfinite(pos)):
            raise ParameterError(f"{self.name or 'emitter'} positions contain NaN or Inf")
        if not (np.isfinite(self.rate) and self.rate > 0):
            raise ParameterError(f"emitter rate must be > 0 samples/s, got {self.rate!r}")
        pr = self.rate if self.pos_rate is None else self.pos_rate
        if not (np.isfinite(pr) and pr > 0):
            raise ParameterError(f"emitter pos_rate must be > 0 samples/s, got {pr!r}")
        if not np.isfinite(self.t0):
            raise ParameterError(f"emitter t0 must be finite, got {self.t0!r}")
        rad = np.broadcast_to(np.asarray(self.radius, dtype=np.float64), (S,))
        if not np.all(np.isfinite(rad) & (rad > 0)):
            raise ParameterError("emitter clamp radius must be > 0 m")
        law_exponent(self.law)
        self.signals = np.ascontiguousarray(sig)
        self.positions = np.ascontiguousarray(pos)
        self.pos_rate = float(pr)
        self.rate = float(self.rate)
        self.t0 = float(self.t0)
        self.radius = np.ascontiguousarray(rad)

    @property
    def n_emitters(self) -> int:
        return int(self.signals.shape[0])

    @property
    def dipole(self) -> bool:
        return self.signals.ndim == 3

    @property
    def moving(self) -> bool:
        return self.positions.ndim == 3

    @property
    def n_samples(self) -> int:
        return int(self.signals.shape[-1])

    @property
    def t_end(self) -> float:
        """Playback second just after the last emitted sample."""
        return self.t0 + self.n_samples / self.rate

    def position_at(self, tau: NDArray[np.float64], s: int) -> NDArray[np.float64]:
        """Emitter ``s``'s position at emission times ``tau`` (N,) -> (N, 3) (linear, held)."""
        if not self.moving:
            return np.broadcast_to(self.positions[s], (np.size(tau), 3))
        assert self.pos_rate is not None
        tp = self.t0 + np.arange(self.positions.shape[1]) / self.pos_rate
        return np.stack([np.interp(tau, tp, self.positions[s, :, k]) for k in range(3)], axis=1)


@dataclass
class FieldSources:
    """Sources detected in a volume, rendered by :func:`auralize.emitters.synthesis.render`.

    ``time_scale`` playback seconds per data second, ``lead`` data seconds
    skipped at the start, ``interp`` the strength interpolation (§3.2.4.3),
    ``timbre`` one of :data:`auralize.emitters.timbre.TIMBRES`.
    """

    tracks: Any  # auralize.sources.detection.SourceTracks
    time_scale: float = 1.0
    lead: float = 0.0
    interp: str = "cubic"
    timbre: str = "physical"
    bounds: tuple[float, ...] | None = None
    name: str = "field"
    meta: dict[str, Any] = field(default_factory=dict)


Part = Emitters | FieldSources | Any  # or a model part with render_part()


@dataclass
class Sound:
    """What a sound model emits: parts for the engine, plus metadata."""

    parts: list[Part]
    meta: dict[str, Any] = field(default_factory=dict)
    name: str = ""

    def __add__(self, other: Sound) -> Sound:
        return Sound(parts=[*self.parts, *other.parts], meta={**self.meta, **other.meta},
                     name="+".join(n for n in (self.name, other.name) if n))  # fmt: skip


def __getattr__(name: str) -> Any:
    # the renderers import synthesis (numba); load them on first use
    if name in ("render", "render_emitters"):
        import importlib

        return getattr(importlib.import_module("auralize.emitters.engine"), name)
    raise AttributeError(name)
