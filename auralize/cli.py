"""The ``auralize`` command.

Every command that writes audio takes the same output options: ``-o``,
``--layout``, ``--rate``, ``--normalize``, ``--limit`` and either
``--listener x,y,z --duration S`` or ``--path CSV``.  Volumes are files or
built-in datasets written ``dataset:NAME`` (e.g. ``dataset:explosion``).
Errors print one line naming what is wrong and exit with status 2.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from auralize.errors import AuralizeError, ParameterError

EXIT_USAGE = 2


# ----------------------------------------------------------------- helpers
def _vec3(text: str) -> np.ndarray:
    try:
        v = np.array([float(x) for x in text.split(",")])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected x,y,z numbers, got {text!r}") from None
    if v.size != 3 or not np.all(np.isfinite(v)):
        raise argparse.ArgumentTypeError(f"expected three finite numbers x,y,z, got {text!r}")
    return v


def _field_map(items: list[str] | None) -> dict[str, str] | None:
    if not items:
        return None
    out = {}
    for it in items:
        if "=" not in it:
            raise ParameterError(f"--field takes NAME=/hdf5/path, got {it!r}")
        k, v = it.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def add_volume_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("volume", metavar="PATH", help="volume file, or dataset:NAME for a built-in one")
    g = p.add_argument_group("volume")
    g.add_argument(
        "--field",
        action="append",
        metavar="NAME=/DATASET",
        help="read a generic HDF5 file by naming datasets (repeatable)",
    )
    g.add_argument(
        "--resolution", type=int, help="points per axis when resampling non-uniform grids"
    )
    g.add_argument(
        "--nan",
        choices=["mask", "error"],
        default="mask",
        help="NaN, fill values and masked cells: mask = no-data (default), error = refuse",
    )
    g.add_argument("--size", type=int, help="grid size of a built-in dataset")
    g.add_argument("--steps", type=int, help="time steps of a built-in dataset")
    g.add_argument("--seed", type=int, default=0, help="seed of a built-in dataset")


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
            help=f"{kind} threshold: absolute value, 'N%%' of the peak, or auto (3%%, 0.3%%, 0.1%%)",
        )
    g.add_argument(
        "--zero-fraction",
        type=float,
        default=1.0,
        help="'almost zero' = below this fraction of the other types' thresholds",
    )


def add_output_options(
    p: argparse.ArgumentParser, *, layouts: str = "mono|stereo|ring8|5.1|7.1|FILE.json"
) -> None:
    g = p.add_argument_group("audio output")
    g.add_argument("-o", "--output", required=True, help="output .wav or .flac")
    g.add_argument("--layout", default="mono", help=layouts)
    g.add_argument("--rate", type=int, default=44100, help="sample rate in Hz (default 44100)")
    g.add_argument(
        "--normalize",
        choices=["peak", "none"],
        default="peak",
        help="peak: loudest sample at 0.99; none: physical pascals (float WAV)",
    )
    g.add_argument(
        "--limit",
        type=float,
        metavar="PA",
        help="truncate pressures beyond this many pascals (paper 000 §7)",
    )
    src = g.add_mutually_exclusive_group(required=True)
    src.add_argument(
        "--path", metavar="CSV", help="listener path CSV (t,x,y,z[,fx,fy,fz,ux,uy,uz])"
    )
    src.add_argument("--listener", type=_vec3, metavar="X,Y,Z", help="static listener position")
    g.add_argument("--duration", type=float, help="seconds to render (with --listener)")


def add_render_options(p: argparse.ArgumentParser) -> None:
    """Synthesis options shared by ``render`` and its Dask variant."""
    p.add_argument("--time-scale", type=float, default=1.0, help="playback seconds per data second")
    p.add_argument("--interp", choices=["linear", "cubic"], default="cubic")
    p.add_argument("--sources", metavar="SOURCES.h5", help="reuse sources from 'auralize detect'")


def listener_from_args(args: argparse.Namespace) -> Any:
    from auralize.listener import ListenerPath

    if args.path:
        return ListenerPath.from_csv(args.path)
    if args.duration is None:
        raise ParameterError("--listener needs --duration S (seconds to render)")
    return ListenerPath.point(args.listener, duration=args.duration)


def _load(args: argparse.Namespace) -> Any:
    from auralize.pipeline import load

    return load(args.volume, size=args.size, steps=args.steps, seed=args.seed,
                fields=_field_map(args.field), resolution=args.resolution,
                nan=getattr(args, "nan", "mask"))  # fmt: skip


def _thresholds(args: argparse.Namespace) -> Any:
    from auralize.sources import Thresholds

    return Thresholds(args.threshold_monopole, args.threshold_dipole, args.threshold_quadrupole,
                      zero_fraction=args.zero_fraction)  # fmt: skip


def _mapping_fields(args: argparse.Namespace) -> dict[str, Any]:
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
    """Say once, on stderr, which source types could not be computed and why."""
    by_reason: dict[str, list[str]] = {}
    for kind, why in (series.meta.get("unavailable") or {}).items():
        by_reason.setdefault(str(why), []).append(kind)
    for why, kinds in by_reason.items():
        print(f"auralize {command}: note: no {' or '.join(kinds)} sources: {why}", file=sys.stderr)


def _progress_wanted() -> bool:
    return sys.stderr.isatty()


# ----------------------------------------------------------------- commands
def cmd_info(args: argparse.Namespace) -> int:
    from auralize.mapping import ROLE_NAMES, match_field
    from auralize.pipeline import auto_mapping

    vol = _load(args)
    d = vol.describe()
    units = vol.attrs.get("units") if isinstance(vol.attrs.get("units"), dict) else {}
    centring = vol.attrs.get("centring") if isinstance(vol.attrs.get("centring"), dict) else {}
    roles = {r: match_field(vol, r) for r in ROLE_NAMES}
    d["times"] = vol.times.tolist()
    d["field_info"] = {
        k: {"kind": d["fields"][k], "units": units.get(k), "centring": centring.get(k, "point")}
        for k in vol.field_names
    }
    d["roles"] = {r: f for r, f in roles.items() if f is not None}
    d["mapping"] = auto_mapping(vol)
    for key in ("time_units", "grid_units", "mesh"):
        if key in vol.attrs:
            d[key] = vol.attrs[key]
    if args.json:
        print(json.dumps(d, indent=2, default=str))
        return 0
    print(f"{d['source']}")
    if "mesh" in vol.attrs:
        print(f"  mesh     {vol.attrs['mesh']}")
    print(f"  grid     {vol.dims[0]} x {vol.dims[1]} x {vol.dims[2]} points, spacing "
          f"{', '.join(f'{s:g}' for s in vol.spacing)} m, origin {', '.join(f'{o:g}' for o in vol.origin)} m")  # fmt: skip
    b = vol.bounds
    print(f"  bounds   x[{b[0]:g}, {b[1]:g}] y[{b[2]:g}, {b[3]:g}] z[{b[4]:g}, {b[5]:g}] m")
    print(f"  valid    {100.0 * vol.valid_ratio:.1f} % of the grid points lie inside the mesh")
    tnote = "" if vol.physical_times else " (no physical times: frames at 30 Hz)"
    print(f"  times    {vol.n_steps} steps, {vol.times[0]:g} .. {vol.times[-1]:g} s{tnote}")
    shown = ", ".join(f"{t:g}" for t in vol.times[:8]) + (" ..." if vol.n_steps > 8 else "")
    print(f"           t = {shown} s"
          + (f" ({vol.attrs['time_units']} in the file)" if "time_units" in vol.attrs else ""))  # fmt: skip
    for name, info in d["field_info"].items():
        unit = f", {info['units']}" if info["units"] else ""
        print(f"  field    {name} ({info['kind']}, {info['centring']} data{unit})")
    role_text = ", ".join(f"{r}={f}" for r, f in d["roles"].items()) or "none recognised"
    print(f"  roles    {role_text}; default mapping {d['mapping']}")
    return 0


def cmd_dataset(args: argparse.Namespace) -> int:
    from auralize.datasets import make_dataset
    from auralize.io import save_volume

    vol = make_dataset(args.name, size=args.size, steps=args.steps, seed=args.seed)
    t = time.perf_counter()
    save_volume(vol, args.output)
    print(f"wrote {args.output}: {args.name}, {vol.dims[0]}x{vol.dims[1]}x{vol.dims[2]} x "
          f"{vol.n_steps} steps, fields {', '.join(vol.field_names)} "
          f"({time.perf_counter() - t:.1f} s)")  # fmt: skip
    return 0


def cmd_detect(args: argparse.Namespace) -> int:
    from auralize.io.sources_file import save_sources_h5, save_sources_pvd
    from auralize.pipeline import detect_sources
    from auralize.volume import tally_nonfinite

    vol, tally = tally_nonfinite(_load(args))
    t = time.perf_counter()
    series = detect_sources(vol, mapping=args.mapping, thresholds=_thresholds(args),
                            progress_bar=_progress_wanted(), **_mapping_fields(args))  # fmt: skip
    elapsed = time.perf_counter() - t
    series.meta["masked_fraction"] = tally.fraction
    _report_unavailable("detect", series)
    out = Path(args.output)
    if out.suffix.lower() == ".pvd":
        save_sources_pvd(series, out)
    elif out.suffix.lower() in (".h5", ".hdf5"):
        save_sources_h5(series, out)
    else:
        raise ParameterError(f"{out}: sources output must end in .h5/.hdf5 or .pvd")
    counts = series.counts()
    if args.json:
        print(json.dumps({
            "output": str(out), "thresholds": series.thresholds.tolist(),
            "mapping": series.meta.get("mapping"),
            "valid_ratio": series.meta.get("valid_ratio"),
            "masked_fraction": series.meta.get("masked_fraction"),
            "unavailable": series.meta.get("unavailable", {}),
            "steps": [{"step": n, "time": float(series.times[n]), **c} for n, c in enumerate(counts)],
            "seconds": elapsed,
        }, indent=2))  # fmt: skip
    else:
        tot = {k: sum(c[k] for c in counts) for k in ("monopole", "dipole", "quadrupole")}
        print(f"wrote {out}: {series.n_steps} steps in {elapsed:.2f} s; source points over all "
              f"steps: {tot['monopole']} monopole, {tot['dipole']} dipole, {tot['quadrupole']} "
              f"quadrupole (thresholds {', '.join(f'{x:.4g}' for x in series.thresholds)}); "
              f"valid points {100.0 * vol.valid_ratio:.1f} %, masked (NaN) "
              f"{100.0 * tally.fraction:.2f} %")  # fmt: skip
    return 0


def cmd_render(args: argparse.Namespace) -> int:
    from auralize.pipeline import auralize, save_rendered

    vol = _load(args)
    path = listener_from_args(args)
    series = None
    if args.sources:
        from auralize.io.sources_file import load_sources_for

        series = load_sources_for(args.sources, vol)
    t = time.perf_counter()
    out, series = auralize(vol, path, mapping=args.mapping, thresholds=_thresholds(args),
                           rate=args.rate, time_scale=args.time_scale, interp=args.interp,
                           layout=args.layout, duration=args.duration if args.path is None else None,
                           series=series, progress_bar=_progress_wanted(), **_mapping_fields(args))  # fmt: skip
    elapsed = time.perf_counter() - t
    _report_unavailable("render", series)
    gain = save_rendered(out, args.output, normalize=args.normalize, limit_pa=args.limit,
                         extra={"command": "auralize " + " ".join(sys.argv[1:])})  # fmt: skip
    peak = float(np.max(np.abs(out.audio))) if out.audio.size else 0.0
    print(f"wrote {args.output}: {out.layout.name}, {out.audio.shape[0]} ch, {out.duration:.2f} s "
          f"at {out.rate} Hz, peak {peak:.4g} Pa, gain {gain:.4g}; {series.tracks().n_sources} "
          f"source points; {elapsed:.2f} s")  # fmt: skip
    return 0


def cmd_path(args: argparse.Namespace) -> int:
    from auralize.listener import ListenerPath

    if args.kind == "point":
        p = ListenerPath.point(args.at, duration=args.duration)
    elif args.kind == "line":
        p = ListenerPath.line(args.start, args.end, duration=args.duration, n=args.captures,
                              face=args.face)  # fmt: skip
    else:
        p = ListenerPath.orbit(args.center, radius=args.radius, duration=args.duration,
                               turns=args.turns, height=args.height, rate_hz=args.rate_hz)  # fmt: skip
    p.to_csv(args.output)
    print(f"wrote {args.output}: {args.kind}, {p.n_captures} captures over {p.duration:g} s")
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
    from auralize.datasets import make_dataset
    from auralize.listener import ListenerPath
    from auralize.pipeline import auralize, save_rendered
    from auralize.plots import save_spectrogram
    from auralize.scene import screenshot

    out_dir = Path(args.output)
    out_dir.mkdir(parents=True, exist_ok=True)
    t = time.perf_counter()
    print(f"generating dataset:explosion ({args.size}³ x 30 steps) ...", flush=True)
    vol = make_dataset("explosion", size=args.size, seed=args.seed).load()
    c = vol.center
    radius = 0.3 * float(vol.bounds[1] - vol.bounds[0])
    duration = float(vol.times[-1] - vol.times[0] + 1 / 30) * args.time_scale
    path = ListenerPath.orbit(c, radius=radius, duration=duration, turns=0.25, height=2.0)
    path.to_csv(out_dir / "explosion_path.csv")
    print("detecting sources and rendering ...", flush=True)
    rendered, series = auralize(vol, path, layout=args.layout, time_scale=args.time_scale,
                                progress_bar=_progress_wanted())  # fmt: skip
    wav = out_dir / f"explosion_{args.layout}.wav"
    save_rendered(rendered, wav, extra={"command": "auralize " + " ".join(sys.argv[1:])})
    png = screenshot(vol, out_dir / "explosion.png", series=series, path=path,
                     step=vol.n_steps // 3)  # fmt: skip
    spec = save_spectrogram(rendered.audio, rendered.rate, out_dir / "explosion_spectrogram.png",
                            channel_names=rendered.layout.channel_names)  # fmt: skip
    counts = series.counts()
    tot = {k: sum(c[k] for c in counts) for k in ("monopole", "dipole", "quadrupole")}
    print(f"wrote {wav} ({rendered.layout.n_channels} channels, {rendered.duration:.2f} s), "
          f"{png}, {spec}")  # fmt: skip
    print(f"sources over {vol.n_steps} steps: {tot['monopole']} monopole, {tot['dipole']} dipole, "
          f"{tot['quadrupole']} quadrupole; {time.perf_counter() - t:.1f} s in all")  # fmt: skip
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from auralize.bench import run_bench

    return run_bench(args)


# ----------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="auralize", description="Hear 3-D time-varying data.")
    ap.add_argument("--version", action="version", version="auralize 0.1.0")
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("info", help="describe a volume (grid, times, fields)")
    add_volume_options(p)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("dataset", help="generate a built-in dataset to a file (.h5 or .pvd)")
    p.add_argument("name", help="explosion | monopole")
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--size", type=int)
    p.add_argument("--steps", type=int)
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=cmd_dataset)

    p = sub.add_parser("detect", help="detect sources; write them to .h5 or ParaView .pvd")
    add_volume_options(p)
    add_detect_options(p)
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--json", action="store_true", help="print per-step counts by type as JSON")
    p.set_defaults(func=cmd_detect)

    p = sub.add_parser("render", help="render the sound heard along a listener path")
    add_volume_options(p)
    add_detect_options(p)
    add_output_options(p)
    add_render_options(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("path", help="build a listener path CSV")
    psub = p.add_subparsers(dest="kind", required=True)
    q = psub.add_parser("point", help="static listener")
    q.add_argument("--at", type=_vec3, required=True, metavar="X,Y,Z")
    q = psub.add_parser("line", help="straight line at constant speed")
    q.add_argument("--start", type=_vec3, required=True, metavar="X,Y,Z")
    q.add_argument("--end", type=_vec3, required=True, metavar="X,Y,Z")
    q.add_argument("--captures", type=int, default=2)
    q.add_argument("--face", choices=["forward", "fixed"], default="forward")
    q = psub.add_parser("orbit", help="horizontal circle around a centre, facing it")
    q.add_argument("--center", type=_vec3, required=True, metavar="X,Y,Z")
    q.add_argument("--radius", type=float, required=True)
    q.add_argument("--turns", type=float, default=1.0)
    q.add_argument("--height", type=float, default=0.0)
    q.add_argument("--rate-hz", type=float, default=10.0, help="captures per second")
    for q in psub.choices.values():
        q.add_argument("--duration", type=float, required=True, help="seconds")
        q.add_argument("-o", "--output", required=True)
    p.set_defaults(func=cmd_path)

    p = sub.add_parser("plugins", help="list registered sound models")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_plugins)

    p = sub.add_parser("demo", help="explosion dataset -> 8-channel WAV, screenshot, spectrogram")
    p.add_argument("-o", "--output", default="demo", help="output folder (default ./demo)")
    p.add_argument("--size", type=int, default=64)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--layout", default="ring8")
    p.add_argument("--time-scale", type=float, default=3.0, help="playback seconds per data second")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("bench", help="timings side by side with the papers' tables")
    p.add_argument("--quick", action="store_true", help="small sizes only (seconds)")
    p.add_argument("--sizes", help="comma-separated grid sizes for detection (default 10..256)")
    p.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
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
    return ap


#: core modules that add their own sub-commands with ``add_commands(subparsers)``
CORE_COMMAND_MODULES = ("auralize.cli_audio", "auralize.viewer.cli", "auralize.cli_dask")


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
    """Let plugins add their own sub-commands (``cli(subparsers)`` hook)."""
    from auralize.plugins import registry

    for _name, cls in registry().items():
        hook: Callable[[Any], None] | None = getattr(cls, "add_cli", None)
        if hook is not None:
            hook(sub)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except AuralizeError as exc:
        print(f"auralize {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"auralize {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
