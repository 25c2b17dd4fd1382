"""The core field auralization (paper 003) as a registered SoundModel named ``field``.

It shows the plugin contract on the built-in pipeline: parameters declared as
data, inputs = a volume (no listener), output = what the volume emits — by
default the sound of its whole field, or its detected monopole/dipole/quadrupole
sources (``heard``, :func:`auralize.pipeline.heard_sound`) — as one
:class:`auralize.emitters.FieldSources` part that the engine renders along
any listener path.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

from auralize.plugins import Parameter, SoundModel

if TYPE_CHECKING:
    from auralize.emitters import Sound
    from auralize.pipeline import HeardSound
    from auralize.volume import TimeVolume


class FieldAuralization(SoundModel):
    name: ClassVar[str] = "field"
    description: ClassVar[str] = (
        "monopole/dipole/quadrupole sources of a volume, retarded-time summation (Shin & Bajaj 2004)"
    )
    paper: ClassVar[str] = "003 §3.2, §4.1"
    input_kind: ClassVar[str] = "volume"
    parameters: ClassVar[tuple[Parameter, ...]] = (
        Parameter(
            "mapping",
            "auto",
            choices=("auto", "paper-density", "identity", "cfd", "incompressible"),
            doc="acoustic mapping preset (§3.2.2)",
        ),  # fmt: skip
        Parameter("threshold_monopole", "auto", doc="absolute, 'N%' of peak, or auto"),
        Parameter("threshold_dipole", "auto", doc="absolute, 'N%' of peak, or auto"),
        Parameter("threshold_quadrupole", "auto", doc="absolute, 'N%' of peak, or auto"),
        Parameter(
            "interp", "cubic", choices=("linear", "cubic"), doc="time interpolation (§3.2.4.3)"
        ),
        Parameter("time_scale", 1.0, range=(1e-6, None), unit="playback s / data s"),
        Parameter(
            "lead",
            0.0,
            range=(0.0, None),
            unit="data s",
            doc="data seconds skipped at the start of playback",
        ),  # fmt: skip
        Parameter(
            "timbre",
            "physical",
            choices=("physical", "extended", "tonal", "auto"),
            doc="how the sources sound (auralize.emitters.timbre)",
        ),
        Parameter(
            "heard",
            "field",
            doc="what is heard: field (the whole field), detected, a list of types such as "
            "dipole,quadrupole, or field:quadrupole (auralize.sources.field.parse_heard)",
        ),
    )

    def synthesize(self, inputs: TimeVolume | tuple[TimeVolume, Any],
                   **params: Any) -> Sound:  # fmt: skip
        """The sources of a volume, for the engine to render.

        Parameters
        ----------
        inputs : TimeVolume, or (TimeVolume, SourceSeries | HeardSound | ListenerPath)
            The volume; with a :class:`~auralize.sources.detection.SourceSeries` already
            detected on it (e.g. by ``auralize detect``), those sources are heard;
            with a :class:`~auralize.pipeline.HeardSound` (:func:`auralize.pipeline.heard_sound`),
            that sound; with the :class:`~auralize.listener.ListenerPath` a scene
            renders along, the whole field's blocks near it are heard as their points
            (:func:`auralize.sources.field.field_tracks`; the model's sound is still
            rendered by the engine along any path).
        **params
            ``mapping`` and ``threshold_*`` (detection, paper 003 §3.2.2–3.2.3),
            ``interp`` (§3.2.4.3), ``time_scale`` (playback s per data s),
            ``lead`` (data s skipped) and ``timbre``.

        Returns
        -------
        auralize.emitters.Sound
            One :class:`~auralize.emitters.FieldSources` part; ``meta`` holds
            the number of source tracks, the mapping and the thresholds.
        """
        from auralize.emitters import FieldSources, Sound
        from auralize.errors import ParameterError
        from auralize.listener import ListenerPath
        from auralize.pipeline import HeardSound, heard_sound
        from auralize.sources.detection import SourceSeries, Thresholds
        from auralize.sources.field import parse_heard
        from auralize.volume import TimeVolume

        series = None
        given: HeardSound | None = None
        near = None
        if isinstance(inputs, tuple) and len(inputs) == 2:
            volume, second = inputs
            if isinstance(second, HeardSound):
                given = second
            elif isinstance(second, SourceSeries):
                series = second
            elif isinstance(second, ListenerPath):
                near = second
            else:
                raise ParameterError(f"field model: the second input must be a SourceSeries, a "
                                     f"HeardSound or a ListenerPath, got "
                                     f"{type(second).__name__}")  # fmt: skip
        else:
            volume = inputs  # type: ignore[assignment]
        if not isinstance(volume, TimeVolume):
            raise ParameterError(f"field model inputs must be a TimeVolume or (TimeVolume, "
                                 f"SourceSeries), got {type(volume).__name__}")  # fmt: skip
        p = self.resolve(**params)
        th = Thresholds(p["threshold_monopole"], p["threshold_dipole"], p["threshold_quadrupole"])
        heard = parse_heard(p["heard"])
        if series is not None and params.get("heard") is None:
            heard = parse_heard("detected")  # sources given: they are what is heard
        # (without a path every block of the whole field is heard through its proxies)
        hs = given or heard_sound(volume, heard=heard, series=series, thresholds=th, path=near,
                                  mapping=None if p["mapping"] == "auto" else p["mapping"])  # fmt: skip
        tracks = hs.tracks
        part = FieldSources(tracks=tracks, time_scale=float(p["time_scale"]), lead=float(p["lead"]),
                            interp=p["interp"], timbre=p["timbre"], bounds=tuple(volume.bounds),
                            name="field", by_type=hs.by_type)  # fmt: skip
        meta = {"n_sources": tracks.n_sources, "volume": volume.source,
                "time_scale": part.time_scale, "lead_data_s": part.lead, **hs.meta}  # fmt: skip
        return Sound(parts=[part], meta={"field": meta}, name="field")
