"""The environment in the 3D view: obstacles, the floor and the closest pair of a motion.

The drawing takes **plain descriptions**, not the collision package's objects, so the view does
not depend on how distances are computed:

* :class:`ObstacleShape` -- one obstacle: a name, a kind (``"box"``, ``"sphere"``,
  ``"cylinder"``, ``"capsule"``, ``"mesh"``), its size and its pose in the world.
  :func:`obstacle_shape` reads one from a study's ``[[obstacle]]`` table (``box_m = [x, y, z]``
  full edge lengths, ``sphere_m = r``, ``cylinder_m = [r, length]`` along the local z axis,
  ``capsule_m`` the same with hemispherical ends, or ``mesh = "file"`` with ``mesh_scale``;
  ``xyz_m`` the centre and ``rpy_deg`` roll-pitch-yaw in the world frame, the URDF convention
  ``R = Rz(yaw) Ry(pitch) Rx(roll)``), from a mapping of the same keys, any object with those
  attributes, or a shape object with ``kind``, ``size_m``, ``transform()`` (or ``xyz_m``,
  ``rpy_deg``) and ``mesh_path`` (the collision package's).
* :class:`ClosestPair` -- the two witness points (world frame, [m]) of the pair that came
  closest, its signed distance [m] and the time [s] of that instant.

:func:`draw_environment` puts them in a meshcat scene under ``/meshcat/environment``: each
obstacle at its pose (translucent orange), the floor as a thin translucent slab whose top face
is the plane ``z = floor_z_m``, and the closest pair as a red line between its witness points
with a small sphere on each (``/meshcat/closest_pair``); it returns the entries for the scene's
JSON manifest (``obstacles``, ``floor_z_m``, ``closest_pair``), so a reader of the HTML file
finds what is drawn without decoding the meshcat commands.

meshcat's cylinder is along its y axis (three.js), coal's and the URDF's along z: the drawn pose
is the obstacle's pose times a +90 deg rotation about x.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from armlab.errors import InputError

__all__ = [
    "ClosestPair",
    "ObstacleShape",
    "SHAPE_KEYS",
    "draw_environment",
    "obstacle_shape",
    "pose_matrix",
]

#: the study keys of an obstacle's shape, one per kind
SHAPE_KEYS = {
    "box_m": "box",
    "sphere_m": "sphere",
    "cylinder_m": "cylinder",
    "capsule_m": "capsule",
    "mesh": "mesh",
}
_SIZES = {"box": 3, "sphere": 1, "cylinder": 2, "capsule": 2, "mesh": 0}

_OBSTACLE_RGBA = (0.95, 0.55, 0.15, 0.55)
_FLOOR_RGBA = (0.55, 0.55, 0.55, 0.35)
_MARKER_RGB = 0xE01010
_FLOOR_THICKNESS_M = 0.01


def pose_matrix(xyz_m=(0.0, 0.0, 0.0), rpy_deg=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The 4x4 pose of a centre ``xyz_m`` [m] with roll-pitch-yaw ``rpy_deg`` [deg],
    ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (the URDF ``rpy`` convention)."""
    r, p, y = (math.radians(float(a)) for a in rpy_deg)
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    T = np.eye(4)
    T[:3, :3] = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    T[:3, 3] = [float(v) for v in xyz_m]
    return T


@dataclass(frozen=True)
class ObstacleShape:
    """One obstacle as drawn.

    Attributes
    ----------
    name : str
    kind : str
        ``"box"``, ``"sphere"``, ``"cylinder"`` or ``"mesh"``.
    size_m : tuple of float
        Box: full edge lengths (x, y, z); sphere: (radius,); cylinder: (radius, length along
        the local z axis); mesh: ().
    pose : ndarray (4, 4)
        Centre and orientation in the world frame.
    mesh : str
        The mesh file (kind ``"mesh"``), else "".
    mesh_scale : tuple of float
        Scale of the mesh's coordinates to [m] (default 1).
    """

    name: str
    kind: str
    size_m: tuple[float, ...]
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))
    mesh: str = ""
    mesh_scale: tuple[float, float, float] = (1.0, 1.0, 1.0)


