"""``auralize view`` and ``auralize script``: the viewer's sub-commands.

Importing this module imports no Qt; the window is built only when
``auralize view`` runs without ``--screenshot``.

Examples
--------
Render a picture off screen and exit::

    auralize view dataset:explosion --screenshot docs/explosion.png --time 15

Run a pvpython-like script::

    auralize script examples/explosion_tour.py
"""

from __future__ import annotations

import argparse
import runpy
import sys
from pathlib import Path
from typing import Any

from auralize.cli.core import add_detect_options, add_volume_options
from auralize.errors import MissingDependencyError, ParameterError


def add_commands(sub: Any) -> None:
    """Add ``view`` and ``script`` to the ``auralize`` sub-command parser."""
    p = sub.add_parser("view", help="open the desktop viewer (or render a --screenshot off screen)")
    # the same volume and detection options as 'auralize detect' / 'render'
    add_volume_options(p)
    for a in p._actions:  # the volume is optional here: open one later from the File menu
        if a.dest == "volume":
            a.nargs = "?"
            a.help = "volume file or dataset:NAME (optional; open one later)"
    add_detect_options(p)
    g = p.add_argument_group("view")
    g.add_argument("--session", metavar="JSON", help="open a saved session")
    g.add_argument("--screenshot", metavar="OUT.png", help="render off screen to OUT.png and exit")
    g.add_argument("--time", type=int, metavar="STEP", help="time step to show (default: middle)")
    g.add_argument("--path", metavar="CSV", help="listener path to draw")
    g.add_argument(
        "--color-by",
        metavar="FIELD",
        help="field to display (default: first scalar field; a plain --field NAME "
        "without '=' means the same)",
    )
    g.add_argument(
        "--representation",
        choices=["volume", "slices", "contour", "glyphs", "none"],
        default="volume",
    )
    g.add_argument(
        "--detect",
        action="store_true",
        help="detect sources (with --screenshot; the window detects on request)",
    )
    g.add_argument("--window-size", default="1200x900", metavar="WxH")
    g.add_argument(
        "--head-tracking",
        type=int,
        metavar="PORT",
        default=None,
        help="turn the live listener's head by a head tracker's OSC messages on this "
        "UDP port (SPARTA's /ypr, /quaternion; IEM SceneRotator's "
        "/SceneRotator/ypr, /SceneRotator/quaternions)",
    )
    p.set_defaults(func=cmd_view)

    p = sub.add_parser(
        "script",
        help="run a pvpython-like script (auralize.simple)",
        description="Run FILE.py as Python, with your rights (it can read, write and run "
        "anything you can: run only scripts you trust), as __main__ with sys.argv = [FILE, "
        "ARGS...]; 'from auralize.simple import *' gives the pvpython-like API. An error in "
        "the script prints the script's own traceback and exits with status 5.",
    )
    p.add_argument("file", metavar="FILE.py", help="the script (Python, run with your rights)")
    p.add_argument("args", nargs=argparse.REMAINDER, help="arguments passed to the script")
    p.set_defaults(func=cmd_script)


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise ParameterError(f"--window-size must be WxH, e.g. 1200x900; got {text!r}") from None
    if w < 16 or h < 16:
        raise ParameterError(f"--window-size must be at least 16x16, got {text!r}")
    from auralize.runtime.resources import require_memory

    # the render window's colour and depth buffers, plus the screenshot's RGB copy
    require_memory(float(w) * h * 12, f"--window-size {text}", hint="choose a smaller window")
    return w, h


def cmd_view(args: argparse.Namespace) -> int:
    if args.screenshot:
        out = screenshot(args)
        print(f"wrote {out}")
        return 0
    try:
        from auralize.viewer.app import run_app
    except ImportError as exc:
        raise MissingDependencyError(
            f"the desktop viewer needs Qt ({exc}); install it with: pip install 'auralize[gui]'"
        ) from None
    return run_app(args, view_options(args))


def view_options(args: argparse.Namespace) -> dict[str, Any]:
    """What ``auralize view``'s options ask for: the session ``data`` entry, the field to
    display, the mapping (name and field names) and the thresholds."""
    from auralize.cli.core import mapping_fields, thresholds_from_args
    from auralize.cli.options import field_map
    from auralize.scene.session import data_spec

    items = list(getattr(args, "field", None) or [])
    plain = [f for f in items if "=" not in f]
    if len(plain) > 1:
        raise ParameterError(f"--field NAME chooses one field to display, got {plain}")
    color_by = getattr(args, "color_by", None) or (plain[0] if plain else None)
    fields = field_map([f for f in items if "=" in f])
    data = (
        data_spec(
            args.volume,
            size=args.size,
            steps=args.steps,
            seed=args.seed,
            fields=fields,
            resolution=args.resolution,
            time_dim=args.time_dim,
            axis_scale=args.axis_scale,
            box=args.box,
            curvilinear="resample" if getattr(args, "resample", False) else None,
        )
        if args.volume is not None
        else None
    )
    return {
        "data": data,
        "field": color_by,
        "mapping": args.mapping,
        "mapping_fields": mapping_fields(args),
        "thresholds": thresholds_from_args(args),
        "head_tracking": getattr(args, "head_tracking", None),
    }


