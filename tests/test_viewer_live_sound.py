"""Live listening in the viewer, under Xvfb, plays the rendered file's sound: the
sources through the 20 Hz high-pass, its state carried from block to block.  On data
whose sound lies mostly below 20 Hz the live stream at a still camera equals the file
rendered along a path standing at the camera, and differs from it without the filter."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pytestqt")
pytest.importorskip("pyvistaqt")

from auralize.audio import Limiter, read_wav
from auralize.emitters.timbre import HIGHPASS_HZ, loudness
from auralize.listener import ListenerPath
from auralize.scene.view import camera_pose

DURATION = 0.5  # playback s, within one loop of the data (0.79 s at time scale 40)


@pytest.fixture
def unpaced(monkeypatch):  # type: ignore[no-untyped-def]
    """Live listening's WAV sink writes without waiting for real time."""
    import auralize.scene.listening as listening

    class Unpaced(listening.WavSink):  # a file-backed sink that does not wait
        def __init__(self, *a, **k):  # type: ignore[no-untyped-def]
            super().__init__(*a, **{**k, "pace": False})

    monkeypatch.setattr(listening, "WavSink", Unpaced)
    return listening


def test_live_listening_is_the_rendered_file(
    open_viewer,
    render_in_viewer,
    qtbot,
    tmp_path,  # type: ignore[no-untyped-def]
    unpaced,
) -> None:
    listening = unpaced
    win, shown = open_viewer()
    win.open_data("dataset:monopole", size=12, steps=60)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    win.ts_spin.setValue(40.0)  # the data slowed down: its sound is infrasonic
    assert win.audio["time_scale"] == 40.0
    win.timbre_box.setCurrentText("physical")  # live listening's timbre
    win.detect()
    qtbot.waitUntil(lambda: win.series is not None and not win.busy, timeout=60_000)
    # a listener path standing where the camera will stand, looking at the data
    c = np.asarray(win.volume.center)
    pos = c + [4.0, 1.0, 0.5]
    fwd = (c - pos) / np.linalg.norm(c - pos)
    ListenerPath.point(pos, duration=DURATION, forward=tuple(fwd), up=(0.0, 0.0, 1.0)).to_csv(
        tmp_path / "still.csv"
    )
    p = win.load_path(tmp_path / "still.csv")
    cam = win.plotter.camera
    cam.position, cam.focal_point, cam.up = tuple(pos), tuple(c), (0.0, 0.0, 1.0)
    pose = camera_pose(cam)
    assert np.allclose(pose[0], p.positions[0]) and np.allclose(pose[1], p.forward[0], atol=1e-6)
    file = render_in_viewer(win, shown, tmp_path / "file.wav")
    n = file.shape[1]
    assert n == round(DURATION * 44100) and win.rendered.meta["highpass_hz"] == HIGHPASS_HZ
    player = win.start_live(tmp_path / "live.wav")
    assert player.engine.highpass_hz == HIGHPASS_HZ
    qtbot.waitUntil(lambda: player.engine.elapsed >= DURATION, timeout=60_000)
    win.stop_live()
    assert player.error is None and not shown
    eng = player.engine
    rows = np.asarray(eng.heard_rows)
    assert np.allclose(rows[:, 1:4], pose[0]) and np.allclose(rows[:, 4:7], pose[1])  # still
    live = eng.heard_audio().audio[:, :n]
    assert live.shape == file.shape
    peak = float(np.max(np.abs(file)))
    assert peak > 0 and np.max(np.abs(live - file)) <= 1e-5 * peak
    # the WAV the sink wrote is that stream through the live limiter (automatic gain, the
    # gain control, at most full scale), block by block
    sunk, rate, _ = read_wav(tmp_path / "live.wav")
    lim = Limiter(None, gain_db=win.gain_db, rate=44100)
    expect = np.concatenate([lim.process(b) for b in eng.heard_blocks], axis=1)
    m = sunk.shape[1]  # (the block rendered when Stop came was not written)
    assert rate == 44100 and n <= m <= expect.shape[1] <= m + eng.block
    assert np.max(np.abs(sunk)) <= 1.0 and np.max(np.abs(sunk - expect[:, :m])) <= 1e-5
    # the same camera without the high-pass: another sound, mostly below 20 Hz
    raw = listening.LiveEngine(
        win.series.tracks(),
        layout=win.audio["layout"],
        time_scale=40.0,
        block=eng.block,
        highpass_hz=0.0,
    )
    raw.set_pose(*pose)
    unfiltered = np.concatenate([raw.next_block() for _ in range(-(-n // raw.block))], 1)[:, :n]
    assert loudness(unfiltered, 44100)["share_above"] < 0.5
    assert np.max(np.abs(unfiltered - file)) > 10 * peak  # 28x here


def test_live_listening_a_kilometre_away_is_heard_in_the_first_block(
    open_viewer,
    qtbot,  # type: ignore[no-untyped-def]
    tmp_path,
    unpaced,
) -> None:
    """The camera 1 km from the data: sound takes 2.9 s to come, three times the
    data's span; live listening skips that travel (as a render does), so the first
    block already holds the data's sound, and the panel says how far away they are."""
    listening = unpaced
    win, shown = open_viewer()
    win.open_data("dataset:explosion", size=16, steps=20)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    c = np.asarray(win.volume.center)
    cam = win.plotter.camera
    cam.position, cam.focal_point, cam.up = tuple(c + [1000.0, 0, 0]), tuple(c), (0.0, 0.0, 1.0)
    player = win.start_live(tmp_path / "far.wav")
    try:
        qtbot.waitUntil(lambda: len(player.engine.heard_blocks) >= 1, timeout=60_000)
        text = win.live_label.text()
    finally:
        win.stop_live()
    assert player.error is None and not shown
    first = player.engine.heard_blocks[0]
    assert np.any(first != 0)
    assert player.engine.lead > 2.8  # data seconds of travel skipped
    b = np.asarray(win.volume.bounds).reshape(3, 2)
    near = 1000.0 - (b[0, 1] - c[0])
    assert f"the data are {near:.3g} m away: sound takes {near / 343:.3g} s" in text, text
    # the clock without the lead: the same first block is exact silence
    tracks = win.heard_sound().tracks
    late = listening.LiveEngine(
        tracks,
        layout=win.audio["layout"],
        block=player.engine.block,
        time_scale=player.engine.time_scale,
        lead=0.0,
    )
    late.set_pose(*camera_pose(cam))
    assert not np.any(late.next_block())


def test_listen_live_makes_its_sound_off_the_qt_thread(
    open_viewer,
    qtbot,
    tmp_path,
    unpaced,  # type: ignore[no-untyped-def]
    monkeypatch,
) -> None:
    """The Listen live button returns at once: the sound heard is made in a task (progress
    bar, Cancel) on a worker thread, and listening starts when it is in."""
    import threading

    import auralize.pipeline as pipeline

    made_on: list[str] = []
    real = pipeline.heard_sound

    def spy(*a, **k):  # type: ignore[no-untyped-def]
        made_on.append(threading.current_thread().name)
        return real(*a, **k)

    monkeypatch.setattr(pipeline, "heard_sound", spy)
    win, shown = open_viewer()
    win.open_data("dataset:monopole", size=12, steps=20)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    win.live_file.setText(str(tmp_path / "button.wav"))
    win.live_btn.click()
    assert win.player is None and win.task is not None and win.task.name == "live sound"
    qtbot.waitUntil(
        lambda: win.player is not None and len(win.player.engine.heard_blocks) >= 2, timeout=60_000
    )
    win.stop_live()
    assert made_on and threading.main_thread().name not in made_on
    assert not shown
