r"""Time-optimal path parameterisation by reachability analysis: cost linear in the grid.

The same problem as :mod:`armlab.planning.topp` -- the fastest rest-to-rest ``s(t)`` along a
fixed joint path ``q(s)`` under velocity, acceleration and torque limits -- solved by the
reachability-analysis algorithm of TOPP-RA (Pham & Pham, "A New Approach to Time-Optimal Path
Parameterization Based on Reachability Analysis", IEEE T-RO 34(3) 2018: controllable sets,
greedy forward pass) instead of an interior-point method: two sweeps over the grid, each step
a two-variable linear program solved in closed form.

Discretisation (the grid and coefficients of :class:`~armlab.planning.topp.ToppProblem`)
-------------------------------------------------------------------------------------------
On the grid ``s_0 .. s_K`` of :func:`~armlab.planning.topp.path_grid`, ``x = sd^2`` at the
nodes and ``u = sdd`` constant on each interval, so ``x(s) = x_k + 2 (s - s_k) u_k`` and
``x_{k+1} = x_k + 2 ds_k u_k`` (the convex pass's ``b`` and ``a``). Every limit is a row of
the canonical form

.. math::
    \mathrm{lo} \le a\,u_k + b\,x_k \le \mathrm{hi}

The joint acceleration ``q' u + q'' x`` and the torque ``m u + c x + g`` (``m, c, g`` from
:func:`~armlab.planning.topp.path_dynamics`: Pinocchio RNEA, exact for the rigid body) are
imposed at :data:`LIMIT_FRACTIONS` of each interval (ends, quarters, middle) and at the
spline knot inside it, if any (``q''`` has a kink there); the joint velocity ``q'^2 x`` at the
nodes and at :data:`VELOCITY_FRACTIONS` (eighths). A row at ``s_k + f ds_k`` reads
``(alpha + 2 f ds_k beta) u_k + beta x_k`` with ``alpha, beta`` its coefficients there; the
velocity rows of one point (one per joint) are parallel lines in ``(x_k, u_k)`` and only the
lowest is kept (:func:`canonical_rows`: 79 lines per interval instead of 114 on a 6-joint arm,
the sets and plans unchanged to the last bit on the benchmark's 24 paths). These
are denser than the convex pass's points (ends and middle; quarters for the velocity): with
those, a peak between the points exceeded a limit (by up to 0.5 %) in half of 20 benchmark
paths and cost a back-off round (a second Trajectory and limit check) each; with these, in
three of the 20 (the one examined: a peak of the Trajectory's interpolation between its
samples, not of ``q(s(t))``; the Trajectory now has a sample where the path crosses a spline
knot, which removed the two rounds left on the 24 benchmark paths:
:meth:`~armlab.planning.topp.ToppProblem.trajectory_from_b`).

The two sweeps
--------------
Per interval the rows bound ``u`` from below by lines ``p_j + q_j x`` and from above by lines
``r_i + w_i x`` (rows with ``a = 0`` bound ``x`` alone). The *static* set of ``x_k`` is where
``F(x) = max_j (p_j + q_j x) - min_i (r_i + w_i x) <= 0``: ``F`` is convex and piecewise
linear, so its ends are found by Newton steps from outside, exact after finitely many steps
(vectorised over all intervals at once). The backward sweep (Pham & Pham: controllable sets) builds
the controllable sets ``K_k = [lo_k, hi_k]``: the ``x_k`` from which some admissible ``u_k``
reaches ``K_{k+1}`` (``K_K = {0}``, rest at the end). Adding the two lines
``(lo_{k+1} - x) / (2 ds_k) <= u <= (hi_{k+1} - x) / (2 ds_k)`` to the static rows, every
pair (lower line, upper line) involving one of them is one linear inequality in ``x``: a
bound ``e K - f`` with ``e, f`` precomputed for all intervals at once. Of these lines only
those that can be the binding one over the range of ``K`` are kept (dominance at the two ends
of the range: exact; on a teachbot6 path 2 of 114 rows per interval on average in this sweep,
8 in the forward one), so each sequential step is a few scalar operations. The forward sweep
(their greedy pass) starts at ``x_0 = 0`` and takes the largest admissible ``u_k`` that
keeps ``x_{k+1}`` in ``K_{k+1}``: a minimum over the (pruned) upper lines. Both sweeps cost
``O(K n)``; the two-variable LP of each step is never handed to a general LP solver (the
tests compare the sets with scipy's HiGHS).

Optimality: the greedy pass maximises each ``x_{k+1}`` given ``x_k``. That is the optimum of
the grid problem when the largest reachable ``x_{k+1} = x_k + 2 ds_k max u(x_k)`` grows with
``x_k``. A velocity row inside an interval bounds ``(1 - f) x_k + f x_{k+1}`` (a sum: ``u``'s
line has slope ``-1 / (2 f ds_k)``), so there a slower ``x_k`` allows a faster ``x_{k+1}``;
where ``q'(s)^2`` curves along a velocity-limited stretch the greedy plan zig-zags below the
optimum. Measured against IPOPT on the same rows (12 benchmark paths, ``n_grid`` 100): 0.01 %
slower in the median, 0.31 % at most (teachbot6, velocity-bound); UR5 cases (acceleration-
bound) within 0.005 %. Neither a time-reversed greedy pass nor the mean of both closes the
gap (measured on six of those paths). Any row whose upper line falls faster than
``-1 / (2 ds_k)`` in ``x_k`` (an acceleration or torque row) breaks the condition too: on rows
at the grid points only (no velocity rows inside the intervals; the benchmark's "TOPP-RA's
rows", 24 paths) the optimum is up to 0.09 % (teachbot6) and 0.39 % (UR5) shorter than the
greedy plan (median 0 and 0.04 %), and on one path TOPP-RA's own plan, which meets those
rows, is 0.05 % shorter (its controllable sets are smaller than these exact ones, and its
greedy pass stays lower).

Where it is used, and jerk
--------------------------
:func:`solve_reachability` has the signature of :meth:`ToppProblem.solve_convex`: it is the
first pass of :func:`~armlab.planning.topp.time_optimal_path` with ``method="reachability"``
(the default), inside that planner's one back-off loop (:meth:`ToppProblem.solve`: the
Trajectory, limits tightened by ``LIMIT_MARGIN``, local back-off of the intervals over a
limit, the tolerance stretch, the final limit check). The algorithm has no jerk limit
(``x, u`` cannot express ``sddd``) and no motor-envelope rows: with a jerk limit the planner's
IPOPT jerk pass runs after it, warm-started from its result; with ``drive_limits`` the planner
uses its convex envelope pass instead.
"""

