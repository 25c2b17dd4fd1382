"""Discharge patterns: stochastic leader growth (paper 002 §4.1, Eq. 2) and CSV paths.

A discharge is a tree of nodes rooted on the negative charge; every non-root
node and its parent form one segment (a line source of half-length l for the
sound, §4.2.2).  The *main channel* is the path from the root to the node that
reached the positive charge: the return stroke and the later dart leaders
follow it (§3.1), side branches are lit by the first stroke only.

Growth (§4.1): from each active tip, n candidate points are drawn at distance
2l within the cone of apex angle ρ around the tip's propagation direction
(uniform on the spherical cap, half-angle ρ/2); candidate i is chosen with
probability ``u_i = φ_i^γ / Σ_j φ_j^γ`` (Eq. 2).  Defaults n = 8, ρ = π/2,
γ = 2.5 (the paper's).  Choices written down here:

* ``reference="tip"`` (default) measures φ_i from the tip's own potential,
  ``φ_i = max(φ(candidate) − φ(tip), 0)``: the leader channel is a conductor
  at the tip's potential, the dielectric-breakdown convention (Niemeyer,
  Pietronero & Wiesmann 1984).  With absolute potentials
  (``reference="absolute"``, the paper's literal Eq. 2) the candidates differ
  by only |∇φ|·2l, so u is nearly uniform and γ barely matters.
* Branching: a second candidate is drawn from the same u; when it differs
  from the chosen one, a side branch starts there with probability
  ``branch_probability`` · 2^(−g), g the generation of the growing tip (0 for
  the trunk, 1 for its branches, …), which keeps the branching sub-critical.  Hence branching falls as γ sharpens u
  (P(second ≠ first) = 1 − Σ u_i²).  A side branch lives a random number of
  segments (exponential, mean ``branch_length`` segments) unless it reaches
  the positive charge first.
* The leader connects when a tip comes within 2l of a positively charged
  grid point (the last segment goes straight to it).  A tip whose candidates
  all have φ ≤ 0 (outside the grid, or, with ``reference="tip"``, all
  against the field) is re-aimed once along the local field ∇φ (a new cone
  of candidates); if those fail too, it stops.  If every tip has stopped, or ``max_segments`` is
  exceeded, the target is unreachable: :class:`~auralize.errors.DataError`.

CSV (``Discharge.to_csv``/``from_csv``): a tree ``id,parent,x,y,z[,main]``
(parent −1 for the root), or a polyline ``x,y,z`` (one chain, all main).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from auralize.errors import DataError, FormatError, ParameterError
from auralize.runtime.files import atomic_write

from .field import ElectricField


@dataclass
class Discharge:
    """A discharge tree (paper 002 §4.1: "the data structure of the discharge pattern is tree-shaped").

    Parameters
    ----------
    nodes : (N, 3) m, node positions; node 0 is the root.
    parent : (N,) int, parent node of each node (−1 for the root); parents
        precede their children.
    main : (N,) bool, nodes on the main channel (root to the strike point).
    meta : growth statistics.
    """

    nodes: NDArray[np.float64]
    parent: NDArray[np.int64]
    main: NDArray[np.bool_]
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.nodes = np.asarray(self.nodes, dtype=np.float64).reshape(-1, 3)
        self.parent = np.asarray(self.parent, dtype=np.int64).reshape(-1)
        self.main = np.asarray(self.main, dtype=bool).reshape(-1)
        n = self.nodes.shape[0]
        if n < 2:
            raise DataError(f"a discharge needs at least 2 nodes (one segment), got {n}")
        if self.parent.size != n or self.main.size != n:
            raise DataError(
                f"discharge arrays disagree: {n} nodes, {self.parent.size} parents, {self.main.size} flags"
            )
        if not np.all(np.isfinite(self.nodes)):
            raise DataError("discharge node positions contain NaN or Inf")
        if (
            self.parent[0] != -1
            or np.any(self.parent[1:] < 0)
            or np.any(self.parent[1:] >= np.arange(1, n))
        ):
            raise DataError(
                "discharge tree: node 0 must be the root (parent -1) and every other "
                "node's parent must come before it"
            )

    # --------------------------------------------------------------- segments
    @property
    def n_segments(self) -> int:
        return self.nodes.shape[0] - 1

    @property
    def seg_start(self) -> NDArray[np.float64]:
        """(S, 3) parent end of each segment."""
        return self.nodes[self.parent[1:]]

    @property
    def seg_end(self) -> NDArray[np.float64]:
        """(S, 3) child end of each segment."""
        return self.nodes[1:]

    @property
    def midpoints(self) -> NDArray[np.float64]:
        return 0.5 * (self.seg_start + self.seg_end)

    @property
    def half_lengths(self) -> NDArray[np.float64]:
        """(S,) m, the l of Eq. 5 for each segment."""
        return 0.5 * np.linalg.norm(self.seg_end - self.seg_start, axis=1)

    @property
    def directions(self) -> NDArray[np.float64]:
        """(S, 3) unit vectors along the segments."""
        d = self.seg_end - self.seg_start
        n = np.linalg.norm(d, axis=1, keepdims=True)
        return d / np.where(n > 0, n, 1.0)

    @property
    def seg_main(self) -> NDArray[np.bool_]:
        """(S,) segment lies on the main channel (both ends on it)."""
        return self.main[1:] & self.main[self.parent[1:]]

    def n_branches(self) -> int:
        """Number of side branches (tree nodes with more than one child, counted per extra child)."""
        counts = np.bincount(self.parent[1:], minlength=self.nodes.shape[0])
        return int(np.sum(np.maximum(counts - 1, 0)))

    def main_length(self) -> float:
        m = self.seg_main
        return float(2 * self.half_lengths[m].sum())

    def subdivided(self, max_half_length: float) -> Discharge:
        """Split segments longer than ``2·max_half_length`` into equal pieces (same shape)."""
        if not max_half_length > 0:
            raise ParameterError(f"max_half_length must be > 0 m, got {max_half_length!r}")
        hl = self.half_lengths
        pieces = np.maximum(np.ceil(hl / max_half_length * (1 - 1e-6)).astype(np.int64), 1)
        if np.all(pieces == 1):
            return self
        nodes = [self.nodes[0]]
        parent = [-1]
        main = [bool(self.main[0])]
        new_id = np.zeros(self.nodes.shape[0], dtype=np.int64)
        for i in range(1, self.nodes.shape[0]):
            a, b = self.nodes[self.parent[i]], self.nodes[i]
            prev = int(new_id[self.parent[i]])
            m = bool(self.main[i] and self.main[self.parent[i]])
            for k in range(1, pieces[i - 1] + 1):
                nodes.append(a + (b - a) * k / pieces[i - 1])
                parent.append(prev)
                main.append(m if k < pieces[i - 1] else bool(self.main[i]))
                prev = len(nodes) - 1
            new_id[i] = prev
        return Discharge(np.asarray(nodes), np.asarray(parent), np.asarray(main), dict(self.meta))

    # -------------------------------------------------------------------- I/O
    def to_csv(self, path: str | Path) -> None:
        """Write ``id,parent,x,y,z,main`` atomically."""
        buf = io.StringIO()
        buf.write("id,parent,x,y,z,main\n")
        for i in range(self.nodes.shape[0]):
            x, y, z = self.nodes[i]
            buf.write(f"{i},{self.parent[i]},{x:.9g},{y:.9g},{z:.9g},{int(self.main[i])}\n")
        atomic_write(Path(path), buf.getvalue().encode())

    @classmethod
    def from_csv(cls, path: str | Path) -> Discharge:
        """Read a tree (``id,parent,x,y,z[,main]``) or a polyline (``x,y,z``) CSV.

        Without a ``main`` column the main channel is the longest root-to-leaf path.
        """
        p = Path(path)
        try:
            text = p.read_text()
        except FileNotFoundError:
            raise FormatError(f"discharge file {str(p)!r} does not exist") from None
        except UnicodeDecodeError:
            raise FormatError(f"{p}: not a text CSV file") from None
        rows = [r for r in csv.reader(io.StringIO(text)) if r and any(c.strip() for c in r)]
        if not rows:
            raise FormatError(f"{p}: empty file; expected a header 'x,y,z' or 'id,parent,x,y,z'")
        header = [h.strip().lower() for h in rows[0]]
        try:
            data = np.array(
                [[float(c) for c in r[: len(header)]] for r in rows[1:]], dtype=np.float64
            )
        except ValueError:
            raise FormatError(f"{p}: non-numeric value in the rows after the header") from None
        if data.size == 0 or data.shape[1] != len(header):
            raise FormatError(f"{p}: expected rows of {len(header)} numbers after the header")
        if header[:3] == ["x", "y", "z"]:
            n = data.shape[0]
            if n < 2:
                raise FormatError(f"{p}: a polyline needs at least 2 points, got {n}")
            return cls(
                data[:, :3],
                np.arange(n) - 1,
                np.ones(n, dtype=bool),
                {"source": str(p), "kind": "polyline"},
            )
        if header[:5] != ["id", "parent", "x", "y", "z"]:
            raise FormatError(
                f"{p}: header must be 'x,y,z' (polyline) or 'id,parent,x,y,z[,main]' "
                f"(tree); got {','.join(header)!r}"
            )
        ids = data[:, 0].astype(np.int64)
        par = data[:, 1].astype(np.int64)
        if np.any(data[:, 0] != ids) or len(set(ids.tolist())) != ids.size:
            raise FormatError(f"{p}: node ids must be distinct integers")
        index = {int(v): k for k, v in enumerate(ids)}
        roots = np.flatnonzero(par < 0)
        if roots.size != 1:
            raise FormatError(f"{p}: a tree needs exactly one root (parent -1), found {roots.size}")
        missing = [int(v) for v in par if v >= 0 and int(v) not in index]
        if missing:
            raise FormatError(f"{p}: parent ids {missing[:5]} do not exist")
        # topological order: breadth-first from the root
        children: dict[int, list[int]] = {}
        for k, v in enumerate(par):
            if v >= 0:
                children.setdefault(index[int(v)], []).append(k)
        order = [int(roots[0])]
        for k in order:
            order.extend(children.get(k, []))
        if len(order) != ids.size:
            raise FormatError(f"{p}: the tree has a cycle or nodes not connected to the root")
        new = {old: new for new, old in enumerate(order)}
        nodes = data[order, 2:5]
        parent = np.array([-1] + [new[index[int(par[k])]] for k in order[1:]])
        if "main" in header:
            main = data[order, header.index("main")] != 0
        else:
            main = _longest_path(nodes, parent)
        return cls(nodes, parent, main, {"source": str(p), "kind": "tree"})


def _longest_path(nodes: NDArray[np.float64], parent: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Nodes on the longest root-to-leaf path (by length)."""
    dist = np.zeros(nodes.shape[0])
    for i in range(1, nodes.shape[0]):
        dist[i] = dist[parent[i]] + np.linalg.norm(nodes[i] - nodes[parent[i]])
    main = np.zeros(nodes.shape[0], dtype=bool)
    k = int(np.argmax(dist))
    while k >= 0:
        main[k] = True
        k = int(parent[k])
    return main


