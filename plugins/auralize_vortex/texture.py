"""Sound textures Q(u, t) of vortex sound (paper 000 §4, §5.1–5.2, Eqs. 1–4).

For each average inflow speed u a small analysis box is simulated with the
stable-fluids solver (:mod:`auralize_vortex.fluid`, §5.1) and, once the flow
is statistically steady, the sound pressure at virtual receivers at r = 1 m is
computed with *integral cells* (§5.2):

    ρ_{j,l}(t) = C ∂³/∂t³ Σ_k w(r_k) f(x_j − y_l, y_k − y_l) Δh³ / |x_j − y_l|³    (Eq. 3)
    f(x, y)   = (x·y) ((y × ω(y)) · x)                                          (Eq. 2)
    w(r_k)    = exp(−α r_k) / Σ_{l'} exp(−α r_{l'})                              (Eq. 4)

Choices and errata (written down as docs/design.md asks):

* ``C = ρ0 / (12π c0²)`` — Howe's compact-vortex far field, which decays as
  1/r (docs/design.md erratum to Eq. 1).  ``coefficient="paper"`` uses the printed
  ``ρ0 c0² / (12π)``.  With either, the texture is the pressure at 1 m.
* the volume element is Δh³ (Eq. 3 prints Δh², which is not a pressure).
* r_k in Eq. 4 is measured in voxel edges, so α = 3 weighs face, edge and
  corner neighbours by e⁻³, e^{−3√2}, e^{−3√3} (α in metres⁻¹ would make the
  weights uniform on a centimetre grid).  The normalising sum runs over all
  integral cells that contain voxel k, its own included, so every voxel's
  weights sum to one (:func:`integral_cell_weights`).
* receivers: ``n_receivers`` on a horizontal ring of radius 1 m around the box
  centre, perpendicular to the mean flow.  Averaging over the *whole* sphere
  would cancel the sound identically: the sphere mean of x̂_i x̂_j is δ_ij/3
  and y·(y×ω) = 0 (see :func:`receiver_ring`).  The ring keeps −Q_zz/2.
* the retarded time inside the compact box (≤ 0.6 ms) is neglected, as in the
  compact-source derivation of Eq. 1.
* ∂³/∂t³ is the central five-point stencil
  ``(s[n+2] − 2s[n+1] + 2s[n−1] − s[n−2]) / (2Δt³)``: second-order accurate,
  no recursion (stable), zero gain at the Nyquist frequency.

The kernel is linear in ω, so it is folded once into a weight field
``G (nz, ny, nx, 3)`` and each time step costs one dot product.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.constants import RHO0
from auralize.emitters import C0
from auralize.errors import DataError, FormatError, ParameterError
from auralize.runtime.files import atomic_hdf5, stop_if_failed
from auralize_vortex.fluid import StableFluids, smooth_noise

TEXTURE_FORMAT = "vortex-texture"
TEXTURE_VERSION = 1

#: default speeds (m/s) of the built-in texture: 8 speeds covering fire plumes (paper §7)
DEFAULT_SPEEDS = (0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0)


# --------------------------------------------------------------- parameters
@dataclass(frozen=True)
class TextureConfig:
    """Every parameter of a texture pre-process (stored in the HDF5 file).

    Parameters
    ----------
    speeds : increasing positive inflow speeds u in m/s.
    size : cells per axis of the cubic analysis box (n_x = n_y = n_z).
    box_m : edge of the analysis box in m (= the sound-source volume, §4).
    duration : seconds of sound recorded per speed (after the warm-up).
    dt : fluid time step in s (paper: 1 ms, §5.1); the texture rate is 1/dt.
    seed : random seed of the inflow perturbation.
    alpha : weight exponent of Eq. 4 (paper: 3.0), per voxel edge.
    n_receivers : virtual receivers on the 1 m ring (§5.2).
    perturbation : relative rms of the inflow speed perturbation (0 = laminar).
    corr_cells : spatial correlation of the perturbation in cells; its
        correlation time is ``corr_cells · h / u``.
    confinement : dimensionless vorticity confinement eps0 ([FSJ01]).
    warmup_transits : warm-up time in box transits H/u before recording.
    div_tol : the flow counts as converged when max|∇·v| h / u < div_tol.
    coefficient : "howe" (ρ0/(12π c0²), physical) or "paper" (ρ0 c0²/(12π)).
    rho0, c0 : air density (kg/m³) and speed of sound (m/s).
    """

    speeds: tuple[float, ...] = DEFAULT_SPEEDS
    size: int = 16
    box_m: float = 0.2
    duration: float = 1.0
    dt: float = 1e-3
    seed: int = 0
    alpha: float = 3.0
    n_receivers: int = 8
    perturbation: float = 0.3
    corr_cells: float = 1.5
    confinement: float = 0.3
    warmup_transits: float = 2.0
    div_tol: float = 1e-8
    coefficient: str = "howe"
    rho0: float = RHO0
    c0: float = C0

    def __post_init__(self) -> None:
        object.__setattr__(self, "speeds", check_speeds(self.speeds))
        checks: list[tuple[str, bool]] = [
            ("size", isinstance(self.size, int | np.integer) and 4 <= self.size <= 128),
            ("box_m", self.box_m > 0),
            ("duration", self.duration > 0),
            ("dt", 0 < self.dt <= 0.1),
            ("alpha", self.alpha >= 0),
            (
                "n_receivers",
                isinstance(self.n_receivers, int | np.integer) and self.n_receivers >= 1,
            ),
            ("perturbation", 0 <= self.perturbation <= 2),
            ("corr_cells", self.corr_cells > 0),
            ("confinement", self.confinement >= 0),
            ("warmup_transits", self.warmup_transits >= 0),
            ("div_tol", self.div_tol > 0),
            ("rho0", self.rho0 > 0),
            ("c0", self.c0 > 0),
        ]
        valid = {
            "size": "an integer in 4..128",
            "box_m": "> 0 m",
            "duration": "> 0 s",
            "dt": "in (0, 0.1] s",
            "alpha": ">= 0",
            "n_receivers": "an integer >= 1",
            "perturbation": "in [0, 2]",
            "corr_cells": "> 0",
            "confinement": ">= 0",
            "warmup_transits": ">= 0",
            "div_tol": "> 0",
            "rho0": "> 0",
            "c0": "> 0",
        }
        for name, ok in checks:
            if not ok:
                raise ParameterError(
                    f"texture parameter {name}={getattr(self, name)!r} is invalid; it must be "
                    f"{valid[name]}"
                )
        if self.coefficient not in ("howe", "paper"):
            raise ParameterError(f"coefficient must be 'howe' or 'paper', got {self.coefficient!r}")
        if self.duration / self.dt < 16:
            raise ParameterError(
                f"duration {self.duration} s holds fewer than 16 steps of dt={self.dt} s"
            )

    def to_json(self) -> str:
        d = asdict(self)
        d["speeds"] = [float(s) for s in self.speeds]
        return json.dumps(d, sort_keys=True)

    def digest(self) -> str:
        """Hash of every parameter and the format version (cache key)."""
        key = f"{TEXTURE_FORMAT}/{TEXTURE_VERSION}/{self.to_json()}"
        return hashlib.sha256(key.encode()).hexdigest()[:16]

    @property
    def prefactor(self) -> float:
        """C of Eq. 3 in kg/m³ · s²/m² (howe) or kg/m³ · m²/s² (paper)."""
        if self.coefficient == "howe":
            return self.rho0 / (12 * math.pi * self.c0**2)
        return self.rho0 * self.c0**2 / (12 * math.pi)


def check_speeds(speeds: Sequence[float] | NDArray[np.floating]) -> tuple[float, ...]:
    """Validate a list of texture speeds: finite, positive, strictly increasing."""
    try:
        arr = np.asarray(speeds, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ParameterError(f"speeds must be numbers in m/s, got {speeds!r}") from None
    if arr.size == 0:
        raise ParameterError("speeds must list at least one speed in m/s, got none")
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ParameterError(f"speeds must be positive finite m/s, got {arr.tolist()}")
    if np.any(np.diff(arr) <= 0):
        i = int(np.argmax(np.diff(arr) <= 0))
        raise ParameterError(
            f"speeds must be strictly increasing; {arr[i + 1]:g} follows {arr[i]:g} "
            f"in {arr.tolist()}"
        )
    return tuple(float(s) for s in arr)


# ------------------------------------------------------------ integral cells
def neighbour_offsets() -> NDArray[np.int64]:
    """The 27 offsets ``(ox, oy, oz)`` of an integral cell (§5.2, Fig. 3b), self first."""
    g = np.array(
        [(0, 0, 0)]
        + [
            (x, y, z)
            for z in (-1, 0, 1)
            for y in (-1, 0, 1)
            for x in (-1, 0, 1)
            if (x, y, z) != (0, 0, 0)
        ]
    )
    return g.astype(np.int64)


def _shifted(a: NDArray[Any], o: NDArray[np.int64]) -> tuple[tuple[slice, ...], tuple[slice, ...]]:
    """Slices (dst, src) with dst[k] = src[k − o] for all k whose k − o is inside (z, y, x)."""
    dst, src = [], []
    for ax, off in zip((0, 1, 2), (o[2], o[1], o[0]), strict=True):
        n = a.shape[ax]
        if off >= 0:
            dst.append(slice(off, n))
            src.append(slice(0, n - off))
        else:
            dst.append(slice(0, n + off))
            src.append(slice(-off, n))
    return tuple(dst), tuple(src)


def integral_cell_weights(
    shape: tuple[int, int, int], alpha: float = 3.0
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Weights of Eq. 4 for every voxel in every integral cell that contains it.

    Parameters
    ----------
    shape : (nz, ny, nx) voxels.
    alpha : exponent per voxel edge (paper: 3.0).

    Returns
    -------
    offsets : (27, 3) int, ``(ox, oy, oz)``; voxel k lies in the cell of l = k − o.
    weights : (27, nz, ny, nx); ``weights[m, k]`` is w of voxel k in the cell of
        voxel ``k − offsets[m]`` (0 where that cell is outside the grid).  For
        every voxel the 27 weights sum to one.

    Examples
    --------
    >>> o, w = integral_cell_weights((4, 4, 4))
    >>> bool(np.allclose(w.sum(axis=0), 1.0))
    True
    """
    offs = neighbour_offsets()
    raw = np.exp(-alpha * np.linalg.norm(offs, axis=1))
    inside = np.zeros((27, *shape))
    ones = np.ones(shape)
    for m, o in enumerate(offs):
        dst, src = _shifted(ones, o)
        inside[m][dst] = ones[src]
    w = raw[:, None, None, None] * inside
    return offs, w / w.sum(axis=0, keepdims=True)


