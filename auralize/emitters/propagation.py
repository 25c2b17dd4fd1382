"""Propagate emitted source signals to a moving listener (a thin wrapper over the engine).

:func:`propagate` renders point sources with emitted signals through
:func:`auralize.emitters.render_emitters`: retarded time (delay and Doppler,
moving sources included), the distance law and the layout's own panning all
come from the engine.  New code should build :class:`auralize.emitters.Emitters`
and call the engine directly.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from auralize.emitters import C0, Emitters, law_exponent
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.spatial.layouts import Layout


def distance_gain(D: NDArray[np.float64], law: str | float) -> NDArray[np.float64]:
    """Amplitude factor for distance D: ``"physical"`` 1/D, ``"paper"`` 1/D³, or 1/D**law.

    Parameters
    ----------
    D : array_like of float
        Distances (m), > 0.
    law : str or float
        ``"physical"``, ``"paper"`` or an exponent in [0, 6]
        (:func:`auralize.emitters.law_exponent`).

    Returns
    -------
    ndarray
        ``1 / D**e``, the shape of ``D``.

    Raises
    ------
    ParameterError
        An unknown law (the message names ``attenuation``, :func:`propagate`'s option).

    Examples
    --------
    >>> distance_gain(np.array([1.0, 2.0]), "physical").tolist()
    [1.0, 0.5]
    >>> distance_gain(np.array([2.0]), "paper").tolist()
    [0.125]
    """
    try:
        e = law_exponent(law)
    except ParameterError:
        raise ParameterError(
            f"attenuation must be 'physical', 'paper' or an exponent, got {law!r}"
        ) from None
    return 1.0 / np.asarray(D, dtype=np.float64) ** e


def propagate(
    signals: NDArray[np.floating],
    emit_rate: float,
    positions: NDArray[np.floating],
    path: ListenerPath,
    *,
    rate: int = 44100,
    duration: float | None = None,
    emit_t0: float = 0.0,
    c0: float = C0,
    attenuation: str | float = "physical",
    min_distance: float = 0.05,
    layout: str | Layout = "mono",
) -> NDArray[np.float64]:
    """Sum emitted source signals as heard along ``path``.

    Parameters
    ----------
    signals : (S, n_emit) float
        Emitted signal of each source (Pa at 1 m), sampled at ``emit_rate``
        from ``emit_t0`` (values outside are zero).
    emit_rate : float
        Samples per second of ``signals`` (Hz).
    positions : (S, 3) or (S, n_emit, 3) float
        Static positions (m), or trajectories sampled like the signals
        (moving sources: Doppler from the retarded time).
    path : ListenerPath
        Playback-time listener; output sample n is at time ``n / rate``.
    rate : int
        Output sample rate (Hz).
    duration : float, optional
        Playback seconds (default: the path's duration).
    emit_t0 : float
        Playback seconds of the signals' sample 0.
    c0 : float
        Speed of sound (m/s).
    attenuation : str or float
        ``"physical"`` (1/D), ``"paper"`` (1/D³) or an exponent.
    min_distance : float
        Distances are clamped here (m; the emitters' clamp radius).
    layout : str or Layout
        Output layout (panned with its own law).

    Returns
    -------
    (n_channels, n_samples) float
        The pressure heard, Pa.

    Raises
    ------
    ParameterError
        Positions that do not fit the signals, an unknown attenuation, and
        what :class:`auralize.emitters.Emitters` and
        :func:`auralize.emitters.engine.render_emitters` refuse.

    Examples
    --------
    >>> from auralize.listener import ListenerPath
    >>> out = propagate(np.ones((1, 400)), 8000, np.array([[0.0, 2.0, 0.0]]),
    ...                 ListenerPath.point((0, 0, 0), duration=0.05), rate=8000)
    >>> out.shape, round(float(out.max()), 6)
    ((1, 400), 0.5)
    """
    sig = np.atleast_2d(np.asarray(signals, dtype=np.float64))
    pos = np.asarray(positions, dtype=np.float64)
    S, n_emit = sig.shape
    moving = pos.ndim == 3
    if pos.shape[0] != S or pos.shape[-1] != 3 or (moving and pos.shape[1] != n_emit):
        raise ParameterError(
            f"positions must be (S, 3) or (S, n_emit, 3) for {S} signals of {n_emit} samples; "
            f"got {pos.shape}"
        )
    distance_gain(np.ones(1), attenuation)  # the error message names 'attenuation'
    em = Emitters(
        sig, float(emit_rate), pos, t0=float(emit_t0), radius=float(min_distance), law=attenuation
    )
    from auralize.emitters.engine import render_emitters

    return render_emitters(em, path, rate=rate, layout=layout, duration=duration, c0=c0).audio
