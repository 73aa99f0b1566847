"""The jerk pass of TOPP: a nonconvex problem in the time domain on the path grid (a duration and
a constant path jerk per interval), warm-started from the first pass (:mod:`armlab.planning.topp`,
"Jerk pass")."""

from __future__ import annotations

import time as _time
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.interpolate import CubicSpline

from armlab._lazy import lazy_import
from armlab.robot import drivetrain
from armlab.robot.limits import Limits
from armlab.trajectory.core import Trajectory

if TYPE_CHECKING:
    import casadi as ca  # the real module for the type checker (CasADi ships type stubs)
else:
    ca = lazy_import("casadi")  # CasADi loads at the first symbolic build, not with the package


if TYPE_CHECKING:
    from armlab.planning.topp_problem import ToppProblem

__all__ = ["solve_jerk", "trajectory_from_jerk"]


def solve_jerk(
    prob: ToppProblem, ls: Limits, b: np.ndarray, env_scale: np.ndarray | None = None
) -> tuple[dict, dict]:
    """Second pass with the jerk limit: nodes keep ``s_k``; ``dt_k`` and the path jerk
    ``u_k`` per interval are free (nonconvex, warm-started from ``b``)."""
    s, K = prob.s, prob.s.size - 1
    ds = np.diff(s)
    Cn = prob.coeffs["node"]
    n = ls.n_joints
    c = ca.SX.sym("sd", K + 1)
    a = ca.SX.sym("sdd", K + 1)
    u = ca.SX.sym("sddd", K)
    h = ca.SX.sym("dt", K)
    x = ca.vertcat(c, a, u, h)
    g, lo, hi = [], [], []

    def rows(expr, lo_v, hi_v):
        g.append(expr)
        lo.append(np.broadcast_to(lo_v, (expr.shape[0],)))
        hi.append(np.broadcast_to(hi_v, (expr.shape[0],)))

    ca_, cb = c[:-1], c[1:]
    aa, ab = a[:-1], a[1:]
    rows(ca.DM(ds) - (ca_ * h + aa * h**2 / 2 + u * h**3 / 6), 0.0, 0.0)
    rows(cb - (ca_ + aa * h + u * h**2 / 2), 0.0, 0.0)
    rows(ab - (aa + u * h), 0.0, 0.0)
    d1, d2, d3 = (ca.DM(Cn[k]) for k in ("d1", "d2", "d3"))
    m, cc, gg = (ca.DM(Cn[k]) for k in ("m", "c", "g"))
    C = ca.repmat(c, 1, n)
    Aa = ca.repmat(a, 1, n)
    if ls.velocity_rad_s is not None:
        rows(
            ca.vec(d1 * C),
            -np.repeat(ls.velocity_rad_s, K + 1),
            np.repeat(ls.velocity_rad_s, K + 1),
        )
    if ls.acceleration_rad_s2 is not None:
        rows(
            ca.vec(d1 * Aa + d2 * C**2),
            -np.repeat(ls.acceleration_rad_s2, K + 1),
            np.repeat(ls.acceleration_rad_s2, K + 1),
        )
    if ls.torque_Nm is not None:
        tq = m * Aa + cc * C**2 + gg
        rows(ca.vec(tq), -np.repeat(ls.torque_Nm, K + 1), np.repeat(ls.torque_Nm, K + 1))
    if ls.jerk_rad_s3 is not None:
        for sl, uu in ((slice(0, K), u), (slice(1, K + 1), u)):  # both one-sided jerks
            U = ca.repmat(uu, 1, n)
            Cs, As = C[sl, :], Aa[sl, :]
            jk = d1[sl, :] * U + 3 * d2[sl, :] * Cs * As + d3[sl, :] * Cs**3
            rows(ca.vec(jk), -np.repeat(ls.jerk_rad_s3, K), np.repeat(ls.jerk_rad_s3, K))
    if prob.train is not None:
        jerk_drive_rows(prob, rows, m * Aa + cc * C**2 + gg, d1 * C, d1 * Aa + d2 * C**2, env_scale)
    G = ca.vertcat(*g)
    nlp = {"x": x, "f": ca.sum1(h), "g": G}
    opts: dict[str, Any] = {
        "print_time": False,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.tol": 1e-9,
        "ipopt.constr_viol_tol": 1e-9,
        "ipopt.acceptable_tol": 1e-4,
        "ipopt.acceptable_obj_change_tol": 1e-9,
        "ipopt.acceptable_iter": 5,
        "ipopt.acceptable_constr_viol_tol": 1e-9,
        "ipopt.max_iter": prob.max_iter,
        "ipopt.mu_strategy": "adaptive",
    }
    solver = ca.nlpsol("armlab_topp_jerk", "ipopt", nlp, opts)
    # warm start: the convex solution, slowed down (sd * beta) until its jerk fits
    x0 = jerk_warm_start(prob, ls, b)
    lbx = np.concatenate(
        [np.zeros(K + 1), np.full(K + 1, -np.inf), np.full(K, -np.inf), np.full(K, 1e-6)]
    )
    ubx = np.concatenate(
        [np.full(K + 1, np.inf), np.full(K + 1, np.inf), np.full(K, np.inf), np.full(K, np.inf)]
    )
    for blk in (0, K + 1):  # rest at both ends: sd = sdd = 0
        lbx[blk] = ubx[blk] = 0.0
        lbx[blk + K] = ubx[blk + K] = 0.0
    t0 = _time.perf_counter()
    res = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=np.concatenate(lo), ubg=np.concatenate(hi))
    wall = _time.perf_counter() - t0
    st = solver.stats()
    xs = np.asarray(res["x"]).ravel()
    sol = {
        "sd": xs[: K + 1],
        "sdd": xs[K + 1 : 2 * K + 2],
        "sddd": xs[2 * K + 2 : 3 * K + 2],
        "dt": xs[3 * K + 2 :],
    }
    info = {
        "success": bool(st.get("success"))
        or st.get("return_status") == "Solved_To_Acceptable_Level",
        "iterations": int(st.get("iter_count", 0)),
        "solve_time_s": wall,
        "return_status": st.get("return_status", ""),
    }
    return sol, info


