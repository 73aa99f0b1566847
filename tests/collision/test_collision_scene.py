"""The collision scene: hand-computed distances of simple primitives, frames, gradients."""

from __future__ import annotations

import math

import numpy as np
import pytest

from armlab.collision import CollisionScene, Shape
from armlab.errors import InputError
from armlab.kinematics import fk
from armlab.kinematics.forward import rpy_to_matrix as rpy_matrix
from armlab.robot.model import load_robot

Q = np.radians([45.0, 20.0, 30.0, 0.0, 40.0, 0.0])  # the demo's pick: tool at z = -0.097 m


@pytest.fixture(scope="module")
def bot():
    return load_robot("teachbot6")


def _pair(dist, a: str, b: str) -> int:
    names = list(dist.pairs)
    return names.index((a, b)) if (a, b) in names else names.index((b, a))


def test_payload_sphere_to_sphere_box_and_floor_by_hand(bot):
    """A sphere of r = 30 mm at the tool point: its distance to a sphere obstacle is the centre
    distance minus both radii, to a box below it the height above the box's top face minus r
    (the tool is inside the box's footprint), to the floor its height minus r."""
    tool = fk(bot, Q)[:3, 3]
    ball = Shape("ball", "sphere", (0.05,), tuple(tool + [0.2, 0.1, 0.05]))
    block = Shape("block", "box", (0.2, 0.2, 0.04), (tool[0], tool[1], tool[2] - 0.1))
    payload = Shape("payload", "sphere", (0.03,))
    scene = CollisionScene.from_robot(bot, [ball, block], floor_z_m=-0.4, payload=payload)
    dist = scene.distances(Q)
    expect = {
        "ball": math.sqrt(0.2**2 + 0.1**2 + 0.05**2) - 0.05 - 0.03,
        "block": (0.1 - 0.02) - 0.03,
        "floor": tool[2] + 0.4 - 0.03,
    }
    for name, d in expect.items():
        k = _pair(dist, "payload", name)
        assert dist.distance_m[k] == pytest.approx(d, abs=1e-6), name
    # the witness point on the payload lies on its surface towards the floor
    k = _pair(dist, "payload", "floor")
    on_payload = dist.point_a_m[k] if dist.pairs[k][0] == "payload" else dist.point_b_m[k]
    assert on_payload == pytest.approx(tool - [0.0, 0.0, 0.03], abs=1e-6)


def test_penetration_is_negative_depth(bot):
    """A sphere obstacle of r = 50 mm centred 60 mm from the tool point overlaps the 30 mm
    payload by 20 mm: signed distance -0.02 m."""
    tool = fk(bot, Q)[:3, 3]
    ball = Shape("ball", "sphere", (0.05,), tuple(tool + [0.0, 0.06, 0.0]))
    scene = CollisionScene.from_robot(bot, [ball], payload=Shape("payload", "sphere", (0.03,)))
    dist = scene.distances(Q)
    assert dist.distance_m[_pair(dist, "payload", "ball")] == pytest.approx(-0.02, abs=1e-6)
    assert scene.min_clearance(Q) <= -0.02 + 1e-6


def test_obstacles_are_in_the_world_frame_with_a_mounted_base(bot):
    """Mount the base 0.5 m up and turned 90 deg about z: an obstacle given in the world at the
    tool's world position + 0.1 m in x is 0.1 m - radii away, and witness points are in the
    world frame."""
    T = np.eye(4)
    T[:3, :3] = rpy_matrix(0.0, 0.0, math.pi / 2)
    T[:3, 3] = [0.2, -0.1, 0.5]
    mounted = load_robot("teachbot6", transform_base_to_world=T)
    tool_world = T[:3, :3] @ fk(bot, Q)[:3, 3] + T[:3, 3]
    ball = Shape("ball", "sphere", (0.02,), tuple(tool_world + [0.1, 0.0, 0.0]))
    scene = CollisionScene.from_robot(
        mounted, [ball], payload=Shape("payload", "sphere", (0.03,)), floor_z_m=0.0
    )
    dist = scene.distances(Q)
    k = _pair(dist, "payload", "ball")
    assert dist.distance_m[k] == pytest.approx(0.1 - 0.05, abs=1e-6)
    pts = {dist.pairs[k][0]: dist.point_a_m[k], dist.pairs[k][1]: dist.point_b_m[k]}
    assert pts["ball"] == pytest.approx(tool_world + [0.08, 0.0, 0.0], abs=1e-6)
    k = _pair(dist, "payload", "floor")
    assert dist.distance_m[k] == pytest.approx(tool_world[2] - 0.03, abs=1e-6)


def test_box_and_cylinder_sizes_follow_the_documented_convention(bot):
    """box_m are full side lengths, cylinder_m = [r, length] along the pose's z: a payload
    sphere at the tool point 0.3 m above a box 0.2 m tall (centre 0.3 m below) is 0.2 - 0.03 m
    away; above a standing cylinder of length 0.2 m likewise, and a cylinder turned by
    roll = 90 deg (axis along y) of radius 0.05 m is 0.3 - 0.05 - 0.03 m away."""
    tool = fk(bot, Q)[:3, 3]
    below = tuple(tool - [0.0, 0.0, 0.3])
    cases = {
        Shape("o", "box", (0.1, 0.1, 0.2), below): 0.3 - 0.1 - 0.03,
        Shape("o", "cylinder", (0.05, 0.2), below): 0.3 - 0.1 - 0.03,
        Shape("o", "cylinder", (0.05, 0.2), below, (90.0, 0.0, 0.0)): 0.3 - 0.05 - 0.03,
        Shape("o", "capsule", (0.05, 0.2), below): 0.3 - 0.1 - 0.05 - 0.03,
    }
    for shape, d in cases.items():
        scene = CollisionScene.from_robot(bot, [shape], payload=Shape("payload", "sphere", (0.03,)))
        dist = scene.distances(Q)
        assert dist.distance_m[_pair(dist, "payload", "o")] == pytest.approx(d, abs=1e-6), shape


