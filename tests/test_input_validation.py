"""Every input is validated at the door: sources files, session/scene/layout JSON, ±Inf.

Each table row names a case, builds the bad input in ``tmp_path``, and gives the
error class and a fragment of its one-line message (which names the file).
Through the CLI the same inputs exit 3 (data error), never 70 (internal error).
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

from auralize.cli import main
from auralize.errors import DataError, FormatError
from auralize.runtime.json_check import MAX_DEPTH, parse_json
from auralize.scene.session import SessionState
from auralize.scene.soundscene import load_scene
from auralize.sources.sources_file import load_sources_for, load_sources_h5
from auralize.spatial.layouts import get_layout, load_layout_json

LISTEN = ["--listener", "0.5,0.5,0.5", "--duration", "0.1"]


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A monopole volume and the sources ``auralize detect`` finds in it."""
    d = tmp_path_factory.mktemp("valid")
    vol, src = d / "vol.h5", d / "src.h5"
    assert main(["-q", "dataset", "monopole", "--size", "8", "--steps", "6", "-o", str(vol)]) == 0
    assert main(["-q", "detect", str(vol), "-o", str(src)]) == 0
    return {"vol": vol, "src": src}


# ------------------------------------------------------------------ sources files
def _replace(h: h5py.File, name: str, data: Any) -> None:
    del h[name]
    h[name] = data


def _set(name: str, edit: Callable[[np.ndarray], Any]) -> Callable[[h5py.File], None]:
    """Replace dataset ``name`` by ``edit(its values)``."""

    def apply(h: h5py.File) -> None:
        a = h[name][()]
        out = edit(a.copy())
        _replace(h, name, a if out is None else out)

    return apply


def _attr(name: str, value: Any) -> Callable[[h5py.File], None]:
    def apply(h: h5py.File) -> None:
        h.attrs[name] = value

    return apply


def _assign(a: np.ndarray, at: Any, value: Any) -> np.ndarray:
    a[at] = value
    return a


def _delete(name: str) -> Callable[[h5py.File], None]:
    def apply(h: h5py.File) -> None:
        del h[name]

    return apply


def _group(name: str) -> Callable[[h5py.File], None]:
    def apply(h: h5py.File) -> None:
        del h[name]
        h.create_group(name)

    return apply


def _shuffle_offsets(a: np.ndarray) -> np.ndarray:
    a[1:-1] = a[1:-1][::-1]
    return a


def _duplicate_index(h: h5py.File) -> None:
    off = h["offsets"][()]
    k = int(np.argmax(np.diff(off) >= 2))  # a step with two sources or more
    idx = h["index"][()]
    idx[off[k] + 1] = idx[off[k]]
    pos = h["position"][()]
    pos[off[k] + 1] = pos[off[k]]
    _replace(h, "index", idx)
    _replace(h, "position", pos)


