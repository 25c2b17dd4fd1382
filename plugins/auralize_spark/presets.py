"""Table 1 presets of paper 002 (§5.3): spark balls, plasma ball, lightning.

=============  ======  =======  ======  ======
object         path    l        r0      T0
=============  ======  =======  ======  ======
spark-balls    2 cm    1 mm     5 cm    30 µs
plasma-ball    20 cm   1 cm     10 cm   40 µs
lightning      5 km    1.5 m    10 m    500 µs
=============  ======  =======  ======  ======

"path" is the gap between the charges of each preset's built-in scene.  The
paper gives no baseline pressures p_s0; the values here are assumptions of
plausible loudness (a laboratory spark of ~500 Pa at 5 cm, Wright 1983's
order of magnitude; a weaker plasma-ball streamer; ~2 kPa at 10 m per
lightning segment).  With peak normalisation they only set relative levels.
Branching parameters are tuned so that the mean segment counts are of the
order of the paper's Table 2 (72, 78 and 9,438 segments).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from auralize.errors import ParameterError

from .field import ChargeScene, ElectricField, solve_field


@dataclass(frozen=True)
class Preset:
    """Typical values of one discharge scale (Table 1) and its built-in scene."""

    name: str
    path_m: float
    half_length: float
    r0: float
    T0: float
    ps0: float
    listener: tuple[float, float, float]
    scene_dict: dict[str, Any] = field(hash=False, compare=False)
    multi_stroke: bool = False
    branch_probability: float = 0.05
    branch_length: float = 10.0
    paper_segments: int = 0
    paper_time: str = ""

    def scene(self) -> ChargeScene:
        return ChargeScene.from_dict(self.scene_dict, source=f"preset {self.name!r}")

    def field(self) -> ElectricField:
        """The preset scene's solved field (cached)."""
        return _preset_field(self.name)


def _balls() -> dict[str, Any]:
    # two 1 cm balls, surfaces 2 cm apart along x
    return {
        "grid": {"dims": [65, 41, 41], "origin": [-0.04, -0.025, -0.025], "spacing": 0.00125},
        "boundary": "neumann",
        "charges": [
            {"shape": "sphere", "center": [-0.02, 0, 0], "radius": 0.01, "sign": "negative"},
            {"shape": "sphere", "center": [0.02, 0, 0], "radius": 0.01, "sign": "positive"},
        ],
    }


def _plasma() -> dict[str, Any]:
    # 3 cm central electrode, a fingertip (1 cm) on the globe 20 cm from it
    return {
        "grid": {"dims": [65, 49, 49], "origin": [-0.1, -0.15, -0.15], "spacing": 0.00625},
        "boundary": "neumann",
        "charges": [
            {"shape": "sphere", "center": [0, 0, 0], "radius": 0.03, "sign": "negative"},
            {"shape": "sphere", "center": [0.24, 0, 0], "radius": 0.01, "sign": "positive"},
        ],
    }


def _lightning() -> dict[str, Any]:
    # negative cloud charge (1 km sphere, base 5 km up), positive induced charge on the ground
    return {
        "grid": {"dims": [31, 31, 34], "origin": [-3000, -3000, 0], "spacing": 200.0},
        "boundary": "neumann",
        "charges": [
            {"shape": "sphere", "center": [0, 0, 6000], "radius": 1000, "sign": "negative"},
            {"shape": "plane", "axis": "z", "position": 0.0, "sign": "positive"},
        ],
    }


PRESETS: dict[str, Preset] = {
    "spark-balls": Preset(
        "spark-balls",
        0.02,
        1e-3,
        0.05,
        30e-6,
        500.0,
        (0.0, -0.5, 0.0),
        _balls(),
        branch_probability=0.7,
        branch_length=14.0,
        paper_segments=72,
        paper_time="< 16 ms",
    ),
    "plasma-ball": Preset(
        "plasma-ball",
        0.20,
        1e-2,
        0.10,
        40e-6,
        50.0,
        (0.1, -1.0, 0.0),
        _plasma(),
        branch_probability=0.45,
        branch_length=11.0,
        paper_segments=78,
        paper_time="< 16 ms",
    ),
    "lightning": Preset(
        "lightning",
        5000.0,
        1.5,
        10.0,
        500e-6,
        2000.0,
        (300.0, 200.0, 2.0),
        _lightning(),
        multi_stroke=True,
        branch_probability=0.007,
        branch_length=350.0,
        paper_segments=9438,
        paper_time="812 ms",
    ),
}


def get_preset(name: str) -> Preset:
    if name not in PRESETS:
        raise ParameterError(f"unknown preset {name!r}; choose one of {sorted(PRESETS)}")
    return PRESETS[name]


@functools.cache
def _preset_field(name: str) -> ElectricField:
    return solve_field(PRESETS[name].scene())


def preset_listener(name: str) -> np.ndarray:
    return np.asarray(get_preset(name).listener, dtype=np.float64)
