"""Bounds and parameters of the optimiser's NLP
(:class:`~armlab.planning.optimal_problem.OptimalProblem`): variable boxes, constraint rows
(velocity, position, torque, duration, motor envelope, RMS) and the parameter vector of the
compiled problem (:mod:`armlab.planning.transcription`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from armlab.planning.transcription import Structure
from armlab.robot.limits import Limits
from armlab.robot.symbolic import (
    dynamic_parameters,
)

if TYPE_CHECKING:
    from armlab.planning.optimal_problem import OptimalProblem

__all__ = [
    "bounds",
    "drive_bounds",
    "params",
    "H_MIN_S",
    "TORQUE_ROW_MARGIN",
    "TIME_REGULARISATION",
]

#: shortest interval the optimiser may use, in [s]
H_MIN_S = 1e-4
#: tiny smoothness weight added to the pure time objective (regularises non-binding joints)
TIME_REGULARISATION = 1e-7
#: the torque rows bound ``|tau| / tau_max`` by ``1 - this``: IPOPT meets a constraint to about
#: 1e-8 relative, and a node where gravity alone then exceeds the limit by that much cannot be
#: fixed by the tolerance stretch (issue 15: 1 of 250 random 5-waypoint teachbot6 problems, a
#: path through a pose where joint4's gravity torque equals its limit)
TORQUE_ROW_MARGIN = 1e-7
#: a voltage-line row is switched off where the peak row implies it with this share of the
#: line to spare (:func:`drive_bounds`): far above the solvers' 1e-9 constraint tolerance
LINE_ROW_SLACK = 1e-6


def _energy_weights(robot) -> tuple[np.ndarray, str]:
    """``R / (k_t N eta)^2`` per joint so that ``w tau^2`` is the copper loss in [W]."""
    n = robot.n_joints
    drives = getattr(robot, "drives", None)
    if not drives:
        return np.ones(n), "N^2 m^2 s"
    w = np.empty(n)
    for i, name in enumerate(robot.joint_names):
        d = drives[name]
        k = d.motor.torque_constant_Nm_A * d.reducer.ratio * d.reducer.efficiency
        w[i] = d.motor.resistance_ohm / k**2
    return w, "J"


def bounds(
    prob: OptimalProblem, st: Structure, limits: Limits, drive_scale=None, implied_off=False
):
    """``(lbx, ubx, lbg, ubg)`` of the optimiser's problem; ``implied_off``: the voltage-line
    rows the peak rows imply switched off (:func:`drive_bounds`; the fatrop backend's, whose
    cost per iteration grows with the rows. IPOPT keeps every row: on a case whose
    non-binding joints are flat in the objective its path, and so its back-off rounds,
    changed with them -- 1 -> 4 rounds, the duration by 7.6e-6 -- measured)."""
    n, N = prob.n, prob.N
    inf = np.inf
    ls = limits
    lo_q = np.tile(ls.lower_rad, (N + 1, 1))
    hi_q = np.tile(ls.upper_rad, (N + 1, 1))
    nodes = prob.waypoint_nodes
    tol = prob.via_tolerance
    for k, node in enumerate(nodes):
        if k in (0, len(nodes) - 1) or not np.any(tol > 0):
            lo_q[node] = hi_q[node] = prob.waypoints[k]
        else:
            lo_q[node] = np.maximum(prob.waypoints[k] - tol, ls.lower_rad)
            hi_q[node] = np.minimum(prob.waypoints[k] + tol, ls.upper_rad)
    (q0, v0, a0), (q1, v1) = prob.boundary_states()
    lo_q[0] = hi_q[0] = q0
    lo_q[-1] = hi_q[-1] = q1
    vmax = ls.velocity_rad_s if ls.velocity_rad_s is not None else np.full(n, inf)
    amax = ls.acceleration_rad_s2 if ls.acceleration_rad_s2 is not None else np.full(n, inf)
    jmax = ls.jerk_rad_s3 if ls.jerk_rad_s3 is not None else np.full(n, inf)
    lo_v, hi_v = np.tile(-vmax, (N + 1, 1)), np.tile(vmax, (N + 1, 1))
    lo_v[0] = hi_v[0] = v0
    lo_v[-1] = hi_v[-1] = v1
    if prob.drive_limits:  # each joint monotone within a segment (module docstring)
        sig = prob.node_directions()
        lo_v = np.where(sig > 0, 0.0, lo_v)
        hi_v = np.where(sig < 0, 0.0, hi_v)
        lo_v[sig == 0] = hi_v[sig == 0] = 0.0
    lbx, ubx = [lo_q.reshape(-1), lo_v.reshape(-1)], [hi_q.reshape(-1), hi_v.reshape(-1)]
    if prob.mode == "jerk":
        lo_a, hi_a = np.tile(-amax, (N + 1, 1)), np.tile(amax, (N + 1, 1))
        lo_a[0] = hi_a[0] = a0
        lo_a[-1] = hi_a[-1] = 0.0
        lbx.append(lo_a.reshape(-1))
        ubx.append(hi_a.reshape(-1))
        lbx.append(np.tile(-jmax, N))
        ubx.append(np.tile(jmax, N))
    else:
        lbx.append(np.tile(-amax, N))
        ubx.append(np.tile(amax, N))
    nseg = len(prob.segment_intervals)
    frac = prob.fractions
    assert frac is not None  # set by make_warm_start, which solve() runs first
    fmin = np.array([frac[prob.segment_of_interval == s].min() for s in range(nseg)])
    lbx.append(H_MIN_S / fmin)
    ubx.append(np.full(nseg, inf))
    # constraint rows
    kind, joint = st.g_kind, st.g_joint
    lbg = np.zeros(kind.size)
    ubg = np.zeros(kind.size)
    m = kind == "velocity"
    lbg[m] = -vmax[joint[m]] / prob.scales["v"][joint[m]]
    ubg[m] = vmax[joint[m]] / prob.scales["v"][joint[m]]
    m = kind == "position"
    lbg[m], ubg[m] = ls.lower_rad[joint[m]], ls.upper_rad[joint[m]]
    m = kind == "torque"
    lbg[m], ubg[m] = -(1.0 - TORQUE_ROW_MARGIN), 1.0 - TORQUE_ROW_MARGIN
    if prob.mode == "jerk" and st.torque_rows and ls.torque_Nm is not None:
        # the first and last knots are fixed states (q, qd, qdd bounds): their torque
        # rows are constants, checked against the request's own limit before the solve
        # (_check_static_torque). A back-off bound below that constant would make the
        # re-solve infeasible by construction (issue 15: gravity 0.9895 of joint4's limit
        # at the start, bound backed off to 0.9833): they keep the request's limit
        own = prob.limits.torque_Nm
        assert own is not None  # a backed-off torque limit comes from the request's
        rows = np.flatnonzero(m)
        ends = np.concatenate([rows[:n], rows[N * n : (N + 1) * n]])  # node-major rows
        relax = own[joint[ends]] / ls.torque_Nm[joint[ends]]
        lbg[ends], ubg[ends] = lbg[ends] * relax, ubg[ends] * relax
    m = kind == "duration"
    if np.any(m):
        lbg[m] = ubg[m] = prob.duration
    if st.drive_rows:
        v_abs = np.maximum(np.abs(lo_v), np.abs(hi_v)) if implied_off else None  # (N + 1, n)
        drive_bounds(prob, st, lbg, ubg, drive_scale, v_abs)
    return np.concatenate(lbx), np.concatenate(ubx), lbg, ubg


def drive_bounds(prob: OptimalProblem, st: Structure, lbg, ubg, drive_scale, v_abs=None) -> None:
    """Bounds of the motor-envelope and RMS rows (:data:`DRIVE_ROW_TAGS`): switched on by
    the direction of motion (upper rows of the motoring branch where ``sigma >= 0``, lower
    ones where ``sigma <= 0``, the back-driven branch always) and scaled by the back-off.

    ``v_abs`` (N + 1, n): the largest ``|qd|`` the velocity bounds allow at each node [rad/s].
    A voltage-line row ``e + k_w <= s U_0`` (``e - k_w >= -s U_0``) follows from the peak row
    of its branch ``e <= s T_p`` (``e >= -s T_p``) wherever ``k_w = (Kt Ke / R) N |qd|``
    cannot exceed ``s (U_0 - T_p)`` (``k_w >= 0`` by the direction bounds): at rest, and at
    every column of a joint whose line stays above its peak torque up to its velocity limit.
    Such rows are switched off (both bounds infinite: the solvers drop them); the feasible set
    is the same (:data:`LINE_ROW_SLACK` of the line's size kept in reserve)."""
    tr = prob.train
    assert tr is not None and st.g_tag is not None and st.g_col is not None
    env_s, rms_s = drive_scale if drive_scale is not None else (1.0, 1.0)
    env_s = np.broadcast_to(np.asarray(env_s, float), (prob.n,))
    line, peak = tr.standstill_torque_Nm, tr.peak_motor_torque_Nm
    kind, joint = st.g_kind, st.g_joint
    m = np.flatnonzero(kind == "motor_envelope")
    j, tag = joint[m], st.g_tag[m]
    col = st.g_col[m]
    sig = prob._column_directions()[j, col]
    is_line = np.char.startswith(tag.astype(str), "A")
    bound = np.where(is_line, line[j], peak[j]) * env_s[j]
    upper = np.char.endswith(tag.astype(str), "+")
    motoring = np.char.find(tag.astype(str), "1") == 1
    active = ~motoring | np.where(upper, sig >= 0, sig <= 0)
    if v_abs is not None:
        coef = tr.symbolic_coefficients()
        k_w = coef[:, 8] * coef[:, 0]  # the rows' back-EMF term per |qd|
        node = prob.column_nodes()[col]
        room = (line[j] - peak[j] - LINE_ROW_SLACK * line[j]) * env_s[j]
        active &= ~(is_line & (k_w[j] * v_abs[node, j] <= room))
    lbg[m] = np.where(active & ~upper, -bound, -np.inf)
    ubg[m] = np.where(active & upper, bound, np.inf)
    r = kind == "motor_rms"
    lbg[r], ubg[r] = -np.inf, 1.0


def params(
    prob: OptimalProblem, limits: Limits, drive_scale=None, st: Structure | None = None
) -> np.ndarray:
    """The parameter vector of the compiled problem; ``st`` its layout (default the IPOPT
    problem's, :meth:`OptimalProblem._structure`; the fatrop backend passes its own)."""
    n = prob.n
    tau = limits.torque_Nm if limits.torque_Nm is not None else np.ones(n)
    if prob.objective == "time":
        w = TIME_REGULARISATION
    elif prob.objective == "time+smooth":
        w = prob.smooth_weight
    else:
        w = 0.0
    ref = prob.limits.jerk_rad_s3 if prob.mode == "jerk" else prob.limits.acceleration_rad_s2
    if ref is None:
        ref = np.ones(n)
    ew, _ = _energy_weights(prob.robot)
    sc = prob.scales
    st = st if st is not None else prob._structure(limits)
    pi = dynamic_parameters(prob.robot) if st.n_pi else np.zeros(0)
    drive: list[np.ndarray] = []
    if st.drive_rows:
        tr = prob.train
        assert tr is not None
        _, rms_s = drive_scale if drive_scale is not None else (1.0, 1.0)
        rms_s = np.broadcast_to(np.asarray(rms_s, float), (n,))
        eps = 1e-2 * tr.available_joint_torque_Nm  # quadrant blend width of the RMS row
        drive = [
            tr.symbolic_coefficients().T.reshape(-1),  # coefficient-major, joint-minor
            prob._column_directions().reshape(-1, order="F"),  # as casadi's vec
            eps,
            (tr.continuous_motor_torque_Nm * rms_s) ** 2,
        ]
    return np.concatenate(
        [tau, [w], ref, ew, sc["v"], sc["a"], sc["u"], sc["T"], prob.fractions, pi, *drive]
    )


def drive_params(p: np.ndarray, n: int, n_columns: int) -> tuple[np.ndarray, ...]:
    """The drive part of a :func:`params` vector (its tail, with ``drive_limits``): the
    envelope coefficients (``9 n``, coefficient-major), the directions (``n x n_columns``,
    column-major), the RMS row's blend widths ``eps`` (``n``) and its bounds ``cont^2``
    (``n``, the back-off scale in them)."""
    k = n * n_columns
    tail = p[p.size - 11 * n - k :]
    return tail[: 9 * n], tail[9 * n : 9 * n + k], tail[-2 * n : -n], tail[-n:]
