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
coordinate, panning gains) are evaluated every ``block`` samples and
interpolated linearly; the per-sample texture look-up and sum is a numba
loop.  The default engine does the per-step kinematics and the per-block
work in fused numba kernels (:func:`_kin_kernel`, :func:`_block_kernel`),
with the sources split over up to two threads; ``engine="numpy"`` runs the
reference numpy path (:func:`kinematics_reference`,
:func:`_receive_reference`), equal up to rounding.  Stereo uses two receivers at the ears (§6); other layouts pan
each source from its direction with the output layer's VBAP
(:func:`auralize.spatial.vbap_gains`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline

from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.spatial import Layout, get_layout, listener_frame_azimuth, vbap_gains
from auralize.synthesis import Rendered

from .objects import AeroObject, Motion, Wind, quat_to_matrix
from .texture import SoundTexture

C0 = 343.0
_NJIT = {"cache": True, "nogil": True, "error_model": "numpy"}
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


# Work is split between up to two threads (the kernels release the GIL).
_N_THREADS = max(1, min(2, os.cpu_count() or 1))
_POOL: ThreadPoolExecutor | None = None


def _parts(S: int) -> list[tuple[int, int]]:
    """Contiguous ranges of ``range(S)``, one per thread."""
    n = max(1, min(_N_THREADS, S))
    edges = [S * i // n for i in range(n + 1)]
    return [(edges[i], edges[i + 1]) for i in range(n)]


def _run(fn: Callable[[int], None], n: int) -> None:
    """``fn(i)`` for i < n: i = 0 on this thread, the rest on the pool."""
    global _POOL
    if n > 1 and _POOL is None:
        _POOL = ThreadPoolExecutor(max_workers=_N_THREADS - 1, thread_name_prefix="auralize-aero")
    futures = [_POOL.submit(fn, i) for i in range(1, n)] if n > 1 and _POOL is not None else []
    fn(0)
    for fu in futures:
        fu.result()


def _in_parts(fn: Callable[[int, int], None], S: int) -> None:
    parts = _parts(S)
    _run(lambda i: fn(*parts[i]), len(parts))


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


def kinematics_reference(obj: AeroObject, v0: float, *, motion: Motion | None, wind: Wind | None,
                         dt: float, duration: float) -> Kinematics:  # fmt: skip
    """Source kinematics and the texture-coordinate recurrence of Eq. 3 (§6), in numpy.

    The reference for :func:`kinematics` (same quantities, one numba pass).
    """
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


@numba.njit(**_NJIT)
def _synth(out: NDArray[np.float64], tex: NDArray[np.float64], lengths: NDArray[np.int64],
           tex_rate: float, s: NDArray[np.float64], qs: NDArray[np.float64], qe: NDArray[np.float64],
           j0: NDArray[np.int64], j1: NDArray[np.int64], wj: NDArray[np.float64],
           gain: NDArray[np.float64], K: int, b0: int = 0, b1: int = -1) -> None:  # fmt: skip
    """Σ_l Q_l(t) · w(s_l(t)) with per-block linear interpolation, accumulated into out (C, n).

    Blocks ``b0 <= b < b1`` only (``b1 = -1``: all): disjoint block ranges write
    disjoint samples, so threads can share ``out``.

    The texture position advances by a constant step within a block and
    wraps around the loop length (the texture is periodic, §6).  Each block
    is summed over the sources in a local buffer (same order of additions)
    and written back once.
    """
    C, n_out = out.shape
    S, B = j0.shape
    if b1 < 0:
        b1 = B
    inv = 1.0 / K
    act = np.empty(C, dtype=np.int64)
    acc = np.empty(K)
    pbuf = np.empty(K)
    for b in range(b0, b1):
        n0 = b * K
        if n0 >= n_out:
            continue
        m = min(K, n_out - n0)
        if C == 1:
            for i in range(m):
                acc[i] = out[0, n0 + i]
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
            ta = tex[ja]
            tb = tex[jb]
            s0 = s[k, b] * tex_rate
            ds = (s[k, b + 1] - s[k, b]) * tex_rate * inv
            pa = s0 - math.floor(s0 / Na) * Na
            pb = s0 - math.floor(s0 / Nb) * Nb
            n_act = 0
            if C > 1:  # channels silent at both block ends only ever add 0.0: skip them
                for c in range(C):
                    if gain[k, b, c] != 0.0 or gain[k, b + 1, c] != 0.0:
                        act[n_act] = c
                        n_act += 1
            if w > 0.0:  # between two sampled directions
                for i in range(m):
                    ia = int(pa)
                    if ia >= Na:
                        ia = Na - 1
                    fa = pa - ia
                    ia1 = ia + 1 if ia + 1 < Na else 0
                    g0 = ta[ia, 0]
                    g1 = ta[ia, 1]
                    gx = g0 + fa * (ta[ia1, 0] - g0)
                    gy = g1 + fa * (ta[ia1, 1] - g1)
                    ib = int(pb)
                    if ib >= Nb:
                        ib = Nb - 1
                    fb = pb - ib
                    ib1 = ib + 1 if ib + 1 < Nb else 0
                    h0 = tb[ib, 0]
                    h1 = tb[ib, 1]
                    gx += w * (h0 + fb * (tb[ib1, 0] - h0) - gx)
                    gy += w * (h1 + fb * (tb[ib1, 1] - h1) - gy)
                    pbuf[i] = (qa0 + dq0 * i) * gx + (qa1 + dq1 * i) * gy
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
            else:  # on a sampled direction: one row
                for i in range(m):
                    ia = int(pa)
                    if ia >= Na:
                        ia = Na - 1
                    fa = pa - ia
                    ia1 = ia + 1 if ia + 1 < Na else 0
                    g0 = ta[ia, 0]
                    g1 = ta[ia, 1]
                    gx = g0 + fa * (ta[ia1, 0] - g0)
                    gy = g1 + fa * (ta[ia1, 1] - g1)
                    pbuf[i] = (qa0 + dq0 * i) * gx + (qa1 + dq1 * i) * gy
                    pa += ds
                    if pa >= Na:
                        pa -= Na
                    elif pa < 0.0:
                        pa += Na
            if C == 1:
                for i in range(m):
                    acc[i] += pbuf[i]
            else:
                for ci in range(n_act):
                    c = act[ci]
                    ga = gain[k, b, c]
                    gb = gain[k, b + 1, c]
                    for i in range(m):
                        out[c, n0 + i] += (ga + i * inv * (gb - ga)) * pbuf[i]
        if C == 1:
            for i in range(m):
                out[0, n0 + i] = acc[i]


@numba.njit(**_NJIT)
def _kin_kernel(p: NDArray[np.float64], dp: NDArray[np.float64], R: NDArray[np.float64],
                dR: NDArray[np.float64], centres: NDArray[np.float64], axes: NDArray[np.float64],
                refs: NDArray[np.float64], wind: NDArray[np.float64], has_wind: bool, v0: float,
                dt: float, pos: NDArray[np.float64], e1o: NDArray[np.float64], e2o: NDArray[np.float64],
                c1o: NDArray[np.float64], c2o: NDArray[np.float64], ao: NDArray[np.float64],
                so: NDArray[np.float64], k0: int, k1: int) -> None:  # fmt: skip
    """Fused :func:`kinematics_reference` after the pose spline: poses ``p (J, 3)``,
    ``R (J, 3, 3)`` and their time derivatives -> per-source arrays (written in place)."""
    J = p.shape[0]
    for k in range(k0, k1):
        cx, cy, cz = centres[k, 0], centres[k, 1], centres[k, 2]
        ax, ay, az = axes[k, 0], axes[k, 1], axes[k, 2]
        rx, ry, rz = refs[k, 0], refs[k, 1], refs[k, 2]
        for j in range(J):
            pos[k, j, 0] = p[j, 0] + (R[j, 0, 0] * cx + R[j, 0, 1] * cy + R[j, 0, 2] * cz)
            pos[k, j, 1] = p[j, 1] + (R[j, 1, 0] * cx + R[j, 1, 1] * cy + R[j, 1, 2] * cz)
            pos[k, j, 2] = p[j, 2] + (R[j, 2, 0] * cx + R[j, 2, 1] * cy + R[j, 2, 2] * cz)
            vx = dp[j, 0] + (dR[j, 0, 0] * cx + dR[j, 0, 1] * cy + dR[j, 0, 2] * cz)
            vy = dp[j, 1] + (dR[j, 1, 0] * cx + dR[j, 1, 1] * cy + dR[j, 1, 2] * cz)
            vz = dp[j, 2] + (dR[j, 2, 0] * cx + dR[j, 2, 1] * cy + dR[j, 2, 2] * cz)
            nx = R[j, 0, 0] * ax + R[j, 0, 1] * ay + R[j, 0, 2] * az
            ny = R[j, 1, 0] * ax + R[j, 1, 1] * ay + R[j, 1, 2] * az
            nz = R[j, 2, 0] * ax + R[j, 2, 1] * ay + R[j, 2, 2] * az
            ex = R[j, 0, 0] * rx + R[j, 0, 1] * ry + R[j, 0, 2] * rz
            ey = R[j, 1, 0] * rx + R[j, 1, 1] * ry + R[j, 1, 2] * rz
            ez = R[j, 2, 0] * rx + R[j, 2, 1] * ry + R[j, 2, 2] * rz
            nn = math.sqrt(nx * nx + ny * ny + nz * nz)
            nx /= nn
            ny /= nn
            nz /= nn
            en = ex * nx + ey * ny + ez * nz
            ex -= en * nx
            ey -= en * ny
            ez -= en * nz
            ee = math.sqrt(ex * ex + ey * ey + ez * ez)
            ex /= ee
            ey /= ee
            ez /= ee
            fx = ny * ez - nz * ey
            fy = nz * ex - nx * ez
            fz = nx * ey - ny * ex
            ux, uy, uz = -vx, -vy, -vz
            if has_wind:
                ux += wind[k, j, 0]
                uy += wind[k, j, 1]
                uz += wind[k, j, 2]
            un = ux * nx + uy * ny + uz * nz
            ux -= un * nx
            uy -= un * ny
            uz -= un * nz
            vp = math.sqrt(ux * ux + uy * uy + uz * uz)
            if vp > 1e-12:
                c1o[k, j] = (ux * ex + uy * ey + uz * ez) / vp
                c2o[k, j] = (ux * fx + uy * fy + uz * fz) / vp
            else:
                c1o[k, j] = 1.0
                c2o[k, j] = 0.0
            e1o[k, j, 0] = ex
            e1o[k, j, 1] = ey
            e1o[k, j, 2] = ez
            e2o[k, j, 0] = fx
            e2o[k, j, 1] = fy
            e2o[k, j, 2] = fz
            ao[k, j] = vp / v0
        acc = 0.0
        so[k, 0] = 0.0
        for j in range(1, J):
            acc += 0.5 * (ao[k, j] + ao[k, j - 1]) * dt
            so[k, j] = acc


@numba.njit(**_NJIT)
def _lerp_index(x: float, J: int) -> tuple[int, float]:
    v = min(max(x, 0.0), J - 1.000001)
    i = int(v)
    return i, v - i


@numba.njit(**_NJIT)
def _vbap_into(g: NDArray[np.float64], k: int, b: int, phi: float, az: NDArray[np.float64],
               ch: NDArray[np.int64], fold_front: bool) -> None:  # fmt: skip
    """Pairwise 2-D VBAP gains of one azimuth written to ``g[k, b] (C,)``: the scalar form
    of :func:`auralize.spatial.vbap_gains` (same law, same operations)."""
    for c in range(g.shape[2]):
        g[k, b, c] = 0.0
    n = az.size
    if n == 0:
        g[k, b, 0] = 1.0
        return
    if fold_front:
        phi = math.atan2(math.sin(phi), abs(math.cos(phi)))
    if not -np.pi <= phi <= np.pi:  # wrap (an atan2 result already is in range)
        phi = math.atan2(math.sin(phi), math.cos(phi))
    i0 = np.searchsorted(az, phi, side="right") - 1
    if i0 < 0:
        i0 = n - 1
    i1 = (i0 + 1) % n
    two_pi = 2 * np.pi
    span = az[i1] - az[i0]
    span = span - math.floor(span / two_pi) * two_pi
    if span == 0:
        span = two_pi
    rel = phi - az[i0]
    rel = rel - math.floor(rel / two_pi) * two_pi
    if span > np.pi:
        rel = 0.0 if rel < 0.5 * span else span
    else:
        rel = min(rel, span)
    s = math.sin(span)
    if abs(s) < 1e-12:
        g0 = math.cos(rel * np.pi / (2 * span))
        g1 = math.sin(rel * np.pi / (2 * span))
    else:
        g0 = math.sin(span - rel) / s
        g1 = math.sin(rel) / s
    g0 = max(g0, 0.0)
    g1 = max(g1, 0.0)
    norm = math.hypot(g0, g1)
    if not norm > 0:
        norm = 1.0
    g[k, b, ch[i0]] += g0 / norm
    g[k, b, ch[i1]] += g1 / norm


@numba.njit(**_NJIT)
def _block_kernel(pos: NDArray[np.float64], e1: NDArray[np.float64], e2: NDArray[np.float64],
                  c1: NDArray[np.float64], c2: NDArray[np.float64], speed: NDArray[np.float64],
                  stex: NDArray[np.float64], span: NDArray[np.float64], L: NDArray[np.float64],
                  tb: NDArray[np.float64], dt: float, c0: float, exponent: float,
                  min_distance: float, fade: float, k_sym: int, has_mirror: bool, mirror_rad: float,
                  m: int, dom_start: float, dom_width: float, cyclic: bool,
                  fwd: NDArray[np.float64], left: NDArray[np.float64], spk_az: NDArray[np.float64],
                  spk_ch: NDArray[np.int64], fold_front: bool, gain: NDArray[np.float64],
                  s_out: NDArray[np.float64], qs: NDArray[np.float64],
                  qe: NDArray[np.float64], j0o: NDArray[np.int64], j1o: NDArray[np.int64],
                  wo: NDArray[np.float64], k0: int, k1: int) -> None:  # fmt: skip
    """The per-block work of :func:`_receive_reference` fused: retarded time, interpolated
    kinematics, amplitude, direction folding and texture look-up (Eq. 4, §7.3)."""
    J = speed.shape[1]
    B1 = tb.size
    pan = gain.shape[0] > 0  # panning gains (several channels) from the source directions
    P0 = np.empty(B1)
    P1 = np.empty(B1)
    Mb = np.empty((B1, 4))
    four_pi_c0 = 4 * np.pi * c0
    step = 0.0
    if m > 1:
        step = dom_width / (m if cyclic else m - 1)
    beta = 0.0
    ax2 = 0.0
    cr = 0.0
    sr = 0.0
    if k_sym != 0:
        beta = 2 * np.pi / k_sym
        ax2 = mirror_rad + beta / 2
        cr = math.cos(2 * ax2)
        sr = math.sin(2 * ax2)
    tau_b = np.empty(B1)
    for k in range(k0, k1):
        # retarded time: fixed point, contraction = source Mach number; one pass over the
        # blocks per step so that independent blocks overlap in the pipeline
        for b in range(B1):
            dx = L[b, 0] - pos[k, 0, 0]
            dy = L[b, 1] - pos[k, 0, 1]
            dz = L[b, 2] - pos[k, 0, 2]
            tau_b[b] = tb[b] - math.sqrt(dx * dx + dy * dy + dz * dz) / c0
        for _ in range(4):
            for b in range(B1):
                i, w = _lerp_index(tau_b[b] / dt, J)
                dx = L[b, 0] - (pos[k, i, 0] + w * (pos[k, i + 1, 0] - pos[k, i, 0]))
                dy = L[b, 1] - (pos[k, i, 1] + w * (pos[k, i + 1, 1] - pos[k, i, 1]))
                dz = L[b, 2] - (pos[k, i, 2] + w * (pos[k, i + 1, 2] - pos[k, i, 2]))
                tau_b[b] = tb[b] - math.sqrt(dx * dx + dy * dy + dz * dz) / c0
        for b in range(B1):
            tau = tau_b[b]
            i, w = _lerp_index(tau / dt, J)
            xx = pos[k, i, 0] + w * (pos[k, i + 1, 0] - pos[k, i, 0])
            xy = pos[k, i, 1] + w * (pos[k, i + 1, 1] - pos[k, i, 1])
            xz = pos[k, i, 2] + w * (pos[k, i + 1, 2] - pos[k, i, 2])
            dx = L[b, 0] - xx
            dy = L[b, 1] - xy
            dz = L[b, 2] - xz
            if pan:  # azimuth of x - L in the listener frame (listener_frame_azimuth)
                phi = math.atan2(
                    -dx * left[b, 0] - dy * left[b, 1] - dz * left[b, 2],
                    -dx * fwd[b, 0] - dy * fwd[b, 1] - dz * fwd[b, 2],
                )
                _vbap_into(gain, k, b, phi, spk_az, spk_ch, fold_front)
            r = max(math.sqrt(dx * dx + dy * dy + dz * dz), min_distance)
            ux = dx / r
            uy = dy / r
            uz = dz / r
            i1 = i + 1
            f1 = (
                ux * (e1[k, i, 0] + w * (e1[k, i1, 0] - e1[k, i, 0]))
                + uy * (e1[k, i, 1] + w * (e1[k, i1, 1] - e1[k, i, 1]))
                + uz * (e1[k, i, 2] + w * (e1[k, i1, 2] - e1[k, i, 2]))
            )
            f2 = (
                ux * (e2[k, i, 0] + w * (e2[k, i1, 0] - e2[k, i, 0]))
                + uy * (e2[k, i, 1] + w * (e2[k, i1, 1] - e2[k, i, 1]))
                + uz * (e2[k, i, 2] + w * (e2[k, i1, 2] - e2[k, i, 2]))
            )
            a = speed[k, i] + w * (speed[k, i1] - speed[k, i])
            s_out[k, b] = stex[k, i] + w * (stex[k, i1] - stex[k, i])
            on = min(max(tau / fade, 0.0), 1.0)
            on = on * on * (3 - 2 * on)
            amp = on * (a * a * a if exponent == 3.0 else a**exponent) * span[k] / (four_pi_c0 * r)
            P0[b] = amp * f1
            P1[b] = amp * f2
            if b == B1 - 1:
                continue
            # direction -> fundamental domain (fold_directions) -> texture rows (lookup)
            cy = c2[k, i] + w * (c2[k, i1] - c2[k, i])
            cx = c1[k, i] + w * (c1[k, i1] - c1[k, i])
            if k_sym == 0:  # rot(atan2(cy, cx)) without the trigonometry
                thf = 0.0
                h = math.sqrt(cx * cx + cy * cy)
                if h > 0.0:
                    cth = cx / h
                    sth = cy / h
                else:  # atan2 of signed zeros
                    th = math.atan2(cy, cx)
                    cth = math.cos(th)
                    sth = math.sin(th)
                m00, m01, m10, m11 = cth, -sth, sth, cth
            else:
                th = math.atan2(cy, cx)
                rr = math.floor((th - mirror_rad) / beta)
                thf = th - rr * beta
                ca = math.cos(rr * beta)
                sa = math.sin(rr * beta)
                m00, m01, m10, m11 = ca, -sa, sa, ca
                if has_mirror and thf > ax2:
                    thf = 2 * ax2 - thf
                    m00, m01, m10, m11 = (
                        ca * cr - sa * sr, ca * sr + sa * cr, sa * cr + ca * sr, sa * sr - ca * cr
                    )  # fmt: skip
            if m == 1:
                j0, j1, wt = 0, 0, 0.0
            else:
                u = (thf * (180.0 / np.pi) - dom_start) / step
                if cyclic:
                    u = u - math.floor(u / m) * m
                    fu = math.floor(u)
                    j0 = int(fu) % m
                    j1 = (j0 + 1) % m
                    wt = u - fu
                else:
                    u = min(max(u, 0.0), m - 1.0)
                    j0 = min(int(math.floor(u)), m - 2)
                    j1 = j0 + 1
                    wt = u - j0
            j0o[k, b] = j0
            j1o[k, b] = j1
            wo[k, b] = wt
            Mb[b, 0] = m00
            Mb[b, 1] = m01
            Mb[b, 2] = m10
            Mb[b, 3] = m11
        for b in range(B1 - 1):  # block b's map at both of its ends
            qs[k, b, 0] = Mb[b, 0] * P0[b] + Mb[b, 2] * P1[b]
            qs[k, b, 1] = Mb[b, 1] * P0[b] + Mb[b, 3] * P1[b]
            qe[k, b, 0] = Mb[b, 0] * P0[b + 1] + Mb[b, 2] * P1[b + 1]
            qe[k, b, 1] = Mb[b, 1] * P0[b + 1] + Mb[b, 3] * P1[b + 1]


def _norm(a: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.sqrt(a[..., 0] ** 2 + a[..., 1] ** 2 + a[..., 2] ** 2)


def _receive_reference(kin: Kinematics, tex: SoundTexture, L: NDArray[np.float64], tb: NDArray[np.float64],
             *, c0: float, exponent: float, min_distance: float, fade: float,
             layout: Layout | None, fwd: NDArray[np.float64] | None, up: NDArray[np.float64] | None,
             out: NDArray[np.float64], K: int) -> None:  # fmt: skip
    """Eq. 4 at one receiver moving along ``L (B+1, 3)`` at block times ``tb (B+1,)`` (numpy).

    The reference for :func:`_receive` (per-block work in numpy arrays).
    """
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


def kinematics(obj: AeroObject, v0: float, *, motion: Motion | None, wind: Wind | None,
               dt: float, duration: float) -> Kinematics:  # fmt: skip
    """Source kinematics and the texture-coordinate recurrence of Eq. 3 (§6).

    The pose spline is evaluated in scipy; everything per source and step
    runs in one numba pass (:func:`_kin_kernel`), equal to
    :func:`kinematics_reference` up to rounding.
    """
    if motion is None and wind is None:
        raise ParameterError("give a motion (object moving) or a wind (static object), or both")
    centres, span, axes, refs = obj.sources()
    S = centres.shape[0]
    J = int(math.ceil(duration / dt)) + 3
    t = np.arange(J) * dt
    if motion is not None:
        tm = motion.times
        tc = np.clip(t, tm[0], tm[-1])
        moving = ((t >= tm[0]) & (t <= tm[-1])).astype(np.float64)
        R = quat_to_matrix(motion.quaternions).reshape(-1, 9)
        spl = CubicSpline(tm, np.concatenate([motion.positions, R], 1), axis=0)
        v = spl(tc)
        dv = spl(tc, 1) * moving[:, None]
        p = np.ascontiguousarray(v[:, :3])
        dp = np.ascontiguousarray(dv[:, :3])
        Rt = np.ascontiguousarray(v[:, 3:]).reshape(J, 3, 3)
        dRt = np.ascontiguousarray(dv[:, 3:]).reshape(J, 3, 3)
    else:
        p = np.zeros((J, 3))
        dp = np.zeros((J, 3))
        Rt = np.ascontiguousarray(np.broadcast_to(np.eye(3), (J, 3, 3)))
        dRt = np.zeros((J, 3, 3))
    uw = np.ascontiguousarray(wind.velocities(S, t)) if wind is not None else np.zeros((1, 1, 3))
    pos = np.empty((S, J, 3))
    e1 = np.empty((S, J, 3))
    e2 = np.empty((S, J, 3))
    c1 = np.empty((S, J))
    c2 = np.empty((S, J))
    a = np.empty((S, J))
    s = np.empty((S, J))
    f = np.ascontiguousarray
    args = (p, dp, Rt, dRt, f(centres, dtype=np.float64), f(axes, dtype=np.float64),
            f(refs, dtype=np.float64), uw, wind is not None, float(v0), float(dt),
            pos, e1, e2, c1, c2, a, s)  # fmt: skip
    _in_parts(lambda k0, k1: _kin_kernel(*args, k0, k1), S)
    return Kinematics(dt, pos, e1, e2, c1, c2, a, s, span)


def _receive(kin: Kinematics, tex: SoundTexture, L: NDArray[np.float64], tb: NDArray[np.float64],
             *, c0: float, exponent: float, min_distance: float, fade: float,
             layout: Layout | None, fwd: NDArray[np.float64] | None, up: NDArray[np.float64] | None,
             out: NDArray[np.float64], K: int) -> None:  # fmt: skip
    """Eq. 4 at one receiver moving along ``L (B+1, 3)`` at block times ``tb (B+1,)``.

    The per-block work (retarded time, interpolations, direction look-up) is
    one numba pass (:func:`_block_kernel`), then the per-sample :func:`_synth`;
    equal to :func:`_receive_reference` up to rounding.
    """
    S = kin.speed.shape[0]
    B1 = tb.size
    B = B1 - 1
    k_sym, mirror = tex.section.symmetry
    start, width, cyclic = tex.domain()
    mono = layout is None or layout.n_channels == 1
    if mono:
        fw = lf = np.zeros((0, 3))
        spk_az, spk_ch, fold = np.zeros(0), np.zeros(0, dtype=np.int64), False
        gain = np.zeros((0, 0, 1))  # read only for several channels
    else:
        fw = np.ascontiguousarray(fwd, dtype=np.float64)
        lf = np.ascontiguousarray(np.cross(up, fwd), dtype=np.float64)
        spk_az, spk_ch = layout.panning_arrays()
        fold = bool(layout.fold_front)
        gain = np.empty((S, B1, layout.n_channels))
    s = np.empty((S, B1))
    qs = np.empty((S, B, 2))
    qe = np.empty((S, B, 2))
    j0 = np.empty((S, B), dtype=np.int64)
    j1 = np.empty((S, B), dtype=np.int64)
    w = np.empty((S, B))
    f = np.ascontiguousarray
    block_args = (f(kin.pos), f(kin.e1), f(kin.e2), f(kin.c1), f(kin.c2), f(kin.speed), f(kin.s),
                  f(kin.span, dtype=np.float64), f(L, dtype=np.float64), f(tb, dtype=np.float64),
                  float(kin.dt), float(c0), float(exponent), float(min_distance), float(fade),
                  int(k_sym), mirror is not None, 0.0 if mirror is None else math.radians(mirror),
                  int(tex.directions_deg.size), float(start), float(width), bool(cyclic),
                  fw, lf, f(spk_az, dtype=np.float64), f(spk_ch, dtype=np.int64), fold, gain,
                  s, qs, qe, j0, j1, w)  # fmt: skip
    g = f(tex.g)
    # threads: the block work split by sources, then the synthesis by block ranges
    _in_parts(lambda k0, k1: _block_kernel(*block_args, k0, k1), S)
    _in_parts(lambda b0, b1: _synth(out, g, tex.lengths, float(tex.rate), s, qs, qe, j0, j1, w,
                                    gain, K, b0, b1), B)  # fmt: skip


def render(texture: SoundTexture, obj: AeroObject, path: ListenerPath, *, motion: Motion | None = None,
           wind: Wind | None = None, rate: int = 44100, layout: str | Layout = "mono",
           exponent: str | float = "physical", duration: float | None = None, c0: float = C0,
           stereo: str = "ears", ear_distance: float = 0.18, min_distance: float = 0.05,
           fade: float = 0.01, block: int = 32, engine: str = "numba") -> Rendered:  # fmt: skip
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
    engine : "numba" (default: fused per-block kernels) or "numpy" (the
        reference path: per-block work in numpy arrays); equal up to rounding.

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
    if engine not in ("numba", "numpy"):
        raise ParameterError(f"engine must be 'numba' or 'numpy', got {engine!r}")
    kin_fn, receive = (
        (kinematics, _receive) if engine == "numba" else (kinematics_reference, _receive_reference)
    )
    K = int(block)
    n_out = int(round(dur * rate))
    kin = kin_fn(obj, texture.speed, motion=motion, wind=wind, dt=K / rate, duration=dur)
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
            receive(kin, texture, L + sign * 0.5 * ear_distance * left, tb, layout=None, fwd=None,
                     up=None, out=out[ch : ch + 1], **common)  # fmt: skip
    elif lay.n_channels == 1:
        receive(kin, texture, L, tb, layout=None, fwd=None, up=None, out=out, **common)
    else:
        fwd, up = path.orientation_at(t_path)
        receive(kin, texture, L, tb, layout=lay, fwd=fwd, up=up, out=out, **common)
    meta = {"n_sources": int(kin.pos.shape[0]), "exponent": e, "texture_speed": texture.speed,
            "max_speed_mps": float(kin.speed.max() * texture.speed)}  # fmt: skip
    return Rendered(audio=out, rate=int(rate), layout=lay, meta=meta)
