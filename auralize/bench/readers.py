"""``auralize bench`` rows of the readers: open and detect a series in each new format.

The same density + velocity series (a pulsating blob on an N³ grid, float32)
is written as auralize HDF5 (the reference), netCDF classic, netCDF4, XDMF
(``3DCoRectMesh`` + HDF5 heavy data), PLOT3D (grid + one ``.q`` per
step) and EnSight Gold (binary, one uniform block part); a structured
curvilinear series (an O-grid with a boundary layer, ``.vts`` files) is opened
and detected natively and resampled (:func:`bench_curvilinear`), and its
strengths are computed by the compiled metric divergence and by the numpy
reference (:func:`bench_curvilinear_strengths`).  Each is then opened and detected in a fresh child process, which
reports the opening time, the detection time and its peak resident memory
above the memory after imports (pyvista, VTK, h5py, scipy), compared with the
same detection on the HDF5 file, in steps' worth (one step of every field as
float64 frames).  Targets: opening under 2 s,
detection within 2× of the HDF5 file, peak memory within 2 steps.

The default size is 48³ × 12 steps (seconds); ``auralize bench
--readers-full`` runs 128³ × 30 steps (≈1 GB of float32 per format, written
once to ``$AURALIZE_BENCH_DIR`` or the temporary folder).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from auralize.plugins import BenchRow

#: (points per axis, steps) of the default and the full benchmark
QUICK_SIZE = (48, 12)
FULL_SIZE = (128, 30)


def _fields(n: int, step: int) -> tuple[np.ndarray, np.ndarray]:
    """Density (n, n, n) and velocity (3, n, n, n) of one step, float32."""
    ax = (np.arange(n, dtype=np.float32) - (n - 1) / 2) / n
    zz, yy, xx = np.meshgrid(ax, ax, ax, indexing="ij")
    g = np.exp(-(xx**2 + yy**2 + zz**2) / 0.02).astype(np.float32)
    a = np.float32(0.01 * np.sin(0.7 * step))
    rho = (1.2 + a * g).astype(np.float32)
    da = np.float32(0.007 * np.cos(0.7 * step))
    vel = np.stack([da * g * xx, da * g * yy, da * g * zz]).astype(np.float32)
    return rho, vel


def write_series(folder: Path, n: int, steps: int) -> dict[str, Path]:
    """Write the benchmark series in every format; returns ``{format: file to open}``."""
    import h5py
    from scipy.io import netcdf_file

    folder.mkdir(parents=True, exist_ok=True)
    h = 1.0 / (n - 1)
    coords = np.arange(n) * h
    out: dict[str, Path] = {}
    # auralize HDF5 (format v1)
    ref = folder / "series.h5"
    with h5py.File(ref, "w") as f:
        f.attrs["auralize_format"] = "volume"
        f.attrs["version"] = 1
        f["time"] = np.arange(steps) * 1e-3
        g = f.create_group("grid")
        g.attrs["origin"] = np.zeros(3)
        g.attrs["spacing"] = np.full(3, h)
        d = f.create_dataset("fields/density", (steps, n, n, n), "f4", chunks=(1, n, n, n))
        v = f.create_dataset("fields/velocity", (steps, n, n, n, 3), "f4", chunks=(1, n, n, n, 3))
        for s in range(steps):
            rho, vel = _fields(n, s)
            d[s] = rho
            v[s] = np.moveaxis(vel, 0, -1)
    out["hdf5"] = ref
    # netCDF classic (64-bit offsets) and netCDF4 (HDF5 with dimension scales)
    nc = folder / "series.nc"
    with netcdf_file(nc, "w", version=2) as f:
        f.createDimension("time", steps)
        for name in ("z", "y", "x"):
            f.createDimension(name, n)
            f.createVariable(name, "f8", (name,))[:] = coords
        t = f.createVariable("time", "f8", ("time",))
        t.units = "milliseconds since 2001-01-01"
        t[:] = np.arange(steps, dtype=np.float64)
        vs = {
            k: f.createVariable(k, "f4", ("time", "z", "y", "x"))
            for k in ("density", "u", "v", "w")
        }
        for s in range(steps):
            rho, vel = _fields(n, s)
            vs["density"][s] = rho
            for k, comp in zip(("u", "v", "w"), vel, strict=True):
                vs[k][s] = comp
    out["netcdf-classic"] = nc
    nc4 = folder / "series4.nc"
    with h5py.File(nc4, "w") as f:
        f.attrs["_NCProperties"] = "version=2"
        for name, vals in (
            ("time", np.arange(steps) * 1.0),
            ("z", coords),
            ("y", coords),
            ("x", coords),
        ):
            ds = f.create_dataset(name, data=vals)
            ds.make_scale(name)
        f["time"].attrs["units"] = "milliseconds since 2001-01-01"
        for k in ("density", "u", "v", "w"):
            ds = f.create_dataset(k, (steps, n, n, n), "f4", chunks=(1, n, n, n))
            for axis, dim in enumerate(("time", "z", "y", "x")):
                ds.dims[axis].attach_scale(f[dim])
        for s in range(steps):
            rho, vel = _fields(n, s)
            f["density"][s] = rho
            for k, comp in zip(("u", "v", "w"), vel, strict=True):
                f[k][s] = comp
    out["netcdf4"] = nc4
    # XDMF: a temporal collection of 3DCoRectMesh grids, heavy data in one HDF5 file
    heavy = folder / "xdmf_data.h5"
    grids = []
    with h5py.File(heavy, "w") as f:
        for s in range(steps):
            rho, vel = _fields(n, s)
            f[f"density/{s}"] = rho
            f[f"velocity/{s}"] = np.moveaxis(vel, 0, -1)
            grids.append(
                f'<Grid Name="s{s}" GridType="Uniform"><Time Value="{s * 1e-3!r}"/>'
                f'<Topology TopologyType="3DCoRectMesh" Dimensions="{n} {n} {n}"/>'
                f'<Geometry GeometryType="ORIGIN_DXDYDZ">'
                f'<DataItem Dimensions="3" Format="XML">0 0 0</DataItem>'
                f'<DataItem Dimensions="3" Format="XML">{h!r} {h!r} {h!r}</DataItem></Geometry>'
                f'<Attribute Name="density" AttributeType="Scalar" Center="Node">'
                f'<DataItem Dimensions="{n} {n} {n}" NumberType="Float" Precision="4" '
                f'Format="HDF">{heavy.name}:/density/{s}</DataItem></Attribute>'
                f'<Attribute Name="velocity" AttributeType="Vector" Center="Node">'
                f'<DataItem Dimensions="{n} {n} {n} 3" NumberType="Float" Precision="4" '
                f'Format="HDF">{heavy.name}:/velocity/{s}</DataItem></Attribute></Grid>'
            )
    xdmf = folder / "series.xdmf"
    xdmf.write_text(
        '<?xml version="1.0"?><Xdmf Version="2.0"><Domain>'
        '<Grid Name="series" GridType="Collection" CollectionType="Temporal">'
        + "".join(grids)
        + "</Grid></Domain></Xdmf>"
    )
    out["xdmf"] = xdmf
    # PLOT3D: big-endian single-grid binary, no record markers; one .q per step
    xyz = folder / "series.xyz"
    zz, yy, xx = np.meshgrid(coords, coords, coords, indexing="ij")
    with xyz.open("wb") as fh:
        np.array([n, n, n], ">i4").tofile(fh)
        for c in (xx, yy, zz):
            c.astype(">f4").tofile(fh)
    for s in range(steps):
        rho, vel = _fields(n, s)
        with (folder / f"series_{s:04d}.q").open("wb") as fh:
            np.array([n, n, n], ">i4").tofile(fh)
            np.array([0.0, 0.0, 1.0, s * 1e-3], ">f4").tofile(fh)
            rho.astype(">f4").tofile(fh)
            for comp in vel:
                (rho * comp).astype(">f4").tofile(fh)
            np.full(rho.shape, 2.5e5, ">f4").tofile(fh)
    out["plot3d"] = xyz

    # EnSight Gold binary: one "block uniform" part, per-node variables per step
    def s80(text: str) -> bytes:
        return text.encode().ljust(80, b"\0")

    with (folder / "series.geo").open("wb") as fh:
        for line in (
            "C Binary",
            "auralize bench",
            "uniform block",
            "node id off",
            "element id off",
            "part",
        ):
            fh.write(s80(line))
        fh.write(np.array([1], "<i4").tobytes() + s80("volume") + s80("block uniform"))
        fh.write(np.array([n, n, n], "<i4").tobytes())
        fh.write(np.array([0, 0, 0, h, h, h], "<f4").tobytes())
    for s in range(steps):
        rho, vel = _fields(n, s)
        for kind, data in (("density", [rho]), ("velocity", list(vel))):
            with (folder / f"series{s:04d}.{kind}").open("wb") as fh:
                fh.write(s80(kind) + s80("part") + np.array([1], "<i4").tobytes() + s80("block"))
                for comp in data:
                    fh.write(comp.astype("<f4").tobytes())
    case = folder / "series.case"
    case.write_text(
        "FORMAT\ntype: ensight gold\nGEOMETRY\nmodel: series.geo\nVARIABLE\n"
        "scalar per node: density series****.density\n"
        "vector per node: velocity series****.velocity\n"
        f"TIME\ntime set: 1\nnumber of steps: {steps}\nfilename start number: 0\n"
        "filename increment: 1\ntime values: "
        + " ".join(f"{s * 1e-3!r}" for s in range(steps))
        + "\n"
    )
    out["ensight"] = case
    return out


_CHILD = r"""
import json, resource, sys, time, warnings
warnings.simplefilter("ignore")
from auralize.io import open_volume
from auralize.pipeline import detect_sources
from auralize.sources.detection import Thresholds
import numpy as np
import pyvista  # libraries every format may load, imported before the baseline
import vtkmodules.all
import scipy.io, h5py
path, mapping, density, second = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
mode = sys.argv[5] if len(sys.argv) > 5 else None
def rss():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
base = rss()
t = time.perf_counter()
vol = open_volume(path, curvilinear=mode)
t_open = time.perf_counter() - t
kw = {"density": density, ("momentum" if mapping == "cfd" else "velocity"): second}
t = time.perf_counter()
series = detect_sources(vol, mapping=mapping, thresholds=Thresholds(1e-3, 1e-3, 1e-3), **kw)
t_detect = time.perf_counter() - t
step_bytes = sum(int(np.prod(f.frame_shape)) * 8 for f in vol.fields.values())
print(json.dumps({"open": t_open, "detect": t_detect, "peak": rss() - base,
                  "step_bytes": step_bytes, "steps": vol.n_steps,
                  "sources": int(sum(sum(c.values()) for c in series.counts())),
                  "points": vol.n_points, "valid": vol.valid_ratio,
                  "below": vol.attrs.get("resampling", {}).get("cells_below_voxel", 0.0)}))
