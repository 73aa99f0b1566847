r"""The optimiser's solver: fatrop on compiled stage functions, IPOPT where fatrop does not apply.

:meth:`armlab.planning.optimal_problem.OptimalProblem._attempt` asks :func:`attempt` for each
solve. The problem (bounds, parameters, warm start, back-off, checks) is the optimiser's own
(:mod:`armlab.planning.optimal_bounds`); only its variables and rows are reordered stage by
stage (:mod:`armlab.planning.fatrop_stages`) and handed to fatrop (Vanroye et al., "FATROP: A
Fast Constrained Optimal Control Problem Solver for Robot Trajectory Optimization and Control",
IROS 2023; the library shipped in the casadi wheel) through its C OCP interface, whose Riccati
recursion costs time linear in the number of intervals. A solver instance is made per grid
shape (intervals and segment ends) in milliseconds and reused with new data.

Where fatrop is used: jerk mode (a jerk limit) and acceleration mode (none), every objective
(``"time"``, ``"time+smooth"`` and the fixed-duration ``"jerk"`` and ``"energy"``), with or
without torque limits, with or without ``drive_limits`` (the motor envelope rows, and the RMS
row only where it binds: :func:`_fatrop`), via
tolerances and moving start or goal states, Hessian ``"partial"`` or ``"exact"``; each
combination of mode, drive rows, duration row and energy cost is its own compiled library
(:class:`~armlab.planning.fatrop_stages.Variant`), compiled on its first use. The energy
objective's cost is normalised by its warm start's value (:func:`_warm_energy`), as the
jerk objective's, and an energy solve that stops at fatrop's acceptable point is taken
(:data:`FATROP_ACCEPTABLE`). Everything else is solved by IPOPT and ``stats["fallback"]``
says why: ``hessian="limited-memory"``, interior torque points, clearance rows, no C
compiler or no fatrop in the casadi wheel
(:class:`~armlab.planning.fatrop_stages.FatropUnavailable`), ``ARMLAB_SOLVER=ipopt`` in the
environment, and a fatrop solve that fails (not converged within its iteration cap, NaN, or
over its CPU-time budget :func:`watchdog_budget_s`, the watchdog): that solve is repeated by
IPOPT from the same start, so every verdict (a plan, or an error naming the limit) is IPOPT's
wherever fatrop does not converge.
"""

from __future__ import annotations

import ctypes
import functools
import os
import threading
import time
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from armlab._lazy import lazy_import
from armlab.planning import optimal_bounds
from armlab.planning.fatrop_stages import (
    FatropUnavailable,
    Variant,
    compiled_library,
    library_key,
)
from armlab.planning.transcription import (
    DRIVE_ROW_TAGS,
    PARTIAL_MAX_ITER,
    TORQUE_INTERIOR_POINTS,
    Structure,
    _drive_rows,
)
from armlab.robot import rigid_body
from armlab.robot.limits import Limits
from armlab.robot.symbolic import dynamic_parameters, parametric_inverse_dynamics_function

if TYPE_CHECKING:
    import casadi as ca

    from armlab.planning.optimal_problem import OptimalProblem
else:
    ca = lazy_import("casadi")

__all__ = ["attempt", "not_covered", "watchdog_budget_s", "SOLVER_ENV", "FATROP_OPTIONS"]

