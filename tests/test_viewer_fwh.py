"""The FW-H surface in the viewer: the ``fwh`` model's overlay draws the surface the
integral runs over, coloured by the pressure fluctuation of the step shown, and its
sound joins what the viewer plays and renders."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.fwh.analytic import Pulse, pulse_field, pulse_volume
from auralize.fwh.surface import box_surface
from auralize.io import save_volume

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

C0, RHO0, P0 = 343.0, 1.2, 101325.0
PULSE = Pulse(amplitude=5e-3, sigma=1e-3, centre=8e-3, c0=C0, rho0=RHO0, p0=P0)
XS = np.array([0.013, -0.007, 0.011])


@pytest.fixture
def stored_sound(tmp_path):  # type: ignore[no-untyped-def]
    """The exact linear field of a monopole pulse (density, velocity, pressure) on 21³
    points, 0.1 m apart, saved as a file the viewer opens."""
    vol = pulse_volume(
        "monopole", XS, n=21, spacing=0.1, origin=-1.0, steps=40, dt=4e-4, pulse=PULSE
    )
    out = tmp_path / "pulse.h5"
    save_volume(vol, out)
    return out


def test_fwh_overlay_draws_the_surface_and_is_heard(qtbot, open_viewer, stored_sound) -> None:  # type: ignore[no-untyped-def]
    win, shown = open_viewer()
    assert "fwh" in win.overlay_checks
    assert win.overlay_checks["fwh"].toolTip().startswith("show the fwh model's overlay")
    win.open_data("dataset:monopole", size=12)  # sources, not sound waves: no advice
    qtbot.waitUntil(lambda: win.volume is not None and not win.busy, timeout=60_000)
    assert win.sound_wave_hint is None and win.overlay_note.text() == ""
    win.open_data(str(stored_sound))
    qtbot.waitUntil(lambda: not win.busy and win.volume.source.endswith("pulse.h5"), timeout=60_000)
    # the data hold sound waves: the viewer says how to hear them as `render` does
    hint = win.sound_wave_hint
    assert hint is not None and "obeys the wave equation" in hint and "Tick fwh" in hint
    assert win.overlay_note.text() == hint and win.statusBar().currentMessage() == hint
    win.set_step(30)
    qtbot.waitUntil(lambda: not win.busy, timeout=60_000)
    result: list[bool] = []
    win.set_overlay("fwh", True, then=result.append)
    qtbot.waitUntil(lambda: bool(result) and "fwh" in win._overlay_sounds, timeout=120_000)
    assert result == [True] and win.overlay_checks["fwh"].isChecked()
    actor = win.scene._actors["overlay:fwh:0"]
    mesh = actor.mapper.dataset
    surface = box_surface([-0.7, 0.7] * 3, panel_size=0.1)  # 3 cells inside each face
    assert mesh.n_cells == surface.n_panels == 6 * 14 * 14
    exact = pulse_field("monopole", XS, win.volume.times[30], surface.centres, PULSE)[0]
    got = mesh.cell_data["p' (Pa)"]
    assert np.max(np.abs(exact)) > 0.1
    assert np.max(np.abs(got - exact)) < 0.1 * np.max(np.abs(exact))
    assert any("fwh overlay: p' (Pa)" in t for t in win.scene.plotter.scalar_bars.keys())
    vol, sound = win._overlay_sounds["fwh"]
    assert vol is win.volume and sound.meta["panels"] == surface.n_panels
    win.set_overlay("fwh", False)
    assert "overlay:fwh:0" not in win.scene._actors and "fwh" not in win._overlay_sounds
    assert win.overlay_note.text() == ""
    assert not shown
