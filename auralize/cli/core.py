"""The ``auralize`` command.

Every command that writes audio takes the same output options: ``-o``,
``--layout``, ``--rate``, ``--normalize``, ``--limit`` and either
``--listener x,y,z --duration S`` or ``--path CSV``.  Volumes are files or
built-in datasets written ``dataset:NAME`` (e.g. ``dataset:explosion``).

Errors print one line naming what is wrong (never a traceback) and exit with
a status that tells the kind of failure (see :data:`EXIT_CODES`, documented
in the README): 2 usage (a bad option or value), 3 data (an input file is
missing, unreadable or malformed), 4 system (the output cannot be written,
not enough memory, no device), 1 when the output was written but is silent,
70 an internal error (a bug: ``AURALIZE_DEBUG=1`` shows the traceback), 130
interrupted; ``auralize regress check`` exits 6 when a figure moved.  Output
folders are never created: the folder of ``-o`` must exist.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import re
import sys
import time
import traceback
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from auralize import __version__
from auralize.cli.options import (  # the shared options; re-exported for older imports
    DEFAULT_RATE,
    RATE_RANGE_HZ,  # noqa: F401
    add_output_options,
    add_volume_options,
    finite_float,
    listener_from_args,  # noqa: F401
    positive_float,
    positive_int,
    rate_int,  # noqa: F401
    seed_int,
)
from auralize.cli.options import field_map as _field_map
from auralize.cli.options import vec3 as _vec3
from auralize.defaults import DEFAULTS, ORBIT_FACES, TIMBRE_CHOICES
from auralize.errors import (
    AuralizeError,
    DataError,
    DeviceError,
    FieldError,
    FormatError,
    ListenerPathError,
    MissingDependencyError,
    MissingFileError,
    OutputError,
    ParameterError,
    PluginError,
    ResourceError,
)
from auralize.runtime.resources import FRAME_WORK_ARRAYS  # noqa: F401  (re-exported)

EXIT_SILENT = 1
EXIT_USAGE = 2
EXIT_DATA = 3
EXIT_SYSTEM = 4
EXIT_SCRIPT = 5
EXIT_REGRESSION = 6
EXIT_INTERNAL = 70
EXIT_INTERRUPTED = 130
#: exit status -> meaning (the README's table)
EXIT_CODES = {
    0: "success",
    EXIT_SILENT: "the output was written but is silent (the warning says why)",
    EXIT_USAGE: "usage error: a bad option or value",
    EXIT_DATA: "data error: an input file is missing, unreadable or malformed",
    EXIT_SYSTEM: "system error: the output cannot be written, not enough memory, no device",
    EXIT_SCRIPT: "the script run by 'auralize script' raised an error (its traceback is shown)",
    EXIT_REGRESSION: "'auralize regress check': a figure moved beyond its tolerance (each is named)",
    EXIT_INTERNAL: "internal error (a bug; AURALIZE_DEBUG=1 shows the traceback)",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C)",
}


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
#: a negative number, or a comma-separated list of numbers that starts with one
_NUMBERS = re.compile(rf"^-(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?:,{_NUMBER})*$")


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line (the value and a --help pointer).

    When required options are missing, the one line names all of them: the
    required options and every required choice (``--motion | --wind``) that
    none of the given options answers, where argparse alone reports the
    choices one run at a time, after the options.
    """

    _given: list[str] | None = None

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # a value that starts with a minus sign and is a number or a comma-separated
        # list of numbers (``--listener -3,0,1.5``) is a value, not an option
        self._negative_number_matcher = _NUMBERS

    def parse_known_args(self, args: Any = None, namespace: Any = None) -> Any:  # type: ignore[override]
        self._given = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(args, namespace)

    def error(self, message: str) -> Any:
        text = " ".join(message.split())
        if text.startswith("the following arguments are required:"):
            text += "".join(f"; and one of {' '.join(g)}" for g in self._open_choices())
        self.exit(EXIT_USAGE, f"{self.prog}: error: {text} (see '{self.prog} --help')\n")

    def _open_choices(self) -> list[list[str]]:
        """The required mutually exclusive groups with none of their options given."""
        given = {a.split("=", 1)[0] for a in self._given or [] if a.startswith("-")}
        out = []
        for group in self._mutually_exclusive_groups:
            if not group.required:
                continue
            names = [o for a in group._group_actions for o in a.option_strings]
            if not given.intersection(names):
                out.append([a.option_strings[-1] for a in group._group_actions if a.option_strings])
        return out


# ----------------------------------------------------------------- helpers
def _captures(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 2, got {text!r}") from None
    if v < 2:
        raise argparse.ArgumentTypeError(f"a line needs at least 2 captures, got {text!r}")
    return v


def _bench_groups(text: str) -> list[str]:
    """argparse type of ``bench --only`` (the bench module is imported when it is used)."""
    from auralize.bench.runner import bench_groups

    return bench_groups(text)


def _sizes(text: str) -> str:
    """argparse type of ``bench --sizes``: comma-separated whole numbers >= 2 (kept as text)."""
    for part in text.split(","):
        try:
            v = int(part)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected comma-separated grid sizes like 16,32,64, got {text!r}"
            ) from None
        if v < 2:
            raise argparse.ArgumentTypeError(f"grid sizes must be >= 2, got {part!r} in {text!r}")
    return text


def add_detect_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("detection")
    g.add_argument(
        "--mapping",
        help="paper-density | identity | cfd | incompressible (default: chosen from the fields)",
    )
    g.add_argument("--density-field", help="field holding density (identity/cfd)")
    g.add_argument("--velocity-field", help="field holding velocity (identity/cfd/incompressible)")
    g.add_argument("--momentum-field", help="field holding momentum ρv (cfd; e.g. PLOT3D Momentum)")
    g.add_argument("--pressure-field", help="field holding pressure (incompressible; e.g. p)")
    g.add_argument("--log-density-field", help="field holding log10 density (paper-density)")
    for kind in ("monopole", "dipole", "quadrupole"):
        g.add_argument(
            f"--threshold-{kind}",
            default="auto",
            metavar="X",
            help=f"{kind} threshold: auto (adapts to the data: a robust noise floor or the "
            f"points carrying 90%% of the strength), 'top:1%%' (strongest 1%% of the valid "
            f"points), 'N%%' of the peak, or an absolute value",
        )
    g.add_argument(
        "--zero-fraction",
        type=float,
        default=1.0,
        help="'almost zero' = below this fraction of the other types' thresholds",
    )
    g.add_argument(
        "--floor",
        type=float,
        default=3.0,
        metavar="X",
        help="a strength not above X times its own discretisation error (the same difference "
        "over 2h and 2Δt compared with it) is not a source, whatever the threshold (default 3; "
        "0: paper 003's literal detection)",
    )


def time_scale_arg(text: str) -> float | str:
    if text.strip().lower() == "auto":
        return "auto"
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'auto' or a number, got {text!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"time scale must be > 0 or 'auto', got {text!r}")
    return v


#: what ``--highpass`` means in ``render``, ``play`` and their Dask variant
HIGHPASS_HELP = (
    "causal high-pass of the volume's sources, Hz (default 20; 0 keeps everything); "
    "--model/--scene sound models are heard as their model makes them (no "
    "high-pass: the same samples as the model's own command)"
)


