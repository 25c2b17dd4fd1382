"""Compile the numba kernels ahead, so that the first real command runs at full speed.

The kernels are compiled on first use and kept in one cache folder
(:func:`auralize.runtime.jit.cache_dir`: ``NUMBA_CACHE_DIR``, else
``~/.cache/auralize/numba``).  From a cold cache the synthesis kernels alone
take minutes of one core (the piece-wise synthesis kernel is one large
parallel function with its helpers inlined); :func:`warmup` runs a tiny
detection and tiny renders through the public pipeline so that exactly the
specializations the commands use are compiled and cached.
``scripts/install.sh`` runs it (``auralize warmup``) as a visible step; a
warm cache makes it take a few seconds.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np


def warmup(*, plugins: bool = False) -> dict[str, Any]:
    """Compile (or load from the cache) the kernels of the core pipeline.

    Parameters
    ----------
    plugins : bool
        Also the kernels of the shipped sound-model plugins (fire, spark,
        vortex), through their smallest runs.

    Returns
    -------
    dict
        ``seconds`` (wall time), ``compiled`` (list of ``(kernel, seconds)``
        compiled in this call; empty when the cache was warm), ``cache`` (folder).
    """
    from auralize.runtime.jit import cache_dir, compiled_kernels, configure

    configure()
    before = len(compiled_kernels())
    t0 = time.perf_counter()

    from auralize.datasets.synthetic import make_dataset
    from auralize.listener import ListenerPath
    from auralize.pipeline import auralize, detect_sources

    vol = make_dataset("explosion", size=12, steps=4, seed=0).load()
    series = detect_sources(vol)
    centre = np.asarray(vol.center, dtype=np.float64)
    path = ListenerPath.orbit(centre, radius=3.0, duration=0.05, turns=0.1)
    point = ListenerPath.point(centre + 2.0, duration=0.05)
    # mono uses the run-sweep kernel, the panned layouts the piece-wise one;
    # cubic and linear interpolation share their specializations
    for layout, p in (("mono", point), ("mono", path), ("ring8", path), ("5.1", path)):
        auralize(vol, p, layout=layout, series=series, rate=8000, time_scale=1.0, timbre="physical")
    # the emitters engine's sampled kernel (one specialization serves every layout)
    from auralize.emitters import Emitters
    from auralize.emitters.engine import render_emitters

    render_emitters(Emitters(np.ones((1, 80)), 8000, centre[None]), point, rate=8000)

    if plugins:
        _warm_plugins()
    return {
        "seconds": time.perf_counter() - t0,
        "compiled": compiled_kernels()[before:],
        "cache": str(cache_dir()),
    }


def _warm_plugins() -> None:
    from auralize_fire import FireSound, make_fire
    from auralize_spark import simulate
    from auralize_vortex import TextureConfig, compute_texture

    FireSound().synthesize(make_fire(size=12, steps=12), extend="none")
    simulate(preset="plasma-ball", seed=1)
    compute_texture(TextureConfig(speeds=(5.0, 10.0), size=8, duration=0.02))
