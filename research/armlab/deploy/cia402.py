"""CiA 402 cyclic synchronous position (CSP) export: per-cycle drive set-points and the object
dictionary values a drive needs to play them (e.g. an EtherCAT servo drive, profile
``ethercat_cia402_csp``).

Object meanings (CiA 402 / IEC 61800-7-201 device profile; as documented in drive manuals, e.g.
the Elmo "CANopen DSP 402 Implementation Guide" §9.2 for the home offset):

* 0x6060 modes of operation = 8, cyclic synchronous position;
* 0x60C2 interpolation time period: sub 1 value (UNSIGNED8) and sub 2 index (INTEGER8),
  period = value x 10^index s -- the set-point table's cycle;
* 0x608F position encoder resolution (increments / motor revolutions), 0x6091 gear ratio
  (motor revolutions / shaft revolutions), 0x6092 feed constant (feed / shaft revolutions): the
  factor group. armlab sets it so that **one position unit is one motor-encoder count** of the
  set-point table (after the decoding), ``0x608F x 0x6091 / 0x6092 = 1`` exactly: the feed per
  joint revolution is the table's counts per joint revolution. Velocity unit: counts/s;
* 0x607A target position [counts] (INTEGER32), one per cycle: the table's counts (so it is
  ``setpoints.csv`` played by the drive), modulo axes wrapped into one joint revolution;
* 0x60B1 velocity offset [counts/s] (INTEGER32): ``rint(qd x counts_per_rad x sign)``;
* 0x60B2 torque offset [per mille of 0x6076] (INTEGER16): the motor torque of the plan,
  ``rint(1000 sign T_m / T_rated)``, ``T_m`` from armlab's inverse dynamics
  (:func:`armlab.robot.rigid_body.inverse_dynamics` at the cycle's q, qd, qdd) through the drive
  train (:func:`armlab.robot.drivetrain.motor_side`: reducer efficiency, rotor and reducer
  inertia, viscous friction) -- the feed-forward armlab's sizing and tracking use;
* 0x6076 motor rated torque [mN m] (UNSIGNED32): the motor's continuous stall torque
  (drives.toml); 0x6072 max torque [per mille] (UNSIGNED16): its peak torque (stall if none);
* 0x607C home offset [counts] (INTEGER32): "the zero position is offset from the home position
  by adding the home offset", so the homing reference at joint angle ``home_position_rad`` (the
  profile's) reads ``c_home = rint(home x counts_per_rad x sign)`` counts when 0x607C =
  ``-c_home`` (some drives define the sign the other way: check the drive manual);
* 0x607E polarity = 0: the axis sign is already in the counts (CiA 402 applies the position
  polarity bit in profile position mode only);
* 0x607D software position limit (sub 1 min, sub 2 max) [counts]: the joint range, rounded
  like the set-points (every checked set-point lies inside);
* modulo axes (profile ``modulo_axes``): 0x607B position range limit = [0, counts per joint
  revolution - 1] instead of 0x607D, and target positions wrapped into it; the counts per joint
  revolution must then be a whole number.

Files (:meth:`Cia402Csp.write`): ``cia402_csp.csv`` (``# meta:`` JSON line, then ``cycle, t_s``
and per axis ``target_position_<j>_counts, velocity_offset_<j>_counts_s,
torque_offset_<j>_permille``) and ``cia402_objects.csv`` (``axis, joint, index, subindex, name,
data_type, value, unit``). :func:`read_cia402_csp` reads the set-points back;
:meth:`Cia402Csp.counts` undoes the modulo wrap, giving the set-point table's counts.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from dataclasses import dataclass, field, fields, replace
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab._keywords import renamed_keywords
from armlab.deploy.formats import _read_csv
from armlab.deploy.numtext import format_rows
from armlab.errors import InputError
from armlab.io import atomic_write_many
from armlab.names import one_line

if TYPE_CHECKING:
    from armlab.deploy.table import SetpointTable
    from armlab.robot.drives import Drive
    from armlab.robot.model import Robot

__all__ = [
    "CIA402_FORMAT",
    "MODE_CSP",
    "CSP_FILE",
    "OBJECTS_FILE",
    "Cia402Object",
    "Cia402Csp",
    "cia402_csp",
    "interpolation_period",
    "read_cia402_csp",
    "read_cia402_objects",
]

CIA402_FORMAT = "armlab.cia402_csp/1"
#: 0x6060 modes of operation: cyclic synchronous position.
MODE_CSP = 8
CSP_FILE = "cia402_csp.csv"
OBJECTS_FILE = "cia402_objects.csv"

#: CiA 301 data types used here and their ranges.
_RANGES = {
    "INTEGER8": (-(2**7), 2**7 - 1),
    "UNSIGNED8": (0, 2**8 - 1),
    "INTEGER16": (-(2**15), 2**15 - 1),
    "UNSIGNED16": (0, 2**16 - 1),
    "INTEGER32": (-(2**31), 2**31 - 1),
    "UNSIGNED32": (0, 2**32 - 1),
}
_OBJECT_FIELDS = ("axis", "joint", "index", "subindex", "name", "data_type", "value", "unit")


@dataclass(frozen=True)
class Cia402Object:
    """One object dictionary entry of one axis.

    Attributes
    ----------
    axis : int
        Controller axis, 1-based.
    joint : str
    index : int
        Object index (0x6060 ...).
    subindex : int
    name : str
    data_type : str
        CiA 301 type (INTEGER8 .. UNSIGNED32).
    value : int
    unit : str
    """

    axis: int
    joint: str
    index: int
    subindex: int
    name: str
    data_type: str
    value: int
    unit: str = ""

    def __post_init__(self) -> None:
        lo, hi = _RANGES[self.data_type]
        if not lo <= int(self.value) <= hi:
            raise InputError(
                f"axis {self.axis} ({self.joint}) object 0x{self.index:04X}:{self.subindex} "
                f"{self.name} = {self.value} does not fit {self.data_type} [{lo}, {hi}]"
            )

    @property
    def address(self) -> str:
        """``0x60C2:1``."""
        return f"0x{self.index:04X}:{self.subindex}"


def interpolation_period(cycle_s: float) -> tuple[int, int]:
    """0x60C2 of a cycle: ``(value, index)`` with ``cycle_s = value x 10^index``, value 1..255,
    the largest index that represents the cycle exactly (1 ms -> (1, -3)).

    Raises
    ------
    InputError
        No such pair (the cycle is not a whole number of 1..255 x 10^index s).
    """
    T = float(cycle_s)
    for index in range(2, -10, -1):
        value = T / 10.0**index
        v = round(value)
        if 1 <= v <= 255 and abs(value - v) <= 1e-9 * v:
            return int(v), index
    raise InputError(f"cycle {T!r} s is not value x 10^index s with value 1..255 (object 0x60C2)")


def _rational(x: float, what: str) -> Fraction:
    f = Fraction(float(x)).limit_denominator(10**6)
    if not (f > 0 and abs(float(f) - x) <= 1e-9 * abs(x)):
        raise InputError(f"{what} {x!r} is not a ratio of whole numbers (CiA 402 factor group)")
    return f


@dataclass
class Cia402Csp:
    """CSP set-points of every axis and the object dictionary values (module docstring).

    Attributes
    ----------
    robot : str
    joint_names : list of str
        Joint of each axis (profile axis order, as the set-point table).
    cycle_s : float
        Interpolation period in [s].
    cycle : int array (n_cycles,)
    t_s : array (n_cycles,)
    target_position : int64 array (n_cycles, n_axes)
        0x607A [counts] (modulo axes wrapped).
    velocity_offset : int64 array (n_cycles, n_axes)
        0x60B1 [counts/s].
    torque_offset : int64 array (n_cycles, n_axes)
        0x60B2 [per mille of the rated torque 0x6076].
    modulo_counts : int64 array (n_axes,)
        Counts per joint revolution of a modulo axis, 0 for the others.
    start_counts : int64 array (n_axes,)
        The set-point table's counts of cycle 0 (to undo the modulo wrap).
    objects : list of Cia402Object
        Per axis object dictionary values (empty for a table read back from a file).
    meta : dict
    """

    robot: str
    joint_names: list[str]
    cycle_s: float
    cycle: np.ndarray
    t_s: np.ndarray
    target_position: np.ndarray
    velocity_offset: np.ndarray
    torque_offset: np.ndarray
    modulo_counts: np.ndarray
    start_counts: np.ndarray
    objects: list[Cia402Object] = field(default_factory=list)
    meta: dict = field(default_factory=dict)

    @property
    def n_cycles(self) -> int:
        return int(self.cycle.size)

    def counts(self) -> np.ndarray:
        """The set-point table's counts: target positions with the modulo wrap undone."""
        out = self.target_position.astype(np.int64).copy()
        for a, period in enumerate(self.modulo_counts):
            if period > 0:
                step = np.diff(out[:, a])
                step -= period * np.rint(step / period).astype(np.int64)
                out[:, a] = self.start_counts[a] + np.concatenate([[0], np.cumsum(step)])
        return out

    def columns(self) -> dict[str, np.ndarray]:
        """``cycle, t_s`` and per axis target position, velocity offset, torque offset."""
        out = {"cycle": self.cycle, "t_s": self.t_s}
        for a, j in enumerate(self.joint_names):
            out[f"target_position_{j}_counts"] = self.target_position[:, a]
            out[f"velocity_offset_{j}_counts_s"] = self.velocity_offset[:, a]
            out[f"torque_offset_{j}_permille"] = self.torque_offset[:, a]
        return out

    def header_meta(self) -> dict:
        value, index = interpolation_period(self.cycle_s)
        m = {
            "format": CIA402_FORMAT,
            "robot": self.robot,
            "joints": list(self.joint_names),
            "cycle_s": self.cycle_s,
            "n_cycles": self.n_cycles,
            "interpolation_period": {"value": value, "index": index},
            "modulo_counts": [int(x) for x in self.modulo_counts],
            "start_counts": [int(x) for x in self.start_counts],
            "units": {
                "target_position": "counts (0x607A)",
                "velocity_offset": "counts/s (0x60B1)",
                "torque_offset": "per mille of motor rated torque 0x6076 (0x60B2)",
            },
        }
        m.update({k: v for k, v in self.meta.items() if k not in m})
        return m

    def render_csp(self) -> bytes:
        """``cia402_csp.csv``: comment lines, ``# meta:`` JSON, the columns."""
        meta = self.header_meta()
        cols = self.columns()
        head = [
            f"# armlab CiA 402 cyclic synchronous position set-points ({CIA402_FORMAT}): "
            "one row per interpolation period",
            f"# robot: {one_line(self.robot)}; axes: {one_line(', '.join(self.joint_names))}",
            f"# interpolation period 0x60C2: {meta['interpolation_period']['value']} x "
            f"10^{meta['interpolation_period']['index']} s",
            "# target_position: 0x607A [counts]; velocity_offset: 0x60B1 [counts/s]; "
            "torque_offset: 0x60B2 [per mille of 0x6076]",
            f"# trajectory_sha256: {meta.get('trajectory_sha256', '')}",
            f"# armlab_version: {meta.get('armlab_version', '')}",
            f"# meta: {json.dumps(meta, allow_nan=False)}",
            ",".join(cols),
        ]
        decimals = [0, 9] + [0] * (len(cols) - 2)
        body = format_rows(list(cols.values()), decimals, names=list(cols))
        return ("\n".join(head) + "\n").encode() + body

    def render_objects(self) -> bytes:
        """``cia402_objects.csv``: one row per axis and object (index as ``0x6060``)."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(_OBJECT_FIELDS)
        for o in self.objects:
            w.writerow(
                [o.axis, o.joint, f"0x{o.index:04X}", o.subindex, o.name, o.data_type, o.value]
                + [o.unit]
            )
        return buf.getvalue().encode()

    def files(self, folder: str | os.PathLike) -> list[tuple[Path, bytes]]:
        folder = Path(folder)
        return [
            (folder / CSP_FILE, self.render_csp()),
            (folder / OBJECTS_FILE, self.render_objects()),
        ]

    def write(self, folder: str | os.PathLike) -> list[Path]:
        """Write ``cia402_csp.csv`` and ``cia402_objects.csv`` into ``folder`` atomically."""
        return atomic_write_many(self.files(folder))


def _numbers(d: Drive) -> Drive:
    """``d`` with unknown (None) motor and reducer figures as NaN: a robot rebuilt from a
    study's design.json carries NaN as JSON null."""

    def fix(part):
        nones = {
            f.name: math.nan
            for f in fields(part)
            if getattr(part, f.name) is None and f.type in ("float", float)
        }
        return replace(part, **nones) if nones else part

    return replace(d, motor=fix(d.motor), reducer=fix(d.reducer))


