"""TimeVolume: a uniform or curvilinear grid with named point fields over increasing times.

Arrays follow the HDF5 volume format v1 of docs/design.md: a scalar frame has shape
``(nz, ny, nx)``, a vector frame ``(nz, ny, nx, 3)`` with components x, y, z;
``dims`` is ``(nx, ny, nz)`` and point ``(i, j, k)`` sits at
``origin + (i, j, k) * spacing``.  This is VTK's point order (x fastest), so a
C-order ravel of a frame is directly a VTK point array.

A structured curvilinear grid (PLOT3D, ``vtkStructuredGrid``) keeps its own
points: ``coords (nz, ny, nx, 3)`` gives each point's position, and the
derivatives use its metric terms (:mod:`auralize.curvilinear`); ``origin`` is
then the corner of its bounding box and ``spacing`` the mean edge length along
each index direction (a nominal size, for scales and messages).

Frames are read lazily, one time step at a time, through a :class:`FrameSource`;
nothing loads a whole series unless asked to (:meth:`TimeVolume.load`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DataError, FieldError

#: Frame rate assumed for datasets without physical times (paper 003 §1: 30 frames/s).
DEFAULT_FRAME_RATE_HZ = 30.0


@runtime_checkable
class FrameSource(Protocol):
    """Anything that can hand out one time step of one field.

    ``frame_shape`` is ``(nz, ny, nx)`` or ``(nz, ny, nx, 3)``; ``read(step)``
    returns a new float array of that shape.  :class:`ArrayFrames`,
    :class:`CallableFrames` and the readers of :mod:`auralize.io` are frame
    sources.

    Examples
    --------
    >>> isinstance(ArrayFrames(np.zeros((2, 3, 4, 5))), FrameSource)
    True
    """

    @property
    def n_steps(self) -> int:
        """Number of time steps T.

        Examples
        --------
        >>> ArrayFrames(np.zeros((2, 3, 4, 5))).n_steps
        2
        """
        ...

    @property
    def frame_shape(self) -> tuple[int, ...]:
        """Shape of one frame: ``(nz, ny, nx)`` (scalar) or ``(nz, ny, nx, 3)`` (vector).

        Examples
        --------
        >>> ArrayFrames(np.zeros((2, 3, 4, 5, 3))).frame_shape
        (3, 4, 5, 3)
        """
        ...

    def read(self, step: int) -> NDArray[np.floating]:
        """One time step as a new float array.

        Parameters
        ----------
        step : int
            Time step, 0 <= step < :attr:`n_steps`.

        Returns
        -------
        ndarray, shape :attr:`frame_shape`

        Examples
        --------
        >>> ArrayFrames(np.arange(4.0).reshape(4, 1, 1, 1)).read(2).tolist()
        [[[2.0]]]
        """
        ...


@dataclass
class ArrayFrames:
    """Frames held in memory as one ``(T, nz, ny, nx[, 3])`` array.

    Parameters
    ----------
    array : array_like, shape (T, nz, ny, nx) or (T, nz, ny, nx, 3)
        The field's values at every time step (not copied).

    Raises
    ------
    DataError
        Any other shape.

    Examples
    --------
    >>> frames = ArrayFrames(np.ones((3, 2, 2, 2)))
    >>> frames.n_steps, frames.frame_shape, float(frames.read(0).sum())
    (3, (2, 2, 2), 8.0)
    """

    array: NDArray[np.floating]

    def __post_init__(self) -> None:
        self.array = np.asarray(self.array)
        if self.array.ndim not in (4, 5) or (self.array.ndim == 5 and self.array.shape[-1] != 3):
            raise DataError(
                f"field array must have shape (T, nz, ny, nx) or (T, nz, ny, nx, 3); "
                f"got {self.array.shape}"
            )

    @property
    def n_steps(self) -> int:
        """Number of time steps T (the array's first axis).

        Examples
        --------
        >>> ArrayFrames(np.zeros((3, 2, 2, 2))).n_steps
        3
        """
        return int(self.array.shape[0])

    @property
    def frame_shape(self) -> tuple[int, ...]:
        """Shape of one frame, ``(nz, ny, nx)`` or ``(nz, ny, nx, 3)``.

        Examples
        --------
        >>> ArrayFrames(np.zeros((3, 2, 4, 5))).frame_shape
        (2, 4, 5)
        """
        return tuple(int(s) for s in self.array.shape[1:])

    def read(self, step: int) -> NDArray[np.floating]:
        """A float64 copy of time step ``step``.

        Parameters
        ----------
        step : int
            Time step (negative counts from the end, as in numpy).

        Returns
        -------
        ndarray, shape :attr:`frame_shape`

        Examples
        --------
        >>> ArrayFrames(np.arange(3).reshape(3, 1, 1, 1)).read(-1).dtype
        dtype('float64')
        """
        return np.array(self.array[step], dtype=np.float64)


@dataclass
class CallableFrames:
    """Frames computed on demand by ``fn(step) -> array`` (generators, readers).

    Parameters
    ----------
    fn : callable
        ``fn(step)`` returns time step ``step`` as an array of ``frame_shape``.
    n_steps : int
        Number of time steps T.
    frame_shape : tuple of int
        ``(nz, ny, nx)`` or ``(nz, ny, nx, 3)``.

    Examples
    --------
    >>> frames = CallableFrames(lambda k: np.full((2, 2, 2), k), n_steps=4, frame_shape=(2, 2, 2))
    >>> float(frames.read(3)[0, 0, 0])
    3.0
    """

    fn: Callable[[int], NDArray[np.floating]]
    n_steps: int
    frame_shape: tuple[int, ...]

    def read(self, step: int) -> NDArray[np.floating]:
        """Time step ``step``, computed by ``fn``, as float64.

        Parameters
        ----------
        step : int
            Time step.

        Returns
        -------
        ndarray, shape :attr:`frame_shape`

        Raises
        ------
        DataError
            ``fn`` returned an array of another shape.

        Examples
        --------
        >>> CallableFrames(lambda k: np.zeros(3), n_steps=1, frame_shape=(1, 1, 1)).read(0)
        Traceback (most recent call last):
        auralize.errors.DataError: frame 0 has shape (3,), expected (1, 1, 1)
        """
        out = np.asarray(self.fn(step), dtype=np.float64)
        if out.shape != self.frame_shape:
            raise DataError(f"frame {step} has shape {out.shape}, expected {self.frame_shape}")
        return out


@dataclass
class TimeVolume:
    """A time series of point fields on a uniform or curvilinear grid.

    Parameters
    ----------
    origin, spacing : array_like, shape (3,)
        Grid origin and spacing in metres (x, y, z).
    dims : tuple of int
        Number of points ``(nx, ny, nz)``.
    times : array_like, shape (T,)
        Strictly increasing times in seconds.
    fields : mapping of str to FrameSource
        Named point fields; scalar frames ``(nz, ny, nx)``, vectors ``(nz, ny, nx, 3)``.
    physical_times : bool
        False when the source file had no times and ``times`` are frame
        indices at :data:`DEFAULT_FRAME_RATE_HZ`.
    source : str
        Where the volume came from (for messages).
    check_finite : bool
        True: :meth:`frame` raises :class:`~auralize.errors.DataError` on
        NaN/Inf at valid points (``--nan error``); False: NaN, fill values and
        masked cells stay NaN in the frames as no-data (``--nan mask``), and
        +Inf/-Inf are read as NaN: no-data too, never a value (a mapping's
        range or peak would otherwise become infinite).
    attrs : dict
        Free-form metadata (dataset name, units, centring ...).
    valid : ndarray of bool, shape (nz, ny, nx), optional
        True where the grid point lies inside the input mesh (resampled
        curvilinear or unstructured meshes); frames hold NaN where it is
        False.  ``None`` means every point is valid.  Static over time: it is
        the first step's mesh; a mesh that moves (ParaView's ``wavy``) has NaN
        in later frames where it has left a point.
    coords : ndarray, shape (nz, ny, nx, 3), optional
        Each point's position (m) on a structured curvilinear grid; None on a
        uniform grid (see the module docstring).

    Raises
    ------
    DataError
        Non-positive or unusable spacing, bad dims, times that are empty,
        not finite or not strictly increasing, or fields, mask or coordinates
        whose shapes disagree with the grid.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.volume import TimeVolume
    >>> rho = np.ones((3, 4, 4, 4))
    >>> vol = TimeVolume.from_arrays({"density": rho}, spacing=0.5, times=[0, 0.1, 0.2])
    >>> vol.dims, vol.n_steps, vol.bounds[1]
    ((4, 4, 4), 3, 1.5)
    """

    def _repr_html_(self) -> str:
        """Notebook display (:mod:`auralize.runtime.notebook`)."""
        from auralize.runtime.notebook import volume_html

        return volume_html(self)

    origin: NDArray[np.float64]
    spacing: NDArray[np.float64]
    dims: tuple[int, int, int]
    times: NDArray[np.float64]
    fields: dict[str, FrameSource] = field(default_factory=dict)
    physical_times: bool = True
    source: str = "<memory>"
    check_finite: bool = True
    attrs: dict[str, object] = field(default_factory=dict)
    valid: NDArray[np.bool_] | None = None
    coords: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        self.origin = _vec3(self.origin, "origin")
        self.spacing = _vec3(self.spacing, "spacing")
        if np.any(self.spacing <= 0):
            raise DataError(f"{self.source}: grid spacing must be positive, got {self.spacing}")
        # second derivatives divide by h²: it must be a finite, non-zero number
        if np.any(self.spacing < 1e-100) or np.any(self.spacing > 1e100):
            raise DataError(
                f"{self.source}: grid spacing {self.spacing.tolist()} m is outside 1e-100 … 1e100 m "
                f"(the strengths divide by its square); check the grid's units"
            )
        self.dims = tuple(int(d) for d in self.dims)  # type: ignore[assignment]
        if len(self.dims) != 3 or min(self.dims) < 1:
            raise DataError(f"{self.source}: dims must be three positive integers, got {self.dims}")
        far = np.abs(self.origin) + self.spacing * (np.asarray(self.dims) - 1)
        if np.any(self.spacing < 1e3 * np.spacing(far)):
            raise DataError(
                f"{self.source}: grid spacing {self.spacing.tolist()} m is too fine for origin "
                f"{self.origin.tolist()} m: float64 cannot keep neighbouring points apart that far "
                f"from 0; move the origin nearer 0"
            )
        self.times = np.asarray(self.times, dtype=np.float64).reshape(-1)
        if self.times.size == 0:
            raise DataError(f"{self.source}: a volume needs at least one time step")
        if not np.all(np.isfinite(self.times)):
            raise DataError(f"{self.source}: times contain NaN or Inf: {self.times}")
        if np.any(np.diff(self.times) <= 0):
            bad = int(np.argmax(np.diff(self.times) <= 0))
            raise DataError(
                f"{self.source}: times must be strictly increasing; "
                f"t[{bad}]={self.times[bad]!r} >= t[{bad + 1}]={self.times[bad + 1]!r}"
            )
        nx, ny, nz = self.dims
        if self.coords is not None:
            coords = np.ascontiguousarray(self.coords, dtype=np.float64)
            if coords.shape != (nz, ny, nx, 3):
                raise DataError(
                    f"{self.source}: the curvilinear grid's coordinates have shape "
                    f"{coords.shape}; the grid (nx, ny, nz)={self.dims} needs {(nz, ny, nx, 3)}"
                )
            if not np.all(np.isfinite(coords)):
                raise DataError(f"{self.source}: the curvilinear grid's coordinates hold NaN/Inf")
            self.coords = coords
        if self.valid is not None:
            valid = np.asarray(self.valid)
            if valid.shape != (nz, ny, nx):
                raise DataError(
                    f"{self.source}: the valid-point mask has shape {valid.shape}; the grid "
                    f"(nx, ny, nz)={self.dims} needs {(nz, ny, nx)}"
                )
            self.valid = None if valid.all() else valid.astype(bool, copy=False)
        for name, src in self.fields.items():
            shape = tuple(src.frame_shape)
            if shape not in ((nz, ny, nx), (nz, ny, nx, 3)):
                raise DataError(
                    f"{self.source}: field {name!r} has frame shape {shape}; the grid "
                    f"(nx, ny, nz)={self.dims} needs {(nz, ny, nx)} or {(nz, ny, nx, 3)}"
                )
            if src.n_steps != self.times.size:
                raise DataError(
                    f"{self.source}: field {name!r} has {src.n_steps} time steps but the "
                    f"volume has {self.times.size} times"
                )

    # ------------------------------------------------------------------ build
    @classmethod
    def from_arrays(
        cls,
        fields: Mapping[str, NDArray[np.floating]],
        *,
        origin: float | tuple[float, float, float] = 0.0,
        spacing: float | tuple[float, float, float] = 1.0,
        times: NDArray[np.floating] | list[float] | None = None,
        source: str = "<memory>",
        coords: NDArray[np.floating] | None = None,
    ) -> TimeVolume:
        """Build a volume from in-memory ``(T, nz, ny, nx[, 3])`` arrays.

        Parameters
        ----------
        fields : mapping of str to array_like
            Named fields, each ``(T, nz, ny, nx)`` (scalar) or
            ``(T, nz, ny, nx, 3)`` (vector), all on the same grid.
        origin : float or (3,) tuple
            Position of point (0, 0, 0), m (one number: the same on every axis).
        spacing : float or (3,) tuple
            Point spacing, m.
        times : array_like, shape (T,), optional
            Seconds, strictly increasing; None means frames at
            :data:`DEFAULT_FRAME_RATE_HZ` (``physical_times`` False).
        source : str
            Name for messages.
        coords : ndarray, shape (nz, ny, nx, 3), optional
            The points of a structured curvilinear grid (``origin`` and
            ``spacing`` are then taken from them).

        Returns
        -------
        TimeVolume

        Raises
        ------
        DataError
            No field, or arrays of a bad or inconsistent shape.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"u": np.zeros((2, 3, 4, 5, 3))}, origin=(1, 0, 0))
        >>> vol.dims, vol.is_vector("u"), vol.physical_times, vol.times.tolist()[1]
        ((5, 4, 3), True, False, 0.03333333333333333)
        """
        if coords is not None:
            from auralize.curvilinear import nominal_spacing

            c = np.asarray(coords, dtype=np.float64)
            if c.ndim == 4 and c.shape[-1] == 3:
                lo, h = c.reshape(-1, 3).min(axis=0), nominal_spacing(c)
                origin = (float(lo[0]), float(lo[1]), float(lo[2]))
                spacing = (float(h[0]), float(h[1]), float(h[2]))
        if not fields:
            raise DataError("a volume needs at least one field")
        frames: dict[str, FrameSource] = {k: ArrayFrames(np.asarray(v)) for k, v in fields.items()}
        first = next(iter(frames.values()))
        nz, ny, nx = first.frame_shape[:3]
        physical = times is not None
        t = (
            np.arange(first.n_steps) / DEFAULT_FRAME_RATE_HZ
            if times is None
            else np.asarray(times, dtype=np.float64)
        )
        return cls(
            origin=np.broadcast_to(np.asarray(origin, dtype=np.float64), (3,)).copy(),
            spacing=np.broadcast_to(np.asarray(spacing, dtype=np.float64), (3,)).copy(),
            dims=(nx, ny, nz),
            times=t,
            fields=dict(frames),
            physical_times=physical,
            source=source,
            coords=None if coords is None else np.asarray(coords, dtype=np.float64),
        )

    # --------------------------------------------------------------- queries
    @property
    def curvilinear(self) -> bool:
        """Whether the grid is structured curvilinear (:attr:`coords`), read natively.

        Examples
        --------
        >>> TimeVolume.from_arrays({"p": np.zeros((1, 2, 2, 2))}).curvilinear
        False
        """
        return self.coords is not None

    @property
    def metric(self) -> Any:
        """The :class:`~auralize.curvilinear.CurvilinearMetric` of a curvilinear grid
        (computed once); None on a uniform grid.

        Examples
        --------
        >>> TimeVolume.from_arrays({"p": np.zeros((1, 2, 2, 2))}).metric is None
        True
        """
        if self.coords is None:
            return None
        # kept outside the dataclass' fields (Dask rebuilds a volume from those)
        cached = self.__dict__.get("_metric_cache")
        if cached is None:
            from auralize.curvilinear import CurvilinearMetric

            cached = CurvilinearMetric(self.coords, thickness=self.spacing, source=self.source)
            self.__dict__["_metric_cache"] = cached
        return cached

    @property
    def n_steps(self) -> int:
        """Number of time steps T.

        Examples
        --------
        >>> TimeVolume.from_arrays({"p": np.zeros((5, 2, 2, 2))}).n_steps
        5
        """
        return int(self.times.size)

    @property
    def n_points(self) -> int:
        """Number of grid points, nx · ny · nz.

        Examples
        --------
        >>> TimeVolume.from_arrays({"p": np.zeros((1, 2, 3, 4))}).n_points
        24
        """
        return int(np.prod(self.dims))

    @property
    def shape(self) -> tuple[int, int, int]:
        """Array shape of a scalar frame, ``(nz, ny, nx)``.

        Examples
        --------
        >>> TimeVolume.from_arrays({"p": np.zeros((1, 2, 3, 4))}).shape
        (2, 3, 4)
        """
        nx, ny, nz = self.dims
        return (nz, ny, nx)

    @property
    def field_names(self) -> list[str]:
        """Names of the fields, in order.

        Examples
        --------
        >>> TimeVolume.from_arrays({"p": np.zeros((1, 2, 2, 2)), "q": np.zeros((1, 2, 2, 2))}).field_names
        ['p', 'q']
        """
        return list(self.fields)

    @property
    def bounds(self) -> tuple[float, float, float, float, float, float]:
        """``(xmin, xmax, ymin, ymax, zmin, zmax)`` in metres (pyvista order).

        Examples
        --------
        >>> TimeVolume.from_arrays({"p": np.zeros((1, 2, 2, 3))}, spacing=0.5).bounds
        (0.0, 1.0, 0.0, 0.5, 0.0, 0.5)
        """
        if self.coords is not None:
            flat = self.coords.reshape(-1, 3)
            lo_c, hi_c = flat.min(axis=0), flat.max(axis=0)
            return tuple(float(v) for a in range(3) for v in (lo_c[a], hi_c[a]))  # type: ignore[return-value]
        hi = self.origin + self.spacing * (np.asarray(self.dims) - 1)
        return (
            float(self.origin[0]),
            float(hi[0]),
            float(self.origin[1]),
            float(hi[1]),
            float(self.origin[2]),
            float(hi[2]),
        )

    @property
    def center(self) -> NDArray[np.float64]:
        """Centre of the bounding box, ``(3,)`` m.

        Examples
        --------
        >>> TimeVolume.from_arrays({"p": np.zeros((1, 2, 2, 3))}, origin=1.0).center.tolist()
        [2.0, 1.5, 1.5]
        """
        b = np.asarray(self.bounds).reshape(3, 2)
        return b.mean(axis=1)

    def is_vector(self, name: str) -> bool:
        """Whether field ``name`` is a vector field (frames ``(nz, ny, nx, 3)``).

        Parameters
        ----------
        name : str
            A field of the volume.

        Returns
        -------
        bool

        Raises
        ------
        FieldError
            No field of that name.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"p": np.zeros((1, 2, 2, 2))})
        >>> vol.is_vector("p")
        False
        >>> vol.is_vector("velocity")
        Traceback (most recent call last):
        auralize.errors.FieldError: <memory>: no field 'velocity'; available fields: p
        """
        return len(self._get(name).frame_shape) == 4

    def _get(self, name: str) -> FrameSource:
        try:
            return self.fields[name]
        except KeyError:
            raise FieldError(
                f"{self.source}: no field {name!r}; available fields: "
                f"{', '.join(self.fields) or '(none)'}"
            ) from None

    def frame(self, name: str, step: int) -> NDArray[np.float64]:
        """Read one time step of one field: finite values and NaN (no-data) only.

        With ``check_finite`` a NaN or ±Inf at a valid point raises
        :class:`~auralize.errors.DataError`; without it ±Inf is replaced by NaN,
        so every consumer treats it as the no-data it is (counted alike by
        :func:`tally_nonfinite`).

        Parameters
        ----------
        name : str
            Field name.
        step : int
            Time step (negative counts from the end).

        Returns
        -------
        ndarray, shape (nz, ny, nx) or (nz, ny, nx, 3)
            A new float64 array.

        Raises
        ------
        FieldError
            No field of that name.
        IndexError
            ``step`` out of range.
        DataError
            NaN/Inf at a valid point with ``check_finite``.

        Examples
        --------
        >>> a = np.arange(8.0).reshape(2, 1, 2, 2)
        >>> TimeVolume.from_arrays({"p": a}).frame("p", -1).ravel().tolist()
        [4.0, 5.0, 6.0, 7.0]
        >>> bad = TimeVolume.from_arrays({"p": np.full((1, 1, 1, 2), np.inf)})
        >>> bad.frame("p", 0)
        Traceback (most recent call last):
        auralize.errors.DataError: <memory>: field 'p' at step 0 (t=0 s) has 2 NaN/Inf values ...
        """
        src = self._get(name)
        if not -self.n_steps <= step < self.n_steps:
            raise IndexError(
                f"{self.source}: step {step} out of range; the volume has {self.n_steps} steps"
            )
        step = step % self.n_steps
        arr = np.asarray(src.read(step), dtype=np.float64)
        if not self.check_finite:
            arr = inf_as_nan(arr)
        if self.check_finite and not np.all(np.isfinite(arr)):
            bad_points: NDArray[np.bool_] = np.asarray(~np.isfinite(arr))
            if bad_points.ndim == 4:
                bad_points = np.asarray(bad_points.any(axis=-1))
            if self.valid is not None:
                bad_points &= self.valid
            bad = int(np.count_nonzero(bad_points))
            if bad:
                raise DataError(
                    f"{self.source}: field {name!r} at step {step} (t={self.times[step]:g} s) "
                    f"has {bad} NaN/Inf values (fill values or masked cells); use --nan mask "
                    f"(nan='mask') to treat them as no-data, or clean the data"
                )
        return arr

    def iter_frames(self, name: str) -> Iterator[NDArray[np.float64]]:
        """Every time step of a field in turn, read as :meth:`frame` reads it.

        Parameters
        ----------
        name : str
            Field name.

        Yields
        ------
        ndarray, shape (nz, ny, nx) or (nz, ny, nx, 3)

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"p": np.arange(3.0).reshape(3, 1, 1, 1)})
        >>> [float(f[0, 0, 0]) for f in vol.iter_frames("p")]
        [0.0, 1.0, 2.0]
        """
        for n in range(self.n_steps):
            yield self.frame(name, n)

    def load(self) -> TimeVolume:
        """Return a copy with every field read into memory.

        Returns
        -------
        TimeVolume
            The same grid, times and attributes; fields are :class:`ArrayFrames`.

        Examples
        --------
        >>> lazy = TimeVolume.from_arrays({"p": np.zeros((2, 1, 1, 1))})
        >>> lazy.fields["p"] = CallableFrames(lambda k: np.full((1, 1, 1), k), 2, (1, 1, 1))
        >>> type(lazy.load().fields["p"]).__name__, lazy.load().frame("p", 1).item()
        ('ArrayFrames', 1.0)
        """
        loaded = {k: ArrayFrames(np.stack(list(self.iter_frames(k)))) for k in self.fields}
        return TimeVolume(
            origin=self.origin.copy(),
            spacing=self.spacing.copy(),
            dims=self.dims,
            times=self.times.copy(),
            fields=dict(loaded),
            physical_times=self.physical_times,
            source=self.source,
            check_finite=self.check_finite,
            attrs=dict(self.attrs),
            valid=self.valid,
            coords=self.coords,
        )

    def axis_coords(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Coordinates along x, y, z of a uniform grid.

        Returns
        -------
        x, y, z : ndarray, shapes (nx,), (ny,), (nz,)
            Point coordinates, m.

        Raises
        ------
        DataError
            The grid is curvilinear (use :meth:`points`).

        Examples
        --------
        >>> x, y, z = TimeVolume.from_arrays({"p": np.zeros((1, 1, 1, 3))}, spacing=0.5).axis_coords()
        >>> x.tolist(), z.tolist()
        ([0.0, 0.5, 1.0], [0.0])
        """
        if self.coords is not None:
            raise DataError(
                f"{self.source}: a curvilinear grid has no coordinate axes; use points()"
            )
        return tuple(self.origin[a] + self.spacing[a] * np.arange(self.dims[a]) for a in range(3))

    def points(self, flat_index: NDArray[np.integer] | None = None) -> NDArray[np.float64]:
        """Point positions for C-order flat indices of a scalar frame.

        Parameters
        ----------
        flat_index : array_like of int, shape (N,), optional
            Indices into a C-order ravel of a ``(nz, ny, nx)`` frame; None:
            all points.

        Returns
        -------
        ndarray, shape (N, 3)
            Positions, m.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"p": np.zeros((1, 2, 2, 2))}, spacing=2.0)
        >>> vol.points(np.array([1, 7])).tolist()
        [[2.0, 0.0, 0.0], [2.0, 2.0, 2.0]]
        """
        if flat_index is None:
            flat_index = np.arange(self.n_points)
        if self.coords is not None:
            return self.coords.reshape(-1, 3)[np.asarray(flat_index)]
        k, j, i = np.unravel_index(np.asarray(flat_index), self.shape)
        ijk = np.stack([i, j, k], axis=-1).astype(np.float64)
        return self.origin + ijk * self.spacing

    def contains(self, pts: NDArray[np.floating], *, tol: float = 1e-9) -> NDArray[np.bool_]:
        """Which points lie inside the grid's bounding box.

        Parameters
        ----------
        pts : array_like, shape (N, 3)
            Positions, m.
        tol : float
            Tolerance on each face, m.

        Returns
        -------
        ndarray of bool, shape (N,)

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"p": np.zeros((1, 2, 2, 2))})
        >>> vol.contains([[0.5, 0.5, 0.5], [2.0, 0.0, 0.0]]).tolist()
        [True, False]
        """
        b = np.asarray(self.bounds).reshape(3, 2)
        p = np.asarray(pts, dtype=np.float64).reshape(-1, 3)
        return np.all((p >= b[:, 0] - tol) & (p <= b[:, 1] + tol), axis=1)

    @property
    def valid_ratio(self) -> float:
        """Fraction of grid points inside the input mesh (1.0 without a mask).

        Examples
        --------
        >>> import dataclasses
        >>> vol = TimeVolume.from_arrays({"p": np.zeros((1, 1, 2, 2))})
        >>> vol.valid_ratio
        1.0
        >>> mask = np.array([True, False, True, True]).reshape(1, 2, 2)
        >>> dataclasses.replace(vol, valid=mask).valid_ratio
        0.75
        """
        if self.valid is None:
            return 1.0
        return float(np.count_nonzero(self.valid)) / float(self.valid.size)

    def valid_mask(self) -> NDArray[np.bool_]:
        """The valid-point mask (all True when :attr:`valid` is None).

        Returns
        -------
        ndarray of bool, shape (nz, ny, nx)

        Examples
        --------
        >>> TimeVolume.from_arrays({"p": np.zeros((1, 1, 2, 2))}).valid_mask().tolist()
        [[[True, True], [True, True]]]
        """
        if self.valid is None:
            return np.ones(self.shape, dtype=bool)
        return self.valid

    def __repr__(self) -> str:
        """A few lines: the grid, the times, the fields (never the arrays)."""
        from auralize.runtime.reprs import number, span, summary

        nx, ny, nz = self.dims
        b = self.bounds
        box = f"x[{number(b[0])}, {number(b[1])}] y[{number(b[2])}, {number(b[3])}] z[{number(b[4])}, {number(b[5])}] m"
        if self.coords is not None:
            grid = f"curvilinear {nx} × {ny} × {nz} points, {box}"
        else:
            grid = (
                f"{nx} × {ny} × {nz} points, spacing "
                f"{', '.join(number(v) for v in self.spacing)} m, {box}"
            )
        valid = self.valid_ratio
        times = f"{self.n_steps} steps, {span(self.times)}" + (
            "" if self.physical_times else " (frame numbers: no times in the file)"
        )
        fields = ", ".join(
            f"{k} ({'vector' if self.is_vector(k) else 'scalar'})" for k in self.field_names
        )
        return summary(
            f"TimeVolume {self.source}",
            [
                ("grid", grid),
                ("valid", "" if valid >= 1 else f"{100 * valid:.3g} % of the points"),
                ("times", times),
                ("fields", fields or "none"),
            ],
        )

    def describe(self) -> dict[str, object]:
        """A JSON-able summary (used by ``auralize info``).

        Returns
        -------
        dict
            Source, grid kind, dims, origin, spacing and bounds (m), number of
            steps, first and last time (s), whether the times are physical,
            the valid ratio and each field's kind; a curvilinear grid adds the
            shortest and longest edge between neighbouring points
            (``edge_lengths``, m).

        Examples
        --------
        >>> d = TimeVolume.from_arrays({"p": np.zeros((2, 1, 1, 2))}, times=[0, 0.5]).describe()
        >>> d["grid"], d["dims"], d["t_end"], d["fields"]
        ('uniform', [2, 1, 1], 0.5, {'p': 'scalar'})
        """
        extra: dict[str, object] = {}
        if self.coords is not None:
            lengths = [
                np.linalg.norm(np.diff(self.coords, axis=ax), axis=-1).reshape(-1)
                for ax in range(3)
                if self.coords.shape[ax] > 1
            ]
            flat = np.concatenate(lengths) if lengths else np.zeros(1)
            extra["edge_lengths"] = [float(flat.min()), float(flat.max())]
        return extra | {
            "source": self.source,
            "grid": "curvilinear, native" if self.coords is not None else "uniform",
            "dims": list(self.dims),
            "origin": self.origin.tolist(),
            "spacing": self.spacing.tolist(),
            "bounds": list(self.bounds),
            "n_steps": self.n_steps,
            "t_start": float(self.times[0]),
            "t_end": float(self.times[-1]),
            "physical_times": self.physical_times,
            "valid_ratio": self.valid_ratio,
            "fields": {
                k: ("vector" if len(v.frame_shape) == 4 else "scalar")
                for k, v in self.fields.items()
            },
        }


