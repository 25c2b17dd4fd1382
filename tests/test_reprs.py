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
    texts = [
        repr(o) for o in (vol, series, series.frames[3], series.tracks(), rendered, rendered.layout)
    ]
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


def test_the_notebook_player_is_the_wav_the_writer_makes(objects) -> None:  # type: ignore[no-untyped-def]
    """The notebook display (at the bottom of the layers) encodes its player's WAV with the
    standard library: the bytes are :func:`auralize.audio.output.wav_bytes`'s, and a render
    of more than two channels is folded to stereo by its layout as ``downmix`` folds it."""
    import base64

    import numpy as np

    from auralize.audio.output import downmix, wav_bytes
    from auralize.runtime.notebook import MAX_PLAYER_S, rendered_html, wav_data_uri

    rendered = objects[2]
    a = np.asarray(rendered.audio)[:, : int(MAX_PLAYER_S * rendered.rate)]
    stereo = downmix(a, rendered.layout, "stereo")
    assert np.array_equal(rendered.layout.downmix(a, "stereo"), stereo)
    peak = float(np.max(np.abs(stereo)))
    want = wav_bytes(stereo * (0.99 / peak), rendered.rate, subtype="pcm16")
    uri = wav_data_uri(stereo, rendered.rate)
    assert base64.b64decode(uri.split(",", 1)[1]) == want
    assert f"src='{uri}'" in rendered_html(rendered)
    mono = np.linspace(-0.5, 0.25, 101)[None]
    got = base64.b64decode(wav_data_uri(mono, 8000).split(",", 1)[1])
    assert got == wav_bytes(mono * (0.99 / 0.5), 8000, subtype="pcm16")
