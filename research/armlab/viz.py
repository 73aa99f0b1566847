"""3D views of an arm: its URDF's visual geometry on Pinocchio's MeshcatVisualizer.

* :func:`show` -- the arm in one pose;
* :func:`animate` -- a planned motion (a :class:`~armlab.trajectory.Trajectory`) as a meshcat
  animation;
* :func:`build_scene` -- the :class:`Scene` both use; :func:`visual_model` -- the geometry;
* :meth:`Scene.add_environment` (``obstacles``, ``floor_z_m``, ``closest`` of :func:`show` and
  :func:`animate`) -- obstacles, the floor and the closest pair of a motion
  (:mod:`armlab.viz_obstacles`).

Where it is shown
-----------------
With ``path`` the scene is written as **one self-contained HTML file** (meshcat's
``static_html``: the three.js viewer, the geometry, the poses and the animation inline; any
browser opens it offline). Writing a file starts no server and opens no port: the meshcat
``Visualizer`` talks to a recording window in this process, which keeps the scene tree exactly
as the meshcat server would and assembles the same HTML as the server's ``get_scene``.

Without ``path`` a meshcat server is started at that call (a local process serving the viewer
on 127.0.0.1; meshcat prints its URL, also in :attr:`Scene.url`), the scene is sent to it and
recorded as well; :meth:`Scene.close` (or leaving a ``with`` block, or the interpreter's exit)
stops it.

Geometry
--------
The visual ``GeometryModel`` comes from the robot's URDF (``<visual>`` elements, through
``pinocchio.buildGeomFromUrdfString``); built-in arms get theirs from their DH table
(:func:`armlab.robot.dh.dh_visuals`). A mesh ``package://PKG/path`` is looked up in the
``package_dirs`` given, the folders holding the URDF (any ancestor with a ``PKG`` folder: this
finds example-robot-data's meshes), ``example_robot_data``'s model folder and
``$ROS_PACKAGE_PATH``; relative paths are relative to the URDF. A visual whose mesh is not
found is left out with one :class:`VizWarning` line for the robot, and the arm is then also
drawn as a **skeleton** of primitives (a cylinder from each joint origin to the next, a sphere
on each joint), as it is for a URDF without any ``<visual>``. Joints the :class:`Robot` locked
(``load_robot(..., lock_joints=...)``) are locked in the geometry the same way (at 0). The arm
stands in the world at ``robot.transform_base_to_world``.

Frame rate
----------
:func:`animate` samples the trajectory every ``1 / fps`` seconds of plan time from its start
(:meth:`~armlab.trajectory.Trajectory.sample`: a uniform grid plus the end point, the last step
possibly shorter): ``ceil(duration * fps) + 1`` animation frames (to rounding), each shown at its
plan time, so the animation plays in real time. The default :data:`DEFAULT_FPS` = 30 is a
screen's pace. The controller period (1 ms for the default profile: 1000 fps) is not the
default: 33x the frames and the file size (about 0.1 kB per frame and geometry) and nothing
more to see; pass ``fps=1 / cycle_s`` to step through every set-point (at most :data:`MAX_FPS`).
"""

from __future__ import annotations

import base64
import json
import math
import os
import re
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from armlab.errors import ArmlabError, InputError, RobotDescriptionError
from armlab.io import atomic_write
from armlab.robot.geometry import mesh_search_dirs as _mesh_search_dirs
from armlab.robot.geometry import reduced_geometry
from armlab.robot.geometry import resolve_mesh as _resolve_mesh

__all__ = [
    "DEFAULT_FPS",
    "MAX_FPS",
    "Scene",
    "VisualizationError",
    "VizWarning",
    "animate",
    "build_scene",
    "show",
    "visual_model",
]

#: Default animation frame rate in [1/s] (frames per second of plan time).
DEFAULT_FPS = 30.0
#: Largest accepted frame rate in [1/s] (a 1 ms controller period).
MAX_FPS = 1000.0

_SKELETON_RGBA = np.array([0.55, 0.62, 0.72, 1.0])


class VisualizationError(ArmlabError):
    """The 3D view cannot be made (meshcat missing, its server not starting)."""