def inf_as_nan(arr: NDArray[np.float64]) -> NDArray[np.float64]:
    """``arr`` with +Inf/-Inf replaced by NaN: no-data, as NaN is (``--nan mask``).

    Parameters
    ----------
    arr : ndarray
        Any float array.

    Returns
    -------
    ndarray
        ``arr`` itself when it holds no infinity, else a new array (the
        caller's data are never modified).

    Examples
    --------
    >>> inf_as_nan(np.array([1.0, -np.inf, np.nan, np.inf])).tolist()
    [1.0, nan, nan, nan]
    """
    with np.errstate(over="ignore", invalid="ignore"):
        if np.isfinite(np.sum(arr)):  # the common case: one pass, no mask allocated
            return arr
    inf = np.isinf(arr)
    return np.where(inf, np.nan, arr) if inf.any() else arr


@dataclass
class NonFiniteTally:
    """Counts of NaN/Inf (no-data) values seen at valid points while frames are read.

    Made by :func:`tally_nonfinite`, which updates it as frames are read.

    Parameters
    ----------
    points_read : int
        Valid points read so far (per frame, not per vector component).
    nonfinite : int
        Of those, the points with a NaN or ±Inf.

    Examples
    --------
    >>> NonFiniteTally(points_read=8, nonfinite=2).fraction
    0.25
    """

    points_read: int = 0
    nonfinite: int = 0

    @property
    def fraction(self) -> float:
        """Masked (no-data) fraction of the valid points read so far (0 before any).

        Examples
        --------
        >>> NonFiniteTally().fraction
        0.0
        """
        return self.nonfinite / self.points_read if self.points_read else 0.0


