"""Session (project) files: everything needed to reproduce a view and a sound, as JSON.

A session names the data (file or ``dataset:NAME`` with its size, steps and
seed), the displayed field and representation, the mapping and thresholds,
the listener path (inline captures, so the file stands alone), the audio
settings (layout, rate, time scale, device) and the camera.  The desktop
viewer and :mod:`auralize.simple` read and write the same format::

    {"auralize_format": "session", "version": 1,
     "data": {"spec": "dataset:explosion", "size": 32, "steps": 8, "seed": 0},
     "view": {"field": "log10_density", "representation": "volume", ...},
     "detection": {"mapping": "paper-density", "thresholds": {...}},
     "path": {"rows": [[t, x, y, z, fx, fy, fz, ux, uy, uz], ...]},
     "audio": {"layout": "ring8", "rate": 44100, "time_scale": 1.0, "device": null},
     "camera": {"position": [...], "focal_point": [...], "up": [...]},
     "models": [{"model": "fire", "input": "/data/fire.h5", "params": {"extend": "none"}}]}

``models`` are the sound models mixed with the data (a scene, see
:mod:`auralize.scene.soundscene`); older files without it have none.

A session is checked when it is read (:meth:`SessionState.from_dict`, which
:meth:`SessionState.load` uses): the JSON is bounded in depth and number size
(:mod:`auralize.runtime.json_check`) and every known key has its type and range
(:data:`SCHEMA`); a fault raises :class:`~auralize.errors.FormatError` naming
the file and the key.  Keys this version does not know are kept out of the
way, not refused, so newer files still open.

Examples
--------
>>> s = SessionState(data={"spec": "dataset:monopole", "size": 8, "steps": 4})
>>> SessionState.from_dict(s.to_dict()) == s
True
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from auralize.defaults import TIMBRE_CHOICES
from auralize.errors import FormatError
from auralize.listener import ListenerPath
from auralize.runtime.files import atomic_write
from auralize.runtime.json_check import (
    AnyJSON,
    Bool,
    DictOf,
    Either,
    ListOf,
    Num,
    Obj,
    Table,
    Text,
    check,
    optional,
    read_json,
    vec3,
)

FORMAT = "session"
VERSION = 1

_TYPES = ("monopole", "dipole", "quadrupole")
_COUNT = Num(lo=1, integer=True)
#: what a session's ``data`` (and a model's input given as data) holds
DATA_SCHEMA = Obj(
    {
        "spec": Text(nonempty=True),
        "size": optional(_COUNT),
        "steps": optional(_COUNT),
        "seed": optional(Num(lo=0, integer=True)),
        "fields": optional(DictOf(Text(nonempty=True))),
        "resolution": optional(Either(_COUNT, ListOf(_COUNT, min_len=3, max_len=3))),
        "time_dim": optional(Text(nonempty=True)),
        "axis_scale": optional(ListOf(Num(lo=0), min_len=3, max_len=3)),
        "box": optional(ListOf(Num(), min_len=6, max_len=6)),
        "curvilinear": optional(Text(nonempty=True)),
    },
    required=("spec",),
    other=AnyJSON(),
)
_THRESHOLD = optional(
    Either(
        Num(lo=0),
        Text(nonempty=True),
        what="a number >= 0 or a text such as 'auto', 'top:1%', '5%'",
    )
)
#: the types and ranges of a session file's keys (unknown keys pass as any JSON)
SCHEMA = Obj(
    {
        "auralize_format": Text(),
        "version": Num(integer=True),
        "data": Obj(
            DATA_SCHEMA.fields, required=DATA_SCHEMA.required, other=AnyJSON(), empty_ok=True
        ),
        "view": Obj(
            {
                "field": optional(Text()),
                "representation": optional(Text()),
                "cmap": optional(Text()),
                "opacity": optional(Num(lo=0, hi=1)),
                "step": Num(lo=0, integer=True),
                "types": DictOf(Bool(), keys=_TYPES),
                "overlays": ListOf(Text(nonempty=True)),
            },
            other=AnyJSON(),
        ),
        "detection": Obj(
            {
                "mapping": optional(Text(nonempty=True)),
                "mapping_fields": optional(DictOf(Text(nonempty=True))),
                "thresholds": optional(
                    Obj(
                        {
                            **dict.fromkeys(_TYPES, _THRESHOLD),
                            "zero_fraction": Num(lo=0),
                            "floor": Num(lo=0),
                        },
                        required=_TYPES,
                        other=AnyJSON(),
                    )
                ),
                "detected": Bool(),
            },
            other=AnyJSON(),
        ),
        "path": optional(
            Obj(
                {
                    "rows": Table(
                        10,
                        what="a list of rows [t, x, y, z, fx, fy, fz, ux, uy, uz] of finite "
                        "numbers",
                    ),
                    "csv": Text(nonempty=True),
                },
                other=AnyJSON(),
            )
        ),
        "audio": Obj(
            {
                "layout": Text(nonempty=True),
                "rate": Num(lo=1),
                "time_scale": Either(
                    Num(lo=0, lo_open=True),
                    Text(choices=("auto",)),
                    what="a number > 0 (playback seconds per data second) or 'auto'",
                ),
                "device": optional(Either(Text(), Num(lo=0, integer=True))),
                "heard": Text(nonempty=True),
                "timbre": Text(choices=TIMBRE_CHOICES),
            },
            other=AnyJSON(),
        ),
        "camera": optional(
            Obj(
                {
                    "position": vec3(),
                    "focal_point": vec3(),
                    "up": vec3(),
                    "view_angle": Num(lo=0, lo_open=True, hi=180),
                },
                required=("position", "focal_point", "up"),
                other=AnyJSON(),
            )
        ),
        "recording": Obj({"rate_hz": Num(lo=0, lo_open=True)}, other=AnyJSON()),
        "models": ListOf(
            Obj(
                {
                    "model": Text(nonempty=True),
                    "input": Either(
                        Text(nonempty=True),
                        DATA_SCHEMA,
                        what="a file name, dataset:NAME or a data object with 'spec'",
                    ),
                    "params": optional(DictOf(AnyJSON())),
                },
                required=("model", "input"),
                other=AnyJSON(),
            )
        ),
    },
    other=AnyJSON(),
)


@dataclass
class SessionState:
    """The JSON-able state of a viewer or scripting session (see the module docstring)."""

    data: dict[str, Any] = field(default_factory=dict)
    view: dict[str, Any] = field(default_factory=dict)
    detection: dict[str, Any] = field(default_factory=dict)
    path: dict[str, Any] | None = None
    audio: dict[str, Any] = field(default_factory=dict)
    camera: dict[str, Any] | None = None
    recording: dict[str, Any] = field(default_factory=dict)
    models: list[dict[str, Any]] = field(default_factory=list)
    #: the file the session was read from (named in messages; not saved)
    source: str = field(default="<memory>", repr=False, compare=False)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d.pop("source")
        return {"auralize_format": FORMAT, "version": VERSION, **d}

    @classmethod
    def from_dict(cls, d: dict[str, Any], *, source: str = "<memory>") -> SessionState:
        """The session a JSON-like dict describes, checked against :data:`SCHEMA`.

        Raises
        ------
        FormatError
            Not a session, another version, or a key of the wrong type or out of
            range (the message names ``source`` and the key).
        """
        if not isinstance(d, dict) or d.get("auralize_format") != FORMAT:
            raise FormatError(
                f'{source}: not an auralize session file (expected "auralize_format": "session")'
            )
        version = d.get("version")
        if isinstance(version, bool) or version != VERSION:
            raise FormatError(
                f"{source}: session version {d.get('version')!r} is not "
                f"supported (this auralize reads version {VERSION})"
            )
        check(d, SCHEMA, source)
        known = {f.name: d[f.name] for f in fields(cls) if f.name != "source" and f.name in d}
        return cls(**known, source=source)

    def save(self, path: str | Path) -> None:
        """Write the session JSON atomically."""
        atomic_write(Path(path), json.dumps(self.to_dict(), indent=2).encode())

    @classmethod
    def load(cls, path: str | Path) -> SessionState:
        p = Path(path)
        try:
            d = read_json(p)
        except FileNotFoundError:
            raise FormatError(f"session file {str(p)!r} does not exist") from None
        return cls.from_dict(d, source=str(p))

    # ------------------------------------------------------------ path helpers
    def listener_path(self) -> ListenerPath | None:
        """The stored path (inline rows, or a CSV file if only ``csv`` is given)."""
        if not self.path:
            return None
        if self.path.get("rows"):
            a = np.asarray(self.path["rows"], dtype=np.float64)
            return ListenerPath(
                a[:, 0], a[:, 1:4], a[:, 4:7], a[:, 7:10], source=f"{self.source}: path.rows"
            )
        if self.path.get("csv"):
            return ListenerPath.from_csv(self.path["csv"])
        return None

    def set_listener_path(self, path: ListenerPath | None) -> None:
        self.path = None if path is None else {"rows": path.rows().tolist()}


def data_spec(
    spec: str,
    *,
    size: int | None = None,
    steps: int | None = None,
    seed: int = 0,
    fields: dict[str, str] | None = None,
    resolution: int | None = None,
    time_dim: str | None = None,
    axis_scale: Any = None,
    box: Any = None,
    curvilinear: str | None = None,
) -> dict[str, Any]:
    """The ``data`` entry of a session (relative file paths are made absolute); ``fields``
    (NAME -> HDF5 dataset), ``resolution``, ``time_dim``, ``axis_scale``, ``box`` and
    ``curvilinear`` are the reader options of ``--field``, ``--resolution``,
    ``--time-dim``, ``--axis-scale``, ``--box`` and ``--resample``."""
    s = str(spec)
    if not s.startswith("dataset:"):
        s = str(Path(s).expanduser().resolve())
    d: dict[str, Any] = {"spec": s, "size": size, "steps": steps, "seed": seed}
    if fields:
        d["fields"] = dict(fields)
    if resolution is not None:
        d["resolution"] = int(resolution)
    if time_dim is not None:
        d["time_dim"] = str(time_dim)
    if axis_scale is not None:
        d["axis_scale"] = [float(v) for v in axis_scale]
    if box is not None:
        d["box"] = [float(v) for v in box]
    if curvilinear is not None:
        d["curvilinear"] = str(curvilinear)
    return d


def reader_options(d: dict[str, Any]) -> dict[str, Any]:
    """The ``time_dim``, ``axis_scale``, ``box`` and ``curvilinear`` of a session's ``data``
    entry, as keywords."""
    return {k: d.get(k) for k in ("time_dim", "axis_scale", "box", "curvilinear")}


def load_data(d: dict[str, Any]) -> Any:
    """Open the volume a session's ``data`` entry names."""
    from auralize.io.options import curvilinear_mode
    from auralize.pipeline import load

    if not d or "spec" not in d:
        raise FormatError("session has no data to open (missing data.spec)")
    with curvilinear_mode(d.get("curvilinear") or "native"):
        return load(
            d["spec"],
            size=d.get("size"),
            steps=d.get("steps"),
            seed=d.get("seed") or 0,
            fields=d.get("fields"),
            resolution=d.get("resolution"),
            time_dim=d.get("time_dim"),
            axis_scale=d.get("axis_scale"),
            box=d.get("box"),
        )
