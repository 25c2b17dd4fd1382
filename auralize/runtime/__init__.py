"""Process-wide machinery below every other package: numba set-up, caches, resources,
progress, lazy exports, safe file output and the notebook displays.

* :mod:`auralize.runtime.jit` — numba settings and the kernel cache;
* :mod:`auralize.runtime.allocator` — glibc's allocator tuned for large temporary arrays;
* :mod:`auralize.runtime.cache` — the one cache directory (``AURALIZE_CACHE_DIR``);
* :mod:`auralize.runtime.resources` — memory and disk checks before allocating;
* :mod:`auralize.runtime.progress` — progress bars and callbacks;
* :mod:`auralize.runtime.lazy` — lazy package exports (PEP 562);
* :mod:`auralize.runtime.files` — atomic writes, paired files, ParaView collections;
* :mod:`auralize.runtime.json_check` — bounded JSON reading and schema checks;
* :mod:`auralize.runtime.hdf5safe` — HDF5 files that read other files, refused;
* :mod:`auralize.runtime.vtkcompat` — VTK names that moved between supported releases;
* :mod:`auralize.runtime.timing` — wall-time helpers of benchmark rows;
* :mod:`auralize.runtime.entrypoints` — entry-point groups loaded once;
* :mod:`auralize.runtime.notebook` — rich notebook displays of the core objects.

Compiling the kernels ahead of use is :mod:`auralize.warmup`, above the engine
it runs.
"""
