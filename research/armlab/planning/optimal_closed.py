r"""The closed form behind :func:`~armlab.planning.optimal` where it solves the problem exactly.

Which problems (issue 26)
-------------------------
:func:`~armlab.planning.optimal` with the ``"time"`` objective between **two** waypoints, at
rest at both ends (no ``qd_start``, ``qdd_start``, ``qd_goal``), with finite velocity,
acceleration and jerk limits and **no** torque limit and no ``drive_limits``. The
transcription's problem is then: minimise the common duration ``T`` of a motion in which every
joint ``i`` moves ``D_i`` from rest to rest within ``|qd_i| <= v_i``, ``|qdd_i| <= a_i``,
``|qddd_i| <= j_i`` (the position range holds on its own: a rest-to-rest double S is monotone,
so it stays between two waypoints that are inside the range).

The joints are coupled only by the common ``T``: joint ``i`` alone needs at least ``t_i``, its
time-optimal double S (Biagiotti & Melchiorri §3.4; :func:`double_s_min_times`), so no
synchronised motion is shorter than ``T* = max_i t_i``; and every joint can take any
``T >= t_i`` within its limits (the double S with a lower peak speed,
:func:`double_s_speed_for_duration`, in closed form). Hence ``T*`` is the minimum of the time
objective, and :func:`~armlab.trajectory.profiles.synchronised_scurves` (Jiang 1987, eq. 1-5
with a double S per joint) gives a motion that reaches it. "Exactly" means: the same
**duration** as the transcription's optimum, which the transcription reaches too (its grid holds
the slowest joint's switching instants); the other joints' profiles are not unique (the
transcription's ``1e-7`` smoothness term picks one, the closed form the stretched double S),
and both are within every limit. Measured on teachbot6 (tests): durations within 1e-6 s of
IPOPT's.

The result holds the exact piecewise cubic: its samples are the switching instants of every
joint (jerk constant between them, the jerk of the phase), so :meth:`Trajectory.at` evaluates
it exactly.

What is verified, and how (``stats["limit_check"]``)
----------------------------------------------------
A result is returned only with its check. The check is exact and made on the phase data
(:func:`exact_report`, :meth:`SCurveBatch.peaks <armlab.trajectory.profiles.SCurveBatch.peaks>`):
within a phase the jerk is constant, the acceleration linear and the speed quadratic, so each
joint's peak ``|qdd|`` is at a phase end, its peak ``|qd|`` at a phase end or where the
acceleration crosses zero inside a phase, its ``|qddd|`` that of a phase of positive length;
its speed never against the move means the position is monotone, so the range ratio is that
of the two waypoints; the end of the last phase is the goal at rest within
:data:`ARRIVAL_TOL` (``stats["arrival_residual"]``). The Trajectory's samples are these phase
data at the switching instants, so the ratios are those of its evaluation too (tests: equal to
:meth:`Trajectory.check_limits` within 1e-12). Where the phase data do not show it (a speed
against the move, an end off the goal) or the caller asks for a grid (``check_dt``), the
samples are checked (:meth:`Trajectory.check_limits`) instead, and ``stats["limit_check"]``
says so. :func:`~armlab.planning.ptp_sync` uses the same check for its rest-to-rest S-curves
and trapezoids without a torque limit.

``stats["method"] = "closed_form"``; :func:`~armlab.planning.build_optimal` (the engine) still
solves the same problem by transcription.
"""

from __future__ import annotations

import time as _time
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from armlab.planning import closed_graph, timescale
from armlab.planning.timescale import BINDING, CHECK_TOL
from armlab.robot.limits import Limits, resolve_limits
from armlab.trajectory.core import Trajectory
from armlab.trajectory.profiles.ops import NP
from armlab.trajectory.sampling import LimitReport, fixed_times
from armlab.trajectory.waypoints import range_with_tolerance

if TYPE_CHECKING:
    from armlab.planning.optimal_problem import OptimalProblem

