"""One compiled specialization per kernel, a parallel warmup, and an honest compile notice.

A cold compile of the synthesis kernels is minutes, so these tests never
compile one: they replace a kernel by a recorder and check what its Python
boundary passes to it (the numba type of every argument, which is what
numba specializes on).
"""

from __future__ import annotations

import logging
import os

import numba
import numpy as np
import pytest
from numba.core import event

from auralize import warmup
from auralize.emitters import Emitters, _sampled
from auralize.emitters._kernels import render_pieces, render_runs
from auralize.emitters.engine import model_emitters, render_emitters
from auralize.emitters.synthesis import render_tracks as synth_render
from auralize.listener import ListenerPath
from auralize.runtime import jit, numba_passes
from auralize.runtime.jit import kernel_arg, kernel_args
from auralize.sources.detection import SourceTracks


def _read_only(a: np.ndarray) -> np.ndarray:
    a = np.array(a)
    a.flags.writeable = False
    return a


def _check_forms(args: tuple) -> None:  # type: ignore[type-arg]
    for a in args:
        if isinstance(a, tuple):  # a named bundle of arguments: each of its fields
            _check_forms(a)
        elif isinstance(a, np.ndarray):
            assert a.flags.c_contiguous and a.flags.writeable and a.flags.aligned
            assert a.dtype in (np.float64, np.int64, np.bool_), a.dtype
        else:
            assert not isinstance(a, np.generic), type(a)  # numpy scalars: Python's own


class _Recorder:
    """Stands in for a kernel: records the numba signature of each call."""

    def __init__(self, result: object = None) -> None:
        self.signatures: set[tuple[object, ...]] = set()
        self.calls = 0
        self.result = result

    def __call__(self, *args: object) -> object:
        _check_forms(args)
        self.signatures.add(tuple(numba.typeof(a) for a in args))
        self.calls += 1
        return self.result


def test_kernel_arg_makes_one_form_and_keeps_conforming_arrays() -> None:
    base = np.arange(24.0).reshape(4, 6)
    cases = [
        base.astype(np.float32),
        base[:, ::2],
        base.T,
        _read_only(base),
        np.asfortranarray(base),
    ]
    for x in cases:
        a = kernel_arg(x)
        assert a.dtype == np.float64 and a.flags.c_contiguous and a.flags.writeable
        assert np.array_equal(a, x)  # float32 widened exactly
        assert numba.typeof(a) == numba.typeof(base)
    assert kernel_arg(base) is base  # an output array stays the caller's
    i = kernel_arg(np.arange(5, dtype=np.int32)[::2])
    assert i.dtype == np.int64 and i.flags.c_contiguous
    b = np.zeros(3, dtype=bool)
    assert kernel_arg(b) is b
    scal = kernel_args(np.float32(0.5), np.int32(3), np.bool_(True), 2.0, 3, False, "x")
    assert [type(v) for v in scal] == [float, int, bool, float, int, bool, str]
    with pytest.raises(TypeError, match="complex"):
        kernel_arg(np.zeros(2, dtype=complex))


