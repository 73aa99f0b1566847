"""Robot descriptions: the DH table is the single source of teachbot6's URDF; loading any URDF."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import armlab
from armlab.errors import InputError, RobotDescriptionError
from armlab.robot import load_robot, read_dh_table, urdf_from_dh
from armlab.robot.dh import mdh_transforms
from armlab.robot.generate import description_urdf
from conftest import PANDA_URDF, REPO, UR5_URDF

DESC = REPO / "robot_desc" / "teachbot6"


def test_committed_urdf_is_the_generator_output():
    assert (DESC / "teachbot6.urdf").read_text() == description_urdf(DESC)


def test_urdf_fk_equals_closed_form_mdh_product(teachbot6):
    rng = np.random.default_rng(1)
    model, data = teachbot6.model, teachbot6.model.createData()
    for q in teachbot6.random_q(rng, 300):
        pin.framesForwardKinematics(model, data, q)
        np.testing.assert_allclose(
            data.oMf[teachbot6.tool_frame_id].homogeneous, teachbot6.dh.fk(q), atol=1e-12
        )
        for i in range(1, 7):  # every DH frame i is the placement of joint i
            np.testing.assert_allclose(
                data.oMi[i].homogeneous, teachbot6.dh.fk(q, upto=i), atol=1e-12
            )


def test_mdh_table_values_match_the_thesis(teachbot6):
    dh = teachbot6.dh
    np.testing.assert_allclose(dh.a_m, [0, 0.12, 0.22, 0.08, 0, 0])
    np.testing.assert_allclose(dh.d_m, [0, 0, 0, 0.202, 0, 0])
    np.testing.assert_allclose(np.degrees(dh.alpha_rad), [0, -90, 0, -90, 90, -90])
    # thesis table 2.1 speeds, as the URDF's <limit velocity> (robot.limits caps them by the
    # drive train: tests/robot/test_limits.py)
    urdf = armlab.robot.limits.description_limits(teachbot6.model)
    np.testing.assert_allclose(urdf.velocity_rad_s, [0.56, 0.26, 0.65, 0.875, 0.875, 1.22])
    assert dh.labels == ("S", "L", "U", "R", "B", "T")


def test_effort_limits_are_table_4_3_available_torque(teachbot6):
    # thesis table 4.3 "available output torque": 9.55, 55, 30, 1.4, 5.3, 1.2 N m
    np.testing.assert_allclose(teachbot6.limits.effort_Nm, [9.55, 55, 30, 1.4, 5.3, 1.2], rtol=0.02)
    d2 = teachbot6.drive("joint2")
    assert d2.available_torque_Nm == pytest.approx(0.28 * 410 * 0.6 * 0.8)


def test_lumped_masses_total_table_4_1(teachbot6):
    # table 4.1: 4.35 + 1.5 + 1.876 + 2.215 + 0.5 + 1.72 + 0.63 + payload 0.5
    assert teachbot6.total_mass_kg == pytest.approx(13.291)
    assert teachbot6.payload.mass_kg == pytest.approx(0.5)


def test_gravity_torque_of_payload_at_home(teachbot6):
    """At q = 0 the tool points along +x base (horizontal), 0.2 m from the wrist centre: the
    payload's gravity moment about joint 5 is m g 0.2."""
    bare = teachbot6.with_payload(0.0)
    g_with = pin.computeGeneralizedGravity(
        teachbot6.model, teachbot6.model.createData(), np.zeros(6)
    )
    g_bare = pin.computeGeneralizedGravity(bare.model, bare.model.createData(), np.zeros(6))
    assert abs(g_with[4] - g_bare[4]) == pytest.approx(0.5 * 9.81 * 0.2, rel=1e-9)
    # a heavier payload scales the difference linearly
    heavy = teachbot6.with_payload(2.0)
    g_heavy = pin.computeGeneralizedGravity(heavy.model, heavy.model.createData(), np.zeros(6))
    np.testing.assert_allclose(g_heavy - g_bare, 4.0 * (g_with - g_bare), atol=1e-12)


