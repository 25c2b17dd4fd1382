"""auralize_vortex: vortex sound from turbulent fields with sound textures (paper 000)."""