#: environment variable choosing the solver: ``"ipopt"`` forces IPOPT, anything else (or unset)
#: uses fatrop where it applies
SOLVER_ENV = "ARMLAB_SOLVER"
#: fatrop's options (its tolerance on the scaled KKT error, as IPOPT's 1e-9 gives durations
#: within 1e-8 of IPOPT's, measured)
FATROP_OPTIONS = {"print_level": 0, "tol": 1e-8, "constr_viol_tol": 1e-9}
#: how far inside its bounds a fixed-duration fatrop solve is asked to stay, x
#: ``max(|bound|, 1)`` (:func:`_inward`): 1.5 x fatrop's bound relaxation
BOUND_MARGIN = 1.5e-8
#: fatrop's tolerance for the fixed-duration "jerk" objective: its minimum is flat (the
#: objective is normalised by its warm-start value), and at 1e-8 one of three random
#: 3-waypoint cases stopped 1.2e-5 above IPOPT's minimum, at 1e-10 within 4e-7 (IPOPT's own
#: distance to the tighter minimum, 5e-7), two iterations more (measured)
FATROP_TOL_FIXED_DURATION = 1e-10
#: fatrop's return flag "stopped at an acceptable point" (``IpSolverReturnFlag``: its KKT
#: error under ``tol_acceptable``, 1e-6 by default, for 15 iterations in a row). An energy
#: solve (only that: the other objectives' solves were measured converging) that stops there
#: is taken, as IPOPT's "Solved_To_Acceptable_Level" is (``OptimalProblem._ipopt_attempt``),
#: the fine-grid check following as for every solve: with drive rows (jerk mode, the tests'
#: W3, 4 s) a back-off round's solve stalled at a KKT error of 6e-9 to 1.3e-8 (objective
#: constant to 9 digits over its last 17 iterations) and stopped there, its energy 5.6e-8
#: relative under IPOPT's (measured)
FATROP_ACCEPTABLE = 2
#: iteration cap of a fatrop solve (exact Hessian; "partial" takes PARTIAL_MAX_ITER as IPOPT)
FATROP_MAX_ITER = 300
#: the watchdog's budget of the solving thread's CPU time (a machine under load does not trip
#: it: 4 of 1000 wall-time budgets did at load 4, measured): this plus WATCHDOG_PER_INTERVAL_S
#: per interval, in [s] (measured solves take 0.15-1.2 ms per interval; a mis-posed one ran
#: > 2 min uncapped)
WATCHDOG_BASE_S = 2.0
WATCHDOG_PER_INTERVAL_S = 0.02
#: fatrop's initial barrier parameter (its default), and the one of a drive-limited solve from
#: the warm start (the first of a plan): from 0.1 four 3-waypoint teachbot6 cases without a
#: back-off round took 23, 26, 25 and 18 iterations, from 1e-3 16, 23, 21 and 16, durations
#: 0.3-1.6e-8 closer to IPOPT's (measured; 1e-4 about the same, 1e-2 and 1 no fewer). A
#: re-solve from a converged plan (a back-off round, the RMS row added) keeps the default:
#: from 1e-5 re-solves took half the iterations, but of 15 acceleration-mode cases
#: (bench_drive_limits --quick, bench_trajectory's drive moves) one then ended after 4 back-off
#: rounds instead of 1, 5.6e-6 longer than IPOPT's plan (and failed with 0.1 for the first
#: solve); as set, every duration within 1.6e-6 of IPOPT's, 744 iterations in all against 733
#: (measured). Where a back-off round is needed the first plan's excess between the knots
#: sets the tightened problem, so another start can end in another local optimum: one of six
#: jerk-mode cases 4.1e-5 shorter than IPOPT's (3.6e-6 with 0.1 for the first solve)
MU_INIT = 0.1
DRIVE_MU_INIT = 1e-3
#: ``drive_limits`` plans are solved without the RMS row first, and with it only where it does
#: not hold there (:func:`_fatrop`; False: with it from the start). The RMS integral costs 7
#: states a stage on six joints (their derivatives 36 % of the Hessian's instructions): a
#: teachbot6 iteration 3.7 -> 2.3 ms, 3-waypoint plans 141 -> 90 ms (median of the 5 moves of
#: bench_trajectory.py --calls-only, measured)
DRIVE_RMS_LAST = True

_LOCK = threading.Lock()
_LIBS: dict[str, Any] = {}  # library key -> ctypes.CDLL, or the FatropUnavailable reason
_POOL: dict[tuple, _Instance] = {}
_POOL_MAX = 16


def watchdog_budget_s(n_intervals: int) -> float:
    """CPU-time budget of one fatrop solve on ``n_intervals`` intervals, in [s]."""
    return WATCHDOG_BASE_S + WATCHDOG_PER_INTERVAL_S * n_intervals


def variant(prob: OptimalProblem, rms: bool = True) -> Variant:
    """The stage library that solves ``prob`` (:class:`~armlab.planning.fatrop_stages.Variant`);
    ``rms=False``: with ``drive_limits``, the one without the RMS row (:func:`_fatrop`)."""
    energy = prob.objective == "energy"  # always with its fixed duration (optimiser)
    return Variant(
        prob.mode, bool(prob.drive_limits), prob.duration is not None, energy=energy, rms=rms
    )


def not_covered(prob: OptimalProblem, hessian: str) -> str:
    """Why fatrop does not solve this problem ("" when it does)."""
    if os.environ.get(SOLVER_ENV, "").strip().lower() == "ipopt":
        return f"{SOLVER_ENV}=ipopt"
    if hessian not in ("exact", "partial"):
        return f"hessian={hessian!r} is solved by IPOPT"
    if TORQUE_INTERIOR_POINTS:
        return "interior torque points are solved by IPOPT"
    if prob.clearance_rows is not None:
        return "clearance rows are solved by IPOPT"
    return ""


