"""Reading a package's imports from its sources with :mod:`ast` (nothing is imported).

Shared by the layout tests (module-level cycles, private names) and the layer
tests (package cycles with imports inside functions counted).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path


def modules(base: Path, top: str) -> dict[str, Path]:
    """``{module name: file}`` of the package ``top`` under ``base``."""
    out = {}
    for path in sorted((base / top).rglob("*.py")):
        parts = list(path.relative_to(base).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def absolute(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    """The module an ``ImportFrom`` in ``module`` names, relative imports resolved."""
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _is_type_checking(test: ast.expr) -> bool:
    return isinstance(test, ast.Name) and test.id == "TYPE_CHECKING"


def imports(module: str, path: Path, *, top_only: bool) -> list[tuple[int, str, list[str]]]:
    """``(line, module, names)`` of the imports of ``path``: module level only (imports
    under ``if TYPE_CHECKING:`` left out) if ``top_only``, else every one anywhere."""
    tree = ast.parse(path.read_text(), str(path))
    nodes = tree.body if top_only else list(ast.walk(tree))
    is_package = path.name == "__init__.py"
    out = []
    for node in nodes:
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name, []) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            out.append(
                (node.lineno, absolute(node, module, is_package), [a.name for a in node.names])
            )
    return out


def lazy_exports(path: Path) -> set[str]:
    """Absolute module names in a package's lazy-export table (``_EXPORTS = {...}``)."""
    tree = ast.parse(path.read_text(), str(path))
    return {
        v.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Assign)
        and any(isinstance(t, ast.Name) and t.id == "_EXPORTS" for t in node.targets)
        and isinstance(node.value, ast.Dict)
        for v in node.value.values
        if isinstance(v, ast.Constant) and isinstance(v.value, str)
    }


def cycles(graph: dict[str, dict[str, list[str]]] | dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one node, each sorted (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(graph) + 100))

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
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
    return sorted(found)
