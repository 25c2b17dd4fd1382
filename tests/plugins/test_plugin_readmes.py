"""Every sound-model plugin has a README: in the guide, in the wheel, with commands that parse.

``docs/guide/plugins.md`` sends readers to each plugin's ``README.md``; the
guide includes each one as a page of its own (``docs/guide/plugin-NAME.md``,
listed in the toctree), the wheel ships it beside the package and the sdist
under ``plugins/``.  Every ``auralize ...`` line of a README's ``sh`` blocks
must parse with the real command line, and every name a ``python`` block
imports must exist (running them is the work of the README's author: they
take minutes).
"""

from __future__ import annotations

import ast
import importlib
import re
import shlex
import tomllib
from pathlib import Path

import pytest

from auralize.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]
PLUGINS = sorted(p for p in (ROOT / "plugins").glob("auralize_*") if (p / "__init__.py").is_file())
IDS = [p.name for p in PLUGINS]


def _blocks(text: str, lang: str) -> list[str]:
    return re.findall(rf"^```{lang}\n(.*?)^```", text, flags=re.S | re.M)


def _command_lines(readme: Path) -> list[list[str]]:
    """The ``auralize`` commands of the README's ``sh`` blocks (continuations joined)."""
    out = []
    for block in _blocks(readme.read_text(encoding="utf-8"), "sh"):
        for line in block.replace("\\\n", " ").splitlines():
            argv = shlex.split(line, comments=True)
            if argv and argv[0] == "auralize":
                out.append(argv[1:])
    return out


def test_the_four_plugins_are_found() -> None:
    assert {"auralize_vortex", "auralize_fire", "auralize_spark", "auralize_aero"} <= set(IDS)


@pytest.mark.parametrize("pkg", PLUGINS, ids=IDS)
def test_readme_names_its_paper_and_is_a_page_of_the_guide(pkg: Path) -> None:
    readme = pkg / "README.md"
    assert readme.is_file(), f"{pkg.name} has no README.md"
    title = readme.read_text(encoding="utf-8").splitlines()[0]
    assert re.fullmatch(rf"# {pkg.name} — .+ \(paper \d{{3}}\)", title), title
    short = pkg.name.removeprefix("auralize_")
    page = ROOT / "docs" / "guide" / f"plugin-{short}.md"
    assert page.read_text(encoding="utf-8") == (
        f"```{{include}} ../../plugins/{pkg.name}/README.md\n:relative-images:\n```\n"
    )
    guide = (ROOT / "docs" / "guide" / "plugins.md").read_text(encoding="utf-8")
    (toctree,) = _blocks(guide, r"\{toctree\}")
    assert f"plugin-{short}" in toctree.splitlines()


@pytest.mark.parametrize("pkg", PLUGINS, ids=IDS)
def test_readme_ships_in_the_wheel_and_the_sdist(pkg: Path) -> None:
    conf = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert "README.md" in conf["tool"]["setuptools"]["package-data"].get(pkg.name, [])
    manifest = (ROOT / "MANIFEST.in").read_text(encoding="utf-8").splitlines()
    assert any(
        ln.split()[:2] == ["recursive-include", "plugins"] and "*.md" in ln.split()[2:]
        for ln in manifest
    )


@pytest.mark.parametrize("pkg", PLUGINS, ids=IDS)
def test_readme_commands_parse(pkg: Path) -> None:
    commands = _command_lines(pkg / "README.md")
    assert commands, f"{pkg.name}/README.md shows no auralize command"
    parser = build_parser()
    for argv in commands:
        try:
            args = parser.parse_args(argv)
        except SystemExit:  # argparse prints the reason on stderr
            pytest.fail(f"{pkg.name}/README.md: 'auralize {shlex.join(argv)}' does not parse")
        assert callable(args.func), argv


@pytest.mark.parametrize("pkg", PLUGINS, ids=IDS)
def test_readme_python_imports_exist(pkg: Path) -> None:
    blocks = _blocks((pkg / "README.md").read_text(encoding="utf-8"), "python")
    assert blocks, f"{pkg.name}/README.md shows no Python"
    for block in blocks:
        tree = ast.parse(block)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module:
                mod = importlib.import_module(node.module)
                missing = [a.name for a in node.names if not hasattr(mod, a.name)]
                assert not missing, f"{pkg.name}/README.md: {node.module} has no {missing}"
            elif isinstance(node, ast.Import):
                for a in node.names:
                    importlib.import_module(a.name)
