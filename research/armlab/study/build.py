"""The study's design from its spec: the robot (description + payload + base mounting + drive
changes + limits) and the controller, before any stage runs.

:func:`build_robot` and :func:`controller_profile` are the study's one robot and one
controller: every stage, ``design.json`` and ``armlab export`` (which rebuilds from that
record) see what they return.
"""

from __future__ import annotations

import functools
import math
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab.errors import SpecError
from armlab.kinematics.forward import rpy_to_matrix
from armlab.robot.controller import ControllerProfile
from armlab.study.spec import StudySpec

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["build_robot", "controller_profile", "base_transform", "rpy_to_matrix"]


@functools.lru_cache(maxsize=8)
def _load_cached(name: str, tool_frame: str | None, lock: tuple[str, ...]):
    from armlab.robot import load_robot

    return load_robot(name, tool_frame=tool_frame, lock_joints=lock)


def _per_joint(value, n: int, where: str) -> np.ndarray:
    scalar = np.isscalar(value)  # a plain bool: the TypeGuard narrows to types float() rejects
    a = np.full(n, float(value)) if scalar else np.asarray(value, float)
    if a.shape != (n,):
        raise SpecError(f"{where}: {a.size} values, the robot has {n} joints")
    return a


def _catalogue(spec: StudySpec):
    """The drive catalogue (``sizing.catalogue`` or the package's)."""
    from armlab.dynamics import load_catalogue as load

    name = spec.sizing.catalogue
    return load(None if name is None else spec.resolve(name))


def _find_part(kind: str, model: str, robot, spec: StudySpec, where: str):
    """(part, derating) of a motor or reducer by model name: the catalogue first, then the
    robot's own drives. A motor brings its derating (the maker's factor on its torque, e.g.
    0.8 on the thesis' joint-2 motor) along."""
    found: dict[str, tuple[Any, float]] = {}
    cat = _catalogue(spec)
    if cat is not None:
        for part in getattr(cat, f"{kind}s"):
            found[part.model] = (
                part,
                cat.derating.get(part.model, 1.0) if kind == "motor" else 1.0,
            )
    for d in robot.drives.values():
        found.setdefault(getattr(d, kind).model, (getattr(d, kind), d.derating))
    if model not in found:
        raise SpecError(f"{where}: unknown {kind} {model!r} (known: {', '.join(sorted(found))})")
    return found[model]


def build_robot(spec: StudySpec) -> Robot:
    """The study's robot: description + payload + drive changes + limit overrides.

    The limits are resolved again (:func:`armlab.robot.resolve_limits`) from the URDF and the
    drive train after the ``[drives]`` changes -- velocity = min(URDF, motor speed / ratio,
    reducer max input speed / ratio), torque = available torque (thesis table 4.3 rule) -- so
    the planners and checks see the new drive; then ``[limits]`` overrides, which may only
    tighten a hardware limit (:class:`SpecError` naming the key, joint and hardware limit).
    """
    from armlab.robot.drives import Drive

    base = _load_cached(
        spec.resolve(spec.robot.name), spec.robot.tool_frame, tuple(spec.robot.lock_joints)
    )
    robot = base.copy()
    base_to_world = base_transform(spec)
    if base_to_world is not None:  # gravity follows the mounting (robot.model.gravity)
        robot.transform_base_to_world = base_to_world
    p = spec.payload
    if p.mass_kg is not None or p.com_m is not None:
        mass = robot.payload.mass_kg if p.mass_kg is None else p.mass_kg
        com = robot.payload.com_m if p.com_m is None else np.asarray(p.com_m)
        robot.attach_payload(mass, com)
    if spec.robot.drives is not None:  # the study's drives file replaces the description's
        from armlab.robot.drives_file import read_drives

        robot.drives = read_drives(spec.resolve(spec.robot.drives), robot.joint_names)
    for joint in spec.drives:
        if joint not in robot.joint_names:
            raise SpecError(
                f"drives.{joint}: no joint {joint!r} in {robot.name} "
                f"(joints: {', '.join(robot.joint_names)})"
            )
    # with [sizing] select = true, a robot without drives and [drives.<joint>] tables for only
    # some joints gets its drives from the selection, which honours the tables given
    # (armlab.study.drive_choice.study_rules)
    partial = any(j not in spec.drives for j in robot.joint_names)
    if spec.drives and not (robot.drives is None and spec.sizing.select and partial):
        if robot.drives is None:
            robot.drives = _drives_from_study(robot, spec)
        drives = dict(robot.drives)
        for joint, change in spec.drives.items():
            where = f"drives.{joint}"
            old: Drive = drives[joint]
            new = old
            if change.motor is not None:
                motor, derating = _find_part("motor", change.motor, robot, spec, f"{where}.motor")
                new = replace(new, motor=motor, derating=derating)
            if change.reducer is not None:
                reducer, _ = _find_part("reducer", change.reducer, robot, spec, f"{where}.reducer")
                new = replace(new, reducer=reducer)
            new = changed_values(new, change)
            if change.amplifier is not None:
                new = replace(new, amplifier=_study_amplifier(spec, change.amplifier, where))
            drives[joint] = new
        robot.drives = drives
    _resolve_robot_limits(robot, spec)
    return robot


