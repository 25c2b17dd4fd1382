"""Sound textures w(l, s, u, v0) of aerodynamic sound (paper 004 §4, §5, Fig. 4).

For each sampled flow direction u_j of a cross-section, a 2-D flow
simulation (:mod:`auralize_aero.lbm`) at the base speed v0 gives the
pressure force per unit span ``F(t) = ∮ n p dl`` (Eq. 2 before d/dt; n the
body's outward normal, so F is the force the body exerts on the fluid,
Curle's dipole strength).  Its time derivative ``g = dF/dt`` (N m⁻¹ s⁻¹) is
the sound source function of Eq. 2 per unit length of the object; a point
source of span Δh radiates ``g Δh`` (§4, Fig. 3).  With a 2-D simulation the
texture has one l (§5.2.1) and is shared by all point sources.

Processing of each direction:

1. the LBM force history is low-pass filtered (zero-phase Butterworth) at
   ``harmonics`` × the shedding frequency — this also removes the weakly
   compressible scheme's pseudo-acoustic noise, absent from the paper's
   incompressible solver — differentiated, and resampled to ``rate_hz``
   (16 kHz, the paper's recommended step 1/16000 s, §5.2);
2. it is cut to a whole number of lift periods and its ends are cross-faded
   so that it loops seamlessly ("the ends of the texture are blended", §6).

Directions are spaced ≈ 5° (§7.3) over the section's fundamental domain of
symmetry (§8.1); a circle needs one (§5.3).  Textures are HDF5 files
(format ``aero_texture`` v1) and are cached by a hash of their parameters.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from auralize.constants import RHO0
from auralize.errors import FormatError, ParameterError
from auralize.runtime.files import atomic_hdf5, stop_if_failed

from .lbm import simulate
from .shapes import Section, check_diameter, fold_directions

FORMAT = "aero_texture"
VERSION = 1


@dataclass
class SoundTexture:
    """A sound texture of one cross-section at base speed v0.

    Attributes
    ----------
    section : Section
    speed : float
        Base speed v0 (m/s).
    rate : float
        Texture sample rate (Hz): sample n is at texture time s = n / rate.
    directions_deg : (m,)
        Sampled flow directions in the body frame (degrees).
    g : (m, N, 2)
        Sound source function dF/dt per unit span, body-frame components
        (N m⁻¹ s⁻¹), each row looping with period ``lengths[j]`` samples.
    force : (m, N, 2)
        Pressure force per unit span F (N/m), same layout (mean included).
    lengths : (m,) int
    strouhal : (m,)
        f·D/v0 of the lift (component across the flow) of each direction.
    meta : dict
        Simulation parameters (resolution, Reynolds number, lattice speed, …).
    """

    section: Section
    speed: float
    rate: float
    directions_deg: NDArray[np.float64]
    g: NDArray[np.float64]
    force: NDArray[np.float64]
    lengths: NDArray[np.int64]
    strouhal: NDArray[np.float64]
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def diameter(self) -> float:
        return self.section.diameter

    @property
    def shedding_hz(self) -> NDArray[np.float64]:
        return self.strouhal * self.speed / self.diameter

    def domain(self) -> tuple[float, float, bool]:
        return self.section.direction_domain()

    def lookup(
        self, theta: NDArray[np.floating]
    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """Directions to texture rows: (j0, j1, weight of j1, M (…, 2, 2)).

        ``g(θ, s) = M · ((1 - w) g[j0](s) + w g[j1](s))`` — linear interpolation
        between the neighbouring sampled directions (§7.3) after folding θ
        into the symmetry domain (:func:`auralize_aero.shapes.fold_directions`).
        """
        th_f, M = fold_directions(self.section, theta)
        m = self.directions_deg.size
        start, width, cyclic = self.domain()
        if m == 1:
            z = np.zeros(th_f.shape, dtype=np.int64)
            return z, z, np.zeros(th_f.shape), M
        step = width / (m if cyclic else m - 1)
        u = (np.rad2deg(th_f) - start) / step
        if cyclic:
            u = np.mod(u, m)
            j0 = np.floor(u).astype(np.int64) % m
            return j0, (j0 + 1) % m, u - np.floor(u), M
        u = np.clip(u, 0, m - 1)
        j0 = np.minimum(np.floor(u).astype(np.int64), m - 2)
        return j0, j0 + 1, u - j0, M

    def save(self, path: str | Path) -> None:
        """Write the texture to HDF5 atomically (format ``aero_texture`` v1)."""
        nbytes = 4.0 * (self.g.size + self.force.size) + 65536.0  # float32 arrays, at most
        what = f"a texture of {self.directions_deg.size} directions"
        with atomic_hdf5(path, nbytes=nbytes, what=what) as h:
            h.attrs["auralize_format"] = FORMAT
            h.attrs["version"] = VERSION
            h.attrs["shape"] = self.section.name
            h.attrs["diameter_m"] = self.diameter
            h.attrs["speed_mps"] = self.speed
            h.attrs["rate_hz"] = self.rate
            h.attrs["meta_json"] = json.dumps(self.meta)
            if self.section.polygon is not None:
                h["polygon"] = self.section.polygon
            h["directions_deg"] = self.directions_deg
            h["lengths"] = self.lengths
            h["strouhal"] = self.strouhal
            h.create_dataset("g", data=self.g.astype(np.float32), compression="gzip")
            stop_if_failed(h)
            h.create_dataset("force", data=self.force.astype(np.float32), compression="gzip")
            h["g"].attrs["units"] = "N/(m*s)"
            h["force"].attrs["units"] = "N/m"

    @classmethod
    def load(cls, path: str | Path) -> SoundTexture:
        """Read a texture written by :meth:`save`."""
        import h5py

        p = Path(path)
        if not p.exists():
            raise FormatError(
                f"texture file {str(p)!r} does not exist; make one with 'auralize aero texture'"
            )
        try:
            h = h5py.File(p, "r")
        except OSError:
            raise FormatError(f"{p}: not an HDF5 file") from None
        with h:
            if h.attrs.get("auralize_format") != FORMAT:
                raise FormatError(
                    f"{p}: not an aero sound texture (auralize_format={h.attrs.get('auralize_format')!r}, "
                    f"expected {FORMAT!r})"
                )
            if int(h.attrs.get("version", -1)) != VERSION:
                raise FormatError(
                    f"{p}: texture version {h.attrs.get('version')!r}, supported: {VERSION}"
                )
            name = str(h.attrs["shape"])
            d = float(h.attrs["diameter_m"])
            poly = np.asarray(h["polygon"], dtype=np.float64) if "polygon" in h else None
            return cls(
                section=Section(name, d, poly),
                speed=float(h.attrs["speed_mps"]),
                rate=float(h.attrs["rate_hz"]),
                directions_deg=np.asarray(h["directions_deg"], dtype=np.float64),
                g=np.asarray(h["g"], dtype=np.float64),
                force=np.asarray(h["force"], dtype=np.float64),
                lengths=np.asarray(h["lengths"], dtype=np.int64),
                strouhal=np.asarray(h["strouhal"], dtype=np.float64),
                meta=json.loads(str(h.attrs["meta_json"])),
            )


def sample_directions(
    section: Section, *, step_deg: float = 5.0, n: int | None = None
) -> NDArray[np.float64]:
    """Sampled flow directions (degrees) over the section's symmetry domain (§7.3, §8.1)."""
    start, width, cyclic = section.direction_domain()
    if width == 0:
        return np.zeros(1)
    if n is None:
        n = max(1, math.ceil(width / step_deg - 1e-9)) + (0 if cyclic else 1)
    if n < (1 if cyclic else 2):
        raise ParameterError(
            f"directions must be >= {1 if cyclic else 2} for a {section.name}, got {n}"
        )
    return start + width * np.arange(n) / (n if cyclic else n - 1)


