"""armlab.deploy.cia402: CiA 402 cyclic synchronous position set-points and object dictionary.

Independent references: the set-point table's counts (``setpoints.csv`` of the same export),
Pinocchio's RNEA called directly with the drive-train rule written out (thesis table 4.3:
reducer efficiency, rotor + reducer inertia, viscous friction), and teachbot6's drives (1000-line
encoders x4, reducer ratios of HEU thesis table 4.3).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pinocchio as pin
import pytest

from armlab.cli import main as cli_main
from armlab.deploy import (
    cia402_csp,
    read_cia402_csp,
    read_cia402_objects,
    read_setpoints,
    setpoint_table,
)
from armlab.deploy.cia402 import Cia402Object, interpolation_period
from armlab.errors import InputError
from armlab.robot import load_profile
from armlab.study import export_study
from armlab.trajectory import Trajectory
from cases import cosine_motion
from conftest import make_study_folder

RATIOS = (125, 410, 385, 80, 298, 128)  # thesis table 4.3


def objects_by_axis(objects) -> dict[tuple[int, int, int], int]:
    return {(o.axis, o.index, o.subindex): o.value for o in objects}


@pytest.fixture(scope="module")
def motion(teachbot6):
    return cosine_motion(teachbot6, duration_s=4.0, n=401)


@pytest.mark.parametrize(
    "cycle_s, pair",
    [(1e-3, (1, -3)), (2.5e-4, (25, -5)), (1.25e-4, (125, -6)), (4e-3, (4, -3)), (2.0, (2, 0))],
)
def test_interpolation_period_value_and_index(cycle_s, pair):
    value, index = interpolation_period(cycle_s)
    assert (value, index) == pair and value * 10.0**index == pytest.approx(cycle_s, rel=1e-12)
    assert 1 <= value <= 255


def test_interpolation_period_refuses_what_0x60c2_cannot_hold():
    with pytest.raises(InputError, match="0x60C2"):
        interpolation_period(1 / 3)


def test_export_counts_round_trip_to_setpoints_csv(teachbot6, motion, tmp_path, capsys):
    study = make_study_folder(tmp_path / "study", teachbot6, motion)
    out = tmp_path / "out"
    code = cli_main(
        ["export", str(study), "--format", "cia402", "--profile", "ethercat_cia402_csp"]
        + ["--out", str(out)]
    )
    assert code == 0
    err = capsys.readouterr().err
    assert "ethercat_cia402_csp" in err and "max_pulses_per_cycle 4095 -> None" in err
    export_study(study, "csv", "ethercat_cia402_csp", out)
    sp = read_setpoints(out / "setpoints.csv")
    csp = read_cia402_csp(out / "cia402_csp.csv")
    assert sp.n_cycles == csp.n_cycles == 4001
    assert np.array_equal(csp.target_position, sp.counts)  # 0x607A = the table, cycle by cycle
    assert np.array_equal(csp.counts(), sp.counts)
    assert np.ptp(sp.counts, axis=0).min() > 1000  # every axis really moves
    assert csp.target_position.dtype == np.int64
    # velocity offset: the planned velocity in counts/s, independent of the table's rounding
    cpr = np.array([teachbot6.drives[j].counts_per_rad() for j in teachbot6.joint_names])
    _, qd, _, _ = motion.at(np.arange(4001) * 1e-3)
    # (rounded once; the table holds qd to 1e-9 rad/s, 2.6e-4 counts/s at most here)
    assert np.abs(csp.velocity_offset - qd * cpr).max() <= 0.5 + 0.5e-9 * cpr.max() + 1e-9
    assert csp.meta["trajectory_sha256"] == sp.trajectory_sha256
    objs = read_cia402_objects(out / "cia402_objects.csv")
    assert len({o.axis for o in objs}) == 6
    by = objects_by_axis(objs)
    assert all(by[(a, 0x6060, 0)] == 8 for a in range(1, 7))
    assert all((by[(a, 0x60C2, 1)], by[(a, 0x60C2, 2)]) == (1, -3) for a in range(1, 7))


def test_object_dictionary_factor_group_limits_home(teachbot6, motion):
    home = (0.1, -0.2, 0.0, 0.5, 0.0, -1.0)
    prof = load_profile("ethercat_cia402_csp").replace(home_position_rad=home)
    table = setpoint_table(teachbot6, motion, prof)
    csp = cia402_csp(teachbot6, table, prof)
    by = objects_by_axis(csp.objects)
    for a, (j, ratio) in enumerate(zip(teachbot6.joint_names, RATIOS, strict=True), start=1):
        res = Fraction(by[(a, 0x608F, 1)], by[(a, 0x608F, 2)])
        gear = Fraction(by[(a, 0x6091, 1)], by[(a, 0x6091, 2)])
        feed = Fraction(by[(a, 0x6092, 1)], by[(a, 0x6092, 2)])
        assert res == 4000 and gear == ratio and feed == 4000 * ratio
        assert res * gear / feed == 1  # one position unit = one count
        cpr = 4000 * ratio / (2 * np.pi)
        assert by[(a, 0x607C, 0)] == -round(home[a - 1] * cpr)
        lo, hi = by[(a, 0x607D, 1)], by[(a, 0x607D, 2)]
        assert (
            lo <= csp.target_position[:, a - 1].min() and csp.target_position[:, a - 1].max() <= hi
        )
        assert hi == round(teachbot6.limits.upper_rad[a - 1] * cpr)
        assert (a, 0x607B, 1) not in by
        motor = teachbot6.drives[j].motor
        assert by[(a, 0x6076, 0)] == round(motor.stall_torque_Nm * 1000)
        assert by[(a, 0x607E, 0)] == 0
        # max torque: the derated peak sizing allows; teachbot6's motors give no peak, so the
        # stall torque stands for it (joint 2 derated to 0.8, thesis table 4.3)
        d = teachbot6.drives[j]
        assert not np.isfinite(motor.peak_torque_Nm)
        assert by[(a, 0x6072, 0)] == round(
            1000 * d.derating * motor.stall_torque_Nm / (by[(a, 0x6076, 0)] / 1000)
        )


def test_torque_offset_is_the_motor_torque_of_the_plan(teachbot6, motion):
    table = setpoint_table(teachbot6, motion, controller="reference_dda")
    csp = cia402_csp(teachbot6, table, controller="reference_dda")
    rated = np.array(
        [
            round(teachbot6.drives[j].motor.stall_torque_Nm * 1000) / 1000
            for j in teachbot6.joint_names
        ]
    )
    model, data = teachbot6.model, teachbot6.model.createData()
    rng = np.random.default_rng(0)
    for k in rng.choice(table.n_cycles, size=25, replace=False):
        q, qd, qdd = table.q_rad[k], table.qd_rad_s[k], table.qdd_rad_s2[k]
        tau = pin.rnea(model, data, q, qd, qdd)
        for a, j in enumerate(teachbot6.joint_names):
            d = teachbot6.drives[j]
            N, eta = d.reducer.ratio, d.reducer.efficiency
            # efficiency by quadrant, passing linearly through standstill over 1 % of the
            # joint speed limit (rated speed, reducer input limit) (docs/drives.md)
            w_lim = min(d.motor.rated_speed_rpm, d.reducer.max_input_speed_rpm) * np.pi / 30
            share = min(abs(qd[a]) / (0.01 * w_lim / N), 1.0) if tau[a] * qd[a] < 0 else 0.0
            t_in = tau[a] * ((1 - share) / (N * eta) + share * eta / N)
            t_m = (
                t_in
                + (d.motor.rotor_inertia_kg_m2 + d.reducer.inertia_kg_m2) * N * qdd[a]
                + d.motor.viscous_friction_Nm_s_rad * N * qd[a]
            )
            assert abs(csp.torque_offset[k, a] - 1000 * t_m / rated[a]) <= 0.5 + 1e-6, (k, j)
    # gravity alone makes the shoulder's offset large and one-signed at rest (cycle 0)
    assert abs(csp.torque_offset[0, 1]) > 50


def test_axis_sign_and_modulo_axis(teachbot6, motion, tmp_path):
    prof = load_profile("ethercat_cia402_csp").replace(
        axis_sign=(1, 1, 1, 1, 1, -1), modulo_axes=("joint6",)
    )
    table = setpoint_table(teachbot6, motion, prof)
    ref = cia402_csp(
        teachbot6,
        setpoint_table(teachbot6, motion, controller="reference_dda"),
        controller="reference_dda",
    )
    csp = cia402_csp(teachbot6, table, prof)
    period = 4000 * 128
    assert csp.modulo_counts.tolist() == [0, 0, 0, 0, 0, period]
    assert table.counts[:, 5].min() < 0  # joint 6 goes negative: wrapped targets differ
    assert csp.target_position[:, 5].min() >= 0 and csp.target_position[:, 5].max() < period
    assert np.array_equal(csp.target_position[:, 5], np.mod(table.counts[:, 5], period))
    assert np.array_equal(csp.counts(), table.counts)
    # the sign reverses position, velocity and torque of the axis, and nothing else
    assert np.array_equal(csp.velocity_offset[:, 5], -ref.velocity_offset[:, 5])
    assert np.array_equal(csp.torque_offset[:, 5], -ref.torque_offset[:, 5])
    assert np.array_equal(csp.torque_offset[:, :5], ref.torque_offset[:, :5])
    by = objects_by_axis(csp.objects)
    assert (by[(6, 0x607B, 1)], by[(6, 0x607B, 2)]) == (0, period - 1)
    assert (6, 0x607D, 1) not in by
    back = read_cia402_csp(csp.write(tmp_path)[0])
    assert np.array_equal(back.counts(), table.counts)


def test_refusals(teachbot6, ur5, motion):
    table = setpoint_table(teachbot6, motion, controller="reference_dda")
    z = np.zeros((11, ur5.n_joints))
    t = np.linspace(0, 1, 11)
    prof = load_profile("generic_1khz").replace(counts_per_joint_rev=(2**17,) * 6)
    ur_table = setpoint_table(ur5, Trajectory(t, z, z, z, joint_names=ur5.joint_names), prof)
    with pytest.raises(InputError, match="no drive train"):
        cia402_csp(ur5, ur_table, prof)
    with pytest.raises(InputError, match="not profile"):
        cia402_csp(teachbot6, table, load_profile().replace(axis_order=(6, 5, 4, 3, 2, 1)))
    odd = load_profile().replace(counts_per_joint_rev=(1000.5,) * 6, modulo_axes=("joint1",))
    slow = Trajectory(t, np.zeros((11, 6)), np.zeros((11, 6)), np.zeros((11, 6)))
    with pytest.raises(InputError, match="not a whole number"):
        cia402_csp(teachbot6, setpoint_table(teachbot6, slow, odd), odd)
    with pytest.raises(InputError, match=r"0x6072:0 max torque = 70000 does not fit UNSIGNED16"):
        Cia402Object(1, "joint1", 0x6072, 0, "max torque", "UNSIGNED16", 70000)
    with pytest.raises(InputError, match="home_position_rad has 2 entries for 6 axes"):
        cia402_csp(teachbot6, table, load_profile().replace(home_position_rad=(0.0, 0.0)))
