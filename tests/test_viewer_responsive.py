"""The viewer stays responsive while listening live (issue #36): synthesis and sink I/O
run off the window's thread, recording captures on its own clock (the asked rate even
while the window is busy), live time steps are redrawn at a bounded duty, and nothing
redraws behind the caller's back.  Behaviour only; the timings are `auralize bench` rows
(auralize.viewer.measure)."""

from __future__ import annotations

import itertools
import threading
import time

import numpy as np
import pytest

pytest.importorskip("pytestqt")
pytest.importorskip("pyvistaqt")

from auralize.listener import ListenerPath
from auralize.scene.view import camera_pose


def _open(qtbot, win, spec="dataset:monopole", **kw):  # type: ignore[no-untyped-def]
    kw.setdefault("size", 12)
    win.open_data(spec, **kw)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)


def test_listening_and_recording_leave_the_window_thread_free(
    qtbot,
    window,
    tmp_path,
    errors,  # type: ignore[no-untyped-def]
    monkeypatch,
):
    import auralize.scene.listening as listening

    win = window
    _open(qtbot, win)
    gui = threading.get_ident()
    blocks: set[int] = set()
    writes: set[int] = set()
    next_block = listening.LiveEngine.next_block
    write = listening.WavSink.write

    def spy_block(self):  # type: ignore[no-untyped-def]
        blocks.add(threading.get_ident())
        return next_block(self)

    def spy_write(self, block):  # type: ignore[no-untyped-def]
        writes.add(threading.get_ident())
        return write(self, block)

    monkeypatch.setattr(listening.LiveEngine, "next_block", spy_block)
    monkeypatch.setattr(listening.WavSink, "write", spy_write)
    player = win.start_live(tmp_path / "live.wav")
    qtbot.waitUntil(lambda: player.engine.elapsed > 0.3 or player.error is not None, timeout=60_000)
    assert player.error is None, player.error
    win.rate_spin.setValue(10.0)
    win.start_recording(tmp_path / "path.csv")
    rec = win.recorder
    # the window's thread is busy (a long redraw, say): the recorder still captures
    n0 = rec.n_captures
    time.sleep(1.0)
    assert rec.n_captures - n0 >= 3
    assert rec.driver_thread is not None and rec.driver_thread != gui
    # synthesis and the sink's writes never ran on the window's thread
    assert blocks and gui not in blocks
    assert writes and gui not in writes
    # the captures follow the camera; the path drawn catches up with them
    v0 = player.engine._pose_version
    win.fly(forward=2)
    pos = camera_pose(win.plotter.camera)[0]
    assert player.engine._pose_version > v0  # live listening heard the move too
    qtbot.waitUntil(lambda: np.allclose(rec.rows[-1][1:4], pos), timeout=30_000)
    qtbot.waitUntil(
        lambda: win.path is not None and win.path.n_captures >= rec.n_captures - 1, timeout=30_000
    )
    assert "Hz achieved (asked 10)" in win.path_label.text()
    path = win.stop_recording()
    assert not rec.driving
    n = rec.n_captures
    assert path is not None and path.n_captures == n
    # live listening still follows the camera after recording stopped
    v1 = player.engine._pose_version
    win.fly(turn=1)
    assert player.engine._pose_version > v1
    win.stop_live()
    v2 = player.engine._pose_version
    win.fly(turn=1)
    assert player.engine._pose_version == v2  # nothing follows the camera any more
    assert rec.n_captures == n
    assert ListenerPath.from_csv(tmp_path / "path.csv").n_captures == n
    assert not errors


# (stopped before the sound has reached the camera: the file written is silent)
@pytest.mark.filterwarnings("ignore::auralize.audio.output.SilentAudioWarning")
def test_live_time_steps_redraw_at_a_bounded_duty(
    qtbot,
    window,
    tmp_path,
    errors,  # type: ignore[no-untyped-def]
    monkeypatch,
):
    """Live listening moves the time slider at most once per LIVE_REDRAW_GAP_S and leaves
    the window at least LIVE_REDRAW_DUTY times each redraw's time free after it, however
    fast the blocks come (an unpaced sink); a step put off is still shown later, and
    nothing is redrawn after Stop."""
    import auralize.scene.listening as listening
    from auralize.viewer.app import LIVE_REDRAW_DUTY, LIVE_REDRAW_GAP_S

    class Unpaced(listening.WavSink):
        def __init__(self, *a, **k):  # type: ignore[no-untyped-def]
            super().__init__(*a, **{**k, "pace": False})

    monkeypatch.setattr(listening, "WavSink", Unpaced)
    win = window
    _open(qtbot, win, steps=60)
    win.ts_spin.setValue(100.0)  # the 20 ms of data last 2 s: steps change every 33 ms
    spans: list[tuple[float, float]] = []
    orig = win.set_step

    def timed(n):  # type: ignore[no-untyped-def]
        t0 = time.perf_counter()
        try:
            return orig(n)
        finally:
            spans.append((t0, time.perf_counter()))

    win.set_step = timed  # type: ignore[method-assign]
    player = win.start_live(tmp_path / "fast.wav")
    qtbot.waitUntil(lambda: len(spans) >= 4 or player.error is not None, timeout=60_000)
    assert player.error is None, player.error
    win.stop_live()
    n = len(spans)
    for (a0, a1), (b0, _) in itertools.pairwise(spans):
        assert b0 - a1 >= max(LIVE_REDRAW_GAP_S, LIVE_REDRAW_DUTY * (a1 - a0))
    qtbot.wait(2 * int(1000 * LIVE_REDRAW_GAP_S) + 100)
    assert len(spans) == n  # the step put off is not drawn after Stop
    assert not errors


def test_drawing_the_path_does_not_redraw(qtbot, window) -> None:  # type: ignore[no-untyped-def]
    """Scene updates asked not to redraw (a capture drawn, the legend gaining the path)
    leave the redraw to their caller: one redraw per update, not two."""
    win = window
    _open(qtbot, win)
    ends: list[int] = []
    win.plotter.render_window.AddObserver("EndEvent", lambda *_: ends.append(1))
    path = ListenerPath.point(win.volume.center + [1.0, 0, 0], duration=1.0)
    win.scene.set_path(path, render=False)  # adds "listener path" to the legend
    assert "listener path" in win.scene._legend_key
    assert ends == []


def test_the_periodic_redraw_skips_a_view_just_drawn(qtbot, window) -> None:  # type: ignore[no-untyped-def]
    """pyvistaqt's periodic redraw (which shows changes made without one) is skipped when
    the view was drawn within its period anyway, and made when it was not."""
    win = window
    _open(qtbot, win)
    ends: list[int] = []
    win.plotter.render_window.AddObserver("EndEvent", lambda *_: ends.append(1))
    timer = win.plotter.render_timer
    win.plotter.render()
    n = len(ends)
    # (drawn "just now" whatever the machine's speed: an hour ahead of the clock)
    win._drawn_at = time.perf_counter() + 3600
    timer.timeout.emit()
    assert len(ends) == n  # just drawn: skipped
    win._drawn_at = time.perf_counter() - 2 * timer.interval() / 1000
    timer.timeout.emit()
    assert len(ends) == n + 1  # not drawn for a period: drawn
