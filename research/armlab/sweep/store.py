"""Sweep results on disk: one Parquet part file per finished row, and a consolidated table.

Layout of a sweep's output folder::

    DIR/sweep.json              base-study hash, parameter keys (a folder holds one sweep)
    DIR/results.parts/<key>.parquet   one row each, written when the row finishes
    DIR/results.parquet         every row, rewritten after completions (at most once per
                                ``consolidate_s``) and at the end

Both are written atomically (:mod:`armlab.io`: temporary file in the same folder, then
``os.replace``), so a crash or Ctrl-C at any moment leaves only complete files: the part files
are the record of what is done (a re-run reads them), ``results.parquet`` the table to analyse.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pandas as pd

from armlab.errors import SpecError
from armlab.io import atomic_open, write_json

__all__ = ["ResultStore", "atomic_parquet"]


def _parquet_safe(frame: pd.DataFrame) -> pd.DataFrame:
    """Object columns that mix strings with numbers become strings (Parquet columns have one
    type); missing values stay missing."""
    out = frame
    for col in frame.columns:
        s = frame[col]
        if s.dtype == object:
            kinds = {type(v) for v in s if v is not None and not (isinstance(v, float) and v != v)}
            if str in kinds and len(kinds) > 1:
                if out is frame:
                    out = frame.copy()
                out[col] = s.map(
                    lambda v: (
                        v
                        if v is None or isinstance(v, str) or (isinstance(v, float) and v != v)
                        else str(v)
                    )
                )
    return out


def atomic_parquet(frame: pd.DataFrame, path: Path) -> None:
    """Write a DataFrame to Parquet atomically (:func:`armlab.io.atomic_open`)."""
    frame = _parquet_safe(frame)
    with atomic_open(path, "wb") as f:
        frame.to_parquet(f, index=False)


class ResultStore:
    """The rows of one sweep's output folder.

    Parameters
    ----------
    out_dir : path
        The sweep's output folder (created).
    meta : dict
        ``study_hash`` and ``parameters`` of the sweep; an existing folder made by another base
        study or other parameter keys is refused (:class:`SpecError`).
    consolidate_s : float
        Least time between two rewrites of ``results.parquet`` in [s] (the part files are
        always written at once).
    """

    def __init__(self, out_dir: str | Path, meta: dict[str, Any], consolidate_s: float = 1.0):
        self.dir = Path(out_dir)
        self.parts = self.dir / "results.parts"
        self.path = self.dir / "results.parquet"
        self.parts.mkdir(parents=True, exist_ok=True)
        self.consolidate_s = consolidate_s
        self._check_meta(meta)
        self.rows: dict[str, dict[str, Any]] = {}
        self._last_write = 0.0
        self._dirty = False
        self._load()

    def _check_meta(self, meta: dict[str, Any]) -> None:
        path = self.dir / "sweep.json"
        if path.is_file():
            old = json.loads(path.read_text())
            if old.get("study_hash") != meta["study_hash"]:
                raise SpecError(
                    f"{self.dir}: holds the results of another base study (sha256 "
                    f"{old.get('study_hash', '?')[:12]}, this sweep's is "
                    f"{meta['study_hash'][:12]}); choose another --out or delete it"
                )
            if sorted(old.get("parameters", [])) != sorted(meta["parameters"]):
                raise SpecError(
                    f"{self.dir}: holds a sweep over {old.get('parameters')}, not "
                    f"{meta['parameters']}; choose another --out or delete it"
                )
            return
        write_json(path, meta)

    def _load(self) -> None:
        """Rows already done: the consolidated table, then any part file it lacks."""
        stamp = -1.0
        if self.path.is_file():
            stamp = self.path.stat().st_mtime
            for row in pd.read_parquet(self.path).to_dict("records"):
                self.rows[row["key"]] = row
        for part in sorted(self.parts.glob("*.parquet")):
            if part.stem not in self.rows or part.stat().st_mtime >= stamp:
                for row in pd.read_parquet(part).to_dict("records"):
                    self.rows[row["key"]] = row
                    self._dirty = True

    def __contains__(self, key: str) -> bool:
        return key in self.rows

    def __len__(self) -> int:
        return len(self.rows)

    def status(self, key: str) -> str | None:
        row = self.rows.get(key)
        return None if row is None else row.get("status")

    def add(self, row: dict[str, Any]) -> None:
        """Record a finished row: its part file now, the consolidated table when due."""
        key = row["key"]
        self.rows[key] = row
        atomic_parquet(pd.DataFrame([row]), self.parts / f"{key}.parquet")
        self._dirty = True
        if time.monotonic() - self._last_write >= self.consolidate_s:
            self.flush()

    def frame(self) -> pd.DataFrame:
        """Every row as a DataFrame (one row per parameter set)."""
        return pd.DataFrame(list(self.rows.values()))

    def flush(self) -> None:
        """Rewrite ``results.parquet`` if rows were added since the last write."""
        if not self._dirty:
            return
        atomic_parquet(self.frame(), self.path)
        self._dirty = False
        self._last_write = time.monotonic()
