"""``auralize play`` makes the sound ``auralize render`` writes: the same timbre choice
(``--timbre auto`` by default) and the same 20 Hz high-pass (``--highpass 0`` off).
What a file-backed ALSA device receives is compared with the rendered WAV."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from auralize.audio import read_wav
from auralize.cli import main

# the monopole's sound at the automatic time scale lies 100 % below 20 Hz: the
# high-pass and the timbre choice decide what is heard
DATA = ["dataset:monopole", "--size", "12", "--steps", "60", "--threshold-monopole", "1%"]
WHERE = ["--listener", "5,1.4,1.4", "--duration", "0.5", "--layout", "stereo"]
DEVICES = ("hp20", "hp0", "auto", "tonal", "scene", "scene_phys", "json")
ASOUNDRC = "".join(
    f'pcm.live18_{d} {{\n type file\n slave.pcm "null"\n file "{{tmp}}/{d}.raw"\n format "raw"\n}}\n'
    for d in DEVICES
)


@pytest.fixture
def devices(tmp_path, monkeypatch):  # type: ignore[no-untyped-def]
    """File-backed ALSA devices ``live18_<name>`` writing ``<tmp_path>/<name>.raw``."""
    from auralize.audio import refresh_devices

    cfg = tmp_path / "cfg"
    (cfg / "alsa").mkdir(parents=True)
    (cfg / "alsa" / "asoundrc").write_text(ASOUNDRC.replace("{tmp}", str(tmp_path)))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(cfg))
    refresh_devices()
    yield tmp_path
    monkeypatch.undo()
    refresh_devices()


def _render(tmp: Path, name: str, *args: str) -> np.ndarray:
    out = tmp / f"{name}.wav"
    assert main(["render", *args, "--normalize", "none", "-o", str(out)]) == 0
    audio, rate, _ = read_wav(out)
    assert rate == 44100 and np.max(np.abs(audio)) > 0
    return np.asarray(audio, dtype=np.float64)


def _play(tmp: Path, name: str, ref: np.ndarray, capsys, *args: str) -> tuple[np.ndarray, str]:  # type: ignore[no-untyped-def]
    """Play to ``live18_<name>`` at the gain that puts ``ref``'s peak at 0.5; returns the
    device's frames in pascals, aligned with ``ref`` at their first sound, and stdout."""
    gain = 0.5 / float(np.max(np.abs(ref)))
    capsys.readouterr()
    assert main(["play", *args, "--device", f"live18_{name}", "--gain", repr(gain)]) == 0
    out = capsys.readouterr().out
    assert "underruns: 0; device underflows: 0" in out
    dev = np.fromfile(tmp / f"{name}.raw", dtype="<f4").reshape(-1, 2).T / gain
    lag = int(np.argmax(np.any(dev != 0, axis=0))) - int(np.argmax(np.any(ref != 0, axis=0)))
    assert 0 <= lag <= 44100
    d = dev[:, lag : lag + ref.shape[1]]
    assert d.shape == ref.shape
    return d, out


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_play_physical_is_the_render_with_its_highpass(devices, capsys) -> None:  # type: ignore[no-untyped-def]
    """Block by block, the high-pass state carried: the device gets ``render``'s samples
    (float32), for ``--highpass 20`` (default) and ``--highpass 0``; they differ."""
    phys = [*DATA, *WHERE, "--timbre", "physical"]
    r20 = _render(devices, "r20", *phys)
    r0 = _render(devices, "r0", *phys, "--highpass", "0")
    p20, out = _play(devices, "hp20", r20, capsys, *phys)
    assert "synthesis per block" in out and "rendered ahead" not in out
    p0, _ = _play(devices, "hp0", r0, capsys, *phys, "--highpass", "0")
    assert _rel(p20, r20) < 1e-5 and _rel(p0, r0) < 1e-5
    # the sound is mostly below 20 Hz: without the high-pass it is several times louder
    # and another
    assert np.max(np.abs(r0)) > 5 * np.max(np.abs(r20))
    assert _rel(p20, r0) > 0.9 and _rel(p0, r20) > 4


def test_play_default_timbre_is_renders_auto(devices, capsys) -> None:  # type: ignore[no-untyped-def]
    """No --timbre: ``auto`` chooses ``extended`` here (as ``render`` says), rendered ahead
    exactly as ``render`` renders it, then played."""
    args = [*DATA, *WHERE]
    ref = _render(devices, "auto", *args)
    got, out = _play(devices, "auto", ref, capsys, *args)
    assert "timbre auto: 100 % of the physical sound lies below 20 Hz" in out
    assert "timbre extended (auto): rendered ahead in" in out
    assert _rel(got, ref) < 1e-5
    phys = _render(devices, "phys", *args, "--timbre", "physical")
    assert _rel(phys, ref) > 0.5  # a different sound from the physical one
    tonal = _render(devices, "tonal", *args, "--timbre", "tonal")
    got, out = _play(devices, "tonal", tonal, capsys, *args, "--timbre", "tonal")
    assert "timbre tonal: rendered ahead in" in out and _rel(got, tonal) < 1e-5


def test_play_a_scene_follows_the_fields_timbre(devices, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    """A scene's field part: ``auto`` is rendered ahead (as ``render --scene``), ``physical``
    block by block; both are what ``render --scene`` writes."""
    vol = tmp_path / "m.h5"
    assert main(["dataset", "monopole", "--size", "12", "--steps", "60", "-o", str(vol)]) == 0
    for name, timbre in (("scene", "auto"), ("scene_phys", "physical")):
        scene = tmp_path / f"{name}.json"
        scene.write_text(
            json.dumps(
                {
                    "listener": {"position": [5.0, 1.4, 1.4]},
                    "duration": 0.5,
                    "layout": "stereo",
                    "models": [
                        {
                            "model": "field",
                            "input": str(vol),
                            "params": {
                                "time_scale": 20,
                                "timbre": timbre,
                                "threshold_monopole": "1%",
                            },
                        }
                    ],
                }
            )
        )
        ref = _render(devices, name, "--scene", str(scene))
        got, out = _play(devices, name, ref, capsys, "--scene", str(scene))
        assert ("timbre auto: rendered ahead in" in out) == (timbre == "auto")
        assert _rel(got, ref) < 1e-5


def test_play_json_prints_the_report_alone(devices, capsys) -> None:  # type: ignore[no-untyped-def]
    """``--json``: standard output is one JSON document (the plan's notes and mapping go
    to standard error), and it reports the blocks played without underruns."""
    capsys.readouterr()
    args = [*DATA, *WHERE, "--timbre", "physical", "--device", "live18_json", "--json"]
    assert main(["play", *args]) == 0
    got = capsys.readouterr()
    rep = json.loads(got.out)
    assert rep["underruns"] == 0 and rep["blocks"] > 0 and rep["channels"] == 2
    assert "s of playback =" in got.err  # the time mapping, for the person at the terminal
