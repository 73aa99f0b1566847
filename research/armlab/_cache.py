"""The one home of armlab's on-disk cache folder and of the C compiler its compiled artefacts
are built with (fatrop's stage libraries, :mod:`armlab.planning.fatrop_stages`; the S-curve
graph, :mod:`armlab.trajectory.profiles.graph`, and the closed-form plan's,
:mod:`armlab.planning.closed_graph`, both through :mod:`armlab._compiled`; the collision-pair
analyses, :mod:`armlab.collision.pairs`)."""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from armlab.errors import ArmlabError

__all__ = ["CompilerUnavailable", "build_library", "cache_dir", "compiler"]


class CompilerUnavailable(ArmlabError):
    """No C compiler here (``$CC`` set to a missing program included)."""


def cache_dir(environ: Mapping[str, str] | None = None) -> Path:
    """The folder of armlab's cached artefacts: ``$ARMLAB_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/armlab``, else ``~/.cache/armlab`` (of ``environ``: a snapshot a
    background thread was given; default the process' environment)."""
    env = os.environ if environ is None else environ
    own = env.get("ARMLAB_CACHE_DIR")
    if own:
        return Path(own).expanduser()
    xdg = env.get("XDG_CACHE_HOME")
    return (Path(xdg).expanduser() if xdg else Path.home() / ".cache") / "armlab"


def compiler(environ: Mapping[str, str] | None = None) -> str:
    """The C compiler: ``$CC`` if set, else ``gcc`` or ``cc`` on the path (of ``environ``, as
    :func:`cache_dir`).

    Raises
    ------
    CompilerUnavailable
        None found (``$CC`` set to a missing program included).
    """
    env = os.environ if environ is None else environ
    cc = env.get("CC")
    names = [cc] if cc else ["gcc", "cc"]
    for name in names:
        found = shutil.which(name, path=env.get("PATH"))
        if found:
            return found
    raise CompilerUnavailable(f"no C compiler ({'CC=' + cc if cc else 'gcc or cc'} not found)")


#: the compile command's shell: run the compiler (arguments 4...), rename its output (1) to
#: the library (2), remove the build folder (3). The shell, not Python, renames and cleans
#: up, so a compile whose Python process exits meanwhile (a background compile of a short
#: script) still finishes and is cached.
_FINISH = 'out=$1 so=$2 tmp=$3; shift 3; "$@" && mv -f "$out" "$so"; rc=$?; rm -rf "$tmp"; exit $rc'


def build_library(so: Path, cc: str, sources: Callable[[Path], Sequence[str]], what: str) -> None:
    """Compile a shared library into ``so``, atomically: ``sources(folder)`` writes the C
    files into a new build folder beside ``so`` and returns the compiler's arguments (files
    and flags, without ``-o``); ``cc`` runs there and its output is renamed to ``so`` (a
    rename within one file system: a reader finds the whole file or none, and parallel
    processes that build the same library at once are safe); the build folder is removed.

    Raises
    ------
    CompilerUnavailable
        The compiler could not run, or failed (``what``: what was being compiled, named in
        the message with the compiler's last line of output).
    """
    so.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=so.parent, prefix=".build-"))
    out = tmp / so.name
    try:
        cmd = ["sh", "-c", _FINISH, "sh", str(out), str(so), str(tmp), cc, *sources(tmp)]
        r = subprocess.run([*cmd, "-o", str(out)], capture_output=True, text=True, check=False)
    except OSError as exc:
        raise CompilerUnavailable(f"the C compiler {cc} could not run: {exc}") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if r.returncode or not so.exists():
        last = (r.stderr.strip().splitlines() or ["(no message)"])[-1]
        raise CompilerUnavailable(f"compiling {what} failed: {last}")