def test_payload_keyword_and_copy_are_independent():
    r = load_robot("teachbot6", payload_kg=1.5)
    assert r.payload.mass_kg == 1.5
    c = r.with_payload(0.0)
    assert r.payload.mass_kg == 1.5 and c.payload.mass_kg == 0.0
    assert r.total_mass_kg - c.total_mass_kg == pytest.approx(1.5)


def test_tool_transform_moves_the_tool_point(teachbot6):
    r = teachbot6.copy()
    T = np.eye(4)
    T[2, 3] = 0.05  # 50 mm longer tool
    r.set_tool(T)
    q = np.array([0.3, -0.2, 0.4, 0.1, 0.5, -0.3])
    from armlab.kinematics import fk

    T0, T1 = fk(teachbot6, q), fk(r, q)
    np.testing.assert_allclose(T1[:3, 3] - T0[:3, 3], 0.05 * T0[:3, 2], atol=1e-12)


def test_base_transform_is_applied(teachbot6):
    from armlab.kinematics import fk

    T_base = np.eye(4)
    T_base[:3, 3] = [0.1, -0.2, 0.8]
    r = load_robot("teachbot6", transform_base_to_world=T_base)
    q = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    np.testing.assert_allclose(fk(r, q), T_base @ fk(teachbot6, q), atol=1e-12)


def test_classic_dh_table_gives_same_kinematics_as_modified(tmp_path):
    """PUMA-like arm written in both conventions: same tool pose at random q."""
    classic = tmp_path / "c.toml"
    # classic rows (theta offset, d, a, alpha) of the teachbot6 geometry
    rows = [
        (0, 0, 120, -90),
        (-90, 0, 220, 0),
        (0, 0, 80, -90),
        (0, 202, 0, 90),
        (0, 0, 0, -90),
        (0, 0, 0, 0),
    ]
    text = 'name = "c"\nconvention = "classic"\n'
    for i, (off, d, a, al) in enumerate(rows, 1):
        text += (
            f'[[joint]]\nname = "j{i}"\na_mm = {a}\nalpha_deg = {al}\n'
            f"theta_offset_deg = {off}\n"
            f"d_mm = {d}\nlower_deg = -170\nupper_deg = 170\nvelocity_rad_s = 1\n"
        )
    classic.write_text(text)
    tc = read_dh_table(classic)
    tm = read_dh_table(DESC / "mdh.toml")
    rng = np.random.default_rng(0)
    q = rng.uniform(-1, 1, (50, 6))
    # tool of the modified table is 200 mm out along z6; compare the wrist frames instead
    np.testing.assert_allclose(tc.fk(q)[:, :3, 3], tm.fk(q, upto=6)[:, :3, 3], atol=1e-12)
    # and the URDF written from the classic table loads and agrees
    urdf = tmp_path / "c.urdf"
    urdf.write_text(urdf_from_dh(tc))
    r = load_robot(urdf)
    from armlab.kinematics import fk_batch

    np.testing.assert_allclose(fk_batch(r, q), tc.fk(q), atol=1e-12)


def test_mdh_transform_is_craig_product():
    a, al, d, th = 0.3, 0.7, -0.2, 1.1
    T = mdh_transforms(np.array([a]), np.array([al]), np.array([d]), np.array([[th]]))[0, 0]

    def rx(x):
        return np.array(
            [
                [1, 0, 0, 0],
                [0, math.cos(x), -math.sin(x), 0],
                [0, math.sin(x), math.cos(x), 0],
                [0, 0, 0, 1],
            ]
        )

    def rz(x):
        return np.array(
            [
                [math.cos(x), -math.sin(x), 0, 0],
                [math.sin(x), math.cos(x), 0, 0],
                [0, 0, 1, 0],
                [0, 0, 0, 1],
            ]
        )

    def tr(x, y, z):
        m = np.eye(4)
        m[:3, 3] = [x, y, z]
        return m

    np.testing.assert_allclose(T, rx(al) @ tr(a, 0, 0) @ rz(th) @ tr(0, 0, d), atol=1e-15)