# ------------------------------------------------------------------ growth
def _cone_directions(
    axis: NDArray[np.float64], n: int, rho: float, rng: np.random.Generator
) -> NDArray[np.float64]:
    """``(T, n, 3)`` unit vectors uniform on the cap of half-angle ρ/2 around each axis (T, 3)."""
    t = axis.shape[0]
    cos_lo = math.cos(0.5 * rho)
    cz = 1.0 - rng.random((t, n)) * (1.0 - cos_lo)
    sz = np.sqrt(np.maximum(1.0 - cz * cz, 0.0))
    az = rng.random((t, n)) * 2 * np.pi
    # orthonormal frame (e1, e2, axis)
    helper = np.where(
        np.abs(axis[:, 2:3]) < 0.9, np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]])
    )
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(axis, e1)
    return (
        (sz * np.cos(az))[..., None] * e1[:, None]
        + (sz * np.sin(az))[..., None] * e2[:, None]
        + cz[..., None] * axis[:, None]
    )


def _start_point(fld: ElectricField) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Root on the negative charge's surface where the field is strongest, and its direction."""
    neg = fld.sign < 0
    free = fld.sign == 0
    surface = neg & ndimage.binary_dilation(free, structure=ndimage.generate_binary_structure(3, 1))
    if not surface.any():
        raise DataError("the negative charge has no free neighbouring point to start a leader from")
    # the strongest field = the largest potential among the free neighbours
    nb_max = ndimage.maximum_filter(
        np.where(free, fld.phi, -np.inf), size=3, mode="constant", cval=-np.inf
    )
    score = np.where(surface, nb_max, -np.inf)
    k, j, i = np.unravel_index(int(np.argmax(score)), score.shape)
    root = fld.origin + np.array([i, j, k]) * fld.spacing
    g = fld.gradient_at(root)[0]
    if not np.linalg.norm(g) > 0:
        pos = fld.points_of(1)
        g = pos[np.argmin(np.linalg.norm(pos - root, axis=1))] - root
    return root, g / np.linalg.norm(g)


