"""One sweep task: run the base study with one parameter set and return its result row.

This function runs on the workers (a Dask worker process, local or remote): it takes plain data
(the base study document, its folder, the parameter set) and returns a plain dict, never raises
for a failing study, and writes no file -- the client writes the rows, so workers need not share
the client's file system.
"""

from __future__ import annotations

import math
import os
import socket
import time
import traceback
from pathlib import Path
from typing import Any

__all__ = ["run_parameter_set", "ROW_FIELDS"]

#: Bookkeeping columns of every result row (then the parameters, then the key figures).
ROW_FIELDS = ("key", "status", "error", "elapsed_s", "worker", "finished_at")


def run_parameter_set(
    document: dict[str, Any], study_dir: str, source: str, params: dict[str, Any], key: str
) -> dict[str, Any]:
    """Run one study and return its row.

    Returns
    -------
    dict
        ``key``, the parameters, ``status`` ("done" or "error"), ``error`` (one line, "" when
        done), ``elapsed_s``, ``worker`` (host:pid), ``finished_at`` (Unix time) and the study's
        key figures (:func:`armlab.study.key_figures`; NaN where a stage did not run).
    """
    t0 = time.perf_counter()
    row: dict[str, Any] = {"key": key, **params}
    try:
        from armlab.errors import ArmlabError
        from armlab.study.runner import key_figures, run_spec
        from armlab.study.spec import apply_overrides, parse_study

        try:
            doc = apply_overrides(document, params)
            spec = parse_study(doc, base_dir=Path(study_dir), source=source)
            result = run_spec(spec, None, progress=False, report=False)
            row.update(status="done", error="")
            row.update(key_figures(result.summary))
        except ArmlabError as exc:
            row.update(status="error", error=_one_line(f"{type(exc).__name__}: {exc}"))
    except Exception as exc:  # a bug in a stage: still a row, with where it happened
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" at {Path(tb[-1].filename).name}:{tb[-1].lineno}" if tb else ""
        row.update(status="error", error=_one_line(f"{type(exc).__name__}: {exc}{where}"))
    row["elapsed_s"] = time.perf_counter() - t0
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    row["finished_at"] = time.time()
    return row


def _one_line(text: str, limit: int = 500) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def nan_row(key: str, params: dict[str, Any], error: str) -> dict[str, Any]:
    """The row of a parameter set that could not be run (its workers kept dying)."""
    return {
        "key": key,
        **params,
        "status": "error",
        "error": _one_line(error),
        "elapsed_s": math.nan,
        "worker": "",
        "finished_at": time.time(),
    }
