"""auralize_fire: fire sound from flame-front flux, bandwidth extension, textures (paper 001).

Chain: a flame simulation (TimeVolume with a burn-rate and a velocity field)
→ flame front by cubic B-spline + VTK contouring (§3.2) → flux integral
I(t) = ∫ u·n dS (§3.1) → p = dI/dt at audio rate with the Mitchell–Netravali
filter (§3.3) → 30 Hz high-pass (§6) → spectral bandwidth extension (§4) or
sound texture synthesis (§5) → one point emitter at the front's centre,
rendered by the sound engine (:mod:`auralize.emitters`).

Examples
--------
>>> from auralize_fire import FireSound, make_fire
>>> snd = FireSound().synthesize(make_fire(size=12, steps=12), extend="none")
>>> em = snd.parts[0]
>>> em.rate, em.signals.shape
(44100.0, (1, 1348))
"""

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module; imported on first access, so that declaring the
#: plugin's sub-commands (``auralize --help``) loads none of its physics
_EXPORTS = {
    "bandwidth_extend": ".bandwidth",
    "fire_training_clip": ".clips",
    "read_audio": ".clips",
    "make_fire": ".dataset",
    "FlameFront": ".flamefront",
    "extract_front": ".flamefront",
    "refine_bspline": ".flamefront",
    "flux_series": ".lowfreq",
    "lowfreq_pressure": ".lowfreq",
    "mitchell_netravali": ".lowfreq",
    "FireSound": ".model",
    "fire_sound": ".model",
    "gaussian_pyramid": ".texture",
    "texture_extend": ".texture",
    "texture_synthesize": ".texture",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = [
    "FireSound",
    "FlameFront",
    "bandwidth_extend",
    "extract_front",
    "fire_sound",
    "fire_training_clip",
    "flux_series",
    "gaussian_pyramid",
    "lowfreq_pressure",
    "make_fire",
    "mitchell_netravali",
    "read_audio",
    "refine_bspline",
    "texture_extend",
    "texture_synthesize",
]
