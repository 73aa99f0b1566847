"""Optimal trajectories against their peers (issue 5), one process, seeded random cases.

1. Rest-to-rest PTP with velocity/acceleration/jerk limits: ``armlab.trajectory.optimal``
   (torque off, so both use exactly Ruckig's limit set) vs Ruckig. Goal: duration ratio median
   <= 1.005, never above 1.02.
2. A 5-waypoint joint path with velocity/acceleration/torque limits vs TOPP-RA on the same
   cubic spline (chord-length parameter, not-a-knot): ``time_optimal_path`` (same path) and
   ``optimal`` (free path through the same via points). Goal: ratio <= 1.00, both checked on
   the same fine grid (dt = T/4000, our ``Trajectory.check_limits``). A path TOPP-RA finds no
   parameterisation for is counted as its failure and left out of the ratios (its log warnings
   are silenced: ``quiet_toppra``).
3. The full problem with all four limits (no peer does it): success rate and solve time over
   random 3-waypoint requests. Goal: 100 % success, median solve < 1 s on one core.
4. The rest-to-rest v/a/j PTP in closed form (``synchronised_scurves``) vs Ruckig: the same
   durations, time per problem (goal <= 10 x Ruckig: met by the scalar copy of the engine that
   issue 23 removed; the one numpy engine took ~40 x, ~20-25 x with issue 26's kernels, and
   4-6 x since one problem is one CasADi graph of the same formulas, ``profiles.graph``,
   compiled first: :func:`graph_ready`) and batched rate (goal >= 100 000/s; each case's fastest
   of ``CALLS_REPEATS`` runs);
   ``--scurves-only`` runs this table alone.
5. ``optimal`` solve time by waypoint count (2, 5, 10, 20; teachbot6, its own limits, random
   waypoints in 70 % of the ranges), v/a/j and v/a/j/tau, with the settings before issue 15
   (``hessian="exact"``, cold back-off re-solves, MUMPS's automatic ordering), the previous
   defaults (``"partial"``, warm re-solves, automatic ordering) and today's (the same with the
   AMF ordering, ``transcription.MUMPS_PIVOT_ORDER``): median / max IPOPT time, wall per call,
   success rate and the largest duration change from "before". Goals (issue 15): v/a/j/tau
   median <= 50 ms at 5 waypoints, <= 300 ms at 20, 100 % success, durations within 0.5 %;
   ``--optimal-scaling-only`` runs this table alone. IPOPT is forced (``ARMLAB_SOLVER=ipopt``):
   these are its settings; the default solver (fatrop) is timed in section 7. (2 waypoints
   v/a/j are planned in closed form whatever the solver.)
6. ``optimal`` success on random problems (issues 15, 26): ``--success N`` (default 1000, 20
   with ``--quick``) random 5-waypoint v/a/j/tau problems on teachbot6 (its own limits,
   waypoints in 70 % of the ranges), each planned twice, by the default solver (fatrop where it
   applies) and by IPOPT (``ARMLAB_SOLVER=ipopt`` around the call), and classified per solver:
   planned within every limit (``check_limits`` at ``T/4000``, 1e-9), refused by name as
   *provably* infeasible (gravity alone at a waypoint over a torque limit, by ``pinocchio``;
   these draws are run but not counted among the ``N``), or a failure (a refusal not proved, an
   unnamed error, a plan over a limit), each failure named by its case index; how many of the
   default solver's plans fell back to IPOPT (``stats["solver"]``, ``stats["fallback"]``); the
   largest duration difference between the two on the same case; median / p90 / max solve time
   per solver. Goals: 100 % for each, durations within 1e-6 s. ``--success-only`` runs this
   table alone (~10 min for 1000 on a shared 2-core machine: run it with ``nice -n 19``;
   ``--success-json PATH`` keeps every case).
7. The whole ``optimal()`` call (issue 26): at 2/5/10/20 waypoints (teachbot6, v/a/j/tau) the
   median and p90 of the call and of the solve and the solver that gave the plans
   (``stats["solver"]``, fallbacks named), the first call on a waypoint count over a repeat
   (in a fresh process, after a plan of another size), TOPP-RA (v/a/torque) on the same
   waypoints where installed (its failures counted, their times left out); 2 waypoints v/a/j
   (``optimal``'s closed form, ``ptp_sync``) per call against Ruckig; ``drive_limits=True``
   over the torque box. Goals (issue 26): whole call <= 15x TOPP-RA at 5 waypoints, 20
   waypoints <= 6x the 5-waypoint time, 2-waypoint v/a/j <= 10x Ruckig, first call <= 3x a
   repeat, drive-limited <= 2x the torque box: a table of each goal's ratio now, at 91f2439
   (``BEFORE_91F2439``, stated, not re-measured) and met / not met. Every case is timed
   ``CALLS_REPEATS`` (3) times and its fastest run kept, ours and the peers alike, before the
   median over cases: with one run per case a loaded 2-core machine moved the 20/5 ratio
   between 3.7x and 6.3x. ``--calls-only`` runs this table alone.

Run:  ``MPLBACKEND=Agg .venv/bin/python benchmarks/bench_trajectory.py [--quick]``
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from contextlib import contextmanager  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402
from _readme import readme_row, sig  # noqa: E402

import armlab  # noqa: E402
from armlab.errors import ArmlabError, InfeasibleError  # noqa: E402
from armlab.planning.topp import GeometricPath, build_topp  # noqa: E402
from armlab.trajectory import Trajectory, optimal, time_optimal_path  # noqa: E402

# ----------------------------------------------------------------------------- parameters
SEED = 20240605
ROBOTS = {
    # name: (load argument, payload_kg, extra limits for plain URDFs)
    "teachbot6": ("teachbot6", None, {}),
    "ur5": ("ur5", 5.0, {"a_max": 8.0, "j_max": 80.0}),
}
#: the full problem: faster drives than the thesis' so that torque limits bind in some cases
FULL_LIMITS = {
    "teachbot6": {"v_max": 2.0, "a_max": 15.0, "j_max": 150.0},
    "ur5": {"a_max": 15.0, "j_max": 150.0},
}
CASES = {"ptp": 20, "topp": 10, "full": 50}  # per robot
QUICK = {"ptp": 4, "topp": 2, "full": 5}
RANGE_FRACTION = 0.8  # waypoints drawn in this central fraction of each joint range ...
RANGE_CAP_RAD = np.pi  # ... and within +-pi
STATIC_MARGIN = 0.9  # reject waypoints whose gravity torque exceeds this fraction of effort
FULL_WAYPOINTS = 3
TOPP_WAYPOINTS = 5
TOPP_STEP_RAD = 0.6  # max joint step between consecutive path waypoints
CHECK_SAMPLES = 4000


#: the UR5 of the example-robot-data wheel (a test dependency; data only, no Python module)
UR5 = "erd:ur_description/urdf/ur5_robot.urdf"


def load(name: str):
    arg, payload, extra = ROBOTS[name]
    robot = armlab.load_robot(UR5 if arg == "ur5" else arg)
    if payload is not None:
        robot = robot.with_payload(payload)
    return robot, extra


def limits_of(robot, extra):
    L = robot.limits
    v = np.full(robot.n_joints, extra["v_max"]) if "v_max" in extra else L.velocity_rad_s
    a = np.full(robot.n_joints, extra["a_max"]) if "a_max" in extra else L.acceleration_rad_s2
    j = np.full(robot.n_joints, extra["j_max"]) if "j_max" in extra else L.jerk_rad_s3
    return v, a, j, L.effort_Nm


def statically_ok(robot, q) -> bool:
    g = pin.computeGeneralizedGravity(robot.model, robot.model.createData(), q)
    return bool(np.all(np.abs(g) <= STATIC_MARGIN * robot.limits.effort_Nm))


def draw_q(robot, rng):
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    mid, half = (lo + hi) / 2, np.minimum((hi - lo) / 2 * RANGE_FRACTION, RANGE_CAP_RAD)
    return mid + half * (2 * rng.random(robot.n_joints) - 1)


def draw_waypoints(robot, rng, n, step=None):
    while True:
        w = [draw_q(robot, rng)]
        for _ in range(n - 1):
            q = (
                draw_q(robot, rng)
                if step is None
                else w[-1] + rng.uniform(-step, step, robot.n_joints)
            )
            w.append(np.clip(q, robot.limits.lower_rad + 1e-3, robot.limits.upper_rad - 1e-3))
        ws = np.array(w)
        if all(statically_ok(robot, q) for q in ws):
            return ws


# ----------------------------------------------------------------------------- 1. Ruckig
def bench_ruckig(robot, extra, rng, n):
    from ruckig import InputParameter, Ruckig
    from ruckig import Trajectory as RTrajectory

    v, a, j, _ = limits_of(robot, extra)
    nj = robot.n_joints
    ratios, ours_t, peer_t, ok = [], [], [], 0
    for _ in range(n):
        w = draw_waypoints(robot, rng, 2)
        t0 = time.perf_counter()
        tr = optimal(robot, w, v_max=v, a_max=a, j_max=j, tau_max=False)
        ours_t.append(time.perf_counter() - t0)
        ok += tr.report.ok(1e-6)
        otg, inp, rt = Ruckig(nj), InputParameter(nj), RTrajectory(nj)
        inp.current_position, inp.target_position = w[0].tolist(), w[1].tolist()
        inp.current_velocity = inp.current_acceleration = [0.0] * nj
        inp.target_velocity = inp.target_acceleration = [0.0] * nj
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = v.tolist(), a.tolist(), j.tolist()
        t0 = time.perf_counter()
        otg.calculate(inp, rt)
        peer_t.append(time.perf_counter() - t0)
        ratios.append(tr.duration / rt.duration)
    return dict(
        ratios=np.array(ratios),
        ours_t=np.array(ours_t),
        peer_t=np.array(peer_t),
        ok=ok,
        peer_ok=n,
        n=n,
    )


# ----------------------------------------------------------------------------- 2. TOPP-RA
_TOPPRA_LOGGING: list[str] = []  # the level set by quiet_toppra (once per process)


def quiet_toppra(level: str = "ERROR") -> None:
    """TOPP-RA's own logging (``toppra.setup_logging``, which adds a console handler at each
    call) set once per process at ``level``: its warning per failed parameterisation ("The
    controllable set at step [i / N] can't be computed", "Fail to parametrize path") is not
    printed; the benchmarks count TOPP-RA's failures instead (``compute_trajectory`` returns
    None)."""
    import toppra as ta

    if not _TOPPRA_LOGGING:
        ta.setup_logging(level)
        _TOPPRA_LOGGING.append(level)


def toppra_problem(robot, w, v, a, tau):
    """TOPP-RA's path (the same spline and parameter as ours) and its velocity, acceleration
    and torque constraints; also used by ``bench_topp.py``."""
    import toppra as ta
    import toppra.constraint as constraint

    quiet_toppra()
    gp = GeometricPath(w, robot.n_joints)  # the same spline and parameter as ours
    path = ta.SplineInterpolator(gp.s_points, w, bc_type="not-a-knot")
    data = robot.model.createData()

    def inv_dyn(q, qd, qdd):
        return pin.rnea(robot.model, data, q, qd, qdd)

    cons = [
        constraint.JointVelocityConstraint(v),
        constraint.JointAccelerationConstraint(a),
        constraint.JointTorqueConstraint(
            inv_dyn, np.vstack([-tau, tau]).T, np.zeros(robot.n_joints)
        ),
    ]
    return path, cons


def toppra_solve(robot, w, v, a, tau):
    import toppra.algorithm as algo

    path, cons = toppra_problem(robot, w, v, a, tau)
    t0 = time.perf_counter()
    inst = algo.TOPPRA(cons, path, parametrizer="ParametrizeConstAccel")
    jt = inst.compute_trajectory(0, 0)
    elapsed = time.perf_counter() - t0
    if jt is None:
        return None, elapsed
    T = jt.duration
    t = np.linspace(0, T, CHECK_SAMPLES + 1)
    traj = Trajectory(t, jt(t), jt(t, 1), jt(t, 2), joint_names=robot.joint_names, method="toppra")
    return traj, elapsed


def stretch_to_feasible(robot, traj, v, a, tau, iters: int = 30) -> float:
    """Smallest time-scaling factor alpha >= 1 making ``traj`` feasible on its samples
    (``qd / alpha``, ``qdd / alpha^2``, torques recomputed), by bisection."""
    data = robot.model.createData()

    def ok(alpha):
        if np.any(np.abs(traj.qd) / alpha > v * (1 + 1e-9)):
            return False
        if np.any(np.abs(traj.qdd) / alpha**2 > a * (1 + 1e-9)):
            return False
        for q, qd, qdd in zip(traj.q, traj.qd / alpha, traj.qdd / alpha**2, strict=True):
            if np.any(np.abs(pin.rnea(robot.model, data, q, qd, qdd)) > tau * (1 + 1e-9)):
                return False
        return True

    if ok(1.0):
        return 1.0
    lo, hi = 1.0, 1.05
    while not ok(hi):
        lo, hi = hi, hi * 1.05
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return hi


def bench_toppra(robot, extra, rng, n):
    v, a, _, tau = limits_of(robot, extra)
    lim = robot.with_limits(acceleration_rad_s2=a, jerk_rad_s3=None).limits
    out: dict[str, list] = {
        k: []
        for k in (
            "ratio_path",
            "ratio_free",
            "ours_t",
            "free_t",
            "peer_t",
            "ours_worst",
            "free_worst",
            "peer_worst",
            "ratio_stretched",
        )
    }
    failed = 0  # TOPP-RA found no parameterisation (its case left out of the ratios)
    for _ in range(n):
        while True:  # a path whose spline stays inside the joint ranges
            w = draw_waypoints(robot, rng, TOPP_WAYPOINTS, step=TOPP_STEP_RAD)
            try:
                build_topp(robot, w, v_max=v, a_max=a, j_max=False, tau_max=tau)
                break
            except InfeasibleError:
                continue
        peer, peer_t = toppra_solve(robot, w, v, a, tau)
        if peer is None:
            failed += 1
            continue
        rep = peer.check_limits(robot, dt=peer.duration / CHECK_SAMPLES, limits=lim)
        t0 = time.perf_counter()
        ours = time_optimal_path(robot, w, v_max=v, a_max=a, j_max=False, tau_max=tau)
        out["ours_t"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        free = optimal(robot, w, v_max=v, a_max=a, j_max=False, tau_max=tau)
        out["free_t"].append(time.perf_counter() - t0)
        out["peer_t"].append(peer_t)
        out["ratio_path"].append(ours.duration / peer.duration)
        out["ratio_free"].append(free.duration / peer.duration)
        alpha = stretch_to_feasible(robot, peer, v, a, tau)
        out["ratio_stretched"].append(ours.duration / (alpha * peer.duration))
        out["peer_worst"].append(max(float(np.max(r)) for r in rep.ratios.values()))
        for key, tr in (("ours_worst", ours), ("free_worst", free)):
            out[key].append(max(float(np.max(r)) for r in tr.report.ratios.values()))
    return {**{k: np.array(x) for k, x in out.items()}, "peer_failed": failed, "n": n}


# ----------------------------------------------------------------------------- 3. full
def bench_full(robot, extra, rng, n):
    v, a, j, tau = limits_of(robot, extra)
    solve, wall, ok, torque_bound, errors = [], [], 0, 0, []
    for _ in range(n):
        w = draw_waypoints(robot, rng, FULL_WAYPOINTS)
        t0 = time.perf_counter()
        try:
            tr = optimal(robot, w, v_max=v, a_max=a, j_max=j, tau_max=tau)
        except ArmlabError as exc:
            errors.append(str(exc))
            continue
        wall.append(time.perf_counter() - t0)
        solve.append(tr.stats["solve_time_s"])
        ok += tr.report.ok(1e-6)
        torque_bound += any(k == "torque" for k, _, _ in tr.stats["binding"])
    return dict(
        solve=np.array(solve),
        wall=np.array(wall),
        ok=ok,
        n=n,
        errors=errors,
        torque_bound=torque_bound,
    )


def graph_ready(n: int, which: str = "scurve") -> str:
    """A graph of ``n`` joints -- ``"scurve"``, the one-problem S-curve engine
    (:mod:`armlab.trajectory.profiles.graph`), or ``"closed"``, the 2-waypoint closed-form plan
    (:mod:`armlab.planning.closed_graph`) -- compiled now (once per machine: the cache) and in
    use, so that every timed call finds what a process' repeat calls find; its status
    (``"vm (...)"`` where there is no compiler)."""
    from armlab._cache import CompilerUnavailable
    from armlab.planning import closed_graph
    from armlab.trajectory.profiles import graph

    g = closed_graph if which == "closed" else graph
    try:
        g.compile_library(n)
    except CompilerUnavailable:
        pass
    status = g.prepare(n)
    end = time.monotonic() + 120.0
    while status == "vm, compiling" and time.monotonic() < end:  # a compile started earlier
        time.sleep(0.05)
        status = g.status(n)
    return status


# ----------------------------------------------------------------------------- 4. S-curves
SCURVE_PROBLEMS = 300  # single problems timed one by one against Ruckig
SCURVE_BATCH = 100_000  # problems per batched call


def bench_scurve_batch(quick: bool = False) -> list[dict]:
    """Rest-to-rest v/a/j PTP (2 waypoints) in closed form vs Ruckig (issue 15): duration
    agreement, time per single problem (ours: :func:`synchronised_scurves` of one problem;
    Ruckig: ``calculate`` alone, inputs set beforehand), and problems per second batched (ours:
    one call on ``(n_problems, n_joints)``; Ruckig: a Python loop). Goals: single <= 10 x
    Ruckig, batched >= 100 000 problems/s."""
    from ruckig import InputParameter, Ruckig
    from ruckig import Trajectory as RTrajectory

    from armlab.trajectory.profiles import synchronised_scurves

    n_single = 40 if quick else SCURVE_PROBLEMS
    n_batch = 10_000 if quick else SCURVE_BATCH
    print()
    print("closed-form synchronised S-curves vs Ruckig (2 waypoints, v/a/j, rest to rest)")
    hdr = (
        f"{'robot':<11}{'n':>7}  {'T ratio max|-1|':>15}  {'ours [us] med':>13}  "
        f"{'Ruckig [us] med':>15}  {'x Ruckig':>8}  {'batch [problems/s]':>18}  "
        f"{'Ruckig loop [problems/s]':>24}"
    )
    print(hdr)
    print("-" * len(hdr))
    results = []
    for name in ROBOTS:
        robot, extra = load(name)
        v, a, j, _ = limits_of(robot, extra)
        nj = robot.n_joints
        graph_ready(nj)  # the one-problem graph ready, as a process' repeat calls find it
        rng = np.random.default_rng(SEED + 4)
        W = np.array([[draw_q(robot, rng), draw_q(robot, rng)] for _ in range(n_single)])
        otg, inp, rt = Ruckig(nj), InputParameter(nj), RTrajectory(nj)
        inp.current_velocity = inp.current_acceleration = [0.0] * nj
        inp.target_velocity = inp.target_acceleration = [0.0] * nj
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = v.tolist(), a.tolist(), j.tolist()
        ours_t, peer_t, dev, peer_T = [], [], [], []
        for w in W:
            inp.current_position, inp.target_position = w[0].tolist(), w[1].tolist()
            t0 = time.perf_counter()
            otg.calculate(inp, rt)
            peer_t.append(time.perf_counter() - t0)
            d = (w[1] - w[0])[None]
            t0 = time.perf_counter()
            b = synchronised_scurves(d, v, a, j)
            ours_t.append(time.perf_counter() - t0)
            dev.append(abs(b.duration[0] / rt.duration - 1))
            peer_T.append(rt.duration)
        D = np.concatenate([W[:, 1] - W[:, 0]] * (n_batch // n_single + 1))[:n_batch]
        synchronised_scurves(D[:100], v, a, j)
        args = (D, v, a, j)
        batch_rate = n_batch / _fastest(lambda args=args: synchronised_scurves(*args))[0]
        t0 = time.perf_counter()
        for w in W:
            inp.current_position, inp.target_position = w[0].tolist(), w[1].tolist()
            otg.calculate(inp, rt)
        loop_rate = n_single / (time.perf_counter() - t0)
        med_o, med_p = np.median(ours_t) * 1e6, np.median(peer_t) * 1e6
        print(
            f"{name:<11}{n_single:>7}  {max(dev):>15.1e}  {med_o:>13.1f}  {med_p:>15.1f}  "
            f"{med_o / med_p:>8.1f}  {batch_rate:>18,.0f}  {loop_rate:>24,.0f}"
        )
        results.append(dict(ours_us=med_o, peer_us=med_p, batch=batch_rate, dev=max(dev)))
    return results


# ----------------------------------------------------------------------------- 5. scaling
SCALING_WAYPOINTS = (2, 5, 10, 20)
SCALING_CASES = 6  # per waypoint count and limit set
SCALING_RANGE = 0.7


def bench_optimal_scaling(quick: bool = False) -> dict:
    """``optimal`` on teachbot6 by waypoint count, before / after issue 15 (module docstring, 5),
    solved by IPOPT (``ARMLAB_SOLVER=ipopt``): the settings compared are IPOPT's (fatrop, the
    default since issue 26, is timed by section 7)."""
    with solver_env("ipopt"):
        return _scaling_ipopt(quick)


def _scaling_ipopt(quick: bool) -> dict:
    """The body of :func:`bench_optimal_scaling` (IPOPT forced around it)."""
    import importlib

    # the module whose solve reads WARM_RESOLVE
    optimal_module: Any = importlib.import_module("armlab.planning.optimal_problem")
    transcription: Any = importlib.import_module("armlab.planning.transcription")
    pivot_now = transcription.MUMPS_PIVOT_ORDER
    robot = armlab.load_robot("teachbot6")
    n_cases = 2 if quick else SCALING_CASES
    # name: (optimal() keywords, warm back-off re-solves, MUMPS ordering; 7 = MUMPS's choice)
    settings = {
        "before": ({"hessian": "exact"}, False, 7),
        "previous": ({}, True, 7),
        "after": ({}, True, pivot_now),
    }
    print()
    print(f"optimal() solve time by waypoint count (teachbot6, seed {SEED + 5:d})")
    hdr = (
        f"{'limits':<10}{'wp':>3}  {'settings':<9}{'n':>3}  {'ipopt [s] med':>13}  "
        f"{'max':>7}  {'wall [s] med':>12}  {'iter med':>8}  {'success':>7}  "
        f"{'T after/before - 1 max':>22}"
    )
    print(hdr)
    print("-" * len(hdr))
    # (limits, waypoints, settings): (median IPOPT time [s], successes, largest |T / T_before - 1|)
    results: dict = {"n_cases": n_cases}
    for kind, tau in (("v/a/j", False), ("v/a/j/tau", None)):
        for nw in SCALING_WAYPOINTS:
            cases = random_cases(robot, nw, n_cases, SEED + 5 + nw)
            durations = {}
            for name, (extra, warm, pivot) in settings.items():
                # before: a back-off re-solve started cold, as it did then
                optimal_module.WARM_RESOLVE = warm
                transcription.MUMPS_PIVOT_ORDER = pivot
                # the compiled problem is built once per size and settings: not timed
                optimal(robot, cases[0], tau_max=tau, **extra)
                solve, wall, iters, ok, T = [], [], [], 0, []
                for w in cases:
                    t0 = time.perf_counter()
                    try:
                        tr = optimal(robot, w, tau_max=tau, **extra)
                    except ArmlabError:
                        T.append(np.nan)
                        continue
                    wall.append(time.perf_counter() - t0)
                    solve.append(tr.stats["solve_time_s"])
                    iters.append(tr.stats["iterations"])
                    ok += bool(tr.stats["success"])
                    T.append(tr.stats["duration_s"])
                durations[name] = np.array(T)
                dev = ""
                if name != "before":
                    r = durations[name] / durations["before"] - 1
                    dev = f"{np.nanmax(np.abs(r)):.1e}"
                print(
                    f"{kind:<10}{nw:>3}  {name:<9}{n_cases:>3}  {np.median(solve):>13.3f}  "
                    f"{np.max(solve):>7.3f}  {np.median(wall):>12.3f}  {np.median(iters):>8.1f}  "
                    f"{ok:>3}/{n_cases:<3}  {dev:>22}",
                    flush=True,
                )
                results[(kind, nw, name)] = (float(np.median(solve)), ok, float(dev or 0.0))
    return results


# ----------------------------------------------------------------------------- 7. whole call
CALLS_CASES = 10  # timed calls per waypoint count (3 with --quick)
CALLS_PTP = 100  # 2-waypoint v/a/j problems timed against Ruckig (20 with --quick)
CALLS_DRIVE = 5  # 3-waypoint moves, drive-limited and torque box (2 with --quick)
#: section 7 times every case this many times and keeps its fastest run (``timeit``'s
#: convention: the run least disturbed by other processes on a shared machine), then takes the
#: median / p90 over the cases; the peers (TOPP-RA, Ruckig) are timed the same way
CALLS_REPEATS = 3
FIRST_WARMUP_WAYPOINTS = 3  # the first-call process plans this size first (not in the table)
#: measured at 91f2439 (main when issue 26 started, fatrop, this 2-core machine; the issue's
#: brief), kept as a stated row, not re-measured: whole call and TOPP-RA by waypoint count [ms]
#: (medians), first call over a repeat (worst size), 2-waypoint v/a/j per call [ms] and Ruckig
#: [us], drive_limits=True and the torque box on 3 waypoints [ms]
BEFORE_91F2439: dict[str, Any] = {
    "call_ms": {2: 43.0, 5: 81.0, 10: 202.0, 20: 404.0},
    "toppra_ms": {2: 4.1, 5: 15.0, 10: 33.0, 20: 68.0},
    "first": 1.53,
    "optimal_2wp_ms": 1.44,
    "ptp_sync_ms": 2.68,
    "ruckig_us": 8.6,
    "optimal_2wp_x": 168.0,
    "ptp_sync_x": 312.0,
    "drive_ms": 1367.0,
    "box_ms": 186.0,
    "drive_x": 9.0,  # the median of the per-move ratios (not the ratio of the medians)
}
#: the goals of issue 26: key, what, limit (the measured ratio must be <= it)
CALL_GOALS = (
    ("toppra5", "whole call / TOPP-RA at 5 waypoints", 15.0),
    ("scale20", "20-waypoint / 5-waypoint whole call", 6.0),
    ("optimal2", "2 wp v/a/j optimal() / Ruckig per call", 10.0),
    ("ptp2", "2 wp v/a/j ptp_sync(scurve) / Ruckig", 10.0),
    ("first", "first call on a new waypoint count / repeat", 3.0),
    ("drive", "drive_limits=True / torque box (3 wp)", 2.0),
)


def _before_ratios() -> dict[str, float]:
    """The goals' ratios at 91f2439 (:data:`BEFORE_91F2439`)."""
    b = BEFORE_91F2439
    return {
        "toppra5": b["call_ms"][5] / b["toppra_ms"][5],
        "scale20": b["call_ms"][20] / b["call_ms"][5],
        "optimal2": b["optimal_2wp_x"],
        "ptp2": b["ptp_sync_x"],
        "first": b["first"],
        "drive": b["drive_x"],
    }


