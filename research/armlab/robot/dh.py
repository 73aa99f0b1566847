"""Denavit-Hartenberg tables and their conversion to URDF.

Two conventions are read:

* **modified** (Craig): row ``i`` holds ``a_{i-1}, alpha_{i-1}, theta_i offset, d_i`` and
  ``T_{i-1,i} = RotX(alpha_{i-1}) TransX(a_{i-1}) RotZ(theta_i) TransZ(d_i)`` (thesis 3.2);
* **classic** (Denavit-Hartenberg 1955): row ``i`` holds ``theta_i offset, d_i, a_i, alpha_i`` and
  ``T_{i-1,i} = RotZ(theta_i) TransZ(d_i) TransX(a_i) RotX(alpha_i)``.

A classic table is converted to the modified form (a classic row's ``a_i, alpha_i`` move to the
next row, the last ones become a fixed flange transform), so one code path writes the URDF and
evaluates the closed-form forward kinematics. The joint variable is ``q_i`` and the DH angle is
``theta_i = q_i + offset_i``.

The table file is TOML with lengths in mm and angles in deg (the units of a drawing); inside, the
:class:`DHTable` holds SI values (m, rad).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from armlab.errors import RobotDescriptionError
from armlab.tomlfile import read_toml

__all__ = [
    "DHTable",
    "LumpedMass",
    "VISUAL_MATERIALS",
    "dh_collisions",
    "dh_visuals",
    "mdh_transforms",
    "read_dh_table",
    "urdf_from_dh",
]


@dataclass(frozen=True)
class LumpedMass:
    """A lumped mass carried by one link.

    Attributes
    ----------
    name : str
        What the mass stands for (``"joint3_drive"``).
    link : int
        Index of the carrying link (0 = base, i = link moved by joint i).
    mass_kg : float
        Mass in [kg].
    xyz_m : tuple of float
        Centre of mass in the link's DH frame, in [m].
    shape : str
        ``"sphere"`` (``size_m`` = radius) or ``"rod"`` (``size_m`` = length along ``axis``):
        the rotational inertia given to the lump, small next to its transport inertia.
    """

    name: str
    link: int
    mass_kg: float
    xyz_m: tuple[float, float, float]
    shape: str = "sphere"
    size_m: float = 0.02
    axis: str = "x"

    def inertia_about_com(self) -> np.ndarray:
        """Rotational inertia about the centre of mass, (3, 3) in [kg m^2]."""
        m, s = self.mass_kg, self.size_m
        if self.shape == "sphere":
            return np.eye(3) * 0.4 * m * s**2
        if self.shape == "rod":
            k = "xyz".index(self.axis)
            diag = np.full(3, m * s**2 / 12.0)
            diag[k] = 0.5 * m * (0.1 * s) ** 2  # thin rod: radius 10 % of its length
            return np.diag(diag)
        raise RobotDescriptionError(f"lumped mass {self.name!r}: unknown shape {self.shape!r}")


@dataclass(frozen=True)
class DHTable:
    """A serial arm's geometry in the **modified** DH convention, SI units.

    Arrays are shape ``(n_joints,)``: ``a_m[i]`` is ``a_{i-1}`` in [m], ``alpha_rad[i]`` is
    ``alpha_{i-1}`` in [rad], ``offset_rad[i]`` the constant part of ``theta_i`` in [rad],
    ``d_m[i]`` is ``d_i`` in [m]; ``lower_rad``/``upper_rad`` the joint range in [rad].
    ``transform_tool_to_last`` is the fixed (4, 4) transform of the tool point in the last DH
    frame (thesis 3.5 ``T_tool``); ``transform_flange_to_last`` that of the mounting flange.
    """

    name: str
    joint_names: tuple[str, ...]
    a_m: np.ndarray
    alpha_rad: np.ndarray
    offset_rad: np.ndarray
    d_m: np.ndarray
    lower_rad: np.ndarray
    upper_rad: np.ndarray
    velocity_rad_s: np.ndarray | None = None
    labels: tuple[str, ...] = ()
    transform_flange_to_last: np.ndarray = field(default_factory=lambda: np.eye(4))
    transform_tool_to_last: np.ndarray = field(default_factory=lambda: np.eye(4))
    masses: tuple[LumpedMass, ...] = ()
    payload: LumpedMass | None = None
    source: str = ""

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    def fk(self, q: np.ndarray, *, upto: int | None = None) -> np.ndarray:
        """Closed-form forward kinematics from the table alone (no Pinocchio).

        Parameters
        ----------
        q : array (n_joints,) or (n_samples, n_joints)
            Joint positions in [rad].
        upto : int, optional
            Return the DH frame ``upto`` (1-based) instead of the tool point.

        Returns
        -------
        array (4, 4) or (n_samples, 4, 4)
            ``T = T_01 T_12 ... T_(n-1)n T_tool`` in the base frame.
        """
        q = np.asarray(q, dtype=float)
        single = q.ndim == 1
        q2 = np.atleast_2d(q)
        frames = mdh_transforms(self.a_m, self.alpha_rad, self.d_m, q2 + self.offset_rad)
        n = self.n_joints if upto is None else upto
        T = np.broadcast_to(np.eye(4), (q2.shape[0], 4, 4)).copy()
        for i in range(n):
            T = T @ frames[:, i]
        if upto is None:
            T = T @ self.transform_tool_to_last
        return T[0] if single else T


def mdh_transforms(a, alpha, d, theta) -> np.ndarray:
    """Per-joint modified-DH transforms, vectorised.

    ``T_{i-1,i} = RotX(alpha_{i-1}) TransX(a_{i-1}) RotZ(theta_i) TransZ(d_i)`` (Craig 3.6).

    Parameters
    ----------
    a, alpha, d : array (n_joints,) or (n_samples, n_joints)
        Link lengths in [m], twists in [rad], offsets in [m].
    theta : array (n_samples, n_joints)
        DH joint angles in [rad].

    Returns
    -------
    array (n_samples, n_joints, 4, 4)
    """
    theta = np.atleast_2d(theta)
    a, alpha, d = (np.broadcast_to(x, theta.shape) for x in (a, alpha, d))
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    T = np.zeros(theta.shape + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 2], T[..., 0, 3] = ct, -st, 0.0, a
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st * ca, ct * ca, -sa, -sa * d
    T[..., 2, 0], T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = st * sa, ct * sa, ca, ca * d
    T[..., 3, 3] = 1.0
    return T


def _transform(xyz_m, rpy_rad) -> np.ndarray:
    r, p, y = rpy_rad
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = Rz @ Ry @ Rx
    T[:3, 3] = xyz_m
    return T


def _rpy(R: np.ndarray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (R = Rz(y) Ry(p) Rx(r)) of a rotation matrix."""
    p = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if abs(math.cos(p)) < 1e-12:  # gimbal lock: put everything in yaw
        return 0.0, p, math.atan2(-R[0, 1], R[1, 1])
    return math.atan2(R[2, 1], R[2, 2]), p, math.atan2(R[1, 0], R[0, 0])


