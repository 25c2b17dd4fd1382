"""One output path: every audio-writing sub-command (core and plugins) declares the
shared output options of :mod:`auralize.cli.options` with the same dest, type and
default, so ``-o``, ``--layout``, ``--rate``, ``--normalize``, ``--format``,
``--limit``, ``--listener``/``--path`` and ``--duration`` mean the same everywhere.

Commands that write a source's emitted signal (``fire lowfreq/extend/texture``)
declare it on their parser and share the :data:`EMITTED_OPTIONS` subset: they have
no listener and no layout, and the test checks that they have none."""

from __future__ import annotations

import argparse
from collections.abc import Iterator

import numpy as np
import pytest

from auralize.cli import build_parser
from auralize.cli.options import (
    EMITTED_OPTIONS,
    EMITTED_SIGNAL,
    LIVE_OPTIONS,
    OUTPUT_OPTIONS,
    add_output_options,
    fit_duration,
    rate_int,
)

#: commands that play live (no file): they share the LIVE_OPTIONS subset
LIVE_COMMANDS = {"play"}
#: the emitted-signal commands there are today (a new one must be declared, see below)
EMITTED_COMMANDS = {"fire lowfreq", "fire extend", "fire texture"}


def _walk(
    p: argparse.ArgumentParser, name: tuple[str, ...] = ()
) -> Iterator[tuple[str, argparse.ArgumentParser]]:
    for a in p._actions:
        if isinstance(a, argparse._SubParsersAction):
            for n, sp in dict(a.choices).items():
                yield from _walk(sp, (*name, n))
            return
    yield " ".join(name), p


COMMANDS = dict(_walk(build_parser()))


def _writes_audio(p: argparse.ArgumentParser) -> bool:
    out = next((a for a in p._actions if a.dest == "output"), None)
    return out is not None and ".wav" in (out.help or "")


def _emitted(cmd: str) -> bool:
    return COMMANDS[cmd].get_default(EMITTED_SIGNAL) is True


def _shared(cmd: str) -> tuple[str, ...]:
    if cmd in LIVE_COMMANDS:
        return LIVE_OPTIONS
    return EMITTED_OPTIONS if _emitted(cmd) else tuple(OUTPUT_OPTIONS)


AUDIO_COMMANDS = sorted(n for n, p in COMMANDS.items() if _writes_audio(p)) + sorted(LIVE_COMMANDS)
CASES = [(cmd, dest) for cmd in AUDIO_COMMANDS for dest in _shared(cmd)]


def test_the_walk_finds_core_and_plugin_audio_commands() -> None:
    assert {"render", "scale-render", "play"} <= set(AUDIO_COMMANDS)
    plugin = {c for c in AUDIO_COMMANDS if c.split()[0] in ("vortex", "aero", "spark", "fire")}
    assert {"vortex render", "aero render", "spark render", "fire render"} <= plugin
    assert "convert" not in AUDIO_COMMANDS and "detect" not in AUDIO_COMMANDS


def test_emitted_signal_commands_are_declared_and_have_no_listener() -> None:
    assert {c for c in AUDIO_COMMANDS if _emitted(c)} == EMITTED_COMMANDS
    for cmd in EMITTED_COMMANDS:
        p = COMMANDS[cmd]
        dests = {a.dest for a in p._actions}
        assert not dests & {"layout", "path", "listener"}, cmd
        # the help says what is written and why there is no listener
        text = p.format_help()
        assert "emitted signal" in text and "1 m" in text and "no --layout" in text, cmd


def test_fit_duration_cuts_or_pads_with_silence() -> None:
    x = np.arange(1.0, 11.0)
    assert fit_duration(x, 10, None) is x
    assert fit_duration(x, 10, 0.5).tolist() == [1, 2, 3, 4, 5]
    y = fit_duration(x[None], 10, 1.5)
    assert y.shape == (1, 15) and y[0, :10].tolist() == x.tolist() and not y[0, 10:].any()


@pytest.mark.parametrize(("cmd", "dest"), CASES)
def test_shared_output_option(cmd: str, dest: str) -> None:
    acts = {a.dest: a for a in COMMANDS[cmd]._actions}
    assert dest in acts, f"auralize {cmd} has no {OUTPUT_OPTIONS[dest][0][-1]}"
    a = acts[dest]
    flags, kind, default = OUTPUT_OPTIONS[dest]
    assert set(flags) <= set(a.option_strings)
    assert a.type is kind, f"auralize {cmd} {flags[-1]}: type {a.type} instead of {kind}"
    if dest == "layout":  # play defaults to ring8; every default is a layout name
        from auralize.spatial import get_layout

        get_layout(a.default)
    else:
        assert a.default == default, f"auralize {cmd} {flags[-1]}: default {a.default!r}"
    if dest == "normalize":
        assert list(a.choices) == ["peak", "none"]
    if dest == "format":
        assert list(a.choices) == ["float32", "pcm16", "pcm24"]
    if dest == "output":
        assert a.required


def test_listener_options_exclude_each_other_and_rate_is_the_output_rate(capsys) -> None:  # type: ignore[no-untyped-def]
    p = argparse.ArgumentParser()
    add_output_options(p)
    with pytest.raises(SystemExit) as e:
        p.parse_args(["-o", "x.wav", "--path", "p.csv", "--listener", "0,0,0"])
    assert e.value.code == 2
    assert "argument --listener: not allowed with argument --path" in capsys.readouterr().err
    args = p.parse_args(["-o", "x.wav", "--listener", "1,2,3", "--rate", "22050"])
    assert args.rate == 22050 and args.listener.tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(argparse.ArgumentTypeError, match="outside 8000..768000"):
        rate_int("100")


def test_old_import_path_still_works() -> None:
    import auralize.cli as cli
    import auralize.cli.options as opts

    for name in (
        "add_output_options",
        "listener_from_args",
        "rate_int",
        "positive_float",
        "finite_float",
        "positive_int",
        "seed_int",
        "RATE_RANGE_HZ",
        "add_volume_options",
    ):
        assert getattr(cli, name) is getattr(opts, name)
    assert cli.field_map is opts.field_map


@pytest.mark.parametrize(
    ("argv", "dest", "value"),
    [
        (["render", "x.h5", "-o", "o.wav", "--listener", "-3,0,1.5"], "listener", (-3, 0, 1.5)),
        (
            ["render", "x.h5", "-o", "o.wav", "--listener", "-.5,-2e1,-1"],
            "listener",
            (-0.5, -20, -1),
        ),
        (["path", "line", "-o", "p.csv", "--start", "-3,-1,0.3"], "start", (-3, -1, 0.3)),
        (["path", "orbit", "-o", "p.csv", "--center", "-1,-1,-1"], "center", (-1, -1, -1)),
    ],
)
def test_negative_coordinates_are_values_not_options(
    argv: list[str], dest: str, value: tuple[float, ...]
) -> None:
    # argparse alone reads "-3,0,1.5" as an unknown option ("expected one argument")
    ns = build_parser().parse_args(argv)
    np.testing.assert_array_equal(np.asarray(getattr(ns, dest), dtype=float), value)


def test_an_unknown_option_after_a_value_option_is_still_refused(capsys) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(SystemExit) as info:
        build_parser().parse_args(["render", "x.h5", "-o", "o.wav", "--listener", "-x"])
    assert info.value.code != 0
    assert "--listener: expected one argument" in capsys.readouterr().err
