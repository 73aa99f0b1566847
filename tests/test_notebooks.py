"""Every notebook under notebooks/ executes (small sizes: ARMLAB_NOTEBOOK_TEST=1, MPLBACKEND=Agg).

The kernel is this interpreter: a kernelspec named ``python3`` whose argv is ``sys.executable`` is
written to a temporary folder that ``JUPYTER_PATH`` puts first, so the notebooks import the same
armlab as the tests whatever kernels the machine has installed.
"""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((REPO / "notebooks").glob("*.ipynb"))


def _missing(requires: list[str]) -> list[str]:
    """The ``module.name`` entries of a notebook's ``metadata.armlab.requires`` (the public
    names it calls) that armlab does not have: a renamed function fails here by name."""
    out = []
    for item in requires:
        module, _, name = item.rpartition(".")
        try:
            if not hasattr(importlib.import_module(module), name):
                out.append(item)
        except ImportError:
            out.append(item)
    return out


@pytest.fixture(scope="module")
def kernel_env(tmp_path_factory):
    root = tmp_path_factory.mktemp("jupyter")
    spec = root / "kernels" / "python3"
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(
        json.dumps(
            {
                "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
                "display_name": "armlab (test interpreter)",
                "language": "python",
            }
        )
    )
    return root


def test_every_notebook_is_stored_without_outputs():
    import nbformat

    assert len(NOTEBOOKS) == 6, [p.name for p in NOTEBOOKS]
    for path in NOTEBOOKS:
        nb = nbformat.read(path, as_version=4)
        for cell in nb.cells:
            if cell.cell_type == "code":
                assert cell.outputs == [] and cell.execution_count is None, path.name


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_executes(path, kernel_env, tmp_path, monkeypatch):
    import nbformat
    from nbclient import NotebookClient

    nb = nbformat.read(path, as_version=4)
    missing = _missing(nb.metadata.get("armlab", {}).get("requires", []))
    assert not missing, f"{path.name} calls names armlab no longer has: {', '.join(missing)}"
    monkeypatch.setenv("JUPYTER_PATH", str(kernel_env))
    monkeypatch.setenv("ARMLAB_NOTEBOOK_TEST", "1")
    monkeypatch.setenv("ARMLAB_NOTEBOOK_OUT", str(tmp_path))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    client = NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}
    )
    client.execute()
    kernel_python = [
        o
        for c in nb.cells
        if c.cell_type == "code"
        for o in c.outputs
        if o.get("name") == "stdout" and "python:" in o.get("text", "")
    ]
    assert kernel_python, "the first cell prints the interpreter"
    assert sys.executable in kernel_python[0]["text"]
