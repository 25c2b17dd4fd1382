"""Live listening: the listener follows the camera and the sound is synthesized block by block.

While the animation plays and the user flies, :class:`LiveEngine` renders
consecutive audio blocks with the one render, :func:`auralize.pipeline.render`
(continued: ``start=`` offsets and a carried filter state join blocks without seams) for the latest camera pose, and
:class:`LivePlayer` pushes them from a worker thread into an :class:`AudioSink`.
A pose set with :meth:`LiveEngine.set_pose` is used by the next block, so a
camera move reaches the sink within one block plus the render time
(:attr:`LivePlayer.latencies` records it; the target is ≤ 100 ms).  Within
a block the listener moves linearly from the previous pose to the new one
(Doppler stays physical); a jump faster than half the speed of sound is
applied at the block edge instead.

The sound is the one the viewer's rendered file holds (the output rule of
``auralize render``, :func:`auralize.pipeline.render`): the
sources' ``physical`` pressure through the causal 20 Hz high-pass
(``highpass_hz``, default :data:`auralize.emitters.timbre.HIGHPASS_HZ`; 0 keeps
everything), a 4th-order Butterworth whose state is carried from block to
block, so that the blocks heard at a still pose join into the offline render
filtered once; the overlays' sound (``extra``) is added as its model makes it,
unfiltered.  The timbre is ``physical``: ``extended`` and ``tonal`` (and the
choice of ``auto``) need the whole render along a path known in advance (β of
paper 001 Eq. 13 is matched over the render), which a camera-driven listener
does not have (the viewer's rendered file, along a recorded path, has them).

The clock is placed as a render's (:func:`auralize.pipeline.plan_render`): each
loop starts when the first sound can reach the camera (``lead``), so a camera
a kilometre away hears the data at once rather than after three seconds of
silence per loop; :meth:`LiveEngine.why_silent` says in words why nothing can
be heard when nothing can.

What was heard is kept (:meth:`LiveEngine.heard_path`,
:meth:`LiveEngine.heard_audio`) so it can be saved as a listener-path CSV
plus its audio.

Sinks: :class:`DeviceSink` plays through the output layer
(``auralize.audio.live`` / ``auralize.audio.output``; it raises
:class:`~auralize.errors.DeviceError` when no device is usable) and
:class:`WavSink` writes the stream to a WAV file at real-time pace (what a
file-backed device does).

Examples
--------
>>> from auralize.pipeline import load, detect_sources
>>> vol = load("dataset:monopole", size=12, steps=60)
>>> tracks = detect_sources(vol).tracks()
>>> eng = LiveEngine(tracks, layout="stereo", block=512)
>>> eng.set_pose(vol.center + [1.0, 0, 0], [0, 1, 0], [0, 0, 1])  # the pose's version
1
>>> eng.next_block().shape
(2, 512)
"""

from __future__ import annotations

import importlib
import math
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from auralize.emitters import FieldSources, Sound
from auralize.emitters.synthesis import C0, Rendered, box_distances, source_extent
from auralize.emitters.timbre import HIGHPASS_HZ, highpass
from auralize.errors import DeviceError, ParameterError
from auralize.listener import ListenerPath
from auralize.rendering import Carry, render
from auralize.sources.detection import SourceTracks
from auralize.spatial.layouts import get_layout, output_stage

#: default block length in samples (23 ms at 44.1 kHz)
DEFAULT_BLOCK = 1024


class AudioSink(Protocol):
    """Where live audio goes: ``write`` blocks until the block is accepted."""

    def write(self, block: NDArray[np.float64]) -> None: ...

    def close(self) -> None: ...


