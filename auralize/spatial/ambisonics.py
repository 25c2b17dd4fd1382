"""Higher-order Ambisonics: AmbiX encoding and decoding to loudspeaker layouts.

Conventions
-----------
*AmbiX* (Nachbar, Zotter, Deleflie & Sontacchi 2011; Zotter & Frank,
*Ambisonics*, Springer 2019, §4.8): real spherical harmonics of order
n ≤ N and degree −n ≤ m ≤ n in **ACN** channel order ``acn = n² + n + m``,
with **SN3D** normalisation and no Condon–Shortley phase::

    Y_n^m(φ, ϑ) = N_n^|m| · P_n^|m|(sin ϑ) · { cos(m φ)   m ≥ 0
                                              { sin(|m| φ) m < 0
    N_n^m = sqrt((2 − δ_m0) (n − m)! / (n + m)!)

with azimuth φ counter-clockwise from the front and elevation ϑ up from the
horizontal plane (the listener frame of :mod:`auralize.spatial.layouts`: x forward,
y left, z up).  So ACN 0 = W = 1 for every direction (a unit plane wave has
W = 1), ACN 1 = Y = y (left), ACN 2 = Z = z (up), ACN 3 = X = x (front).
The harmonics are evaluated in Cartesian form, ``cos^m ϑ · e^{imφ} =
(x + iy)^m`` times a polynomial in z (the associated Legendre recurrence
divided by ``(1 − z²)^{m/2}``), exact at the poles and vectorised over
directions.

SN3D obeys the addition theorem in the form Σ_m Y_n^m(θ) Y_n^m(θ') =
P_n(cos γ) (γ the angle between θ and θ'), which the decoders below use.

Decoders (:func:`decoder_matrix`)
---------------------------------
* **AllRAD** (Zotter & Frank 2012; book §4.9.6): the Ambisonic signal is
  decoded to a dense virtual layout by the sampling decoder
  g(θ) = Σ_n (2n+1)/(4π) a_n Σ_m Y_n^m(θ) b_nm, then every virtual speaker
  is panned onto the real speakers by 3-D VBAP
  (:func:`auralize.spatial.layouts.vbap3d_gains`, with imaginary speakers where the
  layout has gaps, their signal dropped).  In place of a spherical t-design
  the virtual layout is a Gauss–Legendre × equiangular product grid with its
  quadrature weights (:func:`sphere_quadrature`), exact for polynomials up to
  degree 47: the same role (a dense, exact sampling of the sphere).
* **Mode matching** (book §4.9.2): ``D = pinv(Y_L) diag(a_n)`` with ``Y_L``
  the harmonics of the speaker directions; for regular layouts with at least
  (N+1)² well-spread speakers (refused when ``Y_L`` is ill-conditioned).
* **Weights** a_n: ``"maxre"`` (default), the max-rE weights
  a_n = P_n(cos(137.9° / (N + 1.51))) (book §4.7.6, Eq. 4.59's
  approximation), which concentrate the energy vector rE; ``"basic"`` a_n = 1.
* Every decoder is scaled so that the loudspeaker energy Σ_s g_s², averaged
  over all source directions, is 1 (as VBAP's power normalisation).

Using AmbiX files elsewhere
---------------------------
An ``ambixN`` WAV has (N+1)² channels in ACN order with SN3D normalisation
and no channel mask (its sidecar says so).  In a DAW put it on a track with
(N+1)² channels (Reaper: 4, 9 or 16) and insert a standard AmbiX decoder: the
IEM Plug-in Suite's *AllRADecoder* (loudspeakers) or *BinauralDecoder*
(headphones), or SPARTA's *AmbiDEC*/*AmbiBIN*, set to order N, ACN, SN3D.
Game engines and players that take "AmbiX" (e.g. first order in YouTube/Meta
360 video) read the same channel order and normalisation.

Examples
--------
>>> import numpy as np
>>> y = sh_gains(1, np.array([[0.0, 1.0, 0.0]]))   # a source straight left
>>> np.round(y[:, 0], 12).tolist()                  # W, Y, Z, X
[1.0, 1.0, 0.0, 0.0]
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray

from auralize.errors import ParameterError

if TYPE_CHECKING:
    from auralize.spatial.layouts import Layout

#: highest order accepted by the encoder/decoders
MAX_ORDER = 10
#: orders that have a named ``ambixN`` layout
LAYOUT_ORDERS = (1, 2, 3)
#: how :func:`decoder_matrix` decodes (see the module docstring)
DecoderMethod = Literal["allrad", "mode-matching"]
#: per-order weights of a decoder: max-rE or none
OrderWeights = Literal["maxre", "basic"]


def n_channels(order: int) -> int:
    """Number of AmbiX channels (N+1)² of an order N.

    Parameters
    ----------
    order : int
        Ambisonics order N.

    Returns
    -------
    int

    Examples
    --------
    >>> [n_channels(n) for n in range(4)]
    [1, 4, 9, 16]
    """
    return (int(order) + 1) ** 2


def check_order(order: object) -> int:
    """``order`` checked as an Ambisonics order.

    Parameters
    ----------
    order : object
        What was given as an order.

    Returns
    -------
    int
        The order, in 0..:data:`MAX_ORDER`.

    Raises
    ------
    ParameterError
        Not an integer (bools refused) or out of range.

    Examples
    --------
    >>> check_order(np.int64(3))
    3
    >>> check_order(2.0)
    Traceback (most recent call last):
    auralize.errors.ParameterError: Ambisonics order must be an integer 0..10, got 2.0
    """
    if (
        isinstance(order, bool)
        or not isinstance(order, int | np.integer)
        or not (0 <= int(order) <= MAX_ORDER)
    ):
        raise ParameterError(f"Ambisonics order must be an integer 0..{MAX_ORDER}, got {order!r}")
    return int(order)


def order_of_channels(n_ch: int) -> int:
    """The order N of a signal of (N+1)² channels.

    Parameters
    ----------
    n_ch : int
        Number of channels.

    Returns
    -------
    int

    Raises
    ------
    ParameterError
        ``n_ch`` is not a square.

    Examples
    --------
    >>> order_of_channels(16)
    3
    >>> order_of_channels(5)
    Traceback (most recent call last):
    auralize.errors.ParameterError: an AmbiX signal has (N+1)² channels (1, 4, 9, 16, ...), got 5 channels
    """
    n = math.isqrt(int(n_ch)) - 1
    if n < 0 or (n + 1) ** 2 != n_ch:
        raise ParameterError(
            f"an AmbiX signal has (N+1)² channels (1, 4, 9, 16, ...), got {n_ch} channels"
        )
    return n


def acn(n: int, m: int) -> int:
    """ACN channel index of order n, degree m: n² + n + m.

    Parameters
    ----------
    n : int
        Order, n >= 0.
    m : int
        Degree, -n <= m <= n.

    Returns
    -------
    int

    Examples
    --------
    >>> acn(0, 0), acn(1, -1), acn(1, 1), acn(3, 0)
    (0, 1, 3, 12)
    """
    return n * n + n + m


def acn_orders(order: int) -> NDArray[np.int64]:
    """Order n of every ACN channel up to ``order``.

    Parameters
    ----------
    order : int
        Ambisonics order N.

    Returns
    -------
    ndarray of int, shape ((N+1)²,)

    Examples
    --------
    >>> acn_orders(2).tolist()
    [0, 1, 1, 1, 2, 2, 2, 2, 2]
    """
    return np.repeat(np.arange(order + 1), 2 * np.arange(order + 1) + 1)


def _unit(directions: NDArray[np.floating]) -> NDArray[np.float64]:
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    nrm = np.linalg.norm(d, axis=1, keepdims=True)
    return d / np.where(nrm > 0, nrm, 1.0)


def sh_gains(order: int, directions: NDArray[np.floating]) -> NDArray[np.float64]:
    """Real SN3D spherical harmonics in ACN order for listener-frame directions.

    Parameters
    ----------
    order : int
        Ambisonics order N (0..MAX_ORDER).
    directions : (M, 3) array
        Directions (forward, left, up); normalised here (a zero vector gives
        W = 1 and 0 elsewhere).

    Returns
    -------
    ndarray, shape ((N+1)², M)
        Encoding gains: row ``acn(n, m)`` is Y_n^m of each direction.

    Raises
    ------
    ParameterError
        A bad order.

    Examples
    --------
    >>> up = sh_gains(2, np.array([[0.0, 0.0, 1.0]]))[:, 0]
    >>> np.round(up, 12).tolist()     # W, then Z = 1 and ACN 6 = P_2(1) = 1
    [1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]
    """
    order = check_order(order)
    d = _unit(directions)
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    out = np.zeros(((order + 1) ** 2, d.shape[0]))
    # (x + iy)^m = cos^m(el) e^{i m az}; q[n] = P_n^m(z) / (1 - z²)^{m/2}
    xy_m = np.ones(d.shape[0], dtype=np.complex128)
    for m in range(order + 1):
        if m > 0:
            xy_m = xy_m * (x + 1j * y)
        dfact = math.prod(range(1, 2 * m, 2))  # (2m - 1)!!
        q_prev = np.zeros_like(z)
        q = np.full_like(z, float(dfact))  # P_m^m / (1 - z²)^{m/2}
        for n in range(m, order + 1):
            if n == m + 1:
                q_prev, q = q, z * (2 * m + 1) * q
            elif n > m + 1:
                q_prev, q = q, ((2 * n - 1) * z * q - (n + m - 1) * q_prev) / (n - m)
            norm = math.sqrt(
                (1.0 if m == 0 else 2.0) * math.factorial(n - m) / math.factorial(n + m)
            )
            out[acn(n, m)] = norm * q * xy_m.real
            if m > 0:
                out[acn(n, -m)] = norm * q * xy_m.imag
    zero = ~np.any(d != 0.0, axis=1)  # no direction: omnidirectional (W only)
    out[1:, zero] = 0.0
    return out


def encode(
    signal: NDArray[np.floating], order: int, directions: NDArray[np.floating]
) -> NDArray[np.float64]:
    """Encode a mono signal arriving from a direction as AmbiX (a plane wave).

    Parameters
    ----------
    signal : array_like, shape (n,)
        Pressure, Pa.
    order : int
        Ambisonics order N.
    directions : array_like, shape (3,) or (n, 3)
        Listener-frame direction (forward, left, up) the sound comes from,
        one for all samples or one per sample.

    Returns
    -------
    ndarray, shape ((N+1)², n)

    Raises
    ------
    ParameterError
        A bad order, or a number of directions that is neither 1 nor n.

    Examples
    --------
    >>> b = encode(np.array([1.0, -0.5]), 1, np.array([1.0, 0.0, 0.0]))   # from the front
    >>> b.tolist()   # W, Y, Z, X
    [[1.0, -0.5], [0.0, -0.0], [0.0, -0.0], [1.0, -0.5]]
    """
    s = np.asarray(signal, dtype=np.float64).reshape(-1)
    d = np.asarray(directions, dtype=np.float64)
    g = sh_gains(order, d)
    if g.shape[1] == 1:
        return g * s[None, :]
    if g.shape[1] != s.size:
        raise ParameterError(
            f"encode: {g.shape[1]} directions for {s.size} samples; give one direction "
            f"or one per sample"
        )
    return g * s[None, :]


def maxre_weights(order: int) -> NDArray[np.float64]:
    """Per-order max-rE weights a_n = P_n(cos(137.9° / (N + 1.51))) (book §4.7.6).

    Parameters
    ----------
    order : int
        Ambisonics order N.

    Returns
    -------
    ndarray, shape (N+1,)
        a_0 … a_N (a_0 = 1).

    Raises
    ------
    ParameterError
        A bad order.

    Examples
    --------
    >>> np.round(maxre_weights(1), 4).tolist()
    [1.0, 0.5744]
    """
    from scipy.special import eval_legendre

    order = check_order(order)
    c = math.cos(math.radians(137.9 / (order + 1.51)))
    return np.array([eval_legendre(n, c) for n in range(order + 1)])


def order_weights(order: int, weights: OrderWeights) -> NDArray[np.float64]:
    """Per-channel decoder weights: each channel's a_n.

    Parameters
    ----------
    order : int
        Ambisonics order N.
    weights : {"maxre", "basic"}
        Max-rE weights (:func:`maxre_weights`) or all 1.

    Returns
    -------
    ndarray, shape ((N+1)²,)

    Raises
    ------
    ParameterError
        Unknown weights or a bad order.

    Examples
    --------
    >>> np.round(order_weights(1, "maxre"), 4).tolist()
    [1.0, 0.5744, 0.5744, 0.5744]
    >>> order_weights(1, "basic").tolist()
    [1.0, 1.0, 1.0, 1.0]
    """
    if weights == "maxre":
        a = maxre_weights(order)
    elif weights == "basic":
        a = np.ones(order + 1)
    else:
        raise ParameterError(f"weights must be 'maxre' or 'basic', got {weights!r}")
    return a[acn_orders(order)]


@functools.lru_cache(maxsize=8)
def sphere_quadrature(
    n_el: int = 24, n_az: int = 48
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gauss–Legendre (in sin ϑ) × equiangular (in φ) grid on the unit sphere.

    Parameters
    ----------
    n_el : int
        Gauss–Legendre nodes in sin ϑ (elevations).
    n_az : int
        Equally spaced azimuths.

    Returns
    -------
    directions : ndarray, shape (n_el · n_az, 3)
        Unit vectors.
    weights : ndarray, shape (n_el · n_az,)
        Quadrature weights summing to 4π; exact for every polynomial of degree
        ≤ min(2·n_el − 1, n_az − 1) on the sphere.

    Examples
    --------
    >>> d, w = sphere_quadrature(4, 8)
    >>> d.shape, round(float(w.sum() / np.pi), 12), round(float(w @ d[:, 2] ** 2 / np.pi), 12)
    ((32, 3), 4.0, 1.333333333333)
    """
    zs, wz = np.polynomial.legendre.leggauss(n_el)
    az = 2 * np.pi * (np.arange(n_az) + 0.5) / n_az
    r = np.sqrt(1 - zs**2)
    dirs = np.stack(
        [np.outer(r, np.cos(az)), np.outer(r, np.sin(az)), np.repeat(zs[:, None], n_az, axis=1)],
        axis=-1,
    ).reshape(-1, 3)
    w = np.repeat(wz * (2 * np.pi / n_az), n_az)
    return dirs, w


