"""The FW-H surface integral as the sound model ``fwh`` (entry point ``auralize.plugins``).

``auralize render --model "fwh:DATA.h5:surface=box=-0.6;0.6;-0.6;0.6;-0.6;0.6"``
hears it, mixed with any other model, on any layout.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

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
            "file=PATH (a closed surface inside the grid, around the sources)",
        ),  # fmt: skip
        Parameter(
            "panel_size",
            0.0,
            range=(0.0, None),
            unit="m",
            doc="box panel edge (0: the grid's smallest spacing)",
        ),  # fmt: skip
        Parameter("rho0", 1.2, range=(1e-9, None), unit="kg/m³"),
        Parameter("c0", 343.0, range=(1e-9, None), unit="m/s"),
        Parameter("p0", "auto", doc="ambient pressure in Pa, or auto (first step's mean)"),
        Parameter("oversample", 4, range=(1, 64), doc="emission samples per data step"),
        Parameter("time_origin", "auto", doc="data second at playback 0 (auto: first step)"),
    )

    def synthesize(self, inputs: Any, **params: Any) -> Sound:
        """The FW-H emitters of a volume (see :func:`auralize.fwh.formulation.fwh_emitters`)."""
        from auralize.errors import ParameterError
        from auralize.fwh.formulation import fwh_emitters
        from auralize.fwh.surface import surface_from_spec
        from auralize.volume import TimeVolume

        if not isinstance(inputs, TimeVolume):
            raise ParameterError(f"fwh model inputs must be a TimeVolume, got "
                                 f"{type(inputs).__name__}")  # fmt: skip
        p = self.resolve(**params)
        if not p["surface"]:
            raise ParameterError("fwh model needs surface=box=x0;x1;y0;y1;z0;z1, "
                                 "sphere=cx;cy;cz;r or file=PATH")  # fmt: skip
        panel = float(p["panel_size"]) or float(inputs.spacing.min())
        surface = surface_from_spec(str(p["surface"]), panel_size=panel)

        def number(key: str) -> float | None:
            v = p[key]
            if v in ("auto", None):
                return None
            try:
                return float(v)
            except (TypeError, ValueError):
                raise ParameterError(f"fwh model: {key} must be a number or auto, "
                                     f"got {v!r}") from None  # fmt: skip

        return fwh_emitters(inputs, surface, rho0=float(p["rho0"]), c0=float(p["c0"]),
                            p0=number("p0"), oversample=int(p["oversample"]),
                            time_origin=number("time_origin"))  # fmt: skip
