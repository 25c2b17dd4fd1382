"""Outdoor propagation: air absorption (ISO 9613-1) and a flat reflecting ground.

Both act on every part of a :class:`~auralize.emitters.Sound` the engine
renders (:func:`auralize.emitters.engine.render_sound` and its block renderer,
and so :func:`auralize.pipeline.render`), and both are off unless asked for:
without ``air`` and ``ground`` the engine renders exactly what it rendered
before.

Air absorption (ISO 9613-1:1993 §6, Eqs. 3–5).  The pure-tone attenuation
coefficient of still air

    α(f) = 8.686 f² [1.84·10⁻¹¹ (p_a/p_r)⁻¹ (T/T0)^½
           + (T/T0)^−5/2 (0.01275 e^(−2239.1/T) / (f_rO + f²/f_rO)
                          + 0.1068 e^(−3352.0/T) / (f_rN + f²/f_rN))]   dB/m

with the relaxation frequencies of oxygen and nitrogen

    f_rO = (p_a/p_r) (24 + 4.04·10⁴ h (0.02 + h)/(0.391 + h))
    f_rN = (p_a/p_r) (T/T0)^−½ (9 + 280 h e^(−4.170 ((T/T0)^−⅓ − 1)))

and the molar concentration of water vapour h (%) from the relative
humidity (Annex B: h = h_r (p_sat/p_r)/(p_a/p_r), p_sat/p_r = 10^C,
C = −6.8346 (T01/T)^1.261 + 4.6151), T0 = 293.15 K, T01 = 273.16 K,
p_r = 101.325 kPa.  The standard states ±10 % accuracy for −20…50 °C,
10…100 % relative humidity and pressures below 200 kPa.

It is applied per source–listener path as a filter that follows the
distance: the sound travelling a distance D is filtered by
``10^(−α(f) D / 20)`` (zero phase: the delay is the engine's).  The filter is
a short-time Fourier transform (frames of about :data:`FRAME_S`, periodic
square-root Hann windows at a half-frame hop, which overlap-add to the
identity): each frame's spectrum is multiplied by the gain at that frame's
distance, so the gain changes smoothly, frame by frame, as the distance
does.  Where it is applied:

point emitters (:class:`~auralize.emitters.Emitters`, the emitter sets of models and of FW-H)
    on each emitter's emitted signal, at its emission times τ, with D the
    retarded distance of that emitter, ``D = |x_s(τ) − L(τ + D/c0)|`` (a
    fixed-point iteration, contracting by the listener's Mach number), and
    at the frequency the wave has in the air: a moving emitter's
    ``f / (1 − v_s·n̂/c0)``.  Exact to the frame's resolution for every
    emitter, moving or not.
the volume's sources (:class:`~auralize.emitters.FieldSources`: tracks at the data's rate, a timbre synthesized from them)
    on the rendered output, at the frequencies heard, with D the sources'
    mean distance D̄(t) of :func:`auralize.emitters.timbre.mean_distance`
    (the |q|-weighted harmonic mean the timbre's carriers follow).  The
    approximation: all of a volume's sources are taken at one distance, so
    the attenuation of band f is off by about α(f) ΔD across a source
    region ΔD deep (at 4 kHz, 20 °C, 70 %: 0.02 dB per metre of depth).
    The air absorbs at the frequencies heard, also when ``time_scale``
    stretches the data's time (the air's time is not stretched).
a model's own part (``render_part``: closed forms, windowed emitters)
    on the emitters it renders through the engine
    (:func:`auralize.emitters.engine.render_emitters`, as above), else on
    its output with D following the arrivals it took from
    :func:`auralize.emitters.events.arrivals` (their mean distance per
    frame).

The ground (the image-source method).  A plane ``z = height`` with a
plane-wave reflection factor Q (real, −1…1; 1 rigid): every source at x
has an image at its mirror ``(x, y, 2·height − z)`` of Q times its
strength, which the engine renders like any source, with its own retarded
time, distance, Doppler shift, direction and air absorption.  A dipole's
image has its vertical component reversed (``(Gx, Gy, −Gz)``), so that the
sum is symmetric about the plane: over a rigid ground the normal
derivative of the pressure vanishes on it.  Heard at ``r1`` from the source
and ``r2`` from the image, a tone of wavenumber k is heard with the
two-ray pattern ``|1 + Q (r1/r2) e^(−ik(r2 − r1))|`` times the direct
pressure.  The volume's sources get images as more tracks (mirrored, q
times Q: every timbre renders them with the rest); a model's own part is
rendered a second time for a listener mirrored in the plane (distances,
delays, Doppler and dipole projections are those of the image), and its
channels are mirrored left–right back into the listener's frame
(:func:`mirror_matrix`: a permutation for left–right symmetric layouts,
a sign per AmbiX harmonic, the ears swapped; a re-panning of each
speaker's mirrored direction for other custom layouts).

Sources and listeners must stay above the ground (on it is allowed).

Examples
--------
>>> air = Air(temperature=20.0, humidity=70.0, pressure=101.325)
>>> round(1e3 * float(air.alpha(1000.0)), 2)     # dB/km (ISO 9613-1 Table 1: 4.98)
4.98
>>> Ground.parse("0,0.8")
Ground(height=0.0, reflection=0.8)
"""

from __future__ import annotations

import contextlib
import contextvars
import math
from collections.abc import Callable, Iterator
from dataclasses import KW_ONLY, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from auralize.emitters import C0, Emitters, FieldSources, Part, TableEmitters
from auralize.errors import ParameterError
from auralize.listener import ListenerPath

#: reference pressure p_r (kPa), reference temperature T0 and the triple point T01 (K)
P_REF_KPA = 101.325
T0_K = 293.15
T01_K = 273.16
#: the filter's frame length (s, rounded to a power of two of samples)
FRAME_S = 0.02
#: fixed-point iterations of the retarded distance (each contracts by the listener's Mach number)
ITERATIONS = 12
#: complex STFT elements held at once while filtering
_CHUNK = 1 << 22
_DB = math.log(10.0) / 20.0  # dB -> neper


# ----------------------------------------------------------------------------- the air
def air_alpha(
    f: ArrayLike, *, temperature: float = 20.0, humidity: float = 70.0, pressure: float = P_REF_KPA
) -> NDArray[np.float64]:
    """Pure-tone attenuation coefficient α (dB/m) of ISO 9613-1:1993, Eqs. (3)–(5).

    Parameters
    ----------
    f : array_like
        Frequencies, Hz.
    temperature : float
        Air temperature, °C.
    humidity : float
        Relative humidity, %.
    pressure : float
        Atmospheric pressure, kPa.

    Returns
    -------
    ndarray
        α in dB/m, the shape of ``f``.

    Examples
    --------
    >>> np.round(1e3 * air_alpha([125.0, 4000.0], temperature=10, humidity=70), 3).tolist()
    [0.406, 33.059]
    """
    a, b, c, fo, fn = _coefficients(temperature, humidity, pressure)
    f2 = np.square(np.asarray(f, dtype=np.float64))
    return np.asarray(f2 * (a + b / (fo + f2 / fo) + c / (fn + f2 / fn)))


