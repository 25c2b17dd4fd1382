"""Dataset regression: the explosion dataset's per-step source counts and a rendered
clip's RMS and spectral centroid stay within tolerance of auralize/data/regression/."""

from __future__ import annotations

import json

import numpy as np

from auralize.regression.synthetic import STORE, compare, compute, spectral_centroid


def test_explosion_matches_stored_figures() -> None:
    got = compute("explosion")
    stored = json.loads((STORE / "explosion.json").read_text())
    assert len(got["counts"]) == 30
    # the burst starts at the centre: the first steps hold mostly monopoles
    early = got["counts"][:5]
    assert sum(c["monopole"] for c in early) > sum(c["dipole"] for c in early)
    assert compare("explosion", got) == [], compare("explosion", got)
    assert got["thresholds"] == stored["thresholds"] or np.allclose(
        got["thresholds"], stored["thresholds"], rtol=1e-6
    )


def test_spectral_centroid_of_a_tone() -> None:
    rate = 8000
    t = np.arange(rate) / rate
    assert abs(spectral_centroid(np.sin(2 * np.pi * 440 * t), rate) - 440) < 2
