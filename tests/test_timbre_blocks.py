"""The timbres' helpers computed in blocks give the samples of their one-pass
definitions exactly: the envelopes' interpolation to the audio rate and the
envelope-weighted mean distance."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.emitters import timbre
from auralize.emitters.synthesis import Rendered
from auralize.listener import ListenerPath
from auralize.sources.detection import SourceTracks
from auralize.spatial.layouts import get_layout


@pytest.mark.parametrize(("n", "k"), [(44100, 175), (1000, 7), (5, 7), (12345, 64), (64, 64)])
def test_upsampled_is_the_linear_interpolation(n: int, k: int) -> None:
    rng = np.random.default_rng(n)
    e = rng.normal(size=(3, n // k + 2))
    coarse = Rendered(audio=e, rate=1000, layout=get_layout("stereo"))
    out = timbre._upsampled(coarse, e, n, k)
    j = np.arange(n)
    i0, frac = j // k, (j % k) / k
    want = e[:, i0] * (1.0 - frac) + e[:, i0 + 1] * frac  # sample j, as defined
    assert out.audio.shape == (3, n) and out.rate == 1000 * k
    assert np.array_equal(out.audio, want)


def test_mean_distance_in_blocks_equals_one_pass(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(2)
    K, steps = 5000, 20
    tracks = SourceTracks(
        positions=rng.uniform(-20, 20, (K, 3)),
        q=rng.normal(size=(K, steps)),
        radius=np.full(K, 0.1),
        times=np.arange(steps) * 0.04,
    )
    path = ListenerPath.orbit((0, 0, 0), radius=60.0, duration=10.0, turns=0.5, rate_hz=3.3)
    u = np.linspace(0.0, 10.0, 1001)
    blocks = timbre.mean_distance(tracks, path, 0.05 + u / 10.0, u)
    assert timbre._MEAN_BLOCK < 1001 * 512  # (the test runs several blocks)
    monkeypatch.setattr(timbre, "_MEAN_BLOCK", 1 << 40)
    one = timbre.mean_distance(tracks, path, 0.05 + u / 10.0, u)
    assert np.all(np.isfinite(one)) and np.all(one > 40.0)
    assert np.array_equal(blocks, one)
