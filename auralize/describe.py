"""Sources in words: what happens in the data, and what the listener hears when.

:func:`describe` turns the detected sources (:class:`~auralize.sources.detection.SourceSeries`)
and the plan of a render (:func:`auralize.pipeline.plan_render`: the listener,
the time scale and the travel time skipped) into text a screen reader can
read, and into rows for CSV and JSON.  ``auralize describe FILE``,
:func:`auralize.simple.Describe` and the viewer's Describe panel show it.

For every time step and source type it gives

* **what**: the type and how many grid points carry it;
* **where in the data**: the strength-weighted centre of those points in
  thirds of the data's box along each axis — x from *left* to *right*, y
  from *front* to *back* (the default listener looks along +y), z from
  *lower* to *upper* — so ``upper left front corner`` is the third of the
  box at large z, small x, small y; and how far the points spread;
* **where from the listener**: the distance and the direction (azimuth
  counter-clockwise from the listener's forward direction, as the
  loudspeaker layouts count it, and elevation) at the moment the step's
  sound arrives;
* **when it is heard**: the playback second at which sound emitted at the
  step's data time t from the centre x arrives, i.e. the root τ of
  ``t0 + lead + τ / time_scale − |L(τ) − x| / c0 = t`` — the render's own
  clock (docs/design.md: sample n is at data time
  ``t0 + lead + n / (rate · time_scale)``) with the travel time at c0;
* **how strong**: the level, in dB relative to the loudest, of the sound of
  that type's detected sources at the listener around that moment: each
  type's detected sources rendered along the plan's path by the one render
  (:func:`auralize.pipeline.render`; mono, physical timbre, no high-pass, at
  :data:`LEVEL_RATE` Hz), their mean square taken over the step's playback
  interval.

**Events** are the runs of steps in which a type has sources (runs apart by
at most :data:`MERGE_GAP` empty steps are one event): their onset and end in
data time and in playback time, their level (the mean square of the type's
sound over the event's playback span, relative to the loudest event), and
where they are at their loudest step.

Examples
--------
>>> from auralize.datasets.synthetic import make_monopole
>>> d = describe(make_monopole(size=12, steps=16).load(), listener=(0.9, 0.5, 0.5),
...              duration=1.0)
>>> [e.type for e in d.events]
['monopole']
>>> d.events[0].level_db
0.0
>>> print(d.text().splitlines()[0])
Sources in monopole (12 × 12 × 12 points, 16 steps, 0 .. 0.005 s)
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.constants import C0
from auralize.defaults import DEFAULTS, Interp, OrbitFace
from auralize.errors import ParameterError
from auralize.pipeline import (
    RenderPlan,
    detect_sources,
    format_data_time,
    heard_tracks,
    plan_render,
    render,
    volume_arg,
)
from auralize.sources.detection import TYPES, SourceSeries, Thresholds
from auralize.sources.field import parse_heard
from auralize.volume import TimeVolume

__all__ = [
    "FORMATS",
    "LEVEL_RATE",
    "MERGE_GAP",
    "Description",
    "Event",
    "StepRow",
    "arrival_times",
    "box_region",
    "describe",
    "direction_words",
]

#: sample rate of the per-type renders that give the levels, Hz (the lowest the engine takes)
LEVEL_RATE = 8000
#: runs of a type's steps apart by at most this many empty steps make one event
MERGE_GAP = 1
#: points spread (RMS distance from their centre) beyond this fraction of the box's
#: diagonal are "spread through the box"
SPREAD_FRACTION = 0.25
#: levels this far below the loudest (dB) are called inaudible
INAUDIBLE_DB = -100.0
#: output formats of :meth:`Description.render_as` (and ``auralize describe --format``)
FORMATS = ("text", "csv", "json")
#: playback-time samples of the listener path per second used to find arrival times
_ARRIVAL_GRID = 4096
_AXES = (("left", "", "right"), ("front", "", "back"), ("lower", "", "upper"))
_SECTORS = (
    "ahead",
    "ahead-left",
    "left",
    "behind-left",
    "behind",
    "behind-right",
    "right",
    "ahead-right",
)


@dataclass
class StepRow:
    """One source type at one time step (a row of the CSV).

    ``level_db`` is relative to the loudest row (None: the step's sound
    arrives outside the render, or the type is silent there); ``audio_time``
    the playback second the step's sound arrives (None when it arrives
    after the render's end).
    """

    step: int
    time: float
    type: str
    count: int
    x: float
    y: float
    z: float
    spread_m: float
    region: str
    distance_m: float
    azimuth_deg: float
    elevation_deg: float
    direction: str
    audio_time: float | None
    level_db: float | None


@dataclass
class Event:
    """A run of steps in which one type has sources (see the module docstring)."""

    type: str
    first_step: int
    last_step: int
    start: float
    end: float
    audio_start: float | None
    audio_end: float | None
    peak_step: int
    peak_count: int
    region: str
    distance_m: float
    direction: str
    level_db: float | None


@dataclass
class Description:
    """What :func:`describe` found: the plan, the events and the per-step rows.

    Attributes
    ----------
    source : str, the data's name.
    dims : (3,) points per axis; ``times`` (T,) data seconds; ``bounds`` (6,) m.
    physical_times : bool, the data have physical times (else frames).
    plan : dict, :meth:`auralize.pipeline.RenderPlan.as_dict` of the render described.
    heard : str, what that render hears (``--heard``).
    rows : list of StepRow, per step and type present.
    events : list of Event, sorted by playback onset.
    notes : list of str.
    """

    source: str
    dims: tuple[int, int, int]
    times: NDArray[np.float64]
    bounds: tuple[float, ...]
    physical_times: bool
    plan: dict[str, Any]
    heard: str
    rows: list[StepRow]
    events: list[Event]
    notes: list[str] = field(default_factory=list)

    def __str__(self) -> str:
        return self.text()

    def __repr__(self) -> str:
        return (
            f"<Description of {self.source}: {len(self.events)} event(s), "
            f"{len(self.rows)} step rows>"
        )

    def _t(self, seconds: float) -> str:
        return format_data_time(seconds, physical=self.physical_times)

    def text(self) -> str:
        """The description as plain sentences, one per line (for a screen reader)."""
        nx, ny, nz = self.dims
        t = self.times
        b = self.bounds
        p = self.plan
        lines = [
            f"Sources in {self.source} ({nx} × {ny} × {nz} points, {t.size} steps, "
            f"{t[0]:.4g} .. {t[-1]:.4g} s)",
            f"Box: x {b[0]:.4g} .. {b[1]:.4g} m (left to right), y {b[2]:.4g} .. {b[3]:.4g} m "
            f"(front to back), z {b[4]:.4g} .. {b[5]:.4g} m (lower to upper).",
            f"Listener: {p['listener']}; {p['time_mapping']}; the render lasts "
            f"{p['duration_s']:.3g} s of playback and starts "
            + (
                f"{self._t(p['lead_data_s'])} of data after the first step (the sound's "
                f"travel to the listener)."
                if p["lead_data_s"] > 0
                else "at the first step."
            ),
            f"Heard: {self.heard}. Levels are those of each type's detected sources at "
            f"the listener, in dB relative to the loudest.",
        ]
        lines += [n[:1].upper() + n[1:] for n in self.notes]
        if not self.events:
            lines.append("No sources were detected at any step.")
            return "\n".join(lines) + "\n"
        lines.append("")
        lines.append("What you will hear, in playback time:")
        for e in self.events:
            lines.append(f"  {_event_sentence(e, self)}")
        lines.append("")
        lines.append("Step by step:")
        lines += [f"  {s}" for s in self._ranges()]
        return "\n".join(lines) + "\n"

    def _ranges(self) -> list[str]:
        """Consecutive steps whose types, places and directions read the same, as one line."""
        by_step: dict[int, list[StepRow]] = {}
        for r in self.rows:
            by_step.setdefault(r.step, []).append(r)
        out: list[str] = []
        n, T = 0, self.times.size
        while n < T:
            sig = _signature(by_step.get(n, []))
            m = n
            while m + 1 < T and _signature(by_step.get(m + 1, [])) == sig:
                m += 1
            rows = [r for k in range(n, m + 1) for r in by_step.get(k, [])]
            steps = f"step {n}" if m == n else f"steps {n}–{m}"
            when = (
                f"data {self._t(self.times[n])}"
                if m == n
                else f"data {self._t(self.times[n])} .. {self._t(self.times[m])}"
            )
            heard = [r.audio_time for r in rows if r.audio_time is not None]
            if heard:
                a0, a1 = min(heard), max(heard)
                when += (
                    f", heard at {a0:.2f} s"
                    if a1 - a0 < 0.005
                    else f", heard {a0:.2f} .. {a1:.2f} s"
                )
            elif rows:
                when += ", not heard within the render"
            if not rows:
                out.append(f"{steps} ({when}): no sources.")
            else:
                parts = [
                    _range_phrase([r for r in rows if r.type == k])
                    for k in TYPES
                    if any(r.type == k for r in rows)
                ]
                out.append(f"{steps} ({when}): " + "; ".join(parts) + ".")
            n = m + 1
        return out

    def as_dict(self) -> dict[str, Any]:
        """Everything as JSON-ready data (None for levels and times that do not exist)."""
        return {
            "source": self.source,
            "dims": list(self.dims),
            "times": self.times.tolist(),
            "bounds": list(self.bounds),
            "physical_times": self.physical_times,
            "plan": self.plan,
            "heard": self.heard,
            "notes": list(self.notes),
            "events": [asdict(e) for e in self.events],
            "steps": [asdict(r) for r in self.rows],
        }

    def csv_text(self) -> str:
        """The per-step rows as CSV (one row per step and type present)."""
        buf = io.StringIO()
        names = list(StepRow.__dataclass_fields__)
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(names)
        for r in self.rows:
            w.writerow(["" if getattr(r, k) is None else _cell(getattr(r, k)) for k in names])
        return buf.getvalue()

    def render_as(self, fmt: str = "text") -> str:
        """The description in one of :data:`FORMATS`."""
        if fmt == "text":
            return self.text()
        if fmt == "csv":
            return self.csv_text()
        if fmt == "json":
            return json.dumps(self.as_dict(), indent=1) + "\n"
        raise ParameterError(f"description format must be one of {list(FORMATS)}, got {fmt!r}")

    def save(self, path: str | Path, fmt: str | None = None) -> Path:
        """Write the description (atomically); the format from ``fmt`` or the suffix
        (``.csv``, ``.json``, else text)."""
        from auralize.runtime.files import atomic_write

        path = Path(path)
        if fmt is None:
            fmt = {".csv": "csv", ".json": "json"}.get(path.suffix.lower(), "text")
        atomic_write(path, self.render_as(fmt).encode("utf-8"))
        return path

    def at_step(self, step: int) -> str:
        """One sentence about one step (the viewer reads it out as the time slider moves)."""
        rows = [r for r in self.rows if r.step == step]
        t = self._t(self.times[step])
        if not rows:
            return f"Step {step} (data {t}): no sources."
        heard = [r.audio_time for r in rows if r.audio_time is not None]
        when = f", heard at {min(heard):.2f} s" if heard else ", not heard within the render"
        return f"Step {step} (data {t}{when}): " + "; ".join(_range_phrase([r]) for r in rows) + "."


def _cell(v: Any) -> Any:
    return f"{v:.6g}" if isinstance(v, float) else v


def _signature(rows: list[StepRow]) -> tuple[Any, ...]:
    return tuple((r.type, r.region, r.direction) for r in rows)


def _plural(kind: str, n: int) -> str:
    return kind if n == 1 else f"{kind}s"


def _db(v: float | None) -> str:
    if v is None:
        return "not heard within the render"
    if v < INAUDIBLE_DB:
        return f"{v:.0f} dB (inaudible beside the loudest)"
    return f"{v:.1f} dB"


def _points(n: int) -> str:
    return "1 point" if n == 1 else f"{n} points"


def _range_phrase(rows: list[StepRow]) -> str:
    """``monopoles (up to 120 points) in the centre of the box, 45 m away, ahead, -3.0 dB``."""
    r0 = rows[0]
    most = max(r.count for r in rows)
    levels = [r.level_db for r in rows if r.level_db is not None]
    dist = [r.distance_m for r in rows]
    d = (
        f"{min(dist):.3g} m away"
        if max(dist) - min(dist) < 0.05 * max(dist)
        else f"{min(dist):.3g} .. {max(dist):.3g} m away"
    )
    count = _points(most) if len(rows) == 1 else f"up to {_points(most)}"
    size = 2 * max(r.spread_m for r in rows)
    over = (
        "" if r0.region.startswith("spread") or size <= 0 else f", spread over about {size:.2g} m"
    )
    return (
        f"{_plural(r0.type, most)} ({count}) {r0.region}{over}, {d}, {r0.direction}, "
        f"{_db(max(levels) if levels else None)}"
    )


def _event_sentence(e: Event, d: Description) -> str:
    kind = _plural(e.type, 2)
    if e.audio_start is None:
        when = "After the render ends (not heard)"
    else:
        when = f"At {e.audio_start:.2f} s"
    steps = (
        f"step {e.first_step}"
        if e.first_step == e.last_step
        else (f"steps {e.first_step}–{e.last_step}")
    )
    ends = (
        ""
        if e.audio_start is None or e.audio_end is None
        else f"; they end at {e.audio_end:.2f} s"
        if e.last_step > e.first_step
        else "; for one step"
    )
    if e.audio_start is not None and e.audio_end is None:
        ends = "; they last beyond the render's end"
    data = (
        f"data {d._t(e.start)}"
        if e.last_step == e.first_step
        else f"data {d._t(e.start)} .. {d._t(e.end)}"
    )
    return (
        f"{when}: {kind} ({steps}, {data}), up to {_points(e.peak_count)}, loudest "
        f"{e.region}, {e.distance_m:.3g} m away, {e.direction}, level {_db(e.level_db)}"
        f"{ends}."
    )


# ------------------------------------------------------------------ geometry in words
def box_region(
    points: NDArray[np.floating], bounds: Any, spread: NDArray[np.floating] | None = None
) -> list[str]:
    """Where each of ``points (N, 3)`` lies in the box ``bounds`` (6,), in words.

    Thirds of the box along each axis: x *left* / *right*, y *front* / *back*,
    z *lower* / *upper*; the middle third of an axis (and an axis of no
    extent) adds no word.  Points whose ``spread`` (m, RMS distance of the
    source points from their centre) exceeds :data:`SPREAD_FRACTION` of the
    box's diagonal are *spread through the box*.

    Examples
    --------
    >>> box_region(np.array([[0.1, 0.1, 0.9], [0.5, 0.5, 0.5], [0.9, 0.5, 0.5]]),
    ...            (0, 1, 0, 1, 0, 1), spread=np.array([0.0, 0.0, 0.5]))
    ['in the upper left front corner', 'at the centre of the box', 'spread through the box, mostly in its right part']
    """
    b = np.asarray(bounds, dtype=np.float64).reshape(3, 2)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    ext = b[:, 1] - b[:, 0]
    u = np.where(ext > 0, (p - b[:, 0]) / np.where(ext > 0, ext, 1.0), 0.5)
    third = np.clip(np.floor(u * 3), 0, 2).astype(int)  # 0, 1, 2 per axis
    wide = (
        np.zeros(p.shape[0], bool)
        if spread is None
        else np.asarray(spread) > SPREAD_FRACTION * float(np.linalg.norm(ext))
    )
    out = []
    for t, w in zip(third, wide, strict=True):
        words = " ".join(_AXES[a][t[a]] for a in (2, 0, 1) if _AXES[a][t[a]])
        kind = "corner" if words.count(" ") == 2 else "part"
        if w:
            out.append(
                "spread through the box" + (f", mostly in its {words} {kind}" if words else "")
            )
        elif not words:
            out.append("at the centre of the box")
        else:
            out.append(f"in the {words} {kind}" + (" of the box" if kind == "part" else ""))
    return out


def direction_words(
    azimuth_deg: NDArray[np.floating], elevation_deg: NDArray[np.floating]
) -> list[str]:
    """Directions in words: eight sectors of azimuth (counter-clockwise from ahead,
    90° is left), plus ``above`` / ``below`` beyond 30° of elevation.

    Examples
    --------
    >>> direction_words(np.array([0.0, 90.0, -135.0, 10.0]), np.array([0.0, 0.0, 0.0, 60.0]))
    ['ahead', 'left', 'behind-right', 'ahead, above']
    """
    az = np.asarray(azimuth_deg, dtype=np.float64)
    el = np.asarray(elevation_deg, dtype=np.float64)
    sector = np.round(np.mod(az, 360.0) / 45.0).astype(int) % 8
    out = []
    for s, e in zip(sector, el, strict=True):
        w = _SECTORS[s]
        if e > 30:
            w += ", above"
        elif e < -30:
            w += ", below"
        out.append(w)
    return out


def arrival_times(
    plan: RenderPlan,
    points: NDArray[np.floating],
    times: NDArray[np.floating],
    t0: float,
    *,
    c0: float = C0,
) -> NDArray[np.float64]:
    """Playback seconds at which sound emitted at ``points (N, 3)`` at data ``times (N,)``
    reaches the listener of ``plan`` (see the module docstring).

    The listener's emission clock ``g(τ) = t0 + lead + τ / time_scale − D(τ) / c0``
    rises monotonically with playback time τ (the listener is slower than
    sound), so the root is found on a grid of the path and interpolated;
    before the path's start and after its end the listener holds its place
    (then τ is exact).  A time past the render's end is kept (the caller
    decides what it means).

    Examples
    --------
    >>> from auralize.listener import ListenerPath
    >>> plan = RenderPlan(ListenerPath.point((343.0, 0, 0), duration=10.0), time_scale=2.0,
    ...                   duration=10.0, lead=0.0, auto=False, default_listener=False)
    >>> arrival_times(plan, np.zeros((1, 3)), np.array([1.0]), 0.0).round(6).tolist()
    [4.0]
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    te = np.asarray(times, dtype=np.float64).reshape(-1)
    ts, lead, path = plan.time_scale, plan.lead, plan.path
    if pts.shape[0] == 0:
        return np.zeros(0)
    m = int(min(max(_ARRIVAL_GRID * plan.duration, 256), 65536))
    tau = np.linspace(0.0, plan.duration, m)
    where = path.position_at(path.times[0] + tau)  # (M, 3)
    out = np.empty(te.size)
    chunk = max(1, (1 << 22) // m)
    for a in range(0, te.size, chunk):  # chunks of points bound the (points × grid) matrix
        p, t = pts[a : a + chunk], te[a : a + chunk]
        d = np.linalg.norm(where[None, :, :] - p[:, None, :], axis=2)  # (n, M)
        g = t0 + lead + tau[None, :] / ts - d / c0
        k = np.sum(g < t[:, None], axis=1)  # g is increasing along the grid
        lo = np.clip(k - 1, 0, m - 2)
        rows = np.arange(p.shape[0])
        g0, g1 = g[rows, lo], g[rows, lo + 1]
        frac = np.where(g1 > g0, (t - g0) / np.where(g1 > g0, g1 - g0, 1.0), 0.0)
        inside = tau[lo] + frac * (tau[lo + 1] - tau[lo])
        # outside the grid the listener stands at the path's first or last place
        before = (t - t0 - lead + d[:, 0] / c0) * ts
        after = (t - t0 - lead + d[:, -1] / c0) * ts
        out[a : a + chunk] = np.where(
            k == 0,
            np.minimum(before, 0.0),
            np.where(k >= m, np.maximum(after, plan.duration), inside),
        )
    return out


# ------------------------------------------------------------------ the description
def _type_stats(series: SourceSeries) -> dict[str, NDArray[np.float64]]:
    """Per (step, type): count, Σ|q|, centre and spread of the points (vectorized over
    every point of every step).  Arrays of shape (T, 3) ((T, 3, 3) for the centre)."""
    T = series.n_steps
    idx = [f.index for f in series.frames]
    kind = np.concatenate([f.kind for f in series.frames]) if idx else np.zeros(0, np.int8)
    step = np.repeat(np.arange(T), [i.size for i in idx])
    flat = np.concatenate(idx) if idx else np.zeros(0, np.int64)
    w = (
        np.abs(np.concatenate([f.strength * f.volume for f in series.frames]))
        if idx
        else np.zeros(0)
    )
    pos = series.positions(flat) if flat.size else np.zeros((0, 3))
    g = step * 3 + (kind.astype(np.int64) - 1)
    n = T * 3
    count = np.bincount(g, minlength=n).reshape(T, 3).astype(np.float64)
    wsum = np.bincount(g, weights=w, minlength=n)
    # points of zero strength still have a place: weigh them equally then
    wz = np.where(wsum[g] > 0, w, 1.0)
    wzs = np.bincount(g, weights=wz, minlength=n)
    sums = np.stack([np.bincount(g, weights=wz * pos[:, a], minlength=n) for a in range(3)], 1)
    c = sums / np.where(wzs > 0, wzs, 1.0)[:, None]
    r2 = np.bincount(g, weights=wz * np.sum((pos - c[g]) ** 2, axis=1), minlength=n)
    spread = np.sqrt(r2 / np.where(wzs > 0, wzs, 1.0))
    return {
        "count": count,
        "strength": wsum.reshape(T, 3),
        "centre": c.reshape(T, 3, 3),
        "spread": spread.reshape(T, 3),
    }


def _type_sound(
    series: SourceSeries,
    plan: RenderPlan,
    volume: TimeVolume,
    kind: str,
    *,
    interp: Interp,
    c0: float,
) -> NDArray[np.float64] | None:
    """The mono pressure (Pa) of ``kind``'s detected sources along the plan's path, at
    :data:`LEVEL_RATE` (None: no source of that type)."""
    from auralize.emitters import FieldSources, Sound

    tracks = heard_tracks(series, kind)
    if tracks.n_sources == 0:
        return None
    sound = Sound(
        [
            FieldSources(
                tracks,
                time_scale=plan.time_scale,
                lead=plan.lead,
                interp=interp,
                timbre="physical",
                bounds=volume.bounds,
            )
        ],
        name=kind,
    )
    out = render(
        sound,
        plan.path,
        rate=LEVEL_RATE,
        layout="mono",
        duration=plan.duration,
        c0=c0,
        highpass_hz=0.0,
    )
    return np.asarray(out.audio[0], dtype=np.float64)


def _mean_square(
    cs: NDArray[np.float64], a: NDArray[np.floating], b: NDArray[np.floating]
) -> NDArray[np.float64]:
    """Mean square of a signal between playback seconds ``a`` and ``b`` (arrays), from the
    cumulative sum ``cs`` of its squares (NaN where the span lies outside it)."""
    n = cs.size - 1
    ia = np.clip(np.floor(np.asarray(a) * LEVEL_RATE).astype(np.int64), 0, n)
    ib = np.clip(np.ceil(np.asarray(b) * LEVEL_RATE).astype(np.int64), 0, n)
    ib = np.maximum(ib, np.minimum(ia + 1, n))
    width = ib - ia
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(width > 0, (cs[ib] - cs[ia]) / np.where(width > 0, width, 1), np.nan)


def _runs(present: NDArray[np.bool_], gap: int) -> list[tuple[int, int]]:
    """``(first, last)`` of the runs of True in ``present``, runs apart by <= ``gap`` joined."""
    on = np.flatnonzero(present)
    if on.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(on) > gap + 1)
    starts = np.r_[on[0], on[breaks + 1]]
    ends = np.r_[on[breaks], on[-1]]
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def describe(  # noqa: PLR0913 (keyword-only options)
    volume: TimeVolume | str,
    *,
    series: SourceSeries | None = None,
    path: Any = None,
    listener: Any = None,
    duration: float | None = None,
    time_scale: float | str = DEFAULTS.time_scale,
    heard: str = DEFAULTS.heard,
    orbit_face: OrbitFace = DEFAULTS.orbit_face,
    c0: float = C0,
    mapping: str | None = None,
    thresholds: Thresholds | None = None,
    interp: Interp = DEFAULTS.interp,
    plan: RenderPlan | None = None,
    name: str | None = None,
    progress_bar: bool = False,
    **mapping_fields: str,
) -> Description:
    """Describe the sources of ``volume`` and what a render of it lets the listener hear.

    Parameters
    ----------
    volume : TimeVolume or str
        The data (a file name or ``"dataset:NAME"`` is opened).
    series : SourceSeries, optional
        Its detected sources (detected here with ``mapping``, ``thresholds``
        and ``mapping_fields`` otherwise, as ``auralize detect``).
    path, listener, duration, time_scale, heard, orbit_face, c0
        The render described, as :func:`auralize.pipeline.auralize` takes them:
        its plan (:func:`auralize.pipeline.plan_render`) places the listener
        (default: the orbit of ``auralize render``), the time scale and the
        travel time skipped.  ``heard`` matters for the plan only (the default
        orbit and the automatic time scale go around what is heard).
    interp : str
        Strength interpolation of the per-type renders that give the levels.
    plan : RenderPlan, optional
        A plan made already (the viewer's); then the options above that
        make one are not used.
    name : str, optional
        The data's name in the text (default: the file or dataset name given,
        else the volume's source).

    Returns
    -------
    Description
    """
    if name is None and isinstance(volume, str):
        name = volume
    volume = volume_arg(volume, "describe")
    if series is None:
        series = detect_sources(
            volume,
            mapping=mapping,
            thresholds=thresholds,
            progress_bar=progress_bar,
            **mapping_fields,
        )
    elif not isinstance(series, SourceSeries):
        raise ParameterError(
            f"series must be a SourceSeries (detect_sources makes one), got {type(series).__name__}"
        )
    if series.n_steps != volume.n_steps:
        raise ParameterError(
            f"the sources have {series.n_steps} steps, the data {volume.n_steps}; "
            f"give the sources detected in this volume"
        )
    hd = parse_heard(heard)
    if plan is None:
        planned = heard_tracks(series, hd) if hd.mode == "detected" else None
        plan = plan_render(
            volume,
            planned,
            path=path,
            listener=listener,
            duration=duration,
            time_scale=time_scale,
            c0=c0,
            face=orbit_face,
        )
    times = np.asarray(series.times, dtype=np.float64)
    t0 = float(times[0])
    T = times.size
    st = _type_stats(series)
    present = st["count"] > 0  # (T, 3)
    steps, kinds = np.nonzero(present)
    centres = st["centre"][steps, kinds]
    audio = arrival_times(plan, centres, times[steps], t0, c0=c0)
    # where the listener is, and faces, when each step's sound arrives
    tq = plan.path.times[0] + np.clip(audio, 0.0, plan.duration)
    where = plan.path.position_at(tq)
    fwd, up = plan.path.orientation_at(tq)
    v = centres - where
    dist = np.linalg.norm(v, axis=1)
    left = np.cross(up, fwd)
    az = np.degrees(np.arctan2(np.sum(v * left, axis=1), np.sum(v * fwd, axis=1)))
    el = np.degrees(np.arcsin(np.clip(np.sum(v * up, axis=1) / np.maximum(dist, 1e-300), -1, 1)))
    spread = st["spread"][steps, kinds]
    region = box_region(centres, volume.bounds, spread)
    inside = dist < spread
    direction = [
        ("around the listener" if i else w)
        for w, i in zip(direction_words(az, el), inside, strict=True)
    ]
    # the sound of each type at the listener: its mean square over each step's playback span
    half = np.gradient(times) * plan.time_scale / 2 if T > 1 else np.array([0.5])
    sounds = {
        k: _type_sound(series, plan, volume, k, interp=interp, c0=c0)
        for i, k in enumerate(TYPES)
        if present[:, i].any()
    }
    cums = {k: np.r_[0.0, np.cumsum(p**2)] for k, p in sounds.items() if p is not None}
    heard_ok = audio <= plan.duration
    ms = np.full(steps.size, np.nan)
    for i, k in enumerate(TYPES):
        sel = kinds == i
        if k in cums and sel.any():
            ms[sel] = _mean_square(
                cums[k], audio[sel] - half[steps[sel]], audio[sel] + half[steps[sel]]
            )
    ms = np.where(heard_ok, ms, np.nan)
    loud = np.nanmax(ms) if np.any(ms > 0) else np.nan
    with np.errstate(divide="ignore", invalid="ignore"):
        level = 10 * np.log10(ms / loud)
    rows = [
        StepRow(
            step=int(n),
            time=float(times[n]),
            type=TYPES[k],
            count=int(st["count"][n, k]),
            x=float(c[0]),
            y=float(c[1]),
            z=float(c[2]),
            spread_m=float(s),
            region=rg,
            distance_m=float(d),
            azimuth_deg=float(a),
            elevation_deg=float(e),
            direction=dw,
            audio_time=float(au) if ok else None,
            level_db=float(lv) if np.isfinite(lv) else None,
        )
        for n, k, c, s, rg, d, a, e, dw, au, ok, lv in zip(
            steps,
            kinds,
            centres,
            spread,
            region,
            dist,
            az,
            el,
            direction,
            audio,
            heard_ok,
            level,
            strict=True,
        )
    ]
    events = _events(rows, st, times, cums, half)
    notes = list(plan.notes)
    unavailable = series.meta.get("unavailable")
    if isinstance(unavailable, dict):
        by_reason: dict[str, list[str]] = {}
        for kind, why in unavailable.items():
            by_reason.setdefault(str(why), []).append(kind)
        notes += [f"No {' or '.join(k)} sources: {why}." for why, k in by_reason.items()]
    return Description(
        source=name or str(volume.attrs.get("dataset") or volume.source),
        dims=tuple(int(x) for x in volume.dims),  # type: ignore[arg-type]
        times=times,
        bounds=tuple(float(x) for x in volume.bounds),
        physical_times=bool(volume.physical_times),
        plan=plan.as_dict(),
        heard=hd.describe() + f" (render --heard {hd.label})",
        rows=rows,
        events=events,
        notes=notes,
    )


