"""Process-wide machinery: numba set-up, caches, resources, progress, lazy exports.

* :mod:`auralize.runtime.jit` — numba settings and the kernel cache;
* :mod:`auralize.runtime.allocator` — glibc's allocator tuned for large temporary arrays;
* :mod:`auralize.runtime.cache` — the one cache directory (``AURALIZE_CACHE_DIR``);
* :mod:`auralize.runtime.resources` — memory and disk checks before allocating;
* :mod:`auralize.runtime.progress` — progress bars and callbacks;
* :mod:`auralize.runtime.lazy` — lazy package exports (PEP 562);
* :mod:`auralize.runtime.warmup` — compiling the kernels ahead of use.
"""
