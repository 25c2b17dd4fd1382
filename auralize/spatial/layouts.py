"""Speaker layouts and panning gains.

Conventions (docs/design.md): azimuths are degrees counter-clockwise from the
listener's forward direction (0 front, +90 left, -90 right); elevation degrees
up from the horizontal plane.  ``ring8`` is eight speakers at 45°·k, channel k.
Directions in the listener's frame are unit vectors ``(x, y, z)`` = (forward,
left, up).

Panning laws
------------
* **Horizontal layouts** (every panned speaker at elevation 0): pairwise 2-D
  VBAP between the two speakers adjacent to the source azimuth (the convex hull
  methods of 3-D VBAP fail on a coplanar ring).  This is the law the numba
  synthesis kernel applies per piece (:func:`auralize.emitters._kernels.gains._gains`);
  :func:`vbap_gains` is the same law in numpy.
* **Layouts with elevation**: 3-D VBAP (Pulkki 1997) over the triangles of the
  convex hull of the speaker directions (:func:`vbap3d_gains`).  When no
  speaker lies within 20° of the nadir (zenith), an *imaginary* speaker is added
  at the nadir (zenith); its gain is dropped and the remaining gains are
  re-normalised, so a source below the ring is heard on the ring at its own
  azimuth; likewise above the highest speakers.  The synthesis kernel applies
  the same law per piece (:func:`auralize.emitters._kernels.gains._gains3`, from the
  table of :func:`auralize.emitters.synthesis.pan_table`).
* Every law is **power-normalised** (Σ g² = 1 over the panned speakers) and
  continuous in the direction, so gains change smoothly as a source moves or
  the listener turns.  The LFE channel of 5.1/7.1 is never panned to.

Per-speaker distances (custom layouts) are compensated by
:class:`SpeakerAlignment`: nearer speakers are delayed and attenuated so that
every speaker's sound reaches the listener at the same time and level.

Immersive layouts
-----------------
* ``ambix1``, ``ambix2``, ``ambix3``: Ambisonics of order N in the AmbiX
  convention (ACN channel order, SN3D normalisation; :mod:`auralize.spatial.ambisonics`),
  (N+1)² channels without speaker directions or channel mask; ``meta`` says
  ``ambisonic``, ``order``, ``normalisation`` and ``channel_order``.
  :func:`pan_gains` returns the spherical-harmonic encoding gains, so every
  renderer that pans through it writes AmbiX; the synthesis kernels evaluate
  the same harmonics per piece (:func:`auralize.emitters._kernels.gains._gains_sh`, by
  recurrence from the Cartesian direction).  :func:`downmix_matrix` decodes
  AmbiX to any loudspeaker layout (AllRAD with max-rE weights).
* ``binaural``: two ear signals (L, R).  Binaural output is not a panning law:
  renderers pan to its intermediate (:func:`synthesis_layout`) and
  :func:`output_stage` filters that with the head's responses
  (:mod:`auralize.spatial.hrtf`), so every model gets binaural output, smooth
  under motion.  With the built-in spherical head the intermediate is two
  *receivers*, the ears (:func:`auralize.spatial.hrtf.ear_layout`): a layout of
  several receivers (:func:`receivers_layout`) is rendered once per receiver,
  along the receiver's own path (:func:`receiver_path`: a point fixed to the
  listener's head, with its own frame), and the channels are stacked; with a
  SOFA file it is AmbiX order 3 at the head's centre.  The
  stage runs once after the parts are summed (offline:
  :meth:`OutputStage.finish`; block by block: :meth:`OutputStage.process_at`,
  which carries the filters' state), and ``--hrtf`` of the command line sets
  its HRIRs for every renderer (:func:`default_hrtf`).
* Layouts from other tools: :func:`load_layout_json` also reads the IEM
  AllRADecoder / ``LoudspeakerLayout`` JSON (imaginary speakers become
  triangulation helpers of 3-D VBAP, not channels).

Examples
--------
>>> lay = get_layout("ring8")
>>> g = vbap_gains(lay, np.deg2rad([90.0]))     # straight left: channel 2
>>> int(np.argmax(g[:, 0])), round(float(np.sum(g**2)), 12)
(2, 1.0)
"""

from __future__ import annotations

import contextlib
import contextvars
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.constants import C0
from auralize.errors import FormatError, ParameterError
from auralize.runtime.json_check import AnyJSON, Bool, Obj, Text, check, optional, read_json

#: speed of sound used to turn speaker distances into delays (m/s)
C0_ALIGN = C0


@dataclass(frozen=True)
class Speaker:
    """One output channel.

    Parameters
    ----------
    name : str
        Channel name (``FL``, ``S3`` …).
    azimuth_deg : float or None
        Degrees counter-clockwise from the front; None marks a channel that is
        never panned to (LFE).
    elevation_deg : float
        Degrees up from the horizontal plane.
    distance_m : float, optional
        The speaker's distance from the listening position, m, used for
        delay/gain alignment (:class:`SpeakerAlignment`).

    Examples
    --------
    >>> Speaker("SL", 90.0, distance_m=2.5)
    Speaker(name='SL', azimuth_deg=90.0, elevation_deg=0.0, distance_m=2.5)
    """

    name: str
    azimuth_deg: float | None
    elevation_deg: float = 0.0
    distance_m: float | None = None

    @property
    def direction(self) -> NDArray[np.float64]:
        """Unit vector (forward, left, up) of the speaker, ``(3,)`` (zeros for LFE).

        Examples
        --------
        >>> np.round(Speaker("top", 90.0, 90.0).direction, 12).tolist()
        [0.0, 0.0, 1.0]
        >>> Speaker("LFE", None).direction.tolist()
        [0.0, 0.0, 0.0]
        """
        if self.azimuth_deg is None:
            return np.zeros(3)
        return _unit_from_angles(self.azimuth_deg, self.elevation_deg)


def _unit_from_angles(az_deg: float, el_deg: float) -> NDArray[np.float64]:
    a, e = math.radians(az_deg), math.radians(el_deg)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