def _num(x: float) -> str:
    """A float as URDF text, exact to 1e-15 and free of '-0'."""
    s = f"{x:.15g}"
    return "0" if s in ("-0", "0") else s


def _finite(value, what: str, path: Path) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise RobotDescriptionError(f"{path}: {what} is not a number: {value!r}") from None
    if not math.isfinite(v):
        raise RobotDescriptionError(f"{path}: {what} is not finite ({value!r})")
    return v


def read_dh_table(path: str | Path) -> DHTable:
    """Read a DH table file (TOML; mm and deg) into a :class:`DHTable` (m, rad).

    The file has ``name``, ``convention = "modified" | "classic"`` and one ``[[joint]]`` per
    joint with ``name``, ``a_mm``, ``alpha_deg``, ``theta_offset_deg``, ``d_mm``, ``lower_deg``,
    ``upper_deg`` and optionally ``velocity_rad_s`` and ``label``. Optional ``[tool]`` and
    ``[flange]`` tables give ``xyz_mm`` and ``rpy_deg`` in the last DH frame; optional
    ``[[mass]]`` entries give lumped masses (``link``, ``mass_kg``, ``xyz_mm`` in that link's
    DH frame, ``shape``, ``size_mm``, ``axis``) and ``[payload]`` the payload body on the tool.
    """
    path = Path(path)
    data = read_toml(path, "DH table file")
    convention = data.get("convention", "modified")
    if convention not in ("modified", "classic"):
        raise RobotDescriptionError(
            f"{path}: convention must be 'modified' or 'classic', not {convention!r}"
        )
    rows = data.get("joint")
    if not rows:
        raise RobotDescriptionError(f"{path}: no [[joint]] rows")
    cols: dict[str, list[float]] = {k: [] for k in ("a", "alpha", "off", "d", "lo", "hi", "v")}
    names, labels = [], []
    for i, row in enumerate(rows, start=1):
        where = f"joint {i} ({row.get('name', '?')})"
        for key in (
            "name",
            "a_mm",
            "alpha_deg",
            "theta_offset_deg",
            "d_mm",
            "lower_deg",
            "upper_deg",
        ):
            if key not in row:
                raise RobotDescriptionError(f"{path}: {where} has no {key!r}")
        names.append(str(row["name"]))
        labels.append(str(row.get("label", row["name"])))
        cols["a"].append(_finite(row["a_mm"], f"{where} a_mm", path) / 1000.0)
        cols["alpha"].append(math.radians(_finite(row["alpha_deg"], f"{where} alpha_deg", path)))
        cols["off"].append(
            math.radians(_finite(row["theta_offset_deg"], f"{where} theta_offset_deg", path))
        )
        cols["d"].append(_finite(row["d_mm"], f"{where} d_mm", path) / 1000.0)
        lo = math.radians(_finite(row["lower_deg"], f"{where} lower_deg", path))
        hi = math.radians(_finite(row["upper_deg"], f"{where} upper_deg", path))
        if not lo < hi:
            raise RobotDescriptionError(f"{path}: {where} lower_deg must be below upper_deg")
        cols["lo"].append(lo)
        cols["hi"].append(hi)
        cols["v"].append(
            _finite(row.get("velocity_rad_s", "nan"), "v", path)
            if "velocity_rad_s" in row
            else math.nan
        )
    if len(set(names)) != len(names):
        raise RobotDescriptionError(f"{path}: joint names are not unique: {names}")
    a, alpha = np.array(cols["a"]), np.array(cols["alpha"])
    off, d = np.array(cols["off"]), np.array(cols["d"])
    last_extra = np.eye(4)
    if convention == "classic":
        # classic row i: (theta_i, d_i, a_i, alpha_i). Modified row i needs a_{i-1}, alpha_{i-1}.
        last_extra = _transform((a[-1], 0, 0), (alpha[-1], 0, 0))
        a = np.concatenate([[0.0], a[:-1]])
        alpha = np.concatenate([[0.0], alpha[:-1]])

    def fixed(key: str) -> np.ndarray:
        spec = data.get(key, {})
        xyz = [_finite(x, f"[{key}] xyz_mm", path) / 1000.0 for x in spec.get("xyz_mm", [0, 0, 0])]
        rpy = [
            math.radians(_finite(x, f"[{key}] rpy_deg", path))
            for x in spec.get("rpy_deg", [0, 0, 0])
        ]
        return last_extra @ _transform(xyz, rpy)

    def lump(spec: dict, link: int | None = None) -> LumpedMass:
        name = spec.get("name", "payload")
        xyz = tuple(_finite(x, f"mass {name} xyz_mm", path) / 1000.0 for x in spec["xyz_mm"])
        mass = _finite(spec["mass_kg"], f"mass {name} mass_kg", path)
        if mass < 0:
            raise RobotDescriptionError(f"{path}: mass {name} is negative")
        link_index = int(spec["link"]) if link is None else link
        if not 0 <= link_index <= len(names):
            raise RobotDescriptionError(f"{path}: mass {name} on unknown link {link_index}")
        return LumpedMass(
            name=name,
            link=link_index,
            mass_kg=mass,
            xyz_m=xyz,  # type: ignore[arg-type]
            shape=spec.get("shape", "sphere"),
            size_m=_finite(spec.get("size_mm", 20), f"mass {name} size_mm", path) / 1000.0,
            axis=spec.get("axis", "x"),
        )

    masses = tuple(lump(m) for m in data.get("mass", []))
    payload = lump(data["payload"], link=len(names)) if "payload" in data else None
    v = np.array(cols["v"])
    return DHTable(
        name=str(data.get("name", path.stem)),
        joint_names=tuple(names),
        labels=tuple(labels),
        a_m=a,
        alpha_rad=alpha,
        offset_rad=off,
        d_m=d,
        lower_rad=np.array(cols["lo"]),
        upper_rad=np.array(cols["hi"]),
        velocity_rad_s=None if np.isnan(v).all() else v,
        transform_flange_to_last=fixed("flange"),
        transform_tool_to_last=fixed("tool"),
        masses=masses,
        payload=payload,
        source=str(path),
    )