#: what ``--timbre`` means in ``render`` and ``play``
TIMBRE_HELP = (
    "physical: the retarded-time pressure; extended: plus power-law noise above the "
    "data's Nyquist (paper 001 §4); tonal: a carrier per source type; auto "
    "(default): physical if most of it is above 20 Hz, else extended"
)


#: what ``--heard`` means in ``render`` and ``play``
HEARD_HELP = (
    "what is heard: field (default: the physical sound of the whole field, every valid "
    "point, no threshold: Lighthill's stress and the continuity residual); detected "
    "(paper 003: the detected sources); a list of types such as dipole,quadrupole "
    "(the detected sources of those types, the others muted); field:quadrupole or "
    "field:monopole (one term of the whole field)"
)


def add_heard_options(p: Any) -> None:
    """``--heard`` and ``--orbit-face``: what a render of a volume hears, and how the
    default orbit's listener faces."""
    p.add_argument("--heard", default=None, metavar="WHAT", help=HEARD_HELP)
    p.add_argument(
        "--orbit-face",
        choices=ORBIT_FACES,
        default=DEFAULTS.orbit_face,
        help="the default orbit's listener (no --listener or --path): sweep "
        "(default: the head turns so the data pass around the listener, every "
        "speaker carries them), center (faces the data), forward (along the "
        "motion), fixed (faces +y)",
    )


def heard_arg(args: argparse.Namespace) -> str:
    """``--heard`` as given, or ``detected`` when ``--sources`` gives detected sources."""
    h = getattr(args, "heard", None)
    if h:
        return str(h)
    return "detected" if getattr(args, "sources", None) else "field"


def add_render_options(p: argparse.ArgumentParser) -> None:
    """Synthesis options shared by ``render`` and its Dask variant."""
    p.add_argument(
        "--time-scale",
        type=time_scale_arg,
        default=DEFAULTS.time_scale,
        help="playback seconds per data second, or auto (default): the data's span "
        "plays in --duration",
    )
    p.add_argument("--interp", choices=["linear", "cubic"], default="cubic")
    p.add_argument(
        "--sources",
        metavar="SOURCES.h5",
        help="reuse sources from 'auralize detect' (heard with --heard detected, "
        "which this implies)",
    )
    add_heard_options(p)
    p.add_argument("--timbre", choices=TIMBRE_CHOICES, default=DEFAULTS.timbre, help=TIMBRE_HELP)
    p.add_argument(
        "--highpass", type=float, default=DEFAULTS.highpass_hz, metavar="HZ", help=HIGHPASS_HELP
    )
    p.add_argument(
        "--method",
        choices=("auto", "volume", "fwh"),
        default=DEFAULTS.method,
        help="how the volume is heard: volume (the sum of its sources, paper 003), "
        "fwh (the Ffowcs Williams-Hawkings integral on --surface: the sound "
        "waves a compressible simulation holds, in data time), auto (default: "
        "fwh when the data's pressure or density obeys the wave equation, else "
        "volume)",
    )
    p.add_argument(
        "--surface",
        metavar="SPEC",
        default=None,
        help="the FW-H surface: box=x0;x1;y0;y1;z0;z1, sphere=cx;cy;cz;r or "
        "file=PATH (default: a box 10%% of the extent inside the data)",
    )
    p.add_argument("--json", action="store_true", help="print the render report as JSON")


def _air_arg(text: str) -> Any:
    from auralize.emitters.outdoor import Air

    try:
        return Air.parse(text)
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _ground_arg(text: str) -> Any:
    from auralize.emitters.outdoor import Ground

    try:
        return Ground.parse(text)
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_outdoor_options(p: argparse.ArgumentParser) -> None:
    """``--air T[,RH[,P]]`` and ``--ground H[,Q]``: outdoor propagation of every part."""
    g = p.add_argument_group("outdoors (off by default)")
    g.add_argument(
        "--air",
        type=_air_arg,
        default=None,
        metavar="T[,RH[,P]]",
        help="air absorption after ISO 9613-1 along every source-listener path: "
        "temperature °C, relative humidity %% (default 70), pressure kPa "
        "(default 101.325), e.g. --air 20,70",
    )
    g.add_argument(
        "--ground",
        type=_ground_arg,
        default=None,
        metavar="H[,Q]",
        help="a flat ground at z = H m with reflection factor Q (-1..1, default 1: "
        "rigid): every source heard with its image, e.g. --ground 0,0.8 "
        "(a negative height: --ground=-2,0.9)",
    )


def _print_outdoor(meta: dict[str, Any]) -> None:
    """The outdoor line of a render report (nothing when outdoor propagation is off)."""
    od = meta.get("outdoor")
    if od:
        print(od["text"])
        for note in od.get("notes", []):
            print(f"note: {note}")


def outdoor_args(args: argparse.Namespace) -> dict[str, Any]:
    """``air``/``ground`` keywords of the render from ``--air``/``--ground`` (none when off)."""
    air, ground = getattr(args, "air", None), getattr(args, "ground", None)
    return {} if air is None and ground is None else {"air": air, "ground": ground}


def load_volume(args: argparse.Namespace) -> Any:
    from auralize.io.options import curvilinear_mode
    from auralize.pipeline import load

    with curvilinear_mode("resample" if getattr(args, "resample", False) else "native"):
        vol = load(
            args.volume,
            size=args.size,
            steps=args.steps,
            seed=args.seed,
            fields=_field_map(args.field),
            resolution=args.resolution,
            nan=getattr(args, "nan", "mask"),
            time_dim=getattr(args, "time_dim", None),
            axis_scale=getattr(args, "axis_scale", None),
            box=getattr(args, "box", None),
        )
    command = str(getattr(args, "command", "") or "")
    # Dask spreads the steps over workers: only one step must fit in this process
    nbytes = check_volume_memory(vol, data=not command.startswith("scale-"))
    if command not in ("info", "") and not command.startswith("scale-"):
        from auralize.runtime.resources import estimate_note

        note = estimate_note(nbytes)
        if note and logging.getLogger("auralize").isEnabledFor(logging.INFO):  # not with -q
            print(f"auralize {command}: note: {vol.source}: {note}", file=sys.stderr)
    return vol


def check_volume_memory(vol: Any, *, data: bool = True) -> float:
    """Refuse a volume larger than the machine before any work: one time step's working
    arrays plus the bookkeeping of every step must fit in memory, and (``data``) the
    steps x points x components to read must stay below ``AURALIZE_DATA_LIMIT``
    (:func:`auralize.runtime.resources.require_volume`).  Returns the bytes of data
    the work reads."""
    from auralize.runtime.resources import require_volume

    comps = sum(3 if vol.is_vector(n) else 1 for n in vol.field_names)
    return require_volume(
        vol.dims,
        vol.n_steps,
        comps,
        str(vol.source),
        hint="resample it smaller (--resolution N), read fewer fields or steps, or use "
        "'auralize scale-detect'",
        data=data,
    )


