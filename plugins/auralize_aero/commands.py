"""``auralize aero …``: argument declarations only (entry point ``auralize.commands``).

The commands run :meth:`auralize_aero.model.AeroSound._cmd_texture` and
``_cmd_render``, imported when they run.
"""

from __future__ import annotations

import argparse
from typing import Any

#: the §8 examples of :data:`auralize_aero.presets.PRESETS` (a test keeps them equal)
PRESET_NAMES = ("cylinder", "square", "sword", "sphere", "fence", "throw")


def add_commands(subparsers: Any, options: Any) -> None:
    """Add the ``aero`` sub-commands; the physics loads when one runs.

    ``options`` holds the shared-option helpers of the ``auralize`` command
    (see :meth:`auralize.plugins.SoundModel.add_cli`).
    """
    add_output_options = options.add_output_options
    add_renamed_alias = options.add_renamed_alias
    finite_float = options.finite_float
    positive_float = options.positive_float
    positive_int = options.positive_int
    seed_int = options.seed_int
    lazy = options.lazy
    p = subparsers.add_parser(
        "aero", help="aerodynamic sound: sound textures and rendering (paper 004)"
    )
    sub = p.add_subparsers(dest="aero_command", required=True, metavar="ACTION")
    t = sub.add_parser("texture", help="pre-process a sound texture by 2-D flow simulation (§5)")
    t.add_argument(
        "--shape", required=True, help="cylinder | square | sword | polygon FILE of x,y rows"
    )
    t.add_argument("--diameter", type=float, required=True, help="frontal width D in metres")
    t.add_argument("-o", "--output", required=True, help="texture .h5")
    t.add_argument("--speed", type=positive_float, default=10.0, help="base speed v0 in m/s (§7.2)")
    t.add_argument(
        "--directions", type=positive_int, help="sampled flow directions (default: 5° spacing)"
    )
    td = t.add_argument(
        "--texture-duration",
        type=positive_float,
        default=0.05,
        metavar="S",
        help="seconds of texture recorded (default 0.05)",
    )
    add_renamed_alias(t, "--duration", td)
    t.add_argument("--resolution", type=positive_int, default=16, help="lattice cells across D")
    t.add_argument(
        "--reynolds", type=positive_float, default=200.0, help="Reynolds number simulated"
    )
    tr = t.add_argument(
        "--texture-rate",
        type=positive_float,
        default=16000.0,
        metavar="HZ",
        help="texture sample rate in Hz (default 16000; render resamples it)",
    )
    add_renamed_alias(t, "--rate", tr)
    t.add_argument("--seed", type=seed_int, default=0)
    t.add_argument("--no-cache", action="store_true", help="recompute even if cached")
    t.set_defaults(func=lazy("auralize_aero.model:AeroSound._cmd_texture"))
    r = sub.add_parser("render", help="render the sound of a moving object or of wind (§6)")
    r.add_argument(
        "--texture",
        required=True,
        metavar="TEX.h5",
        help="the object's sound texture (written by 'auralize aero texture')",
    )
    mv = r.add_mutually_exclusive_group(required=True)
    mv.add_argument("--motion", metavar="MOTION.csv", help="object poses t,x,y,z,qw,qx,qy,qz")
    mv.add_argument(
        "--wind",
        type=positive_float,
        metavar="SPEED",
        help="wind speed on a static object (m/s)",
    )
    mv.add_argument("--preset", choices=PRESET_NAMES, help="a §8 example's object and motion")
    r.add_argument(
        "--wind-direction",
        default="0,1,0",
        help="x,y,z (with --wind; default +y, across the stick, which lies along +x)",
    )
    r.add_argument(
        "--gust",
        type=finite_float,
        default=0.05,
        help="relative wind fluctuation (with --wind)",
    )
    r.add_argument(
        "--object", default="stick", help="stick | fence | sphere | sword (default stick)"
    )
    r.add_argument("--length", type=positive_float, default=0.5, help="stick length in metres")
    r.add_argument(
        "--exponent",
        choices=["physical", "paper"],
        default="physical",
        help="amplitude ∝ v³ (physical) or v⁶ (paper Eq. 3)",
    )
    # "--stereo ears" (two ear receivers) is refused with an explanation; stereo is a VBAP layout
    r.add_argument("--stereo", help=argparse.SUPPRESS)
    r.add_argument("--seed", type=seed_int, default=0)
    add_output_options(r)
    r.set_defaults(func=lazy("auralize_aero.model:AeroSound._cmd_render"))
