"""The viewer's Describe panel: the sources in words (:mod:`auralize.describe`).

Under the 3-D view: a line about the time step on screen (it follows the
time slider) and, beside it, the whole description in a read-only text box a screen reader reads line by line
(Tab reaches both; the arrows move through the text).  The window fills it
(:meth:`auralize.viewer.app.MainWindow.describe`).
"""

from __future__ import annotations

from typing import Any

from qtpy import QtCore, QtWidgets

#: what the panel says before there is a description
EMPTY = "no description yet: Describe (Ctrl+Shift+D) puts the sources into words"


class DescribePanel(QtWidgets.QWidget):
    """The panel's widgets and the description they show (``description``, or None)."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.description: Any = None
        # a wide, low panel under the 3-D view: the buttons and the step's line on the
        # left, the whole description beside them
        lay = QtWidgets.QHBoxLayout(self)
        left = QtWidgets.QVBoxLayout()
        row = QtWidgets.QHBoxLayout()
        self.describe_btn = QtWidgets.QPushButton("Describe")
        self.describe_btn.setToolTip(
            "put the sources into words: per step their types, where "
            "they are, how loud and when the listener hears them "
            "(detects them first if needed)"
        )
        self.describe_btn.setAccessibleName("Describe the sources in words")
        self.save_btn = QtWidgets.QPushButton("Save description…")
        self.save_btn.setToolTip(
            "save the description as text, CSV (one row per step and "
            "type) or JSON, by the file's suffix"
        )
        self.save_btn.setAccessibleName("Save the description")
        row.addWidget(self.describe_btn)
        row.addWidget(self.save_btn)
        left.addLayout(row)
        self.now = QtWidgets.QLabel(EMPTY)
        self.now.setWordWrap(True)
        self.now.setAlignment(QtCore.Qt.AlignmentFlag.AlignTop | QtCore.Qt.AlignmentFlag.AlignLeft)
        self.now.setTextInteractionFlags(
            QtCore.Qt.TextInteractionFlag.TextSelectableByKeyboard
            | QtCore.Qt.TextInteractionFlag.TextSelectableByMouse
        )
        self.now.setFocusPolicy(QtCore.Qt.FocusPolicy.StrongFocus)
        self.now.setToolTip("the sources at the time step on screen")
        self.now.setAccessibleName("Sources at this step")
        left.addWidget(self.now, 1)
        lay.addLayout(left, 2)
        self.text = QtWidgets.QPlainTextEdit()
        self.text.setReadOnly(True)
        self.text.setTabChangesFocus(True)  # Tab leaves the box; the arrows read it
        self.text.setPlaceholderText(EMPTY)
        self.text.setToolTip(
            "the whole description: what you will hear when, then step by "
            "step (arrow keys move through it)"
        )
        self.text.setAccessibleName("Description of the sources")
        self.text.setMinimumHeight(90)
        lay.addWidget(self.text, 3)
        self.clear()

    def clear(self, why: str = EMPTY) -> None:
        """Forget the description (new data, new sources), saying ``why``."""
        self.description = None
        self.text.setPlainText("")
        self.text.setPlaceholderText(why)
        self.now.setText(why)
        self.save_btn.setEnabled(False)

    def show_description(self, description: Any, step: int = 0) -> None:
        """Show ``description`` (an :class:`auralize.describe.Description`)."""
        self.description = description
        self.text.setPlainText(description.text())
        self.save_btn.setEnabled(True)
        self.show_step(step)

    def show_step(self, step: int) -> None:
        """The line about ``step`` (the time step on screen)."""
        d = self.description
        if d is not None and 0 <= step < len(d.times):
            self.now.setText(d.at_step(step))
