"""Scenes: several sound models along one listener path.

The mix of a scene is the sum of its models rendered alone (engine level, CLI,
scripting), a scene plays live block by block on a file-backed ALSA device
with no underruns, and bad scene input gets one clear line.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

import auralize.plugins as plugins
from auralize.emitters import Emitters, Sound, render_sound
from auralize.errors import FormatError, MissingFileError, ParameterError, PluginError
from auralize.listener import ListenerPath
from auralize.pipeline import render as render_heard
from auralize.plugins import Parameter, SoundModel, check_sound
from auralize.scene.soundscene import (
    SceneModel,
    load_scene,
    parse_model_spec,
    scene_sound,
)

RATE = 44100


class ToneModel(SoundModel):
    """A static sine emitter read from a JSON file (a small model for the CLI plumbing)."""

    name: ClassVar[str] = "tone"
    description: ClassVar[str] = "a sine emitter at a position (tests)"
    parameters: ClassVar[tuple[Parameter, ...]] = (Parameter("gain", 1.0, range=(0.0, None)),)

    def load_input(self, spec: str) -> dict[str, Any]:
        return dict(json.loads(Path(spec).read_text()))

    def synthesize(self, inputs: dict[str, Any], **params: Any) -> Sound:
        p = self.resolve(**params)
        t = np.arange(int(0.5 * 8000)) / 8000.0
        sig = p["gain"] * inputs["amplitude"] * np.sin(2 * np.pi * inputs["freq"] * t)
        em = Emitters(sig[None], 8000.0, np.asarray(inputs["position"], float)[None], name="tone")
        return Sound(parts=[em], name="tone")


class OldModel(SoundModel):
    """A model that still returns its own result type."""

    name: ClassVar[str] = "old"

    def synthesize(self, inputs: Any, **params: Any) -> Any:
        return {"pressure": np.zeros(10)}


@pytest.fixture
def tone_models(monkeypatch, tmp_path):  # type: ignore[no-untyped-def]
    real = plugins.registry()
    monkeypatch.setattr(plugins, "registry", lambda: {**real, "tone": ToneModel, "old": OldModel})
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps({"position": [3.0, 1.0, 0.0], "freq": 440.0, "amplitude": 0.5}))
    b.write_text(json.dumps({"position": [-2.0, 2.0, 0.5], "freq": 300.0, "amplitude": 0.2}))
    return a, b


# --------------------------------------------------------------- the parts
def _fire_sound() -> Sound:
    """The fire model (paper 001 §3: p = dI/dt of the flame-front flux, emitted at the
    moving front's centre)."""
    from auralize.pipeline import load
    from auralize.plugins import synthesize

    return synthesize("fire", load("dataset:fire", size=12), extend="none")


def _vortex_sound() -> Sound:
    """The vortex model (paper 000 §4–6: sub-volume emitters of the plume's texture)."""
    from auralize.pipeline import load
    from auralize.plugins import synthesize

    return synthesize("vortex", load("dataset:fire-plume", size=10, steps=4))


def _field_sound() -> Sound:
    from auralize.field_model import FieldAuralization
    from auralize.pipeline import load

    vol = load("dataset:monopole", size=12, steps=60)
    return FieldAuralization().synthesize(vol, threshold_monopole="1%", time_scale=1.0)


@pytest.fixture(scope="module")
def scene() -> tuple[Sound, ListenerPath]:
    sound = _field_sound() + _fire_sound() + _vortex_sound()
    # the listener walks and turns: arrivals, distances and panning change all the time
    path = ListenerPath.orbit((0.5, 0.5, 0.5), radius=2.0, duration=0.3, turns=0.2)
    return sound, path


def test_field_model_emits_field_sources_without_rendering() -> None:
    from auralize.emitters import FieldSources

    snd = _field_sound()
    assert isinstance(snd, Sound) and len(snd.parts) == 1
    part = snd.parts[0]
    assert isinstance(part, FieldSources) and part.tracks.n_sources > 0
    assert snd.meta["field"]["n_sources"] == part.tracks.n_sources


def test_scene_equals_the_sum_of_its_models_rendered_alone(scene) -> None:  # type: ignore[no-untyped-def]
    sound, path = scene
    assert [p.name for p in sound.parts] == ["field", "fire", "vortex"]
    mix = render_sound(sound, path, rate=RATE, layout="ring8")
    alone = [render_sound(p, path, rate=RATE, layout="ring8").audio for p in sound.parts]
    assert mix.audio.shape == (8, round(0.3 * RATE))
    total = np.sum(alone, axis=0)
    assert np.max(np.abs(mix.audio - total)) <= 1e-12 * np.max(np.abs(total))
    # each model is in the mix, however quiet (the plume's vortex sound is ~1e-12 Pa
    # beside the fire's ~0.1 Pa: compact vortex sound grows as u^4, paper 000 §5)
    for k, a in enumerate(alone):
        assert np.max(np.abs(a)) > 0
        others = np.sum([b for j, b in enumerate(alone) if j != k], axis=0)
        assert np.max(np.abs(mix.audio - others - a)) <= 1e-3 * np.max(np.abs(a))
    assert [p["model"] for p in mix.meta["parts"]] == ["field", "fire", "vortex"]


def test_scene_blocks_join_into_the_offline_render(scene) -> None:  # type: ignore[no-untyped-def]
    sound, path = scene
    off = render_sound(sound, path, rate=RATE, layout="stereo").audio
    sb = render_heard(sound, path, rate=RATE, layout="stereo", block=2205, highpass_hz=0)
    on = np.concatenate([sb.block(i) for i in range(sb.n_blocks)], axis=1)
    assert sb.n_blocks == 6 and on.shape == off.shape
    assert np.max(np.abs(on - off)) <= 1e-6 * np.max(np.abs(off))
    with pytest.raises(ParameterError, match=r"block index 6 outside 0\.\.5"):
        sb.block(6)


ASOUNDRC = """
pcm.auralize_file2 {{
    type file
    slave.pcm "null"
    file "{out2}"
    format "raw"
}}
"""


def test_scene_plays_live_with_no_underruns(scene, tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    from auralize.audio import refresh_devices
    from auralize.audio.live import play

    sound, path = scene
    cfg = tmp_path / "cfg"
    (cfg / "alsa").mkdir(parents=True)
    out2 = tmp_path / "dev2.raw"
    (cfg / "alsa" / "asoundrc").write_text(ASOUNDRC.format(out2=out2))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(cfg))
    refresh_devices()
    try:
        ref = render_sound(sound, path, rate=RATE, layout="stereo").audio
        gain = 0.9 / float(np.max(np.abs(ref)))
        sb = render_heard(sound, path, rate=RATE, layout="stereo", block=2205, highpass_hz=0)
        rep = play(sb, device="auralize_file2", gain=gain, wait_s=1.0)
    finally:
        monkeypatch.undo()
        refresh_devices()
    assert rep.underruns == 0 and rep.device_underflows == 0 and rep.blocks == 6
    dev = np.fromfile(out2, dtype="<f4").reshape(-1, 2).T.astype(np.float64)
    first = int(np.argmax(np.any(dev != 0, axis=0)))  # PortAudio may prime with silence
    lag = first - int(np.argmax(np.any(ref != 0, axis=0)))
    assert 0 <= lag <= RATE
    d = dev[:, lag : lag + ref.shape[1]]
    assert d.shape == ref.shape
    assert np.max(np.abs(d - gain * ref)) <= 1e-5  # the float32 frames of the offline render


# ----------------------------------------------------------- specs and files
def test_model_specs_parse() -> None:
    assert parse_model_spec("vortex:plume.h5") == SceneModel("vortex", "plume.h5", {})
    m = parse_model_spec("fire:dataset:fire:extend=none,seed=3,iso=0.5,flag=true")
    assert m == SceneModel(
        "fire", "dataset:fire", {"extend": "none", "seed": 3, "iso": 0.5, "flag": True}
    )
    assert parse_model_spec("field:C:/data/x.h5").input == "C:/data/x.h5"
    for bad, why in (
        ("fire", "NAME:FILE"),
        ("fire:", "NAME:FILE"),
        ("fire:x.h5:extend=none,oops", "key=value pairs"),
    ):
        with pytest.raises(ParameterError, match=why):
            parse_model_spec(bad)


def test_scene_file_reads_relative_inputs(tmp_path) -> None:  # type: ignore[no-untyped-def]
    ListenerPath.point([0, 0, 0], duration=1.0).to_csv(tmp_path / "p.csv")
    (tmp_path / "s.json").write_text(
        json.dumps(
            {
                "listener": {"path": "p.csv"},
                "layout": "stereo",
                "rate": 22050,
                "duration": 0.5,
                "models": [
                    {"model": "fire", "input": "dataset:fire"},
                    {"model": "tone", "input": "a.json", "params": {"gain": 2}},
                ],
            }
        )
    )
    sc = load_scene(tmp_path / "s.json")
    assert sc.layout == "stereo" and sc.rate == 22050 and sc.duration == 0.5
    assert sc.path is not None and sc.path.duration == 1.0
    assert sc.models[0].input == "dataset:fire"
    assert sc.models[1] == SceneModel("tone", str(tmp_path / "a.json"), {"gain": 2})


@pytest.mark.parametrize(
    ("doc", "why"),
    [
        ("[1, 2]", "holds a JSON object"),
        ("{not json", "not a JSON scene file"),
        ('{"models": []}', "'models' must be a non-empty list"),
        (
            '{"models": [{"model": "fire"}]}',
            r"models\[0\] must be an object with 'model' and 'input'",
        ),
        ('{"models": [{"model": "a", "input": "b", "gain": 1}]}', r"models\[0\] has unknown key"),
        ('{"models": [{"model": "a", "input": "b"}], "speed": 1}', "unknown scene key"),
        (
            '{"models": [{"model": "a", "input": "b"}], "listener": {"position": [1, 2]}}',
            r"listener.position must be \[x, y, z\]",
        ),
        ('{"models": [{"model": "a", "input": "b"}], "rate": "fast"}', "'rate' must be a int"),
    ],
)
def test_bad_scene_files_are_refused_in_one_line(tmp_path, doc: str, why: str) -> None:  # type: ignore[no-untyped-def]
    f = tmp_path / "s.json"
    f.write_text(doc)
    with pytest.raises(FormatError, match=why) as info:
        load_scene(f)
    assert str(f) in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(MissingFileError, match="scene file not found"):
        load_scene(tmp_path / "none.json")


def test_a_model_that_returns_something_else_is_named(tone_models) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(
        PluginError,
        match=r"plugin 'old' returned dict; SoundModel.synthesize "
        r"must return auralize.emitters.Sound",
    ):
        scene_sound([SceneModel("old", {"x": 1})])
    with pytest.raises(PluginError, match=r"plugin 'vortex' returned ndarray"):
        check_sound("vortex", np.zeros(3))
    with pytest.raises(
        PluginError,
        match=r"'base' cannot read its inputs from 'x.h5': it does "
        r"not implement SoundModel.load_input and 'x.h5' is "
        r"not a volume \(.*x.h5",
    ):
        SoundModel().load_input("x.h5")

    class TextureModel(SoundModel):
        name: ClassVar[str] = "tex"
        input_kind: ClassVar[str] = "a texture"

    with pytest.raises(PluginError, match=r"'tex' cannot read its inputs \(a texture\) from"):
        TextureModel().load_input("dataset:monopole")
    assert OldModel().load_input("dataset:monopole").n_steps > 1  # undeclared: volumes tried
    assert SoundModel.bench(True) == [] and SoundModel.add_cli(None, None) is None
    assert SoundModel.datasets == {}


# ----------------------------------------------------------------- the CLI
def _tone_sound(a: Path, b: Path) -> Sound:
    t = ToneModel()
    return t.synthesize(t.load_input(str(a))) + t.synthesize(t.load_input(str(b)), gain=2.0)


def test_render_models_equals_their_sum(tone_models, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    from auralize.audio import read_wav
    from auralize.cli import main

    a, b = tone_models
    out = tmp_path / "mix.wav"
    common = [
        "--listener",
        "0,0,0",
        "--duration",
        "0.4",
        "--layout",
        "stereo",
        "--highpass",
        "0",
        "--normalize",
        "none",
    ]
    assert (
        main(
            [
                "render",
                "--model",
                f"tone:{a}",
                "--model",
                f"tone:{b}:gain=2",
                *common,
                "-o",
                str(out),
            ]
        )
        == 0
    )
    assert "scene of 2 part(s): tone (Emitters), tone (Emitters)" in capsys.readouterr().out
    got, rate, mask = read_wav(out)
    path = ListenerPath.point([0, 0, 0], duration=0.4)
    ref = render_sound(_tone_sound(a, b), path, rate=RATE, layout="stereo").audio
    assert rate == RATE and mask == 0x3 and got.shape == ref.shape
    assert np.max(np.abs(got - ref)) <= 1e-6 * np.max(np.abs(ref))  # float32 WAV
    side = json.loads(Path(f"{out}.json").read_text())
    assert [m["model"] for m in side["scene"]] == ["tone", "tone"]
    assert side["scene"][1]["params"] == {"gain": 2}
    # the same scene from a file gives the same samples
    (tmp_path / "s.json").write_text(
        json.dumps(
            {
                "listener": {"position": [0, 0, 0]},
                "duration": 0.4,
                "layout": "stereo",
                "models": [
                    {"model": "tone", "input": str(a)},
                    {"model": "tone", "input": "b.json", "params": {"gain": 2}},
                ],
            }
        )
    )
    out2 = tmp_path / "scene.wav"
    assert (
        main(
            [
                "render",
                "--scene",
                str(tmp_path / "s.json"),
                "--highpass",
                "0",
                "--normalize",
                "none",
                "-o",
                str(out2),
            ]
        )
        == 0
    )
    assert np.array_equal(read_wav(out2)[0], got)


def test_render_field_plus_model_equals_field_render_plus_model(tone_models, tmp_path) -> None:  # type: ignore[no-untyped-def]
    from auralize.audio import read_wav
    from auralize.cli import main

    a, _ = tone_models
    field = [
        "dataset:monopole",
        "--size",
        "12",
        "--steps",
        "60",
        "--threshold-monopole",
        "1%",
        "--listener",
        "1.5,0.5,0.5",
        "--duration",
        "0.3",
        "--highpass",
        "0",
        "--normalize",
        "none",
        "--layout",
        "stereo",
    ]
    assert main(["render", *field, "-o", str(tmp_path / "f.wav")]) == 0
    assert main(["render", *field, "--model", f"tone:{a}", "-o", str(tmp_path / "m.wav")]) == 0
    f, m = read_wav(tmp_path / "f.wav")[0], read_wav(tmp_path / "m.wav")[0]
    t = ToneModel()
    tone = render_sound(
        t.synthesize(t.load_input(str(a))),
        ListenerPath.point([1.5, 0.5, 0.5], duration=0.3),
        rate=RATE,
        layout="stereo",
    ).audio
    assert f.shape == m.shape == tone.shape
    assert np.max(np.abs(f)) > 0.01 * np.max(np.abs(tone))
    assert np.max(np.abs(m - (f + tone))) <= 1e-5 * np.max(np.abs(m))


@pytest.mark.parametrize(
    ("args", "why", "code"),
    [
        (["--model", "tone"], "--model takes NAME:FILE", 2),
        (["--model", "nosuch:x.h5"], "no sound model 'nosuch'", 4),
        (["--model", "tone:a.json:loud=1"], "model 'tone' has no parameter", 2),
        (["--model", "old:x.h5"], "does not implement SoundModel.load_input", 4),
        (["--model", "tone:a.json"], "needs a listener", 2),
        ([], "give a volume PATH, or sound models with --model", 2),
    ],
)
def test_render_scene_errors(tone_models, tmp_path, capsys, args, why, code) -> None:  # type: ignore[no-untyped-def]
    from auralize.cli import main

    listener = [] if why == "needs a listener" else ["--listener", "0,0,0", "--duration", "0.1"]
    assert main(["render", *args, *listener, "-o", str(tmp_path / "x.wav")]) == code
    err = capsys.readouterr().err
    assert why in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.wav").exists()


def test_add_sound_model_mixes_in_scripts(tone_models) -> None:  # type: ignore[no-untyped-def]
    from auralize import simple
    from auralize.emitters.timbre import HIGHPASS_HZ, highpass

    a, b = tone_models
    simple.ResetSession()
    try:
        p = simple.CreateListenerPath("point", at=[0, 0, 0], duration=0.2)
        simple.AddSoundModel("tone", str(a))
        m = simple.AddSoundModel("tone", str(b), gain=2.0)
        r = simple.RenderAudio(path=p, layout="stereo")
        ref = render_sound(_tone_sound(a, b), p, rate=RATE, layout="stereo").audio
        # the models are heard as they are: the output high-pass filters the data's sources
        assert np.allclose(r.audio, ref, rtol=0, atol=1e-12)
        assert np.max(np.abs(highpass(ref, RATE, HIGHPASS_HZ) - ref)) > 1e-3 * np.max(np.abs(ref))
        simple.RemoveSoundModel(m)
        assert len(simple.GetSession().models) == 1
        with pytest.raises(ParameterError, match="model 'tone' has no parameter"):
            simple.AddSoundModel("tone", str(a), loud=1)
        with pytest.raises(ParameterError, match="no sound model 'old.h5' in the session"):
            simple.RemoveSoundModel("old.h5")
    finally:
        simple.ResetSession()


def test_render_duration_and_rate_mean_the_same_with_a_path(tone_models, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``--duration`` cuts (or extends) a ``--path``; ``--rate`` is the output rate."""
    from auralize.audio import read_wav
    from auralize.cli import main

    a, _ = tone_models
    ListenerPath.line([0, 0, 0], [1, 0, 0], duration=1.0).to_csv(tmp_path / "p.csv")
    out = tmp_path / "x.wav"
    assert (
        main(
            [
                "render",
                "--model",
                f"tone:{a}",
                "--path",
                str(tmp_path / "p.csv"),
                "--duration",
                "0.25",
                "--rate",
                "22050",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    audio, rate, _ = read_wav(out)
    assert rate == 22050 and audio.shape == (1, round(0.25 * 22050))


def test_play_command_plays_a_scene(tone_models, tmp_path, monkeypatch, capsys) -> None:  # type: ignore[no-untyped-def]
    """`auralize play --model ...` sends the scene's offline render to the device."""
    from auralize.audio import refresh_devices
    from auralize.cli import main

    a, b = tone_models
    cfg = tmp_path / "cfg"
    (cfg / "alsa").mkdir(parents=True)
    out2 = tmp_path / "dev2.raw"
    (cfg / "alsa" / "asoundrc").write_text(ASOUNDRC.format(out2=out2))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(cfg))
    refresh_devices()
    try:
        assert (
            main(
                [
                    "play",
                    "--model",
                    f"tone:{a}",
                    "--model",
                    f"tone:{b}:gain=2",
                    "--listener",
                    "0,0,0",
                    "--duration",
                    "0.3",
                    "--layout",
                    "stereo",
                    "--device",
                    "auralize_file2",
                    "--gain",
                    "2",
                    "--highpass",
                    "0",
                    "--json",
                ]
            )
            == 0
        )
    finally:
        monkeypatch.delenv("XDG_CONFIG_HOME")
        refresh_devices()
    rep = json.loads(capsys.readouterr().out)
    assert rep["layout"] == "stereo" and rep["blocks"] == 6 and rep["duration_s"] == 0.3
    ref = (
        2.0
        * render_sound(
            _tone_sound(a, b),
            ListenerPath.point([0, 0, 0], duration=0.3),
            rate=RATE,
            layout="stereo",
        ).audio
    )
    dev = np.fromfile(out2, dtype="<f4").reshape(-1, 2).T.astype(np.float64)
    lag = int(np.argmax(np.any(dev != 0, axis=0))) - int(np.argmax(np.any(ref != 0, axis=0)))
    d = dev[:, lag : lag + ref.shape[1]]
    assert d.shape == ref.shape and np.max(np.abs(d - ref)) <= 1e-5 * np.max(np.abs(ref))


def test_field_model_in_a_scene_fits_the_data_in_the_duration(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    """``field:...:time_scale=auto``: the data's span plays in the scene's duration."""
    from auralize.audio import read_wav
    from auralize.cli import main

    out = tmp_path / "f.wav"
    assert (
        main(
            [
                "render",
                "--model",
                "field:dataset:monopole:time_scale=auto,threshold_monopole=1%",
                "--listener",
                "1.5,0.5,0.5",
                "--duration",
                "0.3",
                "--highpass",
                "0",
                "-o",
                str(out),
                "--json",
            ]
        )
        == 0
    )
    rep = json.loads(capsys.readouterr().out)
    assert [p["model"] for p in rep["parts"]] == ["field"] and rep["parts"][0]["peak_pa"] > 0
    assert rep["scene"][0]["params"] == {"time_scale": "auto", "threshold_monopole": "1%"}
    audio, rate, _ = read_wav(out)
    assert audio.shape == (1, round(0.3 * rate))
    # auto: the data's span (plus the spread of arrival delays) plays in the 0.3 s
    from auralize.pipeline import load

    times = load("dataset:monopole").times
    assert rep["field"]["n_sources"] > 0
    assert 0 < rep["field"]["time_scale"] <= 0.3 / float(times[-1] - times[0])


def test_a_session_keeps_its_sound_models(tone_models, tmp_path) -> None:  # type: ignore[no-untyped-def]
    from auralize import simple

    a, _ = tone_models
    simple.ResetSession()
    try:
        simple.AddSoundModel("tone", str(a), gain=0.5)
        f = simple.SaveSession(tmp_path / "s.json")
        assert json.loads(f.read_text())["models"] == [
            {"model": "tone", "input": str(a.resolve()), "params": {"gain": 0.5}}
        ]
        s = simple.LoadSession(f)
        assert [(m.model, m.input, m.params) for m in s.models] == [
            ("tone", str(a.resolve()), {"gain": 0.5})
        ]
        simple.AddSoundModel("tone", {"position": [0, 0, 0], "freq": 1.0, "amplitude": 1.0})
        with pytest.raises(ParameterError, match="its input is a dict in memory"):
            simple.SaveSession(tmp_path / "t.json")
        assert not (tmp_path / "t.json").exists()
    finally:
        simple.ResetSession()


# ---------------------------------------------------------- the scene's length
def test_a_scene_lasts_until_its_last_emission_is_heard(tone_models, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Without ``--duration`` and with a static listener the scene ends when the last
    emitted sample has reached the listener: ``t_end + D / c0`` of each tone (0.5 s of
    emission, D = √10 m and √8.25 m), the later of the two."""
    from auralize.audio import read_wav
    from auralize.cli import main
    from auralize.emitters import C0
    from auralize.scene.soundscene import part_end, scene_length

    a, b = tone_models
    sound = _tone_sound(a, b)
    p = ListenerPath.point([0, 0, 0], duration=10.0)
    ends = [part_end(q, p) for q in sound.parts]
    assert ends == pytest.approx([0.5 + np.sqrt(10.0) / C0, 0.5 + np.sqrt(8.25) / C0], abs=1e-12)
    assert scene_length(sound, p) == max(ends)
    out = tmp_path / "x.wav"
    assert (
        main(
            [
                "render",
                "--model",
                f"tone:{a}",
                "--model",
                f"tone:{b}:gain=2",
                "--listener",
                "0,0,0",
                "--highpass",
                "0",
                "--normalize",
                "none",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    audio, rate, _ = read_wav(out)
    n = round(max(ends) * rate)
    assert audio.shape == (1, n)
    # the file holds every arrival: rendered twice as long, nothing more is heard
    long = render_sound(sound, p, rate=rate, duration=2 * max(ends)).audio
    assert np.max(np.abs(long[:, n:])) <= 1e-3 * np.max(np.abs(long))
    assert np.max(np.abs(long[:, n - round(0.01 * rate) : n])) > 0.1 * np.max(np.abs(long))
    assert np.max(np.abs(audio - long[:, :n])) <= 1e-5 * np.max(np.abs(long))


def test_the_volume_part_ends_when_the_data_sound_does() -> None:
    """The volume's sources end where :func:`plan_render` clips a render at a fixed time
    scale; a part that cannot tell its end counts the path's duration; a silent scene is
    refused."""
    from auralize.emitters import FieldSources
    from auralize.pipeline import detect_sources, load, plan_render
    from auralize.scene.soundscene import part_end, scene_length
    from auralize.sources import SourceTracks

    vol = load("dataset:monopole", size=12, steps=60)
    tracks = detect_sources(vol, thresholds=None).tracks()
    assert tracks.n_sources > 0
    for ts in (1.0, 3.0):
        plan = plan_render(vol, tracks, listener=[1.5, 0.5, 0.5], duration=10.0, time_scale=ts)
        assert plan.duration < 10.0  # clipped to the data's sound
        part = FieldSources(tracks, time_scale=ts, lead=plan.lead)
        assert part_end(part, plan.path) == pytest.approx(plan.duration, rel=1e-12)

    class Quiet:  # a model part with no end_time
        name = "quiet"

        def render_part(self, path, **kw):  # type: ignore[no-untyped-def]
            raise AssertionError("not rendered")

    p = ListenerPath.point([0, 0, 0], duration=2.5)
    assert part_end(Quiet(), p) is None
    assert scene_length([Quiet()], p) == 2.5
    assert scene_length([Quiet()], p, default=0.7) == 0.7
    empty = SourceTracks(np.zeros((0, 3)), np.zeros((0, 4)), np.zeros(0), np.arange(4.0))
    with pytest.raises(ParameterError, match="silent"):
        scene_length([FieldSources(empty)], p)


def test_add_sound_model_is_heard_after_the_data_sound_ends(tone_models) -> None:  # type: ignore[no-untyped-def]
    """A script's scene lasts the path's duration even when the data's sound is shorter:
    the models are not cut to it (the data alone still is)."""
    from auralize import simple
    from auralize.pipeline import auralize

    a, _ = tone_models
    simple.ResetSession()
    try:
        src = simple.OpenDataFile("dataset:monopole", size=12, steps=60)
        p = simple.CreateListenerPath("point", at=[1.5, 0.5, 0.5], duration=0.2)
        alone = simple.RenderAudio(src, path=p, time_scale=1.0)
        assert 0 < alone.audio.shape[1] < round(0.2 * RATE)  # the data's sound: clipped
        simple.AddSoundModel("tone", str(a))
        r = simple.RenderAudio(src, path=p)
        assert r.audio.shape == (1, round(0.2 * RATE))
        field, _ = auralize(src.Volume, p, series=src.Sources, time_scale=1.0, clip=False)
        tone = render_sound(
            ToneModel().synthesize(ToneModel().load_input(str(a))), p, rate=RATE
        ).audio
        assert np.max(np.abs(tone[:, alone.audio.shape[1] :])) > 0.1 * np.max(np.abs(tone))
        assert np.max(np.abs(r.audio - (field.audio + tone))) <= 1e-9 * np.max(np.abs(r.audio))
    finally:
        simple.ResetSession()


@pytest.mark.parametrize("timbre", ["extended", "auto"])
def test_a_scene_of_the_field_is_auralize_render_whatever_the_timbre(tmp_path, timbre) -> None:  # type: ignore[no-untyped-def]
    """The field model in a scene file writes the samples of ``auralize render`` with the
    same data, path and timbre: the 20 Hz high-pass is the timbre's (its ``auto`` and
    ``extended`` choices depend on it), not a second filter after it."""
    import json

    import auralize
    from auralize.audio import read_wav
    from auralize.cli import main

    # the shipped cavity (a real simulation): its sound lies below 20 Hz, so the
    # timbre's choices depend on the high-pass
    vol = auralize.open("dataset:cavity")
    c, w = np.asarray(vol.center), vol.bounds[3] - vol.bounds[2]
    csv = tmp_path / "p.csv"
    ListenerPath.line(c + [0, -w, 0], c + [0, w, 0], duration=1.0).to_csv(csv)
    data = {"spec": "dataset:cavity"}
    (tmp_path / "s.json").write_text(
        json.dumps(
            {
                "listener": {"path": str(csv)},
                "layout": "stereo",
                "models": [{"model": "field", "input": data, "params": {"timbre": timbre}}],
            }
        )
    )
    assert main(["render", "--scene", str(tmp_path / "s.json"), "-o", str(tmp_path / "a.wav")]) == 0
    assert (
        main(
            [
                "render",
                "dataset:cavity",
                "--path",
                str(csv),
                "--layout",
                "stereo",
                "--timbre",
                timbre,
                "-o",
                str(tmp_path / "b.wav"),
            ]
        )
        == 0
    )
    a, b = read_wav(tmp_path / "a.wav")[0], read_wav(tmp_path / "b.wav")[0]
    assert np.max(np.abs(b)) > 0.5 and np.array_equal(a, b)
