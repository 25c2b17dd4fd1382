"""Compiled core of the retarded-time synthesis (see :mod:`auralize.emitters.synthesis`).

Why numba: the work is a few hundred floating-point operations per (source,
step) piece with data-dependent control (pieces across listener captures or
accumulation blocks, panning pairs) that numpy cannot express without
materialising sources × samples arrays; numba compiles the loops to SIMD code.

The signal of one source between the arrivals of two consecutive knots
(data steps) is a smooth function f(t) = q(τ(t)) / D(t) with τ(t) = t - D(t)/c0
(paper 003 Eqs. 15-17).  It is represented on each piece by the cubic Hermite
interpolant of f and f' at the piece's ends, which is exact for a static
listener (q is a cubic in τ, τ is linear in t) and accurate to O(h⁴) otherwise.
The cubic is written in the binomial basis C(m - m0, i) at its first sample
m0; C(m - m0, i)·H(m - m0) is the (i+1)-fold cumulative sum of an impulse at
m0 + i, so a piece costs 4 impulses at its start and 4 (of the polynomial
continued, subtracted) at its end, whatever its length.  Four cumulative sums
per accumulation block then give the summed signal.  Cost:
O(sounding pieces + samples), not O(sources × samples).

The modules, by stage (each imports only those above it):

:mod:`~auralize.emitters._kernels.common`
    numba options, the chunk width, the rows of the work arrays (declared
    once, as lists: :data:`~auralize.emitters._kernels.common.WORK_ROWS`,
    :data:`~auralize.emitters._kernels.common.RUN_ROWS`) and the kinds of a
    piece (``KIND_*``);
:mod:`~auralize.emitters._kernels.arrivals`
    arrivals and retarded time on the listener's path, per emission and per
    knot row (the listener's candidate lines);
:mod:`~auralize.emitters._kernels.hermite`
    the Hermite pieces of q and f and their accumulator values;
:mod:`~auralize.emitters._kernels.gains`, :mod:`~auralize.emitters._kernels.lane_gains`
    panning laws for one direction, and over a chunk's lanes;
:mod:`~auralize.emitters._kernels.accumulate`
    emissions into the skewed accumulator, the scatter from the work array,
    the capture table, the integration into the output;
:mod:`~auralize.emitters._kernels.pieces`, :mod:`~auralize.emitters._kernels.parts`
    pieces per chunk (SIMD), pieces split at captures (scalar), and parts
    (pieces split at captures, SIMD);
:mod:`~auralize.emitters._kernels.render_pieces`, :mod:`~auralize.emitters._kernels.render_runs`
    the two task kernels (``render_task``, one task per thread): piece by
    piece, and by runs of pieces sharing their knots (unpanned and AmbiX);
:mod:`~auralize.emitters._kernels.tables`
    the piece and run tables they read;
:mod:`~auralize.emitters._kernels.sampled`, :mod:`~auralize.emitters._kernels.emission`
    the emitters engine's sampled backend (audio-rate point emitters, see
    :mod:`auralize.emitters._sampled`): control points, and the emitted signals
    read along the pieces between them.

Arguments travel in named bundles (named tuples of
:mod:`~auralize.emitters._kernels.common`: ``Listener``, ``Panning``,
``Window``, ``PieceTable`` ...): numba passes a bundle's fields as it would
the separate arguments, so they cost nothing at run time.  The kernels
compile once each (one specialization: :func:`auralize.runtime.jit.kernel_args`);
what is compiled into a kernel several times (helpers marked
``inline="always"``, expanded at every call) is what the SIMD loops need
inline, and branch-free selects use
:func:`~auralize.emitters._kernels.common.where`; the rarely taken, longer
paths are compiled once and called.

Layout of the work:

* the sounding pieces are listed once per tracks (cached), sorted by data
  step, in chunks of :data:`~auralize.emitters._kernels.common._CHUNK` whose
  inputs (position, clamp radius, q and dq/dτ at both knots) are contiguous;
* per chunk, branch-free loops that LLVM vectorizes solve both knots'
  arrivals in closed form on the listener's candidate lines of that step,
  the values and slopes of f, the Hermite cubic and its accumulator values
  at its start, end and (across an accumulation block) continuation; for
  ring layouts also the speaker-pair gains; all in one 1-D work array whose
  rows lie at constant distances, so the compiler needs no aliasing checks;
* a scalar loop adds the values to the accumulator; pieces across listener
  captures (the velocity, hence df/dt, jumps there) are split exactly,
  arrivals beyond the candidate lines are solved in full; the emissions at a
  capture of all the pieces split there fall on one sample with one offset,
  so they are summed in a small per-task table (a row per capture, in cache)
  and added to the accumulator once;
* a step whose arrivals may cross listener captures (a path recorded at
  10-20 Hz: most of them) is split there into parts, one per capture
  interval, each on the listener's line of its interval, and the parts are
  summed like pieces, in SIMD loops; the scalar split above remains for
  steps that cross very many captures;
* the accumulator is skewed (level j of an impulse at m + j is stored in row
  m, so an emission touches one 32-byte row) with the channels of a sample
  side by side; threads take contiguous ranges of pieces and accumulate into
  their own stretch of the output only.

Argument names shared by the kernels (all times in data seconds):
``listener_times (M,)``, ``listener_pos (M, 3)``, ``listener_vel (M-1, 3)``
the listener's captures and its velocity on each interval;
``orient_table (N, 6)`` its forward and up sampled from ``orient_clock[0]``
at rate ``orient_clock[1]``; ``fs`` output samples per data second;
``2**shift`` samples per accumulation block; ``acc`` the accumulator, a
task's window of it at offset ``base`` holding blocks ``blo .. blo + nb - 1``;
``capture_sums`` the per-task capture table, its row r for capture
``first_capture + r``; ``work`` a work array (rows
:data:`~auralize.emitters._kernels.common.ROW`).
"""
