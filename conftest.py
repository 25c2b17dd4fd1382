"""Doctests of ``auralize/`` and ``plugins/`` (``--doctest-modules``, see pyproject.toml).

Every docstring example runs in a fresh temporary working folder, so an
example that writes a file leaves nothing behind, and the scripting session of
:mod:`auralize.simple` starts empty for each of its examples.
"""

from __future__ import annotations

import importlib.util

import pytest

#: a script that renders the vortex plugin's README figure (not a module of the package)
collect_ignore = ["plugins/auralize_vortex/docs"]
# the viewer's window needs the ``gui`` extra (pyvistaqt and a Qt binding); without
# it the module cannot be imported, so its docstrings cannot be collected
if importlib.util.find_spec("pyvistaqt") is None or importlib.util.find_spec("qtpy") is None:
    collect_ignore.append("auralize/viewer/app.py")


@pytest.fixture(autouse=True)
def _doctest_in_tmp_folder(request: pytest.FixtureRequest) -> None:
    if not isinstance(request.node, pytest.DoctestItem):
        return
    module = request.node.dtest.globs.get("__name__", "")
    if module.split(".")[:2] in (["auralize", "scale"], ["auralize", "distributed"]):
        # the Dask back end's examples run on Dask (the ``dask`` extra)
        pytest.importorskip("dask.distributed")
    tmp = request.getfixturevalue("tmp_path")
    request.getfixturevalue("monkeypatch").chdir(tmp)
    if module == "auralize.simple":
        from auralize.simple import ResetSession

        ResetSession()
        request.addfinalizer(ResetSession)
