"""Joint trajectories: the :class:`Trajectory` type, classical interpolators and optimisers."""

from armlab.robot.limits import Limits, resolve_limits
from armlab.trajectory.cartesian import arc3, blend, follow_path, line, track_path
from armlab.trajectory.core import LIMIT_KINDS, LimitReport, Trajectory
from armlab.trajectory.online import OnlineInterpolator, OnlineRun, OnlineSample
from armlab.trajectory.optimal import OptimalProblem, build_optimal, optimal
from armlab.trajectory.optimal_plots import (
    plot_limit_profiles,
    plot_phase_plane,
    plot_torque_ratio,
)
from armlab.trajectory.paths import ArcPath, BlendPath, CartesianPath, JointPath, LinePath
from armlab.trajectory.plots import plot_joints, plot_online, plot_tcp_path
from armlab.trajectory.polynomial import cubic_via, quintic_via
from armlab.trajectory.profiles import MotionProfile, double_s_profile, trapezoid_profile
from armlab.trajectory.ptp import ptp_sync
from armlab.trajectory.steps import StepPlan, trapezoid_steps
from armlab.trajectory.symdyn import inverse_dynamics_function
from armlab.trajectory.topp import ToppProblem, build_topp, time_optimal_path
from armlab.trajectory.waypoints import validate_waypoints

__all__ = ["Trajectory", "LimitReport", "LIMIT_KINDS", "validate_waypoints"]
__all__ += [  # classical interpolators (issue 4)
    "ptp_sync",
    "trapezoid_steps",
    "StepPlan",
    "cubic_via",
    "quintic_via",
    "line",
    "arc3",
    "blend",
    "follow_path",
    "track_path",
    "JointPath",
    "CartesianPath",
    "LinePath",
    "ArcPath",
    "BlendPath",
    "OnlineInterpolator",
    "OnlineSample",
    "OnlineRun",
    "MotionProfile",
    "trapezoid_profile",
    "double_s_profile",
    "plot_joints",
    "plot_tcp_path",
    "plot_online",
]
__all__ += [  # optimisers (issue 5)
    "optimal",
    "build_optimal",
    "OptimalProblem",
    "time_optimal_path",
    "build_topp",
    "ToppProblem",
    "Limits",
    "resolve_limits",
    "inverse_dynamics_function",
    "plot_limit_profiles",
    "plot_torque_ratio",
    "plot_phase_plane",
]
