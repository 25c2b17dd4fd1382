"""``auralize describe``: the sources in words, checked against the render they describe.

The onsets it states are checked against where each type's rendered sound
starts (the pipeline's own render, ``auralize(..., heard=TYPE)``, at another
rate), and its levels against the mean square of those renders over the same
playback spans: within :data:`LEVEL_TOL_DB`, and in the same order.
"""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest

from auralize.cli import main
from auralize.describe import (
    Description,
    arrival_times,
    box_region,
    describe,
    direction_words,
)
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.pipeline import RenderPlan, auralize, detect_sources, load

#: describe's level of an event vs the mean square of its type's render over the event, dB
LEVEL_TOL_DB = 1.5
#: rendered sound below this fraction of its peak amplitude counts as silence
SILENCE = 1e-3


# ------------------------------------------------------------------ words and clocks
def test_box_thirds_in_words() -> None:
    b = (0, 3, 0, 3, 0, 3)
    pts = np.array([[0.5, 0.5, 2.5], [2.5, 2.5, 0.5], [1.5, 1.5, 1.5], [1.5, 0.5, 1.5]])
    assert box_region(pts, b) == [
        "in the upper left front corner",
        "in the lower right back corner",
        "at the centre of the box",
        "in the front part of the box",
    ]
    # an axis of no extent (a one-layer grid) adds no word
    assert box_region(np.array([[0.5, 1.5, 7.0]]), (0, 3, 0, 3, 7, 7)) == [
        "in the left part of the box"
    ]


def test_directions_count_counter_clockwise_from_ahead() -> None:
    az = np.array([0, 44, 46, 90, 180, -90, -135, 170])
    el = np.array([0, 0, 0, 0, 0, 0, -45, 0])
    assert direction_words(az, el) == [
        "ahead",
        "ahead-left",
        "ahead-left",
        "left",
        "behind",
        "right",
        "behind-right, below",
        "behind",
    ]


def _plan(path: ListenerPath, ts: float, lead: float, duration: float) -> RenderPlan:
    return RenderPlan(
        path=path, time_scale=ts, duration=duration, lead=lead, auto=False, default_listener=False
    )


def test_arrival_time_of_a_static_listener_is_the_closed_form() -> None:
    c0 = 343.0
    path = ListenerPath.point((100.0, 0.0, 0.0), duration=20.0)
    plan = _plan(path, ts=3.0, lead=0.1, duration=20.0)
    pts = np.array([[0.0, 0.0, 0.0], [50.0, 30.0, 0.0], [100.0, 0.0, 40.0]])
    te = np.array([0.5, 1.0, 2.0])
    d = np.linalg.norm(pts - path.positions[0], axis=1)
    want = (te + d / c0 - 0.0 - 0.1) * 3.0  # t0 = 0
    assert np.allclose(arrival_times(plan, pts, te, 0.0), want, atol=1e-9)


def test_arrival_time_of_a_moving_listener_solves_the_retarded_time() -> None:
    """A listener walking past: τ solves t0 + lead + τ/ts − |L(τ) − x|/c0 = t (checked by
    putting τ back in), including a sound heard after the path ends (the listener held)."""
    c0 = 343.0
    path = ListenerPath.line((-200.0, 50.0, 0.0), (200.0, 50.0, 0.0), duration=4.0, n=9)
    plan = _plan(path, ts=2.0, lead=0.05, duration=4.0)
    pts = np.array([[0.0, 0.0, 0.0], [30.0, -10.0, 5.0], [0.0, 0.0, 0.0]])
    te = np.array([0.3, 1.0, 2.5])  # the last one arrives after the path's end
    tau = arrival_times(plan, pts, te, 0.0)
    where = path.position_at(np.minimum(tau, path.duration))
    g = 0.05 + tau / 2.0 - np.linalg.norm(where - pts, axis=1) / c0
    assert tau[2] > plan.duration
    assert np.allclose(g, te, atol=2e-4)


