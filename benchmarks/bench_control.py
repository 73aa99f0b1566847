"""Benchmark of armlab.control: tuning time per joint, 6-joint closed-loop simulation speed.

Run headless: ``MPLBACKEND=Agg .venv/bin/python benchmarks/bench_control.py``.
Prints four tables: ``tune_arm`` time with the largest relative difference of any margin or
crossover it reports from the same figures on the loops built with python-control
(``tests/oracles/cascade_pc.py``, the oracle of the tests); robust tuning per teachbot6 joint
(time, crossovers, worst margins); simulation speed (simulated seconds per wall second,
6 joints at the 1 kHz servo rate; "loop" is the servo loop alone, "call" the whole call with
set-point evaluation, feed-forward and the TCP forward kinematics of every sample); and our
margin evaluation beside python-control's ``stability_margins`` (the peer) on the same loops.
"""

from __future__ import annotations

import os

# -------------------------------------------------------------------------- parameters (data)
PARAMS = {
    "robot": "teachbot6",
    "blas_threads": "1",  # small matrices: one BLAS thread (contention costs 10-50 x)
    "n_inertia_samples": 400,
    "spec": {},  # TuningSpec keywords; {} = defaults (PM 50, GM 6, 1 kHz)
    "q_start": [0.0, -0.3, 0.4, 0.0, 0.5, 0.0],
    "q_goal": [0.8, 0.2, -0.2, 0.9, -0.4, 1.2],
    "feedforwards": ["none", "velocity", "velocity+acceleration+gravity", "computed_torque"],
    "repeats": 3,  # simulation runs per row (best wall time kept)
    "margin_grid": 1500,
    "tune_repeats": 3,  # tune_arm runs (best wall time kept)
    "goal_tune_s": 0.5,  # issue 15: tune_arm(teachbot6)
    "goal_realtime": 10.0,  # simulated seconds per wall second
}
os.environ.setdefault("OPENBLAS_NUM_THREADS", PARAMS["blas_threads"])
os.environ.setdefault("OMP_NUM_THREADS", PARAMS["blas_threads"])
os.environ.setdefault("MPLBACKEND", "Agg")

import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import control as ct  # noqa: E402
import numpy as np  # noqa: E402
from _readme import readme_row  # noqa: E402

import armlab  # noqa: E402
from armlab.control import (  # noqa: E402
    ArmGains,
    CascadeModel,
    inertia_range,
    joint_plant,
    simulate_tracking,
    tune_arm,
    tune_cascade,
)
from armlab.control.margins import freq_grid, margins  # noqa: E402
from armlab.trajectory import ptp_sync  # noqa: E402

_COMPARED = (
    ("phase_margin_deg", False),
    ("gain_margin_dB", False),
    ("crossover_rad_s", False),
    ("phase_margin_discrete_deg", True),
    ("gain_margin_discrete_dB", True),
    ("crossover_discrete_rad_s", True),
)


