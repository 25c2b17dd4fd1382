"""ListenerPath: timed listener positions and orientations (paper 003 §4.1).

Captures are interpolated linearly in position and by quaternion slerp in
orientation.  Times are playback seconds, non-decreasing; positions are in
data coordinates (metres).  Orientation is given by unit ``forward`` and
``up`` vectors (default forward +y, up +z).

CSV format (docs/design.md): header ``t,x,y,z`` plus optional
``fx,fy,fz,ux,uy,uz``.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from auralize.errors import ListenerPathError, ParameterError
from auralize.runtime.files import atomic_write, read_timed_csv

FORWARD = np.array([0.0, 1.0, 0.0])
UP = np.array([0.0, 0.0, 1.0])


@dataclass
class ListenerPath:
    """Timed listener captures: positions and orientations at playback times.

    Parameters
    ----------
    times : array_like, shape (N,)
        Playback seconds of the captures, non-decreasing (N >= 1).
    positions : array_like, shape (N, 3)
        Listener positions in data coordinates, m (within ±:data:`MAX_COORDINATE_M`).
    forward, up : array_like, shape (N, 3), optional
        Forward and up vectors (normalised here; ``up`` is made orthogonal to
        ``forward``).  Default +y and +z at every capture.
    source : str
        Where the path came from (for messages): a file name, ``"orbit"`` ...

    Raises
    ------
    ListenerPathError
        No capture; shapes that disagree; NaN/Inf; decreasing times; zero or
        parallel orientation vectors; a coordinate beyond :data:`MAX_COORDINATE_M`.

    Examples
    --------
    >>> p = ListenerPath.line((0, 0, 0), (10, 0, 0), duration=2.0)
    >>> p.position_at(np.array([1.0]))
    array([[5., 0., 0.]])
    >>> ListenerPath([0.0, 1.0], [[0, 0, 0], [1, 0, 0]], up=[[0, 1, 1], [0, 0, 1]]).up[0]
    array([0., 0., 1.])
    """

    def _repr_html_(self) -> str:
        """Notebook display (:mod:`auralize.runtime.notebook`)."""
        from auralize.runtime.notebook import path_html

        return path_html(self)

    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    forward: NDArray[np.float64] | None = None
    up: NDArray[np.float64] | None = None
    source: str = "<memory>"

    def __post_init__(self) -> None:
        self.times = np.asarray(self.times, dtype=np.float64).reshape(-1)
        self.positions = np.asarray(self.positions, dtype=np.float64).reshape(-1, 3)
        n = self.times.size
        if n == 0:
            raise ListenerPathError(f"{self.source}: a listener path needs at least one capture")
        if self.positions.shape[0] != n:
            raise ListenerPathError(
                f"{self.source}: {n} times but {self.positions.shape[0]} positions"
            )
        self.forward = _unit_rows(
            np.broadcast_to(FORWARD, (n, 3)) if self.forward is None else self.forward,
            n,
            "forward",
            self.source,
        )
        self.up = _unit_rows(
            np.broadcast_to(UP, (n, 3)) if self.up is None else self.up, n, "up", self.source
        )
        for name, arr in (("times", self.times), ("positions", self.positions)):
            if not np.all(np.isfinite(arr)):
                raise ListenerPathError(f"{self.source}: {name} contain NaN or Inf")
        big = np.abs(self.positions).max(initial=0.0)
        if big > MAX_COORDINATE_M:
            raise ListenerPathError(
                f"{self.source}: a position coordinate is {big:g} m; positions must be within "
                f"±{MAX_COORDINATE_M:g} m (sound takes about a century to cross that)"
            )
        d = np.diff(self.times)
        if np.any(d < 0):
            i = int(np.argmax(d < 0))
            raise ListenerPathError(
                f"{self.source}: times must be non-decreasing; capture {i + 1} has "
                f"t={self.times[i + 1]:g} s after t={self.times[i]:g} s"
            )
        # orthogonalise up against forward
        f, u = self.forward, self.up
        u = u - np.sum(u * f, axis=1, keepdims=True) * f
        nu = np.linalg.norm(u, axis=1)
        if np.any(nu < 1e-9):
            i = int(np.argmax(nu < 1e-9))
            raise ListenerPathError(
                f"{self.source}: forward and up are parallel at capture {i} (t={self.times[i]:g} s)"
            )
        self.up = u / nu[:, None]

    # ------------------------------------------------------------- builders
    @classmethod
    def point(
        cls,
        position: tuple[float, float, float] | NDArray[np.floating],
        *,
        duration: float,
        forward: tuple[float, float, float] = (0, 1, 0),
        up: tuple[float, float, float] = (0, 0, 1),
    ) -> ListenerPath:
        """A static listener for ``duration`` seconds.

        Parameters
        ----------
        position : array_like, shape (3,)
            Where the listener stands, m.
        duration : float
            Playback seconds, > 0.
        forward, up : array_like, shape (3,)
            Orientation (default forward +y, up +z).

        Returns
        -------
        ListenerPath
            Two captures, at 0 and ``duration``.

        Raises
        ------
        ListenerPathError
            ``duration`` is not a positive number of seconds.

        Examples
        --------
        >>> p = ListenerPath.point((1.0, 2.0, 0.0), duration=3.0)
        >>> p.times.tolist(), p.position_at(1.5).tolist()
        ([0.0, 3.0], [[1.0, 2.0, 0.0]])
        """
        _check_duration(duration)
        p = np.asarray(position, dtype=np.float64).reshape(3)
        return cls(
            np.array([0.0, duration]),
            np.stack([p, p]),
            np.stack([forward, forward]),
            np.stack([up, up]),
            source="point",
        )

    @classmethod
    def line(
        cls,
        start: tuple[float, float, float] | NDArray[np.floating],
        end: tuple[float, float, float] | NDArray[np.floating],
        *,
        duration: float,
        n: int = 2,
        face: Literal["forward", "fixed"] = "forward",
    ) -> ListenerPath:
        """Straight line from ``start`` to ``end`` at constant speed.

        Parameters
        ----------
        start, end : array_like, shape (3,)
            First and last position, m.
        duration : float
            Playback seconds from ``start`` to ``end``, > 0.
        n : int
            Number of captures (>= 2), evenly spaced.
        face : {"forward", "fixed"}
            ``"forward"`` looks along the motion; ``"fixed"`` keeps forward +y
            (also used when ``start == end``).

        Returns
        -------
        ListenerPath

        Raises
        ------
        ListenerPathError
            A bad ``duration`` or ``n``.

        Examples
        --------
        >>> p = ListenerPath.line((0, 0, 0), (4, 0, 0), duration=2.0, n=3)
        >>> p.positions[:, 0].tolist(), p.forward[0].tolist()
        ([0.0, 2.0, 4.0], [1.0, 0.0, 0.0])
        """
        _check_duration(duration)
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 2:
            raise ListenerPathError(f"a line needs at least 2 captures, got n={n!r}")
        _check_captures(int(n), f"a line of {n} captures")
        a = np.asarray(start, dtype=np.float64).reshape(3)
        b = np.asarray(end, dtype=np.float64).reshape(3)
        w = np.linspace(0.0, 1.0, max(int(n), 2))[:, None]
        pos = a + w * (b - a)
        fwd = None
        if face == "forward" and np.linalg.norm(b - a) > 0:
            d = (b - a) / np.linalg.norm(b - a)
            fwd = np.broadcast_to(d, pos.shape)
            up = np.broadcast_to(UP if abs(d @ UP) < 0.99 else np.array([1.0, 0, 0]), pos.shape)
            return cls(w[:, 0] * duration, pos, fwd, up, source="line")
        return cls(w[:, 0] * duration, pos, source="line")

    @classmethod
    def orbit(
        cls,
        center: tuple[float, float, float] | NDArray[np.floating],
        *,
        radius: float,
        duration: float,
        turns: float = 1.0,
        height: float = 0.0,
        rate_hz: float | None = 20.0,
        face: str = "center",
    ) -> ListenerPath:
        """Horizontal circle around ``center`` (counter-clockwise seen from +z).

        Parameters
        ----------
        center : array_like, shape (3,)
            Centre of the circle, m.
        radius : float
            Radius of the circle, m, > 0.
        duration : float
            Playback seconds of the orbit, > 0.
        turns : float
            Turns over ``duration`` (negative: clockwise).
        height : float
            Height of the circle above ``center``, m.
        rate_hz : float or None
            Captures per playback second; None: as often as the circle needs,
            every :data:`ORBIT_STEP_RAD` of arc, so that the polyline of
            captures is within 10⁻⁴ of the radius of the circle.  At least 3
            captures either way.
        face : {"center", "forward", "fixed", "sweep"}
            ``"center"`` looks at the centre; ``"forward"`` along the motion;
            ``"fixed"`` along +y throughout (a fixed world orientation);
            ``"sweep"`` turns the head so that the centre passes around the
            listener (front, left, back, right) :data:`SWEEP_TURNS` times over
            the orbit, whatever part of a turn the orbit covers: every speaker
            of a layout hears the data, also when their sound lasts only part
            of the render.

        Returns
        -------
        ListenerPath

        Raises
        ------
        ListenerPathError
            A bad duration, radius, rate, turns, height or face; more captures
            than memory holds.

        Examples
        --------
        >>> p = ListenerPath.orbit((0, 0, 0), radius=2.0, duration=1.0, rate_hz=4)
        >>> p.n_captures, np.round(p.position_at(0.25), 12).tolist(), p.forward[0].tolist()
        (5, [[0.0, 2.0, 0.0]], [-1.0, 0.0, 0.0])
        """
        _check_duration(duration)
        if not radius > 0:
            raise ListenerPathError(f"orbit radius must be > 0, got {radius!r}")
        if rate_hz is not None and not (
            isinstance(rate_hz, int | float) and math.isfinite(rate_hz) and rate_hz > 0
        ):
            raise ListenerPathError(f"orbit rate_hz must be a positive number, got {rate_hz!r}")
        for name, v in (("radius", radius), ("turns", turns), ("height", height)):
            if not math.isfinite(v):
                raise ListenerPathError(f"orbit {name} must be a finite number, got {v!r}")
        if face not in ORBIT_FACES:
            raise ListenerPathError(
                f"orbit face must be one of {', '.join(ORBIT_FACES)}, got {face!r}"
            )
        c = np.asarray(center, dtype=np.float64).reshape(3)
        if rate_hz is None:
            arc = 2 * np.pi * abs(turns)
            n = max(int(math.ceil(arc / ORBIT_STEP_RAD)) + 1, 3)
            if face == "sweep":  # slerp between captures follows a steady turn of the head
                n = max(n, int(math.ceil(2 * np.pi * (SWEEP_TURNS + abs(turns)) / (np.pi / 8))) + 1)
        else:
            _check_captures(duration * rate_hz, f"an orbit of {duration:g} s at {rate_hz:g} Hz")
            n = max(int(math.ceil(duration * rate_hz)) + 1, 3)
        _check_captures(n, f"an orbit of {n} captures")
        t = np.linspace(0.0, duration, n)
        ang = 2 * np.pi * turns * t / duration
        pos = c + np.stack([radius * np.cos(ang), radius * np.sin(ang), np.full(n, height)], 1)
        if face == "center":
            fwd = c - pos
            fwd[:, 2] = 0.0
        elif face == "forward":
            fwd = np.stack([-np.sin(ang), np.cos(ang), np.zeros(n)], 1) * (
                1.0 if turns >= 0 else -1.0
            )
        elif face == "fixed":
            fwd = np.broadcast_to(np.array([0.0, 1.0, 0.0]), pos.shape).copy()
        else:  # sweep: the centre's azimuth in the listener's frame goes once round
            to_centre = ang + np.pi
            heading = to_centre - 2 * np.pi * SWEEP_TURNS * t / duration
            fwd = np.stack([np.cos(heading), np.sin(heading), np.zeros(n)], 1)
        return cls(t, pos, fwd, np.broadcast_to(UP, pos.shape), source="orbit")

    # -------------------------------------------------------------- queries
    @property
    def duration(self) -> float:
        """Playback seconds from the first capture to the last.

        Examples
        --------
        >>> ListenerPath([0.5, 2.0], np.zeros((2, 3))).duration
        1.5
        """
        return float(self.times[-1] - self.times[0])

    @property
    def n_captures(self) -> int:
        """Number of captures N.

        Examples
        --------
        >>> ListenerPath.line((0, 0, 0), (1, 0, 0), duration=1.0, n=5).n_captures
        5
        """
        return int(self.times.size)

    def position_at(self, t: NDArray[np.floating] | float) -> NDArray[np.float64]:
        """Listener positions at playback times, interpolated linearly.

        Parameters
        ----------
        t : float or array_like, shape (M,)
            Playback seconds; before the first capture or after the last the
            position is held.

        Returns
        -------
        ndarray, shape (M, 3)
            Positions, m.

        Examples
        --------
        >>> p = ListenerPath.line((0, 0, 0), (10, 0, 0), duration=2.0)
        >>> p.position_at([0.5, 3.0])[:, 0].tolist()
        [2.5, 10.0]
        """
        tt = np.atleast_1d(np.asarray(t, dtype=np.float64))
        return np.stack([np.interp(tt, self.times, self.positions[:, a]) for a in range(3)], 1)

    def quaternions(self) -> NDArray[np.float64]:
        """Orientation of each capture as a unit quaternion.

        The quaternion rotates the reference frame (forward +y, up +z) onto
        the capture's (forward, up).  Consecutive quaternions share a
        hemisphere so slerp takes the short way.

        Returns
        -------
        ndarray, shape (N, 4)
            Unit quaternions (w, x, y, z).

        Examples
        --------
        >>> p = ListenerPath([0, 1], np.zeros((2, 3)), forward=[[0, 1, 0], [-1, 0, 0]])
        >>> np.round(p.quaternions(), 6).tolist()   # identity, then 90° about +z
        [[1.0, 0.0, 0.0, 0.0], [0.707107, 0.0, 0.0, 0.707107]]
        """
        assert self.forward is not None and self.up is not None
        f, u = self.forward, self.up
        r = np.cross(f, u)
        mats = np.stack([r, f, u], axis=2)  # columns right, forward, up
        q = _mat_to_quat(mats)
        for i in range(1, q.shape[0]):
            if q[i] @ q[i - 1] < 0:
                q[i] = -q[i]
        return q

    def orientation_at(
        self, t: NDArray[np.floating] | float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Forward and up vectors at playback times, by slerp between captures.

        Parameters
        ----------
        t : float or array_like, shape (M,)
            Playback seconds (held before the first and after the last capture).

        Returns
        -------
        forward, up : ndarray, shape (M, 3)
            Unit vectors in data coordinates.

        Examples
        --------
        >>> p = ListenerPath([0, 1], np.zeros((2, 3)), forward=[[0, 1, 0], [-1, 0, 0]])
        >>> f, u = p.orientation_at(0.5)
        >>> np.round(f, 6).tolist(), u.tolist()
        ([[-0.707107, 0.707107, 0.0]], [[0.0, 0.0, 1.0]])
        """
        tt = np.atleast_1d(np.asarray(t, dtype=np.float64))
        q = self.quaternions()
        if self.n_captures == 1:
            qi = np.repeat(q, tt.size, axis=0)
        else:
            s = np.clip(np.searchsorted(self.times, tt, side="right") - 1, 0, self.n_captures - 2)
            span = self.times[s + 1] - self.times[s]
            w = np.where(
                span > 0, np.clip((tt - self.times[s]) / np.where(span > 0, span, 1), 0, 1), 0.0
            )
            qi = _slerp(q[s], q[s + 1], w)
        return _quat_axis(qi, FORWARD), _quat_axis(qi, UP)

    def speeds(self) -> NDArray[np.float64]:
        """Speed on each capture interval.

        Returns
        -------
        ndarray, shape (N - 1,)
            m per playback second; inf where the listener jumps (a move in
            zero time), 0 where it stands still.

        Examples
        --------
        >>> ListenerPath([0, 1, 1, 3], [[0, 0, 0], [2, 0, 0], [3, 0, 0], [3, 0, 0]]).speeds()
        array([ 2., inf,  0.])
        """
        dt = np.diff(self.times)
        dp = np.linalg.norm(np.diff(self.positions, axis=0), axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(dt > 0, dp / np.where(dt > 0, dt, 1), np.where(dp > 0, np.inf, 0.0))

    # ------------------------------------------------------------------ I/O
    def to_csv(self, path: str | Path) -> None:
        """Write the path as CSV ``t,x,y,z,fx,fy,fz,ux,uy,uz``, atomically.

        Parameters
        ----------
        path : str or Path
            The file to write (replaced as a whole, or left as it was).

        Raises
        ------
        OutputError
            The file cannot be written.

        Examples
        --------
        >>> out = Path("path.csv")   # examples run in a temporary folder
        >>> ListenerPath.point((1, 0, 0), duration=2.0).to_csv(out)
        >>> out.read_text().splitlines()[1]
        '0,1,0,0,0,1,0,0,0,1'
        >>> ListenerPath.from_csv(out).duration
        2.0
        """
        buf = io.StringIO()
        buf.write(csv_header() + "\n")
        for row in self.rows():
            buf.write(format_row(row) + "\n")
        atomic_write(Path(path), buf.getvalue().encode())

    def rows(self) -> NDArray[np.float64]:
        """The captures as the rows of the CSV format (:func:`csv_header`).

        Returns
        -------
        ndarray, shape (N, 10)
            ``t, x, y, z, fx, fy, fz, ux, uy, uz`` per capture.

        Examples
        --------
        >>> ListenerPath.point((1, 2, 3), duration=1.0).rows()[1].tolist()
        [1.0, 1.0, 2.0, 3.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        """
        assert self.forward is not None and self.up is not None
        return np.column_stack([self.times, self.positions, self.forward, self.up])

    @classmethod
    def from_csv(cls, path: str | Path) -> ListenerPath:
        """Read a path CSV (header ``t,x,y,z`` [``,fx,fy,fz,ux,uy,uz``]).

        Parameters
        ----------
        path : str or Path
            The CSV file (see the module docstring for its format).

        Returns
        -------
        ListenerPath

        Raises
        ------
        FormatError
            The file does not exist or cannot be read as a path CSV (missing
            columns, non-numbers ...).
        ListenerPathError
            The captures do not make a path (times that decrease, zero
            orientation vectors ...).

        Examples
        --------
        >>> f = Path("walk.csv")
        >>> _ = f.write_text("t,x,y,z\\n0,0,0,0\\n2,4,0,0\\n")
        >>> ListenerPath.from_csv(f).position_at(1.0).tolist()
        [[2.0, 0.0, 0.0]]
        """
        a, has_orient, src = read_timed_csv(
            path, what="listener path", optional=["fx", "fy", "fz", "ux", "uy", "uz"]
        )
        if has_orient:
            return cls(a[:, 0], a[:, 1:4], a[:, 4:7], a[:, 7:10], source=src)
        return cls(a[:, 0], a[:, 1:4], source=src)


#: what an orbit's listener faces (:meth:`ListenerPath.orbit`)
ORBIT_FACES = ("sweep", "center", "forward", "fixed")
#: how many times the data pass around a ``face="sweep"`` orbit's listener
SWEEP_TURNS = 2.0
#: arc between the captures of an orbit captured as often as it needs: the polyline
#: then departs from the circle by r (1 − cos(θ/2)) ≈ 10⁻⁴ r
ORBIT_STEP_RAD = 0.028

#: default listener distance: the orbit's radius in half-diagonals of the data's box
#: (nearest and farthest source then differ by at most 3× in distance, ~10 dB)
ORBIT_RADIUS_FACTOR = 2.0


def _box(bounds: tuple[float, ...] | NDArray[np.floating]) -> tuple[NDArray[np.float64], float]:
    b = np.asarray(bounds, dtype=np.float64).reshape(3, 2)
    if not np.all(np.isfinite(b)) or np.any(b[:, 1] < b[:, 0]):
        raise ListenerPathError(
            f"bounds must be finite (xmin, xmax, ymin, ymax, zmin, zmax), "
            f"got {np.asarray(bounds).tolist()}"
        )
    half = 0.5 * float(np.linalg.norm(b[:, 1] - b[:, 0]))
    return b.mean(axis=1), half if half > 0 else 1.0


def orbit_around(
    bounds: tuple[float, ...] | NDArray[np.floating],
    *,
    duration: float,
    turns: float = 1.0,
    radius: float | None = None,
    rate_hz: float | None = None,
    face: str = "sweep",
) -> ListenerPath:
    """A horizontal orbit around the centre of ``bounds`` (the data's box).

    Parameters
    ----------
    bounds : array_like, shape (6,)
        ``(xmin, xmax, ymin, ymax, zmin, zmax)`` of the data, m.
    duration : float
        Playback seconds, > 0.
    turns : float
        Turns over ``duration``.
    radius : float, optional
        m; default :data:`ORBIT_RADIUS_FACTOR` half-diagonals of the box:
        outside the data, close enough that every source is heard (at most
        3× farther than the nearest).
    rate_hz : float, optional
        Captures per playback second; default as often as the circle needs.
    face : {"sweep", "center", "forward", "fixed"}
        See :meth:`ListenerPath.orbit`.  By default the listener's head turns
        so that the data pass around it: on a speaker layout every channel
        carries them in turn.

    Returns
    -------
    ListenerPath

    Raises
    ------
    ListenerPathError
        Bounds that are not finite or have max < min; a bad orbit parameter.

    Examples
    --------
    >>> p = orbit_around((0, 2, 0, 2, 0, 0), duration=1.0, face="center")
    >>> round(float(np.linalg.norm(p.positions[0] - [1, 1, 0])), 6)   # 2 half-diagonals
    2.828427
    """
    c, half = _box(bounds)
    r = ORBIT_RADIUS_FACTOR * half if radius is None else radius
    p = ListenerPath.orbit(c, radius=r, duration=duration, turns=turns, rate_hz=rate_hz, face=face)
    p.source = "orbit"
    return p


def line_past(
    bounds: tuple[float, ...] | NDArray[np.floating],
    *,
    duration: float,
    length: float | None = None,
) -> ListenerPath:
    """A straight fly-by along +x past the data's box, facing along the motion.

    The line runs :data:`ORBIT_RADIUS_FACTOR` half-diagonals in front of the
    box's centre (towards −y), from two half-diagonals on the left of it to two
    on the right (or ``length`` metres if that is shorter, centred).

    Parameters
    ----------
    bounds : array_like, shape (6,)
        ``(xmin, xmax, ymin, ymax, zmin, zmax)`` of the data, m.
    duration : float
        Playback seconds, > 0.
    length : float, optional
        Largest length of the line, m.

    Returns
    -------
    ListenerPath

    Raises
    ------
    ListenerPathError
        Bounds that are not finite or have max < min; a bad duration.

    Examples
    --------
    >>> p = line_past((-1, 1, -1, 1, -1, 1), duration=2.0, length=2.0)
    >>> np.round(p.positions, 4).tolist()
    [[-1.0, -3.4641, 0.0], [1.0, -3.4641, 0.0]]
    """
    c, half = _box(bounds)
    off = np.array([0.0, -ORBIT_RADIUS_FACTOR * half, 0.0])
    reach = ORBIT_RADIUS_FACTOR * half
    if length is not None and length > 0:
        reach = min(reach, 0.5 * length)
    d = np.array([reach, 0.0, 0.0])
    return ListenerPath.line(c + off - d, c + off + d, duration=duration)


def near_path(points: NDArray[np.float64], path: ListenerPath, dist: float) -> NDArray[np.bool_]:
    """Which ``points (K, 3)`` lie within about ``dist`` (m) of the polyline of
    the listener's captures: all points within ``dist`` of it, none farther
    than ``dist`` + h/2, h the spacing of the points on the polyline that the
    test uses (``dist / 4``, or longer on a path more than 50,000 ``dist``
    long: at most 200,000 points).

    Parameters
    ----------
    points : ndarray, shape (K, 3)
        Positions in data coordinates, m.
    path : ListenerPath
        The listener's captures (a point or a polyline).
    dist : float
        Distance, m.

    Returns
    -------
    ndarray of bool, shape (K,)
        True for the points near the path.

    Examples
    --------
    >>> path = ListenerPath(np.array([0.0, 1.0]), np.array([[0.0, 0, 0], [10.0, 0, 0]]))
    >>> near_path(np.array([[5.0, 0.5, 0], [5.0, 3.0, 0]]), path, 1.0).tolist()
    [True, False]
    """
    from scipy.spatial import cKDTree

    pts = np.asarray(path.positions, dtype=np.float64).reshape(-1, 3)
    h = 0.0
    if pts.shape[0] >= 2:
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        h = max(0.25 * dist, float(seg.sum()) / 200_000)
        m = np.maximum(np.ceil(seg / h), 1).astype(np.int64)
        i = np.repeat(np.arange(seg.size), m)
        f = (np.arange(int(m.sum())) - np.repeat(np.cumsum(m) - m, m)) / np.repeat(m, m)
        pts = np.concatenate([pts[i] + f[:, None] * (pts[i + 1] - pts[i]), pts[-1:]])
    d, _ = cKDTree(pts).query(points, distance_upper_bound=dist + 0.5 * h)
    return np.asarray(np.isfinite(d))


def describe_path(path: ListenerPath) -> str:
    """One phrase saying where the listener is (for reports).

    Parameters
    ----------
    path : ListenerPath

    Returns
    -------
    str
        Its position when it stands still, else its source, captures, duration
        and bounding box.

    Examples
    --------
    >>> describe_path(ListenerPath.point((1, 2, 3), duration=1.0))
    'at (1, 2, 3) m'
    >>> describe_path(ListenerPath.line((0, 0, 0), (4, 0, 0), duration=2.0))
    'line path of 2 captures over 2 s within x[0, 4] y[0, 0] z[0, 0] m'
    """
    p = path.positions
    if np.allclose(p, p[0]):
        return f"at ({', '.join(f'{v:.4g}' for v in p[0])}) m"
    lo, hi = p.min(axis=0), p.max(axis=0)
    return (
        f"{path.source} path of {path.n_captures} captures over {path.duration:.3g} s within "
        f"x[{lo[0]:.4g}, {hi[0]:.4g}] y[{lo[1]:.4g}, {hi[1]:.4g}] z[{lo[2]:.4g}, {hi[2]:.4g}] m"
    )


def csv_header() -> str:
    """The header line of a listener path CSV as written (without a newline).

    Returns
    -------
    str

    Examples
    --------
    >>> csv_header()
    't,x,y,z,fx,fy,fz,ux,uy,uz'
    """
    return "t,x,y,z,fx,fy,fz,ux,uy,uz"


def format_row(row: NDArray[np.float64]) -> str:
    """One CSV line of a capture, 9 significant digits per value (no newline).

    Parameters
    ----------
    row : ndarray, shape (10,)
        A row of :meth:`ListenerPath.rows`.

    Returns
    -------
    str

    Examples
    --------
    >>> format_row(np.array([0.5, 1 / 3, 0, 0, 0, 1, 0, 0, 0, 1]))
    '0.5,0.333333333,0,0,0,1,0,0,0,1'
    """
    return ",".join(f"{v:.9g}" for v in row)


#: bytes a capture takes while a path is built and written (arrays and CSV text)
CAPTURE_BYTES = 512
#: largest coordinate magnitude accepted, m (sound needs ~100 years to cross it)
MAX_COORDINATE_M = 1e12


def _check_captures(n: float, what: str) -> None:
    from auralize.runtime.resources import require_memory

    require_memory(n * CAPTURE_BYTES, what, hint="use fewer captures per second")


def _check_duration(d: float) -> None:
    if not (isinstance(d, int | float) and math.isfinite(d) and d > 0):
        raise ListenerPathError(f"duration must be a positive number of seconds, got {d!r}")


def _unit_rows(a: object, n: int, name: str, src: str) -> NDArray[np.float64]:
    arr = np.array(a, dtype=np.float64).reshape(-1, 3)
    if arr.shape[0] != n:
        raise ListenerPathError(f"{src}: {name} has {arr.shape[0]} rows, expected {n}")
    norm = np.linalg.norm(arr, axis=1)
    if not np.all(np.isfinite(arr)) or np.any(norm < 1e-12):
        raise ListenerPathError(f"{src}: {name} vectors must be finite and non-zero")
    return arr / norm[:, None]


def _mat_to_quat(m: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrices (N, 3, 3) -> unit quaternions (N, 4) (w, x, y, z)."""
    out = np.empty((m.shape[0], 4))
    for i, r in enumerate(m):
        tr = r[0, 0] + r[1, 1] + r[2, 2]
        if tr > 0:
            s = 2.0 * math.sqrt(tr + 1.0)
            out[i] = (
                0.25 * s,
                (r[2, 1] - r[1, 2]) / s,
                (r[0, 2] - r[2, 0]) / s,
                (r[1, 0] - r[0, 1]) / s,
            )
        elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
            s = 2.0 * math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
            out[i] = (
                (r[2, 1] - r[1, 2]) / s,
                0.25 * s,
                (r[0, 1] + r[1, 0]) / s,
                (r[0, 2] + r[2, 0]) / s,
            )
        elif r[1, 1] > r[2, 2]:
            s = 2.0 * math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
            out[i] = (
                (r[0, 2] - r[2, 0]) / s,
                (r[0, 1] + r[1, 0]) / s,
                0.25 * s,
                (r[1, 2] + r[2, 1]) / s,
            )
        else:
            s = 2.0 * math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
            out[i] = (
                (r[1, 0] - r[0, 1]) / s,
                (r[0, 2] + r[2, 0]) / s,
                (r[1, 2] + r[2, 1]) / s,
                0.25 * s,
            )
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def _slerp(
    a: NDArray[np.float64], b: NDArray[np.float64], w: NDArray[np.float64]
) -> NDArray[np.float64]:
    dot = np.sum(a * b, axis=1)
    b = np.where(dot[:, None] < 0, -b, b)
    dot = np.abs(dot)
    th = np.arccos(np.clip(dot, -1, 1))
    st = np.sin(th)
    small = st < 1e-6
    k0 = np.where(small, 1 - w, np.sin((1 - w) * th) / np.where(small, 1, st))
    k1 = np.where(small, w, np.sin(w * th) / np.where(small, 1, st))
    q = k0[:, None] * a + k1[:, None] * b
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _quat_axis(q: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotate vector v by quaternions q (N, 4)."""
    w, x, y, z = q.T
    r = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )
    return r @ v


def listener_from_args(args: Any) -> ListenerPath:
    """The :class:`ListenerPath` of the common output options ``--path`` or ``--listener``/``--duration``.

    With ``--path`` and ``--duration``, the path is rendered for ``--duration``
    seconds (its last capture is held beyond its end: :func:`render_duration`).

    Parameters
    ----------
    args : object
        Any object with attributes ``path`` (CSV file or None), ``listener``
        (x, y, z in m, or None) and ``duration`` (playback seconds or None):
        the parsed options of a command that writes audio.

    Returns
    -------
    ListenerPath

    Raises
    ------
    ParameterError
        Neither ``--path`` nor ``--listener``, or ``--listener`` without
        ``--duration``.
    FormatError
        A path file that does not exist or is not a path CSV.
    ListenerPathError
        Captures that do not make a path, or a bad duration.

    Examples
    --------
    >>> from argparse import Namespace
    >>> listener_from_args(Namespace(path=None, listener=(0, 0, 1), duration=2.0)).duration
    2.0
    >>> listener_from_args(Namespace(path=None, listener=(0, 0, 1), duration=None))
    Traceback (most recent call last):
    auralize.errors.ParameterError: --listener needs --duration S (seconds to render)
    """
    if args.path:
        return ListenerPath.from_csv(args.path)
    if args.listener is None:
        raise ParameterError("give a listener: --path CSV or --listener X,Y,Z --duration S")
    if args.duration is None:
        raise ParameterError("--listener needs --duration S (seconds to render)")
    return ListenerPath.point(args.listener, duration=args.duration)


def render_duration(args: Any, path: Any, *, default: float | None = None) -> float:
    """Playback seconds a command renders: ``--duration``, else the path's, else ``default``.

    Parameters
    ----------
    args : object
        Parsed options with an attribute ``duration`` (seconds or None).
    path : ListenerPath or None
        The listener path, if any.
    default : float, optional
        Seconds when neither gives a duration.

    Returns
    -------
    float
        Playback seconds.

    Raises
    ------
    ParameterError
        No duration from any of the three.

    Examples
    --------
    >>> from argparse import Namespace
    >>> path = ListenerPath.point((0, 0, 0), duration=3.0)
    >>> render_duration(Namespace(duration=None), path), render_duration(Namespace(duration=1), path)
    (3.0, 1.0)
    >>> render_duration(Namespace(duration=None), None, default=0.5)
    0.5
    """
    if args.duration is not None:
        return float(args.duration)
    if path is not None:
        return float(path.duration)
    if default is None:
        raise ParameterError("give --duration S (playback seconds to render)")
    return float(default)