def _inertial_xml(lumps: list[LumpedMass], indent: str) -> str:
    """One URDF <inertial> equivalent to several lumped masses (parallel-axis theorem)."""
    total = sum(m.mass_kg for m in lumps)
    if total <= 0:
        return ""
    com = np.asarray(sum(m.mass_kg * np.array(m.xyz_m) for m in lumps) / total)
    inertia = np.zeros((3, 3))
    for m in lumps:
        r = np.array(m.xyz_m) - com
        inertia += m.inertia_about_com() + m.mass_kg * (r @ r * np.eye(3) - np.outer(r, r))
    i = inertia
    return (
        f"{indent}<inertial>\n"
        f'{indent}  <origin xyz="{_num(com[0])} {_num(com[1])} {_num(com[2])}" rpy="0 0 0"/>\n'
        f'{indent}  <mass value="{_num(total)}"/>\n'
        f'{indent}  <inertia ixx="{_num(i[0, 0])}" ixy="{_num(i[0, 1])}" ixz="{_num(i[0, 2])}" '
        f'iyy="{_num(i[1, 1])}" iyz="{_num(i[1, 2])}" izz="{_num(i[2, 2])}"/>\n'
        f"{indent}</inertial>\n"
    )


def _origin_xml(T: np.ndarray) -> str:
    r, p, y = _rpy(T[:3, :3])
    x = T[:3, 3]
    return (
        f'<origin xyz="{_num(x[0])} {_num(x[1])} {_num(x[2])}" '
        f'rpy="{_num(r)} {_num(p)} {_num(y)}"/>'
    )


