"""Source strengths, exclusive classification and ΔV volumes (paper 003 §3.2.3–3.2.4.1).

For every vertex and time step three strengths are computed from the mapped
density ρ̃ and particle velocity v:

* monopole ``S_m = ∂ρ̃/∂t``,
* dipole ``S_d = ∂/∂x_i (∂(ρ̃ v_i)/∂t)`` (Eq. 13),
* quadrupole ``S_q = Σ_ij ∂²(ρ̃ v_i v_j)/∂x_i∂x_j`` (Eq. 14, all nine terms).

Time derivatives are central differences between the neighbouring steps
(one-sided at the first and last step); space derivatives are second-order
finite differences (see :mod:`auralize.sources._kernels`).

**Steady part.**  A steady flow makes no sound: by default (``steady="remove"``)
the quadrupole strength is that of the stress ρ̃ v_i v_j minus the field's
local steady state (:class:`SteadyBase`): the stress itself at the anchor
steps (the first and the last step and both ends of every step over which
nothing changed, :func:`steady_anchors`), linearly interpolated between them
(Lighthill's far field depends on ∂²T_ij/∂t² only); by linearity this is the
literal S_q minus the S_q of the interpolated stress, and exactly 0 for a
steady field.  S_m and S_d are time derivatives and vanish for steady fields anyway.
``steady="keep"`` gives the literal strengths of the paper.

**No-data points.**  Points where ``volume.valid`` is False (outside the
input mesh) or where a mapped value is NaN/Inf, at any step a time
difference uses, are no-data: zero strength, never classified, and every
strength whose stencil reads one is no-data as well (no one-sided guess from
the points that remain).

Classification is exclusive, on magnitudes (strengths stay signed): a vertex is
a monopole if ``|S_m| > T_m``; a dipole if ``|S_d| > T_d`` and ``|S_m|`` is
"almost zero"; a quadrupole if ``|S_q| > T_q`` and both others are almost zero.
"Almost zero" means at most ``zero_fraction`` times that type's threshold
(default 1: below detection).  Thresholds (:class:`Thresholds`) are absolute,
``auto`` (adapted to the strength distribution), ``top:N%`` or ``N%`` of the
peak.

Each source point gets a ΔV whose extent along each grid edge is the cut
distance of §3.2.4.1 (half the edge towards a neighbour of the same type, else
the linear-interpolated crossing of ``|S|`` with the threshold): by default
(``delta_v="cell"``) the box those cuts bound, h³ inside a source block, so
Σ S ΔV is ∫ S dV over the source region and converges under grid refinement;
``delta_v="sphere"`` is the paper's sphere of the mean cut distance
(r = h/2 inside a block).  Radii are those of spheres of volume ΔV.
"""

from __future__ import annotations

import itertools
import math
import re
import threading
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.curvilinear import curvilinear_errors, curvilinear_strengths
from auralize.errors import DataError, ParameterError
from auralize.runtime.progress import progress
from auralize.sources import _kernels as K
from auralize.sources.mapping import AcousticMapping, get_mapping
from auralize.volume import TimeVolume

KIND_NAMES = {K.MONOPOLE: "monopole", K.DIPOLE: "dipole", K.QUADRUPOLE: "quadrupole"}
TYPES = ("monopole", "dipole", "quadrupole")

#: "auto" thresholds (per type, over the valid points of the sample steps): the
#: larger of a robust noise floor, median + AUTO_NOISE_K · 1.4826 · MAD of |S|
#: (but at most the level of the strongest AUTO_TOP of the points), and the
#: level above which the points carry AUTO_COVER of Σ|S| (the strongest
#: points that make up that share of the type's integrated |S|).
#: Both are properties of the strength *distribution* (integrals and
#: quantiles), not of its single largest value, so they stay put when the
#: grid is refined.
AUTO_NOISE_K = 5.0
AUTO_COVER = 0.9
#: the noise floor never hides the strongest AUTO_TOP of the points of a type that occurs
AUTO_TOP = 0.01
#: fixed fractions of each type's peak |S| (the viewer's default relative
#: thresholds, given as "3%", "0.3%", "0.1%")
AUTO_FRACTIONS = {"monopole": 0.03, "dipole": 0.003, "quadrupole": 0.001}
#: how many evenly spaced steps are sampled for relative, top and auto thresholds
AUTO_SAMPLE_STEPS = 8
#: at most about this many points per sample step enter the statistics
SAMPLE_POINTS = 1 << 15
#: strengths below this fraction of the size of the terms they are differences of
#: (:func:`input_scale`) are round-off: relative, top and auto thresholds never go lower
ROUNDOFF = 1e-9
#: share of the valid points above which a warning says thresholds find everything
WARN_FRACTION = 0.25
#: how the steady (time-mean) part of the flow is treated (see :func:`detect`)
STEADY_MODES = ("remove", "keep")
#: ΔV rules (see :func:`auralize.sources._kernels.classify_and_radius`)
DELTA_V_RULES = {"cell": K.DV_CELL, "sphere": K.DV_SPHERE}


class SourceFractionWarning(UserWarning):
    """More than :data:`WARN_FRACTION` of the valid points were classified as sources.

    Examples
    --------
    >>> issubclass(SourceFractionWarning, UserWarning)
    True
    """


ThresholdSpec = float | str

_NUMBER = r"(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?"


def _parse_threshold(spec: ThresholdSpec, kind: str) -> tuple[str, float]:
    """Return ("abs", value), ("rel", fraction of the peak), ("top", fraction) or ("auto", 0)."""
    if isinstance(spec, int | float) and not isinstance(spec, bool):
        v = float(spec)
        if not math.isfinite(v) or v < 0:
            raise ParameterError(f"{kind} threshold must be a finite number >= 0, got {spec!r}")
        return "abs", v
    s = str(spec).strip().lower()
    if s == "auto":
        return "auto", 0.0
    m = re.fullmatch(rf"top:\s*({_NUMBER})\s*%", s)
    if m:
        frac = float(m.group(1)) / 100.0
        if not 0 < frac <= 1:
            raise ParameterError(f"{kind} threshold {spec!r}: top fraction must be in (0, 100] %")
        return "top", frac
    m = re.fullmatch(rf"(?:rel:)?\s*({_NUMBER})\s*%", s) or re.fullmatch(rf"rel:\s*({_NUMBER})", s)
    if m:
        frac = float(m.group(1)) / (100.0 if s.endswith("%") else 1.0)
        if not 0 <= frac <= 1:
            raise ParameterError(f"{kind} relative threshold must be in 0..100 %, got {spec!r}")
        return "rel", frac
    if re.fullmatch(rf"[+-]?{_NUMBER}", s):
        return _parse_threshold(float(s), kind)
    raise ParameterError(
        f"{kind} threshold {spec!r} is not understood; give an absolute value (e.g. 250), "
        f"'auto', the strongest fraction of the points (e.g. 'top:1%') or a percentage of "
        f"the peak strength (e.g. '5%' or 'rel:0.05')"
    )


@dataclass
class StrengthStats:
    """Statistics of |S| over the valid points of the sample steps, per type.

    ``peak (3,)`` largest |S|; ``sample (3, M)`` |S| at the same M sampled
    valid point-steps (all of them on grids up to :data:`SAMPLE_POINTS`
    points; otherwise a fixed pseudo-random subset chosen by global point
    index, so slabbed and whole-frame detection sample the same points).

    Parameters
    ----------
    peak : ndarray, shape (3,)
        Largest |S| of the monopole, dipole and quadrupole strengths, in their
        units (kg/(m³·s), kg/(m⁴·s), kg/(m³·s²)).
    sample : ndarray, shape (3, M)
        |S| of each type at the M sampled valid point-steps (sorted along axis 1
        once :meth:`merge` has made them).
    scale : ndarray, shape (3,)
        Size of the terms each strength is a difference of (:func:`input_scale`):
        relative, top and auto thresholds stay above :data:`ROUNDOFF` times it.

    Examples
    --------
    >>> st = StrengthStats(peak=np.array([2.0, 0.0, 1.0]), sample=np.ones((3, 5)))
    >>> st.sample.shape, st.scale.tolist()
    ((3, 5), [0.0, 0.0, 0.0])
    """

    peak: NDArray[np.float64]
    sample: NDArray[np.float64]
    #: (3,) size of the terms each strength is a difference of (see :func:`input_scale`)
    scale: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))

    @classmethod
    def merge(cls, parts: list[StrengthStats]) -> StrengthStats:
        """The statistics of several steps (or slabs) as one.

        Peaks and scales are the largest of the parts'; the samples are joined and
        each type's sorted ascending (on the detection's threads).

        Parameters
        ----------
        parts : list of StrengthStats
            The parts, e.g. one per sample step.

        Returns
        -------
        StrengthStats

        Examples
        --------
        >>> a = StrengthStats(peak=np.array([1.0, 5.0, 0.0]), sample=np.array([[1.0], [5.0], [0.0]]))
        >>> b = StrengthStats(peak=np.array([3.0, 2.0, 0.0]), sample=np.array([[3.0], [2.0], [0.0]]))
        >>> m = StrengthStats.merge([a, b])
        >>> m.peak.tolist(), m.sample[1].tolist()
        ([3.0, 5.0, 0.0], [2.0, 5.0])
        """
        peak = np.zeros(3)
        scale = np.zeros(3)
        for p in parts:
            np.maximum(peak, p.peak, out=peak)
            np.maximum(scale, p.scale, out=scale)
        samples = [p.sample for p in parts if p.sample.size]
        if not samples:
            return cls(peak=peak, sample=np.zeros((3, 0)), scale=scale)
        sample = np.concatenate(samples, axis=1)
        # each type's samples sorted (as np.sort along axis 1) on the detection's threads
        K.in_threads(lambda i: sample[i].sort(), sample.shape[0])
        return cls(peak=peak, sample=sample, scale=scale)


#: a level taken from the samples themselves is lowered by this relative amount, so the
#: samples at that level (ties included: every point of a uniform field) exceed it
TIE = 1e-12


def _cover_level(x: NDArray[np.float64], cover: float) -> float:
    """Smallest level whose exceeding values carry ``cover`` of Σx (x sorted ascending)."""
    if x.size == 0 or x[-1] <= 0:
        return np.inf
    tail = np.cumsum(x[::-1])
    k = int(np.searchsorted(tail, cover * tail[-1]))
    return float(x[::-1][min(k, x.size - 1)]) * (1.0 - TIE)


def top_level(x: NDArray[np.float64], top: float) -> float:
    """Level exceeded by the strongest fraction ``top`` of ``x`` and every value tied with them.

    The ``1 - top`` quantile lowered by :data:`TIE`: classification is strict
    (``|S| > T``), so without it a quantile that falls on a sample value
    would hide that value, and a uniform |S| (median = quantile = maximum)
    would classify no point at all.

    Parameters
    ----------
    x : ndarray, shape (M,)
        |S| samples of one type.
    top : float
        Fraction of the points to exceed the level, in (0, 1].

    Returns
    -------
    float
        The level (+inf when ``x`` is empty).

    Examples
    --------
    >>> x = np.arange(1.0, 101.0)
    >>> level = top_level(x, 0.1)
    >>> int((x > level).sum()), bool(level < 90.1)
    (10, True)
    >>> int((np.ones(7) > top_level(np.ones(7), 0.1)).sum())  # ties all exceed it
    7
    """
    if x.size == 0:
        return np.inf
    return float(np.quantile(x, 1.0 - top)) * (1.0 - TIE)


def auto_threshold(x: NDArray[np.float64]) -> float:
    """The "auto" threshold of one type from sorted |S| samples ``x`` (see :data:`AUTO_COVER`).

    The larger of a robust noise floor, median + :data:`AUTO_NOISE_K` ·
    1.4826 · MAD (at most :func:`top_level` of :data:`AUTO_TOP`), and the
    level above which the strongest samples carry :data:`AUTO_COVER` of Σ|S|.

    Parameters
    ----------
    x : ndarray, shape (M,)
        |S| samples of one type, sorted ascending.

    Returns
    -------
    float
        The threshold, in the strength's units (+inf when ``x`` is empty or
        all 0: the type never occurs).

    Examples
    --------
    A few strong points over a floor of weak ones: the threshold lies between
    them.

    >>> x = np.sort(np.r_[np.full(95, 1.0), np.full(5, 1000.0)])
    >>> t = auto_threshold(x)
    >>> bool(1.0 < t < 1000.0), int((x > t).sum())
    (True, 5)
    >>> auto_threshold(np.zeros(4))
    inf
    """
    if x.size == 0 or x[-1] <= 0:
        return np.inf
    med = float(np.median(x))
    mad = float(np.median(np.abs(x - med)))
    noise = min(med + AUTO_NOISE_K * 1.4826 * mad, top_level(x, AUTO_TOP))
    return max(noise, _cover_level(x, AUTO_COVER))


