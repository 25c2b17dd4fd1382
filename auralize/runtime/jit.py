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
  from :data:`COMPILE_SECONDS` for what is compiling.  ``auralize warmup``
  compiles them ahead (``scripts/install.sh`` runs it).
* One specialization per kernel: :func:`kernel_args` at each kernel's Python
  boundary gives every call the same argument types.
"""

from __future__ import annotations

import copy as _copy
import hashlib
import logging
import os
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from numba.core import event, ir

log = logging.getLogger("auralize")

COMPILE_SECONDS: dict[str, float] = {
    # the synthesis kernels, each announced on its own
    "auralize.emitters._kernels.render_pieces.render": 170.0,
    "auralize.emitters._kernels.render_runs.render": 65.0,
    "auralize.emitters._sampled._render": 45.0,
    # detection and field sources
    **{f"auralize.sources._kernels.{k}": v for k, v in (
        ("_error_stencil", 3.5), ("residual", 2.3), ("_stencil", 2.0), ("_radii", 1.9),
        ("_floor_with", 1.6), ("gradient", 1.4), ("_gradient_absmax_planes", 1.3),
        ("subtract_steady", 0.9), ("prepare_render", 0.9), ("_classify_all", 0.8),
        ("_absmax_pair_planes", 1.1), ("_max_along_x", 0.5))},
    # run and piece tables
    "auralize.emitters._sampled._box": 0.8,
    "auralize.emitters._kernels.tables.find_runs": 0.6,
    "auralize.emitters._kernels.tables.fill_runs": 0.4,
    "auralize.emitters._kernels.tables.build_pieces": 0.5,
    # helpers compiled as part of a kernel above
    **dict.fromkeys(
        [f"auralize.emitters._kernels.{k}" for k in (
            "accumulate._flush_captures", "accumulate._integrate", "accumulate._integrate_tasks",
            "pieces._chunk_pieces", "pieces._piece_general", "pieces._piece_across",
            "lane_gains._chunk_pair_gains", "lane_gains._chunk_sh_gains",
            "lane_gains._part_pair_gains", "parts._chunk_parts", "parts._part_batch",
            "gains._pan_far", "gains._constant_rows", "arrivals._row_lines",
            "render_pieces._task_sum", "render_runs._chunk_step", "render_runs._knot_gains")],
        0.0,
    ),
}  # fmt: skip
"""Seconds to compile each kernel (``module.name``) from an empty cache, one core.

Measured, not guessed: ``NUMBA_CACHE_DIR=$(mktemp -d) auralize warmup --json``
lists the seconds of every kernel it compiled (``compiled``); refresh these
from it on the 2-core development machine (quiet, load below 1) whenever a
kernel grows or shrinks by more than a third.  Helpers compiled as part of a
listed kernel count 0; kernels not listed (the plugins') count
:data:`DEFAULT_SECONDS`.  Only :func:`estimate_seconds` (the compile
notice) reads them.
"""
DEFAULT_SECONDS = 2.0
#: a kernel at least this dear (seconds) is announced on its own when it starts compiling
NOTICE_AGAIN_SECONDS = 10.0

_configured = False
_lock = threading.Lock()


#: the core kernel modules, relative to the package: their functions are inlined into
#: kernels of other modules (the synthesis kernels are split by stage over
#: ``emitters/_kernels/``; ``_sampled`` and the plugins use its gains), and numba's
#: cache of a module does not notice a change in a module it inlines from
KERNEL_SOURCES: tuple[str, ...] = (
    "sources/_kernels.py",
    *sorted(
        f"emitters/_kernels/{f.name}"
        for f in (Path(__file__).resolve().parent.parent / "emitters" / "_kernels").glob("*.py")
    ),
    "emitters/_sampled.py",
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


def _inline_function(self: Any, caller_ir: Any, block: Any, i: int, function: Any,
                     arg_typs: Any = None) -> tuple[Any, ...]:  # fmt: skip
    """numba's ``InlineWorker.inline_function`` (the ``inline="always"`` inliner) without
    copying the callee's IR, which it has just built for this call site alone.  The first
    item, the callee's IR before the splice, is ``None`` (numba's caller ignores it)."""
    callee_ir = self.run_untyped_passes(function)
    _INLINE_TLS.fresh = True
    try:
        out = self.inline_ir(caller_ir, block, i, callee_ir, function.__code__.co_freevars,
                             arg_typs=arg_typs)  # fmt: skip
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
    worker.inline_function = _inline_function
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
    an auralize kernel in this process (``auralize warmup`` reports them).
    """

    def __init__(self) -> None:
        self.local = threading.local()
        self.announced = False
        self.named: set[str] = set()
        self.compiled: list[tuple[str, float]] = []

    def on_start(self, ev: Any) -> None:
        stack = self.local.__dict__.setdefault("stack", [])
        name = _kernel_name(ev.data) if not stack else None
        stack.append((name, time.perf_counter()))
        if name is None or name in self.named:
            return
        if self.announced and COMPILE_SECONDS.get(name, DEFAULT_SECONDS) < NOTICE_AGAIN_SECONDS:
            return
        self.announced = True
        self.named.add(name)
        short = ".".join(name.split(".")[-2:])  # module.kernel
        log.warning("compiling kernels, once: ~%d s (%s; cache: %s)", round(estimate_seconds(name)),
                    short, cache_dir())  # fmt: skip

    def on_end(self, ev: Any) -> None:
        stack = self.local.__dict__.setdefault("stack", [])
        if stack:
            name, t0 = stack.pop()
            if name is not None:
                self.compiled.append((name, time.perf_counter() - t0))


def compiled_kernels() -> list[tuple[str, float]]:
    """``(kernel, seconds)`` of the auralize kernels compiled in this process so far."""
    return list(_NOTICE.compiled)


def estimate_seconds(kernel: str) -> float:
    """Seconds to compile ``kernel`` (``module.name``), from :data:`COMPILE_SECONDS`.

    A kernel of at least :data:`NOTICE_AGAIN_SECONDS` counts alone (it is
    announced alone); a cheaper one with the other cheap kernels of its module
    that have no cache index yet, as they tend to compile together (at least
    :data:`DEFAULT_SECONDS`).
    """
    import sys

    from numba.core.registry import CPUDispatcher

    own = COMPILE_SECONDS.get(kernel, DEFAULT_SECONDS)
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
        sec = COMPILE_SECONDS.get(full, DEFAULT_SECONDS)
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
