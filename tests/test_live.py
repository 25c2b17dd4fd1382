"""Live playback: the blocks of the one render (``render(..., block=N)``) equal the
offline render; what a file-backed ALSA device receives matches the offline render
with no underruns."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from auralize.emitters import FieldSources
from auralize.emitters.synthesis import render_tracks
from auralize.errors import DeviceError, ParameterError
from auralize.listener import ListenerPath
from auralize.pipeline import render
from auralize.sources import SourceTracks
from auralize.spatial import downmix_matrix

ROOT = Path(__file__).parents[1]

SCENE = """
import numpy as np
from auralize.listener import ListenerPath
from auralize.sources import SourceTracks

def scene():
    fk = 4000.0
    t = np.arange(int(2.4 * fk)) / fk
    q = np.stack([np.sin(2 * np.pi * 220 * t), 0.5 * np.sin(2 * np.pi * 330 * t + 1.0)])
    tracks = SourceTracks(np.array([[4.0, 0.5, 0.0], [-1.0, 3.0, 1.0]]), q,
                          np.array([0.1, 0.1]), t)
    # the listener walks and turns a half circle: panning changes all the time
    path = ListenerPath.orbit((0, 0, 0), radius=1.0, duration=2.0, turns=0.5, face="forward")
    return tracks, path
