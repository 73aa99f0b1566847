"""armlab.deploy gains export: JSON (loads back into armlab.control objects, same margins;
numbers only), ros2_control YAML, C (header + data file, double or float); and ``armlab export``
of a study holding gains."""

from __future__ import annotations

import json
import math
import shutil
import subprocess

import numpy as np
import pytest
import yaml

import armlab
from armlab.cli import main as cli_main
from armlab.deploy import load_gains, write_gains
from armlab.deploy.gains_export import gains_to_ros2_yaml
from armlab.deploy.provenance import file_sha256, gains_sha256
from armlab.errors import DesignFailure, InputError
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


def _infinite_paths(x, path=()):
    """Paths of the "inf"/"-inf" strings of ArmGains.to_dict()."""
    if isinstance(x, dict):
        for k, v in x.items():
            yield from _infinite_paths(v, (*path, k))
    elif isinstance(x, list):
        for i, v in enumerate(x):
            yield from _infinite_paths(v, (*path, i))
    elif x in ("inf", "-inf"):
        yield path, x


def _at(d, path):
    for k in path:
        d = d[k]
    return d


def test_json_round_trip_same_gains_and_margins(teachbot6, arm_gains, tmp_path):
    path = write_gains(tmp_path / "gains.json", arm_gains)
    text = path.read_text()
    d = json.loads(text)
    # numbers only: every infinity of the gains is null plus a flag, and loads back as inf
    infinite = list(_infinite_paths(arm_gains.to_dict()))
    assert infinite, "the tuned gains have no infinite value: nothing tested"
    assert '"inf"' not in text and '"-inf"' not in text
    back = load_gains(path)
    for where, value in infinite:
        *parent, key = where
        flag = f"{key}_infinite" if value == "inf" else f"{key}_negative_infinite"
        assert _at(d, where) is None and _at(d, parent)[flag] is True, where
    gm = [(j, n) for j in JOINTS for n, lg in arm_gains[j].loops().items()]
    for j, n in gm:
        for key in ("gain_margin_dB", "output_min", "output_max"):
            a, b = getattr(back[j].loops()[n], key), getattr(arm_gains[j].loops()[n], key)
            assert a == b or (math.isnan(a) and math.isnan(b)), (j, n, key)
    assert any(math.isinf(back[j].loops()[n].gain_margin_dB) for j, n in gm)
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
    text = gains_to_ros2_yaml(arm_gains)
    doc = yaml.safe_load(text)
    cm = doc["controller_manager"]["ros__parameters"]
    assert cm["update_rate"] == 1000  # 1 ms servo period
    assert cm["joint_trajectory_controller"]["type"] == (
        "joint_trajectory_controller/JointTrajectoryController"
    )
    d = doc["joint_trajectory_controller"]["ros__parameters"]
    assert d["joints"] == list(JOINTS)
    assert d["command_interfaces"] == ["velocity"]
    assert d["state_interfaces"] == ["position", "velocity"]
    assert "constraints" not in d  # none given
    for j in JOINTS:
        pos = arm_gains[j].position
        g = d["gains"][j]
        assert (g["p"], g["i"], g["d"]) == (pos.kp, pos.ki, pos.kd)
        ratio = arm_gains[j].plant.ratio
        assert g["u_clamp_max"] == pytest.approx(pos.output_max / ratio, rel=1e-15)
        assert g["u_clamp_min"] == pytest.approx(pos.output_min / ratio, rel=1e-15)
        assert (g["i_clamp_max"], g["i_clamp_min"]) == (g["u_clamp_max"], g["u_clamp_min"])
        assert g["u_clamp_min"] < 0 < g["u_clamp_max"]
        assert g["ff_velocity_scale"] == 1.0
        assert g["antiwindup_strategy"] == ("conditional_integration" if pos.ki > 0 else "none")
        assert "i_clamp" not in g  # the deprecated symmetric key is gone
        assert all(isinstance(v, float) for k, v in g.items() if k != "antiwindup_strategy")
    assert gains_sha256(arm_gains) in text


