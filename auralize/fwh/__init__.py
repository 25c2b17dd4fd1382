"""Ffowcs Williams–Hawkings integral on a permeable surface, from stored volume data.

The far field of everything inside a closed surface, from the flow sampled
on it (density, velocity, pressure) at the data's steps: Farassat's
formulation 1A with retarded time (:mod:`auralize.fwh.formulation`) on a box,
a sphere or any closed VTK surface (:mod:`auralize.fwh.surface`), the flow
sampled trilinearly on the panels (:mod:`auralize.fwh.sampling`).  See
``docs/fwh.md`` for the formulas, assumptions and verification.

Examples
--------
>>> from auralize.fwh import box_surface
>>> box_surface((-1, 1, -1, 1, -1, 1), n=4).n_panels
96
"""

from auralize.fwh.formulation import (
    fwh_emitters,
    fwh_pressure,
    fwh_pressure_from_sources,
    fwh_sources,
    fwh_time_window,
)
from auralize.fwh.sampling import SurfaceSamples, sample_surface
from auralize.fwh.surface import (
    Surface,
    box_surface,
    mesh_surface,
    sphere_surface,
    surface_from_spec,
)

__all__ = [
    "Surface",
    "SurfaceSamples",
    "box_surface",
    "fwh_emitters",
    "fwh_pressure",
    "fwh_pressure_from_sources",
    "fwh_sources",
    "fwh_time_window",
    "mesh_surface",
    "sample_surface",
    "sphere_surface",
    "surface_from_spec",
]
