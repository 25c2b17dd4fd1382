"""numba settings of auralize's compiled kernels, applied when a kernel module is imported.

Every kernel module (``auralize.sources._kernels``, the modules of
``auralize.emitters._kernels`` and the plugins' kernels) calls :func:`configure`
before it defines its kernels, so ``import auralize`` changes nothing in the
process; the first use of a kernel does:

* ``OMP_WAIT_POLICY=passive`` unless the user set it: numba's OpenMP threads
  sleep, not spin, between parallel regions (on a shared or small machine, and
  with the viewer's GUI, audio and worker threads, spinning workers steal the
  cores the other threads need).  It must be set before numba's threading
  layer starts, which happens at the first parallel kernel call.
* One cache directory for the compiled kernels of auralize and its plugins:
  ``NUMBA_CACHE_DIR`` when set, otherwise ``numba/`` in auralize's cache
  folder (``$AURALIZE_CACHE_DIR``, default ``~/.cache/auralize``; see
  :mod:`auralize.runtime.cache`).  The same place serves an editable checkout,
  an installed wheel (whose ``site-packages`` may be read-only) and Dask
  worker processes.
* glibc's allocator keeps the memory of a render's large temporary arrays for
  the next one instead of unmapping it (:mod:`auralize.runtime.allocator`;
  ``AURALIZE_MALLOC_TUNING=0`` leaves it alone).
* A notice when kernels are compiled rather than loaded from that cache
  (``compiling kernels, once: ~N s (kernel; cache: ...)``), logged as a
  warning on the ``auralize`` logger, so ``-q`` silences it: at the first
  compile, and again as each of the large synthesis kernels starts, with N
  measured for what is compiling (:func:`compile_seconds`).  ``auralize warmup``
  compiles them ahead (``scripts/install.sh`` runs it).
* One specialization per kernel: :func:`kernel_args` at each kernel's Python
  boundary gives every call the same argument types.
* Two of numba's compiler passes in time linear in a kernel's size, not
  quadratic: the inliner of ``inline="always"`` helpers (:func:`fast_inlining`)
  and the SSA reconstruction (:func:`fast_ssa`).  The compiled code is the same
  (``AURALIZE_FAST_INLINE=0`` leaves numba's own passes); the cold compile of
  the synthesis kernels takes a third of the time.
"""

from __future__ import annotations

import copy as _copy
import functools
import hashlib
import json
import logging
import os
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from numba.core import event, ir

log = logging.getLogger("auralize")

#: measured compile times, shipped with the package (:func:`compile_seconds`)
COMPILE_SECONDS_FILE = Path(__file__).resolve().parent.parent / "data" / "compile_seconds.json"


@functools.cache
def compile_seconds() -> dict[str, float]:
    """Seconds to compile each kernel (``module.name``) from an empty cache, on one core.

    Measured, not written down by hand: :func:`auralize.warmup.measure_compile_seconds`
    compiles every kernel group of ``auralize warmup`` from an empty cache, each in
    a process of its own, and writes the CPU seconds of every kernel compiled at top
    level (helpers compiled as part of one count 0) to :data:`COMPILE_SECONDS_FILE`
    (``auralize/data/compile_seconds.json``, with the machine and versions it was
    measured on).  Refresh it on the 2-core development machine when a kernel
    changes (``python -c "from auralize.warmup import measure_compile_seconds;
    measure_compile_seconds()"``); ``auralize bench`` compares the compile notice's
    estimates with a cold compile (row ``compile``).  Kernels it does not list (the
    plugins') count :data:`DEFAULT_SECONDS`.  Only :func:`estimate_seconds` (the compile
    notice) reads it.
    """
    try:
        data = json.loads(COMPILE_SECONDS_FILE.read_text())
        return {str(k): float(v) for k, v in data["seconds"].items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}


DEFAULT_SECONDS = 2.0
#: a kernel at least this dear (seconds) is announced on its own when it starts compiling
NOTICE_AGAIN_SECONDS = 10.0

_configured = False
_lock = threading.Lock()


