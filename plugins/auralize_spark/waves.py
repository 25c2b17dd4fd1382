"""N-waves, WM-waves and their summation at the listener (paper 002 §4.2.2–4.2.3).

* Eq. 3–4: peak pressure and half-duration of a point-source N-wave at
  distance r, ``p_s = r0 p_s0 / (r √(1 + σ0 ln(r/r0)))`` and
  ``T = T0 √(1 + σ0 ln(r/r0))`` with σ0 = 0.524 (Wright 1983).
* Eq. 5: the WM-wave of a line segment of half-length l seen at angle θ from
  its normal, in τ = (ct − r)/l with ψ = cT/l, B = A l²/(2rcT), s = sin θ;
  two branches, s < ψ (an N-wave with rounded corners) and s ≥ ψ (two
  separate parabolic pulses of opposite sign).
* §4.2.2 (a)–(c): θ, r, T per segment, the wave added into the output buffer
  at its arrival time r/c.  Here each output sample receives the *mean* of p
  over its sampling interval (exact, from the closed-form antiderivative), so
  the µs-scale shocks of the small presets do not alias at 44.1 kHz.
* Propagation is the engine's: the arrival time of each segment centre (the
  retarded time for a moving listener), its distance r, its direction and the
  layout's panning gains come from :func:`auralize.emitters.events.arrivals`;
  the discharge is a model part (:class:`DischargePart`) of an
  :class:`auralize.emitters.Sound`.  Eqs. 3–4 are the model's own physics:
  they set the amplitude and duration of each wave at its distance r (there is
  no further 1/r law on top).

Choices written down here:

* Amplitude: the paper sets A = 1 (arbitrary).  By default
  (``amplitude="eq3"``) A = p_s r / (2l), which makes the broadside (θ = 0)
  WM-wave exactly the N-wave of Eqs. 3–4 (peak 4Bψ = p_s); ``"paper"`` keeps
  A = 1.
* Distance clamping: Eqs. 3–4 are calibrated for r ≥ r0 (for
  r < r0·e^(−1/σ0) ≈ 0.15 r0 the square root would be imaginary), so the
  amplitude and duration laws use max(r, r0); arrival times use the true r.
  A listener on a segment is therefore finite; clamped segments are counted
  in ``meta["clamped_segments"]``.
* T0 is jittered per segment and stroke by a factor ``1 + jitter·N(0, 1)``
  (clipped to [0.5, 1.5]), seeded ("T0 was also fluctuated by small random
  values").
* Strokes (§4.2.3, Fig. 8): the number of strokes of a flash follows the
  logarithmic (log-series) distribution P(k) = −p^k / (k ln(1 − p)) with
  p = 0.85 (P(1) = 0.45, P(4..6) = 0.15, P(>10) = 0.04, mean 3.0: mostly
  single strokes, often 4–6, a tail beyond 10); inter-stroke intervals are
  10 ms · (1 + K), K ~ Poisson(3) (mode 30–40 ms, mean 40 ms), clipped to
  [10, 240] ms.  The first stroke sounds along the whole tree; later strokes
  (dart leaders) along the main channel only.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.emitters import C0
from auralize.emitters.events import arrivals, sparse_gains
from auralize.emitters.synthesis import Rendered
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.spatial.layouts import Layout, get_layout

from ._kernels import accumulate_wm
from .leader import Discharge

SIGMA0 = 0.524
STROKE_P = 0.85
INTERVAL_UNIT_S = 0.010
INTERVAL_POISSON_MEAN = 3.0
INTERVAL_RANGE_S = (0.010, 0.240)


# ------------------------------------------------------------------ Eq. 3–4
def nwave_params(
    r: NDArray[np.floating] | float, *, r0: float, ps0: float, T0: float, sigma0: float = SIGMA0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Peak pressure and half-duration of a point-source N-wave (Eqs. 3–4).

    Parameters
    ----------
    r : (N,) m, distances (clamped to ≥ r0, see the module notes).
    r0 : m, baseline distance; ps0 : Pa, peak at r0; T0 : s, half-duration at r0.
    sigma0 : Eq. 3–4's common parameter (0.524, Wright 1983).

    Returns
    -------
    (p_s (N,) Pa, T (N,) s)

    Examples
    --------
    >>> ps, T = nwave_params(np.array([10.0, 100.0]), r0=10.0, ps0=1000.0, T0=5e-4)
    >>> np.round(ps, 2).tolist(), np.round(T * 1e6, 1).tolist()
    ([1000.0, 67.32], [500.0, 742.7])
    """
    rr = np.maximum(np.asarray(r, dtype=np.float64), r0)
    k = np.sqrt(1.0 + sigma0 * np.log(rr / r0))
    return r0 * ps0 / (rr * k), T0 * k


