"""Head tracking: the listener's head orientation, from a tracker over OSC.

Live binaural and Ambisonics output turn with the listener's head: the head's
orientation, relative to where the listener faces (the camera in the viewer,
the listener path's ``forward`` and ``up`` elsewhere), rotates the listener's
frame before the sources are panned, so the sound field stays put in the
world while the head turns.  It changes from one block to the next without
restarting anything.

Orientation comes as yaw, pitch and roll in degrees or as a unit quaternion,
in the listener's frame ``x`` forward, ``y`` left, ``z`` up (the Ambisonics
axes):

* yaw turns the head to the left (about ``z``), pitch lifts the nose
  (about ``−y``), roll lowers the right ear (about ``x``), applied in that
  order (yaw, then pitch about the turned axis, then roll);
* a quaternion ``(w, x, y, z)`` is the rotation itself (normalised on receipt).

:class:`OSCHeadTracker` listens on a UDP port for the messages head trackers
and the spatial-audio plug-ins speak: SPARTA's (``/ypr``, ``/yaw``, ``/pitch``,
``/roll``, ``/quaternion``), the IEM plug-ins' SceneRotator
(``/SceneRotator/ypr``, ``/SceneRotator/quaternions`` and the single angles),
and the same names under any other prefix (``/head/ypr``).  Other messages are
counted and ignored.

Examples
--------
>>> import numpy as np
>>> head = HeadOrientation()
>>> head.set_ypr(90.0, 0.0, 0.0)  # the head turned a quarter to the left
>>> f, u = head.apply((0.0, 1.0, 0.0), (0.0, 0.0, 1.0))  # facing +y, z up
>>> np.round(f, 12) + 0.0, np.round(u, 12) + 0.0
(array([-1.,  0.,  0.]), array([0., 0., 1.]))
"""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from auralize.errors import DeviceError, ParameterError

__all__ = ["HeadOrientation", "OSCHeadTracker", "quaternion_matrix", "ypr_matrix"]

#: message names (the last part of the OSC address) and what they carry
ANGLE_NAMES = ("yaw", "pitch", "roll")


def ypr_matrix(yaw: float, pitch: float, roll: float) -> NDArray[np.float64]:
    """The rotation (3 × 3, in the listener's x forward, y left, z up) of a head
    turned ``yaw`` degrees to the left, then ``pitch`` degrees nose up, then
    ``roll`` degrees right ear down (module docstring)."""
    a, b, c = (math.radians(float(v)) for v in (yaw, pitch, roll))
    rz = np.array(
        [[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]]
    )
    # nose up: a rotation about −y
    ry = np.array(
        [[math.cos(b), 0.0, -math.sin(b)], [0.0, 1.0, 0.0], [math.sin(b), 0.0, math.cos(b)]]
    )
    rx = np.array(
        [[1.0, 0.0, 0.0], [0.0, math.cos(c), -math.sin(c)], [0.0, math.sin(c), math.cos(c)]]
    )
    return rz @ ry @ rx


def quaternion_matrix(w: float, x: float, y: float, z: float) -> NDArray[np.float64]:
    """The rotation (3 × 3) of the quaternion ``(w, x, y, z)``, normalised first.

    Raises
    ------
    ParameterError
        A zero or non-finite quaternion.
    """
    q = np.array([w, x, y, z], dtype=np.float64)
    n = float(np.linalg.norm(q))
    if not (math.isfinite(n) and n > 0):
        raise ParameterError(
            f"a head orientation quaternion must be finite and non-zero, got {tuple(q)}"
        )
    w, x, y, z = q / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