def receiver_ring(n: int, radius: float = 1.0) -> NDArray[np.float64]:
    """``n`` receivers ``(n, 3)`` on a horizontal ring of ``radius`` m around the origin (§5.2)."""
    ang = 2 * np.pi * (np.arange(n) + 0.5) / n
    return np.stack([radius * np.cos(ang), radius * np.sin(ang), np.zeros(n)], axis=1)


def howe_kernel(
    shape: tuple[int, int, int], h: float, receivers: NDArray[np.floating], *, alpha: float = 3.0
) -> NDArray[np.float64]:
    """Integral-cell kernel G with ``Σ_k G_k · ω_k`` = receiver-mean of Eq. 3's sum (no C, no ∂³).

    Parameters
    ----------
    shape : (nz, ny, nx) voxels of edge ``h`` m, centred on the origin.
    receivers : (R, 3) receiver positions in m relative to the box centre.

    Returns
    -------
    G : (nz, ny, nx, 3) in m² (so that ``G·ω`` is in m²/s · m³/m³...); precisely,
        ``Σ_k G_k·ω_k = mean_j Σ_l Σ_k w f(x_j − y_l, y_k − y_l) Δh³ / |x_j − y_l|³``
        in m⁵ s⁻¹ m⁻³ = m²/s.
    """
    nz, ny, nx = shape
    rec = np.asarray(receivers, dtype=np.float64).reshape(-1, 3)
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    y = (np.stack([i, j, k], axis=-1) + 0.5 - np.array([nx, ny, nz]) / 2.0) * h
    X = rec[:, None, None, None, :] - y[None]  # (R, nz, ny, nx, 3)
    inv_r3 = 1.0 / np.linalg.norm(X, axis=-1) ** 3
    offs, w = integral_cell_weights(shape, alpha)
    G = np.zeros((nz, ny, nx, 3))
    for m, o in enumerate(offs):
        if m == 0:
            continue  # y_k = y_l: f = 0 (§5.2: voxel l does not affect ρ_{j,l})
        d = o.astype(np.float64) * h
        # f = (X·d) ((d×ω)·X) = (X·d) ω·(X×d)
        B = np.mean(
            ((X @ d) * inv_r3)[..., None] * np.cross(X, d), axis=0
        )  # (nz, ny, nx, 3), cell l
        dst, src = _shifted(w[m], o)
        G[dst] += w[m][dst][..., None] * B[src]
    return G * h**3