# ------------------------------------------------------------------ against the render
def _envelope_span(x: np.ndarray, rate: int) -> tuple[float, float]:
    """First and last playback second at which ``x`` exceeds :data:`SILENCE` of its peak."""
    on = np.flatnonzero(np.abs(x) > SILENCE * np.max(np.abs(x)))
    return on[0] / rate, on[-1] / rate


def _check_against_render(vol, series, listener, *, ts: float) -> Description:  # type: ignore[no-untyped-def]
    """Describe ``vol`` heard from ``listener`` (detected sources, fixed time scale), then
    render each type's detected sources through the pipeline and check the onsets, ends
    and levels the description states."""
    rate = 16000
    d = describe(
        vol, series=series, listener=listener, heard="detected", time_scale=ts, interp="linear"
    )
    assert d.events
    dt = float(np.max(np.diff(vol.times)))
    h = dt * ts  # playback seconds of one step
    lead = d.plan["lead_data_s"]
    ms_desc, ms_render = [], []
    renders = {}
    for e in d.events:
        if e.type not in renders:
            out, _ = auralize(
                vol,
                None,
                listener=listener,
                series=series,
                heard=e.type,
                time_scale=ts,
                duration=d.plan["duration_s"] + 2 * h,
                timbre="physical",
                highpass_hz=0.0,
                interp="linear",
                rate=rate,
                method="volume",
                clip=False,
            )
            # each render plans its own travel skip (the box of what it hears): put its
            # clock on the description's
            shift = (lead - out.meta["lead_data_s"]) * ts
            renders[e.type] = (out.audio[0], shift)
        x, shift = renders[e.type]
        # the earliest and latest the event's sound can be heard: from its nearest point at
        # the step before its first (the linear ramp from silence starts there), and from
        # its farthest point at the step after its last
        code = 1 + ("monopole", "dipole", "quadrupole").index(e.type)
        idx = np.concatenate(
            [f.index[f.kind == code] for f in series.frames[e.first_step : e.last_step + 1]]
        )
        dist = np.linalg.norm(series.positions(idx) - np.asarray(listener), axis=1)
        t0 = float(vol.times[0])
        earliest = (float(vol.times[e.first_step]) - dt + dist.min() / 343.0 - t0 - lead) * ts
        latest = (float(vol.times[e.last_step]) + dt + dist.max() / 343.0 - t0 - lead) * ts
        assert e.audio_start is not None and e.audio_end is not None
        mine = x.copy()  # this event's part of the type's render
        mine[: max(0, int((earliest + shift) * rate) - 1)] = 0.0
        mine[int((latest + shift) * rate) + 2 :] = 0.0
        on, off = _envelope_span(mine, rate)
        on, off = on - shift, off - shift
        # the stated onset (the arrival of the first step from the points' centre) comes
        # after the sound starts to rise; nothing is heard after the step after the stated
        # end (before it the sound may fade early: the signed strengths of a ring of
        # dipoles cancel at a far listener)
        assert earliest - 2 / rate <= on <= e.audio_start + 2 / rate, (e, earliest, on)
        assert e.audio_start <= off <= latest + 2 / rate, (e, off, latest)
        lo, hi = e.audio_start - h / 2 + shift, e.audio_end + h / 2 + shift
        seg = x[int(max(lo, 0.0) * rate) : int(hi * rate)]
        ms_render.append(float(np.mean(seg**2)))
        ms_desc.append(e.level_db)
    got = 10 * np.log10(np.array(ms_render) / max(ms_render))
    stated = np.array(ms_desc, dtype=float)
    loud = stated > -60  # the ranking and figures of what can be heard beside the loudest
    assert np.allclose(got[loud], stated[loud], atol=LEVEL_TOL_DB), (got, stated)
    assert list(np.argsort(-got[loud])) == list(np.argsort(-stated[loud]))
    return d


