"""What is heard: the sound of the whole field, not of the detected sources.

Detection (:mod:`auralize.sources.detection`, paper 003 §3.2.3–3.2.4) decides
what is *drawn*: each vertex one type, thresholds, ΔV spheres.  Used to decide
what is *heard*, it breaks the cancellation that the far field of a flow rests
on: over a compact region Lighthill's ∫ ∂²T_ij/∂x_i∂x_j dV is zero at equal
retarded times, and the sound is what the retardation leaves, so cutting away
the weak tails of a source region can make a render tens of dB too loud.  By
default (``heard="field"``) the sound is summed over every valid point with no
threshold:

* **quadrupole term** — Lighthill's source ∂²T_ij/∂x_i∂x_j of the fluctuating
  stress T_ij = ρ̃ v_i v_j (all nine terms), the stress minus the field's
  local steady state (:class:`auralize.sources.detection.SteadyBase`), so a
  flow that is steady, or has become steady, is silent;
* **monopole term** — the mass the data create: the residual of continuity
  Q = ∂ρ̃/∂t + ∇·(ρ̃ v), where it rises above its own discretisation error
  (the h and 2h, Δt and 2Δt stencils compared).  For data without a velocity
  field this is ∂ρ̃/∂t, paper 003's monopole.

Why not also the paper's dipole ∂/∂x_i ∂(ρ̃ v_i)/∂t and its monopole ∂ρ̃/∂t in
a flow: by continuity ∂ρ̃/∂t = Q − ∇·(ρ̃v), and by the momentum equation
∂(ρ̃v_i)/∂t = −∂_j(ρ̃ v_i v_j + p δ_ij) + F_i, so in a flow the paper's three
strengths are views of one sound (Lighthill's equation is continuity and
momentum combined); adding them counts it up to three times.  The stress
term carries what the momentum equation holds; Q carries the mass sources the
stress does not.  Force (dipole) terms would need the pressure and the forces
in the data; none is added.  For the ``incompressible`` mapping, whose density
is made from the pressure (ρ' = p'/c0², not a mass the flow carries),
continuity is that of the incompressible flow, Q = ρ0 ∇·v, truncation error
for a good solution.  For ``paper-density`` (a log-density sonification whose
velocity is the density gradient, not a flow) the monopole term is ∂ρ̃/∂t as
in the paper.

Units: the pressure is p = 1/(4π) Σ S ΔV / D evaluated at retarded time
(:mod:`auralize.emitters.synthesis`).  For the stress term this is Lighthill's
acoustic pressure c0² ρ' in pascals; the monopole term follows paper 003
Eq. 6, the pressure proportional to the rate of mass change (physically a
mass source Q radiates ∂Q/∂t/(4πD); the paper's form is kept so that scalar
data sound as they did, and it is what ``heard="detected"`` renders too).

**Cheap enough to hear every point.**  Summing every point costs ten to
twenty times the detected sources, so the field is cut into blocks of
``b³`` points and each block is replaced by ``p³`` proxy points at Chebyshev
nodes inside it whose strengths are the block's strengths weighted by the
Lagrange polynomials of the nodes (tensor products, degree p − 1 per axis):
the retarded-time kernel q(t − D/c0)/D is a smooth function of the source
position inside the block, and Σ_y L_k(y) s_y is exactly what interpolating
it at the nodes needs (the kernel-independent multipole method of Fong &
Darve, 2009; every moment of the block up to degree p − 1 per axis is kept,
so the monopole, dipole and quadrupole moments and the directivity they make
are exact).  Each proxy is an ordinary point of the engine: its own retarded
time, Doppler shift and panning.  Blocks the listener comes nearer to than
:data:`NEAR_BLOCKS` block sizes are kept as their points; without a path
(live listening, a scene's model) every block is compressed, and a listener
who comes into one hears it from no nearer than half its extent (the proxies'
clamp radius): bounded, blurred, where the interpolation does not hold.  The block size
follows from the error rule in ``docs/design.md`` (:func:`block_plan`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.curvilinear import curvilinear_residual
from auralize.errors import ParameterError
from auralize.runtime.progress import progress
from auralize.sources import _kernels as K
from auralize.sources.detection import (
    ROUNDOFF,
    TYPES,
    SteadyBase,
    StepCache,
    check_steady,
    input_scale,
    require_steps,
    steady_anchors,
    step_strengths,
)
from auralize.sources.mapping import AcousticMapping
from auralize.volume import TimeVolume

#: the terms of the whole-field sound (their kind codes: 1 monopole, 3 quadrupole)
FIELD_TERMS = ("monopole", "quadrupole")
#: what can be heard: the whole field, or the detected sources (paper 003)
HEARD_MODES = ("field", "detected")
#: a residual not above this many times its discretisation-error estimate is not a source
FLOOR = 3.0
#: blocks nearer to the listener's path than this many block sizes (from their
#: centre) are heard as their points
NEAR_BLOCKS = 2.5
#: proxies per block axis
PROXIES = 6
#: largest block (points per axis)
MAX_BLOCK = 16
#: target error of the block compression against the every-point sum (RMS)
TARGET_ERROR = 0.02


@dataclass(frozen=True)
class Heard:
    """What a render hears.

    Built from a user's spec by :func:`parse_heard`, which checks it (the
    class itself takes its fields as given).

    Parameters
    ----------
    mode : {"field", "detected"}
        ``"field"`` (the whole field, every valid point, no threshold) or
        ``"detected"`` (paper 003's detected sources, §3.2.3–3.2.4).
    types : tuple of str
        The source types heard (the others muted), in the order of
        :data:`auralize.sources.detection.TYPES`.  In ``field`` mode the types
        are its terms (:data:`FIELD_TERMS`: ``"monopole"`` the continuity
        residual, ``"quadrupole"`` Lighthill's stress).

    Examples
    --------
    >>> Heard()
    Heard(mode='field', types=('monopole', 'quadrupole'))
    >>> Heard("detected", ("dipole",)).label
    'detected:dipole'
    """

    mode: str = "field"
    types: tuple[str, ...] = FIELD_TERMS

    @property
    def label(self) -> str:
        """``field``, ``detected``, or the mode and the types heard (``detected:dipole,quadrupole``).

        A spec :func:`parse_heard` reads (types in the order of
        :data:`auralize.sources.detection.TYPES`).

        Examples
        --------
        >>> Heard().label, Heard("field", ("quadrupole",)).label
        ('field', 'field:quadrupole')
        >>> parse_heard(Heard("detected", ("monopole", "dipole")).label).types
        ('monopole', 'dipole')
        """
        every = FIELD_TERMS if self.mode == "field" else TYPES
        if tuple(self.types) == tuple(every):
            return self.mode
        return f"{self.mode}:{','.join(self.types)}"

    def describe(self) -> str:
        """One phrase for reports: what was heard.

        Returns
        -------
        str
            ``"whole field: "`` and its terms, or ``"detected "`` and the types.

        Examples
        --------
        >>> Heard().describe()
        'whole field: mass sources (continuity residual) + Lighthill stress'
        >>> Heard("detected", ("dipole", "quadrupole")).describe()
        'detected dipole, quadrupole'
        """
        if self.mode == "field":
            parts = {
                "monopole": "mass sources (continuity residual)",
                "quadrupole": "Lighthill stress",
            }
            return "whole field: " + " + ".join(parts[t] for t in self.types)
        return "detected " + ", ".join(self.types)


_TYPE_ALIASES = {"monopoles": "monopole", "dipoles": "dipole", "quadrupoles": "quadrupole"}


def parse_heard(spec: str | Heard | None) -> Heard:
    """A :class:`Heard` from ``"field"``, ``"detected"``, a list of types
    (``"dipole,quadrupole"``: the detected sources of those types) or
    ``"field:quadrupole"`` (one term of the whole field).

    Parameters
    ----------
    spec : str, Heard or None
        ``"field"`` or None (the default: the whole field, both terms),
        ``"field:TERMS"``, ``"detected"``, ``"detected:TYPES"`` or bare
        ``TYPES`` (detected sources); TYPES separated by commas, ``+`` or
        spaces, case-insensitive, plurals accepted.  A :class:`Heard` is
        returned as it is.

    Returns
    -------
    Heard
        The types in the order of :data:`auralize.sources.detection.TYPES`.

    Raises
    ------
    ParameterError
        A type that is not a source type (``detected``) or not a term of the
        whole field (``field``), or separators and no type (``"detected:,"``;
        nothing after the colon means every type).

    Examples
    --------
    >>> parse_heard("detected").types
    ('monopole', 'dipole', 'quadrupole')
    >>> parse_heard("dipole,quadrupole").label
    'detected:dipole,quadrupole'
    >>> parse_heard("field:quadrupole").describe()
    'whole field: Lighthill stress'
    >>> parse_heard("Quadrupoles + monopoles").label
    'detected:monopole,quadrupole'
    >>> parse_heard("field:dipole")
    Traceback (most recent call last):
    ...
    auralize.errors.ParameterError: heard 'field:dipole': 'dipole' is not a term of the whole field; ...
    """
    if isinstance(spec, Heard):
        return spec
    s = "field" if spec is None else str(spec).strip().lower()
    mode, _, rest = s.partition(":")
    if mode not in HEARD_MODES:
        mode, rest = "detected", s
    every = FIELD_TERMS if mode == "field" else TYPES
    if not rest:
        return Heard(mode, every)
    names = [
        _TYPE_ALIASES.get(t.strip(), t.strip()) for t in re.split(r"[,+ ]+", rest) if t.strip()
    ]
    bad = [t for t in names if t not in every]
    if bad or not names:
        raise ParameterError(
            f"heard {spec!r}: {', '.join(map(repr, bad)) or 'no type'} is not a "
            f"{'term of the whole field' if mode == 'field' else 'source type'}; give 'field', "
            f"'detected', a list of types such as 'dipole,quadrupole' (detected sources of those "
            f"types) or 'field:{'|'.join(FIELD_TERMS)}'"
        )
    return Heard(mode, tuple(t for t in every if t in names))


def mass_flux_rule(mapping: AcousticMapping, volume: TimeVolume) -> str:
    """How the continuity residual of ``mapping`` is made: ``"mapped"`` (∂ρ̃/∂t +
    ∇·(ρ̃v)), ``"constant"`` (ρ0 ∇·v: the incompressible mapping) or ``"none"``
    (∂ρ̃/∂t, paper 003's monopole: no velocity, or a mapping whose velocity
    is not a flow).

    Parameters
    ----------
    mapping : AcousticMapping
        The acoustic mapping (its ``mass_flux`` attribute names the rule).
    volume : TimeVolume
        The volume it maps.

    Returns
    -------
    str
        ``"mapped"``, ``"constant"`` or ``"none"``.

    Examples
    --------
    >>> from auralize.datasets.synthetic import make_monopole, make_spinning
    >>> from auralize.sources.mapping import get_mapping
    >>> mass_flux_rule(get_mapping("identity"), make_monopole(size=4, steps=2))  # density only
    'none'
    >>> mass_flux_rule(get_mapping("identity"), make_spinning(size=4, steps=2))  # and velocity
    'mapped'
    """
    if not has_flow(mapping, volume):
        return "none"
    return str(getattr(mapping, "mass_flux", "mapped"))


def has_flow(mapping: AcousticMapping, volume: TimeVolume) -> bool:
    """Whether ``mapping`` gives ``volume`` a velocity (else no stress term).

    Parameters
    ----------
    mapping : AcousticMapping
        The acoustic mapping.
    volume : TimeVolume
        The volume it maps.

    Returns
    -------
    bool
        False when the mapping reports the quadrupole strength unavailable
        for ``volume`` (no velocity field).

    Examples
    --------
    >>> from auralize.datasets.synthetic import make_monopole, make_spinning
    >>> from auralize.sources.mapping import get_mapping
    >>> m = get_mapping("identity")
    >>> has_flow(m, make_monopole(size=4, steps=2)), has_flow(m, make_spinning(size=4, steps=2))
    (False, True)
    """
    return not mapping.unavailable(volume).get("quadrupole")


@dataclass
class BlockPlan:
    """How the field's points are grouped: blocks of ``block`` points per axis
    (x, y, z), ``proxies`` Chebyshev nodes per axis in each.

    Made by :func:`block_plan`.

    Parameters
    ----------
    block : tuple of 3 int
        Points per block along x, y, z.
    proxies : tuple of 3 int
        Proxy points (Chebyshev nodes) per block along x, y, z; as many as
        the block's points: the block is heard as its points.
    size : float
        The largest block extent, m.
    rule : str
        Why this block size (for reports).

    Examples
    --------
    >>> plan = BlockPlan(block=(8, 8, 8), proxies=(6, 6, 6), size=0.14)
    >>> plan.compresses
    True
    """

    block: tuple[int, int, int]
    proxies: tuple[int, int, int]
    #: the largest block extent (m)
    size: float
    #: why this block size
    rule: str = ""

    @property
    def compresses(self) -> bool:
        """Whether any axis has fewer proxies than points (the blocks are compressed).

        Examples
        --------
        >>> BlockPlan(block=(4, 4, 4), proxies=(4, 4, 4), size=0.75).compresses
        False
        """
        return any(p < b for p, b in zip(self.proxies, self.block, strict=True))


def block_plan(
    volume: TimeVolume, *, block: int | None = None, proxies: int = PROXIES, c0: float = 343.0
) -> BlockPlan:
    """The blocks of :func:`field_tracks` (``block`` points per axis, default by the rule).

    The rule (docs/design.md, "Hearing the whole field"): a block of extent B
    with p Chebyshev nodes per axis interpolates the retarded kernel
    e^{−ik|x−y|} to within about 3 · 2 (kB/4)^p / p! (the Chebyshev bound,
    three axes), k = 2π f / c0 at the data's Nyquist frequency f = 1/(2Δt),
    the highest the data can hold.  The block is the largest (up to
    :data:`MAX_BLOCK` points) that keeps this under :data:`TARGET_ERROR`;
    data sampled faster than sound crosses a few cells are not compressed.
    On a curvilinear grid the cell size is its longest edge along each index
    direction (the blocks are index blocks: the largest one sets the bound).
    The blocks along each axis are as few as the size allows and of equal
    size, so a block may be smaller than ``block``.

    Parameters
    ----------
    volume : TimeVolume
        Its grid spacing (m), dims and step times (s; the shortest step sets
        the Nyquist frequency, 1 s for a single step).
    block : int, optional
        Points per block axis (1 hears every point as itself); default by the
        rule above.
    proxies : int
        Chebyshev nodes per block axis, >= 2 (at most the block's points).
    c0 : float
        Speed of sound, m/s.

    Returns
    -------
    BlockPlan

    Raises
    ------
    ParameterError
        ``proxies`` below 2, or ``block`` not a positive whole number.

    Examples
    --------
    Data sampled at 2880 Hz on 2 cm cells: the rule allows blocks of up to
    17.5 cm with 6 proxies per axis, so this grid of 8 points per axis
    (14 cm) is one block, compressed:

    >>> from auralize.datasets.synthetic import make_spinning
    >>> plan = block_plan(make_spinning(size=8, steps=4))
    >>> plan.block, plan.proxies, plan.compresses
    ((8, 8, 8), (6, 6, 6), True)
    >>> block_plan(make_spinning(size=8, steps=4), block=1).compresses
    False
    """
    h = np.asarray(volume.spacing, dtype=np.float64)
    if volume.coords is not None:
        from auralize.curvilinear import max_edge

        h = max_edge(volume.coords, h)
    dims = tuple(int(d) for d in volume.dims)
    t = np.asarray(volume.times, dtype=np.float64)
    dt = float(np.min(np.diff(t))) if t.size >= 2 else 1.0
    p = int(proxies)
    if p < 2:
        raise ParameterError(f"proxies per block axis must be >= 2, got {proxies!r}")
    if block is None:
        k = math.pi / (c0 * dt)  # 2π (1/2Δt) / c0
        # largest B with 3 * 2 (kB/4)^p / p! <= TARGET_ERROR
        b_max = 4.0 / k * (TARGET_ERROR * math.factorial(p) / 6.0) ** (1.0 / p)
        hmax = float(np.max(h))
        nb = int(min(MAX_BLOCK, max(1, math.floor(b_max / hmax) + 1)))
        rule = (
            f"block of {b_max:.3g} m or less keeps the compression within "
            f"{TARGET_ERROR:.0%} at the data's Nyquist frequency ({0.5 / dt:.4g} Hz)"
        )
    else:
        if not isinstance(block, int | np.integer) or block < 1:
            raise ParameterError(f"block must be a positive number of points, got {block!r}")
        nb = int(block)
        rule = "given"
    # as few blocks per axis as the size allows, of equal size (little padding)
    b = tuple(-(-d // -(-d // max(1, min(nb, d)))) for d in dims)
    pr = tuple(min(p, bb) for bb in b)
    size = float(np.max((np.asarray(b) - 1) * h))
    return BlockPlan(block=b, proxies=pr, size=size, rule=rule)  # type: ignore[arg-type]


def _cheb_nodes(b: int, p: int) -> NDArray[np.float64]:
    """``p`` nodes in point units over ``[0, b − 1]``: the points themselves when
    ``p >= b``, else Chebyshev nodes of the first kind."""
    if p >= b:
        return np.arange(b, dtype=np.float64)
    k = np.arange(p)
    return 0.5 * (b - 1) * (1.0 - np.cos((2 * k + 1) * np.pi / (2 * p)))


def _lagrange(nodes: NDArray[np.float64], b: int) -> NDArray[np.float64]:
    """``(p, b)``: the Lagrange polynomial of each node at the points 0..b−1."""
    x = np.arange(b, dtype=np.float64)
    p = nodes.size
    out = np.ones((p, b))
    for k in range(p):
        for m in range(p):
            if m != k:
                out[k] *= (x - nodes[m]) / (nodes[k] - nodes[m])
    return out


def _trapezoid(dims: tuple[int, int, int], spacing: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cell volume of each point ``(nz, ny, nx)``: the trapezoid rule (half at faces)."""
    w = []
    for n, h in zip(dims[::-1], spacing[::-1], strict=True):  # z, y, x
        a = np.full(n, float(h))
        if n > 1:
            a[0] *= 0.5
            a[-1] *= 0.5
        w.append(a)
    return w[0][:, None, None] * w[1][None, :, None] * w[2][None, None, :]


@dataclass
class FieldTracks:
    """The whole field's heard sound as engine rows (proxies and points).

    Made by :func:`field_tracks`; :meth:`tracks` turns them into the
    engine's :class:`~auralize.sources.detection.SourceTracks`.

    Parameters
    ----------
    positions : ndarray, shape (R, 3)
        Row positions, m.
    q : dict of str to ndarray, shape (R, T)
        Per term (``"monopole"``, ``"quadrupole"``), S·ΔV of the rows (the
        proxies' Lagrange-weighted sums), as paper 003's q_k (Eqs. 15–17).
    radius : ndarray, shape (R,)
        Clamp radii, m (a listener nearer than that is heard from that far).
    times : ndarray, shape (T,)
        Data times of the steps, s.
    meta : dict
        Points, blocks, rows, the block plan, what was heard, ``c0`` and the
        grid's diagonal (``diagonal_m``, which :attr:`hold_steps` reads).

    Examples
    --------
    >>> import numpy as np
    >>> ft = FieldTracks(positions=np.zeros((1, 3)), q={"monopole": np.array([[0.0, 1, 2, 3]])},
    ...                  radius=np.full(1, 0.1), times=np.array([0.0, 0.1, 0.2, 0.3]))
    >>> tr = ft.tracks()
    >>> tr.q.tolist(), tr.t_first, tr.t_last
    ([[0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 3.0, 3.0]], 0.0, 0.3)
    """

    positions: NDArray[np.float64]
    q: dict[str, NDArray[np.float64]]
    radius: NDArray[np.float64]
    times: NDArray[np.float64]
    meta: dict[str, Any] = field(default_factory=dict)
    #: the tracks made so far per term tuple (:meth:`tracks`' cache)
    _made: dict[tuple[str, ...], Any] = field(default_factory=dict, init=False, repr=False)

    def tracks(self, terms: tuple[str, ...] | None = None) -> Any:
        """:class:`~auralize.sources.detection.SourceTracks` of the rows, the terms
        ``terms`` (default all) summed, silent rows dropped, ``kind`` the term's
        code where one term is asked for (cached: the engine keeps its pieces on them).

        The field is taken to go on before its first and after its last step as
        it was there (the data's edges are not events): each row's first and
        last values are held over 2 × :attr:`hold_steps` more steps on each side,
        beyond every arrival that can fall inside a render of the data (the
        engine's silent padding lies past them), so no track fades in or out
        where it can be heard.

        Parameters
        ----------
        terms : tuple of str, optional
            The terms summed (names of :attr:`q`; others are ignored); default all.

        Returns
        -------
        SourceTracks
            ``positions (K, 3)``, ``q (K, T + 4)`` at ``times (T + 4,)`` (two held
            knots on each side), ``radius (K,)``, ``origin``/``end`` the first and
            last data times; the same object on every call with these terms.

        Examples
        --------
        >>> import numpy as np
        >>> ft = FieldTracks(positions=np.zeros((2, 3)),
        ...                  q={"monopole": np.array([[1.0, 2.0], [0.0, 0.0]]),
        ...                     "quadrupole": np.array([[0.0, 0.0], [3.0, 4.0]])},
        ...                  radius=np.full(2, 0.1), times=np.array([0.0, 0.5]))
        >>> mono = ft.tracks(("monopole",))
        >>> mono.n_sources, mono.q.tolist(), mono.kind.tolist()
        (1, [[1.0, 1.0, 1.0, 2.0, 2.0, 2.0]], [[1, 1, 1, 1, 1, 1]])
        >>> ft.tracks().n_sources, ft.tracks() is ft.tracks()
        (2, True)
        >>> mono.times.tolist()  # held over 2 steps on each side
        [-2.0, -1.0, 0.0, 0.5, 1.5, 2.5]
        """
        from auralize.sources.detection import SourceTracks

        names = tuple(t for t in (terms or tuple(self.q)) if t in self.q)
        hit = self._made.get(names)
        if hit is not None:
            return hit
        T = self.times.size
        q = np.zeros((self.positions.shape[0], T + 4))
        for t in names:
            q[:, 2:-2] += self.q[t]
        q[:, :2] = q[:, 2:3]
        q[:, -2:] = q[:, -3:-2]
        keep = np.any(q != 0, axis=1)
        kind = None
        if len(names) == 1:
            code = 1 + TYPES.index(names[0])
            kind = np.where(q[keep] != 0, code, 0).astype(np.int8)
        t = self.times
        d0 = (t[1] - t[0]) if T >= 2 else 1.0
        d1 = (t[-1] - t[-2]) if T >= 2 else 1.0
        # two held knots on each side: the tangent at the inner one is 0, so the
        # field is exactly constant from it to the data
        h = self.hold_steps
        times = np.concatenate(
            [[t[0] - 2 * h * d0, t[0] - h * d0], t, [t[-1] + h * d1, t[-1] + 2 * h * d1]]
        )
        out = SourceTracks(
            positions=self.positions[keep],
            q=np.ascontiguousarray(q[keep]),
            radius=self.radius[keep],
            times=times,
            kind=kind,
            origin=float(t[0]),
            end=float(t[-1]),
        )
        self._made[names] = out
        return out

    @property
    def hold_steps(self) -> float:
        """Steps over which the first and last values are held (see :meth:`tracks`):
        enough for sound to cross the data's box, plus two.

        ``ceil(meta["diagonal_m"] / (meta["c0"] · Δt)) + 2`` with Δt the
        shortest step; 2 for a single step.

        Examples
        --------
        >>> import numpy as np
        >>> ft = FieldTracks(positions=np.zeros((1, 3)), q={}, radius=np.ones(1),
        ...                  times=np.arange(4) * 0.001, meta={"diagonal_m": 1.0, "c0": 343.0})
        >>> ft.hold_steps  # 1 m takes 2.9 steps of 1 ms to cross
        5.0
        """
        T = self.times.size
        if T < 2:
            return 2.0
        step = float(np.min(np.diff(self.times)))
        diag = float(self.meta.get("diagonal_m", 0.0))
        return float(math.ceil(diag / (float(self.meta.get("c0", 343.0)) * step)) + 2)


def _near_blocks(centres: NDArray[np.float64], path: Any, dist: float) -> NDArray[np.bool_]:
    """Which block ``centres (B, 3)`` the listener's path comes within ``dist`` of."""
    if path is None or centres.shape[0] == 0:
        return np.zeros(centres.shape[0], dtype=bool)
    from auralize.listener import near_path

    return near_path(centres, path, dist)


def field_tracks(
    volume: TimeVolume,
    mapping: AcousticMapping,
    *,
    heard: Heard | str | None = None,
    steady: str = "remove",
    floor: float = FLOOR,
    path: Any = None,
    block: int | None = None,
    proxies: int = PROXIES,
    c0: float = 343.0,
    progress_bar: bool = False,
) -> FieldTracks:
    """The whole field's sound as engine rows (see the module docstring).

    Parameters
    ----------
    volume : TimeVolume
        At least two steps; no-data points (``volume.valid`` False, NaN) are
        silent, and so is every strength whose stencil reads one.
    mapping : AcousticMapping
        Prepared for ``volume`` (:func:`auralize.pipeline.resolve_mapping`).
    heard : Heard or str
        ``"field"`` (default, both terms) or ``"field:quadrupole"`` /
        ``"field:monopole"`` (one term).
    steady : {"remove", "keep"}
        ``"remove"``: the stress minus its local steady state
        (:class:`~auralize.sources.detection.SteadyBase`).
    floor : float
        The residual counts where it is above ``floor`` times its
        discretisation-error estimate (0: everywhere).
    path : ListenerPath, optional
        Blocks it comes within :data:`NEAR_BLOCKS` block sizes of are heard
        as their points; without a path every block is compressed.
    block : int, optional
        Points per block axis (:func:`block_plan`, default by its rule;
        ``block=1`` hears every point as itself).
    proxies : int
        Proxies (Chebyshev nodes) per block axis, >= 2.
    c0 : float
        Speed of sound, m/s: sets the block size (:func:`block_plan`) and how
        long the tracks are held at the data's ends (:attr:`FieldTracks.hold_steps`).
    progress_bar : bool
        Show a progress bar over the steps on stderr.

    Returns
    -------
    FieldTracks
        The rows: the proxies of the compressed blocks, then the points of
        the blocks near the path; ``q`` per term heard.

    Raises
    ------
    DataError
        A volume of fewer than two steps.
    ParameterError
        ``heard`` not the whole field (or not a valid spec), ``steady`` not
        one of ``"remove"``/``"keep"``, or a bad ``block`` or ``proxies``.
    FieldError
        ``mapping`` needs a field ``volume`` does not have.

    Examples
    --------
    >>> from auralize.datasets.synthetic import make_monopole
    >>> from auralize.sources.mapping import get_mapping
    >>> vol = make_monopole(size=12, steps=8)
    >>> ft = field_tracks(vol, get_mapping("identity"))
    >>> ft.meta["terms"], ft.times.size, bool(ft.tracks().t_first == ft.times[0])
    (['monopole'], 8, True)
    """
    require_steps(volume)
    hd = parse_heard(heard)
    if hd.mode != "field":
        raise ParameterError(
            f"field_tracks renders the whole field; heard {hd.label!r} is "
            f"the detected sources (SourceSeries.tracks())"
        )
    check_steady(steady)
    mapping.prepare(volume)
    flux = mass_flux_rule(mapping, volume)
    terms = [t for t in hd.types if not (t == "quadrupole" and not has_flow(mapping, volume))]
    plan = block_plan(volume, block=block, proxies=proxies, c0=c0)
    nx, ny, nz = volume.dims
    bx, by, bz = plan.block
    px, py, pz = plan.proxies
    Bx, By, Bz = -(-nx // bx), -(-ny // by), -(-nz // bz)
    h = np.asarray(volume.spacing, dtype=np.float64)
    nodes = [_cheb_nodes(b, p) for b, p in ((bx, px), (by, py), (bz, pz))]
    A = [_lagrange(nd, b) for nd, b in zip(nodes, (bx, by, bz), strict=True)]
    # block centres and the near ones (heard as points)
    bi = np.stack(np.meshgrid(np.arange(Bx), np.arange(By), np.arange(Bz), indexing="ij"), -1)
    bi = bi.transpose(2, 1, 0, 3).reshape(-1, 3)  # (z, y, x) order of blocks, columns x, y, z
    blk = np.array([bx, by, bz])
    coords = volume.coords
    if coords is None:
        centres = volume.origin + (bi * blk + 0.5 * (blk - 1)) * h
    else:  # a curvilinear grid: the positions at those index positions
        from auralize.curvilinear import interp_coords

        centres = interp_coords(coords, bi * blk + 0.5 * (blk - 1))
    near = _near_blocks(centres, path, NEAR_BLOCKS * max(plan.size, float(np.max(h))))
    if not plan.compresses:
        near[:] = False  # blocks of single points: the proxies are the points
    far_blocks = np.flatnonzero(~near)
    near_blocks = np.flatnonzero(near)
    # proxy positions (far blocks) and point positions (near blocks)
    nd3 = np.stack(np.meshgrid(nodes[0], nodes[1], nodes[2], indexing="ij"), -1)  # (px, py, pz, 3)
    nd3 = nd3.transpose(2, 1, 0, 3).reshape(-1, 3)  # node order (z, y, x)
    P = nd3.shape[0]
    if coords is None:
        prox_pos = (volume.origin + (bi[far_blocks, None, :] * blk + nd3[None]) * h).reshape(-1, 3)
    else:
        prox_pos = interp_coords(coords, (bi[far_blocks, None, :] * blk + nd3[None]).reshape(-1, 3))
    # the points of the near blocks, as flat grid indices
    if near_blocks.size:
        lz, ly, lx = np.meshgrid(np.arange(bz), np.arange(by), np.arange(bx), indexing="ij")
        pts = bi[near_blocks][:, None, :] * blk + np.stack([lx, ly, lz], -1).reshape(-1, 3)[None]
        pts = pts.reshape(-1, 3)
        inside = np.all(pts < np.array([nx, ny, nz]), axis=1)
        pts = pts[inside]
        point_index = (pts[:, 2] * ny + pts[:, 1]) * nx + pts[:, 0]
    else:
        point_index = np.zeros(0, dtype=np.int64)
        pts = np.zeros((0, 3), dtype=np.int64)
    point_pos = volume.origin + pts * h if coords is None else volume.points(point_index)
    T = volume.n_steps
    R_prox, R_pts = far_blocks.size * P, point_index.size
    qs = {t: np.zeros((R_prox + R_pts, T)) for t in terms}
    dV = _trapezoid((nx, ny, nz), h) if volume.metric is None else volume.metric.cell_volume()
    pad = (Bz * bz - nz, By * by - ny, Bx * bx - nx)
    mask_far = np.zeros(Bz * By * Bx, dtype=bool)
    mask_far[far_blocks] = True
    cache = StepCache(
        volume,
        mapping,
        qmean=SteadyBase(volume, mapping, steady_anchors(volume, mapping))
        if steady == "remove" and "quadrupole" in terms
        else None,
    )
    buf = K.empty_like_strengths(volume.shape)
    res = np.empty(volume.shape)
    err = np.empty(volume.shape)
    stats = {"residual_points": 0, "residual_floored": 0}
    for n in progress(range(T), desc="field", enabled=progress_bar, unit="step"):
        per: dict[str, NDArray[np.float64]] = {}
        if "quadrupole" in terms:
            s = step_strengths(volume, cache, n, buf)
            per["quadrupole"] = s[2]
        if "monopole" in terms:
            per["monopole"] = _residual(
                volume, cache, n, flux=flux, floor=floor, out=res, err=err, stats=stats
            )
        for t, S in per.items():
            w = S * dV
            g = np.pad(w, ((0, pad[0]), (0, pad[1]), (0, pad[2]))) if any(pad) else w
            g6 = g.reshape(Bz, bz, By, by, Bx, bx)
            W = np.einsum("zcydxe,kc,ld,me->zyxklm", g6, A[2], A[1], A[0], optimize=True)
            qs[t][:R_prox, n] = W.reshape(Bz * By * Bx, P)[far_blocks].reshape(-1)
            if R_pts:
                qs[t][R_prox:, n] = w.reshape(-1)[point_index]
        cache.keep(n, n + 1)
    positions = np.concatenate([prox_pos, point_pos]) if R_pts else prox_pos
    # clamp radii: a point its half cell; a proxy half its block's extent, so that a
    # listener who comes into a compressed block (no path was given, or it strays from
    # it) hears the block as a source that far away, bounded, not the proxies' large
    # alternating weights over tiny distances (the interpolation holds only outside)
    cell = 0.5 * float(np.min(h))
    # a point's own half cell (on a curvilinear grid, of its cell volume |det ∂x/∂ξ|)
    pts_r = (
        np.full(R_pts, cell)
        if volume.metric is None
        else 0.5 * np.cbrt(volume.metric.jac.reshape(-1)[point_index])
    )
    radius = np.concatenate(
        [np.full(R_prox, max(0.5 * plan.size, cell) if plan.compresses else cell), pts_r]
    )
    meta = {
        "heard": hd.label,
        "heard_text": hd.describe(),
        "terms": terms,
        "mass_flux": flux,
        "points": int(volume.n_points),
        "valid_points": int(round(volume.n_points * volume.valid_ratio)),
        "blocks": int(Bz * By * Bx),
        "blocks_as_points": int(near_blocks.size),
        "block": list(plan.block),
        "proxies_per_block": int(P),
        "rows": int(R_prox + R_pts),
        "block_size_m": plan.size,
        "block_rule": plan.rule,
        "floor": floor,
        "steady": steady,
        "diagonal_m": _diagonal(volume),
        "c0": c0,
        "residual_share_above_floor": (stats["residual_points"] - stats["residual_floored"])
        / max(stats["residual_points"], 1),
    }
    return FieldTracks(
        positions=np.ascontiguousarray(positions),
        q=qs,
        radius=radius,
        times=np.asarray(volume.times, dtype=np.float64).copy(),
        meta=meta,
    )


def _diagonal(volume: TimeVolume) -> float:
    """The length of the grid's diagonal (of its bounding box on a curvilinear grid), m."""
    if volume.coords is None:
        h = np.asarray(volume.spacing, dtype=np.float64)
        return float(np.linalg.norm((np.asarray(volume.dims) - 1) * h))
    b = np.asarray(volume.bounds).reshape(3, 2)
    return float(np.linalg.norm(b[:, 1] - b[:, 0]))


def _residual(
    volume: TimeVolume,
    cache: StepCache,
    n: int,
    *,
    flux: str,
    floor: float,
    out: NDArray[np.float64],
    err: NDArray[np.float64],
    stats: dict[str, int],
) -> NDArray[np.float64]:
    """The continuity residual of step ``n`` (``flux`` as :func:`mass_flux_rule`),
    zero where it is not above ``floor`` times its error estimate or round-off."""
    T = volume.n_steps
    t = volume.times
    a, b = max(n - 1, 0), min(n + 1, T - 1)
    a2, b2 = max(n - 2, 0), min(n + 2, T - 1)
    rho_a, _, _, ok_a = cache.get(a)
    rho_b, _, _, ok_b = cache.get(b)
    _, v_c, m_c, ok_c = cache.get(n)
    inv_dt = 1.0 / (t[b] - t[a])
    wide = (a2, b2) != (a, b) and floor > 0
    rho_a2 = cache.get(a2)[0] if wide else rho_a
    rho_b2 = cache.get(b2)[0] if wide else rho_b
    inv_dt2 = 1.0 / (t[b2] - t[a2]) if wide else 0.0
    if flux == "none":
        m = np.zeros((*volume.shape, 3))
    elif flux == "constant":
        m = float(getattr(cache.mapping, "rho0", 1.2)) * v_c
        rho_a = rho_b = rho_a2 = rho_b2 = np.zeros(volume.shape)
    else:
        m = m_c
    oks = [o for o in (ok_a, ok_b, ok_c) if o is not None]
    bad = ~np.logical_and.reduce(oks) if oks else np.zeros(volume.shape, dtype=bool)
    metric = volume.metric
    if metric is None:
        K.residual(
            rho_a,
            rho_b,
            rho_a2,
            rho_b2,
            np.ascontiguousarray(m),
            inv_dt,
            inv_dt2,
            np.asarray(volume.spacing, dtype=np.float64),
            bad,
            out,
            err,
        )
    else:
        curvilinear_residual(
            metric,
            rho_a,
            rho_b,
            rho_a2,
            rho_b2,
            m_c=np.asarray(m),
            inv_dt=inv_dt,
            inv_dt2=inv_dt2,
            bad=bad,
            out=out,
            err=err,
        )
    if oks:
        # a residual whose stencil reads a no-data point is no-data too (as the dipole's)
        s3 = np.zeros((3, *volume.shape))
        s3[1] = out
        if metric is None:
            K.mask_nodata(bad, s3)
        else:
            metric.mask_nodata(bad, s3)
        out[...] = s3[1]
    stats["residual_points"] += int(np.count_nonzero(out))
    if floor > 0:
        scale = input_scale(volume, cache, n)
        s3 = np.zeros((3, *volume.shape))
        s3[0] = out
        e3 = np.zeros_like(s3)
        e3[0] = err
        before = int(np.count_nonzero(out))
        K.apply_floor(s3, e3, float(floor), np.array([ROUNDOFF * scale[0], 0.0, 0.0]))
        out[...] = s3[0]
        stats["residual_floored"] += before - int(np.count_nonzero(out))
    return out
