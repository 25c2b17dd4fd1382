"""Audible overlays, under Xvfb: switching an overlay on adds exactly its model's
sound to the rendered file along the recorded path and to live listening;
switching it off takes it out again."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

pytest.importorskip("pytestqt")
pytest.importorskip("pyvistaqt")

import auralize.plugins as plugins
from auralize.emitters import Emitters, Sound, render_sound
from auralize.listener import ListenerPath
from auralize.plugins import SoundModel
from auralize.scene.listening import LiveEngine


class BeaconModel(SoundModel):
    """A sine emitter beside the volume's centre, with a sphere as its overlay."""

    name: ClassVar[str] = "beacon"
    description: ClassVar[str] = "a tone beside the data (tests)"
    input_kind: ClassVar[str] = "volume"

    def synthesize(self, inputs: Any, **params: Any) -> Sound:
        t = np.arange(8000) / 8000.0
        em = Emitters(
            0.3 * np.sin(2 * np.pi * 500.0 * t)[None],
            8000.0,
            (np.asarray(inputs.center) + [0.3, 0.0, 0.0])[None],
            name="beacon",
        )
        return Sound(parts=[em], name="beacon")

    def overlay(self, inputs: Any, step: int) -> Any:
        import pyvista as pv

        vol = inputs[0]
        return pv.Sphere(radius=0.05, center=tuple(np.asarray(vol.center) + [0.3, 0.0, 0.0]))


class SilentModel(SoundModel):
    """An overlay whose model makes no sound from a volume."""

    name: ClassVar[str] = "sketch"
    description: ClassVar[str] = "a drawing only (tests)"

    def overlay(self, inputs: Any, step: int) -> Any:
        import pyvista as pv

        return pv.Sphere(radius=0.05, center=tuple(inputs[0].center))


class SlowBeaconModel(BeaconModel):
    """The beacon, whose first synthesis (the viewer's background sound task) waits
    until :attr:`gate` is set: its sound is still being computed."""

    name: ClassVar[str] = "slowbeacon"
    gate = threading.Event()
    calls: ClassVar[list[str]] = []

    def synthesize(self, inputs: Any, **params: Any) -> Sound:
        self.calls.append(threading.current_thread().name)
        if len(self.calls) == 1:
            self.gate.wait(120)
        return super().synthesize(inputs, **params)


@pytest.fixture
def window(open_viewer, monkeypatch):  # type: ignore[no-untyped-def]
    real = plugins.registry()
    monkeypatch.setattr(
        plugins,
        "registry",
        lambda: {
            **real,
            "beacon": BeaconModel,
            "sketch": SilentModel,
            "slowbeacon": SlowBeaconModel,
        },
    )
    return open_viewer()


def test_a_render_never_leaves_out_an_overlay(qtbot, window, tmp_path, render_in_viewer) -> None:  # type: ignore[no-untyped-def]
    """An overlay whose sound is still being computed is computed by the render (so it
    is in the file); an overlay that makes no sound is named, with why, in the status
    bar and the sidecar."""
    import json

    win, shown = window
    win.open_data("dataset:monopole", size=12)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    csv = tmp_path / "p.csv"
    ListenerPath.point(win.volume.center + [0.6, 0.0, 0.0], duration=0.4).to_csv(csv)
    win.load_path(csv)
    result: list[bool] = []
    SlowBeaconModel.calls.clear()
    try:
        win.set_overlay("slowbeacon", True, then=result.append)
        qtbot.waitUntil(lambda: len(result) == 1 and not win.busy, timeout=60_000)
        win.set_overlay("sketch", True, then=result.append)
        qtbot.waitUntil(
            lambda: len(result) == 2 and "sketch" in win._overlay_unheard, timeout=60_000
        )
        assert "slowbeacon" in win._sound_tasks and "slowbeacon" not in win._overlay_sounds
        out = tmp_path / "r.wav"
        render_in_viewer(win, shown, out)
    finally:
        SlowBeaconModel.gate.set()
    side = json.loads(Path(f"{out}.json").read_text())
    assert [p["model"] for p in side["parts"]] == ["field", "beacon"]  # (its sound's name)
    assert side["overlays_not_heard"] == {
        "sketch": "sound model 'sketch' does not implement synthesize"
    }
    msg = win.statusBar().currentMessage()
    assert "field + beacon" in msg and "sketch overlay not heard" in msg
    assert len(SlowBeaconModel.calls) == 2  # the waiting task's, and the render's own
    assert not shown


