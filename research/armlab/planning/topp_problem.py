"""The TOPP problem (:class:`ToppProblem`): path coefficients, the first pass with local
back-off, the jerk pass, the fine-grid check and the phase plane; built and run by
:func:`armlab.planning.time_optimal_path` (:mod:`armlab.planning.topp`, the method)."""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np

from armlab._lazy import lazy_import
from armlab.errors import InfeasibleError
from armlab.planning import topp_convex, topp_jerk
from armlab.planning.optimal_problem import CHECK_SAMPLES, JUMP_RAMP_S
from armlab.planning.timescale import (
    CHECK_TOL,
    absorb_drive_tolerance,
    backoff_solve,
    drive_check,
    held_over_limit,
    refuse_drive_violation,
    refuse_violation,
    tighten_drive,
)
from armlab.planning.timescale import (
    binding as timescale_binding,
)
from armlab.planning.tolerance import absorb_tolerance
from armlab.planning.topp_path import VELOCITY_POINTS, GeometricPath, path_dynamics
from armlab.robot import drivetrain
from armlab.robot.limits import Limits, resolve_limits
from armlab.trajectory.core import Trajectory
from armlab.trajectory.sampling import LimitSamples, sample_weights

if TYPE_CHECKING:
    import casadi as ca  # the real module for the type checker (CasADi ships type stubs)
else:
    ca = lazy_import("casadi")  # CasADi loads at the first symbolic build, not with the package

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["ToppProblem", "tighten_intervals", "LIMIT_MARGIN", "JERK_RETRY_SLOWDOWN"]

#: limits are tightened by this fraction from the start: between the check points the speed
#: and acceleration can exceed them by up to ~3e-4 (measured), which would cost re-solves
LIMIT_MARGIN = 5e-4
#: the jerk pass (nonconvex, IPOPT: a local solver) that reports failure from the convex pass's
#: warm start is solved again from that plan slowed down by these factors of the path speed
JERK_RETRY_SLOWDOWN = (0.5, 0.2)


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
            over = held_over_limit(np.abs(C["g"]) / ls.torque_Nm)
            if over is not None:
                k, i = over
                raise InfeasibleError(
                    f"torque limit: {ls.joint_names[i]} needs {abs(C['g'][k, i]):.4g} N m to "
                    f"hold the path at s = {C['s'][k]:.3f} against gravity, above its tau_max "
                    f"of {ls.torque_Nm[i]:.4g} N m"
                )

    # ------------------------------------------------------------------ passes
    def solve_convex(
        self, ls: Limits, scale: dict[str, np.ndarray] | None = None, b0: np.ndarray | None = None
    ) -> tuple[np.ndarray, dict]:
        """Square path velocities ``b_k`` (K+1,) of the convex pass, and solver info
        (:func:`armlab.planning.topp_convex.solve_convex`)."""
        return topp_convex.solve_convex(self, ls, scale, b0)

    def solve_convex_drive(
        self, ls: Limits, scale: dict[str, np.ndarray], b0: np.ndarray | None = None
    ) -> tuple[np.ndarray, dict]:
        """The convex pass with the envelope rows
        (:func:`armlab.planning.topp_convex.solve_convex_drive`)."""
        return topp_convex.solve_convex_drive(self, ls, scale, b0)

    def solve_jerk(self, ls: Limits, b: np.ndarray, env_scale=None) -> tuple[dict, dict]:
        """The jerk pass from the first pass's ``b``
        (:func:`armlab.planning.topp_jerk.solve_jerk`)."""
        return topp_jerk.solve_jerk(self, ls, b, env_scale)

    def trajectory_from_jerk(self, sol: dict) -> Trajectory:
        """The Trajectory of a jerk-pass solution
        (:func:`armlab.planning.topp_jerk.trajectory_from_jerk`)."""
        return topp_jerk.trajectory_from_jerk(self, sol)

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
            rms = drivetrain.rms_torque(t_m, sample_weights(fine.t)) / tr.continuous_motor_torque_Nm
            r = np.minimum(np.maximum(r, rms[None, :]), 2.0)  # inf beyond no-load: cap
            out["motor_envelope"] = per_interval(fine.t, r)
        return out

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
        binding = timescale_binding({**traj.report.ratios, **drive_ratios}, traj.joint_names)
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
