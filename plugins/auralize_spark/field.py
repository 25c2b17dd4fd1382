"""Charge scenes and the electric potential (paper 002 §4.1, Eq. 1).

The user gives a charge distribution and boundary conditions on a grid; the
potential φ is imposed on the charged cells and found elsewhere from
Laplace's equation ∇²φ = 0 (Eq. 1; the charge density of Poisson's equation
is zero off the charged cells).  The paper solves the linear system on a GPU;
here it is red-black SOR (numba) started from the solution on a grid twice
coarser, recursively (a cascadic multigrid), which solves 64³ in a fraction
of a second on one core.

Potentials are normalised so that the negative charge is at φ = 0 and the
positive charge at φ = 1: the leader grows from φ = 0 towards φ = 1 and
Eq. 2 weighs candidates by φ^γ, which needs φ ≥ 0.

Scene files (JSON or TOML) describe charged points, spheres, boxes and planes::

    {"grid": {"dims": [64, 64, 64], "origin": [0, 0, 0], "spacing": 0.001},
     "boundary": "neumann",
     "charges": [
        {"shape": "sphere", "center": [0.016, 0.032, 0.032], "radius": 0.006, "sign": "negative"},
        {"shape": "box", "min": [0.04, 0.02, 0.02], "max": [0.05, 0.04, 0.04], "sign": "positive"},
        {"shape": "plane", "axis": "z", "position": 0.0, "sign": "positive"},
        {"shape": "point", "position": [0.03, 0.03, 0.06], "sign": "negative"}]}

``boundary`` is ``"neumann"`` (insulating box faces, ∂φ/∂n = 0; the default)
or a number: the normalised potential held outside the box (0 = grounded at
the negative charge's potential).  ``sign`` is ``"negative"``/``"positive"``
(or −1/+1); an optional ``potential`` (any unit, e.g. volts) overrides the
default 0/1 and all potentials are then rescaled to [0, 1].
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DataError, FieldError, FormatError, ParameterError

from ._kernels import sor_sweeps

SHAPES = ("sphere", "box", "plane", "point")


@dataclass(frozen=True)
class Charge:
    """One charged object of a scene.

    ``shape`` is one of :data:`SHAPES`; ``sign`` is −1 (negative, where the
    leader starts) or +1 (positive, its target); ``geometry`` holds the
    shape's keys (``center``/``radius``, ``min``/``max``, ``axis``/``position``
    [/``thickness``], or ``position``); ``potential`` overrides the default
    potential (0 for negative, 1 for positive charges).
    """

    shape: str
    sign: int
    geometry: dict[str, Any]
    potential: float | None = None

    @property
    def value(self) -> float:
        if self.potential is not None:
            return float(self.potential)
        return 0.0 if self.sign < 0 else 1.0


@dataclass
class ChargeScene:
    """A grid with charged objects and a boundary condition (paper 002 §4.1).

    Parameters
    ----------
    dims : (nx, ny, nz) grid points.
    origin : (3,) m, position of point (0, 0, 0).
    spacing : (3,) m, point spacing along x, y, z.
    charges : the charged objects (later ones overwrite earlier ones).
    boundary : ``"neumann"`` or a normalised potential held outside the box.

    Examples
    --------
    >>> scene = ChargeScene.from_dict({
    ...     "grid": {"dims": [16, 8, 8], "spacing": 0.01},
    ...     "charges": [{"shape": "plane", "axis": "x", "position": 0.0, "sign": "negative"},
    ...                 {"shape": "plane", "axis": "x", "position": 0.15, "sign": "positive"}]})
    >>> f = solve_field(scene)
    >>> round(float(f.phi[4, 4, 8]), 3)
    0.533
    """

    dims: tuple[int, int, int]
    origin: NDArray[np.float64]
    spacing: NDArray[np.float64]
    charges: list[Charge] = field(default_factory=list)
    boundary: str | float = "neumann"
    source: str = "<memory>"

    def __post_init__(self) -> None:
        self.dims = tuple(int(d) for d in self.dims)  # type: ignore[assignment]
        if len(self.dims) != 3 or min(self.dims) < 2:
            raise ParameterError(
                f"{self.source}: grid dims must be three integers >= 2, got {self.dims}"
            )
        if math.prod(self.dims) > 256**3:
            raise ParameterError(f"{self.source}: grid {self.dims} is larger than 256³ points")
        self.origin = _vec3(self.origin, "origin", self.source)
        self.spacing = _vec3(self.spacing, "spacing", self.source)
        if np.any(self.spacing <= 0):
            raise ParameterError(f"{self.source}: spacing must be positive, got {self.spacing}")
        if isinstance(self.boundary, str):
            if self.boundary != "neumann":
                raise ParameterError(
                    f"{self.source}: boundary must be 'neumann' or a number, got {self.boundary!r}"
                )
        elif not math.isfinite(float(self.boundary)):
            raise ParameterError(f"{self.source}: boundary potential must be finite")

    # ------------------------------------------------------------- builders
    @classmethod
    def from_dict(cls, data: dict[str, Any], *, source: str = "<dict>") -> ChargeScene:
        """Build a scene from the JSON/TOML structure described in the module docstring."""
        if not isinstance(data, dict):
            raise FormatError(f"{source}: a scene must be a mapping, got {type(data).__name__}")
        grid = data.get("grid")
        if not isinstance(grid, dict) or "dims" not in grid or "spacing" not in grid:
            raise FormatError(
                f"{source}: needs a 'grid' table with 'dims' [nx, ny, nz] and 'spacing'"
            )
        items = data.get("charges")
        if not isinstance(items, list) or not items:
            raise FormatError(f"{source}: needs a non-empty list 'charges'")
        charges = [_parse_charge(it, i, source) for i, it in enumerate(items)]
        try:
            dims = tuple(int(d) for d in grid["dims"])
        except (TypeError, ValueError):
            raise FormatError(
                f"{source}: grid dims must be integers, got {grid['dims']!r}"
            ) from None
        return cls(
            dims=dims,
            origin=grid.get("origin", 0.0),
            spacing=grid["spacing"],  # type: ignore[arg-type]
            charges=charges,
            boundary=data.get("boundary", "neumann"),
            source=source,
        )

    @classmethod
    def from_file(cls, path: str | Path) -> ChargeScene:
        """Read a ``.json`` or ``.toml`` scene file."""
        p = Path(path)
        try:
            raw = p.read_bytes()
        except FileNotFoundError:
            raise FormatError(f"scene file {str(p)!r} does not exist") from None
        try:
            if p.suffix.lower() == ".toml":
                data = tomllib.loads(raw.decode())
            elif p.suffix.lower() == ".json":
                data = json.loads(raw)
            else:
                raise FormatError(f"{p}: scene files must end in .json or .toml")
        except (json.JSONDecodeError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise FormatError(f"{p}: cannot parse scene ({exc})") from None
        return cls.from_dict(data, source=str(p))

    # --------------------------------------------------------------- raster
    def coords(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Axis coordinates x (nx,), y (ny,), z (nz,) in metres."""
        return tuple(self.origin[a] + self.spacing[a] * np.arange(self.dims[a]) for a in range(3))  # type: ignore[return-value]

    def rasterize(self) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
        """Charge sign ``(nz, ny, nx)`` int8 (−1, 0, +1) and imposed potentials ``(nz, ny, nx)``.

        Every object covers at least its nearest grid point.
        """
        x, y, z = self.coords()
        nx, ny, nz = self.dims
        Z, Y, X = np.meshgrid(z, y, x, indexing="ij")
        sign = np.zeros((nz, ny, nx), dtype=np.int8)
        value = np.zeros((nz, ny, nx))
        for ch in self.charges:
            g = ch.geometry
            if ch.shape == "sphere":
                c = np.asarray(g["center"], dtype=np.float64)
                m = (X - c[0]) ** 2 + (Y - c[1]) ** 2 + (Z - c[2]) ** 2 <= float(g["radius"]) ** 2
                near = c
            elif ch.shape == "box":
                lo, hi = (
                    np.asarray(g["min"], dtype=np.float64),
                    np.asarray(g["max"], dtype=np.float64),
                )
                m = (
                    (X >= lo[0])
                    & (X <= hi[0])
                    & (Y >= lo[1])
                    & (Y <= hi[1])
                    & (Z >= lo[2])
                    & (Z <= hi[2])
                )
                near = 0.5 * (lo + hi)
            elif ch.shape == "plane":
                a = "xyz".index(g["axis"])
                half = 0.5 * float(g.get("thickness", self.spacing[a]))
                m = np.abs((X, Y, Z)[a] - float(g["position"])) <= half + 1e-12
                if not m.any():  # nearest layer
                    idx = int(
                        np.clip(
                            round((float(g["position"]) - self.origin[a]) / self.spacing[a]),
                            0,
                            self.dims[a] - 1,
                        )
                    )
                    m = np.zeros_like(m)
                    sl: list[Any] = [slice(None)] * 3
                    sl[2 - a] = idx
                    m[tuple(sl)] = True
                near = None
            else:  # point
                near = np.asarray(g["position"], dtype=np.float64)
                m = np.zeros((nz, ny, nx), dtype=bool)
            if near is not None:
                ijk = np.round((near - self.origin) / self.spacing).astype(int)
                if np.all((ijk >= 0) & (ijk < np.asarray(self.dims))):
                    m[ijk[2], ijk[1], ijk[0]] = True
            if not m.any():
                raise DataError(f"{self.source}: a {ch.shape} charge {g} lies outside the grid")
            sign[m] = ch.sign
            value[m] = ch.value
        return sign, value


