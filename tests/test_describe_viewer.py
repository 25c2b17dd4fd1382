"""The viewer without a mouse, and with a screen reader (under Xvfb).

Every control has an accessible name (and different controls different
names), Tab visits every control of the panels and toolbars in the panels'
order, every panel and the 3-D view can be reached with a key, every
button's action is on a menu, and the Describe panel shows the sources in
words — asked for with its key.
"""

from __future__ import annotations

import pytest

pytest.importorskip("pytestqt")
pytest.importorskip("pyvistaqt")

from qtpy import QtCore, QtGui, QtWidgets

from auralize.viewer.access import actionable, tab_chain
from auralize.viewer.app import KEYS, PANEL_ORDER

Key = QtCore.Qt.Key
Mod = QtCore.Qt.KeyboardModifier


def _open(qtbot, win):  # type: ignore[no-untyped-def]
    win.open_data("dataset:explosion", size=24, steps=6)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)


def _controls(win) -> list[QtWidgets.QWidget]:  # type: ignore[no-untyped-def]
    """The actionable widgets a user meets: those of the window, visible."""
    return [w for w in actionable(win) if w.isVisible()]


def _menu_actions(win) -> list[QtGui.QAction]:  # type: ignore[no-untyped-def]
    """Every action of the window's menus (the menu bar's and their submenus)."""
    return [a for m in win.findChildren(QtWidgets.QMenu) for a in m.actions()]


def _screen_reader_name(w: QtWidgets.QWidget) -> str:
    iface = QtGui.QAccessible.queryAccessibleInterface(w)
    return "" if iface is None else iface.text(QtGui.QAccessible.Text.Name)


def test_every_control_has_a_name_of_its_own(qtbot, window, errors) -> None:  # type: ignore[no-untyped-def]
    win = window
    _open(qtbot, win)
    controls = _controls(win)
    assert len(controls) > 45
    unnamed = [f"{type(w).__name__} {w.objectName()!r}" for w in controls if not w.accessibleName()]
    assert not unnamed, unnamed
    # what a screen reader is told is that name
    silent = [w.accessibleName() for w in controls if not _screen_reader_name(w)]
    assert not silent, silent
    # the three Stop buttons, the draw / hear boxes ... are told apart
    names = [w.accessibleName() for w in controls]
    twice = sorted({n for n in names if names.count(n) > 1})
    assert not twice, twice
    assert "Stop recording" in names and "Stop live listening" in names
    assert "Hear the dipoles" in names and "Draw the dipoles" in names
    assert "Audio: layout" in names  # a form row: its panel and its label
    assert "Hide the Describe panel" in names  # Qt's own dock buttons
    # and a description (the tooltip) for those that have a tooltip
    assert win.detect_btn.accessibleDescription().startswith("detect the sound sources")
    assert not errors


def test_tab_visits_every_control_in_the_panels_order(qtbot, window, errors) -> None:  # type: ignore[no-untyped-def]
    win = window
    _open(qtbot, win)
    view = win.plotter.interactor
    chain = tab_chain(view)
    reachable = [
        w
        for w in _controls(win)
        if w.isEnabled() and w.focusPolicy() & QtCore.Qt.FocusPolicy.TabFocus
    ]
    missing = [w.accessibleName() for w in reachable if w not in chain and w is not view]
    assert not missing, missing
    # the panels come in their order, each one whole
    owner = {}
    for title, dock in win.docks.items():
        for w in actionable(dock):
            owner[w] = title
    seen = [owner[w] for w in chain if w in owner]
    blocks = [t for i, t in enumerate(seen) if i == 0 or seen[i - 1] != t]
    assert blocks == [t for t in PANEL_ORDER if t in blocks]
    assert set(blocks) >= {"Data", "Sources", "Listener", "Describe", "Audio"}
    # real Tab presses follow the chain: from the view to the Data panel's first control
    win.activateWindow()
    view.setFocus()
    qtbot.waitUntil(lambda: win.focusWidget() is view, timeout=5000)
    for expected in chain[:6]:
        qtbot.keyClick(win.focusWidget(), Key.Key_Tab)
        assert win.focusWidget() is expected, (win.focusWidget(), expected)
    assert not errors


def test_panels_and_view_are_a_key_away_and_buttons_are_on_menus(qtbot, window, errors) -> None:  # type: ignore[no-untyped-def]
    win = window
    _open(qtbot, win)
    menus = {a.text() for a in win.menuBar().actions()}
    assert {"&Sources", "&Listener", "&Audio", "&Time"} <= menus
    assert all("&" in m for m in menus)  # each opens with Alt + its letter
    for title in PANEL_ORDER:
        w = win.focus_panel(title)
        assert w is not None and win.focusWidget() is w, title
        dock = win.docks[title]
        assert dock.isAncestorOf(w)
    win.focus_view()
    assert win.focusWidget() is win.plotter.interactor
    # every key of the table is a shortcut of a menu action or a view key
    shortcuts = {s.toString() for a in _menu_actions(win) for s in a.shortcuts()}
    menu_keys = [k for b in KEYS if not b.view for k in b.keys]
    assert set(menu_keys) <= shortcuts, set(menu_keys) - shortcuts
    # each push button of a panel does what a menu entry does: the menus hold an action
    # for every method a panel's button calls (Detect, Record, Render …)
    entries = {a.text().replace("&", "") for a in _menu_actions(win)}
    for want in (
        "Detect",
        "Describe in words",
        "Record",
        "Stop recording",
        "Clear path",
        "Render to file…",
        "Play the last render",
        "Stop playing",
        "Listen live",
        "Stop live listening",
        "Save heard…",
        "Save path CSV…",
        "Load path CSV…",
        "Play / pause",
    ):
        assert want in entries, want
    assert not errors


def test_describe_panel_speaks_after_its_key(qtbot, window, errors, tmp_path) -> None:  # type: ignore[no-untyped-def]
    win = window
    _open(qtbot, win)
    panel = win.describe_panel
    assert panel.description is None and "Describe" in panel.now.text()
    win.activateWindow()
    win.focus_view()
    qtbot.waitUntil(lambda: win.isActiveWindow(), timeout=5000)
    # Sources ▸ Describe in words by its key: detects first, then describes
    qtbot.keyClick(win.plotter.interactor, Key.Key_D, Mod.ControlModifier | Mod.ShiftModifier)
    qtbot.waitUntil(lambda: panel.description is not None and not win.busy, timeout=120_000)
    text = panel.text.toPlainText()
    assert text.startswith("Sources in dataset:explosion")
    assert "What you will hear" in text and "monopoles" in text
    assert win.series is not None  # it detected them
    # the line about the step on screen follows the time slider
    win.set_step(3)
    assert panel.now.text().startswith("Step 3 (")
    assert panel.now.text() == panel.description.at_step(3)
    # the same figures as the command's: the plan is the viewer's render's
    assert panel.description.plan["time_scale"] == pytest.approx(win.playback_plan().time_scale)
    out = win.save_description(tmp_path / "d.csv")
    assert out.read_text().startswith("step,time,type,count")
    # new sources: the old words go
    before = win.series
    win.detect()
    qtbot.waitUntil(lambda: win.series is not before and not win.busy, timeout=120_000)
    assert panel.description is None and "detected again" in panel.now.text()
    assert not errors