GAINS_C = r"""
#include <stdio.h>
#include "gains.h"
int main(void) {
    int j, l;
    for (j = 0; j < ARMLAB_GAINS_N_JOINTS; ++j)
        for (l = 0; l < ARMLAB_GAINS_N_LOOPS; ++l) {
            const PID_T *g = &ARMLAB_GAINS[j][l];
            printf("%s %s %.17g %.17g %.17g %.17g %.17g %.17g %.17g %s %s %d\n",
                   ARMLAB_GAINS_JOINT[j], ARMLAB_GAINS_LOOP_NAME[l], (double)g->kp,
                   (double)g->ki, (double)g->kd, (double)g->q0, (double)g->q1, (double)g->q2,
                   (double)g->sample_time_s, ARMLAB_GAINS_UNIT_KP[l],
                   ARMLAB_GAINS_OUTPUT_SIGNAL[j][l], (int)sizeof g->kp);
        }
    return 0;
}
"""
GCC_STRICT = ["gcc", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror"]


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not available")
@pytest.mark.parametrize("real, struct, size", [("double", "f64", 8), ("float", "f32", 4)])
def test_gains_c_files_compile_strict(arm_gains, tmp_path, real, struct, size):
    write_gains(tmp_path / "gains.h", arm_gains, real=real)
    header = (tmp_path / "gains.h").read_text()
    assert "#include <math.h>" not in header and "static" not in header
    assert f"extern const armlab_pid_{struct}_t ARMLAB_GAINS[ARMLAB_GAINS_N_JOINTS][3];" in header
    (tmp_path / "main.c").write_text(GAINS_C.replace("PID_T", f"armlab_pid_{struct}_t"))
    for src in ("gains.c", "main.c"):
        subprocess.run([*GCC_STRICT, "-c", src], check=True, cwd=tmp_path, capture_output=True)
    exe = tmp_path / "main"
    subprocess.run(
        ["gcc", "-o", str(exe), "main.o", "gains.o"], check=True, cwd=tmp_path, capture_output=True
    )
    rows = subprocess.run(
        [str(exe)], check=True, capture_output=True, text=True
    ).stdout.splitlines()
    assert len(rows) == 3 * len(JOINTS)
    as_real = float if real == "double" else (lambda x: float(np.float32(x)))
    for row in rows:
        j, loop, *nums, unit, signal, nbytes = row.split()
        lg = arm_gains[j].loops()[loop]
        want = [lg.kp, lg.ki, lg.kd, lg.q0, lg.q1, lg.q2, lg.sample_time_s]
        assert [float(x) for x in nums] == [as_real(x) for x in want]
        assert unit == lg.units["kp"] and signal == lg.output_signal and int(nbytes) == size
    if real == "float":  # float really rounds: some gain differs from its double value
        assert any(
            float(np.float32(lg.kp)) != lg.kp for cg in arm_gains for lg in cg.loops().values()
        )


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
        "c": ["setpoints.h", "setpoints.c", "gains.h", "gains.c"],
        "ros2": ["ros2_controllers.yaml"],
    }
    for name in ("gains.json", "gains.h", "ros2_controllers.yaml"):
        text = (out / name).read_text()
        assert src in text and gains_sha256(arm_gains) in text and armlab.__version__ in text
    assert load_gains(out / "gains.json").to_dict() == arm_gains.to_dict()
    assert cli_main(["export", str(study), "--format", "ros2", "--out", str(out)]) == 0
    # never write into the study folder (its gains.json is the study's record)
    with pytest.raises(InputError, match="refusing to write into the study folder"):
        export_study(study, "json", None, study)


def test_a_forced_gains_export_states_the_failed_checks(teachbot6, arm_gains, tmp_path):
    """Issue 23: gains exported past failed checks say so (gains.json's source, gains.h's
    ARMLAB_GAINS_FORCED and one comment line per check); the C files still compile."""
    from armlab.trajectory import Trajectory

    t, z = np.linspace(0, 1, 11), np.zeros((11, 6))
    study = make_study_folder(tmp_path / "study", teachbot6, Trajectory(t, z, z, z), arm_gains)
    summary = json.loads((study / "summary.json").read_text())
    failed = ["sizing: joint3 */ motor_peak_torque", "tracking: joint2 error 2.1 mm > 1 mm"]
    # the failed checks as the stages record them (export recomputes the verdict from these)
    for stage, check in zip(("sizing", "tracking"), failed, strict=True):
        summary[stage] = {"status": "error", "verdict": "fail", "failed_checks": [check]}
    summary["design"] = {"verdict": "fail", "failed_checks": failed, "advisories": []}
    (study / "summary.json").write_text(json.dumps(summary))
    with pytest.raises(DesignFailure):
        export_study(study, "c", None, tmp_path / "refused")
    out = tmp_path / "out"
    export_study(study, "c", None, out, force=True)
    header = (out / "gains.h").read_text()
    assert "#define ARMLAB_GAINS_FORCED 1" in header
    assert "#define ARMLAB_GAINS_N_FAILED_CHECKS 2" in header
    assert " *   tracking: joint2 error 2.1 mm > 1 mm" in header
    assert " *   sizing: joint3 * / motor_peak_torque" in header  # no early end of comment
    assert '#define ARMLAB_GAINS_SOURCE_FILE "gains.json"' in header
    assert "#define ARMLAB_SP_FORCED 1" in (out / "setpoints.h").read_text()
    export_study(study, "json", None, out, force=True)
    assert (
        json.loads((out / "gains.json").read_text())["provenance"]["source"]["forced_despite"]
        == failed
    )
    if shutil.which("gcc") is not None:
        for src in ("gains.c", "setpoints.c"):
            subprocess.run([*GCC_STRICT, "-c", src], check=True, cwd=out, capture_output=True)
