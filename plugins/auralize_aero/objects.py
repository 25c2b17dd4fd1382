"""Objects (polylines split into point sources), their motion, and wind (paper 004 §4, §6, §7.1).

An :class:`AeroObject` is one or more polylines in the object's own frame
(metres), e.g. a stick from the grip (origin) along +x.  It is split into
point sources at the correlation length Δh ≈ 3D (§7.1): each source sits at
the middle of its piece, with the piece's length Δh, the local axis n and a
section reference direction e1 ⊥ n (the body-frame ξ axis of the texture).

A :class:`Motion` gives the object's pose over time (CSV ``t,x,y,z`` plus
``qw,qx,qy,qz`` — a unit quaternion rotating object coordinates into the
world); a :class:`Wind` blows on a static object with small seeded random
fluctuations (§8.2, Figs. 14–15).
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from auralize.errors import ParameterError
from auralize.runtime.files import atomic_write, read_timed_csv

from .shapes import check_diameter


@dataclass
class AeroObject:
    """Stick-like object(s) as polylines.

    Parameters
    ----------
    polylines : list of (P_i, 3)
        Vertices in the object frame, metres (P_i >= 2).
    diameter : float
        Section size D (m); the source spacing defaults to 3D (§7.1).
    reference : (3,)
        Direction, in the object frame, of the section's ξ axis (projected
        perpendicular to each piece's axis); default +z, or +y for pieces
        along z.
    spacing : float, optional
        Point-source spacing Δh (m); default ``3 * diameter``.
    name : str
    """

    polylines: list[NDArray[np.float64]]
    diameter: float
    reference: NDArray[np.float64] = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    spacing: float | None = None
    name: str = "object"

    def __post_init__(self) -> None:
        check_diameter(self.diameter)
        if isinstance(self.polylines, np.ndarray) and self.polylines.ndim == 2:
            self.polylines = [self.polylines]
        lines = []
        for k, pl in enumerate(self.polylines):
            a = np.asarray(pl, dtype=np.float64)
            if a.ndim != 2 or a.shape[1] != 3 or a.shape[0] < 2:
                raise ParameterError(
                    f"polyline {k} of {self.name!r} must be (P >= 2, 3); got {a.shape}"
                )
            if not np.all(np.isfinite(a)):
                raise ParameterError(f"polyline {k} of {self.name!r} contains NaN or Inf")
            seg = np.linalg.norm(np.diff(a, axis=0), axis=1)
            if np.any(seg <= 0):
                raise ParameterError(
                    f"polyline {k} of {self.name!r} has a zero-length segment at {int(np.argmin(seg))}"
                )
            lines.append(a)
        if not lines:
            raise ParameterError(f"object {self.name!r} has no polylines")
        self.polylines = lines
        if self.spacing is not None and not float(self.spacing) > 0:
            raise ParameterError(f"spacing must be > 0 m, got {self.spacing!r}")
        self.reference = np.asarray(self.reference, dtype=np.float64).reshape(3)

    @property
    def delta_h(self) -> float:
        return float(self.spacing) if self.spacing is not None else 3.0 * self.diameter

    def sources(
        self,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Point sources in the object frame (§4, Fig. 3a; §7.1).

        Returns
        -------
        centres : (S, 3) m
        lengths : (S,) span Δh of each source's piece (m)
        axes : (S, 3) unit tangent n
        refs : (S, 3) unit section axis ξ, perpendicular to n
        """
        C, Lh, N, E = [], [], [], []
        for pl in self.polylines:
            seg = np.diff(pl, axis=0)
            sl = np.linalg.norm(seg, axis=1)
            arc = np.concatenate([[0.0], np.cumsum(sl)])
            total = arc[-1]
            n = max(1, int(total / self.delta_h + 1e-9))  # §8.1: 50 cm / 3 cm -> 16
            mid = (np.arange(n) + 0.5) * total / n
            k = np.clip(np.searchsorted(arc, mid, side="right") - 1, 0, len(sl) - 1)
            w = (mid - arc[k]) / sl[k]
            C.append(pl[k] + w[:, None] * seg[k])
            Lh.append(np.full(n, total / n))
            t = seg[k] / sl[k][:, None]
            N.append(t)
            ref = np.broadcast_to(self.reference, t.shape).copy()
            par = np.abs(np.sum(ref * t, 1)) > 0.99
            ref[par] = np.where(np.abs(t[par, 1:2]) < 0.9, [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
            e = ref - np.sum(ref * t, 1)[:, None] * t
            E.append(e / np.linalg.norm(e, axis=1)[:, None])
        return np.concatenate(C), np.concatenate(Lh), np.concatenate(N), np.concatenate(E)

    @property
    def n_sources(self) -> int:
        return int(self.sources()[0].shape[0])


def quat_to_matrix(q: NDArray[np.floating]) -> NDArray[np.float64]:
    """Rotation matrices ``(…, 3, 3)`` of unit quaternions ``(…, 4)`` (w, x, y, z)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def axis_angle_quat(axis: NDArray[np.floating], angle: NDArray[np.floating]) -> NDArray[np.float64]:
    """Quaternions ``(N, 4)`` of rotations by ``angle (N,)`` radians about a unit ``axis (3,)``."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    h = 0.5 * np.asarray(angle, dtype=np.float64)
    return np.column_stack([np.cos(h), np.sin(h)[:, None] * a])


@dataclass
class Motion:
    """Timed poses of an object.

    Parameters
    ----------
    times : (T,) seconds, strictly increasing.
    positions : (T, 3) world position of the object origin (m).
    quaternions : (T, 4) unit quaternions (w, x, y, z), object -> world.
    """

    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    quaternions: NDArray[np.float64]
    source: str = "<memory>"

    def __post_init__(self) -> None:
        self.times = np.asarray(self.times, dtype=np.float64).reshape(-1)
        self.positions = np.asarray(self.positions, dtype=np.float64).reshape(-1, 3)
        self.quaternions = np.asarray(self.quaternions, dtype=np.float64).reshape(-1, 4)
        n = self.times.size
        if n < 2:
            raise ParameterError(f"{self.source}: a motion needs at least 2 poses, got {n}")
        if self.positions.shape[0] != n or self.quaternions.shape[0] != n:
            raise ParameterError(
                f"{self.source}: {n} times but {self.positions.shape[0]} positions and "
                f"{self.quaternions.shape[0]} orientations"
            )
        for nm, a in (
            ("times", self.times),
            ("positions", self.positions),
            ("quaternions", self.quaternions),
        ):
            if not np.all(np.isfinite(a)):
                raise ParameterError(f"{self.source}: {nm} contain NaN or Inf")
        d = np.diff(self.times)
        if np.any(d <= 0):
            i = int(np.argmax(d <= 0))
            raise ParameterError(
                f"{self.source}: motion times must be strictly increasing; pose {i + 1} has "
                f"t={self.times[i + 1]:g} s after t={self.times[i]:g} s"
            )
        nq = np.linalg.norm(self.quaternions, axis=1)
        if np.any(nq < 1e-9):
            raise ParameterError(f"{self.source}: zero quaternion at pose {int(np.argmin(nq))}")
        q = self.quaternions / nq[:, None]
        for i in range(1, n):  # same hemisphere for smooth interpolation
            if q[i] @ q[i - 1] < 0:
                q[i] = -q[i]
        self.quaternions = q

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    def world_points(
        self, local: NDArray[np.floating], vectors: bool = False
    ) -> NDArray[np.float64]:
        """Object-frame points (or vectors) ``(S, 3)`` at every pose -> ``(S, T, 3)``."""
        R = quat_to_matrix(self.quaternions)  # (T, 3, 3)
        out = np.einsum("tij,sj->sti", R, np.asarray(local, dtype=np.float64))
        return out if vectors else out + self.positions[None]

    # ------------------------------------------------------------ CSV I/O
    @classmethod
    def from_csv(cls, path: str | Path) -> Motion:
        """Read ``t,x,y,z[,qw,qx,qy,qz]`` (no orientation: identity)."""
        a, has_q, src = read_timed_csv(
            path, what="motion", optional=["qw", "qx", "qy", "qz"], rows_name="poses"
        )
        q = a[:, 4:8] if has_q else np.tile([1.0, 0, 0, 0], (a.shape[0], 1))
        return cls(a[:, 0], a[:, 1:4], q, source=src)

    def to_csv(self, path: str | Path) -> None:
        buf = io.StringIO()
        buf.write("t,x,y,z,qw,qx,qy,qz\n")
        for row in np.column_stack([self.times, self.positions, self.quaternions]):
            buf.write(",".join(f"{v:.9g}" for v in row) + "\n")
        atomic_write(Path(path), buf.getvalue().encode())

    # ------------------------------------------------------------ builders
    @classmethod
    def static(cls, duration: float, position: tuple[float, float, float] = (0, 0, 0)) -> Motion:
        return cls(
            np.array([0.0, duration]), np.tile(position, (2, 1)), np.tile([1.0, 0, 0, 0], (2, 1))
        )

    @classmethod
    def linear(
        cls,
        start: NDArray[np.floating],
        velocity: NDArray[np.floating],
        *,
        duration: float,
        rate_hz: float = 200.0,
    ) -> Motion:
        """Constant velocity (a thrown object, Fig. 12, without its spin)."""
        t = np.linspace(0, duration, max(int(duration * rate_hz), 1) + 1)
        pos = np.asarray(start, dtype=np.float64) + t[:, None] * np.asarray(
            velocity, dtype=np.float64
        )
        return cls(t, pos, np.tile([1.0, 0, 0, 0], (t.size, 1)), source="linear")

    @classmethod
    def swing(
        cls,
        *,
        duration: float = 1.0,
        swings: float = 2.0,
        amplitude_deg: float = 80.0,
        axis: tuple[float, float, float] = (0, 0, 1),
        pivot: tuple[float, float, float] = (0, 0, 0),
        rate_hz: float = 500.0,
    ) -> Motion:
        """A stick swung back and forth about ``axis`` through its grip (Figs. 1, 9):
        angle(t) = A sin(2π swings t / duration)."""
        t = np.linspace(0, duration, max(int(duration * rate_hz), 2) + 1)
        ang = np.deg2rad(amplitude_deg) * np.sin(2 * np.pi * swings * t / duration)
        return cls(
            t,
            np.tile(pivot, (t.size, 1)),
            axis_angle_quat(np.asarray(axis, float), ang),
            source="swing",
        )

    @classmethod
    def circle(
        cls,
        *,
        radius: float = 1.0,
        turns: float = 4.0,
        duration: float = 2.0,
        center: tuple[float, float, float] = (0, 0, 0),
        rate_hz: float = 500.0,
    ) -> Motion:
        """Uniform horizontal circle (a sphere whirled on a string, Fig. 11)."""
        t = np.linspace(0, duration, max(int(duration * rate_hz), 2) + 1)
        a = 2 * np.pi * turns * t / duration
        pos = np.asarray(center, float) + radius * np.stack([np.cos(a), np.sin(a), 0 * a], 1)
        return cls(t, pos, axis_angle_quat(np.array([0, 0, 1.0]), a), source="circle")


@dataclass(frozen=True)
class Wind:
    """Wind on a static object (§8.2): ``speed`` along ``direction`` with small random fluctuations.

    Each point source gets its own seeded, smooth relative fluctuation of
    standard deviation ``gust`` (correlation time ``gust_time`` s), applied
    multiplicatively to the speed.
    """

    speed: float
    direction: tuple[float, float, float] = (1.0, 0.0, 0.0)
    gust: float = 0.05
    gust_time: float = 0.2
    seed: int = 0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.speed) and self.speed >= 0):
            raise ParameterError(f"wind speed must be >= 0 m/s, got {self.speed!r}")
        if not 0 <= self.gust < 0.5:
            raise ParameterError(f"gust must be in [0, 0.5), got {self.gust!r}")
        if np.linalg.norm(self.direction) == 0:
            raise ParameterError("wind direction must be a non-zero vector")

    def velocities(self, n_sources: int, times: NDArray[np.float64]) -> NDArray[np.float64]:
        """Wind velocity at each source ``(S, J, 3)`` on uniform ``times (J,)``."""
        from scipy.ndimage import gaussian_filter1d

        d = np.asarray(self.direction, dtype=np.float64)
        d = d / np.linalg.norm(d)
        J = times.size
        fac = np.ones((n_sources, J))
        if self.gust > 0 and J > 1:
            dt = float(times[1] - times[0])
            rng = np.random.default_rng(self.seed)
            sig = max(self.gust_time / dt, 1.0)
            noise = gaussian_filter1d(rng.standard_normal((n_sources, J)), sig, axis=1, mode="wrap")
            noise /= max(float(noise.std()), 1e-12)
            fac = 1 + self.gust * np.clip(noise, -3, 3)
        return self.speed * fac[:, :, None] * d