def screenshot(args: argparse.Namespace) -> Path:
    """Render the data (and the listener path; the sources with ``--detect`` or when the
    session had them) off screen: no window, no display needed."""
    from auralize.scene.pictures import prefer_egl

    prefer_egl()
    import pyvista as pv

    from auralize.listener import ListenerPath
    from auralize.runtime.files import atomic_path, check_output_path
    from auralize.scene.detection import Detection
    from auralize.scene.session import SessionState, load_data
    from auralize.scene.view import Scene
    from auralize.sources.detection import Thresholds

    # refused before the data is read: the folder must exist (outputs never create folders)
    out = check_output_path(args.screenshot)
    st = SessionState.load(args.session) if args.session else None
    if args.volume is None and st is None:
        raise ParameterError("--screenshot needs a volume PATH (or --session)")
    opts = view_options(args)
    if opts["data"] is not None:
        vol = load_data(opts["data"])
    else:
        assert st is not None
        vol = load_data(st.data)
    w, h = _size(args.window_size)
    plotter = pv.Plotter(off_screen=True, window_size=[w, h])
    try:
        scene = Scene(plotter)
        view = (st.view if st else {}) or {}
        scene.set_volume(
            vol,
            field=opts["field"] or view.get("field"),
            representation=view.get("representation", args.representation),
        )
        th, mapping, mfields = opts["thresholds"], opts["mapping"], opts["mapping_fields"]
        detect = bool(args.detect)
        if st is not None and st.detection:
            t = st.detection.get("thresholds") or {}
            if t:
                th = Thresholds(
                    t["monopole"],
                    t["dipole"],
                    t["quadrupole"],
                    zero_fraction=t.get("zero_fraction", 1.0),
                )
            m = st.detection.get("mapping")
            mapping = mapping or (None if m == "auto" else m)
            mfields = mfields or dict(st.detection.get("mapping_fields") or {})
            detect = detect or bool(st.detection.get("detected"))
        step = args.time if args.time is not None else view.get("step", vol.n_steps // 2)
        if not 0 <= step < vol.n_steps:
            raise ParameterError(f"--time must be a step in 0..{vol.n_steps - 1}, got {step}")
        if detect:
            det = Detection(vol, mapping=mapping, thresholds=th, **mfields)
            scene.set_sources(det.frame)
        path = (
            ListenerPath.from_csv(args.path) if args.path else (st.listener_path() if st else None)
        )
        scene.set_path(path, render=False)
        scene.set_step(step, render=False)
        if st is not None and st.camera:
            scene.set_camera(st.camera)
        else:
            scene.frame_all()
        with atomic_path(out, suffix=".part.png") as tmp:
            plotter.screenshot(str(tmp))
    finally:
        plotter.close()
    return out


def cmd_script(args: argparse.Namespace) -> int:
    """Run FILE.py as ``__main__`` with ``sys.argv = [FILE, *args]``; a ``sys.exit(n)`` in
    the script becomes the command's exit status."""
    f = Path(args.file)
    if not f.is_file():
        raise ParameterError(f"script {str(f)!r} does not exist")
    old = sys.argv
    sys.argv = [str(f), *args.args]
    try:
        runpy.run_path(str(f), run_name="__main__")
    except SystemExit as exc:
        if exc.code is None or isinstance(exc.code, int):
            return int(exc.code or 0)
        print(exc.code, file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        raise
    except BaseException as exc:
        # the script's own error, not auralize's: its traceback from the script's
        # first frame on (a syntax error: where it is), then the status of a script error
        print(_script_traceback(exc, f), file=sys.stderr, end="")
        from auralize.cli.core import EXIT_SCRIPT

        return EXIT_SCRIPT
    finally:
        sys.argv = old
    return 0


def _script_traceback(exc: BaseException, script: Path) -> str:
    """The traceback of an exception raised by ``script``: its frames from the first
    one in the script on (runpy's and auralize's own frames before it left out)."""
    import traceback

    if (
        isinstance(exc, SyntaxError)
        and exc.filename
        and Path(exc.filename).resolve() == script.resolve()
    ):
        return "".join(traceback.format_exception_only(type(exc), exc))
    tb = exc.__traceback__
    here = script.resolve()
    while tb is not None and Path(tb.tb_frame.f_code.co_filename).resolve() != here:
        tb = tb.tb_next
    return "".join(traceback.format_exception(type(exc), exc, tb or exc.__traceback__))