def _events(
    rows: list[StepRow],
    st: dict[str, NDArray[np.float64]],
    times: NDArray[np.float64],
    cums: dict[str, NDArray[np.float64]],
    half: NDArray[np.float64],
) -> list[Event]:
    """The events of the rows (see the module docstring), sorted by playback onset."""
    at = {(r.step, r.type): r for r in rows}
    events: list[Event] = []
    spans: list[tuple[str, float, float]] = []
    for i, k in enumerate(TYPES):
        for a, b in _runs(st["count"][:, i] > 0, MERGE_GAP):
            mine = [at[(n, k)] for n in range(a, b + 1) if (n, k) in at]
            lv = [r.level_db if r.level_db is not None else -np.inf for r in mine]
            peak = (
                mine[int(np.argmax(lv))]
                if np.isfinite(max(lv))
                else max(mine, key=lambda r: st["strength"][r.step, i])
            )
            heard = [r.audio_time for r in mine if r.audio_time is not None]
            first, last = mine[0], mine[-1]
            events.append(
                Event(
                    type=k,
                    first_step=a,
                    last_step=b,
                    start=float(times[a]),
                    end=float(times[b]),
                    audio_start=first.audio_time if heard else None,
                    audio_end=last.audio_time,
                    peak_step=peak.step,
                    peak_count=max(r.count for r in mine),
                    region=peak.region,
                    distance_m=peak.distance_m,
                    direction=peak.direction,
                    level_db=None,
                )
            )
            spans.append(
                (
                    k,
                    (min(heard) - half[a]) if heard else math.nan,
                    (max(heard) + half[b]) if heard else math.nan,
                )
            )
    ms = np.array(
        [
            _mean_square(cums[k], np.array([s0]), np.array([s1]))[0]
            if k in cums and np.isfinite(s0)
            else np.nan
            for k, s0, s1 in spans
        ]
    )
    if np.any(ms > 0):
        with np.errstate(divide="ignore", invalid="ignore"):
            lv = 10 * np.log10(ms / np.nanmax(ms))
        for e, v in zip(events, lv, strict=True):
            e.level_db = float(v) if np.isfinite(v) else None
    events.sort(
        key=lambda e: (math.inf if e.audio_start is None else e.audio_start, TYPES.index(e.type))
    )
    return events
