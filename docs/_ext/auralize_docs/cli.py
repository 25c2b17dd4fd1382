"""``.. auralize-cli::`` — every command's ``--help``, rendered from the parser.

The reference is built from :func:`auralize.cli.build_parser` at documentation
build time, so it lists exactly the commands, options and defaults the installed
``auralize`` has (the plugins' sub-commands included).  Each command and
sub-command gets a section titled ``auralize COMMAND [SUB]`` with the one-line
summary of the command list and its full help text; every section has a label
``cli-COMMAND[-SUB]`` for ``:ref:`` links.

Options: ``:width:`` (the help text's width in characters, default 80).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterator
from typing import Any, ClassVar

from docutils import nodes
from docutils.parsers.rst import directives
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles

#: section underlines by depth: the command list and the commands, sub-commands, ...
_UNDERLINE = ("=", "-", "~", "^")


def _subcommands(parser: argparse.ArgumentParser) -> Iterator[tuple[str, str, Any]]:
    """(name, one-line help, parser) of each sub-command, in the order they were added."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help or "" for a in action._choices_actions}
            seen: set[int] = set()
            for name, sub in action.choices.items():
                if id(sub) in seen:  # an alias of a command already listed
                    continue
                seen.add(id(sub))
                yield name, helps.get(name, ""), sub


def _walk(
    parser: argparse.ArgumentParser, words: tuple[str, ...] = ()
) -> Iterator[tuple[tuple[str, ...], str, argparse.ArgumentParser]]:
    for name, summary, sub in _subcommands(parser):
        yield (*words, name), summary, sub
        yield from _walk(sub, (*words, name))


def _literal(text: str) -> list[str]:
    return (
        [".. code-block:: text", ""]
        + [f"    {line}" if line else "" for line in text.rstrip().splitlines()]
        + [""]
    )


def reference_rst(parser: argparse.ArgumentParser) -> list[str]:
    """The reST of the whole reference: the top-level help, then one section per command."""
    lines = [".. _cli-auralize:", "", "auralize", _UNDERLINE[0] * 8, ""]  # the command list
    lines += _literal(parser.format_help())
    for words, summary, sub in _walk(parser):
        title = "auralize " + " ".join(words)
        label = "cli-" + "-".join(words)
        under = _UNDERLINE[min(len(words) - 1, len(_UNDERLINE) - 1)]
        lines += [f".. _{label}:", "", title, under * len(title), ""]
        if summary:
            text = summary[0].upper() + summary[1:]
            lines += [
                text.replace("*", r"\*").replace("`", r"\`") + ("" if text.endswith(".") else "."),
                "",
            ]
        lines += _literal(sub.format_help())
    return lines


class CLIDirective(SphinxDirective):
    has_content = False
    option_spec: ClassVar[dict[str, Any]] = {"width": directives.positive_int}

    def run(self) -> list[nodes.Node]:
        width = self.options.get("width", 80)
        old = os.environ.get("COLUMNS")
        os.environ["COLUMNS"] = str(width)  # argparse wraps help to the terminal's width
        try:
            from auralize.cli import build_parser

            rst = reference_rst(build_parser())
        finally:
            if old is None:
                os.environ.pop("COLUMNS", None)
            else:
                os.environ["COLUMNS"] = old
        node = nodes.section()
        node.document = self.state.document
        nested_parse_with_titles(self.state, StringList(rst, source="auralize --help"), node)
        return node.children


def setup(app: Any) -> None:
    app.add_directive("auralize-cli", CLIDirective)
