"""The viewer's camera, time controls, menus, screenshots and tooltips (issue "The viewer,
round 3", items 4 and 8), driven for real under Xvfb (pytest-qt + pytest-xvfb)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pytestqt")
pytest.importorskip("pyvistaqt")

from PIL import Image
from qtpy import QtCore, QtWidgets

import auralize
from auralize.listener import ListenerPath
from auralize.scene.view import BACKGROUND
from auralize.viewer.app import KEYS, STANDARD_VIEWS, key_text

Key = QtCore.Qt.Key
SHIFT = QtCore.Qt.KeyboardModifier.ShiftModifier
AXES = {
    "+X": (1, 0, 0),
    "-X": (-1, 0, 0),
    "+Y": (0, 1, 0),
    "-Y": (0, -1, 0),
    "+Z": (0, 0, 1),
    "-Z": (0, 0, -1),
}


@pytest.fixture
def window_size() -> tuple[int, int]:
    return (1000, 700)


def _open(qtbot, win, spec="dataset:explosion", size=16, steps=6, **kw):
    before = win.volume
    win.open_data(spec, size=size, steps=steps, **kw)
    qtbot.waitUntil(lambda: win.volume is not before and not win.busy, timeout=60_000)


def _corners(vol):
    b = np.asarray(vol.bounds, dtype=float).reshape(3, 2)
    return np.array([[b[0, i], b[1, j], b[2, k]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])


def _shows_the_data(win) -> bool:
    """The focal point is the data's centre and its bounding box is inside the frustum."""
    cam = win.plotter.camera
    if not np.allclose(cam.focal_point, win.volume.center, atol=1e-9):
        return False
    ren = win.plotter.renderer
    for p in _corners(win.volume):
        ren.SetWorldPoint(*p, 1.0)
        ren.WorldToView()
        x, y, _ = ren.GetViewPoint()
        if abs(x) > 1 or abs(y) > 1:
            return False
    # and it is not a dot: the box spans a good part of the view
    xs = []
    for p in _corners(win.volume):
        ren.SetWorldPoint(*p, 1.0)
        ren.WorldToView()
        xs.append(ren.GetViewPoint()[:2])
    span = np.ptp(np.asarray(xs), axis=0)
    return bool(span.max() > 0.8)


def _far_path(vol) -> ListenerPath:
    """A path recorded for other data, far from ``vol``."""
    return ListenerPath.orbit(np.asarray(vol.center) + 500.0, radius=20.0, duration=1.0, rate_hz=5)


def _set_path(win, path):
    win.recorder.load(path)
    win.path = path
    win.scene.set_path(path)


def test_new_data_is_framed_and_the_path_question_does_what_it_says(
    qtbot, window, errors, monkeypatch
):
    win = window
    _open(qtbot, win)
    assert _shows_the_data(win)
    old = _far_path(win.volume)
    _set_path(win, old)
    # keep: the path stays, drawn, and the camera frames the new data (not the path)
    _open(qtbot, win, "dataset:monopole", size=12, steps=10, keep_path=True)
    assert win.path is old and win.scene.path is old and "path" in win.scene._actors
    assert _shows_the_data(win)
    # the question, answered by a setting (as tests and scripts do): discard
    win.keep_path_answer = False
    _open(qtbot, win, keep_path=None)
    assert win.path is None and win.scene.path is None and "path" not in win.scene._actors
    assert win.recorder.n_captures == 0 and win.path_label.text() == "no path"
    assert _shows_the_data(win)
    # the real question: Discard is its default, Keep keeps
    win.keep_path_answer = None
    asked: list[str] = []

    def answer(button):
        def exec_(box):
            asked.append(box.text())
            b = box.defaultButton() if button is None else box.button(button)
            b.click()
            return 0

        return exec_

    _set_path(win, old)
    monkeypatch.setattr(QtWidgets.QMessageBox, "exec", answer(None))
    _open(qtbot, win, "dataset:monopole", size=12, steps=10)
    assert asked and "listener path" in asked[-1]
    assert win.path is None
    _set_path(win, old)
    monkeypatch.setattr(
        QtWidgets.QMessageBox, "exec", answer(QtWidgets.QMessageBox.StandardButton.Yes)
    )
    _open(qtbot, win)
    assert len(asked) == 2 and win.path is old
    # no path, no question
    win.clear_path()
    _open(qtbot, win, "dataset:monopole", size=12, steps=10)
    assert len(asked) == 2
    assert not errors


