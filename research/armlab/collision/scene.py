"""The :class:`CollisionScene`: a robot's collision geometry, its payload shape, the floor and
the obstacles of a study, with the pairs to check; signed distances at a configuration.

Frames: the robot's geometry lives in its base frame (Pinocchio's); obstacles and the floor are
given in the world and placed in the base frame through ``robot.transform_base_to_world``, so
distances are those of the world. Witness points are returned in the world frame.

Pairs checked:

* robot-robot: the link pairs on different bodies that :mod:`armlab.collision.pairs` does not
  disable;
* robot-environment: every geometry moved by a joint (the payload included) against every
  obstacle and the floor. Geometry fixed to the base (joint 0: a base plate) is not checked
  against the environment: neither moves, the distance is a fact of the setup (the arm stands on
  its table) and no plan changes it;
* payload: attached to the tool frame's body; checked against the environment and against the
  links the disabled pairs do not exclude for the tool's link (adjacent ones are skipped, as for
  the link itself).

The floor ``[robot] floor_z_m`` is the plane ``z = floor_z_m`` of the world, below which
everything is solid: a box 100 m x 100 m x 10 m whose top face is that plane (a half-space
would do, but coal computes no distance between a half-space and a mesh).

Signed distance: coal's ``distance``: the gap between two separated shapes, minus the
penetration depth of two overlapping convex shapes (negative) (coal, GJK/EPA: Montaut et al.,
"Collision detection accelerated", RSS 2022).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from armlab.collision.geometry import RobotGeometry, robot_geometry
from armlab.collision.pairs import DisabledPairs, disabled_pairs
from armlab.collision.shapes import Shape
from armlab.errors import InputError, LimitViolation

if TYPE_CHECKING:
    from armlab.robot.model import Robot
    from armlab.study.spec import StudySpec

__all__ = ["CollisionError", "CollisionScene", "Distances", "FLOOR_NAME", "collision_summary"]

#: The name of the floor in pair names and messages.
FLOOR_NAME = "floor"
_FLOOR_SIZE_M = (100.0, 100.0, 10.0)


class CollisionError(LimitViolation):
    """A plan or a configuration collides, or comes closer than the required clearance; the
    message names the pair, the time and the depth."""


@dataclass(frozen=True)
class Distances:
    """Signed distances of a scene's checked pairs at one configuration.

    Attributes
    ----------
    pairs : tuple of (str, str)
        The pairs, as geometry names (``link2_0``, ``table``, ``payload``, ``floor``).
    links : tuple of (str, str)
        Each pair's link names (an obstacle's own name; ``payload``; ``floor``).
    distance_m : ndarray (n_pairs,)
        Signed distance in [m] (negative: penetration depth).
    point_a_m, point_b_m : ndarray (n_pairs, 3)
        Witness points on the first and second shape, in the world frame, [m].
    normal : ndarray (n_pairs, 3)
        Unit vector from the first shape towards the second, in the world frame.
    """

    pairs: tuple[tuple[str, str], ...]
    links: tuple[tuple[str, str], ...]
    distance_m: np.ndarray
    point_a_m: np.ndarray
    point_b_m: np.ndarray
    normal: np.ndarray

    def closest(self) -> int:
        """Index of the pair with the smallest signed distance (-1 for no pairs)."""
        return int(np.argmin(self.distance_m)) if len(self.distance_m) else -1

    def pair_name(self, k: int) -> str:
        """``"link2_0 (link2) and table"``: the pair ``k`` for a message."""
        (a, b), (la, lb) = self.pairs[k], self.links[k]
        sa = a if a == la else f"{a} ({la})"
        sb = b if b == lb else f"{b} ({lb})"
        return f"{sa} and {sb}"


@dataclass
class CollisionScene:
    """Robot geometry + payload + floor + obstacles and the pairs to check (module docstring).

    Build one with :meth:`from_robot` or :meth:`from_study`. Attributes
    ----------------------------------------------------------------------
    robot : Robot
    geometry : pinocchio.GeometryModel
        Every object (robot, payload, floor, obstacles) with ``collisionPairs`` the checked pairs.
    source : str
        Where the robot's shapes come from: ``"collision"`` or ``"visual"`` (URDF elements).
    disabled : DisabledPairs
    obstacles : tuple of Shape
    floor_z_m : float or None
    payload : Shape or None
    clearance_m : float
        The clearance the pairs were chosen for (re-enables ``never`` pairs within it).
    link_of : dict of str to str
        Each geometry's link (obstacles, floor, payload: their own name).
    """

    robot: Robot
    geometry: pin.GeometryModel
    source: str
    disabled: DisabledPairs
    obstacles: tuple[Shape, ...] = ()
    floor_z_m: float | None = None
    payload: Shape | None = None
    clearance_m: float = 0.0
    link_of: dict[str, str] = field(default_factory=dict)
    _data: Any = None
    _gdata: Any = None
    _results: list[Any] = field(default_factory=list)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_robot(
        cls,
        robot: Robot,
        obstacles: tuple[Shape, ...] | list[Shape] = (),
        *,
        floor_z_m: float | None = None,
        payload: Shape | None = None,
        pairs_file: str | None = None,
        clearance_m: float = 0.0,
        geometry: RobotGeometry | None = None,
    ) -> CollisionScene:
        """A scene of ``robot`` among ``obstacles`` (poses in the world).

        Parameters
        ----------
        robot : Robot
        obstacles : sequence of Shape
            Obstacles, poses in the world frame.
        floor_z_m : float, optional
            Height of the floor in the world, [m]; None: no floor.
        payload : Shape, optional
            The payload/tool shape, pose in the tool frame.
        pairs_file : str, optional
            A disabled-pairs TOML to use instead of the description's or cached analysis.
        clearance_m : float
            The clearance the check will ask for, [m] (re-enables near ``never`` pairs).
        geometry : RobotGeometry, optional
            The robot's geometry if already built (:func:`robot_geometry`).

        Raises
        ------
        InputError
            Two shapes with the same name, or a name that is one of the robot's geometries.
        """
        geom = robot_geometry(robot) if geometry is None else geometry
        disabled = disabled_pairs(robot, geom, pairs_file)
        gm = geom.geometry.copy()
        link_of = dict(geom.link_of)
        T_world_in_base = np.linalg.inv(np.asarray(robot.transform_base_to_world, float))
        names = set(link_of)
        env: list[int] = []

        def add(name: str, parent_joint: int, parent_frame: int, T: np.ndarray, shape) -> int:
            if name in names:
                raise InputError(f"collision shape name {name!r} twice (a shape or a link's)")
            names.add(name)
            link_of[name] = name
            obj = pin.GeometryObject(
                name, parent_joint, parent_frame, pin.SE3(T[:3, :3], T[:3, 3]), shape
            )
            return int(gm.addGeometryObject(obj))

        root_frame = 0
        for s in obstacles:
            env.append(
                add(s.name, 0, root_frame, T_world_in_base @ s.transform(), s.coal_geometry())
            )
        if floor_z_m is not None:
            import coal

            T = np.eye(4)
            T[2, 3] = float(floor_z_m) - 0.5 * _FLOOR_SIZE_M[2]
            env.append(
                add(FLOOR_NAME, 0, root_frame, T_world_in_base @ T, coal.Box(*_FLOOR_SIZE_M))
            )
        payload_id = -1
        if payload is not None:
            fid = robot.tool_frame_id
            frame = robot.model.frames[fid]
            T_tool = frame.placement.homogeneous @ payload.transform()
            payload_id = add(payload.name, frame.parentJoint, fid, T_tool, payload.coal_geometry())
        scene = cls(
            robot,
            gm,
            geom.source,
            disabled,
            tuple(obstacles),
            floor_z_m,
            payload,
            float(clearance_m),
            link_of,
        )
        scene._add_pairs(env, payload_id)
        return scene

    @classmethod
    def from_study(cls, spec: StudySpec, robot: Robot) -> CollisionScene:
        """The scene a study describes: ``[[obstacle]]``, ``[robot] floor_z_m``,
        ``[robot] collision_pairs``, the ``[payload]`` shape and ``[plan] clearance_m``."""
        pairs = spec.robot.collision_pairs
        return cls.from_robot(
            robot,
            spec.obstacles,
            floor_z_m=spec.robot.floor_z_m,
            payload=spec.payload_shape,
            pairs_file=None if pairs is None else spec.resolve(pairs),
            clearance_m=spec.plan.clearance_m,
        )

    def _add_pairs(self, env: list[int], payload_id: int) -> None:
        gm = self.geometry
        objs = gm.geometryObjects
        model = self.robot.model
        tool_link = model.frames[self.robot.tool_frame_id].name
        env_set = set(env)
        for i in range(len(objs)):
            for j in range(i + 1, len(objs)):
                if i in env_set and j in env_set:
                    continue
                if i in env_set or j in env_set:
                    other = j if i in env_set else i
                    if objs[other].parentJoint == 0:
                        continue  # fixed to the base: a fact of the setup
                    gm.addCollisionPair(pin.CollisionPair(i, j))
                    continue
                a, b = objs[i], objs[j]
                if a.parentJoint == b.parentJoint:
                    continue  # one rigid body
                la = tool_link if i == payload_id else self.link_of[a.name]
                lb = tool_link if j == payload_id else self.link_of[b.name]
                if self.disabled.skipped(la, lb, self.clearance_m):
                    continue
                gm.addCollisionPair(pin.CollisionPair(i, j))
        self._data = self.robot.model.createData()
        self._gdata = pin.GeometryData(gm)
        # references to the results, made once: the vector is never resized, and a fresh
        # Python wrapper per result and call costs 4x the reads (1.6 us each)
        self._results = list(self._gdata.distanceResults)

    # ------------------------------------------------------------------ queries
    @property
    def n_pairs(self) -> int:
        return len(self.geometry.collisionPairs)

    def pair_names(self) -> list[tuple[str, str]]:
        """The checked pairs as geometry names."""
        objs = self.geometry.geometryObjects
        return [(objs[p.first].name, objs[p.second].name) for p in self.geometry.collisionPairs]

    def _update(self, q) -> None:
        q = self.robot.check_q(q)
        pin.framesForwardKinematics(self.robot.model, self._data, q)
        pin.updateGeometryPlacements(self.robot.model, self._data, self.geometry, self._gdata)

    def distance_values(self, q) -> np.ndarray:
        """Signed distance of every checked pair at ``q`` (n_pairs,), [m] (the fast path of
        :meth:`distances`: no witness points copied)."""
        self._update(q)
        pin.computeDistances(self.geometry, self._gdata)
        return np.fromiter((r.min_distance for r in self._results), float, len(self._results))

    def distances(self, q) -> Distances:
        """Signed distances, witness points (world frame) and names of every checked pair."""
        d = self.distance_values(q)
        n = self.n_pairs
        pa, pb, nrm = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        T = np.asarray(self.robot.transform_base_to_world, float)
        R, p = T[:3, :3], T[:3, 3]
        for k, r in enumerate(self._results):
            pa[k] = R @ r.getNearestPoint1() + p
            pb[k] = R @ r.getNearestPoint2() + p
            nrm[k] = R @ r.normal
        names = tuple(self.pair_names())
        links = tuple((self.link_of[a], self.link_of[b]) for a, b in names)
        return Distances(names, links, d, pa, pb, nrm)

    def min_clearance(self, q) -> float:
        """The smallest signed distance over the checked pairs at ``q``, [m] (inf: no pairs)."""
        d = self.distance_values(q)
        return float(d.min()) if len(d) else math.inf

    def distance_jacobian(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Signed distances (n_pairs,) and their gradients with respect to ``q``
        (n_pairs, n_joints).

        For the pair (A, B) with witness points ``p_A``, ``p_B`` and unit normal ``n`` from A to
        B, ``d = n . (p_B - p_A)`` and, the witness points moving with their bodies,
        ``dd/dq = n^T (J_B(p_B) - J_A(p_A))`` with ``J_X(p) = J_v - [p - o]_x J_w`` the point
        Jacobian of body X's joint (origin ``o``; Pinocchio's ``LOCAL_WORLD_ALIGNED`` joint
        Jacobian). Valid where the witness points move smoothly (not across a switch of the
        closest features).
        """
        q = self.robot.check_q(q)
        dist = self.distances(q)
        model, data = self.robot.model, self._data
        pin.computeJointJacobians(model, data, q)
        nq = model.nq
        T = np.asarray(self.robot.transform_base_to_world, float)
        R, p0 = T[:3, :3], T[:3, 3]
        objs = self.geometry.geometryObjects
        cache: dict[int, np.ndarray] = {}

        def point_jac(joint: int, p_world: np.ndarray) -> np.ndarray:
            if joint == 0:
                return np.zeros((3, nq))
            if joint not in cache:
                cache[joint] = pin.getJointJacobian(
                    model, data, joint, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
                )
            J = cache[joint]
            r = R.T @ (p_world - p0) - data.oMi[joint].translation  # in the base frame
            skew = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
            return R @ (J[:3] - skew @ J[3:])

        grad = np.zeros((self.n_pairs, nq))
        for k, cp in enumerate(self.geometry.collisionPairs):
            ja, jb = objs[cp.first].parentJoint, objs[cp.second].parentJoint
            grad[k] = dist.normal[k] @ (
                point_jac(jb, dist.point_b_m[k]) - point_jac(ja, dist.point_a_m[k])
            )
        return dist.distance_m, grad


def collision_summary(robot: Robot) -> str:
    """One line on a robot's collision model (``armlab info``): how many shapes, from which
    URDF elements, how many pairs are checked and which disabled-pair file says why not the
    others. A geometry that cannot be built is reported on the line, not raised."""
    from armlab.errors import ArmlabError

    try:
        scene = CollisionScene.from_robot(robot)
    except ArmlabError as exc:
        return f"none: {exc}"
    n = len(scene.geometry.geometryObjects)
    counts = scene.disabled.counts()
    where = scene.disabled.path or scene.disabled.origin
    return (
        f"{n} shapes from the URDF's <{scene.source}> elements; {scene.n_pairs} pairs checked, "
        f"link pairs disabled: {counts['adjacent']} adjacent, {counts['always']} always, "
        f"{counts['never']} never in contact ({where})"
    )