def check_render_memory(args: argparse.Namespace, duration_s: float, channels: int) -> None:
    """Refuse a render whose audio (duration x rate x channels) cannot fit in memory."""
    from auralize.runtime.resources import audio_bytes, require_memory

    rate = getattr(args, "rate", 44100)
    if duration_s * rate < 2:
        raise ParameterError(
            f"--duration {duration_s:g} s at {rate} Hz gives {duration_s * rate:.3g} samples; "
            f"give at least {2 / rate:.3g} s"
        )
    require_memory(
        audio_bytes(duration_s, rate, channels),
        f"{duration_s:g} s of {channels}-channel audio at {rate} Hz",
        hint="render a shorter duration (or split the path) or a lower --rate",
    )


def thresholds_from_args(args: argparse.Namespace) -> Any:
    from auralize.sources.detection import Thresholds

    return Thresholds(
        args.threshold_monopole,
        args.threshold_dipole,
        args.threshold_quadrupole,
        zero_fraction=args.zero_fraction,
        floor=getattr(args, "floor", 3.0),
    )


def mapping_fields(args: argparse.Namespace) -> dict[str, Any]:
    out: dict[str, Any] = {}
    if args.density_field:
        out["density"] = args.density_field
    if args.velocity_field:
        out["velocity"] = args.velocity_field
    if args.log_density_field:
        out["field"] = args.log_density_field
    if getattr(args, "momentum_field", None):
        out["momentum"] = args.momentum_field
    if getattr(args, "pressure_field", None):
        out["pressure"] = args.pressure_field
    return out


def _report_unavailable(command: str, series: Any) -> None:
    """Say once, on stderr, which source types could not be computed and why
    (``series``: a SourceSeries or a render's meta)."""
    meta = series if isinstance(series, dict) else getattr(series, "meta", {})
    by_reason: dict[str, list[str]] = {}
    for kind, why in (meta.get("unavailable") or {}).items():
        by_reason.setdefault(str(why), []).append(kind)
    for why, kinds in by_reason.items():
        print(f"auralize {command}: note: no {' or '.join(kinds)} sources: {why}", file=sys.stderr)


def progress_wanted() -> bool:
    return sys.stderr.isatty()


# ----------------------------------------------------------------- commands
def cmd_info(args: argparse.Namespace) -> int:
    from auralize.pipeline import auto_mapping
    from auralize.sources.mapping import ROLE_NAMES, match_field, role_reason

    vol = load_volume(args)
    # first: a vector stored as components is assembled into a field of the volume
    roles = {r: match_field(vol, r) for r in ROLE_NAMES}
    d = vol.describe()
    units = vol.attrs.get("units") if isinstance(vol.attrs.get("units"), dict) else {}
    centring = vol.attrs.get("centring") if isinstance(vol.attrs.get("centring"), dict) else {}
    d["times"] = vol.times.tolist()
    d["field_info"] = {
        k: {"kind": d["fields"][k], "units": units.get(k), "centring": centring.get(k, "point")}
        for k in vol.field_names
    }
    d["roles"] = {r: f for r, f in roles.items() if f is not None}
    d["role_reasons"] = {r: role_reason(vol, r, f) for r, f in d["roles"].items()}
    d["mapping"] = auto_mapping(vol)
    d["method"] = _render_method(vol)
    for key in (
        "reader",
        "time_units",
        "time_dim",
        "grid_units",
        "axis_units",
        "projection",
        "mesh",
        "resampling",
        "index_block",
    ):
        if key in vol.attrs:
            d[key] = vol.attrs[key]
    if args.json:
        print(json.dumps(d, indent=2, default=str))
        return 0
    print(f"{d['source']}")
    if "reader" in vol.attrs:
        print(f"  reader   {vol.attrs['reader']}")
    if "mesh" in vol.attrs:
        print(f"  mesh     {vol.attrs['mesh']}")
    b = vol.bounds
    if vol.coords is not None:
        edges = d["edge_lengths"]
        print(
            f"  grid     curvilinear, native: {vol.dims[0]} x {vol.dims[1]} x {vol.dims[2]} "
            f"points (i, j, k), edges {edges[0]:.3g} .. {edges[1]:.3g} m, extent "
            f"x[{b[0]:g}, {b[1]:g}] y[{b[2]:g}, {b[3]:g}] z[{b[4]:g}, {b[5]:g}] m "
            f"(--resample: onto a uniform grid)"
        )
        blk = vol.attrs.get("index_block")
        if isinstance(blk, dict):
            n = blk["of"]
            print(
                f"  box      index block i {blk['i'][0]}..{blk['i'][1]}, j {blk['j'][0]}.."
                f"{blk['j'][1]}, k {blk['k'][0]}..{blk['k'][1]} of {n[0]} x {n[1]} x {n[2]} "
                f"points: the smallest whose cells cover --box"
            )
    else:
        print(
            f"  grid     {vol.dims[0]} x {vol.dims[1]} x {vol.dims[2]} points, spacing "
            f"{', '.join(f'{s:g}' for s in vol.spacing)} m, origin {', '.join(f'{o:g}' for o in vol.origin)} m"
        )
    print(f"  bounds   x[{b[0]:g}, {b[1]:g}] y[{b[2]:g}, {b[3]:g}] z[{b[4]:g}, {b[5]:g}] m")
    axis_units = vol.attrs.get("axis_units")
    if isinstance(axis_units, dict) and axis_units:
        print(f"  axes     {', '.join(f'{a}: {u}' for a, u in axis_units.items())}")
    print(f"  valid    {100.0 * vol.valid_ratio:.1f} % of the grid points lie inside the mesh")
    tnote = "" if vol.physical_times else " (no physical times: frames at 30 Hz)"
    print(f"  times    {vol.n_steps} steps, {vol.times[0]:g} .. {vol.times[-1]:g} s{tnote}")
    shown = ", ".join(f"{t:g}" for t in vol.times[:8]) + (" ..." if vol.n_steps > 8 else "")
    print(
        f"           t = {shown} s"
        + (
            f" (the file's time units: {vol.attrs['time_units']})"
            if "time_units" in vol.attrs
            else ""
        )
    )
    for name, info in d["field_info"].items():
        unit = f", {info['units']}" if info["units"] else ""
        print(f"  field    {name} ({info['kind']}, {info['centring']} data{unit})")
    if not d["roles"]:
        print("  roles    none recognised (name them with --density-field, --velocity-field ...)")
    for r, f in d["roles"].items():
        print(f"  role     {r} = {f}: {d['role_reasons'][r]}")
    print(f"  mapping  {d['mapping']} (default; --mapping to choose)")
    m = d["method"]
    print(f"  method   {m['name']}: {m['why']} (render's --method auto; --method to choose)")
    return 0


#: grid values (points x steps read) above which ``info`` leaves the wave test to the render
INFO_WAVE_TEST_VALUES = 50_000_000


def _render_method(vol: Any) -> dict[str, str]:
    """How ``auralize render`` would hear ``vol`` (:func:`auralize.fwh.classify.choose_method`),
    unless the wave test would read too much for ``info`` (then said so)."""
    from auralize.fwh.classify import SAMPLE_STEPS, choose_method

    if vol.n_points * 6 * SAMPLE_STEPS > INFO_WAVE_TEST_VALUES:
        return {
            "name": "decided by render",
            "why": "the wave test reads 48 steps, left to the render for data this large",
        }
    how = choose_method(vol)
    name = "fwh" if how.name == "fwh" else "volume"
    return {"name": name, "why": how.why}


