"""Keyboard and screen-reader access to the viewer's window (Qt only).

* :func:`actionable` lists the widgets a user acts on (buttons, boxes,
  sliders, text fields, the 3-D view, keyboard-selectable texts), leaving out
  the parts of composite widgets (a spin box's editor, a scroll area's bars,
  a combo box's list), which their owner stands for;
* :func:`name_widgets` gives each of them an accessible name (what a screen
  reader says) where the code gave none: a button's text, a form row's label
  with its panel's title (``Audio: layout``), a toolbar button's action; Qt's
  own dock and toolbar buttons (named "Close", "Float" by Qt) get the title of
  the panel or toolbar they belong to; and an accessible
  description from its tooltip;
* :func:`set_focus_chain` makes Tab visit the 3-D view, then the panels in
  the order given (each top to bottom), then the toolbars;
* :func:`tab_chain` walks the chain as Tab does (tests and Help use it).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable

from qtpy import QtCore, QtWidgets

#: widget classes a user acts on
ACTIONABLE = (
    QtWidgets.QAbstractButton,
    QtWidgets.QComboBox,
    QtWidgets.QAbstractSpinBox,
    QtWidgets.QLineEdit,
    QtWidgets.QAbstractSlider,
    QtWidgets.QPlainTextEdit,
    QtWidgets.QTextEdit,
)
#: parts of these are named and reached through them
_COMPOSITES = (QtWidgets.QAbstractSpinBox, QtWidgets.QComboBox)
#: Qt's own buttons: object name -> accessible name (``{}`` the dock's or toolbar's title)
QT_BUTTONS = {
    "qt_dockwidget_closebutton": "Hide the {} panel",
    "qt_dockwidget_floatbutton": "Float or dock the {} panel",
    "qt_toolbar_ext_button": "More of the {} toolbar",
    "qt_menubar_ext_button": "More menus",
}


def _is_part(w: QtWidgets.QWidget) -> bool:
    """A widget inside a composite one (spin box, combo box), or a scroll area's bar."""
    if isinstance(w, QtWidgets.QScrollBar):
        return True
    p = w.parentWidget()
    while p is not None:
        if isinstance(p, _COMPOSITES):
            return True
        p = p.parentWidget()
    return False


def takes_focus(w: QtWidgets.QWidget) -> bool:
    """Whether Tab can reach ``w`` (its focus policy accepts Tab)."""
    return bool(w.focusPolicy() & QtCore.Qt.FocusPolicy.TabFocus)


def actionable(root: QtWidgets.QWidget) -> list[QtWidgets.QWidget]:
    """The widgets under ``root`` a user acts on or reads with the keyboard (see the
    module docstring), in creation order."""
    out = []
    for w in root.findChildren(QtWidgets.QWidget):
        if _is_part(w):
            continue
        if isinstance(w, ACTIONABLE) or takes_focus(w):
            out.append(w)
    return out


def _owner_title(w: QtWidgets.QWidget) -> str:
    """The title of the dock or toolbar ``w`` is in ("" if none)."""
    p = w.parentWidget()
    while p is not None:
        if isinstance(p, QtWidgets.QDockWidget | QtWidgets.QToolBar):
            return p.windowTitle()
        p = p.parentWidget()
    return ""


def _form_label(w: QtWidgets.QWidget) -> str:
    """The label of the form row ``w`` is the field of ("" if none)."""
    p = w.parentWidget()
    lay = p.layout() if p is not None else None
    if isinstance(lay, QtWidgets.QFormLayout):
        lab = lay.labelForField(w)
        if isinstance(lab, QtWidgets.QLabel):
            return lab.text()
    return ""


def _clean(text: str) -> str:
    return text.replace("&&", "\0").replace("&", "").replace("\0", "&").rstrip("…").strip()


def name_widgets(root: QtWidgets.QWidget) -> None:
    """Give every actionable widget under ``root`` an accessible name and description
    where it has none (see the module docstring); names set in code are kept."""
    for w in actionable(root):
        if not w.accessibleDescription() and w.toolTip():
            w.setAccessibleDescription(w.toolTip())
        title = _owner_title(w)
        if w.objectName() in QT_BUTTONS:  # Qt names them "Close", "Float": whose?
            w.setAccessibleName(QT_BUTTONS[w.objectName()].format(title))
            continue
        if w.accessibleName():
            continue
        name = ""
        if isinstance(w, QtWidgets.QToolButton) and w.defaultAction() is not None:
            name = _clean(w.defaultAction().text())
        elif isinstance(w, QtWidgets.QAbstractButton) and w.text():
            name = _clean(w.text())
        else:
            label = _form_label(w)
            if label:
                name = f"{title}: {label}" if title else label
            elif w.toolTip():
                name = w.toolTip().split(";")[0].split("(")[0].strip()
        if name:
            w.setAccessibleName(name)


def set_focus_chain(widgets: Iterable[QtWidgets.QWidget]) -> None:
    """Make Tab visit ``widgets`` in this order (those that take focus)."""
    chain = [w for w in widgets if takes_focus(w)]
    for a, b in itertools.pairwise(chain):
        QtWidgets.QWidget.setTabOrder(a, b)


def tab_chain(start: QtWidgets.QWidget, *, limit: int = 1000) -> list[QtWidgets.QWidget]:
    """The widgets Tab visits from ``start``, once round (as Qt's ``focusNextPrevChild``:
    enabled, visible widgets that take Tab focus, in the focus chain's order)."""
    out: list[QtWidgets.QWidget] = []
    w = start.nextInFocusChain()
    for _ in range(limit):
        if w is None or w is start:
            break
        if takes_focus(w) and w.isEnabled() and w.isVisible() and w.focusProxy() is None:
            out.append(w)
        w = w.nextInFocusChain()
    return out