def _motor_torque_Nm(
    robot: Robot, table: SetpointTable, index: np.ndarray, drives: list[Drive]
) -> np.ndarray:
    """Motor torque [N m] of each axis and cycle (module docstring), ``(n_cycles, n_axes)``."""
    from armlab.robot.drivetrain import DriveTrain, motor_side
    from armlab.robot.rigid_body import inverse_dynamics

    assert table.qdd_rad_s2 is not None and robot.drives is not None
    n = robot.n_joints
    q = np.zeros((table.n_cycles, n))
    qd, qdd = np.zeros_like(q), np.zeros_like(q)
    q[:, index], qd[:, index], qdd[:, index] = table.q_rad, table.qd_rad_s, table.qdd_rad_s2
    tau = inverse_dynamics(robot, q, qd, qdd)
    t_m, _, _ = motor_side(
        tau[:, index], qd[:, index], qdd[:, index], DriveTrain.from_drives(drives)
    )
    return t_m


@renamed_keywords(profile="controller=")
def cia402_csp(
    robot: Robot, table: SetpointTable, controller, *, source: dict | None = None
) -> Cia402Csp:
    """The CSP set-points and object dictionary values of a checked set-point table.

    Parameters
    ----------
    robot : Robot
        The robot the table was made for (drive train: ratio, encoder, motor torques).
    table : SetpointTable
        From :func:`armlab.deploy.setpoint_table` (pre-flight checked, with accelerations).
    controller : ControllerProfile or str
        The table's controller: axis order, home positions, modulo axes.
    source : dict, optional
        Provenance recorded in the metadata.

    Returns
    -------
    Cia402Csp

    Raises
    ------
    InputError
        A robot without drives, a table without accelerations or of another profile's axes, a
        cycle 0x60C2 cannot express, a modulo axis with a fractional count per revolution, an
        offset or object value beyond its data type.
    """
    from armlab.robot.controller import load_profile

    prof = load_profile(controller)
    if robot.drives is None:
        raise InputError(
            f"robot {robot.name} has no drive train (drives.toml): the CiA 402 torque offset "
            "needs the motors"
        )
    if table.qdd_rad_s2 is None:
        raise InputError("the set-point table has no accelerations (format armlab.setpoints/1)")
    index, sign = prof.axes(robot)
    names = [robot.joint_names[i] for i in index]
    if names != list(table.joint_names) or not np.array_equal(sign, table.axis_sign):
        raise InputError(
            f"the set-point table's axes {table.joint_names} are not profile "
            f"{prof.name!r}'s {names}"
        )
    value, exponent = interpolation_period(table.cycle_s)
    cpr = np.asarray(table.counts_per_rad, dtype=float)
    n_axes = len(names)

    velocity = np.rint(table.qd_rad_s * (cpr * sign)).astype(np.int64)
    drives = [_numbers(robot.drives[j]) for j in names]
    rated_mNm = np.array([int(round(d.motor.stall_torque_Nm * 1000.0)) for d in drives])
    if np.any(rated_mNm < 1):
        j = int(np.argmin(rated_mNm))
        raise InputError(f"joint {names[j]}: motor stall torque below 1 mN m (0x6076)")
    t_m = _motor_torque_Nm(robot, table, index, drives)
    torque = np.rint(1000.0 * sign * t_m / (rated_mNm / 1000.0)).astype(np.int64)
    for what, a, dtype in (
        ("velocity offset 0x60B1", velocity, "INTEGER32"),
        ("torque offset 0x60B2", torque, "INTEGER16"),
    ):
        lo, hi = _RANGES[dtype]
        bad = (a < lo) | (a > hi)
        if bad.any():
            k, j = (int(x) for x in np.argwhere(bad)[0])
            raise InputError(
                f"cycle {k}, joint {names[j]}: {what} = {a[k, j]} does not fit {dtype}"
            )

    modulo = prof.modulo_mask(robot, index)
    period = np.zeros(n_axes, dtype=np.int64)
    target = table.counts.astype(np.int64).copy()
    per_rev = table.counts_per_joint_rev
    for a in np.flatnonzero(modulo):
        p = round(float(per_rev[a]))
        if abs(per_rev[a] - p) > 1e-6:
            raise InputError(
                f"joint {names[a]}: {float(per_rev[a])!r} counts per joint revolution is not "
                "a whole number, a modulo axis would drift"
            )
        period[a] = p
        target[:, a] = np.mod(target[:, a], p)

    home_counts = np.rint(prof.home_positions_rad(n_axes) * cpr * sign).astype(np.int64)
    ranges = np.column_stack(
        [_axis_limits(robot, index, "lower_rad"), _axis_limits(robot, index, "upper_rad")]
    )
    objects: list[Cia402Object] = []
    for a, (j, d) in enumerate(zip(names, drives, strict=True)):
        if modulo[a]:
            range_counts = None
        elif np.all(np.isinf(ranges[a])):  # an unbounded joint: the whole INTEGER32 range
            range_counts = np.array([-(2**31), 2**31 - 1], dtype=float)
        else:
            range_counts = np.sort(np.rint(ranges[a] * cpr[a] * sign[a]))
        rows = _axis_rows(
            j, d, (value, exponent), float(per_rev[a]), int(home_counts[a]), int(period[a]),
            range_counts, int(rated_mNm[a]),
        )  # fmt: skip
        objects += [Cia402Object(a + 1, j, *r) for r in rows]

    meta: dict[str, Any] = {
        "profile": prof.name,
        "counts_per_joint_rev": [float(x) for x in per_rev],
        "axis_sign": [int(s) for s in sign],
        "trajectory_sha256": table.trajectory_sha256,
        "armlab_version": table.meta.get("armlab_version", ""),
        "torque_rule": "inverse dynamics (RNEA) + drive train (armlab.robot.drivetrain.motor_side)",
    }
    if source is not None:
        meta["source"] = dict(source)
    return Cia402Csp(
        robot=table.robot,
        joint_names=names,
        cycle_s=table.cycle_s,
        cycle=table.cycle.copy(),
        t_s=table.t_s.copy(),
        target_position=target,
        velocity_offset=velocity,
        torque_offset=torque,
        modulo_counts=period,
        start_counts=table.counts[0].astype(np.int64).copy(),
        objects=objects,
        meta=meta,
    )


