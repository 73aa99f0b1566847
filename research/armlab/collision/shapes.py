"""Shapes of the environment and of the payload: what a study's ``[[obstacle]]`` tables and
``[payload]`` shape keys hold, checked when the study is read, and made coal shapes when the
scene is built.

One shape is given by exactly one of these keys (lengths in [m]; coal's conventions):

* ``box_m = [x, y, z]``: the full side lengths of a box centred on its pose (``coal.Box``);
* ``sphere_m = r``: the radius of a sphere (``coal.Sphere``);
* ``cylinder_m = [r, length]``: a cylinder along its pose's z axis, centred (``coal.Cylinder``);
* ``capsule_m = [r, length]``: a capsule (cylinder of ``length`` with hemispherical ends) along z
  (``coal.Capsule``);
* ``mesh = "fixture.stl"``: a triangle mesh file (STL, OBJ, DAE: coal's mesh loader, assimp),
  relative to the study file, in metres unless ``mesh_scale`` (3 factors) says otherwise.

and its pose by ``xyz_m`` (the shape's centre) and ``rpy_deg`` (roll, pitch, yaw: ``R = Rz(yaw)
Ry(pitch) Rx(roll)``, as ``[robot] base_rpy_deg``). An obstacle's pose is in the world frame;
the payload's (``[payload] shape_xyz_m``, ``shape_rpy_deg``) in the tool frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from armlab.errors import InputError, SpecError
from armlab.kinematics.forward import rpy_to_matrix
from armlab.names import check_name

__all__ = ["SHAPE_KEYS", "Shape", "shape_from_table"]

#: The keys of which a shape table holds exactly one.
SHAPE_KEYS = ("box_m", "sphere_m", "cylinder_m", "capsule_m", "mesh")


@dataclass(frozen=True)
class Shape:
    """A named rigid shape with its pose in its parent frame (world or tool).

    Attributes
    ----------
    name : str
        Name (the identifier policy of :mod:`armlab.names`: it reaches messages and files).
    kind : str
        ``"box"``, ``"sphere"``, ``"cylinder"``, ``"capsule"`` or ``"mesh"``.
    size_m : tuple of float
        Box: full sides (x, y, z); sphere: (r,); cylinder, capsule: (r, length), in [m].
    xyz_m : tuple of float
        Centre in the parent frame in [m].
    rpy_deg : tuple of float
        Roll, pitch, yaw in [deg] (``R = Rz(yaw) Ry(pitch) Rx(roll)``).
    mesh_path : str
        The mesh file (absolute), ``""`` for a primitive.
    mesh_scale : tuple of float
        Scale factors of the mesh's coordinates (to metres).
    """

    name: str
    kind: str
    size_m: tuple[float, ...] = ()
    xyz_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mesh_path: str = ""
    mesh_scale: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def transform(self) -> np.ndarray:
        """The pose (4, 4) of the shape's centre in its parent frame."""
        T = np.eye(4)
        T[:3, :3] = rpy_to_matrix(*np.radians(self.rpy_deg))
        T[:3, 3] = self.xyz_m
        return T

    def coal_geometry(self) -> Any:
        """The coal collision geometry (``coal.Box``, ``Sphere``, ``Cylinder``, ``Capsule`` or a
        ``BVHModel`` of the mesh).

        Raises
        ------
        InputError
            A mesh file that cannot be read (one line naming the shape and the file).
        """
        import coal

        s = self.size_m
        if self.kind == "box":
            return coal.Box(*s)
        if self.kind == "sphere":
            return coal.Sphere(s[0])
        if self.kind == "cylinder":
            return coal.Cylinder(s[0], s[1])
        if self.kind == "capsule":
            return coal.Capsule(s[0], s[1])
        try:
            return coal.MeshLoader().load(self.mesh_path, np.asarray(self.mesh_scale, float))
        except Exception as exc:  # coal/assimp: RuntimeError or ValueError with its message
            first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise InputError(
                f"{self.name}: cannot read the mesh {self.mesh_path} ({first})"
            ) from None

    def bounding_radius_m(self) -> float:
        """Radius of a sphere about the shape's centre holding it, in [m] (a mesh: its vertices'
        farthest distance from the origin of its file, scaled)."""
        s = self.size_m
        if self.kind == "box":
            return 0.5 * math.sqrt(s[0] ** 2 + s[1] ** 2 + s[2] ** 2)
        if self.kind == "sphere":
            return s[0]
        if self.kind == "cylinder":
            return math.hypot(s[0], 0.5 * s[1])
        if self.kind == "capsule":
            return s[0] + 0.5 * s[1]
        geom = self.coal_geometry()
        geom.computeLocalAABB()
        return float(geom.aabb_radius + np.linalg.norm(geom.aabb_center))


