"""Detection reads and maps each step once (issue "Kernels a newcomer can read", item 4).

:func:`auralize.sources.detection.detect` keeps the mapped frames of the series
(:class:`~auralize.sources.detection.MappedSeries`) so that the steady anchors,
the threshold statistics and detection share one read and one mapping of each
step; the results must be those of the straightforward passes, each mapping
the steps it needs itself.
"""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np
import pytest

from auralize.datasets.synthetic import make_explosion, make_spinning
from auralize.pipeline import detect_sources
from auralize.sources import _kernels as K
from auralize.sources.detection import (
    MappedSeries,
    SourceSeries,
    Thresholds,
    detect,
    gradient,
    gradient_absmax,
    iter_detect,
    steady_strength,
    strength_stats,
)
from auralize.sources.mapping import get_mapping
from auralize.volume import TimeVolume


class CountingFrames:
    """A FrameSource that counts the reads of each step."""

    def __init__(self, src: Any, name: str, reads: Counter[tuple[str, int]]) -> None:
        self.src, self.name, self.reads = src, name, reads

    @property
    def n_steps(self) -> int:
        return int(self.src.n_steps)

    @property
    def frame_shape(self) -> tuple[int, ...]:
        return tuple(self.src.frame_shape)

    def read(self, step: int) -> np.ndarray:
        self.reads[(self.name, step)] += 1
        return self.src.read(step)


def counted(vol: TimeVolume) -> Counter[tuple[str, int]]:
    reads: Counter[tuple[str, int]] = Counter()
    for name in list(vol.fields):
        vol.fields[name] = CountingFrames(vol.fields[name], name, reads)  # type: ignore[assignment]
    return reads


def reference(vol: TimeVolume, mapping: str, thresholds: Thresholds) -> tuple[Any, list[Any]]:
    """The straightforward passes: steady anchors, threshold statistics and detection,
    each mapping every step it needs itself (no store, nothing kept)."""
    m = get_mapping(mapping)
    m.prepare(vol)
    qmean = steady_strength(vol, m)
    stats = (
        strength_stats(vol, m, qmean=qmean, floor=thresholds.floor)
        if thresholds.needs_scale
        else None
    )
    thr = thresholds.resolve(stats)
    frames = [
        f
        for _, f in iter_detect(
            vol, m, thr, zero_fraction=thresholds.zero_fraction, qmean=qmean, floor=thresholds.floor
        )
    ]
    return thr, frames


def assert_same(series: SourceSeries, thr: np.ndarray, frames: list[Any]) -> None:
    np.testing.assert_array_equal(series.thresholds, thr)
    assert len(series.frames) == len(frames)
    for a, b in zip(series.frames, frames, strict=True):
        np.testing.assert_array_equal(a.index, b.index)
        np.testing.assert_array_equal(a.kind, b.kind)
        np.testing.assert_array_equal(a.strength, b.strength)
        np.testing.assert_array_equal(a.radius, b.radius)
        assert a.n_valid == b.n_valid


def masked_spinning() -> TimeVolume:
    vol = make_spinning(size=14, steps=12).load()
    valid = np.ones(vol.shape, dtype=bool)
    valid[:3, :4, :] = False
    vol.valid = valid
    return vol


CASES = [
    ("explosion", lambda: make_explosion(size=14, steps=9).load(), "paper-density", Thresholds()),
    (
        "explosion-mixed",
        lambda: make_explosion(size=14, steps=9).load(),
        "paper-density",
        Thresholds("top:2%", "1%", "auto"),
    ),
    ("spinning", lambda: make_spinning(size=14, steps=12).load(), "identity", Thresholds()),
    (
        "spinning-abs",
        lambda: make_spinning(size=14, steps=12).load(),
        "identity",
        Thresholds(1e-3, 1e-3, 1e-3, floor=0.0),
    ),
    ("masked", masked_spinning, "identity", Thresholds()),
]


@pytest.mark.filterwarnings("ignore::auralize.sources.detection.SourceFractionWarning")
@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_one_pass_detection_equals_the_separate_passes(case: Any) -> None:
    _, make, mapping, thresholds = case
    series = detect(make(), mapping=mapping, thresholds=thresholds)
    thr, frames = reference(make(), mapping, thresholds)
    assert_same(series, thr, frames)


@pytest.mark.filterwarnings("ignore::auralize.sources.detection.SourceFractionWarning")
def test_a_store_that_holds_nothing_gives_the_same_sources(monkeypatch: pytest.MonkeyPatch) -> None:
    """Beyond the memory budget the steps are mapped again when needed: same results."""
    import auralize.sources.detection as D

    full = detect(make_explosion(size=14, steps=9).load(), mapping="paper-density")
    monkeypatch.setattr(D, "SERIES_BYTES", 0)
    vol = make_explosion(size=14, steps=9).load()
    reads = counted(vol)
    none = detect(vol, mapping="paper-density")
    assert_same(none, full.thresholds, full.frames)
    assert max(reads.values()) > 1  # nothing kept: steps are read again


