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

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from auralize.constants import C0
from auralize.defaults import DEFAULTS
from auralize.errors import ParameterError

if TYPE_CHECKING:
    from auralize.emitters import Backend

__all__ = ["Carry", "RenderBlocks", "as_sound", "render", "split_field"]


def as_sound(sound: Any) -> Any:
    """``sound`` as a :class:`~auralize.emitters.Sound`: a Sound as it is, one part or a
    list of parts in a Sound, source tracks as their physical pressure
    (one :class:`~auralize.emitters.FieldSources` of time scale 1).

    Parameters
    ----------
    sound : Sound, a part, a list of parts, or SourceTracks
        What is heard (module docstring).

    Returns
    -------
    Sound
        ``sound`` itself when it is one.

    Examples
    --------
    >>> from auralize.emitters import Emitters
    >>> em = Emitters(np.zeros((1, 8)), 8000, [[1.0, 0, 0]], name="tone")
    >>> snd = as_sound([em, em])
    >>> type(snd).__name__, [p.name for p in snd.parts], as_sound(snd) is snd
    ('Sound', ['tone', 'tone'], True)
    """
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

    Parameters
    ----------
    sound : Sound, a part, a list of parts, or SourceTracks
        What is heard (:func:`as_sound`).

    Returns
    -------
    field : Sound
        The :class:`~auralize.emitters.FieldSources` parts, named ``"field"``.
    models : Sound
        The other parts, named ``"models"``; both keep the sound's ``meta``.

    Examples
    --------
    >>> from auralize.emitters import Emitters, FieldSources
    >>> from auralize.sources.detection import SourceTracks
    >>> tracks = SourceTracks(positions=np.zeros((1, 3)), q=np.zeros((1, 2)),
    ...                       radius=np.array([0.1]), times=np.array([0.0, 1.0]))
    >>> em = Emitters(np.zeros((1, 8)), 8000, [[1.0, 0, 0]])
    >>> field, models = split_field([em, FieldSources(tracks)])
    >>> [type(p).__name__ for p in field.parts], [type(p).__name__ for p in models.parts]
    (['FieldSources'], ['Emitters'])
    """
    from auralize.emitters import FieldSources, Sound

    snd = as_sound(sound)
    field_parts = [p for p in snd.parts if isinstance(p, FieldSources)]
    others = [p for p in snd.parts if not isinstance(p, FieldSources)]
    return (
        Sound(list[Any](field_parts), meta=dict(snd.meta), name="field"),
        Sound(others, meta=dict(snd.meta), name="models"),
    )


class Carry:
    """The state :func:`render` carries from one call to the next (``carry=``): the
    field's output high-pass, started from the first call's first sample as an
    offline render's filter starts.

    Examples
    --------
    Two stretches filtered in turn equal the whole filtered at once:

    >>> x = np.random.default_rng(0).normal(size=(1, 800))
    >>> carry = Carry()
    >>> parts = [carry.filter(x[:, :300], 20.0, 8000), carry.filter(x[:, 300:], 20.0, 8000)]
    >>> bool(np.allclose(np.hstack(parts), Carry().filter(x, 20.0, 8000)))
    True
    """

    def __init__(self) -> None:
        self.zi: NDArray[np.float64] | None = None
        self._sos: tuple[tuple[float, int], NDArray[np.float64]] | None = None

    def sos(self, hz: float, rate: int) -> NDArray[np.float64]:
        """The high-pass's second-order sections (designed once per cut-off and rate).

        A new cut-off or rate designs the filter anew and starts its state afresh.

        Parameters
        ----------
        hz : float
            Cut-off, Hz (0 < hz < rate / 2).
        rate : int
            Sample rate, Hz.

        Returns
        -------
        (2, 6) float
            The 4th-order Butterworth high-pass as second-order sections.

        Examples
        --------
        >>> carry = Carry()
        >>> carry.sos(20.0, 8000).shape, carry.sos(20.0, 8000) is carry.sos(20.0, 8000)
        ((2, 6), True)
        """
        from auralize.emitters.timbre import butter_sos

        key = (float(hz), int(rate))
        if self._sos is None or self._sos[0] != key:
            self._sos = (key, butter_sos(4, float(hz), "highpass", float(rate)))
            self.zi = None
        return self._sos[1]

    def filter(self, audio: NDArray[np.float64], hz: float, rate: int) -> NDArray[np.float64]:
        """``audio`` high-passed at ``hz``, continuing from the previous call's state.

        The first call starts the filter in the steady state of its first
        sample (:func:`auralize.emitters.timbre.highpass_start`), as an
        offline render's high-pass starts.

        Parameters
        ----------
        audio : (n_channels, n) float
            The next stretch of the field's pressure, Pa.
        hz : float
            Cut-off, Hz.
        rate : int
            Sample rate, Hz.

        Returns
        -------
        (n_channels, n) float
            The filtered stretch.

        Examples
        --------
        A constant is no sound: from its steady state the high-pass passes nothing.

        >>> out = Carry().filter(np.full((2, 400), 3.0), 20.0, 8000)
        >>> out.shape, float(np.abs(out).max()) < 1e-9
        ((2, 400), True)
        """
        from scipy.signal import sosfilt

        from auralize.emitters.timbre import highpass_start

        sos = self.sos(hz, rate)
        if audio.shape[1] == 0:
            return audio
        if self.zi is None or self.zi.shape[1] != audio.shape[0]:
            self.zi = highpass_start(sos, audio[:, 0])
        out, self.zi = sosfilt(sos, audio, axis=-1, zi=self.zi)
        return np.asarray(out)


def render(  # noqa: PLR0913 (keyword-only options)
    sound: Any,
    path: Any,
    *,
    rate: int = DEFAULTS.rate,
    layout: Any = DEFAULTS.layout,
    duration: float | None = None,
    start: float = 0.0,
    highpass_hz: float = DEFAULTS.highpass_hz,
    c0: float = C0,
    hrtf: object = None,
    backend: Backend = "auto",
    block: int | None = None,
    carry: Carry | None = None,
    runner: Any = None,
    block_seconds: float | None = None,
    air: Any = None,
    ground: Any = None,
) -> Any:
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
        A bad cut-off, backend, layout or rate, two ways of rendering asked
        at once, a block or Dask render not starting at 0, a timbre other
        than ``physical`` on Dask, outdoor options of the wrong type or
        below the ground, and what the engine refuses
        (:func:`auralize.emitters.engine.render_sound`).
    MissingFileError, FormatError
        An ``hrtf`` SOFA file that does not exist or cannot be read.

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

    Block by block, the blocks join into the offline render:

    >>> blocks = render(em, ListenerPath.point((0, 0, 0), duration=0.1), layout="stereo",
    ...                 block=1024)
    >>> blocks.n_blocks, bool(np.allclose(np.hstack(list(map(blocks.block, range(5)))), r.audio))
    (5, True)
    """
    from auralize.emitters.outdoor import check_options
    from auralize.emitters.timbre import highpass

    highpass(np.zeros((1, 0)), int(rate), highpass_hz)  # a bad cut-off fails before rendering
    check_options(air, ground)
    ways = [
        name
        for name, v in (("block", block), ("carry", carry), ("runner", runner))
        if v is not None
    ]
    if len(ways) > 1:
        raise ParameterError(
            f"render block by block, continued or on Dask, not {' and '.join(ways)} at once"
        )
    snd = as_sound(sound)
    if block is not None:
        if start:
            raise ParameterError(
                "a block-by-block render starts at the path's first capture (start=0)"
            )
        return RenderBlocks(
            snd,
            path,
            rate=rate,
            layout=layout,
            block=block,
            duration=duration,
            highpass_hz=highpass_hz,
            c0=c0,
            backend=backend,
            hrtf=hrtf,
            **_outdoor(air, ground),
        )
    kw: dict[str, Any] = dict(
        rate=int(rate),
        layout=layout,
        duration=duration,
        start=start,
        c0=c0,
        backend=backend,
        hrtf=hrtf,
        **_outdoor(air, ground),
    )
    if runner is not None:
        return _on_dask(
            snd, path, kw, highpass_hz=highpass_hz, runner=runner, block_seconds=block_seconds
        )
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


