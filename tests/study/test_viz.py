"""The arm in 3D (armlab.viz): teachbot6's generated visual geometry, scenes on Pinocchio's
MeshcatVisualizer, self-contained HTML animations, the study report's motion.html. Headless:
nothing here starts a meshcat server or a browser (scenes for files are recorded in-process)."""

from __future__ import annotations

import base64
import json
import math
import re
import tomllib
import warnings
import xml.etree.ElementTree as ET

import coal
import numpy as np
import pinocchio as pin
import pytest
import umsgpack

import armlab
import armlab.viz as viz
from armlab.errors import InputError
from armlab.planning import ptp_sync
from armlab.robot import read_dh_table, urdf_from_dh
from armlab.robot.dh import VISUAL_MATERIALS
from armlab.robot.generate import description_urdf
from cases import quick_study
from conftest import PANDA_FINGERS, PANDA_URDF, REPO, UR5_URDF

DESC = REPO / "robot_desc" / "teachbot6"
Q1 = np.array([0.5, 0.3, -0.4, 0.6, 0.5, -0.7])


def commands(html: str) -> list[dict]:
    """The meshcat commands a static HTML page replays (base64 msgpack blobs), decoded."""
    blobs = re.findall(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]


def urdf_visual_count(path) -> int:
    return sum(1 for _ in ET.parse(path).getroot().iter("visual"))


def tracks(cmds: list[dict]) -> dict[str, dict[str, list]]:
    """{node path: {property: keys}} of the (last) set_animation command."""
    anim = [c for c in cmds if c["type"] == "set_animation"][-1]
    return {
        a["path"]: {t["name"].lstrip("."): t["keys"] for t in a["clip"]["tracks"]}
        for a in anim["animations"]
    }


def last_transforms(cmds: list[dict]) -> dict[str, np.ndarray]:
    out = {}
    for c in cmds:
        if c["type"] == "set_transform":
            out[c["path"]] = np.array(c["matrix"]).reshape(4, 4).T
    return out


# ---------------------------------------------------------------------------- the URDF
def test_generated_visuals_add_geometry_only():
    """The committed URDF is the generator's output, and removing its <visual>s, <collision>s
    and <material>s gives exactly the URDF without visuals: inertial and kinematic content
    unchanged."""
    text = (DESC / "teachbot6.urdf").read_text()
    assert text == description_urdf(DESC)
    table = read_dh_table(DESC / "mdh.toml")
    with_v = ET.fromstring(urdf_from_dh(table))
    without = ET.fromstring(urdf_from_dh(table, visuals=False))
    assert sum(1 for _ in without.iter("visual")) == 0
    for parent in [with_v, *with_v.iter("link")]:
        for child in list(parent):
            if child.tag in ("visual", "collision", "material"):
                parent.remove(child)

    def canonical(root: ET.Element) -> str:
        return ET.canonicalize(ET.tostring(root, encoding="unicode"), strip_text=True)

    assert canonical(with_v) == canonical(without)
    # housings (6) + base plate + links with a length (a1, a2, a3, d4, flange) + tool
    assert urdf_visual_count(DESC / "teachbot6.urdf") == 6 + 1 + 5 + 1


def test_fk_unchanged_and_links_join_the_dh_frames(teachbot6):
    """Pinocchio's FK of the URDF equals the closed-form MDH product, and every DH frame
    origin, the flange and the tool point is an end of a generated link or tool cylinder."""
    table = teachbot6.dh
    housing = VISUAL_MATERIALS["armlab_housing"]
    model = pin.buildModelFromUrdf(str(teachbot6.urdf_path))
    geom = pin.buildGeomFromUrdf(model, str(teachbot6.urdf_path), pin.GeometryType.VISUAL)
    data, gdata = model.createData(), geom.createData()
    tool = model.getFrameId("tool0")
    rng = np.random.default_rng(3)
    for q in teachbot6.random_q(rng, 5):
        pin.framesForwardKinematics(model, data, q)
        np.testing.assert_allclose(data.oMf[tool].homogeneous, table.fk(q), atol=1e-12)
        pin.updateGeometryPlacements(model, data, geom, gdata)
        ends = []
        for k, g in enumerate(geom.geometryObjects):
            if isinstance(g.geometry, coal.Cylinder) and not np.allclose(g.meshColor, housing):
                M = gdata.oMg[k]
                half = g.geometry.halfLength
                ends += [M.act(np.array([0, 0, s * half])) for s in (-1.0, 1.0)]
        ends = np.array(ends)
        points = [table.fk(q, upto=i)[:3, 3] for i in range(1, 7)]
        points.append((table.fk(q, upto=6) @ table.transform_flange_to_last)[:3, 3])
        points.append(table.fk(q)[:3, 3])
        for p in points:
            assert np.min(np.linalg.norm(ends - p, axis=1)) < 1e-9


