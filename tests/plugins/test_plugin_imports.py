"""Plugins reach the core through the SoundModel contract, never through the CLI or the bench.

``auralize.cli`` and ``auralize.bench`` are applications; a plugin that imports
them loads them and ties itself to their internals.  The shared option helpers
reach a plugin as the ``options`` argument of its ``add_commands`` /
``add_cli`` hooks, and the bench row type and timer (``BenchRow``,
``best_of``) are part of the contract (:mod:`auralize.plugins`).
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

PLUGINS = Path(__file__).resolve().parents[2] / "plugins"
SOURCES = sorted(PLUGINS.rglob("*.py"))
FORBIDDEN = ("auralize.cli", "auralize.bench")


def _cli_module(name: str) -> bool:
    """``auralize.cli``, ``auralize.cli.options``, ``auralize.bench.runner``, … or a name in one."""
    return any(name == f or name.startswith(f + ".") for f in FORBIDDEN)


def _imported(tree: ast.AST) -> list[tuple[int, str]]:
    """Every module an ``import`` / ``from … import`` / ``import_module("…")`` names."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.append((node.lineno, node.module))
            out += [(node.lineno, f"{node.module}.{a.name}") for a in node.names]
        elif (
            isinstance(node, ast.Call)
            and getattr(node.func, "attr", getattr(node.func, "id", "")) == "import_module"
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
        ):
            out.append((node.lineno, node.args[0].value))
    return out


def test_the_scan_sees_every_plugin_and_detects_cli_imports() -> None:
    assert {p.parent.name for p in SOURCES} >= {
        "auralize_fire",
        "auralize_aero",
        "auralize_vortex",
        "auralize_spark",
    }
    bad = ast.parse(
        "from auralize.cli import add_output_options\nimport auralize.cli.audio\n"
        "from auralize import cli\nimportlib.import_module('auralize.cli')\n"
        "from auralize.cli.options import rate_int\nfrom auralize.bench import BenchRow\n"
        "from auralize.plugins import BenchRow\nimport auralize.cli_like\n"
    )
    assert {n for _, n in _imported(bad) if _cli_module(n)} == {
        "auralize.cli",
        "auralize.cli.add_output_options",
        "auralize.cli.audio",
        "auralize.cli.options",
        "auralize.cli.options.rate_int",
        "auralize.bench",
        "auralize.bench.BenchRow",
    }


@pytest.mark.parametrize("src", SOURCES, ids=[str(p.relative_to(PLUGINS)) for p in SOURCES])
def test_plugin_does_not_import_the_cli(src: Path) -> None:
    found = [
        f"{src.relative_to(PLUGINS)}:{line}: {name}"
        for line, name in _imported(ast.parse(src.read_text(), str(src)))
        if _cli_module(name)
    ]
    assert not found, "plugins import neither the CLI nor the bench: " + "; ".join(found)


def test_declaring_every_plugin_command_loads_no_cli_module() -> None:
    code = (
        "import argparse, sys\n"
        "from auralize_fire.cli import add_fire_cli\n"
        "from auralize_aero.commands import add_commands as aero\n"
        "from auralize_vortex.commands import add_commands as vortex\n"
        "from auralize_spark.commands import add_commands as spark\n"
        "before = sorted(m for m in sys.modules if m.startswith(('auralize.cli', 'auralize.bench')))\n"
        "from auralize.cli import options\n"
        "sub = argparse.ArgumentParser().add_subparsers()\n"
        "for add in (add_fire_cli, aero, vortex, spark):\n"
        "    add(sub, options)\n"
        "print(before, sorted(sub.choices))\n"
    )
    root = PLUGINS.parent
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), str(PLUGINS)])}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    assert out.stdout.split() == ["[]", "['aero',", "'fire',", "'spark',", "'vortex']"]
