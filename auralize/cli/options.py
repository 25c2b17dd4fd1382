"""The options every audio-writing command shares, importable without the whole CLI.

Plugins declare their sub-commands with these (their ``add_commands`` and
``add_cli`` hooks receive this module as their ``options`` argument, see
:meth:`auralize.plugins.SoundModel.add_cli`), so that ``-o``, ``--layout``, ``--rate``,
``--normalize``, ``--format``, ``--limit``, ``--listener``/``--path`` and
``--duration`` mean the same in ``auralize render``, ``auralize play`` and
every plugin command:

===============  ==================  ======================================================
option           dest, type          meaning
===============  ==================  ======================================================
``-o``           output, str         output .wav or .flac (written atomically, + sidecar)
``--layout``     layout, str         output layout: a name or a layout JSON file
``--rate``       rate, int           *output* sample rate in Hz (8000..768000, default 44100)
``--normalize``  normalize, str      ``peak`` (loudest sample at 0.99) or ``none`` (pascals)
``--format``     format, str         float32 | pcm16 | pcm24 (default float32 WAV, pcm24 FLAC)
``--limit``      limit, float        truncate pressures beyond this many pascals
``--path``       path, str           listener path CSV
``--listener``   listener, (3,)      static listener position x,y,z (m)
``--duration``   duration, float     playback seconds rendered (default: the path's length)
===============  ==================  ======================================================

:data:`OUTPUT_OPTIONS` holds the same table for tests and tools.  Live commands
share :data:`LIVE_OPTIONS`.  Commands that write a source's *emitted* signal
(mono, as at 1 m; ``fire lowfreq/extend/texture``) are declared with
``add_output_options(p, emitted=True)`` and share :data:`EMITTED_OPTIONS`: no
listener and no layout, ``--rate`` still the output rate, ``--duration`` the
seconds written (:func:`fit_duration`).  A command-specific setting that once
used a shared name keeps it as a hidden deprecated alias
(:func:`add_renamed_alias`).
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

import numpy as np

# re-exported: the helpers every command uses, also handed to plugins' hooks
from auralize.audio.output import fit_duration as fit_duration
from auralize.cli.plugin_commands import lazy as lazy
from auralize.defaults import DEFAULTS, LAYOUT_NAMES
from auralize.emitters import RATE_RANGE_HZ as RATE_RANGE_HZ
from auralize.io import field_map as field_map
from auralize.listener import listener_from_args as listener_from_args
from auralize.listener import render_duration as render_duration

#: default output sample rate, Hz
DEFAULT_RATE = DEFAULTS.rate


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return v


def finite_float(text: str) -> float:
    """argparse type: a finite number."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return v


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return v


