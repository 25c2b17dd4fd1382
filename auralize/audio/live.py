"""Live playback: the blocks of a render, synthesized ahead of the sound device's callback.

The blocks come from the one render, :func:`auralize.pipeline.render` with
``block=N`` (a :class:`auralize.rendering.RenderBlocks`: what is heard, with the
render's output rule, synthesized block by block by the engine's
:class:`auralize.emitters.engine.BlockRenderer`); taken in order they join
into the offline render.  This module plays them:

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
    Renders the blocks on a worker thread into a :class:`LiveStream` and
    returns a :class:`PlaybackReport` (per-block synthesis times, underruns,
    gain).

Arrays are ``(n_channels, n_samples)``; they are transposed only in the
callback.  sounddevice is imported inside :class:`LiveStream` only.

Examples
--------
The blocks :func:`play` feeds to a device, without one:

>>> from auralize.listener import ListenerPath
>>> from auralize.pipeline import detect_sources, load, render
>>> vol = load("dataset:monopole", size=12, steps=60)
>>> tracks = detect_sources(vol).tracks()
>>> path = ListenerPath.point(vol.center + [1.0, 0, 0], duration=0.1)
>>> blocks = render(tracks, path, layout="ring8", block=2205)
>>> blocks.n_blocks, blocks.block(0).shape
(2, (8, 2205))
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

from auralize.errors import DeviceError, ParameterError
from auralize.spatial.layouts import (
    Layout,
    SpeakerAlignment,
    downmix_matrix,
    downmix_target,
    get_layout,
)

PEAK_LEVEL = 0.99


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


#: what :func:`play` reads of the blocks it plays
BLOCKS_INTERFACE = (
    "block",
    "render_range",
    "n_blocks",
    "n_samples",
    "block_size",
    "rate",
    "layout",
)


def _check_play_options(blocks: Any, gain: float | str) -> None:
    """Raise :class:`ParameterError` for blocks or a gain ``play`` refuses."""
    missing = [name for name in BLOCKS_INTERFACE if not hasattr(blocks, name)]
    if missing:
        raise ParameterError(
            f"play plays the blocks of a render, not a {type(blocks).__name__} (it has no "
            f"{', '.join(missing)}): give it auralize.pipeline.render(sound, path, block=N, ...)"
        )
    if gain != "auto" and not (isinstance(gain, int | float) and math.isfinite(gain) and gain > 0):
        raise ParameterError(f"gain must be 'auto' or a positive number, got {gain!r}")


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


def play(
    blocks: Any,
    *,
    device: int | str | None = None,
    downmix: bool | str | Layout = False,
    gain: float | str = "auto",
    limit_pa: float | None = None,
    lookahead_s: float = 0.5,
    buffer_s: float = 0.5,
    wait_s: float | None = None,
    on_block: Callable[[int, int], None] | None = None,
) -> PlaybackReport:
    """Play the blocks of a render live: each block synthesized on a worker thread
    ahead of the device.

    Parameters
    ----------
    blocks : RenderBlocks
        What is heard, block by block: ``auralize.pipeline.render(sound, path,
        block=N, ...)`` (:class:`auralize.rendering.RenderBlocks`; its rate, layout
        and block length are played), or any object with the same
        ``block(i)``, ``render_range(start, n)``, ``n_blocks``, ``n_samples``,
        ``block_size``, ``rate`` and ``layout``.
    device : int, str or None
        Output device (index, name part, or the default;
        :func:`auralize.audio.output.choose_output_device`).
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
    lookahead_s : float
        Seconds of blocks rendered before the device starts (``gain="auto"``:
        the gain is set from them).
    buffer_s : float
        How far synthesis may run ahead of the device (at least two blocks).
    wait_s : float, optional
        Longest wait of the device's callback for a late block (see
        :class:`LiveStream`).
    on_block : callable(i, n_blocks), optional
        Called on the worker thread after each block is queued.

    Returns
    -------
    PlaybackReport
        The device, layouts, per-block synthesis times, underruns and gain.

    Raises
    ------
    ParameterError
        ``blocks`` not the blocks of a render (source tracks or a sound: render
        them with ``block=N`` first), a bad gain.
    DeviceError
        No device, wrong index/name, too few channels without ``downmix``.

    Examples
    --------
    Blocks of a pulsing source, played on a device that does not exist:

    >>> from auralize.listener import ListenerPath
    >>> from auralize.pipeline import render
    >>> from auralize.sources.detection import SourceTracks
    >>> t = np.linspace(0.0, 0.1, 21)
    >>> tracks = SourceTracks(positions=np.zeros((1, 3)), q=np.sin(2 * np.pi * 20 * t)[None],
    ...                       radius=np.array([0.1]), times=t)
    >>> blocks = render(tracks, ListenerPath.point((2.0, 0, 0), duration=0.05), block=2205)
    >>> play(blocks, device="no such device")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    auralize.errors.DeviceError: ...
    >>> play(tracks)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    auralize.errors.ParameterError: play plays the blocks of a render, not a SourceTracks ...
    """
    from auralize.audio.output import choose_output_device

    _check_play_options(blocks, gain)
    lay = blocks.layout
    rate = int(blocks.rate)
    block = int(blocks.block_size)
    block_s = block / rate
    dev = choose_output_device(device, lay.n_channels, downmix=bool(downmix))
    out_lay = _output_layout(lay, dev, downmix)
    mix = None if out_lay is lay else downmix_matrix(lay, out_lay)
    align = SpeakerAlignment(lay, rate) if lay.needs_alignment else None
    synth_times: list[float] = []
    state = {"gain": None if gain == "auto" else float(gain), "changes": 0}
    err: list[BaseException] = []
    stop = threading.Event()

    def prepared(i: int) -> NDArray[np.float64]:
        t = time.perf_counter()
        a = blocks.block(i)
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

    n_look = min(blocks.n_blocks, max(1, math.ceil(lookahead_s / block_s))) if gain == "auto" else 0
    stream = LiveStream(
        rate=rate,
        channels=out_lay.n_channels,
        device=dev["index"],
        block=block,
        buffer_s=max(buffer_s, 2 * block_s),
        prefill_s=min(0.2, buffer_s),
        wait_s=wait_s,
    )
    blocks.render_range(0, min(64, blocks.n_samples))  # load the compiled kernel before timing
    t_wall = time.perf_counter()

    def worker() -> None:
        try:
            ahead = [prepared(i) for i in range(n_look)]
            if ahead:
                peak = max(float(np.max(np.abs(a), initial=0.0)) for a in ahead)
                if peak > 0:
                    state["gain"] = PEAK_LEVEL / peak
            for i in range(blocks.n_blocks):
                if stop.is_set():
                    return
                a = ahead[i] if i < len(ahead) else prepared(i)
                stream.write(scaled(a))
                if on_block is not None:
                    on_block(i, blocks.n_blocks)
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
        duration_s=blocks.n_samples / rate,
        blocks=blocks.n_blocks,
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