@dataclass
class Thresholds:
    """Detection thresholds per source type (paper 003 §3.2.3).

    Each of ``monopole``, ``dipole``, ``quadrupole`` is

    * ``"auto"`` (default): adapts to the data, per type, from |S| over the
      valid points of up to :data:`AUTO_SAMPLE_STEPS` evenly spaced steps
      (strengths within their discretisation error already 0, see ``floor``):
      the larger of a robust noise floor (median + 5 · 1.4826 · MAD, at most
      the level of the strongest 1 %) and the level above which the
      strongest points carry 90 % of Σ|S|;
    * ``"top:1%"``: the strongest 1 % of the valid points (a quantile of |S|);
    * ``"5%"`` or ``"rel:0.05"``: a fraction of the series' peak |S| (the
      peak of a second derivative of interpolated data grows as the grid is
      refined, so on resampled meshes this does not converge);
    * an absolute value, in that strength's units: kg/(m³·s) for monopoles,
      kg/(m⁴·s) for dipoles, kg/(m³·s²) for quadrupoles.

    Whatever the threshold, a strength is a source only where it rises above
    ``floor`` times its own discretisation error (the same difference over
    2h and 2Δt compared with it, :func:`step_strengths`): constant density
    has no monopoles, a divergence-free flow at constant density no dipoles
    (its ∇·(ρv) is truncation error), however the rest of the data are
    distributed.  ``floor=0`` is paper 003's literal detection.

    Parameters
    ----------
    monopole, dipole, quadrupole : float or str
        The threshold of each type, as above.
    zero_fraction : float
        "Almost zero" for the exclusive classification: a dipole needs
        ``|S_m|`` at most this times the monopole threshold, a quadrupole both
        others at most this times theirs (default 1: below detection; >= 0).
    floor : float
        A strength not above this many times its discretisation-error estimate
        is not a source (default 3; 0: no floor).

    Raises
    ------
    ParameterError
        A threshold that is not understood or out of range, a negative
        ``zero_fraction`` or ``floor``.

    Examples
    --------
    Absolute and relative thresholds resolve from the peak magnitudes (3,)
    alone; ``"auto"`` and ``"top:"`` need the series' :class:`StrengthStats`:

    >>> t = Thresholds(monopole=10.0, dipole="2%", quadrupole="5%")
    >>> t.resolve(np.array([1.0, 50.0, 40.0]))
    array([10.,  1.,  2.])
    """

    monopole: ThresholdSpec = "auto"
    dipole: ThresholdSpec = "auto"
    quadrupole: ThresholdSpec = "auto"
    zero_fraction: float = 1.0
    #: a strength not above this many times its discretisation-error estimate is
    #: not a source, whatever the threshold (0: no floor, paper 003 literally)
    floor: float = 3.0

    def __post_init__(self) -> None:
        self._parsed = [_parse_threshold(getattr(self, k), k) for k in TYPES]
        if not (math.isfinite(self.zero_fraction) and self.zero_fraction >= 0):
            raise ParameterError(f"zero_fraction must be >= 0, got {self.zero_fraction!r}")
        self.floor = check_floor(self.floor)

    @property
    def needs_scale(self) -> bool:
        """Whether :meth:`resolve` needs the series' statistics (any threshold not absolute).

        Examples
        --------
        >>> Thresholds(1.0, 2.0, 3.0).needs_scale, Thresholds().needs_scale
        (False, True)
        """
        return any(mode != "abs" for mode, _ in self._parsed)

    def resolve(self, stats: StrengthStats | NDArray[np.float64] | None) -> NDArray[np.float64]:
        """Absolute thresholds (3,) from the series' :class:`StrengthStats`.

        Relative thresholds alone may be resolved from the peak magnitudes (3,).
        A type that never occurs (peak 0, or not above :data:`ROUNDOFF` times its
        input scale) gets an infinite threshold; relative, top and auto thresholds
        never go below that round-off level.

        Parameters
        ----------
        stats : StrengthStats or ndarray, shape (3,), or None
            The series' statistics, or its peak |S| per type (relative thresholds
            only), or None (absolute thresholds only).

        Returns
        -------
        ndarray, shape (3,)
            Monopole, dipole and quadrupole thresholds, in the strengths' units.

        Raises
        ------
        ParameterError
            A relative, top or auto threshold without what it needs.

        Examples
        --------
        >>> st = StrengthStats(peak=np.array([100.0, 0.0, 4.0]), sample=np.ones((3, 1)))
        >>> Thresholds(monopole="10%", dipole="auto", quadrupole=2.0).resolve(st)
        array([10., inf,  2.])
        >>> Thresholds().resolve(None)
        Traceback (most recent call last):
        ...
        auralize.errors.ParameterError: monopole threshold 'auto' needs the series' strength statistics
        """
        out = np.empty(3)
        if isinstance(stats, StrengthStats):
            peak: NDArray[np.float64] | None = stats.peak
        else:
            peak = None if stats is None else np.asarray(stats, dtype=np.float64)
            stats = None
        for i, (mode, v) in enumerate(self._parsed):
            if mode == "abs":
                out[i] = v
                continue
            if peak is None or (mode != "rel" and stats is None):
                raise ParameterError(
                    f"{TYPES[i]} threshold {getattr(self, TYPES[i])!r} needs the series' "
                    f"strength statistics"
                )
            floor = ROUNDOFF * float(stats.scale[i]) if stats is not None else 0.0
            if not peak[i] > floor:
                out[i] = np.inf
            elif mode == "rel":
                out[i] = v * float(peak[i])
            elif mode == "top":
                assert stats is not None
                x = stats.sample[i]
                out[i] = top_level(x, v)
            else:
                assert stats is not None
                out[i] = auto_threshold(stats.sample[i])
            out[i] = max(out[i], floor)
        return out

    def describe(self) -> dict[str, object]:
        """The thresholds as given, with ``zero_fraction`` and ``floor`` (saved with a series).

        Returns
        -------
        dict
            ``{"monopole", "dipole", "quadrupole", "zero_fraction", "floor"}``.

        Examples
        --------
        >>> Thresholds(dipole="top:1%").describe()
        {'monopole': 'auto', 'dipole': 'top:1%', 'quadrupole': 'auto', 'zero_fraction': 1.0, 'floor': 3.0}
        """
        return {k: getattr(self, k) for k in (*TYPES, "zero_fraction", "floor")}


@dataclass
class SourceFrame:
    """The sources of one time step.

    Parameters
    ----------
    index : ndarray of int64, shape (N,)
        Flat C-order vertex indices into the ``(nz, ny, nx)`` grid.
    kind : ndarray of int8, shape (N,)
        Source type: 1 monopole, 2 dipole, 3 quadrupole.
    strength : ndarray of float64, shape (N,)
        Signed strength S of the vertex's type, in that type's units
        (kg/(m³·s), kg/(m⁴·s), kg/(m³·s²)).
    radius : ndarray of float64, shape (N,)
        Radius of the sphere of volume ΔV (paper 003 §3.2.4.1), m.
    n_valid : int or None
        Points with data at this step (None: all of the grid's).

    Examples
    --------
    >>> f = SourceFrame(index=np.array([0, 5]), kind=np.array([1, 3], dtype=np.int8),
    ...                 strength=np.array([2.0, -1.0]), radius=np.array([0.5, 0.5]))
    >>> f
    <SourceFrame: 2 sources (monopole 1, dipole 0, quadrupole 1)>
    """

    index: NDArray[np.int64]
    kind: NDArray[np.int8]
    strength: NDArray[np.float64]
    radius: NDArray[np.float64]
    #: points with data at this step (None: all of the grid's)
    n_valid: int | None = None

    @property
    def volume(self) -> NDArray[np.float64]:
        """ΔV = 4/3 π r³ of each source ``(N,)``, m³.

        Examples
        --------
        >>> f = SourceFrame(index=np.array([0]), kind=np.array([1], dtype=np.int8),
        ...                 strength=np.array([1.0]), radius=np.array([1.0]))
        >>> f.volume
        array([4.18879...])
        """
        return (4.0 / 3.0) * np.pi * self.radius**3

    def counts(self) -> dict[str, int]:
        """Number of sources of each type.

        Returns
        -------
        dict of str to int
            ``{"monopole": n1, "dipole": n2, "quadrupole": n3}``.

        Examples
        --------
        >>> f = SourceFrame(index=np.arange(3), kind=np.array([2, 2, 1], dtype=np.int8),
        ...                 strength=np.ones(3), radius=np.ones(3))
        >>> f.counts()
        {'monopole': 1, 'dipole': 2, 'quadrupole': 0}
        """
        c = np.bincount(self.kind, minlength=4)
        return {name: int(c[k]) for k, name in KIND_NAMES.items()}

    def __repr__(self) -> str:
        from auralize.runtime.reprs import counts_text

        return f"<SourceFrame: {self.index.size:,} sources ({counts_text(self.counts())})>"


def _mapping_name(meta: Any) -> str:
    """The mapping's name from a series' ``meta["mapping"]`` (a description or a name)."""
    if isinstance(meta, dict):
        return str(meta.get("name") or "")
    return "" if meta is None else str(meta)


@dataclass
class SourceSeries:
    """Sources at every step of a volume, plus what is needed to reproduce them.

    Parameters
    ----------
    frames : list of SourceFrame
        The sources of each step, ``T`` of them.
    times : ndarray, shape (T,)
        Data time of each step, s.
    origin, spacing : ndarray, shape (3,)
        Position of point (0, 0, 0) and the point spacing (x, y, z), m.
    dims : (3,) tuple of int
        Grid points ``(nx, ny, nz)``.
    thresholds : ndarray, shape (3,)
        The absolute thresholds used (monopole, dipole, quadrupole).
    meta : dict
        How the sources were found: mapping, thresholds as given, peak |S|,
        ``steady``, ``delta_v``, classified fraction (see :func:`detect`).
    coords : ndarray, shape (nz, ny, nx, 3), optional
        Point positions of a curvilinear grid, m (None: uniform).

    Examples
    --------
    >>> f = SourceFrame(index=np.array([5]), kind=np.array([1], dtype=np.int8),
    ...                 strength=np.array([2.0]), radius=np.array([0.5]))
    >>> series = SourceSeries(frames=[f, f], times=np.array([0.0, 0.1]), origin=np.zeros(3),
    ...                       spacing=np.full(3, 0.5), dims=(4, 3, 2), thresholds=np.ones(3))
    >>> series.n_steps, series.shape, series.counts()[1]["monopole"]
    (2, (2, 3, 4), 1)
    """

    def _repr_html_(self) -> str:
        """Notebook display (:mod:`auralize.runtime.notebook`)."""
        from auralize.runtime.notebook import series_html

        return series_html(self)

    frames: list[SourceFrame]
    times: NDArray[np.float64]
    origin: NDArray[np.float64]
    spacing: NDArray[np.float64]
    dims: tuple[int, int, int]
    thresholds: NDArray[np.float64]
    meta: dict[str, object] = field(default_factory=dict)
    #: point positions ``(nz, ny, nx, 3)`` of a curvilinear grid (None: uniform)
    coords: NDArray[np.float64] | None = None

    @property
    def n_steps(self) -> int:
        """Number of steps (frames).

        Examples
        --------
        >>> f = SourceFrame(index=np.array([5]), kind=np.array([1], dtype=np.int8),
        ...                 strength=np.array([2.0]), radius=np.array([0.5]))
        >>> series = SourceSeries(frames=[f, f], times=np.array([0.0, 0.1]), origin=np.zeros(3),
        ...                       spacing=np.full(3, 0.5), dims=(4, 3, 2), thresholds=np.ones(3))
        >>> series.n_steps
        2
        """
        return len(self.frames)

    @property
    def shape(self) -> tuple[int, int, int]:
        """Grid shape ``(nz, ny, nx)`` (``dims`` reversed).

        Examples
        --------
        >>> f = SourceFrame(index=np.array([5]), kind=np.array([1], dtype=np.int8),
        ...                 strength=np.array([2.0]), radius=np.array([0.5]))
        >>> series = SourceSeries(frames=[f, f], times=np.array([0.0, 0.1]), origin=np.zeros(3),
        ...                       spacing=np.full(3, 0.5), dims=(4, 3, 2), thresholds=np.ones(3))
        >>> series.dims, series.shape
        ((4, 3, 2), (2, 3, 4))
        """
        nx, ny, nz = self.dims
        return (nz, ny, nx)

    def positions(self, index: NDArray[np.integer]) -> NDArray[np.float64]:
        """Positions of the vertices with flat indices ``index``.

        Parameters
        ----------
        index : ndarray of int, shape (N,)
            Flat C-order indices into the ``(nz, ny, nx)`` grid.

        Returns
        -------
        ndarray, shape (N, 3)
            x, y, z of each vertex, m (on a curvilinear grid, its ``coords``).

        Examples
        --------
        >>> f = SourceFrame(index=np.array([5]), kind=np.array([1], dtype=np.int8),
        ...                 strength=np.array([2.0]), radius=np.array([0.5]))
        >>> series = SourceSeries(frames=[f, f], times=np.array([0.0, 0.1]), origin=np.zeros(3),
        ...                       spacing=np.full(3, 0.5), dims=(4, 3, 2), thresholds=np.ones(3))
        >>> series.positions(np.array([0, 5]))
        array([[0. , 0. , 0. ],
               [0.5, 0.5, 0. ]])
        """
        if self.coords is not None:
            return self.coords.reshape(-1, 3)[np.asarray(index)]
        k, j, i = np.unravel_index(np.asarray(index), self.shape)
        return self.origin + np.stack([i, j, k], axis=-1) * self.spacing

    def counts(self) -> list[dict[str, int]]:
        """Per-step counts by type.

        Returns
        -------
        list of dict of str to int
            :meth:`SourceFrame.counts` of each step.

        Examples
        --------
        >>> f = SourceFrame(index=np.array([5]), kind=np.array([1], dtype=np.int8),
        ...                 strength=np.array([2.0]), radius=np.array([0.5]))
        >>> series = SourceSeries(frames=[f, f], times=np.array([0.0, 0.1]), origin=np.zeros(3),
        ...                       spacing=np.full(3, 0.5), dims=(4, 3, 2), thresholds=np.ones(3))
        >>> series.counts()[0]
        {'monopole': 1, 'dipole': 0, 'quadrupole': 0}
        """
        return [f.counts() for f in self.frames]

    def __repr__(self) -> str:
        """A few lines: steps, counts per type, thresholds, mapping (never the arrays)."""
        from auralize.runtime.reprs import counts_text, number, span, summary

        counts = self.counts()
        total = {k: sum(c[k] for c in counts) for k in TYPES}
        busiest = max((f.index.size for f in self.frames), default=0)
        nx, ny, nz = self.dims
        th = ", ".join(
            f"{k} {number(float(v))}" for k, v in zip(TYPES, self.thresholds, strict=False)
        )
        return summary(
            "SourceSeries",
            [
                ("steps", f"{self.n_steps} on a {nx} × {ny} × {nz} grid, {span(self.times)}"),
                ("sources", f"{counts_text(total)} over all steps; at most {busiest:,} in a step"),
                ("thresholds", th),
                ("mapping", _mapping_name(self.meta.get("mapping"))),
            ],
        )

    def tracks(self) -> SourceTracks:
        """Per-vertex strength·ΔV over time for every vertex that is ever a source.

        The input of the synthesis (paper 003 §3.2.4.4): q_k(t_n) = S ΔV of vertex
        k at step n, 0 at the steps where it is not a source.

        Returns
        -------
        SourceTracks
            One track per vertex that is a source at some step, its largest ΔV
            radius and its type at each step.

        Examples
        --------
        >>> f = SourceFrame(index=np.array([5]), kind=np.array([1], dtype=np.int8),
        ...                 strength=np.array([2.0]), radius=np.array([0.5]))
        >>> series = SourceSeries(frames=[f, f], times=np.array([0.0, 0.1]), origin=np.zeros(3),
        ...                       spacing=np.full(3, 0.5), dims=(4, 3, 2), thresholds=np.ones(3))
        >>> tr = series.tracks()
        >>> tr.n_sources, tr.q.shape, tr.positions.tolist(), tr.kind.tolist()
        (1, (1, 2), [[0.5, 0.5, 0.0]], [[1, 1]])
        >>> bool(np.allclose(tr.q, 2.0 * 4 / 3 * np.pi * 0.5**3))
        True
        """
        if not self.frames or all(f.index.size == 0 for f in self.frames):
            return SourceTracks(
                positions=np.zeros((0, 3)),
                q=np.zeros((0, self.n_steps)),
                radius=np.zeros(0),
                times=self.times.copy(),
            )
        all_idx = np.concatenate([f.index for f in self.frames])
        uniq = np.unique(all_idx)
        q = np.zeros((uniq.size, self.n_steps))
        kind = np.zeros((uniq.size, self.n_steps), dtype=np.int8)
        rmax = np.zeros(uniq.size)
        for n, f in enumerate(self.frames):
            pos = np.searchsorted(uniq, f.index)
            q[pos, n] = f.strength * f.volume
            kind[pos, n] = f.kind
            np.maximum.at(rmax, pos, f.radius)
        return SourceTracks(
            positions=self.positions(uniq),
            q=q,
            radius=rmax,
            times=self.times.copy(),
            index=uniq,
            kind=kind,
        )


