"""The one render function: how every front end turns what is heard into audio.

:func:`render` (exported as :func:`auralize.pipeline.render`) takes what is
heard and a listener path and gives the audio, with one output rule, whatever
asks: ``auralize render`` (with or without a scene or Dask), ``auralize play``,
:func:`auralize.pipeline.auralize`, :mod:`auralize.simple`, the viewer's
Render to file and live listening, scene files and the models' own commands.

What is heard is a :class:`~auralize.emitters.Sound` (the parts of any
models: emitter sets, a model's own closed form, and the volume's sources as
:class:`~auralize.emitters.FieldSources`), one part, a list of parts, or the
source tracks of a volume (:class:`~auralize.sources.detection.SourceTracks`,
heard as their physical pressure).

The output rule: the output high-pass (``highpass_hz``, default 20 Hz, as
``auralize render --highpass``) filters the volume's sources, whose physical
pressure holds much inaudible sub-20 Hz energy; every other model is heard as
it made its sound (a model filters its own: fire's ``highpass_hz``, paper 001
§6), so a model mixed into a scene writes the same samples as its own command.

Four ways of rendering, one rule:

* offline (the default): a :class:`~auralize.emitters.synthesis.Rendered` of the
  whole duration; the field's high-pass is applied by its timbre
  (:func:`auralize.emitters.timbre.render_timbre`, whose ``auto`` and
  ``extended`` choices depend on it);
* block by block (``block=N`` samples): a :class:`RenderBlocks` for a sound
  device, whose blocks taken in order join into the offline render;
* continued (``carry=Carry()``): consecutive calls for consecutive stretches of
  playback (live listening, where the listener's pose changes from block to
  block) carry the high-pass state from call to call;
* on Dask (``runner=``, :mod:`auralize.distributed`): the volume's sources are
  synthesized in (block, source group) tasks on the workers, the other parts
  here, and the two are mixed by the same rule.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.constants import C0
from auralize.defaults import DEFAULTS
from auralize.errors import ParameterError

__all__ = ["Carry", "RenderBlocks", "as_sound", "render", "split_field"]


def as_sound(sound: Any) -> Any:
    """``sound`` as a :class:`~auralize.emitters.Sound`: a Sound as it is, one part or a
    list of parts in a Sound, source tracks as their physical pressure
    (one :class:`~auralize.emitters.FieldSources` of time scale 1)."""
    from auralize.emitters import FieldSources, Sound
    from auralize.emitters.engine import parts_of
    from auralize.sources.detection import SourceTracks

    if isinstance(sound, Sound):
        return sound
    if isinstance(sound, SourceTracks):
        return Sound([FieldSources(sound)], name="field")
    return Sound(parts_of(sound))


def split_field(sound: Any) -> tuple[Any, Any]:
    """``(field, models)``: the sound's field-source parts and every other part (two Sounds).

    The field parts are :class:`auralize.emitters.FieldSources` (the sources
    of a volume); the output high-pass applies to them only.
    """
    from auralize.emitters import FieldSources, Sound

    snd = as_sound(sound)
    field_parts = [p for p in snd.parts if isinstance(p, FieldSources)]
    others = [p for p in snd.parts if not isinstance(p, FieldSources)]
    return (Sound(list[Any](field_parts), meta=dict(snd.meta), name="field"),
            Sound(others, meta=dict(snd.meta), name="models"))  # fmt: skip


class Carry:
    """The state :func:`render` carries from one call to the next (``carry=``): the
    field's output high-pass, started from the first call's first sample as an
    offline render's filter starts."""

    def __init__(self) -> None:
        self.zi: NDArray[np.float64] | None = None
        self._sos: tuple[tuple[float, int], NDArray[np.float64]] | None = None

    def sos(self, hz: float, rate: int) -> NDArray[np.float64]:
        """The high-pass's second-order sections (designed once per cut-off and rate)."""
        from auralize.emitters.timbre import butter_sos

        key = (float(hz), int(rate))
        if self._sos is None or self._sos[0] != key:
            self._sos = (key, butter_sos(4, float(hz), "highpass", float(rate)))
            self.zi = None
        return self._sos[1]

    def filter(self, audio: NDArray[np.float64], hz: float, rate: int) -> NDArray[np.float64]:
        """``audio`` high-passed at ``hz``, continuing from the previous call's state."""
        from scipy.signal import sosfilt

        from auralize.emitters.timbre import highpass_start

        sos = self.sos(hz, rate)
        if audio.shape[1] == 0:
            return audio
        if self.zi is None or self.zi.shape[1] != audio.shape[0]:
            self.zi = highpass_start(sos, audio[:, 0])
        out, self.zi = sosfilt(sos, audio, axis=-1, zi=self.zi)
        return np.asarray(out)


