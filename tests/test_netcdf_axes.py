"""netCDF axes in metres and time by any name: degrees, pressure levels, --time-dim,
--axis-scale, packed integers with NaN fill values, and the CLI on an ERA-like file."""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest
from scipy.io import netcdf_file

from auralize.cli import main
from auralize.errors import FormatError
from auralize.io import ResampledWarning, open_volume
from auralize.io.netcdf import standard_height

R = 6_371_000.0
LON = np.arange(14) * 0.75  # 0 .. 9.75 °E
LAT = 49.0 - np.arange(13) * 0.75  # 49 .. 40 °N, decreasing as in ERA files
LEVELS = [1000.0, 850.0, 500.0]  # hPa
MONTH_S = 365.242198781 * 86400.0 / 12


def isa_height(p_hpa: float) -> float:
    """ICAO troposphere, written out independently of the reader."""
    t0, lapse, p0, r, g = 288.15, 0.0065, 101325.0, 287.05287, 9.80665
    return t0 / lapse * (1.0 - (p_hpa * 100.0 / p0) ** (r * lapse / g))


def write_era(
    path: Path,
    *,
    time_name: str = "month",
    time_units: str | None = None,
    time_coord: bool = True,
    level_units: str = "millibars",
    level_attrs: dict[str, str] | None = None,
    nt: int = 2,
    lat: np.ndarray = LAT,
    levels: list[float] = LEVELS,
) -> Path:
    """u, v, z on (month, level, latitude, longitude) as an ERA monthly-means file:
    u holds the standard-atmosphere height of its level, v its latitude in degrees."""
    heights = np.array([isa_height(p) for p in LEVELS])
    with netcdf_file(path, "w") as f:
        f.createDimension(time_name, nt)
        for name, n in (("level", len(LEVELS)), ("latitude", lat.size), ("longitude", LON.size)):
            f.createDimension(name, n)
        if time_coord:
            t = f.createVariable(time_name, "i4", (time_name,))
            if time_units is not None:
                t.units = time_units
            t[:] = np.arange(1, nt + 1)
        for name, vals, units in (
            ("level", levels, level_units),
            ("latitude", lat, "degrees_north"),
            ("longitude", LON, "degrees_east"),
        ):
            v = f.createVariable(name, "f4", (name,))
            v.units = units
            v[:] = vals
        for key, value in (level_attrs or {}).items():
            setattr(f.variables["level"], key, value)
        shape = (nt, len(LEVELS), lat.size, LON.size)
        dims = (time_name, "level", "latitude", "longitude")
        u = f.createVariable("u", "f4", dims)
        u.units = "m s**-1"
        u[:] = np.broadcast_to(heights[None, :, None, None], shape)
        v = f.createVariable("v", "f4", dims)
        v.units = "m s**-1"
        v[:] = np.broadcast_to(lat[None, None, :, None], shape)
        z = f.createVariable("z", "f4", dims)
        z.units = "m**2 s**-2"
        z.standard_name = "geopotential"
        t = np.arange(nt)[:, None, None, None]
        wave = (
            np.sin(np.arange(LON.size))[None, None, None, :]
            * np.cos(np.arange(lat.size))[None, None, :, None]
        )
        z[:] = 9.80665 * heights[None, :, None, None] + 50.0 * t * wave
    return path


@pytest.fixture
def era(tmp_path: Path) -> Path:
    return write_era(tmp_path / "era.nc", time_units="months")


# --------------------------------------------------------------------------- axes in metres
def test_standard_atmosphere_heights() -> None:
    np.testing.assert_allclose(
        standard_height(np.array([100000.0, 85000.0, 50000.0])),
        [isa_height(1000.0), isa_height(850.0), isa_height(500.0)],
        rtol=1e-12,
    )
    assert abs(isa_height(1000.0) - 111.0) < 1.0 and abs(isa_height(500.0) - 5574.4) < 0.1
    # above 11 km (22632 hPa) the layer is isothermal at 216.65 K
    p11 = 101325.0 * (216.65 / 288.15) ** (9.80665 / (287.05287 * 0.0065))
    expected = 11000.0 + 287.05287 * 216.65 / 9.80665 * math.log(p11 / 10000.0)
    assert standard_height(10000.0) == pytest.approx(expected, rel=1e-12)  # 100 hPa
    assert standard_height(p11) == pytest.approx(11000.0, abs=1e-6)


