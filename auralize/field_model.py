"""The core field auralization (paper 003) as a registered SoundModel named ``field``.

It shows the plugin contract on the built-in pipeline: parameters declared as
data, inputs = (volume, listener path), output = the pressure at the listener.
"""

from __future__ import annotations

from typing import Any, ClassVar

from auralize.plugins import Parameter, SoundModel, SoundOutput


class FieldAuralization(SoundModel):
    name: ClassVar[str] = "field"
    description: ClassVar[str] = (
        "monopole/dipole/quadrupole sources of a volume, retarded-time summation (Shin & Bajaj 2004)"
    )
    paper: ClassVar[str] = "003 §3.2, §4.1"
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter(
            "mapping",
            "auto",
            choices=("auto", "paper-density", "identity", "cfd"),
            doc="acoustic mapping preset (§3.2.2)",
        ),  # fmt: skip
        Parameter("threshold_monopole", "auto", doc="absolute, 'N%' of peak, or auto"),
        Parameter("threshold_dipole", "auto", doc="absolute, 'N%' of peak, or auto"),
        Parameter("threshold_quadrupole", "auto", doc="absolute, 'N%' of peak, or auto"),
        Parameter(
            "interp", "cubic", choices=("linear", "cubic"), doc="time interpolation (§3.2.4.3)"
        ),
        Parameter("rate", 44100, range=(8000, 384000), unit="Hz"),
        Parameter("time_scale", 1.0, range=(1e-6, None), unit="playback s / data s"),
        Parameter("c0", 343.0, range=(1.0, None), unit="m/s"),
    )

    def synthesize(self, inputs: Any, **params: Any) -> SoundOutput:
        """``inputs = (TimeVolume, ListenerPath)``; returns the mono pressure in Pa."""
        from auralize.pipeline import auralize
        from auralize.sources import Thresholds

        volume, path = inputs
        p = self.resolve(**params)
        th = Thresholds(p["threshold_monopole"], p["threshold_dipole"], p["threshold_quadrupole"])
        out, series = auralize(
            volume, path, mapping=None if p["mapping"] == "auto" else p["mapping"], thresholds=th,
            rate=p["rate"], time_scale=p["time_scale"], interp=p["interp"], c0=p["c0"],
        )  # fmt: skip
        return SoundOutput(rate=out.rate, pressure=out.audio[0],
                           meta={"n_sources": series.tracks().n_sources})  # fmt: skip
