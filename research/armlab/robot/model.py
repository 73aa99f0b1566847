"""The :class:`Robot`: a Pinocchio model with its limits, drive train, base, tool and payload.

Frames (thesis 3.5): ``T_tool_in_world = T_base_in_world @ T_tool_in_base`` where
``T_tool_in_base`` is Pinocchio's ``oMf`` of the tool frame; the base transform is
``transform_base_to_world`` (identity unless the arm is mounted elsewhere), the tool frame a URDF
frame (``tool0`` for robot_desc arms) whose placement :meth:`Robot.set_tool` may change.
"""

from __future__ import annotations

import copy
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from armlab.errors import InputError, RobotDescriptionError
from armlab.names import check_name, check_names, one_line
from armlab.robot.dh import DHTable, read_dh_table
from armlab.robot.drives import Drive
from armlab.robot.drives_file import read_drives
from armlab.robot.limits import Limits, description_limits, resolve_limits
from armlab.robot.urdf_check import build_model_quietly, check_urdf, revolute_continuous

__all__ = [
    "Robot",
    "Payload",
    "load_robot",
    "robot_desc_dir",
    "list_robots",
    "ERD_PREFIX",
    "example_robot_data_urdf",
]


def robot_desc_dir() -> Path:
    """Folder of built-in robot descriptions, the first of:

    1. ``$ARMLAB_ROBOT_DESC``;
    2. ``armlab/robot_desc`` inside the installed package (a wheel install: pyproject.toml ships
       the repository's ``robot_desc/`` there as package data);
    3. ``<repo>/robot_desc`` (a source checkout or an editable install).
    """
    env = os.environ.get("ARMLAB_ROBOT_DESC")
    if env:
        return Path(env)
    from importlib.resources import files

    installed = Path(str(files("armlab") / "robot_desc"))
    if installed.is_dir():
        return installed
    return Path(__file__).resolve().parents[3] / "robot_desc"


def list_robots() -> list[str]:
    """Names of the built-in robots (folders of ``robot_desc/`` holding ``<name>.urdf``)."""
    root = robot_desc_dir()
    if not root.is_dir():
        return []
    return sorted(p.name for p in root.iterdir() if (p / f"{p.name}.urdf").is_file())


@dataclass(frozen=True)
class Payload:
    """A payload rigidly attached to the tool frame.

    ``com_m`` is its centre of mass in the tool frame in [m]; ``inertia_kg_m2`` its (3, 3)
    rotational inertia about the centre of mass in [kg m^2].
    """

    mass_kg: float
    com_m: np.ndarray
    inertia_kg_m2: np.ndarray

    def spatial_inertia(self) -> pin.Inertia:
        return pin.Inertia(
            float(self.mass_kg),
            np.asarray(self.com_m, float),
            np.asarray(self.inertia_kg_m2, float),
        )


def _frozen(a) -> np.ndarray:
    """A read-only float copy of ``a``."""
    out = np.array(a, dtype=float)
    out.flags.writeable = False
    return out


def _sub_inertia(a: pin.Inertia, b: pin.Inertia) -> pin.Inertia:
    """a - b through the (linear) dynamic parameters (a massless remainder keeps its rotation)."""
    p = a.toDynamicParameters() - b.toDynamicParameters()
    if abs(p[0]) < 1e-12:  # [m, m c, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] about the frame origin
        ixx, ixy, iyy, ixz, iyz, izz = p[4:]
        rot = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        return pin.Inertia(0.0, np.zeros(3), rot)
    return pin.Inertia.FromDynamicParameters(p)