def _loop(
    x: NDArray[np.float64], lift: NDArray[np.float64], blend_frac: float = 0.25
) -> tuple[NDArray[np.float64], int]:
    """Cut ``x (n, c)`` to whole periods of ``lift`` and cross-fade its ends (§6, Fig. 7)."""
    y = lift - lift.mean()
    up = np.nonzero((y[:-1] < 0) & (y[1:] >= 0))[0]
    if up.size < 3:
        raise ParameterError(
            f"texture recording holds {max(up.size - 1, 0)} shedding period(s); "
            "increase --duration (at least 2 periods plus a blend are needed)"
        )
    per = float(np.mean(np.diff(up)))
    B = max(2, int(blend_frac * per))
    a = int(up[0])
    ends = up[up + B < x.shape[0]]
    b = int(ends[-1])
    N = b - a
    out = x[a:b].copy()
    ramp = 0.5 - 0.5 * np.cos(np.pi * (np.arange(B) + 0.5) / B)
    out[:B] = ramp[:, None] * x[a : a + B] + (1 - ramp[:, None]) * x[b : b + B]
    return out, N


def compute_texture(  # noqa: PLR0913 (keyword-only options)
    section: Section,
    *,
    speed: float = 10.0,
    duration: float = 0.05,
    rate: float = 16000.0,
    resolution: int = 16,
    reynolds: float = 200.0,
    u_lattice: float = 0.1,
    directions: int | None = None,
    harmonics: float = 8.0,
    rho0: float = RHO0,
    seed: int = 0,
    cache: bool | str | Path = True,
    progress: Any = None,
) -> SoundTexture:
    """Pre-process a sound texture by 2-D flow simulation (§5).

    Parameters
    ----------
    section : Section
        Cross-section (:mod:`auralize_aero.shapes`).
    speed : float
        Base speed v0 (m/s), 10 m/s in all the paper's examples (§7.2).
    duration : float
        Recorded texture length (s) after the flow has become periodic.
    rate : float
        Texture sample rate (Hz); 8–16 kHz per §5.2.
    resolution : int
        Lattice cells across D.
    reynolds : float
        Reynolds number of the simulation.  The paper recommends 10³–10⁴
        (§7.2); a modest 2-D grid sheds a clean, periodic Kármán street at a
        few hundred, and properties 1–2 of §5.1 make the texture's use
        independent of the simulated Re anyway.  Default 200.
    u_lattice : float
        Inflow speed in lattice units (Mach ≈ 1.7 u_lattice).
    directions : int, optional
        Number of sampled directions over the symmetry domain (default: 5° spacing).
    harmonics : float
        Low-pass cut-off in multiples of the shedding frequency.
    rho0 : float
        Air density (kg/m³).
    seed : int
        Seeds the symmetry-breaking kick of each simulation.
    cache : bool or path
        True: ``aero/`` in auralize's cache folder (``$AURALIZE_CACHE_DIR``,
        default ``~/.cache/auralize``); a path: that folder; False: no cache.

    Returns
    -------
    SoundTexture
    """
    check_diameter(section.diameter)
    for nm, v, lo in (
        ("speed", speed, 0.0),
        ("duration", duration, 0.0),
        ("rate", rate, 1000.0),
        ("reynolds", reynolds, 1.0),
        ("harmonics", harmonics, 1.0),
    ):
        if not (math.isfinite(float(v)) and float(v) > lo):
            raise ParameterError(f"{nm} must be > {lo:g}, got {v!r}")
    if int(resolution) < 6:
        raise ParameterError(f"resolution must be >= 6 cells across D, got {resolution!r}")
    if not 0.01 <= u_lattice <= 0.15:
        raise ParameterError(f"u_lattice must be in [0.01, 0.15] (low Mach), got {u_lattice!r}")
    dirs = sample_directions(section, n=directions)
    params = {
        "shape": section.name,
        "diameter_m": section.diameter,
        "polygon": None if section.polygon is None else np.round(section.polygon, 12).tolist(),
        "speed_mps": float(speed),
        "duration_s": float(duration),
        "rate_hz": float(rate),
        "resolution": int(resolution),
        "reynolds": float(reynolds),
        "u_lattice": float(u_lattice),
        "directions_deg": dirs.tolist(),
        "harmonics": float(harmonics),
        "rho0": float(rho0),
        "seed": int(seed),
        "solver": "lbm-d2q9-bgk-v1",
    }
    cpath = _cache_path(cache, params)
    if cpath is not None and cpath.exists():
        try:
            return SoundTexture.load(cpath)
        except FormatError:
            pass  # a damaged cache entry is recomputed
    t_start = time.perf_counter()
    D = section.diameter
    dx = D / resolution
    dt = dx * u_lattice / speed
    nu = u_lattice * resolution / reynolds
    Dc = section.circumdiameter
    nx = int(math.ceil(16 * Dc / dx))
    ny = 2 * int(math.ceil(4 * Dc / dx))
    x = (np.arange(nx) + 0.5) * dx - 4 * Dc
    y = (np.arange(ny) + 0.5) * dx - 0.5 * ny * dx + 0.1 * dx  # slight offset: no exact symmetry
    X, Y = np.meshgrid(x, y)
    f_scale = rho0 * (speed / u_lattice) ** 2 * dx  # lattice force -> N/m
    est_period = D / (0.2 * speed)
    n_rec = int(math.ceil((duration + 1.5 * est_period) / dt))
    from auralize.runtime.resources import require_memory

    # D2Q9 populations (two copies) and fields on the lattice, plus the recorded forces
    require_memory(
        nx * ny * 9 * 8 * 4.0 + n_rec * 8 * 8.0,
        f"a {nx} x {ny} lattice recording {n_rec} steps ({duration:g} s at "
        f"resolution {resolution})",
        hint="lower --resolution or --duration",
    )
    gs, fs, lens, sts, info = [], [], [], [], []
    for j, th_deg in enumerate(dirs):
        th = np.deg2rad(th_deg)
        c, s = np.cos(th), np.sin(th)
        solid = section.contains(c * X - s * Y, s * X + c * Y)  # lattice point in body frame
        solid[:, :2] = solid[:, -2:] = False
        solid[:2, :] = solid[-2:, :] = False
        rec = simulate(
            solid,
            u_lat=u_lattice,
            nu_lat=nu,
            record_steps=n_rec,
            d_cells=float(resolution),
            seed=seed + j,
        )
        F_lat = rec.force * f_scale  # (n, 2) lattice frame, N/m
        # spectrum of the lift -> shedding frequency
        lift = F_lat[:, 1] - F_lat[:, 1].mean()
        nfft = 1 << int(math.ceil(math.log2(lift.size * 8)))
        spec = np.abs(np.fft.rfft(lift * np.hanning(lift.size), nfft))
        freqs = np.fft.rfftfreq(nfft, dt)
        spec[freqs < 0.2 / (n_rec * dt) * 10] = 0
        f_shed = float(freqs[np.argmax(spec)])
        if not f_shed > 0:
            raise ParameterError(f"no vortex shedding found for {section.name} at {th_deg:g}°")
        fc = min(harmonics * f_shed, 0.45 * rate, 0.45 / dt)
        sos = signal.butter(6, fc, fs=1.0 / dt, output="sos")
        F_lp = signal.sosfiltfilt(sos, F_lat, axis=0)
        G = np.gradient(F_lp, dt, axis=0)
        tt = np.arange(0.0, (n_rec - 1) * dt, 1.0 / rate)
        tsim = np.arange(n_rec) * dt
        Gr = np.stack([np.interp(tt, tsim, G[:, k]) for k in range(2)], 1)
        Fr = np.stack([np.interp(tt, tsim, F_lp[:, k]) for k in range(2)], 1)
        both, N = _loop(np.concatenate([Gr, Fr], 1), Fr[:, 1])
        R = np.array([[c, -s], [s, c]])  # lattice -> body frame
        gs.append(both[:, :2] @ R.T)
        fs.append(both[:, 2:] @ R.T)
        lens.append(N)
        sts.append(f_shed * D / speed)
        info.append(
            {
                "periodic": rec.periodic,
                "warmup_steps": rec.warmup_steps,
                "lattice": [ny, nx],
                "period_steps": rec.period_steps,
            }
        )
        if progress is not None:
            progress(j + 1, dirs.size)
    Nmax = max(lens)
    g = np.zeros((dirs.size, Nmax, 2))
    F = np.zeros((dirs.size, Nmax, 2))
    for j, (a, b) in enumerate(zip(gs, fs, strict=True)):
        g[j, : a.shape[0]] = a
        F[j, : b.shape[0]] = b
    meta = {
        **params,
        "polygon": None,
        "dt_lattice_s": dt,
        "dx_m": dx,
        "nu_lattice": nu,
        "directions": info,
        "seconds": time.perf_counter() - t_start,
    }
    tex = SoundTexture(
        section,
        float(speed),
        float(rate),
        dirs,
        g,
        F,
        np.asarray(lens, dtype=np.int64),
        np.asarray(sts),
        meta,
    )
    if cpath is not None:
        cpath.parent.mkdir(parents=True, exist_ok=True)  # the cache folder is auralize's own
        tex.save(cpath)
    return tex


def cache_dir(cache: bool | str | Path = True) -> Path | None:
    if cache is False:
        return None
    if cache is True:
        from auralize.runtime.cache import ENV, cache_root

        # AURALIZE_CACHE: the older name of the variable, still honoured
        old = os.environ.get("AURALIZE_CACHE")
        return (Path(old) if old and not os.environ.get(ENV) else cache_root()) / "aero"
    return Path(cache)


def _cache_path(cache: bool | str | Path, params: dict[str, Any]) -> Path | None:
    d = cache_dir(cache)
    if d is None:
        return None
    key = hashlib.sha256(json.dumps(params, sort_keys=True).encode()).hexdigest()[:20]
    return d / f"{params['shape']}-{key}.h5"


def texture_from_file_or_compute(path: str | Path) -> SoundTexture:
    return SoundTexture.load(path)
