"""Reader options every kind of file takes: ``box=``, ``axis_scale=``, ``time_dim=``."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.errors import DataError, ParameterError
from auralize.io import open_volume, save_volume
from auralize.volume import TimeVolume


@pytest.fixture
def ramp_file(tmp_path):
    t, nz, ny, nx = 3, 4, 5, 6
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    frames = np.stack([100 * s + 10 * k + j + 0.1 * i for s in range(t)]).astype(float)
    vol = TimeVolume.from_arrays({"rho": frames}, spacing=0.5, origin=(1, 0, 0), times=[0, 1, 2])
    path = tmp_path / "ramp.h5"
    save_volume(vol, path)
    return path, frames


def test_box_keeps_the_grid_points_inside_it_and_their_values(ramp_file):
    path, frames = ramp_file
    vol = open_volume(path, box=(1.4, 2.6, 0.5, 1.0, -1, 0.9))
    # x points 1, 1.5, ..., 3.5: inside [1.4, 2.6] are 1.5, 2.0, 2.5 (i = 1..3)
    assert vol.dims == (3, 2, 2)
    np.testing.assert_allclose(vol.origin, [1.5, 0.5, 0.0])
    np.testing.assert_array_equal(vol.frame("rho", 2), frames[2, 0:2, 1:3, 1:4])
    assert vol.attrs["box"] == [1.4, 2.6, 0.5, 1.0, -1.0, 0.9]


def test_box_outside_the_volume_says_which_axis(ramp_file):
    path, _ = ramp_file
    with pytest.raises(DataError, match="no grid point along y"):
        open_volume(path, box=(0, 10, 5, 6, 0, 10))


def test_axis_scale_multiplies_origin_and_spacing_before_the_box(ramp_file):
    path, frames = ramp_file
    vol = open_volume(path, axis_scale=(1000, 1000, 1), box=(0, 1e9, 0, 1000, 0, 10))
    np.testing.assert_allclose(vol.spacing, [500, 500, 0.5])
    np.testing.assert_allclose(vol.origin, [1000, 0, 0])
    assert vol.dims == (6, 3, 4)
    np.testing.assert_array_equal(vol.frame("rho", 1), frames[1, :, :3, :])


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"box": (1, 0, 0, 1, 0, 1)}, "minimum above its maximum along x"),
        ({"box": (0, 1, 0, 1)}, "six numbers"),
        ({"axis_scale": (1, -1, 1)}, "positive number or three"),
        ({"axis_scale": "km"}, "positive number or three"),
        ({"time_dim": "month"}, "names a netCDF time dimension"),
    ],
)
def test_bad_reader_options_are_refused_clearly(ramp_file, kw, match):
    path, _ = ramp_file
    with pytest.raises(ParameterError, match=match):
        open_volume(path, **kw)


def test_a_session_keeps_the_reader_options(ramp_file):
    import json

    from auralize.runtime.json_check import check
    from auralize.scene.session import DATA_SCHEMA, data_spec, load_data

    path, frames = ramp_file
    d = data_spec(str(path), axis_scale=(2, 2, 2), box=(0, 4, 0, 100, 0, 100))
    again = json.loads(json.dumps(d))  # as a session file holds it
    check(again, DATA_SCHEMA, "session.json")
    vol = load_data(again)
    # x points 2, 3, ..., 7 m after scaling: inside [0, 4] are 2, 3, 4 (i = 0..2)
    assert vol.dims == (3, 5, 4)
    np.testing.assert_array_equal(vol.frame("rho", 0), frames[0, :, :, :3])


def test_convert_takes_the_reader_options(ramp_file, tmp_path):
    from auralize.cli import main

    path, frames = ramp_file
    out = tmp_path / "cut.h5"
    assert main(["convert", str(path), str(out), "--box", "1,2,0,10,0,10", "-q"]) == 0
    vol = open_volume(out)
    assert vol.dims == (3, 5, 4)
    np.testing.assert_array_equal(vol.frame("rho", 2), frames[2, :, :, :3])
