"""What a retarded-time render needs before its kernels run, in data seconds: the knot
times (the data's steps, padded), the listener's captures and orientation on the data's
clock (:func:`prepare_render`), the knot rows that can be heard, the listener's line on
each capture interval, and the checks that refuse nonsense (a listener absurdly far
from the data, an output window nothing reaches).  :mod:`auralize.emitters.synthesis`
renders from them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from auralize.emitters import C0
from auralize.errors import ListenerPathError, ParameterError
from auralize.listener import ListenerPath
from auralize.sources.detection import SourceTracks


@dataclass
class _Prepared:
    """A render's times and listener, in data seconds (:func:`prepare_render`): the
    padded knot times, the listener's captures (times, positions, velocity on each
    interval), its forward and up ``(N, 6)`` sampled from ``orient_clock[0]`` at rate
    ``orient_clock[1]``, the output's first time, samples per data second and length."""

    knot_times: NDArray[np.float64]
    capture_times: NDArray[np.float64]
    capture_pos: NDArray[np.float64]
    capture_vel: NDArray[np.float64]
    orient_table: NDArray[np.float64]
    orient_clock: NDArray[np.float64]
    t_start: float
    fs: float
    n_samples: int


def knot_times(tracks: SourceTracks) -> NDArray[np.float64]:
    """The synthesis's knot times: the data's steps padded with one silent step
    before the first and after the last (paper 003 §3.2.4.3: a source fades in
    and out over one step).

    Parameters
    ----------
    tracks : SourceTracks
        Its ``times`` ``(T,)``, s, strictly increasing.

    Returns
    -------
    ndarray, shape (T + 2,)
        Data seconds: ``times`` with ``times[0] - (times[1] - times[0])`` before and
        ``times[-1] + (times[-1] - times[-2])`` after (1 s either side of a
        single step).

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.emitters.synthesis import knot_times
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.ones((1, 3)),
    ...                   radius=np.full(1, 0.1), times=np.array([0.0, 0.1, 0.3]))
    >>> knot_times(tr).round(6).tolist()
    [-0.1, 0.0, 0.1, 0.3, 0.5]
    """
    t = np.asarray(tracks.times, dtype=np.float64)
    if t.size >= 2:
        d0, d1 = t[1] - t[0], t[-1] - t[-2]
    else:
        d0 = d1 = 1.0
    return np.concatenate([[t[0] - d0], t, [t[-1] + d1]])


def _pad_knots(tracks: SourceTracks) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    tn = knot_times(tracks)
    t = tracks.times
    q = np.zeros((tracks.n_sources, t.size + 2))
    q[:, 1:-1] = tracks.q / (4.0 * np.pi)
    return tn, q


