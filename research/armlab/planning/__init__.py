"""Motion planners: each returns a :class:`armlab.trajectory.Trajectory`.

=====================  ===============================================================
module                 planners
=====================  ===============================================================
:mod:`.ptp`            time- or phase-synchronised point-to-point (velocity step,
                       trapezoid, S-curve; Jiang 1987, HEU thesis 6.2)
:mod:`.steps`          the SHU controller paper's per-period trapezoid step table
:mod:`.via_points`     cubic and quintic splines through via points (HEU thesis 6.2.3)
:mod:`.paths`          Cartesian path geometry: line, arc, blended chain
:mod:`.cartesian`      Cartesian motions timed along those paths through IK (Li, Meng,
                       Chen; HEU thesis 6.3)
:mod:`.online`         the online interpolator with speed override (Li, Meng, Chen)
:mod:`.optimiser`      time-synchronised optimal trajectories (:func:`optimal`): the
                       problem (:mod:`.optimal_problem`), its bounds
                       (:mod:`.optimal_bounds`), transcription (:mod:`.transcription`)
                       and warm start (:mod:`.optimal_warmstart`, :mod:`.warmstart`);
                       ``clearance=``: plans that keep clear of obstacles, the floor
                       and the arm itself (:mod:`.optimal_clearance`, issue 27)
:mod:`.topp`           time-optimal path parameterisation along a fixed joint path
                       (:func:`time_optimal_path`): the path (:mod:`.topp_path`), the
                       problem (:mod:`.topp_problem`), its first pass
                       :mod:`.reachability` (Pham & Pham 2018; :mod:`.topp_convex` with
                       the motor envelope), the jerk pass (:mod:`.topp_jerk`);
                       with the Cartesian planners it takes ``clearance=``: the
                       plan's clearance reported, a plan too close refused
                       (:mod:`.keep_clear`)
:mod:`.timescale`      the back-offs: stretch a plan in time until every limit holds
                       (classical planners); re-solve with tightened limits
                       (``backoff_solve``: optimal, topp); the one rule of a held
                       torque over its limit (``held_over_limit``)
=====================  ===============================================================

Limits come from :func:`armlab.robot.resolve_limits` (the robot's, overridden per call);
waypoints are checked by :func:`armlab.trajectory.validate_waypoints`; trapezoid and double-S
timing (PTP, steps, Cartesian, the optimiser's warm start) is
:mod:`armlab.trajectory.profiles`.
"""

from armlab.planning.cartesian import arc3, blend, follow_path, line
from armlab.planning.online import OnlineInterpolator
from armlab.planning.optimiser import optimal
from armlab.planning.path_ik import track_path
from armlab.planning.paths import ArcPath, BlendPath, CartesianPath, JointPath, LinePath
from armlab.planning.ptp import ptp_sync
from armlab.planning.steps import trapezoid_steps
from armlab.planning.topp import time_optimal_path
from armlab.planning.via_points import cubic_via, quintic_via

__all__ = [
    "ArcPath",
    "BlendPath",
    "CartesianPath",
    "JointPath",
    "LinePath",
    "OnlineInterpolator",
    "arc3",
    "blend",
    "cubic_via",
    "follow_path",
    "line",
    "optimal",
    "ptp_sync",
    "quintic_via",
    "time_optimal_path",
    "track_path",
    "trapezoid_steps",
]
