"""The example study among obstacles (examples/teachbot6_obstacles_study.toml, issue 27): the
plan stage's optimal plan goes around the box, the exported plan keeps the clearance on coal's
fine grid (tests/oracles/coal_env_clearance.py), and motion.html draws the obstacles, the floor
and the closest pair."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from armlab.deploy.trajfile import load_trajectory
from armlab.study.report import MOTION_FILE, _motion_file
from armlab.study.runner import run_spec
from armlab.study.spec import load_study
from oracles.coal_env_clearance import env_clearance

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "teachbot6_obstacles_study.toml"
#: the plan and its export only (no sizing, tuning, tracking, no Monte-Carlo, no report)
FAST = {
    "study.stages": ["kinematics", "plan", "export"],
    "study.report": False,
    "kinematics.workspace_samples": 0,
    "kinematics.accuracy_samples": 0,
}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("obstacles")
    spec = load_study(EXAMPLE, FAST)
    return spec, run_spec(spec, out), out


def test_the_exported_plan_keeps_the_clearance(run):
    spec, result, out = run
    assert result.summary["study"]["stages"]["export"]["status"] == "ok"
    assert (out / "setpoints.csv").is_file()
    traj = load_trajectory(out / "trajectory.npz")
    obstacles = [(s.name, s.coal_geometry(), s.transform()) for s in spec.obstacles]
    d, link, obstacle, t = env_clearance(result.context.robot, traj, obstacles)
    assert d >= spec.plan.clearance_m - 1e-4, (d, link, obstacle, t)
    # the planned motion is the one exported, and it went round the box: more than one round
    stats = result.context.trajectory.stats
    assert stats["clearance_rounds"] >= 1 and stats["min_clearance_m"] >= spec.plan.clearance_m
    np.testing.assert_allclose(traj.duration, result.context.trajectory.duration, rtol=1e-9)


def test_motion_html_draws_the_obstacles_and_the_closest_pair(run, tmp_path):
    spec, result, _ = run
    ctx = result.context
    lines, written = _motion_file(ctx.robot, ctx.trajectory, tmp_path, ctx)  # the report's
    assert written
    html = (tmp_path / MOTION_FILE).read_text()
    m = re.search(r'<script type="application/json" id="armlab-scene">(.*?)</script>', html)
    manifest = json.loads(m.group(1))
    assert [o["name"] for o in manifest["obstacles"]] == ["table", "box"]
    assert manifest["floor_z_m"] == pytest.approx(spec.robot.floor_z_m)
    cp = manifest["closest_pair"]
    # the witness points are the pair's distance apart, and it is the plan's minimum
    gap = np.linalg.norm(np.subtract(cp["point_b_m"], cp["point_a_m"]))
    assert gap == pytest.approx(abs(cp["distance_m"]), abs=1e-6)
    assert cp["distance_m"] == pytest.approx(
        result.context.trajectory.stats["min_clearance_m"], abs=2e-4
    )
    assert any("the red line marks the closest pair" in line for line in lines)