"""

ASOUNDRC = """
pcm.auralize_file8 {{
    type file
    slave.pcm "null"
    file "{out8}"
    format "raw"
}}
pcm.auralize_file2 {{
    type file
    slave.pcm "null"
    file "{out2}"
    format "raw"
}}
"""

PLAYER = """
import json, sys
from auralize.audio.live import play
from auralize.pipeline import render
tracks, path = scene()
# the null device is unpaced (it asks for the next block as soon as it has the last),
# so the callback may wait up to 1 s for the worker on this shared 2-core machine
blocks = render(tracks, path, layout="ring8", block=2205)
r8 = play(blocks, device="auralize_file8", gain=2.0, wait_s=1.0)
blocks = render(tracks, path, layout="ring8", block=2205)
r2 = play(blocks, device="auralize_file2", gain=2.0, downmix="stereo", wait_s=1.0)
print(json.dumps([r8.as_dict(), r2.as_dict()]))
"""


def _scene() -> tuple[SourceTracks, ListenerPath]:
    ns: dict[str, object] = {}
    exec(SCENE, ns)
    return ns["scene"]()  # type: ignore[operator, no-any-return]


def _aligned_corr(dev: np.ndarray, ref: np.ndarray) -> tuple[float, int]:
    """Correlation of the device's frames with the reference, aligned at their first
    sound (PortAudio may prime the device with silence first)."""
    first_d = int(np.argmax(np.any(dev != 0, axis=0)))
    first_r = int(np.argmax(np.any(ref != 0, axis=0)))
    lag = first_d - first_r
    assert 0 <= lag <= 44100, lag
    d = dev[:, lag : lag + ref.shape[1]]
    return float(np.corrcoef(d.ravel(), ref[:, : d.shape[1]].ravel())[0, 1]), lag


def test_block_synthesis_equals_offline() -> None:
    """The blocks live playback plays are the offline render's samples, in order or
    asked for out of order (a seek), with or without the output high-pass."""
    tracks, path = _scene()
    off = render_tracks(tracks, path, layout="ring8").audio
    blocks = render(tracks, path, layout="ring8", block=2205, highpass_hz=0.0)
    on = np.concatenate([blocks.block(i) for i in range(blocks.n_blocks)], axis=1)
    assert on.shape == off.shape == (8, 88200)
    assert np.max(np.abs(on - off)) <= 1e-5 * np.max(np.abs(off))
    seek = render(tracks, path, layout="ring8", block=2205, highpass_hz=0.0)
    assert np.max(np.abs(seek.block(20) - off[:, 20 * 2205 : 21 * 2205])) <= 1e-5 * np.max(
        np.abs(off)
    )
    filtered = render(tracks, path, layout="ring8").audio  # the 20 Hz high-pass of `play`
    blocks = render(tracks, path, layout="ring8", block=2205)
    on = np.concatenate([blocks.block(i) for i in range(blocks.n_blocks)], axis=1)
    assert np.max(np.abs(on - filtered)) <= 1e-5 * np.max(np.abs(filtered))
    assert np.max(np.abs(filtered - off)) > 1e-3 * np.max(np.abs(off))  # it did filter
    with pytest.raises(ParameterError, match=r"block index 40 outside 0\.\.39"):
        blocks.block(40)


def test_block_synthesis_with_a_lead_equals_offline() -> None:
    """A far listener: the output starts after the skipped travel time, block by block too."""
    tracks, path = _scene()
    far = ListenerPath(path.times, path.positions + [60.0, 0.0, 0.0], path.forward, path.up)
    lead = 6429 / 44100  # ~50 m / c0, a whole number of samples
    off = render_tracks(tracks, far, layout="stereo", lead=lead).audio
    blocks = render(
        FieldSources(tracks, lead=lead), far, layout="stereo", block=4410, highpass_hz=0.0
    )
    on = np.concatenate([blocks.block(i) for i in range(blocks.n_blocks)], axis=1)
    assert on.shape == off.shape and np.max(np.abs(off)) > 0
    assert np.max(np.abs(on - off)) <= 1e-5 * np.max(np.abs(off))
    # for a static listener the lead moves the sound earlier by exactly its samples
    still = ListenerPath.point([60.0, 0.0, 0.0], duration=1.0)
    led = render_tracks(tracks, still, layout="stereo", lead=lead).audio
    plain = render_tracks(tracks, still, layout="stereo", duration=1.0 + lead).audio
    k = round(lead * 44100)
    assert np.max(np.abs(plain[:, k : k + 44100] - led[:, :44100])) <= 1e-3 * np.max(np.abs(led))


def test_live_playback_on_file_backed_alsa_device(tmp_path) -> None:  # type: ignore[no-untyped-def]
    cfg = tmp_path / "cfg"
    (cfg / "alsa").mkdir(parents=True)
    out8, out2 = tmp_path / "dev8.raw", tmp_path / "dev2.raw"
    (cfg / "alsa" / "asoundrc").write_text(ASOUNDRC.format(out8=out8, out2=out2))
    env = {**os.environ, "XDG_CONFIG_HOME": str(cfg), "PYTHONPATH": str(ROOT)}
    code = textwrap.dedent(SCENE) + textwrap.dedent(PLAYER)
    res = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert res.returncode == 0, res.stderr[-3000:]
    r8, r2 = json.loads(res.stdout.strip().splitlines()[-1])
    for r in (r8, r2):
        assert r["underruns"] == 0 and r["device_underflows"] == 0
        assert r["blocks"] == 40 and r["gain_changes"] == 0
    assert r8["channels"] == 8 and r2["channels"] == 2 and r2["output_layout"] == "stereo"
    tracks, path = _scene()
    ref = 2.0 * render(tracks, path, layout="ring8").audio
    # the file plugin stores the float32 frames the device was given, interleaved
    dev8 = np.fromfile(out8, dtype="<f4").reshape(-1, 8).T.astype(np.float64)
    assert dev8.shape[1] >= ref.shape[1]
    corr, lag = _aligned_corr(dev8, ref)
    assert corr >= 0.99, (corr, lag)
    d = dev8[:, lag : lag + ref.shape[1]]
    assert np.max(np.abs(d - ref)) <= 1e-4 * np.max(np.abs(ref))  # float32 exact
    dev2 = np.fromfile(out2, dtype="<f4").reshape(-1, 2).T.astype(np.float64)
    ref2 = downmix_matrix("ring8", "stereo") @ ref
    corr2, _ = _aligned_corr(dev2, ref2)
    assert corr2 >= 0.99


@pytest.fixture
def alsa_device(tmp_path, monkeypatch):  # type: ignore[no-untyped-def]
    from auralize.audio import refresh_devices

    cfg = tmp_path / "cfg"
    (cfg / "alsa").mkdir(parents=True)
    (cfg / "alsa" / "asoundrc").write_text(
        ASOUNDRC.format(out8=tmp_path / "a.raw", out2=tmp_path / "b.raw")
    )
    monkeypatch.setenv("XDG_CONFIG_HOME", str(cfg))
    refresh_devices()
    yield tmp_path
    monkeypatch.undo()
    refresh_devices()


def test_stream_reports_underruns_and_bad_blocks(alsa_device) -> None:  # type: ignore[no-untyped-def]
    import time

    from auralize.audio.live import open_stream

    s = open_stream(
        rate=44100, channels=2, device="auralize_file2", block=441, prefill_s=0.01, wait_s=0.005
    )  # (not the test session's patient callback)
    with pytest.raises(ParameterError, match=r"block must be \(2, n\), got shape \(3, 10\)"):
        s.write(np.zeros((3, 10)))
    s.write(np.full((2, 882), 0.1))  # 20 ms, then the producer stalls
    time.sleep(0.3)
    s.write(np.full((2, 882), 0.1))
    st = s.close()
    assert st.underruns >= 1 and st.underrun_times[0] == pytest.approx(0.02, abs=0.011)
    with pytest.raises(DeviceError, match="write after close"):
        s.write(np.zeros((2, 10)))


def test_play_errors(alsa_device) -> None:  # type: ignore[no-untyped-def]
    from auralize.audio.live import play

    tracks, path = _scene()
    blocks = render(tracks, path, layout="ring8", block=2205)
    with pytest.raises(DeviceError, match=r"device index 42 is out of range"):
        play(blocks, device=42)
    with pytest.raises(ParameterError, match="gain must be 'auto' or a positive number"):
        play(blocks, device="auralize_file8", gain=-1.0)
    # what is heard is rendered by the one render first, then played
    with pytest.raises(
        ParameterError,
        match=r"play plays the blocks of a render, not a SourceTracks .*"
        r"auralize\.pipeline\.render\(sound, path, block=N",
    ):
        play(tracks, device="auralize_file8")


VIEWER_LIVE = """
import json, time
import numpy as np
from auralize.sources import SourceTracks
from auralize.scene.listening import DeviceSink, LiveEngine, LivePlayer

