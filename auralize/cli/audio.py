"""``auralize play`` and ``auralize devices``: live playback and device listing.

Added to the ``auralize`` command by :func:`add_commands` (see
:data:`auralize.cli.core.CORE_COMMAND_MODULES`).

Examples
--------
::

    auralize devices
    auralize play dataset:explosion --path flight.csv --layout ring8 --device 0
    auralize play data.h5 --path flight.csv --layout ring8 --device "USB" --downmix

``play`` makes the sound ``render`` writes, with the same options and defaults
(``--timbre auto``, ``--highpass 20``, ``--seed``, ``--hrtf``): ``--timbre
physical`` is synthesized block by block as it plays (the high-pass carries
its filter state from block to block, so the blocks join into the offline
render).  ``extended`` and ``tonal`` need the whole render (β of paper 001
Eq. 13 is matched over it, the carriers' clock spans it), and ``auto`` chooses
from the whole physical render along the path (physical if at least half its
energy is above 20 Hz), so with those the sound is rendered once ahead,
exactly as ``render`` does, and then streamed in blocks (the report says how
long that took).  A scene (``--model``/``--scene``) follows the same rule for
its volume's sources.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from auralize.defaults import DEFAULTS, TIMBRE_CHOICES


def cmd_devices(args: argparse.Namespace) -> int:
    """List output devices and their channel counts."""
    from auralize.audio.output import list_devices

    devs = list_devices()
    if args.json:
        print(json.dumps(devs, indent=2))
        return 0
    if not devs:
        print("no audio output devices found; write files with 'auralize render ... -o out.wav'")
        return 0
    for d in devs:
        mark = "*" if d["default"] else " "
        print(
            f"{mark} {d['index']:3d}  {d['name']:40s} {d['max_output_channels']:4d} out ch  "
            f"{d['default_samplerate']:.0f} Hz  ({d['hostapi']})"
        )
    return 0


def _gain_arg(text: str) -> str | float:
    """argparse type of ``--gain``: ``auto`` or a finite number > 0 (full scale per pascal)."""
    if text.strip().lower() == "auto":
        return "auto"
    from auralize.cli.core import positive_float

    try:
        return positive_float(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"expected 'auto' or a gain > 0 (full scale per pascal), got {text!r}"
        ) from None


def _device_arg(text: str) -> int | str:
    return int(text) if text.strip().isdigit() else text


class _RenderedBlocks:
    """Blocks of a sound rendered ahead, in the interface :func:`auralize.audio.live.play`
    plays (that of :class:`auralize.rendering.RenderBlocks`: ``block(i)``,
    ``render_range(start, n)``, ``n_blocks``, ``n_samples``, ``block_size``, ``rate``,
    ``layout``)."""

    def __init__(self, rendered: Any, block: int) -> None:
        self.audio = rendered.audio
        self.rate, self.layout = int(rendered.rate), rendered.layout
        self.block_size = max(int(block), 1)
        self.n_samples = int(self.audio.shape[1])
        self.n_blocks = -(-self.n_samples // self.block_size)

    def render_range(self, start: int, n: int) -> Any:
        return self.audio[:, start : start + max(int(n), 0)]

    def block(self, i: int) -> Any:
        from auralize.errors import ParameterError

        if not 0 <= i < self.n_blocks:
            raise ParameterError(f"block index {i} outside 0..{self.n_blocks - 1}")
        return self.render_range(i * self.block_size, self.block_size)


def _ahead_note(
    timbre: str, resolved: str, seconds: float, duration: float, *, scene: bool = False
) -> str:
    """What ``play`` says when it renders the sound ahead (see the module docstring)."""
    why = (
        "chosen from the whole physical render" if timbre == "auto" else "it needs the whole render"
    )
    name = resolved if resolved == timbre else f"{resolved} ({timbre})"
    how = "a field whose timbre is physical" if scene else "--timbre physical"
    return (
        f"timbre {name}: rendered ahead in {seconds:.2f} s ({why}), then played block by "
        f"block; {how} is synthesized as it plays ({duration:.3g} s)"
    )


def cmd_play(args: argparse.Namespace) -> int:
    """Detect sources (or load them) and play the path live (the sound ``render`` writes)."""
    from auralize.audio.live import play
    from auralize.cli.core import (
        heard_arg,
        load_volume,
        mapping_fields,
        progress_wanted,
        thresholds_from_args,
    )
    from auralize.errors import ParameterError
    from auralize.listener import ListenerPath
    from auralize.pipeline import Planner, heard_sound
    from auralize.spatial.layouts import get_layout

    lay = get_layout(args.layout)  # bad layouts fail before any slow work
    if args.model or args.scene:
        return _play_scene(args)
    if args.volume is None:
        raise ParameterError(
            "give a volume PATH, or sound models with --model NAME:FILE or --scene SCENE.json"
        )
    vol = load_volume(args)
    path = ListenerPath.from_csv(args.path) if args.path else None
    series = None
    if args.sources:
        from auralize.sources.sources_file import load_sources_for

        series = load_sources_for(args.sources, vol)
    from auralize.emitters.synthesis import check_arrival

    planner = Planner(
        vol,
        path=path,
        listener=args.listener,
        duration=args.duration,
        time_scale=args.time_scale,
        face=args.orbit_face,
    )
    hs = heard_sound(
        vol,
        heard=heard_arg(args),
        series=series,
        mapping=args.mapping,
        thresholds=thresholds_from_args(args),
        path=planner,
        progress_bar=progress_wanted(),
        **mapping_fields(args),
    )
    tracks = hs.tracks
    plan = planner.plan
    check_arrival(
        tracks, plan.path, time_scale=plan.time_scale, duration=plan.duration, lead=plan.lead
    )
    # with --json, standard output carries the report alone: what the plan says goes to stderr
    say = sys.stderr if args.json else sys.stdout
    for note in plan.notes:
        print(note, file=say)
    print(plan.mapping_text + (" (auto)" if plan.auto else ""), file=say)
    from auralize.emitters import FieldSources
    from auralize.rendering import render

    sound = FieldSources(
        tracks,
        time_scale=plan.time_scale,
        lead=plan.lead,
        interp=args.interp,
        timbre=args.timbre,
        bounds=vol.bounds,
        by_type=hs.by_type,
        seed=args.seed,
    )
    block = max(round(args.block_ms / 1e3 * args.rate), 1)
    source: Any
    if args.timbre != "physical":  # rendered ahead as `render` renders it (module docstring)
        import time

        from auralize.cli.core import check_render_memory
        from auralize.spatial.layouts import synthesis_layout

        check_render_memory(args, plan.duration, synthesis_layout(lay).n_channels)
        t = time.perf_counter()
        out = render(
            sound,
            plan.path,
            rate=args.rate,
            layout=lay,
            duration=plan.duration,
            highpass_hz=args.highpass,
            hrtf=args.hrtf,
        )
        seconds = time.perf_counter() - t
        for note in [] if args.json else out.meta.get("timbre_notes", []):
            print(note)
        if not args.json:
            print(_ahead_note(args.timbre, out.meta["timbre"], seconds, plan.duration))
        source = _RenderedBlocks(out, block)
    else:
        source = render(
            sound,
            plan.path,
            rate=args.rate,
            layout=lay,
            duration=plan.duration,
            block=block,
            highpass_hz=args.highpass,
            hrtf=args.hrtf,
        )
    rep = play(
        source,
        device=args.device,
        downmix=_downmix_arg(args),
        gain=args.gain,
        limit_pa=args.limit,
    )
    _report(args, rep)
    return 0


def _downmix_arg(args: argparse.Namespace) -> Any:
    if args.downmix is None:
        return False
    return True if args.downmix == "auto" else args.downmix


def _report(args: argparse.Namespace, rep: Any) -> None:
    if args.json:
        print(json.dumps(rep.as_dict(), indent=2))
    else:
        print(rep.summary())
    if rep.underruns:
        print(
            f"auralize play: warning: {rep.underruns} underrun(s): synthesis fell behind the "
            f"device; try a larger --block-ms, higher thresholds, or write a file with "
            f"'auralize render -o out.wav'",
            file=sys.stderr,
        )


def _play_scene(args: argparse.Namespace) -> int:
    """``auralize play --model/--scene``: the scene rendered block by block into the device."""
    from auralize.audio.live import play
    from auralize.cli.core import scene_from_args
    from auralize.cli.options import DEFAULT_RATE
    from auralize.rendering import render

    sound, path, duration, notes = scene_from_args(
        args, {"layout": "ring8", "rate": DEFAULT_RATE}, "play"
    )
    for note in [] if args.json else notes:
        print(note)
    block = max(round(args.block_ms / 1e3 * args.rate), 1)
    from auralize.emitters import FieldSources

    timbres = {p.timbre for p in sound.parts if isinstance(p, FieldSources)}
    blocks: Any
    if timbres - {"physical"}:  # the field's timbre needs the whole render (module docstring)
        import time

        from auralize.cli.core import check_render_memory
        from auralize.spatial.layouts import synthesis_layout

        check_render_memory(args, duration, synthesis_layout(args.layout).n_channels)
        t = time.perf_counter()
        out = render(
            sound,
            path,
            rate=args.rate,
            layout=args.layout,
            duration=duration,
            highpass_hz=args.highpass,
            hrtf=args.hrtf,
        )
        if not args.json:
            timbre = "/".join(sorted(timbres - {"physical"}))
            print(_ahead_note(timbre, timbre, time.perf_counter() - t, duration, scene=True))
        blocks = _RenderedBlocks(out, block)
    else:
        blocks = render(
            sound,
            path,
            rate=args.rate,
            layout=args.layout,
            block=block,
            duration=duration,
            highpass_hz=args.highpass,
            hrtf=args.hrtf,
        )
    rep = play(
        blocks,
        device=args.device,
        downmix=_downmix_arg(args),
        gain=args.gain,
        limit_pa=args.limit,
    )
    _report(args, rep)
    return 0


def add_commands(sub: Any) -> None:
    """Add ``play`` and ``devices`` to the ``auralize`` sub-command parsers."""
    from auralize.cli.core import (
        HIGHPASS_HELP,
        TIMBRE_HELP,
        add_detect_options,
        add_heard_options,
        add_scene_options,
        add_volume_options,
        time_scale_arg,
    )
    from auralize.cli.options import add_output_options, positive_float

    p = sub.add_parser("devices", help="list sound output devices and their channel counts")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_devices)

    p = sub.add_parser("play", help="play the sound along a listener path live (block by block)")
    add_volume_options(p, optional=True)
    add_detect_options(p)
    add_scene_options(p)
    g = add_output_options(
        p, file=False, layout="ring8", listener_required=False, title="live output"
    )
    g.add_argument(
        "--device",
        type=_device_arg,
        metavar="N|NAME",
        help="output device index or name part (see 'auralize devices')",
    )
    g.add_argument(
        "--downmix",
        nargs="?",
        const="auto",
        metavar="LAYOUT",
        help="fold the layout to fit a device with fewer channels (default: the "
        "largest of 7.1/5.1/stereo/mono that fits)",
    )
    g.add_argument(
        "--time-scale",
        type=time_scale_arg,
        default=DEFAULTS.time_scale,
        help="playback seconds per data second, or auto (default): the data's span "
        "plays in --duration",
    )
    g.add_argument(
        "--highpass", type=float, default=DEFAULTS.highpass_hz, metavar="HZ", help=HIGHPASS_HELP
    )
    g.add_argument(
        "--timbre",
        choices=TIMBRE_CHOICES,
        default=DEFAULTS.timbre,
        help=TIMBRE_HELP + "; all but physical are rendered ahead, then played",
    )
    g.add_argument("--interp", choices=["linear", "cubic"], default="cubic")
    g.add_argument(
        "--gain",
        default="auto",
        type=_gain_arg,
        help="full scale per pascal, or auto (peak of the first 0.5 s, lowered if "
        "later blocks would clip)",
    )
    g.add_argument(
        "--block-ms", type=positive_float, default=50.0, help="synthesis block (default 50 ms)"
    )
    g.add_argument(
        "--sources",
        metavar="SOURCES.h5",
        help="reuse sources from 'auralize detect' (heard with --heard detected, "
        "which this implies)",
    )
    add_heard_options(g)
    g.add_argument(
        "--json",
        action="store_true",
        help="print the playback report as JSON (alone on standard output; notes "
        "go to standard error)",
    )
    p.set_defaults(func=cmd_play)
