"""The sound engine: every model's sound reaches the listener through here.

A sound model (:class:`auralize.plugins.SoundModel`) describes what it
*emits*; the engine does the propagation (retarded time, distance law,
Doppler), the panning to any layout, and the summation of several models
along one listener path.  Three kinds of parts make up a :class:`Sound`:

:class:`Emitters`
    point emitters with emitted signals sampled at any rate (audio-rate
    textures of vortex and aerodynamic sound, a fire's pressure, a moving
    object), monopole ``(S, n)`` or dipole ``(S, 3, n)``;
:class:`TableEmitters`
    emitters whose signals are smooth modulations of looping tables
    (aerodynamic sound textures), read from the tables where the engine
    evaluates them;
:class:`FieldSources`
    the monopole/dipole/quadrupole sources detected in a volume
    (:class:`auralize.sources.detection.SourceTracks`), sampled at the data's steps and
    rendered by the piecewise-Hermite kernels of :mod:`auralize.emitters.synthesis`;
a model's own part
    any object with ``name`` and ``render_part(path, *, rate, layout,
    duration, start, c0, backend) -> Rendered`` for closed forms that are
    faster than sampled emission (spark's WM-wave accumulation); it takes its
    arrival times, distances and panning gains from the engine.

Emitter times are seconds of playback from the listener path's first
capture: output sample ``n`` is heard at ``start + n / rate``.

For emitter ``s`` at position ``x_s(τ)`` and a listener at ``L(t)`` the
received pressure is (paper 003 §3.2.4.2 for the retarded time; the
far-field point-source law of paper 000 §6, Eq. 5 and paper 004 §6, Eq. 4):

    p(t) = Σ_s  a_s(τ_s) · g(D_s),   t − τ_s = D_s / c0,   D_s = |L(t) − x_s(τ_s)|

with ``a_s = q_s`` for a monopole, ``a_s = û_s · G_s`` for a dipole (û the
unit vector from the emitter to the listener), ``g(D) = 1/D^e`` (``e = 1``,
"physical"; ``e = 3``, "paper" for paper 000's 1/r³ erratum), and D clamped
to the emitter's radius.  Panning uses the layout's own law on the
emitter's direction in the listener's frame (:func:`auralize.spatial.layouts.pan_gains`).
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from auralize.constants import C0 as C0  # (re-exported: the engine's default)
from auralize.defaults import Interp, Timbre
from auralize.errors import ParameterError

#: lowest and highest output sample rate a render accepts (command line and API), Hz
RATE_RANGE_HZ = (8000, 768000)
#: the named distance laws and their exponents e of ``g(D) = 1/D^e``
LAWS = {"physical": 1.0, "paper": 3.0}
#: the emitter renderers' backends (:func:`auralize.emitters.engine.render_emitters`)
Backend = Literal["auto", "sampled", "reference"]


def law_exponent(law: str | float) -> float:
    """Distance-law exponent e of ``g(D) = 1/D^e``: "physical" 1, "paper" 3, or a number.

    Parameters
    ----------
    law : str or float
        ``"physical"`` (1/D, the far field of a point source), ``"paper"``
        (1/D³, paper 000's Eq. 5 as printed) or an exponent in [0, 6] (a
        number or a string of one).

    Returns
    -------
    float
        The exponent e.

    Raises
    ------
    ParameterError
        A name that is not a law, or an exponent outside [0, 6].

    Examples
    --------
    >>> law_exponent("physical"), law_exponent("paper"), law_exponent(2)
    (1.0, 3.0, 2.0)
    """
    if isinstance(law, str) and law in LAWS:
        return LAWS[law]
    try:
        e = float(law)
    except (TypeError, ValueError):
        raise ParameterError(
            f"distance law must be 'physical', 'paper' or an exponent, got {law!r}"
        ) from None
    if not (np.isfinite(e) and 0.0 <= e <= 6.0):
        raise ParameterError(f"distance-law exponent must be in [0, 6], got {law!r}")
    return e


@dataclass
class Emitters:
    """Point emitters with emitted signals.

    Parameters
    ----------
    signals : (S, n) or (S, 3, n) float
        Emitted pressure at 1 m in Pa (monopoles), or the world-frame vector
        ``G`` of dipoles whose pressure toward unit direction û is ``û · G``.
        Values outside ``[t0, t0 + n / rate)`` are zero.
    rate : float
        Samples per second of ``signals`` (any rate: the engine interpolates).
    positions : (S, 3) or (S, m, 3) float
        Static positions (m), or trajectories sampled at ``pos_rate`` from
        ``t0`` (held at their ends); moving emitters get their Doppler shift
        from the retarded time.
    t0 : float
        Playback seconds (since the listener path's first capture) of sample 0.
    pos_rate : float, optional
        Samples per second of trajectories (default ``rate``).
    radius : float or (S,) float
        Distances are clamped here (m): a listener at an emitter gets no 1/0.
    law : str or float
        ``"physical"`` (1/D), ``"paper"`` (1/D³) or an exponent
        (:func:`law_exponent`).
    name : str
        The model that made them (reports, scene listings).
    meta : dict
        What the model records about them (copied into reports as it is).

    Raises
    ------
    ParameterError
        Signals or positions of the wrong shape or with NaN or Inf, a rate,
        ``pos_rate`` or clamp radius not > 0, a ``t0`` not finite, or an
        unknown ``law``.

    Examples
    --------
    A 440 Hz tone of 10 ms at 8 kHz, 1 Pa at 1 m, emitted 2 m in front of
    the listener from playback second 0.1:

    >>> import numpy as np
    >>> tone = np.sin(2 * np.pi * 440 * np.arange(80) / 8000)
    >>> em = Emitters(tone[None], 8000, [[0.0, 2.0, 0.0]], t0=0.1, name="tone")
    >>> em.n_emitters, em.n_samples, em.dipole, em.moving, em.t_end
    (1, 80, False, False, 0.11)
    """

    signals: NDArray[np.float64]
    rate: float
    positions: NDArray[np.float64]
    _: KW_ONLY
    t0: float = 0.0
    pos_rate: float | None = None
    radius: float | NDArray[np.float64] = 0.05
    law: str | float = "physical"
    name: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        sig = np.asarray(self.signals, dtype=np.float64)
        if sig.ndim == 1:
            sig = sig[None]
        if sig.ndim not in (2, 3) or (sig.ndim == 3 and sig.shape[1] != 3):
            raise ParameterError(
                f"emitter signals must be (S, n) monopoles or (S, 3, n) dipoles, got {sig.shape}"
            )
        if not np.all(np.isfinite(sig)):
            raise ParameterError(f"{self.name or 'emitter'} signals contain NaN or Inf")
        self.signals = np.ascontiguousarray(sig)
        self._place(sig.shape[0], self.name or "emitter")

    def _place(self, S: int, who: str) -> None:
        """Check and normalise the placement fields (positions, rates, t0, clamp
        radius, law) for S emitters; ``who`` names them in the messages."""
        pos = np.asarray(self.positions, dtype=np.float64)
        if pos.ndim == 1:
            pos = pos[None]
        if pos.shape[0] != S or pos.shape[-1] != 3 or pos.ndim not in (2, 3):
            raise ParameterError(
                f"{who} positions must be (S, 3) or (S, m, 3) for S={S} emitters, got {pos.shape}"
            )
        if not np.all(np.isfinite(pos)):
            raise ParameterError(f"{who} positions contain NaN or Inf")
        if not (np.isfinite(self.rate) and self.rate > 0):
            raise ParameterError(f"{who} rate must be > 0 samples/s, got {self.rate!r}")
        pr = self.rate if self.pos_rate is None else self.pos_rate
        if not (np.isfinite(pr) and pr > 0):
            raise ParameterError(f"{who} pos_rate must be > 0 samples/s, got {pr!r}")
        if not np.isfinite(self.t0):
            raise ParameterError(f"{who} t0 must be finite, got {self.t0!r}")
        rad = np.broadcast_to(np.asarray(self.radius, dtype=np.float64), (S,))
        if not np.all(np.isfinite(rad) & (rad > 0)):
            raise ParameterError(f"{who} clamp radius must be > 0 m")
        law_exponent(self.law)
        self.positions = np.ascontiguousarray(pos)
        self.pos_rate = float(pr)
        self.rate = float(self.rate)
        self.t0 = float(self.t0)
        self.radius = np.ascontiguousarray(rad)

    @property
    def n_emitters(self) -> int:
        """Number of emitters S.

        Examples
        --------
        >>> Emitters(np.zeros((3, 10)), 8000, np.zeros((3, 3))).n_emitters
        3
        """
        return int(self.signals.shape[0])

    @property
    def dipole(self) -> bool:
        """Whether the emitters are dipoles (signals ``(S, 3, n)``), not monopoles.

        Examples
        --------
        >>> Emitters(np.zeros((1, 3, 10)), 8000, [[1.0, 0, 0]]).dipole
        True
        """
        return self.signals.ndim == 3

    @property
    def moving(self) -> bool:
        """Whether the positions are trajectories ``(S, m, 3)``, not static ``(S, 3)``.

        Examples
        --------
        >>> Emitters(np.zeros((1, 10)), 8000, np.zeros((1, 4, 3)), pos_rate=100).moving
        True
        """
        return self.positions.ndim == 3

    @property
    def n_samples(self) -> int:
        """Emitted samples n per emitter.

        Examples
        --------
        >>> Emitters(np.zeros((1, 10)), 8000, [[1.0, 0, 0]]).n_samples
        10
        """
        return int(self.signals.shape[-1])

    @property
    def t_end(self) -> float:
        """Playback second just after the last emitted sample, ``t0 + n / rate``.

        Examples
        --------
        >>> Emitters(np.zeros((1, 800)), 8000, [[1.0, 0, 0]], t0=0.5).t_end
        0.6
        """
        return self.t0 + self.n_samples / self.rate

    def position_at(self, tau: NDArray[np.float64], s: int) -> NDArray[np.float64]:
        """Emitter ``s``'s position at emission times ``tau`` (linear, held at the ends).

        Parameters
        ----------
        tau : (N,) float
            Emission times, playback seconds since the listener path's first capture.
        s : int
            Index of the emitter, ``0 <= s < S``.

        Returns
        -------
        (N, 3) float
            Positions (m); a static emitter's position repeated (a read-only view).

        Examples
        --------
        An emitter moving from x = 0 to x = 1 m in 0.1 s (trajectory at 10 Hz):

        >>> em = Emitters(np.zeros((1, 10)), 100, [[[0.0, 0, 0], [1.0, 0, 0]]], pos_rate=10)
        >>> em.position_at(np.array([0.05, 0.2]), 0).tolist()
        [[0.5, 0.0, 0.0], [1.0, 0.0, 0.0]]
        """
        if not self.moving:
            return np.broadcast_to(self.positions[s], (np.size(tau), 3))
        assert self.pos_rate is not None
        tp = self.t0 + np.arange(self.positions.shape[1]) / self.pos_rate
        return np.stack([np.interp(tau, tp, self.positions[s, :, k]) for k in range(3)], axis=1)


class TableEmitters(Emitters):
    """Point emitters whose signals are read from looping tables as the engine renders them.

    For models whose emitted signal is a smooth modulation of a looping
    table (the sound textures of aerodynamic sound, paper 004 §6, Eq. 3):
    the sampled backend evaluates the signal where it reads it, at the
    fractional emission index of each output sample, instead of writing
    every emission sample to an array and reading it back.  The signal of
    emitter s at emission index ``x`` (playback second ``t0 + x / rate``;
    ``0 <= x <= B·block − 1``, zero outside), in table block ``b = ⌊x / block⌋``
    at ``f = x / block − b``, is

        a_c(x) = Σ_p (qa[s,b,c,p] + f (qb[s,b,c,p] − qa[s,b,c,p])) · T_p(x)
        T_p(x) = (1 − w[s,b]) R_p(r0[s,b], φ) + w[s,b] R_p(r1[s,b], φ)
        φ = phase[s,b] + f (phase[s,b+1] − phase[s,b])      (modulo the row's length)

    with ``R_p(r, φ)`` table row r read linearly at position φ, looping (row
    r holds ``lengths[r]`` samples).  :attr:`signals` are its samples at
    integer x (generated on first use; the numpy reference backend and
    upsampling read them); the sampled backend evaluates ``a(x)`` itself,
    which differs from reading those samples linearly by that linear
    read's error.  A dipole's projection on the direction to the listener
    is taken on the P table components once per control point.

    Parameters
    ----------
    table : (R, N, P) float
        R looping rows of P = 1 or 2 components (row r uses its first
        ``lengths[r]`` samples; dimensionless, scaled by ``qa`` and ``qb``).
    lengths : (R,) int
        Samples per row, in ``2..N``.
    qa, qb : (S, B, C, P) float
        Matrix from table components to the emitted signal at the start and
        at the end of each table block: C = 1 monopole (Pa at 1 m), C = 3
        dipole (world-frame vector G, as :class:`Emitters`).
    phase : (S, B + 1) float
        Table position (table samples) at the block boundaries.
    r0, r1 : (S, B) int
        Rows mixed in each block with weights ``1 − w`` and ``w``.
    w : (S, B) float
        Weight of row r1 in each block.
    block : int
        Emission samples per table block.
    rate, positions, t0, pos_rate, radius, law, name, meta
        As for :class:`Emitters` (``positions`` ``(S, 3)`` or ``(S, m, 3)``).
    check : bool
        Scan the table, matrices, phases and weights for NaN or Inf (False:
        arrays a model computed from its own finite inputs; shapes, rows and
        placement are still checked).

    Attributes
    ----------
    padded_table : (R, N + 2 block + 2, P) float
        Each row continued past its length by its own samples from 0, so that
        the sampled backend reads a table block without wrapping.

    Raises
    ------
    ParameterError
        Arrays of shapes that do not fit together, row lengths outside
        ``2..N``, rows outside ``0..R-1``, a block not a positive integer,
        NaN or Inf (with ``check``), or a placement :class:`Emitters` refuses.

    Examples
    --------
    One monopole reading a ramp table at unit speed (the table position
    advances 4 samples per block of 4 emission samples), 1 Pa at 1 m per
    table unit:

    >>> import numpy as np
    >>> one = np.ones((1, 2, 1, 1))
    >>> em = TableEmitters(np.arange(8.0)[None, :, None], np.array([8]), qa=one, qb=one,
    ...                    phase=np.array([[0.0, 4.0, 8.0]]), r0=np.zeros((1, 2), int),
    ...                    r1=np.zeros((1, 2), int), w=np.zeros((1, 2)), block=4, rate=8000,
    ...                    positions=[[0.0, 2.0, 0.0]])
    >>> em.n_emitters, em.n_samples, em.signals.tolist()
    (1, 8, [[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]])
    """

    def __init__(  # noqa: PLR0913 (keyword-only options)
        self,
        table: NDArray[np.float64],
        lengths: NDArray[np.int64],
        *,
        qa: NDArray[np.float64],
        qb: NDArray[np.float64],
        phase: NDArray[np.float64],
        r0: NDArray[np.int64],
        r1: NDArray[np.int64],
        w: NDArray[np.float64],
        block: int,
        rate: float,
        positions: NDArray[np.float64],
        t0: float = 0.0,
        pos_rate: float | None = None,
        radius: float | NDArray[np.float64] = 0.05,
        law: str | float = "physical",
        name: str = "",
        meta: dict[str, Any] | None = None,
        check: bool = True,
    ) -> None:
        f = np.ascontiguousarray
        who = name or "table emitter"
        tab = f(table, dtype=np.float64)
        lens = f(lengths, dtype=np.int64)
        qa, qb = f(qa, dtype=np.float64), f(qb, dtype=np.float64)
        if tab.ndim != 3 or tab.shape[2] not in (1, 2) or lens.shape != (tab.shape[0],):
            raise ParameterError(
                f"{who}: table must be (R, N, P) with P = 1 or 2 and lengths "
                f"(R,), got {tab.shape} and {lens.shape}"
            )
        if np.any(lens < 2) or np.any(lens > tab.shape[1]):
            raise ParameterError(
                f"{who}: table row lengths must be in 2..{tab.shape[1]}, got "
                f"{lens.min()}..{lens.max()}"
            )
        if qa.ndim != 4 or qa.shape != qb.shape or qa.shape[2] not in (1, 3):
            raise ParameterError(
                f"{who}: qa and qb must be (S, B, C, P) with C = 1 or 3, got "
                f"{qa.shape} and {qb.shape}"
            )
        S, B, _, P = qa.shape
        if P != tab.shape[2] or B < 1 or S < 1:
            raise ParameterError(
                f"{who}: qa {qa.shape} must have the table's {tab.shape[2]} "
                "components, >= 1 emitter and >= 1 block"
            )
        ph = f(phase, dtype=np.float64)
        r0, r1 = f(r0, dtype=np.int64), f(r1, dtype=np.int64)
        w = f(w, dtype=np.float64)
        if ph.shape != (S, B + 1) or r0.shape != (S, B) or r1.shape != (S, B) or w.shape != (S, B):
            raise ParameterError(
                f"{who}: phase must be (S, B+1) = {(S, B + 1)} and r0, r1, w "
                f"(S, B) = {(S, B)}, got {ph.shape}, {r0.shape}, {r1.shape}, "
                f"{w.shape}"
            )
        for rows in (r0, r1):
            if rows.min() < 0 or rows.max() >= tab.shape[0]:
                raise ParameterError(f"{who}: table rows must be in 0..{tab.shape[0] - 1}")
        for key, a in (("table", tab), ("qa", qa), ("qb", qb), ("phase", ph), ("w", w)):
            if check and not np.isfinite(np.sum(a)):  # one pass: a sum of finite values is finite
                raise ParameterError(f"{who}: {key} contains NaN or Inf")
        if isinstance(block, bool) or not (isinstance(block, int | np.integer) and block >= 1):
            raise ParameterError(f"{who}: block must be a positive integer, got {block!r}")
        self.table, self.lengths, self.qa, self.qb = tab, lens, qa, qb
        self.phase, self.r0, self.r1, self.w = ph, r0, r1, w
        self.block = int(block)
        # each row continued past its length by its own samples from 0 (2 blocks and one
        # more at unit table speed): a linear read needs no wrap of its second sample, and a
        # table block read inside the padding none at all
        i = np.arange(tab.shape[1] + 2 * self.block + 2)
        self.padded_table = np.ascontiguousarray(
            tab[np.arange(tab.shape[0])[:, None], i[None, :] % lens[:, None]]
        )
        self._signals: NDArray[np.float64] | None = None
        self.rate, self.positions, self.t0, self.pos_rate = rate, positions, t0, pos_rate
        self.radius, self.law, self.name = radius, law, name
        self.meta = {} if meta is None else dict(meta)
        self._place(S, self.name or "table emitter")

    @property
    def signals(self) -> NDArray[np.float64]:  # type: ignore[override]
        """The emission samples ``(S, n)`` or ``(S, 3, n)`` in Pa at 1 m (generated on first use).

        Examples
        --------
        >>> em = TableEmitters(np.ones((1, 4, 1)), np.array([4]), qa=np.ones((2, 1, 1, 1)),
        ...                    qb=np.ones((2, 1, 1, 1)), phase=np.zeros((2, 2)),
        ...                    r0=np.zeros((2, 1), int), r1=np.zeros((2, 1), int),
        ...                    w=np.zeros((2, 1)), block=3, rate=8000, positions=np.eye(2, 3))
        >>> em.signals.shape
        (2, 3)
        """
        if self._signals is None:
            from auralize.emitters._sampled import table_signals

            sig = table_signals(self)
            self._signals = sig if self.dipole else sig[:, 0]
        return self._signals

    @property
    def n_emitters(self) -> int:
        """Number of emitters S (the first axis of ``qa``).

        Examples
        --------
        >>> em = TableEmitters(np.ones((1, 4, 1)), np.array([4]), qa=np.ones((2, 1, 1, 1)),
        ...                    qb=np.ones((2, 1, 1, 1)), phase=np.zeros((2, 2)),
        ...                    r0=np.zeros((2, 1), int), r1=np.zeros((2, 1), int),
        ...                    w=np.zeros((2, 1)), block=3, rate=8000, positions=np.eye(2, 3))
        >>> em.n_emitters
        2
        """
        return int(self.qa.shape[0])

    @property
    def dipole(self) -> bool:
        """Whether the emitters are dipoles (C = 3 rows of ``qa``), not monopoles.

        Examples
        --------
        >>> em = TableEmitters(np.ones((1, 4, 1)), np.array([4]), qa=np.ones((1, 1, 3, 1)),
        ...                    qb=np.ones((1, 1, 3, 1)), phase=np.zeros((1, 2)),
        ...                    r0=np.zeros((1, 1), int), r1=np.zeros((1, 1), int),
        ...                    w=np.zeros((1, 1)), block=3, rate=8000, positions=[[1.0, 0, 0]])
        >>> em.dipole, em.signals.shape
        (True, (1, 3, 3))
        """
        return self.qa.shape[2] == 3

    @property
    def n_samples(self) -> int:
        """Emitted samples per emitter: B table blocks of ``block`` samples.

        Examples
        --------
        >>> em = TableEmitters(np.ones((1, 4, 1)), np.array([4]), qa=np.ones((1, 5, 1, 1)),
        ...                    qb=np.ones((1, 5, 1, 1)), phase=np.zeros((1, 6)),
        ...                    r0=np.zeros((1, 5), int), r1=np.zeros((1, 5), int),
        ...                    w=np.zeros((1, 5)), block=3, rate=8000, positions=[[1.0, 0, 0]])
        >>> em.n_samples
        15
        """
        return int(self.qa.shape[1] * self.block)

    def __repr__(self) -> str:
        return (
            f"TableEmitters({self.name!r}, {self.n_emitters} "
            f"{'dipoles' if self.dipole else 'monopoles'}, {self.n_samples} samples at "
            f"{self.rate:g} Hz, table {self.table.shape})"
        )


@dataclass
class FieldSources:
    """The heard sound of a volume (its whole field, or its detected sources).

    Rendered by the timbre's renderer
    (:func:`auralize.emitters.timbre.render_timbre`; the ``physical`` timbre
    by the piecewise-Hermite kernels of
    :func:`auralize.emitters.synthesis.render_tracks`).  The fields are
    stored as given; the renderer checks them.

    Parameters
    ----------
    tracks : SourceTracks
        The sources' positions ``(K, 3)`` (m) and strengths ``q (K, T)``
        (:class:`auralize.sources.detection.SourceTracks`) at the data's steps.
    time_scale : float
        Playback seconds per data second.
    lead : float
        Data seconds skipped at the start (the sound's travel time to the
        nearest listener position).
    interp : {"linear", "cubic"}
        Interpolation of the strengths between data steps (paper 003 §3.2.4.3).
    timbre : {"physical", "extended", "tonal", "auto"}
        How the strengths sound (:mod:`auralize.emitters.timbre`).
    bounds : tuple of 6 float, optional
        The data's box ``(x0, x1, y0, y1, z0, z1)`` in m (for the timbre's
        distance notes).
    name : str
        The part's name in reports (``meta["parts"]``).
    meta : dict
        What the model records about the part.
    by_type : dict of str to SourceTracks, optional
        The tracks of each source type heard (the ``tonal`` timbre's; None:
        from ``tracks.kind``).
    seed : int
        Seed of the timbre's noise carriers (same seed, same sound).

    Examples
    --------
    One monopole whose strength swings at 20 Hz, heard 2 m away:

    >>> import numpy as np
    >>> from auralize.emitters.engine import render_sound
    >>> from auralize.listener import ListenerPath
    >>> from auralize.sources.detection import SourceTracks
    >>> t = np.linspace(0.0, 0.1, 21)
    >>> tracks = SourceTracks(positions=np.zeros((1, 3)), q=np.sin(2 * np.pi * 20 * t)[None],
    ...                       radius=np.array([0.1]), times=t)
    >>> part = FieldSources(tracks, name="field")
    >>> r = render_sound(part, ListenerPath.point((2.0, 0, 0), duration=0.05), rate=8000)
    >>> r.audio.shape, r.meta["parts"][0]["kind"]
    ((1, 400), 'FieldSources')
    """

    tracks: Any  # auralize.sources.detection.SourceTracks
    _: KW_ONLY
    time_scale: float = 1.0
    lead: float = 0.0
    interp: Interp = "cubic"
    timbre: Timbre = "physical"
    bounds: tuple[float, ...] | None = None
    name: str = "field"
    meta: dict[str, Any] = field(default_factory=dict)
    by_type: dict[str, Any] | None = None
    seed: int = 0


Part = Emitters | FieldSources | Any  # or a model part with render_part()


@dataclass
class Sound:
    """What a sound model emits: parts for the engine, plus metadata.

    Two sounds add to one that holds the parts of both (a scene): rendered
    together they are the sum of each rendered alone
    (:func:`auralize.pipeline.render`).

    Parameters
    ----------
    parts : list
        :class:`Emitters`, :class:`TableEmitters`, :class:`FieldSources` or a
        model's own parts (objects with ``name`` and ``render_part``).
    meta : dict
        What the model records (merged into the render's ``meta``).
    name : str
        The model's name (``"a+b"`` for a sum).

    Examples
    --------
    >>> import numpy as np
    >>> tone = Sound([Emitters(np.ones((1, 8)), 8000, [[1.0, 0, 0]])], name="tone")
    >>> hum = Sound([Emitters(np.ones((2, 8)), 8000, np.eye(2, 3))], meta={"f": 50}, name="hum")
    >>> both = tone + hum
    >>> both.name, len(both.parts), both.meta
    ('tone+hum', 2, {'f': 50})
    """

    parts: list[Part]
    _: KW_ONLY
    meta: dict[str, Any] = field(default_factory=dict)
    name: str = ""

    def __add__(self, other: Sound) -> Sound:
        return Sound(
            parts=[*self.parts, *other.parts],
            meta={**self.meta, **other.meta},
            name="+".join(n for n in (self.name, other.name) if n),
        )


def __getattr__(name: str) -> Any:
    # the renderers import synthesis (numba); load them on first use
    if name in ("render_sound", "render_emitters"):
        import importlib

        return getattr(importlib.import_module("auralize.emitters.engine"), name)
    raise AttributeError(name)
