"""TOPP by reachability analysis (armlab.planning.reachability, the first pass of
time_optimal_path with method="reachability") against closed forms, an LP solver, Pinocchio's
RNEA and the IPOPT convex pass (method="convex")."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import linprog
from test_optimal import ONE_JOINT_URDF  # the one-joint arm of the optimiser's tests

import armlab
from armlab.errors import InfeasibleError, InputError
from armlab.planning.optimal_problem import JUMP_RAMP_S
from armlab.planning.reachability import (
    LIMIT_FRACTIONS,
    VELOCITY_FRACTIONS,
    CanonicalRows,
    canonical_rows,
    controllable_sets,
    greedy_forward,
    interval_coefficients,
    solve_reachability,
    static_sets,
)
from armlab.planning.topp import LIMIT_MARGIN, build_topp
from armlab.robot.limits import resolve_limits
from armlab.trajectory import time_optimal_path

#: waypoints of teachbot6 paths (inside the ranges, spline inside them too)
PATHS = [
    np.array(
        [
            [0.0, 0.0, 0.5, 0.0, 0.3, 0.0],
            [0.5, 0.3, 0.2, 0.4, 0.0, 0.4],
            [1.0, 0.1, -0.2, 0.8, -0.3, 0.8],
        ]
    ),
    np.array(
        [
            [0.2, -0.3, 0.8, 0.1, 0.6, -0.2],
            [-0.1, 0.1, 0.4, 0.5, 0.2, 0.3],
            [0.4, 0.4, 0.1, 0.2, -0.3, 0.9],
            [0.9, 0.2, 0.3, -0.3, -0.1, 0.4],
        ]
    ),
]


@pytest.fixture(scope="module")
def one_joint(tmp_path_factory):
    """A 1 kg arm of 0.2 m on a horizontal axis (gravity matters), 1 rad/s, 10 N m."""
    path = tmp_path_factory.mktemp("one_ra") / "one.urdf"
    path.write_text(ONE_JOINT_URDF)
    return armlab.load_robot(path)


# ---------------------------------------------------------------------------- closed forms
@pytest.mark.parametrize(
    "v_max, distance, expected",
    [
        (0.5, 2.0, 2.0 / 0.5 + 0.5 / 2.0),  # trapezoid: D / v + v / a
        (False, 2.0, 2 * math.sqrt(2.0 / 2.0)),  # triangle: 2 sqrt(D / a)
        (0.5, 0.1, 2 * math.sqrt(0.1 / 2.0)),  # short move: v never reached
    ],
    ids=["trapezoid", "bang-bang", "short"],
)
def test_one_joint_minimum_time(one_joint, v_max, distance, expected):
    """A straight one-joint path under a velocity and an acceleration limit of 2 rad/s^2: the
    classical minimum time. Never faster (it is the optimum), slower only by the limit margin
    (LIMIT_MARGIN, documented), the switch to cruising inside a path interval and the 50 us
    ramp of each acceleration step."""
    traj = time_optimal_path(
        one_joint,
        [[0.0], [distance]],
        v_max=v_max,
        a_max=2.0,
        j_max=False,
        tau_max=False,
        n_grid=100,
        method="reachability",
    )
    assert traj.stats["method"] == "reachability"
    assert traj.duration >= expected
    margin = 1 / (1 - LIMIT_MARGIN)  # v and a both scaled: every term of T by at most this
    assert traj.duration <= expected * margin + 2 * JUMP_RAMP_S + 2e-3 * expected
    assert traj.report.ok(1e-9)
    assert traj.q[-1, 0] == pytest.approx(distance, abs=1e-9)
    assert traj.stats["backoff_rounds"] == 0
    assert {k for k, _, _ in traj.stats["binding"]} >= {"acceleration"}


# ---------------------------------------------------------------------------- the 2-D LPs
def random_rows(rng, K=6, R=5) -> CanonicalRows:
    """Lines around u = 0 (so that x = 0, u = 0 is admissible everywhere): lower lines
    ``-1 - |q| x .. `` and upper lines with slopes of both signs."""
    ds = rng.uniform(0.05, 0.2, K)
    lower_p = -rng.uniform(0.5, 2.0, (K, R))
    upper_p = rng.uniform(0.5, 2.0, (K, R))
    lower_q = rng.uniform(-3.0, 3.0, (K, R))
    upper_q = rng.uniform(-3.0, 3.0, (K, R))
    x_hi = np.append(rng.uniform(0.5, 5.0, K), 0.0)
    return CanonicalRows(
        ds, lower_p, lower_q, upper_p, upper_q, np.zeros(K + 1), x_hi, [f"r{i}" for i in range(R)]
    )


def lp_bounds(rows: CanonicalRows, k: int) -> tuple[float, float]:
    """Smallest and largest x_k from which the rest at the end is reachable: one LP over
    (x_k .. x_K, u_k .. u_{K-1}) with scipy's HiGHS."""
    K = rows.ds.size
    m = K - k  # intervals ahead
    nx = m + 1
    A, b = [], []
    for i in range(m):
        kk = k + i
        for j in range(rows.lower_p.shape[1]):
            # p + q x - u <= 0 ;  u - r - w x <= 0
            row = np.zeros(nx + m)
            row[i], row[nx + i] = rows.lower_q[kk, j], -1.0
            A.append(row)
            b.append(-rows.lower_p[kk, j])
            row = np.zeros(nx + m)
            row[i], row[nx + i] = -rows.upper_q[kk, j], 1.0
            A.append(row)
            b.append(rows.upper_p[kk, j])
    Aeq = np.zeros((m, nx + m))
    for i in range(m):  # x_{i+1} - x_i - 2 ds u_i = 0
        Aeq[i, i + 1], Aeq[i, i], Aeq[i, nx + i] = 1.0, -1.0, -2 * rows.ds[k + i]
    bounds = [(rows.x_lo[k + i], rows.x_hi[k + i]) for i in range(nx)] + [(None, None)] * m
    out = []
    for sign in (1.0, -1.0):
        c = np.zeros(nx + m)
        c[0] = sign
        res = linprog(c, A_ub=np.array(A), b_ub=b, A_eq=Aeq, b_eq=np.zeros(m), bounds=bounds)
        assert res.status == 0
        out.append(float(res.x[0]))
    return out[0], out[1]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sets_match_a_linear_program(seed):
    """The closed-form static sets, controllable sets and the greedy pass against scipy's LP
    solver on random line sets: the largest x_k from which rest is reachable is the LP's."""
    rows = random_rows(np.random.default_rng(seed))
    K = rows.ds.size
    lo, hi, k_empty = controllable_sets(rows)
    assert k_empty == -1
    for k in range(K):
        lp_lo, lp_hi = lp_bounds(rows, k)
        assert hi[k] == pytest.approx(lp_hi, rel=1e-9, abs=1e-12)
        assert lo[k] == pytest.approx(lp_lo, abs=1e-12)
    # static sets: the one-interval LP (no coupling to the next set)
    s_lo, s_hi = static_sets(rows)
    for k in range(K):
        one = CanonicalRows(
            rows.ds[k : k + 1],
            rows.lower_p[k : k + 1],
            rows.lower_q[k : k + 1],
            rows.upper_p[k : k + 1],
            rows.upper_q[k : k + 1],
            np.zeros(2),
            np.array([rows.x_hi[k], 1e9]),
            rows.labels,
        )
        assert s_hi[k] == pytest.approx(lp_bounds(one, 0)[1], rel=1e-9)
    # the greedy pass stays admissible: every u_k within its lines, x within the sets
    x, u = greedy_forward(rows, lo, hi)
    assert x[0] == 0 and x[-1] == pytest.approx(0.0, abs=1e-12)
    assert np.all(x >= lo - 1e-12) and np.all(x <= hi + 1e-12)
    L = rows.lower_p + rows.lower_q * x[:-1, None]
    U = rows.upper_p + rows.upper_q * x[:-1, None]
    assert np.all(L.max(axis=1) <= u + 1e-9) and np.all(u <= U.min(axis=1) + 1e-9)