def cmd_dataset(args: argparse.Namespace) -> int:
    from auralize.io import save_volume
    from auralize.pipeline import load

    vol = load(f"dataset:{args.name}", size=args.size, steps=args.steps, seed=args.seed)
    t = time.perf_counter()
    save_volume(vol, args.output)
    print(
        f"wrote {args.output}: {args.name}, {vol.dims[0]}x{vol.dims[1]}x{vol.dims[2]} x "
        f"{vol.n_steps} steps, fields {', '.join(vol.field_names)} "
        f"({time.perf_counter() - t:.1f} s)"
    )
    return 0


def cmd_detect(args: argparse.Namespace) -> int:
    from auralize.pipeline import detect_sources
    from auralize.sources.sources_file import save_sources_h5, save_sources_pvd
    from auralize.volume import tally_nonfinite

    out = Path(args.output)
    if out.suffix.lower() not in (".pvd", ".h5", ".hdf5", ".vtkhdf"):
        raise ParameterError(f"{out}: sources output must end in .h5/.hdf5, .pvd or .vtkhdf")
    vol, tally = tally_nonfinite(load_volume(args))
    t = time.perf_counter()
    series = detect_sources(
        vol,
        mapping=args.mapping,
        thresholds=thresholds_from_args(args),
        progress_bar=progress_wanted(),
        **mapping_fields(args),
    )
    elapsed = time.perf_counter() - t
    series.meta["masked_fraction"] = tally.fraction
    _report_unavailable("detect", series)
    if out.suffix.lower() == ".pvd":
        save_sources_pvd(series, out)
    elif out.suffix.lower() == ".vtkhdf":
        from auralize.io.vtkhdf_write import write_sources_vtkhdf

        write_sources_vtkhdf(series, out)
    else:
        save_sources_h5(series, out)
    counts = series.counts()
    if args.json:
        print(
            json.dumps(
                {
                    "output": str(out),
                    "thresholds": series.thresholds.tolist(),
                    "mapping": series.meta.get("mapping"),
                    "fraction": series.meta.get("fraction"),
                    "valid_ratio": series.meta.get("valid_ratio"),
                    "masked_fraction": series.meta.get("masked_fraction"),
                    "unavailable": series.meta.get("unavailable", {}),
                    "steps": [
                        {"step": n, "time": float(series.times[n]), **c}
                        for n, c in enumerate(counts)
                    ],
                    "seconds": elapsed,
                },
                indent=2,
            )
        )
    else:
        tot = {k: sum(c[k] for c in counts) for k in ("monopole", "dipole", "quadrupole")}
        print(
            f"wrote {out}: {series.n_steps} steps in {elapsed:.2f} s; source points over all "
            f"steps: {tot['monopole']} monopole, {tot['dipole']} dipole, {tot['quadrupole']} "
            f"quadrupole (thresholds {', '.join(f'{x:.4g}' for x in series.thresholds)}); "
            f"valid points {100.0 * vol.valid_ratio:.1f} %, masked (NaN/Inf) "
            f"{100.0 * tally.fraction:.2f} %"
        )
        frac = series.meta.get("fraction") or {}
        if frac:
            print(
                "share of the valid points classified: "
                + ", ".join(f"{frac[k]:.2%} {k}" for k in ("monopole", "dipole", "quadrupole"))
            )
    return 0


def add_scene_options(p: argparse.ArgumentParser) -> None:
    """``--model NAME:FILE[:key=value,...]`` (repeatable) and ``--scene JSON``."""
    g = p.add_argument_group("scene (several sound models along one listener path)")
    g.add_argument(
        "--model",
        action="append",
        metavar="NAME:FILE[:key=value,...]",
        help="add a sound model's sound (repeatable): NAME a registered model "
        "('auralize plugins'), FILE its input (file or dataset:NAME), then "
        "optional parameters, e.g. fire:dataset:fire:extend=none",
    )
    g.add_argument(
        "--scene",
        metavar="SCENE.json",
        help="a scene file: listener, layout and a list of {model, input, params} "
        "(options given on the command line win), or a saved session (its "
        "data, audible overlays and models along its path)",
    )


def scene_setup(args: argparse.Namespace, parser_defaults: dict[str, Any]) -> tuple[Any, Any, Any]:
    """The models of ``--model``/``--scene`` (checked) and the listener: ``(models, path,
    listener)``.  ``args.layout``/``args.rate``/``args.duration`` take the scene file's
    values where the command line left them at ``parser_defaults``."""
    from auralize.listener import ListenerPath
    from auralize.scene.soundscene import load_scene, parse_model_spec
    from auralize.spatial.layouts import get_layout

    scene = load_scene(args.scene) if args.scene else None
    models = [*(scene.models if scene else []), *(parse_model_spec(m) for m in args.model or [])]
    for sm in models:
        sm.check()
    if scene is not None:  # the scene file fills what the command line left at its default
        for key in ("layout", "rate"):
            if getattr(scene, key) is not None and getattr(args, key) == parser_defaults[key]:
                setattr(args, key, getattr(scene, key))
        if args.duration is None and scene.duration is not None:
            args.duration = float(scene.duration)
    get_layout(args.layout)  # a bad layout fails before any slow work
    path = ListenerPath.from_csv(args.path) if args.path else None
    listener = args.listener
    if path is None and listener is None and scene is not None:
        path, listener = scene.path, scene.listener
    return models, path, listener


def scene_duration(args: argparse.Namespace, sound: Any, path: Any, own_path: bool) -> float:
    """Playback seconds of a scene: ``--duration`` (or the scene file's) exactly; else the
    length of a listener path given with the scene (``--path``, the scene's or session's
    path); else long enough for every part (:func:`auralize.scene.soundscene.scene_length`:
    a spark until its waves have passed, the volume's sound, a fire's emission heard)."""
    from auralize.scene.soundscene import scene_length

    if args.duration is not None:
        return float(args.duration)
    if own_path:
        return float(path.duration)
    return scene_length(sound, path)


