"""optimal() on fatrop (compiled stage functions) against IPOPT, the reference, on teachbot6.

The stage libraries are compiled once for this module into a temporary cache (one per variant:
jerk mode, acceleration mode, each with drive rows, the fixed-duration row, the energy
objective in jerk mode; see docs/api/planning.md for the compile times), or taken from
``$ARMLAB_TEST_FATROP_CACHE`` when that is set (a developer's cache of compiled libraries, to
rerun without compiling); where no compiler is found the compiled-path tests are skipped and
the fallback tests still run.
"""

from __future__ import annotations

import os

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest

import armlab
from armlab.planning import fatrop_backend, fatrop_stages
from armlab.planning.optimiser import build_optimal
from armlab.planning.transcription import structure
from armlab.trajectory import optimal

# waypoints inside teachbot6's ranges (the scaling cases of bench_trajectory.py are random;
# these are fixed so that the test is the same everywhere)
W3 = np.array(
    [[0, 0, 0, 0, 0, 0], [0.5, -0.3, 0.4, 0.2, -0.6, 0.9], [1.0, 0.2, -0.2, 0.4, 0.3, -0.5]]
)
W2 = np.array([[0.1, -0.2, 0.3, 0.0, 0.2, -0.4], [1.2, 0.3, -0.5, 0.6, -0.4, 1.1]])


@pytest.fixture(scope="module")
def robot():
    return armlab.load_robot("teachbot6")


@pytest.fixture(scope="module")
def compiled(robot, tmp_path_factory):
    """The fatrop path on, with teachbot6's library compiled once into a temporary cache."""
    with pytest.MonkeyPatch.context() as mp:
        own = os.environ.get("ARMLAB_TEST_FATROP_CACHE")
        mp.setenv("ARMLAB_CACHE_DIR", own or str(tmp_path_factory.mktemp("armlab-cache")))
        mp.setenv("ARMLAB_SOLVER", "fatrop")
        try:
            so, _ = fatrop_stages.compiled_library(robot)
        except fatrop_stages.FatropUnavailable as exc:
            pytest.skip(f"no fatrop here: {exc}")
        yield so


def _ipopt(mp, robot, w, **kw):
    mp.setenv("ARMLAB_SOLVER", "ipopt")
    traj = optimal(robot, w, **kw)
    mp.setenv("ARMLAB_SOLVER", "fatrop")
    return traj


def _pinocchio_ratios(robot, traj) -> dict[str, float]:
    """Peak |x| / limit on a uniform grid of T/6000 plus every knot, torque from
    pinocchio.rnea (independent of armlab's symbolic dynamics and its own check)."""
    t = np.union1d(np.linspace(traj.t[0], traj.t[-1], 6001), traj.t)
    q, qd, qdd, qddd = traj.at(t)
    data = robot.model.createData()
    tau = np.array([pin.rnea(robot.model, data, q[i], qd[i], qdd[i]) for i in range(t.size)])
    lim = robot.limits
    return {
        "torque": float(np.max(np.abs(tau) / lim.effort_Nm)),
        "velocity": float(np.max(np.abs(qd) / lim.velocity_rad_s)),
        "acceleration": float(np.max(np.abs(qdd) / lim.acceleration_rad_s2)),
        "jerk": float(np.max(np.abs(qddd) / lim.jerk_rad_s3)),
        "range": float(max(np.max(lim.lower_rad - q), np.max(q - lim.upper_rad))),
    }


