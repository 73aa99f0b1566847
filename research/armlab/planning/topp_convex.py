"""The convex first pass of TOPP (Verscheure et al. 2009): IPOPT on the square path speeds
``b_k``, and with ``drive_limits`` the motor-envelope rows by sequential linearisation
(:mod:`armlab.planning.topp`, "First pass" and "Planning inside the motor's envelope")."""

from __future__ import annotations

import time as _time
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import sparse

from armlab._lazy import lazy_import
from armlab.planning.topp_path import VELOCITY_POINTS
from armlab.robot.limits import Limits

if TYPE_CHECKING:
    import casadi as ca  # the real module for the type checker (CasADi ships type stubs)
else:
    ca = lazy_import("casadi")  # CasADi loads at the first symbolic build, not with the package


if TYPE_CHECKING:
    from armlab.planning.topp_problem import ToppProblem

__all__ = ["solve_convex", "solve_convex_drive", "DRIVE_SCP_TOL", "DRIVE_SCP_ITER"]

#: sequential linearisation of the envelope rows (drive_limits): stop when the duration moves
#: by less than this fraction, or after this many convex passes
DRIVE_SCP_TOL = 1e-3
DRIVE_SCP_ITER = 8


def rows(prob: ToppProblem, ls: Limits, scale: dict[str, np.ndarray]):
    """Rows ``A b`` in ``[lo, hi]`` of the convex pass and upper bounds on ``b``.

    Acceleration, torque and velocity are imposed at the midpoint of each interval, where
    ``a_k = (b_{k+1} - b_k) / (2 ds_k)`` and ``b = (b_k + b_{k+1}) / 2`` (second-order
    accurate); velocity also at the nodes (as bounds on ``b_k``). ``scale[kind]`` (K, n)
    tightens the limits of single intervals (local back-off).
    """
    s, K = prob.s, prob.s.size - 1
    ds = np.diff(s)
    Cm, Cn = prob.coeffs["mid"], prob.coeffs["node"]
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
        for frac, d1 in zip(VELOCITY_POINTS, prob.coeffs["vel_d1"], strict=True):
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
    if prob.train is not None and prob._b_lin is not None and "motor_envelope" in scale:
        b0 = np.maximum(prob._b_lin, 0.0)
        for where, C in (("left", Cl), ("mid", Cm), ("right", Cr)):
            frac = {"left": 0.0, "mid": 0.5, "right": 1.0}[where]
            b_at = (1.0 - frac) * b0[:-1] + frac * b0[1:]
            for alpha, beta, hi_v in drive_rows(prob, C, b_at, scale["motor_envelope"]):
                add(alpha, beta, np.full((K, n), -np.inf), hi_v, where)
                kinds.append("motor_envelope")
    nb = len(blocks)
    rows = np.arange(nb * K * n)
    rr = np.concatenate([rows, rows])
    cc = np.concatenate([np.tile(k_idx, nb), np.tile(k_idx + 1, nb)])
    vv = np.concatenate(
        [np.concatenate([b0 for b0, _ in blocks]), np.concatenate([b1 for _, b1 in blocks])]
    )
    A_sp = sparse.csr_matrix((vv, (rr, cc)), shape=(nb * K * n, K + 1))
    lo_all, hi_all = np.concatenate(lo), np.concatenate(hi)
    if "motor_envelope" in kinds:  # envelope rows switched off by the direction: dropped
        keep = np.isfinite(lo_all) | np.isfinite(hi_all)
        A_sp, lo_all, hi_all = A_sp[keep], lo_all[keep], hi_all[keep]
    A = ca.DM(sparse.csc_matrix(A_sp))
    ub = np.full(K + 1, np.inf)
    if ls.velocity_rad_s is not None:  # node velocity: b_k <= (v scale / q')^2
        sc = scale["velocity"]
        scn = np.minimum(np.vstack([sc[:1], sc]), np.vstack([sc, sc[-1:]]))
        ub = np.min((ls.velocity_rad_s * scn) ** 2 / np.maximum(Cn["d1"] ** 2, 1e-300), axis=1)
    return A, lo_all, hi_all, ub, kinds


