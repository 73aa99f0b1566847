"""Drive sizing: every joint's motor, reducer and encoder checked along a duty cycle.

``size(robot, trajectories)`` runs inverse dynamics along the trajectories (a duty cycle) and
checks each joint's drive train (``robot.drives``, from drives.toml, or the ``drives`` given)
with the checks of :func:`armlab.dynamics.checks.evaluate_checks`: the thesis rule (table 4.3),
the harmonic-reducer makers' peak / average (cubic-mean) torque and input-speed limits, the
motor's RMS and peak torque, speed and speed-torque envelope, the encoder resolution, the
winding temperature over the cycle repeated with its dwell (:mod:`armlab.dynamics.thermal`) and,
when the user sets a rule, the load-to-motor inertia ratio, and, with an amplifier, its currents
and the braking energy (:mod:`armlab.dynamics.regeneration`). Each check is
``{name, value, limit, margin, ok}``; a failing check is a result, not an error.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from armlab._keywords import renamed_keywords
from armlab.dynamics.checks import (
    Check,
    Checked,
    SizingOptions,
    checks_for_column,
    counts_per_joint_rev_of,
    evaluate_checks,
)
from armlab.dynamics.inverse import (
    RAD_S_TO_RPM,
    JointLoads,
    as_trajectories,
    inverse_dynamics,
    require_drives,
)
from armlab.dynamics.reducer_life import (
    DEFAULT_REQUIRED_LIFE_H,
    MOMENTARY_LOADS,
    reducer_life_h,
    tilting_moments_Nm,
)
from armlab.dynamics.thermal import AMBIENT_DEGC, with_dwell
from armlab.errors import InputError
from armlab.robot import rigid_body
from armlab.robot.controller import ControllerProfile, load_profile
from armlab.robot.drives import Drive
from armlab.robot.drivetrain import DriveTrain

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["JointSizing", "SizingReport", "size", "lever_arms_m", "joint_inertias_kg_m2"]


def lever_arms_m(robot: Robot) -> np.ndarray:
    """Upper bound of each joint's distance to the tool point, (n_joints,) in [m].

    The sum of the lengths of the joint placements outboard of the joint plus the tool
    frame's offset from the last joint (exact for the stretched arm).
    """
    model = robot.model
    lengths = np.array(
        [np.linalg.norm(model.jointPlacements[k].translation) for k in range(1, model.njoints)]
    )
    tool = np.linalg.norm(model.frames[robot.tool_frame_id].placement.translation)
    # joint k's lever: links k+1.. plus the tool
    tail = np.concatenate([np.cumsum(lengths[::-1])[::-1][1:], [0.0]])
    return tail + tool


def joint_inertias_kg_m2(robot: Robot, q) -> np.ndarray:
    """The arm's inertia at each joint, the diagonal ``M_jj(q)`` of the joint-space mass matrix
    without armature (the rotor is counted on the motor side), ``(n_samples, n_joints)`` in
    [kg m^2], payload included: the inertia the tuning's range spans (:mod:`armlab.control.plant`)
    at the samples of a duty cycle (the inertia ratio of :func:`size`)."""
    M = rigid_body.mass_matrix(robot, np.atleast_2d(q))
    return np.diagonal(M, axis1=1, axis2=2) - robot.model.armature


def _finite_or_none(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


@dataclass
class JointSizing(Checked):
    """The sizing of one joint: its signals' key figures and its checks."""

    joint: str
    drive: Drive
    checks: list[Check]
    peak_torque_Nm: float
    rms_torque_Nm: float
    peak_speed_rad_s: float
    motor_peak_speed_rpm: float
    motor_peak_torque_Nm: float
    motor_rms_torque_Nm: float
    available_torque_Nm: float
    counts_per_joint_rev: float
    winding_peak_temperature_degC: float = float("nan")
    housing_temperature_degC: float = float("nan")
    inertia_ratio_min: float = float("nan")
    inertia_ratio_max: float = float("nan")
    braking_energy_J: float = float("nan")
    peak_regenerated_power_W: float = float("nan")
    reducer_life_h: float = float("nan")
    bearing_tilting_moment_Nm: float = float("nan")

    def check(self, name: str) -> Check:
        for c in self.checks:
            if c.name == name:
                return c
        raise InputError(f"{self.joint}: no check named {name!r}")

    def to_dict(self) -> dict:
        return {
            "peak_torque_Nm": self.peak_torque_Nm,
            "rms_torque_Nm": self.rms_torque_Nm,
            "peak_speed_rad_s": self.peak_speed_rad_s,
            "motor_peak_speed_rpm": self.motor_peak_speed_rpm,
            "motor_peak_torque_Nm": self.motor_peak_torque_Nm,
            "motor_rms_torque_Nm": self.motor_rms_torque_Nm,
            "available_torque_Nm": self.available_torque_Nm,
            "encoder_counts_per_joint_rev": self.counts_per_joint_rev,
            "winding_peak_temperature_degC": self.winding_peak_temperature_degC,
            "housing_temperature_degC": self.housing_temperature_degC,
            "inertia_ratio_min": self.inertia_ratio_min,
            "inertia_ratio_max": self.inertia_ratio_max,
            "braking_energy_J": self.braking_energy_J,
            "peak_regenerated_power_W": self.peak_regenerated_power_W,
            "amplifier": None if self.drive.amplifier is None else self.drive.amplifier.model,
            # NaN (no rating / not computed) -> None; inf (never turns) stays inf -> None too
            "reducer_life_h": _finite_or_none(self.reducer_life_h),
            "bearing_tilting_moment_Nm": _finite_or_none(self.bearing_tilting_moment_Nm),
            "motor": self.drive.motor.model,
            "reducer": self.drive.reducer.model,
            "ok": self.ok,
            "binding_check": self.binding.name,
            "checks": [c.to_dict() for c in self.checks],
        }


