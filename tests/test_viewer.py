"""The desktop viewer driven for real under Xvfb (pytest-qt + pytest-xvfb).

Explosion dataset at 32³ × 8 steps for speed.  Camera moves are scripted
interactor events (VTK mouse drags and Qt key presses).
"""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

pytest.importorskip("pytestqt")
pytest.importorskip("pyvistaqt")

from qtpy import QtCore, QtWidgets

from auralize.errors import FieldError
from auralize.scene.view import camera_pose
from auralize.viewer.app import MainWindow

DATA = {"spec": "dataset:explosion", "size": 32, "steps": 8}


@pytest.fixture
def window_size() -> tuple[int, int]:
    return (900, 700)


def _open(qtbot, win, **kw):
    win.open_data(DATA["spec"], size=DATA["size"], steps=DATA["steps"], **kw)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=30_000)


def _drag(win, dx: int, dy: int, n: int = 2) -> None:
    """Left-button drag through the VTK interactor (rotates the camera)."""
    iren = win.plotter.iren.interactor
    w, h = win.plotter.window_size
    x, y = w // 2, h // 2
    iren.SetEventInformation(x, y, 0, 0)
    iren.InvokeEvent("LeftButtonPressEvent")
    for i in range(1, n + 1):
        iren.SetEventInformation(x + dx * i // n, y + dy * i // n, 0, 0)
        iren.InvokeEvent("MouseMoveEvent")
    iren.InvokeEvent("LeftButtonReleaseEvent")
    win.plotter.render()


def test_record_detect_session_roundtrip(qtbot, window, tmp_path, errors):
    win = window
    _open(qtbot, win)
    assert win.slider.maximum() == DATA["steps"] - 1
    win.detect()
    qtbot.waitUntil(lambda: win.series is not None and not win.busy, timeout=60_000)
    counts = win.detection.counts(win.scene.step)
    assert counts["monopole"] > 0 and counts["dipole"] > 0
    assert win.count_labels["monopole"].text() == str(counts["monopole"])

    # --- record while the camera moves through scripted interactor events
    win.scene.set_representation("contour")  # software GL under Xvfb: keep redraws light
    rate = win.rate_spin.value()
    assert rate == 10.0
    autosave = win.start_recording()
    visited = []
    for k in range(6):
        if k % 2:
            _drag(win, 60, 10)
        else:
            win.plotter.interactor.setFocus()
            for _ in range(3):
                qtbot.keyClick(win.plotter.interactor, QtCore.Qt.Key.Key_Up)
            qtbot.keyClick(win.plotter.interactor, QtCore.Qt.Key.Key_Left)
        pos = camera_pose(win.plotter.camera)[0].copy()
        visited.append(pos)
        qtbot.wait(int(2.5 * 1000 / rate))  # at least two captures at this pose
    # the autosave holds the captures before recording stops
    with open(autosave) as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t", "x", "y", "z", "fx", "fy", "fz", "ux", "uy", "uz"]
    n_saved = len(rows) - 1
    assert n_saved >= 6 and win.recorder.recording
    path = win.stop_recording()
    assert path is not None
    # count: about rate × elapsed (timers may be late, never early)
    assert n_saved <= path.n_captures <= rate * (path.duration + 0.2) + 1
    assert np.all(np.diff(path.times) > 0)
    # the timer never fires early; on a loaded machine a capture may come late
    assert np.median(np.diff(path.times)) >= 0.8 / rate
    # positions follow the camera: every visited pose was captured
    for pos in visited:
        assert np.min(np.linalg.norm(path.positions - pos, axis=1)) < 1e-6
    assert len({tuple(np.round(p, 6)) for p in path.positions}) >= 6
    fwd = path.forward
    assert np.allclose(np.linalg.norm(fwd, axis=1), 1)
    # the autosave file equals the final path
    saved = np.loadtxt(autosave, delimiter=",", skiprows=1)
    assert np.allclose(saved[:, 1:4], path.positions[: saved.shape[0]], atol=1e-6)

    # --- time slider moves the step; the audio cursor follows
    win.slider.setValue(5)
    assert win.scene.step == 5
    # the cursor is where the step's sound from the nearest point is heard: the render's
    # clock skips the travel time from the data's box to the path (plan_render)
    from auralize.emitters.synthesis import C0, box_distances

    assert win.audio["time_scale"] == "auto"
    win.ts_spin.setValue(1.0)
    b = np.asarray(win.volume.bounds).reshape(3, 2)
    lead = float(box_distances(path.positions, b[:, 0], b[:, 1])[0].min()) / C0
    dt = float(win.volume.times[5] - win.volume.times[0])
    assert win.cursor_time() == pytest.approx(max(dt - lead, 0.0), abs=1e-12)
    win.ts_spin.setValue(0.0)  # back to auto (shown as "auto")
    assert win.audio["time_scale"] == "auto" and win.ts_spin.text() == "auto"

    # --- session save/load round trip
    f1 = tmp_path / "s1.json"
    win.th_edits["dipole"].setText("0.5%")
    win.save_session(f1)
    st = json.loads(f1.read_text())
    assert st["data"]["spec"] == "dataset:explosion" and st["data"]["size"] == 32
    assert len(st["path"]["rows"]) == path.n_captures
    cam = win.scene.camera()
    win.fly(forward=5)  # change things, then restore
    win.clear_path()
    win.th_edits["dipole"].setText("1%")
    done = []
    win.load_session(f1, then=lambda: done.append(True))
    qtbot.waitUntil(lambda: bool(done), timeout=60_000)
    assert win.path is not None and np.allclose(win.path.positions, path.positions)
    assert win.th_edits["dipole"].text() == "0.5%"
    assert win.scene.step == 5
    assert np.allclose(win.scene.camera()["position"], cam["position"])
    f2 = tmp_path / "s2.json"
    win.save_session(f2)
    a, b = json.loads(f1.read_text()), json.loads(f2.read_text())
    assert np.allclose(a.pop("path")["rows"], b.pop("path")["rows"], rtol=1e-12, atol=1e-12)
    ca, cb = a.pop("camera"), b.pop("camera")  # (VTK re-orthogonalises the view-up vector)
    assert ca.keys() == cb.keys() and all(np.allclose(ca[k], cb[k], atol=1e-12) for k in ca)
    assert a == b
    assert not errors


def test_bad_input_shows_message_and_stays_usable(qtbot, window, tmp_path, errors):
    win = window
    bad = tmp_path / "broken.h5"
    bad.write_bytes(b"this is not HDF5")
    win.open_data(bad)
    qtbot.waitUntil(lambda: not win.busy and len(errors) == 1, timeout=20_000)
    assert "broken.h5" in errors[0]
    assert win.volume is None and win.open_btn.isEnabled()
    # missing field
    _open(qtbot, win)
    win._guard(win.set_field, "pressure")
    assert "pressure" in errors[-1] and "log10_density" in errors[-1]
    with pytest.raises(FieldError):
        win.set_field("pressure")
    assert win.scene.field == "log10_density"
    # unreadable listener path
    win._guard(win.load_path, tmp_path / "missing.csv")
    assert "missing.csv" in errors[-1]
    # live listening to the detected sources before detecting; every type muted;
    # playback without a render
    win.set_heard("detected")
    win._guard(win.start_live)
    assert "detect" in errors[-1]
    win.set_heard("field")
    for k in ("monopole", "quadrupole"):
        win.hear_checks[k].setChecked(False)
    win._guard(win.start_live)
    assert "muted" in errors[-1]
    win.set_heard("field")
    win._guard(win.play_audio)
    assert "render" in errors[-1]
    n = len(errors)
    # still usable: stepping and recording work
    assert win.set_step(3) < 5
    win.start_recording(tmp_path / "rec.csv")
    qtbot.wait(250)
    assert win.stop_recording().n_captures >= 2
    assert len(errors) == n


def test_detection_can_be_cancelled(qtbot, window, errors):
    win = window
    _open(qtbot, win)
    task = win.detect()
    task.cancel()
    qtbot.waitUntil(lambda: not win.busy, timeout=60_000)
    assert win.series is None  # cancelled: nothing half-done is installed
    assert not errors  # cancelling is not an error
    win.set_step(2)  # the window is usable: the step is shown, without source counts
    assert win.scene.step == 2 and win.slider.value() == 2
    assert all(label.text() == "–" for label in win.count_labels.values())
    assert not errors


def test_a_closed_window_leaves_no_stale_qt_wrappers(qtbot, tmp_path):
    """After the window is closed and Qt has deleted it, PySide holds no wrapper of
    its OpenGL surface or context (a stale one is handed back for the next Qt object
    allocated at that address: a menu action that "is" a ``QSurface``)."""
    from qtpy import QtGui
    from shiboken6 import Shiboken

    def gl_wrappers() -> list[object]:
        kinds = (QtGui.QSurface, QtGui.QOpenGLContext)
        return [w for w in Shiboken.getAllValidWrappers() if isinstance(w, kinds)]

    before = {id(w) for w in gl_wrappers()}
    win = MainWindow(autosave_dir=tmp_path / "autosave")
    win.resize(600, 400)
    win.show()
    qtbot.waitExposed(win)
    win.plotter.render()
    qtbot.waitUntil(lambda: win.plotter._surface is not None)  # the widget's GL is up
    assert [w for w in gl_wrappers() if id(w) not in before]
    win.close()
    win.deleteLater()
    QtWidgets.QApplication.sendPostedEvents(None, QtCore.QEvent.Type.DeferredDelete)
    qtbot.wait(50)
    assert not Shiboken.isValid(win)  # the C++ window is gone, its Python object is not
    assert [w for w in gl_wrappers() if id(w) not in before] == []