# ---------------------------------------------------------------------------- visual geometry
#: Colours of the generated visual geometry, URDF <material> rgba (0..1).
VISUAL_MATERIALS: dict[str, tuple[float, float, float, float]] = {
    "armlab_housing": (0.93, 0.55, 0.13, 1.0),
    "armlab_link": (0.78, 0.79, 0.82, 1.0),
    "armlab_tool": (0.22, 0.23, 0.26, 1.0),
}


def _arm_length_m(table: DHTable) -> float:
    """A table's characteristic length in [m]: sum of |a|, |d| and the tool point's distance
    from the last DH frame (0.822 m for teachbot6); the visual sizes scale with it."""
    tool = float(np.linalg.norm(table.transform_tool_to_last[:3, 3]))
    length = float(np.sum(np.abs(table.a_m)) + np.sum(np.abs(table.d_m))) + tool
    return length if length > 0 else 1.0


def _z_to(u: np.ndarray) -> np.ndarray:
    """The rotation (3, 3) turning +z onto the unit vector ``u`` about ``z x u``."""
    c = float(np.clip(u[2], -1.0, 1.0))
    axis = np.cross([0.0, 0.0, 1.0], u)
    s = float(np.linalg.norm(axis))
    if s < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    k = axis / s
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def _visual_xml(name: str, T: np.ndarray, shape: str, material: str) -> list[str]:
    return [
        f'    <visual name="{escape(name)}">',
        f"      {_origin_xml(T)}",
        f"      <geometry>{shape}</geometry>",
        f'      <material name="{material}"/>',
        "    </visual>",
    ]


def _rod_xml(name: str, p0, p1, radius_m: float, material: str) -> list[str]:
    """A cylinder of ``radius_m`` from point p0 to p1 (in the link frame); none if p0 = p1."""
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    length = float(np.linalg.norm(p1 - p0))
    if length < 1e-9:
        return []
    T = np.eye(4)
    T[:3, :3] = _z_to((p1 - p0) / length)
    T[:3, 3] = 0.5 * (p0 + p1)
    shape = f'<cylinder radius="{_num(radius_m)}" length="{_num(length)}"/>'
    return _visual_xml(name, T, shape, material)


