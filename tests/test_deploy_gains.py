"""armlab.deploy gains export: JSON (loads back into armlab.control objects, same margins),
ros2_control YAML, C header; and ``armlab export`` of a study holding gains."""

from __future__ import annotations

import json
import math
import shutil
import subprocess

import numpy as np
import pytest

import armlab
from armlab.cli import main as cli_main
from armlab.deploy import (
    file_sha256,
    gains_sha256,
    gains_to_ros2_yaml,
    load_gains,
    write_gains,
)
from armlab.errors import InputError
from armlab.study import export_study
from conftest import make_study_folder

ct = pytest.importorskip("control")
tuning = pytest.importorskip("armlab.control.tuning")
plant_mod = pytest.importorskip("armlab.control.plant")
loops_mod = pytest.importorskip("armlab.control.loops")
from armlab.control import ArmGains  # noqa: E402

JOINTS = ("joint4", "joint6")  # the two fastest to tune


@pytest.fixture(scope="module")
def arm_gains(teachbot6):
    inertias = plant_mod.inertia_range(teachbot6, n_samples=200, seed=0)
    joints = {
        j: tuning.tune_cascade(teachbot6, j, inertias=inertias, n_inertia_samples=200)
        for j in JOINTS
    }
    return ArmGains(joints=joints, robot="teachbot6", spec={})


def simple_open_loop(lg, plant_summary):
    """Independent python-control open loop of one loop at the nominal inertia, inner loops
    ideal: current C/(L s + R); speed C Kt/(J s); position C/s (continuous)."""
    s = ct.tf("s")
    C = lg.kp + lg.ki / s
    if lg.kd:
        C = C + lg.kd * s / (lg.derivative_filter_s * s + 1)
    p = plant_summary
    if lg.loop == "current":
        return C / (p.inductance_H * s + p.resistance_ohm)
    if lg.loop == "speed":
        return C * p.torque_constant_Nm_A / (p.inertia_motor_kg_m2["nominal"] * s)
    return C / s


def test_json_round_trip_same_gains_and_margins(teachbot6, arm_gains, tmp_path):
    path = write_gains(tmp_path / "gains.json", arm_gains)
    d = json.loads(path.read_text())
    assert d["provenance"]["gains_sha256"] == gains_sha256(arm_gains)
    assert d["provenance"]["armlab_version"] == armlab.__version__
    back = load_gains(path)
    assert isinstance(back, ArmGains)
    assert back.to_dict() == arm_gains.to_dict()
    assert gains_sha256(back) == gains_sha256(arm_gains)
    for j in JOINTS:
        for name, lg in back[j].loops().items():
            orig = arm_gains[j].loops()[name]
            assert (lg.q0, lg.q1, lg.q2) == (orig.q0, orig.q1, orig.q2)
            # python-control margins of the loaded and of the original gains agree
            gm0, pm0, _, wc0 = ct.margin(simple_open_loop(orig, arm_gains[j].plant))
            gm1, pm1, _, wc1 = ct.margin(simple_open_loop(lg, back[j].plant))
            assert (pm1, wc1) == pytest.approx((pm0, wc0), rel=1e-12)
            assert math.isfinite(pm1) and pm1 > 0
    # the cascade check on the loaded gains reproduces the stored (worst-case) margins
    inertias = plant_mod.inertia_range(teachbot6, n_samples=200, seed=0)
    plant = plant_mod.joint_plant(teachbot6, "joint6", inertias=inertias)
    rechecked = tuning.check_cascade(plant, back["joint6"])
    for name, lg in rechecked.loops().items():
        stored = arm_gains["joint6"].loops()[name]
        for key in (
            "phase_margin_deg",
            "gain_margin_dB",
            "crossover_rad_s",
            "phase_margin_discrete_deg",
            "gain_margin_discrete_dB",
        ):
            a, b = getattr(lg, key), getattr(stored, key)
            assert a == pytest.approx(b, rel=1e-9) or (math.isinf(a) and math.isinf(b)), key


def test_edited_gains_json_is_refused(arm_gains, tmp_path):
    path = write_gains(tmp_path / "gains.json", arm_gains)
    d = json.loads(path.read_text())
    d["joints"]["joint6"]["speed"]["kp"] *= 2
    path.write_text(json.dumps(d))
    with pytest.raises(InputError, match="checksum mismatch"):
        load_gains(path)
    # a study's plain gains.json (no provenance) loads
    (tmp_path / "plain.json").write_text(arm_gains.to_json())
    assert load_gains(tmp_path / "plain.json").to_dict() == arm_gains.to_dict()