from __future__ import annotations

import functools
import time as _time
from dataclasses import dataclass

import numpy as np

from armlab.errors import InfeasibleError
from armlab.planning.topp_problem import ToppProblem
from armlab.robot.limits import Limits

__all__ = [
    "solve_reachability",
    "CanonicalRows",
    "canonical_rows",
    "controllable_sets",
    "greedy_forward",
    "interval_coefficients",
    "static_sets",
]

#: ``F(x) <= FEAS_TOL * (1 + |terms|)`` counts as feasible in the static sets and sweeps
FEAS_TOL = 1e-12
#: Newton steps allowed per end of a static set (a convex piecewise-linear function: exact
#: after at most as many steps as it has pieces; a handful in practice)
MAX_NEWTON = 60
#: where, inside each interval, the acceleration and torque rows are imposed (fractions of it)
LIMIT_FRACTIONS = (0.0, 0.25, 0.5, 0.75, 1.0)
#: where the velocity rows are imposed (besides the nodes, which bound ``x`` directly)
VELOCITY_FRACTIONS = (0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875)
#: start of the Newton search for an unbounded static set (x = sd^2 in [1/s^2])
X_BIG = 1e12


# ----------------------------------------------------------------------------- rows
@dataclass
class CanonicalRows:
    r"""The limits of a TOPP grid as lines bounding ``u = sdd`` per interval.

    Attributes
    ----------
    ds : array (K,)
        Interval lengths in ``s``.
    lower_p, lower_q : array (K, R)
        ``u >= lower_p + lower_q x`` (``-inf`` where a row has no lower bound on ``u``).
    upper_p, upper_q : array (K, R)
        ``u <= upper_p + upper_q x`` (``+inf`` where none).
    x_lo, x_hi : array (K + 1,)
        Bounds on ``x`` at the nodes from the rows without ``u`` and the node velocity limits
        (``x_hi[K] = 0``: rest at the end; ``x_lo[0] = 0`` is required of the start).
    labels : list of str
        What row ``r`` is (``"acceleration joint3 at 0.5"``), for error messages.
    """

    ds: np.ndarray
    lower_p: np.ndarray
    lower_q: np.ndarray
    upper_p: np.ndarray
    upper_q: np.ndarray
    x_lo: np.ndarray
    x_hi: np.ndarray
    labels: list[str]


