"""Head tracking over OSC: the conventions of the angles and quaternions, the messages
SPARTA and the IEM plug-ins send, and a live binaural render on a file-backed ALSA
device that turns with the head."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from auralize.audio.headtrack import HeadOrientation, OSCHeadTracker, quaternion_matrix, ypr_matrix
from auralize.errors import ParameterError

ROOT = Path(__file__).parents[1]
FWD, LEFT, UP = np.eye(3)


@pytest.mark.parametrize(
    ("ypr", "axis", "goes_to"),
    [
        ((90, 0, 0), FWD, LEFT),  # yaw: the nose turns to the left
        ((0, 90, 0), FWD, UP),  # pitch: the nose goes up
        ((0, 0, 90), UP, -LEFT),  # roll: the top of the head goes right (right ear down)
        ((90, 0, 0), LEFT, -FWD),
    ],
)
def test_angle_conventions(ypr, axis, goes_to) -> None:  # type: ignore[no-untyped-def]
    assert np.allclose(ypr_matrix(*ypr) @ axis, goes_to, atol=1e-12)


def test_quaternions_are_the_same_rotations() -> None:
    s = np.sqrt(0.5)
    assert np.allclose(quaternion_matrix(s, 0, 0, s), ypr_matrix(90, 0, 0), atol=1e-12)
    assert np.allclose(quaternion_matrix(2 * s, 0, 0, 2 * s), ypr_matrix(90, 0, 0), atol=1e-12)
    # yaw 30, pitch 20, roll 10 as one quaternion: the product of the three
    half = np.radians([30, 20, 10]) / 2
    qz = np.array([np.cos(half[0]), 0, 0, np.sin(half[0])])
    qy = np.array([np.cos(half[1]), 0, -np.sin(half[1]), 0])  # nose up: about -y
    qx = np.array([np.cos(half[2]), np.sin(half[2]), 0, 0])

    def mul(a, b):  # type: ignore[no-untyped-def]
        w1, x1, y1, z1 = a
        w2, x2, y2, z2 = b
        return np.array(
            [
                w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
            ]
        )

    q = mul(mul(qz, qy), qx)
    assert np.allclose(quaternion_matrix(*q), ypr_matrix(30, 20, 10), atol=1e-12)
    with pytest.raises(ParameterError, match="finite and non-zero"):
        quaternion_matrix(0, 0, 0, 0)


def test_apply_turns_the_listener_frame() -> None:
    head = HeadOrientation()
    f, u = head.apply((1.0, 0.0, 0.0), (0.0, 0.0, 2.0))  # identity (up normalised)
    assert np.allclose(f, [1, 0, 0]) and np.allclose(u, [0, 0, 1])
    head.set_ypr(0, 0, 0)
    head.set_angle("yaw", -90.0)  # a quarter to the right: facing -y
    f, u = head.apply((1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    assert np.allclose(f, [0, -1, 0], atol=1e-12) and np.allclose(u, [0, 0, 1])
    assert head.version == 2
    with pytest.raises(ParameterError, match="one of"):
        head.set_angle("tilt", 3.0)


def _wait(cond, seconds: float = 5.0) -> bool:  # type: ignore[no-untyped-def]
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.01)
    return False


def send_osc(port: int, address: str, values: list[float]) -> None:
    """Send one OSC message to ``port`` on this machine, as a head tracker does (the
    socket closed after it: python-osc's client has ``close`` only from 1.10 on)."""
    from pythonosc.osc_message_builder import OscMessageBuilder

    message = OscMessageBuilder(address=address)
    for value in values:
        message.add_arg(value)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.sendto(message.build().dgram, ("127.0.0.1", port))


def test_osc_messages_of_sparta_and_iem_set_the_head() -> None:
    with OSCHeadTracker(port=0) as tracker:

        def send(address: str, values: list[float]) -> None:
            send_osc(tracker.port, address, values)

        send("/SceneRotator/ypr", [90.0, 0.0, 0.0])
        assert _wait(lambda: tracker.received == 1)
        assert np.allclose(tracker.matrix, ypr_matrix(90, 0, 0))
        send("/SceneRotator/quaternions", [np.sqrt(0.5), 0.0, 0.0, -np.sqrt(0.5)])
        assert _wait(lambda: tracker.received == 2)
        assert np.allclose(tracker.matrix, ypr_matrix(-90, 0, 0), atol=1e-7)
        send("/ypr", [0.0, 10.0, 0.0])  # SPARTA's
        send("/roll", [5.0])
        assert _wait(lambda: tracker.received == 4)
        assert np.allclose(tracker.matrix, ypr_matrix(0, 10, 5), atol=1e-7)
        send("/volume", [0.5])  # not an orientation: ignored
        send("/ypr", [1.0, 2.0])  # wrong count: ignored
        assert _wait(lambda: tracker.ignored == 2)
        assert tracker.received == 4


def test_a_port_in_use_is_a_clear_error() -> None:
    from auralize.errors import DeviceError

    with OSCHeadTracker(port=0) as tracker, pytest.raises(DeviceError, match="cannot listen"):
        OSCHeadTracker(port=tracker.port)


ASOUNDRC = """
pcm.auralize_head2 {{
    type file
    slave.pcm "null"
    file "{out}"
    format "raw"
}}
"""

LIVE = """
import json, socket, time
import numpy as np
from pythonosc.osc_message_builder import OscMessageBuilder
from auralize.audio.headtrack import OSCHeadTracker
from auralize.scene.listening import DeviceSink, LiveEngine, LivePlayer
from auralize.sources import SourceTracks

fk = 16000.0
t = np.arange(int(3.0 * fk)) / fk
# a 3 kHz tone 4 m straight ahead of the listener (who faces +y)
tracks = SourceTracks(np.array([[0.0, 4.0, 0.0]]), np.sin(2 * np.pi * 3000 * t)[None],
                      np.array([0.1]), t)
warm = LiveEngine(tracks, layout="binaural", block=2205)  # compiled before playing
warm.set_pose((0, 0, 0), (0, 1, 0), (0, 0, 1))
warm.next_block()
tracker = OSCHeadTracker(port=0)
eng = LiveEngine(tracks, layout="binaural", block=2205, loop=True, highpass_hz=0.0,
                 head=tracker)
player = LivePlayer(eng, DeviceSink(rate=44100, channels=2, device="auralize_head2"))
player.set_pose((0, 0, 0), (0, 1, 0), (0, 0, 1))
player.start()
def play_until(n):
    while len(eng.heard_rows) < n and player.running:
        time.sleep(0.01)
play_until(10)
message = OscMessageBuilder(address="/SceneRotator/ypr")
for value in (90.0, 0.0, 0.0):
    message.add_arg(value)
with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
    sock.sendto(message.build().dgram, ("127.0.0.1", tracker.port))
while tracker.received < 1:
    time.sleep(0.005)
n_turn = len(eng.heard_rows)
play_until(n_turn + 10)
player.stop()
tracker.close()
facing = [list(row[4:7]) for row in eng.heard_rows]
print(json.dumps({"error": repr(player.error), "n_turn": n_turn, "facing": facing}))
"""


def test_live_binaural_turns_with_the_head_on_a_file_backed_device(tmp_path: Path) -> None:
    """A head turned 90° to the left (IEM SceneRotator's message) brings a source
    that was straight ahead to the right ear: the right channel, equal to the left
    before, is several dB louder after, from the block after the message on."""
    cfg = tmp_path / "cfg"
    (cfg / "alsa").mkdir(parents=True)
    out = tmp_path / "head.raw"
    (cfg / "alsa" / "asoundrc").write_text(ASOUNDRC.format(out=out))
    env = {**os.environ, "XDG_CONFIG_HOME": str(cfg), "PYTHONPATH": str(ROOT)}
    res = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(LIVE)],
        capture_output=True,
        text=True,
        env=env,
        timeout=180,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    rep = json.loads(res.stdout.strip().splitlines()[-1])
    assert rep["error"] == "None"
    facing = np.array(rep["facing"])
    assert np.allclose(facing[0], [0, 1, 0]) and np.allclose(facing[-1], [-1, 0, 0], atol=1e-9)
    first_turned = int(np.argmax(np.isclose(facing[:, 0], -1.0)))
    assert first_turned <= rep["n_turn"] + 1
    dev = np.fromfile(out, dtype="<f4").reshape(-1, 2).T.astype(np.float64)
    n = dev.shape[1] // 2205
    e = (dev[:, : n * 2205].reshape(2, n, 2205) ** 2).sum(axis=2)  # (ears, blocks)
    ratio_db = 10 * np.log10(e[1] / e[0])  # right over left
    before = ratio_db[2 : first_turned - 1]
    after = ratio_db[first_turned + 1 :]
    assert before.size >= 3 and after.size >= 3
    assert np.all(np.abs(before) < 1.0), before  # ahead: both ears alike
    assert np.all(after > 6.0), after  # on the right now


