"""The name policy (armlab.names, issue 24 items 1 and 4): a name that reaches an output is
checked when it is read (URDF, drives file, controller profile, study file), and each writer
escapes for its own format. The C checks compile the export with gcc and compare the macros it
defines and the symbols it declares with the expected ones: no name may add a directive or a
declaration."""

from __future__ import annotations

import csv
import io
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from armlab.cli import main as cli_main
from armlab.control import ArmGains, CascadeGains, LoopGains
from armlab.control.gains import PlantSummary
from armlab.deploy.formats import c_comment, c_string
from armlab.deploy.gains_export import gains_to_c_files
from armlab.deploy.ros2 import ros2_controllers_yaml
from armlab.deploy.table import SetpointTable, read_setpoints
from armlab.errors import InputError, RobotDescriptionError, SpecError
from armlab.names import MAX_NAME_LENGTH, check_names, identifier_key, name_problem
from armlab.robot import load_robot
from armlab.robot.controller import ControllerProfile, load_profile
from armlab.robot.drives_file import read_drives
from armlab.study.spec import parse_study

GCC = shutil.which("gcc")
NM = shutil.which("nm")
CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror"]

#: the hostile names of issue 24 (items 1 and 4)
INJECTIONS = [
    "c*/\n#define ARMLAB_SP_MAX_PULSES_PER_CYCLE_X 1\n/*",
    "a*/ int injected_by_joint = 42; /*",
    "joint,1",
    "joint\n1",
    "joint\r1",
    "joint??/",
    "joint\U0001f600",
    "j" * 20_000,
]


# ---------------------------------------------------------------------- helpers
def _xml_attr(text: str) -> str:
    """``text`` as an XML attribute value (every non-ASCII or control character a reference)."""
    out = []
    for c in text:
        if c in '&<>"' or not (" " <= c <= "~"):
            out.append(f"&#{ord(c)};")
        else:
            out.append(c)
    return "".join(out)


def _urdf(joint_names: list[str], tool: str = "tool0") -> str:
    """A chain of revolute joints with the given names (a link of 1 kg after each)."""
    inertial = (
        '<inertial><mass value="1"/><origin xyz="0 0 0.1"/>'
        '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
    )
    parts = ['<robot name="arm">', '<link name="base_link"/>']
    parent = "base_link"
    for k, name in enumerate(joint_names):
        link = f"link{k + 1}"
        parts += [
            f'<link name="{link}">{inertial}</link>',
            f'<joint name="{_xml_attr(name)}" type="revolute"><parent link="{parent}"/>'
            f'<child link="{link}"/><origin xyz="0 0 0.2"/><axis xyz="0 0 1"/>'
            '<limit lower="-3" upper="3" effort="100" velocity="2"/></joint>',
        ]
        parent = link
    parts += [
        f'<link name="{_xml_attr(tool)}"/>',
        f'<joint name="tool_fixed" type="fixed"><parent link="{parent}"/>'
        f'<child link="{_xml_attr(tool)}"/><origin xyz="0 0 0.1"/></joint>',
        "</robot>",
    ]
    return "\n".join(parts)


def _write_urdf(folder: Path, joint_names: list[str], stem: str = "arm", **kw) -> Path:
    path = folder / f"{stem}.urdf"
    path.write_text(_urdf(joint_names, **kw))
    return path


def _refused_in_one_line(exc: pytest.ExceptionInfo, *fragments: str) -> None:
    msg = str(exc.value)
    assert "\n" not in msg and "\r" not in msg, msg
    assert len(msg) < 400, msg
    for f in fragments:
        assert f in msg, msg