def test_an_empty_set_is_reported_with_its_rows(teachbot6):
    """An interval whose torque limit is scaled below gravity: no speed meets it there."""
    prob = build_topp(teachbot6, PATHS[0], j_max=False, n_grid=30)
    ls = resolve_limits(prob.limits, j_max=False)
    K, n = prob.s.size - 1, ls.n_joints
    scale = {k: np.ones((K, n)) for k in ("velocity", "acceleration", "torque")}
    scale["torque"][K // 2] = 1e-3
    b, info = solve_reachability(prob, ls, scale)
    assert not info["success"]
    assert "torque limit of" in info["return_status"]
    assert f"s = {prob.s[K // 2]:.4f}" in info["return_status"]


# ---------------------------------------------------------------------------- coefficients
def test_torque_rows_are_the_rnea_torques(teachbot6):
    """At every point where a row is imposed, ``m u + c x + g`` is Pinocchio's RNEA of
    ``q(s)``, ``q' sd``, ``q' u + q'' sd^2`` (independent: pinocchio.rnea per sample)."""
    prob = build_topp(teachbot6, PATHS[1], j_max=False, n_grid=20)
    coeffs = interval_coefficients(prob)
    rng = np.random.default_rng(3)
    model, data = teachbot6.model, teachbot6.model.createData()
    s0, ds = prob.s[:-1], np.diff(prob.s)
    for f in LIMIT_FRACTIONS:
        C = coeffs["limit"][f]
        for k in rng.choice(ds.size, 5, replace=False):
            x, u = rng.uniform(0.1, 2.0), rng.uniform(-3.0, 3.0)
            q, d1, d2, _ = prob.path(s0[k] + f * ds[k])
            tau = pin.rnea(model, data, q[0], d1[0] * math.sqrt(x), d1[0] * u + d2[0] * x)
            np.testing.assert_allclose(
                C["m"][k] * u + C["c"][k] * x + C["g"][k], tau, rtol=1e-9, atol=1e-9
            )
    # and the canonical rows are those torques in (u, x_k): x at the row is x_k + 2 f ds u
    ls = resolve_limits(prob.limits, j_max=False, v_max=False, a_max=False)
    rows = canonical_rows(prob, ls)
    assert rows.lower_p.shape[1] == (len(LIMIT_FRACTIONS) + 1) * ls.n_joints


def test_velocity_rows_are_the_lowest_joint_at_each_point(teachbot6):
    """The velocity rows of one point of an interval are parallel lines (one per joint): the
    canonical rows keep the lowest, one line per point; their envelope is the velocity limit
    computed directly from the path's tangent, ``x + 2 f ds u <= min_j (v / q'_j)^2`` at
    each of :data:`VELOCITY_FRACTIONS` (independent: the spline's derivative there)."""
    prob = build_topp(
        teachbot6, PATHS[1], v_max=2.0, a_max=False, tau_max=False, j_max=False, n_grid=20
    )
    rows = canonical_rows(prob, prob.limits)
    assert rows.upper_p.shape[1] == len(VELOCITY_FRACTIONS)
    assert len(rows.labels) == len(VELOCITY_FRACTIONS)
    s0, ds = prob.s[:-1], np.diff(prob.s)
    for x in (0.0, 0.3, 2.0):
        expect = np.full(ds.size, np.inf)
        for f in VELOCITY_FRACTIONS:
            cap = np.min(2.0**2 / prob.path.spline(s0 + f * ds, 1) ** 2, axis=1)
            expect = np.minimum(expect, (cap - x) / (2 * f * ds))
        got = np.min(rows.upper_p + rows.upper_q * x, axis=1)
        np.testing.assert_allclose(got, expect, rtol=1e-12)


# ---------------------------------------------------------------------------- against today
@pytest.mark.parametrize("w", PATHS, ids=["3wp", "4wp"])
def test_close_to_the_convex_topp_and_within_limits_between_samples(teachbot6, w):
    """Same path, limits and grid as today's time_optimal_path (IPOPT convex pass): the
    duration within 0.3 % (the reachability rows are denser, so at most a little slower, and
    never faster than the convex optimum by more than its tolerance); every limit holds on a
    T / 4000 grid, torques from pinocchio.rnea sample by sample."""
    kw = dict(v_max=2.0, a_max=20.0, j_max=False, n_grid=60)
    ra = time_optimal_path(teachbot6, w, method="reachability", **kw)
    today = time_optimal_path(teachbot6, w, method="convex", **kw)
    assert 0.999 * today.duration <= ra.duration <= 1.003 * today.duration
    assert ra.report.ok(1e-9)
    assert ra.stats["method"] == "reachability" and today.stats["method"] == "convex"
    assert ra.stats["solver"].startswith("reachability") and "ipopt" in today.stats["solver"]
    assert ra.stats["passes"] == ["convex"]  # the first pass only: no jerk limit
    # the path is kept and run from end to end
    np.testing.assert_allclose(ra.meta["topp"].path(ra.meta["s"])[0], ra.q, atol=1e-9)
    np.testing.assert_allclose(ra.q[[0, -1]], w[[0, -1]], atol=1e-9)
    # fine grid, independent torques
    lim = resolve_limits(teachbot6, v_max=2.0, a_max=20.0, j_max=False)
    t = np.linspace(0.0, ra.duration, 4001)
    q, qd, qdd, _ = ra.at(t)
    assert np.all(np.abs(qd) <= lim.velocity_rad_s * (1 + 1e-9))
    assert np.all(np.abs(qdd) <= lim.acceleration_rad_s2 * (1 + 1e-9))
    model, data = teachbot6.model, teachbot6.model.createData()
    tau = np.array([pin.rnea(model, data, *z) for z in zip(q, qd, qdd, strict=True)])
    assert np.all(np.abs(tau) <= lim.torque_Nm * (1 + 1e-9))
    # time-optimal: some limit binds
    assert ra.stats["binding"]


def test_the_geometry_of_a_trajectory(teachbot6):
    """A timed Trajectory as the path (its geometry, densely resampled: many spline knots):
    the motion keeps its end points, meets every limit and is faster than the S-curve."""
    w = np.array([[0.0, 0.0, 0.5, 0.0, 0.3, 0.0], [0.6, 0.3, 0.1, 0.5, -0.2, 0.5]])
    ptp = armlab.trajectory.ptp_sync(teachbot6, w[0], w[1], profile="scurve")
    traj = time_optimal_path(teachbot6, ptp, j_max=False, method="reachability")
    assert traj.report.ok(1e-9)
    np.testing.assert_allclose(traj.q[[0, -1]], w, atol=1e-9)
    assert traj.duration < ptp.duration  # no jerk limit, same v/a/tau limits


# ---------------------------------------------------------------------------- errors
def test_bad_requests_raise_named_errors(teachbot6, one_joint):
    with pytest.raises(InputError, match="method"):
        time_optimal_path(teachbot6, PATHS[0], j_max=False, method="seidel")
    with pytest.raises(InputError, match="method"):
        build_topp(teachbot6, PATHS[0], j_max=False, method="Reachability")
    with pytest.raises(InputError, match="shape"):
        time_optimal_path(teachbot6, np.zeros((3, 5)), j_max=False, method="reachability")
    # the problem carries the method; the motor envelope of drive_limits has no rows in the
    # reachability pass: the convex envelope pass is used (not the envelope silently dropped)
    assert build_topp(teachbot6, PATHS[0], j_max=False, n_grid=10).method == "reachability"
    prob = build_topp(
        teachbot6, PATHS[0], j_max=False, drive_limits=True, n_grid=10, method="reachability"
    )
    assert prob.method == "reachability"
    drive = prob.solve()
    assert drive.stats["method"] == "convex" and "ipopt" in drive.stats["solver"]
    assert drive.stats["drive_limits"] and drive.stats["ok"]
    # gravity alone above the torque limit: no speed helps
    with pytest.raises(InfeasibleError, match="against gravity"):
        time_optimal_path(
            one_joint, [[-1.0], [1.0]], a_max=2.0, j_max=False, tau_max=1.0, method="reachability"
        )


def test_interval_ratios_see_the_peaks_the_check_reports(teachbot6):
    """The local back-off's per-interval ratios are taken over the samples of the limit check
    (exact velocity and acceleration peaks, refined torque peaks, the uniform grid): their
    maximum over the intervals is the report's peak, kind by kind and joint by joint."""
    prob = build_topp(teachbot6, PATHS[1], v_max=2.0, a_max=20.0, j_max=False, n_grid=30)
    prob.compute_coefficients()
    ls = resolve_limits(prob.limits, j_max=False)
    b, info = solve_reachability(prob, ls)  # the untightened limits: peaks at or above 1
    assert info["success"]
    traj = prob.trajectory_from_b(b)
    dt = traj.duration / 50  # a coarse grid: the peaks must come from the exact samples
    report = traj.check_limits(teachbot6, dt=dt, limits=ls)
    ratios = prob.interval_ratios(traj, ls, dt)
    assert set(ratios) == {"velocity", "acceleration", "torque"}
    for kind, r in ratios.items():
        assert r.shape == (prob.s.size - 1, ls.n_joints)
        np.testing.assert_allclose(r.max(axis=0), report.ratios[kind], rtol=1e-12)
    # some limit binds at (or a little over) 1 somewhere between the coarse grid's samples
    assert max(float(r.max()) for r in ratios.values()) >= 1 - 1e-3


# ---------------------------------------------------------------------------- the limit check
def dense_ratios(robot, traj, lim, n=20000) -> dict[str, np.ndarray]:
    """Independent of the check: peak ratios per joint on a uniform grid of ``n`` steps,
    torques by pinocchio.rnea sample by sample."""
    t = np.linspace(0.0, traj.duration, n + 1)
    q, qd, qdd, _ = traj.at(t)
    model, data = robot.model, robot.model.createData()
    tau = np.array([pin.rnea(model, data, *z) for z in zip(q, qd, qdd, strict=True)])
    return {
        "velocity": np.abs(qd).max(axis=0) / lim.velocity_rad_s,
        "acceleration": np.abs(qdd).max(axis=0) / lim.acceleration_rad_s2,
        "torque": np.abs(tau).max(axis=0) / lim.torque_Nm,
    }


def test_the_check_finds_a_plan_one_percent_too_fast(teachbot6):
    """The planner's plan, run 1 % faster (``stretched(0.99)``: velocities / 0.99,
    accelerations / 0.99^2): the limit check (the one ``time_optimal_path`` runs every round)
    reports the excess, its peaks at least those of an independent dense grid and close to
    them (not made up), and the planner's own plan passes the same check."""
    kw = dict(v_max=2.0, a_max=20.0, j_max=False)
    traj = time_optimal_path(teachbot6, PATHS[1], method="reachability", n_grid=30, **kw)
    lim = resolve_limits(teachbot6, **kw)
    assert traj.report.ok(1e-9)
    fast = traj.stretched(0.99)
    report = fast.check_limits(teachbot6, limits=lim)
    dense = dense_ratios(teachbot6, fast, lim)
    for kind, r in dense.items():
        assert np.all(report.ratios[kind] >= r * (1 - 1e-9)), kind
        np.testing.assert_allclose(report.ratios[kind], r, rtol=2e-3, err_msg=kind)
    assert not report.ok(1e-6)
    kind, _, worst = report.worst()
    assert worst > 1.005  # the binding limit, 1 % (velocity) or 2 % (acceleration) over
    # the same excess through the planner's own round: samples once, report and intervals
    smp = fast.limit_samples(None, robot=teachbot6)
    same = fast.check_limits(teachbot6, limits=lim, samples=smp)
    for k, r in report.ratios.items():
        np.testing.assert_array_equal(same.ratios[k], r)
    per = traj.meta["topp"].interval_ratios(fast, lim, None, smp)
    for k, r in per.items():
        np.testing.assert_allclose(r.max(axis=0), report.ratios[k], rtol=1e-12)
    with pytest.raises(InputError, match="no torques"):
        fast.check_limits(teachbot6, limits=lim, samples=fast.limit_samples(None))


def test_the_check_finds_a_violation_between_the_samples(teachbot6):
    """A limit lowered below the plan's peak but above every value at the plan's samples (its
    knots and their left limits, the path's grid points among them): the violation exists
    only between samples, and the check reports it, at a time that is no sample's."""
    kw = dict(v_max=2.0, a_max=20.0, j_max=False)
    traj = time_optimal_path(teachbot6, PATHS[1], method="reachability", n_grid=30, **kw)
    lim = resolve_limits(teachbot6, **kw)
    model, data = teachbot6.model, teachbot6.model.createData()
    left = traj.left_limits()
    q = np.vstack([traj.q, left[0]])
    qd = np.vstack([traj.qd, left[1]])
    qdd = np.vstack([traj.qdd, left[2]])
    tau = np.array([pin.rnea(model, data, *z) for z in zip(q, qd, qdd, strict=True)])
    at_samples = {
        "velocity": np.abs(qd).max(axis=0) / lim.velocity_rad_s,
        "acceleration": np.abs(qdd).max(axis=0) / lim.acceleration_rad_s2,
        "torque": np.abs(tau).max(axis=0) / lim.torque_Nm,
    }
    # the kind and joint whose peak lies furthest above its samples
    gap = {k: traj.report.ratios[k] / r for k, r in at_samples.items()}
    kind = max(gap, key=lambda k: float(gap[k].max()))
    j = int(np.argmax(gap[kind]))
    assert gap[kind][j] > 1 + 1e-5  # a peak between the samples exists
    # lower that limit to the middle of the two: every sample within it, the peak over
    factor = 0.5 * (traj.report.ratios[kind][j] + at_samples[kind][j])
    scaled = lim.get(kind).copy()
    scaled[j] *= factor
    key = {"velocity": "v_max", "acceleration": "a_max", "torque": "tau_max"}[kind]
    tight = resolve_limits(teachbot6, **{**kw, key: scaled})
    report = traj.check_limits(teachbot6, limits=tight)
    assert report.ratios[kind][j] > 1 + 1e-6
    assert np.min(np.abs(traj.t - report.at_s[kind][j])) > 0  # between samples
    assert at_samples[kind][j] / factor < 1  # the samples alone would pass


def test_the_check_samples_against_an_independent_construction(teachbot6):
    """The limit samples of a plan (:meth:`Trajectory.limit_samples`, every planner's check)
    rebuilt from the public evaluation: the left limits, the stored knots and the critical
    times evaluated by ``at``, ordered by time with each knot's left limit first; with the
    robot, the same rows plus interior points, and at every row the torque of Pinocchio's
    RNEA called once per row."""
    traj = time_optimal_path(
        teachbot6, PATHS[1], method="reachability", n_grid=30, v_max=2.0, a_max=20.0, j_max=False
    )
    smp = traj.limit_samples(None)
    crit = traj.critical_times()
    left = traj.left_limits()
    inner = traj.at(crit)
    t = np.concatenate([traj.t[1:], traj.t, crit])
    order = np.lexsort((np.repeat([0, 1, 2], [traj.t.size - 1, traj.t.size, crit.size]), t))
    np.testing.assert_array_equal(smp.t, t[order])
    for got, parts in zip(
        (smp.q, smp.qd, smp.qdd),
        ((left[i], stored, inner[i]) for i, stored in enumerate((traj.q, traj.qd, traj.qdd))),
        strict=True,
    ):
        np.testing.assert_array_equal(got, np.concatenate(parts)[order])
    assert smp.qddd is None and smp.tau is None  # no jerk without qddd, no robot
    full = traj.limit_samples(None, robot=teachbot6)
    assert np.all(np.diff(full.t) >= 0)
    assert np.isin(smp.t, full.t).all()  # the exact peak points, and more for the torque
    extra = full.t[~np.isin(full.t, smp.t)]
    assert extra.size > traj.t.size  # the middles of the pieces at least
    assert not np.isin(extra, traj.t).any()  # strictly inside pieces
    model, data = teachbot6.model, teachbot6.model.createData()
    tau = np.array([pin.rnea(model, data, *z) for z in zip(full.q, full.qd, full.qdd, strict=True)])
    np.testing.assert_allclose(full.tau, tau, rtol=1e-12, atol=1e-12 * np.abs(tau).max())
    q, qd, qdd, _ = traj.at(extra)  # the interior rows are the evaluation there
    inside = np.isin(full.t, extra)
    np.testing.assert_allclose(full.q[inside], q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(full.qd[inside], qd, rtol=0, atol=1e-12)
    np.testing.assert_allclose(full.qdd[inside], qdd, rtol=1e-12, atol=1e-9)