SOURCES_CASES: list[tuple[str, Callable[[h5py.File], None], str]] = [
    ("index negative", _set("index", lambda a: _assign(a, 0, -1)), r"/index\[0\] = -1 is outside"),
    (
        "index past the grid",
        _set("index", lambda a: _assign(a, -1, 512)),
        "valid flat indices are 0..511",
    ),
    (
        "index of floats",
        _set("index", lambda a: a.astype(np.float64)),
        "/index must be flat grid indices",
    ),
    ("index twice in a step", _duplicate_index, "twice at step"),
    (
        "every kind code 7",
        _set("kind", lambda a: np.full_like(a, 7)),
        r"/kind\[0\] = 7 is not a kind code; valid: 1 monopole",
    ),
    ("kind code 0", _set("kind", lambda a: _assign(a, 3, 0)), r"/kind\[3\] = 0"),
    (
        "radius -1",
        _set("radius", lambda a: np.full_like(a, -1.0)),
        r"/radius\[0\] = -1.0 m; .* > 0 m",
    ),
    ("radius NaN", _set("radius", lambda a: _assign(a, 2, np.nan)), r"/radius\[2\] = nan"),
    (
        "strength Inf",
        _set("strength", lambda a: _assign(a, 1, np.inf)),
        r"/strength\[1\] = inf is not finite",
    ),
    ("offsets out of order", _set("offsets", _shuffle_offsets), "/offsets must rise from 0"),
    (
        "offsets not ending at N",
        _set("offsets", lambda a: _assign(a, -1, a[-1] - 1)),
        "/offsets must rise from 0",
    ),
    (
        "offsets one short",
        _set("offsets", lambda a: a[:-1]),
        r"/offsets must be integer row offsets .* shape \(7,\)",
    ),
    (
        "offsets of floats",
        _set("offsets", lambda a: a.astype(np.float64)),
        "/offsets must be integer row offsets",
    ),
    (
        "strength shorter",
        _set("strength", lambda a: a[:-1]),
        "/strength must hold one value per source",
    ),
    (
        "kind longer",
        _set("kind", lambda a: np.append(a, a[:1])),
        "/kind must hold one value per source",
    ),
    (
        "position shorter",
        _set("position", lambda a: a[:-1]),
        r"/position must be positions \(m\) of shape",
    ),
    (
        "position elsewhere",
        _set("position", lambda a: a + 0.25),
        r"/position\[0\] = .* is not where /index\[0\]",
    ),
    ("radius a group", _group("radius"), "/radius must hold one value per source"),
    ("kind missing", _delete("kind"), "missing /kind; a sources file holds /time"),
    ("dims with a zero", _attr("dims", np.array([0, 8, 8])), "'dims' must be 3 whole numbers >= 1"),
    ("dims of two", _attr("dims", np.array([8, 8])), "'dims' must be 3 numbers"),
    ("dims absurd", _attr("dims", np.array([10**6] * 3)), "grid points; at most"),
    ("dims fractional", _attr("dims", np.array([8.5, 8, 8])), "'dims' must be 3 whole numbers"),
    ("spacing zero", _attr("spacing", np.zeros(3)), "'spacing' must be 3 finite numbers > 0 m"),
    ("origin NaN", _attr("origin", np.array([0.0, np.nan, 0.0])), "'origin' must be 3 finite"),
    (
        "thresholds negative",
        _attr("thresholds", np.array([-1.0, 1.0, 1.0])),
        "'thresholds' must be 3 numbers >= 0",
    ),
    (
        "meta nested deep",
        _attr("meta", "[" * 100_000 + "]" * 100_000),
        f"nested deeper than {MAX_DEPTH} levels",
    ),
    ("meta not an object", _attr("meta", "[1, 2]"), "'meta' must be a JSON object"),
    ("meta not JSON", _attr("meta", "{oops"), "not valid JSON"),
    ("time NaN", _set("time", lambda a: _assign(a, 2, np.nan)), r"/time\[2\] = nan is not finite"),
    ("times out of order", _set("time", lambda a: a[::-1]), "/time must be strictly increasing"),
    ("times empty", _set("time", lambda a: a[:0]), "/time must be a 1-D dataset of at least one"),
]


def _bad_sources(made: dict[str, Path], tmp_path: Path, edit: Callable[[h5py.File], None]) -> Path:
    bad = tmp_path / "bad.h5"
    shutil.copy(made["src"], bad)
    with h5py.File(bad, "r+") as h:
        edit(h)
    return bad


@pytest.mark.parametrize(
    ("name", "edit", "match"), SOURCES_CASES, ids=[c[0] for c in SOURCES_CASES]
)
def test_a_malformed_sources_file_is_refused_in_one_line(made, tmp_path, name, edit, match) -> None:  # type: ignore[no-untyped-def]
    bad = _bad_sources(made, tmp_path, edit)
    with pytest.raises(DataError, match=match) as info:
        load_sources_h5(bad)
    msg = str(info.value)
    assert msg.startswith(f"{bad}: ") and "\n" not in msg


