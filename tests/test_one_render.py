"""One render path: every front end renders through ``auralize.pipeline.render``.

The front ends (the command line, ``simple``, the viewer, scenes, live
listening, the plugins' commands) import no lower-level renderer, and the
render's four ways (offline, block by block, continued, the models mixed in)
give the same samples.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from auralize.emitters import Emitters, FieldSources, Sound
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.pipeline import Carry, RenderBlocks, render
from auralize.sources.detection import SourceTracks

ROOT = Path(__file__).resolve().parents[1]
#: what renders sound below the one render (and may only be called by it, the bench,
#: the warm-up and the engine's own modules)
LOW_LEVEL = {
    ("auralize.emitters", "render_sound"),
    ("auralize.emitters.engine", "render_sound"),
    ("auralize.emitters.synthesis", "render_tracks"),
    ("auralize.emitters.timbre", "render_timbre"),
    ("auralize.distributed", "render_distributed"),
}
FRONT_ENDS = [
    *sorted((ROOT / "auralize" / "cli").glob("*.py")),
    *sorted((ROOT / "auralize" / "viewer").glob("*.py")),
    *sorted((ROOT / "auralize" / "scene").glob("*.py")),
    ROOT / "auralize" / "simple.py",
    ROOT / "auralize" / "pipeline.py",
    ROOT / "auralize" / "__init__.py",
    *sorted(ROOT.glob("plugins/*/cli.py")),
]


def _low_level_imports(path: Path) -> list[str]:
    """``module.name`` of every low-level renderer ``path`` imports (anywhere in it)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            found += [
                f"{node.module}.{a.name}" for a in node.names if (node.module, a.name) in LOW_LEVEL
            ]
    return found


def test_front_ends_import_no_lower_level_render() -> None:
    assert len(FRONT_ENDS) > 20
    offenders = {str(p.relative_to(ROOT)): _low_level_imports(p) for p in FRONT_ENDS}
    assert {k: v for k, v in offenders.items() if v} == {}


def test_the_scan_finds_a_lower_level_import(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from auralize.emitters.timbre import render_timbre\n")
    assert _low_level_imports(bad) == ["auralize.emitters.timbre.render_timbre"]


RATE = 8000


@pytest.fixture(scope="module")
def mixed() -> tuple[Sound, ListenerPath]:
    """A pulsing monopole's tracks (with a 2 Hz swell the high-pass removes) and a
    300 Hz emitter, heard from a listener walking past."""
    t = np.linspace(0.0, 1.0, 41)
    q = np.sin(2 * np.pi * 12 * t)[None] + 5 * np.sin(2 * np.pi * 2 * t)[None]
    tracks = SourceTracks(np.array([[0.0, 0.0, 0.0]]), q, np.array([0.05]), t)
    tone = 0.02 * np.sin(2 * np.pi * 300 * np.arange(int(1.2 * RATE)) / RATE)
    em = Emitters(tone[None], RATE, [[1.0, 1.0, 0.0]], name="tone")
    path = ListenerPath.line((-2.0, 3.0, 0.0), (2.0, 3.0, 0.0), duration=0.8)
    return Sound([FieldSources(tracks, lead=0.01), em], name="scene"), path


def test_blocks_and_continued_stretches_equal_the_offline_render(mixed) -> None:  # type: ignore[no-untyped-def]
    sound, path = mixed
    off = render(sound, path, rate=RATE, layout="stereo", highpass_hz=20.0)
    assert off.audio.shape == (2, int(0.8 * RATE))
    assert off.meta["highpass_hz"] == 20.0
    assert [p["kind"] for p in off.meta["parts"]] == ["FieldSources", "Emitters"]
    blocks = render(sound, path, rate=RATE, layout="stereo", highpass_hz=20.0, block=512)
    assert isinstance(blocks, RenderBlocks) and blocks.n_blocks == 13
    on = np.concatenate([blocks.block(i) for i in range(blocks.n_blocks)], axis=1)
    scale = np.max(np.abs(off.audio))
    assert np.max(np.abs(on - off.audio)) <= 1e-9 * scale
    carry = Carry()
    n = 640  # 80 ms stretches, as live listening renders them
    parts = [
        render(
            sound,
            path,
            rate=RATE,
            layout="stereo",
            highpass_hz=20.0,
            start=k * n / RATE,
            duration=n / RATE,
            carry=carry,
        ).audio
        for k in range(10)
    ]
    assert np.max(np.abs(np.concatenate(parts, axis=1) - off.audio)) <= 1e-9 * scale


def test_the_highpass_filters_the_volume_not_the_models(mixed) -> None:  # type: ignore[no-untyped-def]
    sound, path = mixed
    field, tone = Sound(sound.parts[:1]), Sound(sound.parts[1:])
    kw = dict(rate=RATE, layout="mono")
    both = render(sound, path, highpass_hz=20.0, **kw).audio
    f20 = render(field, path, highpass_hz=20.0, **kw).audio
    f0 = render(field, path, highpass_hz=0.0, **kw).audio
    t20 = render(tone, path, highpass_hz=20.0, **kw).audio
    t0 = render(tone, path, highpass_hz=0.0, **kw).audio
    assert np.array_equal(t20, t0)  # the model is heard as it made its sound
    assert np.sqrt(np.mean(f0**2)) > 3 * np.sqrt(np.mean(f20**2)) > 0  # the swell is cut
    assert np.max(np.abs(both - (f20 + t20))) <= 1e-12 * np.max(np.abs(both))


def test_source_tracks_are_heard_as_their_physical_pressure(mixed) -> None:  # type: ignore[no-untyped-def]
    sound, path = mixed
    tracks = sound.parts[0].tracks
    a = render(tracks, path, rate=RATE, highpass_hz=0.0).audio
    b = render(FieldSources(tracks, timbre="physical"), path, rate=RATE, highpass_hz=0.0).audio
    assert np.array_equal(a, b) and np.max(np.abs(a)) > 0


def test_two_ways_at_once_are_refused(mixed) -> None:  # type: ignore[no-untyped-def]
    sound, path = mixed
    with pytest.raises(ParameterError, match="not block and carry at once"):
        render(sound, path, block=512, carry=Carry())
    with pytest.raises(ParameterError, match="highpass"):
        render(sound, path, rate=RATE, highpass_hz=RATE)
