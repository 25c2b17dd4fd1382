"""The recorder's own capture clock (PathRecorder.drive): captures on a thread of its own,
so a caller busy elsewhere (a window redrawing, listening live) still records."""

from __future__ import annotations

import threading
import time

import numpy as np

from auralize.listener import ListenerPath
from auralize.scene.recorder import PathRecorder


def _pose(x: float = 0.0) -> tuple[list[float], list[float], list[float]]:
    return [x, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]


def test_drive_captures_while_the_caller_is_busy(tmp_path) -> None:
    rec = PathRecorder(rate_hz=20, autosave=tmp_path / "p.csv")
    latest = {"pose": _pose(0.0)}
    rec.drive(lambda: latest["pose"])
    assert rec.n_captures == 1  # the first at once, on the caller's thread
    latest["pose"] = _pose(2.0)
    time.sleep(1.0)  # the caller does not return to any loop: the clock captures anyway
    n = rec.n_captures
    assert n >= 3
    assert rec.driving and rec.driver_thread not in (None, threading.get_ident())
    # the captures follow the latest pose handed over, times increase
    assert np.allclose(rec.rows[-1][1:4], [2.0, 0.0, 0.0])
    t = np.array([r[0] for r in rec.rows])
    assert np.all(np.diff(t) > 0)
    path = rec.stop()
    assert not rec.driving and not rec.recording
    assert path is not None and path.n_captures >= n
    time.sleep(0.2)
    assert rec.n_captures == path.n_captures  # nothing after stop
    back = ListenerPath.from_csv(tmp_path / "p.csv")
    assert back.n_captures == path.n_captures  # the autosave holds every capture


def test_drive_keeps_the_error_that_stopped_it() -> None:
    rec = PathRecorder(rate_hz=50)
    poses = iter([_pose(0.0), _pose(1.0)])

    def pose():  # type: ignore[no-untyped-def]
        p = next(poses, None)
        return p if p is not None else ([np.nan, 0, 0], [0, 1, 0], [0, 0, 1])

    rec.drive(pose)
    for _ in range(500):
        if not rec.driving:
            break
        time.sleep(0.01)
    assert not rec.driving
    assert rec.drive_error is not None and "NaN" in str(rec.drive_error)
    assert rec.n_captures == 2
    rec.stop()
