"""What every synthesis kernel shares: numba options, the lanes of a chunk, the rows of
the work arrays (declared once, as lists) and the kinds of a piece.

Row tables
----------
A kernel's work array is one 1-D float64 array of rows of :data:`_CHUNK`
lanes (one piece, part or run per lane): value ``v`` of lane ``i`` is at
``work[ROW.V * _CHUNK + i]``.  Every access is at a constant distance from
every other, so the compiler vectorizes the loops over lanes without
aliasing checks.  The rows are declared below as lists of ``(name, rows)``
in storage order; :func:`row_table` gives each name its first row, and
``END`` the number of rows.  numba reads a module-level (named) tuple as a
compile-time constant, so ``ROW.KIND`` costs what the literal did.
"""

from __future__ import annotations

import itertools
from collections import namedtuple
from collections.abc import Sequence
from typing import Any

import numba
from numba.core import types
from numba.extending import intrinsic

from auralize.runtime.jit import configure as _configure_numba

_configure_numba()  # cache folder, OMP wait policy, compile notice

_NJIT = {"cache": True, "nogil": True, "error_model": "numpy"}
#: kernels that allocate nothing: compiled without reference counting (numba's
#: runtime increments and decrements an array's count, with atomic
#: instructions, wherever its code copies the array's handle: in every
#: iteration of the scatter loops, where the helpers taking arrays are
#: inlined); the arrays they get belong to their caller for the whole call
_NJIT_NORC = {**_NJIT, "_nrt": False}

#: lanes of a chunk: pieces (or parts, or runs) summed side by side in SIMD loops
_CHUNK = 64


def row_table(name: str, rows: Sequence[tuple[str, int]]) -> Any:
    """The first row of each named block of ``rows`` (``(name, n_rows)`` in
    storage order), as a named tuple with one more field, ``END``: the
    total.  A block of 0 rows marks a position (where a shorter array ends).

    >>> t = row_table("T", [("A", 1), ("B", 3), ("B_END", 0), ("C", 2)])
    >>> t.A, t.B, t.B_END, t.C, t.END
    (0, 1, 4, 4, 6)
    """
    names = [n for n, _ in rows]
    if len(set(names)) != len(names) or "END" in names:
        raise ValueError(f"row names must be unique and not END: {names}")
    if any(k < 0 for _, k in rows):
        raise ValueError(f"row counts must be >= 0: {rows}")
    starts = list(itertools.accumulate((k for _, k in rows), initial=0))
    return namedtuple(name, [*names, "END"])(*starts)


#: rows of the work array of the piece-wise kernel (one piece per lane; see
#: :mod:`auralize.emitters._kernels.pieces`), continued by those of the parts
#: (pieces split at the listener's captures, see
#: :mod:`auralize.emitters._kernels.parts`)
WORK_ROWS: tuple[tuple[str, int], ...] = (
    # the piece's input, rows of its chunk of ``piece_data``: position, clamp
    # radius, q and dq/dτ at its first knot, q and dq/dτ at its last
    ("X", 1), ("Y", 1), ("Z", 1), ("RM", 1), ("Q0", 1), ("M0", 1), ("Q1", 1), ("M1", 1),
    ("INPUT_END", 0),
    # accumulator values (start, end, continuation: 4 each) of polynomial A,
    # then of B (panned layouts: the piece is g0·A + g1·B on a channel whose
    # gain goes linearly from g0 to g1; unpanned: A is the piece)
    ("VAL_A", 12), ("VAL_B", 12),
    # kind (KIND_*), accumulator rows of the start, end and continuation
    # emissions (-1: none), arrivals and their capture intervals
    ("KIND", 1), ("SI", 1), ("EI", 1), ("CI", 1), ("A0", 1), ("A1", 1), ("S0", 1), ("S1", 1),
    # panning by speaker pairs: the listener's forward and up at both
    # arrivals, the source's direction in the listener's frame (forward,
    # left; AmbiX: up in P0, P1), pair index and its two gains per arrival
    ("O0", 6), ("O1", 6), ("XF0", 1), ("YL0", 1), ("XF1", 1), ("YL1", 1),
    ("P0", 1), ("G00", 1), ("G01", 1), ("P1", 1), ("G10", 1), ("G11", 1),
    # f and df/dt (per sample) at both arrivals
    ("F0", 1), ("WF0", 1), ("F1", 1), ("WF1", 1),
    ("PIECE_END", 0),  # the piece-wise kernel's work array ends here
    # parts: capture interval j, whether each end is a knot (1) or a capture
    # (0), the listener's position at both arrivals, its line on interval j
    # (a row of ``interval_lines``: 9 values) and captures j and j + 1
    # (position and time)
    ("J", 1), ("K0", 1), ("K1", 1), ("L0", 3), ("L1", 3), ("LN", 9), ("C0", 4), ("C1", 4),
)  # fmt: skip
ROW = row_table("WorkRow", WORK_ROWS)

