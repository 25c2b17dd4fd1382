"""``immersive_rows``: the AmbiX/binaural benchmark rows are measured figures."""

from __future__ import annotations

import math

from auralize.bench import BenchRow
from auralize.bench.immersive import immersive_rows


def test_immersive_rows_quick() -> None:
    rows = immersive_rows(True)
    assert len(rows) == 4 and all(isinstance(r, BenchRow) for r in rows)
    assert all(math.isfinite(r.value) and r.value > 0 for r in rows)
    by = {r.unit: r for r in rows}
    assert by["ms"].met is not None and "% of the budget" in by["× real time"].note
