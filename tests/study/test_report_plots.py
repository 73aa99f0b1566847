"""The report's plots drawn by several processes (``armlab run --workers``): the same files as
one process draws, a plot's error raised in the parent with its own type, a dead process named."""

from __future__ import annotations

import ast
import math
import multiprocessing
import os
import subprocess
import sys
import time

import numpy as np
import pytest

from armlab.errors import InputError
from armlab.plots._figure import new_figure
from armlab.study.report import _figure_processes, _FigureDrawing

pytestmark = pytest.mark.skipif(
    "fork" not in multiprocessing.get_all_start_methods(), reason="no fork on this platform"
)


def _plot(k: int):
    def make():
        fig = new_figure(figsize=(3, 2))
        ax = fig.subplots()
        x = np.linspace(0.0, 1.0, 50)
        ax.plot(x, np.sin((k + 1) * 3 * x))
        ax.set_title(f"plot {k}")
        return fig

    return make


def _jobs(n: int):
    return [(f"p{k}.png", f"plot {k}", _plot(k)) for k in range(n)]


def test_plots_from_several_processes_are_the_files_one_draws(tmp_path):
    one, many = tmp_path / "one", tmp_path / "many"
    one.mkdir()
    many.mkdir()
    with _FigureDrawing(_jobs(7), one, 1) as serial:
        pass
    with _FigureDrawing(_jobs(7), many, 3) as parallel:
        assert len(parallel._children) == 2  # the parent draws too
    assert sorted(p.name for p in serial.paths) == sorted(p.name for p in parallel.paths)
    assert len(serial.paths) == 7
    for path in serial.paths:
        assert (many / path.name).read_bytes() == path.read_bytes(), path.name


def test_a_plot_that_fails_in_a_child_raises_its_error_in_the_parent(tmp_path):
    def broken():
        raise InputError("plot 3: no data for joint7")

    jobs = _jobs(6)
    jobs[3] = ("bad.png", "bad", broken)
    with pytest.raises(InputError, match="no data for joint7"):
        with _FigureDrawing(jobs, tmp_path, 2):
            pass
    assert not (tmp_path / "bad.png").exists()


def _wait_for_the_first_plot(drawing) -> None:
    """The parent waits until a child has taken the first plot (at most 5 s)."""
    for _ in range(500):
        if drawing._counter.value > 0:
            return
        time.sleep(0.01)


def test_a_process_that_dies_is_named_not_waited_for(tmp_path):
    def dies():
        if multiprocessing.parent_process() is not None:  # only the child dies
            os._exit(3)
        return _plot(0)()

    jobs = [("dies.png", "dies", dies), *_jobs(1)]
    with pytest.raises(RuntimeError, match=r"\['dies.png'\] were not drawn"):
        with _FigureDrawing(jobs, tmp_path, 2) as drawing:
            _wait_for_the_first_plot(drawing)


def test_a_process_that_hangs_is_stopped_and_named(tmp_path, monkeypatch):
    """A plot process silent for longer than PLOT_PROCESS_SILENCE_S (a fork that inherited a
    held lock) is stopped; the study gets an error naming the plot, not a wait forever."""
    import armlab.study.report as report

    monkeypatch.setattr(report, "PLOT_PROCESS_SILENCE_S", 1.0)

    def hangs():
        if multiprocessing.parent_process() is not None:  # only the child hangs
            time.sleep(3600)
        return _plot(0)()

    jobs = [("hangs.png", "hangs", hangs), *_jobs(1)]
    t0 = time.monotonic()
    with pytest.raises(RuntimeError, match=r"\['hangs.png'\] were not drawn"):
        with _FigureDrawing(jobs, tmp_path, 2) as drawing:
            _wait_for_the_first_plot(drawing)
    assert time.monotonic() - t0 < 30
    assert not any(child.is_alive() for child in drawing._children)


_KILLED_PARENT = """
import os, signal, sys, time
sys.path.insert(0, {tests!r})
from armlab.study.report import _FigureDrawing
from test_report_plots import _plot

def slow():
    time.sleep(1.5)  # the study is killed meanwhile
    return _plot(0)()

drawing = _FigureDrawing([("late.png", "late", slow)], __import__("pathlib").Path({out!r}), 2)
drawing.__enter__()
while drawing._counter.value == 0:  # the child has taken the plot
    time.sleep(0.01)
print(drawing._children[0].pid, flush=True)
os.kill(os.getpid(), signal.SIGKILL)
"""