@pytest.mark.filterwarnings("ignore::auralize.sources.detection.SourceFractionWarning")
@pytest.mark.parametrize(
    "make",
    [lambda: make_explosion(size=14, steps=9), lambda: make_spinning(size=14, steps=12)],
    ids=["explosion-paper-density", "spinning-identity"],
)
def test_detect_sources_reads_each_frame_once(make: Any) -> None:
    """auto thresholds (statistics, steady anchors, detection): one read per field and step."""
    vol = make().load()
    reads = counted(vol)
    detect_sources(vol)
    assert reads, "nothing was read"
    assert set(reads.values()) == {1}
    steps = {n for _, n in reads}
    assert steps == set(range(vol.n_steps))


def counting_map(m: Any) -> Counter[int]:
    """Count the mapping's evaluations of each step (``m.map`` wrapped on the instance)."""
    calls: Counter[int] = Counter()
    plain = m.map

    def counted_map(volume: TimeVolume, n: int) -> Any:
        calls[int(n)] += 1
        return plain(volume, n)

    m.map = counted_map
    return calls


@pytest.mark.filterwarnings("ignore::auralize.sources.detection.SourceFractionWarning")
@pytest.mark.parametrize(
    ("make", "mapping", "kw", "thresholds"),
    [
        (make_explosion, "paper-density", {}, Thresholds()),
        (make_explosion, "paper-density", {"steady": "keep"}, Thresholds(floor=0.0)),
        (make_spinning, "identity", {}, Thresholds("top:2%", "1%", "auto")),
        (make_spinning, "identity", {}, Thresholds(1e-3, 1e-3, 1e-3)),
    ],
    ids=["paper-auto", "paper-keep-nofloor", "identity-mixed", "identity-fixed"],
)
def test_detect_maps_each_step_once(
    make: Any, mapping: str, kw: dict[str, str], thresholds: Thresholds
) -> None:
    """The whole of :func:`detect` (steady anchors, threshold statistics, detection, with
    and without the floor's 2Δt steps) evaluates the mapping once per step."""
    vol = make(size=14, steps=9).load()
    m = get_mapping(mapping)
    calls = counting_map(m)
    series = detect(vol, mapping=m, thresholds=thresholds, **kw)  # type: ignore[arg-type]
    assert sorted(calls) == list(range(vol.n_steps))
    assert set(calls.values()) == {1}
    assert sum(f.index.size for f in series.frames) > 0


def test_each_step_is_mapped_once() -> None:
    vol = make_spinning(size=12, steps=10).load()
    m = get_mapping("identity")
    m.prepare(vol)
    store = MappedSeries(vol, m)
    qmean = steady_strength(vol, m, store=store)
    strength_stats(vol, m, qmean=qmean, floor=3.0, store=store)
    list(iter_detect(vol, m, np.ones(3), qmean=qmean, floor=3.0, store=store))
    assert store.maps == vol.n_steps


def test_gradient_is_numpys() -> None:
    rng = np.random.default_rng(1)
    h = np.array([0.3, 0.7, 1.1])
    for shape in [(5, 6, 7), (1, 4, 5), (2, 1, 3), (3, 2, 1)]:
        f = rng.normal(size=shape)
        want = np.zeros((*shape, 3))
        for comp, axis in ((0, 2), (1, 1), (2, 0)):
            if shape[axis] >= 2:
                want[..., comp] = np.gradient(f, h[comp], axis=axis)
        np.testing.assert_array_equal(gradient(f, h), want)
        np.testing.assert_array_equal(gradient(f, h, 2.5), want * 2.5)
        f[0, 0, 0] = np.nan
        w = np.zeros((*shape, 3))
        for comp, axis in ((0, 2), (1, 1), (2, 0)):
            if shape[axis] >= 2:
                w[..., comp] = np.gradient(f, h[comp], axis=axis)
        assert gradient_absmax(f, h) == float(np.nanmax(np.abs(w), initial=0.0))


def test_floor_is_the_27_point_maximum() -> None:
    rng = np.random.default_rng(2)
    s = rng.normal(size=(3, 6, 5, 7))
    s[:, 2, 2, 2] = 0.0
    err = np.abs(rng.normal(size=s.shape)) * 0.5
    roundoff = np.array([0.05, 0.1, 0.0])
    want = s.copy()
    padded = np.pad(err, ((0, 0), (1, 1), (1, 1), (1, 1)), mode="edge")
    nz, ny, nx = s.shape[1:]
    for c in range(3):
        for k in range(nz):
            for j in range(ny):
                for i in range(nx):
                    a = abs(want[c, k, j, i])
                    e = padded[c, k : k + 3, j : j + 3, i : i + 3].max()
                    if a <= roundoff[c] or a <= 3.0 * e:
                        want[c, k, j, i] = 0.0
    got = s.copy()
    K.apply_floor(got, err, 3.0, roundoff)
    np.testing.assert_array_equal(got, want)


