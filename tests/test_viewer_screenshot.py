"""``auralize view --screenshot`` against a reference picture (with tolerance), so that a
blank or mis-coloured view fails; the source types keep the one palette."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from auralize.cli import main
from auralize.scene import PALETTE

REFERENCE = Path(__file__).parent / "data" / "viewer_reference.png"
ARGS = [
    "view",
    "dataset:explosion",
    "--size",
    "24",
    "--steps",
    "6",
    "--detect",
    "--time",
    "3",
    "--window-size",
    "400x300",
]


def _read(path: Path) -> np.ndarray:
    import matplotlib.image as mpimg

    return (mpimg.imread(path)[..., :3] * 255).astype(np.int16)


def _palette_pixels(img: np.ndarray) -> dict[str, int]:
    """Saturated pixels by the nearest palette hue (shading scales colours, so compare
    directions in RGB space)."""
    v = img.astype(np.float64).reshape(-1, 3)
    sat = v.max(axis=1) - v.min(axis=1) > 60
    v = v[sat] / (np.linalg.norm(v[sat], axis=1, keepdims=True) + 1e-9)
    pal = np.array([PALETTE[k] for k in PALETTE], dtype=np.float64)
    pal /= np.linalg.norm(pal, axis=1, keepdims=True)
    cos = v @ pal.T
    best = np.argmax(cos, axis=1)
    ok = cos[np.arange(best.size), best] > 0.95
    return {k: int(np.sum(ok & (best == i))) for i, k in enumerate(PALETTE)}


def compare(img: np.ndarray, ref: np.ndarray) -> list[str]:
    """What differs beyond tolerance (empty when the picture matches)."""
    if img.shape != ref.shape:
        return [f"size {img.shape} != {ref.shape}"]
    problems = []
    diff = float(np.mean(np.abs(img - ref)))
    if diff > 12:
        problems.append(f"mean difference {diff:.1f} of 255")
    got, want = _palette_pixels(img), _palette_pixels(ref)
    for kind in PALETTE:
        if not 0.75 * want[kind] - 20 <= got[kind] <= 1.33 * want[kind] + 20:
            problems.append(f"{kind}: {got[kind]} pixels of its colour, reference {want[kind]}")
    return problems


def test_screenshot_matches_reference(tmp_path) -> None:
    out = tmp_path / "shot.png"
    assert main([*ARGS, "--screenshot", str(out)]) == 0
    img, ref = _read(out), _read(REFERENCE)
    assert all(v > 50 for v in _palette_pixels(ref).values())  # all three types shown
    assert compare(img, ref) == []


def test_screenshot_refuses_a_missing_folder(tmp_path, capsys) -> None:
    out = tmp_path / "missing" / "shot.png"
    assert main([*ARGS[:6], "--screenshot", str(out)]) == 4  # OutputError
    assert "does not exist" in capsys.readouterr().err
    assert not (tmp_path / "missing").exists()


def test_comparison_fails_for_blank_and_miscoloured_views() -> None:
    ref = _read(REFERENCE)
    blank = np.full_like(ref, 26)
    assert compare(blank, ref)
    # dipole and quadrupole colours swapped (the palette mix-up this guards against)
    swapped = ref.copy()
    d, q = (np.asarray(PALETTE[k]) for k in ("dipole", "quadrupole"))
    v = ref.astype(np.float64)
    norm = np.linalg.norm(v, axis=-1, keepdims=True) + 1e-9
    for a, b in ((d, q), (q, d)):
        m = ((v @ a) / (norm[..., 0] * np.linalg.norm(a)) > 0.985) & (norm[..., 0] > 60)
        swapped[m] = (b / np.linalg.norm(b) * norm[m]).astype(np.int16)
    assert any("dipole" in p or "quadrupole" in p for p in compare(swapped, ref))


def test_one_palette_for_viewer_pictures_plots_and_pvd(tmp_path) -> None:
    import pyvista as pv

    from auralize.pipeline import detect_sources, load
    from auralize.scene import TYPE_COLORS, TYPE_LABELS
    from auralize.scene.plots import plot_counts
    from auralize.scene.view import TYPE_COLORS as VIEWER_COLORS
    from auralize.sources.sources_file import save_sources_pvd

    assert VIEWER_COLORS == PALETTE
    for code, name in TYPE_LABELS.items():
        assert TYPE_COLORS[code] == "#{:02x}{:02x}{:02x}".format(*PALETTE[name])
    series = detect_sources(load("dataset:explosion", size=16, steps=4))
    save_sources_pvd(series, tmp_path / "s.pvd")
    step = pv.read(tmp_path / "s_data" / "step_0002.vtp")
    kinds = np.asarray(step.point_data["kind"])
    rgb = np.asarray(step.point_data["rgb"])
    for code, name in TYPE_LABELS.items():
        assert np.all(rgb[kinds == code] == PALETTE[name])
    ax = plot_counts(series)
    for line in ax.get_lines():  # the legend lists only the types present
        assert np.allclose(line.get_color(), np.asarray(PALETTE[line.get_label()]) / 255)


def test_vector_glyphs_and_robust_colour_range() -> None:
    import pytest
    import pyvista as pv

    from auralize.errors import ParameterError
    from auralize.pipeline import load
    from auralize.scene.view import MAX_GLYPHS, Scene, robust_range

    pl = pv.Plotter(off_screen=True, window_size=[200, 150])
    try:
        scene = Scene(pl)
        scene.set_volume(load("dataset:explosion", size=24, steps=4), representation="glyphs")
        mesh = scene._vol_mesh
        assert mesh.n_points > 0 and "value" in mesh.point_data
        assert scene.sources is None  # shown without any detection
        scene.set_volume(load("dataset:monopole", size=12, steps=4))
        with pytest.raises(ParameterError, match="no vector field"):
            scene.set_representation("glyphs")
    finally:
        pl.close()
    assert MAX_GLYPHS >= 1000
    a = np.concatenate([np.linspace(0, 1, 999), [1e30, -9.99e33, np.nan, np.inf]])
    lo, hi = robust_range([a])
    assert 0 <= lo < 0.02 and 0.98 < hi <= 1


def test_a_one_layer_grid_is_drawn_as_a_coloured_surface(tmp_path) -> None:
    """A flat grid has no inside to ray-cast or contour: it is drawn as its coloured
    surface in the viewer's scene and in the demo's pictures (not only an outline)."""
    from auralize.io import save_volume
    from auralize.scene.pictures import screenshot
    from auralize.volume import TimeVolume

    t = np.arange(8) * 1e-3
    x = np.linspace(-1, 1, 24)
    bump = np.exp(-(x[None, :] ** 2 + x[:, None] ** 2) / 0.1)
    rho = 1.2 - 1e-3 * (1 + t)[:, None, None, None] * bump[None, None]
    vol = TimeVolume.from_arrays({"density": rho}, spacing=2 / 23, times=t)
    f = tmp_path / "flat.h5"
    save_volume(vol, f)
    shots = [tmp_path / "view.png", tmp_path / "picture.png"]
    assert (
        main(
            [
                "view",
                str(f),
                "--time",
                "4",
                "--window-size",
                "400x300",
                "--screenshot",
                str(shots[0]),
            ]
        )
        == 0
    )
    screenshot(vol, shots[1], step=4, window_size=(400, 300))
    for shot in shots:
        img = _read(shot)[:250]  # above the colour bar
        grey = img.mean(axis=2)
        lit = grey > 60  # the background is near black
        # the surface covers a good part of the picture and shows the bump's gradient
        assert lit.mean() > 0.15, shot.name
        assert np.ptp(grey[lit]) > 100 and np.unique(grey[lit].round()).size > 50, shot.name
