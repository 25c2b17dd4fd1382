"""The comparisons every regression check makes: which figure moved, and by how much.

Shared by the user's regression (:mod:`auralize.regression.user`, ``auralize
regress``, the ``auralize_regression`` pytest fixture) and the project's own
(:mod:`auralize.regression.synthetic`, :mod:`auralize.regression.real`).  Each
function returns the :class:`Moved` figures, one per figure beyond its
tolerance, named so that a reader knows where to look (``counts step 4
monopole``, ``level window 2 (2.5–3.75 s)``).

Examples
--------
>>> [str(m) for m in count_changes([{"monopole": 10}], [{"monopole": 30}], rel=0.05,
...                                types=("monopole",))]
['counts step 0 monopole: 10 vs expected 30 (moved by -20; tolerance ±2)']
>>> db_change("level", 86.0, 80.0, tol_db=1.0).by
'+6.00 dB'
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Moved",
    "count_changes",
    "db_change",
    "image_rms",
    "relative_change",
    "spectral_centroid",
    "step_change",
]

TYPES = ("monopole", "dipole", "quadrupole")


@dataclass(frozen=True)
class Moved:
    """A figure beyond its tolerance.

    ``figure`` names it, ``group`` is the kind of figure (``counts``,
    ``onset``, ``level`` ...: the key of its tolerance), ``got`` and
    ``expected`` its values, ``by`` how much it moved and ``tolerance`` what
    was allowed, both as text with units.
    """

    group: str
    figure: str
    got: Any
    expected: Any
    by: str
    tolerance: str

    def __str__(self) -> str:
        return (
            f"{self.figure}: {_show(self.got)} vs expected {_show(self.expected)} "
            f"(moved by {self.by}; tolerance {self.tolerance})"
        )

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _show(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def spectral_centroid(x: NDArray[np.floating], rate: int) -> float:
    """Power-weighted mean frequency (Hz) of a signal ``(n,)``, or of several
    ``(n_channels, n)`` together (their power spectra summed); Hann window.

    Examples
    --------
    >>> t = np.arange(8000) / 8000
    >>> round(spectral_centroid(np.sin(2 * np.pi * 440 * t), 8000))
    440
    """
    a = np.atleast_2d(np.asarray(x, dtype=np.float64))
    spec = np.sum(np.abs(np.fft.rfft(a * np.hanning(a.shape[1]), axis=1)) ** 2, axis=0)
    f = np.fft.rfftfreq(a.shape[1], 1 / rate)
    return float(np.sum(f * spec) / np.sum(spec))


def count_changes(
    got: Sequence[dict[str, int]],
    expected: Sequence[dict[str, int]],
    *,
    rel: float,
    at_least: int = 2,
    types: Sequence[str] = TYPES,
    what: str = "counts",
) -> list[Moved]:
    """Per-step source counts beyond ``max(at_least, rel × expected)`` points; a
    different number of steps is one moved figure (``counts steps``)."""
    if len(got) != len(expected):
        return [
            Moved(
                what,
                f"{what} steps",
                len(got),
                len(expected),
                f"{len(got) - len(expected):+d} steps",
                "the same number of steps",
            )
        ]
    out = []
    for n, (a, b) in enumerate(zip(got, expected, strict=True)):
        for k in types:
            ga, eb = int(a.get(k, 0)), int(b.get(k, 0))
            allowed = max(at_least, rel * eb)
            if abs(ga - eb) > allowed:
                out.append(
                    Moved(what, f"{what} step {n} {k}", ga, eb, f"{ga - eb:+d}", f"±{allowed:.3g}")
                )
    return out


def step_change(
    figure: str, got: int | None, expected: int | None, *, tol: int, group: str = "onset"
) -> Moved | None:
    """A step index (an onset, an end) that moved more than ``tol`` steps (None: never)."""
    if got is None and expected is None:
        return None
    if got is None or expected is None:
        return Moved(
            group,
            figure,
            "never" if got is None else f"step {got}",
            "never" if expected is None else f"step {expected}",
            "appeared or vanished",
            f"±{tol} steps",
        )
    if abs(got - expected) > tol:
        return Moved(
            group,
            figure,
            f"step {got}",
            f"step {expected}",
            f"{got - expected:+d} steps",
            f"±{tol} steps",
        )
    return None


def relative_change(
    group: str,
    figure: str,
    got: float,
    expected: float,
    *,
    rtol: float,
    atol: float = 0.0,
    unit: str = "",
) -> Moved | None:
    """``got`` beyond ``rtol × |expected| + atol`` of ``expected`` (NaN equals NaN only)."""
    g, e = float(got), float(expected)
    if math.isnan(g) and math.isnan(e):
        return None
    if not (math.isnan(g) or math.isnan(e)) and abs(g - e) <= rtol * abs(e) + atol:
        return None
    rel = (g - e) / abs(e) if e and not math.isnan(g) else math.nan
    u = f" {unit}" if unit else ""
    if math.isnan(g) or math.isnan(e):
        by = "from or to nothing (silence)"
    elif math.isfinite(rel):
        by = f"{g - e:+.4g}{u} ({100 * rel:+.2f} %)"
    else:
        by = f"{g - e:+.4g}{u}"
    return Moved(
        group, figure, g, e, by, f"±{100 * rtol:g} %" + (f" + {atol:g}{u}" if atol else "")
    )


def db_change(
    figure: str, got: float, expected: float, *, tol_db: float, group: str = "level"
) -> Moved | None:
    """A level (dB) that moved more than ``tol_db`` (−inf, silence, equals −inf only).

    Examples
    --------
    >>> db_change("level", 80.4, 80.0, tol_db=1.0) is None
    True
    """
    g, e = float(got), float(expected)
    if g == e:  # both silent included
        return None
    if math.isfinite(g) and math.isfinite(e) and abs(g - e) <= tol_db:
        return None
    by = f"{g - e:+.2f} dB" if math.isfinite(g - e) else "from or to silence"
    return Moved(group, figure, g, e, by, f"±{tol_db:g} dB")


def image_rms(a: str | Path | NDArray[Any], b: str | Path | NDArray[Any]) -> float:
    """RMS difference of two RGB images, in 0..255 levels per channel (inf when their
    sizes differ).

    Examples
    --------
    >>> x = np.zeros((4, 4, 3), np.uint8)
    >>> image_rms(x, x + 2)
    2.0
    """
    ia, ib = _rgb(a), _rgb(b)
    if ia.shape != ib.shape:
        return math.inf
    return float(np.sqrt(np.mean((ia - ib) ** 2)))


def _rgb(img: str | Path | NDArray[Any]) -> NDArray[np.float64]:
    if isinstance(img, str | Path):
        from PIL import Image

        with Image.open(img) as im:
            return np.asarray(im.convert("RGB"), dtype=np.float64)
    return np.asarray(img, dtype=np.float64)[..., :3]
