"""Render emitters and whole sounds (scenes) along a listener path."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, get_args

import numpy as np
from numpy.typing import NDArray

from auralize.emitters import C0, Backend, Emitters, FieldSources, Part, Sound, law_exponent
from auralize.emitters.outdoor import (
    Air,
    Ground,
    OutdoorPart,
    describe,
    field_distance,
    in_air,
    outdoor_parts,
    received,
)
from auralize.emitters.synthesis import Rendered, render_tracks
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.spatial.layouts import Layout, output_stage

#: the emitter renderers' backends
BACKENDS: tuple[Backend, ...] = get_args(Backend)


def model_emitters(
    signals: NDArray[np.floating],
    rate: float,
    positions: NDArray[np.float64],
    *,
    t0: float = 0.0,
    pos_rate: float | None = None,
    radius: float = 0.05,
    law: str | float = "physical",
    name: str = "",
) -> Emitters:
    """:class:`Emitters` from arrays a model computed itself, without the O(n) checks.

    For models whose emitted signals come from their own finite tables (made
    window after window while rendering): the shapes, rate, clamp radius and
    law are checked as by :class:`Emitters`, the samples are not scanned for
    NaN or copied.  ``signals`` may be float32 (the sampled backend widens
    them to float64 once per render, exactly: its kernel has one compiled
    signature); they must be C-contiguous.

    Parameters
    ----------
    signals : (S, n) or (S, 3, n) float64 or float32
        Emitted pressure at 1 m (Pa) of monopoles, or the dipoles' vector G
        (as :class:`Emitters`); C-contiguous, used as it is (not copied).
    rate : float
        Samples per second of ``signals``.
    positions : (S, 3) or (S, m, 3) float64
        Static positions (m) or trajectories sampled at ``pos_rate`` from ``t0``.
    t0 : float
        Playback seconds of sample 0.
    pos_rate : float, optional
        Samples per second of trajectories (default ``rate``).
    radius : float
        Clamp radius of every emitter (m).
    law : str or float
        Distance law (:func:`auralize.emitters.law_exponent`).
    name : str
        The model that made them.

    Returns
    -------
    Emitters
        With ``signals`` the array given (float32 stays float32).

    Raises
    ------
    ParameterError
        Shapes, rate, radius or law out of range, or non-contiguous arrays.

    Examples
    --------
    >>> sig = np.zeros((2, 160), dtype=np.float32)
    >>> em = model_emitters(sig, 8000, np.eye(2, 3), t0=0.01, name="model")
    >>> em.signals is sig, em.n_emitters, em.t_end
    (True, 2, 0.03)
    """
    sig, pos = signals, positions
    if not (
        isinstance(sig, np.ndarray)
        and sig.dtype in (np.float32, np.float64)
        and sig.flags.c_contiguous
        and sig.ndim in (2, 3)
        and (sig.ndim == 2 or sig.shape[1] == 3)
    ):
        raise ParameterError(
            f"{name or 'model'} emitter signals must be C-contiguous float64/float32 (S, n) or "
            f"(S, 3, n), got {getattr(sig, 'shape', None)} {getattr(sig, 'dtype', None)}"
        )
    S = sig.shape[0]
    if not (
        isinstance(pos, np.ndarray)
        and pos.dtype == np.float64
        and pos.ndim in (2, 3)
        and pos.shape[0] == S
        and pos.shape[-1] == 3
    ):
        raise ParameterError(
            f"{name or 'model'} emitter positions must be float64 (S, 3) or (S, m, 3) for S={S}, "
            f"got {getattr(pos, 'shape', None)}"
        )
    pr = float(rate if pos_rate is None else pos_rate)
    if not (np.isfinite(rate) and rate > 0 and np.isfinite(pr) and pr > 0 and np.isfinite(t0)):
        raise ParameterError(
            f"emitter rate {rate!r}, pos_rate {pos_rate!r} and t0 {t0!r} must be finite, rates > 0"
        )
    if not (np.isfinite(radius) and radius > 0):
        raise ParameterError(f"emitter clamp radius must be > 0 m, got {radius!r}")
    law_exponent(law)
    em = Emitters.__new__(Emitters)
    em.signals = sig
    em.rate = float(rate)
    em.positions = np.ascontiguousarray(pos)
    em.t0 = float(t0)
    em.pos_rate = pr
    em.radius = np.full(S, float(radius))
    em.law = law
    em.name = name
    em.meta = {}
    return em


def render_emitters(
    em: Emitters,
    path: ListenerPath,
    *,
    rate: int = 44100,
    layout: str | Layout = "mono",
    duration: float | None = None,
    start: float = 0.0,
    c0: float = C0,
    backend: Backend = "auto",
    block: int = 32,
    oversample: int = 4,
    hrtf: object = None,
) -> Rendered:
    """Pressure of point emitters heard along ``path`` (see :mod:`auralize.emitters`).

    Parameters
    ----------
    em : Emitters
        The emitters (:class:`auralize.emitters.TableEmitters` too).
    path : ListenerPath
        Playback-time listener captures (position, forward, up).
    rate : int
        Output sample rate (Hz), 1000..768000.
    layout : str or Layout
        Any output layout (panned with its own law, :func:`auralize.spatial.layouts.pan_gains`;
        ``binaural``: panned to its AmbiX intermediate, then filtered by
        :func:`auralize.spatial.layouts.output_stage`).
    duration : float, optional
        Playback seconds (default: the path's duration after ``start``).
    start : float
        Playback seconds after the path's first capture of output sample 0
        (consecutive blocks join without seams; for ``binaural`` use
        :class:`BlockRenderer`, which carries the ear filters' state).
    c0 : float
        Speed of sound (m/s).
    backend : {"auto", "sampled", "reference"}
        ``auto`` and ``sampled``: the compiled kernel of
        :mod:`auralize.emitters._sampled` (retarded time, distance law,
        dipole projection and panning gains every ``block`` samples,
        interpolated linearly between); ``reference`` evaluates every sample
        in numpy (tests; equal within about 1e-3 of the peak).
    block : int
        Samples (of the evaluation rate) between control points of ``sampled``.
    oversample : int
        ``sampled``: emitters below the output rate are upsampled band-limited
        to at most this × their rate, evaluated at an integer fraction of the
        output rate when possible and resampled band-limited (1: read the
        signals as given, at the output rate).
    hrtf : HRIRSet, str or Path, optional
        ``binaural`` only: the HRIRs (a SOFA file; default the built-in
        spherical head).

    Returns
    -------
    Rendered
        ``audio (n_channels, n_samples)`` in Pa; ``meta``: ``model``,
        ``n_emitters``, ``backend``, ``internal_rate_hz``, ``c0``.

    Raises
    ------
    ParameterError
        Unknown backend, not :class:`Emitters`, a rate, block or
        oversampling factor out of range, a negative duration, a ``c0`` not
        > 0, a ``start`` not finite, or an unknown layout or HRTF
        (:func:`auralize.spatial.layouts.output_stage`).
    MissingFileError
        An ``hrtf`` SOFA file that does not exist.
    FormatError
        An ``hrtf`` SOFA file that cannot be read.

    Examples
    --------
    A 1 Pa (at 1 m) pulse 3.43 m to the listener's left arrives after 10 ms
    at 1/3.43 Pa, on the left channel only:

    >>> em = Emitters(np.ones((1, 80)), 8000, [[-3.43, 0, 0]])
    >>> path = ListenerPath.point((0, 0, 0), duration=0.05)
    >>> r = render_emitters(em, path, rate=8000, layout="stereo", c0=343.0)
    >>> r.audio.shape, int(np.argmax(r.audio[0] > 0)), round(float(r.audio.max()), 4)
    ((2, 400), 80, 0.2915)
    >>> float(np.abs(r.audio[1]).max())
    0.0
    """
    if backend not in BACKENDS:
        raise ParameterError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if not isinstance(em, Emitters):
        raise ParameterError(f"render_emitters needs Emitters, got {type(em).__name__}")
    if isinstance(rate, bool) or not (
        isinstance(rate, int | np.integer) and 1000 <= rate <= 768000
    ):
        raise ParameterError(f"rate must be an integer in 1000..768000 Hz, got {rate!r}")
    if not (np.isfinite(c0) and c0 > 0):
        raise ParameterError(f"c0 must be a positive speed of sound in m/s, got {c0!r}")
    if not np.isfinite(start):
        raise ParameterError(f"start must be finite, got {start!r}")
    if isinstance(block, bool) or not (isinstance(block, int | np.integer) and 1 <= block <= 4096):
        raise ParameterError(f"block must be an integer in 1..4096 samples, got {block!r}")
    if isinstance(oversample, bool) or not (
        isinstance(oversample, int | np.integer) and 1 <= oversample <= 64
    ):
        raise ParameterError(f"oversample must be an integer in 1..64, got {oversample!r}")
    stage = output_stage(layout, int(rate), hrtf=hrtf)
    lay = stage.synthesis_layout
    dur = path.duration - start if duration is None else float(duration)
    if not (np.isfinite(dur) and dur >= 0):
        raise ParameterError(f"duration must be >= 0 s, got {dur!r}")
    n_out = int(round(dur * rate))
    em = in_air(em, path)  # inside a model part heard outdoors: filtered through its air
    meta: dict[str, Any] = {"model": em.name, "n_emitters": em.n_emitters, "c0": c0}
    if backend == "reference":
        from auralize.emitters.reference import render_reference

        audio = render_reference(em, path, rate=rate, layout=lay, duration=dur, start=start, c0=c0)
        meta.update(backend="reference", internal_rate_hz=float(rate))
    else:
        from auralize.emitters._sampled import render_sampled

        audio, m = render_sampled(
            em,
            path,
            rate=int(rate),
            layout=lay,
            n_out=n_out,
            start=start,
            c0=float(c0),
            block=int(block),
            oversample=int(oversample),
        )
        meta.update(backend="sampled", **m)
    return stage.finish(Rendered(audio=audio, rate=int(rate), layout=lay, meta=meta))


def _render_part(
    part: Part,
    path: ListenerPath,
    kw: dict[str, Any],
    field_highpass_hz: float = 0.0,
    *,
    block: bool = False,
) -> Rendered:
    """``part`` rendered along ``path`` with the engine's keywords ``kw``.

    ``block``: a block of a block-by-block render (:class:`BlockRenderer`), where a
    field of the ``physical`` timbre is its synthesized pressure alone, without the
    measures a whole render takes of it (its share above 20 Hz, which a block's
    few milliseconds do not tell); the samples are the same.
    """
    if isinstance(part, Emitters):
        return render_emitters(part, path, **kw)
    if isinstance(part, FieldSources):
        from auralize.emitters.timbre import render_timbre

        def run(k: dict[str, Any]) -> Rendered:
            if block and part.timbre == "physical" and not field_highpass_hz:
                return render_tracks(
                    part.tracks,
                    path,
                    time_scale=part.time_scale,
                    interp=part.interp,
                    lead=part.lead,
                    bounds=part.bounds,
                    **k,
                )
            return render_timbre(
                part.tracks,
                path,
                timbre=part.timbre,
                time_scale=part.time_scale,
                interp=part.interp,
                lead=part.lead,
                bounds=part.bounds,
                highpass_hz=field_highpass_hz,
                by_type=part.by_type,
                seed=part.seed,
                **k,
            )

        kw = {k: v for k, v in kw.items() if k != "backend"}
        air = getattr(part, "air", None)
        if air is not None:  # heard outdoors: its output through the air at its mean distance
            return received(run, kw, path, air, field_distance(part, path, c0=kw["c0"]))
        return run(kw)
    fn = getattr(part, "render_part", None)
    if callable(fn):  # a model's own closed form, with arrivals and gains from the engine
        return fn(path, **kw)
    raise ParameterError(f"cannot render a {type(part).__name__}: not an engine part")


def _listed(part: Part, r: Rendered) -> dict[str, Any]:
    """How ``meta["parts"]`` lists a part rendered as ``r``."""
    return {
        "model": part.name,
        "kind": type(part).__name__,
        "peak_pa": float(np.max(np.abs(r.audio), initial=0.0)),
    }


def parts_of(sound: Sound | Part | Iterable[Part]) -> list[Part]:
    """The parts of ``sound``: a :class:`Sound`'s, one emitter set or custom part, or a list.

    Parameters
    ----------
    sound : Sound, a part, or an iterable of parts
        A :class:`Sound`; one :class:`Emitters`, :class:`FieldSources` or
        model part (an object with ``render_part``); or parts.

    Returns
    -------
    list
        The parts, in order (a new list).

    Examples
    --------
    >>> em = Emitters(np.zeros((1, 8)), 8000, [[1.0, 0, 0]])
    >>> len(parts_of(em)), len(parts_of(Sound([em, em]))), len(parts_of((em,)))
    (1, 2, 1)
    """
    if isinstance(sound, Sound):
        return list(sound.parts)
    if isinstance(sound, Emitters | FieldSources) or hasattr(sound, "render_part"):
        return [sound]
    return list(sound)


def render_sound(
    sound: Sound | Part | Iterable[Part],
    path: ListenerPath,
    *,
    rate: int = 44100,
    layout: str | Layout = "mono",
    duration: float | None = None,
    start: float = 0.0,
    c0: float = C0,
    backend: Backend = "auto",
    hrtf: object = None,
    field_highpass_hz: float = 0.0,
    air: Air | None = None,
    ground: Ground | None = None,
) -> Rendered:
    """Render every part of a sound (or a scene of several models) and sum them.

    All parts share the listener path, output rate, layout and window, so the
    mix equals the sum of the parts rendered alone.  ``meta["parts"]`` lists
    each part's model, kind and peak.  The parts are rendered to
    :func:`auralize.spatial.layouts.synthesis_layout` (``ambix3`` for ``binaural``)
    and the sum goes once through :func:`auralize.spatial.layouts.output_stage`
    (``hrtf``: its HRIRs, binaural only); ``meta`` describes the stage.
    ``field_highpass_hz``: the output high-pass of the volume's sources
    (:class:`FieldSources`), applied by their timbre
    (:func:`auralize.emitters.timbre.render_timbre`, whose ``auto`` and
    ``extended`` choices depend on it), as ``auralize render`` does.
    ``air`` and ``ground``: outdoor propagation, every part heard through the
    air and over the ground (:mod:`auralize.emitters.outdoor`; None, the
    default: neither, and ``meta`` has no ``outdoor`` entry).

    This is the engine's offline render;
    :func:`auralize.pipeline.render` (which front ends call) adds the
    output high-pass rule and the block, continued and Dask renders.

    Parameters
    ----------
    sound : Sound, a part, or an iterable of parts
        What is heard (:func:`parts_of`).
    path : ListenerPath
        Playback-time listener captures (position, forward, up).
    rate : int
        Output sample rate (Hz).
    layout : str or Layout
        Output layout (:func:`auralize.spatial.layouts.get_layout`).
    duration : float, optional
        Playback seconds (default: the path's duration after ``start``).
    start : float
        Playback seconds after the path's first capture of output sample 0.
    c0 : float
        Speed of sound (m/s).
    backend : {"auto", "sampled", "reference"}
        The emitter sets' backend (:func:`render_emitters`).
    hrtf : HRIRSet, str or Path, optional
        ``binaural`` only: the HRIRs or a SOFA file (default the spherical head).
    field_highpass_hz : float
        Output high-pass of the :class:`FieldSources` parts (Hz; 0: none).
    air : Air, optional
        Air absorption (:class:`auralize.emitters.outdoor.Air`).
    ground : Ground, optional
        A reflecting ground (:class:`auralize.emitters.outdoor.Ground`).

    Returns
    -------
    Rendered
        ``audio (n_channels, round(duration * rate))`` in Pa, ``rate``,
        ``layout``; ``meta`` with ``c0``, ``parts`` (each part's ``model``,
        ``kind`` and ``peak_pa``), the sound's own ``meta`` and, outdoors,
        ``outdoor``.

    Raises
    ------
    ParameterError
        A part the engine cannot render, an unknown layout or HRTF, outdoor
        options of the wrong type or a source or listener below the ground,
        and what the parts' renderers refuse (:func:`render_emitters`).
    MissingFileError, FormatError
        An ``hrtf`` SOFA file that does not exist or cannot be read.

    Examples
    --------
    Two tones mixed: the mix is the sum of each rendered alone.

    >>> t = np.arange(400) / 8000
    >>> a = Emitters(np.sin(2 * np.pi * 440 * t)[None], 8000, [[0.0, 2.0, 0.0]], name="a")
    >>> b = Emitters(np.sin(2 * np.pi * 660 * t)[None], 8000, [[2.0, 0.0, 0.0]], name="b")
    >>> path = ListenerPath.point((0, 0, 0), duration=0.05)
    >>> mix = render_sound(Sound([a, b]), path, rate=8000, layout="stereo")
    >>> [p["model"] for p in mix.meta["parts"]], mix.audio.shape
    (['a', 'b'], (2, 400))
    >>> alone = render_sound(a, path, rate=8000, layout="stereo").audio
    >>> bool(np.allclose(mix.audio, alone + render_sound(b, path, rate=8000,
    ...                                                  layout="stereo").audio))
    True
    """
    parts = outdoor_parts(parts_of(sound), path, air=air, ground=ground, c0=c0)
    stage = output_stage(layout, int(rate), hrtf=hrtf)  # a bad HRTF fails before rendering
    lay = stage.synthesis_layout
    dur = path.duration - start if duration is None else float(duration)
    kw: dict[str, Any] = dict(
        rate=rate, layout=lay, duration=dur, start=start, c0=c0, backend=backend
    )
    meta: dict[str, Any] = {"c0": c0}
    if isinstance(sound, Sound):
        meta.update(sound.meta)
    if air is not None or ground is not None:
        meta["outdoor"] = describe(air, ground)
    if len(parts) == 1 and isinstance(parts[0], FieldSources):
        # the volume's sound alone: its timbre renders the output layout itself (the
        # output stage before its high-pass), as a render of the volume does
        one = _render_part(
            parts[0], path, {**kw, "layout": layout, "hrtf": hrtf}, field_highpass_hz
        )
        one.meta.update({**meta, "parts": [_listed(parts[0], one)]})
        return one
    audio = np.zeros((lay.n_channels, int(round(dur * rate))))
    listing = []
    for part in parts:
        r = _render_part(part, path, kw, field_highpass_hz)
        n = min(audio.shape[1], r.audio.shape[1])
        audio[:, :n] += r.audio[:, :n]
        listing.append(_listed(part, r))
    meta["parts"] = listing
    notes = [n for p in parts if isinstance(p, OutdoorPart) for n in p.meta.get("notes", [])]
    if notes:
        meta["outdoor"]["notes"] = notes
    return stage.finish(Rendered(audio=audio, rate=int(rate), layout=lay, meta=meta))


class BlockRenderer:
    """Render a sound (or scene) block by block along a listener path, for live playback.

    The block synthesizer of the one render's block-by-block way
    (:class:`auralize.rendering.RenderBlocks`, made by ``render(..., block=N)``,
    whose blocks :func:`auralize.audio.live.play` plays): ``block(i)``,
    ``render_range(start, n)``, ``n_blocks``, ``n_samples``, ``block_size``
    for any :class:`Sound`.  Block ``i`` holds output samples ``i·block`` to
    ``(i+1)·block`` (the last may be shorter); concatenated blocks equal one
    :func:`render` of the whole duration, since the sampled backend's control
    points lie on a grid fixed in playback time and the field kernels carry
    their state in time too.  Emitted signals that the sampled backend
    upsamples are prepared once, not per block.

    Parameters
    ----------
    sound : Sound, a part or parts
        What is heard (:func:`parts_of`).
    path : ListenerPath
        Playback-time listener captures.
    rate : int
        Output sample rate (Hz), >= 1000.
    layout : str or Layout
        Output layout (:func:`auralize.spatial.layouts.get_layout`).
    block : int, optional
        Samples per block (default 50 ms).
    duration : float, optional
        Playback seconds (default: the path's duration).
    c0 : float
        Speed of sound (m/s).
    backend : {"auto", "sampled", "reference"}
        The emitter sets' backend (:func:`render_emitters`).
    hrtf : HRIRSet, str or Path, optional
        ``binaural`` only (see :func:`render`): the blocks are rendered to the
        AmbiX intermediate and filtered by one output stage that carries its
        state from block to block (:meth:`auralize.spatial.layouts.OutputStage.process_at`).
    air, ground : optional
        Outdoor propagation, as :func:`render_sound` (the emitters are filtered
        once, here; the volume's blocks are filtered over the frames around them).

    Raises
    ------
    ParameterError
        An unknown backend, a rate below 1000 Hz, a block that is not a
        positive number of samples, no duration to play, an unknown layout
        or HRTF, or outdoor options :func:`auralize.emitters.outdoor.outdoor_parts`
        refuses.
    MissingFileError, FormatError
        An ``hrtf`` SOFA file that does not exist or cannot be read.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.emitters import Emitters
    >>> from auralize.listener import ListenerPath
    >>> em = Emitters(np.ones((1, 4410)), 44100, [[3.0, 0, 0]])
    >>> br = BlockRenderer(em, ListenerPath.point((0, 0, 0), duration=0.1), block=1024)
    >>> br.n_blocks, br.block(0).shape, br.block(4).shape
    (5, (1, 1024), (1, 314))
    """

    def __init__(
        self,
        sound: Sound | Part | Iterable[Part],
        path: ListenerPath,
        *,
        rate: int = 44100,
        layout: str | Layout = "mono",
        block: int | None = None,
        duration: float | None = None,
        c0: float = C0,
        backend: Backend = "auto",
        hrtf: object = None,
        air: Air | None = None,
        ground: Ground | None = None,
    ) -> None:
        if backend not in BACKENDS:
            raise ParameterError(f"backend must be one of {BACKENDS}, got {backend!r}")
        if isinstance(rate, bool) or not (isinstance(rate, int | np.integer) and rate >= 1000):
            raise ParameterError(f"rate must be an integer >= 1000 Hz, got {rate!r}")
        size = round(0.05 * rate) if block is None else block
        if isinstance(size, bool) or not (isinstance(size, int | np.integer) and size >= 1):
            raise ParameterError(f"block must be a positive number of samples, got {block!r}")
        dur = path.duration if duration is None else float(duration)
        if not (np.isfinite(dur) and dur > 0):
            raise ParameterError(f"nothing to play: duration {dur!r} s (give a duration)")
        self.parts = outdoor_parts(parts_of(sound), path, air=air, ground=ground, c0=float(c0))
        self.meta = dict(sound.meta) if isinstance(sound, Sound) else {}
        if air is not None or ground is not None:
            self.meta["outdoor"] = describe(air, ground)
        self.path = path
        self.rate = int(rate)
        self.stage = output_stage(layout, int(rate), hrtf=hrtf)
        self.layout = self.stage.layout
        self.synthesis_layout = self.stage.synthesis_layout
        self.block_size = int(size)
        self.duration = dur
        self.n_samples = int(round(dur * rate))
        self.n_blocks = -(-self.n_samples // self.block_size)
        self.c0 = float(c0)
        self.backend = backend
        self.index = 0
        self._prepared: dict[int, Any] = {}

    def _prepared_for(self, em: Emitters) -> Any:
        from auralize.emitters._sampled import prepare, upsampling

        key = id(em)
        if key not in self._prepared:
            up = upsampling(em.rate, self.rate, 4)
            self._prepared[key] = (em, prepare(em.signals, em.rate, em.t0, up))
        return self._prepared[key][1]

    def render_range(self, start: int, n: int) -> NDArray[np.float64]:
        """Output samples ``[start, start + n)`` of :attr:`layout`, in pascals.

        Any range may be asked for; consecutive ranges are cheapest for
        ``binaural`` (its ear filters carry their state).

        Parameters
        ----------
        start : int
            First output sample (sample 0 is the path's first capture).
        n : int
            Number of samples (<= 0: none).

        Returns
        -------
        (n_channels, max(n, 0)) float
            The pressure, Pa.

        Examples
        --------
        >>> em = Emitters(np.ones((1, 800)), 8000, [[1.0, 0, 0]])
        >>> br = BlockRenderer(em, ListenerPath.point((0, 0, 0), duration=0.1), rate=8000)
        >>> whole = np.hstack([br.block(0), br.block(1)])
        >>> bool(np.allclose(br.render_range(100, 300), whole[:, 100:400]))
        True
        """
        if n <= 0:
            return np.zeros((self.layout.n_channels, max(int(n), 0)))
        return self.stage.process_at(int(start), int(n), self._synthesize)

    def _synthesize(self, start: int, n: int) -> NDArray[np.float64]:
        """Samples ``[start, start + n)`` of the :attr:`synthesis_layout`."""
        from auralize.emitters._sampled import render_sampled

        t = start / self.rate
        lay = self.synthesis_layout
        audio = np.zeros((lay.n_channels, max(int(n), 0)))
        if n <= 0:
            return audio
        kw: dict[str, Any] = dict(
            rate=self.rate,
            layout=lay,
            duration=n / self.rate,
            start=t,
            c0=self.c0,
            backend=self.backend,
        )
        for part in self.parts:
            if isinstance(part, Emitters) and self.backend != "reference":
                a, _ = render_sampled(
                    part,
                    self.path,
                    rate=self.rate,
                    layout=lay,
                    n_out=int(n),
                    start=t,
                    c0=self.c0,
                    prepared=self._prepared_for(part),
                )
            else:
                a = _render_part(part, self.path, kw, block=True).audio
            m = min(int(n), a.shape[1])
            audio[:, :m] += a[:, :m]
        return audio

    def block(self, i: int) -> NDArray[np.float64]:
        """Block ``i``: output samples ``i·block_size`` to ``(i+1)·block_size`` (the last may be shorter).

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
        >>> em = Emitters(np.ones((1, 800)), 8000, [[1.0, 0, 0]])
        >>> br = BlockRenderer(em, ListenerPath.point((0, 0, 0), duration=0.1), rate=8000)
        >>> br.block_size, br.n_blocks, br.block(1).shape
        (400, 2, (1, 400))
        """
        if not 0 <= i < self.n_blocks:
            raise ParameterError(f"block index {i} outside 0..{self.n_blocks - 1}")
        s = i * self.block_size
        return self.render_range(s, min(self.block_size, self.n_samples - s))

    def __iter__(self) -> BlockRenderer:
        return self

    def __next__(self) -> NDArray[np.float64]:
        if self.index >= self.n_blocks:
            raise StopIteration
        out = self.block(self.index)
        self.index += 1
        return out
