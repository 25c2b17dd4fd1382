"""Sphinx extensions of the auralize documentation.

* ``.. auralize-cli::`` — the command-line reference, rendered from the parser the
  ``auralize`` command builds (:mod:`auralize_docs.cli`);
* ``.. audio:: FILE.wav`` — an HTML audio player for a sound file, copied into the
  built site (:mod:`auralize_docs.audio`);
* docstrings' absolute values (``|S|``) escaped before reST reads them
  (:mod:`auralize_docs.docstrings`);
* what a module exports from its private modules documented on its page
  (:mod:`auralize_docs.exports`);
* the gallery's scraper of the pictures and sounds an example writes
  (:mod:`auralize_docs.gallery`, named in ``conf.py``'s ``sphinx_gallery_conf``).
"""

from __future__ import annotations

from typing import Any

from auralize_docs import audio, cli, docstrings, exports


def setup(app: Any) -> dict[str, Any]:
    audio.setup(app)
    cli.setup(app)
    docstrings.setup(app)
    exports.setup(app)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