@dataclass
class SourceTracks:
    """Input of the synthesis: per-source q_k(t_n) = S·ΔV at each step (paper 003 §3.2.4.4).

    Parameters
    ----------
    positions : ndarray, shape (K, 3)
        Source positions x, y, z, m.
    q : ndarray, shape (K, T)
        Strength times ΔV of each source at each step (0 where silent).
    radius : ndarray, shape (K,)
        Largest ΔV-sphere radius of each source, m (used to clamp distances).
    times : ndarray, shape (T,)
        Time of each step (knot), s.
    index : ndarray of int64, shape (K,), optional
        Flat grid index of each source's vertex.
    kind : ndarray of int8, shape (K, T), optional
        Source type at each step: 0 where silent, 1 monopole, 2 dipole,
        3 quadrupole (used by the ``tonal`` timbre).
    cache : dict
        Per-tracks memo of derived arrays (not compared).
    origin, end : float, optional
        Data time of the first and the last data step (default ``times[0]``
        and ``times[-1]``); tracks with knots held before and after the data
        (:meth:`auralize.sources.field.FieldTracks.tracks`) set them.

    Examples
    --------
    >>> tr = SourceTracks(positions=np.zeros((2, 3)), q=np.ones((2, 4)), radius=np.full(2, 0.1),
    ...                   times=np.arange(4) / 30)
    >>> tr.n_sources, tr.t_first, tr.t_last
    (2, 0.0, 0.1)
    """

    positions: NDArray[np.float64]
    q: NDArray[np.float64]
    radius: NDArray[np.float64]
    times: NDArray[np.float64]
    index: NDArray[np.int64] | None = None
    kind: NDArray[np.int8] | None = None
    cache: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)
    #: data time of the first and the last data step (default ``times[0]`` and
    #: ``times[-1]``); tracks with knots held before and after the data
    #: (:meth:`auralize.sources.field.FieldTracks.tracks`) set them
    origin: float | None = None
    end: float | None = None

    @property
    def n_sources(self) -> int:
        """Number of sources K.

        Examples
        --------
        >>> SourceTracks(np.zeros((3, 3)), np.zeros((3, 2)), np.zeros(3), np.arange(2.0)).n_sources
        3
        """
        return int(self.q.shape[0])

    def __repr__(self) -> str:
        from auralize.runtime.reprs import number, span

        if not self.n_sources:
            return f"<SourceTracks: no sources, {self.times.size} knots>"
        lo, hi = self.positions.min(axis=0), self.positions.max(axis=0)
        box = " ".join(
            f"{a}[{number(a0)}, {number(a1)}]" for a, a0, a1 in zip("xyz", lo, hi, strict=True)
        )
        return (
            f"<SourceTracks: {self.n_sources:,} sources × {self.times.size} knots, "
            f"{span([self.t_first, self.t_last])}, {box} m>"
        )

    @property
    def t_first(self) -> float:
        """Data time of the first data step: the time origin of a render.

        Examples
        --------
        >>> tr = SourceTracks(np.zeros((1, 3)), np.zeros((1, 3)), np.zeros(1), np.array([-1.0, 0.0, 1.0]))
        >>> tr.t_first, SourceTracks(tr.positions, tr.q, tr.radius, tr.times, origin=0.0).t_first
        (-1.0, 0.0)
        """
        return float(self.times[0]) if self.origin is None else float(self.origin)

    @property
    def t_last(self) -> float:
        """Data time of the last data step.

        Examples
        --------
        >>> tr = SourceTracks(np.zeros((1, 3)), np.zeros((1, 3)), np.zeros(1), np.array([-1.0, 0.0, 1.0]))
        >>> tr.t_last, SourceTracks(tr.positions, tr.q, tr.radius, tr.times, end=0.0).t_last
        (1.0, 0.0)
        """
        return float(self.times[-1]) if self.end is None else float(self.end)


def valid_mask(volume: TimeVolume) -> NDArray[np.bool_] | None:
    """The volume's validity mask ``(nz, ny, nx)`` (True inside the input mesh), or None.

    Parameters
    ----------
    volume : TimeVolume
        The volume.

    Returns
    -------
    ndarray of bool, shape (nz, ny, nx), or None
        None when the volume has no mask or every point is valid.

    Raises
    ------
    DataError
        The mask's shape is not the grid's.

    Examples
    --------
    >>> vol = TimeVolume.from_arrays({"density": np.ones((2, 2, 2, 3))})
    >>> valid_mask(vol) is None
    True
    >>> vol.valid = np.arange(12).reshape(2, 2, 3) > 0
    >>> int(valid_mask(vol).sum())
    11
    """
    valid = getattr(volume, "valid", None)
    if valid is None:
        return None
    valid = np.asarray(valid, dtype=bool)
    if valid.shape != volume.shape:
        raise DataError(
            f"{volume.source}: validity mask has shape {valid.shape}, the grid needs {volume.shape}"
        )
    return None if valid.all() else valid


#: most bytes of mapped frames :func:`detect` keeps for the whole series (see
#: :class:`MappedSeries`); also at most a quarter of the memory available
SERIES_BYTES = 2 << 30