@pytest.mark.parametrize(
    ("units", "physical", "times"),
    [
        ("months", True, [MONTH_S, 2 * MONTH_S]),
        (None, False, [0.0, 1 / 30]),
    ],
)
def test_era_like_file_in_metres(
    tmp_path: Path, units: str | None, physical: bool, times: list[float]
) -> None:
    path = write_era(tmp_path / "era.nc", time_units=units)
    native = open_volume(path)  # the pressure levels on their own points (a rectilinear grid)
    assert native.curvilinear and native.dims == (14, 13, 3)
    zs = np.array([isa_height(p) for p in (1000.0, 850.0, 500.0)])
    np.testing.assert_allclose(native.coords[:, 0, 0, 2], zs, rtol=1e-6)
    np.testing.assert_allclose(native.frame("u", 1)[:, 0, 0], zs, rtol=1e-6)  # u: the height
    assert "unevenly spaced: 3 points" in str(native.attrs["mesh"])
    with pytest.warns(
        ResampledWarning,
        match=r"z coordinate \(millibars -> m \(standard "
        r"atmosphere\)\) is unevenly spaced: 3 points",
    ):
        vol = open_volume(path, curvilinear="resample")
    assert vol.attrs["time_dim"] == "month"
    assert vol.physical_times is physical
    np.testing.assert_allclose(vol.times, times, rtol=1e-12)
    assert ("no reference date" if units else "frames at 30 Hz") in str(vol.attrs["time_units"])
    mid = math.radians(44.5)
    step = math.radians(0.75)
    assert vol.spacing[0] == pytest.approx(R * math.cos(mid) * step, rel=1e-9)
    assert vol.spacing[1] == pytest.approx(R * step, rel=1e-9)
    assert vol.origin[1] == pytest.approx(R * math.radians(40.0), rel=1e-9)  # flipped: 40°N first
    z0, z1 = vol.bounds[4:]
    assert z0 == pytest.approx(isa_height(1000.0), rel=1e-6)
    assert z1 == pytest.approx(isa_height(500.0), rel=1e-6)
    assert vol.dims == (14, 13, 6)  # x, y kept; z at its finest step (1346 m), 6 points
    assert vol.attrs["axis_units"] == {
        "x": "degrees_east -> m (R cos 44.5°)",
        "y": "degrees_north -> m",
        "z": "millibars -> m (standard atmosphere)",
    }
    assert "equirectangular" in str(vol.attrs["projection"])
    # u holds its level's height: linear in height, so the resampled u is z itself
    zs = vol.origin[2] + vol.spacing[2] * np.arange(vol.dims[2])
    u = vol.frame("u", 1)
    np.testing.assert_allclose(u[:, 0, 0], zs, rtol=1e-5)
    # v holds the latitude: 40°N on the first row (the file's last)
    v = vol.frame("v", 0)
    np.testing.assert_allclose(v[0, :, 0], LAT[::-1], rtol=1e-6)
    vel = vol.frame("velocity", 1)
    np.testing.assert_allclose(vel[..., 0], u)
    np.testing.assert_allclose(vel[..., 1], vol.frame("v", 1))
    assert np.all(vel[..., 2] == 0.0)
    assert vol.attrs["units"]["velocity"] == "m s**-1"


def test_latitude_span_over_30_degrees_warns(tmp_path: Path) -> None:
    path = write_era(tmp_path / "wide.nc", time_units="months", lat=np.array([0.0, 20.0, 40.0]))
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*resampled by linear", ResampledWarning)
        with pytest.warns(
            ResampledWarning,
            match=r"latitude spans 40° \(0° \.\. 40°\).*about "
            r"20\.0°.*off by up to 1\.23",
        ):
            vol = open_volume(path)
    step = math.radians(0.75)
    assert vol.spacing[0] == pytest.approx(R * math.cos(math.radians(20.0)) * step, rel=1e-9)


def test_axis_scale_overrides_the_conversions(era: Path) -> None:
    vol = open_volume(era, axis_scale=(1000.0, 1000.0, 10.0))
    assert vol.attrs["axis_scale_applied"] == [1000.0, 1000.0, 10.0]
    assert vol.spacing[:2].tolist() == pytest.approx([750.0, 750.0], rel=1e-12)
    assert vol.origin[:2].tolist() == pytest.approx([0.0, 40000.0], rel=1e-12)
    assert vol.bounds[4:] == pytest.approx((5000.0, 10000.0), rel=1e-12)  # hPa x 10, flipped
    assert vol.attrs["axis_units"]["x"] == "degrees_east x 1000 (--axis-scale)"
    assert vol.attrs["axis_units"]["z"] == "millibars x 10 (--axis-scale)"
    assert "projection" not in vol.attrs