@pytest.mark.parametrize(
    "name",
    [
        "every kind code 7",
        "radius -1",
        "offsets out of order",
        "index past the grid",
        "strength shorter",
        "meta nested deep",
    ],
)
def test_the_cli_refuses_a_malformed_sources_file_as_a_data_error(
    made, tmp_path, capsys, name
) -> None:  # type: ignore[no-untyped-def]
    edit = dict((c[0], c[1]) for c in SOURCES_CASES)[name]
    bad = _bad_sources(made, tmp_path, edit)
    out = tmp_path / "out.wav"
    code = main(["render", str(made["vol"]), "--sources", str(bad), "-o", str(out), *LISTEN])
    err = capsys.readouterr().err
    assert code == 3, err
    assert str(bad) in err and "this is a bug" not in err
    assert not out.exists()


def test_a_detected_sources_file_still_loads_and_renders(made, tmp_path) -> None:  # type: ignore[no-untyped-def]
    from auralize.io import open_volume

    series = load_sources_h5(made["src"])
    assert series.n_steps == 6 and sum(c["monopole"] for c in series.counts()) > 0
    assert all(f.kind.dtype == np.int8 and f.index.dtype == np.int64 for f in series.frames)
    assert load_sources_for(made["src"], open_volume(str(made["vol"]))).dims == series.dims
    out = tmp_path / "ok.wav"
    assert (
        main(
            [
                "-q",
                "render",
                str(made["vol"]),
                "--sources",
                str(made["src"]),
                "-o",
                str(out),
                *LISTEN,
            ]
        )
        == 0
    )
    assert out.exists()


def test_a_sources_file_without_sources_loads(made, tmp_path) -> None:  # type: ignore[no-untyped-def]
    def empty(h: h5py.File) -> None:
        for name in ("index", "kind", "strength", "radius", "position"):
            _replace(h, name, h[name][()][:0])
        _replace(h, "offsets", np.zeros_like(h["offsets"][()]))

    series = load_sources_h5(_bad_sources(made, tmp_path, empty))
    assert all(f.index.size == 0 for f in series.frames)


# ------------------------------------------------------------------ JSON documents
DEEP = "[" * 100_000 + "]" * 100_000
DIGITS = "7" * 5000


def _session(**keys: Any) -> str:
    return json.dumps({"auralize_format": "session", "version": 1, **keys})


def _layout(tmp_path: Path, text: str) -> None:
    get_layout(str(_write(tmp_path / "layout.json", text)))


def _iem(tmp_path: Path, text: str) -> None:
    load_layout_json(_write(tmp_path / "layout.json", text))


def _load_session(tmp_path: Path, text: str) -> None:
    SessionState.load(_write(tmp_path / "session.json", text))


def _scene(tmp_path: Path, text: str) -> None:
    load_scene(_write(tmp_path / "session.json", text))


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


MODEL = [{"model": "tone", "input": "a.json"}]
IEM_SPK = {"Azimuth": 0, "Elevation": 0, "Radius": 1, "IsImaginary": False, "Gain": 1}