def _fastest(fn, repeats: int = CALLS_REPEATS):
    """``(seconds, result)`` of the fastest of ``repeats`` calls of ``fn()``
    (:data:`CALLS_REPEATS`); an exception of the first call propagates."""
    best, out = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = fn()
        elapsed = time.perf_counter() - t0
        if elapsed < best:
            best, out = elapsed, r
    return best, out


def _med_p90(x) -> str:
    x = 1e3 * np.asarray(x, float)
    return f"{np.median(x):.0f} / {np.percentile(x, 90):.0f}" if x.size else "-"


def _solvers(stats: list[dict]) -> str:
    """Which solver gave the plans (``stats["solver"]``, or ``stats["method"]`` where it has no
    solver), e.g. ``fatrop`` or ``fatrop 8, ipopt 2``."""
    names = Counter(
        "closed form" if s.get("method") == "closed_form" else str(s.get("solver", "?"))
        for s in stats
    )
    if len(names) == 1:
        return next(iter(names))
    return ", ".join(f"{k} {v}" for k, v in names.most_common())


def random_cases(robot, nw: int, n: int, seed: int) -> list[np.ndarray]:
    """``n`` random ``nw``-waypoint problems: waypoints uniform in ``SCALING_RANGE`` of each
    joint range, each statically feasible (:func:`statically_ok`), drawn from ``seed`` (the same
    in every process). Sections 5 (seed ``SEED + 5 + nw``) and 7 (``SEED + 7 + nw``) and
    ``bench_fatrop.py`` draw their cases here."""
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * SCALING_RANGE
    rng = np.random.default_rng(seed)
    cases: list[np.ndarray] = []
    while len(cases) < n:
        w = mid + half * (2 * rng.random((nw, robot.n_joints)) - 1)
        if all(statically_ok(robot, q) for q in w):
            cases.append(w)
    return cases