def render(sound: Any, path: Any, *, rate: int = DEFAULTS.rate, layout: Any = DEFAULTS.layout,
           duration: float | None = None, start: float = 0.0,
           highpass_hz: float = DEFAULTS.highpass_hz, c0: float = C0, hrtf: object = None,
           backend: str = "auto", block: int | None = None, carry: Carry | None = None,
           runner: Any = None, block_seconds: float | None = None, air: Any = None,
           ground: Any = None) -> Any:  # fmt: skip
    """Render what is heard along a listener path: the one render of every front end.

    Parameters
    ----------
    sound : Sound, a part, a list of parts, or SourceTracks
        What is heard (module docstring).
    path : ListenerPath
        Where the listener goes; playback time counts from its first capture.
    rate : int
        Output sample rate, Hz.
    layout : str or Layout
        Speaker layout, Ambisonics order or ``binaural``
        (:func:`auralize.spatial.layouts.get_layout`).
    duration : float, optional
        Playback seconds (default: the path's, from ``start``).
    start : float
        Playback second of the first output sample (offline and continued).
    highpass_hz : float
        Cut-off of the causal output high-pass of the volume's sources, Hz (0: none).
    c0 : float
        Speed of sound, m/s.
    hrtf : HRIRSet, str or Path, optional
        ``binaural`` only: the HRIRs or a SOFA file (default the spherical head).
    backend : {"auto", "sampled", "reference"}
        The emitter sets' backend (:func:`auralize.emitters.engine.render_emitters`).
    block : int, optional
        Render block by block: returns a :class:`RenderBlocks` of this many samples
        per block (for :func:`auralize.audio.live.play`).
    carry : Carry, optional
        Continue a previous call (same ``carry``) whose stretch ended at ``start``.
    runner : optional
        A Dask runner (:func:`auralize.distributed.runner.make_runner`): the
        volume's sources are synthesized on its workers (physical timbre only).
    block_seconds : float, optional
        Playback seconds per Dask task block (``runner`` only).
    air : Air, optional
        Outdoor propagation: every part heard through still air that absorbs
        after ISO 9613-1 (:class:`auralize.emitters.outdoor.Air`); None (default): none.
    ground : Ground, optional
        Outdoor propagation: a flat ground with a reflection factor, every
        source heard with its image (:class:`auralize.emitters.outdoor.Ground`);
        None (default): none.  Without ``air`` and ``ground`` the render is
        what it always was, sample for sample.

    Returns
    -------
    Rendered or RenderBlocks
        ``audio (n_channels, round(duration * rate))`` in pascals; ``meta["parts"]``
        lists every part with its peak, ``meta["highpass_hz"]`` the field's cut-off.

    Raises
    ------
    ParameterError
        A bad cut-off, layout or rate, or two ways of rendering asked at once.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.emitters import Emitters
    >>> from auralize.listener import ListenerPath
    >>> tone = np.sin(2 * np.pi * 440 * np.arange(4410) / 44100)
    >>> em = Emitters(tone[None], 44100, [[3.0, 0, 0]])
    >>> r = render(em, ListenerPath.point((0, 0, 0), duration=0.1), layout="stereo")
    >>> r.audio.shape, [p["kind"] for p in r.meta["parts"]]
    ((2, 4410), ['Emitters'])
    """
    from auralize.emitters.outdoor import check_options
    from auralize.emitters.timbre import highpass

    highpass(np.zeros((1, 0)), int(rate), highpass_hz)  # a bad cut-off fails before rendering
    check_options(air, ground)
    ways = [name for name, v in (("block", block), ("carry", carry), ("runner", runner))
            if v is not None]  # fmt: skip
    if len(ways) > 1:
        raise ParameterError(f"render block by block, continued or on Dask, not "
                             f"{' and '.join(ways)} at once")  # fmt: skip
    snd = as_sound(sound)
    if block is not None:
        if start:
            raise ParameterError("a block-by-block render starts at the path's first capture "
                                 "(start=0)")  # fmt: skip
        return RenderBlocks(snd, path, rate=rate, layout=layout, block=block, duration=duration,
                            highpass_hz=highpass_hz, c0=c0, backend=backend, hrtf=hrtf,
                            **_outdoor(air, ground))  # fmt: skip
    kw: dict[str, Any] = dict(rate=int(rate), layout=layout, duration=duration, start=start,
                              c0=c0, backend=backend, hrtf=hrtf, **_outdoor(air, ground))  # fmt: skip
    if runner is not None:
        return _on_dask(snd, path, kw, highpass_hz, runner, block_seconds)
    if carry is not None:
        return _continued(snd, path, kw, highpass_hz, carry)
    from auralize.emitters.engine import render_sound

    field, _ = split_field(snd)
    out = render_sound(snd, path, **kw, field_highpass_hz=highpass_hz)
    out.meta["highpass_hz"] = float(highpass_hz) if field.parts else 0.0
    return out


