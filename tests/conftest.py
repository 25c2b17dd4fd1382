"""Shared fixtures: small deterministic volumes and their detected sources, and the
viewer's window with its render (GUI tests, under Xvfb)."""

from __future__ import annotations

import gc
import os
from pathlib import Path

import numpy as np
import pytest

from auralize.datasets import MonopoleParams, make_monopole
from auralize.sources import SourceSeries, Thresholds, detect

MONO_KW = {"size": 32, "steps": 300}

# the file-backed ALSA devices of the live tests are files, not clocks: their
# callbacks wait for the producer however loaded the machine is (also in the
# subprocesses the tests start), so the tests check what the device receives, not
# whether synthesis kept pace (a row of ``auralize bench``)
os.environ.setdefault("AURALIZE_LIVE_WAIT_S", "60")


@pytest.fixture(scope="session")
def mono_params() -> MonopoleParams:
    return MonopoleParams(**MONO_KW)


@pytest.fixture(scope="session")
def mono_volume():  # type: ignore[no-untyped-def]
    return make_monopole(**MONO_KW).load()


@pytest.fixture(scope="session")
def mono_series(mono_volume) -> SourceSeries:  # type: ignore[no-untyped-def]
    return detect(mono_volume, mapping="identity", thresholds=Thresholds(monopole="0.1%"))


@pytest.fixture(scope="session")
def mono_tracks(mono_series):  # type: ignore[no-untyped-def]
    return mono_series.tracks()


def rng() -> np.random.Generator:
    return np.random.default_rng(1234)


# ------------------------------------------------------------------ the viewer under Xvfb
@pytest.fixture
def errors(monkeypatch):  # type: ignore[no-untyped-def]
    """Error boxes are recorded instead of shown (they would block): their texts."""
    from qtpy import QtWidgets

    shown: list[str] = []

    def critical(parent, title, text, *a, **k):  # type: ignore[no-untyped-def]
        shown.append(text)
        return QtWidgets.QMessageBox.StandardButton.Ok

    monkeypatch.setattr(QtWidgets.QMessageBox, "critical", critical)
    return shown


@pytest.fixture
def window_size() -> tuple[int, int]:
    """Width and height of the viewer's window in a test (a test file may override it)."""
    return (900, 650)


@pytest.fixture
def open_viewer(qtbot, tmp_path, errors, window_size):  # type: ignore[no-untyped-def]
    """A factory: ``open_viewer()`` shows the viewer's main window and returns
    ``(window, shown)``.

    The window autosaves under ``tmp_path`` and is closed after the test; error
    boxes are not shown, their texts are appended to ``shown`` (the ``errors``
    fixture).  Patches made before the call (a test's sound-model registry) hold
    for the window.
    """
    from auralize.viewer.app import MainWindow

    opened = []

    def open_window():  # type: ignore[no-untyped-def]
        win = MainWindow(autosave_dir=tmp_path / "autosave")
        qtbot.addWidget(win)
        win.resize(*window_size)
        win.show()
        qtbot.waitExposed(win)
        opened.append(win)
        return win, errors

    yield open_window
    for win in opened:
        win.close()
    # free the closed windows' VTK and OpenGL objects now, while nothing renders: left to
    # the cyclic garbage collector they may be freed in the middle of a later window's
    # render (a Python callback inside VTK's render can run a collection)
    from PySide6 import QtWidgets

    QtWidgets.QApplication.processEvents()
    opened.clear()
    gc.collect()


@pytest.fixture
def window(open_viewer):  # type: ignore[no-untyped-def]
    """The viewer's main window, shown (see :func:`open_viewer`)."""
    return open_viewer()[0]


@pytest.fixture
def render_in_viewer(qtbot):  # type: ignore[no-untyped-def]
    """``render_in_viewer(win, shown, out)``: the window's render along its listener
    path, written to ``out`` and waited for; returns its audio ``(n_channels, n)`` in
    Pa.  Fails if an error box came up (``shown``, see :func:`open_viewer`)."""

    def run(win, shown: list[str], out: Path) -> np.ndarray:  # type: ignore[no-untyped-def]
        win.rendered = None
        win.render_audio(out)
        qtbot.waitUntil(
            lambda: (win.rendered is not None and not win.busy) or bool(shown), timeout=600_000
        )
        assert not shown
        return np.array(win.rendered.audio)

    return run