@dataclass(frozen=True)
class ClosestPair:
    """The pair that came closest along a motion, as drawn.

    Attributes
    ----------
    a, b : str
        The two geometries' names (a link's collision body, an obstacle, ``floor``).
    distance_m : float
        Their signed distance [m] (negative: penetration depth).
    point_a_m, point_b_m : ndarray (3,)
        The witness points on ``a`` and ``b`` in the world frame [m].
    time_s : float
        The plan time [s] of that instant (nan: a single pose).
    """

    a: str
    b: str
    distance_m: float
    point_a_m: np.ndarray
    point_b_m: np.ndarray
    time_s: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        return {
            "a": self.a,
            "b": self.b,
            "distance_m": float(self.distance_m),
            "point_a_m": [float(v) for v in self.point_a_m],
            "point_b_m": [float(v) for v in self.point_b_m],
            "time_s": None if not math.isfinite(self.time_s) else float(self.time_s),
        }


def _get(src, key: str, default=None):
    if isinstance(src, Mapping):
        return src.get(key, default)
    return getattr(src, key, default)


def obstacle_shape(src, index: int = 0) -> ObstacleShape:
    """An :class:`ObstacleShape` from a study ``[[obstacle]]`` table (a mapping) or an object
    with the same attributes (module docstring); an ``ObstacleShape`` is returned as is.

    Raises
    ------
    InputError
        No shape key or more than one, a size of the wrong length or not positive.
    """
    if isinstance(src, ObstacleShape):
        return src
    name = str(_get(src, "name", "") or f"obstacle{index}")
    where = f"obstacle {name!r}"
    kind = _get(src, "kind")
    if kind in _SIZES and not isinstance(src, Mapping):  # a shape object (kind, size_m, pose)
        pose = _get(src, "transform")
        pose = pose() if callable(pose) else _get(src, "pose")
        if pose is None:
            pose = pose_matrix(_get(src, "xyz_m", (0, 0, 0)), _get(src, "rpy_deg", (0, 0, 0)))
        scale = np.broadcast_to(np.asarray(_get(src, "mesh_scale", 1.0), float), (3,))
        return ObstacleShape(
            name,
            str(kind),
            tuple(float(v) for v in _get(src, "size_m", ())),
            np.asarray(pose, float),
            str(_get(src, "mesh_path", "") or _get(src, "mesh", "") or ""),
            (float(scale[0]), float(scale[1]), float(scale[2])),
        )
    given = [k for k in SHAPE_KEYS if _get(src, k) not in (None, "", ())]
    if len(given) != 1:
        raise InputError(
            f"{where}: give exactly one of {', '.join(SHAPE_KEYS)} (found {given or 'none'})"
        )
    key = given[0]
    kind = SHAPE_KEYS[key]
    value = _get(src, key)
    mesh, size = "", tuple[float, ...]()
    if kind == "mesh":
        mesh = str(value)
    else:
        try:
            size = tuple(float(v) for v in np.atleast_1d(np.asarray(value, dtype=float)))
        except (TypeError, ValueError):
            raise InputError(f"{where}: {key} must be numbers in [m], not {value!r}") from None
        if len(size) != _SIZES[kind] or not all(math.isfinite(s) and s > 0 for s in size):
            raise InputError(
                f"{where}: {key} needs {_SIZES[kind]} positive length(s) in [m], not {value!r}"
            )
    pose = _get(src, "pose")
    if pose is None:
        pose = pose_matrix(_get(src, "xyz_m", (0, 0, 0)), _get(src, "rpy_deg", (0, 0, 0)))
    pose = np.asarray(getattr(pose, "homogeneous", pose), dtype=float)
    sx, sy, sz = np.broadcast_to(np.asarray(_get(src, "mesh_scale", 1.0), float), (3,))
    return ObstacleShape(name, kind, size, pose, mesh, (float(sx), float(sy), float(sz)))


def _material(rgba, meshcat_g):
    color = int(rgba[0] * 255) << 16 | int(rgba[1] * 255) << 8 | int(rgba[2] * 255)
    return meshcat_g.MeshLambertMaterial(color=color, opacity=rgba[3], transparent=rgba[3] < 1)


