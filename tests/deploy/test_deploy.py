"""armlab.deploy: controller profiles, set-point tables, pre-flight checks, file formats, export.

Reference values: the DDA card of the SHU controller paper (§1: 1 ms .. 2 s period, 4095 pulses
per axis per period, x2/x4 decoding, 12-bit +-10 V D/A) and teachbot6's drives (1000-line
encoders, x4, reducer ratios of HEU thesis table 4.3).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import armlab
from armlab.cli import main as cli_main
from armlab.deploy import load_trajectory, read_setpoints, save_trajectory, setpoint_table
from armlab.deploy.checks import CHECKS
from armlab.deploy.formats import c_int_type
from armlab.deploy.numtext import format_list, format_rows
from armlab.deploy.provenance import file_sha256, trajectory_sha256
from armlab.errors import InputError, LimitViolation
from armlab.robot import ControllerProfile, list_profiles, load_profile
from armlab.study import export_study
from armlab.trajectory import Trajectory
from cases import cosine_motion
from conftest import make_study_folder

RATIOS = (125, 410, 385, 80, 298, 128)  # thesis table 4.3


# ---------------------------------------------------------------------- trajectories
def one_joint_bump(robot, joint, peak_speed, omega=2.0, n=2001):
    """Joint ``joint`` moves ``A (1 - cos(w t))`` over one half period with peak speed
    ``peak_speed``; other joints rest at 0."""
    j = robot.joint_index(joint)
    A = peak_speed / omega
    T = math.pi / omega
    t = np.linspace(0.0, T, n)
    q = np.zeros((n, robot.n_joints))
    qd, qdd = np.zeros_like(q), np.zeros_like(q)
    q[:, j] = A * (1 - np.cos(omega * t))
    qd[:, j] = A * omega * np.sin(omega * t)
    qdd[:, j] = A * omega**2 * np.cos(omega * t)
    return Trajectory(t, q, qd, qdd, joint_names=robot.joint_names, method="bump")


def trapezoid_move(robot, joint, v, a, cruise_s, dt=1e-3):
    """Trapezoidal velocity profile on one joint (accelerate with a, cruise at v, decelerate)."""
    j = robot.joint_index(joint)
    ta = v / a
    T = 2 * ta + cruise_s
    t = np.arange(0.0, T + dt / 2, dt)
    t[-1] = T
    acc = np.where(t < ta, a, np.where(t > ta + cruise_s, -a, 0.0))
    vel = np.where(t < ta, a * t, np.where(t > ta + cruise_s, v - a * (t - ta - cruise_s), v))
    pos = np.where(
        t < ta,
        0.5 * a * t**2,
        np.where(
            t > ta + cruise_s,
            0.5 * a * ta**2
            + v * cruise_s
            + v * (t - ta - cruise_s)
            - 0.5 * a * (t - ta - cruise_s) ** 2,
            0.5 * a * ta**2 + v * (t - ta),
        ),
    )
    q = np.zeros((t.size, robot.n_joints))
    qd, qdd = np.zeros_like(q), np.zeros_like(q)
    q[:, j], qd[:, j], qdd[:, j] = pos, vel, acc
    return Trajectory(t, q, qd, qdd, joint_names=robot.joint_names, method="trapezoid")


@pytest.fixture(scope="module")
def motion60(teachbot6):
    return cosine_motion(teachbot6)


@pytest.fixture(scope="module")
def table60(teachbot6, motion60):
    return setpoint_table(teachbot6, motion60, controller="reference_dda")


def write_profile(path: Path, **fields) -> Path:
    base = load_profile().to_dict()
    base.update(fields)
    lines = []
    for k, v in base.items():
        if v is None:
            continue
        lines.append(f"{k} = {json.dumps(v)}")
    path.write_text("\n".join(lines) + "\n")
    return path


# ---------------------------------------------------------------------- profiles
def test_reference_profile_is_the_shu_controller_card():
    p = load_profile()
    assert p.name == "reference_dda"
    assert p.cycle_s == 1e-3 and p.cycle_range_s == (1e-3, 2.0)
    assert p.max_pulses_per_cycle == 4095
    assert p.decoding == 4 and p.servo_period_s == 1e-3 and p.max_axes == 6
    assert p.dac_bits == 12 and p.dac_range_V == 10.0
    assert p.dac_volts_per_lsb == pytest.approx(20.0 / 4096)
    assert {"reference_dda", "reference_dda_10ms", "generic_1khz", "ethercat_cia402_csp"} <= set(
        list_profiles()
    )
    assert load_profile("reference_dda_10ms").cycle_s == 0.01
    ec = load_profile("ethercat_cia402_csp")
    assert ec.max_pulses_per_cycle is None and ec.decoding is None and ec.cycle_s == 1e-3
    assert ec.home_position_rad == (0.0,) * 6 and ec.modulo_axes == ()


def test_profile_errors(tmp_path):
    with pytest.raises(InputError, match="unknown controller profile 'nope'"):
        load_profile("nope")
    p = load_profile()
    with pytest.raises(InputError, match="outside the controller's range"):
        p.with_cycle(2.5)
    with pytest.raises(InputError, match="outside the controller's range"):
        p.with_cycle(0.0005)
    assert p.with_cycle(2.0).cycle_s == 2.0
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\ncycle_s = 0.001\nwobble = 3\n')
    with pytest.raises(InputError, match="unknown key"):
        load_profile(bad)
    with pytest.raises(InputError, match="axis_sign"):
        ControllerProfile(name="x", axis_sign=(1, 2))
    with pytest.raises(InputError, match="decoding"):
        ControllerProfile(name="x", decoding=3)
    with pytest.raises(InputError, match="home_position_rad must be finite"):
        ControllerProfile(name="x", home_position_rad=(0.0, math.inf))
    with pytest.raises(InputError, match="modulo_axes repeats"):
        ControllerProfile(name="x", modulo_axes=("joint6", "joint6"))


def test_counts_per_rev_from_drives_and_profile_decoding(teachbot6):
    """counts per joint rev = 1000 pulses x 4 x ratio (thesis table 4.3); x2 halves them."""
    tr = one_joint_bump(teachbot6, "joint1", 0.3)
    t4 = setpoint_table(teachbot6, tr, controller="reference_dda")
    np.testing.assert_allclose(t4.counts_per_joint_rev, [4000.0 * r for r in RATIOS])
    np.testing.assert_allclose(
        t4.counts_per_rad, [teachbot6.drives[j].counts_per_rad() for j in teachbot6.joint_names]
    )
    t2 = setpoint_table(teachbot6, tr, load_profile().replace(decoding=2))
    np.testing.assert_allclose(t2.counts_per_joint_rev, [2000.0 * r for r in RATIOS])


# ---------------------------------------------------------------------- round trip
def test_round_trip_60s_1ms_six_joints(teachbot6, motion60, table60, tmp_path):
    """Integrating dcounts reproduces counts exactly, and counts the planned positions to within
    one count, for 60 s at 1 ms on all six joints (read back from CSV)."""
    assert table60.n_cycles == 60001 and table60.n_axes == 6
    path = table60.write(tmp_path / "setpoints.csv")
    back = read_setpoints(path)
    counts0 = back.counts[0]
    integrated = counts0 + np.cumsum(back.dcounts, axis=0)
    assert np.array_equal(integrated, back.counts)
    assert np.all(back.dcounts[0] == 0)
    # against the plan evaluated independently at the cycle times
    t = np.arange(60001) * 1e-3
    q_plan, qd_plan, _, _ = motion60.at(t)
    cpr = np.array([teachbot6.drives[j].counts_per_rad() for j in teachbot6.joint_names])
    err_counts = np.abs(integrated / cpr - q_plan) * cpr
    assert err_counts.max() <= 0.5 + 1e-6  # rounding to nearest: half a count
    assert np.array_equal(back.counts, np.rint(q_plan * cpr).astype(np.int64))
    np.testing.assert_allclose(back.q_rad, q_plan, atol=0.6e-9)
    np.testing.assert_allclose(back.qd_rad_s, qd_plan, atol=0.6e-9)
    qdd_plan = motion60.at(t)[2]
    assert back.qdd_rad_s2 is not None and np.abs(qdd_plan).max() > 1e-3
    np.testing.assert_allclose(back.qdd_rad_s2, qdd_plan, atol=0.6e-9)
    np.testing.assert_allclose(back.t_s, t, atol=1e-12)
    # the motion really moves: every joint covers many thousand counts
    assert np.all(np.ptp(back.counts, axis=0) > 10_000)


def test_all_formats_read_back_equal(table60, tmp_path):
    paths = {
        fmt: table60.write(tmp_path / f"sp.{ext}", fmt)
        for fmt, ext in (("csv", "csv"), ("json", "json"), ("npz", "npz"), ("c", "h"))
    }
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "sp.c",
        "sp.csv",
        "sp.h",
        "sp.json",
        "sp.npz",
    ]
    cols = table60.columns()
    assert [c for c in cols if c.startswith("qdd_")] == [
        f"qdd_joint{i}_rad_s2" for i in range(1, 7)
    ]
    for fmt in ("csv", "json", "npz"):
        back = read_setpoints(paths[fmt])
        assert back.joint_names == table60.joint_names
        assert back.cycle_s == table60.cycle_s
        assert back.meta == table60.meta, fmt
        assert back.header_meta()["format"] == "armlab.setpoints/2"
        assert back.trajectory_sha256 == table60.trajectory_sha256 != ""
        for name, values in cols.items():
            got = back.columns()[name]
            assert np.array_equal(got, values), (fmt, name)
            if name.startswith(("counts", "dcounts", "cycle")):
                assert got.dtype == np.int64
    head = paths["csv"].read_text()[:4000]
    for needle in (
        "# robot: teachbot6",
        "# cycle_s: 0.001",
        "joint2=1640000",
        f"# trajectory_sha256: {table60.trajectory_sha256}",
        f"# armlab_version: {armlab.__version__}",
    ):
        assert needle in head
    header = paths["c"].read_text()
    assert f'#define ARMLAB_SP_TRAJECTORY_SHA256 "{table60.trajectory_sha256}"' in header
    assert f'#define ARMLAB_SP_ARMLAB_VERSION "{armlab.__version__}"' in header
    # the header declares, the .c file defines (one copy of the data, not one per includer)
    assert "static" not in header and "{" not in header.split("*/", 1)[1]
    assert (
        "extern const armlab_sp_dcounts_t ARMLAB_SP_DCOUNTS[ARMLAB_SP_N_CYCLES][ARMLAB_SP_N_AXES];"
        in header
    )
    data = (tmp_path / "sp.c").read_text()
    assert '#include "sp.h"' in data and data.count("ARMLAB_SP_DCOUNTS[") == 1
    # 60 s at 1 ms: at most 113 pulses per cycle (int8), counts beyond 2^15 (int32)
    assert 64 < np.abs(table60.dcounts).max() <= 127 and np.abs(table60.counts).max() > 2**15
    assert "typedef int8_t armlab_sp_dcounts_t;" in header
    assert "typedef int32_t armlab_sp_counts_t;" in header


def test_reads_format_1_files_without_accelerations(tmp_path):
    """A set-point CSV of format armlab.setpoints/1 (before accelerations) still reads."""
    meta = {
        "format": "armlab.setpoints/1",
        "robot": "r",
        "joints": ["j1"],
        "axis_sign": [1],
        "cycle_s": 0.001,
        "n_cycles": 3,
        "decimals": 9,
        "counts_per_joint_rev": {"j1": 4000.0},
        "counts_per_rad": [4000.0 / (2 * math.pi)],
        "profile": "reference_dda",
    }
    path = tmp_path / "old.csv"
    path.write_text(
        f"# meta: {json.dumps(meta)}\n"
        "cycle,t_s,q_j1_rad,qd_j1_rad_s,counts_j1,dcounts_j1\n"
        "0,0,0,0,0,0\n1,0.001,0.0005,0.5,0,0\n2,0.002,0.0025,1.5,2,2\n"
    )
    old = read_setpoints(path)
    assert old.qdd_rad_s2 is None and old.n_cycles == 3
    assert old.counts[:, 0].tolist() == [0, 0, 2] and old.qd_rad_s[2, 0] == 1.5
    assert "qdd_j1_rad_s2" not in old.column_names()
    # written again, it stays a format-1 file (no accelerations to write)
    again = read_setpoints(old.write(tmp_path / "again.json"))
    assert again.header_meta()["format"] == "armlab.setpoints/1"
    assert np.array_equal(again.counts, old.counts)
    # a format-2 file must have its accelerations
    meta2 = dict(meta, format="armlab.setpoints/2")
    bad = tmp_path / "bad.csv"
    bad.write_text(path.read_text().replace(json.dumps(meta), json.dumps(meta2)))
    with pytest.raises(InputError, match="no column 'qdd_j1_rad_s2'"):
        read_setpoints(bad)


@pytest.mark.parametrize(
    "values, ctype",
    [
        ([0, -128, 127], "int8_t"),
        ([0, 200], "uint8_t"),
        ([-129, 5], "int16_t"),
        ([40000, 0], "uint16_t"),
        ([-40000], "int32_t"),
        ([2**31], "uint32_t"),
        ([-(2**31) - 1], "int64_t"),
    ],
)
def test_narrowest_c_integer_type(values, ctype):
    assert c_int_type(np.array(values, dtype=np.int64)) == ctype


C_PROGRAM = r"""
#include <stdio.h>
#include <inttypes.h>
#include "sp.h"
int main(void) {
    int64_t s_counts = 0, s_dcounts = 0, weighted = 0;
    int k, a;
    for (k = 0; k < ARMLAB_SP_N_CYCLES; ++k)
        for (a = 0; a < ARMLAB_SP_N_AXES; ++a) {
            s_counts += ARMLAB_SP_COUNTS[k][a];
            s_dcounts += ARMLAB_SP_DCOUNTS[k][a];
            weighted += (int64_t)(k % 97 + 1) * (a + 1) * ARMLAB_SP_DCOUNTS[k][a];
        }
    printf("%d %d %d %" PRId64 " %" PRId64 " %" PRId64 " %s %d %d\n", ARMLAB_SP_N_CYCLES,
           ARMLAB_SP_N_AXES, ARMLAB_SP_MAX_PULSES_PER_CYCLE, s_counts, s_dcounts, weighted,
           ARMLAB_SP_AXIS_JOINT[ARMLAB_SP_N_AXES - 1], (int)sizeof(armlab_sp_counts_t),
           (int)sizeof(armlab_sp_dcounts_t));
    return 0;
}
"""
#: The flags every generated C file must pass.
GCC_STRICT = ["gcc", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror"]


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not available")
def test_c_files_compile_strict_and_checksum(teachbot6, tmp_path):
    table = setpoint_table(
        teachbot6, cosine_motion(teachbot6, duration_s=6.0, n=601), controller="reference_dda"
    )
    table.write(tmp_path / "sp.h", "c")
    (tmp_path / "main.c").write_text(C_PROGRAM)
    for src in ("sp.c", "main.c"):
        subprocess.run([*GCC_STRICT, "-c", src], check=True, cwd=tmp_path, capture_output=True)
    exe = tmp_path / "main"
    subprocess.run(
        ["gcc", "-o", str(exe), "main.o", "sp.o"], check=True, cwd=tmp_path, capture_output=True
    )
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()
    k = (np.arange(table.n_cycles) % 97 + 1)[:, None]
    a = np.arange(1, 7)[None, :]
    # narrowest types: 6 s of this motion stays within +-32767 counts and +-127 pulses per cycle
    assert np.abs(table.counts).max() <= 2**15 - 1 and np.abs(table.counts).max() > 127
    assert np.abs(table.dcounts).max() <= 127
    expect = [
        table.n_cycles,
        6,
        4095,
        int(table.counts.sum()),
        int(table.dcounts.sum()),
        int((k * a * table.dcounts).sum()),
        "joint6",
        2,
        1,
    ]
    assert out == [str(x) for x in expect]


# ---------------------------------------------------------------------- axis order and sign
def test_axis_order_and_sign(teachbot6, tmp_path):
    tr = cosine_motion(teachbot6, duration_s=4.0, n=401)
    prof = load_profile().replace(axis_order=(6, 5, 4, 3, 2, 1), axis_sign=(1, -1, 1, 1, 1, 1))
    t = setpoint_table(teachbot6, tr, prof)
    ref = setpoint_table(teachbot6, tr, controller="reference_dda")
    assert t.joint_names == teachbot6.joint_names[::-1]
    assert np.array_equal(t.counts[:, 1], -ref.counts[:, 4])  # joint5 on axis 2, reversed
    assert np.array_equal(t.counts[:, 0], ref.counts[:, 5])
    assert np.array_equal(t.q_rad[:, 1], ref.q_rad[:, 4])  # positions stay joint-side
    np.testing.assert_allclose(
        t.positions_from_counts(), t.q_rad, atol=0.5 / t.counts_per_rad.min() + 1e-9
    )
    back = read_setpoints(t.write(tmp_path / "s.csv"))
    assert back.column_names()[2] == "q_joint6_rad"
    assert list(back.axis_sign) == [1, -1, 1, 1, 1, 1]
    with pytest.raises(InputError, match="unknown joint"):
        setpoint_table(teachbot6, tr, load_profile().replace(axis_order=("a", 2, 3, 4, 5, 6)))


# ---------------------------------------------------------------------- pre-flight checks
def test_one_percent_too_fast_is_refused_naming_cycle_joint_limit(teachbot6):
    v = 1.01 * teachbot6.limits.velocity_rad_s[1]
    tr = one_joint_bump(teachbot6, "joint2", v)
    with pytest.raises(LimitViolation) as ei:
        setpoint_table(teachbot6, tr, controller="reference_dda")
    f = ei.value.failure
    assert (f.check, f.joint) == ("speed", "joint2")
    # independent: first cycle whose planned speed, or the speed its rounded counts command
    # (what the controller receives), exceeds the limit
    t = np.arange(int(math.ceil(tr.duration / 1e-3 - 1e-9)) + 1) * 1e-3
    q, qd, _, _ = tr.at(t)
    cpr = teachbot6.drives["joint2"].counts_per_rad(4)
    sent = np.zeros(len(t))
    sent[1:] = np.abs(np.diff(np.round(q[:, 1] * cpr))) / (cpr * 1e-3)
    fast = np.maximum(np.abs(qd[:, 1]), sent) > teachbot6.limits.velocity_rad_s[1] * (1 + 1e-6)
    first = int(np.argmax(fast))
    assert f.cycle == first
    msg = str(ei.value)
    assert f"cycle {first}" in msg and "joint joint2" in msg and "speed limit" in msg
    assert f.limit == pytest.approx(0.26) and f.value > 0.26
    # the same motion passes when its counts fit: the limit is 0.26 x cpr x 1 ms = 67.86 counts
    # per cycle, so at most 67 whole counts, 98.7 % of it (99 % rounds to 68 counts: refused)
    setpoint_table(
        teachbot6, one_joint_bump(teachbot6, "joint2", 0.985 * 0.26), controller="reference_dda"
    )
    with pytest.raises(LimitViolation, match="68 counts in one 0.001 s cycle"):
        setpoint_table(
            teachbot6, one_joint_bump(teachbot6, "joint2", 0.99 * 0.26), controller="reference_dda"
        )


def test_pulse_limit_4095_passes_4096_refused(teachbot6):
    """SHU controller paper, §1: 0..4095 pulses per axis per DDA period. On a 25 ms period
    joint 5 (189 713 counts/rad) needs ~4096 pulses per cycle at 0.8635 rad/s, below its
    0.875 rad/s limit."""
    prof = load_profile().with_cycle(0.025)
    cpr = teachbot6.drives["joint5"].counts_per_rad()
    ok = trapezoid_move(teachbot6, "joint5", 4094.5 / (cpr * 0.025), 3.0, 1.0)
    table = setpoint_table(teachbot6, ok, prof)
    assert np.abs(table.dcounts[:, 4]).max() == 4095
    bad = trapezoid_move(teachbot6, "joint5", 4095.6 / (cpr * 0.025), 3.0, 1.0)
    with pytest.raises(LimitViolation) as ei:
        setpoint_table(teachbot6, bad, prof)
    f = ei.value.failure
    assert (f.check, f.joint, f.value, f.limit) == ("pulse rate", "joint5", 4096, 4095)
    # independent: first cycle of the rounded counts with 4096 pulses
    t = np.arange(int(math.ceil(bad.duration / 0.025 - 1e-9)) + 1) * 0.025
    counts = np.rint(bad.at(t)[0][:, 4] * cpr)
    assert f.cycle == int(np.argmax(np.abs(np.diff(counts)) > 4095)) + 1
    assert f"cycle {f.cycle}" in str(ei.value) and "4096 pulses" in str(ei.value)


def test_start_pose_range_continuity_and_order(teachbot6):
    tr = one_joint_bump(teachbot6, "joint3", 0.5)
    q0 = np.zeros(6)
    setpoint_table(teachbot6, tr, q_current=q0, controller="reference_dda")
    cpr3 = teachbot6.drives["joint3"].counts_per_rad()
    off = q0.copy()
    off[2] = 2.0 / cpr3  # two counts away
    with pytest.raises(LimitViolation, match=r"cycle 0 .*joint joint3, start pose"):
        setpoint_table(teachbot6, tr, q_current=off, controller="reference_dda")
    with pytest.raises(InputError, match="q_current has shape"):
        setpoint_table(teachbot6, tr, q_current=np.zeros(5), controller="reference_dda")
    # beyond the range of joint 3 (upper 160 deg): start near the top and go up
    t = np.linspace(0, 1, 101)
    q = np.zeros((101, 6))
    q[:, 2] = np.radians(159.5) + 0.2 * (1 - np.cos(np.pi * t)) / 2
    qd = np.zeros_like(q)
    qd[:, 2] = 0.2 * np.pi / 2 * np.sin(np.pi * t)
    qdd = np.zeros_like(q)
    qdd[:, 2] = 0.2 * np.pi**2 / 2 * np.cos(np.pi * t)
    with pytest.raises(LimitViolation) as ei:
        setpoint_table(teachbot6, Trajectory(t, q, qd, qdd), controller="reference_dda")
    f = ei.value.failure
    assert (f.check, f.joint) == ("joint range", "joint3")
    first = int(np.argmax(q[:, 2] > np.radians(160) + 1e-9))  # samples are on the 10 ms grid
    assert abs(f.t_s - t[first]) <= 0.01 + 1e-12
    # a jump: the Jiang 1987 PTP without ramps starts at full speed (velocity step from rest)
    v = 0.2
    q = np.zeros((11, 6))
    q[:, 0] = v * np.linspace(0, 1, 11)
    qd = np.zeros_like(q)
    qd[:, 0] = v
    with pytest.raises(LimitViolation) as ei:
        setpoint_table(
            teachbot6,
            Trajectory(np.linspace(0, 1, 11), q, qd, np.zeros_like(q)),
            controller="reference_dda",
        )
    f = ei.value.failure
    assert (f.check, f.joint, f.cycle) == ("continuity", "joint1", 1)
    assert f.value == pytest.approx(v, rel=1e-3) and f.limit == pytest.approx(3.5e-3)
    assert CHECKS.index("start pose") < CHECKS.index("speed")


def test_robot_without_drives_needs_counts_in_profile(ur5):
    t = np.linspace(0, 1, 11)
    z = np.zeros((11, ur5.n_joints))
    tr = Trajectory(t, z, z, z, joint_names=ur5.joint_names)
    with pytest.raises(InputError, match="counts_per_joint_rev"):
        setpoint_table(ur5, tr, "generic_1khz")
    prof = load_profile("generic_1khz").replace(counts_per_joint_rev=(2**17,) * 6)
    table = setpoint_table(ur5, tr, prof)
    assert table.n_cycles == 1001 and "continuity" not in table.preflight.checks


# ---------------------------------------------------------------------- atomic writes
def test_failed_write_leaves_old_file_and_no_temporaries(table60, tmp_path, monkeypatch):
    path = tmp_path / "setpoints.csv"
    path.write_text("old\n")
    from armlab.deploy import provenance

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(provenance.os, "fsync", boom)
    with pytest.raises(OSError):
        table60.write(path)
    assert path.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["setpoints.csv"]


# ---------------------------------------------------------------------- trajectory file
def test_trajectory_file_round_trip(teachbot6, tmp_path):
    tr = cosine_motion(teachbot6, duration_s=2.0, n=201)
    path = save_trajectory(tmp_path / "trajectory.npz", tr, teachbot6)
    back = load_trajectory(path)
    for k in ("t", "q", "qd", "qdd"):
        assert np.array_equal(getattr(back, k), getattr(tr, k))
    assert back.meta["sha256"] == trajectory_sha256(tr)
    assert back.meta["file_sha256"] == file_sha256(path)
    assert back.meta["robot"]["joint_names"] == list(teachbot6.joint_names)
    # an edited file is refused
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["q"] = arrays["q"] + 1e-6
    np.savez(tmp_path / "edited.npz", **arrays)
    with pytest.raises(InputError, match="checksum mismatch"):
        load_trajectory(tmp_path / "edited.npz")


# ---------------------------------------------------------------------- export / CLI
def make_study(tmp_path, robot, traj, name="study") -> Path:
    return make_study_folder(tmp_path / name, robot, traj)


def test_export_formats_carry_checksums(teachbot6, tmp_path):
    tr = cosine_motion(teachbot6, duration_s=3.0, n=301)
    study = make_study(tmp_path, teachbot6, tr)
    sha = trajectory_sha256(tr)
    out = tmp_path / "out"
    for fmt, name in (
        ("csv", "setpoints.csv"),
        ("json", "setpoints.json"),
        ("npz", "setpoints.npz"),
        ("c", "setpoints.h"),
    ):
        paths = export_study(study, fmt=fmt, out_dir=out).files
        names = [name, "setpoints.c"] if fmt == "c" else [name]
        assert [p.name for p in paths] == names  # no gains.json in this study
        if fmt == "npz":
            with np.load(paths[0]) as z:
                text = str(z["meta_json"])
        else:
            text = paths[0].read_text()
        assert sha in text and armlab.__version__ in text
    assert read_setpoints(out / "setpoints.csv").meta["trajectory_sha256"] == sha
    with pytest.raises(InputError, match="no gains.json"):
        export_study(study, fmt="ros2", out_dir=out)
    with pytest.raises(InputError, match="unknown export format"):
        export_study(study, fmt="xlsx", out_dir=out)
    with pytest.raises(InputError, match="no summary.json"):
        export_study(tmp_path / "out", fmt="csv", out_dir=tmp_path / "o2")


def test_cli_refuses_too_fast_and_leaves_nothing(teachbot6, tmp_path, capsys):
    study = make_study(tmp_path, teachbot6, one_joint_bump(teachbot6, "joint4", 1.01 * 0.875))
    out = tmp_path / "out"
    code = cli_main(["export", str(study), "--format", "csv", "--out", str(out)])
    err = capsys.readouterr().err
    assert code != 0
    assert "cycle" in err and "joint joint4" in err and "speed limit" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists() or not any(out.iterdir())
    # a real process: exit status and no partial file (module run, like the console script)
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "armlab.cli",
            "export",
            str(study),
            "--format",
            "c",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    assert proc.returncode != 0 and "joint joint4" in proc.stderr
    assert not out.exists() or not any(out.iterdir())


def test_cli_refuses_4096_pulses_with_profile_file(teachbot6, tmp_path, capsys):
    cpr = teachbot6.drives["joint5"].counts_per_rad()
    tr = trapezoid_move(teachbot6, "joint5", 4095.6 / (cpr * 0.025), 3.0, 1.0)
    study = make_study(tmp_path, teachbot6, tr)
    prof = write_profile(tmp_path / "dda25.toml", name="dda25", cycle_s=0.025)
    out = tmp_path / "out"
    for fmt in ("csv", "json", "npz", "c"):
        code = cli_main(
            ["export", str(study), "--format", fmt, "--profile", str(prof), "--out", str(out)]
        )
        err = capsys.readouterr().err
        assert code != 0 and "joint joint5, pulse rate limit" in err and "4096 pulses" in err
    assert not out.exists() or not any(out.iterdir())
    # the default 1 ms profile takes the same motion (~164 pulses per cycle)
    assert cli_main(["export", str(study), "--format", "csv", "--out", str(out)]) == 0
    assert [p.name for p in out.iterdir()] == ["setpoints.csv"]


# ---------------------------------------------------------------------- number text
@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(min_value=-1e6, max_value=1e6, allow_nan=False), min_size=1, max_size=40),
    st.lists(st.integers(min_value=-(2**40), max_value=2**40), min_size=1, max_size=40),
)
def test_numtext_exact(values, ints):
    x = np.array(values)
    text = format_list(x, 9).decode().split(",")
    assert [float(s) for s in text] == list(np.rint(x * 1e9) / 1e9)
    i = np.array(ints, dtype=np.int64)
    assert [int(s) for s in format_list(i, 0).decode().split(",")] == ints
    rows = format_rows([i, i], 0, sep=";", prefix="{", suffix="}\n").decode().splitlines()
    assert rows == [f"{{{v};{v}}}" for v in ints]


def test_numtext_refuses_nan():
    with pytest.raises(InputError, match="not finite at row 1"):
        format_list(np.array([1.0, np.nan]), 9, name="q")


# ---------------------------------------------------------------------- properties
@settings(max_examples=12, deadline=None)
@given(
    scale=st.floats(0.05, 0.98),
    cycle_ms=st.integers(1, 40),
    k1=st.integers(1, 4),
    k2=st.integers(5, 9),
    share=st.floats(0.2, 0.8),
)
def test_any_motion_within_limits_passes_and_round_trips(teachbot6, scale, cycle_ms, k1, k2, share):
    """Motions within the limits pass every check at any cycle (when the pulse limit allows);
    the counts never drift; the same motion sped up past the limits is refused."""
    terms = ((k1, share), (k2, 1.0 - share))
    tr = cosine_motion(teachbot6, duration_s=5.0, n=501, scale=scale, terms=terms)
    prof = load_profile().with_cycle(cycle_ms * 1e-3)
    cpr = np.array([teachbot6.drives[j].counts_per_rad() for j in teachbot6.joint_names])
    v_peak = np.abs(tr.qd).max(axis=0)
    if np.any(v_peak * cpr * prof.cycle_s > 4000):  # too close to the card's pulse limit
        return
    table = setpoint_table(teachbot6, tr, prof)
    assert np.array_equal(table.counts[0] + np.cumsum(table.dcounts, axis=0), table.counts)
    q, _, _, _ = tr.at(table.t_s)
    assert np.abs(table.counts - q * cpr).max() <= 0.5 + 1e-6
    json.dumps(table.to_dict(), allow_nan=False)
    # the same path sped up until one joint is 1 % over its speed limit: refused
    c = 1.01 / np.max(v_peak / teachbot6.limits.velocity_rad_s)
    fast = Trajectory(tr.t / c, tr.q, tr.qd * c, tr.qdd * c**2, joint_names=tr.joint_names)
    with pytest.raises(LimitViolation, match=r"pre-flight check failed at cycle \d+") as ei:
        setpoint_table(teachbot6, fast, prof)
    assert ei.value.failure.check in ("speed", "continuity", "pulse rate")


def test_trajectory_of_one_sample_is_one_cycle(teachbot6):
    z = np.zeros((1, 6))
    table = setpoint_table(teachbot6, Trajectory([0.0], z, z, z), controller="reference_dda")
    assert table.n_cycles == 1 and np.all(table.dcounts == 0)
