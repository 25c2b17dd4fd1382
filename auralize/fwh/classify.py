"""Do the data hold sound, or sources of sound?

A compressible simulation that resolves acoustics stores the sound waves
themselves: outside its sources its pressure and density fluctuations obey
the wave equation.  Summing such a field over the volume as Lighthill sources
(paper 003 §3.2) mis-hears it: Lighthill's source is exactly what the wave
equation leaves over,

    ∂²ρ'/∂t² − c0² ∇²ρ' = ∂²T_ij/∂x_i∂x_j          (paper 003 Eq. 1)

so where the data hold waves the volume sum hears the difference of two large,
nearly equal terms, its discretisation error.  The Ffowcs Williams–Hawkings
integral on a surface around them (:mod:`auralize.fwh.formulation`)
propagates the waves instead.  Data that hold sources (an incompressible or
low-Mach flow, a blob that pulsates in place) are far from obeying it.

The test is that left-over at each point, relative to the two terms:

    share = |g_tt − c0² ∇²g| / (|g_tt| + c0² |∇²g|),     g = ∂f/∂t

(f the pressure, else the density; g obeys the wave equation wherever f does,
and holds no steady background; central differences in time and the 7-point
Laplacian, at the interior points where the field changes), and the
residual is its median over the points and sampled steps.  Linear sound gives
a residual of the order of the discretisation error (a few per cent at 20
points per wavelength and period), however near the field of a point source
it is; a region that holds sources (one term without the other, share near 1)
is a minority of the points of data that hold sound.  The data
hold sound when the residual is below :data:`WAVE_RESIDUAL`.  It needs the
data in metres and seconds; data in other units give residuals near 1 and
are taken as holding sources (the volume sum, the default).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from auralize.constants import C0
from auralize.volume import TimeVolume

#: residual (module docstring) below which the data hold sound: the share of the field's
#: second time derivative that the wave equation at c0 does not explain
WAVE_RESIDUAL = 0.3
#: time steps tested (spread over the series; five frames read at each)
SAMPLE_STEPS = 6


@dataclass(frozen=True)
class WaveTest:
    """Whether a field obeys the wave equation at c0 (:func:`wave_test`).

    ``residual`` the share of its second time derivative the wave equation
    leaves over; ``field`` the field tested; ``steps`` the time steps tested at;
    ``c0`` the speed of sound used (m/s).
    """

    residual: float
    field: str
    steps: tuple[int, ...]
    c0: float

    @property
    def holds_sound(self) -> bool:
        """Whether the data hold sound waves (``residual`` < :data:`WAVE_RESIDUAL`)."""
        return self.residual < WAVE_RESIDUAL

    def describe(self) -> str:
        """One line: what the data hold and why."""
        how = (
            f"{self.field!r} obeys the wave equation at c0 = {self.c0:g} m/s to "
            f"{100 * self.residual:.0f} %"
        )
        if self.holds_sound:
            return f"the data hold sound waves: {how}"
        return f"the data hold sources of sound: {how} (waves would leave < {100 * WAVE_RESIDUAL:.0f} %)"


def _scalar_field(volume: TimeVolume) -> str | None:
    """The field whose fluctuations are measured: pressure, else density (by their
    roles' usual names), else None."""
    from auralize.sources.mapping import match_field

    for role in ("pressure", "density"):
        name = match_field(volume, role)
        if name is not None and not volume.is_vector(name):
            return str(name)
    return None


def wave_test(volume: TimeVolume, field: str | None = None, *, c0: float = C0) -> WaveTest | None:
    """How far ``field`` is from obeying the wave equation at ``c0`` (module docstring),
    or None when it cannot be told (fewer than 3 steps, no pressure or density
    field, fewer than 5 steps or 3 points along an axis, or a field that does not change).

    Reads 5 frames of one field around each of :data:`SAMPLE_STEPS` steps;
    differentiates on the uniform grid (a curvilinear grid: on its index grid
    scaled by the mean spacing, an estimate).

    Examples
    --------
    >>> from auralize.datasets.synthetic import make_dataset
    >>> wt = wave_test(make_dataset("monopole", size=16, steps=24))
    >>> wt.holds_sound, wt.field
    (False, 'density')
    """
    name = field if field is not None else _scalar_field(volume)
    T = volume.n_steps
    if name is None or T < 5 or sum(d >= 3 for d in volume.dims) < 2:
        return None
    frames = volume.fields[name]
    t = np.asarray(volume.times, dtype=np.float64)

    read: dict[int, np.ndarray] = {}

    def frame(j: int) -> np.ndarray:  # each frame read once (five per sampled step)
        if j not in read:
            read[j] = np.asarray(frames.read(j), dtype=np.float64)
        return read[j]

    def rate(k: int) -> np.ndarray:  # ∂f/∂t at step k (central)
        return np.asarray((frame(k + 1) - frame(k - 1)) / (t[k + 1] - t[k - 1]))

    at = np.unique(np.linspace(2, T - 3, min(T - 4, SAMPLE_STEPS)).round().astype(int))
    h = np.asarray(volume.spacing, dtype=np.float64)[::-1]  # (z, y, x), as the arrays
    c2 = float(c0) ** 2
    core = tuple(slice(1, -1) if n >= 3 else slice(None) for n in volume.shape)
    shares = []
    for n in at:
        read.clear()
        a, f, b = rate(n - 1), rate(n), rate(n + 1)
        d1, d2 = float(t[n] - t[n - 1]), float(t[n + 1] - t[n])
        # the second derivative on uneven steps: 2 (d1 (b − f) − d2 (f − a)) / (d1 d2 (d1 + d2))
        ftt = (2.0 * (d1 * (b - f) - d2 * (f - a)) / (d1 * d2 * (d1 + d2)))[core]
        wave = np.zeros_like(ftt)
        for ax in range(3):  # the 7-point Laplacian (axes of fewer than 3 points left out)
            if f.shape[ax] >= 3:
                across = list(core)
                across[ax] = slice(None)
                wave += np.diff(f, 2, axis=ax)[tuple(across)] / h[ax] ** 2
        wave *= c2
        size = np.abs(ftt) + np.abs(wave)
        top = float(np.max(size, initial=0.0))
        if not (np.isfinite(top) and top > 0):
            continue
        # points where the field changes (not round-off around a still region)
        on = size > 1e-6 * top
        shares.append(np.abs(ftt - wave)[on] / size[on])
    if not shares:
        return None
    # the median point: a source region inside the data (and the singular points of a
    # point source) are a minority of the points, the waves fill the rest
    residual = float(np.median(np.concatenate(shares)))
    return WaveTest(
        residual=residual, field=str(name), steps=tuple(int(n) for n in at), c0=float(c0)
    )


#: the ``--method`` choices: ``auto`` picks ``fwh`` for data that hold sound
METHODS = ("auto", "volume", "fwh")
#: the default FW-H box lies this share of the data's extent inside each face (at
#: least :data:`INSET_CELLS` cells): away from the absorbing layers simulations put there
INSET_SHARE = 0.1
INSET_CELLS = 3


@dataclass(frozen=True)
class Method:
    """How a render hears a volume (:func:`choose_method`).

    ``name`` ``"volume"`` (the volume sum of its sources, paper 003) or
    ``"fwh"`` (the FW-H integral on ``surface``, a surface spec as the
    ``fwh`` model's); ``why`` in words; ``test`` the wave test, when run.
    """

    name: str
    why: str
    surface: str | None = None
    test: WaveTest | None = None

    def describe(self) -> str:
        """One line for the user: the method and why."""
        what = (
            "the FW-H surface integral (Farassat 1A) on " + str(self.surface)
            if self.name == "fwh"
            else "the volume sum of its sources (paper 003)"
        )
        return f"method: {what}; {self.why}"


def default_surface(volume: TimeVolume) -> str:
    """The default FW-H surface of ``volume``: a box :data:`INSET_SHARE` of the extent (at
    least :data:`INSET_CELLS` cells) inside each face, as a surface spec."""
    b = np.asarray(volume.bounds, dtype=np.float64).reshape(3, 2)
    ext = b[:, 1] - b[:, 0]
    inset = np.maximum(INSET_SHARE * ext, INSET_CELLS * np.asarray(volume.spacing, dtype=float))
    lo, hi = b[:, 0] + inset, b[:, 1] - inset
    return "box=" + ";".join(f"{v:.6g}" for pair in zip(lo, hi, strict=True) for v in pair)


def fwh_unavailable(volume: TimeVolume) -> str | None:
    """Why the FW-H integral cannot run on ``volume`` (None when it can)."""
    from auralize.errors import FieldError
    from auralize.fwh.sampling import resolve_fields

    if volume.coords is not None:
        return "it runs on uniform grids (this one is curvilinear: add --resample)"
    if min(volume.dims) < 2 * INSET_CELLS + 2:
        return (
            f"the grid ({' x '.join(map(str, volume.dims))} points) is too thin for a closed "
            f"surface inside it"
        )
    try:
        resolve_fields(volume)
    except FieldError as exc:
        return str(exc)
    return None


def choose_method(
    volume: TimeVolume, method: str = "auto", *, surface: str | None = None, c0: float = C0
) -> Method:
    """How to hear ``volume``: ``"volume"``, ``"fwh"``, or ``"auto"``: the FW-H integral on
    ``surface`` (default :func:`default_surface`) when the data hold sound
    (:func:`wave_test`) and the integral can run (:func:`fwh_unavailable`), else
    the volume sum.

    Raises
    ------
    ParameterError
        An unknown method, or ``"fwh"`` on data it cannot run on.

    Examples
    --------
    >>> from auralize.datasets.synthetic import make_dataset
    >>> m = choose_method(make_dataset("monopole", size=16, steps=24))
    >>> m.name, m.why.startswith("the data hold sources of sound")
    ('volume', True)
    """
    from auralize.errors import ParameterError

    if method not in METHODS:
        raise ParameterError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if method == "volume":
        return Method("volume", "as asked (--method volume)")
    cannot = fwh_unavailable(volume)
    if method == "fwh":
        if cannot is not None:
            raise ParameterError(f"--method fwh: {cannot}")
        return Method("fwh", "as asked (--method fwh)", surface or default_surface(volume))
    test = wave_test(volume, c0=c0)
    if test is None:
        return Method(
            "volume",
            "whether the data hold sound waves could not be told (it needs "
            "a changing pressure or density over 5 steps or more)",
        )
    if not test.holds_sound:
        return Method("volume", test.describe(), test=test)
    if cannot is not None:
        return Method(
            "volume",
            f"{test.describe()}, but the FW-H integral cannot run: {cannot}; "
            f"the volume sum mis-hears sound waves",
            test=test,
        )
    return Method("fwh", test.describe(), surface or default_surface(volume), test=test)