class HeadOrientation:
    """The head's current orientation, safe to set from one thread and read from another.

    ``version`` counts the changes; ``matrix`` is the rotation in the
    listener's frame (identity: facing where the listener faces).
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._matrix = np.eye(3)
        self._ypr = [0.0, 0.0, 0.0]
        self.version = 0

    @property
    def matrix(self) -> NDArray[np.float64]:
        with self._lock:
            return self._matrix.copy()

    def _set(self, m: NDArray[np.float64]) -> None:
        with self._lock:
            self._matrix = m
            self.version += 1

    def set_ypr(self, yaw: float, pitch: float, roll: float) -> None:
        """Yaw, pitch and roll in degrees (module docstring)."""
        vals = [float(v) for v in (yaw, pitch, roll)]
        if not all(math.isfinite(v) for v in vals):
            raise ParameterError(f"head yaw, pitch and roll must be finite degrees, got {vals}")
        self._ypr = vals
        self._set(ypr_matrix(*vals))

    def set_angle(self, name: str, degrees: float) -> None:
        """One of ``yaw``, ``pitch``, ``roll`` in degrees, the others kept."""
        if name not in ANGLE_NAMES:
            raise ParameterError(f"head angle must be one of {ANGLE_NAMES}, got {name!r}")
        ypr = list(self._ypr)
        ypr[ANGLE_NAMES.index(name)] = float(degrees)
        self.set_ypr(*ypr)

    def set_quaternion(self, w: float, x: float, y: float, z: float) -> None:
        """A unit quaternion ``(w, x, y, z)`` (normalised here)."""
        self._set(quaternion_matrix(w, x, y, z))

    def apply(self, forward: ArrayLike, up: ArrayLike) -> tuple[NDArray[np.float64], ...]:
        """The head's ``(forward, up)`` for a listener facing ``forward`` with ``up`` (world
        vectors): the listener's frame turned by the head's rotation."""
        f = np.asarray(forward, dtype=np.float64).reshape(3)
        u = np.asarray(up, dtype=np.float64).reshape(3)
        f = f / np.linalg.norm(f)
        u = u - np.dot(u, f) * f
        u = u / np.linalg.norm(u)
        frame = np.stack([f, np.cross(u, f), u], axis=1)  # columns: forward, left, up
        turned = frame @ self.matrix
        return turned[:, 0], turned[:, 2]


class OSCHeadTracker(HeadOrientation):
    """A :class:`HeadOrientation` set by OSC messages arriving on a UDP port.

    Parameters
    ----------
    port : int
        UDP port to listen on (0: any free port; :attr:`port` says which).
    host : str
        Address to listen on (default this machine only).

    Raises
    ------
    DeviceError
        The port cannot be opened (in use, no permission).

    Examples
    --------
    >>> tracker = OSCHeadTracker(port=0)
    >>> tracker.port > 0, tracker.received
    (True, 0)
    >>> tracker.close()
    """

    def __init__(self, port: int = 9000, host: str = "127.0.0.1") -> None:
        super().__init__()
        from pythonosc.dispatcher import Dispatcher
        from pythonosc.osc_server import ThreadingOSCUDPServer

        if isinstance(port, bool) or not (isinstance(port, int) and 0 <= port <= 65535):
            raise ParameterError(f"head-tracking port must be 0..65535, got {port!r}")
        self.received = 0
        self.ignored = 0
        self.last_error: str | None = None
        dispatcher = Dispatcher()
        dispatcher.set_default_handler(self._message)
        try:
            self._server = ThreadingOSCUDPServer((host, port), dispatcher)
        except OSError as exc:
            raise DeviceError(
                f"cannot listen for head tracking on {host}:{port}: {exc.strerror or exc}"
            ) from None
        self.host, self.port = host, int(self._server.server_address[1])
        self._thread = threading.Thread(
            target=self._server.serve_forever, name="auralize-osc", daemon=True
        )
        self._thread.start()

    def _message(self, address: str, *args: Any) -> None:
        name = address.rstrip("/").rsplit("/", 1)[-1].lower()
        try:
            nums = [float(a) for a in args]
            if name == "ypr" and len(nums) == 3:
                self.set_ypr(*nums)
            elif name in ANGLE_NAMES and len(nums) == 1:
                self.set_angle(name, nums[0])
            elif name in ("quaternion", "quaternions", "quat") and len(nums) == 4:
                self.set_quaternion(*nums)
            else:
                self.ignored += 1
                return
        except (TypeError, ValueError, ParameterError) as exc:
            self.ignored += 1
            self.last_error = f"{address}: {exc}"
            return
        self.received += 1

    def close(self) -> None:
        """Stop listening (the orientation is kept)."""
        self._server.shutdown()
        self._server.server_close()
        self._thread.join(timeout=2)

    def __enter__(self) -> OSCHeadTracker:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
