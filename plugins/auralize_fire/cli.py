"""``auralize fire …``: low-frequency sound, bandwidth extension, textures, the full chain.

Sub-commands (paper 001)::

    auralize fire lowfreq PATH -o LOW.wav [--burn-field NAME] [--velocity-field NAME] [--iso X]
    auralize fire extend IN.wav -o OUT.wav [--alpha A] [--fcut HZ] [--seed S]
    auralize fire texture IN.wav --training TRAIN.wav -o OUT.wav [--levels L] [--eps E]
    auralize fire render PATH -o OUT.wav --extend bandwidth|texture --listener X,Y,Z --duration S

``lowfreq``, ``extend`` and ``texture`` are emitted-signal commands: they
write the fire's own (source) signal, mono, as at 1 m, with no listener and
no layout, and share the emitted subset of the output options
(``add_output_options(..., emitted=True)``: ``-o``, ``--rate`` = the output
rate, ``--normalize``, ``--format``, ``--limit``, ``--duration``).  An input
at another rate than ``--rate`` is resampled to it before processing, so the
extension and the texture fill the output's band.  Raw float32 inputs
(``.f32``) take ``--input-rate`` (default: the ``manifest.json`` beside them).
``render`` runs the chain and renders the fire, one point emitter at
the flame front's centre (:func:`auralize_fire.model.fire_sound`), along a
listener path with the engine (:func:`auralize.emitters.render_sound`: retarded
time, 1/D, Doppler, the layout's 2-D or 3-D panning) and the common output
options, written by the core writer (channel mask, sidecar).  PATH is a
volume file or ``dataset:fire``.
"""

from __future__ import annotations

import argparse
import time
from typing import Any, cast

import numpy as np

from auralize.audio import fit_duration

#: help text of the emitted-signal commands' output section
EMITTED_TITLE = "emitted-signal output (mono, the fire's own signal at 1 m: no listener, no layout)"


def _emitted_out(p: argparse.ArgumentParser, o: Any) -> None:
    o.add_output_options(p, emitted=True, title=EMITTED_TITLE)


def _signal_in(p: argparse.ArgumentParser, o: Any) -> None:
    p.add_argument("input", metavar="IN", help="low-frequency sound (.wav, .flac or raw .f32)")
    p.add_argument(
        "--input-rate",
        type=o.rate_int,
        metavar="HZ",
        help="sample rate of a raw .f32 input (default: its manifest.json)",
    )


def _read_input(args: argparse.Namespace) -> np.ndarray:
    """The input signal at the output rate ``--rate``, cut to ``--duration`` if shorter."""
    from auralize_fire.clips import read_audio, resample

    x, rate = read_audio(args.input, rate=args.input_rate)
    if args.duration is not None:  # process no more than is written
        x = x[: round(args.duration * rate)]
    return resample(x, rate, args.rate)


def _volume_in(p: argparse.ArgumentParser, o: Any) -> None:
    p.add_argument("volume", metavar="PATH", help="volume file or dataset:fire")
    p.add_argument("--burn-field", default="burn", help="scalar field of the front (default burn)")
    p.add_argument("--velocity-field", default="velocity", help="velocity field (default velocity)")
    p.add_argument("--iso", type=o.finite_float, help="front iso-value (default 10%% of the peak)")
    p.add_argument(
        "--refine", type=o.positive_int, default=2, help="B-spline refinement (default 2)"
    )
    p.add_argument(
        "--highpass", type=o.finite_float, default=30.0, help="high-pass cutoff Hz (§6; 0 = off)"
    )
    p.add_argument("--size", type=o.positive_int, help="grid size of dataset:fire")
    p.add_argument("--steps", type=o.positive_int, help="steps of dataset:fire")


def _extend_opts(p: argparse.ArgumentParser, o: Any) -> None:
    p.add_argument(
        "--alpha", type=o.finite_float, default=3.0, help="power-law exponent (default 3)"
    )
    p.add_argument(
        "--fcut",
        type=o.positive_float,
        default=180.0,
        help="blend centre Hz (default 180; render --extend texture: top of the level-matched band)",
    )
    p.add_argument("--seed", type=o.seed_int, default=0)


