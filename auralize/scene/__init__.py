"""Qt-free scene state shared by the viewer and :mod:`auralize.simple`.

* :mod:`auralize.scene.pictures` — the source palette, glyphs and off-screen
  pictures (the public names below);
* :mod:`auralize.scene.view` — the 3-D scene drawn on any plotter;
* :mod:`auralize.scene.detection` — detection runs in the background;
* :mod:`auralize.scene.recorder` — the listener-path recorder;
* :mod:`auralize.scene.session` — session files;
* :mod:`auralize.scene.listening` — live listening while the scene moves;
* :mod:`auralize.scene.soundscene` — scene files mixing several sound models;
* :mod:`auralize.scene.plots` — matplotlib figures (the notebook displays of
  the core objects are in :mod:`auralize.runtime.notebook`).

Nothing here imports Qt; only :mod:`auralize.viewer` does.
"""

from auralize.runtime.lazy import lazy_exports

#: exported name -> sub-module, imported on first access
_EXPORTS = {
    "PALETTE": ".pictures",
    "TYPE_LABELS": ".pictures",
    "TYPE_COLORS": ".pictures",
    "PATH_RGB": ".pictures",
    "PATH_COLOR": ".pictures",
    "type_rgb": ".pictures",
    "SPRITE_LIMIT": ".pictures",
    "source_points": ".pictures",
    "add_source_actor": ".pictures",
    "source_glyphs": ".pictures",
    "path_tube": ".pictures",
    "screenshot": ".pictures",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

__all__ = [
    "PALETTE",
    "PATH_COLOR",
    "PATH_RGB",
    "SPRITE_LIMIT",
    "TYPE_COLORS",
    "TYPE_LABELS",
    "add_source_actor",
    "path_tube",
    "screenshot",
    "source_glyphs",
    "source_points",
    "type_rgb",
]
