"""Bounded work (issue 24, item 7): a study that asks for more samples than armlab's bounds
(:mod:`armlab.study.budget`) is refused before anything big is allocated, with one line naming
the study key and the estimate.

The issue's values each ran out of memory (``MemoryError`` tracebacks; ``speed_scale = 1e-6``
grew to 20 GB). Here every case runs in one child process whose address space is limited to
4 GB, so an allocation that escaped the bounds fails the test instead of the machine.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from armlab.errors import SpecError
from armlab.study.budget import MAX_SAMPLES, check_samples, check_waypoints, min_duration_s
from armlab.study.spec import parse_study
from cases import QUICK_WAYPOINTS_DEG, quick_study
from conftest import sweep_env

ALL_STAGES = ("kinematics", "plan", "sizing", "tuning", "tracking", "export")

#: (case, text replaced in the quick study, replacement, the key the refusal names)
CASES = [
    ("speed_scale", 'planner = "ptp"', 'planner = "ptp"\nspeed_scale = 1e-6', "plan.speed_scale"),
    ("check_dt_s", "check_dt_s = 0.01", "check_dt_s = 1e-7", "plan.check_dt_s"),
    (
        "workspace_samples",
        "[plan]",
        "[kinematics]\nworkspace_samples = 10000000000\n[plan]",
        "kinematics.workspace_samples",
    ),
    (
        "n_inertia_samples",
        "[plan]",
        "[control]\nn_inertia_samples = 1000000000\n[plan]",
        "control.n_inertia_samples",
    ),
    ("t_after_s", "[plan]", "[tracking]\nt_after_s = 1e9\n[plan]", "tracking.t_after_s"),
    ("servo_period_s", "[plan]", "[controller]\nservo_period_s = 1e-9\n[plan]", "servo_period_s"),
    (
        "cubic_hour",
        'planner = "ptp"\ncheck_dt_s = 0.01',
        'planner = "cubic"\nduration_s = 3600.0\ncheck_dt_s = 0.001',
        "plan.duration_s",
    ),
]

#: run every study in this process, address space limited to 4 GB; one JSON line per case
CHILD = textwrap.dedent(
    """
    import contextlib, io, json, resource, sys
    resource.setrlimit(resource.RLIMIT_AS, (4 * 2**30, 4 * 2**30))
    from armlab.cli import main
    for name, study, out in json.loads(sys.argv[1]):
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                code = main(["run", study, "--out", out])
            except BaseException as exc:  # what escaped main: a MemoryError, say
                code, err = -1, io.StringIO(f"{type(exc).__name__}: {exc}")
        print(json.dumps({"name": name, "code": code, "err": err.getvalue()}), flush=True)
    """
)


@pytest.mark.slow
def test_the_issues_requests_are_refused_naming_the_key(tmp_path):
    jobs = []
    for name, old, new, _ in CASES:
        text = quick_study(name, ALL_STAGES)
        assert old in text
        study = tmp_path / f"{name}.toml"
        study.write_text(text.replace(old, new, 1))
        jobs.append([name, str(study), str(tmp_path / name)])
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, json.dumps(jobs)],
        capture_output=True,
        text=True,
        env=sweep_env(),
        timeout=900,
    )
    results = {r["name"]: r for r in map(json.loads, proc.stdout.splitlines())}
    assert set(results) == {c[0] for c in CASES}, proc.stderr
    for name, _, _, key in CASES:
        r = results[name]
        lines = r["err"].strip().splitlines()
        assert r["code"] == 2, (name, r)
        assert len(lines) == 1 and key in lines[0], (name, lines)
        assert "Traceback" not in r["err"]


def test_the_estimate_is_a_lower_bound_of_the_duration():
    """min_duration_s: each segment lasts at least its slowest joint's distance / speed."""
    q = np.radians(np.array(QUICK_WAYPOINTS_DEG + [[0, 0, 0, 0, 0, 0]], float))
    v = np.array([1.0, 0.5, 2.0, 1.0, 4.0, 1.0])
    segments = [max(abs(q[i + 1] - q[i]) / v) for i in range(2)]
    assert min_duration_s(q, v) == pytest.approx(sum(segments), rel=1e-12)
    assert min_duration_s(q, None) == 0.0
    assert min_duration_s(q[:1], v) == 0.0


def test_bounds_refuse_above_and_pass_at_the_bound():
    check_samples(MAX_SAMPLES, 6, "plan.check_dt_s = 1", "at the bound")
    for bad in (MAX_SAMPLES + 1, float("inf"), float("nan")):
        with pytest.raises(SpecError, match=r"^plan\.check_dt_s = 1: needs"):
            check_samples(bad, 6, "plan.check_dt_s = 1", "over")
    check_waypoints(100, "optimal", "waypoints.joint")
    with pytest.raises(SpecError, match="waypoints.joint: 101 waypoints"):
        check_waypoints(101, "optimal", "waypoints.joint")
    check_waypoints(1000, "ptp", "waypoints.joint")
    with pytest.raises(SpecError, match="waypoints.joint: 1001 waypoints"):
        check_waypoints(1001, "ptp", "waypoints.joint")


def test_ten_thousand_waypoints_are_refused_when_the_study_is_read():
    rows = [[0.0] * 6, [1.0] * 6] * 5000
    for planner in ("optimal", "ptp"):
        doc = {
            "robot": {"name": "teachbot6"},
            "waypoints": {"joint": rows},
            "plan": {"planner": planner},
        }
        with pytest.raises(SpecError, match="^waypoints.joint: 10000 waypoints"):
            parse_study(doc)