#: rows of a chunk of the runs' knot data (each _CHUNK lanes, see
#: :mod:`auralize.emitters._kernels.render_runs`): position, clamp radius, run
#: length (pieces), then per knot j q at KNOT + 2j and dq/dτ at KNOT + 2j + 1
#: (linear interpolation: the slope of the piece from knot j)
KNOT_ROWS: tuple[tuple[str, int], ...] = (
    ("X", 1), ("Y", 1), ("Z", 1), ("RM", 1), ("LEN", 1), ("KNOT", 0),
)  # fmt: skip
KNOT_ROW = row_table("KnotRow", KNOT_ROWS)

#: rows of the work array of the runs kernel (one run per lane)
RUN_ROWS: tuple[tuple[str, int], ...] = (
    # inputs of a step: the run's position, radius and length, q and dq/dτ at
    # this knot and the previous one
    ("X", 1), ("Y", 1), ("Z", 1), ("RM", 1), ("LEN", 1), ("Q", 1), ("M", 1), ("QP", 1), ("MP", 1),
    # outputs: the emission at the previous knot (accumulator row, 4 values),
    # the restart of the piece that ends at this knot (sample; the cubic's c2,
    # c3), the piece's kind (KIND_*) and what the scalar code needs of it
    ("EROW", 1), ("E", 4), ("RROW", 1), ("C2", 2), ("KIND", 1),
    ("A0", 1), ("A1", 1), ("S0", 1), ("S1", 1), ("F0", 1), ("WF0", 1), ("F1", 1), ("WF1", 1),
    # state carried from knot to knot: arrival in samples, its sample, f,
    # df/dt (per sample, of the piece that starts there), arrival, capture
    # interval, found, and the pending end of the piece that ends there (4
    # Taylor coefficients around the arrival; flag)
    ("U", 1), ("SM", 1), ("F", 1), ("W", 1), ("A", 1), ("SG", 1), ("OK", 1), ("P", 4), ("PF", 1),
    ("PLAIN_END", 0),  # unpanned runs' work array ends here
    # AmbiX runs only: the emission at the previous knot split by gain (X, Y,
    # Z: 4 rows each, see render_runs), the A part of this piece's c2, c3 and
    # f/L at its start (B's slope there), the A part of the pending end (its
    # slope, c2, c3: its value is 0), the listener's forward and up at the
    # knot's arrival and the knot's direction in the listener's frame
    ("GX", 4), ("GY", 4), ("GZ", 4), ("CA", 3), ("PA", 3), ("OR", 6), ("DIR", 3),
)  # fmt: skip
RUN_ROW = row_table("RunRow", RUN_ROWS)