def _table(robot: str, joints: list[str], profile: str) -> SetpointTable:
    n, m = 3, len(joints)
    counts = np.arange(n * m, dtype=np.int64).reshape(n, m)
    dcounts = np.zeros_like(counts)
    dcounts[1:] = np.diff(counts, axis=0)
    return SetpointTable(
        robot=robot,
        joint_names=list(joints),
        cycle_s=1e-3,
        cycle=np.arange(n, dtype=np.int64),
        t_s=np.arange(n) * 1e-3,
        q_rad=np.zeros((n, m)),
        qd_rad_s=np.zeros((n, m)),
        qdd_rad_s2=np.zeros((n, m)),
        counts=counts,
        dcounts=dcounts,
        counts_per_rad=np.full(m, 1000.0),
        axis_sign=np.ones(m, dtype=np.int64),
        meta={"profile": profile, "max_pulses_per_cycle": 4095, "trajectory_sha256": "0" * 64},
    )


def _gains(robot: str, joints: list[str]) -> ArmGains:
    inertia = {"min": 1e-5, "nominal": 2e-5, "max": 3e-5}
    cascades = {
        j: CascadeGains(
            joint=j,
            current=LoopGains("current", "PI", kp=5.0, ki=1e4, sample_time_s=5e-5),
            speed=LoopGains("speed", "PI", kp=0.1, ki=2.0, sample_time_s=1e-3),
            position=LoopGains(
                "position", "P", kp=40.0, sample_time_s=1e-3, output_min=-300, output_max=300
            ),
            plant=PlantSummary(
                ratio=100.0, inertia_motor_kg_m2=inertia, inertia_joint_kg_m2=inertia
            ),
        )
        for j in joints
    }
    return ArmGains(joints=cascades, robot=robot)


