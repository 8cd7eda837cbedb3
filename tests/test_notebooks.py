"""Execute every notebook in ``notebooks/`` in quick mode, one test per notebook.

``VISCOFORCE_NB_QUICK=1`` makes each notebook choose its small parameters; the kernel runs with
the notebook's folder as working directory, as nbmake does (``python -m pytest --nbmake
notebooks/``). Skipped when nbformat, nbclient or ipykernel is not installed.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

NOTEBOOKS_DIR = Path(__file__).resolve().parents[1] / "notebooks"
NOTEBOOKS = sorted(path.name for path in NOTEBOOKS_DIR.glob("*.ipynb"))
EXPECTED = {"quickstart.ipynb", "paper_figures.ipynb", "measured_data.ipynb",
            "speed_accuracy.ipynb"}


def test_expected_notebooks_exist():
    assert EXPECTED <= set(NOTEBOOKS)


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_notebook_is_committed_without_outputs(name):
    notebook = json.loads((NOTEBOOKS_DIR / name).read_text(encoding="utf-8"))
    assert notebook["nbformat"] == 4
    code = [cell for cell in notebook["cells"] if cell["cell_type"] == "code"]
    assert code, f"{name} has no code cells"
    dirty = [i for i, cell in enumerate(code) if cell["outputs"] or cell["execution_count"]]
    assert not dirty, f"{name}: clear the outputs of code cells {dirty} before committing"


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_notebook_runs(name, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    monkeypatch.setenv("VISCOFORCE_NB_QUICK", "1")   # inherited by the kernel process
    notebook = nbformat.read(NOTEBOOKS_DIR / name, as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=None, startup_timeout=3600,
                                     kernel_name="python3",
                                     resources={"metadata": {"path": str(NOTEBOOKS_DIR)}})
    client.execute()   # raises CellExecutionError, naming the cell, if any cell fails
    warned = [i for i, cell in enumerate(notebook.cells) if cell.cell_type == "code"
              for output in cell.outputs
              if output.output_type == "stream" and output.name == "stderr"
              and "Warning" in output.text]
    assert not warned, f"{name}: warnings printed by cells {warned}"