def jerk_drive_rows(prob: ToppProblem, rows, tau, qd, qdd, env_scale) -> None:
    """The envelope rows of the jerk pass, exact (``sd`` is a variable): the rows of
    :data:`armlab.planning.transcription.DRIVE_ROW_TAGS` at the nodes, switched on by the
    direction of motion ``sign(q')``."""
    from armlab.planning.transcription import DRIVE_ROW_TAGS

    tr = prob.train
    assert tr is not None
    Cn = prob.coeffs["node"]
    K1, n = Cn["d1"].shape
    sig = np.sign(Cn["d1"])
    sig_f = np.where(Cn["d1"] != 0, sig, np.sign(Cn["d2"]))
    coeffs = [ca.DM(np.tile(c, (K1, 1))) for c in tr.symbolic_coefficients().T]
    e1, e2 = drivetrain.motor_torque_branches(tau, qd, qdd, ca.DM(sig_f), coeffs)
    kw = coeffs[8] * coeffs[0] * ca.DM(sig) * qd  # derated Kt Ke / R |w_m|
    env = np.ones(n) if env_scale is None else env_scale
    line, peak = tr.standstill_torque_Nm, tr.peak_motor_torque_Nm
    exprs = (e1 + kw, e2 + kw, e1 - kw, e2 - kw, e1, e2, e1, e2)
    for expr, tag in zip(exprs, DRIVE_ROW_TAGS, strict=True):
        bound = np.tile((line if tag[0] == "A" else peak) * env, (K1, 1))
        upper = tag[-1] == "+"
        active = (tag[1] == "2") | ((sig >= 0) if upper else (sig <= 0))
        lo = np.where(active & ~upper, -bound, -np.inf)
        hi = np.where(active & upper, bound, np.inf)
        rows(ca.vec(expr), lo.reshape(-1, order="F"), hi.reshape(-1, order="F"))


def jerk_warm_start(prob: ToppProblem, ls: Limits, b: np.ndarray) -> np.ndarray:
    """A consistent (s, sd, sdd, sddd) plan on the grid: the convex ``sd`` profile smoothed,
    slowed down, and re-integrated as a piecewise-cubic ``s(t)`` through the nodes."""
    s, K = prob.s, prob.s.size - 1
    sd = np.sqrt(np.maximum(b, 0.0))
    # moving average to remove the acceleration steps, then slow down
    w = 5
    ker = np.ones(w) / w
    sm = np.convolve(np.pad(sd, w // 2, mode="edge"), ker, mode="valid")[: K + 1]
    sm[0] = sm[-1] = 0.0
    Cn = prob.coeffs["node"]
    beta = 1.0
    for _ in range(40):
        c = sm * beta
        dt = 2 * np.diff(s) / np.maximum(c[:-1] + c[1:], 1e-9)
        t = np.concatenate([[0.0], np.cumsum(dt)])
        # fit a C2 cubic s(t) through (t_k, s_k) with zero end velocity/acceleration
        spl = CubicSpline(t, s, bc_type="clamped")
        cd, cdd, cddd = spl(t, 1), spl(t, 2), spl(t, 3)
        jerk = (
            np.abs(Cn["d1"] * cddd[:, None])
            + 3 * np.abs(Cn["d2"] * (cd * cdd)[:, None])
            + np.abs(Cn["d3"]) * np.abs(cd[:, None]) ** 3
        )
        ratio = np.max(jerk / ls.jerk_rad_s3) if ls.jerk_rad_s3 is not None else 0.0
        if ls.acceleration_rad_s2 is not None:
            acc = np.abs(Cn["d1"] * cdd[:, None]) + np.abs(Cn["d2"]) * cd[:, None] ** 2
            ratio = max(ratio, np.max(acc / ls.acceleration_rad_s2) ** 1.5)
        if ratio <= 1.0:
            break
        beta /= min(max(ratio ** (1 / 3), 1.05), 2.0)
    uu = np.diff(cdd) / dt
    return np.concatenate([cd, cdd, uu, dt])


def trajectory_from_jerk(prob: ToppProblem, sol: dict) -> Trajectory:
    """Map the piecewise-cubic ``s(t)`` of the jerk pass through the path."""
    s, K = prob.s, prob.s.size - 1
    c, a, u, dt = sol["sd"], sol["sdd"], sol["sddd"], sol["dt"]
    t = np.concatenate([[0.0], np.cumsum(dt)])
    times, S, SD, SDD, SDDD = [], [], [], [], []
    for k in range(K):
        for frac in (0.0, 0.25, 0.5, 0.75):
            tau = frac * dt[k]
            times.append(t[k] + tau)
            S.append(s[k] + c[k] * tau + a[k] * tau**2 / 2 + u[k] * tau**3 / 6)
            SD.append(c[k] + a[k] * tau + u[k] * tau**2 / 2)
            SDD.append(a[k] + u[k] * tau)
            SDDD.append(u[k])
    times.append(t[-1])
    S.append(1.0)
    SD.append(0.0)
    SDD.append(0.0)
    SDDD.append(u[-1])
    return prob._map(np.array(times), np.array(S), np.array(SD), np.array(SDD), np.array(SDDD))
