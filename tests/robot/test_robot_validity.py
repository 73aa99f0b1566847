"""Physically valid robots only (issue 17): URDF checks at load, drives.toml values checked by
their meaning, the URDF parser's console output captured, a corrupt trajectory.npz refused;
every refusal one line, no traceback."""

from __future__ import annotations

import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

import armlab
from armlab.cli import main
from armlab.errors import InputError, RobotDescriptionError
from armlab.robot import read_drives
from conftest import REPO

DESC = REPO / "robot_desc" / "teachbot6"

# A two-link arm: link1 (1 kg) moved by joint1, link2 (0.5 kg) by joint2, tool0 fixed on link2.
URDF = """<?xml version="1.0"?>
<robot name="arm2">
  <link name="base_link"/>
  <link name="link1">
    <inertial>
      <origin xyz="{com1}" rpy="0 0 0"/>
      <mass value="{mass1}"/>
      <inertia ixx="{ixx1}" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
  </link>
  <link name="link2">{inertial2}</link>
  <link name="tool0"/>
  <joint name="joint1" type="revolute">
    <parent link="base_link"/>
    <child link="link1"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/>
    <axis xyz="{axis1}"/>
    <limit lower="{lower1}" upper="1.5" effort="{effort1}" velocity="1"/>
  </joint>
  <joint name="joint2" type="revolute">
    <parent link="{parent2}"/>
    <child link="link2"/>
    <origin xyz="0.3 0 0" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="{velocity2}"/>
  </joint>
  <joint name="tool_joint" type="fixed">
    <parent link="link2"/>
    <child link="tool0"/>
    <origin xyz="0.2 0 0" rpy="0 0 0"/>
  </joint>
</robot>
"""
INERTIAL2 = """
    <inertial>
      <origin xyz="0.1 0 0" rpy="0 0 0"/>
      <mass value="0.5"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/>
    </inertial>
  """
DEFAULTS = {
    "com1": "0.15 0 0",
    "mass1": "1.0",
    "ixx1": "0.005",
    "inertial2": INERTIAL2,
    "axis1": "0 0 1",
    "lower1": "-1.5",
    "effort1": "20",
    "parent2": "link1",
    "velocity2": "1",
}


def write_urdf(tmp_path: Path, **changes: str) -> Path:
    path = tmp_path / "arm2.urdf"
    path.write_text(URDF.format(**{**DEFAULTS, **changes}))
    return path


def test_the_valid_two_link_arm_loads(tmp_path):
    robot = armlab.load_robot(write_urdf(tmp_path))
    assert robot.n_joints == 2
    assert robot.total_mass_kg == pytest.approx(1.5)


# The defects users met, each refused with one line naming the link or joint and the value.
REFUSED = [
    # mass -6 loaded; `armlab info` showed "mass -6.000 kg", a plan 1.8e47 N m gravity torques
    ({"mass1": "-6"}, "link 'link1' has a negative mass (-6 kg)"),
    # the C++ parser dropped the <inertial> ("mass [nan] is not a float"): the link weighed 0
    ({"mass1": "nan"}, "link 'link1' <mass value=\"nan\">: not a finite number"),
    ({"mass1": "inf"}, "link 'link1' <mass value=\"inf\">: not a finite number"),
    ({"mass1": "1kg"}, "link 'link1' <mass value=\"1kg\">: not a finite number"),
    ({"ixx1": "nan"}, "link 'link1' <inertia ixx=\"nan\">: not a finite number"),
    ({"com1": "0.15 inf 0"}, "link 'link1' <origin xyz=\"0.15 inf 0\">: not 3 finite numbers"),
    ({"com1": "0.15 0"}, "link 'link1' <origin xyz=\"0.15 0\">: not 3 finite numbers"),
    ({"lower1": "nan"}, "joint 'joint1' <limit lower=\"nan\">: not a finite number"),
    ({"axis1": "0 nan 1"}, "joint 'joint1' <axis xyz=\"0 nan 1\">: not 3 finite numbers"),
    (
        {"mass1": "0"},
        "link 'link1' has mass 0 kg but a nonzero inertia; give a mass > 0, or declare a "
        "massless link with no <inertial> (or zero mass and zero inertia)",
    ),
    (
        {"ixx1": "-0.001"},
        "link 'link1' inertia is not positive (semi-)definite: principal moments -0.001, 0.01, "
        "0.01 kg m^2",
    ),
    (
        {"ixx1": "0.03"},
        "link 'link1' inertia breaks the triangle inequality: principal moments 0.01 + 0.01 < "
        "0.03 kg m^2",
    ),
    # axis "0 0 0" loaded silently (a joint that moves nothing)
    (
        {"axis1": "0 0 0"},
        "joint 'joint1' <axis xyz=\"0 0 0\"> is the zero vector; give the unit direction of the "
        "motion",
    ),
    (
        {"axis1": "0 0 2"},
        "joint 'joint1' <axis xyz=\"0 0 2\"> has length 2, not 1; write the unit vector "
        'xyz="0 0 1"',
    ),
    ({"lower1": "2"}, "joint 'joint1' limit lower 2 > upper 1.5"),
    (
        {"effort1": "-20"},
        "joint 'joint1' limit effort -20 is negative (a magnitude; 0 means unknown)",
    ),
    (
        {"velocity2": "-1"},
        "joint 'joint2' limit velocity -1 is negative (a magnitude; 0 means unknown)",
    ),
]


