"""Sweep throughput: studies per second on 1 and 2 workers, and the per-task overhead of Dask.

Runs side by side, on the same parameter sets:

* ``armlab.sweep``'s execution path -- a Dask ``LocalCluster`` of single-threaded worker
  processes, tasks submitted one per parameter set and collected with ``as_completed``;
* a plain ``concurrent.futures.ProcessPoolExecutor`` (spawned processes) running the same task
  function -- the floor any local pool could reach.

Then the overhead per task of each backend, from tasks that do nothing. First, studies per
second of one worker (this process, sequential), with the mean time per study
(``--one-worker-only``: this figure alone). Every worker is warmed
up first (armlab imported, robot loaded, CasADi functions built), so the figures are steady-state
throughput. Goal: 2 workers >= 1.8x the rate of 1 worker on the default study (on 2 cores).

Usage::

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_sweep.py
"""

from __future__ import annotations

import logging
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context

import numpy as np
from _readme import readme_row

# ---------------------------------------------------------------------------- parameters
PARAMS = {
    # the default study (armlab run's built-in teachbot6 study) without the report files and
    # without the Monte-Carlo workspace/accuracy clouds: plan, static load, sizing, tuning,
    # tracking and the set-point table, in memory
    "study": "demo",
    "overrides": {
        "study.report": False,
        "kinematics.workspace_samples": 0,
        "kinematics.accuracy_samples": 0,
    },
    "vary": "payload.mass_kg",  # one study per value
    "values": list(np.round(np.linspace(0.0, 1.0, 6), 4)),
    "workers": (1, 2),
    "repeats": 2,  # best of: the machine is shared, interference only slows
    "n_noop": 400,  # tasks of the overhead measurement
    "goal_scaling": 1.8,  # 2 workers over 1 (on 2 cores)
}


def noop(i: int) -> int:
    return i


def _study_task(doc, study_dir, source, params, key):
    from armlab.sweep.task import run_parameter_set

    return run_parameter_set(doc, study_dir, source, params, key)


def _sets():
    from armlab.study import apply_overrides
    from armlab.study.spec import read_study_document
    from armlab.sweep.spec import parameter_key

    doc, base, source = read_study_document(None if PARAMS["study"] == "demo" else PARAMS["study"])
    doc = apply_overrides(doc, PARAMS["overrides"])
    sets = [{PARAMS["vary"]: float(v)} for v in PARAMS["values"]]
    return doc, str(base), source, [(parameter_key(s), s) for s in sets]


def _check(rows):
    bad = [r for r in rows if r["status"] != "done"]
    if bad:
        raise SystemExit(f"a study failed: {bad[0]['error']}")


def dask_run(n_workers: int, doc, base, source, sets) -> tuple[float, float]:
    """(studies per second, seconds per no-op task) on a LocalCluster of n_workers."""
    from distributed import Client, LocalCluster
    from distributed import as_completed as dask_completed

    with (
        LocalCluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster) as client,
    ):
        # warm-up: every worker runs one study (imports, robot cache, CasADi build)
        warm = [
            client.submit(
                _study_task, doc, base, source, sets[0][1], sets[0][0], pure=False, workers=[w]
            )
            for w in client.scheduler_info()["workers"]
        ]
        _check(client.gather(warm))
        rate = 0.0
        for _ in range(PARAMS["repeats"]):
            t0 = time.perf_counter()
            futs = [
                client.submit(_study_task, doc, base, source, s, k, pure=False) for k, s in sets
            ]
            rows = [f.result() for f in dask_completed(futs)]
            rate = max(rate, len(sets) / (time.perf_counter() - t0))
            _check(rows)
        n = PARAMS["n_noop"]
        per_task = float("inf")
        for _ in range(PARAMS["repeats"]):
            t0 = time.perf_counter()
            futs = [client.submit(noop, i, pure=False) for i in range(n)]
            for f in dask_completed(futs):
                f.result()
            per_task = min(per_task, (time.perf_counter() - t0) / n)
    return rate, per_task


