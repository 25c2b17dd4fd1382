"""propagate(): delay, distance law, Doppler of moving sources, panning."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.emitters.propagation import propagate
from auralize.errors import ParameterError
from auralize.listener import ListenerPath

RATE = 8000


def _tone(f: float, dur: float, rate: int = RATE) -> np.ndarray:
    t = np.arange(int(dur * rate)) / rate
    return np.sin(2 * np.pi * f * t)


def test_delay_and_inverse_distance() -> None:
    sig = _tone(200.0, 0.3)[None]
    sig[0, : int(0.01 * RATE)] = 0  # silence first, to see the onset
    outs = {}
    for D in (10.0, 20.0):
        path = ListenerPath.point((D, 0, 0), duration=0.3)
        outs[D] = propagate(sig, RATE, np.zeros((1, 3)), path, rate=RATE)[0]
        onset = np.argmax(np.abs(outs[D]) > 1e-9) / RATE
        assert onset == pytest.approx(0.01 + D / 343.0, abs=2 / RATE)
    win = slice(int(0.1 * RATE), int(0.25 * RATE))
    assert np.std(outs[10.0][win]) / np.std(outs[20.0][win]) == pytest.approx(2.0, rel=0.01)
    paper = propagate(
        sig,
        RATE,
        np.zeros((1, 3)),
        ListenerPath.point((10, 0, 0), duration=0.3),
        rate=RATE,
        attenuation="paper",
    )[0]
    assert np.std(paper[win]) == pytest.approx(np.std(outs[10.0][win]) / 100, rel=0.01)


def test_moving_source_doppler() -> None:
    v = 30.0
    n = int(1.0 * RATE)
    sig = _tone(400.0, 1.0)[None]
    t = np.arange(n) / RATE
    # source moves towards a listener at +x from x = -40 m
    traj = np.zeros((1, n, 3))
    traj[0, :, 0] = -40.0 + v * t
    out = propagate(sig, RATE, traj, ListenerPath.point((5, 0, 0), duration=1.0), rate=RATE)[0]
    seg = out[int(0.3 * RATE) : int(0.9 * RATE)]
    spec = np.abs(np.fft.rfft(seg * np.hanning(seg.size), 16 * seg.size))
    f = np.fft.rfftfreq(16 * seg.size, 1 / RATE)[np.argmax(spec)]
    assert f == pytest.approx(400.0 / (1 - v / 343.0), rel=0.003)


def test_panning_to_ring8_follows_direction() -> None:
    sig = _tone(300.0, 0.2)[None]
    # listener at origin facing +y; source on the left (-x) -> ring8 channel 2
    out = propagate(
        sig,
        RATE,
        np.array([[-5.0, 0, 0]]),
        ListenerPath.point((0, 0, 0), duration=0.2),
        rate=RATE,
        layout="ring8",
    )
    e = np.sum(out**2, axis=1)
    assert np.argmax(e) == 2 and e[2] / e.sum() > 0.99


def test_bad_positions() -> None:
    with pytest.raises(ParameterError, match=r"positions must be \(S, 3\)"):
        propagate(
            np.zeros((2, 10)), RATE, np.zeros((3, 3)), ListenerPath.point((0, 0, 0), duration=0.1)
        )
    with pytest.raises(ParameterError, match="attenuation must be"):
        propagate(
            np.zeros((1, 10)),
            RATE,
            np.zeros((1, 3)),
            ListenerPath.point((1, 0, 0), duration=0.1),
            attenuation="loud",
        )
