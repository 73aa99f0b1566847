"""Where users look: figures that pyplot (and so Jupyter) shows, file output that leaves the
caller's backend alone, progress bars that are on in Jupyter, and the command-line help."""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
import threading

import numpy as np
import pytest

import armlab

# ----------------------------------------------------------------------------- figures


@pytest.fixture(scope="module")
def motion(teachbot6):
    from armlab.trajectory import ptp_sync

    return ptp_sync(teachbot6, np.zeros(6), np.radians([20, 10, 10, 0, 10, 0]))


def test_plots_are_pyplot_figures_so_jupyter_shows_them(motion, teachbot6):
    """The inline backend shows the figures pyplot manages: every plot is one of them."""
    import matplotlib.pyplot as plt

    from armlab.plots import plot_joints, plot_limit_profiles

    before = set(plt.get_fignums())
    figs = [plot_joints(motion, teachbot6), plot_limit_profiles(motion, teachbot6)]
    try:
        assert {f.number for f in figs} <= set(plt.get_fignums()) - before
        assert all(f.canvas.manager is not None for f in figs)
    finally:
        for f in figs:
            plt.close(f)
    assert set(plt.get_fignums()) == before


def test_offscreen_figures_stay_out_of_pyplot(motion, tmp_path):
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from armlab.plots import offscreen, plot_joints
    from armlab.plots._figure import is_offscreen

    before = set(plt.get_fignums())
    seen_by_other_thread = []
    with offscreen():
        fig = plot_joints(motion)
        worker = threading.Thread(target=lambda: seen_by_other_thread.append(is_offscreen()))
        worker.start()
        worker.join()
    assert not is_offscreen()
    assert seen_by_other_thread == [False]  # a context variable: only this thread
    assert set(plt.get_fignums()) == before
    assert type(fig.canvas) is FigureCanvasAgg and fig.canvas.manager is None
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    assert buf.getvalue()[:8] == b"\x89PNG\r\n\x1a\n"


_KEEPS_BACKEND = r"""
import sys
from pathlib import Path
import matplotlib
matplotlib.use("svg")  # a caller's backend that armlab must leave as it is
import matplotlib.pyplot as plt
import pandas as pd
from armlab.study import load_study, run_spec
from armlab.sweep import parse_sweep
from armlab.sweep.report import write_sweep_plots

out = Path(sys.argv[1])
study = load_study(None, {
    "study.stages": ["kinematics", "plan"], "study.report": True, "plan.planner": "ptp",
    "kinematics.workspace_samples": 300, "kinematics.accuracy_samples": 0,
})
run_spec(study, out / "study")
spec = parse_sweep({
    "sweep": {"name": "t", "study": "demo", "figures": ["duration_s"]},
    "parameter": [{"key": "payload.mass_kg", "values": [0.0, 1.0]}],
})
frame = pd.DataFrame({"key": ["a", "b"], "status": ["done", "done"],
                      "payload.mass_kg": [0.0, 1.0], "duration_s": [1.0, 1.5]})
(out / "sweep").mkdir()
plots = write_sweep_plots(frame, spec, out / "sweep")
pngs = sorted(p.name for p in (out / "study").glob("*.png"))
print(matplotlib.get_backend(), len(plt.get_fignums()), len(plots), ",".join(pngs))
"""


def test_report_and_sweep_plots_keep_the_callers_backend(tmp_path):
    """Before: ``matplotlib.use("Agg")`` in both switched a Jupyter kernel's backend for good."""
    out = subprocess.run(
        [sys.executable, "-c", _KEEPS_BACKEND, str(tmp_path)],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "MPLBACKEND": "svg"},
    ).stdout.strip()
    backend, n_open, n_sweep_plots, pngs = out.splitlines()[-1].split(" ")
    assert backend == "svg"
    assert n_open == "0"  # no figure left registered with pyplot
    assert n_sweep_plots == "1"
    assert {"kinematics_workspace.png", "plan_profiles.png"} <= set(pngs.split(",")), pngs


# ----------------------------------------------------------------------------- progress


def test_progress_is_off_without_a_terminal_and_on_in_jupyter(monkeypatch):
    import armlab._progress as progress

    assert not progress.in_jupyter_kernel()  # pytest is no kernel
    bar = progress.tqdm(total=2, disable=None, file=io.StringIO())
    assert bar.disable  # tqdm's own rule: no terminal, no bar
    bar.close()
    monkeypatch.setattr(progress, "in_jupyter_kernel", lambda: True)
    bar = progress.tqdm(total=2, disable=None, file=sys.stderr)
    try:
        assert not bar.disable
        if not progress._has_ipywidgets():  # the text bar goes to the cell's stdout
            assert getattr(bar.fp, "_wrapped", bar.fp) is sys.stdout
    finally:
        bar.close()
    assert progress.tqdm(total=1, disable=True).disable  # an explicit choice is kept


# ----------------------------------------------------------------------------- command line


def _parsers(parser: argparse.ArgumentParser):
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                yield from _parsers(sub)


def test_cli_version(capsys):
    from armlab.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"armlab {armlab.__version__}"


def test_every_cli_argument_has_plain_help():
    from armlab.cli import build_parser

    parsers = list(_parsers(build_parser()))
    assert [p.prog for p in parsers] == [
        "armlab",
        "armlab info",
        "armlab drives",
        "armlab run",
        "armlab sweep",
        "armlab export",
    ]
    for parser in parsers:
        assert parser.description, parser.prog
        for text in (parser.description, parser.format_help()):
            for rst in ("``", ":func:", ":class:", ":mod:"):
                assert rst not in text, (parser.prog, rst)
        for action in parser._actions:
            assert action.help and action.help.strip(), (parser.prog, action.dest)


def test_cli_help_lists_the_builtin_names(capsys):
    from armlab.cli import main
    from armlab.robot import list_profiles, list_robots

    robots, profiles = list_robots(), list_profiles()
    assert "teachbot6" in robots and "reference_dda" in profiles
    for command, names in (("info", robots), ("export", profiles)):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        text = " ".join(capsys.readouterr().out.split())  # argparse wraps lines
        for name in names:
            assert name in text, (command, name)