__all__ = [
    "closed_form_applies",
    "closed_form_optimal",
    "exact_check",
    "exact_report",
    "EXACT_CHECK",
    "SAMPLE_CHECK",
]


def closed_form_applies(prob: OptimalProblem) -> bool:
    """True where the closed form is the optimum of ``prob`` (module docstring): the time
    objective, two waypoints at rest, finite v/a/j limits, no torque limit, no drive limits."""
    ls = prob.limits
    return (
        prob.objective == "time"
        and prob.waypoints.shape[0] == 2
        and prob.mode == "jerk"
        and not prob.from_state
        and not prob.drive_limits
        and ls.torque_Nm is None
        and ls.derived("finite v/a/j", _finite_vaj)
    )


def _finite_vaj(ls) -> bool:
    """Velocity, acceleration and jerk limits given and finite for every joint (kept with
    the Limits: :meth:`~armlab.robot.Limits.derived`)."""
    kin = (ls.velocity_rad_s, ls.acceleration_rad_s2, ls.jerk_rad_s3)
    return all(x is not None and bool(np.isfinite(x).all()) for x in kin)


def _knots(t0: np.ndarray, T: float) -> np.ndarray:
    """Every joint's switching instants (the phase starts ``t0``, (7, n_joints)) and the
    ends, sorted and merged as :func:`~armlab.trajectory.sampling.sample_times` keeps knots
    (:func:`~armlab.trajectory.sampling.fixed_times`)."""
    return np.concatenate(((0.0,), fixed_times(t0[1:], T)))


#: what the exact check of a closed-form plan verified (``stats["limit_check"]``)
EXACT_CHECK = (
    "exact, from each joint's phase data: peak |qd| at the phase ends and where the "
    "acceleration crosses zero, peak |qdd| at the phase ends, |qddd| of every phase, the "
    "speed never against the move (positions between start and goal), the end state at the "
    "goal at rest within rounding"
)
#: ``stats["limit_check"]`` where the samples were checked (:meth:`Trajectory.check_limits`)
SAMPLE_CHECK = "samples (Trajectory.check_limits)"
#: the end state of the phase data against the goal at rest, relative to the move (position)
#: and to the limits (speed, acceleration): rounding only
ARRIVAL_TOL = 1e-10


def exact_report(batch, start, goal, limits, joint_names) -> tuple[LimitReport, float] | None:
    """The :class:`~armlab.trajectory.sampling.LimitReport` of one synchronised double S
    (``batch`` of one problem, :func:`~armlab.trajectory.profiles.synchronised_scurves`)
    from its phase data, exactly (:meth:`SCurveBatch.peaks`), and the largest arrival residual
    (relative, :data:`ARRIVAL_TOL`); None where the phase data do not show what the exact check
    needs (a speed against the move, an end state off the goal at rest): the caller then
    checks the samples.

    A rest-to-rest double S moves monotonically (its speed never changes sign), so its
    positions stay between ``start`` and ``goal`` and their peak ratio to the range is at an
    end; its speed, acceleration and jerk peak at the phase ends or (speed) where the
    acceleration crosses zero inside a phase (Biagiotti & Melchiorri §3.4): the ratios below
    are those of the motion, not of samples of it.
    """
    pk = batch.peaks_flat()
    v, a, j = limits.velocity_rad_s, limits.acceleration_rad_s2, limits.jerk_rad_s3
    centre, half = limits.centre_half_rad()
    T = float(batch.duration.reshape(-1)[0])
    # a trapezoid (j = inf in the batch) has no jerk signal: no jerk ratio, as for its samples
    jerk = j if batch.jerk_finite else None
    arrived, residual, ratios, at_s = exact_check(
        NP, pk, batch.distance.reshape(-1), v, a, jerk, start, goal, centre, half, T
    )
    if not arrived:
        return None
    residual = float(residual)
    report = LimitReport(list(joint_names))
    report.ratios.update(ratios)
    report.at_s.update(at_s)
    return report, residual


