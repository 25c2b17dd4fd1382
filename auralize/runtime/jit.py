"""numba settings of auralize's compiled kernels, applied when a kernel module is imported.

Every kernel module (``auralize.sources._kernels``, ``auralize.emitters._synth_kernel``,
``auralize.emitters._runs_kernel`` and the plugins' kernels) calls :func:`configure`
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
  (``compiling kernels, once: ~N s``), logged as a warning on the
  ``auralize`` logger, so ``-q`` silences it.  ``auralize warmup`` compiles
  them ahead (``scripts/install.sh`` runs it).
"""

from __future__ import annotations

import hashlib
import logging
import os
import threading
import time
from pathlib import Path
from typing import Any

from numba.core import event

log = logging.getLogger("auralize")

#: CPU seconds to compile each kernel from a cold cache (measured with
#: ``auralize warmup`` on the 2-core development machine; numba compiles on one
#: core).  Helpers compiled as part of a listed kernel count 0; kernels not
#: listed count :data:`_DEFAULT_SECONDS`.
COMPILE_SECONDS: dict[str, float] = {
    "auralize.emitters._synth_kernel.render": 170.0,
    "auralize.emitters._runs_kernel.render": 55.0,
    "auralize.emitters._sampled._render": 47.0,
    **dict.fromkeys(
        [
            f"auralize.emitters._synth_kernel.{k}"
            for k in (
                "_flush_captures",
                "_chunk_pieces",
                "_chunk_pair_gains",
                "_chunk_sh_gains",
                "_piece_general",
                "_piece_across",
                "_integrate",
                "_task_sum",
                "_part_pair_gains",
                "_chunk_parts",
                "_part_batch",
                "_pan_far",
                "_constant_rows",
            )
        ],
        0.0,
    ),
    "auralize.emitters._runs_kernel._chunk_step": 0.0,
    "auralize.emitters._runs_kernel._knot_gains": 0.0,
}
_DEFAULT_SECONDS = 2.0

_configured = False
_lock = threading.Lock()


#: the core kernel modules, relative to the package: their functions are inlined into
#: kernels of other modules (``_sampled`` and the plugins use ``_synth_kernel``'s gains),
#: and numba's cache of a module does not notice a change in a module it inlines from
KERNEL_SOURCES = ("sources/_kernels.py", "emitters/_synth_kernel.py",
                  "emitters/_runs_kernel.py", "emitters/_sampled.py")  # fmt: skip


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


def _kernel_name(event_data: Any) -> str | None:
    disp = (event_data or {}).get("dispatcher")
    func = getattr(disp, "py_func", None)
    mod = getattr(func, "__module__", "") or ""
    if not (mod == "auralize" or mod.startswith(("auralize.", "auralize_"))):
        return None
    return f"{mod}.{func.__qualname__}"  # type: ignore[union-attr]


class _CompileNotice(event.Listener):
    """numba event listener: one notice per process when auralize kernels compile.

    ``compiled`` lists ``(kernel, seconds)`` of every top-level compilation of
    an auralize kernel in this process (``auralize warmup`` reports them).
    """

    def __init__(self) -> None:
        self.local = threading.local()
        self.announced = False
        self.compiled: list[tuple[str, float]] = []

    def on_start(self, ev: Any) -> None:
        stack = self.local.__dict__.setdefault("stack", [])
        name = _kernel_name(ev.data) if not stack else None
        stack.append((name, time.perf_counter()))
        if name is not None and not self.announced:
            self.announced = True
            est = estimate_seconds()
            log.warning("compiling kernels, once: ~%d s (cache: %s)", round(est), cache_dir())

    def on_end(self, ev: Any) -> None:
        stack = self.local.__dict__.setdefault("stack", [])
        if stack:
            name, t0 = stack.pop()
            if name is not None:
                self.compiled.append((name, time.perf_counter() - t0))


def compiled_kernels() -> list[tuple[str, float]]:
    """``(kernel, seconds)`` of the auralize kernels compiled in this process so far."""
    return list(_NOTICE.compiled)


def estimate_seconds() -> float:
    """Seconds to compile the kernels that the cache lacks (from :data:`COMPILE_SECONDS`).

    Counts the kernels (not the inlined helpers) of the loaded kernel modules
    that have no cache index yet; at least :data:`_DEFAULT_SECONDS`.
    """
    import sys

    from numba.core.registry import CPUDispatcher

    total = 0.0
    for modname, mod in list(sys.modules.items()):
        if mod is None or not modname.startswith(("auralize.", "auralize_")):
            continue
        for name, obj in list(vars(mod).items()):
            if not isinstance(obj, CPUDispatcher) or obj.py_func.__module__ != modname:
                continue
            if obj.targetoptions.get("inline", "never") == "always":
                continue
            cache_file = getattr(getattr(obj, "_cache", None), "_cache_file", None)
            index = getattr(cache_file, "_index_path", None)
            if index is not None and os.path.exists(index):
                continue
            total += COMPILE_SECONDS.get(f"{modname}.{name}", _DEFAULT_SECONDS)
    return max(total, _DEFAULT_SECONDS)


_NOTICE = _CompileNotice()
