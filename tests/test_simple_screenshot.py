"""``auralize.simple`` scripts (issue "The viewer, round 3", item 9): a screenshot shows
the active source, a wrong argument to Show says which, and ``time_scale="auto"``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from auralize.errors import FormatError, ParameterError
from auralize.scene.session import SessionState
from auralize.scene.view import BACKGROUND
from auralize.simple import (
    CreateListenerPath,
    CreateView,
    GetActiveView,
    GetSession,
    LoadSession,
    OpenDataFile,
    Render,
    RenderAudio,
    ResetSession,
    SaveScreenshot,
    SaveSession,
    Show,
)

SMALL = {"size": 16, "steps": 6}


@pytest.fixture(autouse=True)
def fresh():
    ResetSession()
    yield
    ResetSession()


def _lit_fraction(png) -> float:
    img = np.asarray(Image.open(png).convert("RGB")).astype(int)
    return float((np.abs(img - np.asarray(BACKGROUND)).sum(axis=2) > 30).mean())


def test_screenshot_before_show_shows_the_active_source(tmp_path):
    src = OpenDataFile("dataset:explosion", **SMALL)
    out = SaveScreenshot(tmp_path / "v.png", resolution=(320, 240))
    with Image.open(out) as im:
        assert im.size == (320, 240)
    assert GetActiveView().shown is src  # shown, as Show(src) would
    assert _lit_fraction(out) > 0.02  # the data, not an all-dark picture
    # the same picture as showing first
    ResetSession()
    src = OpenDataFile("dataset:explosion", **SMALL)
    Show(src)
    ref = SaveScreenshot(tmp_path / "ref.png", resolution=(320, 240))
    a = np.asarray(Image.open(out).convert("RGB"), dtype=float)
    b = np.asarray(Image.open(ref).convert("RGB"), dtype=float)
    assert np.abs(a - b).mean() < 2.0


def test_screenshot_with_nothing_to_show_says_why(tmp_path):
    with pytest.raises(ParameterError, match="nothing to show.*OpenDataFile"):
        SaveScreenshot(tmp_path / "v.png")
    assert not (tmp_path / "v.png").exists()
    # a view with a listener path and no data shows the path
    CreateListenerPath("orbit", center=(0, 0, 0), radius=1.0, duration=1.0)
    out = SaveScreenshot(tmp_path / "p.png", resolution=(160, 120))
    assert out.exists()


def test_show_with_a_wrong_argument_names_it():
    src = OpenDataFile("dataset:monopole", size=10, steps=20)
    path = CreateListenerPath("point", duration=0.1)
    with pytest.raises(TypeError, match=r"Show view argument must be a View.*ListenerPath") as e:
        Show(src, path)  # type: ignore[arg-type]
    assert isinstance(e.value, ParameterError)
    assert "Show(path)" in str(e.value)
    with pytest.raises(ParameterError, match="first argument must be a data source"):
        Show("dataset:monopole")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="Render view argument must be a View"):
        Render(src)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="SaveScreenshot view argument"):
        SaveScreenshot("x.png", path)  # type: ignore[arg-type]
    v = Show(src, CreateView(size=(80, 60)))  # the right kinds still work
    assert v.shown is src


def test_time_scale_auto_is_the_default_and_accepted(tmp_path):
    assert GetSession().audio["time_scale"] == "auto"  # as the CLI's --time-scale
    src = OpenDataFile("dataset:monopole", size=10, steps=20)
    centre = np.asarray(src.Volume.center)
    p = CreateListenerPath("point", at=centre + [0.5, 0, 0], duration=0.05)
    Show(src)  # the listener glyph is placed with the auto scale
    r = RenderAudio(src, path=p)
    assert r.audio.shape == (1, round(0.05 * 44100))
    assert r.meta["time_scale_auto"] is True
    # the data's span (plus the spread of arrival delays) plays in the path's 0.05 s
    assert 0 < r.meta["time_scale"] <= 0.05 / np.ptp(src.Volume.times)
    r2 = RenderAudio(src, path=p, time_scale="auto")
    assert np.allclose(r.audio, r2.audio)
    r3 = RenderAudio(src, path=p, time_scale=2.0)
    assert r3.meta["time_scale"] == 2.0 and GetSession().audio["time_scale"] == 2.0
    with pytest.raises(ParameterError, match="time_scale must be 'auto' or a number"):
        RenderAudio(src, path=p, time_scale="fast")
    # a session saved with "auto" loads back with it
    GetSession().audio["time_scale"] = "auto"
    f = SaveSession(tmp_path / "s.json")
    assert json.loads(f.read_text())["audio"]["time_scale"] == "auto"
    assert LoadSession(f).audio["time_scale"] == "auto"
    bad = json.loads(f.read_text())
    bad["audio"]["time_scale"] = "fast"
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    with pytest.raises(FormatError, match="time_scale"):
        SessionState.load(tmp_path / "bad.json")
