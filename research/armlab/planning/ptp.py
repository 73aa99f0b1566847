"""Time-synchronised point-to-point motion in joint space (Jiang 1987, eq. 1-5).

Jiang 1987 (a welding robot): joint ``i`` alone would need ``t_i = |Qd_i - Qc_i| / w_i``
(eq. 3); the common time is ``T = max t_i`` and every joint moves at
``w_i = (Qd_i - Qc_i) / T`` (eq. 4), so that all arrive together; the set-point of the next
step is ``Qn = Qc + (Qd - Qc) dt / T`` (eq. 5), ``dt = 100 ms``.

Profiles here:

* ``"velocity"`` — the paper's constant speeds. A controller starts such a motion within one
  interpolation period, so each joint ramps from rest to ``w_i`` in ``dt`` (acceleration
  ``w_i / dt``) and back: a trapezoid with ramps of one period, duration ``T + dt``. If that
  acceleration breaks a joint's limit, ``T`` is lengthened to ``max |Q_i| / (a_i dt)``.
* ``"trapezoid"`` — per joint the shortest trapezoid within its speed and acceleration
  limits; the slowest joint sets ``T`` and the others are stretched to end at ``T``
  (``sync="time"``: same accelerations, lower cruise speeds), or all joints follow one
  normalised profile (``sync="phase"``: straight line in joint space, as eq. 5).
* ``"scurve"`` — the same with a jerk-limited double S per joint.

Replanning from where the arm is (``qd_start``, ``qdd_start``, ``qd_goal``, as Ruckig's
current velocity / acceleration and target velocity), with ``sync="time"``:

* ``"trapezoid"``: each joint's shortest move from its speed to its goal speed is
  bang-coast-bang (:func:`~armlab.trajectory.profiles.trapezoid_min_time_from_state`); a
  joint moving towards its goal may be unable to take some longer durations without
  reversing (:func:`~armlab.trajectory.profiles.trapezoid_blocked_from_state`), so the common
  duration is the smallest one at or above every joint's minimum that lies in no joint's gap,
  and each joint then takes exactly that long
  (:func:`~armlab.trajectory.profiles.trapezoid_from_state`). The trapezoid's acceleration
  steps at ``t = 0`` like at its other corners, so ``qdd_start`` is only checked against the
  limit.
* ``"scurve"``: the same with jerk-limited moves from a speed and an acceleration
  (Berscheid & Kröger 2021, steps 1 and 2, the method of Ruckig): each joint's time-optimal
  move of at most seven phases of jerk ``+-j`` or 0, its blocked durations, the common
  duration, and per joint a move of exactly that duration
  (:class:`~armlab.trajectory.profiles.JerkMove`,
  :func:`~armlab.trajectory.profiles.synchronised_from_state`). The acceleration is
  continuous: the plan starts with ``qdd_start`` and ends with zero acceleration.

Rest to rest with ``sync="time"``, every joint's samples come from the batch's phase data in
one evaluation (:meth:`~armlab.trajectory.profiles.SCurveBatch.evaluate_jerk`), and without a
torque limit the limit report is the exact check of the phase data
(:func:`~armlab.planning.optimal_closed.exact_report`, ``stats["limit_check"]``); with one,
the samples and their torques are checked.

A start or goal speed above a joint's velocity limit, a start acceleration above its
acceleration limit, or (``"scurve"``) a start acceleration the jerk limit cannot bring to zero
before the speed passes its limit (``qd + qdd |qdd| / 2 j``) is refused (:class:`InputError`
naming the keyword and the joint): brake first. ``sync="phase"`` and ``"velocity"`` do not
replan from a moving state (:class:`InputError`). Torque limits are met by lowering the
acceleration (and jerk) limits and planning again from the same state (not below what the
start state needs), and a speed that cannot be braked within the joint's range ends in
:class:`LimitViolation`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from armlab._keywords import renamed_keywords
from armlab.errors import InputError, LimitViolation
from armlab.planning.optimal_closed import EXACT_CHECK, SAMPLE_CHECK, exact_report
from armlab.planning.timescale import finish, held_over_limit, stretch_needed
from armlab.robot import rigid_body
from armlab.robot.limits import resolve_limits
from armlab.trajectory.core import Trajectory
from armlab.trajectory.profiles import (
    MotionProfile,
    SCurveBatch,
    double_s_binding,
    double_s_profile,
    rest_profile,
    synchronised_from_state,
    synchronised_scurves,
    trapezoid_blocked_from_state,
    trapezoid_from_state,
    trapezoid_min_time_from_state,
    trapezoid_profile,
)
from armlab.trajectory.sampling import sample_times
from armlab.trajectory.waypoints import (
    COINCIDE_RAD,
    check_stoppable,
    validate_joint_state,
    validate_waypoints,
)

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["ptp_sync", "PTP_PROFILES"]

PTP_PROFILES = ("trapezoid", "scurve", "velocity")
_DEFAULT_DT = {"trapezoid": 0.01, "scurve": 0.01, "velocity": 0.1}
#: the limit kinds each profile needs
_NEEDS = {
    "trapezoid": ("velocity", "acceleration"),
    "scurve": ("velocity", "acceleration", "jerk"),
    "velocity": ("velocity",),
}


def _velocity_profiles(D, v, a, dt):
    """Jiang 1987, eq. 3-4 with one-period ramps; returns (profiles, T, binding)."""
    t_i = D / v  # eq. 3
    T = float(t_i.max())
    binding = ("velocity", int(t_i.argmax()))
    if a is not None:
        t_acc = D / (a * dt)  # ramp w_i / dt <= a_i  <=>  T >= D_i / (a_i dt)
        if t_acc.max() > T:
            T = float(t_acc.max())
            binding = ("acceleration", int(t_acc.argmax()))
    T = max(T, dt)
    profs = []
    for d in D:
        if d <= 0:
            profs.append(rest_profile(T + dt))
            continue
        w = d / T  # eq. 4
        profs.append(
            MotionProfile(
                np.array([dt, T - dt, dt]),
                np.array([w / dt, 0.0, -w / dt]),
                np.zeros(3),
                kind="velocity",
                params={"v": w, "a_acc": w / dt, "a_dec": w / dt},
            )
        )
    return profs, T + dt, binding


def _from_state_profiles(delta, v0, a0, v1, v, a, j):
    """Time-synchronised moves from speeds ``v0`` (accelerations ``a0``) to ``v1``:
    bang-coast-bang (``j`` None) or jerk-limited: (profiles, T, binding joint, its limit
    kind, whether a joint's gap moved T)."""
    if j is not None:
        return _scurves_from_state(delta, v0, a0, v1, v, a, j)
    n = delta.size
    moving = (np.abs(delta) > 0) | (v0 != 0) | (v1 != 0)
    t_min = np.array(
        [
            trapezoid_min_time_from_state(delta[i], v0[i], v1[i], v[i], a[i]) if moving[i] else 0.0
            for i in range(n)
        ]
    )
    gaps = [
        trapezoid_blocked_from_state(delta[i], v0[i], v1[i], v[i], a[i]) if moving[i] else None
        for i in range(n)
    ]
    T = float(t_min.max())
    gap_moved = False
    for _ in range(n + 1):  # each gap can push T at most once
        inside = [g for g in gaps if g is not None and g[0] < T < g[1]]
        if not inside:
            break
        T = max(g[1] for g in inside)
        gap_moved = True
    profs = [
        trapezoid_from_state(delta[i], v0[i], v1[i], v[i], a[i], T)
        if moving[i]
        else rest_profile(T)
        for i in range(n)
    ]
    bj = int(np.argmax(t_min))
    cruise = abs(profs[bj].params.get("v", 0.0)) >= v[bj] * (1 - 1e-12)
    return profs, T, bj, ("velocity" if cruise else "acceleration"), gap_moved


@renamed_keywords(torque="tau_max= (False: no torque limit)")
def ptp_sync(
    robot: Robot,
    q_start,
    q_goal,
    profile: str = "trapezoid",
    *,
    v_max=None,
    a_max=None,
    j_max=None,
    dt: float | None = None,
    sync: str = "time",
    tau_max=None,
    qd_start=None,
    qdd_start=None,
    qd_goal=None,
) -> Trajectory:
    """Joint-space point-to-point motion in which every joint arrives at the same instant.

    Parameters
    ----------
    robot : Robot
    q_start, q_goal : array (n_joints,)
        Start and goal in [rad], inside the joint ranges.
    profile : {"trapezoid", "scurve", "velocity"}
        See the module docstring (Jiang 1987, eq. 1-5 for ``"velocity"``).
    v_max, a_max, j_max : None, False, float or array (n_joints,)
        Limits in [rad/s], [rad/s^2], [rad/s^3] (:func:`armlab.robot.resolve_limits`): None
        takes the robot's, False switches the kind off, a value replaces it. ``"trapezoid"``
        needs velocity and acceleration limits, ``"scurve"`` also jerk, ``"velocity"`` velocity
        only (its acceleration limit, if known, lengthens the motion); a needed one that is
        missing or off is an :class:`InputError` naming the study key and the keyword.
    dt : float, optional
        Sample period of the result in [s]; for ``"velocity"`` also the interpolation period
        of the paper (default 0.1 s there, 0.01 s otherwise).
    sync : {"time", "phase"}
        ``"time"``: each joint keeps its own acceleration and is slowed to end at ``T``;
        ``"phase"``: one normalised profile for all joints (a straight line in joint space).
        ``"velocity"`` is always phase-synchronous.
    tau_max : None, False, float or array (n_joints,)
        Torque limit in [N m] (:func:`armlab.robot.resolve_limits`): None the robot's, False
        no torque check, a value replaces it; the inverse-dynamics torques are kept within it
        (slowing down if needed).
    qd_start, qdd_start, qd_goal : array (n_joints,), optional
        Replanning from a moving state: the joint speeds [rad/s] and accelerations [rad/s^2]
        now, and the speeds [rad/s] wanted at the goal (default: rest; the goal
        acceleration is zero). ``"trapezoid"`` or ``"scurve"`` with ``sync="time"`` only
        (module docstring; Berscheid & Kröger 2021 for the S-curve); each within its limit.
        ``qdd_start`` shapes the S-curve's start; the trapezoid only checks it.

    Returns
    -------
    Trajectory
        ``method = "ptp_<profile>"``; ``meta``: profile, sync, T, the joint and limit that set
        the duration (``binding``), per-joint profile parameters, ``slowdown`` if torque
        forced a longer motion. ``qddd`` is given for ``"scurve"`` only (elsewhere the
        acceleration steps). A zero-length move gives one sample at rest.

    Raises
    ------
    InputError
        Bad shape, unknown profile, missing limit; start or goal outside a joint's range
        (:func:`~armlab.trajectory.waypoints.validate_waypoints`); a start or goal state
        beyond the limits (module docstring).
    LimitViolation
        Gravity alone above a torque limit; from a moving state, the start state's own
        torque above it, or a speed that cannot be braked within the joint range.
    """
    req = _request(
        robot, q_start, q_goal, profile, sync, dt, (v_max, a_max, j_max, tau_max),
        (qd_start, qdd_start, qd_goal),
    )  # fmt: skip
    q0, q1, lim, torque = req.q0, req.q1, req.lim, req.torque
    v, a, j = lim.velocity_rad_s, lim.acceleration_rad_s2, lim.jerk_rad_s3
    delta = q1 - q0
    D = np.abs(delta)
    D[D < COINCIDE_RAD] = 0.0  # a joint that does not move
    method = f"ptp_{profile}"
    if req.from_state:
        assert v is not None and a is not None
        return _ptp_from_state(
            robot, q0, q1, req.v0, req.a0, req.v1, v, a, j if profile == "scurve" else None,
            lim, req.dt, torque,
        )  # fmt: skip
    if not (D > 0).any():
        return _zero_length(robot, q0, q1, profile, sync, lim, torque)
    sy = _synchronise(robot, D, delta, profile, sync, lim, req.dt)
    traj, T, profs, slowdown = _sampled(robot, req, delta, profile, sy)
    normalised = profile != "velocity" and sy.sync == "phase"
    traj.meta.update(
        profile=profile,
        sync=sy.sync,
        duration_s=float(T),
        dt_s=req.dt,
        binding={"joint": robot.joint_names[sy.joint], "limit": sy.kind},
        q_start=q0.tolist(),
        q_goal=q1.tolist(),
        joint_profiles=None if normalised else _profile_dicts(profs, sy.batch),
        normalised_profile=profs[0].to_dict() if normalised else None,
        slowdown=slowdown,
    )
    traj.stats.update(method="closed_form", duration_s=float(T), torque_stretch=T / sy.T)
    # without torque and unstretched, the exact check of the phase data (optimal_closed);
    # otherwise (or where the phase data do not show it) the samples
    exact = None
    if not torque and slowdown is None and sy.batch is not None:
        exact = exact_report(sy.batch, q0, q1, lim, robot.joint_names)
    traj.stats["limit_check"] = SAMPLE_CHECK if exact is None else EXACT_CHECK
    traj.stats["arrival_residual"] = None if exact is None else exact[1]
    report = None if exact is None else exact[0]
    return finish(traj, robot, lim, torque=torque, what=method, report=report)


class _Request(NamedTuple):
    """A :func:`ptp_sync` request, validated: the start and goal, the sample period, the
    resolved limits (``torque``: a torque limit applies), the start and goal states and
    whether the arm moves at the start or must move at the goal (``from_state``)."""

    q0: np.ndarray
    q1: np.ndarray
    dt: float
    lim: Any
    torque: bool
    v0: np.ndarray
    a0: np.ndarray
    v1: np.ndarray
    from_state: bool


def _request(robot, q_start, q_goal, profile, sync, dt, limits, states) -> _Request:
    """:func:`ptp_sync`'s arguments checked where they enter (its ``Raises``): ``limits``
    ``(v_max, a_max, j_max, tau_max)``, ``states`` ``(qd_start, qdd_start, qd_goal)``."""
    if profile not in PTP_PROFILES:
        raise InputError(f"unknown PTP profile {profile!r}; use one of {PTP_PROFILES}")
    if sync not in ("time", "phase"):
        raise InputError(f"sync must be 'time' or 'phase', not {sync!r}")
    q0 = validate_waypoints(robot, q_start, where="ptp_sync q_start", min_rows=None)
    q1 = validate_waypoints(robot, q_goal, where="ptp_sync q_goal", min_rows=None)
    dt = _DEFAULT_DT[profile] if dt is None else float(dt)
    if not math.isfinite(dt) or dt <= 0:
        raise InputError(f"dt must be a positive number of seconds, not {dt!r}")
    v_max, a_max, j_max, tau_max = limits
    lim = resolve_limits(
        robot,
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
        need=_NEEDS[profile],
        where=f"ptp_sync {profile}",
    )
    v, a, j = lim.velocity_rad_s, lim.acceleration_rad_s2, lim.jerk_rad_s3
    assert v is not None  # resolve_limits raises when a needed limit is missing
    qd_start, qdd_start, qd_goal = states
    v0 = validate_joint_state(robot, qd_start, "qd_start", v, "velocity", where="ptp_sync")
    v1 = validate_joint_state(robot, qd_goal, "qd_goal", v, "velocity", where="ptp_sync")
    a0 = validate_joint_state(robot, qdd_start, "qdd_start", a, "acceleration", where="ptp_sync")
    rest = qd_start is None and qdd_start is None and qd_goal is None  # the common case
    if profile == "scurve" and not rest:  # (at rest there is nothing to stop)
        assert j is not None  # resolve_limits raises when a needed limit is missing
        check_stoppable(robot, v0, a0, v, j, where="ptp_sync")
    elif profile != "scurve":
        a0 = np.zeros(robot.n_joints)  # a trapezoid's acceleration steps: only checked
    # a nonzero speed or acceleration
    from_state = not rest and bool(v0.any() or v1.any() or a0.any())
    if from_state and (profile == "velocity" or sync != "time"):
        raise InputError(
            f"ptp_sync: qd_start/qdd_start/qd_goal (replanning from a moving state) need "
            f"profile='trapezoid' or 'scurve' and sync='time', not profile={profile!r}, "
            f"sync={sync!r}"
        )
    # tau_max=False switched the torque limit off in resolve_limits
    return _Request(q0, q1, dt, lim, lim.torque_Nm is not None, v0, a0, v1, from_state)


def _zero_length(robot, q0, q1, profile, sync, lim, torque) -> Trajectory:
    """The result of a move of zero length: one sample at rest."""
    method = f"ptp_{profile}"
    z = np.zeros((1, robot.n_joints))
    traj = Trajectory(
        [0.0],
        q0[None],
        z,
        z.copy(),
        z.copy() if profile == "scurve" else None,
        joint_names=robot.joint_names,
        method=method,
    )
    traj.meta.update(
        profile=profile,
        sync=sync,
        duration_s=0.0,
        zero_length=True,
        q_start=q0.tolist(),
        q_goal=q1.tolist(),
    )
    return finish(traj, robot, lim, torque=torque, what=method)


class _Synchronised(NamedTuple):
    """The synchronised profiles of a move: the batch of every joint's double S (time sync)
    or the profiles (``profs``: phase sync, the velocity profile), the duration ``T``, the
    joint that sets it and its binding limit (``kind``), the synchronisation used."""

    batch: SCurveBatch | None
    profs: list | None
    T: float
    joint: int
    kind: str
    sync: str


def _synchronise(robot, D, delta, profile, sync, lim, dt) -> _Synchronised:
    """Every joint's profile of a move from rest to rest (module docstring; Jiang 1987,
    eq. 3-4): ``D`` the distances, ``delta`` the signed moves."""
    v, a, j = lim.velocity_rad_s, lim.acceleration_rad_s2, lim.jerk_rad_s3
    if profile == "velocity":
        profs, T, (bkind, bj) = _velocity_profiles(D, v, a, dt)
        return _Synchronised(None, profs, T, bj, bkind, "phase")
    assert a is not None  # needed by the trapezoid and S-curve profiles
    # a trapezoid is the double S without a jerk limit
    jj = j if profile == "scurve" and j is not None else np.full(robot.n_joints, np.inf)
    # Jiang 1987, eq. 3-4, each joint's double S in closed form (one batch)
    # the signed moves: its evaluation is signed (no signed copies of the samples)
    batch = synchronised_scurves(np.copysign(D, delta)[None], v, a, jj)
    T, t_i = float(batch.duration[0]), batch.t_min[0]
    bj = int(t_i.argmax())
    # the slowest joint takes its own shortest time: its speed is its peak speed
    bkind = double_s_binding(D[bj], v[bj], a[bj], jj[bj], peak=batch.v[0, bj])
    if sync != "phase":  # each joint's MotionProfile: built where the torque stretch needs them
        return _Synchronised(batch, None, T, bj, bkind, sync)
    moving = D > 0
    vs = float(np.min(v[moving] / D[moving]))
    as_ = float(np.min(a[moving] / D[moving]))
    if profile == "trapezoid":
        base = trapezoid_profile(1.0, vs, as_)
    else:
        base = double_s_profile(1.0, vs, as_, float(np.min(jj[moving] / D[moving])))
    # one normalised profile: not the batch's
    return _Synchronised(None, [base] * robot.n_joints, base.duration, bj, bkind, sync)


def _sampled(robot, req: _Request, delta, profile, sy: _Synchronised) -> tuple:
    """The sampled motion of the synchronised profiles ``sy``, stretched in time where a
    torque limit needs it: ``(Trajectory, T, profiles, slowdown)`` (``profiles`` None where
    the batch's phase data served)."""
    normalised = profile != "velocity" and sy.sync == "phase"
    method = f"ptp_{profile}"

    def build(duration, corners, evaluate, signed: bool = False) -> Trajectory:
        # every joint's switching times are knots: each piece between knots is the Taylor
        # polynomial of its left knot (constant acceleration or jerk), evaluated exactly
        t = sample_times(duration, req.dt, corners)
        s, sd, sdd, sddd = evaluate(t)  # each (n_samples, n_joints)
        if not signed:  # phase sync: one profile over [0, 1]; else each joint's distance
            scale = delta if normalised else np.sign(delta)
            s, sd, sdd, sddd = scale * s, scale * sd, scale * sdd, scale * sddd
        q = req.q0 + s
        q[-1] = req.q1  # exact arrival of every joint at the last sample
        # arrays made here: float64 (n_samples, n_joints), finite (closed-form profiles of
        # finite moves under finite limits > 0), t strictly increasing (sample_times)
        return Trajectory._from_checked(
            t, q, sd, sdd, sddd if profile == "scurve" else None, robot.joint_names, method
        )

    T, profs, batch = sy.T, sy.profs, sy.batch
    if batch is not None:  # time sync: every joint at once, from the batch's phase data
        traj = build(T, batch.boundaries()[0, 1:].reshape(-1), _batch_columns(batch), True)
    else:
        assert profs is not None
        traj = build(T, np.concatenate([p.corners for p in profs]), _columns(profs))
    slowdown: dict | None = None
    # without a torque limit the closed-form profiles are within every limit by construction
    # (the check below says so, exactly from the phase data where it can): no stretch rounds
    for _ in range(10 if req.torque else 0):  # torque peaks move between samples: iterate
        # on the evaluation's peaks (knots, left limits, interior extremes, refined torques)
        check = traj.limit_samples(robot=robot if req.torque else None)
        k, kind, joint = stretch_needed(check, robot, req.lim, torque=req.torque)
        if k <= 1 + 1e-12:
            break
        k *= 1 + 1e-9
        if profs is None:
            assert batch is not None
            profs = batch.profiles(0)
        profs = [p.stretched(k) for p in profs]
        T = T * k
        traj = build(T, np.concatenate([p.corners for p in profs]), _columns(profs))
        if slowdown is None:
            slowdown = {"kind": kind, "joint": joint}
        slowdown["factor"] = T / sy.T
    return traj, T, profs, slowdown


def _profile_dicts(profs, batch) -> list[dict]:
    """Each joint's profile for ``meta["joint_profiles"]``: of its :class:`MotionProfile`, or
    of the batch's phase data where none was built (the same dicts)."""
    return batch.profile_dicts(0) if profs is None else [p.to_dict() for p in profs]


def _columns(profiles):
    """The evaluation of one profile per joint as ``(n_samples, n_joints)`` arrays
    ``(s, sd, sdd, sddd)`` at times ``t``."""

    def evaluate(t):
        cols = [p.evaluate(t) for p in profiles]
        return tuple(np.stack([c[i] for c in cols], axis=1) for i in range(4))

    return evaluate


def _batch_columns(batch):
    """:func:`_columns` of a batch of one problem (:meth:`SCurveBatch.evaluate_jerk`)."""
    return lambda t: tuple(x[:, 0] for x in batch.evaluate_jerk(t))


def _scurves_from_state(delta, v0, a0, v1, v, a, j):
    """:func:`_from_state_profiles` with a jerk limit (Berscheid & Kröger 2021, steps 1-2)."""
    T, moves, profs, moved = synchronised_from_state(delta, v0, a0, v1, v, a, j)
    bj = int(np.argmax([m.t_min for m in moves]))
    p = profs[bj]
    flat = p.jerks == 0  # a cruise at the speed limit, or a plateau at the acceleration limit
    if np.any(flat & (p.accels == 0) & (np.abs(p.v_knots[:-1]) >= v[bj] * (1 - 1e-12))):
        kind = "velocity"
    elif np.any(flat & (np.abs(p.accels) >= a[bj] * (1 - 1e-12))):
        kind = "acceleration"
    else:
        kind = "jerk"
    return profs, T, bj, kind, moved


def _ptp_from_state(robot, q0, q1, v0, a0, v1, v, a, j, lim, dt, torque) -> Trajectory:
    """:func:`ptp_sync` from a moving state (module docstring); ``j`` None: trapezoids."""
    profile = "trapezoid" if j is None else "scurve"
    method = f"ptp_{profile}"
    delta = q1 - q0
    delta = np.where(np.abs(delta) < 1e-12, 0.0, delta)

    def build(profiles, duration) -> Trajectory:
        t = sample_times(duration, dt, np.concatenate([p.corners for p in profiles]))
        n = t.size
        q = np.empty((n, robot.n_joints))
        qd, qdd, qddd = np.empty_like(q), np.empty_like(q), np.empty_like(q)
        for i, p in enumerate(profiles):
            s, sd, sdd, sddd = p.evaluate(t)
            q[:, i], qd[:, i], qdd[:, i], qddd[:, i] = q0[i] + s, sd, sdd, sddd
        q[-1] = q1  # exact arrival
        qd[0], qd[-1] = v0, v1  # exact boundary speeds
        if j is not None:  # and accelerations: the S-curve's is continuous
            qdd[0], qdd[-1] = a0, 0.0
        return Trajectory(
            t,
            q,
            qd,
            qdd,
            None if j is None else qddd,
            joint_names=robot.joint_names,
            method=method,
        )

    tau_max = lim.torque_Nm
    if tau_max is not None:  # the start state alone, before any change
        h = rigid_body.inverse_dynamics(robot, q0[None], v0[None], a0[None])[0]
        over = held_over_limit(np.abs(h)[None] / np.asarray(tau_max))  # the planners' one rule
        if over is not None:
            jk = over[1]
            raise LimitViolation(
                f"{method}: {robot.joint_names[jk]} needs {h[jk]:.4g} N m at the start state "
                f"(qd_start, qdd_start) before any change, above its torque limit "
                f"{float(np.asarray(tau_max)[jk]):.4g} N m"
            )
    a_used = np.asarray(a, float).copy()
    j_used = None if j is None else np.asarray(j, float).copy()
    # the lowest limits the start state allows: |a0| <= a, and v0 + a0 |a0| / 2j within v
    a_floor = np.abs(a0)
    room = np.maximum(v - np.sign(a0) * v0, 1e-300)
    j_floor = a0 * a0 / (2 * room) * (1 + 1e-9)
    profs, T, bj, bkind, gap = _from_state_profiles(delta, v0, a0, v1, v, a_used, j_used)
    traj = build(profs, T)
    T0 = T
    slowdown: dict[str, Any] | None = None
    k_prev = math.inf
    for _ in range(6):  # torque: lower the acceleration limit, the boundary speeds stay
        check = traj.limit_samples(robot=robot if torque else None)
        k, kind, joint = stretch_needed(check, robot, lim, torque=torque)
        if k <= 1 + 1e-12 or (k > 0.9 * k_prev and k > 1.01) or T > 50 * T0:
            # done, or the excess does not shrink with the acceleration (torque of the
            # start speed itself): finish() names it
            break
        # the factor assumes every torque term scales with 1/k^2; the start speed's do not,
        # so after the first round the (small) remaining excess is over-corrected
        power = 2.0 if math.isinf(k_prev) else 6.0
        k_prev = k
        a_used = np.maximum(a_used / (k * (1 + 1e-9)) ** power, a_floor)
        if j_used is not None:  # the jerk as a time scaling would lower it: k^3 for k^2
            j_used = np.maximum(j_used / (k * (1 + 1e-9)) ** (1.5 * power), j_floor)
        profs, T, bj, bkind, gap = _from_state_profiles(delta, v0, a0, v1, v, a_used, j_used)
        traj = build(profs, T)
        if slowdown is None:
            slowdown = {"kind": kind, "joint": joint}
        slowdown["factor"] = T / T0 if T0 > 0 else 1.0
        slowdown["acceleration_scale"] = float(np.min(a_used / a))
        if j_used is not None:
            slowdown["jerk_scale"] = float(np.min(j_used / j))
    traj.meta.update(
        profile=profile,
        sync="time",
        duration_s=float(T),
        dt_s=dt,
        binding={"joint": robot.joint_names[bj], "limit": bkind, "gap": gap},
        q_start=q0.tolist(),
        q_goal=q1.tolist(),
        qd_start=v0.tolist(),
        qd_goal=v1.tolist(),
        **({} if j is None else {"qdd_start": a0.tolist()}),
        joint_profiles=[p.to_dict() for p in profs],
        normalised_profile=None,
        slowdown=slowdown,
    )
    return finish(traj, robot, lim, torque=torque, what=method)