# -------------------------------------------------------------------- Eq. 5
def wm_wave(tau: NDArray[np.floating], s: float, psi: float, B: float) -> NDArray[np.float64]:
    """The WM-wave of Eq. 5 evaluated pointwise.

    Parameters
    ----------
    tau : (N,) dimensionless time τ = (ct − r)/l.
    s : sin θ, θ the angle between the segment normal and the listener (0 ≤ s ≤ 1).
    psi : ψ = cT/l.  B : Pa, B = A l²/(2rcT).

    Returns
    -------
    (N,) pressure in Pa (both branches, s < ψ and s ≥ ψ).
    """
    t = np.asarray(tau, dtype=np.float64)
    p = np.zeros_like(t)
    if s <= 0.0:
        m = (t > -psi) & (t <= psi)
        p[m] = -4 * B * t[m]
        return p
    if s < psi:
        m1 = (t > -psi - s) & (t <= -psi + s)
        m2 = (t > -psi + s) & (t <= psi - s)
        m3 = (t > psi - s) & (t <= psi + s)
    else:
        m1 = (t > -psi - s) & (t <= psi - s)
        m2 = np.zeros_like(m1)
        m3 = (t > -psi + s) & (t <= psi + s)
    p[m1] = -(B / s) * ((t[m1] + s) ** 2 - psi**2)
    p[m2] = -4 * B * t[m2]
    p[m3] = (B / s) * ((t[m3] - s) ** 2 - psi**2)
    return p


