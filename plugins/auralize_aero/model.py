"""The ``aero`` SoundModel: parameters, synthesis, viewer overlay, CLI and bench (paper 004)."""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any, ClassVar

import numpy as np

from auralize.emitters import C0, Sound
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.plugins import Parameter, SoundModel

from .objects import AeroObject, Motion, Wind
from .presets import get_preset, stick
from .render import emission, no_ears, render
from .shapes import circle, get_section
from .texture import SoundTexture, compute_texture


def _unpack(inputs: Any) -> dict[str, Any]:
    """Inputs as a dict (texture, object, motion, wind) or a tuple in that order.

    A dict's ``path`` entry (the viewer's overlay inputs) is not used here.
    """
    if isinstance(inputs, dict):
        d = dict(inputs)
    elif isinstance(inputs, tuple | list) and len(inputs) >= 2:
        if any(isinstance(x, ListenerPath) for x in inputs):
            raise ParameterError(
                "aero inputs take no listener path: synthesize((texture, object, motion, wind)) "
                "and render the returned Sound along the path with auralize.pipeline.render"
            )
        d = dict(zip(("texture", "object", "motion", "wind"), inputs, strict=False))
    else:
        got = (
            f"a {type(inputs).__name__} of {len(inputs)} items"
            if isinstance(inputs, tuple | list)
            else type(inputs).__name__
        )
        raise ParameterError(
            "aero inputs must be a dict with keys texture, object and motion and/or wind, "
            f"or a tuple of 2 to 4 items (texture, object[, motion, wind]); got {got}"
        )
    if not isinstance(d.get("object"), AeroObject):
        raise ParameterError(
            f"aero inputs need an AeroObject under 'object', got {type(d.get('object')).__name__}"
        )
    return d


