"""The gallery's scraper of the files an example writes: pictures and sounds.

A gallery example writes what a user's script would (``SaveScreenshot("x.png")``,
``save_rendered(out, "x.wav")``) into its working folder, which sphinx-gallery
sets to the examples' source folder.  After each code block,
:func:`files_scraper` moves the block's new pictures to the gallery's image
paths (they become the block's figures, and the first one the thumbnail) and its
new sounds under ``gallery/audio/``, shown as an ``.. audio::`` player.
:func:`reset_files` notes the folder before an example and removes whatever
else the example left there afterwards (sidecars, paths, volumes), so the
source tree stays as it was.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

from sphinx_gallery.scrapers import figure_rst

DOCS = Path(__file__).resolve().parents[2]
#: the examples' working folder (``sphinx_gallery_conf["examples_dirs"]``)
SOURCE = DOCS / "gallery_src"
#: where the examples' sounds go (inside the documentation's sources)
AUDIO = DOCS / "gallery" / "audio"
_PICTURES = (".png", ".jpg", ".jpeg", ".svg")
_SOUNDS = (".wav", ".flac")

_before: set[Path] = set()
_taken: set[Path] = set()


def _listing() -> set[Path]:
    return {p for p in SOURCE.rglob("*") if p.is_file()}


def reset_files(gallery_conf: dict[str, Any], fname: str | None, when: str) -> None:
    """Before an example: note the files there are.  After it: remove the new ones."""
    global _before
    if when == "before":
        _before = _listing()
        _taken.clear()
    else:
        for p in sorted(_listing() - _before):
            p.unlink()


def files_scraper(block: Any, block_vars: dict[str, Any], gallery_conf: dict[str, Any]) -> str:
    """Move the pictures and sounds a block wrote; return the reST that shows them."""
    new = sorted(
        p for p in _listing() - _before - _taken if p.suffix.lower() in _PICTURES + _SOUNDS
    )
    _taken.update(new)
    example = Path(block_vars["src_file"]).stem
    pictures: list[str] = []
    rst = ""
    for p in new:
        if p.suffix.lower() in _PICTURES:
            target = Path(block_vars["image_path_iterator"].next()).with_suffix(p.suffix.lower())
            shutil.move(p, target)
            pictures.append(str(target))
    if pictures:
        rst += figure_rst(pictures, gallery_conf["src_dir"])
    for p in new:
        if p.suffix.lower() in _SOUNDS:
            AUDIO.mkdir(parents=True, exist_ok=True)
            target = AUDIO / f"{example}_{p.name}"
            shutil.move(p, target)
            rel = target.relative_to(DOCS).as_posix()
            rst += f"\n.. audio:: /{rel}\n   :caption: {p.name}\n\n"
    return rst


#: the gallery's order: from a first render to the pieces behind it
ORDER = (
    "plot_explosion_levels.py",
    "plot_detection_spheres.py",
    "plot_layouts.py",
    "plot_scene.py",
    "plot_fwh_pulse.py",
)


def example_order(filename: str) -> tuple[int, str]:
    """Sort key of ``sphinx_gallery_conf["within_subsection_order"]``."""
    name = Path(filename).name
    return (ORDER.index(name) if name in ORDER else len(ORDER), name)