class LiveEngine:
    """Consecutive audio blocks for a listener pose that may change at any time.

    Parameters
    ----------
    tracks : SourceTracks
        The detected sources (:meth:`SourceSeries.tracks`).
    layout : str
        Speaker layout, AmbiX or ``binaural`` (rendered in its AmbiX
        intermediate and filtered by one output stage carrying its state from
        block to block: the head turns with the camera).
    rate : int
        Sample rate in Hz.
    time_scale : float
        Playback seconds per data second.
    block : int
        Samples per block.
    loop : bool
        Start again at the first step after the last (as the animation loops).
    extra : Sound, optional
        More sound heard with the sources (the viewer's audible overlays, an
        :class:`auralize.emitters.Sound`), rendered by the engine along the same
        block paths and added (:meth:`set_extra` changes it from the next block on).
    highpass_hz : float
        Cut-off (Hz) of the causal 4th-order Butterworth high-pass of the
        sources' sound (not of ``extra``), as ``auralize render --highpass``
        (default 20 Hz; 0 keeps everything).  Its state is carried from block
        to block (and across a loop); per block it costs one ``sosfilt`` of
        the block, nothing is designed or allocated beyond the block.
    lead : float or "auto"
        Data seconds of sound travel skipped at the start of each loop, as
        :func:`auralize.pipeline.plan_render` places a render's clock.
        ``"auto"`` (default): at each loop's start, the travel time from the
        sources' box to the listener then (:attr:`lead`), so the first sound
        is heard at once however far away the camera is; each loop lasts the
        data's span plus the spread of arrival delays across the box.
    box : (lo, hi), optional
        The box the clock is placed from (default: the sources'); a render of
        the whole field plans from the data's bounds
        (:func:`auralize.pipeline.source_box`), which the viewer passes.
    head : HeadOrientation, optional
        The listener's head orientation relative to the pose
        (:class:`auralize.audio.headtrack.OSCHeadTracker` from a head tracker):
        each block turns the pose's frame by it, so binaural and Ambisonics
        output follow the head (:meth:`set_head` changes it).
    """

    def __init__(
        self,
        tracks: SourceTracks,
        *,
        layout: str = "stereo",
        rate: int = 44100,
        time_scale: float = 1.0,
        block: int = DEFAULT_BLOCK,
        c0: float = C0,
        loop: bool = True,
        extra: Any = None,
        highpass_hz: float = HIGHPASS_HZ,
        lead: float | str = "auto",
        box: Any = None,
        head: Any = None,
    ) -> None:
        if not (isinstance(block, int) and 16 <= block <= 1 << 16):
            raise ParameterError(f"block must be 16..65536 samples, got {block!r}")
        highpass(np.zeros((1, 0)), int(rate), highpass_hz)  # a bad cut-off fails here
        self.tracks = tracks
        self.stage = output_stage(get_layout(layout), int(rate))
        self.layout = self.stage.layout
        self.rate = int(rate)
        self.time_scale = float(time_scale)
        self.block = block
        self.c0 = float(c0)
        self.loop = loop
        if not (
            lead == "auto" or (isinstance(lead, int | float) and math.isfinite(lead) and lead >= 0)
        ):
            raise ParameterError(f"lead must be 'auto' or data seconds >= 0, got {lead!r}")
        self.auto_lead = lead == "auto"
        #: data seconds of travel skipped in the current loop
        self.lead = 0.0 if self.auto_lead else float(lead)
        self.box = (
            None
            if not tracks.n_sources
            else source_extent(tracks)[:2]
            if box is None
            else tuple(np.asarray(b, dtype=np.float64).reshape(3) for b in box)
        )
        span = tracks.t_last - tracks.t_first if tracks.times.size > 1 else 0.0
        self.data_span = float(span)
        self.span_s = span * self.time_scale  # playback seconds of one loop
        self.t = 0.0  # playback seconds into the current loop
        self.elapsed = 0.0  # playback seconds since start
        self._lock = threading.Lock()
        self._pose: tuple[NDArray[np.float64], ...] | None = None
        self._pose_version = 0
        self._prev: tuple[NDArray[np.float64], ...] | None = None
        self.extra = extra
        self.heard_rows: list[NDArray[np.float64]] = []
        self.heard_blocks: list[NDArray[np.float64]] = []
        self.keep_heard = True
        #: playback seconds of heard audio kept (older blocks are dropped)
        self.keep_heard_s = 600.0
        self.highpass_hz = float(highpass_hz)
        # the high-pass's state, carried from block to block (and across a loop)
        self._carry = Carry()
        self.head = head

    @property
    def block_s(self) -> float:
        return self.block / self.rate

    @property
    def data_time(self) -> float:
        """Data time (s) of the next block's first sample (for the time slider): when
        the sound the listener hears then left the nearest source."""
        return float(self.tracks.t_first + self.t / self.time_scale)

    def distances(self, position: ArrayLike) -> tuple[float, float]:
        """Nearest and farthest distance (m) from ``position`` to the sources' box
        (``(inf, inf)`` when nothing is heard)."""
        if self.box is None:
            return math.inf, math.inf
        near, far = box_distances(np.asarray(position, dtype=np.float64).reshape(1, 3), *self.box)
        return float(near[0]), float(far[0])

    def _start_loop(self, position: NDArray[np.float64]) -> None:
        """Place a loop's clock for the listener at ``position``: skip the travel time to
        the first arrival (``lead``) and last the data's span plus the spread of
        arrival delays, as a render along a path standing there."""
        near, far = self.distances(position)
        if not math.isfinite(near):
            return
        if self.auto_lead:
            self.lead = near / self.c0
        self.span_s = self.time_scale * (self.data_span + max(far - near, 0.0) / self.c0)

    def why_silent(self) -> str | None:
        """Why nothing can be heard now, in words (None when something can)."""
        if self.tracks.n_sources == 0:
            return (
                "nothing is heard: no sources (detect with lower thresholds, unmute a "
                "type, or hear the whole field)"
            )
        if self.data_span <= 0:
            return "nothing is heard: the data have one time step, so nothing changes"
        q = np.asarray(self.tracks.q, dtype=np.float64)
        if q.size and not np.any(q.max(axis=1) > q.min(axis=1)):
            return "nothing is heard: no source's strength changes in time (the field is steady)"
        return None

    def describe_distance(self) -> str:
        """Where the listener is from the sources, and the travel time skipped."""
        with self._lock:
            pose = self._pose
        if pose is None or self.box is None:
            return ""
        near, _ = self.distances(pose[0])
        where = f"{near / 1000:.3g} km" if near >= 1000 else f"{near:.3g} m"
        return (
            f"the data are {where} away: sound takes {near / self.c0:.3g} s "
            f"(skipped: the first arrival plays at once)"
            if self.auto_lead
            else f"the data are {where} away: sound takes {near / self.c0:.3g} s"
        )

    def set_pose(self, position: ArrayLike, forward: ArrayLike, up: ArrayLike) -> int:
        """Set the listener pose used from the next block on; returns a version number."""
        pose = tuple(
            np.asarray(v, dtype=np.float64).reshape(3).copy() for v in (position, forward, up)
        )
        with self._lock:
            self._pose = pose
            self._pose_version += 1
            return self._pose_version

    def set_head(self, head: Any) -> None:
        """Turn the listener's head by ``head`` (a :class:`~auralize.audio.headtrack.HeadOrientation`,
        or None to face the pose) from the next block on."""
        with self._lock:
            self.head = head

    def set_extra(self, sound: Any) -> None:
        """Hear ``sound`` (a :class:`auralize.emitters.Sound`, or None) from the next block on."""
        with self._lock:
            self.extra = sound

    def next_block(self) -> NDArray[np.float64]:
        """Render the next block ``(n_channels, block)`` in pascals."""
        with self._lock:
            pose, version, extra, head = self._pose, self._pose_version, self.extra, self.head
        if pose is None:
            raise ParameterError("set the listener pose before rendering")
        prev = self._prev if self._prev is not None else pose
        self._prev = pose  # the pose as set (the head turns it afresh each block)
        if head is not None:  # the head's orientation at this block, on both poses
            pose = (pose[0], *head.apply(pose[1], pose[2]))
            prev = (prev[0], *head.apply(prev[1], prev[2]))
        if self.loop and self.span_s > 0 and self.t >= self.span_s:
            self.t = 0.0
        if self.t == 0.0:
            self._start_loop(pose[0])
        dur = self.block_s
        move = float(np.linalg.norm(pose[0] - prev[0]))
        if move / (dur / self.time_scale) >= 0.5 * self.c0:
            prev = pose  # too fast to be a motion: jump at the block edge
        # captures at playback 0 and t (previous pose) and t + dur (new pose)
        times = np.array([0.0, self.t, self.t + dur]) if self.t > 0 else np.array([0.0, dur])
        pos = [prev[0], prev[0], pose[0]] if self.t > 0 else [prev[0], pose[0]]
        fwd = [prev[1], prev[1], pose[1]] if self.t > 0 else [prev[1], pose[1]]
        up = [prev[2], prev[2], pose[2]] if self.t > 0 else [prev[2], pose[2]]
        path = ListenerPath(times, np.array(pos), np.array(fwd), np.array(up), source="live")
        sound = Sound(
            [FieldSources(self.tracks, time_scale=self.time_scale, lead=self.lead)], name="field"
        )
        if extra is not None and extra.parts:
            sound = sound + extra
        out = render(
            sound,
            path,
            rate=self.rate,
            layout=self.stage.synthesis_layout,
            c0=self.c0,
            start=self.t,
            duration=dur,
            highpass_hz=self.highpass_hz,
            carry=self._carry,
        )
        audio = out.audio
        if audio.shape[1] != self.block:  # rounding of duration * rate
            audio = np.pad(audio, ((0, 0), (0, max(self.block - audio.shape[1], 0))))[
                :, : self.block
            ]
        audio = self.stage.process(audio)
        if self.keep_heard:
            self.heard_rows.append(np.concatenate([[self.elapsed + dur], *pose]))
            self.heard_blocks.append(audio.astype(np.float32))
            if len(self.heard_blocks) * dur > self.keep_heard_s:  # bounded memory
                del self.heard_blocks[0], self.heard_rows[0]
        self.t += dur
        self.elapsed += dur
        self.last_version = version
        return audio

    def heard_path(self) -> ListenerPath | None:
        """The poses heard, one capture per block end (playback seconds from the start)."""
        if not self.heard_rows:
            return None
        a = np.asarray(self.heard_rows)
        a[:, 0] -= a[0, 0] - self.block_s  # from the start of the first block kept
        a = np.vstack([np.concatenate([[0.0], a[0, 1:]]), a])
        return ListenerPath(a[:, 0], a[:, 1:4], a[:, 4:7], a[:, 7:10], source="live")

    def heard_audio(self) -> Rendered:
        """All blocks heard so far as one :class:`Rendered`."""
        audio = (
            np.concatenate(self.heard_blocks, axis=1).astype(np.float64)
            if self.heard_blocks
            else np.zeros((self.layout.n_channels, 0))
        )
        return Rendered(
            audio=audio,
            rate=self.rate,
            layout=self.layout,
            time_scale=self.time_scale,
            meta={"live": True},
        )

    def save_heard(self, csv_path: str | Path, audio_path: str | Path) -> None:
        """Write what was heard: the listener path CSV and its audio (peak-normalised)."""
        from auralize.pipeline import save_rendered

        p = self.heard_path()
        if p is None:
            raise ParameterError("nothing was heard yet; start live listening first")
        p.to_csv(csv_path)
        save_rendered(self.heard_audio(), audio_path, extra={"path": str(csv_path)})


