"""Collision checking: self-collision, the floor, the obstacles of a study and the payload.

Public API (stable: other parts of armlab build on it)
------------------------------------------------------
=========================================  ===================================================
:class:`CollisionScene`                    the robot's collision geometry + payload shape +
                                           floor + obstacles, with the pairs to check
``CollisionScene.from_study(spec, robot)`` the scene a study describes (``[[obstacle]]``,
                                           ``[robot] floor_z_m``, ``[robot] collision_pairs``,
                                           the ``[payload]`` shape, ``[plan] clearance_m``)
``CollisionScene.from_robot(robot,         the same from Python objects
obstacles, floor_z_m=, payload=,
pairs_file=, clearance_m=)``
``scene.distances(q) -> Distances``        per checked pair: signed distance [m] (negative:
                                           penetration), witness points and normal in the
                                           world frame, geometry and link names
``scene.distance_values(q)``               the signed distances only (n_pairs,), the fast path
``scene.distance_jacobian(q)``             distances and their gradients d(d)/dq
                                           (n_pairs, n_joints): for a clearance constraint
``scene.min_clearance(q)``                 the smallest signed distance [m]
``scene.n_pairs``, ``scene.pair_names()``  the checked pairs (geometry names)
``scene.clearance_m``, ``scene.source``    the study's clearance; ``"collision"`` or
                                           ``"visual"`` (which URDF elements the shapes are)
:func:`check_motion`                       ``check_motion(scene, trajectory, clearance_m=None)
                                           -> ClearanceReport``: certified minimum clearance
                                           of a whole motion, per pair and its time
:class:`ClearanceReport`                   ``ok``, ``min_distance_m``, ``time_s``, ``pair``,
                                           ``pairs`` (:class:`PairClearance` per pair, closest
                                           first), ``depth_m``, ``message()``,
                                           ``raise_if_failed()``, ``to_dict()``
:class:`CollisionError`                    a :class:`~armlab.errors.LimitViolation`: a plan or
                                           a waypoint collides or comes too close
:class:`Shape`, :func:`shape_from_table`   obstacle and payload shapes (box, sphere, cylinder,
                                           capsule, mesh) and their study keys
:func:`robot_geometry`                     the URDF's ``<collision>`` (else ``<visual>``) shapes
:func:`collision_summary`                  one line for ``armlab info``
:func:`disabled_pairs`, :func:`analyse_pairs`,  the sampled analysis of pairs that never need
:func:`read_pairs`, :func:`write_pairs`    a check (adjacent, always, never in contact),
                                           cached per URDF sha256 as an editable TOML
=========================================  ===================================================

Modules: :mod:`.shapes` (shapes and their keys), :mod:`.geometry` (the robot's shapes from its
URDF), :mod:`.pairs` (the disabled-pair analysis and its file), :mod:`.scene` (the scene and
distances at a configuration), :mod:`.motion` (the certified check of a whole motion).

Units: metres, radians, seconds; the world frame is the study's (the base mounted by
``[robot] base_xyz_m``/``base_rpy_deg``). Pinocchio names a URDF link's k-th collision element
``<link>_<k>``.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "ClearanceReport",
    "CollisionError",
    "CollisionScene",
    "DisabledPairs",
    "Distances",
    "PairClearance",
    "RobotGeometry",
    "Shape",
    "analyse_pairs",
    "check_motion",
    "collision_summary",
    "disabled_pairs",
    "read_pairs",
    "robot_geometry",
    "shape_from_table",
    "write_pairs",
]

_HOME = {
    "ClearanceReport": "motion",
    "PairClearance": "motion",
    "check_motion": "motion",
    "CollisionError": "scene",
    "CollisionScene": "scene",
    "Distances": "scene",
    "collision_summary": "scene",
    "DisabledPairs": "pairs",
    "analyse_pairs": "pairs",
    "disabled_pairs": "pairs",
    "read_pairs": "pairs",
    "write_pairs": "pairs",
    "RobotGeometry": "geometry",
    "robot_geometry": "geometry",
    "Shape": "shapes",
    "shape_from_table": "shapes",
}


def __getattr__(name: str) -> Any:
    """The public names, imported on first use (the study file reader needs only
    :mod:`.shapes`, which imports neither Pinocchio nor coal)."""
    if name in _HOME:
        value = getattr(importlib.import_module(f"armlab.collision.{_HOME[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'armlab.collision' has no attribute {name!r}")