@dataclass
class SizingReport:
    """Result of :func:`size`: one :class:`JointSizing` per joint and the loads behind them.

    ``ok`` is True when every check of every joint passes; ``failures()`` lists
    ``(joint, check name)``; ``to_dict()`` gives the summary.json block (per joint:
    ``peak_torque_Nm, rms_torque_Nm, peak_speed_rad_s, motor_peak_speed_rpm, checks`` ...);
    ``to_markdown()`` a table, with the thesis' table 4.3 beside it for teachbot6.
    """

    robot_name: str
    joint_names: list[str]
    payload_kg: float
    duration_s: float
    n_samples: int
    joints: list[JointSizing]
    options: SizingOptions
    loads: JointLoads | None = field(default=None, repr=False)

    @property
    def ok(self) -> bool:
        return all(j.ok for j in self.joints)

    def failures(self) -> list[tuple[str, str]]:
        """``(joint, check name)`` of every failing check."""
        return [(j.joint, c.name) for j in self.joints for c in j.checks if not c.ok]

    def joint(self, name) -> JointSizing:
        for j in self.joints:
            if j.joint == name:
                return j
        raise InputError(
            f"no joint {name!r} in the sizing report (joints: {', '.join(self.joint_names)})"
        )

    def to_dict(self) -> dict:
        return {j.joint: j.to_dict() for j in self.joints}

    def to_markdown(self) -> str:
        from armlab.dynamics.reference import sizing_markdown

        return sizing_markdown(self)