def exact_check(ops, pk, D, v, a, j, start, goal, centre, half, T) -> tuple:
    """What :func:`exact_report` reads from the peaks ``pk`` (:meth:`SCurveBatch.peaks_flat`)
    of one synchronised double S, written once against a backend ``ops``
    (:mod:`armlab.trajectory.profiles.ops`: numpy, and CasADi SX in the closed form's graph,
    :mod:`armlab.planning.closed_graph`): ``(arrived, residual, ratios, at_s)``.

    * ``arrived``: the phase data show the check -- the residual not above
      :data:`ARRIVAL_TOL` and no joint's speed against the move above ``ARRIVAL_TOL * v``
      (else :func:`exact_report` returns None and the samples are checked);
    * ``residual``: the largest arrival residual, NaN if any is: ``| end_position - |D| | /
      (1 + |D|)``, ``|end_velocity| / v``, ``|end_acceleration| / a`` (``a`` None: left out);
    * ``ratios``, ``at_s``: by kind, the position ratio ``max(r0, r1)`` of the two ends
      (``r = |q - centre| / half``) at ``T`` where ``r1 > r0``, else 0; the velocity,
      acceleration and jerk peaks over their limits and their times (a limit None: no kind).
    """
    L = abs(D)
    off = [abs(pk["end_position"] - L) / (1.0 + L), abs(pk["end_velocity"]) / v]
    if a is not None:
        off.append(abs(pk["end_acceleration"]) / a)
    residual = ops.nanmax(ops.concat(off))
    reverse = ops.any_of(pk["reverse"] > ARRIVAL_TOL * v)
    arrived = ops.and_(ops.not_(residual > ARRIVAL_TOL), ops.not_(reverse))
    r0, r1 = abs(start - centre) / half, abs(goal - centre) / half
    ratios = {"position": ops.fmax(r0, r1)}
    at_s = {"position": ops.where(r1 > r0, T, 0.0)}  # the start where both are equal
    for kind, lim in (("velocity", v), ("acceleration", a), ("jerk", j)):
        if lim is not None:
            ratios[kind] = pk[kind] / lim
            at_s[kind] = pk[f"{kind}_at_s"]
    return arrived, residual, ratios, at_s


class _Plan(NamedTuple):
    """What every closed-form plan of one resolved :class:`~armlab.robot.Limits` shares (made
    once per Limits, :meth:`~armlab.robot.Limits.derived`): the graph's parameters ``P``
    (:mod:`~armlab.planning.closed_graph`: ``v, a, j``, the range with
    :data:`~armlab.trajectory.waypoints.RANGE_TOL_RAD`, its centre and half), read-only; the
    joint names; the ``(kind, joint)`` of each binding flag."""

    P: np.ndarray
    shape: tuple[int, int]
    names: tuple[str, ...]
    labels: tuple[tuple[str, str], ...]
    t: int  # where the knots start in the output
    samples: slice  # q, qd, qdd, qddd: (4, S, n)
    checks: slice  # the ratio and at rows: (8, n)
    bind: slice  # the velocity, acceleration and jerk ratios: (3 n,)


def _plan(ls: Limits) -> _Plan | None:
    """The :class:`_Plan` of ``ls``; None where the closed form does not apply to its limits
    (a torque limit, a velocity, acceleration or jerk limit missing or infinite)."""
    if ls.torque_Nm is not None or not ls.derived("finite v/a/j", _finite_vaj):
        return None
    centre, half = ls.centre_half_rad()
    lo, hi, _ = range_with_tolerance(ls)
    kin = (ls.velocity_rad_s, ls.acceleration_rad_s2, ls.jerk_rad_s3)
    P = np.concatenate([*kin, lo, hi, centre, half])
    P.flags.writeable = False
    names = tuple(ls.joint_names)
    labels = tuple((k, name) for k in ("velocity", "acceleration", "jerk") for name in names)
    n, lay = len(names), closed_graph.layout(len(names))
    o = lay["ratio"][0]
    assert lay["at"] == (o + 4 * n, o + 8 * n)  # the check rows are one block
    return _Plan(
        P,
        (2, n),
        names,
        labels,
        lay["t"][0],
        slice(lay["q"][0], lay["qddd"][1]),
        slice(o, o + 8 * n),
        slice(o + n, o + 4 * n),
    )


