"""Issue 13: any arm, the whole chain -- from a bare URDF to gains and set-points.

The shipped example studies (``examples/``) on the UR5 and the Panda of example-robot-data run
every stage with drives selected from the catalogue; the drives file ``armlab drives`` writes
reads back to the same drives and the same sizing; bad input gives one-line errors naming the
key; limits a plain URDF lacks are derived from the drive train (closed form on a 1-joint arm).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from armlab.cli import info_text, main
from armlab.dynamics import size
from armlab.dynamics.selection import select_drives
from armlab.errors import ArmlabError, InfeasibleError, RobotDescriptionError
from armlab.robot import load_profile, load_robot
from armlab.robot.catalogue import load_catalogue
from armlab.robot.drives_file import drives_toml, read_drives
from armlab.study.build import build_robot
from armlab.study.drive_stages import selection_duty
from armlab.study.runner import run_spec
from armlab.study.spec import load_study, parse_study

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
UR5 = "erd:ur_description/urdf/ur5_robot.urdf"
#: shorter runs for the tests: no report, 2 inertia samples per joint in the tuning
FAST = {"study.report": False, "control.n_inertia_samples": 2}


@pytest.fixture(scope="module")
def ur5_fast(tmp_path_factory) -> Path:
    """The UR5 example with 2 inertia samples (FAST) as a study file, for `armlab drives`: the
    selection tunes its candidates with the study's own [control] (drive_choice)."""
    text = (EXAMPLES / "ur5_study.toml").read_text()
    assert "n_inertia_samples = 8" in text
    path = tmp_path_factory.mktemp("ur5") / "ur5_fast.toml"
    path.write_text(text.replace("n_inertia_samples = 8", "n_inertia_samples = 2"))
    return path


@pytest.fixture(scope="module")
def ur5_run(ur5_fast):
    return run_spec(load_study(ur5_fast, {"study.report": False}))


@pytest.fixture(scope="module")
def panda_run():
    return run_spec(load_study(EXAMPLES / "panda_study.toml", FAST))


def _assert_whole_chain(result, n_joints: int) -> None:
    stages = result.summary["study"]["stages"]
    for stage in ("kinematics", "plan", "static_load", "sizing", "tuning", "tracking", "export"):
        assert stages[stage]["status"] == "ok", (stage, result.summary.get(stage))
    # a verdict, not a status: pass, or fail with the checks that failed
    assert result.verdict in ("pass", "fail")
    assert (result.verdict == "fail") == bool(result.failed_checks)
    ctx = result.context
    assert result.summary["robot"]["drives_from"] == "catalogue selection (sizing stage)"
    assert set(ctx.robot.drives) == set(ctx.robot.joint_names) and ctx.robot.n_joints == n_joints
    # every selected drive passes its own checks on the duty cycle it was selected for
    assert result.summary["sizing"]["verdict"] == "pass"
    assert ctx.sizing.ok
    for js in ctx.selection.joints:
        assert js.chosen is not None and js.chosen.ok
        assert js.chosen.binding.name in {c.name for c in js.chosen.checks}
        assert js.runner_up is not None and js.runner_up.ok
        assert (js.chosen.mass_kg, js.chosen.price) <= (js.runner_up.mass_kg, js.runner_up.price)
        drive = ctx.robot.drives[js.joint]
        assert drive.motor == js.chosen.motor and drive.reducer == js.chosen.reducer
    assert ctx.gains is not None and ctx.setpoints is not None
    assert ctx.setpoints.n_cycles == result.summary["export"]["n_cycles"] > 0
    assert "encoder 1000 pulses/rev x4" in ctx.selection.assumptions[0]


def test_ur5_from_a_bare_urdf_reaches_every_stage(ur5_run):
    _assert_whole_chain(ur5_run, 6)
    # the velocity limits now include the selected motors' speed / ratio
    sources = ur5_run.summary["robot"]["limits"]["sources"]["velocity"]
    assert any("ratio" in s for s in sources.values())


def test_panda_with_locked_fingers_reaches_every_stage(panda_run):
    _assert_whole_chain(panda_run, 7)
    assert panda_run.context.controller.name == "dda_n_axis"
    assert panda_run.context.robot.tool_frame == "panda_hand"