def third_derivative(s: NDArray[np.floating], dt: float) -> NDArray[np.float64]:
    """Central five-point ∂³/∂t³ of ``s (..., n)`` → ``(..., n − 4)`` (samples 2..n−3)."""
    s = np.asarray(s, dtype=np.float64)
    return (s[..., 4:] - 2 * s[..., 3:-1] + 2 * s[..., 1:-3] - s[..., :-4]) / (2 * dt**3)


# ------------------------------------------------------------------- texture
@dataclass
class Texture:
    """A sound texture Q(u, t): pressure at 1 m for each speed (§4, Fig. 2b).

    Parameters
    ----------
    speeds : (U,) strictly increasing m/s.
    pressure : (U, n) Pa at 1 m, sampled at ``rate`` Hz.
    rate : samples per second (1/dt of the pre-process).
    box_m : edge of the analysis box in m (sound-source volume size).
    config : the full pre-process parameters (None for textures built otherwise).
    """

    speeds: NDArray[np.float64]
    pressure: NDArray[np.float64]
    rate: float
    box_m: float
    config: TextureConfig | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.speeds = np.asarray(check_speeds(self.speeds))
        self.pressure = np.atleast_2d(np.asarray(self.pressure, dtype=np.float64))
        if self.pressure.shape[0] != self.speeds.size or self.pressure.shape[1] < 8:
            raise DataError(
                f"texture pressure must be (n_speeds={self.speeds.size}, n >= 8), "
                f"got {self.pressure.shape}"
            )
        if not np.all(np.isfinite(self.pressure)):
            raise DataError("texture pressure contains NaN or Inf")
        if not (self.rate > 0 and self.box_m > 0):
            raise DataError(
                f"texture rate and box_m must be positive, got {self.rate}, {self.box_m}"
            )

    @property
    def n_samples(self) -> int:
        return int(self.pressure.shape[1])

    @property
    def duration(self) -> float:
        return self.n_samples / self.rate

    def rms(self) -> NDArray[np.float64]:
        """RMS pressure (Pa at 1 m) per speed, ``(U,)``."""
        return np.sqrt(np.mean(self.pressure**2, axis=1))

    # -------------------------------------------------------------- file i/o
    def save(self, path: str | Path) -> Path:
        """Write the texture to HDF5 atomically (format ``vortex-texture`` v1)."""
        p = Path(path)
        nbytes = 8.0 * self.pressure.size + 16.0 * self.speeds.size + 65536.0
        what = f"a texture of {self.speeds.size} speeds x {self.n_samples} samples"
        with atomic_hdf5(p, nbytes=nbytes, what=what) as f:
            f.attrs["auralize_format"] = TEXTURE_FORMAT
            f.attrs["version"] = TEXTURE_VERSION
            f.attrs["rate_hz"] = float(self.rate)
            f.attrs["box_m"] = float(self.box_m)
            f.attrs["distance_m"] = 1.0
            f.attrs["config"] = self.config.to_json() if self.config else ""
            f.attrs["meta"] = json.dumps(self.meta, default=str)
            f.attrs["paper"] = "Dobashi, Yamamoto, Nishita 2004, §5 (auralize seed 000)"
            if self.config:
                for k, v in json.loads(self.config.to_json()).items():
                    f.attrs[f"param_{k}"] = v
            f.create_dataset("speeds", data=self.speeds).attrs["units"] = "m/s"
            ds = f.create_dataset("pressure", data=self.pressure)
            stop_if_failed(f)
            ds.attrs["units"] = "Pa at 1 m"
            ds.attrs["axes"] = "speed, time"
            f.create_dataset("rms", data=self.rms()).attrs["units"] = "Pa at 1 m"
        return p

    @classmethod
    def load(cls, path: str | Path) -> Texture:
        """Read a texture written by :meth:`save`; other files/versions raise FormatError."""
        import h5py

        p = Path(path)
        if not p.is_file():
            raise FormatError(f"{p}: no such texture file; make one with 'auralize vortex texture'")
        try:
            f = h5py.File(p, "r")
        except OSError:
            raise FormatError(f"{p}: not an HDF5 file, so not a vortex texture") from None
        with f:
            kind = f.attrs.get("auralize_format")
            kind = kind.decode() if isinstance(kind, bytes) else kind
            if kind != TEXTURE_FORMAT:
                raise FormatError(
                    f"{p}: not a vortex texture (auralize_format={kind!r}, expected "
                    f"{TEXTURE_FORMAT!r})"
                )
            version = int(f.attrs.get("version", -1))
            if version != TEXTURE_VERSION:
                raise FormatError(
                    f"{p}: vortex texture version {version}; this auralize_vortex reads version "
                    f"{TEXTURE_VERSION} — recompute it with 'auralize vortex texture'"
                )
            try:
                speeds = np.asarray(f["speeds"][()], dtype=np.float64)
                pressure = np.asarray(f["pressure"][()], dtype=np.float64)
                rate, box = float(f.attrs["rate_hz"]), float(f.attrs["box_m"])
            except KeyError as exc:
                raise FormatError(f"{p}: vortex texture is missing {exc}") from None
            cfg_text = f.attrs.get("config", "")
            meta = json.loads(f.attrs.get("meta", "{}") or "{}")
        config = None
        if cfg_text:
            d = json.loads(cfg_text)
            d["speeds"] = tuple(d["speeds"])
            try:
                config = TextureConfig(**d)
            except TypeError as exc:
                raise FormatError(
                    f"{p}: texture parameters do not match this version: {exc}"
                ) from None
        try:
            return cls(speeds, pressure, rate, box, config=config, meta=meta)
        except (DataError, ParameterError) as exc:
            raise FormatError(f"{p}: {exc}") from None


