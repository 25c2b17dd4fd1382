"""``auralize regress record|check``: regression tests of a user's own data.

``record`` runs the pipeline on a dataset (reading, detection, a render along
a listener path) and stores the figures that came out, with the settings and
the path, in a JSON file (and a picture beside it); ``check`` runs it again
with the stored settings and names every figure that moved beyond its
tolerance (exit status 6), optionally writing a report with plots
(:mod:`auralize.regression.user`).
"""

from __future__ import annotations

import argparse
import json
from typing import Any

#: the tolerance names (``--tolerance NAME=VALUE``) and their meaning, for the help
TOLERANCE_HELP = (
    "counts (relative, default 0.05), counts_at_least (points, 2), onset "
    "(steps, 0: onsets and ends), level (dB, 1), centroid (relative, 0.05), "
    "bands (dB, 3), image (RMS of 0..255 pixel levels, 2)"
)


def tolerance_arg(text: str) -> tuple[str, float]:
    """argparse type of ``--tolerance NAME=VALUE``."""
    name, eq, value = text.partition("=")
    try:
        v = float(value)
    except ValueError:
        v = float("nan")
    if not eq or not name.strip() or not v >= 0:
        raise argparse.ArgumentTypeError(
            f"expected NAME=VALUE with VALUE >= 0 (names: {TOLERANCE_HELP}), got {text!r}"
        )
    return name.strip(), v


def _tolerances(args: argparse.Namespace) -> dict[str, float]:
    from auralize.regression.user import tolerances_from

    given = dict(args.tolerance or [])
    tolerances_from(**given)  # names and values checked before any slow work
    return given


def cmd_record(args: argparse.Namespace) -> int:
    from auralize.cli.core import heard_arg, mapping_fields
    from auralize.cli.options import field_map
    from auralize.listener import ListenerPath
    from auralize.regression.user import record

    tol = _tolerances(args)
    read = {
        "size": args.size,
        "steps": args.steps,
        "seed": args.seed,
        "fields": field_map(args.field),
        "resolution": args.resolution,
        "nan": args.nan,
        "time_dim": args.time_dim,
        "axis_scale": list(args.axis_scale) if args.axis_scale else None,
        "box": list(args.box) if args.box else None,
        "resample": args.resample or None,
    }
    path = ListenerPath.from_csv(args.path) if args.path else None
    doc = record(
        args.volume,
        args.output,
        path=path,
        tolerances=tol,
        read={k: v for k, v in read.items() if v not in (None, {}, [])},
        mapping=args.mapping,
        mapping_fields=mapping_fields(args),
        thresholds=[args.threshold_monopole, args.threshold_dipole, args.threshold_quadrupole],
        zero_fraction=args.zero_fraction,
        floor=args.floor,
        listener=None if args.listener is None else [float(v) for v in args.listener],
        duration=args.duration,
        time_scale=args.time_scale,
        layout=args.layout,
        rate=args.rate,
        heard=heard_arg(args),
        timbre=args.timbre,
        highpass_hz=args.highpass,
        interp=args.interp,
        method=args.method,
        orbit_face=args.orbit_face,
        windows=args.windows,
        screenshot=not args.no_screenshot,
        screenshot_size=list(args.screenshot_size),
    )
    f = doc["figures"]
    levels = [v for v in f["level_db"] if v is not None]
    loud = f"{max(levels):.1f} dB" if levels else "silence"
    image = f" and {doc['image']}" if doc["image"] else ""
    print(
        f"wrote {args.output}{image}: {f['steps']} steps, {len(f['level_db'])} windows over "
        f"{f['duration_s']:.3g} s, loudest window {loud}, {f['rms_pa']:.4g} Pa RMS"
    )
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    from auralize.cli.core import EXIT_REGRESSION
    from auralize.regression.user import check

    result = check(args.volume, args.expect, tolerances=_tolerances(args), report=args.report)
    if args.json:
        print(
            json.dumps(
                {
                    "passed": result.passed,
                    "data": result.data,
                    "expect": str(result.expect_file),
                    "tolerances": result.tolerances,
                    "moved": [m.as_dict() for m in result.moved],
                    "report": args.report,
                },
                indent=1,
                default=str,
            )
        )
    else:
        print(result.summary())
        if args.report:
            print(f"report: {args.report}/report.md (and report.html)")
    if not result.passed:
        return EXIT_REGRESSION
    return 0


def _size(text: str) -> tuple[int, int]:
    w, _, h = text.lower().partition("x")
    try:
        size = (int(w), int(h))
    except ValueError:
        size = (0, 0)
    if min(size) < 16 or max(size) > 4096:
        raise argparse.ArgumentTypeError(
            f"expected WIDTHxHEIGHT in pixels (16..4096), got {text!r}"
        )
    return size


