"""The report of a study (``report.md`` and its plots): drawn by the study's own process after
its stages, so that a plot's error is the study's error, and a study that stops leaves no plot."""

from __future__ import annotations

import ast
import os
import subprocess
import sys

import pytest

from armlab.errors import ArmlabError, InputError


def _study(tmp_path, stages, payload_kg):
    from armlab.study import load_study

    text = f"""
[study]
name = "early plots"
stages = {stages!r}
report = true
[robot]
name = "teachbot6"
[payload]
mass_kg = {payload_kg}
[kinematics]
workspace_samples = 300
accuracy_samples = 200
[waypoints]
unit = "deg"
joint = [[0, 0, 0, 0, 0, 0], [30, 10, 20, 0, 30, 0]]
[plan]
planner = "ptp"
"""
    path = tmp_path / "study.toml"
    path.write_text(text.replace("'", '"'))
    return load_study(path)


def test_a_study_that_stops_leaves_no_plots_of_its_earlier_stages(tmp_path):
    from armlab.study import run_spec

    spec = _study(tmp_path, ["kinematics", "plan"], 500.0)  # gravity alone over the limits
    with pytest.raises(ArmlabError, match="^plan: "):
        run_spec(spec, tmp_path / "out")
    assert not list((tmp_path / "out").glob("*.png"))
    assert (tmp_path / "out" / "summary.json").is_file()


def test_a_plot_that_fails_is_the_study_s_error(tmp_path, monkeypatch):
    """A plot that raises stops the study with its own error (nothing swallows it and nothing
    draws it again elsewhere); the plots drawn before it stay, none after it is drawn."""
    import armlab.plots
    from armlab.study import run_spec

    def broken(*args, **kwargs):
        raise InputError("plot_joints: no data for joint7")

    monkeypatch.setattr(armlab.plots, "plot_joints", broken)
    spec = _study(tmp_path, ["kinematics", "plan"], 0.5)
    with pytest.raises(InputError, match="no data for joint7"):
        run_spec(spec, tmp_path / "out")
    drawn = {p.name for p in (tmp_path / "out").glob("*.png")}
    assert "kinematics_workspace.png" in drawn  # drawn before the broken one
    assert "plan_profiles.png" not in drawn and "plan_tool_path.png" not in drawn
    assert not (tmp_path / "out" / "report.md").exists()


def test_the_drive_model_plot_s_ideal_drive_tracks_better_than_the_full_model(tmp_path):
    """The drive-model plot simulates the study's motion without the supply limit and losses
    in the study's process and keeps the runs on the context: the ideal drive's TCP error is
    below the full model's (which the verdict uses), and the plot is in the report."""
    from armlab.study import run_spec

    spec = _study(tmp_path, ["kinematics", "plan", "tuning", "tracking"], 0.5)
    res = run_spec(spec, tmp_path / "out")
    ctx = res.context
    assert {"ideal", "no_voltage_limit"} <= set(ctx.tracking_variants)
    assert ctx.tracking_variants["ideal"].tcp_max_error_m < ctx.tracking.tcp_max_error_m
    assert "tracking_drive_model.png" in (tmp_path / "out" / "report.md").read_text()
    assert (tmp_path / "out" / "tracking_drive_model.png").is_file()


def test_the_motion_file_is_linked_and_a_stopped_study_leaves_none(tmp_path, monkeypatch):
    """The 3D animation is written with the report and linked from it; a study that stops
    before its report leaves no animation, as it leaves no plots."""
    from armlab.study import run_spec
    from armlab.study import runner as study_runner

    stages = ["kinematics", "plan", "static_load", "sizing", "tuning"]
    spec = _study(tmp_path, stages, 0.5)
    done = run_spec(spec, tmp_path / "done")
    text = (tmp_path / "done" / "report.md").read_text()
    assert (tmp_path / "done" / "motion.html").is_file()
    assert any("](motion.html)" in line for line in text.splitlines())
    assert "motion.html" in {p.name for p in done.files}

    def broken(ctx):
        raise ArmlabError("tuning broke on purpose")

    monkeypatch.setitem(study_runner.STAGE_FUNCTIONS, "tuning", broken)
    with pytest.raises(ArmlabError, match="tuning broke"):
        run_spec(spec, tmp_path / "stopped")
    assert not (tmp_path / "stopped" / "motion.html").exists()
    assert not list((tmp_path / "stopped").glob("*.png"))
    assert not list((tmp_path / "stopped").glob("*.tmp"))


