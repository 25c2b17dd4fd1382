"""Asynchronous generation and continuous discharges (paper 002 §4.2.1, §4.2.4).

:class:`LiveDischarges` computes a discharge's waveform on a worker thread
and mixes it into a live output stream at its arrival time (§4.2.1); the
arrival times, distances and panning gains of its segments are the engine's
(:func:`auralize_spark.waves.emissions` takes them from
:func:`auralize.emitters.events.arrivals`).  The
stream is pulled by the audio callback (:meth:`LiveDischarges.pull`), which
never blocks on the computation.  When the computation finishes after the
first wave should already have arrived (the propagation delay r_min/c is
shorter than the computation), the paper computes the waveform completely
anyway and accepts the delay; here the whole waveform is shifted later by the
overrun and the :class:`Delivery` report says so (``late_s > 0``).

:func:`continuous_discharges` repeats a discharge's waveform at intervals of
10–50 ms (§4.2.4, the plasma ball) while the charge distribution changes
little, and regenerates the field, pattern and waveform when it changes
beyond a threshold.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.spatial.layouts import Layout, get_layout, output_stage, receiver_paths

from .leader import Discharge
from .waves import WaveParams, accumulate, emissions


@dataclass
class Delivery:
    """What happened to one submitted discharge (times in stream seconds).

    ``compute_s``: wall time of the waveform computation; ``propagation_s``:
    delay of the first wave, r_min/c; ``late_s``: how much later than
    physically due the sound was delivered (0 when the computation beat the
    propagation delay); ``start_sample``: where the waveform went in the stream.
    """

    t_discharge: float
    compute_s: float
    propagation_s: float
    late_s: float
    start_sample: int
    n_samples: int
    segments: int

    @property
    def exceeded(self) -> bool:
        """The computation took longer than the propagation delay (§4.2.1)."""
        return self.late_s > 0


class LiveDischarges:
    """Live output of discharge sounds generated on a worker thread (§4.2.1).

    Parameters
    ----------
    listener : (3,) m, static listener position, or a ListenerPath whose
        playback time is the stream time (arrivals are the exact retarded
        times along it).
    params : WaveParams of the discharges.
    rate : Hz; layout : output layout (``binaural`` too: each ear a receiver).
    capacity_s : length of the ring buffer in seconds (sound due further
        ahead than this is dropped).
    clock : callable returning seconds (default: :func:`time.perf_counter`);
        stream time 0 is the clock's value at construction.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize_spark.waves import WaveParams
    >>> d = Discharge(np.array([[0.0, 0, 0], [0.002, 0, 0]]), [-1, 0], [True, True])
    >>> with LiveDischarges(np.array([0.0, 1000.0, 0.0]),  # the sound is due after 2.9 s
    ...                     params=WaveParams(r0=0.05, T0=30e-6, ps0=500.0)) as live:
    ...     report = live.submit(d).result()
    >>> report.exceeded
    False
    """

    def __init__(
        self,
        listener: ListenerPath | NDArray[np.floating],
        *,
        params: WaveParams,
        rate: int = 44100,
        layout: str | Layout = "mono",
        capacity_s: float = 60.0,
        clock: Callable[[], float] | None = None,
    ) -> None:
        self.listener: ListenerPath | NDArray[np.float64] = (
            listener
            if isinstance(listener, ListenerPath)
            else np.asarray(listener, dtype=np.float64).reshape(3)
        )
        self.params = params
        self.rate = int(rate)
        # binaural: the waves are mixed in the ears' channels (each ear a receiver
        # with its own arrivals), and pull() filters them with the ears' stage
        self.stage = output_stage(get_layout(layout), self.rate)
        self.layout = self.stage.layout
        syn = self.stage.synthesis_layout
        if syn.meta.get("receivers"):
            path = (
                self.listener
                if isinstance(self.listener, ListenerPath)
                else ListenerPath(np.zeros(1), self.listener.reshape(1, 3))
            )
            self._receivers: list[tuple[Layout, Any]] = receiver_paths(syn, path)
        else:
            self._receivers = [(syn, self.listener)]
        if not capacity_s > 0:
            raise ParameterError(f"capacity_s must be > 0, got {capacity_s!r}")
        self._buf = np.zeros((syn.n_channels, int(math.ceil(capacity_s * self.rate))))
        self._read = 0  # absolute index of the next sample to pull (ring buffer)
        self._lock = threading.Lock()
        self._clock = clock or time.perf_counter
        self._t0 = self._clock()
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="auralize-spark")
        self.deliveries: list[Delivery] = []
        self._seq = 0

    # ------------------------------------------------------------------ time
    def now(self) -> float:
        """Stream time in seconds."""
        return self._clock() - self._t0

    # ------------------------------------------------------------ producers
    def submit(
        self,
        discharge: Discharge,
        *,
        at: float | None = None,
        strokes: NDArray[np.floating] | None = None,
    ) -> Future[Delivery]:
        """Generate ``discharge``'s sound on the worker thread; returns a Future of its Delivery.

        ``at`` is the stream time of the discharge (default: now).
        """
        t_d = self.now() if at is None else float(at)
        seed = self._seq
        self._seq += 1
        st = np.zeros(1) if strokes is None else np.asarray(strokes, dtype=np.float64)
        return self._pool.submit(self._work, discharge, t_d, st, seed)

    def _work(
        self, discharge: Discharge, t_d: float, strokes: NDArray[np.float64], seed: int
    ) -> Delivery:
        t_start = self._clock()
        # one set of emissions per receiver (the same seed: the same discharge)
        ems = [
            emissions(
                discharge,
                lis,
                params=self.params,
                strokes=strokes,
                layout=lay,
                t0=t_d,
                rng=np.random.default_rng(seed),
            )
            for lay, lis in self._receivers
        ]
        # stream time at which the first wave arrives
        due = max(min(em.start_time for em in ems), t_d)
        first = due - t_d
        n = int(math.ceil((max(em.end_time for em in ems) - due) * self.rate)) + 2
        waves = []
        for (lay, _), em in zip(self._receivers, ems, strict=True):
            em.t_center = em.t_center - due  # waveform relative to its first sample
            waves.append(accumulate(em, lay.n_channels, n, rate=self.rate, c=self.params.c))
        wave = np.concatenate(waves)
        t_done = self._clock()
        compute = t_done - t_start
        late = max(0.0, (t_done - self._t0) - due)
        start = int(round((due + late) * self.rate))
        with self._lock:
            if start < self._read:  # the reader already passed: deliver from now on
                late += (self._read - start) / self.rate
                start = self._read
            self._mix(wave, start)
        rep = Delivery(t_d, compute, first, late, start, n, discharge.n_segments)
        self.deliveries.append(rep)
        return rep

    # ------------------------------------------------------------- consumer
    def pull(self, n_frames: int) -> NDArray[np.float64]:
        """The next ``n_frames`` samples of the stream ``(n_channels, n_frames)`` of
        :attr:`layout` (never blocks on work; binaural: through the ears' filters,
        whose state carries from pull to pull)."""
        n = int(n_frames)
        cap = self._buf.shape[1]
        with self._lock:
            idx = (self._read + np.arange(n)) % cap
            out = self._buf[:, idx]
            if n > cap:  # frames beyond the capacity are silent
                out[:, cap:] = 0.0
            self._buf[:, idx] = 0.0
            self._read += n
        return self.stage.process(out)

    def _mix(self, wave: NDArray[np.float64], start: int) -> None:
        """Add ``wave`` at absolute sample ``start`` (caller holds the lock); beyond capacity is dropped."""
        cap = self._buf.shape[1]
        n = min(wave.shape[1], self._read + cap - start)
        if n <= 0:
            return
        idx = (start + np.arange(n)) % cap
        self._buf[:, idx] += wave[:, :n]

    def close(self) -> None:
        """Wait for pending work and stop the worker thread."""
        self._pool.shutdown(wait=True)

    def __enter__(self) -> LiveDischarges:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# --------------------------------------------------------------- §4.2.4
@dataclass
class ContinuousResult:
    """Audio of a continuous discharge and which repetitions were regenerated."""

    audio: NDArray[np.float64]
    rate: int
    times: NDArray[np.float64]
    regenerated: NDArray[np.bool_]
    meta: dict[str, Any] = field(default_factory=dict)


def continuous_discharges(
    make_waveform: Callable[[int], NDArray[np.float64]],
    state: Callable[[float], NDArray[np.floating]],
    *,
    duration: float,
    rate: int = 44100,
    interval_s: tuple[float, float] = (0.010, 0.050),
    threshold: float = 0.05,
    seed: int = 0,
) -> ContinuousResult:
    """Repeat a discharge waveform while the field changes little (paper 002 §4.2.4).

    Parameters
    ----------
    make_waveform : ``f(k) -> (n_channels, n)`` waveform of a discharge (k
        counts regenerations, use it as a seed); called at the start and when
        the state has changed by more than ``threshold``.
    state : ``g(t) -> array`` the charge distribution at time t (s), compared
        with the state at the last regeneration by the relative L2 change
        ``‖g(t) − g_ref‖ / ‖g_ref‖``.
    duration : s of output.  interval_s : (min, max) s between discharges
        (uniform; the paper's plasma ball: 10–50 ms).
    threshold : relative change that triggers a regeneration.
    seed : seeds the intervals.

    Returns
    -------
    ContinuousResult with the audio, the discharge times and which ones were
    regenerated (the others reuse the last waveform).
    """
    lo, hi = interval_s
    if not 0 < lo <= hi:
        raise ParameterError(f"interval_s must be 0 < min <= max seconds, got {interval_s!r}")
    if not duration > 0:
        raise ParameterError(f"duration must be > 0 s, got {duration!r}")
    if not threshold >= 0:
        raise ParameterError(f"threshold must be >= 0, got {threshold!r}")
    rng = np.random.default_rng(seed)
    times = [0.0]
    while True:
        t = times[-1] + rng.uniform(lo, hi)
        if t >= duration:
            break
        times.append(t)
    n_out = int(math.ceil(duration * rate))
    ref = np.asarray(state(0.0), dtype=np.float64)
    k = 0
    wave = np.asarray(make_waveform(k), dtype=np.float64)
    out = np.zeros((wave.shape[0], n_out))
    regen = []
    for t in times:
        cur = np.asarray(state(t), dtype=np.float64)
        denom = float(np.linalg.norm(ref)) or 1.0
        changed = float(np.linalg.norm(cur - ref)) / denom > threshold
        if changed:
            k += 1
            wave = np.asarray(make_waveform(k), dtype=np.float64)
            ref = cur
        regen.append(t == 0.0 or changed)
        a = int(round(t * rate))
        b = min(n_out, a + wave.shape[1])
        out[:, a:b] += wave[:, : b - a]
    return ContinuousResult(
        out,
        int(rate),
        np.asarray(times),
        np.asarray(regen),
        {"discharges": len(times), "regenerated": int(np.sum(regen))},
    )
