"""Dask options for the ``auralize`` command (out-of-core and distributed runs).

:func:`add_commands` extends the core sub-commands, so the same commands run
on a laptop, a workstation or a cluster:

``auralize detect PATH -o S.h5 --scheduler distributed --workers 2``
    Distributed, resumable detection (:mod:`auralize.distributed.detect`); any of
    ``--scheduler``, ``--address`` or ``--workers`` selects it.  Rerun the
    same command after an interruption to resume; ``--restart`` starts over.
``auralize render PATH ... --scheduler threads --workers 2``
    Synthesis in independent tasks over the workers, one per (block, source
    group) (and detection too, unless ``--sources`` is given).
``auralize dataset explosion -o big.h5 --size 256 --steps 100 --chunked``
    The big-data recipe (:func:`auralize.distributed.write_chunked_explosion`).

It also adds ``auralize scale-detect`` and ``auralize scale-render``, the
same as ``detect``/``render`` with a Dask scheduler, for when the core
commands are not there to extend.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

import numpy as np

from auralize.errors import ParameterError


def add_scheduler_options(p: argparse.ArgumentParser) -> None:
    """``--scheduler``, ``--address``, ``--workers`` and the detection chunking options."""
    from auralize.cli.core import positive_float, positive_int

    g = p.add_argument_group("dask (out-of-core and distributed runs)")
    g.add_argument(
        "--scheduler",
        choices=["sync", "threads", "processes", "distributed"],
        help="run on Dask with this scheduler (distributed: a local cluster, or --address)",
    )
    g.add_argument(
        "--address", metavar="tcp://HOST:PORT", help="an existing dask.distributed scheduler"
    )
    g.add_argument(
        "--dashboard-address",
        metavar="HOST:PORT",
        help="where a local cluster's dashboard listens (default 127.0.0.1, a free "
        "port; give 0.0.0.0:8787 to reach it from other machines)",
    )
    g.add_argument(
        "--workers",
        type=positive_int,
        metavar="N",
        help="threads/processes, or workers of a local cluster (default: cores)",
    )
    g.add_argument(
        "--timeout",
        type=positive_float,
        default=5.0,
        help="seconds to wait for the scheduler at --address (default 5)",
    )
    g.add_argument(
        "--chunk-steps", type=positive_int, default=8, help="time steps per detection task"
    )
    g.add_argument(
        "--slab-planes",
        type=positive_int,
        help="z-planes per detection task (default: what fits --task-memory)",
    )
    g.add_argument(
        "--task-memory",
        type=positive_float,
        default=1.0,
        metavar="GIB",
        help="memory budget of one detection task in GiB (default 1)",
    )
    g.add_argument(
        "--restart",
        action="store_true",
        help="discard the saved state of an interrupted run instead of resuming",
    )
    g.add_argument(
        "--block-seconds",
        type=positive_float,
        help="playback seconds per synthesis block (default: one block, or blocks of at most "
        "2**25 samples × channels); every block is split in source groups, two per worker",
    )


def wants_dask(args: argparse.Namespace) -> bool:
    return bool(
        getattr(args, "scheduler", None)
        or getattr(args, "address", None)
        or getattr(args, "workers", None)
    )


def _runner(args: argparse.Namespace) -> Any:
    from auralize.distributed import Runner

    sched = args.scheduler or ("distributed" if args.address or args.workers else "sync")
    return Runner(
        sched,
        address=args.address,
        workers=args.workers,
        timeout=args.timeout,
        log=lambda msg: print(msg, flush=True),
        dashboard_address=args.dashboard_address,
    )


def _detect(args: argparse.Namespace, vol: Any, runner: Any, output: Any) -> Any:
    from auralize.cli.core import mapping_fields, thresholds_from_args
    from auralize.distributed import detect_distributed
    from auralize.pipeline import resolve_mapping

    return detect_distributed(
        vol,
        mapping=resolve_mapping(vol, args.mapping, **mapping_fields(args)),
        thresholds=thresholds_from_args(args),
        output=output,
        runner=runner,
        chunk_steps=args.chunk_steps,
        slab_planes=args.slab_planes,
        task_memory=int(args.task_memory * (1 << 30)),
        restart=args.restart,
    )


def cmd_detect_dask(args: argparse.Namespace) -> int:
    """``auralize detect`` on Dask: resumable, chunked, with any scheduler."""
    from auralize.cli.core import load_volume

    vol = load_volume(args)
    t = time.perf_counter()
    with _runner(args) as runner:
        series = _detect(args, vol, runner, args.output)
    elapsed = time.perf_counter() - t
    counts = series.counts()
    sc = series.meta["scale"]
    if args.json:
        print(
            json.dumps(
                {
                    "output": str(args.output),
                    "thresholds": series.thresholds.tolist(),
                    "mapping": series.meta.get("mapping"),
                    "scale": sc,
                    "steps": [
                        {"step": n, "time": float(series.times[n]), **c}
                        for n, c in enumerate(counts)
                    ],
                    "seconds": elapsed,
                },
                indent=2,
                default=str,
            )
        )
        return 0
    tot = {k: sum(c[k] for c in counts) for k in ("monopole", "dipole", "quadrupole")}
    peak = max(sc["peak_rss_per_process"], default=0) / 2**30
    print(
        f"wrote {args.output}: {series.n_steps} steps ({len(sc['computed_steps'])} computed, "
        f"{sc['resumed_steps']} resumed) in {elapsed:.2f} s on {sc['workers']} workers "
        f"({sc['scheduler']}), {sc['tasks']} tasks, {len(sc['slabs'])} slabs; peak RSS of a "
        f"worker {peak:.2f} GiB; source points: {tot['monopole']} monopole, {tot['dipole']} "
        f"dipole, {tot['quadrupole']} quadrupole"
    )
    return 0


def _heard(args: argparse.Namespace, vol: Any, runner: Any, planner: Any) -> Any:
    """What a Dask render of ``vol`` hears (as the render without Dask options,
    :func:`auralize.pipeline.heard_sound`): the whole field, computed here as
    it streams through the steps, or the detected sources, detected on the
    workers (or read from ``--sources``)."""
    from auralize.cli.core import heard_arg, mapping_fields, progress_wanted, thresholds_from_args
    from auralize.pipeline import heard_sound
    from auralize.sources.field import parse_heard

    heard = heard_arg(args)
    series = None
    if parse_heard(heard).mode == "detected":
        if args.sources:
            from auralize.sources.sources_file import load_sources_for

            series = load_sources_for(args.sources, vol)
        else:
            series = _detect(args, vol, runner, None)
    return heard_sound(
        vol,
        heard=heard,
        series=series,
        mapping=args.mapping,
        thresholds=thresholds_from_args(args),
        path=planner,
        progress_bar=progress_wanted(),
        **mapping_fields(args),
    )


def cmd_render_dask(args: argparse.Namespace) -> int:
    """``auralize render`` with synthesis (and detection) spread over Dask workers."""
    from auralize.cli.core import check_render_memory, load_volume, outdoor_args
    from auralize.emitters import FieldSources
    from auralize.emitters.synthesis import check_arrival
    from auralize.emitters.timbre import highpass
    from auralize.listener import ListenerPath
    from auralize.pipeline import Planner, save_rendered
    from auralize.rendering import render

    if getattr(args, "method", "auto") == "fwh":
        raise ParameterError(
            "--method fwh runs on this machine: render without the Dask "
            "options (the Dask render sums the volume's sources)"
        )
    if getattr(args, "model", None) or getattr(args, "scene", None):
        return _render_scene_dask(args)
    if getattr(args, "volume", None) is None:
        raise ParameterError("the Dask render needs a volume PATH")
    timbre = getattr(args, "timbre", "physical")
    if timbre not in ("physical", "auto"):
        raise ParameterError(
            f"--timbre {timbre}: the Dask render renders the physical pressure "
            f"only; render {timbre} without the Dask options"
        )
    highpass(np.zeros((1, 0)), args.rate, getattr(args, "highpass", 0.0))  # validate early
    path = ListenerPath.from_csv(args.path) if args.path else None
    from auralize.pipeline import DEFAULT_DURATION
    from auralize.spatial.layouts import get_layout

    duration = args.duration or (path.duration if path is not None else DEFAULT_DURATION)
    check_render_memory(args, duration, get_layout(args.layout).n_channels)
    vol = load_volume(args)
    t = time.perf_counter()
    with _runner(args) as runner:
        planner = Planner(
            vol,
            path=path,
            listener=args.listener,
            duration=args.duration,
            time_scale=args.time_scale,
            face=getattr(args, "orbit_face", "sweep"),
        )
        hs = _heard(args, vol, runner, planner)
        tracks = hs.tracks
        plan = planner.plan
        check_arrival(
            tracks, plan.path, time_scale=plan.time_scale, duration=plan.duration, lead=plan.lead
        )
        for note in plan.notes:
            print(note)
        field = FieldSources(
            tracks,
            time_scale=plan.time_scale,
            lead=plan.lead,
            interp=args.interp,
            bounds=vol.bounds,
        )
        out = render(
            field,
            plan.path,
            rate=args.rate,
            layout=args.layout,
            duration=plan.duration,
            highpass_hz=getattr(args, "highpass", 0.0),
            runner=runner,
            block_seconds=args.block_seconds,
            **outdoor_args(args),
        )
    from auralize.emitters.timbre import AUDIBLE_SHARE

    share = out.meta["share_above_20hz_unfiltered"]
    print(plan.mapping_text + (" (auto)" if plan.auto else ""))
    if share < AUDIBLE_SHARE:
        print(
            f"note: {100 * (1 - share):.0f} % of the physical sound lies below 20 Hz "
            f"(inaudible); try a smaller --time-scale, or --timbre extended without the Dask "
            f"options"
        )
    out.meta.update(plan.as_dict())
    elapsed = time.perf_counter() - t
    out.meta.update({"volume": vol.source, **hs.meta})
    gain = save_rendered(
        out, args.output, normalize=args.normalize, limit_pa=args.limit, subtype=args.format
    )
    peak = float(np.max(np.abs(out.audio))) if out.audio.size else 0.0
    print(
        f"wrote {args.output}: {out.layout.name}, {out.audio.shape[0]} ch, {out.duration:.2f} s "
        f"at {out.rate} Hz in {out.meta['tasks']} tasks ({out.meta['blocks']} blocks × "
        f"{out.meta['groups']} source groups) on {out.meta['workers']} workers, "
        f"peak {peak:.4g} Pa, gain {gain:.4g}; {elapsed:.2f} s"
    )
    return 0


def _render_scene_dask(args: argparse.Namespace) -> int:
    """``auralize render PATH --model/--scene ...`` with Dask options.

    The volume's sources are detected (unless ``--sources``) and synthesized
    on the Dask workers as in a plain Dask render; the models' parts are
    rendered by the engine in this process along the same path; the two meet
    by the one render's rule (:func:`auralize.pipeline.render`: the
    field high-passed at ``--highpass``, the models as they are), so the file
    equals the render without the Dask options.
    """
    from auralize.cli.core import (
        check_render_memory,
        cmd_render_scene,
        load_volume,
        outdoor_args,
        scene_duration,
        scene_setup,
    )
    from auralize.cli.options import DEFAULT_RATE
    from auralize.emitters import FieldSources, Sound
    from auralize.emitters.engine import parts_of
    from auralize.emitters.synthesis import check_arrival
    from auralize.emitters.timbre import highpass, loudness
    from auralize.pipeline import Planner, save_rendered
    from auralize.rendering import render
    from auralize.scene.soundscene import scene_sound
    from auralize.spatial import get_layout

    defaults = {"layout": "mono", "rate": DEFAULT_RATE}
    if getattr(args, "volume", None) is None:
        print(
            "note: the scene has no volume PATH, so nothing runs on Dask: its models render "
            "on this machine"
        )
        return cmd_render_scene(args, defaults)
    if args.timbre not in ("physical", "auto"):
        raise ParameterError(
            f"--timbre {args.timbre}: the Dask render renders the physical "
            f"pressure only; render {args.timbre} without the Dask options"
        )
    highpass(np.zeros((1, 0)), args.rate, args.highpass)  # validate early
    models, path, listener = scene_setup(args, defaults)
    own_path = path is not None
    lay = get_layout(args.layout)
    vol = load_volume(args)
    t = time.perf_counter()
    with _runner(args) as runner:
        planner = Planner(
            vol,
            path=path,
            listener=listener,
            duration=args.duration,
            time_scale=args.time_scale,
            clip=False,
            face=getattr(args, "orbit_face", "sweep"),
        )
        hs = _heard(args, vol, runner, planner)
        tracks = hs.tracks
        plan = planner.plan
        sound = scene_sound(models, plan.path, args.duration, rate=args.rate)
        mine = FieldSources(
            tracks,
            time_scale=plan.time_scale,
            lead=plan.lead,
            interp=args.interp,
            bounds=vol.bounds,
        )
        duration = scene_duration(args, [mine, *parts_of(sound)], plan.path, own_path)
        check_render_memory(args, duration, lay.n_channels)
        check_arrival(
            tracks, plan.path, time_scale=plan.time_scale, duration=duration, lead=plan.lead
        )
        out = render(
            Sound([mine]) + sound,
            plan.path,
            rate=args.rate,
            layout=lay,
            duration=duration,
            highpass_hz=args.highpass,
            runner=runner,
            block_seconds=args.block_seconds,
            **outdoor_args(args),
        )
    from auralize.emitters.timbre import AUDIBLE_SHARE

    if not args.json and out.meta["share_above_20hz_unfiltered"] < AUDIBLE_SHARE:
        print(
            "note: most of the volume's physical sound lies below 20 Hz (inaudible); try a "
            "smaller --time-scale, or --timbre extended without the Dask options"
        )
    dask_meta = {k: out.meta[k] for k in ("blocks", "groups", "tasks", "workers", "scheduler")}
    out.meta.update(
        {
            **plan.as_dict(),
            "timbre": "physical",
            "volume": vol.source,
            **hs.meta,
            "dask": dask_meta,
            "duration_s": duration,
            "seconds": time.perf_counter() - t,
        }
    )
    gain = save_rendered(
        out, args.output, normalize=args.normalize, limit_pa=args.limit, subtype=args.format
    )
    ld = loudness(out.audio, out.rate)
    report = (
        f"wrote {args.output}: {out.duration:.2f} s, {lay.name} ({lay.n_channels} ch) at "
        f"{out.rate} Hz; the volume's sources in {dask_meta['tasks']} tasks on "
        f"{dask_meta['workers']} workers ({dask_meta['scheduler']}) and "
        f"{len(out.meta['parts']) - 1} model part(s) on this machine; peak "
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
    for note in plan.notes:
        print(note)
    print(plan.mapping_text + (" (auto)" if plan.auto else ""))
    for part in out.meta["parts"]:
        print(f"  {part['model']:10s} {part['kind']:20s} peak {part['peak_pa']:.4g} Pa")
    print(report)
    return 0


def cmd_dataset_chunked(args: argparse.Namespace) -> int:
    """``auralize dataset explosion --chunked``: the big-data recipe, in bounded memory."""
    from auralize.distributed import write_chunked_explosion

    if args.name != "explosion":
        raise ParameterError(f"--chunked writes the 'explosion' dataset, not {args.name!r}")
    t = time.perf_counter()
    size = args.size or 256
    steps = args.steps or 100
    write_chunked_explosion(
        args.output,
        size,
        steps,
        args.seed,
        generator=args.generator,
        dtype=args.dtype,
        progress=sys.stdout.isatty(),
    )
    print(
        f"wrote {args.output}: explosion ({args.generator}), {size}x{size}x{size} x {steps} "
        f"steps, one step per chunk, {args.dtype} ({time.perf_counter() - t:.1f} s)"
    )
    return 0


def _chain(parser: argparse.ArgumentParser, dask_cmd: Any) -> None:
    """Make ``parser``'s command run ``dask_cmd`` when a Dask option is given."""
    plain = parser.get_default("func")

    def func(args: argparse.Namespace) -> int:
        if wants_dask(args) or plain is None:
            return int(dask_cmd(args))
        return int(plain(args))

    parser.set_defaults(func=func)