fk = 4000.0
t = np.arange(int(2.4 * fk)) / fk
tracks = SourceTracks(np.array([[4.0, 0.0, 0.0]]), np.sin(2 * np.pi * 220 * t)[None],
                      np.array([0.1]), t)
# compile the synthesis kernels first (a fresh checkout has no numba cache yet), so that
# blocks are played on both sides of the turn
warm = LiveEngine(tracks, layout="ring8", block=2205)
warm.set_pose((0, 0, 0), (0, 1, 0), (0, 0, 1))
warm.next_block()
eng = LiveEngine(tracks, layout="ring8", block=2205, loop=True)
sink = DeviceSink(rate=44100, channels=8, device="auralize_file8")
player = LivePlayer(eng, sink)
player.set_pose((0, 0, 0), (0, 1, 0), (0, 0, 1))  # source at +x: on the right (channel 6)
player.start()
def play_until(n_blocks):  # however long the machine takes for them
    while len(eng.heard_rows) < n_blocks and player.running:
        time.sleep(0.01)
play_until(12)
player.set_pose((0, 0, 0), (0, -1, 0), (0, 0, 1))  # turned round: now on the left (channel 2)
n_turn = len(eng.heard_rows)  # blocks rendered when the turn was made, or more
play_until(n_turn + 12)
player.stop()
facing = [row[5] for row in eng.heard_rows]  # forward y of each block
print(json.dumps({"latencies": player.latencies, "error": repr(player.error),
                  "n_turn": n_turn, "first_turned": facing.index(-1.0)}))
"""


def test_viewer_live_listening_on_file_backed_alsa_device(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A camera turn during live playback moves the energy across the ring8
    channels the device receives, from the block after the one in progress on (the
    latency in milliseconds is a row of ``auralize bench``)."""
    cfg = tmp_path / "cfg"
    (cfg / "alsa").mkdir(parents=True)
    out8 = tmp_path / "dev8.raw"
    (cfg / "alsa" / "asoundrc").write_text(ASOUNDRC.format(out8=out8, out2=tmp_path / "x.raw"))
    env = {**os.environ, "XDG_CONFIG_HOME": str(cfg), "PYTHONPATH": str(ROOT)}
    res = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(VIEWER_LIVE)],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    rep = json.loads(res.stdout.strip().splitlines()[-1])
    assert rep["error"] == "None"
    assert len(rep["latencies"]) == 2  # the first pose and the turn were both heard
    assert rep["first_turned"] <= rep["n_turn"] + 1
    dev = np.fromfile(out8, dtype="<f4").reshape(-1, 8).T.astype(np.float64)
    blocks = dev[:, : dev.shape[1] // 2205 * 2205].reshape(8, -1, 2205)
    e = (blocks**2).sum(axis=2)  # (8, n_blocks)
    loud = e.sum(axis=0) > 1e-3 * e.sum(axis=0).max()
    dominant = np.argmax(e[:, loud], axis=0)
    assert dominant[0] == 6 and dominant[-1] == 2, dominant
    # after the turn the energy has moved by four speakers and stays there
    # (at most one block in between, where the turn happens)
    switch = int(np.argmax(dominant == 2))
    assert np.all(dominant[switch:] == 2)
    assert np.sum(dominant[:switch] != 6) <= 1


def test_play_command_defaults(alsa_device, capsys) -> None:  # type: ignore[no-untyped-def]
    """`auralize play` without a listener: default orbit, automatic time scale, high-pass."""
    from auralize.cli import main

    assert (
        main(
            [
                "play",
                "dataset:monopole",
                "--size",
                "12",
                "--steps",
                "60",
                "--layout",
                "stereo",
                "--device",
                "auralize_file2",
                "--duration",
                "0.5",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "listener: orbit of radius" in out
    assert "1 s of playback = " in out and "(auto)" in out
    raw = (alsa_device / "b.raw").read_bytes()
    assert len(raw) > 0 and any(raw)