@pytest.mark.parametrize(("changes", "message"), REFUSED, ids=[str(c) for c, _ in REFUSED])
def test_a_physically_invalid_urdf_is_refused_naming_the_value(tmp_path, capfd, changes, message):
    path = write_urdf(tmp_path, **changes)
    with pytest.raises(RobotDescriptionError) as err:
        armlab.load_robot(path)
    assert str(err.value) == f"{path}: {message}"
    out, errs = capfd.readouterr()
    assert out == "" and errs == ""  # nothing of the C++ parser reaches the terminal


def test_massless_links_and_rounded_axes_load(tmp_path):
    """Explicitly massless: no <inertial> (link2 here), or mass 0 with zero inertia (UR5's
    tool0, Panda's panda_link8); a point mass (zero inertia, mass > 0) and a unit axis rounded
    to 4 digits are valid too."""
    zero = (
        '<inertial><mass value="0"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>'
        "</inertial>"
    )
    point = zero.replace('"0"/><inertia', '"0.2"/><inertia')
    for inertial2, mass in (("", 1.0), (zero, 1.0), (point, 1.2)):
        robot = armlab.load_robot(write_urdf(tmp_path, inertial2=inertial2))
        assert robot.total_mass_kg == pytest.approx(mass)
    rounded = armlab.load_robot(write_urdf(tmp_path, axis1="0 0.7071 0.7071"))
    axis = rounded.model.joints[1].extract().axis
    np.testing.assert_allclose(axis, [0, 2**-0.5, 2**-0.5], atol=1e-12)  # normalised


def test_a_link_fixed_to_the_base_is_not_checked_for_inertia(tmp_path):
    """The base never moves: only its numbers are checked (tiago's antennas, anymal's base)."""
    text = write_urdf(tmp_path).read_text()
    text = text.replace(
        '<link name="base_link"/>',
        '<link name="base_link"><inertial><mass value="2"/>'
        '<inertia ixx="-1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>',
    )
    path = tmp_path / "base.urdf"
    path.write_text(text)
    assert armlab.load_robot(path).total_mass_kg == pytest.approx(1.5)
    path.write_text(text.replace('<mass value="2"/>', '<mass value="-2"/>'))
    with pytest.raises(RobotDescriptionError, match=r"link 'base_link' has a negative mass"):
        armlab.load_robot(path)


def test_teachbot6_with_a_nan_mass_is_refused_not_lightened(tmp_path, capfd):
    """The user's case: link2's mass written "nan"; the parser dropped 3.4 kg of arm with a
    warning on stderr, the worst static torque fell from 29.4 to 23.4 N m, exit 0."""
    folder = tmp_path / "teachbot6"
    shutil.copytree(DESC, folder)
    urdf = folder / "teachbot6.urdf"
    text, n = re.subn(
        r'(<link name="link2">\s*<inertial>.*?<mass value=")[^"]+',
        r"\g<1>nan",
        urdf.read_text(),
        count=1,
        flags=re.S,
    )
    assert n == 1
    urdf.write_text(text)
    with pytest.raises(RobotDescriptionError) as err:
        armlab.load_robot(folder)
    assert str(err.value) == f"{urdf}: link 'link2' <mass value=\"nan\">: not a finite number"
    assert capfd.readouterr() == ("", "")


def test_the_parser_output_of_a_malformed_urdf_is_summarised_not_printed(tmp_path, capfd):
    """urdfdom prints 'Error: ... at line N in link.cpp' on fd 2 before raising; armlab keeps it
    off the terminal and puts its first error line into the message."""
    path = write_urdf(tmp_path, parent2="no_such_link")
    with pytest.raises(RobotDescriptionError) as err:
        armlab.load_robot(path)
    assert str(err.value).startswith(
        f"{path}: malformed URDF (Failed to build tree: parent link [no_such_link] of joint "
        "[joint2] not found."
    )
    assert "\n" not in str(err.value)
    assert capfd.readouterr() == ("", "")
    # fds 1 and 2 are restored: what is printed afterwards reaches them again
    print("after")
    print("after-err", file=sys.stderr)
    assert capfd.readouterr() == ("after\n", "after-err\n")


