"""What is heard around a source's onset and end, against the closed forms of
the two time interpolations (paper 001 §3.2.4.3).

The cubic interpolation is Hermite's with central-difference tangents: it is
symmetric in time, so a strength that steps from 0 to Q at knot k is heard
from knot k − 2, as −s²(1 − s)/2 · Q on [t_{k−2}, t_{k−1}] (a dip of −2/27 Q,
7.4 % of the step, at s = 2/3), and one that falls from Q to 0 after knot j is
heard until knot j + 2 (−s(1 − s)²/2 · Q on [t_{j+1}, t_{j+2}]).  Nothing is
heard outside those two knots.  The linear interpolation is heard only between
the knots where the strength is non-zero and their neighbours.
"""

from __future__ import annotations

import numpy as np
import pytest

from auralize.emitters.synthesis import C0, render_tracks
from auralize.listener import ListenerPath
from auralize.sources.detection import SourceTracks

DT, RATE, DIST = 0.01, 48000, 1.7
#: the strength is Q on knots ON..OFF (inclusive), 0 elsewhere
ON, OFF, Q = 20, 40, 2.5


def _heard(interp: str) -> tuple[np.ndarray, np.ndarray]:
    """The pressure at DIST from a source that switches on and off, in units of
    Q/(4π DIST), and the data time each sample was emitted at."""
    t = np.arange(64) * DT
    n = np.arange(t.size)
    q = np.where((n >= ON) & (n <= OFF), Q, 0.0)
    tracks = SourceTracks(positions=np.zeros((1, 3)), q=q[None], radius=np.array([0.05]), times=t)
    path = ListenerPath.point((DIST, 0.0, 0.0), duration=0.62)
    p = render_tracks(tracks, path, rate=RATE, interp=interp).audio[0]
    tau = np.arange(p.size) / RATE - DIST / C0
    return p / (Q / (4 * np.pi * DIST)), tau


def test_cubic_onset_and_end_are_the_hermite_closed_forms() -> None:
    p, tau = _heard("cubic")
    # before knot ON - 2 and after knot OFF + 2: silence (to round-off)
    outside = (tau < (ON - 2) * DT - 1e-9) | (tau > (OFF + 2) * DT + 1e-9)
    assert np.max(np.abs(p[outside])) < 1e-9  # the cumulative sums' round-off, below -180 dB
    before = (tau >= (ON - 2) * DT) & (tau < (ON - 1) * DT)
    s = tau[before] / DT - (ON - 2)
    np.testing.assert_allclose(p[before], -(s**2) * (1 - s) / 2, atol=1e-9)
    assert p[before].min() == pytest.approx(-2 / 27, abs=1e-6)
    after = (tau >= (OFF + 1) * DT) & (tau < (OFF + 2) * DT)
    s = tau[after] / DT - (OFF + 1)
    np.testing.assert_allclose(p[after], -s * (1 - s) ** 2 / 2, atol=1e-9)
    # the plateau between the knots is the strength itself: Q/(4π D)
    flat = (tau > (ON + 1) * DT) & (tau < (OFF - 1) * DT)
    np.testing.assert_allclose(p[flat], 1.0, atol=1e-9)


def test_linear_is_heard_only_between_the_sounding_knots_and_their_neighbours() -> None:
    p, tau = _heard("linear")
    outside = (tau < (ON - 1) * DT - 1e-9) | (tau > (OFF + 1) * DT + 1e-9)
    assert np.max(np.abs(p[outside])) < 1e-9  # the cumulative sums' round-off, below -180 dB
    rise = (tau >= (ON - 1) * DT) & (tau <= ON * DT)
    np.testing.assert_allclose(p[rise], tau[rise] / DT - (ON - 1), atol=1e-9)
    assert p.min() >= -1e-12  # no undershoot
