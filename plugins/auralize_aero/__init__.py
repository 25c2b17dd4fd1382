"""auralize_aero: aerodynamic sound with Curle's model and sound textures (paper 004)."""