class AeroSound(SoundModel):
    """Aerodynamic sound of moving sticks and wind (Dobashi et al. 2003): Curle's model + sound textures.

    ``inputs`` = ``{"texture": SoundTexture, "object": AeroObject, "motion":
    Motion | None, "wind": Wind | None}`` (or that tuple); :meth:`synthesize`
    returns the emitted sound (point dipoles) for the sound engine.
    """

    name: ClassVar[str] = "aero"
    description: ClassVar[str] = (
        "aerodynamic sound (aeolian tones): CFD sound textures + Curle dipoles (Dobashi et al. 2003)"
    )
    paper: ClassVar[str] = "004 §5–§8, Eqs. 1–4"
    #: not a volume: the viewer draws the object over a volume but cannot hear it,
    #: and ``--model aero:FILE`` is refused (use ``AddSoundModel("aero", inputs)``)
    input_kind: ClassVar[str] = "a sound texture and a moving object or wind"
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter(
            "exponent",
            "physical",
            choices=("physical", "paper"),
            doc="amplitude ∝ v³ (pressure law, docs/design.md) or the paper's v⁶ (Eq. 3)",
        ),
        Parameter("rate", 44100, range=(1000, 384000), unit="Hz", doc="emission sample rate"),
        Parameter("c0", C0, range=(1.0, None), unit="m/s"),
        Parameter("min_distance", 0.05, range=(1e-6, None), unit="m"),
        Parameter(
            "duration",
            0.0,
            range=(0.0, None),
            unit="s",
            doc="seconds of emission; 0: the motion's duration",
        ),
    )

    def synthesize(self, inputs: Any, **params: Any) -> Sound:
        """The emitted sound: one :class:`~auralize_aero.render.AeroEmission` part (§6, Eqs. 3–4).

        Parameters
        ----------
        inputs : dict or tuple
            ``texture`` (SoundTexture), ``object`` (AeroObject), and ``motion``
            (Motion) and/or ``wind`` (Wind); no listener path.
        **params
            ``exponent``, ``rate`` (emission Hz), ``c0`` (m/s), ``min_distance``
            (m), ``duration`` (s; needed for wind on a static object).

        Returns
        -------
        auralize.emitters.Sound
            Render it along a listener path with :func:`auralize.emitters.render_sound`.
        """
        if "stereo" in params:
            no_ears(params.pop("stereo"))
        p = self.resolve(**params)
        d = _unpack(inputs)
        motion: Motion | None = d.get("motion")
        dur = p["duration"] or (float(motion.times[-1]) if motion is not None else 0.0)
        if not dur > 0:
            raise ParameterError(
                "aero: give duration= (seconds of emission) for wind on a static object"
            )
        texture: Any = d.get("texture")  # checked by emission()
        part = emission(
            texture,
            d["object"],
            motion=motion,
            wind=d.get("wind"),
            rate=p["rate"],
            duration=dur,
            exponent=p["exponent"],
            c0=p["c0"],
            min_distance=p["min_distance"],
        )
        return Sound([part], meta=dict(part.meta), name=self.name)

    def overlay(self, inputs: Any, step: int) -> Any:
        """pyvista meshes at motion pose ``step``: the object's polylines and its point sources."""
        import pyvista as pv

        from auralize.volume import TimeVolume

        if isinstance(inputs, tuple) and inputs and isinstance(inputs[0], TimeVolume):
            # the viewer's (volume, path): a stick across the middle of the data's box
            b = np.asarray(inputs[0].bounds, dtype=np.float64).reshape(3, 2)
            c, span = b.mean(axis=1), 0.6 * float(b[0, 1] - b[0, 0])
            ends = np.array([c - [span / 2, 0, 0], c + [span / 2, 0, 0]])
            diameter = max(span, 1e-6) / 100
            inputs = {"object": AeroObject([ends], diameter, name="stick")}
        d = _unpack(inputs)
        obj: AeroObject = d["object"]
        motion: Motion | None = d.get("motion")
        centres = obj.sources()[0]
        if motion is not None:
            k = int(np.clip(step, 0, motion.times.size - 1))
            lines = [motion.world_points(pl)[:, k] for pl in obj.polylines]
            centres = motion.world_points(centres)[:, k]
        else:
            lines = list(obj.polylines)
        pts = np.concatenate(lines)
        cells, off = [], 0
        for pl in lines:
            cells += [len(pl), *range(off, off + len(pl))]
            off += len(pl)
        body = pv.PolyData(pts, lines=np.asarray(cells))
        body.field_data["kind"] = ["object"]
        src = pv.PolyData(np.asarray(centres, dtype=np.float64))
        src.point_data["span_m"] = obj.sources()[1]
        src.field_data["kind"] = ["point_sources"]
        return [body, src]

    # ------------------------------------------------------------------ CLI
    @classmethod
    def add_cli(cls, subparsers: Any, options: Any) -> None:
        """Declare the sub-commands (see :mod:`auralize_aero.commands`)."""
        from auralize_aero.commands import add_commands

        add_commands(subparsers, options)

    @staticmethod
    def _cmd_texture(args: argparse.Namespace) -> int:
        from auralize.runtime.progress import progress_callback

        sec = get_section(args.shape, args.diameter)
        t0 = time.perf_counter()
        with progress_callback("texture", unit="direction") as cb:
            tex = compute_texture(
                sec,
                speed=args.speed,
                duration=args.texture_duration,
                rate=args.texture_rate,
                resolution=args.resolution,
                reynolds=args.reynolds,
                directions=args.directions,
                seed=args.seed,
                cache=not args.no_cache,
                progress=cb,
            )
        tex.save(args.output)
        print(
            f"wrote {args.output}: {sec.name}, D = {sec.diameter:g} m, v0 = {tex.speed:g} m/s, "
            f"{tex.directions_deg.size} direction(s), St = {', '.join(f'{s:.3f}' for s in tex.strouhal)}, "
            f"{time.perf_counter() - t0:.1f} s"
        )
        return 0

    @staticmethod
    def _cmd_render(args: argparse.Namespace) -> int:
        from auralize.audio.output import write_audio
        from auralize.listener import listener_from_args, render_duration

        tex = SoundTexture.load(args.texture)
        path = listener_from_args(args)
        duration = render_duration(args, path)
        motion = wind = None
        if args.preset:
            pr = get_preset(args.preset, duration=duration, seed=args.seed)
            obj, motion, wind = pr.obj, pr.motion, pr.wind
        else:
            obj = _object_from_args(args, tex.diameter)
            if args.motion:
                motion = Motion.from_csv(args.motion)
            else:
                wind = Wind(
                    args.wind, tuple(_floats(args.wind_direction)), gust=args.gust, seed=args.seed
                )
                _check_crosswind(obj, _floats(args.wind_direction), args.wind_direction)
        if getattr(args, "stereo", None) is not None:
            no_ears(args.stereo)
            print(
                "note: --stereo is no longer needed: stereo is panned (VBAP) like every layout",
                file=sys.stderr,
            )
        t0 = time.perf_counter()
        out = render(
            tex,
            obj,
            path,
            motion=motion,
            wind=wind,
            rate=args.rate,
            layout=args.layout,
            exponent=args.exponent,
            duration=duration,
        )
        el = time.perf_counter() - t0
        gain = write_audio(
            args.output,
            out.audio,
            out.rate,
            channel_mask=out.layout.channel_mask,
            normalize=args.normalize,
            limit_pa=args.limit,
            subtype=args.format,
            sidecar={"model": "aero", "texture": str(args.texture), **out.meta},
        )
        peak = float(np.max(np.abs(out.audio))) if out.audio.size else 0.0
        print(
            f"wrote {args.output}: {out.layout.name}, {out.audio.shape[0]} ch, {out.duration:.2f} s at "
            f"{out.rate} Hz, {out.meta['n_sources']} point sources, peak {peak:.4g} Pa, gain {gain:.4g}; "
            f"{el:.2f} s"
        )
        return 0

    # ---------------------------------------------------------------- bench
    @classmethod
    def bench(cls, quick: bool) -> list[Any]:
        """Cylinder texture pre-process (target ≤ 2 min) and 16-source swinging stick (≥ 100×)."""
        from auralize.listener import ListenerPath
        from auralize.plugins import BenchRow, best_of

        rows = []
        res, dur = (10, 0.03) if quick else (16, 0.05)
        t0 = time.perf_counter()
        tex = compute_texture(circle(0.01), resolution=res, duration=dur, cache=False)
        t_tex = time.perf_counter() - t0
        rows.append(
            BenchRow(
                "aero",
                f"cylinder texture ({res} cells/D, {dur:g} s)",
                t_tex,
                "s",
                target="" if quick else "≤ 120 s",
                met=None if quick else t_tex <= 120,
                paper="45 min (FEM, 4 CPUs), ~1 h (FDM, PIII)",
                note=f"St = {tex.strouhal[0]:.3f}; {tex.meta['directions'][0]['lattice']} lattice",
            )
        )
        obj = stick(0.5, 0.01)
        seconds = 2.0 if quick else 4.0
        motion = Motion.swing(
            duration=seconds, swings=2 * seconds, amplitude_deg=80.0, rate_hz=200.0
        )
        path = ListenerPath.point((0.3, 1.0, 0.2), duration=seconds)
        for layout in ("mono", "ring8"):
            t = best_of(
                lambda layout=layout: render(tex, obj, path, motion=motion, layout=layout), repeat=3
            )
            rows.append(
                BenchRow(
                    "aero",
                    f"swinging stick, {obj.n_sources} sources → {layout}",
                    seconds / t,
                    "× real time",
                    target="≥ 100×" if layout == "mono" else "",
                    met=(seconds / t >= 100) if layout == "mono" else None,
                    paper="real time at 60 fps (PIII 1.3 GHz)",
                    note=f"{seconds:g} s of audio in {t * 1e3:.1f} ms",
                )
            )
        return rows


