"""Regression tests of a user's own data: ``auralize regress`` and the pytest fixture.

The data are made here, outside auralize: a ParaView ``.pvd`` series of
``.vti`` files written by VTK's own XML writer, holding a density pulse (a
Gaussian blob that swells and fades).  A recorded expectation passes; the
same run with the amplitude doubled fails naming the level figures (+6.02 dB)
and not the counts (thresholds follow the data's scale); the pulse shifted
in time fails naming the counts and the onset.
"""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from auralize.cli import EXIT_CODES, EXIT_REGRESSION, main
from auralize.errors import ParameterError
from auralize.regression import real, synthetic
from auralize.regression.compare import image_rms
from auralize.regression.user import DEFAULT_TOLERANCES, check, record

ROOT = Path(__file__).resolve().parents[1]
#: the render of every check here: a listener beside the data, 1 s at 8 kHz, no high-pass
#: (the pulse's sound lies below 20 Hz at this time scale)
RENDER = [
    "--listener",
    "2,0.5,0.5",
    "--duration",
    "1",
    "--rate",
    "8000",
    "--highpass",
    "0",
    "--timbre",
    "physical",
    "--screenshot-size",
    "320x240",
]
#: the expected level change of a doubled amplitude, dB
DOUBLED_DB = 20 * np.log10(2.0)


def write_series(
    folder: Path,
    *,
    amplitude: float = 1.0,
    t_event: float = 0.4,
    n: int = 12,
    steps: int = 16,
    dt: float = 0.05,
) -> Path:
    """A density pulse as ``folder/run.pvd`` + one ``.vti`` per step, written by VTK."""
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk

    folder.mkdir()
    h = 1.0 / (n - 1)
    c = np.arange(n) * h
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    blob = np.exp(-((x - 0.35) ** 2 + (y - 0.5) ** 2 + (z - 0.6) ** 2) / (2 * 0.12**2))
    items = []
    for k in range(steps):
        t = k * dt
        rho = 1.2 + amplitude * 0.01 * blob * np.exp(-((t - t_event) ** 2) / (2 * 0.08**2))
        img = vtk.vtkImageData()
        img.SetDimensions(n, n, n)
        img.SetSpacing(h, h, h)
        arr = numpy_to_vtk(np.ascontiguousarray(rho.ravel()), deep=True)  # x varies fastest
        arr.SetName("density")
        img.GetPointData().AddArray(arr)
        w = vtk.vtkXMLImageDataWriter()
        w.SetFileName(str(folder / f"step_{k:03d}.vti"))
        w.SetInputData(img)
        assert w.Write() == 1
        items.append(f'<DataSet timestep="{t:.6g}" part="0" file="step_{k:03d}.vti"/>')
    pvd = folder / "run.pvd"
    pvd.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
        "<Collection>\n" + "\n".join(items) + "\n</Collection>\n</VTKFile>\n"
    )
    return pvd


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):  # type: ignore[no-untyped-def]
    """The pulse, its doubled and its shifted variants, and the pulse's expectation."""
    base = tmp_path_factory.mktemp("regress")
    data = write_series(base / "run")
    doubled = write_series(base / "doubled", amplitude=2.0)
    shifted = write_series(base / "shifted", t_event=0.6)
    expect = base / "expect.json"
    assert main(["regress", "record", str(data), "-o", str(expect), *RENDER]) == 0
    return data, doubled, shifted, expect


def _check_json(capsys, data, expect, *extra):  # type: ignore[no-untyped-def]
    code = main(["regress", "check", str(data), str(expect), "--json", *extra])
    return code, json.loads(capsys.readouterr().out)


def test_record_stores_settings_path_and_picture(recorded) -> None:  # type: ignore[no-untyped-def]
    data, _, _, expect = recorded
    doc = json.loads(expect.read_text())
    assert doc["format"] == "auralize-regression" and doc["data"] == str(data)
    st = doc["settings"]
    assert (st["rate"], st["layout"], st["listener"], st["highpass_hz"]) == (
        8000,
        "mono",
        [2.0, 0.5, 0.5],
        0.0,
    )
    rows = np.asarray(doc["path"]["rows"])
    assert rows.shape[1] == 10 and np.allclose(rows[:, 1:4], [2.0, 0.5, 0.5])
    assert doc["tolerances"] == DEFAULT_TOLERANCES
    f = doc["figures"]
    assert f["steps"] == 16 and len(f["counts"]) == 16
    assert f["onset"]["monopole"] is not None and f["onset"]["dipole"] is None  # no velocity
    assert len(f["level_db"]) == 8 and len(f["band_levels_db"][0]) == len(f["band_labels"])
    png = expect.with_suffix(".png")
    assert doc["image"] == png.name and png.stat().st_size > 1000