def _outdoor(air: Any, ground: Any) -> dict[str, Any]:
    """The outdoor keywords of the engine's renders: none when both are off (the
    engine then renders exactly as it did before they existed)."""
    return {} if air is None and ground is None else {"air": air, "ground": ground}


def _continued(snd: Any, path: Any, kw: dict[str, Any], highpass_hz: float, carry: Carry) -> Any:
    """One stretch of a continued render: the field high-passed with the carried state."""
    from auralize.emitters.engine import render_sound

    field, models = split_field(snd)
    out = render_sound(field if field.parts else models, path, **kw)
    if field.parts and highpass_hz > 0:
        out.audio = carry.filter(out.audio, highpass_hz, kw["rate"])
    if field.parts and models.parts:
        more = render_sound(models, path, **kw)
        n = min(out.audio.shape[1], more.audio.shape[1])
        out.audio = np.array(out.audio)
        out.audio[:, :n] += more.audio[:, :n]
        out.meta["parts"] = [*out.meta["parts"], *more.meta["parts"]]
    out.meta["highpass_hz"] = float(highpass_hz) if field.parts else 0.0
    return out


def _on_dask(snd: Any, path: Any, kw: dict[str, Any], highpass_hz: float, runner: Any,
             block_seconds: float | None) -> Any:  # fmt: skip
    """The volume's sources synthesized on the runner's workers, the other parts here."""
    from auralize.distributed import render_distributed
    from auralize.emitters.engine import render_sound
    from auralize.emitters.timbre import highpass, loudness
    from auralize.spatial.layouts import get_layout

    field, models = split_field(snd)
    odd = sorted({p.timbre for p in field.parts} - {"physical", "auto"})
    if odd:
        raise ParameterError(f"timbre {'/'.join(odd)}: the Dask render renders the physical "
                             f"pressure only; render it without the Dask options")  # fmt: skip
    lay: Any = get_layout(kw["layout"])
    path_dur = path.duration - kw["start"]
    duration = path_dur if kw["duration"] is None else float(kw["duration"])
    if kw["start"]:
        raise ParameterError("a Dask render starts at the path's first capture (start=0)")
    out = None
    listing = []
    if "air" in kw:  # outdoors: the sources with their ground images, through the air
        from auralize.emitters.outdoor import outdoor_parts

        field.parts = outdoor_parts(field.parts, path, air=kw["air"], ground=kw["ground"],
                                    c0=kw["c0"])  # fmt: skip
    for part in field.parts:

        def run(k: dict[str, Any], part: Any = part) -> Any:
            return render_distributed(part.tracks, path, rate=kw["rate"],
                                      time_scale=part.time_scale, interp=part.interp, layout=lay,
                                      c0=kw["c0"], duration=k["duration"], bounds=part.bounds,
                                      block_seconds=block_seconds, runner=runner,
                                      lead=part.lead)  # fmt: skip

        if getattr(part, "air", None) is not None:
            from auralize.emitters.outdoor import field_distance, received

            r = received(run, {"rate": kw["rate"], "start": 0.0, "duration": duration}, path,
                         part.air, field_distance(part, path, c0=kw["c0"]))  # fmt: skip
        else:
            r = run({"duration": duration})
        listing.append({"model": part.name, "kind": "FieldSources (Dask)",
                        "peak_pa": float(np.max(np.abs(r.audio), initial=0.0))})  # fmt: skip
        if out is None:
            out = r
        else:
            out.audio = out.audio + r.audio
    if out is None:
        return render(models, path, highpass_hz=highpass_hz, **kw)
    share = loudness(out.audio, out.rate)["share_above"]
    out.audio = highpass(out.audio, out.rate, highpass_hz)
    out.meta.update({"parts": listing, "highpass_hz": float(highpass_hz), "timbre": "physical",
                     "share_above_20hz_unfiltered": share, **snd.meta})  # fmt: skip
    if "air" in kw:
        from auralize.emitters.outdoor import describe

        out.meta["outdoor"] = describe(kw["air"], kw["ground"])
    if models.parts:
        more = render_sound(models, path, **{**kw, "duration": duration})
        n = min(out.audio.shape[1], more.audio.shape[1])
        out.audio[:, :n] += more.audio[:, :n]
        out.meta["parts"] = [*listing, *more.meta["parts"]]
    return out


