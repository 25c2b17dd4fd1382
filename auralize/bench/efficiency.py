"""How close the synthesis runs to the machine: ``auralize bench`` rows of efficiency.

Two paths make the pressure heard, and each has its own bound:

* **The data-step path** (:func:`auralize.emitters.synthesis.render_tracks`,
  what a volume's sources go through): each source is a Hermite piece between
  two data steps, and a piece costs about 300 floating-point operations
  whatever the number of output samples it covers (its arrival times, the
  piece's cubic, its gains).  Its floor is the number of pieces times 300
  flops at the machine's peak rate, measured here as a large matrix product
  (BLAS reaches close to the cores' peak).
* **The signal path** (:func:`auralize.emitters.engine.render_emitters`,
  emitters with sampled signals, as the plugins make them): every signal
  sample is read once (8 bytes), so its bound is the memory bandwidth divided
  by 8 bytes, measured here as a streamed add of arrays far larger than the
  caches.

Both rates are per CPU second (every thread of the process counted), as are
the bounds, so a busy machine lowers neither side more than the other.  The
rows give each rate, its bound and the ratio.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from auralize.plugins import BenchRow

#: floating-point operations of one Hermite piece in the data-step path
FLOPS_PER_PIECE = 300
#: bytes read per source-sample of the signal path (one float64)
BYTES_PER_SAMPLE = 8


def _cpu_seconds(fn: Callable[[], object], repeat: int) -> float:
    """Least CPU time (s, all threads) of ``fn`` over ``repeat`` calls after one warm-up."""
    fn()
    best = np.inf
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return float(best)


def peak_flops(n: int = 1536, repeat: int = 3) -> float:
    """Floating-point operations per CPU second of a float64 matrix product
    (``2 n³`` operations): the practical peak of the cores.

    Parameters
    ----------
    n : int
        Size of the square matrices.
    repeat : int
        Products timed (the fastest is kept).

    Returns
    -------
    float
        Operations per CPU second (every thread counted).

    Examples
    --------
    >>> peak_flops(n=64, repeat=1) > 1e6
    True
    """
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(n, n)), rng.normal(size=(n, n))
    return 2.0 * n**3 / _cpu_seconds(lambda: a @ b, repeat)


def memory_bandwidth(n: int = 1 << 25, repeat: int = 3) -> float:
    """Bytes per CPU second of ``c = a + b`` on arrays of ``n`` float64 (two
    read, one written: ``24 n`` bytes), far larger than the caches.

    Parameters
    ----------
    n : int
        Elements of each array (the default, 32 Mi, is 256 MiB each).
    repeat : int
        Sums timed (the fastest is kept).

    Returns
    -------
    float
        Bytes per CPU second.

    Examples
    --------
    >>> memory_bandwidth(n=1 << 16, repeat=1) > 1e6
    True
    """
    a = np.ones(n)
    b = np.ones(n)
    c = np.empty(n)
    return 24.0 * n / _cpu_seconds(lambda: np.add(a, b, out=c), repeat)


def _pieces(q: np.ndarray) -> int:
    """Hermite pieces a render evaluates: intervals with a sounding knot at either end."""
    nz = q != 0
    return int(np.count_nonzero(nz[:, :-1] | nz[:, 1:]))


def data_step_rows(quick: bool, flops: float) -> list[BenchRow]:
    """The data-step path on :func:`auralize.bench.runner.scaling_scene` (100k
    sources, 30 data steps a data second, 1 s of data in 10 s of audio; ``quick``:
    30k sources, 4 s) heard from a point 30 m from the scene's centre, mono."""
    from auralize.bench.runner import scaling_scene
    from auralize.emitters.synthesis import render_tracks
    from auralize.listener import ListenerPath

    dur = 4.0 if quick else 10.0
    n_src = 30_000 if quick else 100_000
    tracks = scaling_scene(n_src, round(3 * dur) + 1)
    path = ListenerPath.point((30.0, 0.0, 1.0), duration=dur)
    rate = 44100
    cpu = _cpu_seconds(
        lambda: render_tracks(tracks, path, rate=rate, time_scale=10.0, duration=dur), repeat=3
    )
    pieces = _pieces(np.asarray(tracks.q))
    equivalent = n_src * dur * rate / cpu
    floor = pieces * FLOPS_PER_PIECE / flops
    share = floor / cpu
    return [
        BenchRow(
            "efficiency",
            f"data-step path, {n_src // 1000}k sources → mono, {dur:g} s",
            equivalent / 1e9,
            "G source-samples/CPU-s",
            note=f"{pieces:,} pieces in {cpu * 1e3:.1f} CPU-ms",
        ),
        BenchRow(
            "efficiency",
            "… share of its floor (pieces × 300 flops at peak)",
            100.0 * share,
            "%",
            target="≥ 15 %",
            met=share >= 0.15,
            note=f"floor {floor * 1e3:.1f} CPU-ms at {flops / 1e9:.1f} GFLOP/CPU-s "
            "(float64 matrix product)",
        ),
    ]


def signal_rows(quick: bool, bandwidth: float) -> list[BenchRow]:
    """The signal path: 64 static emitters with 48 kHz noise signals, rendered to
    mono at 48 kHz from a point 5 m away (the signals at the output rate: no
    upsampling inside)."""
    from auralize.emitters import Emitters
    from auralize.emitters.engine import render_emitters
    from auralize.listener import ListenerPath

    dur = 2.0 if quick else 10.0
    rate = 48000
    n_em = 64
    rng = np.random.default_rng(0)
    sig = rng.normal(size=(n_em, int((dur + 0.1) * rate)))
    pos = rng.uniform(-1.0, 1.0, size=(n_em, 3))
    em = Emitters(sig, float(rate), pos, t0=-0.05, name="signal path")
    path = ListenerPath.point((5.0, 0.0, 0.0), duration=dur)
    cpu = _cpu_seconds(
        lambda: render_emitters(em, path, rate=rate, layout="mono"), repeat=3 if quick else 5
    )
    achieved = n_em * dur * rate / cpu
    bound = bandwidth / BYTES_PER_SAMPLE
    share = achieved / bound
    return [
        BenchRow(
            "efficiency",
            f"signal path, {n_em} emitters 48 kHz → mono, {dur:g} s",
            achieved / 1e9,
            "G source-samples/CPU-s",
            note=f"{cpu * 1e3:.1f} CPU-ms",
        ),
        BenchRow(
            "efficiency",
            "… share of the memory bound (8 bytes a sample)",
            100.0 * share,
            "%",
            target="≥ 40 %",
            met=share >= 0.40,
            note=f"bound {bound / 1e9:.2f} G samples/CPU-s at "
            f"{bandwidth / 1e9:.1f} GB/CPU-s (streamed add)",
        ),
    ]


def efficiency_rows(quick: bool) -> list[BenchRow]:
    """Rows of both paths beside the machine's bounds, measured in the same run.

    Parameters
    ----------
    quick : bool
        Shorter renders and fewer sources (``auralize bench --quick``).

    Returns
    -------
    list of BenchRow
        The machine's measured bounds, then each path's rate and its share of
        its bound (targets 15 % and 40 %).
    """
    flops = peak_flops()
    bandwidth = memory_bandwidth()
    rows: list[Any] = [
        BenchRow("efficiency", "peak: float64 matrix product", flops / 1e9, "GFLOP/CPU-s"),
        BenchRow(
            "efficiency", "memory: streamed add of 256 MiB arrays", bandwidth / 1e9, "GB/CPU-s"
        ),
    ]
    rows += data_step_rows(quick, flops)
    rows += signal_rows(quick, bandwidth)
    return rows
