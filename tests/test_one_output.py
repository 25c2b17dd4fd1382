"""One output path for every model: the same samples whichever command writes them.

- The output high-pass (``--highpass``, default 20 Hz) filters the volume's sources only:
  a sound model mixed into ``auralize render`` writes the same samples as its own
  command (``spark render``, ``fire render``), and a field mixed with a model is the
  field's render plus the model's.
- ``auralize render PATH --model ...`` with Dask options equals the same render without
  them (the volume's sources on Dask, the models on this machine, one output stage).
- ``auralize play PATH --model ...`` plays the mix on a file-backed ALSA device with no
  underruns.
- Every sidecar records the command as the user would retype it, also when ``main`` is
  called from Python.
"""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import numpy as np
import pytest

from auralize.audio import read_wav
from auralize.cli import main

RATE = 22050


def _wav(path: Path) -> np.ndarray:
    audio, rate, _ = read_wav(path)
    assert rate == RATE
    return np.asarray(audio, dtype=np.float64)


def _sidecar(path: Path) -> dict:
    return json.loads(Path(f"{path}.json").read_text())


@pytest.fixture(scope="module")
def discharge(tmp_path_factory) -> Path:  # type: ignore[no-untyped-def]
    """A spark discharge tree saved by ``spark render --save-discharge``."""
    d = tmp_path_factory.mktemp("spark")
    tree = d / "tree.csv"
    assert (
        main(
            [
                "spark",
                "render",
                "--seed",
                "3",
                "-o",
                str(d / "a.wav"),
                "--listener",
                "0.5,0.3,0.2",
                "--duration",
                "0.05",
                "--rate",
                str(RATE),
                "--save-discharge",
                str(tree),
            ]
        )
        == 0
    )
    return tree


@pytest.fixture(scope="module")
def fire_file(tmp_path_factory) -> Path:
    from auralize_fire.dataset import make_fire

    from auralize.io import save_volume

    f = tmp_path_factory.mktemp("fire") / "fire.h5"
    save_volume(make_fire(size=12, steps=12), f)
    return f


# ----------------------------------------------------------- one high-pass rule
OUT = ["--rate", str(RATE), "--normalize", "none", "--layout", "stereo"]