def _coefficients(
    temperature: float, humidity: float, pressure: float
) -> tuple[float, float, float, float, float]:
    """``(a, b, c, f_rO, f_rN)`` with ``α(f) = f² (a + b/(f_rO + f²/f_rO) + c/(f_rN + f²/f_rN))``."""
    T = float(temperature) + 273.15
    pa = float(pressure) / P_REF_KPA
    C = -6.8346 * (T01_K / T) ** 1.261 + 4.6151
    h = float(humidity) * 10.0**C / pa  # molar concentration of water vapour, %
    tr = T / T0_K
    fo = pa * (24.0 + 4.04e4 * h * (0.02 + h) / (0.391 + h))
    fn = pa * tr**-0.5 * (9.0 + 280.0 * h * math.exp(-4.170 * (tr ** (-1.0 / 3.0) - 1.0)))
    a = 8.686 * 1.84e-11 / pa * tr**0.5
    b = 8.686 * tr**-2.5 * 0.01275 * math.exp(-2239.1 / T)
    c = 8.686 * tr**-2.5 * 0.1068 * math.exp(-3352.0 / T)
    return a, b, c, fo, fn


def _number(text: str, what: str, spec: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ParameterError(f"{what}: {text!r} in {spec!r} is not a number") from None
    if not math.isfinite(v):
        raise ParameterError(f"{what}: {text!r} in {spec!r} is not finite")
    return v


@dataclass(frozen=True)
class Air:
    """Still air that absorbs sound after ISO 9613-1 (see the module docstring).

    Parameters
    ----------
    temperature : float
        °C, in −50…60 (the standard's accuracy holds in −20…50).
    humidity : float
        Relative humidity, %, in 0…100 (accuracy: 10…100).
    pressure : float
        kPa, in 10…200.

    Raises
    ------
    ParameterError
        A value that is not a number or outside its range.

    Examples
    --------
    >>> Air(temperature=10.0, humidity=80.0)
    Air(temperature=10.0, humidity=80.0, pressure=101.325)
    """

    temperature: float = 20.0
    humidity: float = 70.0
    pressure: float = P_REF_KPA

    def __post_init__(self) -> None:
        for name, v, lo, hi, unit in (
            ("temperature", self.temperature, -50.0, 60.0, "°C"),
            ("humidity", self.humidity, 0.0, 100.0, "%"),
            ("pressure", self.pressure, 10.0, 200.0, "kPa"),
        ):
            if isinstance(v, bool) or not isinstance(v, int | float | np.floating | np.integer):
                raise ParameterError(f"air {name} must be a number ({unit}), got {v!r}")
            if not (math.isfinite(v) and lo <= v <= hi):
                raise ParameterError(f"air {name} must be in {lo:g}…{hi:g} {unit}, got {v!r}")
            object.__setattr__(self, name, float(v))

    @classmethod
    def parse(cls, spec: str) -> Air:
        """The air of a command-line spec: ``"T"``, ``"T,RH"`` or ``"T,RH,P"``.

        Parameters
        ----------
        spec : str
            Temperature (°C), relative humidity (%) and pressure (kPa),
            comma-separated; those not given take their defaults.

        Returns
        -------
        Air

        Raises
        ------
        ParameterError
            Not one to three numbers, or a value out of range.

        Examples
        --------
        >>> Air.parse("10,80")
        Air(temperature=10.0, humidity=80.0, pressure=101.325)
        """
        bits = [b.strip() for b in str(spec).split(",")]
        if not 1 <= len(bits) <= 3 or not all(bits):
            raise ParameterError(
                f"air must be T[,RH[,P]] (°C, %, kPa), e.g. 20,70,101.325; got {spec!r}"
            )
        names = ("temperature", "humidity", "pressure")
        return cls(**{n: _number(b, f"air {n}", spec) for n, b in zip(names, bits, strict=False)})

    def alpha(self, f: ArrayLike) -> NDArray[np.float64]:
        """α (dB/m) at frequencies ``f`` (Hz): :func:`air_alpha` of this air.

        Parameters
        ----------
        f : array_like
            Frequencies, Hz.

        Returns
        -------
        ndarray
            α in dB/m, the shape of ``f``.

        Examples
        --------
        >>> np.round(1e3 * Air().alpha([1000.0, 8000.0]), 1).tolist()   # dB/km
        [5.0, 77.6]
        """
        return air_alpha(
            f, temperature=self.temperature, humidity=self.humidity, pressure=self.pressure
        )

    def describe(self) -> dict[str, float]:
        """The air as ``meta["outdoor"]["air"]`` records it (units in the keys).

        Returns
        -------
        dict
            ``temperature_c``, ``humidity_pct``, ``pressure_kpa``.

        Examples
        --------
        >>> Air(15.0).describe()
        {'temperature_c': 15.0, 'humidity_pct': 70.0, 'pressure_kpa': 101.325}
        """
        return {
            "temperature_c": self.temperature,
            "humidity_pct": self.humidity,
            "pressure_kpa": self.pressure,
        }


@dataclass(frozen=True)
class Ground:
    """A flat ground at ``z = height`` (m) with a real reflection factor (−1…1; 1 rigid).

    Parameters
    ----------
    height : float
        Height of the plane, m (sources and listeners stay at or above it).
    reflection : float
        Plane-wave reflection factor Q in −1…1 (1 rigid, 0 absorbing).

    Raises
    ------
    ParameterError
        A value that is not a finite number, or Q outside −1…1.

    Examples
    --------
    >>> Ground(height=-1.0, reflection=0.8)
    Ground(height=-1.0, reflection=0.8)
    """

    height: float = 0.0
    reflection: float = 1.0

    def __post_init__(self) -> None:
        for name, v in (("height", self.height), ("reflection", self.reflection)):
            if isinstance(v, bool) or not isinstance(v, int | float | np.floating | np.integer):
                raise ParameterError(f"ground {name} must be a number, got {v!r}")
            if not math.isfinite(v):
                raise ParameterError(f"ground {name} must be finite, got {v!r}")
            object.__setattr__(self, name, float(v))
        if not -1.0 <= self.reflection <= 1.0:
            raise ParameterError(
                f"ground reflection factor must be in −1…1 (1 rigid, 0 "
                f"absorbing), got {self.reflection!r}"
            )

    @classmethod
    def parse(cls, spec: str) -> Ground:
        """The ground of a command-line spec: ``"H"`` or ``"H,Q"``.

        Parameters
        ----------
        spec : str
            The plane's height (m) and reflection factor (default 1), comma-separated.

        Returns
        -------
        Ground

        Raises
        ------
        ParameterError
            Not one or two numbers, or Q outside −1…1.

        Examples
        --------
        >>> Ground.parse("1.5")
        Ground(height=1.5, reflection=1.0)
        """
        bits = [b.strip() for b in str(spec).split(",")]
        if not 1 <= len(bits) <= 2 or not all(bits):
            raise ParameterError(
                f"ground must be H[,Q] (height in m, reflection factor), e.g. 0,0.8; got {spec!r}"
            )
        names = ("height", "reflection")
        vals = {n: _number(b, f"ground {n}", spec) for n, b in zip(names, bits, strict=False)}
        return cls(**vals)

    def mirror(self, points: NDArray[np.floating]) -> NDArray[np.float64]:
        """``points`` mirrored in the plane: z → 2 height − z.

        Parameters
        ----------
        points : (..., 3) float
            Positions, m.

        Returns
        -------
        (..., 3) float
            The mirrored positions (a new array).

        Examples
        --------
        >>> Ground(height=1.0).mirror(np.array([[2.0, 3.0, 4.0]])).tolist()
        [[2.0, 3.0, -2.0]]
        """
        out = np.array(points, dtype=np.float64)
        out[..., 2] = 2.0 * self.height - out[..., 2]
        return out

    def describe(self) -> dict[str, float]:
        """The ground as ``meta["outdoor"]["ground"]`` records it.

        Returns
        -------
        dict
            ``height_m`` and ``reflection``.

        Examples
        --------
        >>> Ground(0.0, 0.8).describe()
        {'height_m': 0.0, 'reflection': 0.8}
        """
        return {"height_m": self.height, "reflection": self.reflection}


def check_options(air: Any, ground: Any) -> None:
    """Refuse ``air``/``ground`` that are not :class:`Air`/:class:`Ground` (or None).

    Parameters
    ----------
    air : Air or None
        The air option of a render.
    ground : Ground or None
        The ground option of a render.

    Raises
    ------
    ParameterError
        Either of another type (a spec string: parse it with :meth:`Air.parse`
        or :meth:`Ground.parse`).

    Examples
    --------
    >>> check_options(Air(), None)
    >>> check_options("20,70", None)
    Traceback (most recent call last):
    ...
    auralize.errors.ParameterError: air must be an auralize.emitters.outdoor.Air or None, got '20,70'
    """
    if air is not None and not isinstance(air, Air):
        raise ParameterError(f"air must be an auralize.emitters.outdoor.Air or None, got {air!r}")
    if ground is not None and not isinstance(ground, Ground):
        raise ParameterError(
            f"ground must be an auralize.emitters.outdoor.Ground or None, got {ground!r}"
        )


def describe(air: Air | None, ground: Ground | None) -> dict[str, Any]:
    """What ``meta["outdoor"]`` records of the options (``text``: one line for reports).

    Parameters
    ----------
    air : Air or None
        The air (None: no absorption).
    ground : Ground or None
        The ground (None: none).

    Returns
    -------
    dict
        ``air`` and ``ground`` (:meth:`Air.describe`, :meth:`Ground.describe`
        or None) and ``text``.

    Examples
    --------
    >>> describe(None, Ground(0.0, 0.8))["text"]
    'outdoors: ground at z = 0 m, reflection factor 0.8'
    """
    said = []
    if air is not None:
        said.append(
            f"air {air.temperature:g} °C, {air.humidity:g} % RH, {air.pressure:g} kPa (ISO 9613-1)"
        )
    if ground is not None:
        said.append(f"ground at z = {ground.height:g} m, reflection factor {ground.reflection:g}")
    return {
        "air": None if air is None else air.describe(),
        "ground": None if ground is None else ground.describe(),
        "text": "outdoors: " + "; ".join(said),
    }


# ----------------------------------------------------------------------------- the filter
def frame_length(rate: float) -> int:
    """Samples per frame of the absorption filter at ``rate``: :data:`FRAME_S`, a power of two
    in 32…4096.

    Parameters
    ----------
    rate : float
        Sample rate, Hz.

    Returns
    -------
    int
        The power of two nearest ``FRAME_S · rate`` in log scale, within 32…4096.

    Examples
    --------
    >>> frame_length(8000), frame_length(44100), frame_length(768000)
    (128, 1024, 4096)
    """
    return int(2 ** min(12, max(5, round(math.log2(max(FRAME_S * float(rate), 1.0))))))


def _window(n: int) -> NDArray[np.float32]:
    """Periodic square-root Hann window: its squares overlap-add to 1 at a hop of n/2."""
    return np.sqrt(0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(n) / n)).astype(np.float32)