JSON_CASES: list[tuple[str, Callable[[Path, str], None], str, type[Exception], str]] = [
    # sessions (file and, through load_scene, a saved session rendered as a scene)
    (
        "session nested 50k deep",
        _load_session,
        '{"auralize_format": "session", "version": 1, "view": ' + "[" * 50_000 + "]" * 50_000 + "}",
        FormatError,
        f"nested deeper than {MAX_DEPTH} levels",
    ),
    (
        "session audio a list",
        _load_session,
        _session(audio=[1, 2, 3]),
        FormatError,
        r"audio must be an object, got \[1, 2, 3\]",
    ),
    (
        "session time_scale a text",
        _load_session,
        _session(audio={"time_scale": "eval('1')"}),
        FormatError,
        r"audio.time_scale must be a number > 0 \(playback seconds per data "
        r"second\) or 'auto', got \"eval\('1'\)\"",
    ),
    (
        "session time_scale zero",
        _scene,
        _session(audio={"time_scale": 0}, models=MODEL),
        FormatError,
        r"audio.time_scale must be a number > 0 \(.*\) or 'auto', got 0",
    ),
    (
        "session path row of two",
        _load_session,
        _session(path={"rows": [[0.0, 1.0]]}),
        FormatError,
        r"path.rows\[0\] must be a row of 10 finite numbers, got \[0.0, 1.0\]",
    ),
    (
        "session thresholds without a key",
        _scene,
        _session(
            data={"spec": "dataset:monopole"},
            detection={"thresholds": {"monopole": "auto", "quadrupole": "auto"}},
        ),
        FormatError,
        r"detection.thresholds must be .*\(missing 'dipole'\)",
    ),
    (
        "session threshold a list",
        _load_session,
        _session(detection={"thresholds": {"monopole": [1], "dipole": 1, "quadrupole": 1}}),
        FormatError,
        r"detection.thresholds.monopole must be .*got \[1\]",
    ),
    (
        "session 5000-digit integer",
        _load_session,
        '{"auralize_format": "session", "version": 1, '
        '"data": {"spec": "dataset:monopole", "size": ' + DIGITS + "}}",
        FormatError,
        "a number with 5000 digits at line 1, column 91; numbers may have at most 30",
    ),
    (
        "session NaN",
        _load_session,
        '{"auralize_format": "session", "version": 1, "audio": {"rate": NaN}}',
        FormatError,
        "NaN is not a number JSON allows here",
    ),
    (
        "session 1e999",
        _load_session,
        '{"auralize_format": "session", "version": 1, "audio": {"rate": 1e999}}',
        FormatError,
        "number 1e999 at line 1, column 64 overflows",
    ),
    (
        "session size negative",
        _load_session,
        _session(data={"spec": "dataset:x", "size": -3}),
        FormatError,
        "data.size must be an integer >= 1 or null, got -3",
    ),
    (
        "session data without spec",
        _load_session,
        _session(data={"size": 8}),
        FormatError,
        r"data must be an object with 'spec' \(missing 'spec'\)",
    ),
    (
        "session camera of two",
        _load_session,
        _session(camera={"position": [1, 2], "focal_point": [0, 0, 0], "up": [0, 0, 1]}),
        FormatError,
        r"camera.position must be \[x, y, z\] \(3 finite numbers\)",
    ),
    (
        "session unknown view type",
        _load_session,
        _session(view={"types": {"sound": True}}),
        FormatError,
        r"unknown key 'view.types.sound'; valid keys: \['monopole'",
    ),
    (
        "session model without input",
        _load_session,
        _session(models=[{"model": "fire"}]),
        FormatError,
        r"models\[0\] must be an object with 'model', 'input' \(missing 'input'\)",
    ),
    (
        "session view step a bool",
        _load_session,
        _session(view={"step": True}),
        FormatError,
        "view.step must be an integer >= 0, got True",
    ),
    (
        "session not a session",
        _load_session,
        '{"auralize_format": "volume"}',
        FormatError,
        "not an auralize session file",
    ),
    # layouts
    ("layout nested 100k deep", _layout, DEEP, FormatError, f"nested deeper than {MAX_DEPTH}"),
    (
        "layout object nested deep",
        _layout,
        '{"speakers": ' + '{"a": ' * 70 + "1" + "}" * 71,
        FormatError,
        "at line 1, column 392",
    ),
    (
        "layout 5000-digit azimuth",
        _layout,
        '[{"azimuth": 0}, {"azimuth": ' + DIGITS + "}]",
        FormatError,
        "a number with 5000 digits",
    ),
    (
        "layout name a number",
        _layout,
        '[{"azimuth": 0}, {"azimuth": 90, "name": 5}]',
        FormatError,
        r"speakers\[1\].name must be a non-empty string or null, got 5",
    ),
    (
        "layout lfe a text",
        _layout,
        '[{"azimuth": 0}, {"azimuth": 90, "lfe": "no"}]',
        FormatError,
        r"speakers\[1\].lfe must be true or false or null, got 'no'",
    ),
    (
        "layout name an object",
        _layout,
        '{"name": {"x": 1}, "speakers": [{"azimuth": 0}, {"azimuth": 90}]}',
        FormatError,
        r"name must be a non-empty string, got \{'x': 1\}",
    ),
    (
        "layout too many speakers",
        _layout,
        json.dumps([{"azimuth": k * 0.1} for k in range(2000)]),
        FormatError,
        "at most 1024",
    ),
    (
        "iem channel absurd",
        _iem,
        json.dumps(
            {
                "LoudspeakerLayout": {
                    "Loudspeakers": [
                        {**IEM_SPK, "Channel": 1},
                        {**IEM_SPK, "Azimuth": 90, "Channel": 10**20},
                    ]
                }
            }
        ),
        FormatError,
        r"'Channel' must be an integer ≥ 1 \(1-based\) and ≤ 1024",
    ),
    # scene files
    (
        "scene nested deep",
        _scene,
        '{"models": ' + DEEP + "}",
        FormatError,
        r"not a JSON scene file \(JSON nested deeper",
    ),
    (
        "scene listener position of texts",
        _scene,
        json.dumps({"models": MODEL, "listener": {"position": [1, "a", 3]}}),
        FormatError,
        r"listener.position\[1\] must be a number, got 'a'",
    ),
    (
        "scene listener position a bool",
        _scene,
        json.dumps({"models": MODEL, "listener": {"position": [1, True, 3]}}),
        FormatError,
        r"listener.position\[1\] must be a number, got True",
    ),
    (
        "scene listener path a number",
        _scene,
        json.dumps({"models": MODEL, "listener": {"path": 3}}),
        FormatError,
        r"listener.path must be a non-empty string, got 3",
    ),
    (
        "scene rate zero",
        _scene,
        json.dumps({"models": MODEL, "rate": 0}),
        FormatError,
        "rate must be an integer >= 1, got 0",
    ),
    (
        "scene duration 1e999",
        _scene,
        '{"models": [{"model": "a", "input": "b"}], "duration": 1e999}',
        FormatError,
        "overflows to infinity",
    ),
    (
        "scene model name a list",
        _scene,
        json.dumps({"models": [{"model": [1], "input": "x"}]}),
        FormatError,
        r"models\[0\].model must be a non-empty string",
    ),
    (
        "scene input data bad size",
        _scene,
        json.dumps({"models": [{"model": "field", "input": {"spec": "dataset:x", "size": "big"}}]}),
        FormatError,
        r"models\[0\].input.size must be an integer >= 1 or null, got 'big'",
    ),
]