def changed_values(drive, change):
    """``drive`` with the numbers of a ``[drives.<joint>]`` table (ratio, efficiency, encoder,
    derating; not its part names) put in."""
    new = drive
    red = {k: getattr(change, k) for k in ("ratio", "efficiency") if getattr(change, k) is not None}
    if red:
        new = replace(new, reducer=replace(new.reducer, **red))
    enc = {
        k: getattr(change, k)
        for k in ("pulses_per_rev", "decoding")
        if getattr(change, k) is not None
    }
    if enc:
        new = replace(new, encoder=replace(new.encoder, **enc))
    if change.derating is not None:
        new = replace(new, derating=change.derating)
    return new


def _resolve_robot_limits(robot, spec: StudySpec) -> None:
    """``robot.limits`` from its description, drive train and the study's ``[limits]``; a drive
    value the drives file left out becomes the resolved (derived or study) one."""
    from armlab.robot.limits import description_limits, resolve_limits

    robot.limits = resolve_limits(
        description_limits(robot.model, robot.joint_names),
        robot.drives,
        overrides=vars(spec.limits),
        model=robot.model,
    )
    if robot.drives is not None:
        robot.drives = _complete_drives(robot.drives, robot.limits)


def _complete_drives(drives: dict, limits) -> dict:
    """The drives with an acceleration or jerk left out of the drives file (NaN) replaced by
    the robot's resolved limit (derived from the drive train, or the study's)."""
    out = {}
    for j, name in enumerate(limits.joint_names):
        d = drives[name]
        for key in ("acceleration_rad_s2", "jerk_rad_s3"):
            value = getattr(limits, key)
            if math.isnan(getattr(d, key)) and value is not None:
                d = replace(d, **{key: float(value[j])})
        out[name] = d
    return out


def _drives_from_study(robot, spec: StudySpec) -> dict:
    """A drive train built from ``[drives.<joint>]`` catalogue names alone, for a robot without
    one: every joint needs ``motor``, ``reducer`` and ``pulses_per_rev`` (decoding default 4, as
    in a drives file); acceleration and jerk are left to the limits (study or derived)."""
    from armlab.robot.drives import Drive, Encoder

    missing = [j for j in robot.joint_names if j not in spec.drives]
    if missing:
        raise SpecError(
            f"drives.{missing[0]}: missing; robot {robot.name} has no drive train, so every "
            f"joint needs [drives.<joint>] motor, reducer and pulses_per_rev (or give "
            "[robot] drives = <drives file> or [sizing] select = true)"
        )
    cat = _catalogue(spec)
    out = {}
    for joint in robot.joint_names:
        change = spec.drives[joint]
        where = f"drives.{joint}"
        for key in ("motor", "reducer", "pulses_per_rev"):
            if getattr(change, key) is None:
                raise SpecError(
                    f"{where}.{key}: missing (robot {robot.name} has no drive train to change)"
                )
        motor = cat.motor(str(change.motor), f"{where}.motor")
        reducer = cat.reducer(str(change.reducer), f"{where}.reducer")
        out[joint] = Drive(
            joint=joint,
            motor=motor,
            reducer=reducer,
            encoder=Encoder(int(change.pulses_per_rev or 0), int(change.decoding or 4)),
            acceleration_rad_s2=math.nan,
            jerk_rad_s3=math.nan,
            derating=cat.derating.get(motor.model, 1.0),
            amplifier=None
            if change.amplifier is None
            else _study_amplifier(spec, change.amplifier, where),
        )
    return out


def _study_amplifier(spec: StudySpec, value, where: str):
    """The amplifier a study's ``[drives.<joint>] amplifier`` names: a catalogue model or a
    table of :class:`~armlab.robot.drives.Amplifier` fields (checked as in a drives file)."""
    from armlab.errors import RobotDescriptionError
    from armlab.robot.drives_file import amplifier_from_dict

    try:
        if isinstance(value, dict):
            return amplifier_from_dict(dict(value), where, "amplifier")
        return _catalogue(spec).amplifier(str(value), f"{where}.amplifier")
    except RobotDescriptionError as exc:
        raise SpecError(str(exc)) from None


def base_transform(spec: StudySpec) -> np.ndarray | None:
    """``transform_base_to_world`` from ``[robot] base_xyz_m, base_rpy_deg`` (None: identity)."""
    r = spec.robot
    if r.base_xyz_m is None and r.base_rpy_deg is None:
        return None
    T = np.eye(4)
    if r.base_rpy_deg is not None:
        T[:3, :3] = rpy_to_matrix(*np.radians(np.asarray(r.base_rpy_deg, float)))
    if r.base_xyz_m is not None:
        T[:3, 3] = np.asarray(r.base_xyz_m, float)
    return T


def controller_profile(spec: StudySpec, robot: Robot | None = None) -> ControllerProfile:
    """The study's controller: the profile ``[controller] profile`` (default: the reference
    controller, or for a robot it cannot drive the same controller for any axis count:
    :func:`armlab.study.decisions.resolve_controller`) with the study's ``cycle_s``,
    ``pulse_limit`` and ``servo_period_s``, validated against ``robot`` when given.

    This is the one controller of a study: sizing's encoder checks, the tuning's discretisation,
    the simulation's servo period and the set-point table all read it.
    """
    from armlab.study.decisions import resolve_controller

    return resolve_controller(spec, robot)[0]
