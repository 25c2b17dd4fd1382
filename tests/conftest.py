"""Shared fixtures: small deterministic volumes and their detected sources, and the
viewer's window with its render (GUI tests, under Xvfb)."""

from __future__ import annotations

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
def open_viewer(qtbot, tmp_path, monkeypatch):  # type: ignore[no-untyped-def]
    """A factory: ``open_viewer()`` shows the viewer's main window and returns
    ``(window, shown)``.

    The window autosaves under ``tmp_path`` and is closed after the test; error
    boxes are not shown, their texts are appended to ``shown``.  Patches made
    before the call (a test's sound-model registry) hold for the window.
    """
    from qtpy import QtWidgets

    from auralize.viewer.app import MainWindow

    shown: list[str] = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "critical",
                        lambda *a, **k: shown.append(a[2]) or QtWidgets.QMessageBox.StandardButton.Ok)  # fmt: skip
    opened = []

    def open_window():  # type: ignore[no-untyped-def]
        win = MainWindow(autosave_dir=tmp_path / "autosave")
        qtbot.addWidget(win)
        win.resize(900, 650)
        win.show()
        qtbot.waitExposed(win)
        opened.append(win)
        return win, shown

    yield open_window
    for win in opened:
        win.close()


@pytest.fixture
def render_in_viewer(qtbot):  # type: ignore[no-untyped-def]
    """``render_in_viewer(win, shown, out)``: the window's render along its listener
    path, written to ``out`` and waited for; returns its audio ``(n_channels, n)`` in
    Pa.  Fails if an error box came up (``shown``, see :func:`open_viewer`)."""

    def run(win, shown: list[str], out: Path) -> np.ndarray:  # type: ignore[no-untyped-def]
        win.rendered = None
        win.render_audio(out)
        qtbot.waitUntil(lambda: (win.rendered is not None and not win.busy) or bool(shown),
                        timeout=600_000)  # fmt: skip
        assert not shown
        return np.array(win.rendered.audio)

    return run
