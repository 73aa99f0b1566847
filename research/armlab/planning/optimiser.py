r"""Time-synchronised optimal joint trajectories through waypoints (CasADi + IPOPT).

Problem (issue 5, item 2)
-------------------------
Given joint waypoints ``w_0 .. w_{W-1}`` (start and goal at rest unless a start or goal state
is given, below; via points passed exactly or within ``via_tolerance``), find ``q(t)`` for all
joints together — one time axis, so all joints start and end together — minimising the
duration (or a fixed-duration objective) subject to, at every instant,

.. math::
    q_{lo} \le q \le q_{hi},\quad |\dot q| \le v_{max},\quad |\ddot q| \le a_{max},\quad
    |\dddot q| \le j_{max},\quad |\tau(q, \dot q, \ddot q)| \le \tau_{max},

with ``tau`` the inverse dynamics of the robot, payload included
(:mod:`armlab.robot.symbolic`).

Transcription
-------------
Each segment ``s`` between waypoints has ``N_s`` intervals of durations
``h_k = T_s f_k``: the segment duration ``T_s`` is a decision variable, the fractions ``f_k`` are
fixed by the warm start — they put nodes at the switching instants of the slowest joint's
S-curve and then halve the longest intervals. The closed-form minimum time of a rest-to-rest
motion is therefore represented exactly (not approximated on a uniform grid), the problem has
one nonconvex time variable per segment, and the warm start is an exact solution of the
integration equations below (fully free interval durations were tried: many more iterations
and poor local minima).

* **jerk mode** (a jerk limit, or the ``"jerk"`` objective): the jerk ``u_k`` is constant on each
  interval, so ``q`` is a piecewise cubic, ``qdd`` piecewise linear and ``qd`` piecewise quadratic,
  integrated exactly::

      q_{k+1}   = q_k + h qd_k + h^2/2 qdd_k + h^3/6 u_k
      qd_{k+1}  = qd_k + h qdd_k + h^2/2 u_k
      qdd_{k+1} = qdd_k + h u_k

* **acceleration mode** (no jerk limit): the acceleration ``u_k`` is constant on each interval
  (the bang-bang and trapezoid optima have acceleration jumps).

Guarantee between the nodes (every instant, not only at nodes)
----------------------------------------------------------------
* jerk: constant per interval, bounded directly — exact.
* acceleration: linear (jerk mode) or constant (acceleration mode) per interval, so its extremes
  are at the nodes — node bounds are exact.
* velocity: quadratic per interval in jerk mode. A polynomial lies in the convex hull of its
  Bernstein coefficients, so bounding ``qd_k``, ``qd_k + qdd_k h/2`` and ``qd_{k+1}`` bounds it
  everywhere (conservative by O(h^2) only where the peak is interior; tight where the profile
  cruises). Linear in acceleration mode — node bounds are exact.
* position: cubic (quadratic) per interval — its Bernstein coefficients ``q_k``,
  ``q_k + qd_k h/3``, ``q_{k+1} - qd_{k+1} h/3`` (``q_k + qd_k h/2``) are kept in the range.
* torque: nonlinear in ``q``; constrained at the nodes (both one-sided accelerations in
  acceleration mode; optionally also inside the intervals,
  ``transcription.TORQUE_INTERIOR_POINTS``). After the solve the trajectory is checked on a
  fine grid (default ``dt = T/4000``, about 100 samples per interval); a joint whose torque
  ratio exceeds ``1 + 1e-6`` has its torque limit backed off by that ratio and a margin (0.1 %)
  and the problem is re-solved from the previous solution (at most ``max_backoff`` rounds;
  :func:`armlab.planning.timescale.backoff_solve`, the loop shared with the TOPP). The
  returned trajectory's ``report`` is that fine-grid check — the torque guarantee is "on the
  fine grid", not a proof between its samples.

The returned :class:`~armlab.trajectory.Trajectory` holds the exact piecewise polynomial: its
samples are the knots (jerk mode; ``Trajectory.at`` evaluates each cubic piece exactly, and the
last knot is the goal at rest). An excess within the solver's tolerance (up to ``CHECK_TOL``) is
removed by a uniform time stretch (:mod:`armlab.planning.tolerance`; ``stats`` key
``tolerance_stretch``; where the plan passes a pose whose gravity torque alone is above a
limit -- slowing down would move the torque there towards gravity -- only the stretch the
other limits need, kept if every torque still holds after it, else none, ``stats`` key
``tolerance_stretch_skipped``; the torque rows hold ``|tau| <= (1 - TORQUE_ROW_MARGIN)
tau_max`` so that the solver's tolerance does not leave such a node above the limit). In
acceleration mode each acceleration jump is replaced by a linear ramp of
``JUMP_RAMP_S`` (50 us): the box-average of the optimum over that width, which keeps velocity,
acceleration and position within their bounds (an average stays within the range it averages),
changes positions by ``|jump| ramp^2 / 24`` (< 1e-9 rad) and adds ``JUMP_RAMP_S`` to the duration.

Back-off on a finer grid (issue 15)
-----------------------------------
The back-off lowers a joint's torque bound at every knot; it cannot reach an excess that
the knots do not see. The 4 refusals among 1 000 random 5-waypoint teachbot6 problems
(``bench_trajectory.py --success-only``) were of two kinds: (1) a slow segment (12 s, intervals of
0.74 s) whose path crosses, between two knots, a pose where joint4's gravity torque alone is
0.7 % above its limit, held there by the motion's dynamics -- each lower bound moved the knots
and the excess grew (1.000005, 1.00014, 1.00023, 1.00026 after 4 rounds); (2) the bound
lowered below the torque of a fixed end knot (gravity at rest, 0.9895 of the limit at the
start, bound 0.9833), which made the re-solve infeasible by construction (IPOPT:
``Infeasible_Problem_Detected``, the last plan kept and refused). So the first and
last knots of jerk mode, whose states are fixed, keep the request's own torque bound
(:meth:`OptimalProblem._bounds`; their torque is checked before the solve), and a plan the
back-off leaves over a limit is solved again on finer grids, twice then three times as fine
(:data:`FINER_GRIDS`; ``stats`` key ``n_intervals_raised``, as for a solve that does not
converge): the error between the knots falls with the square of the interval, and where it
lies depends on where the knots fall. Only a plan over a limit on those too is refused.

The controls the solver returns meet the integration equations to its constraint tolerance;
integrated forward they miss the goal by about that much, and the last piece, closed onto the
goal, absorbed the miss -- a jerk up to 1e-4 over its limit and a needless back-off round in
about one plan in five. The miss is now spread over every piece
(:func:`~armlab.planning.warmstart.fit_piecewise`, the smallest change in the time integral
of the squared jerk change, as for the warm start): 12 of 56 random problems lost their
back-off round, 1.8e-5 shorter at most, 7 % less solve time on average; the others changed by
less than 2e-8.

Replanning from a moving state (issue 15)
-----------------------------------------
``qd_start``, ``qdd_start`` and ``qd_goal`` (the names and checks of
:func:`~armlab.planning.ptp.ptp_sync`, as Ruckig's current velocity / acceleration and target
velocity) replace rest at the ends, so a plan can be recomputed from where the arm is now. The
boundary conditions (bounds on the first and last knots; everything else unchanged, so every
limit holds from the first sample): jerk mode -- first knot ``q = w_0``, ``qd = qd_start``,
``qdd = qdd_start``; last knot ``q = w_{W-1}``, ``qd = qd_goal``, ``qdd = 0`` (the arm leaves
the goal at constant speed, Ruckig's default target acceleration); the jerk is free at both
ends. Acceleration mode (no jerk limit, the acceleration may jump): the first sample is the
given state, then the usual ``JUMP_RAMP_S`` ramp from ``qdd_start`` to the first interval's
acceleration, the last sample is the goal at ``qd_goal``
(:meth:`OptimalProblem.boundary_states`). The fixed-duration objectives take the same
conditions. The checks before the solve (each an error naming the joint): a state above its
limit, and a start speed that the jerk limit carries past the speed limit
(``|qd0 + qdd0 |qdd0| / (2 j_max)| > v_max``, :func:`~armlab.trajectory.waypoints.check_stoppable`
as in ``ptp_sync``), are an :class:`InputError` ("brake first", the keyword named); a start
or goal state whose inverse dynamics exceed ``tau_max`` is an :class:`InfeasibleError`; a
start the limits cannot brake within the joint range is found by the solver and named the same
way. Not with ``drive_limits`` (its joints move monotonically from rest to rest). The warm start
of a replan's first and last segments is the time-synchronised jerk-limited move from the state
(:func:`~armlab.trajectory.profiles.synchronised_from_state`, Berscheid & Kröger 2021, the
method of Ruckig) on a grid that holds its switching instants, so the kinematic optimum is
represented exactly as at rest; without a jerk limit, or a start acceleration above the
warm start's acceleration scale, it is the rest-to-rest segment refitted to the state
(:meth:`OptimalProblem._warm_boundaries`). The tolerance stretch below (``k <= 1 + CHECK_TOL``,
measured ``k - 1 ~ 2e-9``) scales the boundary speeds by ``1/k``. Measured on teachbot6: against
Ruckig's exact time-optimal durations (v/a/j, one segment from a moving state, 42 random cases)
within 1e-8 (the refitted rest-to-rest warm start alone: +0.4 % median, +1.5 % max); a replan
from ``T/3`` of a plan takes the remaining ``2T/3`` within 2e-9 (Bellman's principle).

Planning inside the motor's envelope (``drive_limits=True``, issue 14)
--------------------------------------------------------------------
The motor torque the motion needs -- the drive-train model of :mod:`armlab.robot.drivetrain`:
joint friction, reducer efficiency by quadrant (motoring / back-driven), reflected rotor and
reducer inertia, motor friction -- stays within the voltage line
``|T_m| <= derating Kt (U - Ke |w_m|) / R`` (both quadrants; no credit for regeneration), within
``derating x T_peak``, and its RMS over the plan within ``derating x T_stall``; the motor speed
stays within the velocity limits (motor speed limit / ratio). The robot's torque box (the
thesis' available torque, the same motor in its static form) is then off unless ``tau_max`` is
given. The quadrant switch is handled with the **direction of motion**, known per segment from
the waypoints: each joint moves monotonically within a segment (velocity-sign bounds; a joint
whose waypoints do not change holds still, and a via point where a joint reverses is passed
with that joint at rest). With it the envelope is a set of smooth rows at the nodes
(:func:`armlab.planning.transcription._drive_rows`; exact where the bound can bind, conservative
elsewhere); the RMS row uses a smooth quadrant blend. The fine-grid check is the exact numeric
model (:func:`armlab.planning.timescale.drive_check`), and the back-off tightens the envelope
or RMS bound of a joint that exceeds it (:func:`~armlab.planning.timescale.tighten_drive`).
``stats["drive_ratios"]`` holds the final check.

Objectives: ``"time"`` (``sum T_s``, plus ``1e-7`` times the smoothness term to make the
non-binding joints' profiles unique), ``"time+smooth"`` (``T + w int sum_i (u_i/u_ref,i)^2 dt``,
``u`` the jerk — or acceleration — normalised by its limit), and, for a fixed ``duration``,
``"jerk"`` (``int sum_i (qddd_i/j_ref,i)^2 dt``) and ``"energy"`` (copper losses
``int sum_i R_i (tau_i / (k_t,i N_i eta_i))^2 dt`` in [J] from the drive train; ``int sum tau^2 dt``
when the robot has no drives file).

Warm start: the time-synchronised rest-to-rest S-curve of each segment (stopping at the via
points; :func:`armlab.trajectory.profiles.synchronised_profiles`, the timing PTP motion uses
too), refitted to be an exact piecewise polynomial on the node grid
(:mod:`armlab.planning.warmstart`) and slowed down uniformly until its torques fit.
(``armlab.trajectory.ptp_sync`` is not used: sampled on our grid its profile does not satisfy
the integration equations, and an inconsistent start measurably slowed IPOPT down.) The solver
is fatrop on stage functions compiled once per robot kinematics where it applies (jerk and
acceleration mode, every objective; :mod:`armlab.planning.fatrop_backend`, ``stats["solver"]`` and
``stats["fallback"]``), else IPOPT (CasADi SX) with the exact Hessian, by default without
the curvature of the torque-limit rows (``hessian="partial"``,
:data:`armlab.planning.transcription.HESSIANS`; where the time goes and what was measured:
``transcription`` module docstring, "Solve time"); the inverse dynamics take the inertial
parameters
as an input, so one compiled problem serves every payload of a robot (cached per kinematics,
sizes and flags).

Closed form (issue 26): between two waypoints at rest with finite v/a/j limits, no torque or
drive limit and the ``"time"`` objective, :func:`optimal` returns the time-synchronised double
S of :func:`~armlab.trajectory.profiles.synchronised_scurves` -- the problem's exact minimum
duration (:mod:`armlab.planning.optimal_closed`), ``stats["method"] = "closed_form"``, about
2 ms instead of 40-130 ms of IPOPT (teachbot6, durations within 4e-8 s of IPOPT's); every other
plan says ``"transcription"``. :func:`build_optimal` (the engine) always transcribes.

Outside the solver (issue 26): a fine-grid check is one batched RNEA pass
(:func:`armlab.robot.rigid_body.inverse_dynamics`, ``pinocchio.rneaInParallel``, about 1 us
of CPU per point on teachbot6; a CasADi map of the symbolic RNEA compiled with ``-O3`` was
measured on par, its virtual machine 4x and a Python loop over ``pinocchio.rnea`` 2x slower)
over the ~4 000-6 500 limit samples, and a plan without back-off rounds makes three: the
back-off check, the gravity torques of the tolerance stretch, and the check of the plan
handed out (the stretched one), whose samples also give ``stats["energy"]``. The warm
start's torque slow-down is one batched pass over the samples of every segment.

References: Verscheure et al., IEEE TAC 54(10) 2009 (time-optimal problems as optimisation);
Betts, *Practical Methods for Optimal Control*, 2010 (direct transcription); Farouki, CAGD 29 2012
(Bernstein convex-hull property); Jiang 1987, eq. 1-5 (time-synchronised PTP); Berscheid &
Kröger, "Jerk-limited real-time trajectory generation with arbitrary target states", RSS 2021
(the time-synchronised moves from a state, Ruckig).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import ArmlabError, InfeasibleError, InputError
from armlab.planning.optimal_closed import closed_form_applies, closed_form_optimal
from armlab.planning.optimal_closed import direct as closed_direct
from armlab.planning.optimal_problem import (
    OBJECTIVES,
    OptimalProblem,
    _BackoffStalled,
    _NotConverged,
    default_intervals,
)
from armlab.planning.timescale import (
    held_over_limit,
)
from armlab.planning.transcription import HESSIAN, HESSIANS
from armlab.robot import drivetrain, rigid_body
from armlab.robot.limits import Limits, resolve_limits
from armlab.trajectory.core import Trajectory
from armlab.trajectory.waypoints import (
    COINCIDE_RAD,
    check_stoppable,
    validate_joint_state,
    validate_waypoints,
)

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["optimal", "build_optimal", "FINER_GRIDS"]

#: the finer grids :func:`optimal` tries, in turn, when IPOPT did not converge or the back-off
#: left the plan over a limit between the knots (factors of every segment's intervals; issue
#: 15: one of 1 000 random problems stalled at 16 and 32 intervals per segment, planned at 48)
FINER_GRIDS = (2, 3)


def _check_waypoints(robot, waypoints) -> np.ndarray:
    w = validate_waypoints(robot, waypoints, where="optimal waypoints")
    # consecutive waypoints within COINCIDE_RAD in every joint (as Python floats: a few rows,
    # and a pair is told apart by its first differing joint)
    rows = w.tolist()
    for k in range(len(rows) - 1):
        if all(abs(b - a) < COINCIDE_RAD for a, b in zip(rows[k], rows[k + 1], strict=True)):
            raise InputError(f"waypoints {k} and {k + 1} coincide; remove the duplicate")
    return w


def _check_static_torque(robot, w: np.ndarray, ls: Limits, exact: np.ndarray, states=None) -> None:
    """InfeasibleError naming the joint if an exact waypoint needs more than its torque limit:
    gravity at rest, or the inverse dynamics of the boundary state ``states = (qd, qdd)``
    (each (n_waypoints, n_joints); nonzero at the start and the goal of a replan)."""
    if ls.torque_Nm is None:
        return
    idx = np.flatnonzero(exact)
    if idx.size == 0:
        return
    if states is None:
        gs = rigid_body.gravity_torques(robot, w[idx])
        moving = np.zeros(idx.size, bool)
    else:
        qd, qdd = states
        gs = rigid_body.inverse_dynamics(robot, w[idx], qd[idx], qdd[idx])
        moving = np.any(qd[idx] != 0, axis=1) | np.any(qdd[idx] != 0, axis=1)
    over = held_over_limit(np.abs(gs) / ls.torque_Nm)
    if over is not None:
        m, i = over
        k = int(idx[m])
        what = (
            f"at waypoint {k} in its {'start' if k == 0 else 'goal'} state "
            f"({'qd_start, qdd_start' if k == 0 else 'qd_goal'})"
            if moving[m]
            else f"to hold waypoint {k} against gravity"
        )
        raise InfeasibleError(
            f"torque limit: {ls.joint_names[i]} needs {abs(gs[m, i]):.4g} N m {what}, above its "
            f"tau_max of {ls.torque_Nm[i]:.4g} N m"
        )


def _check_static_drive(robot, w: np.ndarray, ls: Limits, exact: np.ndarray, train) -> None:
    """InfeasibleError naming the joint if a motor cannot hold an exact waypoint at rest
    (holding is the motoring quadrant: ``|g| / (N eta) <= derating min(T_peak, Kt U / R)``)."""
    idx = np.flatnonzero(exact)
    gs = rigid_body.gravity_torques(robot, w[idx])
    z = np.zeros_like(gs)
    t_m, _ = drivetrain.motor_torque(gs, z, z, train)
    over = held_over_limit(drivetrain.envelope_ratio(t_m, z, train))
    if over is not None:
        k, i = over
        raise InfeasibleError(
            f"motor envelope: the motor of {ls.joint_names[i]} needs {abs(t_m[k, i]):.4g} N m to "
            f"hold waypoint {idx[k]} against gravity, above the "
            f"{float(drivetrain.envelope_torque(0.0, train)[i]):.4g} N m it can give at rest"
        )


def _transcribed(traj: Trajectory) -> Trajectory:
    """``stats["method"]``: a plan of the transcription (the closed form says
    ``"closed_form"``, :mod:`armlab.planning.optimal_closed`)."""
    traj.stats.setdefault("method", "transcription")
    return traj


# ----------------------------------------------------------------------------- public
def build_optimal(
    robot: Robot,
    waypoints,
    *,
    v_max=None,
    a_max=None,
    j_max=None,
    tau_max=None,
    objective: str = "time",
    duration: float | None = None,
    payload_kg: float | None = None,
    via_tolerance=0.0,
    n_intervals: int | tuple[int, ...] | None = None,
    smooth_weight: float = 0.5,
    check_dt: float | None = None,
    max_backoff: int = 4,
    max_iter: int = 1000,
    drive_limits: bool = False,
    hessian: str = HESSIAN,
    qd_start=None,
    qdd_start=None,
    qd_goal=None,
) -> OptimalProblem:
    """Build (do not solve) the problem of :func:`optimal`; same parameters."""
    if payload_kg is not None:
        robot = robot.with_payload(payload_kg)
    if objective not in OBJECTIVES:
        raise InputError(f"objective {objective!r} unknown; choose one of {OBJECTIVES}")
    if hessian not in HESSIANS:
        raise InputError(f"hessian {hessian!r} unknown; choose one of {HESSIANS}")
    # the envelope replaces the robot's torque box (module docstring)
    train, tau_max = drivetrain.planning_drive_train(robot, drive_limits, tau_max, where="optimal")
    w = _check_waypoints(robot, waypoints)
    ls = resolve_limits(
        robot,
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
        need="unset",  # a limit left None is the robot's own: it must be there
        where=f"optimal on {robot.name}",
    )
    if (
        ls.acceleration_rad_s2 is None
        and ls.jerk_rad_s3 is None
        and ls.torque_Nm is None
        and train is None
    ):
        raise InputError(
            "velocity limits alone have no minimum-time solution: give a_max, j_max, tau_max "
            "or drive_limits"
        )
    fixed = objective in ("jerk", "energy")
    if fixed:
        if duration is None:
            raise InputError(f"objective {objective!r} needs a duration in [s]")
        duration = float(duration)
        if not np.isfinite(duration) or duration <= 0:
            raise InputError(f"duration must be a positive number of seconds, not {duration!r}")
    elif duration is not None:
        raise InputError(
            f"objective {objective!r} minimises the duration; duration= is only "
            "for the fixed-duration objectives 'jerk' and 'energy'"
        )
    exact = np.ones(w.shape[0], bool)
    tol = np.asarray(via_tolerance, float)
    tol = np.full(robot.n_joints, float(tol)) if tol.ndim == 0 else tol
    # one value per joint: as Python floats (NaN fails the test)
    values = tol.tolist() if tol.shape == (robot.n_joints,) else [math.nan]
    if not all(0.0 <= x < math.inf for x in values):
        raise InputError(f"via_tolerance must be >= 0 rad, scalar or ({robot.n_joints},)")
    if any(x > 0.0 for x in values):
        exact[1:-1] = False
    mode = "jerk" if (ls.jerk_rad_s3 is not None or objective == "jerk") else "acceleration"
    # replanning from a moving state: the ptp_sync keywords, validated the same way
    qd0 = validate_joint_state(
        robot, qd_start, "qd_start", ls.velocity_rad_s, "velocity", where="optimal"
    )
    qd1 = validate_joint_state(
        robot, qd_goal, "qd_goal", ls.velocity_rad_s, "velocity", where="optimal"
    )
    qdd0 = validate_joint_state(
        robot, qdd_start, "qdd_start", ls.acceleration_rad_s2, "acceleration", where="optimal"
    )
    moving = not (qd_start is None and qdd_start is None and qd_goal is None) and bool(
        qd0.any() or qdd0.any() or qd1.any()  # a nonzero (or NaN) entry
    )
    states = None
    if moving:
        if train is not None:
            raise InputError(
                "optimal: qd_start/qdd_start/qd_goal (replanning from a moving state) cannot be "
                "combined with drive_limits (its joints move monotonically from rest to rest)"
            )
        if mode == "jerk" and ls.velocity_rad_s is not None and ls.jerk_rad_s3 is not None:
            # without a jerk limit the acceleration may jump: nothing is carried over
            check_stoppable(robot, qd0, qdd0, ls.velocity_rad_s, ls.jerk_rad_s3, where="optimal")
        states = (np.zeros_like(w), np.zeros_like(w))
        states[0][0], states[1][0], states[0][-1] = qd0, qdd0, qd1
    _check_static_torque(robot, w, ls, exact, states)
    if train is not None:
        _check_static_drive(robot, w, ls, exact, train)
    nseg = w.shape[0] - 1
    if n_intervals is None:
        n_intervals = default_intervals(nseg)
    counts = np.asarray(n_intervals)
    seg_n = tuple(int(x) for x in counts) if counts.ndim else (int(counts),) * nseg
    if len(seg_n) != nseg or min(seg_n) < 2:
        raise InputError(f"n_intervals must be >= 2 per segment ({nseg} segments)")
    return OptimalProblem(
        robot=robot,
        waypoints=w,
        limits=ls,
        objective=objective,
        duration=duration,
        via_tolerance=tol,
        segment_intervals=seg_n,
        mode=mode,
        smooth_weight=float(smooth_weight),
        check_dt=check_dt,
        max_backoff=int(max_backoff),
        max_iter=int(max_iter),
        drive_limits=bool(drive_limits),
        train=train,
        hessian=hessian,
        qd_start=qd0 if moving else None,
        qdd_start=qdd0 if moving else None,
        qd_goal=qd1 if moving else None,
    )


def optimal(
    robot: Robot,
    waypoints,
    *,
    v_max=None,
    a_max=None,
    j_max=None,
    tau_max=None,
    objective: str = "time",
    duration: float | None = None,
    payload_kg: float | None = None,
    via_tolerance=0.0,
    n_intervals: int | tuple[int, ...] | None = None,
    smooth_weight: float = 0.5,
    check_dt: float | None = None,
    max_backoff: int = 4,
    max_iter: int = 1000,
    drive_limits: bool = False,
    hessian: str = HESSIAN,
    qd_start=None,
    qdd_start=None,
    qd_goal=None,
    clearance=None,
) -> Trajectory:
    """Time-synchronised optimal trajectory through joint waypoints.

    Parameters
    ----------
    robot : Robot
    waypoints : array (n_waypoints, n_joints)
        Joint positions in [rad]; start and goal are at rest (unless ``qd_start``, ... say
        otherwise), via points are passed with free (continuous) velocity.
    v_max, a_max, j_max, tau_max : None, False, float or array (n_joints,)
        Limits on ``|qd|`` [rad/s], ``|qdd|`` [rad/s^2], ``|qddd|`` [rad/s^3], ``|tau|`` [N m].
        None takes the robot's own (``robot.limits``; plain URDFs have no acceleration or jerk
        limit, pass them), False switches the limit off, a value overrides it
        (:func:`armlab.robot.resolve_limits`; every missing one is named in one InputError).
    objective : {"time", "time+smooth", "jerk", "energy"}
        Minimum time (default); minimum time plus ``smooth_weight`` times the integral of the
        squared normalised jerk; minimum jerk or minimum energy for a fixed ``duration``.
    duration : float, optional
        Total duration in [s] for ``"jerk"`` and ``"energy"``.
    payload_kg : float, optional
        Plan with this payload (a copy of the robot; its centre of mass kept).
    via_tolerance : float or array (n_joints,)
        Via points are passed within this box in [rad] (0: exactly).
    n_intervals : int or tuple, optional
        Intervals per segment (default :func:`default_intervals`: 32 for one segment,
        ``max(16, 48 // n_segments)`` for more).
    check_dt : float, optional
        Step of the fine feasibility check in [s] (default ``T / 4000``).
    max_backoff : int
        Re-solves allowed when the fine check finds a torque above its limit.
    drive_limits : bool
        Plan inside each motor's envelope (module docstring): the motor torque of the
        drive-train model within the voltage line and the peak torque, its RMS within the
        continuous rating. The robot's torque box is then off unless ``tau_max`` is given;
        each joint moves monotonically within a segment. Needs the robot's drives.
    hessian : {"partial", "exact", "limited-memory"}
        The Hessian of the Lagrangian IPOPT works with
        (:data:`armlab.planning.transcription.HESSIANS`): ``"partial"`` (default) leaves the
        curvature of the torque-limit rows out of the Newton model (their values and Jacobian
        stay exact, so the solution meets the same conditions; with torque limits ~1.5 x
        faster, durations within 1e-5, measured on teachbot6; a solve that stalls is repeated
        with the exact Hessian, ``stats["hessian_fallback"]``), ``"exact"`` the full one,
        ``"limited-memory"`` L-BFGS. Without a torque limit ``"partial"`` equals ``"exact"``.
    qd_start, qdd_start, qd_goal : array (n_joints,), optional
        Replanning from a moving state (module docstring): the joint speeds [rad/s] and
        accelerations [rad/s^2] at the first waypoint, and the speeds [rad/s] wanted at the last
        (default: rest). Each within its limit (else :class:`InputError` naming the keyword and
        the joint); the first sample of the result is that state, the last the goal at
        ``qd_goal`` with zero acceleration. Not with ``drive_limits``.
    clearance : armlab.collision.CollisionScene, optional
        Keep every pair the scene checks at least its ``clearance_m`` apart:
        clearance rows on the knots in sequential convex rounds, the motion checked between
        them (:func:`armlab.planning.optimal_clearance.plan_clear`; an
        :class:`InfeasibleError` naming the pair, the time and the depth when it cannot).

    Returns
    -------
    Trajectory
        With ``.report`` (fine-grid :class:`LimitReport` against the request's limits),
        ``.stats`` (solver -- ``"fatrop"`` or ``"ipopt"`` -- and ``fallback``, why not fatrop,
        :mod:`~armlab.planning.fatrop_backend`; iterations, solve_time_s, n_intervals, success,
        duration_s,
        binding limits ``[(kind, joint, ratio)]``, energy; with ``drive_limits`` the fine-grid
        ``drive_ratios``; ``n_intervals_raised`` when IPOPT did not converge on the requested
        grid, or its back-off left the plan over a limit between the knots, and the plan was
        solved once more with twice the intervals of every segment;
        ``tolerance_stretch``, the factor of the last stretch (module docstring), and
        ``tolerance_stretch_skipped``, why none was made where the plan passes a pose whose
        gravity torque alone is above a limit, :func:`~armlab.planning.tolerance.absorb_tolerance`)
        and ``.meta`` (waypoint times, ``qd_start``,
        ``qdd_start``, ``qd_goal``, ...).

    Raises
    ------
    InfeasibleError
        A torque limit below the static gravity torque at a waypoint (or the torque of the start
        or goal state), a duration shorter than the minimum, a torque limit no trajectory
        meets, a start state that cannot be braked within the limits, a plan the back-off
        leaves over a limit on the requested grid and on the finer ones — the message
        names the limit and the joint.
    InputError
        Bad shapes, values or keyword combinations; a waypoint outside a joint range
        (:func:`~armlab.trajectory.waypoints.validate_waypoints`).
    ArmlabError
        IPOPT did not converge, no limit was violated at its last iterate, and the finer
        grids (:data:`FINER_GRIDS`) did not converge either.
    """
    if (
        (tau_max is False or tau_max is None)
        and v_max is None
        and a_max is None
        and j_max is None
        and duration is None
        and payload_kg is None
        and n_intervals is None
        and check_dt is None
        and drive_limits is False
        and qd_start is None
        and qdd_start is None
        and qd_goal is None
        and clearance is None
        and type(objective) is str
        and objective == "time"
        and type(via_tolerance) is float
        and via_tolerance == 0.0
        and type(smooth_weight) is float
        and smooth_weight == 0.5
        and type(max_backoff) is int
        and max_backoff == 4
        and type(max_iter) is int
        and max_iter == 1000
        and type(hessian) is str
        and hessian == HESSIAN
    ):
        # every keyword at its default: two waypoints at rest under the robot's v/a/j limits
        # are the closed form's (optimal_closed.direct; None where the path below must run)
        traj = closed_direct(robot, waypoints, tau_max is False)
        if traj is not None:
            return traj
    kw = dict(
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
        objective=objective,
        duration=duration,
        payload_kg=payload_kg,
        via_tolerance=via_tolerance,
        smooth_weight=smooth_weight,
        check_dt=check_dt,
        max_backoff=max_backoff,
        max_iter=max_iter,
        drive_limits=drive_limits,
        hessian=hessian,
        qd_start=qd_start,
        qdd_start=qdd_start,
        qd_goal=qd_goal,
    )
    if clearance is not None:  # issue 27: sequential convex rounds (optimal_clearance)
        from armlab.planning.optimal_clearance import plan_clear

        return plan_clear(
            lambda: optimal(robot, waypoints, n_intervals=n_intervals, **kw),
            lambda grid: build_optimal(robot, waypoints, n_intervals=grid or n_intervals, **kw),
            clearance,
        )
    prob = build_optimal(robot, waypoints, n_intervals=n_intervals, **kw)
    if closed_form_applies(prob):  # the exact optimum in closed form (optimal_closed)
        traj = closed_form_optimal(prob)
        if traj.stats["ok"]:
            return traj
    try:
        return _transcribed(prob.solve())
    except _NotConverged as first:
        # IPOPT stopped without converging and with no limit violated at its last iterate, or
        # the back-off left the plan over a limit between the knots: finer grids (twice, then
        # three times the intervals of every segment: an excess between the knots depends on
        # where they fall), stated in the stats
        last: _NotConverged = first
        for factor in FINER_GRIDS:
            finer = tuple(factor * n for n in prob.segment_intervals)
            try:
                traj = build_optimal(robot, waypoints, n_intervals=finer, **kw).solve()
            except _NotConverged as again:
                last = again
                continue
            traj.stats["n_intervals_raised"] = {
                "from": list(prob.segment_intervals),
                "to": list(finer),
                "why": str(first),
            }
            return _transcribed(traj)
        tried = " and ".join(str(tuple(f * n for n in prob.segment_intervals)) for f in FINER_GRIDS)
        if isinstance(last, _BackoffStalled):
            raise InfeasibleError(f"{last} (also with {tried} intervals per segment)") from None
        error = InfeasibleError if isinstance(first, _BackoffStalled) else ArmlabError
        raise error(f"{first}; also with {tried} intervals per segment") from None
