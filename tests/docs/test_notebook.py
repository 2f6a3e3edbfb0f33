"""The example notebook ``docs/tutorials/notebook.ipynb`` runs from top to bottom (issue 42
item 8): a small sweep written and opened, selections, a map, and its error variables checked
against Mindlin's closed form by the notebook's own last cell (an ``assert``: the true error of
every K_a/K_b within its estimate, every estimate ≤ the 1e-6 asked for).

Executed with nbclient on an ipykernel of this interpreter, in a temporary folder (the sweep
writes its spec, data set and journals there), within 120 s (it takes ~10 s of CPU).
"""

from __future__ import annotations

from pathlib import Path

import nbformat
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOK = ROOT / "docs" / "tutorials" / "notebook.ipynb"


def test_the_notebook_runs_and_its_checks_hold(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("HOME", str(tmp_path))
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    assert not any(cell.get("outputs") for cell in notebook.cells if cell.cell_type == "code"), (
        "the notebook is stored without outputs (the test makes them)"
    )
    NotebookClient(
        notebook, timeout=120, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    ).execute()
    assert (tmp_path / "results" / "notebook_ellipses.nc").is_file()
    texts = [output.get("text", "") for cell in notebook.cells for output in cell.get("outputs", [])]
    assert any("worst estimated error" in text for text in texts)