#: kinds of a piece (or part, or run step), in row KIND of a work array:
#: silent or outside the output ...
KIND_SILENT = 0.0
#: ... summed by the SIMD loops and the scatter (within one capture interval
#: and at most two accumulation blocks) ...
KIND_SIMPLE = 1.0
#: ... an arrival beyond the listener's candidate lines (or, panned, a
#: direction no speaker pair holds): solved in full by the scalar code ...
KIND_GENERAL = 2.0
#: ... across listener captures or several accumulation blocks: split by the
#: scalar code, from the arrivals, values and gains of the SIMD loops
KIND_ACROSS = 3.0


#: Bundles of arguments (named tuples: numba passes them as their fields, and
#: reads a field where the kernel names it).  The listener's path: capture
#: times ``(M,)``, positions ``(M, 3)``, velocities on each interval
#: ``(M-1, 3)``, and its forward and up ``(N, 6)`` sampled from
#: ``orient_clock[0]`` at rate ``orient_clock[1]`` (see
#: :func:`auralize.emitters._kernels.gains._orient`).
Listener = namedtuple("Listener", ["times", "pos", "vel", "orient_table", "orient_clock"])
#: A layout's panning: speaker azimuths (sorted) and channels, the channel of
#: the next speaker, the pair, triangle or harmonic table ``pinv`` (see
#: :func:`auralize.emitters._kernels.gains._gains`), whether rear directions
#: fold to the front, whether the layout is panned at all, by speaker pairs
#: (SIMD gains), by harmonics (every channel gained: AmbiX), and whether the
#: listener's orientation is constant.
Panning = namedtuple(
    "Panning",
    ["spk_az", "spk_ch", "nxt", "pinv", "fold", "panned", "pairs", "dense", "const_orient"],
)
#: Where a task's emissions go: the accumulator ``acc`` and the task's window
#: of it (offset ``base``, blocks ``blo .. blo + nb - 1`` of ``2**shift``
#: samples, ``n_ch`` channels), the output's length, first time and samples
#: per data second, and the task's capture table (row r: capture
#: ``first_capture + r``, see :func:`auralize.emitters._kernels.accumulate._emit_piece`).
Window = namedtuple(
    "Window",
    [
        "acc",
        "base",
        "blo",
        "nb",
        "n_ch",
        "shift",
        "n_samples",
        "t_start",
        "fs",
        "capture_sums",
        "first_capture",
    ],
)
#: The same window as the SIMD loops read it (floats where they compute with
#: them), with the speed of sound: c0, 1/c0, t_start, fs, 1/fs, n_samples,
#: block length and its inverse, blo, nb, base and values per sample row.
LaneGrid = namedtuple(
    "LaneGrid",
    [
        "c0",
        "inv_c0",
        "t_start",
        "fs",
        "inv_fs",
        "fn",
        "fblock",
        "inv_block",
        "blo",
        "nb",
        "base",
        "rs",
    ],
)
#: A task's scratch: gains at a piece's two ends and two more (per channel),
#: the listener's forward and up (6), and the counts of :func:`auralize.emitters._kernels.parts._chunk_parts`.
Scratch = namedtuple("Scratch", ["ga", "gb", "gx", "gy", "frame", "counts"])
#: The work arrays of a task of the piece-wise kernel: the pieces' and the parts'
#: (rows :data:`ROW`), per-lane gains at both ends of a piece ``(_CHUNK, n_ch)``
#: (layouts panned neither by pairs nor by harmonics), per-lane AmbiX gains at both
#: ends ``(n_ch, _CHUNK)`` and the harmonics' scratch ``(5, _CHUNK)``.
Lanes = namedtuple(
    "Lanes", ["pieces", "parts", "gains0", "gains1", "sh_gains0", "sh_gains1", "sh_scratch"]
)
#: The sounding pieces in chunks of :data:`_CHUNK` lanes, sorted by knot row: row n's
#: chunks are ``chunk_start[n]`` .. ``chunk_start[n + 1] - 1``, chunk c holds
#: ``chunk_count[c]`` pieces, ``piece_data (C, 8, _CHUNK)`` their inputs (rows X ..
#: M1 of :data:`ROW`); task j sums chunks ``task_chunks[j, 0]`` .. ``task_chunks[j, 1] - 1``.
PieceTable = namedtuple("PieceTable", ["piece_data", "chunk_start", "chunk_count", "task_chunks"])
#: The runs of sounding pieces in chunks (see :mod:`auralize.emitters._kernels.render_runs`):
#: chunk g holds ``count[g]`` runs whose first piece is in knot row ``first_row[g]``,
#: the longest ``length[g]`` pieces, their knot data at ``offset[g]`` of ``knot_data``
#: (rows :data:`KNOT_ROW`); task j sweeps knot rows ``task_rows[j, 0]`` .. ``task_rows[j, 1] - 1``.
RunTable = namedtuple(
    "RunTable", ["first_row", "length", "count", "offset", "knot_data", "task_rows"]
)
#: The knot rows: knot times ``(Tp,)`` (padded with silent knots), the rows ``n_lo`` ..
#: ``n_hi - 1`` that can be heard, the listener's candidate lines per row
#: (:func:`auralize.emitters._kernels.arrivals._row_lines`), and (piece-wise kernel) the
#: rows split into parts at listener captures ``row_captures[n, 0]`` ..
#: ``row_captures[n, 1] - 1`` on the listener's line of each capture interval j, row
#: j + 1 of ``interval_lines (M+1, 9)``.
KnotRows = namedtuple(
    "KnotRows", ["knot_times", "n_lo", "n_hi", "row_lines", "row_captures", "interval_lines"]
)
#: Where the tasks sum: the accumulator ``acc`` holding every task's window, task j's
#: at ``task_blk[j]`` = (first block, blocks, offset in ``acc``, first sample it
#: emits at; blocks of ``2**shift`` samples, ``n_ch`` channels), their capture tables
#: ``capture_sums (n_tasks, R·n_ch·4)`` for captures ``first_capture`` .. ``+ R - 1``,
#: and the output's length, first time and samples per data second.
Accumulator = namedtuple(
    "Accumulator",
    [
        "acc",
        "task_blk",
        "capture_sums",
        "first_capture",
        "shift",
        "n_samples",
        "t_start",
        "fs",
        "n_ch",
    ],
)