def interval_coefficients(prob: ToppProblem) -> dict:
    """The path coefficients at the points of each interval where the rows are imposed:
    ``{"limit": {f: C}, "velocity": {f: q'}}`` for ``f`` in :data:`LIMIT_FRACTIONS` and
    :data:`VELOCITY_FRACTIONS`; ``C`` holds ``d1, d2`` (``q', q''``) and ``m, c, g``
    (:func:`~armlab.planning.topp.path_dynamics`), each (K, n_joints). The nodes and
    midpoints are ``prob.coeffs``'; the other points are computed once and kept in
    ``prob.coeffs["reachability"]`` -- in the same batch as the nodes and midpoints
    (:meth:`~armlab.planning.topp.ToppProblem.compute_coefficients`: one path evaluation, one
    RNEA call) when ``prob.coeffs`` is still empty."""
    cached = prob.coeffs.get("reachability")
    if cached is not None:
        return cached
    s, ds = prob.s, np.diff(prob.s)
    K = ds.size
    keys = ("d1", "d2", "m", "c", "g")
    other = [f for f in LIMIT_FRACTIONS if f not in (0.0, 0.5, 1.0)]  # not nodes nor middles
    # the spline's interior knots: q'' has a kink there (its third derivative steps), where
    # the acceleration and torque can peak between the fractions above; one more row in each
    # interval holding a knot (the first, if several)
    k_of, knots = prob.knots_in_intervals()
    frac = np.full(K, np.nan)
    frac[k_of] = (knots - s[k_of]) / ds[k_of]
    pts = np.concatenate([(s[:-1, None] + ds[:, None] * np.array(other)).T.reshape(-1), knots])
    vel_pts = (s[:-1, None] + ds[:, None] * np.array(VELOCITY_FRACTIONS)).T.reshape(-1)
    ex: dict[str, np.ndarray] | None
    ex_d1: np.ndarray | None
    if prob.coeffs:  # nodes and midpoints computed before: the rest now
        ex, ex_d1 = prob.path_values(pts), prob.path.tangent(vel_pts)
    else:  # everything in one batch
        ex, ex_d1 = prob.compute_coefficients(extra=pts, extra_d1=vel_pts)
    assert ex is not None and ex_d1 is not None
    Cn, Cm = prob.coeffs["node"], prob.coeffs["mid"]
    n = Cn["d1"].shape[1]
    limit: dict[float, dict[str, np.ndarray]] = {
        0.0: {k: Cn[k][:-1] for k in keys},
        0.5: {k: Cm[k] for k in keys},
        1.0: {k: Cn[k][1:] for k in keys},
    }
    for i, f in enumerate(other):
        sl = slice(i * K, (i + 1) * K)
        limit[f] = {k: ex[k][sl] for k in keys}
    knot_c = {k: np.zeros((K, n)) for k in keys}
    at_knots = slice(len(other) * K, None)
    for k in keys:
        knot_c[k][k_of] = ex[k][at_knots]
    d1v = ex_d1.reshape(len(VELOCITY_FRACTIONS), K, n)
    out = {
        "limit": {f: limit[f] for f in LIMIT_FRACTIONS},
        "velocity": dict(zip(VELOCITY_FRACTIONS, d1v, strict=True)),
        "knot": {"frac": frac, "C": knot_c},
    }
    prob.coeffs["reachability"] = out
    return out


@functools.cache
def _labels(names: tuple[str, ...], blocks: tuple[tuple[str, str], ...]) -> tuple[str, ...]:
    """What each row is, for error messages: ``blocks`` (kind, where) of n rows each."""
    return tuple(f"{kind} limit of {j} at {where}" for kind, where in blocks for j in names)


