"""Bad input and faults: one clear line, a documented exit status, nothing lost.

* a table of bad command lines across every sub-command (core and plugins),
  each run in-process through :func:`auralize.cli.main`: non-zero exit with
  the documented status, exactly one line on stderr naming the bad value, no
  traceback, and no output file left behind;
* OS faults (disk full, no permission) on the write path;
* hypothesis fuzzing of the CSV and HDF5 readers (deterministic, a few
  hundred examples): a reader either returns a valid object or raises an
  :class:`~auralize.errors.AuralizeError`, nothing else;
* SIGKILL at random points of a render's WAV + sidecar write, a detect to
  ``.pvd`` and a dataset write: the old or the new output is found, complete;
* the local Dask cluster listens on loopback only.
"""

from __future__ import annotations

import errno
import json
import os
import random
import signal
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from auralize.cli import core as cli
from auralize.errors import AuralizeError, FormatError, OutputExistsError, ParameterError

EXIT = {"usage": cli.EXIT_USAGE, "data": cli.EXIT_DATA, "system": cli.EXIT_SYSTEM}


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Small input files shared by the table (a volume, CSVs, broken HDF5 files)."""
    from auralize.datasets import make_monopole
    from auralize.io import save_volume

    d = tmp_path_factory.mktemp("inputs")
    vol = d / "m.h5"
    save_volume(make_monopole(size=8, steps=4).load(), vol)
    (d / "big_t.csv").write_text("t,x,y,z\n0,0.5,0.5,0.5\n1e30,0.5,0.5,0.5\n")
    (d / "nan.csv").write_text("t,x,y,z\n0,0.5,0.5,0.5\nnan,0.5,0.5,0.5\n")
    (d / "far.csv").write_text("t,x,y,z\n0,1e30,0,0\n1,1e30,0,0\n")
    (d / "garbage.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(range(256)) * 8)
    with h5py.File(d / "extlink.h5", "w") as f:
        f["time"] = np.arange(2.0)
        f["rho"] = h5py.ExternalLink("/etc/passwd", "/data")
    with h5py.File(d / "extstore.h5", "w") as f:
        (d / "raw.bin").write_bytes(np.zeros(2 * 2 * 2 * 2).tobytes())
        f.create_dataset(
            "rho", shape=(2, 2, 2, 2), dtype="<f8", external=[(str(d / "raw.bin"), 0, 128)]
        )
    with h5py.File(d / "vtkhdf_link.hdf", "w") as f:
        f.create_group("VTKHDF").attrs["Type"] = np.bytes_("ImageData")
        f["VTKHDF/PointData"] = h5py.ExternalLink("/etc/passwd", "/data")
    with h5py.File(d / "loop.h5", "w") as f:
        f["a"] = h5py.SoftLink("/b")
        f["b"] = h5py.SoftLink("/a")
    with h5py.File(d / "badmeta.h5", "w") as f:
        f.attrs["auralize_format"] = "volume"
        f.attrs["version"] = 1
        f["time"] = np.array([0.0, 1.0])
        f.create_group("grid").attrs["origin"] = "abc"
    with h5py.File(d / "far_origin.h5", "w") as f:
        f.attrs["auralize_format"] = "volume"
        f.attrs["version"] = 1
        f["time"] = np.array([0.0, 1.0])
        g = f.create_group("grid")
        g.attrs["origin"] = np.array([1e30, 0.0, 0.0])
        g.attrs["spacing"] = np.array([1.0, 1.0, 1.0])
        f["fields/rho"] = np.ones((2, 3, 3, 3))
    with h5py.File(d / "huge.h5", "w") as f:  # 4000³ frames declared, nothing stored
        f.attrs["auralize_format"] = "volume"
        f.attrs["version"] = 1
        f["time"] = np.array([0.0, 1.0])
        g = f.create_group("grid")
        g.attrs["origin"] = np.zeros(3)
        g.attrs["spacing"] = np.ones(3)
        f.create_dataset("fields/rho", shape=(2, 4000, 4000, 4000), dtype="f8", chunks=(1, 8, 8, 8))
    (d / "afile").write_text("not a folder")
    (d / "adir").mkdir()
    return {p.name: p for p in d.iterdir()} | {"dir": d}


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """``auralize ARGV`` in-process: (exit status, stderr)."""
    try:
        code = cli.main([str(a) for a in argv])
    except SystemExit as exc:  # argparse usage errors
        code = int(exc.code or 0)
    return code, capsys.readouterr().err


def files_under(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


# --------------------------------------------------------------------------- the table
#: (id, argv with {in}/{out} placeholders, exit kind or None (any non-zero), text the line names)
CASES: list[tuple[str, list[str], str | None, str]] = [
    # core: volumes and their options
    ("info-missing", ["info", "{out}/nope.h5"], "data", "nope.h5"),
    ("info-garbage", ["info", "{in}/garbage.h5"], "data", "garbage.h5"),
    ("info-extlink", ["info", "{in}/extlink.h5", "--field", "rho=/rho"], "data", "external link"),
    ("info-extstore", ["info", "{in}/extstore.h5", "--field", "rho=/rho"], "data", "external"),
    ("info-vtkhdf-extlink", ["info", "{in}/vtkhdf_link.hdf"], "data", "external link"),
    ("info-loop", ["info", "{in}/loop.h5", "--field", "rho=/a"], "data", "loop.h5"),
    ("info-badmeta", ["info", "{in}/badmeta.h5"], "data", "badmeta.h5"),
    ("info-far-origin", ["info", "{in}/far_origin.h5"], "data", "1e+30"),
    ("info-huge-frames", ["info", "{in}/huge.h5"], "system", "4000 x 4000 x 4000"),
    ("info-seed", ["info", "dataset:monopole", "--seed", "-1"], "usage", "'-1'"),
    ("info-size", ["info", "dataset:monopole", "--size", "abc"], "usage", "'abc'"),
    ("dataset-seed", ["dataset", "explosion", "-o", "{out}/x.h5", "--seed", "-1"], "usage", "'-1'"),
    ("dataset-nodir", ["dataset", "monopole", "-o", "{out}/no/x.h5"], "system", "does not exist"),
    ("dataset-isdir", ["dataset", "monopole", "-o", "{in}/adir"], "system", "is a folder"),
    ("dataset-parent-file", ["dataset", "monopole", "-o", "{in}/afile/x.h5"], "system", "afile"),
    ("dataset-steps", ["dataset", "monopole", "-o", "{out}/x.h5", "--steps", "0"], "usage", "'0'"),
    (
        "detect-threshold-e",
        ["detect", "{in}/m.h5", "-o", "{out}/s.h5", "--threshold-monopole", "e%"],
        None,
        "e",
    ),
    ("detect-suffix", ["detect", "{in}/m.h5", "-o", "{out}/s.txt"], "usage", "s.txt"),
    ("detect-nodir", ["detect", "{in}/m.h5", "-o", "{out}/no/s.pvd"], "system", "does not exist"),
    # core: render and its common output options
    (
        "render-rate-1",
        [
            "render",
            "{in}/m.h5",
            "--listener",
            "0,0,0",
            "--duration",
            "0.1",
            "-o",
            "{out}/a.wav",
            "--rate",
            "1",
        ],
        "usage",
        "'1'",
    ),
    (
        "render-rate-8",
        [
            "render",
            "{in}/m.h5",
            "--listener",
            "0,0,0",
            "--duration",
            "0.1",
            "-o",
            "{out}/a.wav",
            "--rate",
            "8",
        ],
        "usage",
        "'8'",
    ),
    (
        "render-tiny-duration",
        ["render", "{in}/m.h5", "--listener", "0,0,0", "--duration", "1e-9", "-o", "{out}/a.wav"],
        "usage",
        "1e-09",
    ),
    (
        "render-nan-duration",
        ["render", "{in}/m.h5", "--listener", "0,0,0", "--duration", "nan", "-o", "{out}/a.wav"],
        "usage",
        "'nan'",
    ),
    (
        "render-huge-duration",
        ["render", "{in}/m.h5", "--listener", "0,0,0", "--duration", "1e5", "-o", "{out}/a.wav"],
        "system",
        "GiB",
    ),
    (
        "render-far-listener",
        ["render", "{in}/m.h5", "--listener", "1e30,0,0", "--duration", "1", "-o", "{out}/a.wav"],
        "data",
        "1e+30",
    ),
    (
        "render-csv-t-1e30",
        ["render", "{in}/m.h5", "--path", "{in}/big_t.csv", "-o", "{out}/a.wav"],
        "system",
        "1e+30 s",
    ),
    (
        "render-csv-nan",
        ["render", "{in}/m.h5", "--path", "{in}/nan.csv", "-o", "{out}/a.wav"],
        "data",
        "'nan'",
    ),
    (
        "render-csv-far",
        ["render", "{in}/m.h5", "--path", "{in}/far.csv", "-o", "{out}/a.wav"],
        "data",
        "1e+30",
    ),
    (
        "render-csv-missing",
        ["render", "{in}/m.h5", "--path", "{out}/none.csv", "-o", "{out}/a.wav"],
        "data",
        "none.csv",
    ),
    (
        "render-mp3",
        ["render", "{in}/m.h5", "--listener", "0,0,0", "--duration", "0.1", "-o", "{out}/a.mp3"],
        "usage",
        "a.mp3",
    ),
    (
        "render-out-dir",
        ["render", "{in}/m.h5", "--listener", "0,0,0", "--duration", "0.1", "-o", "{in}/adir"],
        "system",
        "adir",
    ),
    (
        "render-time-scale",
        [
            "render",
            "{in}/m.h5",
            "--listener",
            "0,0,0",
            "--duration",
            "0.1",
            "-o",
            "{out}/a.wav",
            "--time-scale",
            "0",
        ],
        "usage",
        "'0'",
    ),
    (
        "render-limit",
        [
            "render",
            "{in}/m.h5",
            "--listener",
            "0,0,0",
            "--duration",
            "0.1",
            "-o",
            "{out}/a.wav",
            "--limit",
            "-1",
        ],
        "usage",
        "'-1'",
    ),
    (
        "render-workers-0",
        [
            "render",
            "{in}/m.h5",
            "--listener",
            "0,0,0",
            "--duration",
            "0.1",
            "-o",
            "{out}/a.wav",
            "--scheduler",
            "threads",
            "--workers",
            "0",
        ],
        "usage",
        "'0'",
    ),
    (
        "scale-detect-workers",
        ["scale-detect", "{in}/m.h5", "-o", "{out}/s.h5", "--workers", "-2"],
        "usage",
        "'-2'",
    ),
    (
        "play-gain",
        ["play", "{in}/m.h5", "--listener", "0,0,0", "--duration", "0.1", "--gain", "loud"],
        "usage",
        "'loud'",
    ),
    (
        "play-rate",
        ["play", "{in}/m.h5", "--listener", "0,0,0", "--duration", "0.1", "--rate", "8"],
        "usage",
        "'8'",
    ),
    # core: paths, bench, demo, view
    (
        "path-orbit-nan",
        [
            "path",
            "orbit",
            "--center",
            "0,0,0",
            "--radius",
            "1",
            "--duration",
            "1",
            "--rate-hz",
            "nan",
            "-o",
            "{out}/p.csv",
        ],
        "usage",
        "'nan'",
    ),
    (
        "path-orbit-zero",
        [
            "path",
            "orbit",
            "--center",
            "0,0,0",
            "--radius",
            "1",
            "--duration",
            "1",
            "--rate-hz",
            "0",
            "-o",
            "{out}/p.csv",
        ],
        "usage",
        "'0'",
    ),
    (
        "path-orbit-huge",
        [
            "path",
            "orbit",
            "--center",
            "0,0,0",
            "--radius",
            "1",
            "--duration",
            "1",
            "--rate-hz",
            "1e12",
            "-o",
            "{out}/p.csv",
        ],
        "system",
        "1e+12 Hz",
    ),
    (
        "path-line-negative",
        [
            "path",
            "line",
            "--start",
            "0,0,0",
            "--end",
            "1,0,0",
            "--duration",
            "1",
            "--captures",
            "-5",
            "-o",
            "{out}/p.csv",
        ],
        "usage",
        "'-5'",
    ),
    (
        "path-line-1e8",
        [
            "path",
            "line",
            "--start",
            "0,0,0",
            "--end",
            "1,0,0",
            "--duration",
            "1",
            "--captures",
            "1e8",
            "-o",
            "{out}/p.csv",
        ],
        "usage",
        "'1e8'",
    ),
    (
        "path-line-many",
        [
            "path",
            "line",
            "--start",
            "0,0,0",
            "--end",
            "1,0,0",
            "--duration",
            "1",
            "--captures",
            "100000000000",
            "-o",
            "{out}/p.csv",
        ],
        "system",
        "100000000000 captures",
    ),
    (
        "path-point-far",
        ["path", "point", "--at", "1e30,0,0", "--duration", "1", "-o", "{out}/p.csv"],
        "data",
        "1e+30",
    ),
    (
        "path-nodir",
        ["path", "point", "--at", "0,0,0", "--duration", "1", "-o", "{out}/no/p.csv"],
        "system",
        "does not exist",
    ),
    ("bench-sizes", ["bench", "--sizes", "abc"], "usage", "'abc'"),
    ("demo-size", ["demo", "-o", "{out}/demo", "--size", "-3"], "usage", "'-3'"),
    ("demo-parent-file", ["demo", "-o", "{in}/afile/demo"], "system", "afile"),
    (
        "view-window",
        [
            "view",
            "dataset:monopole",
            "--size",
            "8",
            "--steps",
            "4",
            "--screenshot",
            "{out}/v.png",
            "--window-size",
            "100000x100000",
        ],
        "system",
        "100000x100000",
    ),
    (
        "scale-render-block",
        [
            "scale-render",
            "{in}/m.h5",
            "--listener",
            "0,0,0",
            "--duration",
            "0.1",
            "-o",
            "{out}/a.wav",
            "--block-seconds",
            "-1",
        ],
        "usage",
        "'-1'",
    ),
    ("script-missing", ["script", "{out}/nope.py"], None, "nope.py"),
    ("devices-option", ["devices", "--bogus"], "usage", "--bogus"),
    ("plugins-option", ["plugins", "--bogus"], "usage", "--bogus"),
    # plugins
    (
        "fire-texture-missing",
        ["fire", "texture", "{out}/none.wav", "-o", "{out}/f.wav"],
        "data",
        "none.wav",
    ),
    (
        "vortex-speeds",
        ["vortex", "texture", "--speeds", "abc", "-o", "{out}/t.h5"],
        "usage",
        "'abc'",
    ),
    (
        "vortex-duration",
        ["vortex", "texture", "--speeds", "1,2", "--texture-duration", "1e9", "-o", "{out}/t.h5"],
        "system",
        "1e+09 s",
    ),
    (
        "vortex-seed",
        ["vortex", "texture", "--speeds", "1,2", "--seed", "-1", "-o", "{out}/t.h5"],
        "usage",
        "'-1'",
    ),
    (
        "vortex-block",
        [
            "vortex",
            "render",
            "{in}/m.h5",
            "--block",
            "0",
            "--listener",
            "0,0,0",
            "--duration",
            "0.1",
            "-o",
            "{out}/a.wav",
        ],
        "usage",
        "'0'",
    ),
    (
        "fire-rate",
        ["fire", "lowfreq", "dataset:fire", "--rate", "8", "-o", "{out}/f.wav"],
        "usage",
        "'8'",
    ),
    (
        "fire-refine",
        [
            "fire",
            "render",
            "dataset:fire",
            "--size",
            "16",
            "--steps",
            "4",
            "--refine",
            "1000",
            "--listener",
            "0,0,1",
            "--duration",
            "0.1",
            "-o",
            "{out}/f.wav",
        ],
        "system",
        "refinement 1000",
    ),
    (
        "fire-extend-missing",
        ["fire", "extend", "{out}/none.wav", "-o", "{out}/f.wav"],
        None,
        "none.wav",
    ),
    (
        "spark-seed",
        [
            "spark",
            "render",
            "--seed",
            "-1",
            "--listener",
            "0,0,1",
            "--duration",
            "0.1",
            "-o",
            "{out}/s.wav",
        ],
        "usage",
        "'-1'",
    ),
    (
        "spark-T0",
        [
            "spark",
            "render",
            "--T0",
            "nan",
            "--listener",
            "0,0,1",
            "--duration",
            "0.1",
            "-o",
            "{out}/s.wav",
        ],
        "usage",
        "'nan'",
    ),
    (
        "spark-strokes",
        [
            "spark",
            "render",
            "--strokes",
            "0",
            "--listener",
            "0,0,1",
            "--duration",
            "0.1",
            "-o",
            "{out}/s.wav",
        ],
        "usage",
        "'0'",
    ),
    (
        "aero-directions",
        [
            "aero",
            "texture",
            "--shape",
            "cylinder",
            "--diameter",
            "0.01",
            "--directions",
            "0",
            "-o",
            "{out}/t.h5",
        ],
        "usage",
        "'0'",
    ),
    (
        "aero-duration",
        [
            "aero",
            "texture",
            "--shape",
            "cylinder",
            "--diameter",
            "0.01",
            "--texture-duration",
            "1e9",
            "-o",
            "{out}/t.h5",
        ],
        "system",
        "1e+09 s",
    ),
    (
        "aero-diameter",
        ["aero", "texture", "--shape", "cylinder", "--diameter", "-1", "-o", "{out}/t.h5"],
        "usage",
        "got -1",
    ),
    (
        "aero-texture-missing",
        [
            "aero",
            "render",
            "--texture",
            "{out}/none.h5",
            "--wind",
            "5",
            "--listener",
            "0,1,0",
            "--duration",
            "0.1",
            "-o",
            "{out}/a.wav",
        ],
        None,
        "none.h5",
    ),
]


@pytest.mark.parametrize(
    ("argv", "kind", "names"), [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
def test_bad_input_gives_one_line(
    argv: list[str],
    kind: str | None,
    names: str,
    inputs: dict[str, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("AURALIZE_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("AURALIZE_CACHE_DIR", str(tmp_path / "cache"))
    args = [a.replace("{in}", str(inputs["dir"])).replace("{out}", str(tmp_path)) for a in argv]
    before_in = files_under(inputs["dir"])
    code, err = run(args, capsys)
    assert code != 0
    if kind is not None:
        assert code == EXIT[kind], err
    assert code != cli.EXIT_INTERNAL or "threshold" in argv[-2], err  # thresholds: the sources work
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert "error:" in lines[0] and names in lines[0], lines[0]
    assert files_under(tmp_path) <= {"cache"}, files_under(tmp_path)  # nothing written
    assert files_under(inputs["dir"]) == before_in  # nothing of the inputs touched


def test_exit_codes_are_documented() -> None:
    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text()
    for code in cli.EXIT_CODES:
        assert f"| {code} |" in readme, code


# --------------------------------------------------------------------------- OS faults
def test_disk_full_is_one_line_and_leaves_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import auralize.io.hdf5 as hdf5

    real = os.replace

    def full(src: Any, dst: Any) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # as a write() reports it

    monkeypatch.setattr(hdf5.os, "replace", full)
    code, err = run(
        ["dataset", "monopole", "--size", "8", "--steps", "4", "-o", tmp_path / "x.h5"], capsys
    )
    assert code == cli.EXIT_SYSTEM
    assert err.count("\n") == 1 and "No space left on device" in err and "x.h5" in err
    assert list(tmp_path.iterdir()) == []
    monkeypatch.setattr(hdf5.os, "replace", real)


def test_no_permission_is_refused_up_front(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(os, "access", lambda *a, **k: False)
    code, err = run(
        ["path", "point", "--at", "0,0,0", "--duration", "1", "-o", tmp_path / "p.csv"], capsys
    )
    assert code == cli.EXIT_SYSTEM and "no permission to write" in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_internal_errors_are_one_line(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    def boom(args: Any) -> int:
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(cli, "cmd_plugins", boom)
    code, err = run(["plugins"], capsys)
    assert code == cli.EXIT_INTERNAL
    assert err.count("\n") == 1 and "ZeroDivisionError" in err and "AURALIZE_DEBUG" in err


# --------------------------------------------------------------------------- corrupt and silent outputs
def test_float32_overflow_and_underflow_are_refused(tmp_path: Path) -> None:
    from auralize.audio import write_audio

    with pytest.raises(ParameterError, match="overflows a float32"):
        write_audio(tmp_path / "a.wav", np.full((1, 100), 1e39), 44100, normalize="none")
    with pytest.raises(ParameterError, match="all zeros"):
        write_audio(tmp_path / "a.wav", np.full((1, 100), 1e-50), 44100, normalize="none")
    assert list(tmp_path.iterdir()) == []
    # far below anything audible: written as silence, not amplified to full scale
    from auralize.audio import SilentAudioWarning

    with pytest.warns(SilentAudioWarning, match="round-off or nothing"):
        assert write_audio(tmp_path / "a.wav", np.full((1, 100), 1e-320), 44100) == 1.0


def test_silent_render_says_so(
    tmp_path: Path, inputs: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    from auralize.audio import SilentAudioWarning, write_audio

    with pytest.warns(SilentAudioWarning, match="silent"):
        write_audio(tmp_path / "z.wav", np.zeros((2, 100)), 44100)
    assert json.loads((tmp_path / "z.wav.json").read_text())["silent"] is True
    # nothing arrives within 1 ms at 10 m from the data: written, flagged, exit 1
    code, err = run(
        [
            "render",
            inputs["m.h5"],
            "--listener",
            "0.5,0.5,0.5",
            "--duration",
            "0.001",
            "--heard",
            "detected",
            "--threshold-monopole",
            "1e300",
            "-o",
            tmp_path / "s.wav",
        ],
        capsys,
    )
    # one warning line (a note that no velocity means no dipoles may come with it)
    lines = [ln for ln in err.splitlines() if ": note: " not in ln]
    assert code == cli.EXIT_SILENT and "silent" in err and len(lines) == 1
    assert json.loads((tmp_path / "s.wav.json").read_text())["silent"] is True


def test_pair_records_the_audio_hash(tmp_path: Path) -> None:
    from auralize.audio import write_audio
    from auralize.runtime.files import file_sha256

    write_audio(tmp_path / "a.wav", np.ones((1, 64)), 44100)
    side = json.loads((tmp_path / "a.wav.json").read_text())
    assert side["sha256"] == file_sha256(tmp_path / "a.wav")


# --------------------------------------------------------------------------- .pvd folders
def small_series(n_steps: int = 2) -> Any:
    from auralize.sources import SourceFrame, SourceSeries

    frames = [
        SourceFrame(
            index=np.array([0, 5]),
            kind=np.array([1, 2], np.int8),
            strength=np.array([1.0, -2.0]),
            radius=np.array([0.1, 0.1]),
        )
        for _ in range(n_steps)
    ]
    return SourceSeries(
        frames=frames,
        times=np.arange(n_steps) * 0.1,
        origin=np.zeros(3),
        spacing=np.ones(3),
        dims=(3, 3, 3),
        thresholds=np.ones(3),
        meta={},
    )


def test_pvd_never_replaces_a_foreign_folder(tmp_path: Path) -> None:
    from auralize.sources.sources_file import save_sources_pvd

    mine = tmp_path / "s_data"
    mine.mkdir()
    (mine / "thesis.tex").write_text("years of work")
    with pytest.raises(OutputExistsError, match=r"thesis\.tex"):
        save_sources_pvd(small_series(), tmp_path / "s.pvd")
    assert (mine / "thesis.tex").read_text() == "years of work"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s_data"]
    # a folder listed by an old .pvd but holding other files is not ours either
    (tmp_path / "s.pvd").write_text(
        '<VTKFile type="Collection"><Collection><DataSet file="s_data/a.vtp"/>'
        "</Collection></VTKFile>"
    )
    with pytest.raises(OutputExistsError):
        save_sources_pvd(small_series(), tmp_path / "s.pvd")
    assert (mine / "thesis.tex").exists()


def test_pvd_swap_uses_a_fresh_marked_folder_with_usual_permissions(tmp_path: Path) -> None:
    from auralize.runtime.files import DATA_MARKER, collection_folders
    from auralize.sources.sources_file import save_sources_pvd

    pvd = tmp_path / "s.pvd"
    save_sources_pvd(small_series(2), pvd)
    assert collection_folders(pvd) == {"s_data"}
    umask = os.umask(0)
    os.umask(umask)
    assert (tmp_path / "s_data").stat().st_mode & 0o777 == 0o777 & ~umask
    assert (tmp_path / "s_data" / DATA_MARKER).is_file()
    save_sources_pvd(small_series(3), pvd)
    assert collection_folders(pvd) == {"s_data.1"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.pvd", "s_data.1"]
    save_sources_pvd(small_series(4), pvd)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.pvd", "s_data"]
    assert len(list((tmp_path / "s_data").glob("*.vtp"))) == 4


# --------------------------------------------------------------------------- HDF5 security
def test_external_data_needs_permission(
    inputs: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    from auralize.io import open_volume
    from auralize.io.hdf5 import allow_external_data

    with pytest.raises(FormatError, match="stored in external files"):
        open_volume(inputs["extstore.h5"], fields={"rho": "/rho"})
    allow_external_data(True)
    try:
        vol = open_volume(inputs["extstore.h5"], fields={"rho": "/rho"})
        assert vol.frame("rho", 1).shape == (2, 2, 2)
    finally:
        allow_external_data(False)
    code, err = run(
        ["info", inputs["extstore.h5"], "--field", "rho=/rho", "--allow-external"], capsys
    )
    assert code == 0, err


def test_aero_wind_along_the_stick_is_refused() -> None:
    from auralize_aero.model import _check_crosswind
    from auralize_aero.presets import stick

    with pytest.raises(ParameterError, match="blows along the stick's axis"):
        _check_crosswind(stick(0.5, 0.01), [1.0, 0.0, 0.0], "1,0,0")
    _check_crosswind(stick(0.5, 0.01), [0.0, 1.0, 0.0], "0,1,0")  # across: fine


def test_bench_folder_is_private(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import tempfile

    from auralize.bench.distributed import bench_dir
    from auralize.errors import OutputError

    monkeypatch.delenv("AURALIZE_BENCH_DIR", raising=False)
    monkeypatch.setattr(tempfile, "gettempdir", lambda: str(tmp_path))
    d = bench_dir()
    assert d.parent == tmp_path and d.stat().st_mode & 0o777 == 0o700
    d.chmod(0o777)  # someone else could plant files in it
    with pytest.raises(OutputError, match="not a private folder"):
        bench_dir()


# --------------------------------------------------------------------------- hypothesis
FUZZ = settings(
    max_examples=150,
    derandomize=True,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
_cell = st.one_of(
    st.sampled_from(
        [
            "0",
            "1",
            "-1",
            "0.5",
            "1e30",
            "-1e308",
            "nan",
            "inf",
            "",
            " ",
            "x",
            "1,2",
            "1e999",
            "0x10",
            "٣",
            '"1"',
            "\x00",
        ]
    ),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=4),
)


@FUZZ
@given(
    header=st.sampled_from(
        ["t,x,y,z", "t,x,y,z,fx,fy,fz,ux,uy,uz", "T, X ,y,z", "x,y,z,t", "", "t,x"]
    ),
    rows=st.lists(st.lists(_cell, min_size=0, max_size=11), max_size=6),
)
def test_fuzz_path_csv(tmp_path: Path, header: str, rows: list[list[str]]) -> None:
    from auralize.listener import ListenerPath

    p = tmp_path / "fuzz.csv"
    p.write_text(
        header + "\n" + "\n".join(",".join(r) for r in rows) + "\n",
        encoding="utf-8",
        errors="surrogatepass",
    )
    try:
        path = ListenerPath.from_csv(p)
    except AuralizeError as exc:
        assert str(exc) and "\n" not in str(exc).strip()
        return
    assert np.all(np.isfinite(path.times)) and np.all(np.diff(path.times) >= 0)
    assert np.all(np.isfinite(path.positions))


_meta = st.one_of(
    st.none(),
    st.floats(allow_nan=True, allow_infinity=True),
    st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=0, max_size=4),
    st.text(max_size=3),
    st.sampled_from(["link-dangling", "link-loop", "link-external", "group"]),
)


def _put(f: h5py.File, name: str, value: object, *, attr_of: str | None = None) -> None:
    if value is None:
        return
    if attr_of is not None:
        obj = f.require_group(attr_of)
        obj.attrs[name] = (
            value if not isinstance(value, list) else np.asarray(value, dtype=np.float64)
        )
        return
    if value == "link-dangling":
        f[name] = h5py.SoftLink("/nowhere")
    elif value == "link-loop":
        f[name] = h5py.SoftLink("/" + name)
    elif value == "link-external":
        f[name] = h5py.ExternalLink("/etc/passwd", "/x")
    elif value == "group":
        f.create_group(name)
    else:
        f[name] = np.asarray(value, dtype=np.float64) if isinstance(value, list) else value


@FUZZ
@given(
    version=st.sampled_from([1, 2, "1", -1, 1.5]),
    time=_meta,
    origin=_meta,
    spacing=_meta,
    shape=st.lists(st.integers(0, 4), min_size=0, max_size=6),
    field=st.sampled_from(
        ["data", "link-dangling", "link-loop", "link-external", "group", "string"]
    ),
    axes=st.sampled_from([None, "tzyx", "txyz", "xyz", 3]),
)
def test_fuzz_hdf5_metadata(
    tmp_path: Path,
    version: Any,
    time: Any,
    origin: Any,
    spacing: Any,
    shape: list[int],
    field: str,
    axes: Any,
) -> None:
    from auralize.io import open_volume

    p = tmp_path / "fuzz.h5"
    with h5py.File(p, "w") as f:
        f.attrs["auralize_format"] = "volume"
        f.attrs["version"] = version
        _put(f, "time", time)
        _put(f, "origin", origin, attr_of="grid")
        _put(f, "spacing", spacing, attr_of="grid")
        g = f.create_group("fields")
        if field == "data":
            g.create_dataset("rho", data=np.ones(shape))
            if axes is not None:
                g["rho"].attrs["axes"] = axes
        elif field == "string":
            g["rho"] = "text"
        else:
            _put(g, "rho", field)
    try:
        vol = open_volume(p)
        for name in vol.field_names:
            vol.frame(name, vol.n_steps - 1)
    except AuralizeError as exc:
        assert str(exc)
        return
    assert np.all(np.isfinite(vol.times)) and np.all(np.diff(vol.times) > 0)


@pytest.fixture(scope="module")
def good_h5(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    from auralize.datasets import make_monopole
    from auralize.io import save_volume

    p = tmp_path_factory.mktemp("good") / "g.h5"
    save_volume(make_monopole(size=4, steps=3).load(), p)
    return p.read_bytes()


@FUZZ
@given(
    flips=st.lists(st.tuples(st.integers(0, 10**9), st.integers(1, 255)), min_size=1, max_size=8)
)
def test_fuzz_hdf5_bytes(tmp_path: Path, good_h5: bytes, flips: list[tuple[int, int]]) -> None:
    from auralize.io import open_volume

    raw = bytearray(good_h5)
    for pos, x in flips:
        raw[pos % len(raw)] ^= x
    p = tmp_path / "corrupt.h5"
    p.write_bytes(bytes(raw))
    try:
        vol = open_volume(p)
        for name in vol.field_names:
            for step in range(vol.n_steps):
                vol.frame(name, step)
    except AuralizeError as exc:
        assert str(exc)


# --------------------------------------------------------------------------- kill -9
def _kill_trials(
    write_new: Any, check: Any, *, trials: int, max_delay_s: float, seed: int
) -> list[str]:
    """Fork a child that rewrites an output forever, SIGKILL it at a random moment,
    then ``check()`` what is on disk (old or new, complete); returns what was seen."""
    rnd = random.Random(seed)
    seen = []
    for _ in range(trials):
        pid = os.fork()
        if pid == 0:  # pragma: no cover - the child only writes until it is killed
            try:
                k = 0
                while True:
                    write_new(k)
                    k += 1
            finally:
                os._exit(0)
        time.sleep(rnd.uniform(0.0, max_delay_s))
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        seen.append(check())
    return seen


def test_kill_during_writes_keeps_old_or_new(tmp_path: Path) -> None:
    from auralize.audio import read_wav, write_audio
    from auralize.io import open_volume, save_volume
    from auralize.runtime.files import DATA_MARKER, collection_folders, file_sha256, recover_pair
    from auralize.sources.sources_file import save_sources_pvd
    from auralize.volume import TimeVolume

    # a render's output: the WAV and its sidecar, versions of 1 and 3 channels
    wav, side = tmp_path / "r.wav", tmp_path / "r.wav.json"
    audio = {n: np.random.default_rng(n).uniform(-1, 1, (n, 200_000)) for n in (1, 3)}
    write_audio(wav, audio[1], 44100)

    def check_wav() -> str:
        recover_pair(wav, side)  # what the next write does first
        meta = json.loads(side.read_text())
        assert meta["sha256"] == file_sha256(wav)
        a, _, _ = read_wav(wav)
        assert a.shape[0] == meta["channels"] and a.shape[1] == meta["samples"] == 200_000
        return f"wav{a.shape[0]}"

    seen = _kill_trials(
        lambda k: write_audio(wav, audio[1 + 2 * (k % 2)], 44100),
        check_wav,
        trials=12,
        max_delay_s=0.15,
        seed=1,
    )
    assert set(seen) <= {"wav1", "wav3"}

    # a detect to .pvd: versions of 2 and 5 steps
    pvd = tmp_path / "s.pvd"
    save_sources_pvd(small_series(2), pvd)

    def check_pvd() -> str:
        root = ET.parse(pvd).getroot()
        files = [e.get("file") or "" for e in root.iter("DataSet")]
        assert len(files) in (2, 5) and all((tmp_path / f).stat().st_size > 0 for f in files)
        (folder,) = collection_folders(pvd)
        assert (tmp_path / folder / DATA_MARKER).is_file()
        return f"pvd{len(files)}"

    seen = _kill_trials(
        lambda k: save_sources_pvd(small_series(2 + 3 * (k % 2)), pvd),
        check_pvd,
        trials=12,
        max_delay_s=0.15,
        seed=2,
    )
    assert set(seen) <= {"pvd2", "pvd5"}
    save_sources_pvd(small_series(2), pvd)  # the next run removes what the killed ones left
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith("s")) == [
        "s.pvd",
        "s_data",
    ] or sorted(p.name for p in tmp_path.iterdir() if p.name.startswith("s")) == [
        "s.pvd",
        "s_data.1",
    ]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith((".s.pvd", ".s_data"))]

    # a dataset write: versions of 2 and 6 steps
    h5 = tmp_path / "v.h5"
    vols = {
        n: TimeVolume.from_arrays({"p": np.ones((n, 20, 20, 20))}, times=np.arange(n) * 0.1)
        for n in (2, 6)
    }
    save_volume(vols[2], h5)

    def check_h5() -> str:
        vol = open_volume(h5)
        for step in range(vol.n_steps):
            assert np.all(vol.frame("p", step) == 1.0)
        return f"h5{vol.n_steps}"

    seen = _kill_trials(
        lambda k: save_volume(vols[2 + 4 * (k % 2)], h5),
        check_h5,
        trials=12,
        max_delay_s=0.15,
        seed=3,
    )
    assert set(seen) <= {"h52", "h56"}
    save_volume(vols[2], h5)  # stale temporaries of the killed writers are removed
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".v.h5")]


# --------------------------------------------------------------------------- Dask
@pytest.mark.parametrize("processes", [False, True], ids=["threads", "processes"])
def test_dask_cluster_listens_on_loopback_only(processes: bool) -> None:
    pytest.importorskip("distributed")
    import psutil

    from auralize.distributed.runner import Runner

    me = psutil.Process()

    def listening() -> set[tuple[int, Any]]:
        procs = [me, *me.children(recursive=True)]
        return {
            (p.pid, c.laddr)
            for p in procs
            for c in p.net_connections("inet")
            if c.status == psutil.CONN_LISTEN
        }

    before = listening()
    with Runner("distributed", workers=1, processes=processes, log=None, setup_workers=False) as r:
        assert r.dashboard_address.startswith("127.0.0.1:")
        opened = [addr for _, addr in listening() - before]
        link = r.dashboard_link or ""
    assert opened, "the cluster opened no listening socket"
    assert all(a.ip in ("127.0.0.1", "::1") for a in opened), opened
    assert "//127.0.0.1:" in link, link


def test_stale_temporaries_are_recognised(tmp_path: Path) -> None:
    from auralize.runtime.files import atomic_write

    dead = 99_999_999  # above any pid_max: no such process
    stale = tmp_path / f".o.csv.{dead}-0123456789ab.csv.part"
    live = tmp_path / f".o.csv.{os.getpid()}-0123456789ab.csv.part"
    users = tmp_path / ".o.csv.2024-notes.txt"
    for p in (stale, live, users):
        p.write_text("x")
    atomic_write(tmp_path / "o.csv", b"t,x,y,z\n")
    assert not stale.exists() and live.exists() and users.exists()
    assert (tmp_path / "o.csv").read_bytes() == b"t,x,y,z\n"


@pytest.mark.parametrize("out", ["x.h5", "x.pvd", "x.wav"])
def test_too_little_disk_space_is_refused_before_writing(
    out: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import shutil
    from collections import namedtuple

    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda _p: usage(10**6, 10**6 - 1000, 1000))
    if out == "x.wav":
        argv = [
            "render",
            "dataset:monopole",
            "--size",
            "8",
            "--steps",
            "4",
            "--listener",
            "0.5,0.5,0.5",
            "--duration",
            "0.1",
            "-o",
            tmp_path / out,
        ]
    else:
        argv = ["dataset", "monopole", "--size", "8", "--steps", "4", "-o", tmp_path / out]
    code, err = run(argv, capsys)
    assert code == cli.EXIT_SYSTEM and err.count("\n") == 1
    assert "free on that disk" in err and out in err
    assert list(tmp_path.iterdir()) == []


_RENDER_LOOP = """
import sys
from auralize.cli import core as cli
vol, wav = sys.argv[1], sys.argv[2]
k = 0
while True:
    cli.main(["render", vol, "--listener", "0.5,0.5,0.5", "--duration", ("1.0", "0.5")[k % 2],
              "--layout", ("stereo", "mono")[k % 2], "-o", wav])
    if k == 1:
        print("ready", flush=True)
    k += 1