def dh_visuals(table: DHTable, tool_frame: str = "tool0") -> dict[str, list[str]]:
    """Schematic visual geometry of a DH table: URDF ``<visual>`` lines per link name.

    Everything is derived from the table (no drawing of the real arm exists), with sizes
    proportional to the arm's length ``L`` (sum of ``|a|``, ``|d|`` and the tool point's distance
    from the last DH frame; 0.822 m for teachbot6):

    * a **joint housing** per joint: a cylinder along the joint axis ``z_i``, centred where the
      common normal ``a_{i-1}`` meets the axis (the point ``(a_{i-1}, 0, 0)`` of frame ``i-1``,
      where the lumped drive masses of teachbot6 sit), carried by the link before the joint;
      radius ``0.045 L`` tapering linearly to 60 % at the last joint, length ``0.11 L`` (same
      taper); under joint 1 a base plate (radius 1.5 x the housing's, thickness ``0.03 L``);
    * **links** as cylinders along the MDH geometry (radius ``0.03 L``, same taper): the common
      normal ``a_{i-1}`` along ``x_{i-1}`` belongs to link ``i-1``, the offset ``d_i`` along the
      axis ``z_i`` to link ``i`` (the link that rotates about it); the last link gets a cylinder
      from its origin to the flange;
    * the **tool** as a small cylinder (radius ``0.01 L``) from the flange to the tool point,
      on the tool frame.

    Returns
    -------
    dict of str to list of str
        URDF lines (indented for a ``<link>``) of each link that has visual geometry; the
        materials are :data:`VISUAL_MATERIALS`.
    """
    n = table.n_joints
    L = _arm_length_m(table)
    taper = [1.0 - 0.4 * i / max(n - 1, 1) for i in range(n)]  # joint i+1 (0-based i)
    links = ["base_link"] + [f"link{i}" for i in range(1, n + 1)]
    out: dict[str, list[str]] = {name: [] for name in [*links, tool_frame]}
    h_len = 0.11 * L
    plate = 0.03 * L
    r_base = 1.5 * 0.045 * L
    out["base_link"] += _rod_xml(
        "base_plate",
        (0, 0, -0.5 * h_len - plate),
        (0, 0, -0.5 * h_len),
        r_base,
        "armlab_housing",
    )
    for i in range(n):  # joint i+1 and the links around it
        parent, child = links[i], links[i + 1]
        a, alpha, d = float(table.a_m[i]), float(table.alpha_rad[i]), float(table.d_m[i])
        r_parent, r_child = 0.03 * L * taper[max(i - 1, 0)], 0.03 * L * taper[i]
        # common normal a_i along x_i, on link i (the parent of joint i+1)
        out[parent] += _rod_xml(f"{parent}_a", (0, 0, 0), (a, 0, 0), r_parent, "armlab_link")
        # offset d_(i+1) along z_(i+1), on link i+1, ending at its origin
        out[child] += _rod_xml(f"{child}_d", (0, 0, -d), (0, 0, 0), r_child, "armlab_link")
        # the housing of joint i+1 on its parent, along the joint axis, where a_i meets it
        T_joint = _transform((0, 0, 0), (alpha, 0, 0)) @ _transform((a, 0, 0), (0, 0, 0))
        r_h = 0.045 * L * taper[i]
        shape = f'<cylinder radius="{_num(r_h)}" length="{_num(h_len * taper[i])}"/>'
        out[parent] += _visual_xml(
            f"{table.joint_names[i]}_housing", T_joint, shape, "armlab_housing"
        )
    last = links[-1]
    p_flange = table.transform_flange_to_last[:3, 3]
    out[last] += _rod_xml(
        f"{last}_flange", (0, 0, 0), p_flange, 0.03 * L * taper[-1], "armlab_link"
    )
    T_tool = table.transform_tool_to_last
    p_flange_in_tool = np.linalg.solve(T_tool, np.append(p_flange, 1.0))[:3]
    out[tool_frame] += _rod_xml("tool", p_flange_in_tool, (0, 0, 0), 0.01 * L, "armlab_tool")
    return {k: v for k, v in out.items() if v}


def dh_collisions(visual_lines: dict[str, list[str]]) -> dict[str, list[str]]:
    """URDF ``<collision>`` lines of the same primitives as :func:`dh_visuals`' (same names,
    origins and geometry, no material): the collision geometry of a generated arm is its drawn
    geometry, so what the 3D view shows is what :mod:`armlab.collision` checks."""
    out: dict[str, list[str]] = {}
    for link, lines in visual_lines.items():
        out[link] = [
            line.replace("<visual ", "<collision ").replace("</visual>", "</collision>")
            for line in lines
            if "<material " not in line
        ]
    return out


