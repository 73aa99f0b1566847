"""Import time of armlab's packages, each in fresh interpreters, beside ``import pinocchio``.

Every module is imported in ``repeats`` new subprocesses (nothing cached in ``sys.modules``;
the OS file cache is warm after the first run); the table shows the median wall time of the
import statement, the spread, and which heavy dependencies the import pulled in. Pinocchio is
the peer: armlab cannot start faster than the rigid-body library it is built on, and
``armlab.robot`` / ``armlab.kinematics`` / ``armlab.dynamics`` should cost little more.

Usage::

    .venv/bin/python benchmarks/bench_import.py [--repeats N] [--quick]

Goal (issue 15): ``import armlab`` and ``import armlab.dynamics`` each <= 0.3 s.

Set ``PYTHONPATH`` to another checkout's ``research/`` to time that tree with the same
interpreter (the "before" of a change).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

from _readme import readme_row

# ---------------------------------------------------------------------------- parameters
PARAMS = {
    "modules": [
        "pinocchio",  # the peer baseline
        "armlab",
        "armlab.robot",
        "armlab.kinematics",
        "armlab.dynamics",
        "armlab.trajectory",
        "armlab.control",
    ],
    "repeats": 7,
    "quick_repeats": 3,
    "goal_s": {"armlab": 0.3, "armlab.dynamics": 0.3},  # issue 15
    # dependencies whose presence after the import is reported
    "heavy": ["casadi", "matplotlib", "scipy", "osqp", "control", "pandas", "dask"],
}

_PROBE = """
import json, sys, time
t0 = time.perf_counter()
import {module}
dt = time.perf_counter() - t0
print(json.dumps({{"s": dt, "loaded": [m for m in {heavy!r} if m in sys.modules]}}))
"""


def time_import(module: str, heavy: list[str]) -> tuple[float, list[str]]:
    """Seconds to import ``module`` in a fresh interpreter, and the heavy modules it loaded."""
    env = {**os.environ, "MPLBACKEND": "Agg"}
    out = subprocess.run(
        [sys.executable, "-c", _PROBE.format(module=module, heavy=heavy)],
        capture_output=True,
        text=True,
        check=True,
        env=env,
    ).stdout
    d = json.loads(out.strip().splitlines()[-1])
    return d["s"], d["loaded"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=PARAMS["repeats"])
    ap.add_argument("--quick", action="store_true", help=f"{PARAMS['quick_repeats']} repeats")
    args = ap.parse_args()
    if args.quick:
        args.repeats = PARAMS["quick_repeats"]
    time_import("armlab", PARAMS["heavy"])  # warm the file cache and the .pyc files
    rows = []
    for module in PARAMS["modules"]:
        runs = [time_import(module, PARAMS["heavy"]) for _ in range(args.repeats)]
        times = sorted(t for t, _ in runs)
        rows.append((module, statistics.median(times), times[0], times[-1], runs[-1][1]))
    base = rows[0][1]
    print(f"import time, median of {args.repeats} fresh interpreters ({sys.executable})")
    print(f"{'module':<20} {'median [s]':>10} {'min [s]':>8} {'max [s]':>8} {'x pin':>6}  loaded")
    for module, med, lo, hi, loaded in rows:
        print(
            f"{module:<20} {med:>10.3f} {lo:>8.3f} {hi:>8.3f} {med / base:>6.2f}  "
            f"{', '.join(loaded) or '-'}"
        )
    median = {module: med for module, med, *_ in rows}
    goals = PARAMS["goal_s"]
    readme_row(
        __file__,
        f"import time in a fresh interpreter, median of {args.repeats} (goal "
        + " and ".join(f"`import {m}` <= {g:g} s" for m, g in goals.items())
        + ")",
        ", ".join(f"`{m}` {median[m]:.2f} s" for m in PARAMS["modules"][1:]),
        f"`import {PARAMS['modules'][0]}` {median[PARAMS['modules'][0]]:.2f} s",
    )


if __name__ == "__main__":
    main()