@pytest.mark.parametrize(
    ("units", "attrs", "levels", "expected", "note"),
    [
        ("km", {}, [0.0, 1.0, 2.0], [0.0, 1000.0, 2000.0], "km -> m"),
        ("cm", {}, [0.0, 50.0, 100.0], [0.0, 0.5, 1.0], "cm -> m"),
        ("metres", {}, [0.0, 5.0, 10.0], [0.0, 5.0, 10.0], "metres"),
        ("", {}, [0.0, 1.0, 2.0], [0.0, 1.0, 2.0], "no units: taken as m"),
        (
            "m",
            {"positive": "down"},
            [0.0, 10.0, 20.0],
            [-20.0, -10.0, 0.0],
            "m (positive down -> height: negated)",
        ),
    ],
)
def test_vertical_length_units(
    tmp_path: Path,
    units: str,
    attrs: dict[str, str],
    levels: list[float],
    expected: list[float],
    note: str,
) -> None:
    path = tmp_path / "len.nc"
    with netcdf_file(path, "w") as f:
        for name, n in (("time", 2), ("depth", 3), ("y", 1), ("x", 2)):
            f.createDimension(name, n)
        t = f.createVariable("time", "f8", ("time",))
        t.units = "seconds since 2000-01-01"
        t[:] = [0.0, 1.0]
        d = f.createVariable("depth", "f8", ("depth",))
        if units:
            d.units = units
        for key, value in attrs.items():
            setattr(d, key, value)
        d[:] = levels
        f.createVariable("x", "f8", ("x",))[:] = [0.0, 1.0]
        rho = f.createVariable("rho", "f8", ("time", "depth", "y", "x"))
        rho[:] = np.arange(12.0).reshape(2, 3, 1, 2)
    vol = open_volume(path)
    assert vol.dims == (2, 1, 3)
    assert [vol.bounds[4], vol.bounds[5]] == pytest.approx([expected[0], expected[-1]])
    assert vol.spacing[2] == pytest.approx(expected[1] - expected[0])
    assert vol.attrs["axis_units"]["z"] == note
    rho = vol.frame("rho", 1)[:, 0, 0]
    np.testing.assert_array_equal(rho, [10.0, 8.0, 6.0] if attrs else [6.0, 8.0, 10.0])


def test_sigma_levels_are_refused_unless_scaled(tmp_path: Path) -> None:
    path = write_era(
        tmp_path / "sigma.nc",
        time_units="months",
        level_units="1",
        level_attrs={"standard_name": "atmosphere_sigma_coordinate"},
    )
    with pytest.raises(
        FormatError,
        match=r"'level' is a parametric vertical coordinate "
        r"\(atmosphere_sigma_coordinate, CF Appendix D\) whose formula_terms '' "
        r"leave out .*sigma, ps, ptop\); give them, or --axis-scale",
    ):
        open_volume(path)
    vol = open_volume(path, axis_scale=(1.0, 1.0, 0.01))
    assert vol.bounds[4:] == pytest.approx((5.0, 10.0))


# --------------------------------------------------------------------------- time by any name
def test_time_dimension_with_an_unguessable_name(tmp_path: Path) -> None:
    path = write_era(
        tmp_path / "m2.nc",
        time_name="month2",
        time_coord=False,
        level_units="km",
        levels=[0.0, 1.0, 2.0],
        nt=3,
    )
    with pytest.raises(
        FormatError,
        match=re.escape(
            "no time dimension found among (month2, level, latitude, longitude): name it with "
            "--time-dim NAME (CF: a coordinate with axis='T' or units '<unit> since <date>')"
        ),
    ):
        open_volume(path)
    vol = open_volume(path, time_dim="month2")
    assert vol.attrs["time_dim"] == "month2" and vol.n_steps == 3 and not vol.physical_times
    assert vol.attrs["time_units"] == (
        "none: no coordinate variable 'month2', its steps are frames at 30 Hz"
    )
    assert vol.dims == (14, 13, 3) and vol.spacing[2] == pytest.approx(1000.0)
    assert vol.attrs["axis_units"]["z"] == "km -> m"
    with pytest.raises(
        FormatError,
        match=r"--time-dim 'nope': the file has no such dimension; "
        r"its dimensions are month2 \(3\), level \(3\), latitude \(13\), "
        r"longitude \(14\)",
    ):
        open_volume(path, time_dim="nope")


def test_time_by_cf_axis_attribute(tmp_path: Path) -> None:
    path = tmp_path / "axis.nc"
    with netcdf_file(path, "w") as f:
        f.createDimension("tt", 3)
        f.createDimension("x", 4)
        t = f.createVariable("tt", "f8", ("tt",))
        t.axis = "T"
        t.units = "hours"
        t[:] = [0.0, 1.0, 3.0]
        f.createVariable("rho", "f8", ("tt", "x"))[:] = np.ones((3, 4))
    vol = open_volume(path)
    assert vol.attrs["time_dim"] == "tt" and vol.physical_times
    np.testing.assert_allclose(vol.times, [0.0, 3600.0, 10800.0])


