"""Run a sweep on Dask: a local process cluster by default, or any cluster by its scheduler.

One code path: :func:`run_sweep` always talks to a ``dask.distributed`` scheduler -- a
``LocalCluster(processes=True, n_workers=N, threads_per_worker=1)`` started for the sweep, or
the scheduler at ``--scheduler tcp://host:port``. Every missing parameter set is submitted as
one task (:func:`armlab.sweep.task.run_parameter_set`); rows are written as they complete
(:class:`armlab.sweep.store.ResultStore`).

Failures
--------
* A study that fails (an :class:`armlab.ArmlabError`, or any exception in a stage) is a row with
  ``status = "error"`` and its one-line message; the sweep goes on.
* A worker that dies: the scheduler reschedules its tasks on the other workers (Dask's own
  recovery, ``distributed.scheduler.allowed-failures``); if a task still ends with
  ``KilledWorker`` it is resubmitted up to ``sweep.retries`` times, then recorded as an error.
* Ctrl-C or a crash of the client (``kill -9`` included): every finished row is already on
  disk; running the same command again runs only the parameter sets that have no row (and, with
  ``sweep.rerun_errors``, those that ended in an error).

Provenance and one writer
-------------------------
* Every row records armlab's version and the sha256 of the base study and of the files it reads
  (URDF, ``drives.toml``, ``mdh.toml``, drive catalogue, controller profile) and their checksum
  ``inputs_sha256`` (:mod:`armlab.sweep.provenance`). On a resume, a row whose inputs changed
  (``drives.toml`` edited, armlab upgraded) is removed and run again -- a note on stderr says how
  many and what changed; the table never mixes rows of old and new inputs.
* A folder holds one sweep (``sweep.json``): a sweep with another definition (base study,
  parameter keys or parameter sets) is refused with one line unless ``overwrite``.
* One client per folder (:class:`armlab.io.lock.SweepLock`): a second client is refused while
  the first runs; the lock of a killed client is taken over.
"""

from __future__ import annotations

import errno
import logging
import sys
import time
import uuid
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pandas as pd

from armlab._cpus import usable_cpus
from armlab.deploy.provenance import armlab_version, file_sha256
from armlab.errors import InputError
from armlab.io import atomic_write
from armlab.io.lock import SweepLock
from armlab.sweep.provenance import describe_changes, file_hashes, input_files, row_provenance
from armlab.sweep.spec import (
    SweepSpec,
    definition_sha256,
    load_sweep,
    parameter_key,
    parameter_sets,
)
from armlab.sweep.store import ResultStore
from armlab.sweep.task import nan_row, run_parameter_set

if TYPE_CHECKING:
    from distributed import Client, LocalCluster

__all__ = ["run_sweep", "run_sweep_spec", "open_client", "sweep_meta", "sweep_outcome"]

SWEEP_FORMAT = "armlab.sweep/2"


def open_client(
    workers: int | None = None, scheduler: str | None = None
) -> tuple[Client, LocalCluster | None]:
    """(client, cluster or None): a client of ``scheduler``, or of a new local process cluster
    with ``workers`` single-threaded worker processes (default: one per CPU).

    Raises
    ------
    InputError
        The scheduler cannot be reached, or ``workers`` < 1.
    """
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            return Client(scheduler, timeout="10s"), None
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(
                f"cannot reach the Dask scheduler at {scheduler!r} ({type(exc).__name__}: {exc})"
            ) from None
    n = usable_cpus() if workers is None else int(workers)
    if n < 1:
        raise InputError(f"--workers must be >= 1, not {workers}")
    cluster = LocalCluster(
        n_workers=n,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
    )
    return Client(cluster), cluster


def _progress(total: int, initial: int, enabled: bool | None, desc: str):
    from armlab._progress import tqdm  # tqdm.auto; on in Jupyter

    # rate and ETA are in tqdm's default format; disable=None: silent without a terminal
    return tqdm(
        total=total,
        initial=initial,
        desc=desc,
        unit="study",
        smoothing=0.05,
        disable=None if enabled is None else not enabled,
        file=sys.stderr,
    )


def _sha_or_none(path: str | Path | None) -> str | None:
    try:
        return None if path is None else file_sha256(path)
    except OSError:
        return None