# ----------------------------------------------------------------------------- library
def _library(robot, var: Variant) -> tuple[Any, str]:
    """The loaded stage library of ``robot`` and ``var`` (compiled on first use) and its key;
    raises :class:`FatropUnavailable` with the reason (remembered for the process)."""
    key = library_key(robot, var)
    got = _LIBS.get(key)
    if isinstance(got, str):
        raise FatropUnavailable(got)
    if got is not None:
        return got, key
    try:
        so, _ = compiled_library(robot, var)
        lib = ctypes.CDLL(str(so))
    except FatropUnavailable as exc:
        _LIBS[key] = str(exc)
        raise
    except OSError as exc:
        _LIBS[key] = f"the fatrop stage library could not be loaded: {exc}"
        raise FatropUnavailable(_LIBS[key]) from None
    dims = var.dims(robot.n_joints)
    built = [lib.fp_dim(i) for i in range(5)]
    want = [dims[k] for k in ("nx", "nu", "ng", "ngn", "npk")]
    if lib.fp_nj() != robot.n_joints or built != want:
        raise FatropUnavailable(f"{so} is built for other sizes ({built}, not {want})")
    dp = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
    ip = np.ctypeslib.ndpointer(dtype=np.int32, flags="C_CONTIGUOUS")
    vp, ci, cd = ctypes.c_void_p, ctypes.c_int, ctypes.c_double
    lib.fp_create.restype = vp
    lib.fp_create.argtypes = [ci, ip, ci, dp, dp, dp, dp, dp, dp, ip, dp, dp, dp, dp, ci]
    lib.fp_update.restype = ci
    lib.fp_update.argtypes = [vp, dp, dp, dp, dp, dp, dp, ip, dp, dp, dp, dp, ci]
    lib.fp_set_option.restype = ci
    lib.fp_set_option.argtypes = [vp, ctypes.c_char_p, cd]
    lib.fp_set_deadline.argtypes = [vp, cd]
    lib.fp_solve.restype = ci
    lib.fp_solve.argtypes = [vp, dp, dp, dp]
    lib.fp_free.argtypes = [vp]
    _LIBS[key] = lib
    return lib, key


