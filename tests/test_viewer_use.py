"""The viewer as people use it, under Xvfb: open and look first, fly with the keys,
record (autosave always complete), listen live with safe levels, overlays, sessions."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pytestqt")
pytest.importorskip("pyvistaqt")

from qtpy import QtCore, QtWidgets

from auralize.errors import DataError
from auralize.listener import ListenerPath
from auralize.scene.recorder import PathRecorder
from auralize.scene.view import camera_pose

ROOT = Path(__file__).parents[1]
WAVY = ROOT / "auralize" / "data" / "paraview-wavy" / "wavy00.vts"


def _open(qtbot, win, spec="dataset:monopole", **kw):
    kw.setdefault("size", 12 if spec == "dataset:monopole" else None)
    win.open_data(spec, **kw)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)


def _detect(qtbot, win):
    win.detect()
    qtbot.waitUntil(lambda: win.series is not None and not win.busy, timeout=60_000)


def _blocks(player) -> int:
    """Blocks the live engine has rendered so far."""
    return round(player.engine.elapsed / player.engine.block_s)


def _saturated(img: np.ndarray) -> int:
    rgb = img[..., :3].astype(int)
    return int(np.sum(rgb.max(axis=-1) - rgb.min(axis=-1) > 80))


def test_single_step_real_file_is_shown_and_detection_explains(qtbot, window, errors):
    win = window
    _open(qtbot, win, str(WAVY))
    assert win.volume.n_steps == 1 and win.scene.field == "z"
    assert "volume" in win.scene._actors and "outline" in win.scene._actors
    assert win.scene.sources is None  # nothing detected on opening
    # the reader's note (a surface read on its own lattice) is shown, not lost
    assert "note: a surface (StructuredGrid" in win.info.text()
    img = win.plotter.screenshot()
    assert img[..., :3].std() > 5  # not a blank view
    assert not win.detect_btn.isEnabled()
    assert "two" in win.detect_note.text()
    with pytest.raises(DataError, match="at least 2 time steps"):
        win.detect()
    assert not errors


def test_keys_fly_after_clicking_record_and_readouts(qtbot, window, errors, tmp_path):
    win = window
    _open(qtbot, win)
    qtbot.mouseClick(win.rec_btn, QtCore.Qt.MouseButton.LeftButton)
    assert win.recorder.recording
    target = QtWidgets.QApplication.focusWidget() or win.rec_btn
    moves = {}
    for key in (
        QtCore.Qt.Key.Key_Up,
        QtCore.Qt.Key.Key_PageUp,
        QtCore.Qt.Key.Key_W,
        QtCore.Qt.Key.Key_PageDown,
        QtCore.Qt.Key.Key_D,
    ):
        before = camera_pose(win.plotter.camera)
        qtbot.keyClick(target, key)
        after = camera_pose(win.plotter.camera)
        moves[key] = (before, after)
        assert not np.allclose(before[0], after[0]) or not np.allclose(before[1], after[1]), key
    b, a = moves[QtCore.Qt.Key.Key_PageUp]
    assert (a[0] - b[0]) @ b[2] > 0  # PageUp rises along the view's up
    b, a = moves[QtCore.Qt.Key.Key_Up]
    assert (a[0] - b[0]) @ b[1] > 0  # Up moves forward
    # while a number box is being edited, the arrows are the box's
    win.rate_spin.setFocus()
    qtbot.keyClick(win.rate_spin, QtCore.Qt.Key.Key_Up)
    assert win.rate_spin.value() == 11.0
    # also with the keys sent straight to the 3-D view
    before = camera_pose(win.plotter.camera)[0]
    qtbot.keyClick(win.plotter.interactor, QtCore.Qt.Key.Key_Down)
    assert not np.allclose(before, camera_pose(win.plotter.camera)[0])
    qtbot.wait(450)
    win._update_readouts()
    assert win.camera_label.text().startswith("camera (")
    text = win.path_label.text()
    assert "Hz achieved" in text and str(win.recorder.autosave) in text
    assert "PgUp" in win.key_map.text()
    win.stop_recording()
    assert not errors


def test_autosave_is_complete_after_loading_a_path(qtbot, window, tmp_path, errors):
    win = window
    _open(qtbot, win)
    loaded = ListenerPath.orbit(win.volume.center, radius=2.0, duration=1.0, rate_hz=5)
    csv = tmp_path / "loaded.csv"
    loaded.to_csv(csv)
    win.load_path(csv)
    autosave = win.start_recording(tmp_path / "auto.csv")
    qtbot.waitUntil(lambda: win.recorder.n_captures >= loaded.n_captures + 2, timeout=5000)
    # read back while recording (as after a crash): header, the loaded captures, the new ones
    back = ListenerPath.from_csv(autosave)
    assert back.n_captures >= loaded.n_captures + 2
    assert np.allclose(back.positions[: loaded.n_captures], loaded.positions)
    assert np.all(np.diff(back.times) > 0)
    win.stop_recording()
    # the same after loading a session
    sess = tmp_path / "s.json"
    win.save_session(sess)
    n_before = win.path.n_captures
    done: list[bool] = []
    win.load_session(sess, then=lambda: done.append(True))
    qtbot.waitUntil(lambda: bool(done), timeout=30_000)
    autosave2 = win.start_recording(tmp_path / "auto2.csv")
    qtbot.waitUntil(lambda: win.recorder.n_captures >= n_before + 1, timeout=5000)
    back2 = ListenerPath.from_csv(autosave2)
    assert back2.n_captures >= n_before + 1
    win.stop_recording()
    assert not errors


def test_recorder_autosave_starts_with_held_captures(tmp_path) -> None:
    rec = PathRecorder(rate_hz=10, autosave=tmp_path / "a.csv")
    rec.load(ListenerPath.point([1.0, 2.0, 3.0], duration=0.5))
    rec.start()
    rec.capture([4.0, 5.0, 6.0], [0, 1, 0], [0, 0, 1], t=1.0)
    back = ListenerPath.from_csv(tmp_path / "a.csv")
    rec.stop()
    assert back.n_captures == 3 and np.allclose(back.positions[-1], [4, 5, 6])


def test_live_listening_levels_and_quick_stop(qtbot, window, tmp_path, errors):
    from auralize.audio import read_wav

    win = window
    _open(qtbot, win)
    _detect(qtbot, win)
    win.set_gain_db(30.0)  # far too loud on purpose: the limiter must hold full scale
    out = tmp_path / "live.wav"
    steps: list[int] = []
    orig = win.set_step
    win.set_step = lambda n: (steps.append(n), orig(n))[1]  # type: ignore[method-assign]
    player = win.start_live(out)
    qtbot.waitUntil(lambda: player.engine.elapsed > 0.5 or player.error is not None, timeout=30_000)
    assert player.error is None, player.error
    qtbot.waitUntil(lambda: player.limiter.peak_dbfs > -20, timeout=30_000)
    win._update_readouts()
    assert win.meter.format().startswith("peak") and "limiting" in win.meter.format()
    n_stop = _blocks(player)
    win.stop_live()
    n_stopped = _blocks(player)
    assert not player.running and n_stopped - n_stop <= 2  # the block(s) in progress
    n = len(steps)
    qtbot.wait(400)
    assert len(steps) == n  # no redraws after Stop
    assert _blocks(player) == n_stopped  # and no more blocks
    audio, _, _ = read_wav(out)
    assert audio.shape[0] == 2 and np.max(np.abs(audio)) <= 0.99 + 1e-6
    assert np.max(np.abs(audio)) > 0.5
    assert not errors


def test_overlay_steps_compute_off_the_ui_thread(qtbot, window, errors, monkeypatch):
    """A slow overlay: moving through the steps never blocks the UI thread, results for
    steps already left are dropped, the overlay shown ends at the current step, and
    Cancel stops a step being computed."""
    import threading

    from auralize.plugins import get_model

    cls = type(get_model("aero"))
    orig = cls.overlay
    ui = threading.get_ident()
    computed: list[tuple[int, bool]] = []  # (step, on the UI thread)
    finished: list[int] = []
    delay = [0.0]
    gate = threading.Event()  # a step's overlay computes only while the gate is open
    gate.set()

    def slow(self, inputs, step):
        computed.append((step, threading.get_ident() == ui))
        assert gate.wait(60), "the gate stayed closed"
        time.sleep(delay[0])
        meshes = orig(self, inputs, step)
        out = []
        for m in meshes if isinstance(meshes, list | tuple) else [meshes]:
            m = m.copy()
            m.field_data["step"] = np.array([step])
            out.append(m)
        finished.append(step)
        return out

    monkeypatch.setattr(cls, "overlay", slow)
    win = window
    _open(qtbot, win, "dataset:monopole", size=12, steps=6)
    result: list[bool] = []
    win.set_overlay("aero", True, then=result.append)
    qtbot.waitUntil(lambda: bool(result) and not win.busy, timeout=60_000)
    assert result == [True] and win.scene.overlay_shown["aero"] == 0

    def shown_step() -> int:
        return int(win.scene._actors["overlay:aero:0"].mapper.dataset.field_data["step"][0])

    assert shown_step() == 0 and finished == [0]
    gate.clear()  # step 1's overlay now computes until the gate opens
    ticks: list[int] = []
    timer = QtCore.QTimer()
    timer.timeout.connect(lambda: ticks.append(1))
    timer.start(10)
    for step in (1, 2, 3, 4):
        win.set_step(step)  # returns while step 1's overlay is still being computed
        assert finished == [0]
        n = len(ticks)
        # the UI thread keeps processing its events (timer ticks) meanwhile
        qtbot.waitUntil(lambda n=n: len(ticks) >= n + 3, timeout=30_000)
        assert win.progress.isVisible() and win.cancel_btn.isVisible()
    assert [s for s, _ in computed[1:]] == [1]  # one task at a time: the others wait
    gate.set()
    qtbot.waitUntil(lambda: not win._overlay_tasks, timeout=30_000)
    timer.stop()
    assert win.scene.step == 4 and win.scene.overlay_shown["aero"] == 4 and shown_step() == 4
    assert [s for s, _ in computed[1:]] == [1, 4]  # steps 2 and 3 were left before their turn
    assert not any(on_ui for _, on_ui in computed[1:])
    assert not win.progress.isVisible() and not win.cancel_btn.isVisible()

    # Cancel stops the step being computed; the overlay keeps showing step 4
    gate.clear()
    win.set_step(5)
    assert win._overlay_tasks
    qtbot.mouseClick(win.cancel_btn, QtCore.Qt.MouseButton.LeftButton)
    gate.set()
    qtbot.waitUntil(lambda: not win._overlay_tasks, timeout=30_000)
    qtbot.wait(50)
    assert win.scene.overlay_shown["aero"] == 4 and shown_step() == 4
    assert "cancelled" in win.statusBar().currentMessage()

    # closing while a step computes waits for it and draws nothing afterwards
    delay[0] = 0.3
    win.set_step(2)
    assert win._overlay_tasks
    win.close()
    assert not win._threads or all(t.isFinished() for t in win._threads)
    assert not errors


@pytest.mark.parametrize("spec", ["dataset:explosion", "dataset:monopole", "dataset:fire"])
def test_each_plugin_overlay_on_each_builtin_dataset(qtbot, window, errors, spec):
    win = window
    _open(qtbot, win, spec, size=16, steps=4)
    drawn = {}
    for name in win.overlay_checks:
        result: list[bool] = []
        win.set_overlay(name, True, then=result.append)  # computed in the background
        qtbot.waitUntil(lambda r=result: bool(r) and not win.busy, timeout=60_000)
        drawn[name] = result[0]
        if drawn[name]:
            assert any(k.startswith(f"overlay:{name}") for k in win.scene._actors)
            win.set_step(1)  # the overlay follows the time step (computed in the background)
            qtbot.waitUntil(lambda n=name: not win._overlay_tasks, timeout=60_000)
            assert name not in win.scene.overlay_errors
            assert win.scene.overlay_shown[name] == 1
        else:  # does not apply: one clear line, the box unticked
            assert win.overlay_note.text().startswith(f"{name} overlay does not apply")
            assert not win.overlay_checks[name].isChecked()
        win.set_overlay(name, False)
    assert drawn["aero"] and drawn["spark"]
    if spec == "dataset:fire":
        assert drawn["fire"]
    assert not errors


@pytest.mark.parametrize("heard", ["field", "detected"])
def test_render_to_file_is_auralize_render_and_records_how(qtbot, window, tmp_path, errors, heard):
    """One plan: the viewer's Render to file, with its default settings, writes the
    samples of ``auralize render DATA --path P --layout stereo`` (the command's own
    defaults: auto time scale and thresholds, auto timbre, 20 Hz high-pass), and its
    sidecar holds a command (``render --scene`` of the session saved beside it) that
    writes them again."""
    import json
    import shlex

    from auralize.audio import read_wav
    from auralize.cli import main
    from auralize.defaults import DEFAULTS

    win = window
    _open(qtbot, win, steps=40)
    win.set_heard(heard)
    if heard == "detected":
        _detect(qtbot, win)
    assert win.audio["time_scale"] == DEFAULTS.time_scale == "auto"
    assert win.audio["timbre"] == DEFAULTS.timbre
    assert tuple(win.read_thresholds().describe().values())[:3] == DEFAULTS.thresholds
    csv = tmp_path / "p.csv"
    ListenerPath.line(
        win.volume.center + [3.0, -2, 0], win.volume.center + [3.0, 2, 0], duration=0.6
    ).to_csv(csv)
    win.load_path(csv)
    out = tmp_path / "r.wav"
    win.render_audio(out)
    qtbot.waitUntil(lambda: win.rendered is not None and not win.busy, timeout=120_000)
    assert not errors
    viewer, rate, _ = read_wav(out)
    assert rate == 44100 and viewer.shape == (2, round(0.6 * 44100))
    assert np.max(np.abs(viewer)) > 0.5  # peak-normalised, as the command writes

    cli = tmp_path / "cli.wav"
    args = [
        "render",
        "dataset:monopole",
        "--size",
        "12",
        "--steps",
        "40",
        "--path",
        str(csv),
        "--layout",
        "stereo",
        "--heard",
        heard,
        "-o",
        str(cli),
    ]
    assert main(args) == 0
    assert np.array_equal(read_wav(cli)[0], viewer)

    side = json.loads(Path(f"{out}.json").read_text())
    session = Path(side["session"])
    assert session == tmp_path / "r.wav.session.json" and session.is_file()
    cmd = shlex.split(side["command"])
    assert cmd[:4] == ["auralize", "render", "--scene", str(session)]
    again = tmp_path / "again.wav"
    assert main([*cmd[1:-1], str(again)]) == 0
    assert np.array_equal(read_wav(again)[0], viewer)
    assert json.loads(session.read_text())["audio"]["heard"] == heard


def test_file_menu_open_builtin_save_and_restore_session(
    qtbot, window, tmp_path, errors, monkeypatch
):
    win = window
    titles = [a.text() for a in win.file_menu.actions() if a.text()]
    assert titles[:1] == ["&Open…"] and "&Save session" in titles and "&Quit" in titles
    assert "Save session &as…" in titles
    builtin = win.builtin_menu
    names = [a.text() for a in builtin.actions()]
    assert {"explosion", "monopole", "fire"} <= set(names)
    next(a for a in builtin.actions() if a.text() == "monopole").trigger()
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    assert win.data["spec"] == "dataset:monopole"
    _detect(qtbot, win)
    n_src = win.detection.counts(win.scene.step)["monopole"]
    f = tmp_path / "s.json"
    monkeypatch.setattr(
        QtWidgets.QFileDialog, "getSaveFileName", lambda *a, **k: (str(f), "Sessions (*.json)")
    )
    next(a for a in win.file_menu.actions() if a.text() == "Save session &as…").trigger()
    assert f.exists() and win.session_file == f
    f.unlink()
    next(a for a in win.file_menu.actions() if a.text() == "&Save session").trigger()
    assert f.exists()  # saved again to the same file, without asking
    win.set_mapping("identity")  # forget the sources
    assert win.series is None
    done: list[bool] = []
    win.load_session(f, then=lambda: done.append(True))
    qtbot.waitUntil(lambda: bool(done) and not win.busy, timeout=60_000)
    assert win.series is not None  # the session restores the detected sources
    assert win.detection.counts(win.scene.step)["monopole"] == n_src
    assert not errors


def test_detect_on_a_real_time_series_with_field_options(qtbot, window, tmp_path, errors):
    import zipfile

    with zipfile.ZipFile(ROOT / "auralize" / "data" / "openfoam-cavity" / "OpenFOAM.zip") as z:
        z.extractall(tmp_path)
    win = window
    win.mapping, win.mapping_fields = "identity", {"density": "p", "velocity": "U"}
    _open(qtbot, win, str(tmp_path / "OpenFOAM" / "cavity" / "case.foam"), size=None)
    assert win.volume.n_steps == 6 and win.scene.sources is None
    assert win.detect_btn.isEnabled()
    _detect(qtbot, win)
    assert win.series.n_steps == 6
    assert sum(win.detection.counts(0).values()) > 0
    assert win.session_state().detection["mapping_fields"] == {"density": "p", "velocity": "U"}
    assert not errors


def test_record_from_the_default_camera(qtbot, window, tmp_path, errors):
    win = window
    _open(qtbot, win)
    autosave = win.start_recording(tmp_path / "cam.csv")
    qtbot.wait(350)
    path = win.stop_recording()
    assert path is not None and path.n_captures >= 3
    # the default camera looks at the data from outside its box, as in ParaView
    assert not np.any(win.volume.contains(path.positions))
    assert ListenerPath.from_csv(autosave).n_captures == path.n_captures
    assert not errors


def test_unpaced_device_cannot_flood_the_window(qtbot, window, tmp_path, errors, monkeypatch):
    """A device that asks for blocks as fast as they come (ALSA null/file plugins): the
    redraw ticks are coalesced (not one per block), nothing is drawn or rendered after
    Stop, and the heard audio kept is bounded."""
    import auralize.scene.listening as listening

    class Unpaced(listening.WavSink):
        def __init__(self, *a, **k):
            super().__init__(*a, **{**k, "pace": False})

    monkeypatch.setattr(listening, "WavSink", Unpaced)
    win = window
    _open(qtbot, win)
    _detect(qtbot, win)
    handled: list[float] = []
    orig = win._on_live_tick
    win._on_live_tick = lambda t: (handled.append(t), orig(t))[1]  # type: ignore[method-assign]
    win.live_tick.disconnect()
    win.live_tick.connect(win._on_live_tick)
    player = win.start_live(tmp_path / "fast.wav")
    player.engine.keep_heard_s = 1.0
    qtbot.waitUntil(lambda: player.engine.elapsed > 3.0, timeout=30_000)
    n_stop = _blocks(player)
    win.stop_live()
    assert not player.running and _blocks(player) - n_stop <= 2  # the block(s) in progress
    blocks = _blocks(player)
    n = len(handled)
    assert n < blocks  # not one redraw per block
    qtbot.wait(300)
    assert len(handled) <= n + 1  # at most the tick already queued, then nothing
    assert _blocks(player) == blocks
    heard = sum(b.shape[1] for b in player.engine.heard_blocks) / player.engine.rate
    assert heard <= 1.0 + player.engine.block_s
    assert not errors
