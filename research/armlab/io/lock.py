"""One writer per output folder: an exclusive lock file in the folder -- the one lock of armlab.

``armlab run`` and ``armlab export`` lock a study folder (``DIR/.armlab.lock``,
:class:`FolderLock`), ``armlab sweep`` its sweep folder (``DIR/.sweep.lock``, :class:`SweepLock`).
The client creates the lock file exclusively (the operating system lets one process create
it) holding who has it: the command, pid, host, start time, the process's start time
(``/proc/<pid>/stat``, to tell a recycled pid) and a random token. The content goes to a
temporary file first, which is then hard-linked to the lock's name (``link`` fails if the name
exists), so the lock file is complete whenever it exists (without hard links:
``O_CREAT | O_EXCL``, then a write). A second client on the same folder is refused with one
line naming the holder; the holder removes the file when it ends, whatever the
reason (Ctrl-C included).

A lock left by a client that was killed (``kill -9``, power loss of a laptop that comes back) is
stale: on the same host, a holder whose pid is gone, a zombie, or a recycled pid (another start
time) is taken over. The take-over happens under ``flock`` of the folder and only if the file
still holds the bytes judged stale, so two clients that find the same stale lock cannot both
take it. A lock of another host cannot be checked: the message says which file to delete once
that client is known to be gone.
"""

from __future__ import annotations

import json
import os
import secrets
import socket
import time
from pathlib import Path
from typing import Any

from armlab.errors import InputError

__all__ = [
    "LOCK_NAME",
    "STUDY_LOCK_NAME",
    "FolderLock",
    "SweepLock",
    "lock_names",
    "is_lock_file",
]

#: The lock file of a sweep folder.
LOCK_NAME = ".sweep.lock"
#: The lock file of a study folder (``armlab run``, ``armlab export``).
STUDY_LOCK_NAME = ".armlab.lock"


def lock_names() -> tuple[str, ...]:
    """Every lock file name (a folder check must not count a lock as a foreign file)."""
    return (LOCK_NAME, STUDY_LOCK_NAME)


def is_lock_file(path: Path) -> bool:
    """A folder lock or a lock's temporary file: nobody's output (a folder check must not count
    it as a foreign file)."""
    name = Path(path).name
    return any(
        name == n or (name.startswith(n + ".") and name.endswith(".tmp")) for n in lock_names()
    )


#: A lock file still empty after this long lost its writer between create and write [s].
_EMPTY_STALE_S = 30.0


def _proc_stat(pid: int) -> tuple[str, int] | None:
    """(state, start time in clock ticks) of a process from ``/proc``; None when unknown."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rfind(")") + 2 :].split()
    try:
        return fields[0], int(fields[19])
    except (IndexError, ValueError):
        return None


def _alive(pid: int, started: int | None) -> bool:
    """The process ``pid`` runs (not a zombie) and, if ``started`` is known, is the same one."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: it exists
        pass
    stat = _proc_stat(pid)
    if stat is None:
        return True
    state, start = stat
    if state in ("Z", "X"):
        return False
    return started is None or start == started