def _floats(text: str) -> list[float]:
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        raise ParameterError(f"expected x,y,z numbers, got {text!r}") from None
    if len(v) != 3:
        raise ParameterError(f"expected three numbers x,y,z, got {text!r}")
    return v


def _check_crosswind(obj: AeroObject, direction: Any, text: str) -> None:
    """Refuse a wind that blows along every piece of the object: no shedding, 0 Pa (§6)."""
    d = np.asarray(direction, dtype=np.float64).reshape(-1)
    if d.size != 3 or not np.all(np.isfinite(d)) or not np.linalg.norm(d) > 0:
        raise ParameterError(
            f"--wind-direction must be three numbers x,y,z, not all 0; got {text!r}"
        )
    d = d / np.linalg.norm(d)
    seg = np.concatenate(
        [np.diff(np.asarray(pl, dtype=np.float64), axis=0) for pl in obj.polylines]
    )
    seg = seg[np.linalg.norm(seg, axis=1) > 0]
    if seg.size and np.all(np.abs(seg @ d) / np.linalg.norm(seg, axis=1) > 0.9999):
        raise ParameterError(
            f"--wind-direction {text} blows along the {obj.name}'s axis: no flow crosses it, so it "
            f"sheds no vortices and makes no sound (0 Pa); give a direction across it, e.g. 0,1,0"
        )


def _object_from_args(args: argparse.Namespace, diameter: float) -> AeroObject:
    from .presets import fence, sphere_object, sword_object

    if args.object == "stick":
        return stick(args.length, diameter)
    if args.object == "fence":
        return fence(diameter=diameter)
    if args.object == "sphere":
        return sphere_object(diameter / 2)
    if args.object == "sword":
        return sword_object(args.length, diameter)
    raise ParameterError(f"unknown --object {args.object!r}; choose stick, fence, sphere or sword")


__all__ = ["AeroSound", "circle", "get_section"]
