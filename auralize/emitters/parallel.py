"""Pieces of compiled (GIL-free) work shared between this thread and a small pool."""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

#: threads used by the compiled kernels that split their work (this one included)
N_THREADS = max(1, min(2, os.cpu_count() or 1))
_POOL: ThreadPoolExecutor | None = None
_LOCK = threading.Lock()


def run_pieces(fn: Callable[[int], None], n: int, threads: int | None = None) -> None:
    """Call ``fn(i)`` for every ``0 <= i < n`` on up to ``threads`` threads.

    This thread works too; each thread takes the next piece when it is done
    with one, so a thread slowed down by other processes on its core takes
    fewer pieces.  ``fn`` should release the GIL (a ``nogil`` numba kernel).

    Parameters
    ----------
    fn : callable
        ``fn(i)`` does piece ``i`` (its result is not kept; an exception is
        raised here once every thread is done).
    n : int
        Number of pieces.
    threads : int, optional
        Most threads to use (default and at most :data:`N_THREADS`).

    Examples
    --------
    >>> out = [0] * 5
    >>> run_pieces(lambda i: out.__setitem__(i, i * i), 5)
    >>> out
    [0, 1, 4, 9, 16]
    """
    global _POOL
    nt = max(1, min(n, N_THREADS if threads is None else threads, N_THREADS))
    if nt > 1 and _POOL is None:
        with _LOCK:
            if _POOL is None:
                _POOL = ThreadPoolExecutor(
                    max_workers=N_THREADS - 1, thread_name_prefix="auralize-pieces"
                )
    pieces = itertools.count()  # next() is atomic under the GIL

    def work() -> None:
        for i in pieces:
            if i >= n:
                return
            fn(i)

    pool = _POOL
    futures = [pool.submit(work) for _ in range(nt - 1)] if nt > 1 and pool is not None else []
    work()
    for fu in futures:
        fu.result()
