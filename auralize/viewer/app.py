"""The desktop viewer: a pyvistaqt 3-D view with ParaView-like dock panels.

Panels: **Data** (file, grid, fields, steps; field, representation, colour
map, opacity, mapping), **Sources** (thresholds, detect, per-type toggles and
counts), **Listener** (record / stop / clear, capture rate, save / load CSV,
autosave), **Audio** (layout, device, time scale, render to file, play / stop,
waveform and spectrogram with a cursor on the time slider), **Live listening**
and **Overlays** (sound-model plugin overlays; an overlay whose model makes
sound from the volume is heard too, live and in rendered files).  Long work (loading,
detection, rendering, each time step of an overlay) runs in a :class:`Task`
thread with a progress bar and a Cancel button.  Errors show a message box; the session stays usable.

Menus: **File** (Open…, Open built-in dataset, Save session, Save session
as…, Open session…, Save Screenshot…, Quit), **View** (Reset Camera, the six
standard views, show / hide each panel and toolbar, Go to: the keyboard focus to
the 3-D view or a panel), **Sources** (Detect, Describe in words, Save
description…), **Listener** (Record, Stop, Clear, save / load the path),
**Audio** (Render to file…, Play, Stop, Listen live, Stop live, Save heard…),
**Time** (first, previous, play / pause, next, last frame) and **Help** (Keys,
Documentation, About): every button of the panels and toolbars is also a menu
entry, most with a key.

**Describe** (:mod:`auralize.viewer.describe_panel`, under the 3-D view): the sources in words
(:mod:`auralize.describe`): what the listener hears when, step by step, in a
read-only text box, and a line about the step on screen that follows the time
slider.

Keyboard and screen readers (:mod:`auralize.viewer.access`): Tab visits the
3-D view, then the panels (left column, the Describe panel, the right column,
each top down; status texts too), then the toolbars; every control has an accessible name (what a screen
reader says) and a description (its tooltip).  Opening shows the data at once (volume, slices or contour, the
data's outline and a colour bar) with the camera framing it; a listener path
recorded for the previous data is discarded unless the user keeps it (a
question, Discard by default; ``open_data(keep_path=...)`` or
:attr:`MainWindow.keep_path_answer` answer it in scripts and tests).  Sources
are detected only when asked (Sources panel).

Toolbars, as ParaView's: **Camera** (Reset Camera: frame the data keeping the
view direction; +X … −Z: look along an axis) and **Time** (first, previous,
Play, next, last frame, the time slider).

Keys: one table, :data:`KEYS`, makes the key handling, the menus' shortcuts and
Help ▸ Keys.  The view keys work whenever no text or number box is being
edited (Qt key codes, so they work whatever name VTK gives the key): flying —
Up/W forward, Down/S back, Left/A and Right/D turn, PageUp/R rise, PageDown/F
sink; camera — C Reset Camera, X / Y / Z look along +X / +Y / +Z, Shift+X / Y / Z
along −X / −Y / −Z; time — Home first, ``,`` previous, ``.`` next, End last
frame.  Menus: Ctrl+O open, Ctrl+S save session, Ctrl+Shift+S save screenshot,
Ctrl+Q quit, F1 keys; Ctrl+D detect, Ctrl+Shift+D describe, Ctrl+R / Ctrl+Shift+R
record / stop, Ctrl+E render to file, Ctrl+P / Ctrl+Shift+P play / stop, Ctrl+L /
Ctrl+Shift+L live listening on / off, P play / pause the time steps, Alt+0 the
3-D view, Alt+1 … Alt+7 the panels.  The camera position is in the status bar.
"""

from __future__ import annotations

import os
import shlex
import time
import traceback
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

os.environ.setdefault("QT_API", "pyside6")

import numpy as np
from pyvistaqt import QtInteractor
from qtpy import QtCore, QtGui, QtWidgets

from auralize.defaults import DEFAULTS, LAYOUT_NAMES, TIMBRE_CHOICES
from auralize.errors import AuralizeError, OutputError, ParameterError
from auralize.listener import ListenerPath
from auralize.scene.detection import Cancelled, Detection
from auralize.scene.recorder import DEFAULT_RATE_HZ, PathRecorder
from auralize.scene.session import SessionState, data_spec, reader_options
from auralize.scene.soundscene import input_key
from auralize.scene.view import PENDING, REPRESENTATIONS, TYPE_COLORS, Scene, camera_pose
from auralize.sources.detection import TYPES, Thresholds
from auralize.viewer.access import name_widgets, set_focus_chain
from auralize.viewer.describe_panel import DescribePanel

#: the Audio panel's entry that asks for a custom layout JSON file
CUSTOM_LAYOUT = "custom layout file…"


def _short(text: str, n: int = 34) -> str:
    """``text`` cut at a word before ``n`` characters, with an ellipsis."""
    if len(text) <= n:
        return text
    cut = text[:n].rsplit(" ", 1)[0].rstrip(",:;(")
    return cut + "…"


MAPPINGS = ("auto", "paper-density", "identity", "cfd")
CMAPS = ("gray", "viridis", "inferno", "coolwarm", "bone")


@dataclass(frozen=True)
class KeyBinding:
    """One row of :data:`KEYS`: ``keys`` (Qt key-sequence text, e.g. ``"Shift+X"``) call
    the window's method ``action`` with ``args``; ``what`` is its line in Help ▸ Keys.

    ``view`` keys act on the 3-D view: they work whenever no text or number box
    is being edited (:class:`ViewKeys`, an application event filter), and only
    once data is open; the others are menu shortcuts (Qt's).  A binding whose
    action is on a menu or toolbar (:meth:`MainWindow._act`) is also that action's
    shortcut, so the menus show its keys (Qt's shortcut or the filter handles a key
    press, never both)."""

    group: str
    keys: tuple[str, ...]
    action: str
    what: str
    args: tuple[Any, ...] = ()
    view: bool = True


#: every key binding of the viewer: the key handling (:class:`ViewKeys`, the menu and
#: toolbar actions' shortcuts) and Help ▸ Keys are made from this one table
KEYS: tuple[KeyBinding, ...] = (
    KeyBinding("Fly (the camera is the listener)", ("Up", "W"), "fly", "forward", (1, 0, 0)),
    KeyBinding("Fly (the camera is the listener)", ("Down", "S"), "fly", "back", (-1, 0, 0)),
    KeyBinding("Fly (the camera is the listener)", ("Left", "A"), "fly", "turn left", (0, 1, 0)),
    KeyBinding("Fly (the camera is the listener)", ("Right", "D"), "fly", "turn right", (0, -1, 0)),
    KeyBinding("Fly (the camera is the listener)", ("PgUp", "R"), "fly", "rise", (0, 0, 1)),
    KeyBinding("Fly (the camera is the listener)", ("PgDown", "F"), "fly", "sink", (0, 0, -1)),
    KeyBinding(
        "Camera", ("C",), "reset_camera", "Reset Camera: frame the data, keeping the view direction"
    ),
    KeyBinding("Camera", ("X",), "look", "view direction +X (look along +X)", ("+X",)),
    KeyBinding("Camera", ("Shift+X",), "look", "view direction −X", ("-X",)),
    KeyBinding("Camera", ("Y",), "look", "view direction +Y", ("+Y",)),
    KeyBinding("Camera", ("Shift+Y",), "look", "view direction −Y", ("-Y",)),
    KeyBinding("Camera", ("Z",), "look", "view direction +Z (look down)", ("+Z",)),
    KeyBinding("Camera", ("Shift+Z",), "look", "view direction −Z (look up)", ("-Z",)),
    KeyBinding("Time", ("Home",), "first_step", "first frame"),
    KeyBinding("Time", (",",), "previous_step", "previous frame"),
    KeyBinding("Time", (".",), "next_step", "next frame"),
    KeyBinding("Time", ("End",), "last_step", "last frame"),
    KeyBinding("Menus", ("Ctrl+O",), "_ask_open", "File ▸ Open…", view=False),
    KeyBinding("Menus", ("Ctrl+S",), "save_session_current", "File ▸ Save session", view=False),
    KeyBinding(
        "Menus", ("Ctrl+Shift+S",), "save_screenshot", "File ▸ Save Screenshot…", view=False
    ),
    KeyBinding("Menus", ("Ctrl+Q",), "close", "File ▸ Quit", view=False),
    KeyBinding("Menus", ("F1",), "show_keys", "Help ▸ Keys (this list)", view=False),
    KeyBinding("Time", ("P",), "toggle_playing", "play / pause the time steps"),
    KeyBinding("Sources", ("Ctrl+D",), "detect", "Sources ▸ Detect", view=False),
    KeyBinding("Sources", ("Ctrl+Shift+D",), "describe", "Sources ▸ Describe in words", view=False),
    KeyBinding("Listener", ("Ctrl+R",), "start_recording", "Listener ▸ Record", view=False),
    KeyBinding(
        "Listener", ("Ctrl+Shift+R",), "stop_recording", "Listener ▸ Stop recording", view=False
    ),
    KeyBinding("Audio", ("Ctrl+E",), "_ask_render", "Audio ▸ Render to file…", view=False),
    KeyBinding("Audio", ("Ctrl+P",), "play_audio", "Audio ▸ Play the last render", view=False),
    KeyBinding("Audio", ("Ctrl+Shift+P",), "stop_audio", "Audio ▸ Stop playing", view=False),
    KeyBinding("Audio", ("Ctrl+L",), "listen_live", "Audio ▸ Listen live", view=False),
    KeyBinding("Audio", ("Ctrl+Shift+L",), "stop_live", "Audio ▸ Stop live listening", view=False),
    KeyBinding(
        "Go to (keyboard focus)", ("Alt+0",), "focus_view", "View ▸ Go to ▸ 3-D view", view=False
    ),
    *(
        KeyBinding(
            "Go to (keyboard focus)",
            (f"Alt+{i}",),
            "focus_panel",
            f"View ▸ Go to ▸ {title} panel",
            (title,),
            view=False,
        )
        for i, title in enumerate(
            ("Data", "Sources", "Listener", "Describe", "Audio", "Live listening", "Overlays"),
            start=1,
        )
    ),
)
#: the panels in the order Tab visits them (the left column, the one under the 3-D view,
#: the right column; each top down)
PANEL_ORDER = ("Data", "Sources", "Listener", "Describe", "Audio", "Live listening", "Overlays")
#: the six standard views (ParaView's camera toolbar): name -> (view direction, view up)
STANDARD_VIEWS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "+X": ((1, 0, 0), (0, 0, 1)),
    "-X": ((-1, 0, 0), (0, 0, 1)),
    "+Y": ((0, 1, 0), (0, 0, 1)),
    "-Y": ((0, -1, 0), (0, 0, 1)),
    "+Z": ((0, 0, 1), (0, 1, 0)),
    "-Z": ((0, 0, -1), (0, 1, 0)),
}
_MODS = (
    QtCore.Qt.KeyboardModifier.ShiftModifier
    | QtCore.Qt.KeyboardModifier.ControlModifier
    | QtCore.Qt.KeyboardModifier.AltModifier
    | QtCore.Qt.KeyboardModifier.MetaModifier
)


def binding(action: str, *args: Any) -> KeyBinding:
    """The row of :data:`KEYS` for ``action`` called with ``args``."""
    for b in KEYS:
        if b.action == action and b.args == args:
            return b
    raise KeyError((action, args))


def key_text(b: KeyBinding) -> str:
    """The keys of a binding as the menus show them (``"Up / W"``)."""
    return " / ".join(
        QtGui.QKeySequence(k).toString(QtGui.QKeySequence.SequenceFormat.NativeText) for k in b.keys
    )


def keys_html() -> str:
    """Help ▸ Keys: every binding of :data:`KEYS`, grouped, as an HTML table."""
    rows, group = [], None
    for b in KEYS:
        if b.group != group:
            group = b.group
            rows.append(f"<tr><th colspan=2 align=left><br>{group}</th></tr>")
        rows.append(f"<tr><td><b>{key_text(b)}</b></td><td>{b.what}</td></tr>")
    return (
        "<p>View keys work whenever no text or number box is being edited "
        "(click the 3-D view first).</p><table cellspacing=4>" + "".join(rows) + "</table>"
    )


def _combo(key: int, mods: Any) -> int:
    return int(
        QtCore.QKeyCombination(
            QtCore.Qt.KeyboardModifier(mods & _MODS), QtCore.Qt.Key(key)
        ).toCombined()
    )


#: view keys: key combination -> binding
VIEW_KEYS: dict[int, KeyBinding] = {
    QtGui.QKeySequence(k)[0].toCombined(): b  # type: ignore[index]
    for b in KEYS
    if b.view
    for k in b.keys
}
KEY_MAP_TEXT = (
    "fly: "
    + " · ".join(f"{key_text(b)} {b.what}" for b in KEYS if b.action == "fly")
    + " (when no box is being edited; Help ▸ Keys lists every key)"
)
#: live listening moves the time slider no sooner than this after its last redraw (s) ...
LIVE_REDRAW_GAP_S = 0.1
#: ... nor sooner than this many times that redraw's duration after it.  The widget's
#: paint draws each frame once more after it (pyvistaqt), so a step shown costs about
#: twice the time measured: time steps shown while listening take at most about
#: 2 / (2 + LIVE_REDRAW_DUTY) = 1/3 of the window's thread; keys, the mouse and
#: recording keep the rest
LIVE_REDRAW_DUTY = 4.0
#: sizes and steps File ▸ Open built-in dataset uses (quick to open); others: their defaults
BUILTIN_SIZES = {"explosion": (32, 12), "monopole": (16, 60)}


class ViewKeys(QtCore.QObject):
    """Application event filter: the view keys of :data:`KEYS` (flying, camera, time)
    reach the window unless a text or number box has the focus (then the box gets
    them, as usual).  Flying keys work with Shift held too."""

    def __init__(self, window: MainWindow) -> None:
        super().__init__(window)
        self.window = window

    def eventFilter(self, obj: QtCore.QObject, event: QtCore.QEvent) -> bool:
        if event.type() != QtCore.QEvent.Type.KeyPress:
            return False
        key = int(event.key())  # type: ignore[attr-defined]
        mods = event.modifiers()  # type: ignore[attr-defined]
        b = VIEW_KEYS.get(_combo(key, mods))
        if b is None and mods & QtCore.Qt.KeyboardModifier.ShiftModifier:
            b = VIEW_KEYS.get(_combo(key, mods & ~QtCore.Qt.KeyboardModifier.ShiftModifier))
            if b is not None and b.action != "fly":
                b = None
        if b is None:
            return False
        # a key event goes to the focus widget (or the window): that is ``obj``
        if not isinstance(obj, QtWidgets.QWidget) or obj.window() is not self.window:
            return False
        if _edits_text(obj):
            return False
        if self.window.volume is None:
            return False
        self.window._guard(getattr(self.window, b.action), *b.args)
        return True


#: the old name
FlyKeys = ViewKeys


