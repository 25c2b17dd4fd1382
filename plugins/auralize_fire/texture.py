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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree

from auralize.errors import DataError, ParameterError
from auralize_fire import _kernels
from auralize_fire.bandwidth import check_signal

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
    """§5 parameters (paper: L = 6, h = 4, h_f = 3, ε = 1)."""

    levels: int = 6
    h: int = 4
    h_f: int = 3
    eps: float = 1.0

    def check(self) -> None:
        if int(self.levels) != self.levels or not 2 <= self.levels <= 12:
            raise ParameterError(f"levels must be an integer in 2..12, got {self.levels!r}")
        if int(self.h) != self.h or self.h < 1:
            raise ParameterError(f"h (window half-width) must be an integer >= 1, got {self.h!r}")
        if int(self.h_f) != self.h_f or self.h_f < 1:
            raise ParameterError(f"h_f must be an integer >= 1, got {self.h_f!r}")
        if not (self.eps >= 0 and np.isfinite(self.eps)):
            raise ParameterError(f"eps must be a finite number >= 0, got {self.eps!r}")

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


def _coarse_part(coarse: NDArray[np.float64], centres: NDArray[np.float64],
                 half: int) -> NDArray[np.float64]:  # fmt: skip
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
            self.tree = _kernels.kd_build(self.features, 16)
        else:
            self.tree = cKDTree(self.features, leafsize=16, balanced_tree=False)

    @property
    def size(self) -> int:
        """|D_ℓ|, the number of feature-window pairs."""
        return int(self.values.shape[0])


def build_dictionary(fine: NDArray[np.float64], coarse: NDArray[np.float64],
                     prm: TextureParams, engine: str = "numba") -> _Dictionary:  # fmt: skip
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
    feat = np.concatenate([fine[c[:, None] + past], _coarse_part(coarse, c.astype(float), h * hf)],
                          axis=1)  # fmt: skip
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


def synthesize_level(dic: _Dictionary, coarse: NDArray[np.float64], n: int, prm: TextureParams,
                     *, scale: NDArray[np.float64] | None = None) -> NDArray[np.float64]:  # fmt: skip
    """Synthesise one signal level of ``n`` samples window by window (Fig. 6).

    ``scale`` (per window) multiplies the coarse feature part (Eq. 17 at level L-1).
    """
    h, hf = prm.h, prm.h_f
    n_win = -(-(n - 1) // h) + 1
    c = np.arange(n_win) * h
    cpart = _coarse_part(coarse, c.astype(float), h * hf)
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


def texture_synthesize(p_s: NDArray[np.floating], p_t: NDArray[np.floating], *, levels: int = 6,
                       h: int = 4, h_f: int = 3, eps: float = 1.0, range_matching: bool = True,
                       engine: str = "numba") -> NDArray[np.float64]:  # fmt: skip
    """Fire-sound details from a training clip, synchronised with p_S (paper 001 §5).

    Parameters
    ----------
    p_s : (n,) low-frequency input (e.g. §3 output after the 30 Hz high-pass).
    p_t : (m,) training clip at the same sample rate as ``p_s``.
    levels : pyramid levels L (paper: 6).
    h, h_f : window half-width and feature half-width multiplier (paper: 4, 3).
    eps : approximate nearest-neighbour tolerance ε (paper: 1; 0 = exact).
    range_matching : apply the dynamic range matching of §5.3 (Eq. 17).
    engine : ``"numba"`` (fused synthesis loop with its own kd-tree) or
        ``"scipy"`` (Python loop over ``cKDTree.query``; same search rule).
        The method has no random step: same inputs, same output.

    Returns
    -------
    (n,) synthesised signal, level 1 of G_S, in the training clip's units.

    Examples
    --------
    >>> from auralize_fire.clips import fire_training_clip
    >>> rate = 8000
    >>> t = np.arange(rate) / rate
    >>> low = np.sin(2 * np.pi * 3 * t) * np.sin(2 * np.pi * 40 * t)
    >>> out = texture_synthesize(low, fire_training_clip(2.0, rate, seed=0), levels=4)
    >>> out.shape
    (8000,)
    """
    prm = TextureParams(levels, h, h_f, float(eps))
    prm.check()
    if engine not in ("numba", "scipy"):
        raise ParameterError(f"engine must be 'numba' or 'scipy', got {engine!r}")
    xs = check_signal(p_s, "input")
    xt = check_signal(p_t, "training")
    need = prm.min_training()
    if xt.size < need:
        raise DataError(f"training clip has {xt.size} samples; a {prm.levels}-level pyramid with "
                        f"h={prm.h}, h_f={prm.h_f} needs at least {need}")  # fmt: skip
    gs = gaussian_pyramid(xs, prm.levels)
    gt = gaussian_pyramid(xt, prm.levels)
    L = prm.levels
    current = gs[L - 1]
    ratio = _range_matcher(gs[L - 1], gt[L - 1]) if range_matching else None
    for lev in range(L - 2, -1, -1):  # 0-based: level lev+1 of the paper
        dic = build_dictionary(gt[lev], gt[lev + 1], prm, engine)
        scale = None
        if lev == L - 2 and ratio is not None:
            n_win = -(-(gs[lev].size - 1) // prm.h) + 1
            c = np.arange(n_win) * prm.h
            p_avg = np.mean(np.abs(_coarse_part(current, c.astype(float), prm.h * prm.h_f)), axis=1)
            scale = ratio(p_avg)
        current = synthesize_level(dic, current, gs[lev].size, prm, scale=scale)
    return current
