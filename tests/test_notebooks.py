"""The notebooks under notebooks/: stored without outputs, and every cell runs without error.

Each notebook is executed top to bottom with nbclient on the ``python3`` kernel (the one
ipykernel registers for the running interpreter), in a temporary working directory, with
``PCGEOM_NOTEBOOK_BUDGET=small``: every notebook reads that variable in its first code cell and
then trains on a small cloud for a few short stages (seconds each), so CI checks that the
notebooks still run without paying for the real thing.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

import nbclient
import nbformat

NOTEBOOK_DIR = Path(__file__).resolve().parent.parent / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.ipynb"))
BUDGET_VARIABLE = "PCGEOM_NOTEBOOK_BUDGET"
CELL_TIMEOUT_S = 300
"""Per cell; under the small budget no cell takes more than about 20 s on two CPU cores."""


def _ids(paths):
    return [p.stem for p in paths]


def test_there_are_notebooks():
    assert {"quickstart", "domains_and_landmarks", "distortion_analysis",
            "boundary_and_reconstruction"} <= {p.stem for p in NOTEBOOKS}


@pytest.mark.parametrize("path", NOTEBOOKS, ids=_ids(NOTEBOOKS))
def test_notebook_is_stored_without_outputs(path):
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    assert nb.metadata.get("kernelspec", {}).get("name") == "python3"
    for k, cell in enumerate(nb.cells):
        if cell.cell_type == "code":
            assert cell.outputs == [], f"{path.name}: code cell {k} has stored outputs"
            assert cell.execution_count is None, f"{path.name}: code cell {k} has a count"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=_ids(NOTEBOOKS))
def test_notebook_reads_the_budget_variable(path):
    nb = nbformat.read(path, as_version=4)
    first_code = next(c for c in nb.cells if c.cell_type == "code")
    assert BUDGET_VARIABLE in first_code.source
    assert BUDGET_VARIABLE in nb.cells[0].source  # documented in the first (markdown) cell


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=_ids(NOTEBOOKS))
def test_notebook_runs(path, tmp_path, monkeypatch):
    nb = nbformat.read(path, as_version=4)
    # The kernel inherits this process's environment.
    monkeypatch.setenv(BUDGET_VARIABLE, "small")
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    client = nbclient.NotebookClient(
        nb,
        kernel_name="python3",
        timeout=CELL_TIMEOUT_S,
        resources={"metadata": {"path": str(tmp_path)}},
    )
    start = time.perf_counter()
    try:
        client.execute(cwd=str(tmp_path))
    except nbclient.exceptions.CellExecutionError as err:
        pytest.fail(f"{path.name}: a cell failed:\n{err}", pytrace=False)
    seconds = time.perf_counter() - start
    print(f"{path.name}: {seconds:.1f} s")
    assert not any(out.get("output_type") == "error"
                   for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs)
    # Every notebook draws something.
    assert any("image/png" in out.get("data", {})
               for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs)
