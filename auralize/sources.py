"""Source strengths, exclusive classification and ΔV spheres (paper 003 §3.2.3–3.2.4.1).

For every vertex and time step three strengths are computed from the mapped
density ρ̃ and particle velocity v:

* monopole ``S_m = ∂ρ̃/∂t``,
* dipole ``S_d = ∂/∂x_i (∂(ρ̃ v_i)/∂t)`` (Eq. 13),
* quadrupole ``S_q = Σ_ij ∂²(ρ̃ v_i v_j)/∂x_i∂x_j`` (Eq. 14, all nine terms).

Time derivatives are central differences between the neighbouring steps
(one-sided at the first and last step); space derivatives are second-order
finite differences (see :mod:`auralize._kernels`).

Classification is exclusive, on magnitudes (strengths stay signed): a vertex is
a monopole if ``|S_m| > T_m``; a dipole if ``|S_d| > T_d`` and ``|S_m|`` is
"almost zero"; a quadrupole if ``|S_q| > T_q`` and both others are almost zero.
"Almost zero" means at most ``zero_fraction`` times that type's threshold
(default 1: below detection).

Each source point gets a ΔV sphere whose radius is the mean cut distance along
its grid edges (§3.2.4.1): half the edge towards a neighbour of the same type,
else the linear-interpolated crossing of ``|S|`` with the threshold.
ΔV = 4/3 π r³.  An interior voxel of a source block has r = h/2.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize import _kernels as K
from auralize.errors import DataError, ParameterError
from auralize.mapping import AcousticMapping, get_mapping
from auralize.progress import progress
from auralize.volume import TimeVolume

KIND_NAMES = {K.MONOPOLE: "monopole", K.DIPOLE: "dipole", K.QUADRUPOLE: "quadrupole"}
TYPES = ("monopole", "dipole", "quadrupole")

#: default relative thresholds ("auto"): these fractions of each type's peak |S|.
#: Strength distributions are heavy-tailed and the dipole and quadrupole terms
#: (one and two more space derivatives) reach higher peaks relative to their
#: bulk, so their fractions are lower; with these all three types show up in
#: the built-in explosion.
AUTO_FRACTIONS = {"monopole": 0.03, "dipole": 0.003, "quadrupole": 0.001}
#: how many evenly spaced steps are sampled to find the peak |S| for relative thresholds
AUTO_SAMPLE_STEPS = 8


ThresholdSpec = float | str


def _parse_threshold(spec: ThresholdSpec, kind: str) -> tuple[str, float]:
    """Return ("abs", value) or ("rel", fraction)."""
    if isinstance(spec, int | float) and not isinstance(spec, bool):
        v = float(spec)
        if not math.isfinite(v) or v < 0:
            raise ParameterError(f"{kind} threshold must be a finite number >= 0, got {spec!r}")
        return "abs", v
    s = str(spec).strip().lower()
    if s == "auto":
        return "rel", AUTO_FRACTIONS[kind]
    m = re.fullmatch(r"(?:rel:)?([0-9.eE+-]+)\s*%", s) or re.fullmatch(r"rel:([0-9.eE+-]+)", s)
    if m:
        frac = float(m.group(1)) / (100.0 if s.endswith("%") else 1.0)
        if not 0 <= frac <= 1:
            raise ParameterError(f"{kind} relative threshold must be in 0..100 %, got {spec!r}")
        return "rel", frac
    try:
        return _parse_threshold(float(s), kind)
    except ValueError:
        raise ParameterError(
            f"{kind} threshold {spec!r} is not understood; give an absolute value (e.g. 250), "
            f"a percentage of the peak strength (e.g. '5%' or 'rel:0.05') or 'auto'"
        ) from None


@dataclass
class Thresholds:
    """Detection thresholds per source type.

    Each of ``monopole``, ``dipole``, ``quadrupole`` is an absolute value (in
    that strength's units: kg/(m³·s) for monopoles, kg/(m⁴·s) for dipoles,
    kg/(m³·s²)·... for quadrupoles), a relative one (``"5%"``, ``"rel:0.05"``:
    a fraction of the series' peak magnitude, estimated from up to
    :data:`AUTO_SAMPLE_STEPS` evenly spaced steps), or ``"auto"``
    (= :data:`AUTO_FRACTIONS` relative: 3 %, 0.3 %, 0.1 %).

    Examples
    --------
    >>> Thresholds(monopole=10.0, dipole="2%").resolve(np.array([1.0, 50.0, 1.0]))
    array([10.,  1., 0.05])
    """

    monopole: ThresholdSpec = "auto"
    dipole: ThresholdSpec = "auto"
    quadrupole: ThresholdSpec = "auto"
    zero_fraction: float = 1.0

    def __post_init__(self) -> None:
        self._parsed = [_parse_threshold(getattr(self, k), k) for k in TYPES]
        if not (math.isfinite(self.zero_fraction) and self.zero_fraction >= 0):
            raise ParameterError(f"zero_fraction must be >= 0, got {self.zero_fraction!r}")

    @property
    def needs_scale(self) -> bool:
        return any(mode == "rel" for mode, _ in self._parsed)

    def resolve(self, peak: NDArray[np.float64] | None) -> NDArray[np.float64]:
        """Absolute thresholds (3,) given the peak magnitudes (3,) of the series."""
        out = np.empty(3)
        for i, (mode, v) in enumerate(self._parsed):
            if mode == "abs":
                out[i] = v
            else:
                if peak is None:
                    raise ParameterError("relative thresholds need the series' peak strengths")
                # a type that never occurs (peak 0) gets an infinite threshold
                out[i] = v * float(peak[i]) if peak[i] > 0 else np.inf
        return out

    def describe(self) -> dict[str, object]:
        return {k: getattr(self, k) for k in (*TYPES, "zero_fraction")}


@dataclass
class SourceFrame:
    """The sources of one time step.

    Attributes
    ----------
    index : (N,) int64 flat C-order vertex indices into the ``(nz, ny, nx)`` grid.
    kind : (N,) int8, 1 monopole, 2 dipole, 3 quadrupole.
    strength : (N,) float64 signed strength S of the vertex's type.
    radius : (N,) float64 ΔV-sphere radius in metres.
    """

    index: NDArray[np.int64]
    kind: NDArray[np.int8]
    strength: NDArray[np.float64]
    radius: NDArray[np.float64]

    @property
    def volume(self) -> NDArray[np.float64]:
        """ΔV = 4/3 π r³ in m³."""
        return (4.0 / 3.0) * np.pi * self.radius**3

    def counts(self) -> dict[str, int]:
        c = np.bincount(self.kind, minlength=4)
        return {name: int(c[k]) for k, name in KIND_NAMES.items()}


@dataclass
class SourceSeries:
    """Sources at every step of a volume, plus what is needed to reproduce them."""

    frames: list[SourceFrame]
    times: NDArray[np.float64]
    origin: NDArray[np.float64]
    spacing: NDArray[np.float64]
    dims: tuple[int, int, int]
    thresholds: NDArray[np.float64]
    meta: dict[str, object] = field(default_factory=dict)

    @property
    def n_steps(self) -> int:
        return len(self.frames)

    @property
    def shape(self) -> tuple[int, int, int]:
        nx, ny, nz = self.dims
        return (nz, ny, nx)

    def positions(self, index: NDArray[np.integer]) -> NDArray[np.float64]:
        k, j, i = np.unravel_index(np.asarray(index), self.shape)
        return self.origin + np.stack([i, j, k], axis=-1) * self.spacing

    def counts(self) -> list[dict[str, int]]:
        """Per-step counts by type."""
        return [f.counts() for f in self.frames]

    def tracks(self) -> SourceTracks:
        """Per-vertex strength·ΔV over time for every vertex that is ever a source."""
        if not self.frames or all(f.index.size == 0 for f in self.frames):
            return SourceTracks(
                positions=np.zeros((0, 3)), q=np.zeros((0, self.n_steps)),
                radius=np.zeros(0), times=self.times.copy(),
            )  # fmt: skip
        all_idx = np.concatenate([f.index for f in self.frames])
        uniq = np.unique(all_idx)
        q = np.zeros((uniq.size, self.n_steps))
        rmax = np.zeros(uniq.size)
        for n, f in enumerate(self.frames):
            pos = np.searchsorted(uniq, f.index)
            q[pos, n] = f.strength * f.volume
            np.maximum.at(rmax, pos, f.radius)
        return SourceTracks(positions=self.positions(uniq), q=q, radius=rmax,
                            times=self.times.copy(), index=uniq)  # fmt: skip


@dataclass
class SourceTracks:
    """Input of the synthesis: per-source q_k(t_n) = S·ΔV at each step.

    ``positions (K, 3)``, ``q (K, T)``, ``radius (K,)`` (largest ΔV radius,
    used to clamp distances), ``times (T,)``.
    """

    positions: NDArray[np.float64]
    q: NDArray[np.float64]
    radius: NDArray[np.float64]
    times: NDArray[np.float64]
    index: NDArray[np.int64] | None = None
    cache: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def n_sources(self) -> int:
        return int(self.q.shape[0])


class _StepCache:
    """Mapped (ρ, v, ρv) frames, kept for the three steps the stencil needs."""

    def __init__(self, volume: TimeVolume, mapping: AcousticMapping) -> None:
        self.volume, self.mapping = volume, mapping
        self._cache: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self.work: np.ndarray | None = None  # kernel scratch, reused between steps

    def get(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if n not in self._cache:
            rho, v = self.mapping.map(self.volume, n)
            rho = np.ascontiguousarray(rho, dtype=np.float64)
            v = np.ascontiguousarray(v, dtype=np.float64)
            self._cache[n] = (rho, v, rho[..., None] * v)
        return self._cache[n]

    def keep(self, lo: int, hi: int) -> None:
        for k in [k for k in self._cache if k < lo or k > hi]:
            del self._cache[k]


def step_strengths(volume: TimeVolume, cache: _StepCache, n: int,
                   out: NDArray[np.float64] | None = None) -> NDArray[np.float64]:  # fmt: skip
    """Strengths ``(3, nz, ny, nx)`` (monopole, dipole, quadrupole) at step ``n``."""
    T = volume.n_steps
    a, b = max(n - 1, 0), min(n + 1, T - 1)
    rho_a, _, m_a = cache.get(a)
    rho_b, _, m_b = cache.get(b)
    rho_c, v_c, _ = cache.get(n)
    if out is None:
        out = K.empty_like_strengths(volume.shape)
    inv_dt = 1.0 / (volume.times[b] - volume.times[a])
    cache.work = K.strengths(rho_a, rho_b, m_a, m_b, inv_dt, rho_c, v_c, volume.spacing, out,
                             cache.work)  # fmt: skip
    return out


def compute_strengths(volume: TimeVolume, mapping: str | AcousticMapping | None = None,
                      step: int = 0) -> NDArray[np.float64]:  # fmt: skip
    """Strengths ``(3, nz, ny, nx)`` at one step (convenience for inspection)."""
    _require_steps(volume)
    m = get_mapping(mapping)
    m.prepare(volume)
    return step_strengths(volume, _StepCache(volume, m), step)


def classify(strengths: NDArray[np.float64], thresholds: NDArray[np.float64], spacing: NDArray[np.float64],
             *, zero_fraction: float = 1.0) -> tuple[NDArray[np.int8], NDArray[np.float64]]:  # fmt: skip
    """Classify vertices and compute ΔV radii from strengths ``(3, nz, ny, nx)``.

    Returns ``kind (nz, ny, nx)`` int8 (0 none, 1 monopole, 2 dipole,
    3 quadrupole) and ``radius (nz, ny, nx)`` in metres (0 where no source).
    """
    s = np.ascontiguousarray(strengths, dtype=np.float64)
    thr = np.asarray(thresholds, dtype=np.float64)
    zero = thr * zero_fraction
    kind = np.empty(s.shape[1:], dtype=np.int8)
    radius = np.empty(s.shape[1:], dtype=np.float64)
    K.classify_and_radius(s, thr, zero, np.asarray(spacing, dtype=np.float64), kind, radius)
    return kind, radius


def extract(kind: NDArray[np.int8], radius: NDArray[np.float64],
            strengths: NDArray[np.float64]) -> SourceFrame:  # fmt: skip
    """Gather the source points of one step into a :class:`SourceFrame`."""
    flat_kind = kind.reshape(-1)
    idx = np.flatnonzero(flat_kind)
    k = flat_kind[idx]
    s = strengths.reshape(3, -1)[k.astype(np.intp) - 1, idx]
    return SourceFrame(index=idx.astype(np.int64), kind=k, strength=s,
                       radius=radius.reshape(-1)[idx])  # fmt: skip


def _require_steps(volume: TimeVolume) -> None:
    if volume.n_steps < 2:
        raise DataError(
            f"{volume.source}: source detection needs at least 2 time steps (strengths are "
            f"time derivatives); this volume has {volume.n_steps}"
        )


def peak_strengths(volume: TimeVolume, mapping: AcousticMapping, *,
                   max_steps: int = AUTO_SAMPLE_STEPS,
                   progress_bar: bool = False) -> NDArray[np.float64]:  # fmt: skip
    """Largest |S| of each type over evenly spaced sample steps (3,)."""
    steps = np.unique(np.linspace(0, volume.n_steps - 1, min(max_steps, volume.n_steps)).round())
    cache = _StepCache(volume, mapping)
    peak = np.zeros(3)
    buf = K.empty_like_strengths(volume.shape)
    for n in progress(steps.astype(int), desc="peak pass", enabled=progress_bar, unit="step"):
        s = step_strengths(volume, cache, int(n), buf)
        peak = np.maximum(peak, np.abs(s).reshape(3, -1).max(axis=1))
        cache.keep(n, n)
    return peak


def iter_detect(volume: TimeVolume, mapping: AcousticMapping, thr: NDArray[np.float64], *,
                zero_fraction: float = 1.0, steps: range | None = None,
                progress_bar: bool = False) -> Iterator[tuple[int, SourceFrame]]:  # fmt: skip
    """Yield ``(step, SourceFrame)`` for each step, reading frames one at a time."""
    cache = _StepCache(volume, mapping)
    buf = K.empty_like_strengths(volume.shape)
    steps = steps if steps is not None else range(volume.n_steps)
    for n in progress(steps, desc="detect", enabled=progress_bar, unit="step"):
        s = step_strengths(volume, cache, n, buf)
        kind, radius = classify(s, thr, volume.spacing, zero_fraction=zero_fraction)
        yield n, extract(kind, radius, s)
        cache.keep(n, n + 1)


def detect(volume: TimeVolume, *, mapping: str | AcousticMapping | None = "identity",
           thresholds: Thresholds | None = None, progress_bar: bool = False,
           **mapping_fields: str) -> SourceSeries:  # fmt: skip
    """Detect monopole, dipole and quadrupole sources at every step.

    Parameters
    ----------
    volume : TimeVolume
        At least two time steps.
    mapping : str or AcousticMapping
        Acoustic mapping preset or instance (see :mod:`auralize.mapping`).
    thresholds : Thresholds, optional
        Default: ``"auto"`` for all three types.
    progress_bar : bool
        Show a progress bar on stderr.

    Returns
    -------
    SourceSeries

    Examples
    --------
    >>> from auralize.datasets import make_monopole
    >>> vol = make_monopole(size=16, steps=8)
    >>> series = detect(vol, mapping="identity")
    >>> series.counts()[4]["dipole"]
    0
    """
    _require_steps(volume)
    m = get_mapping(mapping, **mapping_fields)
    m.prepare(volume)
    thresholds = thresholds or Thresholds()
    peak = peak_strengths(volume, m, progress_bar=progress_bar) if thresholds.needs_scale else None
    thr = thresholds.resolve(peak)
    frames = [f for _, f in iter_detect(volume, m, thr, zero_fraction=thresholds.zero_fraction,
                                        progress_bar=progress_bar)]  # fmt: skip
    return SourceSeries(
        frames=frames, times=volume.times.copy(), origin=volume.origin.copy(),
        spacing=volume.spacing.copy(), dims=volume.dims, thresholds=thr,
        meta={"mapping": m.describe(), "thresholds": thresholds.describe(),
              "peak": None if peak is None else peak.tolist(), "source": volume.source},
    )  # fmt: skip