def _request_plan(key: bool):
    """For :func:`direct`: the resolved limits of a request with ``tau_max`` False (``key``)
    or None, and their :class:`_Plan` (None where the closed form does not apply)."""

    def make(base: Limits) -> tuple[Limits, _Plan | None]:
        ls = resolve_limits(base, tau_max=False if key else None)
        return ls, ls.derived(_PLAN, _plan)

    return make


_PLAN = "closed-form plan"
_REQUEST = {True: _request_plan(True), False: _request_plan(False)}


def direct(robot, waypoints, tau_off: bool) -> Trajectory | None:
    """:func:`~armlab.planning.optimal`'s front gate (issue 26): the closed-form plan of
    ``optimal(robot, waypoints, tau_max=False)`` (``tau_off``; else ``tau_max=None``) with
    every other keyword at its default, without building the transcription's problem; None
    where the ordinary path must run -- the closed form does not apply to the robot's limits,
    the waypoints are not two valid rows (the ordinary path names the error: the graph's
    ``valid`` flag is only ever 1 where that validation accepts them), or the exact check
    cannot show the plan within its limits (the ordinary path then checks the samples or
    transcribes). The result is :func:`closed_form_optimal`'s of the same request (tested)."""
    base = getattr(robot, "limits", None)
    if not isinstance(base, Limits):
        return None
    ls, plan = base.derived(("closed-form request", tau_off), _REQUEST[tau_off])
    if plan is None:
        return None
    try:
        W = np.array(waypoints, dtype=float)  # a copy of the caller's: meta["waypoints"]
    except (TypeError, ValueError):
        return None
    if W.shape != plan.shape:
        return None
    t_start = _time.perf_counter()
    out = closed_graph.evaluate(W, plan.P)
    head = out[:7].tolist()
    if not (head[2] and head[3] and head[4]):  # valid, exact_ok, ok
        return None
    traj = _trajectory(out, head, plan, W, t_start, ls)
    traj.report = _report(out, plan)
    return _finish(traj, head, plan, ls, "time", None, EXACT_CHECK, out)


def closed_form_optimal(prob: OptimalProblem) -> Trajectory:
    """The time-synchronised double S of ``prob`` (:func:`closed_form_applies` must hold) as
    the :func:`~armlab.planning.optimal` result: exact piecewise cubic, ``report`` (its exact
    limit check, :func:`exact_report`; the sample check of
    :meth:`~armlab.trajectory.Trajectory.check_limits` where the caller gives ``check_dt``),
    ``stats`` (``method = "closed_form"``, ``limit_check``, the keys of a transcribed plan
    that apply) and ``meta``. Evaluated by one graph (:mod:`~armlab.planning.closed_graph`):
    the engine, the knots, the samples at them and the exact check."""
    t_start = _time.perf_counter()
    ls = prob.limits
    plan = ls.derived(_PLAN, _plan)
    w = prob.waypoints
    out = closed_graph.evaluate(w, plan.P)
    head = out[:7].tolist()
    traj = _trajectory(out, head, plan, w.copy(), t_start, ls)
    if prob.check_dt is None and head[3]:  # exact_ok: the phase data show the check
        traj.report = _report(out, plan)
        _finish(traj, head, plan, ls, prob.objective, None, EXACT_CHECK, out)
    else:  # a grid asked for, or a speed against the move / an end off the goal: samples
        traj.report = traj.check_limits(prob.robot, dt=prob.check_dt, limits=ls, torque=False)
        head[6] = None  # no arrival residual
        _finish(traj, head, plan, ls, prob.objective, prob.check_dt, SAMPLE_CHECK)
    prob.stats = traj.stats
    return traj