def test_explosion_onsets_and_levels_match_the_render() -> None:
    vol = load("dataset:explosion", size=32, steps=12)
    series = detect_sources(vol)
    c = vol.center
    d = _check_against_render(vol, series, c + [60.0, 10.0, 5.0], ts=4.0)
    kinds = {e.type for e in d.events}
    assert {"monopole", "dipole"} <= kinds
    text = d.text()
    assert "monopoles" in text and "What you will hear" in text
    # the burst starts at the centre: the first step's monopoles are at the box's centre
    first = [r for r in d.rows if r.step == 0 and r.type == "monopole"]
    assert first and first[0].region == "at the centre of the box"
    # the data lie towards −x of a listener facing +y: on its left
    assert first[0].direction == "left"


def test_cavity_onsets_and_levels_match_the_render() -> None:
    vol = load("dataset:cavity")
    series = detect_sources(vol)
    d = _check_against_render(vol, series, (0.05, -0.1, 0.005), ts=0.5)
    assert any(e.type == "quadrupole" for e in d.events)
    # the lid drives the flow along the top of the cavity (large y): its quadrupoles
    # are in the back third, ahead of a listener in front of the box facing +y
    q = [r for r in d.rows if r.type == "quadrupole"]
    assert all("back" in r.region for r in q)
    assert all(r.direction == "ahead" for r in q)


def test_levels_are_relative_to_the_loudest_and_silence_is_said() -> None:
    vol = load("dataset:monopole", size=12, steps=16)
    d = describe(vol, listener=(0.9, 0.5, 0.5), duration=1.0)
    assert max(r.level_db for r in d.rows if r.level_db is not None) == 0.0
    assert "no sources" in d.text()  # the pulse's quiet steps
    # a listener that hears nothing within the render: said, not a number
    late = describe(vol, listener=(0.9, 0.5, 0.5), duration=1.0, time_scale=1e-3)
    assert "not heard within the render" in late.text() or all(
        r.audio_time is None for r in late.rows
    )


def test_describe_refuses_sources_of_other_data() -> None:
    vol = load("dataset:monopole", size=12, steps=16)
    other = detect_sources(load("dataset:monopole", size=12, steps=10))
    with pytest.raises(ParameterError, match="10 steps, the data 16"):
        describe(vol, series=other, listener=(0.9, 0.5, 0.5), duration=1.0)


# ------------------------------------------------------------------ the command
def test_command_text_csv_and_json(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    args = [
        "describe",
        "dataset:monopole",
        "--size",
        "12",
        "--steps",
        "16",
        "--listener",
        "0.9,0.5,0.5",
        "--duration",
        "1",
    ]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert text.startswith("Sources in dataset:monopole")
    assert main([*args, "--format", "csv"]) == 0
    rows = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert rows and {r["type"] for r in rows} == {"monopole"}
    assert float(rows[0]["distance_m"]) > 0
    out = tmp_path / "d.json"
    assert main([*args, "-o", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["source"] == "dataset:monopole"
    assert data["events"][0]["type"] == "monopole"
    assert [r["step"] for r in data["steps"]] == [int(r["step"]) for r in rows]


def test_command_refuses_a_bad_format(capsys) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(SystemExit) as err:
        main(["describe", "dataset:monopole", "--format", "yaml"])
    assert err.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


def test_the_default_plan_is_the_default_renders() -> None:
    """Without a listener or a time scale, the description's clock is that of ``auralize
    render`` with the same options: the same orbit, time scale and travel skipped."""
    vol = load("dataset:explosion", size=16, steps=8)
    d = describe(vol, duration=2.0)
    out, _ = auralize(vol, duration=2.0, rate=8000, method="volume")
    for key in ("time_scale", "lead_data_s", "duration_s", "listener", "time_mapping"):
        assert d.plan[key] == out.meta[key], key
    # and with --heard detected, whose default orbit goes around the detected sources
    d = describe(vol, duration=2.0, heard="detected")
    out, _ = auralize(vol, duration=2.0, rate=8000, method="volume", heard="detected")
    assert d.plan["lead_data_s"] == out.meta["lead_data_s"]
    assert d.plan["listener"] == out.meta["listener"]