#: the core kernel modules, relative to the package: their functions are inlined into
#: kernels of other modules (the synthesis kernels are split by stage over
#: ``emitters/_kernels/``, with the emitters engine's; the plugins use its gains), and
#: numba's cache of a module does not notice a change in a module it inlines from
KERNEL_SOURCES: tuple[str, ...] = (
    "sources/_kernels.py",
    *sorted(
        f"emitters/_kernels/{f.name}"
        for f in (Path(__file__).resolve().parent.parent / "emitters" / "_kernels").glob("*.py")
    ),
)


def kernel_digest(root: Path | None = None) -> str:
    """Short digest of :data:`KERNEL_SOURCES` under ``root`` (default: this package),
    which names the cache folder of those sources."""
    root = Path(__file__).resolve().parent.parent if root is None else Path(root)
    h = hashlib.sha256()
    for rel in KERNEL_SOURCES:
        f = root / rel
        h.update(rel.encode())
        h.update(f.read_bytes() if f.is_file() else b"")
    return h.hexdigest()[:12]


def cache_dir() -> Path:
    """The folder of the compiled kernels: ``NUMBA_CACHE_DIR``, else
    ``numba/<digest>`` in :func:`auralize.runtime.cache.cache_root`
    (``$AURALIZE_CACHE_DIR``, ``~/.cache/auralize``).

    ``<digest>`` is :func:`kernel_digest`: when a core kernel changes (an
    upgrade, a checkout of another version) every kernel that may have inlined
    it compiles again instead of loading stale machine code.
    """
    env = os.environ.get("NUMBA_CACHE_DIR")
    if env:
        return Path(env)
    from auralize.runtime.cache import cache_root

    return cache_root() / "numba" / kernel_digest()


def configure() -> None:
    """Apply the settings above once per process (idempotent, thread-safe)."""
    global _configured
    with _lock:
        if _configured:
            return
        _configured = True
        os.environ.setdefault("OMP_WAIT_POLICY", "passive")
        from auralize.runtime.allocator import tune

        tune()
        import numba

        config: Any = numba.config
        if not config.CACHE_DIR:
            config.CACHE_DIR = str(cache_dir())
        event.register("numba:compile", _NOTICE)
        if os.environ.get("AURALIZE_FAST_INLINE", "1") != "0":
            fast_inlining()
            fast_ssa()


_INLINE_TLS = threading.local()


class _InlinerCopy:
    """The ``copy`` module as :mod:`numba.core.inline_closurecall` sees it once
    :func:`fast_inlining` is applied: ``deepcopy`` of an IR block returns the block
    itself while a callee's freshly built IR is spliced in, and is the standard
    deep copy otherwise."""

    def __getattr__(self, name: str) -> Any:
        return getattr(_copy, name)

    @staticmethod
    def deepcopy(x: Any, memo: Any = None) -> Any:
        if getattr(_INLINE_TLS, "fresh", False) and isinstance(x, ir.Block):
            return x
        return _copy.deepcopy(x, memo)


def _inline_function(
    self: Any, caller_ir: Any, block: Any, i: int, function: Any, arg_typs: Any = None
) -> tuple[Any, ...]:
    """numba's ``InlineWorker.inline_function`` (the ``inline="always"`` inliner) without
    copying the callee's IR, which it has just built for this call site alone.  The first
    item, the callee's IR before the splice, is ``None`` (numba's caller ignores it)."""
    callee_ir = self.run_untyped_passes(function)
    _INLINE_TLS.fresh = True
    try:
        out = self.inline_ir(
            caller_ir, block, i, callee_ir, function.__code__.co_freevars, arg_typs=arg_typs
        )
    finally:
        _INLINE_TLS.fresh = False
    return (None, *out[1:])


