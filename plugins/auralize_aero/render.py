"""Real-time rendering of aerodynamic sound from sound textures (paper 004 §6, Eqs. 3–4).

For every point source l (:meth:`AeroObject.sources`):

* its velocity relative to the air, ``u = wind - v_source`` (§4, Fig. 3c),
  gives by property 3 of §5.1 the effective speed ``v cos φ`` (the component
  perpendicular to the object's axis n; φ is the angle between the flow and
  the plane normal to n — the paper's "angle between n and c" must be read
  this way, since a flow along the axis sheds nothing) and the projected
  direction c' (angle θ in the section frame);
* Eq. 3: the texture coordinate advances as ``s_k = s_{k-1} + (v/v0) Δt``,
  and ``g_l = (v/v0)^e w(s_k, c')`` with the amplitude exponent e = 3 for the
  pressure law (DESIGN.md; ``"physical"``) or the paper's e = 6
  (``"paper"``).  Directions between samples are interpolated linearly;
  the texture loops (its ends are blended when it is made);
* Eq. 4 / Eq. 1: ``p(q, t) = Σ_l (q - o_l) · g_l(τ_l) Δh_l / (4π c0 r_l²)``
  with the retarded time τ_l solving ``τ = t - |q(t) - o_l(τ)| / c0`` — so
  the Doppler shift of moving sources comes out of the evaluation; before
  the sound arrives (τ < 0) g = 0.  A 10 ms fade-in at τ = 0 replaces the
  paper's "object static at t = 0" start.

Smooth quantities (retarded time, distances, projections, texture
coordinate, panning gains) are evaluated every ``block`` samples in numpy
and interpolated linearly; the per-sample texture look-up and sum is a
numba loop.  Stereo uses two receivers at the ears (§6); other layouts pan
each source from its direction with the output layer's VBAP
(:func:`auralize.spatial.vbap_gains`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline

from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.spatial import Layout, get_layout, listener_frame_azimuth, vbap_gains

from .objects import AeroObject, Motion, Wind, quat_to_matrix
from .texture import SoundTexture

C0 = 343.0
EXPONENTS = {"physical": 3.0, "paper": 6.0}


def resolve_exponent(exponent: str | float) -> float:
    """``"physical"`` → 3 (pressure ∝ v³), ``"paper"`` → 6 (Eq. 3 as printed), or a number."""
    if isinstance(exponent, str):
        if exponent in EXPONENTS:
            return EXPONENTS[exponent]
        try:
            return float(exponent)
        except ValueError:
            raise ParameterError(
                f"exponent must be 'physical', 'paper' or a number, got {exponent!r}"
            ) from None
    e = float(exponent)
    if not math.isfinite(e):
        raise ParameterError(f"exponent must be finite, got {exponent!r}")
    return e


@dataclass
class Kinematics:
    """Per-source quantities on a uniform emission-time grid ``t = j · dt`` (j < J).

    pos (S, J, 3) m; e1, e2 (S, J, 3) unit section axes; c1, c2 (S, J) the
    flow direction's components along e1, e2; speed (S, J) = v cos φ / v0;
    s (S, J) texture time (s); span (S,) Δh (m).
    """

    dt: float
    pos: NDArray[np.float64]
    e1: NDArray[np.float64]
    e2: NDArray[np.float64]
    c1: NDArray[np.float64]
    c2: NDArray[np.float64]
    speed: NDArray[np.float64]
    s: NDArray[np.float64]
    span: NDArray[np.float64]


def _apply(R: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Matrices ``R (J, 3, 3)`` applied to vectors ``v (S, 3)`` -> ``(S, J, 3)``."""
    return np.ascontiguousarray(np.matmul(R, v.T).transpose(2, 0, 1))