@dataclass(frozen=True)
class Layout:
    """An ordered set of output channels.

    Parameters
    ----------
    name : str
    speakers : tuple of Speaker
        In channel order.
    fold_front : bool
        Two-speaker layouts mirror rear directions to the front (stereo cannot
        place sounds behind).
    channel_mask : int, optional
        WAVE_FORMAT_EXTENSIBLE ``dwChannelMask`` (speaker positions of the
        channels, in order); None for layouts without standard positions.
    meta : dict
        What else describes the layout (AmbiX order, binaural intermediate,
        receivers, an IEM file's imaginary speakers and channel gains).

    Examples
    --------
    >>> lay = Layout("pair", (Speaker("A", 45.0), Speaker("B", -45.0)), fold_front=True)
    >>> lay
    <Layout pair: 2 channels (A, B)>
    >>> get_layout("5.1").channel_names
    ['FL', 'FR', 'FC', 'LFE', 'BL', 'BR']
    """

    name: str
    speakers: tuple[Speaker, ...]
    fold_front: bool = False
    channel_mask: int | None = None
    meta: dict[str, object] = field(default_factory=dict, compare=False)

    @property
    def n_channels(self) -> int:
        """Number of output channels.

        Examples
        --------
        >>> get_layout("7.1").n_channels
        8
        """
        return len(self.speakers)

    def __repr__(self) -> str:
        return f"<Layout {self.name}: {self.n_channels} channels ({', '.join(self.channel_names)})>"

    def downmix(self, audio: NDArray[np.floating], dst: Layout | str) -> NDArray[np.float64]:
        """Fold ``audio (n_channels, n)`` of this layout into ``dst``: ``downmix_matrix(self,
        dst) @ audio`` (:func:`downmix_matrix`).

        Parameters
        ----------
        audio : array_like, shape (n_channels, n)
            Audio in this layout's channel order.
        dst : Layout or str
            The target layout (a name or JSON file, :func:`get_layout`).

        Returns
        -------
        ndarray, shape (dst.n_channels, n)

        Raises
        ------
        ParameterError
            ``audio`` does not have this layout's channels; a target that needs
            filters (binaural).

        Examples
        --------
        >>> front = np.zeros((8, 3)); front[0] = 1.0      # ring8 channel 0: straight ahead
        >>> np.round(get_layout("ring8").downmix(front, "stereo"), 4).tolist()
        [[0.7071, 0.7071, 0.7071], [0.7071, 0.7071, 0.7071]]
        """
        a = np.asarray(audio, dtype=np.float64)
        if a.ndim != 2 or a.shape[0] != self.n_channels:
            raise ParameterError(
                f"layout {self.name!r} has {self.n_channels} channels, audio has shape {a.shape}"
            )
        return downmix_matrix(self, dst) @ a

    @property
    def channel_names(self) -> list[str]:
        """Names of the channels, in order.

        Examples
        --------
        >>> get_layout("stereo").channel_names
        ['L', 'R']
        """
        return [s.name for s in self.speakers]

    @property
    def panned_channels(self) -> NDArray[np.int64]:
        """Indices of the channels that take part in panning (all but LFE).

        Examples
        --------
        >>> get_layout("5.1").panned_channels.tolist()
        [0, 1, 2, 4, 5]
        """
        return np.array(
            [c for c, s in enumerate(self.speakers) if s.azimuth_deg is not None], dtype=np.int64
        )

    @property
    def is_horizontal(self) -> bool:
        """True when every panned speaker lies in the horizontal plane.

        Examples
        --------
        >>> get_layout("ring8").is_horizontal
        True
        """
        return all(abs(s.elevation_deg) < 1e-9 for s in self.speakers if s.azimuth_deg is not None)

    @property
    def has_distances(self) -> bool:
        """True when any speaker has a distance (:class:`SpeakerAlignment` applies).

        Examples
        --------
        >>> get_layout("ring8").has_distances
        False
        """
        return any(s.distance_m is not None for s in self.speakers)

    @property
    def channel_gains(self) -> NDArray[np.float64] | None:
        """Linear output gain per channel ``(n_channels,)`` (an IEM layout's
        ``Gain``), or None when every channel has gain 1.

        Examples
        --------
        >>> get_layout("stereo").channel_gains is None
        True
        """
        g = self.meta.get("channel_gains")
        return None if g is None else np.asarray(g, dtype=np.float64)

    @property
    def needs_alignment(self) -> bool:
        """True when :class:`SpeakerAlignment` changes the output: speaker
        distances or per-channel gains.

        Examples
        --------
        >>> lay = make_layout("x", [Speaker("A", 30.0, 0.0, 2.0), Speaker("B", -30.0, 0.0, 2.0)])
        >>> lay.needs_alignment, get_layout("5.1").needs_alignment
        (True, False)
        """
        return self.has_distances or self.channel_gains is not None

    def directions(self) -> NDArray[np.float64]:
        """Speaker directions in the listener frame; LFE rows are zero.

        Returns
        -------
        ndarray, shape (n_channels, 3)
            Unit vectors (forward, left, up).

        Examples
        --------
        >>> np.round(get_layout("stereo").directions(), 4).tolist()
        [[0.866, 0.5, 0.0], [0.866, -0.5, 0.0]]
        """
        return np.stack([s.direction for s in self.speakers])

    def panning_arrays(self) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Sorted azimuths (radians, in (-π, π]) and their channel indices, for the
        pairwise 2-D law of the synthesis kernel (mono: empty).

        For a layout with elevation this is its horizontal projection: at each
        distinct azimuth the speaker nearest the horizontal plane (the kernel
        then pans with the 3-D table instead).

        Returns
        -------
        azimuths : ndarray, shape (S,)
            Radians in (-π, π], increasing.
        channels : ndarray of int, shape (S,)
            The channel of each azimuth.

        Raises
        ------
        ParameterError
            For AmbiX and binaural layouts, which have no speaker azimuths
            (their gains come from :func:`pan_gains` and :func:`output_stage`).

        Examples
        --------
        >>> az, ch = get_layout("5.1").panning_arrays()
        >>> np.round(np.degrees(az)).tolist(), ch.tolist()
        ([-110.0, -30.0, 0.0, 30.0, 110.0], [5, 1, 2, 0, 4])
        """
        if self.meta.get("ambisonic") or self.meta.get("binaural"):
            raise ParameterError(
                f"layout {self.name!r} has no speaker azimuths to pan between: AmbiX gains come "
                f"from auralize.spatial.layouts.pan_gains, binaural ears from auralize.spatial.layouts.output_stage"
                f"; this renderer supports loudspeaker layouts only"
            )
        if self.n_channels == 1:
            return np.zeros(0), np.zeros(0, dtype=np.int64)
        best: dict[float, tuple[float, int, float]] = {}
        for c, s in enumerate(self.speakers):
            if s.azimuth_deg is None:
                continue
            a = math.radians(((s.azimuth_deg + 180.0) % 360.0) - 180.0)
            if a <= -math.pi:
                a += 2 * math.pi
            key = round(a, 9)
            if key not in best or abs(s.elevation_deg) < best[key][0]:
                best[key] = (abs(s.elevation_deg), c, a)
        az = np.array([v[2] for v in best.values()])
        ch = np.array([v[1] for v in best.values()], dtype=np.int64)
        order = np.argsort(az)
        return az[order], ch[order]

    def describe(self) -> dict[str, object]:
        """JSON-able description; :func:`load_layout_json` reads it back.

        That holds for speaker layouts; AmbiX channels are components, not
        speakers, and the ``meta`` of immersive layouts says what they are.

        Returns
        -------
        dict
            ``name``, ``channel_mask`` and ``speakers`` (name, azimuth and
            elevation in degrees, distance in m, ``lfe``), or for AmbiX
            ``channels`` and ``meta``.

        Examples
        --------
        >>> import json
        >>> d = get_layout("stereo").describe()
        >>> d["speakers"][0]
        {'name': 'L', 'azimuth': 30.0, 'elevation': 0.0, 'distance': None}
        >>> _ = Path("stereo.json").write_text(json.dumps(d))
        >>> load_layout_json("stereo.json").channel_names
        ['L', 'R']
        """
        if self.meta.get("ambisonic"):
            return {
                "name": self.name,
                "channel_mask": None,
                "meta": dict(self.meta),
                "channels": self.channel_names,
            }
        out: dict[str, object] = {
            "name": self.name,
            "channel_mask": self.channel_mask,
            "speakers": [
                {
                    "name": s.name,
                    "azimuth": s.azimuth_deg,
                    "elevation": s.elevation_deg,
                    "distance": s.distance_m,
                    **({"lfe": True} if s.azimuth_deg is None else {}),
                }
                for s in self.speakers
            ],
        }
        if self.meta:
            out["meta"] = dict(self.meta)
        return out


def _sp(name: str, az: float | None, el: float = 0.0) -> Speaker:
    return Speaker(name, az, el)


BUILTIN_LAYOUTS: dict[str, Layout] = {
    "mono": Layout("mono", (_sp("M", 0.0),), channel_mask=0x4),
    "stereo": Layout(
        "stereo", (_sp("L", 30.0), _sp("R", -30.0)), fold_front=True, channel_mask=0x3
    ),
    "ring8": Layout("ring8", tuple(_sp(f"S{k}", 45.0 * k) for k in range(8))),
    # WAVE/SMPTE order: FL FR FC LFE BL BR (ITU-R BS.775 angles)
    "5.1": Layout(
        "5.1",
        (
            _sp("FL", 30.0),
            _sp("FR", -30.0),
            _sp("FC", 0.0),
            _sp("LFE", None),
            _sp("BL", 110.0),
            _sp("BR", -110.0),
        ),
        channel_mask=0x3F,
    ),
    # WAVE order: FL FR FC LFE BL BR SL SR
    "7.1": Layout(
        "7.1",
        (
            _sp("FL", 30.0),
            _sp("FR", -30.0),
            _sp("FC", 0.0),
            _sp("LFE", None),
            _sp("BL", 150.0),
            _sp("BR", -150.0),
            _sp("SL", 90.0),
            _sp("SR", -90.0),
        ),
        channel_mask=0x63F,
    ),
}


#: order of the Ambisonic intermediate of the binaural layout
BINAURAL_ORDER = 3


def ambix_layout(order: int, channels: NDArray[np.integer] | None = None) -> Layout:
    """The AmbiX layout of an order N: (N+1)² channels ``ACN0`` … in ACN order, SN3D.

    Its channels have no direction (they are spherical-harmonic components, not
    speakers) and the layout no WAVE channel mask.

    Parameters
    ----------
    order : int
        Ambisonics order N >= 1.
    channels : array_like of int, optional
        Increasing ACN indices: keeps a subset of the harmonics
        (``meta["acn"]``, name ``ambixN[k,...]``), the binaural stage's
        intermediate when its filters of the other harmonics are zero
        (:class:`OutputStage`); the renderers pan to the kept harmonics only.

    Returns
    -------
    Layout

    Raises
    ------
    ParameterError
        A bad order, or channels that are not increasing ACN indices of it.

    Examples
    --------
    >>> ambix_layout(1).channel_names
    ['ACN0', 'ACN1', 'ACN2', 'ACN3']
    >>> ambix_layout(3, [0, 2, 6, 12]).name
    'ambix3[0,2,6,12]'
    """
    from auralize.spatial.ambisonics import check_order, n_channels

    n = check_order(order)
    if n < 1:
        raise ParameterError(f"an Ambisonic layout needs order ≥ 1, got {order!r}")
    meta: dict[str, object] = {
        "ambisonic": True,
        "order": n,
        "normalisation": "SN3D",
        "channel_order": "ACN",
        "convention": "AmbiX",
    }
    acn = np.arange(n_channels(n))
    name = f"ambix{n}"
    if channels is not None:
        acn = np.asarray(channels, dtype=np.int64).reshape(-1)
        if acn.size == 0 or np.any(np.diff(acn) <= 0) or acn[0] < 0 or acn[-1] >= n_channels(n):
            raise ParameterError(
                f"AmbiX channels must be increasing ACN indices in 0..{n_channels(n) - 1}, "
                f"got {acn.tolist()}"
            )
        if acn.size < n_channels(n):
            meta["acn"] = acn.tolist()
            name = f"ambix{n}[{','.join(str(int(k)) for k in acn)}]"
    return Layout(name, tuple(Speaker(f"ACN{int(k)}", None) for k in acn), meta=meta)


def ambix_channels(layout: Layout) -> NDArray[np.int64]:
    """ACN indices of the channels of an AmbiX layout (all (N+1)², or its subset).

    Parameters
    ----------
    layout : Layout
        An AmbiX layout (:func:`ambix_layout`).

    Returns
    -------
    ndarray of int, shape (n_channels,)

    Examples
    --------
    >>> ambix_channels(ambix_layout(1)).tolist(), ambix_channels(ambix_layout(2, [0, 2, 6])).tolist()
    ([0, 1, 2, 3], [0, 2, 6])
    """
    from auralize.spatial.ambisonics import n_channels

    acn = layout.meta.get("acn")
    if acn is not None:
        return np.asarray(acn, dtype=np.int64)
    return np.arange(n_channels(int(layout.meta["order"])))  # type: ignore[call-overload]


def binaural_layout() -> Layout:
    """The ``binaural`` layout: two ear signals (L, R).

    Rendered through an intermediate (:func:`synthesis_layout`) and filtered
    into ears by :func:`output_stage`.

    Returns
    -------
    Layout

    Examples
    --------
    >>> lay = binaural_layout()
    >>> lay.channel_names, is_binaural(lay)
    (['L', 'R'], True)
    """
    return Layout(
        "binaural",
        (Speaker("L", 90.0), Speaker("R", -90.0)),
        channel_mask=0x3,
        meta={"binaural": True, "intermediate": f"ambix{BINAURAL_ORDER}"},
    )


@dataclass(frozen=True)
class Receiver:
    """One receiver of a multi-receiver synthesis layout (:func:`receivers_layout`).

    A point fixed to the listener's head (an ear), with a frame of its own: the
    renderers solve its retarded times, distances and Doppler from its own
    position, and pan its channels with ``layout``'s law in its own frame.

    Parameters
    ----------
    name : str
        Prefix of its channels' names (``L`` → ``L.ACN0`` …).
    offset : (3,) tuple
        Position relative to the listener, in the listener frame (forward,
        left, up), m.
    forward, up : (3,) tuples
        The receiver frame's forward and up axes, in the listener frame.
    layout : Layout
        What the receiver's channels are (an AmbiX subset for the ears).

    Examples
    --------
    >>> left = Receiver("L", (0.0, 0.1, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0), ambix_layout(1))
    >>> receivers_layout("one-ear", (left,)).channel_names
    ['L.ACN0', 'L.ACN1', 'L.ACN2', 'L.ACN3']
    """

    name: str
    offset: tuple[float, float, float]
    forward: tuple[float, float, float]
    up: tuple[float, float, float]
    layout: Layout


def receivers_layout(name: str, receivers: tuple[Receiver, ...], **meta: object) -> Layout:
    """A synthesis layout whose channels are those of several receivers, in turn.

    Renderers given such a layout render each receiver along its own path
    (:func:`receiver_paths`) and stack the channels; an output stage then
    combines them (the ears of ``binaural``).

    Parameters
    ----------
    name : str
        Layout name.
    receivers : tuple of Receiver
        In channel order.
    **meta : object
        Extra entries of the layout's ``meta``.

    Returns
    -------
    Layout
        Channels without direction, ``meta["receivers"]`` the receivers.

    Examples
    --------
    >>> ears = [Receiver(n, (0.0, y, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), ambix_layout(1))
    ...         for n, y in (("L", 0.09), ("R", -0.09))]
    >>> lay = receivers_layout("two", tuple(ears), head_radius_m=0.09)
    >>> lay.n_channels, [r.name for r in receivers_of(lay)], lay.meta["head_radius_m"]
    (8, ['L', 'R'], 0.09)
    """
    speakers = tuple(
        replace(sp, name=f"{r.name}.{sp.name}", azimuth_deg=None)
        for r in receivers
        for sp in r.layout.speakers
    )
    return Layout(name, speakers, meta={"receivers": tuple(receivers), **meta})


def receivers_of(layout: Layout) -> tuple[Receiver, ...]:
    """The receivers of a :func:`receivers_layout` (empty for any other layout).

    Parameters
    ----------
    layout : Layout

    Returns
    -------
    tuple of Receiver

    Examples
    --------
    >>> receivers_of(get_layout("ring8"))
    ()
    >>> [r.name for r in receivers_of(synthesis_layout("binaural"))]
    ['L', 'R']
    """
    return tuple(layout.meta.get("receivers", ()))  # type: ignore[call-overload]


def receiver_path(path: Any, receiver: Receiver) -> Any:
    """The path of a receiver fixed to the listener of ``path``.

    At each capture the receiver sits at position + R·offset and faces
    R·forward, R·up, where R turns the listener frame into the world (columns
    forward, left, up).  Between captures positions are interpolated linearly
    and orientations by slerp, as for the listener: for an offset of a few
    centimetres the chord differs from the arc by well under a millimetre at
    the turn rates of a head.  The result is cached on ``path`` (renderers
    that key caches on a path's arrays then see the same ones every call).

    Parameters
    ----------
    path : ListenerPath
        The listener's path.
    receiver : Receiver

    Returns
    -------
    ListenerPath
        The receiver's path (same times).

    Examples
    --------
    >>> from auralize.listener import ListenerPath
    >>> ear = receivers_of(synthesis_layout("binaural"))[0]          # the left ear
    >>> path = ListenerPath.point((0, 0, 0), duration=1.0)           # facing +y
    >>> np.round(receiver_path(path, ear).positions[0], 4).tolist()  # left of +y is -x
    [-0.0862, -0.0152, 0.0]
    """
    from auralize.listener import ListenerPath

    f, u = path.forward, path.up
    key = (path.times, path.positions, f, u)
    cache = path.__dict__.setdefault("_receiver_paths", {})
    hit = cache.get(receiver)
    if hit is not None and all(a is b for a, b in zip(hit[0], key, strict=True)):
        return hit[1]
    rot = np.stack([f, np.cross(u, f), u], axis=2)  # (N, 3, 3): world = rot @ local
    off, fw, up = (
        np.asarray(v, dtype=np.float64) for v in (receiver.offset, receiver.forward, receiver.up)
    )
    out = ListenerPath(
        path.times,
        path.positions + rot @ off,
        rot @ fw,
        rot @ up,
        source=f"{path.source} ({receiver.name})",
    )
    cache[receiver] = (key, out)
    return out


def receiver_paths(layout: Layout, path: Any) -> list[tuple[Layout, Any]]:
    """``(layout, path)`` of each receiver of a multi-receiver layout, in channel order.

    Parameters
    ----------
    layout : Layout
        A :func:`receivers_layout` (any other layout: an empty list).
    path : ListenerPath
        The listener's path.

    Returns
    -------
    list of (Layout, ListenerPath)
        Each receiver's channels and path (:func:`receiver_path`).

    Examples
    --------
    >>> from auralize.listener import ListenerPath
    >>> parts = receiver_paths(synthesis_layout("binaural"), ListenerPath.point((0, 0, 0), duration=1.0))
    >>> [(lay.n_channels, p.source) for lay, p in parts]
    [(4, 'point (L)'), (4, 'point (R)')]
    """
    return [(r.layout, receiver_path(path, r)) for r in receivers_of(layout)]


#: layouts that are not loudspeaker layouts (no panning law of their own)
IMMERSIVE_LAYOUTS: dict[str, Layout] = {
    **{f"ambix{n}": ambix_layout(n) for n in (1, 2, 3)},
    "binaural": binaural_layout(),
}


def is_ambisonic(layout: Layout) -> bool:
    """True for an AmbiX layout (``ambix1`` …).

    Parameters
    ----------
    layout : Layout

    Returns
    -------
    bool

    Examples
    --------
    >>> is_ambisonic(get_layout("ambix2")), is_ambisonic(get_layout("5.1"))
    (True, False)
    """
    return bool(layout.meta.get("ambisonic"))


def is_binaural(layout: Layout) -> bool:
    """True for the ``binaural`` layout.

    Parameters
    ----------
    layout : Layout

    Returns
    -------
    bool

    Examples
    --------
    >>> is_binaural(get_layout("binaural")), is_binaural(get_layout("stereo"))
    (True, False)
    """
    return bool(layout.meta.get("binaural"))


def get_layout(spec: str | Path | Layout) -> Layout:
    """A built-in layout by name, or a custom one from a JSON file.

    Parameters
    ----------
    spec : str, Path or Layout
        ``mono``, ``stereo``, ``ring8``, ``5.1``, ``7.1``, ``binaural``,
        ``ambix1``/``ambix2``/``ambix3`` or a path ending in ``.json`` (our
        format or an IEM ``LoudspeakerLayout``; see :func:`load_layout_json`).
        A Layout is returned as it is.

    Returns
    -------
    Layout

    Raises
    ------
    ParameterError
        Unknown name.
    FormatError
        Malformed or invalid JSON layout.

    Examples
    --------
    >>> get_layout("ring8")
    <Layout ring8: 8 channels (S0, S1, S2, S3, S4, S5, S6, S7)>
    >>> get_layout("quad")
    Traceback (most recent call last):
    auralize.errors.ParameterError: unknown layout 'quad'; choose one of ...
    """
    if isinstance(spec, Layout):
        return spec
    s = str(spec)
    if s in BUILTIN_LAYOUTS:
        return BUILTIN_LAYOUTS[s]
    if s in IMMERSIVE_LAYOUTS:
        return IMMERSIVE_LAYOUTS[s]
    if s.lower().endswith(".json"):
        return load_layout_json(Path(s))
    raise ParameterError(
        f"unknown layout {s!r}; choose one of {sorted(BUILTIN_LAYOUTS) + list(IMMERSIVE_LAYOUTS)} "
        f"or a FILE.json with speaker azimuths/elevations in degrees"
    )


#: most speakers (or channels) a layout file may hold
MAX_SPEAKERS = 1024
_NAME = Text(nonempty=True)
#: a speaker's optional keys besides its numbers (checked by :func:`_num`)
_SPEAKER = Obj({"name": optional(_NAME), "lfe": optional(Bool())}, other=AnyJSON())


def _num(path: Path, i: int, it: dict[str, Any], *keys: str, default: float | None) -> float | None:
    for k in keys:
        if k in it and it[k] is not None:
            v = it[k]
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise FormatError(f"{path}: speaker {i}: {k!r} must be a number, got {v!r}")
            if not math.isfinite(float(v)):
                raise FormatError(f"{path}: speaker {i}: {k!r} must be finite, got {v!r}")
            return float(v)
    return default


def load_layout_json(path: str | Path) -> Layout:
    """Read a custom layout.

    Format: ``{"name": "...", "speakers": [{"azimuth": deg, "elevation": deg,
    "name": "...", "distance": m, "channel": i, "lfe": false}, ...]}`` or a bare
    list of speaker objects.  ``channel`` (0-based output channel) is optional;
    if one speaker has it, all must, and they must be 0..n-1 exactly once.
    A speaker with ``"lfe": true`` has no direction and is never panned to.

    Also reads the IEM AllRADecoder / Plug-in Suite format ``{"LoudspeakerLayout":
    {"Name": ..., "Loudspeakers": [{"Azimuth": deg, "Elevation": deg, "Radius": m,
    "IsImaginary": bool, "Channel": 1-based, "Gain": linear}, ...]}}``: real
    speakers come out on their ``Channel`` (a channel without a speaker is a
    silent output without direction), imaginary ones only help 3-D VBAP's
    triangulation (``meta["imaginary_directions"]``).  A real speaker's ``Gain``
    (linear, finite; negative inverts the polarity) multiplies its output
    channel wherever the speakers are aligned (:class:`SpeakerAlignment`: files
    written with the layout, live playback), after the distance alignment of its
    ``Radius``; gains other than 1 are kept in ``meta["channel_gains"]``.  An
    imaginary speaker's ``Gain`` (IEM's share of its signal spread to its
    neighbours) is not used: the 3-D law drops the imaginary speaker's gain and
    renormalises the real ones (:func:`vbap3d_gains`).  The file's ``Decoder``
    object, if any, is not read: decoders are built from the layout
    (:func:`auralize.spatial.ambisonics.decoder_matrix`).

    Parameters
    ----------
    path : str or Path
        The JSON file.

    Returns
    -------
    Layout

    Raises
    ------
    FormatError
        Missing file, invalid JSON (or nested deeper, or with longer numbers,
        than :mod:`auralize.runtime.json_check` reads), missing/duplicate channels,
        non-numeric or out-of-range angles, a name that is not a string, an
        ``lfe`` that is not true or false, duplicate directions or names,
        non-positive distances, fewer than two speakers to pan between or more
        than :data:`MAX_SPEAKERS`.

    Examples
    --------
    >>> _ = Path("tri.json").write_text('{"name": "tri", "speakers": ['
    ...     '{"azimuth": 0}, {"azimuth": 120, "distance": 2}, {"azimuth": -120}]}')
    >>> lay = load_layout_json("tri.json")
    >>> lay.name, lay.channel_names, lay.speakers[1].distance_m
    ('tri', ['S0', 'S1', 'S2'], 2.0)
    >>> _ = Path("iem.json").write_text('{"LoudspeakerLayout": {"Name": "pair", "Loudspeakers": ['
    ...     '{"Azimuth": 30, "Elevation": 0, "Channel": 1, "IsImaginary": false, "Gain": 0.5},'
    ...     '{"Azimuth": -30, "Elevation": 0, "Channel": 2, "IsImaginary": false}]}}')
    >>> load_layout_json("iem.json").channel_gains.tolist()
    [0.5, 1.0]
    """
    p = Path(path)
    try:
        data = read_json(p)
    except FileNotFoundError:
        raise FormatError(f"layout file {str(p)!r} does not exist") from None
    if isinstance(data, dict) and ("LoudspeakerLayout" in data or "Loudspeakers" in data):
        return _load_iem_layout(p, data)
    if isinstance(data, dict):
        items = data.get("speakers", data.get("channels"))
        name = data.get("name", p.stem)
    else:
        items, name = data, p.stem
    if not isinstance(items, list) or not items:
        raise FormatError(
            f"{p}: expected a non-empty list 'speakers' of {{azimuth, elevation}} objects"
        )
    if len(items) > MAX_SPEAKERS:
        raise FormatError(f"{p}: {len(items)} speakers; a layout has at most {MAX_SPEAKERS}")
    check(name, _NAME, str(p), where="name")
    speakers: list[Speaker] = []
    chans: list[int | None] = []
    for i, it in enumerate(items):
        if not isinstance(it, dict):
            raise FormatError(f"{p}: speaker {i} must be an object, got {it!r}")
        check(it, _SPEAKER, str(p), where=f"speakers[{i}]")
        lfe = it.get("lfe") is True
        az = _num(p, i, it, "azimuth", "azimuth_deg", default=None)
        if az is None and not lfe:
            raise FormatError(f"{p}: speaker {i} needs an 'azimuth' in degrees, got {it!r}")
        el = _num(p, i, it, "elevation", "elevation_deg", default=0.0)
        assert el is not None
        if not -90.0 <= el <= 90.0:
            raise FormatError(f"{p}: speaker {i}: elevation must be in [-90, 90] degrees, got {el}")
        dist = _num(p, i, it, "distance", "distance_m", default=None)
        if dist is not None and not dist > 0:
            raise FormatError(f"{p}: speaker {i}: distance must be > 0 m, got {dist}")
        ch = it.get("channel")
        if ch is not None and (isinstance(ch, bool) or not isinstance(ch, int)):
            raise FormatError(f"{p}: speaker {i}: 'channel' must be an integer, got {ch!r}")
        chans.append(ch)
        speakers.append(Speaker(it.get("name") or f"S{i}", None if lfe else az, el, dist))
    n = len(speakers)
    given = [c for c in chans if c is not None]
    if given:
        if len(given) != n:
            raise FormatError(f"{p}: either every speaker or none has a 'channel' index")
        dup = sorted({c for c in given if given.count(c) > 1})
        if dup:
            raise FormatError(f"{p}: duplicate channel(s) {dup}")
        missing = sorted(set(range(n)) - set(given))
        if missing:
            raise FormatError(
                f"{p}: channels must be 0..{n - 1} exactly once; missing {missing}, "
                f"got {sorted(given)}"
            )
        order = np.argsort(given)
        speakers = [speakers[int(k)] for k in order]
    names = [s.name for s in speakers]
    if len(set(names)) != len(names):
        raise FormatError(f"{p}: duplicate speaker names {names}")
    return make_layout(str(name), speakers, source=str(p))


def _load_iem_layout(p: Path, data: dict[str, Any]) -> Layout:
    """An IEM AllRADecoder ``LoudspeakerLayout`` (see :func:`load_layout_json`)."""
    import dataclasses

    lay = data.get("LoudspeakerLayout", data)
    if (
        not isinstance(lay, dict)
        or not isinstance(lay.get("Loudspeakers"), list)
        or not lay["Loudspeakers"]
    ):
        raise FormatError(
            f"{p}: an IEM layout needs 'LoudspeakerLayout': {{'Loudspeakers': [{{'Azimuth', "
            f"'Elevation', 'Radius', 'IsImaginary', 'Channel', 'Gain'}}, ...]}}"
        )
    if len(lay["Loudspeakers"]) > MAX_SPEAKERS:
        raise FormatError(
            f"{p}: {len(lay['Loudspeakers'])} loudspeakers; a layout has at most {MAX_SPEAKERS}"
        )
    name = lay.get("Name") or data.get("Name") or p.stem
    check(name, _NAME, str(p), where="Name")
    real: dict[int, Speaker] = {}
    gains: dict[int, float] = {}
    imaginary: list[list[float]] = []
    for i, it in enumerate(lay["Loudspeakers"]):
        if not isinstance(it, dict):
            raise FormatError(f"{p}: Loudspeakers[{i}] must be an object, got {it!r}")
        az = _num(p, i, it, "Azimuth", default=None)
        el = _num(p, i, it, "Elevation", default=None)
        if az is None or el is None:
            raise FormatError(f"{p}: Loudspeakers[{i}] needs 'Azimuth' and 'Elevation' in degrees")
        if not -90.0 <= el <= 90.0:
            raise FormatError(f"{p}: Loudspeakers[{i}]: Elevation must be in [-90, 90], got {el}")
        imag = it.get("IsImaginary", False)
        if not isinstance(imag, bool):
            raise FormatError(f"{p}: Loudspeakers[{i}]: 'IsImaginary' must be true or false")
        if imag:  # a triangulation helper, not an output channel
            imaginary.append(_unit_from_angles(az, el).tolist())
            continue
        ch = it.get("Channel")
        if isinstance(ch, bool) or not isinstance(ch, int) or not 1 <= ch <= MAX_SPEAKERS:
            raise FormatError(
                f"{p}: Loudspeakers[{i}]: 'Channel' must be an integer ≥ 1 (1-based) and "
                f"≤ {MAX_SPEAKERS}, got {ch!r}"
            )
        if ch in real:
            raise FormatError(f"{p}: Loudspeakers[{i}]: channel {ch} is used twice")
        radius = _num(p, i, it, "Radius", default=None)
        if radius is not None and not radius > 0:
            raise FormatError(f"{p}: Loudspeakers[{i}]: 'Radius' must be > 0 m, got {radius}")
        gain = _num(p, i, it, "Gain", default=1.0)
        assert gain is not None
        real[ch] = Speaker(f"CH{ch}", az, el, radius)
        gains[ch] = gain
    if not real:
        raise FormatError(f"{p}: the layout has no real (non-imaginary) loudspeaker")
    n = max(real)
    # a channel without a speaker (e.g. a subwoofer's) is a silent output without direction
    speakers = [real.get(c, Speaker(f"CH{c}", None)) for c in range(1, n + 1)]
    out = make_layout(name, speakers, source=str(p))
    meta: dict[str, object] = {"format": "IEM LoudspeakerLayout"}
    if imaginary:
        meta["imaginary_directions"] = imaginary
    if any(g != 1.0 for g in gains.values()):
        meta["channel_gains"] = [gains.get(c, 0.0) for c in range(1, n + 1)]
    return dataclasses.replace(out, meta=meta)


def make_layout(
    name: str,
    speakers: list[Speaker] | tuple[Speaker, ...],
    *,
    channel_mask: int | None = None,
    source: str = "<layout>",
) -> Layout:
    """Validate and build a custom :class:`Layout`.

    Parameters
    ----------
    name : str
        Layout name.
    speakers : sequence of Speaker
        In channel order.
    channel_mask : int, optional
        WAVE ``dwChannelMask``.
    source : str
        Where the layout comes from (for messages).

    Returns
    -------
    Layout
        Two panned speakers fold rear directions to the front.

    Raises
    ------
    FormatError
        Fewer than two panned speakers, or two speakers in the same direction.

    Examples
    --------
    >>> make_layout("pair", [Speaker("A", 30.0), Speaker("B", -30.0)]).fold_front
    True
    >>> make_layout("same", [Speaker("A", 30.0), Speaker("B", 30.0)])
    Traceback (most recent call last):
    auralize.errors.FormatError: <layout>: speakers 'A' and 'B' point the same way (azimuth 30.0°, elevation 0.0°)
    """
    panned = [s for s in speakers if s.azimuth_deg is not None]
    if len(panned) < 2:
        raise FormatError(
            f"{source}: panning needs at least 2 speakers with a direction, got {len(panned)}"
        )
    dirs = np.stack([s.direction for s in panned])
    cos = dirs @ dirs.T
    np.fill_diagonal(cos, -1.0)
    i, j = np.unravel_index(int(np.argmax(cos)), cos.shape)
    if cos[i, j] > 1.0 - 1e-9:
        raise FormatError(
            f"{source}: speakers {panned[i].name!r} and {panned[j].name!r} point the same way "
            f"(azimuth {panned[i].azimuth_deg}°, elevation {panned[i].elevation_deg}°)"
        )
    return Layout(
        str(name), tuple(speakers), fold_front=len(panned) == 2, channel_mask=channel_mask
    )


# ------------------------------------------------------------------ 2-D VBAP
def vbap_gains(layout: Layout, azimuth_rad: NDArray[np.floating]) -> NDArray[np.float64]:
    """Pairwise 2-D VBAP gains of the synthesis kernel, ``(n_channels, N)``.

    Parameters
    ----------
    layout : Layout
        A loudspeaker layout.
    azimuth_rad : array_like, shape (N,)
        Source azimuths in the listener's frame (radians, counter-clockwise
        from forward).

    Returns
    -------
    ndarray, shape (n_channels, N)
        Gains; the squared gains of each direction sum to 1.  Elevated layouts
        are panned on their horizontal projection
        (:meth:`Layout.panning_arrays`); use :func:`pan_gains` for the 3-D law.

    Raises
    ------
    ParameterError
        An AmbiX or binaural layout.

    Examples
    --------
    >>> g = vbap_gains(get_layout("ring8"), np.radians([22.5]))   # between speakers 0 and 1
    >>> np.round(g[:2, 0], 4).tolist()
    [0.7071, 0.7071]
    """
    az, ch = layout.panning_arrays()
    phi = np.atleast_1d(np.asarray(azimuth_rad, dtype=np.float64))
    out = np.zeros((layout.n_channels, phi.size))
    if az.size == 0:
        out[0] = 1.0
        return out
    if layout.fold_front:
        phi = np.arctan2(np.sin(phi), np.abs(np.cos(phi)))
    phi = np.angle(np.exp(1j * phi))
    n = az.size
    i0 = np.searchsorted(az, phi, side="right") - 1
    i0 = np.where(i0 < 0, n - 1, i0)
    i1 = (i0 + 1) % n
    two_pi = 2 * np.pi
    span = np.mod(az[i1] - az[i0], two_pi)
    span = np.where(span == 0, two_pi, span)
    rel = np.mod(phi - az[i0], two_pi)
    wide = span > np.pi
    rel = np.where(wide, np.where(rel < 0.5 * span, 0.0, span), np.minimum(rel, span))
    s = np.sin(span)
    with np.errstate(divide="ignore", invalid="ignore"):
        g0 = np.where(np.abs(s) < 1e-12, np.cos(rel * np.pi / (2 * span)), np.sin(span - rel) / s)
        g1 = np.where(np.abs(s) < 1e-12, np.sin(rel * np.pi / (2 * span)), np.sin(rel) / s)
    g0, g1 = np.clip(g0, 0, None), np.clip(g1, 0, None)
    norm = np.hypot(g0, g1)
    norm = np.where(norm > 0, norm, 1)
    cols = np.arange(phi.size)
    np.add.at(out, (ch[i0], cols), g0 / norm)
    np.add.at(out, (ch[i1], cols), g1 / norm)
    return out


# ------------------------------------------------------------------ 3-D VBAP
@dataclass(frozen=True)
class Triangulation:
    """Speaker triangles for 3-D VBAP (made by :func:`triangulate`).

    Parameters
    ----------
    inverse : ndarray, shape (T, 3, 3)
        Per triangle the inverse of the matrix whose rows are its three
        speaker directions, so gains are ``p @ inverse[t]``.
    channels : ndarray of int, shape (T, 3)
        Output channel of each vertex, -1 for an imaginary speaker.
    imaginary_neighbours : tuple of tuple of int
        For each imaginary speaker, the real channels adjacent to it on the
        hull (they share its gain when a source lies exactly at it).
    imaginary_directions : ndarray, shape (K, 3)
        Unit directions of the imaginary speakers.

    Examples
    --------
    >>> tri = triangulate(make_layout("dome", [Speaker(f"S{k}", 90.0 * k) for k in range(4)]
    ...                               + [Speaker("top", 0.0, 90.0)]))
    >>> tri.channels.shape, tri.imaginary_directions.tolist()   # a nadir speaker added
    ((8, 3), [[0.0, 0.0, -1.0]])
    """

    inverse: NDArray[np.float64]
    channels: NDArray[np.int64]
    imaginary_neighbours: tuple[tuple[int, ...], ...]
    imaginary_directions: NDArray[np.float64]


def triangulate(layout: Layout) -> Triangulation:
    """Convex-hull triangulation of a layout's panned speakers, for 3-D VBAP.

    Imaginary speakers are added: those of ``layout.meta["imaginary_directions"]``,
    and at the nadir/zenith when no speaker lies within 20° of them.

    Parameters
    ----------
    layout : Layout

    Returns
    -------
    Triangulation

    Raises
    ------
    ParameterError
        The layout has fewer than three non-coplanar directions (use the 2-D law).

    Examples
    --------
    >>> tri = triangulate(get_layout("ring8"))      # a ring: closed by nadir and zenith
    >>> tri.channels.shape, bool((tri.channels == -1).any(axis=1).all())
    ((16, 3), True)
    """
    from scipy.spatial import ConvexHull, QhullError

    chans = list(layout.panned_channels)
    pts = [layout.speakers[c].direction for c in chans]
    imag: list[NDArray[np.float64]] = [
        np.asarray(v, dtype=np.float64) / np.linalg.norm(v)
        for v in layout.meta.get("imaginary_directions", ())  # type: ignore[attr-defined]
    ]
    z = [float(v[2]) for v in pts + imag]
    if min(z) > -math.sin(math.radians(70.0)):
        imag.append(np.array([0.0, 0.0, -1.0]))
    if max(z) < math.sin(math.radians(70.0)):
        imag.append(np.array([0.0, 0.0, 1.0]))
    allp = np.array(pts + imag)
    labels = np.array(chans + [-1 - k for k in range(len(imag))], dtype=np.int64)
    try:
        hull = ConvexHull(allp)
    except QhullError as exc:
        raise ParameterError(
            f"layout {layout.name!r}: its speaker directions do not span 3-D space ({exc}); "
            f"a horizontal layout uses the 2-D law"
        ) from None
    inv, tri_ch = [], []
    neigh: list[set[int]] = [set() for _ in imag]
    for simplex in hull.simplices:
        m = allp[simplex]
        if abs(np.linalg.det(m)) < 1e-9:  # plane through the listener: cannot pan
            continue
        inv.append(np.linalg.inv(m))
        lab = labels[simplex]
        tri_ch.append(np.where(lab >= 0, lab, -1))
        for v in lab:
            if v < 0:
                neigh[-1 - v].update(int(x) for x in lab if x >= 0)
    return Triangulation(
        np.array(inv),
        np.array(tri_ch, dtype=np.int64),
        tuple(tuple(sorted(s)) for s in neigh),
        np.array(imag).reshape(-1, 3),
    )


def vbap3d_gains(
    layout: Layout, directions: NDArray[np.floating], *, triangulation: Triangulation | None = None
) -> NDArray[np.float64]:
    """3-D VBAP gains (Pulkki 1997) for directions in the listener frame.

    For each direction the triangle whose gains have the largest minimum is
    used (all gains ≥ 0 inside the hull; outside the layout's coverage the
    negative gains are clipped); imaginary speakers' gains are dropped; the
    result is power-normalised (Σ g² = 1).

    Parameters
    ----------
    layout : Layout
        A layout whose directions span 3-D space.
    directions : array_like, shape (N, 3)
        Source directions (forward, left, up), any length but 0.
    triangulation : Triangulation, optional
        The layout's :func:`triangulate` (computed when not given).

    Returns
    -------
    ndarray, shape (n_channels, N)

    Raises
    ------
    ParameterError
        The layout's directions do not span 3-D space.

    Examples
    --------
    >>> dome = make_layout("dome", [Speaker(f"S{k}", 90.0 * k) for k in range(4)]
    ...                    + [Speaker("top", 0.0, 90.0)])
    >>> np.round(vbap3d_gains(dome, np.array([[1.0, 0.0, 1.0]]))[:, 0], 4).tolist()
    [0.7071, 0.0, 0.0, 0.0, 0.7071]
    """
    tri = triangulation if triangulation is not None else triangulate(layout)
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    nrm = np.linalg.norm(d, axis=1, keepdims=True)
    d = d / np.where(nrm > 0, nrm, 1.0)
    g_all = np.einsum("nj,tjk->ntk", d, tri.inverse)  # (N, T, 3)
    best = np.argmax(g_all.min(axis=2), axis=1)
    g = np.clip(g_all[np.arange(d.shape[0]), best], 0.0, None)  # (N, 3)
    ch = tri.channels[best]  # (N, 3)
    g = np.where(ch >= 0, g, 0.0)
    out = np.zeros((layout.n_channels, d.shape[0]))
    cols = np.repeat(np.arange(d.shape[0])[:, None], 3, axis=1)
    np.add.at(out, (np.where(ch >= 0, ch, 0), cols), g)
    power = np.sum(out**2, axis=0)
    dead = power < 1e-24
    if np.any(dead):  # exactly at an imaginary speaker: spread over its hull neighbours
        for n in np.flatnonzero(dead):
            k = int(np.argmax(tri.imaginary_directions @ d[n]))
            out[list(tri.imaginary_neighbours[k]), n] = 1.0
        power = np.sum(out**2, axis=0)
    return out / np.sqrt(power)


def pan_gains(layout: Layout, directions: NDArray[np.floating]) -> NDArray[np.float64]:
    """Panning gains ``(n_channels, N)`` of the layout's own law for listener-frame
    directions ``(N, 3)``: 2-D pairwise VBAP on the azimuth for horizontal
    layouts (elevation ignored), 3-D VBAP for layouts with elevation, 1 for mono,
    the AmbiX encoding gains (SN3D spherical harmonics in ACN order,
    :func:`auralize.spatial.ambisonics.sh_gains`) for ``ambix1..3``.

    Parameters
    ----------
    layout : Layout
        Any layout but ``binaural``.
    directions : array_like, shape (N, 3)
        Source directions (forward, left, up).

    Returns
    -------
    ndarray, shape (n_channels, N)

    Raises
    ------
    ParameterError
        For ``binaural``, which is not a panning law: pan to
        :func:`synthesis_layout` and filter with :func:`output_stage`.

    Examples
    --------
    >>> right = np.array([[0.0, -1.0, 0.0]])
    >>> np.round(pan_gains(get_layout("7.1"), right)[:, 0], 4).tolist()   # SR
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    >>> pan_gains(get_layout("ambix1"), right)[:, 0].tolist()             # W, Y, Z, X
    [1.0, -1.0, 0.0, 0.0]
    """
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    if is_ambisonic(layout):
        from auralize.spatial.ambisonics import sh_gains

        g = sh_gains(int(layout.meta["order"]), d)  # type: ignore[call-overload]
        return g if "acn" not in layout.meta else g[ambix_channels(layout)]
    if is_binaural(layout):
        raise ParameterError(
            "the binaural layout has no panning gains: render to "
            "auralize.spatial.layouts.synthesis_layout(layout) (ambix3) and filter the result with "
            "auralize.spatial.layouts.output_stage(layout, rate, hrtf=...)"
        )
    if layout.n_channels == 1:
        return np.ones((1, d.shape[0]))
    if layout.is_horizontal:
        flat = np.hypot(d[:, 0], d[:, 1]) < 1e-12
        g = vbap_gains(layout, np.arctan2(d[:, 1], d[:, 0]))
        if np.any(flat):  # straight above/below a ring: spread evenly (as the kernel does)
            ch = layout.panned_channels
            g[:, flat] = 0.0
            g[np.ix_(ch, np.flatnonzero(flat))] = 1.0 / math.sqrt(ch.size)
        return g
    return vbap3d_gains(layout, d)


def listener_frame_azimuth(
    direction: NDArray[np.floating], *, forward: NDArray[np.floating], up: NDArray[np.floating]
) -> NDArray[np.float64]:
    """Azimuth of world directions in a listener's frame.

    Parameters
    ----------
    direction : array_like, shape (N, 3)
        World directions (from the listener towards the source).
    forward, up : array_like, shape (N, 3) or (3,)
        The listener's unit forward and up vectors.

    Returns
    -------
    ndarray, shape (N,)
        Radians, counter-clockwise from forward, in [-π, π].

    Examples
    --------
    >>> az = listener_frame_azimuth(np.array([[1.0, 0.0, 0.0]]), forward=[0, 1, 0], up=[0, 0, 1])
    >>> np.degrees(az).tolist()   # +x is on the right of a listener facing +y
    [-90.0]
    """
    d = np.asarray(direction, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(forward, dtype=np.float64).reshape(-1, 3)
    u = np.asarray(up, dtype=np.float64).reshape(-1, 3)
    left = np.cross(u, f)
    return np.arctan2(np.sum(d * left, axis=1), np.sum(d * f, axis=1))


def listener_frame(
    direction: NDArray[np.floating], forward: NDArray[np.floating], up: NDArray[np.floating]
) -> NDArray[np.float64]:
    """World directions expressed in the listener frame (forward, left, up).

    Parameters
    ----------
    direction : array_like, shape (N, 3)
        World directions.
    forward, up : array_like, shape (N, 3) or (3,)
        The listener's unit forward and up vectors.

    Returns
    -------
    ndarray, shape (N, 3)
        Components along forward, left and up.

    Examples
    --------
    >>> listener_frame(np.array([[1.0, 0.0, 0.0]]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])).tolist()
    [[0.0, -1.0, 0.0]]
    """
    d = np.asarray(direction, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(forward, dtype=np.float64).reshape(-1, 3)
    u = np.asarray(up, dtype=np.float64).reshape(-1, 3)
    left = np.cross(u, f)
    return np.stack([np.sum(d * f, 1), np.sum(d * left, 1), np.sum(d * u, 1)], axis=1)


# ------------------------------------------------------------ downmix
def downmix_matrix(src: Layout | str, dst: Layout | str) -> NDArray[np.float64]:
    """Matrix ``(dst.n_channels, src.n_channels)`` folding one layout into another.

    Each source speaker is re-panned to its own direction with the target
    layout's law (power-preserving for uncorrelated channels); an LFE channel
    goes to the target's LFE if it has one, else equally (in power) to every
    panned target speaker.  ``dst @ audio`` applies it to ``(n_ch, n)`` audio.

    An AmbiX source is decoded (:func:`auralize.spatial.ambisonics.decoder_matrix`,
    AllRAD with max-rE weights); an AmbiX target encodes each source speaker
    as a plane wave from its direction (LFE into W); AmbiX to AmbiX keeps the
    common orders.  Binaural targets need filters, not a matrix (error).

    Parameters
    ----------
    src, dst : Layout or str
        Source and target layouts (:func:`get_layout`).

    Returns
    -------
    ndarray, shape (dst.n_channels, src.n_channels)

    Raises
    ------
    ParameterError
        A binaural target; unknown layouts.

    Examples
    --------
    >>> np.round(downmix_matrix("5.1", "stereo"), 4)
    array([[1.    , 0.    , 0.7071, 0.7071, 1.    , 0.    ],
           [0.    , 1.    , 0.7071, 0.7071, 0.    , 1.    ]])
    """
    s, d = get_layout(src), get_layout(dst)
    for lay in (s, d):
        if is_ambisonic(lay) and "acn" in lay.meta:  # a subset of the harmonics
            full = ambix_layout(int(lay.meta["order"]))  # type: ignore[call-overload]
            if lay is s:
                return downmix_matrix(full, d)[:, ambix_channels(s)]
            return downmix_matrix(s, full)[ambix_channels(d)]
    if is_binaural(d):
        raise ParameterError(
            f"cannot fold {s.name!r} into binaural with a matrix: ear signals need HRIR "
            f"filtering (auralize.spatial.hrtf)"
        )
    if is_ambisonic(s):
        order = int(s.meta["order"])  # type: ignore[call-overload]
        if is_ambisonic(d):  # truncate or zero-pad the orders
            m = np.eye(d.n_channels, s.n_channels)
            return m
        from auralize.spatial.ambisonics import decoder_matrix

        return np.array(decoder_matrix(order, d))
    m = np.zeros((d.n_channels, s.n_channels))
    lfe_dst = [c for c, sp in enumerate(d.speakers) if sp.azimuth_deg is None]
    for c, sp in enumerate(s.speakers):
        if sp.azimuth_deg is None:
            if lfe_dst:
                m[lfe_dst[0], c] = 1.0
            elif is_ambisonic(d):  # omnidirectional: W only
                m[0, c] = 1.0
            else:
                ch = d.panned_channels if d.n_channels > 1 else np.array([0])
                m[ch, c] = 1.0 / math.sqrt(ch.size)
            continue
        m[:, c] = pan_gains(d, sp.direction[None, :])[:, 0]
    return m


def downmix_target(layout: Layout | str, max_channels: int) -> Layout:
    """The largest built-in layout (7.1, 5.1, stereo, mono) fitting ``max_channels``.

    Parameters
    ----------
    layout : Layout or str
        The layout to be folded (not used: the targets are the same for all).
    max_channels : int
        Channels of the device.

    Returns
    -------
    Layout

    Raises
    ------
    ParameterError
        ``max_channels`` < 1.

    Examples
    --------
    >>> downmix_target("ring8", 6).name, downmix_target("ring8", 3).name
    ('5.1', 'stereo')
    """
    for name in ("7.1", "5.1", "stereo", "mono"):
        lay = BUILTIN_LAYOUTS[name]
        if lay.n_channels <= max_channels:
            return lay
    raise ParameterError(f"cannot downmix to {max_channels} channels")


# ------------------------------------------------------------ alignment
class SpeakerAlignment:
    """Delay and attenuate nearer speakers so every speaker is heard as if at the
    distance of the farthest one (time- and level-aligned at the listener).

    Speaker c at distance d_c gets delay ``round((d_max - d_c)/c0 · rate)``
    samples and gain ``d_c / d_max`` (1/r law), times the layout's
    :attr:`Layout.channel_gains` (an IEM layout's per-speaker ``Gain``).
    Speakers without a distance are taken at d_max.  Processing is stateful,
    so consecutive blocks give exactly the same samples as the whole signal
    (:meth:`process`).

    Parameters
    ----------
    layout : Layout
    rate : float
        Sample rate, Hz.
    c0 : float
        Speed of sound turning distances into delays, m/s.

    Raises
    ------
    ParameterError
        A rate that is not a positive number.

    Examples
    --------
    >>> from auralize.spatial.layouts import Layout, Speaker
    >>> lay = Layout("x", (Speaker("A", 0.0, 0.0, 2.0), Speaker("B", 90.0, 0.0, 1.0)))
    >>> al = SpeakerAlignment(lay, 343)
    >>> al.delays.tolist(), al.gains.tolist()
    ([0, 1], [1.0, 0.5])
    """

    def __init__(self, layout: Layout, rate: float, *, c0: float = C0_ALIGN) -> None:
        if not (math.isfinite(rate) and rate > 0):
            raise ParameterError(f"rate must be > 0 Hz, got {rate!r}")
        dist = [s.distance_m for s in layout.speakers]
        d_max = max((x for x in dist if x is not None), default=1.0)
        dd = np.array([d_max if x is None else x for x in dist], dtype=np.float64)
        self.delays = np.round((d_max - dd) / c0 * rate).astype(np.int64)
        self.gains = dd / d_max
        if layout.channel_gains is not None:
            self.gains = self.gains * layout.channel_gains
        self.active = bool(np.any(self.delays > 0) or np.any(self.gains != 1.0))
        self._tail = np.zeros((layout.n_channels, int(self.delays.max(initial=0))))

    def process(self, block: NDArray[np.floating]) -> NDArray[np.float64]:
        """Aligned copy of the next block (state carried to the next block).

        Parameters
        ----------
        block : array_like, shape (n_channels, n)
            The next samples of every channel.

        Returns
        -------
        ndarray, shape (n_channels, n)

        Examples
        --------
        >>> lay = Layout("x", (Speaker("A", 0.0, 0.0, 3.0), Speaker("B", 90.0, 0.0, 1.0)))
        >>> al = SpeakerAlignment(lay, 343)   # B is 2 m nearer: 2 samples later, 1/3 as loud
        >>> x = np.array([[1.0, 2, 3], [3.0, 6, 9]])
        >>> np.hstack([al.process(x[:, :2]), al.process(x[:, 2:])]).tolist()
        [[1.0, 2.0, 3.0], [0.0, 0.0, 1.0]]
        """
        b = np.asarray(block, dtype=np.float64)
        if not self.active:
            return b
        n = b.shape[1]
        out = np.empty_like(b)
        for c in range(b.shape[0]):
            k = int(self.delays[c])
            x = np.concatenate([self._tail[c, -k:] if k else np.zeros(0), b[c]])
            out[c] = self.gains[c] * x[:n]
            if k:
                self._tail[c, -k:] = x[n:]
        return out


def align_speakers(
    audio: NDArray[np.floating], layout: Layout, rate: float, *, c0: float = C0_ALIGN
) -> NDArray[np.float64]:
    """Apply :class:`SpeakerAlignment` to a whole signal.

    Parameters
    ----------
    audio : array_like, shape (n_channels, n)
        The layout's channels.
    layout : Layout
    rate : float
        Sample rate, Hz.
    c0 : float
        Speed of sound, m/s.

    Returns
    -------
    ndarray, shape (n_channels, n)
        Same length: the last ≤ max-delay samples of delayed channels are cut.

    Examples
    --------
    >>> lay = Layout("x", (Speaker("A", 0.0, 0.0, 2.0), Speaker("B", 90.0, 0.0, 1.0)))
    >>> align_speakers(np.ones((2, 3)), lay, 343).tolist()
    [[1.0, 1.0, 1.0], [0.0, 0.5, 0.5]]
    """
    return SpeakerAlignment(layout, rate, c0=c0).process(audio)


# ------------------------------------------------------------ immersive output
def synthesis_layout(layout: Layout | str) -> Layout:
    """The layout a renderer pans to.

    The layout itself, or for ``binaural`` the intermediate that
    :func:`output_stage` turns into ears: with the built-in head its two ear
    receivers (:func:`auralize.spatial.hrtf.ear_layout`), with an HRIR set
    (:func:`default_hrtf`) the AmbiX layout ``ambix3``.

    Parameters
    ----------
    layout : Layout or str

    Returns
    -------
    Layout

    Examples
    --------
    >>> synthesis_layout("5.1").name, synthesis_layout("binaural").name
    ('5.1', 'binaural-ears')
    """
    lay = get_layout(layout)
    if is_binaural(lay):
        if _HRTF.get() is None:
            from auralize.spatial.hrtf import ear_layout

            return ear_layout()
        return IMMERSIVE_LAYOUTS[str(lay.meta["intermediate"])]
    return lay


class OutputStage:
    """From the channels of :func:`synthesis_layout` to the layout's own channels.

    Identity for every layout but ``binaural``, whose stage is a decoder
    (stateful: consecutive blocks give the samples of the whole signal).
    Build with :func:`output_stage`.

    :attr:`synthesis_layout` is what renderers pan to.  For ``binaural``:

    * with the built-in spherical head (no ``hrtf``), the two ear receivers
      of :func:`auralize.spatial.hrtf.ear_layout`, each rendered with its own
      retarded time, decoded by :class:`auralize.spatial.hrtf.EarDecoder`;
    * with an HRIR set or SOFA file, the harmonics of ``ambix3`` whose filters
      are not zero (all 16 for a measured set), decoded by
      :class:`auralize.spatial.hrtf.BinauralDecoder`; :meth:`process` also
      takes the whole ``ambix3``.

    Parameters
    ----------
    layout : Layout
        The output layout.
    rate : int
        Sample rate, Hz.
    hrtf : HRIRSet, str or Path, optional
        See :func:`output_stage`.

    Raises
    ------
    ParameterError
        An ``hrtf`` for a layout other than binaural.
    MissingFileError
        A SOFA file that does not exist.
    FormatError
        A SOFA file that cannot be read.

    Examples
    --------
    >>> st = OutputStage(get_layout("ring8"), 48000)
    >>> st.synthesis_layout.name, st.history, st.describe()
    ('ring8', 0, {})
    """

    def __init__(self, layout: Layout, rate: int, *, hrtf: object = None) -> None:
        self.layout = layout
        self.synthesis_layout = synthesis_layout(layout)
        self.rate = int(rate)
        self.decoder = None
        self._pos = -1  # next input sample of process_at's stream (-1: none yet)
        if hrtf is None and is_binaural(layout):
            hrtf = _HRTF.get()
        if is_binaural(layout) and hrtf is None:
            from auralize.spatial.hrtf import EarDecoder

            self.decoder = EarDecoder(self.rate)
            self.synthesis_layout = self.decoder.layout
        elif is_binaural(layout):
            from auralize.spatial.hrtf import BinauralDecoder, HRIRSet

            self.synthesis_layout = IMMERSIVE_LAYOUTS[str(layout.meta["intermediate"])]
            if isinstance(hrtf, HRIRSet):
                hrirs = hrtf
            else:
                from auralize.spatial.sofa import read_sofa

                hrirs = read_sofa(hrtf)  # type: ignore[arg-type]
            self.decoder = BinauralDecoder(hrirs, BINAURAL_ORDER, rate=self.rate)
            if self.decoder.channels.size < self.decoder.n_in:  # harmonics with zero filters
                self.synthesis_layout = ambix_layout(BINAURAL_ORDER, self.decoder.channels)
        elif hrtf is not None:
            raise ParameterError(
                f"an HRTF only applies to the binaural layout, not to {layout.name!r}"
            )

    def describe(self) -> dict[str, object]:
        """What the stage does, for a sidecar (empty for speaker layouts).

        Returns
        -------
        dict
            ``{"binaural": decoder description}`` or ``{}``.

        Examples
        --------
        >>> sorted(output_stage("binaural", 8000).describe()["binaural"])[:3]
        ['bulk_delay_s', 'decoder', 'ear_azimuth_deg']
        """
        if self.decoder is None:
            return {}
        return {"binaural": self.decoder.describe()}

    def process(self, block: NDArray[np.floating]) -> NDArray[np.float64]:
        """Output channels of the next rendered block (filter state carried on).

        Parameters
        ----------
        block : array_like, shape (synthesis_layout.n_channels, n)
            Rendered channels.

        Returns
        -------
        ndarray, shape (layout.n_channels, n)

        Examples
        --------
        >>> output_stage("ring8", 48000).process(np.ones((8, 4))).shape
        (8, 4)
        """
        if self.decoder is None:
            return np.asarray(block, dtype=np.float64)
        return self.decoder.process(block)

    @property
    def history(self) -> int:
        """Input samples the stage remembers (its filters' length − 1; 0 for identity).

        Examples
        --------
        >>> output_stage("ring8", 48000).history, output_stage("binaural", 8000).history
        (0, 63)
        """
        return 0 if self.decoder is None else int(self.decoder.filters.shape[2]) - 1

    def process_at(
        self, start: int, n: int, render: Callable[[int, int], NDArray[np.float64]]
    ) -> NDArray[np.float64]:
        """Output samples ``[start, start + n)`` of a stream rendered on demand.

        ``render(s, m)`` gives the :attr:`synthesis_layout` samples ``[s, s + m)``.
        Consecutive calls carry the filter state; after a jump (a seek, the
        first call) the state is rebuilt from the :attr:`history` samples before
        ``start``, so any call returns the samples of one whole render.

        Parameters
        ----------
        start : int
            First output sample.
        n : int
            Number of samples.
        render : callable
            ``render(s, m)`` returns the rendered samples ``[s, s + m)``,
            ``(synthesis_layout.n_channels, m)``.

        Returns
        -------
        ndarray, shape (layout.n_channels, n)

        Examples
        --------
        >>> st = output_stage("binaural", 8000)
        >>> sig = np.random.default_rng(1).standard_normal((8, 400))
        >>> render = lambda s, m: sig[:, s : s + m]
        >>> whole = st.process_at(0, 400, render)
        >>> bool(np.allclose(st.process_at(250, 150, render), whole[:, 250:], atol=1e-5))  # a seek
        True
        """
        if self.decoder is None:
            return render(start, n)
        if start != self._pos:
            self.decoder.reset()
            h = min(self.history, start)
            if h > 0:
                self.decoder.process(render(start - h, h))
        out = self.decoder.process(render(start, n))
        self._pos = start + n
        return out

    def finish(self, rendered: Any) -> Any:
        """A whole render of the :attr:`synthesis_layout` as a render of :attr:`layout`.

        Filtered from a clear state, ``meta`` updated with :meth:`describe`.

        Parameters
        ----------
        rendered : Rendered
            A :class:`auralize.emitters.synthesis.Rendered` of the
            :attr:`synthesis_layout` (changed in place).

        Returns
        -------
        Rendered
            ``rendered``, now of :attr:`layout`.

        Examples
        --------
        >>> from auralize.emitters.synthesis import Rendered
        >>> st = output_stage("binaural", 8000)
        >>> r = st.finish(Rendered(np.zeros((8, 100)), 8000, st.synthesis_layout))
        >>> r.layout.name, r.audio.shape
        ('binaural', (2, 100))
        """
        if self.decoder is None:
            rendered.layout = self.layout
            return rendered
        self.decoder.reset()
        rendered.audio = self.decoder.process(rendered.audio)
        self._pos = -1
        rendered.layout = self.layout
        rendered.meta.update(self.describe())
        return rendered


#: the HRTF of :func:`output_stage` when none is given (see :func:`default_hrtf`)
_HRTF: contextvars.ContextVar[object] = contextvars.ContextVar("auralize_hrtf", default=None)


@contextlib.contextmanager
def default_hrtf(hrtf: object) -> Iterator[None]:
    """Within the block, binaural output stages built without an ``hrtf`` use this one.

    The command line's ``--hrtf`` sets it.

    Parameters
    ----------
    hrtf : HRIRSet, str, Path or None
        An :class:`auralize.spatial.hrtf.HRIRSet` or a SOFA file; None: the
        built-in spherical head.

    Yields
    ------
    None

    Examples
    --------
    >>> from auralize.spatial.hrtf import spherical_head_hrirs
    >>> with default_hrtf(spherical_head_hrirs(rate=8000)):
    ...     synthesis_layout("binaural").name
    'ambix3'
    >>> synthesis_layout("binaural").name
    'binaural-ears'
    """
    token = _HRTF.set(hrtf)
    try:
        yield
    finally:
        _HRTF.reset(token)


def output_stage(layout: Layout | str, rate: int, *, hrtf: object = None) -> OutputStage:
    """The stage after panning for ``layout`` at ``rate`` Hz.

    Parameters
    ----------
    layout : Layout or str
    rate : int
        Sample rate of the rendered audio (HRIRs are resampled to it).
    hrtf : HRIRSet, str or Path, optional
        Binaural only: an HRIR set or a SOFA file (default the built-in
        spherical-head model).

    Returns
    -------
    OutputStage

    Raises
    ------
    ParameterError
        An unknown layout, or an ``hrtf`` for a layout other than binaural.
    MissingFileError
        A SOFA file that does not exist.
    FormatError
        A SOFA file that cannot be read.

    Examples
    --------
    >>> st = output_stage("binaural", 8000)
    >>> st.synthesis_layout.name, st.synthesis_layout.n_channels
    ('binaural-ears', 8)
    >>> st.process(np.zeros((8, 480))).shape
    (2, 480)
    """
    return OutputStage(get_layout(layout), rate, hrtf=hrtf)


def flac_mask_warning(layout: Layout | str) -> str | None:
    """The warning to print when ``layout`` is written to FLAC, or None.

    FLAC carries no WAVE channel mask: players take the standard channel
    assignment for the channel count (1–8 channels), so a layout without a
    standard mask (ring8, custom and AmbiX layouts) may be routed as if it were
    5.1/7.1 (AmbiX and >8 channels may not be played at all).

    Parameters
    ----------
    layout : Layout or str

    Returns
    -------
    str or None

    Examples
    --------
    >>> flac_mask_warning("5.1") is None
    True
    >>> flac_mask_warning("ring8")
    "layout 'ring8' is a non-standard 8-channel layout: FLAC cannot record its channel positions, ..."
    """
    lay = get_layout(layout)
    if lay.channel_mask is not None and lay.n_channels <= 8:
        return None
    what = (
        f"AmbiX order {lay.meta.get('order')} (ACN/SN3D)"
        if is_ambisonic(lay)
        else f"a non-standard {lay.n_channels}-channel layout"
    )
    guess = {6: "5.1", 8: "7.1"}.get(lay.n_channels)
    return (
        f"layout {lay.name!r} is {what}: FLAC cannot record its channel positions, so "
        f"players may route its channels as the standard {lay.n_channels}-channel layout"
        + (f" ({guess})" if guess else "")
        + "; write WAV (with the sidecar) to keep them, or decode first"
    )
