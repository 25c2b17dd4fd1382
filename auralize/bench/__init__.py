"""``auralize bench``: timings side by side with the papers' tables.

* :mod:`auralize.bench.runner` — the core rows and :func:`run_bench`;
* :mod:`auralize.bench.output`, :mod:`~auralize.bench.readers`,
  :mod:`~auralize.bench.distributed`, :mod:`~auralize.bench.immersive`,
  :mod:`~auralize.bench.viewer`, :mod:`~auralize.bench.compile` — one module per
  group of rows.

A row is a :class:`auralize.plugins.BenchRow` (the plugins' contract type).
"""

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module, imported on first access
_EXPORTS = {
    "PAPER_DETECT_S": ".runner",
    "PAPER_FRAME_US": ".runner",
    "BENCH_THRESHOLDS": ".runner",
    "BenchRow": "auralize.plugins",  # the contract type, re-exported
    "best_of": "auralize.runtime.timing",  # the timers of every bench row, re-exported
    "batch_times": "auralize.runtime.timing",
    "bench_detection": ".runner",
    "bench_synthesis": ".runner",
    "emitters_rows": ".runner",
    "plugin_rows": ".runner",
    "format_rows": ".runner",
    "run_bench": ".runner",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = [
    "BENCH_THRESHOLDS",
    "PAPER_DETECT_S",
    "PAPER_FRAME_US",
    "BenchRow",
    "batch_times",
    "bench_detection",
    "bench_synthesis",
    "best_of",
    "emitters_rows",
    "format_rows",
    "plugin_rows",
    "run_bench",
]
