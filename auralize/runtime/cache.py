"""The one cache folder of auralize: compiled kernels and pre-computed sound textures.

``$AURALIZE_CACHE_DIR`` when set, otherwise ``$XDG_CACHE_HOME/auralize``
(``~/.cache/auralize``).  It holds ``numba/`` (the compiled kernels, see
:mod:`auralize.runtime.jit`; numba's own ``NUMBA_CACHE_DIR`` wins for them
when set), the vortex textures and ``aero/``.  Deleting it costs only time.
"""

from __future__ import annotations

import os
from pathlib import Path

ENV = "AURALIZE_CACHE_DIR"


def cache_root() -> Path:
    """``$AURALIZE_CACHE_DIR``, else ``$XDG_CACHE_HOME/auralize``, else ``~/.cache/auralize``."""
    env = os.environ.get(ENV)
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "auralize"