def kinematics(obj: AeroObject, v0: float, *, motion: Motion | None, wind: Wind | None,
               dt: float, duration: float) -> Kinematics:  # fmt: skip
    """Source kinematics and the texture-coordinate recurrence of Eq. 3 (§6)."""
    if motion is None and wind is None:
        raise ParameterError("give a motion (object moving) or a wind (static object), or both")
    centres, span, axes, refs = obj.sources()
    S = centres.shape[0]
    J = int(math.ceil(duration / dt)) + 3
    t = np.arange(J) * dt
    if motion is not None:
        # spline the pose (origin and rotation matrix: 12 components), then place the sources
        tm = motion.times
        tc = np.clip(t, tm[0], tm[-1])
        moving = ((t >= tm[0]) & (t <= tm[-1])).astype(np.float64)
        R = quat_to_matrix(motion.quaternions).reshape(-1, 9)
        spl = CubicSpline(tm, np.concatenate([motion.positions, R], 1), axis=0)
        v = spl(tc)
        dv = spl(tc, 1) * moving[:, None]
        Rt = v[:, 3:].reshape(J, 3, 3)
        dRt = dv[:, 3:].reshape(J, 3, 3)
        pos = v[None, :, :3] + _apply(Rt, centres)
        vel = dv[None, :, :3] + _apply(dRt, centres)
        n = _apply(Rt, axes)
        e = _apply(Rt, refs)
    else:
        pos = np.broadcast_to(centres[:, None], (S, J, 3)).copy()
        vel = np.zeros((S, J, 3))
        n = np.broadcast_to(axes[:, None], (S, J, 3)).copy()
        e = np.broadcast_to(refs[:, None], (S, J, 3)).copy()
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    e -= np.sum(e * n, 2, keepdims=True) * n
    e /= np.linalg.norm(e, axis=2, keepdims=True)
    e2 = np.cross(n, e)
    u = -vel
    if wind is not None:
        u = u + wind.velocities(S, t)
    u_perp = u - np.sum(u * n, 2, keepdims=True) * n  # property 3 (§5.1, Fig. 5)
    vp = np.linalg.norm(u_perp, axis=2)
    safe = np.where(vp > 1e-12, vp, 1.0)
    c1 = np.where(vp > 1e-12, np.sum(u_perp * e, 2) / safe, 1.0)
    c2 = np.where(vp > 1e-12, np.sum(u_perp * e2, 2) / safe, 0.0)
    a = vp / v0
    s = np.concatenate([np.zeros((S, 1)), np.cumsum(0.5 * (a[:, 1:] + a[:, :-1]) * dt, axis=1)], 1)
    return Kinematics(dt, pos, e, e2, c1, c2, a, s, span)


