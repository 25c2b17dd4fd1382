"""A viewer overlay's sound is kept by the saved session: the session lists it among its
sound models, ``auralize render --scene SESSION.json`` with its default options renders
the same file the viewer rendered (field high-passed at 20 Hz + overlay), and reopening
the session switches the overlay on and heard."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pytestqt")
pytest.importorskip("pyvistaqt")

from auralize.audio import read_wav
from auralize.cli import main
from auralize.listener import ListenerPath


@pytest.fixture
def window(open_viewer):  # type: ignore[no-untyped-def]
    return open_viewer()


def test_a_saved_session_keeps_the_fire_overlay_heard(
    qtbot, window, tmp_path, render_in_viewer
) -> None:  # type: ignore[no-untyped-def]
    win, shown = window
    win.open_data("dataset:fire", size=12)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=300_000)
    win.detect()
    qtbot.waitUntil(lambda: win.series is not None and not win.busy, timeout=300_000)
    csv = tmp_path / "p.csv"
    ListenerPath.point(win.volume.center + [0.0, -1.0, 0.0], duration=0.3).to_csv(csv)
    win.load_path(csv)
    plain = render_in_viewer(win, shown, tmp_path / "plain.wav")
    result: list[bool] = []
    win.set_overlay("fire", True, then=result.append)
    qtbot.waitUntil(lambda: bool(result) and "fire" in win._overlay_sounds, timeout=300_000)
    heard = render_in_viewer(win, shown, tmp_path / "fire.wav")
    assert np.max(np.abs(heard - plain)) > 1e-3 * np.max(np.abs(heard))  # the fire is heard

    session = tmp_path / "s.json"
    win.save_session(session)
    doc = json.loads(session.read_text())
    assert doc["view"]["overlays"] == ["fire"]
    assert doc["models"] == [{"model": "fire", "input": doc["data"], "params": {}}]

    # the command line with its default options renders what the viewer rendered: the
    # same 20 Hz high-pass of the volume's sources, recorded in both sidecars
    viewer_side = json.loads(Path(f"{tmp_path / 'fire.wav'}.json").read_text())
    assert viewer_side["highpass_hz"] == 20.0
    out = tmp_path / "cli.wav"
    assert main(["render", "--scene", str(session), "--normalize", "none", "-o", str(out)]) == 0
    audio, rate, _ = read_wav(out)
    assert rate == win.audio["rate"] and audio.shape == heard.shape
    assert np.max(np.abs(audio - heard)) <= 1e-5 * np.max(np.abs(heard))
    side = json.loads(Path(f"{out}.json").read_text())
    assert [p["model"] for p in side["parts"]] == ["field", "fire"]
    assert side["highpass_hz"] == 20.0
    # without the high-pass the file differs: the comparison above can fail
    raw = tmp_path / "raw.wav"
    assert (
        main(
            [
                "render",
                "--scene",
                str(session),
                "--highpass",
                "0",
                "--normalize",
                "none",
                "-o",
                str(raw),
            ]
        )
        == 0
    )
    unfiltered, _, _ = read_wav(raw)
    assert np.max(np.abs(unfiltered - heard)) > 1e-3 * np.max(np.abs(heard))

    # reopening the session switches the overlay on again, and it is heard
    win.set_overlay("fire", False)
    win.overlay_checks["fire"].setChecked(False)
    assert win.overlay_sound() is None
    loaded: list[bool] = []
    win.load_session(session, then=lambda: loaded.append(True))
    qtbot.waitUntil(
        lambda: bool(loaded) and "fire" in win._overlay_sounds and not win.busy, timeout=600_000
    )
    assert win.overlay_checks["fire"].isChecked() and "fire" in win.scene.overlays
    again = render_in_viewer(win, shown, tmp_path / "again.wav")
    assert np.max(np.abs(again - heard)) <= 1e-9 * np.max(np.abs(heard))
    assert not shown
