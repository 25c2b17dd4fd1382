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

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module; imported on first access, so that listing the
#: ``fwh`` model (``auralize --help``, ``--version``) loads none of its physics
_EXPORTS = {
    "fwh_emitters": ".formulation",
    "fwh_pressure": ".formulation",
    "fwh_pressure_from_sources": ".formulation",
    "fwh_sources": ".formulation",
    "fwh_time_window": ".formulation",
    "SurfaceSamples": ".sampling",
    "sample_surface": ".sampling",
    "Surface": ".surface",
    "box_surface": ".surface",
    "mesh_surface": ".surface",
    "sphere_surface": ".surface",
    "surface_from_spec": ".surface",
}

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

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
