"""``optimal()`` on fatrop (compiled stage functions) vs IPOPT, in one process (issue 26).

teachbot6, its own v/a/j/tau limits, waypoints uniform in 70 % of each joint range (the
scaling cases of ``bench_trajectory.py``, same seeds), 2/5/10/20 waypoints. Per size: the
compile of the stage library (once per robot kinematics, into a fresh temporary cache unless
``--cache`` is given), then for each solver (``ARMLAB_SOLVER``, alternating case by case) the
first call on the waypoint count (IPOPT builds its problem per size, fatrop makes an instance)
and the repeat calls: median / p90 of the whole ``optimal()`` call and of the solve
(``stats["solve_time_s"]``), and the largest relative duration difference.
Goals (issue 26): durations within 1e-6 of IPOPT's; first call <= 3 x a repeat.

With ``--variants``: the other stage libraries (issue 26) on 3-waypoint cases of the same
draw (the middle half of each range, as ``bench_trajectory.py``'s drive row): per variant the
compile (wall and the compiler's CPU; with drive rows of both libraries, the one without the
RMS row that every drive plan solves first and the one with it), then IPOPT and fatrop
alternating case by case, the first case dropped (IPOPT builds its problem): median whole
call and solve, ipopt / fatrop, the largest relative duration difference (for the fixed
duration: of the jerk objective's value).

With ``--energy``: the ``"energy"`` objective's stage libraries on 3- and 5-waypoint cases of
the same draw as ``--variants``, each case over 1.5 x its own minimum duration (the
time-optimal plan of the same request): per request (jerk or acceleration mode, torque box
or drive_limits) IPOPT and fatrop alternating case by case, the first case dropped: median
whole call and solve, ipopt / fatrop, the median and largest relative difference of
``stats["energy"]``, on how many cases fatrop's energy is lower / higher than IPOPT's by more
than 1e-6 (the problem is not convex: the two solvers can stop in different local minima),
and fatrop's fallbacks.

Run:  ``.venv/bin/python benchmarks/bench_fatrop.py [--quick] [--variants] [--energy]
[--cache DIR]``
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from bench_trajectory import SCALING_RANGE, random_cases  # noqa: E402

import armlab  # noqa: E402
from armlab.planning import fatrop_stages  # noqa: E402
from armlab.trajectory import optimal  # noqa: E402

SEED = 20240605  # bench_trajectory.py's; its scaling cases use SEED + 5 + waypoints
RANGE = SCALING_RANGE  # bench_trajectory.py's cases (random_cases)
WAYPOINTS = (2, 5, 10, 20)
CASES = 10
QUICK_CASES = 3
SOLVERS = ("ipopt", "fatrop")


def cases_for(robot, nw: int, n: int) -> list[np.ndarray]:
    """The cases of bench_trajectory.py's section 5 (its :func:`random_cases`, seed
    ``SEED + 5 + nw``)."""
    return random_cases(robot, nw, n, SEED + 5 + nw)


def one_call(robot, w, solver: str) -> tuple[float, dict]:
    os.environ["ARMLAB_SOLVER"] = solver
    t0 = time.perf_counter()
    traj = optimal(robot, w)
    return time.perf_counter() - t0, traj.stats


#: the variants' requests (teachbot6's own limits otherwise) and their stage library
VARIANTS = {
    "jerk, torque box": ({}, ("jerk", False, False)),
    "acceleration, torque box": ({"j_max": False}, ("acceleration", False, False)),
    "acceleration, v/torque": ({"a_max": False, "j_max": False}, ("acceleration", False, False)),
    "acceleration, drive_limits": (
        {"a_max": False, "j_max": False, "drive_limits": True},
        ("acceleration", True, False),
    ),
    "jerk, drive_limits": ({"drive_limits": True}, ("jerk", True, False)),
    "jerk objective, duration": ({"objective": "jerk", "duration": 12.0}, ("jerk", False, True)),
}


def _libraries(var: tuple) -> list:
    """The stage libraries of a variant row: with drive rows the one without the RMS row (every
    drive plan solves it first) and the one with it (a plan whose RMS row binds)."""
    mode, drive, duration = var
    full = fatrop_stages.Variant(mode, drive, duration)
    return [fatrop_stages.Variant(mode, drive, duration, rms=False), full] if drive else [full]


def variant_table(robot, n: int) -> None:
    """``--variants`` (module docstring)."""
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * RANGE * 0.5  # bench_trajectory.py drive row
    rng = np.random.default_rng(SEED + 73)
    cases = [mid + half * (2 * rng.random((3, robot.n_joints)) - 1) for _ in range(n + 1)]
    hdr = (
        f"{'variant':<28} | {'compile wall/CPU [s]':>20} | {'ipopt call/solve [ms]':>21} | "
        f"{'fatrop call/solve [ms]':>22} | {'ipopt/fatrop':>12} | {'max dev':>7} | fb"
    )
    print(hdr)
    print("-" * len(hdr))
    for name, (kw, var) in VARIANTS.items():
        t0, c0 = time.perf_counter(), os.times()
        for lib in _libraries(var):
            fatrop_stages.compiled_library(robot, lib)
        c1 = os.times()
        cpu = (c1.children_user + c1.children_system) - (c0.children_user + c0.children_system)
        wall_c = time.perf_counter() - t0
        res: dict = {s: [] for s in SOLVERS}
        for i, w in enumerate(cases):
            for s in SOLVERS if i % 2 else SOLVERS[::-1]:
                os.environ["ARMLAB_SOLVER"] = s
                t1 = time.perf_counter()
                traj = optimal(robot, w, **kw)
                if i:
                    res[s].append((time.perf_counter() - t1, traj))
        if "duration" in kw:  # the jerk objective's value, the plans' durations being fixed
            val = {s: [_jerk_value(robot, t) for _, t in res[s]] for s in res}
        else:
            val = {s: [t.stats["duration_s"] for _, t in res[s]] for s in res}
        dev = float(np.max(np.abs(np.array(val["fatrop"]) / np.array(val["ipopt"]) - 1)))
        med = {
            s: (
                np.median([c for c, _ in res[s]]),
                np.median([t.stats["solve_time_s"] for _, t in res[s]]),
            )
            for s in SOLVERS
        }
        fb = sum(t.stats["solver"] != "fatrop" for _, t in res["fatrop"])
        print(
            f"{name:<28} | {wall_c:>9.1f} /{cpu:>9.1f} | {1e3 * med['ipopt'][0]:>10.0f} /"
            f"{1e3 * med['ipopt'][1]:>9.0f} | {1e3 * med['fatrop'][0]:>11.0f} /"
            f"{1e3 * med['fatrop'][1]:>9.0f} | {med['ipopt'][0] / med['fatrop'][0]:>12.1f} | "
            f"{dev:>7.1e} | {fb}",
            flush=True,
        )
    os.environ.pop("ARMLAB_SOLVER", None)


#: the energy objective's requests (teachbot6's own limits otherwise; the stage libraries
#: jerk-dur-energy, acc-dur-energy, jerk-drive-dur-energy, acc-drive-dur-energy)
ENERGY_REQUESTS = {
    "jerk, torque box": {},
    "acceleration, torque box": {"j_max": False},
    "jerk, drive_limits": {"drive_limits": True},
    "acceleration, drive_limits": {"a_max": False, "j_max": False, "drive_limits": True},
}
#: the energy plans' duration over the case's minimum duration
ENERGY_SLACK = 1.5


def energy_table(robot, n: int) -> None:
    """``--energy`` (module docstring)."""
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * RANGE * 0.5  # as variant_table
    hdr = (
        f"{'wp':>2} {'request':<26} | {'ipopt call/solve [ms]':>21} | "
        f"{'fatrop call/solve [ms]':>22} | {'ipopt/fatrop':>12} | {'med|dE|':>7} | "
        f"{'max|dE|':>7} | {'lower/higher':>12} | fb"
    )
    print(hdr)
    print("-" * len(hdr))
    for nw in (3, 5):
        rng = np.random.default_rng(SEED + 79 + nw)
        cases = [mid + half * (2 * rng.random((nw, robot.n_joints)) - 1) for _ in range(n + 1)]
        for name, kw in ENERGY_REQUESTS.items():
            res: dict = {s: [] for s in SOLVERS}
            for i, w in enumerate(cases):
                os.environ["ARMLAB_SOLVER"] = "fatrop"
                tmin = optimal(robot, w, **kw).stats["duration_s"]
                ekw = {**kw, "objective": "energy", "duration": ENERGY_SLACK * tmin}
                for s in SOLVERS if i % 2 else SOLVERS[::-1]:
                    os.environ["ARMLAB_SOLVER"] = s
                    t1 = time.perf_counter()
                    traj = optimal(robot, w, **ekw)
                    if i:
                        res[s].append((time.perf_counter() - t1, traj.stats))
            e = {s: np.array([st["energy"] for _, st in res[s]]) for s in SOLVERS}
            rel = e["fatrop"] / e["ipopt"] - 1  # local minima: who found the lower one
            lower, higher = int(np.sum(rel < -1e-6)), int(np.sum(rel > 1e-6))
            med = {
                s: (
                    np.median([c for c, _ in res[s]]),
                    np.median([st["solve_time_s"] for _, st in res[s]]),
                )
                for s in SOLVERS
            }
            fb = sum(st["solver"] != "fatrop" for _, st in res["fatrop"])
            print(
                f"{nw:>2} {name:<26} | {1e3 * med['ipopt'][0]:>10.0f} /"
                f"{1e3 * med['ipopt'][1]:>9.0f} | {1e3 * med['fatrop'][0]:>11.0f} /"
                f"{1e3 * med['fatrop'][1]:>9.0f} | {med['ipopt'][0] / med['fatrop'][0]:>12.1f} | "
                f"{np.median(np.abs(rel)):>7.1e} | {np.max(np.abs(rel)):>7.1e} | "
                f"{lower:>5d} /{higher:>5d} | {fb}",
                flush=True,
            )
    os.environ.pop("ARMLAB_SOLVER", None)


def _jerk_value(robot, traj) -> float:
    """The jerk objective, integral of (jerk / j_max)^2 on a fine grid (trapezoid)."""
    t = np.linspace(traj.t[0], traj.t[-1], 20001)
    jerk = traj.at(t)[3] / robot.limits.jerk_rad_s3
    return float(np.trapezoid(np.sum(jerk**2, axis=1), t))


def q(x, p) -> float:
    return float(np.percentile(np.asarray(x) * 1e3, p))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help=f"{QUICK_CASES} cases per size")
    ap.add_argument("--cache", help="compile into / load from this cache folder")
    ap.add_argument("--variants", action="store_true", help="the variants' table (3 waypoints)")
    ap.add_argument("--energy", action="store_true", help="the energy objective (3, 5 waypoints)")
    args = ap.parse_args()
    n = QUICK_CASES if args.quick else CASES
    cache = args.cache or tempfile.mkdtemp(prefix="armlab-bench-cache-")
    os.environ["ARMLAB_CACHE_DIR"] = cache
    robot = armlab.load_robot("teachbot6")
    if args.variants:
        variant_table(robot, n)
        return
    if args.energy:
        energy_table(robot, n)
        return
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