class VizWarning(UserWarning):
    """A part of the arm's geometry cannot be shown (a mesh not found, an unsupported shape)."""


# ---------------------------------------------------------------------------- geometry
def _urdf_with_found_meshes(urdf: Path, dirs: list[Path]) -> tuple[str, int, list[str]]:
    """The URDF text with every visual mesh made an absolute path and the visuals whose mesh
    is missing removed: (text, number of visuals kept, the missing meshes' file names)."""
    try:
        root = ET.parse(urdf).getroot()
    except (OSError, ET.ParseError) as exc:
        raise RobotDescriptionError(f"{urdf}: cannot read the URDF ({exc})") from None
    missing: list[str] = []
    kept = 0
    for link in root.iter("link"):
        for visual in list(link.findall("visual")):
            mesh = visual.find("geometry/mesh")
            if mesh is not None:
                found = _resolve_mesh(mesh.get("filename", ""), urdf, dirs)
                if found is None:
                    missing.append(mesh.get("filename", "?"))
                    link.remove(visual)
                    continue
                mesh.set("filename", str(found.resolve()))
            kept += 1
    return ET.tostring(root, encoding="unicode"), kept, missing


def _length_m(model: pin.Model) -> float:
    """The arm's characteristic length in [m]: its joint offsets and fixed-frame offsets."""
    length = sum(float(np.linalg.norm(p.translation)) for p in model.jointPlacements[1:])
    length += max(
        (float(np.linalg.norm(f.placement.translation)) for f in model.frames), default=0.0
    )
    return length if length > 1e-6 else 1.0


def _skeleton(model: pin.Model, geom: pin.GeometryModel) -> None:
    """Add a primitive skeleton to ``geom``: a sphere on each joint, a cylinder from each joint
    origin to the next joint origin and to each fixed frame (tool) on it."""
    import coal

    r = 0.02 * _length_m(model)

    def add(name: str, parent: int, placement: pin.SE3, shape) -> None:
        obj = pin.GeometryObject(name, parent, placement, shape)
        obj.meshColor = _SKELETON_RGBA
        geom.addGeometryObject(obj)

    def rod(name: str, parent: int, p: np.ndarray) -> None:
        length = float(np.linalg.norm(p))
        if length < 1e-6:
            return
        R = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), p / length).matrix()
        add(name, parent, pin.SE3(R, 0.5 * p), coal.Cylinder(r, length))

    for j in range(1, model.njoints):
        add(f"skeleton_joint{j}", j, pin.SE3.Identity(), coal.Sphere(1.5 * r))
        rod(f"skeleton_link{j}", model.parents[j], model.jointPlacements[j].translation)
    for f in model.frames:
        if f.type == pin.FrameType.FIXED_JOINT and f.parentJoint > 0:
            rod(f"skeleton_{f.name}", f.parentJoint, f.placement.translation)


def visual_model(
    robot, package_dirs: Sequence[str | os.PathLike] = ()
) -> tuple[pin.Model, pin.GeometryModel, list[str]]:
    """The kinematic model and visual geometry of a robot, from its URDF.

    Parameters
    ----------
    robot : Robot
    package_dirs : sequence of path
        Extra folders holding the packages of ``package://`` mesh paths.

    Returns
    -------
    model : pinocchio.Model
        The URDF's model with the joints the robot locked locked at 0: its joints are the
        robot's (``model.names == robot.model.names``).
    geometry : pinocchio.GeometryModel
        Visual geometry, one object per ``<visual>`` found (plus the skeleton if any is missing).
    notes : list of str
        One-line warnings (meshes not found).

    Raises
    ------
    RobotDescriptionError
        The URDF cannot be read, or its joints are not the robot's.
    """
    urdf = Path(robot.urdf_path)
    dirs = _mesh_search_dirs(urdf, package_dirs)
    text, kept, missing = _urdf_with_found_meshes(urdf, dirs)
    model, geom = reduced_geometry(
        robot, text, pin.GeometryType.VISUAL, "visual", package_dirs=[str(d) for d in dirs]
    )
    notes = []
    if missing:
        notes.append(
            f"{robot.name}: {len(missing)} visual mesh(es) not found (first: {missing[0]}); "
            "drawn as a skeleton of primitives instead"
        )
    if missing or kept == 0:
        _skeleton(model, geom)
    return model, geom, notes


