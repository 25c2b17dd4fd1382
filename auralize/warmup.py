"""Compile the numba kernels ahead, so that the first real command runs at full speed.

The kernels are compiled on first use and kept in one cache folder
(:func:`auralize.runtime.jit.cache_dir`: ``NUMBA_CACHE_DIR``, else
``~/.cache/auralize/numba``).  From a cold cache they take a few minutes of
one core in all, and numba compiles on one core per process.
:func:`warmup` therefore compiles independent kernel groups (:data:`GROUPS`)
in parallel worker processes (at most two, or the core count if smaller),
each group by running tiny renders through the public entry points (the
detection, the synthesis and the emitters engine), so that exactly the
specializations the commands use are compiled and cached.  The groups are
listed longest first: a worker takes the next one when it is done, so the
long ones start first and the short ones fill in.  A group's progress line
is printed as it finishes.  The processes share the on-disk cache safely:
numba keeps each function in its own index and data files, written to a
temporary name and renamed; two processes that compile the same helper both
write the same one signature (each kernel has one, see
:func:`auralize.runtime.jit.kernel_args`).

:func:`compile_ahead` starts the same work in the background for a command
that will need a group later (``auralize demo`` compiles the synthesis
kernels while it detects the sources).

``scripts/install.sh`` runs it (``auralize warmup``) as a visible step; a
warm cache makes it take a few seconds.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

#: kernel groups compiled by one worker process each, the longest first (a
#: process that starts first ends last); each names the kernels it compiles
GROUPS: dict[str, str] = {
    "pieces": "piece-wise synthesis (stereo, 5.1, ring8, recorded paths): "
    "_kernels.render_pieces.render_task",
    "detection": "source detection and the whole field's sources: sources._kernels",
    "emitters": "the emitters engine (every sound model): _kernels.sampled.render",
    "runs": "run-sweep synthesis (mono, AmbiX, binaural): _kernels.render_runs.render_task",
}
#: compiled with ``plugins=True``
PLUGIN_GROUPS: dict[str, str] = {"plugins": "the sound-model plugins' kernels (their warm_up)"}


def warmup(
    *,
    plugins: bool = False,
    processes: int | None = None,
    progress: Callable[[dict[str, Any]], None] | None = None,
) -> dict[str, Any]:
    """Compile (or load from the cache) the kernels of the core pipeline.

    Parameters
    ----------
    plugins : bool
        Also the kernels of the shipped sound-model plugins (fire, spark,
        vortex), through their smallest runs.
    processes : int, optional
        Worker processes (default ``min(2, os.cpu_count())``); 1 compiles the
        groups one after the other in this process.
    progress : callable, optional
        Called with each group's result (as in ``groups`` below) when it is ready.

    Returns
    -------
    dict
        ``seconds`` (wall time), ``compiled`` (list of ``(kernel, seconds)``
        compiled in this call; empty when the cache was warm), ``helpers`` (the
        functions compiled as part of those kernels), ``cache`` (folder),
        ``processes`` and ``groups`` (per group: ``group``, ``seconds``,
        ``cpu_seconds`` of its process, ``compiled``, ``helpers``).
    """
    from auralize.runtime.jit import cache_dir, configure

    configure()
    names = list(GROUPS) + (list(PLUGIN_GROUPS) if plugins else [])
    n_proc = min(2, os.cpu_count() or 1) if processes is None else int(processes)
    n_proc = max(1, min(n_proc, len(names)))
    t0 = time.perf_counter()
    done: list[dict[str, Any]] = []

    def finished(res: dict[str, Any]) -> None:
        done.append(res)
        if progress is not None:
            progress(res)

    if n_proc == 1:
        for name in names:
            finished(compile_group(name))
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed

        # spawn: a fresh interpreter, no numba state or threads inherited
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(n_proc, mp_context=ctx, initializer=_quiet_worker) as pool:
            futures = [pool.submit(compile_group, name) for name in names]
            try:
                for fut in as_completed(futures):
                    finished(fut.result())
            except BaseException:  # a group failed: start no other
                for fut in futures:
                    fut.cancel()
                raise
    order = {n: i for i, n in enumerate(names)}
    done.sort(key=lambda r: order[r["group"]])
    return {
        "seconds": time.perf_counter() - t0,
        "compiled": [c for r in done for c in r["compiled"]],
        "helpers": sorted({h for r in done for h in r.get("helpers", [])}),
        "cache": str(cache_dir()),
        "processes": n_proc,
        "groups": done,
    }


def _quiet_worker() -> None:
    """Worker set-up: the parent reports progress; the workers' compile notices would
    repeat it, interleaved."""
    import logging

    logging.getLogger("auralize").setLevel(logging.ERROR)


def compile_group(name: str) -> dict[str, Any]:
    """Compile (or load) the kernels of group ``name`` of :data:`GROUPS` or
    :data:`PLUGIN_GROUPS` in this process: ``{"group", "seconds", "cpu_seconds",
    "compiled", "helpers"}``."""
    from auralize.runtime.jit import compiled_helpers, compiled_kernels, configure

    configure()
    before, helpers = len(compiled_kernels()), set(compiled_helpers())
    t0, c0 = time.perf_counter(), time.process_time()
    _RUNS[name]()
    return {
        "group": name,
        "seconds": time.perf_counter() - t0,
        "cpu_seconds": time.process_time() - c0,
        "compiled": compiled_kernels()[before:],
        "helpers": sorted(set(compiled_helpers()) - helpers),
    }


def compile_ahead(groups: list[str]) -> Any:
    """Start compiling kernel ``groups`` (of :data:`GROUPS`) in a background process,
    one after the other, while this process goes on: a command that needs them
    later finds them in the cache (numba loads a kernel from the cache when it is
    first called).  Returns the process (:class:`Background`: ``join()`` waits for it),
    or None when the cache already holds the groups' kernels (nothing to do).

    Two cores compile two kernels at once: the synthesis kernels compile there while
    this process compiles and runs the detection.  The synthesis waits for the
    background process before it first calls a kernel that process compiles
    (:func:`auralize.runtime.jit.await_kernel`): the kernel then loads from the
    cache, and the wait is the rest of that compile, not a compile of its own.

    The process is a fresh interpreter (``python -c``) on this one's module path,
    not a ``multiprocessing`` child, which would import the calling script again
    (a script without an ``if __name__ == "__main__"`` guard would run again in
    it); it is stopped if this process exits first.
    """
    import atexit
    import subprocess
    import sys

    from auralize.runtime.jit import compiling_elsewhere, configure

    configure()
    todo = [g for g in groups if not group_cached(g)]
    if not todo:
        return None
    code = f"from auralize.warmup import _compile_quietly; _compile_quietly({todo!r})"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    from auralize.runtime.jit import group_compile_seconds

    expected = sum(group_compile_seconds().get(g, 0.0) for g in todo)
    proc = Background(
        subprocess.Popen(
            [sys.executable, "-c", code],
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        ),
        expected_cpu=expected or None,
    )
    atexit.register(proc.stop)
    compiling_elsewhere([".".join(_GROUP_KERNELS[g]) for g in todo if g in _GROUP_KERNELS], proc)
    return proc


class Background:
    """A background compile (:func:`compile_ahead`): ``is_alive()``, ``join()`` (wait
    for it), ``cpu_seconds()`` (what it has used, of its ``expected_cpu``) and
    ``stop()`` (end it, if it still runs) of its process."""

    def __init__(self, popen: Any, expected_cpu: float | None = None) -> None:
        self.popen = popen
        #: the CPU seconds its groups take (measured: ``auralize/data/compile_seconds.json``)
        self.expected_cpu = expected_cpu

    def is_alive(self) -> bool:
        return bool(self.popen.poll() is None)

    def join(self, timeout: float | None = None) -> None:
        """Wait for the process to end (at most ``timeout`` seconds when given)."""
        import subprocess

        try:
            self.popen.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            pass

    def cpu_seconds(self) -> float | None:
        """CPU seconds the process has used so far (Linux: from ``/proc``; None
        elsewhere, or when it has ended)."""
        try:
            fields = Path(f"/proc/{self.popen.pid}/stat").read_text().rsplit(")", 1)[1].split()
            return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
        except (OSError, ValueError, IndexError, AttributeError):
            return None

    def stop(self) -> None:
        if self.is_alive():
            self.popen.terminate()
            self.popen.wait()


def _compile_quietly(groups: list[str]) -> None:
    _quiet_worker()
    for name in groups:
        compile_group(name)


#: the kernels that show whether a group's kernels are cached (its last compiled)
_GROUP_KERNELS: dict[str, tuple[str, str]] = {
    "pieces": ("auralize.emitters._kernels.render_pieces", "render_task"),
    "runs": ("auralize.emitters._kernels.render_runs", "render_task"),
    "emitters": ("auralize.emitters._kernels.sampled", "render"),
}


def group_cached(name: str) -> bool:
    """Whether the cache holds the main kernel of group ``name`` (numba's index file of
    it exists; groups without a listed kernel count as not cached)."""
    import importlib

    mod_name, kernel = _GROUP_KERNELS.get(name, ("", ""))
    if not mod_name:
        return False
    disp = getattr(importlib.import_module(mod_name), kernel)
    cache_file = getattr(getattr(disp, "_cache", None), "_cache_file", None)
    index = getattr(cache_file, "_index_path", None)
    return index is not None and os.path.exists(index)


def measure_compile_seconds(path: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """Compile every group of :data:`GROUPS` from an empty cache, each in a process of
    its own with a cache of its own (none loads what another compiled; two at a time,
    on a 2-core machine), and write what each kernel took to ``path`` (default
    :data:`auralize.runtime.jit.COMPILE_SECONDS_FILE`), the data of the compile
    notice's estimates (:func:`auralize.runtime.jit.compile_seconds`).

    Every kernel compiled at top level gets the CPU seconds of its compiling
    thread; the functions compiled as part of one, 0 (they are in its figure).
    Run it on a quiet machine: the figures are what a user waits for.  Returns the
    data written.
    """
    import json
    import platform
    import tempfile
    from concurrent.futures import ThreadPoolExecutor

    import numba

    from auralize.runtime.files import atomic_write
    from auralize.runtime.jit import COMPILE_SECONDS_FILE

    path = COMPILE_SECONDS_FILE if path is None else path
    with tempfile.TemporaryDirectory(prefix="auralize-numba-") as tmp:
        n = max(1, min(2, os.cpu_count() or 1))
        with ThreadPoolExecutor(n) as pool:  # (threads that wait for the processes)
            groups = list(pool.map(lambda g: _cold_group(g, Path(tmp) / g), GROUPS))
    helpers = {h for g in groups for h in g["helpers"]}
    seconds: dict[str, float] = dict.fromkeys(helpers, 0.0)
    for name, sec in (c for g in groups for c in g["compiled"]):
        seconds[name] = round(max(seconds.get(name, 0.0), sec), 2)
    data = {
        "about": "CPU seconds to compile each auralize kernel from an empty numba cache "
        "(its compiling thread's; helpers compiled as part of a kernel 0), measured by "
        "auralize.warmup.measure_compile_seconds",
        "measured_on": f"{platform.machine()}, {os.cpu_count()} cores, python "
        f"{platform.python_version()}, numba {numba.__version__}",
        "date": time.strftime("%Y-%m-%d"),
        "groups_cpu_seconds": {g["group"]: round(g["cpu_seconds"], 1) for g in groups},
        "seconds": dict(sorted(seconds.items())),
    }
    atomic_write(Path(path), (json.dumps(data, indent=1) + "\n").encode())
    return data


def _cold_group(name: str, cache: Path) -> dict[str, Any]:
    """:func:`compile_group` ``name`` in a fresh interpreter whose kernel cache is the
    empty folder ``cache``."""
    import json
    import subprocess
    import sys

    code = (
        "import json, sys; from auralize.warmup import _quiet_worker, compile_group; "
        "_quiet_worker(); print(json.dumps(compile_group(sys.argv[1])))"
    )
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(cache),
        "PYTHONPATH": os.pathsep.join(p for p in sys.path if p),
    }
    out = subprocess.run(
        [sys.executable, "-c", code, name], env=env, capture_output=True, text=True, check=True
    )
    return dict(json.loads(out.stdout.strip().splitlines()[-1]))


def _tiny_tracks() -> Any:
    """Three sources over nine steps, near the origin."""
    from auralize.sources.detection import SourceTracks

    t = np.linspace(0.0, 0.2, 9)
    q = np.sin(40.0 * t)[None].repeat(3, axis=0) * np.array([[1.0], [0.5], [0.2]])
    pos = np.array([[2.0, 0.0, 0.0], [0.0, 3.0, 0.0], [1.0, 1.0, 1.0]])
    return SourceTracks(pos, q, np.full(3, 0.05), t)


def _warm_pieces() -> None:
    # the piece-wise kernel, through synthesis.render_tracks, whose kernel_args give
    # every caller this one specialization
    from auralize.emitters.synthesis import render_tracks
    from auralize.listener import ListenerPath

    path = ListenerPath.orbit((0.0, 0.0, 0.0), radius=0.5, duration=0.2, turns=0.1)
    render_tracks(_tiny_tracks(), path, rate=8000, layout="ring8", time_scale=1.0)


def _warm_runs() -> None:
    # the run-sweep kernel: a still listener, unpanned and AmbiX (a moving listener
    # whose captures the arrivals cross takes the piece-wise kernel)
    from auralize.emitters.synthesis import render_tracks
    from auralize.listener import ListenerPath

    point = ListenerPath.point((0.0, 0.0, 0.0), duration=0.2)
    for layout in ("mono", "ambix1"):
        render_tracks(_tiny_tracks(), point, rate=8000, layout=layout, time_scale=1.0)


def _warm_detection() -> None:
    # detection (drawn) and the whole field's sources (heard) of a tiny volume
    from auralize.datasets.synthetic import make_dataset
    from auralize.pipeline import detect_sources, heard_sound

    vol = make_dataset("explosion", size=12, steps=4, seed=0).load()
    detect_sources(vol)
    heard_sound(vol)


def _warm_emitters() -> None:
    # the emitters engine's sampled kernel: one specialization serves every layout, rate
    # and dtype (auralize.runtime.jit.kernel_args); table emitters' samples
    from auralize.emitters import Emitters
    from auralize.emitters.engine import render_emitters
    from auralize.listener import ListenerPath

    point = ListenerPath.point((2.0, 2.0, 2.0), duration=0.05)
    render_emitters(Emitters(np.ones((1, 80)), 8000, np.zeros((1, 3))), point, rate=8000)


def _warm_plugins() -> None:
    """Every registered sound model's :meth:`~auralize.plugins.SoundModel.warm_up`."""
    from auralize.plugins import registry

    for cls in registry().values():
        cls().warm_up()


_RUNS: dict[str, Callable[[], None]] = {
    "pieces": _warm_pieces,
    "detection": _warm_detection,
    "emitters": _warm_emitters,
    "runs": _warm_runs,
    "plugins": _warm_plugins,
}