@pytest.mark.parametrize(
    ("w", "kw"),
    [
        (W2, {}),
        (W3, {}),
        (W3, {"objective": "time+smooth"}),
        (W3, {"via_tolerance": 0.05, "payload_kg": 1.0}),
        (W2, {"qd_start": [0.2, 0, -0.1, 0, 0.3, 0], "qdd_start": [0, 0.5, 0, 0, 0, 0]}),
        (W3, {"hessian": "exact"}),
    ],
)
def test_fatrop_plans_as_ipopt_within_every_limit(compiled, robot, w, kw):
    with pytest.MonkeyPatch.context() as mp:
        fat = optimal(robot, w, **kw)
        ref = _ipopt(mp, robot, w, **kw)
    assert fat.stats["solver"] == "fatrop" and fat.stats["fallback"] == ""
    assert ref.stats["solver"] == "ipopt"
    assert fat.stats["duration_s"] == pytest.approx(ref.stats["duration_s"], rel=1e-6)
    ratios = _pinocchio_ratios(robot, fat)
    for kind in ("torque", "velocity", "acceleration", "jerk"):
        assert ratios[kind] <= 1 + 1e-6, (kind, ratios[kind])
    assert ratios["range"] <= 1e-9
    np.testing.assert_allclose(fat.q[-1], w[-1], atol=1e-9)


def _drive_ok(traj) -> bool:
    return all(max(r) <= 1 + 1e-6 for r in traj.stats["drive_ratios"].values())


@pytest.mark.parametrize(
    ("w", "kw"),
    [
        (W3, {"j_max": False}),  # acceleration mode, torque box
        (W3, {"j_max": False, "tau_max": False}),  # acceleration mode, v/a only
        (W3, {"a_max": False, "j_max": False, "drive_limits": True}),  # acc., motor envelope
        (W2, {"drive_limits": True}),  # jerk mode, motor envelope and RMS
    ],
)
def test_new_variants_plan_as_ipopt(compiled, robot, w, kw):
    """Acceleration mode and drive_limits (each its own stage library) on fatrop: the same
    durations as IPOPT's, every limit held on the fine grid (and the motor envelope and RMS
    rating by the independent drive check)."""
    with pytest.MonkeyPatch.context() as mp:
        fat = optimal(robot, w, **kw)
        ref = _ipopt(mp, robot, w, **kw)
    assert fat.stats["solver"] == "fatrop" and fat.stats["fallback"] == ""
    assert fat.stats["duration_s"] == pytest.approx(ref.stats["duration_s"], rel=1e-6)
    assert fat.stats["ok"] and fat.report.ok(1e-6)
    if kw.get("drive_limits"):
        assert _drive_ok(fat) and _drive_ok(ref)
    np.testing.assert_allclose(fat.q[-1], w[-1], atol=1e-9)


DRIVE_ACC = {"a_max": False, "j_max": False, "drive_limits": True, "n_intervals": 8}


def _three_ways(robot, w, **kw):
    """The plan of fatrop as it runs (the RMS row checked after a solve without it), of fatrop
    with the RMS row from the start, and of IPOPT."""
    with pytest.MonkeyPatch.context() as mp:
        fat = optimal(robot, w, **kw)
        mp.setattr(fatrop_backend, "DRIVE_RMS_LAST", False)
        full = optimal(robot, w, **kw)
        ref = _ipopt(mp, robot, w, **kw)
    for plan in (fat, full):
        assert plan.stats["solver"] == "fatrop" and plan.stats["fallback"] == ""
    return fat, full, ref


def test_drive_plan_without_a_binding_rms_row_is_the_full_problems(compiled, robot):
    """teachbot6's motors run far below their RMS rating on W3 (0.25 of it, measured): the
    plan solved without the RMS row, the row checked at its optimum, has the duration of the
    full problem's plan (fatrop with the row, and IPOPT), within the envelope and the
    rating by the independent drive check."""
    fat, full, ref = _three_ways(robot, W3, **DRIVE_ACC)
    assert fat.stats["drive_rms"] == "inactive, checked"
    assert full.stats["drive_rms"] == ref.stats["drive_rms"] == "solved with the RMS row"
    for other in (full, ref):
        assert fat.stats["duration_s"] == pytest.approx(other.stats["duration_s"], rel=1e-6)
    assert fat.stats["ok"] and fat.report.ok(1e-6) and _drive_ok(fat)
    assert max(fat.stats["drive_ratios"]["motor_rms"]) < 0.5


