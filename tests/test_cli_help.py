"""Every sub-command's ``--help`` (core and plugins) prints and exits 0."""

from __future__ import annotations

import argparse
import contextlib
import io

import pytest

from auralize.cli import build_parser, main


def _commands(parser: argparse.ArgumentParser, prefix: list[str]) -> list[list[str]]:
    out: list[list[str]] = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                out.append([*prefix, name])
                out.extend(_commands(sub, [*prefix, name]))
    return out


COMMANDS = _commands(build_parser(), [])


def test_the_walk_finds_core_and_plugin_commands() -> None:
    names = {" ".join(c) for c in COMMANDS}
    assert {"render", "detect", "view", "script", "play", "path orbit"} <= names
    assert {"vortex render", "fire render", "spark render", "aero render"} <= names


@pytest.mark.parametrize("command", COMMANDS, ids=[" ".join(c) for c in COMMANDS])
def test_help_exits_zero(command: list[str]) -> None:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as exc:
        main([*command, "--help"])
    assert exc.value.code == 0
    text = out.getvalue()
    assert text.startswith("usage: ") and command[-1] in text.splitlines()[0]
