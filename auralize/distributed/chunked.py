"""Lazy, chunked volumes: frames as Dask arrays, and z-slabs with ghost layers.

* :func:`to_dask` turns one field of any :class:`~auralize.volume.TimeVolume`
  (HDF5, VTK series, OpenFOAM, generated) into a Dask array
  ``(T, nz, ny, nx[, 3])`` with one time step per chunk; building it reads
  nothing.  :func:`volume_from_dask` goes the other way (e.g. for Zarr
  stores opened with ``dask.array.from_zarr``), and :func:`chunked_volume`
  re-backs every field of a volume by Dask arrays.
* :class:`SlabFrames` and :func:`slab_volume` cut a volume into a z-slab
  ``[z0, z1)`` so a task holds only that part of each frame.  HDF5 datasets
  are read as hyperslabs (only the slab's bytes); other sources read the
  whole frame and slice it.

Slabs are what bounds the memory of distributed detection: a task on a slab
of ``s`` planes of a ``n × n`` grid keeps about 20 · s · n² · 8 bytes alive
(mapped frames of three steps, strengths and kernel scratch).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.distributed._dask import require
from auralize.errors import DataError, FormatError
from auralize.volume import FrameSource, TimeVolume, inf_as_nan


def _read_step(
    src: FrameSource, step: int, shape: tuple[int, ...], label: str, no_inf: bool = False
) -> NDArray[np.float64]:
    """One step as a chunk ``(1, *shape)``; with ``no_inf`` ±Inf is read as NaN (no-data),
    as :meth:`TimeVolume.frame <auralize.volume.TimeVolume.frame>` reads it."""
    arr = np.asarray(src.read(step), dtype=np.float64)
    if arr.shape != shape:
        raise DataError(
            f"{label}: step {step} has shape {arr.shape}, but the chunk is declared as {shape}; "
            f"every step of a field must have the same frame shape"
        )
    if no_inf:
        arr = inf_as_nan(arr)
    return arr[None]


def to_dask(volume: TimeVolume, name: str) -> Any:
    """One field as a lazy Dask array ``(T, nz, ny, nx[, 3])``, one step per chunk.

    Parameters
    ----------
    volume : TimeVolume
        Any volume; its frame source must be picklable for process-based or
        distributed schedulers (the HDF5 and VTK readers' are).
    name : str
        Field name.

    Returns
    -------
    dask.array.Array
        float64; computing a chunk calls the field's ``read(step)`` and checks
        the shape (a mismatch raises :class:`~auralize.errors.DataError`).
        When the volume does not check finiteness (``check_finite`` False,
        ``--nan mask``) ±Inf is read as NaN, as :meth:`TimeVolume.frame` reads it.

    Examples
    --------
    >>> import numpy as np
    >>> vol = TimeVolume.from_arrays({"p": np.arange(24.0).reshape(3, 2, 2, 2)})
    >>> arr = to_dask(vol, "p")
    >>> arr.chunks[0], float(arr[1].sum().compute(scheduler="sync"))
    ((1, 1, 1), 92.0)
    """
    da = require("dask.array")
    src = volume._get(name)
    shape = tuple(int(s) for s in src.frame_shape)
    label = f"{volume.source}: field {name!r}"
    no_inf = not volume.check_finite
    tok = require("dask.base").tokenize(
        volume.source, name, shape, volume.times.tobytes(), id(src), no_inf
    )
    key = f"auralize-frames-{name}-{tok}"
    layer = {
        (key, n, *(0,) * len(shape)): (_read_step, src, n, shape, label, no_inf)
        for n in range(volume.n_steps)
    }
    chunks = ((1,) * volume.n_steps, *((s,) for s in shape))
    return da.Array(layer, key, chunks, dtype=np.float64)


@dataclass
class DaskFrames:
    """A :class:`~auralize.volume.FrameSource` over a Dask (or NumPy) array ``(T, ...)``.

    ``read`` computes one step with the synchronous scheduler (inside a
    distributed task this runs on the worker itself).
    """

    array: Any

    def __post_init__(self) -> None:
        shape = tuple(int(s) for s in self.array.shape)
        if len(shape) not in (4, 5) or (len(shape) == 5 and shape[-1] != 3):
            raise DataError(
                f"a field array must have shape (T, nz, ny, nx) or (T, nz, ny, nx, 3); got {shape}"
            )

    @property
    def n_steps(self) -> int:
        return int(self.array.shape[0])

    @property
    def frame_shape(self) -> tuple[int, ...]:
        return tuple(int(s) for s in self.array.shape[1:])

    def _get(self, sel: tuple[Any, ...]) -> NDArray[np.float64]:
        part = self.array[sel]
        if hasattr(part, "compute"):
            part = part.compute(scheduler="sync")
        return np.asarray(part, dtype=np.float64)

    def read(self, step: int) -> NDArray[np.float64]:
        out = self._get((step,))
        if out.shape != self.frame_shape:  # pragma: no cover - dask keeps shapes
            raise DataError(f"step {step} has shape {out.shape}, expected {self.frame_shape}")
        return out

    def read_slab(self, step: int, z0: int, z1: int) -> NDArray[np.float64]:
        return self._get((step, slice(z0, z1)))


def volume_from_dask(
    fields: Mapping[str, Any],
    *,
    times: Any = None,
    origin: float | tuple[float, float, float] = 0.0,
    spacing: float | tuple[float, float, float] = 1.0,
    source: str = "<dask>",
    coords: NDArray[np.floating] | None = None,
) -> TimeVolume:
    """A lazy :class:`TimeVolume` whose fields are Dask arrays ``(T, nz, ny, nx[, 3])``.

    Parameters
    ----------
    fields : mapping of str to dask.array.Array
        Arrays of one grid and one number of steps; any chunking (a chunk
        spanning several steps is read whole for each of its steps, so one
        step per chunk is best).
    times : array_like, optional
        Seconds; default: frames at 30 Hz.
    origin, spacing : float or (3,)
        Grid geometry in metres.
    coords : (nz, ny, nx, 3) array, optional
        The points of a structured curvilinear grid (``origin`` is then their
        lowest corner; ``spacing`` the nominal size, as in
        :class:`~auralize.volume.TimeVolume`).

    Raises
    ------
    DataError
        Arrays of different grids or step counts, or of a shape that is not a
        field's.

    Examples
    --------
    >>> import dask.array as da
    >>> vol = volume_from_dask({"rho": da.ones((4, 3, 3, 3), chunks=(1, 3, 3, 3))})
    >>> vol.n_steps, vol.dims
    (4, (3, 3, 3))
    """
    require("dask.array")
    if not fields:
        raise DataError("a volume needs at least one field")
    frames = {name: DaskFrames(arr) for name, arr in fields.items()}
    first_name, first = next(iter(frames.items()))
    grid = first.frame_shape[:3]
    for name, fr in frames.items():
        if fr.frame_shape[:3] != grid or fr.n_steps != first.n_steps:
            raise DataError(
                f"{source}: field {name!r} has shape {(fr.n_steps, *fr.frame_shape)} but field "
                f"{first_name!r} has {(first.n_steps, *first.frame_shape)}; all fields need the "
                f"same number of steps and the same (nz, ny, nx) grid"
            )
    physical = times is not None
    t = np.arange(first.n_steps) / 30.0 if times is None else np.asarray(times, dtype=np.float64)
    nz, ny, nx = grid
    if coords is not None:
        origin = tuple(np.asarray(coords, dtype=np.float64).reshape(-1, 3).min(axis=0))
    return TimeVolume(
        origin=np.broadcast_to(np.asarray(origin, dtype=np.float64), (3,)).copy(),
        spacing=np.broadcast_to(np.asarray(spacing, dtype=np.float64), (3,)).copy(),
        dims=(nx, ny, nz),
        times=t,
        fields=dict(frames),
        physical_times=physical,
        source=source,
        coords=None if coords is None else np.asarray(coords, dtype=np.float64),
    )


def chunked_volume(volume: TimeVolume) -> TimeVolume:
    """The same volume with every field backed by a Dask array (one step per chunk)."""
    vol = volume_from_dask(
        {name: to_dask(volume, name) for name in volume.field_names},
        times=volume.times,
        origin=tuple(volume.origin),
        spacing=tuple(volume.spacing),
        source=volume.source,
        coords=volume.coords,
    )
    vol.physical_times = volume.physical_times
    vol.attrs = dict(volume.attrs)
    vol.valid = volume.valid
    vol.check_finite = volume.check_finite
    return vol


# ------------------------------------------------------------------ z-slabs
@dataclass
class SlabFrames:
    """Planes ``[z0, z1)`` of another frame source (an HDF5 field is read as a hyperslab)."""

    base: FrameSource
    z0: int
    z1: int

    @property
    def n_steps(self) -> int:
        return int(self.base.n_steps)

    @property
    def frame_shape(self) -> tuple[int, ...]:
        full = tuple(self.base.frame_shape)
        return (self.z1 - self.z0, *full[1:])

    def read(self, step: int) -> NDArray[np.float64]:
        from auralize.io.hdf5 import HDF5Frames

        b = self.base
        if isinstance(b, HDF5Frames):
            arr = _read_hdf5_slab(b, step, self.z0, self.z1)
        elif hasattr(b, "read_slab"):
            arr = np.asarray(b.read_slab(step, self.z0, self.z1), dtype=np.float64)
        else:
            full = np.asarray(b.read(step), dtype=np.float64)
            if full.shape != tuple(b.frame_shape):
                raise DataError(
                    f"step {step}: the frame source returned shape {full.shape}, but its frames "
                    f"are declared as {tuple(b.frame_shape)}; every step of a field must have "
                    f"the same shape"
                )
            arr = full[self.z0 : self.z1]
        if arr.shape != self.frame_shape:
            raise DataError(
                f"step {step}, planes {self.z0}:{self.z1}: got shape {arr.shape}, expected "
                f"{self.frame_shape}; the frame source returned a chunk of the wrong shape"
            )
        return np.ascontiguousarray(arr)


def _read_hdf5_slab(b: Any, step: int, z0: int, z1: int) -> NDArray[np.float64]:
    import h5py

    try:
        with h5py.File(b.filename, "r") as f:
            ds = f[b.dataset]
            if b.axes == "txyz":
                raw = np.asarray(ds[step, :, :, z0:z1], dtype=np.float64)
                return np.ascontiguousarray(raw.transpose(2, 1, 0, *range(3, raw.ndim)))
            return np.asarray(ds[step, z0:z1], dtype=np.float64)
    except (OSError, KeyError, ValueError) as exc:
        raise FormatError(
            f"{b.filename}: cannot read step {step}, planes {z0}:{z1} of {b.dataset!r} ({exc}); "
            f"the file may be truncated, corrupt or changed since it was opened"
        ) from exc


def slab_volume(volume: TimeVolume, z0: int, z1: int) -> TimeVolume:
    """Planes ``[z0, z1)`` of ``volume`` as a volume of its own (origin moved to plane z0).

    A curvilinear volume's slab holds those planes' points (``coords``; its origin
    is their lowest corner) and keeps
    the volume's nominal spacing (the thickness of an axis of one point), so its
    metric terms (:mod:`auralize.curvilinear`) are the whole grid's wherever the
    stencils stay inside the slab.
    """
    nx, ny, nz = volume.dims
    if not 0 <= z0 < z1 <= nz:
        raise DataError(f"{volume.source}: slab {z0}:{z1} outside the {nz} z-planes")
    origin = volume.origin.copy()
    coords = None if volume.coords is None else volume.coords[z0:z1]
    if coords is not None:
        origin = coords.reshape(-1, 3).min(axis=0)
    else:
        origin[2] += z0 * volume.spacing[2]
    sub = TimeVolume(
        origin=origin,
        spacing=volume.spacing.copy(),
        dims=(nx, ny, z1 - z0),
        times=volume.times,
        fields={k: SlabFrames(v, z0, z1) for k, v in volume.fields.items()},
        physical_times=volume.physical_times,
        source=f"{volume.source}[z {z0}:{z1}]",
        check_finite=volume.check_finite,
        valid=None if volume.valid is None else volume.valid[z0:z1],
        coords=coords,
    )
    valid = getattr(volume, "valid", None)  # the validity mask (nz, ny, nx), if any
    if valid is not None:
        sub.valid = np.asarray(valid)[z0:z1]  # type: ignore[attr-defined]
    return sub