def map_step(
    volume: TimeVolume, mapping: AcousticMapping, n: int, valid: NDArray[np.bool_] | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Step ``n`` mapped: ``(rho, v, ok)``, no-data values replaced by 0 (see :class:`StepCache`).

    Parameters
    ----------
    volume : TimeVolume
        The volume.
    mapping : AcousticMapping
        Its (prepared) mapping.
    n : int
        Time step.
    valid : ndarray of bool, shape (nz, ny, nx), or None
        The volume's :func:`valid_mask`.

    Returns
    -------
    rho : ndarray, shape (nz, ny, nx)
        Mapped density, kg/m³, C-contiguous float64; 0 at no-data points.
    v : ndarray, shape (nz, ny, nx, 3)
        Mapped velocity, m/s; 0 at no-data points.
    ok : ndarray of bool, shape (nz, ny, nx), or None
        Points valid with finite ρ and v (None: all).

    Examples
    --------
    >>> vol = TimeVolume.from_arrays({"density": np.ones((2, 2, 2, 2))})
    >>> valid = np.ones((2, 2, 2), dtype=bool)
    >>> valid[0, 0, 0] = False
    >>> rho, v, ok = map_step(vol, get_mapping("identity"), 1, valid)
    >>> float(rho[0, 0, 0]), int(ok.sum()), map_step(vol, get_mapping("identity"), 0, None)[2]
    (0.0, 7, None)
    """
    rho, v = mapping.map(volume, n)
    rho = np.ascontiguousarray(rho, dtype=np.float64)
    v = np.ascontiguousarray(v, dtype=np.float64)
    ok = valid
    if not _all_finite(rho, v):
        fin = np.isfinite(rho) & np.isfinite(v).all(axis=-1)
        ok = fin if ok is None else ok & fin
    if ok is not None:
        rho = np.where(ok, rho, 0.0)
        v = np.where(ok[..., None], v, 0.0)
    return rho, v, ok


def _all_finite(rho: NDArray[np.float64], v: NDArray[np.float64]) -> bool:
    """Whether every value of ``rho (nz, ny, nx)`` and ``v (nz, ny, nx, 3)`` is finite: sums
    first (cheap, and finite whenever every value is, barring overflow), per slab on the
    detection's threads when large (:func:`in_slabs`), then the values themselves."""
    sums = [True] * max(1, rho.shape[0] if rho.ndim else 1)

    def piece(sl: slice) -> None:
        sums[sl.start] = bool(np.isfinite(np.sum(rho[sl])) and np.isfinite(np.sum(v[sl])))

    if not in_slabs(piece, rho):
        sums[0] = bool(np.isfinite(np.sum(rho)) and np.isfinite(np.sum(v)))
    return all(sums) or bool(np.isfinite(rho).all() and np.isfinite(v).all())


class MappedSeries:
    """Every step's mapped ``(rho, v, ok)``, each step read and mapped once.

    :func:`detect` needs each step several times: to find the steady anchors
    (consecutive steps compared), for the anchors' stress, for the strengths
    of the threshold sample steps (and their neighbours) and for detection.
    The mapped frames are kept after their first use, up to ``max_bytes``
    (default the smaller of :data:`SERIES_BYTES` and a quarter of the memory
    available: 64³ × 70 steps is 0.6 GB); steps beyond it are mapped again
    (read again) each time they are needed.  Bigger data are for
    :mod:`auralize.distributed` (chunked, out of core).  ``maps`` counts the
    mapping evaluations.

    Parameters
    ----------
    volume : TimeVolume
        The volume.
    mapping : AcousticMapping
        Its (prepared) mapping.
    max_bytes : int, optional
        Most bytes of mapped frames kept (:func:`step_bytes` a step); None:
        :func:`series_bytes`.

    Examples
    --------
    >>> rho = 1.0 + 0.1 * np.arange(3.0).reshape(3, 1, 1, 1) * np.ones((3, 4, 4, 4))
    >>> vol = TimeVolume.from_arrays({"density": rho}, times=[0.0, 0.5, 1.0])
    >>> store = MappedSeries(vol, get_mapping("identity"), max_bytes=4 * step_bytes(vol))
    >>> store.get(1) is store.get(1), store.maps, store.max_steps
    (True, 1, 4)
    """

    def __init__(
        self, volume: TimeVolume, mapping: AcousticMapping, *, max_bytes: int | None = None
    ) -> None:
        self.volume, self.mapping = volume, mapping
        self.valid = valid_mask(volume)
        budget = series_bytes() if max_bytes is None else int(max_bytes)
        self.max_steps = budget // step_bytes(volume)
        self.frames: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray | None]] = {}
        #: per step, each plane's (max|ρ|, max|ρv|, max|ρv ∘ v|) ``(nz, 3)``, gathered by
        #: :func:`steady_anchors` as it compares the steps (:func:`input_scale`)
        self.maxima: dict[int, np.ndarray] = {}
        self.maps = 0

    def get(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Step ``n``'s ``(rho, v, ok)`` (:func:`map_step`), mapped on first use and kept
        while the budget allows.

        Parameters
        ----------
        n : int
            Time step.

        Returns
        -------
        tuple of (ndarray, ndarray, ndarray or None)
            ``rho (nz, ny, nx)`` kg/m³, ``v (nz, ny, nx, 3)`` m/s and the no-data
            mask ``ok`` (None: every point has data).

        Examples
        --------
        >>> rho = 1.0 + 0.1 * np.arange(3.0).reshape(3, 1, 1, 1) * np.ones((3, 4, 4, 4))
        >>> vol = TimeVolume.from_arrays({"density": rho}, times=[0.0, 0.5, 1.0])
        >>> store = MappedSeries(vol, get_mapping("identity"), max_bytes=0)
        >>> rho1, v1, ok = store.get(1)
        >>> round(float(rho1.mean()), 12), v1.shape, ok, store.get(1) is store.get(1), store.maps
        (1.1, (4, 4, 4, 3), None, False, 3)
        """
        hit = self.frames.get(n)
        if hit is None:
            hit = map_step(self.volume, self.mapping, n, self.valid)
            self.maps += 1
            if len(self.frames) < self.max_steps:
                self.frames[n] = hit
        return hit


def step_bytes(volume: TimeVolume) -> int:
    """Bytes of one mapped step in :class:`MappedSeries` (rho and v, float64).

    Parameters
    ----------
    volume : TimeVolume
        The volume.

    Returns
    -------
    int
        32 bytes a point (at least 1).

    Examples
    --------
    >>> step_bytes(TimeVolume.from_arrays({"density": np.ones((2, 4, 4, 4))}))
    2048
    """
    return max(32 * volume.n_points, 1)


def series_bytes() -> int:
    """The default memory for :class:`MappedSeries`: :data:`SERIES_BYTES`, at most a quarter
    of the memory available.

    Returns
    -------
    int
        Bytes.

    Examples
    --------
    >>> 0 < series_bytes() <= SERIES_BYTES
    True
    """
    from auralize.runtime.resources import available_bytes

    return int(min(SERIES_BYTES, available_bytes() // 4))


class StepCache:
    """Mapped (ρ, v, ok) frames, kept for the steps the stencils need.

    ``ok`` is None when every point of the step is valid and finite, else a
    bool mask; no-data values are replaced by 0 (they are masked out of the
    strengths by :func:`auralize.sources._kernels.mask_nodata`, never used).
    The kernels take the mass flux ρv from ρ and v; :meth:`get` makes it for
    other callers.

    Parameters
    ----------
    volume : TimeVolume
        The volume.
    mapping : AcousticMapping
        Its (prepared) mapping.
    qmean : SteadyBase or ndarray, shape (nz, ny, nx), optional
        The steady state subtracted from every step's quadrupole strength: a
        :class:`SteadyBase`, or a fixed quadrupole strength of a mean stress
        (kg/(m³·s²)); None: the literal strengths.
    floor : float
        Strengths not above ``floor`` times their discretisation-error estimate
        are zeroed (0: off; see :func:`step_strengths`).
    store : MappedSeries, optional
        Where the mapped frames come from (None: mapped here).

    Raises
    ------
    ParameterError
        A negative or non-numeric ``floor``.

    Examples
    --------
    >>> rho = 1.0 + 0.1 * np.arange(3.0).reshape(3, 1, 1, 1) * np.ones((3, 4, 4, 4))
    >>> vol = TimeVolume.from_arrays({"density": rho}, times=[0.0, 0.5, 1.0])
    >>> cache = StepCache(vol, get_mapping("identity"))
    >>> rho, v, m, ok = cache.get(2)
    >>> float(rho.max()), m.shape, ok
    (1.2, (4, 4, 4, 3), None)
    """

    def __init__(
        self,
        volume: TimeVolume,
        mapping: AcousticMapping,
        *,
        qmean: SteadyBase | NDArray[np.float64] | None = None,
        floor: float = 0.0,
        store: MappedSeries | None = None,
    ) -> None:
        self.volume, self.mapping = volume, mapping
        self.valid = valid_mask(volume)
        self.qmean = qmean
        self.store = store
        #: strengths not above ``floor`` times their error estimate are zeroed (0: off)
        self.floor = check_floor(floor)
        self._cache: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray | None]] = {}
        self._flux: dict[int, np.ndarray] = {}
        #: per-plane (max|ρ|, max|ρv|, max|ρv ∘ v|) ``(nz, 3)`` of steps (:func:`input_scale`)
        self.maxima: dict[int, np.ndarray] = {}
        self.work: np.ndarray | None = None  # kernel scratch, reused between steps
        self.floor_work: np.ndarray | None = None  # scratch of the floor (2Δt momentum change)
        #: no-data points ``(nz, ny, nx)`` of the last step computed (None: none)
        self.nodata: np.ndarray | None = None

    def frame(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Step ``n``'s ``(rho, v, ok)``.

        Parameters
        ----------
        n : int
            Time step.

        Returns
        -------
        tuple of (ndarray, ndarray, ndarray or None)
            ``rho (nz, ny, nx)`` kg/m³, ``v (nz, ny, nx, 3)`` m/s and the no-data
            mask ``ok`` (None: every point has data); kept until :meth:`keep`
            drops it.

        Examples
        --------
        >>> rho = 1.0 + 0.1 * np.arange(3.0).reshape(3, 1, 1, 1) * np.ones((3, 4, 4, 4))
        >>> vol = TimeVolume.from_arrays({"density": rho}, times=[0.0, 0.5, 1.0])
        >>> cache = StepCache(vol, get_mapping("identity"))
        >>> cache.frame(1) is cache.frame(1), round(float(cache.frame(1)[0].mean()), 12)
        (True, 1.1)
        """
        hit = self._cache.get(n)
        if hit is None:
            if self.store is not None:
                hit = self.store.get(n)
            else:
                hit = map_step(self.volume, self.mapping, n, self.valid)
            self._cache[n] = hit
        return hit

    def get(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """Step ``n``'s ``(rho, v, rho v, ok)``.

        Parameters
        ----------
        n : int
            Time step.

        Returns
        -------
        tuple of (ndarray, ndarray, ndarray, ndarray or None)
            As :meth:`frame`, with the mass flux ρv ``(nz, ny, nx, 3)``, kg/(m²·s),
            third.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"density": np.full((2, 2, 2, 2), 2.0),
        ...                               "velocity": np.full((2, 2, 2, 2, 3), 3.0)})
        >>> rho, v, m, ok = StepCache(vol, get_mapping("identity")).get(0)
        >>> float(m.max())
        6.0
        """
        rho, v, ok = self.frame(n)
        m = self._flux.get(n)
        if m is None:
            m = self._flux[n] = rho[..., None] * v
        return rho, v, m, ok

    def keep(self, lo: int, hi: int) -> None:
        """Drop the frames outside steps ``[lo, hi]`` (one more on each side when the
        floor's 2Δt stencil reads them).

        Parameters
        ----------
        lo, hi : int
            First and last step to keep.

        Examples
        --------
        >>> rho = 1.0 + 0.1 * np.arange(3.0).reshape(3, 1, 1, 1) * np.ones((3, 4, 4, 4))
        >>> vol = TimeVolume.from_arrays({"density": rho}, times=[0.0, 0.5, 1.0])
        >>> cache = StepCache(vol, get_mapping("identity"))
        >>> first = cache.frame(0)
        >>> cache.keep(1, 2)
        >>> cache.frame(0) is first  # mapped again
        False
        """
        if self.floor > 0:
            lo, hi = lo - 1, hi + 1
        for store in (self._cache, self._flux, self.maxima):
            for k in [k for k in store if k < lo or k > hi]:
                del store[k]


def step_strengths(
    volume: TimeVolume, cache: StepCache, n: int, out: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """Strengths ``(3, nz, ny, nx)`` (monopole, dipole, quadrupole) at step ``n``.

    Paper 003 §3.2.3: S_m = ∂ρ̃/∂t, S_d = ∂/∂x_i (∂(ρ̃ v_i)/∂t) (Eq. 13) and
    S_q = ∂²(ρ̃ v_i v_j)/∂x_i∂x_j (Eq. 14), the time derivatives central
    differences between steps n-1 and n+1 (one-sided at the ends).

    A point is no-data at step n when it is invalid or non-finite at any of
    the steps its time differences use (n-1, n, n+1); a strength whose
    stencil reads a no-data point is 0 (see :func:`auralize.sources._kernels.mask_nodata`).
    ``cache.nodata`` holds the step's no-data points afterwards.

    The quadrupole strength is that of the stress minus the field's local
    steady state (``cache.qmean``, :class:`SteadyBase`).  With ``cache.floor``
    > 0, a strength not above that many times its discretisation-error
    estimate (:func:`auralize.sources._kernels._error_stencil`: the h and 2h
    stencils compared) or above round-off (:data:`ROUNDOFF` of
    :func:`input_scale`) is 0: it is not a source.  On a uniform grid all of
    it is one sweep along z (:func:`auralize.sources._kernels.detect_step`).

    Parameters
    ----------
    volume : TimeVolume
        The volume (at least 2 steps).
    cache : StepCache
        Its mapped frames, steady state and floor.
    n : int
        Time step.
    out : ndarray, shape (3, nz, ny, nx), optional
        Where to write the strengths (a new array when None).

    Returns
    -------
    ndarray, shape (3, nz, ny, nx)
        S_m in kg/(m³·s), S_d in kg/(m⁴·s), S_q in kg/(m³·s²).

    Examples
    --------
    A density rising by 0.1 kg/m³ every 0.5 s: S_m = 0.2 kg/(m³·s) everywhere,
    no flow, so no dipoles or quadrupoles:

    >>> rho = 1.0 + 0.1 * np.arange(3.0).reshape(3, 1, 1, 1) * np.ones((3, 4, 4, 4))
    >>> vol = TimeVolume.from_arrays({"density": rho}, times=[0.0, 0.5, 1.0])
    >>> s = step_strengths(vol, StepCache(vol, get_mapping("identity")), 1)
    >>> s.shape, round(float(s[0].min()), 12), round(float(s[0].max()), 12), float(np.abs(s[1:]).max())
    ((3, 4, 4, 4), 0.2, 0.2, 0.0)
    """
    T = volume.n_steps
    a, b = max(n - 1, 0), min(n + 1, T - 1)
    rho_a, v_a, ok_a = cache.frame(a)
    rho_b, v_b, ok_b = cache.frame(b)
    rho_c, v_c, ok_c = cache.frame(n)
    if out is None:
        out = K.empty_like_strengths(volume.shape)
    inv_dt = 1.0 / (volume.times[b] - volume.times[a])
    oks = [o for o in (ok_a, ok_b, ok_c) if o is not None]
    cache.nodata = ~(oks[0] if len(oks) == 1 else np.logical_and.reduce(oks)) if oks else None
    if volume.metric is None:
        _uniform_strengths(volume, cache, n, a=a, b=b, inv_dt=inv_dt, out=out)
        return out
    metric = volume.metric
    if cache.work is None or cache.work.shape != (9, *volume.shape):
        cache.work = np.empty((9, *volume.shape))
    dm, tt = cache.work[:3], cache.work[3:]
    K.momentum_change(rho_a, v_a, rho_b, v_b, dm)
    K.stress(rho_c, v_c, tt)
    curvilinear_strengths(metric, rho_a, rho_b, dm, tt, inv_dt=inv_dt, out=out)
    base = cache.qmean
    if isinstance(base, SteadyBase):
        base.subtract(n, out[2], tt, with_stress=cache.floor > 0)
    elif base is not None:
        np.subtract(out[2], base, out=out[2])
    if cache.nodata is not None:
        metric.mask_nodata(cache.nodata, out)
    if cache.floor > 0:
        _apply_floor(volume, cache, n, a=a, b=b, inv_dt=inv_dt, out=out)
    return out


def _wide_steps(volume: TimeVolume, cache: StepCache, n: int, a: int, b: int) -> tuple[Any, ...]:
    """The frames of steps n-2 and n+2 (clipped) the floor's 2Δt stencil reads, its inverse
    time span (0 when the series is too short for it), and the no-data points of the
    error estimates: the step's and those without data at n-2 or n+2."""
    T = volume.n_steps
    a2, b2 = max(n - 2, 0), min(n + 2, T - 1)
    wide = (a2, b2) != (a, b)
    rho_a2, v_a2, ok_a2 = cache.frame(a2)
    rho_b2, v_b2, ok_b2 = cache.frame(b2)
    inv_dt2 = 1.0 / (volume.times[b2] - volume.times[a2]) if wide else 0.0
    bad = cache.nodata
    extra = [o for o in (ok_a2, ok_b2) if o is not None]
    if extra:
        wider = ~np.logical_and.reduce(extra)
        bad = wider if bad is None else bad | wider
    return rho_a2, v_a2, rho_b2, v_b2, inv_dt2, (_no_bad(volume.shape) if bad is None else bad)


def _uniform_strengths(
    volume: TimeVolume,
    cache: StepCache,
    n: int,
    *,
    a: int,
    b: int,
    inv_dt: float,
    out: NDArray[np.float64],
) -> None:
    """:func:`step_strengths` on a uniform grid: :func:`auralize.sources._kernels.detect_step`."""
    rho_a, v_a, _ = cache.frame(a)
    rho_b, v_b, _ = cache.frame(b)
    rho_c, v_c, _ = cache.frame(n)
    nodata = _no_bad(volume.shape) if cache.nodata is None else cache.nodata
    if cache.floor > 0:
        rho_a2, v_a2, rho_b2, v_b2, inv_dt2, bad = _wide_steps(volume, cache, n, a, b)
        roundoff = ROUNDOFF * input_scale(volume, cache, n)
    else:
        rho_a2, v_a2, rho_b2, v_b2, inv_dt2, bad = rho_a, v_a, rho_b, v_b, 0.0, nodata
        roundoff = np.zeros(3)
    base = cache.qmean
    if isinstance(base, SteadyBase):
        steady = base.parts(n)
    elif base is not None:
        given = np.ascontiguousarray(base, dtype=np.float64)
        steady = (K.STEADY_GIVEN, 0.0, given, *_NO_STEADY[1:])
    else:
        steady = (K.STEADY_NONE, 0.0, *_NO_STEADY)
    rowbad = _NO_ROWS.get(volume.shape) if bad is _NO_BAD.get(volume.shape) else None
    K.detect_step(
        (rho_a, v_a, rho_b, v_b, rho_c, v_c, rho_a2, v_a2, rho_b2, v_b2),
        steady,
        nodata,
        bad,
        inv_dt,
        inv_dt2,
        volume.spacing,
        cache.floor,
        roundoff,
        out,
        rowbad=rowbad,
    )


#: the steady state's arrays when there is none (:func:`auralize.sources._kernels.detect_step`)
_NO_STEADY = (
    np.empty((0, 0, 0)),
    np.empty((0, 0, 0)),
    np.empty((0, 0, 0)),
    np.empty((0, 0, 0, 0)),
    np.empty((0, 0, 0)),
    np.empty((0, 0, 0, 0)),
)


def _apply_floor(
    volume: TimeVolume,
    cache: StepCache,
    n: int,
    *,
    a: int,
    b: int,
    inv_dt: float,
    out: NDArray[np.float64],
) -> None:
    """Zero the strengths of step ``n`` on a curvilinear grid within their discretisation
    error (see :func:`step_strengths`)."""
    assert volume.metric is not None and cache.work is not None
    rho_a2, v_a2, rho_b2, v_b2, inv_dt2, bad = _wide_steps(volume, cache, n, a, b)
    if cache.floor_work is None or cache.floor_work.shape != out.shape:
        cache.floor_work = np.empty_like(out)
    dm2 = cache.floor_work  # the momentum change over 2Δt, planar
    K.momentum_change(rho_a2, v_a2, rho_b2, v_b2, dm2)
    roundoff = ROUNDOFF * input_scale(volume, cache, n)
    work = cache.work
    err = curvilinear_errors(
        volume.metric,
        out,
        rho_a2=rho_a2,
        rho_b2=rho_b2,
        dm=work[:3],
        dm2=dm2,
        tt=work[3:],
        bad=bad,
        inv_dt=inv_dt,
        inv_dt2=inv_dt2,
    )
    K.apply_floor(out, err, float(cache.floor), roundoff)


_NO_BAD: dict[tuple[int, ...], NDArray[np.bool_]] = {}


def _no_bad(shape: tuple[int, ...]) -> NDArray[np.bool_]:
    """An all-False mask of ``shape`` (cached; the kernels only read it, and it stays
    writable so that they are compiled for one kind of mask, not two)."""
    m = _NO_BAD.get(shape)
    if m is None:
        if len(_NO_BAD) > 4:
            _NO_BAD.clear()
            _NO_ROWS.clear()
        m = _NO_BAD[shape] = np.zeros(shape, dtype=bool)
        _NO_ROWS[shape] = np.zeros(shape[:2], dtype=bool)
    return m


#: the rows with a no-data point of each :func:`_no_bad` mask (none)
_NO_ROWS: dict[tuple[int, ...], NDArray[np.bool_]] = {}


def check_floor(floor: float) -> float:
    """A valid floor factor (>= 0; 0 turns the floor off).

    Parameters
    ----------
    floor : float
        The factor (see :class:`Thresholds`).

    Returns
    -------
    float

    Raises
    ------
    ParameterError
        Not a finite number >= 0.

    Examples
    --------
    >>> check_floor("3")
    3.0
    >>> check_floor(-1)
    Traceback (most recent call last):
    ...
    auralize.errors.ParameterError: floor must be a number >= 0 (0: off), got -1
    """
    try:
        f = float(floor)
    except (TypeError, ValueError):
        raise ParameterError(f"floor must be a number >= 0 (0: off), got {floor!r}") from None
    if not (math.isfinite(f) and f >= 0):
        raise ParameterError(f"floor must be a number >= 0 (0: off), got {floor!r}")
    return f


#: relative change of the mapped density and mass flux between two steps below which
#: the second step is taken as steady (six significant digits: text output's precision)
STEADY_RTOL = 1e-6


def steady_anchors(
    volume: TimeVolume,
    mapping: AcousticMapping,
    *,
    rtol: float = STEADY_RTOL,
    store: MappedSeries | None = None,
) -> NDArray[np.int64]:
    """The steps where the field is in its own steady state: the first and the
    last step, and both ends of every step over which nothing changed (the mapped
    density and mass flux within ``rtol`` of their largest magnitude).

    Between two anchors the field's local steady state is the linear
    interpolation of the stress at them (:class:`SteadyBase`).  With ``store``
    the mapped frames come from (and stay in) it, as do each step's input
    maxima (:func:`input_scale`).  Fewer than 3 steps, or a mapping without
    quadrupoles: the first and the last step only.

    Parameters
    ----------
    volume : TimeVolume
        The volume.
    mapping : AcousticMapping
        Its (prepared) mapping.
    rtol : float
        Relative change below which a step is unchanged (:data:`STEADY_RTOL`).
    store : MappedSeries, optional
        Mapped frames to use and keep.

    Returns
    -------
    ndarray of int64, shape (A,)
        Sorted anchor steps.

    Examples
    --------
    Steps 1 and 2 are the same:

    >>> rho = np.array([1.0, 2.0, 2.0, 3.0, 4.0]).reshape(5, 1, 1, 1) * np.ones((5, 3, 3, 3))
    >>> vol = TimeVolume.from_arrays({"density": rho, "velocity": np.ones((5, 3, 3, 3, 3))})
    >>> m = get_mapping("identity")
    >>> steady_anchors(vol, m).tolist()
    [0, 1, 2, 4]
    """
    T = volume.n_steps
    anchors = {0, T - 1}
    if T < 3 or mapping.unavailable(volume).get("quadrupole"):
        return np.array(sorted(anchors), dtype=np.int64)
    cache = StepCache(volume, mapping, store=store)
    r0, v0, _ = cache.frame(0)
    before = K.input_maxima_planes(r0, v0)
    if store is not None:
        store.maxima[0] = before
    for n in range(1, T):
        r0, v0, _ = cache.frame(n - 1)
        r1, v1, _ = cache.frame(n)
        # max|r1 - r0| and max|m1 - m0|, m = ρv, with step n's input maxima, in one
        # compiled pass; the frames are finite, so the maxima are the NaN-free ones
        dr, dm, now = K.step_change(r0, v0, r1, v1)
        if store is not None:
            store.maxima[n] = now
        (a0, b0, _), (a1, b1, _) = before.max(axis=0, initial=0.0), now.max(axis=0, initial=0.0)
        before = now
        scale_r = max(a0, a1)
        scale_m = max(b0, b1)
        if dr <= rtol * scale_r and dm <= rtol * scale_m:
            anchors.update((n - 1, n))
        cache.keep(n, n)
    return np.array(sorted(anchors), dtype=np.int64)


#: anchors whose quadrupole strength :class:`SteadyBase` keeps: the two around a step, and
#: a third for the steps detected at the same time on either side of an anchor
ANCHORS_KEPT = 3


class SteadyBase:
    """The field's local steady state, whose sound is removed (``steady="remove"``).

    Lighthill's far field depends on the time changes of the stress
    T_ij = ρ v_i v_j only, and a flow that is steady, or has become steady,
    makes no sound.  The steady state is judged locally in time: at the
    anchor steps (:func:`steady_anchors`: the first and the last step, and
    every stretch over which nothing changed) it is the stress itself, and
    between two anchors the linear interpolation of the stress at them.  The
    quadrupole strength of step n is that of T(n) minus this state: exactly
    0 at an anchor (a steady stretch, the ends of the series) and, since the
    state is linear in time between anchors, its ∂²/∂t² is 0 there and the
    far field it removes is nothing but the static near field of the mean
    stress.

    Parameters
    ----------
    volume : TimeVolume
        The volume (or one slab of it).
    mapping : AcousticMapping
        Its (prepared) mapping.
    anchors : ndarray of int, shape (A,)
        Anchor steps (:func:`steady_anchors`; sorted and made unique here).
    store : MappedSeries, optional
        Where the anchors' mapped frames come from (None: mapped here).

    Examples
    --------
    >>> rho = np.array([1.0, 2.0, 2.0, 3.0, 4.0]).reshape(5, 1, 1, 1) * np.ones((5, 3, 3, 3))
    >>> vol = TimeVolume.from_arrays({"density": rho, "velocity": np.ones((5, 3, 3, 3, 3))})
    >>> m = get_mapping("identity")
    >>> base = SteadyBase(vol, m, [0, 4])
    >>> base.at(4) is None
    True
    >>> sq, tt = base.at(2)  # halfway: the mean of the stress ρ v_i v_j at steps 0 and 4
    >>> tt.shape, round(float(tt[0, 1, 1, 1]), 12), float(np.abs(sq).max())
    ((6, 3, 3, 3), 2.5, 0.0)
    """

    def __init__(
        self,
        volume: TimeVolume,
        mapping: AcousticMapping,
        anchors: NDArray[np.integer],
        *,
        store: MappedSeries | None = None,
    ) -> None:
        self.volume, self.mapping = volume, mapping
        self.anchors = np.unique(np.asarray(anchors, dtype=np.int64))
        self.store = store
        #: per anchor step: the quadrupole strength of its stress, its density and velocity
        self._held: dict[
            int, tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
        ] = {}
        self._tt: dict[int, NDArray[np.float64]] = {}
        self._lock = threading.Lock()  # detection's threads share the anchors

    def for_volume(self, volume: TimeVolume, mapping: AcousticMapping | None = None) -> SteadyBase:
        """The same anchors on another volume (a slab of this one).

        Parameters
        ----------
        volume : TimeVolume
            The other volume.
        mapping : AcousticMapping, optional
            Its mapping (None: this one's).

        Returns
        -------
        SteadyBase
            Without a store.

        Examples
        --------
        >>> rho = np.array([1.0, 2.0, 2.0, 3.0, 4.0]).reshape(5, 1, 1, 1) * np.ones((5, 3, 3, 3))
        >>> vol = TimeVolume.from_arrays({"density": rho, "velocity": np.ones((5, 3, 3, 3, 3))})
        >>> m = get_mapping("identity")
        >>> SteadyBase(vol, m, [4, 0, 0]).for_volume(vol).anchors.tolist()
        [0, 4]
        """
        return SteadyBase(volume, self.mapping if mapping is None else mapping, self.anchors)

    def _anchor(
        self, a: int
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Anchor step ``a``'s ``(S_q of its stress, rho, v)`` (the last :data:`ANCHORS_KEPT`
        anchors kept)."""
        with self._lock:
            hit = self._held.get(a)
            if hit is None:
                rho, v, _ = StepCache(self.volume, self.mapping, store=self.store).frame(a)
                tt = np.ascontiguousarray(_stress(rho, v))
                metric = self.volume.metric
                sq = (
                    K.quadrupole_of_stress(tt, self.volume.spacing)
                    if metric is None
                    else metric.quadrupole(tt)
                )
                hit = (sq, rho, v)
                if len(self._held) >= ANCHORS_KEPT:
                    gone = next(iter(self._held))
                    self._held.pop(gone)
                    self._tt.pop(gone, None)
                self._held[a] = hit
            return hit

    def _state(self, a: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Anchor step ``a``'s ``(S_q, stress)``."""
        sq, rho, v = self._anchor(a)
        tt = self._tt.get(a)
        if tt is None:
            tt = self._tt[a] = np.ascontiguousarray(_stress(rho, v))
        return sq, tt

    def at(self, n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """``(S_q, stress)`` of the steady state at step ``n``, or None at an anchor
        (the field is its own steady state there).

        Parameters
        ----------
        n : int
            Time step.

        Returns
        -------
        tuple of ndarray, or None
            The quadrupole strength ``(nz, ny, nx)`` of the interpolated stress,
            kg/(m³·s²), and that stress ``(6, nz, ny, nx)`` (xx, yy, zz, xy, xz,
            yz: :data:`STRESS_PAIRS`), kg/(m·s²); None at an anchor.

        Examples
        --------
        >>> rho = np.array([1.0, 2.0, 2.0, 3.0, 4.0]).reshape(5, 1, 1, 1) * np.ones((5, 3, 3, 3))
        >>> vol = TimeVolume.from_arrays({"density": rho, "velocity": np.ones((5, 3, 3, 3, 3))})
        >>> m = get_mapping("identity")
        >>> base = SteadyBase(vol, m, [0, 4])
        >>> base.at(0) is None, round(float(base.at(1)[1][3].mean()), 12)
        (True, 1.75)
        """
        i = int(np.searchsorted(self.anchors, n))
        if i < self.anchors.size and self.anchors[i] == n:
            return None
        a, b = int(self.anchors[i - 1]), int(self.anchors[i])
        t = self.volume.times
        f = float((t[n] - t[a]) / (t[b] - t[a]))
        sa, ta = self._state(a)
        sb, tb = self._state(b)
        return (1.0 - f) * sa + f * sb, (1.0 - f) * ta + f * tb

    def parts(self, n: int) -> tuple[Any, ...]:
        """The steady state at step ``n`` as :func:`auralize.sources._kernels.detect_step`
        takes it: ``(mode, f, sa, sb, rho_a, v_a, rho_b, v_b)``, the anchors' quadrupole
        strengths and their frames (whose stress :meth:`subtract` subtracts).

        Parameters
        ----------
        n : int
            Time step.

        Returns
        -------
        tuple
            ``mode`` (``K.STEADY_ANCHOR`` at an anchor, then with empty arrays, else
            ``K.STEADY_BETWEEN``), the interpolation weight ``f`` of the later
            anchor, and the anchors' S_q ``(nz, ny, nx)``, ρ and v.

        Examples
        --------
        >>> rho = np.array([1.0, 2.0, 2.0, 3.0, 4.0]).reshape(5, 1, 1, 1) * np.ones((5, 3, 3, 3))
        >>> vol = TimeVolume.from_arrays({"density": rho, "velocity": np.ones((5, 3, 3, 3, 3))})
        >>> m = get_mapping("identity")
        >>> base = SteadyBase(vol, m, [0, 4])
        >>> base.parts(0)[0] == K.STEADY_ANCHOR, base.parts(1)[0] == K.STEADY_BETWEEN
        (True, True)
        >>> round(base.parts(1)[1], 12), base.parts(1)[4].shape
        (0.25, (3, 3, 3))
        """
        i = int(np.searchsorted(self.anchors, n))
        if i < self.anchors.size and self.anchors[i] == n:
            return (K.STEADY_ANCHOR, 0.0, *_NO_STEADY)
        a, b = int(self.anchors[i - 1]), int(self.anchors[i])
        t = self.volume.times
        f = float((t[n] - t[a]) / (t[b] - t[a]))
        sa, ra, va = self._anchor(a)
        sb, rb, vb = self._anchor(b)
        return (K.STEADY_BETWEEN, f, sa, sb, ra, va, rb, vb)

    def subtract(
        self, n: int, sq: NDArray[np.float64], tt: NDArray[np.float64], *, with_stress: bool
    ) -> None:
        """Subtract the steady state at step ``n`` from the quadrupole strength ``sq``
        (and, ``with_stress``, from the stress ``tt``) in place: ``sq - at(n)[0]``
        (0 at an anchor) in one compiled pass, without :meth:`at`'s arrays.

        Parameters
        ----------
        n : int
            Time step.
        sq : ndarray, shape (nz, ny, nx)
            Quadrupole strength of step ``n``, kg/(m³·s²); changed in place.
        tt : ndarray, shape (6, nz, ny, nx)
            Stress of step ``n``; changed in place with ``with_stress``.
        with_stress : bool
            Subtract the interpolated stress from ``tt`` too.

        Examples
        --------
        >>> rho = np.array([1.0, 2.0, 2.0, 3.0, 4.0]).reshape(5, 1, 1, 1) * np.ones((5, 3, 3, 3))
        >>> vol = TimeVolume.from_arrays({"density": rho, "velocity": np.ones((5, 3, 3, 3, 3))})
        >>> m = get_mapping("identity")
        >>> base = SteadyBase(vol, m, [0, 4])
        >>> sq, tt = np.ones((3, 3, 3)), np.full((6, 3, 3, 3), 3.0)
        >>> base.subtract(2, sq, tt, with_stress=True)
        >>> float(sq.max()), round(float(tt[0, 0, 0, 0]), 12)
        (1.0, 0.5)
        >>> base.subtract(4, sq, tt, with_stress=False)
        >>> float(sq.max())
        0.0
        """
        i = int(np.searchsorted(self.anchors, n))
        if i < self.anchors.size and self.anchors[i] == n:
            sq[...] = 0.0  # the field's own steady state: no fluctuation
            return
        a, b = int(self.anchors[i - 1]), int(self.anchors[i])
        t = self.volume.times
        f = float((t[n] - t[a]) / (t[b] - t[a]))
        sa, ta = self._state(a)
        sb, tb = self._state(b)
        K.subtract_steady(sq, sa, sb, tt, ta, tb, f, bool(with_stress))


def _stress(rho: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.stack([rho * v[..., p] * v[..., q] for p, q in STRESS_PAIRS])


#: component pairs of the stress in the kernels' order xx, yy, zz, xy, xz, yz
STRESS_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def steady_strength(
    volume: TimeVolume,
    m: AcousticMapping,
    steady: str = "remove",
    *,
    store: MappedSeries | None = None,
) -> SteadyBase | None:
    """The field's local steady state to subtract (``steady="remove"``,
    :class:`SteadyBase`), or None (``"keep"``); ``store`` as :func:`steady_anchors`.

    Parameters
    ----------
    volume : TimeVolume
        The volume.
    m : AcousticMapping
        Its (prepared) mapping.
    steady : {"remove", "keep"}
        Whether the steady part is removed.
    store : MappedSeries, optional
        Mapped frames to use and keep.

    Returns
    -------
    SteadyBase or None

    Raises
    ------
    ParameterError
        ``steady`` is not one of :data:`STEADY_MODES`.

    Examples
    --------
    >>> rho = np.array([1.0, 2.0, 2.0, 3.0, 4.0]).reshape(5, 1, 1, 1) * np.ones((5, 3, 3, 3))
    >>> vol = TimeVolume.from_arrays({"density": rho, "velocity": np.ones((5, 3, 3, 3, 3))})
    >>> m = get_mapping("identity")
    >>> steady_strength(vol, m).anchors.tolist(), steady_strength(vol, m, "keep")
    ([0, 1, 2, 4], None)
    """
    if check_steady(steady) == "keep":
        return None
    return SteadyBase(volume, m, steady_anchors(volume, m, store=store), store=store)


def compute_strengths(
    volume: TimeVolume,
    mapping: str | AcousticMapping | None = None,
    step: int = 0,
    *,
    steady: str = "remove",
) -> NDArray[np.float64]:
    """Strengths ``(3, nz, ny, nx)`` at one step (convenience for inspection).

    ``steady="remove"`` (default, as :func:`detect`): those of the time-varying
    part; ``"keep"``: the paper's literal strengths (paper 003 §3.2.3,
    Eqs. 13–14).  No discretisation-error floor is applied (all strengths as
    computed, see :func:`step_strengths`).

    Parameters
    ----------
    volume : TimeVolume
        At least two time steps.
    mapping : str or AcousticMapping, optional
        Mapping preset or instance (:func:`~auralize.sources.mapping.get_mapping`;
        default ``identity``); it is prepared here.
    step : int
        Time step.
    steady : {"remove", "keep"}
        Whether the quadrupole strength of the steady state is removed.

    Returns
    -------
    ndarray, shape (3, nz, ny, nx)
        S_m in kg/(m³·s), S_d in kg/(m⁴·s), S_q in kg/(m³·s²).

    Raises
    ------
    DataError
        Fewer than 2 time steps.
    ParameterError
        An unknown mapping or ``steady``.

    Examples
    --------
    >>> rho = 1.0 + 0.1 * np.arange(3.0).reshape(3, 1, 1, 1) * np.ones((3, 4, 4, 4))
    >>> vol = TimeVolume.from_arrays({"density": rho}, times=[0.0, 0.5, 1.0])
    >>> s = compute_strengths(vol, "identity", step=2)
    >>> s.shape, round(float(s[0].mean()), 12)
    ((3, 4, 4, 4), 0.2)
    """
    require_steps(volume)
    m = get_mapping(mapping)
    m.prepare(volume)
    return step_strengths(
        volume, StepCache(volume, m, qmean=steady_strength(volume, m, steady)), step
    )


def check_steady(steady: str) -> str:
    """``steady`` if it is one of :data:`STEADY_MODES`.

    Parameters
    ----------
    steady : str
        ``"remove"`` or ``"keep"``.

    Returns
    -------
    str
        ``steady``.

    Raises
    ------
    ParameterError
        Any other value.

    Examples
    --------
    >>> check_steady("keep")
    'keep'
    >>> check_steady("mean")
    Traceback (most recent call last):
    ...
    auralize.errors.ParameterError: steady must be one of ('remove', 'keep'), got 'mean'
    """
    if steady not in STEADY_MODES:
        raise ParameterError(f"steady must be one of {STEADY_MODES}, got {steady!r}")
    return steady


def delta_v_rule(delta_v: str) -> int:
    """The kernels' code of a ΔV rule name (:data:`DELTA_V_RULES`).

    Parameters
    ----------
    delta_v : str
        ``"cell"`` or ``"sphere"``.

    Returns
    -------
    int
        ``K.DV_CELL`` or ``K.DV_SPHERE``.

    Raises
    ------
    ParameterError
        Any other name.

    Examples
    --------
    >>> delta_v_rule("sphere") == K.DV_SPHERE
    True
    >>> delta_v_rule("ball")
    Traceback (most recent call last):
    ...
    auralize.errors.ParameterError: delta_v must be one of ['cell', 'sphere'], got 'ball'
    """
    try:
        return DELTA_V_RULES[delta_v]
    except KeyError:
        raise ParameterError(
            f"delta_v must be one of {sorted(DELTA_V_RULES)}, got {delta_v!r}"
        ) from None


def classify(
    strengths: NDArray[np.float64],
    thresholds: NDArray[np.float64],
    spacing: NDArray[np.float64],
    *,
    zero_fraction: float = 1.0,
    delta_v: str = "cell",
    cell: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
    """Classify vertices and compute ΔV radii from strengths ``(3, nz, ny, nx)``.

    Exclusive classification of paper 003 §3.2.3 on magnitudes: a monopole if
    ``|S_m| > T_m``; a dipole if ``|S_d| > T_d`` and ``|S_m|`` is almost zero;
    a quadrupole if ``|S_q| > T_q`` and both others are almost zero ("almost
    zero": at most ``zero_fraction`` times that type's threshold).  ``delta_v``
    is ``"cell"`` (ΔV = the box the cut distances of §3.2.4.1 bound, the
    vertex's share of the source region, so Σ S ΔV converges to ∫ S dV) or
    ``"sphere"`` (the sphere of the mean cut distance, §3.2.4.1, Fig. 3,
    literally); see :func:`auralize.sources._kernels.classify_and_radius`.

    ``cell (nz, ny, nx)``: on a curvilinear grid, each point's cell volume
    |det ∂x/∂ξ| (:class:`~auralize.curvilinear.CurvilinearMetric`); the cuts
    are then taken in index units (``spacing`` ignored) and ΔV is their box
    times the cell volume (a radius times its cube root).

    Parameters
    ----------
    strengths : ndarray, shape (3, nz, ny, nx)
        S_m, S_d, S_q (:func:`step_strengths`).
    thresholds : ndarray, shape (3,)
        Absolute thresholds (:meth:`Thresholds.resolve`).
    spacing : ndarray, shape (3,)
        Grid spacing (x, y, z), m.
    zero_fraction : float
        "Almost zero", as a fraction of each type's threshold.
    delta_v : {"cell", "sphere"}
        ΔV rule.
    cell : ndarray, shape (nz, ny, nx), optional
        Cell volumes of a curvilinear grid, m³.

    Returns
    -------
    kind : ndarray of int8, shape (nz, ny, nx)
        0 none, 1 monopole, 2 dipole, 3 quadrupole.
    radius : ndarray, shape (nz, ny, nx)
        Radius of the sphere of volume ΔV, m (0 where no source).

    Raises
    ------
    ParameterError
        An unknown ``delta_v``.

    Examples
    --------
    The threshold is crossed 0.9 of the way to each neighbour: the sphere's
    radius is the mean cut 0.9, the cell's box is 1.8³:

    >>> s = np.zeros((3, 3, 3, 3))
    >>> s[0, 1, 1, 1] = 10.0  # one monopole of 10 in a 3³ grid, thresholds 1
    >>> kind, r_cell = classify(s, np.ones(3), np.ones(3))
    >>> _, r_sphere = classify(s, np.ones(3), np.ones(3), delta_v="sphere")
    >>> int(kind[1, 1, 1]), int((kind > 0).sum()), round(float(r_sphere[1, 1, 1]), 12)
    (1, 1, 0.9)
    >>> round(4 / 3 * np.pi * float(r_cell[1, 1, 1]) ** 3, 12)
    5.832
    """
    s = np.ascontiguousarray(strengths, dtype=np.float64)
    thr = np.asarray(thresholds, dtype=np.float64)
    zero = thr * zero_fraction
    kind = np.empty(s.shape[1:], dtype=np.int8)
    radius = np.empty(s.shape[1:], dtype=np.float64)
    h = np.ones(3) if cell is not None else np.asarray(spacing, dtype=np.float64)
    K.classify_and_radius(s, thr, zero, h, kind, radius, delta_v_rule(delta_v))
    if cell is not None:
        radius *= np.cbrt(cell)
    return kind, radius


def classify_sources(
    strengths: NDArray[np.float64],
    thresholds: NDArray[np.float64],
    spacing: NDArray[np.float64],
    *,
    zero_fraction: float = 1.0,
    delta_v: str = "cell",
    cell: NDArray[np.float64] | None = None,
    kinds: NDArray[np.int8] | None = None,
) -> SourceFrame:
    """:func:`classify` then :func:`extract`, the same :class:`SourceFrame`, without the
    arrays of every point's radius (:func:`auralize.sources._kernels.sources`).

    Parameters
    ----------
    strengths : ndarray, shape (3, nz, ny, nx)
        S_m, S_d, S_q (:func:`step_strengths`).
    thresholds : ndarray, shape (3,)
        Absolute thresholds.
    spacing : ndarray, shape (3,)
        Grid spacing (x, y, z), m.
    zero_fraction : float
        "Almost zero", as a fraction of each type's threshold.
    delta_v : {"cell", "sphere"}
        ΔV rule.
    cell : ndarray, shape (nz, ny, nx), optional
        Cell volumes of a curvilinear grid, m³.
    kinds : ndarray of int8, shape (nz, ny, nx), optional
        Scratch of the grid's shape, reused between steps.

    Returns
    -------
    SourceFrame
        Without ``n_valid``.

    Raises
    ------
    ParameterError
        An unknown ``delta_v``.

    Examples
    --------
    >>> s = np.zeros((3, 3, 3, 3))
    >>> s[0, 1, 1, 1] = 10.0  # one monopole of 10 in a 3³ grid, thresholds 1
    >>> f = classify_sources(s, np.ones(3), np.ones(3))
    >>> g = extract(*classify(s, np.ones(3), np.ones(3)), s)
    >>> f.index.tolist(), bool(np.array_equal(f.radius, g.radius))
    ([13], True)
    """
    s = np.ascontiguousarray(strengths, dtype=np.float64)
    thr = np.asarray(thresholds, dtype=np.float64)
    h = np.ones(3) if cell is not None else np.asarray(spacing, dtype=np.float64)
    idx, kind, strength, radius = K.sources(
        s, thr, thr * zero_fraction, h, delta_v_rule(delta_v), kinds
    )
    if cell is not None:
        radius *= np.cbrt(cell.reshape(-1)[idx])
    return SourceFrame(index=idx, kind=kind, strength=strength, radius=radius)


def extract(
    kind: NDArray[np.int8], radius: NDArray[np.float64], strengths: NDArray[np.float64]
) -> SourceFrame:
    """Gather the source points of one step into a :class:`SourceFrame`.

    Parameters
    ----------
    kind : ndarray of int8, shape (nz, ny, nx)
        Source type of each vertex (0: none), as :func:`classify` gives it.
    radius : ndarray, shape (nz, ny, nx)
        ΔV radius of each vertex, m.
    strengths : ndarray, shape (3, nz, ny, nx)
        S_m, S_d, S_q.

    Returns
    -------
    SourceFrame
        The vertices with ``kind > 0`` in flat C order, each with the strength
        of its type.

    Examples
    --------
    >>> s = np.zeros((3, 3, 3, 3))
    >>> s[0, 1, 1, 1] = 10.0  # one monopole of 10 in a 3³ grid, thresholds 1
    >>> f = extract(*classify(s, np.ones(3), np.ones(3)), s)
    >>> f.index.tolist(), f.kind.tolist(), f.strength.tolist()
    ([13], [1], [10.0])
    """
    flat_kind = kind.reshape(-1)
    idx = np.flatnonzero(flat_kind)
    k = flat_kind[idx]
    s = strengths.reshape(3, -1)[k.astype(np.intp) - 1, idx]
    return SourceFrame(
        index=idx.astype(np.int64), kind=k, strength=s, radius=radius.reshape(-1)[idx]
    )


def gradient(
    f: NDArray[np.float64], spacing: NDArray[np.float64], scale: float = 1.0
) -> NDArray[np.float64]:
    """∇f · ``scale`` ``(nz, ny, nx, 3)`` (components x, y, z) of ``f (nz, ny, nx)``:
    :func:`numpy.gradient`'s differences (central inside, one-sided at the faces;
    0 along an axis of one point) in the compiled stencil, the same numbers.

    Parameters
    ----------
    f : ndarray, shape (nz, ny, nx)
        Values on a uniform grid.
    spacing : ndarray, shape (3,)
        Spacing (x, y, z), m.
    scale : float
        Factor applied to the gradient.

    Returns
    -------
    ndarray, shape (nz, ny, nx, 3)
        The gradient (units of ``f`` per m, times ``scale``).

    Examples
    --------
    >>> f = np.broadcast_to(np.arange(4.0) ** 2, (2, 2, 4))
    >>> gradient(f, np.array([0.5, 1.0, 1.0]))[0, 0, :, 0].tolist()
    [2.0, 4.0, 8.0, 10.0]
    >>> bool(np.array_equal(gradient(f, np.ones(3))[..., 0], np.gradient(f, axis=2)))
    True
    """
    f = np.ascontiguousarray(f, dtype=np.float64)
    out = np.empty((*f.shape, 3))
    K.gradient(f, np.asarray(spacing, dtype=np.float64), float(scale), out)
    return out


def in_threads(fn: Any, n: int) -> None:
    """Call ``fn(i)`` for ``0 <= i < n`` on the detection's threads
    (:func:`auralize.sources._kernels.in_threads`); ``fn`` releases the GIL.

    Parameters
    ----------
    fn : callable
        ``fn(i)``, its result ignored.
    n : int
        Number of calls.

    Examples
    --------
    >>> rows = np.zeros((4, 3))
    >>> in_threads(lambda i: rows[i].fill(i), 4)
    >>> rows[:, 0].tolist()
    [0.0, 1.0, 2.0, 3.0]
    """
    K.in_threads(fn, n)


#: arrays of at least this many values are worked on in slabs on the detection's threads
SLAB_SPLIT = 1 << 16


def in_slabs(fn: Any, x: NDArray[Any]) -> bool:
    """Call ``fn(sl)`` for slices ``sl`` that split the first axis of ``x`` into one slab
    per thread, on the detection's threads (``fn`` runs numpy, which releases the GIL);
    False (nothing called) when ``x`` is too small to be worth it (:data:`SLAB_SPLIT`).

    Parameters
    ----------
    fn : callable
        ``fn(sl)`` for a slice of the first axis, its result ignored.
    x : ndarray
        The array whose first axis is split.

    Returns
    -------
    bool
        Whether ``fn`` was called (then the slices cover the axis once).

    Examples
    --------
    >>> x = np.ones((8, 128, 128))
    >>> in_slabs(lambda sl: np.multiply(x[sl], 2.0, out=x[sl]), x), float(x.min())
    (True, 2.0)
    >>> in_slabs(lambda sl: None, np.ones((2, 2)))
    False
    """
    if x.size < SLAB_SPLIT or x.ndim == 0 or x.shape[0] < 2:
        return False
    threads = K.thread_count()
    n = min(x.shape[0], threads)
    edges = K.split(x.shape[0], n)
    K.in_threads(lambda i: fn(slice(edges[i], edges[i + 1])), n, threads)
    return True


def gradient_max(
    f: NDArray[np.float64], spacing: NDArray[np.float64], out: NDArray[np.float64]
) -> float:
    """:func:`gradient` (scale 1) into ``out (nz, ny, nx, 3)``, and :func:`gradient_absmax`
    of it, in one pass.

    Parameters
    ----------
    f : ndarray, shape (nz, ny, nx)
        Values on a uniform grid.
    spacing : ndarray, shape (3,)
        Spacing (x, y, z), m.
    out : ndarray, shape (nz, ny, nx, 3)
        Receives the gradient.

    Returns
    -------
    float
        The largest finite |component| (0 if none).

    Examples
    --------
    >>> f = np.broadcast_to(np.arange(4.0) ** 2, (2, 2, 4)).copy()
    >>> out = np.empty((2, 2, 4, 3))
    >>> gradient_max(f, np.ones(3), out), out[0, 0, :, 0].tolist()
    (5.0, [1.0, 2.0, 4.0, 5.0])
    """
    return float(K.gradient_max(f, np.asarray(spacing, dtype=np.float64), out))


def gradient_absmax(f: NDArray[np.float64], spacing: NDArray[np.float64]) -> float:
    """The largest |component| of :func:`gradient` over the finite ones (0 if none),
    without making the gradient.

    Parameters
    ----------
    f : ndarray, shape (nz, ny, nx)
        Values on a uniform grid.
    spacing : ndarray, shape (3,)
        Spacing (x, y, z), m.

    Returns
    -------
    float

    Examples
    --------
    >>> f = np.broadcast_to(np.arange(4.0) ** 2, (2, 2, 4)).copy()
    >>> gradient_absmax(f, np.array([0.5, 1.0, 1.0]))
    10.0
    """
    return float(K.gradient_absmax(f, spacing))


def require_steps(volume: TimeVolume) -> None:
    """Check the volume has the 2 steps or more that detection needs.

    Parameters
    ----------
    volume : TimeVolume
        The volume.

    Raises
    ------
    DataError
        Fewer than 2 time steps (strengths are time derivatives).

    Examples
    --------
    >>> require_steps(TimeVolume.from_arrays({"density": np.ones((1, 2, 2, 2))}))
    Traceback (most recent call last):
    ...
    auralize.errors.DataError: <memory>: source detection needs at least 2 time steps ...
    """
    if volume.n_steps < 2:
        raise DataError(
            f"{volume.source}: source detection needs at least 2 time steps (strengths are "
            f"time derivatives); this volume has {volume.n_steps}"
        )


def input_scale(
    volume: TimeVolume, cache: StepCache, n: int, lo: int = 0, hi: int | None = None
) -> NDArray[np.float64]:
    """Size of the terms each strength of step ``n`` is a difference of (planes ``[lo, hi)``).

    ``max|ρ|/Δt`` (monopole), ``max|ρv|/(h Δt)`` (dipole) and
    ``max|ρ| |v|²/h²`` (quadrupole; the largest |ρ v_i v_j|), with the
    smallest step Δt and spacing h: a strength far below it is round-off
    (e.g. the dipole strength of a divergence-free flow), not a source.

    Parameters
    ----------
    volume : TimeVolume
        The volume.
    cache : StepCache
        Its mapped frames (each step's per-plane maxima are kept in it).
    n : int
        Time step.
    lo, hi : int
        Planes (z indices) of a slab (default all).

    Returns
    -------
    ndarray, shape (3,)
        kg/(m³·s), kg/(m⁴·s), kg/(m³·s²).

    Examples
    --------
    >>> vol = TimeVolume.from_arrays({"density": np.full((3, 2, 2, 2), 2.0),
    ...                               "velocity": np.full((3, 2, 2, 2, 3), 3.0)},
    ...                              times=[0.0, 0.5, 1.0], spacing=0.5)
    >>> input_scale(vol, StepCache(vol, get_mapping("identity")), 1).tolist()
    [4.0, 24.0, 72.0]
    """
    sl = slice(lo, hi)
    dt = float(np.min(np.diff(volume.times)))
    live = [volume.spacing[a] for a in range(3) if volume.dims[a] > 1]
    h = float(min(live)) if live else 1.0
    planes = cache.maxima.get(n)
    if planes is None and cache.store is not None:
        planes = cache.store.maxima.get(n)
    if planes is None:
        rho, v, _ = cache.frame(n)
        planes = cache.maxima[n] = K.input_maxima_planes(rho, v)
    r, mm, t = np.max(planes[sl], axis=0, initial=0.0)
    return np.array([r / dt, mm / (h * dt), t / (h * h)])


def sample_stats(
    s: NDArray[np.float64],
    nodata: NDArray[np.bool_] | None,
    offset: int,
    n_points: int,
    scale: NDArray[np.float64] | None = None,
) -> StrengthStats:
    """:class:`StrengthStats` of one step's strengths ``(3, ...)`` (or a slab's planes).

    ``offset`` is the global flat index of the first point of ``s``,
    ``n_points`` the number of points of the whole grid: the sampled points
    depend on the global index only.

    Parameters
    ----------
    s : ndarray, shape (3, ...)
        S_m, S_d, S_q of the step (or slab).
    nodata : ndarray of bool, or None
        No-data points of ``s`` (left out of the sample; None: none).
    offset : int
        Global flat index of the first point of ``s``.
    n_points : int
        Points of the whole grid; above :data:`SAMPLE_POINTS` a fixed subset
        is sampled.
    scale : ndarray, shape (3,), optional
        :func:`input_scale` of the step (None: zeros).

    Returns
    -------
    StrengthStats
        The peak over all points of ``s``, the sample unsorted.

    Examples
    --------
    >>> s = np.arange(24.0).reshape(3, 2, 2, 2) - 12.0
    >>> nodata = np.zeros((2, 2, 2), dtype=bool)
    >>> nodata[0, 0, 0] = True
    >>> st = sample_stats(s, nodata, 0, 8)
    >>> st.peak.tolist(), st.sample.shape
    ([12.0, 4.0, 11.0], (3, 7))
    """
    flat = s.reshape(3, -1)
    a = np.abs(flat)
    if n_points > SAMPLE_POINTS:
        # the sampled points (:func:`_sampled_points`), less those without data
        idx = _sampled_points(offset, flat.shape[1], n_points)
        if nodata is not None:
            idx = idx[~nodata.reshape(-1)[idx]]
        sample = a[:, idx]
    else:
        sample = a if nodata is None else a[:, ~nodata.reshape(-1)]
    peak = a.max(axis=1) if a.size else np.zeros(3)
    return StrengthStats(
        peak=peak,
        sample=sample.copy(),
        scale=np.zeros(3) if scale is None else np.asarray(scale, dtype=np.float64),
    )


_SAMPLED: dict[tuple[int, int, int], NDArray[np.intp]] = {}


def _sampled_points(offset: int, size: int, n_points: int) -> NDArray[np.intp]:
    """Where in a run of ``size`` points from global flat index ``offset`` (of ``n_points``) the
    points sampled for the statistics are: those whose index hashes below
    :data:`SAMPLE_POINTS` / ``n_points`` of the hash range, the same at every step (cached)."""
    key = (offset, size, n_points)
    hit = _SAMPLED.get(key)
    if hit is None:
        g = np.arange(offset, offset + size, dtype=np.uint64)
        h = (g * np.uint64(2654435761)) & np.uint64(0xFFFFFFFF)
        hit = np.flatnonzero(h < np.uint64(int(SAMPLE_POINTS / n_points * 2**32)))
        if len(_SAMPLED) > 64:
            _SAMPLED.clear()
        _SAMPLED[key] = hit
    return hit


def sample_steps(n_steps: int, max_steps: int = AUTO_SAMPLE_STEPS) -> NDArray[np.int64]:
    """The evenly spaced steps whose strengths set relative, top and auto thresholds.

    Parameters
    ----------
    n_steps : int
        Steps of the series.
    max_steps : int
        Most steps sampled (:data:`AUTO_SAMPLE_STEPS`).

    Returns
    -------
    ndarray of int64
        Sorted steps, the first and the last included.

    Examples
    --------
    >>> sample_steps(30).tolist(), sample_steps(3).tolist()
    ([0, 4, 8, 12, 17, 21, 25, 29], [0, 1, 2])
    """
    return np.unique(np.linspace(0, n_steps - 1, min(max_steps, n_steps)).round()).astype(np.int64)


def strength_stats(
    volume: TimeVolume,
    mapping: AcousticMapping,
    *,
    qmean: SteadyBase | NDArray[np.float64] | None = None,
    max_steps: int = AUTO_SAMPLE_STEPS,
    floor: float = 0.0,
    progress_bar: bool = False,
    store: MappedSeries | None = None,
    keep: dict[int, tuple[np.ndarray, np.ndarray | None]] | None = None,
) -> StrengthStats:
    """|S| statistics of each type over evenly spaced sample steps (valid points only;
    strengths within their discretisation error are 0 with ``floor`` > 0, see
    :func:`step_strengths`).

    Parameters
    ----------
    volume : TimeVolume
        The volume (at least 2 steps).
    mapping : AcousticMapping
        Its (prepared) mapping.
    qmean : SteadyBase or ndarray, optional
        Steady state removed from the quadrupole strength (:class:`StepCache`).
    max_steps : int
        Most steps sampled (:func:`sample_steps`).
    floor : float
        Discretisation-error floor (0: off).
    progress_bar : bool
        Show a progress bar on stderr.
    store : MappedSeries, optional
        Where the mapped frames come from.
    keep : dict, optional
        Receives each sample step's strengths and no-data mask
        (``{step: (strengths, nodata)}``), for :func:`iter_detect` to reuse.

    Returns
    -------
    StrengthStats
        Merged over the sample steps (samples sorted).

    Examples
    --------
    >>> rho = 1.0 + 0.1 * np.arange(3.0).reshape(3, 1, 1, 1) * np.ones((3, 4, 4, 4))
    >>> vol = TimeVolume.from_arrays({"density": rho}, times=[0.0, 0.5, 1.0])
    >>> st = strength_stats(vol, get_mapping("identity"))
    >>> st.peak.round(12).tolist(), st.sample.shape, st.scale.tolist()
    ([0.2, 0.0, 0.0], (3, 192), [2.4, 0.0, 0.0])
    """
    cache = StepCache(volume, mapping, qmean=qmean, floor=floor, store=store)
    buf = K.empty_like_strengths(volume.shape)
    parts = []
    steps = sample_steps(volume.n_steps, max_steps)
    for n in progress(steps, desc="peak pass", enabled=progress_bar, unit="step"):
        if keep is not None:  # each kept step's strengths in their own array
            buf = K.empty_like_strengths(volume.shape)
        s = step_strengths(volume, cache, int(n), buf)
        parts.append(
            sample_stats(s, cache.nodata, 0, volume.n_points, input_scale(volume, cache, int(n)))
        )
        if keep is not None:
            keep[int(n)] = (s, cache.nodata)
        cache.keep(int(n), int(n))
    return StrengthStats.merge(parts)


def peak_strengths(
    volume: TimeVolume,
    mapping: AcousticMapping,
    *,
    max_steps: int = AUTO_SAMPLE_STEPS,
    progress_bar: bool = False,
) -> NDArray[np.float64]:
    """Largest |S| of each type over evenly spaced sample steps (3,) (literal strengths).

    Parameters
    ----------
    volume : TimeVolume
        The volume (at least 2 steps).
    mapping : AcousticMapping
        Its (prepared) mapping.
    max_steps : int
        Most steps sampled (:func:`sample_steps`).
    progress_bar : bool
        Show a progress bar on stderr.

    Returns
    -------
    ndarray, shape (3,)
        kg/(m³·s), kg/(m⁴·s), kg/(m³·s²); steady part kept, no floor.

    Examples
    --------
    >>> rho = 1.0 + 0.1 * np.arange(3.0).reshape(3, 1, 1, 1) * np.ones((3, 4, 4, 4))
    >>> vol = TimeVolume.from_arrays({"density": rho}, times=[0.0, 0.5, 1.0])
    >>> peak_strengths(vol, get_mapping("identity")).round(12).tolist()
    [0.2, 0.0, 0.0]
    """
    return strength_stats(volume, mapping, max_steps=max_steps, progress_bar=progress_bar).peak


def iter_detect(
    volume: TimeVolume,
    mapping: AcousticMapping,
    thr: NDArray[np.float64],
    *,
    zero_fraction: float = 1.0,
    steps: range | None = None,
    progress_bar: bool = False,
    qmean: SteadyBase | NDArray[np.float64] | None = None,
    delta_v: str = "cell",
    floor: float = 0.0,
    store: MappedSeries | None = None,
    known: dict[int, tuple[np.ndarray, np.ndarray | None]] | None = None,
) -> Iterator[tuple[int, SourceFrame]]:
    """Yield ``(step, SourceFrame)`` for each step, reading frames one at a time.

    Each frame's ``n_valid`` is the number of points with data at that step;
    ``floor`` as :class:`StepCache`.  ``store`` (:class:`MappedSeries`): the
    mapped frames come from it; ``known``: strengths already computed with the
    same ``qmean`` and ``floor`` (:func:`strength_stats`'s ``keep``), used
    (and dropped) instead of computing them again.  With several threads, a
    uniform grid and a store that holds every step, several steps are
    detected at a time, each on one thread (yielded in order).

    Parameters
    ----------
    volume : TimeVolume
        The volume (at least 2 steps).
    mapping : AcousticMapping
        Its (prepared) mapping.
    thr : ndarray, shape (3,)
        Absolute thresholds.
    zero_fraction : float
        "Almost zero", as a fraction of each type's threshold (:func:`classify`).
    steps : range, optional
        The steps (default all).
    progress_bar : bool
        Show a progress bar on stderr.
    qmean : SteadyBase or ndarray, optional
        Steady state removed from the quadrupole strength.
    delta_v : {"cell", "sphere"}
        ΔV rule.
    floor : float
        Discretisation-error floor (0: off).
    store : MappedSeries, optional
        Where the mapped frames come from.
    known : dict, optional
        ``{step: (strengths, nodata)}`` already computed.

    Yields
    ------
    step : int
    frame : SourceFrame

    Examples
    --------
    >>> rho = 1.0 + 0.1 * np.arange(3.0).reshape(3, 1, 1, 1) * np.ones((3, 4, 4, 4))
    >>> vol = TimeVolume.from_arrays({"density": rho}, times=[0.0, 0.5, 1.0])
    >>> thr = np.array([0.1, 1.0, 1.0])
    >>> [(n, f.index.size, f.n_valid) for n, f in iter_detect(vol, get_mapping("identity"), thr)]
    [(0, 64, 64), (1, 64, 64), (2, 64, 64)]
    """
    steps = steps if steps is not None else range(volume.n_steps)
    known = {} if known is None else known
    threads = K.thread_count()
    # a step at a time on each thread when every frame is mapped once and for all (a
    # uniform grid: its kernels run on the calling thread), else the threads share each step
    if (
        threads > 1
        and len(steps) > 1
        and volume.metric is None
        and store is not None
        and store.max_steps >= volume.n_steps
    ):
        yield from _detect_side_by_side(
            volume,
            mapping,
            thr,
            steps,
            threads,
            progress_bar=progress_bar,
            zero_fraction=zero_fraction,
            qmean=qmean,
            delta_v=delta_v,
            floor=floor,
            store=store,
            known=known,
        )
        return
    work = _StepWork(volume, mapping, qmean, floor, store)
    for n in progress(steps, desc="detect", enabled=progress_bar, unit="step"):
        yield n, work.detect(n, thr, known, zero_fraction, delta_v)
        work.cache.keep(n, n + 1)


class _StepWork:
    """What detecting one step at a time needs: a :class:`StepCache` and scratch arrays."""

    def __init__(
        self,
        volume: TimeVolume,
        mapping: AcousticMapping,
        qmean: SteadyBase | NDArray[np.float64] | None,
        floor: float,
        store: MappedSeries | None,
    ) -> None:
        self.volume = volume
        self.cache = StepCache(volume, mapping, qmean=qmean, floor=floor, store=store)
        self.buf = K.empty_like_strengths(volume.shape)
        self.kinds = np.empty(volume.shape, dtype=np.int8)  # scratch of classify_sources
        self.cell = None if volume.metric is None else volume.metric.jac

    def detect(
        self,
        n: int,
        thr: NDArray[np.float64],
        known: dict[int, tuple[np.ndarray, np.ndarray | None]],
        zero_fraction: float,
        delta_v: str,
    ) -> SourceFrame:
        """The sources of step ``n`` (its strengths from ``known`` when there)."""
        volume = self.volume
        hit = known.pop(n, None)
        if hit is None:
            s = step_strengths(volume, self.cache, n, self.buf)
            nodata = self.cache.nodata
        else:
            s, nodata = hit
        f = classify_sources(
            s,
            thr,
            volume.spacing,
            zero_fraction=zero_fraction,
            delta_v=delta_v,
            cell=self.cell,
            kinds=self.kinds,
        )
        f.n_valid = volume.n_points - (0 if nodata is None else int(nodata.sum()))
        return f


def _detect_side_by_side(
    volume: TimeVolume,
    mapping: AcousticMapping,
    thr: NDArray[np.float64],
    steps: range,
    threads: int,
    *,
    progress_bar: bool,
    zero_fraction: float,
    qmean: SteadyBase | NDArray[np.float64] | None,
    delta_v: str,
    floor: float,
    store: MappedSeries,
    known: dict[int, tuple[np.ndarray, np.ndarray | None]],
) -> Iterator[tuple[int, SourceFrame]]:
    """:func:`iter_detect` with ``threads`` steps detected at a time, each whole on one thread
    (its kernels on that thread alone: no block of planes waits for another, and no
    plane is computed twice at the blocks' edges), yielded in order.

    The steps go in batches of :data:`SIDE_BY_SIDE` per thread, each thread taking the
    next step of the batch when it is free; each thread keeps its own
    :class:`StepCache` and scratch, whose frames come from ``store``, which holds
    them all.
    """
    import numba

    works: dict[int, _StepWork] = {}
    todo = iter(progress(steps, desc="detect", enabled=progress_bar, unit="step"))
    while batch := list(itertools.islice(todo, SIDE_BY_SIDE * threads)):
        out: list[SourceFrame | None] = [None] * len(batch)

        def one(i: int, batch: list[int] = batch, out: list[SourceFrame | None] = out) -> None:
            work = works.get(threading.get_ident())
            if work is None:
                work = works[threading.get_ident()] = _StepWork(
                    volume, mapping, qmean, floor, store
                )
            own = numba.get_num_threads()
            numba.set_num_threads(1)  # this thread's kernels on this thread alone
            try:
                out[i] = work.detect(batch[i], thr, known, zero_fraction, delta_v)
            finally:
                numba.set_num_threads(own)

        K.in_threads(one, len(batch), threads)
        for work in works.values():  # the next batch's frames (and their neighbours)
            work.cache.keep(batch[-1] + steps.step, batch[-1] + len(batch) * steps.step)
        for n, f in zip(batch, out, strict=True):
            assert f is not None
            yield n, f


#: steps per thread in a batch of :func:`_detect_side_by_side`
SIDE_BY_SIDE = 4


def classified_fraction(frames: Sequence[SourceFrame], n_points: int) -> dict[str, float]:
    """Share of the valid point-steps classified as each type (and ``"any"``).

    Parameters
    ----------
    frames : sequence of SourceFrame
        The sources of each step.
    n_points : int
        Points of the grid (the valid points of a frame whose ``n_valid`` is None).

    Returns
    -------
    dict of str to float
        ``{"monopole", "dipole", "quadrupole", "any"}``, each in [0, 1].

    Examples
    --------
    >>> f = SourceFrame(index=np.arange(3), kind=np.array([1, 1, 2], dtype=np.int8),
    ...                 strength=np.ones(3), radius=np.ones(3), n_valid=10)
    >>> classified_fraction([f, f], 64)
    {'monopole': 0.2, 'dipole': 0.1, 'quadrupole': 0.0, 'any': 0.30000000000000004}
    """
    valid = sum(n_points if f.n_valid is None else f.n_valid for f in frames)
    tot = dict.fromkeys(TYPES, 0)
    for f in frames:
        for k, v in f.counts().items():
            tot[k] += v
    out = {k: (v / valid if valid else 0.0) for k, v in tot.items()}
    out["any"] = sum(out[k] for k in TYPES)
    return out


def warn_fraction(fraction: dict[str, float], source: str, *, uniform: bool = False) -> None:
    """Warn (once per call site) when more than :data:`WARN_FRACTION` of the points are sources.

    Parameters
    ----------
    fraction : dict of str to float
        :func:`classified_fraction`.
    source : str
        The volume's name, for the message.
    uniform : bool
        Every sampled point of a classified type has the same |S| (a uniform
        volume source, which no threshold splits): the advice says so.

    Warns
    -----
    SourceFractionWarning
        ``fraction["any"]`` above :data:`WARN_FRACTION`.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warn_fraction({"monopole": 0.5, "dipole": 0.0, "quadrupole": 0.0, "any": 0.5}, "x")
    >>> caught[0].category.__name__, str(caught[0].message)[:42]
    ('SourceFractionWarning', 'x: 50% of the valid points are sources (50')
    """
    if fraction["any"] > WARN_FRACTION:
        parts = ", ".join(f"{fraction[k]:.0%} {k}" for k in TYPES)
        advice = (
            "every point has the same strength: a uniform volume source, which no threshold splits"
            if uniform
            else "the thresholds find everything, not sources: raise them (e.g. 'top:1%' or "
            "an absolute value)"
        )
        warnings.warn(
            f"{source}: {fraction['any']:.0%} of the valid points are sources ({parts}); {advice}",
            SourceFractionWarning,
            stacklevel=3,
        )


def detect(
    volume: TimeVolume,
    *,
    mapping: str | AcousticMapping | None = "identity",
    thresholds: Thresholds | None = None,
    progress_bar: bool = False,
    steady: str = "remove",
    delta_v: str = "cell",
    **mapping_fields: str,
) -> SourceSeries:
    """Detect monopole, dipole and quadrupole sources at every step (paper 003 §3.2.3).

    The mapped fields (§3.2.2) give the strengths of Eqs. 13–14 at every
    point, the :class:`Thresholds` classify them exclusively, and each
    source point gets its ΔV (§3.2.4.1).

    Parameters
    ----------
    volume : TimeVolume
        At least two time steps.  Points where ``volume.valid`` (if the
        volume has one) is False, or where a mapped value is NaN/Inf, are
        no-data: they are never sources and no stencil reads them (a
        derivative that would is no-data too, see :func:`step_strengths`).
    mapping : str or AcousticMapping
        Acoustic mapping preset or instance (see :mod:`auralize.sources.mapping`).
    thresholds : Thresholds, optional
        Default: ``"auto"`` for all three types.
    progress_bar : bool
        Show a progress bar on stderr.
    steady : {"remove", "keep"}
        ``"remove"`` (default): a steady flow makes no sound, so the
        quadrupole strength is taken from the stress ρ v_i v_j minus the
        field's local steady state (:class:`SteadyBase`: the stress at the
        anchor steps of :func:`steady_anchors`, linearly interpolated
        between them; Lighthill's far field depends on ∂²T_ij/∂t² only).  The
        monopole and dipole strengths are time derivatives already and vanish
        for a steady field.  ``"keep"``: the literal strengths of paper 003
        Eq. 14, steady part included.
    delta_v : {"cell", "sphere"}
        ΔV rule (see :func:`classify`); ``"cell"`` converges under refinement.
    **mapping_fields
        Field-name overrides for a mapping preset (:func:`get_mapping`), e.g.
        ``density="rho"``.

    Each step is read and mapped once: the mapping's series statistics keep
    what they read for the first mapping of each step, and the mapped frames
    are kept (:class:`MappedSeries`, up to :data:`SERIES_BYTES` and a quarter
    of the memory available) for the steady anchors, the threshold statistics
    (the :data:`AUTO_SAMPLE_STEPS` sample steps, whose strengths detection
    then reuses when the store holds every step) and detection.  The results
    are those of separate passes, bit for bit; beyond the budget steps are
    read again.

    Returns
    -------
    SourceSeries
        ``meta["fraction"]`` is the share of the valid point-steps classified
        as each type; a :class:`SourceFractionWarning` says when more than a
        quarter of them are sources.

    Raises
    ------
    DataError
        Fewer than 2 time steps, or mapped fields of a bad shape.
    FieldError
        A field the mapping needs is not in the volume.
    ParameterError
        An unknown mapping, ``steady`` or ``delta_v``, or a field override
        the mapping does not take.

    Examples
    --------
    >>> from auralize.datasets.synthetic import make_monopole
    >>> vol = make_monopole(size=16, steps=8)
    >>> series = detect(vol, mapping="identity")
    >>> series.counts()[4]["dipole"]
    0
    """
    require_steps(volume)
    m = get_mapping(mapping, **mapping_fields)
    delta_v_rule(delta_v)
    check_steady(steady)
    thresholds = thresholds or Thresholds()
    store = MappedSeries(volume, m)
    # the mapping's series statistics read each frame once; what they read is
    # kept for the first map() of each step (paper-density), as much as the store holds
    m.prepare_series(volume, hold_bytes=min(store.max_steps, volume.n_steps) * step_bytes(volume))
    try:
        # pass 1 (each step read and mapped once, kept in the store): the steady anchors
        qmean = steady_strength(volume, m, steady, store=store)
        known: dict[int, tuple[np.ndarray, np.ndarray | None]] = {}
        stats = (
            strength_stats(
                volume,
                m,
                qmean=qmean,
                progress_bar=progress_bar,
                floor=thresholds.floor,
                store=store,
                keep=known if store.max_steps >= volume.n_steps else None,
            )
            if thresholds.needs_scale
            else None
        )
        thr = thresholds.resolve(stats)
        frames = [
            f
            for _, f in iter_detect(
                volume,
                m,
                thr,
                zero_fraction=thresholds.zero_fraction,
                progress_bar=progress_bar,
                qmean=qmean,
                delta_v=delta_v,
                floor=thresholds.floor,
                store=store,
                known=known,
            )
        ]
    finally:
        m.release()
    fraction = classified_fraction(frames, volume.n_points)
    uniform = stats is not None and all(
        x[0] == x[-1] for i, x in enumerate(stats.sample) if x.size and fraction[TYPES[i]] > 0
    )
    warn_fraction(fraction, volume.source, uniform=uniform)
    return SourceSeries(
        frames=frames,
        times=volume.times.copy(),
        origin=volume.origin.copy(),
        spacing=volume.spacing.copy(),
        dims=volume.dims,
        thresholds=thr,
        meta={
            "mapping": m.describe(),
            "thresholds": thresholds.describe(),
            "peak": None if stats is None else stats.peak.tolist(),
            "source": volume.source,
            "steady": steady,
            "delta_v": delta_v,
            "fraction": fraction,
            "valid_points": _valid_share(frames, volume.n_points),
            **({"grid": "curvilinear"} if volume.coords is not None else {}),
        },
        coords=volume.coords,
    )


def _valid_share(frames: Sequence[SourceFrame], n_points: int) -> float:
    """Mean share of the grid's points with data over the steps."""
    if not frames:
        return 1.0
    return float(np.mean([1.0 if f.n_valid is None else f.n_valid / n_points for f in frames]))