def test_plot_processes_end_with_a_killed_study(tmp_path):
    """A study killed with -9 while a plot process draws leaves no process that writes into the
    folder afterwards (a re-run may own it by then)."""
    import subprocess
    import sys
    from pathlib import Path

    script = _KILLED_PARENT.format(tests=str(Path(__file__).parent), out=str(tmp_path))
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert proc.returncode == -9, proc.stderr
    child = int(proc.stdout.split()[0])
    time.sleep(2.5)  # past the child's drawing
    assert not (tmp_path / "late.png").exists()
    assert not list(tmp_path.glob(".*.tmp"))
    try:
        os.kill(child, 0)
    except ProcessLookupError:
        pass
    else:  # still there (a zombie is gone from /proc/<pid>/status as "Z")
        status = Path(f"/proc/{child}/status")
        assert not status.exists() or "State:\tZ" in status.read_text(), "plot process alive"


def test_process_count():
    assert _figure_processes(11, None) == 1
    assert _figure_processes(11, 1) == 1
    assert _figure_processes(11, 4) == 4
    assert _figure_processes(2, 8) == 2
    assert _figure_processes(0, 8) == 1


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


def test_plots_drawn_during_the_later_stages_are_the_report_s(tmp_path):
    """With two workers a stage's final plots are drawn while the later stages run (here the
    kinematics plots during the plan): the report shows them, and they are the files one
    process draws."""
    from armlab.study import run_spec

    spec = _study(tmp_path, ["kinematics", "plan"], 0.5)
    one = run_spec(spec, tmp_path / "one", workers=1)
    two = run_spec(spec, tmp_path / "two", workers=2)
    assert two.summary["study"]["plot_processes"] == 2
    names = sorted(p.name for p in one.files if p.suffix == ".png")
    assert "kinematics_accuracy.png" in names and "plan_profiles.png" in names
    assert sorted(p.name for p in two.files if p.suffix == ".png") == names
    for name in names:
        assert (tmp_path / "two" / name).read_bytes() == (tmp_path / "one" / name).read_bytes()


def test_a_study_that_stops_leaves_no_plots_of_its_earlier_stages(tmp_path):
    from armlab.errors import ArmlabError
    from armlab.study import run_spec

    spec = _study(tmp_path, ["kinematics", "plan"], 500.0)  # gravity alone over the limits
    with pytest.raises(ArmlabError, match="^plan: "):
        run_spec(spec, tmp_path / "out", workers=2)
    assert not list((tmp_path / "out").glob("*.png"))
    assert (tmp_path / "out" / "summary.json").is_file()


def test_the_command_line_runs_blas_on_one_thread_unless_told(monkeypatch):
    """``armlab`` commands set numpy's BLAS to one thread (the report's plot processes run
    beside the stages), and leave it alone when the environment chooses."""
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


def test_drive_model_variants_simulated_beside_the_tracking_stage_are_the_plot_s(
    tmp_path, monkeypatch
):
    """With two workers the drive-model plot's variants are simulated by a process forked at
    the end of the tuning stage, beside the tracking stage: the plot is the file one process
    draws, and the variants are those simulated in the study's own process."""
    from armlab.control.diagnosis import tracking_variants
    from armlab.study import run_spec
    from armlab.study.report import DRIVE_MODEL_VARIANTS, _VariantPrefetch

    spec = _study(tmp_path, ["kinematics", "plan", "tuning", "tracking"], 0.5)
    one = run_spec(spec, tmp_path / "one", workers=1)
    started: list[str] = []
    original = _VariantPrefetch.__init__

    def counted(self, ctx) -> None:
        started.append(ctx.spec.study.name)
        original(self, ctx)

    monkeypatch.setattr(_VariantPrefetch, "__init__", counted)
    run_spec(spec, tmp_path / "two", workers=2)
    monkeypatch.undo()
    assert len(started) == 1  # one process simulated the variants, beside the stage
    name = "tracking_drive_model.png"
    assert (tmp_path / "two" / name).read_bytes() == (tmp_path / "one" / name).read_bytes()

    ctx = one.context
    prefetch = _VariantPrefetch(ctx)
    try:
        got = prefetch.take()
    finally:
        prefetch.close()
    here = tracking_variants(
        ctx.robot, ctx.trajectory, ctx.gains, DRIVE_MODEL_VARIANTS, **ctx.tracking_options
    )
    assert set(got) == set(here) and "ideal" in got
    for key, res in here.items():
        assert np.array_equal(got[key].q, res.q) and np.array_equal(
            got[key].current_A, res.current_A
        )
    assert got["ideal"].tcp_max_error_m < ctx.tracking.tcp_max_error_m  # not the full model