def drive_rows(prob: ToppProblem, C: dict, b0: np.ndarray, env_scale: np.ndarray):
    """Linearised envelope rows ``alpha a + beta b <= hi`` (each (K, n)) at one point of
    every interval (coefficients ``C``, linearisation point ``b0`` (K,)): module docstring.
    Inactive rows (by the direction of motion) get ``hi = inf``."""
    tr = prob.train
    assert tr is not None
    N, eta, eta_b, J, b_m, f_c, f_v, _, kc = tr.symbolic_coefficients().T
    d1, d2, m, c, g = C["d1"], C["d2"], C["m"], C["c"], C["g"]
    sig = np.sign(d1)
    sig_f = np.where(d1 != 0, sig, np.sign(d2))  # at rest along the path: along q''
    line, peak = tr.standstill_torque_Nm, tr.peak_motor_torque_Nm
    # tangent points no lower than 2 % of the top path speed: any b0 > 0 gives an upper
    # bound, and near rest a tiny one would make the rows badly scaled
    root = np.sqrt(np.maximum(b0, 0.0))
    root0 = np.maximum(root, 0.02 * max(float(root.max()), 1e-6))[:, None]
    # branch k: alpha a + beta b + gamma sqrt(b) + delta (1: motoring, 2: back-driven)
    branches = []
    for gain in (1.0 / (N * eta), eta_b / N):
        alpha = m * gain + J * N * d1
        beta = c * gain + J * N * d2
        gamma = f_v * d1 * gain + b_m * N * d1
        delta = (g + f_c * sig_f) * gain
        branches.append((alpha, beta, gamma, delta))
    emf = kc * N * np.abs(d1)  # derated Kt Ke / R x |w_m| / sd
    # inside the quadrant band (joint speed below it at the linearisation point) the motor
    # torque is a blend of the two branches (drivetrain.quadrant_share): both bound it
    in_band = np.abs(d1) * root[:, None] < tr.quadrant_band_rad_s
    rows = []
    for k, (alpha, beta, gamma, delta) in enumerate(branches):
        motoring = k == 0
        for side in (1.0, -1.0):  # upper rows: e <= bound; lower: -e <= bound
            active = (sig * side >= 0) | (not motoring) | in_band
            for bound, with_emf in ((line, True), (peak, False)):
                gam = side * gamma + (emf if with_emf else 0.0)
                pos = np.maximum(gam, 0.0)  # negative parts dropped (conservative)
                b_eff = side * beta + pos / (2 * root0)
                hi = bound * env_scale - side * delta - pos * root0 / 2
                rows.append((side * alpha, b_eff, np.where(active, hi, np.inf)))
    return rows


def solve_convex(
    prob: ToppProblem,
    ls: Limits,
    scale: dict[str, np.ndarray] | None = None,
    b0: np.ndarray | None = None,
) -> tuple[np.ndarray, dict]:
    """Square path velocities ``b_k`` (K+1,) of the convex pass, and solver info."""
    s, K = prob.s, prob.s.size - 1
    ds = np.diff(s)
    n = ls.n_joints
    if scale is None:
        scale = {k: np.ones((K, n)) for k in ("velocity", "acceleration", "torque")}
    A, lo, hi, ub, kinds = rows(prob, ls, scale)
    key = (tuple(kinds), A.nnz())
    # linearised envelope rows change their coefficients every pass: never reuse that solver
    # (a key on id(A) could match a new matrix at a freed one's address)
    fresh = "motor_envelope" in kinds
    if fresh or prob._convex_solver is None or prob._convex_solver[0] != key:
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
            "ipopt.max_iter": prob.max_iter,
            "ipopt.mu_strategy": "adaptive",
        }
        prob._convex_solver = (key, ca.nlpsol("armlab_topp", "ipopt", nlp, opts))
    solver = prob._convex_solver[1]
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


def solve_convex_drive(
    prob: ToppProblem, ls: Limits, scale: dict[str, np.ndarray], b0: np.ndarray | None = None
) -> tuple[np.ndarray, dict]:
    """The convex pass with the envelope rows: sequential linearisation (module docstring)
    from the solution without them (or ``b0``); every pass meets its rows."""
    plain = {k: v for k, v in scale.items() if k != "motor_envelope"}
    prob._b_lin = None
    b, info = solve_convex(prob, ls, plain, b0)
    its, wall = info["iterations"], info["solve_time_s"]
    if not info["success"]:
        return b, info
    tr = prob.train
    assert tr is not None
    d1 = prob.coeffs["node"]["d1"]
    with np.errstate(divide="ignore"):  # the no-load speed U / Ke at the joint, over |q'(s)|
        cap = np.min((0.5 * tr.no_load_speed_rad_s / (tr.ratio * np.abs(d1))) ** 2, axis=1)
    b = np.minimum(b, cap)  # linearise no faster than half the no-load path speed
    T = np.inf
    for _ in range(DRIVE_SCP_ITER):
        prob._b_lin = b
        b_new, info = solve_convex(prob, ls, scale, b)
        its, wall = its + info["iterations"], wall + info["solve_time_s"]
        if not info["success"]:
            break
        b = b_new
        T_new = prob.duration_of(b)
        if abs(T - T_new) <= DRIVE_SCP_TOL * T_new:
            break
        T = T_new
    info = {**info, "iterations": its, "solve_time_s": wall}
    if not info["success"] and np.isfinite(T):  # a later pass failed: the last good one
        info["success"] = True
    return b, info
