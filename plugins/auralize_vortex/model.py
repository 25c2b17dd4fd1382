"""The ``vortex`` SoundModel: parameters, synthesis, viewer overlay, CLI and bench hooks."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from auralize.emitters import Sound
from auralize.errors import DataError, ParameterError
from auralize.plugins import Parameter, SoundModel
from auralize.volume import TimeVolume
from auralize_vortex.datasets import make_fire_plume
from auralize_vortex.fluid import curl
from auralize_vortex.render import (
    block_mean,
    render_vortex,
    split_subvolumes,
    velocity_field_name,
    vortex_sound,
)
from auralize_vortex.texture import DEFAULT_SPEEDS, Texture, TextureConfig, check_speeds, texture


def _texture_from(spec: str | Path | Texture | None, *, quiet: bool = True) -> Texture:
    """A Texture object, a file path, or None/"" for the cached default texture."""
    if isinstance(spec, Texture):
        return spec
    if spec in (None, ""):

        def say(msg: str) -> None:
            if not quiet:
                print(f"vortex texture: {msg}", file=sys.stderr)

        tex, _cached = texture(TextureConfig(), progress=say)
        return tex
    return Texture.load(spec)  # type: ignore[arg-type]


class VortexSound(SoundModel):
    """Vortex sound from turbulent fields with sound textures (Dobashi et al. 2004, paper 000).

    ``synthesize(volume, **params)`` returns what Eq. 5 emits: the
    sub-volumes as static emitters playing the texture of §5 (``texture=`` a
    file; empty for the cached default texture, computed once, ~30 s); the
    engine (:func:`auralize.emitters.render_sound`) propagates and pans them.
    ``overlay(inputs, step)`` returns pyvista meshes of the sound-source
    sub-volumes coloured by average speed.

    Examples
    --------
    >>> from auralize_vortex import VortexSound
    >>> [p.name for p in VortexSound.parameters][:3]
    ['texture', 'block', 'attenuation']
    """

    name: ClassVar[str] = "vortex"
    description: ClassVar[str] = (
        "vortex sound of turbulent flow from sound textures Q(u,t) (Dobashi et al. 2004)"
    )
    paper: ClassVar[str] = "000 §5–§6, Eqs. 1–5"
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter(
            "texture", "", doc="texture HDF5 from 'auralize vortex texture' ('' = cached default)"
        ),
        Parameter("block", 5, range=(1, 1024), unit="points", doc="sub-volume edge (§4)"),
        Parameter(
            "attenuation",
            "physical",
            choices=("physical", "paper"),
            doc="1/r (Howe, docs/design.md) or the paper's 1/r³ (Eq. 5)",
        ),
        Parameter("velocity_field", "velocity", doc="vector field holding the velocity (m/s)"),
        Parameter(
            "low_speed",
            "u4",
            choices=("u4", "clamp"),
            doc="below the smallest texture speed: scale by (u/u_min)^4 or clamp",
        ),
        Parameter(
            "offsets",
            "random",
            choices=("random", "zero"),
            doc="per-source start offsets into the looped texture",
        ),
        Parameter("seed", 0, range=(0, None)),
        Parameter(
            "blend", 0.05, range=(0.0, None), unit="s", doc="cross-fade of the loop ends (§6)"
        ),
        Parameter("time_scale", 1.0, range=(1e-6, None), unit="playback s / data s"),
        Parameter(
            "limit_pa",
            0.0,
            range=(0.0, None),
            unit="Pa",
            doc="maximum received pressure, truncated beyond (§7); 0 = off",
        ),
        Parameter(
            "oversample",
            0,
            range=(0, 64),
            doc="emission rate = oversample × texture rate (0: 1 for sub-volumes as large as "
            "the texture box, else 4)",
        ),
        Parameter(
            "duration",
            0.0,
            range=(0.0, None),
            unit="s",
            doc="playback seconds of emission (0 = the frames' duration × time_scale)",
        ),
        Parameter(
            "lead",
            0.5,
            range=(0.0, None),
            unit="s",
            doc="emission before playback 0 (first step's speeds), heard up to lead × c0 away",
        ),
        Parameter("radius", 0.05, range=(1e-6, None), unit="m", doc="distance clamp"),
    )
    #: built-in datasets (auralize.datasets.synthetic hook)
    datasets: ClassVar[dict[str, Any]] = {"fire-plume": make_fire_plume}

    def __init__(self, *, block: int = 5, isosurface: float | str | None = None) -> None:
        self.overlay_block = block
        self.overlay_isosurface = isosurface

    # ------------------------------------------------------------ synthesis
    def synthesize(self, inputs: Any, **params: Any) -> Sound:
        """What the velocity volume ``inputs`` emits (§6, Eq. 5).

        Parameters
        ----------
        inputs : TimeVolume
            With the vector field ``velocity_field`` (m/s); no listener path
            (render the result with :func:`auralize.emitters.render_sound`).
        **params
            The declared :attr:`parameters`.

        Returns
        -------
        Sound
            One :class:`auralize.emitters.Emitters` part: the sub-volume
            centres ``positions (S, 3)`` m emitting ``signals (S, n)`` Pa at
            1 m from ``t0 = -lead`` (rounded to whole samples); wrapped to
            truncate the received pressure when ``limit_pa`` > 0.
        """
        if not isinstance(inputs, TimeVolume):
            raise ParameterError(
                f"vortex synthesize takes the velocity TimeVolume, got {type(inputs).__name__} "
                f"(the listener path goes to auralize.pipeline.render)"
            )
        p = self.resolve(**params)
        tex = _texture_from(p["texture"])
        return vortex_sound(
            inputs,
            tex,
            block=int(p["block"]),
            attenuation=p["attenuation"],
            velocity_field=p["velocity_field"],
            low_speed=p["low_speed"],
            offsets=p["offsets"],
            seed=int(p["seed"]),
            blend=p["blend"],
            time_scale=p["time_scale"],
            oversample=int(p["oversample"]),
            duration=p["duration"] or None,
            lead=p["lead"],
            radius=p["radius"],
            limit_pa=p["limit_pa"] or None,
        )

    def load_input(self, spec: str) -> TimeVolume:
        """The velocity volume of ``spec``: a file, a core dataset or ``dataset:fire-plume``."""
        return load_volume(
            argparse.Namespace(
                volume=spec, seed=0, size=None, steps=None, field=None, resolution=None
            )
        )

    # -------------------------------------------------------------- overlay
    def warm_up(self) -> None:
        """Compile the texture kernels on a tiny texture (``auralize warmup --plugins``)."""
        from auralize_vortex import TextureConfig, compute_texture

        compute_texture(TextureConfig(speeds=(5.0, 10.0), size=8, duration=0.02))

    def overlay(self, inputs: Any, step: int) -> list[Any]:
        """Pyvista meshes for the viewer at time step ``step``.

        ``inputs`` is a TimeVolume or ``(TimeVolume, path)``.  Returns
        ``[boxes, centres]`` (+ an isosurface when ``isosurface`` was given
        to the constructor): ``boxes`` is a PolyData of the sub-volume boxes
        with cell data ``speed`` (m/s), ``centres`` a PolyData of their
        centres with point data ``speed``, the isosurface a PolyData of the
        vorticity magnitude (1/s) at the level given (or ``"auto"``: half the
        maximum).
        """
        import pyvista as pv

        volume = inputs[0] if isinstance(inputs, tuple) else inputs
        if not isinstance(volume, TimeVolume):
            raise ParameterError(f"overlay needs a TimeVolume, got {type(volume).__name__}")
        name = velocity_field_name(volume)
        sub = split_subvolumes(volume, self.overlay_block)
        v = volume.frame(name, step)
        speed = block_mean(np.sqrt(np.einsum("...i,...i->...", v, v)), sub)
        half = sub.extent_m / 2
        boxes = []
        for c, hh in zip(sub.centres, half, strict=True):
            b = pv.Box(
                bounds=(
                    c[0] - hh[0],
                    c[0] + hh[0],
                    c[1] - hh[1],
                    c[1] + hh[1],
                    c[2] - hh[2],
                    c[2] + hh[2],
                )
            )
            boxes.append(b)
        merged = pv.merge(boxes) if len(boxes) > 1 else boxes[0]
        merged.cell_data["speed"] = np.repeat(speed, boxes[0].n_cells)
        centres = pv.PolyData(sub.centres.copy())
        centres.point_data["speed"] = speed
        out: list[Any] = [merged, centres]
        if self.overlay_isosurface is not None:
            om = np.linalg.norm(curl(v, volume.spacing), axis=-1)
            grid = pv.ImageData(
                dimensions=volume.dims, spacing=tuple(volume.spacing), origin=tuple(volume.origin)
            )
            grid.point_data["vorticity"] = om.ravel()
            level = (
                0.5 * float(om.max())
                if self.overlay_isosurface == "auto"
                else float(self.overlay_isosurface)
            )
            out.append(grid.contour([level], scalars="vorticity"))
        return out

    # ------------------------------------------------------------------ CLI
    @classmethod
    def add_cli(cls, subparsers: Any, options: Any) -> None:
        """Declare the sub-commands (see :mod:`auralize_vortex.commands`)."""
        from auralize_vortex.commands import add_commands

        add_commands(subparsers, options)

    @staticmethod
    def _cmd_texture(args: argparse.Namespace) -> int:
        try:
            speeds = [float(s) for s in args.speeds.split(",") if s.strip()]
        except ValueError:
            raise ParameterError(
                f"--speeds takes comma-separated numbers in m/s, got {args.speeds!r}"
            ) from None
        cfg = TextureConfig(
            speeds=check_speeds(speeds),
            size=args.size,
            duration=args.texture_duration,
            seed=args.seed,
            box_m=args.box,
            dt=args.dt,
            coefficient=args.coefficient,
        )
        from auralize.runtime.progress import progress_callback

        t0 = time.perf_counter()
        with progress_callback("texture", total=len(cfg.speeds), unit="speed") as cb:
            tex, cached = texture(cfg, args.output, progress=cb)
        rms = ", ".join(f"{u:g}: {r:.3g}" for u, r in zip(tex.speeds, tex.rms(), strict=True))
        how = (
            "reused (same parameters)"
            if cached
            else f"computed in {time.perf_counter() - t0:.1f} s"
        )
        print(
            f"wrote {args.output}: {tex.speeds.size} speeds x {tex.n_samples} samples at "
            f"{tex.rate:g} Hz, {how}; rms Pa at 1 m by speed {{{rms}}}"
        )
        return 0

    @staticmethod
    def _cmd_render(args: argparse.Namespace) -> int:
        from auralize.audio.output import write_audio
        from auralize.listener import listener_from_args

        volume = load_volume(args)
        path = listener_from_args(args)
        tex = _texture_from(args.texture, quiet=False)
        t0 = time.perf_counter()
        r = render_vortex(
            volume,
            path,
            tex,
            block=args.block,
            rate=args.rate,
            layout=args.layout,
            duration=args.duration,
            attenuation=args.attenuation,
            velocity_field=args.velocity_field,
            time_scale=args.time_scale,
            seed=args.seed,
        )
        el = time.perf_counter() - t0
        gain = write_audio(
            args.output,
            r.audio,
            r.rate,
            channel_mask=r.layout.channel_mask,
            normalize=args.normalize,
            limit_pa=args.limit,
            subtype=args.format,
            sidecar={"layout": r.layout.describe(), **r.meta},
        )
        peak = float(np.max(np.abs(r.audio))) if r.audio.size else 0.0
        print(
            f"wrote {args.output}: {r.layout.name}, {r.audio.shape[0]} ch, {r.duration:.2f} s at "
            f"{r.rate} Hz, {r.meta['n_sources']} sub-volumes, peak {peak:.3g} Pa, gain {gain:.3g}; "
            f"{el:.2f} s ({r.duration / max(el, 1e-9):.0f}x real time)"
        )
        return 0

    # ---------------------------------------------------------------- bench
    @classmethod
    def bench(cls, quick: bool) -> list[Any]:
        """Texture pre-process for 8 speeds (target ≤ 60 s) and rendering speed (≥ 50× real time)."""
        from auralize.listener import ListenerPath
        from auralize.plugins import BenchRow, best_of
        from auralize_vortex.texture import compute_texture

        rows = []
        dur = 0.25 if quick else 1.0
        cfg = TextureConfig(speeds=DEFAULT_SPEEDS, duration=dur)
        t0 = time.perf_counter()
        tex = compute_texture(cfg)
        el = time.perf_counter() - t0
        slope = float(np.polyfit(np.log(tex.speeds), np.log(tex.rms()), 1)[0])
        rows.append(
            BenchRow(
                "vortex",
                f"texture: 8 speeds, {cfg.size}³ box, {dur:g} s each",
                el,
                "s",
                target="≤ 60 s" if not quick else "",
                met=(el <= 60) if not quick else None,
                paper="several minutes (§7)",
                note=f"rms ∝ u^{slope:.2f} (compact vortex sound: 4)",
            )
        )
        vol = make_fire_plume()
        c = vol.center
        for layout in ("mono", "ring8"):
            length = 2.0
            path = ListenerPath.point(c + np.array([0.0, -2.0, 0.0]), duration=length)

            def run(layout: str = layout, path: ListenerPath = path) -> None:
                render_vortex(vol, path, tex, layout=layout)

            t = best_of(run, repeat=3)
            rows.append(
                BenchRow(
                    "vortex",
                    f"render 15×15×20 plume → {layout}, {length:g} s",
                    length / t,
                    "× real time",
                    target="≥ 50×",
                    met=length / t >= 50,
                    paper="10–20 fps interactive (§7)",
                    note=f"{t * 1e3:.1f} ms; 36 sub-volumes of 5³ through the sound engine",
                )
            )
        return rows


def load_volume(args: argparse.Namespace) -> TimeVolume:
    """Open ``args.volume``: a file, a core built-in dataset, or ``dataset:fire-plume``.

    (The core ``make_dataset`` only knows the core datasets, so the plugin's
    own are resolved here.)
    """
    spec = str(args.volume)
    if spec.startswith("dataset:") and spec.split(":", 1)[1] in VortexSound.datasets:
        kw: dict[str, int] = {"seed": args.seed}
        if args.size is not None:
            kw["size"] = args.size
        if args.steps is not None:
            kw["steps"] = args.steps
        return VortexSound.datasets[spec.split(":", 1)[1]](**kw)
    from auralize.io import field_map
    from auralize.io.options import curvilinear_mode
    from auralize.pipeline import load

    with curvilinear_mode("resample"):  # the vorticity takes uniform spacing
        vol = load(
            spec,
            size=args.size,
            steps=args.steps,
            seed=args.seed,
            fields=field_map(args.field),
            resolution=args.resolution,
        )
    if not isinstance(vol, TimeVolume):  # pragma: no cover - load always returns one
        raise DataError(f"{spec}: not a volume")
    return vol


def speed_series(volume: TimeVolume, block: int = 5) -> NDArray[np.float64]:
    """Average speed of every sub-volume at every step ``(T, S)`` (convenience for scripts)."""
    from auralize_vortex.render import subvolume_speeds

    return subvolume_speeds(volume, split_subvolumes(volume, block))