def _row_blocks(prob: ToppProblem, kinds: tuple[bool, bool, bool]) -> dict:
    """The parts of the rows that do not depend on the limit values or scales, for the active
    kinds (velocity, acceleration, torque): ``a, b`` (K, R) of the canonical form, the rows
    without ``u``, the line slopes, the rows absent from an interval (knot rows), the
    gravity terms of the torque rows, the labels; kept in ``prob.coeffs["reachability"]``."""
    coeffs = interval_coefficients(prob)
    cache = coeffs.setdefault("blocks", {})
    if kinds in cache:
        return cache[kinds]
    vel_on, acc_on, tau_on = kinds
    ds = np.diff(prob.s)
    K, n = ds.size, prob.coeffs["node"]["d1"].shape[1]
    # the blocks (n rows each, one per joint): a row at s_k + frac ds_k reads
    # alpha u + beta (x_k + 2 frac ds_k u); frac a number or (K, 1) (the knot rows; NaN: no
    # row in that interval)
    alphas: list[np.ndarray | None] = []  # None: 0 (velocity)
    betas: list[np.ndarray] = []
    fracs: list[float | np.ndarray] = []
    G: list[np.ndarray] = []  # gravity of each torque block
    order: list[str] = []  # kind of each block

    def add(alpha, beta, frac, kind: str) -> None:
        alphas.append(alpha)
        betas.append(beta)
        fracs.append(frac)
        order.append(kind)

    if vel_on:
        for frac, d1 in coeffs["velocity"].items():
            add(None, d1**2, frac, "velocity")
    at: list[tuple[float | np.ndarray, dict]] = list(coeffs["limit"].items())
    at.append((coeffs["knot"]["frac"][:, None], coeffs["knot"]["C"]))
    for frac, C in at:
        if acc_on:
            add(C["d1"], C["d2"], frac, "acceleration")
        if tau_on:
            add(C["m"], C["c"], frac, "torque")
            G.append(C["g"])
    nb = len(order)
    two_f_ds = np.empty((K, nb))  # 2 frac ds_k, evaluated as (2 frac) ds_k
    none_b = np.zeros((K, nb), bool)
    for i, f in enumerate(fracs):
        if isinstance(f, np.ndarray):
            two_f_ds[:, i] = (2 * np.nan_to_num(f, nan=0.0) * ds[:, None])[:, 0]
            none_b[:, i] = np.isnan(f)[:, 0]
        else:
            two_f_ds[:, i] = 2 * f * ds
    beta3 = np.stack(betas, axis=1)  # (K, blocks, n): hstack's column order once reshaped
    alpha3 = np.stack([np.zeros((K, n)) if x is None else x for x in alphas], axis=1)
    a = (alpha3 + two_f_ds[:, :, None] * beta3).reshape(K, nb * n)
    b = beta3.reshape(K, nb * n)
    where = tuple(
        (kind, "a spline knot" if isinstance(f, np.ndarray) else f"{f:g} of the interval")
        for kind, f in zip(order, fracs, strict=True)
    )
    labels = list(_labels(tuple(prob.limits.joint_names), where))
    # rows without u (|a| negligible in its interval) bound x_k alone
    amax_k = np.max(np.abs(a), axis=1, initial=0.0)
    free = np.abs(a) <= 1e-13 * amax_k[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.where(free, 0.0, -b / a)
    none_all = np.repeat(none_b, n, axis=1)
    out = {
        "a": a,
        "b": b,
        "free": free,
        "any_free": bool(free.any()),
        "free_cols": np.flatnonzero(free.any(axis=0)),  # the columns holding such rows
        "pos": a > 0,
        "slope": slope,
        "none": none_all,
        "none_cols": np.flatnonzero(none_all.any(axis=0)),  # the knot rows' columns
        "order": order,
        "g": G,
        "labels": labels,
        "velocity_labels": [
            f"velocity limit (of the joint that binds) at {f:g} of the interval"
            for f in (coeffs["velocity"] if vel_on else ())
        ],
    }
    cache[kinds] = out
    return out


def canonical_rows(
    prob: ToppProblem, ls: Limits, scale: dict[str, np.ndarray] | None = None
) -> CanonicalRows:
    """The rows ``lo <= a u + b x <= hi`` of ``prob``'s grid (module docstring) as lines in
    ``u``; ``scale[kind]`` (K, n_joints) tightens the limits of single intervals as in
    :meth:`ToppProblem.solve_convex` (default 1)."""
    s = prob.s
    K, n = s.size - 1, ls.n_joints
    ds = np.diff(s)
    if scale is None:
        scale = {k: np.ones((K, n)) for k in ("velocity", "acceleration", "torque")}
    kinds = (
        ls.velocity_rad_s is not None,
        ls.acceleration_rad_s2 is not None,
        ls.torque_Nm is not None,
    )
    blk = _row_blocks(prob, kinds)
    Cn = prob.coeffs["node"]
    # the bounds of each block: the scaled limits (torque: less the gravity there)
    lo_hi: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    if ls.velocity_rad_s is not None:
        lo_hi["velocity"] = (
            np.full((K, n), -np.inf),
            (ls.velocity_rad_s * scale["velocity"]) ** 2,
        )
    if ls.acceleration_rad_s2 is not None:
        amax = ls.acceleration_rad_s2 * scale["acceleration"]
        lo_hi["acceleration"] = (-amax, amax)
    tmax = None if ls.torque_Nm is None else ls.torque_Nm * scale["torque"]
    LO: list[np.ndarray] = []
    HI: list[np.ndarray] = []
    gi = 0
    for kind in blk["order"]:
        if kind == "torque":
            assert tmax is not None
            g = blk["g"][gi]
            gi += 1
            LO.append(-tmax - g)
            HI.append(tmax - g)
        else:
            LO.append(lo_hi[kind][0])
            HI.append(lo_hi[kind][1])
    none, nc = blk["none"], blk["none_cols"]  # rows absent from an interval: no bounds
    lo, hi = np.hstack(LO), np.hstack(HI)
    lo[:, nc] = np.where(none[:, nc], -np.inf, lo[:, nc])
    hi[:, nc] = np.where(none[:, nc], np.inf, hi[:, nc])
    a, b, free, pos = blk["a"], blk["b"], blk["free"], blk["pos"]

    x_lo = np.zeros(K + 1)
    x_hi = np.full(K + 1, np.inf)
    if blk["any_free"]:  # rows without u bound x_k alone (in the columns holding any)
        fc = blk["free_cols"]
        fr, bf, lf, hf = free[:, fc], b[:, fc], lo[:, fc], hi[:, fc]
        with np.errstate(divide="ignore", invalid="ignore"):
            xb1, xb2 = lf / bf, hf / bf
            xl = np.where(fr & (bf > 0), xb1, np.where(fr & (bf < 0), xb2, -np.inf))
            xh = np.where(fr & (bf > 0), xb2, np.where(fr & (bf < 0), xb1, np.inf))
        dead = fr & (bf == 0) & ((lf > 0) | (hf < 0))  # 0 outside [lo, hi]: no x at all
        xh = np.where(dead, -np.inf, xh)
        x_lo[:-1] = np.maximum(0.0, np.max(xl, axis=1, initial=-np.inf))
        x_hi[:-1] = np.min(xh, axis=1, initial=np.inf)
    if ls.velocity_rad_s is not None:  # node velocity: x_k <= (v scale / q')^2
        sc = scale["velocity"]
        scn = np.minimum(np.vstack([sc[:1], sc]), np.vstack([sc, sc[-1:]]))
        with np.errstate(divide="ignore"):
            cap = np.min((ls.velocity_rad_s * scn) ** 2 / (Cn["d1"] ** 2), axis=1)
        x_hi = np.minimum(x_hi, cap)
    x_hi[-1] = 0.0

    # rows with u: a lower and an upper line each (a > 0: lo gives the lower one); an
    # infinite bound gives an infinite line of the right sign (a > 0: lo = -inf -> -inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        p_lo = np.where(pos, lo, hi) / a
        p_hi = np.where(pos, hi, lo) / a
    if blk["any_free"]:
        fc = blk["free_cols"]
        p_lo[:, fc] = np.where(free[:, fc], -np.inf, p_lo[:, fc])
        p_hi[:, fc] = np.where(free[:, fc], np.inf, p_hi[:, fc])
    slope = blk["slope"]
    q_lo = np.where(np.isfinite(p_lo), slope, 0.0)
    q_hi = np.where(np.isfinite(p_hi), slope, 0.0)
    labels = blk["labels"]
    nv = len(blk["velocity_labels"])  # the velocity blocks come first, n columns each
    if nv:
        # the velocity rows at one point of an interval bound x there, x_k + 2 f ds_k u: lines
        # of one slope (-1 / (2 f ds_k)) whatever the joint, of which only the lowest can bind;
        # one line per point instead of one per joint (every later step works on fewer)
        cut = nv * n
        kk, ff = np.indices((K, nv))
        low = np.argmin(p_hi[:, :cut].reshape(K, nv, n), axis=2)

        def lowest(z: np.ndarray) -> np.ndarray:
            return np.hstack([z[:, :cut].reshape(K, nv, n)[kk, ff, low], z[:, cut:]])

        p_lo, q_lo, p_hi, q_hi = lowest(p_lo), lowest(q_lo), lowest(p_hi), lowest(q_hi)
        labels = blk["velocity_labels"] + labels[cut:]
    return CanonicalRows(ds, p_lo, q_lo, p_hi, q_hi, x_lo, x_hi, labels)


# ----------------------------------------------------------------------------- static sets
def _gap(rows: CanonicalRows, x: np.ndarray, idx: np.ndarray):
    """``F(x)`` = largest lower line minus smallest upper line at ``x`` (m,) for intervals
    ``idx`` (m,), its slope and a rounding scale of its terms."""
    L = rows.lower_p[idx] + rows.lower_q[idx] * x[:, None]
    U = rows.upper_p[idx] + rows.upper_q[idx] * x[:, None]
    jl, ju = np.argmax(L, axis=1), np.argmin(U, axis=1)
    r = np.arange(idx.size)
    lv, uv = L[r, jl], U[r, ju]
    with np.errstate(invalid="ignore"):
        F = lv - uv
    slope = rows.lower_q[idx, jl] - rows.upper_q[idx, ju]
    mag = (
        1.0 + np.where(np.isfinite(lv), np.abs(lv), 0.0) + np.where(np.isfinite(uv), np.abs(uv), 0)
    )
    return F, slope, mag


def _newton_end(rows: CanonicalRows, x0: np.ndarray, idx: np.ndarray, direction: int):
    """From ``x0`` (outside or on the static set) move towards it (``direction`` -1: down
    from above, +1: up from below) by Newton steps on the convex ``F``; returns the end
    reached and a mask of the intervals whose set is empty on that side."""
    x = x0.copy()
    empty = np.zeros(idx.size, bool)
    todo = np.arange(idx.size)
    for _ in range(MAX_NEWTON):
        F, slope, mag = _gap(rows, x[todo], idx[todo])
        over = F > FEAS_TOL * mag
        if not over.any():
            break
        todo, F, slope = todo[over], F[over], slope[over]
        wrong = slope * direction >= 0  # F grows towards the set: nothing feasible that way
        empty[todo[wrong]] = True
        todo, F, slope = todo[~wrong], F[~wrong], slope[~wrong]
        x[todo] = x[todo] - F / slope
        if not todo.size:
            break
    else:  # pragma: no cover - a convex piecewise-linear F ends in few steps
        raise InfeasibleError("reachability: the static sets did not converge")
    return x, empty


def static_sets(rows: CanonicalRows) -> tuple[np.ndarray, np.ndarray]:
    """``[lo_k, hi_k]`` (K,): the ``x_k`` for which some ``u`` meets every row of interval
    ``k`` (empty: ``lo > hi``), within ``rows.x_lo, x_hi``."""
    K = rows.ds.size
    idx = np.arange(K)
    lo, hi = rows.x_lo[:-1].copy(), rows.x_hi[:-1].copy()
    start = np.where(np.isfinite(hi), hi, X_BIG)
    top, empty_hi = _newton_end(rows, start, idx, -1)
    hi = np.where(np.isfinite(hi) | (top < X_BIG), np.minimum(top, hi), np.inf)
    bottom, empty_lo = _newton_end(rows, lo, idx, +1)
    lo = np.maximum(lo, bottom)
    bad = empty_hi | empty_lo
    lo[bad], hi[bad] = np.inf, -np.inf
    return lo, hi


# ----------------------------------------------------------------------------- sweeps
def _coupling(rows: CanonicalRows):
    """Per interval, the bounds on ``x_k`` from pairing the rows' lines with the two lines of
    the next set, ``e K - f`` for the next set's end ``K``: (e, f) arrays (K, R) for the
    upper lines with ``lo_{k+1}`` and the lower lines with ``hi_{k+1}``, and the sign masks
    saying which give an upper bound on ``x_k``."""
    inv = 1.0 / (2 * rows.ds[:, None])
    # lower line j and u <= (hi' - x) / 2ds:  (q_j + inv) x <= inv hi' - p_j
    g = rows.lower_q + inv
    g = np.where(g == 0, 1e-300, g)
    e_hi, f_hi, up_hi = inv / g, rows.lower_p / g, g > 0
    # upper line i and u >= (lo' - x) / 2ds:  (w_i + inv) x >= inv lo' - r_i
    h = rows.upper_q + inv
    h = np.where(h == 0, -1e-300, h)
    e_lo, f_lo, up_lo = inv / h, rows.upper_p / h, h < 0
    return (e_hi, f_hi, up_hi), (e_lo, f_lo, up_lo)


def _envelope(
    E: np.ndarray, F: np.ndarray, x0: np.ndarray, x1: np.ndarray
) -> tuple[list[float], list[float], list[int]]:
    """The lines ``E x - F`` (K, R) that can be the minimum of their row for ``x`` in
    ``[x0_k, x1_k]``: every line above the minimal line at ``x0`` or at ``x1`` at both ends is
    dropped (dominance: exact, most lines go), as are lines without a finite value. Returns
    flat Python lists ``E, F`` and offsets ``o`` (K + 1,): row ``k`` keeps ``o[k]:o[k + 1]``."""
    with np.errstate(invalid="ignore"):
        V0 = E * x0[:, None] - F
        V1 = E * x1[:, None] - F
    V0 = np.where(np.isnan(V0), np.inf, V0)
    V1 = np.where(np.isnan(V1), np.inf, V1)
    r = np.arange(E.shape[0])
    keep = np.isfinite(V0) & np.isfinite(V1)
    for m in (np.argmin(V0, axis=1), np.argmin(V1, axis=1)):
        dom = (V0 >= V0[r, m][:, None]) & (V1 >= V1[r, m][:, None])
        dom[r, m] = False
        keep &= ~dom
    counts = keep.sum(axis=1)
    offsets = np.concatenate([[0], np.cumsum(counts)])
    return E[keep].tolist(), F[keep].tolist(), offsets.tolist()


def controllable_sets(
    rows: CanonicalRows, static: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray, int]:
    """Backward sweep: the controllable sets ``[lo_k, hi_k]`` (K + 1,) of ``x_k`` (Pham &
    Pham), ``K_K = [0, 0]``. Returns ``(lo, hi, k_empty)`` with ``k_empty`` the last
    interval whose set is empty (-1 if none; the sets before it are not computed).

    Each step evaluates the few lines of :func:`_envelope` in plain Python (a numpy call per
    step costs more than the arithmetic); ``hi_{k+1}`` ranges over ``[0, static hi_{k+1}]``."""
    K = rows.ds.size
    s_lo, s_hi = static_sets(rows) if static is None else static
    (e_hi, f_hi, up_hi), (e_lo, f_lo, up_lo) = _coupling(rows)
    # pairs with hi_{k+1}: x_k <= e hi' - f (up) or x_k >= e hi' - f (not up)
    nxt = np.minimum(np.append(s_hi[1:], 0.0), X_BIG)
    nxt = np.where(np.isfinite(nxt), np.maximum(nxt, 0.0), 0.0)
    zero = np.zeros(K)
    eu, fu, ou = _envelope(
        np.where(up_hi, e_hi, 0.0), np.where(up_hi, f_hi, -np.inf), zero, nxt
    )  # min of the upper bounds
    el, fl, ol = _envelope(
        np.where(up_hi, 0.0, -e_hi), np.where(up_hi, -np.inf, -f_hi), zero, nxt
    )  # max of the lower bounds, as minus the min of their negatives
    # pairs with lo_{k+1} (x_k bounded by e lo' - f): constants while lo_{k+1} = 0
    with np.errstate(invalid="ignore"):
        lo_u = np.where(up_lo, -f_lo, np.inf)
        lo_l = np.where(up_lo, -np.inf, -f_lo)
    zero_u = np.min(np.where(np.isnan(lo_u), np.inf, lo_u), axis=1, initial=np.inf).tolist()
    zero_l = np.max(np.where(np.isnan(lo_l), -np.inf, lo_l), axis=1, initial=-np.inf).tolist()
    slo, shi = s_lo.tolist(), s_hi.tolist()
    lo = np.zeros(K + 1)
    hi = np.zeros(K + 1)
    k_empty = -1
    nlo, nhi = 0.0, 0.0
    for k in range(K - 1, -1, -1):
        a, b = slo[k], shi[k]
        for j in range(ou[k], ou[k + 1]):
            v = eu[j] * nhi - fu[j]
            if v < b:
                b = v
        for j in range(ol[k], ol[k + 1]):
            v = fl[j] - el[j] * nhi
            if v > a:
                a = v
        if nlo == 0.0:
            b = min(b, zero_u[k])
            a = max(a, zero_l[k])
        else:  # rare: a minimum speed ahead (torque at rest infeasible there)
            with np.errstate(invalid="ignore"):
                v_all = e_lo[k] * nlo - f_lo[k]
            b = min(b, float(np.min(v_all[up_lo[k]], initial=np.inf)))
            a = max(a, float(np.max(v_all[~up_lo[k]], initial=-np.inf)))
        a = max(a, 0.0)
        if a > b * (1 + FEAS_TOL) + FEAS_TOL:
            k_empty = k
            lo[: k + 1], hi[: k + 1] = np.inf, -np.inf
            break
        b = max(a, b)
        lo[k], hi[k] = a, b
        nlo, nhi = a, b
    return lo, hi, k_empty


def greedy_forward(
    rows: CanonicalRows, lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Forward sweep from ``x_0 = 0``: the largest admissible ``u_k`` keeping ``x_{k+1}`` in
    its controllable set (Pham & Pham: the greedy pass). Returns ``x`` (K + 1,) and ``u`` (K,)."""
    K = rows.ds.size
    # u <= r + w x_k = w x_k - (-r): the lines that can be the smallest on [lo_k, hi_k]
    w, mr, o = _envelope(rows.upper_q, -rows.upper_p, lo[:-1], hi[:-1])
    two_ds = (2 * rows.ds).tolist()
    los, his = lo.tolist(), hi.tolist()
    x = [0.0] * (K + 1)
    xk = 0.0
    for k in range(K):
        xn = his[k + 1]  # u <= (hi' - x_k) / 2ds, then each upper line
        for j in range(o[k], o[k + 1]):
            v = xk + two_ds[k] * (w[j] * xk - mr[j])
            if v < xn:
                xn = v
        if xn < los[k + 1]:
            xn = los[k + 1]
        x[k + 1] = xn
        xk = xn
    xa = np.array(x)
    return xa, np.diff(xa) / (2 * rows.ds)


def solve_reachability(
    prob: ToppProblem,
    ls: Limits,
    scale: dict[str, np.ndarray] | None = None,
    b0: np.ndarray | None = None,
) -> tuple[np.ndarray, dict]:
    """Square path velocities ``b_k = x_k`` (K + 1,) on ``prob``'s grid and solver info:
    a drop-in for :meth:`ToppProblem.solve_convex` (same arguments; ``b0``, a warm start,
    is not needed and ignored). ``info["success"]`` is False when no parameterisation meets
    the rows; ``info["return_status"]`` then names the interval and row that fail. Velocity,
    acceleration and torque rows only (no motor envelope: ``solve_convex_drive``'s)."""
    del b0
    interval_coefficients(prob)  # with the nodes' and midpoints' if not computed yet
    t0 = _time.perf_counter()
    rows = canonical_rows(prob, ls, scale)
    lo, hi, k_empty = controllable_sets(rows)
    status = "Solve_Succeeded"
    if k_empty < 0 and not lo[0] <= 0.0 <= hi[0] * (1 + FEAS_TOL) + FEAS_TOL:
        k_empty = 0
    if k_empty >= 0:
        b = np.zeros(prob.s.size)
        status = _why_empty(prob, rows, k_empty)
        ok = False
    else:
        b, _ = greedy_forward(rows, lo, hi)
        ok = True
    wall = _time.perf_counter() - t0
    info = {
        "success": ok,
        "iterations": 2 * (prob.s.size - 1),  # grid steps of the two sweeps
        "solve_time_s": wall,
        "return_status": status,
        "controllable": (lo, hi),
    }
    return b, info


def _why_empty(prob: ToppProblem, rows: CanonicalRows, k: int) -> str:
    """Which rows of interval ``k`` cannot hold even at the slowest admissible speed."""
    s_k = float(prob.s[k])
    L = rows.lower_p[k] + rows.lower_q[k] * rows.x_lo[k]
    U = rows.upper_p[k] + rows.upper_q[k] * rows.x_lo[k]
    j, i = int(np.argmax(L)), int(np.argmin(U))
    if L[j] > U[i]:
        return (
            f"at s = {s_k:.4f} the {rows.labels[j]} and the {rows.labels[i]} cannot both "
            "hold at any speed"
        )
    return (
        f"from s = {s_k:.4f} on, no admissible path acceleration brings the motion to rest at "
        "the end within the limits"
    )
