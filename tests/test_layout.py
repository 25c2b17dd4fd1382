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

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "auralize"
PLUGINS = ROOT / "plugins"


def _module_name(path: Path, base: Path) -> str:
    parts = list(path.relative_to(base).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _sources(base: Path, top: str) -> dict[str, Path]:
    return {_module_name(p, base): p for p in sorted((base / top).rglob("*.py"))}


MODULES = _sources(ROOT, "auralize")


def _resolve(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    """The absolute module an ``ImportFrom`` names (relative imports resolved)."""
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _imports(module: str, path: Path, *, top_only: bool) -> list[tuple[int, str, list[str]]]:
    """``(line, module, names)`` of the imports of ``path`` (module level only if ``top_only``)."""
    tree = ast.parse(path.read_text(), str(path))
    nodes = tree.body if top_only else list(ast.walk(tree))
    is_package = path.name == "__init__.py"
    out = []
    for node in nodes:
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name, []) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            out.append((node.lineno, _resolve(node, module, is_package),
                        [a.name for a in node.names]))  # fmt: skip
        elif top_only and isinstance(node, ast.If) and _is_type_checking(node.test):
            continue  # imports for annotations only run under a type checker
    return out


def _is_type_checking(test: ast.expr) -> bool:
    return isinstance(test, ast.Name) and test.id == "TYPE_CHECKING"


def _targets(mod: str, names: list[str], known: dict[str, Path]) -> set[str]:
    """The known modules an import statement loads (``from pkg import submodule`` too)."""
    out = {mod} if mod in known else set()
    out |= {f"{mod}.{n}" for n in names if f"{mod}.{n}" in known}
    return out


def _graph(known: dict[str, Path]) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for mod, path in known.items():
        deps: set[str] = set()
        for _, target, names in _imports(mod, path, top_only=True):
            deps |= _targets(target, names, known)
        graph[mod] = deps - {mod}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _family(module: str) -> str:
    """The package a module belongs to: ``auralize.sources`` for ``auralize.sources.detection``.

    Top-level modules (``auralize.pipeline``) are their own family.
    """
    parts = module.split(".")
    return ".".join(parts[:2])


def _private_imports(known: dict[str, Path], root: Path = ROOT) -> list[str]:
    """``from auralize.x import _name`` lines where ``_name`` is not the importer's own.

    A package's private modules (``auralize.sources._kernels``,
    ``auralize.emitters._kernels.gains``) are its implementation: the modules
    of the same package may import them and their private names.  Anything
    else takes public names only.
    """
    bad = []
    for mod, path in known.items():
        package = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
        for line, target, names in _imports(mod, path, top_only=False):
            if not target.startswith("auralize"):
                continue
            private_module = any(p.startswith("_") for p in target.split(".")[1:])
            if _family(target) == _family(mod) and (private_module or target == package):
                continue
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if private or private_module:
                bad.append(f"{path.relative_to(root)}:{line}: from {target} import "
                           f"{', '.join(private) or ', '.join(names)}")  # fmt: skip
    return bad


def test_the_graph_sees_the_packages_and_finds_a_cycle() -> None:
    graph = _graph(MODULES)
    assert {"auralize.cli.core", "auralize.emitters.engine", "auralize.sources.detection"} <= set(
        graph
    )
    assert "auralize.volume" in graph["auralize.io.hdf5"]
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycle_among_auralize_modules() -> None:
    assert _cycles(_graph(MODULES)) == []


def test_no_import_cycle_inside_a_plugin() -> None:
    for top in sorted(p.name for p in PLUGINS.glob("auralize_*")):
        assert _cycles(_graph(_sources(PLUGINS, top))) == [], top


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
    known = _sources(tmp_path, "auralize")
    bad = _private_imports(known, tmp_path)
    assert sorted(b.split(": ", 1)[1] for b in bad) == [
        "from auralize.cli.core import _load",
        "from auralize.sources import _kernels",
        "from auralize.sources.detection import _StepCache",
    ]


def test_no_private_name_crosses_a_package() -> None:
    bad = _private_imports(MODULES)
    for top in sorted(p.name for p in PLUGINS.glob("auralize_*")):
        bad += [b for b in _private_imports(_sources(PLUGINS, top)) if "auralize." in b]
    assert bad == []


def test_plugins_import_no_private_core_name() -> None:
    bad = []
    for path in sorted(PLUGINS.rglob("*.py")):
        mod = _module_name(path, PLUGINS)
        for line, target, names in _imports(mod, path, top_only=False):
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
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env=env, timeout=120)  # fmt: skip
    assert out.stdout.split() == ["[]"]


def test_only_the_viewer_imports_qt() -> None:
    qt = ("PySide6", "PyQt5", "PyQt6", "PySide2", "qtpy", "pyvistaqt")
    bad = []
    for mod, path in MODULES.items():
        if mod == "auralize.viewer" or mod.startswith("auralize.viewer."):
            continue
        for line, target, _ in _imports(mod, path, top_only=False):
            if target.split(".")[0] in qt:
                bad.append(f"{path.relative_to(ROOT)}:{line}: {target}")
    assert bad == []