def scene_from_args(
    args: argparse.Namespace, parser_defaults: dict[str, Any], command: str = "render"
) -> tuple[Any, Any, float, list[str]]:
    """The scene of ``--model``/``--scene`` (plus the field of a positional volume).

    Returns ``(sound, path, duration, notes)``: every model's
    :class:`~auralize.emitters.Sound` joined, the listener path, the playback
    seconds (:func:`scene_duration`) and what to tell the user.
    ``args.layout``/``args.rate``/``args.duration`` take the scene file's
    values where the command line left them at ``parser_defaults``.
    """
    from auralize.emitters import Sound
    from auralize.pipeline import DEFAULT_DURATION
    from auralize.scene.soundscene import scene_sound
    from auralize.spatial import get_layout

    models, path, listener = scene_setup(args, parser_defaults)
    own_path = path is not None
    n_channels = get_layout(args.layout).n_channels
    if args.duration is not None or own_path:  # a known length fails before any slow work
        check_render_memory(args, args.duration or path.duration, n_channels)
    notes: list[str] = []
    sound = Sound(parts=[], meta={}, name="")
    if args.volume is not None:  # the field of the positional volume, planned as a plain render
        from auralize.field_model import FieldAuralization
        from auralize.pipeline import plan_heard

        vol = load_volume(args)
        series = None
        if args.sources:
            from auralize.sources.sources_file import load_sources_for

            series = load_sources_for(args.sources, vol)
        hs, plan = plan_heard(
            vol,
            path=path,
            listener=listener,
            duration=args.duration,
            time_scale=args.time_scale,
            clip=False,
            orbit_face=getattr(args, "orbit_face", DEFAULTS.orbit_face),
            heard=heard_arg(args),
            series=series,
            mapping=args.mapping,
            thresholds=thresholds_from_args(args),
            progress_bar=progress_wanted(),
            **mapping_fields(args),
        )
        path = plan.path
        notes += plan.notes + [plan.mapping_text + (" (auto)" if plan.auto else "")]
        sound = sound + FieldAuralization().synthesize(
            (vol, hs),
            time_scale=plan.time_scale,
            lead=plan.lead,
            interp=args.interp,
            timbre=getattr(args, "timbre", DEFAULTS.timbre),
        )
        _report_unavailable(command, hs.meta)
    elif args.sources:
        raise ParameterError("--sources needs the volume they were detected in (PATH)")
    else:
        if path is None and listener is None:
            raise ParameterError(
                "a scene without a volume needs a listener: --path CSV, "
                "--listener X,Y,Z or 'listener' in the scene file"
            )
        if path is None:
            from auralize.listener import ListenerPath

            path = ListenerPath.point(listener, duration=args.duration or DEFAULT_DURATION)
    sound = sound + scene_sound(models, path, args.duration, rate=args.rate)
    duration = scene_duration(args, sound, path, own_path)
    if args.duration is None and not own_path:
        check_render_memory(args, duration, n_channels)
        notes.append(
            f"scene length {duration:.4g} s: until every part has been heard "
            f"(give --duration to choose)"
        )
    return sound, path, duration, notes


def cmd_render_scene(args: argparse.Namespace, parser_defaults: dict[str, Any]) -> int:
    """``auralize render`` with ``--model``/``--scene``: every model summed along one path."""
    from auralize.emitters.timbre import loudness
    from auralize.pipeline import save_rendered
    from auralize.rendering import render
    from auralize.spatial.layouts import get_layout

    t = time.perf_counter()
    sound, path, duration, notes = scene_from_args(args, parser_defaults)
    lay = get_layout(args.layout)
    out = render(
        sound,
        path,
        rate=args.rate,
        layout=lay,
        duration=duration,
        highpass_hz=args.highpass,
        **outdoor_args(args),
    )
    out.meta.update({"seconds": time.perf_counter() - t, "duration_s": duration, "notes": notes})
    gain = save_rendered(
        out, args.output, normalize=args.normalize, limit_pa=args.limit, subtype=args.format
    )
    ld = loudness(out.audio, out.rate)
    kinds = ", ".join(f"{p['model']} ({p['kind']})" for p in out.meta["parts"])
    report = (
        f"wrote {args.output}: {out.duration:.2f} s, {lay.name} ({lay.n_channels} ch) at "
        f"{out.rate} Hz; scene of {len(out.meta['parts'])} part(s): {kinds}; peak "
        f"{ld['peak']:.4g}, RMS {ld['rms']:.4g} Pa (gain {gain:.4g})"
    )
    if args.json:
        print(
            json.dumps(
                {
                    "output": str(args.output),
                    **out.meta,
                    "gain": gain,
                    "loudness": ld,
                    "report": report,
                },
                indent=2,
                default=str,
            )
        )
        return 0
    for note in notes:
        print(note)
    for part in out.meta["parts"]:
        print(f"  {part['model']:10s} {part['kind']:14s} peak {part['peak_pa']:.4g} Pa")
    _print_outdoor(out.meta)
    print(report)
    return 0


def cmd_render(args: argparse.Namespace) -> int:
    from auralize.pipeline import DEFAULT_DURATION, auralize, report_line, save_rendered
    from auralize.spatial.layouts import synthesis_layout

    if args.model or args.scene:
        return cmd_render_scene(args, {"layout": "mono", "rate": DEFAULT_RATE})
    if args.volume is None:
        raise ParameterError(
            "give a volume PATH, or sound models with --model NAME:FILE or --scene SCENE.json"
        )

    path = None
    if args.path:
        from auralize.listener import ListenerPath

        path = ListenerPath.from_csv(args.path)
    duration = args.duration or (path.duration if path is not None else DEFAULT_DURATION)
    check_render_memory(args, duration, synthesis_layout(args.layout).n_channels)
    vol = load_volume(args)
    series = None
    if args.sources:
        from auralize.sources.sources_file import load_sources_for

        series = load_sources_for(args.sources, vol)
    t = time.perf_counter()
    out, series = auralize(
        vol,
        path,
        mapping=args.mapping,
        thresholds=thresholds_from_args(args),
        rate=args.rate,
        time_scale=args.time_scale,
        interp=args.interp,
        layout=args.layout,
        duration=args.duration,
        series=series,
        progress_bar=progress_wanted(),
        timbre=args.timbre,
        highpass_hz=args.highpass,
        seed=args.seed,
        listener=args.listener,
        heard=heard_arg(args),
        orbit_face=args.orbit_face,
        method=args.method,
        surface=args.surface,
        **outdoor_args(args),
        **mapping_fields(args),
    )
    elapsed = time.perf_counter() - t
    out.meta["seconds"] = elapsed
    gain = save_rendered(
        out, args.output, normalize=args.normalize, limit_pa=args.limit, subtype=args.format
    )
    _report_unavailable("render", out.meta)
    report = report_line(out, args.output, gain=gain)
    if args.json:
        from auralize.emitters.timbre import loudness

        print(
            json.dumps(
                {
                    "output": str(args.output),
                    **out.meta,
                    "gain": gain,
                    "loudness": loudness(out.audio, out.rate),
                    "report": report,
                },
                indent=2,
                default=str,
            )
        )
        return 0
    for note in out.meta.get("notes", []):
        print(note)
    print(out.meta["method_text"])
    print(out.meta["time_mapping"] + (" (auto)" if out.meta.get("time_scale_auto") else ""))
    for note in out.meta.get("timbre_notes", []):
        print(note)
    _print_outdoor(out.meta)
    print(report)
    return 0