@pytest.mark.parametrize(
    ("name", "load", "text", "error", "match"), JSON_CASES, ids=[c[0] for c in JSON_CASES]
)
def test_a_malformed_json_document_is_refused_in_one_line(
    tmp_path, name, load, text, error, match
) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(error, match=match) as info:
        load(tmp_path, text)
    msg = str(info.value)
    assert str(tmp_path) in msg and "\n" not in msg and len(msg) < 400


def _deep_list(depth: int) -> list[Any]:
    top: list[Any] = []
    inner = top
    for _ in range(depth):
        inner.append([])
        inner = inner[0]
    return top


@pytest.mark.parametrize(
    ("name", "doc", "match"),
    [
        (
            "a 5000-digit Python int",
            lambda: {"audio": {"rate": 10**5000}},
            "audio.rate must be a number >= 1, got an integer of more than 30 digits",
        ),
        ("a tuple for audio", lambda: {"audio": (1, 2)}, "audio must be an object"),
        (
            "params nested deep",
            lambda: {
                "models": [{"model": "m", "input": "x", "params": {"p": _deep_list(100_000)}}]
            },
            r"models\[0\].params.p must be a JSON value \(finite numbers, at most 64 levels",
        ),
        (
            "rows with an Inf",
            lambda: {"path": {"rows": [[0.0] * 9 + [float("inf")]]}},
            r"path.rows\[0\] must be a row of 10 finite numbers",
        ),
        (
            "a set for overlays",
            lambda: {"view": {"overlays": {"fire"}}},
            "view.overlays must be a list",
        ),
    ],
)
def test_a_session_built_in_python_is_checked_too(name, doc, match) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(FormatError, match=match) as info:
        SessionState.from_dict({"auralize_format": "session", "version": 1, **doc()}, source="mine")
    assert str(info.value).startswith("mine: ")


