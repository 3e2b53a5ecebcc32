"""The example notebook runs from top to bottom (its last cell checks the simulated onset
against the prediction); the executed copy is kept in target/ for a look."""

from __future__ import annotations

import shutil
from pathlib import Path

import nbformat
from nbclient import NotebookClient


def test_the_example_notebook_runs(repo: Path) -> None:
    path = repo / "examples" / "critical_speed_scan.ipynb"
    # A fresh scan, not one resumed from an earlier run of the notebook.
    shutil.rmtree(repo / "results" / "notebook_scan", ignore_errors=True)
    nb = nbformat.read(path, as_version=4)
    NotebookClient(nb, timeout=900, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}).execute()
    out = repo / "target" / "notebooks"
    out.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, out / path.name)
    images = sum(
        1
        for cell in nb.cells
        if cell.cell_type == "code"
        for o in cell.get("outputs", [])
        if "image/png" in o.get("data", {})
    )
    assert images == 2, f"{images} figures drawn"