def test_ros2_yaml(arm_gains, tmp_path):
    yaml = pytest.importorskip("yaml")
    text = gains_to_ros2_yaml(arm_gains)
    d = yaml.safe_load(text)["joint_trajectory_controller"]["ros__parameters"]
    assert d["joints"] == list(JOINTS)
    assert d["command_interfaces"] == ["velocity"]
    for j in JOINTS:
        pos = arm_gains[j].position
        g = d["gains"][j]
        assert (g["p"], g["i"], g["d"]) == (pos.kp, pos.ki, pos.kd)
        clamp = max(abs(pos.output_min), abs(pos.output_max)) / arm_gains[j].plant.ratio
        assert g["i_clamp"] == pytest.approx(clamp, rel=1e-15)
        assert all(isinstance(g[k], float) for k in ("p", "i", "d", "i_clamp"))
    assert gains_sha256(arm_gains) in text


GAINS_C = r"""
#include <stdio.h>
#include "gains.h"
int main(void) {
    for (int j = 0; j < ARMLAB_GAINS_N_JOINTS; ++j)
        for (int l = 0; l < ARMLAB_GAINS_N_LOOPS; ++l) {
            const armlab_pid_t *g = &ARMLAB_GAINS[j][l];
            printf("%s %s %.17g %.17g %.17g %.17g %.17g %.17g %.17g %s %s\n",
                   ARMLAB_GAINS_JOINT[j], ARMLAB_GAINS_LOOP_NAME[l], g->kp, g->ki, g->kd,
                   g->q0, g->q1, g->q2, g->sample_time_s, ARMLAB_GAINS_UNIT_KP[l],
                   ARMLAB_GAINS_OUTPUT_SIGNAL[j][l]);
        }
    return 0;
}
"""


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not available")
def test_gains_c_header_compiles(arm_gains, tmp_path):
    write_gains(tmp_path / "gains.h", arm_gains)
    (tmp_path / "main.c").write_text(GAINS_C)
    exe = tmp_path / "main"
    subprocess.run(
        ["gcc", "-std=c99", "-Wall", "-Werror", "-o", str(exe), "main.c", "-lm"],
        check=True,
        cwd=tmp_path,
        capture_output=True,
    )
    rows = subprocess.run(
        [str(exe)], check=True, capture_output=True, text=True
    ).stdout.splitlines()
    assert len(rows) == 3 * len(JOINTS)
    for row in rows:
        j, loop, *nums, unit, signal = row.split()
        lg = arm_gains[j].loops()[loop]
        assert [float(x) for x in nums] == [
            lg.kp,
            lg.ki,
            lg.kd,
            lg.q0,
            lg.q1,
            lg.q2,
            lg.sample_time_s,
        ]
        assert unit == lg.units["kp"] and signal == lg.output_signal


def test_export_study_with_gains(teachbot6, arm_gains, tmp_path, capsys):
    t = np.linspace(0, 1, 11)
    z = np.zeros((11, 6))
    from armlab.trajectory import Trajectory

    study = make_study_folder(tmp_path / "study", teachbot6, Trajectory(t, z, z, z), arm_gains)
    src = file_sha256(study / "gains.json")
    out = tmp_path / "out"
    names = {
        fmt: [p.name for p in export_study(study, fmt, None, out).files]
        for fmt in ("json", "c", "ros2")
    }
    assert names == {
        "json": ["setpoints.json", "gains.json"],
        "c": ["setpoints.h", "gains.h"],
        "ros2": ["gains_ros2.yaml"],
    }
    for name in ("gains.json", "gains.h", "gains_ros2.yaml"):
        text = (out / name).read_text()
        assert src in text and gains_sha256(arm_gains) in text and armlab.__version__ in text
    assert load_gains(out / "gains.json").to_dict() == arm_gains.to_dict()
    assert cli_main(["export", str(study), "--format", "ros2", "--out", str(out)]) == 0
    # never write into the study folder (its gains.json is the study's record)
    with pytest.raises(InputError, match="refusing to write into the study folder"):
        export_study(study, "json", None, study)
