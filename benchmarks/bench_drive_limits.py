"""Planning inside the motor's envelope (issue 14): ``optimal(..., drive_limits=True)`` against
torque boxes, on teachbot6.

Cases: ``CASES`` seeded random rest-to-rest moves of teachbot6 (start and goal uniform in the
middle ``RANGE_SHARE`` of every joint range, payload uniform in [0, 1] kg) and the demo cycle
(``research/armlab/data/demo_study.toml``: 4 waypoints, 0.5 kg). Every plan is the optimiser in
its torque-limited form (velocity and torque limits, ``a_max=False, j_max=False``: the
acceleration and jerk limits of drives.toml would otherwise bind first and hide the torque), with
``n_intervals`` per segment. Three plans per case:

- **box**: today's torque box (``robot.limits.torque_Nm``, the thesis' available torque
  stall x ratio x efficiency x derating) and today's velocity limits;
- **safe box**: a constant box that is safe at its top speed. With the drives' constants the
  voltage line reaches zero at the motor's table speed, which is where the velocity limit of
  joints 2-3 sits, so the box "safe at the speed limit" is zero there; the baseline takes the
  top speed ``v_b = min(v_limit, w_no_load / (2 N))`` (half the no-load speed: the constant
  torque-speed pair with the largest power on a voltage line) and the box
  ``N eta derating min(T_peak, Kt (U - Ke N v_b) / R)``. A box on the rigid-body torque does
  not see the reflected rotor inertia ``J N^2`` (15.7 kg m^2 at joint 2, more than the arm), so
  the baseline plans on a model whose armature is ``eta J N^2`` (its RNEA torque is then
  ``N eta T_m`` in the motoring quadrant);
- **drive**: ``drive_limits=True`` (the envelope of :mod:`armlab.robot.drivetrain`).

Every plan is checked by the independent per-sample computation
(:func:`armlab.planning.timescale.drive_check`: the numeric drive-train model on the trajectory's
limit samples and a ``T / 4000`` grid). Reported: (a) the share of box plans outside the motor
envelope, (b) the duration of the drive plan over the safe box's (median, and where a torque
limit binds in the safe-box plan), violations of the drive plans (goal 0), wall time per plan.

With ``--solvers`` (issue 26) it also plans the box and the drive plans of every case with
IPOPT (``ARMLAB_SOLVER=ipopt``) and with fatrop (the default: compiled stage libraries of
acceleration mode with and without the drive rows; the drive plans without the RMS row
first, ``stats["drive_rms"]``), alternating, and prints per case the
whole-call and solve times, the largest duration difference and the drive / box ratio of each
solver (medians; the first case's calls are dropped: they build IPOPT's problem or load the
library).

Run:  ``MPLBACKEND=Agg .venv/bin/python benchmarks/bench_drive_limits.py [--quick] [--solvers]``
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402
import tomllib  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from _readme import readme_row  # noqa: E402

import armlab  # noqa: E402
from armlab.errors import ArmlabError  # noqa: E402
from armlab.planning import optimal  # noqa: E402
from armlab.planning.timescale import drive_check  # noqa: E402
from armlab.robot import drivetrain  # noqa: E402

SEED = 20261124
CASES = 50
QUICK = 6
RANGE_SHARE = 0.6  # moves are drawn in the middle 60 % of each joint range
N_INTERVALS = 24  # per segment
TOL = 1e-6  # a ratio above 1 + TOL breaks the envelope
DEMO = Path(armlab.__file__).parent / "data" / "demo_study.toml"


def demo_cycle() -> np.ndarray:
    doc = tomllib.loads(DEMO.read_text())
    w = np.asarray(doc["waypoints"]["joint"], float)
    return np.deg2rad(w) if doc["waypoints"].get("unit") == "deg" else w


def draw_cases(robot, n: int, rng) -> list[tuple[str, np.ndarray, float]]:
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * RANGE_SHARE
    cases = []
    for k in range(n):
        w = mid + half * rng.uniform(-1, 1, size=(2, robot.n_joints))
        cases.append((f"move {k}", w, float(rng.uniform(0.0, 1.0))))
    cases.append(("demo cycle", demo_cycle(), 0.5))
    return cases


def safe_box(robot):
    """(robot with armature eta J N^2, v_b, box) of the safe-box baseline (module docstring)."""
    tr = drivetrain.drive_train(robot)
    v_lim = robot.limits.velocity_rad_s
    v_b = np.minimum(v_lim, tr.no_load_speed_rad_s / (2 * tr.ratio))
    t_safe = drivetrain.envelope_torque(tr.ratio * v_b, tr)
    box = tr.ratio * tr.efficiency * t_safe - tr.coulomb_friction_Nm
    model_robot = robot.copy()
    model_robot.model.armature = tr.efficiency * tr.inertia_motor_side_kg_m2 * tr.ratio**2
    return model_robot, v_b, box


def plan(robot, w, **kw):
    t0 = time.perf_counter()
    try:
        tr = optimal(robot, w, a_max=False, j_max=False, n_intervals=N_INTERVALS, **kw)
    except ArmlabError as exc:
        return None, time.perf_counter() - t0, str(exc).split("\n")[0][:60]
    return tr, time.perf_counter() - t0, ""


def solver_table(cases) -> None:
    """fatrop against IPOPT on the box and drive plans of ``cases`` (module docstring)."""
    print(f"\nsolvers: {'case':>11} | {'plan':>5} | ipopt call/solve [ms] | fatrop call/solve "
          "[ms] | ipopt/fatrop | dT/T")  # fmt: skip
    rows: dict = {(s, dl): [] for s in ("ipopt", "fatrop") for dl in (False, True)}
    devs = []
    for i, (name, w, _kg, robot) in enumerate(cases):
        for dl in (False, True):
            got = {}
            for s in ("ipopt", "fatrop") if i % 2 else ("fatrop", "ipopt"):
                os.environ["ARMLAB_SOLVER"] = s
                tr, wall, err = plan(robot, w, drive_limits=dl)
                got[s] = (tr, wall)
                if i and tr is not None:
                    rms = tr.stats.get("drive_rms", "")
                    rows[(s, dl)].append((wall, tr.stats["solve_time_s"], tr.stats["solver"], rms))
            (a, wa), (b, wb) = got["ipopt"], got["fatrop"]
            if a is None or b is None:
                continue
            dev = b.duration / a.duration - 1
            devs.append(abs(dev))
            print(f"{'':>8} {name:>11} | {'drive' if dl else 'box':>5} | {1e3 * wa:>10.0f} "
                  f"/{1e3 * a.stats['solve_time_s']:>7.0f}  | {1e3 * wb:>9.0f} "
                  f"/{1e3 * b.stats['solve_time_s']:>7.0f}  | {wa / wb:>12.1f} | {dev:+.1e} "
                  f"{b.stats['solver']}", flush=True)  # fmt: skip
    os.environ.pop("ARMLAB_SOLVER", None)
    med = {k: np.median([r[0] for r in v]) if v else np.nan for k, v in rows.items()}
    fb = sum(r[2] != "fatrop" for k, v in rows.items() if k[0] == "fatrop" for r in v)
    # fatrop's drive plans re-solved with the RMS row (it bound at the optimum without it)
    again = sum(r[3].startswith("re-solved") for r in rows[("fatrop", True)])
    print(f"whole call, median over the repeat cases: drive / box ipopt "
          f"{med[('ipopt', True)] / med[('ipopt', False)]:.1f}x, fatrop "
          f"{med[('fatrop', True)] / med[('fatrop', False)]:.1f}x; drive ipopt / fatrop "
          f"{med[('ipopt', True)] / med[('fatrop', True)]:.1f}x; max |dT/T| "
          f"{max(devs, default=np.nan):.1e}; fatrop plans solved by IPOPT: {fb}; fatrop "
          f"drive plans re-solved with the RMS row: {again} of "
          f"{len(rows[('fatrop', True)])}")  # fmt: skip


def worst(ratios: dict) -> float:
    return max(float(np.max(r)) for r in ratios.values())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"{QUICK} moves instead of {CASES}")
    ap.add_argument("--solvers", action="store_true", help="fatrop vs IPOPT table only")
    args = ap.parse_args()
    base = armlab.load_robot("teachbot6")
    rng = np.random.default_rng(SEED)
    cases = draw_cases(base, QUICK if args.quick else CASES, rng)
    if args.solvers:
        solver_table([(nm, w, kg, base.with_payload(kg)) for nm, w, kg in cases])
        return
    rows = []
    print(
        f"teachbot6, optimal() torque-limited (a_max=False, j_max=False), {N_INTERVALS} intervals"
    )
    head = f"{'case':>11} {'kg':>4} | {'box T':>6} {'env':>6} | {'safe T':>6} {'env':>5} "
    print(head + f"{'tau':>5} | {'drive T':>7} {'env':>5} {'rms':>5} | {'gain':>6} | wall [s]")
    for name, w, kg in cases:
        robot = base.with_payload(kg)
        tr = drivetrain.drive_train(robot)
        model_robot, v_b, box = safe_box(robot)
        a, ta, ea = plan(robot, w)
        b, tb, eb = plan(model_robot, w, v_max=v_b, tau_max=box)
        c, tc, ec = plan(robot, w, drive_limits=True)
        env_a = worst(drive_check(a, robot, tr, a.duration / 4000)) if a is not None else np.nan
        db = drive_check(b, robot, tr, b.duration / 4000) if b is not None else None
        env_b = worst(db) if db is not None else np.nan
        tau_bind = b is not None and max(float(np.max(r)) for k, r in b.report.ratios.items()
                                         if k == "torque") > 1 - 2e-3  # fmt: skip
        dc = drive_check(c, robot, tr, c.duration / 4000) if c is not None else None
        env_c = float(np.max(dc["motor_envelope"])) if dc is not None else np.nan
        rms_c = float(np.max(dc["motor_rms"])) if dc is not None else np.nan
        gain = b.duration / c.duration - 1 if (b is not None and c is not None) else np.nan
        rows.append((name, kg, a, env_a, b, env_b, tau_bind, c, dc, gain, ta, tb, tc, ec or eb))
        print(
            f"{name:>11} {kg:4.2f} | {a.duration if a else np.nan:6.3f} {env_a:6.2f} | "
            f"{b.duration if b else np.nan:6.3f} {env_b:5.2f} {'bind' if tau_bind else '':>5} | "
            f"{c.duration if c else np.nan:7.3f} {env_c:5.3f} {rms_c:5.3f} | "
            f"{100 * gain:+5.1f}% | {ta:.1f}/{tb:.1f}/{tc:.1f} {ec or eb}",
            flush=True,
        )
    moves = [r for r in rows if r[0] != "demo cycle"]
    box_ok = [r for r in moves if r[2] is not None]
    broken = [r for r in box_ok if r[3] > 1 + TOL]
    done = [r for r in moves if r[4] is not None and r[7] is not None]
    gains = np.array([r[9] for r in done])
    bind = np.array([r[9] for r in done if r[6]])
    viol = [r for r in rows if r[8] is not None and worst(r[8]) > 1 + TOL]
    failed = [r for r in rows if r[7] is None and r[2] is not None]  # drive fails, box does not
    hold = [r for r in rows if r[7] is None and r[2] is None]  # nothing can hold the waypoints
    print()
    print(f"(a) box plans outside the motor envelope: {len(broken)}/{len(box_ok)} "
          f"({100 * len(broken) / max(len(box_ok), 1):.0f} %); worst ratio "
          f"{max((r[3] for r in box_ok), default=np.nan):.3g}")  # fmt: skip
    print(f"(b) drive_limits vs safe box, duration gain (safe T / drive T - 1): median "
          f"{100 * np.median(gains):+.1f} % over {gains.size} moves (slower on "
          f"{int(np.sum(gains < -1e-3))}, by < 0.1 % on {int(np.sum(np.abs(gains) <= 1e-3))}); "
          "where a torque limit binds "
          f"in the safe-box plan: median {100 * np.median(bind) if bind.size else np.nan:+.1f} % "
          f"over {bind.size}, slower (> 0.1 %) on {int(np.sum(bind < -1e-3))}")  # fmt: skip
    demo = rows[-1]
    if demo[4] is not None and demo[7] is not None:
        print(f"    demo cycle: safe box {demo[4].duration:.3f} s, drive {demo[7].duration:.3f} s "
              f"({100 * demo[9]:+.1f} %), box {demo[2].duration if demo[2] else np.nan:.3f} s "
              f"(envelope ratio {demo[3]:.3g})")  # fmt: skip
    print(f"    drive plans outside the envelope (goal 0): {len(viol)}; drive plans failed where "
          f"the box plan did not: {len(failed)}; moves no planner can hold at a waypoint "
          f"(gravity above the motor's rating at rest): {len(hold)}")  # fmt: skip
    walls = np.array([[r[10], r[11], r[12]] for r in rows])
    ms = 1e3 * np.median(walls, axis=0)
    print(f"    wall per plan, median [ms]: box {ms[0]:.0f}, safe box {ms[1]:.0f}, drive "
          f"{ms[2]:.0f}")  # fmt: skip
    demo_text = (
        f", demo cycle {demo[4].duration:.2f} -> {demo[7].duration:.2f} s"
        if demo[4] is not None and demo[7] is not None
        else ", demo cycle: no plan"
    )
    readme_row(
        __file__,
        f"{len(moves)} random teachbot6 moves (payload 0-1 kg) + the demo cycle, "
        "`optimal(..., drive_limits=True)` vs a torque box",
        "(a) plans under the joint torque box of before (available torque) that leave the motor "
        f"envelope: {len(broken)} of {len(box_ok)} (worst ratio "
        f"{max((r[3] for r in box_ok), default=np.nan):.3g}); (b) drive-limited plans "
        f"{100 * np.median(gains):.1f} % faster (median over {gains.size}) than the constant box "
        f"safe at top speed{demo_text}; {len(viol)} envelope violations; median "
        f"{ms[2]:.0f} ms per drive plan (box {ms[0]:.0f} ms)",
        "no peer plans in the motor's voltage envelope",
    )


if __name__ == "__main__":
    main()