def grow_leader(
    fld: ElectricField,
    *,
    half_length: float,
    n_candidates: int = 8,
    rho: float = math.pi / 2,
    gamma: float = 2.5,
    seed: int = 0,
    branch_probability: float = 0.05,
    branch_length: float = 20.0,
    max_tips: int = 64,
    max_segments: int | None = None,
    reference: str = "tip",
) -> Discharge:
    """Grow a discharge tree through ``fld`` from the negative to the positive charge (§4.1, Eq. 2).

    Parameters
    ----------
    fld : ElectricField
        Solved, normalised potential (0 on the negative, 1 on the positive charge).
    half_length : m, segment half-length l (each step advances 2l).
    n_candidates, rho, gamma : Eq. 2's n, cone apex angle ρ (rad) and exponent γ.
    seed : random seed (same seed, same tree).
    branch_probability : chance that a differing second draw starts a side branch.
    branch_length : mean lifetime of a side branch, in segments.
    max_tips : at most this many growing tips at once.
    max_segments : give up after this many segments (default: 100 × the
        straight root-to-target distance in segments, at least 5,000).
    reference : ``"tip"`` (φ relative to the tip) or ``"absolute"`` (paper's literal Eq. 2).

    Returns
    -------
    Discharge whose ``main`` flags the channel from the root to the strike point.

    Raises
    ------
    DataError
        The positive charge cannot be reached (enclosed, or all tips stopped,
        or ``max_segments`` exceeded).

    Examples
    --------
    >>> from auralize_spark.presets import PRESETS
    >>> d = grow_leader(PRESETS["spark-balls"].field(), half_length=1e-3, seed=1)
    >>> bool(d.main.any()) and d.meta["reached"]
    True
    """
    if not half_length > 0:
        raise ParameterError(f"half_length must be > 0 m, got {half_length!r}")
    if int(n_candidates) < 1:
        raise ParameterError(f"n_candidates must be >= 1, got {n_candidates!r}")
    if not 0 < rho <= 2 * math.pi:
        raise ParameterError(f"rho must be in (0, 2π] rad, got {rho!r}")
    if not gamma >= 0:
        raise ParameterError(f"gamma must be >= 0, got {gamma!r}")
    if reference not in ("tip", "absolute"):
        raise ParameterError(f"reference must be 'tip' or 'absolute', got {reference!r}")
    if not 0 <= branch_probability <= 1:
        raise ParameterError(f"branch_probability must be in [0, 1], got {branch_probability!r}")
    _check_reachable(fld)
    rng = np.random.default_rng(seed)
    step = 2.0 * half_length
    root, d0 = _start_point(fld)
    pos_pts = fld.points_of(1)
    # distance to the positive charge (m), on the grid, for the connection test
    dist_pos = ndimage.distance_transform_edt(fld.sign <= 0, sampling=fld.spacing[::-1])
    straight = float(np.min(np.linalg.norm(pos_pts - root, axis=1)))
    if max_segments is None:
        max_segments = max(5000, int(100 * straight / step))
    nodes = [root]
    parent = [-1]
    # active tips: node index, direction, remaining life (inf for the trunk)
    tip_node = np.array([0], dtype=np.int64)
    tip_pos = root[None, :]
    tip_dir = d0[None, :]
    tip_life = np.array([np.inf])
    tip_gen = np.array([0], dtype=np.int64)
    hit = -1
    n_branch = 0
    while hit < 0:
        if tip_node.size == 0:
            raise DataError(
                f"the leader stopped after {len(nodes) - 1} segments without reaching the positive "
                "charge (every tip ran out of grid or potential); the target is unreachable"
            )
        if len(nodes) - 1 > max_segments:
            raise DataError(
                f"the leader did not reach the positive charge within {max_segments} segments "
                f"(straight distance {straight:.4g} m, step {step:.4g} m); the target is unreachable "
                "or the segments too short"
            )
        tips = tip_pos
        # connection: a tip within one step of the positive charge
        dnear = _sample_nearest(dist_pos, fld, tips)
        close = np.flatnonzero(dnear <= step)
        if close.size:
            q = int(close[0])
            tgt = pos_pts[np.argmin(np.linalg.norm(pos_pts - tips[q], axis=1))]
            nodes.append(tgt)
            parent.append(int(tip_node[q]))
            hit = len(nodes) - 1
            break
        dirs = _cone_directions(tip_dir, int(n_candidates), rho, rng)  # (T, n, 3)
        cand, wgt = _weights(fld, tips, dirs, step=step, gamma=gamma, reference=reference)
        tot = wgt.sum(axis=1)
        stuck = np.flatnonzero(tot <= 0)
        if stuck.size:  # re-aim stuck tips along the local field before giving up on them
            g = fld.gradient_at(tips[stuck])
            gn = np.linalg.norm(g, axis=1, keepdims=True)
            aim = np.where(gn > 0, g / np.where(gn > 0, gn, 1.0), tip_dir[stuck])
            d2 = _cone_directions(aim, int(n_candidates), rho, rng)
            c2, w2 = _weights(fld, tips[stuck], d2, step=step, gamma=gamma, reference=reference)
            dirs[stuck], cand[stuck], wgt[stuck] = d2, c2, w2
            tot = wgt.sum(axis=1)
        alive = tot > 0
        u = np.where(alive[:, None], wgt / np.where(alive, tot, 1.0)[:, None], 0.0)
        cdf = np.cumsum(u, axis=1)
        r1, r2, r3 = rng.random(u.shape[0]), rng.random(u.shape[0]), rng.random(u.shape[0])
        pick = np.minimum((cdf < r1[:, None]).sum(axis=1), u.shape[1] - 1)
        pick2 = np.minimum((cdf < r2[:, None]).sum(axis=1), u.shape[1] - 1)
        new_node, new_pos, new_dir, new_life, new_gen = [], [], [], [], []
        for t in np.flatnonzero(alive):
            nodes.append(cand[t, pick[t]])
            parent.append(int(tip_node[t]))
            life = tip_life[t] - 1
            if life > 0:
                new_node.append(len(nodes) - 1)
                new_pos.append(nodes[-1])
                new_dir.append(dirs[t, pick[t]])
                new_life.append(life)
                new_gen.append(tip_gen[t])
            if (
                pick2[t] != pick[t]
                and r3[t] < branch_probability * 0.5 ** tip_gen[t]
                and len(new_node) + 1 < max_tips
            ):
                nodes.append(cand[t, pick2[t]])
                parent.append(int(tip_node[t]))
                new_node.append(len(nodes) - 1)
                new_pos.append(nodes[-1])
                new_dir.append(dirs[t, pick2[t]])
                new_life.append(max(1.0, rng.exponential(branch_length)))
                new_gen.append(tip_gen[t] + 1)
                n_branch += 1
        tip_node = np.asarray(new_node, dtype=np.int64)
        tip_pos = np.asarray(new_pos).reshape(-1, 3)
        tip_dir = np.asarray(new_dir).reshape(-1, 3)
        tip_life = np.asarray(new_life)
        tip_gen = np.asarray(new_gen, dtype=np.int64)
    nodes_a = np.asarray(nodes)
    parent_a = np.asarray(parent, dtype=np.int64)
    main = np.zeros(nodes_a.shape[0], dtype=bool)
    k = hit
    while k >= 0:
        main[k] = True
        k = int(parent_a[k])
    meta = {
        "reached": True,
        "seed": seed,
        "gamma": gamma,
        "n_candidates": int(n_candidates),
        "rho": rho,
        "reference": reference,
        "half_length": half_length,
        "branches_started": n_branch,
        "straight_distance": straight,
    }
    # the final connection can be longer than 2l: keep every segment at most 2l long
    return Discharge(nodes_a, parent_a, main, meta).subdivided(half_length)