def frames(n: int, frame: int, *, lead: int = 0) -> tuple[int, int]:
    """``(total, K)``: the padded length and number of frames :func:`stft_filter` uses for
    rows of ``n`` samples with ``lead`` zeros before them (frame k starts at sample
    ``k·frame/2 − lead``).

    Parameters
    ----------
    n : int
        Samples per row.
    frame : int
        Frame length (even; the hop is half of it).
    lead : int
        Zeros before the rows (0: none, and none after them either).

    Returns
    -------
    total : int
        Samples of the padded rows (``n`` when ``lead`` is 0).
    K : int
        Number of frames.

    Examples
    --------
    >>> frames(448, 128), frames(1000, 128, lead=128)
    ((448, 6), (1280, 19))
    """
    H = frame // 2
    total = -(-(n + 2 * lead) // H) * H if lead else n
    return total, (total - frame) // H + 1


def stft_filter(
    x: NDArray[np.floating],
    frame: int,
    log_gain: Callable[[slice], NDArray[np.float64]],
    *,
    lead: int = 0,
    dtype: type = np.float64,
) -> NDArray[Any]:
    """Rows ``x (R, n)`` filtered frame by frame with zero-phase gains.

    The rows are taken with ``lead`` zeros before them and zeros after, to
    whole frames (:func:`frames`; with ``lead`` 0, ``n − frame`` must be a
    multiple of the hop).  Frame ``k`` covers samples ``k·H − lead`` …
    ``k·H − lead + frame`` (H = frame/2); ``log_gain(rows)`` gives the
    natural-log gains ``(rows, K, frame//2 + 1)`` of those rows at each frame
    and frequency bin.  Samples covered by both frames that overlap them (all
    but the first and last H of the padded rows) are exact; with gains 0 they
    are ``x`` to single-precision round-off (the transforms run in float32:
    about 10⁻⁷ of each frame's largest sample, far below what the air takes).
    The rows are filtered a chunk at a time.

    Parameters
    ----------
    x : (R, n) float
        The rows.
    frame : int
        Frame length N (even; :func:`frame_length`).
    log_gain : callable
        ``log_gain(rows: slice) -> (rows, K, N//2 + 1)`` natural-log gains of
        those rows at each frame and frequency bin (``np.fft.rfftfreq(N, 1/rate)``).
    lead : int
        Zeros taken before the rows (N: every sample is covered by two frames).
    dtype : type
        Type of the output.

    Returns
    -------
    (R, n) ndarray
        The filtered rows, of ``dtype``.

    Examples
    --------
    Gains of 1 give the rows back; a gain of e⁻¹ at every bin scales them:

    >>> x = np.random.default_rng(0).normal(size=(2, 1000))
    >>> K = frames(1000, 128, lead=128)[1]
    >>> def unit(rows):
    ...     return np.zeros((rows.stop - rows.start, K, 65))
    >>> bool(np.allclose(stft_filter(x, 128, unit, lead=128), x, atol=1e-5))
    True
    >>> y = stft_filter(x, 128, lambda rows: unit(rows) - 1.0, lead=128)
    >>> bool(np.allclose(y, x / np.e, atol=1e-5))
    True
    """
    from numpy.lib.stride_tricks import sliding_window_view
    from scipy.fft import irfft, rfft

    R, n = x.shape
    H = frame // 2
    total, K = frames(n, frame, lead=lead)
    w = _window(frame)
    out: NDArray[Any] = np.empty((R, n), dtype=dtype)
    step = max(1, _CHUNK // max(1, K * (frame // 2 + 1)))
    for r0 in range(0, R, step):  # row chunks: the frames of a chunk stay within _CHUNK
        rows = slice(r0, min(R, r0 + step))
        xs = np.zeros((rows.stop - rows.start, total), dtype=np.float32)
        xs[:, lead : lead + n] = x[rows]
        spec = rfft(sliding_window_view(xs, frame, axis=-1)[:, ::H] * w, axis=-1)
        spec *= np.exp(log_gain(rows).astype(np.float32))
        y = irfft(spec, n=frame, axis=-1)
        y *= w
        acc = np.zeros_like(xs)
        o = acc.reshape(y.shape[0], total // H, H)
        o[:, :K] += y[:, :, :H]  # the two frames overlapping each hop
        o[:, 1 : K + 1] += y[:, :, H:]
        out[rows] = acc[:, lead : lead + n]
    return out


# ----------------------------------------------------------------------------- emitters
def _positions_at(em: Emitters, tau: NDArray[np.float64]) -> NDArray[np.float64]:
    """Emitter positions ``(S, K, 3)`` at emission times ``tau (K,)`` (linear, held at the ends)."""
    pos = em.positions
    S = pos.shape[0]
    if pos.ndim == 2:
        return np.broadcast_to(pos[:, None, :], (S, tau.size, 3))
    m = pos.shape[1]
    if m == 1:
        return np.broadcast_to(pos[:, :1, :], (S, tau.size, 3))
    assert em.pos_rate is not None
    x = np.clip((tau - em.t0) * em.pos_rate, 0.0, m - 1.0)
    i0 = np.minimum(x.astype(np.int64), m - 2)
    fr = (x - i0)[None, :, None]
    return np.asarray(pos[:, i0] * (1.0 - fr) + pos[:, i0 + 1] * fr)


def retarded_distance(
    em: Emitters, path: ListenerPath, tau: NDArray[np.float64], *, c0: float = C0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Distance and air-frame frequency factor of each emitter's sound emitted at ``tau``.

    The distance solves ``D = |x_s(τ) − L(τ + D/c0)|`` by fixed-point
    iteration (:data:`ITERATIONS` at most; it contracts by the listener's
    Mach number).

    Parameters
    ----------
    em : Emitters
        The emitters (static or moving).
    path : ListenerPath
        The listener.
    tau : (K,) float
        Emission times, playback seconds since the path's first capture.
    c0 : float
        Speed of sound (m/s).

    Returns
    -------
    D : (S, K) float
        The distance (m, clamped to the emitter's radius) the sound emitted
        at playback second τ travels to the listener.
    gamma : (S, K) float
        The factor ``1 / (1 − v_s·n̂/c0)`` from the emitted frequency to the
        frequency of the wave in the air (1 for a static emitter; v_s its
        velocity, n̂ the unit vector to the listener; at most 20).

    Examples
    --------
    An emitter moving at 34.3 m/s straight toward a listener 100 m ahead:

    >>> track = np.linspace([0.0, 0, 0], [34.3, 0, 0], 11)[None]   # 1 s at 10 Hz
    >>> em = Emitters(np.zeros((1, 8)), 8000, track, pos_rate=10.0)
    >>> D, g = retarded_distance(em, ListenerPath.point((100.0, 0, 0), duration=1.0),
    ...                          np.array([0.1, 0.5]), c0=343.0)
    >>> D.round(3).tolist(), g.round(4).tolist()
    ([[96.57, 82.85]], [[1.1111, 1.1111]])
    """
    X = _positions_at(em, tau)
    S, K = X.shape[:2]
    t_abs = path.times[0] + tau
    L = np.broadcast_to(path.position_at(t_abs)[None], X.shape)
    D = np.linalg.norm(X - L, axis=-1)
    moving = bool(np.ptp(path.positions, axis=0).max(initial=0.0) > 0)
    for _ in range(ITERATIONS if moving else 0):
        L = path.position_at((t_abs[None, :] + D / c0).ravel()).reshape(S, K, 3)
        D_new = np.linalg.norm(X - L, axis=-1)
        done = float(np.max(np.abs(D_new - D), initial=0.0)) < 1e-9 * (1.0 + float(D.max()))
        D = D_new
        if done:
            break
    gamma = np.ones((S, K))
    if em.moving:
        assert em.pos_rate is not None
        dt = 0.5 / em.pos_rate
        V = (_positions_at(em, tau + dt) - _positions_at(em, tau - dt)) / (2.0 * dt)
        n_hat = (L - X) / np.maximum(D, 1e-300)[..., None]
        gamma = 1.0 / np.maximum(1.0 - np.sum(V * n_hat, axis=-1) / c0, 0.05)
    assert isinstance(em.radius, np.ndarray)
    return np.maximum(D, em.radius[:, None]), gamma


def _rebuilt(
    em: Emitters, signals: NDArray[np.floating], positions: NDArray[np.float64], name: str
) -> Emitters:
    """``em`` with other signals and positions (placement checked, samples not rescanned)."""
    out = Emitters.__new__(Emitters)
    out.signals = np.ascontiguousarray(signals)
    out.rate, out.t0, out.pos_rate = em.rate, em.t0, em.pos_rate
    out.positions = np.ascontiguousarray(positions)
    out.radius = np.array(em.radius, dtype=np.float64)
    out.law, out.name, out.meta = em.law, name, dict(em.meta)
    return out


def absorbed_emitters(em: Emitters, path: ListenerPath, air: Air, *, c0: float = C0) -> Emitters:
    """``em`` with each emitted signal filtered by the air along its path to the listener.

    Each emitter's signal is filtered by ``10^(−α(γ f) D / 20)`` frame by frame
    (:func:`stft_filter`), with D and γ of :func:`retarded_distance` at the
    frame's centre.  The emission window stays ``[t0, t0 + n/rate)``; the
    signals are float32 (as the filter computes them; the sampled backend
    widens them once per render).

    Parameters
    ----------
    em : Emitters
        The emitters (a :class:`~auralize.emitters.TableEmitters` is filtered
        from its samples and becomes plain :class:`~auralize.emitters.Emitters`).
    path : ListenerPath
        The listener.
    air : Air
        The air.
    c0 : float
        Speed of sound (m/s).

    Returns
    -------
    Emitters
        The same placement, name and law, with the filtered signals.

    Examples
    --------
    A 4 kHz tone from 1 km loses α(4 kHz) · 1000 m, about 23 dB, on its way:

    >>> t = np.arange(1600) / 16000
    >>> em = Emitters(np.sin(2 * np.pi * 4000 * t)[None], 16000, [[0.0, 1000.0, 0.0]])
    >>> out = absorbed_emitters(em, ListenerPath.point((0, 0, 0), duration=0.1), Air())
    >>> mid = slice(400, 1200)
    >>> loss = 20 * np.log10(np.std(em.signals[0, mid]) / np.std(out.signals[0, mid]))
    >>> out.signals.dtype, round(float(loss), 1), round(float(Air().alpha(4000.0)) * 1000, 1)
    (dtype('float32'), 23.1, 23.1)
    """
    sig = em.signals
    n = sig.shape[-1]
    C = 3 if em.dipole else 1
    N = frame_length(em.rate)
    _, K = frames(n, N, lead=N)
    tau = em.t0 + (np.arange(K, dtype=np.float64) * (N // 2) - 0.5 * N) / em.rate  # frame centres
    D, gamma = retarded_distance(em, path, tau, c0=c0)
    f = np.fft.rfftfreq(N, 1.0 / em.rate)
    nd = -_DB * D  # (S, K)
    still = bool(np.all(gamma == 1.0))
    a_f = air.alpha(f)

    def log_gain(rows: slice) -> NDArray[np.float64]:
        s = np.arange(rows.start, rows.stop) // C  # the emitter of each row
        if still:
            return np.asarray(nd[s][:, :, None] * a_f[None, None, :])
        return np.asarray(nd[s][:, :, None] * air.alpha(f[None, None, :] * gamma[s][:, :, None]))

    rows = sig.reshape(-1, n)
    out = stft_filter(rows, N, log_gain, lead=N, dtype=np.float32).reshape(sig.shape)
    return _rebuilt(em, out, em.positions, em.name)


def image_emitters(em: Emitters, ground: Ground) -> Emitters:
    """The ground image of ``em``: positions mirrored, signals times Q, a dipole's z reversed.

    Parameters
    ----------
    em : Emitters
        The emitters (a :class:`~auralize.emitters.TableEmitters` gives a
        table-emitter image).
    ground : Ground
        The plane and its reflection factor Q.

    Returns
    -------
    Emitters
        Named ``"<name>:ground"``.

    Examples
    --------
    >>> em = Emitters(np.ones((1, 4)), 8000, [[0.0, 5.0, 2.0]], name="bell")
    >>> img = image_emitters(em, Ground(0.0, 0.5))
    >>> img.name, img.positions.tolist(), img.signals.tolist()
    ('bell:ground', [[0.0, 5.0, -2.0]], [[0.5, 0.5, 0.5, 0.5]])
    """
    Q = ground.reflection
    pos = ground.mirror(em.positions)
    name = f"{em.name or 'emitters'}:ground"
    if isinstance(em, TableEmitters):
        scale = np.array([Q, Q, -Q])[None, None, :, None] if em.dipole else Q
        return TableEmitters(
            em.table,
            em.lengths,
            qa=em.qa * scale,
            qb=em.qb * scale,
            phase=em.phase,
            r0=em.r0,
            r1=em.r1,
            w=em.w,
            block=em.block,
            rate=em.rate,
            positions=pos,
            t0=em.t0,
            pos_rate=em.pos_rate,
            radius=em.radius,
            law=em.law,
            name=name,
            meta=em.meta,
            check=False,
        )
    sig = em.signals
    if em.dipole:
        sig = sig * np.array([Q, Q, -Q], dtype=sig.dtype)[None, :, None]
    else:
        sig = sig * sig.dtype.type(Q)
    return _rebuilt(em, sig, pos, name)


# ----------------------------------------------------------------------------- the volume
@dataclass
class OutdoorField(FieldSources):
    """The volume's sources with the outdoor options: ``tracks`` with their ground
    images (if any), heard through ``air`` at their mean distance (if any).

    Made by :func:`outdoor_parts`.

    Parameters
    ----------
    tracks, time_scale, lead, interp, timbre, bounds, name, meta, by_type, seed
        As :class:`~auralize.emitters.FieldSources` (``tracks`` with the
        ground images).
    air : Air, optional
        The air the sources are heard through (None: no absorption).

    Examples
    --------
    >>> from auralize.sources.detection import SourceTracks
    >>> t = np.linspace(0.0, 0.1, 11)
    >>> tracks = SourceTracks(positions=np.array([[0.0, 0, 1.0]]), q=np.ones((1, 11)),
    ...                       radius=np.array([0.1]), times=t)
    >>> path = ListenerPath.point((3.0, 0, 1.0), duration=0.05)
    >>> [part] = outdoor_parts([FieldSources(tracks)], path, air=Air(), ground=Ground())
    >>> type(part).__name__, part.tracks.n_sources, part.air
    ('OutdoorField', 2, Air(temperature=20.0, humidity=70.0, pressure=101.325))
    """

    air: Air | None = field(default=None, kw_only=True)


def imaged_tracks(tracks: Any, ground: Ground) -> Any:
    """Source tracks plus their ground images (mirrored, q times Q), as one set.

    Parameters
    ----------
    tracks : SourceTracks
        K sources (:class:`auralize.sources.detection.SourceTracks`).
    ground : Ground
        The plane and its reflection factor Q.

    Returns
    -------
    SourceTracks
        2K sources: the K given, then their images in the same order.

    Examples
    --------
    >>> from auralize.sources.detection import SourceTracks
    >>> tracks = SourceTracks(positions=np.array([[0.0, 0, 1.0]]), q=np.ones((1, 3)),
    ...                       radius=np.array([0.1]), times=np.arange(3.0))
    >>> both = imaged_tracks(tracks, Ground(0.0, -1.0))
    >>> both.positions.tolist(), both.q[:, 0].tolist()
    ([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]], [1.0, -1.0])
    """
    from auralize.sources.detection import SourceTracks

    pos = np.asarray(tracks.positions, dtype=np.float64).reshape(-1, 3)
    q = np.asarray(tracks.q, dtype=np.float64)
    kind = None if tracks.kind is None else np.concatenate([tracks.kind, tracks.kind])
    index = None if tracks.index is None else np.concatenate([tracks.index, tracks.index])
    return SourceTracks(
        positions=np.concatenate([pos, ground.mirror(pos)]),
        q=np.concatenate([q, ground.reflection * q]),
        radius=np.concatenate([tracks.radius, tracks.radius]),
        times=tracks.times,
        index=index,
        kind=kind,
        origin=tracks.origin,
        end=tracks.end,
    )


def field_distance(
    part: FieldSources, path: ListenerPath, *, c0: float = C0
) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """D̄(t): the mean distance (m) of the volume's sources heard at playback seconds t.

    The |q|-weighted harmonic mean the timbres' carriers follow
    (:func:`auralize.emitters.timbre.mean_distance`), at least 1 mm.

    Parameters
    ----------
    part : FieldSources
        The volume's sources (its ``time_scale`` and ``lead`` map playback
        time to data time).
    path : ListenerPath
        The listener.
    c0 : float
        Speed of sound (m/s).

    Returns
    -------
    callable
        ``D(t)``: playback seconds ``(J,)`` since the path's first capture to
        distances ``(J,)`` in m.

    Examples
    --------
    >>> from auralize.sources.detection import SourceTracks
    >>> t = np.linspace(0.0, 0.1, 11)
    >>> tracks = SourceTracks(positions=np.zeros((1, 3)), q=np.ones((1, 11)),
    ...                       radius=np.array([0.1]), times=t)
    >>> D = field_distance(FieldSources(tracks), ListenerPath.point((3.0, 0, 0), duration=0.1))
    >>> D(np.array([0.02, 0.05])).tolist()
    [3.0, 3.0]
    """
    from auralize.emitters.timbre import mean_distance

    tracks = part.tracks
    t0 = tracks.t_first + part.lead

    def at(t: NDArray[np.float64]) -> NDArray[np.float64]:
        t_data = t0 + t / part.time_scale
        return np.maximum(mean_distance(tracks, path, t_data, path.times[0] + t, c0=c0), 1e-3)

    return at


# ----------------------------------------------------------------------------- received filter
def received(
    run: Callable[[dict[str, Any]], Any],
    kw: dict[str, Any],
    path: ListenerPath,
    air: Air,
    distance: Callable[[NDArray[np.float64]], NDArray[np.float64]],
) -> Any:
    """``run(kw)`` (a render of samples ``kw["start"]``… ``kw["duration"]``) heard through the air.

    The render is taken over every frame of the absorption filter that overlaps
    the asked samples (frames on a grid fixed in playback time, the time before
    the path's first capture silent) and filtered with the gain at
    ``distance(t)`` of each frame's centre; so consecutive ranges join into
    the render of their union, as the engine's block renders must.
    ``distance`` is called after ``run`` (it may read what ``run`` recorded).

    Parameters
    ----------
    run : callable
        ``run(kw) -> Rendered``: a render with the keywords ``kw`` (its
        ``start`` and ``duration`` changed to cover whole frames).
    kw : dict
        The render's keywords: ``rate`` (Hz), ``start`` (playback s) and
        ``duration`` (playback s; None: the rest of the path), and whatever
        ``run`` takes besides.
    path : ListenerPath
        The listener.
    air : Air
        The air.
    distance : callable
        ``distance(t)``: playback seconds ``(K,)`` to distances ``(K,)`` in m.

    Returns
    -------
    Rendered
        ``run``'s render of the asked samples, its ``audio`` filtered.

    Examples
    --------
    At distance 0 the air takes nothing: the render comes back as it was.

    >>> from auralize.emitters.engine import render_sound
    >>> em = Emitters(np.random.default_rng(1).normal(size=(1, 800)), 8000, [[0.0, 2.0, 0.0]])
    >>> path = ListenerPath.point((0, 0, 0), duration=0.1)
    >>> def run(k):
    ...     return render_sound(em, path, **k)
    >>> kw = {"rate": 8000, "start": 0.0, "duration": 0.1}
    >>> out = received(run, kw, path, Air(), lambda t: np.zeros_like(t))
    >>> out.audio.shape, bool(np.allclose(out.audio, run(kw).audio, atol=1e-5))
    ((1, 800), True)
    """
    rate = int(kw["rate"])
    start = float(kw["start"])
    dur = path.duration - start if kw.get("duration") is None else float(kw["duration"])
    s = int(round(start * rate))
    off = start - s / rate
    n = int(round(dur * rate))
    N = frame_length(rate)
    H = N // 2
    k_lo = (s - N) // H + 1
    k_hi = max((s + n - 1) // H, k_lo)
    a, b = k_lo * H, k_hi * H + N
    lo = max(a, 0)
    r = run({**kw, "start": lo / rate + off, "duration": (b - lo) / rate})
    x = np.zeros((r.audio.shape[0], b - a))
    m = min(b - lo, r.audio.shape[1])
    x[:, lo - a : lo - a + m] = r.audio[:, :m]
    K = k_hi - k_lo + 1
    D = np.asarray(distance(off + (a + np.arange(K) * H + 0.5 * N) / rate), dtype=np.float64)
    a_f = air.alpha(np.fft.rfftfreq(N, 1.0 / rate))
    nd = -_DB * D

    def log_gain(rows: slice) -> NDArray[np.float64]:
        return np.broadcast_to(
            nd[None, :, None] * a_f[None, None, :], (rows.stop - rows.start, K, a_f.size)
        )

    r.audio = stft_filter(x, N, log_gain)[:, s - a : s - a + n]
    return r


# ----------------------------------------------------------------------------- model parts
@dataclass
class _Context:
    air: Air
    c0: float
    emitters: int = 0
    arrivals: list[tuple[NDArray[np.float64], NDArray[np.float64]]] = field(default_factory=list)


_ACTIVE: contextvars.ContextVar[_Context | None] = contextvars.ContextVar("outdoor", default=None)


@contextlib.contextmanager
def _through_air(air: Air | None, c0: float) -> Iterator[_Context | None]:
    """While active, the engine's emitter renders filter their emitters through ``air``."""
    if air is None:
        yield None
        return
    ctx = _Context(air, float(c0))
    token = _ACTIVE.set(ctx)
    try:
        yield ctx
    finally:
        _ACTIVE.reset(token)


def in_air(em: Emitters, path: ListenerPath) -> Emitters:
    """``em`` filtered by the air of the active model part.

    :func:`auralize.emitters.engine.render_emitters` calls this: the emitters
    a model's own part renders through the engine inside an
    :class:`OutdoorPart` are heard through its air (:func:`absorbed_emitters`);
    outside such a render it is ``em`` itself.

    Parameters
    ----------
    em : Emitters
        The emitters being rendered.
    path : ListenerPath
        The listener.

    Returns
    -------
    Emitters
        ``em``, or its air-filtered copy.

    Examples
    --------
    >>> em = Emitters(np.zeros((1, 8)), 8000, [[1.0, 0, 0]])
    >>> in_air(em, ListenerPath.point((0, 0, 0), duration=0.01)) is em
    True
    """
    ctx = _ACTIVE.get()
    if ctx is None:
        return em
    ctx.emitters += 1
    return absorbed_emitters(em, path, ctx.air, c0=ctx.c0)


def note_arrivals(time: NDArray[np.float64], distance: NDArray[np.float64]) -> None:
    """Record arrivals a closed-form part takes from the engine (for its air filter).

    :func:`auralize.emitters.events.arrivals` calls this; inside an
    :class:`OutdoorPart`'s render the arrivals give the distances its output
    is filtered along (:func:`arrival_distance`); elsewhere nothing is kept.

    Parameters
    ----------
    time : array_like of float
        Arrival times, playback seconds since the path's first capture.
    distance : array_like of float
        Distances travelled (m), one per arrival.

    Examples
    --------
    >>> note_arrivals(np.array([0.1]), np.array([3.0]))   # outside a part's render: kept nowhere
    """
    ctx = _ACTIVE.get()
    if ctx is not None and np.size(time):
        ctx.arrivals.append(
            (np.array(time, dtype=np.float64).ravel(), np.array(distance, dtype=np.float64).ravel())
        )


def arrival_distance(
    ctx: _Context, rate: float
) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """D(t) of recorded arrivals: their mean distance within each frame, interpolated
    between frames that hear none (held at the ends).

    Parameters
    ----------
    ctx : _Context
        The active part's context, with the arrivals :func:`note_arrivals`
        recorded (at least one).
    rate : float
        Output sample rate (Hz; sets the frame length, :func:`frame_length`).

    Returns
    -------
    callable
        ``D(t)``: frame centres ``(K,)`` in playback seconds to distances ``(K,)`` in m.

    Examples
    --------
    >>> ctx = _Context(Air(), 343.0, arrivals=[(np.array([0.1, 0.2]), np.array([10.0, 20.0]))])
    >>> arrival_distance(ctx, 8000)(np.array([0.1, 0.15, 0.2])).tolist()
    [10.0, 15.0, 20.0]
    """
    t = np.concatenate([a[0] for a in ctx.arrivals])
    d = np.concatenate([a[1] for a in ctx.arrivals])
    order = np.argsort(t, kind="stable")
    t, d = t[order], d[order]
    cum = np.concatenate([[0.0], np.cumsum(d)])
    half = 0.5 * frame_length(rate) / rate

    def at(tc: NDArray[np.float64]) -> NDArray[np.float64]:
        i0 = np.searchsorted(t, tc - half)
        i1 = np.searchsorted(t, tc + half)
        cnt = i1 - i0
        mean = (cum[i1] - cum[i0]) / np.maximum(cnt, 1)
        return np.where(cnt > 0, mean, np.interp(tc, t, d))

    return at


def mirror_matrix(layout: Any) -> NDArray[np.float64]:
    """``(n, n)`` matrix taking a render for the mirrored listener back to the listener's frame.

    A listener mirrored in the ground with forward and up mirrored has a
    left-handed frame: the engine, which takes left = up × forward, pans its
    sources mirrored left–right.  This matrix mirrors them back: mono as it
    is; AmbiX harmonics of negative degree m (odd in azimuth) negated;
    receivers (the ears) swapped with their mirror partners (zonal harmonics
    about each ear's axis); speakers re-panned by the layout's own law to
    their mirrored directions (a permutation for a left–right symmetric
    layout; LFE kept).

    Parameters
    ----------
    layout : Layout
        The output layout (:func:`auralize.spatial.layouts.get_layout`).

    Returns
    -------
    (n_channels, n_channels) float
        ``M`` with ``M @ mirrored_render`` in the listener's frame.

    Raises
    ------
    ParameterError
        A layout of receivers that are not mirror pairs with zonal channels.

    Examples
    --------
    >>> from auralize.spatial.layouts import get_layout
    >>> mirror_matrix(get_layout("stereo")).tolist()
    [[0.0, 1.0], [1.0, 0.0]]
    >>> np.diag(mirror_matrix(get_layout("ambix1"))).tolist()
    [1.0, -1.0, 1.0, 1.0]
    """
    from auralize.spatial.layouts import (
        ambix_channels,
        is_ambisonic,
        pan_gains,
        receivers_of,
    )

    n = layout.n_channels
    if n == 1:
        return np.ones((1, 1))
    if is_ambisonic(layout):
        k = ambix_channels(layout)
        deg = np.floor(np.sqrt(k)).astype(np.int64)
        m = k - deg * deg - deg
        return np.diag(np.where(m < 0, -1.0, 1.0))
    ears = receivers_of(layout)
    if ears:
        out = np.zeros((n, n))
        c = np.cumsum([0] + [r.layout.n_channels for r in ears])
        for i, r in enumerate(ears):
            want = (r.offset[0], -r.offset[1], r.offset[2])
            j = next(
                (
                    j
                    for j, e in enumerate(ears)
                    if np.allclose(e.offset, want) and e.layout == r.layout
                ),
                None,
            )
            acn = ambix_channels(r.layout) if is_ambisonic(r.layout) else None
            zonal = acn is not None and bool(
                np.all(acn == np.floor(np.sqrt(acn)) ** 2 + np.floor(np.sqrt(acn)))
            )
            if j is None or not zonal:
                raise ParameterError(
                    f"the ground image of a model's own part cannot be heard "
                    f"in layout {layout.name!r}: its receivers are not mirror "
                    f"pairs with zonal channels"
                )
            out[c[i] : c[i + 1], c[j] : c[j + 1]] = np.eye(c[i + 1] - c[i])
        return out
    dirs = layout.directions()
    ch = layout.panned_channels
    out = np.eye(n)
    mirrored = dirs[ch] * np.array([1.0, -1.0, 1.0])
    g = pan_gains(layout, mirrored)  # (n, len(ch)): column k the gains of channel ch[k]'s mirror
    out[:, ch] = g
    return out


def mirrored_path(path: ListenerPath, ground: Ground) -> ListenerPath:
    """The listener mirrored in the ground: positions, forward and up (cached on ``path``).

    Parameters
    ----------
    path : ListenerPath
        The listener.
    ground : Ground
        The plane.

    Returns
    -------
    ListenerPath
        The mirrored path (the same object for the same path and ground).

    Examples
    --------
    >>> path = ListenerPath.point((0, 0, 1.5), duration=1.0)
    >>> image = mirrored_path(path, Ground(0.0))
    >>> image.positions[0].tolist(), image.up[0].tolist(), mirrored_path(path, Ground(0.0)) is image
    ([0.0, 0.0, -1.5], [0.0, 0.0, -1.0], True)
    """
    cache = path.__dict__.setdefault("_ground_images", {})
    key = (path.times, path.positions, path.forward, path.up)
    hit = cache.get(ground)
    if hit is not None and all(a is b for a, b in zip(hit[0], key, strict=True)):
        return hit[1]
    flip = np.array([1.0, 1.0, -1.0])
    assert path.forward is not None and path.up is not None
    out = ListenerPath(
        path.times,
        ground.mirror(path.positions),
        path.forward * flip,
        path.up * flip,
        source=f"{path.source} (mirrored in the ground)",
    )
    cache[ground] = (key, out)
    return out


@dataclass
class OutdoorPart:
    """A model's own part (``render_part``) heard through the air and over the ground.

    The part is rendered as it is, its emitter renders filtered through the
    air (or its output, along the distances of the arrivals it took from the
    engine); its ground image is the part rendered for the listener mirrored
    in the ground, times Q, its channels mirrored back (:func:`mirror_matrix`).
    Made by :func:`outdoor_parts`.

    Parameters
    ----------
    part : object
        The model's part: ``name`` and ``render_part(path, *, rate, layout,
        duration, start, c0, backend) -> Rendered``.
    air : Air or None
        The air (None: no absorption).
    ground : Ground or None
        The ground (None: none).
    name : str
        The part's name (default the part's own).
    meta : dict
        Ignored: the part's own ``meta`` plus ``notes`` (what could not be
        done outdoors).

    Examples
    --------
    A part that renders one emitter 2 m away, over a rigid ground: the
    image, 2.83 m away, adds 0.354 Pa to the direct 0.5 Pa.

    >>> from auralize.emitters.engine import render_emitters
    >>> class Beep:
    ...     name = "beep"
    ...     def render_part(self, path, **kw):
    ...         em = Emitters(np.ones((1, 400)), 8000, [[0.0, 2.0, 1.0]])
    ...         return render_emitters(em, path, **kw)
    >>> part = OutdoorPart(Beep(), None, Ground(0.0))
    >>> r = part.render_part(ListenerPath.point((0, 0, 1.0), duration=0.05), rate=8000,
    ...                      layout="mono", duration=0.05, start=0.0, c0=343.0)
    >>> part.name, round(float(r.audio[0, -1]), 4)
    ('beep', 0.8536)
    """

    part: Any
    air: Air | None
    ground: Ground | None
    _: KW_ONLY
    name: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.name = self.name or str(getattr(self.part, "name", ""))
        self.meta = {**getattr(self.part, "meta", {}), "notes": []}

    def _one(self, path: ListenerPath, kw: dict[str, Any]) -> Any:
        """One render of the part along ``path`` (the air as the module docstring says)."""
        with _through_air(self.air, kw["c0"]) as ctx:
            if ctx is None:
                return self.part.render_part(path, **kw)
            state: dict[str, Any] = {}

            def run(k: dict[str, Any]) -> Any:
                state["r"] = self.part.render_part(path, **k)
                return state["r"]

            def distance(t: NDArray[np.float64]) -> NDArray[np.float64]:
                if ctx.emitters or not ctx.arrivals:  # filtered at its emitters (or nothing known)
                    return np.zeros(np.shape(t))
                return arrival_distance(ctx, float(kw["rate"]))(t)

            out = received(run, kw, path, ctx.air, distance)
            if not ctx.emitters and not ctx.arrivals:
                self.meta["notes"] = [
                    f"{self.name}: renders without the engine's emitters or "
                    f"arrivals; heard without air absorption"
                ]
            return out

    def render_part(self, path: ListenerPath, **kw: Any) -> Any:
        """Render along ``path``: the part through the air, plus its ground image.

        Parameters
        ----------
        path : ListenerPath
            The listener.
        **kw
            As every part's ``render_part``: ``rate``, ``layout``,
            ``duration``, ``start``, ``c0``, ``backend``.

        Returns
        -------
        Rendered
            The part's render with its image added.

        Raises
        ------
        ParameterError
            A ground image in a layout :func:`mirror_matrix` cannot mirror,
            and what the part's own render refuses.

        Examples
        --------
        >>> from auralize.emitters.engine import render_emitters
        >>> class Beep:
        ...     name = "beep"
        ...     def render_part(self, path, **kw):
        ...         em = Emitters(np.ones((1, 400)), 8000, [[0.0, 2.0, 1.0]])
        ...         return render_emitters(em, path, **kw)
        >>> part = OutdoorPart(Beep(), None, Ground(0.0, 0.0))   # absorbing: no image
        >>> r = part.render_part(ListenerPath.point((0, 0, 1.0), duration=0.05), rate=8000,
        ...                      layout="mono", duration=0.05, start=0.0, c0=343.0)
        >>> round(float(r.audio[0, -1]), 4)
        0.5
        """
        from auralize.spatial.layouts import get_layout

        out = self._one(path, kw)
        g = self.ground
        if g is not None and g.reflection != 0:
            img = self._one(mirrored_path(path, g), kw)
            mix = g.reflection * mirror_matrix(get_layout(kw["layout"]))
            n = min(out.audio.shape[1], img.audio.shape[1])
            out.audio = np.array(out.audio, dtype=np.float64)
            out.audio[:, :n] += mix @ img.audio[:, :n]
        return out


# ----------------------------------------------------------------------------- every part
def _check_above(points: NDArray[np.floating], ground: Ground, what: str) -> None:
    z = np.asarray(points, dtype=np.float64).reshape(-1, 3)[:, 2]
    if z.size and float(z.min()) < ground.height - 1e-9 * (1.0 + abs(ground.height)):
        raise ParameterError(
            f"{what} goes below the ground (lowest z = {float(z.min()):.6g} m, "
            f"ground at z = {ground.height:g} m): place the ground below it, "
            f"e.g. --ground {math.floor(float(z.min())):g}"
        )


def outdoor_parts(
    parts: list[Part],
    path: ListenerPath,
    *,
    air: Air | None = None,
    ground: Ground | None = None,
    c0: float = C0,
) -> list[Part]:
    """The parts of a sound heard outdoors along ``path`` (see the module docstring).

    Emitter sets become their air-filtered selves and their ground images;
    the volume's sources an :class:`OutdoorField`; a model's own part an
    :class:`OutdoorPart`.  With neither option, ``parts`` as they are.

    Parameters
    ----------
    parts : list
        The sound's parts (:func:`auralize.emitters.engine.parts_of`).
    path : ListenerPath
        The listener.
    air : Air, optional
        The air (None: no absorption).
    ground : Ground, optional
        The ground (None: none).
    c0 : float
        Speed of sound (m/s).

    Returns
    -------
    list
        The parts to render (a new list).

    Raises
    ------
    ParameterError
        Options of the wrong type; a source or the listener below the ground.

    Examples
    --------
    >>> em = Emitters(np.ones((1, 8)), 8000, [[0.0, 5.0, 2.0]], name="bell")
    >>> path = ListenerPath.point((0, 0, 1.7), duration=0.01)
    >>> [p.name for p in outdoor_parts([em], path, ground=Ground(0.0, 0.8))]
    ['bell', 'bell:ground']
    >>> outdoor_parts([em], path, ground=Ground(3.0))
    Traceback (most recent call last):
    ...
    auralize.errors.ParameterError: the listener's path goes below the ground ...
    """
    check_options(air, ground)
    if air is None and ground is None:
        return list(parts)
    if ground is not None:
        _check_above(path.positions, ground, "the listener's path")
    out: list[Part] = []
    for p in parts:
        if isinstance(p, Emitters):
            if ground is not None:
                _check_above(p.positions, ground, f"emitter set {p.name or '(unnamed)'!r}")
            ems = [p]
            if ground is not None and ground.reflection != 0:
                ems.append(image_emitters(p, ground))
            out += [absorbed_emitters(e, path, air, c0=c0) if air else e for e in ems]
        elif isinstance(p, FieldSources):
            tracks = p.tracks
            by_type = p.by_type
            if ground is not None:
                _check_above(tracks.positions, ground, f"the volume's sources ({p.name})")
                if ground.reflection != 0:
                    tracks = imaged_tracks(tracks, ground)
                    if by_type is not None:
                        by_type = {k: imaged_tracks(v, ground) for k, v in by_type.items()}
            fields = {f: getattr(p, f) for f in FieldSources.__dataclass_fields__}
            out.append(
                OutdoorField(
                    **{
                        **fields,
                        "tracks": tracks,
                        "by_type": by_type,
                        "meta": dict(p.meta),
                        "air": air,
                    }
                )
            )
        else:
            out.append(OutdoorPart(p, air, ground))
    return out


__all__ = [
    "Air",
    "Ground",
    "OutdoorField",
    "OutdoorPart",
    "absorbed_emitters",
    "air_alpha",
    "image_emitters",
    "imaged_tracks",
    "mirror_matrix",
    "outdoor_parts",
    "received",
]
