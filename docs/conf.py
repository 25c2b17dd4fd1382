"""Sphinx configuration of the auralize documentation.

Build (warnings are errors, nothing is fetched from the network)::

    make -C docs html
    python -m sphinx -W --keep-going -b html docs docs/_build/html

The gallery's examples (``docs/gallery_src``) run during the build: their pictures
and sounds are what the reader sees and hears.  The CLI reference is rendered from
``auralize.cli.build_parser()`` (``docs/_ext/auralize_docs/cli.py``).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
# document the tree the docs sit in (and its plugins), not another installed copy
sys.path[:0] = [str(DOCS / "_ext"), str(ROOT), str(ROOT / "plugins")]
# off-screen VTK without an X display; no sound device is opened by the examples
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
if not os.environ.get("DISPLAY"):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import auralize  # noqa: E402

project = "auralize"
author = "the auralize developers"
copyright = "the auralize developers"
version = release = auralize.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "auralize_docs",
]
# intersphinx would fetch inventories from the network: opt in with AURALIZE_DOCS_INTERSPHINX=1
if os.environ.get("AURALIZE_DOCS_INTERSPHINX") == "1":
    extensions.append("sphinx.ext.intersphinx")
    intersphinx_mapping = {
        "python": ("https://docs.python.org/3", None),
        "numpy": ("https://numpy.org/doc/stable", None),
        "pyvista": ("https://docs.pyvista.org", None),
    }

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = [
    "_build",
    "**.ipynb_checkpoints",
    # the gallery's sources; sphinx-gallery writes the pages under gallery/
    "gallery_src",
]
templates_path = ["_templates"]
html_static_path = ["_static"]
html_css_files = ["auralize.css"]

# ------------------------------------------------------------------ MyST
myst_enable_extensions = ["colon_fence", "dollarmath", "deflist"]
myst_heading_anchors = 3
# README and the guides link into the source tree (scripts/, tests/, ...); those
# links stay plain links to the files rather than cross-references
myst_url_schemes = ["http", "https", "mailto"]

# ------------------------------------------------------------------ API reference
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_typehints = "none"  # numpydoc's Parameters sections hold the types
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# ------------------------------------------------------------------ gallery
sphinx_gallery_conf = {
    "examples_dirs": "gallery_src",
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "auralize_docs.gallery.example_order",
    # what an example prints is shown, not the value of a block's last expression
    # (a writer's return value; a Rendered's HTML repr, which embeds its sound: the
    # players come from the WAV files instead)
    "capture_repr": (),
    "image_scrapers": ("matplotlib", "auralize_docs.gallery.files_scraper"),
    "reset_modules": ("matplotlib", "auralize_docs.gallery.reset_files"),
    "reset_modules_order": "both",
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "min_reported_time": 1,
    "abort_on_example_error": True,
    "matplotlib_animations": False,
    "plot_gallery": "True",
}

# ------------------------------------------------------------------ HTML
html_theme = "pydata_sphinx_theme"
html_title = f"auralize {release}"
html_logo = None
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "navigation_with_keys": False,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
    "secondary_sidebar_items": ["page-toc", "sourcelink"],
}
html_show_sourcelink = True
html_last_updated_fmt = None