def fast_inlining() -> bool:
    """Splice ``inline="always"`` callees into their callers in linear time; returns
    whether the change applies to the installed numba.

    numba's inliner builds the callee's IR afresh for every call site (its untyped
    passes), then deep-copies it twice before splicing it in, one block at a time; the
    copy of every block drags a copy of the callee's whole variable scope along, so an
    inlined function costs its blocks × its variables, and nested inlined helpers
    (the synthesis kernels' SIMD loops are built of them) most of a kernel's cold
    compile.  The copies guard IR that is used again; the IR of this call site is not
    (the inliner of ``@overload`` functions, whose IR is cached, still copies).  The
    compiled code is the same, instruction for instruction (tested).

    Applied by :func:`configure` unless ``AURALIZE_FAST_INLINE=0``, and only when numba's
    inliner is the one described (its source is checked): a numba that changes it keeps
    its own.
    """
    import inspect

    import numba.core.inline_closurecall as icc

    worker = icc.InlineWorker
    if worker.inline_function is _inline_function:
        return True
    try:
        fn_src = inspect.getsource(worker.inline_function)
        ir_src = inspect.getsource(worker.inline_ir)
    except (OSError, TypeError):
        return False
    fresh = "callee_ir = self.run_untyped_passes(function)" in fn_src
    copies = "copy.deepcopy(the_ir.blocks[block_label])" in ir_src
    if not (fresh and copies and getattr(icc, "copy", None) is _copy):
        return False
    icc.copy = _InlinerCopy()  # type: ignore[assignment]
    worker.inline_function = _inline_function  # type: ignore[method-assign]
    return True


def _rewrite_blocks(blocks: Any, states: Any, handler: Any, labels: Any) -> Any:
    """numba's ``ssa._run_block_rewrite`` over the blocks ``labels`` only; the other
    blocks, which do not mention the variable being renamed, keep their statements
    (as its handlers leave them)."""
    from numba.core import ssa

    newblocks = {}
    for label, blk in blocks.items():
        newblk = ir.Block(scope=blk.scope, loc=blk.loc)
        if label in labels:
            states["label"] = label
            states["block"] = blk
            newblk.body = list(ssa._run_ssa_block_pass(states, blk, handler))
        else:
            newblk.body = list(blk.body)
        newblocks[label] = newblk
    return newblocks


def _run_ssa(blocks: Any) -> Any:
    """numba's ``ssa._run_ssa`` (SSA reconstruction, one variable assigned more than once
    at a time) with each variable's two passes over the blocks that mention it, not
    over the whole function: the same renamed variables and phi nodes, in time
    linear in the function instead of in its size times its reassigned variables."""
    from collections import defaultdict

    from numba.core import errors, ssa

    if not blocks:
        return {}
    cfg = ssa.compute_cfg_from_blocks(blocks)
    df_plus = ssa._iterated_domfronts(cfg)
    violators = ssa._find_defs_violators(blocks, cfg)
    cache_list_vars = ssa._CacheListVars()
    mentioned: dict[str, set[Any]] = {name: set() for name in violators}
    for label, blk in blocks.items():
        for stmt in blk.body:
            for var in cache_list_vars.get(stmt):
                where = mentioned.get(var.name)
                if where is not None:
                    where.add(label)
    for varname in violators:
        labels = mentioned[varname]
        # fresh variables for every assignment to it ...
        states = ssa._make_states(blocks)
        states["varname"] = varname
        states["defmap"] = defmap = defaultdict(list)
        blocks = _rewrite_blocks(blocks, states, ssa._FreshVarHandler(), labels)
        # ... and every use taken to its reaching definition (phi nodes where needed)
        states = ssa._make_states(blocks)
        states["varname"] = varname
        states["defmap"] = defmap
        states["phimap"] = phimap = defaultdict(list)
        states["cfg"] = cfg
        states["phi_locations"] = ssa._compute_phi_locations(df_plus, defmap)
        blocks = _rewrite_blocks(blocks, states, ssa._FixSSAVars(cache_list_vars), labels)
        for label, philist in phimap.items():
            blocks[label].body = philist + blocks[label].body
    if ssa.compute_cfg_from_blocks(blocks) != cfg:
        raise errors.CompilerError("CFG mutated in SSA pass")
    return blocks


