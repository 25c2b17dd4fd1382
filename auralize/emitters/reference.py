"""Numpy reference of the emitters engine: every output sample evaluated directly.

O(emitters × samples) with per-sample panning gains; for equality tests
against the fast backends, never for production renders.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from auralize.emitters import C0, Emitters, law_exponent
from auralize.listener import ListenerPath
from auralize.spatial.layouts import Layout, get_layout, listener_frame, pan_gains, receiver_paths


def render_reference(
    em: Emitters,
    path: ListenerPath,
    *,
    rate: int = 44100,
    layout: str | Layout = "mono",
    duration: float | None = None,
    start: float = 0.0,
    c0: float = C0,
) -> NDArray[np.float64]:
    """Pressure ``(n_channels, n_samples)`` of ``em`` heard along ``path``.

    Output sample n is at playback time ``start + n / rate`` after the
    path's first capture.  The retarded time of a moving emitter is found
    by fixed-point iteration (contraction = the emitter's Mach number);
    signals are interpolated linearly in emission time.

    Parameters
    ----------
    em : Emitters
        The emitters (see :mod:`auralize.emitters`).
    path : ListenerPath
        Playback-time listener captures.
    rate : int
        Output sample rate (Hz).
    layout : str or Layout
        A speaker, Ambisonics or receiver layout
        (:func:`auralize.spatial.layouts.get_layout`; for ``binaural``, its
        AmbiX intermediate: the output stage is
        :func:`auralize.emitters.engine.render_emitters`'s).
    duration : float, optional
        Playback seconds (default: the path's duration after ``start``).
    start : float
        Playback seconds after the path's first capture of output sample 0.
    c0 : float
        Speed of sound (m/s).

    Returns
    -------
    (n_channels, n_samples) float
        The pressure heard, Pa.

    Raises
    ------
    ParameterError
        An unknown layout, or a law :func:`auralize.emitters.law_exponent` refuses.

    Examples
    --------
    A 1 Pa (at 1 m) monopole 2 m away is heard at 0.5 Pa once its sound arrives:

    >>> from auralize.listener import ListenerPath
    >>> em = Emitters(np.ones((1, 80)), 8000, [[2.0, 0, 0]])
    >>> out = render_reference(em, ListenerPath.point((0, 0, 0), duration=0.01), rate=8000)
    >>> out.shape, float(out[0, -1])
    ((1, 80), 0.5)
    """
    lay = get_layout(layout)
    ears = receiver_paths(lay, path)
    if ears:  # several receivers (the ears): each along its own path, channels stacked
        return np.concatenate(
            [
                render_reference(em, p, rate=rate, layout=rl, duration=duration, start=start, c0=c0)
                for rl, p in ears
            ]
        )
    dur = path.duration - start if duration is None else float(duration)
    n_out = int(round(dur * rate))
    t = start + np.arange(n_out) / rate
    L = path.position_at(path.times[0] + t)
    if lay.n_channels > 1:
        fwd, up = path.orientation_at(path.times[0] + t)
    e = law_exponent(em.law)
    t_sig = em.t0 + np.arange(em.n_samples) / em.rate
    out = np.zeros((lay.n_channels, n_out))
    assert isinstance(em.radius, np.ndarray)
    for s in range(em.n_emitters):
        x = em.position_at(t, s)
        tau = t - np.linalg.norm(L - x, axis=1) / c0
        if em.moving:
            for _ in range(30):
                x = em.position_at(tau, s)
                tau_new = t - np.linalg.norm(L - x, axis=1) / c0
                done = np.max(np.abs(tau_new - tau), initial=0.0) < 1e-12
                tau = tau_new
                if done:
                    break
            x = em.position_at(tau, s)
        d_vec = x - L  # listener -> emitter
        D_true = np.linalg.norm(d_vec, axis=1)
        D = np.maximum(D_true, em.radius[s])
        if em.dipole:
            u = -d_vec / np.maximum(D_true, 1e-300)[:, None]  # emitter -> listener
            a = sum(
                u[:, k] * np.interp(tau, t_sig, em.signals[s, k], left=0.0, right=0.0)
                for k in range(3)
            )
        else:
            a = np.interp(tau, t_sig, em.signals[s], left=0.0, right=0.0)
        v = a / D**e
        if lay.n_channels == 1:
            out[0] += v
        else:
            out += pan_gains(lay, listener_frame(d_vec, fwd, up)) * v
    return out