def _energy_normalise(dec: NDArray[np.float64], order: int) -> NDArray[np.float64]:
    dirs, w = sphere_quadrature()
    g = dec @ sh_gains(order, dirs)
    mean_e = float(np.sum(w * np.sum(g**2, axis=0)) / (4 * np.pi))
    if not mean_e > 0:
        raise ParameterError("Ambisonic decoder has no output energy")
    return dec / math.sqrt(mean_e)


def _decoder_allrad(order: int, layout: Layout, a: NDArray[np.float64]) -> NDArray[np.float64]:
    from auralize.spatial.layouts import vbap3d_gains

    dirs, w = sphere_quadrature()
    y = sh_gains(order, dirs)  # (K, L)
    v = vbap3d_gains(layout, dirs)  # (S, L)
    n_of = acn_orders(order)
    sampling = (w[:, None] * y.T) * ((2 * n_of + 1) / (4 * np.pi) * a)[None, :]  # (L, K)
    return v @ sampling


def _decoder_mode_matching(
    order: int, layout: Layout, a: NDArray[np.float64]
) -> NDArray[np.float64]:
    chans = layout.panned_channels
    k = n_channels(order)
    if chans.size < k:
        raise ParameterError(
            f"mode-matching decoding of order {order} needs at least {k} speakers, layout "
            f"{layout.name!r} has {chans.size}; use method='allrad'"
        )
    y = sh_gains(order, layout.directions()[chans])  # (K, S)
    n_of = acn_orders(order)
    y_n3d = y * np.sqrt(2 * n_of + 1)[:, None]
    cond = np.linalg.cond(y_n3d)
    if not cond < 1e3:
        raise ParameterError(
            f"layout {layout.name!r} is too irregular for mode-matching decoding of order {order} "
            f"(condition number {cond:.3g}); use method='allrad'"
        )
    dec = np.zeros((layout.n_channels, k))
    dec[chans] = np.linalg.pinv(y) * a[None, :]
    return dec