# ---------------------------------------------------------------------------- meshcat glue
def _meshcat():
    """meshcat, imported quietly (its server module imports a deprecated pyzmq module)."""
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "zmq.eventloop.ioloop", DeprecationWarning)
            import meshcat
            import meshcat.animation  # noqa: F401
            import umsgpack  # noqa: F401
            from meshcat.servers.tree import SceneTree  # noqa: F401
            from pinocchio.visualize import MeshcatVisualizer  # noqa: F401
    except ImportError as exc:
        raise VisualizationError(
            f"3D view needs meshcat (pip install meshcat): {exc}".splitlines()[0]
        ) from None
    return meshcat


def _command_js(data: bytes) -> str:
    """One recorded meshcat command as the JavaScript meshcat's ``get_scene`` writes."""
    b64 = base64.b64encode(data).decode("ascii")
    return (
        f'\nfetch("data:application/octet-binary;base64,{b64}")\n'
        "    .then(res => res.arrayBuffer())\n"
        "    .then(buffer => viewer.handle_command_bytearray(new Uint8Array(buffer)));\n"
    )


_HTML = """<!DOCTYPE html>
<html>
  <head><meta charset="utf-8"><title>{title}</title></head>
  <body>
    <div id="meshcat-pane"></div>
    <script>
{mainjs}
    </script>
    <script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
{commands}
    </script>
    <style>
      body {{ margin: 0; }}
      #meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
    </style>
    <script type="application/json" id="armlab-scene">{manifest}</script>
  </body>
</html>
"""


class _RecordingWindow:
    """A meshcat viewer window that keeps the scene tree in this process (what the meshcat
    server keeps) and forwards every command to a live window, if any."""

    def __init__(self, live=None, title: str = "armlab") -> None:
        from meshcat.servers.tree import SceneTree

        self.tree = SceneTree()
        self.live = live
        self.web_url = None if live is None else live.web_url
        self.title = title
        self.manifest: dict[str, Any] = {}

    def send(self, command) -> None:
        import umsgpack
        from meshcat.servers.tree import SceneTree, find_node

        data = command.lower()
        kind = data["type"]
        path = [p for p in str(data.get("path", "")).split("/") if p]
        packed = umsgpack.packb(data)
        if kind == "delete":
            if not path:
                self.tree = SceneTree()
            else:
                parent = find_node(self.tree, path[:-1])
                parent.pop(path[-1], None)
        elif kind == "set_object":
            node = find_node(self.tree, path)
            node.object, node.properties = packed, []
        elif kind == "set_transform":
            find_node(self.tree, path).transform = packed
        elif kind == "set_property":
            find_node(self.tree, path).properties.append(packed)
        elif kind == "set_animation":
            find_node(self.tree, path).animation = packed
        if self.live is not None:
            self.live.send(command)

    def get_scene(self) -> str:
        """The scene as one self-contained HTML page (the layout of meshcat's get_scene)."""
        import meshcat
        from meshcat.servers.tree import walk

        commands = []
        for node in walk(self.tree):
            blobs = [node.object, *node.properties, node.transform, node.animation]
            commands += [_command_js(b) for b in blobs if b is not None]
        mainjs = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
        return _HTML.format(
            title=self.title.replace("<", "").replace("&", ""),
            mainjs=mainjs.read_text(encoding="utf-8"),
            commands="".join(commands),
            manifest=json.dumps(self.manifest).replace("</", "<\\/"),
        )

    def open(self) -> None:
        if self.live is None:
            raise VisualizationError("this scene has no server to open (it is written to a file)")
        self.live.open()

    def wait(self) -> str:
        return "" if self.live is None else self.live.wait()

    def get_image(self):
        if self.live is None:
            raise VisualizationError("no browser renders this scene: nothing to capture")
        return self.live.get_image()

    def close(self) -> None:
        live, self.live = self.live, None
        if live is None:
            return
        try:
            live.zmq_socket.close(linger=0)
        finally:
            proc = getattr(live, "server_proc", None)
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait(timeout=10)
            for stream in (getattr(proc, "stdout", None), getattr(proc, "stderr", None)):
                if stream is not None:
                    stream.close()