def calls_cases(robot, nw: int, n: int) -> list[np.ndarray]:
    """``n`` random ``nw``-waypoint problems of section 7 (:func:`random_cases`, seed
    ``SEED + 7 + nw``)."""
    return random_cases(robot, nw, n, SEED + 7 + nw)


def first_call(nw: int, n: int) -> dict:
    """In a fresh process (``--first-call NW``): plan a ``FIRST_WARMUP_WAYPOINTS`` problem (the
    per-robot work: the compiled library loaded, the symbolic functions built), then time the
    first call on ``nw`` waypoints and ``n`` repeats of that size. Whatever a process keeps per
    waypoint count is thus paid by the first call, whatever its cache is named."""
    robot = armlab.load_robot("teachbot6")
    optimal(robot, calls_cases(robot, FIRST_WARMUP_WAYPOINTS, 1)[0])
    cases = calls_cases(robot, nw, n)
    t0 = time.perf_counter()
    tr = optimal(robot, cases[0])
    first = time.perf_counter() - t0
    repeat = []
    for w in cases:
        t0 = time.perf_counter()
        optimal(robot, w)
        repeat.append(time.perf_counter() - t0)
    solver = tr.stats.get("solver", "?")
    return {"first_s": first, "repeat_s": float(np.median(repeat)), "solver": solver}