def fast_ssa() -> bool:
    """Rebuild SSA form in time linear in a function's size; returns whether the change
    applies to the installed numba.

    numba turns every variable assigned more than once (a loop's accumulator, a
    value clamped in place, every such variable of every inlined copy of a helper)
    into single assignments one variable at a time, each time rewriting every
    statement of the function: its size times its reassigned variables, a sixth
    to a third of the frontend's time on the synthesis kernels.  Here each
    variable's rewrite visits the blocks that mention it (those numba's own
    rewrite changes: it acts on the variables a statement lists, nothing else).
    The compiled code is the same, instruction for instruction (tested).

    Applied by :func:`configure` with :func:`fast_inlining` (``AURALIZE_FAST_INLINE=0``
    leaves both off), and only when numba's SSA pass is the one described.
    """
    import inspect

    from numba.core import ssa

    if ssa._run_ssa is _run_ssa:
        return True
    try:
        src = inspect.getsource(ssa._run_ssa)
        fix_src = inspect.getsource(ssa._fix_ssa_vars)
    except (OSError, TypeError):
        return False
    expected = (
        "blocks, defmap = _fresh_vars(blocks, varname)" in src
        and "_fix_ssa_vars(blocks, varname, defmap, cfg, df_plus" in src
        and "_run_block_rewrite(blocks, states, _FixSSAVars(cache_list_vars))" in fix_src
        and all(
            hasattr(ssa, n)
            for n in (
                "_iterated_domfronts",
                "_find_defs_violators",
                "_CacheListVars",
                "_make_states",
                "_FreshVarHandler",
                "_FixSSAVars",
                "_compute_phi_locations",
                "_run_ssa_block_pass",
            )
        )
    )
    if not expected:
        return False
    ssa._run_ssa = _run_ssa
    return True


def _kernel_name(event_data: Any) -> str | None:
    disp = (event_data or {}).get("dispatcher")
    func = getattr(disp, "py_func", None)
    mod = getattr(func, "__module__", "") or ""
    if not (mod == "auralize" or mod.startswith(("auralize.", "auralize_"))):
        return None
    return f"{mod}.{func.__qualname__}"  # type: ignore[union-attr]


class _CompileNotice(event.Listener):
    """numba event listener: a notice when auralize kernels compile.

    The first compile in the process is announced with the estimate of its
    module's uncached kernels (:func:`estimate_seconds`); after it, each kernel
    whose own estimate is at least :data:`NOTICE_AGAIN_SECONDS` once more, when
    it starts (once per kernel, not per specialization).

    ``compiled`` lists ``(kernel, seconds)`` of every top-level compilation of
    an auralize kernel in this process (``auralize warmup`` reports them; the
    CPU seconds of the compiling thread, which a loaded machine does not
    inflate), ``helpers`` the auralize functions compiled as part of one,
    ``notices`` the ``(kernel, estimated seconds)`` announced.
    """

    def __init__(self) -> None:
        self.local = threading.local()
        self.announced = False
        self.named: set[str] = set()
        self.compiled: list[tuple[str, float]] = []
        self.helpers: set[str] = set()
        self.notices: list[tuple[str, float]] = []

    def on_start(self, ev: Any) -> None:
        stack = self.local.__dict__.setdefault("stack", [])
        if stack:
            helper = _kernel_name(ev.data)
            if helper is not None:
                self.helpers.add(helper)
        name = _kernel_name(ev.data) if not stack else None
        stack.append((name, time.thread_time()))
        if name is None or name in self.named:
            return
        if self.announced and compile_seconds().get(name, DEFAULT_SECONDS) < NOTICE_AGAIN_SECONDS:
            return
        self.announced = True
        self.named.add(name)
        short = ".".join(name.split(".")[-2:])  # module.kernel
        estimate = estimate_seconds(name)
        self.notices.append((name, estimate))
        log.warning(
            "compiling kernels, once: ~%d s (%s; cache: %s)", round(estimate), short, cache_dir()
        )

    def on_end(self, ev: Any) -> None:
        stack = self.local.__dict__.setdefault("stack", [])
        if stack:
            name, t0 = stack.pop()
            if name is not None:
                self.compiled.append((name, time.thread_time() - t0))


def compiled_kernels() -> list[tuple[str, float]]:
    """``(kernel, CPU seconds)`` of the auralize kernels compiled in this process so far."""
    return list(_NOTICE.compiled)


#: kernels being compiled into the cache by background processes: (kernel names, process)
_BACKGROUND: list[tuple[frozenset[str], Any]] = []


def compiling_elsewhere(kernels: Any, process: Any) -> None:
    """Note that ``process`` (with ``join()`` and ``is_alive()``) compiles ``kernels``
    (``module.name``) into the cache (:func:`auralize.warmup.compile_ahead`)."""
    _BACKGROUND.append((frozenset(kernels), process))