def cmd_path(args: argparse.Namespace) -> int:
    from auralize.listener import ListenerPath, line_past, orbit_around

    spec = getattr(args, "volume_pos", None) or getattr(args, "volume", None)
    bounds = None
    span = 0.0
    if spec:
        from auralize.pipeline import load

        vol = load(spec, size=args.size, steps=args.steps, seed=args.seed)
        bounds = vol.bounds
        span = float(vol.times[-1] - vol.times[0])
    duration = args.duration
    if duration is None:
        from auralize.pipeline import DEFAULT_DURATION

        duration = DEFAULT_DURATION

    def need(name: str, value: Any) -> Any:
        if value is None and bounds is None:
            raise ParameterError(
                f"path {args.kind}: give --{name}, or a volume (--volume FILE) "
                f"to place the path around the data"
            )
        return value

    # a path around the data moves at most MAX_ORBIT_MACH × c0 in data time when
    # rendered with the automatic time scale (the data's span in the path's duration)
    from auralize.emitters.synthesis import C0
    from auralize.pipeline import MAX_ORBIT_MACH

    reach = MAX_ORBIT_MACH * C0 * span  # metres the listener may travel
    if args.kind == "point":
        p = ListenerPath.point(args.at, duration=duration)
    elif args.kind == "line":
        if need("start", args.start) is None or need("end", args.end) is None:
            p = line_past(bounds, duration=duration, length=reach)  # type: ignore[arg-type]
        else:
            p = ListenerPath.line(
                args.start, args.end, duration=duration, n=args.captures, face=args.face
            )
    else:
        if need("center", args.center) is None or need("radius", args.radius) is None:
            p = orbit_around(
                bounds,  # type: ignore[arg-type]
                duration=duration,
                turns=args.turns or 1.0,
                radius=args.radius,
                rate_hz=args.rate_hz,
            )
            travel = args.turns or 1.0
            length = float(np.sum(np.linalg.norm(np.diff(p.positions, axis=0), axis=1)))
            if args.turns is None and length > reach:
                travel = reach / length
                p = orbit_around(
                    bounds,  # type: ignore[arg-type]
                    duration=duration,
                    turns=travel,
                    radius=args.radius,
                    rate_hz=args.rate_hz,
                )
            if args.center is not None:
                p = ListenerPath.orbit(
                    args.center,
                    radius=float(
                        np.linalg.norm(
                            p.positions[0] - np.asarray(bounds).reshape(3, 2).mean(axis=1)
                        )
                    ),
                    duration=duration,
                    turns=travel,
                    height=args.height,
                    rate_hz=args.rate_hz,
                )
            elif args.height:
                p.positions[:, 2] += args.height
        else:
            p = ListenerPath.orbit(
                args.center,
                radius=args.radius,
                duration=duration,
                turns=args.turns or 1.0,
                height=args.height,
                rate_hz=args.rate_hz,
            )
    p.to_csv(args.output)
    from auralize.listener import describe_path

    print(
        f"wrote {args.output}: {args.kind}, {p.n_captures} captures over {p.duration:g} s, "
        f"{describe_path(p)}"
    )
    return 0


def cmd_plugins(args: argparse.Namespace) -> int:
    from auralize.plugins import registry

    models = {name: cls().describe() for name, cls in registry().items()}
    if args.json:
        print(json.dumps(models, indent=2, default=str))
        return 0
    if not models:
        print("no sound models registered")
    for name, d in models.items():
        print(f"{name:10s} {d['description']}")
        for prm in d["parameters"]:
            rng = prm["range"] or prm["choices"] or ""
            print(f"    {prm['name']:22s} default {prm['default']!r} {prm['unit']} {rng}")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    """The main job on a built-in dataset: explosion -> sources -> ring8 WAV + pictures."""
    from auralize.datasets.synthetic import make_dataset
    from auralize.listener import ListenerPath
    from auralize.pipeline import auralize, detect_sources, save_rendered
    from auralize.scene.pictures import screenshot
    from auralize.scene.plots import save_spectrogram
    from auralize.warmup import compile_ahead

    # with a cold kernel cache, the synthesis kernel compiles on another core while this
    # one compiles and runs the detection (the render waits for it, then loads it)
    compile_ahead(["pieces"])
    out_dir = Path(args.output)
    out_dir.mkdir(exist_ok=True)  # the output folder itself; its parent must exist
    t = time.perf_counter()
    print(f"generating dataset:explosion ({args.size}³ x 30 steps) ...", flush=True)
    vol = make_dataset("explosion", size=args.size, seed=args.seed).load()
    c = vol.center
    radius = 0.3 * float(vol.bounds[1] - vol.bounds[0])
    duration = float(vol.times[-1] - vol.times[0] + 1 / 30) * args.time_scale
    # the head turns as the default orbit's does (DEFAULTS.orbit_face): every speaker carries
    # the data, not only those facing the centre
    path = ListenerPath.orbit(
        c, radius=radius, duration=duration, turns=0.25, height=2.0, face=DEFAULTS.orbit_face
    )
    path.to_csv(out_dir / "explosion_path.csv")
    print("detecting sources (drawn) and rendering the whole field (heard) ...", flush=True)
    series = detect_sources(vol, progress_bar=progress_wanted())
    rendered, _ = auralize(
        vol,
        path,
        layout=args.layout,
        time_scale=args.time_scale,
        progress_bar=progress_wanted(),
        timbre="auto",
    )
    for note in rendered.meta.get("timbre_notes", []):
        print(note)
    wav = out_dir / f"explosion_{args.layout}.wav"
    save_rendered(rendered, wav)
    png = screenshot(
        vol, out_dir / "explosion.png", series=series, path=path, step=vol.n_steps // 3
    )
    spec = save_spectrogram(
        rendered.audio,
        rendered.rate,
        out_dir / "explosion_spectrogram.png",
        channel_names=rendered.layout.channel_names,
    )
    counts = series.counts()
    tot = {k: sum(c[k] for c in counts) for k in ("monopole", "dipole", "quadrupole")}
    print(
        f"wrote {wav} ({rendered.layout.n_channels} channels, {rendered.duration:.2f} s), "
        f"{png}, {spec}"
    )
    print(
        f"drawn: sources over {vol.n_steps} steps: {tot['monopole']} monopole, {tot['dipole']} "
        f"dipole, {tot['quadrupole']} quadrupole; heard: {rendered.meta['heard_text']}; "
        f"{time.perf_counter() - t:.1f} s in all"
    )
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from auralize.bench.runner import run_bench

    return run_bench(args)


