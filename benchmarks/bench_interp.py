"""Classical interpolators: points per second, side by side with the Robotics Toolbox.

Run: ``MPLBACKEND=Agg .venv/bin/python benchmarks/bench_interp.py``

Each row times one call that produces about ``N_POINTS`` samples (best of ``REPEATS``) and
reports samples per second. The Robotics Toolbox for Python (``roboticstoolbox``) runs beside
us where it has the same method: ``mtraj(trapezoidal)`` for the trapezoidal PTP, ``jtraj``
and ``mtraj(quintic)`` for the quintic, ``ctraj`` for Cartesian line poses, ``ctraj`` +
``ikine_LM`` (seeded by the previous point) for a line in joint space. The toolbox does not
check limits; our planners also find the limiting joint and check torques (RNEA at every
sample) — the rows ``torque=False`` show the planners without that check.
"""

from __future__ import annotations

import os
import time
import warnings

import numpy as np
from _readme import readme_row, sci, sig

os.environ.setdefault("MPLBACKEND", "Agg")
warnings.filterwarnings("ignore")

import armlab  # noqa: E402
from armlab.kinematics import fk  # noqa: E402
from armlab.trajectory import (  # noqa: E402
    LinePath,
    OnlineInterpolator,
    arc3,
    blend,
    cubic_via,
    line,
    ptp_sync,
    quintic_via,
    trapezoid_steps,
)

# ---------------------------------------------------------------------- parameters (data)
ROBOT = "teachbot6"
N_POINTS = 1000  # samples per call (approximately, for our planners)
REPEATS = 5  # best of
Q_START = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
Q_GOAL = [1.0, -0.5, 0.8, 2.0, -1.0, 0.3]
VIA = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.5, -0.3, 0.4, 1.0, 0.2, 0.0],
    [0.8, 0.2, 0.9, 0.5, -0.5, 1.0],
    [0.4, 0.3, 0.6, -0.5, 0.3, 0.5],
    [0.2, 0.1, 0.3, 0.0, 0.0, 0.0],
]
Q_CART = [0.3, 0.3, 0.9, 0.5, 0.7, 0.2]  # comfortable start for Cartesian moves
LINE_DP_M = [0.05, -0.1, 0.08]
LINE_SPEED = 0.05  # [m/s]
ARC_OFFSETS_M = ([0.02, 0.02, 0.0], [0.04, 0.0, 0.01])
BLEND_OFFSETS_M = ([0.06, 0.0, 0.0], [0.06, 0.06, 0.0], [0.0, 0.06, 0.04])
BLEND_RADIUS_M = 0.02
STEPS_ARGS = dict(length=1.0, v=0.1, a_acc=1.0, a_dec=0.5, period=0.001)
ONLINE_ARGS = dict(path=1.0, v_cruise=0.3, a_max=1.0)
ONLINE_PERIOD = 0.004


def best_time(fn, repeats=REPEATS):
    """(best wall time [s], result of the last call)."""
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def rate(n, seconds):
    return n / seconds if seconds > 0 else np.inf