@functools.lru_cache(maxsize=32)
def _decoder_cached(
    order: int, layout: Layout, method: DecoderMethod, weights: OrderWeights
) -> NDArray[np.float64]:
    a = order_weights(order, weights)
    if layout.meta.get("ambisonic") or layout.meta.get("binaural"):
        raise ParameterError(
            f"cannot decode Ambisonics to {layout.name!r}: decode to a loudspeaker layout "
            f"(binaural output uses auralize.spatial.hrtf.binaural_from_ambisonics)"
        )
    if layout.n_channels == 1 or layout.panned_channels.size == 1:
        dec = np.zeros((layout.n_channels, n_channels(order)))
        dec[layout.panned_channels if layout.panned_channels.size else 0, 0] = 1.0  # W only
        return dec
    if method == "allrad":
        dec = _decoder_allrad(order, layout, a)
    elif method == "mode-matching":
        dec = _decoder_mode_matching(order, layout, a)
    else:
        raise ParameterError(f"method must be 'allrad' or 'mode-matching', got {method!r}")
    dec = _energy_normalise(dec, order)
    dec.setflags(write=False)
    return dec


def decoder_matrix(
    order: int,
    layout: str | Layout,
    *,
    method: DecoderMethod = "allrad",
    weights: OrderWeights = "maxre",
) -> NDArray[np.float64]:
    """Decoding matrix ``(layout.n_channels, (N+1)²)`` from AmbiX to a speaker layout.

    Parameters
    ----------
    order : int
        Ambisonics order N of the signal.
    layout : str or Layout
        Any loudspeaker layout (:func:`auralize.spatial.layouts.get_layout`); LFE
        channels get nothing.
    method : {"allrad", "mode-matching"}
        See the module docstring.
    weights : {"maxre", "basic"}
        Per-order weights (:func:`order_weights`).

    Returns
    -------
    ndarray, shape (layout.n_channels, (N+1)²)
        Read-only; ``D @ audio`` decodes ``audio ((N+1)², n)``.  Scaled so that
        the loudspeaker energy averaged over all directions is 1.

    Raises
    ------
    ParameterError
        A bad order, method or weights; an AmbiX or binaural layout; a layout
        too small or irregular for mode matching.

    Examples
    --------
    >>> D = decoder_matrix(1, "ring8")
    >>> D.shape, D.flags.writeable
    ((8, 4), False)
    >>> g = D @ sh_gains(1, np.array([[0.0, 1.0, 0.0]]))[:, 0]   # a source on the left
    >>> int(np.argmax(g))                                          # speaker 2 (90°)
    2
    """
    from auralize.spatial.layouts import get_layout

    return _decoder_cached(check_order(order), get_layout(layout), method, weights)