def _gcc(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([GCC, *CFLAGS, *args], cwd=cwd, capture_output=True, text=True)


def _macros(header: Path) -> dict[str, str]:
    """Macros the header defines beyond <stdint.h>: name -> value (``gcc -E -dM``)."""

    def defined(path: Path) -> dict[str, str]:
        out = subprocess.run(
            [GCC, "-std=c99", "-E", "-dM", str(path)], capture_output=True, text=True, check=True
        ).stdout
        pairs = (line.split(" ", 2)[1:] for line in out.splitlines() if line.startswith("#define"))
        return {p[0]: (p[1] if len(p) > 1 else "") for p in pairs}

    base = header.parent / "_base.h"
    base.write_text("#include <stdint.h>\n")
    known = defined(base)
    return {k: v for k, v in defined(header).items() if k not in known}


def _symbols(obj: Path) -> set[str]:
    out = subprocess.run(
        [NM, "-g", "--defined-only", str(obj)], capture_output=True, text=True, check=True
    ).stdout
    return {line.split()[-1] for line in out.splitlines() if line.strip()}


SETPOINT_MACROS = {
    "SETPOINTS_H",
    "ARMLAB_SP_FORMAT",
    "ARMLAB_SP_ROBOT",
    "ARMLAB_SP_PROFILE",
    "ARMLAB_SP_TRAJECTORY_SHA256",
    "ARMLAB_SP_ARMLAB_VERSION",
    "ARMLAB_SP_N_CYCLES",
    "ARMLAB_SP_N_AXES",
    "ARMLAB_SP_CYCLE_S",
    "ARMLAB_SP_CYCLE_US",
    "ARMLAB_SP_MAX_PULSES_PER_CYCLE",
    "ARMLAB_SP_FORCED",
}
SETPOINT_SYMBOLS = {
    "ARMLAB_SP_AXIS_JOINT",
    "ARMLAB_SP_AXIS_SIGN",
    "ARMLAB_SP_COUNTS_PER_JOINT_REV",
    "ARMLAB_SP_START_COUNTS",
    "ARMLAB_SP_COUNTS",
    "ARMLAB_SP_DCOUNTS",
}

_MAIN = r"""
#include <stdio.h>
#include <string.h>
#include "setpoints.h"
static void put(const char *s) { fwrite(s, 1, strlen(s), stdout); fputc(0, stdout); }
int main(void) {
    int a;
    put(ARMLAB_SP_ROBOT);
    put(ARMLAB_SP_PROFILE);
    for (a = 0; a < ARMLAB_SP_N_AXES; ++a) put(ARMLAB_SP_AXIS_JOINT[a]);
    printf("%d", (int)ARMLAB_SP_MAX_PULSES_PER_CYCLE);
    return 0;
}
"""


def _c_round_trip(table: SetpointTable, folder: Path) -> list[bytes]:
    """Compile the table's C files with a program printing its names; check that the header
    defines exactly the expected macros and the data file exactly the expected symbols; return
    the printed strings (robot, profile, joints) and the pulse limit."""
    folder.mkdir(parents=True, exist_ok=True)
    for path, data in table.files(folder / "setpoints.h", "c"):
        path.write_bytes(data)
    (folder / "main.c").write_text(_MAIN)
    macros = _macros(folder / "setpoints.h")
    assert set(macros) == SETPOINT_MACROS
    assert macros["ARMLAB_SP_MAX_PULSES_PER_CYCLE"] == "4095"
    done = _gcc(["-c", "setpoints.c", "-o", "setpoints.o"], folder)
    assert done.returncode == 0, done.stderr
    assert _symbols(folder / "setpoints.o") == SETPOINT_SYMBOLS
    done = _gcc(["main.c", "setpoints.o", "-o", "main"], folder)
    assert done.returncode == 0, done.stderr
    out = subprocess.run([str(folder / "main")], capture_output=True, check=True).stdout
    return out.split(b"\0")


# ---------------------------------------------------------------------- refused at load
@pytest.mark.parametrize("name", INJECTIONS, ids=lambda s: repr(s[:12]))
def test_hostile_joint_name_is_refused_at_load_in_one_line(tmp_path, name):
    urdf = _write_urdf(tmp_path, ["joint1", name])
    with pytest.raises(RobotDescriptionError) as exc:
        load_robot(urdf)
    _refused_in_one_line(exc, str(urdf), "joint name", repr(name[:40]))


@pytest.mark.parametrize("name", INJECTIONS, ids=lambda s: repr(s[:12]))
def test_hostile_name_in_drives_file_profile_and_study_is_refused(tmp_path, name):
    drives = tmp_path / "drives.toml"
    drives.write_text(f"[[joint]]\nname = {json.dumps(name, ensure_ascii=False)}\n")
    with pytest.raises(RobotDescriptionError) as exc:
        read_drives(drives, ["joint1", name])
    _refused_in_one_line(exc, str(drives), "joint name")

    profile = tmp_path / "hostile.toml"
    profile.write_text(
        f"name = {json.dumps(name, ensure_ascii=False)}\ncycle_s = 0.001\n"
        "max_pulses_per_cycle = 4095\n"
    )
    with pytest.raises(InputError) as exc:
        load_profile(profile)
    _refused_in_one_line(exc, "controller profile: name")

    doc = {"robot": {"name": "teachbot6"}, "waypoints": {"joint": [[0.0] * 6, [0.1] * 6]}}
    with pytest.raises(SpecError) as exc:
        parse_study({**doc, "drives": {name: {"ratio": 100.0}}})
    _refused_in_one_line(exc, "drives", "joint name")


@pytest.mark.parametrize("name", INJECTIONS, ids=lambda s: repr(s[:12]))
def test_hostile_robot_and_tool_names_are_refused(tmp_path, name):
    with pytest.raises(RobotDescriptionError) as exc:  # named as the tool
        load_robot(_write_urdf(tmp_path, ["joint1"], tool=name), tool_frame=name)
    _refused_in_one_line(exc, "tool frame name")
    with pytest.raises(RobotDescriptionError) as exc:  # the default rule picks it (issue 25)
        load_robot(_write_urdf(tmp_path, ["joint1"], tool=name + "tool"))
    _refused_in_one_line(exc, "tool frame name")
    if "/" not in name and len(name) < 200:  # a file name can hold it
        with pytest.raises(RobotDescriptionError) as exc:
            load_robot(_write_urdf(tmp_path, ["joint1"], stem=name))
        _refused_in_one_line(exc, "robot name")


def test_the_issue_urdf_is_refused_by_the_command_line(tmp_path, capsys):
    """Issue 24 item 1: the injection joint in a URDF and its drives.toml; ``armlab info`` (and
    so ``run`` and ``export``, which load the robot the same way) stops with one line, exit 2."""
    folder = tmp_path / "arm"
    folder.mkdir()
    _write_urdf(folder, ["joint1", INJECTIONS[0]])
    (folder / "drives.toml").write_text(f"[[joint]]\nname = {json.dumps(INJECTIONS[0])}\n")
    assert cli_main(["info", str(folder / "arm.urdf")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "joint name 'c*/\\n#define" in err


def test_study_title_is_printable_text_on_one_line():
    doc = {"robot": {"name": "teachbot6"}, "waypoints": {"joint": [[0.0] * 6, [0.1] * 6]}}
    ok = "UR5 pick and place, drives selected from the catalogue (ü, 5 kg)"
    assert parse_study({**doc, "study": {"name": ok}}).study.name == ok
    for bad in ("two\nlines", "cr\rhere", "x" * 201, "bidi\u202eoverride", ""):
        with pytest.raises(SpecError) as exc:
            parse_study({**doc, "study": {"name": bad}})
        _refused_in_one_line(exc, "study.name")


def test_joints_equal_in_c_are_refused(tmp_path):
    for pair in (["wrist-1", "wrist_1"], ["Joint1", "joint1"], ["a.b", "a_b"]):
        with pytest.raises(RobotDescriptionError) as exc:
            load_robot(_write_urdf(tmp_path, pair))
        _refused_in_one_line(exc, "joint name", repr(pair[1]), identifier_key(pair[1]))


def test_published_arm_names_keep_the_policy():
    """The names of the arms armlab ships or tests with load: UR5, Panda, teachbot6, and names
    with dashes and dots (a link or joint of another vendor)."""
    assert load_robot("erd:ur_description/urdf/ur5_robot.urdf").joint_names[0] == (
        "shoulder_pan_joint"
    )
    assert "panda_joint1" in load_robot("erd:panda_description/urdf/panda.urdf").joint_names
    assert load_robot("teachbot6").joint_names == [f"joint{i}" for i in range(1, 7)]
    assert check_names(["arm-1.joint_a", "_x", "J" * MAX_NAME_LENGTH], "joint name", "t") == [
        "arm-1.joint_a",
        "_x",
        "J" * MAX_NAME_LENGTH,
    ]


# ---------------------------------------------------------------------- writers' own defence
@pytest.mark.skipif(GCC is None or NM is None, reason="gcc/nm not installed")
def test_c_writers_escape_names_that_bypass_the_readers(tmp_path):
    """A table or gains object built in code (not read) with the hostile names: the C files
    compile under -Werror and hold no extra directive or declaration."""
    table = _table(INJECTIONS[0], INJECTIONS[:2] + INJECTIONS[4:6], INJECTIONS[1])
    printed = _c_round_trip(table, tmp_path / "sp")
    assert printed[:-1] == [s.encode() for s in [INJECTIONS[0], INJECTIONS[1], *table.joint_names]]
    header, data = gains_to_c_files(_gains(INJECTIONS[1], INJECTIONS[:2] + INJECTIONS[4:6]))
    (tmp_path / "gains.h").write_text(header)
    (tmp_path / "gains.c").write_text(data)
    done = _gcc(["-c", "gains.c", "-o", "gains.o"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert not any("inject" in s for s in _symbols(tmp_path / "gains.o"))
    assert not any("_X" in m for m in _macros(tmp_path / "gains.h"))


def test_yaml_and_csv_writers_escape_names_that_bypass_the_readers():
    joints = ["joint\n1", "j,2", "j\U0001f600", "true", "x: {a: 1}"]
    doc = yaml.safe_load(ros2_controllers_yaml(_gains("robot\nname: evil", joints)))
    assert set(doc) == {"controller_manager", "joint_trajectory_controller"}
    assert doc["joint_trajectory_controller"]["ros__parameters"]["joints"] == joints
    with pytest.raises(InputError, match="CSV column"):
        _table("r", ["j,2"], "p").render("csv")
    text = _table("robot\n1,2", ["a", "b"], "p\rq").render("csv").decode()
    assert all(line.startswith("#") for line in text.splitlines()[:10])
    assert c_comment("a*/b/*c??/") == "a* /b/ *c? ?/"
    assert c_string('a"\\?\n\U0001f600') == r'"a\"\\\?\012\360\237\230\200"'


# ---------------------------------------------------------------------- property test
_HOSTILE = ",;\"'`\\/*?#:{}[]&!|>%@ \t\n\r\x00\x0b\x85\u2028\u202e\U0001f600é-."
names = st.one_of(
    st.from_regex(r"[A-Za-z_][A-Za-z0-9_.-]{0,70}", fullmatch=True),  # the policy's alphabet
    st.text(min_size=1, max_size=20),  # any unicode: control characters, emoji, separators
    st.text(alphabet=st.sampled_from(_HOSTILE + "abcXYZ019_"), min_size=1, max_size=20),
)


@pytest.mark.skipif(GCC is None or NM is None, reason="gcc/nm not installed")
@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(name=names)
def test_every_name_is_refused_at_load_or_round_trips_every_format(tmp_path_factory, name):
    folder = tmp_path_factory.mktemp("name")
    ok = name_problem(name) is None
    event("accepted" if ok else "refused")
    urdf_name = name if ok else "joint1"
    stem = name if ok else "arm"
    if not ok:
        with pytest.raises(RobotDescriptionError) as exc:
            load_robot(_write_urdf(folder, ["base_joint", name]))
        _refused_in_one_line(exc, "arm.urdf")
        with pytest.raises(InputError):
            ControllerProfile(name=name)
        return
    robot = load_robot(_write_urdf(folder, ["base_joint", urdf_name], stem=stem))
    profile = ControllerProfile(name=name)
    assert robot.name == name and robot.joint_names == ["base_joint", name]
    table = _table(robot.name, robot.joint_names, profile.name)
    # C: gcc -Werror, no extra macro or symbol, the strings read back byte for byte
    printed = _c_round_trip(table, folder / "c")
    assert printed[:-1] == [s.encode() for s in [name, name, "base_joint", name]]
    # C gains: compiles, no extra symbol, the joint names read back
    header, data = gains_to_c_files(_gains(robot.name, robot.joint_names))
    (folder / "c" / "gains.h").write_text(header)
    (folder / "c" / "gains.c").write_text(data)
    done = _gcc(["-c", "gains.c", "-o", "gains.o"], folder / "c")
    assert done.returncode == 0, done.stderr
    assert all(s.startswith("ARMLAB_GAINS") for s in _symbols(folder / "c" / "gains.o"))
    # JSON: the names read back exactly
    meta = json.loads(table.render("json"))["meta"]
    assert meta["joints"] == robot.joint_names and meta["robot"] == name
    # YAML: the joint is a key and a list item, read back exactly
    params = yaml.safe_load(ros2_controllers_yaml(_gains(robot.name, robot.joint_names)))
    jtc = params["joint_trajectory_controller"]["ros__parameters"]
    assert jtc["joints"] == robot.joint_names and list(jtc["gains"]) == robot.joint_names
    # CSV: the header row parses (csv module) to the columns; the table reads back
    text = table.render("csv").decode()
    header = next(csv.reader(io.StringIO(text.split("\n")[-len(table.t_s) - 2])))
    assert header == table.column_names()
    assert re.search(rf"^# robot: {re.escape(name)}$", text, re.M)
    path = folder / "sp.csv"
    table.write(path)
    assert read_setpoints(path).joint_names == robot.joint_names
