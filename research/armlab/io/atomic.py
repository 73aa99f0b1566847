"""Atomic file writes and strict JSON: the one place armlab puts bytes on disk.

A write goes to a temporary file in the target's folder (``.<name>.<random>.tmp``), is flushed and
``fsync``-ed, then renamed over the target with ``os.replace`` and the folder is ``fsync``-ed.
A reader sees the old file or the new one, never a partial one; on any error (including
Ctrl-C) the temporary file is removed and the old file is left as it was.

The temporary file is created with ``os.open(..., 0o666)``, so the kernel applies the process
umask: the file ends up ``0o666 & ~umask`` (0644 under umask 022) — not the 0600 that
``tempfile.mkstemp`` would leave.
"""

from __future__ import annotations

import json
import math
import os
import secrets
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

import numpy as np

from armlab.errors import InputError

__all__ = ["atomic_open", "atomic_write", "atomic_write_many", "json_safe", "write_json"]

_MODES = ("w", "wt", "wb")


def _create_temp(path: Path) -> tuple[int, Path]:
    """A new, empty temporary file beside ``path``: its descriptor and name."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    for _ in range(100):
        tmp = path.parent / f".{path.name}.{secrets.token_hex(4)}.tmp"
        try:
            return os.open(tmp, flags, 0o666), tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"{path.parent}: no free temporary name for {path.name}")


def _fsync_dir(folder: Path) -> None:
    """Make a rename in ``folder`` durable (best effort: some file systems refuse it)."""
    try:
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextmanager
def atomic_open(
    path: str | os.PathLike, mode: str = "w", *, encoding: str | None = None, newline=None
) -> Iterator[IO]:
    """Open ``path`` for an atomic write; the file appears only when the block ends cleanly.

    Parameters
    ----------
    path : path
        The target file; its folder must exist.
    mode : {"w", "wt", "wb"}
        Text or binary.
    encoding, newline
        As for :func:`open` (text mode only; encoding defaults to UTF-8).

    Yields
    ------
    file object
        Write to it; do not close it.

    Examples
    --------
    >>> with atomic_open(out / "plot.png", "wb") as f:   # doctest: +SKIP
    ...     fig.savefig(f, format="png")
    """
    if mode not in _MODES:
        raise InputError(f"atomic_open: mode must be one of {_MODES}, not {mode!r}")
    path = Path(path)
    fd, tmp = _create_temp(path)
    f: IO[Any]
    try:
        if "b" in mode:
            f = os.fdopen(fd, "wb")
        else:
            f = os.fdopen(fd, "w", encoding=encoding or "utf-8", newline=newline)
    except BaseException:
        os.close(fd)
        tmp.unlink(missing_ok=True)
        raise
    try:
        with f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)


def _as_bytes(data: bytes | str) -> bytes:
    return data.encode("utf-8") if isinstance(data, str) else bytes(data)


def _write_temp(path: Path, data: bytes) -> Path:
    """``data`` in a durable temporary file beside ``path`` (not yet renamed)."""
    fd, tmp = _create_temp(path)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return tmp


def atomic_write(path: str | os.PathLike, data: bytes | str) -> Path:
    """Write ``data`` (str is UTF-8 encoded) to ``path`` atomically; returns the path."""
    return atomic_write_many([(path, data)])[0]


def atomic_write_many(items: Iterable[tuple[str | os.PathLike, bytes | str]]) -> list[Path]:
    """Write several files: every temporary file first, then rename them all.

    If any write fails, every temporary file is removed and no target is touched.
    """
    pairs = [(Path(p), _as_bytes(d)) for p, d in items]
    temps: list[Path] = []
    try:
        for path, data in pairs:
            temps.append(_write_temp(path, data))
        for (path, _), tmp in zip(pairs, temps, strict=True):
            os.replace(tmp, path)
    except BaseException:
        for t in temps:
            t.unlink(missing_ok=True)
        raise
    for folder in dict.fromkeys(p.parent for p, _ in pairs):
        _fsync_dir(folder)
    return [p for p, _ in pairs]


def json_safe(x: Any) -> Any:
    """``x`` made strict-JSON safe: NaN -> None, +-inf -> ``"inf"``/``"-inf"``; NumPy scalars
    and arrays become Python numbers and lists; dicts, lists and tuples are walked."""
    if isinstance(x, np.ndarray):
        return json_safe(x.tolist())
    if isinstance(x, np.generic):
        return json_safe(x.item())
    if isinstance(x, float):
        if math.isnan(x):
            return None
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return x
    if isinstance(x, dict):
        return {k: json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    return x


def write_json(path: str | os.PathLike, data: Any, *, indent: int = 2) -> Path:
    """Write ``data`` as strict JSON (:func:`json_safe`, ``allow_nan=False``) atomically.

    Returns the path. A value JSON cannot hold raises ``TypeError`` and leaves no file.
    """
    text = json.dumps(json_safe(data), indent=indent, allow_nan=False) + "\n"
    return atomic_write(path, text)
