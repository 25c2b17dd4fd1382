"""Plugins take the shared options from :mod:`auralize.cli.options`, never from the CLI.

``auralize.cli`` (and its ``cli_*`` parts) is the application; a plugin that
imports it loads the whole CLI and ties itself to its internals.  The
``auralize.bench`` helpers (``BenchRow``, ``best_of``) are a library API the
plugins' ``bench`` hooks use, so they are allowed.
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
ALLOWED = {"auralize.cli.options"}


def _cli_module(name: str) -> bool:
    """``auralize.cli``, ``auralize.cli.audio``, … or a name in one; not ``cli_options``."""
    top = ".".join(name.split(".")[:2])
    return top.startswith("auralize.cli") and top not in ALLOWED


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
        "from auralize.cli.options import rate_int\n"
    )
    assert {n for _, n in _imported(bad) if _cli_module(n)} == {
        "auralize.cli",
        "auralize.cli.add_output_options",
        "auralize.cli.audio",
    }


@pytest.mark.parametrize("src", SOURCES, ids=[str(p.relative_to(PLUGINS)) for p in SOURCES])
def test_plugin_does_not_import_the_cli(src: Path) -> None:
    found = [
        f"{src.relative_to(PLUGINS)}:{line}: {name}"
        for line, name in _imported(ast.parse(src.read_text(), str(src)))
        if _cli_module(name)
    ]
    assert not found, "plugins import auralize.cli.options, not the CLI: " + "; ".join(found)


def test_declaring_every_plugin_command_loads_no_cli_module() -> None:
    code = (
        "import argparse, sys\n"
        "from auralize_fire.cli import add_fire_cli\n"
        "from auralize_aero.commands import add_commands as aero\n"
        "from auralize_vortex.commands import add_commands as vortex\n"
        "from auralize_spark.commands import add_commands as spark\n"
        "sub = argparse.ArgumentParser().add_subparsers()\n"
        "for add in (add_fire_cli, aero, vortex, spark):\n"
        "    add(sub)\n"
        "print(sorted(m for m in sys.modules if m.startswith('auralize.cli')))\n"
    )
    root = PLUGINS.parent
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), str(PLUGINS)])}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    assert out.stdout.split() == ["['auralize.cli.options']"]
