"""The three example scripts run (through ``auralize script``) and do what they say."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from auralize.audio import read_wav
from auralize.cli import main
from auralize.listener import ListenerPath

EX = Path(__file__).resolve().parents[1] / "examples"
SMALL = ["--size", "24", "--steps", "6"]


def test_explosion_tour(tmp_path, capsys):
    args = [str(tmp_path), *SMALL, "--duration", "0.5"]
    assert main(["script", str(EX / "explosion_tour.py"), *args]) == 0
    audio, rate, _ = read_wav(tmp_path / "tour.wav")
    assert audio.shape[0] == 8 and rate == 44100
    assert audio.shape[1] == pytest.approx(0.5 * rate, abs=2)
    assert np.max(np.abs(audio)) > 0.5  # peak-normalised, not silent
    path = ListenerPath.from_csv(tmp_path / "tour.csv")
    assert path.n_captures == 6 and np.all(np.diff(path.times) > 0)
    st = json.loads((tmp_path / "tour.json").read_text())
    assert st["auralize_format"] == "session" and len(st["path"]["rows"]) == 6
    assert (tmp_path / "tour.png").stat().st_size > 10_000
    assert "captures" in capsys.readouterr().out


def test_regression_check_passes_then_catches_a_change(tmp_path, capsys):
    exp = tmp_path / "expected.json"
    script = str(EX / "regression_check.py")
    assert main(["script", script, str(exp), *SMALL, "--update"]) == 0
    assert main(["script", script, str(exp), *SMALL]) == 0
    want = json.loads(exp.read_text())
    want["counts"][2]["monopole"] += 50
    exp.write_text(json.dumps(want))
    assert main(["script", script, str(exp), *SMALL]) == 1
    assert "step 2 monopole" in capsys.readouterr().out


def test_batch_render(tmp_path):
    assert main(["script", str(EX / "batch_render.py"), str(tmp_path), *SMALL]) == 0
    wavs = sorted(tmp_path.glob("*.wav"))
    assert len(wavs) == 7
    peaks = {w.stem: np.max(np.abs(read_wav(w)[0])) for w in wavs}
    assert all(p > 0.5 for p in peaks.values())
    assert all((tmp_path / f"{w.stem}.csv").exists() for w in wavs)
