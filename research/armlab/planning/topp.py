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
:mod:`armlab.planning.optimal` with one "joint" ``s``). Joint velocity, acceleration, jerk
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
rounds; the jerk pass backs off whole joint limits, as :mod:`armlab.planning.optimal` does: both
loops are :func:`armlab.planning.timescale.backoff_solve`). ``traj.report`` is the final
check: exact for velocity and acceleration, "feasible on the refined samples" for torque, not
a proof between them. The convex pass
is globally optimal on its grid, the reachability pass greedy on its (denser) rows; the jerk
pass is a local optimum. Jerk-free results have
acceleration steps, replaced by 50 us ramps as in :mod:`armlab.planning.optimal`.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np
from scipy import sparse
from scipy.interpolate import CubicSpline

from armlab._lazy import lazy_import
from armlab.errors import InfeasibleError, InputError
from armlab.planning.optimal import CHECK_SAMPLES, JUMP_RAMP_S
from armlab.planning.timescale import (
    CHECK_TOL,
    absorb_drive_tolerance,
    backoff_solve,
    drive_check,
    refuse_drive_violation,
    refuse_violation,
    tighten_drive,
)
from armlab.planning.tolerance import absorb_tolerance
from armlab.robot import drivetrain, rigid_body
from armlab.robot.limits import LIMIT_KEYS, Limits, resolve_limits
from armlab.trajectory.core import LimitSamples, Trajectory, sample_weights
from armlab.trajectory.waypoints import validate_waypoints

if TYPE_CHECKING:
    import casadi as ca  # the real module for the type checker (CasADi ships type stubs)
else:
    ca = lazy_import("casadi")  # CasADi loads at the first symbolic build, not with the package

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "time_optimal_path",
    "build_topp",
    "ToppProblem",
    "GeometricPath",
    "path_dynamics",
    "path_grid",
]

#: geometric refinement levels of the first and last path intervals
END_REFINEMENT = 8
#: where, inside each path interval, the velocity limit is imposed (besides the nodes)
VELOCITY_POINTS = (0.25, 0.5, 0.75)
#: limits are tightened by this fraction from the start: between the check points the speed
#: and acceleration can exceed them by up to ~3e-4 (measured), which would cost re-solves
LIMIT_MARGIN = 5e-4
#: the jerk pass (nonconvex, IPOPT: a local solver) that reports failure from the convex pass's
#: warm start is solved again from that plan slowed down by these factors of the path speed
JERK_RETRY_SLOWDOWN = (0.5, 0.2)
#: sequential linearisation of the envelope rows (drive_limits): stop when the duration moves
#: by less than this fraction, or after this many convex passes
DRIVE_SCP_TOL = 1e-3
DRIVE_SCP_ITER = 8
#: solvers of the first pass (``method``): :mod:`armlab.planning.reachability`'s two sweeps,
#: or the convex program with IPOPT
METHODS = ("reachability", "convex")


# ----------------------------------------------------------------------------- path
class GeometricPath:
    """A joint path ``q(s)``, ``s`` in [0, 1], with derivatives up to the third.

    Built from joint points ``(n_points, n_joints)`` — a cubic spline (not-a-knot) through
    them, parameterised by normalised cumulative chord length — or from a
    :class:`Trajectory`: its geometry sampled densely (``n_resample`` instants and its knots)
    and treated the same way (its timing is discarded).
    """

    def __init__(self, path, n_joints: int, n_resample: int = 400) -> None:
        self.trajectory = None
        if isinstance(path, Trajectory):
            if path.n_joints != n_joints:
                raise InputError(f"path has {path.n_joints} joints, the robot {n_joints}")
            if path.n_samples < 2 or path.duration <= 0:
                raise InputError("path Trajectory must have at least two samples")
            # its geometry, re-parameterised by chord length: a timed trajectory starts and
            # ends at rest, so q'(t) vanishes there and a time parameter is singular for TOPP
            self.trajectory = path
            t = np.unique(np.concatenate([np.linspace(path.t[0], path.t[-1], n_resample), path.t]))
            pts = path.at(t)[0]
            keep = np.concatenate([[True], np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9])
            keep[-1] = True
            pts = pts[keep]
            if pts.shape[0] < 2:
                raise InputError("path Trajectory does not move")
        else:
            pts = np.asarray(path, dtype=float)
            if pts.ndim != 2 or pts.shape[1] != n_joints or pts.shape[0] < 2:
                raise InputError(
                    f"path has shape {pts.shape}, expected (n_points >= 2, {n_joints})"
                )
            if not np.all(np.isfinite(pts)):
                raise InputError("path contains NaN or infinite values")
        step = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        if np.any(step < 1e-12):
            k = int(np.flatnonzero(step < 1e-12)[0])
            raise InputError(f"path points {k} and {k + 1} coincide; remove the duplicate")
        ss = np.concatenate([[0.0], np.cumsum(step)])
        ss /= ss[-1]
        self.points = pts
        self.s_points = ss
        bc = "not-a-knot" if pts.shape[0] > 3 else "natural"
        self.spline = CubicSpline(ss, pts, bc_type=bc, axis=0)
        self._d = [self.spline.derivative(k) for k in (1, 2, 3)]

    def __call__(self, s) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``q, q', q'', q'''`` at ``s`` (n,), each (n, n_joints)."""
        s = np.clip(np.asarray(s, float).reshape(-1), 0.0, 1.0)
        return self.spline(s), self._d[0](s), self._d[1](s), self._d[2](s)

    def tangent(self, s) -> np.ndarray:
        """``q'`` at ``s`` (n,): (n, n_joints)."""
        return self._d[0](np.clip(np.asarray(s, float).reshape(-1), 0.0, 1.0))


