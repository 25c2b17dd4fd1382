"""``auralize spark …``: argument declarations only (entry point ``auralize.commands``).

The command runs :func:`auralize_spark.model.cmd_spark_render`, imported when it runs.
"""

from __future__ import annotations

from typing import Any

#: the Table 1 presets of :data:`auralize_spark.presets.PRESETS` (a test keeps them equal)
PRESET_NAMES = ("spark-balls", "plasma-ball", "lightning")


def add_commands(subparsers: Any, options: Any) -> None:
    """Add the ``spark`` sub-commands; the physics loads when one runs.

    ``options`` holds the shared-option helpers of the ``auralize`` command
    (see :meth:`auralize.plugins.SoundModel.add_cli`).
    """
    add_output_options = options.add_output_options
    finite_float = options.finite_float
    positive_float = options.positive_float
    positive_int = options.positive_int
    seed_int = options.seed_int
    lazy = options.lazy
    p = subparsers.add_parser("spark", help="spark discharges and thunder (paper 002)")
    sub = p.add_subparsers(dest="spark_command", required=True, metavar="ACTION")
    r = sub.add_parser("render", help="grow (or read) a discharge and render its sound")
    r.add_argument(
        "--preset",
        choices=PRESET_NAMES,
        default=None,
        help="Table 1 scale and its built-in scene (default spark-balls); "
        "with --scene/--discharge only the Table 1 values are used",
    )
    r.add_argument("--scene", metavar="FILE", help="charge scene .json/.toml")
    r.add_argument(
        "--discharge", metavar="CSV", help="discharge tree/polyline CSV instead of growing one"
    )
    r.add_argument("--seed", type=seed_int, default=0)
    r.add_argument("--strokes", type=positive_int, help="strokes per flash (default: preset)")
    r.add_argument("--gamma", type=finite_float, default=2.5, help="Eq. 2 exponent (default 2.5)")
    r.add_argument(
        "--T0", type=positive_float, help="baseline half-duration in s (default: preset)"
    )
    r.add_argument("--save-discharge", metavar="CSV", help="also write the discharge tree")
    r.add_argument("--json", action="store_true", help="print segments, strokes and timing as JSON")
    add_output_options(r)
    r.set_defaults(func=lazy("auralize_spark.model:cmd_spark_render"), command="spark render")