def _first_call_subprocess(nw: int, n: int) -> dict:
    """:func:`first_call` in a fresh interpreter (this script with ``--first-call``)."""
    import json
    import subprocess
    import sys

    cmd = [sys.executable, __file__, "--first-call", str(nw), "--first-repeats", str(n)]
    out = subprocess.run(cmd, capture_output=True, text=True, check=False, env=os.environ)
    for line in out.stdout.splitlines():
        if line.startswith("FIRST-CALL\t"):
            return json.loads(line.split("\t", 1)[1])
    tail = (out.stderr or out.stdout).strip().splitlines()[-1:] or ["no output"]
    return {"first_s": np.nan, "repeat_s": np.nan, "solver": f"failed: {tail[0]}"}


def _peer_toppra(robot, w) -> float | None:
    """TOPP-RA's time [s] on ``w`` (v/a/torque, :func:`toppra_solve`), None when it finds no
    parameterisation (a failure of the peer: counted, its time left out)."""
    L = robot.limits
    try:
        traj, dt = toppra_solve(robot, w, L.velocity_rad_s, L.acceleration_rad_s2, L.effort_Nm)
    except Exception:  # noqa: BLE001 -- the peer failing is what is counted
        return None
    return None if traj is None else dt


def _calls_by_size(robot, n_cases: int, have_toppra: bool, res: dict) -> None:
    """The per-waypoint-count rows of section 7 into ``res[nw]``."""
    hdr = (
        f"{'wp':>3}{'n':>4}  {'call [ms] med/p90':>18}  {'solve [ms] med/p90':>19}  "
        f"{'solver':<16}{'first/repeat':>12}  {'TOPP-RA [ms] med':>16}  {'TOPP-RA failed':>14}  "
        f"{'call/TOPP-RA':>12}"
    )
    print(hdr)
    print("-" * len(hdr))
    b = BEFORE_91F2439
    for nw in SCALING_WAYPOINTS:
        cases = calls_cases(robot, nw, n_cases)
        optimal(robot, cases[0])  # this size's first call (timed apart, in a fresh process)
        call, solve, stats, peer, refused = [], [], [], [], 0
        for w in cases:
            try:
                elapsed, tr = _fastest(lambda w=w: optimal(robot, w))
            except ArmlabError:
                refused += 1
                continue
            dt = _fastest(lambda w=w: _peer_toppra(robot, w))[1] if have_toppra else None
            call.append(elapsed)
            solve.append(tr.stats["solve_time_s"])
            stats.append(tr.stats)
            if dt is not None:
                peer.append((elapsed, dt))
        fc = _first_call_subprocess(nw, min(n_cases, 5))
        ratio = fc["first_s"] / fc["repeat_s"]
        if have_toppra:
            pc = np.array(peer).reshape(-1, 2)
            peer_med = f"{1e3 * np.median(pc[:, 1]):.1f}" if len(pc) else "-"
            fails = f"{len(call) - len(pc)}/{len(call)}"
            vs = np.median(pc[:, 0]) / np.median(pc[:, 1]) if len(pc) else np.nan
        else:
            peer_med, fails, vs = "not installed", "-", np.nan
        used = _solvers(stats) + (f", {refused} refused" if refused else "")
        print(
            f"{nw:>3}{len(call):>4}  {_med_p90(call):>18}  {_med_p90(solve):>19}  {used:<16}"
            f"{ratio:>12.2f}  {peer_med:>16}  {fails:>14}  {vs:>11.1f}x",
            flush=True,
        )
        for why, k in Counter(s["fallback"] for s in stats if s.get("fallback")).items():
            print(f"{'':>9}fell back to IPOPT {k}x: {why}")
        if not str(fc["solver"]).startswith(("fatrop", "ipopt")):
            print(f"{'':>9}first-call process: {fc['solver']}")
        res[nw] = {
            "call": float(np.median(call)),
            "solve": float(np.median(solve)),
            "first": ratio,
            "toppra": float(np.median(np.array(peer)[:, 1])) if peer else np.nan,
            "vs_toppra": float(vs),
            "toppra_failed": len(call) - len(peer) if have_toppra else -1,
            "solver": used,
        }
    before = ", ".join(
        f"{nw} wp {b['call_ms'][nw]:.0f} ms (TOPP-RA {b['toppra_ms'][nw]:g})"
        for nw in SCALING_WAYPOINTS
    )
    print(f"measured at 91f2439 (not re-measured): {before}; first call <= {b['first']}x")


def _calls_ptp(robot, n: int, res: dict) -> None:
    """2 waypoints, v/a/j, no torque: ``optimal`` and ``ptp_sync(..., "scurve")`` per call
    against Ruckig's ``calculate`` (inputs set beforehand) on the same problems.

    Each call is timed in its own loop over the problems (each problem's fastest of
    :data:`CALLS_REPEATS` calls, then the median), as a process that plans one move after
    another runs it, and as Ruckig is timed: the headline ratios. The same ratio measured
    with the calls interleaved per problem (``optimal`` three times, then Ruckig three times,
    with ``ptp_sync`` and Ruckig's sampling between problems, each evicting the others' data
    from the caches) is printed beside it: it costs the Python calls more than Ruckig's."""
    from ruckig import InputParameter, Ruckig
    from ruckig import Trajectory as RTrajectory

    from armlab.planning import ptp_sync

    L = robot.limits
    v, a, j = L.velocity_rad_s, L.acceleration_rad_s2, L.jerk_rad_s3
    lo, hi = L.lower_rad, L.upper_rad
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * SCALING_RANGE
    rng = np.random.default_rng(SEED + 72)
    ws = [mid + half * (2 * rng.random((2, robot.n_joints)) - 1) for _ in range(n)]
    nj = robot.n_joints
    print(
        f"one-problem S-curve graph: {graph_ready(nj)}; closed-form plan graph: "
        f"{graph_ready(nj, 'closed')}"
    )
    optimal(robot, ws[0], tau_max=False)  # warm: imports, first calls
    ptp_sync(robot, ws[0][0], ws[0][1], "scurve", tau_max=False)

    def ruckig(w):
        otg, inp, rt = Ruckig(nj), InputParameter(nj), RTrajectory(nj)
        inp.current_position, inp.target_position = w[0].tolist(), w[1].tolist()
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = v.tolist(), a.tolist(), j.tolist()
        return otg, inp, rt

    rks = [ruckig(w) for w in ws]
    t_opt, trs = zip(
        *(_fastest(lambda w=w: optimal(robot, w, tau_max=False)) for w in ws), strict=True
    )
    stats = [tr.stats for tr in trs]
    t_ptp, ptps = zip(
        *(_fastest(lambda w=w: ptp_sync(robot, w[0], w[1], "scurve", tau_max=False)) for w in ws),
        strict=True,
    )
    t_rk = [_fastest(lambda r=r: r[0].calculate(r[1], r[2]))[0] for r in rks]
    # the same output: Ruckig's trajectory evaluated at the times our results hold (the
    # switching instants of optimal's, the dt grid of ptp_sync's)
    same = {
        key: [
            _fastest(lambda r=r, t=tr.t: _ruckig_sampled(*r, t.tolist()))[0]
            for r, tr in zip(rks, out, strict=True)
        ]
        for key, out in (("opt", trs), ("ptp", ptps))
    }
    mixed_opt, mixed_rk = [], []  # interleaved per problem (module docstring of this section)
    for w, r, tr in zip(ws, rks, ptps, strict=True):
        mixed_opt.append(_fastest(lambda w=w: optimal(robot, w, tau_max=False))[0])
        _fastest(lambda w=w: ptp_sync(robot, w[0], w[1], "scurve", tau_max=False))
        mixed_rk.append(_fastest(lambda r=r: r[0].calculate(r[1], r[2]))[0])
        _fastest(lambda r=r, t=tr.t: _ruckig_sampled(*r, t.tolist()))
    methods = Counter(str(s.get("method", "transcription")) for s in stats)
    method = ", ".join(f"{k} {c}" if len(methods) > 1 else k for k, c in methods.most_common())
    rk = float(np.median(t_rk))
    res["ptp"] = {
        "optimal_ms": 1e3 * float(np.median(t_opt)),
        "ptp_ms": 1e3 * float(np.median(t_ptp)),
        "ruckig_us": 1e6 * rk,
        "optimal2": float(np.median(t_opt)) / rk,
        "ptp2": float(np.median(t_ptp)) / rk,
        "optimal2_mixed": float(np.median(mixed_opt)) / float(np.median(mixed_rk)),
        "same_opt_us": 1e6 * float(np.median(same["opt"])),
        "same_ptp_us": 1e6 * float(np.median(same["ptp"])),
        "same_opt_x": float(np.median(np.array(t_opt) / np.array(same["opt"]))),
        "same_ptp_x": float(np.median(np.array(t_ptp) / np.array(same["ptp"]))),
        "method": method,
        "solver": _solvers(stats),
    }
    p, b = res["ptp"], BEFORE_91F2439
    print(
        f"2 wp v/a/j per call ({n} problems): optimal ({p['solver']}) "
        f"{1e3 * p['optimal_ms']:.1f} us = {p['optimal2']:.2f}x Ruckig, ptp_sync scurve "
        f"{1e3 * p['ptp_ms']:.0f} us = {p['ptp2']:.0f}x Ruckig ({p['ruckig_us']:.2f} us); "
        f"interleaved per problem: optimal {p['optimal2_mixed']:.2f}x Ruckig; at 91f2439 "
        f"{b['optimal_2wp_ms']} ms = {b['optimal_2wp_x']:.0f}x and {b['ptp_sync_ms']} ms = "
        f"{b['ptp_sync_x']:.0f}x (Ruckig {b['ruckig_us']} us)"
    )
    print(
        "the same output from Ruckig (calculate, then its state at each time our result holds, "
        f"from Python): at optimal's switching instants {p['same_opt_us']:.1f} us (optimal "
        f"{p['same_opt_x']:.2f}x that), on ptp_sync's dt grid {p['same_ptp_us']:.1f} us "
        f"(ptp_sync {p['same_ptp_x']:.2f}x that)"
    )


