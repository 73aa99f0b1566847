"""Sweep results on disk: one Parquet part file per finished row, and a consolidated table.

Layout of a sweep's output folder::

    DIR/sweep.json              the sweep's definition and provenance (a folder holds one sweep)
    DIR/.sweep.lock             while a client writes the folder (armlab.io.lock)
    DIR/results.parts/<key>.parquet   one row each, written when the row finishes
    DIR/results.parquet         every row, rewritten after completions (at most once per
                                ``consolidate_s``) and at the end
    DIR/summary.txt, DIR/plots/<figure>_vs_<parameter>.png    written at the end

Every file is written atomically (:mod:`armlab.io`: temporary file in the same folder, then
``os.replace``), so a crash, Ctrl-C or ``kill -9`` at any moment leaves only complete files under
their names (and perhaps a ``.<name>.<random>.tmp``, removed by the next client): the part files
are the record of what is done (a re-run reads them), ``results.parquet`` the table to analyse.

``sweep.json`` holds the definition of the sweep -- the sha256 of the base study document, the
parameter keys, the ids of the parameter sets and their checksum ``definition_sha256`` -- and
its provenance (armlab's version, the sha256 of the study and sweep files and of every file the
base study reads). A folder holding another sweep is refused unless ``overwrite``, which first
removes the other sweep's files (and no other file).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pandas as pd

from armlab.errors import SpecError
from armlab.io import atomic_open, write_json

__all__ = ["ResultStore", "atomic_parquet", "SWEEP_FILE"]

SWEEP_FILE = "sweep.json"


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


def _difference(folder: Path, old: dict[str, Any], new: dict[str, Any]) -> str | None:
    """Why the sweep recorded in ``old`` (sweep.json) is not the sweep ``new``; None: same."""
    if old.get("study_hash") != new["study_hash"]:
        return (
            f"{folder}: holds the results of another base study (sha256 "
            f"{str(old.get('study_hash', '?'))[:12]}, this sweep's is {new['study_hash'][:12]})"
        )
    if sorted(old.get("parameters", [])) != sorted(new["parameters"]):
        return f"{folder}: holds a sweep over {old.get('parameters')}, not {new['parameters']}"
    a, b = old.get("definition_sha256"), new.get("definition_sha256")
    if a is not None and b is not None and a != b:
        mine, theirs = set(new.get("set_keys", [])), set(old.get("set_keys", []))
        return (
            f"{folder}: holds another sweep over the same keys (other values: "
            f"{len(theirs)} parameter sets, {len(mine & theirs)} of them in this sweep's "
            f"{len(mine)})"
        )
    return None


class ResultStore:
    """The rows of one sweep's output folder.

    The caller holds the folder's lock (:class:`armlab.io.lock.SweepLock`): one writer.

    Parameters
    ----------
    out_dir : path
        The sweep's output folder (created).
    meta : dict
        The content of ``sweep.json``: at least ``study_hash`` and ``parameters``, and
        ``definition_sha256`` and ``set_keys``; a folder holding another sweep (another base
        study, other parameter keys, other parameter sets) is refused (:class:`SpecError`).
    consolidate_s : float
        Least time between two rewrites of ``results.parquet`` in [s] (the part files are
        always written at once).
    overwrite : bool
        Replace another sweep's results instead of refusing the folder.
    """

    def __init__(
        self,
        out_dir: str | Path,
        meta: dict[str, Any],
        consolidate_s: float = 1.0,
        *,
        overwrite: bool = False,
    ):
        self.dir = Path(out_dir)
        self.parts = self.dir / "results.parts"
        self.path = self.dir / "results.parquet"
        self.meta_path = self.dir / SWEEP_FILE
        self.dir.mkdir(parents=True, exist_ok=True)
        self.consolidate_s = consolidate_s
        self._check_meta(meta, overwrite)
        self.parts.mkdir(exist_ok=True)
        self._remove_temporaries()
        write_json(self.meta_path, meta)
        self.rows: dict[str, dict[str, Any]] = {}
        self._last_write = 0.0
        self._dirty = False
        self._load()

    def _check_meta(self, meta: dict[str, Any], overwrite: bool) -> None:
        if not self.meta_path.is_file():
            return
        try:
            old = json.loads(self.meta_path.read_text())
        except (OSError, ValueError):
            old = None
        why = (
            f"{self.dir}: {SWEEP_FILE} is not readable JSON"
            if not isinstance(old, dict)
            else _difference(self.dir, old, meta)
        )
        if why is None:
            return
        if not overwrite:
            raise SpecError(f"{why}; choose another --out, or --overwrite to replace it")
        self.clear()

    def clear(self) -> None:
        """Remove every file a sweep writes into the folder (files it does not write stay)."""
        for pattern in ("results.parts/*.parquet", "plots/*.png", "summary.txt", SWEEP_FILE):
            for p in self.dir.glob(pattern):
                p.unlink(missing_ok=True)
        self.path.unlink(missing_ok=True)
        self._remove_temporaries()

    def _remove_temporaries(self) -> None:
        """Temporary files of an atomic write interrupted by a killed client."""
        for folder in (self.dir, self.parts, self.dir / "plots"):
            for p in folder.glob(".*.tmp") if folder.is_dir() else ():
                p.unlink(missing_ok=True)

    def _load(self) -> None:
        """Rows already done: a row per part file (the record), from the consolidated table
        when it is newer than the part file. A part file that cannot be read is no row."""
        parts = {p.stem: p for p in self.parts.glob("*.parquet")}
        stamp, table = -1.0, {}
        if self.path.is_file():
            try:
                stamp = self.path.stat().st_mtime
                table = {r["key"]: r for r in pd.read_parquet(self.path).to_dict("records")}
            except (OSError, ValueError):
                stamp, table = -1.0, {}
        for key, part in sorted(parts.items()):
            if key in table and part.stat().st_mtime < stamp:
                self.rows[key] = table[key]
                continue
            try:
                records = pd.read_parquet(part).to_dict("records")
            except (OSError, ValueError):
                continue  # run again, the part file then replaced
            for row in records:
                self.rows[row["key"]] = row
            self._dirty = True
        if set(table) - set(self.rows):  # rows of the table without a part file: dropped
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
        # dirty before the part file exists: an interrupt right after the part is written must
        # still rewrite the table in the caller's final flush
        self._dirty = True
        atomic_parquet(pd.DataFrame([row]), self.parts / f"{key}.parquet")
        if time.monotonic() - self._last_write >= self.consolidate_s:
            self.flush()

    def discard(self, keys) -> None:
        """Forget rows (their part files are removed; the table is rewritten at the next
        flush)."""
        for key in keys:
            self.rows.pop(key, None)
            (self.parts / f"{key}.parquet").unlink(missing_ok=True)
            self._dirty = True

    def frame(self) -> pd.DataFrame:
        """Every row as a DataFrame (one row per parameter set)."""
        return pd.DataFrame(list(self.rows.values()))

    def flush(self) -> None:
        """Rewrite ``results.parquet`` if rows were added or discarded since the last write."""
        if not self._dirty:
            return
        if self.rows:
            atomic_parquet(self.frame(), self.path)
        else:
            self.path.unlink(missing_ok=True)
        self._dirty = False
        self._last_write = time.monotonic()
