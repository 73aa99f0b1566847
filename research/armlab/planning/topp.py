r"""Time-optimal path parameterisation (TOPP) of a fixed geometric path.

Given a joint path ``q(s)``, ``s`` in [0, 1], find the fastest ``s(t)`` from rest to rest.
Along the path ``qd = q' sd``, ``qdd = q' sdd + q'' sd^2``, and the inverse dynamics become

.. math::
    \tau = m(s)\,\ddot s + c(s)\,\dot s^2 + g(s),\qquad m = M q',\quad
    c = M q'' + C(q, q')\,q',\quad g = g(q)

(computed numerically with Pinocchio: ``g = rnea(q, 0, 0)``, ``m = rnea(q, 0, q') - g``,
``c = rnea(q, q', q'') - g``; payload included).

First pass, ``method="convex"`` (Verscheure et al. 2009)
--------------------------------------------------------
Verscheure, Demeulenaere, Swevers, De Schutter, Diehl, "Time-Optimal Path Tracking for Robots:
a Convex Optimization Approach", IEEE TAC 54(10) 2009. With ``b = sd^2`` and ``a = sdd``
(``b' = 2a``), velocity, acceleration and torque limits are *linear* in ``(a, b)``. On a
grid ``s_0 .. s_K`` with ``a`` constant per interval (``b`` linear in ``s``,
``a_k = (b_{k+1} - b_k) / (2 ds_k)``) the acceleration and torque limits are imposed at
both ends and the midpoint of each interval, the velocity limit at the nodes and at 1/4, 1/2,
3/4 of each interval; the travel time ``T = sum_k 2 ds_k / (sqrt(b_k) + sqrt(b_{k+1}))`` is
convex in ``b``. The problem is solved with CasADi + IPOPT (convex: its local optimum is the
global one on this grid). The first and last intervals are split geometrically (from rest the
path speed rises within a small fraction of a uniform interval, which would otherwise cost up
to ``ds / sd`` there: 1.4 % of the duration at 200 intervals, measured).

First pass, ``method="reachability"`` (default; Pham & Pham 2018)
-----------------------------------------------------------------
Pham and Pham, "A New Approach to Time-Optimal Path Parameterization Based on Reachability
Analysis", IEEE T-RO 34(3) 2018: the same grid and variables (``x = b``, ``u = a``), the
limits as linear rows in ``(u_k, x_k)`` imposed at more points per interval (ends, quarters,
middle and any spline knot; the velocity at eighths), a backward sweep of controllable sets
and a greedy forward pass, each step a two-variable LP in closed form
(:mod:`armlab.planning.reachability`). Greedy on denser rows, not the convex optimum: in
``benchmarks/bench_topp.py`` (24 paths, ``n_grid`` 100) at most 0.26 % slower than the convex
pass (median 0.06 % teachbot6, 0.001 % UR5), and the whole call takes about 12-13 ms against
0.7-1.3 s: 2.6-2.8x TOPP-RA's solve on the same grid (1.9x its whole call, with its spline and
constraint objects), half of it the limit check (a quarter of the call its one batched RNEA).
Its plans are 0.03-0.7 % longer than TOPP-RA's on the same grid (median 0.14 %) because the
limits are imposed between the grid points too: TOPP-RA's plans break them there (by
0.03-11 % on a ``T / 4000`` check). On rows at the grid points only (no ``LIMIT_MARGIN``;
fewer than TOPP-RA's, which imposes the acceleration at both ends of each interval) these
sweeps give plans up to 1.2 % shorter than TOPP-RA's (median 0.04 % teachbot6, 0.9 % UR5)
and on one path 0.05 % longer: a loss of the greedy forward pass, not of the rows (without
the spline-knot rows it stays; TOPP-RA's plan meets these rows) -- on those rows the optimum
(IPOPT) is up to 0.09 % (teachbot6) and 0.39 % (UR5) shorter than the greedy plan (median
0 and 0.04 %; :mod:`armlab.planning.reachability`, "Optimality"). No envelope
rows: with ``drive_limits`` the convex envelope pass runs whatever the method. Everything
after the first pass (Trajectory, back-off, jerk pass, check) is shared.

Jerk pass (not convex in ``(a, b)``)
-----------------------------------
``qddd = q' sddd + 3 q'' sd sdd + q''' sd^3`` is not convex in the Verscheure variables. When a
jerk limit is given we solve a second, *nonconvex* problem in the time domain on the same
s-grid: the nodes keep their ``s_k``; each interval gets a duration ``dt_k`` and a constant
path jerk ``u_k`` (``s(t)`` piecewise cubic, integrated exactly — the same transcription as
:mod:`armlab.planning.optimiser` with one "joint" ``s``). Joint velocity, acceleration, jerk
(both one-sided values) and torque are constrained at the nodes. It is warm-started from the
first pass's solution slowed down until its jerk fits, and solved with IPOPT: a local optimum.

Planning inside the motor's envelope (``drive_limits=True``, issue 14)
--------------------------------------------------------------------
Along the path the direction of motion is known: ``sign(qd) = sign(q'(s))`` (``sd >= 0``), so
the motor torque of the drive-train model (:mod:`armlab.robot.drivetrain`: friction, quadrant
efficiency, reflected inertia) is, per branch, ``alpha a + beta b + gamma sqrt(b) + delta``
(``sqrt(b) = sd`` from the viscous terms and the back-EMF of the voltage line
``|T_m| <= derating Kt (U - Ke |w_m|) / R``). The envelope rows keep the convex pass convex
by a convex-concave (sequential) linearisation: a positive ``gamma sqrt(b)`` on the ``<=``
side is bounded by its tangent at the previous solution ``b0``
(``sqrt(b) <= (b + b0) / (2 sqrt(b0))``), a negative one is dropped (``sqrt(b) >= 0``); both
are conservative, so every iterate meets the rows, and the pass is repeated from the new
``b`` until the duration moves by less than ``DRIVE_SCP_TOL`` (at most ``DRIVE_SCP_ITER``
passes), starting from the solution without the envelope. Quadrant rows follow
:func:`armlab.planning.transcription._drive_rows` (both branches on the side where the
motoring one can bind, the back-driven one on the other). The jerk pass imposes the same
rows exactly (``sd`` is a variable there). The RMS over the plan is checked on the fine
grid; a joint over its RMS rating has its envelope bound backed off by the excess (a
heuristic: lower peaks lower the RMS), like a joint over its envelope. The robot's torque
box is off with ``drive_limits`` unless ``tau_max`` is given.

What is guaranteed
------------------
Limits are imposed at those points; between them the trajectory is checked, every back-off
round, by one :meth:`Trajectory.limit_samples` of the Trajectory handed out -- its own
evaluation between its knots, not the path coefficients the rows were built from: the
knots and the left limit of every piece, the exact extremes of velocity and acceleration
inside each piece (roots of the piece's polynomials), and torques by one batched RNEA at
those points, at every piece's middle and at most ``T / 1024`` apart, refined by three steps
of parabolic interpolation towards each peak (plus a uniform grid of step ``check_dt`` if
given; with the motor envelope, ``T / 4000``). The report and, when a limit is over, the
per-interval ratios of the local back-off are read from those same samples (one RNEA pass per
round). A check of ``q(s(t))`` at fixed path points instead (their RNEA computed once per path,
each round a few products ``m sdd + c sd^2 + g``) would be cheaper but would not certify the
Trajectory: its evaluation between knots differs from ``q(s(t))`` by up to 0.2 % of the
acceleration limit (measured on the benchmark paths). The limits are tightened by
``LIMIT_MARGIN`` (5e-4)
from the start (speed and acceleration between the check points exceed them by up to ~3e-4
otherwise). The path itself
must stay in the joint ranges (checked densely when the problem is built). Intervals where a
limit is still exceeded by more than ``1e-6`` are tightened by the excess (plus 0.1 %) and the
problem re-solved; residues after that tighten the whole limit kind slightly (``max_backoff``
rounds; the jerk pass backs off whole joint limits, as :mod:`armlab.planning.optimiser` does: both
loops are :func:`armlab.planning.timescale.backoff_solve`). ``traj.report`` is the final
check: exact for velocity and acceleration, "feasible on the refined samples" for torque, not
a proof between them. The convex pass
is globally optimal on its grid, the reachability pass greedy on its (denser) rows; the jerk
pass is a local optimum. Jerk-free results have
acceleration steps, replaced by 50 us ramps as in :mod:`armlab.planning.optimiser`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import InfeasibleError, InputError
from armlab.planning.keep_clear import keep_clear
from armlab.planning.topp_convex import DRIVE_SCP_ITER, DRIVE_SCP_TOL
from armlab.planning.topp_path import (
    END_REFINEMENT,
    VELOCITY_POINTS,
    GeometricPath,
    path_dynamics,
    path_grid,
)
from armlab.planning.topp_problem import LIMIT_MARGIN, ToppProblem
from armlab.robot import drivetrain
from armlab.robot.limits import resolve_limits
from armlab.trajectory.core import Trajectory
from armlab.trajectory.waypoints import validate_waypoints

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "time_optimal_path",
    "build_topp",
    "ToppProblem",
    "GeometricPath",
    "path_dynamics",
    "path_grid",
    "METHODS",
    "LIMIT_MARGIN",
    "END_REFINEMENT",
    "VELOCITY_POINTS",
    "DRIVE_SCP_TOL",
    "DRIVE_SCP_ITER",
]

#: solvers of the first pass (``method``): :mod:`armlab.planning.reachability`'s two sweeps,
#: or the convex program with IPOPT
METHODS = ("reachability", "convex")


# ----------------------------------------------------------------------------- public
def build_topp(
    robot: Robot,
    path,
    *,
    v_max=None,
    a_max=None,
    j_max=None,
    tau_max=None,
    payload_kg: float | None = None,
    n_grid: int | None = None,
    check_dt: float | None = None,
    max_backoff: int = 4,
    max_iter: int = 3000,
    drive_limits: bool = False,
    method: str = "reachability",
) -> ToppProblem:
    """Build (do not solve) the problem of :func:`time_optimal_path`; same parameters."""
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, not {method!r}")
    if payload_kg is not None:
        robot = robot.with_payload(payload_kg)
    # the envelope replaces the robot's torque box (module docstring)
    train, tau_max = drivetrain.planning_drive_train(
        robot, drive_limits, tau_max, where="time_optimal_path"
    )
    ls = resolve_limits(
        robot,
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
        need="unset",  # a limit left None is the robot's own: it must be there
        where=f"time_optimal_path on {robot.name}",
    )
    if (
        ls.velocity_rad_s is None
        and ls.acceleration_rad_s2 is None
        and ls.torque_Nm is None
        and train is None
    ):
        raise InputError("time_optimal_path needs at least one of v_max, a_max, tau_max")
    gp = GeometricPath(path, robot.n_joints)
    lo, hi = ls.lower_rad, ls.upper_rad
    pts = validate_waypoints(robot, gp.points, where="time_optimal_path points")
    s_dense = np.linspace(0.0, 1.0, 40 * pts.shape[0] + 400)
    q_dense = gp.spline(s_dense)
    out = (q_dense < lo - 1e-9) | (q_dense > hi + 1e-9)
    if np.any(out):
        k, i = np.argwhere(out)[0]
        seg = int(np.searchsorted(gp.s_points, s_dense[k], side="right")) - 1
        raise InfeasibleError(
            f"position limit: the path leaves the range of {ls.joint_names[i]} "
            f"([{lo[i]:.4g}, {hi[i]:.4g}] rad) between its points {seg} and {seg + 1} "
            f"(reaches {q_dense[k, i]:.4g} rad)"
        )
    if n_grid is None:
        n_grid = 100 if pts.shape[0] <= 3 else 200
    if int(n_grid) < 4:
        raise InputError("n_grid must be >= 4")
    s = path_grid(int(n_grid))
    return ToppProblem(
        robot=robot,
        path=gp,
        limits=ls,
        s=s,
        check_dt=check_dt,
        max_backoff=int(max_backoff),
        max_iter=int(max_iter),
        train=train,
        method=method,
    )


def time_optimal_path(
    robot: Robot,
    path,
    *,
    v_max=None,
    a_max=None,
    j_max=None,
    tau_max=None,
    payload_kg: float | None = None,
    n_grid: int | None = None,
    check_dt: float | None = None,
    max_backoff: int = 4,
    max_iter: int = 3000,
    drive_limits: bool = False,
    method: str = "reachability",
    clearance=None,
) -> Trajectory:
    """Fastest rest-to-rest motion along a fixed joint path (TOPP).

    Parameters
    ----------
    robot : Robot
    path : array (n_points, n_joints) or Trajectory
        Joint points (a cubic spline through them, chord-length parameterised; a dense
        array is a fine path) or a Trajectory whose geometry is used (for example a
        Cartesian line mapped through IK); its timing is discarded.
    v_max, a_max, j_max, tau_max : None, False, float or array (n_joints,)
        As in :func:`armlab.trajectory.optimal` (None: the robot's own, False: off). With a
        jerk limit the nonconvex jerk pass (IPOPT) runs after the first pass, warm-started
        from it; ``j_max=False`` gives the classical (Verscheure / TOPP-RA) problem.
    payload_kg : float, optional
    n_grid : int, optional
        Path intervals (default 100, 200 for longer or dense paths).
    check_dt : float, optional
        Step [s] of a uniform grid added to the feasibility check (default: none -- the
        check evaluates the exact velocity and acceleration peaks and the refined torque peaks
        of :meth:`Trajectory.limit_samples`; ``T / 4000`` with ``drive_limits``, whose RMS
        needs uniform samples).
    max_backoff : int
        Re-solves allowed when the fine check finds a limit exceeded between grid points.
    drive_limits : bool
        Keep each motor inside its envelope (module docstring): the motor torque of the
        drive-train model within the voltage line and peak torque, its RMS within the
        continuous rating; the robot's torque box is then off unless ``tau_max`` is given.
        The envelope rows exist in the convex program only: with ``drive_limits`` the first
        pass is the IPOPT envelope pass whatever ``method`` says (``stats["method"]`` is
        ``"convex"``).
    method : {"reachability", "convex"}
        Solver of the first pass on the ``(sdd, sd^2)`` grid problem. ``"reachability"``
        (default): reachability analysis (Pham & Pham, "A New Approach to Time-Optimal Path
        Parameterization Based on Reachability Analysis"), two closed-form sweeps over the
        grid (:mod:`armlab.planning.reachability`; denser limit rows, greedy: at most 0.3 %
        slower than the convex pass in the benchmark, about 13 ms a call against about 1 s).
        ``"convex"``: the
        convex program of Verscheure et al. with IPOPT (globally optimal on its grid).
    clearance : armlab.collision.CollisionScene, optional
        Check the plan's clearance (the path is given: the TOPP does not plan around
        obstacles): :class:`~armlab.collision.CollisionError` naming the pair, the time and the
        depth if it comes closer than the scene's ``clearance_m``
        (:func:`armlab.planning.keep_clear.keep_clear`).

    Returns
    -------
    Trajectory
        ``.report`` (fine-grid limit ratios), ``.stats`` (solver, method, iterations,
        n_intervals, passes (``"convex"``: the first pass, whichever method; ``"jerk"``),
        back-off rounds, binding limits; wall times [s]: ``solve_time_s`` of the solvers,
        ``trajectory_time_s`` of building the first pass's Trajectories, ``check_time_s`` of
        the limit checks, ``wall_time_s`` of the whole solve), ``.meta["topp"]`` (the problem,
        for :func:`armlab.plots.optimal.plot_phase_plane`).

    Raises
    ------
    InputError
        A path point outside a joint range
        (:func:`~armlab.trajectory.waypoints.validate_waypoints`), or ``method`` not one of
        :data:`METHODS`.
    InfeasibleError
        The spline between the points leaves a joint range, gravity alone above a torque limit
        somewhere on the path (named joint and ``s``), or no feasible parameterisation.
    """
    prob = build_topp(
        robot,
        path,
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
        payload_kg=payload_kg,
        n_grid=n_grid,
        check_dt=check_dt,
        max_backoff=max_backoff,
        max_iter=max_iter,
        drive_limits=drive_limits,
        method=method,
    )
    return keep_clear(prob.solve(), clearance, "time_optimal_path")  # issue 27