def decode_ambisonics(
    audio: NDArray[np.floating],
    order: int,
    layout: str | Layout,
    *,
    method: DecoderMethod = "allrad",
    weights: OrderWeights = "maxre",
) -> NDArray[np.float64]:
    """Decode an AmbiX signal to speaker feeds (:func:`decoder_matrix`).

    Parameters
    ----------
    audio : array_like, shape ((N+1)², n)
        AmbiX signal (ACN, SN3D), Pa.
    order : int
        Its order N.
    layout : str or Layout
        A loudspeaker layout.
    method : {"allrad", "mode-matching"}
        See :func:`decoder_matrix`.
    weights : {"maxre", "basic"}
        See :func:`decoder_matrix`.

    Returns
    -------
    ndarray, shape (layout.n_channels, n)
        Speaker feeds.

    Raises
    ------
    ParameterError
        ``audio`` of another shape; see :func:`decoder_matrix`.

    Examples
    --------
    >>> b = encode(np.ones(3), 1, np.array([-1.0, 0.0, 0.0]))   # from behind
    >>> feeds = decode_ambisonics(b, 1, "ring8")
    >>> feeds.shape, int(np.argmax(feeds[:, 0]))                  # speaker 4 (180°)
    ((8, 3), 4)
    """
    a = np.asarray(audio, dtype=np.float64)
    order = check_order(order)
    if a.ndim != 2 or a.shape[0] != n_channels(order):
        raise ParameterError(
            f"an order-{order} AmbiX signal has shape ({n_channels(order)}, n), got {a.shape}"
        )
    return decoder_matrix(order, layout, method=method, weights=weights) @ a


def energy_vector(
    gains: NDArray[np.floating], directions: NDArray[np.floating]
) -> NDArray[np.float64]:
    """Gerzon's energy vector rE = Σ g_s² u_s / Σ g_s² (book §2.2.3).

    Parameters
    ----------
    gains : array_like, shape (S, M)
        Speaker gains of M sources.
    directions : array_like, shape (S, 3)
        Unit speaker directions.

    Returns
    -------
    ndarray, shape (M, 3)
        Its direction is the perceived direction, its length ≤ 1 the spread
        (1 = a single speaker).

    Examples
    --------
    >>> dirs = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    >>> energy_vector(np.array([[1.0, 1.0], [0.0, 1.0]]), dirs).tolist()
    [[1.0, 0.0, 0.0], [0.5, 0.5, 0.0]]
    """
    g2 = np.asarray(gains, dtype=np.float64) ** 2
    return (g2.T @ np.asarray(directions, dtype=np.float64)) / np.sum(g2, axis=0)[:, None]
