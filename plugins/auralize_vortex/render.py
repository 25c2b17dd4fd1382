"""Vortex sound with sound textures (paper 000 §6, Eq. 5, Fig. 4) as engine emitters.

The domain of a velocity time series is split into sound-source sub-volumes
(§4, Fig. 2a); each is a static point emitter at its centre whose emitted
pressure at 1 m is the texture read at the sub-volume's average speed:

    p(q, t) = Σ_i g(r_i) Q(u_i(t − r_i/c0), t − r_i/c0)        (Eq. 5)

This module builds the emitted signals ``Q(u_i(τ), τ)``
(:func:`vortex_emitters`); the retarded time, the distance law ``g``
(``1/r`` physical, Howe's far field, docs/design.md erratum; or the paper's
``1/r³``) and the panning are the engine's (:mod:`auralize.emitters`).
Details the paper leaves open, as implemented here:

* u_i is the mean speed |v| over the sub-volume's valid points at each step
  of the volume, linearly interpolated in (data) time (§6).  Above the largest
  texture speed u is clamped (§6); below the smallest the texture row is
  scaled by (u/u_min)⁴ (the compact vortex-sound law, so still air is silent)
  unless ``low_speed="clamp"``.  Between speeds the two rows are linearly
  blended.  Before the first step and after the last the speeds are held.
* the texture is played periodically with its ends cross-faded over
  ``blend`` seconds (§6: "the ends of the texture are blended"); every
  source starts at its own seeded random offset so the sources are mutually
  incoherent (a shared offset would sum them coherently and comb-filter).
* a sub-volume of edge L_i different from the texture box L_tex is rendered
  by similarity: amplitude × L_i/L_tex and time × L_tex/L_i (p ∝ u⁴L, f ∝ u/L).
* the emitted signals are sampled at ``oversample`` × the texture rate (the
  texture rows upsampled band-limited): by default 1 when every sub-volume
  is as large as the texture box, so that the emitters play the texture's
  own samples (integer offsets, nothing interpolated; the engine upsamples
  band-limited), and 4 otherwise, because the similarity time scaling reads
  between samples (linearly).  They span ``[−lead, duration]`` playback
  seconds with raised-cosine ramps of :data:`EDGE_FADE_S` at both ends, so a
  listener within ``lead × c0`` hears the flow from the first sample and a
  longer render does not click when the emission stops.
* optional maximum-pressure truncation ``limit_pa`` (§7, explosions): a
  property of the *received* pressure, so it is applied after the engine has
  summed and panned the sub-volumes (:class:`TruncatedEmitters`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.signal import resample_poly

from auralize.emitters import C0, Emitters, Sound, law_exponent
from auralize.errors import DataError, FieldError, ParameterError
from auralize.listener import ListenerPath
from auralize.runtime.jit import configure as _configure_numba
from auralize.spatial.layouts import Layout
from auralize.volume import TimeVolume
from auralize_vortex.texture import Texture

if TYPE_CHECKING:
    from auralize.emitters.synthesis import Rendered

_configure_numba()  # cache folder, OMP wait policy, compile notice

#: raised-cosine ramp (s) at both ends of the emitted signals
EDGE_FADE_S = 0.02


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
            f"{volume.field_names} (vector fields: {vectors or 'none'}); name the velocity "
            f"with --velocity-field NAME, or velocity_field=NAME in --model vortex:FILE:..."
        )
    if not volume.is_vector(name):
        raise DataError(
            f"{volume.source}: field {name!r} is a scalar; vortex sound needs a 3-component "
            f"velocity (m/s)"
        )
    return name


def block_mean(a: NDArray[np.floating], sub: SubVolumes) -> NDArray[np.float64]:
    """Mean of scalar frames ``(..., nz, ny, nx)`` over each sub-volume → ``(..., S)``.

    No-data points (NaN, outside a resampled mesh) are left out of the mean;
    a sub-volume without any valid point gets 0.
    """
    ex, ey, ez = sub.edges
    a = np.asarray(a, dtype=np.float64)
    lead = a.shape[:-3]
    ok = np.isfinite(a)

    def total(x: NDArray[np.float64]) -> NDArray[np.float64]:
        x = np.add.reduceat(x, ez[:-1], axis=-3)
        x = np.add.reduceat(x, ey[:-1], axis=-2)
        return np.add.reduceat(x, ex[:-1], axis=-1).reshape(*lead, -1)

    if ok.all():
        cnt = np.diff(ez)[:, None, None] * np.diff(ey)[None, :, None] * np.diff(ex)[None, None, :]
        return total(a) / cnt.ravel()
    n = total(ok.astype(np.float64))
    return np.divide(total(np.where(ok, a, 0.0)), n, out=np.zeros_like(n), where=n > 0)


def subvolume_speeds(
    volume: TimeVolume, sub: SubVolumes, field: str = "velocity"
) -> NDArray[np.float64]:
    """Average flow speed u_i of every sub-volume at every step, ``(T, S)`` m/s (§6).

    Frames are read one by one and reduced in batches of about 2²² points.
    """
    name = velocity_field_name(volume, field)
    T = volume.n_steps
    out = np.empty((T, sub.n_sources))
    batch = max(1, (1 << 22) // max(1, int(np.prod(volume.dims))))
    for n0 in range(0, T, batch):
        steps = range(n0, min(n0 + batch, T))
        v = np.stack([volume.frame(name, n) for n in steps])
        speed = np.sqrt(v[..., 0] ** 2 + v[..., 1] ** 2 + v[..., 2] ** 2)
        out[n0 : n0 + len(steps)] = block_mean(speed, sub)
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

    def lookup(
        self, u: NDArray[np.floating], pos: NDArray[np.floating], *, low_speed: str = "u4"
    ) -> NDArray[np.float64]:
        """Q(u, t) at speeds ``u`` and fractional sample positions ``pos`` (same shape)."""
        if low_speed not in ("u4", "clamp"):
            raise ParameterError(f"low_speed must be 'u4' or 'clamp', got {low_speed!r}")
        uu = np.ascontiguousarray(np.atleast_2d(np.asarray(u, dtype=np.float64)))
        pp = np.ascontiguousarray(np.broadcast_to(np.asarray(pos, dtype=np.float64), uu.shape))
        out = np.empty(uu.shape)
        _lookup(self.rows, self.speeds, uu, pp, low_speed == "u4", out)
        return out.reshape(np.shape(u))


@numba.njit(cache=True)
def _lookup(rows, speeds, u, pos, u4, out):  # type: ignore[no-untyped-def]  # noqa: PLR0917 (a compiled kernel: its arrays are its arguments)  # pragma: no cover
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


# ---------------------------------------------------------------- emitters
def _law(attenuation: str | float) -> str | float:
    """The engine's distance law for ``attenuation`` (checked, the error names the option)."""
    try:
        law_exponent(attenuation)
    except ParameterError:
        raise ParameterError(
            f"attenuation must be 'physical' (1/r), 'paper' (1/r³, Eq. 5) or an exponent in "
            f"[0, 6], got {attenuation!r}"
        ) from None
    return attenuation


