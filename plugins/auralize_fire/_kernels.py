"""numba kernels of the flame-front step (paper 001 §3.2).

The separable B-spline refinement and the 64-tap gradient evaluation at
triangle centroids are 4-tap stencils over millions of points; in numpy they
need one full-size temporary per tap and per axis (≈10× slower, see
``auralize bench``), so they are fused loops here.  Both functions mirror the
pure-numpy reference implementations in :mod:`auralize_fire.flamefront`,
which the tests compare against.
"""

from __future__ import annotations

import numba
import numpy as np

from auralize.runtime.jit import configure as _configure_numba

_configure_numba()  # cache folder, OMP wait policy, compile notice


@numba.njit(cache=True, inline="always")
def _phi(t: float) -> float:
    a = abs(t)
    if a <= 1.0:
        return (4.0 - 6.0 * a * a + 3.0 * a * a * a) / 6.0
    if a <= 2.0:
        b = 2.0 - a
        return b * b * b / 6.0
    return 0.0


@numba.njit(cache=True, inline="always")
def _dphi(t: float) -> float:
    a = abs(t)
    s = 1.0 if t > 0 else (-1.0 if t < 0 else 0.0)
    if a <= 1.0:
        return s * (-12.0 * a + 9.0 * a * a) / 6.0
    if a <= 2.0:
        b = 2.0 - a
        return -s * 3.0 * b * b / 6.0
    return 0.0


