"""The one home of armlab's on-disk cache folder and of the C compiler its compiled artefacts
are built with (fatrop's stage libraries, :mod:`armlab.planning.fatrop_stages`; the S-curve
graph, :mod:`armlab.trajectory.profiles.graph`; the collision-pair analyses,
:mod:`armlab.collision.pairs`)."""

from __future__ import annotations

import os
import shutil
from collections.abc import Mapping
from pathlib import Path

from armlab.errors import ArmlabError

__all__ = ["CompilerUnavailable", "cache_dir", "compiler"]


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