def test_reset_camera_button_and_key_frame_the_data(qtbot, window, errors):
    win = window
    _open(qtbot, win)
    _set_path(win, _far_path(win.volume))
    for _ in range(10):
        win.fly(forward=5, turn=1)
    assert not _shows_the_data(win)
    before = np.asarray(win.plotter.camera.GetDirectionOfProjection())
    win.reset_camera_action.trigger()
    assert _shows_the_data(win)
    # ParaView's Reset Camera keeps the view direction
    assert np.allclose(win.plotter.camera.GetDirectionOfProjection(), before, atol=1e-6)
    win.fly(forward=30)
    assert not _shows_the_data(win)
    win.plotter.interactor.setFocus()
    qtbot.keyClick(win.plotter.interactor, Key.Key_C)
    assert _shows_the_data(win)
    assert not errors


@pytest.mark.parametrize("how", ["button", "key"])
def test_standard_views_look_along_the_axes(qtbot, window, errors, how):
    win = window
    _open(qtbot, win)
    keys = {
        "+X": (Key.Key_X, None),
        "-X": (Key.Key_X, SHIFT),
        "+Y": (Key.Key_Y, None),
        "-Y": (Key.Key_Y, SHIFT),
        "+Z": (Key.Key_Z, None),
        "-Z": (Key.Key_Z, SHIFT),
    }
    assert set(STANDARD_VIEWS) == set(AXES) == set(win.view_actions)
    for name, axis in AXES.items():
        win.fly(forward=3, turn=2)  # from somewhere else
        if how == "button":
            win.view_actions[name].trigger()
        else:
            win.plotter.interactor.setFocus()
            key, mod = keys[name]
            qtbot.keyClick(win.plotter.interactor, key, *([mod] if mod else []))
        cam = win.plotter.camera
        assert np.allclose(cam.GetDirectionOfProjection(), axis, atol=1e-9), name
        assert np.allclose(cam.GetViewPlaneNormal(), -np.asarray(axis), atol=1e-9), name
        assert abs(np.dot(cam.up, axis)) < 1e-9  # the view up is across the view
        assert _shows_the_data(win), name
    assert not errors


def test_frame_buttons_and_keys_step_through_time(qtbot, window, errors):
    win = window
    _open(qtbot, win, steps=6)
    last = win.volume.n_steps - 1
    acts = win.time_actions
    acts["last_step"].trigger()
    assert win.scene.step == last and win.slider.value() == last
    acts["next_step"].trigger()  # stays at the last
    assert win.scene.step == last
    acts["previous_step"].trigger()
    assert win.scene.step == last - 1
    acts["first_step"].trigger()
    assert win.scene.step == 0 and win.slider.value() == 0
    acts["previous_step"].trigger()  # stays at the first
    assert win.scene.step == 0
    acts["next_step"].trigger()
    assert win.scene.step == 1
    assert f"step 1/{last}" in win.step_label.text()
    # the keys, on the 3-D view
    view = win.plotter.interactor
    view.setFocus()
    qtbot.keyClick(view, Key.Key_End)
    assert win.scene.step == last
    qtbot.keyClick(view, Key.Key_Comma)
    assert win.scene.step == last - 1
    qtbot.keyClick(view, Key.Key_Home)
    assert win.scene.step == 0
    qtbot.keyClick(view, Key.Key_Period)
    qtbot.keyClick(view, Key.Key_Period)
    assert win.scene.step == 2
    # a stepping key stops Play
    win.play_btn.setChecked(True)
    assert win._anim_timer.isActive()
    qtbot.keyClick(view, Key.Key_Home)
    assert not win._anim_timer.isActive() and not win.play_btn.isChecked()
    assert win.scene.step == 0
    # typing in a text box types, it does not step
    edit = win.th_edits["monopole"]
    edit.setFocus()
    edit.setText("3")
    qtbot.keyClick(edit, Key.Key_Period)
    qtbot.keyClick(edit, Key.Key_End)
    assert win.scene.step == 0 and edit.text() == "3."
    assert not errors


