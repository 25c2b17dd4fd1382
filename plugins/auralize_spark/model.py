"""The ``spark`` sound model: discharge pattern → N-/WM-waves at the listener (paper 002).

Pipeline (Fig. 4–5): charge scene → Laplace field (§4.1, Eq. 1) → leader
growth (Eq. 2) or a user-supplied discharge CSV → strokes (§4.2.3) → one
WM-wave per segment and stroke (Eqs. 3–5) summed at the arrival times and
panned from each segment's direction to the output layout.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from auralize.emitters import C0, Sound
from auralize.emitters.events import as_path
from auralize.errors import FormatError, ParameterError
from auralize.listener import ListenerPath
from auralize.plugins import Parameter, SoundModel
from auralize.spatial.layouts import Layout

from .field import ChargeScene, ElectricField, field_from_volume, solve_field
from .leader import Discharge, grow_leader
from .presets import PRESETS, Preset, get_preset
from .waves import SIGMA0, DischargePart, Rendered, WaveParams, stroke_times

PRESET_NAMES = tuple(PRESETS)


@dataclass
class SparkResult:
    """A rendered discharge with everything that produced it."""

    rendered: Rendered
    discharge: Discharge
    field: ElectricField | None
    strokes: NDArray[np.float64]
    params: WaveParams
    listener: Any
    seed: int = 0
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def part(self) -> DischargePart:
        """The discharge's sound as an engine part (same strokes and T0 jitter)."""
        return DischargePart(self.discharge, self.params, self.strokes, seed=self.seed)

    def render(self, layout: str | Layout = "mono") -> Rendered:
        """The same discharge, strokes and T0 jitter rendered again to another layout."""
        ren = self.rendered
        n = ren.audio.shape[1]
        out = self.part.render_part(
            as_path(self.listener),
            rate=ren.rate,
            layout=layout,
            duration=n / ren.rate,
            c0=self.params.c,
        )
        out.audio = out.audio[:, :n]
        return out

    def summary(self) -> dict[str, Any]:
        m = self.rendered.meta
        out = {
            "segments": m["segments"],
            "main_segments": m["main_segments"],
            "branches": self.discharge.n_branches(),
            "strokes": m["strokes"],
            "stroke_times_s": m["stroke_times_s"],
            "first_arrival_s": m["first_arrival_s"],
            "wave_duration_s": m["wave_duration_s"],
            "clamped_segments": m["clamped_segments"],
            "rate": m["rate"],
            "layout": m["layout"],
            "timing_s": {**self.timings, "geometry": m["geometry_s"], "waveform": m["waveform_s"]},
        }
        if self.field is not None:
            out["laplace"] = {"dims": list(self.field.dims), **self.field.info}
        return out


def resolve_source(
    source: Any, preset: Preset, *, step: int = 0, charge_field: str = "charge"
) -> tuple[ElectricField | None, Discharge | None]:
    """Field and/or discharge from any accepted source.

    ``None`` (the preset's scene), a :class:`ChargeScene`, an
    :class:`ElectricField`, a TimeVolume (charge field ``charge_field`` at
    ``step``), a :class:`Discharge`, or a path: ``.json``/``.toml`` scene or
    ``.csv`` discharge.
    """
    if source is None:
        return preset.field(), None
    if isinstance(source, Discharge):
        return None, source
    if isinstance(source, ElectricField):
        return source, None
    if isinstance(source, ChargeScene):
        return solve_field(source), None
    if isinstance(source, str | Path):
        p = Path(source)
        if p.suffix.lower() == ".csv":
            return None, Discharge.from_csv(p)
        if p.suffix.lower() in (".json", ".toml"):
            return solve_field(ChargeScene.from_file(p)), None
        raise FormatError(f"{p}: expected a scene (.json/.toml) or a discharge (.csv)")
    if hasattr(source, "field_names") and hasattr(source, "frame"):
        return field_from_volume(source, name=charge_field, step=step), None
    raise ParameterError(
        f"spark source must be None, a ChargeScene, ElectricField, TimeVolume, Discharge or a "
        f".json/.toml/.csv path; got {type(source).__name__}"
    )