# ----------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    ap = _Parser(prog="auralize", description="Hear 3-D time-varying data.")
    ap.add_argument("--version", action="version", version=f"auralize {__version__}")
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("info", help="describe a volume (grid, times, fields)")
    add_volume_options(p)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_info)

    from auralize.datasets.shipped import describe as describe_datasets

    p = sub.add_parser(
        "dataset",
        help="write a dataset that comes with auralize to a file (.h5, .pvd, ...)",
        description="Write a generated dataset, or a shipped real one, to a "
        "file. Every command also opens them as dataset:NAME.",
    )
    p.add_argument(
        "name", help=f"{describe_datasets()}; plugins add generated ones (auralize plugins)"
    )
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--size", type=positive_int)
    p.add_argument("--steps", type=positive_int)
    p.add_argument("--seed", type=seed_int, default=0)
    p.set_defaults(func=cmd_dataset)

    p = sub.add_parser("detect", help="detect sources; write them to .h5, ParaView .pvd or .vtkhdf")
    add_volume_options(p)
    add_detect_options(p)
    p.add_argument(
        "-o",
        "--output",
        required=True,
        help="sources file: .h5/.hdf5, .pvd (ParaView) or .vtkhdf (ParaView, VTK)",
    )
    p.add_argument("--json", action="store_true", help="print per-step counts by type as JSON")
    p.set_defaults(func=cmd_detect)

    p = sub.add_parser("render", help="render the sound heard along a listener path")
    add_volume_options(p, optional=True)
    add_detect_options(p)
    add_output_options(p, listener_required=False)
    add_render_options(p)
    add_scene_options(p)
    add_outdoor_options(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("path", help="build a listener path CSV")
    psub = p.add_subparsers(dest="kind", required=True)
    q = psub.add_parser("point", help="static listener")
    q.add_argument("--at", type=_vec3, required=True, metavar="X,Y,Z")
    q = psub.add_parser(
        "line", help="straight line at constant speed (default: a fly-by past the data)"
    )
    q.add_argument("--start", type=_vec3, metavar="X,Y,Z")
    q.add_argument("--end", type=_vec3, metavar="X,Y,Z")
    q.add_argument("--captures", type=_captures, default=2, help="captures (>= 2)")
    q.add_argument("--face", choices=["forward", "fixed"], default="forward")
    q = psub.add_parser(
        "orbit",
        help="horizontal circle around a centre, facing it (default: "
        "around the data, two half-diagonals out)",
    )
    q.add_argument("--center", type=_vec3, metavar="X,Y,Z")
    q.add_argument("--radius", type=positive_float)
    q.add_argument(
        "--turns",
        type=finite_float,
        help="default 1, or around a volume: at most what keeps the listener below "
        "0.1 c0 in data time at the automatic time scale",
    )
    q.add_argument("--height", type=finite_float, default=0.0)
    q.add_argument("--rate-hz", type=positive_float, default=10.0, help="captures per second")
    for q in psub.choices.values():
        q.add_argument(
            "volume_pos",
            nargs="?",
            metavar="VOLUME",
            help="place the path around this volume's bounds (file or dataset:NAME)",
        )
        q.add_argument("--volume", metavar="FILE", help="same as the positional VOLUME")
        q.add_argument("--size", type=positive_int, help="grid size of a built-in dataset")
        q.add_argument("--steps", type=positive_int, help="time steps of a built-in dataset")
        q.add_argument("--seed", type=seed_int, default=0, help="seed of a built-in dataset")
        q.add_argument("--duration", type=positive_float, help="seconds (default 10)")
        q.add_argument("-o", "--output", required=True)
    p.set_defaults(func=cmd_path)

    p = sub.add_parser("plugins", help="list registered sound models")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_plugins)

    p = sub.add_parser("demo", help="explosion dataset -> 8-channel WAV, screenshot, spectrogram")
    p.add_argument("-o", "--output", default="demo", help="output folder (default ./demo)")
    p.add_argument("--size", type=positive_int, default=64)
    p.add_argument("--seed", type=seed_int, default=0)
    p.add_argument("--layout", default="ring8")
    p.add_argument(
        "--time-scale", type=positive_float, default=3.0, help="playback seconds per data second"
    )
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("bench", help="timings side by side with the papers' tables")
    p.add_argument("--quick", action="store_true", help="small sizes only (seconds)")
    p.add_argument(
        "--sizes", type=_sizes, help="comma-separated grid sizes for detection (default 10..256)"
    )
    p.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    p.add_argument(
        "--only",
        metavar="GROUPS",
        type=_bench_groups,
        help="run only these comma-separated groups: detection, synthesis, timbre, scaling, "
        "emitters, compile, immersive, readers, efficiency, fwh, outdoor, output, viewer, dask, "
        "plugins",
    )
    p.add_argument(
        "--dask-full",
        action="store_true",
        help="Dask rows on the 256³ x 100-step file (writes ~27 GB to the temp folder)",
    )
    p.add_argument(
        "--readers-full",
        action="store_true",
        help="reader rows on 128³ x 30-step series (~1 GB per format in the temp folder)",
    )
    p.set_defaults(func=cmd_bench)

    _extend_with_core_modules(sub)
    _extend_with_plugins(sub)
    _add_verbosity_flags(ap)
    return ap


def _add_verbosity_flags(parser: argparse.ArgumentParser, *, top: bool = True) -> None:
    """``-q/--quiet`` and ``-v/--verbose`` before or after any (sub-)command."""
    # below the top level the flags do not reset what an earlier position set
    kw: dict[str, Any] = {} if top else {"default": argparse.SUPPRESS}
    g = parser.add_argument_group("output") if top else parser
    g.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        help="errors only: no warnings, notices or progress bars",
        **kw,
    )
    g.add_argument(
        "-v",
        "--verbose",
        action="count",
        help="also debug messages",
        **({"default": 0} if top else kw),
    )
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for p in dict.fromkeys(action.choices.values()):
                _add_verbosity_flags(p, top=False)


#: core modules that add their own sub-commands with ``add_commands(subparsers)``
CORE_COMMAND_MODULES = (
    "auralize.cli.audio",
    "auralize.cli.view",
    "auralize.cli.distributed",
    "auralize.cli.warmup",
    "auralize.cli.convert",
    "auralize.cli.spectrum",
    "auralize.cli.describe",
    "auralize.cli.regress",
)


def _extend_with_core_modules(sub: Any) -> None:
    import importlib

    for modname in CORE_COMMAND_MODULES:
        try:
            mod = importlib.import_module(modname)
        except ModuleNotFoundError as exc:
            if exc.name is None or not modname.startswith(
                exc.name
            ):  # a missing dependency inside is real
                raise
            continue
        mod.add_commands(sub)


def _extend_with_plugins(sub: Any) -> None:
    """Let plugins add their own sub-commands (see :mod:`auralize.cli.plugin_commands`)."""
    from auralize.cli.plugin_commands import add_plugin_commands

    add_plugin_commands(sub)


def exit_code(exc: BaseException) -> int:
    """The exit status for an error (see :data:`EXIT_CODES`)."""
    if isinstance(exc, ParameterError):
        return EXIT_USAGE
    if isinstance(exc, DataError | FormatError | FieldError | ListenerPathError | MissingFileError):
        return EXIT_DATA
    if isinstance(
        exc,
        OutputError
        | ResourceError
        | DeviceError
        | MissingDependencyError
        | PluginError
        | OSError
        | MemoryError,
    ):
        return EXIT_SYSTEM
    if isinstance(exc, AuralizeError):
        return EXIT_USAGE
    return EXIT_INTERNAL


