"""Text reprs are short summaries (as xarray's): a few lines that say what an object
holds — grid, times, fields, counts, layout, rate, level — never its arrays."""

from __future__ import annotations

import pytest

import auralize.pipeline as ap


@pytest.fixture(scope="module")
def objects():  # type: ignore[no-untyped-def]
    vol = ap.load("dataset:explosion", size=16, steps=10)
    series = ap.detect_sources(vol)
    rendered, _ = ap.auralize(vol, duration=0.1, layout="ring8")
    return vol, series, rendered


def test_reprs_are_short_summaries(objects) -> None:  # type: ignore[no-untyped-def]
    vol, series, rendered = objects
    texts = [repr(o) for o in (vol, series, series.frames[3], series.tracks(), rendered,
                               rendered.layout)]  # fmt: skip
    for t in texts:
        assert len(t) < 600 and len(t.splitlines()) <= 6, t
        assert "array(" not in t and "<function" not in t and "lambda" not in t, t
    v, s, f, tr, r, lay = texts
    assert v.splitlines()[0] == "<TimeVolume dataset:explosion>"
    assert "16 × 16 × 16 points, spacing 1, 1, 1 m" in v and "10 steps, 0 – 0.3 s" in v
    assert "log10_density (scalar), velocity (vector)" in v
    counts = {k: sum(c[k] for c in series.counts()) for k in ("monopole", "dipole")}
    assert f"monopole {counts['monopole']:,}, dipole {counts['dipole']:,}" in s
    assert "mapping     paper-density" in s
    assert f.startswith(f"<SourceFrame: {series.frames[3].index.size:,} sources (monopole")
    assert tr.startswith(f"<SourceTracks: {series.tracks().n_sources:,} sources × 10 knots")
    assert r.startswith("<Rendered: 0.1 s, ring8 (8 ch) at 44100 Hz, peak ")
    assert lay.startswith("<Layout ring8: 8 channels (S0, S1")
