"""auralize.simple scripting, ``auralize view --screenshot`` and live listening."""

from __future__ import annotations

import time

import numpy as np
import pytest
from PIL import Image

from auralize.cli import main
from auralize.errors import FieldError, FormatError, ListenerPathError, ParameterError
from auralize.scene.view import PATH_COLOR, TYPE_COLORS
from auralize.simple import (
    ApplyMapping,
    CreateListenerPath,
    DetectSources,
    GetActiveSource,
    GetActiveView,
    GetSession,
    Hide,
    LoadSession,
    OpenDataFile,
    RecordListenerPath,
    RenderAudio,
    ResetSession,
    SaveScreenshot,
    SaveSession,
    SetActiveSource,
    Show,
)

SMALL = {"size": 24, "steps": 6}


def _hue_pixels(img: np.ndarray, rgb: tuple[int, int, int]) -> int:
    """Pixels whose colour direction matches ``rgb`` (shading scales all channels alike)."""
    a = img[..., :3].astype(float)
    n = np.linalg.norm(a, axis=-1) + 1e-9
    c = np.asarray(rgb, float) / np.linalg.norm(rgb)
    cos = (a @ c) / n
    return int(np.count_nonzero((cos > 0.985) & (n > 60)))


@pytest.fixture(autouse=True)
def fresh_session():
    ResetSession()
    yield
    ResetSession()


def test_screenshot_command_shows_sources_and_path(tmp_path, capsys):
    csv = tmp_path / "path.csv"
    # a path above the blast (not hidden behind the spheres)
    csv.write_text("t,x,y,z\n0,3,3,20\n1,20,3,20\n2,20,20,20\n3,3,20,20\n")
    out = tmp_path / "shot.png"
    rc = main(
        [
            "view",
            "dataset:explosion",
            "--size",
            "24",
            "--steps",
            "6",
            "--time",
            "3",
            "--detect",
            "--path",
            str(csv),
            "--screenshot",
            str(out),
            "--window-size",
            "640x480",
        ]
    )
    assert rc == 0 and f"wrote {out}" in capsys.readouterr().out
    with Image.open(out) as im:
        img = np.asarray(im)
    assert img.shape[:2] == (480, 640)
    scene = img[:, : int(0.7 * 640)]  # leave out the legend (top right)
    assert scene.std() > 10  # not blank
    for kind, rgb in TYPE_COLORS.items():
        assert _hue_pixels(scene, rgb) > 20, kind
    assert _hue_pixels(scene, PATH_COLOR) > 20
    # without the path: no path colour in the scene
    out2 = tmp_path / "nopath.png"
    main(
        [
            "view",
            "dataset:explosion",
            "--size",
            "24",
            "--steps",
            "6",
            "--time",
            "3",
            "--screenshot",
            str(out2),
            "--window-size",
            "640x480",
        ]
    )
    with Image.open(out2) as im:
        scene2 = np.asarray(im)[:, : int(0.7 * 640)]
    assert _hue_pixels(scene2, PATH_COLOR) < 5


def test_scripting_session(tmp_path):
    src = OpenDataFile("dataset:explosion", **SMALL)
    assert GetActiveSource() is src
    view = Show(src, step=2)
    assert GetActiveView() is view and view.ViewTime == 2
    c = src.Volume.center
    path = RecordListenerPath(
        [
            {"position": c + [6, 0, 1], "focal_point": c},
            {"position": c + [0, 6, 1], "focal_point": c},
        ],
        duration=1.0,
        rate_hz=10,
        autosave=tmp_path / "rec.csv",
    )
    assert path.n_captures == 11
    assert np.allclose(path.positions[0], c + [6, 0, 1]) and np.allclose(
        path.positions[-1], c + [0, 6, 1]
    )
    assert np.allclose(path.forward[0], [-1, 0, -1 / 6] / np.linalg.norm([-1, 0, -1 / 6]))
    saved = np.loadtxt(tmp_path / "rec.csv", delimiter=",", skiprows=1)
    assert np.allclose(saved[:, 1:4], path.positions)
    png = SaveScreenshot(tmp_path / "v.png", resolution=(320, 240))
    with Image.open(png) as im:
        assert im.size == (320, 240)
    Hide("path")
    series = DetectSources()
    assert series.n_steps == 6
    r = RenderAudio(layout="stereo", time_scale=1.0 / src.Volume.times[-1])
    assert r.audio.shape == (2, 44100) and np.max(np.abs(r.audio)) > 0
    f = SaveSession(tmp_path / "s.json")
    cam = view.CameraPosition
    s = LoadSession(f)
    assert s is GetSession() and s.path is not None
    assert np.allclose(s.path.positions, path.positions)
    assert np.allclose(s.active_view.CameraPosition, cam)
    assert s.audio["layout"] == "stereo"
    other = OpenDataFile("dataset:monopole", size=10, steps=20)
    SetActiveSource(src)
    assert GetActiveSource() is src and other in GetSession().sources


