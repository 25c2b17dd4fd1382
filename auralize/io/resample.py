"""Choosing uniform grids and resampling uniform volumes onto them.

Non-uniform meshes are sampled with VTK in :mod:`auralize.io._mesh`; this
module holds the pure-numpy parts: the grid that covers a bounding box at a
requested ``resolution=`` (:func:`grid_for_bounds`), the automatic grid of a
mesh chosen from its own cell sizes (:func:`grid_for_cells`), and lazy
trilinear resampling of a uniform :class:`~auralize.volume.TimeVolume` onto
another uniform grid.
"""

from __future__ import annotations

import dataclasses
from dataclasses import KW_ONLY, dataclass, field

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DataError, ParameterError
from auralize.io._common import warn_resampled
from auralize.volume import FrameSource, TimeVolume

#: Largest number of points per axis :func:`grid_for_bounds`'s automatic resolution picks.
AUTO_MAX_POINTS_PER_AXIS = 128

#: Percentile of a mesh's cell sizes (cells in the region of interest) that the automatic
#: voxel matches (:func:`grid_for_cells`).  Graded meshes put most of their cells where the
#: features are (boundary layers, wakes, the body), so a low percentile is the size of the
#: cells that resolve them; the 20th rather than the minimum or the 5th because the very
#: smallest cells are outliers (first boundary-layer rows, slivers, cells squeezed at a
#: trailing edge or an O-grid's axis) that would make every other region needlessly fine.
AUTO_CELL_PERCENTILE = 20.0

#: Most grid points the automatic resolution of a 3-D mesh picks (159^3): one step's
#: detection works on about 16 float64 arrays of the grid's size
#: (:data:`auralize.runtime.resources.FRAME_WORK_ARRAYS`), 512 MB at this size, and VTK
#: probes about a few million points per second, so a step stays around a second.
AUTO_MAX_GRID_POINTS_3D = 4_000_000

#: Most grid points the automatic resolution of a flat (2-D) mesh picks (1414^2): already
#: finer than a screen shows, and half the 3-D budget because 2-D series are typically
#: long transients (many steps) that are read step by step.
AUTO_MAX_GRID_POINTS_2D = 2_000_000

#: What ``resolution=`` may be: automatic, max points per axis, or exact ``(nx, ny, nz)``.
ResolutionArg = int | tuple[int, int, int] | None


