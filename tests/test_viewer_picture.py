"""A tidy picture, under Xvfb: one colour bar per coloured thing shown, never on top of
each other; overlay switches that follow the overlays; the command line's layouts."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("pytestqt")
pytest.importorskip("pyvistaqt")

from auralize.defaults import LAYOUT_NAMES
from auralize.spatial.layouts import get_layout


def _rect(bar) -> tuple[float, float, float, float]:  # type: ignore[no-untyped-def]
    """(x0, y0, x1, y1) of a scalar bar in normalised viewport coordinates."""
    x, y = bar.GetPositionCoordinate().GetValue()[:2]
    w, h = bar.GetPosition2Coordinate().GetValue()[:2]
    return x, y, x + w, y + h


def _overlap(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def test_each_coloured_overlay_has_its_own_bar_clear_of_the_fields(qtbot, open_viewer) -> None:  # type: ignore[no-untyped-def]
    win, shown = open_viewer()
    win.open_data("dataset:explosion", size=16, steps=8)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    result: list[bool] = []
    win.set_overlay("vortex", True, then=result.append)
    qtbot.waitUntil(lambda: bool(result) and not win.busy, timeout=120_000)
    assert result == [True] and not shown
    assert win.overlay_checks["vortex"].isChecked()  # the switch follows a scripted change
    bars = dict(win.plotter.scalar_bars.items())
    assert sorted(bars) == ["log10_density", "vortex overlay: speed"]
    rects = [_rect(b) for b in bars.values()]
    assert not _overlap(*rects)
    assert all(0 <= r[0] < r[2] <= 1 and 0 <= r[1] < r[3] <= 1 for r in rects)
    # the labels sit below the bar, the title apart from them
    for b in bars.values():
        assert b.GetTextPosition() == b.PrecedeScalarBar
    win.set_overlay("vortex", False)
    assert not win.overlay_checks["vortex"].isChecked()
    assert list(win.plotter.scalar_bars.keys()) == ["log10_density"]


def test_the_layouts_are_the_command_lines_and_a_custom_file_is_checked(
    window,
    tmp_path,  # type: ignore[no-untyped-def]
    errors,
) -> None:
    from auralize.cli.options import add_output_options

    items = [window.layout_box.itemText(i) for i in range(window.layout_box.count())]
    assert items[:-1] == list(LAYOUT_NAMES) and items[-1].startswith("custom layout file")
    import argparse

    p = argparse.ArgumentParser()
    add_output_options(p)
    cli = next(a for a in p._actions if a.dest == "layout").help
    assert all(name in cli for name in LAYOUT_NAMES)
    # a custom layout file: checked, then added to the list and used
    f = tmp_path / "quad.json"
    quad = get_layout("ring8")
    f.write_text(json.dumps(quad.describe()))
    window.set_layout(f)
    assert window.audio["layout"] == str(f) and window.layout_box.currentText() == str(f)
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    window._guard(window.set_layout, bad)
    assert str(bad) in errors[-1] or "bad.json" in errors[-1]
    assert window.audio["layout"] == str(f) and window.layout_box.currentText() == str(f)


def test_opening_new_data_clears_what_the_panels_said_of_the_old(
    qtbot,
    open_viewer,  # type: ignore[no-untyped-def]
    tmp_path,
) -> None:
    from auralize.listener import ListenerPath

    win, shown = open_viewer()
    win.open_data("dataset:monopole", size=12, steps=20)
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    win.detect()
    qtbot.waitUntil(lambda: win.series is not None and not win.busy, timeout=60_000)
    csv = tmp_path / "p.csv"
    ListenerPath.point(win.volume.center + [1.0, 0, 0], duration=0.2).to_csv(csv)
    win.load_path(csv)
    win.render_audio()
    qtbot.waitUntil(lambda: win.rendered is not None and not win.busy, timeout=60_000)
    assert win.detect_note.text().startswith("detected") and win.figure.axes
    win.open_data("dataset:explosion", size=12, steps=6, keep_path=False)
    qtbot.waitUntil(
        lambda: not win.busy and win.volume.source == "dataset:explosion", timeout=60_000
    )
    assert win.rendered is None and not win.figure.axes
    assert win.detect_note.text() == "sources are detected when you ask (Detect)"
    assert win.live_label.text() == "off" and win.count_labels["monopole"].text() == "–"
    assert not shown