def pool_run(n_workers: int, doc, base, source, sets) -> tuple[float, float]:
    """(studies per second, seconds per no-op task) on a ProcessPoolExecutor."""
    import dask

    # the same single-threaded BLAS/OpenMP environment Dask's nanny gives its workers
    os.environ.update(
        {k: str(v) for k, v in dask.config.get("distributed.nanny.pre-spawn-environ").items()}
    )
    with ProcessPoolExecutor(n_workers, mp_context=get_context("spawn")) as pool:
        warm = [
            pool.submit(_study_task, doc, base, source, sets[0][1], sets[0][0])
            for _ in range(n_workers)
        ]
        _check([f.result() for f in warm])
        rate = 0.0
        for _ in range(PARAMS["repeats"]):
            t0 = time.perf_counter()
            futs = [pool.submit(_study_task, doc, base, source, s, k) for k, s in sets]
            rows = [f.result() for f in as_completed(futs)]
            rate = max(rate, len(sets) / (time.perf_counter() - t0))
            _check(rows)
        n = PARAMS["n_noop"]
        per_task = float("inf")
        for _ in range(PARAMS["repeats"]):
            t0 = time.perf_counter()
            futs = [pool.submit(noop, i) for i in range(n)]
            for f in as_completed(futs):
                f.result()
            per_task = min(per_task, (time.perf_counter() - t0) / n)
    return rate, per_task


def one_worker_rate(doc, base, source, sets) -> float:
    """Studies per second of one worker (this process, sequential; returned), and the mean
    time per study."""
    from armlab.sweep.task import run_parameter_set

    _check([run_parameter_set(doc, base, source, sets[0][1], sets[0][0])])  # warm
    t0 = time.perf_counter()
    rows = [run_parameter_set(doc, base, source, s, k) for k, s in sets]
    rate = len(sets) / (time.perf_counter() - t0)
    _check(rows)
    elapsed = float(np.mean([r["elapsed_s"] for r in rows]))
    print(f"\none worker, {len(sets)} studies sequentially")
    print(f"{'studies/s/worker':>18}{'s per study':>16}")
    print(f"{rate:>18.3f}{elapsed:>16.2f}")
    return rate


def main() -> None:
    import sys

    doc, base, source, sets = _sets()
    one_rate = one_worker_rate(doc, base, source, sets)
    engine_row = (
        __file__,
        f"demo study (no report, no workspace clouds), one worker, {len(sets)} studies in a row",
        f"{one_rate:.3f} studies/s",
    )
    if "--one-worker-only" in sys.argv[1:]:
        readme_row(*engine_row)
        return
    t0 = time.perf_counter()
    from armlab.sweep.task import run_parameter_set

    one = run_parameter_set(doc, base, source, sets[0][1], sets[0][0])
    _check([one])
    stages = {k[6:]: v for k, v in one.items() if k.startswith("stage_")}
    print(f"default study: {source} with {PARAMS['overrides']}")
    print(f"stages: {stages}")
    print(
        f"one study in this process (cold): {time.perf_counter() - t0:.2f} s; "
        f"{len(sets)} studies per measurement, varying {PARAMS['vary']}; "
        f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}"
    )
    rows = []
    for name, run in (("dask LocalCluster", dask_run), ("process pool", pool_run)):
        rates = {}
        for w in PARAMS["workers"]:
            rate, per_task = run(w, doc, base, source, sets)
            rates[w] = rate
            rows.append((name, w, rate, rate / rates[PARAMS["workers"][0]], per_task))
    print()
    print(
        f"{'backend':<20}{'workers':>8}{'studies/s':>12}{'scaling':>10}{'overhead/task [ms]':>20}"
    )
    for name, w, rate, scale, per_task in rows:
        print(f"{name:<20}{w:>8}{rate:>12.3f}{scale:>9.2f}x{per_task * 1e3:>20.3f}")
    d2 = next(r for r in rows if r[0] == "dask LocalCluster" and r[1] == 2)
    p1 = next(r for r in rows if r[0] == "process pool" and r[1] == 1)
    d1 = next(r for r in rows if r[0] == "dask LocalCluster" and r[1] == 1)
    print()
    print(f"scaling 1 -> 2 workers (dask): {d2[3]:.2f}x (goal >= 1.8x)")
    print(
        f"dask vs process pool on 1 worker: {d1[2] / p1[2]:.3f} x the pool's rate; "
        f"overhead per task {d1[4] * 1e3:.2f} ms vs {p1[4] * 1e3:.2f} ms"
    )
    p2 = next(r for r in rows if r[0] == "process pool" and r[1] == 2)
    readme_row(
        __file__,
        f"demo study (no report, no workspace clouds), 1 -> 2 workers "
        f"(goal >= {PARAMS['goal_scaling']:g}x)",
        f"Dask {d1[2]:.3f} -> {d2[2]:.3f} studies/s ({d2[3]:.2f}x), {d1[4] * 1e3:.1f} ms "
        "overhead per task",
        f"process pool {p1[2]:.3f} -> {p2[2]:.3f} ({p2[3]:.2f}x), {p1[4] * 1e3:.2f} ms",
    )
    readme_row(*engine_row)


if __name__ == "__main__":
    main()
