"""Propagate emitted source signals to a moving listener and pan them to a layout.

Sound models that produce an *emitted* signal per source (vortex sub-volumes,
aerodynamic point sources, discharge segments) use :func:`propagate`: for each
output sample time t at listener position L(t), each source's signal is read
at the retarded time τ solving ``t - τ = |L(t) - x_s(τ)| / c0`` (so delay and
Doppler come out of the evaluation, for moving sources too), divided by the
distance law, and panned from the source's direction in the listener's frame
with the layout's pairwise VBAP (:func:`auralize.spatial.vbap_gains`).

Cost is O(sources × samples), meant for models with up to a few hundred
sources; the field auralization uses its own O(sources × steps) kernel.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.spatial import Layout, get_layout, listener_frame_azimuth, vbap_gains

C0 = 343.0


def distance_gain(D: NDArray[np.float64], law: str | float) -> NDArray[np.float64]:
    """Amplitude factor for distance D: ``"physical"`` 1/D, ``"paper"`` 1/D³, or 1/D**law."""
    if law == "physical":
        return 1.0 / D
    if law == "paper":
        return 1.0 / D**3
    try:
        e = float(law)
    except (TypeError, ValueError):
        raise ParameterError(
            f"attenuation must be 'physical', 'paper' or an exponent, got {law!r}"
        ) from None
    return 1.0 / D**e


def propagate(signals: NDArray[np.floating], emit_rate: float, positions: NDArray[np.floating],
              path: ListenerPath, *, rate: int = 44100, duration: float | None = None,
              emit_t0: float = 0.0, c0: float = C0, attenuation: str | float = "physical",
              min_distance: float = 0.05, layout: str | Layout = "mono",
              chunk: int = 65536, pan_stride: int = 64) -> NDArray[np.float64]:  # fmt: skip
    """Sum emitted source signals as heard along ``path``.

    Parameters
    ----------
    signals : (S, n_emit)
        Emitted signal of each source, sampled at ``emit_rate`` from ``emit_t0``
        (values outside are zero).
    positions : (S, 3) static positions, or (S, n_emit, 3) trajectories sampled
        like the signals (moving sources: Doppler from the retarded time).
    path : ListenerPath
        Playback-time listener; output sample n is at time ``n / rate``.
    attenuation : "physical" (1/D), "paper" (1/D³) or an exponent.
    min_distance : distances are clamped here (no 1/0 at a source).
    layout : output layout (pairwise VBAP in the listener's frame).
    pan_stride : panning gains are computed every this many samples and
        interpolated linearly (they follow head turns and motion, which are slow).

    Returns
    -------
    (n_channels, n_samples) pressure.
    """
    sig = np.atleast_2d(np.asarray(signals, dtype=np.float64))
    pos = np.asarray(positions, dtype=np.float64)
    S, n_emit = sig.shape
    moving = pos.ndim == 3
    if pos.shape[0] != S or pos.shape[-1] != 3 or (moving and pos.shape[1] != n_emit):
        raise ParameterError(
            f"positions must be (S, 3) or (S, n_emit, 3) for {S} signals of {n_emit} samples; "
            f"got {pos.shape}"
        )
    lay = get_layout(layout)
    dur = path.duration if duration is None else float(duration)
    n_out = round(dur * rate)
    out = np.zeros((lay.n_channels, n_out))
    t_emit = emit_t0 + np.arange(n_emit) / emit_rate
    for a in range(0, n_out, chunk):
        b = min(n_out, a + chunk)
        t = path.times[0] + np.arange(a, b) / rate
        L = path.position_at(t)
        fwd, up = path.orientation_at(t) if lay.n_channels > 1 else (L, L)
        tt = t - path.times[0]
        for s in range(S):
            if moving:
                tau = tt - np.linalg.norm(L - pos[s, 0], axis=1) / c0
                for _ in range(4):  # fixed point; contraction = source Mach number
                    xs = np.stack([np.interp(tau, t_emit, pos[s, :, k]) for k in range(3)], 1)
                    tau = tt - np.linalg.norm(L - xs, axis=1) / c0
                d_vec = xs - L
            else:
                d_vec = pos[s] - L
            D = np.maximum(np.linalg.norm(d_vec, axis=1), min_distance)
            tau = tt - D / c0
            v = np.interp(tau, t_emit, sig[s], left=0.0, right=0.0) * distance_gain(D, attenuation)
            if lay.n_channels == 1:
                out[0, a:b] += v
            else:
                # gains change slowly: evaluate them every `pan_stride` samples
                # (≈1.5 ms at 44.1 kHz) and interpolate linearly in between
                k = np.arange(0, b - a, pan_stride)
                if k[-1] != b - a - 1:
                    k = np.append(k, b - a - 1)
                g = vbap_gains(lay, listener_frame_azimuth(d_vec[k], fwd[k], up[k]))
                idx = np.arange(b - a)
                for c in np.flatnonzero(np.any(g != 0, axis=1)):
                    out[c, a:b] += np.interp(idx, k, g[c]) * v
    return out
