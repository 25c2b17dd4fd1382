"""Cross-sections of stick-like objects: circle, polygons, symmetry (paper 004 §5.2.1, §8.1).

A section lives in its own 2-D body frame (ξ, η).  Its size ``D`` is the
frontal width seen by a flow along +ξ (the η extent), the length of the
Strouhal number f·D/v and of the correlation length 3D (§7.1).  The flow
direction θ is measured from +ξ towards +η.

Symmetry (§8.1: "one eighth of [the directions] due to the symmetrical shape
of the prism") is found from the vertices: the largest rotation order k and
any mirror axis.  Only the fundamental domain of flow directions is
simulated; :func:`fold_directions` maps any direction into it.

Examples
--------
>>> sq = square(0.01)
>>> sq.symmetry
(4, 0.0)
>>> sq.direction_domain()
(0.0, 45.0, False)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from auralize.errors import FormatError, ParameterError


@dataclass(frozen=True)
class Section:
    """A cross-section.

    Parameters
    ----------
    name : str
    diameter : float
        Frontal width D at θ = 0, metres.
    polygon : (P, 2) or None
        Vertices in metres (counter-clockwise, centred on the area centroid,
        not repeated); None for a circle of diameter D.
    """

    name: str
    diameter: float
    polygon: NDArray[np.float64] | None = None

    @property
    def is_circle(self) -> bool:
        return self.polygon is None

    @property
    def circumdiameter(self) -> float:
        """Diameter of the smallest centred circle holding the section (m)."""
        if self.polygon is None:
            return self.diameter
        return 2.0 * float(np.max(np.hypot(self.polygon[:, 0], self.polygon[:, 1])))

    @property
    def symmetry(self) -> tuple[int, float | None]:
        """(rotation order k, mirror-axis angle in degrees or None); circle: (0, 0.0)."""
        if self.polygon is None:
            return 0, 0.0
        return polygon_symmetry(self.polygon)

    def direction_domain(self) -> tuple[float, float, bool]:
        """Fundamental domain of flow directions: (start°, width°, cyclic).

        Dihedral symmetry D_k with a mirror at α: [α, α + 180/k] (both ends
        sampled); rotations only (C_k): [0, 360/k) (wraps); circle: a single
        direction (width 0).
        """
        k, mirror = self.symmetry
        if k == 0:
            return 0.0, 0.0, False
        if mirror is not None:
            return float(mirror), 180.0 / k, False
        return 0.0, 360.0 / k, True

    def contains(self, xi: NDArray[np.floating], eta: NDArray[np.floating]) -> NDArray[np.bool_]:
        """Point-in-section test (even–odd rule) for arrays of body-frame points (m)."""
        xi = np.asarray(xi, dtype=np.float64)
        eta = np.asarray(eta, dtype=np.float64)
        if self.polygon is None:
            return xi**2 + eta**2 <= (0.5 * self.diameter) ** 2
        inside = np.zeros(np.broadcast(xi, eta).shape, dtype=bool)
        P = self.polygon
        for a, b in zip(P, np.roll(P, -1, axis=0), strict=True):
            if a[1] == b[1]:
                continue
            cond = (a[1] > eta) != (b[1] > eta)
            x_cross = a[0] + (eta - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
            inside ^= cond & (xi < x_cross)
        return inside

    def outline(self, n: int = 64) -> NDArray[np.float64]:
        """Closed outline ``(n or P, 2)`` in metres (for plots and overlays)."""
        if self.polygon is None:
            a = np.linspace(0, 2 * np.pi, n, endpoint=False)
            return 0.5 * self.diameter * np.stack([np.cos(a), np.sin(a)], 1)
        return self.polygon.copy()


# --------------------------------------------------------------- validation
def _segments_intersect(P: NDArray[np.float64]) -> tuple[int, int] | None:
    """First pair of non-adjacent polygon edges that intersect (or touch), else None."""
    A = P
    B = np.roll(P, -1, axis=0)
    n = len(P)

    def orient(p, q, r):  # type: ignore[no-untyped-def]
        return (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (
            r[..., 0] - p[..., 0]
        )

    i, j = np.triu_indices(n, k=2)
    keep = ~((i == 0) & (j == n - 1))
    i, j = i[keep], j[keep]
    a, b, c, d = A[i], B[i], A[j], B[j]
    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    hit = (o1 * o2 <= 0) & (o3 * o4 <= 0)
    # collinear, disjoint segments give all-zero orientations: check overlap of extents
    col = (o1 == 0) & (o2 == 0)
    if np.any(col):
        for k in np.nonzero(col)[0]:
            lo1, hi1 = np.minimum(a[k], b[k]), np.maximum(a[k], b[k])
            lo2, hi2 = np.minimum(c[k], d[k]), np.maximum(c[k], d[k])
            hit[k] = bool(np.all(lo1 <= hi2) and np.all(lo2 <= hi1))
    if np.any(hit):
        k = int(np.argmax(hit))
        return int(i[k]), int(j[k])
    return None


def make_polygon(
    vertices: NDArray[np.floating],
    *,
    diameter: float | None = None,
    name: str = "polygon",
    source: str = "<memory>",
) -> Section:
    """A validated polygonal section.

    Parameters
    ----------
    vertices : (P + 1, 2)
        A closed ring: the last vertex repeats the first.  Units are free;
        the polygon is scaled to ``diameter`` if given (else taken as metres).
    diameter : float, optional
        Frontal width D (η extent) after scaling, metres.

    Raises
    ------
    ParameterError
        Open ring, fewer than 3 distinct vertices, zero area, self-intersection,
        non-finite values or a non-positive diameter.
    """
    V = np.asarray(vertices, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 2:
        raise ParameterError(
            f"{source}: polygon vertices must be (P, 2) x,y pairs, got shape {V.shape}"
        )
    if not np.all(np.isfinite(V)):
        raise ParameterError(f"{source}: polygon vertices contain NaN or Inf")
    if not np.allclose(V[0], V[-1], rtol=0, atol=1e-12 * max(1.0, float(np.abs(V).max()))):
        raise ParameterError(
            f"{source}: the polygon is open (first vertex {V[0].tolist()} != last {V[-1].tolist()}); "
            "close it by repeating the first vertex as the last"
        )
    if V.shape[0] < 4:
        raise ParameterError(
            f"{source}: a closed polygon needs at least 3 vertices plus the repeated first one; "
            f"got {V.shape[0]} rows"
        )
    P = V[:-1]
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    if np.any(seg == 0):
        raise ParameterError(
            f"{source}: polygon has repeated consecutive vertices at index {int(np.argmin(seg))}"
        )
    bad = _segments_intersect(P)
    if bad is not None:
        raise ParameterError(
            f"{source}: polygon is self-intersecting (edges {bad[0]} and {bad[1]} cross); "
            "give a simple closed ring"
        )
    area2 = float(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1]))
    if abs(area2) <= 1e-12 * float(np.ptp(P, axis=0).max()) ** 2:
        raise ParameterError(f"{source}: polygon has zero area")
    if area2 < 0:
        P = P[::-1].copy()
        area2 = -area2
    # centre on the area centroid
    x, y = P[:, 0], P[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cr = x * y1 - x1 * y
    c = np.array([np.sum((x + x1) * cr), np.sum((y + y1) * cr)]) / (3.0 * area2)
    P = P - c
    width = float(np.ptp(P[:, 1]))
    if diameter is not None:
        check_diameter(diameter)
        P = P * (diameter / width)
        width = float(diameter)
    return Section(name, width, P)


def check_diameter(d: float) -> float:
    try:
        v = float(d)
    except (TypeError, ValueError):
        raise ParameterError(f"diameter must be a number of metres, got {d!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ParameterError(f"diameter must be > 0 m, got {d!r}")
    return v


def polygon_symmetry(P: NDArray[np.float64], tol: float = 1e-6) -> tuple[int, float | None]:
    """Rotation order and a mirror-axis angle (degrees in [0, 180/k)) of a centred polygon."""
    scale = float(np.max(np.hypot(P[:, 0], P[:, 1])))
    atol = tol * scale

    def same(Q: NDArray[np.float64]) -> bool:
        d = np.linalg.norm(P[:, None, :] - Q[None, :, :], axis=2)
        return bool(np.all(d.min(axis=1) < atol) and np.all(d.min(axis=0) < atol))

    k = 1
    for order in range(min(len(P), 24), 1, -1):
        a = 2 * np.pi / order
        R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        if same(P @ R.T):
            k = order
            break
    mids = 0.5 * (P + np.roll(P, -1, axis=0))
    cands = np.concatenate([np.arctan2(P[:, 1], P[:, 0]), np.arctan2(mids[:, 1], mids[:, 0])])
    cands = np.unique(np.round(np.mod(cands, np.pi / k), 12))
    for al in cands:
        c, s = np.cos(2 * al), np.sin(2 * al)
        if same(P @ np.array([[c, s], [s, -c]]).T):
            deg = float(np.rad2deg(al))
            return k, 0.0 if abs(deg) < 1e-9 or abs(deg - 180.0 / k) < 1e-9 else round(deg, 9)
    return k, None


# ------------------------------------------------------------------ presets
def circle(diameter: float) -> Section:
    """Circular cylinder of diameter D (§8.1: D = 1 cm)."""
    return Section("cylinder", check_diameter(diameter), None)


def square(diameter: float) -> Section:
    """Square prism of side D, faces normal to ξ and η (§8.1)."""
    h = 0.5 * check_diameter(diameter)
    V = np.array([[-h, -h], [h, -h], [h, h], [-h, h], [-h, -h]])
    return make_polygon(V, name="square")


def sword(diameter: float) -> Section:
    """A sword blade cross-section (Fig. 9a, approximated): a flat hexagon.

    The blade's thickness is D (the frontal width for a flow along +ξ, i.e.
    hitting the edge); its chord along ξ is 5 D with bevelled edges.
    """
    t = check_diameter(diameter)
    c = 2.5 * t
    V = np.array(
        [
            [-c, 0],
            [-c + t, -t / 2],
            [c - t, -t / 2],
            [c, 0],
            [c - t, t / 2],
            [-c + t, t / 2],
            [-c, 0],
        ]
    )
    return make_polygon(V, name="sword")


SHAPES = {"cylinder": circle, "circle": circle, "square": square, "sword": sword}


def read_polygon_file(path: str | Path, *, diameter: float) -> Section:
    """A polygon from a text file of ``x,y`` rows (comma or whitespace; optional header).

    The ring must be closed (last row = first row); it is scaled so that its
    frontal width (η extent) is ``diameter`` metres.
    """
    p = Path(path)
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise FormatError(f"polygon file {str(p)!r} does not exist") from None
    except UnicodeDecodeError:
        raise FormatError(f"{p}: not a text file of x,y rows") from None
    rows = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.replace(",", " ").split()
        try:
            vals = [float(v) for v in parts]
        except ValueError:
            if not rows and lineno == 1:
                continue  # header
            raise FormatError(f"{p}, line {lineno}: not two numbers: {line!r}") from None
        if len(vals) != 2:
            raise FormatError(f"{p}, line {lineno}: expected 2 columns x,y, got {len(vals)}")
        rows.append(vals)
    if not rows:
        raise FormatError(f"{p}: no vertices")
    return make_polygon(np.asarray(rows), diameter=diameter, name=p.stem, source=str(p))


def get_section(shape: str, diameter: float) -> Section:
    """``cylinder``/``circle``, ``square``, ``sword`` or a polygon file path."""
    check_diameter(diameter)
    if shape in SHAPES:
        return SHAPES[shape](diameter)
    if Path(shape).exists():
        return read_polygon_file(shape, diameter=diameter)
    raise ParameterError(
        f"unknown shape {shape!r}: choose one of {sorted(SHAPES)} or give a polygon file of x,y rows"
    )


# ------------------------------------------------------- direction folding
def fold_directions(
    section: Section, theta: NDArray[np.floating]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Map flow directions into the fundamental domain.

    Parameters
    ----------
    theta : (...) radians, body frame.

    Returns
    -------
    theta_f : (...) radians inside :meth:`Section.direction_domain`.
    M : (..., 2, 2) orthogonal maps with ``F(θ) = M · F(θ_f)`` for the force
        (and its time derivative) in body-frame components.
    """
    th = np.asarray(theta, dtype=np.float64)
    k, mirror = section.symmetry

    def rot(a: NDArray[np.float64]) -> NDArray[np.float64]:
        c, s = np.cos(a), np.sin(a)
        return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)

    if k == 0:  # isotropic: one direction, rotate its force
        return np.zeros_like(th), rot(th)
    beta = 2 * np.pi / k
    start = 0.0 if mirror is None else np.deg2rad(mirror)
    r = np.floor((th - start) / beta)
    th1 = th - r * beta  # in [start, start + beta)
    M = rot(r * beta)
    if mirror is None:
        return th1, M
    ax = start + beta / 2  # the mirror axis at α + π/k
    flip = th1 > ax
    c, s = np.cos(2 * ax), np.sin(2 * ax)
    Ref = np.array([[c, s], [s, -c]])
    th_f = np.where(flip, 2 * ax - th1, th1)
    M = np.where(flip[..., None, None], M @ Ref, M)
    return th_f, M
