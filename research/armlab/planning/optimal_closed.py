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
joint (jerk constant between them), so :meth:`Trajectory.at` evaluates it exactly, and the limit
check (:meth:`Trajectory.check_limits`, knots and each piece's interior extremes) is exact
without a fine grid (a grid of ``check_dt`` is added when the caller gives one).
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

if TYPE_CHECKING:
    from armlab.planning.optimal_problem import OptimalProblem

__all__ = ["closed_form_applies", "closed_form_optimal"]


def closed_form_applies(prob: OptimalProblem) -> bool:
    """True where the closed form is the optimum of ``prob`` (module docstring): the time
    objective, two waypoints at rest, finite v/a/j limits, no torque limit, no drive limits."""
    ls = prob.limits
    kin = (ls.velocity_rad_s, ls.acceleration_rad_s2, ls.jerk_rad_s3)
    return (
        prob.objective == "time"
        and prob.waypoints.shape[0] == 2
        and prob.mode == "jerk"
        and not prob.from_state
        and not prob.drive_limits
        and ls.torque_Nm is None
        and all(x is not None and bool(np.all(np.isfinite(x))) for x in kin)
    )


def _knots(batch) -> np.ndarray:
    """Every joint's switching instants and the ends, sorted; instants closer than the
    rounding of the times merge (as :func:`~armlab.trajectory.sampling.sample_times`)."""
    T = float(batch.duration[0])
    tc = batch.ta[0] - 2 * batch.tj[0]
    phases = np.stack([batch.tj[0], tc, batch.tj[0], batch.tv[0], batch.tj[0], tc, batch.tj[0]])
    corners = np.cumsum(phases, axis=0)[:-1].reshape(-1)
    tiny = 8 * np.finfo(float).eps * max(T, 1.0)
    inner = np.unique(corners[(corners > tiny) & (corners < T - tiny)])
    inner = inner[np.append(np.diff(inner) > tiny, True)] if inner.size else inner
    return np.concatenate([[0.0], inner, [T]])


def closed_form_optimal(prob: OptimalProblem) -> Trajectory:
    """The time-synchronised double S of ``prob`` (:func:`closed_form_applies` must hold) as
    the :func:`~armlab.planning.optimal` result: exact piecewise cubic, ``report`` (its exact
    limit check), ``stats`` (``method = "closed_form"``, the keys of a transcribed plan that
    apply) and ``meta``."""
    t0 = _time.perf_counter()
    ls = prob.limits
    w = prob.waypoints
    batch = synchronised_scurves(
        np.diff(w, axis=0), ls.velocity_rad_s, ls.acceleration_rad_s2, ls.jerk_rad_s3
    )
    t = _knots(batch)
    q, qd, qdd = (x[:, 0] for x in batch.evaluate(t))
    # the jerk of each piece, from the acceleration at its two ends (linear in between: the
    # knots hold every joint's switching instants); exact zero where it does not step
    h = np.diff(t)[:, None]
    jerk = np.diff(qdd, axis=0) / h
    jmax = ls.jerk_rad_s3
    assert jmax is not None  # closed_form_applies
    jerk = np.clip(np.where(np.abs(jerk) < 1e-9 * jmax, 0.0, jerk), -jmax, jmax)
    q = w[0] + q
    q[-1], qd[-1], qdd[-1] = w[-1], 0.0, 0.0  # the goal at rest exactly
    J = np.vstack([jerk, np.zeros((1, prob.n))])
    traj = Trajectory(t, q, qd, qdd, J, joint_names=prob.robot.joint_names, method="optimal")
    solve_time = _time.perf_counter() - t0
    traj.report = traj.check_limits(prob.robot, dt=prob.check_dt, limits=ls, torque=False)
    T = float(batch.duration[0])
    binding = [
        (k, traj.joint_names[i], float(r[i]))
        for k, r in traj.report.ratios.items()
        for i in range(len(r))
        if r[i] >= 1 - 2e-3 and k != "position"
    ]
    ok = traj.report.ok(CHECK_TOL)
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
