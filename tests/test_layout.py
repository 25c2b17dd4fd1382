"""The package layout keeps its promises: no import cycle, no private name across modules.

Read from the sources with :mod:`ast` (nothing is imported):

* module-level imports among ``auralize`` modules form no cycle (imports
  inside functions are the lazy ones that break load-time dependencies);
* no module imports another module's private name (``from auralize.x
  import _name``), except from the private modules of its own package
  (``auralize.sources._kernels``), which are that package's implementation;
* ``import auralize.simple`` (in a fresh interpreter) imports no Qt module.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from import_scan import cycles, imports, modules

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "auralize"
PLUGINS = ROOT / "plugins"


MODULES = modules(ROOT, "auralize")


def _targets(mod: str, names: list[str], known: dict[str, Path]) -> set[str]:
    """The known modules an import statement loads (``from pkg import submodule`` too)."""
    out = {mod} if mod in known else set()
    out |= {f"{mod}.{n}" for n in names if f"{mod}.{n}" in known}
    return out


def _graph(known: dict[str, Path]) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for mod, path in known.items():
        deps: set[str] = set()
        for _, target, names in imports(mod, path, top_only=True):
            deps |= _targets(target, names, known)
        graph[mod] = deps - {mod}
    return graph


def _family(module: str) -> str:
    """The package a module belongs to: ``auralize.sources`` for ``auralize.sources.detection``.

    Top-level modules (``auralize.pipeline``) are their own family.
    """
    parts = module.split(".")
    return ".".join(parts[:2])


def _privateimports(known: dict[str, Path], root: Path = ROOT) -> list[str]:
    """``from auralize.x import _name`` lines where ``_name`` is not the importer's own.

    A package's private modules (``auralize.sources._kernels``,
    ``auralize.emitters._kernels.gains``) are its implementation: the modules
    of the same package may import them and their private names.  Anything
    else takes public names only.
    """
    bad = []
    for mod, path in known.items():
        package = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
        for line, target, names in imports(mod, path, top_only=False):
            if not target.startswith("auralize"):
                continue
            private_module = any(p.startswith("_") for p in target.split(".")[1:])
            if _family(target) == _family(mod) and (private_module or target == package):
                continue
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if private or private_module:
                bad.append(
                    f"{path.relative_to(root)}:{line}: from {target} import "
                    f"{', '.join(private) or ', '.join(names)}"
                )
    return bad


def test_the_graph_sees_the_packages_and_finds_a_cycle() -> None:
    graph = _graph(MODULES)
    assert {"auralize.cli.core", "auralize.emitters.engine", "auralize.sources.detection"} <= set(
        graph
    )
    assert "auralize.volume" in graph["auralize.io.hdf5"]
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycle_among_auralize_modules() -> None:
    assert cycles(_graph(MODULES)) == []


def test_no_import_cycle_inside_a_plugin() -> None:
    for top in sorted(p.name for p in PLUGINS.glob("auralize_*")):
        assert cycles(_graph(modules(PLUGINS, top))) == [], top


def test_the_private_scan_flags_a_foreign_private_name(tmp_path: Path) -> None:
    pkg = tmp_path / "auralize"
    (pkg / "sources").mkdir(parents=True)
    (pkg / "cli").mkdir()
    (pkg / "pipeline.py").write_text("from auralize.sources.detection import _StepCache\n")
    (pkg / "sources" / "__init__.py").write_text("")
    (pkg / "sources" / "detection.py").write_text(
        "from auralize.sources import _kernels\nfrom auralize.sources._kernels import _f\n"
    )
    (pkg / "cli" / "__init__.py").write_text("")
    (pkg / "cli" / "core.py").write_text("from auralize.sources import _kernels\n")
    (pkg / "cli" / "audio.py").write_text("from auralize.cli.core import _load, main\n")
    known = modules(tmp_path, "auralize")
    bad = _privateimports(known, tmp_path)
    assert sorted(b.split(": ", 1)[1] for b in bad) == [
        "from auralize.cli.core import _load",
        "from auralize.sources import _kernels",
        "from auralize.sources.detection import _StepCache",
    ]


def test_no_private_name_crosses_a_package() -> None:
    bad = _privateimports(MODULES)
    for top in sorted(p.name for p in PLUGINS.glob("auralize_*")):
        bad += [b for b in _privateimports(modules(PLUGINS, top)) if "auralize." in b]
    assert bad == []


def test_plugins_import_no_private_core_name() -> None:
    bad = []
    for path in sorted(PLUGINS.rglob("*.py")):
        mod = ".".join(path.relative_to(PLUGINS).with_suffix("").parts).removesuffix(".__init__")
        for line, target, names in imports(mod, path, top_only=False):
            if target == "auralize" or target.startswith("auralize."):
                private = [n for n in names if n.startswith("_")]
                if private or any(p.startswith("_") for p in target.split(".")):
                    bad.append(f"{path.relative_to(ROOT)}:{line}: {target} {private}")
    assert bad == []


@pytest.mark.parametrize("module", ["auralize.simple", "auralize.scene", "auralize.viewer"])
def test_import_without_qt(module: str) -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(PLUGINS)])}
    code = (
        f"import sys, {module}\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in "
        "('PySide6', 'PyQt5', 'PyQt6', 'PySide2', 'qtpy', 'pyvistaqt')))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env=env,
        timeout=120,
    )
    assert out.stdout.split() == ["[]"]


def test_only_the_viewer_imports_qt() -> None:
    qt = ("PySide6", "PyQt5", "PyQt6", "PySide2", "qtpy", "pyvistaqt")
    bad = []
    for mod, path in MODULES.items():
        if mod == "auralize.viewer" or mod.startswith("auralize.viewer."):
            continue
        for line, target, _ in imports(mod, path, top_only=False):
            if target.split(".")[0] in qt:
                bad.append(f"{path.relative_to(ROOT)}:{line}: {target}")
    assert bad == []
