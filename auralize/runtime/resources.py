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
"""

from __future__ import annotations

import math
import os
import shutil
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


def _env_limit() -> int | None:
    text = os.environ.get("AURALIZE_MEMORY_LIMIT", "").strip().upper().removesuffix("B")
    if not text:
        return None
    unit = text[-1] if text[-1] in _UNITS else ""
    try:
        value = float(text[: len(text) - len(unit)]) * _UNITS[unit]
    except ValueError:
        raise ParameterError(
            f"AURALIZE_MEMORY_LIMIT={os.environ['AURALIZE_MEMORY_LIMIT']!r} is not a size; "
            f"give bytes or a number with K, M, G or T"
        ) from None
    return int(value)


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
