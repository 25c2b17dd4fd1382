"""Live playback: synthesis block by block, ahead of the sound device's callback.

Three parts:

:class:`BlockSynth`
    Renders any block of samples of the sound along a listener path with the
    core synthesis (:func:`auralize.emitters.synthesis.render_tracks` with ``start=``), which
    reads only the data steps whose emissions can arrive inside the block
    (largest source-listener distance / c0 before it).  The result equals the
    offline render sample for sample (up to rounding) at a cost that does not
    grow with the length of the data: no whole-file precompute.
    :meth:`BlockSynth.window` cuts the tracks down to what a block can hear
    (for shipping a block's work elsewhere).
:class:`LiveStream`
    A push stream over sounddevice's callback API: :meth:`LiveStream.write`
    queues ``(n_channels, n)`` blocks (blocking while the queue is full), the
    PortAudio callback pulls them.  When the queue is empty the callback
    waits at most ``wait_s`` (default half a block) for the producer, then
    plays silence and counts an **underrun** (with its playback time);
    PortAudio's own output-underflow flags are counted separately.  The
    bounded wait is what lets an unpaced device (ALSA ``null``/``file``
    plugins, which call back as fast as they are fed) keep up with a producer
    that is faster than real time; on a sound card the queue is normally full
    and the callback never waits.
:func:`play`
    Renders on a worker thread into a :class:`LiveStream` and returns a
    :class:`PlaybackReport` (per-block synthesis times, underruns, gain).

Arrays are ``(n_channels, n_samples)``; they are transposed only in the
callback.  sounddevice is imported inside :class:`LiveStream` only.

Examples
--------
Blocks of a render, without a device (:func:`play` feeds them to one):

>>> from auralize.listener import ListenerPath
>>> from auralize.pipeline import detect_sources, load
>>> vol = load("dataset:monopole", size=12, steps=60)
>>> tracks = detect_sources(vol).tracks()
>>> path = ListenerPath.point(vol.center + [1.0, 0, 0], duration=0.1)
>>> bs = BlockSynth(tracks, path, layout="ring8", block=2205)
>>> bs.block(0).shape
(8, 2205)
"""

from __future__ import annotations

import math
import os
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.emitters.synthesis import C0, render_tracks
from auralize.errors import DeviceError, ParameterError
from auralize.listener import ListenerPath
from auralize.sources.detection import SourceTracks
from auralize.spatial.layouts import (
    Layout,
    SpeakerAlignment,
    downmix_matrix,
    downmix_target,
    get_layout,
    output_stage,
)

#: default block length in seconds (the 50 ms budget of a block's synthesis)
DEFAULT_BLOCK_S = 0.05
PEAK_LEVEL = 0.99


