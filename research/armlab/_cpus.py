"""How many CPUs this process may use: the default worker count of a sweep's local cluster."""

from __future__ import annotations

import os

__all__ = ["usable_cpus"]


def usable_cpus() -> int:
    """The CPUs this process may run on (its affinity mask, which a container or ``taskset``
    narrows; ``os.cpu_count()`` where the platform has none)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1