def test_viewer_live_listening_follows_a_head_tracker(open_viewer, qtbot, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``auralize view --head-tracking PORT``: live listening opens the port, names it in
    the Live panel, and turns the listener's head by the messages it receives."""
    pytest.importorskip("pytestqt")

    win, _ = open_viewer()
    win.head_tracking_port = 0  # any free port
    win.open_data("dataset:monopole", size=12, steps=60)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    win.ts_spin.setValue(40.0)  # the data's sound in the audible range
    c = np.asarray(win.volume.center)
    cam = win.plotter.camera  # 4 m from the data, looking at it
    cam.position, cam.focal_point, cam.up = tuple(c + [4.0, 1.0, 0.5]), tuple(c), (0.0, 0.0, 1.0)
    player = win.start_live(tmp_path / "live.wav")
    try:
        tracker = win.head_tracker()
        assert player.engine.head is tracker and tracker.port > 0
        assert f"head tracking on UDP port {tracker.port}" in win.live_label.text()
        send_osc(tracker.port, "/SceneRotator/ypr", [90.0, 0.0, 0.0])
        qtbot.waitUntil(lambda: tracker.received == 1, timeout=5_000)
        n = len(player.engine.heard_rows)
        qtbot.waitUntil(lambda: len(player.engine.heard_rows) > n + 1, timeout=30_000)
        cam_fwd = np.asarray(win._cam_pose[1])
        cam_up = np.asarray(win._cam_pose[2])
        heard_fwd = np.asarray(player.engine.heard_rows[-1][4:7])
        # the head faces the camera's left now
        assert np.allclose(heard_fwd, np.cross(cam_up, cam_fwd) / np.linalg.norm(cam_up), atol=1e-6)
    finally:
        win.stop_live()
