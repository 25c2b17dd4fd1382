"""``auralize convert IN OUT``: a volume (or a sources file) from one format to another.

Volumes: every format :func:`auralize.io.open_volume` reads (HDF5 v1, generic
HDF5 with ``--field``, ``.pvd``/``.series``, VTK meshes, VTKHDF, OpenFOAM) or
a built-in ``dataset:NAME``, to every format :func:`auralize.io.save_volume`
writes (``.h5``/``.hdf5``, ``.pvd``, ``.vtkhdf``).  Sources written by
``auralize detect`` (``.h5``) convert to ``.pvd`` or ``.vtkhdf`` (and ``.h5``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from auralize.errors import FormatError, ParameterError

SOURCES_SUFFIXES = (".h5", ".hdf5", ".pvd", ".vtkhdf")


def _is_sources_file(path: Path) -> bool:
    if path.suffix.lower() not in (".h5", ".hdf5") or not path.is_file():
        return False
    import h5py

    try:
        with h5py.File(path, "r") as h:
            return bool(h.attrs.get("auralize_format") == "sources")
    except OSError:
        return False


def convert_sources(src: Path, out: Path) -> str:
    """Write the sources file ``src`` as ``out`` (by suffix); return a summary."""
    from auralize.io.vtkhdf_write import write_sources_vtkhdf
    from auralize.sources.sources_file import load_sources_h5, save_sources_h5, save_sources_pvd

    suffix = out.suffix.lower()
    if suffix not in SOURCES_SUFFIXES:
        raise FormatError(
            f"{out}: sources convert to {', '.join(SOURCES_SUFFIXES)}, "
            f"not {suffix or '(no suffix)'!r}"
        )
    series = load_sources_h5(src)
    if suffix == ".pvd":
        save_sources_pvd(series, out)
    elif suffix == ".vtkhdf":
        write_sources_vtkhdf(series, out)
    else:
        save_sources_h5(series, out)
    n = sum(f.index.size for f in series.frames)
    return f"sources, {series.n_steps} steps, {n} source points"


def cmd_convert(args: argparse.Namespace) -> int:
    from auralize.cli.options import field_map
    from auralize.io import WRITE_SUFFIXES, save_volume
    from auralize.pipeline import load

    src, out = str(args.input), Path(args.output).expanduser()
    if not src.startswith("dataset:") and Path(src).expanduser().resolve() == out.resolve():
        raise ParameterError(f"{out}: input and output are the same file; name another output")
    t = time.perf_counter()
    if not src.startswith("dataset:") and _is_sources_file(Path(src).expanduser()):
        what = convert_sources(Path(src).expanduser(), out)
    else:
        if out.suffix.lower() not in WRITE_SUFFIXES:
            raise ParameterError(
                f"{out}: cannot write {out.suffix or '(no suffix)'!r}; volumes "
                f"convert to {', '.join(WRITE_SUFFIXES)}"
            )
        from auralize.io.options import curvilinear_mode

        with curvilinear_mode("resample" if getattr(args, "resample", False) else "native"):
            vol = load(
                src,
                size=args.size,
                steps=args.steps,
                seed=args.seed,
                fields=field_map(args.field),
                resolution=args.resolution,
                time_dim=args.time_dim,
                axis_scale=args.axis_scale,
                box=args.box,
            )
        save_volume(vol, out, compression=args.compression)
        nx, ny, nz = vol.dims
        what = f"volume {nx}x{ny}x{nz} x {vol.n_steps} steps, fields {', '.join(vol.field_names)}"
    print(f"wrote {out}: {what} ({time.perf_counter() - t:.1f} s)")
    return 0


def add_commands(sub: Any) -> None:
    from auralize.cli.options import add_reader_options

    p = sub.add_parser(
        "convert",
        help="convert a volume (or a sources file) between formats, e.g. .pvd -> .vtkhdf",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
    )
    p.add_argument("input", metavar="IN", help="volume file, dataset:NAME, or sources .h5")
    p.add_argument("output", metavar="OUT", help="output: .h5/.hdf5, .pvd or .vtkhdf")
    p.add_argument(
        "--field",
        action="append",
        metavar="NAME=/DATASET",
        help="read a generic HDF5 file by naming datasets (repeatable)",
    )
    p.add_argument(
        "--resolution", type=int, help="points per axis when resampling non-uniform grids"
    )
    add_reader_options(p)
    p.add_argument("--size", type=int, help="grid size of a built-in dataset")
    p.add_argument("--steps", type=int, help="time steps of a built-in dataset")
    p.add_argument("--seed", type=int, default=0, help="seed of a built-in dataset")
    p.add_argument("--compression", choices=["gzip"], help="compress .h5/.pvd output")
    p.set_defaults(func=cmd_convert)