class FolderLock:
    """The lock of one output folder (a context manager).

    Parameters
    ----------
    folder : path
        The output folder (must exist).
    command : str
        What takes it (``"armlab run"``), recorded in the lock and named to a refused client.
    name : str
        The lock file's name in the folder.
    """

    def __init__(
        self, folder: str | Path, command: str = "armlab run", name: str = STUDY_LOCK_NAME
    ):
        self.folder = Path(folder)
        self.command = command
        self.path = self.folder / name
        self._content: bytes | None = None

    def _holder_info(self) -> dict[str, Any]:
        stat = _proc_stat(os.getpid())
        return {
            "command": self.command,
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "started_at": time.time(),
            "proc_start": None if stat is None else stat[1],
            "token": secrets.token_hex(8),
        }

    def acquire(self) -> None:
        """Take the lock, taking over a stale one.

        Raises
        ------
        InputError
            Another live client holds it (one line naming it).
        """
        content = json.dumps(self._holder_info()).encode()
        for _ in range(5):
            try:
                created = self._create(content)
            except FileNotFoundError:  # our temporary file was swept away: try again
                continue
            if created:
                self._content = content
                return
            seen = self._read()
            if seen is None:  # released meanwhile: try again
                continue
            if self._stale(seen):
                self._break(seen)
                continue
            raise InputError(self._busy_message(seen))
        raise InputError(f"{self.path}: cannot take the folder's lock (it keeps changing)")

    def _create(self, content: bytes) -> bool:
        """Create the lock file holding ``content``, exclusively; False if it exists.

        The content is written to a temporary file first and hard-linked to the lock's name
        (``link`` fails if the name exists), so the lock file is never seen empty; where the
        file system has no hard links, ``O_CREAT | O_EXCL`` and a write.
        """
        tmp = self.folder / f"{self.path.name}.{secrets.token_hex(4)}.tmp"
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        try:
            try:
                os.write(fd, content)
                os.fsync(fd)
            finally:
                os.close(fd)
            try:
                os.link(tmp, self.path)
                return True
            except FileExistsError:
                return False
            except FileNotFoundError:
                raise
            except OSError:  # no hard links here
                pass
        finally:
            tmp.unlink(missing_ok=True)
        try:
            fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            return False
        try:
            os.write(fd, content)
            os.fsync(fd)
        finally:
            os.close(fd)
        return True

    def release(self) -> None:
        """Remove the lock file if it is still this client's."""
        if self._content is None:
            return
        try:
            if self.path.read_bytes() == self._content:
                self.path.unlink()
        except OSError:
            pass
        self._content = None

    def __enter__(self) -> FolderLock:
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    # ------------------------------------------------------------------ helpers
    def _read(self) -> bytes | None:
        try:
            return self.path.read_bytes()
        except FileNotFoundError:
            return None

    def _stale(self, content: bytes) -> bool:
        try:
            info = json.loads(content)
        except ValueError:
            info = None
        if not isinstance(info, dict):  # a writer that died between create and write
            try:
                age = time.time() - self.path.stat().st_mtime
            except OSError:
                return True
            return age > _EMPTY_STALE_S
        if info.get("host") != socket.gethostname():
            return False
        pid, start = info.get("pid"), info.get("proc_start")
        if not isinstance(pid, int):
            return True
        return not _alive(pid, start if isinstance(start, int) else None)

    def _break(self, seen: bytes) -> None:
        """Remove the stale lock ``seen`` -- under flock of the folder, and only if the file
        still holds those bytes (another client may have taken it over meanwhile)."""
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not POSIX
            fcntl = None  # type: ignore[assignment]
        fd = os.open(self.folder, os.O_RDONLY)
        try:
            if fcntl is not None:
                fcntl.flock(fd, fcntl.LOCK_EX)
            try:
                if self.path.read_bytes() == seen:
                    self.path.unlink()
            except FileNotFoundError:
                pass
        finally:
            os.close(fd)  # releases the flock

    def _busy_message(self, content: bytes | None) -> str:
        try:
            info = json.loads(content or b"")
        except ValueError:
            info = None
        if not isinstance(info, dict):
            return f"{self.folder}: another {self.command} is starting in this folder ({self.path})"
        command = info.get("command")
        if not isinstance(command, str) or not command:
            command = self.command
        since = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(info.get("started_at", 0)))
        where = (
            f"delete it if that {command.split()[-1]} is gone"
            if info.get("host") != socket.gethostname()
            else "wait for it to end"
        )
        return (
            f"{self.folder}: another {command} writes here (pid {info.get('pid')} on "
            f"{info.get('host')} since {since}; lock {self.path}): {where}"
        )


class SweepLock(FolderLock):
    """The lock of one sweep folder, ``DIR/.sweep.lock`` (:class:`FolderLock`)."""

    def __init__(self, folder: str | Path):
        super().__init__(folder, command="armlab sweep", name=LOCK_NAME)
