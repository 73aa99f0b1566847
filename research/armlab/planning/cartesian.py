"""Cartesian motions: line, arc through three points, blended chain (FlyBy), any path.

A Cartesian path (:mod:`armlab.planning.paths`) is timed by a trapezoid (or double S) in arc
length ``s(t)``; every sample goes through inverse kinematics (analytic for spherical-wrist
arms, a Newton corrector seeded from the previous point for any other URDF), keeping one IK
branch along the whole path. Joint velocities and accelerations follow exactly from the path
derivatives (no finite differences)::

    J(q) g = [dp/ds; w_s]                 g = dq/ds
    J(q) h = [d2p/ds2; dw_s/ds] - Jdot g  h = d2q/ds2   (Jdot g: Pinocchio's classical
                                                         acceleration at (q, g, 0))
    qd = g sdot,   qdd = g sddot + h sdot^2,   qddd = g s''' + 3 h sdot sddot + k sdot^3

Limits: the cruise speed is capped by ``min_j v_j / max_s |g_j|`` and by ``|h_j| v^2 <= a_j / 2``
(room left to accelerate); the acceleration by ``min (a_j - |h_j| v^2) / |g_j|``; the jerk
likewise. What remains (peaks between the probe points, torques) is met by a uniform time
stretch. ``on_limit="raise"`` raises :class:`LimitViolation` instead of lowering a requested
speed or acceleration. A jump between IK branches (a singularity, or the only in-range branch
ending) raises :class:`UnreachableError` with the arc length and point — never a silent jump.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from armlab._keywords import renamed_keywords
from armlab.errors import InputError, LimitViolation, UnreachableError
from armlab.kinematics import fk, has_analytic_ik, ik, ik_nearest
from armlab.planning.keep_clear import refuses_collision
from armlab.planning.path_ik import MinNormFlow, path_derivatives, track_path, where_on
from armlab.planning.paths import ArcPath, BlendPath, CartesianPath, LinePath
from armlab.planning.timescale import finish, stretch_needed
from armlab.robot.limits import resolve_limits
from armlab.trajectory.core import Trajectory
from armlab.trajectory.profiles import double_s_profile, trapezoid_profile
from armlab.trajectory.sampling import sample_times
from armlab.trajectory.waypoints import validate_waypoints

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["line", "arc3", "blend", "follow_path"]

#: a time stretch above this after the probe's rates means the path's joint-space derivatives
#: vary faster than the probe resolves (a jerk 1000 times its estimate): refused, not crawled
MAX_STRETCH = 10.0


def _choose_rates(G, H, K, lim, speed, accel, jerk, scurve: bool):
    """Speed, acceleration and jerk along s from the joint limits (module docstring)."""
    vlim, alim = lim.velocity_rad_s, lim.acceleration_rad_s2
    with np.errstate(divide="ignore", invalid="ignore"):
        v_bound = float(np.min(vlim / G.max(axis=0)))
        v_curv = float(np.min(np.sqrt(0.5 * alim / H.max(axis=0))))
    v = min(speed, v_bound, v_curv)
    with np.errstate(divide="ignore", invalid="ignore"):
        a_room = np.where(G > 0, (alim - H * v * v) / G, np.inf)
    a_bound = 0.98 * float(np.min(a_room))
    a = a_bound if accel is None else min(accel, a_bound)
    j = math.inf
    if scurve:
        jlim = lim.jerk_rad_s3
        for _ in range(60):
            rest = jlim - 3 * H * v * a - K * v**3
            if np.all(rest >= 0.5 * jlim):
                break
            v, a = 0.8 * v, 0.64 * a
        with np.errstate(divide="ignore", invalid="ignore"):
            j_bound = 0.98 * float(
                np.min(np.where(G > 0, (jlim - 3 * H * v * a - K * v**3) / G, np.inf))
            )
        j = j_bound if jerk is None else min(jerk, j_bound)
    return v, a, j, {"v_bound": v_bound, "v_curvature": v_curv, "a_bound": a_bound}


def _positive_or_none(x, name):
    if x is None:
        return None
    x = float(x)
    if not (math.isfinite(x) and x > 0):
        raise InputError(f"{name} must be a finite number > 0, not {x!r}")
    return x


def _start_configuration(robot, pose, q_start) -> np.ndarray:
    if q_start is not None:
        q0 = validate_waypoints(robot, q_start, where="q_start", min_rows=None)
        T = fk(robot, q0)
        err_p = np.linalg.norm(T[:3, 3] - pose[:3, 3])
        err_r = np.linalg.norm(pin.log3(T[:3, :3].T @ pose[:3, :3]))
        if err_p > 1e-6 or err_r > 1e-6:
            raise InputError(
                f"q_start puts the tool {err_p:.3g} m / {err_r:.3g} rad away from "
                "the path's start pose"
            )
        return q0
    ref = np.clip(np.zeros(robot.n_joints), robot.limits.lower_rad, robot.limits.upper_rad)
    try:
        if has_analytic_ik(robot):
            return ik_nearest(robot, pose, ref)
        return ik(robot, pose, ref, tol_pos_m=1e-10, tol_rot_rad=1e-10)
    except UnreachableError as exc:
        raise UnreachableError(f"the path's start pose is unreachable ({exc})") from None


@renamed_keywords(torque="tau_max= (False: no torque limit)")
def follow_path(
    robot: Robot,
    path: CartesianPath,
    speed: float,
    *,
    accel: float | None = None,
    jerk: float | None = None,
    profile: str = "trapezoid",
    q_start=None,
    dt: float = 0.01,
    on_limit: str = "slow",
    v_max=None,
    a_max=None,
    j_max=None,
    tau_max=None,
    probe_step_m: float = 1e-3,
    method: str | None = None,
) -> Trajectory:
    """Time a Cartesian path with a trapezoid (or double S) in arc length and map it to joints.

    Parameters
    ----------
    robot : Robot
    path : CartesianPath
        :class:`LinePath`, :class:`ArcPath`, :class:`BlendPath`, ...
    speed : float
        Requested cruise speed of the tool centre point [m/s].
    accel, jerk : float, optional
        Requested acceleration [m/s^2] and jerk [m/s^3] along the path; default: as high as the
        joint limits allow.
    profile : {"trapezoid", "scurve"}
    q_start : array (n_joints,), optional
        Configuration at the start pose (chooses the IK branch); default the solution nearest
        to the zero configuration.
    dt : float
        Sample period [s].
    on_limit : {"slow", "raise"}
        What to do when a joint limit needs a lower speed/acceleration than requested.
    v_max, a_max, j_max : None, False, float or array (n_joints,)
        Joint limits (:func:`armlab.robot.resolve_limits`): None the robot's, False off, a value
        replaces it; velocity and acceleration are needed (jerk too for ``"scurve"``).
    tau_max : None, False, float or array (n_joints,)
        Torque limit in [N m] (:func:`armlab.robot.resolve_limits`): None the robot's, False
        no torque check, a value replaces it; the inverse-dynamics torques are kept within it
        (slowing down if needed).
    probe_step_m : float
        Spacing of the IK probe points used to find the rates and to check branch continuity.

    Returns
    -------
    Trajectory
        ``meta``: path kind and length, requested and achieved speed/acceleration/jerk,
        ``slowdown`` (factor, limit, joint) if limits lowered a request, ``s`` (arc length at
        every sample), ``taught_points``. ``qddd`` for ``"scurve"`` on single-piece paths.

    Raises
    ------
    UnreachableError
        A point is unreachable or the path crosses a singularity / needs a branch change.
    LimitViolation
        ``on_limit="raise"`` and a request breaks a joint limit (names joint and limit), or
        gravity alone exceeds a torque limit.
    """
    if profile not in ("trapezoid", "scurve"):
        raise InputError(f"Cartesian profile must be 'trapezoid' or 'scurve', not {profile!r}")
    if on_limit not in ("slow", "raise"):
        raise InputError(f"on_limit must be 'slow' or 'raise', not {on_limit!r}")
    speed = _positive_or_none(speed, "speed")
    if speed is None:
        raise InputError("speed must be given in [m/s]")
    accel = _positive_or_none(accel, "accel")
    jerk = _positive_or_none(jerk, "jerk")
    dt = _positive_or_none(dt, "dt")
    scurve = profile == "scurve"
    method = method or path.kind
    lim = resolve_limits(
        robot,
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
        need=("velocity", "acceleration") + (("jerk",) if scurve else ()),
        where=method,
    )
    torque = lim.torque_Nm is not None  # tau_max=False switched it off in resolve_limits
    pose0 = path.point(0.0)
    q0 = _start_configuration(robot, pose0, q_start)
    L = path.length
    if L <= 1e-12:
        z = np.zeros((1, robot.n_joints))
        traj = Trajectory(
            [0.0],
            q0[None],
            z,
            z.copy(),
            z.copy() if scurve else None,
            joint_names=robot.joint_names,
            method=method,
        )
        traj.meta.update(path_kind=path.kind, length_m=0.0, zero_length=True, s=[0.0])
        return finish(traj, robot, lim, torque=torque, what=method)

    # 1. probe: one branch along the path, its joint-space derivatives
    n_probe = int(np.clip(math.ceil(L / probe_step_m) + 1, 51, 4001))
    s_probe = np.linspace(0.0, L, n_probe)
    # a redundant arm: the minimum-norm flow (its rates are the exact derivatives of its path)
    flow = MinNormFlow(robot, path, q0) if robot.n_joints > 6 else None
    q_probe = track_path(robot, path, s_probe, q0) if flow is None else flow.at(s_probe)
    sample = path.evaluate(s_probe)
    g, h = path_derivatives(robot, q_probe, sample)
    G, H = np.abs(g), np.abs(h)
    K = np.abs(np.gradient(h, s_probe, axis=0)) if scurve else np.zeros_like(G)
    v, a, j, bounds = _choose_rates(G, H, K, lim, speed, accel, jerk, scurve)
    if not (math.isfinite(a) and math.isfinite(j if scurve else 0.0)):
        raise InputError(f"{method}: no joint moves along this path (length {L:.3g})")
    if v < 1e-3 * speed:
        jj = int(np.argmax(np.max(G / lim.velocity_rad_s, axis=0)))
        kk = int(np.argmax(G[:, jj]))
        raise UnreachableError(
            f"{method}: near {where_on(path, s_probe[kk])} {robot.joint_names[jj]} would turn "
            f"{G[kk, jj]:.3g} rad per m of path: the path passes (too) close to a singularity"
        )

    def build(v, a, j):
        prof = double_s_profile(L, v, a, j) if scurve else trapezoid_profile(L, v, a)
        # knots where the profile switches and where the path's curvature steps (line/arc
        # junctions): each piece between knots is smooth (module docstring of
        # armlab.trajectory.core)
        knots = np.concatenate([prof.corners, prof.time_at(path.junctions)])
        t = sample_times(prof.duration, dt, knots)
        s, sd, sdd, sddd = prof.evaluate(t)
        s[-1] = L
        if flow is None:
            guide = np.column_stack(
                [np.interp(s, s_probe, q_probe[:, i]) for i in range(robot.n_joints)]
            )
            q = track_path(robot, path, s, q0, guide=guide)
        else:
            q = flow.at(s)
        smp = path.evaluate(s)
        gs, hs = path_derivatives(robot, q, smp)
        qd = gs * sd[:, None]
        qdd = gs * sdd[:, None] + hs * (sd**2)[:, None]
        qddd = None
        if scurve and len(path.pieces) == 1:
            ks = np.gradient(hs, s, axis=0) if s.size > 2 else np.zeros_like(hs)
            qddd = gs * sddd[:, None] + 3 * hs * (sd * sdd)[:, None] + ks * (sd**3)[:, None]
        traj = Trajectory(t, q, qd, qdd, qddd, joint_names=robot.joint_names, method=method)
        return traj, prof, s

    def needed(traj):  # on the evaluation's peaks (knots, left limits, interior extremes)
        return stretch_needed(
            traj.limit_samples(robot=robot if torque else None), robot, lim, torque=torque
        )

    traj, prof, s = build(v, a, j)
    k, kind, joint = needed(traj)
    for _ in range(6):
        if k <= 1 + 1e-12:
            break
        k *= 1 + 1e-9
        v, a, j = v / k, a / k**2, j / k**3
        if v < 1e-3 * speed or k > MAX_STRETCH:  # the path's derivatives outran the probe
            raise UnreachableError(
                f"{method}: the {kind} limit of {joint} needs the motion {k:.3g} times slower "
                f"than the probe's rates (path speed {v:.3g} m/s for {speed:.3g} requested): "
                "the joint rates change faster than the probe resolves -- the path passes "
                "(too) close to a singularity"
            )
        traj, prof, s = build(v, a, j)
        k2, kind2, joint2 = needed(traj)
        kind, joint = (kind2, joint2) if k2 > 1 else (kind, joint)
        k = k2
    lowered = []
    if v < speed * (1 - 1e-9):
        lowered.append(("speed", speed, v))
    if accel is not None and a < accel * (1 - 1e-9):
        lowered.append(("accel", accel, a))
    if jerk is not None and scurve and j < jerk * (1 - 1e-9):
        lowered.append(("jerk", jerk, j))
    slowdown = None
    if lowered:
        binding = _binding(G, H, lim, v, a, bounds, robot) if not kind else (kind, joint)
        slowdown = {
            "requested": {n: r for n, r, _ in lowered},
            "achieved": {n: x for n, _, x in lowered},
            "kind": binding[0],
            "joint": binding[1],
        }
        if on_limit == "raise":
            what = ", ".join(f"{n} {r:.4g} -> {x:.4g}" for n, r, x in lowered)
            raise LimitViolation(
                f"{method}: the {binding[0]} limit of {binding[1]} needs a slower motion ({what})"
            )
    traj.meta.update(
        path_kind=path.kind,
        length_m=float(L),
        profile=prof.to_dict(),
        speed_requested=speed,
        speed=float(v),
        accel_requested=accel,
        accel=float(a),
        jerk_requested=jerk,
        jerk=float(j) if scurve else None,
        slowdown=slowdown,
        s=s.tolist(),
        dt_s=dt,
        q_start=q0.tolist(),
    )
    return finish(traj, robot, lim, torque=torque, what=method)


def _binding(G, H, lim, v, a, bounds, robot) -> tuple[str, str]:
    """The joint limit that capped the speed (for the report)."""
    if v >= bounds["v_bound"] * (1 - 1e-6):
        j = int(np.argmax(G.max(axis=0) / lim.velocity_rad_s))
        return "velocity", robot.joint_names[j]
    j = int(np.argmax((G * a + H * v * v).max(axis=0) / lim.acceleration_rad_s2))
    return "acceleration", robot.joint_names[j]


# ---------------------------------------------------------------------- public planners
def _as_pose(robot, x, name: str, rotation=None) -> np.ndarray:
    a = np.asarray(x, float)
    if a.shape == (4, 4):
        return a
    if a.shape == (3,):
        if rotation is None:
            raise InputError(f"{name} is a position: give q_start (or a pose) for the orientation")
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = rotation, a
        return T
    raise InputError(f"{name} must be a (4, 4) pose or a (3,) position in [m], got shape {a.shape}")


def _start_rotation(robot, first, q_start, rotation):
    if rotation is not None:
        return np.asarray(rotation, float)
    if np.shape(first) == (4, 4):
        return np.asarray(first, float)[:3, :3]
    if q_start is not None:
        return fk(robot, q_start)[:3, :3]
    return None


@refuses_collision("line")  # clearance=: issue 27, planning.keep_clear
def line(
    robot: Robot,
    pose_start,
    pose_goal,
    speed: float,
    *,
    orientation: str = "slerp",
    rotation_radius_m: float = 0.1,
    q_start=None,
    **kwargs,
) -> Trajectory:
    """Straight line of the tool centre point (Jiang 1987, eq. 6-9; HEU thesis, 6.3.3).

    Parameters
    ----------
    robot : Robot
    pose_start, pose_goal : array (4, 4) or (3,)
        Tool poses (or positions, orientation then from ``q_start``) in the world, [m].
        ``pose_start=None`` starts at ``fk(q_start)``.
    speed : float
        Cruise speed [m/s].
    orientation : {"slerp", "hold", "first", "last"}
        Thesis 6.3.6: ``"slerp"`` turns while moving (simultaneous), ``"hold"`` keeps the start
        orientation (the goal's rotation is ignored), ``"first"`` turns on the spot and then
        moves, ``"last"`` moves and then turns (two motions with a stop between).
    rotation_radius_m : float
        See :class:`LinePath` (a rotation counts as a movement at this radius).
    q_start : array (n_joints,), optional
        Start configuration (IK branch).
    **kwargs
        ``accel``, ``jerk``, ``profile``, ``dt``, ``on_limit``, ``v_max``, ``a_max``, ``j_max``,
        ``tau_max`` of :func:`follow_path`; ``clearance`` (a CollisionScene: the plan's
        clearance is checked and a plan too close refused, :mod:`armlab.planning.keep_clear`;
        also for :func:`arc3` and :func:`blend`).

    Returns
    -------
    Trajectory
        ``method = "line"``; the tool stays on the segment (each sample solves the IK).
    """
    if pose_start is None:
        if q_start is None:
            raise InputError("line: give pose_start or q_start")
        pose_start = fk(robot, q_start)
    R0 = _start_rotation(robot, pose_start, q_start, None)
    T0 = _as_pose(robot, pose_start, "pose_start", R0)
    T1 = _as_pose(robot, pose_goal, "pose_goal", T0[:3, :3])
    kwargs.setdefault("method", "line")
    if orientation in ("slerp", "hold"):
        path = LinePath(T0, T1, orientation, rotation_radius_m)
        traj = follow_path(robot, path, speed, q_start=q_start, **kwargs)
        traj.meta["taught_points"] = [T0[:3, 3].tolist(), T1[:3, 3].tolist()]
        traj.meta["orientation"] = orientation
        return traj
    if orientation not in ("first", "last"):
        raise InputError(
            f"line orientation must be 'slerp', 'hold', 'first' or 'last', not {orientation!r}"
        )
    Tm = T0.copy()
    if orientation == "first":
        Tm[:3, :3] = T1[:3, :3]
    else:
        Tm[:3, 3] = T1[:3, 3]
    first = follow_path(
        robot, LinePath(T0, Tm, "slerp", rotation_radius_m), speed, q_start=q_start, **kwargs
    )
    second = follow_path(
        robot, LinePath(Tm, T1, "slerp", rotation_radius_m), speed, q_start=first.q[-1], **kwargs
    )
    traj = first.concat(second) if second.n_samples > 1 else first
    traj.method = "line"
    traj.meta.update(first.meta)
    traj.meta.update(
        orientation=orientation,
        parts=[first.meta, second.meta],
        taught_points=[T0[:3, 3].tolist(), T1[:3, 3].tolist()],
        s=None,
        length_m=first.meta["length_m"] + second.meta["length_m"],
    )
    lim = resolve_limits(
        robot,
        v_max=kwargs.get("v_max"),
        a_max=kwargs.get("a_max"),
        j_max=kwargs.get("j_max"),
        tau_max=kwargs.get("tau_max"),
    )
    return finish(traj, robot, lim, torque=lim.torque_Nm is not None, what="line")


@refuses_collision("arc3")  # clearance=: issue 27, planning.keep_clear
def arc3(
    robot: Robot,
    p1,
    p2,
    p3,
    speed: float,
    *,
    orientation: str = "hold",
    rotation=None,
    rotation_end=None,
    full_circle: bool = False,
    q_start=None,
    **kwargs,
) -> Trajectory:
    """Arc (or full circle) of the tool centre point through three points (Jiang 1987,
    eq. 10-24; HEU thesis, 6.3.4-6.3.5); planar arcs are the special case of a plane parallel
    to a base plane.

    Parameters
    ----------
    robot : Robot
    p1, p2, p3 : array (3,) or (4, 4)
        Start, intermediate and end point in the world [m] (poses: their translations; the
        start orientation is ``p1``'s rotation, else ``rotation``, else ``fk(q_start)``'s).
    speed : float
        Cruise speed along the arc [m/s] (Jiang 1987, eq. 21: the polar angle advances by
        ``v dt / R``).
    orientation : {"hold", "rotate", "slerp"}
        See :class:`ArcPath`.
    full_circle : bool
        Continue past ``p3`` back to ``p1``.
    q_start : array (n_joints,), optional
    **kwargs
        As :func:`follow_path`.

    Returns
    -------
    Trajectory
        ``method = "arc3"``; ``meta``: ``centre_m``, ``radius_m``, ``normal``, ``s_points``
        (arc length at P1, P2, P3), ``taught_points``.

    Raises
    ------
    InputError
        Collinear or coincident points.
    """
    R0 = _start_rotation(robot, p1, q_start, rotation)
    if R0 is None:
        raise InputError("arc3: give the start orientation (p1 as a pose, rotation= or q_start)")
    path = ArcPath(
        p1,
        p2,
        p3,
        rotation=R0,
        orientation=orientation,
        rotation_end=rotation_end,
        full_circle=full_circle,
    )
    kwargs.setdefault("method", "arc3")
    traj = follow_path(robot, path, speed, q_start=q_start, **kwargs)
    c = path.circle
    traj.meta.update(
        centre_m=c.centre.tolist(),
        radius_m=c.radius,
        normal=c.normal.tolist(),
        s_points=path.s_points.tolist(),
        full_circle=full_circle,
        orientation=orientation,
        taught_points=[
            np.asarray(p, float)[:3, 3].tolist()
            if np.shape(p) == (4, 4)
            else np.asarray(p, float).tolist()
            for p in (p1, p2, p3)
        ],
    )
    return traj


@refuses_collision("blend")  # clearance=: issue 27, planning.keep_clear
def blend(
    robot: Robot,
    points,
    radius,
    speed: float,
    *,
    orientation: str = "hold",
    rotation=None,
    rotation_end=None,
    q_start=None,
    **kwargs,
) -> Trajectory:
    """Lines through a chain of points, each corner rounded by a tangent arc (SHU
    controller paper, §2.2 (2)); the whole chain is one FlyBy motion (Li, Meng, Chen) timed
    by one profile.

    Parameters
    ----------
    robot : Robot
    points : array (n, 3) or (n, 4, 4)
        Taught points in the world [m], n >= 2.
    radius : float or array (n - 2,)
        Blend radius per interior corner [m]. ``0`` (everywhere) gives exact corners: the
        tool stops at each point (lines concatenated).
    speed : float
        Cruise speed [m/s].
    orientation : {"hold", "slerp"}
        See :class:`BlendPath`.
    q_start : array (n_joints,), optional
    **kwargs
        As :func:`follow_path`.

    Returns
    -------
    Trajectory
        ``method = "blend"``; ``meta``: ``tangent_lengths_m``, ``radius_m``,
        ``taught_points``.

    Raises
    ------
    InputError
        A radius too large for a segment (names the segment and the room it has), a corner
        turning back on itself, repeated points.
    """
    pts = np.asarray(points, float)
    first = pts[0] if pts.ndim >= 2 else pts
    R0 = _start_rotation(robot, first, q_start, rotation)
    if R0 is None:
        raise InputError("blend: give the start orientation (poses, rotation= or q_start)")
    kwargs.setdefault("method", "blend")
    r = np.asarray(radius, float)
    taught = pts[:, :3, 3] if pts.ndim == 3 else pts
    if np.all(r == 0):
        # exact corners: stop at every point
        if orientation != "hold":
            raise InputError("blend with radius 0 supports orientation 'hold' only")
        traj = None
        q = q_start
        for k in range(taught.shape[0] - 1):
            Ta = np.eye(4)
            Ta[:3, :3], Ta[:3, 3] = R0, taught[k]
            Tb = Ta.copy()
            Tb[:3, 3] = taught[k + 1]
            part = follow_path(robot, LinePath(Ta, Tb, "hold"), speed, q_start=q, **kwargs)
            q = part.q[-1]
            traj = part if traj is None else traj.concat(part)
        assert traj is not None  # at least two points (documented n >= 2)
        traj.method = "blend"
        traj.meta.update(radius_m=0.0, stops=True, taught_points=taught.tolist(), s=None)
        lim = resolve_limits(
            robot,
            v_max=kwargs.get("v_max"),
            a_max=kwargs.get("a_max"),
            j_max=kwargs.get("j_max"),
            tau_max=kwargs.get("tau_max"),
        )
        return finish(traj, robot, lim, torque=lim.torque_Nm is not None, what="blend")
    path = BlendPath(
        points, radius, rotation=R0, orientation=orientation, rotation_end=rotation_end
    )
    traj = follow_path(robot, path, speed, q_start=q_start, **kwargs)
    traj.meta.update(
        radius_m=path.radius.tolist(),
        tangent_lengths_m=path.tangent_lengths.tolist(),
        taught_points=taught.tolist(),
    )
    return traj
