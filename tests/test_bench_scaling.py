"""``scaling_rows`` and ``timbre_cost_rows``: the bench's cliff and default-timbre rows
are measured figures with their targets."""

from __future__ import annotations

import math

import numpy as np

from auralize.bench import BenchRow
from auralize.bench.runner import scaling_rows, scaling_scene, timbre_cost_rows


def test_scaling_scene_sounds_at_about_half_the_steps() -> None:
    tr = scaling_scene(2000, 31)
    assert tr.positions.shape == (2000, 3) and tr.q.shape == (2000, 31)
    assert np.all(np.abs(tr.positions) <= 10.0)
    assert 0.45 < float(np.mean(tr.q != 0)) < 0.55
    assert np.allclose(np.diff(tr.times), 1 / 30)


def test_scaling_and_timbre_rows_quick() -> None:
    rows = scaling_rows(True) + timbre_cost_rows(True)
    assert all(isinstance(r, BenchRow) for r in rows)
    assert all(math.isfinite(r.value) and r.value > 0 for r in rows)
    names = [r.name for r in rows]
    assert "10× sources (1k → 10k), ring8" in names
    ratios = [r for r in rows if r.target]
    # 3× duration (mono, ring8), stereo / ring8 (twice), default timbre / physical (3 layouts
    # and the whole call)
    assert len(ratios) == 8 and all(r.met is not None for r in ratios)
    whole = [r for r in rows if r.name.startswith("auralize.render(")]
    assert len(whole) == 1 and whole[0].group == "timbre"
    auto, phys = (
        float(w.split()[0]) for w in whole[0].note.split("auto ")[1].split("physical ")[:2]
    )
    assert math.isclose(whole[0].value, auto / phys, rel_tol=0.02)
    assert {r.group for r in rows} == {"scaling", "timbre"}
