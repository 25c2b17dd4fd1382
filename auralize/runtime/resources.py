"""Memory estimates: refuse a request larger than the machine before allocating it.

Every entry point that sizes an allocation from user input (a render's
duration × rate × channels, a path's captures, the frame size a file
declares, a plugin's simulation length) calls :func:`require_memory` with its
estimate first; a request beyond the memory available raises
:class:`~auralize.errors.ResourceError` with both figures, so the user sees
``render needs 33 GiB ... 21 GiB available`` instead of a crash (or the
kernel's OOM killer) minutes later.

The available figure is Linux's ``MemAvailable`` (``/proc/meminfo``), capped
by the process's cgroup limit; elsewhere ``psutil`` when installed, else the
physical memory reported by ``os.sysconf``.  ``AURALIZE_MEMORY_LIMIT`` (bytes,
or with a ``K``/``M``/``G``/``T`` suffix) lowers it, e.g. on a shared machine.

A volume's time steps count too (:func:`require_volume`): every step holds
:data:`STEP_BYTES` whatever its grid, and one command reads at most
``AURALIZE_DATA_LIMIT`` (default :data:`DEFAULT_DATA_LIMIT`, 128 GiB) of data:
steps x points x components as float64, each step counted as at least
:data:`STEP_MIN_VALUES` values (the fixed cost of a step of a small grid).
Beyond it a command is refused before it starts, with the figure; below it a
long one says how long it may take (:func:`work_estimate`).

A :class:`MemoryError` that escapes an allocation anyway (an estimate that was
low, memory taken by another process) becomes a
:class:`~auralize.errors.ResourceError` naming the work and the figures
(:func:`memory_error`, :func:`memory_guard`).
"""

from __future__ import annotations

import contextlib
import math
import os
import shutil
from collections.abc import Iterator, Sequence
from pathlib import Path

from auralize.errors import OutputError, ParameterError, ResourceError

_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}


