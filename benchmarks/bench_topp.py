"""TOPP along a fixed joint path: reachability analysis, convex pass, TOPP-RA (issue 15).

Seeded random 5-waypoint joint paths with velocity, acceleration and torque limits (the cases
of ``bench_trajectory.py`` section 2), all on the same cubic spline (chord-length parameter,
not-a-knot) and the same grid (:func:`armlab.planning.topp.path_grid`: ``n_grid`` uniform
intervals plus the refined ends):

- ``time_optimal_path(method="reachability")`` (the default, :mod:`armlab.planning.reachability`:
  two closed-form sweeps) and, with ``--full``, ``method="convex"`` (CasADi + IPOPT), each
  with the planner's back-off loop and limit check;
- TOPP-RA (``toppra``: seidel LP per step, ``ParametrizeConstAccel``) on the same grid points,
  and on its own default grid.

Times: wall per call, the fastest of ``REPEATS`` calls per path (ours and TOPP-RA's
alternating, so that both see the same load of a shared machine), then median and max over
the paths. Ours: the whole ``time_optimal_path`` call from the waypoints (path spline, grid,
coefficients, sweeps, Trajectory, limit check), also split (in its last call) into its
sweeps (``solve_time_s``), the Trajectory build and the limit check. TOPP-RA: its solve
(``TOPPRA(...).compute_trajectory``, which evaluates its constraints on the grid) with its
spline and constraint objects built beforehand -- the goal's measure, the stricter one -- and
its whole call with those built too.

Limits: every plan is checked the same way, on a uniform ``T / 4000`` grid of its own
evaluation (TOPP-RA: its spline ``jt(t)``; ours: :meth:`Trajectory.at`), torques by RNEA at
each sample; the worst ratio to any limit is printed for each. Ours also has its own report
(exact velocity and acceleration peaks, refined torque peaks between samples:
:meth:`Trajectory.check_limits`).

Durations: ours over TOPP-RA's on the same grid; over TOPP-RA *made feasible* (TOPP-RA imposes
its limits at the grid points only and breaks them between: stretched in time by the smallest
factor that meets every limit on the same fine check,
:func:`armlab.planning.timescale.stretch_needed`); and, to show where a difference comes from,
our sweeps *on TOPP-RA's rows* -- the limits imposed at the grid points only (each interval's
``(u_k, x_k)`` at ``s_k``, TOPP-RA's collocation of the torque; TOPP-RA imposes the
acceleration at ``s_k+1`` too, its default "interpolation", so these rows are fewer than its;
the velocity at the nodes), not tightened by ``LIMIT_MARGIN``, the grid profile's duration --
over TOPP-RA's (above 1 on a path: a loss of the greedy forward pass,
:mod:`armlab.planning.reachability` "Optimality"). Goals (issue 15): time <= 3x
TOPP-RA's at the same grid, duration no longer than TOPP-RA's (judged against TOPP-RA made
feasible, since TOPP-RA's own plan is over its limits between grid points).

Run:  ``MPLBACKEND=Agg .venv/bin/python benchmarks/bench_topp.py [--quick] [--full] [--n-grid 100]``
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402
from _readme import readme_row, sig  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_trajectory import ROBOTS, draw_waypoints, limits_of, load, quiet_toppra  # noqa: E402

from armlab.errors import ArmlabError, InfeasibleError  # noqa: E402
from armlab.planning import reachability  # noqa: E402
from armlab.planning.timescale import stretch_needed  # noqa: E402
from armlab.planning.topp import build_topp  # noqa: E402
from armlab.robot import rigid_body  # noqa: E402
from armlab.robot.limits import resolve_limits  # noqa: E402
from armlab.trajectory import Trajectory, time_optimal_path  # noqa: E402
from armlab.trajectory.sampling import LimitSamples  # noqa: E402

SEED = 20261123
CASES = 12  # paths per robot
QUICK = 3
WAYPOINTS = 5
STEP_RAD = 0.6  # max joint step between consecutive waypoints
CHECK_SAMPLES = 4000
REPEATS = 5  # timed calls per case, ours and TOPP-RA's alternating (the fastest is kept)


def toppra_solve(robot, w, v, a, tau, gridpoints):
    """TOPP-RA from the waypoints: the spline (our chord-length parameter, not-a-knot), the
    velocity, acceleration and torque constraints (collocated at the grid points; torques by
    ``pinocchio.rnea``) and the solve, once. Returns (its trajectory ``jt`` or None, wall time
    [s] of the solve alone (spline and constraints built before), of the whole call)."""
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    quiet_toppra()  # once per process: its failures are counted, not printed
    data = robot.model.createData()

    def inv_dyn(q, qd, qdd):
        return pin.rnea(robot.model, data, q, qd, qdd)

    t0 = time.perf_counter()
    step = np.linalg.norm(np.diff(w, axis=0), axis=1)
    ss = np.concatenate([[0.0], np.cumsum(step)]) / np.sum(step)
    path = ta.SplineInterpolator(ss, w, bc_type="not-a-knot")
    cons = [
        constraint.JointVelocityConstraint(v),
        constraint.JointAccelerationConstraint(a),
        constraint.JointTorqueConstraint(
            inv_dyn, np.vstack([-tau, tau]).T, np.zeros(robot.n_joints)
        ),
    ]
    t1 = time.perf_counter()
    inst = algo.TOPPRA(cons, path, gridpoints=gridpoints, parametrizer="ParametrizeConstAccel")
    jt = inst.compute_trajectory(0, 0)
    t2 = time.perf_counter()
    return jt, t2 - t1, t2 - t0


def fine_samples(robot, plan) -> LimitSamples:
    """The same fine check for every plan: its own evaluation (ours: :meth:`Trajectory.at`;
    TOPP-RA: its spline ``jt(t, order)``) on a uniform ``T / CHECK_SAMPLES`` grid, torques by
    RNEA at each sample."""
    t = np.linspace(0.0, plan.duration, CHECK_SAMPLES + 1)
    if isinstance(plan, Trajectory):
        q, qd, qdd, _ = plan.at(t)
    else:
        q, qd, qdd = plan(t), plan(t, 1), plan(t, 2)
    return LimitSamples(t, q, qd, qdd, tau=rigid_body.inverse_dynamics(robot, q, qd, qdd))


def worst_ratio(smp: LimitSamples, lim) -> float:
    """Largest ratio of the samples to any velocity, acceleration or torque limit."""
    pairs = (
        (smp.qd, lim.velocity_rad_s),
        (smp.qdd, lim.acceleration_rad_s2),
        (smp.tau, lim.torque_Nm),
    )
    return max(float(np.max(np.abs(x) / L)) for x, L in pairs)


def collocated_duration(robot, w, kw) -> float:
    """Our sweeps on TOPP-RA's rows (module docstring): limits at the grid points only (the
    rows at fraction 0 of each interval, and at a spline knot inside one), the velocity at the
    nodes, the limits not tightened; the grid profile's duration [s] (NaN if none)."""
    saved = reachability.LIMIT_FRACTIONS, reachability.VELOCITY_FRACTIONS
    reachability.LIMIT_FRACTIONS, reachability.VELOCITY_FRACTIONS = (0.0,), ()
    try:
        prob = build_topp(robot, w, **kw)
        b, info = reachability.solve_reachability(prob, resolve_limits(prob.limits, j_max=False))
    finally:
        reachability.LIMIT_FRACTIONS, reachability.VELOCITY_FRACTIONS = saved
    return prob.duration_of(b) if info["success"] else np.nan


