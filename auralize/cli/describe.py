"""``auralize describe``: the detected sources and what the listener hears, in words.

Text a screen reader can read (or CSV / JSON rows): per step or range of
steps, the source types, where they are in the data's box and from the
listener, how loud (dB relative to the loudest), their onsets and ends, and
when the listener hears them in playback time — the clock of ``auralize
render`` with the same options (:mod:`auralize.describe`).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any


def cmd_describe(args: argparse.Namespace) -> int:
    from auralize.cli.core import (
        heard_arg,
        load_volume,
        mapping_fields,
        progress_wanted,
        thresholds_from_args,
    )
    from auralize.describe import describe
    from auralize.listener import ListenerPath

    vol = load_volume(args)
    series = None
    if args.sources:
        from auralize.sources.sources_file import load_sources_for

        series = load_sources_for(args.sources, vol)
    path = ListenerPath.from_csv(args.path) if args.path else None
    d = describe(
        vol,
        series=series,
        path=path,
        listener=args.listener,
        duration=args.duration,
        time_scale=args.time_scale,
        heard=heard_arg(args),
        orbit_face=args.orbit_face,
        mapping=args.mapping,
        thresholds=thresholds_from_args(args),
        interp=args.interp,
        progress_bar=progress_wanted(),
        name=args.volume,
        **mapping_fields(args),
    )
    if args.output:
        d.save(args.output, args.format)
        print(
            f"wrote {args.output}: {len(d.events)} event(s), {len(d.rows)} step rows "
            f"({args.format or 'from the suffix'})",
            file=sys.stderr,
        )
        return 0
    sys.stdout.write(d.render_as(args.format or "text"))
    return 0


def add_commands(sub: Any) -> None:
    from auralize.cli.core import add_detect_options, add_heard_options, time_scale_arg
    from auralize.cli.options import add_volume_options, positive_float, vec3
    from auralize.defaults import DEFAULTS

    p = sub.add_parser(
        "describe",
        help="the sources and what the listener hears, in words (text, CSV or JSON)",
        description="Describe the detected sources of a volume in words a screen reader can "
        "read: per step or range of steps the source types, where they are (in thirds of the "
        "data's box: left/right along x, front/back along y, lower/upper along z; and the "
        "distance and direction from the listener), how loud (dB relative to the loudest, at "
        "the listener), their onsets and ends, and when the listener hears them in playback "
        "time: the time scale, listener and travel time of 'auralize render' with the same "
        "options.",
    )
    add_volume_options(p)
    add_detect_options(p)
    g = p.add_argument_group("the render described (as auralize render's options)")
    src = g.add_mutually_exclusive_group()
    src.add_argument("--path", metavar="CSV", help="listener path CSV (t,x,y,z[,fx,...])")
    src.add_argument("--listener", type=vec3, metavar="X,Y,Z", help="static listener position")
    g.add_argument(
        "--duration",
        type=positive_float,
        help="playback seconds (default: the path's length, else 10)",
    )
    g.add_argument(
        "--time-scale",
        type=time_scale_arg,
        default=DEFAULTS.time_scale,
        help="playback seconds per data second, or auto (default)",
    )
    g.add_argument(
        "--interp",
        choices=["linear", "cubic"],
        default=DEFAULTS.interp,
        help="strength interpolation of the renders that give the levels",
    )
    g.add_argument(
        "--sources",
        metavar="SOURCES.h5",
        help="describe these sources (from 'auralize detect') instead of detecting",
    )
    add_heard_options(g)
    g = p.add_argument_group("output")
    g.add_argument(
        "--format",
        choices=["text", "csv", "json"],
        help="text (default; one sentence per line), csv (one row per step and "
        "type) or json (everything)",
    )
    g.add_argument(
        "-o",
        "--output",
        metavar="FILE",
        help="write to FILE (atomically) instead of the terminal; the format from "
        "--format or the suffix (.csv, .json, else text)",
    )
    p.set_defaults(func=cmd_describe)
