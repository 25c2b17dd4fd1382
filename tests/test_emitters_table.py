"""TableEmitters: signals of looping tables, evaluated by the sampled kernel where it reads them."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.emitters import Emitters, TableEmitters, render_emitters
from auralize.errors import ParameterError
from auralize.listener import ListenerPath

RATE = 44100
K = 32


def _table(seed: int = 0, rows: int = 2, P: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Smooth looping rows (a few harmonics well below their Nyquist frequency)."""
    rng = np.random.default_rng(seed)
    N = 400
    lengths = np.array([N, N - 37][:rows])
    tab = np.zeros((rows, N, P))
    for r, n in enumerate(lengths):
        ph = 2 * np.pi * np.arange(n) / n
        for p in range(P):
            for h in (3, 7, 11):
                tab[r, :n, p] += rng.standard_normal() * np.sin(h * ph + rng.uniform(0, 6))
    return tab, lengths


def _emitters(
    C: int = 3,
    P: int = 2,
    rows: int = 2,
    B: int = 300,
    S: int = 2,
    rate: float = RATE,
    mix: bool = True,
    seed: int = 1,
) -> TableEmitters:
    """S moving emitters (a few m/s, about 1 m from the origin) of B table blocks."""
    tab, lengths = _table(seed, rows, P)
    rng = np.random.default_rng(seed)
    t = np.arange(B + 1) / B  # slow, smooth modulations over the emission
    env = 0.5 + 0.5 * np.sin(2 * np.pi * t)[None, :, None, None]
    q = env * rng.standard_normal((S, 1, C, P))
    qa, qb = q[:, :-1], q[:, 1:]
    speed = 0.36 + 0.1 * np.sin(3 * np.pi * t)
    phase = np.cumsum(np.r_[0.0, speed[:-1]] * K)[None] + rng.uniform(0, 300, (S, 1))
    r0 = np.zeros((S, B), dtype=np.int64)
    r1 = np.full((S, B), rows - 1, dtype=np.int64)
    w = np.broadcast_to(np.linspace(0, 1, B), (S, B)) if mix else np.zeros((S, B))
    tp = np.arange(B + 1) * K / rate
    pos = np.stack([0.8 * np.cos(3 * tp + s) for s in range(S)])[..., None] * [1, 0, 0]
    pos = pos + np.stack([0.8 * np.sin(3 * tp + s) for s in range(S)])[..., None] * [0, 1, 0]
    pos = pos + [0, 0, 0.2]
    return TableEmitters(
        tab,
        lengths,
        qa=qa,
        qb=qb,
        phase=phase,
        r0=r0,
        r1=r1,
        w=w,
        block=K,
        rate=rate,
        positions=pos,
        pos_rate=rate / K,
        radius=0.05,
        law=1.0,
        name="test",
    )


def _definition(em: TableEmitters) -> np.ndarray:
    """The samples of :class:`TableEmitters`' definition, in numpy: ``(S, C, B·block)``."""
    S, B, C, P = em.qa.shape
    j = np.arange(em.block)
    f = j / em.block
    out = np.zeros((S, C, B * em.block))
    for s in range(S):
        for b in range(B):
            pos = em.phase[s, b] + f * (em.phase[s, b + 1] - em.phase[s, b])

            def row(r: int, pos: np.ndarray = pos) -> np.ndarray:
                n = em.lengths[r]
                x = np.mod(pos, n)
                i = np.floor(x).astype(int)
                i1 = (i + 1) % n
                fr = (x - i)[:, None]
                return em.table[r, i] + fr * (em.table[r, i1] - em.table[r, i])  # (K, P)

            T = (1 - em.w[s, b]) * row(em.r0[s, b]) + em.w[s, b] * row(em.r1[s, b])
            Q = em.qa[s, b][None] + f[:, None, None] * (em.qb[s, b] - em.qa[s, b])[None]
            out[s, :, b * em.block : (b + 1) * em.block] = np.einsum("kcp,kp->ck", Q, T)
    return out


def _stored(
    em: TableEmitters, signals: np.ndarray | None = None, rate: float | None = None
) -> Emitters:
    sig = em.signals if signals is None else signals
    return Emitters(
        sig,
        em.rate if rate is None else rate,
        em.positions,
        t0=em.t0,
        pos_rate=em.pos_rate,
        radius=em.radius,
        law=em.law,
    )