def _axis_rows(
    j: str,
    d: Drive,
    period_value_index: tuple[int, int],
    per_rev: float,
    home_counts: int,
    period: int,
    range_counts: np.ndarray | None,
    rated_mNm: int,
) -> list[tuple[int, int, str, str, int, str]]:
    """The object dictionary rows ``(index, subindex, name, type, value, unit)`` of one axis:
    mode, interpolation period, factor group (0x608F, 0x6091, 0x6092: exact fractions of the
    drive's ratio and counts), home offset, position range (modulo ``period`` counts, else the
    joint range ``range_counts``), rated and maximum torque (the drive's derated peak)."""
    value, exponent = period_value_index
    ratio = _rational(d.reducer.ratio, f"joint {j} reducer ratio")
    feed = _rational(per_rev, f"joint {j} counts per joint revolution")
    resolution = feed / ratio
    peak = d.peak_motor_torque_Nm  # derated: the peak sizing allows
    rows: list[tuple[int, int, str, str, int, str]] = [
        (0x6060, 0, "modes of operation", "INTEGER8", MODE_CSP, "8 = cyclic sync position"),
        (0x60C2, 1, "interpolation time period value", "UNSIGNED8", value, "x 10^index s"),
        (0x60C2, 2, "interpolation time index", "INTEGER8", exponent, "power of ten"),
        (
            0x608F,
            1,
            "position encoder resolution: increments",
            "UNSIGNED32",
            resolution.numerator,
            "counts",
        ),
        (
            0x608F,
            2,
            "position encoder resolution: motor revolutions",
            "UNSIGNED32",
            resolution.denominator,
            "rev",
        ),
        (0x6091, 1, "gear ratio: motor revolutions", "UNSIGNED32", ratio.numerator, "rev"),
        (0x6091, 2, "gear ratio: shaft revolutions", "UNSIGNED32", ratio.denominator, "rev"),
        (0x6092, 1, "feed constant: feed", "UNSIGNED32", feed.numerator, "counts"),
        (0x6092, 2, "feed constant: shaft revolutions", "UNSIGNED32", feed.denominator, "rev"),
        (0x607C, 0, "home offset", "INTEGER32", -home_counts, "counts"),
        (0x607E, 0, "polarity", "UNSIGNED8", 0, "sign is in the counts"),
    ]
    if range_counts is None:
        rows += [
            (0x607B, 1, "position range limit: min", "INTEGER32", 0, "counts"),
            (0x607B, 2, "position range limit: max", "INTEGER32", period - 1, "counts"),
        ]
    else:
        lim = range_counts
        rows += [
            (0x607D, 1, "software position limit: min", "INTEGER32", int(lim[0]), "counts"),
            (0x607D, 2, "software position limit: max", "INTEGER32", int(lim[1]), "counts"),
        ]
    rows += [
        (0x6076, 0, "motor rated torque", "UNSIGNED32", rated_mNm, "mN m"),
        (
            0x6072,
            0,
            "max torque",
            "UNSIGNED16",
            int(round(1000.0 * peak * 1000.0 / rated_mNm)),
            "per mille of 0x6076",
        ),
    ]
    return rows