def make_part(  # noqa: PLR0913 (keyword-only options)
    source: Any = None,
    *,
    preset: str = "spark-balls",
    half_length: float | None = None,
    r0: float | None = None,
    T0: float | None = None,
    ps0: float | None = None,
    sigma0: float = SIGMA0,
    c0: float = C0,
    jitter: float = 0.05,
    amplitude: str = "eq3",
    n_candidates: int = 8,
    rho: float = math.pi / 2,
    gamma: float = 2.5,
    reference: str = "tip",
    branch_probability: float | None = None,
    branch_length: float | None = None,
    strokes: int | None = None,
    seed: int = 0,
    t0: float = 0.0,
    step: int = 0,
    charge_field: str = "charge",
) -> tuple[DischargePart, ElectricField | None, dict[str, float]]:
    """Scene (or discharge) to the discharge's sound part (paper 002 Fig. 4–5, before propagation).

    Parameters are those of :func:`simulate` without the listener and the
    output; ``t0`` is the playback time of the first stroke.

    Returns
    -------
    (DischargePart, the solved field or None, timings in s)
    """
    pre = get_preset(preset)
    hl = pre.half_length if half_length is None else float(half_length)
    timings: dict[str, float] = {}
    t = time.perf_counter()
    fld, dis = resolve_source(source, pre, step=step, charge_field=charge_field)
    timings["field"] = time.perf_counter() - t
    if dis is None:
        assert fld is not None
        t = time.perf_counter()
        dis = grow_leader(
            fld,
            half_length=hl,
            n_candidates=n_candidates,
            rho=rho,
            gamma=gamma,
            seed=seed,
            reference=reference,
            branch_probability=pre.branch_probability
            if branch_probability is None
            else branch_probability,
            branch_length=pre.branch_length if branch_length is None else branch_length,
        )
        timings["leader"] = time.perf_counter() - t
    else:
        dis = dis.subdivided(hl)
    rng = np.random.default_rng([seed, 7])
    if strokes is None:
        st = stroke_times(rng) if pre.multi_stroke else np.zeros(1)
    else:
        st = stroke_times(rng, n=int(strokes))
    params = WaveParams(
        r0=pre.r0 if r0 is None else float(r0),
        T0=pre.T0 if T0 is None else float(T0),
        ps0=pre.ps0 if ps0 is None else float(ps0),
        sigma0=sigma0,
        c=c0,
        jitter=jitter,
        amplitude=amplitude,
    )
    return DischargePart(dis, params, st, t0=t0, seed=seed), fld, timings


