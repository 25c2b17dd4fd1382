"""auralize_aero: aerodynamic sound with Curle's model and sound textures (paper 004).

Dobashi, Yamamoto & Nishita (2003), "Real-time rendering of aerodynamic
sound using sound textures based on computational fluid dynamics".

Pipeline: a 2-D lattice Boltzmann flow past a cross-section
(:mod:`~auralize_aero.lbm`, §5.2) gives the sound source function
g = d/dt ∮ n p dl per sampled flow direction, stored as a looping HDF5
sound texture (:mod:`~auralize_aero.texture`, §5, Eq. 2); objects are
polylines split into point sources at 3D (:mod:`~auralize_aero.objects`,
§7.1) and emitted as point dipoles by Eqs. 3–4
(:mod:`~auralize_aero.render`, §6), which the sound engine
(:mod:`auralize.emitters`) delays, attenuates and pans to the listener.
Amplitude ∝ v³ by default (pressure law, docs/design.md) or the paper's v⁶.

Example
-------
A coarse, short texture (the defaults simulate finer and longer, and cache
the result in auralize's cache folder; ``cache=False`` keeps nothing):

>>> from auralize_aero import circle, compute_texture, stick, Wind, render
>>> from auralize.listener import ListenerPath
>>> tex = compute_texture(circle(0.01), resolution=6, duration=0.005, u_lattice=0.15,
...                       cache=False)
>>> out = render(tex, stick(0.5), ListenerPath.point((0.25, 0, 2), duration=0.1),
...              wind=Wind(10.0, (0, 1, 0)))
>>> out.audio.shape
(1, 4410)
"""

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module; imported on first access, so that declaring the
#: plugin's sub-commands (``auralize --help``) loads none of its physics
_EXPORTS = {
    "AeroSound": ".model",
    "AeroObject": ".objects",
    "Motion": ".objects",
    "Wind": ".objects",
    "PRESETS": ".presets",
    "fence": ".presets",
    "get_preset": ".presets",
    "sphere_object": ".presets",
    "stick": ".presets",
    "sword_object": ".presets",
    "AeroEmission": ".render",
    "Rendered": ".render",
    "emission": ".render",
    "render": ".render",
    "Section": ".shapes",
    "circle": ".shapes",
    "get_section": ".shapes",
    "make_polygon": ".shapes",
    "read_polygon_file": ".shapes",
    "square": ".shapes",
    "sword": ".shapes",
    "SoundTexture": ".texture",
    "compute_texture": ".texture",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = [
    "PRESETS",
    "AeroEmission",
    "AeroObject",
    "AeroSound",
    "Motion",
    "Rendered",
    "Section",
    "SoundTexture",
    "Wind",
    "circle",
    "compute_texture",
    "emission",
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