def test_run_refuses_workers_on_one_line(tmp_path, capsys):
    """``armlab run --workers`` is refused (a study runs in one process; sweeps run studies in
    parallel) with one line and exit status 2, before any study runs."""
    from armlab.cli import main

    assert main(["run", "--out", str(tmp_path / "out"), "--workers", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "armlab sweep --workers" in err[0], err
    assert not (tmp_path / "out").exists()


def test_the_command_line_runs_blas_on_one_thread_unless_told(monkeypatch):
    """``armlab`` commands set numpy's BLAS to one thread (its matrices are small; a second
    thread only competes with other processes), and leave it alone when the environment
    chooses."""
    import threadpoolctl

    from armlab.cli import BLAS_THREAD_VARIABLES, one_blas_thread

    def blas_threads() -> set[int]:
        info = threadpoolctl.threadpool_info()
        return {i["num_threads"] for i in info if i["user_api"] == "blas"}

    before = threadpoolctl.threadpool_info()
    try:
        with threadpoolctl.threadpool_limits(2, user_api="blas"):
            monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
            assert one_blas_thread() is False and blas_threads() == {2}
            for name in BLAS_THREAD_VARIABLES:
                monkeypatch.delenv(name, raising=False)
            assert one_blas_thread() is True and blas_threads() == {1}
        assert os.environ["OPENBLAS_NUM_THREADS"] == "1"  # for the libraries loaded later
    finally:
        threadpoolctl.threadpool_limits(
            {i["prefix"]: i["num_threads"] for i in before if i["user_api"] == "blas"}
        )


def test_blas_loaded_after_the_command_line_starts_runs_on_one_thread():
    """scipy's own OpenBLAS loads at the first use of ``scipy.linalg``, after ``armlab``
    limited the BLAS already loaded: it must run on one thread too (a fresh process, as the
    command line is)."""
    from armlab.cli import BLAS_THREAD_VARIABLES

    code = (
        "from armlab.cli import one_blas_thread; import threadpoolctl; "
        "assert one_blas_thread(); import scipy.linalg; "
        "print(sorted((i['filepath'].rsplit('/', 1)[-1], i['num_threads']) "
        "for i in threadpoolctl.threadpool_info() if i['user_api'] == 'blas'))"
    )
    env = {k: v for k, v in os.environ.items() if k not in BLAS_THREAD_VARIABLES}
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    ).stdout
    libraries = ast.literal_eval(out.strip())
    assert len(libraries) >= 2, libraries  # numpy's and scipy's OpenBLAS
    assert {n for _, n in libraries} == {1}, libraries


def test_the_export_section_names_the_limit_a_refused_table_breaks(tmp_path):
    """A set-point table that breaks a controller limit (here 1 pulse per cycle) is a failed
    check: the report's export section names it and claims no cycles that passed."""
    from armlab.study import load_study, run_spec

    _study(tmp_path, ["kinematics", "plan", "export"], 0.5)
    spec = load_study(tmp_path / "study.toml", {"controller.pulse_limit": 1})
    res = run_spec(spec, tmp_path / "out")
    assert res.verdict == "fail" and res.context.setpoints is None
    report = (tmp_path / "out" / "report.md").read_text()
    section = report.split("## Export", 1)[1].split("\n## ", 1)[0]
    assert "No set-point table" in section and "export: " in section, section
    assert "passed the pre-flight checks" not in section
