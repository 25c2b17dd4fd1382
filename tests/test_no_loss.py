"""Nothing lost: no output replaces an input or a file auralize did not write; a
closed pipe ends quietly; a script's error is the script's."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from auralize.cli import main


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err


@pytest.fixture
def volume(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    v = tmp_path / "m.h5"
    assert main(["dataset", "monopole", "--size", "8", "--steps", "6", "-o", str(v)]) == 0
    capsys.readouterr()
    return v


def test_an_output_that_is_an_input_is_refused_and_the_input_kept(
    volume: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    before = volume.read_bytes()
    code, err = _run(["detect", volume, "-o", volume], capsys)
    assert code == 2 and "would replace the input" in err and volume.read_bytes() == before
    # the same file under another name (a hard link) is the same file
    link = tmp_path / "link.h5"
    os.link(volume, link)
    code, err = _run(["detect", volume, "-o", link], capsys)
    assert code == 2 and "would replace the input" in err and volume.read_bytes() == before
    # sources read by render are inputs too
    src = tmp_path / "s.h5"
    assert _run(["detect", volume, "-o", src], capsys)[0] == 0
    kept = src.read_bytes()
    code, err = _run(["render", volume, "--sources", src, "-o", src], capsys)
    assert code == 2 and "would replace the input" in err and src.read_bytes() == kept
    # an input inside the folder a .pvd output writes its pieces to
    data = tmp_path / "out_data"
    data.mkdir()
    inside = data / "m.h5"
    inside.write_bytes(before)
    code, err = _run(["detect", inside, "-o", tmp_path / "out.pvd"], capsys)
    assert code == 2 and "would replace the input" in err and inside.read_bytes() == before


def test_a_sidecar_auralize_did_not_write_is_never_replaced(
    volume: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    wav = tmp_path / "o.wav"
    theirs = tmp_path / "o.wav.json"
    theirs.write_text('{"mine": 1}')
    args = ["render", volume, "--listener", "1,1,4", "--duration", "0.05", "-o", wav]
    code, err = _run(args, capsys)
    assert code == 4 and "not an auralize sidecar" in err
    assert theirs.read_text() == '{"mine": 1}' and not wav.exists()
    # ours is recognised by its marker, and replaced by the next render
    theirs.unlink()
    assert _run(args, capsys)[0] == 0
    assert json.loads(theirs.read_text())["auralize_format"] == "audio-sidecar"
    assert _run(args, capsys)[0] == 0


def test_a_closed_pipe_ends_quietly() -> None:
    """``auralize plugins | head -1``: the line, exit 0, nothing on stderr."""
    exe = Path(sys.executable).parent / "auralize"
    p = subprocess.run(
        f"'{exe}' plugins | head -1; exit ${{PIPESTATUS[0]}}",
        shell=True,
        executable="/bin/bash",
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 0, p.stderr
    assert p.stdout.count("\n") == 1 and p.stderr == ""


def test_a_scripts_error_is_the_scripts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    return 1 / 0\n\nf()\n")
    code, err = _run(["script", bad], capsys)
    assert code == 5 and "internal error" not in err and "this is a bug" not in err
    assert err.startswith("Traceback") and f'File "{bad}", line 4' in err
    assert "ZeroDivisionError: division by zero" in err and "runpy" not in err
    syn = tmp_path / "syn.py"
    syn.write_text("x = (\n")
    code, err = _run(["script", syn], capsys)
    assert code == 5 and "SyntaxError" in err and f'File "{syn}", line 1' in err


def test_impossible_numbers_are_refused_by_name(
    volume: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import numpy as np

    from auralize.errors import DataError, OutputError, ParameterError
    from auralize.pipeline import plan_render
    from auralize.simple import SaveAudio
    from auralize.volume import TimeVolume

    # a field the user names must exist; the message lists the ones that do
    code, err = _run(
        ["render", volume, "--velocity-field", "nosuch", "-o", tmp_path / "o.wav"], capsys
    )
    assert code == 3 and "--velocity-field 'nosuch'" in err and not (tmp_path / "o.wav").exists()
    # a spacing whose square under- or overflows is a units mistake, said so
    times = np.arange(3) * 1e-3
    for h in (1e-200, 1e200):
        with pytest.raises(DataError, match="check the grid's units"):
            TimeVolume.from_arrays({"p": np.zeros((3, 2, 2, 2))}, spacing=h, times=times)
    ok = TimeVolume.from_arrays({"p": np.zeros((3, 2, 2, 2))}, times=times)
    for c0 in (0.0, -343.0, float("nan"), float("inf")):
        with pytest.raises(ParameterError, match="speed of sound"):
            plan_render(ok, c0=c0)
    # saving to a folder that does not exist fails before looking for a render
    with pytest.raises(OutputError, match="does not exist"):
        SaveAudio(tmp_path / "nowhere" / "o.wav")


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"rate": 0}, "ParameterError", "rate must be a whole number of Hz in 8000..768000"),
        ({"rate": "x"}, "ParameterError", "rate must be a whole number"),
        ({"rate": 44100.5}, "ParameterError", "rate must be a whole number"),
        ({"rate": True}, "ParameterError", "rate must be a whole number"),
        ({"duration": 1e12}, "ResourceError", "1e+12 s of 1-channel audio at 44100 Hz needs"),
        ({"listener": (1, 2)}, "ParameterError", "listener must be three finite numbers"),
        ({"listener": "a"}, "ParameterError", "listener must be three finite numbers"),
        ({"listener": (0, 0, float("nan"))}, "ParameterError", "listener must be three finite"),
        ({"seed": -1}, "ParameterError", "seed must be a whole number in 0..4294967295"),
        ({"thresholds": "x"}, "ParameterError", "thresholds must be a Thresholds"),
    ],
)
def test_the_api_raises_auralizes_errors_before_any_work(
    kwargs: dict[str, object], error: str, message: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The public render function checks its arguments before any work, with auralize's
    errors (which still subclass the builtins a caller may catch)."""
    import auralize.errors as errors
    import auralize.pipeline as pipeline

    vol = pipeline.load("dataset:monopole", size=8, steps=6)

    def no_work(*a: object, **k: object) -> None:
        raise AssertionError("the work started before the arguments were checked")

    monkeypatch.setattr(pipeline, "heard_sound", no_work)
    with pytest.raises(getattr(errors, error), match=message.replace("+", r"\+")) as e:
        pipeline.auralize(vol, **kwargs)  # type: ignore[arg-type]
    assert isinstance(e.value, ValueError | MemoryError)


def test_the_api_takes_a_file_name_and_names_what_it_needs() -> None:
    from auralize.errors import MissingFileError, ParameterError
    from auralize.pipeline import auralize, detect_sources

    out, _ = auralize("dataset:monopole", duration=0.5, rate=8000)
    assert out.audio.shape[1] == 4000 and out.audio.any()
    with pytest.raises(ParameterError, match="needs a TimeVolume .* got NoneType"):
        detect_sources(None)  # type: ignore[arg-type]
    with pytest.raises(MissingFileError, match="'nosuch.h5': no such file"):
        detect_sources("nosuch.h5")  # type: ignore[arg-type]