def await_kernel(kernel: Any) -> None:
    """Before the first call of ``kernel`` (a numba dispatcher) in this process: if a
    background process is compiling it, wait for that process, so that the kernel
    loads from the cache instead of compiling a second time (the other core is
    already on it)."""
    func = getattr(kernel, "py_func", None)
    if func is None or getattr(kernel, "overloads", None):
        return
    name = f"{func.__module__}.{func.__qualname__}"
    for names, process in list(_BACKGROUND):
        if name in names and process.is_alive():
            process.join()


def compile_notices() -> list[tuple[str, float]]:
    """``(kernel, estimated seconds)`` of the compile notices given in this process so far."""
    return list(_NOTICE.notices)


def compiled_helpers() -> list[str]:
    """The auralize functions compiled in this process as part of a kernel."""
    return sorted(_NOTICE.helpers)


def estimate_seconds(kernel: str) -> float:
    """Seconds to compile ``kernel`` (``module.name``), from :func:`compile_seconds`.

    A kernel of at least :data:`NOTICE_AGAIN_SECONDS` counts alone (it is
    announced alone); a cheaper one with the other cheap kernels of its module
    that have no cache index yet, as they tend to compile together (at least
    :data:`DEFAULT_SECONDS`).
    """
    import sys

    from numba.core.registry import CPUDispatcher

    table = compile_seconds()
    own = table.get(kernel, DEFAULT_SECONDS)
    if own >= NOTICE_AGAIN_SECONDS:
        return own
    modname = kernel.rsplit(".", 1)[0]
    mod = sys.modules.get(modname)
    total = own
    for name, obj in list(vars(mod).items()) if mod is not None else []:
        if not isinstance(obj, CPUDispatcher) or obj.py_func.__module__ != modname:
            continue
        full = f"{modname}.{name}"
        if full == kernel or obj.targetoptions.get("inline", "never") == "always":
            continue
        sec = table.get(full, DEFAULT_SECONDS)
        if sec >= NOTICE_AGAIN_SECONDS:
            continue
        cache_file = getattr(getattr(obj, "_cache", None), "_cache_file", None)
        index = getattr(cache_file, "_index_path", None)
        if index is not None and os.path.exists(index):
            continue
        total += sec
    return max(total, DEFAULT_SECONDS)


#: the one dtype of a kernel's arrays, by numpy dtype kind
_KERNEL_DTYPES: dict[str, type] = {"f": np.float64, "i": np.int64, "u": np.int64, "b": np.bool_}


def kernel_arg(x: Any) -> Any:
    """``x`` in the one form a compiled kernel's signature takes.

    numba compiles one specialization per distinct argument type, and an
    array's type includes its dtype, memory layout ('C' or 'A') and whether
    it is read-only; each specialization of a large kernel costs a cold
    compile of its own (tens of CPU-seconds to minutes).  So at the Python
    boundary of every kernel, arrays become C-contiguous, aligned, writable
    float64 (floating), int64 (integer) or bool, and numpy scalars Python
    ``float``/``int``/``bool``.  An array already in that form is returned
    itself (output arrays stay the caller's); otherwise it is copied (a
    float32 array is widened exactly).  Other objects pass unchanged.
    """
    if isinstance(x, np.ndarray):
        dt = _KERNEL_DTYPES.get(x.dtype.kind)
        if dt is None:
            raise TypeError(f"kernel arrays are floating, integer or bool, got {x.dtype}")
        a: np.ndarray[Any, Any] = np.ascontiguousarray(x, dtype=dt)
        if not (a.flags.writeable and a.flags.aligned):
            a = a.copy()
        return a
    if isinstance(x, bool | np.bool_):
        return bool(x)
    if isinstance(x, int | np.integer):
        return int(x)
    if isinstance(x, float | np.floating):
        return float(x)
    return x


def kernel_args(*args: Any) -> tuple[Any, ...]:
    """:func:`kernel_arg` of each argument: one compiled signature per kernel, whatever
    the dtype, layout or write flag of the arrays a caller passes."""
    return tuple(kernel_arg(a) for a in args)


_NOTICE = _CompileNotice()