def tune_table(robot) -> tuple[float, float]:
    """``tune_arm`` wall and CPU time (inertia range included), best of repeats, and the largest
    relative difference of its robustness rows' margins and crossovers from python-control's
    loops (the tests' oracle) on the same gains; returns (best wall time [s], difference)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from oracles.cascade_pc import Cascade, response

    print(f"\n## tune_arm({robot.name}) and its figures against python-control's loops\n")
    print("| wall [s] | CPU [s] | max rel. diff. of margins and crossovers vs python-control |")
    print("|---|---|---|")
    best, cpu, gains = float("inf"), float("inf"), None
    for _ in range(PARAMS["tune_repeats"]):
        t0, c0 = time.perf_counter(), time.process_time()
        gains = tune_arm(
            robot, n_inertia_samples=PARAMS["n_inertia_samples"], controller="reference_dda"
        )
        best = min(best, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
    assert gains is not None
    inertias = inertia_range(robot, n_samples=PARAMS["n_inertia_samples"])
    worst = 0.0
    for name in robot.joint_names:
        plant = joint_plant(robot, name, inertias=inertias)
        for loop, lg in gains[name].loops().items():
            for row in lg.robustness:
                oracle = Cascade(plant.at(row["label"]), gains[name])
                for key, disc in _COMPARED:
                    w = freq_grid(lg.sample_time_s if disc else None, n=1500)
                    ref = margins(w, response(oracle.open_loop(loop, disc), w))
                    a, b = row[key], getattr(ref, key.replace("_discrete", ""))
                    if np.isfinite(a) and np.isfinite(b) and b != 0:
                        worst = max(worst, abs(a - b) / abs(b))
    print(f"| {best:.3f} | {cpu:.3f} | {worst:.1e} |")
    return best, worst


def main() -> None:
    warnings.simplefilter("ignore")
    robot = armlab.load_robot(PARAMS["robot"])
    print(
        f"armlab {armlab.__version__}, python-control {ct.__version__}, "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}"
    )
    t0 = time.perf_counter()
    inertias = inertia_range(robot, n_samples=PARAMS["n_inertia_samples"])
    t_inertia = time.perf_counter() - t0

    # ------------------------------------------------------------------ tune_arm
    t_tune, diff = tune_table(robot)

    # ------------------------------------------------------------------ tuning
    print(
        f"\n## Robust cascade tuning ({robot.name}; inertia range {t_inertia * 1e3:.0f} ms, "
        f"{PARAMS['n_inertia_samples']} samples)\n"
    )
    print(
        "| joint | tune [s] | J max/min | wc current | wc speed (min..max J) | wc position "
        "| worst PM cont/disc [deg] | worst GM cont/disc [dB] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    joints = {}
    for name in robot.joint_names:
        t0 = time.perf_counter()
        g = tune_cascade(robot, name, inertias=inertias, **PARAMS["spec"])
        dt = time.perf_counter() - t0
        joints[name] = g
        Jc = g.plant.inertia_motor_kg_m2
        ws = [r["crossover_rad_s"] for r in g.speed.robustness]
        pm_c = min(lg.phase_margin_deg for lg in g.loops().values())
        pm_d = min(lg.phase_margin_discrete_deg for lg in g.loops().values())
        gm_c = min(lg.gain_margin_dB for lg in g.loops().values())
        gm_d = min(lg.gain_margin_discrete_dB for lg in g.loops().values())
        print(
            f"| {name} | {dt:.2f} | {Jc['max'] / Jc['min']:.2f} | "
            f"{g.current.crossover_rad_s:.0f} | {min(ws):.0f}..{max(ws):.0f} | "
            f"{g.position.crossover_rad_s:.1f} | {pm_c:.1f} / {pm_d:.1f} | "
            f"{gm_c:.1f} / {gm_d:.1f} |"
        )
    gains = ArmGains(joints=joints, robot=robot.name)

    # ------------------------------------------------------------------ simulation
    traj = ptp_sync(
        robot, np.array(PARAMS["q_start"]), np.array(PARAMS["q_goal"]), "trapezoid", dt=1e-3
    )
    print(
        f"\n## Closed-loop simulation, 6 joints, 1 kHz, Pinocchio ABA "
        f"(trajectory {traj.duration:.2f} s + 0.2 s settling)\n"
    )
    print(
        "| feed-forward | quantise | sim s / wall s (loop) | sim s / wall s (call) | "
        "TCP max error [mm] | worst joint max error [rad] |"
    )
    print("|---|---|---|---|---|---|")
    factors_loop, factors_call = [], []
    for ff in PARAMS["feedforwards"]:
        ffs = "none" if ff == "none" else tuple(ff.split("+"))
        for quant in (True, False):
            best, call = None, float("inf")
            for _ in range(PARAMS["repeats"]):
                t0 = time.perf_counter()
                res = simulate_tracking(
                    robot, traj, gains, feedforward=ffs, quantise=quant, controller="reference_dda"
                )
                call = min(call, time.perf_counter() - t0)
                best = res if best is None or res.wall_time_s < best.wall_time_s else best
            sim_s = best.t[-1] - best.t[0]
            factors_loop.append(best.realtime_factor)
            factors_call.append(sim_s / call)
            print(
                f"| {ff} | {quant} | {best.realtime_factor:.1f} | {sim_s / call:.1f} | "
                f"{best.tcp_max_error_m * 1e3:.4f} | {best.max_error_rad.max():.2e} |"
            )

    # ------------------------------------------------------------------ margins vs peer
    print(
        "\n## Margin evaluation: ours (batched solve on a log grid) vs python-control "
        "stability_margins (peer), joint 2, nominal inertia\n"
    )
    print("| loop | ours PM [deg] | peer PM [deg] | ours [ms] | peer [ms] |")
    print("|---|---|---|---|---|")
    t_margins, pm_diff = {"ours": [], "peer": []}, 0.0
    plant = joint_plant(robot, "joint2", inertias=inertias)
    m = CascadeModel(plant, gains["joint2"], cases=("nominal",))
    for loop in ("current", "speed", "position"):
        for disc in (False, True):
            L = m.open_loop(loop, disc, "nominal")
            t0 = time.perf_counter()
            ours = m.margins(loop, disc, n=PARAMS["margin_grid"])[0]
            t_ours = time.perf_counter() - t0
            t0 = time.perf_counter()
            frd = ct.frd(L, freq_grid(L.dt or None, n=PARAMS["margin_grid"]))
            _, pm, *_ = ct.stability_margins(frd)
            t_peer = time.perf_counter() - t0
            t_margins["ours"].append(t_ours)
            t_margins["peer"].append(t_peer)
            if np.isfinite(ours.phase_margin_deg) and np.isfinite(pm):
                pm_diff = max(pm_diff, abs(ours.phase_margin_deg - pm))
            print(
                f"| {loop} {'disc' if disc else 'cont'} | {ours.phase_margin_deg:.2f} | "
                f"{pm:.2f} | {t_ours * 1e3:.1f} | {t_peer * 1e3:.1f} |"
            )

    # ------------------------------------------------------------------ README rows
    readme_row(
        __file__,
        f"`tune_arm({robot.name})`: robust tuning of all {robot.n_joints} joints "
        f"(goal <= {PARAMS['goal_tune_s']:g} s)",
        f"{t_tune:.3f} s (closed-form frequency responses over the frequency x inertia grid), "
        f"margins and crossovers within {diff:.1e} (relative) of python-control's loops",
    )
    readme_row(
        __file__,
        f"closed-loop {robot.n_joints}-joint simulation at 1 kHz "
        f"(goal >= {PARAMS['goal_realtime']:g}x real time)",
        f"{min(factors_loop):.0f}-{max(factors_loop):.0f}x real time (servo loop), "
        f"{min(factors_call):.0f}-{max(factors_call):.0f}x the whole call, "
        f"over {len(PARAMS['feedforwards'])} feed-forwards x quantised or not",
    )
    ms = {k: (1e3 * min(v), 1e3 * max(v)) for k, v in t_margins.items()}
    readme_row(
        __file__,
        "loop margins",
        f"{ms['ours'][0]:.1f}-{ms['ours'][1]:.1f} ms per loop, phase margins within "
        f"{pm_diff:.2g} deg of the peer's",
        f"python-control `stability_margins` {ms['peer'][0]:.0f}-{ms['peer'][1]:.0f} ms",
    )


if __name__ == "__main__":
    main()