def simulate(  # noqa: PLR0913 (keyword-only options)
    source: Any = None,
    listener: ListenerPath | NDArray[np.floating] | None = None,
    *,
    preset: str = "spark-balls",
    half_length: float | None = None,
    r0: float | None = None,
    T0: float | None = None,
    ps0: float | None = None,
    sigma0: float = SIGMA0,
    c0: float = C0,
    jitter: float = 0.05,
    amplitude: str = "eq3",
    n_candidates: int = 8,
    rho: float = math.pi / 2,
    gamma: float = 2.5,
    reference: str = "tip",
    branch_probability: float | None = None,
    branch_length: float | None = None,
    strokes: int | None = None,
    seed: int = 0,
    rate: int = 44100,
    layout: str | Layout = "mono",
    duration: float | None = None,
    step: int = 0,
    charge_field: str = "charge",
) -> SparkResult:
    """Scene (or discharge) to sound at the listener, end to end (paper 002 Fig. 4–5).

    Parameters
    ----------
    source : see :func:`resolve_source` (None = the preset's own scene).
    listener : ListenerPath, static (3,) position in m, or None (the preset's).
    preset : Table 1 row whose l, r0, T0 (and p_s0, branching) are the defaults.
    half_length, r0, T0, ps0 : override Table 1 values (m, m, s, Pa).
    n_candidates, rho, gamma, reference : Eq. 2 (see :func:`grow_leader`).
    strokes : number of strokes (None: random log-series for ``lightning``,
        1 for the other presets).
    seed : seeds growth, strokes and T0 jitter.
    rate, layout, duration : output (duration None: until the last wave passed).

    Returns
    -------
    SparkResult (audio in ``.rendered.audio``, (n_channels, n_samples) Pa).

    Examples
    --------
    >>> res = simulate(preset="spark-balls", seed=3)
    >>> res.rendered.audio.shape[0], res.summary()["strokes"]
    (1, 1)
    """
    part, fld, timings = make_part(
        source,
        preset=preset,
        half_length=half_length,
        r0=r0,
        T0=T0,
        ps0=ps0,
        sigma0=sigma0,
        c0=c0,
        jitter=jitter,
        amplitude=amplitude,
        n_candidates=n_candidates,
        rho=rho,
        gamma=gamma,
        reference=reference,
        branch_probability=branch_probability,
        branch_length=branch_length,
        strokes=strokes,
        seed=seed,
        step=step,
        charge_field=charge_field,
    )
    lis = (
        np.asarray(get_preset(preset).listener, dtype=np.float64) if listener is None else listener
    )
    ren = part.render_part(as_path(lis), rate=rate, layout=layout, duration=duration, c0=c0)
    return SparkResult(ren, part.discharge, fld, part.strokes, part.params, lis, seed, timings)


# ------------------------------------------------------------------ overlay
def discharge_mesh(discharge: Discharge, strokes: int = 1) -> Any:
    """Line mesh of the discharge tree with cell data ``brightness``, ``strokes``, ``main``.

    Main-channel segments are lit by every stroke (brightness 1); side
    branches by the first stroke only and at half the current
    (brightness 0.5 / n_strokes).
    """
    import pyvista as pv

    n = discharge.n_segments
    lines = np.column_stack([np.full(n, 2), discharge.parent[1:], np.arange(1, n + 1)]).ravel()
    mesh = pv.PolyData(discharge.nodes.copy(), lines=lines)
    main = discharge.seg_main
    k = max(int(strokes), 1)
    lit = np.where(main, k, 1)
    mesh.cell_data["strokes"] = lit.astype(np.int32)
    mesh.cell_data["main"] = main.astype(np.uint8)
    mesh.cell_data["brightness"] = np.where(main, 1.0, 0.5 / k)
    mesh.set_active_scalars("brightness", preference="cell")
    return mesh


def fitted_scene(volume: Any, *, points: int = 32) -> ChargeScene:
    """The lightning preset's geometry fitted to a volume's bounding box (for overlays).

    A negative sphere (radius 1/6 of the height) centred 5/6 up, a positive
    plane at the bottom, on a grid of about ``points`` per axis.
    """
    b = np.asarray(volume.bounds, dtype=np.float64).reshape(3, 2)
    size = np.maximum(b[:, 1] - b[:, 0], 1e-9)
    h = float(size.max()) / (points - 1)
    dims = [max(int(round(s / h)) + 1, 4) for s in size]
    center = [0.5 * (b[0, 0] + b[0, 1]), 0.5 * (b[1, 0] + b[1, 1]), b[2, 0] + size[2] * 5 / 6]
    return ChargeScene.from_dict(
        {
            "grid": {"dims": dims, "origin": b[:, 0].tolist(), "spacing": h},
            "charges": [
                {"shape": "sphere", "center": center, "radius": size[2] / 6, "sign": "negative"},
                {"shape": "plane", "axis": "z", "position": float(b[2, 0]), "sign": "positive"},
            ],
        },
        source=f"overlay scene for {getattr(volume, 'source', 'volume')}",
    )