def _texture_opts(p: argparse.ArgumentParser, o: Any) -> None:
    p.add_argument("--levels", type=o.positive_int, default=6, help="pyramid levels (default 6)")
    p.add_argument("--eps", type=float, default=1.0, help="approximate-NN ε (default 1; 0 exact)")
    p.add_argument(
        "--coarse-weight",
        type=float,
        default=3.0,
        help="weight of the coarser-level (Eq. 16) feature samples (default 3; 1 = unweighted)",
    )
    p.add_argument("--training-rate", type=o.rate_int, help="rate of a raw .f32 training clip")


def _write(args: argparse.Namespace, x: np.ndarray, info: dict[str, Any], *, units: str) -> None:
    """Write the emitted signal ``x`` (n,) in ``units`` at ``--rate``, cut or padded to
    ``--duration``."""
    from auralize.audio.output import write_audio

    rate = args.rate
    x = fit_duration(x, rate, args.duration)
    gain = write_audio(
        args.output,
        x[None],
        rate,
        normalize=args.normalize,
        limit_pa=args.limit,
        subtype=args.format,
        sidecar={"model": "fire", "signal": "emitted (source, mono)", **info},
        units=units,
    )
    print(
        f"wrote {args.output}: emitted signal, mono, {x.shape[-1] / rate:.2f} s at "
        f"{rate} Hz, gain {gain:.4g}"
    )


def cmd_lowfreq(args: argparse.Namespace) -> int:
    from auralize_fire.lowfreq import flux_series, lowfreq_pressure
    from auralize_fire.model import MONOPOLE_1M, load_volume

    vol = load_volume(args.volume, size=args.size, steps=args.steps)
    t = time.perf_counter()
    fs = flux_series(
        vol,
        burn_field=args.burn_field,
        velocity_field=args.velocity_field,
        iso=args.iso,
        refine=args.refine,
    )
    # dI/dt (m³/s²) as the pressure it radiates at 1 m, ρ0/(4π) dI/dt
    p = MONOPOLE_1M * lowfreq_pressure(fs, rate=args.rate, highpass_hz=args.highpass)
    _write(
        args,
        p,
        {
            "stage": "lowfreq (§3)",
            "iso": fs.iso,
            "steps": vol.n_steps,
            "seconds": time.perf_counter() - t,
        },
        units="Pa at 1 m",
    )
    return 0


def cmd_extend(args: argparse.Namespace) -> int:
    from auralize_fire.bandwidth import bandwidth_extend

    x = _read_input(args)
    t = time.perf_counter()
    y = bandwidth_extend(x, args.rate, alpha=args.alpha, f_cut=args.fcut, seed=args.seed)
    _write(
        args,
        cast(np.ndarray, y),
        {
            "stage": "bandwidth extension (§4)",
            "alpha": args.alpha,
            "f_cut": args.fcut,
            "seed": args.seed,
            "seconds": time.perf_counter() - t,
        },
        units="the input's units",
    )
    return 0


def cmd_texture(args: argparse.Namespace) -> int:
    from auralize.runtime.progress import progress_callback
    from auralize_fire.model import training_at
    from auralize_fire.texture import texture_synthesize

    x = _read_input(args)
    train = training_at(args.training, args.rate, training_rate=args.training_rate)
    t = time.perf_counter()
    with progress_callback("texture", total=args.levels - 1, unit="level") as cb:
        y = texture_synthesize(
            x,
            train,
            levels=args.levels,
            eps=args.eps,
            coarse_weight=args.coarse_weight,
            progress=cb,
        )
    _write(
        args,
        y,
        {
            "stage": "texture synthesis (§5)",
            "training": args.training,
            "levels": args.levels,
            "eps": args.eps,
            "coarse_weight": args.coarse_weight,
            "seconds": time.perf_counter() - t,
        },
        units="the training clip's units",
    )
    return 0


