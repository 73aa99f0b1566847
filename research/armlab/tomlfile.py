"""Reading armlab's TOML files (robot descriptions, catalogues, profiles, studies, sweeps)."""

from __future__ import annotations

import tomllib
from pathlib import Path

from armlab.errors import ArmlabError, RobotDescriptionError

__all__ = ["read_toml"]


def read_toml(
    path: str | Path, what: str, error: type[ArmlabError] = RobotDescriptionError, prefix: str = ""
) -> dict:
    """The parsed TOML document at ``path``.

    Raises ``error`` with a one-line message ``"<prefix><path>: <what> not found"``, ``"... cannot
    read (...)"`` or ``"... not valid TOML (...)"`` instead of an OS or parser traceback.
    """
    path = Path(path)
    where = f"{prefix}{path}"
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise error(f"{where}: {what} not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{where}: cannot read {what} ({exc})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{where}: not valid TOML ({exc})") from None