def charge_glyphs(fld: ElectricField | None) -> Any:
    """Glyphs of the charge scene: spheres, boxes and planes with point data ``sign`` (−1/+1).

    Without a scene (a grid charge field) the charged grid points are shown
    as points.
    """
    import pyvista as pv

    blocks = pv.MultiBlock()
    if fld is None:
        return blocks
    if fld.scene is None:
        for sgn, name in ((-1, "negative"), (1, "positive")):
            pts = pv.PolyData(fld.points_of(sgn))
            pts.point_data["sign"] = np.full(pts.n_points, sgn, dtype=np.int8)
            blocks[name] = pts
        return blocks
    lo, hi = fld.origin, fld.upper
    for i, ch in enumerate(fld.scene.charges):
        g = ch.geometry
        if ch.shape == "sphere":
            m = pv.Sphere(radius=g["radius"], center=g["center"])
        elif ch.shape == "box":
            b = [g["min"][0], g["max"][0], g["min"][1], g["max"][1], g["min"][2], g["max"][2]]
            m = pv.Box(bounds=b)
        elif ch.shape == "plane":
            a = "xyz".index(g["axis"])
            center = 0.5 * (lo + hi)
            center[a] = g["position"]
            normal = np.eye(3)[a]
            size = hi - lo
            others = [k for k in range(3) if k != a]
            m = pv.Plane(
                center=center, direction=normal, i_size=size[others[0]], j_size=size[others[1]]
            )
        else:
            m = pv.Sphere(radius=0.5 * float(np.min(fld.spacing)), center=g["position"])
        m.point_data["sign"] = np.full(m.n_points, ch.sign, dtype=np.int8)
        blocks[f"{'negative' if ch.sign < 0 else 'positive'}-{ch.shape}-{i}"] = m
    return blocks


def _fitted(source: Any, step: int, params: dict[str, Any]) -> tuple[Any, int, dict[str, Any]]:
    """A volume without a ``charge`` field becomes the lightning geometry fitted to its bounds."""
    params = dict(params)
    if hasattr(source, "field_names") and "charge" not in source.field_names:
        source, step = fitted_scene(source), 0
        params.setdefault("half_length", float(np.ptp(np.asarray(source.coords()[2]))) / 200)
        params.setdefault("branch_probability", 0.1)
        params.setdefault("branch_length", 15.0)
    return source, step, params