def test_spark_alone_and_in_a_render_write_the_same_samples(discharge, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``spark render`` and ``render --model spark`` (default --highpass 20) agree: the
    high-pass is the field's, and a spark has no field sources."""
    a, b = tmp_path / "alone.wav", tmp_path / "scene.wav"
    lis = ["--listener", "0.5,0.3,0.2", "--duration", "0.1"]
    assert (
        main(
            [
                "spark",
                "render",
                "--discharge",
                str(discharge),
                "--seed",
                "3",
                "-o",
                str(a),
                *lis,
                *OUT,
            ]
        )
        == 0
    )
    assert main(["render", "--model", f"spark:{discharge}:seed=3", "-o", str(b), *lis, *OUT]) == 0
    x, y = _wav(a), _wav(b)
    assert x.shape == y.shape == (2, round(0.1 * RATE))
    assert np.max(np.abs(x)) > 1.0  # an N-wave of pascals at half a metre
    assert np.max(np.abs(x - y)) <= 1e-6 * np.max(np.abs(x))
    assert _sidecar(b)["highpass_hz"] == 0.0  # nothing was high-passed
    # the 20 Hz high-pass would have changed the samples (the test can fail)
    from auralize.emitters.timbre import highpass

    assert np.max(np.abs(highpass(x, RATE, 20.0) - x)) > 1e-3 * np.max(np.abs(x))


def test_fire_alone_and_in_a_render_write_the_same_samples(fire_file, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``fire render`` (its own §6 high-pass, 30 Hz) = ``render --model fire``."""
    a, b = tmp_path / "alone.wav", tmp_path / "scene.wav"
    lis = ["--listener", "0.5,0.5,3", "--duration", "0.4"]
    assert (
        main(["fire", "render", str(fire_file), "--extend", "none", "-o", str(a), *lis, *OUT]) == 0
    )
    assert (
        main(["render", "--model", f"fire:{fire_file}:extend=none", "-o", str(b), *lis, *OUT]) == 0
    )
    x, y = _wav(a), _wav(b)
    assert x.shape == y.shape and np.max(np.abs(x)) > 0
    assert np.max(np.abs(x - y)) <= 1e-6 * np.max(np.abs(x))


def _field_args(tmp_path: Path) -> list[str]:
    return [
        "dataset:monopole",
        "--size",
        "12",
        "--steps",
        "60",
        "--threshold-monopole",
        "1%",
        "--timbre",
        "physical",
        "--listener",
        "1.5,0.5,0.5",
        "--duration",
        "0.3",
        "--time-scale",
        "1",
    ]


def test_field_plus_model_is_the_filtered_field_plus_the_model(discharge, tmp_path) -> None:  # type: ignore[no-untyped-def]
    field, model, mix = tmp_path / "f.wav", tmp_path / "m.wav", tmp_path / "mix.wav"
    fa = _field_args(tmp_path)
    spark = f"spark:{discharge}:seed=3"
    assert main(["render", *fa, "-o", str(field), *OUT]) == 0  # default --highpass 20
    assert (
        main(
            [
                "render",
                "--model",
                spark,
                "--listener",
                "1.5,0.5,0.5",
                "--duration",
                "0.3",
                "-o",
                str(model),
                *OUT,
            ]
        )
        == 0
    )
    assert main(["render", *fa, "--model", spark, "-o", str(mix), *OUT]) == 0
    f, m, x = _wav(field), _wav(model), _wav(mix)
    assert np.max(np.abs(f)) > 0 and np.max(np.abs(m)) > 0
    # the volume alone lasts as long as the data's sound does (shorter than 0.3 s at time
    # scale 1); the scene lasts the --duration asked, to the sample
    n = f.shape[1]
    assert 0 < n < round(0.3 * RATE)
    assert x.shape == m.shape == (2, round(0.3 * RATE))
    assert np.max(np.abs(x[:, :n] - (f + m[:, :n]))) <= 1e-6 * np.max(np.abs(x))
    # after the data's sound: the spark, plus what is left of the field's high-pass
    assert np.max(np.abs(x[:, n:] - m[:, n:])) <= np.max(np.abs(f))
    side = _sidecar(mix)
    assert side["highpass_hz"] == 20.0 and side["duration_s"] == 0.3
    assert [p["model"] for p in side["parts"]] == ["field", "spark"]


def test_a_scene_without_duration_lasts_until_every_part_is_heard(discharge, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """No ``--duration`` and a static listener: the scene lasts until its last part has
    been heard.  The spark flashes at 0.05 s, after the volume's sound has ended; every
    one of its waves is in the file, and the file ends soon after the last."""
    field, model, mix = tmp_path / "f.wav", tmp_path / "m.wav", tmp_path / "mix.wav"
    fa = [a for a in _field_args(tmp_path) if a not in ("--duration", "0.3")]
    spark = f"spark:{discharge}:seed=3,t0=0.05"
    assert main(["render", *fa, "-o", str(field), *OUT]) == 0
    assert (
        main(
            [
                "render",
                "--model",
                spark,
                "--listener",
                "1.5,0.5,0.5",
                "--duration",
                "0.3",
                "-o",
                str(model),
                *OUT,
            ]
        )
        == 0
    )
    assert main(["render", *fa, "--model", spark, "-o", str(mix), *OUT]) == 0
    f, m, x = _wav(field), _wav(model), _wav(mix)
    heard = np.flatnonzero(np.any(m != 0, axis=0))
    first, last = int(heard[0]), int(heard[-1])
    assert f.shape[1] < first  # cut to the volume's sound, the file would hold no spark
    assert last < x.shape[1] <= last + round(0.02 * RATE)
    assert np.max(np.abs(x[:, : f.shape[1]] - (f + m[:, : f.shape[1]]))) <= 1e-6 * np.max(np.abs(x))
    assert np.max(np.abs(x[:, first:] - m[:, first : x.shape[1]])) <= 1e-3 * np.max(np.abs(m))
    # without a volume the spark alone gets the same length
    alone = tmp_path / "alone.wav"
    assert (
        main(["render", "--model", spark, "--listener", "1.5,0.5,0.5", "-o", str(alone), *OUT]) == 0
    )
    assert _wav(alone).shape == x.shape


# ------------------------------------------------------------------------ Dask
@pytest.mark.filterwarnings("ignore:.*unclosed.*:ResourceWarning")
@pytest.mark.parametrize(("scheduler", "length"), [("sync", "--duration"), ("threads", "natural")])
def test_dask_render_of_a_scene_equals_the_render_without_dask(
    discharge,
    tmp_path,
    capsys,  # type: ignore[no-untyped-def]
    scheduler,
    length,
) -> None:
    """Also the scene's length: ``--duration`` 0.3 s, or (no duration) until the spark
    flashing after the volume's sound has been heard."""
    pytest.importorskip("dask")
    fa = _field_args(tmp_path)
    spark = f"spark:{discharge}:seed=3"
    if length == "natural":
        fa = [a for a in fa if a not in ("--duration", "0.3")]
        spark += ",t0=0.05"
    plain, dask = tmp_path / "plain.wav", tmp_path / "dask.wav"
    assert main(["render", *fa, "--model", spark, "-o", str(plain), *OUT]) == 0
    capsys.readouterr()
    assert (
        main(
            [
                "render",
                *fa,
                "--model",
                spark,
                "-o",
                str(dask),
                *OUT,
                "--scheduler",
                scheduler,
                "--workers",
                "2",
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert f"({scheduler})" in text and "1 model part(s) on this machine" in text
    x, y = _wav(plain), _wav(dask)
    assert x.shape == y.shape and np.max(np.abs(x)) > 0
    if length == "--duration":
        assert x.shape == (2, round(0.3 * RATE))
    else:  # the spark flashes at 0.05 s and lasts a few ms
        assert 0.05 * RATE < x.shape[1] < 0.1 * RATE
    assert np.max(np.abs(x - y)) <= 1e-6 * np.max(np.abs(x))
    side = _sidecar(dask)
    assert side["duration_s"] == pytest.approx(x.shape[1] / RATE, abs=1 / RATE)
    assert side["dask"]["scheduler"] == scheduler and side["highpass_hz"] == 20.0
    assert [p["model"] for p in side["parts"]] == ["field", "spark"]


def test_dask_render_of_a_scene_file(discharge, tmp_path) -> None:  # type: ignore[no-untyped-def]
    pytest.importorskip("dask")
    scene = tmp_path / "scene.json"
    scene.write_text(
        json.dumps(
            {
                "layout": "stereo",
                "rate": RATE,
                "listener": {"position": [1.5, 0.5, 0.5]},
                "duration": 0.3,
                "models": [{"model": "spark", "input": str(discharge), "params": {"seed": 3}}],
            }
        )
    )
    fa = [
        "dataset:monopole",
        "--size",
        "12",
        "--steps",
        "60",
        "--threshold-monopole",
        "1%",
        "--timbre",
        "physical",
        "--time-scale",
        "1",
        "--normalize",
        "none",
    ]
    plain, dask = tmp_path / "plain.wav", tmp_path / "dask.wav"
    assert main(["render", *fa, "--scene", str(scene), "-o", str(plain)]) == 0
    assert main(["render", *fa, "--scene", str(scene), "-o", str(dask), "--scheduler", "sync"]) == 0
    x, y = _wav(plain), _wav(dask)
    assert x.shape[0] == 2 and x.shape == y.shape and np.max(np.abs(x)) > 0
    assert np.max(np.abs(x - y)) <= 1e-6 * np.max(np.abs(x))


# ------------------------------------------------------------------------ live
ASOUNDRC = """
pcm.auralize_file3 {{
    type file
    slave.pcm "null"
    file "{out}"
    format "raw"
}}
"""


def test_play_field_and_model_on_a_file_backed_device(
    discharge,
    tmp_path,
    monkeypatch,  # type: ignore[no-untyped-def]
    capsys,
) -> None:
    """``auralize play PATH --model ...``: no underruns, and the device gets the render."""
    from auralize.audio import refresh_devices

    fa = _field_args(tmp_path)
    spark = f"spark:{discharge}:seed=3"
    ref = tmp_path / "ref.wav"
    assert main(["render", *fa, "--model", spark, "-o", str(ref), *OUT]) == 0
    r = _wav(ref)
    cfg = tmp_path / "cfg"
    (cfg / "alsa").mkdir(parents=True)
    out = tmp_path / "dev.raw"
    (cfg / "alsa" / "asoundrc").write_text(ASOUNDRC.format(out=out))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(cfg))
    refresh_devices()
    gain = 0.9 / float(np.max(np.abs(r)))
    capsys.readouterr()
    try:
        assert (
            main(
                [
                    "play",
                    *fa,
                    "--model",
                    spark,
                    "--layout",
                    "stereo",
                    "--rate",
                    str(RATE),
                    "--device",
                    "auralize_file3",
                    "--gain",
                    repr(gain),
                    "--json",
                ]
            )
            == 0
        )
    finally:
        monkeypatch.delenv("XDG_CONFIG_HOME")
        refresh_devices()
    rep = json.loads(capsys.readouterr().out)
    assert rep["underruns"] == 0 and rep["device_underflows"] == 0
    assert rep["blocks"] == -(-r.shape[1] // round(0.05 * RATE))  # 50 ms blocks
    assert rep["duration_s"] == pytest.approx(r.shape[1] / RATE)
    dev = np.fromfile(out, dtype="<f4").reshape(-1, 2).T.astype(np.float64)
    lag = int(np.argmax(np.any(dev != 0, axis=0))) - int(np.argmax(np.any(r != 0, axis=0)))
    assert 0 <= lag <= RATE
    d = dev[:, lag : lag + r.shape[1]]
    assert d.shape == r.shape
    assert np.max(np.abs(d - gain * r)) <= 1e-5


# --------------------------------------------------------------- sidecar command
def test_sidecars_record_the_command_as_typed(discharge, fire_file, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``main([...])`` (as ``python -m auralize.cli``) records ``auralize ARGS``, quoted."""
    d = tmp_path / "a folder"
    d.mkdir()
    cases = [
        ["render", *_field_args(tmp_path), "-o", str(d / "field.wav")],
        [
            "render",
            "--model",
            f"spark:{discharge}",
            "--listener",
            "1,0,0",
            "--duration",
            "0.05",
            "-o",
            str(d / "spark scene.wav"),
        ],
        [
            "spark",
            "render",
            "--discharge",
            str(discharge),
            "--listener",
            "1,0,0",
            "--duration",
            "0.05",
            "-o",
            str(d / "spark.wav"),
        ],
        [
            "fire",
            "render",
            str(fire_file),
            "--extend",
            "none",
            "--listener",
            "0.5,0.5,3",
            "--duration",
            "0.1",
            "-o",
            str(d / "fire.wav"),
        ],
        ["fire", "lowfreq", str(fire_file), "-o", str(d / "low.wav")],
    ]
    for argv in cases:
        assert main(argv) == 0, argv
        cmd = _sidecar(Path(argv[-1]))["command"]
        assert cmd == "auralize " + shlex.join(argv)
        assert shlex.split(cmd)[1:] == argv  # retyped in a shell, it is the same command
