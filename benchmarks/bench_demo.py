"""The demo study the way ``make demo`` runs it: ``armlab run --out DIR`` in a fresh process.

Each run is a new process of the ``armlab`` console script beside this interpreter (what
``make demo`` calls, ``MPLBACKEND=Agg``) writing into a new temporary folder, so imports, the
robot's loading and the optimiser's CasADi build are all inside the time (a study runs in one
process: its stages, then its report's plots). Reported, the median over ``--repeats`` runs
of: the wall time of the process, each stage's own time (from the output's ``summary.json``,
``summary["study"]["stages"][stage]["time_s"]``) and the remainder (wall minus the stages:
interpreter start-up, imports, the report and its plots, writing the files), split into the
start-up alone (``armlab --help`` in a fresh process: interpreter and the CLI's imports) and
the rest (the report, its plots, the files). Goal (issue 15): the demo study <= 5 s after
set-up (``make setup``, the installed venv).

Run:  ``MPLBACKEND=Agg .venv/bin/python benchmarks/bench_demo.py [--repeats 3] [--quick]``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _readme import readme_row

# ---------------------------------------------------------------------------- parameters
PARAMS = {
    "repeats": 3,  # runs (median)
    "quick_repeats": 1,
    "variants": {"armlab run": []},
    "goal_s": 5.0,
}


def armlab_command() -> list[str]:
    """The ``armlab`` console script of this interpreter's environment (``make demo`` calls
    ``.venv/bin/armlab``), else the same entry point through ``-m``."""
    script = Path(sys.executable).parent / "armlab"
    return [str(script)] if script.exists() else [sys.executable, "-m", "armlab.cli"]


def run_once(extra: list[str]) -> tuple[float, dict[str, float]]:
    """(wall time [s], each stage's time [s]) of one ``armlab run`` into a new folder."""
    with tempfile.TemporaryDirectory(prefix="bench_demo_") as tmp:
        out = Path(tmp) / "demo"
        cmd = [*armlab_command(), "run", "--out", str(out), *extra]
        env = {**os.environ, "MPLBACKEND": "Agg"}
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
        wall = time.perf_counter() - t0
        if proc.returncode not in (0, 1):  # 1: the design fails, the study still ran
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:]
            raise SystemExit(f"{' '.join(cmd)} exited {proc.returncode}: {' '.join(tail)}")
        summary = json.loads((out / "summary.json").read_text())
    stages = summary["study"]["stages"]
    return wall, {name: float(s["time_s"]) for name, s in stages.items() if "time_s" in s}


def startup_s() -> float:
    """Wall time [s] of ``armlab --help`` in a fresh process: the start-up every run pays."""
    t0 = time.perf_counter()
    subprocess.run([*armlab_command(), "--help"], capture_output=True, check=True)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=PARAMS["repeats"], help="runs (median)")
    ap.add_argument("--quick", action="store_true", help=f"{PARAMS['quick_repeats']} run each")
    args = ap.parse_args()
    repeats = PARAMS["quick_repeats"] if args.quick else args.repeats
    if repeats < 1:
        raise SystemExit("--repeats: at least 1")
    startup = statistics.median(startup_s() for _ in range(max(repeats, 3)))
    results = {}
    for variant, extra in PARAMS["variants"].items():
        runs = [run_once(extra) for _ in range(repeats)]
        names = list(runs[0][1])
        walls = [w for w, _ in runs]
        rest = [w - sum(s.values()) for w, s in runs]
        results[variant] = {
            "wall": statistics.median(walls),
            "min": min(walls),
            "max": max(walls),
            "stages": {n: statistics.median(s.get(n, 0.0) for _, s in runs) for n in names},
            "rest": statistics.median(rest),
        }

    names = list(next(iter(results.values()))["stages"])
    print(
        f"demo study: {' '.join(armlab_command())} run --out <new folder>, MPLBACKEND=Agg, "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}; "
        f"median of {repeats} fresh processes; {os.cpu_count()} CPUs, "
        f"load average {os.getloadavg()[0]:.2f}\n"
    )
    print(
        "| variant | wall [s] (min..max) | "
        + " | ".join(names)
        + " | start-up [s] | report and the rest [s] |"
    )
    print("|---" * (len(names) + 4) + "|")
    for variant, r in results.items():
        cells = " | ".join(f"{r['stages'][n]:.2f}" for n in names)
        print(
            f"| {variant} | {r['wall']:.2f} ({r['min']:.2f}..{r['max']:.2f}) | {cells} | "
            f"{startup:.2f} | {r['rest'] - startup:.2f} |"
        )
    goal = PARAMS["goal_s"]
    default = results["armlab run"]
    print(
        f"\ngoal: demo study <= {goal:g} s after set-up -> {default['wall']:.2f} s "
        f"({'met' if default['wall'] <= goal else 'NOT met'})"
    )
    slowest = sorted(names, key=lambda n: -default["stages"][n])[:3]
    readme_row(
        __file__,
        f"`make demo` (`armlab run`, fresh process, one process per study, median of "
        f"{repeats}) (goal demo study <= {goal:g} s after set-up)",
        f"{default['wall']:.1f} s; of which "
        + ", ".join(f"{n} {default['stages'][n]:.2f} s" for n in slowest)
        + f"; start-up {startup:.1f} s, report and the rest {default['rest'] - startup:.1f} s",
    )


if __name__ == "__main__":
    main()
