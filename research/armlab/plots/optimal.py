"""Figures of optimised motions: joint profiles against the request's limits, torque ratio
over time, and the phase plane ``sd(s)`` of a time-optimal path parameterisation.

Every function returns a :class:`matplotlib.figure.Figure` made by pyplot (Jupyter shows it;
:func:`armlab.plots.offscreen` for files only).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import InputError
from armlab.plots._figure import fixed_layout, new_figure

if TYPE_CHECKING:  # matplotlib is imported when a plot is drawn, not with the package
    from matplotlib.figure import Figure

    from armlab.robot.model import Robot

__all__ = ["plot_limit_profiles", "plot_torque_ratio", "plot_phase_plane"]

_ROWS = (
    ("q", "position [rad]", None),
    ("qd", "velocity [rad/s]", "velocity_rad_s"),
    ("qdd", "acceleration [rad/s$^2$]", "acceleration_rad_s2"),
    ("qddd", "jerk [rad/s$^3$]", "jerk_rad_s3"),
)


def _limits_of(traj, robot) -> dict:
    """``{field: {joint: value}}`` (:meth:`Limits.to_dict`): the limits the planner used, else
    the robot's."""
    if "limits" in traj.meta:
        return traj.meta["limits"]
    if robot is None:
        return {}
    return robot.limits.to_dict()


def plot_limit_profiles(
    traj, robot: Robot | None = None, *, dt: float | None = None, title: str | None = None
) -> Figure:
    """Joint position, velocity, acceleration and jerk over time with their limits (dashed).

    Parameters
    ----------
    traj : Trajectory
        Typically from :func:`~armlab.trajectory.optimal` or
        :func:`~armlab.trajectory.time_optimal_path` (their ``meta["limits"]`` are drawn).
    robot : Robot, optional
        Source of the limits when the trajectory does not carry them.
    dt : float, optional
        Resample step [s] for smooth curves (default ``duration / 1500``).
    """
    step = dt or max(traj.duration / 1500, 1e-6)
    times = traj.t[0] + np.arange(0.0, traj.duration + step / 2, step)
    q, qd, qdd, qddd = traj.at(times)  # on the planner's own knots: exact piecewise values
    signals = {"q": q, "qd": qd, "qdd": qdd, "qddd": qddd}
    t_rel = times - traj.t[0]
    limits = _limits_of(traj, robot)
    fig = new_figure(figsize=(9, 9))
    axes = fig.subplots(4, 1, sharex=True)
    fixed_layout(fig, 4, 1, left=0.95, right=0.25, top=0.6, bottom=0.6, hgap=0.2)
    for ax, (key, label, lim_name) in zip(axes, _ROWS, strict=True):
        lim = limits.get(lim_name) if lim_name else None
        for j, name in enumerate(traj.joint_names):
            color = f"C{j % 10}"
            ax.plot(t_rel, signals[key][:, j], color=color, lw=1.2, label=name)
            if lim and lim.get(name) is not None and np.isfinite(lim[name]):
                for sign in (1, -1):
                    ax.axhline(sign * lim[name], color=color, lw=0.7, ls="--", alpha=0.6)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(ncol=min(traj.n_joints, 6), fontsize=8, loc="upper right")
    axes[-1].set_xlabel("time [s]")
    if "waypoint_times_s" in traj.meta:
        for ax in axes:
            for tw in traj.meta["waypoint_times_s"]:
                ax.axvline(tw, color="k", lw=0.5, alpha=0.4)
    fig.suptitle(title or f"{traj.method}: {traj.duration:.3f} s")
    return fig


def plot_torque_ratio(
    traj, robot: Robot, *, dt: float | None = None, tau_max=None, title: str | None = None
) -> Figure:
    """``|tau_i(t)| / tau_max,i`` for every joint (inverse dynamics, payload included).

    Parameters
    ----------
    traj : Trajectory
    robot : Robot
        Dynamics (its payload) and, by default, its effort limits.
    tau_max : array (n_joints,), optional
        Torque limits in [N m] (default: the planner's ``meta["limits"]``, else the robot's).
    """
    fine = traj.sample(dt or max(traj.duration / 1500, 1e-6))
    tau = fine.torques(robot)
    if tau_max is None:
        lim = _limits_of(traj, robot).get("torque_Nm")
        tau_max = np.array([lim[n] for n in traj.joint_names]) if lim else robot.limits.torque_Nm
        if tau_max is None:
            raise InputError(f"{robot.name} has no torque limit: pass tau_max in [N m]")
    tau_max = np.asarray(tau_max, float)
    if tau_max.shape != (traj.n_joints,):
        raise InputError(f"tau_max has shape {tau_max.shape}, expected ({traj.n_joints},)")
    ratio = np.abs(tau) / tau_max
    fig = new_figure(figsize=(9, 4))
    ax = fig.subplots()
    fixed_layout(fig, 1, 1, left=0.8, right=0.25, top=0.45, bottom=0.6)
    for j, name in enumerate(traj.joint_names):
        ax.plot(
            fine.t,
            ratio[:, j],
            color=f"C{j % 10}",
            lw=1.2,
            label=f"{name} (peak {ratio[:, j].max():.3f})",
        )
    ax.axhline(1.0, color="k", ls="--", lw=1.0)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(r"$|\tau| / \tau_{max}$")
    ax.set_ylim(0, max(1.1, float(ratio.max()) * 1.05))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=3, loc="upper right")
    ax.set_title(title or "torque ratio")
    return fig


def plot_phase_plane(traj_or_problem, *, title: str | None = None) -> Figure:
    """Phase plane of a path parameterisation: ``sd(s)`` with its limit curves.

    Draws the solution, the velocity-limit curve ``min_i v_i / |q_i'(s)|`` and the maximum
    velocity curve of all limits (largest ``sd`` for which some ``sdd`` satisfies every
    acceleration and torque limit; Verscheure et al. 2009 fig. 2 style).

    Parameters
    ----------
    traj_or_problem : Trajectory or ToppProblem
        A result of :func:`~armlab.trajectory.time_optimal_path` (its ``meta["topp"]``).
    """
    prob = getattr(traj_or_problem, "meta", {}).get("topp", traj_or_problem)
    if not hasattr(prob, "limit_curves"):
        raise InputError("plot_phase_plane needs a time_optimal_path result (meta['topp'])")
    curves = prob.limit_curves()
    fig = new_figure(figsize=(9, 4.5), constrained_layout=True)
    ax = fig.subplots()
    s = curves["s"]
    ax.plot(s, curves["velocity"], color="C1", ls="--", lw=1.2, label="velocity limit curve")
    ax.plot(
        s, curves["all"], color="C3", ls=":", lw=1.5, label="maximum velocity curve (all limits)"
    )
    traj = traj_or_problem if hasattr(traj_or_problem, "meta") else None
    if traj is not None and "s" in traj.meta:
        ax.plot(
            traj.meta["s"],
            traj.meta["sd"],
            color="C0",
            lw=1.6,
            label=rf"solution ($T$ = {traj.duration:.3f} s)",
        )
    elif "b" in getattr(prob, "stats", {}):
        ax.plot(s, np.sqrt(prob.stats["b"]), color="C0", lw=1.6, label="solution")
    top = np.nanmax(np.where(np.isfinite(curves["velocity"]), curves["velocity"], np.nan))
    if np.isfinite(top):
        ax.set_ylim(0, 1.15 * top)
    ax.set_xlabel("path parameter s [-]")
    ax.set_ylabel(r"$\dot s$ [1/s]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    ax.set_title(title or "phase plane")
    return fig
