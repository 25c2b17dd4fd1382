"""Listener-path recording: timed camera captures with a crash-safe autosave.

Paper 003 §4.1 records the listener at about 6–10 Hz with timestamps while the
user flies through the data.  :class:`PathRecorder` keeps the captures and
appends each one to an autosave CSV (the listener-path format of docs/design.md)
the moment it is taken: the line is flushed at once, so a crash of the
program loses nothing, and the file is fsync'ed at least once a second, so a
crash of the machine loses at most one second.  The autosave is always a
complete path: :meth:`PathRecorder.start` first writes (atomically) the header
and every capture already held — e.g. a path loaded from a CSV or a session —
and only then appends.

Captures may come from a driver of the caller's (a GUI timer, a script calling
:meth:`PathRecorder.capture`) or from the recorder's own clock thread
(:meth:`PathRecorder.drive`): it captures ``pose()`` every
:attr:`~PathRecorder.interval_s` whatever the calling thread is doing, so a
viewer busy redrawing (or listening live) still records at the asked rate;
``pose`` only returns the latest camera pose the viewer has seen.

Examples
--------
>>> import numpy as np
>>> rec = PathRecorder(rate_hz=10)
>>> rec.start()
>>> rec.capture([0, 0, 0], [0, 1, 0], [0, 0, 1], t=0.0)
>>> rec.capture([1, 0, 0], [0, 1, 0], [0, 0, 1], t=0.1)
>>> rec.stop().n_captures
2
"""

from __future__ import annotations

import math
import os
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO

import numpy as np
from numpy.typing import ArrayLike

from auralize.errors import ParameterError
from auralize.listener import ListenerPath, csv_header, format_row

DEFAULT_RATE_HZ = 10.0
#: an autosave is fsync'ed at least this often (seconds)
FSYNC_INTERVAL_S = 1.0