def _ruckig_sampled(otg, inp, rt, times: list[float]) -> np.ndarray:
    """Ruckig's ``calculate`` and its trajectory's position, speed and acceleration at
    ``times`` (``Trajectory.at_time``, one call a time: Ruckig's Python interface has no
    vectorised sampler), as one array ``(3, m, n_joints)``."""
    otg.calculate(inp, rt)
    return np.array([rt.at_time(t) for t in times]).transpose(1, 0, 2)


def _calls_drive(robot, n: int, res: dict) -> None:
    """``drive_limits=True`` over the torque box on the same 3-waypoint moves (v/torque,
    ``a_max=j_max=False`` as bench_drive_limits.py), repeats (each size planned once first)."""
    L = robot.limits
    lo, hi = L.lower_rad, L.upper_rad
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * SCALING_RANGE
    rng = np.random.default_rng(SEED + 73)
    box: list[float] = []
    drive: list[float] = []
    s_box: list[dict] = []
    s_drive: list[dict] = []
    kw = dict(a_max=False, j_max=False)
    for i in range(n):
        w = mid + 0.5 * half * (2 * rng.random((3, robot.n_joints)) - 1)
        if i == 0:
            optimal(robot, w, **kw)
            optimal(robot, w, drive_limits=True, **kw)
        for out, st, dl in ((box, s_box, False), (drive, s_drive, True)):
            elapsed, tr = _fastest(lambda w=w, dl=dl: optimal(robot, w, drive_limits=dl, **kw))
            out.append(elapsed)
            st.append(tr.stats)
    res["drive"] = {
        "ratio": float(np.median(np.array(drive) / np.array(box))),
        "drive_ms": 1e3 * float(np.median(drive)),
        "box_ms": 1e3 * float(np.median(box)),
        "solver": f"{_solvers(s_drive)} / {_solvers(s_box)}",
    }
    d, b = res["drive"], BEFORE_91F2439
    print(
        f"3 wp v/torque ({n} moves): drive_limits=True {_med_p90(drive)} ms, torque box "
        f"{_med_p90(box)} ms (med/p90; solvers {d['solver']}): drive / box median "
        f"{d['ratio']:.1f}x; at 91f2439 {b['drive_ms']:.0f} vs {b['box_ms']:.0f} ms"
    )


def calls_goals(res: dict) -> list[tuple[str, float, float, float, bool]]:
    """The goals of issue 26 (:data:`CALL_GOALS`): (what, limit, at 91f2439, now, met)."""
    now = {
        "toppra5": res[5]["vs_toppra"],
        "scale20": res[20]["call"] / res[5]["call"],
        "optimal2": res["ptp"]["optimal2"],
        "ptp2": res["ptp"]["ptp2"],
        "first": max(res[nw]["first"] for nw in SCALING_WAYPOINTS),
        "drive": res["drive"]["ratio"],
    }
    before = _before_ratios()
    return [(what, lim, before[k], now[k], bool(now[k] <= lim)) for k, what, lim in CALL_GOALS]


def bench_optimal_calls(quick: bool = False) -> dict:
    """The whole ``optimal()`` call by waypoint count (issue 26; module docstring, 7).

    teachbot6, its own v/a/j/tau limits, the waypoints of section 5 (70 % of the ranges): wall
    time of the whole call and the solve (median / p90, ms, repeats), which solver gave the plans
    (``stats["solver"]``), the first call on a waypoint count over a repeat (measured in a fresh
    process after a plan of another size: "after the per-robot compile"), TOPP-RA (v/a/torque,
    its own spline through the same waypoints, the solve alone) where installed, with its
    failures counted and their times left out; 2 waypoints v/a/j against Ruckig per call
    (``optimal`` and ``ptp_sync(..., "scurve")``); ``drive_limits=True`` over the torque box;
    then each goal of issue 26 against the same ratio at 91f2439 (:data:`BEFORE_91F2439`,
    stated, not re-measured), met or not."""
    from importlib.util import find_spec

    robot = armlab.load_robot("teachbot6")
    n_cases = 3 if quick else CALLS_CASES
    have_toppra = find_spec("toppra") is not None
    if have_toppra:
        quiet_toppra()
    res: dict = {"n_cases": n_cases}
    print()
    print(f"optimal() whole call by waypoint count (teachbot6, v/a/j/tau, seed {SEED + 7:d})")
    optimal(robot, calls_cases(robot, FIRST_WARMUP_WAYPOINTS, 1)[0])  # per robot, not timed
    _calls_by_size(robot, n_cases, have_toppra, res)
    _calls_ptp(robot, 20 if quick else CALLS_PTP, res)
    _calls_drive(robot, 2 if quick else CALLS_DRIVE, res)
    res["goals"] = calls_goals(res)
    print()
    hdr = f"{'goal (issue 26)':<46}{'limit':>7}  {'at 91f2439':>10}  {'now':>8}  verdict"
    print(hdr)
    print("-" * len(hdr))
    for what, lim, before, now, met in res["goals"]:
        print(
            f"{what:<46}{lim:>6.0f}x  {before:>9.2f}x  {now:>7.2f}x  "
            f"{'goal met' if met else 'goal NOT met'}"
        )
    return res


def calls_row(res: dict) -> None:
    """README row of section 7: the whole optimal() call and the goals of issue 26."""
    cells = ", ".join(f"{nw} wp {1e3 * res[nw]['call']:.0f} ms" for nw in SCALING_WAYPOINTS)
    solvers = sorted({res[nw]["solver"] for nw in SCALING_WAYPOINTS})
    goals = "; ".join(
        f"{what} {now:.3g}x (goal <= {lim:g}x, {'met' if met else 'NOT met'}; {before:.3g}x at "
        "91f2439)"
        for what, lim, before, now, met in res["goals"]
    )
    peer = ", ".join(
        f"{nw} wp {1e3 * res[nw]['toppra']:.1f} ms"
        + (f" ({res[nw]['toppra_failed']} failed)" if res[nw]["toppra_failed"] > 0 else "")
        for nw in SCALING_WAYPOINTS
    )
    b = BEFORE_91F2439
    readme_row(
        __file__,
        "`optimal` whole call by waypoint count (teachbot6, v/a/j/tau, each case's fastest of "
        f"{CALLS_REPEATS} runs, median of {res['n_cases']}; issue 26 goals, before = 91f2439: "
        + ", ".join(f"{nw} wp {b['call_ms'][nw]:.0f} ms" for nw in SCALING_WAYPOINTS)
        + ")",
        f"{cells} ({'; '.join(solvers)}); {goals}; 2 wp v/a/j per call (each in its own loop): "
        f"optimal() {1e3 * res['ptp']['optimal_ms']:.1f} us (closed form, one compiled graph; "
        f"{res['ptp']['optimal2_mixed']:.1f}x Ruckig with the calls interleaved per problem), "
        f"ptp_sync {1e3 * res['ptp']['ptp_ms']:.0f} us "
        f"(at 91f2439 {1e3 * b['optimal_2wp_ms']:.0f} and {1e3 * b['ptp_sync_ms']:.0f} us, "
        f"against Ruckig's single run {b['ruckig_us']} us); against the same output from "
        "Ruckig (calculate, then its state at each time our result holds, from Python): "
        f"optimal() {res['ptp']['same_opt_x']:.2f}x, ptp_sync {res['ptp']['same_ptp_x']:.2f}x",
        f"TOPP-RA (v/a/torque) {peer}; Ruckig {res['ptp']['ruckig_us']:.1f} us per case "
        f"(calculate), {res['ptp']['same_opt_us']:.0f} us at optimal's switching instants, "
        f"{res['ptp']['same_ptp_us']:.0f} us on ptp_sync's dt grid",
    )