def sweep_meta(
    spec: SweepSpec, set_keys: list[str], memo: dict[Path, str] | None = None
) -> dict[str, Any]:
    """The content of ``sweep.json``: the sweep's definition and its provenance.

    ``format``, ``name``, ``armlab_version``; ``sweep_file`` and ``study_file`` with their
    sha256; ``study_hash`` (sha256 of the base study document after ``[set]``), ``parameters``,
    ``n_sets``, ``definition_sha256`` (:func:`armlab.sweep.spec.definition_sha256`); ``inputs``:
    path and sha256 of every file the base study reads; ``set_keys``: the ids of the sets.
    """
    files = input_files(spec.study_document, spec.study_dir)
    hashes = file_hashes(files, memo)
    sweep_file = None if spec.source == "<dict>" else Path(spec.source)
    return {
        "format": SWEEP_FORMAT,
        "name": spec.name,
        "armlab_version": armlab_version(),
        "sweep_file": None if sweep_file is None else str(sweep_file.resolve()),
        "sweep_file_sha256": _sha_or_none(sweep_file),
        "study": spec.study_source,
        "study_file": None if spec.study_file is None else str(spec.study_file),
        "study_file_sha256": _sha_or_none(spec.study_file),
        "study_hash": spec.study_hash,
        "parameters": spec.parameter_keys,
        "n_sets": len(set_keys),
        "definition_sha256": definition_sha256(spec, set_keys),
        "inputs": {
            name: {
                "path": None if path is None else str(path),
                "sha256": hashes[f"{name}_sha256"],
            }
            for name, path in files.items()
        },
        "set_keys": list(set_keys),
    }


def sweep_outcome(frame: pd.DataFrame) -> dict[str, int]:
    """Counts behind the exit status of ``armlab sweep``: ``rows``, ``errors`` (rows whose
    study did not finish), ``failing`` (finished, design verdict "fail") and ``not_judged``
    (finished, verdict "incomplete": a judging stage did not run)."""
    n = len(frame)
    status = frame["status"] if "status" in frame else pd.Series([""] * n, dtype=object)
    verdict = frame["verdict"] if "verdict" in frame else pd.Series([""] * n, dtype=object)
    done = (status == "done").to_numpy()
    fail = (verdict == "fail").to_numpy()
    judged = verdict.isin(["pass", "fail"]).to_numpy()
    return {
        "rows": n,
        "errors": int((~done).sum()),
        "failing": int((done & fail).sum()),
        "not_judged": int((done & ~judged).sum()),
    }


def _stale_note(changes: dict[str, list[str]]) -> str:
    what: list[str] = []
    for lines in changes.values():
        for line in lines:
            if line not in what:
                what.append(line)
    shown = "; ".join(what[:3]) + (f"; and {len(what) - 3} more" if len(what) > 3 else "")
    return (
        f"armlab: sweep: {len(changes)} row(s) were computed from other inputs ({shown}): "
        "they run again"
    )


