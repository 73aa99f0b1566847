"""The optimiser's warm start: the synchronised S-curve plan through the waypoints (stopping at
each), slowed down until the torques (and the motor envelope) fit, on the node grid of
:class:`~armlab.planning.optimal_problem.OptimalProblem`; its fit to a moving start or goal
state (:func:`~armlab.planning.warmstart.fit_piecewise`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from armlab.planning.optimal_bounds import H_MIN_S, TORQUE_ROW_MARGIN
from armlab.planning.timescale import (
    torque_stretch,
)
from armlab.planning.warmstart import (
    fit_piecewise,
    integrate_piecewise,
    phase_grid,
    sample_profiles,
)
from armlab.robot import drivetrain, rigid_body
from armlab.robot.limits import Limits
from armlab.trajectory.profiles import (
    synchronised_from_state,
    synchronised_profiles,
    synchronised_scurves,
)

if TYPE_CHECKING:
    from armlab.planning.optimal_problem import OptimalProblem

__all__ = ["make_warm_start", "warm_boundaries"]


def _surrogate_acc(robot, w0, ls: Limits, train=None) -> np.ndarray:
    """An acceleration scale for the warm start when no acceleration limit is given (from the
    torque limit, or with ``drive_limits`` the thesis' available torque of the drives)."""
    if ls.acceleration_rad_s2 is not None:
        return ls.acceleration_rad_s2
    if ls.jerk_rad_s3 is not None:
        return np.full(robot.n_joints, np.inf)
    M = rigid_body.mass_matrix(robot, w0)
    g = np.abs(rigid_body.gravity_torques(robot, w0))
    inertia = np.diag(M).copy()
    if ls.torque_Nm is not None:
        tau = ls.torque_Nm
    else:  # drive_limits: the motor at half the speed limit, and the reflected inertia
        assert train is not None  # build_optimal refuses velocity limits alone
        v = ls.velocity_rad_s if ls.velocity_rad_s is not None else train.rated_speed_rad_s
        w_half = 0.5 * np.minimum(v * train.ratio, train.rated_speed_rad_s)
        tau = train.ratio * train.efficiency * drivetrain.envelope_torque(w_half, train)
        inertia += train.efficiency * train.reflected_inertia_kg_m2
    spare = np.maximum(tau - g, 0.1 * tau)
    return 0.5 * spare / np.maximum(inertia, 1e-6)


def _classical_segment(
    robot, qa, qb, ls: Limits, acc, ns: int, mode: str, state=None, batch=None, index=0
):
    """(T, node times, q, qd, qdd, u) of one synchronised S-curve segment.

    Rest to rest (:func:`~armlab.trajectory.profiles.synchronised_profiles`), or with
    ``state = (qd0, qdd0, qd1)`` (a replan's first or last segment, jerk mode, every limit
    finite and the state within it) the time-synchronised jerk-limited moves from that state
    (:func:`~armlab.trajectory.profiles.synchronised_from_state`, Berscheid & Kröger 2021,
    the method of Ruckig). The node times hold the switching instants of the slowest joint(s)
    (those within 2 % of the segment time), the rest of the grid halves the longest intervals;
    every joint's profile is then refitted (:func:`fit_piecewise`) to be an exact solution of
    the optimiser's integration equations on that grid. (Another state, or acceleration mode:
    the rest-to-rest segment, refitted to the state later,
    :meth:`OptimalProblem._warm_boundaries`.) ``batch``: the rest-to-rest segments of all
    waypoints in closed form (:func:`~armlab.trajectory.profiles.synchronised_scurves`), this
    one at ``index``; the same profiles as ``synchronised_profiles``, ~40 x faster.
    """
    n = robot.n_joints
    v = ls.velocity_rad_s if ls.velocity_rad_s is not None else np.full(n, np.inf)
    j = ls.jerk_rad_s3 if ls.jerk_rad_s3 is not None else np.full(n, np.inf)
    D = qb - qa
    z = np.zeros(n)
    v0, a0, v1 = state if state is not None else (z, z, z)
    if (
        state is not None
        and mode == "jerk"
        and all(np.all(np.isfinite(x)) for x in (v, acc, j))
        and np.all(np.abs(a0) <= acc)
    ):
        T, moves, profiles, _ = synchronised_from_state(D, v0, a0, v1, v, acc, j)
        Tj = np.array([m.t_min for m in moves])
        signs = np.ones(n)  # the moves are signed
    elif batch is not None:
        T, Tj = float(batch.duration[index]), batch.t_min[index]
        profiles = [batch.profile((*index, i)) for i in range(n)]
        signs = np.sign(D)
        v0, a0, v1 = z, z, z
    else:
        T, Tj, profiles = synchronised_profiles(np.abs(D), v, acc, j)
        signs = np.sign(D)
        v0, a0, v1 = z, z, z  # refitted to the state later (_warm_boundaries)
    slow = np.argsort(-Tj)[: max(1, int(np.sum(Tj >= 0.98 * T)))][:3]
    t = phase_grid(profiles, T, ns, h_min=2 * H_MIN_S, joints=slow)
    q, qd, qdd = sample_profiles(profiles, signs, t)
    h = np.diff(t)
    m = "jerk" if mode == "jerk" else "acceleration"
    if mode == "jerk":
        u_ref = np.diff(qdd, axis=0) / h[:, None]
        target = np.vstack([D, v1, z])
    else:
        u_ref = np.diff(qd, axis=0) / h[:, None]
        target = np.vstack([D, z])
    start = (v0, a0) if state is not None else None
    u = fit_piecewise(h, u_ref, target, m, start=start)
    q, qd, qdd = integrate_piecewise(h, u, qa, m, start=start)
    return T, t, q, qd, qdd, u


def _segment_dynamics(robot, segments, need: bool) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(tau, g)`` of every segment's samples (RNEA torques and gravity torques, each
    ``(n_samples, n_joints)`` in [N m]) from one batched pass over all of them
    (:func:`~armlab.robot.rigid_body.inverse_dynamics`: each sample's torque is computed on
    its own, so the values are those of a pass per segment); empty if not ``need``."""
    if not need:
        return []
    q, qd, qdd = (np.vstack([seg[i] for seg in segments]) for i in (2, 3, 4))
    taus = rigid_body.inverse_dynamics(robot, q, qd, qdd)
    gs = rigid_body.gravity_torques(robot, q)
    cut = np.cumsum([seg[2].shape[0] for seg in segments])[:-1]
    return list(zip(np.split(taus, cut), np.split(gs, cut), strict=True))


def _timescale_for_torque(tau, g, tau_max) -> float:
    """Smallest factor ``alpha >= 1`` so that slowing the warm start's samples (torques
    ``tau``, gravity torques ``g``) down by it meets the optimiser's torque rows,
    ``|tau| <= (1 - TORQUE_ROW_MARGIN) tau_max``
    (:func:`~armlab.planning.timescale.torque_stretch`, exact; samples where gravity alone is
    over the limit are left to the solver)."""
    if tau_max is None:
        return 1.0
    return float(np.max(torque_stretch(tau, g, (1.0 - TORQUE_ROW_MARGIN) * tau_max)))


def _timescale_for_drive(tau, g, qd, qdd, train) -> float:
    """Smallest factor ``alpha >= 1`` (of a geometric search, step 5 %) with which the warm
    start's samples (torques ``tau``, gravity torques ``g``) fit the motor envelope (voltage
    line and peak torque); the plan's RMS is left to the optimiser. A start that never fits
    is returned at ``alpha = 20``."""
    if train is None:
        return 1.0
    d = tau - g
    alpha = 1.0
    for _ in range(62):
        a2 = alpha**2
        t_m, _ = drivetrain.motor_torque(g + d / a2, qd / alpha, qdd / a2, train)
        r = drivetrain.envelope_ratio(t_m, drivetrain.motor_speed(qd / alpha, train), train)
        if float(np.max(r)) <= 0.99:
            break
        alpha *= 1.05
    return alpha


def make_warm_start(prob: OptimalProblem) -> np.ndarray:
    """The synchronised S-curve plan (stopping at each via point) on the node grid."""
    w, ls, n = prob.waypoints, prob.limits, prob.n
    acc = _surrogate_acc(prob.robot, w[0], ls, prob.train)
    qs, vs, us, hs, T_list = [w[:1]], [np.zeros((1, n))], [], [], []
    as_: list[Any] = [None]  # accelerations per segment (index 0 unused)
    (_, v0, a0), (_, v1) = prob.boundary_states()
    last, z = len(prob.segment_intervals) - 1, np.zeros(n)
    v_lim = ls.velocity_rad_s
    batch = None  # every rest-to-rest segment at once, in closed form (limits finite)
    if v_lim is not None and np.all(np.isfinite(acc)) and np.all(np.isfinite(v_lim)):
        j_lim = ls.jerk_rad_s3 if ls.jerk_rad_s3 is not None else np.inf
        batch = synchronised_scurves(np.diff(w, axis=0)[None], v_lim, acc, j_lim)
    segments = []
    for s, ns in enumerate(prob.segment_intervals):
        state = None
        if prob.from_state and s in (0, last):  # a replan's first or last segment
            state = (v0 if s == 0 else z, a0 if s == 0 else z, v1 if s == last else z)
        segments.append(
            _classical_segment(
                prob.robot, w[s], w[s + 1], ls, acc, ns, prob.mode, state, batch, (0, s)
            )
        )
    drive = prob.drive_limits and prob.train is not None
    dynamics = _segment_dynamics(prob.robot, segments, ls.torque_Nm is not None or drive)
    for s, (T, t, q, qd, qdd, u) in enumerate(segments):
        # slow down uniformly until the torques fit: t*alpha, qd/alpha, qdd/alpha^2, ...
        alpha = 1.0
        if ls.torque_Nm is not None:
            alpha = _timescale_for_torque(*dynamics[s], ls.torque_Nm)
        if drive:
            alpha = max(alpha, _timescale_for_drive(*dynamics[s], qd, qdd, prob.train))
        order = 3 if prob.mode == "jerk" else 2
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
    if prob.duration is not None:  # stretch or squeeze onto the requested duration
        beta = prob.duration / Ts.sum()
        order = 3 if prob.mode == "jerk" else 2
        h, v, a, Ts, u = h * beta, v / beta, a / beta**2, Ts * beta, u / beta**order
    if prob.from_state:
        q, v, a, u = warm_boundaries(prob, q, v, a, u, h)
    prob.fractions = h / Ts[prob.segment_of_interval]
    if prob.mode != "jerk":
        a = None
    prob.warm_durations_s = Ts

    def scale(lim, warm):
        if lim is not None:
            return lim.copy()
        return np.maximum(np.max(np.abs(warm), axis=0), 1e-3)

    prob.scales = {
        "v": scale(ls.velocity_rad_s, v),
        "a": scale(ls.acceleration_rad_s2, a if a is not None else u),
        "u": scale(ls.jerk_rad_s3 if prob.mode == "jerk" else ls.acceleration_rad_s2, u),
        "T": Ts.copy(),
    }
    prob.x0 = prob._pack(q, v, a, u, Ts)
    return prob.x0


def warm_boundaries(prob: OptimalProblem, q, v, a, u, h):
    """The first and last segments of the warm start refitted (:func:`fit_piecewise`, the
    smallest change of their inputs) to leave the start state and reach the goal state
    (:meth:`boundary_states`) instead of rest; the via points stay at rest."""
    (q0, v0, a0), (q1, v1) = prob.boundary_states()
    nodes = prob.waypoint_nodes
    m = "jerk" if prob.mode == "jerk" else "acceleration"
    last = len(prob.segment_intervals) - 1
    z = np.zeros(prob.n)
    for s in sorted({0, last}):
        i, j = int(nodes[s]), int(nodes[s + 1])
        qa = q0 if s == 0 else q[i]
        qb = q1 if s == last else q[j]
        vb = v1 if s == last else z
        start = (v0, a0) if s == 0 else (z, z)
        target = np.vstack([qb - qa, vb, z]) if m == "jerk" else np.vstack([qb - qa, vb])
        uu = fit_piecewise(h[i:j], u[i:j], target, m, start=start)
        qq, vv, aa = integrate_piecewise(h[i:j], uu, qa, m, start=start)
        q[i : j + 1], v[i : j + 1], a[i : j + 1], u[i:j] = qq, vv, aa, uu
    return q, v, a, u