def test_a_urdf_that_is_not_xml_is_refused_before_the_parser(tmp_path, capfd):
    path = tmp_path / "broken.urdf"
    path.write_text(write_urdf(tmp_path).read_text().replace("</robot>", ""))
    with pytest.raises(RobotDescriptionError) as err:
        armlab.load_robot(path)
    assert str(err.value).startswith(f"{path}: malformed URDF (XML: no element found: line ")
    assert capfd.readouterr() == ("", "")


def test_armlab_info_on_a_negative_mass_is_one_line_exit_2(tmp_path, capfd):
    path = write_urdf(tmp_path, mass1="-6")
    assert main(["info", str(path)]) == 2
    out, err = capfd.readouterr()
    assert out == ""
    assert err == f"armlab: error: {path}: link 'link1' has a negative mass (-6 kg)\n"


def test_the_published_arms_still_load(ur5, panda, teachbot6):
    assert (ur5.n_joints, panda.n_joints, teachbot6.n_joints) == (6, 7, 6)
    for robot in (ur5, panda, teachbot6):
        masses = [inertia.mass for inertia in robot.model.inertias[1:]]
        assert min(masses) >= 0 and robot.total_mass_kg > 5


# ----------------------------------------------------------------------------- drives.toml
DRIVES_NAMES = [f"joint{i}" for i in range(1, 7)]
DRIVE_CASES = [
    # pulses_per_rev = 0 was accepted: the set-point table's counts stayed 0 while q moved
    ("pulses_per_rev = 1000", "pulses_per_rev = 0", "encoder.pulses_per_rev: 0 is not > 0"),
    # a negative stall torque was accepted
    (
        "stall_torque_Nm = 0.1274",
        "stall_torque_Nm = -0.1274",
        "motor.stall_torque_Nm: -0.1274 is not > 0",
    ),
    (
        "pulses_per_rev = 1000",
        "pulses_per_rev = 1000.5",
        "encoder.pulses_per_rev: 1000.5 is not an integer",
    ),
    (
        "decoding = 4",
        "decoding = 3",
        "encoder.decoding: 3 is not one of 1, 2, 4 (x1, x2, x4 decoding)",
    ),
    ("ratio = 125", "ratio = 0", "reducer.ratio: 0 is not > 0"),
    ("ratio = 125", 'ratio = "125"', "reducer.ratio: '125' is not a number"),
    ("efficiency = 0.6", "efficiency = 1.2", "reducer.efficiency: 1.2 is not in (0, 1]"),
    ("rated_torque_Nm = 33", "rated_torque_Nm = -33", "reducer.rated_torque_Nm: -33 is not > 0"),
    (
        "max_input_speed_rpm = 3500",
        "max_input_speed_rpm = 0",
        "reducer.max_input_speed_rpm: 0 is not > 0",
    ),
    (
        "inertia_kg_m2 = 2e-06",
        "inertia_kg_m2 = -2e-06",
        "reducer.inertia_kg_m2: -2e-06 is not >= 0",
    ),
    ("resistance_ohm = 16.092", "resistance_ohm = 0", "motor.resistance_ohm: 0 is not > 0"),
    (
        "inductance_H = 0.016092",
        "inductance_H = inf",
        "motor.inductance_H: inf is not a finite number",
    ),
    (
        "torque_constant_Nm_A = 0.146437",
        "torque_constant_Nm_A = -0.1",
        "motor.torque_constant_Nm_A: -0.1 is not > 0",
    ),
    ("back_emf_V_s_rad = 0.146437", "back_emf_V_s_rad = 0", "motor.back_emf_V_s_rad: 0 is not > 0"),
    (
        "rated_speed_rpm = 1500",
        "rated_speed_rpm = -1500",
        "motor.rated_speed_rpm: -1500 is not > 0",
    ),
    (
        "rotor_inertia_kg_m2 = 2.66515e-05",
        "rotor_inertia_kg_m2 = -1e-05",
        "motor.rotor_inertia_kg_m2: -1e-05 is not >= 0",
    ),
    ("supply_voltage_V = 24.0", "supply_voltage_V = 0.0", "motor.supply_voltage_V: 0.0 is not > 0"),
    ("power_W = 12.18", "power_W = nan", "motor.power_W: nan is not a finite number"),
    ("current_A = 0.87", "current_A = true", "motor.current_A: True is not a number"),
    ("derating = 1.0", "derating = 0.0", "derating: 0.0 is not in (0, 1]"),
    ("derating = 1.0", "derating = nan", "derating: nan is not a finite number"),
    ("jerk_rad_s3 = 35", "jerk_rad_s3 = -35", "jerk_rad_s3: -35 is not > 0"),
    (
        "acceleration_rad_s2 = 3.5",
        "acceleration_rad_s2 = inf",
        "acceleration_rad_s2: inf is not a finite number",
    ),
    ("derating = 1.0", "deratng = 0.8", ": unknown key(s) ['deratng']"),
]


