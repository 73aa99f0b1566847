"""The two back-offs of the planners: a uniform time stretch, and re-solving with tightened limits.

The limits of a request are a :class:`armlab.robot.Limits` from
:func:`armlab.robot.resolve_limits` (the robot's, overridden or switched off per call).

Stretching a trajectory in time by ``k >= 1`` (``q_k(t) = q(t / k)``) divides the velocities
by ``k``, the accelerations by ``k^2`` and the jerks by ``k^3``. Inverse dynamics
``tau = M(q) qdd + C(q, qd) qd + g(q)`` becomes ``g + (tau - g) / k^2`` at the same path point,
so the smallest ``k`` that meets every limit follows in closed form from the samples
(:func:`stretch_needed`). The classical planners use it to slow down instead of violating a
limit, and say which limit set the pace (``Trajectory.meta["slowdown"]``).

The optimising planners (:mod:`armlab.planning.optimiser`, :mod:`armlab.planning.topp`) impose
their limits on a grid and check the solution on a finer one; where a limit is exceeded by
more than ``CHECK_TOL`` between the grid points it is multiplied by
``(1 - BACKOFF_MARGIN) / ratio`` and the problem re-solved (:func:`backoff_solve`, the one
back-off loop: at most ``max_rounds`` re-solves, a failed re-solve keeps the last good
solution), and a plan still over a limit after that is refused (:func:`refuse_violation`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Generic, NoReturn, TypeVar

import numpy as np

from armlab.errors import InfeasibleError, LimitViolation
from armlab.robot import drivetrain, rigid_body
from armlab.trajectory.sampling import sample_times, sample_weights

if TYPE_CHECKING:
    from armlab.robot.drivetrain import DriveTrain
    from armlab.robot.model import Robot
    from armlab.trajectory.core import Trajectory

__all__ = [
    "stretch_needed",
    "torque_stretch",
    "held_over_limit",
    "HOLD_RTOL",
    "finish",
    "check_in_range",
    "backoff_solve",
    "Backoff",
    "over_limits",
    "tighten_limits",
    "refuse_violation",
    "drive_check",
    "tighten_drive",
    "absorb_drive_tolerance",
    "refuse_drive_violation",
    "DriveState",
    "CHECK_TOL",
    "BACKOFF_MARGIN",
]

#: a fine-grid peak ratio above ``1 + CHECK_TOL`` breaks a limit (the optimisers' check)
CHECK_TOL = 1e-6
#: a limit whose peak ratio is at least this binds the plan (``stats["binding"]``)
BINDING = 1 - 2e-3


def binding(ratios, joint_names) -> list[tuple[str, str, float]]:
    """``stats["binding"]``: ``(kind, joint, ratio)`` of every ratio of ``ratios`` (kind ->
    per-joint array, a :class:`~armlab.trajectory.sampling.LimitReport`'s and drive ratios) at
    least :data:`BINDING`, position left out (a range is no limit a plan runs against)."""
    return [
        (k, name, x)
        for k, r in ratios.items()
        if k != "position"
        for name, x in zip(joint_names, r.tolist(), strict=True)
        if x >= BINDING
    ]


#: a broken limit is backed off by its peak ratio and this fraction more
BACKOFF_MARGIN = 1e-3
#: a held torque (gravity alone, or a fixed boundary state) is over its limit above
#: ``1 + HOLD_RTOL`` times it: round-off of RNEA, ~1e-15 relative, with room (a pose whose
#: gravity torque equals the limit to the last bits is not refused; issue 15)
HOLD_RTOL = 1e-12


def held_over_limit(ratio) -> tuple[int, int] | None:
    """Where a torque no path speed changes is over its limit: the first sample of ``ratio``
    (samples, joints) -- ``|g| / tau_max`` of gravity alone, or a motor's holding torque over
    its envelope -- with a ratio above ``1 + HOLD_RTOL``, and its worst joint, as
    ``(sample, joint)``; None if every ratio is within.

    The one rule of "gravity alone is over a limit": along a time-scaled path
    ``tau(k) = g + (tau - g) / k^2`` tends to ``g`` as ``k -> inf`` (:func:`torque_stretch`), so
    a pose with ``|g| > tau_max`` cannot be passed or held at any speed. The planners name the
    joint and pose from it (waypoints of :func:`~armlab.planning.optimal`, path points of
    :func:`~armlab.planning.time_optimal_path`, samples of :func:`stretch_needed`).
    """
    r = np.atleast_2d(np.asarray(ratio, float))
    if r.size == 0:
        return None
    over = np.flatnonzero(np.max(r, axis=1) > 1.0 + HOLD_RTOL)
    if over.size == 0:
        return None
    k = int(over[0])
    return k, int(np.argmax(r[k]))


def torque_stretch(tau, g, tau_max) -> np.ndarray:
    """Smallest time-stretch factors ``k >= 1`` (samples, joints) that bring the torques
    ``tau`` (samples, joints) within ``|tau| <= tau_max``, gravity torques ``g`` at the same
    poses.

    Stretching by ``k`` gives ``tau(k) = g + (tau - g) x`` with ``x = 1 / k^2`` (module
    docstring); ``|g + d x| <= tau_max``, ``d = tau - g``, holds for ``x`` in an interval that
    contains 0 when ``|g| <= tau_max``; its upper end ``x_max = (tau_max - g) / d`` (``d > 0``)
    or ``(-tau_max - g) / d`` (``d < 0``) gives ``k = 1 / sqrt(x_max)`` where ``x_max < 1``.
    Exact: no margin. Where gravity alone is over the limit (:func:`held_over_limit`) no
    ``k`` helps: ``k = 1`` is returned there, the caller decides.
    """
    tau, g = np.asarray(tau, float), np.asarray(g, float)
    eff = np.asarray(tau_max, float)
    d = tau - g
    with np.errstate(divide="ignore", invalid="ignore"):
        xmax = np.where(d > 0, (eff - g) / d, np.where(d < 0, (-eff - g) / d, np.inf))
    xmax = np.clip(xmax, 0.0, np.inf)
    kk = np.where(xmax >= 1, 1.0, 1.0 / np.sqrt(np.maximum(xmax, 1e-300)))
    return np.where(np.abs(g) > eff * (1 + HOLD_RTOL), 1.0, kk)


def check_in_range(robot: Robot, q, what: str) -> None:
    """Raise :class:`LimitViolation` naming the joint if ``q`` (n_joints,) or (n, n_joints)
    leaves the joint range."""
    q2 = np.atleast_2d(np.asarray(q, float))
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    bad = (q2 < lo - 1e-9) | (q2 > hi + 1e-9)
    if np.any(bad):
        k, j = np.argwhere(bad)[0]
        raise LimitViolation(
            f"{what}: {robot.joint_names[j]} = {q2[k, j]:.6g} rad is outside its range "
            f"[{lo[j]:.6g}, {hi[j]:.6g}] rad" + (f" (sample {k})" if q2.shape[0] > 1 else "")
        )


def _ratio(signal, limit) -> np.ndarray:
    """Peak |signal| / limit per joint (0 where the limit is infinite)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.abs(signal).max(axis=0) / np.asarray(limit, float)
    return np.where(np.isfinite(r), r, 0.0)


def stretch_needed(traj, robot: Robot, limits, *, torque: bool = True) -> tuple[float, str, str]:
    """Smallest time-stretch factor ``k >= 1`` that brings ``traj`` within ``limits``
    (a :class:`~armlab.robot.Limits`; kinds that are None are not limited). ``traj``: samples
    with ``t, q, qd, qdd`` (and ``qddd``), typically its
    :meth:`~armlab.trajectory.Trajectory.limit_samples` with ``robot``, whose torques are used.

    ``k = max(r_v, sqrt(r_a), cbrt(r_j), k_tau)`` with ``r`` the peak ratios of the samples
    and ``k_tau`` the exact factor for the torques (:func:`torque_stretch`).

    Returns
    -------
    (k, kind, joint)
        The factor and the limit that sets it (``("", "")`` if ``k == 1``).

    Raises
    ------
    LimitViolation
        Gravity alone exceeds a joint's torque limit somewhere (no speed can fix it).
    """
    cands: list[tuple[float, str, int]] = [(1.0, "", 0)]
    if limits.velocity_rad_s is not None:
        r = _ratio(traj.qd, limits.velocity_rad_s)
        cands.append((float(r.max()), "velocity", int(r.argmax())))
    if limits.acceleration_rad_s2 is not None:
        r = _ratio(traj.qdd, limits.acceleration_rad_s2)
        cands.append((math.sqrt(r.max()), "acceleration", int(r.argmax())))
    if limits.jerk_rad_s3 is not None and traj.qddd is not None:
        r = _ratio(traj.qddd, limits.jerk_rad_s3)
        cands.append((float(np.cbrt(r.max())), "jerk", int(r.argmax())))
    eff = limits.torque_Nm
    if torque and eff is not None and np.any(np.isfinite(eff)):
        g = rigid_body.gravity_torques(robot, traj.q)
        tau = getattr(traj, "tau", None)  # limit samples carry their torques
        if tau is None:
            tau = rigid_body.inverse_dynamics(robot, traj.q, traj.qd, traj.qdd)
        with np.errstate(divide="ignore", invalid="ignore"):
            over = held_over_limit(np.abs(g) / eff)
        if over is not None:
            m, i = over
            raise LimitViolation(
                f"{robot.name}: gravity alone needs {abs(g[m, i]):.4g} N m at "
                f"{robot.joint_names[i]} (t = {traj.t[m]:.4g} s), above its torque limit "
                f"{eff[i]:.4g} N m: no slower motion can meet it"
            )
        kk = torque_stretch(tau, g, eff)
        jj = int(np.argmax(kk.max(axis=0)))
        cands.append((float(kk.max()), "torque", jj))
    k, kind, j = max(cands, key=lambda c: c[0])
    if k <= 1.0:
        return 1.0, "", ""
    return k, kind, robot.joint_names[j]


def finish(traj, robot: Robot, limits, *, torque: bool, what: str, report=None) -> Trajectory:
    """Set ``traj.report`` and raise :class:`LimitViolation` if any limit is still broken;
    ``report``: the caller's exact report of ``traj`` (a closed form's,
    :func:`~armlab.planning.optimal_closed.exact_report`) instead of the sample check."""
    traj.report = (
        report if report is not None else traj.check_limits(robot, torque=torque, limits=limits)
    )
    bad = traj.report.violations(tol=1e-9)
    if bad:
        kind, joint, ratio, at = max(bad, key=lambda b: b[2])
        raise LimitViolation(
            f"{what}: {joint} {kind} reaches {ratio:.4g} x its limit at t = {at:.4g} s"
        )
    return traj


# ---------------------------------------------------------------------------- back-off loop
S = TypeVar("S")  # what is tightened: a Limits, or a planner's own scale factors
R = TypeVar("R")  # what one solve returns


@dataclass
class Backoff(Generic[R, S]):
    """What :func:`backoff_solve` ends with.

    Attributes
    ----------
    result : R
        The last successful solve.
    limits : S
        The (tightened) limits it was solved with.
    rounds : int
        Back-off re-solves done.
    iterations : int
        Solver iterations over all solves, failed ones included.
    solve_time_s : float
        Solve time over all solves in [s].
    info : dict
        The solver info of the last solve attempted (a failed re-solve's, if one failed).
    """

    result: R
    limits: S
    rounds: int
    iterations: int
    solve_time_s: float
    info: dict


def over_limits(ratios: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The kinds of ``ratios`` (kind -> peak ratios to the limit, any shape) that exceed
    ``1 + CHECK_TOL`` somewhere; positions are left out (the planners bound them exactly)."""
    return {k: r for k, r in ratios.items() if k != "position" and np.any(r > 1 + CHECK_TOL)}


def tighten_limits(
    limits, over: dict[str, np.ndarray], rounds: int = 0, margin: float = BACKOFF_MARGIN
):
    """``limits`` (a :class:`~armlab.robot.Limits`) with each joint's limit of a kind in
    ``over`` (kind -> peak ratio per joint) times ``(1 - margin) / ratio`` where the ratio
    exceeds ``1 + CHECK_TOL``; the sources say "back-off". ``rounds`` is not used (the
    signature of :func:`backoff_solve`'s ``tighten``)."""
    for kind, r in over.items():
        factor = (1 - margin) / np.maximum(r, 1.0)
        factor[r <= 1 + CHECK_TOL] = 1.0
        limits = limits.tightened(kind, factor, "back-off")
    return limits


def backoff_solve(
    solve: Callable[[S, R | None], tuple[R, dict]],
    limits: S,
    check: Callable[[R], dict[str, np.ndarray]],
    *,
    max_rounds: int,
    fail: Callable[[R, dict], NoReturn],
    margin: float = BACKOFF_MARGIN,
    tighten: Callable[[S, dict[str, np.ndarray], int, float], S] = tighten_limits,
) -> Backoff[R, S]:
    """Solve, check on the fine grid, tighten what is exceeded and re-solve: the one back-off
    loop of the optimising planners (module docstring).

    Parameters
    ----------
    solve : callable ``(limits, previous) -> (result, info)``
        One solve with these limits; ``previous`` is the last successful result (None at
        first), for a warm start. ``info`` holds ``success`` (bool), ``iterations`` and
        ``solve_time_s`` [s].
    limits : Limits or any state
        What the first solve uses and ``tighten`` changes.
    check : callable ``result -> {kind: ratios}``
        Peak ratios to the request's own limits on the fine grid (arrays, any shape).
    max_rounds : int
        Re-solves allowed.
    fail : callable ``(result, info)``
        Raises the planner's error when the first solve fails.
    margin : float
        Extra fraction a broken limit is backed off by.
    tighten : callable ``(limits, over, rounds, margin) -> limits``
        The new limits from the kinds over their limit (:func:`over_limits`) after ``rounds``
        re-solves; default :func:`tighten_limits`.

    Returns
    -------
    Backoff
        The last successful solve, its limits, the rounds, the summed iterations and time.
    """
    rounds, iterations, solve_time = 0, 0, 0.0
    kept: tuple[R, S] | None = None  # the last successful solve and its limits
    while True:
        result, info = solve(limits, None if kept is None else kept[0])
        iterations += int(info.get("iterations", 0))
        solve_time += float(info.get("solve_time_s", 0.0))
        if not info["success"]:
            if kept is None:
                fail(result, info)
            break  # a backed-off re-solve failed: keep the last good one
        kept = (result, limits)
        over = over_limits(check(result))
        if not over or rounds >= max_rounds:
            break
        limits = tighten(limits, over, rounds, margin)
        rounds += 1
    assert kept is not None  # a failed first solve went to fail(), which raises
    return Backoff(kept[0], kept[1], rounds, iterations, solve_time, info)


def refuse_violation(traj: Trajectory, planner: str, rounds: int) -> None:
    """Raise :class:`InfeasibleError` if the fine-grid report of a solved plan still breaks a
    limit after the back-off re-solves: a plan is never handed out with a silent violation."""
    if traj.report is None or traj.report.ok(CHECK_TOL):
        return
    kind, joint, ratio, t_s = max(traj.report.violations(CHECK_TOL), key=lambda v: v[2])
    raise InfeasibleError(
        f"{planner}: after {rounds} back-off re-solve(s) the plan still exceeds the {kind} limit "
        f"of {joint} (peak ratio {ratio:.6f} at t = {t_s:.4f} s on the fine check grid); loosen "
        "that limit or use more intervals"
    )


# ---------------------------------------------------------------------------- drive limits
#: what the planners' back-off tightens with ``drive_limits``: the request's limits, and per
#: joint the scale of the motor-envelope bounds and of the RMS bound
DriveState = tuple  # (Limits, envelope scale (n,), rms scale (n,))


def drive_check(traj: Trajectory, robot: Robot, train: DriveTrain, dt: float, samples=None) -> dict:
    """Peak ratios of a trajectory to its motors' envelope, per joint: the independent
    per-sample check of ``drive_limits`` (:func:`armlab.robot.drivetrain.drive_ratios` kinds).

    ``motor_envelope`` and ``motor_speed`` on :meth:`Trajectory.limit_samples` (every knot,
    the critical times, the uniform grid ``dt`` [s] and the refined torque peaks) with the exact
    numeric drive-train model; ``motor_rms`` on the uniform grid ``dt`` with trapezoidal
    weights (:func:`armlab.trajectory.sampling.sample_weights`).

    ``samples``: ``traj``'s limit samples at ``dt`` with torques if the caller has them (not
    computed again). The uniform grid's rows are read from them (:func:`_grid_rows`: the same
    floats as ``traj.sample(dt)`` and its RNEA, so one motor-torque pass serves the peaks and
    the RMS); where they are not all there, the grid is sampled and its torques computed.
    """
    if samples is None or samples.tau is None:
        samples = traj.limit_samples(dt, robot=robot)
    assert samples.tau is not None  # a robot was given
    t_m, _ = drivetrain.motor_torque(samples.tau, samples.qd, samples.qdd, train)
    w_m = drivetrain.motor_speed(samples.qd, train)
    ratios = {
        "motor_envelope": drivetrain.envelope_ratio(t_m, w_m, train).max(axis=0),
        "motor_speed": np.abs(w_m).max(axis=0) / train.rated_speed_rad_s,
    }
    times, rows = _grid_rows(traj, dt, samples.t)
    if rows is not None:  # the grid's rows of the samples: its RMS from the same motor torques
        rms = drivetrain.rms_torque(t_m[rows], sample_weights(times))
        ratios["motor_rms"] = rms / train.continuous_motor_torque_Nm
        return ratios
    fine = traj.sample(dt)
    tau = rigid_body.inverse_dynamics(robot, fine.q, fine.qd, fine.qdd)
    grid = drivetrain.drive_ratios(tau, fine.qd, fine.qdd, sample_weights(fine.t), train)
    grid["motor_envelope"] = np.maximum(grid["motor_envelope"], ratios["motor_envelope"])
    grid["motor_speed"] = np.maximum(grid["motor_speed"], ratios["motor_speed"])
    return grid


def _grid_rows(traj: Trajectory, dt: float, t_samples: np.ndarray):
    """``(times, rows)``: the times of ``traj.sample(dt)`` and the rows of the limit samples
    (times ``t_samples``) at them (a knot's own row: its last), or ``rows = None`` if one of
    them is not among the samples."""
    times = traj.t[0] + sample_times(traj.duration, dt)
    times[-1] = traj.t[-1]  # as Trajectory.sample
    rows = np.searchsorted(t_samples, times, "right") - 1
    if rows.min(initial=0) < 0 or not np.array_equal(t_samples[rows], times):
        return times, None
    return times, rows


def tighten_drive(state: DriveState, over: dict, rounds: int, margin: float) -> DriveState:
    """The back-off of ``drive_limits`` (``tighten`` of :func:`backoff_solve`): the request's
    limit kinds as :func:`tighten_limits` (a motor-speed excess tightens the velocity limit);
    the envelope and RMS scales of each joint over its limit by ``(1 - margin) / ratio`` (a
    ratio capped at 2: beyond the no-load speed the ratio is infinite)."""
    limits, env, rms = state
    plain = {k: r for k, r in over.items() if k not in drivetrain.DRIVE_KINDS}
    if "motor_speed" in over and limits.velocity_rad_s is not None:
        v = over["motor_speed"]
        plain["velocity"] = np.maximum(plain["velocity"], v) if "velocity" in plain else v
    limits = tighten_limits(limits, plain, rounds, margin)

    def factor(r):
        r = np.minimum(np.asarray(r, float), 2.0)
        return np.where(r > 1 + CHECK_TOL, (1 - margin) / np.maximum(r, 1.0), 1.0)

    if "motor_envelope" in over:
        env = env * factor(over["motor_envelope"])
    if "motor_rms" in over:
        rms = rms * factor(over["motor_rms"])
    return limits, env, rms


def absorb_drive_tolerance(
    traj: Trajectory, robot: Robot, train: DriveTrain, dt: float, ratios: dict | None = None
):
    """``(trajectory, k, ratios)``: an excess of the motor envelope within ``CHECK_TOL`` removed
    by the smallest of a few uniform stretches (``1 + 1e-7 .. 1e-5``) that brings every drive
    ratio to 1 (slowing down does not lower every torque -- gravity stays, and it can raise
    ``|tau|`` where the dynamic part opposes it -- so each stretch is checked again).
    ``ratios``: :func:`drive_check` of ``traj`` at ``dt`` if the caller has it (not computed
    again)."""
    if ratios is None:
        ratios = drive_check(traj, robot, train, dt)
    worst = max(float(np.max(r)) for r in ratios.values())
    if worst <= 1.0 or worst > 1.0 + CHECK_TOL:
        return traj, 1.0, ratios
    for k in (1 + 1e-7, 1 + 1e-6, 1 + 1e-5):
        cand = traj.stretched(k)
        r = drive_check(cand, robot, train, dt * k)
        if max(float(np.max(x)) for x in r.values()) <= 1.0:
            return cand, k, r
    return traj, 1.0, ratios


def refuse_drive_violation(ratios: dict, traj: Trajectory, planner: str, rounds: int) -> None:
    """:func:`~armlab.planning.timescale.refuse_violation` for the motor-envelope ratios."""
    bad = [(k, i, float(r[i])) for k, r in ratios.items() for i in range(len(r))]
    bad = [b for b in bad if b[2] > 1 + CHECK_TOL]
    if not bad:
        return
    kind, i, ratio = max(bad, key=lambda b: b[2])
    raise InfeasibleError(
        f"{planner}: after {rounds} back-off re-solve(s) the plan still exceeds the {kind} "
        f"limit of {traj.joint_names[i]} (peak ratio {ratio:.6f} on the fine check grid); use "
        "more intervals or a lower payload"
    )