def _weak_rms(robot, plan, factor: float):
    """``robot`` with the continuous rating of the motor that ``plan`` loads most (RMS over
    rating) lowered to ``1 / factor`` of that plan's RMS torque; the peak rating kept (the
    envelope unchanged): on ``plan``'s path the RMS row then binds."""
    import dataclasses

    rms = np.asarray(plan.stats["drive_ratios"]["motor_rms"])
    j = int(np.argmax(rms))
    name = robot.joint_names[j]
    d = robot.drives[name]
    motor = dataclasses.replace(
        d.motor,
        stall_torque_Nm=d.motor.stall_torque_Nm * rms[j] / factor,
        peak_torque_Nm=d.peak_motor_torque_rating_Nm,
    )
    weak = robot.copy()
    weak.drives = {**robot.drives, name: dataclasses.replace(d, motor=motor)}
    assert weak.drives[name].peak_motor_torque_Nm == pytest.approx(d.peak_motor_torque_Nm)
    return weak, j


def test_drive_plan_with_a_binding_rms_row_is_the_full_problems(compiled, robot):
    """A motor whose RMS rating the plan without the RMS row would exceed by 10 %: the plan
    is re-solved with the row (stats say so) and is the full problem's (fatrop with the row
    from the start, IPOPT): the same duration, the RMS at its rating (the row binds) and
    every limit held by the independent drive check. (At 30 % over, IPOPT's back-off ends
    in another local optimum, 1.2e-4 longer than both fatrop plans, which agree to 1.5e-8,
    measured.)"""
    from armlab.planning.timescale import drive_check
    from armlab.robot import drivetrain

    base = optimal(robot, W3, **DRIVE_ACC)
    weak, j = _weak_rms(robot, base, 1.1)
    train = drivetrain.drive_train(weak)
    over = drive_check(base, weak, train, base.duration / 4000)["motor_rms"][j]
    assert over == pytest.approx(1.1, rel=1e-3)  # the optimum without the row breaks it
    fat, full, ref = _three_ways(weak, W3, **DRIVE_ACC)
    assert fat.stats["drive_rms"] == "re-solved with the RMS row"
    for other in (full, ref):
        assert fat.stats["duration_s"] == pytest.approx(other.stats["duration_s"], rel=1e-6)
    assert fat.stats["ok"] and fat.report.ok(1e-6) and _drive_ok(fat)
    rms = drive_check(fat, weak, train, fat.duration / 4000)["motor_rms"]
    assert 0.99 < rms[j] <= 1 + 1e-6


def _rms_row_by_hand(robot, prob, x) -> np.ndarray:
    """The RMS row of a plan written out here: the trapezoid sum of the smoothed motor torque
    squared over its points (both ends of every interval in acceleration mode, the knots in
    jerk mode), over the elapsed time and the continuous rating squared
    (transcription._drive_rows' formula: ``T_m = tau_out / N (eta_b + (1 / eta - eta_b) p) +
    J N qdd + b_m N qd``, ``tau_out = tau + F_c s + F_v qd``, ``p = 1 - s^2 (1 - logistic(s
    tau_out / eps))``, ``eps`` 1 % of the available joint torque)."""
    from armlab.robot import drivetrain, rigid_body

    n = prob.n
    st = fatrop_backend.layout_structure(prob, torque_rows=True)
    q, v, a, u, h = prob._unpack(st, x)
    s = prob.node_directions()  # (N + 1, n)
    if prob.mode == "jerk":
        Q, V, A, S = q, v, a, s
        w = np.append(h, 0.0) / 2 + np.insert(h, 0, 0.0) / 2
    else:
        Q, V, A = np.vstack([q[:-1], q[1:]]), np.vstack([v[:-1], v[1:]]), np.vstack([u, u])
        S, w = np.vstack([s[:-1], s[1:]]), np.concatenate([h, h]) / 2
    train = drivetrain.drive_train(robot)
    ratio, eta, eta_b, J, b_m, f_c, f_v = train.symbolic_coefficients()[:, :7].T
    eps = 1e-2 * train.available_joint_torque_Nm
    tau_out = rigid_body.inverse_dynamics(robot, Q, V, A) + f_c * S + f_v * V
    p = 1 - S**2 * (1 - 1 / (1 + np.exp(-S * tau_out / eps)))
    t_m = tau_out / ratio * (eta_b + (1 / eta - eta_b) * p) + J * ratio * A + b_m * ratio * V
    assert t_m.shape == (w.size, n)
    return (w @ t_m**2) / (h.sum() * train.continuous_motor_torque_Nm**2)