@pytest.mark.parametrize(("old", "new", "message"), DRIVE_CASES, ids=[c[1] for c in DRIVE_CASES])
def test_every_drive_value_is_checked_by_its_meaning(tmp_path, old, new, message):
    text = (DESC / "drives.toml").read_text()
    assert old in text
    path = tmp_path / "drives.toml"
    path.write_text(text.replace(old, new, 1))  # the first occurrence: joint1
    with pytest.raises(RobotDescriptionError) as err:
        read_drives(path, DRIVES_NAMES)
    sep = "" if message.startswith(":") else " "
    assert str(err.value) == f"{path} joint 'joint1'{sep}{message}"


def test_a_robot_with_a_zero_pulse_encoder_does_not_load(tmp_path, capfd):
    folder = tmp_path / "teachbot6"
    shutil.copytree(DESC, folder)
    drives = folder / "drives.toml"
    drives.write_text(drives.read_text().replace("pulses_per_rev = 1000", "pulses_per_rev = 0", 1))
    assert main(["info", str(folder)]) == 2
    assert capfd.readouterr().err == (
        f"armlab: error: {drives} joint 'joint1' encoder.pulses_per_rev: 0 is not > 0\n"
    )


def test_a_joint_listed_twice_in_drives_toml_is_refused(tmp_path):
    text = (DESC / "drives.toml").read_text()
    path = tmp_path / "drives.toml"
    path.write_text(text.replace('name = "joint6"', 'name = "joint5"'))
    with pytest.raises(RobotDescriptionError, match=r"joint 'joint5': listed twice$"):
        read_drives(path, DRIVES_NAMES)


def test_the_shipped_drives_and_catalogue_pass_the_checks():
    from armlab.robot.catalogue import load_catalogue

    drives = read_drives(DESC / "drives.toml", DRIVES_NAMES)
    assert [d.encoder.pulses_per_rev for d in drives.values()] == [1000] * 6
    cat = load_catalogue()
    assert all(m.stall_torque_Nm > 0 for m in cat.motors) and len(cat.reducers) > 0


# ----------------------------------------------------------------------------- trajectory.npz
@pytest.fixture
def trajectory_file(tmp_path) -> Path:
    from armlab.deploy import save_trajectory
    from armlab.trajectory import Trajectory

    t = np.linspace(0.0, 1.0, 101)
    q = np.outer(t, [0.1, -0.2, 0.3])
    traj = Trajectory(
        t, q, np.gradient(q, t, axis=0), np.zeros_like(q), joint_names=["a", "b", "c"]
    )
    return save_trajectory(tmp_path / "trajectory.npz", traj)


def test_a_truncated_trajectory_file_is_one_input_error(trajectory_file):
    from armlab.deploy import load_trajectory

    assert load_trajectory(trajectory_file).q.shape == (101, 3)
    data = trajectory_file.read_bytes()
    trajectory_file.write_bytes(data[: len(data) // 2])  # a copy cut short
    with pytest.raises(InputError) as err:
        load_trajectory(trajectory_file)
    assert str(err.value) == (
        f"{trajectory_file}: not a readable .npz, truncated or corrupt (BadZipFile: File is not "
        "a zip file)"
    )


def test_any_corruption_of_a_trajectory_file_is_an_input_error(trajectory_file, tmp_path):
    """Cut at every 97th byte and one byte flipped at every 89th: never a traceback."""
    from armlab.deploy import load_trajectory

    data = trajectory_file.read_bytes()
    cases = [data[:n] for n in range(0, len(data), 97)]
    cases += [data[:i] + bytes([data[i] ^ 0xFF]) + data[i + 1 :] for i in range(0, len(data), 89)]
    cases += [b"not a zip at all", b"PK\x03\x04" + b"\x00" * 40]
    bad = tmp_path / "bad.npz"
    refused = 0
    for content in cases:
        bad.write_bytes(content)
        try:
            load_trajectory(bad)  # a flip in zip metadata no reader checks may load
        except InputError as exc:
            assert "\n" not in str(exc)
            refused += 1
    assert refused >= 0.8 * len(cases)
