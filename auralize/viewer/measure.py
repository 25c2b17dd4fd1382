"""How responsive the viewer window is, measured in a real window (for ``auralize bench``).

:func:`responsiveness` opens the viewer (:class:`auralize.viewer.app.MainWindow`)
on the explosion, detects its sources, optionally listens live (into a WAV file
paced in real time, as a device) and records the camera at 10 Hz, then presses
flying keys as a user does (Qt key events posted to the 3-D view, a key every
``gap_s``) and times each key until the render window has finished the redraw
its flight step asks for (its ``EndEvent``): the key→redraw latency, queueing
behind whatever the window was doing included.  It also counts the recorder's captures over the
same time (the rate achieved, asked 10 Hz).

Run as ``python -m auralize.viewer.measure`` it prints the figures as JSON (the
bench runs it so, in a process of its own, under ``xvfb-run`` when there is no
display).  Needs a display: the VTK Qt widget does not draw on Qt's offscreen
platform.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np


def responsiveness(
    *,
    size: int = 64,
    steps: int = 30,
    keys: int = 40,
    gap_s: float = 0.25,
    rate_hz: float = 10.0,
    live: tuple[bool, ...] = (False, True),
) -> list[dict[str, Any]]:
    """Key→redraw latencies (s) and the capture rate (Hz) of the viewer window.

    Parameters
    ----------
    size, steps : int
        The explosion's grid size and time steps.
    keys : int
        Flying keys pressed (W, A, S, D in turn) per run.
    gap_s : float
        Seconds between a redraw and the next key (the window runs meanwhile).
    rate_hz : float
        Capture rate of the recording running meanwhile.
    live : tuple of bool
        One run per item, in the same window, listening live (into a real-time
        paced WAV file) or not.

    Returns
    -------
    list of dict
        Per run: ``live``, ``latency_s`` (one per key; ``inf`` when no redraw came
        within 60 s), ``p50_ms``, ``p95_ms``, ``capture_hz`` (captures per second
        over the keys' time), ``captures``, ``seconds``, and when listening
        ``audio_s`` (audio synthesized meanwhile) and ``move_heard_ms`` (median
        camera move→sound).
    """
    from qtpy import QtCore, QtWidgets

    from auralize.viewer.app import MainWindow

    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    tmp = tempfile.TemporaryDirectory(prefix="auralize-measure-")
    out = Path(tmp.name)
    win = MainWindow(autosave_dir=out / "autosave")
    win.keep_path_answer = False
    win.resize(1024, 768)
    win.show()

    def wait(cond: Any, timeout: float) -> bool:
        t0 = time.perf_counter()
        while not cond():
            app.processEvents(QtCore.QEventLoop.ProcessEventsFlag.AllEvents, 20)
            time.sleep(0.002)
            if time.perf_counter() - t0 > timeout:
                return False
        return True

    runs: list[dict[str, Any]] = []
    try:
        win.open_data("dataset:explosion", size=size, steps=steps)
        wait(lambda: win.volume is not None and not win.busy, 3600)
        win.detect()
        wait(lambda: win.series is not None and not win.busy, 3600)
        win.plotter.interactor.setFocus()
        ends: list[float] = []
        # the redraw showing a key is the one its flight step asks for (not one
        # that happened to be under way when the key came)
        flying = [False]
        rw = win.plotter.render_window
        assert rw is not None

        def drawn(*_: Any) -> None:
            if flying[0]:
                ends.append(time.perf_counter())

        rw.AddObserver("EndEvent", drawn)
        fly = win.fly

        def timed_fly(*a: Any, **k: Any) -> None:
            flying[0] = True
            try:
                fly(*a, **k)
            finally:
                flying[0] = False

        win.fly = timed_fly  # type: ignore[method-assign]
        for k, on in enumerate(live):
            res: dict[str, Any] = {"size": size, "steps": steps, "live": on, "rate_hz": rate_hz}
            if on:
                player = win.start_live(out / f"live{k}.wav")
                # past the first blocks (the heard sound built, nothing left to compile)
                wait(lambda p=player: p.engine.elapsed > 0.5 or p.error is not None, 3600)
                if player.error is not None:
                    raise player.error
                audio0 = player.engine.elapsed
            win.rate_spin.setValue(rate_hz)
            win.clear_path()
            win.start_recording(out / f"path{k}.csv")
            res.update(_press_keys(win, app, ends, wait, keys=keys, gap_s=gap_s))
            if on:
                res["audio_s"] = win.player.engine.elapsed - audio0
                lats = win.player.latencies[1:]
                res["move_heard_ms"] = float(np.median(lats) * 1e3) if lats else float("nan")
            win.stop_recording()
            win.stop_live()
            runs.append(res)
    finally:
        win.stop_live()
        win.stop_recording()
        win.close()
        app.processEvents()
        tmp.cleanup()
    return runs


def _press_keys(
    win: Any, app: Any, ends: list[float], wait: Any, *, keys: int, gap_s: float
) -> dict[str, Any]:
    """Press the flying keys; the latencies and the captures taken meanwhile."""
    from qtpy import QtCore, QtGui, QtWidgets

    n0, t0 = win.recorder.n_captures, time.perf_counter()
    codes = [QtCore.Qt.Key.Key_W, QtCore.Qt.Key.Key_A, QtCore.Qt.Key.Key_S, QtCore.Qt.Key.Key_D]
    lat = []
    for k in range(keys):
        t1 = time.perf_counter()
        wait(lambda t1=t1: time.perf_counter() - t1 >= gap_s, 60)
        n = len(ends)
        ev = QtGui.QKeyEvent(
            QtCore.QEvent.Type.KeyPress, codes[k % 4], QtCore.Qt.KeyboardModifier.NoModifier
        )
        ts = time.perf_counter()
        QtWidgets.QApplication.postEvent(win.plotter.interactor, ev)
        handled = wait(lambda n=n: len(ends) > n, 60)
        lat.append(ends[n] - ts if handled else float("inf"))
    el = time.perf_counter() - t0
    caps = win.recorder.n_captures - n0
    a = np.asarray(lat)
    return {
        "latency_s": lat,
        "p50_ms": float(np.median(a) * 1e3),
        "p95_ms": float(np.percentile(a, 95) * 1e3),
        "captures": caps,
        "seconds": el,
        "capture_hz": caps / el,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m auralize.viewer.measure",
        description="the viewer's key→redraw latency and capture rate, as JSON",
    )
    p.add_argument("--size", type=int, default=64)
    p.add_argument("--steps", type=int, default=30)
    p.add_argument("--keys", type=int, default=40)
    p.add_argument(
        "--live",
        choices=("both", "on", "off"),
        default="both",
        help="runs with live listening on, off or both (default)",
    )
    a = p.parse_args(argv)
    live = {"both": (False, True), "on": (True,), "off": (False,)}[a.live]
    print(json.dumps(responsiveness(size=a.size, steps=a.steps, keys=a.keys, live=live)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
