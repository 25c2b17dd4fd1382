"""``immersive_rows``: the AmbiX/binaural benchmark rows are measured figures."""

from __future__ import annotations

import math

from auralize.bench import BenchRow
from auralize.bench.immersive import immersive_rows


def test_immersive_rows_quick() -> None:
    rows = immersive_rows(True)
    assert len(rows) == 5 and all(isinstance(r, BenchRow) for r in rows)
    assert all(math.isfinite(r.value) and r.value > 0 for r in rows)
    by = {r.unit: r for r in rows}
    assert "% of the budget" in by["× real time"].note
    live = [r for r in rows if r.unit == "ms"]
    assert len(live) == 2 and all(r.met is not None for r in live)
    assert "CPU per block" in live[1].note and "binaural-ears" in live[1].note