# ---------------------------------------------------------------- pre-process
class InflowForcing:
    """Random, smooth-in-time perturbation ξ(x, y, t) of the inflow speed (§5.1).

    ``ξ = Σ_m A_m(x, y) cos(ω_m t) + B_m(x, y) sin(ω_m t)`` with ``n_modes``
    frequencies ``ω_m = κ_m u / (corr_cells h)``, κ_m uniform in [0.5, 2],
    and smooth periodic random fields A_m, B_m of correlation ``corr_cells``
    cells; zero mean over the face, unit rms.  It is band-limited and
    infinitely differentiable — a white-in-time (e.g. Ornstein–Uhlenbeck)
    perturbation would dominate the third time derivative of Eq. 1 with
    forcing noise that does not follow the flow's u⁴ law — and it is
    self-similar: time scales are ``h/u``.
    """

    def __init__(
        self,
        shape: tuple[int, int],
        *,
        u: float,
        h: float,
        corr_cells: float,
        seed: int | tuple[int, ...] = 0,
        n_modes: int = 6,
    ) -> None:
        rng = np.random.default_rng(seed)
        self.omega = rng.uniform(0.5, 2.0, n_modes) * u / (corr_cells * h)
        self.a = np.stack([smooth_noise(rng, shape, corr_cells) for _ in range(n_modes)])
        self.b = np.stack([smooth_noise(rng, shape, corr_cells) for _ in range(n_modes)])
        self.scale = 1.0 / math.sqrt(n_modes)  # each term has variance 1/2 per field

    def __call__(self, t: float) -> NDArray[np.float64]:
        c = np.cos(self.omega * t)
        s = np.sin(self.omega * t)
        return self.scale * (np.tensordot(c, self.a, 1) + np.tensordot(s, self.b, 1))


