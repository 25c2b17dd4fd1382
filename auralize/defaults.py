"""The one plan every front end starts from: what a render hears and how, by default.

``auralize render``/``play``, :mod:`auralize.simple` sessions, the viewer,
scene files and the ``field`` sound model all take their defaults from
:data:`DEFAULTS`, so the same data and listener path give the same sound
whichever way a user comes in.  The values:

* ``time_scale="auto"``: the data's span, plus the spread of arrival delays,
  plays in the path's duration (:func:`auralize.pipeline.plan_render`);
* thresholds ``auto`` for each type (:class:`auralize.sources.detection.Thresholds`);
* ``timbre="auto"``: ``physical`` when most of the sound is audible, else
  ``extended`` (:mod:`auralize.emitters.timbre`);
* a 20 Hz causal high-pass of the volume's sound (paper 001 §6 uses 30 Hz);
* the whole field heard (``heard="field"``, :func:`auralize.sources.field.parse_heard`);
* ``method="auto"``: data that hold sound waves (a compressible simulation's
  acoustics) are heard through the FW-H integral on a box inside them, other
  data by the volume sum of their sources (:mod:`auralize.fwh.classify`);
* without a path, an orbit around the data whose head turns so that every
  speaker carries the sound (``orbit_face="sweep"``), for 10 s.

This module imports nothing beyond the standard library, so the command
line's parser can read it without loading the engine.

Examples
--------
>>> from auralize.defaults import DEFAULTS
>>> DEFAULTS.time_scale, DEFAULTS.timbre, DEFAULTS.highpass_hz
('auto', 'auto', 20.0)
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Literal, get_args

__all__ = [
    "DEFAULTS",
    "LAYOUT_NAMES",
    "ORBIT_FACES",
    "TIMBRE_CHOICES",
    "Interp",
    "Method",
    "OrbitFace",
    "RenderDefaults",
    "Timbre",
]

#: the named output layouts (``--layout``; a layout JSON file is also accepted)
LAYOUT_NAMES = ("mono", "stereo", "ring8", "5.1", "7.1", "binaural", "ambix1", "ambix2", "ambix3")

#: a ``--timbre`` choice (``auto`` picks one of the others)
Timbre = Literal["auto", "physical", "extended", "tonal"]
#: the ``--timbre`` choices
TIMBRE_CHOICES: tuple[Timbre, ...] = get_args(Timbre)
#: how the default orbit's listener faces (:meth:`auralize.listener.ListenerPath.orbit`)
OrbitFace = Literal["sweep", "center", "forward", "fixed"]
#: the orbit's facing choices
ORBIT_FACES: tuple[OrbitFace, ...] = get_args(OrbitFace)
#: time interpolation of the sources' strengths between data steps (paper 003 §3.2.4.3)
Interp = Literal["linear", "cubic"]
#: how a volume is heard (:func:`auralize.fwh.classify.choose_method`)
Method = Literal["auto", "volume", "fwh"]


@dataclass(frozen=True)
class RenderDefaults:
    """Default settings of a render (see the module docstring).

    Attributes
    ----------
    time_scale : str or float
        Playback seconds per data second, or ``"auto"``.
    thresholds : tuple of str
        Monopole, dipole and quadrupole detection thresholds.
    timbre : str
        One of :data:`TIMBRE_CHOICES`.
    highpass_hz : float
        Cut-off of the volume's sound's high-pass, Hz (0: none).
    heard : str
        What is heard (``field``, ``detected``, ...).
    orbit_face : str
        One of :data:`ORBIT_FACES`.
    duration : float
        Playback seconds without a listener path.
    rate : int
        Output sample rate, Hz.
    layout : str
        Output layout of the command line and scripts (the viewer plays
        ``stereo`` on the desktop's device).
    interp : str
        Time interpolation of the sources (paper 003 §3.2.4.3).
    mapping : str
        Acoustic mapping preset (``auto`` chooses from the fields).
    method : str
        How a volume is heard: ``auto`` (the FW-H integral when the data hold
        sound waves, else the volume sum), ``volume`` or ``fwh``.
    """

    time_scale: str | float = "auto"
    thresholds: tuple[str, str, str] = ("auto", "auto", "auto")
    timbre: Timbre = "auto"
    highpass_hz: float = 20.0
    heard: str = "field"
    orbit_face: OrbitFace = "sweep"
    duration: float = 10.0
    rate: int = 44100
    layout: str = "mono"
    interp: Interp = "cubic"
    mapping: str = "auto"
    method: Method = "auto"

    def as_dict(self) -> dict[str, Any]:
        """The settings as a plain dict (for sidecars and comparisons)."""
        return asdict(self)


#: the defaults of every front end
DEFAULTS = RenderDefaults()