# --------------------------------------------------------------------------- packed integers
def test_packed_int16_with_nan_fill_reads_without_warnings(tmp_path: Path) -> None:
    path = tmp_path / "packed.nc"
    with warnings.catch_warnings(), netcdf_file(path, "w") as f:
        warnings.simplefilter("ignore", RuntimeWarning)  # scipy casts the NaN fill on writing
        f.createDimension("time", 2)
        f.createDimension("x", 3)
        t = f.createVariable("time", "f8", ("time",))
        t.units = "seconds since 2000-01-01"
        t[:] = [0.0, 1.0]
        v = f.createVariable("rho", "i2", ("time", "x"))
        v.scale_factor = np.float32(0.5)
        v.add_offset = np.float32(1.0)
        v._FillValue = np.float32(np.nan)  # as some writers do, against CF's type rule
        v.missing_value = np.int16(-32767)
        v[:] = [[0, 2, -32767], [4, 6, 8]]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vol = open_volume(path)
        a0, a1 = vol.frame("rho", 0), vol.frame("rho", 1)
    np.testing.assert_array_equal(a0[0, 0], [1.0, 2.0, np.nan])
    np.testing.assert_array_equal(a1[0, 0], [3.0, 4.0, 5.0])


def test_netcdf4_standard_name_components(tmp_path: Path) -> None:
    """Wind components known by their CF standard names form the velocity (netCDF4)."""
    path = tmp_path / "w.nc"
    with h5py.File(path, "w") as f:
        for name, vals, units in (
            ("time", [0.0, 1.0], "hours since 2001-01-01"),
            ("lat", [10.0, 11.0], "degrees_north"),
            ("lon", [0.0, 1.0, 2.0], "degrees_east"),
        ):
            ds = f.create_dataset(name, data=np.asarray(vals))
            ds.make_scale(name)
            ds.attrs["units"] = units
        for name, std, k in (("ua", "eastward_wind", 1.0), ("va", "northward_wind", 2.0)):
            ds = f.create_dataset(name, data=np.full((2, 2, 3), k))
            ds.attrs["standard_name"] = std
            ds.attrs["units"] = "m s-1"
            for axis, dim in enumerate(("time", "lat", "lon")):
                ds.dims[axis].attach_scale(f[dim])
    vol = open_volume(path)
    assert vol.field_names == ["ua", "va", "velocity"]
    assert vol.frame("velocity", 1)[0, 0, 0].tolist() == [1.0, 2.0, 0.0]
    assert vol.attrs["units"]["velocity"] == "m s-1"
    assert vol.spacing[1] == pytest.approx(R * math.radians(1.0), rel=1e-9)
    assert vol.attrs["axis_units"]["x"] == "degrees_east -> m (R cos 10.5°)"


# --------------------------------------------------------------------------- CLI
def test_cli_info_shows_the_axes(era: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResampledWarning)
        assert main(["info", str(era)]) == 0
        out = capsys.readouterr().out
        assert main(["info", str(era), "--json"]) == 0
        info = json.loads(capsys.readouterr().out)
    assert (
        "  axes     x: degrees_east -> m (R cos 44.5°), y: degrees_north -> m, "
        "z: millibars -> m (standard atmosphere)"
    ) in out
    assert "(the file's time units: months (no reference date; one unit = 2.62974e+06 s))" in out
    assert info["axis_units"]["z"] == "millibars -> m (standard atmosphere)"
    assert info["time_dim"] == "month"


def test_cli_detect_and_render_era_like(era: Path, tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    src, wav = tmp_path / "s.h5", tmp_path / "a.wav"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResampledWarning)
        rc = main(["detect", str(era), "--density-field", "z", "-o", str(src), "--json"])
        assert rc == 0
        det = json.loads(capsys.readouterr().out)
        x, y = R * math.cos(math.radians(44.5)) * math.radians(5.0), R * math.radians(44.5)
        rc = main(
            [
                "render",
                str(era),
                "--density-field",
                "z",
                "--sources",
                str(src),
                "--listener",
                f"{x:.0f},{y:.0f},3000",
                "--duration",
                "0.01",
                "--rate",
                "8000",
                "-o",
                str(wav),
            ]
        )
    assert rc == 0 and wav.stat().st_size > 44
    assert len(det["steps"]) == 2 and det["valid_ratio"] == 1.0
    assert json.loads((tmp_path / "a.wav.json").read_text())["volume"] == str(era)


def test_velocity_alone_is_assembled_from_its_components(era: Path) -> None:
    with pytest.warns(ResampledWarning, match="z coordinate"):
        vol = open_volume(era, fields={"wind": "velocity"}, curvilinear="resample")
    assert vol.field_names == ["wind"] and vol.attrs["units"] == {"wind": "m s**-1"}
    wind = vol.frame("wind", 0)
    assert wind.shape == (6, 13, 14, 3)
    np.testing.assert_allclose(wind[0, :, 0, 1], LAT[::-1], rtol=1e-6)  # v: the latitude
    np.testing.assert_allclose(wind[-1, 0, 0, 0], isa_height(500.0), rtol=1e-5)  # u: the height