@dataclass
class _TalliedFrames:
    base: FrameSource
    valid: NDArray[np.bool_] | None
    tally: NonFiniteTally

    @property
    def n_steps(self) -> int:
        return int(self.base.n_steps)

    @property
    def frame_shape(self) -> tuple[int, ...]:
        return tuple(self.base.frame_shape)

    def read(self, step: int) -> NDArray[np.floating]:
        arr = np.asarray(self.base.read(step), dtype=np.float64)
        bad: NDArray[np.bool_] = np.asarray(~np.isfinite(arr))
        if bad.ndim == 4:
            bad = np.asarray(bad.any(axis=-1))
        if self.valid is not None:
            bad &= self.valid
            self.tally.points_read += int(np.count_nonzero(self.valid))
        else:
            self.tally.points_read += int(bad.size)
        self.tally.nonfinite += int(np.count_nonzero(bad))
        return arr


def tally_nonfinite(volume: TimeVolume) -> tuple[TimeVolume, NonFiniteTally]:
    """The same volume, counting the NaN/Inf values at valid points of every frame read.

    Used to report the masked fraction of a run without a second pass over
    the data.

    Parameters
    ----------
    volume : TimeVolume
        Usually read with ``check_finite=False`` (``--nan mask``).

    Returns
    -------
    volume : TimeVolume
        A copy whose fields count as they are read.
    tally : NonFiniteTally
        The counts, updated by every frame read from the copy.

    Examples
    --------
    >>> a = np.ones((1, 1, 2, 2)); a[0, 0, 0, 0] = np.nan
    >>> vol = TimeVolume.from_arrays({"p": a})
    >>> vol.check_finite = False
    >>> counted, tally = tally_nonfinite(vol)
    >>> _ = counted.frame("p", 0)
    >>> tally.nonfinite, tally.points_read, tally.fraction
    (1, 4, 0.25)
    """
    import dataclasses

    tally = NonFiniteTally()
    fields: dict[str, FrameSource] = {
        k: _TalliedFrames(v, volume.valid, tally) for k, v in volume.fields.items()
    }
    return dataclasses.replace(volume, fields=fields), tally


def _vec3(value: object, name: str) -> NDArray[np.float64]:
    arr = np.asarray(value, dtype=np.float64).reshape(-1)
    if arr.size == 1:
        arr = np.repeat(arr, 3)
    if arr.size != 3 or not np.all(np.isfinite(arr)):
        raise DataError(f"{name} must be 3 finite numbers, got {value!r}")
    return arr


def as_path(p: str | Path) -> Path:
    """A file name as a :class:`~pathlib.Path`, with ``~`` expanded.

    Parameters
    ----------
    p : str or Path

    Returns
    -------
    Path

    Examples
    --------
    >>> as_path("data/run.h5").parts
    ('data', 'run.h5')
    >>> as_path("~/run.h5").is_absolute()
    True
    """
    return Path(p).expanduser()