def urdf_from_dh(
    table: DHTable,
    *,
    effort_Nm: np.ndarray | None = None,
    velocity_rad_s: np.ndarray | None = None,
    tool_frame: str = "tool0",
    visuals: bool = True,
) -> str:
    """Write a URDF for a modified-DH table.

    Link ``i`` carries DH frame ``i``; joint ``i`` has origin
    ``RotX(alpha_{i-1}) TransX(a_{i-1}) TransZ(d_i) RotZ(offset_i)`` in frame ``i-1`` and axis z,
    so the URDF's joint value is ``q_i = theta_i - offset_i``. Fixed frames ``flange`` and
    ``tool_frame`` hang on the last link, and a ``payload`` link (the payload body of the table)
    on the tool frame.

    Parameters
    ----------
    table : DHTable
    effort_Nm, velocity_rad_s : array (n_joints,), optional
        ``<limit effort velocity>`` in [N m] and [rad/s]; velocity defaults to the table's.
    tool_frame : str
        Name of the tool point's fixed frame.
    visuals : bool
        Give the links ``<visual>`` primitives drawn from the table (:func:`dh_visuals`: joint
        housings, links, tool) and the same primitives as ``<collision>`` elements
        (:func:`dh_collisions`). They change neither the kinematics nor the ``<inertial>``
        elements.

    Returns
    -------
    str
        The URDF text.
    """
    n = table.n_joints
    vel = table.velocity_rad_s if velocity_rad_s is None else np.asarray(velocity_rad_s)
    if vel is None:
        raise RobotDescriptionError(f"{table.name}: no velocity limits for the URDF")
    eff = np.zeros(n) if effort_Nm is None else np.asarray(effort_Nm, dtype=float)
    links = ["base_link"] + [f"link{i}" for i in range(1, n + 1)]
    out = [
        '<?xml version="1.0"?>',
        f"<!-- Generated by armlab.robot.urdf_from_dh from {Path(table.source).name or 'a table'}"
        ": do not edit by hand. -->",
        f'<robot name="{escape(table.name)}">',
    ]
    shapes = dh_visuals(table, tool_frame) if visuals else {}
    collisions = dh_collisions(shapes)
    if visuals:
        for name, rgba in VISUAL_MATERIALS.items():
            out.append(f'  <material name="{name}">')
            out.append(f'    <color rgba="{" ".join(_num(c) for c in rgba)}"/>')
            out.append("  </material>")
    for k, link in enumerate(links):
        lumps = [m for m in table.masses if m.link == k]
        out.append(f'  <link name="{link}">')
        inertial = _inertial_xml(lumps, "    ")
        if inertial:
            out.append(inertial.rstrip("\n"))
        out += shapes.get(link, [])
        out += collisions.get(link, [])
        out.append("  </link>")
    for i in range(n):
        T = (
            _transform((0, 0, 0), (table.alpha_rad[i], 0, 0))
            @ _transform((table.a_m[i], 0, table.d_m[i]), (0, 0, 0))
            @ _transform((0, 0, 0), (0, 0, table.offset_rad[i]))
        )
        out += [
            f'  <joint name="{escape(table.joint_names[i])}" type="revolute">',
            f'    <parent link="{links[i]}"/>',
            f'    <child link="{links[i + 1]}"/>',
            f"    {_origin_xml(T)}",
            '    <axis xyz="0 0 1"/>',
            f'    <limit lower="{_num(table.lower_rad[i])}" upper="{_num(table.upper_rad[i])}" '
            f'effort="{_num(eff[i])}" velocity="{_num(vel[i])}"/>',
            "  </joint>",
        ]
    fixed = [("flange", table.transform_flange_to_last), (tool_frame, table.transform_tool_to_last)]
    for name, T in fixed:
        lines = shapes.get(name, []) + collisions.get(name, [])
        out += (
            [f'  <link name="{name}">', *lines, "  </link>"]
            if lines
            else [f'  <link name="{name}"/>']
        )
        out += [
            f'  <joint name="{name}_joint" type="fixed">',
            f'    <parent link="{links[-1]}"/>',
            f'    <child link="{name}"/>',
            f"    {_origin_xml(T)}",
            "  </joint>",
        ]
    if table.payload is not None:
        out += [
            '  <link name="payload">',
            _inertial_xml([table.payload], "    ").rstrip("\n"),
            "  </link>",
            '  <joint name="payload_joint" type="fixed">',
            f'    <parent link="{tool_frame}"/>',
            '    <child link="payload"/>',
            '    <origin xyz="0 0 0" rpy="0 0 0"/>',
            "  </joint>",
        ]
    out.append("</robot>")
    return "\n".join(out) + "\n"
