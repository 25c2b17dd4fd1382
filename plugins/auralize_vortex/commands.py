"""``auralize vortex …``: argument declarations only (entry point ``auralize.commands``).

The commands run :meth:`auralize_vortex.model.VortexSound._cmd_texture` and
``_cmd_render``, imported when they run.
"""

from __future__ import annotations

from typing import Any


def add_commands(subparsers: Any, options: Any) -> None:
    """Add the ``vortex`` sub-commands; the physics loads when one runs.

    ``options`` holds the shared-option helpers of the ``auralize`` command
    (see :meth:`auralize.plugins.SoundModel.add_cli`).
    """
    add_output_options = options.add_output_options
    add_renamed_alias = options.add_renamed_alias
    add_volume_options = options.add_volume_options
    positive_float = options.positive_float
    positive_int = options.positive_int
    seed_int = options.seed_int
    lazy = options.lazy
    p = subparsers.add_parser("vortex", help="vortex sound with sound textures (paper 000)")
    sub = p.add_subparsers(dest="vortex_command", required=True, metavar="SUBCOMMAND")
    t = sub.add_parser("texture", help="pre-compute a sound texture Q(u,t) into HDF5 (§5)")
    t.add_argument("--speeds", required=True, help="comma-separated increasing speeds in m/s")
    t.add_argument(
        "-o", "--output", required=True, help="texture .h5 (reused if the parameters match)"
    )
    t.add_argument(
        "--size", type=positive_int, default=16, help="cells per axis of the analysis box"
    )
    td = t.add_argument(
        "--texture-duration",
        type=positive_float,
        default=1.0,
        metavar="S",
        help="seconds of texture recorded per speed (default 1)",
    )
    add_renamed_alias(t, "--duration", td)
    t.add_argument("--seed", type=seed_int, default=0)
    t.add_argument("--box", type=positive_float, default=0.2, help="analysis box edge in m")
    t.add_argument("--dt", type=positive_float, default=1e-3, help="fluid time step in s")
    t.add_argument("--coefficient", choices=["howe", "paper"], default="howe")
    t.set_defaults(func=lazy("auralize_vortex.model:VortexSound._cmd_texture"))
    r = sub.add_parser("render", help="render the vortex sound of a velocity volume (§6)")
    add_volume_options(r)
    add_output_options(r)
    r.add_argument("--texture", metavar="TEX.h5", help="texture (default: cached default texture)")
    r.add_argument("--attenuation", choices=["physical", "paper"], default="physical")
    r.add_argument("--block", type=positive_int, default=5, help="points per sub-volume edge")
    r.add_argument("--velocity-field", default="velocity")
    r.add_argument("--time-scale", type=positive_float, default=1.0)
    r.set_defaults(func=lazy("auralize_vortex.model:VortexSound._cmd_render"))
