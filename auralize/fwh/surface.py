"""Closed integration surfaces for the Ffowcs Williams–Hawkings integral.

A :class:`Surface` is a set of flat panels: their corners, centres, unit
outward normals and areas.  The FW-H integral samples the flow at the panel
centres and sums panel contributions (midpoint rule), so a surface is a
closed polyhedron whose panels are small against the shortest wavelength
heard (the grid spacing is a good panel size: the data hold nothing finer).

Three ways to place one:

:func:`box_surface`
    an axis-aligned box ``(xmin, xmax, ymin, ymax, zmin, zmax)`` cut into
    rectangles of about ``panel_size``;
:func:`sphere_surface`
    an icosphere (triangles) of a centre, radius and subdivision level;
:func:`mesh_surface`
    any closed triangle surface pyvista reads (``.vtp``, ``.vtk``, ``.stl``,
    ``.ply``, ``.obj``) or a ``pyvista.PolyData``; open surfaces are refused
    and the normals are made outward (the enclosed volume positive).

:func:`surface_from_spec` reads the command-line form
(``box=x0,x1,y0,y1,z0,z1``, ``sphere=cx,cy,cz,r[,nsub]``, ``file=PATH``).

The surface is stationary (the data's grid does not move): ``velocity`` is
zero; the FW-H sources are written with the surface velocity term
(:func:`auralize.fwh.formulation.fwh_sources`) so a moving surface can come
later.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DataError, MissingFileError, ParameterError

#: default icosphere subdivision level (20·4^4 = 5120 triangles)
SPHERE_NSUB = 4


@dataclass
class Surface:
    """A closed surface of flat panels (triangles or quadrilaterals).

    Parameters
    ----------
    corners : (P, k, 3) float
        Panel corners in metres, k = 3 (triangles) or 4 (quadrilaterals),
        ordered counter-clockwise seen from outside.
    centres : (P, 3) float
        Panel centres (where the flow is sampled).
    normals : (P, 3) float
        Unit outward normals.
    areas : (P,) float
        Panel areas in m².
    velocity : (P, 3) float, optional
        Surface velocity in m/s (zeros: stationary; the only case the
        propagation handles yet).
    kind : str
        ``box``, ``sphere`` or ``mesh``.
    description : str
        What was asked for (messages, reports).

    Examples
    --------
    >>> s = box_surface((-1, 1, -1, 1, -1, 1), panel_size=0.5)
    >>> s.n_panels, round(s.total_area, 6), s.closure() < 1e-12
    (96, 24.0, True)
    """

    corners: NDArray[np.float64]
    centres: NDArray[np.float64]
    normals: NDArray[np.float64]
    areas: NDArray[np.float64]
    velocity: NDArray[np.float64] | None = None
    kind: str = "mesh"
    description: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.centres = np.ascontiguousarray(self.centres, dtype=np.float64).reshape(-1, 3)
        P = self.centres.shape[0]
        self.normals = np.ascontiguousarray(self.normals, dtype=np.float64).reshape(P, 3)
        self.areas = np.ascontiguousarray(self.areas, dtype=np.float64).reshape(P)
        self.corners = np.ascontiguousarray(self.corners, dtype=np.float64)
        if P == 0:
            raise ParameterError(f"surface {self.description!r} has no panels")
        if self.corners.ndim != 3 or self.corners.shape[0] != P or self.corners.shape[2] != 3:
            raise ParameterError(
                f"surface corners must be (P, k, 3) for P={P}, got {self.corners.shape}"
            )
        if self.velocity is None:
            self.velocity = np.zeros((P, 3))
        self.velocity = np.ascontiguousarray(self.velocity, dtype=np.float64).reshape(P, 3)
        for name, a in (
            ("corners", self.corners),
            ("normals", self.normals),
            ("areas", self.areas),
            ("velocity", self.velocity),
        ):
            if not np.isfinite(a).all():
                raise ParameterError(f"surface {self.description!r}: {name} contain NaN or Inf")
        if np.any(self.areas <= 0):
            raise ParameterError(
                f"surface {self.description!r} has {int(np.sum(self.areas <= 0))} "
                "panels of zero area"
            )

    @property
    def n_panels(self) -> int:
        return int(self.centres.shape[0])

    @property
    def total_area(self) -> float:
        return float(self.areas.sum())

    @property
    def stationary(self) -> bool:
        assert self.velocity is not None
        return not np.any(self.velocity)

    @property
    def bounds(self) -> tuple[float, float, float, float, float, float]:
        """``(xmin, xmax, ymin, ymax, zmin, zmax)`` of the corners (pyvista order)."""
        c = self.corners.reshape(-1, 3)
        lo, hi = c.min(axis=0), c.max(axis=0)
        return (float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1]), float(lo[2]), float(hi[2]))

    @property
    def enclosed_volume(self) -> float:
        """Volume enclosed (m³; divergence theorem, positive for outward normals)."""
        return float(np.sum(np.einsum("pi,pi->p", self.centres, self.normals) * self.areas) / 3.0)

    def closure(self) -> float:
        """|∮ n dS| / ∮ dS: zero (to round-off) for a closed surface."""
        return float(np.linalg.norm(self.normals.T @ self.areas) / self.total_area)

    def to_polydata(self) -> Any:
        """The panels as a ``pyvista.PolyData`` (for drawing), cell data ``area``."""
        import pyvista as pv

        P, k, _ = self.corners.shape
        pts = self.corners.reshape(-1, 3)
        faces = np.hstack([np.full((P, 1), k), np.arange(P * k).reshape(P, k)]).ravel()
        mesh = pv.PolyData(pts, faces=faces)
        mesh.cell_data["area"] = self.areas
        mesh.cell_data["normal"] = self.normals
        return mesh

    def __repr__(self) -> str:
        return (
            f"Surface({self.kind}, {self.n_panels} panels, area {self.total_area:.4g} m², "
            f"volume {self.enclosed_volume:.4g} m³)"
        )


def _panels(corners: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """Centres, unit normals and areas of flat panels ``(P, k, 3)`` (k = 3 or 4).

    The area vector of a planar polygon is ½ Σ c_i × c_{i+1}; for a quad it is
    ½ (d1 × d2) with d1, d2 its diagonals.  The centre is the corners' mean
    (the centroid for triangles and parallelograms).
    """
    if corners.shape[1] == 3:
        av = 0.5 * np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    else:
        av = 0.5 * np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 1])
    area = np.linalg.norm(av, axis=1)
    normal = av / np.where(area > 0, area, 1.0)[:, None]
    return corners.mean(axis=1), normal, area


def _check_box(box: Any) -> NDArray[np.float64]:
    b = np.asarray(box, dtype=np.float64).reshape(-1)
    if b.size != 6 or not np.isfinite(b).all():
        raise ParameterError(
            f"box must be six numbers (xmin, xmax, ymin, ymax, zmin, zmax), got {box!r}"
        )
    if np.any(b[1::2] <= b[0::2]):
        raise ParameterError(f"box {b.tolist()} must have xmin < xmax, ymin < ymax, zmin < zmax")
    return b


def box_surface(box: Any, *, panel_size: float | None = None, n: int | None = None) -> Surface:
    """An axis-aligned box cut into rectangular panels.

    Parameters
    ----------
    box : sequence of 6 float
        ``(xmin, xmax, ymin, ymax, zmin, zmax)`` in metres.
    panel_size : float, optional
        Largest panel edge in metres (each face edge is cut into
        ``ceil(edge / panel_size)`` equal parts).
    n : int, optional
        Instead: panels along the longest edge (default 24).

    Returns
    -------
    Surface
        Quadrilateral panels, outward normals ±x, ±y, ±z.

    Examples
    --------
    >>> s = box_surface((0, 2, 0, 1, 0, 1), n=2)
    >>> s.n_panels, s.enclosed_volume
    (10, 2.0)
    """
    b = _check_box(box)
    lo, hi = b[0::2], b[1::2]
    ext = hi - lo
    if panel_size is None:
        m = 24 if n is None else int(n)
        if m < 1:
            raise ParameterError(f"n must be >= 1 panels per edge, got {n!r}")
        panel_size = float(ext.max()) / m
    if not (np.isfinite(panel_size) and panel_size > 0):
        raise ParameterError(f"panel_size must be > 0 m, got {panel_size!r}")
    counts = np.maximum(1, np.ceil(ext / panel_size - 1e-9).astype(int))
    if int(2 * (counts[0] * counts[1] + counts[1] * counts[2] + counts[0] * counts[2])) > 5_000_000:
        raise ParameterError(
            f"box {b.tolist()} with panel_size {panel_size:g} m needs more than "
            "5 million panels; choose a larger panel_size"
        )
    faces = []
    for axis in range(3):
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3  # (a1, a2, axis) is right-handed
        e1 = np.linspace(lo[a1], hi[a1], counts[a1] + 1)
        e2 = np.linspace(lo[a2], hi[a2], counts[a2] + 1)
        g1, g2 = np.meshgrid(e1, e2, indexing="ij")
        for side, value in ((+1, hi[axis]), (-1, lo[axis])):
            quad = np.zeros((counts[a1], counts[a2], 4, 3))
            # counter-clockwise seen from +axis: (0,0) (1,0) (1,1) (0,1) in (a1, a2)
            order = (
                [(0, 0), (1, 0), (1, 1), (0, 1)] if side > 0 else [(0, 0), (0, 1), (1, 1), (1, 0)]
            )
            for c, (d1, d2) in enumerate(order):
                quad[:, :, c, a1] = g1[d1 : d1 + counts[a1], d2 : d2 + counts[a2]]
                quad[:, :, c, a2] = g2[d1 : d1 + counts[a1], d2 : d2 + counts[a2]]
                quad[:, :, c, axis] = value
            faces.append(quad.reshape(-1, 4, 3))
    corners = np.concatenate(faces)
    centres, normals, areas = _panels(corners)
    return Surface(
        corners,
        centres,
        normals,
        areas,
        kind="box",
        description=f"box={','.join(f'{v:g}' for v in b)}",
        meta={"box": b.tolist(), "panel_size": float(panel_size)},
    )


def sphere_surface(center: Any, radius: float, *, resolution: int = SPHERE_NSUB) -> Surface:
    """An icosphere: 20·4^resolution flat triangles with vertices on the sphere.

    Parameters
    ----------
    center : sequence of 3 float
        Centre in metres.
    radius : float
        Radius in metres (> 0).
    resolution : int
        Subdivisions of the icosahedron, 0..7 (panels 20, 80, 320, 1280,
        5120, ...; edge about 1.1 R / 2^resolution).

    Examples
    --------
    >>> s = sphere_surface((0, 0, 0), 1.0, resolution=2)
    >>> s.n_panels, s.closure() < 1e-12
    (320, True)
    """
    c = np.asarray(center, dtype=np.float64).reshape(-1)
    if c.size != 3 or not np.isfinite(c).all():
        raise ParameterError(f"sphere centre must be three numbers, got {center!r}")
    if not (np.isfinite(radius) and radius > 0):
        raise ParameterError(f"sphere radius must be > 0 m, got {radius!r}")
    if isinstance(resolution, bool) or not (
        isinstance(resolution, int | np.integer) and 0 <= resolution <= 7
    ):
        raise ParameterError(f"sphere resolution must be an integer 0..7, got {resolution!r}")
    import pyvista as pv

    mesh = pv.Icosphere(radius=float(radius), center=tuple(c), nsub=int(resolution))
    s = _from_triangles(
        np.asarray(mesh.points),
        _triangles(mesh),
        "sphere",
        f"sphere={','.join(f'{v:g}' for v in c)},{radius:g},{resolution}",
    )
    s.meta.update(center=c.tolist(), radius=float(radius), resolution=int(resolution))
    return s


def _triangles(mesh: Any) -> NDArray[np.int64]:
    """The (n, 3) vertex indices of an all-triangle PolyData."""
    faces = np.asarray(mesh.faces, dtype=np.int64)
    return faces.reshape(-1, 4)[:, 1:]


def _from_triangles(
    points: NDArray[np.float64], tris: NDArray[np.int64], kind: str, description: str
) -> Surface:
    """A Surface of triangles, checked closed and oriented outward."""
    if tris.shape[0] == 0:
        raise DataError(f"surface {description!r} has no triangles")
    # each undirected edge of a closed surface is shared by exactly two triangles
    edges = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    undirected = np.sort(edges, axis=1)
    _, counts = np.unique(undirected, axis=0, return_counts=True)
    open_edges = int(np.sum(counts == 1))
    if open_edges or np.any(counts > 2):
        what = (
            f"{open_edges} open (boundary) edges"
            if open_edges
            else f"{int(np.sum(counts > 2))} edges shared by more than two triangles"
        )
        raise DataError(
            f"surface {description!r} is not closed: {what}. The FW-H integral needs a closed "
            f"surface around the sources (close the holes, e.g. pyvista's fill_holes, or use "
            f"box=... / sphere=...)"
        )
    # a consistently oriented closed surface has every directed edge once
    _, dcounts = np.unique(edges, axis=0, return_counts=True)
    if np.any(dcounts > 1):
        raise DataError(
            f"surface {description!r} is closed but its triangles are not consistently "
            f"oriented; reorient them (pyvista: compute_normals(consistent_normals=True, "
            f"auto_orient_normals=True))"
        )
    corners = np.ascontiguousarray(points[tris], dtype=np.float64)
    centres, normals, areas = _panels(corners)
    if np.any(areas <= 0):
        raise DataError(
            f"surface {description!r} has {int(np.sum(areas <= 0))} degenerate "
            "(zero-area) triangles; clean the mesh"
        )
    s = Surface(corners, centres, normals, areas, kind=kind, description=description)
    if s.enclosed_volume < 0:  # inward: flip every triangle
        corners = corners[:, ::-1].copy()
        s = Surface(corners, centres, -normals, areas, kind=kind, description=description)
    if not s.enclosed_volume > 0:
        raise DataError(f"surface {description!r} encloses no volume")
    return s


def mesh_surface(mesh: Any) -> Surface:
    """A closed surface from a ``pyvista.PolyData`` or any surface file pyvista reads.

    Polygons are triangulated; the surface must be closed (every edge shared
    by two triangles) and consistently oriented; the normals are made outward
    (enclosed volume positive).

    Raises
    ------
    MissingFileError
        The file does not exist.
    DataError
        The file holds no surface, the surface is open, non-manifold,
        inconsistently oriented or degenerate.
    """
    import pyvista as pv

    description = "<PolyData>"
    if isinstance(mesh, str | Path):
        path = Path(mesh)
        description = str(path)
        if not path.is_file():
            raise MissingFileError(f"surface file {str(path)!r} does not exist")
        try:
            mesh = pv.read(path)
        except Exception as exc:  # pyvista raises many kinds
            raise DataError(f"cannot read surface file {str(path)!r}: {exc}") from None
    if isinstance(mesh, pv.MultiBlock):
        mesh = mesh.combine()
    if not isinstance(mesh, pv.PolyData):
        try:
            mesh = mesh.extract_surface()
        except AttributeError:
            raise DataError(f"{description}: not a surface ({type(mesh).__name__})") from None
    mesh = mesh.triangulate().clean()
    if mesh.n_cells == 0 or not mesh.is_all_triangles:
        raise DataError(f"{description}: holds no surface triangles (lines or points only?)")
    return _from_triangles(
        np.asarray(mesh.points, dtype=np.float64), _triangles(mesh), "mesh", description
    )


def surface_from_spec(spec: str | Surface | Any, *, panel_size: float | None = None) -> Surface:
    """A surface from its command-line form, a Surface, or a PolyData.

    ``box=xmin,xmax,ymin,ymax,zmin,zmax``, ``sphere=cx,cy,cz,r[,resolution]``,
    ``file=PATH`` (or a bare path).  Numbers may also be separated by ``;``
    (inside ``--model`` parameters, whose pairs are comma-separated).
    ``panel_size`` applies to the box.

    Examples
    --------
    >>> surface_from_spec("box=-1,1,-1,1,-1,1", panel_size=1.0).n_panels
    24
    >>> surface_from_spec("sphere=0,0,0,2,1").n_panels
    80
    >>> surface_from_spec("box=0;1;0;1;0;1", panel_size=0.5).n_panels
    24
    """
    if isinstance(spec, Surface):
        return spec
    if not isinstance(spec, str | Path):
        return mesh_surface(spec)
    text = str(spec).strip()
    key, _, value = text.partition("=")
    key = key.strip().lower()
    if key in ("box", "sphere"):
        try:
            nums = [float(v) for v in value.replace(";", ",").split(",")]
        except ValueError:
            raise ParameterError(f"surface {text!r}: {key} needs comma-separated numbers") from None
        if key == "box":
            return box_surface(nums, panel_size=panel_size)
        if len(nums) not in (4, 5):
            raise ParameterError(
                f"surface {text!r}: sphere=cx,cy,cz,r[,resolution] needs 4 or 5 "
                f"numbers, got {len(nums)}"
            )
        res = SPHERE_NSUB if len(nums) == 4 else nums[4]
        if res != math.floor(res):
            raise ParameterError(f"surface {text!r}: resolution must be an integer, got {res:g}")
        return sphere_surface(nums[:3], nums[3], resolution=int(res))
    if key == "file":
        return mesh_surface(value.strip())
    if "=" not in text:
        return mesh_surface(text)
    raise ParameterError(
        f"unknown surface {text!r}; use box=xmin,xmax,ymin,ymax,zmin,zmax, "
        "sphere=cx,cy,cz,r[,resolution] or file=PATH"
    )