def wm_coefficients(
    r: NDArray[np.float64],
    hl: NDArray[np.float64],
    T: NDArray[np.float64],
    ps: NDArray[np.float64],
    *,
    c: float = C0,
    amplitude: str = "eq3",
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """ψ and B of Eq. 5 for segments at (clamped) distance r with half-length l and duration T.

    ``amplitude="eq3"``: A = p_s r/(2l), so B = p_s l/(4cT) and the broadside
    peak 4Bψ equals p_s; ``"paper"``: A = 1.
    """
    psi = c * T / hl
    if amplitude == "eq3":
        B = ps * hl / (4.0 * c * T)
    elif amplitude == "paper":
        B = hl * hl / (2.0 * r * c * T)
    else:
        raise ParameterError(f"amplitude must be 'eq3' or 'paper', got {amplitude!r}")
    return psi, B


# ------------------------------------------------------------------ strokes
def stroke_times(
    rng: np.random.Generator, *, n: int | None = None, p: float = STROKE_P
) -> NDArray[np.float64]:
    """Emission times (s, first = 0) of the strokes of one flash (§4.2.3, Fig. 8).

    ``n`` forces the number of strokes; otherwise it is drawn from the
    log-series distribution with parameter ``p``.  Intervals are
    10 ms · (1 + Poisson(3)), clipped to [10, 240] ms.
    """
    if n is None:
        n = int(rng.logseries(p))
    if int(n) < 1:
        raise ParameterError(f"a flash needs at least 1 stroke, got {n!r}")
    k = rng.poisson(INTERVAL_POISSON_MEAN, size=int(n) - 1)
    gaps = np.clip(INTERVAL_UNIT_S * (1 + k), *INTERVAL_RANGE_S)
    return np.round(np.concatenate([[0.0], np.cumsum(gaps)]), 9)


# ---------------------------------------------------------------- rendering
@dataclass(frozen=True)
class WaveParams:
    """Per-discharge constants of §4.2.2 (Table 1 gives l, r0, T0 per scale)."""

    r0: float
    T0: float
    ps0: float
    sigma0: float = SIGMA0
    c: float = C0
    jitter: float = 0.05
    amplitude: str = "eq3"

    def __post_init__(self) -> None:
        for name in ("r0", "T0", "ps0", "c"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ParameterError(f"{name} must be a positive number, got {v!r}")
        if not 0 <= self.jitter <= 0.5:
            raise ParameterError(f"jitter must be in [0, 0.5], got {self.jitter!r}")
        if self.amplitude not in ("eq3", "paper"):
            raise ParameterError(f"amplitude must be 'eq3' or 'paper', got {self.amplitude!r}")


@dataclass
class Emissions:
    """Every (stroke, segment) line source of a flash as heard at the listener.

    Arrays are (E,): arrival time of the segment centre ``t_center`` (s of
    playback), half-length ``hl`` (m, the l of Eq. 5), ``s = sin θ``, ``psi``, ``B`` (Pa),
    true distance ``r`` (m), segment index ``seg`` and ``stroke``; panning
    ``chans``/``gains`` are (E, K); ``c`` the speed of sound (m/s);
    ``doppler`` (E,) the time scale dt/dτ of each wave at a moving listener
    (1 for a static one).
    """

    t_center: NDArray[np.float64]
    hl: NDArray[np.float64]
    s: NDArray[np.float64]
    psi: NDArray[np.float64]
    B: NDArray[np.float64]
    r: NDArray[np.float64]
    seg: NDArray[np.int64]
    stroke: NDArray[np.int64]
    chans: NDArray[np.int64]
    gains: NDArray[np.float64]
    clamped: int = 0
    c: float = C0
    doppler: NDArray[np.float64] | None = None

    @property
    def time_length(self) -> NDArray[np.float64]:
        """(E,) m: the length mapping τ to heard time, ``t = t_center + τ · hl · doppler / c``."""
        return self.hl if self.doppler is None else self.hl * self.doppler

    @property
    def start_time(self) -> float:
        """Playback time (s) before which no wave has arrived."""
        if self.t_center.size == 0:
            return 0.0
        return float(np.min(self.t_center - (self.psi + self.s) * self.time_length / self.c))

    @property
    def end_time(self) -> float:
        """Playback time (s) after which every wave has passed."""
        if self.t_center.size == 0:
            return 0.0
        return float(np.max(self.t_center + (self.psi + self.s) * self.time_length / self.c * 1.01))


def emissions(
    discharge: Discharge,
    listener: ListenerPath | NDArray[np.floating],
    *,
    params: WaveParams,
    strokes: NDArray[np.floating] | None = None,
    layout: str | Layout = "mono",
    t0: float = 0.0,
    rng: np.random.Generator | None = None,
) -> Emissions:
    """Eq. 3–5 coefficients of every segment of every stroke at its arrival (§4.2.2 (a)–(b)).

    Parameters
    ----------
    discharge : the tree; listener : a :class:`ListenerPath` (playback time
        from its first capture) or a static (3,) position in m.
    strokes : (K,) s, stroke emission times relative to ``t0``.
    layout : output layout.
    rng : generator for the T0 jitter (default: seed 0).

    Arrival times, distances r, directions and panning gains of the segment
    centres come from the engine (:func:`auralize.emitters.events.arrivals`:
    the exact retarded time for a moving, turning listener, the layout's own
    2-D or 3-D law); θ is the angle between the segment and the direction to
    the listener at arrival.
    """
    rng = np.random.default_rng(0) if rng is None else rng
    lay = get_layout(layout)
    strokes = (
        np.zeros(1) if strokes is None else np.atleast_1d(np.asarray(strokes, dtype=np.float64))
    )
    mid_all, dirs_all, hl_all = discharge.midpoints, discharge.directions, discharge.half_lengths
    on_main = discharge.seg_main
    seg_idx, stk = [], []
    for k in range(strokes.size):
        idx = np.arange(discharge.n_segments) if k == 0 else np.flatnonzero(on_main)
        seg_idx.append(idx)
        stk.append(np.full(idx.size, k))
    seg = np.concatenate(seg_idx).astype(np.int64)
    stroke = np.concatenate(stk).astype(np.int64)
    mid, dirs, hl = mid_all[seg], dirs_all[seg], hl_all[seg]
    arr = arrivals(mid, t0 + strokes[stroke], listener, c0=params.c, layout=lay)
    r = arr.distance
    s = np.clip(np.abs(np.sum(arr.direction * dirs, axis=1)), 0.0, 1.0)
    s = np.where(r > 0, s, 0.0)
    s = np.maximum(s, 1e-9)  # Eq. 5 divides by s; pieces of width 2s vanish smoothly
    T0 = params.T0 * np.clip(1.0 + params.jitter * rng.standard_normal(seg.size), 0.5, 1.5)
    r_eff = np.maximum(r, params.r0)
    ps, T = nwave_params(r_eff, r0=params.r0, ps0=params.ps0, T0=1.0, sigma0=params.sigma0)
    T = T * T0
    psi, B = wm_coefficients(r_eff, hl, T, ps, c=params.c, amplitude=params.amplitude)
    assert arr.gains is not None
    chans, gains = sparse_gains(arr.gains)
    return Emissions(
        arr.time,
        hl,
        s,
        psi,
        B,
        r,
        seg,
        stroke,
        chans,
        gains,
        int(np.count_nonzero(r < params.r0)),
        float(params.c),
        arr.doppler,
    )


def accumulate(
    em: Emissions,
    n_channels: int,
    n_samples: int,
    *,
    rate: int,
    c: float = C0,
    out: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Sum the box-filtered WM-waves of ``em`` into a ``(n_channels, n_samples)`` buffer (§4.2.2 (c)).

    Sample n covers playback time ``[(n − ½)/rate, (n + ½)/rate)``; each wave's
    time axis is scaled by its Doppler factor (the pressure values are those
    of Eq. 5: a moving listener hears the static wave compressed or stretched).
    """
    if out is None:
        out = np.zeros((n_channels, n_samples))
    accumulate_wm(
        out,
        em.t_center,
        np.ascontiguousarray(em.time_length),
        em.s,
        em.psi,
        em.B,
        em.chans,
        em.gains,
        float(rate),
        float(c),
    )
    return out


@dataclass
class DischargePart:
    """A discharge's sound as a part of :class:`auralize.emitters.Sound` (paper 002 §4.2.2–4.2.3).

    Rendered in closed form by :meth:`render_part`: one WM-wave (Eq. 5) per
    segment and stroke, its amplitude and duration from Eqs. 3–4 at the
    segment's distance, added at its arrival time with the layout's gains;
    arrival times, distances, directions and gains come from
    :func:`auralize.emitters.events.arrivals`.

    Parameters
    ----------
    discharge : Discharge
    params : WaveParams (r0, T0, p_s0, σ0, jitter, amplitude; its ``c`` is
        replaced by the render's speed of sound).
    strokes : (K,) s, stroke emission times relative to ``t0`` (first 0).
    t0 : s, playback time of the first stroke (since the listener path's first capture).
    seed : seeds the T0 jitter (the same seed gives the same waves in any layout).
    """

    discharge: Discharge
    params: WaveParams
    strokes: NDArray[np.float64] = field(default_factory=lambda: np.zeros(1))
    t0: float = 0.0
    seed: int = 0
    name: str = "spark"
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        st = np.atleast_1d(np.asarray(self.strokes, dtype=np.float64))
        if st.ndim != 1 or st.size == 0 or not np.all(np.isfinite(st)):
            raise ParameterError(
                f"strokes must be a non-empty list of finite times in s, got {st!r}"
            )
        if not math.isfinite(self.t0):
            raise ParameterError(f"t0 must be a finite time in s, got {self.t0!r}")
        self.strokes = st

    def emissions(
        self,
        listener: ListenerPath | NDArray[np.floating],
        *,
        layout: str | Layout = "mono",
        c0: float | None = None,
    ) -> Emissions:
        """The emissions heard along ``listener`` (speed of sound ``c0``, default ``params.c``)."""
        params = self.params if c0 is None else replace(self.params, c=float(c0))
        return emissions(
            self.discharge,
            listener,
            params=params,
            strokes=self.strokes,
            layout=layout,
            t0=self.t0,
            rng=np.random.default_rng(self.seed),
        )

    def end_time(self, path: ListenerPath | NDArray[np.floating], *, c0: float = C0) -> float:
        """Playback second (s) when the last wave has passed the listener, +10 ms: the
        length :meth:`render_part` renders without a duration (scenes take it)."""
        return self.emissions(path, c0=c0).end_time + 0.01

    def render_part(
        self,
        path: ListenerPath | NDArray[np.floating],
        *,
        rate: int = 44100,
        layout: str | Layout = "mono",
        duration: float | None = None,
        start: float = 0.0,
        c0: float = C0,
        backend: str = "auto",
    ) -> Rendered:
        """Pressure ``(n_channels, n_samples)`` in Pa heard along ``path``.

        Output sample n is at playback time ``start + n / rate``; ``duration``
        None renders until the last wave has passed (+10 ms).  The closed form
        has one implementation, exact for every ``backend``.
        """
        from auralize.emitters.engine import BACKENDS
        from auralize.spatial.layouts import output_stage, receiver_paths

        lay = get_layout(layout)
        stage = output_stage(lay, int(rate))
        if stage.synthesis_layout is not lay:  # binaural: its intermediate, then the ears' filters
            out = self.render_part(
                path,
                rate=rate,
                layout=stage.synthesis_layout,
                duration=duration,
                start=start,
                c0=c0,
                backend=backend,
            )
            return stage.finish(out)
        if lay.meta.get("receivers"):  # the ears: each along its own path, channels stacked
            if not isinstance(path, ListenerPath):
                path = ListenerPath(np.zeros(1), np.asarray(path, dtype=np.float64).reshape(1, 3))
            if duration is None:  # until the last wave has passed the head's centre, +10 ms
                duration = self.emissions(path, c0=c0).end_time + 0.01 - start
            outs = [
                self.render_part(
                    p, rate=rate, layout=rl, duration=duration, start=start, c0=c0, backend=backend
                )
                for rl, p in receiver_paths(lay, path)
            ]
            return Rendered(
                audio=np.concatenate([o.audio for o in outs]),
                rate=int(rate),
                layout=lay,
                meta={**outs[0].meta, "layout": lay.name},
            )

        if backend not in BACKENDS:
            raise ParameterError(f"backend must be one of {BACKENDS}, got {backend!r}")
        if not (isinstance(rate, int | np.integer) and 1000 <= rate <= 768000):
            raise ParameterError(f"rate must be an integer in [1000, 768000] Hz, got {rate!r}")
        if not math.isfinite(start):
            raise ParameterError(f"start must be a finite time in s, got {start!r}")
        lay = get_layout(layout)
        t_start = time.perf_counter()
        em = self.emissions(path, layout=lay, c0=c0)
        t_geo = time.perf_counter()
        if duration is None:
            duration = em.end_time + 0.01 - start
        if not (math.isfinite(duration) and duration > 0):
            raise ParameterError(f"duration must be a positive number of seconds, got {duration!r}")
        n = int(math.ceil(duration * rate))
        em.t_center = em.t_center - start
        audio = accumulate(em, lay.n_channels, n, rate=int(rate), c=c0)
        t_end = time.perf_counter()
        em.t_center = em.t_center + start
        dis = self.discharge
        meta = {
            "model": self.name,
            "segments": int(dis.n_segments),
            "main_segments": int(dis.seg_main.sum()),
            "emissions": int(em.t_center.size),
            "strokes": int(self.strokes.size),
            "stroke_times_s": self.strokes.tolist(),
            "first_arrival_s": float(em.t_center.min()),
            "last_arrival_s": float(em.t_center.max()),
            "wave_duration_s": float(em.end_time - em.t_center.min()),
            "clamped_segments": em.clamped,
            "geometry_s": t_geo - t_start,
            "waveform_s": t_end - t_geo,
            "rate": int(rate),
            "layout": lay.name,
            "c0": float(c0),
        }
        return Rendered(audio=audio, rate=int(rate), layout=lay, meta=meta)


def render_discharge(
    discharge: Discharge,
    listener: ListenerPath | NDArray[np.floating],
    *,
    params: WaveParams,
    rate: int = 44100,
    layout: str | Layout = "mono",
    strokes: NDArray[np.floating] | None = None,
    duration: float | None = None,
    t0: float = 0.0,
    seed: int = 0,
) -> Rendered:
    """The sound of ``discharge`` heard by ``listener`` (paper 002 §4.2.2–4.2.3).

    Renders a :class:`DischargePart` with the speed of sound ``params.c``.

    Parameters
    ----------
    discharge : Discharge tree.
    listener : ListenerPath or static (3,) position (m).
    params : WaveParams (r0, T0, p_s0, σ0, c, jitter, amplitude).
    rate : Hz.  layout : output layout name or Layout.
    strokes : (K,) s, stroke times (default: a single stroke at 0).
    duration : s of output (default: until the last wave has passed, +10 ms).
    t0 : s, playback time of the first stroke.  seed : T0 jitter seed.

    Returns
    -------
    Rendered with ``audio (n_channels, n_samples)`` in Pa.

    Examples
    --------
    >>> d = Discharge(np.array([[0, 0, 0], [0.002, 0, 0]]), [-1, 0], [True, True])
    >>> out = render_discharge(d, np.array([0.001, 0.5, 0.0]),
    ...                        params=WaveParams(r0=0.05, T0=30e-6, ps0=500.0), rate=192000)
    >>> out.audio.shape[0], round(out.meta["first_arrival_s"] * 1e3, 3)
    (1, 1.458)
    """
    st = np.zeros(1) if strokes is None else strokes
    part = DischargePart(discharge, params, st, t0=t0, seed=seed)
    return part.render_part(listener, rate=rate, layout=layout, duration=duration, c0=params.c)
