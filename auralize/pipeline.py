"""The core pipeline as plain functions: load -> map -> detect -> synthesize -> write.

This is the Python API behind the ``auralize`` command; each CLI sub-command
is a thin wrapper over one of these.

Examples
--------
>>> import auralize.pipeline as ap
>>> vol = ap.load("dataset:monopole", size=16, steps=40)
>>> path = ap.ListenerPath.point(vol.center + [1.0, 0, 0], duration=0.02)
>>> out, _ = ap.auralize(vol, path, time_scale="auto")
>>> out.audio.shape, out.meta["time_mapping"], out.meta["heard"]
((1, 882), '1 s of playback = 1.22 s of data', 'field')
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import KW_ONLY, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from auralize.datasets.opener import load as load
from auralize.datasets.synthetic import DEFAULT_MAPPING
from auralize.defaults import DEFAULTS, Interp, Method, OrbitFace, Timbre
from auralize.emitters import RATE_RANGE_HZ
from auralize.emitters.synthesis import (
    C0,
    Rendered,
    box_distances,
    check_arrival,
    check_distance,
    source_extent,
)
from auralize.errors import FieldError, ParameterError
from auralize.listener import SWEEP_TURNS, ListenerPath, describe_path, orbit_around
from auralize.rendering import Carry, RenderBlocks, render
from auralize.runtime.progress import progress_step
from auralize.runtime.resources import audio_bytes, memory_guard, require_memory
from auralize.sources.detection import (
    TYPES,
    SourceSeries,
    SourceTracks,
    Thresholds,
    detect,
    require_steps,
)
from auralize.sources.field import FLOOR, Heard, field_tracks, parse_heard
from auralize.sources.mapping import ROLE_NAMES, AcousticMapping, get_mapping, match_field
from auralize.spatial.layouts import get_layout
from auralize.volume import TimeVolume

if TYPE_CHECKING:
    from auralize.audio.output import Normalize, SampleFormat

__all__ = [
    "DEFAULT_DURATION",
    "Carry",
    "Heard",
    "HeardSound",
    "ListenerPath",
    "Planner",
    "RenderBlocks",
    "RenderPlan",
    "Thresholds",
    "auralize",
    "auto_mapping",
    "describe_time_scale",
    "detect_sources",
    "heard_sound",
    "heard_tracks",
    "load",
    "plan_heard",
    "plan_render",
    "render",
    "report_line",
    "resolve_mapping",
    "save_rendered",
]

#: playback seconds of a render without --duration or --path
DEFAULT_DURATION = DEFAULTS.duration
#: the default orbit is slowed to at most this fraction of c0 in data time
MAX_ORBIT_MACH = 0.1
_UNITS = (
    (365.25 * 86400, "years"),
    (86400.0, "days"),
    (3600.0, "h"),
    (60.0, "min"),
    (1.0, "s"),
    (1e-3, "ms"),
    (1e-6, "µs"),
    (1e-9, "ns"),
)


def auto_mapping(volume: TimeVolume) -> str:
    """The mapping preset a volume most likely wants.

    Built-in datasets name theirs; a log10-density field means the paper's
    mapping; density plus momentum means ``cfd``; pressure without density
    (incompressible CFD such as OpenFOAM's ``p`` and ``U``) means
    ``incompressible``; otherwise ``identity``.  Field roles are found by
    :func:`auralize.sources.mapping.match_field`.

    Parameters
    ----------
    volume : TimeVolume
        The data (their ``attrs["dataset"]`` and field names are read).

    Returns
    -------
    str
        A preset of :func:`auralize.sources.mapping.get_mapping`.

    Examples
    --------
    >>> auto_mapping(load("dataset:monopole", size=12, steps=8))
    'identity'
    """
    ds = volume.attrs.get("dataset")
    if isinstance(ds, str) and ds in DEFAULT_MAPPING:
        return DEFAULT_MAPPING[ds]
    role = {r: match_field(volume, r) for r in ROLE_NAMES}
    if role["log10_density"] is not None and role["density"] is None:
        return "paper-density"
    if role["density"] is not None and role["momentum"] is not None:
        return "cfd"
    if role["density"] is None and role["pressure"] is not None:
        return "incompressible"
    return "identity"


#: The field-name options of each preset and the role each one plays.
PRESET_ROLES = {
    "identity": {"density": "density", "velocity": "velocity"},
    "cfd": {"density": "density", "momentum": "momentum", "velocity": "velocity"},
    "incompressible": {"pressure": "pressure", "velocity": "velocity"},
    "paper-density": {"field": "log10_density"},
}


def _mapping_for_options(names: dict[str, str]) -> str | None:
    """The preset that field options given without ``--mapping`` ask for, if any.

    A density field means density is known (``cfd`` with momentum, else
    ``identity``); a pressure field without density means ``incompressible``;
    a log10-density field means the paper's mapping.
    """
    if "density" in names:
        return "cfd" if "momentum" in names else "identity"
    if "field" in names:
        return "paper-density"
    if "pressure" in names:
        return "incompressible"
    return None


def resolve_mapping(
    volume: TimeVolume, mapping: str | AcousticMapping | None = None, **mapping_fields: str
) -> AcousticMapping:
    """The mapping for ``volume``: the preset (default :func:`auto_mapping`) with its
    field names matched to the volume's fields where not given.

    Field options given without a preset choose one (a density field:
    ``identity``, with momentum ``cfd``; a pressure field ``incompressible``;
    a log10-density field the paper's).  ``identity`` without a density
    field takes the first scalar field as density (and logs so).

    Parameters
    ----------
    volume : TimeVolume
        The data.
    mapping : str or AcousticMapping, optional
        A preset name (``identity``, ``cfd``, ``incompressible``,
        ``paper-density``, ...), a mapping object (used as it is), or None
        (:func:`auto_mapping`).
    **mapping_fields : str
        Field names of the preset's roles (``density``, ``momentum``,
        ``velocity``, ``pressure``, ``field``); empty ones are ignored.

    Returns
    -------
    AcousticMapping

    Raises
    ------
    FieldError
        A named field that is not a field of the volume.
    ParameterError
        An unknown preset, or a field option the preset does not take
        (:func:`auralize.sources.mapping.get_mapping`).

    Examples
    --------
    >>> vol = load("dataset:monopole", size=12, steps=8)
    >>> resolve_mapping(vol).describe()
    {'name': 'identity', 'density': 'density', 'velocity': 'velocity'}
    """
    if isinstance(mapping, AcousticMapping) or callable(mapping):
        return get_mapping(mapping, **mapping_fields)
    names = {k: v for k, v in mapping_fields.items() if v}
    for option, field_name in names.items():  # a field named by the user must exist
        if field_name not in volume.fields:
            flag = "--log-density-field" if option == "field" else f"--{option}-field"
            raise FieldError(
                f"{volume.source}: {flag} {field_name!r} is not a field of the volume; it has "
                f"{volume.field_names}"
            )
    name = mapping or _mapping_for_options(names) or auto_mapping(volume)
    for option, role in PRESET_ROLES.get(name, {}).items():
        if option not in names:
            found = match_field(volume, role)
            if found is not None:
                names[option] = found
    if name == "identity" and "density" not in names:
        scalar = next((f for f in volume.field_names if not volume.is_vector(f)), None)
        if scalar is not None:
            # no field is named like a density: sonify the first scalar field as one
            logging.getLogger("auralize").info(
                "%s: no density field; taking the scalar field %r as density (choose with "
                "--density-field NAME)",
                volume.source,
                scalar,
            )
            names["density"] = scalar
    return get_mapping(name, **names)


def volume_arg(volume: Any, who: str) -> TimeVolume:
    """``volume`` as a :class:`TimeVolume`: one already, or a file name / ``"dataset:NAME"``
    opened with :func:`load`; anything else is a :class:`ParameterError`.

    Parameters
    ----------
    volume : TimeVolume, str or PathLike
        The data, or where they are.
    who : str
        The function asking (named in the error).

    Returns
    -------
    TimeVolume

    Raises
    ------
    ParameterError
        Anything else than a volume or a file name.
    MissingFileError, FormatError, DataError
        A file that is missing, unreadable or holds no usable time series
        (:func:`load`).

    Examples
    --------
    >>> vol = load("dataset:monopole", size=12, steps=8)
    >>> volume_arg(vol, "auralize") is vol
    True
    >>> volume_arg(3, "auralize")
    Traceback (most recent call last):
    ...
    auralize.errors.ParameterError: auralize needs a TimeVolume (auralize.load(FILE) opens one) or a file name, got int 3
    """
    if isinstance(volume, TimeVolume):
        return volume
    if isinstance(volume, str | os.PathLike):
        return load(os.fspath(volume))
    raise ParameterError(
        f"{who} needs a TimeVolume (auralize.load(FILE) opens one) or a file "
        f"name, got {type(volume).__name__} {volume!r:.60}"
    )


def check_rate(rate: Any) -> int:
    """``rate`` as an output sample rate: a whole number of Hz in :data:`RATE_RANGE_HZ`.

    Parameters
    ----------
    rate : int
        Sample rate, Hz (a Python or numpy integer; not a bool, not a float).

    Returns
    -------
    int

    Raises
    ------
    ParameterError
        Not a whole number in 8000..768000.

    Examples
    --------
    >>> check_rate(48000)
    48000
    >>> check_rate(44100.0)
    Traceback (most recent call last):
    ...
    auralize.errors.ParameterError: rate must be a whole number of Hz in 8000..768000, got 44100.0
    """
    lo, hi = RATE_RANGE_HZ
    if isinstance(rate, bool) or not isinstance(rate, int | np.integer) or not lo <= rate <= hi:
        raise ParameterError(f"rate must be a whole number of Hz in {lo}..{hi}, got {rate!r}")
    return int(rate)


def check_listener(listener: Any) -> NDArray[np.float64]:
    """A fixed listener position: three finite numbers x, y, z in metres.

    Parameters
    ----------
    listener : array_like
        Three numbers (a sequence or an array of 3 elements).

    Returns
    -------
    (3,) float

    Raises
    ------
    ParameterError
        Not three finite numbers.

    Examples
    --------
    >>> check_listener([1, 2, 3]).tolist()
    [1.0, 2.0, 3.0]
    """
    try:
        p = np.asarray(listener, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        p = np.full(3, np.nan)
    if not np.all(np.isfinite(p)):
        raise ParameterError(
            f"listener must be three finite numbers x, y, z in metres, got {listener!r:.80}"
        )
    return p


def detect_sources(
    volume: TimeVolume,
    *,
    mapping: str | AcousticMapping | None = None,
    thresholds: Thresholds | None = None,
    progress_bar: bool = False,
    **mapping_fields: str,
) -> SourceSeries:
    """Detect sources with ``mapping`` (default :func:`auto_mapping`).

    Source types the mapping cannot compute (e.g. no velocity field: no
    dipoles or quadrupoles) are listed in ``series.meta["unavailable"]``
    (``{type: reason}``), and the volume's valid-point ratio in
    ``series.meta["valid_ratio"]``.

    Parameters
    ----------
    volume : TimeVolume, str or PathLike
        The data (a file name is opened: :func:`volume_arg`).
    mapping : str or AcousticMapping, optional
        As :func:`resolve_mapping`.
    thresholds : Thresholds, optional
        Detection thresholds per type (default ``auto`` for each).
    progress_bar : bool
        Show a progress bar on the terminal.
    **mapping_fields : str
        As :func:`resolve_mapping`.

    Returns
    -------
    SourceSeries
        The sources of every step (:func:`auralize.sources.detection.detect`).

    Raises
    ------
    ParameterError
        ``thresholds`` not a :class:`Thresholds`, a bad mapping, or a
        volume of fewer than 3 steps.
    FieldError
        A named field missing from the volume.
    ResourceError
        More memory than the machine has.

    Examples
    --------
    >>> series = detect_sources(load("dataset:monopole", size=12, steps=8))
    >>> series.meta["valid_ratio"], sorted(series.counts()[3])
    (1.0, ['dipole', 'monopole', 'quadrupole'])
    """
    volume = volume_arg(volume, "detect_sources")
    if thresholds is not None and not isinstance(thresholds, Thresholds):
        raise ParameterError(
            f"thresholds must be a Thresholds(monopole, dipole, quadrupole), got {thresholds!r}"
        )
    m = resolve_mapping(volume, mapping, **mapping_fields)
    with memory_guard(f"detecting sources in {volume.source}"):
        series = detect(volume, mapping=m, thresholds=thresholds, progress_bar=progress_bar)
    unavailable = m.unavailable(volume)
    if unavailable:
        series.meta["unavailable"] = unavailable
    series.meta["valid_ratio"] = volume.valid_ratio
    return series


def format_data_time(seconds: float, *, physical: bool = True, frame_hz: float = 30.0) -> str:
    """``seconds`` of data time in a readable unit (``6.3 days``); frames when the
    data have no physical times (taken as frames at ``frame_hz``).

    Parameters
    ----------
    seconds : float
        Data seconds.
    physical : bool
        The data have physical times (False: frame numbers).
    frame_hz : float
        Frames per second of data without physical times.

    Returns
    -------
    str
        Three significant digits and a unit (years to ns, or frames).

    Examples
    --------
    >>> format_data_time(545000.0), format_data_time(2e-5), format_data_time(2.0, physical=False)
    ('6.31 days', '20 µs', '60 frames')
    """
    if not physical:
        return f"{seconds * frame_hz:.3g} frames"
    a = abs(seconds)
    for size, name in _UNITS:
        if a >= size:
            return f"{seconds / size:.3g} {name}"
    return f"{seconds:.3g} s"


def describe_time_scale(time_scale: float, *, physical: bool = True) -> str:
    """``1 s of playback = 6.3 days of data`` for a time scale (playback s per data s).

    Parameters
    ----------
    time_scale : float
        Playback seconds per data second (> 0).
    physical : bool
        The data have physical times (False: frames, :func:`format_data_time`).

    Returns
    -------
    str

    Examples
    --------
    >>> describe_time_scale(0.5)
    '1 s of playback = 2 s of data'
    """
    return f"1 s of playback = {format_data_time(1.0 / time_scale, physical=physical)} of data"


@dataclass
class RenderPlan:
    """Where the listener is and how data time maps to playback time (:func:`plan_render`).

    Parameters
    ----------
    path : ListenerPath
        The listener, in playback time.
    time_scale : float
        Playback seconds per data second.
    duration : float
        Playback seconds rendered.
    lead : float
        Data seconds of sound travel skipped at the start (the output starts
        when the first sound can arrive).
    auto : bool
        The time scale was chosen to fit the data in ``duration``.
    default_listener : bool
        The listener was placed by :func:`plan_render`.
    physical_times : bool
        The data have physical times (False: frame numbers, for the texts).
    notes : list of str
        What the user should be told (clipping, placement).

    Examples
    --------
    >>> plan = plan_render(load("dataset:monopole", size=12, steps=8), duration=2.0)
    >>> plan.duration, plan.auto, plan.default_listener, plan.path.duration
    (2.0, True, True, 2.0)
    """

    path: ListenerPath
    _: KW_ONLY
    time_scale: float
    duration: float
    lead: float
    auto: bool
    default_listener: bool
    physical_times: bool = True
    notes: list[str] = field(default_factory=list)

    @property
    def mapping_text(self) -> str:
        """The time mapping in words (:func:`describe_time_scale`).

        Examples
        --------
        >>> plan = plan_render(load("dataset:monopole", size=12, steps=8), time_scale=1000.0,
        ...                    duration=0.01, clip=False)
        >>> plan.mapping_text
        '1 s of playback = 1 ms of data'
        """
        return describe_time_scale(self.time_scale, physical=self.physical_times)

    def as_dict(self) -> dict[str, Any]:
        """The plan as a render's ``meta`` (and sidecar) records it.

        Returns
        -------
        dict
            ``time_scale``, ``time_scale_auto``, ``data_seconds_per_playback_second``,
            ``time_mapping``, ``duration_s``, ``lead_data_s``, ``default_listener``,
            ``listener`` (:func:`auralize.listener.describe_path`) and ``notes``.

        Examples
        --------
        >>> plan = plan_render(load("dataset:monopole", size=12, steps=8), duration=2.0)
        >>> sorted(plan.as_dict())[:4]
        ['data_seconds_per_playback_second', 'default_listener', 'duration_s', 'lead_data_s']
        """
        return {
            "time_scale": self.time_scale,
            "time_scale_auto": self.auto,
            "data_seconds_per_playback_second": 1.0 / self.time_scale,
            "time_mapping": self.mapping_text,
            "duration_s": self.duration,
            "lead_data_s": self.lead,
            "default_listener": self.default_listener,
            "listener": describe_path(self.path),
            "notes": list(self.notes),
        }


def source_box(volume: TimeVolume, tracks: SourceTracks | None) -> tuple[np.ndarray, np.ndarray]:
    """``(lo, hi)``: the box a render plans around: the detected sources' (``tracks``),
    else the data's bounds (the whole field).

    Parameters
    ----------
    volume : TimeVolume
        The data.
    tracks : SourceTracks, optional
        The detected sources (None or none: the data's box).

    Returns
    -------
    lo, hi : (3,) float
        The box's corners, m.

    Examples
    --------
    >>> lo, hi = source_box(load("dataset:monopole", size=12, steps=8), None)
    >>> lo.tolist(), hi.tolist()
    ([0.0, 0.0, 0.0], [2.75, 2.75, 2.75])
    """
    if tracks is not None and tracks.n_sources:
        lo, hi, _ = source_extent(tracks)
        return lo, hi
    b = np.asarray(volume.bounds, dtype=np.float64).reshape(3, 2)
    return b[:, 0], b[:, 1]


def plan_render(
    volume: TimeVolume,
    tracks: SourceTracks | None = None,
    *,
    path: ListenerPath | None = None,
    listener: Any = None,
    duration: float | None = None,
    time_scale: float | str = DEFAULTS.time_scale,
    c0: float = C0,
    clip: bool = True,
    face: OrbitFace = DEFAULTS.orbit_face,
) -> RenderPlan:
    """Choose the listener (if none is given), the time scale and the output window.

    * No ``path`` and no ``listener``: an orbit around the data
      (:func:`auralize.listener.orbit_around`), one turn unless that would
      move faster than :data:`MAX_ORBIT_MACH` × c0 in data time; ``face``
      as :meth:`auralize.listener.ListenerPath.orbit` (default ``"sweep"``:
      the head turns so that the data pass around the listener, so
      every speaker of a layout carries them).
    * ``duration``: playback seconds (default the path's length, else
      :data:`DEFAULT_DURATION`).
    * ``time_scale="auto"``: the data's span, plus the spread of arrival
      delays between the nearest and the farthest source, plays in
      ``duration``, whatever the data's time unit.  A number is kept; a
      ``duration`` beyond the data's sound is clipped (with a note), so no
      render ends in silence; ``clip=False`` keeps it (a scene, whose other
      sounds may last longer than the data's).
    * The output starts when the first sound can arrive: ``lead`` = nearest
      distance from the path to the sources' box / c0.

    Parameters
    ----------
    volume : TimeVolume
        The data (their times and box).
    tracks : SourceTracks, optional
        The sources heard (their box; None: the data's, :func:`source_box`).
    path : ListenerPath, optional
        Where the listener goes, in playback time.
    listener : array_like, optional
        A fixed listener position (m; used without ``path``).
    duration : float, optional
        Playback seconds (> 0).
    time_scale : float or "auto"
        Playback seconds per data second.
    c0 : float
        Speed of sound (m/s).
    clip : bool
        Clip a ``duration`` beyond the data's sound (with a note).
    face : {"sweep", "center", "forward", "fixed"}
        How the default orbit's listener faces.

    Returns
    -------
    RenderPlan

    Raises
    ------
    ParameterError
        A ``c0``, ``duration`` or time scale not > 0 (or a string other than
        ``"auto"``), a listener that is not three finite numbers, or data of
        fewer than 2 time steps.

    Examples
    --------
    >>> vol = load("dataset:monopole", size=12, steps=8)
    >>> plan = plan_render(vol, listener=(10.0, 1.4, 1.4), duration=0.5)
    >>> plan.duration, plan.default_listener, round(plan.lead * C0, 2)
    (0.5, False, 7.25)
    """
    if not (math.isfinite(c0) and c0 > 0):
        raise ParameterError(f"speed of sound c0 must be > 0 m/s, got {c0!r}")
    times = np.asarray(volume.times, dtype=np.float64)
    span = float(times[-1] - times[0]) if times.size >= 2 else 0.0
    if not span > 0:
        raise ParameterError(
            f"{volume.source}: the data have {times.size} time step(s); rendering needs at least 2"
        )
    auto = isinstance(time_scale, str)
    if auto and str(time_scale).strip().lower() != "auto":
        raise ParameterError(
            f"time scale must be 'auto' or a number of playback seconds per "
            f"data second, got {time_scale!r}"
        )
    if not auto and not (math.isfinite(float(time_scale)) and float(time_scale) > 0):
        raise ParameterError(
            f"time scale must be > 0 playback seconds per data second, got {time_scale!r}"
        )
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        raise ParameterError(f"duration must be > 0 seconds, got {duration!r}")
    notes: list[str] = []
    lo, hi = source_box(volume, tracks)
    bounds = np.stack([lo, hi], axis=1).reshape(-1)
    default = path is None and listener is None
    if default:
        dur = duration or DEFAULT_DURATION
        path = orbit_around(bounds, duration=dur, face=face)
    elif path is None:
        dur = duration or DEFAULT_DURATION
        path = ListenerPath.point(check_listener(listener), duration=dur)
    else:
        dur = duration or path.duration
    near, far = box_distances(path.positions, lo, hi)
    d_near, d_far = float(near.min()), float(far.max())
    window = span + max(d_far - d_near, 0.0) / c0  # data seconds that hold sound
    ts = dur / window if auto else float(time_scale)
    if clip and not auto and dur > ts * window * (1 + 1e-9):
        notes.append(
            f"{dur:g} s requested, but the data's sound lasts {ts * window:.4g} s at "
            f"time scale {ts:g}: clipped to {ts * window:.4g} s"
        )
        dur = ts * window
    if default:
        speed = float(np.max(path.speeds(), initial=0.0)) * ts  # m per data second
        if speed > MAX_ORBIT_MACH * c0:
            path = orbit_around(bounds, duration=dur, turns=MAX_ORBIT_MACH * c0 / speed, face=face)
        c = 0.5 * (lo + hi)
        r = float(np.linalg.norm(path.positions[0] - c))
        facing = {
            "sweep": f"the head turning so the data pass {SWEEP_TURNS:g} times around the listener",
            "center": "facing the data",
            "forward": "facing along the motion",
            "fixed": "facing +y",
        }.get(face, face)
        notes.append(
            f"listener: orbit of radius {r:.4g} m around the data's centre "
            f"({', '.join(f'{v:.4g}' for v in c)}) m, "
            f"{_turns(path, c):.3g} turn(s) in {dur:g} s, {facing} "
            f"(give --listener X,Y,Z or --path CSV to choose)"
        )
    lead = d_near / c0
    return RenderPlan(
        path=path,
        time_scale=ts,
        duration=dur,
        lead=lead,
        auto=auto,
        default_listener=default,
        physical_times=bool(volume.physical_times),
        notes=notes,
    )


def _turns(path: ListenerPath, center: np.ndarray) -> float:
    d = path.positions[:, :2] - center[:2]
    ang = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    return float(abs(ang[-1] - ang[0]) / (2 * np.pi))


def auralize(  # noqa: PLR0913 (keyword-only options)
    volume: TimeVolume,
    path: ListenerPath | None = None,
    *,
    mapping: str | AcousticMapping | None = None,
    thresholds: Thresholds | None = None,
    rate: int = DEFAULTS.rate,
    time_scale: float | str = DEFAULTS.time_scale,
    interp: Interp = DEFAULTS.interp,
    layout: str = DEFAULTS.layout,
    c0: float = C0,
    duration: float | None = None,
    series: SourceSeries | None = None,
    progress_bar: bool = False,
    timbre: Timbre = DEFAULTS.timbre,
    highpass_hz: float = DEFAULTS.highpass_hz,
    seed: int = 0,
    listener: Any = None,
    hrtf: object = None,
    clip: bool = True,
    heard: str | Heard = DEFAULTS.heard,
    orbit_face: OrbitFace = DEFAULTS.orbit_face,
    block: int | None = None,
    extra: Any = None,
    method: Method = DEFAULTS.method,
    surface: str | None = None,
    air: Any = None,
    ground: Any = None,
    **mapping_fields: str,
) -> tuple[Rendered, SourceSeries | None]:
    """Render the sound of ``volume`` along ``path``.

    What is heard (``heard``, :func:`auralize.sources.field.parse_heard`):
    ``"field"`` (default) is the physical sound of the whole field, summed
    over every valid point with no threshold (:func:`auralize.sources.field.field_tracks`:
    Lighthill's stress term and the continuity residual); ``"detected"`` is
    paper 003's detected sources (``series``, or detected here with
    ``thresholds``), and ``"dipole,quadrupole"`` mutes the other types of
    them.  Detection decides what is drawn; in ``field`` mode it is not run
    (``series`` is returned as given, or None).

    The listener may be anywhere (see :func:`plan_render`: without ``path`` or
    ``listener`` an orbit around the data, ``orbit_face`` as
    :meth:`auralize.listener.ListenerPath.orbit`; ``time_scale="auto"`` fits
    the data in ``duration``; the output starts when the first sound can
    arrive).  ``timbre``, ``highpass_hz`` and ``hrtf`` (binaural) as
    :func:`auralize.emitters.timbre.render_timbre`; ``clip`` as
    :func:`plan_render`; ``block`` the field's block size
    (:func:`auralize.sources.field.block_plan`).  ``extra``: other models' sound
    (an :class:`auralize.emitters.Sound`) heard with the volume's along the
    same path, mixed by :func:`render`'s rule.  The plan and what was heard
    are recorded in ``meta`` (and so in the sidecar).

    ``method``: how the volume is heard (:func:`auralize.fwh.classify.choose_method`):
    ``"volume"`` the sum of its sources as above; ``"fwh"`` the
    Ffowcs Williams–Hawkings integral on ``surface`` (a surface spec as the
    ``fwh`` model's; default a box inside the data), the data's own sound waves
    played in their own time (time scale 1); ``"auto"`` (default) the FW-H
    integral when the whole field would be heard and the data hold sound waves
    (their pressure or density obeys the wave equation), else the volume sum.
    ``meta["method"]`` and ``meta["method_text"]`` say which, and why.

    ``air`` (:class:`auralize.emitters.outdoor.Air`) and ``ground``
    (:class:`auralize.emitters.outdoor.Ground`): outdoor propagation, as
    :func:`render` (None, the default: neither).

    The defaults are those of ``auralize render FILE -o OUT`` with no other
    option: the mapping chosen from the fields, the whole field heard, the
    steady part removed, a default orbit, ``time_scale="auto"`` over
    ``duration`` = 10 s, ``timbre="auto"``, a 20 Hz high-pass, mono at
    44.1 kHz, seed 0; :func:`save_rendered` then peak-normalises as the
    command does, so ``save_rendered(auralize(load(FILE))[0], OUT)`` writes
    the command's samples.

    Parameters
    ----------
    volume : TimeVolume, str or PathLike
        The data (a file name is opened: :func:`volume_arg`).
    path : ListenerPath, optional
        Where the listener goes, in playback time (default: ``listener``,
        else an orbit around the data).
    mapping : str or AcousticMapping, optional
        As :func:`resolve_mapping` (default :func:`auto_mapping`).
    thresholds : Thresholds, optional
        Detection thresholds (``detected`` mode; ``floor`` is also the whole
        field's residual floor).
    rate : int
        Output sample rate, Hz (:func:`check_rate`).
    time_scale : float or "auto"
        Playback seconds per data second.
    interp : {"cubic", "linear"}
        Interpolation of the strengths between data steps (paper 003 §3.2.4.3).
    layout : str
        Output layout (:func:`auralize.spatial.layouts.get_layout`).
    c0 : float
        Speed of sound (m/s).
    duration : float, optional
        Playback seconds (default: the path's, else :data:`DEFAULT_DURATION`).
    series : SourceSeries, optional
        Detected sources to hear (``detected`` mode; returned as given).
    progress_bar : bool
        Show progress on the terminal.
    timbre : {"auto", "physical", "extended", "tonal"}
        How the strengths sound (:mod:`auralize.emitters.timbre`).
    highpass_hz : float
        Cut-off of the volume's sound's causal high-pass, Hz (0: none).
    seed : int
        Seed of the timbre's noise carriers, 0..2³²−1.
    listener : array_like, optional
        A fixed listener position (m; used without ``path``).
    hrtf : HRIRSet, str or Path, optional
        ``binaural`` only: the HRIRs or a SOFA file.
    clip : bool
        Clip a ``duration`` beyond the data's sound (:func:`plan_render`).
    heard : str or Heard
        What is heard (:func:`auralize.sources.field.parse_heard`).
    orbit_face : {"sweep", "center", "forward", "fixed"}
        How the default orbit's listener faces.
    block : int, optional
        The whole field's block size.
    extra : Sound, optional
        Other models' sound, mixed in.
    method : {"auto", "volume", "fwh"}
        How the volume is heard.
    surface : str, optional
        The FW-H surface spec (``fwh`` method).
    air : Air, optional
        Air absorption (:class:`auralize.emitters.outdoor.Air`).
    ground : Ground, optional
        A reflecting ground (:class:`auralize.emitters.outdoor.Ground`).
    **mapping_fields : str
        As :func:`resolve_mapping`.

    Returns
    -------
    rendered : Rendered
        ``audio (n_channels, n_samples)`` in Pa (not normalised), ``rate``,
        ``layout``, ``meta`` (the plan, what was heard, the method).
    series : SourceSeries or None
        The detected sources (``detected`` mode), else ``series`` as given.

    Raises
    ------
    ParameterError
        A bad rate, seed, thresholds, listener, time scale, duration,
        method, heard spec, layout or outdoor option, a listener too close
        to (or, for FW-H, inside) the data, or sound that cannot arrive
        within the duration.
    FieldError
        A named field missing from the volume.
    ResourceError
        More memory than the machine has (refused before allocating).
    MissingFileError, FormatError, DataError
        A volume file (or an ``hrtf`` SOFA file) missing or unreadable.

    Examples
    --------
    >>> vol = load("dataset:monopole", size=12, steps=20)
    >>> out, series = auralize(vol, duration=0.05, rate=8000, layout="stereo")
    >>> out.audio.shape, out.meta["heard"], out.meta["method"], series is None
    ((2, 400), 'field', 'volume', True)
    """
    # everything that can be checked before the work is checked first
    volume = volume_arg(volume, "auralize")
    rate = check_rate(rate)
    from auralize.emitters.outdoor import check_options

    check_options(air, ground)
    outdoor = {} if air is None and ground is None else {"air": air, "ground": ground}
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or not 0 <= seed < 2**32:
        raise ParameterError(f"seed must be a whole number in 0..4294967295, got {seed!r}")
    if thresholds is not None and not isinstance(thresholds, Thresholds):
        raise ParameterError(
            f"thresholds must be a Thresholds(monopole, dipole, quadrupole), got {thresholds!r}"
        )
    if listener is not None:
        listener = check_listener(listener)
    channels = get_layout(layout).n_channels

    def check_memory(seconds: float) -> None:
        require_memory(
            audio_bytes(seconds, rate, channels),
            f"{seconds:g} s of {channels}-channel audio at {rate} Hz",
            hint="render a shorter duration or at a lower rate",
        )

    if duration is not None and math.isfinite(duration) and duration > 0:
        check_memory(duration)
    hd = parse_heard(heard)
    from auralize.fwh.classify import Method, choose_method

    if method == "auto" and (series is not None or hd.label != DEFAULTS.heard):
        how = Method(
            "volume", f"the {hd.describe() if hd.mode == 'detected' else hd.label} asked for"
        )
    else:
        how = choose_method(volume, method, surface=surface, c0=c0)
    if how.name == "fwh":
        return _auralize_fwh(
            volume,
            how,
            path=path,
            listener=listener,
            duration=duration,
            time_scale=time_scale,
            rate=rate,
            layout=layout,
            c0=c0,
            clip=clip,
            orbit_face=orbit_face,
            hrtf=hrtf,
            extra=extra,
            check_memory=check_memory,
            outdoor=outdoor,
        ), series
    with memory_guard(f"rendering {volume.source}"):
        hs, plan = plan_heard(
            volume,
            path=path,
            listener=listener,
            duration=duration,
            time_scale=time_scale,
            c0=c0,
            clip=clip,
            orbit_face=orbit_face,
            heard=hd,
            series=series,
            mapping=mapping,
            thresholds=thresholds,
            block=block,
            progress_bar=progress_bar,
            **mapping_fields,
        )
    check_memory(plan.duration)
    tracks = hs.tracks
    check_arrival(
        tracks, plan.path, time_scale=plan.time_scale, duration=plan.duration, c0=c0, lead=plan.lead
    )
    from auralize.emitters import FieldSources, Sound

    sound = Sound(
        [
            FieldSources(
                tracks,
                time_scale=plan.time_scale,
                lead=plan.lead,
                interp=interp,
                timbre=timbre,
                bounds=volume.bounds,
                by_type=hs.by_type,
                seed=seed,
            )
        ],
        name="field",
    )
    if extra is not None:
        sound = sound + extra
    with progress_step("render", enabled=progress_bar), memory_guard(f"rendering {volume.source}"):
        out = render(
            sound,
            plan.path,
            rate=rate,
            layout=layout,
            duration=plan.duration,
            c0=c0,
            highpass_hz=highpass_hz,
            hrtf=hrtf,
            **outdoor,
        )
    out.meta.update(
        {
            "volume": volume.source,
            **plan.as_dict(),
            **hs.meta,
            "method": "volume",
            "method_text": how.describe(),
        }
    )
    return out, hs.series


def _auralize_fwh(  # noqa: PLR0913 (keyword-only options)
    volume: TimeVolume,
    how: Any,
    *,
    path: ListenerPath | None,
    listener: Any,
    duration: float | None,
    time_scale: float | str,
    rate: int,
    layout: str,
    c0: float,
    clip: bool,
    orbit_face: OrbitFace,
    hrtf: object,
    extra: Any,
    check_memory: Any,
    outdoor: dict[str, Any],
) -> Rendered:
    """:func:`auralize` by the FW-H integral on ``how.surface``: the data's sound waves
    through the surface, heard along the path in the data's own time."""
    from auralize.fwh.model import FWHSound
    from auralize.fwh.surface import surface_from_spec

    if not (time_scale == "auto" or float(time_scale) == 1.0):
        raise ParameterError(
            f"the FW-H method plays the data's sound waves in their own time "
            f"(time scale 1), not at time scale {time_scale!r}; give "
            f"--method volume to hear the data's sources at another pace"
        )
    asked = duration
    placed = path is None and listener is None
    if placed:  # the data's sound lasts milliseconds: a listener standing where the orbit starts
        listener = orbit_around(volume.bounds, duration=1.0, face=orbit_face).positions[0]
    if duration is None and path is None:
        duration = DEFAULT_DURATION
    plan = plan_render(
        volume,
        None,
        path=path,
        listener=listener,
        duration=duration,
        time_scale=1.0,
        c0=c0,
        clip=clip,
        face=orbit_face,
    )
    if asked is None and path is None:  # no length was asked: the data's sound's own
        plan.notes = [n for n in plan.notes if "requested" not in n]
        plan.notes.append(
            f"the data's sound lasts {plan.duration:.4g} s (data time: the FW-H "
            f"method plays it at its own pace)"
        )
    if placed:
        where = ", ".join(f"{v:.4g}" for v in listener)
        plan.notes.insert(
            0,
            f"listener: standing at ({where}) m, outside the data (give "
            f"--listener X,Y,Z or --path CSV to choose)",
        )
    check_memory(plan.duration)
    spacing = float(np.min(volume.spacing))
    inside = surface_from_spec(str(how.surface), panel_size=spacing)
    lo, hi = np.asarray(inside.bounds, dtype=np.float64).reshape(3, 2).T
    pos = np.asarray(plan.path.positions, dtype=np.float64)
    if np.any(np.all((pos >= lo) & (pos <= hi), axis=1)):
        raise ParameterError(
            f"the listener must stay outside the FW-H surface {how.surface} "
            f"(inside it the integral is not the sound); move the path or give "
            f"a smaller --surface"
        )
    sound = FWHSound().synthesize(
        volume, surface=str(how.surface), c0=c0, time_origin=float(volume.times[0]) + plan.lead
    )
    if extra is not None:
        sound = sound + extra
    with memory_guard(f"rendering {volume.source}"):
        out = render(
            sound,
            plan.path,
            rate=rate,
            layout=layout,
            duration=plan.duration,
            c0=c0,
            hrtf=hrtf,
            **outdoor,
        )
    out.meta.update(
        {
            "volume": volume.source,
            **plan.as_dict(),
            "method": "fwh",
            "method_text": how.describe(),
            "surface": how.surface,
            "heard": "fwh",
            "heard_text": f"the sound waves through the FW-H surface {how.surface}",
            "timbre": "physical",
            "time_mapping": "data time (time scale 1)",
        }
    )
    if how.test is not None:
        out.meta["wave_residual"] = how.test.residual
    return out


def plan_heard(  # noqa: PLR0913 (keyword-only options)
    volume: TimeVolume,
    *,
    path: ListenerPath | None = None,
    listener: Any = None,
    duration: float | None = None,
    time_scale: float | str = DEFAULTS.time_scale,
    c0: float = C0,
    clip: bool = True,
    orbit_face: OrbitFace = DEFAULTS.orbit_face,
    heard: str | Heard = DEFAULTS.heard,
    series: SourceSeries | None = None,
    mapping: str | AcousticMapping | None = None,
    thresholds: Thresholds | None = None,
    block: int | None = None,
    progress_bar: bool = False,
    **mapping_fields: str,
) -> tuple[HeardSound, RenderPlan]:
    """What a render of ``volume`` hears, and its plan: the one planning step of every
    front end (:func:`auralize`, ``auralize render`` with or without a scene,
    the ``field`` model in scene files and sessions, the viewer's Render to file).

    :func:`heard_sound` with a :class:`Planner` as its path, so the default
    listener goes around what is heard and the time scale and the travel time
    skipped (``lead``) are those of :func:`plan_render`, whatever the time scale.

    Parameters
    ----------
    volume : TimeVolume
    path, listener, duration, time_scale, c0, clip, orbit_face
        As :func:`plan_render` (``orbit_face`` is its ``face``).
    heard, series, mapping, thresholds, block, progress_bar, **mapping_fields
        As :func:`heard_sound`.

    Returns
    -------
    heard : HeardSound
        What is heard (:func:`heard_sound`).
    plan : RenderPlan
        The listener, time scale and window (:func:`plan_render`).

    Raises
    ------
    ParameterError, FieldError, ResourceError
        As :func:`plan_render` and :func:`heard_sound`.

    Examples
    --------
    >>> vol = load("dataset:monopole", size=12, steps=8)
    >>> hs, plan = plan_heard(vol, duration=2.0)
    >>> plan.duration, plan.auto, hs.meta["heard"]
    (2.0, True, 'field')
    """
    planner = Planner(
        volume,
        path=path,
        listener=listener,
        duration=duration,
        time_scale=time_scale,
        c0=c0,
        clip=clip,
        face=orbit_face,
    )
    hs = heard_sound(
        volume,
        heard=heard,
        series=series,
        mapping=mapping,
        thresholds=thresholds,
        path=planner,
        block=block,
        c0=c0,
        progress_bar=progress_bar,
        **mapping_fields,
    )
    return hs, planner.plan


class Planner:
    """Plans a render once the tracks it hears are known: the ``path`` callback of
    :func:`heard_sound`, whose default listener goes around the detected sources
    (or the data's box for the whole field).  ``planner.plan`` is the
    :class:`RenderPlan` afterwards; its listener is checked against the data's
    box (:func:`~auralize.emitters.synthesis.check_distance`).

    Parameters
    ----------
    volume : TimeVolume
        The data.
    **plan
        :func:`plan_render`'s keywords (``path``, ``listener``, ``duration``,
        ``time_scale``, ``c0``, ``clip``, ``face``).

    Raises
    ------
    ParameterError
        When called: what :func:`plan_render` refuses, or a listener too close to the data.

    Examples
    --------
    >>> vol = load("dataset:monopole", size=12, steps=8)
    >>> planner = Planner(vol, duration=1.0)
    >>> hs = heard_sound(vol, path=planner)
    >>> planner.plan.duration, planner.plan.default_listener
    (1.0, True)
    """

    def __init__(self, volume: TimeVolume, **plan: Any) -> None:
        self.volume = volume
        self.options = plan
        self._plan: RenderPlan | None = None

    def __call__(self, tracks: SourceTracks | None) -> ListenerPath:
        self._plan = plan_render(self.volume, tracks, **self.options)
        check_distance(self._plan.path, self.volume.bounds)
        return self._plan.path

    @property
    def plan(self) -> RenderPlan:
        """The plan, once the planner has been called (a :class:`ParameterError` before).

        Examples
        --------
        >>> planner = Planner(load("dataset:monopole", size=12, steps=8), duration=1.0)
        >>> _ = planner(None)   # the whole field: planned around the data's box
        >>> planner.plan.duration
        1.0
        """
        if self._plan is None:
            raise ParameterError("nothing planned yet: pass the Planner as heard_sound's path")
        return self._plan


@dataclass
class HeardSound:
    """What a render of a volume hears (:func:`heard_sound`).

    Parameters
    ----------
    tracks : SourceTracks
        The engine's input: positions ``(K, 3)`` (m), strengths ``q (K, T)``.
    heard : Heard
        What is heard (:func:`auralize.sources.field.parse_heard`).
    meta : dict
        What to record: ``heard``, ``heard_text``, ``mapping``, and ``field``
        (blocks, rows, points) or ``sources`` and ``thresholds`` (counts per type).
    by_type : dict of str to SourceTracks, optional
        The tracks of each type heard (the ``tonal`` timbre's; None: from
        ``tracks.kind``).
    series : SourceSeries, optional
        The detected sources (None when the whole field is heard and none
        were given).

    Examples
    --------
    >>> hs = heard_sound(load("dataset:monopole", size=12, steps=8), heard="detected")
    >>> hs.heard.label, hs.series is not None, sorted(hs.meta["sources"])
    ('detected', True, ['dipole', 'monopole', 'quadrupole'])
    """

    tracks: SourceTracks
    heard: Heard
    _: KW_ONLY
    meta: dict[str, Any]
    by_type: dict[str, SourceTracks] | None = None
    series: SourceSeries | None = None


def heard_sound(
    volume: TimeVolume,
    *,
    heard: str | Heard = "field",
    series: SourceSeries | None = None,
    mapping: str | AcousticMapping | None = None,
    thresholds: Thresholds | None = None,
    path: Any = None,
    block: int | None = None,
    c0: float = C0,
    progress_bar: bool = False,
    **mapping_fields: str,
) -> HeardSound:
    """The sound of ``volume`` that renders hear: the whole field or the detected sources.

    The one place where what is heard is decided, for the command line,
    ``simple``, the viewer, live listening and scenes alike.

    Parameters
    ----------
    volume : TimeVolume
    heard : str or Heard
        ``"field"`` (default), ``"detected"``, types such as
        ``"dipole,quadrupole"``, or ``"field:quadrupole"``
        (:func:`auralize.sources.field.parse_heard`).
    series : SourceSeries, optional
        Detected sources to hear (``detected`` mode; detected here otherwise).
    mapping, thresholds, **mapping_fields
        As :func:`detect_sources`; ``thresholds.floor`` is also the whole
        field's residual floor.
    path : ListenerPath or callable, optional
        Where the listener goes (blocks near it are heard as points); a
        callable ``path(tracks_or_None) -> ListenerPath`` is called once the
        detected tracks are known (None for the whole field), so that a
        default path can be planned around them.
    block : int, optional
        The whole field's block size (:func:`auralize.sources.field.block_plan`).
    c0 : float
        Speed of sound (m/s; which blocks are near the path).
    progress_bar : bool
        Show progress on the terminal.

    Returns
    -------
    HeardSound

    Raises
    ------
    ParameterError
        A bad heard spec or mapping, or a volume of fewer than 3 steps.
    FieldError
        A named field missing from the volume.
    ResourceError
        More memory than the machine has.

    Examples
    --------
    >>> vol = load("dataset:monopole", size=12, steps=8)
    >>> hs = heard_sound(vol)
    >>> hs.meta["heard"], hs.tracks.n_sources > 0
    ('field', True)
    """
    hd = parse_heard(heard)
    require_steps(volume)
    if hd.mode == "detected":
        if series is None:
            series = detect_sources(
                volume,
                mapping=mapping,
                thresholds=thresholds,
                progress_bar=progress_bar,
                **mapping_fields,
            )
        tracks = heard_tracks(series, hd)
        if callable(path):
            path(tracks)
        counts = series.counts()
        meta: dict[str, Any] = {
            "heard": hd.label,
            "heard_text": hd.describe(),
            "mapping": series.meta.get("mapping"),
            "thresholds": series.thresholds.tolist(),
            "sources": {k: int(sum(c[k] for c in counts)) for k in TYPES},
        }
        if series.meta.get("unavailable"):
            meta["unavailable"] = series.meta["unavailable"]
        return HeardSound(tracks=tracks, heard=hd, meta=meta, series=series)
    m = resolve_mapping(volume, mapping, **mapping_fields)
    m.prepare(volume)
    where = path(None) if callable(path) else path
    ft = field_tracks(
        volume,
        m,
        heard=hd,
        path=where,
        block=block,
        c0=c0,
        floor=thresholds.floor if thresholds is not None else FLOOR,
        progress_bar=progress_bar,
    )
    meta = {
        "heard": hd.label,
        "mapping": m.describe(),
        "field": ft.meta,
        "heard_text": f"{ft.meta['heard_text']}, {ft.meta['valid_points']:,} points as "
        f"{ft.meta['rows']:,} rows",
    }
    unavailable = m.unavailable(volume)
    if unavailable:
        meta["unavailable"] = unavailable
    return HeardSound(tracks=ft.tracks(), heard=hd, meta=meta, by_type=_by_type(ft), series=series)


def _by_type(ft: Any) -> dict[str, SourceTracks]:
    """The whole field's tracks of each of its terms (for the ``tonal`` timbre)."""
    return {t: ft.tracks((t,)) for t in ft.q}


def heard_tracks(series: SourceSeries, heard: Heard | str = "detected") -> SourceTracks:
    """The tracks of the detected sources of the types ``heard`` names (the others muted).

    Parameters
    ----------
    series : SourceSeries
        Detected sources.
    heard : Heard or str
        ``"detected"`` (every type) or types such as ``"dipole,quadrupole"``
        (:func:`auralize.sources.field.parse_heard`).

    Returns
    -------
    SourceTracks
        The series' tracks with the other types' strengths set to 0 (and
        sources left silent dropped).

    Raises
    ------
    ParameterError
        A heard spec :func:`~auralize.sources.field.parse_heard` refuses.

    Examples
    --------
    >>> series = detect_sources(load("dataset:monopole", size=12, steps=8))
    >>> every, some = heard_tracks(series), heard_tracks(series, "monopole")
    >>> some.n_sources <= every.n_sources, set(np.unique(some.kind)) <= {0, 1}
    (True, True)
    """
    hd = parse_heard(heard)
    tracks = series.tracks()
    if hd.mode != "detected" or tuple(hd.types) == TYPES or tracks.kind is None:
        return tracks
    codes = [1 + TYPES.index(t) for t in hd.types]
    on = np.isin(tracks.kind, codes)
    q = np.where(on, tracks.q, 0.0)
    keep = np.any(q != 0, axis=1)
    return SourceTracks(
        positions=tracks.positions[keep],
        q=np.ascontiguousarray(q[keep]),
        radius=tracks.radius[keep],
        times=tracks.times,
        origin=tracks.origin,
        end=tracks.end,
        index=None if tracks.index is None else tracks.index[keep],
        kind=np.where(on, tracks.kind, 0).astype(np.int8)[keep],
    )


def report_line(rendered: Rendered, output: str | Path, *, gain: float | None = None) -> str:
    """The one-line summary of a render: file, mapping, timbre, sources per type, loudness.

    Parameters
    ----------
    rendered : Rendered
        The render (its ``meta`` says what was heard).
    output : str or Path
        Where it was written.
    gain : float, optional
        The gain it was written with (:func:`save_rendered`).

    Returns
    -------
    str

    Examples
    --------
    >>> vol = load("dataset:monopole", size=12, steps=20)
    >>> out, _ = auralize(vol, duration=0.05, rate=8000)
    >>> report_line(out, "out.wav", gain=2.0)
    'wrote out.wav: 0.05 s, mono (1 ch) at 8000 Hz; 1 s of playback = ... ms of data; timbre ...; heard whole field: ... points as ... rows; peak ..., RMS ... Pa (gain 2), ... % of the energy above 20 Hz'
    """
    from auralize.emitters.timbre import loudness

    m = rendered.meta
    ld = loudness(rendered.audio, rendered.rate)
    if "sources" in m:
        src = m["sources"]
        heard = (
            f"heard {m.get('heard_text', 'the detected sources')} "
            f"({', '.join(f'{src.get(k, 0)} {k}' for k in TYPES)} source points)"
        )
    else:
        heard = f"heard {m.get('heard_text', 'the whole field')}"
    g = f" (gain {gain:.4g})" if gain is not None else ""
    return (
        f"wrote {output}: {rendered.duration:.2f} s, {rendered.layout.name} "
        f"({rendered.audio.shape[0]} ch) at {rendered.rate} Hz; "
        f"{m.get('time_mapping', describe_time_scale(rendered.time_scale))}; "
        f"timbre {m.get('timbre', 'physical')}; {heard}; "
        f"peak {ld['peak']:.4g}, RMS {ld['rms']:.4g} Pa{g}, "
        f"{100 * ld['share_above']:.0f} % of the energy above 20 Hz"
    )


def save_rendered(
    rendered: Rendered,
    out: str | Path,
    *,
    normalize: Normalize = "peak",
    limit_pa: float | None = None,
    extra: dict[str, Any] | None = None,
    subtype: SampleFormat | None = None,
) -> float:
    """Write a render to WAV/FLAC (atomic) with its sidecar JSON; returns the gain.

    Parameters
    ----------
    rendered : Rendered
        The render (its layout's channel mask and ``meta`` go in the files).
    out : str or Path
        ``.wav`` or ``.flac`` file; the sidecar is ``out + ".json"``.
    normalize : {"peak", "none"}
        ``peak``: scaled to full scale; ``none``: physical pascals.
    limit_pa : float, optional
        With ``none``: the pressure written as full scale (Pa).
    extra : dict, optional
        More entries for the sidecar.
    subtype : {"float32", "pcm16", "pcm24"}, optional
        Sample format (default ``float32`` for WAV, ``pcm24`` for FLAC; see
        :func:`auralize.audio.output.write_audio`).

    Returns
    -------
    float
        The gain the samples were written with (file value per pascal).

    Raises
    ------
    ParameterError
        A bad normalisation, format, limit or suffix, or samples the format
        cannot hold (:func:`auralize.audio.output.write_audio`).
    OutputError
        The files cannot be written, or the sidecar's name is taken by a
        file auralize did not write.

    Examples
    --------
    >>> from auralize.rendering import render
    >>> from auralize.emitters import Emitters
    >>> em = Emitters(np.ones((1, 400)), 8000, [[0.0, 2.0, 0.0]])
    >>> r = render(em, ListenerPath.point((0, 0, 0), duration=0.05), rate=8000)
    >>> gain = save_rendered(r, "beep.wav", extra={"note": "example"})
    >>> round(gain, 3), sorted(p.name for p in Path(".").iterdir())
    (1.98, ['beep.wav', 'beep.wav.json'])
    """
    from auralize.audio.output import write_audio

    if normalize not in ("peak", "none"):
        raise ParameterError(f"normalize must be 'peak' or 'none', got {normalize!r}")
    return write_audio(
        out,
        rendered.audio,
        rendered.rate,
        channel_mask=rendered.layout.channel_mask,
        normalize=normalize,
        limit_pa=limit_pa,
        subtype=subtype,
        sidecar={
            "layout": rendered.layout.describe(),
            "time_scale": rendered.time_scale,
            **rendered.meta,
            **(extra or {}),
        },
    )