def add_commands(sub: Any) -> None:
    from auralize.cli.core import (
        HIGHPASS_HELP,
        TIMBRE_HELP,
        add_detect_options,
        add_heard_options,
        time_scale_arg,
    )
    from auralize.cli.options import (
        add_volume_options,
        positive_float,
        positive_int,
        rate_int,
        vec3,
    )
    from auralize.defaults import DEFAULTS, TIMBRE_CHOICES

    p = sub.add_parser(
        "regress",
        help="regression tests of your data: record what it detects and sounds like, check it",
        description="Regression tests of your own data. 'record' runs the pipeline on DATA "
        "(detection, a render along a listener path) and stores the figures in EXPECT.json "
        "with the settings and the path used, and a picture in EXPECT.png beside it; 'check' "
        "runs DATA again with the stored settings and names every figure that moved beyond "
        "its tolerance. Figures: source points per step and type, each type's onset and end "
        "step; along the path, in windows of playback time, the level, the spectral centroid "
        "and the 1/3-octave band levels; the picture's RMS pixel difference. Exit status of "
        "check: 0 every figure within tolerance, 6 a figure moved, 2 usage, 3 data, 4 "
        "system errors.",
    )
    rsub = p.add_subparsers(dest="regress_command", required=True, metavar="record|check")
    q = rsub.add_parser(
        "record", help="run DATA and store its figures in EXPECT.json (and EXPECT.png)"
    )
    add_volume_options(q)
    add_detect_options(q)
    g = q.add_argument_group("the render (as auralize render's options)")
    g.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="EXPECT.json",
        help="the expectation file to write (the picture goes beside it, .png)",
    )
    src = g.add_mutually_exclusive_group()
    src.add_argument("--path", metavar="CSV", help="listener path CSV (stored in the JSON)")
    src.add_argument("--listener", type=vec3, metavar="X,Y,Z", help="static listener position")
    g.add_argument(
        "--duration",
        type=positive_float,
        help="playback seconds (default: the path's length, else 10)",
    )
    g.add_argument(
        "--layout", default=DEFAULTS.layout, help=f"output layout (default {DEFAULTS.layout})"
    )
    g.add_argument(
        "--rate",
        type=rate_int,
        default=DEFAULTS.rate,
        help=f"sample rate, Hz (default {DEFAULTS.rate})",
    )
    g.add_argument(
        "--time-scale",
        type=time_scale_arg,
        default=DEFAULTS.time_scale,
        help="playback seconds per data second, or auto (default)",
    )
    g.add_argument("--interp", choices=["linear", "cubic"], default=DEFAULTS.interp)
    g.add_argument("--timbre", choices=TIMBRE_CHOICES, default=DEFAULTS.timbre, help=TIMBRE_HELP)
    g.add_argument(
        "--highpass", type=float, default=DEFAULTS.highpass_hz, metavar="HZ", help=HIGHPASS_HELP
    )
    g.add_argument(
        "--method",
        choices=("auto", "volume", "fwh"),
        default=DEFAULTS.method,
        help="how the volume is heard (as auralize render --method)",
    )
    add_heard_options(g)
    g = q.add_argument_group("the figures")
    g.add_argument(
        "--windows",
        type=positive_int,
        default=8,
        help="windows of playback time along the path (default 8)",
    )
    g.add_argument("--no-screenshot", action="store_true", help="no picture")
    g.add_argument(
        "--screenshot-size",
        type=_size,
        default=(480, 360),
        metavar="WxH",
        help="the picture's size in pixels (default 480x360)",
    )
    g.add_argument(
        "--tolerance",
        type=tolerance_arg,
        action="append",
        metavar="NAME=VALUE",
        help=f"a tolerance stored with the figures (repeatable): {TOLERANCE_HELP}",
    )
    q.set_defaults(func=cmd_record)

    q = rsub.add_parser(
        "check",
        help="run DATA again with EXPECT.json's settings; exit 6 if a figure moved",
        description="Run DATA again with the settings and listener path stored in "
        "EXPECT.json and compare its figures with the stored ones. Prints every figure that "
        "moved beyond its tolerance and by how much. Exit status: 0 every figure within "
        "tolerance; 6 a figure moved; 2 a bad option; 3 the data or the expectation cannot "
        "be read; 4 the report cannot be written.",
    )
    q.add_argument("volume", metavar="DATA", help="the data (a file, or dataset:NAME)")
    q.add_argument("expect", metavar="EXPECT.json", help="the expectation 'record' wrote")
    q.add_argument(
        "--tolerance",
        type=tolerance_arg,
        action="append",
        metavar="NAME=VALUE",
        help=f"override a stored tolerance (repeatable): {TOLERANCE_HELP}",
    )
    q.add_argument(
        "--report",
        metavar="DIR",
        help="write a report into DIR (made if missing; its parent must exist): "
        "report.md, report.html, plots and the pictures compared",
    )
    q.add_argument("--json", action="store_true", help="print the result as JSON")
    q.add_argument(
        "--allow-external",
        action="store_true",
        help="let HDF5 files read data from other files (refused by default)",
    )
    q.set_defaults(func=cmd_check)
