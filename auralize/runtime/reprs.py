"""Short text reprs: a title line and a few aligned ``key  value`` rows, as xarray's.

The core types (:class:`~auralize.volume.TimeVolume`,
:class:`~auralize.sources.detection.SourceSeries`, ...) print a summary of what
they hold — grid, times, fields, counts, layout, rate, duration — never their
arrays, so a console or a log stays readable whatever the data's size.

Examples
--------
>>> print(summary("TimeVolume dataset:pulse", [("grid", "8 × 8 × 8"), ("times", "4 steps")]))
<TimeVolume dataset:pulse>
  grid   8 × 8 × 8
  times  4 steps
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

__all__ = ["counts_text", "number", "span", "summary"]


def summary(title: str, rows: Iterable[tuple[str, str]]) -> str:
    """``<title>`` then one line per ``(key, value)`` row, the values aligned."""
    rows = [(k, v) for k, v in rows if v != ""]
    width = max((len(k) for k, _ in rows), default=0)
    return "\n".join([f"<{title}>", *(f"  {k:<{width}}  {v}" for k, v in rows)])


def number(value: float) -> str:
    """A number in 4 significant digits (``1.235e+04``, ``0.1``)."""
    return f"{value:.4g}"


def span(values: Sequence[float], unit: str = "s") -> str:
    """``first – last unit`` of a sorted sequence (``–`` when empty)."""
    if len(values) == 0:
        return "–"
    first, last = float(values[0]), float(values[-1])
    return (
        f"{number(first)} {unit}" if first == last else f"{number(first)} – {number(last)} {unit}"
    )


def counts_text(counts: dict[str, int]) -> str:
    """``monopole 12, dipole 3, quadrupole 0`` with thousands separators."""
    return ", ".join(f"{k} {v:,}" for k, v in counts.items())