class Robot:
    """A serial arm: Pinocchio model + limits + drive train + base/tool transforms + payload.

    Use :func:`load_robot` to build one. Attributes
    ----------------------------------------------
    name : str
    model : pinocchio.Model
        Kinematic and inertial model, payload included (``model.inertias``).
    joint_names : list of str
    limits : Limits
        The resolved limits (:func:`armlab.robot.resolve_limits`): the URDF's combined with the
        drive train (``limits.sources`` says where each value came from).
    drives : dict of str to Drive, or None
    dh : DHTable or None
        The DH table the URDF was generated from (built-in arms), used by the analytic IK.
    tool_frame : str
    transform_base_to_world : ndarray (4, 4)
        Mounting of the base in the world, a rigid transform (read-only array; assign a new
        one to change it).
    gravity_in_world : ndarray (3,)
        Gravity in the world in [m/s^2], the URDF model's gravity as loaded (0, 0, -9.81).
    payload : Payload
    urdf_path : Path

    Gravity convention: ``model.gravity`` is the gravity expressed in the **base** frame,
    ``g_base = R_base_in_world^T g_world`` with ``R_base_in_world`` the rotation of
    ``transform_base_to_world``; assigning either property updates it. Every Pinocchio call on
    ``model`` (``rnea``, ``aba``, ``computeGeneralizedGravity``, :mod:`armlab.robot.rigid_body`)
    and the symbolic twin (:mod:`armlab.robot.symbolic`) therefore honour a rotated base
    without rotating anything themselves.
    """

    def __init__(
        self,
        name: str,
        model: pin.Model,
        *,
        urdf_path: Path,
        tool_frame: str,
        drives: dict[str, Drive] | None = None,
        dh: DHTable | None = None,
        payload_frame: str | None = None,
        transform_base_to_world: np.ndarray | None = None,
    ) -> None:
        self.name = name
        self.model = model
        #: continuous joints of the URDF -> True when they came with a range (revolute over it),
        #: False when unbounded (no position limit); and how the tool frame was chosen
        self.continuous_joints: dict[str, bool] = {}
        self.tool_frame_from = "given"
        self.urdf_path = Path(urdf_path)
        self.joint_names = list(model.names[1:])
        self.dh = dh
        self.drives = drives
        if tool_frame not in [f.name for f in model.frames]:
            raise RobotDescriptionError(f"{self.urdf_path}: no frame named {tool_frame!r}")
        self.tool_frame = tool_frame
        self.tool_frame_id = model.getFrameId(tool_frame)
        self._tool_parent = model.frames[self.tool_frame_id].parentJoint
        self._tool_placement0 = model.frames[self.tool_frame_id].placement.copy()
        self._gravity_in_world = _frozen(model.gravity.linear)
        self.transform_base_to_world = transform_base_to_world  # sets model.gravity
        # Separate the description's payload from the bare arm so it can be replaced.
        self._bare_inertia = model.inertias[self._tool_parent].copy()
        payload = Payload(0.0, np.zeros(3), np.zeros((3, 3)))
        if payload_frame is not None:
            f = model.frames[model.getFrameId(payload_frame)]
            if f.parentJoint != self._tool_parent:
                raise RobotDescriptionError(f"{self.urdf_path}: payload not on the tool's link")
            inertia_in_joint = f.inertia.se3Action(f.placement)
            self._bare_inertia = _sub_inertia(self._bare_inertia, inertia_in_joint)
            # the payload expressed in the tool frame
            tool_in_joint = self._tool_placement0
            y = f.inertia.se3Action(tool_in_joint.actInv(f.placement))
            payload = Payload(float(y.mass), y.lever.copy(), y.inertia.copy())
        self.payload = payload
        self.attach_payload(payload.mass_kg, payload.com_m, payload.inertia_kg_m2)
        self.limits = resolve_limits(
            description_limits(model, self.joint_names), drives, model=model
        )
        self.data = model.createData()

    # ------------------------------------------------------------------ base and gravity
    @property
    def transform_base_to_world(self) -> np.ndarray:
        """Mounting of the base in the world (4, 4), [m] (read-only; assign to change)."""
        return self._transform_base_to_world

    @transform_base_to_world.setter
    def transform_base_to_world(self, value: np.ndarray | None) -> None:
        T = np.eye(4) if value is None else np.asarray(value, dtype=float)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise InputError("transform_base_to_world must be a finite (4, 4) array")
        R = T[:3, :3]
        rigid = np.allclose(R.T @ R, np.eye(3), atol=1e-6) and np.linalg.det(R) > 0
        if not rigid or not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0], atol=1e-12):
            raise InputError(
                "transform_base_to_world must be a rigid transform (rotation, [0 0 0 1])"
            )
        self._transform_base_to_world = _frozen(T)
        self._update_gravity()

    @property
    def gravity_in_world(self) -> np.ndarray:
        """Gravity in the world (3,) in [m/s^2] (read-only; assign to change)."""
        return self._gravity_in_world

    @gravity_in_world.setter
    def gravity_in_world(self, value) -> None:
        g = np.asarray(value, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise InputError("gravity_in_world must be a finite (3,) array in [m/s^2]")
        self._gravity_in_world = _frozen(g)
        self._update_gravity()

    def _update_gravity(self) -> None:
        """``model.gravity = R_base_in_world^T g_world`` (the class docstring's convention)."""
        R = self._transform_base_to_world[:3, :3]
        self.model.gravity = pin.Motion(R.T @ self._gravity_in_world, np.zeros(3))

    # ------------------------------------------------------------------ basic facts
    @property
    def n_joints(self) -> int:
        return self.model.nq

    def __repr__(self) -> str:
        return (
            f"Robot({self.name!r}, n_joints={self.n_joints}, tool={self.tool_frame!r}, "
            f"payload={self.payload.mass_kg:g} kg)"
        )

    @property
    def total_mass_kg(self) -> float:
        """Mass of all moving links, payload included, in [kg]."""
        return float(sum(inertia.mass for inertia in self.model.inertias[1:]))

    def joint_index(self, name: str | int) -> int:
        """Index of a joint by name or 1-based number; :class:`InputError` if unknown."""
        if isinstance(name, (int, np.integer)):
            if 1 <= int(name) <= self.n_joints:
                return int(name) - 1
        elif name in self.joint_names:
            return self.joint_names.index(name)
        elif self.dh is not None and name in self.dh.labels:
            return self.dh.labels.index(name)
        raise InputError(
            f"{self.name}: unknown joint {name!r} (joints: {', '.join(self.joint_names)})"
        )

    def frame_id(self, frame: str | None) -> int:
        """Pinocchio frame index of ``frame`` (the tool frame if None)."""
        if frame is None:
            return self.tool_frame_id
        if not self.model.existFrame(frame):
            raise InputError(f"{self.name}: unknown frame {frame!r}")
        return self.model.getFrameId(frame)

    def check_q(self, q, *, name: str = "q", batch: bool = False) -> np.ndarray:
        """Validate joint positions: shape ``(n_joints,)`` (or ``(n, n_joints)``), finite."""
        q = np.asarray(q, dtype=float)
        ok = q.shape[-1:] == (self.n_joints,) and (q.ndim == 1 or (batch and q.ndim == 2))
        if not ok:
            want = f"(n, {self.n_joints})" if batch else f"({self.n_joints},)"
            raise InputError(f"{name} has shape {q.shape}, expected {want} for {self.name}")
        if not np.all(np.isfinite(q)):
            raise InputError(f"{name} contains NaN or infinite values")
        return q

    def within_limits(self, q, tol: float = 1e-9) -> np.ndarray:
        """True where every joint of ``q`` (..., n_joints) lies in its range (+- tol)."""
        q = np.asarray(q)
        return np.all(
            (q >= self.limits.lower_rad - tol) & (q <= self.limits.upper_rad + tol), axis=-1
        )

    def random_q(self, rng: np.random.Generator, n: int | None = None) -> np.ndarray:
        """Uniform random configurations inside the joint ranges (one turn for an unbounded joint):
        (n_joints,) or (n, n_joints)."""
        size = (self.n_joints,) if n is None else (n, self.n_joints)
        lo, hi = self.limits.sample_lower_rad, self.limits.sample_upper_rad
        return lo + (hi - lo) * rng.random(size)

    # ------------------------------------------------------------------ tool and payload
    def set_tool(self, transform_tool_to_flange_default: np.ndarray) -> None:
        """Move the tool frame: its new placement is the original tool placement times this
        (4, 4) transform (thesis 3.5, ``T_tool``). The payload stays where it was in the tool."""
        T = np.asarray(transform_tool_to_flange_default, float)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise InputError("tool transform must be a finite (4, 4) array")
        f = self.model.frames[self.tool_frame_id]
        f.placement = self._tool_placement0 * pin.SE3(T[:3, :3], T[:3, 3])
        self.model.frames[self.tool_frame_id] = f
        self.attach_payload(self.payload.mass_kg, self.payload.com_m, self.payload.inertia_kg_m2)

    def attach_payload(self, mass_kg: float, com_m=(0.0, 0.0, 0.0), inertia_kg_m2=None) -> None:
        """Replace the payload carried at the tool frame.

        Parameters
        ----------
        mass_kg : float
            Payload mass in [kg] (0 removes it).
        com_m : array (3,)
            Centre of mass in the tool frame, in [m].
        inertia_kg_m2 : array (3, 3), optional
            Rotational inertia about the centre of mass in [kg m^2]; default: a solid sphere of
            30 mm radius.
        """
        mass = float(mass_kg)
        if not math.isfinite(mass) or mass < 0:
            raise InputError(f"payload mass must be a finite number >= 0, not {mass_kg!r}")
        com = np.asarray(com_m, dtype=float).reshape(-1)
        if com.shape != (3,) or not np.all(np.isfinite(com)):
            raise InputError("payload centre of mass must be a finite (3,) array in [m]")
        if inertia_kg_m2 is None:
            inertia = np.eye(3) * 0.4 * mass * 0.03**2
        else:
            inertia = np.asarray(inertia_kg_m2, dtype=float)
            if inertia.shape != (3, 3) or not np.all(np.isfinite(inertia)):
                raise InputError("payload inertia must be a finite (3, 3) array in [kg m^2]")
        self.payload = Payload(mass, com, inertia)
        tool_in_joint = self.model.frames[self.tool_frame_id].placement
        y = self.payload.spatial_inertia().se3Action(tool_in_joint)
        self.model.inertias[self._tool_parent] = self._bare_inertia + y
        if hasattr(self, "data"):
            self.data = self.model.createData()

    def with_payload(self, mass_kg: float, com_m=None, inertia_kg_m2=None) -> Robot:
        """A copy of this robot carrying another payload (same centre of mass by default)."""
        other = self.copy()
        com = self.payload.com_m if com_m is None else com_m
        other.attach_payload(mass_kg, com, inertia_kg_m2)
        return other

    def copy(self) -> Robot:
        """An independent copy (model and data duplicated)."""
        other = copy.copy(self)
        other.model = self.model.copy()
        other._bare_inertia = self._bare_inertia.copy()
        other.data = other.model.createData()
        return other

    def with_limits(self, limits: Limits | None = None, /, **changes) -> Robot:
        """A copy with other limits: a whole :class:`Limits`, or some fields replaced
        (``velocity_rad_s=...``, recorded as their source; no hardware check -- a study's
        overrides go through :func:`armlab.robot.resolve_limits`)."""
        other = self.copy()
        base = self.limits if limits is None else limits
        if base.joint_names != tuple(self.joint_names):
            raise InputError(f"limits are for joints {list(base.joint_names)}, not {self.name}'s")
        other.limits = base.with_values("Robot.with_limits", **changes) if changes else base
        return other

    def drive(self, joint) -> Drive:
        """The drive train of a joint (name or 1-based number)."""
        if self.drives is None:
            raise RobotDescriptionError(f"{self.name}: no drives file (drives.toml) for this robot")
        return self.drives[self.joint_names[self.joint_index(joint)]]


#: Prefix of a URDF shipped by the ``example-robot-data`` package
#: (``erd:ur_description/urdf/ur5_robot.urdf``).
ERD_PREFIX = "erd:"


def example_robot_data_urdf(relative: str) -> Path:
    """The path of a URDF of the ``example-robot-data`` package (a test dependency of armlab),
    ``relative`` to its ``robots/`` folder (``ur_description/urdf/ur5_robot.urdf``).

    Raises
    ------
    RobotDescriptionError
        The package is not installed or holds no such file.
    """
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        dist = distribution("example-robot-data")
    except PackageNotFoundError:
        raise RobotDescriptionError(
            f"{ERD_PREFIX}{relative}: the example-robot-data package is not installed "
            "(pip install example-robot-data)"
        ) from None
    path = Path(str(dist.locate_file(f"cmeel.prefix/share/example-robot-data/robots/{relative}")))
    if not path.is_file():
        raise RobotDescriptionError(f"{ERD_PREFIX}{relative}: no such file in example-robot-data")
    return path


def _find_urdf(name_or_path: str | os.PathLike) -> tuple[str, Path, Path | None]:
    """(name, urdf path, description folder or None)."""
    s = str(name_or_path)
    if s.startswith(ERD_PREFIX):
        s = str(example_robot_data_urdf(s[len(ERD_PREFIX) :]))
    path = Path(s)
    if path.suffix.lower() == ".urdf" or os.sep in s or path.exists():
        if path.is_dir():
            urdf = path / f"{path.name}.urdf"
            if not urdf.is_file():
                raise RobotDescriptionError(f"{path}: folder holds no {path.name}.urdf")
            return path.name, urdf, path
        if not path.is_file():
            raise RobotDescriptionError(f"{path}: URDF file not found")
        folder = path.parent if (path.parent / "drives.toml").is_file() else None
        return path.stem, path, folder
    folder = robot_desc_dir() / s
    urdf = folder / f"{s}.urdf"
    if not urdf.is_file():
        known = ", ".join(list_robots()) or "none"
        raise RobotDescriptionError(
            f"unknown robot {s!r}: not a URDF path and not in {robot_desc_dir()} (known: {known})"
        )
    return s, urdf, folder


#: Words that name a tool or flange frame, in the order :func:`default_tool_frame` prefers them.
TOOL_FRAME_WORDS = ("tcp", "tool", "end_effector", "eef", "ee", "flange", "hand")


def default_tool_frame(model: pin.Model) -> tuple[str, str]:
    """The tool frame a URDF implies when the study names none, and the rule that chose it.

    Among the frames carried by the last moving joint (those on its link and the fixed links
    below it), the first match in :data:`TOOL_FRAME_WORDS` order: a frame named ``tool0``
    (ROS-Industrial's convention, anywhere in the URDF), else one whose name has ``tcp``,
    ``tool``, ``end_effector``, ``eef``, ``ee``, ``flange`` or ``hand`` in it; else the link the
    last joint moves (its flange). The URDF's last frame is not a tool by itself: on many arms it
    is a finger tip (Kinova j2s6s200) or a camera.

    Returns
    -------
    frame : str
    rule : str
        How it was chosen, for the study's decisions (``"frame named tool0"`` ...).
    """
    if model.existFrame("tool0"):
        return "tool0", "the frame named tool0"
    last = model.njoints - 1
    kinds = (pin.FrameType.BODY, pin.FrameType.OP_FRAME)
    carried = [f for f in model.frames if f.parentJoint == last and f.type in kinds]
    for word in TOOL_FRAME_WORDS:
        for f in carried:
            parts = [p for p in f.name.lower().replace("-", "_").split("_") if p]
            if word in parts or (word != "ee" and word in f.name.lower()):
                return f.name, f"the last joint's frame named like a tool ({word!r})"
    if carried:  # the link the last joint moves
        return carried[0].name, (
            f"no tool frame in the URDF: the link of the last moving joint {model.names[last]!r}"
        )
    return model.frames[len(model.frames) - 1].name, "the URDF's last frame"


def load_robot(
    name_or_path: str | os.PathLike,
    payload_kg: float | None = None,
    *,
    tool_frame: str | None = None,
    lock_joints: list[str] | tuple[str, ...] = (),
    transform_base_to_world: np.ndarray | None = None,
) -> Robot:
    """Load a robot by built-in name (``"teachbot6"``) or URDF path.

    Parameters
    ----------
    name_or_path : str or path
        A folder name under ``robot_desc/``, the path of any URDF, or ``erd:<path>`` for a URDF
        of the ``example-robot-data`` package (``erd:ur_description/urdf/ur5_robot.urdf``). A
        ``drives.toml`` (and an ``mdh.toml``) beside the URDF are read too.
    payload_kg : float, optional
        Replace the description's payload mass (its centre of mass is kept; for a plain URDF it
        is put at the tool frame). None keeps the description's payload.
    tool_frame : str, optional
        The tool frame; default :func:`default_tool_frame` (``tool0`` if the URDF has it, else
        a frame of the last joint named like a tool, else that joint's link), recorded with its
        rule in ``robot.tool_frame_from``.
    lock_joints : sequence of str
        Joints to lock at 0 (gripper fingers, for example).
    transform_base_to_world : (4, 4) array, optional
        Mounting of the base in the world (thesis 3.5 ``T_base``).

    Raises
    ------
    RobotDescriptionError
        Unknown name, missing or malformed URDF/drives file, unsupported joints, a physically
        invalid URDF (negative or zero mass on a moving link, an inertia that is not positive
        definite or breaks the triangle inequality, a zero or non-unit joint axis, NaN/inf,
        lower limit above upper: :mod:`armlab.robot.urdf_check`); a robot, joint or tool frame
        name outside the name policy, or two joints equal in C (:mod:`armlab.names`). The URDF
        parser's own console output is captured, never printed; its first error line is the
        message.
    """
    name, urdf, folder = _find_urdf(name_or_path)
    # the names that reach the exports (armlab.names): robot, moving joints, tool frame
    what = "robot name (the URDF's file or folder name)"
    check_name(name, what, one_line(str(urdf)), RobotDescriptionError)
    try:
        text = urdf.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise RobotDescriptionError(f"{urdf}: cannot read ({exc})") from None
    if "<robot" not in text:
        raise RobotDescriptionError(f"{urdf}: not a URDF (no <robot> element)")
    check_urdf(text, urdf)  # physical validity; what the C++ parser would drop silently
    rewritten, continuous = revolute_continuous(text)
    model = build_model_quietly(urdf, rewritten if continuous else None)
    unbounded = [j for j, bounded in continuous.items() if not bounded]
    for j in unbounded:  # no position limit at all (revolute_continuous)
        if model.existJointName(j):
            i = model.joints[model.getJointId(j)].idx_q
            model.lowerPositionLimit[i] = -np.inf
            model.upperPositionLimit[i] = np.inf
    if lock_joints:
        unknown = [j for j in lock_joints if not model.existJointName(j)]
        if unknown:
            raise InputError(f"{urdf}: cannot lock unknown joint(s) {unknown}")
        ids = [model.getJointId(j) for j in lock_joints]
        model = pin.buildReducedModel(model, ids, pin.neutral(model))
    if model.nq == 0:
        raise RobotDescriptionError(f"{urdf}: the model has no moving joints")
    check_names(list(model.names[1:]), "joint name", str(urdf), RobotDescriptionError)
    if model.nq != model.nv:
        bad = [model.names[j] for j in range(1, model.njoints) if model.joints[j].nq != 1]
        raise RobotDescriptionError(
            f"{urdf}: only 1-DOF revolute/prismatic joints are supported (not: {bad}); "
            "lock them or describe them as revolute/prismatic joints"
        )
    free = np.array([n in unbounded for n in model.names[1:]], bool)
    limits_bad = ~np.isfinite(model.lowerPositionLimit) | ~np.isfinite(model.upperPositionLimit)
    limits_bad &= ~free
    if np.any(limits_bad):
        names = [model.names[i + 1] for i in np.flatnonzero(limits_bad)]
        raise RobotDescriptionError(f"{urdf}: joint(s) without finite range: {names}")
    tool_from = "given"
    if tool_frame is None:
        tool_frame, tool_from = default_tool_frame(model)
    check_name(tool_frame, "tool frame name", str(urdf), RobotDescriptionError)
    # pinocchio keeps a fixed link's inertia on the frame of the fixed joint that carries it
    payload_frame = next(
        (
            f.name
            for f in model.frames
            if f.name in ("payload_joint", "payload") and f.inertia.mass > 0
        ),
        None,
    )
    drives = dh = None
    if folder is not None:
        joint_names = list(model.names[1:])
        if (folder / "drives.toml").is_file():
            drives = read_drives(folder / "drives.toml", joint_names)
        if (folder / "mdh.toml").is_file():
            dh = read_dh_table(folder / "mdh.toml")
            if list(dh.joint_names) != joint_names:
                raise RobotDescriptionError(
                    f"{folder / 'mdh.toml'}: joints {list(dh.joint_names)} differ from the URDF's "
                    f"{joint_names}"
                )
    robot = Robot(
        name,
        model,
        urdf_path=urdf,
        tool_frame=tool_frame,
        drives=drives,
        dh=dh,
        payload_frame=payload_frame,
        transform_base_to_world=transform_base_to_world,
    )
    robot.continuous_joints = {j: b for j, b in continuous.items() if j in robot.joint_names}
    robot.tool_frame_from = tool_from
    if payload_kg is not None:
        p = robot.payload
        scale = float(payload_kg) / p.mass_kg if p.mass_kg > 0 else 0.0
        inertia = p.inertia_kg_m2 * scale if p.mass_kg > 0 else None
        robot.attach_payload(payload_kg, p.com_m, inertia)
    return robot