def _start_server():
    """A meshcat server process and a window connected to it."""
    from meshcat.visualizer import ViewerWindow

    try:
        return ViewerWindow(zmq_url=None, start_server=True, server_args=[])
    except Exception as exc:  # the server process failed to start
        raise VisualizationError(f"the meshcat server did not start: {exc}") from None


def _one_line(message: object) -> str:
    lines = [s.strip() for s in str(message).splitlines() if s.strip()]
    return " ".join(lines[:2]) if lines else "warning"


# ---------------------------------------------------------------------------- the scene
class Scene:
    """A robot in a meshcat scene: Pinocchio's MeshcatVisualizer on a meshcat Visualizer.

    Build it with :func:`build_scene` (or :func:`show` / :func:`animate`).

    Attributes
    ----------
    robot : Robot
    model : pinocchio.Model
        The kinematic model the geometry hangs on (the robot's joints).
    geometry : pinocchio.GeometryModel
        The visual geometry (:func:`visual_model`).
    viz : pinocchio.visualize.MeshcatVisualizer
    viewer : meshcat.Visualizer
    root : str
        Scene-tree name of the robot: geometry ``k`` is at ``/meshcat/<root>/visuals/<name>``.
    geometry_paths : list of str
        Scene-tree paths of the geometries shown (a shape meshcat cannot draw is left out).
    notes : list of str
        The one-line warnings issued while building (also emitted as :class:`VizWarning`).
    url : str or None
        The live viewer's address (None for a scene recorded for a file).
    n_frames, fps : int, float
        Animation frames and frame rate [1/s] set by :meth:`set_motion` (0 and nan before).
    """

    def __init__(
        self,
        robot,
        *,
        server: bool = False,
        package_dirs: Sequence[str | os.PathLike] = (),
    ) -> None:
        meshcat = _meshcat()
        from pinocchio.visualize import MeshcatVisualizer

        self.robot = robot
        self.model, self.geometry, notes = visual_model(robot, package_dirs)
        self.data = self.model.createData()
        self.root = re.sub(r"[^A-Za-z0-9_.-]", "_", str(robot.name)) or "robot"
        self.n_frames, self.fps = 0, math.nan
        live = _start_server() if server else None
        self._window = _RecordingWindow(live, title=f"armlab: {robot.name}")
        try:
            self.viewer = meshcat.Visualizer(window=self._window)
            self.viz = MeshcatVisualizer(self.model, None, self.geometry)
            self.viz.initViewer(viewer=self.viewer)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                self.viz.loadViewerModel(rootNodeName=self.root)
            notes += [f"{robot.name}: {_one_line(w.message)}" for w in caught]
            self.viewer[self.root].set_transform(np.asarray(robot.transform_base_to_world))
            self._set_camera()
        except BaseException:
            self.close()
            raise
        self.url: str | None = self._window.web_url
        self.notes = notes
        for note in notes:
            warnings.warn(note, VizWarning, stacklevel=3)
        self.geometry_paths = self._shown_paths()
        self._window.manifest = {
            "robot": str(robot.name),
            "geometry_paths": self.geometry_paths,
            "n_frames": 0,
            "fps": None,
        }

    # ------------------------------------------------------------------ set-up
    def _shown_paths(self) -> list[str]:
        from meshcat.servers.tree import find_node

        group = find_node(self._window.tree, ["meshcat", self.root, "visuals"])
        return [
            f"/meshcat/{self.root}/visuals/{g.name}"
            for g in self.geometry.geometryObjects
            if g.name in group and group[g.name].object is not None
        ]

    def _set_camera(self) -> None:
        """Look at the arm from the front right, from about 1.4 arm lengths away."""
        L = _length_m(self.model)
        target = np.asarray(self.robot.transform_base_to_world) @ np.array([0, 0, 0.25 * L, 1])
        T = np.eye(4)
        T[:3, 3] = target[:3]
        self.viewer["/Cameras/default"].set_transform(T)
        # the camera's offset about its target, in the viewer's y-up frame (x, z_world, -y_world)
        offset = [0.9 * L, 0.55 * L, 0.9 * L]
        self.viewer["/Cameras/default/rotated/<object>"].set_property("position", offset)

    # ------------------------------------------------------------------ environment
    def add_environment(
        self, obstacles=(), *, floor_z_m: float | None = None, closest=None
    ) -> dict[str, Any]:
        """Draw obstacles, the floor and the closest pair
        (:func:`armlab.viz_obstacles.draw_environment`; plain descriptions: a study's
        ``[[obstacle]]`` tables, :class:`~armlab.viz_obstacles.ObstacleShape`,
        :class:`~armlab.viz_obstacles.ClosestPair`); they enter the HTML file's manifest."""
        from armlab.viz_obstacles import draw_environment

        entries = draw_environment(
            self.viewer,
            obstacles,
            floor_z_m=floor_z_m,
            closest=closest,
            extent_m=1.5 * _length_m(self.model),
        )
        self._window.manifest.update(entries)
        return entries

    # ------------------------------------------------------------------ poses
    def display(self, q=None) -> None:
        """Show the arm at joint positions ``q`` (n_joints,) in [rad]; None: all zeros."""
        q = np.zeros(self.robot.n_joints) if q is None else self.robot.check_q(q)
        self.viz.display(q)

    def set_motion(self, trajectory, fps: float = DEFAULT_FPS) -> int:
        """Make ``trajectory`` the scene's animation, sampled every ``1 / fps`` [s].

        Parameters
        ----------
        trajectory : Trajectory
            Joint positions of the robot's joints in [rad].
        fps : float
            Frame rate in [1/s] of plan time, ``0 < fps <= MAX_FPS`` (module docstring).

        Returns
        -------
        int
            Number of animation frames: ``ceil(duration * fps) + 1`` to rounding.
        """
        from meshcat.animation import Animation

        fps = _check_fps(fps)
        if trajectory.n_joints != self.robot.n_joints:
            raise InputError(
                f"trajectory has {trajectory.n_joints} joints, {self.robot.name} has "
                f"{self.robot.n_joints}"
            )
        sampled = trajectory.sample(1.0 / fps) if trajectory.n_samples > 1 else trajectory
        q = self.robot.check_q(sampled.q, name="trajectory q", batch=True)
        frames = (sampled.t - sampled.t[0]) * fps
        shown = set(self.geometry_paths)
        geoms = [
            (k, g, self.viz.getViewerNodeName(g, pin.GeometryType.VISUAL))
            for k, g in enumerate(self.geometry.geometryObjects)
        ]
        geoms = [(k, g, name) for k, g, name in geoms if f"/meshcat/{name}" in shown]
        gdata = self.geometry.createData()
        anim = Animation(default_framerate=fps)
        for frame, qk in zip(frames, q, strict=True):
            pin.forwardKinematics(self.model, self.data, qk)
            pin.updateGeometryPlacements(self.model, self.data, self.geometry, gdata)
            at = anim.at_frame(self.viewer, float(frame))
            for k, g, name in geoms:
                node = at[name]
                node.set_transform(gdata.oMg[k].homogeneous)
                scale = np.asarray(g.meshScale, dtype=float).reshape(-1)
                if not np.allclose(scale, 1.0):
                    node.set_property("scale", "vector3", [float(s) for s in scale])
        self.display(q[0])
        self.viewer.set_animation(anim, play=True, repetitions=1)
        self.n_frames, self.fps = len(frames), fps
        self._window.manifest.update(
            n_frames=self.n_frames, fps=fps, duration_s=float(sampled.t[-1] - sampled.t[0])
        )
        return self.n_frames

    # ------------------------------------------------------------------ output
    def static_html(self) -> str:
        """The scene as one self-contained HTML page (meshcat's ``static_html``)."""
        return self.viewer.static_html()

    def save(self, path: str | os.PathLike) -> Path:
        """Write :meth:`static_html` to ``path`` (atomically); returns the path."""
        return atomic_write(Path(path), self.static_html())

    def open(self) -> None:
        """Open the live viewer in a web browser (a scene made with ``server=True``)."""
        self._window.open()

    def close(self) -> None:
        """Stop the meshcat server of a live scene (nothing for a recorded one)."""
        self._window.close()

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        where = self.url or "recorded (no server)"
        return (
            f"Scene({self.robot.name!r}, {len(self.geometry_paths)} geometries, "
            f"{self.n_frames} frames, {where})"
        )


