"""auralize_vortex: vortex sound from turbulent fields with sound textures (paper 000).

Dobashi, Yamamoto & Nishita (2004): a texture Q(u, t) of vortex sound is
pre-computed from small stable-fluids simulations (§5, :mod:`.texture`,
:mod:`.fluid`) and mapped onto the sound-source sub-volumes of any velocity
time series (§6, Eq. 5, :mod:`.render`).  Registered as the ``vortex`` sound
model; adds ``auralize vortex texture|render`` and the ``fire-plume`` dataset.
"""

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module; imported on first access, so that declaring the
#: plugin's sub-commands (``auralize --help``) loads none of its physics
_EXPORTS = {
    "VortexSound": ".model",
    "render_vortex": ".render",
    "Texture": ".texture",
    "TextureConfig": ".texture",
    "compute_texture": ".texture",
    "texture": ".texture",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = ["Texture", "TextureConfig", "VortexSound", "compute_texture", "render_vortex", "texture"]