def cmd_render(args: argparse.Namespace) -> int:
    from auralize.listener import listener_from_args
    from auralize.pipeline import save_rendered
    from auralize.rendering import render
    from auralize.spatial.layouts import get_layout
    from auralize_fire.model import fire_sound, load_volume, training_at

    lay = get_layout(args.layout)
    vol = load_volume(args.volume, size=args.size, steps=args.steps)
    path = listener_from_args(args)
    train = None
    if args.extend == "texture":
        train = training_at(
            args.training, args.rate, seed=args.seed, training_rate=args.training_rate
        )
    t = time.perf_counter()
    snd = fire_sound(
        vol,
        extend=args.extend,
        rate=args.rate,
        burn_field=args.burn_field,
        velocity_field=args.velocity_field,
        iso=args.iso,
        refine=args.refine,
        highpass_hz=args.highpass,
        alpha=args.alpha,
        f_cut=args.fcut,
        levels=args.levels,
        eps=args.eps,
        coarse_weight=args.coarse_weight,
        training=train,
        seed=args.seed,
    )
    out = render(snd, path, rate=args.rate, layout=lay, duration=args.duration)
    for per_step in ("flux", "front_area"):  # the sidecar keeps the summary, not the series
        out.meta.pop(per_step, None)
    out.meta["seconds"] = time.perf_counter() - t
    gain = save_rendered(
        out,
        args.output,
        normalize=args.normalize,
        limit_pa=args.limit,
        subtype=args.format,
        extra={"model": "fire"},
    )
    a = out.audio
    print(
        f"wrote {args.output}: {lay.name}, {a.shape[0]} ch, {a.shape[1] / args.rate:.2f} s "
        f"at {args.rate} Hz, gain {gain:.4g}"
    )
    return 0


def add_fire_cli(subparsers: Any, options: Any) -> None:
    """Register ``auralize fire`` and its sub-commands.

    ``options`` holds the shared-option helpers of the ``auralize`` command
    (see :meth:`auralize.plugins.SoundModel.add_cli`).
    """
    o = options
    fire = subparsers.add_parser(
        "fire", help="fire sound (paper 001): lowfreq, extend, texture, render"
    )
    sub = fire.add_subparsers(dest="fire_command", required=True, metavar="STAGE")

    emitted = (
        "writes the fire's emitted signal (mono, as at 1 m from the source), not what a "
        "listener hears: no --layout, --path or --listener; `auralize fire render` places "
        "the fire along a listener path"
    )
    p = sub.add_parser(
        "lowfreq",
        help="§3: p = dI/dt of the flame-front flux, at audio rate",
        description="§3: p = dI/dt of the flame-front flux, at audio rate; " + emitted,
    )
    _volume_in(p, o)
    _emitted_out(p, o)
    p.set_defaults(func=cmd_lowfreq)

    p = sub.add_parser(
        "extend",
        help="§4: spectral bandwidth extension with power-law noise",
        description="§4: spectral bandwidth extension with power-law noise, at "
        "the output rate --rate; " + emitted,
    )
    _signal_in(p, o)
    _emitted_out(p, o)
    _extend_opts(p, o)
    p.set_defaults(func=cmd_extend)

    p = sub.add_parser(
        "texture",
        help="§5: sound texture synthesis from a training clip",
        description="§5: sound texture synthesis from a training clip, at the "
        "output rate --rate; " + emitted,
    )
    _signal_in(p, o)
    p.add_argument("--training", help="training clip (.wav/.flac/.f32; default: procedural)")
    _emitted_out(p, o)
    _texture_opts(p, o)
    p.set_defaults(func=cmd_texture)

    p = sub.add_parser("render", help="the chain §3 → §4/§5, placed along a listener path")
    _volume_in(p, o)
    p.add_argument("--extend", choices=["none", "bandwidth", "texture"], default="bandwidth")
    p.add_argument("--training", help="training clip for --extend texture")
    _extend_opts(p, o)
    _texture_opts(p, o)
    o.add_output_options(p)
    p.set_defaults(func=cmd_render)
