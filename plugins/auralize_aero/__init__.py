"""auralize_aero: aerodynamic sound with Curle's model and sound textures (paper 004).

Dobashi, Yamamoto & Nishita (2003), "Real-time rendering of aerodynamic
sound using sound textures based on computational fluid dynamics".

Pipeline: a 2-D lattice Boltzmann flow past a cross-section
(:mod:`~auralize_aero.lbm`, §5.2) gives the sound source function
g = d/dt ∮ n p dl per sampled flow direction, stored as a looping HDF5
sound texture (:mod:`~auralize_aero.texture`, §5, Eq. 2); objects are
polylines split into point sources at 3D (:mod:`~auralize_aero.objects`,
§7.1) and rendered by Eqs. 3–4 with retarded times
(:mod:`~auralize_aero.render`, §6).  Amplitude ∝ v³ by default (pressure
law, DESIGN.md) or the paper's v⁶.

Example
-------
>>> from auralize_aero import circle, compute_texture, stick, Wind, render   # doctest: +SKIP
>>> from auralize.listener import ListenerPath                              # doctest: +SKIP
>>> tex = compute_texture(circle(0.01))                                     # doctest: +SKIP
>>> out = render(tex, stick(0.5), ListenerPath.point((0.25, 0, 2), duration=1),
...              wind=Wind(10.0, (0, 1, 0)))                                # doctest: +SKIP
"""

from .model import AeroSound
from .objects import AeroObject, Motion, Wind
from .presets import PRESETS, fence, get_preset, sphere_object, stick, sword_object
from .render import Rendered, render
from .shapes import Section, circle, get_section, make_polygon, read_polygon_file, square, sword
from .texture import SoundTexture, compute_texture

__all__ = [
    "PRESETS",
    "AeroObject",
    "AeroSound",
    "Motion",
    "Rendered",
    "Section",
    "SoundTexture",
    "Wind",
    "circle",
    "compute_texture",
    "fence",
    "get_preset",
    "get_section",
    "make_polygon",
    "read_polygon_file",
    "render",
    "sphere_object",
    "square",
    "stick",
    "sword",
    "sword_object",
]