@numba.njit(cache=True)
def _interp_rows(arr: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """``arr (S, J, C)`` at fractional indices ``x (S, B)`` (clamped) -> ``(S, B, C)``."""
    S, J, C = arr.shape
    B = x.shape[1]
    out = np.empty((S, B, C))
    for k in range(S):
        for b in range(B):
            v = min(max(x[k, b], 0.0), J - 1.000001)
            i = int(v)
            w = v - i
            for c in range(C):
                out[k, b, c] = arr[k, i, c] + w * (arr[k, i + 1, c] - arr[k, i, c])
    return out


def _at(arr: NDArray[np.float64], tau: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
    """Linear interpolation of ``arr (S, J[, C])`` at per-source times ``tau (S, B)``."""
    if arr.ndim == 2:
        return _interp_rows(np.ascontiguousarray(arr[..., None]), tau / dt)[..., 0]
    return _interp_rows(np.ascontiguousarray(arr), tau / dt)


@numba.njit(cache=True)
def _synth(out: NDArray[np.float64], tex: NDArray[np.float64], lengths: NDArray[np.int64],
           tex_rate: float, s: NDArray[np.float64], qs: NDArray[np.float64], qe: NDArray[np.float64],
           j0: NDArray[np.int64], j1: NDArray[np.int64], wj: NDArray[np.float64],
           gain: NDArray[np.float64], K: int) -> None:  # fmt: skip
    """Σ_l Q_l(t) · w(s_l(t)) with per-block linear interpolation, accumulated into out (C, n).

    The texture position advances by a constant step within a block and
    wraps around the loop length (the texture is periodic, §6).
    """
    C, n_out = out.shape
    S, B = j0.shape
    inv = 1.0 / K
    for b in range(B):
        n0 = b * K
        if n0 >= n_out:
            continue
        for k in range(S):
            qa0 = qs[k, b, 0]
            qa1 = qs[k, b, 1]
            dq0 = (qe[k, b, 0] - qa0) * inv
            dq1 = (qe[k, b, 1] - qa1) * inv
            if qa0 == 0.0 and qa1 == 0.0 and dq0 == 0.0 and dq1 == 0.0:
                continue
            ja = j0[k, b]
            jb = j1[k, b]
            w = wj[k, b]
            Na = lengths[ja]
            Nb = lengths[jb]
            s0 = s[k, b] * tex_rate
            ds = (s[k, b + 1] - s[k, b]) * tex_rate * inv
            pa = s0 - math.floor(s0 / Na) * Na
            pb = s0 - math.floor(s0 / Nb) * Nb
            m = min(K, n_out - n0)
            for i in range(m):
                ia = int(pa)
                if ia >= Na:
                    ia = Na - 1
                fa = pa - ia
                ia1 = ia + 1 if ia + 1 < Na else 0
                g0 = tex[ja, ia, 0]
                g1 = tex[ja, ia, 1]
                gx = g0 + fa * (tex[ja, ia1, 0] - g0)
                gy = g1 + fa * (tex[ja, ia1, 1] - g1)
                if w > 0.0:
                    ib = int(pb)
                    if ib >= Nb:
                        ib = Nb - 1
                    fb = pb - ib
                    ib1 = ib + 1 if ib + 1 < Nb else 0
                    h0 = tex[jb, ib, 0]
                    h1 = tex[jb, ib, 1]
                    gx += w * (h0 + fb * (tex[jb, ib1, 0] - h0) - gx)
                    gy += w * (h1 + fb * (tex[jb, ib1, 1] - h1) - gy)
                p = (qa0 + dq0 * i) * gx + (qa1 + dq1 * i) * gy
                if C == 1:
                    out[0, n0 + i] += p
                else:
                    fr = i * inv
                    for c in range(C):
                        out[c, n0 + i] += (
                            gain[k, b, c] + fr * (gain[k, b + 1, c] - gain[k, b, c])
                        ) * p
                pa += ds
                if pa >= Na:
                    pa -= Na
                elif pa < 0.0:
                    pa += Na
                pb += ds
                if pb >= Nb:
                    pb -= Nb
                elif pb < 0.0:
                    pb += Nb


@dataclass
class Rendered:
    """Rendered audio ``(n_channels, n_samples)`` in Pa at ``rate``, with its layout."""

    audio: NDArray[np.float64]
    rate: int
    layout: Layout
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def duration(self) -> float:
        return self.audio.shape[1] / self.rate


def _norm(a: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.sqrt(a[..., 0] ** 2 + a[..., 1] ** 2 + a[..., 2] ** 2)


def _receive(kin: Kinematics, tex: SoundTexture, L: NDArray[np.float64], tb: NDArray[np.float64],
             *, c0: float, exponent: float, min_distance: float, fade: float,
             layout: Layout | None, fwd: NDArray[np.float64] | None, up: NDArray[np.float64] | None,
             out: NDArray[np.float64], K: int) -> None:  # fmt: skip
    """Eq. 4 at one receiver moving along ``L (B+1, 3)`` at block times ``tb (B+1,)``."""
    S = kin.pos.shape[0]
    tau = np.broadcast_to(tb, (S, tb.size)) - _norm(L[None] - kin.pos[:, :1]) / c0
    for _ in range(4):  # fixed point; contraction = source Mach number
        x = _at(kin.pos, tau, kin.dt)
        tau = tb[None] - _norm(L[None] - x) / c0
    x = _at(kin.pos, tau, kin.dt)
    d = L[None] - x
    r = np.maximum(_norm(d), min_distance)
    uhat = d / r[..., None]
    e1 = _at(kin.e1, tau, kin.dt)
    e2 = _at(kin.e2, tau, kin.dt)
    theta = np.arctan2(_at(kin.c2, tau, kin.dt), _at(kin.c1, tau, kin.dt))
    a = _at(kin.speed, tau, kin.dt)
    s = _at(kin.s, tau, kin.dt)
    on = np.clip(tau / fade, 0.0, 1.0)
    on = on * on * (3 - 2 * on)
    amp = on * a**exponent * kin.span[:, None] / (4 * np.pi * c0 * r)
    P = np.stack([amp * np.sum(uhat * e1, 2), amp * np.sum(uhat * e2, 2)], -1)  # (S, B+1, 2)
    j0, j1, w, M = tex.lookup(theta[:, :-1])
    Mt = np.swapaxes(M, -1, -2)
    qs = Mt[..., 0] * P[:, :-1, :1] + Mt[..., 1] * P[:, :-1, 1:]
    qe = Mt[..., 0] * P[:, 1:, :1] + Mt[..., 1] * P[:, 1:, 1:]
    if layout is None or layout.n_channels == 1:
        gain = np.ones((S, tb.size, 1))
    else:
        az = listener_frame_azimuth((x - L[None]).reshape(-1, 3), np.repeat(fwd[None], S, 0).reshape(-1, 3),
                                    np.repeat(up[None], S, 0).reshape(-1, 3))  # fmt: skip
        gain = vbap_gains(layout, az).T.reshape(S, tb.size, layout.n_channels)
    _synth(out, np.ascontiguousarray(tex.g), tex.lengths, float(tex.rate), np.ascontiguousarray(s),
           np.ascontiguousarray(qs), np.ascontiguousarray(qe), np.ascontiguousarray(j0),
           np.ascontiguousarray(j1), np.ascontiguousarray(w), np.ascontiguousarray(gain), K)  # fmt: skip


def render(texture: SoundTexture, obj: AeroObject, path: ListenerPath, *, motion: Motion | None = None,
           wind: Wind | None = None, rate: int = 44100, layout: str | Layout = "mono",
           exponent: str | float = "physical", duration: float | None = None, c0: float = C0,
           stereo: str = "ears", ear_distance: float = 0.18, min_distance: float = 0.05,
           fade: float = 0.01, block: int = 32) -> Rendered:  # fmt: skip
    """Render the aerodynamic sound of ``obj`` heard along ``path`` (§6, Eqs. 3–4).

    Parameters
    ----------
    texture : SoundTexture
        Texture of the object's cross-section at base speed v0.
    obj : AeroObject
        Polylines split into point sources at Δh ≈ 3D.
    path : ListenerPath
        Listener; output sample n is at data time n / rate.
    motion : Motion, optional
        Object poses (moving object: Doppler follows from the retarded time).
    wind : Wind, optional
        Wind on the object (both may be given: relative velocity).
    rate : int
        Output sample rate (Hz).
    layout : str or Layout
        ``mono``, ``stereo`` (two ear receivers with ``stereo="ears"``, or
        VBAP with ``"pan"``), ``ring8``, ``5.1``, ``7.1`` or a JSON layout.
    exponent : "physical" (pressure ∝ v³, default), "paper" (v⁶) or a number.
    duration : float, optional
        Seconds to render (default: the path's duration).
    min_distance : float
        Distances are clamped here (m): a listener at a source gets no 1/0.

    Returns
    -------
    Rendered
        ``audio (n_channels, n_samples)`` in Pa.

    Examples
    --------
    >>> from auralize_aero.presets import stick, cylinder_texture   # doctest: +SKIP
    >>> out = render(cylinder_texture(), stick(), ListenerPath.point((0, 1, 0), duration=1),
    ...              wind=Wind(10.0))                                # doctest: +SKIP
    """
    if not isinstance(texture, SoundTexture):
        raise ParameterError(f"texture must be a SoundTexture, got {type(texture).__name__}")
    e = resolve_exponent(exponent)
    lay = get_layout(layout)
    if stereo not in ("ears", "pan"):
        raise ParameterError(f"stereo must be 'ears' or 'pan', got {stereo!r}")
    if int(rate) < 1000:
        raise ParameterError(f"rate must be >= 1000 Hz, got {rate!r}")
    dur = path.duration if duration is None else float(duration)
    if not (math.isfinite(dur) and dur > 0):
        raise ParameterError(f"duration must be > 0 s, got {dur!r}")
    K = int(block)
    n_out = int(round(dur * rate))
    kin = kinematics(obj, texture.speed, motion=motion, wind=wind, dt=K / rate, duration=dur)
    B = int(math.ceil(n_out / K))
    tb = np.arange(B + 1) * (K / rate)
    t_path = path.times[0] + tb
    L = path.position_at(t_path)
    out = np.zeros((lay.n_channels, n_out))
    common = {"c0": c0, "exponent": e, "min_distance": min_distance, "fade": fade, "K": K}
    if lay.n_channels == 2 and lay.name == "stereo" and stereo == "ears":
        fwd, up = path.orientation_at(t_path)
        left = np.cross(up, fwd)
        for ch, sign in ((0, 1.0), (1, -1.0)):
            _receive(kin, texture, L + sign * 0.5 * ear_distance * left, tb, layout=None, fwd=None,
                     up=None, out=out[ch : ch + 1], **common)  # fmt: skip
    elif lay.n_channels == 1:
        _receive(kin, texture, L, tb, layout=None, fwd=None, up=None, out=out, **common)
    else:
        fwd, up = path.orientation_at(t_path)
        _receive(kin, texture, L, tb, layout=lay, fwd=fwd, up=up, out=out, **common)
    meta = {"n_sources": int(kin.pos.shape[0]), "exponent": e, "texture_speed": texture.speed,
            "max_speed_mps": float(kin.speed.max() * texture.speed)}  # fmt: skip
    return Rendered(out, int(rate), lay, meta)
