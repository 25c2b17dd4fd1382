"""Choosing uniform grids and resampling uniform volumes onto them.

Non-uniform meshes are sampled with VTK in :mod:`auralize.io._mesh`; this
module holds the pure-numpy parts: the grid that covers a bounding box at a
requested ``resolution=``, and lazy trilinear resampling of a uniform
:class:`~auralize.volume.TimeVolume` onto another uniform grid.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DataError, ParameterError
from auralize.io._common import warn_resampled
from auralize.volume import FrameSource, TimeVolume

#: Largest number of points per axis the automatic resolution picks.
AUTO_MAX_POINTS_PER_AXIS = 128

#: What ``resolution=`` may be: automatic, max points per axis, or exact ``(nx, ny, nz)``.
ResolutionArg = int | tuple[int, int, int] | None


def check_resolution(resolution: object, *, source: str) -> ResolutionArg:
    """Validate ``resolution=``: ``None``, an int >= 2, or three ints >= 1.

    Examples
    --------
    >>> check_resolution((4, 4, 1), source="demo.pvd")
    (4, 4, 1)
    """
    if resolution is None:
        return None
    if isinstance(resolution, int | np.integer) and not isinstance(resolution, bool):
        if int(resolution) < 2:
            raise ParameterError(
                f"{source}: resolution={resolution!r} is too small; give at least 2 points "
                f"per axis, or (nx, ny, nz)"
            )
        return int(resolution)
    if (
        isinstance(resolution, tuple | list | np.ndarray)
        and len(resolution) == 3
        and all(isinstance(r, int | np.integer) and not isinstance(r, bool) for r in resolution)
        and all(int(r) >= 1 for r in resolution)
    ):
        return (int(resolution[0]), int(resolution[1]), int(resolution[2]))
    raise ParameterError(
        f"{source}: resolution={resolution!r} is not valid; give None (automatic), an int >= 2 "
        f"(max points per axis) or three ints >= 1 (nx, ny, nz)"
    )


def grid_for_bounds(
    bounds: tuple[float, ...] | NDArray[np.floating],
    *,
    n_points: int,
    resolution: ResolutionArg,
    source: str,
) -> tuple[NDArray[np.float64], NDArray[np.float64], tuple[int, int, int]]:
    """A uniform grid covering ``bounds`` exactly.

    Parameters
    ----------
    bounds : sequence of 6 float
        ``(xmin, xmax, ymin, ymax, zmin, zmax)`` in metres.
    n_points : int
        Point count of the source mesh; the automatic grid keeps about as many.
    resolution : None, int or (int, int, int)
        ``None``: about ``n_points`` points at equal spacing, at most
        :data:`AUTO_MAX_POINTS_PER_AXIS` per axis; ``int``: that many points
        along the longest axis and the same spacing on the others; a tuple:
        exactly ``(nx, ny, nz)`` points.  An axis of zero extent gets one point.
    source : str
        File name for messages.

    Returns
    -------
    origin, spacing : ndarray, shape (3,)
    dims : tuple of int
        ``(nx, ny, nz)``.

    Examples
    --------
    >>> o, s, d = grid_for_bounds((0, 1, 0, 2, 0, 0), n_points=10, resolution=5, source="x")
    >>> d, s.tolist()
    ((3, 5, 1), [0.5, 0.5, 0.5])
    """
    b = np.asarray(bounds, dtype=np.float64).reshape(3, 2)
    lo = b[:, 0].copy()
    ext = b[:, 1] - b[:, 0]
    if not np.all(np.isfinite(b)) or np.any(ext < 0):
        raise DataError(f"{source}: mesh bounds {b.ravel().tolist()} are not valid")
    scale = float(ext.max())
    if scale <= 0:
        raise DataError(
            f"{source}: the mesh is a single point (bounds {b.ravel().tolist()}); "
            f"nothing to put on a grid"
        )
    flat = ext <= 1e-9 * scale

    def dims_for(h: float, cap: int) -> NDArray[np.int64]:
        d = np.clip(np.round(ext / h).astype(np.int64) + 1, 2, cap)
        return np.where(flat, 1, d)

    if resolution is None:
        target = max(int(n_points), 8)
        h_small, h_big = scale / 1e5, scale
        for _ in range(80):
            h_mid = float(np.sqrt(h_small * h_big))
            count = float(np.prod(dims_for(h_mid, 2**31).astype(np.float64)))
            if count > target:
                h_small = h_mid
            else:
                h_big = h_mid
        dims = dims_for(h_big, AUTO_MAX_POINTS_PER_AXIS)
    elif isinstance(resolution, int):
        dims = dims_for(scale / (resolution - 1), resolution)
    else:
        dims = np.asarray(resolution, dtype=np.int64)
        bad = [("xyz"[a], int(dims[a])) for a in range(3) if flat[a] and dims[a] != 1]
        if bad:
            raise ParameterError(
                f"{source}: resolution={resolution!r} asks for {bad[0][1]} points along "
                f"{bad[0][0]}, but the mesh has zero extent there; use 1 for that axis"
            )
    active = dims > 1
    spacing = np.ones(3)
    spacing[active] = ext[active] / (dims[active] - 1)
    if np.any(active):
        spacing[~active] = spacing[active].min()
    return lo, spacing, (int(dims[0]), int(dims[1]), int(dims[2]))


def describe_grid(
    origin: NDArray[np.float64], spacing: NDArray[np.float64], dims: tuple[int, int, int]
) -> str:
    """``'20x20x2 points, spacing (0.005, 0.005, 0.01) m, origin (0, 0, 0) m'``."""
    sp = ", ".join(f"{s:.6g}" for s in spacing)
    org = ", ".join(f"{o:.6g}" for o in origin)
    return f"{dims[0]}x{dims[1]}x{dims[2]} points, spacing ({sp}) m, origin ({org}) m"


@dataclass
class UniformResampledFrames:
    """Trilinear resampling of a uniform-grid :class:`FrameSource`, one frame per read.

    ``index_x``, ``index_y``, ``index_z`` are the new points' fractional
    indices into the source grid along each axis.
    """

    source: FrameSource
    index_x: NDArray[np.float64]
    index_y: NDArray[np.float64]
    index_z: NDArray[np.float64]
    n_steps: int = field(init=False)
    frame_shape: tuple[int, ...] = field(init=False)

    def __post_init__(self) -> None:
        self.n_steps = int(self.source.n_steps)
        tail = tuple(self.source.frame_shape[3:])
        self.frame_shape = (self.index_z.size, self.index_y.size, self.index_x.size, *tail)

    def read(self, step: int) -> NDArray[np.float64]:
        arr = np.asarray(self.source.read(step), dtype=np.float64)
        # Array axes are (z, y, x[, c]); linear interpolation is separable.
        arr = _interp_axis(arr, 2, self.index_x)
        arr = _interp_axis(arr, 1, self.index_y)
        return _interp_axis(arr, 0, self.index_z)


def _interp_axis(arr: NDArray[np.float64], axis: int, idx: NDArray[np.float64]) -> NDArray:
    n = arr.shape[axis]
    if n == 1:
        return np.repeat(arr, idx.size, axis=axis)
    i0 = np.clip(np.floor(idx).astype(np.intp), 0, n - 2)
    w = np.clip(idx - i0, 0.0, 1.0)
    shape = [1] * arr.ndim
    shape[axis] = idx.size
    w = w.reshape(shape)
    return np.take(arr, i0, axis=axis) * (1.0 - w) + np.take(arr, i0 + 1, axis=axis) * w


def resample_uniform(volume: TimeVolume, resolution: ResolutionArg) -> TimeVolume:
    """Put a uniform volume on the grid ``resolution`` asks for, lazily.

    Returns ``volume`` itself when the grid would not change (``resolution``
    is ``None``, an int no smaller than the largest dimension, or equal to
    ``volume.dims``); otherwise warns with
    :class:`~auralize.io.ResampledWarning`.
    """
    resolution = check_resolution(resolution, source=volume.source)
    if resolution is None:
        return volume
    if isinstance(resolution, int) and max(volume.dims) <= resolution:
        return volume
    if not isinstance(resolution, int) and tuple(resolution) == tuple(volume.dims):
        return volume
    origin, spacing, dims = grid_for_bounds(
        volume.bounds, n_points=volume.n_points, resolution=resolution, source=volume.source
    )
    idx = [
        (origin[a] + spacing[a] * np.arange(dims[a]) - volume.origin[a]) / volume.spacing[a]
        for a in range(3)
    ]
    fields: dict[str, FrameSource] = {
        name: UniformResampledFrames(src, idx[0], idx[1], idx[2])
        for name, src in volume.fields.items()
    }
    valid = None
    if volume.valid is not None:
        # A new point is valid only when every source point its trilinear weights touch is.
        weight = volume.valid.astype(np.float64)
        weight = _interp_axis(weight, 2, idx[0])
        weight = _interp_axis(weight, 1, idx[1])
        valid = _interp_axis(weight, 0, idx[2]) > 1.0 - 1e-9
    warn_resampled(
        f"{volume.source}: resampled the uniform {volume.dims[0]}x{volume.dims[1]}x"
        f"{volume.dims[2]} grid onto {describe_grid(origin, spacing, dims)} "
        f"(resolution={resolution!r}), by trilinear interpolation"
    )
    return dataclasses.replace(
        volume, origin=origin, spacing=spacing, dims=dims, fields=fields, valid=valid
    )