# -------------------------------------------------------------------- model
class SparkSound(SoundModel):
    """Spark-discharge and thunder sound (Matsuyama, Fujimoto & Chiba; paper 002).

    ``synthesize(inputs, **params)`` takes the model's data without a
    listener: ``inputs`` is a source as in :func:`resolve_source` (None for the
    preset's scene; a volume without a ``charge`` field gets the lightning
    geometry fitted to its bounds, as the overlay shows it).  It returns an
    :class:`auralize.emitters.Sound` with one :class:`DischargePart`; render it
    along a listener path with :func:`auralize.emitters.render_sound` (any layout,
    speed of sound ``c0`` of the render).
    """

    name: ClassVar[str] = "spark"
    description: ClassVar[str] = (
        "spark discharges and thunder: Laplace field, stochastic leaders, N-/WM-waves (Matsuyama et al.)"
    )
    paper: ClassVar[str] = "002 §4.1–4.2, Eqs. 1–5, Table 1"
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter("preset", "spark-balls", choices=PRESET_NAMES, doc="Table 1 scale"),
        Parameter(
            "half_length", 0.0, range=(0.0, None), unit="m", doc="segment half-length l; 0 = preset"
        ),
        Parameter("r0", 0.0, range=(0.0, None), unit="m", doc="baseline distance; 0 = preset"),
        Parameter("T0", 0.0, range=(0.0, None), unit="s", doc="baseline half-duration; 0 = preset"),
        Parameter("ps0", 0.0, range=(0.0, None), unit="Pa", doc="baseline peak at r0; 0 = preset"),
        Parameter("sigma0", SIGMA0, range=(0.0, 10.0), doc="Eqs. 3–4 (Wright 1983)"),
        Parameter("gamma", 2.5, range=(0.0, 20.0), doc="Eq. 2 exponent"),
        Parameter("n_candidates", 8, range=(1, 64), doc="Eq. 2 candidates"),
        Parameter(
            "rho",
            math.pi / 2,
            range=(0.01, 2 * math.pi),
            unit="rad",
            doc="candidate cone apex angle",
        ),
        Parameter(
            "reference",
            "tip",
            choices=("tip", "absolute"),
            doc="φ of Eq. 2 relative to the tip or absolute",
        ),
        Parameter(
            "branch_probability",
            -1.0,
            range=(-1.0, 1.0),
            doc="side-branch chance per step; -1 = preset",
        ),
        Parameter(
            "branch_length",
            0.0,
            range=(0.0, None),
            doc="mean side-branch life (segments); 0 = preset",
        ),
        Parameter(
            "strokes",
            0,
            range=(0, 100),
            doc="strokes per flash; 0 = preset (log-series for lightning)",
        ),
        Parameter("jitter", 0.05, range=(0.0, 0.5), doc="relative T0 jitter"),
        Parameter(
            "amplitude", "eq3", choices=("eq3", "paper"), doc="A of Eq. 5: match Eq. 3, or A = 1"
        ),
        Parameter("seed", 0, range=(0, None)),
        Parameter("t0", 0.0, range=(None, None), unit="s", doc="playback time of the first stroke"),
    )

    def load_input(self, spec: str) -> Any:
        """The source in ``spec``: a charge scene (``.json``/``.toml``), a discharge
        (``.csv``, as ``spark render --save-discharge`` writes), else a volume
        (``dataset:NAME`` or a volume file, as :meth:`SoundModel.load_input`).

        So ``auralize render --model spark:tree.csv`` mixes a saved discharge
        into a scene.
        """
        suffix = Path(spec).suffix.lower()
        if suffix == ".csv":
            return Discharge.from_csv(spec)
        if suffix in (".json", ".toml"):
            return ChargeScene.from_file(spec)
        return super().load_input(spec)

    def _part(self, source: Any, step: int = 0, **params: Any) -> tuple[DischargePart, Any]:
        p = self.resolve(**params)
        part, fld, _ = make_part(
            source,
            preset=p["preset"],
            half_length=p["half_length"] or None,
            r0=p["r0"] or None,
            T0=p["T0"] or None,
            ps0=p["ps0"] or None,
            sigma0=p["sigma0"],
            jitter=p["jitter"],
            amplitude=p["amplitude"],
            n_candidates=int(p["n_candidates"]),
            rho=p["rho"],
            gamma=p["gamma"],
            reference=p["reference"],
            strokes=int(p["strokes"]) or None,
            seed=int(p["seed"]),
            branch_probability=None if p["branch_probability"] < 0 else p["branch_probability"],
            branch_length=p["branch_length"] or None,
            t0=float(p["t0"]),
            step=step,
        )
        return part, fld

    def synthesize(self, inputs: Any, **params: Any) -> Sound:
        """The discharge's sound part (no listener: render it with :func:`auralize.emitters.render_sound`).

        Parameters
        ----------
        inputs : None, a ChargeScene, ElectricField, TimeVolume, Discharge or a
            ``.json``/``.toml``/``.csv`` path (see :func:`resolve_source`).
        **params : the model's :attr:`parameters`.

        Returns
        -------
        Sound with one :class:`DischargePart` (its ``discharge`` is the tree);
        ``meta`` has the segment and stroke counts and the stroke times.
        """
        if isinstance(inputs, tuple):
            raise ParameterError(
                "spark inputs are the source only (None, a scene, field, volume, discharge or "
                "file), without a listener: render the returned Sound along a path with "
                "auralize.pipeline.render"
            )
        source, step, params = _fitted(inputs, 0, params)
        part, fld = self._part(source, step=step, **params)
        dis = part.discharge
        meta: dict[str, Any] = {
            "model": "spark",
            "segments": int(dis.n_segments),
            "main_segments": int(dis.seg_main.sum()),
            "branches": dis.n_branches(),
            "strokes": int(part.strokes.size),
            "stroke_times_s": part.strokes.tolist(),
        }
        if fld is not None:
            meta["laplace"] = {"dims": list(fld.dims), **fld.info}
        return Sound([part], meta=meta, name="spark")

    def warm_up(self) -> None:
        """Compile the spark kernels on the plasma ball (``auralize warmup --plugins``)."""
        from auralize_spark import simulate

        simulate(preset="plasma-ball", seed=1)

    def overlay(self, inputs: Any, step: int) -> Any:
        """pyvista MultiBlock: ``discharge`` lines (brightness by stroke) and ``charges`` glyphs.

        ``inputs = source`` or ``(source, listener[, params])`` (the listener is
        not used); the viewer passes ``(volume, path)``.  A volume with a scalar ``charge``
        field is solved at ``step``; a volume without one gets the lightning
        geometry fitted to its bounding box (:func:`fitted_scene`), so the
        overlay shows a discharge in any dataset.  Results are cached per
        (source, step, parameters): stepping back and forth does not regrow.
        """
        import pyvista as pv

        params = dict(inputs[2]) if isinstance(inputs, tuple) and len(inputs) > 2 else {}
        orig = inputs[0] if isinstance(inputs, tuple) else inputs
        source, step, params = _fitted(orig, step, params)
        key = (id(orig), int(step), tuple(sorted(params.items())))
        cache = self.__dict__.setdefault("_overlay_cache", {})
        if key not in cache:
            part, fld = self._part(source, step=step, **params)
            out = pv.MultiBlock()
            out["discharge"] = discharge_mesh(part.discharge, part.strokes.size)
            out["charges"] = charge_glyphs(fld)
            cache.clear()  # keep only the latest (meshes can be large)
            cache[key] = (orig, out)  # holding orig keeps its id unique
        return cache[key][1]

    # ------------------------------------------------------------------ CLI
    @classmethod
    def add_cli(cls, subparsers: Any, options: Any) -> None:
        """Declare the sub-commands (see :mod:`auralize_spark.commands`)."""
        from auralize_spark.commands import add_commands

        add_commands(subparsers, options)

    # ---------------------------------------------------------------- bench
    @classmethod
    def bench(cls, quick: bool) -> list[Any]:
        from .bench import bench_rows

        return bench_rows(quick)


