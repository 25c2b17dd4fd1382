"""Arrivals of impulsive emissions at a moving, turning listener.

Closed-form model parts (spark's WM-waves, paper 002 §4.2.2) place a whole
wave at once at its arrival time instead of sampling an emitted signal.  They
take the propagation from here: for an emission at position ``x`` and
emission time ``τ`` (playback seconds since the listener path's first
capture) the arrival time ``t`` solves the retarded-time condition of paper
003 §3.2.4.2,

    t − τ = |L(t) − x| / c0,

with ``L(t)`` the listener's position on the path.  On each capture interval
``L`` is linear, ``L(t) = P_k + V_k (t − t_k)``, so squaring gives the
quadratic

    (|V|² − c0²) s² + 2 (A·V − c0² b) s + (|A|² − c0² b²) = 0,
    s = t − t_k,  A = P_k − x,  b = t_k − τ,

whose root with ``s + b ≥ 0`` is the arrival (the other root is the advanced
solution).  For a listener slower than sound the function
``f(t) = t − τ − |L(t) − x|/c0`` increases monotonically, so the capture
interval holding the root is found by a vectorised bisection on the captures'
``f`` (O(E log N) for E emissions and N captures), and the root is exact, not
iterated.  Before the first and after the last capture the listener is held
at its end positions, as :meth:`ListenerPath.position_at` does.

A moving listener also hears each emission's waveform scaled in time by the
Doppler factor ``dt/dτ = 1 / (1 − Ḋ/c0)`` (:attr:`Arrivals.doppler`), which
closed forms apply to their wave's time axis.

The direction, distance and panning gains are those at the arrival: the
listener's position and orientation at ``t`` and the layout's own law
(:func:`auralize.spatial.layouts.pan_gains`: 2-D VBAP for horizontal layouts, 3-D
VBAP for layouts with elevation), exactly as the sampled emitters are panned
(:mod:`auralize.emitters.reference`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from auralize.emitters import C0
from auralize.emitters.outdoor import note_arrivals
from auralize.errors import ParameterError
from auralize.listener import FORWARD, UP, ListenerPath
from auralize.spatial.layouts import Layout, get_layout, listener_frame, pan_gains


@dataclass
class Arrivals:
    """Where and when impulsive emissions reach the listener (made by :func:`arrivals`).

    Parameters
    ----------
    time : (E,) float
        Arrival time, playback seconds since the path's first capture.
    distance : (E,) float
        True distance |L(t) − x| at arrival (m), not clamped.
    listener : (E, 3) float
        Listener position at arrival (m).
    direction : (E, 3) float
        Unit vector from the emitter to the listener, world frame (the û of a
        dipole's ``û · G``; zero where the listener is at the emitter).
    direction_local : (E, 3) float
        The same unit vector in the listener's frame (forward, left, up); the
        sound comes from ``-direction_local``.
    doppler : (E,) float
        ``dt/dτ`` at the arrival, ``1 / (1 − Ḋ/c0)`` with ``Ḋ = û · V_L`` the
        rate at which the moving listener recedes from the emitter: an emitted
        waveform of duration T is heard lasting ``doppler · T`` (< 1 approaching).
    gains : (n_channels, E) float or None
        Panning gains of the layout for the direction the sound comes from
        (None when no layout was given).

    Examples
    --------
    An emission 343 m ahead of a listener who moves toward it at 34.3 m/s
    (a tenth of c0) is heard compressed in time by 1/1.1:

    >>> path = ListenerPath.line((0, 0, 0), (0, 34.3, 0), duration=1.0)
    >>> a = arrivals(np.array([[0.0, 343.0, 0.0]]), np.array([0.0]), path, c0=343.0)
    >>> round(float(a.time[0]), 6), round(float(a.doppler[0]), 6), a.gains is None
    (0.909091, 0.909091, True)
    """

    time: NDArray[np.float64]
    distance: NDArray[np.float64]
    listener: NDArray[np.float64]
    direction: NDArray[np.float64]
    direction_local: NDArray[np.float64]
    doppler: NDArray[np.float64]
    gains: NDArray[np.float64] | None = None


def as_path(
    listener: ListenerPath | NDArray[np.floating] | tuple[float, float, float],
) -> ListenerPath:
    """A ListenerPath from a path or a static (3,) position (one capture, forward +y, up +z).

    Parameters
    ----------
    listener : ListenerPath or (3,) float
        A path (returned as it is) or a fixed position (m).

    Returns
    -------
    ListenerPath
        ``listener``, or one capture at time 0 at the position.

    Raises
    ------
    ParameterError
        A position that is not three finite numbers.

    Examples
    --------
    >>> p = as_path((1.0, 2.0, 0.0))
    >>> p.n_captures, p.positions.tolist()
    (1, [[1.0, 2.0, 0.0]])
    """
    if isinstance(listener, ListenerPath):
        return listener
    return ListenerPath(np.zeros(1), _position(listener)[None], source="static listener")


def _position(listener: object) -> NDArray[np.float64]:
    p = np.asarray(listener, dtype=np.float64)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ParameterError(
            f"listener must be a ListenerPath or a finite (x, y, z) position in m, got {listener!r}"
        )
    return p


def _check(
    positions: NDArray[np.floating], times: NDArray[np.floating], c0: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    x = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    tau = np.asarray(times, dtype=np.float64).reshape(-1)
    if tau.shape[0] != x.shape[0]:
        raise ParameterError(
            f"emission times {tau.shape} and positions {x.shape} must both have E rows"
        )
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(tau))):
        raise ParameterError("emission positions and times must be finite")
    if not (np.isfinite(c0) and c0 > 0):
        raise ParameterError(f"c0 must be a positive speed in m/s, got {c0!r}")
    return x, tau


def arrival_times(
    positions: NDArray[np.floating],
    times: NDArray[np.floating],
    path: ListenerPath,
    *,
    c0: float = C0,
) -> NDArray[np.float64]:
    """Arrival times (E,) solving ``t − τ = |L(t) − x| / c0`` exactly (see the module notes).

    Parameters
    ----------
    positions : (E, 3) float
        Emission positions x (m).
    times : (E,) float
        Emission times τ (playback seconds since the path's first capture).
    path : ListenerPath
        The listener (held at its end positions before and after its captures).
    c0 : float
        Speed of sound (m/s).

    Returns
    -------
    (E,) float
        Arrival times in playback seconds since the path's first capture.

    Raises
    ------
    ParameterError
        Positions and times of different lengths, values not finite, or a
        ``c0`` not > 0.

    Examples
    --------
    >>> path = ListenerPath.point((0, 0, 0), duration=1.0)
    >>> arrival_times(np.array([[343.0, 0, 0], [0, 0, 34.3]]), np.array([0.0, 0.5]), path,
    ...               c0=343.0).tolist()
    [1.0, 0.6]
    """
    return _solve(positions, times, path, c0)[0]


def _solve(
    positions: NDArray[np.floating], times: NDArray[np.floating], path: ListenerPath, c0: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Arrival times (E,) and the listener's velocity (E, 3) (m/s) at them."""
    x, tau = _check(positions, times, c0)
    T = path.times - path.times[0]
    P = path.positions
    N = T.size
    E = tau.size
    if N == 1:  # a static listener: t = τ + D/c0
        return tau + np.linalg.norm(P[0] - x, axis=1) / c0, np.zeros((E, 3))

    def f(k: NDArray[np.int64], rows: NDArray[np.int64]) -> NDArray[np.float64]:
        """t − τ − D/c0 at capture k for emissions ``rows``."""
        return T[k] - tau[rows] - np.linalg.norm(P[k] - x[rows], axis=1) / c0

    # bisection over captures: lo = last capture with f <= 0 (-1: none), hi = lo + 1
    lo = np.full(E, -1, dtype=np.int64)
    hi = np.full(E, N, dtype=np.int64)
    while True:
        open_ = np.flatnonzero(hi - lo > 1)
        if open_.size == 0:
            break
        mid = (lo[open_] + hi[open_]) // 2
        neg = f(mid, open_) <= 0.0
        lo[open_[neg]] = mid[neg]
        hi[open_[~neg]] = mid[~neg]
    t = np.empty(E)
    vel = np.zeros((E, 3))
    held = (lo < 0) | (lo >= N - 1)  # before the first or after the last capture
    if np.any(held):
        i = np.flatnonzero(held)
        end = np.where(lo[i] < 0, 0, N - 1)
        t[i] = tau[i] + np.linalg.norm(P[end] - x[i], axis=1) / c0
    i = np.flatnonzero(~held)
    if i.size:
        k = lo[i]
        h = T[k + 1] - T[k]
        V = np.where((h > 0)[:, None], (P[k + 1] - P[k]) / np.where(h > 0, h, 1.0)[:, None], 0.0)
        A = P[k] - x[i]
        b = T[k] - tau[i]
        c2 = c0 * c0
        a2 = np.sum(V * V, axis=1) - c2
        b1 = np.sum(A * V, axis=1) - c2 * b
        g0 = np.sum(A * A, axis=1) - c2 * b * b
        disc = np.maximum(b1 * b1 - a2 * g0, 0.0)
        q = -(b1 + np.copysign(np.sqrt(disc), b1))
        with np.errstate(divide="ignore", invalid="ignore"):
            r1 = np.where(a2 != 0.0, q / a2, np.nan)
            r2 = np.where(q != 0.0, g0 / q, np.nan)
        # the retarded root: s + b >= 0 inside the interval (smallest such, for a
        # supersonic listener that meets the wave twice)
        tol = 1e-12 * (1.0 + np.abs(b) + h)
        ok1 = np.isfinite(r1) & (r1 + b >= -tol) & (r1 >= -tol) & (r1 <= h + tol)
        ok2 = np.isfinite(r2) & (r2 + b >= -tol) & (r2 >= -tol) & (r2 <= h + tol)
        s = np.where(ok1 & ok2, np.minimum(r1, r2), np.where(ok1, r1, np.where(ok2, r2, 0.0)))
        s = np.clip(s, 0.0, h)
        t[i] = T[k] + s
        vel[i] = V
    return t, vel


def arrivals(
    positions: NDArray[np.floating],
    times: NDArray[np.floating],
    listener: ListenerPath | NDArray[np.floating],
    *,
    c0: float = C0,
    layout: str | Layout | None = None,
) -> Arrivals:
    """Arrival time, distance, direction and panning gains of impulsive emissions.

    Parameters
    ----------
    positions : (E, 3) float
        Emission positions x (m).
    times : (E,) float
        Emission times τ, playback seconds since the path's first capture.
    listener : ListenerPath or (3,) float
        The listener's path, or a static position (m; forward +y, up +z).
    c0 : float
        Speed of sound (m/s).
    layout : str or Layout, optional
        Output layout; with it the gains ``(n_channels, E)`` of
        :func:`auralize.spatial.layouts.pan_gains` for each emission's direction in the
        listener's frame at its arrival.

    Returns
    -------
    Arrivals
        Time, distance, listener position, directions, Doppler factor and gains.

    Raises
    ------
    ParameterError
        Positions and times of different lengths or not finite, a ``c0``
        not > 0, a listener position that is not three finite numbers, or an
        unknown layout.

    Examples
    --------
    >>> a = arrivals(np.array([[0.0, 343.0, 0.0]]), np.array([0.5]), np.zeros(3))
    >>> float(a.time[0]), float(a.distance[0])
    (1.5, 343.0)

    With a layout, the gains of the direction the sound comes from (the
    listener's left, channel 0 of ``stereo``):

    >>> a = arrivals(np.array([[-2.0, 0, 0]]), np.array([0.0]), np.zeros(3), layout="stereo")
    >>> a.gains.round(6).tolist(), a.direction_local.round(6).tolist()
    ([[1.0], [0.0]], [[0.0, -1.0, 0.0]])
    """
    if isinstance(listener, ListenerPath) and listener.n_captures > 1:
        path = listener
        x, tau = _check(positions, times, c0)
        t, vel = _solve(x, tau, path, c0)
        ta = path.times[0] + t
        L = path.position_at(ta)
        fwd, up = path.orientation_at(ta)
    else:  # one place, one orientation: t = τ + D/c0
        if isinstance(listener, ListenerPath):
            assert listener.forward is not None and listener.up is not None
            p0, fwd, up = listener.positions[0], listener.forward[:1], listener.up[:1]
        else:
            p0, fwd, up = _position(listener), FORWARD[None], UP[None]
        x, tau = _check(positions, times, c0)
        L = np.broadcast_to(p0, x.shape)
        vel = None
    d_vec = x - L  # listener -> emitter
    D = np.sqrt(np.einsum("ij,ij->i", d_vec, d_vec))
    u = -d_vec / np.where(D > 0, D, 1.0)[:, None]
    if vel is None:
        t = tau + D / c0
        doppler = np.ones(D.size)
    else:
        # dt/dτ = 1 / (1 − Ḋ/c0) with Ḋ = û · V the listener's speed away from the emitter
        doppler = 1.0 / np.maximum(1.0 - np.sum(u * vel, axis=1) / c0, 1e-6)
    if fwd.shape[0] == 1:  # one orientation: a single rotation into (forward, left, up)
        f, w = fwd[0], up[0]
        left = np.array(
            [w[1] * f[2] - w[2] * f[1], w[2] * f[0] - w[0] * f[2], w[0] * f[1] - w[1] * f[0]]
        )
        local = u @ np.stack([f, left, w], axis=1)
    else:
        local = listener_frame(u, fwd, up)
    gains = None
    if layout is not None:
        gains = pan_gains(get_layout(layout), -local)
    note_arrivals(t, D)  # a part heard outdoors filters its output along these distances
    return Arrivals(t, D, np.array(L), u, local, doppler, gains)


def sparse_gains(gains: NDArray[np.floating]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Dense gains ``(n_channels, E)`` as per-emission lists ``(chans (E, K), gains (E, K))``.

    K is the largest number of non-zero gains of any emission (1 for mono, 2
    for pairwise VBAP, up to 3 for 3-D VBAP); unused entries have channel −1.

    Parameters
    ----------
    gains : (n_channels, E) float
        Panning gains of each emission (:attr:`Arrivals.gains`).

    Returns
    -------
    chans : (E, K) int64
        The channels of each emission's non-zero gains, in channel order (−1: unused).
    gains : (E, K) float
        Their gains (0 where unused).

    Examples
    --------
    >>> chans, g = sparse_gains(np.array([[1.0, 0.0], [0.0, 0.6], [0.0, 0.8]]))
    >>> chans.tolist(), g.tolist()
    ([[0, -1], [1, 2]], [[1.0, 0.0], [0.6, 0.8]])
    """
    g = np.asarray(gains, dtype=np.float64)
    if g.shape[0] == 1:  # mono
        return np.zeros((g.shape[1], 1), dtype=np.int64), np.ascontiguousarray(g.T)
    gt = np.ascontiguousarray(g.T)  # (E, n_channels)
    nz = gt != 0.0
    K = max(int(nz.sum(axis=1).max(initial=0)), 1)
    # the K channels of largest |gain| (all the non-zero ones), in channel order
    order = np.sort(np.argpartition(-np.abs(gt), K - 1, axis=1)[:, :K], axis=1)
    gk = np.take_along_axis(gt, order, axis=1)
    chans = np.where(gk != 0.0, order, -1).astype(np.int64)
    return chans, np.ascontiguousarray(gk)
