"""Fast rendering of vortex sound with sound textures (paper 000 §6, Eq. 5, Fig. 4).

The domain of a velocity time series is split into sound-source sub-volumes
(§4, Fig. 2a); each is a point source at its centre whose emitted pressure at
1 m is the texture read at the sub-volume's average speed:

    p(q, t) = Σ_i g(r_i) Q(u_i(t − r_i/c0), t − r_i/c0)        (Eq. 5)

with ``g = 1/r`` (physical, Howe's far field; DESIGN.md erratum) or the
paper's ``1/r³``.  Details the paper leaves open, as implemented here:

* u_i is the mean speed |v| over the sub-volume's points at each step of the
  volume, linearly interpolated in (data) time (§6).  Above the largest
  texture speed u is clamped (§6); below the smallest the texture row is
  scaled by (u/u_min)⁴ (the compact vortex-sound law, so still air is silent)
  unless ``low_speed="clamp"``.  Between speeds the two rows are linearly
  blended.
* the texture is played periodically with its ends cross-faded over
  ``blend`` seconds (§6: "the ends of the texture are blended"); every
  source starts at its own seeded random offset so the sources are mutually
  incoherent (a shared offset would sum them coherently and comb-filter).
* a sub-volume of edge L_i different from the texture box L_tex is rendered
  by similarity: amplitude × L_i/L_tex and time × L_tex/L_i (p ∝ u⁴L, f ∝ u/L).
* propagation: retarded time, distance law and pairwise VBAP exactly as
  :func:`auralize.propagation.propagate` (same core functions), but evaluated
  at an intermediate rate (4 × the texture rate; the texture holds nothing
  above its Nyquist frequency) with the panning gains at a 200 Hz control
  rate, then resampled band-limited to the output rate.  This is what makes
  rendering ≥ 50× faster than real time (propagate itself renders 36 sources
  to ring8 at about 2× real time at 44.1 kHz).
* optional maximum-pressure truncation ``limit_pa`` (§7, explosions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.signal import resample_poly

from auralize._numba_setup import configure as _configure_numba
from auralize.errors import DataError, FieldError, ParameterError
from auralize.listener import ListenerPath
from auralize.propagation import distance_gain
from auralize.spatial import Layout, get_layout, listener_frame_azimuth, vbap_gains
from auralize.volume import TimeVolume
from auralize_vortex.texture import C0, Texture

_configure_numba()  # cache folder, OMP wait policy, compile notice

CONTROL_RATE_HZ = 200.0


# ------------------------------------------------------------- sub-volumes
@dataclass
class SubVolumes:
    """Sound-source sub-volumes of a grid (§4).

    ``edges[a]`` are the point-index boundaries along axis a (x, y, z), so the
    sub-volume (ix, iy, iz) holds points ``edges[0][ix]:edges[0][ix+1]`` etc.
    ``centres (S, 3)`` in m, ``size_m (S,)`` cube-equivalent edge in m,
    ``shape (Sz, Sy, Sx)``; sources are numbered in C order of that shape.
    """

    edges: tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]
    centres: NDArray[np.float64]
    size_m: NDArray[np.float64]
    extent_m: NDArray[np.float64]

    @property
    def shape(self) -> tuple[int, int, int]:
        return (len(self.edges[2]) - 1, len(self.edges[1]) - 1, len(self.edges[0]) - 1)

    @property
    def n_sources(self) -> int:
        return int(np.prod(self.shape))


def split_subvolumes(volume: TimeVolume, block: int | tuple[int, int, int]) -> SubVolumes:
    """Split the grid into sub-volumes of about ``block`` points per axis (§4, Fig. 2a).

    Each axis of n points is cut into ``max(1, round(n / block))`` nearly equal parts.
    """
    b = np.broadcast_to(np.asarray(block), (3,))
    if not np.all(np.equal(np.mod(b, 1), 0)) or np.any(b < 1):
        raise ParameterError(f"block must be a positive integer (points per edge), got {block!r}")
    edges = []
    for a in range(3):
        n = volume.dims[a]
        parts = max(1, round(n / int(b[a])))
        edges.append(np.linspace(0, n, parts + 1).round().astype(np.int64))
    ax = volume.axis_coords()
    ctr, ext = [], []
    for a in range(3):
        e = edges[a]
        lo, hi = e[:-1], e[1:]
        ctr.append(0.5 * (ax[a][lo] + ax[a][hi - 1]))
        ext.append((hi - lo) * volume.spacing[a])
    cz, cy, cx = np.meshgrid(ctr[2], ctr[1], ctr[0], indexing="ij")
    ez, ey, ex = np.meshgrid(ext[2], ext[1], ext[0], indexing="ij")
    centres = np.stack([cx.ravel(), cy.ravel(), cz.ravel()], axis=1)
    extent = np.stack([ex.ravel(), ey.ravel(), ez.ravel()], axis=1)
    return SubVolumes(tuple(edges), centres, np.cbrt(np.prod(extent, axis=1)), extent)  # type: ignore[arg-type]


def velocity_field_name(volume: TimeVolume, name: str = "velocity") -> str:
    """Check that ``volume`` has a vector field ``name`` (errors name what is available)."""
    if name not in volume.fields:
        vectors = [k for k in volume.fields if volume.is_vector(k)]
        raise FieldError(
            f"{volume.source}: vortex sound needs a velocity field {name!r}; the volume has "
            f"{volume.field_names} (vector fields: {vectors or 'none'})"
        )
    if not volume.is_vector(name):
        raise DataError(
            f"{volume.source}: field {name!r} is a scalar; vortex sound needs a 3-component "
            f"velocity (m/s)"
        )
    return name


def block_mean(a: NDArray[np.floating], sub: SubVolumes) -> NDArray[np.float64]:
    """Mean of a scalar frame ``(nz, ny, nx)`` over each sub-volume → ``(S,)``."""
    ex, ey, ez = sub.edges
    s = np.add.reduceat(np.asarray(a, dtype=np.float64), ez[:-1], axis=0)
    s = np.add.reduceat(s, ey[:-1], axis=1)
    s = np.add.reduceat(s, ex[:-1], axis=2)
    cnt = np.diff(ez)[:, None, None] * np.diff(ey)[None, :, None] * np.diff(ex)[None, None, :]
    return (s / cnt).ravel()


def subvolume_speeds(
    volume: TimeVolume, sub: SubVolumes, field: str = "velocity"
) -> NDArray[np.float64]:
    """Average flow speed u_i of every sub-volume at every step, ``(T, S)`` m/s (§6)."""
    name = velocity_field_name(volume, field)
    out = np.empty((volume.n_steps, sub.n_sources))
    for n in range(volume.n_steps):
        v = volume.frame(name, n)
        out[n] = block_mean(np.sqrt(np.einsum("...i,...i->...", v, v)), sub)
    return out


# ------------------------------------------------------------ texture lookup
@dataclass
class LoopedTexture:
    """A texture upsampled to ``rate`` and made periodic with cross-faded ends (§6)."""

    speeds: NDArray[np.float64]
    rows: NDArray[np.float64]  # (U, period)
    rate: float

    @classmethod
    def build(cls, tex: Texture, *, up: int, blend: float) -> LoopedTexture:
        rows = resample_poly(tex.pressure, up, 1, axis=1) if up > 1 else tex.pressure.copy()
        rate = tex.rate * up
        n = rows.shape[1]
        nb = int(round(blend * rate))
        if not 0 <= nb <= n // 2:
            raise ParameterError(
                f"blend {blend} s must be between 0 and half the texture ({tex.duration / 2:g} s)"
            )
        if nb > 0:
            # equal-power cross-fade: the rows are noise-like, so the blended part keeps the power
            ramp = (np.arange(nb) + 0.5) / nb
            head = rows[:, :nb] * np.sqrt(ramp) + rows[:, n - nb :] * np.sqrt(1 - ramp)
            rows = np.concatenate([head, rows[:, nb : n - nb]], axis=1)
        return cls(np.asarray(tex.speeds), np.ascontiguousarray(rows), rate)

    @property
    def period(self) -> int:
        return int(self.rows.shape[1])

    def lookup(self, u: NDArray[np.floating], pos: NDArray[np.floating], *,
               low_speed: str = "u4") -> NDArray[np.float64]:  # fmt: skip
        """Q(u, t) at speeds ``u`` and fractional sample positions ``pos`` (same shape)."""
        if low_speed not in ("u4", "clamp"):
            raise ParameterError(f"low_speed must be 'u4' or 'clamp', got {low_speed!r}")
        uu = np.ascontiguousarray(np.atleast_2d(np.asarray(u, dtype=np.float64)))
        pp = np.ascontiguousarray(np.broadcast_to(np.asarray(pos, dtype=np.float64), uu.shape))
        out = np.empty(uu.shape)
        _lookup(self.rows, self.speeds, uu, pp, low_speed == "u4", out)
        return out.reshape(np.shape(u))


@numba.njit(cache=True)
def _lookup(rows, speeds, u, pos, u4, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    """Bilinear texture read: speed rows blended linearly, time linearly, periodic in time."""
    U, period = rows.shape
    S, n = u.shape
    for s in range(S):
        for m in range(n):
            us = u[s, m]
            uc = min(max(us, speeds[0]), speeds[U - 1])
            j = 0
            while j < U - 2 and speeds[j + 1] <= uc:
                j += 1
            a = 0.0
            if U > 1:
                a = min(max((uc - speeds[j]) / (speeds[j + 1] - speeds[j]), 0.0), 1.0)
            p = pos[s, m] % period
            i0 = int(p)
            if i0 >= period:
                i0 = period - 1
            f = p - i0
            i1 = i0 + 1 if i0 + 1 < period else 0
            q = rows[j, i0] * (1 - f) + rows[j, i1] * f
            if U > 1:
                q = q * (1 - a) + (rows[j + 1, i0] * (1 - f) + rows[j + 1, i1] * f) * a
            if u4 and us < speeds[0]:
                r = max(us, 0.0) / speeds[0]
                q *= r * r * r * r
            out[s, m] = q


# -------------------------------------------------------------- propagation
@numba.njit(cache=True, fastmath=False)
def _receive(emis, emit_t0, emit_rate, src, lis, t, c0, exponent, dmin, pan, ctrl_step,
             out, per_src):  # type: ignore[no-untyped-def]  # pragma: no cover - numba  # fmt: skip
    """Retarded-time sum of static sources at a moving listener (see module docstring)."""
    S, n_e = emis.shape
    n = t.size
    n_ch = out.shape[0]
    keep = per_src.shape[0] == S
    for s in range(S):
        for m in range(n):
            dx = src[s, 0] - lis[m, 0]
            dy = src[s, 1] - lis[m, 1]
            dz = src[s, 2] - lis[m, 2]
            D = math.sqrt(dx * dx + dy * dy + dz * dz)
            if D < dmin:
                D = dmin
            x = (t[m] - D / c0 - emit_t0) * emit_rate
            if x < 0.0 or x > n_e - 1:
                continue
            i0 = int(x)
            if i0 >= n_e - 1:
                i0 = n_e - 2
            f = x - i0
            if exponent == 1.0:
                gain = 1.0 / D
            elif exponent == 3.0:
                gain = 1.0 / (D * D * D)
            else:
                gain = D ** (-exponent)
            val = (emis[s, i0] * (1 - f) + emis[s, i0 + 1] * f) * gain
            if keep:
                per_src[s, m] = val
            c = m / ctrl_step
            k0 = int(c)
            g = c - k0
            for ch in range(n_ch):
                out[ch, m] += val * (pan[s, k0, ch] * (1 - g) + pan[s, k0 + 1, ch] * g)


def attenuation_exponent(attenuation: str | float) -> float:
    """Distance-law exponent: ``"physical"`` 1, ``"paper"`` 3 (Eq. 5), or a number."""
    d = distance_gain(np.array([2.0]), attenuation)[0]  # validates like the core
    return float(-math.log2(d))


def receive(signals: NDArray[np.floating], emit_rate: float, positions: NDArray[np.floating],
            path: ListenerPath, *, rate: float, duration: float | None = None,
            emit_t0: float = 0.0, c0: float = C0, attenuation: str | float = "physical",
            min_distance: float = 0.05, layout: str | Layout = "mono",
            per_source: bool = False) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:  # fmt: skip
    """Static sources heard along ``path``: same physics as :func:`auralize.propagation.propagate`.

    Parameters
    ----------
    signals : (S, n_emit) emitted pressure (Pa at 1 m) sampled at ``emit_rate`` from ``emit_t0``.
    positions : (S, 3) m.
    rate : output rate (Hz) of this evaluation.
    per_source : also return the per-source received signals ``(S, n)`` (mono, no panning).

    Returns
    -------
    (audio (n_channels, n), per_source (S, n) or None)
    """
    sig = np.ascontiguousarray(np.atleast_2d(np.asarray(signals, dtype=np.float64)))
    pos = np.ascontiguousarray(np.asarray(positions, dtype=np.float64).reshape(-1, 3))
    if pos.shape[0] != sig.shape[0]:
        raise ParameterError(f"{sig.shape[0]} signals but {pos.shape[0]} positions")
    lay = get_layout(layout)
    dur = path.duration if duration is None else float(duration)
    n = round(dur * rate)
    t = np.arange(n) / rate
    lis = path.position_at(path.times[0] + t) if n else np.zeros((0, 3))
    step = max(1, int(round(rate / CONTROL_RATE_HZ)))
    n_ctrl = n // step + 2
    tc = path.times[0] + np.arange(n_ctrl) * step / rate
    S = pos.shape[0]
    if lay.n_channels == 1:
        pan = np.ones((S, n_ctrl, 1))
    else:
        lc = path.position_at(tc)
        fwd, up = path.orientation_at(tc)
        d = pos[:, None, :] - lc[None]  # (S, n_ctrl, 3)
        az = listener_frame_azimuth(d.reshape(-1, 3), np.tile(fwd, (S, 1)), np.tile(up, (S, 1)))
        pan = vbap_gains(lay, az).T.reshape(S, n_ctrl, lay.n_channels)
    out = np.zeros((lay.n_channels, n))
    per = np.zeros((S, n)) if per_source else np.zeros((0, 0))
    _receive(sig, float(emit_t0), float(emit_rate), pos, np.ascontiguousarray(lis), t, float(c0),
             attenuation_exponent(attenuation), float(min_distance), np.ascontiguousarray(pan),
             float(step), out, per)  # fmt: skip
    return out, (per if per_source else None)


# -------------------------------------------------------------------- render
@dataclass
class VortexRender:
    """Result of :func:`render_vortex`."""

    audio: NDArray[np.float64]  # (n_channels, n) Pa
    rate: int
    layout: Layout
    per_source: NDArray[np.float64] | None  # (S, n) Pa received from each sub-volume
    positions: NDArray[np.float64]  # (S, 3) m
    emitted: NDArray[np.float64]  # (S, n_emit) Pa at 1 m
    emit_rate: float
    emit_t0: float
    speeds: NDArray[np.float64]  # (T, S) m/s
    meta: dict[str, Any]

    @property
    def duration(self) -> float:
        return self.audio.shape[1] / self.rate


def _resample(x: NDArray[np.float64], src: float, dst: int, pad: int, n_out: int,
              band_hz: float) -> NDArray[np.float64]:  # fmt: skip
    """Band-limited resampling of ``(C, n)`` from rate ``src`` to ``dst``; drops ``pad`` input samples.

    The signal holds nothing above ``band_hz`` (the texture's Nyquist
    frequency), so the anti-imaging filter only needs to stop from
    ``src − band_hz``: a Kaiser FIR with 80 dB attenuation over that wide
    transition band is several times shorter than ``resample_poly``'s default.
    """
    from scipy.signal import firwin, kaiserord

    if float(src) == float(dst):
        y = x[:, pad:]
    else:
        g = math.gcd(int(round(src)), int(dst))
        up, down = int(dst) // g, int(round(src)) // g
        fs = up * float(src)
        stop = min(float(src), float(dst)) - band_hz
        width = max(stop - band_hz, 0.05 * src)
        numtaps, beta = kaiserord(80.0, width / (0.5 * fs))
        numtaps += 1 - numtaps % 2  # odd: centred
        h = firwin(numtaps, band_hz + 0.5 * width, fs=fs, window=("kaiser", beta))
        y = resample_poly(x, up, down, axis=1, window=h)
        y = y[:, (pad * up) // down :]
    if y.shape[1] < n_out:
        y = np.pad(y, ((0, 0), (0, n_out - y.shape[1])))
    return y[:, :n_out]


def render_vortex(volume: TimeVolume, path: ListenerPath, texture: Texture, *,
                  block: int = 5, rate: int = 44100, layout: str | Layout = "mono",
                  duration: float | None = None, attenuation: str | float = "physical",
                  c0: float = C0, velocity_field: str = "velocity", low_speed: str = "u4",
                  offsets: str = "random", seed: int = 0, blend: float = 0.05,
                  time_scale: float = 1.0, limit_pa: float | None = None,
                  min_distance: float = 0.05, oversample: int = 4,
                  per_source: bool = False) -> VortexRender:  # fmt: skip
    """Render the vortex sound of a velocity time series along a listener path (§6, Eq. 5).

    Parameters
    ----------
    volume : TimeVolume with a vector field ``velocity_field`` (m/s).
    path : listener path (playback seconds).
    texture : sound texture Q(u, t) (:mod:`auralize_vortex.texture`).
    block : points per sub-volume edge.
    layout : output layout (mono, stereo, ring8, 5.1, 7.1, JSON file).
    attenuation : "physical" (1/r, default) or "paper" (1/r³, Eq. 5) or an exponent.
    offsets : "random" (seeded, one start offset per source) or "zero".
    time_scale : playback seconds per data second; u_i(t) follows data time
        ``t0 + t / time_scale`` while the texture plays in playback time.
    limit_pa : truncate the output beyond ±limit_pa Pa (§7), None = off.
    oversample : intermediate rate = oversample × texture rate (capped at ``rate``).

    Returns
    -------
    VortexRender with ``audio (n_channels, n)`` in Pa.

    Examples
    --------
    >>> from auralize_vortex.datasets import make_fire_plume
    >>> from auralize_vortex.texture import Texture
    >>> tex = Texture([1.0, 2.0], np.random.default_rng(0).normal(size=(2, 500)), 1000.0, 0.2)
    >>> vol = make_fire_plume(size=6, steps=4)
    >>> r = render_vortex(vol, ListenerPath.point((0.1, -1, 0.1), duration=0.2), tex, rate=8000)
    >>> r.audio.shape
    (1, 1600)
    """
    if not (isinstance(rate, int | np.integer) and 1000 <= rate <= 384000):
        raise ParameterError(f"rate must be an integer in 1000..384000 Hz, got {rate!r}")
    if not c0 > 0 or not time_scale > 0:
        raise ParameterError(f"c0 and time_scale must be positive, got {c0!r}, {time_scale!r}")
    if offsets not in ("random", "zero"):
        raise ParameterError(f"offsets must be 'random' or 'zero', got {offsets!r}")
    if limit_pa is not None and not limit_pa > 0:
        raise ParameterError(f"limit_pa must be a positive pressure in Pa, got {limit_pa!r}")
    lay = get_layout(layout)
    sub = split_subvolumes(volume, block)
    speeds = subvolume_speeds(volume, sub, velocity_field)
    up = max(1, min(int(oversample), int(rate // texture.rate)))
    looped = LoopedTexture.build(texture, up=up, blend=blend)
    R = looped.rate
    dur = path.duration if duration is None else float(duration)
    if not dur > 0:
        raise ParameterError(f"duration must be > 0 s, got {dur!r}")
    # emission times cover every retarded time the listener can hear
    lp = path.position_at(np.linspace(path.times[0], path.times[-1], 64))
    dmax = float(np.max(np.linalg.norm(sub.centres[:, None] - lp[None], axis=-1)))
    emit_t0 = -(dmax / c0) - 0.01
    n_e = int(math.ceil((dur - emit_t0) * R)) + 2
    tau = emit_t0 + np.arange(n_e) / R  # playback time of emission
    t_data = volume.times[0] + tau / time_scale
    u = np.empty((sub.n_sources, n_e))
    for s in range(sub.n_sources):
        u[s] = np.interp(t_data, volume.times, speeds[:, s])
    rng = np.random.default_rng(seed)
    start = (
        rng.uniform(0, looped.period, sub.n_sources)
        if offsets == "random"
        else np.zeros(sub.n_sources)
    )
    ratio = texture.box_m / sub.size_m  # similarity: time × L_tex/L_i, amplitude × L_i/L_tex
    pos = start[:, None] + (tau[None, :] * R) * ratio[:, None]
    emitted = looped.lookup(u, pos, low_speed=low_speed) / ratio[:, None]
    # propagate at R with a pad so that the band-limited resampling has no edge transient
    g = math.gcd(int(round(R)), int(rate))
    down = int(round(R)) // g
    pad = down * int(math.ceil(64 / down))
    shifted = ListenerPath(np.concatenate([[path.times[0] - pad / R], path.times]),
                           np.concatenate([path.positions[:1], path.positions]),
                           np.concatenate([path.forward[:1], path.forward]),  # type: ignore[index]
                           np.concatenate([path.up[:1], path.up]), source=path.source)  # type: ignore[index]  # fmt: skip
    n_out = round(dur * rate)
    out, per = receive(emitted, R, sub.centres, shifted, rate=R, duration=dur + pad / R + 64 / R,
                       emit_t0=emit_t0 + pad / R, c0=c0, attenuation=attenuation,
                       min_distance=min_distance, layout=lay, per_source=per_source)  # fmt: skip
    band = 0.5 * texture.rate / min(ratio.min(), 1.0)  # the texture's Nyquist, after similarity
    band = min(band, 0.45 * R)
    audio = _resample(out, R, int(rate), pad, n_out, band)
    per_out = _resample(per, R, int(rate), pad, n_out, band) if per is not None else None
    if limit_pa is not None:
        audio = np.clip(audio, -limit_pa, limit_pa)
    meta = {
        "model": "vortex", "paper": "000 §6, Eq. 5", "n_sources": sub.n_sources,
        "subvolumes": list(sub.shape), "block": block, "attenuation": attenuation,
        "texture_speeds": texture.speeds.tolist(), "texture_rate_hz": texture.rate,
        "intermediate_rate_hz": R, "speed_range_m_s": [float(speeds.min()), float(speeds.max())],
        "low_speed": low_speed, "offsets": offsets, "seed": seed, "limit_pa": limit_pa,
    }  # fmt: skip
    return VortexRender(
        audio, int(rate), lay, per_out, sub.centres, emitted, R, emit_t0, speeds, meta
    )