# ---------------------------------------------------------------------------- scenes
def test_teachbot6_scene_shows_every_urdf_visual(teachbot6):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no geometry of the generated URDF is left out
        scene = viz.build_scene(teachbot6)
    n = urdf_visual_count(teachbot6.urdf_path)
    assert scene.geometry.ngeoms == len(scene.geometry_paths) == n == 13
    assert scene.url is None and scene.notes == []
    cmds = commands(scene.static_html())
    objects = {c["path"] for c in cmds if c["type"] == "set_object"}
    assert set(scene.geometry_paths) <= objects
    assert all(p.startswith("/meshcat/teachbot6/visuals/") for p in scene.geometry_paths)


def test_show_places_the_tool_where_the_dh_table_puts_it(tmp_path, teachbot6):
    robot = teachbot6.copy()
    T_base = np.eye(4)
    T_base[:3, 3] = [0.1, -0.2, 0.3]
    robot.transform_base_to_world = T_base
    scene = viz.show(robot, Q1, path=tmp_path / "pose.html")
    html = (tmp_path / "pose.html").read_text()
    assert html.startswith("<!DOCTYPE html>") and "MeshCat.Viewer" in html
    placed = last_transforms(commands(html))
    np.testing.assert_allclose(placed["/meshcat/teachbot6"], T_base, atol=1e-12)
    # the tool cylinder runs from the flange to the tool point: its centre is their midpoint
    table = robot.dh
    flange = (table.fk(Q1, upto=6) @ table.transform_flange_to_last)[:3, 3]
    mid = 0.5 * (flange + table.fk(Q1)[:3, 3])
    tool_path = next(p for p in scene.geometry_paths if p.endswith("/tool0_0"))
    np.testing.assert_allclose(placed[tool_path][:3, 3], mid, atol=1e-9)
    manifest = re.search(r'<script type="application/json" id="armlab-scene">(.*?)</script>', html)
    assert json.loads(manifest.group(1))["geometry_paths"] == scene.geometry_paths


def test_animate_writes_one_frame_per_sample_period(tmp_path, teachbot6):
    q0 = np.zeros(6)
    traj = ptp_sync(teachbot6, q0, Q1)
    path = tmp_path / "motion.html"
    scene = viz.animate(teachbot6, traj, path, fps=30)
    expected = math.ceil(traj.duration * 30 - 1e-9) + 1
    assert scene.n_frames == expected and expected > 30  # a 1.25 s plan
    cmds = commands(path.read_text())
    anim = tracks(cmds)
    assert set(anim) == set(scene.geometry_paths)  # every geometry is animated
    (animation,) = [c for c in cmds if c["type"] == "set_animation"]
    assert {a["clip"]["fps"] for a in animation["animations"]} == {30}
    for keys in anim.values():
        assert set(keys) == {"position", "quaternion"}
        times = [k["time"] for k in keys["position"]]
        assert len(times) == expected
        np.testing.assert_allclose(times[:-1], np.arange(expected - 1), atol=1e-9)
        assert times[-1] == pytest.approx(traj.duration * 30, abs=1e-9)
    # first and last frames: the tool cylinder between flange and tool point at q0 and q1
    table = teachbot6.dh
    tool_path = next(p for p in scene.geometry_paths if p.endswith("/tool0_0"))
    for q, key in ((q0, 0), (Q1, -1)):
        flange = (table.fk(q, upto=6) @ table.transform_flange_to_last)[:3, 3]
        mid = 0.5 * (flange + table.fk(q)[:3, 3])
        np.testing.assert_allclose(anim[tool_path]["position"][key]["value"], mid, atol=1e-7)


def test_frame_rate_rule_and_bad_rates(tmp_path, teachbot6):
    traj = ptp_sync(teachbot6, np.zeros(6), Q1)
    scene = viz.build_scene(teachbot6)
    for fps in (5.0, 12.5, 100.0):
        assert scene.set_motion(traj, fps) == math.ceil(traj.duration * fps - 1e-9) + 1
    for bad in (0, -1, math.nan, 2000, "fast"):
        with pytest.raises(InputError, match="fps"):
            viz.animate(teachbot6, traj, tmp_path / "x.html", fps=bad)
    with pytest.raises(InputError, match="7 joints"):
        short = armlab.trajectory.Trajectory(
            traj.t, np.zeros((traj.n_samples, 7)), np.zeros((traj.n_samples, 7)),
            np.zeros((traj.n_samples, 7)),
        )  # fmt: skip
        scene.set_motion(short)
    assert not (tmp_path / "x.html").exists()


