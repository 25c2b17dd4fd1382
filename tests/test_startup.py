"""Start-up: ``import auralize`` changes nothing process-wide, plugin sub-commands are
declared without loading the plugins' physics, lazy plugin exports behave like eager ones."""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from auralize.cli.plugin_commands import LazyCommand, lazy
from auralize.runtime import jit
from auralize.runtime.jit import kernel_digest

ROOT = Path(__file__).resolve().parents[1]
PLUGINS = ("auralize_vortex", "auralize_fire", "auralize_aero", "auralize_spark")


def _run(code: str, **env: str) -> dict:  # type: ignore[type-arg]
    # a process as a user starts it (Dask's tests leave MALLOC_TRIM_THRESHOLD_ in this one)
    e = {
        k: v
        for k, v in os.environ.items()
        if k not in ("OMP_WAIT_POLICY", "GLIBC_TUNABLES") and not k.startswith("MALLOC_")
    }
    e.update(env)
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=e, check=True, timeout=120
    )
    return json.loads(out.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def test_import_auralize_changes_no_process_setting() -> None:
    got = _run(
        "import os, sys, json; before = dict(os.environ); import auralize, auralize.cli; "
        "print(json.dumps({'env': sorted(set(os.environ.items()) ^ set(before.items())), "
        "'mods': [m for m in ('numba', 'PySide6', 'sounddevice', 'pyvista', 'vtk') if m in sys.modules]}))"
    )
    assert got == {"env": [], "mods": []}


def test_kernel_modules_set_their_numba_settings_on_import(tmp_path: Path) -> None:
    got = _run(
        "import os, json, numba; import auralize.sources._kernels; "
        "print(json.dumps([os.environ.get('OMP_WAIT_POLICY'), numba.config.CACHE_DIR]))",
        NUMBA_CACHE_DIR=str(tmp_path),
    )
    assert got == ["passive", str(tmp_path)]


GLIBC = sys.platform == "linux" and __import__("platform").libc_ver()[0] == "glibc"
#: a 2 s swinging stick rendered 8 times (results discarded, as a bench or a batch does):
#: status of the allocator tuning, and the pages first touched by each render
_RENDERS = (
    "import json, resource; from auralize.listener import ListenerPath; "
    "from auralize_aero import circle, compute_texture, stick; "
    "from auralize_aero.objects import Motion; from auralize_aero.render import render; "
    "from auralize.runtime.allocator import status; "
    "tex = compute_texture(circle(0.01), resolution=6, duration=0.005, u_lattice=0.15, cache=False); "
    "m = Motion.swing(duration=2.0, swings=4, amplitude_deg=80.0, rate_hz=200.0); "
    "p = ListenerPath.point((0.3, 1.0, 0.2), duration=2.0); obj = stick(0.5, 0.01); faults = []\n"
    "for _ in range(8):\n"
    "    f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt; render(tex, obj, p, motion=m)\n"
    "    faults.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0)\n"
    "print(json.dumps([status(), faults]))"
)


def test_import_auralize_leaves_the_allocator_alone() -> None:
    got = _run(
        "import json, auralize, auralize.cli; from auralize.runtime.allocator import status; "
        "print(json.dumps(status()))"
    )
    assert got is None


@pytest.mark.skipif(not GLIBC, reason="the allocator tuning is glibc's mallopt")
def test_renders_reuse_their_memory_once_kernels_are_loaded() -> None:
    """With the tuning, a render's arrays land on memory freed by the previous render
    (no page is touched for the first time); glibc's defaults unmap and map them again."""
    status, faults = _run(_RENDERS)
    assert status == "tuned"
    assert max(faults[3:]) < 50, faults  # a render of this case touches ~2,000 new pages
    status, untuned = _run(_RENDERS, AURALIZE_MALLOC_TUNING="0")
    assert status == "AURALIZE_MALLOC_TUNING=0"
    assert min(untuned[3:]) > 10 * max(50, max(faults[3:])), (faults, untuned)


@pytest.mark.skipif(not GLIBC, reason="the allocator tuning is glibc's mallopt")
def test_the_users_allocator_settings_are_kept() -> None:
    code = (
        "import json, auralize.sources._kernels; from auralize.runtime.allocator import status; "
        "print(json.dumps(status()))"
    )
    assert _run(code, GLIBC_TUNABLES="glibc.malloc.trim_threshold=65536") == (
        "the allocator is tuned by the environment"
    )
    assert _run(code, MALLOC_MMAP_THRESHOLD_="65536") == "the allocator is tuned by the environment"
    assert _run(code) == "tuned"
    # a Dask worker overrides its nanny's setting
    forced = code.replace(
        "print(json.dumps(status()))",
        "from auralize.distributed.worker_setup import tune_allocator; "
        "print(json.dumps([status(), tune_allocator(), status()]))",
    )
    assert _run(forced, MALLOC_TRIM_THRESHOLD_="65536") == [
        "the allocator is tuned by the environment",
        True,
        "tuned",
    ]


@pytest.mark.parametrize("var", ["XDG_CACHE_HOME", "AURALIZE_CACHE_DIR"])
def test_one_cache_folder_for_kernels_and_textures(tmp_path: Path, var: str) -> None:
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("NUMBA_CACHE_DIR", "AURALIZE_CACHE_DIR", "AURALIZE_CACHE")
    }
    env[var] = str(tmp_path)
    code = (
        "import numba, auralize.sources._kernels; from auralize_vortex.texture import cache_dir as v; "
        "from auralize_aero.texture import cache_dir as a; print(numba.config.CACHE_DIR); "
        "print(v()); print(a())"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env=env,
        check=True,
        timeout=120,
    ).stdout.split()
    root = tmp_path / "auralize" if var == "XDG_CACHE_HOME" else tmp_path
    assert out == [str(root / "numba" / kernel_digest()), str(root), str(root / "aero")]