def check_resolution(resolution: object, *, source: str) -> ResolutionArg:
    """Validate ``resolution=``: ``None``, an int >= 2, or three ints >= 1.

    Parameters
    ----------
    resolution : object
        What the user gave: None (automatic), the most points per axis, or
        ``(nx, ny, nz)``.
    source : str
        File name for messages.

    Returns
    -------
    None, int or (int, int, int)
        Python ints (numpy integers and lists are converted).

    Raises
    ------
    ParameterError
        Anything else (booleans, an int below 2, a tuple of other than three
        positive ints).

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

    Raises
    ------
    DataError
        Bounds that are not finite, a minimum above its maximum, or a mesh
        that is a single point.
    ParameterError
        A tuple ``resolution`` with more than one point along an axis of zero
        extent.

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
        return _dims_for(ext, flat, h, cap)

    if resolution is None:
        h_big = _spacing_for_count(ext, flat, max(int(n_points), 8))
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
    return lo, _spacing_of(ext, dims), (int(dims[0]), int(dims[1]), int(dims[2]))


def _dims_for(
    ext: NDArray[np.float64], flat: NDArray[np.bool_], h: float, cap: int
) -> NDArray[np.int64]:
    """Points per axis at spacing about ``h`` (at least 2, at most ``cap``; 1 if flat)."""
    d = np.clip(np.round(ext / h).astype(np.int64) + 1, 2, cap)
    return np.where(flat, 1, d)


def _count(ext: NDArray[np.float64], flat: NDArray[np.bool_], h: float) -> float:
    return float(np.prod(_dims_for(ext, flat, h, 2**31).astype(np.float64)))


def _spacing_for_count(ext: NDArray[np.float64], flat: NDArray[np.bool_], target: float) -> float:
    """The finest spacing (to 1e-9 relative) whose grid has at most ``target`` points."""
    scale = float(ext.max())
    h_small, h_big = scale / 1e6, scale
    for _ in range(80):
        h_mid = float(np.sqrt(h_small * h_big))
        if _count(ext, flat, h_mid) > target:
            h_small = h_mid
        else:
            h_big = h_mid
    return h_big


def _spacing_of(ext: NDArray[np.float64], dims: NDArray[np.int64]) -> NDArray[np.float64]:
    active = dims > 1
    spacing = np.ones(3)
    spacing[active] = ext[active] / (dims[active] - 1)
    if np.any(active):
        spacing[~active] = spacing[active].min()
    return spacing


@dataclass(frozen=True)
class GridChoice:
    """The uniform grid a mesh is resampled onto, and why.

    Parameters
    ----------
    origin, spacing : ndarray, shape (3,)
        The grid's first point and its spacing along x, y, z in metres.
    dims : (int, int, int)
        Points along x, y, z.
    voxel : float
        The grid's edge in metres (the geometric mean of the spacing along its
        non-flat axes, :func:`voxel_edge`).
    capped : bool
        Whether the point budget made the grid coarser than the mesh's cells
        asked.
    cell : float
        The percentile cell size (m) the automatic choice aimed at; NaN when
        ``resolution=`` was given or no cell has a size.
    why : str
        The choice in words.

    Examples
    --------
    >>> g = grid_for_cells((0, 1, 0, 1, 0, 1), np.full(10, 0.25), n_points=27,
    ...                    resolution=None, budget=10**6, source="x")
    >>> g.dims, g.voxel, g.cell, g.why
    ((5, 5, 5), 0.25, 0.25, 'automatic: the 20th-percentile cell size 0.25 m')
    """

    origin: NDArray[np.float64]
    spacing: NDArray[np.float64]
    _: KW_ONLY
    dims: tuple[int, int, int]
    voxel: float
    capped: bool
    cell: float
    why: str


def voxel_edge(spacing: NDArray[np.float64], dims: tuple[int, int, int]) -> float:
    """Geometric mean of ``spacing`` along the axes with more than one point.

    Parameters
    ----------
    spacing : ndarray, shape (3,)
        Grid spacing along x, y, z in metres.
    dims : (int, int, int)
        Points along x, y, z.

    Returns
    -------
    float
        In metres; the smallest spacing when every axis has one point.

    Examples
    --------
    >>> voxel_edge(np.array([0.5, 2.0, 7.0]), (10, 10, 1))
    1.0
    """
    active = [float(spacing[a]) for a in range(3) if dims[a] > 1]
    return float(np.exp(np.mean(np.log(active)))) if active else float(np.min(spacing))


def grid_for_cells(
    bounds: tuple[float, ...] | NDArray[np.floating],
    cell_sizes: NDArray[np.floating],
    *,
    n_points: int,
    resolution: ResolutionArg,
    budget: int,
    source: str,
) -> GridChoice:
    """The uniform grid a mesh's region ``bounds`` is resampled onto.

    With ``resolution=None`` the voxel is the :data:`AUTO_CELL_PERCENTILE`-th
    percentile of ``cell_sizes`` (equivalent edge lengths of the mesh's cells
    in the region, metres), or the spacing that keeps about ``n_points`` grid
    points, whichever is finer (so a grid is never coarser than the point
    count alone gave); then coarsened, if needed, until the grid has at most
    ``budget`` points (``capped``).  An explicit ``resolution`` means what it
    means in :func:`grid_for_bounds`, over ``bounds``.

    Parameters
    ----------
    bounds : sequence of 6 float
        ``(xmin, xmax, ymin, ymax, zmin, zmax)`` of the region in metres.
    cell_sizes : ndarray
        Equivalent edge lengths (m) of the mesh's cells in the region; values
        that are not finite and positive are ignored.
    n_points : int
        Point count of the mesh (in the region).
    resolution : None, int or (int, int, int)
        As in :func:`grid_for_bounds`; None chooses from ``cell_sizes``.
    budget : int
        Most grid points of an automatic grid.
    source : str
        File name for messages.

    Returns
    -------
    GridChoice

    Raises
    ------
    DataError
        Bounds that are not valid or a region that is a single point.
    ParameterError
        A ``resolution`` that does not fit the region (see :func:`grid_for_bounds`).

    Examples
    --------
    >>> g = grid_for_cells((0, 10, 0, 10, 0, 0), np.full(50, 0.5), n_points=100,
    ...                    resolution=None, budget=10**6, source="x")
    >>> g.dims, g.voxel, g.capped
    ((21, 21, 1), 0.5, False)
    >>> grid_for_cells((0, 10, 0, 10, 0, 0), np.full(50, 0.5), n_points=100,
    ...                resolution=None, budget=100, source="x").dims
    (10, 10, 1)
    """
    if resolution is not None:
        origin, spacing, dims = grid_for_bounds(
            bounds, n_points=n_points, resolution=resolution, source=source
        )
        return GridChoice(
            origin,
            spacing,
            dims=dims,
            voxel=voxel_edge(spacing, dims),
            capped=False,
            cell=float("nan"),
            why=f"resolution={resolution!r}",
        )
    b = np.asarray(bounds, dtype=np.float64).reshape(3, 2)
    origin, _, _ = grid_for_bounds(bounds, n_points=8, resolution=2, source=source)  # checks
    ext = b[:, 1] - b[:, 0]
    flat = ext <= 1e-9 * float(ext.max())
    sizes = np.asarray(cell_sizes, dtype=np.float64).reshape(-1)
    sizes = sizes[np.isfinite(sizes) & (sizes > 0)]
    h_points = _spacing_for_count(ext, flat, max(int(n_points), 8))
    cell = float(np.percentile(sizes, AUTO_CELL_PERCENTILE)) if sizes.size else float("nan")
    h = min(cell, h_points) if sizes.size else h_points
    why = (
        f"automatic: the {AUTO_CELL_PERCENTILE:g}th-percentile cell size {cell:.3g} m"
        if sizes.size and cell <= h_points
        else f"automatic: about as many grid points as the mesh's {int(n_points)}"
    )
    capped = _count(ext, flat, h) > budget
    if capped:
        h = max(h, _spacing_for_count(ext, flat, float(budget)))
        why += f", capped at {budget:,} grid points"
    counts = _dims_for(ext, flat, h, 2**31)
    spacing = _spacing_of(ext, counts)
    d = (int(counts[0]), int(counts[1]), int(counts[2]))
    return GridChoice(
        origin, spacing, dims=d, voxel=voxel_edge(spacing, d), capped=capped, cell=cell, why=why
    )


def describe_grid(
    origin: NDArray[np.float64], spacing: NDArray[np.float64], dims: tuple[int, int, int]
) -> str:
    """A uniform grid in words, for messages.

    Parameters
    ----------
    origin, spacing : ndarray, shape (3,)
        The grid's first point and its spacing along x, y, z in metres.
    dims : (int, int, int)
        Points along x, y, z.

    Returns
    -------
    str
        Numbers to 6 significant digits.

    Examples
    --------
    >>> describe_grid(np.zeros(3), np.array([0.005, 0.005, 0.01]), (20, 20, 2))
    '20x20x2 points, spacing (0.005, 0.005, 0.01) m, origin (0, 0, 0) m'
    """
    sp = ", ".join(f"{s:.6g}" for s in spacing)
    org = ", ".join(f"{o:.6g}" for o in origin)
    return f"{dims[0]}x{dims[1]}x{dims[2]} points, spacing ({sp}) m, origin ({org}) m"


@dataclass
class UniformResampledFrames:
    """Trilinear resampling of a uniform-grid :class:`FrameSource`, one frame per read.

    Parameters
    ----------
    source : FrameSource
        Frames of shape ``(nz, ny, nx)`` or ``(nz, ny, nx, 3)``.
    index_x, index_y, index_z : ndarray
        The new points' fractional indices into the source grid along x, y
        and z; values outside the grid are clamped to its edge.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"p": np.arange(3.0).reshape(1, 1, 1, 3)}, times=[0.0])
    >>> half = UniformResampledFrames(vol.fields["p"], index_x=np.array([0.5, 1.5]),
    ...                               index_y=np.zeros(1), index_z=np.zeros(1))
    >>> half.frame_shape, half.read(0).tolist()
    ((1, 1, 2), [[[0.5, 1.5]]])
    """

    source: FrameSource
    _: KW_ONLY
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
        """The source's frame ``step`` at the new points (float64).

        Parameters
        ----------
        step : int
            Time step, 0 to ``n_steps - 1``.

        Returns
        -------
        ndarray, shape frame_shape
            ``(len(index_z), len(index_y), len(index_x)[, 3])``.

        Examples
        --------
        >>> import numpy as np
        >>> from auralize.volume import TimeVolume
        >>> vol = TimeVolume.from_arrays({"p": np.arange(4.0).reshape(1, 1, 2, 2)}, times=[0.0])
        >>> mid = UniformResampledFrames(vol.fields["p"], index_x=np.array([0.5]),
        ...                              index_y=np.array([0.5]), index_z=np.zeros(1))
        >>> mid.read(0).tolist()  # the mean of the four corners
        [[[1.5]]]
        """
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

    Parameters
    ----------
    volume : TimeVolume
        A volume on a uniform grid.
    resolution : None, int or (int, int, int)
        As in :func:`grid_for_bounds`, over the volume's bounds.

    Returns
    -------
    TimeVolume
        Frames interpolated trilinearly as they are read
        (:class:`UniformResampledFrames`); a point is valid only when every
        source point its weights touch is.

    Raises
    ------
    ParameterError
        A ``resolution`` that is not valid (:func:`check_resolution`) or does
        not fit the volume (:func:`grid_for_bounds`).

    Warns
    -----
    ResampledWarning
        When the grid changes.

    Examples
    --------
    >>> import warnings
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"p": np.zeros((2, 9, 9, 9))}, times=[0.0, 0.1])
    >>> resample_uniform(vol, None) is vol
    True
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     coarse = resample_uniform(vol, 5)
    >>> coarse.dims, coarse.spacing.tolist()
    ((5, 5, 5), [2.0, 2.0, 2.0])
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
        name: UniformResampledFrames(src, index_x=idx[0], index_y=idx[1], index_z=idx[2])
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