def _weights(
    fld: ElectricField,
    tips: NDArray[np.float64],
    dirs: NDArray[np.float64],
    *,
    step: float,
    gamma: float,
    reference: str,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Candidate points ``(T, n, 3)`` and their Eq. 2 weights φ_i^γ ``(T, n)``."""
    cand = tips[:, None, :] + step * dirs
    phi = fld.potential_at(cand.reshape(-1, 3)).reshape(dirs.shape[:2])
    if reference == "tip":
        phi = phi - fld.potential_at(tips)[:, None]
    phi = np.where(np.isnan(phi), 0.0, np.maximum(phi, 0.0))
    return cand, phi**gamma


def _sample_nearest(
    grid: NDArray[np.float64], fld: ElectricField, pts: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Nearest-point lookup of a grid array at ``pts`` (inf outside the grid)."""
    f = (pts - fld.origin) / fld.spacing
    ijk = np.round(f).astype(np.int64)
    dims = np.asarray(fld.dims)
    ok = np.all((ijk >= 0) & (ijk < dims), axis=1)
    ijk = np.clip(ijk, 0, dims - 1)
    # the grid point may be up to half a cell away from the tip
    out = grid[ijk[:, 2], ijk[:, 1], ijk[:, 0]] - 0.5 * float(np.linalg.norm(fld.spacing))
    out[~ok] = np.inf
    return out


def _check_reachable(fld: ElectricField) -> None:
    """The positive charge must be connected to the negative one through free points."""
    conn = ndimage.generate_binary_structure(3, 1)
    free_or_pos = fld.sign >= 0
    lab, _ = ndimage.label(free_or_pos, structure=conn)
    neg_nb = ndimage.binary_dilation(fld.sign < 0, structure=conn) & free_or_pos
    start_labels = set(np.unique(lab[neg_nb]).tolist()) - {0}
    pos_labels = set(np.unique(lab[fld.sign > 0]).tolist())
    if not start_labels & pos_labels:
        raise DataError(
            "the positive charge is unreachable: no path of free grid points joins it to the "
            "negative charge (it is enclosed by other charges or the grid)"
        )
