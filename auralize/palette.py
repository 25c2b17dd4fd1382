"""THE colours of the source types, shared by every picture of them (the bottom layer:
it imports nothing of auralize, so the notebook displays, the sources files, the
off-screen pictures, the plots and the viewer all take their colours from here).

Examples
--------
>>> from auralize.palette import PALETTE, type_rgb
>>> PALETTE["dipole"]
(55, 126, 184)
>>> type_rgb(np.array([1, 3])).tolist()
[[228, 26, 28], [77, 175, 74]]
"""

from __future__ import annotations

import numpy as np

__all__ = ["PALETTE", "type_rgb"]

#: THE palette of the source types (ColorBrewer Set1), RGB 0..255: the viewer, off-screen
#: pictures, plots and the ``rgb`` array of a ``.pvd`` export all use it
PALETTE: dict[str, tuple[int, int, int]] = {
    "monopole": (228, 26, 28),
    "dipole": (55, 126, 184),
    "quadrupole": (77, 175, 74),
}


def type_rgb(kind: np.ndarray) -> np.ndarray:
    """``(N, 3)`` uint8 palette colours of type codes ``kind`` (0 = none: black).

    Examples
    --------
    >>> type_rgb(np.array([1, 3])).tolist()
    [[228, 26, 28], [77, 175, 74]]
    """
    lut = np.array([(0, 0, 0), *PALETTE.values()], dtype=np.uint8)
    return lut[np.asarray(kind, dtype=np.int64)]
