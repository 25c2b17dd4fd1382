"""Wall-time helpers of ``auralize bench`` and the plugins' ``bench`` rows.

Benchmarks only: no test may depend on wall-clock speed.

Examples
--------
>>> t = best_of(lambda: sum(range(100)), repeat=3, min_time=0.003)
>>> t > 0
True
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["batch_times", "best_of"]


def best_of(fn: Callable[[], object], *, repeat: int = 5, min_time: float = 0.2) -> float:
    """Median wall time of ``fn`` over ``repeat`` batches (after one warm-up)."""
    return float(np.median(batch_times(fn, repeat=repeat, min_time=min_time)))


def batch_times(
    fn: Callable[[], object], *, repeat: int = 5, min_time: float = 0.2
) -> NDArray[np.float64]:
    """Mean wall time of ``fn`` in each of ``repeat`` batches of about
    ``min_time / repeat`` seconds (after one warm-up)."""
    fn()
    times = []
    for _ in range(repeat):
        n, t0 = 0, time.perf_counter()
        while True:
            fn()
            n += 1
            el = time.perf_counter() - t0
            if el >= min_time / repeat or n >= 50:
                break
        times.append(el / n)
    return np.array(times)