@pytest.mark.parametrize("path, n", [(UR5_URDF, 6), (PANDA_URDF, 9)])
def test_load_example_robot_data_urdfs(path, n):
    r = load_robot(path)
    assert r.n_joints == n
    assert r.drives is None and r.dh is None
    assert np.all(r.limits.upper_rad > r.limits.lower_rad)
    assert r.limits.acceleration_rad_s2 is None


def test_panda_with_locked_fingers(panda):
    assert panda.n_joints == 7
    assert "panda_finger_joint1" not in panda.joint_names


def test_payload_on_a_plain_urdf(ur5):
    r = ur5.with_payload(3.0)
    assert r.total_mass_kg - ur5.total_mass_kg == pytest.approx(3.0)


# ---------------------------------------------------------------- bad input
def test_unknown_robot_name():
    with pytest.raises(RobotDescriptionError, match="unknown robot 'nosuchbot'"):
        load_robot("nosuchbot")


def test_missing_urdf_file(tmp_path):
    with pytest.raises(RobotDescriptionError, match="not found"):
        load_robot(tmp_path / "missing.urdf")


def test_malformed_urdf(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text('<robot name="x"><link name="a"></robot>')
    with pytest.raises(RobotDescriptionError, match=r"bad\.urdf: malformed URDF"):
        load_robot(bad)


def test_dh_table_with_nan(tmp_path):
    text = (DESC / "mdh.toml").read_text().replace("a_mm = 220", "a_mm = nan", 1)
    p = tmp_path / "mdh.toml"
    p.write_text(text)
    with pytest.raises(
        RobotDescriptionError, match=r"mdh\.toml: joint 3 \(joint3\) a_mm is not finite"
    ):
        read_dh_table(p)


def test_drives_with_unknown_joint(tmp_path):
    from armlab.robot import read_drives

    p = tmp_path / "drives.toml"
    p.write_text((DESC / "drives.toml").read_text().replace('name = "joint6"', 'name = "joint7"'))
    with pytest.raises(RobotDescriptionError, match="'joint7': no such joint"):
        read_drives(p, [f"joint{i}" for i in range(1, 7)])


def test_unknown_joint_name(teachbot6):
    with pytest.raises(InputError, match="unknown joint 'elbow'"):
        teachbot6.joint_index("elbow")
    assert teachbot6.joint_index("U") == 2 and teachbot6.joint_index(3) == 2


def test_bad_q_shape_and_nan(teachbot6):
    with pytest.raises(InputError, match=r"shape \(5,\)"):
        teachbot6.check_q(np.zeros(5))
    with pytest.raises(InputError, match="NaN"):
        teachbot6.check_q(np.array([0, 0, np.nan, 0, 0, 0]))


def test_negative_payload_rejected(teachbot6):
    with pytest.raises(InputError, match="payload mass"):
        teachbot6.copy().attach_payload(-1.0)


# ---------------------------------------------------------------- CLI
def _armlab(*args):
    exe = Path(sys.executable).with_name("armlab")
    return subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=120)


def test_cli_info_teachbot6():
    res = _armlab("info", "teachbot6")
    assert res.returncode == 0, res.stderr
    assert "joint6" in res.stdout and "GP22C" in res.stdout
    reach_mm = float(res.stdout.split("reach")[1].split("mm")[0])
    assert reach_mm >= 700.0  # thesis 2.2.2 requirement


@pytest.mark.parametrize(
    "arg, needle", [("nosuchbot", "unknown robot"), ("/nonexistent/x.urdf", "not found")]
)
def test_cli_errors_are_one_line(arg, needle):
    res = _armlab("info", arg)
    assert res.returncode != 0
    assert needle in res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1


def test_version_exported():
    assert armlab.__version__