class BlockSynth:
    """Block-wise synthesis of the sound along ``path``.

    Parameters
    ----------
    tracks : SourceTracks
    path : ListenerPath
    rate : int
        Sample rate in Hz.
    layout : str or Layout
    time_scale : float
        Playback seconds per data second.
    interp : {"cubic", "linear"}
    c0 : float
        Speed of sound (m/s).
    block : int, optional
        Samples per block (default 50 ms).
    duration : float, optional
        Playback seconds (default: the path's duration).
    threads : int, optional
        Threads of the synthesis kernel.
    hrtf : HRIRSet, str or Path, optional
        ``binaural`` only: the HRIRs (default the built-in spherical head).  A
        binaural stream is synthesized in its AmbiX intermediate and filtered
        by one :class:`auralize.spatial.layouts.OutputStage` that carries its state
        from block to block, so consecutive blocks equal one offline render.
    """

    def __init__(
        self,
        tracks: SourceTracks,
        path: ListenerPath,
        *,
        rate: int = 44100,
        layout: str | Layout = "ring8",
        time_scale: float = 1.0,
        interp: str = "cubic",
        c0: float = C0,
        block: int | None = None,
        duration: float | None = None,
        threads: int | None = None,
        lead: float = 0.0,
        hrtf: object = None,
    ) -> None:
        if not (isinstance(rate, int | np.integer) and rate > 0):
            raise ParameterError(f"rate must be a positive integer number of Hz, got {rate!r}")
        if not (math.isfinite(time_scale) and time_scale > 0):
            raise ParameterError(
                f"time_scale must be > 0 (playback s per data s), got {time_scale!r}"
            )
        if not (math.isfinite(lead) and lead >= 0):
            raise ParameterError(f"lead must be >= 0 data seconds, got {lead!r}")
        self.tracks, self.path, self.lead = tracks, path, float(lead)
        self.rate, self.time_scale, self.interp, self.c0 = int(rate), float(time_scale), interp, c0
        self.stage = output_stage(layout, int(rate), hrtf=hrtf)
        self.layout = self.stage.layout
        self.synthesis_layout = self.stage.synthesis_layout
        self.threads = threads
        self.block_size = int(block) if block is not None else round(DEFAULT_BLOCK_S * rate)
        if self.block_size < 1:
            raise ParameterError(f"block must be >= 1 sample, got {block!r}")
        dur = path.duration if duration is None else float(duration)
        if not (math.isfinite(dur) and dur > 0):
            raise ParameterError(
                f"nothing to play: duration {dur!r} s (path of one capture? give a duration)"
            )
        self.duration = dur
        self.n_samples = round(dur * rate)
        self.n_blocks = -(-self.n_samples // self.block_size)
        self._t0 = tracks.t_first + self.lead
        q = np.asarray(tracks.q)
        nz = q != 0
        has = nz.any(axis=1)
        self._first = np.where(has, np.argmax(nz, axis=1), q.shape[1])
        self._last = np.where(has, q.shape[1] - 1 - np.argmax(nz[:, ::-1], axis=1), -1)
        pos = np.asarray(tracks.positions, dtype=np.float64).reshape(-1, 3)
        if pos.shape[0]:
            lo, hi = pos.min(axis=0), pos.max(axis=0)
            far = np.maximum(np.abs(path.positions - lo), np.abs(path.positions - hi))
            self._d_max = float(np.max(np.linalg.norm(far, axis=1))) + float(
                np.max(tracks.radius, initial=0.0)
            )
        else:
            self._d_max = 0.0

    def window(self, start: int, n: int) -> SourceTracks:
        """The tracks restricted to what samples ``[start, start + n)`` can hear."""
        tr = self.tracks
        times = tr.times
        fs = self.rate * self.time_scale
        t_start = self._t0 + start / fs
        t_end = self._t0 + (start + n) / fs
        i_lo = int(np.searchsorted(times, t_start - self._d_max / self.c0, side="right")) - 1
        i_hi = int(np.searchsorted(times, t_end, side="right"))
        a = max(i_lo - 2, 0)
        b = min(i_hi + 2, times.size - 1)
        rows = np.flatnonzero((self._first <= b) & (self._last >= a))
        qw = tr.q[rows, a : b + 1]
        tw = times[a : b + 1]
        pos = tr.positions[rows]
        # per source: only the knots it can be heard from in this window (its
        # distance to the listener is bounded by a sphere around the listener's
        # positions during the window); 2 knots of margin keep the tangents exact
        tp = self.path.times[0] + np.array([start, start + n]) / self.rate
        inner = self.path.times[(self.path.times > tp[0]) & (self.path.times < tp[1])]
        lp = self.path.position_at(np.concatenate([tp, inner]))
        centre = 0.5 * (lp.min(axis=0) + lp.max(axis=0))
        spread = float(np.max(np.linalg.norm(lp - centre, axis=1)))
        dc = np.linalg.norm(pos - centre, axis=1)
        d_hi = dc + spread + tr.radius[rows]
        d_lo = np.maximum(dc - spread, 0.0)
        lo_k = np.searchsorted(tw, t_start - d_hi / self.c0, side="right") - 3
        hi_k = np.searchsorted(tw, t_end - d_lo / self.c0, side="right") + 2
        j = np.arange(tw.size)
        qw = np.where((j >= lo_k[:, None]) & (j <= hi_k[:, None]), qw, 0.0)
        if a > 0:  # keep the data's first time (the time origin) as a silent knot
            tw = np.concatenate([times[:1], tw])
            qw = np.concatenate([np.zeros((rows.size, 1)), qw], axis=1)
        return SourceTracks(
            pos, np.ascontiguousarray(qw), tr.radius[rows], tw, origin=tr.t_first, end=tr.t_last
        )

    def render_range(self, start: int, n: int) -> NDArray[np.float64]:
        """Samples ``[start, start + n)`` as ``(n_channels, n)`` pascals.

        The synthesis reads only the data steps whose emissions can arrive in
        the range (its pieces are cached on the tracks at the first call), so
        a block costs what its own sources cost, however long the data.
        Channels of :attr:`layout` (for ``binaural`` consecutive ranges are
        cheapest: the ear filters' state is carried, not rebuilt).
        """
        if n <= 0:
            return np.zeros((self.layout.n_channels, 0))
        return self.stage.process_at(int(start), int(n), self._synthesize)

    def _synthesize(self, start: int, n: int) -> NDArray[np.float64]:
        """Samples ``[start, start + n)`` of the :attr:`synthesis_layout`."""
        out = render_tracks(
            self.tracks,
            self.path,
            rate=self.rate,
            time_scale=self.time_scale,
            interp=self.interp,
            layout=self.synthesis_layout,
            c0=self.c0,
            start=start / self.rate,
            duration=n / self.rate,
            threads=self.threads,
            lead=self.lead,
        )
        a = out.audio
        if a.shape[1] != n:  # rounding of duration·rate; never more than a sample
            a = np.pad(a, ((0, 0), (0, max(n - a.shape[1], 0))))[:, :n]
        return a

    def block(self, i: int) -> NDArray[np.float64]:
        """Block ``i`` (the last one may be shorter)."""
        if not 0 <= i < self.n_blocks:
            raise ParameterError(f"block index {i} outside 0..{self.n_blocks - 1}")
        s = i * self.block_size
        return self.render_range(s, min(self.block_size, self.n_samples - s))


@dataclass
class StreamStats:
    """What a :class:`LiveStream` did: frames played, underruns and when."""

    frames: int = 0
    callbacks: int = 0
    underruns: int = 0
    underrun_times: list[float] = field(default_factory=list)
    device_underflows: int = 0
    waited_s: float = 0.0


class LiveStream:
    """Push ``(n_channels, n)`` float blocks to a sound device (sounddevice callback API).

    Parameters
    ----------
    rate : int
        Sample rate in Hz.
    channels : int
        Channels to open on the device.
    device : int, str or None
        See :func:`auralize.audio.output.choose_output_device`.
    block : int, optional
        PortAudio callback size in frames (default 0: PortAudio's choice).
    buffer_s : float
        Most audio queued ahead of the device; :meth:`write` blocks beyond.
    prefill_s : float
        Audio queued before the device is started (so it does not start on an
        empty queue).
    wait_s : float, optional
        Longest wait of the callback for a late block before it plays silence
        and counts an underrun (default: ``$AURALIZE_LIVE_WAIT_S`` seconds when
        set — a device that is a file, not a clock, can wait for any producer —
        else half the callback period, 10 ms when
        the period is not fixed).
    latency : str or float
        PortAudio latency (``"high"`` for robustness).
    stall_s : float
        :meth:`write` raises :class:`DeviceError` when the device has not
        called back for this long while the queue is full.
    """

    def __init__(
        self,
        *,
        rate: int,
        channels: int,
        device: int | str | None = None,
        block: int = 0,
        buffer_s: float = 0.5,
        prefill_s: float = 0.2,
        wait_s: float | None = None,
        latency: str | float = "high",
        stall_s: float = 5.0,
    ) -> None:
        from auralize.audio.output import choose_output_device, import_sounddevice

        if channels < 1:
            raise ParameterError(f"channels must be >= 1, got {channels!r}")
        self.rate, self.channels = int(rate), int(channels)
        self.device = choose_output_device(device, self.channels)
        self._sd = import_sounddevice()
        self._cond = threading.Condition()
        self._chunks: deque[NDArray[np.float32]] = deque()
        self._offset = 0
        self._queued = 0
        self._capacity = max(int(buffer_s * rate), 1)
        self._prefill = max(int(prefill_s * rate), 1)
        if wait_s is None and os.environ.get("AURALIZE_LIVE_WAIT_S"):
            wait_s = _env_seconds("AURALIZE_LIVE_WAIT_S")
        self._wait = (0.5 * block / rate if block else 0.010) if wait_s is None else float(wait_s)
        self._closing = False
        self._started = False
        self._done = threading.Event()
        self._last_callback = time.perf_counter()
        self._stall_s = float(stall_s)
        self.stats = StreamStats()
        try:
            self._stream = self._sd.OutputStream(
                samplerate=self.rate,
                channels=self.channels,
                device=self.device["index"],
                dtype="float32",
                blocksize=int(block),
                latency=latency,
                callback=self._callback,
                finished_callback=self._done.set,
            )
        except self._sd.PortAudioError as exc:
            raise DeviceError(
                f"cannot open device {self.device['index']} ({self.device['name']}) with "
                f"{self.channels} channels at {self.rate} Hz: {exc}"
            ) from None

    # ---------------------------------------------------------------- producer
    def write(self, block: NDArray[np.floating]) -> None:
        """Queue ``block (channels, n)``; blocks while ``buffer_s`` is queued."""
        b = np.asarray(block)
        if b.ndim != 2 or b.shape[0] != self.channels:
            raise ParameterError(f"block must be ({self.channels}, n), got shape {b.shape}")
        if not np.all(np.isfinite(b)):
            raise ParameterError("block contains NaN or Inf; refusing to play it")
        data = np.ascontiguousarray(b.T, dtype=np.float32)
        with self._cond:
            if self._closing:
                raise DeviceError("write after close")
            while self._queued >= self._capacity and self._started and not self._done.is_set():
                self._cond.wait(0.1)
                idle = time.perf_counter() - self._last_callback
                if idle > self._stall_s:
                    raise DeviceError(
                        f"device {self.device['name']!r} stopped asking for audio ({idle:.1f} s "
                        f"without a callback); check the device, or write a file with -o"
                    )
            if self._done.is_set():
                raise DeviceError(f"the stream on {self.device['name']!r} stopped")
            self._chunks.append(data)
            self._queued += data.shape[0]
            self._cond.notify_all()
            start = not self._started and self._queued >= self._prefill
        if start:
            self._start()

    def _start(self) -> None:
        self._started = True
        self._last_callback = time.perf_counter()
        self._stream.start()

    def close(self, *, drain: bool = True, timeout: float | None = None) -> StreamStats:
        """Play what is queued (``drain``) and close the device; returns :attr:`stats`."""
        with self._cond:
            self._closing = True
            queued = self._queued
            self._cond.notify_all()
        try:
            if drain and queued and not self._started:
                self._start()
            if self._started and drain:
                limit = timeout if timeout is not None else queued / self.rate + 5.0
                if not self._done.wait(limit):
                    raise DeviceError(
                        f"device {self.device['name']!r} did not finish playing within {limit:.1f} s"
                    )
        finally:
            if self._started:
                self._stream.abort() if not drain else self._stream.stop()
            self._stream.close()
        return self.stats

    def __enter__(self) -> LiveStream:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close(drain=exc[0] is None)

    # ---------------------------------------------------------------- consumer
    def _callback(self, outdata: Any, frames: int, time_info: Any, status: Any) -> None:
        st = self.stats
        st.callbacks += 1
        self._last_callback = time.perf_counter()
        if status.output_underflow:
            st.device_underflows += 1
        filled = 0
        ended = False
        with self._cond:
            deadline = None
            while filled < frames:
                if not self._chunks:
                    if self._closing:
                        ended = True
                        break
                    now = time.perf_counter()
                    if deadline is None:
                        deadline = now + self._wait
                    if now >= deadline:
                        break
                    self._cond.wait(deadline - now)
                    continue
                chunk = self._chunks[0]
                take = min(frames - filled, chunk.shape[0] - self._offset)
                outdata[filled : filled + take] = chunk[self._offset : self._offset + take]
                filled += take
                self._offset += take
                if self._offset == chunk.shape[0]:
                    self._chunks.popleft()
                    self._offset = 0
            self._queued -= filled
            self._cond.notify_all()
        if deadline is not None:
            st.waited_s += max(time.perf_counter() - deadline + self._wait, 0.0)
        if filled < frames:
            outdata[filled:] = 0.0
            if ended:
                st.frames += filled
                raise self._sd.CallbackStop
            st.underruns += 1
            st.underrun_times.append(st.frames / self.rate)
        st.frames += frames


def _env_seconds(name: str) -> float:
    """A duration in seconds from the environment variable ``name`` (>= 0)."""
    text = os.environ.get(name, "")
    try:
        v = float(text)
    except ValueError:
        raise ParameterError(f"{name}={text!r}: give a number of seconds") from None
    if not (math.isfinite(v) and v >= 0):
        raise ParameterError(f"{name}={text!r}: give a number of seconds >= 0")
    return v


def open_stream(
    *, rate: int, channels: int, device: int | str | None = None, **kw: Any
) -> LiveStream:
    """A :class:`LiveStream` (``write(block)``, ``close()``) on ``device``."""
    return LiveStream(rate=rate, channels=channels, device=device, **kw)


@dataclass
class PlaybackReport:
    """Outcome of :func:`play`."""

    device: str
    layout: str
    output_layout: str
    channels: int
    rate: int
    duration_s: float
    blocks: int
    block_s: float
    synth_ms_mean: float
    synth_ms_p95: float
    synth_ms_max: float
    underruns: int
    underrun_times: list[float]
    device_underflows: int
    gain: float
    gain_changes: int
    wall_s: float

    @property
    def budget_ok(self) -> bool:
        """Every block synthesized within its own duration."""
        return self.synth_ms_max <= 1e3 * self.block_s

    def summary(self) -> str:
        lines = [
            f"played {self.duration_s:.2f} s on {self.device!r}: {self.layout}"
            + (f" folded to {self.output_layout}" if self.output_layout != self.layout else "")
            + f", {self.channels} ch at {self.rate} Hz, {self.blocks} blocks of "
            f"{1e3 * self.block_s:.0f} ms in {self.wall_s:.2f} s",
            f"synthesis per block: mean {self.synth_ms_mean:.1f} ms, 95% {self.synth_ms_p95:.1f} "
            f"ms, max {self.synth_ms_max:.1f} ms (budget {1e3 * self.block_s:.0f} ms)",
            f"underruns: {self.underruns}"
            + (
                f" at {', '.join(f'{t:.2f}' for t in self.underrun_times[:8])} s"
                if self.underruns
                else ""
            )
            + f"; device underflows: {self.device_underflows}",
            f"gain {self.gain:.4g} full scale per Pa"
            + (f" (lowered {self.gain_changes}× to avoid clipping)" if self.gain_changes else ""),
        ]
        return "\n".join(lines)

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _check_play_options(block_s: float, gain: float | str, highpass_hz: float, rate: int) -> None:
    """Raise :class:`ParameterError` for a block length, gain or high-pass ``play`` refuses."""
    if not (math.isfinite(block_s) and block_s > 0):
        raise ParameterError(f"block_s must be > 0 seconds, got {block_s!r}")
    if gain != "auto" and not (isinstance(gain, int | float) and math.isfinite(gain) and gain > 0):
        raise ParameterError(f"gain must be 'auto' or a positive number, got {gain!r}")
    if not (math.isfinite(highpass_hz) and 0 <= highpass_hz < rate / 2):
        raise ParameterError(
            f"highpass must be 0 (off) or between 0 and {rate / 2:g} Hz, got {highpass_hz!r}"
        )


def _output_layout(lay: Layout, dev: dict[str, Any], downmix: bool | str | Layout) -> Layout:
    """The layout sent to device ``dev``: ``lay`` itself, the layout ``downmix`` names, or
    (``downmix=True``) the largest built-in one the device's channels hold."""
    if isinstance(downmix, str | Layout) and not isinstance(downmix, bool):
        out_lay = get_layout(downmix)
        if out_lay.n_channels > dev["max_output_channels"]:
            raise DeviceError(
                f"device {dev['name']!r} has {dev['max_output_channels']} channels; "
                f"layout {out_lay.name!r} needs {out_lay.n_channels}"
            )
        return out_lay
    if downmix and dev["max_output_channels"] < lay.n_channels:
        return downmix_target(lay, dev["max_output_channels"])
    return lay


def play(  # noqa: PLR0913 (keyword-only options)
    tracks: SourceTracks | Any,
    path: ListenerPath,
    *,
    rate: int = 44100,
    layout: str | Layout = "ring8",
    device: int | str | None = None,
    time_scale: float = 1.0,
    interp: str = "cubic",
    c0: float = C0,
    downmix: bool | str | Layout = False,
    gain: float | str = "auto",
    limit_pa: float | None = None,
    block_s: float = DEFAULT_BLOCK_S,
    lookahead_s: float = 0.5,
    buffer_s: float = 0.5,
    duration: float | None = None,
    threads: int | None = None,
    wait_s: float | None = None,
    on_block: Callable[[int, int], None] | None = None,
    lead: float = 0.0,
    highpass_hz: float = 0.0,
    hrtf: object = None,
) -> PlaybackReport:
    """Play the sound along ``path`` live, synthesizing block by block.

    Parameters
    ----------
    tracks, path : the sources and the listener path (as for
        :func:`auralize.emitters.synthesis.render_tracks`); or, in place of ``tracks``, a
        block renderer of a scene (:class:`auralize.emitters.engine.BlockRenderer`,
        whose rate, layout and block length are used).
    layout : speaker layout of the synthesis.
    device : int, str or None
        Output device (index, name part, or the default).
    downmix : bool, str or Layout
        When the device has fewer channels than the layout: ``True`` folds
        to the largest built-in layout that fits, a layout name folds to that
        layout; ``False`` raises :class:`DeviceError`.
    gain : "auto" or float
        Output units per pascal.  ``"auto"`` scales the loudest sample of the
        first ``lookahead_s`` seconds to 0.99 and lowers the gain at a block
        boundary whenever a later block would clip (reported).
    limit_pa : float, optional
        Truncate pressures beyond this many pascals (as offline).
    block_s : float
        Block length; each block must be synthesized within it.
    buffer_s : float
        How far synthesis may run ahead of the device.
    on_block : callable(i, n_blocks), optional
        Called on the worker thread after each block is queued.
    lead : float
        Data seconds skipped at the start (as :func:`auralize.emitters.synthesis.render_tracks`).
    highpass_hz : float
        Causal high-pass of the output (as :func:`auralize.emitters.timbre.highpass`,
        its state carried from block to block); 0 keeps everything.
    hrtf : HRIRSet, str or Path, optional
        ``binaural`` only: the HRIRs (see :class:`BlockSynth`).

    Returns
    -------
    PlaybackReport

    Raises
    ------
    DeviceError
        No device, wrong index/name, too few channels without ``downmix``.
    """
    from auralize.audio.output import choose_output_device

    lay = get_layout(layout)
    _check_play_options(block_s, gain, highpass_hz, rate)
    dev = choose_output_device(device, lay.n_channels, downmix=bool(downmix))
    out_lay = _output_layout(lay, dev, downmix)
    mix = None if out_lay is lay else downmix_matrix(lay, out_lay)
    block = max(round(block_s * rate), 1)
    synth: Any
    if isinstance(tracks, SourceTracks):
        synth = BlockSynth(
            tracks,
            path,
            rate=rate,
            layout=lay,
            time_scale=time_scale,
            interp=interp,
            c0=c0,
            block=block,
            duration=duration,
            threads=threads,
            lead=lead,
            hrtf=hrtf,
        )
    else:  # a block renderer of a scene (auralize.emitters.engine.BlockRenderer)
        synth = tracks
        if synth.rate != rate or synth.layout.n_channels != lay.n_channels:
            raise ParameterError(
                f"the block renderer makes {synth.layout.name} at {synth.rate} "
                f"Hz; play was asked for {lay.name} at {rate} Hz"
            )
        block = synth.block_size
    hp: list[Any] = []
    if highpass_hz > 0:
        from auralize.emitters.timbre import butter_sos

        sos = butter_sos(4, float(highpass_hz), "highpass", float(rate))
        hp = [sos, np.zeros((sos.shape[0], lay.n_channels, 2))]
    align = SpeakerAlignment(lay, rate) if lay.needs_alignment else None
    synth_times: list[float] = []
    state = {"gain": None if gain == "auto" else float(gain), "changes": 0}
    err: list[BaseException] = []
    stop = threading.Event()

    def prepared(i: int) -> NDArray[np.float64]:
        t = time.perf_counter()
        a = synth.block(i)
        if hp:
            from scipy.signal import sosfilt

            a, hp[1] = sosfilt(hp[0], a, axis=-1, zi=hp[1])
        if limit_pa is not None:
            a = np.clip(a, -limit_pa, limit_pa)
        if align is not None:
            a = align.process(a)
        if mix is not None:
            a = mix @ a
        synth_times.append(time.perf_counter() - t)
        return a

    def scaled(a: NDArray[np.float64]) -> NDArray[np.float64]:
        peak = float(np.max(np.abs(a), initial=0.0))
        g = state["gain"]
        if g is None:  # auto gain, nothing heard yet
            if peak == 0:
                return a
            g = state["gain"] = PEAK_LEVEL / peak
        elif gain == "auto" and peak * g > 1.0:
            g = state["gain"] = PEAK_LEVEL / peak
            state["changes"] += 1
        return a * g

    n_look = min(synth.n_blocks, max(1, math.ceil(lookahead_s / block_s))) if gain == "auto" else 0
    stream = LiveStream(
        rate=rate,
        channels=out_lay.n_channels,
        device=dev["index"],
        block=block,
        buffer_s=max(buffer_s, 2 * block_s),
        prefill_s=min(0.2, buffer_s),
        wait_s=wait_s,
    )
    synth.render_range(0, min(64, synth.n_samples))  # load the compiled kernel before timing
    t_wall = time.perf_counter()

    def worker() -> None:
        try:
            ahead = [prepared(i) for i in range(n_look)]
            if ahead:
                peak = max(float(np.max(np.abs(a), initial=0.0)) for a in ahead)
                if peak > 0:
                    state["gain"] = PEAK_LEVEL / peak
            for i in range(synth.n_blocks):
                if stop.is_set():
                    return
                a = ahead[i] if i < len(ahead) else prepared(i)
                stream.write(scaled(a))
                if on_block is not None:
                    on_block(i, synth.n_blocks)
        except BaseException as exc:
            err.append(exc)

    th = threading.Thread(target=worker, name="auralize-synth", daemon=True)
    th.start()
    try:
        while th.is_alive():
            th.join(0.1)
    except BaseException:
        stop.set()
        th.join(5.0)
        stream.close(drain=False)
        raise
    if err:
        stream.close(drain=False)
        raise err[0]
    st = stream.close(drain=True)
    ms = 1e3 * np.asarray(synth_times) if synth_times else np.zeros(1)
    return PlaybackReport(
        device=str(dev["name"]),
        layout=lay.name,
        output_layout=out_lay.name,
        channels=out_lay.n_channels,
        rate=int(rate),
        duration_s=synth.n_samples / rate,
        blocks=synth.n_blocks,
        block_s=block / rate,
        synth_ms_mean=float(ms.mean()),
        synth_ms_p95=float(np.percentile(ms, 95)),
        synth_ms_max=float(ms.max()),
        underruns=st.underruns,
        underrun_times=list(st.underrun_times),
        device_underflows=st.device_underflows,
        gain=float(state["gain"] or 1.0),
        gain_changes=int(state["changes"]),
        wall_s=time.perf_counter() - t_wall,
    )