"""

_ARGS = {
    "hdf5": ("identity", "density", "velocity"),
    "netcdf-classic": ("identity", "density", "velocity"),
    "netcdf4": ("identity", "density", "velocity"),
    "xdmf": ("identity", "density", "velocity"),
    "plot3d": ("cfd", "Density", "Momentum"),
    "ensight": ("identity", "density", "velocity"),
    "curvilinear": ("identity", "density", "velocity"),
}

#: (points around, across, along z; steps) of the O-grid series, default and full
CURVI_QUICK = (96, 40, 6, 8)
CURVI_FULL = (256, 96, 16, 20)


def ogrid_points(n_around: int, n_across: int, n_z: int) -> np.ndarray:
    """The O-grid of :func:`write_curvilinear_series`: points ``(n_z, n_around, n_across, 3)``
    (i across, from the wall out; j around; k along z)."""
    growth = np.geomspace(0.002, 0.25, n_across - 1)
    r = 0.5 + np.concatenate([[0.0], np.cumsum(growth)])
    r = 0.5 + (r - 0.5) * (2.5 / (r[-1] - 0.5))  # out to 3 m
    t = np.linspace(0.0, 2 * np.pi, n_around, endpoint=False)
    zz, tt, rr = np.meshgrid(np.linspace(0.0, 0.5, n_z), t, r, indexing="ij")
    return np.stack([rr * np.cos(tt), rr * np.sin(tt), zz], axis=-1)


def bench_curvilinear_strengths(full: bool = False) -> list[BenchRow]:
    """The dipole and quadrupole strengths of one step on the O-grid's points
    (:func:`auralize.curvilinear.curvilinear_strengths`: the metric divergences of
    ``∇·Δm`` and ``∂_j ∂_i T_ij``), compiled vs the numpy reference
    (``compiled=False``): CPU time per point-step on one thread, median of 7."""
    import time

    import numba

    from auralize.curvilinear import CurvilinearMetric, nominal_spacing

    na, nc, nz, _ = CURVI_FULL if full else CURVI_QUICK
    coords = ogrid_points(na, nc, nz)
    metric = CurvilinearMetric(coords, thickness=nominal_spacing(coords))
    rng = np.random.default_rng(0)
    dm, tt = rng.normal(size=(3, *metric.shape)), rng.normal(size=(6, *metric.shape))

    def strengths(compiled: bool) -> float:
        best = []
        for _ in range(8):  # the first compiles or warms up
            t0 = time.process_time()
            metric.divergence(dm, compiled=compiled)
            metric.quadrupole(tt, compiled=compiled)
            best.append(time.process_time() - t0)
        return float(np.median(best[1:])) / coords[..., 0].size

    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        fast, ref = strengths(True), strengths(False)
    finally:
        numba.set_num_threads(threads)
    return [
        BenchRow(
            "readers",
            f"curvilinear strengths O-grid {na}×{nc}×{nz}: compiled",
            fast * 1e9,
            "ns/point",
            target="< numpy",
            met=fast < ref,
            note=f"numpy reference {ref * 1e9:.0f} ns per point and step ({ref / fast:.1f}×), "
            f"one thread, CPU time; dipole + quadrupole: 5 metric divergences",
        )
    ]


def write_curvilinear_series(
    folder: Path, n_around: int, n_across: int, n_z: int, steps: int
) -> Path:
    """An O-grid around a cylinder of radius 0.5 m out to 3 m, ``.vts`` per step (VTK's
    XML structured-grid writer) in a ``.pvd``: its cells grow geometrically from 2 mm at
    the wall (a boundary layer) to ~0.25 m; a density layer 1 cm thick pulses in the
    boundary layer, with a swirling velocity."""
    import pyvista as pv

    folder.mkdir(parents=True, exist_ok=True)
    c = ogrid_points(n_around, n_across, n_z)
    grid = pv.StructuredGrid(*(c[..., a].transpose(2, 1, 0) for a in range(3)))
    p = np.asarray(grid.points)
    entries = []
    # a layer 1 cm thick at 1 cm from the wall, 0.3 m long around it and along z
    radius = np.hypot(p[:, 0], p[:, 1])
    arc = 0.5 * np.arctan2(p[:, 1], p[:, 0])
    g = np.exp(
        -((radius - 0.51) ** 2) / (2 * 0.01**2) - (arc**2 + (p[:, 2] - 0.25) ** 2) / (2 * 0.1**2)
    )
    for s in range(steps):
        step = grid.copy()
        step.point_data["density"] = (1.2 + 0.01 * np.sin(0.7 * s) * g).astype(np.float32)
        step.point_data["velocity"] = (
            0.5 * g[:, None] * np.stack([-p[:, 1], p[:, 0], np.zeros(len(p))], axis=1)
        ).astype(np.float32)
        step.save(folder / f"ogrid_{s:04d}.vts")
        entries.append(f'<DataSet timestep="{s * 1e-3!r}" file="ogrid_{s:04d}.vts"/>')
    path = folder / "ogrid.pvd"
    path.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">'
        f"<Collection>{''.join(entries)}</Collection></VTKFile>\n"
    )
    return path


def bench_curvilinear(full: bool = False) -> list[BenchRow]:
    """Opening and detecting a curvilinear series natively vs resampled (time, peak memory).

    The O-grid of :func:`write_curvilinear_series`, opened and detected in a
    fresh child process each way (as the other reader rows): on its own
    points (metric terms) and resampled onto the automatic uniform grid
    (``curvilinear="resample"``: its voxel from the cells' 20th-percentile
    size, within the 4 M point budget).  Peak memory is the child's maximum
    resident size above the memory after imports.
    """
    na, nc, nz, steps = CURVI_FULL if full else CURVI_QUICK
    base = Path(os.environ.get("AURALIZE_BENCH_DIR", tempfile.gettempdir()))
    folder = base / f"auralize-bench-curvilinear-{na}x{nc}x{nz}x{steps}"
    marker = folder / "complete"
    if not marker.exists():
        write_curvilinear_series(folder, na, nc, nz, steps)
        marker.write_text("ok")
    path = folder / "ogrid.pvd"
    size = f"O-grid {na}×{nc}×{nz} × {steps}"
    got: dict[str, dict[str, float]] = {}
    rows: list[BenchRow] = []
    for mode in ("native", "resample"):
        try:
            got[mode] = _measure(path, "curvilinear", mode)
        except RuntimeError as exc:
            rows.append(
                BenchRow("readers", f"curvilinear {size}: {mode}", float("nan"), "", note=str(exc))
            )
    if len(got) < 2:
        return rows
    nat, res = got["native"], got["resample"]
    t_nat, t_res = nat["open"] + nat["detect"], res["open"] + res["detect"]
    rows.append(
        BenchRow(
            "readers",
            f"curvilinear {size}: open + detect natively",
            t_nat,
            "s",
            target="≤ resampled",
            met=t_nat <= t_res,
            note=f"open {nat['open']:.2f} s + detect {nat['detect']:.2f} s on its "
            f"{int(nat['points'])} points; resampled: open {res['open']:.2f} s + detect "
            f"{res['detect']:.2f} s = {t_res:.2f} s on {int(res['points'])} grid points "
            f"({100 * res['valid']:.0f} % inside the mesh, {100 * res['below']:.0f} % of the "
            f"cells smaller than a voxel)",
        )
    )
    rows.append(
        BenchRow(
            "readers",
            f"curvilinear {size}: peak memory natively",
            nat["peak"] / 2**20,
            "MiB",
            target="≤ resampled",
            met=nat["peak"] <= res["peak"],
            note=f"resampled: {res['peak'] / 2**20:.0f} MiB (child's peak resident size above "
            f"imports); {nat['sources']} vs {res['sources']} source points",
        )
    )
    return rows


def _measure(path: Path, fmt: str, mode: str | None = None) -> dict[str, float]:
    mapping, density, second = _ARGS[fmt]
    extra = [] if mode is None else [mode]
    done = subprocess.run(
        [sys.executable, "-c", _CHILD, str(path), mapping, density, second, *extra],
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
    )
    if done.returncode != 0:
        raise RuntimeError(done.stderr.strip().splitlines()[-1] if done.stderr else "failed")
    return json.loads(done.stdout.strip().splitlines()[-1])


def bench_readers(full: bool = False) -> list[BenchRow]:
    """Open/detect rows for each new format against the same series in HDF5."""
    n, steps = FULL_SIZE if full else QUICK_SIZE
    base = Path(os.environ.get("AURALIZE_BENCH_DIR", tempfile.gettempdir()))
    folder = base / f"auralize-bench-readers-{n}x{steps}"
    marker = folder / "complete"
    if not marker.exists():
        paths = write_series(folder, n, steps)
        marker.write_text(json.dumps({k: str(v) for k, v in paths.items()}))
    paths = {k: Path(v) for k, v in json.loads(marker.read_text()).items()}
    size = f"{n}³ × {steps}"
    rows: list[BenchRow] = []
    ref: dict[str, float] | None = None
    for fmt, path in paths.items():
        try:
            got = _measure(path, fmt)
        except RuntimeError as exc:
            rows.append(BenchRow("readers", f"{fmt} {size}", float("nan"), "", note=str(exc)))
            continue
        if fmt == "hdf5":
            ref = got
        rows.append(
            BenchRow(
                "readers",
                f"{fmt} {size}: open",
                got["open"],
                "s",
                target="< 2 s",
                met=got["open"] < 2.0,
            )
        )
        ratio = got["detect"] / ref["detect"] if ref else float("nan")
        rows.append(
            BenchRow(
                "readers",
                f"{fmt} {size}: detect",
                got["detect"],
                "s",
                target="≤ 2× HDF5",
                met=bool(ratio <= 2.0) if ref else None,
                note=f"{ratio:.2f}× HDF5; {got['sources']} source points",
            )
        )
        # Detection itself holds a few steps of mapped frames and strengths; the reader's
        # share is the peak above the same detection on the HDF5 file.
        extra = (got["peak"] - ref["peak"]) / got["step_bytes"] if ref else 0.0
        rows.append(
            BenchRow(
                "readers",
                f"{fmt} {size}: peak memory over HDF5",
                extra,
                "steps",
                target="≤ 2 steps",
                met=extra <= 2.0,
                note=f"peak {got['peak'] / 2**20:.0f} MiB above imports "
                f"(HDF5: {ref['peak'] / 2**20 if ref else float('nan'):.0f} MiB); "
                f"a step (float64 frames) is {got['step_bytes'] / 2**20:.1f} MiB",
            )
        )
    return rows + bench_curvilinear(full) + bench_curvilinear_strengths(full)
