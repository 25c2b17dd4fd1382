"""Every public function of ``auralize.simple`` has a docstring example, and they run."""

from __future__ import annotations

import doctest

import pytest

import auralize.simple as simple


def test_every_public_name_has_an_example() -> None:
    missing = [name for name in simple.__all__
               if ">>>" not in (getattr(simple, name).__doc__ or "")]  # fmt: skip
    assert missing == []


def test_docstring_examples_run(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    simple.ResetSession()
    try:
        res = doctest.testmod(simple, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
                              extraglobs={"np": __import__("numpy")}, report=True)  # fmt: skip
    finally:
        simple.ResetSession()
    assert res.failed == 0
    assert res.attempted >= 2 * len(simple.__all__)


@pytest.mark.parametrize("name", ["auralize.audio.output", "auralize.scene.notebook", "auralize.scene.plots",
                                  "auralize.scene.pictures", "auralize.scene.view", "auralize.scene.soundscene",
                                  "auralize.scene.recorder"])  # fmt: skip
def test_docstring_examples_of_the_viewer_modules_run(name: str) -> None:
    import importlib

    res = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert res.failed == 0 and res.attempted > 0