def main() -> None:
    robot = armlab.load_robot(ROBOT)
    q0, q1 = np.array(Q_START), np.array(Q_GOAL)
    rows = []

    def ours(name, make, count=lambda tr: tr.n_samples):
        t, out = best_time(make)
        return name, rate(count(out), t), count(out)

    def dt_for(traj, n=N_POINTS):
        return traj.duration / (n - 1)

    try:
        import roboticstoolbox as rtb
        import spatialmath as sm

        rtb_robot = rtb.Robot.URDF(str(robot.urdf_path))
    except Exception as exc:  # pragma: no cover - benchmark-only peer
        print(f"roboticstoolbox unavailable ({exc}); armlab rows only")
        rtb = sm = rtb_robot = None

    def peer(make, n):
        if rtb is None:
            return None
        t, _ = best_time(make)
        return rate(n, t)

    # -- joint space ------------------------------------------------------------------
    for profile in ("trapezoid", "scurve", "velocity"):
        # "velocity" ramps in one period: with velocity limits only (the paper), so that the
        # sample period does not change the plan
        extra = {"a_max": np.inf} if profile == "velocity" else {}
        probe = ptp_sync(robot, q0, q1, profile, **extra)
        dt = dt_for(probe)
        for torque in (True, False):
            name, r, n = ours(
                f"ptp_sync {profile} torque={torque}",
                lambda p=profile, d=dt, tq=torque, e=extra: ptp_sync(
                    robot, q0, q1, p, dt=d, tau_max=None if tq else False, **e
                ),
            )
            rr, peer_name = None, "-"
            if profile == "trapezoid":
                rr = peer(lambda n=n: rtb.mtraj(rtb.trapezoidal, q0, q1, n), n)
                peer_name = "mtraj(trapezoidal)"
            rows.append((name, r, n, peer_name, rr))

    T = quintic_via(robot, np.array([q0, q1])).duration  # the shortest within the limits
    W2 = np.array([q0, q1])
    for torque in (True, False):
        name, r, n = ours(
            f"quintic_via 2 points torque={torque}",
            lambda tq=torque: quintic_via(
                robot, W2, durations=[T], dt=T / (N_POINTS - 1), tau_max=None if tq else False
            ),
        )
        rows.append((name, r, n, "jtraj", peer(lambda n=n: rtb.jtraj(q0, q1, n), n)))
    rows.append(
        ("  (same)", r, n, "mtraj(quintic)", peer(lambda: rtb.mtraj(rtb.quintic, q0, q1, n), n))
    )
    W = np.array(VIA)
    probe = cubic_via(robot, W)
    for fn, label in ((cubic_via, "cubic_via 5 points"), (quintic_via, "quintic_via 5 points")):
        name, r, n = ours(label, lambda f=fn: f(robot, W, dt=dt_for(probe)))
        rows.append((name, r, n, "-", None))
    t, plan = best_time(lambda: trapezoid_steps(**STEPS_ARGS))
    rows.append(("trapezoid_steps (SHU paper)", rate(plan.n_steps, t), plan.n_steps, "-", None))

    # -- Cartesian ----------------------------------------------------------------------
    qc = np.array(Q_CART)
    T0 = fk(robot, qc)
    T1 = T0.copy()
    T1[:3, 3] += LINE_DP_M
    path = LinePath(T0, T1, "hold")
    s = np.linspace(0, path.length, N_POINTS)
    name, r, n = ours("LinePath.point (poses only)", lambda: path.point(s), count=len)
    if rtb is not None:
        S0, S1 = sm.SE3(T0, check=False), sm.SE3(T1, check=False)
    rows.append((name, r, n, "ctraj (poses)", peer(lambda: rtb.ctraj(S0, S1, n), n)))
    probe = line(robot, T0, T1, LINE_SPEED, q_start=qc, orientation="hold")
    dtl = dt_for(probe)
    for torque in (True, False):
        name, r, n = ours(
            f"line + IK + limits torque={torque}",
            lambda tq=torque: line(
                robot,
                T0,
                T1,
                LINE_SPEED,
                q_start=qc,
                orientation="hold",
                dt=dtl,
                tau_max=None if tq else False,
            ),
        )

        def rtb_line(n=n):
            poses = rtb.ctraj(S0, S1, n)
            q = qc.copy()
            out = np.empty((n, 6))
            for k in range(n):
                q = rtb_robot.ikine_LM(poses[k], q0=q, end="tool0").q
                out[k] = q
            return out

        if torque:
            rtb_rate = peer(rtb_line, n)
        rows.append((name, r, n, "ctraj + ikine_LM", rtb_rate))
    p1 = T0[:3, 3]
    p2, p3 = (p1 + np.array(o) for o in ARC_OFFSETS_M)
    probe = arc3(robot, p1, p2, p3, LINE_SPEED, q_start=qc)
    name, r, n = ours(
        "arc3 + IK + limits",
        lambda: arc3(robot, p1, p2, p3, LINE_SPEED, q_start=qc, dt=dt_for(probe)),
    )
    rows.append((name, r, n, "-", None))
    pts = np.array([p1] + [p1 + np.array(o) for o in BLEND_OFFSETS_M])
    probe = blend(robot, pts, BLEND_RADIUS_M, LINE_SPEED, q_start=qc)
    name, r, n = ours(
        "blend (FlyBy) + IK + limits",
        lambda: blend(robot, pts, BLEND_RADIUS_M, LINE_SPEED, q_start=qc, dt=dt_for(probe)),
    )
    rows.append((name, r, n, "-", None))

    # -- online ---------------------------------------------------------------------------
    def online():
        oi = OnlineInterpolator(**ONLINE_ARGS)
        k = 0
        while not oi.done:
            oi.step(ONLINE_PERIOD, 1.0 if k % 500 < 400 else 0.3)
            k += 1
        return k

    t, k = best_time(online)
    rows.append(("OnlineInterpolator.step (Li, Meng, Chen)", rate(k, t), k, "-", None))

    # -- table --------------------------------------------------------------------------
    print(f"robot {ROBOT}, ~{N_POINTS} samples per call, best of {REPEATS}\n")
    head = (
        f"{'armlab':40s} {'points':>7s} {'points/s':>12s}   {'Robotics Toolbox':18s} "
        f"{'points/s':>12s} {'ratio':>7s}"
    )
    print(head)
    print("-" * len(head))
    for name, r, n, pname, pr in rows:
        ps = f"{pr:12.3g}" if pr is not None else f"{'-':>12s}"
        ratio = f"{r / pr:7.2f}" if pr else f"{'-':>7s}"
        print(f"{name:40s} {n:7d} {r:12.3g}   {pname:18s} {ps} {ratio}")
    print(
        "\npoints/s = samples produced / wall time of one call. armlab planners also choose the"
        "\nduration from the joint limits and verify them (torque=True adds inverse dynamics at"
        "\nevery sample); the toolbox functions only evaluate the profile for a given time."
        "\n'ptp_sync velocity torque=True': the one-period velocity steps of Jiang 1987 need more"
        "\ntorque than the drives have, so the planner slows down (more samples)."
    )
    by_name = {r[0]: r for r in rows}
    _, r_line, _, _, rr_line = by_name["line + IK + limits torque=True"]
    readme_row(
        __file__,
        "line through IK with limit checks",
        f"{sci(r_line)} points/s",
        f"RTB `ctraj` + `ikine_LM` {sig(rr_line)} points/s"
        if rr_line
        else "Robotics Toolbox not installed",
    )
    steps = by_name["trapezoid_steps (SHU paper)"][1]
    online = by_name["OnlineInterpolator.step (Li, Meng, Chen)"][1]
    readme_row(
        __file__,
        "SHU controller paper step lengths; online interpolator step",
        f"{sci(steps)} steps/s; {sci(online)} steps/s",
    )


if __name__ == "__main__":
    main()