class WavSink:
    """Write the live stream to a WAV file, accepting blocks at real-time pace.

    ``buffer_blocks`` blocks may be queued ahead of the (simulated) playback
    position, as in a device buffer; ``pace=False`` accepts blocks at once.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        rate: int,
        channels: int,
        pace: bool = True,
        buffer_blocks: int = 1,
    ) -> None:
        self.path, self.rate, self.channels = Path(path), int(rate), int(channels)
        self.pace, self.buffer_blocks = pace, max(int(buffer_blocks), 0)
        self.blocks: list[NDArray[np.float64]] = []
        self.write_times: list[float] = []
        self._play_start: float | None = None
        self._queued_s = 0.0

    def write(self, block: NDArray[np.float64]) -> None:
        if block.shape[0] != self.channels:
            raise DeviceError(
                f"{self.path}: sink has {self.channels} channels, block has {block.shape[0]}"
            )
        now = time.perf_counter()
        if self._play_start is None:
            self._play_start = now
        if self.pace:
            # playback position advances in real time; wait while the buffer is full
            ahead = self._queued_s - (now - self._play_start)
            limit = self.buffer_blocks * block.shape[1] / self.rate
            if ahead > limit:
                time.sleep(ahead - limit)
        self.blocks.append(np.array(block))
        self._queued_s += block.shape[1] / self.rate
        self.write_times.append(time.perf_counter())

    def close(self, drain: bool = True) -> None:
        from auralize.audio.output import write_audio

        if self.blocks:
            write_audio(self.path, np.concatenate(self.blocks, axis=1), self.rate, normalize="none")


class DeviceSink:
    """Play through the output layer's live stream (``auralize.audio.live``), else raise.

    The output layer (another part of auralize) owns sounddevice; this adapter
    only looks up its stream class.  :class:`~auralize.errors.DeviceError` is
    raised when the layer or a usable device is missing.
    """

    def __init__(self, *, rate: int, channels: int, device: Any = None) -> None:
        try:
            live = importlib.import_module("auralize.audio.live")
        except ModuleNotFoundError as exc:
            if exc.name != "auralize.audio.live":
                raise
            raise DeviceError(
                "live playback is not available: the output layer "
                "(auralize.audio.live) is not installed"
            ) from None
        factory = getattr(live, "open_stream", None) or getattr(live, "LiveStream", None)
        if factory is None:
            raise DeviceError(
                "auralize.audio.live offers no open_stream/LiveStream for live playback"
            )
        self._stream = factory(rate=rate, channels=channels, device=device)

    def write(self, block: NDArray[np.float64]) -> None:
        self._stream.write(block)

    def close(self, drain: bool = True) -> None:
        self._stream.close(drain=drain)


class LivePlayer:
    """Runs a :class:`LiveEngine` into a sink on a worker thread.

    Every block passes through :attr:`limiter` (:class:`auralize.audio.output.Limiter`:
    automatic gain from the first sound, the gain control ``gain_db``, and a peak
    limiter), so a sink never receives a sample beyond full scale; the limiter's
    level meter describes the last block.  ``on_block(data_time)`` is called after
    each block (e.g. to move the time slider); :attr:`latencies` holds, for each
    pose change picked up, the seconds from :meth:`set_pose` until its block was
    accepted by the sink.  :meth:`stop` returns within one block (plus the render
    of the block in progress).
    """

    def __init__(
        self,
        engine: LiveEngine,
        sink: AudioSink,
        *,
        on_block: Callable[[float], None] | None = None,
        gain_db: float = 0.0,
    ) -> None:
        from auralize.audio.output import Limiter

        self.engine, self.sink, self.on_block = engine, sink, on_block
        self.limiter = Limiter(None, gain_db=gain_db, rate=engine.rate)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._pending: dict[int, float] = {}
        self.latencies: list[float] = []
        self.error: BaseException | None = None

    def set_pose(self, position: ArrayLike, forward: ArrayLike, up: ArrayLike) -> None:
        v = self.engine.set_pose(position, forward, up)
        self._pending[v] = time.perf_counter()

    def start(self) -> None:
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="auralize-live", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                block = self.engine.next_block()
                if self._stop.is_set():
                    break
                self.sink.write(self.limiter.process(block))
                done = time.perf_counter()
                v = self.engine.last_version
                for k in [k for k in self._pending if k <= v]:
                    self.latencies.append(done - self._pending.pop(k))
                if self.on_block is not None:
                    self.on_block(self.engine.data_time)
        except BaseException as exc:  # reported to the GUI, never lost
            self.error = exc

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def set_gain_db(self, gain_db: float) -> None:
        """Change the gain control (dB) from the next block on."""
        from auralize.audio.output import check_gain_db

        self.limiter.gain_db = check_gain_db(gain_db)

    def stop(self) -> None:
        """Stop after the block in progress; the sink is closed without playing its queue."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None
        try:
            self.sink.close(drain=False)  # type: ignore[call-arg]
        except TypeError:
            self.sink.close()
