"""A URDF's physical validity, checked before Pinocchio reads it, and a quiet Pinocchio build.

Pinocchio's URDF parser (urdfdom) trusts its input: a negative mass, a zero joint axis or a
lower limit above the upper one load silently, and a number it cannot read (``nan``) makes it
drop the whole ``<inertial>`` after printing a line on the process' standard error. armlab
reads the XML itself first (:func:`check_urdf`) and refuses, with one
:class:`~armlab.errors.RobotDescriptionError` line naming the link or joint and the value:

* **numbers**: every number of a ``<link>`` or ``<joint>`` (origins, mass, inertia, axis,
  limits, dynamics, safety controller, calibration, mimic, geometry sizes) must be finite and
  have its count (3 for ``xyz``, ``rpy``, ``size``, ``scale``), anywhere in the robot;
* **masses**: negative on any link; on a *moving* link (one behind at least one non-fixed joint)
  ``0`` is allowed only for an explicitly massless link -- no ``<inertial>`` at all, or
  ``<mass value="0"/>`` with an all-zero (or no) ``<inertia>`` (the UR and Panda descriptions'
  ``tool0``/``ee_link``/``panda_link8`` frames); mass 0 with a nonzero inertia is refused;
* **inertia** of a moving link with mass > 0: the rotational inertia about the centre of mass
  must be positive semi-definite and its principal moments ``I1 <= I2 <= I3`` must satisfy the
  triangle inequality ``I1 + I2 >= I3`` -- together the physical consistency of a rigid body
  (its pseudo-inertia is positive semi-definite: Wensing, Kim, Slotine, IEEE RA-L 3(1), 2018;
  Traversaro et al., IROS 2016). Both to a rounding allowance of ``1e-6 (|I1| + |I2| + |I3|)
  + 1e-12 kg m^2``. Zero principal moments are accepted: a point mass (all zero: the tool and
  sensor frames of many published arms, SO-101's ``gripper_frame_link``) and a thin rod are the
  consistent limits of real bodies; a negative moment is refused. Links fixed to the root never
  move (Pinocchio merges them into the fixed base), so only their numbers are checked;
* **joint axes** (revolute, continuous, prismatic, planar): the zero vector is refused; an axis
  whose length is within ``1e-3`` of 1 is a rounded unit vector and accepted (Pinocchio
  normalises it); any other length (``"0 0 2"``) is refused, with the unit vector to write,
  since Pinocchio would silently normalise it and the author may have meant another direction;
* **joint limits** of revolute and prismatic joints: ``lower > upper`` and a negative
  ``effort`` or ``velocity`` (magnitudes; 0 means unknown) are refused.

:func:`build_model_quietly` then runs ``pinocchio.buildModelFromUrdf`` with the C-level file
descriptors 1 and 2 redirected into a temporary file: the parser's own lines never reach the
terminal; its first ``Error`` line becomes the message of the error raised (also when the
parser carried on after it, having dropped part of the description).
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import math
import os
import sys
import tempfile
import threading
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin

from armlab.errors import RobotDescriptionError

__all__ = ["check_urdf", "build_model_quietly", "revolute_continuous", "UNBOUNDED_SENTINEL_RAD"]

#: The range a continuous joint without ``<limit lower upper>`` is built with before its limits
#: become +-inf (:func:`revolute_continuous`): far beyond any motion, never a real limit.
UNBOUNDED_SENTINEL_RAD = 1.0e9

_log = logging.getLogger(__name__)

#: element tag -> {numeric attribute: count of numbers (0: one or more)}
_NUMBERS: dict[str, dict[str, int]] = {
    "origin": {"xyz": 3, "rpy": 3},
    "mass": {"value": 1},
    "inertia": {k: 1 for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")},
    "axis": {"xyz": 3},
    "limit": {"lower": 1, "upper": 1, "effort": 1, "velocity": 1},
    "dynamics": {"damping": 1, "friction": 1},
    "safety_controller": {
        "soft_lower_limit": 1,
        "soft_upper_limit": 1,
        "k_position": 1,
        "k_velocity": 1,
    },
    "calibration": {"rising": 1, "falling": 1, "reference_position": 1},
    "mimic": {"multiplier": 1, "offset": 1},
    "box": {"size": 3},
    "cylinder": {"radius": 1, "length": 1},
    "sphere": {"radius": 1},
    "capsule": {"radius": 1, "length": 1},
    "mesh": {"scale": 3},
}
_INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
_AXIS_JOINTS = ("revolute", "continuous", "prismatic", "planar")
_AXIS_TOL = 1e-3  # |norm - 1| of an axis accepted as a rounded unit vector
#: rounding allowance of the inertia checks: relative to the sum of |principal moments|, plus
#: an absolute [kg m^2] one (1 g at 1 mm is 1e-9 kg m^2) for tensors written as zeros
_INERTIA_RTOL, _INERTIA_ATOL = 1e-6, 1e-12


def _numbers(raw: str, count: int) -> list[float] | None:
    """The finite numbers of an attribute, or None if one is not a finite number or the count
    (``count`` > 0) is wrong."""
    try:
        values = [float(t) for t in raw.split()]
    except ValueError:
        return None
    if not values or (count and len(values) != count):
        return None
    return values if all(math.isfinite(v) for v in values) else None


def _check_numbers(where: str, owner: str, element: ET.Element) -> None:
    for el in element.iter():
        for attr, count in _NUMBERS.get(el.tag, {}).items():
            raw = el.get(attr)
            if raw is not None and _numbers(raw, count) is None:
                what = "a finite number" if count == 1 else f"{count} finite numbers"
                raise RobotDescriptionError(
                    f'{where}: {owner} <{el.tag} {attr}="{raw}">: not {what}'
                )


def _value(el: ET.Element | None, attr: str, default: float) -> float:
    """An attribute already checked by :func:`_check_numbers` (default if absent)."""
    if el is None or el.get(attr) is None:
        return default
    return float(str(el.get(attr)))


def _moving_links(root: ET.Element) -> set[str]:
    """Links behind at least one non-fixed joint (walking the joint tree from its roots)."""
    parent_of: dict[str, tuple[str, str]] = {}  # child -> (parent, joint type)
    for joint in root.findall("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if parent is not None and child is not None:
            parent_of[str(child.get("link"))] = (str(parent.get("link")), joint.get("type", ""))
    moving = set()
    for name in parent_of:
        link, seen = name, set()
        while link in parent_of and link not in seen:
            seen.add(link)
            link, kind = parent_of[link]
            if kind != "fixed":
                moving.add(name)
                break
    return moving


def _check_inertial(where: str, name: str, inertial: ET.Element, moving: bool) -> None:
    owner = f"link {name!r}"
    mass_el = inertial.find("mass")
    if mass_el is None or mass_el.get("value") is None:
        raise RobotDescriptionError(f'{where}: {owner} has an <inertial> without <mass value="">')
    mass = _value(mass_el, "value", 0.0)
    raw = mass_el.get("value")
    if mass < 0:
        raise RobotDescriptionError(f"{where}: {owner} has a negative mass ({raw} kg)")
    if not moving:
        return
    inertia_el = inertial.find("inertia")
    ixx, ixy, ixz, iyy, iyz, izz = (_value(inertia_el, k, 0.0) for k in _INERTIA_KEYS)
    tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    if mass == 0:
        if np.any(tensor != 0):
            raise RobotDescriptionError(
                f"{where}: {owner} has mass 0 kg but a nonzero inertia; give a mass > 0, or "
                "declare a massless link with no <inertial> (or zero mass and zero inertia)"
            )
        return
    if inertia_el is None:
        raise RobotDescriptionError(f"{where}: {owner} has a mass ({raw} kg) but no <inertia>")
    moments = np.linalg.eigvalsh(tensor)  # ascending principal moments
    tol = _INERTIA_RTOL * float(np.sum(np.abs(moments))) + _INERTIA_ATOL
    if moments[0] < -tol:
        shown = ", ".join(f"{m:.4g}" for m in moments)
        raise RobotDescriptionError(
            f"{where}: {owner} inertia is not positive (semi-)definite: principal moments "
            f"{shown} kg m^2"
        )
    i1, i2, i3 = moments
    if i1 + i2 < i3 - tol:
        raise RobotDescriptionError(
            f"{where}: {owner} inertia breaks the triangle inequality: principal moments "
            f"{i1:.4g} + {i2:.4g} < {i3:.4g} kg m^2"
        )


def _check_joint(where: str, joint: ET.Element) -> None:
    owner = f"joint {joint.get('name')!r}"
    kind = joint.get("type", "")
    axis_el = joint.find("axis")
    if kind in _AXIS_JOINTS and axis_el is not None and axis_el.get("xyz") is not None:
        raw = str(axis_el.get("xyz"))
        axis = np.array([float(t) for t in raw.split()])
        norm = float(np.linalg.norm(axis))
        if norm == 0:
            raise RobotDescriptionError(
                f'{where}: {owner} <axis xyz="{raw}"> is the zero vector; give the unit direction '
                "of the motion"
            )
        if abs(norm - 1.0) > _AXIS_TOL:
            unit = " ".join(f"{v:.6g}" for v in axis / norm)
            raise RobotDescriptionError(
                f'{where}: {owner} <axis xyz="{raw}"> has length {norm:.6g}, not 1; write the '
                f'unit vector xyz="{unit}"'
            )
    limit = joint.find("limit")
    if limit is None or kind not in ("revolute", "prismatic"):
        return
    lower, upper = _value(limit, "lower", 0.0), _value(limit, "upper", 0.0)
    if lower > upper:
        raise RobotDescriptionError(
            f"{where}: {owner} limit lower {limit.get('lower')} > upper {limit.get('upper')}"
        )
    for key in ("effort", "velocity"):
        if _value(limit, key, 0.0) < 0:
            raise RobotDescriptionError(
                f"{where}: {owner} limit {key} {limit.get(key)} is negative (a magnitude; 0 means "
                "unknown)"
            )


def check_urdf(text: str, where: str | os.PathLike = "URDF") -> None:
    """Refuse a URDF that is not valid XML or not physically valid (module docstring).

    Parameters
    ----------
    text : str
        The URDF document.
    where : str or path
        The file, the head of every message.

    Raises
    ------
    RobotDescriptionError
        One line naming the link or joint and the offending value.
    """
    where = str(where)
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise RobotDescriptionError(f"{where}: malformed URDF (XML: {exc})") from None
    if root.tag != "robot":
        raise RobotDescriptionError(f"{where}: not a URDF (root element <{root.tag}>, not <robot>)")
    for link in root.findall("link"):
        _check_numbers(where, f"link {link.get('name')!r}", link)
    for joint in root.findall("joint"):
        _check_numbers(where, f"joint {joint.get('name')!r}", joint)
    moving = _moving_links(root)
    for link in root.findall("link"):
        inertial = link.find("inertial")
        if inertial is not None:
            name = str(link.get("name"))
            _check_inertial(where, name, inertial, name in moving)
    for joint in root.findall("joint"):
        _check_joint(where, joint)


# ----------------------------------------------------------------------------- quiet build
_FD_LOCK = threading.Lock()  # fds 1 and 2 are per process: one redirection at a time


def _flush_c_stdio() -> None:
    """Flush the C library's stdio buffers (what C++ code printed but did not flush yet)."""
    with contextlib.suppress(Exception):
        ctypes.CDLL(None).fflush(None)