# ----------------------------------------------------------------------------- layout
def _layout(prob: OptimalProblem, torque_rows: bool, var: Variant) -> tuple[Structure, np.ndarray]:
    """The optimiser's variable and row layout (the ``slices``, ``g_kind``, ``g_joint``,
    ``g_tag`` and ``g_col`` of :func:`armlab.planning.transcription.build_structure`, whose
    order this repeats) without building IPOPT's problem -- the bounds and parameters of
    :mod:`~armlab.planning.optimal_bounds` read only these -- and where each row goes among
    the stage rows (``N ng`` of the intervals, then ``ngn`` of the last node;
    :meth:`~armlab.planning.fatrop_stages.Variant.dims`), -1 for the integration rows (they
    are fatrop's dynamics)."""
    n, N, nseg = prob.n, prob.N, len(prob.segment_intervals)
    dm = var.dims(n)
    ng, ngn = dm["ng"], dm["ngn"]
    sizes = [("q", n * (N + 1)), ("v", n * (N + 1))]
    sizes += [("a", n * (N + 1))] if var.jerk else []
    slices, start = {}, 0
    for name, size in [*sizes, ("u", n * N), ("T", nseg)]:
        slices[name] = slice(start, start + size)
        start += size
    kinds: list[np.ndarray] = []
    tags: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    where: list[np.ndarray] = []
    J = np.arange(n)

    def add(kind, stages, local=0, tag="", first=0):
        stages = np.asarray(stages)
        local = np.broadcast_to(np.asarray(local), stages.shape)
        m = stages.size
        kinds.append(np.full(m * n, kind))
        tags.append(np.full(m * n, tag))
        cols.append(first + np.repeat(np.arange(m), n))
        spot = stages[:, None] * ng + local[:, None] + J
        where.append(np.where(stages[:, None] < 0, -1, spot).ravel())

    ivals, nodes = np.arange(N), np.arange(N + 1)
    for _ in range(3 if var.jerk else 2):  # q, qd (and qdd) integration: fatrop's dynamics
        add("dynamics", np.full(N, -1))
    if var.jerk:
        add("velocity", ivals, n)
        add("position", ivals, 2 * n)
        add("position", ivals, 3 * n)
        if torque_rows:
            add("torque", nodes, 0)
        if var.drive:
            for t, name in enumerate(DRIVE_ROW_TAGS):
                add("motor_envelope", nodes, np.where(nodes < N, 4 * n, n) + t * n, name)
            add("motor_rms", [N if var.has_rms else -1], 9 * n)
    else:
        add("position", ivals, 2 * n)
        if torque_rows:
            add("torque", ivals, 0)
            add("torque", ivals, n)
        if var.drive:
            for side in range(2):
                for t, name in enumerate(DRIVE_ROW_TAGS):
                    add("motor_envelope", ivals, (3 + 8 * side + t) * n, name, side * N)
            add("motor_rms", [N if var.has_rms else -1], 0)
    kind, tag, col, spot = (np.concatenate(z) for z in (kinds, tags, cols, where))
    joint = np.tile(J, kind.size // n)
    if var.duration:
        kind, tag = np.append(kind, "duration"), np.append(tag, "")
        col, joint = np.append(col, -1), np.append(joint, -1)
        spot = np.append(spot, N * ng + ngn - 1)
    light = Structure(
        solver=None,  # type: ignore[arg-type]  # no IPOPT problem: fatrop solves this one
        g_fun=None,  # type: ignore[arg-type]
        n=n,
        seg_n=prob.segment_intervals,
        mode=prob.mode,
        torque_rows=torque_rows,
        g_kind=kind,
        g_joint=joint,
        n_pi=dynamic_parameters(prob.robot).size,
        nx=start,
        slices=slices,
        build_time_s=0.0,
        drive_rows=var.drive,
        g_tag=tag,
        g_col=col,
        n_drive_columns=((N + 1) if var.jerk else 2 * N) if var.drive else 0,
    )
    return light, spot


def layout_structure(prob: OptimalProblem, torque_rows: bool) -> Structure:
    """The optimiser's layout for fatrop (:func:`_layout`) without the row placement."""
    return _layout(prob, torque_rows, variant(prob))[0]


def _stage_data(prob, st: Structure, spot, var: Variant, limits: Limits, x0, drive_scale):
    """The fatrop arrays of one solve (glue order) and the optimiser's own scaled data."""
    n, N = prob.n, prob.N
    dm = var.dims(n)
    lbx, ubx, lbg, ubg = optimal_bounds.bounds(prob, st, limits, drive_scale, implied_off=True)
    p = optimal_bounds.params(prob, limits, drive_scale, st=st)
    sv = prob._scale_vector()
    lbx, ubx = lbx / sv, ubx / sv
    xs0 = np.clip(x0 / sv, lbx, ubx)
    seg = prob.segment_of_interval
    nseg = len(prob.segment_intervals)
    last = np.cumsum(prob.segment_intervals) - 1
    b = np.zeros(N, np.int32)
    b[last[:-1]] = 1
    tau, w, uref, ew = p[:n], p[n], p[n + 1 : 2 * n + 1], p[2 * n + 1 : 3 * n + 1]
    o = 3 * n + 1  # after tau, w, uref, energy weights
    s_v, s_a, s_u = p[o : o + n], p[o + n : o + 2 * n], p[o + 2 * n : o + 3 * n]
    o += 3 * n
    s_T, frac = p[o : o + nseg], p[o + nseg : o + nseg + N]
    o += nseg + N
    pi = p[o : o + st.n_pi]
    s_e = float(np.sum(s_T))  # the scale of the elapsed time
    S = st.slices
    h0 = (xs0[S["T"]] * s_T)[seg] * frac  # the warm start's intervals [s]
    tw, w, e_end = _objective_weights(prob, var, w, xs0, sv, S, h0, (s_u, uref, pi, ew))
    drive: list[np.ndarray] = []
    Pk = np.zeros((N + 1, dm["npk"]))
    Pk[:N, 0], Pk[:N, 1] = s_T[seg] * frac, b
    if var.energy and var.jerk:  # its last column (fatrop_stages.Variant.dims)
        Pk[N - 1, -1] = e_end
    if var.drive:
        dc, _, eps, cont2 = optimal_bounds.drive_params(p, n, st.n_drive_columns)
        drive = [dc, eps, cont2] if var.has_rms else [dc]  # the directions are stage data
        sig = prob._column_directions()  # (n, columns)
        if var.jerk:
            Pk[:, 2 : 2 + n] = sig.T
        else:
            Pk[:N, 2:] = np.hstack([sig[:, :N].T, sig[:, N:].T])
    pg = np.concatenate([s_v, s_a, s_u, tau, uref, [w, tw], pi, *drive])
    if var.elapsed:
        pg = np.append(pg, s_e)
    if var.energy:
        pg = np.append(pg, ew)  # the energy weights
    te0 = np.concatenate([[0.0], np.cumsum(h0)]) / s_e

    def stage(arr, fill):
        blk = [arr[S[k]].reshape(-1, n) for k in ("q", "v", "a", "u") if k in S]
        T = arr[S["T"]]
        extra = np.zeros((N + 1, dm["nx"] - dm["it"] - 1))
        if fill is not None:
            extra[:] = fill
        X = np.hstack([*blk[:-1], np.append(T[seg], T[-1])[:, None], extra])
        nxt = np.zeros(N)
        nxt[last[:-1]] = T[1:]
        return X, np.hstack([blk[-1], nxt[:, None]])

    free = np.inf
    (lX, lU), (hX, hU) = stage(lbx, -free), stage(ubx, free)
    X0, U0 = stage(xs0, None)
    it = dm["it"]
    lX[N, it], hX[N, it] = -np.inf, np.inf  # the last node's copy of T is free
    lX[0, it + 1 :] = hX[0, it + 1 :] = 0.0  # integrals and elapsed time start at 0
    if var.elapsed:
        X0[:, -1] = te0
    if var.has_rms:  # a guess of the RMS integrals (half the rating); hp = the last interval
        X0[:, it + 1 : it + 1 + n] = 0.5 * te0[:, None]
        if var.jerk:
            X0[1:, it + 1 + n] = h0 / s_e
    elif var.energy and var.jerk:  # hp, the last interval (the drive rows' when they are on)
        X0[1:, it + 1] = h0 / s_e

    def rows(arr, off):  # off: the bound of a row that is not there
        G = np.full(N * dm["ng"] + dm["ngn"], off)
        m = spot >= 0
        G[spot[m]] = arr[m]
        return G

    lG, hG = rows(lbg, -np.inf), rows(ubg, np.inf)
    if var.drive:
        _merge_peak_rows(prob, st, spot, lG, hG)
    if var.duration:
        # the duration row t_N s_e = D as a bound on the last node's elapsed time: fatrop holds
        # a fixed state exactly (an equality), a row with equal bounds only within its bound
        # relaxation (the plan came back 4e-8 s long, measured)
        d = spot[st.g_kind == "duration"][0]
        lX[N, -1] = hX[N, -1] = lG[d] / s_e
        lG[d], hG[d] = -np.inf, np.inf
    if var.duration or var.drive:
        # every other bound moved in, so no tolerance stretch lengthens the plan (_inward)
        (lX, hX), (lU, hU), (lG, hG) = _inward(lX, hX), _inward(lU, hU), _inward(lG, hG)
    arrays = [lX, hX, lU, hU, lG, hG]
    gmask = np.ones(N * dm["ng"] + dm["ngn"], np.int32)
    data = [np.ascontiguousarray(a, float) for a in arrays]
    rest = [np.ascontiguousarray(a, float) for a in (Pk, pg, X0, U0)]
    return b, data, gmask, rest, (lbx, ubx, lbg, ubg, p, xs0), sv


def _objective_weights(prob, var: Variant, w, xs0, sv, S, h0, data) -> tuple[float, float, float]:
    """The stage cost's weights ``(tw, w, e_end)``: ``tw T + w smooth`` for ``"time"`` and
    ``"time+smooth"`` (``w`` the request's); the smoothness or energy term alone, over its value
    at the warm start ``xs0`` (scaled, intervals ``h0``), for the fixed-duration objectives: the
    same minimiser, but fatrop's absolute KKT tolerance then means a relative one (a long fixed
    duration makes the jerk integral ~1e-4, and the plain sum stopped 1e-4 above IPOPT's
    minimum, measured); ``e_end``: the energy's ``e_N/2`` of the last node (its state is fixed;
    0 otherwise). ``data``: ``(s_u, uref, pi, ew)`` of :func:`optimal_bounds.params`."""
    s_u, uref, pi, ew = data
    if prob.objective not in ("jerk", "energy"):
        return 1.0, float(w), 0.0
    if prob.objective == "jerk":  # params gives it weight 0: transcription adds it unweighted
        u0 = xs0[S["u"]].reshape(prob.N, prob.n) * s_u / uref
        return 0.0, 1.0 / max(float(np.sum(h0 * np.sum(u0**2, axis=1))), 1e-12), 0.0
    e0, e_last = _warm_energy(prob, var, xs0 * sv, S, h0, pi, ew)
    return 0.0, 1.0 / max(e0, 1e-12), e_last / 2


def _warm_energy(prob, var: Variant, x, S, h, pi, ew) -> tuple[float, float]:
    """The copper-loss quadrature of the transcription's ``"energy"`` objective at the
    physical point ``x`` with intervals ``h`` (the warm start's: fatrop's stage cost is this
    over it, so that its absolute KKT tolerance is a relative one, as for ``"jerk"``), and
    ``e_N = sum_i ew_i tau_i^2`` at the last node (jerk mode; 0 in acceleration mode). The
    inverse dynamics are the stage functions' own
    (:func:`armlab.robot.symbolic.parametric_inverse_dynamics_function`, inertial parameters
    ``pi``)."""
    n, N = prob.n, prob.N
    rnea = parametric_inverse_dynamics_function(prob.robot)
    q, v = (x[S[k]].reshape(N + 1, n) for k in ("q", "v"))

    def e(qq, vv, aa):  # (m,) sum_i ew_i tau_i^2 at m points
        m = qq.shape[0]
        tau = np.asarray(rnea.map(m)(qq.T, vv.T, aa.T, np.tile(pi[:, None], (1, m))))
        return ew @ tau**2

    if var.jerk:
        ek = e(q, v, x[S["a"]].reshape(N + 1, n))
        return float(np.sum(h * (ek[:-1] + ek[1:]) / 2)), float(ek[-1])
    u = x[S["u"]].reshape(N, n)
    return float(np.sum(h / 2 * (e(q[:-1], v[:-1], u) + e(q[1:], v[1:], u)))), 0.0


def _merge_peak_rows(prob: OptimalProblem, st: Structure, spot, lG, hG) -> None:
    """The back-driven branch's peak rows ``P2+`` (``e_2 <= T_p``) and ``P2-`` (``e_2 >=
    -T_p``) made one two-sided row where the joint moves (``sigma != 0``: there the two rows are
    the same expression, :func:`armlab.planning.transcription._drive_rows`), in place: 12 of
    ~83 rows a stage fewer on six joints, 3-8 % less solve time, the same iterations and
    durations on four 3-waypoint teachbot6 cases (measured; IPOPT keeps both rows)."""
    assert st.g_tag is not None and st.g_col is not None
    up, lo = np.flatnonzero(st.g_tag == "P2+"), np.flatnonzero(st.g_tag == "P2-")
    assert np.array_equal(st.g_col[up], st.g_col[lo])
    assert np.array_equal(st.g_joint[up], st.g_joint[lo])
    sig = prob._column_directions()[st.g_joint[up], st.g_col[up]]
    m = (sig != 0) & (spot[up] >= 0) & (spot[lo] >= 0)
    su, sl = spot[up][m], spot[lo][m]
    lG[su], lG[sl], hG[sl] = lG[sl], -np.inf, np.inf


def _inward(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The inequality bounds ``lo <= . <= hi`` moved inside by :data:`BOUND_MARGIN` x
    ``max(|bound|, 1)``; equalities, zero and infinite bounds unchanged. fatrop relaxes every
    bound it is given by about 1e-8 x ``max(|bound|, 1)`` (as IPOPT's ``bound_relax_factor``; its
    C interface does not expose the option) and its converged point may lie there: a velocity
    1.03e-8 over its limit (measured). The optimiser's tolerance stretch then slows the plan by
    that fraction, which a fixed duration must not be; so a fixed-duration solve gets its bounds
    moved in by a little more than the relaxation. (A time-optimal solve keeps its bounds: moved
    in, 20-waypoint solves took 5 % more iterations and 9 % more time, measured, for a stretch
    of 1e-8 it no longer needs.) A drive-limited solve gets them moved in too: its iterations
    did not change (23, 26, 25, 18 against 23, 26, 24, 18 on four 3-waypoint cases), and where
    the stretch was needed (4 of 8 cases) the plan's fine-grid samples and drive check were
    computed twice more (after the stretch), 10 of ~85 ms a plan (measured); the plans are
    1e-8 to 2e-8 longer."""
    lo, hi = lo.copy(), hi.copy()
    m = BOUND_MARGIN
    d_lo, d_hi = m * np.maximum(np.abs(lo), 1.0), m * np.maximum(np.abs(hi), 1.0)
    room = ~(np.isfinite(lo) & np.isfinite(hi)) | (hi - lo > 2 * (d_lo + d_hi))
    ok_lo = room & np.isfinite(lo) & (lo != 0.0)
    ok_hi = room & np.isfinite(hi) & (hi != 0.0)
    lo[ok_lo] += d_lo[ok_lo]
    hi[ok_hi] -= d_hi[ok_hi]
    return lo, hi


class _Instance:
    """One fatrop solver for one grid shape; new data for the same shape is copied in."""

    def __init__(self, lib, b, data, gmask, rest, exact: bool):
        self.lib, self.N = lib, b.size
        self._keep = (b, data, gmask, rest)
        self.ptr = lib.fp_create(self.N, b, rest[1].size, *data, gmask, *rest, int(exact))
        for name, value in FATROP_OPTIONS.items():
            lib.fp_set_option(self.ptr, name.encode(), float(value))

    def update(self, data, gmask, rest, exact: bool) -> bool:
        """False if the rows changed in number (a new instance is then needed)."""
        self._keep = (self._keep[0], data, gmask, rest)
        return self.lib.fp_update(self.ptr, *data, gmask, *rest, int(exact)) == 0

    def solve(self, max_iter: int, budget_s: float, nx: int, nu: int, tol: float):
        self.lib.fp_set_option(self.ptr, b"max_iter", float(max_iter))
        self.lib.fp_set_option(self.ptr, b"tol", tol)
        self.lib.fp_set_deadline(self.ptr, budget_s)
        X, U, stats = np.zeros((self.N + 1, nx)), np.zeros((self.N, nu)), np.zeros(14)
        ret = self.lib.fp_solve(self.ptr, X, U, stats)
        return ret, X, U, stats

    def __del__(self):
        if getattr(self, "ptr", None):
            self.lib.fp_free(self.ptr)
            self.ptr = None


def _instance(lib, key: str, b, data, gmask, rest, exact: bool) -> _Instance:
    pkey = (key, tuple(b.tolist()))
    inst = _POOL.get(pkey)
    if inst is not None and inst.update(data, gmask, rest, exact):
        return inst
    inst = _Instance(lib, b, data, gmask, rest, exact)
    if pkey not in _POOL and len(_POOL) >= _POOL_MAX:
        _POOL.pop(next(iter(_POOL)))
    _POOL[pkey] = inst
    return inst


# ----------------------------------------------------------------------------- solve
def _fatrop(prob: OptimalProblem, hessian: str, limits: Limits, x0: np.ndarray, drive_scale):
    """One fatrop solve: the optimiser's ``_attempt`` tuple, and a failure reason ("" if
    none).

    With ``drive_limits`` the problem is first solved without its RMS row (the variant
    ``rms=False``: no RMS integral states and elapsed time, 7 states fewer a stage on six
    joints). If the RMS row holds at that optimum (:func:`rms_row`, the row's own expression
    at the solution), the optimum is the full problem's: it is feasible for it, and optimal
    for a problem with fewer rows (its KKT point, the RMS multiplier 0). Otherwise the full
    problem is solved from there. ``info["drive_rms"]`` says which (``"inactive, checked"``,
    or ``"re-solved with the RMS row"``)."""
    var = variant(prob)
    if not (var.drive and DRIVE_RMS_LAST):
        return _solve_variant(prob, hessian, limits, x0, drive_scale, var)
    out, why = _solve_variant(prob, hessian, limits, x0, drive_scale, variant(prob, rms=False))
    if why:
        return out, why
    st, x, info, arm, _ = out
    ratio = rms_row(prob, st, x, arm[4])
    if float(np.max(ratio)) <= 1.0 - BOUND_MARGIN:  # the row's bound as its solve has it
        info["drive_rms"] = "inactive, checked"
        return out, why
    out2, why = _solve_variant(prob, hessian, limits, x, drive_scale, var, True)
    out2[2]["iterations"] += info["iterations"]
    out2[2]["solve_time_s"] += info["solve_time_s"]
    out2[2]["drive_rms"] = "re-solved with the RMS row"
    return out2, why


@functools.lru_cache(maxsize=8)
def _rms_point(n: int) -> ca.Function:
    """``(tau, qd, qdd, w, dc, sigma, eps) -> w T_m^2`` (n,) at one point: the numerator of the
    RMS row (:func:`armlab.planning.transcription._drive_rows`, the same expression)."""
    SX = ca.SX
    tau, v, a, dc = SX.sym("tau", n), SX.sym("v", n), SX.sym("a", n), SX.sym("dc", 9 * n)
    w, sig, eps = SX.sym("w"), SX.sym("sig", n), SX.sym("eps", n)
    _, num = _drive_rows([(tau, v, a)], [w], dc, sig, eps, n)
    return ca.Function("rms_point", [tau, v, a, w, dc, sig, eps], [num])


def rms_row(prob: OptimalProblem, st: Structure, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The RMS row of ``drive_limits`` at the plan ``x`` (unscaled variables), per joint:
    ``sum_k w_k T_m,k^2 / (cont^2 sum h)`` with the trapezoid weights ``w_k`` of its points
    (the nodes in jerk mode, both ends of every interval in acceleration mode) and the bound's
    back-off scale in ``cont^2`` (the parameters ``p``, :func:`~armlab.planning.optimal_bounds
    .params`); the row holds where it is <= 1. The torques are the rigid-body model's
    (:func:`armlab.robot.rigid_body.inverse_dynamics`, the same model as the rows')."""
    n, N = prob.n, prob.N
    q, v, a, u, h = prob._unpack(st, x)
    sig = prob._column_directions()
    dc, _, eps, cont2 = optimal_bounds.drive_params(p, n, sig.shape[1])
    if prob.mode == "jerk":
        Q, V, A = q, v, a
        w = np.zeros(N + 1)
        w[:-1] += h / 2
        w[1:] += h / 2
    else:  # the left and then the right end of every interval, its acceleration u
        Q, V, A = np.vstack([q[:-1], q[1:]]), np.vstack([v[:-1], v[1:]]), np.vstack([u, u])
        w = np.concatenate([h, h]) / 2
    tau = rigid_body.inverse_dynamics(prob.robot, Q, V, A)
    m = w.size
    f = _rms_point(n).map(m)
    num = np.asarray(
        f(tau.T, V.T, A.T, w[None, :], np.tile(dc[:, None], m), sig, np.tile(eps[:, None], m))
    )
    return num.sum(axis=1) / (cont2 * float(np.sum(h)))


def _resolve(prob: OptimalProblem, limits: Limits, drive_scale) -> bool:
    """Whether this solve is a back-off re-solve (tightened limits or drive scales: it starts
    from the last plan, :func:`armlab.planning.timescale.backoff_solve`)."""
    if limits is not prob.limits:
        return True
    return drive_scale is not None and any(np.any(np.asarray(z) != 1.0) for z in drive_scale)


def _solve_variant(
    prob: OptimalProblem, hessian: str, limits: Limits, x0, drive_scale, var, from_plan=False
):
    """One fatrop solve with the stage library ``var``: as :func:`_fatrop`; ``from_plan``: ``x0``
    is a converged plan (of the problem without the RMS row). The first drive-limited solve
    of a plan starts its barrier at :data:`DRIVE_MU_INIT`; one from a converged plan (that, or
    a back-off re-solve) at fatrop's default :data:`MU_INIT`."""
    lib, key = _library(prob.robot, var)
    st, spot = _layout(prob, limits.torque_Nm is not None, var)
    b, data, gmask, rest, arm, sv = _stage_data(prob, st, spot, var, limits, x0, drive_scale)
    n, N = prob.n, prob.N
    dm = var.dims(n)
    exact = hessian == "exact" or not st.torque_rows or var.one_hessian
    cap = min(prob.max_iter, FATROP_MAX_ITER if exact else PARTIAL_MAX_ITER)
    budget = watchdog_budget_s(N)
    t0 = time.perf_counter()
    with _LOCK:
        inst = _instance(lib, key, b, data, gmask, rest, exact)
        tol = FATROP_TOL_FIXED_DURATION if var.duration else FATROP_OPTIONS["tol"]
        first = var.drive and not (from_plan or _resolve(prob, limits, drive_scale))
        if first:
            lib.fp_set_option(inst.ptr, b"mu_init", DRIVE_MU_INIT)
        ret, X, U, stats = inst.solve(cap, budget, dm["nx"], dm["nu"], tol)
        if ret != 0 and var.energy and int(stats[7]) == FATROP_ACCEPTABLE:
            ret = 0  # an energy solve at fatrop's acceptable point (FATROP_ACCEPTABLE)
        if first:
            lib.fp_set_option(inst.ptr, b"mu_init", MU_INIT)
        if ret != 0 or stats[13] or not np.all(np.isfinite(X)):
            # a failed or aborted instance is not reused (its state may hold NaN)
            _POOL.pop((key, tuple(b.tolist())), None)
    wall = time.perf_counter() - t0
    iters = int(stats[0])
    why = ""
    if stats[13]:
        why = f"fatrop exceeded its {budget:.3g} s budget (watchdog) after {iters} iterations"
    elif not (np.all(np.isfinite(X)) and np.all(np.isfinite(U))):
        why = "fatrop returned NaN"
    elif ret != 0:
        capped = iters >= cap
        why = f"fatrop did not converge ({'iteration cap ' + str(cap) if capped else ret})"
    xs = np.zeros(st.nx)
    S = st.slices
    names = ("q", "v", "a") if var.jerk else ("q", "v")
    for i, name in enumerate(names):
        xs[S[name]] = X[:, i * n : (i + 1) * n].ravel()
    xs[S["u"]] = U[:, :n].ravel()
    xs[S["T"]] = X[prob.waypoint_nodes[:-1], dm["it"]]
    info = {
        "return_status": "Solve_Succeeded" if not why else why,
        "success": not why,
        "iterations": iters,
        "solve_time_s": wall,
        "build_time_s": 0.0,
        "solver": "fatrop",
        "fallback": "",
    }
    return (st, xs * sv, info, arm, None), why


def attempt(prob: OptimalProblem, hessian: str, limits: Limits, x0, drive_scale, lam, ipopt):
    """One solve of the optimiser: fatrop where it applies (module docstring), else
    ``ipopt(hessian, limits, x0, drive_scale, lam)``; ``info["solver"]`` names the one that
    gave the result and ``info["fallback"]`` why it is not fatrop ("" when it is)."""
    why = not_covered(prob, hessian)
    fatrop_time = 0.0
    if not why:
        try:
            out, why = _fatrop(prob, hessian, limits, x0, drive_scale)
        except FatropUnavailable as exc:
            why = str(exc)
        else:
            if not why:
                return out
            fatrop_time = out[2]["solve_time_s"]
    out = ipopt(hessian, limits, x0, drive_scale, lam)
    info = cast(dict, out[2])
    info["solve_time_s"] += fatrop_time
    info["solver"], info["fallback"] = "ipopt", why
    return out
