"""The FW-H surface integral as the sound model ``fwh`` (entry point ``auralize.plugins``).

``auralize render --model "fwh:DATA.h5:surface=box=-0.6;0.6;-0.6;0.6;-0.6;0.6"``
hears it, mixed with any other model, on any layout.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from auralize.plugins import Parameter, SoundModel

if TYPE_CHECKING:
    from auralize.emitters import Sound


class FWHSound(SoundModel):
    """Permeable-surface Ffowcs Williams–Hawkings integral (Farassat's formulation 1A).

    Inputs: one :class:`~auralize.volume.TimeVolume` with density and/or
    pressure and velocity (or momentum).  Output: per panel a monopole and
    two dipoles (:func:`auralize.fwh.formulation.fwh_emitters`), played in
    data time (playback second 0 = ``time_origin``, default the first step).

    Examples
    --------
    >>> m = FWHSound()
    >>> m.resolve(surface="sphere=0;0;0;1")["panel_size"]
    0.0
    """

    name: ClassVar[str] = "fwh"
    description: ClassVar[str] = (
        "Ffowcs Williams-Hawkings integral on a closed surface (Farassat 1A, stationary)"
    )
    paper: ClassVar[str] = "Farassat 2007, NASA/TM-2007-214853"
    input_kind: ClassVar[str] = "volume"
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter(
            "surface",
            "",
            doc="box=x0;x1;y0;y1;z0;z1, sphere=cx;cy;cz;r[;nsub] or "
            "file=PATH (a closed surface inside the grid, around the sources; "
            "default: a box 10 % of the extent, at least 3 cells, inside each face)",
        ),
        Parameter(
            "panel_size",
            0.0,
            range=(0.0, None),
            unit="m",
            doc="box panel edge (0: the grid's smallest spacing)",
        ),
        Parameter("rho0", 1.2, range=(1e-9, None), unit="kg/m³"),
        Parameter("c0", 343.0, range=(1e-9, None), unit="m/s"),
        Parameter("p0", "auto", doc="ambient pressure in Pa, or auto (first step's mean)"),
        Parameter("oversample", 4, range=(1, 64), doc="emission samples per data step"),
        Parameter(
            "solid",
            0,
            range=(0, 1),
            doc="1: the surface is a body's wall (impermeable, no slip): Curle's loading noise",
        ),
        Parameter("time_origin", "auto", doc="data second at playback 0 (auto: first step)"),
    )

    def surface_of(self, volume: Any, params: dict[str, Any]) -> Any:
        """The :class:`~auralize.fwh.surface.Surface` the resolved ``params`` place in
        ``volume``: the ``surface`` given, or the default box
        (:func:`auralize.fwh.classify.default_surface`, as ``auralize render`` uses)."""
        from auralize.fwh.classify import default_surface
        from auralize.fwh.surface import surface_from_spec

        spec = str(params["surface"]) or default_surface(volume)
        panel = float(params["panel_size"]) or float(volume.spacing.min())
        return surface_from_spec(spec, panel_size=panel)

    def overlay(self, inputs: Any, step: int) -> Any:
        """The FW-H surface for the viewer, its panels coloured by p' (Pa) at ``step``.

        ``inputs`` is a TimeVolume or ``(TimeVolume, path)``; the surface is the
        one :meth:`synthesize` integrates over with the model's parameters
        (default: the box inside the data that ``auralize render`` uses).

        Raises
        ------
        FieldError, DataError
            The data cannot be heard through the surface (no velocity, no density
            or pressure, a curvilinear grid, the surface outside the grid): the
            viewer says so in its Overlays panel.
        """
        import pyvista as pv

        from auralize.errors import ParameterError
        from auralize.fwh.sampling import panel_pressure, trilinear_weights
        from auralize.volume import TimeVolume

        volume = inputs[0] if isinstance(inputs, tuple) else inputs
        if not isinstance(volume, TimeVolume):
            raise ParameterError(f"fwh overlay needs a TimeVolume, got {type(volume).__name__}")
        p = self.resolve()
        surface = self.surface_of(volume, p)
        trilinear_weights(volume, surface.centres[:1])  # a curvilinear grid says why it cannot
        corners = surface.corners
        P, k = corners.shape[:2]
        faces = np.hstack([np.full((P, 1), k), np.arange(P * k).reshape(P, k)]).ravel()
        mesh = pv.PolyData(corners.reshape(-1, 3).copy(), faces=faces)
        mesh.cell_data["p' (Pa)"] = panel_pressure(
            volume, surface, step, rho0=float(p["rho0"]), c0=float(p["c0"])
        )
        return mesh

    def synthesize(self, inputs: Any, **params: Any) -> Sound:
        """The FW-H emitters of a volume (see :func:`auralize.fwh.formulation.fwh_emitters`)."""
        from auralize.errors import ParameterError
        from auralize.fwh.formulation import fwh_emitters
        from auralize.volume import TimeVolume

        if not isinstance(inputs, TimeVolume):
            raise ParameterError(
                f"fwh model inputs must be a TimeVolume, got {type(inputs).__name__}"
            )
        p = self.resolve(**params)
        surface = self.surface_of(inputs, p)

        def number(key: str) -> float | None:
            v = p[key]
            if v in ("auto", None):
                return None
            try:
                return float(v)
            except (TypeError, ValueError):
                raise ParameterError(
                    f"fwh model: {key} must be a number or auto, got {v!r}"
                ) from None

        return fwh_emitters(
            inputs,
            surface,
            rho0=float(p["rho0"]),
            c0=float(p["c0"]),
            p0=number("p0"),
            oversample=int(p["oversample"]),
            time_origin=number("time_origin"),
            solid=bool(int(p["solid"])),
        )