@pytest.mark.parametrize("mounted", [False, True])
def test_distance_gradient_matches_finite_differences(bot, mounted):
    """d(d)/dq from the witness points and joint Jacobians equals a central difference
    (step 1e-3 rad) to 5e-4 m/rad for every pair with a sphere (the distance of a point to a
    convex set is smooth; two cylinders have kinks where their axes turn parallel). The step
    is large next to GJK's 1e-6 m tolerance, small for the curvature (error ~ h^2). Also with
    the base mounted tilted and moved (witness points and normals in the world frame)."""
    T = np.eye(4)
    if mounted:
        T[:3, :3] = rpy_matrix(0.3, -0.2, 1.0)
        T[:3, 3] = [0.2, -0.1, 0.5]
        bot = load_robot("teachbot6", transform_base_to_world=T)
    tool = T[:3, :3] @ fk(load_robot("teachbot6"), Q)[:3, 3] + T[:3, 3]
    ball = Shape("ball", "sphere", (0.05,), tuple(tool + [0.15, -0.1, 0.08]))
    scene = CollisionScene.from_robot(bot, [ball], payload=Shape("payload", "sphere", (0.03,)))
    d, grad = scene.distance_jacobian(Q)
    spheres = np.array(
        [a in ("ball", "payload") or b in ("ball", "payload") for a, b in scene.pair_names()]
    )
    assert spheres.sum() >= 8  # the ball against the moving links, the payload against links
    h = 1e-3
    for j in range(bot.n_joints):
        e = np.zeros(bot.n_joints)
        e[j] = h
        fd = (scene.distance_values(Q + e) - scene.distance_values(Q - e)) / (2 * h)
        assert grad[spheres, j] == pytest.approx(fd[spheres], abs=5e-4), j
    assert np.max(np.abs(grad[spheres])) > 0.05  # not a vacuous comparison of zeros


def test_self_collision_is_seen_and_same_body_pairs_are_not(bot):
    """The scene's pairs never include two shapes on one joint, the adjacent pairs
    (link2-link3, base-link1) are not checked, and the upper arm against the wrist is."""
    scene = CollisionScene.from_robot(bot)
    objs = scene.geometry.geometryObjects
    for cp in scene.geometry.collisionPairs:
        assert objs[cp.first].parentJoint != objs[cp.second].parentJoint
    links = {tuple(sorted((scene.link_of[a], scene.link_of[b]))) for a, b in scene.pair_names()}
    assert ("link2", "link3") not in links and ("base_link", "link1") not in links
    assert ("link2", "link4") in links  # the upper arm and the wrist can meet


def test_duplicate_shape_names_are_refused(bot):
    ball = Shape("link2_0", "sphere", (0.05,), (1.0, 0.0, 0.0))
    with pytest.raises(InputError, match="link2_0"):
        CollisionScene.from_robot(bot, [ball])


def _cube_stl(path, side: float) -> None:
    """An ASCII STL of a cube of ``side`` centred on its origin (12 triangles)."""
    h = side / 2
    v = [(x, y, z) for x in (-h, h) for y in (-h, h) for z in (-h, h)]
    faces = [
        (0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
        (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3),
    ]  # fmt: skip
    lines = ["solid cube"]
    for f in faces:
        lines += ["facet normal 0 0 0", "outer loop"]
        lines += [f"vertex {v[k][0]} {v[k][1]} {v[k][2]}" for k in f]
        lines += ["endloop", "endfacet"]
    lines.append("endsolid cube")
    path.write_text("\n".join(lines) + "\n")


def test_mesh_obstacle_matches_the_same_box(tmp_path, bot):
    """A 0.1 m cube as an STL mesh (in mm, mesh_scale 0.001) 0.2 m below the tool point: the
    payload sphere is 0.2 - 0.05 - 0.03 m from it, as from the box primitive of that size."""
    _cube_stl(tmp_path / "cube.stl", 100.0)
    tool = fk(bot, Q)[:3, 3]
    below = tuple(tool - [0.0, 0.0, 0.2])
    mesh = Shape(
        "o", "mesh", xyz_m=below, mesh_path=str(tmp_path / "cube.stl"), mesh_scale=(1e-3,) * 3
    )
    payload = Shape("payload", "sphere", (0.03,))
    scene = CollisionScene.from_robot(bot, [mesh], payload=payload)
    dist = scene.distances(Q)
    assert dist.distance_m[_pair(dist, "payload", "o")] == pytest.approx(0.12, abs=1e-6)


def test_payload_is_checked_against_every_link_but_the_one_before_its_body(bot):
    """The payload was not part of the sampled analysis: it is checked against link4 (a
    'never' pair of the tool's own shape) but not against link5 (joined to the tool's body by
    joint 6) nor the shapes on its own body (link6, tool0)."""
    scene = CollisionScene.from_robot(bot, payload=Shape("payload", "box", (0.1, 0.1, 0.2)))
    partners = {scene.link_of[b if a == "payload" else a] for a, b in scene.pair_names()
                if "payload" in (a, b)}  # fmt: skip
    assert {"link4", "link3", "link2", "base_link"} <= partners
    assert not partners & {"link5", "link6", "tool0"}