def error_message(
    exc: BaseException, output: str | os.PathLike[str] | None = None
) -> tuple[str, int]:
    """One line describing ``exc`` for the terminal, and the exit status.

    ``output`` is the command's output file, named when an OS error of a write
    does not say which file (a full disk).  The conversions that are not the
    CLI's own are shared with the API, so both say the same:
    :func:`auralize.runtime.files.output_error` (a failed write) and
    :func:`auralize.runtime.resources.memory_error` (a failed allocation).
    """
    from auralize.runtime.files import is_disk_full, output_error, raised_in_hdf5
    from auralize.runtime.resources import memory_error

    if isinstance(exc, AuralizeError):
        return " ".join(str(exc).split()), exit_code(exc)
    if isinstance(exc, MemoryError):
        return " ".join(str(memory_error(exc, "")).split()), EXIT_SYSTEM
    if isinstance(exc, OSError | RuntimeError) and is_disk_full(exc):
        target = output or getattr(exc, "filename", None) or "the output"
        return " ".join(str(output_error(exc, target)).split()), EXIT_SYSTEM
    if isinstance(exc, OSError):
        what = exc.strerror or str(exc) or type(exc).__name__
        where = " ".join(repr(str(f)) for f in (exc.filename, exc.filename2) if f)
        text = f"{where}: {what}" if where else what
        text = " ".join(text.split())
        if raised_in_hdf5(exc):
            return f"cannot read HDF5 data: {text}", EXIT_DATA
        return text, EXIT_SYSTEM
    if raised_in_hdf5(exc):
        return (
            f"cannot read HDF5 data ({type(exc).__name__}: {' '.join(str(exc).split())})",
            EXIT_DATA,
        )
    return (
        f"internal error: {type(exc).__name__}: {' '.join(str(exc).split())} (this is a bug; "
        f"run with AURALIZE_DEBUG=1 to see the traceback)",
        EXIT_INTERNAL,
    )


#: the options whose values may name a command's input files
INPUT_OPTIONS = (
    "volume",
    "volume_pos",
    "input",
    "sources",
    "path",
    "scene",
    "texture",
    "discharge",
    "layout",
    "hrtf",
    "file",
)


def _inputs(args: argparse.Namespace) -> list[Path]:
    """The existing files and folders a command reads (its positional input, sources,
    path, scene, model inputs ...)."""
    out: list[Path] = []
    for name in INPUT_OPTIONS:
        v = getattr(args, name, None)
        if isinstance(v, str | Path) and str(v) and not str(v).startswith("dataset:"):
            out.append(Path(v).expanduser())
    for spec in getattr(args, "model", None) or []:
        from auralize.scene.soundscene import parse_model_spec

        try:
            src = parse_model_spec(spec).input
        except Exception:  # a bad spec is reported by the command itself
            continue
        if isinstance(src, str | Path) and not str(src).startswith("dataset:"):
            out.append(Path(src).expanduser())
    return [p for p in out if p.exists()]


def check_not_input(out: str | Path, inputs: Sequence[str | Path]) -> None:
    """Refuse an output that is one of the inputs (by resolved path and by inode: a
    link to it too), would be written into an input folder's place, or whose own
    folder of pieces (``.pvd``: ``NAME_data/``) holds an input."""
    o = Path(out).expanduser()
    targets = [o, Path(str(o) + ".json")]
    if o.suffix.lower() == ".pvd":
        targets.append(o.with_name(o.stem + "_data"))
    for src in inputs:
        s = Path(src).expanduser()
        for t in targets:
            same = t.resolve() == s.resolve()
            if not same and t.exists():
                try:
                    same = os.path.samefile(t, s)
                except OSError:
                    same = False
            inside = t.is_dir() or (t.suffix == "" and t.name.endswith("_data"))
            if same and t == o:
                raise ParameterError(
                    f"{o}: it is the same file as the input {str(s)!r}; writing it would "
                    f"replace the input; name another output"
                )
            if same or (inside and s.resolve().is_relative_to(t.resolve())):
                raise ParameterError(
                    f"{o}: writing it would replace the input {str(s)!r}; name another output"
                )


def _check_outputs(args: argparse.Namespace) -> None:
    """Refuse an output path that cannot be written before any slow work (a missing
    folder, no permission, an output that would replace an input, a sidecar that
    auralize did not write)."""
    from auralize.runtime.files import check_output_path

    out = getattr(args, "output", None)
    if isinstance(out, str | Path) and str(out) != "-":
        check_output_path(out, folder=getattr(args, "command", None) == "demo")
        check_not_input(out, _inputs(args))
        suffix = Path(out).suffix.lower()
        if hasattr(args, "normalize") and suffix not in (".wav", ".flac"):
            raise ParameterError(f"{out}: audio output must end in .wav or .flac")
        if suffix in (".wav", ".flac"):
            from auralize.audio.output import check_sidecar_target

            check_sidecar_target(Path(str(out) + ".json"))
    if getattr(args, "hrtf", None):
        from auralize.spatial.layouts import get_layout, is_binaural
        from auralize.spatial.sofa import read_sofa

        if not is_binaural(get_layout(getattr(args, "layout", "mono"))):
            raise ParameterError(
                f"--hrtf {args.hrtf}: HRTFs apply to --layout binaural only, "
                f"not {getattr(args, 'layout', 'mono')!r}"
            )
        args.hrtf = read_sofa(args.hrtf)  # a bad file fails before any slow work


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``auralize`` command; return the exit status (see :data:`EXIT_CODES`)."""
    from auralize.audio.output import SilentAudioWarning, running_command

    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    name = f"auralize {getattr(args, 'command', '')}".strip()
    from auralize.cli.console import setup_console

    restore_console = setup_console(quiet=args.quiet, verbose=args.verbose)
    # --allow-external holds for this command only; the setting before it (the
    # caller's, or AURALIZE_HDF5_EXTERNAL's) is put back after (h5py is not
    # imported for commands that read no HDF5)
    hdf5 = sys.modules.get("auralize.io.hdf5")
    external_before = hdf5.external_data_allowed() if hdf5 is not None else None
    try:
        if getattr(args, "allow_external", False):
            from auralize.io.hdf5 import allow_external_data

            allow_external_data(True)
        _check_outputs(args)
        with warnings.catch_warnings(record=True) as caught:
            # every warning is collected and shown as one line after the command (a
            # warning never aborts a command, whatever the process-wide filters say)
            warnings.simplefilter("always")
            warnings.simplefilter("ignore", DeprecationWarning)
            warnings.simplefilter("ignore", PendingDeprecationWarning)
            from auralize.spatial.layouts import default_hrtf

            # every renderer's binaural stage; every sidecar's "command"
            with default_hrtf(getattr(args, "hrtf", None)), running_command(argv):
                status = int(args.func(args) or 0)
        for w in caught:
            if issubclass(w.category, SilentAudioWarning):
                print(f"{name}: warning: {' '.join(str(w.message).split())}", file=sys.stderr)
                status = status or EXIT_SILENT
            else:
                warnings.showwarning(w.message, w.category, w.filename, w.lineno)
        return status
    except KeyboardInterrupt:
        print(f"{name}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # the reader of our output went away (``auralize plugins | head -1``): it had
        # what it wanted; end quietly, and keep Python's exit-time flush quiet too
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except Exception as exc:
        if os.environ.get("AURALIZE_DEBUG"):
            traceback.print_exc()
        out = getattr(args, "output", None)
        text, code = error_message(exc, out if isinstance(out, str | Path) and out else None)
        print(f"{name}: error: {text}", file=sys.stderr)
        return code
    finally:
        restore_console()
        hdf5 = sys.modules.get("auralize.io.hdf5")
        if hdf5 is not None:
            env = os.environ.get("AURALIZE_HDF5_EXTERNAL", "") == "1"
            hdf5.allow_external_data(env if external_before is None else external_before)


if __name__ == "__main__":
    sys.exit(main())
