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

Examples
--------
>>> s = SessionState(data={"spec": "dataset:monopole", "size": 8, "steps": 4})
>>> SessionState.from_dict(s.to_dict()) == s
True
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from auralize.errors import FormatError
from auralize.io.files import atomic_write
from auralize.listener import ListenerPath

FORMAT = "session"
VERSION = 1


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

    def to_dict(self) -> dict[str, Any]:
        return {"auralize_format": FORMAT, "version": VERSION, **asdict(self)}

    @classmethod
    def from_dict(cls, d: dict[str, Any], *, source: str = "<memory>") -> SessionState:
        if not isinstance(d, dict) or d.get("auralize_format") != FORMAT:
            raise FormatError(f"{source}: not an auralize session file "
                              f"(expected \"auralize_format\": \"session\")")  # fmt: skip
        if d.get("version") != VERSION:
            raise FormatError(f"{source}: session version {d.get('version')!r} is not "
                              f"supported (this auralize reads version {VERSION})")  # fmt: skip
        known = {k: d[k] for k in cls.__dataclass_fields__ if k in d}
        return cls(**known)

    def save(self, path: str | Path) -> None:
        """Write the session JSON atomically."""
        atomic_write(Path(path), json.dumps(self.to_dict(), indent=2).encode())

    @classmethod
    def load(cls, path: str | Path) -> SessionState:
        p = Path(path)
        try:
            d = json.loads(p.read_text())
        except FileNotFoundError:
            raise FormatError(f"session file {str(p)!r} does not exist") from None
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise FormatError(f"{p}: not a JSON session file ({exc})") from None
        return cls.from_dict(d, source=str(p))

    # ------------------------------------------------------------ path helpers
    def listener_path(self) -> ListenerPath | None:
        """The stored path (inline rows, or a CSV file if only ``csv`` is given)."""
        if not self.path:
            return None
        if self.path.get("rows"):
            a = np.asarray(self.path["rows"], dtype=np.float64)
            return ListenerPath(a[:, 0], a[:, 1:4], a[:, 4:7], a[:, 7:10], source="session")
        if self.path.get("csv"):
            return ListenerPath.from_csv(self.path["csv"])
        return None

    def set_listener_path(self, path: ListenerPath | None) -> None:
        self.path = None if path is None else {"rows": path.rows().tolist()}


def data_spec(spec: str, *, size: int | None = None, steps: int | None = None,
              seed: int = 0, fields: dict[str, str] | None = None,
              resolution: int | None = None) -> dict[str, Any]:  # fmt: skip
    """The ``data`` entry of a session (relative file paths are made absolute); ``fields``
    (NAME -> HDF5 dataset) and ``resolution`` are the reader options of ``--field`` and
    ``--resolution``."""
    s = str(spec)
    if not s.startswith("dataset:"):
        s = str(Path(s).expanduser().resolve())
    d: dict[str, Any] = {"spec": s, "size": size, "steps": steps, "seed": seed}
    if fields:
        d["fields"] = dict(fields)
    if resolution is not None:
        d["resolution"] = int(resolution)
    return d


def load_data(d: dict[str, Any]) -> Any:
    """Open the volume a session's ``data`` entry names."""
    from auralize.pipeline import load

    if not d or "spec" not in d:
        raise FormatError("session has no data to open (missing data.spec)")
    return load(d["spec"], size=d.get("size"), steps=d.get("steps"), seed=d.get("seed") or 0,
                fields=d.get("fields"), resolution=d.get("resolution"))  # fmt: skip