"""


def test_kill_during_render_command_keeps_old_or_new(
    tmp_path: Path, inputs: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    """``auralize render`` itself (a separate process: numba's OpenMP forbids forking),
    killed at random moments of its loop of detection, synthesis and writing."""
    import subprocess
    import sys

    from auralize.audio import read_wav
    from auralize.runtime.files import file_sha256, recover_pair

    wav, side = tmp_path / "r.wav", tmp_path / "r.wav.json"
    assert (
        cli.main(
            [
                "render",
                str(inputs["m.h5"]),
                "--listener",
                "0.5,0.5,0.5",
                "--duration",
                "0.5",
                "-o",
                str(wav),
            ]
        )
        == 0
    )
    capsys.readouterr()
    rnd = random.Random(4)
    seen = set()
    for _ in range(2):  # each trial starts (and compiles) a process: a few seconds
        proc = subprocess.Popen(
            [sys.executable, "-c", _RENDER_LOOP, str(inputs["m.h5"]), str(wav)],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        assert proc.stdout is not None
        for line in proc.stdout:  # both versions written once: kernels compiled, warm
            if line.strip() == "ready":
                break
        time.sleep(rnd.uniform(0.0, 0.3))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stdout.close()
        recover_pair(wav, side)  # what the next write does first
        meta = json.loads(side.read_text())
        assert meta["sha256"] == file_sha256(wav)
        a, rate, _ = read_wav(wav)
        assert (a.shape, rate) in (((1, 22050), 44100), ((2, 44100), 44100))
        seen.add(a.shape[0])
    assert seen <= {1, 2}
