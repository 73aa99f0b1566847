"""File output shared by every writer in armlab: atomic writes and strict JSON.

Every file armlab writes (study outputs, sweep tables, exports, plots) goes through
:func:`atomic_open` / :func:`atomic_write`: a reader never sees a partial file, a failed write
leaves the previous file untouched and no temporary file behind, and the result has the usual
``0o666 & ~umask`` permissions (0644 under the common umask 022).
"""

from armlab.io.atomic import atomic_open, atomic_write, atomic_write_many, write_json

__all__ = [
    "atomic_open",
    "atomic_write",
    "atomic_write_many",
    "write_json",
]
