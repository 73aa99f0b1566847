r"""Time-optimal path parameterisation (TOPP) of a fixed geometric path.

Given a joint path ``q(s)``, ``s`` in [0, 1], find the fastest ``s(t)`` from rest to rest.
Along the path ``qd = q' sd``, ``qdd = q' sdd + q'' sd^2``, and the inverse dynamics become

.. math::
    \tau = m(s)\,\ddot s + c(s)\,\dot s^2 + g(s),\qquad m = M q',\quad
    c = M q'' + C(q, q')\,q',\quad g = g(q)

(computed numerically with Pinocchio: ``g = rnea(q, 0, 0)``, ``m = rnea(q, 0, q') - g``,
``c = rnea(q, q', q'') - g``; payload included).

Convex pass (Verscheure, Demeulenaere, Swevers, De Schutter, Diehl, IEEE TAC 54(10) 2009)
----------------------------------------------------------------------------------------
With ``b = sd^2`` and ``a = sdd`` (``b' = 2a``), velocity, acceleration and torque limits are
*linear* in ``(a, b)``. On a grid ``s_0 .. s_K`` with ``a`` constant per interval (``b`` linear
in ``s``, ``a_k = (b_{k+1} - b_k) / (2 ds_k)``) the acceleration and torque limits are imposed at
both ends and the midpoint of each interval, the velocity limit at the nodes and at 1/4, 1/2,
3/4 of each interval; the travel time ``T = sum_k 2 ds_k / (sqrt(b_k) + sqrt(b_{k+1}))`` is
convex in ``b``. The problem is solved with CasADi + IPOPT (convex: its local optimum is the
global one on this grid). The first and last intervals are split geometrically (from rest the
path speed rises within a small fraction of a uniform interval, which would otherwise cost up
to ``ds / sd`` there: 1.4 % of the duration at 200 intervals, measured).

Jerk pass (not convex in ``(a, b)``)
-----------------------------------
``qddd = q' sddd + 3 q'' sd sdd + q''' sd^3`` is not convex in the Verscheure variables. When a
jerk limit is given we solve a second, *nonconvex* problem in the time domain on the same
s-grid: the nodes keep their ``s_k``; each interval gets a duration ``dt_k`` and a constant
path jerk ``u_k`` (``s(t)`` piecewise cubic, integrated exactly — the same transcription as
:mod:`armlab.planning.optimal` with one "joint" ``s``). Joint velocity, acceleration, jerk
(both one-sided values) and torque are constrained at the nodes. It is warm-started from the
convex solution slowed down until its jerk fits, and solved with IPOPT: a local optimum.

What is guaranteed
------------------
Limits are imposed at those points; between them the trajectory is checked on a fine grid
(``T/4000``). The limits are tightened by ``LIMIT_MARGIN`` (5e-4) from the start (speed and
acceleration between the check points exceed them by up to ~3e-4 otherwise). The path itself
must stay in the joint ranges (checked densely when the problem is built). Intervals where a
limit is still exceeded by more than ``1e-6`` are tightened by the excess (plus 0.1 %) and the
problem re-solved; residues after that tighten the whole limit kind slightly (``max_backoff``
rounds; the jerk pass backs off whole joint limits, as :mod:`armlab.planning.optimal` does: both
loops are :func:`armlab.planning.timescale.backoff_solve`). ``traj.report`` is the final
fine-grid check: "feasible on the fine grid", not a proof between its samples. The convex pass
is globally optimal on its grid; the jerk pass is a local optimum. Jerk-free results have
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
from armlab.errors import ArmlabError, InfeasibleError, InputError
from armlab.planning.optimal import CHECK_SAMPLES, JUMP_RAMP_S
from armlab.planning.timescale import CHECK_TOL, backoff_solve, refuse_violation
from armlab.planning.tolerance import absorb_tolerance
from armlab.robot import rigid_body
from armlab.robot.limits import LIMIT_KEYS, Limits, resolve_limits
from armlab.trajectory.core import Trajectory
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


def path_dynamics(robot: Robot, q, dq, ddq) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``m, c, g`` (each (n, n_joints)) so that ``tau = m sdd + c sd^2 + g`` along the path.

    ``q``, ``dq = q'``, ``ddq = q''`` are (n, n_joints); ``g`` in [N m], ``m = M q'`` and
    ``c = M q'' + C(q, q') q'`` in [N m s^2] (batched :mod:`armlab.robot.rigid_body` calls).
    """
    z = np.zeros_like(np.asarray(q, dtype=float))
    g = rigid_body.gravity_torques(robot, q)
    m = rigid_body.inverse_dynamics(robot, q, z, dq) - g
    c = rigid_body.inverse_dynamics(robot, q, dq, ddq) - g
    return m, c, g


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

    # ------------------------------------------------------------------ coefficients
    def compute_coefficients(self) -> dict:
        s = self.s
        mid = 0.5 * (s[:-1] + s[1:])
        out: dict[str, Any] = {}
        for name, pts in (("node", s), ("mid", mid)):
            q, d1, d2, d3 = self.path(pts)
            m, c, g = path_dynamics(self.robot, q, d1, d2)
            out[name] = {"s": pts, "q": q, "d1": d1, "d2": d2, "d3": d3, "m": m, "c": c, "g": g}
        ds = np.diff(s)
        out["vel_d1"] = [self.path(s[:-1] + f * ds)[1] for f in VELOCITY_POINTS]
        self.coeffs = out
        return out

    def _static_check(self, ls: Limits) -> None:
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
        nb = len(blocks)
        rows = np.arange(nb * K * n)
        rr = np.concatenate([rows, rows])
        cc = np.concatenate([np.tile(k_idx, nb), np.tile(k_idx + 1, nb)])
        vv = np.concatenate(
            [np.concatenate([b0 for b0, _ in blocks]), np.concatenate([b1 for _, b1 in blocks])]
        )
        A = ca.DM(sparse.csc_matrix((vv, (rr, cc)), shape=(nb * K * n, K + 1)))
        ub = np.full(K + 1, np.inf)
        if ls.velocity_rad_s is not None:  # node velocity: b_k <= (v scale / q')^2
            sc = scale["velocity"]
            scn = np.minimum(np.vstack([sc[:1], sc]), np.vstack([sc, sc[-1:]]))
            ub = np.min((ls.velocity_rad_s * scn) ** 2 / np.maximum(Cn["d1"] ** 2, 1e-300), axis=1)
        return A, np.concatenate(lo), np.concatenate(hi), ub, kinds

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

    def interval_ratios(self, traj: Trajectory, ls: Limits, dt: float) -> dict:
        """Peak ratio to each limit per path interval and joint, on the fine grid (K, n)."""
        fine = traj.sample(dt)
        s_f = np.interp(fine.t, traj.t, traj.meta["s"])
        K = self.s.size - 1
        k = np.clip(np.searchsorted(self.s, s_f, side="right") - 1, 0, K - 1)
        sig = {"velocity": fine.qd, "acceleration": fine.qdd}
        if ls.torque_Nm is not None:
            sig["torque"] = fine.torques(self.robot)
        out = {}
        for kind, x in sig.items():
            lim = ls.get(kind)
            if lim is None:
                continue
            r = np.abs(x) / lim
            agg = np.zeros((K, ls.n_joints))
            for i in range(ls.n_joints):
                np.maximum.at(agg[:, i], k, r[:, i])
            out[kind] = agg
        return out

    # ------------------------------------------------------------------ trajectories
    def trajectory_from_b(self, b: np.ndarray) -> Trajectory:
        """``s(t)`` with ``sdd`` constant per interval, each jump ramped over ``JUMP_RAMP_S``
        (box average of ``s(t)``), mapped through the path."""
        s = self.s
        ds = np.diff(s)
        sd = np.sqrt(np.maximum(b, 0.0))
        dt = 2 * ds / np.maximum(sd[:-1] + sd[1:], 1e-300)
        a = (b[1:] - b[:-1]) / (2 * ds)
        t = np.concatenate([[0.0], np.cumsum(dt)])
        d = JUMP_RAMP_S
        acc = np.concatenate([[0.0], a, [0.0]])
        times, S, SD, SDD = [], [], [], []
        K = ds.size
        for k in range(K + 1):
            # window edges around node k, then interior samples of interval k
            for side, ak in ((-1, acc[k]), (+1, acc[k + 1])):
                tau = side * d / 2
                times.append(t[k] + tau + d / 2)
                S.append(s[k] + sd[k] * tau + ak * tau**2 / 2 + ak * d**2 / 24)
                SD.append(sd[k] + ak * tau)
                SDD.append(ak)
            if k < K:
                for frac in (0.25, 0.5, 0.75):
                    tau = frac * dt[k]
                    if d / 2 < tau < dt[k] - d / 2:
                        times.append(t[k] + tau + d / 2)
                        S.append(s[k] + sd[k] * tau + a[k] * tau**2 / 2 + a[k] * d**2 / 24)
                        SD.append(sd[k] + a[k] * tau)
                        SDD.append(a[k])
        return self._map(np.array(times), np.array(S), np.array(SD), np.array(SDD), None)

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
    def solve_jerk(self, ls: Limits, b: np.ndarray) -> tuple[dict, dict]:
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
        """Convex pass (and jerk pass), fine-grid check, back-off rounds; the Trajectory."""
        if not self.coeffs:
            self.compute_coefficients()
        self._static_check(self.limits)
        ls0 = self.limits
        jl = ls0
        ls = resolve_limits(ls0, j_max=False)  # the convex pass has no jerk limit
        K, n = self.s.size - 1, ls.n_joints
        scale = {
            k: np.full((K, n), 1 - LIMIT_MARGIN) for k in ("velocity", "acceleration", "torque")
        }

        # convex pass with local back-off: the limits of each path interval are scaled
        def solve_convex(scale, previous):  # warm: the last good (b, trajectory)
            b, info = self.solve_convex(ls, scale, None if previous is None else previous[0])
            return (b, self.trajectory_from_b(b) if info["success"] else None), info

        def interval_ratios(result) -> dict[str, np.ndarray]:
            return self.interval_ratios(result[1], ls0, self._dt(result[1]))

        def convex_failed(result, info) -> NoReturn:
            raise InfeasibleError(
                f"time_optimal_path: the convex problem failed ({info['return_status']}); "
                "a limit cannot be met along this path"
            )

        convex = backoff_solve(
            solve_convex,
            scale,
            interval_ratios,
            max_rounds=self.max_backoff,
            fail=convex_failed,
            tighten=_tighten_intervals,
        )
        (b_convex, traj), rounds = convex.result, convex.rounds
        total_it, total_t = convex.iterations, convex.solve_time_s
        passes = ["convex"]
        if ls0.jerk_rad_s3 is not None:

            def solve_jerk(ls: Limits, previous):  # always warm-started from the convex pass
                sol, info = self.solve_jerk(ls, b_convex)
                return (self.trajectory_from_jerk(sol) if info["success"] else None), info

            def ratios(traj) -> dict[str, np.ndarray]:
                return traj.check_limits(
                    self.robot, dt=self._dt(traj), limits=jl, torque=ls0.torque_Nm is not None
                ).ratios

            def jerk_failed(result, info) -> NoReturn:
                raise ArmlabError(
                    f"time_optimal_path: the jerk pass failed ({info['return_status']})"
                )

            jerk = backoff_solve(
                solve_jerk, ls0, ratios, max_rounds=self.max_backoff, fail=jerk_failed
            )
            traj = jerk.result
            rounds += jerk.rounds
            total_it += jerk.iterations
            total_t += jerk.solve_time_s
            passes.append("jerk")
        dt = self._dt(traj)
        # an excess within the solver's tolerance: a uniform stretch by k <= 1 + CHECK_TOL
        torque_on = ls0.torque_Nm is not None
        traj, k_tol = absorb_tolerance(traj, self.robot, jl, torque=torque_on, dt=dt)
        traj.meta["sd"] = np.asarray(traj.meta["sd"]) / k_tol
        traj.report = traj.check_limits(self.robot, dt=dt, limits=jl, torque=torque_on)
        binding = [
            (k, traj.joint_names[i], float(r[i]))
            for k, r in traj.report.ratios.items()
            for i in range(len(r))
            if r[i] >= 1 - 2e-3 and k != "position"
        ]
        stats = {
            # casadi's stubs omit the module's __version__
            "solver": f"ipopt (casadi {ca.__version__})",  # type: ignore[attr-defined]
            "iterations": total_it,
            "solve_time_s": total_t,
            "n_intervals": int(self.s.size - 1),
            "success": traj.report.ok(CHECK_TOL),
            "passes": passes,
            "backoff_rounds": rounds,
            "duration_s": traj.duration,
            "tolerance_stretch": k_tol,
            "binding": binding,
            "report_dt_s": dt,
            "ok": traj.report.ok(CHECK_TOL),
        }
        self.stats = stats
        traj.stats = stats
        refuse_violation(traj, "time_optimal_path", rounds)
        traj.meta.update(
            {
                "path_s_grid": self.s.copy(),
                "b": b_convex,
                "limits": ls0.to_dict(),
                "path_points": self.path.points.copy(),
            }
        )
        traj.meta["topp"] = self
        return traj

    def _dt(self, traj: Trajectory) -> float:
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