def run_sweep_spec(
    spec: SweepSpec,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool | None = None,
    quiet: bool = False,
    client=None,
    overwrite: bool = False,
) -> pd.DataFrame:
    """Run a validated sweep into ``out_dir``; see :func:`run_sweep`.

    ``client`` (a ``distributed.Client``) reuses an open cluster instead of starting one.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():  # an error of the file system: exit status 3
        raise NotADirectoryError(errno.ENOTDIR, "--out exists and is not a folder", str(out))
    out.mkdir(parents=True, exist_ok=True)
    sets = parameter_sets(spec)
    keys = [parameter_key(s) for s in sets]
    memo: dict[Path, str] = {}
    expected = {
        k: row_provenance(spec.study_document, spec.study_dir, s, k, memo)
        for k, s in zip(keys, sets, strict=True)
    }
    with SweepLock(out):
        store = ResultStore(out, sweep_meta(spec, keys, memo), overwrite=overwrite)
        stale = {
            k: describe_changes(store.rows[k], expected[k])
            for k in keys
            if k in store and store.rows[k].get("inputs_sha256") != expected[k]["inputs_sha256"]
        }
        if stale:
            print(_stale_note(stale), file=sys.stderr)
        # rows of old inputs (and of sets this sweep does not have) never stay in the table
        store.discard([*stale, *(k for k in store.rows if k not in expected)])
        store.flush()
        todo = [
            (k, s)
            for k, s in zip(keys, sets, strict=True)
            if k not in store or (spec.rerun_errors and store.status(k) == "error")
        ]
        n_before = len(sets) - len(todo)
        t_start = time.perf_counter()
        ran = 0
        if todo:
            own = client is None
            cluster = None
            if own:
                client, cluster = open_client(workers, scheduler)
            bar = _progress(len(sets), n_before, progress, spec.name)
            try:
                ran = _execute(client, spec, todo, store, bar, expected)
            finally:
                bar.close()
                store.flush()
                if own:
                    client.close()
                    if cluster is not None:
                        cluster.close()
        store.flush()
        frame = store.frame()
        order = {k: i for i, k in enumerate(keys)}
        frame = frame[frame["key"].isin(order)].copy()
        frame = frame.sort_values("key", key=lambda s: s.map(order)).reset_index(drop=True)
        from armlab.sweep.report import sweep_summary_text, write_sweep_plots

        plots = write_sweep_plots(frame, spec, out)
        text = sweep_summary_text(
            frame,
            spec,
            ran=ran,
            before=n_before,
            elapsed_s=time.perf_counter() - t_start,
            plots=plots,
            out_dir=out,
        )
        atomic_write(out / "summary.txt", text + "\n")
    if not quiet:
        print(text)
    return frame


def _execute(
    client, spec: SweepSpec, todo, store: ResultStore, bar, expected: dict[str, dict[str, str]]
) -> int:
    """Submit every task, record rows as they complete; returns the number of rows written."""
    from distributed import as_completed
    from distributed.client import FutureCancelledError
    from distributed.scheduler import KilledWorker

    doc, study_dir, source = spec.study_document, str(spec.study_dir), spec.study_source
    token = uuid.uuid4().hex[:8]
    attempts: dict[str, int] = {}
    params_of: dict[str, dict[str, Any]] = {}

    def submit(key: str, params: dict[str, Any]):
        n = attempts.get(key, 0)
        return client.submit(
            run_parameter_set,
            doc,
            study_dir,
            source,
            params,
            key,
            expected[key],
            key=f"armlab-study-{key}-{token}-{n}",
            pure=False,
        )

    futures = {}
    for key, params in todo:
        params_of[key] = params
        futures[submit(key, params)] = key
    done = 0
    queue = as_completed(list(futures))
    for fut in queue:
        key = futures.pop(fut)
        try:
            row = fut.result()
        except KilledWorker as exc:
            attempts[key] = attempts.get(key, 0) + 1
            if attempts[key] <= spec.retries:
                new = submit(key, params_of[key])
                futures[new] = key
                queue.add(new)
                continue
            row = nan_row(
                key,
                params_of[key],
                f"KilledWorker: the workers running this set died {attempts[key]} times ({exc})",
                expected[key],
            )
        except (FutureCancelledError, Exception) as exc:  # noqa: BLE001 - any task failure is a row
            row = nan_row(key, params_of[key], f"{type(exc).__name__}: {exc}", expected[key])
        finally:
            fut.release()
        store.add(row)
        done += 1
        bar.update()
    return done


def run_sweep(
    sweep: str | Path,
    out_dir: str | Path,
    workers: int | None = None,
    scheduler: str | None = None,
    *,
    progress: bool | None = None,
    quiet: bool = False,
    overwrite: bool = False,
) -> pd.DataFrame:
    """Run a SWEEP.toml into ``out_dir`` (``armlab sweep``); returns one row per parameter set.

    Parameters
    ----------
    sweep : str or Path
        The sweep file (:mod:`armlab.sweep.spec`).
    out_dir : str or Path
        ``results.parquet`` (+ ``results.parts/``, ``sweep.json``), ``summary.txt`` and
        ``plots/<figure>_vs_<parameter>.png``. An existing folder of the same sweep is resumed:
        only the missing parameter sets run, and those whose inputs changed. A folder holding
        another sweep is refused (:class:`armlab.SpecError`), a folder another client writes too
        (:class:`armlab.InputError`).
    workers : int, optional
        Worker processes of the local cluster (default: one per CPU). Ignored with ``scheduler``.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:port``); its workers need armlab
        installed (and the robot descriptions the study names).
    progress : bool or None
        Progress bar with rate and ETA; None: only on a terminal.
    quiet : bool
        Do not print the summary table.
    overwrite : bool
        Replace the results of another sweep in ``out_dir`` instead of refusing the folder.

    Returns
    -------
    pandas.DataFrame
        Columns ``key``, the parameter keys, ``status``, ``error``, ``elapsed_s``, ``worker``,
        ``finished_at``, the key figures of :func:`armlab.study.figures.key_figures` (``verdict``
        among them) and the provenance columns (:mod:`armlab.sweep.provenance`).
        :func:`sweep_outcome` counts its errors and failing designs.
    """
    return run_sweep_spec(
        load_sweep(sweep),
        out_dir,
        workers=workers,
        scheduler=scheduler,
        progress=progress,
        quiet=quiet,
        overwrite=overwrite,
    )