@pytest.mark.parametrize(("w", "kw"), [(W3, DRIVE_ACC), (W2, {"drive_limits": True})])
def test_rms_row_is_the_rows_formula(compiled, robot, w, kw):
    """The RMS row the optimum without it is checked with (``fatrop_backend.rms_row``, from
    the row's own CasADi expression) against the row written out by hand, in both modes;
    the RMS rating enters squared, so a back-off scale of the rating s divides it by s^2."""
    from armlab.planning import optimal_bounds

    prob = build_optimal(robot, w, **kw)
    prob.solve()
    x = prob.solution_x
    st = fatrop_backend.layout_structure(prob, torque_rows=True)
    ones = np.ones(prob.n)
    p = optimal_bounds.params(prob, prob.limits, (ones, ones), st=st)
    row = fatrop_backend.rms_row(prob, st, x, p)
    np.testing.assert_allclose(row, _rms_row_by_hand(robot, prob, x), rtol=1e-9)
    assert 0.01 < float(np.max(row)) < 1  # a plan well inside the rating (0.07 of it squared)
    half = optimal_bounds.params(prob, prob.limits, (ones, 0.5 * ones), st=st)
    np.testing.assert_allclose(fatrop_backend.rms_row(prob, st, x, half), 4 * row, rtol=1e-12)


def _jerk_integral(traj, robot) -> float:
    """Integral of the squared jerk over the jerk limit (the "jerk" objective, by the
    trapezoid rule on a fine grid, independent of the optimiser's own sum)."""
    t = np.linspace(traj.t[0], traj.t[-1], 20001)
    jerk = traj.at(t)[3] / robot.limits.jerk_rad_s3
    return float(np.trapezoid(np.sum(jerk**2, axis=1), t))


def test_fixed_duration_plans_as_ipopt(compiled, robot):
    """The "jerk" objective over a fixed duration (the elapsed time a state, its terminal row
    the duration): that duration, the same minimum as IPOPT's."""
    kw = {"objective": "jerk", "duration": 4.0}
    with pytest.MonkeyPatch.context() as mp:
        fat = optimal(robot, W3, **kw)
        ref = _ipopt(mp, robot, W3, **kw)
    assert fat.stats["solver"] == "fatrop" and fat.stats["fallback"] == ""
    assert fat.stats["duration_s"] == pytest.approx(4.0, rel=1e-6)
    assert _jerk_integral(fat, robot) == pytest.approx(_jerk_integral(ref, robot), rel=1e-5)
    assert fat.stats["ok"]


@pytest.mark.parametrize(
    ("w", "kw"),
    [
        (W3, {}),  # jerk mode on the robot's torque box
        (W2, {"payload_kg": 1.0, "tau_max": False}),  # no torque rows: the same library
    ],
)
def test_energy_plans_as_ipopt(compiled, robot, w, kw):
    """The "energy" objective (copper losses over a fixed duration) on fatrop: exactly that
    duration, the same minimum as IPOPT's (stats["energy"], the fine-grid trapezoid of
    optimal_problem, not the solver's own sum), every limit held on the fine grid."""
    kw = {"objective": "energy", "duration": 4.0, **kw}
    with pytest.MonkeyPatch.context() as mp:
        fat = optimal(robot, w, **kw)
        ref = _ipopt(mp, robot, w, **kw)
    assert fat.stats["solver"] == "fatrop" and fat.stats["fallback"] == ""
    assert fat.stats["duration_s"] == pytest.approx(4.0, abs=1e-9)
    # IPOPT's plan may be stretched by its tolerance (4.0000000073 s, measured), its energy
    # then that much lower: within 1e-8 relative on W3 (measured)
    assert fat.stats["energy"] == pytest.approx(ref.stats["energy"], rel=1e-6)
    assert fat.stats["ok"] and fat.report.ok(1e-6)
    np.testing.assert_allclose(fat.q[-1], w[-1], atol=1e-9)