# ----------------------------------------------------------------------------- 6. success
SUCCESS_CASES = 1000  # planner tests (problems not proved infeasible) in a full run
SUCCESS_QUICK = 20
SUCCESS_WAYPOINTS = 5
SUCCESS_RANGE = 0.7  # waypoints uniform in this central fraction of each joint range
#: the verdicts of one success case; the last three are failures of the planner
VERDICTS = ("planned", "refused: proved infeasible", "refused: not proved", "unnamed error",
            "plan over a limit")  # fmt: skip
#: the evaluation a plan must pass: every limit within this (README, "Property tests"), on
#: ``Trajectory.check_limits`` at ``dt = T / CHECK_SAMPLES``
PROMISED_TOL = 1e-9


def success_problem(robot, i: int) -> tuple[np.ndarray, str]:
    """Problem ``i`` of the success benchmark: ``SUCCESS_WAYPOINTS`` waypoints uniform in
    ``SUCCESS_RANGE`` of each joint range (seed ``(SEED + 6, i)``, so a case is re-run alone),
    and why it is provably infeasible ("" if it is not proved so): gravity alone at a
    waypoint above a joint's torque limit (``pinocchio.computeGeneralizedGravity``,
    independent of armlab's dynamics). A waypoint is held at rest, so no motion through it
    meets that limit."""
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * SUCCESS_RANGE
    rng = np.random.default_rng([SEED + 6, i])
    w = mid + half * (2 * rng.random((SUCCESS_WAYPOINTS, robot.n_joints)) - 1)
    data = robot.model.createData()
    tau = robot.limits.effort_Nm
    for k, q in enumerate(w):
        g = np.abs(pin.computeGeneralizedGravity(robot.model, data, q))
        if np.any(g > tau):
            j = int(np.argmax(g / tau))
            return w, (
                f"gravity alone at waypoint {k} is {g[j] / tau[j]:.4f} x "
                f"{robot.joint_names[j]}'s torque limit"
            )
    return w, ""


#: the solvers of the success table: ``"fatrop"`` is the default (fatrop where it applies,
#: :mod:`armlab.planning.fatrop_backend`; ``stats["solver"]`` says which solver gave the plan),
#: ``"ipopt"`` the reference (``ARMLAB_SOLVER=ipopt`` around the call)
SOLVERS = ("fatrop", "ipopt")
#: goal of issue 26: the default solver's durations within this of IPOPT's on the same case [s]
DURATION_GOAL_S = 1e-6
SUCCESS_PROGRESS = 50  # a progress line every this many planner tests


@contextmanager
def solver_env(solver: str):
    """The environment of one call: ``ARMLAB_SOLVER`` unset (the default, fatrop where it
    applies) or ``ARMLAB_SOLVER=ipopt`` (the public switch of
    :mod:`armlab.planning.fatrop_backend`); restored afterwards."""
    from armlab.planning.fatrop_backend import SOLVER_ENV

    before = os.environ.pop(SOLVER_ENV, None)
    if solver == "ipopt":
        os.environ[SOLVER_ENV] = "ipopt"
    try:
        yield
    finally:
        os.environ.pop(SOLVER_ENV, None)
        if before is not None:
            os.environ[SOLVER_ENV] = before


def success_case(robot, i: int, solver: str = "fatrop") -> dict:
    """Plan problem ``i`` (:func:`success_problem`) with teachbot6's own v/a/j/tau limits and
    the given solver (:data:`SOLVERS`) and classify it (:data:`VERDICTS`): a plan must pass
    ``check_limits`` within ``PROMISED_TOL``; a refusal (an ``ArmlabError``) is accepted only
    for a problem proved infeasible. ``used`` is ``stats["solver"]`` of the plan (the last
    solve's), ``fallback`` why it was not fatrop (``stats["fallback"]``, "" when it was)."""
    w, proof = success_problem(robot, i)
    out: dict = {"case": i, "proof": proof, "message": "", "solve_s": np.nan, "T_s": np.nan}
    out.update(used="", fallback="")
    t0 = time.perf_counter()
    try:
        with solver_env(solver):
            tr = optimal(robot, w)
    except ArmlabError as exc:
        out["verdict"] = VERDICTS[1] if proof else VERDICTS[2]
        out["message"] = f"{type(exc).__name__}: {exc}"
    except Exception as exc:  # noqa: BLE001 -- what the benchmark counts
        out["verdict"] = VERDICTS[3]
        out["message"] = f"{type(exc).__name__}: {exc}"
    else:
        out["wall_s"] = time.perf_counter() - t0
        out["solve_s"] = tr.stats["solve_time_s"]
        out["T_s"] = tr.duration
        out["backoff_rounds"] = tr.stats["backoff_rounds"]
        raised = tr.stats.get("n_intervals_raised")  # the plan of a finer grid (optimiser)
        out["intervals"] = "" if not raised else f", grid raised {raised['from']} -> {raised['to']}"
        out["used"] = str(tr.stats.get("solver", "ipopt"))
        out["fallback"] = str(tr.stats.get("fallback", ""))
        rep = tr.check_limits(robot, dt=tr.duration / CHECK_SAMPLES)
        bad = rep.violations(PROMISED_TOL)
        out["verdict"] = VERDICTS[4] if bad else VERDICTS[0]
        if bad:
            kind, joint, ratio, _ = max(bad, key=lambda b: b[2])
            out["message"] = f"{joint} {kind} ratio 1 + {ratio - 1:.2g}"
    out.setdefault("wall_s", time.perf_counter() - t0)
    return out


def _success_summary(cases: list[dict], n: int) -> dict:
    """Counts and times of one solver's cases (:func:`success_case` results)."""
    count = {v: sum(c["verdict"] == v for c in cases) for v in VERDICTS}
    planned = [c for c in cases if c["verdict"] == VERDICTS[0]]
    fell = [c for c in planned if c["used"] != "fatrop"]
    return {
        "n": n,
        "count": count,
        "fails": count[VERDICTS[2]] + count[VERDICTS[3]] + count[VERDICTS[4]],
        "solve": np.array([c["solve_s"] for c in planned]),
        "wall": np.array([c["wall_s"] for c in planned]),
        "fatrop": len(planned) - len(fell),
        "fallback": len(fell),
        "reasons": Counter(c["fallback"] or c["used"] for c in fell),
        "failed": [c for c in cases if c["verdict"] not in VERDICTS[:2]],
    }


def _duration_gap(by_solver: dict) -> tuple[float, int, int]:
    """Largest ``|T_fatrop - T_ipopt|`` [s] over the cases both planned, its case, and how many
    cases differ by more than :data:`DURATION_GOAL_S`."""
    gaps = [
        (abs(a["T_s"] - b["T_s"]), a["case"])
        for a, b in zip(by_solver["fatrop"], by_solver["ipopt"], strict=True)
        if a["verdict"] == b["verdict"] == VERDICTS[0]
    ]
    if not gaps:
        return np.nan, -1, 0
    worst = max(gaps)
    return float(worst[0]), int(worst[1]), sum(g > DURATION_GOAL_S for g, _ in gaps)


def _rerun_fallbacks(robot, cases: list[dict]) -> list[dict]:
    """The default solver's plans that fell back to IPOPT, planned once more by it after the
    loop: a fallback of the watchdog (wall time) can come from a busy machine rather than the
    problem; the rerun tells which (``used`` "fatrop" the second time: the load)."""
    return [
        success_case(robot, c["case"], "fatrop")
        for c in cases
        if c["verdict"] == VERDICTS[0] and c["used"] != "fatrop"
    ]


def bench_success(n: int, json_path: str | None = None) -> dict:
    """``optimal`` on random 5-waypoint v/a/j/tau problems (teachbot6, its own limits) until
    ``n`` problems not proved infeasible have been planned or refused, each by the default
    solver (fatrop where it applies) and by IPOPT, each classified by :func:`success_case`.
    The draws that are proved infeasible (gravity at a waypoint) are run too -- the refusal
    must be a named error -- but counted apart: a problem without a solution does not test the
    planner. Goals (issues 15, 26): 100 % of the ``n`` planned within every limit by each
    solver, the default solver's durations within :data:`DURATION_GOAL_S` of IPOPT's."""
    robot = armlab.load_robot("teachbot6")
    for solver in SOLVERS:  # the compiled problems (fatrop: the per-robot library): not timed
        with solver_env(solver):
            optimal(robot, success_problem(robot, 10**6)[0])
    by_solver: dict[str, list[dict]] = {s: [] for s in SOLVERS}
    tests = 0
    i = 0
    t_start = time.perf_counter()
    print(
        f"optimal() success, {SUCCESS_WAYPOINTS} random waypoints, teachbot6, solvers "
        f"{' and '.join(SOLVERS)} on the same cases: {n} planner tests",
        flush=True,
    )
    while tests < n:
        for solver in SOLVERS:
            c = success_case(robot, i, solver)
            by_solver[solver].append(c)
            if c["verdict"] not in VERDICTS[:2]:  # a failure, named as it happens
                print(f"  case {i} ({solver}): {c['verdict']}: {c['message']}", flush=True)
        f, p = by_solver["fatrop"][-1], by_solver["ipopt"][-1]
        if (
            f["verdict"] == p["verdict"] == VERDICTS[0]
            and abs(f["T_s"] - p["T_s"]) > DURATION_GOAL_S
        ):
            print(
                f"  case {i}: durations differ: fatrop ({f['used']}) {f['T_s']:.9f} s, "
                f"IPOPT {p['T_s']:.9f} s",
                flush=True,
            )
        tests += not f["proof"]
        i += 1
        if not f["proof"] and tests % SUCCESS_PROGRESS == 0:
            done = {s: sum(c["verdict"] == VERDICTS[0] for c in by_solver[s]) for s in SOLVERS}
            fell = sum(c["verdict"] == VERDICTS[0] and c["used"] != "fatrop"
                       for c in by_solver["fatrop"])  # fmt: skip
            gap, _, _ = _duration_gap(by_solver)
            print(
                f"  {tests:>5}/{n} tests ({i} draws), {time.perf_counter() - t_start:.0f} s: "
                f"planned {', '.join(f'{s} {done[s]}' for s in SOLVERS)}; fatrop fell back "
                f"{fell}; largest |dT| {gap:.1e} s",
                flush=True,
            )
    res: dict = {"n": n, "draws": i, "by_solver": by_solver}
    for s in SOLVERS:
        res[s] = _success_summary(by_solver[s], n)
    res["gap"] = _duration_gap(by_solver)
    res["rerun"] = _rerun_fallbacks(robot, by_solver["fatrop"])
    success_print(res)
    if json_path:
        import json

        with open(json_path, "w", encoding="utf-8") as fh:
            json.dump(by_solver, fh, indent=1, default=float)
        print(f"  cases written to {json_path}")
    return res