def _vec3(v: Any, name: str, src: str) -> NDArray[np.float64]:
    try:
        a = np.broadcast_to(np.asarray(v, dtype=np.float64), (3,)).copy()
    except (TypeError, ValueError):
        raise ParameterError(
            f"{src}: {name} must be a number or three numbers, got {v!r}"
        ) from None
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{src}: {name} must be finite, got {a}")
    return a


def _parse_charge(it: Any, i: int, src: str) -> Charge:
    if not isinstance(it, dict):
        raise FormatError(f"{src}: charge {i} must be a table, got {it!r}")
    shape = it.get("shape")
    if shape not in SHAPES:
        raise FormatError(f"{src}: charge {i} has shape {shape!r}; valid shapes: {list(SHAPES)}")
    raw_sign = it.get("sign")
    sign = {"negative": -1, "positive": 1, "-": -1, "+": 1, -1: -1, 1: 1}.get(raw_sign)  # type: ignore[call-overload]
    if sign is None:
        raise FormatError(
            f"{src}: charge {i} sign must be 'negative' or 'positive' (or -1/+1), got {raw_sign!r}"
        )
    need = {
        "sphere": ("center", "radius"),
        "box": ("min", "max"),
        "plane": ("axis", "position"),
        "point": ("position",),
    }[shape]
    missing = [k for k in need if k not in it]
    if missing:
        raise FormatError(f"{src}: charge {i} ({shape}) needs {list(need)}; missing {missing}")
    geom = {k: it[k] for k in it if k not in ("shape", "sign", "potential")}
    try:
        for k in ("center", "min", "max") + (("position",) if shape == "point" else ()):
            if k in geom:
                geom[k] = [float(v) for v in geom[k]]
                if len(geom[k]) != 3:
                    raise ValueError
        for k in ("radius", "thickness") + (("position",) if shape == "plane" else ()):
            if k in geom:
                geom[k] = float(geom[k])
    except (TypeError, ValueError):
        raise FormatError(f"{src}: charge {i} ({shape}) has malformed geometry {geom}") from None
    if shape == "plane" and geom["axis"] not in ("x", "y", "z"):
        raise FormatError(
            f"{src}: charge {i} plane axis must be 'x', 'y' or 'z', got {geom['axis']!r}"
        )
    if shape == "sphere" and not geom["radius"] > 0:
        raise FormatError(f"{src}: charge {i} sphere radius must be > 0, got {geom['radius']}")
    pot = it.get("potential")
    return Charge(shape, sign, geom, None if pot is None else float(pot))