def simulate_speed(cfg: TextureConfig, index: int) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """Texture row for ``cfg.speeds[index]``: pressure at 1 m ``(n,)`` and run info (§5.1–5.2)."""
    u = cfg.speeds[index]
    n = cfg.size
    h = cfg.box_m / n
    fl = StableFluids((n, n, n), h=h, dt=cfg.dt, eps0=cfg.confinement, speed_ref=u)
    fl.w[:] = u
    forcing = InflowForcing((n, n), u=u, h=h, corr_cells=cfg.corr_cells, seed=(cfg.seed, index))
    G = howe_kernel((n, n, n), h, receiver_ring(cfg.n_receivers), alpha=cfg.alpha)
    n_warm = math.ceil(cfg.warmup_transits * cfg.box_m / u / cfg.dt)
    n_rec = round(cfg.duration / cfg.dt) + 4
    s = np.empty(n_rec)

    t = 0.0

    def advance() -> None:
        nonlocal t
        fl.w[0] = u * (1 + cfg.perturbation * forcing(t))
        fl.step()
        t += cfg.dt

    steps = 0
    while True:  # warm-up: until the transit time has passed and continuity holds (§5.1)
        if steps >= n_warm:
            div = float(np.max(np.abs(fl.divergence()))) * h / u
            if div < cfg.div_tol:
                break
            if steps > 4 * max(n_warm, 100):
                raise DataError(
                    f"texture flow at u={u:g} m/s did not converge: max|div| h/u = {div:.3g} "
                    f">= {cfg.div_tol:g} after {steps} steps"
                )
        advance()
        steps += 1
    for m in range(n_rec):
        advance()
        s[m] = np.einsum("zyxc,zyxc->", G, fl.vorticity())
    p = cfg.prefactor * third_derivative(s, cfg.dt)
    return p, {
        "speed": u,
        "warmup_steps": steps,
        "recorded_steps": n_rec,
        "max_div_h_over_u": float(np.max(np.abs(fl.divergence()))) * h / u,
    }