def success_print(res: dict) -> None:
    """The success table of :func:`bench_success` (per solver, then the duration gap)."""
    n, draws = res["n"], res["draws"]
    print()
    print(
        f"optimal() success: {SUCCESS_WAYPOINTS} random waypoints in {SUCCESS_RANGE:.0%} of the "
        f"ranges, v/a/j/tau, teachbot6 (seed ({SEED + 6}, case))"
    )
    print(f"  draws {draws}: {n} planner tests, {draws - n} proved infeasible")
    print(f"  {'verdict':<28}" + "".join(f"{s:>10}" for s in SOLVERS))
    for v in VERDICTS:
        print(f"  {v:<28}" + "".join(f"{res[s]['count'][v]:>10}" for s in SOLVERS))
    fat = res["fatrop"]
    print(f"  fatrop's plans solved by fatrop: {fat['fatrop']}, fell back to IPOPT: "
          f"{fat['fallback']}")  # fmt: skip
    for why, k in fat["reasons"].most_common(5):
        print(f"    {k:>5} x {why}")
    fell = [c["case"] for c in res["by_solver"]["fatrop"]
            if c["verdict"] == VERDICTS[0] and c["used"] != "fatrop"]  # fmt: skip
    if fell:
        print(f"    cases: {', '.join(map(str, fell[:20]))}{' ...' if len(fell) > 20 else ''}")
    for s in SOLVERS:
        r = res[s]
        if r["solve"].size:
            print(
                f"  {s:<7} solve [s]: median {np.median(r['solve']):.3f}, p90 "
                f"{np.percentile(r['solve'], 90):.3f}, max {np.max(r['solve']):.3f}; whole call "
                f"median {np.median(r['wall']):.3f}, p90 {np.percentile(r['wall'], 90):.3f}"
            )
        for c in r["failed"]:
            print(f"  {s:<7} failed case {c['case']}: {c['verdict']}: {c['message']}")
    for c in res["rerun"]:
        print(
            f"    case {c['case']} planned again: {c['verdict']} by {c['used']} "
            f"({c['fallback'] or 'no fallback'}), solve {c['solve_s']:.3f} s"
        )
    for a, b in zip(res["by_solver"]["fatrop"], res["by_solver"]["ipopt"], strict=True):
        both = a["verdict"] == b["verdict"] == VERDICTS[0]
        if both and abs(a["T_s"] - b["T_s"]) > DURATION_GOAL_S:
            print(
                f"  case {a['case']}: T fatrop ({a['used']}) {a['T_s']:.6f} s, "
                f"{a['backoff_rounds']} back-off rounds{a.get('intervals', '')}; IPOPT "
                f"{b['T_s']:.6f} s, {b['backoff_rounds']}{b.get('intervals', '')}"
            )
    gap, case, over = res["gap"]
    print(
        f"  largest duration difference fatrop vs IPOPT: {gap:.1e} s (case {case}); "
        f"{over} cases over {DURATION_GOAL_S:.0e} s"
    )
    goal = all(res[s]["count"][VERDICTS[0]] == n for s in SOLVERS) and gap <= DURATION_GOAL_S
    print(f"  goal (each {n}/{n} within every limit, |dT| <= {DURATION_GOAL_S:.0e} s): "
          f"{'met' if goal else 'NOT met'}")  # fmt: skip


def success_row(res: dict) -> None:
    """README row of section 6."""
    n = res["n"]
    cells = []
    for s in SOLVERS:
        r = res[s]
        c, solve = r["count"], r["solve"]
        cell = (
            f"{s}: {100 * c[VERDICTS[0]] / n:.1f} % planned within every limit (1e-9), "
            f"{r['fails']} failures ({c[VERDICTS[2]]} refusals not proved, {c[VERDICTS[3]]} "
            f"unnamed errors, {c[VERDICTS[4]]} plans over a limit)"
        )
        if s == "fatrop":
            cell += f", {r['fallback']} fell back to IPOPT"
            again = sum(c["used"] == "fatrop" for c in res.get("rerun", []))
            if r["fallback"]:
                cell += f" ({again} of them solved by fatrop when planned again: load)"
        if solve.size:
            cell += (
                f", solve median {1e3 * np.median(solve):.0f} ms, p90 "
                f"{1e3 * np.percentile(solve, 90):.0f} ms"
            )
        cells.append(cell)
    gap, _, over = res["gap"]
    refused = res["fatrop"]["count"][VERDICTS[1]]
    readme_row(
        __file__,
        f"`optimal`, {SUCCESS_WAYPOINTS} random waypoints, v/a/j/tau (teachbot6's limits): "
        f"success on {f'{n:,}'.replace(',', ' ')} problems not proved infeasible, fatrop "
        "(default) and IPOPT on the same cases (goal 100 %, durations within 1e-6 s)",
        "; ".join(cells) + f"; durations fatrop vs IPOPT within {gap:.1e} s ({over} cases over "
        f"1e-6 s); {refused} more draws refused by name, gravity at a waypoint over a torque "
        "limit",
        "neither peer can do it",
    )