def _geometry(shape: ObstacleShape, meshcat_g):
    """The meshcat geometry of a shape and the pose correction of its axis convention."""
    fix = np.eye(4)
    if shape.kind == "box":
        return meshcat_g.Box(list(shape.size_m)), fix
    if shape.kind == "sphere":
        return meshcat_g.Sphere(shape.size_m[0]), fix
    if shape.kind in ("cylinder", "capsule"):  # a capsule drawn as its cylinder (+ end caps)
        fix[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # +90 deg about x: y -> z
        return meshcat_g.Cylinder(shape.size_m[1], shape.size_m[0]), fix
    path = Path(shape.mesh)
    loaders = {
        ".stl": meshcat_g.StlMeshGeometry,
        ".obj": meshcat_g.ObjMeshGeometry,
        ".dae": meshcat_g.DaeMeshGeometry,
    }
    loader = loaders.get(path.suffix.lower())
    if loader is None or not path.is_file():
        raise InputError(
            f"obstacle {shape.name!r}: mesh {shape.mesh!r} is not a readable .stl/.obj/.dae file"
        )
    fix[:3, :3] = np.diag(shape.mesh_scale)
    return loader.from_file(os.fspath(path)), fix


def draw_environment(
    viewer,
    obstacles: Iterable = (),
    *,
    floor_z_m: float | None = None,
    closest: ClosestPair | None = None,
    extent_m: float = 1.0,
) -> dict[str, Any]:
    """Draw obstacles, the floor and the closest pair in a meshcat ``viewer``.

    Parameters
    ----------
    viewer : meshcat.Visualizer
    obstacles : iterable
        Obstacle descriptions (:func:`obstacle_shape` reads each).
    floor_z_m : float, optional
        Height [m] of the floor plane in the world frame; None: no floor.
    closest : ClosestPair, optional
        The pair to mark.
    extent_m : float
        Half the floor's edge length [m] (the arm's reach, say).

    Returns
    -------
    dict
        The manifest entries: ``obstacles`` (name, kind, size_m, xyz_m, path each),
        ``floor_z_m`` and ``closest_pair`` (:meth:`ClosestPair.to_dict`, or None).
    """
    import meshcat.geometry as g

    shapes = [obstacle_shape(o, k) for k, o in enumerate(obstacles)]
    drawn = []
    for shape in shapes:
        geom, fix = _geometry(shape, g)
        path = f"environment/{_node(shape.name)}"
        viewer[path].set_object(geom, _material(_OBSTACLE_RGBA, g))
        viewer[path].set_transform(shape.pose @ fix)
        if shape.kind == "capsule":  # the hemispherical ends as spheres
            r, length = shape.size_m
            for end, sign in (("cap_a", 1.0), ("cap_b", -1.0)):
                viewer[f"{path}_{end}"].set_object(g.Sphere(r), _material(_OBSTACLE_RGBA, g))
                viewer[f"{path}_{end}"].set_transform(
                    shape.pose @ pose_matrix((0.0, 0.0, sign * length / 2))
                )
        drawn.append(
            {
                "name": shape.name,
                "kind": shape.kind,
                "size_m": list(shape.size_m),
                "xyz_m": [float(v) for v in shape.pose[:3, 3]],
                "path": f"/meshcat/{path}",
            }
        )
    floor = None
    if floor_z_m is not None and math.isfinite(float(floor_z_m)):
        floor = float(floor_z_m)
        side = 2.0 * float(extent_m)
        viewer["environment/floor"].set_object(
            g.Box([side, side, _FLOOR_THICKNESS_M]), _material(_FLOOR_RGBA, g)
        )
        viewer["environment/floor"].set_transform(
            pose_matrix((0.0, 0.0, floor - _FLOOR_THICKNESS_M / 2))
        )
    marker = None
    if closest is not None:
        marker = closest.to_dict()
        pa, pb = (np.asarray(p, float).reshape(3) for p in (closest.point_a_m, closest.point_b_m))
        line = g.PointsGeometry(np.column_stack([pa, pb]).astype(np.float32))
        viewer["closest_pair/line"].set_object(
            g.Line(line, g.LineBasicMaterial(color=_MARKER_RGB, linewidth=3))
        )
        r = max(0.004, 0.01 * float(extent_m))
        for tag, p in (("a", pa), ("b", pb)):
            viewer[f"closest_pair/{tag}"].set_object(
                g.Sphere(r), g.MeshLambertMaterial(color=_MARKER_RGB)
            )
            viewer[f"closest_pair/{tag}"].set_transform(pose_matrix(p))
        marker["path"] = "/meshcat/closest_pair"
    return {"obstacles": drawn, "floor_z_m": floor, "closest_pair": marker}


def _node(name: str) -> str:
    """A scene-tree name for an obstacle (no slashes)."""
    return "".join(c if c.isalnum() or c in "_.-" else "_" for c in name) or "obstacle"
