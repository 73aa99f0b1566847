"""Checksums shared by every exporter.

Every file armlab.deploy writes carries the sha256 of its source (trajectory or gains) and
armlab's version, and is written atomically with :func:`armlab.io.atomic_write`: a reader
never sees a partial file, and a failed export leaves nothing behind.
"""

from __future__ import annotations

import hashlib
import json
import os

import numpy as np

__all__ = [
    "armlab_version",
    "trajectory_sha256",
    "gains_sha256",
    "file_sha256",
]


def armlab_version() -> str:
    """``armlab.__version__``."""
    import armlab

    return armlab.__version__


def trajectory_sha256(trajectory) -> str:
    """Content checksum of a :class:`~armlab.trajectory.Trajectory`.

    sha256 over a small text header (format tag, joint names, shape) and the float64
    little-endian C-order bytes of ``t, q, qd, qdd`` (and ``qddd`` when present). Independent of
    how the trajectory was stored: :func:`armlab.deploy.load_trajectory` gives back the same value.
    """
    h = hashlib.sha256()
    head = {
        "format": "armlab.trajectory/1",
        "joint_names": list(trajectory.joint_names),
        "n_samples": int(trajectory.n_samples),
        "qddd": trajectory.qddd is not None,
    }
    h.update(json.dumps(head, sort_keys=True).encode())
    arrays = [trajectory.t, trajectory.q, trajectory.qd, trajectory.qdd]
    if trajectory.qddd is not None:
        arrays.append(trajectory.qddd)
    for a in arrays:
        h.update(np.ascontiguousarray(a, dtype="<f8").tobytes())
    return h.hexdigest()


def gains_sha256(gains) -> str:
    """Content checksum of gains: sha256 of the canonical JSON (sorted keys, no spaces) of
    ``gains.to_dict()`` (an :class:`armlab.control.ArmGains` or anything with ``to_dict``)."""
    d = gains.to_dict() if hasattr(gains, "to_dict") else gains
    text = json.dumps(d, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def file_sha256(path: str | os.PathLike) -> str:
    """sha256 of a file's bytes (what ``sha256sum`` prints)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