def cmd_spark_render(args: argparse.Namespace) -> int:
    from auralize.pipeline import save_rendered

    if args.scene and args.discharge:
        raise ParameterError("give either --scene FILE or --discharge CSV, not both")
    preset = args.preset or "spark-balls"
    source: Any = args.discharge or args.scene or None
    if args.path:
        listener: Any = ListenerPath.from_csv(args.path)
        duration = args.duration
    else:
        listener = args.listener
        duration = args.duration
    t = time.perf_counter()
    res = simulate(
        source,
        listener,
        preset=preset,
        seed=args.seed,
        strokes=args.strokes,
        gamma=args.gamma,
        T0=args.T0,
        rate=args.rate,
        layout=args.layout,
        duration=duration,
    )
    total = time.perf_counter() - t
    if args.save_discharge:
        res.discharge.to_csv(args.save_discharge)
    summary = res.summary()
    summary["timing_s"]["total"] = total
    summary["output"] = args.output
    lay = res.rendered.layout
    gain = save_rendered(
        res.rendered,
        args.output,
        normalize=args.normalize,
        limit_pa=args.limit,
        subtype=args.format,
        extra={"model": "spark", "preset": preset, "seed": args.seed},
    )
    summary["gain"] = gain
    summary["peak_pa"] = float(np.max(np.abs(res.rendered.audio)))
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        a = res.rendered.audio
        print(
            f"wrote {args.output}: {lay.name}, {a.shape[0]} ch, {a.shape[1] / res.rendered.rate:.3f} s "
            f"at {res.rendered.rate} Hz; {summary['segments']} segments, {summary['strokes']} "
            f"stroke(s), peak {summary['peak_pa']:.4g} Pa; {total:.2f} s"
        )
    return 0