def _parser_summary(lines: list[str]) -> str:
    """The first ``Error`` line of urdfdom's output without its tag (else its first line), and
    how many more error lines it printed."""
    text = [s.strip() for s in lines if s.strip()]
    errors = [s.split(":", 1)[-1].strip() for s in text if s.lower().startswith("error")]
    if not errors:
        return text[0] if text else ""
    more = len(errors) - 1
    return errors[0] + (f" (+{more} more parser error{'s' if more > 1 else ''})" if more else "")


def build_model_quietly(path: str | os.PathLike, text: str | None = None) -> pin.Model:
    """``pinocchio.buildModelFromUrdf(path)`` with the parser's console output captured.

    ``text``: the URDF's XML to build instead of the file's (``path`` then only names it in
    messages), e.g. with continuous joints rewritten (:func:`revolute_continuous`).

    The C-level stdout and stderr (file descriptors 1 and 2) point to a temporary file during
    the call (under a lock: they are shared by the threads of the process); nothing the parser
    prints reaches the terminal.

    Raises
    ------
    RobotDescriptionError
        The parser failed, or printed an ``Error`` line (it then dropped part of the
        description); the message is its first error line.
    """
    path = Path(path)
    model = None
    failure: BaseException | None = None
    with _FD_LOCK, tempfile.TemporaryFile() as tmp:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        saved: list[int] = []
        try:
            saved = [os.dup(1)]
            saved.append(os.dup(2))
        except OSError:  # no fd 1 or 2 (a detached process): build without capturing
            for fd in saved:
                os.close(fd)
            saved = []
        try:
            if saved:
                os.dup2(tmp.fileno(), 1)
                os.dup2(tmp.fileno(), 2)
            if text is None:
                model = pin.buildModelFromUrdf(str(path))
            else:
                model = pin.buildModelFromXML(text)
        except Exception as exc:  # pinocchio raises ValueError/RuntimeError with XML details
            failure = exc
        finally:
            if saved:
                _flush_c_stdio()
                os.dup2(saved[0], 1)
                os.dup2(saved[1], 2)
                for fd in saved:
                    os.close(fd)
        tmp.seek(0)
        lines = tmp.read().decode("utf-8", errors="replace").splitlines()
    errors = [s for s in lines if s.strip().lower().startswith("error")]
    if failure is not None or errors:
        summary = _parser_summary(lines)
        if not summary and failure is not None:
            text = str(failure).strip()
            summary = text.splitlines()[0] if text else type(failure).__name__
        raise RobotDescriptionError(f"{path}: malformed URDF ({summary})")
    if lines:
        _log.debug("%s: URDF parser output: %s", path, " | ".join(lines))
    assert model is not None
    return model