def test_script_errors_are_library_exceptions(tmp_path):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not hdf5")
    with pytest.raises(FormatError, match="bad.h5"):
        OpenDataFile(bad)
    OpenDataFile("dataset:explosion", **SMALL)
    with pytest.raises(FieldError, match="pressure"):
        ApplyMapping("identity", density="pressure")
    with pytest.raises(FieldError, match="pressure"):
        Show(field="pressure")
    with pytest.raises(ParameterError, match="RenderAudio|listener path"):
        RenderAudio()
    with pytest.raises(FormatError, match="nope.csv"):
        CreateListenerPath(str(tmp_path / "nope.csv"))
    # a listener outside the grid is heard (far field); one a million km away is a mistake
    CreateListenerPath("line", start=(-50, 0, 0), end=(50, 0, 0), duration=1.0)
    assert np.max(np.abs(RenderAudio().audio)) > 0
    CreateListenerPath("line", start=(-1e9, 0, 0), end=(-1e9, 10, 0), duration=1.0)
    with pytest.raises(ListenerPathError, match="listeners must be within"):
        RenderAudio()


def test_live_listening_follows_pose(tmp_path):
    """A pose change during live playback reaches the (file-backed) sink in the block after the
    one in progress, and moves the energy between the stereo channels.  (The latency in
    milliseconds is a row of ``auralize bench``: live listening, camera move to sound.)"""
    from auralize.pipeline import heard_sound
    from auralize.scene.listening import LiveEngine, LivePlayer, WavSink

    src = OpenDataFile("dataset:explosion", **SMALL)
    tracks = heard_sound(src.Volume).tracks  # what renders hear: the whole field
    c = src.Volume.center
    # (at this time scale the blast is infrasonic: the pan is measured without the high-pass)
    eng = LiveEngine(tracks, layout="stereo", block=1024, time_scale=4.0, highpass_hz=0.0)
    sink = WavSink(tmp_path / "live.wav", rate=44100, channels=2)
    player = LivePlayer(eng, sink)
    # facing +y from the -x side: the blast is on the right
    player.set_pose(c - [8, 0, 0], [0, 1, 0], [0, 0, 1])
    player.start()

    def play_until(n_blocks: int) -> None:  # however long the machine takes for them
        while len(sink.blocks) < n_blocks and player.running:
            time.sleep(0.01)

    play_until(8)
    n_before = len(sink.blocks)
    player.set_pose(c - [8, 0, 0], [0, -1, 0], [0, 0, 1])  # turn round: now on the left
    n_turn = len(sink.blocks)  # blocks accepted by the sink when the turn was made, or more
    play_until(n_turn + 8)
    player.stop()
    assert player.error is None
    assert len(player.latencies) == 2  # the first pose and the turn
    # the block in progress at the turn may still face +y; the next one faces -y
    facing = np.array([row[5] for row in eng.heard_rows[: len(sink.blocks)]])  # forward y
    assert np.all(facing[:n_before] == 1.0) and facing[-1] == -1.0
    assert int(np.argmax(facing == -1.0)) <= n_turn + 1
    blocks = np.stack(sink.blocks)  # (n, 2, block)
    e = (blocks**2).sum(axis=2)
    before = e[: n_before - 1].sum(axis=0)
    after = e[n_before + 1 :].sum(axis=0)
    assert before[1] > before[0]  # right louder (stereo: channel 1 = right)
    assert after[0] > after[1]  # left louder after turning
    heard = eng.heard_path()
    assert heard is not None and np.allclose(heard.forward[-1], [0, -1, 0])
    eng.save_heard(tmp_path / "heard.csv", tmp_path / "heard.wav")
    assert (tmp_path / "live.wav").exists() and (tmp_path / "heard.wav").exists()


def test_default_orbit_around_a_one_layer_grid(tmp_path):
    """A flat (one-layer) grid has a zero side; the default orbit ignores it."""
    from auralize.io import save_volume
    from auralize.volume import TimeVolume

    ResetSession()
    t = np.arange(12) * 1e-3
    for shape in ((1, 8, 8), (8, 1, 8)):
        rho = 1.2 + 1e-3 * np.random.default_rng(0).random((12, *shape))
        f = tmp_path / f"flat{shape[0]}{shape[1]}.h5"
        save_volume(TimeVolume.from_arrays({"density": rho}, spacing=0.5, times=t), f)
        src = OpenDataFile(f)
        path = CreateListenerPath("orbit", duration=1.0)
        r = np.linalg.norm(path.positions[:, :2] - np.asarray(src.Volume.center)[:2], axis=1)
        assert np.allclose(r, 0.3 * 3.5, rtol=1e-6)  # 0.3 × the 3.5 m side, not 0