@intrinsic
def where(typingctx, cond, a, b):
    """``a if cond else b`` for scalars, both evaluated, no branch: one instruction
    (LLVM's ``select``) where the conditional expression is three blocks of numba IR and
    a variable assigned twice, which numba's compiler passes pay for in every inlined
    copy (the compiled loops are the same: LLVM turns those blocks into the select).
    Not in code compiled with FMA contraction whose results must stay bit for bit:
    there a select of a computed operand can change which multiply-adds LLVM fuses
    (see :mod:`auralize.emitters._kernels.hermite`)."""
    res = typingctx.unify_pairs(a, b)
    if res is None or not isinstance(res, types.Number | types.Boolean):
        return None

    def codegen(context, builder, signature, args):
        c, x, y = args
        c = context.cast(builder, c, signature.args[0], types.boolean)
        x = context.cast(builder, x, signature.args[1], res)
        y = context.cast(builder, y, signature.args[2], res)
        return builder.select(c, x, y)

    return res(cond, a, b), codegen


@numba.njit(inline="always", **_NJIT)
def lane_grid(c0, win):
    """The :class:`LaneGrid` of window ``win`` (a :class:`Window`)."""
    fblock = float(1 << win.shift)
    return LaneGrid(
        c0,
        1.0 / c0,
        win.t_start,
        win.fs,
        1.0 / win.fs,
        float(win.n_samples),
        fblock,
        1.0 / fblock,
        win.blo,
        win.nb,
        win.base,
        4.0 * win.n_ch,
    )


@numba.njit(inline="always", **_NJIT)
def _inverses(a, b, c):
    """1/a, 1/b and 1/c with one division."""
    r = 1.0 / (a * b * c)
    return b * c * r, a * c * r, a * b * r
