"""Listener paths: builders, interpolation, slerp, CSV round trip and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.errors import FormatError, ListenerPathError
from auralize.listener import ListenerPath


def test_line_interpolates_linearly_and_faces_motion() -> None:
    p = ListenerPath.line((0, 0, 0), (10, 0, 0), duration=2.0, n=3)
    assert np.allclose(p.position_at([0.5, 1.5]), [[2.5, 0, 0], [7.5, 0, 0]])
    f, u = p.orientation_at([1.0])
    assert np.allclose(f, [[1, 0, 0]]) and np.allclose(u, [[0, 0, 1]])


def test_slerp_between_captures_rotates_at_constant_rate() -> None:
    p = ListenerPath([0, 1], [[0, 0, 0], [0, 0, 0]], forward=[[0, 1, 0], [-1, 0, 0]])
    f, u = p.orientation_at(np.array([0.0, 0.5, 1.0]))
    assert np.allclose(f[1], [-np.sqrt(0.5), np.sqrt(0.5), 0])
    assert np.allclose(u, [[0, 0, 1]] * 3)
    ang = np.degrees(np.arctan2(-f[:, 0], f[:, 1]))
    assert np.allclose(ang, [0, 45, 90])


def test_orbit_keeps_radius_and_faces_centre() -> None:
    p = ListenerPath.orbit((1, 2, 3), radius=4.0, duration=3.0, rate_hz=10)
    r = np.linalg.norm(p.positions - [1, 2, 3], axis=1)
    assert np.allclose(r, 4.0)
    to_c = np.array([1, 2, 3]) - p.positions
    assert np.allclose(np.sum(p.forward * to_c, axis=1) / 4.0, 1.0)


def test_csv_round_trip(tmp_path) -> None:  # type: ignore[no-untyped-def]
    p = ListenerPath.orbit((0, 0, 0), radius=2.0, duration=1.0, rate_hz=7)
    f = tmp_path / "p.csv"
    p.to_csv(f)
    q = ListenerPath.from_csv(f)
    assert np.allclose(q.times, p.times) and np.allclose(q.positions, p.positions)
    assert np.allclose(q.forward, p.forward, atol=1e-8)
    # minimal header without orientation
    f.write_text("t,x,y,z\n0,1,2,3\n1,2,2,3\n")
    q = ListenerPath.from_csv(f)
    assert np.allclose(q.forward, [[0, 1, 0]] * 2)


def test_bad_paths(tmp_path) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(
        ListenerPathError, match="non-decreasing; capture 2 has t=0.5 s after t=1 s"
    ):
        ListenerPath([0, 1, 0.5], np.zeros((3, 3)))
    with pytest.raises(ListenerPathError, match="NaN"):
        ListenerPath([0, 1], [[0, 0, 0], [np.nan, 0, 0]])
    with pytest.raises(ListenerPathError, match="parallel"):
        ListenerPath([0], [[0, 0, 0]], forward=[[0, 0, 1]], up=[[0, 0, 2]])
    with pytest.raises(ListenerPathError, match="positive number of seconds"):
        ListenerPath.point((0, 0, 0), duration=0)
    f = tmp_path / "bad.csv"
    f.write_text("time,x,y,z\n0,0,0,0\n")
    with pytest.raises(FormatError, match="header must start with 't,x,y,z'"):
        ListenerPath.from_csv(f)
    f.write_text("t,x,y,z\n0,0,zero,0\n")
    with pytest.raises(FormatError, match="line 2: not a number"):
        ListenerPath.from_csv(f)
    with pytest.raises(FormatError, match="does not exist"):
        ListenerPath.from_csv(tmp_path / "missing.csv")


def test_written_files_get_the_usual_permissions(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import os

    f = tmp_path / "p.csv"
    ListenerPath.point((0, 0, 0), duration=1.0).to_csv(f)
    mask = os.umask(0o022)
    os.umask(mask)
    assert f.stat().st_mode & 0o777 == 0o666 & ~mask


def test_near_path_finds_the_points_near_the_polyline() -> None:
    """:func:`auralize.listener.near_path` (what the field's blocks and the timbre's merging
    use): points within ``dist`` of the polyline, none beyond ``dist + h/2``."""
    from scipy.spatial import cKDTree

    from auralize.listener import near_path

    rng = np.random.default_rng(3)
    path = ListenerPath(np.linspace(0.0, 2.0, 7), rng.uniform(-5, 5, (7, 3)))
    pts = rng.uniform(-7, 7, (2000, 3))
    got = near_path(pts, path, 1.5)
    seg = np.linspace(0, 1, 4001)[:, None, None]
    p = path.positions
    dense = (p[:-1] + seg * (p[1:] - p[:-1])).reshape(-1, 3)
    d, _ = cKDTree(dense).query(pts)  # distance to the polyline, within 1 mm
    assert got[d <= 1.5 - 1e-3].all() and not got[d > 1.5 + 0.5 * 1.5 / 4 + 1e-3].any()
    assert 0 < got.sum() < got.size