def test_the_recorded_run_passes(recorded, capsys) -> None:  # type: ignore[no-untyped-def]
    data, _, _, expect = recorded
    code, out = _check_json(capsys, data, expect)
    assert code == 0 and out["passed"] and out["moved"] == []


def test_a_doubled_amplitude_fails_naming_the_level(recorded, capsys) -> None:  # type: ignore[no-untyped-def]
    _, doubled, _, expect = recorded
    code, out = _check_json(capsys, doubled, expect)
    assert code == EXIT_REGRESSION == 6
    groups = {m["group"] for m in out["moved"]}
    assert "level" in groups and "counts" not in groups and "onset" not in groups
    levels = [m for m in out["moved"] if m["group"] == "level"]
    assert all(m["figure"].startswith("level window ") for m in levels)
    # every audible window is 6.02 dB louder: the pressure doubles with the density
    for m in levels:
        assert m["got"] - m["expected"] == pytest.approx(DOUBLED_DB, abs=0.01), m
    # with a wider level tolerance (and bands') it passes: only those figures moved
    code, out = _check_json(
        capsys, doubled, expect, "--tolerance", "level=7", "--tolerance", "bands=7"
    )
    assert code == 0, out["moved"]


def test_a_shifted_event_fails_naming_counts_and_onset(recorded, capsys) -> None:  # type: ignore[no-untyped-def]
    _, _, shifted, expect = recorded
    code = main(["regress", "check", str(shifted), str(expect)])
    text = capsys.readouterr().out
    assert code == EXIT_REGRESSION
    # the pulse comes 0.2 s = 4 steps later: its onset moves by 4 steps (its end goes past
    # the data's last step)
    assert re.search(r"onset monopole: step \d+ vs expected step \d+ \(moved by \+4 steps", text)
    assert re.search(r"end monopole: step 15 vs expected step \d+ \(moved by \+\d steps", text)
    assert re.search(r"counts step \d+ monopole: \d+ vs expected \d+", text)
    assert text.index("counts:") < text.index("level:")  # the summary names kinds in order