def _tangents(tn: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Central-difference tangents dq/dτ at each knot (zero at the padded ends)."""
    m = np.zeros_like(q)
    if q.shape[1] > 2:
        m[:, 1:-1] = (q[:, 2:] - q[:, :-2]) / (tn[2:] - tn[:-2])
    return m


def padded_knots(
    tracks: SourceTracks,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Padded knot times, q/(4π) and tangents, cached on the tracks (block-wise
    and live rendering call the synthesis many times with the same tracks)."""
    key = (id(tracks.q), tracks.q.shape, id(tracks.times))
    cached = tracks.cache.get("knots")
    if cached is not None and cached[0] == key:
        return cached[1]
    tn, q = _pad_knots(tracks)
    out = (tn, np.ascontiguousarray(q), np.ascontiguousarray(_tangents(tn, q)))
    tracks.cache["knots"] = (key, out)
    return out


#: orientation table resolution (data seconds) and size cap
_ORIENT_DT = 1e-3
_ORIENT_MAX = 200_000


def _orientation_table(
    path: ListenerPath, tc: NDArray[np.float64], time_scale: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Forward/up (N, 6) sampled by slerp every ~1 ms of data time over the path."""
    span = float(tc[-1] - tc[0])
    n = int(min(max(np.ceil(span / _ORIENT_DT) + 1, 2), _ORIENT_MAX)) if span > 0 else 1
    tg = np.linspace(tc[0], tc[-1], n)
    fwd, up = path.orientation_at(path.times[0] + (tg - tc[0]) * time_scale)
    rate = (n - 1) / span if span > 0 else 0.0
    return np.ascontiguousarray(np.hstack([fwd, up])), np.array([tc[0], rate])


def prepare_render(
    tracks: SourceTracks,
    path: ListenerPath,
    *,
    rate: float,
    time_scale: float,
    c0: float,
    duration: float | None,
    bounds: tuple[float, ...] | None,
    start: float = 0.0,
    orientation: bool = True,
    lead: float = 0.0,
) -> _Prepared:
    """A render's times and listener on the data's clock, checked: the knot times,
    the listener's captures and their velocities, its orientation table, and the
    output's first time, rate and length.

    Playback time t_p on the path maps to data time ``t_first + lead + (t_p -
    path.times[0]) / time_scale``; audio sample n is at data time ``t_start + n /
    fs`` (docs/design.md, "Time").  Captures with equal times collapse (the last
    one wins); between captures the listener moves on straight lines.

    Parameters
    ----------
    tracks : SourceTracks
        The sources; their times set the knots and ``t_first``.
    path : ListenerPath
        Playback-time captures.
    rate : float
        Audio sample rate, Hz, > 0.
    time_scale : float
        Playback seconds per data second, > 0.
    c0 : float
        Speed of sound, m/s, > 0; the listener must move slower than it in
        data time.
    duration : float or None
        Playback seconds to render (None: the path's duration after ``start``).
    bounds : tuple or None
        Grid bounds ``(xmin, xmax, ymin, ymax, zmin, zmax)``, m, for
        :func:`check_distance` (None: not checked).
    start : float
        Playback seconds into the path of the first sample, >= 0.
    orientation : bool
        Whether to sample the listener's orientation (panned layouts); False
        leaves a single placeholder row.
    lead : float
        Data seconds from the data's first step to the first sample, >= 0.

    Returns
    -------
    _Prepared
        ``knot_times (T + 2,)`` s; ``capture_times (M,)`` data s,
        ``capture_pos (M, 3)`` m, ``capture_vel (M - 1, 3)`` m per data s;
        ``orient_table (N, 6)`` forward and up sampled every ~1 ms of data time
        from ``orient_clock[0]`` at rate ``orient_clock[1]``; ``t_start`` (data s),
        ``fs = rate · time_scale`` (samples per data s) and ``n_samples =
        round(duration · rate)``.

    Raises
    ------
    ParameterError
        A rate, time scale or speed of sound that is not a positive number, a
        negative ``lead`` or ``start``, or no duration left to render.
    ListenerPathError
        The listener moves as fast as sound in data time, or is absurdly far
        from ``bounds``.

    Examples
    --------
    A listener 343 m away, the data played at half speed:

    >>> import numpy as np
    >>> from auralize.emitters.synthesis import prepare_render
    >>> from auralize.listener import ListenerPath
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.ones((1, 4)),
    ...                   radius=np.full(1, 0.1), times=np.arange(4) * 0.1)
    >>> pr = prepare_render(tr, ListenerPath.point([343.0, 0, 0], duration=0.6),
    ...                     rate=8000, time_scale=2.0, c0=343.0, duration=None,
    ...                     bounds=None, start=0.2)
    >>> pr.t_start, pr.fs, pr.n_samples, pr.capture_times.tolist()
    (0.1, 16000.0, 3200, [0.0, 0.3])
    """
    if not (np.isfinite(rate) and rate > 0):
        raise ParameterError(f"rate must be a positive number of samples per second, got {rate!r}")
    if not (np.isfinite(time_scale) and time_scale > 0):
        raise ParameterError(f"time_scale must be > 0 (playback s per data s), got {time_scale!r}")
    if not (np.isfinite(c0) and c0 > 0):
        raise ParameterError(f"speed of sound c0 must be > 0 m/s, got {c0!r}")
    if not (np.isfinite(lead) and lead >= 0):
        raise ParameterError(f"lead must be >= 0 data seconds, got {lead!r}")
    if bounds is not None:
        check_distance(path, bounds)
    # collapse captures with equal times (the last one wins)
    keep = np.append(np.diff(path.times) > 0, True)
    ptimes, ppos = path.times[keep], path.positions[keep]
    t0 = tracks.t_first + lead
    tc = t0 + (ptimes - path.times[0]) / time_scale
    if tc.size >= 2:
        vc = np.diff(ppos, axis=0) / np.diff(tc)[:, None]
        speed = np.linalg.norm(vc, axis=1)
        if np.any(speed >= c0):
            i = int(np.argmax(speed))
            raise ListenerPathError(
                f"{path.source}: the listener moves at {speed[i]:.1f} m per data second between "
                f"captures {i} and {i + 1} (time_scale={time_scale:g}); synthesis needs it slower "
                f"than sound (c0={c0:g} m/s). Slow the path down or raise time_scale."
            )
    else:
        vc = np.zeros((0, 3))
    if not (np.isfinite(start) and start >= 0):
        raise ParameterError(f"start must be >= 0 playback seconds, got {start!r}")
    if duration is None:
        duration = path.duration - start
    if not (np.isfinite(duration) and duration > 0):
        raise ParameterError(
            f"nothing to render: duration {duration!r} s; give a path longer than one capture "
            f"or a positive duration"
        )
    n_samples = round(duration * rate)
    tn = knot_times(tracks)
    if orientation:
        otab, ot = _orientation_table(path, tc, time_scale)
    else:  # unpanned: the listener's orientation is not needed
        otab, ot = np.zeros((1, 6)), np.array([tc[0], 0.0])
    return _Prepared(
        knot_times=tn,
        capture_times=tc,
        capture_pos=np.ascontiguousarray(ppos),
        capture_vel=np.ascontiguousarray(vc),
        orient_table=otab,
        orient_clock=ot,
        t_start=t0 + start / time_scale,
        fs=float(rate) * time_scale,
        n_samples=int(n_samples),
    )


def source_extent(tracks: SourceTracks) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Bounding box of the source positions and the largest clamp radius (cached on
    the tracks while their positions and radii are the same arrays).

    Parameters
    ----------
    tracks : SourceTracks
        Its ``positions (K, 3)`` and ``radius (K,)``, m.

    Returns
    -------
    lo, hi : ndarray, shape (3,)
        Smallest and largest x, y, z of the sources, m (zeros without sources).
    r_max : float
        Largest ΔV radius, m, at least 1e-9 (0 without sources).

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.emitters.synthesis import source_extent
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.array([[0.0, 1, 2], [3.0, -1, 0]]),
    ...                   q=np.ones((2, 2)), radius=np.array([0.1, 0.25]),
    ...                   times=np.arange(2.0))
    >>> lo, hi, r = source_extent(tr)
    >>> lo.tolist(), hi.tolist(), r
    ([0.0, -1.0, 0.0], [3.0, 1.0, 2.0], 0.25)
    """
    key = (id(tracks.positions), id(tracks.radius))
    cached = tracks.cache.get("extent")
    if cached is not None and cached[0] == key:
        return cached[1]
    pos = np.asarray(tracks.positions, dtype=np.float64).reshape(-1, 3)
    if pos.shape[0] == 0:
        out = (np.zeros(3), np.zeros(3), 0.0)
    else:
        out = (pos.min(axis=0), pos.max(axis=0), float(np.max(tracks.radius, initial=1e-9)))
    tracks.cache["extent"] = (key, out)
    return out


def audible_rows(pr: _Prepared, tracks: SourceTracks, c0: float) -> tuple[int, int, float]:
    """Knot range [n_lo, n_hi] whose pieces can arrive inside the output window,
    and the largest source-listener distance D_max.

    Arrivals of piece n lie in [t_n, t_{n+1} + D_max/c0], D_max being the
    largest source-listener distance (the path is piecewise linear, so the
    farthest point of it is a capture).
    """
    if tracks.n_sources == 0:
        return 0, 0, 0.0
    lo_b, hi_b, r_max = source_extent(tracks)
    far = np.maximum(np.abs(pr.capture_pos - lo_b), np.abs(pr.capture_pos - hi_b))
    d_max = float(np.max(np.linalg.norm(far, axis=1))) + r_max
    t_end = pr.t_start + pr.n_samples / pr.fs
    tn = pr.knot_times
    n_lo = int(np.searchsorted(tn, pr.t_start - d_max / c0, side="left")) - 1
    n_hi = int(np.searchsorted(tn, t_end, side="right"))
    return max(n_lo, 0), min(n_hi, tn.size - 1), d_max


#: a listener farther from the data than this many times the data's diagonal
#: (and than :data:`MAX_DISTANCE_M`) is taken for a mistake
MAX_DISTANCE_FACTOR = 1e4
MAX_DISTANCE_M = 1e6


def box_distances(
    points: NDArray[np.float64], lo: NDArray[np.float64], hi: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Nearest and farthest distance from each point to an axis-aligned box.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Positions, m.
    lo, hi : ndarray, shape (3,)
        The box's smallest and largest corner, m.

    Returns
    -------
    near, far : ndarray, shape (N,)
        Distance to the nearest point of the box (0 inside it) and to its
        farthest corner, m.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.emitters.synthesis import box_distances
    >>> near, far = box_distances(np.array([[3.0, 0.5, 0.5], [0.5, 0.5, 0.5]]),
    ...                           np.zeros(3), np.ones(3))
    >>> near.tolist(), far.round(4).tolist()
    ([2.0, 0.0], [3.0822, 0.866])
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    near = np.linalg.norm(np.maximum(np.maximum(lo - p, p - hi), 0.0), axis=1)
    far = np.linalg.norm(np.maximum(np.abs(p - lo), np.abs(p - hi)), axis=1)
    return near, far


def check_distance(path: ListenerPath, bounds: tuple[float, ...]) -> None:
    """Raise :class:`ListenerPathError` if the listener is absurdly far from the data.

    The listener may be anywhere (outside the grid is the usual far-field
    case); a capture farther from the grid's box than
    ``MAX_DISTANCE_FACTOR`` times its diagonal and than ``MAX_DISTANCE_M``
    metres is nonsense (a unit mistake, a stray coordinate).

    Parameters
    ----------
    path : ListenerPath
        The listener's captures (positions in m).
    bounds : tuple of 6 float
        The grid's box ``(xmin, xmax, ymin, ymax, zmin, zmax)``, m.

    Raises
    ------
    ListenerPathError
        Naming the first capture that is too far, its distance and the limit.

    Examples
    --------
    >>> from auralize.emitters.synthesis import check_distance
    >>> from auralize.listener import ListenerPath
    >>> box = (0.0, 1.0, 0.0, 1.0, 0.0, 1.0)
    >>> check_distance(ListenerPath.point([5e5, 0, 0], duration=1.0), box)  # 500 km: allowed
    >>> check_distance(ListenerPath.point([2e6, 0, 0], duration=1.0), box)
    Traceback (most recent call last):
    ...
    auralize.errors.ListenerPathError: point: capture 0 at t=0 s, ... listeners must be within 1e+06 m of the data
    """
    b = np.asarray(bounds, dtype=np.float64).reshape(3, 2)
    near, _ = box_distances(path.positions, b[:, 0], b[:, 1])
    diag = float(np.linalg.norm(b[:, 1] - b[:, 0]))
    limit = max(MAX_DISTANCE_FACTOR * diag, MAX_DISTANCE_M)
    if np.any(near > limit):
        i = int(np.argmax(near))
        raise ListenerPathError(
            f"{path.source}: capture {i} at t={path.times[i]:g} s, position "
            f"{np.round(path.positions[i], 4).tolist()} is {near[i]:.4g} m from the grid "
            f"x[{b[0, 0]:g}, {b[0, 1]:g}] y[{b[1, 0]:g}, {b[1, 1]:g}] z[{b[2, 0]:g}, {b[2, 1]:g}]; "
            f"listeners must be within {limit:.4g} m of the data"
        )


def check_arrival(
    tracks: SourceTracks,
    path: ListenerPath,
    *,
    time_scale: float,
    duration: float | None = None,
    c0: float = C0,
    lead: float = 0.0,
) -> None:
    """Raise :class:`ListenerPathError` when no sound can reach the listener inside the
    output window (the data ends before the window starts, or the nearest sound
    arrives after it ends).

    Sound of the data arrives between ``t_first + D_near / c0`` and ``t_last +
    D_far / c0`` (the reachable sources of paper 003 §3.2.4.2), D measured to the
    sources' bounding box from the listener's captures.

    Parameters
    ----------
    tracks : SourceTracks
        The sources (without sources nothing is refused).
    path : ListenerPath
        The listener's captures.
    time_scale : float
        Playback seconds per data second.
    duration : float, optional
        Playback seconds (default: the path's duration).
    c0 : float
        Speed of sound, m/s.
    lead : float
        Data seconds between the data's first step and the output's first sample.

    Raises
    ------
    ListenerPathError
        Nothing can be heard: the message gives the arrival window, the
        output's window and the nearest source's distance.
    ParameterError
        Invalid times or speed of sound (as :func:`prepare_render`).

    Examples
    --------
    Data 0.3 s long heard from 1 km: its first sound arrives after 2.9 s.

    >>> import numpy as np
    >>> from auralize.emitters.synthesis import check_arrival
    >>> from auralize.listener import ListenerPath
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.ones((1, 4)),
    ...                   radius=np.full(1, 0.1), times=np.arange(4) * 0.1)
    >>> check_arrival(tr, ListenerPath.point([1000.0, 0, 0], duration=4.0), time_scale=1.0)
    >>> check_arrival(tr, ListenerPath.point([1000.0, 0, 0], duration=1.0), time_scale=1.0)
    Traceback (most recent call last):
    ...
    auralize.errors.ListenerPathError: point: nothing can be heard: ... move the listener closer, render longer, or use a smaller time scale
    """
    pr = prepare_render(
        tracks,
        path,
        rate=1000.0,
        time_scale=time_scale,
        c0=c0,
        duration=duration,
        bounds=None,
        orientation=False,
        lead=lead,
    )
    source = path.source
    if tracks.n_sources == 0 or pr.n_samples == 0:
        return
    lo_b, hi_b, _ = source_extent(tracks)
    near, far = box_distances(pr.capture_pos, lo_b, hi_b)
    t_end = pr.t_start + pr.n_samples / pr.fs
    first = tracks.t_first + float(np.min(near)) / c0
    last = tracks.t_last + float(np.max(far)) / c0
    if first >= t_end or last < pr.t_start:
        raise ListenerPathError(
            f"{source}: nothing can be heard: sound from the data reaches the listener between "
            f"data times {first:.6g} and {last:.6g} s, the output covers {pr.t_start:.6g} .. "
            f"{t_end:.6g} s (nearest source {float(np.min(near)):.4g} m away at c0={c0:g} m/s); "
            f"move the listener closer, render longer, or use a smaller time scale"
        )


def capture_interval_lines(pr: _Prepared, c0: float) -> NDArray[np.float64]:
    """The listener's line on each capture interval j, at row j + 1 (M + 1, 9):
    its position at time tr, velocity, tr, c0² - V² and 1/(c0² - V²); held
    (V = 0) before the first capture and after the last."""
    m = pr.capture_times.size
    interval_lines = np.zeros((m + 1, 9))
    interval_lines[0, :3], interval_lines[0, 6] = pr.capture_pos[0], pr.capture_times[0]
    interval_lines[m, :3], interval_lines[m, 6] = pr.capture_pos[-1], pr.capture_times[-1]
    if m >= 2:
        interval_lines[1:m, :3], interval_lines[1:m, 3:6], interval_lines[1:m, 6] = (
            pr.capture_pos[:-1],
            pr.capture_vel,
            pr.capture_times[:-1],
        )
    interval_lines[:, 7] = c0 * c0 - np.sum(interval_lines[:, 3:6] ** 2, axis=1)
    interval_lines[:, 8] = 1.0 / interval_lines[:, 7]
    return interval_lines


def interpolate_knots(
    tn: NDArray[np.float64],
    q: NDArray[np.float64],
    m: NDArray[np.float64],
    tau: NDArray[np.float64],
    interp: str,
) -> NDArray[np.float64]:
    inside = (tau >= tn[0]) & (tau <= tn[-1])
    n = np.clip(np.searchsorted(tn, tau, side="right") - 1, 0, tn.size - 2)
    h = tn[n + 1] - tn[n]
    s = np.clip((tau - tn[n]) / h, 0, 1)
    if interp == "linear":
        val = q[n] + (q[n + 1] - q[n]) * s
    else:
        s2, s3 = s * s, s * s * s
        val = (
            (2 * s3 - 3 * s2 + 1) * q[n]
            + (s3 - 2 * s2 + s) * m[n] * h
            + (-2 * s3 + 3 * s2) * q[n + 1]
            + (s3 - s2) * m[n + 1] * h
        )
    return np.where(inside, val, 0.0)
