"""The optimiser's problem (:class:`OptimalProblem`): its layout on the node grid, the solve
with back-off, the trajectory it hands out and the diagnosis of a failed solve. Built and run
by :func:`armlab.planning.optimal` (:mod:`armlab.planning.optimiser`, the method); warm start
:mod:`.optimal_warmstart`, bounds and parameters :mod:`.optimal_bounds`, transcription
:mod:`.transcription`."""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np

from armlab._lazy import lazy_import
from armlab.errors import ArmlabError, InfeasibleError
from armlab.planning import fatrop_backend, optimal_bounds, optimal_warmstart
from armlab.planning.optimal_bounds import (
    H_MIN_S,
    TIME_REGULARISATION,
    TORQUE_ROW_MARGIN,
    _energy_weights,
)
from armlab.planning.timescale import (
    CHECK_TOL,
    absorb_drive_tolerance,
    backoff_solve,
    drive_check,
    refuse_drive_violation,
    refuse_violation,
    tighten_drive,
)
from armlab.planning.timescale import (
    binding as timescale_binding,
)
from armlab.planning.tolerance import absorb_tolerance
from armlab.planning.transcription import HESSIAN, Structure, structure
from armlab.planning.warmstart import (
    fit_piecewise,
    integrate_piecewise,
)
from armlab.robot import drivetrain
from armlab.robot.limits import Limits
from armlab.trajectory.core import Trajectory
from armlab.trajectory.sampling import sample_times

if TYPE_CHECKING:
    import casadi as ca  # the real module for the type checker (CasADi ships type stubs)
else:
    ca = lazy_import("casadi")  # CasADi loads at the first symbolic build, not with the package

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "OptimalProblem",
    "default_intervals",
    "OBJECTIVES",
    "JUMP_RAMP_S",
    "H_MIN_S",
    "CHECK_SAMPLES",
    "TORQUE_ROW_MARGIN",
    "TIME_REGULARISATION",
]

OBJECTIVES = ("time", "time+smooth", "jerk", "energy")
#: width of the ramp that replaces an acceleration jump (acceleration mode), in [s]
JUMP_RAMP_S = 5e-5
#: samples of the fine feasibility check (~100 per optimisation interval)
CHECK_SAMPLES = 4000
#: start the back-off re-solves from the last solution's multipliers (issue 15)
WARM_RESOLVE = True
#: fewest intervals per segment by default with several segments. 10 was tried (issue 15,
#: teachbot6, 10 and 20 waypoints with torque limits): 25-55 % faster median solves and
#: durations within 4e-4, but the coarser grid let the torque exceed its limit between the
#: nodes more often, and one 20-waypoint case needed 4 fine-grid back-off rounds (the
#: maximum) and 2.6 x the time -- kept at 16
MIN_SEGMENT_INTERVALS = 16


