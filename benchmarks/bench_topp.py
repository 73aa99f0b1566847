"""TOPP along a fixed joint path: convex pass, reachability analysis, TOPP-RA (issue 15).

Seeded random 5-waypoint joint paths with velocity, acceleration and torque limits (the cases
of ``bench_trajectory.py`` section 2), all three on the same cubic spline and the same grid
(:func:`armlab.planning.topp.path_grid`: ``n_grid`` uniform intervals plus the refined ends):

- ``time_optimal_path(method="convex")`` (CasADi + IPOPT convex pass),
- ``time_optimal_path(method="reachability")`` (the default: :mod:`armlab.planning.reachability`,
  two closed-form sweeps), both with the planner's one back-off loop and limit check,
- TOPP-RA (``toppra``, seidel LP per step, ``ParametrizeConstAccel``) on the same grid points,
  and on its own default grid.

Times: wall per call (median), ours also split into the rows and sweeps (``solve_time_s``: the
part TOPP-RA's own time compares with), the Trajectory build and its limit check, and the whole
call (build, coefficients, sweeps, Trajectory, check). Durations: ours over the convex pass's,
over TOPP-RA's, and over TOPP-RA *made feasible* (TOPP-RA imposes its limits at the grid points
only: stretched in time by the smallest factor that meets every limit on our fine check,
:func:`armlab.planning.timescale.stretch_needed` on :meth:`Trajectory.limit_samples`). Every
plan of ours is re-checked on a ``T / 4000`` grid (not timed). Goals (issue 15): time <= 3x
TOPP-RA's at the same grid, duration no longer than TOPP-RA's.

Run:  ``MPLBACKEND=Agg .venv/bin/python benchmarks/bench_topp.py [--quick] [--n-grid 100]``
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_trajectory import (  # noqa: E402
    ROBOTS,
    draw_waypoints,
    limits_of,
    load,
    toppra_problem,
)

from armlab.errors import ArmlabError, InfeasibleError  # noqa: E402
from armlab.planning.timescale import stretch_needed  # noqa: E402
from armlab.planning.topp import build_topp  # noqa: E402
from armlab.trajectory import Trajectory, time_optimal_path  # noqa: E402

SEED = 20261123
CASES = 12  # paths per robot
QUICK = 3
WAYPOINTS = 5
STEP_RAD = 0.6  # max joint step between consecutive waypoints
CHECK_SAMPLES = 4000
REPEATS = 3  # timed calls per case (the median is kept)


def toppra_solve(robot, w, v, a, tau, gridpoints):
    """TOPP-RA on the spline and parameter of ours; (Trajectory sampled at T / 4000 or None,
    wall time [s] of the median of ``REPEATS`` calls)."""
    import toppra.algorithm as algo

    path, cons = toppra_problem(robot, w, v, a, tau)
    times, jt = [], None
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        inst = algo.TOPPRA(cons, path, gridpoints=gridpoints, parametrizer="ParametrizeConstAccel")
        jt = inst.compute_trajectory(0, 0)
        times.append(time.perf_counter() - t0)
    if jt is None:
        return None, float(np.median(times))
    t = np.linspace(0, jt.duration, CHECK_SAMPLES + 1)
    traj = Trajectory(t, jt(t), jt(t, 1), jt(t, 2), joint_names=robot.joint_names, method="toppra")
    return traj, float(np.median(times))


def timed(fn, repeats=REPEATS):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, float(np.median(times))


def bench_robot(robot, extra, rng, n, n_grid):
    v, a, _, tau = limits_of(robot, extra)
    lim = robot.with_limits(acceleration_rad_s2=a, jerk_rad_s3=None).limits
    keys = (
        "convex_t",
        "ra_t",
        "ra_solve_t",
        "ra_check_t",
        "ra_traj_t",
        "peer_t",
        "peer_default_t",
        "ra_convex",
        "ra_peer",
        "ra_peer_default",
        "ra_peer_feasible",
        "ra_worst",
        "peer_worst",
        "rounds",
    )
    out: dict[str, list] = {k: [] for k in keys}
    errors: list[str] = []
    kw = dict(v_max=v, a_max=a, j_max=False, tau_max=tau, n_grid=n_grid)
    for _ in range(n):
        while True:  # a path whose spline stays inside the joint ranges
            w = draw_waypoints(robot, rng, WAYPOINTS, step=STEP_RAD)
            try:
                prob = build_topp(robot, w, **kw)
                break
            except InfeasibleError:
                continue
        peer, peer_t = toppra_solve(robot, w, v, a, tau, prob.s)
        peer_d, peer_dt = toppra_solve(robot, w, v, a, tau, None)
        try:
            ra, ra_t = timed(lambda w=w: time_optimal_path(robot, w, method="reachability", **kw))
        except ArmlabError as exc:
            errors.append(f"time_optimal_path (reachability): {exc}")
            continue
        try:
            convex, convex_t = timed(
                lambda w=w: time_optimal_path(robot, w, method="convex", **kw), repeats=1
            )
            convex_d = convex.duration
        except ArmlabError as exc:  # the convex pass refused the path: no ratio to it
            errors.append(f"time_optimal_path (convex): {exc}")
            convex_t, convex_d = np.nan, np.nan
        if peer is None or peer_d is None:
            errors.append("toppra found no parameterisation")
            continue
        fine = ra.check_limits(robot, dt=ra.duration / CHECK_SAMPLES, limits=lim)
        smp = peer.limit_samples(peer.duration / CHECK_SAMPLES, robot=robot)
        k_peer, _, _ = stretch_needed(smp, robot, lim)
        rep = peer.check_limits(robot, dt=peer.duration / CHECK_SAMPLES, limits=lim)
        out["convex_t"].append(convex_t)
        out["ra_t"].append(ra_t)
        out["ra_solve_t"].append(ra.stats["solve_time_s"])
        out["ra_check_t"].append(ra.stats["check_time_s"])
        out["ra_traj_t"].append(ra.stats["trajectory_time_s"])
        out["peer_t"].append(peer_t)
        out["peer_default_t"].append(peer_dt)
        out["ra_convex"].append(ra.duration / convex_d)
        out["ra_peer"].append(ra.duration / peer.duration)
        out["ra_peer_default"].append(ra.duration / peer_d.duration)
        out["ra_peer_feasible"].append(ra.duration / (k_peer * peer.duration))
        out["ra_worst"].append(max(float(np.max(r)) for r in fine.ratios.values()))
        out["peer_worst"].append(max(float(np.max(r)) for r in rep.ratios.values()))
        out["rounds"].append(ra.stats["backoff_rounds"])
    res = {k: np.array(x) for k, x in out.items()}
    res["errors"] = errors  # type: ignore[assignment]
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a few cases per robot")
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
        for method in ("convex", "reachability"):
            try:
                time_optimal_path(
                    robot,
                    w,
                    v_max=v,
                    a_max=a,
                    j_max=False,
                    tau_max=tau,
                    n_grid=args.n_grid,
                    method=method,
                )
            except ArmlabError:
                pass
        rows.append((name, bench_robot(robot, extra, rng, n, args.n_grid)))

    quick = ", quick" if args.quick else ""
    print()
    print(
        f"TOPP on a fixed path, v/a/tau, {WAYPOINTS} waypoints, n_grid = {args.n_grid} "
        f"(seed {SEED:d}{quick}); times are medians over cases of the median of {REPEATS} calls"
    )
    hdr = f"{'quantity':<58}{'robot':<11}{'n':>4}  {'median':>10}  {'min':>10}  {'max':>10}"
    print(hdr)
    print("-" * len(hdr))

    def line(label, name, x, fmt="{:>10.4f}"):
        x = np.asarray(x)[np.isfinite(x)]
        if len(x) == 0:
            print(f"{label:<58}{name:<11}{0:>4}")
            return
        cells = "  ".join(fmt.format(f) for f in (np.median(x), np.min(x), np.max(x)))
        print(f"{label:<58}{name:<11}{len(x):>4}  {cells}")

    ms = "{:>10.2f}"
    for name, r in rows:
        line("time [ms]: method=convex (IPOPT), whole call", name, 1e3 * r["convex_t"], ms)
        line("time [ms]: method=reachability (ra), whole call", name, 1e3 * r["ra_t"], ms)
        line("time [ms]: ra, sweeps only", name, 1e3 * r["ra_solve_t"], ms)
        line("time [ms]: ... of which Trajectory build", name, 1e3 * r["ra_traj_t"], ms)
        line("time [ms]: ... of which limit check", name, 1e3 * r["ra_check_t"], ms)
        line("time [ms]: TOPP-RA, same grid", name, 1e3 * r["peer_t"], ms)
        line("time [ms]: TOPP-RA, its default grid", name, 1e3 * r["peer_default_t"], ms)
        line("time ratio: ra whole call / TOPP-RA same grid", name, r["ra_t"] / r["peer_t"])
        line("time ratio: ra sweeps / TOPP-RA same grid", name, r["ra_solve_t"] / r["peer_t"])
        line(
            "time ratio: ra without the limit check / TOPP-RA",
            name,
            (r["ra_t"] - r["ra_check_t"]) / r["peer_t"],
        )
        line("time ratio: convex / ra whole call", name, r["convex_t"] / r["ra_t"], ms)
        line("duration ratio: ra / convex", name, r["ra_convex"], "{:>10.5f}")
        line("duration ratio: ra / TOPP-RA same grid", name, r["ra_peer"], "{:>10.5f}")
        line("duration ratio: ra / TOPP-RA default grid", name, r["ra_peer_default"], "{:>10.5f}")
        line("duration ratio: ra / TOPP-RA made feasible", name, r["ra_peer_feasible"], "{:>10.5f}")
        line("worst limit ratio, T/4000 grid: ra", name, r["ra_worst"], "{:>10.6f}")
        line(
            "worst limit ratio, T/4000 grid: TOPP-RA same grid", name, r["peer_worst"], "{:>10.6f}"
        )
        line("back-off rounds: ra", name, r["rounds"], "{:>10.0f}")
        for e in r["errors"][:3]:
            print(f"      error: {e}")
    allr = {k: np.concatenate([r[k] for _, r in rows]) for k in ("ra_t", "peer_t", "ra_peer")}
    feas = np.concatenate([r["ra_peer_feasible"] for _, r in rows])
    print()
    print(
        f"goals: time ra / TOPP-RA same grid median {np.median(allr['ra_t'] / allr['peer_t']):.2f}"
        f" (<= 3); duration ra / TOPP-RA same grid median {np.median(allr['ra_peer']):.4f}, "
        f"made feasible median {np.median(feas):.4f} (<= 1)"
    )


if __name__ == "__main__":
    main()