# ------------------------------------------------------------------ solver
@dataclass
class ElectricField:
    """A solved potential on a grid (paper 002 §4.1).

    Attributes
    ----------
    phi : (nz, ny, nx) normalised potential, 0 on the negative and 1 on the
        positive charge.
    sign : (nz, ny, nx) int8, −1/+1 on charged cells, 0 elsewhere.
    origin, spacing : (3,) m.
    info : solver statistics (sweeps per level, last change, residual).
    """

    phi: NDArray[np.float64]
    sign: NDArray[np.int8]
    origin: NDArray[np.float64]
    spacing: NDArray[np.float64]
    info: dict[str, Any] = field(default_factory=dict)
    scene: ChargeScene | None = None

    @property
    def dims(self) -> tuple[int, int, int]:
        nz, ny, nx = self.phi.shape
        return nx, ny, nz

    @property
    def upper(self) -> NDArray[np.float64]:
        return self.origin + self.spacing * (np.asarray(self.dims) - 1)

    def _frac(self, points: NDArray[np.floating]) -> NDArray[np.float64]:
        return (np.asarray(points, dtype=np.float64).reshape(-1, 3) - self.origin) / self.spacing

    def inside(self, points: NDArray[np.floating]) -> NDArray[np.bool_]:
        """Which of ``points (N, 3)`` lie in the grid box."""
        f = self._frac(points)
        return np.all((f >= 0) & (f <= np.asarray(self.dims) - 1), axis=1)

    def potential_at(self, points: NDArray[np.floating]) -> NDArray[np.float64]:
        """Trilinear potential at ``points (N, 3)``; NaN outside the grid."""
        f = self._frac(points)
        dims = np.asarray(self.dims)
        ok = np.all((f >= 0) & (f <= dims - 1), axis=1)
        i0 = np.clip(np.floor(f).astype(np.int64), 0, np.maximum(dims - 2, 0))
        w = np.clip(f - i0, 0.0, 1.0)
        out = np.zeros(f.shape[0])
        for dz in (0, 1):
            wz = w[:, 2] if dz else 1 - w[:, 2]
            kz = np.minimum(i0[:, 2] + dz, dims[2] - 1)
            for dy in (0, 1):
                wy = w[:, 1] if dy else 1 - w[:, 1]
                ky = np.minimum(i0[:, 1] + dy, dims[1] - 1)
                for dx in (0, 1):
                    wx = w[:, 0] if dx else 1 - w[:, 0]
                    kx = np.minimum(i0[:, 0] + dx, dims[0] - 1)
                    out += wz * wy * wx * self.phi[kz, ky, kx]
        out[~ok] = np.nan
        return out

    def sign_at(self, points: NDArray[np.floating]) -> NDArray[np.int8]:
        """Charge sign of the nearest grid point (0 outside the grid)."""
        f = self._frac(points)
        ijk = np.round(f).astype(np.int64)
        dims = np.asarray(self.dims)
        ok = np.all((ijk >= 0) & (ijk < dims), axis=1)
        ijk = np.clip(ijk, 0, dims - 1)
        out = self.sign[ijk[:, 2], ijk[:, 1], ijk[:, 0]].copy()
        out[~ok] = 0
        return out

    def gradient_at(self, points: NDArray[np.floating]) -> NDArray[np.float64]:
        """∇φ at ``points (N, 3)`` (1/m) by central differences of the trilinear field."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        g = np.zeros_like(p)
        for a in range(3):
            h = np.zeros(3)
            h[a] = 0.5 * self.spacing[a]
            lo, hi = p - h, p + h
            lo = np.clip(lo, self.origin, self.upper)
            hi = np.clip(hi, self.origin, self.upper)
            g[:, a] = (self.potential_at(hi) - self.potential_at(lo)) / np.maximum(
                hi[:, a] - lo[:, a], 1e-300
            )
        return g

    def points_of(self, sign: int) -> NDArray[np.float64]:
        """Positions ``(N, 3)`` of the grid points carrying charge ``sign``."""
        k, j, i = np.nonzero(self.sign == sign)
        return self.origin + np.stack([i, j, k], 1) * self.spacing


def _normalise(
    sign: NDArray[np.int8], value: NDArray[np.float64], src: str, boundary: str | float
) -> tuple[NDArray[np.float64], float | None]:
    neg, pos = sign < 0, sign > 0
    if not neg.any():
        raise DataError(
            f"{src}: the scene has no negative charge; a leader needs one to start from"
        )
    if not pos.any():
        raise DataError(f"{src}: the scene has no positive charge; a leader needs one to reach")
    v_neg, v_pos = float(value[neg].min()), float(value[pos].max())
    if not v_pos > v_neg:
        raise DataError(
            f"{src}: the positive charge's potential ({v_pos:g}) must exceed the negative one's ({v_neg:g})"
        )
    out = (value - v_neg) / (v_pos - v_neg)
    bnd = None if isinstance(boundary, str) else (float(boundary) - v_neg) / (v_pos - v_neg)
    return out, bnd


def _coarsen(
    fixed: NDArray[np.bool_], value: NDArray[np.float64]
) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """2×2×2 blocks: a coarse point is fixed when any child is; its value is the children's mean."""
    pad = [(0, s % 2) for s in fixed.shape]
    f = np.pad(fixed, pad, mode="edge")
    v = np.pad(np.where(fixed, value, 0.0), pad, mode="edge")
    nz, ny, nx = (s // 2 for s in f.shape)
    fb = f.reshape(nz, 2, ny, 2, nx, 2)
    vb = v.reshape(nz, 2, ny, 2, nx, 2)
    cnt = fb.sum(axis=(1, 3, 5))
    tot = (vb * fb).sum(axis=(1, 3, 5))
    return cnt > 0, np.where(cnt > 0, tot / np.maximum(cnt, 1), 0.0)


def solve_laplace(
    fixed: NDArray[np.bool_],
    value: NDArray[np.float64],
    *,
    spacing: NDArray[np.floating] | float = 1.0,
    boundary: float | None = None,
    tol: float = 1e-5,
    max_sweeps: int = 20000,
) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """Solve ∇²φ = 0 (paper 002 Eq. 1) with imposed potentials on ``fixed`` cells.

    Parameters
    ----------
    fixed : (nz, ny, nx) bool, cells with an imposed potential.
    value : (nz, ny, nx) potentials of the fixed cells.
    spacing : m, grid spacing (scalar or (dx, dy, dz)); the 7-point stencil
        weighs each axis by 1/h².
    boundary : potential outside the box (Dirichlet) or None for insulating
        faces (Neumann, ∂φ/∂n = 0).
    tol : stop when the largest change of a sweep is below ``tol`` (same
        units as ``value``).

    Returns
    -------
    (phi (nz, ny, nx), info) where ``info`` lists sweeps per level and the
    max-norm residual of the discrete Laplacian relative to the stencil weight.

    Notes
    -----
    Cascadic multigrid: the problem is coarsened by 2×2×2 blocks down to
    ~8 points per axis, solved there, and each finer level is started from the
    prolonged coarse solution and relaxed by red-black SOR with
    ω = 2 / (1 + π / n_max).
    """
    fixed = np.asarray(fixed, dtype=bool)
    value = np.asarray(value, dtype=np.float64)
    if fixed.ndim != 3 or value.shape != fixed.shape:
        raise ParameterError(
            f"fixed and value must be equal (nz, ny, nx) arrays, got {fixed.shape}, {value.shape}"
        )
    h = np.broadcast_to(np.asarray(spacing, dtype=np.float64), (3,))
    levels = [(fixed, value, h)]
    while min(levels[-1][0].shape) >= 16:
        f, v, hh = levels[-1]
        cf, cv = _coarsen(f, v)
        levels.append((cf, cv, hh * 2))
    neumann = boundary is None
    bval = 0.0 if boundary is None else float(boundary)
    init = float(np.mean(value[fixed])) if fixed.any() else bval
    phi = np.full(levels[-1][0].shape, init)
    sweeps = []
    change = 0.0
    for li in range(len(levels) - 1, -1, -1):
        f, v, hh = levels[li]
        if phi.shape != f.shape:  # prolong the coarser solution (piecewise constant)
            phi = np.repeat(np.repeat(np.repeat(phi, 2, 0), 2, 1), 2, 2)[
                : f.shape[0], : f.shape[1], : f.shape[2]
            ]
            phi = np.ascontiguousarray(phi)
        phi[f] = v[f]
        w = 1.0 / hh**2
        n_max = max(f.shape)
        omega = 2.0 / (1.0 + math.pi / n_max)
        n, change = sor_sweeps(phi, f, w, bval, neumann, omega, max_sweeps, tol)
        sweeps.append(int(n))
    res = _residual(phi, fixed, h, bval, neumann)
    return phi, {
        "sweeps": sweeps[::-1],
        "last_change": float(change),
        "residual": res,
        "converged": bool(change < tol),
    }


def _residual(
    phi: NDArray[np.float64],
    fixed: NDArray[np.bool_],
    h: NDArray[np.float64],
    bval: float,
    neumann: bool,
) -> float:
    """Max |mean of neighbours − φ| over free cells (the Laplacian scaled by its diagonal)."""
    w = 1.0 / h**2
    s = np.zeros_like(phi)
    ws = np.zeros_like(phi)
    for a, ax in enumerate((2, 1, 0)):  # x, y, z
        for shift in (1, -1):
            nb = np.roll(phi, shift, axis=ax)
            valid = np.ones_like(phi, dtype=bool)
            edge: list[Any] = [slice(None)] * 3
            edge[ax] = 0 if shift == 1 else -1
            valid[tuple(edge)] = False
            if neumann:
                s += np.where(valid, w[a] * nb, 0.0)
                ws += np.where(valid, w[a], 0.0)
            else:
                s += w[a] * np.where(valid, nb, bval)
                ws += w[a]
    r = np.abs(s / np.maximum(ws, 1e-300) - phi)
    r[fixed] = 0.0
    return float(r.max()) if r.size else 0.0


def solve_field(scene: ChargeScene, *, tol: float = 1e-5) -> ElectricField:
    """Rasterize ``scene`` and solve Eq. 1 for its normalised potential.

    Raises
    ------
    DataError
        When the scene has no negative or no positive charge.
    """
    sign, value = scene.rasterize()
    norm, bnd = _normalise(sign, value, scene.source, scene.boundary)
    phi, info = solve_laplace(sign != 0, norm, spacing=scene.spacing, boundary=bnd, tol=tol)
    return ElectricField(phi, sign, scene.origin.copy(), scene.spacing.copy(), info, scene)


def field_from_volume(
    volume: Any,
    *,
    name: str = "charge",
    step: int = 0,
    boundary: str | float = "neumann",
    tol: float = 1e-5,
) -> ElectricField:
    """Solve Eq. 1 for a charge field of a :class:`~auralize.volume.TimeVolume`.

    Points with ``charge < 0`` form the negative charge (φ = 0), points with
    ``charge > 0`` the positive charge (φ = 1); zero points are free.
    """
    if name not in volume.field_names:
        raise FieldError(
            f"{volume.source}: no field {name!r} for the charge distribution; "
            f"available fields: {', '.join(volume.field_names)}"
        )
    if volume.is_vector(name):
        raise FieldError(
            f"{volume.source}: charge field {name!r} must be scalar, it is a vector field"
        )
    q = volume.frame(name, step)
    sign = np.sign(q).astype(np.int8)
    src = f"{volume.source} field {name!r} step {step}"
    norm, bnd = _normalise(sign, (sign > 0).astype(np.float64), src, boundary)
    phi, info = solve_laplace(sign != 0, norm, spacing=volume.spacing, boundary=bnd, tol=tol)
    return ElectricField(
        phi,
        sign,
        np.asarray(volume.origin, dtype=np.float64).copy(),
        np.asarray(volume.spacing, dtype=np.float64).copy(),
        info,
    )