@numba.njit(cache=True)
def refine_axis(a: np.ndarray, axis: int, r: int, pad: int) -> np.ndarray:  # pragma: no cover
    """B-spline sum along ``axis`` of ``a`` (padded there by ``pad``), ``r`` points per cell."""
    shp = a.shape
    n = shp[axis] - 2 * pad
    nf = (n - 1) * r + 1
    w = np.empty((r, 4))
    for p in range(r):
        for k in range(4):
            w[p, k] = _phi(p / r - (k - 1))
    if axis == 0:
        out = np.zeros((nf, shp[1], shp[2]))
    elif axis == 1:
        out = np.zeros((shp[0], nf, shp[2]))
    else:
        out = np.zeros((shp[0], shp[1], nf))
    for j in range(nf):
        i = min(j // r, n - 1)
        p = j - i * r
        for k in range(4):
            wk = w[p, k]
            if wk == 0.0:
                continue
            src = i + k - 1 + pad
            if axis == 0:
                for y in range(shp[1]):
                    for x in range(shp[2]):
                        out[j, y, x] += wk * a[src, y, x]
            elif axis == 1:
                for z in range(shp[0]):
                    for x in range(shp[2]):
                        out[z, j, x] += wk * a[z, src, x]
            else:
                for z in range(shp[0]):
                    for y in range(shp[1]):
                        out[z, y, j] += wk * a[z, y, src]
    return out


@numba.njit(cache=True)
def eval_points(
    f: np.ndarray, pts: np.ndarray, n3: np.ndarray, pad: int, gradient: bool
) -> np.ndarray:  # pragma: no cover
    """B̃ or ∇B̃ (per index unit) at index points (x, y, z); ``f`` padded by ``pad`` per side."""
    npt = pts.shape[0]
    out = np.zeros((npt, 3 if gradient else 1))
    wx = np.empty(4)
    wy = np.empty(4)
    wz = np.empty(4)
    dx = np.empty(4)
    dy = np.empty(4)
    dz = np.empty(4)
    for m in range(npt):
        ix = min(max(int(np.floor(pts[m, 0])), 0), n3[0] - 2)
        iy = min(max(int(np.floor(pts[m, 1])), 0), n3[1] - 2)
        iz = min(max(int(np.floor(pts[m, 2])), 0), n3[2] - 2)
        fx = pts[m, 0] - ix
        fy = pts[m, 1] - iy
        fz = pts[m, 2] - iz
        for k in range(4):
            wx[k] = _phi(fx - (k - 1))
            wy[k] = _phi(fy - (k - 1))
            wz[k] = _phi(fz - (k - 1))
            dx[k] = _dphi(fx - (k - 1))
            dy[k] = _dphi(fy - (k - 1))
            dz[k] = _dphi(fz - (k - 1))
        gx = 0.0
        gy = 0.0
        gz = 0.0
        for c in range(4):
            zc = iz + c - 1 + pad
            for b in range(4):
                yb = iy + b - 1 + pad
                for a in range(4):
                    v = f[zc, yb, ix + a - 1 + pad]
                    if gradient:
                        gx += v * dx[a] * wy[b] * wz[c]
                        gy += v * wx[a] * dy[b] * wz[c]
                        gz += v * wx[a] * wy[b] * dz[c]
                    else:
                        gx += v * wx[a] * wy[b] * wz[c]
        out[m, 0] = gx
        if gradient:
            out[m, 1] = gy
            out[m, 2] = gz
    return out


# --------------------------------------------------------------------------
# kd-tree with (1+ε)-approximate nearest-neighbour search, and the windowed
# hierarchical synthesis loop of paper 001 §5.2.  The loop is sequential
# (window i's feature holds the output of windows < i), so a Python loop
# around scipy's cKDTree costs ~30 µs of call overhead per window; fused here.
# nogil: texture.py builds the next dictionaries in a worker thread meanwhile.


@numba.njit(cache=True, nogil=True)
def kd_build(data: np.ndarray, leafsize: int):  # type: ignore[no-untyped-def]  # pragma: no cover
    """Build a kd-tree (split on the widest dimension at the median).

    Returns (points in tree order, original index per point, node arrays
    lo, hi, dim, split, left, right); a leaf has left = -1.
    """
    n, d = data.shape
    perm = np.arange(n)
    cap = 4 * (n // max(leafsize, 1) + 1) + 1  # leaves hold >= leafsize / 2 points
    lo = np.empty(cap, np.int64)
    hi = np.empty(cap, np.int64)
    dim = np.zeros(cap, np.int64)
    split = np.zeros(cap)
    left = np.full(cap, -1, np.int64)
    right = np.full(cap, -1, np.int64)
    lo[0], hi[0] = 0, n
    n_nodes = 1
    stack = np.empty(cap, np.int64)
    sp = 0
    stack[sp] = 0
    sp += 1
    while sp > 0:
        sp -= 1
        node = stack[sp]
        a, b = lo[node], hi[node]
        if b - a <= leafsize:
            continue
        best_d, best_s = 0, -1.0
        for k in range(d):
            mn, mx = np.inf, -np.inf
            for t in range(a, b):
                v = data[perm[t], k]
                mn = min(mn, v)
                mx = max(mx, v)
            if mx - mn > best_s:
                best_s, best_d = mx - mn, k
        if best_s <= 0:
            continue  # all points equal: keep as a leaf
        vals = np.empty(b - a)
        for t in range(a, b):
            vals[t - a] = data[perm[t], best_d]
        order = np.argsort(vals)
        seg = perm[a:b].copy()
        for t in range(b - a):
            perm[a + t] = seg[order[t]]
        mid = a + (b - a) // 2
        dim[node] = best_d
        split[node] = data[perm[mid], best_d]
        l_node, r_node = n_nodes, n_nodes + 1
        n_nodes += 2
        lo[l_node], hi[l_node] = a, mid
        lo[r_node], hi[r_node] = mid, b
        left[node], right[node] = l_node, r_node
        stack[sp] = l_node
        stack[sp + 1] = r_node
        sp += 2
    pts = np.empty((n, d))
    for t in range(n):
        pts[t] = data[perm[t]]
    return (
        pts,
        perm,
        lo[:n_nodes].copy(),
        hi[:n_nodes].copy(),
        dim[:n_nodes].copy(),
        split[:n_nodes].copy(),
        left[:n_nodes].copy(),
        right[:n_nodes].copy(),
    )


@numba.njit(cache=True, nogil=True)
def kd_query(
    pts, lo, hi, dim, split, left, right, q, eps2, stack_node, stack_bound, stack_off, cur_off
):  # type: ignore[no-untyped-def]  # pragma: no cover
    """Index (tree order) of a point within (1+ε) of q's nearest neighbour.

    Arya–Mount incremental search: each pending subtree carries the squared
    distance from q to its cell (per-axis offsets updated one split at a
    time) and is skipped when (1+ε)² times that distance is >= the best
    found, since all its points are then at least best/(1+ε) away.
    ``eps2`` = (1+ε)².
    """
    d = pts.shape[1]
    best = np.inf
    best_i = -1
    stack_node[0] = 0
    stack_bound[0] = 0.0
    for k in range(d):
        stack_off[0, k] = 0.0
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack_node[sp]
        rd = stack_bound[sp]
        if rd * eps2 >= best:
            continue
        for k in range(d):
            cur_off[k] = stack_off[sp, k]
        while left[node] >= 0:
            k0 = dim[node]
            diff = q[k0] - split[node]
            if diff < 0:
                near, far = left[node], right[node]
            else:
                near, far = right[node], left[node]
            old = cur_off[k0]
            rd_far = rd - old * old + diff * diff
            if rd_far * eps2 < best:
                stack_node[sp] = far
                stack_bound[sp] = rd_far
                for k in range(d):
                    stack_off[sp, k] = cur_off[k]
                stack_off[sp, k0] = diff
                sp += 1
            node = near
        for t in range(lo[node], hi[node]):
            s = 0.0
            for k in range(d):
                e = pts[t, k] - q[k]
                s += e * e
                if s >= best:
                    break
            if s < best:
                best = s
                best_i = t
    return best_i


@numba.njit(cache=True, nogil=True)
def synth_level(pts, perm, lo, hi, dim, split, left, right, values, rot_f, base, h, hf, n, eps):  # type: ignore[no-untyped-def]  # pragma: no cover
    """Windowed hierarchical synthesis of one level (paper 001 §5.2, Fig. 6).

    Window i: feature = rot_f @ out[c_i - 2 h h_f … c_i - h] + base[i] (the
    rotated coarse part is precomputed), nearest training window added with
    the hat (h - |n - c_i|)/h.  Returns the n synthesised samples.
    """
    n_win = base.shape[0]
    off = 2 * h * hf
    out = np.zeros(off + n_win * h + h + 1)
    nf = rot_f.shape[1]
    dd = rot_f.shape[0]
    q = np.empty(dd)
    hat = np.empty(2 * h + 1)
    for t in range(2 * h + 1):
        hat[t] = (h - abs(t - h)) / h
    depth = 2 * (lo.shape[0] + 1)
    stack_node = np.empty(depth, np.int64)
    stack_bound = np.empty(depth)
    stack_off = np.empty((depth, dd))
    cur_off = np.empty(dd)
    eps2 = (1.0 + eps) ** 2
    for i in range(n_win):
        s = off + i * h
        p0 = s - off
        for r in range(dd):
            acc = base[i, r]
            for t in range(nf):
                acc += rot_f[r, t] * out[p0 + t]
            q[r] = acc
        j = perm[
            kd_query(
                pts,
                lo,
                hi,
                dim,
                split,
                left,
                right,
                q,
                eps2,
                stack_node,
                stack_bound,
                stack_off,
                cur_off,
            )
        ]
        for t in range(2 * h + 1):
            out[s - h + t] += hat[t] * values[j, t]
    return out[off : off + n].copy()
