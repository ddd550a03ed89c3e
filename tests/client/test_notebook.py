"""examples/gait_study.ipynb runs end to end (nbclient, a real Python kernel) against the
served instance: a small study submitted and waited for, its grid plotted, the best job's
history, bundle and figures read, and its video rendered and shown."""

from __future__ import annotations

from pathlib import Path

import nbformat
from nbclient import NotebookClient

NOTEBOOK = Path(__file__).resolve().parents[2] / "examples" / "gait_study.ipynb"


def test_the_example_notebook_runs(served, finished, tmp_path, monkeypatch):
    monkeypatch.setenv("GAITMEND_SERVER", served[0])
    monkeypatch.setenv("GAITMEND_EXAMPLE_SMALL", "1")  # small searches and a small video
    nb = nbformat.read(NOTEBOOK, as_version=4)
    assert not any(c.get("outputs") for c in nb.cells if c.cell_type == "code"), "commit the notebook without outputs"
    NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    pngs = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(pngs) >= 4  # the grid, the history, the centre of mass, the bundle's convergence figure
    html = " ".join(o["data"].get("text/html", "") for o in outputs if "data" in o)
    assert "<video" in html and "data:video/mp4;base64," in html
    assert "damage.lost_legs" in html and "forward_cm" in html  # the results table