@pytest.mark.parametrize("C,P", [(3, 2), (1, 1), (1, 2)])
def test_signals_are_the_definition(C: int, P: int) -> None:
    em = _emitters(C=C, P=P, B=40)
    ref = _definition(em)
    sig = em.signals if C == 3 else em.signals[:, None]
    assert em.dipole == (C == 3) and em.n_samples == 40 * K and em.n_emitters == 2
    np.testing.assert_allclose(sig, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize("layout", ["mono", "ring8"])
def test_render_evaluates_the_signal_at_the_emission_index(layout: str) -> None:
    """The table path is closer to the continuous signal than a linear read of its samples."""
    em = _emitters(mix=False, rows=1)  # one row: a continuous signal
    path = ListenerPath.line((0.0, 0.0, 0.0), (0.3, 0.1, 0.0), duration=0.2)
    table = render_emitters(em, path, rate=RATE, layout=layout).audio
    stored = render_emitters(_stored(em), path, rate=RATE, layout=layout).audio
    # the same continuous signal sampled 4x finer: a linear read of it is ~16x more exact
    fine = TableEmitters(
        em.table,
        em.lengths,
        qa=em.qa,
        qb=em.qb,
        phase=em.phase,
        r0=em.r0,
        r1=em.r1,
        w=em.w,
        block=4 * K,
        rate=4 * RATE,
        positions=em.positions,
        pos_rate=em.pos_rate,
        radius=em.radius,
        law=1.0,
    )
    truth = render_emitters(_stored(fine), path, rate=RATE, layout=layout, oversample=1).audio
    peak = np.abs(truth).max()
    assert peak > 0
    err_table = np.abs(table - truth) / peak
    err_stored = np.abs(stored - truth) / peak
    assert err_table.max() < 5e-4 and err_table.max() < err_stored.max()
    assert np.sqrt(np.mean(err_table**2)) < np.sqrt(np.mean(err_stored**2)) / 3
    np.testing.assert_allclose(table, stored, rtol=0, atol=2e-3 * peak)


def test_wide_control_points_read_across_several_table_blocks() -> None:
    """Control points every 128 output samples: each piece spans four or more table blocks
    of 32 samples and is read block by block without per-sample tests; it stays as close to
    the continuous signal as 32-sample control points, and windows still join."""
    em = _emitters(mix=False, rows=1)
    path = ListenerPath.line((0.0, 0.0, 0.0), (0.3, 0.1, 0.0), duration=0.2)
    fine = TableEmitters(
        em.table,
        em.lengths,
        qa=em.qa,
        qb=em.qb,
        phase=em.phase,
        r0=em.r0,
        r1=em.r1,
        w=em.w,
        block=4 * K,
        rate=4 * RATE,
        positions=em.positions,
        pos_rate=em.pos_rate,
        radius=em.radius,
        law=1.0,
    )
    truth = render_emitters(_stored(fine), path, rate=RATE, layout="mono", oversample=1).audio
    peak = np.abs(truth).max()
    wide = render_emitters(em, path, rate=RATE, layout="mono", block=128)
    assert peak > 0 and wide.meta["block"] == 128
    err = np.abs(wide.audio - truth) / peak
    assert err.max() < 5e-4 and np.sqrt(np.mean(err**2)) < 5e-5
    a = render_emitters(em, path, rate=RATE, layout="mono", block=128, duration=0.07).audio
    b = render_emitters(
        em, path, rate=RATE, layout="mono", block=128, start=0.07, duration=0.13
    ).audio
    np.testing.assert_allclose(np.concatenate([a, b], 1), wide.audio, rtol=0, atol=1e-9 * peak)


def test_windows_join_and_reference_backend() -> None:
    em = _emitters(mix=False, rows=1)
    path = ListenerPath.line((0.0, 0.0, 0.0), (0.0, 0.4, 0.0), duration=0.2)
    whole = render_emitters(em, path, rate=RATE, layout="ring8").audio
    a = render_emitters(em, path, rate=RATE, layout="ring8", duration=0.07).audio
    b = render_emitters(em, path, rate=RATE, layout="ring8", start=0.07, duration=0.13).audio
    np.testing.assert_allclose(
        np.concatenate([a, b], 1), whole, rtol=0, atol=1e-9 * np.abs(whole).max()
    )
    ref = render_emitters(em, path, rate=RATE, layout="ring8", backend="reference").audio
    np.testing.assert_allclose(whole, ref, rtol=0, atol=3e-3 * np.abs(ref).max())


def test_low_rate_tables_are_upsampled_as_their_samples() -> None:
    """Below the output rate the engine upsamples band-limited: the stored samples are used."""
    em = _emitters(rate=RATE / 4, B=60)
    path = ListenerPath.point((0.0, 0.0, 0.0), duration=0.15)
    a = render_emitters(em, path, rate=RATE).audio
    b = render_emitters(_stored(em), path, rate=RATE).audio
    assert np.abs(b).max() > 0
    np.testing.assert_array_equal(a, b)


def test_bad_tables() -> None:
    em = _emitters(B=4)
    args = dict(
        table=em.table,
        lengths=em.lengths,
        qa=em.qa,
        qb=em.qb,
        phase=em.phase,
        r0=em.r0,
        r1=em.r1,
        w=em.w,
        block=K,
        rate=RATE,
        positions=em.positions,
    )
    with pytest.raises(ParameterError, match="table must be"):
        TableEmitters(**{**args, "table": em.table[..., None]})
    with pytest.raises(ParameterError, match="lengths must be in 2..400"):
        TableEmitters(**{**args, "lengths": np.array([400, 401])})
    with pytest.raises(ParameterError, match="qa and qb"):
        TableEmitters(**{**args, "qb": em.qb[:, :-1]})
    with pytest.raises(ParameterError, match="phase must be"):
        TableEmitters(**{**args, "phase": em.phase[:, :-1]})
    with pytest.raises(ParameterError, match="rows must be in 0..1"):
        TableEmitters(**{**args, "r1": em.r1 + 5})
    bad = em.qa.copy()
    bad[0, 0, 0, 0] = np.nan
    with pytest.raises(ParameterError, match="qa contains NaN"):
        TableEmitters(**{**args, "qa": bad})
    with pytest.raises(ParameterError, match="block must be a positive integer"):
        TableEmitters(**{**args, "block": 0})
    with pytest.raises(ParameterError, match="positions must be"):
        TableEmitters(**{**args, "positions": em.positions[:1]})
