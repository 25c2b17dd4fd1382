"""The example notebook runs headless (nbclient) and its output holds the rich displays:
a volume table, source counts, a path plot, a picture of the view and an audio player."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

nbclient = pytest.importorskip("nbclient")
nbformat = pytest.importorskip("nbformat")
pytest.importorskip("ipykernel")

ROOT = Path(__file__).parents[1]


def test_example_notebook_runs_and_shows_an_audio_player(tmp_path, monkeypatch) -> None:
    nb = nbformat.read(ROOT / "examples" / "notebook_tour.ipynb", as_version=4)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    client = nbclient.NotebookClient(
        nb, timeout=240, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    )
    client.execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    htmls = [o["data"]["text/html"] for o in outputs if "text/html" in o.get("data", {})]
    pngs = [o for o in outputs if "image/png" in o.get("data", {})]
    text = "\n".join(htmls)
    assert "TimeVolume" in text and "SourceSeries" in text and "ListenerPath" in text
    assert "<audio controls src='data:audio/wav;base64," in text
    assert "monopole" in text and "data:image/png;base64," in text
    assert pngs  # Show(...) displays the view as a picture