def _check_fps(fps) -> float:
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise InputError(f"fps must be a number of frames per second, not {fps!r}") from None
    if not (math.isfinite(value) and 0 < value <= MAX_FPS):
        raise InputError(f"fps must be in (0, {MAX_FPS:g}] frames per second, not {fps!r}")
    return value


def build_scene(
    robot, *, server: bool = False, package_dirs: Sequence[str | os.PathLike] = ()
) -> Scene:
    """A :class:`Scene` of ``robot``: recorded in-process (``server=False``, for a file) or also
    sent to a meshcat server started now (``server=True``; :meth:`Scene.close` stops it).

    Raises
    ------
    VisualizationError
        meshcat is not installed, or its server does not start.
    RobotDescriptionError
        The URDF cannot be read or does not match the robot.
    """
    return Scene(robot, server=server, package_dirs=package_dirs)


def show(
    robot,
    q=None,
    *,
    path: str | os.PathLike | None = None,
    open: bool = False,
    package_dirs: Sequence[str | os.PathLike] = (),
    obstacles=(),
    floor_z_m: float | None = None,
    closest=None,
) -> Scene:
    """Show the arm at ``q``.

    Parameters
    ----------
    robot : Robot
    q : array (n_joints,), optional
        Joint positions in [rad]; default all zeros.
    path : path, optional
        Write the scene to this self-contained HTML file (no server). Without it a meshcat
        server is started and the URL printed; ``scene.close()`` stops it.
    open : bool
        Also open the live viewer in a browser (without ``path`` only).
    package_dirs : sequence of path
        Extra folders for ``package://`` meshes.
    obstacles, floor_z_m, closest
        The environment drawn with the arm (:meth:`Scene.add_environment`).

    Returns
    -------
    Scene
    """
    scene = build_scene(robot, server=path is None, package_dirs=package_dirs)
    try:
        scene.add_environment(obstacles, floor_z_m=floor_z_m, closest=closest)
        scene.display(q)
        if path is not None:
            scene.save(path)
        elif open:
            scene.open()
    except BaseException:
        scene.close()
        raise
    return scene