def test_drives_file_reproduces_the_selection_and_its_sizing(ur5_run, ur5_fast, tmp_path):
    """``armlab drives`` writes the run's selection; read back, the same drives size the same
    duty cycle to exactly the same numbers -- and to the selection's own (vectorised) checks."""
    ctx = ur5_run.context
    out = tmp_path / "drives.toml"
    study = str(ur5_fast)
    assert main(["drives", UR5, study, "--out", str(out)]) == 0
    back = read_drives(out, ctx.robot.joint_names)
    assert back == ctx.robot.drives  # every number exactly (dataclass equality)
    assert drives_toml(back) == drives_toml(ctx.robot.drives)
    robot = ctx.robot.copy()
    robot.drives = back
    duty = selection_duty(ctx)
    again = size(robot, duty, dt=ctx.spec.plan.check_dt_s, controller=ctx.controller)
    for j, (a, b) in enumerate(zip(again.joints, ctx.sizing.joints, strict=True)):
        assert [c.to_dict() for c in a.checks] == [c.to_dict() for c in b.checks]
        chosen = ctx.selection.joints[j].chosen
        assert [(c.name, c.ok) for c in a.checks] == [(c.name, c.ok) for c in chosen.checks]
        np.testing.assert_allclose(
            [c.value for c in a.checks], [c.value for c in chosen.checks], rtol=1e-12
        )
    # an existing file is not replaced without --overwrite
    assert main(["drives", UR5, study, "--out", str(out)]) == 2


def test_no_catalogue_entry_passes_names_the_joint_and_the_check(ur5_run, tmp_path):
    """A catalogue of one small motor and one small reducer: the error names the first joint
    and the check every candidate fails."""
    tiny = tmp_path / "tiny.toml"
    tiny.write_text(
        """
[[motor]]
model = "tiny"
stall_torque_Nm = 0.01
rated_speed_rpm = 5000
current_A = 1.0
torque_constant_Nm_A = 0.01
back_emf_V_s_rad = 0.01
resistance_ohm = 1.0
inductance_H = 0.0001
rotor_inertia_kg_m2 = 1e-7
mass_kg = 0.05
price = 10

[[reducer]]
model = "tiny 50:1"
ratio = 50
efficiency = 0.8
rated_torque_Nm = 1.0
peak_torque_Nm = 2.0
max_input_speed_rpm = 8000
mass_kg = 0.05
price = 10
"""
    )
    ctx = ur5_run.context
    robot = ctx.robot.copy()
    robot.drives = None
    sel = select_drives(robot, selection_duty(ctx), catalogue=tiny, controller="reference_dda")
    first = sel.joints[0]
    assert not first.ok and "thesis_rule" in first.failed_by_all
    with pytest.raises(InfeasibleError, match=r"no catalogue entry passes for shoulder_pan_joint"):
        sel.require()
    with pytest.raises(InfeasibleError, match=r"all 1 motor \+ reducer pairs fail .*thesis_rule"):
        sel.drives(robot)
    # the study stops at the sizing stage with the same line; `armlab drives` writes nothing
    study = _study(tmp_path, f'catalogue = "{tiny}"')
    with pytest.raises(InfeasibleError, match=r"^sizing: drive selection: no catalogue entry"):
        run_spec(load_study(study, FAST))
    out = tmp_path / "drives.toml"
    assert main(["drives", UR5, str(study), "--out", str(out)]) == 2 and not out.exists()


# ---------------------------------------------------------------- bad input
def _study(tmp_path: Path, extra: str = "", robot: str = UR5) -> Path:
    path = tmp_path / "study.toml"
    path.write_text(
        f"""
[robot]
name = "{robot}"
[limits]
acceleration_rad_s2 = 3.0
jerk_rad_s3 = 30.0
[waypoints]
joint = [[0, -90, 90, -90, -90, 0], [10, -80, 80, -90, -90, 0]]
[sizing]
select = true
{extra}
"""
    )
    return path


def _one_line_error(args, capsys, needle: str, out: Path) -> None:
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert needle in err, err
    assert not out.exists()  # nothing written


def test_unknown_catalogue_name_is_one_line_naming_the_key(tmp_path, capsys, ur5):
    """``[drives.<joint>]`` catalogue names for a robot without a drive train."""
    tables = []
    for name in ur5.joint_names:
        motor = "maxon EC 90 flat 260 W" if name == "elbow_joint" else "maxon EC 90 flat 260 W 48 V"
        tables.append(
            f'[drives.{name}]\nmotor = "{motor}"\n'
            'reducer = "Harmonic Drive CSG-32-100-2A"\npulses_per_rev = 1000\n'
        )
    out = tmp_path / "out.toml"
    study = _study(tmp_path, "\n".join(tables))
    needle = "drives.elbow_joint.motor: no motor 'maxon EC 90 flat 260 W' in the catalogue"
    _one_line_error(["drives", UR5, str(study), "--out", str(out)], capsys, needle, out)
    # named correctly, the same tables build the drive train
    robot = build_robot(load_study(study, {"drives.elbow_joint.motor": "maxon EC-i 52 180 W 48 V"}))
    assert robot.drives["elbow_joint"].motor.model == "maxon EC-i 52 180 W 48 V"
    assert robot.drives["wrist_3_joint"].encoder.pulses_per_rev == 1000