def test_steady_subtraction_is_the_numpy_expression() -> None:
    rng = np.random.default_rng(3)
    sq, sa, sb = (rng.normal(size=(4, 5, 6)) for _ in range(3))
    tt, ta, tb = (rng.normal(size=(6, 4, 5, 6)) for _ in range(3))
    f = 0.37
    want_q = sq - ((1.0 - f) * sa + f * sb)
    want_t = tt - ((1.0 - f) * ta + f * tb)
    q, t = sq.copy(), tt.copy()
    K.subtract_steady(q, sa, sb, t, ta, tb, f, True)
    np.testing.assert_array_equal(q, want_q)
    np.testing.assert_array_equal(t, want_t)


def test_paper_density_series_mapping_equals_prepare() -> None:
    vol = make_explosion(size=12, steps=5).load()
    a = get_mapping("paper-density")
    a.prepare(vol)
    want = [a.map(vol, n) for n in range(vol.n_steps)]
    b = get_mapping("paper-density")
    reads = counted(vol)
    b.prepare_series(vol, hold_bytes=1 << 30)
    assert set(reads.values()) == {1}
    for n in range(vol.n_steps):
        ra, va = want[n]
        rb, vb = b.map(vol, n)
        np.testing.assert_array_equal(ra, rb)
        np.testing.assert_array_equal(va, vb)
    assert set(reads.values()) == {1}  # the held frames were used, once each
    b.map(vol, 0)
    assert reads[("log10_density", 0)] == 2  # handed out once: then read again
    b.release()


def test_paper_density_in_slabs_is_the_numpy_mapping() -> None:
    """A frame large enough to be mapped in slabs on the detection's threads (10**x, its
    extremes, ρ̃ scaled in place, the gradients held in one block): numpy's numbers."""
    from auralize.sources.detection import SLAB_SPLIT

    vol = make_explosion(size=41, steps=4).load()
    assert vol.n_points >= SLAB_SPLIT
    x = [vol.frame("log10_density", n) for n in range(vol.n_steps)]
    x[2][3:6, 4:9, 5] = np.nan  # no-data points do not count in the extremes
    vol.fields["log10_density"].array[2] = x[2]  # type: ignore[attr-defined]
    vol.check_finite = False  # NaN is no-data (nan="mask")
    r = [np.power(10.0, f) for f in x]
    lo = min(float(np.nanmin(f)) for f in r)
    hi = max(float(np.nanmax(f)) for f in r)
    rho = [0.5 + (15.0 - 0.5) * (f - lo) / (hi - lo) for f in r]
    hx, hy, hz = vol.spacing
    g = [np.stack(np.gradient(f, hz, hy, hx)[::-1], axis=-1) for f in rho]
    scale = 150.0 / max(float(np.nanmax(np.abs(a))) for a in g)
    m = get_mapping("paper-density")
    m.prepare_series(vol, hold_bytes=1 << 30)
    for n in range(vol.n_steps):
        got_rho, got_v = m.map(vol, n)
        np.testing.assert_array_equal(got_rho, rho[n])
        np.testing.assert_array_equal(got_v, g[n] * scale)
    m.release()


@pytest.mark.filterwarnings("ignore::auralize.sources.detection.SourceFractionWarning")
@pytest.mark.parametrize(
    "mapping", [{"mapping": "paper-density"}, {"mapping": "identity", "density": "log10_density"}]
)
def test_detection_on_one_thread_and_on_two_is_the_same(mapping: dict[str, str]) -> None:
    """On two threads the mapping works in slabs and each thread detects whole steps
    (their own caches, side by side); on one, step after step: the same sources."""
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has one thread")

    def volume() -> TimeVolume:
        vol = make_explosion(size=41, steps=11).load()
        arr = vol.fields["log10_density"].array  # type: ignore[attr-defined]
        arr[6, 10:14, 3:8, 20:30] = np.nan  # no-data at one step: a mapped frame with NaN
        vol.check_finite = False  # NaN is no-data (nan="mask")
        return vol

    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = detect(volume(), **mapping)  # type: ignore[arg-type]
        numba.set_num_threads(2)
        two = detect(volume(), **mapping)  # type: ignore[arg-type]
    finally:
        numba.set_num_threads(old)
    assert_same(two, one.thresholds, one.frames)
    assert sum(f.index.size for f in one.frames) > 1000
    n_valid = one.frames[6].n_valid
    assert n_valid is not None and n_valid < 41**3  # the NaN points are no-data