def test_writing_a_file_starts_no_server(tmp_path, teachbot6, monkeypatch):
    def no_server():
        raise AssertionError("a meshcat server was started")

    monkeypatch.setattr(viz, "_start_server", no_server)
    traj = ptp_sync(teachbot6, np.zeros(6), Q1)
    scene = viz.animate(teachbot6, traj, tmp_path / "m.html")
    assert scene.url is None and (tmp_path / "m.html").stat().st_size > 100_000
    with pytest.raises(viz.VisualizationError, match="no server"):
        scene.open()


def test_meshcat_missing_is_one_line(monkeypatch, teachbot6):
    monkeypatch.setitem(__import__("sys").modules, "meshcat", None)
    with pytest.raises(viz.VisualizationError) as err:
        viz.build_scene(teachbot6)
    assert "meshcat" in str(err.value) and "\n" not in str(err.value)


# ---------------------------------------------------------------------------- other URDFs
@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_example_robot_data_meshes_resolve(name, ur5, panda):
    robot = {"ur5": ur5, "panda": panda}[name]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = viz.build_scene(robot)
    assert len(scene.geometry_paths) == urdf_visual_count(robot.urdf_path)
    assert list(scene.model.names) == list(robot.model.names)  # Panda: fingers locked
    meshes = [c for c in commands(scene.static_html()) if c["type"] == "set_object"]
    assert any(c["object"]["object"].get("format") == "dae" for c in meshes)


def test_missing_meshes_warn_in_one_line_and_draw_a_skeleton(tmp_path):
    text = UR5_URDF.read_text().replace("package://example-robot-data", "package://nosuch")
    urdf = tmp_path / "ur5_lost.urdf"
    urdf.write_text(text)
    robot = armlab.load_robot(urdf)
    with pytest.warns(viz.VizWarning) as caught:
        scene = viz.show(robot, np.zeros(6), path=tmp_path / "lost.html")
    assert len(caught) == 1
    message = str(caught[0].message)
    assert "\n" not in message and "7 visual mesh(es) not found" in message
    names = [p.rsplit("/", 1)[1] for p in scene.geometry_paths]
    assert sum(n.startswith("skeleton_joint") for n in names) == 6
    assert any(n.startswith("skeleton_link") for n in names)
    assert (tmp_path / "lost.html").is_file()


def test_panda_animation_uses_the_locked_model(tmp_path):
    panda = armlab.load_robot(PANDA_URDF, lock_joints=PANDA_FINGERS, tool_frame="panda_hand")
    q0 = np.array([0, -0.5, 0, -2.0, 0, 1.6, 0.8])
    traj = ptp_sync(panda, q0, q0 + 0.2, a_max=2.0)  # a plain URDF: no acceleration limit
    scene = viz.animate(panda, traj, tmp_path / "panda.html", fps=10)
    assert scene.n_frames == math.ceil(traj.duration * 10 - 1e-9) + 1


# ---------------------------------------------------------------------------- study report
STUDY = quick_study("viz", ("kinematics", "plan"), report=True, check_dt_s=None)


def test_study_report_links_the_motion(tmp_path):
    from armlab.study import parse_study, run_spec

    res = run_spec(parse_study(tomllib.loads(STUDY)), tmp_path)
    report = (tmp_path / "report.md").read_text()
    assert "[3D animation of the planned motion](motion.html)" in report
    assert tmp_path / "motion.html" in res.files
    anim = tracks(commands((tmp_path / "motion.html").read_text()))
    n = math.ceil(res.trajectory.duration * viz.DEFAULT_FPS - 1e-9) + 1
    assert {len(k["position"]) for k in anim.values()} == {n}


def test_study_report_says_when_the_motion_cannot_be_drawn(tmp_path, monkeypatch):
    from armlab.study import parse_study, run_spec

    def broken(*args, **kwargs):
        raise viz.VisualizationError("3D view needs meshcat (pip install meshcat)")

    monkeypatch.setattr(viz, "animate", broken)
    doc = tomllib.loads(STUDY)
    res = run_spec(parse_study(doc), tmp_path)
    assert res.summary["trajectory"]["status"] == "ok"
    report = (tmp_path / "report.md").read_text()
    line = "3D animation not written: 3D view needs meshcat (pip install meshcat)"
    assert line in report.splitlines()
    assert not (tmp_path / "motion.html").exists()
    # no plan stage: no 3D section at all
    doc["study"]["stages"] = ["kinematics"]
    run_spec(parse_study(doc), tmp_path / "k")
    assert "3D" not in (tmp_path / "k" / "report.md").read_text()