def _edits_text(w: QtWidgets.QWidget) -> bool:
    """Whether ``w`` takes typed keys itself (line edits, spin boxes, editable combos)."""
    if isinstance(
        w,
        QtWidgets.QLineEdit
        | QtWidgets.QAbstractSpinBox
        | QtWidgets.QTextEdit
        | QtWidgets.QPlainTextEdit,
    ):
        return True
    return isinstance(w, QtWidgets.QComboBox) and w.isEditable()


def default_autosave_dir() -> Path:
    base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(base) / "auralize" / "recordings"


class Task(QtCore.QThread):
    """Run ``fn(progress)`` off the GUI thread; ``progress(done, total)`` returns False
    once :meth:`cancel` was called (the function then stops, e.g. raising
    :class:`Cancelled`)."""

    progressed = QtCore.Signal(int, int)
    succeeded = QtCore.Signal(object)
    failed = QtCore.Signal(object)

    def __init__(
        self,
        name: str,
        fn: Callable[[Callable[[int, int], bool]], Any],
        parent: QtCore.QObject | None = None,
    ) -> None:
        super().__init__(parent)
        self.name, self.fn = name, fn
        self._cancel = False
        #: set (on the UI thread) once its result or error has been handled
        self.reported = False

    def cancel(self) -> None:
        self._cancel = True

    def _progress(self, done: int, total: int) -> bool:
        self.progressed.emit(int(done), int(total))
        return not self._cancel

    def run(self) -> None:
        try:
            self.succeeded.emit(self.fn(self._progress))
        except BaseException as exc:  # reported on the GUI thread
            self.failed.emit(exc)


def _readable(label: QtWidgets.QLabel, name: str) -> None:
    """Let the keyboard reach a status text (Tab stops on it, a screen reader reads it)."""
    label.setTextInteractionFlags(
        QtCore.Qt.TextInteractionFlag.TextSelectableByKeyboard
        | QtCore.Qt.TextInteractionFlag.TextSelectableByMouse
    )
    label.setFocusPolicy(QtCore.Qt.FocusPolicy.StrongFocus)
    label.setAccessibleName(name)
    if not label.toolTip():
        label.setToolTip(name)


def _form(parent: QtWidgets.QWidget) -> QtWidgets.QFormLayout:
    lay = QtWidgets.QFormLayout(parent)
    lay.setFieldGrowthPolicy(QtWidgets.QFormLayout.FieldGrowthPolicy.AllNonFixedFieldsGrow)
    return lay


def _sound_wave_hint(vol: Any) -> str | None:
    """The advice for data that hold sound waves (the render's ``auto`` would hear them
    through the FW-H integral, :func:`auralize.fwh.classify.choose_method`), else None.

    The viewer hears the field's sources; such data are mis-heard that way, so the
    Overlays panel and the status bar say how to hear them as ``auralize render``
    does.  Data the test cannot judge give None.
    """
    from auralize.fwh.classify import choose_method

    try:
        how = choose_method(vol, "auto")
    except AuralizeError:
        return None
    if how.name != "fwh":
        return None
    return (
        f"{how.why}: summed as sources they are mis-heard. Tick fwh in Overlays to hear "
        f"them through the FW-H surface ({how.surface}), as auralize render does"
    )


