"""Benchmark armlab.dynamics: RNEA throughput and full drive sizing of a 10 s, 1 kHz trajectory.

Goal (issue 3): the full sizing (RNEA + motor side + every check of every joint) of such a
trajectory in under 50 ms. Run: ``MPLBACKEND=Agg .venv/bin/python benchmarks/bench_dynamics.py``
"""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin
from _readme import readme_row, sci, sig

import armlab
from armlab.dynamics import inverse_dynamics, requirement_moves, select_drives, size, static_load
from armlab.dynamics.inverse import joint_torques
from armlab.trajectory import Trajectory

# ----------------------------------------------------------------------------- parameters
ROBOT = "teachbot6"
DURATION_S = 10.0
RATE_HZ = 1000.0
FREQ_HZ = 0.1  # sine motion of every joint, inside the speed limits
AMPLITUDE_RAD = (0.8, 0.35, 0.6, 1.2, 1.0, 1.5)
REPEATS = 7
GOAL_SIZING_MS = 50.0


def sine_trajectory(n_joints: int) -> Trajectory:
    t = np.arange(int(round(DURATION_S * RATE_HZ)) + 1) / RATE_HZ
    w = 2 * np.pi * FREQ_HZ
    amp = np.asarray(AMPLITUDE_RAD[:n_joints])
    phase = np.linspace(0, np.pi, n_joints)
    s = np.sin(w * t[:, None] + phase)
    c = np.cos(w * t[:, None] + phase)
    return Trajectory(t, amp * s, amp * w * c, -amp * w**2 * s, -amp * w**3 * c, method="sine")


def timed(fn, repeats: int = REPEATS) -> tuple[float, float]:
    """(best, median) wall time in [s]."""
    fn()  # warm up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), float(np.median(times))


def main() -> None:
    robot = armlab.load_robot(ROBOT)
    traj = sine_trajectory(robot.n_joints)
    n = traj.n_samples
    model, data = robot.model, robot.model.createData()

    def loop_rnea():
        for k in range(n):
            pin.rnea(model, data, traj.q[k], traj.qd[k], traj.qdd[k])

    rows = [
        ("pinocchio.rnea, Python loop (Trajectory.torques)", n, lambda: traj.torques(robot)),
        ("pinocchio.rnea, bare Python loop", n, loop_rnea),
        (
            "joint_torques (rneaInParallel, 1 thread)",
            n,
            lambda: joint_torques(robot, traj.q, traj.qd, traj.qdd, threads=1),
        ),
        (
            "joint_torques (rneaInParallel, 2 threads)",
            n,
            lambda: joint_torques(robot, traj.q, traj.qd, traj.qdd, threads=2),
        ),
        ("inverse_dynamics (+ motor side)", n, lambda: inverse_dynamics(robot, traj)),
        ("size: full sizing, 1 thread", n, lambda: size(robot, traj, controller="reference_dda")),
        (
            "size: full sizing, 2 threads",
            n,
            lambda: size(robot, traj, threads=2, controller="reference_dda"),
        ),
    ]
    static = static_load(robot)
    moves = requirement_moves(robot, static)
    n_moves = sum(m.n_samples for m in moves)
    slow = [
        ("static_load (6 joints, multi-start L-BFGS-B)", 0, lambda: static_load(robot)),
        (
            "select_drives (every catalogue pair x 6 joints)",
            n_moves,
            lambda: select_drives(robot, moves, controller="reference_dda", allow_estimated=True),
        ),
    ]
    print(
        f"armlab.dynamics benchmark: {ROBOT}, {DURATION_S:g} s at {RATE_HZ:g} Hz "
        f"({n} samples), best / median of {REPEATS}\n"
    )
    print(f"{'what':<52}{'best [ms]':>11}{'median [ms]':>13}{'samples/s':>13}")
    print("-" * 89)
    best_s = {}
    for name, samples, fn in rows + slow:
        best, med = timed(fn, REPEATS if samples else 3)
        rate = f"{samples / best:>13.3g}" if samples else f"{'-':>13}"
        print(f"{name:<52}{best * 1e3:>11.2f}{med * 1e3:>13.2f}{rate}")
        best_s[name] = best
    sizing_best = best_s["size: full sizing, 1 thread"]
    verdict = "met" if sizing_best * 1e3 < GOAL_SIZING_MS else "NOT met"
    print(
        f"\ngoal: full sizing of the 10 s trajectory < {GOAL_SIZING_MS:g} ms -> "
        f"{sizing_best * 1e3:.1f} ms, {verdict}"
    )
    report = size(robot, traj, controller="reference_dda")
    print(f"sizing verdict of the sine trajectory: ok={report.ok}, failures={report.failures()}")
    t1, t2 = (best_s[f"joint_torques (rneaInParallel, {k})"] for k in ("1 thread", "2 threads"))
    readme_row(
        __file__,
        f"RNEA, {DURATION_S:g} s at {RATE_HZ / 1e3:g} kHz ({sig(n, 6)} samples), 1 / 2 threads",
        f"{t1 * 1e3:.1f} ms / {t2 * 1e3:.1f} ms ({sci(n / t1)} / {sci(n / t2)} samples/s)",
        f"`pin.rnea` Python loop {best_s['pinocchio.rnea, bare Python loop'] * 1e3:.1f} ms",
    )
    readme_row(
        __file__,
        f"full drive sizing of that trajectory (goal < {GOAL_SIZING_MS:g} ms)",
        f"{sizing_best * 1e3:.1f} ms",
    )


if __name__ == "__main__":
    main()
