"""One sweep task: run the base study with one parameter set and return its result row.

This function runs on the workers (a Dask worker process, local or remote): it takes plain data
(the base study document, its folder, the parameter set) and returns a plain dict, never raises
for a failing study, and writes no file -- the client writes the rows, so workers need not share
the client's file system.

Every row carries its provenance (:mod:`armlab.sweep.provenance`): armlab's version and the
sha256 of the base study and of every file the study reads, as the worker sees them. When the
client passes the provenance it expects and the worker's differs (another armlab, another
``drives.toml`` on a remote worker), the row is an error naming the difference. A worker process
loads each robot once (:func:`armlab.study.build.build_robot` caches it); the cache is emptied
when a robot file changes under a long-lived worker, so a row never uses a stale description.
"""

from __future__ import annotations

import math
import os
import socket
import time
import traceback
from pathlib import Path
from typing import Any

__all__ = ["run_parameter_set", "ROW_FIELDS", "nan_row"]

#: Bookkeeping columns of every result row (then the parameters, the key figures and the
#: provenance columns :data:`armlab.sweep.provenance.PROVENANCE_FIELDS`).
ROW_FIELDS = ("key", "status", "error", "elapsed_s", "worker", "finished_at")

#: Robot files seen by this process: URDF path -> sha256 of (URDF, drives.toml, mdh.toml).
_robot_files_seen: dict[str, tuple[str, str, str]] = {}


def _forget_changed_robot(document: dict[str, Any], study_dir: str, prov: dict[str, str]) -> None:
    """Empty the study stages' robot cache when this robot's files are not the ones this
    process saw the last time (a description edited under a long-lived worker, or a robot
    this process may have loaded before it ran sweep tasks)."""
    from armlab.sweep.provenance import input_files

    urdf = input_files(document, study_dir)["urdf"]
    if urdf is None:
        return
    files = (prov["urdf_sha256"], prov["drives_sha256"], prov["mdh_sha256"])
    if _robot_files_seen.get(str(urdf)) == files:
        return
    from armlab.study import build

    build._load_cached.cache_clear()
    _robot_files_seen[str(urdf)] = files


def run_parameter_set(
    document: dict[str, Any],
    study_dir: str,
    source: str,
    params: dict[str, Any],
    key: str,
    expected: dict[str, str] | None = None,
) -> dict[str, Any]:
    """Run one study and return its row.

    Parameters
    ----------
    document : dict
        The base study document (``[set]`` applied).
    study_dir : str
        The folder its relative paths refer to.
    source : str
        Its name in messages.
    params : dict
        The parameter set (dotted study keys).
    key : str
        Its id (:func:`armlab.sweep.spec.parameter_key`).
    expected : dict, optional
        The provenance the client computed for this set; a worker that reads other inputs
        returns an error row naming them.

    Returns
    -------
    dict
        ``key``, the parameters, ``status`` ("done" or "error"), ``error`` (one line, "" when
        done), ``elapsed_s``, ``worker`` (host:pid), ``finished_at`` (Unix time), the study's
        key figures (:func:`armlab.study.figures.key_figures`; NaN where a stage did not run)
        and the provenance columns.
    """
    t0 = time.perf_counter()
    row: dict[str, Any] = {"key": key, **params}
    prov: dict[str, str] = {}
    try:
        from armlab.errors import ArmlabError
        from armlab.study.runner import run_spec
        from armlab.study.spec import apply_overrides, parse_study
        from armlab.sweep.provenance import describe_changes, row_provenance

        prov = row_provenance(document, study_dir, params, key)
        if expected is not None and prov["inputs_sha256"] != expected.get("inputs_sha256"):
            changed = "; ".join(describe_changes(expected, prov))
            row.update(
                status="error",
                error=_one_line(
                    "InputError: this worker reads other inputs than the client (client -> "
                    f"worker): {changed}; give the workers the client's armlab and robot files"
                ),
            )
        else:
            try:
                doc = apply_overrides(document, params)
                _forget_changed_robot(doc, study_dir, prov)
                spec = parse_study(doc, base_dir=Path(study_dir), source=source)
                result = run_spec(spec, None, progress=False, report=False)
                row.update(status="done", error="")
                row.update(result.key_figures())
            except ArmlabError as exc:
                row.update(status="error", error=_one_line(f"{type(exc).__name__}: {exc}"))
    except Exception as exc:  # a bug in a stage: still a row, with where it happened
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" at {Path(tb[-1].filename).name}:{tb[-1].lineno}" if tb else ""
        row.update(status="error", error=_one_line(f"{type(exc).__name__}: {exc}{where}"))
    row["elapsed_s"] = time.perf_counter() - t0
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    row["finished_at"] = time.time()
    row.update(prov)
    return row


def _one_line(text: str, limit: int = 500) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def nan_row(
    key: str, params: dict[str, Any], error: str, provenance: dict[str, str] | None = None
) -> dict[str, Any]:
    """The row of a parameter set that could not be run (its workers kept dying); it carries
    the client's ``provenance`` of the set."""
    return {
        "key": key,
        **params,
        "status": "error",
        "error": _one_line(error),
        "elapsed_s": math.nan,
        "worker": "",
        "finished_at": time.time(),
        **(provenance or {}),
    }
