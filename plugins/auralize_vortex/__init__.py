"""auralize_vortex: vortex sound from turbulent fields with sound textures (paper 000).

Dobashi, Yamamoto & Nishita (2004): a texture Q(u, t) of vortex sound is
pre-computed from small stable-fluids simulations (§5, :mod:`.texture`,
:mod:`.fluid`) and mapped onto the sound-source sub-volumes of any velocity
time series (§6, Eq. 5, :mod:`.render`).  Registered as the ``vortex`` sound
model; adds ``auralize vortex texture|render`` and the ``fire-plume`` dataset.
"""

from auralize_vortex.model import VortexSound
from auralize_vortex.render import render_vortex
from auralize_vortex.texture import Texture, TextureConfig, compute_texture, texture

__all__ = ["Texture", "TextureConfig", "VortexSound", "compute_texture", "render_vortex", "texture"]
