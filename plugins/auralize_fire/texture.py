"""Synchronised sound texture synthesis (paper 001 §5, Eqs. 14–17, Fig. 6).

Gaussian pyramids (Burt & Adelson 5-tap REDUCE) G_S of the low-frequency
input p_S and G_T of a training clip p_T, level 1 = full rate, level L =
coarsest.  G_S(L) keeps p_S; levels L-1 … 1 are synthesised coarse to fine,
window by window: window i of level ℓ has centre c_i = i h and samples
Ω_i = [c_i - h, c_i + h]; its feature vector holds

* the already synthesised samples of G_S(ℓ) just before the window,
  [c_i - 2 h h_f, c_i - h] (Eq. 15), and
* the samples of G_S(ℓ+1) in [c_i/2 - h h_f, c_i/2 + h h_f] (Eq. 16,
  linear interpolation at non-integral positions).

With h = 4, h_f = 3 this is 21 + 25 = 46 dimensions, the number the paper
states.  (Eq. 15 as printed, [c_i - h h_f, c_i - h], would give 9 + 25 = 34;
the fine range spanning the same time as the coarse one, 2 h h_f fine
samples, reproduces the 46.)  The nearest training feature in a kd-tree per
level (D_ℓ, built from G_T) gives the window p_new, added with the hat
W_i[n] = h - |n - c_i| (normalised by h so overlapping hats sum to one).

The search is (1+ε)-approximate (ε = 1 as the paper's ANN queries; ε = 0 is
exact).  Features are rotated onto their principal axes before building the
tree: a rotation keeps every distance, so the (1+ε) guarantee is unchanged,
but the kd-tree's splits then follow the directions of largest variance and
queries are several times faster.

Dynamic range matching (§5.3, Eq. 17): at level L-1 the coarse part of each
feature, taken from G_S(L), is scaled by r = F_T⁻¹(F_S(p_abs,avg)) / p_abs,avg
with F_S, F_T the CDFs of |G_S(L)| and |G_T(L)|.

Feature weighting.  §5.1 asks for "the low-frequency temporal
structure of p_S": the only carrier of p_S is G_S(L), which reaches the
output solely through the Eq. 16 part of the features — at level L-1
directly, below it through the synthesised level ℓ+1.  The paper names the
46 samples but no metric.  With the plain Euclidean distance (w_c = 1) the
21 Eq. 15 samples (continuity with the already synthesised, training-derived
past) outweigh the constraint: on the authors' candle input with the
procedural training clip the 180 Hz low-passed output correlates with the
input at only 0.69–0.74 (six training seeds), and at level L-1 even an exact
search leaves ~60 % of the Eq. 16 energy unmatched.  Scaling the Eq. 16
samples by w_c = 3 (training and query features alike, so the search is
still a (1+ε)-approximate nearest neighbour search, in the weighted space)
gives 0.80–0.83 for the same six seeds and 0.84–0.88 on the five real
``fire-lowfreq`` inputs measured against the Eq. 17-mapped input
(:func:`range_matching_gain`); w_c = 2 is nearly as good, w_c >= 4 adds
nothing and slows the search.  ``coarse_weight=1`` is the unweighted metric.

What "keeps the input's envelope" can mean here.  The output's low band
follows r(t)·p_S, not p_S: Eq. 17 maps p_S's amplitude distribution onto the
training clip's, a monotone but, for inputs with a wider dynamic range than
p_T, strongly compressive map (flame_jet: a 0.8 Pa transient at 3.3 s among
~0.03 Pa, and dropouts; its 5–95 % level range of ~3000 becomes ~30).  The
Pearson correlation of the low-passed output with the *raw* p_S therefore
stays below 0.8 on such inputs (0.60 on flame_jet) however well the synthesis
follows its constraint, while against r(t)·p_S it is >= 0.84.  On inputs
whose r is nearly constant (the 1 s candle excerpt of the tests, r within
±5 %) the two measures coincide.  The high band is the training clip's
texture (§5.1, "the fiery details of p_T"): crackles land where the search
puts them, so an envelope of the full-band output depends on the training
clip (0.68–0.83 over six training seeds on that 1 s excerpt) and is not a
measure of the constraint.

Units.  Eq. 17 maps p_S's amplitudes onto p_T's, so
:func:`texture_synthesize` returns the training clip's units and level (the
paper's texture).  With range matching the output does not depend on p_S's
scale at all (r scales as 1/p_S: r(a p_S) · a p_S = r(p_S) · p_S).  To
*extend* p_S, :func:`texture_extend` inverts that map by one rescale: the
output times g = RMS(LP(p_S)) / RMS(LP(y)), LP the zero-phase low-pass at
f_cut (the band where y follows r(t) · p_S), so the output's band below
f_cut has the input's RMS and the whole output is in p_S's units, linear in
p_S's level.  One gain, not 1/r(t) sample by sample: r is undefined where
p_S is silent and its inverse would rescale the training texture's own
crackles window by window; on inputs with a nearly constant r (the candle)
the two nearly coincide.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy import signal as sps
from scipy.spatial import cKDTree

from auralize.errors import DataError, ParameterError
from auralize_fire import _kernels
from auralize_fire.bandwidth import check_signal

#: points per kd-tree leaf (both engines)
KD_LEAFSIZE = 8

#: Burt & Adelson's generating kernel (a = 0.375)
BURT_KERNEL = np.array([1.0, 4.0, 6.0, 4.0, 1.0]) / 16.0


def gaussian_pyramid(x: NDArray[np.floating], levels: int) -> list[NDArray[np.float64]]:
    """1-D Gaussian pyramid [G(1) = x, G(2), …, G(L)] (REDUCE: 5-tap blur, keep every 2nd).

    Parameters
    ----------
    x : (n,) signal.
    levels : L >= 1.

    Returns
    -------
    list of L arrays; level ℓ has ⌈n / 2^(ℓ-1)⌉ samples.
    """
    out = [np.asarray(x, dtype=np.float64)]
    for _ in range(levels - 1):
        out.append(ndimage.convolve1d(out[-1], BURT_KERNEL, mode="reflect")[::2])
    return out


@dataclass(frozen=True)
class TextureParams:
    """§5 parameters (paper: L = 6, h = 4, h_f = 3, ε = 1).

    ``coarse_weight`` w_c multiplies the Eq. 16 (coarser-level) part of every
    feature, training and query alike; the paper does not state a metric, and
    w_c = 1 is the plain Euclidean distance over the 46 samples.  See the
    module docstring for why the default is 3.
    """

    levels: int = 6
    h: int = 4
    h_f: int = 3
    eps: float = 1.0
    coarse_weight: float = 3.0

    def check(self) -> None:
        if int(self.levels) != self.levels or not 2 <= self.levels <= 12:
            raise ParameterError(f"levels must be an integer in 2..12, got {self.levels!r}")
        if int(self.h) != self.h or self.h < 1:
            raise ParameterError(f"h (window half-width) must be an integer >= 1, got {self.h!r}")
        if int(self.h_f) != self.h_f or self.h_f < 1:
            raise ParameterError(f"h_f must be an integer >= 1, got {self.h_f!r}")
        if not (self.eps >= 0 and np.isfinite(self.eps)):
            raise ParameterError(f"eps must be a finite number >= 0, got {self.eps!r}")
        if not (self.coarse_weight > 0 and np.isfinite(self.coarse_weight)):
            raise ParameterError(
                f"coarse_weight must be a finite number > 0, got {self.coarse_weight!r}"
            )

    @property
    def n_fine(self) -> int:
        """Feature samples from the level being synthesised, [c - 2 h h_f, c - h]."""
        return 2 * self.h * self.h_f - self.h + 1

    @property
    def n_coarse(self) -> int:
        """Feature samples from the next coarser level, [c/2 - h h_f, c/2 + h h_f]."""
        return 2 * self.h * self.h_f + 1

    @property
    def dim(self) -> int:
        return self.n_fine + self.n_coarse

    def min_training(self) -> int:
        """Training samples needed so that every level has at least one full window."""
        h, hf = self.h, self.h_f
        # level ℓ needs c - 2 h h_f >= 0, c + h < N_ℓ and c/2 + h h_f < N_{ℓ+1}
        need = 2 * h * hf + h + 1
        return need * 2 ** (self.levels - 2) + 2 ** (self.levels - 1)


def _coarse_part(
    coarse: NDArray[np.float64], centres: NDArray[np.float64], half: int
) -> NDArray[np.float64]:
    """Linearly interpolated coarse samples at centres/2 + k, k = -half … half (clamped)."""
    pos = centres[:, None] / 2.0 + np.arange(-half, half + 1)
    pos = np.clip(pos, 0, coarse.size - 1)
    i0 = np.minimum(np.floor(pos).astype(np.int64), coarse.size - 2)
    f = pos - i0
    return coarse[i0] * (1 - f) + coarse[i0 + 1] * f


@dataclass
class _Dictionary:
    features: NDArray[np.float64]  # (n, dim) rotated features f^i_T,ℓ
    rot: NDArray[np.float64]  # (dim, dim) rows = principal axes
    mean: NDArray[np.float64]
    values: NDArray[np.float64]  # (n, 2h + 1) windows p^i_T,ℓ
    engine: str = "numba"

    def __post_init__(self) -> None:
        if self.engine == "numba":
            self.tree = _kernels.kd_build(self.features, KD_LEAFSIZE)
        else:
            self.tree = cKDTree(self.features, leafsize=KD_LEAFSIZE, balanced_tree=False)

    @property
    def size(self) -> int:
        """|D_ℓ|, the number of feature-window pairs."""
        return int(self.values.shape[0])


def build_dictionary(
    fine: NDArray[np.float64],
    coarse: NDArray[np.float64],
    prm: TextureParams,
    engine: str = "numba",
) -> _Dictionary:
    """D_ℓ: features and windows of one training level (§5.2)."""
    h, hf = prm.h, prm.h_f
    i_lo = -(-2 * h * hf // h)
    i_hi_f = (fine.size - 1 - h) // h
    i_hi_c = int(np.floor((2 * (coarse.size - 1 - h * hf)) / h))
    idx = np.arange(i_lo, min(i_hi_f, i_hi_c) + 1)
    if idx.size < 1:
        raise DataError("training clip is too short for the pyramid: a level has no full window")
    c = idx * h
    past = np.arange(-2 * h * hf, -h + 1)
    cpart = prm.coarse_weight * _coarse_part(coarse, c.astype(float), h * hf)
    feat = np.concatenate([fine[c[:, None] + past], cpart], axis=1)
    vals = fine[c[:, None] + np.arange(-h, h + 1)]
    mean = feat.mean(axis=0)
    sub = feat[:: max(1, feat.shape[0] // 20000)] - mean
    _, _, vt = np.linalg.svd(sub, full_matrices=False)
    if vt.shape[0] < feat.shape[1]:  # fewer samples than dimensions: complete the basis
        q, _ = np.linalg.qr(np.concatenate([vt, np.eye(feat.shape[1])]).T)
        vt = q.T[: feat.shape[1]]
    return _Dictionary((feat - mean) @ vt.T, vt, mean, vals, engine)


def _range_matcher(gs_top: NDArray[np.float64], gt_top: NDArray[np.float64]):  # type: ignore[no-untyped-def]
    """r(p_abs,avg) of Eq. 17 from the CDFs of |G_S(L)| and |G_T(L)|."""
    s_sorted = np.sort(np.abs(gs_top))
    t_abs = np.abs(gt_top)

    def ratio(p_avg: NDArray[np.float64]) -> NDArray[np.float64]:
        q = np.searchsorted(s_sorted, p_avg, side="right") / s_sorted.size  # F_S
        target = np.quantile(t_abs, np.clip(q, 0.0, 1.0))  # F_T⁻¹
        return np.where(p_avg > 0, target / np.where(p_avg > 0, p_avg, 1.0), 1.0)

    return ratio


def _window_ratios(
    gs: list[NDArray[np.float64]], gt: list[NDArray[np.float64]], prm: TextureParams
) -> NDArray[np.float64]:
    """r of Eq. 17 for every window of level L-1 (p_abs,avg over its Eq. 16 samples of G_S(L))."""
    L = prm.levels
    n_win = -(-(gs[L - 2].size - 1) // prm.h) + 1
    c = np.arange(n_win) * prm.h
    p_avg = np.mean(np.abs(_coarse_part(gs[L - 1], c.astype(float), prm.h * prm.h_f)), axis=1)
    return _range_matcher(gs[L - 1], gt[L - 1])(p_avg)


def range_matching_gain(
    p_s: NDArray[np.floating],
    p_t: NDArray[np.floating],
    *,
    levels: int = 6,
    h: int = 4,
    h_f: int = 3,
) -> NDArray[np.float64]:
    """The §5.3 gain r (Eq. 17) per input sample, linearly interpolated between windows.

    r scales G_S(L) where it enters the level-(L-1) features, so r(t) · p_S is
    the constraint the synthesis follows: the output's low band is p_S's low
    band with its amplitude distribution mapped onto the training clip's
    (F_T⁻¹ ∘ F_S, monotone but not linear when p_S has a wider dynamic range
    than p_T).  Used to measure how well the output follows that constraint.

    Returns
    -------
    (n,) gain, dimensionless.
    """
    prm = TextureParams(levels, h, h_f)
    prm.check()
    xs = check_signal(p_s, "input")
    xt = check_signal(p_t, "training")
    gs = gaussian_pyramid(xs, prm.levels)
    gt = gaussian_pyramid(xt, prm.levels)
    r = _window_ratios(gs, gt, prm)
    centres = np.arange(r.size) * prm.h * 2.0 ** (prm.levels - 2)  # level-(L-1) index -> input
    return np.interp(np.arange(xs.size), centres, r)


def synthesize_level(
    dic: _Dictionary,
    coarse: NDArray[np.float64],
    n: int,
    prm: TextureParams,
    *,
    scale: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Synthesise one signal level of ``n`` samples window by window (Fig. 6).

    ``scale`` (per window) multiplies the coarse feature part (Eq. 17 at level L-1).
    """
    h, hf = prm.h, prm.h_f
    n_win = -(-(n - 1) // h) + 1
    c = np.arange(n_win) * h
    cpart = prm.coarse_weight * _coarse_part(coarse, c.astype(float), h * hf)
    if scale is not None:
        cpart = cpart * scale[:, None]
    nf = prm.n_fine
    rot_f = np.ascontiguousarray(dic.rot[:, :nf])
    # rotated feature = rot_f @ past + (rot_c @ coarse - rot @ mean), second part precomputed
    base = np.ascontiguousarray(cpart @ dic.rot[:, nf:].T - dic.rot @ dic.mean)
    if dic.engine == "numba":
        return _kernels.synth_level(*dic.tree, dic.values, rot_f, base, h, hf, n, float(prm.eps))
    off = 2 * h * hf  # zeros before the signal start
    out = np.zeros(off + n_win * h + h + 1)
    hat = (h - np.abs(np.arange(-h, h + 1))) / h
    query = dic.tree.query
    vals = dic.values
    eps = float(prm.eps)
    for i in range(n_win):
        s = off + i * h  # = c_i + off
        q = rot_f @ out[s - 2 * h * hf : s - h + 1] + base[i]
        _, j = query(q, k=1, eps=eps)
        out[s - h : s + h + 1] += hat * vals[j]
    return out[off : off + n]


def texture_synthesize(
    p_s: NDArray[np.floating],
    p_t: NDArray[np.floating],
    *,
    levels: int = 6,
    h: int = 4,
    h_f: int = 3,
    eps: float = 1.0,
    range_matching: bool = True,
    coarse_weight: float = 3.0,
    engine: str = "numba",
    progress: Callable[[str], None] | None = None,
) -> NDArray[np.float64]:
    """Fire-sound details from a training clip, synchronised with p_S (paper 001 §5).

    Parameters
    ----------
    p_s : (n,) low-frequency input (e.g. §3 output after the 30 Hz high-pass).
    p_t : (m,) training clip at the same sample rate as ``p_s``.
    levels : pyramid levels L (paper: 6).
    h, h_f : window half-width and feature half-width multiplier (paper: 4, 3).
    eps : approximate nearest-neighbour tolerance ε (paper: 1; 0 = exact).
    range_matching : apply the dynamic range matching of §5.3 (Eq. 17).
    coarse_weight : weight w_c of the Eq. 16 feature samples (default 3;
        1 = unweighted Euclidean distance, see the module docstring).
    engine : ``"numba"`` (fused synthesis loop with its own kd-tree) or
        ``"scipy"`` (Python loop over ``cKDTree.query``; same search rule).
        The method has no random step: same inputs, same output.
    progress : called with a one-line message (``"level 3: 66120 samples"``;
        level 1 is the full rate) after each synthesised level: ``levels - 1``
        calls, coarse to fine, each level having about twice the samples, and
        so twice the work, of the one before.  E.g. the callback of
        :func:`auralize.runtime.progress.progress_callback`.

    Returns
    -------
    (n,) synthesised signal, level 1 of G_S, in the training clip's units.

    Examples
    --------
    >>> from auralize_fire.clips import fire_training_clip
    >>> rate = 8000
    >>> t = np.arange(2000) / rate
    >>> low = np.sin(2 * np.pi * 3 * t) * np.sin(2 * np.pi * 40 * t)
    >>> out = texture_synthesize(low, fire_training_clip(0.5, rate, seed=0), levels=3)
    >>> out.shape
    (2000,)
    """
    prm = TextureParams(levels, h, h_f, float(eps), float(coarse_weight))
    prm.check()
    if engine not in ("numba", "scipy"):
        raise ParameterError(f"engine must be 'numba' or 'scipy', got {engine!r}")
    xs = check_signal(p_s, "input")
    xt = check_signal(p_t, "training")
    need = prm.min_training()
    if xt.size < need:
        raise DataError(
            f"training clip has {xt.size} samples; a {prm.levels}-level pyramid with "
            f"h={prm.h}, h_f={prm.h_f} needs at least {need}"
        )
    gs = gaussian_pyramid(xs, prm.levels)
    gt = gaussian_pyramid(xt, prm.levels)
    L = prm.levels
    current = gs[L - 1]
    # The dictionaries D_ℓ depend on the training pyramid only: one worker
    # builds them, finest last, while this thread synthesises the coarser
    # levels (the numba kernels release the GIL).  Same result as building
    # each one just before it is used.
    with ThreadPoolExecutor(max_workers=1) as pool:
        dics = [
            pool.submit(build_dictionary, gt[lev], gt[lev + 1], prm, engine)
            for lev in range(L - 2, -1, -1)
        ]
        for k, lev in enumerate(range(L - 2, -1, -1)):  # 0-based: level lev+1 of the paper
            scale = _window_ratios(gs, gt, prm) if lev == L - 2 and range_matching else None
            current = synthesize_level(dics[k].result(), current, gs[lev].size, prm, scale=scale)
            dics[k] = None  # type: ignore[call-overload]  # free D_ℓ once used
            if progress is not None:
                progress(f"level {lev + 1}: {current.size} samples")
    return current


def input_level_gain(
    p_s: NDArray[np.floating], y: NDArray[np.floating], rate: float, f_cut: float = 180.0
) -> float:
    """The rescale g that puts a texture ``y`` of ``p_s`` back in ``p_s``'s units.

    g = RMS(LP(p_S)) / RMS(LP(y)), LP a 4th-order Butterworth low-pass at
    ``f_cut`` run forwards and backwards (zero phase, 8th-order slope): the
    inverse of Eq. 17's range matching as one gain, matching the RMS of the
    band in which the synthesis follows the input (see the module docstring).

    Parameters
    ----------
    p_s : (n,) low-frequency input.
    y : (n,) :func:`texture_synthesize` of ``p_s``.
    rate : Hz, the sample rate of both.
    f_cut : Hz, the top of the matched band (default 180 Hz, §4's f_cut).

    Returns
    -------
    g, in p_S's units per training-clip unit.
    """
    x = np.asarray(p_s, dtype=np.float64)
    z = np.asarray(y, dtype=np.float64)
    if x.shape != z.shape:
        raise ParameterError(f"input and texture differ in shape: {x.shape} and {z.shape}")
    if not 0 < f_cut < rate / 2:
        raise ParameterError(f"f_cut must be in (0, {rate / 2:g}) Hz, got {f_cut!r}")
    sos = sps.butter(4, f_cut, btype="lowpass", fs=rate, output="sos")
    padlen = max(min(x.size - 1, 3 * int(rate / f_cut)), 0)
    rms_x = float(np.sqrt(np.mean(sps.sosfiltfilt(sos, x, padlen=padlen) ** 2)))
    rms_y = float(np.sqrt(np.mean(sps.sosfiltfilt(sos, z, padlen=padlen) ** 2)))
    if not (rms_x > 0 and rms_y > 0):
        raise DataError(
            f"no sound below {f_cut:g} Hz in the input or the texture (RMS {rms_x:.3g}, "
            f"{rms_y:.3g}): the texture's level cannot be matched to the input's"
        )
    return rms_x / rms_y


def texture_extend(
    p_s: NDArray[np.floating],
    p_t: NDArray[np.floating],
    rate: float,
    *,
    f_cut: float = 180.0,
    **options: Any,
) -> NDArray[np.float64]:
    """§5 texture synthesis as an extension of p_S, in p_S's units and at its level.

    :func:`texture_synthesize` (Eq. 17 range matching on) times
    :func:`input_level_gain`: the output's band below ``f_cut`` has the RMS
    of p_S's, so switching from :func:`auralize_fire.bandwidth.bandwidth_extend`
    (which keeps p_S's units) keeps the flame's level, and the output is
    linear in p_S's scale.

    Parameters
    ----------
    p_s : (n,) low-frequency input (any units, e.g. Pa at 1 m).
    p_t : (m,) training clip at ``rate``.
    rate : Hz, the sample rate of both.
    f_cut : Hz, the top of the band whose RMS is matched (default 180).
    **options : :func:`texture_synthesize`'s keyword options (``levels``,
        ``eps``, ``coarse_weight``, ``engine``, ``progress``, ...).

    Returns
    -------
    (n,) synthesised signal in p_S's units.

    Examples
    --------
    >>> from auralize_fire.clips import fire_training_clip
    >>> rate = 8000
    >>> t = np.arange(2000) / rate
    >>> low = np.sin(2 * np.pi * 3 * t) * np.sin(2 * np.pi * 40 * t)
    >>> clip = fire_training_clip(0.5, rate, seed=0)
    >>> a = texture_extend(low, clip, rate, levels=3)
    >>> b = texture_extend(2 * low, clip, rate, levels=3)
    >>> bool(np.allclose(b, 2 * a))
    True
    """
    y = texture_synthesize(p_s, p_t, **options)
    return y * input_level_gain(p_s, y, rate, f_cut)
