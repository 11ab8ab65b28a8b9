"""docs/study.ipynb runs from top to bottom (issue 48): it opens a scenario file, computes its
numbers through core and shows the dashboard's Maps tab (executed with nbclient)."""

from pathlib import Path

import pytest

nbclient = pytest.importorskip("nbclient")  # the test extra (pyproject.toml)
nbformat = pytest.importorskip("nbformat")

ROOT = Path(__file__).parents[1]


def test_the_study_notebook_runs(monkeypatch):
    nb = nbformat.read(ROOT / "docs" / "study.ipynb", as_version=4)  # in memory: not written back
    monkeypatch.setenv("PYTHONPATH", str(ROOT))  # the kernel's code: this tree's
    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(ROOT / "docs")}})
    client.execute()
    out = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []))
    assert "share within 10 m:" in out and "unobservable: 0.0%" in out
    last = nb.cells[-1].outputs
    assert last and any("application/vnd.holoviews_load.v0+json" in o.get("data", {}) or
                        "text/html" in o.get("data", {}) for o in last)