@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"j_max": False},
        {"drive_limits": True},
        {"a_max": False, "j_max": False, "drive_limits": True},
    ],
)
def test_energy_stage_cost_is_the_transcriptions(robot, kw):
    """The energy variants' stage costs (symbolic, nothing compiled) summed over the stages
    equal IPOPT's objective (build_structure's copper-loss quadrature) times fatrop's weight,
    at a point away from the warm start (inputs and durations perturbed; in jerk mode the
    interior nodes too, the last node's state fixed as its bounds fix it; in acceleration
    mode the nodes integrated from the inputs, as the dynamics hold them)."""
    prob = build_optimal(robot, W3, n_intervals=4, objective="energy", duration=3.0, **kw)
    prob.make_warm_start()
    var = fatrop_backend.variant(prob)
    assert var.energy and var.duration
    st, spot = fatrop_backend._layout(prob, True, var)
    _, _, _, (Pk, pg, _, _), arm, _ = fatrop_backend._stage_data(
        prob, st, spot, var, prob.limits, prob.x0, None
    )
    p, xs = arm[4], arm[5].copy()
    n, N, S = prob.n, prob.N, st.slices
    rng = np.random.default_rng(3)
    for name in ("q", "v", "a"):  # interior nodes
        if name in S:
            block = xs[S[name]].reshape(N + 1, n)
            block[1:-1] += 0.1 * rng.standard_normal((N - 1, n))
    xs[S["u"]] += 0.1 * rng.standard_normal(N * n)
    xs[S["T"]] *= 1 + 0.1 * rng.random(len(prob.segment_intervals))
    seg = prob.segment_of_interval
    nseg = len(prob.segment_intervals)
    o = 3 * n + 1  # the scales in p (optimal_bounds.params)
    s_v, s_u, s_T = p[o : o + n], p[o + 2 * n : o + 3 * n], p[o + 3 * n : o + 3 * n + nseg]
    Ts = xs[S["T"]]
    h = (Ts * s_T)[seg] * prob.fractions
    if not var.jerk:
        # acceleration mode: the interval's right end is the next node in the transcription,
        # the integration of the left one in the stage; equal on the dynamics, so integrate
        q, v = xs[S["q"]].reshape(N + 1, n), xs[S["v"]].reshape(N + 1, n) * s_v
        u = xs[S["u"]].reshape(N, n) * s_u
        for k in range(N):
            q[k + 1] = q[k] + h[k] * v[k] + h[k] ** 2 / 2 * u[k]
            v[k + 1] = v[k] + h[k] * u[k]
        xs[S["q"]], xs[S["v"]] = q.ravel(), (v / s_v).ravel()
    # the stage vectors of that point (fatrop_stages' module docstring)
    s_e = float(np.sum(s_T))
    dm = var.dims(n)
    X = np.zeros((N + 1, dm["nx"]))
    for i, name in enumerate(k for k in ("q", "v", "a") if k in S):
        X[:, i * n : (i + 1) * n] = xs[S[name]].reshape(N + 1, n)
    X[:, dm["it"]] = np.append(Ts[seg], Ts[-1])
    X[:, -1] = np.concatenate([[0.0], np.cumsum(h)]) / s_e  # elapsed time
    if var.jerk:  # hp, the last interval, after the drive rows' RMS integrals
        X[1:, dm["it"] + 1 + (n if var.drive else 0)] = h / s_e
    U = np.zeros((N, dm["nu"]))
    U[:, :n] = xs[S["u"]].reshape(N, n)
    stage = fatrop_stages._symbolic_stage(robot, var)
    cost = ca.Function("cost", [stage[k] for k in ("x", "u", "pk", "pg")], [stage["cost"]])
    fatrop_sum = sum(float(cost(X[k], U[k], Pk[k], pg)) for k in range(N))
    real = structure(
        robot, 6, prob.segment_intervals, prob.mode, "energy", True, True, 100, var.drive
    )
    f = ca.Function("f", [real.nlp["x"], real.nlp["p"]], [real.nlp["f"]])
    weight = pg[5 * n]  # 1 over the warm start's energy
    assert fatrop_sum == pytest.approx(weight * float(f(xs, p)), rel=1e-12)
    assert abs(fatrop_sum - 1.0) > 1e-3  # away from the warm start (where it is 1)