def test_a_good_session_still_round_trips(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from auralize.listener import ListenerPath

    st = SessionState(
        data={"spec": "dataset:monopole", "size": 8, "steps": 4, "seed": 0},
        view={
            "field": "density",
            "representation": "volume",
            "step": 2,
            "opacity": 0.5,
            "types": {"monopole": True, "dipole": False},
            "overlays": [],
        },
        detection={
            "mapping": "paper-density",
            "mapping_fields": {},
            "thresholds": {
                "monopole": "auto",
                "dipole": 2.5,
                "quadrupole": "top:1%",
                "zero_fraction": 1.0,
                "floor": 3.0,
            },
            "detected": True,
        },
        audio={
            "layout": "stereo",
            "rate": 44100,
            "time_scale": 1.0,
            "device": None,
            "heard": "field",
        },
        camera={
            "position": [1, 2, 3],
            "focal_point": [0, 0, 0],
            "up": [0, 0, 1],
            "view_angle": 30.0,
        },
        recording={"rate_hz": 30.0},
        models=[{"model": "fire", "input": {"spec": "dataset:fire", "size": None}, "params": {}}],
    )
    st.set_listener_path(ListenerPath.point([0.5, 0.5, 0.5], duration=1.0))
    f = tmp_path / "s.json"
    st.save(f)
    back = SessionState.load(f)
    assert back == st and back.source == str(f) and "source" not in json.loads(f.read_text())
    assert back.listener_path() is not None


def test_deep_json_is_refused_before_the_parser_recurses() -> None:
    with pytest.raises(DataError, match="nested deeper than 64 levels"):
        parse_json("{" + '"a": {' * 200_000, "x.json", error=DataError)
    assert parse_json("[" * MAX_DEPTH + "]" * MAX_DEPTH, "x.json") is not None
    # brackets and digits inside strings are text, not structure or numbers
    assert parse_json(json.dumps({"a": "[" * 500 + "9" * 500}), "x.json")["a"][0] == "["


@pytest.mark.parametrize(
    ("name", "argv", "text"),
    [
        ("scene file nested deep", ["render", "--scene", "{f}", "-o", "{o}"], DEEP),
        (
            "session scene with a text time scale",
            ["render", "--scene", "{f}", "-o", "{o}"],
            _session(data={"spec": "dataset:monopole"}, audio={"time_scale": "eval('1')"}),
        ),
        (
            "session scene with a short path row",
            ["render", "--scene", "{f}", "-o", "{o}"],
            _session(data={"spec": "dataset:monopole"}, path={"rows": [[0, 1]]}),
        ),
        (
            "layout nested deep",
            ["render", "dataset:monopole", "--layout", "{f}", "-o", "{o}", *LISTEN],
            DEEP,
        ),
        (
            "layout with a 5000-digit number",
            ["render", "dataset:monopole", "--layout", "{f}", "-o", "{o}", *LISTEN],
            '[{"azimuth": 0}, {"azimuth": ' + DIGITS + "}]",
        ),
    ],
)
def test_the_cli_refuses_malformed_json_as_a_data_error(tmp_path, capsys, name, argv, text) -> None:  # type: ignore[no-untyped-def]
    f = _write(tmp_path / "in.json", text)
    out = tmp_path / "out.wav"
    code = main([a.format(f=f, o=out) for a in argv])
    err = capsys.readouterr().err
    assert code == 3, err
    assert str(f) in err and "this is a bug" not in err and not out.exists()


# ------------------------------------------------------------------ ±Inf in fields
def _volume_with(
    tmp_path: Path, name: str, field: str, value: float | None, *, at: tuple[int, ...]
) -> Path:
    """A density + velocity volume; ``value`` written at ``at`` of ``field``."""
    from auralize.io import save_volume
    from auralize.volume import TimeVolume

    rng = np.random.default_rng(3)
    t = np.arange(6) * 0.01
    x = np.linspace(0.0, 1.0, 8)
    rho = 1.2 + 0.01 * np.sin(2 * np.pi * (20 * t[:, None, None, None] + x)) * np.ones((6, 8, 8, 8))
    vel = 0.5 * rng.standard_normal((6, 8, 8, 8, 3))
    path = tmp_path / f"{name}.h5"
    save_volume(
        TimeVolume.from_arrays({"density": rho, "velocity": vel}, spacing=0.1, times=t), path
    )
    if value is not None:
        with h5py.File(path, "r+") as h:
            a = h[f"fields/{field}"][()]
            a[at] = value
            h[f"fields/{field}"][...] = a
    return path


NONFINITE = [("NaN", np.nan), ("-Inf", -np.inf), ("+Inf", np.inf)]


@pytest.mark.parametrize(
    ("field", "at"), [("velocity", (2, 4, 4, 4, 0)), ("density", (2, 4, 4, 4))]
)
def test_inf_is_no_data_counted_and_heard_like_nan(tmp_path, capsys, field, at) -> None:  # type: ignore[no-untyped-def]
    """``--nan mask``: ±Inf is masked, counted and rendered exactly as NaN is."""
    from auralize.audio import read_wav

    reports, sounds = {}, {}
    for label, value in NONFINITE:
        vol = _volume_with(tmp_path, label, field, value, at=at)
        src = tmp_path / f"{label}.src.h5"
        capsys.readouterr()
        assert main(["detect", str(vol), "--mapping", "identity", "-o", str(src), "--json"]) == 0
        reports[label] = json.loads(capsys.readouterr().out)
        wav = tmp_path / f"{label}.wav"
        assert (
            main(
                [
                    "-q",
                    "render",
                    str(vol),
                    "--mapping",
                    "identity",
                    "--normalize",
                    "none",
                    "-o",
                    str(wav),
                    *LISTEN,
                ]
            )
            == 0
        )
        sounds[label] = read_wav(wav)[0]
    nan = reports["NaN"]
    assert nan["masked_fraction"] == pytest.approx(1 / (2 * 6 * 8**3))  # of the two fields read
    for label in ("-Inf", "+Inf"):
        assert reports[label]["masked_fraction"] == nan["masked_fraction"], label
        assert reports[label]["steps"] == nan["steps"], label
        np.testing.assert_array_equal(sounds[label], sounds["NaN"])


@pytest.mark.parametrize(("label", "value"), NONFINITE)
def test_inf_in_a_log_density_is_no_data_for_the_paper_mapping(tmp_path, label, value) -> None:  # type: ignore[no-untyped-def]
    """The paper-density mapping's range comes from the finite values: ±Inf (like NaN)
    neither widens it nor is taken for a linear density."""
    from auralize.io import open_volume
    from auralize.pipeline import detect_sources

    src = tmp_path / "e.h5"
    assert main(["-q", "dataset", "explosion", "--size", "8", "--steps", "4", "-o", str(src)]) == 0
    with h5py.File(src, "r+") as h:
        a = h["fields/log10_density"][()]
        a[1, 3, 3, 3] = value
        h["fields/log10_density"][...] = a
    vol = open_volume(str(src), nan="mask")
    frame = vol.frame("log10_density", 1)
    assert (
        np.isnan(frame[3, 3, 3]) and np.isfinite(np.delete(frame.ravel(), 3 * 64 + 3 * 8 + 3)).all()
    )
    series = detect_sources(vol)
    assert series.n_steps == 4


def test_inf_in_a_field_is_refused_with_nan_error(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    vol = _volume_with(tmp_path, "minf", "velocity", -np.inf, at=(1, 0, 0, 0, 2))
    code = main(
        [
            "detect",
            str(vol),
            "--mapping",
            "identity",
            "--nan",
            "error",
            "-o",
            str(tmp_path / "s.h5"),
        ]
    )
    err = capsys.readouterr().err
    assert code == 3 and "'velocity' at step 1" in err and "1 NaN/Inf values" in err


def test_inf_as_nan_leaves_the_callers_array_alone() -> None:
    from auralize.volume import inf_as_nan

    a = np.array([[1.0, -np.inf], [np.nan, 2.0]])
    b = inf_as_nan(a)
    assert np.isneginf(a[0, 1]) and np.isnan(b[0, 1]) and b[1, 1] == 2.0
    clean = np.ones(4)
    assert inf_as_nan(clean) is clean
