"""Benchmark of armlab.kinematics: FK, Jacobian, analytic IK (single and batched) and numerical
IK, with the Robotics Toolbox for Python's ``ik_LM`` run beside ours on the same poses.

Run: ``MPLBACKEND=Agg .venv/bin/python benchmarks/bench_kinematics.py`` (headless, one thread).

Poses are FK of uniform random in-range configurations; numerical IK starts from a random
in-range seed ("cold") or from the true configuration plus N(0, 0.1 rad) noise ("warm", the
path-tracking case). Success is judged the same way for both libraries: position error
<= 1e-6 m, rotation error <= 1e-6 rad, configuration inside the joint ranges.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core

import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
import xml.etree.ElementTree as ET  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402
from _readme import readme_row, sig  # noqa: E402

import armlab  # noqa: E402
from armlab.kinematics import (  # noqa: E402
    fk,
    fk_batch,
    ik_all,
    ik_all_batch,
    ik_nearest,
    ik_solve,
    jacobian,
)

# ------------------------------------------------------------------ parameters (data)
PARAMS = {
    "seed": 0,
    "n_fk": 5000,  # single FK / Jacobian calls
    "n_batch_fk": 20000,  # configurations in one fk_batch / dh.fk call
    "n_ik_single": 3000,  # ik_all calls, one pose each
    "n_ik_batch": 100_000,  # poses in one ik_all_batch / ik_nearest call
    "n_numerical": 300,  # poses per robot for numerical IK (ours and ik_LM)
    "warm_noise_rad": 0.1,  # std of the seed perturbation for "warm" starts
    "tol_pos_m": 1e-6,
    "tol_rot_rad": 1e-6,
    "robots_numerical": ["teachbot6", "ur5", "panda"],
    "rtb_ilimit": 30,  # ik_LM iterations per search (its default)
    "rtb_slimit": 100,  # ik_LM searches (its default)
    "goal_ik_batch_per_s": 100_000,  # batched analytic IK
}
NAMES = {"teachbot6": "teachbot6", "ur5": "UR5", "panda": "Panda"}  # in the README

ERD = (
    Path(sys.prefix)
    / "lib"
    / f"python{sys.version_info.major}.{sys.version_info.minor}"
    / "site-packages"
    / "cmeel.prefix"
    / "share"
    / "example-robot-data"
    / "robots"
)
URDFS = {
    "ur5": ERD / "ur_description/urdf/ur5_robot.urdf",
    "panda": ERD / "panda_description/urdf/panda.urdf",
}


def load(name: str):
    if name == "teachbot6":
        return armlab.load_robot("teachbot6")
    if name == "ur5":
        return armlab.load_robot(URDFS["ur5"])
    if name == "panda":
        return armlab.load_robot(
            URDFS["panda"],
            tool_frame="panda_hand",
            lock_joints=("panda_finger_joint1", "panda_finger_joint2"),
        )
    raise ValueError(name)


def rate(n: int, seconds: float) -> float:
    return n / seconds if seconds > 0 else float("inf")


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def pose_errors(robot, q, T) -> tuple[float, float]:
    Tq = fk(robot, q)
    pos = float(np.linalg.norm(Tq[:3, 3] - T[:3, 3]))
    rot = float(np.linalg.norm(pin.log3(Tq[:3, :3].T @ T[:3, :3])))
    return pos, rot


# ------------------------------------------------------------------ Robotics Toolbox twins
def rtb_robot(name: str, robot):
    """The same arm in roboticstoolbox (None if unavailable), its end link name and the fixed
    transform ``T_tool_in_end`` (targets for ik_LM are ``T @ inv(T_tool_in_end)``: ik_LM
    ignores a DHRobot's ``tool``)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import roboticstoolbox as rtb
    except Exception as exc:  # noqa: BLE001 - optional peer
        print(f"# roboticstoolbox unavailable: {exc}")
        return None, None, None
    tool = np.eye(4)
    if name == "teachbot6":  # from the DH table (MDH links)
        dh = robot.dh
        links = [
            rtb.RevoluteMDH(
                a=dh.a_m[i],
                alpha=dh.alpha_rad[i],
                d=dh.d_m[i],
                offset=dh.offset_rad[i],
                qlim=[robot.limits.lower_rad[i], robot.limits.upper_rad[i]],
            )
            for i in range(6)
        ]
        twin = rtb.DHRobot(links, name=name)
        tool = robot.model.frames[robot.tool_frame_id].placement.homogeneous
        end = None
    elif name == "ur5":  # from the URDF, meshes stripped (package:// paths unresolvable)
        tree = ET.parse(URDFS["ur5"])
        for link in tree.getroot().findall("link"):
            for tag in ("visual", "collision"):
                for e in link.findall(tag):
                    link.remove(e)
        path = Path(tempfile.mkdtemp()) / "ur5.urdf"
        tree.write(path)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            twin = rtb.Robot.URDF(str(path))
        end = robot.tool_frame
    else:
        return None, None, None
    q = robot.random_q(np.random.default_rng(1))
    T = (twin.fkine(q, end=end).A if end else twin.fkine(q).A) @ tool
    err = np.abs(T - fk(robot, q)).max()
    assert err < 1e-12, f"rtb twin of {name} disagrees with armlab FK by {err}"
    return twin, end, tool


# ------------------------------------------------------------------ sections
def bench_forward(rows: list) -> None:
    p = PARAMS
    robot = load("teachbot6")
    rng = np.random.default_rng(p["seed"])
    q = robot.random_q(rng, p["n_fk"])
    _, t = timed(lambda: [fk(robot, qk) for qk in q])
    rows.append(("teachbot6", "fk (Pinocchio), single", p["n_fk"], rate(p["n_fk"], t), "", ""))
    _, t = timed(lambda: [jacobian(robot, qk) for qk in q])
    rows.append(("teachbot6", "jacobian (world), single", p["n_fk"], rate(p["n_fk"], t), "", ""))
    qb = robot.random_q(rng, p["n_batch_fk"])
    _, t = timed(lambda: fk_batch(robot, qb))
    rows.append(
        (
            "teachbot6",
            "fk_batch (Pinocchio loop)",
            p["n_batch_fk"],
            rate(p["n_batch_fk"], t),
            "",
            "",
        )
    )
    _, t = timed(lambda: robot.dh.fk(qb))
    rows.append(
        (
            "teachbot6",
            "dh.fk (closed form, numpy)",
            p["n_batch_fk"],
            rate(p["n_batch_fk"], t),
            "",
            "",
        )
    )


def bench_analytic(rows: list) -> None:
    p = PARAMS
    robot = load("teachbot6")
    rng = np.random.default_rng(p["seed"] + 1)
    q = robot.random_q(rng, p["n_ik_batch"])
    T = robot.dh.fk(q)
    n1 = p["n_ik_single"]
    sols, t = timed(lambda: [ik_all(robot, T[k]) for k in range(n1)])
    found = np.mean([np.abs(s - q[k]).max(axis=1).min() < 1e-6 for k, s in enumerate(sols)])
    rows.append(
        ("teachbot6", "ik_all, one pose per call", n1, rate(n1, t), f"{100 * found:.2f}", "")
    )
    (sol, valid), t = timed(lambda: ik_all_batch(robot, T))
    found = np.where(valid, np.abs(sol - q[:, None]).max(axis=2), np.inf).min(axis=1) < 1e-6
    rows.append(
        (
            "teachbot6",
            "ik_all_batch (poses/s)",
            len(T),
            rate(len(T), t),
            f"{100 * found.mean():.2f}",
            "",
        )
    )
    out, t = timed(lambda: ik_nearest(robot, T, q))
    ok = np.abs(out - q).max(axis=1) < 1e-6
    rows.append(
        (
            "teachbot6",
            "ik_nearest batched (poses/s)",
            len(T),
            rate(len(T), t),
            f"{100 * ok.mean():.2f}",
            "",
        )
    )


def bench_numerical(rows: list) -> None:
    p = PARAMS
    for name in p["robots_numerical"]:
        robot = load(name)
        twin, end, tool = rtb_robot(name, robot)
        rng = np.random.default_rng(p["seed"] + 2)
        n = p["n_numerical"]
        q = robot.random_q(rng, n)
        T = fk_batch(robot, q)
        seeds = {
            "cold": robot.random_q(rng, n),
            "warm": np.clip(
                q + p["warm_noise_rad"] * rng.standard_normal(q.shape),
                robot.limits.lower_rad,
                robot.limits.upper_rad,
            ),
        }
        for start, q0 in seeds.items():
            res, t = timed(
                lambda q0=q0, robot=robot, T=T, n=n: [
                    ik_solve(
                        robot,
                        T[k],
                        q0[k],
                        tol_pos_m=p["tol_pos_m"],
                        tol_rot_rad=p["tol_rot_rad"],
                        rng=np.random.default_rng(k),
                    )
                    for k in range(n)
                ]
            )
            ok = np.mean([r.success for r in res])
            iters = np.median([r.iterations for r in res])
            rows.append(
                (
                    name,
                    f"armlab ik_solve (OSQP), {start} seed",
                    n,
                    rate(n, t),
                    f"{100 * ok:.2f}",
                    f"{iters:g}",
                )
            )
            if twin is None:
                continue
            kw = {"end": end} if end else {}
            T_end = T @ np.linalg.inv(tool)
            np.random.seed(p["seed"])  # ik_LM restarts draw from numpy's global generator
            sol, t = timed(
                lambda q0=q0, kw=kw, twin=twin, T_end=T_end, n=n: [
                    twin.ik_LM(
                        T_end[k],
                        q0=q0[k],
                        ilimit=p["rtb_ilimit"],
                        slimit=p["rtb_slimit"],
                        tol=0.5 * p["tol_pos_m"] ** 2,
                        joint_limits=True,
                        **kw,
                    )
                    for k in range(n)
                ]
            )
            good = []
            for k, s in enumerate(sol):
                pos, rot = pose_errors(robot, s.q, T[k])
                good.append(
                    pos <= p["tol_pos_m"]
                    and rot <= p["tol_rot_rad"]
                    and bool(robot.within_limits(s.q, tol=1e-9))
                )
            own = np.mean([bool(s.success) for s in sol])
            iters = np.median([s.iterations for s in sol])
            rows.append(
                (
                    name,
                    f"rtb ik_LM (C++), {start} seed",
                    n,
                    rate(n, t),
                    f"{100 * np.mean(good):.2f} (own flag {100 * own:.1f})",
                    f"{iters:g}",
                )
            )


def main() -> None:
    rows: list = []
    bench_forward(rows)
    bench_analytic(rows)
    bench_numerical(rows)
    header = ("robot", "what", "calls", "rate [1/s]", "success [%]", "median iters")
    widths = [max(len(str(r[i])) if i != 3 else 12 for r in rows + [header]) for i in range(6)]
    line = "  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True))
    print(f"# armlab.kinematics benchmark, {PARAMS}")
    print(line)
    print("-" * len(line))
    for r in rows:
        cells = [str(r[0]), str(r[1]), str(r[2]), f"{r[3]:,.0f}", str(r[4]), str(r[5])]
        print("  ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)))
    readme_rows(rows)


def readme_rows(rows: list) -> None:
    """The README's three kinematics rows from the table's rows."""
    by = {(r[0], r[1]): r for r in rows}

    def pct(cell: str) -> str:
        return f"{float(cell.split()[0]):.4g} %"

    batch = by[("teachbot6", "ik_all_batch (poses/s)")]
    readme_row(
        __file__,
        f"batched analytic IK, teachbot6 (goal >= {sig(PARAMS['goal_ik_batch_per_s'])} poses/s)",
        f"{sig(batch[3])} poses/s, {pct(batch[4])} found",
    )
    rate = {k: sig(by[("teachbot6", k)][3]) for k in (
        "fk (Pinocchio), single",
        "fk_batch (Pinocchio loop)",
        "dh.fk (closed form, numpy)",
        "jacobian (world), single",
    )}  # fmt: skip
    readme_row(
        __file__,
        "FK single / batched (`fk_batch`) / closed form (`dh.fk`); Jacobian",
        " / ".join(f"{v}/s" for v in list(rate.values())[:3]) + f"; {list(rate.values())[3]}/s",
    )

    def both(name: str, lib: str) -> str:
        cells = [by[(name, f"{lib}, {start} seed")] for start in ("cold", "warm")]
        return f"{NAMES[name]} " + " / ".join(f"{sig(r[3])}/s {pct(r[4])}" for r in cells)

    robots = PARAMS["robots_numerical"]
    ours = [both(name, "armlab ik_solve (OSQP)") for name in robots]
    peer = [both(n, "rtb ik_LM (C++)") for n in robots if (n, "rtb ik_LM (C++), cold seed") in by]
    readme_row(
        __file__,
        "numerical IK (OSQP QP per step), cold / warm seed, success within "
        f"{PARAMS['tol_pos_m']:g} m and {PARAMS['tol_rot_rad']:g} rad",
        "; ".join(ours),
        ("RTB `ik_LM` (C++) " + "; ".join(peer)) if peer else "Robotics Toolbox not installed",
    )


if __name__ == "__main__":
    main()
