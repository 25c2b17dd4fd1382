"""``.. audio:: FILE`` — an ``<audio controls>`` player for a sound file.

The path is relative to the document, or to the documentation's source folder
when it starts with ``/`` (as ``.. image::`` paths are).  The file is copied into
the built site the way ``:download:`` files are (``_downloads/<hash>/NAME``), and
the player carries a download link for browsers that play no WAV.

Options: ``:caption:`` (text under the player).
"""

from __future__ import annotations

import posixpath
from pathlib import Path
from typing import Any, ClassVar
from urllib.parse import quote

from docutils import nodes
from docutils.parsers.rst import directives
from sphinx.util.docutils import SphinxDirective

_TYPES = {".wav": "audio/wav", ".flac": "audio/flac", ".ogg": "audio/ogg", ".mp3": "audio/mpeg"}


class audio_node(nodes.General, nodes.Element):
    """A sound file to play; ``filename`` is its unique name under ``_downloads``."""


class AudioDirective(SphinxDirective):
    required_arguments = 1
    final_argument_whitespace = False
    option_spec: ClassVar[dict[str, Any]] = {"caption": directives.unchanged}

    def run(self) -> list[nodes.Node]:
        rel, abs_ = self.env.relfn2path(self.arguments[0], self.env.docname)
        suffix = Path(abs_).suffix.lower()
        if suffix not in _TYPES:
            raise self.error(
                f"audio: {self.arguments[0]!r} is not a sound file ({', '.join(sorted(_TYPES))})"
            )
        if not Path(abs_).is_file():
            raise self.error(f"audio: no file {abs_}")
        self.env.note_dependency(rel)
        node = audio_node()
        node["filename"] = Path(self.env.dlfiles.add_file(self.env.docname, rel)).as_posix()
        node["mimetype"] = _TYPES[suffix]
        node["caption"] = self.options.get("caption", "")
        node["name"] = Path(abs_).name
        return [node]


def visit_audio_html(self: Any, node: audio_node) -> None:
    url = posixpath.join(self.builder.dlpath, quote(node["filename"]))
    caption = self.encode(node["caption"])
    name = self.encode(node["name"])
    self.body.append(
        '<figure class="auralize-audio">'
        f'<audio controls preload="none" src="{url}"'
        f' aria-label="{caption or name}">'
        f'<source src="{url}" type="{node["mimetype"]}"/>'
        f'<a href="{url}">{name}</a></audio>'
        f"<figcaption>{caption + ' — ' if caption else ''}"
        f'<a class="reference download" href="{url}" download>{name}</a></figcaption>'
        "</figure>\n"
    )
    raise nodes.SkipNode


def visit_audio_text(self: Any, node: audio_node) -> None:
    raise nodes.SkipNode


def setup(app: Any) -> None:
    app.add_node(
        audio_node,
        html=(visit_audio_html, None),
        latex=(visit_audio_text, None),
        text=(visit_audio_text, None),
        man=(visit_audio_text, None),
        texinfo=(visit_audio_text, None),
    )
    app.add_directive("audio", AudioDirective)
