r"""Time-synchronised optimal joint trajectories through waypoints (CasADi + IPOPT).

Problem (issue 5, item 2)
-------------------------
Given joint waypoints ``w_0 .. w_{W-1}`` (start and goal at rest, via points passed exactly or
within ``via_tolerance``), find ``q(t)`` for all joints together — one time axis, so all joints
start and end together — minimising the duration (or a fixed-duration objective) subject to,
at every instant,

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
``tolerance_stretch``). In acceleration mode each acceleration jump is replaced by a linear ramp of
``JUMP_RAMP_S`` (50 us): the box-average of the optimum over that width, which keeps velocity,
acceleration and position within their bounds (an average stays within the range it averages),
changes positions by ``|jump| ramp^2 / 24`` (< 1e-9 rad) and adds ``JUMP_RAMP_S`` to the duration.

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
is IPOPT with the exact Hessian (CasADi SX); the inverse dynamics take the inertial parameters
as an input, so one compiled problem serves every payload of a robot (cached per kinematics,
sizes and flags).

References: Verscheure et al., IEEE TAC 54(10) 2009 (time-optimal problems as optimisation);
Betts, *Practical Methods for Optimal Control*, 2010 (direct transcription); Farouki, CAGD 29 2012
(Bernstein convex-hull property); Jiang 1987, eq. 1-5 (time-synchronised PTP).
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np

from armlab._lazy import lazy_import
from armlab.errors import ArmlabError, InfeasibleError, InputError
from armlab.planning.timescale import CHECK_TOL, backoff_solve, refuse_violation
from armlab.planning.tolerance import absorb_tolerance
from armlab.planning.transcription import Structure, structure
from armlab.planning.warmstart import (
    fit_piecewise,
    integrate_piecewise,
    phase_grid,
    sample_profiles,
)
from armlab.robot import rigid_body
from armlab.robot.limits import LIMIT_KEYS, Limits, resolve_limits
from armlab.robot.symbolic import (
    dynamic_parameters,
)
from armlab.trajectory.core import Trajectory
from armlab.trajectory.profiles import synchronised_profiles
from armlab.trajectory.waypoints import validate_waypoints

if TYPE_CHECKING:
    import casadi as ca  # the real module for the type checker (CasADi ships type stubs)
else:
    ca = lazy_import("casadi")  # CasADi loads at the first symbolic build, not with the package

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["optimal", "build_optimal", "OptimalProblem", "OBJECTIVES", "JUMP_RAMP_S", "H_MIN_S"]

OBJECTIVES = ("time", "time+smooth", "jerk", "energy")
#: shortest interval the optimiser may use, in [s]
H_MIN_S = 1e-4
#: width of the ramp that replaces an acceleration jump (acceleration mode), in [s]
JUMP_RAMP_S = 5e-5
#: tiny smoothness weight added to the pure time objective (regularises non-binding joints)
TIME_REGULARISATION = 1e-7
#: samples of the fine feasibility check (~100 per optimisation interval)
CHECK_SAMPLES = 4000


# ----------------------------------------------------------------------------- helpers
def _check_waypoints(robot, waypoints) -> np.ndarray:
    w = validate_waypoints(robot, waypoints, where="optimal waypoints")
    same = np.flatnonzero(np.all(np.abs(np.diff(w, axis=0)) < 1e-12, axis=1))
    if same.size:
        raise InputError(f"waypoints {same[0]} and {same[0] + 1} coincide; remove the duplicate")
    return w


def _check_static_torque(robot, w: np.ndarray, ls: Limits, exact: np.ndarray) -> None:
    if ls.torque_Nm is None:
        return
    idx = np.flatnonzero(exact)
    if idx.size == 0:
        return
    gs = rigid_body.gravity_torques(robot, w[idx])
    for k, g in zip(idx, gs, strict=True):
        r = np.abs(g) / ls.torque_Nm
        i = int(np.argmax(r))
        if r[i] > 1.0:
            raise InfeasibleError(
                f"torque limit: {ls.joint_names[i]} needs {abs(g[i]):.4g} N m to hold waypoint "
                f"{k} against gravity, above its tau_max of {ls.torque_Nm[i]:.4g} N m"
            )


def _energy_weights(robot) -> tuple[np.ndarray, str]:
    """``R / (k_t N eta)^2`` per joint so that ``w tau^2`` is the copper loss in [W]."""
    n = robot.n_joints
    drives = getattr(robot, "drives", None)
    if not drives:
        return np.ones(n), "N^2 m^2 s"
    w = np.empty(n)
    for i, name in enumerate(robot.joint_names):
        d = drives[name]
        k = d.motor.torque_constant_Nm_A * d.reducer.ratio * d.reducer.efficiency
        w[i] = d.motor.resistance_ohm / k**2
    return w, "J"


def _surrogate_acc(robot, w0, ls: Limits) -> np.ndarray:
    """An acceleration scale for the warm start when no acceleration limit is given."""
    if ls.acceleration_rad_s2 is not None:
        return ls.acceleration_rad_s2
    if ls.jerk_rad_s3 is not None:
        return np.full(robot.n_joints, np.inf)
    assert ls.torque_Nm is not None  # build_optimal refuses velocity limits alone
    M = rigid_body.mass_matrix(robot, w0)
    g = np.abs(rigid_body.gravity_torques(robot, w0))
    spare = np.maximum(ls.torque_Nm - g, 0.1 * ls.torque_Nm)
    return 0.5 * spare / np.maximum(np.diag(M), 1e-6)


def _classical_segment(robot, qa, qb, ls: Limits, acc, ns: int, mode: str):
    """(T, node times, q, qd, qdd, u) of one synchronised rest-to-rest S-curve segment.

    The node times hold the switching instants of the slowest joint(s) (those within 2 % of
    the segment time), the rest of the grid halves the longest intervals; every joint's
    S-curve is then refitted (:func:`fit_piecewise`) to be an exact solution of the
    optimiser's integration equations on that grid.
    """
    n = robot.n_joints
    v = ls.velocity_rad_s if ls.velocity_rad_s is not None else np.full(n, np.inf)
    j = ls.jerk_rad_s3 if ls.jerk_rad_s3 is not None else np.full(n, np.inf)
    D = qb - qa
    T, Tj, profiles = synchronised_profiles(np.abs(D), v, acc, j)
    slow = np.argsort(-Tj)[: max(1, int(np.sum(Tj >= 0.98 * T)))][:3]
    t = phase_grid(profiles, T, ns, h_min=2 * H_MIN_S, joints=slow)
    q, qd, qdd = sample_profiles(profiles, np.sign(D), t)
    h = np.diff(t)
    if mode == "jerk":
        u_ref = np.diff(qdd, axis=0) / h[:, None]
        target = np.vstack([D, np.zeros(n), np.zeros(n)])
    else:
        u_ref = np.diff(qd, axis=0) / h[:, None]
        target = np.vstack([D, np.zeros(n)])
    u = fit_piecewise(h, u_ref, target, "jerk" if mode == "jerk" else "acceleration")
    q, qd, qdd = integrate_piecewise(h, u, qa, "jerk" if mode == "jerk" else "acceleration")
    return T, t, q, qd, qdd, u


def _timescale_for_torque(robot, q, qd, qdd, tau_max) -> float:
    """Smallest factor ``alpha >= 1`` so that slowing down by it fits the torque limits.

    ``tau(alpha) = g + (tau - g) / alpha^2`` for a time-scaled trajectory.
    """
    if tau_max is None:
        return 1.0
    taus = rigid_body.inverse_dynamics(robot, q, qd, qdd)
    gs = rigid_body.gravity_torques(robot, q)
    need = 1.0
    for tau, g in zip(taus, gs, strict=True):
        room = tau_max - np.abs(g)
        if np.any(room <= 0):
            continue
        need = max(need, float(np.max(np.abs(tau - g) / room)))
    return float(np.sqrt(need)) * 1.02 if need > 1.0 else 1.0


# ----------------------------------------------------------------------------- problem
@dataclass
class OptimalProblem:
    """A built (not yet solved) optimal trajectory problem; :meth:`solve` returns a Trajectory.

    Build with :func:`build_optimal`. Attributes are inspectable: ``limits`` (the effective
    :class:`Limits`), ``waypoints``, ``segment_intervals``, ``mode`` ("jerk" or
    "acceleration"), ``fractions`` (interval durations over their segment's), ``x0`` (warm
    start), ``warm_durations_s``.
    """

    robot: Robot
    waypoints: np.ndarray
    limits: Limits
    objective: str
    duration: float | None
    via_tolerance: np.ndarray
    segment_intervals: tuple[int, ...]
    mode: str
    smooth_weight: float
    check_dt: float | None
    max_backoff: int
    max_iter: int
    x0: np.ndarray | None = None
    fractions: np.ndarray | None = None
    warm_durations_s: np.ndarray | None = None
    scales: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)

    # ------------------------------------------------------------------ layout helpers
    @property
    def n(self) -> int:
        return self.robot.n_joints

    @property
    def N(self) -> int:
        return int(sum(self.segment_intervals))

    @property
    def waypoint_nodes(self) -> np.ndarray:
        return np.concatenate([[0], np.cumsum(self.segment_intervals)]).astype(int)

    def _structure(self, limits: Limits) -> Structure:
        return structure(
            self.robot,
            self.n,
            self.segment_intervals,
            self.mode,
            self.objective,
            limits.torque_Nm is not None,
            self.duration is not None,
            self.max_iter,
        )

    @property
    def segment_of_interval(self) -> np.ndarray:
        return np.repeat(np.arange(len(self.segment_intervals)), self.segment_intervals)

    def _pack(self, q, v, a, u, T) -> np.ndarray:
        # node-major, as casadi's vec of the (n, N+1) matrices
        parts = [q.reshape(-1), v.reshape(-1)]
        if self.mode == "jerk":
            parts.append(a.reshape(-1))
        parts += [u.reshape(-1), np.asarray(T, float)]
        return np.concatenate(parts)

    def _scale_vector(self) -> np.ndarray:
        """Per-variable scale: physical x = scaled x * this (same layout as :meth:`_pack`)."""
        sc, n, N = self.scales, self.n, self.N
        a = np.tile(sc["a"], (N + 1, 1)) if self.mode == "jerk" else None
        return self._pack(
            np.ones((N + 1, n)), np.tile(sc["v"], (N + 1, 1)), a, np.tile(sc["u"], (N, 1)), sc["T"]
        )

    def _unpack(self, st: Structure, x: np.ndarray):
        n, N = self.n, self.N
        q = x[st.slices["q"]].reshape(N + 1, n)
        v = x[st.slices["v"]].reshape(N + 1, n)
        a = x[st.slices["a"]].reshape(N + 1, n) if "a" in st.slices else None
        u = x[st.slices["u"]].reshape(N, n)
        T = x[st.slices["T"]]
        h = self.fractions * T[self.segment_of_interval]
        return q, v, a, u, h

    # ------------------------------------------------------------------ warm start
    def make_warm_start(self) -> np.ndarray:
        """The synchronised S-curve plan (stopping at each via point) on the node grid."""
        w, ls, n = self.waypoints, self.limits, self.n
        acc = _surrogate_acc(self.robot, w[0], ls)
        qs, vs, us, hs, T_list = [w[:1]], [np.zeros((1, n))], [], [], []
        as_: list[Any] = [None]  # accelerations per segment (index 0 unused)
        for s, ns in enumerate(self.segment_intervals):
            T, t, q, qd, qdd, u = _classical_segment(
                self.robot, w[s], w[s + 1], ls, acc, ns, self.mode
            )
            # slow down uniformly until the torques fit: t*alpha, qd/alpha, qdd/alpha^2, ...
            alpha = _timescale_for_torque(self.robot, q, qd, qdd, ls.torque_Nm)
            order = 3 if self.mode == "jerk" else 2
            T, t, qd, qdd, u = T * alpha, t * alpha, qd / alpha, qdd / alpha**2, u / alpha**order
            qs.append(q[1:])
            vs.append(qd[1:])
            as_.append(qdd)
            us.append(u)
            hs.append(np.diff(t))
            T_list.append(T)
        q, v, h, u = np.vstack(qs), np.vstack(vs), np.concatenate(hs), np.vstack(us)
        # accelerations at the nodes: from the segment ends (zero at rest, jerk mode)
        a: np.ndarray | None = np.vstack([as_[1][:1]] + [x[1:] for x in as_[1:]])
        Ts = np.array(T_list)
        if self.duration is not None:  # stretch or squeeze onto the requested duration
            beta = self.duration / Ts.sum()
            order = 3 if self.mode == "jerk" else 2
            h, v, a, Ts, u = h * beta, v / beta, a / beta**2, Ts * beta, u / beta**order
        self.fractions = h / Ts[self.segment_of_interval]
        if self.mode != "jerk":
            a = None
        self.warm_durations_s = Ts

        def scale(lim, warm):
            if lim is not None:
                return lim.copy()
            return np.maximum(np.max(np.abs(warm), axis=0), 1e-3)

        self.scales = {
            "v": scale(ls.velocity_rad_s, v),
            "a": scale(ls.acceleration_rad_s2, a if a is not None else u),
            "u": scale(ls.jerk_rad_s3 if self.mode == "jerk" else ls.acceleration_rad_s2, u),
            "T": Ts.copy(),
        }
        self.x0 = self._pack(q, v, a, u, Ts)
        return self.x0

    # ------------------------------------------------------------------ bounds
    def _bounds(self, st: Structure, limits: Limits):
        n, N = self.n, self.N
        inf = np.inf
        ls = limits
        lo_q = np.tile(ls.lower_rad, (N + 1, 1))
        hi_q = np.tile(ls.upper_rad, (N + 1, 1))
        nodes = self.waypoint_nodes
        tol = self.via_tolerance
        for k, node in enumerate(nodes):
            if k in (0, len(nodes) - 1) or not np.any(tol > 0):
                lo_q[node] = hi_q[node] = self.waypoints[k]
            else:
                lo_q[node] = np.maximum(self.waypoints[k] - tol, ls.lower_rad)
                hi_q[node] = np.minimum(self.waypoints[k] + tol, ls.upper_rad)
        vmax = ls.velocity_rad_s if ls.velocity_rad_s is not None else np.full(n, inf)
        amax = ls.acceleration_rad_s2 if ls.acceleration_rad_s2 is not None else np.full(n, inf)
        jmax = ls.jerk_rad_s3 if ls.jerk_rad_s3 is not None else np.full(n, inf)
        lo_v, hi_v = np.tile(-vmax, (N + 1, 1)), np.tile(vmax, (N + 1, 1))
        lo_v[[0, -1]] = hi_v[[0, -1]] = 0.0
        lbx, ubx = [lo_q.reshape(-1), lo_v.reshape(-1)], [hi_q.reshape(-1), hi_v.reshape(-1)]
        if self.mode == "jerk":
            lo_a, hi_a = np.tile(-amax, (N + 1, 1)), np.tile(amax, (N + 1, 1))
            lo_a[[0, -1]] = hi_a[[0, -1]] = 0.0
            lbx.append(lo_a.reshape(-1))
            ubx.append(hi_a.reshape(-1))
            lbx.append(np.tile(-jmax, N))
            ubx.append(np.tile(jmax, N))
        else:
            lbx.append(np.tile(-amax, N))
            ubx.append(np.tile(amax, N))
        nseg = len(self.segment_intervals)
        frac = self.fractions
        assert frac is not None  # set by make_warm_start, which solve() runs first
        fmin = np.array([frac[self.segment_of_interval == s].min() for s in range(nseg)])
        lbx.append(H_MIN_S / fmin)
        ubx.append(np.full(nseg, inf))
        # constraint rows
        kind, joint = st.g_kind, st.g_joint
        lbg = np.zeros(kind.size)
        ubg = np.zeros(kind.size)
        m = kind == "velocity"
        lbg[m] = -vmax[joint[m]] / self.scales["v"][joint[m]]
        ubg[m] = vmax[joint[m]] / self.scales["v"][joint[m]]
        m = kind == "position"
        lbg[m], ubg[m] = ls.lower_rad[joint[m]], ls.upper_rad[joint[m]]
        m = kind == "torque"
        lbg[m], ubg[m] = -1.0, 1.0
        m = kind == "duration"
        if np.any(m):
            lbg[m] = ubg[m] = self.duration
        return np.concatenate(lbx), np.concatenate(ubx), lbg, ubg

    def _params(self, limits: Limits) -> np.ndarray:
        n = self.n
        tau = limits.torque_Nm if limits.torque_Nm is not None else np.ones(n)
        if self.objective == "time":
            w = TIME_REGULARISATION
        elif self.objective == "time+smooth":
            w = self.smooth_weight
        else:
            w = 0.0
        ref = self.limits.jerk_rad_s3 if self.mode == "jerk" else self.limits.acceleration_rad_s2
        if ref is None:
            ref = np.ones(n)
        ew, _ = _energy_weights(self.robot)
        sc = self.scales
        st = self._structure(limits)
        pi = dynamic_parameters(self.robot) if st.n_pi else np.zeros(0)
        return np.concatenate(
            [tau, [w], ref, ew, sc["v"], sc["a"], sc["u"], sc["T"], self.fractions, pi]
        )

    # ------------------------------------------------------------------ trajectory
    def _trajectory(self, st: Structure, x: np.ndarray) -> Trajectory:
        q, v, a, u, h = self._unpack(st, x)
        names = self.robot.joint_names
        t = np.concatenate([[0.0], np.cumsum(h)])
        q0 = q[0].copy()
        Q = np.empty_like(q)
        Vv = np.empty_like(v)
        Q[0], Vv[0] = q0, 0.0
        if self.mode == "jerk":
            Aa = np.empty_like(a)
            Aa[0] = 0.0
            for k in range(self.N):
                hk, uk = h[k], u[k]
                Q[k + 1] = Q[k] + hk * Vv[k] + hk**2 / 2 * Aa[k] + hk**3 / 6 * uk
                Vv[k + 1] = Vv[k] + hk * Aa[k] + hk**2 / 2 * uk
                Aa[k + 1] = Aa[k] + hk * uk
            # the goal at rest exactly (the integrated controls end within the solver's
            # constraint tolerance of it)
            Q[-1], Vv[-1], Aa[-1] = q[-1], 0.0, 0.0
            J = np.vstack([u, u[-1:]])
            traj = Trajectory(t, Q, Vv, Aa, J, joint_names=names, method="optimal")
        else:
            for k in range(self.N):
                hk, uk = h[k], u[k]
                Q[k + 1] = Q[k] + hk * Vv[k] + hk**2 / 2 * uk
                Vv[k + 1] = Vv[k] + hk * uk
            Q[-1], Vv[-1] = q[-1], 0.0  # the goal at rest exactly, as above
            traj = _ramped_trajectory(t, Q, Vv, u, names)
        traj.meta["knot_times_s"] = t
        return traj

    def _check_dt(self, traj: Trajectory) -> float:
        return self.check_dt or traj.duration / CHECK_SAMPLES

    # ------------------------------------------------------------------ solve
    def _solve_once(self, limits: Limits, x0: np.ndarray):
        st = self._structure(limits)
        lbx, ubx, lbg, ubg = self._bounds(st, limits)
        p = self._params(limits)
        sv = self._scale_vector()
        lbx, ubx = lbx / sv, ubx / sv
        x0 = np.clip(x0 / sv, lbx, ubx)
        t0 = _time.perf_counter()
        res = st.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=p)
        wall = _time.perf_counter() - t0
        s = st.solver.stats()
        xs = np.asarray(res["x"]).ravel()
        x = xs * sv
        info = {
            "return_status": s.get("return_status", ""),
            "success": bool(s.get("success")),
            "iterations": int(s.get("iter_count", 0)),
            "solve_time_s": wall,
            "build_time_s": st.build_time_s,
        }
        if not info["success"] and info["return_status"] in ("Solved_To_Acceptable_Level",):
            info["success"] = True
        if info["success"]:  # accept only if the constraints really hold
            g = np.asarray(st.g_fun(xs, p)).ravel()
            viol = np.maximum(lbg - g, g - ubg)
            scale = np.where(np.isfinite(ubg) & (np.abs(ubg) > 1), np.abs(ubg), 1.0)
            if np.max(viol / scale, initial=0.0) > 1e-6:
                info["success"] = False
                info["return_status"] += " (constraints violated)"
        return st, x, info, (lbx, ubx, lbg, ubg, p, xs)

    def solve(self) -> Trajectory:
        """Solve (with torque back-off rounds) and return the checked Trajectory.

        Raises
        ------
        InfeasibleError
            The request cannot meet its limits; the message names the binding limit and joint.
        """
        x0 = self.x0 if self.x0 is not None else self.make_warm_start()
        torque_on = self.limits.torque_Nm is not None
        jl = self.limits

        def solve(limits: Limits, previous):  # warm: the last good solution
            st, x, info, data = self._solve_once(limits, x0 if previous is None else previous[1])
            return (st, x, data), info

        def check(result) -> dict[str, np.ndarray]:
            traj = self._trajectory(result[0], result[1])
            dt = self._check_dt(traj)
            return traj.check_limits(self.robot, dt=dt, limits=jl, torque=torque_on).ratios

        def fail(result, info) -> NoReturn:
            st, x, data = result
            self._diagnose(st, x, info, data)

        out = backoff_solve(solve, jl, check, max_rounds=self.max_backoff, fail=fail)
        (st, x, _), limits, info, rounds = out.result, out.limits, out.info, out.rounds
        total_iter, total_time = out.iterations, out.solve_time_s
        traj = self._trajectory(st, x)
        dt = self._check_dt(traj)
        # an excess within the solver's tolerance: a uniform stretch by k <= 1 + CHECK_TOL
        traj, k_tol = absorb_tolerance(traj, self.robot, jl, torque=torque_on, dt=dt)
        traj.meta["knot_times_s"] = traj.meta["knot_times_s"] * k_tol
        traj.report = traj.check_limits(self.robot, dt=dt, limits=jl, torque=torque_on)
        binding = [
            (k, traj.joint_names[i], float(r[i]))
            for k, r in traj.report.ratios.items()
            for i in range(len(r))
            if r[i] >= 1 - 2e-3 and k != "position"
        ]
        q, v, a, u, h = self._unpack(st, x)
        stats = {
            # casadi's stubs omit the module's __version__
            "solver": f"ipopt (casadi {ca.__version__})",  # type: ignore[attr-defined]
            "iterations": total_iter,
            "solve_time_s": total_time,
            "build_time_s": info["build_time_s"],
            "n_intervals": self.N,
            "success": traj.report.ok(CHECK_TOL),  # solved and feasible on the fine grid
            "return_status": info["return_status"],
            "backoff_rounds": rounds,
            "objective": self.objective,
            "mode": self.mode,
            "duration_s": float(np.sum(h)) * k_tol,
            "tolerance_stretch": k_tol,
            "binding": binding,
            "report_dt_s": dt,
            "ok": traj.report.ok(CHECK_TOL),
        }
        if self.objective == "energy" or torque_on:
            ew, unit = _energy_weights(self.robot)
            fine = traj.sample(dt)
            stats["energy"] = float(np.trapezoid(fine.torques(self.robot) ** 2 @ ew, fine.t))
            stats["energy_unit"] = unit
        self.stats = stats
        traj.stats = stats
        refuse_violation(traj, "optimal", rounds)
        traj.meta.update(
            {
                "waypoints": self.waypoints.copy(),
                "waypoint_times_s": traj.meta["knot_times_s"][self.waypoint_nodes]
                + (JUMP_RAMP_S / 2 if self.mode != "jerk" else 0.0),
                "limits": self.limits.to_dict(),
                "backed_off_torque_Nm": limits.torque_Nm,  # read-only, or None
            }
        )
        return traj

    # ------------------------------------------------------------------ diagnosis
    def _diagnose(self, st, x, info, data) -> NoReturn:
        lbx, ubx, lbg, ubg, p, xs = data
        status = info["return_status"]
        if self.duration is not None:
            fastest = optimal(
                self.robot,
                self.waypoints,
                v_max=_kw(self.limits.velocity_rad_s),
                a_max=_kw(self.limits.acceleration_rad_s2),
                j_max=_kw(self.limits.jerk_rad_s3),
                tau_max=_kw(self.limits.torque_Nm),
                via_tolerance=self.via_tolerance,
                n_intervals=self.segment_intervals,
            )
            tmin = fastest.stats["duration_s"]
            if self.duration < tmin * (1 + 1e-6):
                kind, joint, _ = _binding_of(fastest)
                raise InfeasibleError(
                    f"{kind} limit: duration {self.duration:.4g} s is shorter than the minimum "
                    f"{tmin:.4g} s, where the {kind} limit of {joint} binds"
                )
        g = np.asarray(st.g_fun(xs, p)).ravel()
        viol = np.maximum(np.maximum(lbg - g, g - ubg), 0.0)
        kinds = st.g_kind
        limit_rows = np.isin(kinds, ["velocity", "position", "torque"])
        if self.limits.torque_Nm is not None:
            tau_rows = kinds == "torque"
            rat = np.abs(g[tau_rows])
            jnt = st.g_joint[tau_rows]
            worst = np.zeros(self.n)
            np.maximum.at(worst, jnt, rat)
            i = int(np.argmax(worst))
            raise InfeasibleError(
                f"torque limit: no trajectory keeps {self.limits.joint_names[i]} within its "
                f"tau_max of {self.limits.torque_Nm[i]:.4g} N m (solver: {status}; peak ratio "
                f"{worst[i]:.3g} at its last iterate)"
            )
        if np.any(viol[limit_rows] > 1e-6):
            r = int(np.argmax(np.where(limit_rows, viol, -1)))
            raise InfeasibleError(
                f"{kinds[r]} limit of {self.limits.joint_names[st.g_joint[r]]} cannot be met "
                f"(solver: {status})"
            )
        raise ArmlabError(f"trajectory optimiser failed ({status}); try more n_intervals")


def _kw(x):
    return False if x is None else x


def _binding_of(traj: Trajectory) -> tuple[str, str, float]:
    best = ("", "", -np.inf)
    assert traj.report is not None  # a solved plan carries its fine-grid check
    for kind, r in traj.report.ratios.items():
        if kind == "position":
            continue
        i = int(np.argmax(r))
        if r[i] > best[2]:
            best = (kind, traj.joint_names[i], float(r[i]))
    return best


def _ramped_trajectory(t, Q, V, U, names) -> Trajectory:
    """Piecewise-constant acceleration, each jump replaced by a ramp of ``JUMP_RAMP_S``.

    The result is the box average (width ``d = JUMP_RAMP_S``) of the piecewise quadratic:
    outside the ramps ``q + a d^2/24``, ``qd``, ``qdd = a``; inside, ``qdd`` is linear. Times are
    shifted by ``d/2`` so the trajectory starts at 0.
    """
    d = JUMP_RAMP_S
    N = U.shape[0]
    n = Q.shape[1]
    acc = np.vstack([np.zeros((1, n)), U, np.zeros((1, n))])  # a_{-1}, a_0..a_{N-1}, a_N
    ts, qs, vs, as_ = [], [], [], []
    for k in range(N + 1):
        for side, a_side in ((-1, acc[k]), (+1, acc[k + 1])):
            if side == -1:  # end of piece k-1, evaluated d/2 before the knot
                if k == 0:
                    qk, vk = Q[0], V[0]
                else:
                    qk = Q[k] - V[k] * d / 2 + a_side * d**2 / 8
                    vk = V[k] - a_side * d / 2
            else:
                qk = Q[k] + V[k] * d / 2 + a_side * d**2 / 8
                vk = V[k] + a_side * d / 2
            ts.append(t[k] + side * d / 2 + d / 2)
            qs.append(qk + a_side * d**2 / 24)
            vs.append(vk)
            as_.append(a_side)
    return Trajectory(
        np.array(ts), np.array(qs), np.array(vs), np.array(as_), joint_names=names, method="optimal"
    )


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
) -> OptimalProblem:
    """Build (do not solve) the problem of :func:`optimal`; same parameters."""
    if payload_kg is not None:
        robot = robot.with_payload(payload_kg)
    if objective not in OBJECTIVES:
        raise InputError(f"objective {objective!r} unknown; choose one of {OBJECTIVES}")
    w = _check_waypoints(robot, waypoints)
    asked = (v_max, a_max, j_max, tau_max)
    ls = resolve_limits(
        robot,
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
        need=[k for k, v in zip(LIMIT_KEYS, asked, strict=True) if v is None],  # the robot's
        where=f"optimal on {robot.name}",
    )
    if ls.acceleration_rad_s2 is None and ls.jerk_rad_s3 is None and ls.torque_Nm is None:
        raise InputError(
            "velocity limits alone have no minimum-time solution: give a_max, j_max or tau_max"
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
    tol = np.asarray(via_tolerance, float)
    tol = np.full(robot.n_joints, float(tol)) if tol.ndim == 0 else tol
    if tol.shape != (robot.n_joints,) or np.any(tol < 0) or not np.all(np.isfinite(tol)):
        raise InputError(f"via_tolerance must be >= 0 rad, scalar or ({robot.n_joints},)")
    exact = np.ones(w.shape[0], bool)
    if np.any(tol > 0):
        exact[1:-1] = False
    _check_static_torque(robot, w, ls, exact)
    nseg = w.shape[0] - 1
    if n_intervals is None:
        n_intervals = max(16, 48 // nseg) if nseg > 1 else 32
    counts = np.asarray(n_intervals)
    seg_n = tuple(int(x) for x in counts) if counts.ndim else (int(counts),) * nseg
    if len(seg_n) != nseg or min(seg_n) < 2:
        raise InputError(f"n_intervals must be >= 2 per segment ({nseg} segments)")
    mode = "jerk" if (ls.jerk_rad_s3 is not None or objective == "jerk") else "acceleration"
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
) -> Trajectory:
    """Time-synchronised optimal trajectory through joint waypoints.

    Parameters
    ----------
    robot : Robot
    waypoints : array (n_waypoints, n_joints)
        Joint positions in [rad]; start and goal are at rest, via points are passed with free
        (continuous) velocity.
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
        Intervals per segment (default 32 for one segment, ``max(16, 48 // n_segments)``).
    check_dt : float, optional
        Step of the fine feasibility check in [s] (default ``T / 4000``).
    max_backoff : int
        Re-solves allowed when the fine check finds a torque above its limit.

    Returns
    -------
    Trajectory
        With ``.report`` (fine-grid :class:`LimitReport` against the request's limits),
        ``.stats`` (solver, iterations, solve_time_s, n_intervals, success, duration_s,
        binding limits ``[(kind, joint, ratio)]``, energy) and ``.meta`` (waypoint times, ...).

    Raises
    ------
    InfeasibleError
        A torque limit below the static gravity torque at a waypoint, a duration shorter than
        the minimum, or a torque limit no trajectory meets — the message names the limit and
        the joint.
    InputError
        Bad shapes, values or keyword combinations; a waypoint outside a joint range
        (:func:`~armlab.trajectory.waypoints.validate_waypoints`).
    """
    prob = build_optimal(
        robot,
        waypoints,
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
        objective=objective,
        duration=duration,
        payload_kg=payload_kg,
        via_tolerance=via_tolerance,
        n_intervals=n_intervals,
        smooth_weight=smooth_weight,
        check_dt=check_dt,
        max_backoff=max_backoff,
        max_iter=max_iter,
    )
    return prob.solve()