def test_the_payload_is_run_time_data(compiled, robot):
    """A payload changes the inertias, not the kinematics: the same library plans it (one
    library of the variant in the cache) and the plan carries it: the torques the plan
    reports grow with it (W3 is speed-bound, so the duration need not change)."""
    light = optimal(robot, W3)
    before = sorted(compiled.parent.iterdir())
    heavy = optimal(robot, W3, payload_kg=1.5)
    assert heavy.stats["solver"] == "fatrop"
    peak = [max(t.report.ratios["torque"]) for t in (light, heavy)]
    assert peak[1] > 1.5 * peak[0]  # 0.30 -> 0.71 of the torque limits, measured
    assert sorted(compiled.parent.iterdir()) == before  # nothing compiled for the payload


@pytest.mark.parametrize(
    ("mode", "objective", "drive", "duration"),
    [
        ("jerk", "time", False, False),
        ("acceleration", "time", False, False),
        ("acceleration", "time", True, False),
        ("jerk", "time", True, False),
        ("jerk", "jerk", False, True),
        ("jerk", "energy", False, True),
        ("acceleration", "energy", True, True),
    ],
)
def test_layout_is_the_transcriptions(robot, mode, objective, drive, duration):
    """fatrop's light layout repeats build_structure's variable slices and row order (what
    optimal_bounds reads), in every variant."""
    kw = {"j_max": False} if mode == "acceleration" else {}
    if duration:
        kw.update(objective=objective, duration=3.0)
    prob = build_optimal(robot, W3, n_intervals=4, drive_limits=drive, **kw)
    prob.make_warm_start()
    assert prob.mode == mode
    real = structure(robot, 6, prob.segment_intervals, mode, objective, True, duration, 100, drive)
    light = fatrop_backend.layout_structure(prob, True)
    assert light.slices == real.slices and light.nx == real.nx
    np.testing.assert_array_equal(light.g_kind, real.g_kind)
    np.testing.assert_array_equal(light.g_joint, real.g_joint)
    if drive:
        np.testing.assert_array_equal(light.g_tag, real.g_tag)
        np.testing.assert_array_equal(light.g_col, real.g_col)
        assert light.n_drive_columns == real.n_drive_columns


@pytest.mark.parametrize("kw", [{}, {"objective": "energy", "duration": 4.0}])
def test_no_compiler_falls_back_to_ipopt(robot, tmp_path, kw):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("ARMLAB_CACHE_DIR", str(tmp_path))
        mp.setenv("ARMLAB_SOLVER", "fatrop")
        mp.setenv("CC", "/nonexistent/cc")
        traj = optimal(robot, W2, **kw)
        ref = _ipopt(mp, robot, W2, **kw)
    assert traj.stats["solver"] == "ipopt"
    assert "no C compiler" in traj.stats["fallback"]
    assert traj.stats["duration_s"] == pytest.approx(ref.stats["duration_s"], rel=1e-9)
    if "energy" in kw:
        assert traj.stats["energy"] == pytest.approx(ref.stats["energy"], rel=1e-9)
    assert not list(tmp_path.iterdir())  # nothing half-built left behind


def test_forced_ipopt_and_uncovered_variants_say_so(robot, monkeypatch):
    monkeypatch.setenv("ARMLAB_SOLVER", "ipopt")
    assert optimal(robot, W2).stats["fallback"] == "ARMLAB_SOLVER=ipopt"
    monkeypatch.setenv("ARMLAB_SOLVER", "fatrop")
    lbfgs = optimal(robot, W2, hessian="limited-memory")
    assert lbfgs.stats["solver"] == "ipopt" and "limited-memory" in lbfgs.stats["fallback"]


