"""The wheel built from this checkout, installed in a fresh virtual environment.

Marked ``packaging`` (deselected in the default run: from a cold numba cache
the installed copy compiles its kernels, minutes on 2 cores); ``.ci/run``
runs it as its own step: ``pytest -m packaging tests/test_wheel.py``.

The environment reuses the dependencies installed for the running
interpreter (a ``.pth`` line naming its ``site-packages``, without running
that folder's own ``.pth`` files, so an editable auralize there is not
loaded); auralize itself comes from the wheel, the checkout is not on
``sys.path`` and the commands run from a scratch folder.
"""

from __future__ import annotations

import os
import resource
import shutil
import site
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.packaging

ROOT = Path(__file__).resolve().parents[1]


def _sh(
    cmd: list[str], *, cwd: Path, env: dict[str, str] | None = None, timeout: float = 1800
) -> str:
    out = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert out.returncode == 0, f"{' '.join(cmd)} failed:\n{out.stdout}\n{out.stderr}"
    return out.stdout + out.stderr


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("wheel")
    # the sources as git knows them (committed and new, not ignored), copied so
    # that building leaves nothing in the checkout
    files = subprocess.run(
        ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT,
        capture_output=True,
        check=True,
    ).stdout.split(b"\0")
    src = tmp / "src"
    for f in filter(None, (x.decode() for x in files)):
        if (ROOT / f).is_file():
            (src / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / f, src / f)
    venv = tmp / "venv"
    _sh([sys.executable, "-m", "venv", "--without-pip", str(venv)], cwd=tmp)
    py = venv / "bin" / "python"
    purelib = Path(
        _sh(
            [str(py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"], cwd=tmp
        ).strip()
    )
    (purelib / "_auralize_test_deps.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    # build with setuptools >= 77 (SPDX licence expression); CI has it (constraints.txt)
    need = "import setuptools, sys; sys.exit(int(setuptools.__version__.split('.')[0]) < 77)"
    if subprocess.run([str(py), "-c", need], env=env, cwd=tmp).returncode:
        _sh([str(py), "-m", "pip", "install", "-q", "setuptools>=77"], cwd=tmp, env=env)
    dist = tmp / "dist"
    code = (
        "from setuptools import build_meta as b; "
        f"print('BUILT', b.build_wheel({str(dist)!r})); print('BUILT', b.build_sdist({str(dist)!r}))"
    )
    out = _sh([str(py), "-c", code], cwd=src, env=env)
    built = [ln.split()[1] for ln in out.splitlines() if ln.startswith("BUILT ")]
    wheel, sdist = dist / built[-2], dist / built[-1]
    _sh(
        [str(py), "-m", "pip", "install", "-q", "--no-deps", "--no-index", str(wheel)],
        cwd=tmp,
        env=env,
    )
    run = tmp / "run"
    run.mkdir()
    env["NUMBA_CACHE_DIR"] = str(tmp / "numba")
    return {"venv": venv, "wheel": wheel, "sdist": sdist, "run": run, "env": env}  # type: ignore[dict-item]


def test_wheel_and_sdist_carry_data_licences_and_examples(installed: dict) -> None:  # type: ignore[type-arg]
    names = set(zipfile.ZipFile(installed["wheel"]).namelist())
    for f in (
        "auralize/data/regression/explosion.json",
        "auralize/data/PROVENANCE.md",
        "auralize/data/openfoam-cavity/OpenFOAM.zip",
        "auralize_fire/data/candle_2s.f32",
        "auralize_fire/data/LICENSE-BSD-2-Clause",
        "auralize/py.typed",
        "auralize-0.1.0.dist-info/licenses/LICENSE",
    ):
        assert f in names, f
    meta = zipfile.ZipFile(installed["wheel"]).read("auralize-0.1.0.dist-info/METADATA").decode()
    assert "License-Expression: BSD-3-Clause" in meta
    # every licence file shipped beside a dataset is named in the metadata too
    shipped = sorted(
        n.split("/", 1)[1]
        for n in names
        if "/data/" in n and ".dist-info/" not in n and n.rsplit("/", 1)[-1].startswith("LICENSE")
    )
    assert len(shipped) >= 7, shipped
    declared = {ln.split(": ", 1)[1] for ln in meta.splitlines() if ln.startswith("License-File:")}
    for lic in shipped:
        assert any(d.endswith(lic) for d in declared), (lic, declared)
    assert "Provides-Extra: notebook" in meta
    requires = [ln for ln in meta.splitlines() if ln.startswith("Requires-Dist:")]
    assert "Requires-Dist: numpy>=2.0.2" in requires
    assert not [r for r in requires if "==" in r.split(";")[0]], requires
    import tarfile

    members = {m.split("/", 1)[1] for m in tarfile.open(installed["sdist"]).getnames() if "/" in m}
    for f in (
        "LICENSE",
        "constraints.txt",
        "examples/explosion_tour.py",
        "examples/regression_check.py",
        "examples/batch_render.py",
        "examples/notebook_tour.ipynb",
        "auralize/data/regression/explosion.json",
        "tests/test_wheel.py",
    ):
        assert f in members, f


# a cold compile of every kernel (``auralize warmup``) takes 10 CPU-minutes or more on
# a 2-core machine: past the suite's default per-test limit
@pytest.mark.timeout(3000)
def test_installed_wheel_starts_fast_and_runs_the_demo_and_regression(installed: dict) -> None:  # type: ignore[type-arg]
    venv, run, env = installed["venv"], installed["run"], installed["env"]
    py, exe = str(venv / "bin" / "python"), str(venv / "bin" / "auralize")
    where = _sh(
        [
            py,
            "-c",
            "import auralize, auralize_fire, sys; print(auralize.__file__); "
            "print(auralize_fire.__file__); print(sys.path)",
        ],
        cwd=run,
        env=env,
    )
    lines = where.splitlines()
    assert lines[0].startswith(str(venv)) and lines[1].startswith(str(venv)), where
    # the checkout (and its plugins folder) is not importable; the venv it was
    # installed from may live inside it (``.venv``), which is fine
    import ast

    inside = [p for p in ast.literal_eval(lines[2]) if p and Path(p).resolve().is_relative_to(ROOT)]
    assert all(Path(p).resolve().is_relative_to(ROOT / ".venv") for p in inside), inside
    # start-up: --version, --help and a plugin's --help load no physics; CPU
    # seconds (user + system) of the process, best of 3, so that a loaded
    # machine does not decide
    for cmd in (["--version"], ["--help"], ["vortex", "render", "--help"]):
        best = min(_cpu_seconds([exe, *cmd], run, env) for _ in range(3))
        assert best < 0.5, f"auralize {' '.join(cmd)}: {best:.2f} CPU-s"
    # the install step, then the demo and the regression check from the wheel's copy
    _sh([exe, "warmup"], cwd=run, env=env)
    out = _sh([exe, "demo", "--size", "24", "-o", "demo"], cwd=run, env=env)
    assert "compiling kernels" not in out, out
    for f in ("explosion_ring8.wav", "explosion.png", "explosion_spectrogram.png"):
        assert (run / "demo" / f).stat().st_size > 1000
    _sh([py, "-m", "auralize.regression.synthetic"], cwd=run, env=env)
    clip = _sh(
        [
            py,
            "-c",
            "import numpy as np; from auralize_fire.benchmark import DATA; "
            "print(np.fromfile(DATA / 'candle_2s.f32', dtype='<f4').size)",
        ],
        cwd=run,
        env=env,
    )
    assert int(clip.split()[-1]) == 88200


def _cpu_seconds(cmd: list[str], cwd: Path, env: dict[str, str]) -> float:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    _sh(cmd, cwd=cwd, env=env)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