class MainWindow(QtWidgets.QMainWindow):
    """The viewer window. Its methods are the actions of the panels (tests drive them)."""

    live_tick = QtCore.Signal(float)

    def __init__(self, *, autosave_dir: Path | None = None) -> None:
        super().__init__()
        self.setWindowTitle("auralize")
        self.resize(1400, 900)
        self.plotter = QtInteractor(self)
        self.setCentralWidget(self.plotter.interactor)
        # the side columns run the window's height; a bottom panel sits under the view only
        for corner, area in (
            (QtCore.Qt.Corner.BottomLeftCorner, QtCore.Qt.DockWidgetArea.LeftDockWidgetArea),
            (QtCore.Qt.Corner.BottomRightCorner, QtCore.Qt.DockWidgetArea.RightDockWidgetArea),
        ):
            self.setCorner(corner, area)
        self.scene = Scene(self.plotter)
        self.volume: Any = None
        self.data: dict[str, Any] = {}
        self.detection: Detection | None = None
        self.series: Any = None
        self.mapping = "auto"
        self.mapping_fields: dict[str, str] = {}
        #: UDP port of a head tracker for live listening (``--head-tracking``), or None
        self.head_tracking_port: int | None = None
        self._head: Any = None
        self.load_notes: list[str] = []
        #: what to do when the data on screen hold sound waves (:func:`_sound_wave_hint`)
        self.sound_wave_hint: str | None = None
        self.thresholds = Thresholds(*DEFAULTS.thresholds)
        self.autosave_dir = autosave_dir or default_autosave_dir()
        self.recorder = PathRecorder(rate_hz=DEFAULT_RATE_HZ)
        self.path: ListenerPath | None = None
        self.rendered: Any = None
        self.player: Any = None
        self.playback: Any = None
        self.gain_db = 0.0
        self._live_time = 0.0
        #: the latest camera pose seen (the capture clock's and live listening's listener)
        self._cam_pose: tuple[Any, ...] = camera_pose(self.plotter.camera)
        self._cam_obs: tuple[Any, int] | None = None
        self._shown_captures = -1
        self._tick_pending = False
        self._live_redraw_at = 0.0  # perf_counter time of the next live step redraw allowed
        self.task: Task | None = None
        #: answer to "keep the listener path for the new data?" (None: ask; tests set it)
        self.keep_path_answer: bool | None = None
        # overlay steps computed in the background: the running task, the step wanted
        # next and the steps computed so far per overlay (for one volume and path)
        self._overlay_tasks: dict[str, Task] = {}
        self._overlay_want: dict[str, int] = {}
        self._overlay_cache: dict[str, tuple[Any, Any, dict[int, Any]]] = {}
        # what an overlay's model emits (heard with the sources): name -> (volume, Sound),
        # computed in the background after the overlay is drawn
        self._overlay_sounds: dict[str, tuple[Any, Any]] = {}
        self._sound_tasks: dict[str, Task] = {}
        self._overlay_params: dict[str, dict[str, Any]] = {}
        # overlays drawn whose model makes no sound from the volume: name -> why
        self._overlay_unheard: dict[str, str] = {}
        self._threads: set[Task] = set()
        # the command line's plan (auralize.defaults), but stereo on the desktop's device
        self.audio: dict[str, Any] = {
            "layout": "stereo",
            "rate": DEFAULTS.rate,
            "time_scale": DEFAULTS.time_scale,
            "timbre": DEFAULTS.timbre,
            "device": None,
            "heard": DEFAULTS.heard,
        }
        self._plan_cache: tuple[Any, Any] | None = None
        self._heard: Any = None
        self._rec_timer = QtCore.QTimer(self)
        self._rec_timer.timeout.connect(self._show_recording)
        self._anim_timer = QtCore.QTimer(self)
        self._anim_timer.timeout.connect(self._advance)
        self.live_tick.connect(self._on_live_tick)
        self._live_redraw_timer = QtCore.QTimer(self)  # a live step redraw put off
        self._live_redraw_timer.setSingleShot(True)
        self._live_redraw_timer.timeout.connect(self._live_redraw)
        self._build_menu()
        self._build_toolbar()
        self._build_panels()
        self._build_view_menu()
        self._build_task_menus()
        self._build_status()
        self._qt_button_tips()
        self._build_access()
        self.fly_keys = ViewKeys(self)
        app = QtWidgets.QApplication.instance()
        if app is not None:
            app.installEventFilter(self.fly_keys)
        self._quiet_auto_render()
        self._ui_timer = QtCore.QTimer(self)  # camera readout and level meter
        self._ui_timer.timeout.connect(self._update_readouts)
        self._ui_timer.start(150)
        self._refresh_enabled()

    def _quiet_auto_render(self) -> None:
        """pyvistaqt redraws the view several times a second, whatever happens (to show
        changes made without a redraw, e.g. a capture drawn).  Skip that redraw when the
        view was drawn within the period anyway (a key, a live time step): every change
        is still shown within two periods, and the window's thread is not spent
        drawing the same picture again while the user flies."""
        timer = getattr(self.plotter, "render_timer", None)
        rw = self.plotter.render_window
        if timer is None or rw is None or not timer.isActive():
            return
        self._drawn_at = 0.0
        rw.AddObserver("EndEvent", lambda *_: setattr(self, "_drawn_at", time.perf_counter()))
        period = timer.interval() / 1000

        def auto_render() -> None:
            if time.perf_counter() - self._drawn_at >= period:
                self.plotter._auto_render()

        timer.timeout.disconnect()
        timer.timeout.connect(auto_render)

    # ============================================================ building
    def _act(
        self, text: str, action: str, *args: Any, tip: str = "", icon: Any = None
    ) -> QtGui.QAction:
        """A menu / toolbar action calling ``self.<action>(*args)``; its shortcut (and
        the key in its tooltip) comes from :data:`KEYS`."""
        a = QtGui.QAction(text, self)
        if icon is not None:
            a.setIcon(self.style().standardIcon(icon))
        tip = tip or text.replace("&", "").rstrip("…")
        try:
            b = binding(action, *args)
        except KeyError:
            pass
        else:
            a.setShortcuts([QtGui.QKeySequence(k) for k in b.keys])
            tip = f"{tip} ({key_text(b)})"
        a.setToolTip(tip)
        a.setStatusTip(tip)
        fn = getattr(self, action)
        a.triggered.connect(lambda _c=False: self._guard(fn, *args))
        return a

    def _build_menu(self) -> None:
        m = self.menuBar().addMenu("&File")
        m.setToolTipsVisible(True)
        m.addAction(self._act("&Open…", "_ask_open", tip="Open a data file"))
        sub = self.builtin_menu = m.addMenu("Open &built-in dataset")
        from auralize.datasets.synthetic import all_datasets

        for name in all_datasets():
            size, steps = BUILTIN_SIZES.get(name, (None, None))
            a = sub.addAction(name)
            a.triggered.connect(
                lambda _c=False, n=name, sz=size, st=steps: self._guard(
                    lambda: self.open_data(f"dataset:{n}", size=sz, steps=st)
                )
            )
        m.addSeparator()
        m.addAction(
            self._act(
                "&Save session",
                "save_session_current",
                tip="Save the session (to its file, or ask for one)",
            )
        )
        act = m.addAction("Save session &as…")
        act.triggered.connect(self._ask_save_session)
        act = m.addAction("Open &session…")
        act.triggered.connect(
            lambda: self._ask_file("open", "Sessions (*.json)", self.load_session)
        )
        m.addSeparator()
        self.screenshot_action = self._act(
            "Save Screens&hot…",
            "save_screenshot",
            tip="Save the 3-D view as a PNG image (asks for a file name)",
        )
        m.addAction(self.screenshot_action)
        m.addSeparator()
        m.addAction(self._act("&Quit", "close", tip="Close the window"))
        self.file_menu = m
        self.session_file: Path | None = None
        # filled once the panels and toolbars exist (_build_view_menu)
        self.view_menu = self.menuBar().addMenu("&View")
        self.view_menu.setToolTipsVisible(True)
        h = self.help_menu = self.menuBar().addMenu("&Help")
        h.setToolTipsVisible(True)
        h.addAction(self._act("&Keys…", "show_keys", tip="Every key binding"))
        h.addAction(
            self._act(
                "&Documentation",
                "open_docs",
                tip="Open the README (the docs/ folder has the design notes)",
            )
        )
        h.addAction(self._act("&About auralize", "show_about", tip="Version and links"))

    def _build_view_menu(self) -> None:
        """View: Reset Camera, the six standard views, and show / hide each panel and
        toolbar."""
        v = self.view_menu
        v.addAction(self.reset_camera_action)
        for a in self.view_actions.values():
            v.addAction(a)
        v.addSeparator()
        for title, d in self.docks.items():
            a = d.toggleViewAction()
            a.setText(f"{title} panel")
            a.setToolTip(f"Show or hide the {title} panel")
            v.addAction(a)
        v.addSeparator()
        for tb in (self.time_toolbar, self.camera_toolbar):
            a = tb.toggleViewAction()
            a.setText(f"{tb.windowTitle()} toolbar")
            a.setToolTip(f"Show or hide the {tb.windowTitle()} toolbar")
            v.addAction(a)

    def _build_task_menus(self) -> None:
        """Sources, Listener, Audio and Time menus (every panel's action, with its keys
        from :data:`KEYS`) and View ▸ Go to (the keyboard focus to a panel or the view)."""
        bar = self.menuBar()
        before = self.help_menu.menuAction()

        def menu(title: str, entries: list[Any]) -> QtWidgets.QMenu:
            m = QtWidgets.QMenu(title, self)
            m.setToolTipsVisible(True)
            for e in entries:
                if e is None:
                    m.addSeparator()
                else:
                    m.addAction(e)
            bar.insertMenu(before, m)
            return m

        act = self._act
        self.sources_menu = menu(
            "&Sources",
            [
                act("&Detect", "detect", tip="Detect the sources at every time step"),
                act(
                    "Describe in &words",
                    "describe",
                    tip="Put the sources into words (the Describe panel)",
                ),
                act(
                    "&Save description…",
                    "_ask_save_description",
                    tip="Save the description as text, CSV or JSON",
                ),
            ],
        )
        self.listener_menu = menu(
            "&Listener",
            [
                act("&Record", "start_recording", tip="Record the camera as the listener path"),
                act("&Stop recording", "stop_recording"),
                act("&Clear path", "clear_path", tip="Forget the listener path"),
                None,
                act("Save path &CSV…", "_ask_save_path", tip="Save the listener path as CSV"),
                act("&Load path CSV…", "_ask_load_path", tip="Load a listener path from CSV"),
            ],
        )
        self.audio_menu = menu(
            "&Audio",
            [
                act(
                    "&Render to file…",
                    "_ask_render",
                    tip="Render the sound heard along the listener path to a file",
                ),
                act("&Play the last render", "play_audio"),
                act("S&top playing", "stop_audio"),
                None,
                act("Listen &live", "listen_live", tip="Hear the data live: the camera listens"),
                act("Stop live &listening", "stop_live"),
                act(
                    "Save &heard…",
                    "_ask_save_heard",
                    tip="Save what live listening played (path CSV and WAV)",
                ),
            ],
        )
        play = act("&Play / pause", "toggle_playing", tip="Step through time at the time scale")
        self.time_menu = menu(
            "&Time",
            [
                self.time_actions["first_step"],
                self.time_actions["previous_step"],
                play,
                self.time_actions["next_step"],
                self.time_actions["last_step"],
            ],
        )
        go = self.view_menu.addMenu("&Go to")
        go.setToolTipsVisible(True)
        go.addAction(act("&3-D view", "focus_view", tip="Keyboard focus to the 3-D view"))
        for title in PANEL_ORDER:
            go.addAction(
                act(
                    f"{title} panel",
                    "focus_panel",
                    title,
                    tip=f"Keyboard focus to the {title} panel",
                )
            )
        self.go_menu = go

    def _build_access(self) -> None:
        """Accessible names on every control and the Tab order: the 3-D view, the
        panels of :data:`PANEL_ORDER` (each top down), the toolbars, the Cancel button
        (:mod:`auralize.viewer.access`)."""
        view = self.plotter.interactor
        view.setAccessibleName("3-D view (the camera is the listener)")
        view.setAccessibleDescription(KEY_MAP_TEXT)
        view.setFocusPolicy(QtCore.Qt.FocusPolicy.StrongFocus)
        for name, a in self.view_actions.items():
            w = self.camera_toolbar.widgetForAction(a)
            if w is not None:
                w.setAccessibleName(f"View direction {name.replace('-', '−')}")
        from auralize.viewer.access import actionable

        chain: list[QtWidgets.QWidget] = [view]
        for title in PANEL_ORDER:
            chain += actionable(self.docks[title].widget())
        for tb in (self.camera_toolbar, self.time_toolbar):
            chain += actionable(tb)
        chain.append(self.cancel_btn)
        set_focus_chain(chain)
        name_widgets(self)

    def focus_view(self) -> None:
        """View ▸ Go to ▸ 3-D view: the keyboard to the view (its keys fly, look and step)."""
        self.plotter.interactor.setFocus(QtCore.Qt.FocusReason.ShortcutFocusReason)

    def focus_panel(self, title: str) -> QtWidgets.QWidget | None:
        """View ▸ Go to ▸ a panel: show it and give the keyboard to its first control."""
        from auralize.viewer.access import actionable, takes_focus

        if title not in self.docks:
            raise ParameterError(f"no panel {title!r}; the panels are {', '.join(self.docks)}")
        dock = self.docks[title]
        dock.show()
        dock.raise_()
        for w in actionable(dock.widget()):
            if takes_focus(w) and w.isEnabled() and w.isVisible():
                w.setFocus(QtCore.Qt.FocusReason.ShortcutFocusReason)
                return w
        return None

    def toggle_playing(self) -> None:
        """Time ▸ Play / pause (the toolbar's Play button)."""
        self.set_playing(not self._anim_timer.isActive())

    def listen_live(self) -> Any:
        """Audio ▸ Listen live (the Live listening panel's button)."""
        return self.start_live(wait=False)

    def _ask_render(self) -> None:
        self._ask_file("save", "Audio (*.wav *.flac)", self.render_audio)

    def _ask_save_path(self) -> None:
        self._ask_file("save", "CSV (*.csv)", self.save_path)

    def _ask_load_path(self) -> None:
        self._ask_file("open", "CSV (*.csv)", self.load_path)

    def _ask_save_heard(self) -> None:
        self._ask_file("save", "CSV (*.csv)", self.save_heard)

    def _ask_save_description(self) -> None:
        self._ask_file("save", "Text (*.txt);;CSV (*.csv);;JSON (*.json)", self.save_description)

    def _ask_save_session(self) -> None:
        self._ask_file("save", "Sessions (*.json)", self.save_session)

    def save_session_current(self) -> Path | None:
        """File ▸ Save session: to the session's file, or ask for one the first time."""
        if self.session_file is None:
            self._ask_save_session()
            return self.session_file
        self.save_session(self.session_file)
        return self.session_file

    def _build_toolbar(self) -> None:
        sp = QtWidgets.QStyle.StandardPixmap
        cam = self.camera_toolbar = self.addToolBar("Camera")
        cam.setObjectName("camera")
        self.reset_camera_action = self._act(
            "Reset Camera",
            "reset_camera",
            icon=sp.SP_BrowserReload,
            tip="Reset Camera: frame the data, keeping the view direction",
        )
        cam.addAction(self.reset_camera_action)
        self.view_actions: dict[str, QtGui.QAction] = {}
        for name in STANDARD_VIEWS:
            label = name.replace("-", "−")
            a = self._act(label, "look", name, tip=f"Set view direction to {label}")
            self.view_actions[name] = a
            cam.addAction(a)
        tb = self.time_toolbar = self.addToolBar("Time")
        tb.setObjectName("time")
        self.time_actions: dict[str, QtGui.QAction] = {}
        for action, icon, text in (
            ("first_step", sp.SP_MediaSkipBackward, "First frame"),
            ("previous_step", sp.SP_MediaSeekBackward, "Previous frame"),
        ):
            self.time_actions[action] = a = self._act(text, action, icon=icon)
            tb.addAction(a)
        self.play_btn = QtWidgets.QPushButton("Play")
        self.play_btn.setCheckable(True)
        self.play_btn.setToolTip(
            f"Play / pause: step through time at the time scale "
            f"({key_text(binding('toggle_playing'))})"
        )
        self.play_btn.setAccessibleName("Play or pause the time steps")
        self.play_btn.toggled.connect(self.set_playing)
        tb.addWidget(self.play_btn)
        for action, icon, text in (
            ("next_step", sp.SP_MediaSeekForward, "Next frame"),
            ("last_step", sp.SP_MediaSkipForward, "Last frame"),
        ):
            self.time_actions[action] = a = self._act(text, action, icon=icon)
            tb.addAction(a)
        self.slider = QtWidgets.QSlider(QtCore.Qt.Orientation.Horizontal)
        self.slider.setMinimumWidth(300)
        self.slider.setToolTip(
            f"Time step (first / previous / next / last frame: "
            f"{', '.join(key_text(binding(a)) for a in self.time_actions)})"
        )
        self.slider.setAccessibleName("Time step")
        self.slider.valueChanged.connect(self._on_slider)
        tb.addWidget(self.slider)
        self.step_label = QtWidgets.QLabel("no data")
        tb.addWidget(self.step_label)

    def _qt_button_tips(self) -> None:
        """Tooltips for the buttons Qt makes itself (dock title bars, overflow arrows)."""
        tips = {
            "qt_dockwidget_closebutton": "hide this panel (View menu shows it again)",
            "qt_dockwidget_floatbutton": "float this panel in its own window, or dock it again",
            "qt_toolbar_ext_button": "more of this toolbar",
            "qt_menubar_ext_button": "more menus",
        }
        for b in self.findChildren(QtWidgets.QAbstractButton):
            if not b.toolTip() and b.objectName() in tips:
                b.setToolTip(tips[b.objectName()])

    def _dock(
        self,
        title: str,
        widget: QtWidgets.QWidget,
        area: QtCore.Qt.DockWidgetArea = QtCore.Qt.DockWidgetArea.LeftDockWidgetArea,
    ) -> QtWidgets.QDockWidget:
        d = QtWidgets.QDockWidget(title, self)
        d.setObjectName(title)
        d.setWidget(widget)
        self.addDockWidget(area, d)
        self.docks[title] = d
        return d

    def _build_panels(self) -> None:
        self.docks: dict[str, QtWidgets.QDockWidget] = {}
        self._build_data_panel()
        self._build_sources_panel()
        self._build_listener_panel()
        self._build_describe_panel()
        self._build_audio_panel()
        self._build_live_panel()
        self._build_overlays_panel()

    def _build_data_panel(self) -> None:
        """The Data panel."""
        w = QtWidgets.QWidget()
        f = _form(w)
        self.open_btn = QtWidgets.QPushButton("Open…")
        self.open_btn.setToolTip("Open a data file (File ▸ Open built-in dataset has examples)")
        self.open_btn.clicked.connect(self._ask_open)
        f.addRow(self.open_btn)
        self.info = QtWidgets.QLabel("no data")
        self.info.setWordWrap(True)
        _readable(self.info, "Data information")
        f.addRow(self.info)
        self.field_box = QtWidgets.QComboBox()
        self.field_box.setToolTip("the field shown (vector fields: their magnitude)")
        self.field_box.activated.connect(
            lambda _i: self._guard(self.set_field, self.field_box.currentText())
        )
        f.addRow("field", self.field_box)
        self.rep_box = QtWidgets.QComboBox()
        self.rep_box.addItems(list(REPRESENTATIONS))
        self.rep_box.setToolTip(
            "how the field is drawn: volume rendering, three orthogonal "
            "slices, a contour, arrows of a vector field, or nothing"
        )
        self.rep_box.activated.connect(
            lambda _i: self._guard(self.scene.set_representation, self.rep_box.currentText())
        )
        f.addRow("show as", self.rep_box)
        self.cmap_box = QtWidgets.QComboBox()
        self.cmap_box.addItems(list(CMAPS))
        self.cmap_box.setToolTip("colour map of the field")
        self.cmap_box.activated.connect(
            lambda _i: self._guard(self.scene.set_colormap, self.cmap_box.currentText())
        )
        f.addRow("colour map", self.cmap_box)
        self.opacity = QtWidgets.QDoubleSpinBox()
        self.opacity.setRange(0, 1)
        self.opacity.setSingleStep(0.05)
        self.opacity.setValue(self.scene.opacity)
        self.opacity.setToolTip("overall opacity of the field (0 transparent, 1 opaque)")
        self.opacity.valueChanged.connect(lambda v: self._guard(self.scene.set_colormap, None, v))
        f.addRow("opacity", self.opacity)
        self.mapping_box = QtWidgets.QComboBox()
        self.mapping_box.addItems(list(MAPPINGS))
        self.mapping_box.setToolTip(
            "acoustic mapping: how field values become density and "
            "particle velocity (auto chooses from the fields)"
        )
        self.mapping_box.activated.connect(
            lambda _i: self._guard(self.set_mapping, self.mapping_box.currentText())
        )
        f.addRow("mapping", self.mapping_box)
        self._dock("Data", w)

    def _build_sources_panel(self) -> None:
        """The Sources panel."""
        w = QtWidgets.QWidget()
        f = _form(w)
        self.th_edits: dict[str, QtWidgets.QLineEdit] = {}
        self.type_checks: dict[str, QtWidgets.QCheckBox] = {}
        self.count_labels: dict[str, QtWidgets.QLabel] = {}
        for kind, d in zip(TYPES, DEFAULTS.thresholds, strict=True):
            e = QtWidgets.QLineEdit(d)
            e.setToolTip(
                f"{kind} detection threshold: an absolute strength, N% of the peak, or auto"
            )
            self.th_edits[kind] = e
            f.addRow(f"{kind} threshold", e)
        self.heard_box = QtWidgets.QComboBox()
        self.heard_box.addItems(["whole field", "detected"])
        self.heard_box.setToolTip(
            "what is heard: the whole field (every point, no threshold: Lighthill's stress and "
            "the continuity residual) or the detected sources drawn here (paper 003)"
        )
        self.heard_box.activated.connect(lambda _i: self._guard(self._heard_changed))
        f.addRow("heard", self.heard_box)
        self.hear_checks: dict[str, QtWidgets.QCheckBox] = {}
        for kind in TYPES:
            row = QtWidgets.QHBoxLayout()
            cb = QtWidgets.QCheckBox(kind)
            cb.setChecked(True)
            r, g, bl = TYPE_COLORS[kind]
            cb.setStyleSheet(f"color: rgb({r},{g},{bl}); font-weight: bold")
            cb.setToolTip(f"draw the {kind}s")
            cb.setAccessibleName(f"Draw the {kind}s")
            cb.toggled.connect(lambda on, k=kind: self._guard(self.scene.set_type_visible, k, on))
            self.type_checks[kind] = cb
            lab = QtWidgets.QLabel("–")
            lab.setToolTip(f"{kind} source points at this step")
            lab.setAccessibleName(f"{kind} source points at this step")
            self.count_labels[kind] = lab
            hear = QtWidgets.QCheckBox("heard")
            hear.setChecked(True)
            hear.setToolTip(f"hear the {kind} term (mute it by unticking)")
            hear.setAccessibleName(f"Hear the {kind}s")
            hear.toggled.connect(lambda _on: self._guard(self._heard_changed))
            self.hear_checks[kind] = hear
            row.addWidget(cb)
            row.addWidget(lab)
            row.addWidget(hear)
            f.addRow(row)
        self._sync_hear_checks()
        self.detect_btn = QtWidgets.QPushButton("Detect")
        self.detect_btn.setToolTip(
            "detect the sound sources at every time step (in the "
            "background, the current step first)"
        )
        self.detect_btn.setAccessibleName("Detect the sources")
        self.detect_btn.clicked.connect(lambda: (self._guard(self.detect), self._focus_view()))
        f.addRow(self.detect_btn)
        self.detect_note = QtWidgets.QLabel("sources are detected when you ask (Detect)")
        self.detect_note.setWordWrap(True)
        _readable(self.detect_note, "Detection status")
        f.addRow(self.detect_note)
        self._dock("Sources", w)

    def _build_listener_panel(self) -> None:
        """The Listener panel."""
        w = QtWidgets.QWidget()
        f = _form(w)
        self.rate_spin = QtWidgets.QDoubleSpinBox()
        self.rate_spin.setRange(0.5, 60)
        self.rate_spin.setValue(DEFAULT_RATE_HZ)
        self.rate_spin.setSuffix(" Hz")
        self.rate_spin.setToolTip("how often the camera is captured while recording")
        f.addRow("capture rate", self.rate_spin)
        row = QtWidgets.QHBoxLayout()
        self.rec_btn = QtWidgets.QPushButton("Record")
        self.rec_btn.clicked.connect(
            lambda: (self._guard(self.start_recording), self._focus_view())
        )
        self.stop_btn = QtWidgets.QPushButton("Stop")
        self.stop_btn.clicked.connect(lambda: self._guard(self.stop_recording))
        self.clear_btn = QtWidgets.QPushButton("Clear")
        self.clear_btn.clicked.connect(lambda: self._guard(self.clear_path))
        self.rec_btn.setToolTip(
            "record the camera as the listener path (fly with the keys "
            "or the mouse); autosaved as it goes"
        )
        self.stop_btn.setToolTip("stop recording")
        self.clear_btn.setToolTip("forget the listener path")
        self.rec_btn.setAccessibleName("Record the listener path")
        self.stop_btn.setAccessibleName("Stop recording")
        self.clear_btn.setAccessibleName("Clear the listener path")
        for b in (self.rec_btn, self.stop_btn, self.clear_btn):
            row.addWidget(b)
        f.addRow(row)
        row = QtWidgets.QHBoxLayout()
        b = QtWidgets.QPushButton("Save CSV…")
        b.setToolTip("save the listener path as CSV (t,x,y,z,fx,fy,fz,ux,uy,uz)")
        b.setAccessibleName("Save the listener path as CSV")
        b.clicked.connect(self._ask_save_path)
        row.addWidget(b)
        b = QtWidgets.QPushButton("Load CSV…")
        b.setToolTip("load a listener path from CSV")
        b.setAccessibleName("Load a listener path from CSV")
        b.clicked.connect(self._ask_load_path)
        row.addWidget(b)
        f.addRow(row)
        self.path_label = QtWidgets.QLabel("no path")
        self.path_label.setWordWrap(True)
        _readable(self.path_label, "Listener path status")
        f.addRow(self.path_label)
        self.key_map = QtWidgets.QLabel(KEY_MAP_TEXT)
        self.key_map.setToolTip("Help ▸ Keys lists every key")
        self.key_map.setWordWrap(True)
        f.addRow(self.key_map)
        self._dock("Listener", w)

    def _build_describe_panel(self) -> None:
        """The Describe panel."""
        self.describe_panel = DescribePanel()
        self.describe_panel.describe_btn.clicked.connect(lambda: self._guard(self.describe))
        self.describe_panel.save_btn.clicked.connect(self._ask_save_description)
        self._dock("Describe", self.describe_panel, QtCore.Qt.DockWidgetArea.BottomDockWidgetArea)

    def _build_audio_panel(self) -> None:
        """The Audio panel."""
        w = QtWidgets.QWidget()
        f = _form(w)
        self.layout_box = QtWidgets.QComboBox()
        self.layout_box.addItems([*LAYOUT_NAMES, CUSTOM_LAYOUT])
        self.layout_box.setToolTip(
            "loudspeaker layout (or binaural / Ambisonics) of renders "
            "and live listening: the layouts of auralize render "
            "--layout, or a custom layout JSON file"
        )
        self.layout_box.setCurrentText(self.audio["layout"])
        self.layout_box.textActivated.connect(lambda t: self._guard(self._on_layout, t))
        f.addRow("layout", self.layout_box)
        self.device_box = QtWidgets.QComboBox()
        self.device_box.addItem("default")
        self.device_box.setToolTip("sound device for Play and live listening")
        self.device_box.addItems([str(d) for d in _devices()])
        self.device_box.currentTextChanged.connect(
            lambda t: self.audio.__setitem__("device", None if t == "default" else t)
        )
        f.addRow("device", self.device_box)
        self.ts_spin = QtWidgets.QDoubleSpinBox()
        self.ts_spin.setRange(0.0, 1e6)
        self.ts_spin.setDecimals(3)
        self.ts_spin.setSpecialValueText("auto")  # shown at the minimum, 0
        self.ts_spin.setValue(0.0 if DEFAULTS.time_scale == "auto" else float(DEFAULTS.time_scale))
        self.ts_spin.setToolTip(
            "time scale: playback seconds per data second; auto (as "
            "auralize render): the data's sound plays in the listener "
            "path's duration (10 s without a path)"
        )
        self.ts_spin.valueChanged.connect(self._on_time_scale)
        f.addRow("time scale", self.ts_spin)
        self.timbre_box = QtWidgets.QComboBox()
        self.timbre_box.addItems(list(TIMBRE_CHOICES))
        self.timbre_box.setCurrentText(DEFAULTS.timbre)
        self.timbre_box.setToolTip(
            "how the sources sound in rendered files (as auralize render "
            "--timbre; auto: physical when most of the sound is "
            "audible, else extended); live listening is physical"
        )
        self.timbre_box.currentTextChanged.connect(lambda t: self.audio.__setitem__("timbre", t))
        f.addRow("timbre", self.timbre_box)
        row = QtWidgets.QHBoxLayout()
        b = QtWidgets.QPushButton("Render to file…")
        b.setToolTip("render the sound heard along the listener path to a WAV/FLAC file")
        b.setAccessibleName("Render to a file")
        b.clicked.connect(self._ask_render)
        row.addWidget(b)
        b = QtWidgets.QPushButton("Play")
        b.setToolTip("play the last render on the sound device")
        b.setAccessibleName("Play the last render")
        b.clicked.connect(lambda: self._guard(self.play_audio))
        row.addWidget(b)
        b = QtWidgets.QPushButton("Stop")
        b.setToolTip("stop playing")
        b.setAccessibleName("Stop playing")
        b.clicked.connect(lambda: self._guard(self.stop_audio))
        row.addWidget(b)
        f.addRow(row)
        self.gain_spin = QtWidgets.QDoubleSpinBox()
        self.gain_spin.setRange(-60, 40)
        self.gain_spin.setSingleStep(1)
        self.gain_spin.setSuffix(" dB")
        self.gain_spin.setToolTip(
            "gain of Play and live listening; a limiter keeps every sample within full scale"
        )
        self.gain_spin.valueChanged.connect(lambda v: self._guard(self.set_gain_db, v))
        f.addRow("gain", self.gain_spin)
        self.meter = QtWidgets.QProgressBar()
        self.meter.setRange(-60, 0)
        self.meter.setValue(-60)
        self.meter.setFormat("level: –")
        self.meter.setToolTip("peak level of what is playing (dBFS) and the limiter's reduction")
        f.addRow("level", self.meter)
        from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
        from matplotlib.figure import Figure

        self.figure = Figure(figsize=(4, 3), layout="constrained")
        self.canvas = FigureCanvasQTAgg(self.figure)
        self.canvas.setMinimumHeight(220)
        # a picture with no keys of its own: Tab passes it by; its name says what it shows
        self.canvas.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        self.canvas.setAccessibleName("Waveform and spectrogram of the last render")
        f.addRow(self.canvas)
        self._cursors: list[Any] = []
        self._dock("Audio", w, QtCore.Qt.DockWidgetArea.RightDockWidgetArea)

    def _build_live_panel(self) -> None:
        """The Live listening panel."""
        w = QtWidgets.QWidget()
        f = _form(w)
        self.block_spin = QtWidgets.QSpinBox()
        self.block_spin.setRange(256, 16384)
        self.block_spin.setValue(2048)
        self.block_spin.setToolTip(
            "samples synthesized per block in live listening (larger: steadier, more latency)"
        )
        f.addRow("block (samples)", self.block_spin)
        self.live_file = QtWidgets.QLineEdit()
        self.live_file.setPlaceholderText("device (or a WAV file to write instead)")
        self.live_file.setToolTip("empty: the sound device; a WAV file name: write there instead")
        f.addRow("output", self.live_file)
        row = QtWidgets.QHBoxLayout()
        self.live_btn = QtWidgets.QPushButton("Listen live")
        self.live_btn.clicked.connect(lambda: self._guard(lambda: self.start_live(wait=False)))
        self.live_btn.setToolTip("hear the data live: the listener follows the camera")
        row.addWidget(self.live_btn)
        b = QtWidgets.QPushButton("Stop")
        b.setToolTip("stop live listening")
        b.setAccessibleName("Stop live listening")
        b.clicked.connect(lambda: self._guard(self.stop_live))
        row.addWidget(b)
        b = QtWidgets.QPushButton("Save heard…")
        b.setToolTip("save what live listening played: the path CSV and a WAV beside it")
        b.setAccessibleName("Save what live listening played")
        b.clicked.connect(self._ask_save_heard)
        row.addWidget(b)
        f.addRow(row)
        self.live_label = QtWidgets.QLabel("off")
        self.live_label.setWordWrap(True)
        _readable(self.live_label, "Live listening status")
        f.addRow(self.live_label)
        self._dock("Live listening", w, QtCore.Qt.DockWidgetArea.RightDockWidgetArea)

    def _build_overlays_panel(self) -> None:
        """The Overlays panel."""
        w = QtWidgets.QWidget()
        v = QtWidgets.QVBoxLayout(w)
        self.overlay_checks: dict[str, QtWidgets.QCheckBox] = {}
        from auralize.plugins import SoundModel, registry

        for name, cls in registry().items():
            if cls.overlay is SoundModel.overlay:  # the plugin offers no overlay
                continue
            cb = QtWidgets.QCheckBox(f"{name}: {_short(cls.description)}")
            cb.setToolTip(
                f"show the {name} model's overlay (and hear its sound): {cls.description}"
            )
            cb.setAccessibleName(f"Show the {name} overlay")
            cb.toggled.connect(lambda on, n=name: self._toggle_overlay(n, on))
            self.overlay_checks[name] = cb
            v.addWidget(cb)
        if not self.overlay_checks:
            v.addWidget(QtWidgets.QLabel("no sound-model plugin offers an overlay"))
        self.overlay_note = QtWidgets.QLabel("")
        self.overlay_note.setWordWrap(True)
        v.addWidget(self.overlay_note)
        v.addStretch(1)
        scroll = QtWidgets.QScrollArea()  # a long note scrolls rather than being cut off
        scroll.setWidgetResizable(True)
        scroll.setFrameShape(QtWidgets.QFrame.Shape.NoFrame)
        scroll.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)  # Tab goes to its boxes
        scroll.setAccessibleName("Overlays")
        scroll.setWidget(w)
        self._dock("Overlays", scroll, QtCore.Qt.DockWidgetArea.RightDockWidgetArea)

    def _build_status(self) -> None:
        sb = self.statusBar()
        self.progress = QtWidgets.QProgressBar()
        self.progress.setMaximumWidth(240)
        self.progress.hide()
        self.cancel_btn = QtWidgets.QPushButton("Cancel")
        self.cancel_btn.setToolTip("cancel the work in progress")
        self.cancel_btn.setAccessibleName("Cancel the work in progress")
        self.cancel_btn.hide()
        self.cancel_btn.clicked.connect(self.cancel_task)
        self.camera_label = QtWidgets.QLabel("")
        sb.addPermanentWidget(self.camera_label)
        sb.addPermanentWidget(self.progress)
        sb.addPermanentWidget(self.cancel_btn)

    def _focus_view(self) -> None:
        """Give the keyboard to the 3-D view (after a button click)."""
        self.plotter.interactor.setFocus()

    def _update_readouts(self) -> None:
        """Camera position in the status bar; the level meter of what is playing."""
        if self.volume is not None:
            pos, fwd, _ = camera_pose(self.plotter.camera)
            self.camera_label.setText(
                f"camera ({pos[0]:.3g}, {pos[1]:.3g}, {pos[2]:.3g}) m, looking "
                f"({fwd[0]:+.2f}, {fwd[1]:+.2f}, {fwd[2]:+.2f})"
            )
        lim = None
        if self.player is not None and self.player.running:
            lim = self.player.limiter
        elif self.playback is not None and self.playback.running:
            lim = self.playback.limiter
        if lim is None:
            self.meter.setValue(-60)
            self.meter.setFormat("level: –")
            if self.playback is not None and not self.playback.running:
                pb, self.playback = self.playback, None
                if pb.error is not None:
                    self.show_error(pb.error)
            return
        peak = lim.peak_dbfs
        self.meter.setValue(int(max(-60.0, min(0.0, peak))))
        red = f", limiting {lim.reduction_db:.1f} dB" if lim.reduction_db < -0.05 else ""
        self.meter.setFormat(f"peak {peak:.1f} dBFS{red}" if peak > -200 else "silence")
        if peak <= -200 and self.player is not None and self.player.running:
            why = self.player.engine.why_silent()  # silent live listening says why in words
            if why:
                self.live_label.setText(why)

    # ============================================================== errors
    def show_error(self, exc: BaseException) -> None:
        """Message box for an error; the session stays as it was."""
        if isinstance(exc, Cancelled):
            self.statusBar().showMessage(str(exc), 5000)
            return
        msg = (
            str(exc)
            if isinstance(exc, AuralizeError | OSError)
            else (
                f"{type(exc).__name__}: {exc}\n\n{''.join(traceback.format_exception(exc))[-1500:]}"
            )
        )
        QtWidgets.QMessageBox.critical(self, "auralize", msg)

    def _guard(self, fn: Callable[..., Any], *args: Any) -> Any:
        try:
            return fn(*args)
        except Exception as exc:
            self.show_error(exc)
            return None

    def _ask_file(self, mode: str, filt: str, action: Callable[[str], Any]) -> None:
        if mode == "save":
            name, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save", "", filt)
        else:
            name, _ = QtWidgets.QFileDialog.getOpenFileName(self, "Open", "", filt)
        if name:
            self._guard(action, name)

    def _ask_open(self) -> None:
        """File ▸ Open: every kind the readers know (built-in datasets are in File ▸ Open
        built-in dataset)."""
        from auralize.io import READ_SUFFIXES

        kinds = " ".join(f"*{x}" for x in READ_SUFFIXES)
        self._ask_file("open", f"Volumes ({kinds});;All files (*)", self.open_data)

    # =============================================================== tasks
    def run_task(
        self,
        name: str,
        fn: Callable[[Callable[[int, int], bool]], Any],
        done: Callable[[Any], None],
    ) -> Task:
        """Run ``fn`` in a :class:`Task` with the progress bar; ``done(result)`` on success."""
        self._check_idle()
        if self.task is not None and self.task.isRunning():
            self.task.wait(5_000)  # it has reported its result; its thread is ending
        t = Task(name, fn, self)
        self.task = t
        self.progress.setRange(0, 0)
        self.progress.setFormat(f"{name} %v/%m")
        self.progress.show()
        self.cancel_btn.show()

        def prog(d: int, n: int) -> None:
            self.progress.setRange(0, n)
            self.progress.setValue(d)

        def finish() -> None:
            # its result is in: not busy any more, though the thread may take a moment
            # to end after emitting it
            t.reported = True
            self.progress.hide()
            self.cancel_btn.hide()
            self._refresh_enabled()
            self._overlay_progress()

        def ok(result: Any) -> None:
            finish()
            self._guard(done, result)

        def bad(exc: BaseException) -> None:
            finish()
            self.show_error(exc)

        t.progressed.connect(prog)
        t.succeeded.connect(ok)
        t.failed.connect(bad)
        t.start()
        self._refresh_enabled()
        return t

    def _check_idle(self) -> None:
        if self.busy:
            assert self.task is not None
            raise ParameterError(f"busy with {self.task.name}; wait or cancel it first")

    def cancel_task(self) -> None:
        """The Cancel button: stop the running task and any overlay step being computed."""
        if self.task is not None:
            self.task.cancel()
        self._overlay_want.clear()
        for t in self._overlay_tasks.values():
            t.cancel()

    @property
    def busy(self) -> bool:
        t = self.task
        return t is not None and t.isRunning() and not t.reported

    def _refresh_enabled(self) -> None:
        has = self.volume is not None
        for wdg in (self.detect_btn, self.rec_btn, self.live_btn, self.field_box):
            wdg.setEnabled(has and not self.busy)
        self.open_btn.setEnabled(not self.busy)
        if has and self.volume.n_steps < 2:
            self.detect_btn.setEnabled(False)
            self.detect_note.setText(
                "one time step: the data is shown, but source detection needs at least two "
                "steps (strengths are time derivatives)"
            )
        elif has and self.series is None:
            self.detect_note.setText("sources are detected when you ask (Detect)")

    # ================================================================ data
    def open_data(  # noqa: PLR0913 (keyword-only options)
        self,
        spec: str | Path,
        *,
        size: int | None = None,
        steps: int | None = None,
        seed: int = 0,
        fields: dict[str, str] | None = None,
        resolution: int | None = None,
        field: str | None = None,
        then: Callable[[], None] | None = None,
        time_dim: str | None = None,
        axis_scale: Any = None,
        box: Any = None,
        curvilinear: str | None = None,
        keep_path: bool | None = None,
    ) -> Task:
        """Open a file or ``dataset:NAME`` in the background (frames are read ahead) and show
        it; no detection runs (see :meth:`detect`).  ``fields``, ``resolution``,
        ``time_dim``, ``axis_scale``, ``box`` and ``curvilinear`` are the readers'
        options (``--field NAME=/DATASET``, ``--resolution``, ``--time-dim``, ...,
        ``--resample``), ``field`` the field
        to display.  Reader warnings (e.g. resampling) are shown in the Data panel.

        The camera frames the new data.  A listener path recorded (or loaded) for
        the data on screen is discarded unless ``keep_path`` is True; None asks
        (:meth:`ask_keep_path`, Discard by default) when there is one."""
        from auralize.scene.session import load_data

        self._check_idle()
        if keep_path is None:
            keep_path = self.path is not None and self.ask_keep_path()

        d = data_spec(
            str(spec),
            size=size,
            steps=steps,
            seed=seed,
            fields=fields,
            resolution=resolution,
            time_dim=time_dim,
            axis_scale=axis_scale,
            box=box,
            curvilinear=curvilinear,
        )

        def work(progress: Callable[[int, int], bool]) -> Any:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                vol = load_data(d)
            notes = list(dict.fromkeys(str(w.message) for w in caught))
            from auralize.scene.view import default_field

            if field is not None:
                vol._get(field)  # FieldError names the fields there are
            name = field or default_field(vol)
            frames = []
            for n in range(vol.n_steps):  # read ahead: the slider never waits for I/O
                a = vol.frame(name, n)
                frames.append(np.linalg.norm(a, axis=-1) if a.ndim == 4 else a)
                if not progress(n + 1, vol.n_steps):
                    raise Cancelled(f"opening {spec} cancelled")
            return vol, name, frames, notes, _sound_wave_hint(vol)

        def done(res: Any) -> None:
            vol, name, frames, notes, hint = res
            self.load_notes = notes
            self.sound_wave_hint = hint
            if not keep_path:
                self._drop_path()
            self._set_volume(vol, d, name, frames)
            if then is not None:
                then()

        return self.run_task("open", work, done)

    def _set_volume(self, vol: Any, d: dict[str, Any], name: str, frames: list[Any]) -> None:
        self.stop_recording()
        self.stop_live()
        self.volume, self.data = vol, d
        self.detection, self.series = None, None
        self.scene.set_volume(vol, field=name, frames=frames)
        self._overlay_sounds.clear()
        self._overlay_unheard.clear()
        # the panels describe the data on screen only: what was said of the old data goes
        self.rendered = None
        self.plot_audio()
        self.detect_note.setText("sources are detected when you ask (Detect)")
        self.describe_panel.clear()
        self.overlay_note.setText(self.sound_wave_hint or "")
        self.live_label.setText("off")
        self.statusBar().clearMessage()
        if self.sound_wave_hint:
            self.statusBar().showMessage(self.sound_wave_hint)
        if self.scene.overlays:  # the overlays switched on are heard for the new data
            from auralize.plugins import get_model

            for overlay in list(self.scene.overlays):
                self._start_overlay_sound(overlay, get_model(overlay))
        self.field_box.clear()
        self.field_box.addItems(vol.field_names)
        self.field_box.setCurrentText(name)
        self.slider.blockSignals(True)
        self.slider.setRange(0, vol.n_steps - 1)
        self.slider.setValue(0)
        self.slider.blockSignals(False)
        b = vol.bounds
        name = vol.source if str(vol.source).startswith("dataset:") else Path(vol.source).name
        text = (
            f"{vol.source}\n{vol.dims[0]}×{vol.dims[1]}×{vol.dims[2]} points, spacing "
            f"{', '.join(f'{s:g}' for s in vol.spacing)} m\nx[{b[0]:g}, {b[1]:g}] "
            f"y[{b[2]:g}, {b[3]:g}] z[{b[4]:g}, {b[5]:g}] m\n{vol.n_steps} steps, "
            f"{vol.times[0]:g}–{vol.times[-1]:g} s"
            f"{'' if vol.physical_times else ' (no times in the file: frames at 30 Hz)'}\n"
            f"fields: {', '.join(vol.field_names)}"
        )
        # the panel shows the file's name and short notes; the tooltip has everything
        notes = [n.replace(f"{vol.source}: ", "") for n in self.load_notes]
        short = text.replace(str(vol.source), str(name), 1) + "".join(
            f"\nnote: {n if len(n) <= 60 else n[:58] + '…'}" for n in notes
        )
        self.info.setText(short)
        lines = short.count("\n") + 1 + sum(len(n) > 40 for n in notes)
        self.info.setMinimumHeight(lines * self.info.fontMetrics().lineSpacing() + 4)
        self.info.setToolTip(text + "".join(f"\nnote: {n}" for n in self.load_notes))
        self.scene.set_path(self.path, time_scale=self.time_scale_value(), render=False)
        self._update_step_label()
        self._refresh_enabled()
        self.plotter.render()

    def ask_keep_path(self) -> bool:
        """Ask whether the listener path of the data on screen is kept for the data being
        opened (Keep / Discard, Discard by default: its positions are in the old data's
        coordinates).  :attr:`keep_path_answer` (True / False), when set, answers
        without asking (scripts and tests)."""
        if self.keep_path_answer is not None:
            return bool(self.keep_path_answer)
        mb = QtWidgets.QMessageBox
        box = mb(
            mb.Icon.Question,
            "auralize",
            "Keep the listener path for the new data?",
            mb.StandardButton.Discard | mb.StandardButton.Yes,
            self,
        )
        keep = box.button(mb.StandardButton.Yes)
        keep.setText("Keep")
        box.setDefaultButton(mb.StandardButton.Discard)
        p = self.path
        box.setInformativeText(
            (
                f"The path ({p.n_captures} captures, {p.duration:.2f} s) was recorded for "
                f"{self.data.get('spec', 'the data on screen')}; its positions are in that "
                "data's coordinates."
                if p is not None
                else ""
            )
            + " Discard it (the default) or keep it for the new data."
        )
        box.exec()
        return box.clickedButton() is keep

    def _drop_path(self) -> None:
        """Forget the listener path (opening other data)."""
        self.stop_recording()
        self.recorder.clear()
        self.path = None
        self.scene.set_path(None, render=False)
        self._path_info()

    def set_field(self, name: str) -> None:
        if self.volume is None:
            raise ParameterError("open a data file first")
        self.scene.set_field(name)
        self.field_box.setCurrentText(name)

    def set_mapping(self, name: str) -> None:
        from auralize.sources.mapping import get_mapping

        if self.volume is not None and name != "auto":
            get_mapping(name).prepare(self.volume)  # FieldError if the fields are missing
        self.mapping = name
        self.mapping_box.setCurrentText(name)
        self.detection, self.series = None, None
        self.stop_live()
        self.scene.set_sources(None)
        self.plotter.render()

    # ============================================================= heard
    def heard_spec(self) -> str:
        """What the viewer's renders and live listening hear, for
        :func:`auralize.sources.field.parse_heard`: ``field`` or ``detected``,
        with the unticked types muted."""
        from auralize.sources.field import FIELD_TERMS

        mode = "detected" if self.heard_box.currentText() == "detected" else "field"
        every = TYPES if mode == "detected" else FIELD_TERMS
        on = [k for k in every if self.hear_checks[k].isChecked()]
        if not on:
            raise ParameterError("every source type is muted: tick at least one 'heard' box")
        return mode if len(on) == len(every) else f"{mode}:{','.join(on)}"

    def set_heard(self, spec: str) -> None:
        """Set what is heard (``field``, ``detected``, ``detected:dipole,quadrupole``, ...)."""
        from auralize.sources.field import parse_heard

        hd = parse_heard(spec)
        self.heard_box.setCurrentText("detected" if hd.mode == "detected" else "whole field")
        for k in TYPES:
            self.hear_checks[k].blockSignals(True)
            self.hear_checks[k].setChecked(k in hd.types)
            self.hear_checks[k].blockSignals(False)
        self._heard_changed()

    def _sync_hear_checks(self) -> None:
        """The whole field has no dipole term: its 'heard' box is off and disabled there."""
        field_mode = self.heard_box.currentText() != "detected"
        box = self.hear_checks["dipole"]
        box.setEnabled(not field_mode)
        box.setToolTip(
            "the whole field has no dipole term (forces would need the pressure)"
            if field_mode
            else "hear the dipole term (mute it by unticking)"
        )

    def _heard_changed(self) -> None:
        self._sync_hear_checks()
        self._heard = None
        self.audio["heard"] = self.heard_spec()
        self.stop_live()

    def heard_sound(self, path: Any = None) -> Any:
        """The :class:`auralize.pipeline.HeardSound` of the volume (cached until the data,
        mapping, thresholds, sources, the 'heard' choice or ``path`` change).

        With ``path`` (a render along the recorded path) the blocks of the whole
        field that the path comes near are heard as their points; live listening
        (no path: the camera goes anywhere) hears every block through its proxies."""
        key, hit, compute = self._heard_request(path)
        if hit is not None:
            return hit
        hs = compute()
        self._heard = (key, path, hs)
        return hs

    def _heard_request(self, path: Any = None) -> tuple[Any, Any, Callable[[], Any]]:
        """``(key, cached sound or None, compute)``: the widgets are read here (on the Qt
        thread); ``compute()`` touches none, so it may run in a worker."""
        from auralize.pipeline import heard_sound
        from auralize.sources.field import parse_heard

        if self.volume is None:
            raise ParameterError("open a data file first")
        spec = self.heard_spec()
        hd = parse_heard(spec)
        if hd.mode == "detected" and self.series is None:
            raise ParameterError(
                "detect the sources first (Sources panel), or hear the whole field"
            )
        th = self.read_thresholds()
        key = (
            spec,
            id(self.volume),
            self.mapping,
            tuple(sorted(self.mapping_fields.items())),
            repr(th.describe()),
            id(self.series) if hd.mode == "detected" else None,
        )
        hit = getattr(self, "_heard", None)
        if hit is not None and hit[0] == key and hit[1] is path:  # (the path held: its own)
            return key, hit[2], lambda: hit[2]
        vol, series, mapping, fields = (
            self.volume,
            self.series,
            self.mapping,
            dict(self.mapping_fields),
        )

        def compute() -> Any:
            return heard_sound(
                vol,
                heard=hd,
                series=series,
                thresholds=th,
                path=path,
                mapping=None if mapping == "auto" else mapping,
                **fields,
            )

        return key, None, compute

    # ============================================================= sources
    def read_thresholds(self) -> Thresholds:
        return Thresholds(*(self.th_edits[k].text().strip() for k in TYPES))

    def detect(self, then: Callable[[], None] | None = None) -> Task:
        """Detect sources at every step in the background (the current step first)."""
        if self.volume is None:
            raise ParameterError("open a data file first")
        th = self.read_thresholds()
        vol, mapping, step = self.volume, self.mapping, self.scene.step
        mfields = dict(self.mapping_fields)
        from auralize.sources.detection import require_steps

        require_steps(vol)  # one step: say why there is nothing to detect

        def work(progress: Callable[[int, int], bool]) -> Any:
            if not progress(0, vol.n_steps):
                raise Cancelled("detection cancelled")
            det = Detection(
                vol, mapping=None if mapping == "auto" else mapping, thresholds=th, **mfields
            )
            det.frame(step)
            return det, det.run(progress)

        def done(res: Any) -> None:
            self.detection, self.series = res
            self.thresholds = th
            if self.describe_panel.description is not None:
                self.describe_panel.clear(
                    "the sources were detected again: Describe "
                    "(Ctrl+Shift+D) to put them into words"
                )
            self.scene.set_sources(self.detection.get)
            self.detect_note.setText(
                f"detected (mapping {self.mapping}), thresholds "
                f"{', '.join(f'{k} {v}' for k, v in th.describe().items() if k in TYPES)}"
            )
            self._update_step_label()
            self.plotter.render()
            if then is not None:
                then()

        return self.run_task("detect", work, done)

    def describe(self, then: Callable[[], None] | None = None) -> Task:
        """Sources ▸ Describe in words: the detected sources (detected first if needed) and
        when the listener hears them, in the Describe panel (:mod:`auralize.describe`),
        on the clock of a render along the listener path (:meth:`playback_plan`)."""
        if self.volume is None:
            raise ParameterError("open a data file first")
        if self.series is None:
            return self.detect(then=lambda: self._guard(self.describe, then))
        from auralize.describe import describe

        vol, series, plan, heard = self.volume, self.series, self.playback_plan(), self.heard_spec()
        name = str(self.data.get("spec") or vol.source)

        def work(progress: Callable[[int, int], bool]) -> Any:
            if not progress(0, 1):
                raise Cancelled("description cancelled")
            return describe(vol, series=series, plan=plan, heard=heard, name=name)

        def done(d: Any) -> None:
            self.describe_panel.show_description(d, self.scene.step)
            dock = self.docks["Describe"]
            dock.show()
            dock.raise_()
            self.statusBar().showMessage(
                f"described: {len(d.events)} event(s) (the Describe panel)", 5000
            )
            if then is not None:
                then()

        return self.run_task("describe", work, done)

    def save_description(self, filename: str | Path) -> Path:
        """Save the Describe panel's description (text, or CSV / JSON by the suffix)."""
        d = self.describe_panel.description
        if d is None:
            raise ParameterError("nothing to save yet: Describe first (Ctrl+Shift+D)")
        from auralize.runtime.files import check_output_path

        check_output_path(filename)
        out = d.save(filename)
        self.statusBar().showMessage(f"description saved: {out}", 5000)
        return out

    # ================================================================ time
    def _on_slider(self, step: int) -> None:
        if self.volume is not None:
            self._guard(self.set_step, step)

    def set_step(self, step: int) -> float:
        """Show a time step; returns the redraw time in seconds."""
        el = self.scene.set_step(int(step))
        if self.slider.value() != step:
            self.slider.blockSignals(True)
            self.slider.setValue(int(step))
            self.slider.blockSignals(False)
        self._update_step_label()
        self._update_cursor()
        self.describe_panel.show_step(int(step))
        return el

    def _update_step_label(self) -> None:
        if self.volume is None:
            return
        n = self.scene.step
        self.step_label.setText(
            f"step {n}/{self.volume.n_steps - 1}  t={self.volume.times[n]:.4g} s"
        )
        counts = self.detection.counts(n) if self.detection is not None else None
        for k in TYPES:
            self.count_labels[k].setText("–" if counts is None else str(counts[k]))

    def set_playing(self, on: bool) -> None:
        if on and self.volume is not None:
            dt = np.diff(self.volume.times).mean() if self.volume.n_steps > 1 else 0.1
            self._anim_timer.start(max(int(1000 * dt * self.time_scale_value()), 15))
        else:
            self._anim_timer.stop()
        self.play_btn.blockSignals(True)
        self.play_btn.setChecked(on and self.volume is not None)
        self.play_btn.setText("Pause" if self._anim_timer.isActive() else "Play")
        self.play_btn.blockSignals(False)

    def _advance(self) -> None:
        if self.volume is None or (self.player is not None and self.player.running):
            return  # live listening drives the slider itself
        self._guard(self.set_step, (self.scene.step + 1) % self.volume.n_steps)

    def _on_layout(self, text: str) -> None:
        """A layout chosen in the Audio panel; "custom layout file…" asks for a JSON file."""
        if text == CUSTOM_LAYOUT:
            name, _ = QtWidgets.QFileDialog.getOpenFileName(
                self, "Custom layout", "", "Layout (*.json)"
            )
            if not name:
                self.layout_box.setCurrentText(str(self.audio["layout"]))
                return
            self.set_layout(name)
            return
        self.set_layout(text)

    def set_layout(self, layout: str | Path) -> None:
        """Set the output layout: a name of :data:`auralize.defaults.LAYOUT_NAMES` or a
        custom layout JSON file (checked now, as ``--layout FILE.json`` is)."""
        from auralize.spatial.layouts import get_layout

        text = str(layout)
        try:
            get_layout(text)  # a bad file fails here, with the reason
        finally:
            if self.layout_box.currentText() != str(self.audio["layout"]):
                self.layout_box.setCurrentText(str(self.audio["layout"]))
        if self.layout_box.findText(text) < 0:
            self.layout_box.insertItem(self.layout_box.count() - 1, text)
        self.layout_box.setCurrentText(text)
        self.audio["layout"] = text
        self.stop_live()

    def _on_time_scale(self, v: float) -> None:
        self.audio["time_scale"] = "auto" if v <= 0 else float(v)
        self.scene.time_scale = self.time_scale_value()

    def playback_plan(self) -> Any:
        """The plan of a render of the data on screen along the listener path (without a
        path: the default orbit), with the viewer's time scale
        (:func:`auralize.pipeline.plan_render`): its time scale places the cursor,
        paces Play and live listening."""
        from auralize.pipeline import plan_render

        if self.volume is None:
            raise ParameterError("open a data file first")
        key = (id(self.volume), id(self.path), self.audio["time_scale"])
        if self._plan_cache is not None and self._plan_cache[0] == key:
            return self._plan_cache[1]
        plan = plan_render(
            self.volume, None, path=self.path, clip=False, time_scale=self.audio["time_scale"]
        )
        self._plan_cache = (key, plan)
        return plan

    def time_scale_value(self) -> float:
        """Playback seconds per data second now (``auto`` resolved by :meth:`playback_plan`)."""
        ts = self.audio["time_scale"]
        if ts != "auto":
            return float(ts)
        if self.volume is None or self.volume.n_steps < 2:
            return 1.0
        return float(self.playback_plan().time_scale)

    def first_step(self) -> None:
        """First frame (ParaView's VCR control; stops Play)."""
        self._step_to(0)

    def previous_step(self) -> None:
        """Previous frame (stays at the first)."""
        self._step_to(self.scene.step - 1)

    def next_step(self) -> None:
        """Next frame (stays at the last)."""
        self._step_to(self.scene.step + 1)

    def last_step(self) -> None:
        """Last frame."""
        self._step_to(self.volume.n_steps - 1 if self.volume is not None else 0)

    def _step_to(self, step: int) -> None:
        if self.volume is None:
            return
        self.set_playing(False)
        self.set_step(int(np.clip(step, 0, self.volume.n_steps - 1)))

    # ============================================================== camera
    def reset_camera(self) -> None:
        """Reset Camera (ParaView's): frame the data (its bounding box, not a listener
        path far from it), keeping the view direction."""
        if self.volume is None:
            return
        self.scene.reset_camera()
        self.plotter.render()

    def look(self, direction: str) -> None:
        """One of the six standard views (ParaView's camera toolbar): ``"+X"`` looks along
        +X (from the −X side), ... ``"-Z"`` looks up; the data is framed."""
        if direction not in STANDARD_VIEWS:
            raise ParameterError(
                f"view direction must be one of {', '.join(STANDARD_VIEWS)}, got {direction!r}"
            )
        if self.volume is None:
            return
        self.scene.reset_camera(*STANDARD_VIEWS[direction])
        self.plotter.render()

    def save_screenshot(self, filename: str | Path | None = None) -> Path | None:
        """File ▸ Save Screenshot: the 3-D view as a PNG (asks for a file name unless
        ``filename`` is given; a name without a suffix gets ``.png``)."""
        from auralize.runtime.files import check_output_path

        if filename is None:
            name, _ = QtWidgets.QFileDialog.getSaveFileName(
                self, "Save Screenshot", "", "PNG image (*.png);;JPEG image (*.jpg *.jpeg)"
            )
            if not name:
                return None
            filename = name
        out = Path(filename).expanduser()
        if not out.suffix:
            out = out.with_suffix(".png")
        if out.suffix.lower() not in (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"):
            raise ParameterError(
                f"cannot save a screenshot as {out.suffix!r} ({out}); give a .png or .jpg file"
            )
        check_output_path(out)
        self.plotter.render()
        self.plotter.screenshot(str(out))
        self.statusBar().showMessage(f"screenshot saved: {out}", 5000)
        return out

    # ================================================================ help
    def show_keys(self) -> QtWidgets.QDialog:
        """Help ▸ Keys: every key binding (from :data:`KEYS`), in a window that stays open."""
        dlg = getattr(self, "keys_dialog", None)
        if dlg is None:
            dlg = self.keys_dialog = QtWidgets.QDialog(self)
            dlg.setWindowTitle("auralize — keys")
            lay = QtWidgets.QVBoxLayout(dlg)
            self.keys_view = QtWidgets.QTextBrowser()
            self.keys_view.setHtml(keys_html())
            lay.addWidget(self.keys_view)
            dlg.resize(520, 620)
        dlg.show()
        dlg.raise_()
        return dlg

    def docs_path(self) -> Path | None:
        """The README of the source tree (beside the ``docs/`` folder), if installed from
        a checkout."""
        import auralize

        root = Path(auralize.__file__).resolve().parents[1]
        readme = root / "README.md"
        return readme if readme.exists() else None

    def about_text(self) -> str:
        import auralize

        doc = self.docs_path()
        where = (
            f'<a href="{doc.as_uri()}">{doc}</a> and <a href="{(doc.parent / "docs").as_uri()}">'
            f"{doc.parent / 'docs'}</a>"
            if doc is not None
            else "README.md and docs/ in the source distribution"
        )
        return (
            f"<h3>auralize {auralize.__version__}</h3><p>Hear time-varying 3-D data: "
            f"sound sources found in a volume time series, heard along the path the "
            f"camera flies.</p><p>Documentation: {where}</p>"
            f"<p>Help ▸ Keys lists every key.</p>"
        )

    def show_about(self) -> QtWidgets.QMessageBox:
        """Help ▸ About: version and where the documentation is (a window that stays open)."""
        box = QtWidgets.QMessageBox(self)
        box.setWindowTitle("About auralize")
        box.setTextFormat(QtCore.Qt.TextFormat.RichText)
        box.setText(self.about_text())
        box.setWindowModality(QtCore.Qt.WindowModality.NonModal)
        box.show()
        self.about_box = box
        return box

    def open_docs(self) -> None:
        """Help ▸ Documentation: the README in the desktop's viewer."""
        doc = self.docs_path()
        if doc is None:
            raise ParameterError(
                "no README here (an installed package): see the project's "
                "README.md and docs/ in its source"
            )
        QtGui.QDesktopServices.openUrl(QtCore.QUrl.fromLocalFile(str(doc)))

    # ============================================================ listener
    def fly(self, forward: float = 0.0, turn: float = 0.0, rise: float = 0.0) -> None:
        """Move the camera like a flight: ``forward`` steps along the view, ``turn`` steps of
        10° to the left, ``rise`` steps up (a step is 2 % of the data's diagonal)."""
        cam = self.plotter.camera
        pos, fwd, up = camera_pose(cam)
        b = np.asarray(self.volume.bounds if self.volume is not None else (0, 1) * 3).reshape(3, 2)
        stepm = 0.02 * float(np.linalg.norm(b[:, 1] - b[:, 0]))
        if turn:
            a = np.deg2rad(10.0 * turn)
            right = np.cross(fwd, up)
            fwd = np.cos(a) * fwd - np.sin(a) * right
        pos = pos + stepm * (forward * fwd + rise * up)
        dist = max(
            float(np.linalg.norm(np.asarray(cam.focal_point) - np.asarray(cam.position))), stepm
        )
        cam.position = tuple(pos)
        cam.focal_point = tuple(pos + dist * fwd)
        cam.up = tuple(up)
        self.plotter.renderer.ResetCameraClippingRange()
        self.plotter.render()

    def start_recording(self, autosave: str | Path | None = None) -> Path:
        """Record the camera as the listener at the capture rate; returns the autosave file."""
        if self.volume is None:
            raise ParameterError("open a data file first")
        if self.recorder.recording:
            assert self.recorder.autosave is not None
            return self.recorder.autosave
        rate = float(self.rate_spin.value())
        if self.recorder.rows and self.recorder.rate_hz == rate:
            out = self.recorder.autosave
        else:
            self.recorder = PathRecorder(rate_hz=rate)
            out = None
        stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
        self.recorder.autosave = (
            Path(autosave) if autosave else (out or self.autosave_dir / f"recording-{stamp}.csv")
        )
        if not autosave and self.recorder.autosave.parent == self.autosave_dir:
            # the autosave folder is the viewer's own state folder (not an output
            # the user named), so the viewer creates it
            try:
                self.autosave_dir.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                raise OutputError(
                    f"cannot create the autosave folder {str(self.autosave_dir)!r}: "
                    f"{e.strerror or e}; give an autosave file in an existing folder"
                ) from None
        self.recorder.start()
        # the captures are taken by the recorder's clock thread (at the asked rate
        # whatever the window is drawing, e.g. while listening live) from the latest
        # camera pose this thread has seen; the timer only shows the path so far
        self._watch_camera()
        self.recorder.drive(lambda: self._cam_pose)
        self._shown_captures = -1
        self._show_recording()
        self._rec_timer.start(max(int(round(1000 / rate)), 1))
        self.rec_btn.setText("Recording…")
        return self.recorder.autosave

    def capture(self) -> None:
        """Take one capture of the camera now (besides the recorder's clock) and show it."""
        if not self.recorder.recording:
            return
        self._cam_pose = camera_pose(self.plotter.camera)
        self.recorder.capture(*self._cam_pose)
        self._show_recording()

    def _watch_camera(self) -> None:
        """Keep :attr:`_cam_pose` (the pose the capture clock and live listening use) up
        to date: a camera observer (installed once) refreshes it on every change."""
        cam = self.plotter.renderer.GetActiveCamera()
        self._cam_pose = camera_pose(self.plotter.camera)
        if self._cam_obs is not None and self._cam_obs[0] is cam:
            return
        self._unwatch_camera()
        self._cam_obs = (cam, cam.AddObserver("ModifiedEvent", self._on_camera))

    def _unwatch_camera(self) -> None:
        if self._cam_obs is not None:
            cam, tag = self._cam_obs
            cam.RemoveObserver(tag)
            self._cam_obs = None

    def _show_recording(self) -> None:
        """(The recording timer) draw the path recorded so far, once per new capture."""
        if not self.recorder.recording:
            return
        if self.recorder.drive_error is not None:
            err, self.recorder.drive_error = self.recorder.drive_error, None
            self.stop_recording()
            self.show_error(err)
            return
        # the camera replaced (a session loaded): watch the new one
        self._watch_camera()
        n = self.recorder.n_captures
        if n == self._shown_captures:
            return
        self._shown_captures = n
        self.path = self.recorder.path()
        self.scene.set_path(self.path, render=False)
        self.scene.listener = self._cam_pose
        self.path_label.setText(
            f"recording: {self.recorder.n_captures} captures, "
            f"{self.path.duration if self.path else 0:.1f} s, "
            f"{self.recorder.achieved_rate_hz():.1f} Hz achieved (asked {self.recorder.rate_hz:g})"
            f"\nautosave: {self.recorder.autosave}"
        )

    def stop_recording(self) -> ListenerPath | None:
        self._rec_timer.stop()
        if not self.recorder.recording:
            return self.path
        self.path = self.recorder.stop()
        if self.player is None or not self.player.running:
            self._unwatch_camera()
        self.scene.listener = None
        self.scene.set_path(self.path)
        self.rec_btn.setText("Record")
        self._path_info()
        return self.path

    def clear_path(self) -> None:
        self.stop_recording()
        self.recorder.clear()
        self.path = None
        self.scene.set_path(None)
        self._path_info()

    def save_path(self, filename: str | Path) -> None:
        if self.path is None:
            raise ParameterError("no listener path to save; record or load one first")
        self.path.to_csv(filename)

    def load_path(self, filename: str | Path) -> ListenerPath:
        p = ListenerPath.from_csv(filename)
        self.stop_recording()
        self.recorder.load(p)
        self.path = p
        self.scene.set_path(p, time_scale=self.time_scale_value())
        self._path_info()
        return p

    def _path_info(self) -> None:
        p = self.path
        self.path_label.setText(
            "no path" if p is None else f"{p.n_captures} captures, {p.duration:.2f} s ({p.source})"
        )

    # =============================================================== audio
    def render_audio(
        self, filename: str | Path | None = None, *, then: Callable[[], None] | None = None
    ) -> Task:
        """Render the sound heard along the listener path in the background and write it
        to ``filename`` (WAV/FLAC) if given.

        The render is ``auralize render --scene SESSION``'s: the viewer's session
        (data, mapping, thresholds, what is heard, time scale, timbre, layout,
        rate, the path, every overlay that is heard) becomes a scene
        (:func:`auralize.scene.soundscene.session_scene`) rendered by
        :func:`auralize.scene.soundscene.render_scene_file`, the volume on screen
        taken as it is.  With ``filename``, that session is saved beside it as
        ``FILE.session.json`` and the sidecar's ``command`` is
        ``auralize render --scene FILE.session.json -o FILE``, which writes the
        same samples.  Overlays whose sound is still being computed are
        computed here (the progress bar counts them), so none is left out; an
        overlay whose model makes no sound from the data is named, with why,
        in the status bar and the sidecar (``overlays_not_heard``)."""
        from auralize.scene.soundscene import render_scene_file, session_scene

        if self.volume is None:
            raise ParameterError("open a data file first")
        if self.path is None:
            raise ParameterError("no listener path; record or load one first")
        self.heard_spec()  # every type muted: say so before the work starts
        from auralize.emitters.synthesis import check_distance

        check_distance(self.path, self.volume.bounds)
        doc = self.session_state().to_dict()
        scene = session_scene(doc, source="the viewer's session")
        unheard = {n: why for n, why in self._overlay_unheard.items() if n in self.scene.overlays}
        key = str(input_key(self.data))
        loaded = {key: self.volume}
        ready = {
            (n, key): (self._overlay_params.get(n, {}), snd)
            for n, (vol, snd) in self._overlay_sounds.items()
            if vol is self.volume
        }
        out = None if filename is None else Path(filename).expanduser().resolve()
        session_file = None if out is None else out.with_name(out.name + ".session.json")

        def work(progress: Callable[[int, int], bool]) -> Any:
            from auralize.pipeline import save_rendered

            r = render_scene_file(scene, loaded=loaded, progress=progress, sounds=ready)
            if out is not None and session_file is not None:
                SessionState.from_dict(doc, source=str(session_file)).save(session_file)
                cmd = shlex.join(
                    ["auralize", "render", "--scene", str(session_file), "-o", str(out)]
                )
                save_rendered(
                    r,
                    out,
                    extra={
                        "command": cmd,
                        "session": str(session_file),
                        "overlays_not_heard": unheard,
                    },
                )
            return r

        def done(r: Any) -> None:
            self.rendered = r
            self.plot_audio()
            parts = " + ".join(p["model"] for p in r.meta.get("parts", []))
            where = f"wrote {out.name}" if out is not None else "rendered"
            more = "".join(f"; {n} overlay not heard: {why}" for n, why in unheard.items())
            self.statusBar().showMessage(f"{where}: {r.duration:.2f} s of {parts}{more}", 15000)
            if then is not None:
                then()

        return self.run_task("render", work, done)

    def plot_audio(self) -> None:
        """Waveform and spectrogram of the last render, with the time cursor."""
        r = self.rendered
        self.figure.clear()
        if r is None:
            self.canvas.draw_idle()
            return
        ax1, ax2 = self.figure.subplots(2, 1, sharex=True)
        t = np.arange(r.audio.shape[1]) / r.rate
        for c in range(r.audio.shape[0]):
            ax1.plot(t, r.audio[c], lw=0.5, label=r.layout.channel_names[c])
        ax1.set_ylabel("p (Pa)")
        mono = r.audio.mean(axis=0)
        if mono.size > 256:
            with np.errstate(divide="ignore"):  # silent stretches are -inf dB, drawn blank
                ax2.specgram(mono, NFFT=512, Fs=r.rate, noverlap=256, cmap="magma")
        ax2.set_ylabel("f (Hz)")
        ax2.set_xlabel("playback time (s)")
        self._cursors = [ax.axvline(0, color="tab:orange", lw=1) for ax in (ax1, ax2)]
        self._update_cursor()

    def cursor_time(self) -> float:
        """Playback seconds of the current step (where the cursor is drawn)."""
        if self.volume is None or self.volume.n_steps < 2:
            return 0.0
        plan = self.playback_plan()  # the render's clock: its time scale and the travel skipped
        data = float(self.volume.times[self.scene.step] - self.volume.times[0]) - plan.lead
        return max(data, 0.0) * plan.time_scale

    def _update_cursor(self) -> None:
        if not self._cursors:
            return
        x = self.cursor_time()
        for c in self._cursors:
            c.set_xdata([x, x])
        self.canvas.draw_idle()

    def play_audio(self) -> Any:
        """Play the last render on the chosen device (gain control, limiter, level meter);
        a message box says why if no device is usable."""
        from auralize.audio.output import play

        if self.rendered is None:
            raise ParameterError("render the audio first")
        self.stop_audio()
        self.playback = play(
            self.rendered, device=self.audio["device"], gain_db=self.gain_db, blocking=False
        )
        return self.playback

    def stop_audio(self) -> None:
        """Stop Play (within one block)."""
        pb, self.playback = self.playback, None
        if pb is not None:
            pb.stop()

    def set_gain_db(self, gain_db: float) -> None:
        """The gain control (dB) of Play and live listening (takes effect at once)."""
        from auralize.audio.output import check_gain_db

        self.gain_db = check_gain_db(gain_db)
        if self.gain_spin.value() != self.gain_db:
            self.gain_spin.setValue(self.gain_db)
        if self.player is not None and self.player.running:
            self.player.set_gain_db(self.gain_db)
        if self.playback is not None:
            self.playback.limiter.gain_db = self.gain_db

    # ================================================================ live
    def start_live(self, output: str | Path | None = None, *, wait: bool = True) -> Any:
        """Listen live: the listener follows the camera, sound is synthesized block by block
        into the device (or a WAV file given as ``output`` / in the panel), with the sound
        of the overlays switched on (added or taken out as they are switched).

        The sound heard (:meth:`heard_sound`) is made first if it is not ready: with
        ``wait=False`` (the Listen live button) in the background, with the progress
        bar and Cancel, and listening starts when it is in (the :class:`Task` is
        returned); with ``wait=True`` (scripts) here, and the player is returned.

        The same sound as the rendered file (:meth:`render_audio`): the sources'
        ``physical`` pressure through the 20 Hz high-pass
        (:data:`auralize.emitters.timbre.HIGHPASS_HZ`, its filter state carried from
        block to block), the overlays' sound unfiltered; at a still camera the live
        blocks equal the file rendered along a path standing at the camera."""
        from auralize.emitters.timbre import HIGHPASS_HZ
        from auralize.scene.listening import DeviceSink, LiveEngine, LivePlayer, WavSink

        if self.player is not None and self.player.running:
            return self.player
        from auralize.pipeline import source_box

        key, hit, compute = self._heard_request()
        if hit is None and not wait:

            def work(progress: Callable[[int, int], bool]) -> Any:
                progress(0, 1)
                hs = compute()
                if not progress(1, 1):
                    raise Cancelled("live listening cancelled")
                return hs

            def ready(hs: Any) -> None:
                self._heard = (key, None, hs)
                self.start_live(output)

            return self.run_task("live sound", work, ready)
        a = self.audio
        hs = self.heard_sound()
        box = source_box(self.volume, hs.tracks if hs.heard.mode == "detected" else None)
        eng = LiveEngine(
            hs.tracks,
            layout=a["layout"],
            rate=a["rate"],
            time_scale=self.time_scale_value(),
            block=int(self.block_spin.value()),
            extra=self.overlay_sound(),
            highpass_hz=HIGHPASS_HZ,
            box=box,
            head=self.head_tracker(),
        )
        target = output or self.live_file.text().strip() or None
        n_ch = eng.layout.n_channels
        sink = (
            WavSink(target, rate=a["rate"], channels=n_ch)
            if target
            else DeviceSink(rate=a["rate"], channels=n_ch, device=a["device"])
        )
        self._tick_pending = False
        self.player = LivePlayer(eng, sink, on_block=self._on_live_block, gain_db=self.gain_db)
        self._watch_camera()
        self.player.set_pose(*self._cam_pose)
        self.player.start()
        why = eng.why_silent()
        head = (
            ""
            if self._head is None
            else f"; head tracking on UDP port {self._head.port} (SPARTA/IEM messages)"
        )
        self.live_label.setText(
            why
            or f"live: {eng.layout.name}, block {eng.block} samples "
            f"({1000 * eng.block_s:.0f} ms), physical, "
            f"{eng.highpass_hz:g} Hz high-pass; "
            f"{eng.describe_distance()}{head}"
        )
        return self.player

    def head_tracker(self) -> Any:
        """The head tracker live listening turns the listener's head by (None without
        ``head_tracking_port``): an OSC listener opened on first use and kept until the
        window closes (:class:`auralize.audio.headtrack.OSCHeadTracker`)."""
        if self.head_tracking_port is None:
            return None
        if self._head is None:
            from auralize.audio.headtrack import OSCHeadTracker

            self._head = OSCHeadTracker(port=self.head_tracking_port)
        return self._head

    def _on_camera(self, *_: Any) -> None:
        """(Camera ModifiedEvent) the latest pose, for the capture clock and live listening."""
        self._cam_pose = camera_pose(self.plotter.camera)
        if self.player is not None and self.player.running:
            self.player.set_pose(*self._cam_pose)

    def _on_live_block(self, data_time: float) -> None:
        """(Worker thread) a block was played: ask the GUI for one redraw at a time.

        Ticks are coalesced: while one is waiting to be handled no other is sent, so
        an audio device that asks for blocks faster than the window redraws (an
        unpaced device) cannot pile up redraws that outlive Stop.
        """
        self._live_time = data_time
        if not self._tick_pending:
            self._tick_pending = True
            self.live_tick.emit(data_time)

    def _on_live_tick(self, _data_time: float) -> None:
        self._tick_pending = False
        data_time = self._live_time
        if self.volume is None or self.player is None or not self.player.running:
            if self.player is not None and self.player.error is not None:
                err, self.player.error = self.player.error, None
                self.stop_live()
                self.show_error(err)
            return
        if self.player.error is not None:
            err, self.player.error = self.player.error, None
            self.stop_live()
            self.show_error(err)
            return
        self._live_redraw(data_time)
        lat = self.player.latencies
        eng = self.player.engine
        why = eng.why_silent()
        if why:
            self.live_label.setText(why)
        elif lat:
            self.live_label.setText(
                f"live: last move heard after {1000 * lat[-1]:.0f} ms; {eng.describe_distance()}"
            )

    def _live_redraw(self, data_time: float | None = None) -> None:
        """Show the time step live listening is playing, if it changed: at most one redraw
        per :data:`LIVE_REDRAW_GAP_S` and per :data:`LIVE_REDRAW_DUTY` times the last one's
        duration (a step due sooner is shown when that time comes, by a single-shot timer),
        so that the window's thread stays free for the user's keys and mouse."""
        if self.volume is None or self.player is None or not self.player.running:
            return
        t = self._live_time if data_time is None else data_time
        step = int(
            np.clip(
                np.searchsorted(self.volume.times, t, side="right") - 1, 0, self.volume.n_steps - 1
            )
        )
        if step == self.scene.step:
            return
        now = time.perf_counter()
        if now < self._live_redraw_at:
            if not self._live_redraw_timer.isActive():
                self._live_redraw_timer.start(max(int(1000 * (self._live_redraw_at - now)) + 1, 1))
            return
        self._guard(self.set_step, step)
        end = time.perf_counter()
        self._live_redraw_at = end + max(LIVE_REDRAW_GAP_S, LIVE_REDRAW_DUTY * (end - now))

    def stop_live(self) -> None:
        """Stop live listening (returns within one block; no redraw follows it)."""
        self._live_redraw_timer.stop()
        if not self.recorder.recording:
            self._unwatch_camera()
        if self.player is not None:
            self.player.on_block = None
            if self.player.running:
                self.player.stop()
            self.live_label.setText("off")

    def save_heard(self, csv_file: str | Path, audio_file: str | Path | None = None) -> None:
        """Save what live listening played: the path CSV and ``<csv>.wav``."""
        if self.player is None:
            raise ParameterError("nothing heard yet; listen live first")
        audio_file = audio_file or Path(csv_file).with_suffix(".wav")
        self.player.engine.save_heard(csv_file, audio_file)

    # ============================================================ overlays
    def _toggle_overlay(self, name: str, on: bool) -> None:
        """The Overlays panel's check box: untick it again if the overlay cannot start."""
        if self._guard(self.set_overlay, name, on) is None and on:
            cb = self.overlay_checks[name]
            cb.blockSignals(True)
            cb.setChecked(False)
            cb.blockSignals(False)

    def set_overlay(
        self, name: str, on: bool, *, then: Callable[[bool], None] | None = None
    ) -> Task | None:
        """Switch a plugin's overlay on or off.

        An overlay whose model makes sound from the volume on screen is also
        heard: once the overlay is drawn, ``synthesize(volume)`` runs in the
        background (unless the model's ``input_kind`` names other inputs), and
        its sound is added to live listening and rendered files
        (:meth:`overlay_sound`) until the overlay is switched off; a model that
        cannot make sound from the volume is shown, not heard, and the Overlays
        panel says why.

        Switching on computes the overlay of the current step in the background
        (progress bar, Cancel), then draws it.  Later steps are computed in the
        background too as the time slider moves or playback advances (see
        :meth:`_overlay_fn`): the view keeps the last overlay drawn until the
        current step's is ready, and results for steps already left are dropped.  An overlay that does not apply to the data (e.g. fields it
        needs are missing) is switched off again with the reason in the Overlays
        panel.  ``then(drawn)`` is called when done.
        """
        from auralize.plugins import get_model

        cb = self.overlay_checks.get(name)
        if cb is not None and cb.isChecked() != on:  # switched from a script or a session
            cb.blockSignals(True)
            cb.setChecked(on)
            cb.blockSignals(False)
        self._overlay_unheard.pop(name, None)
        if not on:
            self._overlay_want.pop(name, None)
            self._overlay_cache.pop(name, None)
            t = self._overlay_tasks.get(name)
            if t is not None:
                t.cancel()
            st = self._sound_tasks.pop(name, None)
            if st is not None:
                st.cancel()
            if self._overlay_sounds.pop(name, None) is not None:
                self._update_live_sound()
            self.scene.set_overlay(name, None)
            self.overlay_note.setText("")
            self.plotter.render()
            if then is not None:
                then(False)
            return None
        if self.volume is None:
            raise ParameterError("open a data file first")
        model = get_model(name)
        vol, path, step = self.volume, self.path, self.scene.step

        def work(progress: Callable[[int, int], bool]) -> Any:
            progress(0, 1)
            try:
                first = model.overlay((vol, path), step)
            except AuralizeError as exc:
                return exc
            if not progress(1, 1):
                raise Cancelled(f"{name} overlay cancelled")
            return first

        def done(first: Any) -> None:
            drawn = not isinstance(first, AuralizeError)
            if drawn:
                self._overlay_cache[name] = (vol, path, {step: first})
                self.scene.set_overlay(name, self._overlay_fn(name, model))
                err = self.scene.overlay_errors.get(name)
                drawn = err is None
                if not drawn:
                    self.scene.set_overlay(name, None)
                    first = AuralizeError(err)
            if not drawn:
                cb = self.overlay_checks.get(name)
                if cb is not None:
                    cb.blockSignals(True)
                    cb.setChecked(False)
                    cb.blockSignals(False)
                self.overlay_note.setText(f"{name} overlay does not apply to this data: {first}")
            else:
                self.overlay_note.setText("")
                self.plotter.render()
                self._start_overlay_sound(name, model)
            if then is not None:
                then(drawn)

        return self.run_task(f"{name} overlay", work, done)

    # ------------------------------------------------------ audible overlays
    def _start_overlay_sound(self, name: str, model: Any) -> Task | None:
        """Compute what overlay ``name``'s model emits for the volume on screen, in the
        background; once in, it is heard in live listening and in rendered files."""
        from auralize.plugins import synthesize

        if model.input_kind not in ("", "volume"):
            why = f"its model makes sound from {model.input_kind}, not from a volume"
            self._overlay_unheard[name] = why
            self.overlay_note.setText(f"{name} overlay is shown but not heard: {why}")
            return None
        from auralize.scene.soundscene import model_params

        vol = self.volume
        label = f"{name} sound"
        # the parameters a render of the session gives it (the output rate): the render
        # takes this sound as it is
        params = model_params(model, {}, int(self.audio["rate"]))

        def work(progress: Callable[[int, int], bool]) -> Any:
            progress(0, 1)
            try:  # a model whose inputs are not a volume says so (shown in the panel)
                sound = (params, synthesize(model, vol, **params))
            except (AuralizeError, NotImplementedError) as exc:
                return exc
            if not progress(1, 1):
                raise Cancelled(f"{label} cancelled")
            return sound

        t = Task(label, work, self)
        self._sound_tasks[name] = t
        self._threads.add(t)
        t.succeeded.connect(lambda r: self._overlay_sound_done(name, t, vol, r))
        t.failed.connect(lambda e: self._overlay_sound_done(name, t, vol, e))
        t.finished.connect(lambda: self._forget_thread(t))
        t.start()
        return t

    def _overlay_sound_done(self, name: str, t: Task, vol: Any, result: Any) -> None:
        """An overlay's sound arrived on the UI thread: keep it if the overlay is still on
        for the same data, and let live listening hear it."""
        if self._sound_tasks.get(name) is not t:
            return  # switched off (or on again) meanwhile
        del self._sound_tasks[name]
        if isinstance(result, Cancelled):
            return
        if isinstance(result, BaseException):
            why = " ".join(str(result).split())
            self._overlay_unheard[name] = why
            self.overlay_note.setText(f"{name} overlay is shown but not heard: {why}")
            return
        if name in self.scene.overlays and vol is self.volume:
            self._overlay_sounds[name] = (vol, result[1])
            self._overlay_params[name] = result[0]
            self._update_live_sound()

    def overlay_sound(self) -> Any:
        """What the switched-on overlays emit for the volume on screen (one
        :class:`auralize.emitters.Sound`), or None when no overlay is heard."""
        from auralize.emitters import Sound

        heard = [snd for vol, snd in self._overlay_sounds.values() if vol is self.volume]
        if not heard:
            return None
        total = Sound(parts=[], name="")
        for snd in heard:
            total = total + snd
        return total

    def _update_live_sound(self) -> None:
        if self.player is not None and self.player.running:
            self.player.engine.set_extra(self.overlay_sound())

    def _overlay_fn(self, name: str, model: Any) -> Callable[[int], Any]:
        """The scene's function for overlay ``name``: the step's meshes when computed,
        else :data:`~auralize.scene.view.PENDING` and the step is computed off the
        UI thread (:meth:`_request_overlay_step`)."""

        def fn(n: int) -> Any:
            vol, path, steps = self._overlay_cache.get(name, (None, None, {}))
            if vol is not self.volume or path is not self.path:
                steps = {}
                self._overlay_cache[name] = (self.volume, self.path, steps)
            if n in steps:
                got = steps[n]
                if isinstance(got, AuralizeError):
                    raise got
                return got
            self._request_overlay_step(name, model, n)
            return PENDING

        return fn

    def _request_overlay_step(self, name: str, model: Any, n: int) -> None:
        """Compute step ``n`` of overlay ``name`` in a :class:`Task`.  One task per
        overlay runs at a time; a step asked for meanwhile is started when it ends."""
        self._overlay_want[name] = n
        if name in self._overlay_tasks:
            return
        vol, path = self.volume, self.path
        label = f"{name} overlay, step {n}"

        def work(progress: Callable[[int, int], bool]) -> Any:
            progress(0, 1)
            try:
                meshes = model.overlay((vol, path), n)
            except AuralizeError as exc:  # shown (and the overlay hidden) if still wanted
                meshes = exc
            if not progress(1, 1):
                raise Cancelled(f"{label} cancelled")
            return meshes

        t = Task(label, work, self)
        self._overlay_tasks[name] = t
        self._threads.add(t)
        t.succeeded.connect(lambda r: self._overlay_step_done(name, t, vol, path, n=n, result=r))
        t.failed.connect(lambda e: self._overlay_step_done(name, t, vol, path, n=n, result=e))
        t.finished.connect(lambda: self._forget_thread(t))
        t.start()
        self._overlay_progress()

    def _forget_thread(self, t: Task) -> None:
        """Delete a finished task (``finished`` is sent just before its thread ends:
        wait for that first, as deleting a running thread aborts the process)."""
        t.wait()
        self._threads.discard(t)
        t.deleteLater()

    def _overlay_step_done(
        self, name: str, t: Task, vol: Any, path: Any, *, n: int, result: Any
    ) -> None:
        """A computed overlay step arrived on the UI thread: draw it if it is still the
        current step of the same data, drop it otherwise; then start the step wanted now."""
        if self._overlay_tasks.get(name) is t:
            del self._overlay_tasks[name]
        self._overlay_progress()
        if isinstance(result, Cancelled) or (
            isinstance(result, BaseException) and not isinstance(result, AuralizeError)
        ):
            if name in self.scene.overlays:
                if not isinstance(result, Cancelled):  # a failing plugin: switch it off
                    self._toggle_overlay(name, False)
                    cb = self.overlay_checks.get(name)
                    if cb is not None:
                        cb.blockSignals(True)
                        cb.setChecked(False)
                        cb.blockSignals(False)
                self.show_error(result)  # Cancelled: a status-bar note
            return
        entry = self._overlay_cache.get(name)
        if name not in self.scene.overlays or entry is None:
            return  # switched off meanwhile
        if entry[0] is vol and entry[1] is path and vol is self.volume and path is self.path:
            if n == self.scene.step:
                steps = entry[2]
                steps[n] = result
                while len(steps) > 16:  # keep the most recent steps
                    del steps[next(iter(steps))]
        if self._overlay_want.get(name) is None:
            return  # cancelled: the overlay shows what it showed
        shown = self.scene.overlay_shown.get(name)
        self.scene.refresh_overlay(name, render=False)  # draws, or asks for the current step
        err = self.scene.overlay_errors.get(name)
        if err is not None:
            self.overlay_note.setText(f"{name} overlay cannot show step {self.scene.step}: {err}")
        if self.scene.overlay_shown.get(name) != shown or err is not None:
            self.plotter.render()

    def _overlay_progress(self) -> None:
        """Busy bar and Cancel while overlay steps compute (unless a task shows its own)."""
        if self.busy:
            return
        if self._overlay_tasks:
            t = next(iter(self._overlay_tasks.values()))
            self.progress.setRange(0, 0)
            self.progress.setFormat(t.name)
            self.progress.show()
            self.cancel_btn.show()
        else:
            self.progress.hide()
            self.cancel_btn.hide()

    # ============================================================= session
    def session_state(self) -> SessionState:
        st = SessionState(data=dict(self.data), audio=dict(self.audio))
        st.view = {
            "field": self.scene.field,
            "representation": self.scene.representation,
            "cmap": self.scene.cmap,
            "opacity": self.scene.opacity,
            "step": self.scene.step,
            "types": dict(self.scene.visible_types),
        }
        st.detection = {
            "mapping": self.mapping,
            "thresholds": self.read_thresholds().describe(),
            "mapping_fields": dict(self.mapping_fields),
            "detected": self.series is not None,
        }
        # the overlays switched on, and those heard as sound models mixed with the data
        st.view["overlays"] = sorted(self.scene.overlays)
        st.models = [
            {"model": n, "input": dict(self.data), "params": {}}
            for n in sorted(self.scene.overlays)
            if n in self._overlay_sounds or n in self._sound_tasks
        ]
        st.set_listener_path(self.path)
        st.recording = {"rate_hz": float(self.rate_spin.value())}
        st.camera = self.scene.camera() if self.volume is not None else None
        return st

    def save_session(self, filename: str | Path) -> None:
        """Save the session (data, view, thresholds, path, audio, camera) to a JSON file;
        File ▸ Save session writes there from now on."""
        self.session_state().save(filename)
        self.session_file = Path(filename)
        self.setWindowTitle(f"auralize — {self.session_file.name}")

    def load_session(
        self, filename: str | Path, *, then: Callable[[], None] | None = None
    ) -> Task | None:
        """Open a session: data in the background, then view, path, audio, camera
        (and detection if the session had sources)."""
        st = SessionState.load(filename)
        self.session_file = Path(filename)

        def apply() -> None:
            v = st.view or {}
            if v.get("field"):
                self.set_field(v["field"])
            if v.get("representation"):
                self.rep_box.setCurrentText(v["representation"])
                self.scene.set_representation(v["representation"], render=False)
            if v.get("cmap") or v.get("opacity") is not None:
                self.cmap_box.setCurrentText(v.get("cmap", self.scene.cmap))
                self.opacity.setValue(float(v.get("opacity", self.scene.opacity)))
            for k, on in (v.get("types") or {}).items():
                self.type_checks[k].setChecked(bool(on))
            det = st.detection or {}
            for k in TYPES:
                if det.get("thresholds"):
                    self.th_edits[k].setText(str(det["thresholds"][k]))
            self.mapping = det.get("mapping") or "auto"
            self.mapping_fields = dict(det.get("mapping_fields") or {})
            self.mapping_box.setCurrentText(self.mapping)
            a = st.audio or {}
            self.audio.update(a)
            self.audio.setdefault("time_scale", DEFAULTS.time_scale)
            self.audio.setdefault("timbre", DEFAULTS.timbre)
            self.set_heard(str(self.audio.get("heard") or DEFAULTS.heard))
            self.set_layout(self.audio["layout"])
            self.timbre_box.setCurrentText(str(self.audio["timbre"]))
            ts = self.audio["time_scale"]
            self.ts_spin.setValue(0.0 if ts == "auto" else float(ts))
            self.rate_spin.setValue(float((st.recording or {}).get("rate_hz", DEFAULT_RATE_HZ)))
            p = st.listener_path()
            if p is not None:
                self.recorder.load(p)
            else:
                self.recorder.clear()
            self.path = p
            self.scene.set_path(p, time_scale=self.time_scale_value(), render=False)
            self._path_info()
            self.set_step(int(v.get("step", 0)))
            if st.camera:
                self.scene.set_camera(st.camera)
                self.plotter.render()
            # overlays (and the models they make heard) come back once the view is set
            names = [*(v.get("overlays") or []), *(m.get("model") for m in st.models)]
            wanted = [n for n in dict.fromkeys(names) if n in self.overlay_checks]

            def overlays(k: int = 0) -> None:
                if k == len(wanted):
                    if det.get("detected"):
                        self.detect(then=then)
                    elif then is not None:
                        then()
                    return
                cb = self.overlay_checks[wanted[k]]
                cb.blockSignals(True)
                cb.setChecked(True)
                cb.blockSignals(False)
                if self.set_overlay(wanted[k], True, then=lambda _on: overlays(k + 1)) is None:
                    overlays(k + 1)

            overlays()

        d = st.data
        if not d:
            apply()
            return None
        return self.open_data(
            d["spec"],
            size=d.get("size"),
            steps=d.get("steps"),
            seed=d.get("seed") or 0,
            fields=d.get("fields"),
            resolution=d.get("resolution"),
            then=apply,
            keep_path=False,
            **reader_options(d),
        )

    # ============================================================== window
    def closeEvent(self, event: Any) -> None:
        app = QtWidgets.QApplication.instance()
        if app is not None:
            app.removeEventFilter(self.fly_keys)
        self._ui_timer.stop()
        self.stop_recording()
        self.stop_live()
        self.stop_audio()
        if self._head is not None:
            self._head.close()
            self._head = None
        self._anim_timer.stop()
        if self.task is not None and self.task.isRunning():
            self.task.cancel()
            self.task.wait(10_000)
        self.cancel_task()
        for t in self._sound_tasks.values():
            t.cancel()
        for t in list(self._threads):
            t.wait(10_000)
        self._overlay_tasks.clear()
        self._sound_tasks.clear()
        self.plotter.close()
        _drop_surface_wrapper_on_delete(self.plotter)
        super().closeEvent(event)


def _drop_surface_wrapper_on_delete(interactor: Any) -> None:
    """Unregister the interactor's ``QSurface`` wrapper when Qt deletes the surface.

    pyvistaqt's widget keeps a Python wrapper of its OpenGL surface to make its
    context current.  A ``QSurface`` is not a ``QObject``, so PySide is never told
    when Qt deletes it with the widget: the wrapper stays registered at that address
    and PySide hands it back for the next Qt object allocated there (a menu's
    ``QAction`` then "is" a ``QSurface``).  Qt deletes the widget's context first
    and its surface right after, and the context's ``aboutToBeDestroyed`` slots may
    still use the surface (pyvistaqt's own makes the context current to free its GL
    objects); a slot connected here runs after those and invalidates the wrapper
    before the surface goes.
    """
    from shiboken6 import Shiboken

    ctx = interactor.context() if Shiboken.isValid(interactor) else None
    if ctx is None or getattr(interactor, "_surface_watched", False):
        return
    surface = ctx.surface()
    if surface is None:
        return
    interactor._surface_watched = True

    def release() -> None:
        if Shiboken.isValid(surface):
            Shiboken.invalidate(surface)

    ctx.aboutToBeDestroyed.connect(release)


def _devices() -> list[Any]:
    """Output devices offered by the output layer (``auralize.audio.output.list_devices``), if any."""
    import auralize.audio.output as audio

    fn = getattr(audio, "list_devices", None) or getattr(audio, "output_devices", None)
    if fn is None:
        return []
    try:
        return [d.get("name", d) if isinstance(d, dict) else d for d in fn()]
    except AuralizeError:
        return []


def run_app(args: Any, opts: dict[str, Any]) -> int:
    """Start the Qt application (``auralize view``).

    ``args`` are the command's parsed options, ``opts`` what they ask for
    (:func:`auralize.cli.view.view_options`: the data, field, mapping,
    thresholds and head-tracking port).
    """
    from auralize.sources.detection import TYPES

    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    win = MainWindow()
    win.show()
    th = opts["thresholds"].describe()
    for k in TYPES:
        if str(th[k]) != "auto":
            win.th_edits[k].setText(str(th[k]))
    if opts["mapping"]:
        win.mapping = opts["mapping"]
        win.mapping_box.setCurrentText(opts["mapping"])
    win.mapping_fields = dict(opts["mapping_fields"])
    win.head_tracking_port = opts["head_tracking"]
    if getattr(args, "session", None):
        win._guard(win.load_session, args.session)
    elif opts["data"] is not None:
        d = opts["data"]

        def after() -> None:
            if args.path:
                win._guard(win.load_path, args.path)
            if args.time is not None:
                win._guard(win.set_step, args.time)
            if args.representation != "volume":
                win.rep_box.setCurrentText(args.representation)
                win._guard(win.scene.set_representation, args.representation)
            if args.detect:
                win._guard(win.detect)

        win._guard(
            lambda: win.open_data(
                d["spec"],
                size=d["size"],
                steps=d["steps"],
                seed=d["seed"],
                fields=d.get("fields"),
                resolution=d.get("resolution"),
                field=opts["field"],
                then=after,
                **reader_options(d),
            )
        )
    return int(app.exec())