def _axis_limits(robot: Robot, index: np.ndarray, key: str) -> np.ndarray:
    """The joint range bound ``key`` (``lower_rad``/``upper_rad``) of each axis [rad]."""
    return np.asarray(getattr(robot.limits, key), dtype=float)[index]


def read_cia402_csp(path: str | os.PathLike) -> Cia402Csp:
    """Read ``cia402_csp.csv`` (the set-points; objects: :func:`read_cia402_objects`).

    Raises
    ------
    InputError
        Missing file, not an armlab CiA 402 file, missing or non-integral columns.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"CiA 402 file {path} not found")
    meta, cols = _read_csv(path)
    if meta.get("format") != CIA402_FORMAT:
        raise InputError(f"{path}: format {meta.get('format')!r} is not {CIA402_FORMAT!r}")
    joints = list(meta["joints"])

    def ints(name: str) -> np.ndarray:
        if name not in cols:
            raise InputError(f"{path}: no column {name!r}")
        a = cols[name]
        ai = np.rint(a).astype(np.int64)
        if not np.array_equal(ai, a):
            raise InputError(f"{path}: column {name} is not integral")
        return ai

    def per(pat: str) -> np.ndarray:
        return np.column_stack([ints(pat.format(j)) for j in joints])

    keep = {"format", "robot", "joints", "cycle_s", "n_cycles", "modulo_counts", "start_counts"}
    out = Cia402Csp(
        robot=str(meta.get("robot", "")),
        joint_names=joints,
        cycle_s=float(meta["cycle_s"]),
        cycle=ints("cycle"),
        t_s=np.asarray(cols["t_s"], dtype=float),
        target_position=per("target_position_{}_counts"),
        velocity_offset=per("velocity_offset_{}_counts_s"),
        torque_offset=per("torque_offset_{}_permille"),
        modulo_counts=np.asarray(meta["modulo_counts"], dtype=np.int64),
        start_counts=np.asarray(meta["start_counts"], dtype=np.int64),
        meta={k: v for k, v in meta.items() if k not in keep},
    )
    if int(meta.get("n_cycles", out.n_cycles)) != out.n_cycles:
        raise InputError(
            f"{path}: header says {meta['n_cycles']} cycles, file holds {out.n_cycles}"
        )
    return out


def read_cia402_objects(path: str | os.PathLike) -> list[Cia402Object]:
    """Read ``cia402_objects.csv`` back into :class:`Cia402Object` rows (values range-checked).

    Raises
    ------
    InputError
        Missing file, other columns, unreadable numbers, a value beyond its data type.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"CiA 402 object file {path} not found")
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    out = []
    for i, r in enumerate(rows):
        if set(r) != set(_OBJECT_FIELDS):
            raise InputError(f"{path}: columns {sorted(r)} are not {list(_OBJECT_FIELDS)}")
        try:
            out.append(
                Cia402Object(
                    axis=int(r["axis"]),
                    joint=r["joint"],
                    index=int(r["index"], 16),
                    subindex=int(r["subindex"]),
                    name=r["name"],
                    data_type=r["data_type"],
                    value=int(r["value"]),
                    unit=r["unit"],
                )
            )
        except (ValueError, KeyError) as exc:
            raise InputError(f"{path}: row {i + 2} unreadable ({exc})") from None
    return out
