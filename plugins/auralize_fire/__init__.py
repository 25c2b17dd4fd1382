"""auralize_fire: fire sound from flame-front flux, bandwidth extension, textures (paper 001).

Chain: a flame simulation (TimeVolume with a burn-rate and a velocity field)
→ flame front by cubic B-spline + VTK contouring (§3.2) → flux integral
I(t) = ∫ u·n dS (§3.1) → p = dI/dt at audio rate with the Mitchell–Netravali
filter (§3.3) → 30 Hz high-pass (§6) → spectral bandwidth extension (§4) or
sound texture synthesis (§5).

Examples
--------
>>> from auralize_fire import FireSound, make_fire
>>> out = FireSound().synthesize(make_fire(size=12, steps=12), extend="none")
>>> out.rate, out.pressure.shape
(44100, (1348,))
"""

from auralize_fire.bandwidth import bandwidth_extend
from auralize_fire.clips import fire_training_clip, read_audio
from auralize_fire.dataset import make_fire
from auralize_fire.flamefront import FlameFront, extract_front, refine_bspline
from auralize_fire.lowfreq import flux_series, lowfreq_pressure, mitchell_netravali
from auralize_fire.model import FireSound
from auralize_fire.texture import gaussian_pyramid, texture_synthesize

__all__ = [
    "FireSound",
    "FlameFront",
    "bandwidth_extend",
    "extract_front",
    "fire_training_clip",
    "flux_series",
    "gaussian_pyramid",
    "lowfreq_pressure",
    "make_fire",
    "mitchell_netravali",
    "read_audio",
    "refine_bspline",
    "texture_synthesize",
]