class RenderBlocks:
    """What is heard, rendered block by block for a sound device, with :func:`render`'s rule.

    The interface :func:`auralize.audio.live.play` takes: ``block(i)``,
    ``render_range(start, n)``, ``n_blocks``, ``n_samples``, ``block_size``,
    ``rate``, ``layout``.  The volume's sources' blocks go through the causal
    ``highpass_hz`` high-pass, its state carried from block to block, so blocks
    taken in order join into the offline :func:`render` of the whole duration
    (of the ``physical`` timbre); the other models' blocks are added as they are.
    Made by ``render(..., block=N)``; arguments as :func:`render`.
    """

    def __init__(self, sound: Any, path: Any, *, rate: int = DEFAULTS.rate,
                 layout: Any = DEFAULTS.layout, block: int | None = None,
                 duration: float | None = None, highpass_hz: float = DEFAULTS.highpass_hz,
                 **kw: Any) -> None:  # fmt: skip
        from auralize.emitters.engine import BlockRenderer
        from auralize.emitters.timbre import highpass

        highpass(np.zeros((1, 0)), rate, highpass_hz)  # a bad cut-off fails here
        snd = as_sound(sound)
        field, models = split_field(snd)
        args: dict[str, Any] = dict(rate=rate, layout=layout, block=block, duration=duration,
                                    **kw)  # fmt: skip
        self.highpass_hz = float(highpass_hz)
        self.field: Any
        self.models: Any
        if not field.parts or self.highpass_hz == 0:
            self.field, self.models = None, BlockRenderer(snd, path, **args)
        else:
            self.field = BlockRenderer(field, path, **args)
            self.models = BlockRenderer(models, path, **args) if models.parts else None
        first = self.field if self.field is not None else self.models
        assert first is not None
        self.rate: int = first.rate
        self.layout: Any = first.layout
        self.block_size: int = first.block_size
        self.n_samples: int = first.n_samples
        self.n_blocks: int = first.n_blocks
        self.duration: float = first.duration
        self.meta = dict(first.meta)
        self._carry: Carry | None = None
        self._next = 0

    def _field_range(self, start: int, n: int, carry: Carry) -> NDArray[np.float64]:
        assert self.field is not None
        return carry.filter(self.field.render_range(start, n), self.highpass_hz, self.rate)

    def render_range(self, start: int, n: int) -> NDArray[np.float64]:
        """Samples ``[start, start + n)`` (the field's filter run from sample 0)."""
        if self.field is None:
            assert self.models is not None
            return self.models.render_range(start, n)
        a = self._field_range(0, int(start) + int(n), Carry())[:, int(start) :]
        if self.models is not None:
            a = a + self.models.render_range(start, n)
        return a

    def block(self, i: int) -> NDArray[np.float64]:
        """Block ``i`` (the last one may be shorter); in order, the filter state carries on."""
        if self.field is None:
            assert self.models is not None
            return self.models.block(i)
        if not 0 <= i < self.n_blocks:
            raise ParameterError(f"block index {i} outside 0..{self.n_blocks - 1}")
        s = i * self.block_size
        n = min(self.block_size, self.n_samples - s)
        if i != self._next or self._carry is None:  # out of order: run the filter up to it
            self._carry = Carry()
            if s:
                self._field_range(0, s, self._carry)
        a = self._field_range(s, n, self._carry)
        self._next = i + 1
        if self.models is not None:
            a = a + self.models.block(i)
        return a