def add_commands(sub: Any) -> None:
    """Add the Dask options to ``detect``, ``render`` and ``dataset`` and two commands."""
    from auralize.cli.core import (
        add_detect_options,
        add_output_options,
        add_render_options,
        add_volume_options,
    )

    choices = sub.choices
    if "detect" in choices:
        add_scheduler_options(choices["detect"])
        _chain(choices["detect"], cmd_detect_dask)
    if "render" in choices:
        add_scheduler_options(choices["render"])
        _chain(choices["render"], cmd_render_dask)
    if "dataset" in choices:
        p = choices["dataset"]
        g = p.add_argument_group("big data")
        g.add_argument(
            "--chunked",
            action="store_true",
            help="write step by step in bounded memory (explosion; default 256³ x 100)",
        )
        g.add_argument(
            "--generator",
            choices=["auto", "particles", "analytic"],
            default="auto",
            help="with --chunked: particles (the core model) or analytic (fast, "
            "default above 128³)",
        )
        g.add_argument(
            "--dtype",
            choices=["float32", "float64"],
            default="float32",
            help="with --chunked: storage type (default float32)",
        )
        plain = p.get_default("func")
        p.set_defaults(func=lambda a: cmd_dataset_chunked(a) if a.chunked else plain(a))

    p = sub.add_parser("scale-detect", help="detect sources on Dask (resumable, chunked)")
    add_volume_options(p)
    add_detect_options(p)
    add_scheduler_options(p)
    p.add_argument("-o", "--output", required=True, help="sources .h5 or .pvd")
    p.add_argument("--json", action="store_true", help="print per-step counts as JSON")
    p.set_defaults(func=cmd_detect_dask)

    p = sub.add_parser(
        "scale-render", help="render with synthesis tasks (blocks × source groups) on Dask workers"
    )
    add_volume_options(p)
    add_detect_options(p)
    add_output_options(p)
    add_scheduler_options(p)
    add_render_options(p)
    p.set_defaults(func=cmd_render_dask)