def vortex_emitters(  # noqa: PLR0913 (keyword-only options)
    volume: TimeVolume,
    texture: Texture,
    *,
    block: int | tuple[int, int, int] = 5,
    attenuation: str | float = "physical",
    velocity_field: str = "velocity",
    low_speed: str = "u4",
    offsets: str = "random",
    seed: int = 0,
    blend: float = 0.05,
    time_scale: float = 1.0,
    oversample: int = 0,
    duration: float | None = None,
    lead: float = 0.5,
    radius: float = 0.05,
) -> Emitters:
    """The sub-volumes of a velocity time series as static emitters (§4, §6, Eq. 5).

    Parameters
    ----------
    volume : TimeVolume
        With a vector field ``velocity_field`` (m/s).
    texture : Texture
        Sound texture Q(u, t) (:mod:`auralize_vortex.texture`), Pa at 1 m.
    block : int or (3,) int
        Points per sub-volume edge.
    attenuation : "physical" (1/r), "paper" (1/r³, Eq. 5) or an exponent
        The engine's distance law for these emitters.
    low_speed : {"u4", "clamp"}
        Below the smallest texture speed: scale by (u/u_min)⁴ or clamp.
    offsets : {"random", "zero"}
        Per-source start offsets into the looped texture (seeded by ``seed``).
    blend : float
        Cross-fade of the texture's loop ends (s, §6).
    time_scale : float
        Playback seconds per data second: u_i follows data time
        ``t0 + τ / time_scale`` while the texture plays in playback time τ.
    oversample : int
        Emission rate = oversample × texture rate; 0: 1 when every
        sub-volume is as large as the texture box (its own samples are
        read), else 4 (the similarity scaling interpolates between samples).
    duration : float, optional
        Playback seconds of emission after 0 (default: the data's duration
        × ``time_scale``, the last frame lasting one frame interval, e.g.
        2 s for 60 frames at 30 Hz).
    lead : float
        Playback seconds of emission before 0 (first step's speeds): a
        listener up to ``lead × c0`` away hears the flow from the start.
    radius : float
        The engine clamps distances to this (m).

    Returns
    -------
    Emitters
        ``signals (S, n)`` Pa at 1 m from ``t0 = −lead`` (rounded down to a
        whole sample) at ``rate`` Hz,
        ``positions (S, 3)`` the sub-volume centres (m); ``meta`` holds
        ``speeds (T, S)`` m/s, ``subvolumes``, ``size_m (S,)`` and the
        texture's rate.
    """
    if not (math.isfinite(time_scale) and time_scale > 0):
        raise ParameterError(f"time_scale must be > 0 playback s per data s, got {time_scale!r}")
    if offsets not in ("random", "zero"):
        raise ParameterError(f"offsets must be 'random' or 'zero', got {offsets!r}")
    if not (isinstance(oversample, int | np.integer) and 0 <= oversample <= 64):
        raise ParameterError(
            f"oversample must be an integer in 0..64 (0 = auto), got {oversample!r}"
        )
    if not (math.isfinite(lead) and lead >= 0):
        raise ParameterError(f"lead must be >= 0 s, got {lead!r}")
    law = _law(attenuation)
    sub = split_subvolumes(volume, block)
    speeds = subvolume_speeds(volume, sub, velocity_field)
    if duration is None:
        T = volume.n_steps  # every frame lasts one mean frame interval, the last one too
        duration = float(volume.times[-1] - volume.times[0]) * T / max(T - 1, 1) * time_scale
        if not duration > 0:
            raise ParameterError(
                f"{volume.source}: the volume has a single time step; give the emission duration "
                f"(s) to play it for"
            )
    if not (math.isfinite(duration) and duration > 0):
        raise ParameterError(f"duration must be > 0 s, got {duration!r}")
    ratio = texture.box_m / sub.size_m  # similarity: time × L_tex/L_i, amplitude × L_i/L_tex
    if oversample == 0:
        oversample = 1 if np.allclose(ratio, 1.0, rtol=1e-9, atol=0) else 4
    looped = LoopedTexture.build(texture, up=int(oversample), blend=blend)
    R = looped.rate
    # whole emission samples before 0, so that τ·R is an integer: a sub-volume as large as
    # the texture box reads the texture's own samples, not linear blends of two (a low-pass)
    n_lead = int(math.ceil(lead * R - 1e-9))
    n_e = n_lead + int(math.ceil(duration * R)) + 1
    tau = (np.arange(n_e) - n_lead) / R  # playback time of emission
    t_data = volume.times[0] + tau / time_scale
    u = np.empty((sub.n_sources, n_e))
    for s in range(sub.n_sources):
        u[s] = np.interp(t_data, volume.times, speeds[:, s])
    rng = np.random.default_rng(seed)
    start = (
        rng.integers(0, looped.period, sub.n_sources).astype(np.float64)
        if offsets == "random"
        else np.zeros(sub.n_sources)
    )
    pos = start[:, None] + (tau[None, :] * R) * ratio[:, None]
    emitted = looped.lookup(u, pos, low_speed=low_speed) / ratio[:, None]
    nf = min(int(round(EDGE_FADE_S * R)), n_e // 2)
    if nf > 0:
        ramp = 0.5 - 0.5 * np.cos(np.pi * (np.arange(nf) + 0.5) / nf)
        emitted[:, :nf] *= ramp
        emitted[:, n_e - nf :] *= ramp[::-1]
    meta = {
        "speeds": speeds,
        "subvolumes": list(sub.shape),
        "size_m": sub.size_m,
        "texture_rate_hz": texture.rate,
        "band_hz": 0.5 * texture.rate * float(ratio.max()),
    }
    return Emitters(
        emitted, R, sub.centres, t0=-n_lead / R, radius=radius, law=law, name="vortex", meta=meta
    )


@dataclass
class TruncatedEmitters:
    """Emitters whose received pressure is truncated beyond ±``limit_pa`` Pa (§7).

    An engine part (``render_part``): the engine renders the emitters (its
    arrivals, distance law and panning), then every output channel is
    clipped, as a pressure limit of the received sound must be.
    """

    emitters: Emitters
    limit_pa: float
    name: str = "vortex"

    def end_time(self, path: ListenerPath, *, c0: float = C0) -> float:
        """Playback second (s) when the last emitted sample has reached the listener."""
        from auralize.scene.soundscene import part_end

        end = part_end(self.emitters, path, c0=c0)
        assert end is not None
        return end

    def render_part(
        self,
        path: ListenerPath,
        *,
        rate: int,
        layout: str | Layout,
        duration: float | None,
        start: float,
        c0: float,
        backend: str,
    ) -> Rendered:
        """Render with :func:`auralize.emitters.render_emitters`, then truncate."""
        from auralize.emitters import render_emitters

        r = render_emitters(
            self.emitters,
            path,
            rate=rate,
            layout=layout,
            duration=duration,
            start=start,
            c0=c0,
            backend=backend,
        )
        np.clip(r.audio, -self.limit_pa, self.limit_pa, out=r.audio)
        r.meta["limit_pa"] = self.limit_pa
        return r


def vortex_sound(
    volume: TimeVolume, texture: Texture, *, limit_pa: float | None = None, **kw: Any
) -> Sound:
    """What the vortex model emits: :func:`vortex_emitters` as an engine :class:`Sound`.

    ``limit_pa`` (Pa, §7) wraps the emitters in :class:`TruncatedEmitters`;
    ``kw`` go to :func:`vortex_emitters`.  ``meta`` is JSON-ready (model,
    paper, sub-volumes, texture, speed range).
    """
    if limit_pa is not None and not limit_pa > 0:
        raise ParameterError(f"limit_pa must be a positive pressure in Pa, got {limit_pa!r}")
    em = vortex_emitters(volume, texture, **kw)
    speeds = em.meta["speeds"]
    meta = {
        "model": "vortex",
        "paper": "000 §6, Eq. 5",
        "n_sources": em.n_emitters,
        "subvolumes": em.meta["subvolumes"],
        "block": kw.get("block", 5),
        "attenuation": em.law,
        "texture_speeds": texture.speeds.tolist(),
        "texture_rate_hz": texture.rate,
        "emit_rate_hz": em.rate,
        "speed_range_m_s": [float(speeds.min()), float(speeds.max())],
        "low_speed": kw.get("low_speed", "u4"),
        "offsets": kw.get("offsets", "random"),
        "seed": kw.get("seed", 0),
        "limit_pa": limit_pa,
    }
    part = em if limit_pa is None else TruncatedEmitters(em, float(limit_pa))
    return Sound(parts=[part], meta=meta, name="vortex")


# -------------------------------------------------------------------- render
def render_vortex(  # noqa: PLR0913 (keyword-only options)
    volume: TimeVolume,
    path: ListenerPath,
    texture: Texture,
    *,
    block: int = 5,
    rate: int = 44100,
    layout: str | Layout = "mono",
    duration: float | None = None,
    attenuation: str | float = "physical",
    c0: float = C0,
    velocity_field: str = "velocity",
    low_speed: str = "u4",
    offsets: str = "random",
    seed: int = 0,
    blend: float = 0.05,
    time_scale: float = 1.0,
    limit_pa: float | None = None,
    min_distance: float = 0.05,
    oversample: int = 0,
    backend: str = "auto",
) -> Rendered:
    """Render the vortex sound of a velocity time series along a listener path (§6, Eq. 5).

    :func:`vortex_sound` rendered by :func:`auralize.emitters.render_sound`, with
    the emission spanning exactly what the path can hear (from ``−D_max/c0``
    to the end of the render).

    Parameters
    ----------
    volume : TimeVolume with a vector field ``velocity_field`` (m/s).
    path : listener path (playback seconds).
    texture : sound texture Q(u, t) (:mod:`auralize_vortex.texture`).
    block : points per sub-volume edge.
    rate : output sample rate (Hz).
    layout : output layout (mono, stereo, ring8, 5.1, 7.1, JSON file).
    duration : playback seconds (default: the path's duration).
    attenuation : "physical" (1/r, default) or "paper" (1/r³, Eq. 5) or an exponent.
    offsets : "random" (seeded, one start offset per source) or "zero".
    time_scale : playback seconds per data second; u_i(t) follows data time
        ``t0 + t / time_scale`` while the texture plays in playback time.
    limit_pa : truncate the received pressure beyond ±limit_pa Pa (§7), None = off.
    min_distance : distances are clamped here (m).
    oversample : emission rate = oversample × texture rate (0: auto, see
        :func:`vortex_emitters`).
    backend : the engine's backend ("auto" or "reference").

    Returns
    -------
    Rendered
        ``audio (n_channels, n)`` in Pa; ``meta`` the model's (sub-volumes,
        texture, speed range) and the engine's (``parts``, ``c0``).

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
    from auralize.rendering import render

    if not (isinstance(rate, int | np.integer) and 1000 <= rate <= 384000):
        raise ParameterError(f"rate must be an integer in 1000..384000 Hz, got {rate!r}")
    if not (math.isfinite(c0) and c0 > 0):
        raise ParameterError(f"c0 must be a positive speed in m/s, got {c0!r}")
    dur = path.duration if duration is None else float(duration)
    if not (math.isfinite(dur) and dur > 0):
        raise ParameterError(f"duration must be > 0 s, got {dur!r}")
    sub = split_subvolumes(volume, block)
    # emission starts early enough to be heard anywhere along the path: the path lies
    # inside the bounding box of its captures, so this bounds every distance
    c_lo, c_hi = sub.centres.min(0), sub.centres.max(0)
    p_lo, p_hi = path.positions.min(0), path.positions.max(0)
    dmax = float(np.linalg.norm(np.maximum(c_hi - p_lo, p_hi - c_lo)))
    sound = vortex_sound(
        volume,
        texture,
        block=block,
        attenuation=attenuation,
        velocity_field=velocity_field,
        low_speed=low_speed,
        offsets=offsets,
        seed=seed,
        blend=blend,
        time_scale=time_scale,
        oversample=oversample,
        duration=dur + EDGE_FADE_S + 0.01,
        lead=dmax / c0 + EDGE_FADE_S + 0.01,
        radius=min_distance,
        limit_pa=limit_pa,
    )
    return render(sound, path, rate=int(rate), layout=layout, duration=dur, c0=c0, backend=backend)
