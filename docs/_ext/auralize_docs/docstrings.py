"""Docstrings as the code writes them, read as reST.

auralize's docstrings write absolute values and norms the way the papers do,
``|S|``, ``|x − y(τ)|``, ``|det ∂x/∂ξ|``; reST reads ``|...|`` as a
substitution reference and fails on it.  :func:`escape_bars` escapes those bars
before numpydoc and autodoc parse a docstring, so they print as written.  Bars
are left alone where reST gives them no meaning or another one: inside
``inline literals``, literal blocks (after ``::``), doctest blocks, and lines
that are a line block's (``| text``) or a grid table's (``| a | b |``, ``+---+``).

:data:`AS_LITERAL` names docstrings whose reST is broken in a way escaping cannot
repair; they are shown as preformatted text, as written, until fixed in the code.
"""

from __future__ import annotations

import re
from typing import Any

#: objects whose docstring is shown verbatim (a literal block); each one to be fixed
#: in its docstring, then removed from here
AS_LITERAL = {
    # a simple table whose second column starts one character early in one row
    "auralize.io.vtk_readers",
}

_LITERAL_SPAN = re.compile(r"``.*?``")


def _escape_line(line: str) -> str:
    out, last = [], 0
    for m in _LITERAL_SPAN.finditer(line):
        out.append(line[last : m.start()].replace("|", r"\|"))
        out.append(m.group(0))
        last = m.end()
    out.append(line[last:].replace("|", r"\|"))
    return "".join(out)


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def escape_bars(lines: list[str]) -> list[str]:
    """``lines`` with the bars of absolute values escaped (see the module's docstring)."""
    out: list[str] = []
    literal_from: int | None = None  # the indent of the paragraph that opened a literal block
    doctest = False
    for i, line in enumerate(lines):
        stripped = line.strip()
        if literal_from is not None:
            if stripped and _indent(line) <= literal_from:
                literal_from = None
            else:
                out.append(line)
                continue
        if doctest:
            if not stripped:
                doctest = False
            out.append(line)
            continue
        if stripped.startswith(">>>"):
            doctest = True
            out.append(line)
            continue
        table = (
            stripped.startswith("+-")
            or stripped.startswith("+=")
            or (
                stripped.startswith("|")
                and stripped.endswith("|")
                and len(stripped) > 1
                and stripped[1] == " "
            )
        )
        if "|" not in line or stripped.startswith("| ") or stripped == "|" or table:
            out.append(line)
        else:
            out.append(_escape_line(line))
        if stripped.endswith("::"):
            # the paragraph's indent: its first line's
            j = i
            while j > 0 and lines[j - 1].strip():
                j -= 1
            literal_from = _indent(lines[j])
    return out


def process_docstring(  # noqa: PLR0917 (the signature of Sphinx's autodoc-process-docstring event)
    app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]
) -> None:
    """``autodoc-process-docstring``: verbatim docstrings, then the bars escaped."""
    if name in AS_LITERAL:
        lines[:] = ["::", ""] + [f"    {line}" if line.strip() else "" for line in lines] + [""]
        return
    lines[:] = escape_bars(lines)


def setup(app: Any) -> None:
    # before numpydoc (priority 500) parses the sections
    app.connect("autodoc-process-docstring", process_docstring, priority=100)
