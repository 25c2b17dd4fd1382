"""Field roles: which field of a volume is its density, velocity, momentum or pressure.

Names are compared case-insensitively with the names the writing tools use
(:data:`ROLE_NAMES`); a vector stored as three scalar components
(:data:`COMPONENT_NAMES`) is assembled into one vector field
(:func:`assemble_vector`).  The readers (netCDF's components), the acoustic
mappings (:mod:`auralize.sources.mapping`, which re-exports these names) and
the command line's ``info`` all match fields here, below all of them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from auralize.volume import TimeVolume

Frame = NDArray[np.float64]


#: Names each role goes by, compared case-insensitively, in order of preference
#: (FLUENT ``SV_*``, CGNS, CF standard names after the generic ones).
ROLE_NAMES: dict[str, tuple[str, ...]] = {
    "density": ("density", "rho", "dens", "sv_density", "air_density", "sea_water_density"),
    "velocity": ("velocity", "u", "vel", "v", "flow_velocity", "sv_velocity"),
    "momentum": ("momentum", "rhou", "rho_u", "mom"),
    "pressure": (
        "pressure",
        "p",
        "press",
        "pres",
        "sv_p",
        "static_pressure",
        "air_pressure",
        "sea_water_pressure",
    ),
    "log10_density": ("log10_density", "log_density", "log10_rho", "logrho"),
}
#: Roles whose field is a 3-vector.
VECTOR_ROLES = ("velocity", "momentum")
#: Scalar (x, y, z) components a vector role may be stored as, compared
#: case-insensitively, in order of preference; a missing z is taken as 0 (2-D data).
COMPONENT_NAMES: dict[str, tuple[tuple[str, str, str], ...]] = {
    "velocity": (
        ("velocityx", "velocityy", "velocityz"),  # CGNS
        ("velocity_x", "velocity_y", "velocity_z"),
        ("sv_u", "sv_v", "sv_w"),  # FLUENT
        ("x_velocity", "y_velocity", "z_velocity"),
        ("u_x", "u_y", "u_z"),
        ("ux", "uy", "uz"),
        ("vx", "vy", "vz"),
        ("u", "v", "w"),
        ("eastward_wind", "northward_wind", "upward_air_velocity"),  # CF
        (
            "eastward_sea_water_velocity",
            "northward_sea_water_velocity",
            "upward_sea_water_velocity",
        ),
    ),
    "momentum": (
        ("momentumx", "momentumy", "momentumz"),  # CGNS
        ("momentum_x", "momentum_y", "momentum_z"),
        ("rhou", "rhov", "rhow"),
    ),
}


def _stacked(volume: TimeVolume, names: tuple[str | None, ...]) -> Callable[[int], Frame]:
    """A reader of the vector frame made of the scalar fields ``names`` (None: zeros)."""

    def read(step: int) -> Frame:
        parts = [volume._get(n).read(step) if n is not None else None for n in names]
        like = next(p for p in parts if p is not None)
        return np.stack([np.zeros(like.shape) if p is None else p for p in parts], axis=-1)

    return read


def assemble_vector(volume: TimeVolume, role: str) -> str | None:
    """The vector field of ``role`` assembled from scalar components, added to ``volume``.

    The first triple of :data:`COMPONENT_NAMES` whose x and y components are
    scalar fields of the volume is stacked (z is 0 when the volume has no z
    component: a 2-D flow) into a field named ``"(X, Y, Z)"`` after the
    components (``"(SV_U, SV_V, 0)"``), read on demand.  Returns its name, or
    None when no components are found.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.volume import TimeVolume
    >>> u = np.ones((2, 1, 2, 2))
    >>> vol = TimeVolume.from_arrays({"SV_U": u, "SV_V": 2 * u, "SV_P": u})
    >>> name = assemble_vector(vol, "velocity")
    >>> name, vol.frame(name, 0)[0, 0, 0].tolist()
    ('(SV_U, SV_V, 0)', [1.0, 2.0, 0.0])
    """
    from auralize.volume import CallableFrames

    scalars: dict[str, str] = {}
    for name in volume.field_names:
        if not volume.is_vector(name):
            scalars.setdefault(name.lower(), name)
    for triple in COMPONENT_NAMES.get(role, ()):
        found = tuple(scalars.get(c) for c in triple)
        if found[0] is None or found[1] is None:
            continue
        name = "(" + ", ".join(f if f is not None else "0" for f in found) + ")"
        if name not in volume.fields:
            shape = tuple(volume._get(found[0]).frame_shape)
            volume.fields[name] = CallableFrames(
                _stacked(volume, found), volume.n_steps, (*shape, 3)
            )
        return name
    return None


def match_field(volume: TimeVolume, role: str) -> str | None:
    """The field of ``volume`` that plays ``role`` (density, velocity, momentum, pressure).

    Names are compared case-insensitively against :data:`ROLE_NAMES`; a
    velocity or momentum must be a vector field, the others scalars.  A vector
    role stored as scalar components (:data:`COMPONENT_NAMES`) is assembled
    into a vector field of the volume (:func:`assemble_vector`).

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"U": np.zeros((2, 2, 2, 2, 3)), "p": np.zeros((2, 2, 2, 2))})
    >>> match_field(vol, "velocity"), match_field(vol, "pressure"), match_field(vol, "density")
    ('U', 'p', None)
    """
    want_vector = role in VECTOR_ROLES
    by_lower: dict[str, str] = {}
    for name in volume.field_names:
        if volume.is_vector(name) == want_vector:
            by_lower.setdefault(name.lower(), name)
    for candidate in ROLE_NAMES.get(role, (role,)):
        if candidate in by_lower:
            return by_lower[candidate]
    if want_vector:
        return assemble_vector(volume, role)
    return None


#: Which tool or convention writes a role's name (lower case).
_NAME_ORIGINS = {
    "sv_density": "FLUENT",
    "sv_velocity": "FLUENT",
    "sv_p": "FLUENT",
    "sv_u": "FLUENT",
    "velocityx": "CGNS",
    "momentumx": "CGNS",
    "air_density": "a CF standard name",
    "sea_water_density": "a CF standard name",
    "air_pressure": "a CF standard name",
    "sea_water_pressure": "a CF standard name",
    "eastward_wind": "CF standard names",
    "eastward_sea_water_velocity": "CF standard names",
    "p": "OpenFOAM",
    "u": "OpenFOAM",
}


def role_reason(volume: TimeVolume, role: str, field: str | None) -> str:
    """Why ``field`` plays ``role`` in ``volume`` (as :func:`match_field` chose it), in words.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.volume import TimeVolume
    >>> u = np.ones((2, 1, 2, 2))
    >>> vol = TimeVolume.from_arrays({"SV_U": u, "SV_V": u, "SV_DENSITY": u})
    >>> role_reason(vol, "density", match_field(vol, "density"))
    "named 'SV_DENSITY' (FLUENT)"
    >>> role_reason(vol, "velocity", match_field(vol, "velocity"))
    'assembled from the components SV_U, SV_V (z = 0: a 2-D flow) (FLUENT)'
    >>> role_reason(vol, "pressure", None)
    'no field named pressure, p, press, ...'
    """
    names = ROLE_NAMES.get(role, (role,))
    if field is None:
        return f"no field named {', '.join(names[:3])}, ..."
    units = volume.attrs.get("units")
    unit = units.get(field) if isinstance(units, dict) else None
    tail = f"; {unit}" if unit else ""
    if field.startswith("(") and field.endswith(")"):
        parts = [c.strip() for c in field[1:-1].split(",")]
        comps = [c for c in parts if c != "0"]
        flat = " (z = 0: a 2-D flow)" if len(comps) < len(parts) else ""
        origin = _NAME_ORIGINS.get(comps[0].lower())
        return (
            f"assembled from the components {', '.join(comps)}{flat}"
            + (f" ({origin})" if origin else "")
            + tail
        )
    origin = _NAME_ORIGINS.get(field.lower())
    if field.lower() == role:
        return f"named {field!r}{tail}"
    return f"named {field!r}" + (f" ({origin})" if origin else f" (a usual name of {role})") + tail