def default_intervals(n_segments: int) -> int:
    """Intervals per segment when ``n_intervals`` is not given: 32 for a single segment,
    else ``max(MIN_SEGMENT_INTERVALS, 48 // n_segments)``."""
    return max(MIN_SEGMENT_INTERVALS, 48 // n_segments) if n_segments > 1 else 32


def _node_directions(w: np.ndarray, seg_n: tuple[int, ...]) -> np.ndarray:
    """Direction of motion of each joint at each node ``(N+1, n)``: the sign of its waypoint
    change in the node's segment; at a via point the common sign of both segments, else 0
    (at rest); 0 at the start and the goal."""
    sig_seg = np.sign(np.where(np.abs(np.diff(w, axis=0)) > 1e-12, np.diff(w, axis=0), 0.0))
    nodes = np.concatenate([[0], np.cumsum(seg_n)])
    out = np.zeros((int(nodes[-1]) + 1, w.shape[1]))
    for s_, (a, b) in enumerate(zip(nodes[:-1], nodes[1:], strict=True)):
        out[a + 1 : b] = sig_seg[s_]
        if s_ > 0:
            out[a] = np.where(sig_seg[s_ - 1] == sig_seg[s_], sig_seg[s_], 0.0)
    return out


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
    drive_limits: bool = False
    train: drivetrain.DriveTrain | None = None
    hessian: str = HESSIAN
    #: replanning from a moving state (issue 15): start speeds [rad/s], start accelerations
    #: [rad/s^2] and goal speeds [rad/s], (n_joints,) each; None is rest
    qd_start: np.ndarray | None = None
    qdd_start: np.ndarray | None = None
    qd_goal: np.ndarray | None = None
    #: clearance rows on the knots (issue 27, :mod:`armlab.planning.optimal_clearance`), and
    #: the last solution (physical variables), the warm start of its next round
    clearance_rows: Any = None
    solution_x: np.ndarray | None = None
    #: set when a "partial" solve failed: the back-off rounds after it use the exact Hessian
    _exact_after_fallback: bool = field(default=False, init=False, repr=False)

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

    def _structure(self, limits: Limits, hessian: str | None = None) -> Structure:
        return structure(
            self.robot,
            self.n,
            self.segment_intervals,
            self.mode,
            self.objective,
            limits.torque_Nm is not None,
            self.duration is not None,
            self.max_iter,
            self.drive_limits,
            hessian or self.hessian,
        )

    @property
    def from_state(self) -> bool:
        """True when the start or the goal is not at rest (``qd_start``, ``qdd_start``,
        ``qd_goal``)."""
        return any(
            x is not None and bool(np.any(x != 0))
            for x in (self.qd_start, self.qdd_start, self.qd_goal)
        )

    def boundary_states(self) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
        """The optimiser's first and last knots, ``(q_0, qd_0, qdd_0), (q_N, qd_N)``.

        Jerk mode: the first waypoint with ``qd_start`` and ``qdd_start``, the last one with
        ``qd_goal`` (and zero acceleration, a bound). Acceleration mode: the trajectory's
        first sample is the start state itself, followed by a linear acceleration ramp of
        ``JUMP_RAMP_S`` from ``qdd_start`` to the first interval's (the box-averaged jumps,
        :func:`_ramped_trajectory`), so the knot is that ramp's state at its middle,
        ``q_0 = w_0 + qd0 d/2 + qdd0 d^2/12``, ``qd_0 = qd0 + qdd0 d/2``; the last sample,
        ``d/2`` after the last knot at constant speed, is the goal: ``q_N = w_N - qd_goal d/2``
        (``d = JUMP_RAMP_S``; at rest both are the waypoints).
        """
        z = np.zeros(self.n)
        v0 = z if self.qd_start is None else self.qd_start
        a0 = z if self.qdd_start is None else self.qdd_start
        v1 = z if self.qd_goal is None else self.qd_goal
        q0, q1 = self.waypoints[0].copy(), self.waypoints[-1].copy()
        if self.mode != "jerk":
            d = JUMP_RAMP_S
            q0, v0 = q0 + v0 * d / 2 + a0 * d**2 / 12, v0 + a0 * d / 2
            q1 = q1 - v1 * d / 2
            a0 = z
        return (q0, v0, a0), (q1, v1)

    def node_directions(self) -> np.ndarray:
        """Direction of motion of each joint at each node, ``(N+1, n)`` (``drive_limits``)."""
        return _node_directions(self.waypoints, self.segment_intervals)

    def _column_directions(self) -> np.ndarray:
        """``(n, n_columns)``: the direction at each point of the drive rows (the nodes in
        jerk mode; left then right end of every interval in acceleration mode)."""
        sig = self.node_directions()
        cols = sig if self.mode == "jerk" else np.vstack([sig[:-1], sig[1:]])
        return cols.T

    def column_nodes(self) -> np.ndarray:
        """The node of each point of the drive rows (:meth:`_column_directions` order)."""
        nodes = np.arange(self.N + 1)
        return nodes if self.mode == "jerk" else np.concatenate([nodes[:-1], nodes[1:]])

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
        """The synchronised S-curve plan (stopping at each via point) on the node grid
        (:func:`~armlab.planning.optimal_warmstart.make_warm_start`)."""
        return optimal_warmstart.make_warm_start(self)

    # ------------------------------------------------------------------ bounds
    def _bounds(self, st: Structure, limits: Limits, drive_scale=None):
        return optimal_bounds.bounds(self, st, limits, drive_scale)

    def _params(self, limits: Limits, drive_scale=None) -> np.ndarray:
        return optimal_bounds.params(self, limits, drive_scale)

    # ------------------------------------------------------------------ trajectory
    def _trajectory(self, st: Structure, x: np.ndarray) -> Trajectory:
        q, v, a, u, h = self._unpack(st, x)
        names = self.robot.joint_names
        t = np.concatenate([[0.0], np.cumsum(h)])
        (q0, v0, a0), (q1, v1) = self.boundary_states()
        if self.mode == "jerk":
            # the solver's controls miss the goal by its constraint tolerance: the smallest
            # change that ends on it, spread over every piece (module docstring)
            goal = np.vstack([q1 - q0, v1, np.zeros(self.n)])
            u = fit_piecewise(h, u, goal, "jerk", start=(v0, a0))
            Q, Vv, Aa = integrate_piecewise(h, u, q0, "jerk", start=(v0, a0))
            # the goal state exactly (the corrected controls end within rounding of it)
            Q[-1], Vv[-1], Aa[-1] = q1, v1, 0.0
            J = np.vstack([u, u[-1:]])
            traj = Trajectory(t, Q, Vv, Aa, J, joint_names=names, method="optimal")
        else:
            Q, Vv, _ = integrate_piecewise(h, u, q0, "acceleration", start=(v0, a0))
            Q[-1], Vv[-1] = q1, v1  # the goal state exactly, as above
            start = None
            if self.from_state:  # the caller's state itself (boundary_states)
                z = np.zeros(self.n)
                start = (
                    self.waypoints[0],
                    z if self.qd_start is None else self.qd_start,
                    z if self.qdd_start is None else self.qdd_start,
                )
            traj = _ramped_trajectory(t, Q, Vv, u, names, start)
        traj.meta["knot_times_s"] = t
        return traj

    def _check_dt(self, traj: Trajectory) -> float:
        return self.check_dt or traj.duration / CHECK_SAMPLES

    # ------------------------------------------------------------------ solve
    def _solve_once(self, limits: Limits, x0: np.ndarray, drive_scale=None, lam=None):
        """One IPOPT solve; a ``"partial"``-Hessian solve that fails (it is capped at
        :data:`~armlab.planning.transcription.PARTIAL_MAX_ITER` iterations) is repeated with
        the exact Hessian from the same start (``info["hessian_fallback"]``)."""
        hessian = "exact" if self._exact_after_fallback else self.hessian
        out = self._attempt(hessian, limits, x0, drive_scale, lam)
        info = out[2]
        if not info["success"] and hessian == "partial" and out[0].torque_rows:
            self._exact_after_fallback = True
            out = self._attempt("exact", limits, x0, drive_scale, None)
            out[2]["iterations"] += info["iterations"]
            out[2]["solve_time_s"] += info["solve_time_s"]
            out[2]["hessian_fallback"] = True
        return out

    def _attempt(self, hessian: str, limits: Limits, x0, drive_scale, lam):
        """One solve: fatrop where it applies, else IPOPT (:mod:`.fatrop_backend`)."""
        return fatrop_backend.attempt(
            self, hessian, limits, x0, drive_scale, lam, self._ipopt_attempt
        )

    def _ipopt_attempt(self, hessian: str, limits: Limits, x0, drive_scale, lam):
        st = self._structure(limits, hessian)
        lbx, ubx, lbg, ubg = self._bounds(st, limits, drive_scale)
        p = self._params(limits, drive_scale)
        if self.clearance_rows is not None:  # issue 27: rows C q_k >= l (optimal_clearance)
            st, p, lbg, ubg = self.clearance_rows.extend(st, p, lbg, ubg)
        sv = self._scale_vector()
        lbx, ubx = lbx / sv, ubx / sv
        x0 = np.clip(x0 / sv, lbx, ubx)
        t0 = _time.perf_counter()
        if lam is not None and WARM_RESOLVE:  # a back-off round: from the last multipliers
            res = st.warm_solver()(
                x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=p, lam_x0=lam[0], lam_g0=lam[1]
            )
        else:
            res = st.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=p)
        wall = _time.perf_counter() - t0
        s = (st.warm_solver() if lam is not None and WARM_RESOLVE else st.solver).stats()
        xs = np.asarray(res["x"]).ravel()
        lam_out = (np.asarray(res["lam_x"]).ravel(), np.asarray(res["lam_g"]).ravel())
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
        return st, x, info, (lbx, ubx, lbg, ubg, p, xs), lam_out

    def solve(self) -> Trajectory:
        """Solve (with torque back-off rounds) and return the checked Trajectory.

        Raises
        ------
        InfeasibleError
            The request cannot meet its limits; the message names the binding limit and joint.
        """
        x0 = self.x0 if self.x0 is not None else self.make_warm_start()
        self._exact_after_fallback = False
        torque_on = self.limits.torque_Nm is not None
        jl = self.limits
        train = self.train if self.drive_limits else None

        def solve(state, previous):  # warm: the last good solution
            limits, scale = (state[0], state[1:]) if train is not None else (state, None)
            warm = x0 if previous is None else previous[1]
            lam = None if previous is None else previous[3]
            st, x, info, data, lam_out = self._solve_once(limits, warm, scale, lam)
            return (st, x, data, lam_out), info

        checked: dict[str, Any] = {}  # the last check's plan and samples, reused below

        def check(result) -> dict[str, np.ndarray]:
            traj = self._trajectory(result[0], result[1])
            dt = self._check_dt(traj)
            # with the drive rows, the torques serve the drive check (drive_check)
            with_tau = torque_on or train is not None
            smp = traj.limit_samples(dt, robot=self.robot if with_tau else None)
            ratios = traj.check_limits(
                self.robot, dt=dt, limits=jl, torque=torque_on, samples=smp
            ).ratios
            drive = drive_check(traj, self.robot, train, dt, smp) if train is not None else None
            checked.update(x=result[1], traj=traj, samples=smp, drive=drive)
            return ratios if drive is None else {**ratios, **drive}

        def fail(result, info) -> NoReturn:
            st, x, data, _ = result
            self._diagnose(st, x, info, data)

        out: Any
        if train is None:
            out = backoff_solve(solve, jl, check, max_rounds=self.max_backoff, fail=fail)
            limits = out.limits
        else:
            ones = np.ones(self.n)
            out = backoff_solve(
                solve,
                (jl, ones, ones),
                check,
                max_rounds=self.max_backoff,
                fail=fail,
                tighten=tighten_drive,
            )
            limits = out.limits[0]
        (st, x, _, _), info, rounds = out.result, out.info, out.rounds
        self.solution_x = x
        total_iter, total_time = out.iterations, out.solve_time_s
        reuse = checked.get("x") is x  # the plan the last back-off check sampled
        traj = checked["traj"] if reuse else self._trajectory(st, x)
        dt = self._check_dt(traj)
        # an excess within the solver's tolerance: a uniform stretch by k <= 1 + CHECK_TOL
        # (where the plan passes a pose whose gravity alone exceeds a torque limit, held there
        # by its dynamics, the report below is the verdict: issue 15, 1 of 250 random
        # 5-waypoint problems)
        absorbed = absorb_tolerance(
            traj,
            self.robot,
            jl,
            torque=torque_on,
            dt=dt,
            samples=checked["samples"] if reuse else None,
        )
        traj, k_tol, samples = absorbed.traj, absorbed.k, absorbed.samples
        stretch_skipped = absorbed.skipped
        drive_ratios: dict[str, np.ndarray] = {}
        if train is not None:
            # the last check's drive ratios where the plan is the one it checked, unstretched
            last = checked.get("drive") if reuse and absorbed.traj is checked["traj"] else None
            traj, k_drive, drive_ratios = absorb_drive_tolerance(traj, self.robot, train, dt, last)
            k_tol *= k_drive
            samples = samples if k_drive == 1.0 else None
        traj.meta["knot_times_s"] = traj.meta["knot_times_s"] * k_tol
        if samples is None:  # a stretched plan: its own samples (the energy below reads them)
            samples = traj.limit_samples(dt, robot=self.robot if torque_on else None)
        traj.report = traj.check_limits(
            self.robot, dt=dt, limits=jl, torque=torque_on, samples=samples
        )
        binding = timescale_binding({**traj.report.ratios, **drive_ratios}, traj.joint_names)
        drive_ok = all(float(np.max(r)) <= 1 + 1e-9 for r in drive_ratios.values())
        q, v, a, u, h = self._unpack(st, x)
        stats = {
            # the solver of the last solve ("fatrop" or "ipopt") and why not fatrop
            # (fatrop_backend.attempt); casadi's stubs omit the module's __version__
            "solver": info.get("solver", "ipopt"),
            "fallback": info.get("fallback", ""),
            "casadi_version": ca.__version__,  # type: ignore[attr-defined]
            "hessian": self.hessian,
            "hessian_fallback": self._exact_after_fallback,
            "iterations": total_iter,
            "solve_time_s": total_time,
            "build_time_s": info["build_time_s"],
            "n_intervals": self.N,
            "success": traj.report.ok(CHECK_TOL) and drive_ok,  # feasible on the fine grid
            "return_status": info["return_status"],
            "backoff_rounds": rounds,
            "objective": self.objective,
            "mode": self.mode,
            "duration_s": float(np.sum(h)) * k_tol,
            "tolerance_stretch": k_tol,
            "tolerance_stretch_skipped": stretch_skipped,
            "binding": binding,
            "report_dt_s": dt,
            "ok": traj.report.ok(CHECK_TOL) and drive_ok,
            "drive_limits": train is not None,
        }
        if train is not None:
            stats["drive_ratios"] = {k: r.tolist() for k, r in drive_ratios.items()}
            # how the RMS row was met (fatrop_backend._fatrop; IPOPT solves it with the rest)
            stats["drive_rms"] = info.get("drive_rms", "solved with the RMS row")
        if self.objective == "energy" or torque_on:
            stats["energy"], stats["energy_unit"] = _fine_energy(traj, self.robot, dt, samples)
        self.stats = stats
        traj.stats = stats
        try:
            refuse_violation(traj, "optimal", rounds)
        except InfeasibleError as exc:
            raise _BackoffStalled(str(exc)) from None
        refuse_drive_violation(drive_ratios, traj, "optimal", rounds)
        wp_times = traj.meta["knot_times_s"][self.waypoint_nodes] + (
            JUMP_RAMP_S / 2 if self.mode != "jerk" else 0.0
        )
        if self.from_state and self.mode != "jerk":  # the first and last samples (boundary_states)
            wp_times[0], wp_times[-1] = traj.t[0], traj.t[-1]
        traj.meta.update(
            {
                "waypoints": self.waypoints.copy(),
                "waypoint_times_s": wp_times,
                "limits": self.limits.to_dict(),
                "backed_off_torque_Nm": limits.torque_Nm,  # read-only, or None
                "qd_start": None if self.qd_start is None else self.qd_start.copy(),
                "qdd_start": None if self.qdd_start is None else self.qdd_start.copy(),
                "qd_goal": None if self.qd_goal is None else self.qd_goal.copy(),
            }
        )
        return traj

    # ------------------------------------------------------------------ diagnosis
    def _diagnose(self, st, x, info, data) -> NoReturn:
        lbx, ubx, lbg, ubg, p, xs = data
        status = info["return_status"]
        if self.duration is not None:
            from armlab.planning.optimiser import optimal  # it builds this class

            fastest = optimal(
                self.robot,
                self.waypoints,
                v_max=_kw(self.limits.velocity_rad_s),
                a_max=_kw(self.limits.acceleration_rad_s2),
                j_max=_kw(self.limits.jerk_rad_s3),
                tau_max=_kw(self.limits.torque_Nm),
                via_tolerance=self.via_tolerance,
                n_intervals=self.segment_intervals,
                drive_limits=self.drive_limits,
                hessian=self.hessian,
                qd_start=self.qd_start,
                qdd_start=self.qdd_start,
                qd_goal=self.qd_goal,
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
        drive_rows = np.isin(kinds, ["motor_envelope", "motor_rms"])
        if np.any(drive_rows & (viol > 1e-6)):
            r = int(np.argmax(np.where(drive_rows, viol, -1)))
            what = "envelope" if kinds[r] == "motor_envelope" else "RMS torque rating"
            raise InfeasibleError(
                f"motor {what}: no trajectory keeps the motor of "
                f"{self.limits.joint_names[st.g_joint[r]]} within its {what} (drive_limits; "
                f"solver: {status})"
            )
        if self.limits.torque_Nm is not None:
            tau_rows = kinds == "torque"
            rat = np.abs(g[tau_rows])
            jnt = st.g_joint[tau_rows]
            worst = np.zeros(self.n)
            np.maximum.at(worst, jnt, rat)
            i = int(np.argmax(worst))
            kinematic = np.any(viol[limit_rows] > 1e-6)
            # a kinematic limit broken while every torque holds: name that one (below)
            if not (kinematic and worst[i] <= 1 + 1e-6):
                raise InfeasibleError(
                    f"torque limit: no trajectory keeps {self.limits.joint_names[i]} within "
                    f"its tau_max of {self.limits.torque_Nm[i]:.4g} N m (solver: {status}; "
                    f"peak ratio {worst[i]:.3g} at its last iterate)"
                )
        if np.any(viol[limit_rows] > 1e-6):
            r = int(np.argmax(np.where(limit_rows, viol, -1)))
            hint = (
                " from the start state (qd_start, qdd_start): it cannot be braked in time"
                if self.from_state
                else ""
            )
            raise InfeasibleError(
                f"{kinds[r]} limit of {self.limits.joint_names[st.g_joint[r]]} cannot be met"
                f"{hint} (solver: {status})"
            )
        raise _NotConverged(f"trajectory optimiser failed ({status}); try more n_intervals")


class _NotConverged(ArmlabError):
    """The solver stopped (iteration limit, restoration failure) with no limit violated at its
    last iterate: not a proof of infeasibility; :func:`optimal` retries on a finer grid."""


class _BackoffStalled(_NotConverged, InfeasibleError):
    """The fine-grid back-off ended with the plan still over a limit (the refusal of
    :func:`~armlab.planning.timescale.refuse_violation`, its message): the excess lies between
    the knots, where the node-wise torque rows do not see it (module docstring, "Back-off on a
    finer grid"); :func:`optimal` retries on finer grids (:data:`FINER_GRIDS`), and refuses
    with this message if those do not meet the limits either."""


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


def _fine_energy(traj: Trajectory, robot: Robot, dt: float, samples) -> tuple[float, str]:
    """``(int sum_i w_i tau_i^2 dt, unit)`` by the trapezoidal rule on the uniform grid of
    ``traj.sample(dt)`` (weights :func:`~armlab.planning.optimal_bounds._energy_weights`).

    The torques on that grid are read from ``samples`` (``traj``'s limit samples at ``dt``
    with torques: they hold every grid time, evaluated and RNEA'd from the same numbers as
    ``traj.sample(dt)``, so the rows are the same floats); where a grid time is not among
    them (or the samples have no torques) the grid is sampled and its torques computed."""
    ew, unit = _energy_weights(robot)
    times = traj.t[0] + sample_times(traj.duration, dt)
    times[-1] = traj.t[-1]  # as Trajectory.sample
    tau = None
    if samples is not None and samples.tau is not None:
        rows = np.searchsorted(samples.t, times, "right") - 1  # a knot's own row: its last
        if np.array_equal(samples.t[rows], times):
            tau = samples.tau[rows]
    if tau is None:
        fine = traj.sample(dt)
        times, tau = fine.t, fine.torques(robot)
    return float(np.trapezoid(tau**2 @ ew, times)), unit


def _ramped_trajectory(t, Q, V, U, names, start=None) -> Trajectory:
    """Piecewise-constant acceleration, each jump replaced by a ramp of ``JUMP_RAMP_S``.

    The result is the box average (width ``d = JUMP_RAMP_S``) of the piecewise quadratic:
    outside the ramps ``q + a d^2/24``, ``qd``, ``qdd = a``; inside, ``qdd`` is linear. Times are
    shifted by ``d/2`` so the trajectory starts at 0. ``start = (q, qd, qdd)`` (replanning
    from a moving state): the first sample is that state, and the first ramp goes from its
    acceleration to the first interval's (the first knot is then the ramp's state at its
    middle, :meth:`OptimalProblem.boundary_states`).
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
    if start is not None:
        qs[0], vs[0], as_[0] = (np.asarray(x, float) for x in start)
    return Trajectory(
        np.array(ts), np.array(qs), np.array(vs), np.array(as_), joint_names=names, method="optimal"
    )