def format_bytes(n: float) -> str:
    """``n`` bytes as a short human figure, e.g. ``'32.9 GiB'``."""
    if not math.isfinite(n):
        return f"{n!r} bytes"
    for unit, div in (("PiB", 1 << 50), ("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20)):
        if n >= div:
            return f"{n / div:.3g} {unit}"
    return f"{n / 1024:.3g} KiB"


def _meminfo_available() -> int | None:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def _cgroup_limit() -> int | None:
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(path) as f:
                text = f.read().strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < 1 << 60:
            return int(text)
    return None


def env_size(name: str) -> int | None:
    """The size in bytes that environment variable ``name`` gives (``None`` if unset).

    Bytes, or a number with a ``K``/``M``/``G``/``T`` suffix (powers of 1024; a
    trailing ``B`` is allowed): ``8G``, ``512MB``, ``1e9``.

    Raises
    ------
    ParameterError
        The value is not such a size (a finite number >= 0).
    """
    raw = os.environ.get(name, "")
    text = raw.strip().upper().removesuffix("B")
    if not text:
        return None
    unit = text[-1] if text[-1] in _UNITS else ""
    try:
        value = float(text[: len(text) - len(unit)]) * _UNITS[unit]
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise ParameterError(
            f"{name}={raw!r} is not a size; give bytes or a number with K, M, G or T"
        )
    return int(value)


def _env_limit() -> int | None:
    return env_size("AURALIZE_MEMORY_LIMIT")


def available_bytes() -> int:
    """Memory this process can still allocate without swapping, in bytes."""
    avail = _meminfo_available()
    if avail is None:
        try:
            import psutil

            avail = int(psutil.virtual_memory().available)
        except ImportError:
            avail = int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    for cap in (_cgroup_limit(), _env_limit()):
        if cap is not None:
            avail = min(avail, cap)
    return avail


def require_memory(nbytes: float, what: str, *, hint: str = "") -> None:
    """Refuse ``what`` if its estimated ``nbytes`` exceed the memory available.

    Parameters
    ----------
    nbytes : float
        Estimated peak bytes (may be ``inf`` for absurd requests).
    what : str
        What is asked, with the values that size it, e.g.
        ``"a 1e+05 s render at 44100 Hz x 8 channels"``.
    hint : str
        What to do instead (appended after a semicolon).

    Raises
    ------
    ResourceError
        ``nbytes`` is not finite or exceeds :func:`available_bytes`.
    """
    avail = available_bytes()
    if not (math.isfinite(nbytes) and nbytes <= avail):
        raise ResourceError(
            f"{what} needs about {format_bytes(nbytes)} of memory but {format_bytes(avail)} is "
            f"available; refusing to start" + (f"; {hint}" if hint else "")
        )


def audio_bytes(seconds: float, rate: float, channels: int) -> float:
    """Peak bytes of rendering ``seconds`` of ``channels``-channel audio at ``rate`` Hz.

    The render holds the float64 signal, its normalised copy and the encoded
    file (float32): about 3 × 8 bytes per sample and channel.
    """
    return float(seconds) * float(rate) * max(int(channels), 1) * 24.0


def require_disk(path: str | os.PathLike[str], nbytes: float, what: str) -> None:
    """Refuse to write ``what`` (about ``nbytes``) to ``path`` if its disk has less free.

    Writers check before they start: a disk that fills up half-way through an
    HDF5 write leaves the HDF5 library in a state that can crash the process
    when the file is closed.

    Raises
    ------
    OutputError
        The free space of the file system holding ``path``'s folder is below
        ``nbytes``.
    """
    folder = Path(path).expanduser().parent
    try:
        free = shutil.disk_usage(folder if str(folder) else ".").free
    except OSError:
        return  # the write itself will report the folder's problem
    if nbytes > free:
        raise OutputError(
            f"cannot write {str(path)!r}: {what} needs about {format_bytes(nbytes)} but only "
            f"{format_bytes(free)} is free on that disk"
        )


# ----------------------------------------------------------------- volumes: steps and data
#: bytes a command holds per time step of a volume whatever its grid: the step's time,
#: its detected sources (arrays and their bookkeeping), its rows in the outputs
STEP_BYTES = 2048
#: each time step costs at least the work of this many values (the fixed cost of a step,
#: which dominates on small grids)
STEP_MIN_VALUES = 4096
#: float64 frame-sized arrays that detection holds at once (fields, derivatives, masks)
FRAME_WORK_ARRAYS = 16
#: the most data one command reads from a volume unless ``AURALIZE_DATA_LIMIT`` says
#: otherwise: steps x points x components as float64 (128 GiB, about an hour of work on
#: one core; more is work for ``auralize scale-detect``/``scale-render``)
DEFAULT_DATA_LIMIT = 128 << 30
#: nominal values per second that one core reads and classifies (the estimate's rate)
NOMINAL_VALUES_PER_S = 5e6
#: a command whose estimate is longer than this many seconds says so before it starts
ESTIMATE_NOTE_S = 60.0


def data_limit() -> int:
    """The most data one command reads from a volume, in bytes: ``AURALIZE_DATA_LIMIT``
    (bytes or ``K``/``M``/``G``/``T``) or :data:`DEFAULT_DATA_LIMIT`."""
    limit = env_size("AURALIZE_DATA_LIMIT")
    return DEFAULT_DATA_LIMIT if limit is None else limit


def volume_data_bytes(n_points: int, n_steps: int, components: int) -> float:
    """The data a command reads from a volume, in bytes of float64: ``n_steps`` x
    ``n_points`` x ``components``, each step counted as at least :data:`STEP_MIN_VALUES`
    values."""
    per_step = max(float(n_points) * max(int(components), 1), float(STEP_MIN_VALUES))
    return float(n_steps) * per_step * 8.0


def format_seconds(seconds: float) -> str:
    """A duration as a short human figure: ``'40 s'``, ``'17 min'``, ``'3.2 h'``, ``'5.1 days'``."""
    if not math.isfinite(seconds):
        return "forever"
    if seconds < 90:
        return f"{seconds:.2g} s"
    if seconds < 5400:
        return f"{seconds / 60:.2g} min"
    if seconds < 172800:
        return f"{seconds / 3600:.2g} h"
    return f"{seconds / 86400:.2g} days"


def work_estimate(data_bytes: float) -> float:
    """Nominal seconds one core takes to read and classify ``data_bytes`` of float64 data
    (at :data:`NOMINAL_VALUES_PER_S`; a machine may be several times faster or slower)."""
    return data_bytes / 8.0 / NOMINAL_VALUES_PER_S


def require_volume(
    dims: Sequence[int],
    n_steps: int,
    components: int,
    what: str,
    *,
    hint: str = "",
    data: bool = True,
) -> float:
    """Refuse work on a volume that is larger than the machine, before it starts.

    Parameters
    ----------
    dims : (nx, ny, nz)
        Grid points per axis, as the file declares them.
    n_steps : int
        Time steps, as the file declares them.
    components : int
        Values per point over the fields read (a vector field counts 3).
    what : str
        The volume, e.g. its file name.
    hint : str
        What to do instead (appended after a semicolon).
    data : bool
        Also apply the data bound (:func:`data_limit`); ``False`` for work spread over
        many machines (Dask), where only one step must fit in this one.

    Returns
    -------
    float
        The data the work reads, in bytes (:func:`volume_data_bytes`).

    Raises
    ------
    ResourceError
        One step's working arrays plus :data:`STEP_BYTES` per step exceed the memory
        available, or the data exceed :func:`data_limit`.
    """
    nx, ny, nz = (int(d) for d in dims)
    n_points = float(nx) * ny * nz
    n_steps = int(n_steps)
    grid = f"{n_steps} step{'s' if n_steps != 1 else ''} of {nx} x {ny} x {nz} points"
    require_memory(
        n_points * 8.0 * max(int(components), FRAME_WORK_ARRAYS) + float(n_steps) * STEP_BYTES,
        f"{what}: {grid}",
        hint=hint,
    )
    nbytes = volume_data_bytes(int(n_points), n_steps, components)
    limit = data_limit()
    if data and nbytes > limit:
        raise ResourceError(
            f"{what}: {grid} is {format_bytes(nbytes)} of data to read (about "
            f"{format_seconds(work_estimate(nbytes))} of work on one core), above the "
            f"{format_bytes(limit)} one command reads (AURALIZE_DATA_LIMIT); refusing to start"
            + (f"; {hint}" if hint else "")
        )
    return nbytes


def estimate_note(data_bytes: float) -> str | None:
    """What to tell the user before work on ``data_bytes`` of data that takes long (its
    size and nominal duration), or ``None`` when it is quick."""
    seconds = work_estimate(data_bytes)
    if seconds < ESTIMATE_NOTE_S:
        return None
    return (
        f"{format_bytes(data_bytes)} of data to read: about {format_seconds(seconds)} of work "
        f"on one core (a rough figure; it depends on the machine)"
    )


# ----------------------------------------------------------------- allocation failures
def memory_error(exc: MemoryError, what: str, *, hint: str = "") -> ResourceError:
    """The :class:`~auralize.errors.ResourceError` for an allocation that failed during
    ``what`` (may be empty): the size asked for (when numpy says it) and the memory
    available.

    The CLI's error line and the API's exception carry this same text.
    """
    if isinstance(exc, ResourceError):
        return exc
    size = getattr(exc, "_total_size", None)  # numpy's _ArrayMemoryError
    asked = f" of {format_bytes(float(size))}" if isinstance(size, int | float) else ""
    try:
        avail = f"; {format_bytes(available_bytes())} is available"
    except ParameterError:
        avail = ""
    return ResourceError(
        (f"{what}: " if what else "")
        + f"not enough memory (an allocation{asked} failed{avail})"
        + (f"; {hint}" if hint else "")
    )


@contextlib.contextmanager
def memory_guard(what: str, *, hint: str = "") -> Iterator[None]:
    """Turn a :class:`MemoryError` raised inside into :func:`memory_error`'s
    :class:`~auralize.errors.ResourceError` (which is still a :class:`MemoryError`).

    Examples
    --------
    >>> import numpy as np
    >>> with memory_guard("detecting sources in big.h5"):
    ...     a = np.zeros(4)
    """
    try:
        yield
    except ResourceError:
        raise
    except MemoryError as exc:
        raise memory_error(exc, what, hint=hint) from exc
