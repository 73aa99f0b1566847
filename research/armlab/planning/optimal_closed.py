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
from typing import TYPE_CHECKING

import numpy as np

from armlab.planning.timescale import CHECK_TOL
from armlab.trajectory.core import Trajectory
from armlab.trajectory.profiles import synchronised_scurves
from armlab.trajectory.profiles.ops import NP
from armlab.trajectory.sampling import LimitReport, fixed_times

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
    residual, reverse, ratios, at_s = exact_check(
        NP, pk, batch.distance.reshape(-1), v, a, jerk, start, goal, centre, half, T
    )
    residual = float(residual)
    if residual > ARRIVAL_TOL or reverse:
        return None
    report = LimitReport(list(joint_names))
    report.ratios.update(ratios)
    report.at_s.update(at_s)
    return report, residual


def exact_check(ops, pk, D, v, a, j, start, goal, centre, half, T) -> tuple:
    """What :func:`exact_report` reads from the peaks ``pk`` (:meth:`SCurveBatch.peaks_flat`)
    of one synchronised double S, written once against a backend ``ops``
    (:mod:`armlab.trajectory.profiles.ops`: numpy, and CasADi SX in the closed form's graph,
    :mod:`armlab.planning.closed_graph`): ``(residual, reverse, ratios, at_s)``.

    * ``residual``: the largest arrival residual, NaN if any is: ``| end_position - |D| | /
      (1 + |D|)``, ``|end_velocity| / v``, ``|end_acceleration| / a`` (``a`` None: left out);
    * ``reverse``: whether a joint's speed against the move exceeds ``ARRIVAL_TOL * v``;
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
    r0, r1 = abs(start - centre) / half, abs(goal - centre) / half
    ratios = {"position": ops.fmax(r0, r1)}
    at_s = {"position": ops.where(r1 > r0, T, 0.0)}  # the start where both are equal
    for kind, lim in (("velocity", v), ("acceleration", a), ("jerk", j)):
        if lim is not None:
            ratios[kind] = pk[kind] / lim
            at_s[kind] = pk[f"{kind}_at_s"]
    return residual, reverse, ratios, at_s


def closed_form_optimal(prob: OptimalProblem) -> Trajectory:
    """The time-synchronised double S of ``prob`` (:func:`closed_form_applies` must hold) as
    the :func:`~armlab.planning.optimal` result: exact piecewise cubic, ``report`` (its exact
    limit check, :func:`exact_report`; the sample check of
    :meth:`~armlab.trajectory.Trajectory.check_limits` where the caller gives ``check_dt``),
    ``stats`` (``method = "closed_form"``, ``limit_check``, the keys of a transcribed plan
    that apply) and ``meta``."""
    t0 = _time.perf_counter()
    ls = prob.limits
    w = prob.waypoints
    batch = synchronised_scurves(
        w[1:] - w[:-1], ls.velocity_rad_s, ls.acceleration_rad_s2, ls.jerk_rad_s3
    )
    T = float(batch.duration[0])
    t = _knots(batch.boundaries()[0, :, 0], T)
    # the phase data at every switching instant: each piece between knots is one phase of
    # every joint (constant jerk, the one of the phase that starts at its left knot)
    q, qd, qdd, J = (x[:, 0] for x in batch.evaluate_jerk(t))
    q += w[0]  # (the evaluation's own arrays)
    q[-1], qd[-1], qdd[-1], J[-1] = w[-1], 0.0, 0.0, 0.0  # the goal at rest exactly
    # arrays made here: float64 (m, n_joints), finite (the phase data of finite moves under
    # finite limits > 0), t strictly increasing from 0 to T (_knots)
    traj = Trajectory._from_checked(t, q, qd, qdd, J, prob.robot.joint_names, "optimal")
    solve_time = _time.perf_counter() - t0
    exact = None  # a grid asked for (check_dt): the samples
    if prob.check_dt is None:
        exact = exact_report(batch, w[0], w[-1], ls, traj.joint_names)
    if exact is None:
        traj.report = traj.check_limits(prob.robot, dt=prob.check_dt, limits=ls, torque=False)
        check, residual = SAMPLE_CHECK, None
    else:
        (traj.report, residual), check = exact, EXACT_CHECK
    ok = traj.report.ok(CHECK_TOL)
    ratios = traj.report.ratios
    binding = [
        (k, name, x)
        for k, r in ratios.items()
        if k != "position"
        for name, x in zip(traj.joint_names, r.tolist(), strict=True)
        if x >= 1 - 2e-3
    ]
    traj.stats = {
        "method": "closed_form",
        "solver": "closed form (synchronised_scurves)",
        "hessian": None,
        "hessian_fallback": False,
        "iterations": 0,
        "solve_time_s": solve_time,
        "build_time_s": 0.0,
        "n_intervals": int(t.size - 1),
        "success": ok,
        "return_status": "closed form",
        "backoff_rounds": 0,
        "objective": prob.objective,
        "mode": prob.mode,
        "duration_s": T,
        "tolerance_stretch": 1.0,
        "tolerance_stretch_skipped": None,
        "binding": binding,
        "report_dt_s": prob.check_dt,
        "ok": ok,
        "drive_limits": False,
        "limit_check": check,
        "arrival_residual": residual,
    }
    traj.meta.update(
        {
            "knot_times_s": t,
            "waypoints": w.copy(),
            "waypoint_times_s": np.array([0.0, T]),
            "limits": ls.to_dict(),
            "backed_off_torque_Nm": None,
            "qd_start": None,
            "qdd_start": None,
            "qd_goal": None,
        }
    )
    prob.stats = traj.stats
    return traj
