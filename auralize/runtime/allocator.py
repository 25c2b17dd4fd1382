"""glibc's allocator tuned for auralize's large, short-lived arrays.

A render allocates tens of megabytes of temporary arrays (per-source kinematics,
per-block tables, output buffers) and frees them when it returns.  glibc serves
blocks above its mmap threshold (128 KiB at start, raised by the blocks freed)
with fresh ``mmap`` pages and gives them back with ``munmap``, and returns free
memory above the heap's trim threshold to the system, so each render touches
its arrays' pages for the first time again: a page fault and a zeroed page per
4 KiB, which two threads faulting at once take in turn.  Untuned, the 4 s aero
bench case (16 dipoles, mono) renders in 37 ms instead of 29 ms on one thread
and in 26-28 ms instead of 17 ms on two.  Setting any threshold in the
environment (a Dask nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_``)
also turns glibc's dynamic mmap threshold off, so then every array above
128 KiB is a fresh ``mmap``.

:func:`tune` sets both thresholds to the ceiling glibc's dynamic adjustment
would reach (``mallopt``): blocks up to :data:`MMAP_THRESHOLD` come from the
heap, and free memory at the heap's top is returned to the system above
:data:`TRIM_THRESHOLD`, so the process keeps at most that much free memory
mapped.  It does nothing

* on a C library other than glibc (``mallopt`` is glibc's),
* when the environment sets the allocator (``MALLOC_MMAP_THRESHOLD_``,
  ``MALLOC_TRIM_THRESHOLD_``, or ``glibc.malloc`` in ``GLIBC_TUNABLES``),
  unless forced (a Dask worker, :mod:`auralize.distributed.worker_setup`),
* when ``AURALIZE_MALLOC_TUNING=0``.

:func:`auralize.runtime.jit.configure` calls it when the first kernel module is
imported, so ``import auralize`` alone changes nothing.
"""

from __future__ import annotations

import ctypes
import os
import platform
import threading

#: blocks up to this size are served from the heap (glibc's upper limit for it)
MMAP_THRESHOLD = 32 << 20
#: free memory at the heap's top kept mapped for the next allocations
TRIM_THRESHOLD = 2 * MMAP_THRESHOLD

_M_TRIM_THRESHOLD = -1  # mallopt parameters (glibc's malloc.h)
_M_MMAP_THRESHOLD = -3
_USER_SETTINGS = ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_")

_state: dict[str, str] = {}
_lock = threading.Lock()


def _reason_not_to(force: bool) -> str | None:
    if os.environ.get("AURALIZE_MALLOC_TUNING", "1").strip().lower() in ("0", "no", "off", "false"):
        return "AURALIZE_MALLOC_TUNING=0"
    if not force and (
        any(k in os.environ for k in _USER_SETTINGS)
        or "glibc.malloc" in os.environ.get("GLIBC_TUNABLES", "")
    ):
        return "the allocator is tuned by the environment"
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return "not glibc"
    return None


def tune(*, force: bool = False) -> str:
    """Set glibc's mmap and trim thresholds once per process; returns what was done.

    Returns ``"tuned"``, or why not (``"not glibc"``, ``"AURALIZE_MALLOC_TUNING=0"``,
    ``"the allocator is tuned by the environment"``, ``"mallopt refused"``).
    ``force`` tunes even when the environment sets the allocator.  Idempotent
    and thread-safe.
    """
    with _lock:
        done = _state.get("result")
        if done == "tuned" or (done is not None and not force):
            return done
        why = _reason_not_to(force)
        if why is None:
            try:
                mallopt = ctypes.CDLL(None).mallopt
                mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
                mallopt.restype = ctypes.c_int
                ok = mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1
                ok = mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD) == 1 and ok
            except (OSError, AttributeError):  # no mallopt in this C library
                ok = False
            why = "tuned" if ok else "mallopt refused"
        _state["result"] = why
        return why


def status() -> str | None:
    """What :func:`tune` did in this process, or None if it has not run."""
    return _state.get("result")
