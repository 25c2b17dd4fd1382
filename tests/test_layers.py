"""The packages form layers, and no cycle, with imports inside functions counted.

Two checks of the same promise (DESIGN: "an import inside a function is still an
arrow; the packages form no cycle when those are counted"):

* the import-linter contracts of ``[tool.importlinter]`` in ``pyproject.toml``
  (the layer order, no cycle among the children of ``auralize``, nothing below
  imports the command line or the viewer, the bottom imports nothing, plugins
  import neither the command line nor the bench), run through import-linter's
  API;
* an own reading of the sources with :mod:`ast`: each sub-package of
  ``auralize`` and each top-level module (``auralize.volume``) is a node, every
  import anywhere in a module (module level, inside functions, under
  ``TYPE_CHECKING``) and every absolute module named in a package's lazy
  exports (``_EXPORTS``) is an arrow, and the strongly connected components of
  more than one node are the package cycles.

Each check is shown to fail on a small fabricated package with a cycle.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from import_scan import cycles, imports, lazy_exports, modules

ROOT = Path(__file__).resolve().parents[1]
PLUGINS = ROOT / "plugins"


def _node(module: str) -> str:
    """The package-level node of a module: ``auralize.sources`` for
    ``auralize.sources.detection``, ``auralize.volume`` for itself, ``auralize`` for the root."""
    return ".".join(module.split(".")[:2])


def _imported(module: str, path: Path, known: dict[str, Path]) -> set[str]:
    """The known modules that ``module`` imports anywhere, or names in its lazy exports."""
    out: set[str] = set(lazy_exports(path))
    for _, target, names in imports(module, path, top_only=False):
        out |= {target} | {f"{target}.{n}" for n in names}
    return {m for m in out if m in known}


def package_graph(known: dict[str, Path]) -> dict[str, dict[str, list[str]]]:
    """``{node: {imported node: ["importer -> imported", ...]}}`` between different nodes
    (the root package, which only re-exports, is left out as a target)."""
    root = min(known, key=len)
    graph: dict[str, dict[str, list[str]]] = {}
    for module, path in known.items():
        a = _node(module)
        graph.setdefault(a, {})
        for target in sorted(_imported(module, path, known)):
            b = _node(target)
            if b not in (a, root):
                graph[a].setdefault(b, []).append(f"{module} -> {target}")
    return graph


package_cycles = cycles


def _explain(graph: dict[str, dict[str, list[str]]], cycles: list[list[str]]) -> str:
    lines = []
    for comp in cycles:
        lines.append(f"cycle of {len(comp)} packages: {', '.join(comp)}")
        for a in comp:
            for b, why in sorted(graph[a].items()):
                if b in comp:
                    lines.append(f"  {a} -> {b}: {'; '.join(why[:3])}")
    return "\n".join(lines)


# ------------------------------------------------------------------ the own reading


def test_the_cycle_finder_finds_a_cycle_and_leaves_a_chain() -> None:
    assert package_cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert package_cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []
    assert package_cycles({"x": {"y"}, "y": {"x"}, "a": {"b"}, "b": {"a"}}) == [
        ["a", "b"],
        ["x", "y"],
    ]


def test_imports_inside_functions_and_lazy_exports_are_arrows(tmp_path: Path) -> None:
    pkg = tmp_path / "demo"
    (pkg / "low").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from demo.high import f\n")
    (pkg / "high.py").write_text("from demo.low.base import g\n\ndef f():\n    return g()\n")
    (pkg / "low" / "__init__.py").write_text('_EXPORTS = {"h": "demo.other"}\n')
    (pkg / "low" / "base.py").write_text("def g():\n    from demo import high\n    return high\n")
    (pkg / "other.py").write_text("from .low import base\n")
    graph = package_graph(modules(tmp_path, "demo"))
    assert set(graph["demo.high"]) == {"demo.low"}
    assert set(graph["demo.low"]) == {"demo.high", "demo.other"}  # in a function; lazy export
    assert set(graph["demo.other"]) == {"demo.low"}  # a relative import
    assert "demo" not in graph["demo.low"]  # the root only re-exports
    cycles = package_cycles(graph)
    assert cycles == [["demo.high", "demo.low", "demo.other"]]
    assert "demo.low.base -> demo.high" in _explain(graph, cycles)


def test_the_graph_sees_the_packages_and_their_lazy_imports() -> None:
    graph = package_graph(modules(ROOT, "auralize"))
    assert {"auralize.sources", "auralize.emitters", "auralize.cli", "auralize.volume"} <= set(
        graph
    )
    assert "auralize.viewer" in graph["auralize.cli"]  # imported inside cmd_view only
    assert "auralize.plugins" in graph["auralize.bench"]  # a lazy export of BenchRow


def test_no_cycle_among_the_packages() -> None:
    graph = package_graph(modules(ROOT, "auralize"))
    cycles = package_cycles(graph)
    assert cycles == [], _explain(graph, cycles)


# ------------------------------------------------------------------ import-linter


def _lint(pyproject: Path, *paths: Path) -> subprocess.CompletedProcess[str]:
    """``lint-imports`` on ``pyproject``'s ``[tool.importlinter]`` contracts (in a fresh
    interpreter, the packages found on ``paths`` first)."""
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([*map(str, paths), os.environ.get("PYTHONPATH", "")]),
    }
    code = "from importlinter.cli import lint_imports_command; lint_imports_command()"
    return subprocess.run(
        [sys.executable, "-c", code, "--config", str(pyproject), "--no-cache"],
        capture_output=True,
        text=True,
        env=env,
        cwd=pyproject.parent,
        timeout=300,
    )


def test_the_import_contracts_hold() -> None:
    pytest.importorskip("importlinter", reason="pip install import-linter (the dev extra)")
    out = _lint(ROOT / "pyproject.toml", ROOT, PLUGINS)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "Contracts: 5 kept, 0 broken." in out.stdout


def test_the_import_contracts_catch_an_upward_import_and_a_cycle(tmp_path: Path) -> None:
    pytest.importorskip("importlinter", reason="pip install import-linter (the dev extra)")
    pkg = tmp_path / "layerdemo"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "top.py").write_text("from layerdemo import bottom\n")
    (pkg / "bottom.py").write_text("def f():\n    from layerdemo import top\n    return top\n")
    (tmp_path / "pyproject.toml").write_text(
        '[tool.importlinter]\nroot_packages = ["layerdemo"]\n\n'
        '[[tool.importlinter.contracts]]\nid = "layers"\nname = "demo layers"\n'
        'type = "layers"\ncontainers = ["layerdemo"]\nlayers = ["top", "bottom"]\n\n'
        '[[tool.importlinter.contracts]]\nid = "acyclic"\nname = "demo acyclic"\n'
        'type = "acyclic_siblings"\nancestors = ["layerdemo"]\ndepth = 0\n'
    )
    out = _lint(tmp_path / "pyproject.toml", tmp_path)
    assert out.returncode == 1, out.stdout + out.stderr
    assert "demo layers BROKEN" in out.stdout and "demo acyclic BROKEN" in out.stdout
    assert "layerdemo.bottom -> layerdemo.top" in out.stdout