def seed_int(text: str) -> int:
    """argparse type: a random seed, 0 to 2**32 - 1."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a seed 0..4294967295, got {text!r}") from None
    if not 0 <= v < 2**32:
        raise argparse.ArgumentTypeError(f"expected a seed 0..4294967295, got {text!r}")
    return v


def rate_int(text: str) -> int:
    """argparse type: an audio sample rate in :data:`RATE_RANGE_HZ`."""
    lo, hi = RATE_RANGE_HZ
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a sample rate in Hz ({lo}..{hi}), got {text!r}"
        ) from None
    if not lo <= v <= hi:
        raise argparse.ArgumentTypeError(f"sample rate {text!r} Hz is outside {lo}..{hi} Hz")
    return v


def _numbers(text: str, counts: tuple[int, ...], what: str) -> list[float]:
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    if len(v) not in counts or not all(np.isfinite(v)):
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
    return v


def axis_scale_arg(text: str) -> tuple[float, float, float]:
    """argparse type: metres per file unit, ``S`` or ``SX,SY,SZ`` (all positive)."""
    v = _numbers(text, (1, 3), "one or three positive numbers (metres per file unit)")
    if min(v) <= 0:
        raise argparse.ArgumentTypeError(f"axis scales must be positive, got {text!r}")
    return (v[0], v[0], v[0]) if len(v) == 1 else (v[0], v[1], v[2])


def box_arg(text: str) -> tuple[float, ...]:
    """argparse type: ``XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX`` in metres, min <= max."""
    v = _numbers(text, (6,), "six numbers XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX")
    bad = [a for i, a in enumerate("xyz") if v[2 * i] > v[2 * i + 1]]
    if bad:
        raise argparse.ArgumentTypeError(
            f"box minimum above maximum along {', '.join(bad)}: {text!r}"
        )
    return tuple(v)


def vec3(text: str) -> np.ndarray:
    """argparse type: three finite numbers ``x,y,z`` -> (3,) float."""
    try:
        v = np.array([float(x) for x in text.split(",")])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected x,y,z numbers, got {text!r}") from None
    if v.size != 3 or not np.all(np.isfinite(v)):
        raise argparse.ArgumentTypeError(f"expected three finite numbers x,y,z, got {text!r}")
    return v


def add_reader_options(g: Any) -> None:
    """``--time-dim``, ``--axis-scale`` and ``--box``: the options every reader takes."""
    g.add_argument(
        "--time-dim",
        metavar="NAME",
        help="name of a netCDF file's time dimension, when it is not found by CF's "
        "axis='T', 'units: ... since ...' or a common name (time, month, ...)",
    )
    g.add_argument(
        "--axis-scale",
        type=axis_scale_arg,
        metavar="S|SX,SY,SZ",
        help="metres per file unit along x, y, z (e.g. 1000 for a grid in km); "
        "overrides a netCDF file's own conversion of degrees and pressure levels",
    )
    g.add_argument(
        "--box",
        type=box_arg,
        metavar="XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX",
        help="region of interest in metres: keep the grid inside it (of a "
        "curvilinear grid, the smallest index block whose cells cover it); a "
        "mesh's resolution is chosen from its cells inside it",
    )
    g.add_argument(
        "--resample",
        action="store_true",
        help="read a structured curvilinear grid (PLOT3D, .vts) resampled onto a "
        "uniform grid instead of on its own points (the default: derivatives "
        "by its metric terms); --resolution resamples it too",
    )


def add_volume_options(p: argparse.ArgumentParser, *, optional: bool = False) -> None:
    """The volume positional and the options that read it (``optional``: may be left out)."""
    p.add_argument(
        "volume",
        metavar="PATH",
        nargs="?" if optional else None,
        help="volume file, or dataset:NAME for a built-in one"
        + (" (optional with --model/--scene)" if optional else ""),
    )
    g = p.add_argument_group("volume")
    g.add_argument(
        "--field",
        action="append",
        metavar="NAME=/DATASET",
        help="read a generic HDF5 file by naming datasets (repeatable)",
    )
    g.add_argument(
        "--resolution", type=positive_int, help="points per axis when resampling non-uniform grids"
    )
    add_reader_options(g)
    g.add_argument("--size", type=positive_int, help="grid size of a built-in dataset")
    g.add_argument("--steps", type=positive_int, help="time steps of a built-in dataset")
    g.add_argument("--seed", type=seed_int, default=0, help="seed of a built-in dataset")
    g.add_argument(
        "--allow-external",
        action="store_true",
        help="let HDF5 files read data from other files (external storage and "
        "links; refused by default)",
    )
    g.add_argument(
        "--nan",
        choices=["mask", "error"],
        default="mask",
        help="NaN, fill values and masked cells: mask = no-data (default), error = refuse",
    )


#: dest -> (option strings, argparse type, default) of the shared output options;
#: ``"layout"``'s default may differ per command (``play`` defaults to ring8)
OUTPUT_OPTIONS: dict[str, tuple[tuple[str, ...], Any, Any]] = {
    "output": (("-o", "--output"), None, None),
    "layout": (("--layout",), None, "mono"),
    "rate": (("--rate",), rate_int, DEFAULT_RATE),
    "normalize": (("--normalize",), None, "peak"),
    "format": (("--format",), None, None),
    "limit": (("--limit",), positive_float, None),
    "path": (("--path",), None, None),
    "listener": (("--listener",), vec3, None),
    "duration": (("--duration",), positive_float, None),
}
#: the subset that live commands (no file) share
LIVE_OPTIONS = ("layout", "rate", "limit", "path", "listener", "duration")
#: the subset that emitted-signal commands share: they write a source's own signal
#: (mono, at 1 m), so they have no listener and no layout
EMITTED_OPTIONS = ("output", "rate", "normalize", "format", "limit", "duration")
#: the argparse default (``p.get_default(EMITTED_SIGNAL)``) that declares a command
#: an emitted-signal command; set by ``add_output_options(..., emitted=True)``
EMITTED_SIGNAL = "emitted_signal"


def add_output_options(
    p: argparse.ArgumentParser,
    *,
    layouts: str = "|".join([*LAYOUT_NAMES, "FILE.json"]),
    listener_required: bool = True,
    file: bool = True,
    layout: str = "mono",
    title: str = "audio output",
    emitted: bool = False,
) -> argparse._ArgumentGroup:
    """Add the shared output options (see the module docstring) to ``p``.

    Parameters
    ----------
    p : argparse.ArgumentParser
    layouts : str
        Help text of ``--layout`` (the layouts the command offers).
    listener_required : bool
        One of ``--path``/``--listener`` must be given (else the command
        chooses a listener itself).
    file : bool
        The command writes a file (``-o``, ``--normalize``, ``--format``);
        False for live commands.
    layout : str
        Default of ``--layout``.
    title : str
        Title of the help section.
    emitted : bool
        The command writes a source's emitted signal (mono, at 1 m), not a
        listener's: only :data:`EMITTED_OPTIONS` are added (no ``--layout``,
        ``--path``, ``--listener``), ``--duration`` cuts or pads that signal
        (:func:`fit_duration`) and the parser is declared with
        ``p.set_defaults(emitted_signal=True)``.

    Returns
    -------
    argparse._ArgumentGroup
        The group, for command-specific additions.
    """
    g = p.add_argument_group(title)
    if emitted:
        file = True
        p.set_defaults(**{EMITTED_SIGNAL: True})
    if file:
        g.add_argument(
            "-o",
            "--output",
            required=True,
            help="output .wav or .flac" + (" (mono, the signal at 1 m)" if emitted else ""),
        )
    if not emitted:
        g.add_argument("--layout", default=layout, help=f"{layouts} (default {layout})")
        g.add_argument(
            "--hrtf",
            metavar="FILE.sofa",
            help="HRIRs for --layout binaural (AES69 SOFA, decoded from AmbiX order 3); "
            "default: a spherical head whose ears are receivers of their own",
        )
    g.add_argument(
        "--rate",
        type=rate_int,
        default=DEFAULT_RATE,
        help=f"output sample rate in Hz (default {DEFAULT_RATE})"
        + ("; an input at another rate is resampled to it" if emitted else ""),
    )
    if file:
        g.add_argument(
            "--normalize",
            choices=["peak", "none"],
            default="peak",
            help="peak: loudest sample at 0.99; none: physical pascals in a float WAV, whose "
            "samples go beyond ±1 by design (scale them before playing)",
        )
        g.add_argument(
            "--format",
            choices=["float32", "pcm16", "pcm24"],
            help="sample format (default: float32 WAV, pcm24 FLAC); pcm needs --normalize peak",
        )
    g.add_argument(
        "--limit",
        type=positive_float,
        metavar="PA",
        help="truncate pressures beyond this many pascals (paper 000 §7)",
    )
    if emitted:
        g.add_argument(
            "--duration",
            type=positive_float,
            help="seconds written (default: the whole signal; a longer signal is cut, "
            "a shorter one padded with silence)",
        )
        return g
    src = g.add_mutually_exclusive_group(required=listener_required)
    src.add_argument(
        "--path", metavar="CSV", help="listener path CSV (t,x,y,z[,fx,fy,fz,ux,uy,uz])"
    )
    src.add_argument("--listener", type=vec3, metavar="X,Y,Z", help="static listener position")
    g.add_argument(
        "--duration",
        type=positive_float,
        help="playback seconds to render (default: the listener path's length"
        + (
            "; needed with --listener)"
            if listener_required
            else ", else 10; a --model/--scene scene at a static listener: until every "
            "part has been heard)"
        ),
    )
    return g


class _RenamedOption(argparse.Action):
    """The hidden old spelling of a renamed option: stores into the new dest, with a note."""

    def __init__(self, option_strings: list[str], dest: str, *, new: str, **kw: Any) -> None:
        self.new = new
        super().__init__(option_strings, dest, **kw)

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        print(
            f"note: {parser.prog} {option_string} is deprecated; it is now {self.new}",
            file=sys.stderr,
        )
        setattr(namespace, self.dest, values)


def add_renamed_alias(p: argparse.ArgumentParser, old: str, new: argparse.Action) -> None:
    """Accept ``old`` as a hidden, deprecated spelling of the option ``new``.

    For command-specific settings that once used a shared option's name (a
    texture's ``--duration``), so that old command lines keep working.

    Parameters
    ----------
    p : the parser ``new`` was added to.
    old : the old option string, e.g. ``"--duration"``.
    new : the action :meth:`argparse.ArgumentParser.add_argument` returned.
    """
    kind: dict[str, Any] = {} if new.type is None else {"type": new.type}
    p.add_argument(
        old,
        dest=new.dest,
        action=_RenamedOption,
        new=new.option_strings[-1],
        default=argparse.SUPPRESS,
        help=argparse.SUPPRESS,
        **kind,
    )
