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
  quadratic, where numba's version and sources are those they were checked
  against (:mod:`auralize.runtime.numba_passes`: the inliner of
  ``inline="always"`` helpers and the SSA reconstruction; the same compiled
  code, ``AURALIZE_FAST_COMPILE=0`` keeps numba's own passes).
"""

from __future__ import annotations

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
from numba.core import event

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


@functools.cache
def group_compile_seconds() -> dict[str, float]:
    """CPU seconds of each kernel group of ``auralize warmup`` compiled from an empty
    cache in a process of its own (its helpers and the imports it triggers included),
    from the same measurement as :func:`compile_seconds`."""
    try:
        data = json.loads(COMPILE_SECONDS_FILE.read_text())
        return {str(k): float(v) for k, v in data["groups_cpu_seconds"].items()}
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
        from auralize.runtime import numba_passes

        numba_passes.apply()


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
    ``notices`` the ``(kernel, estimated seconds)`` announced (by :func:`await_kernel`
    too), ``waits`` the ``(kernel, wall seconds)`` waited for a background compile.
    """

    def __init__(self) -> None:
        self.local = threading.local()
        self.announced = False
        self.named: set[str] = set()
        self.compiled: list[tuple[str, float]] = []
        self.helpers: set[str] = set()
        self.notices: list[tuple[str, float]] = []
        self.waits: list[tuple[str, float]] = []

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


#: kernels being compiled into the cache by background processes: (kernel names, process,
#: when it started: ``time.monotonic()``)
_BACKGROUND: list[tuple[frozenset[str], Any, float]] = []


def compiling_elsewhere(kernels: Any, process: Any) -> None:
    """Note that ``process`` (with ``join(timeout=None)`` and ``is_alive()``), started
    now, compiles ``kernels`` (``module.name``) into the cache
    (:func:`auralize.warmup.compile_ahead`)."""
    _BACKGROUND.append((frozenset(kernels), process, time.monotonic()))


#: seconds a wait for a background compile watches that process before announcing
#: it: the share of a core it gets while this process waits is measured, not guessed
PROBE_SECONDS = 0.25
#: the least CPU seconds a background compile that has not ended is expected to need
LEAST_LEFT_SECONDS = 1.0


def _cpu_share(process: Any, started: float) -> tuple[float | None, float]:
    """CPU seconds ``process`` has used and the share of a core it gets now: over
    :data:`PROBE_SECONDS` of this process's wait when it tells its CPU time (its
    ``cpu_seconds()``; the waiting process leaves a core to it), else its wall time
    since it started, at one core.  The share is held within 0.1 and 1."""
    cpu: Any = getattr(process, "cpu_seconds", None)
    before = cpu() if cpu is not None else None
    t0 = time.monotonic()
    process.join(timeout=PROBE_SECONDS)
    if before is None:
        return None, 1.0
    after = cpu() if process.is_alive() else None
    if after is None:
        return before, 1.0
    return after, min(max((after - before) / max(time.monotonic() - t0, 1e-3), 0.1), 1.0)


def await_kernel(kernel: Any) -> None:
    """Before the first call of ``kernel`` (a numba dispatcher) in this process: if a
    background process is compiling it, wait for that process, so that the kernel
    loads from the cache instead of compiling a second time (the other core is
    already on it).

    A wait longer than :data:`PROBE_SECONDS` is announced as a compile is
    (``compiling kernels, once: ~N s (kernel, in another process; ...)``): what the
    process is expected to use (its ``expected_cpu``, else the kernel's estimate)
    less the CPU time it has used (its ``cpu_seconds()``), at the share of a core it
    gets while this process waits (measured over the first :data:`PROBE_SECONDS`);
    a process that does not tell its CPU time counts its wall time since it started,
    at one core.  :func:`compile_waits` lists the waits."""
    func = getattr(kernel, "py_func", None)
    if func is None or getattr(kernel, "overloads", None):
        return
    name = f"{func.__module__}.{func.__qualname__}"
    for names, process, started in list(_BACKGROUND):
        if name not in names or not process.is_alive():
            continue
        t0 = time.monotonic()
        total = getattr(process, "expected_cpu", None) or estimate_seconds(name)
        used, share = _cpu_share(process, started)
        if process.is_alive():
            if used is None:
                used = time.monotonic() - started
            left = max(total - used, LEAST_LEFT_SECONDS) / share
            _NOTICE.notices.append((name, left))
            _NOTICE.named.add(name)
            short = ".".join(name.split(".")[-2:])
            log.warning(
                "compiling kernels, once: ~%d s (%s, in another process; cache: %s)",
                round(left),
                short,
                cache_dir(),
            )
            process.join()
        _NOTICE.waits.append((name, time.monotonic() - t0))


def compile_waits() -> list[tuple[str, float]]:
    """``(kernel, wall seconds)`` this process waited for kernels compiling in a
    background process (:func:`await_kernel`)."""
    return list(_NOTICE.waits)


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
    :data:`DEFAULT_SECONDS`).  Of those others only the measured ones count: a
    kernel the warm-up never compiles (none of the commands' paths uses it)
    is not compiled with them either.
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
        sec = table.get(full, 0.0)
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
#: those dtypes (native byte order)
_KERNEL_FORMS = frozenset(np.dtype(t) for t in (np.float64, np.int64, np.bool_))


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
        flags = x.flags
        if x.dtype in _KERNEL_FORMS and flags.c_contiguous and flags.writeable and flags.aligned:
            return x  # (the usual case, first: every kernel call passes here)
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
    return tuple(map(kernel_arg, args))


_NOTICE = _CompileNotice()