def test_kernel_cache_folder_follows_the_kernel_sources(tmp_path: Path) -> None:
    """A changed core kernel gets a new cache folder: kernels that inlined it recompile."""
    pkg = Path(jit.__file__).resolve().parent.parent
    for rel in jit.KERNEL_SOURCES:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(pkg / rel, tmp_path / rel)
    assert jit.kernel_digest(tmp_path) == kernel_digest()
    f = tmp_path / jit.KERNEL_SOURCES[1]
    f.write_bytes(f.read_bytes() + b"\n# changed\n")
    assert jit.kernel_digest(tmp_path) != kernel_digest()


@pytest.mark.parametrize("plugin", PLUGINS)
def test_plugin_commands_declared_without_physics(plugin: str) -> None:
    ep = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    target = ep["auralize.commands"][plugin.split("_")[1]]
    module, func = target.split(":")
    got = _run(
        "import argparse, importlib, json, sys; "
        f"ap = argparse.ArgumentParser(); sub = ap.add_subparsers(dest='command'); "
        f"getattr(importlib.import_module({module!r}), {func!r})"
        "(sub, importlib.import_module('auralize.cli.options')); "
        f"heavy = [m for m in sys.modules if m.startswith({plugin!r} + '.') "
        f"and m.split('.')[1] not in ('commands', 'cli')]; "
        "print(json.dumps({'heavy': heavy, 'numba': 'numba' in sys.modules, "
        "'scipy': 'scipy' in sys.modules, 'commands': sorted(sub.choices)}))"
    )
    assert got == {"heavy": [], "numba": False, "scipy": False, "commands": [plugin.split("_")[1]]}


def test_every_plugin_declares_its_commands_by_entry_point() -> None:
    ep = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    models = {n for n, v in ep["auralize.plugins"].items() if not v.startswith("auralize.")}
    assert set(ep["auralize.commands"]) == models


def test_declared_preset_choices_match_the_presets() -> None:
    import auralize_aero.commands as aero_cmd
    import auralize_spark.commands as spark_cmd
    from auralize_aero.presets import PRESETS as AERO
    from auralize_spark.presets import PRESETS as SPARK

    assert tuple(aero_cmd.PRESET_NAMES) == tuple(AERO)
    assert tuple(spark_cmd.PRESET_NAMES) == tuple(SPARK)


def test_lazy_command_imports_when_called() -> None:
    cmd = lazy("auralize.cli.core:_vec3")
    assert isinstance(cmd, LazyCommand)
    assert list(cmd("1,2,3")) == [1.0, 2.0, 3.0]  # type: ignore[arg-type]
    assert lazy("auralize_vortex.model:VortexSound._cmd_render").resolve().__name__ == "_cmd_render"
    with pytest.raises(ValueError, match="module:function"):
        lazy("auralize.cli")


def test_lazy_exports_keep_functions_over_submodules() -> None:
    import auralize_aero.render
    import auralize_vortex.texture
    from auralize_aero import render
    from auralize_vortex import texture

    assert callable(texture) and texture.__module__ == "auralize_vortex.texture"
    assert callable(render) and render.__module__ == "auralize_aero.render"
    assert auralize_vortex.texture is texture and auralize_aero.render is render
    import auralize_vortex

    assert "VortexSound" in dir(auralize_vortex)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        auralize_vortex.nope  # noqa: B018


def test_parser_serves_plugin_commands() -> None:
    from auralize.cli import build_parser

    ap = build_parser()
    args = ap.parse_args(
        ["spark", "render", "-o", "x.wav", "--listener", "0,0,1", "--duration", "0.1"]
    )
    assert isinstance(args.func, LazyCommand)
    assert args.func.target == "auralize_spark.model:cmd_spark_render"
    sub = next(a for a in ap._actions if isinstance(a, argparse._SubParsersAction))
    assert {"vortex", "fire", "aero", "spark", "warmup"} <= set(sub.choices)


def test_version_and_help_load_no_physics() -> None:
    # every registered model is listed (its class loaded), none of their physics is
    for args in (["--version"], ["--help"]):
        got = _run(
            "import sys, json, contextlib, io\n"
            "from auralize.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            f"    try: main({args!r})\n"
            "    except SystemExit: pass\n"
            "print(json.dumps({m: m in sys.modules for m in ('scipy', 'numba', 'pyvista')}))"
        )
        assert got == {"scipy": False, "numba": False, "pyvista": False}, args
