"""Set-point tables: a :class:`~armlab.trajectory.Trajectory` sampled at the controller's cycle.

One row per controller cycle ``k = 0 .. n`` at ``t_k = t_0 + k T`` (``T`` the profile's period,
1 ms .. 2 s on the DDA card of the SHU controller paper; the last row holds the end point).
Per axis (controller axis order of the profile):

* ``q_<joint>_rad``, ``qd_<joint>_rad_s``, ``qdd_<joint>_rad_s2`` — planned position, velocity
  and acceleration (joint side), stored to 1e-9 (nano) resolution (CSV, JSON, NPZ; the
  acceleration is the feed-forward the CiA 402 export turns into a torque offset);
* ``counts_<joint>`` — absolute motor-encoder counts
  ``round(q_k x counts_per_rad x sign)`` with ``counts_per_rad = pulses_per_rev x decoding x
  ratio / (2 pi)`` (drives.toml; the profile may override the decoding) — computed from the
  exact position of each cycle, never by summing rounded increments, so it cannot drift;
* ``dcounts_<joint>`` — counts of this cycle, ``counts_k - counts_{k-1}`` (0 on cycle 0): the
  pulses the DDA card emits during cycle k (SHU controller paper, §1: one pulse = one
  position-command step).

``counts_0 + cumsum(dcounts) == counts`` exactly, and ``counts / (counts_per_rad sign)`` is within
half a count of the planned position. Rounding is to nearest, ties to even (``numpy.rint``).
Zero counts is the joint's zero position (the homing reference).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from armlab._keywords import renamed_keywords
from armlab.deploy import formats
from armlab.deploy.checks import PreflightReport, preflight
from armlab.deploy.formats import DECIMALS, READABLE_SETPOINT_FORMATS, SETPOINTS_FORMAT
from armlab.deploy.provenance import armlab_version, trajectory_sha256
from armlab.errors import InputError
from armlab.io import atomic_write_many
from armlab.names import check_name, check_names
from armlab.robot.controller import load_profile

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "SetpointTable",
    "setpoint_table",
    "read_setpoints",
    "SETPOINTS_FORMAT",
    "DECIMALS",
]


def _round(x: np.ndarray) -> np.ndarray:
    return np.rint(x * 10.0**DECIMALS) / 10.0**DECIMALS


@dataclass
class SetpointTable:
    """A checked set-point table (see the module docstring for the columns).

    Attributes
    ----------
    robot : str
    joint_names : list of str
        Joint of each controller axis (profile axis order).
    cycle_s : float
        Controller period in [s].
    cycle : int array (n_cycles,)
    t_s : array (n_cycles,)
        Cycle times in [s].
    q_rad, qd_rad_s : arrays (n_cycles, n_axes)
        Planned positions [rad] and velocities [rad/s] (1e-9 resolution).
    counts, dcounts : int64 arrays (n_cycles, n_axes)
        Absolute motor-encoder counts and counts this cycle.
    counts_per_rad : array (n_axes,)
        Encoder counts per joint radian.
    axis_sign : int array (n_axes,)
    meta : dict
        Provenance and profile: format, robot, profile, max_pulses_per_cycle, trajectory_sha256,
        trajectory_method, armlab_version, source, preflight (JSON-able).
    preflight : PreflightReport or None
        The checks that passed (None for a table read back from a file).
    qdd_rad_s2 : array (n_cycles, n_axes) or None
        Planned accelerations [rad/s^2] (1e-9 resolution); None for a table read from a file
        of format ``armlab.setpoints/1``, which had none.
    """

    robot: str
    joint_names: list[str]
    cycle_s: float
    cycle: np.ndarray
    t_s: np.ndarray
    q_rad: np.ndarray
    qd_rad_s: np.ndarray
    counts: np.ndarray
    dcounts: np.ndarray
    counts_per_rad: np.ndarray
    axis_sign: np.ndarray
    meta: dict = field(default_factory=dict)
    preflight: PreflightReport | None = None
    qdd_rad_s2: np.ndarray | None = None

    # ------------------------------------------------------------------ facts
    @property
    def n_cycles(self) -> int:
        return int(self.cycle.size)

    @property
    def n_axes(self) -> int:
        return len(self.joint_names)

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1] - self.t_s[0]) if self.n_cycles else 0.0

    @property
    def counts_per_joint_rev(self) -> np.ndarray:
        """Encoder counts per joint revolution per axis (pulses x decoding x ratio)."""
        return self.counts_per_rad * 2.0 * math.pi

    @property
    def trajectory_sha256(self) -> str:
        return str(self.meta.get("trajectory_sha256", ""))

    def __repr__(self) -> str:
        return (
            f"SetpointTable(robot={self.robot!r}, n_cycles={self.n_cycles}, "
            f"cycle_s={self.cycle_s:g}, axes={self.joint_names})"
        )

    def column_names(self) -> list[str]:
        """``cycle, t_s`` then per joint ``q_<j>_rad, qd_<j>_rad_s, qdd_<j>_rad_s2, counts_<j>,
        dcounts_<j>`` (no ``qdd`` for a table without accelerations)."""
        return list(self.columns())

    def columns(self) -> dict[str, np.ndarray]:
        """Every column by name (the order of :meth:`column_names`)."""
        out = {"cycle": self.cycle, "t_s": self.t_s}
        for a, j in enumerate(self.joint_names):
            out[f"q_{j}_rad"] = self.q_rad[:, a]
            out[f"qd_{j}_rad_s"] = self.qd_rad_s[:, a]
            if self.qdd_rad_s2 is not None:
                out[f"qdd_{j}_rad_s2"] = self.qdd_rad_s2[:, a]
            out[f"counts_{j}"] = self.counts[:, a]
            out[f"dcounts_{j}"] = self.dcounts[:, a]
        return out

    def positions_from_counts(self) -> np.ndarray:
        """Joint positions [rad] the counts command: ``counts / (counts_per_rad x sign)``."""
        return self.counts / (self.counts_per_rad * self.axis_sign)

    def header_meta(self) -> dict:
        """The metadata every format carries (JSON-able)."""
        m = {
            # a table read from an old file has no accelerations: it is written in that format
            "format": SETPOINTS_FORMAT
            if self.qdd_rad_s2 is not None
            else READABLE_SETPOINT_FORMATS[0],
            "robot": self.robot,
            "joints": list(self.joint_names),
            "axis_sign": [int(s) for s in self.axis_sign],
            "cycle_s": self.cycle_s,
            "n_cycles": self.n_cycles,
            "decimals": DECIMALS,
            "counts_per_joint_rev": dict(
                zip(self.joint_names, map(float, self.counts_per_joint_rev), strict=True)
            ),
            "counts_per_rad": [float(c) for c in self.counts_per_rad],
        }
        m.update({k: v for k, v in self.meta.items() if k not in m})
        return m

    def to_dict(self) -> dict:
        """Summary for summary.json (no per-cycle data): metadata, peak pulses per cycle."""
        peak = np.abs(self.dcounts).max(axis=0) if self.n_cycles else np.zeros(self.n_axes)
        return {
            **self.header_meta(),
            "peak_pulses_per_cycle": dict(zip(self.joint_names, map(int, peak), strict=True)),
        }

    # ------------------------------------------------------------------ files
    def render(self, format: str = "csv") -> bytes:
        """The bytes of the file in ``format`` (csv, json, npz; c: the header)."""
        return formats.render_setpoints(self, format)

    def files(self, path: str | os.PathLike, format: str | None = None) -> list[tuple[Path, bytes]]:
        """``(path, bytes)`` of every file :meth:`write` writes (two for C: ``.h`` and ``.c``)."""
        path = Path(path)
        return formats.setpoint_files(self, path, formats.setpoints_format(path, format))

    def write(self, path: str | os.PathLike, format: str | None = None) -> Path:
        """Write the table atomically (temporary files in the same folder, then rename).

        Parameters
        ----------
        path : path
        format : {"csv", "json", "npz", "c"}, optional
            Default: from the suffix (.csv, .json, .npz, .h), else csv. CSV: DESIGN.md columns
            after ``#`` header lines (robot, cycle period, counts per joint revolution,
            trajectory sha256, armlab version, and the full metadata as one JSON line). JSON:
            ``{"format", "meta", "columns": {name: [...]}}``. NPZ: one array per quantity plus
            ``meta_json``. C: the header at ``path`` (``#define`` metadata, ``extern``
            declarations) and the data file ``path`` with suffix ``.c`` (the count arrays, each
            in the narrowest ``<stdint.h>`` type that holds it).

        Returns
        -------
        Path
            ``path`` (for C: the header; the data file is next to it).
        """
        return atomic_write_many(self.files(path, format))[0]


def _check_names(robot, trajectory) -> None:
    if trajectory.n_joints != robot.n_joints:
        raise InputError(
            f"trajectory has {trajectory.n_joints} joints, robot {robot.name} has {robot.n_joints}"
        )
    generic = [f"joint{i + 1}" for i in range(trajectory.n_joints)]
    names = list(trajectory.joint_names)
    if names != list(robot.joint_names) and names != generic:
        raise InputError(
            f"trajectory joints {names} are not robot {robot.name}'s {list(robot.joint_names)}"
        )


@renamed_keywords(profile="controller=")
def setpoint_table(
    robot: Robot, trajectory, controller, *, q_current=None, source: dict | None = None
) -> SetpointTable:
    """Sample a trajectory at the controller's cycle, convert to encoder counts, check it.

    Parameters
    ----------
    robot : Robot
        Limits (range, speed, acceleration) and drives (encoder, reducer) come from it.
    trajectory : Trajectory
        Evaluated at ``t_0 + k T`` by its own interpolation (``Trajectory.at``).
    controller : ControllerProfile, str or path
        The joint controller (:func:`load_profile`; e.g. ``"reference_dda"``, the DDA
        controller of the SHU controller paper).
    q_current : array (n_joints,), optional
        The robot's current pose [rad] (robot joint order): the table must start there (within
        the profile's ``start_tolerance_counts``).
    source : dict, optional
        Provenance recorded in the metadata (e.g. ``{"file": ..., "sha256": ...}``).

    Returns
    -------
    SetpointTable

    Raises
    ------
    LimitViolation
        A pre-flight check fails (:mod:`armlab.deploy.checks`): the message names the first
        failing cycle, joint and limit; ``error.failure`` holds the details.
    InputError
        Joint mismatch, bad ``q_current``, a robot without drives and a profile without counts.
    """
    prof = load_profile(controller)
    _check_names(robot, trajectory)
    index, sign = prof.axes(robot)
    cpr = prof.counts_per_rad(robot, index)  # Drive.counts_per_rad with its decoding
    names = [robot.joint_names[i] for i in index]
    T = prof.cycle_s
    n_steps = max(0, int(math.ceil(trajectory.duration / T - 1e-9)))
    cycle = np.arange(n_steps + 1, dtype=np.int64)
    times = trajectory.t[0] + cycle * T
    q_all, qd_all, qdd_all, _ = trajectory.at(times)
    q, qd, qdd = q_all[:, index], qd_all[:, index], qdd_all[:, index]
    qc = None
    if q_current is not None:
        qc = np.asarray(q_current, dtype=float).reshape(-1)
        if qc.shape != (robot.n_joints,):
            raise InputError(
                f"q_current has shape {np.shape(q_current)}, expected "
                f"({robot.n_joints},) for {robot.name}"
            )
        qc = qc[index]
    with np.errstate(invalid="ignore", over="ignore"):
        counts_exact = q * (cpr * sign)
        finite = np.all(np.isfinite(counts_exact)) and np.all(np.abs(counts_exact) < 2**62)
    counts = dcounts = None
    if finite:
        counts = np.rint(counts_exact).astype(np.int64)
        dcounts = np.zeros_like(counts)
        dcounts[1:] = np.diff(counts, axis=0)
    report = preflight(
        t_s=times,
        q=q,
        qd=qd,
        qdd=qdd,
        counts_exact=counts_exact,
        dcounts=dcounts,
        limits=robot.limits.subset(index),
        counts_per_rad=cpr,
        cycle_s=T,
        max_pulses_per_cycle=prof.max_pulses_per_cycle,
        q_current=qc,
        start_tolerance_counts=prof.start_tolerance_counts,
        speed_tolerance=prof.speed_tolerance,
        continuity_tolerance=prof.continuity_tolerance,
    )
    report.raise_if_failed()
    # non-finite or huge counts fail the "finite" or "counter range" check above
    assert counts is not None and dcounts is not None
    meta = {
        "profile": prof.name,
        "max_pulses_per_cycle": prof.max_pulses_per_cycle,
        "trajectory_sha256": trajectory_sha256(trajectory),
        "trajectory_method": trajectory.method,
        "armlab_version": armlab_version(),
        "preflight": {"ok": True, "checks": list(report.checks), "peak_ratio": report.peak_ratio},
    }
    if source is not None:
        meta["source"] = dict(source)
    return SetpointTable(
        robot=robot.name,
        joint_names=names,
        cycle_s=T,
        cycle=cycle,
        t_s=_round(times),
        q_rad=_round(q),
        qd_rad_s=_round(qd),
        counts=counts,
        dcounts=dcounts,
        counts_per_rad=cpr,
        axis_sign=sign,
        meta=meta,
        preflight=report,
        qdd_rad_s2=_round(qdd),
    )


def read_setpoints(path: str | os.PathLike) -> SetpointTable:
    """Read a set-point table written by :meth:`SetpointTable.write` (CSV, JSON or NPZ).

    Raises
    ------
    InputError
        Missing file, unknown suffix, not an armlab set-point file, inconsistent columns.
    """
    meta, cols = formats.read_setpoints_file(Path(path))
    return _table_from_columns(meta, cols, str(path))


def _table_from_columns(meta: dict, cols: dict[str, np.ndarray], where: str) -> SetpointTable:
    """Build a table from metadata and named columns (used by the readers)."""
    try:
        joints = list(meta["joints"])
        cycle_s = float(meta["cycle_s"])
        cpr = np.asarray(meta["counts_per_rad"], dtype=float)
        sign = np.asarray(meta["axis_sign"], dtype=np.int64)
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{where}: metadata lacks {exc}") from None
    # a table read back may be written again (C, YAML): its names keep the name policy too
    check_names(joints, "joint name", where)
    if meta.get("robot"):
        check_name(meta["robot"], "robot name", where)

    def col(name: str, integer: bool) -> np.ndarray:
        if name not in cols:
            raise InputError(f"{where}: no column {name!r}")
        a = np.asarray(cols[name])
        if integer:
            ai = np.rint(a).astype(np.int64) if a.dtype.kind == "f" else a.astype(np.int64)
            if a.dtype.kind == "f" and not np.array_equal(ai, a):
                raise InputError(f"{where}: column {name} is not integral")
            return ai
        return a.astype(float)

    def per(pat: str, integer: bool) -> np.ndarray:
        if not joints:
            return np.zeros((0, 0))
        return np.column_stack([col(pat.format(j), integer) for j in joints])

    table = SetpointTable(
        robot=str(meta.get("robot", "")),
        joint_names=joints,
        cycle_s=cycle_s,
        cycle=col("cycle", True),
        t_s=col("t_s", False),
        q_rad=per("q_{}_rad", False),
        qd_rad_s=per("qd_{}_rad_s", False),
        counts=per("counts_{}", True),
        dcounts=per("dcounts_{}", True),
        # format /1 files have no accelerations; /2 files must have them
        qdd_rad_s2=per("qdd_{}_rad_s2", False) if meta.get("format") == SETPOINTS_FORMAT else None,
        counts_per_rad=cpr,
        axis_sign=sign,
        meta={
            k: v
            for k, v in meta.items()
            if k
            not in (
                "format",
                "robot",
                "joints",
                "axis_sign",
                "cycle_s",
                "n_cycles",
                "decimals",
                "counts_per_joint_rev",
                "counts_per_rad",
            )
        },
    )
    if "n_cycles" in meta and int(meta["n_cycles"]) != table.n_cycles:
        raise InputError(
            f"{where}: header says {meta['n_cycles']} cycles, file holds "
            f"{table.n_cycles} (truncated?)"
        )
    return table
