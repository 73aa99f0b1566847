"""Figures of planned motions: joint signals over time, the tool path in 3-D, online runs.

Every function returns a :class:`matplotlib.figure.Figure` made by pyplot (Jupyter shows it;
:func:`armlab.plots.offscreen` for files only).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from armlab.plots._figure import fixed_layout, new_figure

if TYPE_CHECKING:  # matplotlib is imported when a plot is drawn, not with the package
    from matplotlib.figure import Figure

    from armlab.robot.model import Robot

__all__ = ["plot_joints", "plot_tcp_path", "plot_online"]


def plot_joints(
    traj, robot: Robot | None = None, *, limits: bool = True, title: str | None = None
) -> Figure:
    """Joint positions [rad], velocities [rad/s] and accelerations [rad/s^2] over time.

    Parameters
    ----------
    traj : Trajectory
    robot : Robot, optional
        With ``limits=True``, the velocity and acceleration limits are drawn dashed.
    """
    fig = new_figure(figsize=(9, 7.5), constrained_layout=True)
    axes = fig.subplots(3, 1, sharex=True)
    rows = [
        ("q", traj.q, "position [rad]", None),
        ("qd", traj.qd, "velocity [rad/s]", "velocity_rad_s"),
        ("qdd", traj.qdd, "acceleration [rad/s$^2$]", "acceleration_rad_s2"),
    ]
    colors = [f"C{i}" for i in range(traj.n_joints)]
    for ax, (_, y, label, lim_name) in zip(axes, rows, strict=True):
        for j in range(traj.n_joints):
            ax.plot(traj.t, y[:, j], color=colors[j], lw=1.2, label=traj.joint_names[j])
            if robot is not None and limits and lim_name is not None:
                lim = getattr(robot.limits, lim_name)
                if lim is not None and np.isfinite(lim[j]):
                    for sign in (1, -1):
                        ax.axhline(sign * lim[j], color=colors[j], lw=0.6, ls="--", alpha=0.5)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(ncol=min(traj.n_joints, 6), fontsize=8, loc="upper right")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title or f"{traj.method or 'trajectory'}: {traj.duration:.3g} s")
    return fig


def plot_tcp_path(robot: Robot, traj, taught_points=None, *, title: str | None = None) -> Figure:
    """Path of the tool centre point in 3-D (forward kinematics of every sample), with the
    taught points (default ``traj.meta["taught_points"]``) marked."""
    from armlab.kinematics import fk_batch

    P = fk_batch(robot, traj.q)[:, :3, 3]
    pts = traj.meta.get("taught_points") if taught_points is None else taught_points
    fig = new_figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    fixed_layout(fig, 1, 1, left=0.3, right=0.3, top=0.4, bottom=0.3)
    ax.plot(P[:, 0], P[:, 1], P[:, 2], lw=1.5, label="tool centre point")
    ax.scatter(*P[0], color="g", s=30, label="start")
    ax.scatter(*P[-1], color="r", s=30, label="end")
    if pts is not None and len(pts):
        T = np.asarray(pts, float).reshape(-1, 3)
        ax.scatter(T[:, 0], T[:, 1], T[:, 2], marker="x", color="k", s=50, label="taught points")
        ax.plot(T[:, 0], T[:, 1], T[:, 2], color="k", lw=0.5, ls=":")
    span = np.ptp(P, axis=0).max() / 2 or 0.05
    mid = (P.max(axis=0) + P.min(axis=0)) / 2
    ax.set_xlim(mid[0] - span, mid[0] + span)
    ax.set_ylim(mid[1] - span, mid[1] + span)
    ax.set_zlim(mid[2] - span, mid[2] + span)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.legend(fontsize=8)
    ax.set_title(title or f"{traj.method or 'trajectory'}: tool path")
    return fig


def plot_online(run, *, title: str | None = None) -> Figure:
    """Arc length, speed and override of an :class:`OnlineRun` over time."""
    fig = new_figure(figsize=(8, 6), constrained_layout=True)
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True)
    ax1.plot(run.t, run.s)
    ax1.set_ylabel("s")
    ax2.plot(run.t, run.v)
    ax2.set_ylabel("speed [unit/s]")
    ax3.step(run.t, 100 * run.override, where="pre")
    ax3.set_ylabel("override [%]")
    ax3.set_xlabel("time [s]")
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3)
    fig.suptitle(title or "online interpolator")
    return fig
