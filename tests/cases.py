"""Shared study cases: the small studies many tests run, written once.

``quick_study`` is teachbot6 (or another robot) moving between two joint waypoints with the
classical PTP planner: cheap enough to run dozens of times in a sweep test.
"""

from __future__ import annotations

import json
import math

import numpy as np

from armlab.trajectory import Trajectory

#: the two joint waypoints of the quick study, in degrees
QUICK_WAYPOINTS_DEG = [[0, 0, 0, 0, 0, 0], [20, 10, 10, 0, 20, 0]]


def quick_study(
    name: str = "quick",
    stages: tuple[str, ...] = ("kinematics", "plan", "static_load"),
    *,
    robot: str = "teachbot6",
    report: bool = False,
    check_dt_s: float | None = 0.01,
    accuracy_samples: int | None = None,
) -> str:
    """The TOML text of the quick study (study file reference: docs/study-file.md)."""
    lines = [
        "[study]",
        f"name = {json.dumps(name)}",
        f"stages = {json.dumps(list(stages))}",
        f"report = {'true' if report else 'false'}",
        "[robot]",
        f"name = {json.dumps(robot)}",
        "[waypoints]",
        'unit = "deg"',
        f"joint = {json.dumps(QUICK_WAYPOINTS_DEG)}",
        "[plan]",
        'planner = "ptp"',
    ]
    if check_dt_s is not None:
        lines.append(f"check_dt_s = {check_dt_s!r}")
    if accuracy_samples is not None:
        lines += ["[kinematics]", f"accuracy_samples = {accuracy_samples}"]
    return "\n".join(lines) + "\n"


def cosine_motion(robot, duration_s=60.0, n=6001, scale=0.9, terms=((3, 0.45), (7, 0.3))):
    """Sum of ``A (1 - cos(w t)) - A`` per joint, at rest at both ends, within ``scale`` of the
    speed and acceleration limits (each term takes a share ``frac`` of both)."""
    t = np.linspace(0.0, duration_s, n)
    lim = robot.limits
    q = np.zeros((n, robot.n_joints))
    qd, qdd = np.zeros_like(q), np.zeros_like(q)
    for j in range(robot.n_joints):
        for k, frac in terms:
            w = 2 * math.pi * k / duration_s
            A = min(
                frac * scale * lim.velocity_rad_s[j] / w,
                frac * scale * lim.acceleration_rad_s2[j] / w**2,
            )
            q[:, j] += A * (1 - np.cos(w * t)) - A
            qd[:, j] += A * w * np.sin(w * t)
            qdd[:, j] += A * w * w * np.cos(w * t)
    return Trajectory(t, q, qd, qdd, joint_names=robot.joint_names, method="cosines")


def one_line(capsys) -> str:
    """The one line a refused command wrote to stderr (asserts it is exactly one)."""
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


# ---------------------------------------------------------- the compiled CasADi graphs
def graph_mode(monkeypatch):
    """For a ``mode`` fixture: ``set_mode(value, **env)`` sets ``$ARMLAB_SCURVE_GRAPH`` (and
    other variables) and resets the graphs' process state (:mod:`armlab._compiled`); undone,
    and reset again, after the test."""
    from armlab import _compiled

    def set_mode(value, **env):
        monkeypatch.setenv("ARMLAB_SCURVE_GRAPH", value)
        for k, x in env.items():
            monkeypatch.setenv(k, x)
        _compiled.reset()

    yield set_mode
    monkeypatch.undo()
    _compiled.reset()


def compiled_into_tmp(tmp_path_factory, compile_library, n: int):
    """For a module fixture: a graph of ``n`` joints compiled once (``compile_library(n)``)
    into a temporary cache folder, its library's path; the test skipped without a compiler."""
    import pytest

    from armlab._cache import CompilerUnavailable

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("ARMLAB_CACHE_DIR", str(tmp_path_factory.mktemp("armlab-cache")))
        try:
            so = compile_library(n)
        except CompilerUnavailable as exc:
            pytest.skip(f"no compiled graph here: {exc}")
        yield so


def in_threads(work, n_threads: int) -> None:
    """``work(k)`` in ``n_threads`` threads at once (``k`` the thread's number); an
    AssertionError of any thread raised here, in the test's thread."""
    import threading

    errors: list[AssertionError] = []

    def run(k: int) -> None:
        try:
            work(k)
        except AssertionError as exc:
            errors.append(exc)

    threads = [threading.Thread(target=run, args=(k,)) for k in range(n_threads)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors[0]
