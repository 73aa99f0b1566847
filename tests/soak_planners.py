"""Soak the planner property checks of ``test_planner_properties`` on many random cases.

``make soak`` runs this script; by hand::

    MPLBACKEND=Agg .venv/bin/python tests/soak_planners.py --cases 100000 --minutes 60

Each planner runs seeds 0, 1, 2, ... (the same cases as the property tests' ``run(planner,
seed)``) until ``--cases`` cases or ``--minutes`` of wall time, whichever comes first (the
optimisers get ``--optimiser-cases``), spread over ``--workers`` processes. A case that takes
longer than ``--timeout`` seconds is stopped and counted. Prints one Markdown table row per
planner -- cases, properties broken, named refusals, largest relative excess over a limit
(``peak ratio - 1``; negative: every case stayed below its limits), slowest case -- and writes
everything (with the first failures and refusal kinds) to ``--out`` as JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE / "planning")]
os.environ.setdefault("MPLBACKEND", "Agg")

OPTIMISERS = ("optimal", "topp")


class _Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise _Timeout()


def _empty() -> dict:
    """The counts of no case yet."""
    return {
        "cases": 0,
        "ok": 0,
        "failed": 0,
        "refused": 0,
        "timeouts": 0,
        "peak_ratio": 0.0,
        "slowest_s": 0.0,
        "slowest_seed": None,
        "refusals": Counter(),
        "failures": [],
        "seconds": 0.0,
    }


def _chunk(args: tuple[str, int, int, float, float]) -> dict:
    """Run seeds ``[start, stop)`` of ``planner`` until ``deadline`` (epoch seconds)."""
    import test_planner_properties as props

    planner, start, stop, deadline, timeout = args
    signal.signal(signal.SIGALRM, _alarm)
    out = _empty()
    for seed in range(start, stop):
        if time.time() > deadline:
            break
        t0 = time.perf_counter()
        signal.alarm(max(1, int(timeout)))
        try:
            res = props.run(planner, seed)
        except _Timeout:
            out["timeouts"] += 1
            out["cases"] += 1
            out["failures"].append({"seed": seed, "failures": [f"over {timeout:g} s"]})
            continue
        except Exception as exc:  # anything not named is a broken property
            signal.alarm(0)
            res = props.Outcome("failed", failures=[f"{type(exc).__name__}: {exc}"])
        finally:
            signal.alarm(0)
        dt = time.perf_counter() - t0
        out["cases"] += 1
        out["seconds"] += dt
        out[res.status] += 1
        out["peak_ratio"] = max(out["peak_ratio"], res.peak_ratio)
        if dt > out["slowest_s"]:
            out["slowest_s"], out["slowest_seed"] = dt, seed
        if res.status == "refused":
            out["refusals"][res.message.split(":")[0]] += 1
        elif res.status == "failed" and len(out["failures"]) < 20:
            out["failures"].append({"seed": seed, "failures": res.failures[:3]})
    return out


def _merge(total: dict, part: dict) -> None:
    for key in ("cases", "ok", "failed", "refused", "timeouts", "seconds"):
        total[key] += part[key]
    total["peak_ratio"] = max(total["peak_ratio"], part["peak_ratio"])
    if part["slowest_s"] > total["slowest_s"]:
        total["slowest_s"], total["slowest_seed"] = part["slowest_s"], part["slowest_seed"]
    total["refusals"].update(part["refusals"])
    total["failures"] = (total["failures"] + part["failures"])[:20]


def soak(planner: str, cases: int, minutes: float, workers: int, timeout: float) -> dict:
    """Every case of ``planner`` within the budget, in chunks of seeds over the workers."""
    deadline = time.time() + 60 * minutes
    chunk = 25 if planner in OPTIMISERS else 500
    tasks = [(planner, s, min(s + chunk, cases), deadline, timeout) for s in range(0, cases, chunk)]
    total = _empty()
    t0 = time.time()
    with ProcessPoolExecutor(max_workers=workers) as pool:
        for part in pool.map(_chunk, tasks):
            _merge(total, part)
    total["wall_s"] = time.time() - t0
    total["refusals"] = dict(total["refusals"].most_common())
    return total


def row(planner: str, r: dict) -> str:
    """One Markdown table row."""
    excess = r["peak_ratio"] - 1.0
    slow = f"{r['slowest_s']:.2f} s (seed {r['slowest_seed']})"
    return (
        f"| {planner} | {r['cases']} | {r['failed'] + r['timeouts']} | {r['refused']} | "
        f"{excess:+.1e} | {slow} |"
    )


def main(argv: list[str] | None = None) -> int:
    from test_planner_properties import PLANNERS

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=100_000, help="cases per planner")
    ap.add_argument("--optimiser-cases", type=int, default=2_000, help="cases per optimiser")
    ap.add_argument("--minutes", type=float, default=60.0, help="wall-time budget per planner")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds per case")
    ap.add_argument("--planners", default=",".join(PLANNERS))
    ap.add_argument("--out", default=str(HERE.parent / "out" / "soak.json"))
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    results: dict = {"settings": vars(a), "planners": {}}
    print("| planner | cases | broken | named refusals | largest excess | slowest case |")
    print("|---|---:|---:|---:|---:|---|")
    bad = 0
    for planner in a.planners.split(","):
        n = a.optimiser_cases if planner in OPTIMISERS else a.cases
        r = soak(planner, n, a.minutes, a.workers, a.timeout)
        results["planners"][planner] = r
        out.write_text(json.dumps(results, indent=1, default=str))
        print(row(planner, r), flush=True)
        bad += r["failed"] + r["timeouts"]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
