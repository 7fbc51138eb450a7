"""docs/tutorial.ipynb runs top to bottom in a fresh Jupyter kernel (nbclient), and its own
checks against the MuJoCo truth of fixtures/diagnose/cases.json hold (each step asserts
its answer). Outputs go to a scratch directory."""
import os

import nbformat
from nbclient import NotebookClient

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def test_tutorial_notebook_runs(tmp_path, monkeypatch):
    nb = nbformat.read(os.path.join(ROOT, "docs", "tutorial.ipynb"), as_version=4)
    assert not any(c.get("outputs") for c in nb.cells if c.cell_type == "code"), "commit the notebook without outputs"
    monkeypatch.setenv("IVDYN_ROOT", ROOT)
    monkeypatch.setenv("IVDYN_TUTORIAL_OUT", str(tmp_path))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    client = NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": os.path.join(ROOT, "docs")}})
    client.execute()
    text = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs)
    assert "mass 2.0" in text and (tmp_path / "diagnosis" / "report.html").is_file()