def test_sampled_kernel_gets_one_signature_for_any_input(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    rec = _Recorder()
    monkeypatch.setattr(_sampled, "render", rec)
    rng = np.random.default_rng(0)
    sig = rng.standard_normal((2, 800))
    pos = np.array([[3.0, 0.0, 0.0], [0.0, 4.0, 1.0]])
    path = ListenerPath.orbit((0.0, 0.0, 0.0), radius=0.5, duration=0.05, turns=0.1)
    wide = np.zeros((2, 1600))
    wide[:, ::2] = sig
    ems = [
        Emitters(sig, 8000, pos),
        model_emitters(sig.astype(np.float32), 8000, pos),  # float32, as a model makes it
        Emitters(wide[:, ::2], 8000, pos),  # sliced
        Emitters(_read_only(sig), 8000, _read_only(pos)),  # read-only
        Emitters(sig, 2000, pos),  # upsampled: resample_poly's padded rows
    ]
    ro = model_emitters(_read_only(sig), 8000, _read_only(pos))
    ro.radius = _read_only(ro.radius)
    ems.append(ro)
    for em in ems:
        for layout in ("mono", "ring8"):
            render_emitters(em, path, rate=8000, layout=layout)
    assert rec.calls >= 2 * len(ems)
    assert len(rec.signatures) == 1


def test_synthesis_kernels_get_one_signature_each(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    runs, pieces = _Recorder(0), _Recorder(0)
    monkeypatch.setattr(render_runs, "render_task", runs)
    monkeypatch.setattr(render_pieces, "render_task", pieces)
    t = np.linspace(0.0, 0.2, 9)
    q = np.sin(40.0 * t)[None].repeat(3, axis=0) * np.array([[1.0], [0.5], [0.2]])
    pos = np.array([[2.0, 0.0, 0.0], [0.0, 3.0, 0.0], [1.0, 1.0, 1.0]])
    rad = np.full(3, 0.05)
    point = ListenerPath.point((0.0, 0.0, 0.0), duration=0.2)
    orbit = ListenerPath.orbit((0.0, 0.0, 0.0), radius=0.3, duration=0.2, turns=0.2)
    wide = np.zeros((3, 18))
    wide[:, ::2] = q
    variants = [
        SourceTracks(pos, q, rad, t),
        SourceTracks(
            pos.astype(np.float32),
            q.astype(np.float32),
            rad.astype(np.float32),
            t.astype(np.float32),
        ),
        SourceTracks(pos.T.copy().T, wide[:, ::2], rad, t),  # non-contiguous
        SourceTracks(_read_only(pos), _read_only(q), _read_only(rad), _read_only(t)),
    ]
    for tr in variants:
        synth_render(tr, point, rate=8000, layout="mono", time_scale=1.0)
        synth_render(tr, orbit, rate=8000, layout="ring8", time_scale=1.0)
        synth_render(tr, orbit, rate=8000, layout="ambix1", time_scale=1.0)
    assert runs.calls >= len(variants) and pieces.calls >= len(variants)
    assert len(runs.signatures) == 1
    assert len(pieces.signatures) == 1


def test_warmup_runs_every_group_and_reports_each(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    ran: list[str] = []
    monkeypatch.setattr(warmup, "_RUNS", {n: (lambda n=n: ran.append(n)) for n in warmup._RUNS})
    seen: list[str] = []
    out = warmup.warmup(processes=1, progress=lambda r: seen.append(r["group"]))
    assert ran == seen == list(warmup.GROUPS)
    assert out["processes"] == 1 and [g["group"] for g in out["groups"]] == list(warmup.GROUPS)
    assert out["compiled"] == []


def test_warmup_groups_run_in_processes_by_default(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(warmup.os, "cpu_count", lambda: 8)
    used: dict[str, int] = {}

    class Pool:
        def __init__(self, n: int, **kw: object) -> None:
            used["n"] = n
            assert kw["mp_context"].get_start_method() == "spawn"

        def __enter__(self) -> Pool:
            return self

        def __exit__(self, *a: object) -> None:
            pass

        def submit(self, fn, name):  # type: ignore[no-untyped-def]
            from concurrent.futures import Future

            f: Future[dict[str, object]] = Future()
            f.set_result({"group": name, "seconds": 0.0, "compiled": [(name, 1.0)]})
            return f

    import concurrent.futures

    monkeypatch.setattr(concurrent.futures, "ProcessPoolExecutor", Pool)
    out = warmup.warmup()
    assert used["n"] == 2 == out["processes"]
    assert [c[0] for c in out["compiled"]] == list(warmup.GROUPS)


def test_cheap_kernels_of_a_module_are_announced_once_together(caplog, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    import sys
    import types

    mod = types.ModuleType("auralize._test_cheap")
    kernels = {}
    for name, body in (("one", lambda x: x + 1), ("two", lambda x: x + 2)):
        body.__module__, body.__qualname__ = mod.__name__, name
        kernels[name] = numba.njit(body)
        setattr(mod, name, kernels[name])
        monkeypatch.setitem(jit.compile_seconds(), f"{mod.__name__}.{name}", 7.0)
    monkeypatch.setitem(sys.modules, mod.__name__, mod)
    monkeypatch.setattr(jit._NOTICE, "announced", True)
    monkeypatch.setattr(jit._NOTICE, "named", {f"{mod.__name__}.one", f"{mod.__name__}.two"})
    notice = jit._CompileNotice()
    event.register("numba:compile", notice)
    try:
        with caplog.at_level(logging.WARNING, logger="auralize"):
            assert kernels["one"](1) == 2 and kernels["two"](1) == 3
    finally:
        event.unregister("numba:compile", notice)
    msgs = [r.getMessage() for r in caplog.records if "compiling kernels" in r.getMessage()]
    # one notice for both (7 s each, below NOTICE_AGAIN_SECONDS), estimating both
    assert len(msgs) == 1 and msgs[0].startswith("compiling kernels, once: ~14 s"), msgs


def test_the_first_notice_counts_only_measured_kernels_of_its_module(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """A module's kernels that the warm-up never compiled (no measured time) are not
    in its first notice: the commands' paths do not compile them."""
    import sys
    import types

    mod = types.ModuleType("auralize._test_unmeasured")

    def kernel(name: str) -> object:
        def body(x):  # type: ignore[no-untyped-def]
            return x

        body.__module__, body.__qualname__ = mod.__name__, name
        return numba.njit(body)

    for name in ("used", "also_used", "never_used"):
        setattr(mod, name, kernel(name))
    monkeypatch.setitem(sys.modules, mod.__name__, mod)
    monkeypatch.setitem(jit.compile_seconds(), f"{mod.__name__}.used", 3.0)
    monkeypatch.setitem(jit.compile_seconds(), f"{mod.__name__}.also_used", 4.0)
    assert jit.estimate_seconds(f"{mod.__name__}.used") == pytest.approx(7.0)
    # unmeasured itself: the default for it, and the measured others
    assert jit.estimate_seconds(f"{mod.__name__}.never_used") == pytest.approx(
        jit.DEFAULT_SECONDS + 7.0
    )


def test_compile_notice_estimates_the_kernel_that_compiles(caplog, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    # the process-wide notice stays quiet about these
    monkeypatch.setattr(jit._NOTICE, "announced", True)
    monkeypatch.setattr(
        jit._NOTICE, "named", {"auralize._test_small.small", "auralize._test_big.big"}
    )
    monkeypatch.setitem(jit.compile_seconds(), "auralize._test_big.big", 120.0)
    notice = jit._CompileNotice()
    event.register("numba:compile", notice)

    def small(x):  # type: ignore[no-untyped-def]
        return x + 1

    def big(x):  # type: ignore[no-untyped-def]
        return x * 3

    small.__module__, small.__qualname__ = "auralize._test_small", "small"
    big.__module__, big.__qualname__ = "auralize._test_big", "big"
    try:
        with caplog.at_level(logging.WARNING, logger="auralize"):
            assert numba.njit(small)(1) == 2
            k = numba.njit(big)
            assert k(1) == 3 and k(1.5) == 4.5
    finally:
        event.unregister("numba:compile", notice)
    msgs = [r.getMessage() for r in caplog.records if "compiling kernels" in r.getMessage()]
    # the first compile, then the expensive kernel once (not per specialization)
    assert len(msgs) == 2, msgs
    assert msgs[1].startswith("compiling kernels, once: ~120 s")


def test_plugins_are_warmed_through_their_hook(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """``warmup --plugins`` asks every registered model to warm up (no plugin named in
    the core): a model registered by a third party is warmed too."""
    import auralize.plugins as plugins
    from auralize.plugins import SoundModel

    warmed: list[str] = []

    class Probe(SoundModel):
        name = "probe"

        def warm_up(self) -> None:
            warmed.append(self.name)

    monkeypatch.setattr(plugins, "registry", lambda: {"probe": Probe, "base": SoundModel})
    warmup._warm_plugins()
    assert warmed == ["probe"]
    assert SoundModel().warm_up() is None  # the default: nothing to compile


#: compiles kernels with inlined helpers and variables assigned more than once
#: (``_cut_at_end`` inlines ``_hermite_at``; ``_gains_called`` every panning law; the
#: listener's candidate lines; the piece and run tables) and prints which passes ran and
#: the kernels' LLVM IR
_IR_CHILD = """
import numpy as np
from auralize import warmup
from auralize.emitters import _synth_prepare, _synth_tables
from auralize.emitters._kernels import arrivals, gains, hermite, tables
from auralize.emitters._kernels.common import LaneGrid
from auralize.runtime import numba_passes
from auralize.runtime.jit import kernel_args
line = tuple(float(v) for v in range(12))
grid = LaneGrid(343.0, 1 / 343.0, 0.0, 8000.0, 1 / 8000.0, 100.0, 64.0, 1 / 64.0, 0, 4, 0, 4.0)
hermite._cut_at_end((1.0, 2.0, 3.0, 0.1, 0.5, 0.2, 0.4, 0.1), 11.0, True, line, line, 1.0, grid)
gains._gains_called((1.0, 0.5, 0.2), (1.0, 0.0, 0.0, 0.0, 0.0, 1.0), np.zeros(2),
                    np.arange(2), False, np.zeros((1, 4)), np.zeros(2))
tn = np.linspace(0.0, 0.2, 5)
lt = np.array([0.0, 0.1, 0.2])
arrivals._row_lines(*kernel_args(tn, lt, np.zeros((3, 3)), np.zeros((2, 3)), 343.0, 5.0, 0, 4,
                                 np.zeros((5, 2 * arrivals._LINE + 1))))
tracks = warmup._tiny_tracks()
_synth_tables.sounding_pieces(tracks, _synth_prepare.knot_times(tracks), "cubic")
_synth_tables.sounding_runs(tracks, _synth_prepare.knot_times(tracks), "cubic")
state = numba_passes.apply()
print("FAST" if all(state.values()) else "NUMBA" if not any(state.values()) else state)
for k in (hermite._cut_at_end, gains._gains_called, arrivals._row_lines, tables.build_pieces,
          tables.find_runs, tables.fill_runs):
    print(k.inspect_llvm(k.signatures[0]))
"""


def _child(code: str, tmp_path, **env: str) -> str:  # type: ignore[no-untyped-def]
    """Standard output of ``code`` run by a fresh interpreter with its own kernel cache."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), **env}
    res = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    return res.stdout


def _process_names(ir: str) -> str:
    """``ir`` with the names that differ from process to process made equal: those of
    constants named after an object's address (pickled exceptions, parallel regions)."""
    import re

    # (LLVM adds .1, .2 ... to a name already taken: after the address, or after .sha1)
    ir = re.sub(r"(pickledata|picklebuf)\.\d+(\.sha1)?(\.\d+)?", r"\1.N\2", ir)
    return re.sub(r"0x[0-9a-f]{6,}", "0xN", ir)


def test_fast_passes_compile_numbas_code(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The inliner without its deep copies and the SSA pass by blocks give numba's LLVM
    IR, line for line (the same string hashes: PYTHONHASHSEED fixed)."""
    fast = _child(_IR_CHILD, tmp_path / "fast", PYTHONHASHSEED="0")
    own = _child(_IR_CHILD, tmp_path / "numba", AURALIZE_FAST_COMPILE="0", PYTHONHASHSEED="0")
    fast, own = _process_names(fast), _process_names(own)
    assert fast.startswith("FAST\n") and own.startswith("NUMBA\n")
    fast, own = fast.split("\n", 1)[1], own.split("\n", 1)[1]
    for name in ("_cut_at_end", "_gains_called", "_row_lines", "build_pieces", "fill_runs"):
        assert name in fast
    assert len(fast) > 10_000
    assert fast == own


def test_fast_passes_apply_to_the_numba_installed() -> None:
    """The installed numba (0.60 to 0.68.1, the versions checked) gets both passes."""
    import numba.core.inline_closurecall as icc
    import numba.core.ssa as ssa

    assert numba_passes.refusal("inlining") is None and numba_passes.refusal("ssa") is None
    assert numba_passes.apply() == {"inlining": True, "ssa": True}
    assert icc.InlineWorker.inline_function is numba_passes._inline_function
    assert ssa._run_ssa is numba_passes._run_ssa


def test_numba_versions_outside_those_checked_keep_numbas_passes() -> None:
    lo, hi = numba_passes.VERIFIED_NUMBA
    assert lo == (0, 60, 0) and hi >= (0, 68, 1)
    for version in ("0.60.0", "0.64.0", "0.68.1"):
        assert numba_passes.refusal("inlining", version) is None
        assert numba_passes.refusal("ssa", version) is None
    for version in ("0.59.1", "0.68.2", "0.69.0rc1", "0.70.0", "1.0.0", "unknown"):
        for name in ("inlining", "ssa"):
            why = numba_passes.refusal(name, version)
            assert why is not None and "outside the versions checked" in why, (version, why)
    assert numba_passes.numba_version("0.69.0rc1") == (0, 69, 0)
    assert numba_passes.numba_version("0.61.0dev0+12.g1234abc") == (0, 61, 0)
    assert numba_passes.numba_version("dev") is None


def test_changed_numba_internals_keep_numbas_passes(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """A numba function the replacements rely on with another source, or a digest the
    list does not hold, refuses the replacement."""
    import numba.core.ssa as ssa

    def _fix_ssa_vars(blocks, varname, defmap, cfg, df_plus, cache_list_vars):  # type: ignore[no-untyped-def]
        return blocks

    monkeypatch.setattr(ssa, "_fix_ssa_vars", _fix_ssa_vars)
    why = numba_passes.refusal("ssa")
    assert why is not None and "numba.core.ssa:_fix_ssa_vars is not the source checked" in why
    assert numba_passes.refusal("inlining") is None
    monkeypatch.undo()
    name = "numba.core.inline_closurecall:InlineWorker.inline_ir"
    monkeypatch.setitem(numba_passes.NUMBA_SOURCES["inlining"], name, frozenset({"0" * 16}))
    why = numba_passes.refusal("inlining")
    assert why is not None and name in why


#: a numba of another version (or other internals), then the kernel modules' set-up
_REFUSED_CHILD = """
import numba
import numba.core.inline_closurecall as icc
import numba.core.ssa as ssa
if CHANGE == "version":
    numba.__version__ = "0.69.0"
else:
    inline_ir = icc.InlineWorker.inline_ir
    icc.InlineWorker.inline_ir = lambda *a, **k: inline_ir(*a, **k)
    steps = ssa._run_block_rewrite
    ssa._run_block_rewrite = lambda *a: steps(*a)
from auralize.emitters._kernels import gains
from auralize.runtime import numba_passes
print(icc.InlineWorker.inline_function is numba_passes._inline_function,
      ssa._run_ssa is numba_passes._run_ssa, numba_passes.apply())
"""


@pytest.mark.parametrize("change", ["version", "internals"])
def test_kernel_modules_keep_numbas_passes_where_unchecked(change, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The check runs when a kernel module is imported (the compiler is set up before any
    kernel compiles)."""
    out = _child(f"CHANGE = {change!r}\n" + _REFUSED_CHILD, tmp_path)
    assert out.split() == ["False", "False", "{'inlining':", "False,", "'ssa':", "False}"]


def test_where_selects_without_a_branch() -> None:
    from auralize.emitters._kernels.common import where

    @numba.njit
    def pick(c, a, b):  # type: ignore[no-untyped-def]
        return where(c, a, b), where(a > b, 1, 2.5), where(c, 3, 4)

    assert pick(True, 1.0, 2.0) == (1.0, 2.5, 3)
    assert pick(False, 3.0, 2.0) == (2.0, 1.0, 4)
    assert numba.typeof(pick(True, 1.0, 2.0)[2]) == numba.int64
    ir = pick.inspect_llvm(pick.signatures[0])
    assert "select i1" in ir  # LLVM's select, from the intrinsic


def test_compile_seconds_are_measured_data(monkeypatch, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The notice's estimates come from the shipped measurements, not from code text;
    a missing or broken file gives the default."""
    import json

    seconds = jit.compile_seconds()
    assert seconds, "auralize/data/compile_seconds.json lists no kernel"
    data = json.loads(jit.COMPILE_SECONDS_FILE.read_text())
    assert data["seconds"] == seconds and data["measured_on"]
    groups = jit.group_compile_seconds()
    assert set(groups) == set(warmup.GROUPS) and all(v > 0.0 for v in groups.values())
    for kernel in (
        "auralize.emitters._kernels.render_pieces.render_task",
        "auralize.emitters._kernels.render_runs.render_task",
        "auralize.emitters._kernels.sampled.render",
    ):
        assert seconds[kernel] > 0.0
    assert (
        jit.estimate_seconds("auralize.emitters._kernels.render_pieces.render_task")
        == (seconds["auralize.emitters._kernels.render_pieces.render_task"])
    )
    bad = tmp_path / "broken.json"
    bad.write_text("{not json")
    monkeypatch.setattr(jit, "COMPILE_SECONDS_FILE", bad)
    jit.compile_seconds.cache_clear()
    try:
        assert jit.compile_seconds() == {}
        assert jit.estimate_seconds("auralize.emitters._kernels.tables.fill_runs") >= (
            jit.DEFAULT_SECONDS
        )
    finally:
        monkeypatch.undo()
        jit.compile_seconds.cache_clear()


def test_waiting_for_a_background_compile_is_announced(caplog, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """A kernel that another process compiles is waited for, with a notice of what is
    left of its estimate at the share of a core that process gets while this one
    waits (measured over the first PROBE_SECONDS); the wait is recorded."""
    import time

    @numba.njit
    def kernel(x):  # type: ignore[no-untyped-def]
        return x

    name = f"{kernel.py_func.__module__}.{kernel.py_func.__qualname__}"
    monkeypatch.setitem(jit.compile_seconds(), name, 40.0)

    class Proc:
        """A background compile that ends when joined without a timeout."""

        def __init__(self, cpu: float | None = None, share: float = 1.0) -> None:
            self.joined = False
            self.t0 = time.monotonic()
            if cpu is not None:  # it has used ``cpu`` CPU-s and gets ``share`` of a core
                self.cpu_seconds = lambda: cpu + share * (time.monotonic() - self.t0)

        def is_alive(self) -> bool:
            return not self.joined

        def join(self, timeout: float | None = None) -> None:
            time.sleep(0.05 if timeout is None else timeout)
            self.joined = timeout is None

    def notice(kernel: object, proc: Proc, expected: float | None = None, ago: float = 0.0) -> str:
        """The one notice of a wait for ``kernel`` that ``proc`` compiles."""
        fn = kernel.py_func  # type: ignore[attr-defined]
        if expected is not None:
            proc.expected_cpu = expected  # type: ignore[attr-defined]
        jit.compiling_elsewhere([f"{fn.__module__}.{fn.__qualname__}"], proc)
        jit._BACKGROUND[-1] = (*jit._BACKGROUND[-1][:2], time.monotonic() - ago)
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="auralize"):
            jit.await_kernel(kernel)
        assert proc.joined
        msgs = [r.getMessage() for r in caplog.records if "in another process" in r.getMessage()]
        assert len(msgs) == 1, msgs
        return msgs[0]

    monkeypatch.setattr(jit, "_BACKGROUND", [])
    monkeypatch.setattr(jit._NOTICE, "notices", [])
    monkeypatch.setattr(jit._NOTICE, "waits", [])
    # a process that does not tell its CPU time, started 15 s ago: the estimate less that
    assert notice(kernel, Proc(), ago=15.0).startswith("compiling kernels, once: ~25 s")
    with caplog.at_level(logging.WARNING, logger="auralize"):
        jit.await_kernel(kernel)  # done: no second wait
    assert [n for n, _ in jit.compile_notices()] == [name]
    waits = jit.compile_waits()
    assert [n for n, _ in waits] == [name] and waits[0][1] >= jit.PROBE_SECONDS + 0.05
    # one that tells its CPU time (30 of 40 used, a whole core now): about 10 s left
    kernel2 = numba.njit(lambda x: x + 1)
    fn2 = kernel2.py_func
    monkeypatch.setitem(jit.compile_seconds(), f"{fn2.__module__}.{fn2.__qualname__}", 40.0)
    msg = notice(kernel2, Proc(cpu=30.0), ago=40.0)
    assert msg.startswith("compiling kernels, once: ~10 s"), msg
    # ... and one that knows what its groups take: that less what it has used
    kernel3 = numba.njit(lambda x: x + 2)
    msg = notice(kernel3, Proc(cpu=30.0), expected=50.0, ago=40.0)
    assert msg.startswith("compiling kernels, once: ~20 s"), msg
    # ... on a loaded machine, at the share of a core it gets: half of one
    kernel4 = numba.njit(lambda x: x + 3)
    msg = notice(kernel4, Proc(cpu=10.0, share=0.5), expected=30.0, ago=20.0)
    assert msg.startswith("compiling kernels, once: ~40 s"), msg
    # ... and near its end: what is left, not a fixed minimum at a starved share
    kernel5 = numba.njit(lambda x: x + 4)
    msg = notice(kernel5, Proc(cpu=49.0, share=1.0), expected=50.0, ago=200.0)
    assert msg.startswith("compiling kernels, once: ~1 s"), msg


def test_compile_ahead_starts_only_what_is_not_cached(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """The groups not cached are compiled by a fresh interpreter (``python -c``: the
    calling script is not imported again), on this process's module path."""
    import subprocess
    import sys

    started: list[tuple[list[str], dict[str, str]]] = []

    class Popen:
        def __init__(self, cmd, env, **kw) -> None:  # type: ignore[no-untyped-def]
            started.append((cmd, env))

        def poll(self) -> int:
            return 0

    monkeypatch.setattr(subprocess, "Popen", Popen)
    monkeypatch.setattr(jit, "_BACKGROUND", [])  # (the fake process is forgotten after)
    monkeypatch.setattr(warmup, "group_cached", lambda g: g == "runs")
    proc = warmup.compile_ahead(["pieces", "runs"])
    assert isinstance(proc, warmup.Background) and not proc.is_alive()
    [(cmd, env)] = started
    assert cmd[:2] == [sys.executable, "-c"]
    assert "_compile_quietly(['pieces'])" in cmd[2]
    assert env["PYTHONPATH"].split(os.pathsep) == [p for p in sys.path if p]
    assert [sorted(names) for names, _, _ in jit._BACKGROUND] == [
        ["auralize.emitters._kernels.render_pieces.render_task"]
    ]
    monkeypatch.setattr(warmup, "group_cached", lambda g: True)
    assert warmup.compile_ahead(["pieces", "runs"]) is None and len(started) == 1


def test_a_background_compile_is_stopped_at_exit() -> None:
    import subprocess
    import sys

    proc = warmup.Background(
        subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    )
    assert proc.is_alive()
    used = proc.cpu_seconds()
    assert used is not None and 0.0 <= used < 60.0  # (Linux: from /proc)
    proc.stop()  # (what compile_ahead registers with atexit)
    assert not proc.is_alive() and proc.popen.returncode != 0
    proc.stop()  # ended: nothing to do