def test_switching_an_overlay_on_adds_its_sound_to_the_render(
    qtbot, window, tmp_path, render_in_viewer
) -> None:  # type: ignore[no-untyped-def]
    import json

    win, shown = window
    win.open_data("dataset:monopole", size=12)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    win.detect()
    qtbot.waitUntil(lambda: win.series is not None and not win.busy, timeout=60_000)
    csv = tmp_path / "p.csv"
    ListenerPath.line(
        win.volume.center + [0.6, -0.4, 0], win.volume.center + [0.6, 0.4, 0], duration=0.6
    ).to_csv(csv)
    path = win.load_path(csv)
    plain = render_in_viewer(win, shown, tmp_path / "plain.wav")

    result: list[bool] = []
    win.set_overlay("beacon", True, then=result.append)
    qtbot.waitUntil(lambda: bool(result) and "beacon" in win._overlay_sounds, timeout=60_000)
    assert result == [True]
    with_beacon = render_in_viewer(win, shown, tmp_path / "beacon.wav")
    alone = render_sound(
        BeaconModel().synthesize(win.volume),
        path,
        rate=win.audio["rate"],
        layout=win.audio["layout"],
        duration=plain.shape[1] / win.audio["rate"],
    ).audio
    assert with_beacon.shape == plain.shape == alone.shape
    assert np.max(np.abs(alone)) > 0.1 * np.max(np.abs(with_beacon))
    assert np.max(np.abs(with_beacon - (plain + alone))) <= 1e-9 * np.max(np.abs(with_beacon))
    side = json.loads(Path(f"{tmp_path / 'beacon.wav'}.json").read_text())
    assert [p["model"] for p in side["parts"]] == ["field", "beacon"]

    # an overlay without sound is drawn, says so, and changes nothing heard
    win.set_overlay("sketch", True, then=result.append)
    qtbot.waitUntil(lambda: len(result) == 2 and not win._sound_tasks, timeout=60_000)
    assert win.overlay_note.text() == (
        "sketch overlay is shown but not heard: sound model 'sketch' does not implement synthesize"
    )
    assert list(win._overlay_sounds) == ["beacon"]

    # live listening hears it too, and stops hearing it when switched off
    player = win.start_live(output=str(tmp_path / "live.wav"))
    try:
        assert player.engine.extra is not None and player.engine.extra.parts[0].name == "beacon"
        qtbot.waitUntil(lambda: len(player.engine.heard_blocks) >= 3, timeout=30_000)
        assert np.max(np.abs(np.concatenate(player.engine.heard_blocks, axis=1))) > 0
        win.set_overlay("beacon", False)
        assert player.engine.extra is None
    finally:
        win.stop_live()
    again = render_in_viewer(win, shown, tmp_path / "again.wav")
    assert np.array_equal(again, plain)
    assert not shown


