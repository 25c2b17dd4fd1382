"""``auralize spectrum``: OASPL, dBA and ⅓-octave band levels, as CSV/JSON and a plot.

From an audio file auralize wrote (its sidecar gives the pascals), or from a
volume at an observer point: the pressure of the volume sum (the whole field,
physical time, no high-pass) or of the FW-H surface integral
(:mod:`auralize.fwh`), in pascals (:mod:`auralize.spectrum`).
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from auralize.errors import ParameterError

AUDIO_SUFFIXES = (".wav", ".flac")


def cmd_spectrum(args: argparse.Namespace) -> int:
    from pathlib import Path

    from auralize.spectrum import read_pascals, spectrum

    src = str(args.volume)
    if Path(src).suffix.lower() in AUDIO_SUFFIXES:
        if args.listener is not None:
            raise ParameterError(
                "--listener is for a volume; an audio file already holds the pressure heard"
            )
        audio, rate, names, _ = read_pascals(src)
        what = Path(src).name
    else:
        if args.listener is None:
            raise ParameterError(
                "a volume's spectrum is taken at an observer: give "
                "--listener X,Y,Z (or analyse a rendered .wav/.flac)"
            )
        from auralize.cli.core import load_volume
        from auralize.spectrum import observer_pressure

        audio, method = observer_pressure(
            load_volume(args),
            args.listener,
            method=args.method,
            surface=args.surface,
            rate=args.rate,
        )
        rate, names = args.rate, ["observer"]
        what = f"{src} at ({', '.join(f'{v:g}' for v in args.listener)}) m, {method}"
    s = spectrum(audio, rate, channels=names, fmin=args.fmin, fmax=args.fmax, source=what)
    written = []
    if args.output:
        written.append(str(s.save(args.output)))
    if args.plot:
        written.append(str(s.plot(args.plot)))
    if args.json:
        print(json.dumps({**s.as_dict(), "written": written}, indent=2))
        return 0
    print(repr(s))
    loud = int(s.band_levels.max(axis=0).argmax()) if s.band_levels.size else None
    if loud is not None:
        print(f"  loudest band  {s.band_labels[loud]} Hz: {s.band_levels[:, loud].max():.1f} dB")
    for w in written:
        print(f"wrote {w}")
    return 0


def add_commands(sub: Any) -> None:
    from auralize.cli.options import add_volume_options, rate_int, vec3

    p = sub.add_parser(
        "spectrum",
        help="OASPL, dBA and 1/3-octave band levels of a render or at an observer",
        description="Sound pressure levels as the field reports them (dB re 20 uPa): the "
        "overall level (OASPL), A-weighted (dBA), and 1/3-octave bands (IEC 61260-1 base-10 "
        "centres), of an audio file auralize wrote (PATH.wav/.flac: its sidecar gives the "
        "pascals) or of a volume's pressure at an observer (PATH a volume, --listener): the "
        "volume sum of the whole field in physical time, or the FW-H surface integral "
        "(--method fwh --surface ...).",
    )
    add_volume_options(p)
    for action in p._actions:
        if action.dest == "volume":
            action.help = (
                "a .wav/.flac written by auralize, or a volume file or dataset:NAME "
                "(with --listener)"
            )
    g = p.add_argument_group("output")
    g.add_argument(
        "-o",
        "--output",
        metavar="LEVELS.csv|.json",
        help="write the levels (one row per band, one column per channel)",
    )
    g.add_argument("--plot", metavar="PNG", help="draw the bands and the narrowband spectrum")
    g.add_argument("--json", action="store_true", help="print the levels as JSON")
    g.add_argument("--fmin", type=float, default=10.0, help="lowest band, Hz (10)")
    g.add_argument(
        "--fmax",
        type=float,
        help="highest band, Hz (default 20000, or below the Nyquist frequency)",
    )
    g = p.add_argument_group("at an observer (PATH a volume)")
    g.add_argument("--listener", type=vec3, metavar="X,Y,Z", help="observer position, m")
    g.add_argument(
        "--method",
        choices=["volume", "fwh"],
        default="volume",
        help="volume: the whole field's volume sum (default); fwh: the FW-H "
        "surface integral (data that hold sound: compressible fields)",
    )
    g.add_argument(
        "--surface",
        metavar="SPEC",
        help="FW-H surface: box=x0;x1;y0;y1;z0;z1, sphere=cx;cy;cz;r[;nsub] or file=PATH",
    )
    g.add_argument("--rate", type=rate_int, default=44100, help="sample rate, Hz (44100)")
    p.set_defaults(func=cmd_spectrum)