@renamed_keywords(options="controller= (and tool_resolution_m=)")
def size(
    robot: Robot,
    trajectory,
    *,
    controller: ControllerProfile | str,
    drives=None,
    tool_resolution_m: float = SizingOptions.tool_resolution_m,
    dt: float | None = None,
    threads: int = 1,
    dwell_s: float = 0.0,
    cycles: int | None = None,
    ambient_degC: float = AMBIENT_DEGC,
    max_inertia_ratio: float = float("inf"),
    required_life_h: float = DEFAULT_REQUIRED_LIFE_H,
    momentary_load: str = "plan",
) -> SizingReport:
    """Check every joint's drive train along a trajectory or a duty cycle of trajectories.

    Parameters
    ----------
    robot : Robot
        With drives (drives.toml) unless ``drives`` is given; payload included.
    trajectory : Trajectory or sequence of Trajectory
        The duty cycle (trajectories are stacked; peaks, RMS and averages run over all).
    controller : ControllerProfile or str
        The joint controller the set-point table is written for
        (:func:`armlab.robot.load_profile`): the encoder checks use its cycle, pulse limit and
        decoding (:class:`SizingOptions`).
    drives : dict of joint name to Drive, or list of Drive, optional
        Drive trains to check instead of ``robot.drives``.
    tool_resolution_m : float
        Largest tool-point displacement of one encoder count [m] (:class:`SizingOptions`).
    dt : float, optional
        Resample every trajectory on this grid [s] first (catches peaks between knots).
    threads : int
        Threads of the batched RNEA.
    dwell_s, cycles, ambient_degC, max_inertia_ratio
        The duty cycle's rest at its last pose [s] (part of the cycle: RMS and thermal check),
        the thermal check's cycles (None: periodic) and ambient [degC], and the inertia-ratio
        rule (inf: reported, not checked): :class:`SizingOptions`.
    required_life_h : float
        Life the reducers must reach over the duty cycle, [h] (``[sizing] required_life_h``;
        :mod:`armlab.dynamics.reducer_life`).
    momentary_load : {"plan", "stop"}
        Load case of the momentary-torque check (:class:`SizingOptions`).

    Returns
    -------
    SizingReport

    Raises
    ------
    InputError
        Not a trajectory, wrong joint count, NaN samples.
    RobotDescriptionError
        The robot has no drives and none are given.
    """
    if momentary_load not in MOMENTARY_LOADS:
        raise InputError(
            f"momentary_load must be one of {', '.join(MOMENTARY_LOADS)}, not {momentary_load!r}"
        )
    options = SizingOptions(
        load_profile(controller),
        tool_resolution_m,
        required_life_h=float(required_life_h),
        momentary_load=momentary_load,
        dwell_s=dwell_s,
        cycles=cycles,
        ambient_degC=ambient_degC,
        max_inertia_ratio=max_inertia_ratio,
    )
    drive_list = require_drives(robot, drives)
    trajs = as_trajectories(trajectory, robot)
    if dt is not None:
        trajs = [tr.sample(dt) for tr in trajs]
    trajs = with_dwell(trajs, options.dwell_s)
    loads = inverse_dynamics(robot, trajs, drives=drive_list, threads=threads)
    arrays = DriveTrain.from_drives(drive_list)
    figures: dict[str, np.ndarray] = {}
    # the tilting moments only where a reducer has a bearing rating (an RNEA pass per sample)
    rated = any(np.isfinite(d.reducer.bearing_moment_rating_Nm) for d in drive_list)
    offsets = [d.reducer.bearing_offset_m for d in drive_list]
    tilt = tilting_moments_Nm(robot, loads, offsets) if rated else None
    results = evaluate_checks(
        loads.torque_Nm,
        loads.qd,
        loads.qdd,
        loads.weights,
        arrays,
        lever_arms_m(robot),
        options,
        joint_inertia_kg_m2=joint_inertias_kg_m2(robot, loads.q),
        figures=figures,
        tilt_Nm=tilt,
    )
    life = reducer_life_h(loads.torque_Nm, loads.qd, loads.weights, arrays)
    counts_per_rev = counts_per_joint_rev_of(arrays, options.controller)
    peak_t, rms_t, peak_v = loads.peak_torque_Nm, loads.rms_torque_Nm, loads.peak_speed_rad_s
    m_peak, m_rms = loads.motor_peak_torque_Nm, loads.motor_rms_torque_Nm
    # drives given: inverse_dynamics computed the motor-side signals
    assert m_peak is not None and m_rms is not None and loads.motor_speed_rad_s is not None
    m_speed = np.abs(loads.motor_speed_rad_s).max(axis=0) * RAD_S_TO_RPM
    joints = []
    for j, name in enumerate(robot.joint_names):
        d = drive_list[j]
        joints.append(
            JointSizing(
                joint=name,
                drive=d,
                checks=checks_for_column(results, j, drives=arrays),
                peak_torque_Nm=float(peak_t[j]),
                rms_torque_Nm=float(rms_t[j]),
                peak_speed_rad_s=float(peak_v[j]),
                motor_peak_speed_rpm=float(m_speed[j]),
                motor_peak_torque_Nm=float(m_peak[j]),
                motor_rms_torque_Nm=float(m_rms[j]),
                available_torque_Nm=float(d.available_torque_Nm),
                counts_per_joint_rev=float(counts_per_rev[j]),
                winding_peak_temperature_degC=float(figures["winding_peak_temperature_degC"][j]),
                housing_temperature_degC=float(figures["housing_temperature_degC"][j]),
                inertia_ratio_min=float(figures["inertia_ratio_min"][j]),
                inertia_ratio_max=float(figures["inertia_ratio_max"][j]),
                braking_energy_J=float(figures["braking_energy_J"][j]),
                peak_regenerated_power_W=float(figures["peak_regenerated_power_W"][j]),
                reducer_life_h=float(life[j]),
                bearing_tilting_moment_Nm=float(tilt[j]) if tilt is not None else float("nan"),
            )
        )
    return SizingReport(
        robot_name=robot.name,
        joint_names=list(robot.joint_names),
        payload_kg=float(robot.payload.mass_kg),
        duration_s=loads.duration,
        n_samples=loads.n_samples,
        joints=joints,
        options=options,
        loads=loads,
    )