def test_live_block_with_an_overlay_sound_is_the_sum() -> None:
    """One live block with an extra sound = the block without it + the engine's render of
    that sound along the block's path."""
    from auralize.sources import SourceTracks

    fk = 4000.0
    t = np.arange(int(0.5 * fk)) / fk
    tracks = SourceTracks(
        np.array([[2.0, 0.0, 0.0]]), np.sin(2 * np.pi * 220 * t)[None], np.array([0.1]), t
    )
    em = Emitters(
        np.cos(2 * np.pi * 330 * np.arange(4000) / 8000.0)[None],
        8000.0,
        np.array([[0.0, 3.0, 0.5]]),
        name="beacon",
    )
    pose = ((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    a = LiveEngine(tracks, layout="stereo", block=1024)
    b = LiveEngine(tracks, layout="stereo", block=1024, extra=Sound([em]))
    for eng in (a, b):
        eng.set_pose(*pose)
    blocks = [(a.next_block(), b.next_block()) for _ in range(3)]
    b.set_extra(None)
    a4, b4 = a.next_block(), b.next_block()
    assert np.array_equal(a4, b4)  # taken out from the next block on
    p = ListenerPath.point(pose[0], duration=1.0)
    ref = render_sound(Sound([em]), p, rate=44100, layout="stereo", duration=3 * 1024 / 44100).audio
    got = np.concatenate([y - x for x, y in blocks], axis=1)
    assert np.max(np.abs(got - ref[:, : got.shape[1]])) <= 1e-9 * np.max(np.abs(ref))


def test_the_fire_front_overlay_is_heard(qtbot, window, tmp_path, render_in_viewer) -> None:  # type: ignore[no-untyped-def]
    """The real fire model: its flame-front overlay adds the fire's sound (paper 001 §3)."""
    from auralize.plugins import synthesize

    win, shown = window
    win.open_data("dataset:fire", size=12)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    win.detect()
    qtbot.waitUntil(lambda: win.series is not None and not win.busy, timeout=60_000)
    csv = tmp_path / "p.csv"
    ListenerPath.point(win.volume.center + [0.0, -1.0, 0.0], duration=0.3).to_csv(csv)
    path = win.load_path(csv)
    plain = render_in_viewer(win, shown, tmp_path / "plain.wav")
    result: list[bool] = []
    win.set_overlay("fire", True, then=result.append)
    qtbot.waitUntil(lambda: bool(result) and "fire" in win._overlay_sounds, timeout=60_000)
    heard = render_in_viewer(win, shown, tmp_path / "fire.wav")
    fire = render_sound(
        synthesize("fire", win.volume),
        path,
        rate=win.audio["rate"],
        layout=win.audio["layout"],
        duration=plain.shape[1] / win.audio["rate"],
    ).audio
    assert np.max(np.abs(fire)) > 0
    assert np.max(np.abs(heard - (plain + fire))) <= 1e-9 * np.max(np.abs(heard))
    assert not shown


def test_an_overlay_switched_on_is_heard_for_newly_opened_data(qtbot, window) -> None:  # type: ignore[no-untyped-def]
    win, shown = window
    win.open_data("dataset:monopole", size=12)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    result: list[bool] = []
    win.set_overlay("beacon", True, then=result.append)
    qtbot.waitUntil(lambda: "beacon" in win._overlay_sounds, timeout=60_000)
    first = win.volume
    win.open_data("dataset:explosion", size=12, steps=4)
    qtbot.waitUntil(lambda: win.volume is not first and not win.busy, timeout=60_000)
    qtbot.waitUntil(
        lambda: win._overlay_sounds.get("beacon", (None,))[0] is win.volume, timeout=60_000
    )
    em = win.overlay_sound().parts[0]
    assert np.allclose(em.positions[0], np.asarray(win.volume.center) + [0.3, 0.0, 0.0])
    assert not shown


def test_the_aero_overlay_says_why_it_is_not_heard(qtbot, window) -> None:  # type: ignore[no-untyped-def]
    """aero declares its inputs (a texture and an object), so the viewer draws its stick
    over the volume and says in one line why it cannot hear it."""
    win, shown = window
    win.open_data("dataset:monopole", size=12)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    result: list[bool] = []
    win.set_overlay("aero", True, then=result.append)
    qtbot.waitUntil(lambda: bool(result) and not win.busy and not win._sound_tasks, timeout=60_000)
    assert result == [True] and "aero" not in win._overlay_sounds
    assert win.overlay_note.text() == (
        "aero overlay is shown but not heard: its model makes sound from a sound texture "
        "and a moving object or wind, not from a volume"
    )
    assert not shown