class PathRecorder:
    """Timed listener captures, autosaved as they happen.

    Parameters
    ----------
    rate_hz : float
        Captures per second a driver (timer, script) should take; default 10.
    autosave : path, optional
        CSV file written from :meth:`start`: header, then one line per capture.
    clock : callable
        Seconds (default :func:`time.perf_counter`); capture times are relative
        to :meth:`start`.
    """

    def __init__(
        self,
        *,
        rate_hz: float = DEFAULT_RATE_HZ,
        autosave: str | Path | None = None,
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        self.rate_hz = check_rate(rate_hz)
        self.autosave = Path(autosave) if autosave is not None else None
        self.clock = clock
        self.rows: list[np.ndarray] = []
        self.recording = False
        self._t0 = 0.0
        self._file: IO[str] | None = None
        self._lock = threading.Lock()
        self._stop_sync = threading.Event()
        self._syncer: threading.Thread | None = None
        self.capture_seconds: list[float] = []  # cost of each capture (benchmark)
        self._stop_drive = threading.Event()
        self._driver: threading.Thread | None = None
        #: the error that stopped :meth:`drive` (None while it runs or after a clean stop)
        self.drive_error: BaseException | None = None
        #: the ident of the thread :meth:`drive` captures on (not the caller's)
        self.driver_thread: int | None = None

    @property
    def interval_s(self) -> float:
        return 1.0 / self.rate_hz

    @property
    def n_captures(self) -> int:
        return len(self.rows)

    def achieved_rate_hz(self, window_s: float = 3.0) -> float:
        """Captures per second actually taken over the last ``window_s`` seconds of the path
        (0 with fewer than two captures)."""
        if len(self.rows) < 2:
            return 0.0
        t = np.asarray([r[0] for r in self.rows[-int(window_s * self.rate_hz * 2 + 2) :]])
        t = t[t >= t[-1] - window_s]
        return float((t.size - 1) / (t[-1] - t[0])) if t.size > 1 and t[-1] > t[0] else 0.0

    def start(self) -> None:
        """Start (or restart after :meth:`clear`) recording; opens the autosave file."""
        if self.recording:
            return
        if not self.rows:
            self._t0 = self.clock()
        else:  # continue an existing path: keep times increasing
            self._t0 = self.clock() - float(self.rows[-1][0]) - self.interval_s
        self.recording = True
        if self.autosave is not None:
            from auralize.runtime.files import atomic_write

            # the file starts complete (header and the captures held), then grows
            text = "".join(f"{line}\n" for line in [csv_header(), *map(format_row, self.rows)])
            atomic_write(self.autosave, text.encode("utf-8"))
            self._file = open(self.autosave, "a", encoding="utf-8")
            self._file.flush()
            self._stop_sync = threading.Event()
            self._syncer = threading.Thread(
                target=self._sync_loop,
                args=(self._file, self._stop_sync),
                name="auralize-autosave",
                daemon=True,
            )
            self._syncer.start()

    def capture(
        self, position: ArrayLike, forward: ArrayLike, up: ArrayLike, *, t: float | None = None
    ) -> None:
        """Append one capture (``t`` defaults to the clock since :meth:`start`)."""
        if not self.recording:
            raise ParameterError("not recording; call start() first")
        t0 = time.perf_counter()
        pose = [np.asarray(v, float).reshape(3) for v in (position, forward, up)]
        with self._lock:  # the clock thread (drive) and a caller may both capture
            tt = self.clock() - self._t0 if t is None else float(t)
            if self.rows and tt < self.rows[-1][0]:
                raise ParameterError(f"capture time {tt:g} s is before the previous one")
            row = np.concatenate([[tt], *pose])
            if not np.all(np.isfinite(row)):
                raise ParameterError(f"capture contains NaN or Inf: {row.tolist()}")
            self.rows.append(row)
            if self._file is not None:
                self._file.write(format_row(row) + "\n")
                self._file.flush()
        self.capture_seconds.append(time.perf_counter() - t0)

    def drive(self, pose: Callable[[], tuple[ArrayLike, ArrayLike, ArrayLike]]) -> None:
        """Capture ``pose()`` now, then every :attr:`interval_s` on a thread of its own,
        until :meth:`stop` (starts recording if needed).

        The captures keep the asked rate whatever the caller's thread is doing (a
        viewer redrawing or listening live): ``pose`` should only hand back the
        latest pose the caller has seen (a tuple it replaces, never a camera to
        read).  Slots missed (the machine was busy) are skipped, not taken late in a
        burst.  An error of ``pose`` or of a capture stops the clock and is kept in
        :attr:`drive_error`.
        """
        self.start()
        self._end_drive()
        self.drive_error = None
        stop = self._stop_drive = threading.Event()
        self.capture(*pose())  # the first one at once, on the caller's thread
        t_first = time.perf_counter()

        def run() -> None:
            self.driver_thread = threading.get_ident()
            t_next = t_first
            try:
                while self.recording and not stop.is_set():
                    now = time.perf_counter()
                    t_next += self.interval_s
                    if t_next <= now:  # late: the next slot still ahead
                        t_next += math.ceil((now - t_next) / self.interval_s) * self.interval_s
                    if stop.wait(t_next - now) or not self.recording:
                        break
                    self.capture(*pose())
            except BaseException as exc:  # kept for the caller, never lost
                if self.recording and not stop.is_set():
                    self.drive_error = exc

        self._driver = threading.Thread(target=run, name="auralize-capture", daemon=True)
        self._driver.start()

    @property
    def driving(self) -> bool:
        """Whether the clock thread of :meth:`drive` is capturing."""
        return self._driver is not None and self._driver.is_alive()

    def _end_drive(self) -> None:
        self._stop_drive.set()
        if self._driver is not None:
            if self._driver is not threading.current_thread():
                self._driver.join(timeout=5)
            self._driver = None

    def _sync_loop(self, fh: IO[str], stop: threading.Event) -> None:
        """fsync ``fh`` every :data:`FSYNC_INTERVAL_S` until stopped, then close it."""
        fd = fh.fileno()
        while not stop.wait(FSYNC_INTERVAL_S):
            os.fsync(fd)
        with self._lock:
            fh.flush()
        os.fsync(fd)
        fh.close()

    def stop(self) -> ListenerPath | None:
        """Stop recording (and the clock of :meth:`drive`); returns the path so far (None
        without captures)."""
        self.recording = False
        self._end_drive()
        if self._file is not None:
            with self._lock:
                self._file.flush()
            self._stop_sync.set()  # the syncer fsyncs and closes the file
            self._file = None
            self._syncer = None
        return self.path()

    def clear(self) -> None:
        """Forget every capture (recording stops; the autosave file is truncated on restart)."""
        self.stop()
        self.rows = []

    def path(self) -> ListenerPath | None:
        """The captures as a :class:`ListenerPath` (None without captures)."""
        if not self.rows:
            return None
        a = np.asarray(self.rows)
        return ListenerPath(a[:, 0], a[:, 1:4], a[:, 4:7], a[:, 7:10], source="recording")

    def load(self, path: ListenerPath) -> None:
        """Replace the captures by those of ``path`` (e.g. after loading a CSV)."""
        self.stop()
        self.rows = [r.copy() for r in path.rows()]


def check_rate(rate_hz: float) -> float:
    if not (isinstance(rate_hz, int | float) and math.isfinite(rate_hz) and 0 < rate_hz <= 1000):
        raise ParameterError(f"capture rate must be in (0, 1000] Hz, got {rate_hz!r}")
    return float(rate_hz)
