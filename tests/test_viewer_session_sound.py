"""A viewer overlay's sound is kept by the saved session: the session lists it among its
sound models, ``auralize render --scene SESSION.json`` renders the same file the viewer
rendered (field + overlay), and reopening the session switches the overlay on and heard."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pytestqt")
pytest.importorskip("pyvistaqt")
from qtpy import QtWidgets

from auralize.audio import read_wav
from auralize.cli import main
from auralize.listener import ListenerPath


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):  # type: ignore[no-untyped-def]
    from auralize.viewer.app import MainWindow

    shown: list[str] = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "critical",
                        lambda *a, **k: shown.append(a[2]) or QtWidgets.QMessageBox.StandardButton.Ok)  # fmt: skip
    win = MainWindow(autosave_dir=tmp_path / "autosave")
    qtbot.addWidget(win)
    win.resize(900, 650)
    win.show()
    qtbot.waitExposed(win)
    yield win, shown
    win.close()


def _render(qtbot, win, shown: list[str], out: Path) -> np.ndarray:  # type: ignore[no-untyped-def]
    win.rendered = None
    win.render_audio(out)
    qtbot.waitUntil(lambda: (win.rendered is not None and not win.busy) or bool(shown),
                    timeout=600_000)  # fmt: skip
    assert not shown
    return np.array(win.rendered.audio)


def test_a_saved_session_keeps_the_fire_overlay_heard(qtbot, window, tmp_path) -> None:  # type: ignore[no-untyped-def]
    win, shown = window
    win.open_data("dataset:fire", size=12)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=300_000)
    win.detect()
    qtbot.waitUntil(lambda: win.series is not None and not win.busy, timeout=300_000)
    csv = tmp_path / "p.csv"
    ListenerPath.point(win.volume.center + [0.0, -1.0, 0.0], duration=0.3).to_csv(csv)
    win.load_path(csv)
    plain = _render(qtbot, win, shown, tmp_path / "plain.wav")
    result: list[bool] = []
    win.set_overlay("fire", True, then=result.append)
    qtbot.waitUntil(lambda: bool(result) and "fire" in win._overlay_sounds, timeout=300_000)
    heard = _render(qtbot, win, shown, tmp_path / "fire.wav")
    assert np.max(np.abs(heard - plain)) > 1e-3 * np.max(np.abs(heard))  # the fire is heard

    session = tmp_path / "s.json"
    win.save_session(session)
    doc = json.loads(session.read_text())
    assert doc["view"]["overlays"] == ["fire"]
    assert doc["models"] == [{"model": "fire", "input": doc["data"], "params": {}}]

    # the command line renders what the viewer rendered (the viewer's field has no high-pass)
    out = tmp_path / "cli.wav"
    assert main(["render", "--scene", str(session), "--highpass", "0", "--normalize", "none",
                 "-o", str(out)]) == 0  # fmt: skip
    audio, rate, _ = read_wav(out)
    assert rate == win.audio["rate"] and audio.shape == heard.shape
    assert np.max(np.abs(audio - heard)) <= 1e-5 * np.max(np.abs(heard))
    side = json.loads(Path(f"{out}.json").read_text())
    assert [p["model"] for p in side["parts"]] == ["field", "fire"]

    # reopening the session switches the overlay on again, and it is heard
    win.set_overlay("fire", False)
    win.overlay_checks["fire"].setChecked(False)
    assert win.overlay_sound() is None
    loaded: list[bool] = []
    win.load_session(session, then=lambda: loaded.append(True))
    qtbot.waitUntil(lambda: bool(loaded) and "fire" in win._overlay_sounds and not win.busy,
                    timeout=600_000)  # fmt: skip
    assert win.overlay_checks["fire"].isChecked() and "fire" in win.scene.overlays
    again = _render(qtbot, win, shown, tmp_path / "again.wav")
    assert np.max(np.abs(again - heard)) <= 1e-9 * np.max(np.abs(heard))
    assert not shown
