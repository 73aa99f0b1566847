"""``optimal()`` on fatrop (compiled stage functions) vs IPOPT, in one process (issue 26).

teachbot6, its own v/a/j/tau limits, waypoints uniform in 70 % of each joint range (the
scaling cases of ``bench_trajectory.py``, same seeds), 2/5/10/20 waypoints. Per size: the
compile of the stage library (once per robot kinematics, into a fresh temporary cache unless
``--cache`` is given), then for each solver (``ARMLAB_SOLVER``, alternating case by case) the
first call on the waypoint count (IPOPT builds its problem per size, fatrop makes an instance)
and the repeat calls: median / p90 of the whole ``optimal()`` call and of the solve
(``stats["solve_time_s"]``), and the largest relative duration difference.
Goals (issue 26): durations within 1e-6 of IPOPT's; first call <= 3 x a repeat.

Run:  ``.venv/bin/python benchmarks/bench_fatrop.py [--quick] [--cache DIR]``
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

import armlab  # noqa: E402
from armlab.planning import fatrop_stages  # noqa: E402
from armlab.trajectory import optimal  # noqa: E402

SEED = 20240605  # bench_trajectory.py's; its scaling cases use SEED + 5 + waypoints
RANGE = 0.7
WAYPOINTS = (2, 5, 10, 20)
CASES = 10
QUICK_CASES = 3
SOLVERS = ("ipopt", "fatrop")


def statically_ok(robot, q) -> bool:
    g = pin.computeGeneralizedGravity(robot.model, robot.model.createData(), q)
    return bool(np.all(np.abs(g) <= 0.9 * robot.limits.effort_Nm))


def cases_for(robot, nw: int, n: int) -> list[np.ndarray]:
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * RANGE
    rng = np.random.default_rng(SEED + 5 + nw)
    out: list[np.ndarray] = []
    while len(out) < n:
        w = mid + half * (2 * rng.random((nw, robot.n_joints)) - 1)
        if all(statically_ok(robot, q) for q in w):
            out.append(w)
    return out


def one_call(robot, w, solver: str) -> tuple[float, dict]:
    os.environ["ARMLAB_SOLVER"] = solver
    t0 = time.perf_counter()
    traj = optimal(robot, w)
    return time.perf_counter() - t0, traj.stats


def q(x, p) -> float:
    return float(np.percentile(np.asarray(x) * 1e3, p))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help=f"{QUICK_CASES} cases per size")
    ap.add_argument("--cache", help="compile into / load from this cache folder")
    args = ap.parse_args()
    n = QUICK_CASES if args.quick else CASES
    cache = args.cache or tempfile.mkdtemp(prefix="armlab-bench-cache-")
    os.environ["ARMLAB_CACHE_DIR"] = cache
    robot = armlab.load_robot("teachbot6")
    t0, c0 = time.perf_counter(), os.times()
    _, took = fatrop_stages.compiled_library(robot)
    c1 = os.times()
    cpu = (c1.children_user + c1.children_system) - (c0.children_user + c0.children_system)
    print(
        f"stage library of teachbot6: {'compiled' if took else 'cached'} in "
        f"{time.perf_counter() - t0:.1f} s wall ({cpu:.1f} s compiler CPU), cache {cache}"
    )
    hdr = (
        f"{'wp':>3} {'solver':<7} {'n':>3} | {'call med/p90 [ms]':>18} | "
        f"{'solve med/p90 [ms]':>18} | {'first call [ms]':>15} {'first/repeat':>12} | "
        f"{'iter med':>8} | {'fallbacks':>9}"
    )
    print(hdr)
    print("-" * len(hdr))
    for nw in WAYPOINTS:
        cases = cases_for(robot, nw, n + 1)
        first = {s: one_call(robot, cases[0], s) for s in SOLVERS}  # a new waypoint count
        calls: dict = {s: [] for s in SOLVERS}
        for w in cases[1:]:
            for s in SOLVERS if len(calls["ipopt"]) % 2 else SOLVERS[::-1]:
                calls[s].append(one_call(robot, w, s))
        T = {s: np.array([st["duration_s"] for _, st in calls[s]]) for s in SOLVERS}
        dev = float(np.max(np.abs(T["fatrop"] / T["ipopt"] - 1)))
        for s in SOLVERS:
            wall = [c for c, _ in calls[s]]
            solve = [st["solve_time_s"] for _, st in calls[s]]
            iters = np.median([st["iterations"] for _, st in calls[s]])
            fb = sum(bool(st["fallback"]) and st["solver"] != s for _, st in calls[s])
            print(
                f"{nw:>3} {s:<7} {n:>3} | {q(wall, 50):>8.1f} /{q(wall, 90):>8.1f} | "
                f"{q(solve, 50):>8.1f} /{q(solve, 90):>8.1f} | {first[s][0] * 1e3:>15.1f} "
                f"{first[s][0] / np.median(wall):>12.2f} | {iters:>8.0f} | {fb:>9d}",
                flush=True,
            )
        ratio = np.median([c for c, _ in calls["ipopt"]]) / np.median(
            [c for c, _ in calls["fatrop"]]
        )
        print(f"{'':>3} whole call ipopt/fatrop {ratio:.2f}; max |T_fatrop/T_ipopt - 1| {dev:.1e}")


if __name__ == "__main__":
    main()
