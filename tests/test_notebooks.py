"""Every notebook under notebooks/ executes cleanly (small sizes: ARMLAB_NOTEBOOK_TEST=1).

The kernel is this interpreter: a kernelspec named ``python3`` whose argv is ``sys.executable`` is
written to a temporary folder that ``JUPYTER_PATH`` puts first, so the notebooks import the same
armlab as the tests whatever kernels the machine has installed. The kernel runs Jupyter's own
inline backend (``MPLBACKEND=module://matplotlib_inline.backend_inline``, not the suite's Agg), so
a figure shows exactly as it would for a user: a notebook fails when a cell writes anything to
stderr (a traceback, an error, a warning) or when a cell that calls a ``plot_*``/``*_figure``
function shows fewer PNG images than it makes calls.
"""

from __future__ import annotations

import importlib
import json
import re
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((REPO / "notebooks").glob("*.ipynb"))
INLINE = "module://matplotlib_inline.backend_inline"
#: A call of an armlab figure function: ``plot_workspace(``, ``bode_figure(``.
PLOT_CALL = re.compile(r"\b(plot_\w+|\w+_figure)\(")


def _problems(nb) -> list[str]:
    """What is wrong with an executed notebook: each cell's stderr output or error, and each cell
    that calls a figure function but shows fewer ``image/png`` outputs than it has calls."""
    out = []
    for i, cell in enumerate(nb.cells):
        if cell.cell_type != "code":
            continue
        for o in cell.outputs:
            if o.get("output_type") == "stream" and o.get("name") == "stderr":
                text = o.get("text", "").strip()
                if text:
                    out.append(f"cell {i} wrote to stderr: {text.splitlines()[0][:200]}")
            elif o.get("output_type") == "error":
                out.append(f"cell {i} raised {o.get('ename')}: {o.get('evalue', '')[:200]}")
        calls = PLOT_CALL.findall(cell.source)
        images = sum("image/png" in o.get("data", {}) for o in cell.outputs)
        if images < len(calls):
            out.append(
                f"cell {i} calls {', '.join(calls)} but shows {images} image(s): "
                "a figure that Jupyter does not display"
            )
    return out


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
    monkeypatch.setenv("MPLBACKEND", INLINE)  # what Jupyter uses: figures must show
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
    assert _problems(nb) == []


def test_problems_finds_stderr_errors_and_missing_figures():
    """The checker itself: a traceback on stderr, a raised error and a plot cell without an
    image are each reported; a plot cell with its image and plain stdout are not."""
    import nbformat
    from nbformat.v4 import new_code_cell, new_notebook, new_output

    png = {"image/png": "iVBORw0KGgo=", "text/plain": "<Figure size 640x480 with 1 Axes>"}
    nb = new_notebook(
        cells=[
            new_code_cell("print(1)", outputs=[new_output("stream", name="stdout", text="1\n")]),
            new_code_cell("plot_workspace(w);", outputs=[new_output("display_data", data=png)]),
            new_code_cell(
                "plot_joint_loads(l)\nbode_figure(p, g);",
                outputs=[new_output("display_data", data=png)],
            ),
            new_code_cell(
                "import x",
                outputs=[
                    new_output(
                        "stream",
                        name="stderr",
                        text="Traceback (most recent call last):\nModuleNotFoundError: x\n",
                    )
                ],
            ),
            new_code_cell(
                "f()",
                outputs=[new_output("error", ename="ValueError", evalue="bad", traceback=[])],
            ),
            new_code_cell("key_figures(summary)", outputs=[]),
        ]
    )
    nbformat.validate(nb)
    problems = _problems(nb)
    assert [p.split()[1] for p in problems] == ["2", "3", "4"], problems
    assert "plot_joint_loads, bode_figure but shows 1 image" in problems[0]
    assert "Traceback" in problems[1] and "ValueError: bad" in problems[2]


def test_every_plot_cell_of_the_notebooks_is_found():
    """The figure calls the checker looks for exist in the notebooks (a renamed pattern or
    notebook would make the image check vacuous)."""
    import nbformat

    calls = [
        call
        for path in NOTEBOOKS
        for cell in nbformat.read(path, as_version=4).cells
        if cell.cell_type == "code"
        for call in PLOT_CALL.findall(cell.source)
    ]
    assert len(calls) >= 11, calls
    assert {"plot_workspace", "bode_figure", "tracking_figure", "plot_figure_vs_parameter"} <= set(
        calls
    )