def compute_texture(
    cfg: TextureConfig, *, progress: Callable[[str], None] | None = None
) -> Texture:
    """Run the pre-process of §5 for every speed and return the texture (not cached)."""
    from auralize.runtime.resources import require_memory

    n_rec = float(cfg.duration) / float(cfg.dt)
    # recorded pressure and its derivatives per receiver, plus the fluid fields of the box
    require_memory(
        n_rec * 8.0 * 8 * max(int(cfg.n_receivers), 1) + float(cfg.size) ** 3 * 8 * 40,
        f"a {cfg.duration:g} s texture at dt = {cfg.dt:g} s ({n_rec:.3g} steps)",
        hint="lower --duration or raise --dt",
    )
    t0 = time.perf_counter()
    rows, infos = [], []
    for i, u in enumerate(cfg.speeds):
        p, info = simulate_speed(cfg, i)
        rows.append(p)
        infos.append(info)
        if progress is not None:
            progress(
                f"u = {u:g} m/s: rms {np.sqrt(np.mean(p**2)):.3g} Pa at 1 m "
                f"({time.perf_counter() - t0:.1f} s)"
            )
    meta = {"runs": infos, "seconds": time.perf_counter() - t0, "digest": cfg.digest()}
    return Texture(
        np.asarray(cfg.speeds), np.stack(rows), 1.0 / cfg.dt, cfg.box_m, config=cfg, meta=meta
    )


def cache_dir() -> Path:
    """Texture cache folder: auralize's cache folder (:func:`auralize.runtime.cache.cache_root`)."""
    from auralize.runtime.cache import cache_root

    return cache_root()


def texture(
    cfg: TextureConfig | None = None,
    path: str | Path | None = None,
    *,
    progress: Callable[[str], None] | None = None,
) -> tuple[Texture, bool]:
    """Cached texture: same parameters, same file.

    ``path=None`` uses ``cache_dir()/vortex-texture-<digest>.h5``.  An existing
    file with exactly these parameters is loaded instead of recomputed.

    Returns
    -------
    (texture, cached) : ``cached`` is True when the file was reused.
    """
    cfg = cfg or TextureConfig()
    p = Path(path) if path is not None else cache_dir() / f"vortex-texture-{cfg.digest()}.h5"
    if p.is_file():
        try:
            old = Texture.load(p)
        except FormatError:
            old = None
        if old is not None and old.config == cfg:
            return old, True
    tex = compute_texture(cfg, progress=progress)
    if path is None:
        p.parent.mkdir(parents=True, exist_ok=True)  # the cache folder is auralize's own
    tex.save(p)
    tex.meta["path"] = str(p)
    return tex, False
