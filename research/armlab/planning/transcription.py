"""The transcription of the optimal-trajectory problem into one CasADi NLP (IPOPT).

Decision variables per interval: joint positions, velocities (and accelerations in jerk mode)
at the knots, the piecewise-constant input (acceleration or jerk) and the segment durations,
all scaled; constraints: the exact polynomial integration of each interval, the convex-hull
bounds that keep velocity, acceleration and position inside their limits between the knots,
and -- with torque limits -- the inverse dynamics of the symbolic twin
(:func:`armlab.robot.symbolic.parametric_inverse_dynamics_function`, gravity in the base frame)
at the knots. With ``drive_rows`` (``drive_limits=True``) the motor torque of the drive-train
model (:func:`armlab.robot.drivetrain.motor_torque_branches`, the CasADi twin) is bounded by
the motor's envelope at the same points (:func:`_drive_rows`), and its RMS over the plan by the
continuous rating. The compiled NLP depends only on the robot's kinematic tree, the sizes and
the flags, so it is built once and cached (:func:`structure`); the payload, limits, drive data,
directions of motion, scales and grid fractions are parameters. The problem and its solve are
in :mod:`armlab.planning.optimiser`.

Solve time (issue 15, teachbot6, 5 waypoints, 64 intervals, v/a/j/tau, cProfile and IPOPT's
timing statistics): ~85 % of a call is IPOPT, ~15 % the warm start and the fine-grid checks.
Inside IPOPT, with the exact Hessian, ~60 % were function evaluations -- the Hessian of the
Lagrangian (1.25 M SX instructions, ~18.5 k per node for the inverse dynamics, ~8 ms a call)
and the constraint Jacobian (0.72 M, ~4.5 ms) -- and ~40 % IPOPT's own linear algebra (MUMPS)
and bookkeeping. Without torque rows the evaluations are negligible and IPOPT's linear
algebra is the cost (~5 ms an iteration). ``hessian="partial"`` drops the inverse-dynamics
curvature (the torque rows and their Jacobian stay exact) for ~1 more iteration in 20. One
heavily torque-bound case stalled without that curvature, so a ``"partial"`` solve is capped at
:data:`PARTIAL_MAX_ITER` iterations and then repeated with the exact Hessian
(``optimal.OptimalProblem._solve_once``). A fine-grid back-off re-solve starts from the last
solution's multipliers (:meth:`Structure.warm_solver`): ~1/3 fewer iterations there. Tried
and not kept: MX graphs (2.3 x slower), ``mu_strategy="monotone"``, no NLP scaling,
``mu_init``, smaller ``bound_push`` (46 instead of 20 iterations), a looser ``tol`` (no fewer
iterations), 10 instead of 16 intervals per segment (see ``optimal.MIN_SEGMENT_INTERVALS``).
A Riccati solver (``fatrop``, in CasADi's wheel) needs stage-wise variables and rows and the
segment durations carried as states; on stand-alone probes of the same integration equations
(one segment, teachbot6) it was 1.6 x faster than IPOPT with v/a/j limits (64 and 304
intervals), but with the torque rows 1.0 x (64) and 1.2 x (304): there the derivative
evaluations in CasADi's virtual machine are ~75 % of its time, and it does not reduce them.

Measured later in issue 15 (teachbot6, v/a/j/tau, 20 waypoints = 304 intervals, IPOPT's timing
statistics): ~55 % IPOPT's linear algebra (the KKT factorisations inside the adaptive barrier
update), ~35 % the constraint Jacobian (``nlp_jac_g``, ~25 ms a call), the rest small. Kept:
MUMPS's approximate-minimum-fill ordering (:data:`MUMPS_PIVOT_ORDER`; 7-20 % less IPOPT time at
5-20 waypoints, same plans; not for the motor-envelope rows, :data:`MUMPS_AUTOMATIC_ORDER`).
Tried and not kept: compiling ``nlp_jac_g`` to C with the system
``gcc`` (5 waypoints: 19 MB of C, 48 s to compile at ``-O0`` and 380 s at ``-O1``, for 4.6 x
faster Jacobian calls -- ~25 % of a solve; a compile that long on first use of every problem
size is not acceptable for the demo study, even cached on disk), CasADi's common-subexpression
elimination of the Jacobian (3 % fewer instructions, 5 % faster calls), ``mu_oracle`` ``loqo``
or ``probing`` instead of the quality function (35 and 28 instead of 21 iterations, slower),
``bound_relax_factor = 0`` (no fewer tolerance stretches, one more back-off round in 6 cases).

Per iteration, at the end of issue 15 (IPOPT's ``print_timing_statistics``, teachbot6,
v/a/j/tau, the scaling cases of ``bench_trajectory.py``, every solve of a call, on the shared
machine): 5 waypoints (64 intervals) median 24 iterations a call, 16.8 ms an iteration, of which
7.7 ms (46 %) the augmented-system solves (``StdAugSystemSolverMultiSolve``: MUMPS's
factorisations and back-solves; IPOPT's own ``LinearSystemFactorization`` timer stays at 0 with
MUMPS) and 6.7 ms (40 %) function evaluations (5.6 ms the constraint Jacobian); 20 waypoints
(304 intervals) median 31 iterations, 98 ms an iteration: 55 ms (56 %) linear algebra, 33 ms
(34 %) evaluations (28 ms the Jacobian).

Per-size build (issue 26): a first call on a waypoint count built the NLP (0.4 s at 2 waypoints
to 3.7 s at 20, teachbot6 with torque rows): ~2/3 casadi's AD of the whole constraint graph for
IPOPT's Jacobian, ~1/3 ``nlp_grad`` (the gradient of the Lagrangian in ``p``, which casadi
makes for ``lam_p`` at every build and armlab does not read). Now the torque rows' Jacobian is
the inverse dynamics' own Jacobian ``d tau / d(q, qd, qdd)`` (one SX function per robot,
7.1 k instructions with casadi's common-subexpression elimination) mapped over the nodes in a
thin MX shell (:func:`_jacobian_shell`; the rows without torque, a small polynomial graph, are
differentiated by casadi as before), and ``nlp_grad`` is not made. The build at 5 waypoints
fell from 0.74 to 0.15 s CPU, at 20 from 3.7 to 0.7 s (the rest: the SX graph itself and the
``"partial"`` Hessian, 0.27 s at 20); the same nonzeros and values (tests), the same
iterations and durations on the cases compared (within 1.6e-7 s of 90 s), a repeat solve no
slower (10 waypoints: 0.85 s CPU against 0.90-0.98 s). Not yet on this path: the drive rows
(``drive_limits``), the energy objective and ``TORQUE_INTERIOR_POINTS``.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab._lazy import lazy_import
from armlab.robot.drivetrain import motor_torque_branches
from armlab.robot.symbolic import kinematics_key, parametric_inverse_dynamics_function

if TYPE_CHECKING:
    import casadi as ca  # the real module for the type checker (CasADi ships type stubs)
else:
    ca = lazy_import("casadi")  # CasADi loads at the first symbolic build

__all__ = [
    "Structure",
    "structure",
    "build_structure",
    "ipopt_options",
    "DRIVE_ROW_TAGS",
    "HESSIANS",
]

#: the envelope rows per joint and column (``_drive_rows``): ``A`` the voltage line, ``P`` the
#: peak torque; ``1`` the motoring branch, ``2`` the back-driven one; ``+`` upper, ``-`` lower
DRIVE_ROW_TAGS = ("A1+", "A2+", "A1-", "A2-", "P1+", "P2+", "P1-", "P2-")
#: coefficients per joint of the drive rows (:meth:`DriveTrain.symbolic_coefficients` order)
N_DRIVE_COEFFS = 9

#: expression graph of the NLP: "MX" (maps of the SX inverse dynamics; fast to build) or "SX"
SYMBOLIC = "SX"
#: the Hessians of the Lagrangian IPOPT can be given (:func:`build_structure`): ``"exact"``;
#: ``"partial"`` -- exact, except that the curvature of the torque-box rows (the inverse
#: dynamics over ``tau_max``) is left out (the motor-envelope and RMS rows of ``drive_limits``
#: keep theirs: without it the drive test case needed > 1000 iterations, measured);
#: ``"limited-memory"`` -- IPOPT's L-BFGS. The converged point meets
#: the same KKT conditions to the same tolerance with each; only the Newton model differs.
HESSIANS = ("exact", "partial", "limited-memory")
#: the default (issue 15, measured on teachbot6 with torque limits: the inverse-dynamics
#: Hessian was ~35 % of the solve time, dropping its curvature costs ~1 iteration in 20)
HESSIAN = "partial"
#: IPOPT options of a back-off re-solve started from the last solution and its multipliers
WARM_OPTIONS = {
    "ipopt.warm_start_init_point": "yes",
    "ipopt.warm_start_bound_push": 1e-9,
    "ipopt.warm_start_bound_frac": 1e-9,
    "ipopt.warm_start_slack_bound_push": 1e-9,
    "ipopt.warm_start_slack_bound_frac": 1e-9,
    "ipopt.warm_start_mult_bound_push": 1e-9,
    "ipopt.mu_init": 1e-6,
}
#: iteration cap of a ``"partial"`` solve (above it ``optimal`` repeats the solve with the
#: exact Hessian: a heavily torque-bound case stalled without that curvature, measured)
PARTIAL_MAX_ITER = 100
#: the rows whose curvature ``"partial"`` leaves out
_DYNAMICS_ROWS = ("torque",)
#: where, inside each interval, the torque is also constrained (fractions; none by default:
#: with the balanced grid the fine-grid back-off is cheaper than midpoint rows, measured)
TORQUE_INTERIOR_POINTS: tuple[float, ...] = ()

#: MUMPS fill-reducing ordering (ICNTL(7)): 2 = approximate minimum fill (AMF). MUMPS's
#: automatic choice (7) was 1.5-2.2 x slower on the KKT systems of 10 and 20 waypoints (issue 15,
#: teachbot6, v/a/j/tau: median IPOPT time 1.46 -> 0.97-1.05 s at 10, 4.5 -> 2.1 s at 20; same
#: iterations and durations), the same at 5. METIS (5) was as fast as AMF, PORD (4) 1.2 x
#: slower, QAMD (6) 1.5 x, SCOTCH (3) 2.2 x.
MUMPS_PIVOT_ORDER = 2
#: MUMPS's automatic ordering, kept for the motor-envelope rows (``drive_limits``): with AMF
#: IPOPT ran out of iterations on the demo cycle's drive-limited plan (24 intervals a segment)
#: and the retry on twice the intervals took 364 s, against 38-40 s with this (measured; METIS
#: and AMD also converge there, but are no faster than this on the torque-box plans)
MUMPS_AUTOMATIC_ORDER = 7

_STRUCTURES: dict[tuple, Structure] = {}
_STRUCTURES_MAX = 32


# ----------------------------------------------------------------------------- structure
@dataclass
class Structure:
    """One compiled NLP: depends only on the robot dynamics, sizes and flags (cached)."""

    solver: ca.Function
    g_fun: ca.Function
    n: int
    seg_n: tuple[int, ...]
    mode: str
    torque_rows: bool
    g_kind: np.ndarray
    g_joint: np.ndarray
    n_pi: int
    nx: int
    slices: dict[str, slice]
    build_time_s: float
    drive_rows: bool = False
    g_tag: np.ndarray | None = None  # DRIVE_ROW_TAGS of the motor_envelope rows ("" elsewhere)
    g_col: np.ndarray | None = None  # their column (drive_columns order)
    n_drive_columns: int = 0
    nlp: dict | None = None  # the symbolic NLP and the solver options (for warm_solver)
    options: dict | None = None
    _warm: ca.Function | None = None

    @property
    def N(self) -> int:
        return int(sum(self.seg_n))

    def warm_solver(self) -> ca.Function:
        """The same NLP with IPOPT started from given multipliers (``warm_start_init_point``),
        for the re-solves of the fine-grid back-off; built at the first use, reusing the
        derivative functions of :attr:`solver`."""
        if self._warm is None:
            assert self.nlp is not None and self.options is not None
            opts = {**self.options, **WARM_OPTIONS}
            opts["jac_g"] = self.solver.get_function("nlp_jac_g")
            if opts.get("ipopt.hessian_approximation") == "exact":
                opts["hess_lag"] = self.solver.get_function("nlp_hess_l")
            self._warm = ca.nlpsol("armlab_optimal_warm", "ipopt", self.nlp, opts)
        return self._warm


def ipopt_options(max_iter: int, hessian: str = HESSIAN, drive_rows: bool = False) -> dict:
    return {
        "print_time": False,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.max_iter": max_iter,
        "ipopt.tol": 1e-9,
        "ipopt.constr_viol_tol": 1e-9,
        # L-BFGS stalls in the dual residual once the objective no longer moves: accept then
        # (primal feasibility, what the limits need, stays at 1e-9)
        "ipopt.acceptable_tol": 1e-4,
        "ipopt.acceptable_constr_viol_tol": 1e-9,
        "ipopt.acceptable_obj_change_tol": 1e-9,
        "ipopt.acceptable_iter": 5,
        "ipopt.mu_strategy": "adaptive",
        "ipopt.linear_solver": "mumps",
        "ipopt.mumps_pivot_order": MUMPS_AUTOMATIC_ORDER if drive_rows else MUMPS_PIVOT_ORDER,
        # "partial" hands IPOPT its own exact-Hessian function (hess_lag, build_structure)
        "ipopt.hessian_approximation": "limited-memory" if hessian == "limited-memory" else "exact",
    }


def build_structure(
    rnea_p,
    n_pi: int,
    n: int,
    seg_n: tuple[int, ...],
    mode: str,
    objective: str,
    torque_rows: bool,
    fixed_duration: bool,
    max_iter: int,
    drive_rows: bool = False,
    hessian: str = HESSIAN,
) -> Structure:
    t0 = _time.perf_counter()
    # SX or MX, chosen by a module constant; both share the symbolic API, and typing it as the
    # union makes mypy reject every mixed SX/MX operation it cannot rule out
    X: Any = ca.MX if SYMBOLIC == "MX" else ca.SX
    N = int(sum(seg_n))
    # decision variables are scaled: physical = scaled * scale (scales are parameters)
    Q = X.sym("q", n, N + 1)
    Vs = X.sym("v", n, N + 1)
    As = X.sym("a", n, N + 1) if mode == "jerk" else None
    Us = X.sym("u", n, N)
    nseg = len(seg_n)
    Ts = X.sym("T", nseg)  # segment durations / their warm-start values
    blocks = (
        [("q", Q), ("v", Vs)] + ([("a", As)] if As is not None else []) + [("u", Us), ("T", Ts)]
    )
    slices, start = {}, 0
    for name, m in blocks:
        slices[name] = slice(start, start + m.numel())
        start += m.numel()
    x = ca.vertcat(*[ca.vec(m) for _, m in blocks])
    p_tau = X.sym("tau_scale", n)
    p_w = X.sym("w_smooth")
    p_uref = X.sym("u_ref", n)
    p_ew = X.sym("energy_w", n)
    s_v = X.sym("s_v", n)
    s_a = X.sym("s_a", n)
    s_u = X.sym("s_u", n)
    s_T = X.sym("s_T", nseg)
    frac = X.sym("fractions", N)  # h_k = T_seg(k) * fraction_k
    p_pi = X.sym("inertial_parameters", n_pi)  # payload is a parameter, not structure
    n_cols = (N + 1 if mode == "jerk" else 2 * N) if drive_rows else 0
    p_dc = X.sym("drive_coefficients", n * N_DRIVE_COEFFS if drive_rows else 0)
    p_sig = X.sym("direction", n, n_cols)  # sign of qd per joint and column (0: at rest)
    p_eps = X.sym("quadrant_smoothing_Nm", n if drive_rows else 0)
    p_cont2 = X.sym("continuous_torque_sq", n if drive_rows else 0)
    p = ca.vertcat(
        p_tau, p_w, p_uref, p_ew, s_v, s_a, s_u, s_T, frac, p_pi, p_dc, ca.vec(p_sig), p_eps,
        p_cont2,
    )  # fmt: skip

    def rnea(qq, vv, aa):
        m = qq.shape[1]
        return rnea_p.map(m)(qq, vv, aa, ca.repmat(p_pi, 1, m))

    V = Vs * ca.repmat(s_v, 1, N + 1)
    U = Us * ca.repmat(s_u, 1, N)
    A = As * ca.repmat(s_a, 1, N + 1) if mode == "jerk" else None
    T = Ts * s_T
    seg_of = np.repeat(np.arange(nseg), seg_n)
    select = np.zeros((N, nseg))
    select[np.arange(N), seg_of] = 1.0
    H = ca.mtimes(ca.DM(select), T) * frac
    rv, ra = ca.repmat(s_v, 1, N), ca.repmat(s_a, 1, N)

    Hr = ca.repmat(H.T, n, 1)
    Qa, Qb, Va, Vb = Q[:, :N], Q[:, 1:], V[:, :N], V[:, 1:]
    rows: list[tuple] = []  # (expr, kind, per-joint[, tag, first column])
    if A is not None:  # jerk mode
        Aa, Ab = A[:, :N], A[:, 1:]
        rows.append((Qb - (Qa + Hr * Va + Hr**2 / 2 * Aa + Hr**3 / 6 * U), "dynamics", True))
        rows.append(((Vb - (Va + Hr * Aa + Hr**2 / 2 * U)) / rv, "dynamics", True))
        rows.append(((Ab - (Aa + Hr * U)) / ra, "dynamics", True))
        rows.append(((Va + Aa * Hr / 2) / rv, "velocity", True))
        rows.append((Qa + Va * Hr / 3, "position", True))
        rows.append((Qb - Vb * Hr / 3, "position", True))
    else:
        rows.append((Qb - (Qa + Hr * Va + Hr**2 / 2 * U), "dynamics", True))
        rows.append(((Vb - (Va + Hr * U)) / rv, "dynamics", True))
        rows.append((Qa + Va * Hr / 2, "position", True))
    need_tau = torque_rows or objective == "energy" or drive_rows
    tau_nodes: list[Any] = []
    torque_at = len(rows)  # the torque rows start here (rows[torque_at:torque_end])
    if need_tau:
        if mode == "jerk":
            tau_nodes = [rnea(Q, V, A)]
        else:
            tau_nodes = [rnea(Qa, Va, U), rnea(Qb, Vb, U)]
        if torque_rows:
            inner = []
            for th in TORQUE_INTERIOR_POINTS:  # exact states at a fraction th of each interval
                d = Hr * th
                if mode == "jerk":
                    qi = Qa + d * Va + d**2 / 2 * Aa + d**3 / 6 * U
                    vi = Va + d * Aa + d**2 / 2 * U
                    ai = Aa + d * U
                else:
                    qi = Qa + d * Va + d**2 / 2 * U
                    vi = Va + d * U
                    ai = U
                inner.append(rnea(qi, vi, ai))
            for tn in tau_nodes + inner:
                rows.append((tn / ca.repmat(p_tau, 1, tn.shape[1]), "torque", True))
    torque_end = len(rows)
    scalar_rows: list[tuple] = []
    if drive_rows:
        if mode == "jerk":
            cols = [(tau_nodes[0], V, A)]
            weights = [ca.horzcat(H[0] / 2, (H[:-1] + H[1:]).T / 2, H[-1] / 2)]
        else:
            cols = [(tau_nodes[0], Va, U), (tau_nodes[1], Vb, U)]
            weights = [H.T / 2, H.T / 2]
        drive, rms = _drive_rows(cols, weights, p_dc, p_sig, p_eps, n)
        rows += drive
        rows.append((rms / (ca.sum1(T) * p_cont2), "motor_rms", True))
    if fixed_duration:
        scalar_rows.append((ca.sum1(T), "duration"))
    g_parts, kinds, joints, tags, gcols = [], [], [], [], []
    for row in rows:
        expr, kind = row[0], row[1]
        tag, first = (row[3], row[4]) if len(row) > 3 else ("", 0)
        g_parts.append(ca.vec(expr))
        kinds += [kind] * expr.numel()
        joints += list(np.tile(np.arange(n), expr.shape[1]))
        tags += [tag] * expr.numel()
        gcols += list(first + np.repeat(np.arange(expr.shape[1]), n))
    for expr, kind in scalar_rows:
        g_parts.append(expr)
        kinds.append(kind)
        joints.append(-1)
        tags.append("")
        gcols.append(-1)
    g = ca.vertcat(*g_parts)

    Un = U / ca.repmat(p_uref, 1, N)
    smooth = ca.dot(ca.sum1(Un**2).T, H)
    if objective in ("time", "time+smooth"):
        f = ca.sum1(T) + p_w * smooth
    elif objective == "jerk":
        f = smooth
    else:  # energy
        ew = [ca.sum1(ca.repmat(p_ew, 1, tn.shape[1]) * tn**2) for tn in tau_nodes]
        if mode == "jerk":
            e = ew[0]
            f = ca.dot(((e[:, :N] + e[:, 1:]) / 2).T, H)
        else:
            f = ca.dot(((ew[0] + ew[1]) / 2).T, H)
    nlp = {"x": x, "p": p, "f": f, "g": g}
    opts = ipopt_options(max_iter, hessian, drive_rows)
    g_fun = ca.Function("g", [x, p], [g])
    if (
        torque_rows
        and not drive_rows
        and objective != "energy"
        and not TORQUE_INTERIOR_POINTS
        and X is ca.SX
    ):
        # the constraint Jacobian from the inverse dynamics' own Jacobian at each node (one
        # small function per robot, mapped over the nodes in a thin MX shell) instead of
        # casadi's AD over the whole graph: the per-size build falls from seconds to a
        # fraction (issue 26); the same nonzeros and values
        parts = [ca.vec(r[0]) for r in rows]
        before = ca.vertcat(*parts[:torque_at])
        after = ca.vertcat(*parts[torque_end:], *[e for e, _ in scalar_rows])
        rest = ca.Function("jac_rest", [x, p], [ca.jacobian(before, x), ca.jacobian(after, x)])
        sizes = [int(e.numel()) for e in (p_tau, p_w, p_uref, p_ew, s_v, s_a, s_u, s_T, frac)]
        names = ("tau", "w", "uref", "ew", "sv", "sa", "su", "sT", "frac", "pi")
        offsets = dict(zip(names, np.concatenate([[0], np.cumsum(sizes)]).tolist(), strict=True))
        opts["jac_g"] = _jacobian_shell(
            rnea_p, g_fun, rest, int(x.numel()), int(p.numel()), n, N, n_pi, mode, slices, offsets
        )
    # the gradient of the Lagrangian in p (casadi's lam_p, unused here) costs an AD pass over
    # the whole graph at every build: not made
    opts["no_nlp_grad"], opts["calc_lam_p"] = True, False
    if hessian == "partial":
        opts["hess_lag"] = _partial_hessian(x, p, f, g, np.array(kinds), X)
    solver = ca.nlpsol("armlab_optimal", "ipopt", nlp, opts)
    return Structure(
        solver=solver,
        g_fun=g_fun,
        n=n,
        seg_n=seg_n,
        mode=mode,
        torque_rows=torque_rows,
        g_kind=np.array(kinds),
        g_joint=np.array(joints),
        n_pi=n_pi,
        nx=int(x.numel()),
        slices=slices,
        build_time_s=_time.perf_counter() - t0,
        drive_rows=drive_rows,
        g_tag=np.array(tags),
        g_col=np.array(gcols),
        n_drive_columns=n_cols,
        nlp=nlp,
        options=opts,
    )


def _jacobian_shell(rnea_p, g_fun, rest, nx, n_p, n, N, n_pi, mode, slices, offsets):
    """IPOPT's ``jac_g`` (``(x, p) -> (g, dg/dx)``) as a thin MX function: the rows without
    torque differentiated by casadi (``rest``: a small polynomial graph), the torque rows from
    :func:`_torque_jacobian` (the inverse dynamics' Jacobian mapped over the nodes)."""
    xm, pm = ca.MX.sym("x", nx), ca.MX.sym("p", n_p)

    def par(name, size):
        return pm[offsets[name] : offsets[name] + size]

    def var(name, cols):
        return ca.reshape(xm[slices[name]], n, cols)

    s_v, s_a, s_u = par("sv", n), par("sa", n), par("su", n)
    p_tau, p_pi = par("tau", n), par("pi", n_pi)
    Q = var("q", N + 1)
    V = var("v", N + 1) * ca.repmat(s_v, 1, N + 1)
    starts = slices["q"].start, slices["v"].start
    if mode == "jerk":
        A = var("a", N + 1) * ca.repmat(s_a, 1, N + 1)
        args = [(Q, V, A, s_a, (*starts, slices["a"].start, 0, 0))]
    else:
        U = var("u", N) * ca.repmat(s_u, 1, N)
        cols_u = slices["u"].start
        args = [
            (Q[:, :N], V[:, :N], U, s_u, (*starts, cols_u, 0, 0)),
            (Q[:, 1:], V[:, 1:], U, s_u, (*starts, cols_u, 1, 0)),
        ]
    tau_jac = [
        _torque_jacobian(rnea_p, qq, vv, aa, p_pi, p_tau, s_v, sa, cols, nx)
        for qq, vv, aa, sa, cols in args
    ]
    jb, ja = rest(xm, pm)
    jac = ca.vertcat(jb, *tau_jac, ja)
    return ca.Function("armlab_jac_g", [xm, pm], [g_fun(xm, pm), jac])


def _torque_jacobian(rnea_p, qq, vv, aa, p_pi, p_tau, s_v, s_a, cols, nx: int):
    """The Jacobian of the torque rows ``rnea(q_k, v_k, a_k; pi) / tau_scale`` (``m`` nodes,
    node-major rows) in the scaled variables ``x``: the inverse dynamics' Jacobian
    ``d tau / d(q, qd, qdd)`` (:func:`_rnea_jacobian`, one function per robot) mapped over the
    nodes, times the variables' scales, over ``tau_scale`` -- the same nonzeros casadi's AD of
    the whole graph finds. ``cols = (q0, v0, a0, shift, shift_a)``: where the q, v and a (or u)
    blocks start in ``x``; node ``k``'s q and v are column ``k + shift`` of theirs, its a (or u)
    column ``k + shift_a`` (column-major)."""
    n, m = qq.shape
    q0, v0, a0, shift, shift_a = cols
    block = _rnea_jacobian(rnea_p).map(m)(qq, vv, aa, ca.repmat(p_pi, 1, m))
    r, c = (np.asarray(z, int) for z in block.sparsity().get_triplet())
    k, kind, j = c // (3 * n), c % (3 * n) // n, c % n  # node, q/v/a, joint of the variable
    scale = ca.vertcat(ca.DM.ones(n), s_v, s_a)  # d(physical)/d(scaled) of q, v, a
    pick = [ca.vec(x) for x in (block.nz[:], scale[(kind * n + j).tolist()], p_tau[r.tolist()])]
    vals = pick[0] * pick[1] / pick[2]
    start = np.array([q0, v0, a0])[kind]
    sh = np.where(kind == 2, shift_a, shift)
    r, c = k * n + r, start + (k + sh) * n + j
    order = np.lexsort((r, c))  # casadi's column-major nonzero order
    sp = ca.Sparsity.triplet(n * m, nx, r[order].tolist(), c[order].tolist())
    return ca.MX(sp, ca.vec(vals[order.tolist()]))


_RNEA_JACOBIANS: dict[int, tuple[Any, ca.Function]] = {}


def _rnea_jacobian(rnea_p) -> ca.Function:
    """``(q, qd, qdd, pi) -> d tau / d(q, qd, qdd)`` (n, 3 n) of the parametric inverse
    dynamics (SX, sparse; casadi's common-subexpression elimination), made once per
    function."""
    hit = _RNEA_JACOBIANS.get(id(rnea_p))
    if hit is not None and hit[0] is rnea_p:
        return hit[1]
    n = rnea_p.size1_in(0)
    q, v, a = (ca.SX.sym(s, n) for s in ("q", "v", "a"))
    pi = ca.SX.sym("pi", rnea_p.size1_in(3))
    jac = ca.jacobian(rnea_p(q, v, a, pi), ca.vertcat(q, v, a))  # one pass: shared terms
    fun = ca.Function("rnea_jacobian", [q, v, a, pi], [jac], {"cse": True})
    _RNEA_JACOBIANS[id(rnea_p)] = (rnea_p, fun)
    return fun


def _partial_hessian(x, p, f, g, kinds: np.ndarray, X) -> ca.Function:
    """IPOPT's ``hess_lag``: the upper triangle of the Hessian of ``lam_f f + lam_g' g`` with
    the torque-box rows (:data:`_DYNAMICS_ROWS`) left out. Those rows
    and their Jacobian stay exact; only their curvature is missing from the Newton model
    (a Gauss-Newton-like step for them), so the converged point is a KKT point of the same
    problem to the same tolerance."""
    lam_f = X.sym("lam_f")
    lam_g = X.sym("lam_g", g.numel())
    keep = np.flatnonzero(~np.isin(kinds, _DYNAMICS_ROWS)).tolist()
    lag = lam_f * f + ca.dot(lam_g[keep], g[keep])
    hess = ca.triu(ca.hessian(lag, x)[0])
    return ca.Function("armlab_partial_hessian", [x, p, lam_f, lam_g], [hess])


def _drive_rows(cols, weights, p_dc, p_sig, p_eps, n: int) -> tuple[list[tuple], Any]:
    """The motor-envelope rows and the RMS numerator of ``drive_limits``.

    ``cols``: ``(tau, qd, qdd)`` matrices (n, m) at the constrained points; ``weights``: the time
    each column stands for (1, m), trapezoidal. Per joint and column, with the direction of
    motion ``sigma`` (a parameter; the velocity bounds keep it true), the two quadrant branches
    of the motor torque (:func:`~armlab.robot.drivetrain.motor_torque_branches`) with the
    Coulomb friction along ``sigma`` -- both directions where ``sigma = 0`` (upper rows +1,
    lower rows -1: conservative) -- and ``k_w = derating Kt Ke / R x N sigma qd`` (= the
    derated back-EMF term, ``|w_m|`` by the sign bounds) give the rows of
    :data:`DRIVE_ROW_TAGS`: ``e + k_w <= derating Kt U / R``, ``e - k_w >= -...``, ``|e| <=
    derating T_peak``; :func:`~armlab.planning.optimal_bounds.bounds` switches each
    on by ``sigma`` (module :mod:`armlab.robot.drivetrain`: max of the branches moving forward,
    min backwards). The RMS numerator ``sum_k w_k T_k^2`` uses the smooth quadrant blend
    ``T_in = tau_out / N (eta_b + (1/eta - eta_b) p)``, ``p = 1 - sigma^2 (1 - logistic(sigma
    tau_out / eps))``; the fine-grid check afterwards is exact.
    """
    dc = [p_dc[i * n : (i + 1) * n] for i in range(N_DRIVE_COEFFS)]
    rows: list[tuple] = []
    rms = 0
    first = 0
    for (tn, vv, aa), w in zip(cols, weights, strict=True):
        m = tn.shape[1]
        coeffs = [ca.repmat(c, 1, m) for c in dc]
        sig = p_sig[:, first : first + m]
        c_up = sig + (1 - sig**2)  # sigma where moving, +1 at rest
        c_lo = sig - (1 - sig**2)  # sigma where moving, -1 at rest
        e1u, e2u = motor_torque_branches(tn, vv, aa, c_up, coeffs)
        e1l, e2l = motor_torque_branches(tn, vv, aa, c_lo, coeffs)
        kw = coeffs[8] * coeffs[0] * sig * vv
        exprs = (e1u + kw, e2u + kw, e1l - kw, e2l - kw, e1u, e2u, e1l, e2l)
        for expr, tag in zip(exprs, DRIVE_ROW_TAGS, strict=True):
            rows.append((expr, "motor_envelope", True, tag, first))
        N_, eta, eta_b, J, b_m, f_c, f_v = coeffs[:7]
        tau_out = tn + f_c * sig + f_v * vv
        eps = ca.repmat(p_eps, 1, m)
        p = 1 - sig**2 * (0.5 - 0.5 * ca.tanh(sig * tau_out / (2 * eps)))  # logistic, no overflow
        t_m = tau_out / N_ * (eta_b + (1 / eta - eta_b) * p) + J * N_ * aa + b_m * N_ * vv
        rms = rms + ca.mtimes(t_m**2, w.T)
        first += m
    return rows, rms


def structure(
    robot,
    n,
    seg_n,
    mode,
    objective,
    torque_rows,
    fixed_duration,
    max_iter,
    drive_rows=False,
    hessian: str = HESSIAN,
) -> Structure:
    need_tau = torque_rows or objective == "energy" or drive_rows
    kkey = kinematics_key(robot) if need_tau else None
    if hessian == "partial" and not torque_rows:
        hessian = "exact"  # the same Hessian: share the compiled problem, no iteration cap
    if hessian == "partial":
        max_iter = min(max_iter, PARTIAL_MAX_ITER)
    # the problem is fixed by these (and the robot's kinematics and the module's settings)
    args = (n, seg_n, mode, objective, torque_rows, fixed_duration, max_iter, drive_rows, hessian)
    key = (kkey, *args, TORQUE_INTERIOR_POINTS, SYMBOLIC, MUMPS_PIVOT_ORDER)
    st = _STRUCTURES.get(key)
    if st is None:
        rnea_p = parametric_inverse_dynamics_function(robot) if need_tau else None
        n_pi = rnea_p.size1_in(3) if rnea_p is not None else 0
        st = build_structure(rnea_p, n_pi, *args)
        if len(_STRUCTURES) >= _STRUCTURES_MAX:
            _STRUCTURES.pop(next(iter(_STRUCTURES)))
        _STRUCTURES[key] = st
    return st