# ----------------------------------------------------------------------------- main
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a few cases per benchmark")
    ap.add_argument(
        "--scurves-only", action="store_true", help="only the closed-form S-curve table"
    )
    ap.add_argument(
        "--optimal-scaling-only",
        action="store_true",
        help="only the optimal() solve time by waypoint count",
    )
    ap.add_argument(
        "--success",
        type=int,
        metavar="N",
        help=f"planner tests of the success table (default {SUCCESS_CASES}, {SUCCESS_QUICK} "
        "with --quick)",
    )
    ap.add_argument("--success-only", action="store_true", help="only the success table")
    ap.add_argument(
        "--success-json",
        metavar="PATH",
        help="write the success table's cases (per solver: verdict, duration, times) as JSON",
    )
    ap.add_argument(
        "--calls-only", action="store_true", help="only the whole-call table (issue 26)"
    )
    ap.add_argument(
        "--peers-only",
        action="store_true",
        help="only the side-by-side with Ruckig and (where installed) TOPP-RA: notebook 03",
    )
    ap.add_argument("--first-call", type=int, metavar="NW", help=argparse.SUPPRESS)
    ap.add_argument("--first-repeats", type=int, default=5, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.first_call:  # section 7's first call, in the fresh process run_calls starts
        import json

        print("FIRST-CALL\t" + json.dumps(first_call(args.first_call, args.first_repeats)))
        return
    if args.peers_only:
        peers_table(args.quick)
        return
    n_success = args.success or (SUCCESS_QUICK if args.quick else SUCCESS_CASES)
    if args.optimal_scaling_only:
        scaling_row(bench_optimal_scaling(args.quick))
        return
    if args.success_only:
        success_row(bench_success(n_success, args.success_json))
        return
    if args.calls_only:
        calls_row(bench_optimal_calls(args.quick))
        return
    if args.scurves_only:
        scurve_row(bench_scurve_batch(args.quick))
        return
    cases = QUICK if args.quick else CASES
    rng = np.random.default_rng(SEED)
    rows = []
    for name in ROBOTS:
        robot, extra = load(name)
        # warm the compiled problems once per robot (builds are cached, not timed below)
        w = draw_waypoints(robot, np.random.default_rng(0), 2)
        v, a, j, tau = limits_of(robot, extra)
        t0 = time.perf_counter()
        optimal(robot, w, v_max=v, a_max=a, j_max=j, tau_max=False)
        vf, af, jf, _ = limits_of(robot, {**extra, **FULL_LIMITS[name]})
        optimal(
            robot,
            draw_waypoints(robot, np.random.default_rng(1), FULL_WAYPOINTS),
            v_max=vf,
            a_max=af,
            j_max=jf,
            tau_max=tau,
        )
        optimal(
            robot,
            draw_waypoints(robot, np.random.default_rng(2), TOPP_WAYPOINTS, step=TOPP_STEP_RAD),
            v_max=v,
            a_max=a,
            j_max=False,
            tau_max=tau,
        )
        build = time.perf_counter() - t0
        r1 = bench_ruckig(robot, extra, rng, cases["ptp"])
        r2 = bench_toppra(robot, extra, rng, cases["topp"])
        r3 = bench_full(robot, {**extra, **FULL_LIMITS[name]}, rng, cases["full"])
        rows.append((name, build, r1, r2, r3))

    print()
    peers_header(args.quick)
    for name, build, r1, r2, r3 in rows:
        ruckig_line(name, r1)
        toppra_lines(name, r2)
        solved = len(r3["solve"])
        print(
            f"{'full v/a/j/tau, 3 wp, faster drives: success':<47}{name:<11}{r3['n']:>4}  "
            f"{'':>9}  {'':>9}  {np.median(r3['solve']):>12.3f}  {'(no peer)':>12}  "
            f"{r3['ok']:>8}/{r3['n']:<9}"
        )
        print(
            f"{'  ... wall per call incl. checks [s] med/max':<47}{name:<11}{solved:>4}  "
            f"{'':>9}  {'':>9}  {np.median(r3['wall']):>12.3f}  {np.max(r3['wall']):>12.3f}"
        )
        print(
            f"{'  ... torque binding in':<47}{name:<11}{solved:>4}  "
            f"{r3['torque_bound']:>9d} cases; first build of the compiled problems {build:.1f} s"
        )
        for e in r3["errors"][:3]:
            print(f"      error: {e}")
    all_solve = np.concatenate([r[4]["solve"] for r in rows])
    all_ok = sum(r[4]["ok"] for r in rows)
    all_n = sum(r[4]["n"] for r in rows)
    ptp = np.concatenate([r[2]["ratios"] for r in rows])
    topp = np.concatenate([r[3]["ratio_path"] for r in rows])
    print()
    print(
        f"goals: PTP/Ruckig median {np.median(ptp):.4f} (<= 1.005), max {np.max(ptp):.4f} "
        f"(<= 1.02); path/TOPP-RA median {np.median(topp):.4f} (<= 1.00); full problem "
        f"{all_ok}/{all_n} feasible successes (100 %), median solve {np.median(all_solve):.3f} s"
        f" (< 1 s)"
    )
    scurves = bench_scurve_batch(args.quick)
    calls = bench_optimal_calls(args.quick)
    scaling = bench_optimal_scaling(args.quick)
    success = bench_success(n_success, args.success_json)

    # ------------------------------------------------------------------------- README rows
    names = {"teachbot6": "teachbot6", "ur5": "UR5"}
    per_robot = [float(np.median(r[2]["ours_t"])) for r in rows]
    readme_row(
        __file__,
        "rest-to-rest PTP, v/a/j limits: duration ours / Ruckig's",
        f"median {np.median(ptp):.4f}, max {np.max(ptp):.4f} "
        f"({' and '.join(names[r[0]] for r in rows)}, {cases['ptp']} cases each); "
        f"{min(per_robot):.2f}-{max(per_robot):.2f} s per solve (median)",
        f"Ruckig {sig(1e6 * np.median(np.concatenate([r[2]['peer_t'] for r in rows])))} us "
        "per case",
    )
    ours_over = sum(int(np.sum(r[3]["ours_worst"] > 1 + 1e-6)) for r in rows)
    peer_ms = 1e3 * np.concatenate([r[3]["peer_t"] for r in rows])
    readme_row(
        __file__,
        f"{TOPP_WAYPOINTS} waypoints, v/a/torque: `time_optimal_path` / TOPP-RA",
        "median "
        + ", ".join(f"{np.median(r[3]['ratio_path']):.4f} ({names[r[0]]})" for r in rows)
        # TOPP-RA's limit excess is measured fairly (its own spline) by bench_topp.py: here
        # its samples are re-interpolated by our Trajectory, which overstates it
        + f"; armlab over a limit on the fine grid on {ours_over} of {len(topp)} paths; "
        "`optimal` (free path through the waypoints) / TOPP-RA: median "
        + " / ".join(f"{np.median(r[3]['ratio_free']):.2f}" for r in rows),
        f"TOPP-RA {np.min(peer_ms):.0f}-{np.max(peer_ms):.0f} ms per path; no "
        f"parameterisation on {sum(r[3]['peer_failed'] for r in rows)} of "
        f"{sum(r[3]['n'] for r in rows)} paths (left out)",
    )
    readme_row(
        __file__,
        f"all four limits at once (v, a, jerk, torque), {all_n} random cases",
        f"{100 * all_ok / all_n:.0f} % success, median solve {np.median(all_solve):.2f} s",
        "neither peer can do it",
    )
    scaling_row(scaling)
    scurve_row(scurves)
    success_row(success)
    calls_row(calls)


def peers_header(quick: bool) -> None:
    print(f"armlab.trajectory optimisers vs peers (seed {SEED:d}{', quick' if quick else ''})")
    hdr = (
        f"{'benchmark':<47}{'robot':<11}{'n':>4}  {'ratio med':>9}  {'ratio max':>9}  "
        f"{'ours [s] med':>12}  {'peer [s] med':>12}  {'feasible ours/peer':>18}"
    )
    print(hdr)
    print("-" * len(hdr))


def ruckig_line(name: str, r1: dict) -> None:
    print(
        f"{'PTP v/a/j: optimal / Ruckig':<47}{name:<11}{r1['n']:>4}  "
        f"{np.median(r1['ratios']):>9.4f}  {np.max(r1['ratios']):>9.4f}  "
        f"{np.median(r1['ours_t']):>12.3f}  {np.median(r1['peer_t']):>12.6f}  "
        f"{r1['ok']:>8}/{r1['peer_ok']:<9}"
    )


def toppra_lines(name: str, r2: dict) -> None:
    n2 = len(r2["ratio_path"])
    peer_ok = int(np.sum(r2["peer_worst"] <= 1 + 1e-6))
    ok_path = int(np.sum(r2["ours_worst"] <= 1 + 1e-6))
    ok_free = int(np.sum(r2["free_worst"] <= 1 + 1e-6))
    print(
        f"{'5-wp v/a/tau: time_optimal_path / TOPP-RA':<47}{name:<11}{n2:>4}  "
        f"{np.median(r2['ratio_path']):>9.4f}  {np.max(r2['ratio_path']):>9.4f}  "
        f"{np.median(r2['ours_t']):>12.3f}  {np.median(r2['peer_t']):>12.4f}  "
        f"{ok_path:>8}/{peer_ok:<9}"
    )
    print(
        f"{'5-wp v/a/tau: optimal (free path) / TOPP-RA':<47}{name:<11}{n2:>4}  "
        f"{np.median(r2['ratio_free']):>9.4f}  {np.max(r2['ratio_free']):>9.4f}  "
        f"{np.median(r2['free_t']):>12.3f}  {np.median(r2['peer_t']):>12.4f}  "
        f"{ok_free:>8}/{peer_ok:<9}"
    )
    print(
        f"{'  TOPP-RA found no parameterisation (left out)':<47}{name:<11}{r2['n']:>4}  "
        f"{r2['peer_failed']:>9d} of {r2['n']} paths"
    )
    print(
        f"{'  TOPP-RA worst limit ratio on the fine grid':<47}{name:<11}{n2:>4}  "
        f"{np.median(r2['peer_worst']):>9.4f}  {np.max(r2['peer_worst']):>9.4f}"
    )
    print(
        f"{'  time_optimal_path / TOPP-RA made feasible':<47}{name:<11}{n2:>4}  "
        f"{np.median(r2['ratio_stretched']):>9.4f}  {np.max(r2['ratio_stretched']):>9.4f}"
    )


def peers_table(quick: bool) -> None:
    """Tables 1 and 2 alone (``--peers-only``, notebook 03): optimal vs Ruckig (a test
    dependency) on teachbot6 and the UR5 of example-robot-data, and time_optimal_path /
    optimal vs TOPP-RA where it is installed (the bench extra); no README rows."""
    from importlib.util import find_spec

    cases = QUICK if quick else CASES
    rng = np.random.default_rng(SEED)
    have_toppra = find_spec("toppra") is not None
    peers_header(quick)
    for name in ROBOTS:
        robot, extra = load(name)
        ruckig_line(name, bench_ruckig(robot, extra, rng, cases["ptp"]))
        if have_toppra:
            toppra_lines(name, bench_toppra(robot, extra, rng, cases["topp"]))
    if not have_toppra:
        print("TOPP-RA rows left out: toppra is not installed (pip install -e '.[test,bench]')")


def scaling_row(res: dict) -> None:
    """README row of section 5: "before" -> today's median IPOPT time by waypoint count."""
    cells, worst, ok, n = [], 0.0, 0, 0
    for kind in ("v/a/j", "v/a/j/tau"):
        steps = []
        for nw in SCALING_WAYPOINTS:
            before, _, _ = res[(kind, nw, "before")]
            after, k, dev = res[(kind, nw, "after")]
            steps.append(f"{nw} wp {before:.3g} -> {after:.3g} s")
            worst, ok, n = max(worst, dev), ok + k, n + res["n_cases"]
        cells.append(f"{kind}: " + ", ".join(steps))
    readme_row(
        __file__,
        "`optimal` solve time by waypoint count (teachbot6, IPOPT median, "
        f"{res['n_cases']} cases each): settings before issue 15 (exact Hessian, cold back-off "
        "re-solves) -> today's defaults",
        "; ".join(cells) + f"; durations within {worst:.1e}, {100 * ok / n:.0f} % success",
    )


def scurve_row(res: list[dict]) -> None:
    """README row of section 4: closed-form S-curves against Ruckig."""
    ours = [r["ours_us"] for r in res]
    peer = [r["peer_us"] for r in res]
    ratio = [r["ours_us"] / r["peer_us"] for r in res]
    batch = [r["batch"] for r in res]
    readme_row(
        __file__,
        "time-synchronised rest-to-rest S-curves, v/a/j, closed form "
        "(`synchronised_scurves`): one 6-joint problem; a batch",
        f"{min(ours):.0f}-{max(ours):.0f} us per problem ({min(ratio):.0f}-{max(ratio):.0f}x "
        "Ruckig; since issue 26 one problem is one CasADi graph of the engine's own formulas, "
        "with the phase table and the exact peaks in the same evaluation, gcc-compiled once "
        "per joint count and cached; 56-61 us for the engine alone with numpy before); "
        f"{sig(min(batch))}-{sig(max(batch))} problems/s batched (numpy); durations equal to "
        f"Ruckig's within {max(r['dev'] for r in res):.1e}",
        f"Ruckig {min(peer):.1f}-{max(peer):.1f} us per problem",
    )


if __name__ == "__main__":
    main()