def _tighten_intervals(
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
) -> ToppProblem:
    """Build (do not solve) the problem of :func:`time_optimal_path`; same parameters."""
    if payload_kg is not None:
        robot = robot.with_payload(payload_kg)
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
    if ls.velocity_rad_s is None and ls.acceleration_rad_s2 is None and ls.torque_Nm is None:
        raise InputError("time_optimal_path needs at least one of v_max, a_max, tau_max")
    gp = GeometricPath(path, robot.n_joints)
    lo, hi = ls.lower_rad, ls.upper_rad
    pts = validate_waypoints(robot, gp.points, where="time_optimal_path points")
    s_dense = np.linspace(0.0, 1.0, 40 * pts.shape[0] + 400)
    q_dense = gp(s_dense)[0]
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
        jerk limit the nonconvex jerk pass runs after the convex one; ``j_max=False`` gives
        the classical (Verscheure / TOPP-RA) problem.
    payload_kg : float, optional
    n_grid : int, optional
        Path intervals (default 100, 200 for longer or dense paths).
    check_dt : float, optional
        Fine-grid step of the feasibility check in [s] (default ``T / 4000``).
    max_backoff : int
        Re-solves allowed when the fine check finds a limit exceeded between grid points.

    Returns
    -------
    Trajectory
        ``.report`` (fine-grid limit ratios), ``.stats`` (solver, iterations, solve_time_s,
        n_intervals, passes, binding limits), ``.meta["topp"]`` (the problem, for
        :func:`armlab.plots.optimal.plot_phase_plane`).

    Raises
    ------
    InputError
        A path point outside a joint range
        (:func:`~armlab.trajectory.waypoints.validate_waypoints`).
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
    )
    return prob.solve()