def test_menus_have_their_actions_and_shortcuts(qtbot, window, errors):
    win = window
    bar = [a.text() for a in win.menuBar().actions()]
    assert bar == ["&File", "&View", "&Sources", "&Listener", "&Audio", "&Time", "&Help"]

    def by_text(menu):
        return {a.text(): a for a in menu.actions() if a.text()}

    view = by_text(win.view_menu)
    assert view["Reset Camera"].shortcut().toString() == "C"
    for name in STANDARD_VIEWS:
        label = name.replace("-", "−")
        assert label in view
    assert view["−X"].shortcut().toString() == "Shift+X"
    for title, dock in win.docks.items():
        a = view[f"{title} panel"]
        assert a.isCheckable() and a.isChecked()
        a.trigger()
        assert dock.isHidden()
        a.trigger()
        assert not dock.isHidden()
    assert "Time toolbar" in view and "Camera toolbar" in view
    file = by_text(win.file_menu)
    assert file["Save Screens&hot…"].shortcut().toString() == "Ctrl+Shift+S"
    assert file["&Open…"].shortcut().toString() == "Ctrl+O"
    help_ = by_text(win.help_menu)
    assert {"&Keys…", "&About auralize", "&Documentation"} <= set(help_)
    # Help ▸ Keys lists every key binding of the one table the key handling uses
    help_["&Keys…"].trigger()
    text = win.keys_view.toPlainText()
    for b in KEYS:
        assert key_text(b) in text and b.what in text
    assert win.keys_dialog.isVisible()
    # the frame keys are on the toolbar buttons
    assert {a.shortcut().toString() for a in win.time_actions.values()} == {"Home", ",", ".", "End"}
    # About: the version and the docs
    help_["&About auralize"].trigger()
    assert auralize.__version__ in win.about_box.text()
    doc = win.docs_path()
    assert doc is not None and doc.exists() and doc.name == "README.md"
    assert "docs" in win.about_box.text()
    assert not errors


def test_save_screenshot_writes_what_is_shown(qtbot, window, tmp_path, errors, monkeypatch):
    win = window
    _open(qtbot, win)
    win.scene.set_representation("slices")
    out = win.save_screenshot(tmp_path / "view.png")
    assert out == tmp_path / "view.png" and out.exists()
    img = np.asarray(Image.open(out).convert("RGB")).astype(int)
    off = np.abs(img - np.asarray(BACKGROUND)).sum(axis=2) > 30
    assert off.mean() > 0.05  # the data, not a dark picture
    # File ▸ Save Screenshot asks for the name (a name without suffix gets .png)
    monkeypatch.setattr(
        QtWidgets.QFileDialog, "getSaveFileName", lambda *a, **k: (str(tmp_path / "asked"), "")
    )
    win.screenshot_action.trigger()
    assert (tmp_path / "asked.png").exists()
    # a missing folder is an error box, not a crash
    win._guard(win.save_screenshot, tmp_path / "no" / "x.png")
    assert len(errors) == 1 and "does not exist" in errors[0]


def test_every_control_has_a_tooltip(qtbot, window):
    win = window
    kinds = (
        QtWidgets.QAbstractButton,
        QtWidgets.QComboBox,
        QtWidgets.QSlider,
        QtWidgets.QAbstractSpinBox,
        QtWidgets.QCheckBox,
        QtWidgets.QLineEdit,
    )
    seen = 0
    missing = []
    for w in win.findChildren(QtWidgets.QWidget):
        if not isinstance(w, kinds):
            continue
        if isinstance(w, QtWidgets.QLineEdit) and isinstance(
            w.parent(), QtWidgets.QAbstractSpinBox | QtWidgets.QComboBox
        ):
            continue  # the editor inside a spin / combo box (the box has the tooltip)
        seen += 1
        if not w.toolTip().strip():
            missing.append(f"{type(w).__name__} {w.objectName()!r} {getattr(w, 'text', str)()!r}")
    assert seen > 40
    assert not missing, missing
