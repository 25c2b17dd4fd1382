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

from auralize.defaults import DEFAULTS, TIMBRE_CHOICES
from auralize.plugins import Parameter, SoundModel

if TYPE_CHECKING:
    from auralize.emitters import Sound
    from auralize.listener import ListenerPath
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
        ),
        Parameter(
            "threshold_monopole", DEFAULTS.thresholds[0], doc="absolute, 'N%' of peak, or auto"
        ),
        Parameter(
            "threshold_dipole", DEFAULTS.thresholds[1], doc="absolute, 'N%' of peak, or auto"
        ),
        Parameter(
            "threshold_quadrupole", DEFAULTS.thresholds[2], doc="absolute, 'N%' of peak, or auto"
        ),
        Parameter(
            "interp",
            DEFAULTS.interp,
            choices=("linear", "cubic"),
            doc="time interpolation (§3.2.4.3)",
        ),
        Parameter(
            "time_scale",
            DEFAULTS.time_scale,
            range=(1e-6, None),
            auto=True,
            unit="playback s / data s",
            doc="or auto: the data's sound plays in the render's duration",
        ),
        Parameter(
            "lead",
            "auto",
            range=(0.0, None),
            auto=True,
            unit="data s",
            doc="data seconds skipped at the start of playback, or auto: the travel time "
            "from the nearest source to the listener",
        ),
        Parameter(
            "timbre",
            DEFAULTS.timbre,
            choices=TIMBRE_CHOICES,
            doc="how the sources sound (auralize.emitters.timbre)",
        ),
        Parameter(
            "fields",
            None,
            doc="the mapping's fields by role, e.g. {'density': 'rho'} (as --density-field)",
        ),
        Parameter(
            "heard",
            DEFAULTS.heard,
            doc="what is heard: field (the whole field), detected, a list of types such as "
            "dipole,quadrupole, or field:quadrupole (auralize.sources.field.parse_heard)",
        ),
    )

    def synthesize(self, inputs: TimeVolume | tuple[TimeVolume, Any], **params: Any) -> Sound:
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
            ``lead`` (data s skipped), ``timbre`` and ``heard``; their defaults
            are :data:`auralize.defaults.DEFAULTS`.  ``time_scale`` and
            ``lead`` ``"auto"`` are planned for the listener path when one is
            given (:meth:`plan`), else for the default render's orbit.

        Returns
        -------
        auralize.emitters.Sound
            One :class:`~auralize.emitters.FieldSources` part; ``meta`` holds
            the number of source tracks, the mapping and the thresholds.
        """
        from auralize.emitters import FieldSources, Sound
        from auralize.pipeline import heard_sound, plan_render

        volume, series, given, near = _split_inputs(inputs)
        p = self.resolve(**params)
        hs = given
        if hs is None and near is not None:
            return self.synthesize(self.plan(inputs, params, near, near.duration)[0], **params)
        if hs is None:  # no listener known: every block of the whole field through its proxies
            hs = heard_sound(volume, **_heard_args(p, params, series))
        ts, lead = p["time_scale"], p["lead"]
        if "auto" in (ts, lead):  # planned for the default render: an orbit of the default length
            plan = plan_render(
                volume,
                hs.tracks if hs.heard.mode == "detected" else None,
                duration=DEFAULTS.duration,
                time_scale=ts,
                clip=False,
            )
            ts = plan.time_scale if ts == "auto" else ts
            lead = plan.lead if lead == "auto" else lead
        tracks = hs.tracks
        part = FieldSources(
            tracks=tracks,
            time_scale=float(ts),
            lead=float(lead),
            interp=p["interp"],
            timbre=p["timbre"],
            bounds=tuple(volume.bounds),
            name="field",
            by_type=hs.by_type,
        )
        meta = {
            "n_sources": tracks.n_sources,
            "volume": volume.source,
            "time_scale": part.time_scale,
            "lead_data_s": part.lead,
            **hs.meta,
        }
        return Sound(parts=[part], meta={"field": meta}, name="field")

    def plan(
        self, inputs: Any, params: dict[str, Any], path: ListenerPath, duration: float
    ) -> tuple[Any, dict[str, Any]]:
        """What the volume's render along ``path`` hears, and its time scale and lead.

        :func:`auralize.pipeline.plan_heard`, as ``auralize render`` plans:
        ``time_scale="auto"`` fits the data's sound in ``duration``, ``lead``
        (unless given) skips the travel time from the nearest source to the
        path, and the whole field's blocks near the path are heard as their
        points.  Returns ``((volume, HeardSound), params)`` with numbers for
        ``time_scale`` and ``lead``.
        """
        from auralize.pipeline import plan_heard

        volume, series, given, _ = _split_inputs(inputs)
        if given is not None:
            return inputs, params
        p = self.resolve(**params)
        hs, plan = plan_heard(
            volume,
            path=path,
            duration=duration,
            time_scale=p["time_scale"],
            clip=False,
            **_heard_args(p, params, series),
        )
        out = {**params, "time_scale": plan.time_scale}
        if p["lead"] == "auto":
            out["lead"] = plan.lead
        return (volume, hs), out


def _split_inputs(inputs: Any) -> tuple[TimeVolume, Any, HeardSound | None, ListenerPath | None]:
    """The field model's inputs as ``(volume, series, heard sound, path)`` (None when absent)."""
    from auralize.errors import ParameterError
    from auralize.listener import ListenerPath
    from auralize.pipeline import HeardSound
    from auralize.sources.detection import SourceSeries
    from auralize.volume import TimeVolume

    series, given, near = None, None, None
    if isinstance(inputs, tuple) and len(inputs) == 2:
        volume, second = inputs
        if isinstance(second, HeardSound):
            given = second
        elif isinstance(second, SourceSeries):
            series = second
        elif isinstance(second, ListenerPath):
            near = second
        else:
            raise ParameterError(
                f"field model: the second input must be a SourceSeries, a "
                f"HeardSound or a ListenerPath, got "
                f"{type(second).__name__}"
            )
    else:
        volume = inputs
    if not isinstance(volume, TimeVolume):
        raise ParameterError(
            f"field model inputs must be a TimeVolume or (TimeVolume, "
            f"SourceSeries), got {type(volume).__name__}"
        )
    return volume, series, given, near


def _heard_args(p: dict[str, Any], params: dict[str, Any], series: Any) -> dict[str, Any]:
    """:func:`auralize.pipeline.heard_sound`'s arguments from the resolved parameters ``p``
    (``params`` as given: detected sources given without ``heard`` are what is heard)."""
    from auralize.sources.detection import Thresholds
    from auralize.sources.field import parse_heard

    heard = parse_heard(p["heard"])
    if series is not None and params.get("heard") is None:
        heard = parse_heard("detected")
    th = Thresholds(p["threshold_monopole"], p["threshold_dipole"], p["threshold_quadrupole"])
    fields = p["fields"] or {}
    if not isinstance(fields, dict) or not all(isinstance(v, str) for v in fields.values()):
        from auralize.errors import ParameterError

        raise ParameterError(
            f"field model: 'fields' maps roles to field names, e.g. "
            f"{{'density': 'rho'}}, got {fields!r}"
        )
    return {
        "heard": heard,
        "series": series,
        "thresholds": th,
        "mapping": None if p["mapping"] == "auto" else p["mapping"],
        **fields,
    }