def bench_robot(robot, extra, rng, n, n_grid, full):
    v, a, _, tau = limits_of(robot, extra)
    lim = robot.with_limits(acceleration_rad_s2=a, jerk_rad_s3=None).limits
    out: dict[str, list] = {}
    errors: list[str] = []

    def put(key, value):
        out.setdefault(key, []).append(value)

    kw = dict(v_max=v, a_max=a, j_max=False, tau_max=tau, n_grid=n_grid)
    for _ in range(n):
        while True:  # a path whose spline stays inside the joint ranges
            w = draw_waypoints(robot, rng, WAYPOINTS, step=STEP_RAD)
            try:
                prob = build_topp(robot, w, **kw)
                break
            except InfeasibleError:
                continue
        times: dict[str, list[float]] = {"peer": [], "peer_whole": [], "peer_d": [], "ra": []}
        try:
            for _ in range(REPEATS):  # alternating: both see the same load on the machine
                peer, t_solve, t_whole = toppra_solve(robot, w, v, a, tau, prob.s)
                peer_d, t_d, _ = toppra_solve(robot, w, v, a, tau, None)
                t0 = time.perf_counter()
                ra = time_optimal_path(robot, w, method="reachability", **kw)
                times["ra"].append(time.perf_counter() - t0)
                times["peer"].append(t_solve)
                times["peer_whole"].append(t_whole)
                times["peer_d"].append(t_d)
        except ArmlabError as exc:
            errors.append(f"time_optimal_path (reachability): {exc}")
            continue
        if peer is None or peer_d is None:
            errors.append("toppra found no parameterisation")
            continue
        ra_t, peer_t, peer_whole_t, peer_dt = (
            min(times[k]) for k in ("ra", "peer", "peer_whole", "peer_d")
        )
        peer_smp = fine_samples(robot, peer)
        ra_smp = fine_samples(robot, ra)
        k_peer, _, _ = stretch_needed(peer_smp, robot, lim)
        put("ra_t", ra_t)
        put("ra_solve_t", ra.stats["solve_time_s"])
        put("ra_check_t", ra.stats["check_time_s"])
        put("ra_traj_t", ra.stats["trajectory_time_s"])
        put("peer_t", peer_t)
        put("peer_whole_t", peer_whole_t)
        put("peer_default_t", peer_dt)
        put("ra_peer", ra.duration / peer.duration)
        put("ra_peer_default", ra.duration / peer_d.duration)
        put("ra_peer_feasible", ra.duration / (k_peer * peer.duration))
        put("colloc_peer", collocated_duration(robot, w, kw) / peer.duration)
        put("ra_worst", worst_ratio(ra_smp, lim))
        put("ra_report", max(float(np.max(r)) for r in ra.report.ratios.values()))
        put("peer_worst", worst_ratio(peer_smp, lim))
        put("rounds", ra.stats["backoff_rounds"])
        if full:
            try:
                t0 = time.perf_counter()
                convex = time_optimal_path(robot, w, method="convex", **kw)
                convex_t = time.perf_counter() - t0
            except ArmlabError as exc:  # the convex pass refused the path: no ratio to it
                errors.append(f"time_optimal_path (convex): {exc}")
                continue
            cv_smp = fine_samples(robot, convex)
            put("convex_t", convex_t)
            put("ra_convex", ra.duration / convex.duration)
            put("convex_peer", convex.duration / peer.duration)
            put("convex_worst", worst_ratio(cv_smp, lim))
    res = {k: np.array(x) for k, x in out.items()}
    return res, errors


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a few cases per robot")
    ap.add_argument("--full", action="store_true", help="also the convex pass (IPOPT, ~1 s each)")
    ap.add_argument("--n-grid", type=int, default=100, help="uniform path intervals")
    args = ap.parse_args()
    n = QUICK if args.quick else CASES
    rng = np.random.default_rng(SEED)
    rows = []
    for name in ROBOTS:
        robot, extra = load(name)
        # warm up: CasADi's first build, toppra's imports, pinocchio's first calls
        v, a, _, tau = limits_of(robot, extra)
        w = draw_waypoints(robot, np.random.default_rng(0), WAYPOINTS, step=STEP_RAD)
        kw = dict(v_max=v, a_max=a, j_max=False, tau_max=tau, n_grid=args.n_grid)
        for method in ("convex", "reachability") if args.full else ("reachability",):
            try:
                time_optimal_path(robot, w, method=method, **kw)
            except ArmlabError:
                pass
        toppra_solve(robot, w, v, a, tau, None)
        rows.append((name, *bench_robot(robot, extra, rng, n, args.n_grid, args.full)))

    quick = ", quick" if args.quick else ""
    print()
    print(
        f"TOPP on a fixed path, v/a/tau, {WAYPOINTS} waypoints, n_grid = {args.n_grid} "
        f"(seed {SEED:d}{quick}); times: over paths, of the fastest of {REPEATS} calls each"
    )
    hdr = f"{'quantity':<60}{'robot':<11}{'n':>4}  {'median':>10}  {'min':>10}  {'max':>10}"
    print(hdr)
    print("-" * len(hdr))

    def line(label, name, x, fmt="{:>10.4f}"):
        x = np.asarray(x, dtype=float)
        x = x[np.isfinite(x)]
        if len(x) == 0:
            print(f"{label:<60}{name:<11}{0:>4}")
            return
        cells = "  ".join(fmt.format(f) for f in (np.median(x), np.min(x), np.max(x)))
        print(f"{label:<60}{name:<11}{len(x):>4}  {cells}")

    ms, r5, r6 = "{:>10.2f}", "{:>10.5f}", "{:>10.6f}"
    for name, r, errors in rows:
        line("time [ms]: ours (reachability), whole call", name, 1e3 * r["ra_t"], ms)
        line("time [ms]: ... of which sweeps", name, 1e3 * r["ra_solve_t"], ms)
        line("time [ms]: ... of which Trajectory build", name, 1e3 * r["ra_traj_t"], ms)
        line("time [ms]: ... of which limit check", name, 1e3 * r["ra_check_t"], ms)
        if "convex_t" in r:
            line("time [ms]: ours (convex, IPOPT), whole call", name, 1e3 * r["convex_t"], ms)
        line("time [ms]: TOPP-RA, same grid, solve", name, 1e3 * r["peer_t"], ms)
        line(
            "time [ms]: TOPP-RA, same grid, with its spline, constraints",
            name,
            1e3 * r["peer_whole_t"],
            ms,
        )
        line("time [ms]: TOPP-RA, its default grid, solve", name, 1e3 * r["peer_default_t"], ms)
        line("time ratio: ours whole call / TOPP-RA same grid solve", name, r["ra_t"] / r["peer_t"])
        line(
            "time ratio: ours whole call / TOPP-RA whole call", name, r["ra_t"] / r["peer_whole_t"]
        )
        line(
            "time ratio: ours without the limit check / TOPP-RA",
            name,
            (r["ra_t"] - r["ra_check_t"]) / r["peer_t"],
        )
        if "convex_t" in r:
            line(
                "time ratio: ours (convex) / TOPP-RA same grid",
                name,
                r["convex_t"] / np.median(r["peer_t"]),
            )
        line("duration ratio: ours / TOPP-RA same grid", name, r["ra_peer"], r5)
        line("duration ratio: ours / TOPP-RA made feasible", name, r["ra_peer_feasible"], r5)
        line("duration ratio: ours / TOPP-RA default grid", name, r["ra_peer_default"], r5)
        line("duration ratio: our sweeps on TOPP-RA's rows / TOPP-RA", name, r["colloc_peer"], r5)
        if "convex_t" in r:
            line("duration ratio: ours / ours (convex)", name, r["ra_convex"], r5)
            line("duration ratio: ours (convex) / TOPP-RA same grid", name, r["convex_peer"], r5)
        line("worst limit ratio, T/4000 grid: ours", name, r["ra_worst"], r6)
        line("worst limit ratio, own report (exact peaks): ours", name, r["ra_report"], r6)
        if "convex_t" in r:
            line("worst limit ratio, T/4000 grid: ours (convex)", name, r["convex_worst"], r6)
        line("worst limit ratio, T/4000 grid: TOPP-RA same grid", name, r["peer_worst"], r6)
        line("back-off rounds: ours", name, r["rounds"], "{:>10.0f}")
        for e in errors[:3]:
            print(f"      error: {e}")
    cat = {
        k: np.concatenate([r[k] for _, r, _ in rows])
        for k in ("ra_t", "peer_t", "peer_whole_t", "ra_peer")
    }
    feas = np.concatenate([r["ra_peer_feasible"] for _, r, _ in rows])
    tr = cat["ra_t"] / cat["peer_t"]
    print()
    print(
        f"goals: time ours (whole call) / TOPP-RA same grid (solve) median {np.median(tr):.2f}, "
        f"max {np.max(tr):.2f} (<= 3), / TOPP-RA whole call median "
        f"{np.median(cat['ra_t'] / cat['peer_whole_t']):.2f}; "
        f"duration ours / TOPP-RA same grid median {np.median(cat['ra_peer']):.4f}, "
        f"over TOPP-RA made feasible median {np.median(feas):.4f}, max {np.max(feas):.4f} (<= 1)"
    )
    full = all("convex_t" in r for _, r, _ in rows)
    names = {"ur5": "UR5"}  # as the README writes them
    times = "; ".join(
        f"{1e3 * np.median(r['ra_t']):.0f} ms"
        + (f" vs {sig(1e3 * np.median(r['convex_t']))} ms" if full else "")
        + f" ({names.get(name, name)})"
        for name, r, _ in rows
    )
    ours_worst = max(float(np.max(r["ra_worst"])) for _, r, _ in rows)
    peer_over = [100 * (float(np.max(r["peer_worst"])) - 1) for _, r, _ in rows]
    if full:
        vs = np.concatenate([r["ra_convex"] for _, r, _ in rows]) - 1
        duration = (
            f"duration {100 * np.median(vs):+.3g} % median, {100 * np.max(vs):+.2g} % max over "
            "the convex pass"
        )
    else:
        duration = f"duration / TOPP-RA made feasible: median {np.median(feas):.4f}"
    readme_row(
        __file__,
        f"`time_optimal_path`, {WAYPOINTS} waypoints, v/a/torque, {args.n_grid} intervals: "
        "reachability analysis (default)" + (" vs the convex IPOPT pass" if full else ""),
        f"{times}; {duration}; worst limit ratio {ours_worst:.4f} on a T/{CHECK_SAMPLES} grid",
        f"TOPP-RA {1e3 * np.median(cat['peer_t']):.1f} ms on the same grid (breaks its limits "
        f"between grid points by {min(peer_over):.0f}-{max(peer_over):.0f} %)",
    )


if __name__ == "__main__":
    main()