def _trajectory(out, head, plan: _Plan, W, t_start: float, ls) -> Trajectory:
    """The :class:`Trajectory` of the graph's output ``out`` (views of it: a fresh array per
    call) and its ``meta``; ``stats["solve_time_s"]`` from ``t_start``. The graph's knots are
    sorted, merged to more than the times' rounding apart, from 0 to ``T``, and its samples
    finite where ``exact_ok`` (:meth:`Trajectory._from_checked`)."""
    m, o = int(head[0]), plan.t
    t = out[o : o + m]
    X = out[plan.samples].reshape(4, -1, plan.shape[1])[:, :m]
    traj = Trajectory._from_checked(t, X[0], X[1], X[2], X[3], plan.names, "optimal")
    traj.stats = {"solve_time_s": _time.perf_counter() - t_start}
    traj.meta = {
        "knot_times_s": t,
        "waypoints": W,
        "waypoint_times_s": out[7:9],  # [0, T]
        "limits": ls.to_dict(),
        "backed_off_torque_Nm": None,
        "qd_start": None,
        "qdd_start": None,
        "qd_goal": None,
    }
    return traj


def _report(out, plan: _Plan) -> LimitReport:
    """The exact check's :class:`~armlab.trajectory.sampling.LimitReport` in the graph's
    output (:func:`exact_report`'s ratios and times)."""
    r = out[plan.checks].reshape(8, plan.shape[1])  # the ratio rows, then the at rows
    ratios = {"position": r[0], "velocity": r[1], "acceleration": r[2], "jerk": r[3]}
    at_s = {"position": r[4], "velocity": r[5], "acceleration": r[6], "jerk": r[7]}
    return LimitReport(list(plan.names), ratios, at_s)


def _finish(traj, head, plan: _Plan, ls, objective, check_dt, check, out=None) -> Trajectory:
    """``traj.stats``: the keys of a transcribed plan that apply (module docstring); ``out``
    the graph's output where its exact check is the report (its verdict and binding flags),
    else None (the report's)."""
    if out is None:
        ok = traj.report.ok(CHECK_TOL)
        binding = timescale.binding(traj.report.ratios, traj.joint_names)
    else:  # the same test on the same ratios, in the graph (ok: every ratio <= 1 + CHECK_TOL)
        ok = bool(head[4])
        rows = out[plan.bind].tolist()  # the velocity, acceleration, jerk ratios
        binding = [(*lab, x) for lab, x in zip(plan.labels, rows, strict=True) if x >= BINDING]
    stats = _STATS.copy()  # the constant keys, in order
    stats["solve_time_s"] = traj.stats["solve_time_s"]
    stats["n_intervals"] = int(head[0]) - 1
    stats["success"] = stats["ok"] = ok
    stats["objective"] = objective
    stats["duration_s"] = head[1]
    stats["binding"] = binding
    stats["report_dt_s"] = check_dt
    stats["limit_check"] = check
    stats["arrival_residual"] = head[6]
    traj.stats = stats
    return traj


#: ``stats`` of a closed-form plan: the keys of a transcribed plan that apply, in their order
#: (None: set per plan, :func:`_finish`)
_STATS: dict[str, object] = {
    "method": "closed_form",
    "solver": "closed form (synchronised_scurves)",
    "hessian": None,
    "hessian_fallback": False,
    "iterations": 0,
    "solve_time_s": None,
    "build_time_s": 0.0,
    "n_intervals": None,
    "success": None,
    "return_status": "closed form",
    "backoff_rounds": 0,
    "objective": None,
    "mode": "jerk",
    "duration_s": None,
    "tolerance_stretch": 1.0,
    "tolerance_stretch_skipped": None,
    "binding": None,
    "report_dt_s": None,
    "ok": None,
    "drive_limits": False,
    "limit_check": None,
    "arrival_residual": None,
}