_CATALOGUE_JOINT = """motor = "maxon EC 90 flat 260 W 48 V"
reducer = "Harmonic Drive CSG-32-100-2A"
[joint.encoder]
pulses_per_rev = 1000
"""


def _motor_table(**changes) -> str:
    """The catalogue's EC 90 flat as a ``[joint.motor]`` table, with ``changes``
    (None: the key left out)."""
    motor = vars(load_catalogue().motor("maxon EC 90 flat 260 W 48 V"))
    motor = {**motor, **changes}
    lines = ["[joint.motor]"]
    for k, v in motor.items():
        if v is None or (isinstance(v, float) and math.isnan(v)):
            continue
        if isinstance(v, tuple):  # e.g. `estimated`: a TOML list of literal strings
            v = list(v)
        lines.append(f'{k} = "{v}"' if isinstance(v, str) else f"{k} = {v!r}")
    return "\n".join(lines) + "\n"


def _drives_file(tmp_path: Path, names, first: str, first_name: str = "") -> Path:
    """A drives file: the first joint's body is ``first``, the others name catalogue parts."""
    blocks = []
    for k, name in enumerate(names):
        body = first if k == 0 else _CATALOGUE_JOINT
        blocks.append(f'[[joint]]\nname = "{(first_name or name) if k == 0 else name}"\n{body}')
    path = tmp_path / "drives.toml"
    path.write_text("version = 1\n" + "\n".join(blocks))
    return path


def test_drives_file_errors_name_the_key(tmp_path, capsys, ur5):
    out = tmp_path / "out.toml"
    names = ur5.joint_names
    reducer = 'reducer = "Harmonic Drive CSG-32-100-2A"\n'
    encoder = "[joint.encoder]\npulses_per_rev = 1000\n"
    cases = [
        (_CATALOGUE_JOINT, "nosuch_joint", "joint 'nosuch_joint': no such joint in the robot"),
        (
            reducer + _motor_table(stall_torque_Nm=None) + encoder,
            "",
            "joint 'shoulder_pan_joint' motor: missing field(s) ['stall_torque_Nm']",
        ),
        (
            reducer + _motor_table(stall_torque_Nm=-0.953) + encoder,
            "",
            "joint 'shoulder_pan_joint' motor.stall_torque_Nm: -0.953 is not > 0",
        ),
        (
            _CATALOGUE_JOINT.replace("260 W 48 V", "260 W"),
            "",
            "joint 'shoulder_pan_joint' motor: no motor 'maxon EC 90 flat 260 W' in the catalogue",
        ),
    ]
    for first, first_name, needle in cases:
        drives = _drives_file(tmp_path, names, first, first_name)
        with pytest.raises(RobotDescriptionError) as info:
            read_drives(drives, names)
        assert needle in str(info.value) and "\n" not in str(info.value)
        # the study key [robot] drives reads it the same way: one line, nothing written
        study = _study(tmp_path)
        text = study.read_text().replace("[limits]", f'drives = "{drives.name}"\n[limits]', 1)
        study.write_text(text)
        _one_line_error(["drives", UR5, str(study), "--out", str(out)], capsys, needle, out)
    # the same drives file without errors reads, acceleration and jerk left to the limits
    good = read_drives(_drives_file(tmp_path, names, _CATALOGUE_JOINT), names)
    assert all(math.isnan(d.acceleration_rad_s2) for d in good.values())


def test_study_drives_for_a_joint_the_urdf_lacks(tmp_path):
    study = _study(tmp_path, '[drives.nosuch_joint]\nmotor = "maxon EC 90 flat 260 W 48 V"')
    spec = load_study(study)
    with pytest.raises(ArmlabError, match=r"^drives\.nosuch_joint: no joint 'nosuch_joint'"):
        build_robot(spec)
    # without select = true, a robot without drives still needs every joint's table
    spec = load_study(study, {"sizing.select": False, "drives.shoulder_pan_joint.ratio": 100})
    with pytest.raises(ArmlabError, match=r"^drives\.nosuch_joint: no joint"):
        build_robot(spec)


def test_select_false_without_drives_says_how_to_give_them(tmp_path):
    spec = load_study(_study(tmp_path), {"sizing.select": False, **FAST})
    res = run_spec(spec)
    reason = res.summary["sizing"]["reason"]
    assert "[robot] drives" in reason and "[sizing] select = true" in reason
    assert res.verdict == "incomplete"