def _positive(v, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise SpecError(f"{where}: expected a finite number > 0, not {v!r}")
    return float(v)


def _vector(v, n: int, where: str, *, positive: bool = False) -> tuple[float, ...]:
    if not isinstance(v, list) or len(v) != n:
        raise SpecError(f"{where}: expected a list of {n} numbers, not {v!r}")
    out = []
    for i, x in enumerate(v):
        if positive:
            out.append(_positive(x, f"{where}[{i}]"))
        elif isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
            raise SpecError(f"{where}[{i}]: expected a finite number, not {x!r}")
        else:
            out.append(float(x))
    return tuple(out)


def shape_from_table(
    table: dict[str, Any],
    name: str,
    where: str,
    base_dir: str | Path = ".",
    *,
    pose_keys: tuple[str, str] = ("xyz_m", "rpy_deg"),
) -> Shape:
    """The :class:`Shape` a study table describes (module docstring), checked.

    Parameters
    ----------
    table : dict
        The table's shape keys (one of :data:`SHAPE_KEYS`, ``mesh_scale``) and pose keys; other
        keys are the caller's business.
    name : str
        The shape's name (checked against the name policy by the caller or here).
    where : str
        The dotted table (``obstacle[2]``), the head of every message.
    base_dir : path
        The folder a relative ``mesh`` path is relative to (the study file's).
    pose_keys : (str, str)
        The names of the position and angle keys (``("shape_xyz_m", "shape_rpy_deg")`` for
        the payload).

    Raises
    ------
    SpecError
        One line naming the key: no shape key or two, a size that is not a positive finite
        number, a pose that is not 3 finite numbers, a mesh file that does not exist.
    """
    check_name(name, "shape name", f"{where}.name", SpecError)
    given = [k for k in SHAPE_KEYS if k in table]
    if len(given) != 1:
        what = "none" if not given else " and ".join(given)
        raise SpecError(f"{where}: give exactly one of {', '.join(SHAPE_KEYS)} (got {what})")
    key = given[0]
    value = table[key]
    size: tuple[float, ...] = ()
    mesh_path = ""
    if key == "box_m":
        kind, size = "box", _vector(value, 3, f"{where}.box_m", positive=True)
    elif key == "sphere_m":
        kind, size = "sphere", (_positive(value, f"{where}.sphere_m"),)
    elif key in ("cylinder_m", "capsule_m"):
        kind, size = key[:-2], _vector(value, 2, f"{where}.{key}", positive=True)
    else:
        kind = "mesh"
        if not isinstance(value, str) or not value:
            raise SpecError(f"{where}.mesh: expected a file name, not {value!r}")
        path = Path(value) if Path(value).is_absolute() else Path(base_dir) / value
        if not path.is_file():
            raise SpecError(f"{where}.mesh: no such file {str(path)!r}")
        mesh_path = str(path.resolve())
    scale: tuple[float, ...] = (1.0, 1.0, 1.0)
    if "mesh_scale" in table:
        if kind != "mesh":
            raise SpecError(f"{where}.mesh_scale: only a mesh has a scale")
        scale = _vector(table["mesh_scale"], 3, f"{where}.mesh_scale", positive=True)
    xyz_key, rpy_key = pose_keys
    xyz = _vector(table.get(xyz_key, [0, 0, 0]), 3, f"{where}.{xyz_key}")
    rpy = _vector(table.get(rpy_key, [0, 0, 0]), 3, f"{where}.{rpy_key}")
    return Shape(
        name=name,
        kind=kind,
        size_m=size,
        xyz_m=(xyz[0], xyz[1], xyz[2]),
        rpy_deg=(rpy[0], rpy[1], rpy[2]),
        mesh_path=mesh_path,
        mesh_scale=(scale[0], scale[1], scale[2]),
    )