def revolute_continuous(text: str) -> tuple[str, dict[str, bool]]:
    """The URDF with every ``continuous`` joint rewritten as ``revolute``, and which had limits.

    Pinocchio builds a continuous joint as an unbounded revolute joint with two configuration
    variables (cos, sin), which armlab's planners, tables and checks cannot take. A continuous
    joint is one angle all the same:

    * with ``<limit lower upper>`` it is a revolute joint over that range (ROS' URDF spec
      ignores the range of a continuous joint; armlab honours it, as its docs say);
    * without them it is a revolute joint over ``+-UNBOUNDED_SENTINEL_RAD``, which
      :func:`armlab.robot.load_robot` turns into an unbounded range (``-inf, inf``): no
      position limit in plans and set-point tables.

    Returns
    -------
    text : str
        The rewritten XML (``text`` itself when it has no continuous joint).
    continuous : dict of str to bool
        Joint name -> True when the joint came with a range.
    """
    if "continuous" not in text:
        return text, {}
    try:
        root = ET.fromstring(text)
    except ET.ParseError:  # the parser's own message is the better one
        return text, {}
    found: dict[str, bool] = {}
    for joint in root.iter("joint"):
        if joint.get("type") != "continuous":
            continue
        joint.set("type", "revolute")
        limit = joint.find("limit")
        if limit is None:
            limit = ET.SubElement(joint, "limit", {"effort": "0", "velocity": "0"})
        bounded = limit.get("lower") is not None and limit.get("upper") is not None
        if not bounded:
            limit.set("lower", repr(-UNBOUNDED_SENTINEL_RAD))
            limit.set("upper", repr(UNBOUNDED_SENTINEL_RAD))
        for key in ("effort", "velocity"):
            if limit.get(key) is None:
                limit.set(key, "0")
        found[str(joint.get("name"))] = bounded
    if not found:
        return text, {}
    return ET.tostring(root, encoding="unicode"), found