def test_report_has_the_table_plots_and_pictures(recorded, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    _, _, shifted, expect = recorded
    rep = tmp_path / "report"
    assert main(["regress", "check", str(shifted), str(expect), "--report", str(rep)]) == 6
    md = (rep / "report.md").read_text()
    assert "FAILED" in md and "| onset monopole |" in md
    html = (rep / "report.html").read_text()
    assert "<table>" in html and 'src="level.png"' in html
    for name in (
        "level.png",
        "counts.png",
        "bands.png",
        "expected.png",
        "got.png",
        "difference.png",
    ):
        assert (rep / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    # the pulse drawn at another step: the pictures differ, and the difference shows it
    assert image_rms(rep / "got.png", rep / "expected.png") > DEFAULT_TOLERANCES["image"]
    from PIL import Image

    diff = np.asarray(Image.open(rep / "difference.png"))
    assert diff.max() > 0
    # a folder whose parent is missing is refused, as every output
    code = main(
        ["regress", "check", str(shifted), str(expect), "--report", str(tmp_path / "no" / "report")]
    )
    assert code == 4 and "does not exist" in capsys.readouterr().err


def test_api_check_reports_moved_figures(recorded) -> None:  # type: ignore[no-untyped-def]
    _, doubled, _, expect = recorded
    result = check(doubled, expect, tolerances={"bands": 100.0})
    assert not result.passed and {m.group for m in result.moved} == {"level"}
    assert "level window" in result.summary() and "+6.02 dB" in result.summary()


def test_bad_inputs_are_clear_errors(recorded, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    data, _, _, expect = recorded
    bad = tmp_path / "bad.json"
    bad.write_text('{"hello": 1}')
    assert main(["regress", "check", str(data), str(bad)]) == 3
    assert "not an auralize regression expectation" in capsys.readouterr().err
    assert main(["regress", "check", str(data), str(tmp_path / "none.json")]) == 3
    assert "no such expectation file" in capsys.readouterr().err
    assert main(["regress", "check", str(data), str(expect), "--tolerance", "loudness=3"]) == 2
    assert "tolerance 'loudness' is not one of" in capsys.readouterr().err
    with pytest.raises(SystemExit) as err:
        main(["regress", "check", str(data), str(expect), "--tolerance", "level"])
    assert err.value.code == 2
    # a missing picture is said, not taken as a pass
    copy = tmp_path / "copy.json"
    copy.write_text(expect.read_text())
    assert main(["regress", "check", str(data), str(copy)]) == 3
    assert "the picture recorded beside copy.json is missing" in capsys.readouterr().err
    # and record refuses a name that is not .json
    with pytest.raises(ParameterError, match="ends in .json"):
        record(data, tmp_path / "expect.txt")


def test_exit_status_is_documented() -> None:
    assert "moved" in EXIT_CODES[EXIT_REGRESSION]
    from auralize.cli.core import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    regress = sub.choices["regress"]
    assert "6 a figure moved" in regress.description
    check_p = next(a for a in regress._actions if a.dest == "regress_command").choices["check"]
    assert "Exit status: 0 every figure within tolerance; 6 a figure moved" in check_p.description


# ------------------------------------------------------------------ the pytest plugin
pytest_plugins = ["pytester"]


def test_the_entry_point_names_the_plugin() -> None:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    target = meta["project"]["entry-points"]["pytest11"]["auralize"]
    assert target == "auralize.regression.pytest_plugin"
    import importlib

    plugin = importlib.import_module(target)
    assert callable(plugin.pytest_addoption) and hasattr(plugin, "auralize_regression")


def test_the_fixture_records_checks_and_names_what_moved(pytester, recorded, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    data, doubled, _, _ = recorded
    # the plugin as pytest loads it from the entry point, without the others installed here
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")
    pytester.makepyfile(
        test_sim=f"""
        import os

        def test_simulation(auralize_regression):
            data = os.environ.get("SIM_DATA", {str(data)!r})
            auralize_regression.check(data, listener=(2, 0.5, 0.5), duration=1.0, rate=8000,
                                      highpass_hz=0.0, timbre="physical",
                                      screenshot_size=[320, 240])
    """
    )
    args = ["-p", "auralize.regression.pytest_plugin", "-p", "no:cacheprovider"]
    first = pytester.runpytest(*args)
    first.assert_outcomes(failed=1)
    first.stdout.fnmatch_lines(["*no expectation yet; recorded*test_simulation.json*"])
    stored = pytester.path / "auralize_regression" / "test_simulation.json"
    assert stored.is_file() and stored.with_suffix(".png").is_file()
    pytester.runpytest(*args).assert_outcomes(passed=1)
    monkeypatch.setenv("SIM_DATA", str(doubled))
    moved = pytester.runpytest(*args, "--auralize-regression-report", "reports")
    moved.assert_outcomes(failed=1)
    moved.stdout.fnmatch_lines(["*level window*moved by +6.02 dB*"])
    assert (pytester.path / "reports" / "test_simulation" / "report.md").is_file()
    # a change meant: record again, and the check passes
    pytester.runpytest(*args, "--auralize-regression-record").assert_outcomes(passed=1)
    pytester.runpytest(*args).assert_outcomes(passed=1)


# ------------------------------------------------------------------ the project's own
def test_the_project_regression_names_moved_figures_the_same_way() -> None:
    stored = json.loads((synthetic.STORE / "explosion.json").read_text())
    got = {**stored, "rms": stored["rms"] * 1.05}
    got["counts"] = [dict(c) for c in stored["counts"]]
    got["counts"][3]["monopole"] = int(1.1 * got["counts"][3]["monopole"]) + 10
    problems = synthetic.compare("explosion", got)
    assert any(
        p.startswith("rms: ") and "moved by" in p and "tolerance ±1 %" in p for p in problems
    )
    assert any(p.startswith("counts step 3 monopole: ") for p in problems)
    assert synthetic.compare("explosion", stored) == []
    name = next(iter(json.loads(real.STORE.read_text())))
    same = json.loads(real.STORE.read_text())[name]
    assert real.compare(name, same) == []
