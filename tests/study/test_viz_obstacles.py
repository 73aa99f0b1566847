"""The environment in the 3D view (armlab.viz_obstacles through armlab.viz): obstacles at their
poses, the floor and the closest pair's marker, read back from the HTML file's meshcat commands
and its manifest. Headless (recorded scenes, no server)."""

from __future__ import annotations

import base64
import json
import math
import re

import numpy as np
import pytest
import umsgpack

import armlab.viz as viz
from armlab.errors import InputError
from armlab.planning import ptp_sync
from armlab.viz_obstacles import ClosestPair, obstacle_shape, pose_matrix

OBSTACLES = [
    {"name": "table", "box_m": [0.8, 0.6, 0.04], "xyz_m": [0.45, 0.0, -0.02]},
    {"name": "post", "cylinder_m": [0.05, 0.3], "xyz_m": [0.3, 0.3, 0.15], "rpy_deg": [0, 0, 30]},
    {"name": "ball", "sphere_m": 0.05, "xyz_m": [0.3, -0.3, 0.2]},
]
PAIR = ClosestPair(
    "link3", "table", 0.012, np.array([0.3, 0.0, 0.012]), np.zeros(3) + [0.3, 0, 0], 1.25
)


def commands(html: str) -> list[dict]:
    blobs = re.findall(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]


def manifest(html: str) -> dict:
    m = re.search(r'<script type="application/json" id="armlab-scene">(.*?)</script>', html)
    assert m is not None
    return json.loads(m.group(1))


def by_path(cmds: list[dict], kind: str) -> dict[str, dict]:
    return {c["path"]: c for c in cmds if c["type"] == kind}


def test_rpy_is_the_urdf_convention():
    """Rz(yaw) Ry(pitch) Rx(roll), written out for 90 deg yaw then 90 deg roll."""
    T = pose_matrix((1, 2, 3), (90, 0, 90))
    # Rx(90) maps y -> z; then Rz(90) maps x -> y: e_x -> e_y, e_y -> e_z, e_z -> e_x
    np.testing.assert_allclose(T[:3, :3], [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-12)
    np.testing.assert_allclose(T[:3, 3], [1, 2, 3])


def test_show_draws_obstacles_floor_and_closest_pair(tmp_path, teachbot6):
    path = tmp_path / "pose.html"
    viz.show(teachbot6, None, path=path, obstacles=OBSTACLES, floor_z_m=-0.04, closest=PAIR)
    html = path.read_text()
    cmds = commands(html)
    objects, placed = by_path(cmds, "set_object"), by_path(cmds, "set_transform")
    box = objects["/meshcat/environment/table"]["object"]["geometries"][0]
    assert box["type"] == "BoxGeometry"
    assert [box["width"], box["height"], box["depth"]] == pytest.approx([0.8, 0.6, 0.04])
    table = np.array(placed["/meshcat/environment/table"]["matrix"]).reshape(4, 4).T
    np.testing.assert_allclose(table[:3, 3], [0.45, 0.0, -0.02])
    # the cylinder's axis (meshcat: local y) is the obstacle's z axis, here the world's z
    post = np.array(placed["/meshcat/environment/post"]["matrix"]).reshape(4, 4).T
    np.testing.assert_allclose(post[:3, 1], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(post[:3, 0], [math.cos(math.pi / 6), math.sin(math.pi / 6), 0])
    cyl = objects["/meshcat/environment/post"]["object"]["geometries"][0]
    assert (cyl["radiusTop"], cyl["height"]) == pytest.approx((0.05, 0.3))
    # floor: its top face is the plane z = floor_z_m
    floor = np.array(placed["/meshcat/environment/floor"]["matrix"]).reshape(4, 4).T
    depth = objects["/meshcat/environment/floor"]["object"]["geometries"][0]["depth"]
    assert floor[2, 3] + depth / 2 == pytest.approx(-0.04)
    # the closest pair: a line whose two vertices are the witness points
    line = objects["/meshcat/closest_pair/line"]["object"]["geometries"][0]
    xyz = np.frombuffer(line["data"]["attributes"]["position"]["array"].data, np.float32).reshape(
        -1, 3
    )
    np.testing.assert_allclose(xyz, [PAIR.point_a_m, PAIR.point_b_m], atol=1e-7)
    m = manifest(html)
    assert [o["name"] for o in m["obstacles"]] == ["table", "post", "ball"]
    assert m["floor_z_m"] == pytest.approx(-0.04)
    cp = m["closest_pair"]
    assert (cp["a"], cp["b"], cp["distance_m"], cp["time_s"]) == ("link3", "table", 0.012, 1.25)


def test_animation_keeps_the_environment(tmp_path, teachbot6):
    traj = ptp_sync(teachbot6, np.zeros(6), np.array([0.5, 0.3, -0.4, 0.6, 0.5, -0.7]))
    path = tmp_path / "motion.html"
    viz.animate(teachbot6, traj, path, obstacles=OBSTACLES[:1], closest=PAIR)
    cmds = commands(path.read_text())
    objects = by_path(cmds, "set_object")
    assert "/meshcat/environment/table" in objects and "/meshcat/closest_pair/line" in objects
    anim = [c for c in cmds if c["type"] == "set_animation"][-1]
    animated = {a["path"] for a in anim["animations"]}
    assert not any("environment" in p or "closest_pair" in p for p in animated)  # fixed
    assert manifest(path.read_text())["floor_z_m"] is None


class _Shape:  # an object with the collision package's attributes
    name, kind, size_m, mesh_path = "pillar", "capsule", (0.04, 0.2), ""

    def transform(self):
        return pose_matrix((0.1, 0.2, 0.3))


def test_shape_objects_and_bad_tables():
    s = obstacle_shape(_Shape())
    assert (s.kind, s.size_m) == ("capsule", (0.04, 0.2))
    np.testing.assert_allclose(s.pose[:3, 3], [0.1, 0.2, 0.3])
    with pytest.raises(InputError, match="exactly one"):
        obstacle_shape({"name": "x", "box_m": [1, 1, 1], "sphere_m": 0.1})
    with pytest.raises(InputError, match="box_m needs 3"):
        obstacle_shape({"name": "x", "box_m": [1, 1]})
    with pytest.raises(InputError, match="sphere_m needs 1 positive"):
        obstacle_shape({"name": "x", "sphere_m": -0.1})