# ---------------------------------------------------------------- derived limits
_ONE_JOINT = """<robot name="turntable">
  <link name="base"/>
  <link name="table">
    <inertial><origin xyz="0.3 0 0"/><mass value="2.0"/>
      <inertia ixx="0.03" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.05"/></inertial>
  </link>
  <joint name="spin" type="revolute">
    <parent link="base"/><child link="table"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="2" effort="100"/>
  </joint>
</robot>
"""


def test_acceleration_and_jerk_derived_from_the_drive_train(tmp_path):
    """A vertical-axis turntable: no gravity torque, constant link inertia
    ``M = I_zz + m r^2``; ``a = T_peak / (J_r + M)`` and ``j = Kt U / L N eta / (J_r + M)``."""
    (tmp_path / "turntable.urdf").write_text(_ONE_JOINT)
    (tmp_path / "drives.toml").write_text(
        """
[[joint]]
name = "spin"
motor = "maxon EC 90 flat 260 W 48 V"
reducer = "Harmonic Drive CSG-32-100-2A"
[joint.encoder]
pulses_per_rev = 1000
"""
    )
    robot = load_robot(tmp_path / "turntable.urdf")
    m = load_catalogue().motor("maxon EC 90 flat 260 W 48 V")
    r = load_catalogue().reducer("Harmonic Drive CSG-32-100-2A")
    link = 0.05 + 2.0 * 0.3**2
    total = (m.rotor_inertia_kg_m2 + r.inertia_kg_m2) * r.ratio**2 + link
    # the data sheet gives no peak motor torque: the continuous one stands in (docs/drives.md)
    t_motor = m.peak_torque_Nm if math.isfinite(m.peak_torque_Nm) else m.stall_torque_Nm
    peak = min(t_motor * r.ratio * r.efficiency, r.peak_torque_Nm)
    lim = robot.limits
    assert lim.acceleration_rad_s2[0] == pytest.approx(peak / total, rel=1e-9)
    slew = m.torque_constant_Nm_A * m.supply_voltage_V / m.inductance_H
    assert lim.jerk_rad_s3[0] == pytest.approx(slew * r.ratio * r.efficiency / total, rel=1e-9)
    assert lim.sources["acceleration"][0].startswith("derived from the drive train")
    # a study value replaces the derived one (and may be above it: nothing to tighten)
    spec = parse_study(
        {
            "robot": {"name": str(tmp_path / "turntable.urdf")},
            "limits": {"acceleration_rad_s2": 1.0},
            "waypoints": {"joint": [[0], [10]]},
        }
    )
    built = build_robot(spec)
    assert built.limits.acceleration_rad_s2[0] == 1.0
    assert built.limits.sources["jerk"][0].startswith("derived from the drive train")
    assert built.drives["spin"].acceleration_rad_s2 == 1.0  # the file left it out
    # info shows the derived source
    assert "derived from the drive train" in info_text(str(tmp_path / "turntable.urdf"))


def test_plain_urdf_without_acceleration_names_the_study_key(tmp_path):
    study = _study(tmp_path)
    study.write_text(study.read_text().replace("acceleration_rad_s2 = 3.0", ""))
    with pytest.raises(ArmlabError, match=r"\[limits\] acceleration_rad_s2"):
        run_spec(load_study(study, FAST))


# ---------------------------------------------------------------- info and profiles
def test_info_prismatic_in_metres_and_long_names_aligned():
    text = info_text("erd:panda_description/urdf/panda.urdf", tool_frame="panda_hand")
    rows = [line for line in text.splitlines() if line.startswith("panda_")]
    assert len(rows) == 9
    assert any("0 .. 0.04 m" in r and " P " in r for r in rows)
    # the type column starts at the same place on every row, after the longest name
    assert len({r.index(" R ") if " R " in r else r.index(" P ") for r in rows}) == 1
    locked = info_text(
        "erd:panda_description/urdf/panda.urdf",
        lock_joints=["panda_finger_joint1", "panda_finger_joint2"],
    )
    assert "panda_finger_joint1" not in locked and "joints     7" in locked


def test_generic_n_axis_profile_drives_seven_axes(panda_run):
    robot = panda_run.context.robot
    index, sign = load_profile("dda_n_axis").axes(robot)
    assert len(index) == 7 and np.all(sign == 1)
    with pytest.raises(ArmlabError, match="dda_n_axis"):
        load_profile("reference_dda").axes(robot)
