"""Every public function of ``auralize.simple`` has a docstring example.

The examples themselves run as doctests of the package (``--doctest-modules``
in pyproject.toml; the repository's ``conftest.py`` gives each a temporary
working folder and a fresh scripting session).
"""

from __future__ import annotations

import doctest
import importlib

import pytest

import auralize.simple as simple


def test_every_public_name_has_an_example() -> None:
    missing = [
        name for name in simple.__all__ if ">>>" not in (getattr(simple, name).__doc__ or "")
    ]
    assert missing == []


@pytest.mark.parametrize(
    "name",
    [
        "auralize.audio.output",
        "auralize.runtime.notebook",
        "auralize.scene.plots",
        "auralize.scene.pictures",
        "auralize.scene.view",
        "auralize.scene.soundscene",
        "auralize.scene.recorder",
    ],
)
def test_the_viewer_modules_have_examples(name: str) -> None:
    tests = doctest.DocTestFinder().find(importlib.import_module(name))
    assert sum(len(t.examples) for t in tests) > 0
