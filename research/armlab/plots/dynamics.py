"""Plots of joint loads: torque, speed and power over time, and motor operating points on the
speed-torque plane with the DC motor's envelope. Functions return matplotlib Figures
(made by pyplot: Jupyter shows them; :func:`armlab.plots.offscreen` for files only)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from armlab.dynamics.inverse import RAD_S_TO_RPM, JointLoads, require_drives
from armlab.errors import InputError
from armlab.plots._figure import fixed_layout, new_figure
from armlab.robot import drivetrain

if TYPE_CHECKING:  # matplotlib is imported when a plot is drawn, not with armlab.dynamics
    from matplotlib.figure import Figure

    from armlab.robot.model import Robot

__all__ = ["plot_joint_loads", "plot_operating_points"]


def _joint_indices(loads: JointLoads, joints) -> list[int]:
    names = list(loads.joint_names) if joints is None else list(joints)
    unknown = [n for n in names if n not in loads.joint_names]
    if unknown:
        raise InputError(f"unknown joint(s) {unknown} (joints: {', '.join(loads.joint_names)})")
    return [loads.joint_names.index(n) for n in names]


def plot_joint_loads(loads: JointLoads, robot: Robot | None = None, *, joints=None) -> Figure:
    """Torque, speed and power over time, one row per joint, limits drawn dashed.

    Parameters
    ----------
    loads : JointLoads
        From :func:`inverse_dynamics` (or ``SizingReport.loads``).
    robot : Robot, optional
        Draws the limits: effort (available torque) and, with drives, the reducer's peak
        torque; the speed limit; the motor's table power.
    joints : sequence of str, optional
        Joints to draw (default all).
    """
    idx = _joint_indices(loads, joints)
    fig = new_figure(figsize=(11, 2.1 * len(idx) + 0.6))
    axes = fig.subplots(len(idx), 3, squeeze=False, sharex=True)
    fixed_layout(fig, len(idx), 3, left=0.95, top=0.55, hgap=0.2, wgap=0.75)
    for row, j in enumerate(idx):
        series = (
            (loads.torque_Nm[:, j], "torque [N m]"),
            (loads.qd[:, j], "speed [rad/s]"),
            (loads.power_W[:, j], "power [W]"),
        )
        for col, (y, label) in enumerate(series):
            ax = axes[row, col]
            ax.plot(loads.t, y, lw=1.0)
            ax.set_ylabel(f"{loads.joint_names[j]}\n{label}" if col == 0 else label)
            ax.grid(True, alpha=0.3)
        if robot is not None:
            lim = robot.limits
            if lim.torque_Nm is not None:
                for s in (1, -1):
                    axes[row, 0].axhline(
                        s * lim.torque_Nm[j],
                        color="C3",
                        ls="--",
                        lw=0.8,
                        label="available" if s == 1 else None,
                    )
            if robot.drives is not None:
                d = robot.drives[loads.joint_names[j]]
                for s in (1, -1):
                    axes[row, 0].axhline(
                        s * d.reducer.peak_torque_Nm,
                        color="C1",
                        ls=":",
                        lw=0.8,
                        label="reducer peak" if s == 1 else None,
                    )
                axes[row, 2].axhline(
                    d.motor.power_W, color="C3", ls="--", lw=0.8, label="motor power"
                )
            if lim.velocity_rad_s is not None:
                for s in (1, -1):
                    axes[row, 1].axhline(s * lim.velocity_rad_s[j], color="C3", ls="--", lw=0.8)
            if row == 0:
                axes[row, 0].legend(fontsize=7, loc="upper right")
    for col in range(3):
        axes[-1, col].set_xlabel("time [s]")
    fig.suptitle(f"Joint loads (payload {loads.payload_kg:g} kg)")
    return fig


def plot_operating_points(loads: JointLoads, robot: Robot, *, drives=None, joints=None) -> Figure:
    """Motor operating points on the speed-torque plane with each motor's envelope.

    The envelope (:func:`armlab.robot.drivetrain.envelope_torque`, the bound the sizing
    check and ``drive_limits`` use) is ``derating x min(T_peak, Kt (U - Ke |w|) / R)``, the
    same line in both quadrants (no credit for regeneration); the continuous (stall) torque
    and the table speed are drawn dashed.

    Parameters
    ----------
    loads : JointLoads
        With motor-side signals.
    robot : Robot
        Its drives (or ``drives``) give the motor data.
    """
    drive_list = require_drives(robot, drives)
    if loads.motor_torque_Nm is None or loads.motor_speed_rad_s is None:
        raise InputError("loads have no motor-side signals (robot without drives)")
    idx = _joint_indices(loads, joints)
    ncol = min(3, len(idx))
    nrow = int(np.ceil(len(idx) / ncol))
    fig = new_figure(figsize=(4.2 * ncol, 3.4 * nrow))
    axes = np.atleast_1d(fig.subplots(nrow, ncol, squeeze=False)).ravel()
    fixed_layout(fig, nrow, ncol, left=0.85, top=0.35, hgap=0.75, wgap=1.0)
    for ax, j in zip(axes, idx, strict=False):
        d = drive_list[j]
        arr = drivetrain.DriveTrain.from_drives([d])
        w = loads.motor_speed_rad_s[:, j]
        t = loads.motor_torque_Nm[:, j]
        w_nl = float(arr.no_load_speed_rad_s[0])
        ws = np.linspace(-w_nl, w_nl, 401)
        env = drivetrain.envelope_torque(ws[:, None], arr)[:, 0]
        ax.plot(ws * RAD_S_TO_RPM, env, color="C3", lw=1.2, label="envelope")
        ax.plot(ws * RAD_S_TO_RPM, -env, color="C3", lw=1.2)
        stall = float(d.continuous_motor_torque_Nm)
        ax.axhline(stall, color="C1", ls="--", lw=0.8, label="continuous")
        ax.axhline(-stall, color="C1", ls="--", lw=0.8)
        rated = float(arr.rated_speed_rad_s[0]) * RAD_S_TO_RPM
        ax.axvline(rated, color="C2", ls=":", lw=0.8, label="table speed")
        ax.axvline(-rated, color="C2", ls=":", lw=0.8)
        ax.plot(w * RAD_S_TO_RPM, t, ".", ms=2, color="C0", label="operating points")
        ax.set_title(f"{loads.joint_names[j]}: {d.motor.model[:28]}", fontsize=9)
        ax.set_xlabel("motor speed [rpm]")
        ax.set_ylabel("motor torque [N m]")
        ax.grid(True, alpha=0.3)
    for ax in axes[len(idx) :]:
        ax.set_visible(False)
    axes[0].legend(fontsize=7, loc="lower left")
    return fig