def animate(
    robot,
    trajectory,
    path: str | os.PathLike | None = None,
    *,
    fps: float = DEFAULT_FPS,
    open: bool = False,
    package_dirs: Sequence[str | os.PathLike] = (),
    obstacles=(),
    floor_z_m: float | None = None,
    closest=None,
) -> Scene:
    """Animate a planned motion of the arm.

    Parameters
    ----------
    robot : Robot
    trajectory : Trajectory
        The motion, joint positions in [rad].
    path : path, optional
        Write a self-contained HTML file (no server) that plays the motion on opening (the
        viewer's Animations menu replays it). Without it a meshcat server is started and the
        animation sent to it; ``scene.close()`` stops it.
    fps : float
        Frames per second of plan time, ``0 < fps <= MAX_FPS``: the trajectory is sampled every
        ``1 / fps`` [s] from its start, its end point included (module docstring).
    open : bool
        Also open the live viewer in a browser (without ``path`` only).
    package_dirs : sequence of path
        Extra folders for ``package://`` meshes.
    obstacles, floor_z_m, closest
        The environment drawn with the arm, and the closest pair of the motion marked
        (:meth:`Scene.add_environment`).

    Returns
    -------
    Scene
        With ``n_frames`` (``ceil(duration * fps) + 1``) and ``fps``.
    """
    fps = _check_fps(fps)
    scene = build_scene(robot, server=path is None, package_dirs=package_dirs)
    try:
        scene.add_environment(obstacles, floor_z_m=floor_z_m, closest=closest)
        scene.set_motion(trajectory, fps)
        if path is not None:
            scene.save(path)
        elif open:
            scene.open()
    except BaseException:
        scene.close()
        raise
    return scene
