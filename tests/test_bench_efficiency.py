"""``auralize bench``'s efficiency rows: each path's rate beside its bound, the
share of the bound computed from the same figures the rows print."""

from __future__ import annotations

import math

import numpy as np

from auralize.bench.efficiency import (
    BYTES_PER_SAMPLE,
    FLOPS_PER_PIECE,
    _pieces,
    data_step_rows,
    signal_rows,
)
from auralize.bench.runner import scaling_scene


def test_pieces_are_intervals_with_a_sounding_knot() -> None:
    q = np.array(
        [
            [0.0, 1.0, 0.0, 0.0, 0.0],  # knot 1 sounds: intervals 0 and 1
            [0.0, 0.0, 0.0, 0.0, 2.0],  # knot 4: interval 3
            [0.0, 0.0, 0.0, 0.0, 0.0],  # silent
            [1.0, 1.0, 1.0, 1.0, 1.0],  # every interval
        ]
    )
    assert _pieces(q) == 2 + 1 + 0 + 4


def test_data_step_share_is_floor_over_cpu_time() -> None:
    flops = 1e10
    rate_row, share_row = data_step_rows(True, flops)
    assert rate_row.group == share_row.group == "efficiency"
    assert rate_row.unit == "G source-samples/CPU-s" and rate_row.value > 0
    # the rate row's CPU time, and the pieces of the same (seeded) scene
    n_src, dur = 30_000, 4.0
    cpu = n_src * dur * 44100 / (rate_row.value * 1e9)
    pieces = _pieces(np.asarray(scaling_scene(n_src, round(3 * dur) + 1).q))
    assert f"{pieces:,} pieces" in rate_row.note
    expected = 100.0 * pieces * FLOPS_PER_PIECE / flops / cpu
    assert math.isclose(share_row.value, expected, rel_tol=1e-9)
    assert share_row.met == (share_row.value >= 15.0)


def test_signal_share_is_rate_over_memory_bound() -> None:
    bandwidth = 16e9
    rate_row, share_row = signal_rows(True, bandwidth)
    assert rate_row.value > 0 and share_row.unit == "%"
    bound = bandwidth / BYTES_PER_SAMPLE / 1e9
    assert math.isclose(share_row.value, 100.0 * rate_row.value / bound, rel_tol=1e-9)
    assert share_row.met == (share_row.value >= 40.0)