def test_watchdog_hands_the_solve_to_ipopt(compiled, robot, monkeypatch):
    """A budget the solve cannot meet: fatrop stops, IPOPT plans, stats say why; the next
    call with the normal budget is fatrop's again (the aborted instance is not reused)."""
    monkeypatch.setattr(fatrop_backend, "WATCHDOG_BASE_S", 1e-9)
    monkeypatch.setattr(fatrop_backend, "WATCHDOG_PER_INTERVAL_S", 0.0)
    slow = optimal(robot, W3)
    assert slow.stats["solver"] == "ipopt" and "watchdog" in slow.stats["fallback"]
    monkeypatch.undo()
    again = optimal(robot, W3)
    assert again.stats["solver"] == "fatrop"
    assert again.stats["duration_s"] == pytest.approx(slow.stats["duration_s"], rel=1e-6)


def test_cache_key_follows_the_kinematics(compiled, robot, monkeypatch):
    """Same kinematics, same key (payload included); another tree or casadi, another key."""
    key = fatrop_stages.library_key(robot)
    assert fatrop_stages.library_key(robot.with_payload(2.0)) == key
    other = armlab.load_robot("erd:z1_description/urdf/z1.urdf")
    assert fatrop_stages.library_key(other) != key
    monkeypatch.setattr(fatrop_stages.ca, "__version__", "0.0.0-test", raising=False)
    assert fatrop_stages.library_key(robot) != key
    monkeypatch.undo()
    monkeypatch.setattr(fatrop_stages, "_glue_source", lambda: "/* another glue */")
    assert fatrop_stages.library_key(robot) != key


def test_cache_dir_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv("ARMLAB_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert fatrop_stages.cache_dir() == tmp_path / "armlab"
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path / "own"))
    assert fatrop_stages.cache_dir() == tmp_path / "own"


def test_line_rows_switched_off_only_where_the_peak_binds(robot):
    """drive_limits: a voltage-line row is switched off only where the velocity bounds keep the
    motor below the speed at which its line falls under the peak torque (the drive-train
    model's envelope is the peak there), so the feasible set is the same; at a joint whose
    line crosses its peak within its speed limit (joint 6: at 1.3 % of its no-load speed) the
    line rows of moving columns stay on."""
    from armlab.planning import optimal_bounds
    from armlab.robot import drivetrain

    prob = build_optimal(robot, W3, n_intervals=8, a_max=False, j_max=False, drive_limits=True)
    prob.make_warm_start()
    st, _ = fatrop_backend._layout(prob, False, fatrop_backend.variant(prob))
    _, _, lbg, ubg = optimal_bounds.bounds(prob, st, prob.limits, implied_off=True)
    env = np.flatnonzero(st.g_kind == "motor_envelope")
    tag, j, col = st.g_tag[env].astype(str), st.g_joint[env], st.g_col[env]
    on = np.isfinite(lbg[env]) | np.isfinite(ubg[env])
    line = np.char.startswith(tag, "A")
    off = line & ~on & (np.char.find(tag, "2") == 1)  # back-driven rows: on unless implied
    assert off.any() and (line & on).any()
    node = prob.column_nodes()[col[off]]
    sig = prob.node_directions()
    top = np.where(sig[node, j[off]] == 0, 0.0, robot.limits.velocity_rad_s[j[off]])
    train = drivetrain.drive_train(robot)
    w_top = np.zeros((off.sum(), robot.n_joints))
    w_top[np.arange(off.sum()), j[off]] = top * train.ratio[j[off]]
    peak = train.peak_motor_torque_Nm[j[off]]
    np.testing.assert_allclose(
        drivetrain.envelope_torque(w_top, train)[np.arange(off.sum()), j[off]], peak, rtol=1e-12
    )
    moving = (
        (sig[prob.column_nodes()[col], j] != 0) & (j == 5) & line & (np.char.find(tag, "2") == 1)
    )
    assert moving.any() and on[moving].all()
