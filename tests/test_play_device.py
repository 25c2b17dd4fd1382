"""Play, ``simple.PlayAudio`` and the viewer's Play / live listening on a file-backed ALSA
device: the audio arrives, and never beyond full scale whatever the gain."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from auralize.audio import CEILING, Limiter

ROOT = Path(__file__).parents[1]

ASOUNDRC = """
pcm.auralize_file {{
    type file
    slave.pcm "null"
    file "{a}"
    format "raw"
}}
pcm.auralize_view {{
    type file
    slave.pcm "null"
    file "{b}"
    format "raw"
}}
pcm.auralize_live {{
    type file
    slave.pcm "null"
    file "{c}"
    format "raw"
}}
"""

SCRIPT = """
import json, time
import numpy as np
from auralize.simple import *

ResetSession()
src = OpenDataFile("dataset:monopole", size=12)
path = CreateListenerPath("point", at=src.Volume.center + [1.0, 0, 0], duration=0.4)
r = RenderAudio(path=path, layout="stereo")
pb = PlayAudio(r, device="auralize_file", gain_db=20.0)   # blocking, far too loud
out = {"simple": {"frames": pb.frames_sent, "n": r.audio.shape[1],
                  "limited": pb.limiter.limited_blocks}}

from qtpy import QtWidgets
from auralize.viewer.app import MainWindow
app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
win = MainWindow()
win.show()
def spin(cond, timeout):
    t0 = time.perf_counter()
    while not cond() and time.perf_counter() - t0 < timeout:
        app.processEvents()
        time.sleep(0.01)
    return cond()
win.open_data("dataset:monopole", size=12)
assert spin(lambda: win.volume is not None and not win.busy, 60)
win.detect()
assert spin(lambda: win.series is not None and not win.busy, 60)
win.rendered = r
win.audio["device"] = "auralize_view"
pb2 = win.play_audio()
assert spin(lambda: not pb2.running, 30), "play did not finish"
out["play"] = {"frames": pb2.frames_sent, "error": str(pb2.error) if pb2.error else None}
win.audio["device"] = "auralize_live"
player = win.start_live()
assert spin(lambda: player.engine.elapsed > 0.5 or player.error is not None, 60)
def blocks():
    return round(player.engine.elapsed / player.engine.block_s)  # blocks rendered
n_stop = blocks()
win.stop_live()
n_stopped = blocks()
spin(lambda: False, 0.3)  # events and the device keep running: nothing more is rendered
out["live"] = {"error": repr(player.error), "elapsed": player.engine.elapsed,
               "running": player.running, "after_stop": n_stopped - n_stop,
               "later": blocks() - n_stopped}
win.close()
print(json.dumps(out))
"""


def _raw(path: Path, channels: int) -> np.ndarray:
    return np.fromfile(path, dtype="<f4").reshape(-1, channels).T


def test_limiter_never_exceeds_full_scale() -> None:
    rng = np.random.default_rng(1)
    lim = Limiter(None, gain_db=40.0, rate=8000)
    peaks = []
    for _k in range(50):
        block = rng.normal(scale=10.0 ** rng.uniform(-3, 4), size=(2, 256))
        out = lim.process(block)
        peaks.append(float(np.max(np.abs(out))))
    assert max(peaks) <= np.float32(CEILING)
    assert lim.limited_blocks > 0 and lim.reduction_db < 0
    # the gain reduction recovers when the sound gets quiet again
    quiet = [lim.process(np.full((2, 256), 1e-6)) for _ in range(200)]
    assert lim.reduction_db > -0.1 and np.all(np.isfinite(quiet[-1]))


def test_play_paths_on_file_backed_alsa_device(tmp_path) -> None:  # type: ignore[no-untyped-def]
    pytest.importorskip("pyvistaqt")
    if not os.environ.get("DISPLAY"):
        pytest.skip("needs an X display (pytest-xvfb provides one)")
    cfg = tmp_path / "cfg"
    (cfg / "alsa").mkdir(parents=True)
    a, b, c = tmp_path / "simple.raw", tmp_path / "view.raw", tmp_path / "live.raw"
    (cfg / "alsa" / "asoundrc").write_text(ASOUNDRC.format(a=a, b=b, c=c))
    env = {
        **os.environ,
        "XDG_CONFIG_HOME": str(cfg),
        "PYTHONPATH": str(ROOT),
        "XDG_STATE_HOME": str(tmp_path / "state"),
    }
    res = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(SCRIPT)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    out = json.loads(res.stdout.strip().splitlines()[-1])
    assert out["simple"]["frames"] == out["simple"]["n"] and out["simple"]["limited"] > 0
    assert out["play"] == {"frames": out["simple"]["n"], "error": None}
    assert out["live"]["error"] == "None" and not out["live"]["running"]
    # Stop ends live playback with the block in progress (the time it takes is a row
    # of ``auralize bench``: live listening, Stop)
    assert out["live"]["after_stop"] <= 2 and out["live"]["later"] == 0
    for f in (a, b, c):
        dev = _raw(f, 2)
        assert np.count_nonzero(dev) > 1000, f  # audio arrived
        assert np.max(np.abs(dev)) <= np.float32(CEILING), f  # never beyond full scale
    # Play gives the device the whole render (PortAudio may add leading silence)
    assert _raw(a, 2).shape[1] >= out["simple"]["n"]