def _on_dask(
    snd: Any,
    path: Any,
    kw: dict[str, Any],
    *,
    highpass_hz: float,
    runner: Any,
    block_seconds: float | None,
) -> Any:
    """The volume's sources synthesized on the runner's workers, the other parts here."""
    from auralize.distributed import render_distributed
    from auralize.emitters.engine import render_sound
    from auralize.emitters.timbre import highpass, loudness
    from auralize.spatial.layouts import get_layout

    field, models = split_field(snd)
    odd = sorted({p.timbre for p in field.parts} - {"physical", "auto"})
    if odd:
        raise ParameterError(
            f"timbre {'/'.join(odd)}: the Dask render renders the physical "
            f"pressure only; render it without the Dask options"
        )
    lay: Any = get_layout(kw["layout"])
    path_dur = path.duration - kw["start"]
    duration = path_dur if kw["duration"] is None else float(kw["duration"])
    if kw["start"]:
        raise ParameterError("a Dask render starts at the path's first capture (start=0)")
    out = None
    listing = []
    if "air" in kw:  # outdoors: the sources with their ground images, through the air
        from auralize.emitters.outdoor import outdoor_parts

        field.parts = outdoor_parts(
            field.parts, path, air=kw["air"], ground=kw["ground"], c0=kw["c0"]
        )
    for part in field.parts:

        def run(k: dict[str, Any], part: Any = part) -> Any:
            return render_distributed(
                part.tracks,
                path,
                rate=kw["rate"],
                time_scale=part.time_scale,
                interp=part.interp,
                layout=lay,
                c0=kw["c0"],
                duration=k["duration"],
                bounds=part.bounds,
                block_seconds=block_seconds,
                runner=runner,
                lead=part.lead,
            )

        if getattr(part, "air", None) is not None:
            from auralize.emitters.outdoor import field_distance, received

            r = received(
                run,
                {"rate": kw["rate"], "start": 0.0, "duration": duration},
                path,
                part.air,
                field_distance(part, path, c0=kw["c0"]),
            )
        else:
            r = run({"duration": duration})
        listing.append(
            {
                "model": part.name,
                "kind": "FieldSources (Dask)",
                "peak_pa": float(np.max(np.abs(r.audio), initial=0.0)),
            }
        )
        if out is None:
            out = r
        else:
            out.audio = out.audio + r.audio
    if out is None:
        return render(models, path, highpass_hz=highpass_hz, **kw)
    share = loudness(out.audio, out.rate)["share_above"]
    out.audio = highpass(out.audio, out.rate, highpass_hz)
    out.meta.update(
        {
            "parts": listing,
            "highpass_hz": float(highpass_hz),
            "timbre": "physical",
            "share_above_20hz_unfiltered": share,
            **snd.meta,
        }
    )
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

    Parameters
    ----------
    sound : Sound, a part, a list of parts, or SourceTracks
        What is heard (:func:`as_sound`).
    path : ListenerPath
        Where the listener goes; playback time counts from its first capture.
    rate : int
        Output sample rate, Hz.
    layout : str or Layout
        Output layout (:func:`auralize.spatial.layouts.get_layout`).
    block : int, optional
        Samples per block (default 50 ms).
    duration : float, optional
        Playback seconds (default: the path's).
    highpass_hz : float
        Cut-off of the volume's sources' causal high-pass, Hz (0: none).
    **kw
        ``c0``, ``backend``, ``hrtf``, ``air``, ``ground``: as :func:`render`
        (:class:`auralize.emitters.engine.BlockRenderer`).

    Raises
    ------
    ParameterError
        A bad cut-off, and what :class:`auralize.emitters.engine.BlockRenderer` refuses.

    Examples
    --------
    A source whose strength swings at 20 Hz, heard 2 m away, in blocks of 100 samples:

    >>> from auralize.listener import ListenerPath
    >>> from auralize.sources.detection import SourceTracks
    >>> t = np.linspace(0.0, 0.1, 21)
    >>> tracks = SourceTracks(positions=np.zeros((1, 3)), q=np.sin(2 * np.pi * 20 * t)[None],
    ...                       radius=np.array([0.1]), times=t)
    >>> path = ListenerPath.point((2.0, 0, 0), duration=0.05)
    >>> rb = RenderBlocks(tracks, path, rate=8000, block=100)
    >>> rb.n_blocks, rb.block_size, rb.layout.name, rb.block(3).shape
    (4, 100, 'mono', (1, 100))
    """

    def __init__(
        self,
        sound: Any,
        path: Any,
        *,
        rate: int = DEFAULTS.rate,
        layout: Any = DEFAULTS.layout,
        block: int | None = None,
        duration: float | None = None,
        highpass_hz: float = DEFAULTS.highpass_hz,
        **kw: Any,
    ) -> None:
        from auralize.emitters.engine import BlockRenderer
        from auralize.emitters.timbre import highpass

        highpass(np.zeros((1, 0)), rate, highpass_hz)  # a bad cut-off fails here
        snd = as_sound(sound)
        field, models = split_field(snd)
        args: dict[str, Any] = dict(rate=rate, layout=layout, block=block, duration=duration, **kw)
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
        """Output samples ``[start, start + n)`` (the field's filter run from sample 0).

        Parameters
        ----------
        start : int
            First output sample (sample 0 is the path's first capture).
        n : int
            Number of samples.

        Returns
        -------
        (n_channels, n) float
            The pressure, Pa.

        Examples
        --------
        >>> from auralize.emitters import Emitters
        >>> from auralize.listener import ListenerPath
        >>> em = Emitters(np.ones((1, 800)), 8000, [[1.0, 0, 0]])
        >>> rb = RenderBlocks(em, ListenerPath.point((0, 0, 0), duration=0.1), rate=8000,
        ...                   block=400)
        >>> bool(np.allclose(rb.render_range(300, 200), np.hstack([rb.block(0), rb.block(1)])[:, 300:500]))
        True
        """
        if self.field is None:
            assert self.models is not None
            return self.models.render_range(start, n)
        a = self._field_range(0, int(start) + int(n), Carry())[:, int(start) :]
        if self.models is not None:
            a = a + self.models.render_range(start, n)
        return a

    def block(self, i: int) -> NDArray[np.float64]:
        """Block ``i`` (the last one may be shorter); in order, the filter state carries on.

        Out of order, the field's filter is run from sample 0 up to the block.

        Parameters
        ----------
        i : int
            Block index, ``0 <= i < n_blocks``.

        Returns
        -------
        (n_channels, n) float
            The block's pressure, Pa.

        Raises
        ------
        ParameterError
            ``i`` outside ``0..n_blocks-1``.

        Examples
        --------
        >>> from auralize.emitters import Emitters
        >>> from auralize.listener import ListenerPath
        >>> em = Emitters(np.ones((1, 800)), 8000, [[1.0, 0, 0]])
        >>> rb = RenderBlocks(em, ListenerPath.point((0, 0, 0), duration=0.1), rate=8000,
        ...                   block=300)
        >>> [rb.block(i).shape[1] for i in range(rb.n_blocks)]
        [300, 300, 200]
        """
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
