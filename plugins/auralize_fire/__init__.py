"""auralize_fire: fire sound from flame-front flux, bandwidth extension, textures (paper 001)."""