def test_drive_model_variants_whose_process_dies_are_simulated_by_the_plot(tmp_path):
    """A variant process that dies gives no variants, and the plot simulates them itself."""
    from armlab.study import run_spec
    from armlab.study.report import _drive_model_figure, _VariantPrefetch

    spec = _study(tmp_path, ["kinematics", "plan", "tuning", "tracking"], 0.5)
    ctx = run_spec(spec, tmp_path / "one", workers=1).context
    prefetch = _VariantPrefetch(ctx)
    assert len(prefetch.sides) == 2  # with and without the supply limit
    for side in prefetch.sides:
        side._process.kill()
        side._process.join()
    try:
        assert prefetch.take() == {}
        fig = _drive_model_figure(ctx, prefetch)  # simulated here instead
    finally:
        prefetch.close()
    assert len(fig.axes) >= 2


def test_the_tuning_run_beside_the_earlier_stages_gives_the_study_s_gains(tmp_path):
    """With two workers the servo tuning runs in a forked process beside the kinematics and
    plan stages (it needs the drives and the controller only): the stage takes its gains, the
    same numbers one process tunes, and says so in its block."""
    from armlab.study import run_spec

    spec = _study(tmp_path, ["kinematics", "plan", "tuning"], 0.5)
    one = run_spec(spec, tmp_path / "one", workers=1)
    two = run_spec(spec, tmp_path / "two", workers=2)
    assert one.summary["control"]["tuned_ahead"] is False
    assert two.summary["control"]["tuned_ahead"] is True
    g1, g2 = one.context.gains, two.context.gains
    assert g1.summary() == g2.summary()
    for joint in g1.joints:
        assert g1[joint] == g2[joint]


def test_a_side_process_that_fails_or_dies_gives_no_result():
    """A side process whose function raises, or which dies, gives None: the stage that needs
    the result then does the work itself."""
    from armlab._fork import SideProcess

    failing = SideProcess(math.sqrt, -1.0)  # ValueError in the child
    dying = SideProcess(time.sleep, 60.0)
    working = SideProcess(math.sqrt, 4.0)
    dying._process.kill()
    try:
        assert failing.result(30.0) is None
        assert dying.result(30.0) is None
        assert working.result(30.0) == 2.0
    finally:
        for side in (failing, dying, working):
            side.close()


def test_the_motion_file_written_beside_the_stages_is_the_report_s(tmp_path, monkeypatch):
    """With two workers the 3D animation is written by a process forked when the sizing stage
    ends: the report links it as one process does. A study that stops after that leaves no
    animation behind, as it leaves no plots."""
    from armlab.errors import ArmlabError
    from armlab.study import run_spec
    from armlab.study import runner as study_runner

    stages = ["kinematics", "plan", "static_load", "sizing", "tuning"]
    spec = _study(tmp_path, stages, 0.5)
    one = run_spec(spec, tmp_path / "one", workers=1)
    two = run_spec(spec, tmp_path / "two", workers=2)

    def motion_lines(folder):
        text = (folder / "report.md").read_text()
        return [line for line in text.splitlines() if "motion.html" in line]

    assert (tmp_path / "two" / "motion.html").is_file()
    assert motion_lines(tmp_path / "two") == motion_lines(tmp_path / "one") != []
    assert "motion.html" in {p.name for p in two.files}
    assert {p.name for p in two.files} == {p.name for p in one.files}

    def broken(ctx):
        raise ArmlabError("tuning broke on purpose")

    monkeypatch.setitem(study_runner.STAGE_FUNCTIONS, "tuning", broken)
    with pytest.raises(ArmlabError, match="tuning broke"):
        run_spec(spec, tmp_path / "stopped", workers=2)
    assert not (tmp_path / "stopped" / "motion.html").exists()
    assert not list((tmp_path / "stopped").glob("*.png"))
    assert not list((tmp_path / "stopped").glob("*.tmp"))