def path_dynamics(robot: Robot, q, dq, ddq) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``m, c, g`` (each (n, n_joints)) so that ``tau = m sdd + c sd^2 + g`` along the path.

    ``q``, ``dq = q'``, ``ddq = q''`` are (n, n_joints); ``g`` in [N m], ``m = M q'`` and
    ``c = M q'' + C(q, q') q'`` in [N m s^2] (batched :mod:`armlab.robot.rigid_body` calls).
    """
    q = np.asarray(q, dtype=float)
    z = np.zeros_like(q)
    # one batched RNEA of the three stacked: rnea(q, 0, 0), rnea(q, 0, q'), rnea(q, q', q'')
    tau = rigid_body.inverse_dynamics(
        robot, np.vstack([q, q, q]), np.vstack([z, z, dq]), np.vstack([z, dq, ddq])
    )
    g, m, c = np.split(tau, 3)
    return m - g, c - g, g


# ----------------------------------------------------------------------------- problem
@dataclass
class ToppProblem:
    """A built TOPP problem: the path, its grid and coefficients; :meth:`solve` returns the
    Trajectory. Attributes: ``s`` (K+1,), ``limits``, ``path``, ``coeffs`` at the nodes and
    interval midpoints."""

    robot: Robot
    path: GeometricPath
    limits: Limits
    s: np.ndarray
    check_dt: float | None
    max_backoff: int
    max_iter: int
    coeffs: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)
    _convex_solver: tuple | None = field(default=None, repr=False)
    train: drivetrain.DriveTrain | None = None
    _b_lin: np.ndarray | None = field(default=None, repr=False)
    method: str = "reachability"

    # ------------------------------------------------------------------ coefficients
    def path_values(self, pts) -> dict[str, np.ndarray]:
        """The path and its dynamics at ``pts`` (m,): ``s``, ``q, d1, d2, d3`` (``q`` and its
        first three derivatives in ``s``) and ``m, c, g`` (:func:`path_dynamics`), each
        (m, n_joints); one path evaluation and one batched RNEA."""
        pts = np.asarray(pts, dtype=float).reshape(-1)
        q, d1, d2, d3 = self.path(pts)
        m, c, g = path_dynamics(self.robot, q, d1, d2)
        return {"s": pts, "q": q, "d1": d1, "d2": d2, "d3": d3, "m": m, "c": c, "g": g}

    def compute_coefficients(
        self, extra=None, extra_d1=None
    ) -> tuple[dict[str, np.ndarray] | None, np.ndarray | None]:
        """:attr:`coeffs`: the :meth:`path_values` at the nodes (``"node"``) and interval
        midpoints (``"mid"``), and ``q'`` at :data:`VELOCITY_POINTS` of each interval
        (``"vel_d1"``). With ``extra`` (m,) and ``extra_d1`` (p,), the same batch also gives
        (and returns) the path values at ``extra`` and ``q'`` at ``extra_d1`` (else None)."""
        s = self.s
        K = s.size - 1
        ds = np.diff(s)
        mid = 0.5 * (s[:-1] + s[1:])
        ex = np.zeros(0) if extra is None else np.asarray(extra, dtype=float).reshape(-1)
        ex_d1 = np.zeros(0) if extra_d1 is None else np.asarray(extra_d1, dtype=float).reshape(-1)
        vel = (s[:-1, None] + ds[:, None] * np.array(VELOCITY_POINTS)).T.reshape(-1)
        values = self.path_values(np.concatenate([s, mid, ex]))
        tangents = self.path.tangent(np.concatenate([vel, ex_d1]))
        parts = {}
        start = 0
        for name, pts in (("node", s), ("mid", mid), ("extra", ex)):
            sl = slice(start, start + pts.size)
            parts[name] = {k: v[sl] for k, v in values.items()}
            start += pts.size
        self.coeffs = {
            "node": parts["node"],
            "mid": parts["mid"],
            "vel_d1": list(tangents[: vel.size].reshape(len(VELOCITY_POINTS), K, -1)),
        }
        return (
            None if extra is None else parts["extra"],
            None if extra_d1 is None else tangents[vel.size :],
        )

    def static_check(self, ls: Limits) -> None:
        """Raise :class:`InfeasibleError` where gravity alone exceeds a torque limit of ``ls``
        at a node or interval midpoint (no path speed helps there)."""
        if ls.torque_Nm is None:
            return
        for name in ("node", "mid"):
            C = self.coeffs[name]
            r = np.abs(C["g"]) / ls.torque_Nm
            k, i = np.unravel_index(int(np.argmax(r)), r.shape)
            if r[k, i] > 1.0:
                raise InfeasibleError(
                    f"torque limit: {ls.joint_names[i]} needs {abs(C['g'][k, i]):.4g} N m to "
                    f"hold the path at s = {C['s'][k]:.3f} against gravity, above its tau_max "
                    f"of {ls.torque_Nm[i]:.4g} N m"
                )

    # ------------------------------------------------------------------ convex pass
    def _rows(self, ls: Limits, scale: dict[str, np.ndarray]):
        """Rows ``A b`` in ``[lo, hi]`` of the convex pass and upper bounds on ``b``.

        Acceleration, torque and velocity are imposed at the midpoint of each interval, where
        ``a_k = (b_{k+1} - b_k) / (2 ds_k)`` and ``b = (b_k + b_{k+1}) / 2`` (second-order
        accurate); velocity also at the nodes (as bounds on ``b_k``). ``scale[kind]`` (K, n)
        tightens the limits of single intervals (local back-off).
        """
        s, K = self.s, self.s.size - 1
        ds = np.diff(s)
        Cm, Cn = self.coeffs["mid"], self.coeffs["node"]
        n = ls.n_joints
        k_idx = np.repeat(np.arange(K), n)  # rows ordered interval-major, joint-minor
        blocks, lo, hi = [], [], []

        def add(alpha, beta, lo_v, hi_v, where):
            # alpha a_k + beta b(where) with b(where) = w0 b_k + w1 b_{k+1}
            frac = {"left": 0.0, "mid": 0.5, "right": 1.0}.get(where, where)
            w0, w1 = 1.0 - frac, frac
            al, be = alpha.reshape(-1), beta.reshape(-1)
            d = np.repeat(2 * ds, n)
            blocks.append((-al / d + w0 * be, al / d + w1 * be))
            lo.append(lo_v.reshape(-1))
            hi.append(hi_v.reshape(-1))

        kinds = []
        Cl = {k: v[:-1] for k, v in Cn.items() if k != "s"}
        Cr = {k: v[1:] for k, v in Cn.items() if k != "s"}
        if ls.velocity_rad_s is not None:  # q'(s)^2 b(s) at 1/4, 1/2, 3/4 of each interval
            sc = scale["velocity"]
            for frac, d1 in zip(VELOCITY_POINTS, self.coeffs["vel_d1"], strict=True):
                add(
                    np.zeros((K, n)),
                    d1**2,
                    np.full((K, n), -np.inf),
                    (ls.velocity_rad_s * sc) ** 2,
                    frac,
                )
                kinds.append("velocity")
        for where, C in (("left", Cl), ("mid", Cm), ("right", Cr)):
            if ls.acceleration_rad_s2 is not None:
                sc = scale["acceleration"]
                add(
                    C["d1"],
                    C["d2"],
                    -ls.acceleration_rad_s2 * sc,
                    ls.acceleration_rad_s2 * sc,
                    where,
                )
                kinds.append("acceleration")
            if ls.torque_Nm is not None:
                sc = scale["torque"]
                add(C["m"], C["c"], -ls.torque_Nm * sc - C["g"], ls.torque_Nm * sc - C["g"], where)
                kinds.append("torque")
        if self.train is not None and self._b_lin is not None and "motor_envelope" in scale:
            b0 = np.maximum(self._b_lin, 0.0)
            for where, C in (("left", Cl), ("mid", Cm), ("right", Cr)):
                frac = {"left": 0.0, "mid": 0.5, "right": 1.0}[where]
                b_at = (1.0 - frac) * b0[:-1] + frac * b0[1:]
                for alpha, beta, hi_v in self._drive_rows(C, b_at, scale["motor_envelope"]):
                    add(alpha, beta, np.full((K, n), -np.inf), hi_v, where)
                    kinds.append("motor_envelope")
        nb = len(blocks)
        rows = np.arange(nb * K * n)
        rr = np.concatenate([rows, rows])
        cc = np.concatenate([np.tile(k_idx, nb), np.tile(k_idx + 1, nb)])
        vv = np.concatenate(
            [np.concatenate([b0 for b0, _ in blocks]), np.concatenate([b1 for _, b1 in blocks])]
        )
        A_sp = sparse.csr_matrix((vv, (rr, cc)), shape=(nb * K * n, K + 1))
        lo_all, hi_all = np.concatenate(lo), np.concatenate(hi)
        if "motor_envelope" in kinds:  # envelope rows switched off by the direction: dropped
            keep = np.isfinite(lo_all) | np.isfinite(hi_all)
            A_sp, lo_all, hi_all = A_sp[keep], lo_all[keep], hi_all[keep]
        A = ca.DM(sparse.csc_matrix(A_sp))
        ub = np.full(K + 1, np.inf)
        if ls.velocity_rad_s is not None:  # node velocity: b_k <= (v scale / q')^2
            sc = scale["velocity"]
            scn = np.minimum(np.vstack([sc[:1], sc]), np.vstack([sc, sc[-1:]]))
            ub = np.min((ls.velocity_rad_s * scn) ** 2 / np.maximum(Cn["d1"] ** 2, 1e-300), axis=1)
        return A, lo_all, hi_all, ub, kinds

    def _drive_rows(self, C: dict, b0: np.ndarray, env_scale: np.ndarray):
        """Linearised envelope rows ``alpha a + beta b <= hi`` (each (K, n)) at one point of
        every interval (coefficients ``C``, linearisation point ``b0`` (K,)): module docstring.
        Inactive rows (by the direction of motion) get ``hi = inf``."""
        tr = self.train
        assert tr is not None
        N, eta, eta_b, J, b_m, f_c, f_v, _, kc = tr.symbolic_coefficients().T
        d1, d2, m, c, g = C["d1"], C["d2"], C["m"], C["c"], C["g"]
        sig = np.sign(d1)
        sig_f = np.where(d1 != 0, sig, np.sign(d2))  # at rest along the path: along q''
        line = tr.derating * tr.torque_constant_Nm_A * tr.supply_voltage_V / tr.resistance_ohm
        peak = tr.peak_motor_torque_Nm
        # tangent points no lower than 2 % of the top path speed: any b0 > 0 gives an upper
        # bound, and near rest a tiny one would make the rows badly scaled
        root = np.sqrt(np.maximum(b0, 0.0))
        root0 = np.maximum(root, 0.02 * max(float(root.max()), 1e-6))[:, None]
        # branch k: alpha a + beta b + gamma sqrt(b) + delta (1: motoring, 2: back-driven)
        branches = []
        for gain in (1.0 / (N * eta), eta_b / N):
            alpha = m * gain + J * N * d1
            beta = c * gain + J * N * d2
            gamma = f_v * d1 * gain + b_m * N * d1
            delta = (g + f_c * sig_f) * gain
            branches.append((alpha, beta, gamma, delta))
        emf = kc * N * np.abs(d1)  # derated Kt Ke / R x |w_m| / sd
        # inside the quadrant band (joint speed below it at the linearisation point) the motor
        # torque is a blend of the two branches (drivetrain.quadrant_share): both bound it
        in_band = np.abs(d1) * root[:, None] < tr.quadrant_band_rad_s
        rows = []
        for k, (alpha, beta, gamma, delta) in enumerate(branches):
            motoring = k == 0
            for side in (1.0, -1.0):  # upper rows: e <= bound; lower: -e <= bound
                active = (sig * side >= 0) | (not motoring) | in_band
                for bound, with_emf in ((line, True), (peak, False)):
                    gam = side * gamma + (emf if with_emf else 0.0)
                    pos = np.maximum(gam, 0.0)  # negative parts dropped (conservative)
                    b_eff = side * beta + pos / (2 * root0)
                    hi = bound * env_scale - side * delta - pos * root0 / 2
                    rows.append((side * alpha, b_eff, np.where(active, hi, np.inf)))
        return rows

    def solve_convex(
        self, ls: Limits, scale: dict[str, np.ndarray] | None = None, b0: np.ndarray | None = None
    ) -> tuple[np.ndarray, dict]:
        """Square path velocities ``b_k`` (K+1,) of the convex pass, and solver info."""
        s, K = self.s, self.s.size - 1
        ds = np.diff(s)
        n = ls.n_joints
        if scale is None:
            scale = {k: np.ones((K, n)) for k in ("velocity", "acceleration", "torque")}
        A, lo, hi, ub, kinds = self._rows(ls, scale)
        key = (tuple(kinds), A.nnz())
        if "motor_envelope" in kinds:
            key = (key, id(A))  # linearised rows: their coefficients change every pass
        if self._convex_solver is None or self._convex_solver[0] != key:
            x = ca.SX.sym("b", K + 1)
            eps = 1e-14
            root = ca.sqrt(x + eps)
            f = ca.sum1(2 * ca.DM(ds) / (root[:-1] + root[1:]))
            nlp = {"x": x, "f": f, "g": ca.mtimes(A, x)}
            opts: dict[str, Any] = {
                "print_time": False,
                "ipopt.print_level": 0,
                "ipopt.sb": "yes",
                "ipopt.tol": 1e-10,
                "ipopt.constr_viol_tol": 1e-10,
                "ipopt.max_iter": self.max_iter,
                "ipopt.mu_strategy": "adaptive",
            }
            self._convex_solver = (key, ca.nlpsol("armlab_topp", "ipopt", nlp, opts))
        solver = self._convex_solver[1]
        lbx = np.zeros(K + 1)
        ubx = ub.copy()
        ubx[0] = ubx[-1] = 0.0
        if b0 is not None:  # warm start: the previous solution, just inside the new bounds
            x0 = np.minimum(b0 * 0.999, ubx)
        else:
            cap = np.where(np.isfinite(ub), ub, 1.0)
            x0 = np.clip(1e-3 * cap, 0, None)
        x0[0] = x0[-1] = 0.0
        t0 = _time.perf_counter()
        res = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lo, ubg=hi)
        wall = _time.perf_counter() - t0
        st = solver.stats()
        b = np.maximum(np.asarray(res["x"]).ravel(), 0.0)
        b[0] = b[-1] = 0.0
        info = {
            "success": bool(st.get("success")),
            "iterations": int(st.get("iter_count", 0)),
            "solve_time_s": wall,
            "return_status": st.get("return_status", ""),
        }
        return b, info

    def interval_ratios(
        self, traj: Trajectory, ls: Limits, dt: float | None, samples: LimitSamples | None = None
    ) -> dict:
        """Peak ratio to each limit per path interval and joint (K, n): the local back-off's
        input. Velocity, acceleration and torque over :meth:`Trajectory.limit_samples` (its
        exact velocity and acceleration peaks, refined torque peaks and the uniform grid of
        step ``dt`` [s]; ``samples`` if the caller has them), so every peak
        :meth:`Trajectory.check_limits` reports is seen; the motor envelope (``drive_limits``)
        on the uniform grid (the RMS needs its weights)."""
        torque_on = ls.torque_Nm is not None
        smp = samples
        if smp is None:
            smp = traj.limit_samples(dt, robot=self.robot if torque_on else None)
        K = self.s.size - 1

        def per_interval(t: np.ndarray, r: np.ndarray) -> np.ndarray:
            s_f = np.interp(t, traj.t, traj.meta["s"])
            k = np.clip(np.searchsorted(self.s, s_f, side="right") - 1, 0, K - 1)
            agg = np.zeros((K, ls.n_joints))
            for i in range(ls.n_joints):
                np.maximum.at(agg[:, i], k, r[:, i])
            return agg

        out = {}
        for kind, x in (("velocity", smp.qd), ("acceleration", smp.qdd), ("torque", smp.tau)):
            lim = ls.get(kind)
            if lim is None or x is None:
                continue
            out[kind] = per_interval(smp.t, np.abs(x) / lim)
        if self.train is not None:  # the envelope per interval; the RMS joint-wide (folded in)
            tr = self.train
            fine = traj.sample(self._uniform_dt(traj))
            tau = fine.torques(self.robot)
            t_m, _ = drivetrain.motor_torque(tau, fine.qd, fine.qdd, tr)
            r = drivetrain.envelope_ratio(t_m, drivetrain.motor_speed(fine.qd, tr), tr)
            rms = drivetrain.rms_torque(t_m, sample_weights(fine.t)) / tr.continuous_torque_Nm
            r = np.minimum(np.maximum(r, rms[None, :]), 2.0)  # inf beyond no-load: cap
            out["motor_envelope"] = per_interval(fine.t, r)
        return out

    def solve_convex_drive(
        self, ls: Limits, scale: dict[str, np.ndarray], b0: np.ndarray | None = None
    ) -> tuple[np.ndarray, dict]:
        """The convex pass with the envelope rows: sequential linearisation (module docstring)
        from the solution without them (or ``b0``); every pass meets its rows."""
        plain = {k: v for k, v in scale.items() if k != "motor_envelope"}
        self._b_lin = None
        b, info = self.solve_convex(ls, plain, b0)
        its, wall = info["iterations"], info["solve_time_s"]
        if not info["success"]:
            return b, info
        tr = self.train
        assert tr is not None
        d1 = self.coeffs["node"]["d1"]
        line = tr.torque_constant_Nm_A * tr.supply_voltage_V / tr.resistance_ohm
        emf = tr.torque_constant_Nm_A * tr.back_emf_V_s_rad / tr.resistance_ohm * tr.ratio
        with np.errstate(divide="ignore"):
            cap = np.min((0.5 * line / (emf * np.abs(d1))) ** 2, axis=1)
        b = np.minimum(b, cap)  # linearise no faster than half the no-load path speed
        T = np.inf
        for _ in range(DRIVE_SCP_ITER):
            self._b_lin = b
            b_new, info = self.solve_convex(ls, scale, b)
            its, wall = its + info["iterations"], wall + info["solve_time_s"]
            if not info["success"]:
                break
            b = b_new
            T_new = self.duration_of(b)
            if abs(T - T_new) <= DRIVE_SCP_TOL * T_new:
                break
            T = T_new
        info = {**info, "iterations": its, "solve_time_s": wall}
        if not info["success"] and np.isfinite(T):  # a later pass failed: the last good one
            info["success"] = True
        return b, info

    def duration_of(self, b: np.ndarray) -> float:
        """Travel time ``sum 2 ds / (sqrt(b_k) + sqrt(b_k+1))`` of square path speeds ``b``."""
        sd = np.sqrt(np.maximum(b, 0.0))
        return float(np.sum(2 * np.diff(self.s) / np.maximum(sd[:-1] + sd[1:], 1e-300)))

    # ------------------------------------------------------------------ trajectories
    def trajectory_from_b(self, b: np.ndarray) -> Trajectory:
        """``s(t)`` with ``sdd`` constant per interval, each jump ramped over ``JUMP_RAMP_S``
        (box average of ``s(t)``), mapped through the path.

        Samples: the ramp edges around every node, 1/4, 1/2 and 3/4 of every interval, and
        the instant the motion passes a spline knot (the first in an interval, outside the
        ramps): the path's third derivative steps there, and a Trajectory piece across it
        (one polynomial, :mod:`armlab.trajectory.core`) overshot the path's acceleration by
        up to 1e-3 of the limit (measured; a back-off round each time)."""
        s = self.s
        ds = np.diff(s)
        sd = np.sqrt(np.maximum(b, 0.0))
        dt = 2 * ds / np.maximum(sd[:-1] + sd[1:], 1e-300)
        a = (b[1:] - b[:-1]) / (2 * ds)
        t = np.concatenate([[0.0], np.cumsum(dt)])
        d = JUMP_RAMP_S
        acc = np.concatenate([[0.0], a, [0.0]])
        K = ds.size
        # per node k (rows): the window edges around it (the acceleration before and after),
        # then the interior samples of interval k at 1/4, 1/2, 3/4 of it (none after the last
        # node, nor within half a window of a node); one (K + 1, 5) table, flattened row-major
        tau = np.zeros((K + 1, 5))
        tau[:, 0], tau[:, 1] = -d / 2, d / 2
        ak = np.empty((K + 1, 5))
        ak[:, 0], ak[:, 1] = acc[:-1], acc[1:]
        dt_k = np.append(dt, 0.0)
        tau[:, 2:] = dt_k[:, None] * np.array([0.25, 0.5, 0.75])
        ak[:, 2:] = acc[1:, None]
        keep = np.ones((K + 1, 5), bool)
        keep[:, 2:] = (d / 2 < tau[:, 2:]) & (tau[:, 2:] < dt_k[:, None] - d / 2)
        keep[K, 2:] = False
        s_k, sd_k, t_k = (np.broadcast_to(x[:, None], (K + 1, 5)) for x in (s, sd, t))
        tau, ak, s_k, sd_k, t_k = (x[keep] for x in (tau, ak, s_k, sd_k, t_k))
        # the spline knots: s_k + sd_k tau + a tau^2 / 2 + a d^2 / 24 = knot (the sample's s)
        k_of, knot = self.knots_in_intervals()
        gap = knot - s[k_of] - a[k_of] * d**2 / 24
        root = np.sqrt(np.maximum(sd[k_of] ** 2 + 2 * a[k_of] * gap, 0.0))
        tau_kn = 2 * gap / np.maximum(sd[k_of] + root, 1e-300)
        inside = (d / 2 < tau_kn) & (tau_kn < dt[k_of] - d / 2)
        k_of, tau_kn = k_of[inside], tau_kn[inside]
        tau = np.concatenate([tau, tau_kn])
        ak = np.concatenate([ak, a[k_of]])
        s_k, sd_k, t_k = (np.concatenate([x, y[k_of]]) for x, y in ((s_k, s), (sd_k, sd), (t_k, t)))
        S = s_k + sd_k * tau + ak * tau**2 / 2 + ak * d**2 / 24
        return self._map(t_k + tau + d / 2, S, sd_k + ak * tau, ak, None)

    def knots_in_intervals(self) -> tuple[np.ndarray, np.ndarray]:
        """The path's interior spline knots, the first in each grid interval holding one, and
        their intervals: ``(k, s_knot)``, as the reachability pass's knot rows."""
        knots = self.path.s_points[1:-1]
        K = self.s.size - 1
        k_of = np.clip(np.searchsorted(self.s, knots, side="right") - 1, 0, K - 1)
        first = np.unique(k_of, return_index=True)[1]
        return k_of[first], knots[first]

    def _map(self, t, S, SD, SDD, SDDD) -> Trajectory:
        order = np.argsort(t, kind="stable")
        t, S, SD, SDD = t[order], S[order], SD[order], SDD[order]
        keep = np.concatenate([[True], np.diff(t) > 1e-12])
        t, S, SD, SDD = t[keep], S[keep], SD[keep], SDD[keep]
        q, d1, d2, d3 = self.path(np.clip(S, 0, 1))
        qd = d1 * SD[:, None]
        qdd = d1 * SDD[:, None] + d2 * SD[:, None] ** 2
        qddd = None
        if SDDD is not None:
            SDDD = SDDD[order][keep]
            qddd = d1 * SDDD[:, None] + 3 * d2 * (SD * SDD)[:, None] + d3 * SD[:, None] ** 3
        qd[[0, -1]] = 0.0
        tr = Trajectory(
            t - t[0],
            q,
            qd,
            qdd,
            qddd,
            joint_names=self.robot.joint_names,
            method="time_optimal_path",
        )
        tr.meta["s"] = S
        tr.meta["sd"] = SD
        return tr

    # ------------------------------------------------------------------ jerk pass
    def solve_jerk(
        self, ls: Limits, b: np.ndarray, env_scale: np.ndarray | None = None
    ) -> tuple[dict, dict]:
        """Second pass with the jerk limit: nodes keep ``s_k``; ``dt_k`` and the path jerk
        ``u_k`` per interval are free (nonconvex, warm-started from ``b``)."""
        s, K = self.s, self.s.size - 1
        ds = np.diff(s)
        Cn = self.coeffs["node"]
        n = ls.n_joints
        c = ca.SX.sym("sd", K + 1)
        a = ca.SX.sym("sdd", K + 1)
        u = ca.SX.sym("sddd", K)
        h = ca.SX.sym("dt", K)
        x = ca.vertcat(c, a, u, h)
        g, lo, hi = [], [], []

        def rows(expr, lo_v, hi_v):
            g.append(expr)
            lo.append(np.broadcast_to(lo_v, (expr.shape[0],)))
            hi.append(np.broadcast_to(hi_v, (expr.shape[0],)))

        ca_, cb = c[:-1], c[1:]
        aa, ab = a[:-1], a[1:]
        rows(ca.DM(ds) - (ca_ * h + aa * h**2 / 2 + u * h**3 / 6), 0.0, 0.0)
        rows(cb - (ca_ + aa * h + u * h**2 / 2), 0.0, 0.0)
        rows(ab - (aa + u * h), 0.0, 0.0)
        d1, d2, d3 = (ca.DM(Cn[k]) for k in ("d1", "d2", "d3"))
        m, cc, gg = (ca.DM(Cn[k]) for k in ("m", "c", "g"))
        C = ca.repmat(c, 1, n)
        Aa = ca.repmat(a, 1, n)
        if ls.velocity_rad_s is not None:
            rows(
                ca.vec(d1 * C),
                -np.repeat(ls.velocity_rad_s, K + 1),
                np.repeat(ls.velocity_rad_s, K + 1),
            )
        if ls.acceleration_rad_s2 is not None:
            rows(
                ca.vec(d1 * Aa + d2 * C**2),
                -np.repeat(ls.acceleration_rad_s2, K + 1),
                np.repeat(ls.acceleration_rad_s2, K + 1),
            )
        if ls.torque_Nm is not None:
            tq = m * Aa + cc * C**2 + gg
            rows(ca.vec(tq), -np.repeat(ls.torque_Nm, K + 1), np.repeat(ls.torque_Nm, K + 1))
        if ls.jerk_rad_s3 is not None:
            for sl, uu in ((slice(0, K), u), (slice(1, K + 1), u)):  # both one-sided jerks
                U = ca.repmat(uu, 1, n)
                Cs, As = C[sl, :], Aa[sl, :]
                jk = d1[sl, :] * U + 3 * d2[sl, :] * Cs * As + d3[sl, :] * Cs**3
                rows(ca.vec(jk), -np.repeat(ls.jerk_rad_s3, K), np.repeat(ls.jerk_rad_s3, K))
        if self.train is not None:
            self._jerk_drive_rows(
                rows, m * Aa + cc * C**2 + gg, d1 * C, d1 * Aa + d2 * C**2, env_scale
            )
        G = ca.vertcat(*g)
        nlp = {"x": x, "f": ca.sum1(h), "g": G}
        opts: dict[str, Any] = {
            "print_time": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",
            "ipopt.tol": 1e-9,
            "ipopt.constr_viol_tol": 1e-9,
            "ipopt.acceptable_tol": 1e-4,
            "ipopt.acceptable_obj_change_tol": 1e-9,
            "ipopt.acceptable_iter": 5,
            "ipopt.acceptable_constr_viol_tol": 1e-9,
            "ipopt.max_iter": self.max_iter,
            "ipopt.mu_strategy": "adaptive",
        }
        solver = ca.nlpsol("armlab_topp_jerk", "ipopt", nlp, opts)
        # warm start: the convex solution, slowed down (sd * beta) until its jerk fits
        x0 = self._jerk_warm_start(ls, b)
        lbx = np.concatenate(
            [np.zeros(K + 1), np.full(K + 1, -np.inf), np.full(K, -np.inf), np.full(K, 1e-6)]
        )
        ubx = np.concatenate(
            [np.full(K + 1, np.inf), np.full(K + 1, np.inf), np.full(K, np.inf), np.full(K, np.inf)]
        )
        for blk in (0, K + 1):  # rest at both ends: sd = sdd = 0
            lbx[blk] = ubx[blk] = 0.0
            lbx[blk + K] = ubx[blk + K] = 0.0
        t0 = _time.perf_counter()
        res = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=np.concatenate(lo), ubg=np.concatenate(hi))
        wall = _time.perf_counter() - t0
        st = solver.stats()
        xs = np.asarray(res["x"]).ravel()
        sol = {
            "sd": xs[: K + 1],
            "sdd": xs[K + 1 : 2 * K + 2],
            "sddd": xs[2 * K + 2 : 3 * K + 2],
            "dt": xs[3 * K + 2 :],
        }
        info = {
            "success": bool(st.get("success"))
            or st.get("return_status") == "Solved_To_Acceptable_Level",
            "iterations": int(st.get("iter_count", 0)),
            "solve_time_s": wall,
            "return_status": st.get("return_status", ""),
        }
        return sol, info

    def _jerk_drive_rows(self, rows, tau, qd, qdd, env_scale) -> None:
        """The envelope rows of the jerk pass, exact (``sd`` is a variable): the rows of
        :data:`armlab.planning.transcription.DRIVE_ROW_TAGS` at the nodes, switched on by the
        direction of motion ``sign(q')``."""
        from armlab.planning.transcription import DRIVE_ROW_TAGS

        tr = self.train
        assert tr is not None
        Cn = self.coeffs["node"]
        K1, n = Cn["d1"].shape
        sig = np.sign(Cn["d1"])
        sig_f = np.where(Cn["d1"] != 0, sig, np.sign(Cn["d2"]))
        coeffs = [ca.DM(np.tile(c, (K1, 1))) for c in tr.symbolic_coefficients().T]
        e1, e2 = drivetrain.motor_torque_branches(tau, qd, qdd, ca.DM(sig_f), coeffs)
        kw = coeffs[8] * coeffs[0] * ca.DM(sig) * qd  # derated Kt Ke / R |w_m|
        env = np.ones(n) if env_scale is None else env_scale
        line = tr.derating * tr.torque_constant_Nm_A * tr.supply_voltage_V / tr.resistance_ohm
        peak = tr.derating * tr.peak_torque_Nm
        exprs = (e1 + kw, e2 + kw, e1 - kw, e2 - kw, e1, e2, e1, e2)
        for expr, tag in zip(exprs, DRIVE_ROW_TAGS, strict=True):
            bound = np.tile((line if tag[0] == "A" else peak) * env, (K1, 1))
            upper = tag[-1] == "+"
            active = (tag[1] == "2") | ((sig >= 0) if upper else (sig <= 0))
            lo = np.where(active & ~upper, -bound, -np.inf)
            hi = np.where(active & upper, bound, np.inf)
            rows(ca.vec(expr), lo.reshape(-1, order="F"), hi.reshape(-1, order="F"))

    def _jerk_warm_start(self, ls: Limits, b: np.ndarray) -> np.ndarray:
        """A consistent (s, sd, sdd, sddd) plan on the grid: the convex ``sd`` profile smoothed,
        slowed down, and re-integrated as a piecewise-cubic ``s(t)`` through the nodes."""
        s, K = self.s, self.s.size - 1
        sd = np.sqrt(np.maximum(b, 0.0))
        # moving average to remove the acceleration steps, then slow down
        w = 5
        ker = np.ones(w) / w
        sm = np.convolve(np.pad(sd, w // 2, mode="edge"), ker, mode="valid")[: K + 1]
        sm[0] = sm[-1] = 0.0
        Cn = self.coeffs["node"]
        beta = 1.0
        for _ in range(40):
            c = sm * beta
            dt = 2 * np.diff(s) / np.maximum(c[:-1] + c[1:], 1e-9)
            t = np.concatenate([[0.0], np.cumsum(dt)])
            # fit a C2 cubic s(t) through (t_k, s_k) with zero end velocity/acceleration
            spl = CubicSpline(t, s, bc_type="clamped")
            cd, cdd, cddd = spl(t, 1), spl(t, 2), spl(t, 3)
            jerk = (
                np.abs(Cn["d1"] * cddd[:, None])
                + 3 * np.abs(Cn["d2"] * (cd * cdd)[:, None])
                + np.abs(Cn["d3"]) * np.abs(cd[:, None]) ** 3
            )
            ratio = np.max(jerk / ls.jerk_rad_s3) if ls.jerk_rad_s3 is not None else 0.0
            if ls.acceleration_rad_s2 is not None:
                acc = np.abs(Cn["d1"] * cdd[:, None]) + np.abs(Cn["d2"]) * cd[:, None] ** 2
                ratio = max(ratio, np.max(acc / ls.acceleration_rad_s2) ** 1.5)
            if ratio <= 1.0:
                break
            beta /= min(max(ratio ** (1 / 3), 1.05), 2.0)
        uu = np.diff(cdd) / dt
        return np.concatenate([cd, cdd, uu, dt])

    def trajectory_from_jerk(self, sol: dict) -> Trajectory:
        """Map the piecewise-cubic ``s(t)`` of the jerk pass through the path."""
        s, K = self.s, self.s.size - 1
        c, a, u, dt = sol["sd"], sol["sdd"], sol["sddd"], sol["dt"]
        t = np.concatenate([[0.0], np.cumsum(dt)])
        times, S, SD, SDD, SDDD = [], [], [], [], []
        for k in range(K):
            for frac in (0.0, 0.25, 0.5, 0.75):
                tau = frac * dt[k]
                times.append(t[k] + tau)
                S.append(s[k] + c[k] * tau + a[k] * tau**2 / 2 + u[k] * tau**3 / 6)
                SD.append(c[k] + a[k] * tau + u[k] * tau**2 / 2)
                SDD.append(a[k] + u[k] * tau)
                SDDD.append(u[k])
        times.append(t[-1])
        S.append(1.0)
        SD.append(0.0)
        SDD.append(0.0)
        SDDD.append(u[-1])
        return self._map(np.array(times), np.array(S), np.array(SD), np.array(SDD), np.array(SDDD))

    # ------------------------------------------------------------------ solve
    def solve(self) -> Trajectory:
        """First pass (``method``: reachability analysis or the IPOPT convex program; the
        envelope pass with ``drive_limits``) with local back-off, the jerk pass if a jerk limit
        is set, the fine-grid check; the Trajectory."""
        t_start = _time.perf_counter()
        if self.train is None and self.method == "reachability":
            from armlab.planning.reachability import interval_coefficients

            interval_coefficients(self)  # all of its points in one batch
        elif not self.coeffs:
            self.compute_coefficients()
        self.static_check(self.limits)
        ls0 = self.limits
        jl = ls0
        # the first pass has no jerk limit
        ls = ls0 if ls0.jerk_rad_s3 is None else resolve_limits(ls0, j_max=False)
        K, n = self.s.size - 1, ls.n_joints
        kinds: tuple[str, ...] = ("velocity", "acceleration", "torque")
        train = self.train
        if train is not None:
            kinds += ("motor_envelope",)
        scale = {k: np.full((K, n), 1 - LIMIT_MARGIN) for k in kinds}
        torque_on = ls0.torque_Nm is not None
        # the envelope rows exist in the convex program only: drive_limits uses it always
        method = "convex" if train is not None else self.method
        first_pass: Any
        if train is not None:
            first_pass = self.solve_convex_drive
        elif method == "reachability":
            from armlab.planning.reachability import solve_reachability  # it imports this module

            def first_pass(ls, scale, b0):
                return solve_reachability(self, ls, scale, b0)
        else:
            first_pass = self.solve_convex
        spent = {"trajectory": 0.0, "check": 0.0}  # wall time [s] outside the solvers

        # first pass with local back-off: the limits of each path interval are scaled
        def solve_first(scale, previous):  # warm: the last good (b, trajectory)
            b, info = first_pass(ls, scale, None if previous is None else previous[0])
            if not info["success"]:
                return (b, None), info
            t0 = _time.perf_counter()
            traj = self.trajectory_from_b(b)
            spent["trajectory"] += _time.perf_counter() - t0
            return (b, traj), info

        def interval_ratios(result) -> dict[str, np.ndarray]:
            traj = result[1]
            t0 = _time.perf_counter()
            dt = self._dt(traj)
            if train is not None:  # the envelope per interval every round; the report at the end
                out = self.interval_ratios(traj, ls0, dt)
            else:  # one limit check per round (kept as the report); per interval only when
                # something is over, from the same samples
                smp = traj.limit_samples(dt, robot=self.robot if torque_on else None)
                traj.report = traj.check_limits(
                    self.robot, dt=dt, limits=jl, torque=torque_on, samples=smp
                )
                ok = traj.report.ok(CHECK_TOL)
                out = {} if ok else self.interval_ratios(traj, ls0, dt, smp)
            spent["check"] += _time.perf_counter() - t0
            return out

        def first_failed(result, info) -> NoReturn:
            raise InfeasibleError(
                f"time_optimal_path: the {method} pass found no parameterisation "
                f"({info['return_status']}); a limit cannot be met along this path"
            )

        first = backoff_solve(
            solve_first,
            scale,
            interval_ratios,
            max_rounds=self.max_backoff,
            fail=first_failed,
            tighten=tighten_intervals,
        )
        (b_convex, traj), rounds = first.result, first.rounds
        total_it, total_t = first.iterations, first.solve_time_s
        passes = ["convex"]
        if ls0.jerk_rad_s3 is not None:

            def solve_jerk(state, previous):  # always warm-started from the first pass
                lim, env = (state[0], state[1]) if train is not None else (state, None)
                sol, info = self.solve_jerk(lim, b_convex, env)
                for slower in JERK_RETRY_SLOWDOWN:  # IPOPT is local: a slower warm start
                    if info["success"]:
                        break
                    sol, info = self.solve_jerk(lim, b_convex * slower**2, env)
                return (self.trajectory_from_jerk(sol) if info["success"] else None), info

            def ratios(traj) -> dict[str, np.ndarray]:
                out = traj.check_limits(
                    self.robot, dt=self._dt(traj), limits=jl, torque=ls0.torque_Nm is not None
                ).ratios
                if train is not None:  # the RMS backs off the envelope (module docstring)
                    d = drive_check(traj, self.robot, train, self._uniform_dt(traj))
                    env = np.maximum(d["motor_envelope"], d["motor_rms"])
                    out = {**out, "motor_envelope": env, "motor_speed": d["motor_speed"]}
                return out

            def jerk_failed(result, info) -> NoReturn:
                raise InfeasibleError(
                    f"time_optimal_path: the jerk pass (IPOPT, a local solver) found no "
                    f"jerk-limited parameterisation from the convex plan nor from it slowed "
                    f"down ({info['return_status']}); give a larger j_max, or j_max=False"
                )

            jerk: Any
            if train is None:
                jerk = backoff_solve(
                    solve_jerk, ls0, ratios, max_rounds=self.max_backoff, fail=jerk_failed
                )
            else:
                ones = np.ones(n)
                jerk = backoff_solve(
                    solve_jerk,
                    (ls0, ones, ones),
                    ratios,
                    max_rounds=self.max_backoff,
                    fail=jerk_failed,
                    tighten=tighten_drive,
                )
            traj = jerk.result
            rounds += jerk.rounds
            total_it += jerk.iterations
            total_t += jerk.solve_time_s
            passes.append("jerk")
        dt = self._dt(traj)
        t0 = _time.perf_counter()
        k_tol = 1.0
        stretch_skipped = None
        drive_ratios: dict[str, np.ndarray] = {}
        # the first pass's report holds when nothing is over (a stretch would be k <= 1)
        if passes != ["convex"] or train is not None or not traj.report.ok(0.0):
            # an excess within the solver's tolerance: a uniform stretch by k <= 1 + CHECK_TOL
            absorbed = absorb_tolerance(traj, self.robot, jl, torque=torque_on, dt=dt)
            traj, k_tol, samples = absorbed.traj, absorbed.k, absorbed.samples
            stretch_skipped = absorbed.skipped
            if train is not None:
                traj, k_drive, drive_ratios = absorb_drive_tolerance(
                    traj, self.robot, train, self._uniform_dt(traj)
                )
                k_tol *= k_drive
                samples = samples if k_drive == 1.0 else None
            traj.meta["sd"] = np.asarray(traj.meta["sd"]) / k_tol
            traj.report = traj.check_limits(
                self.robot, dt=dt, limits=jl, torque=torque_on, samples=samples
            )
        spent["check"] += _time.perf_counter() - t0
        binding = [
            (k, traj.joint_names[i], float(r[i]))
            for k, r in {**traj.report.ratios, **drive_ratios}.items()
            for i in range(len(r))
            if r[i] >= 1 - 2e-3 and k != "position"
        ]
        drive_ok = all(float(np.max(r)) <= 1 + 1e-9 for r in drive_ratios.values())
        report_ok = traj.report.ok(CHECK_TOL) and drive_ok
        solver = "reachability analysis (Pham & Pham 2018)"
        if method == "convex" or "jerk" in passes:
            # casadi's stubs omit the module's __version__
            ipopt = f"ipopt (casadi {ca.__version__})"  # type: ignore[attr-defined]
            solver = ipopt if method == "convex" else f"{solver}; jerk pass: {ipopt}"
        stats = {
            "solver": solver,
            "method": method,
            "iterations": total_it,
            "solve_time_s": total_t,
            "trajectory_time_s": spent["trajectory"],
            "check_time_s": spent["check"],
            "n_intervals": int(self.s.size - 1),
            "success": report_ok,
            "passes": passes,
            "backoff_rounds": rounds,
            "duration_s": traj.duration,
            "tolerance_stretch": k_tol,
            "tolerance_stretch_skipped": stretch_skipped,
            "binding": binding,
            "report_dt_s": dt,
            "ok": report_ok,
            "drive_limits": train is not None,
        }
        if train is not None:
            stats["drive_ratios"] = {k: r.tolist() for k, r in drive_ratios.items()}
        self.stats = stats
        traj.stats = stats
        refuse_violation(traj, "time_optimal_path", rounds)
        refuse_drive_violation(drive_ratios, traj, "time_optimal_path", rounds)
        traj.meta.update(
            {
                "path_s_grid": self.s.copy(),
                "b": b_convex,
                "limits": ls0.to_dict(),
                "path_points": self.path.points.copy(),
            }
        )
        traj.meta["topp"] = self
        stats["wall_time_s"] = _time.perf_counter() - t_start
        return traj

    def _dt(self, traj: Trajectory) -> float | None:
        """The uniform grid [s] the limit check adds to the exact peak points of
        :meth:`Trajectory.limit_samples`: ``check_dt`` if given; else none, except with the
        motor envelope, whose RMS needs uniform samples (``T / CHECK_SAMPLES``)."""
        if self.check_dt is not None or self.train is None:
            return self.check_dt
        return self._uniform_dt(traj)

    def _uniform_dt(self, traj: Trajectory) -> float:
        """The uniform step [s] of the motor-envelope checks: ``check_dt`` or
        ``T / CHECK_SAMPLES``."""
        return self.check_dt or traj.duration / CHECK_SAMPLES

    # ------------------------------------------------------------------ phase plane
    def limit_curves(self, ls: Limits | None = None) -> dict[str, np.ndarray]:
        """Upper bounds on ``sd(s)`` at the nodes: from the velocity limits alone, and the
        maximum velocity curve of all limits (largest ``sd`` for which some ``sdd`` satisfies
        every acceleration and torque limit), for the phase-plane figure."""
        ls = ls or self.limits
        C = self.coeffs["node"]
        K1 = self.s.size
        out = {"s": self.s.copy()}
        if ls.velocity_rad_s is not None:
            bv = np.min(ls.velocity_rad_s**2 / np.maximum(C["d1"] ** 2, 1e-300), axis=1)
        else:
            bv = np.full(K1, np.inf)
        out["velocity"] = np.sqrt(bv)
        bmax = np.empty(K1)
        for k in range(K1):
            lo_a = []  # constraints alpha * a + beta * b in [lo, hi]
            if ls.acceleration_rad_s2 is not None:
                for i in range(ls.n_joints):
                    lo_a.append(
                        (
                            C["d1"][k, i],
                            C["d2"][k, i],
                            -ls.acceleration_rad_s2[i],
                            ls.acceleration_rad_s2[i],
                        )
                    )
            if ls.torque_Nm is not None:
                for i in range(ls.n_joints):
                    lo_a.append(
                        (
                            C["m"][k, i],
                            C["c"][k, i],
                            -ls.torque_Nm[i] - C["g"][k, i],
                            ls.torque_Nm[i] - C["g"][k, i],
                        )
                    )
            bmax[k] = _max_b(lo_a, bv[k])
        out["all"] = np.sqrt(bmax)
        return out


def tighten_intervals(
    scale: dict[str, np.ndarray], over: dict[str, np.ndarray], rounds: int, margin: float
) -> dict[str, np.ndarray]:
    """The convex pass's back-off (``tighten`` of :func:`~armlab.planning.timescale.backoff_solve`)
    on the per-interval limit scales (K, n): at first only the intervals over their limit, by
    their ratio and ``margin``; after that (the residue moves around) the whole kind a little,
    by its peak ratio and ``10 CHECK_TOL``."""
    out = dict(scale)
    for kind, r in over.items():
        f: np.ndarray | float
        if rounds == 0:
            f = np.where(r > 1 + CHECK_TOL, (1 - margin) / np.maximum(r, 1.0), 1.0)
        else:
            f = (1 - 10 * CHECK_TOL) / float(np.max(r))
        out[kind] = scale[kind] * f
    return out


def _max_b(cons, b_cap: float) -> float:
    """Largest ``b <= b_cap`` for which ``lo <= alpha a + beta b <= hi`` has a solution ``a``
    (bisection on b: the feasible ``a`` interval shrinks as b grows past the limits)."""
    if not cons:
        return b_cap

    def feasible(b):
        lo_a, hi_a = -np.inf, np.inf
        for al, be, lo, hi in cons:
            l_, h_ = lo - be * b, hi - be * b
            if abs(al) < 1e-12:
                if l_ > 1e-12 or h_ < -1e-12:
                    return False
                continue
            x1, x2 = l_ / al, h_ / al
            lo_a, hi_a = max(lo_a, min(x1, x2)), min(hi_a, max(x1, x2))
        return lo_a <= hi_a

    hi = b_cap if np.isfinite(b_cap) else 1.0
    if not np.isfinite(b_cap):
        while feasible(hi) and hi < 1e12:
            hi *= 4
        if feasible(hi):
            return hi
    elif feasible(hi):
        return hi
    lo = 0.0
    if not feasible(lo):
        return 0.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if feasible(mid) else (lo, mid)
    return lo


def path_grid(n_intervals: int, end_levels: int = END_REFINEMENT) -> np.ndarray:
    """Uniform grid on [0, 1] whose first and last intervals are split geometrically
    (halves, quarters, ...): from rest the path speed rises in a short distance, and a whole
    uniform interval of constant ``sdd`` would cost up to ``ds / sd`` of extra time there."""
    s = np.linspace(0.0, 1.0, n_intervals + 1)
    ds = s[1]
    extra = ds * 0.5 ** np.arange(1, end_levels + 1)
    return np.unique(np.concatenate([s, extra, 1.0 - extra]))


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
    asked = (v_max, a_max, j_max, tau_max)
    ls = resolve_limits(
        robot,
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
        need=[k for k, v in zip(LIMIT_KEYS, asked, strict=True) if v is None],  # the robot's
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
    return prob.solve()
