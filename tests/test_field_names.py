"""Field names as the writing tools write them: each role is found under FLUENT's,
CGNS's and CF's names, and a velocity stored as components is assembled."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from auralize.cli import main
from auralize.io import save_volume
from auralize.sources.mapping import match_field
from auralize.volume import TimeVolume

STEPS, N = 6, 5


def _volume(names: dict[str, str], rng: np.random.Generator) -> tuple[TimeVolume, dict]:
    """A volume whose fields are named ``names`` ({role or component: file name})."""
    arrays = {v: rng.random((STEPS, N, N, N)) for v in names.values()}
    return TimeVolume.from_arrays(arrays, times=np.arange(STEPS) * 1e-3), arrays


CASES = {
    # FLUENT: SV_D (a decoy: the density is SV_DENSITY), SV_U/V/W, SV_P
    "fluent": (
        {
            "decoy": "SV_D",
            "density": "SV_DENSITY",
            "x": "SV_U",
            "y": "SV_V",
            "z": "SV_W",
            "pressure": "SV_P",
        },
        "(SV_U, SV_V, SV_W)",
    ),
    "cgns": (
        {
            "density": "Density",
            "x": "VelocityX",
            "y": "VelocityY",
            "z": "VelocityZ",
            "pressure": "Pressure",
        },
        "(VelocityX, VelocityY, VelocityZ)",
    ),
    # CF standard names; 2-D winds (no upward component): z is zero
    "cf": (
        {
            "density": "air_density",
            "x": "eastward_wind",
            "y": "northward_wind",
            "pressure": "air_pressure",
        },
        "(eastward_wind, northward_wind, 0)",
    ),
}


@pytest.mark.parametrize("tool", CASES)
def test_roles_under_the_tools_names(
    tool: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    names, velocity = CASES[tool]
    vol, arrays = _volume(names, np.random.default_rng(1))
    assert match_field(vol, "density") == names["density"]
    assert match_field(vol, "pressure") == names["pressure"]
    assert match_field(vol, "velocity") == velocity
    v = vol.frame(velocity, 3)
    assert v.shape == (N, N, N, 3)
    assert np.array_equal(v[..., 0], arrays[names["x"]][3])
    assert np.array_equal(v[..., 1], arrays[names["y"]][3])
    z = arrays[names["z"]][3] if "z" in names else np.zeros((N, N, N))
    assert np.array_equal(v[..., 2], z)
    # info says which field it took for each role
    f = tmp_path / "v.h5"
    save_volume(_volume(names, np.random.default_rng(1))[0], f)
    capsys.readouterr()
    assert main(["info", str(f), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["roles"] == {
        "density": names["density"],
        "velocity": velocity,
        "pressure": names["pressure"],
    }
    # ... and why: the name it matched, or the components it assembled
    assert d["role_reasons"]["density"].startswith(f"named {names['density']!r}")
    assert d["role_reasons"]["velocity"].startswith("assembled from the components " + names["x"])
    if tool == "fluent":
        assert "(FLUENT)" in d["role_reasons"]["density"]
    assert main(["info", str(f)]) == 0
    text = capsys.readouterr().out
    assert f"role     density = {names['density']}: named" in text


def test_a_vector_field_wins_over_components() -> None:
    rng = np.random.default_rng(2)
    vol = TimeVolume.from_arrays(
        {
            "U": rng.random((STEPS, N, N, N, 3)),
            "u": rng.random((STEPS, N, N, N)),
            "v": rng.random((STEPS, N, N, N)),
        }
    )
    assert match_field(vol, "velocity") == "U" and vol.field_names == ["U", "u", "v"]
