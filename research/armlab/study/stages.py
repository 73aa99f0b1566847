"""The stages of a study: each takes the :class:`StudyContext` and returns its summary.json block.

Chain (DESIGN.md): robot -> kinematics checks -> plan -> static load -> sizing -> tuning ->
closed-loop tracking -> export. Each stage calls the package's public functions; a stage that
cannot apply (no drive data, no trajectory) reports ``status: "skipped"`` or ``"not available"``
with the reason, and the stages that need its result are skipped -- a study never fakes a result.

A stage raises an :class:`armlab.ArmlabError` when its input is impossible (a waypoint out of
range, an infeasible plan, an impossible control spec); the runner records it and stops.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from armlab.errors import LimitViolation, SpecError, UnreachableError
from armlab.study.spec import StudySpec

__all__ = [
    "StudyContext",
    "NotAvailable",
    "NotApplicable",
    "STAGE_FUNCTIONS",
    "SUMMARY_KEY",
    "build_robot",
    "api",
]

#: summary.json block written by each stage.
SUMMARY_KEY = {
    "kinematics": "kinematics",
    "plan": "trajectory",
    "static_load": "static_load",
    "sizing": "sizing",
    "tuning": "control",
    "tracking": "tracking",
    "export": "export",
}

#: Limit kinds a planner must honour exactly (the plan stage refuses a plan that breaks them).
_KINEMATIC = ("position", "velocity", "acceleration", "jerk")


class NotAvailable(Exception):
    """A stage's package function is missing from this installation (not an armlab error)."""


def api(module: str, name: str):
    """``module.name``, imported when a stage runs (a study imports only the stages it uses)."""
    return getattr(importlib.import_module(module), name)


def _call(fn, where: str, *args, **options):
    """Call ``fn`` with the options the user set (not None); an option ``fn`` does not take is a
    :class:`SpecError` naming the study key (``where.<option>``)."""
    sig = inspect.signature(fn)
    takes_any = any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values())
    kw = {}
    for key, (param, value) in options.items():
        if value is None:
            continue
        if not takes_any and param not in sig.parameters:
            raise SpecError(
                f"{where}.{key.rstrip('_')}: not supported by {fn.__module__}.{fn.__name__}"
            )
        kw[param] = value
    return fn(*args, **kw)


@dataclass
class StudyContext:
    """Everything the stages share: the spec, the robot and each stage's result object."""

    spec: StudySpec
    out_dir: Path | None = None
    workers: int | None = None
    robot: Any = None
    waypoints_q: np.ndarray | None = None
    waypoint_poses: np.ndarray | None = None
    trajectory: Any = None
    static_load: Any = None
    sizing: Any = None
    requirement_sizing: Any = None
    selection: Any = None
    gains: Any = None
    tracking: Any = None
    setpoints: Any = None
    jerk_limited: bool = True
    files: dict[str, str] = field(default_factory=dict)
    figures: dict[str, Any] = field(default_factory=dict)

    @property
    def rng(self) -> np.random.Generator:
        return np.random.default_rng(self.spec.study.seed)


# ---------------------------------------------------------------------------- robot
@functools.lru_cache(maxsize=8)
def _load_cached(name: str, tool_frame: str | None, lock: tuple[str, ...]):
    from armlab.robot import load_robot

    return load_robot(name, tool_frame=tool_frame, lock_joints=lock)


def _per_joint(value, n: int, where: str) -> np.ndarray:
    a = np.full(n, float(value)) if np.isscalar(value) else np.asarray(value, float)
    if a.shape != (n,):
        raise SpecError(f"{where}: {a.size} values, the robot has {n} joints")
    return a


def _catalogue(spec: StudySpec):
    """The drive catalogue (``sizing.catalogue`` or the package's)."""
    load = api("armlab.dynamics", "load_catalogue")
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


def build_robot(spec: StudySpec):
    """The study's robot: description + payload + drive changes + limit overrides.

    A drive change (ratio, motor, reducer, efficiency, derating) also updates the joint's
    effort limit when the description derives it from the drive (URDF effort = available output
    torque, thesis table 4.3 rule), so the planners and checks see the new drive.
    """
    from armlab.robot.drives import Drive

    base = _load_cached(
        spec.resolve(spec.robot.name), spec.robot.tool_frame, tuple(spec.robot.lock_joints)
    )
    robot = base.copy()
    p = spec.payload
    if p.mass_kg is not None or p.com_m is not None:
        mass = robot.payload.mass_kg if p.mass_kg is None else p.mass_kg
        com = robot.payload.com_m if p.com_m is None else np.asarray(p.com_m)
        robot.attach_payload(mass, com)
    lim = robot.limits
    if spec.drives:
        if robot.drives is None:
            raise SpecError(f"drives: robot {robot.name} has no drives.toml to change")
        drives = dict(robot.drives)
        effort = lim.effort_Nm.copy()
        for joint, change in spec.drives.items():
            where = f"drives.{joint}"
            if joint not in drives:
                raise SpecError(
                    f"{where}: no joint {joint!r} in {robot.name} "
                    f"(joints: {', '.join(robot.joint_names)})"
                )
            old: Drive = drives[joint]
            new = old
            if change.motor is not None:
                motor, derating = _find_part("motor", change.motor, robot, spec, f"{where}.motor")
                new = replace(new, motor=motor, derating=derating)
            if change.reducer is not None:
                reducer, _ = _find_part("reducer", change.reducer, robot, spec, f"{where}.reducer")
                new = replace(new, reducer=reducer)
            red = {
                k: getattr(change, k)
                for k in ("ratio", "efficiency")
                if getattr(change, k) is not None
            }
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
            j = robot.joint_names.index(joint)
            if math.isclose(effort[j], old.available_torque_Nm, rel_tol=1e-3):
                effort[j] = new.available_torque_Nm
            drives[joint] = new
        robot.drives = drives
        lim = replace(lim, effort_Nm=effort)
    n = robot.n_joints
    changes = {
        k: _per_joint(v, n, f"limits.{k}") for k, v in vars(spec.limits).items() if v is not None
    }
    robot.limits = replace(lim, **changes)
    return robot


def robot_block(ctx: StudyContext) -> dict:
    """summary.json "robot": name, joints, payload, mass, drives."""
    r = ctx.robot
    block = {
        "status": "ok",
        "name": r.name,
        "n_joints": r.n_joints,
        "joint_names": list(r.joint_names),
        "urdf": str(r.urdf_path),
        "tool_frame": r.tool_frame,
        "payload_kg": r.payload.mass_kg,
        "total_mass_kg": r.total_mass_kg,
        "limits": {
            "velocity_rad_s": r.limits.velocity_rad_s.tolist(),
            "effort_Nm": r.limits.effort_Nm.tolist(),
        },
    }
    if r.drives is not None:
        block["drives"] = {
            j: {
                "motor": d.motor.model,
                "reducer": d.reducer.model,
                "ratio": d.reducer.ratio,
                "available_torque_Nm": d.available_torque_Nm,
            }
            for j, d in r.drives.items()
        }
    return block


# ---------------------------------------------------------------------------- kinematics
def _rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll) (URDF / ROS fixed-axis convention)."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _angles(values, unit: str) -> np.ndarray:
    a = np.asarray(values, float)
    return np.radians(a) if unit == "deg" else a


def waypoint_poses(spec: StudySpec) -> np.ndarray | None:
    """Cartesian waypoints as (n, 4, 4) tool poses in the world, or None."""
    wp = spec.waypoints
    if wp.cartesian is None:
        return None
    out = []
    for row in wp.cartesian:
        T = np.eye(4)
        T[:3, :3] = _rpy_to_matrix(*_angles(row[3:], wp.unit))
        T[:3, 3] = row[:3]
        out.append(T)
    return np.array(out)


def _solve_ik(ctx: StudyContext, poses: np.ndarray) -> np.ndarray:
    """Joint waypoints from poses, keeping the IK branch continuous: the analytic solution
    nearest to the previous waypoint's (thesis 3.4.2, 6.3.1) on arms that have one, numerical IK
    seeded with the previous waypoint otherwise. The first reference is ``waypoints.ik_seed``
    (default: the middle of the joint ranges)."""
    robot, wp = ctx.robot, ctx.spec.waypoints
    lim = robot.limits
    seed = (
        0.5 * (lim.lower_rad + lim.upper_rad)
        if wp.ik_seed is None
        else _per_joint(list(_angles(wp.ik_seed, wp.unit)), robot.n_joints, "waypoints.ik_seed")
    )
    if api("armlab.kinematics", "has_analytic_ik")(robot):
        ik_nearest = api("armlab.kinematics", "ik_nearest")
        try:
            return np.atleast_2d(ik_nearest(robot, poses, seed, sequential=True))
        except UnreachableError as exc:
            raise UnreachableError(f"waypoints.cartesian: {exc}") from None
    ik = api("armlab.kinematics", "ik")
    out = []
    for k, pose in enumerate(poses):
        try:
            q = np.asarray(ik(robot, pose, seed, rng=np.random.default_rng(ctx.spec.study.seed)))
        except UnreachableError as exc:
            raise UnreachableError(f"waypoints.cartesian[{k}]: {exc}") from None
        out.append(q)
        seed = q
    return np.array(out)


def stage_kinematics(ctx: StudyContext) -> dict:
    """Waypoints to joint space (IK for Cartesian ones), range check, TCP positions, reach, and
    the optional Monte-Carlo workspace and accuracy studies."""
    from armlab.kinematics import fk, max_reach_m

    spec, robot = ctx.spec, ctx.robot
    wp = spec.waypoints
    lim = robot.limits
    ctx.waypoint_poses = waypoint_poses(spec)
    if wp.joint is not None:
        q = _angles(wp.joint, wp.unit)
        if q.shape[1] != robot.n_joints:
            raise SpecError(
                f"waypoints.joint: rows of {q.shape[1]} values, robot {robot.name} "
                f"has {robot.n_joints} joints"
            )
        source = "joint"
    else:
        q = _solve_ik(ctx, ctx.waypoint_poses)
        source = "cartesian (IK)"
    for k, row in enumerate(q):
        bad = np.flatnonzero((row < lim.lower_rad - 1e-9) | (row > lim.upper_rad + 1e-9))
        if bad.size:
            j = bad[0]
            conv = math.degrees if wp.unit == "deg" else float
            raise UnreachableError(
                f"waypoints.{'joint' if wp.joint is not None else 'cartesian'}[{k}]: "
                f"{robot.joint_names[j]} = {conv(row[j]):.6g} {wp.unit} is outside its range "
                f"{conv(lim.lower_rad[j]):.6g} .. {conv(lim.upper_rad[j]):.6g} {wp.unit}"
            )
    ctx.waypoints_q = q
    tcp = np.array([fk(robot, row)[:3, 3] for row in q])
    block = {
        "status": "ok",
        "waypoints_from": source,
        "n_waypoints": int(len(q)),
        "waypoints_rad": q.tolist(),
        "tcp_positions_m": tcp.tolist(),
        "max_reach_m": max_reach_m(robot, seed=spec.study.seed),
    }
    ks = spec.kinematics
    if ks.workspace_samples:
        block["workspace"] = _optional_study(ctx, "workspace", ks.workspace_samples)
    if ks.accuracy_samples:
        block["accuracy"] = _optional_study(ctx, "accuracy", ks.accuracy_samples)
    return block


def _optional_study(ctx: StudyContext, kind: str, n: int) -> dict:
    """The Monte-Carlo workspace cloud or accuracy study (thesis 3.6, 3.7) at the study seed."""
    name = {"workspace": "workspace_cloud", "accuracy": "accuracy_study"}[kind]
    fn = api("armlab.kinematics", name)
    if kind == "accuracy" and ctx.robot.dh is None:
        return {"status": "skipped", "reason": f"{ctx.robot.name} has no DH table"}
    res = fn(ctx.robot, n_samples=n, seed=ctx.spec.study.seed)
    ctx.figures[kind] = res
    return {"status": "ok", **_to_dict(res)}


# ---------------------------------------------------------------------------- plan
def planning_robot(ctx: StudyContext):
    """The robot with its velocity/acceleration/jerk limits scaled by s, s^2, s^3."""
    s = ctx.spec.plan.speed_scale
    lim = ctx.robot.limits
    if s == 1.0:
        return ctx.robot
    scaled = {"velocity_rad_s": lim.velocity_rad_s * s}
    if lim.acceleration_rad_s2 is not None:
        scaled["acceleration_rad_s2"] = lim.acceleration_rad_s2 * s**2
    if lim.jerk_rad_s3 is not None:
        scaled["jerk_rad_s3"] = lim.jerk_rad_s3 * s**3
    return ctx.robot.with_limits(**scaled)


def _concat(parts):
    out = parts[0]
    for p in parts[1:]:
        out = out.concat(p, tol=1e-6)
    return out


def _jerk_on(planner, requested: bool | None) -> bool:
    """Whether the plan honours the jerk limits: as requested, else the planner's default
    (its ``j_max`` keyword: ``False`` = off)."""
    if requested is not None:
        return requested
    p = inspect.signature(planner).parameters.get("j_max")
    return p is None or p.default is not False


def plan_trajectory(ctx: StudyContext):
    """Run the planner the study names; returns a Trajectory."""
    plan, robot = ctx.spec.plan, planning_robot(ctx)
    Q = ctx.waypoints_q
    T = "armlab.trajectory"
    if plan.planner in ("optimal", "path"):
        fn = api(T, "optimal" if plan.planner == "optimal" else "time_optimal_path")
        ctx.jerk_limited = _jerk_on(fn, plan.jerk_limits)
        limits = {
            "tau_max": None if plan.torque_limits else False,
            "j_max": None if ctx.jerk_limited else False,
        }
        if plan.planner == "path":  # the cubic spline through the waypoints, time-optimally
            return fn(robot, Q, **limits)
        return _call(
            fn,
            "plan",
            robot,
            Q,
            objective=("objective", plan.objective),
            duration_s=("duration", plan.duration_s),
            **{k: (k, v) for k, v in limits.items() if v is not None},
        )
    # classical planners sample at the check step (the controller cycle by default), so the
    # set-point table hits their samples and never interpolates across a profile corner
    if plan.planner == "ptp":
        fn = api(T, "ptp_sync")
        return _concat(
            [
                _call(
                    fn,
                    "plan",
                    robot,
                    Q[i],
                    Q[i + 1],
                    profile=("profile", plan.profile),
                    check_dt_s=("dt", plan.check_dt_s),
                    torque_limits=("torque", plan.torque_limits),
                )
                for i in range(len(Q) - 1)
            ]
        )
    if plan.planner == "cubic":
        fn = api(T, "cubic_via")
        durations = None
        if plan.duration_s is not None:
            d = np.linalg.norm(np.diff(Q, axis=0), axis=1)
            durations = plan.duration_s * d / d.sum()
        return _call(
            fn,
            "plan",
            robot,
            Q,
            duration_s=("durations", durations),
            check_dt_s=("dt", plan.check_dt_s),
            torque_limits=("torque", plan.torque_limits),
        )
    poses = ctx.waypoint_poses
    speed = plan.speed_m_s
    if speed is None:
        raise SpecError(f"plan.speed_m_s: missing (required by planner {plan.planner!r})")
    # the IK branch of the first waypoint starts the path; each line starts where the last ended
    opts = {"dt": plan.check_dt_s, "torque": plan.torque_limits}
    if plan.planner == "line":
        fn = api(T, "line")
        parts, q0 = [], Q[0]
        for i in range(len(poses) - 1):
            parts.append(fn(robot, poses[i], poses[i + 1], speed, q_start=q0, **opts))
            q0 = parts[-1].q[-1]
        return _concat(parts)
    if plan.planner == "arc3":
        return api(T, "arc3")(robot, poses[0], poses[1], poses[2], speed, q_start=Q[0], **opts)
    return api(T, "blend")(robot, poses, plan.blend_radius_m, speed, q_start=Q[0], **opts)


def stage_plan(ctx: StudyContext) -> dict:
    """Plan, then check the plan on a fine grid against the robot's full limits.

    A plan that breaks a kinematic limit (range, velocity, acceleration, and jerk unless
    ``plan.jerk_limits = false``) is refused with :class:`LimitViolation` naming the limit,
    joint and time; a torque ratio above 1 (with ``plan.torque_limits = false``) is reported
    and left to the sizing stage.
    """
    spec = ctx.spec
    traj = plan_trajectory(ctx)
    ctx.trajectory = traj
    robot = ctx.robot
    torque = bool(np.all(robot.limits.effort_Nm > 0))
    # a trajectory already sampled at least as finely as the check step is checked at its own
    # samples: they are the planner's exact values (resampling would interpolate across the
    # acceleration steps of a trapezoid)
    fine = traj.n_samples > 1 and np.max(np.diff(traj.t)) <= spec.plan.check_dt_s * (1 + 1e-9)
    report = traj.check_limits(robot, dt=None if fine else spec.plan.check_dt_s, torque=torque)
    enforced = [k for k in _KINEMATIC if k != "jerk" or ctx.jerk_limited]
    for kind, joint, ratio, at in report.violations(tol=1e-6):
        if kind in enforced:
            raise LimitViolation(
                f"the {traj.method or spec.plan.planner} plan breaks the "
                f"{kind} limit of {joint} ({ratio:.4g} x the limit at "
                f"t = {at:.4g} s)"
            )
    kind, joint, ratio = report.worst()
    return {
        "status": "ok",
        "planner": spec.plan.planner,
        "method": traj.method,
        "duration_s": traj.duration,
        "n_waypoints": int(len(ctx.waypoints_q)),
        "n_samples": traj.n_samples,
        "speed_scale": spec.plan.speed_scale,
        "check_dt_s": spec.plan.check_dt_s,
        "peak_ratio": {k: float(np.max(r)) for k, r in report.ratios.items()},
        "peak_joint": {k: report.joint_names[int(np.argmax(r))] for k, r in report.ratios.items()},
        "ratios": report.to_dict(),
        "feasible": report.ok(tol=1e-6),
        "worst": {"kind": kind, "joint": joint, "ratio": ratio},
        "stats": _jsonable(getattr(traj, "stats", {})),
    }


# ---------------------------------------------------------------------------- dynamics
def _to_dict(obj) -> dict:
    if hasattr(obj, "to_dict"):
        return _jsonable(obj.to_dict())
    if isinstance(obj, dict):
        return _jsonable(obj)
    raise TypeError(f"{type(obj).__name__} has no to_dict()")


def _jsonable(x):
    """Plain JSON values (numpy arrays/scalars to lists/floats; NaN/inf kept for the writer)."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path):
        return str(x)
    return x


def stage_static_load(ctx: StudyContext) -> dict:
    """Worst-case static holding torque per joint (thesis 4.2.1) with the payload."""
    res = _call(
        api("armlab.dynamics", "static_load"),
        "study",
        ctx.robot,
        seed=("seed", ctx.spec.study.seed),
    )
    ctx.static_load = res
    return {"status": "ok", **_to_dict(res)}


class NotApplicable(Exception):
    """A stage that does not apply to this robot (no drive data): the stage is skipped."""


def _needs_drives(ctx: StudyContext) -> None:
    if ctx.robot.drives is None:
        raise NotApplicable(f"{ctx.robot.name} has no drives.toml (motor, reducer, encoder)")


def stage_sizing(ctx: StudyContext) -> dict:
    """Drive sizing checks along the planned trajectory; optional selection from a catalogue."""
    _needs_drives(ctx)
    if ctx.trajectory is None:
        raise NotAvailable("needs a trajectory")
    size = api("armlab.dynamics", "size")
    res = _call(
        size, "plan", ctx.robot, ctx.trajectory, check_dt_s=("dt", ctx.spec.plan.check_dt_s)
    )
    ctx.sizing = res
    block = {"status": "ok", **_to_dict(res)}
    if ctx.static_load is not None:
        # thesis tables 4.2/4.3: the drives against each joint's worst case (full speed and
        # acceleration from its worst static pose), beside the planned cycle
        moves = api("armlab.dynamics", "requirement_moves")(ctx.robot, ctx.static_load)
        ctx.requirement_sizing = size(ctx.robot, moves)
        block["requirement_moves"] = {
            "ok": bool(ctx.requirement_sizing.ok),
            "failures": [f"{joint}:{check}" for joint, check in ctx.requirement_sizing.failures()],
        }
    if ctx.spec.sizing.select:
        select = api("armlab.dynamics", "select_drives")
        sel = _call(
            select,
            "sizing",
            ctx.robot,
            [ctx.trajectory],
            catalogue=("catalogue", _catalogue(ctx.spec)),
            check_dt_s=("dt", ctx.spec.plan.check_dt_s),
        )
        ctx.selection = sel
        block["selection"] = {"status": "ok", **_to_dict(sel)}
    return block


# ---------------------------------------------------------------------------- control
def stage_tuning(ctx: StudyContext) -> dict:
    """Robust cascade tuning of every joint (current PI, speed PI, position P) to the study's
    control specs, checked continuous and discrete over each joint's inertia range."""
    _needs_drives(ctx)
    c = ctx.spec.control
    tune_arm = api("armlab.control", "tune_arm")
    gains = _call(
        tune_arm,
        "control",
        ctx.robot,
        position_bandwidth_rad_s=("position_bandwidth_rad_s", c.position_bandwidth_rad_s),
        rise_time_s=("rise_time_s", c.rise_time_s),
        phase_margin_deg=("phase_margin_deg", c.phase_margin_deg),
        gain_margin_dB=("gain_margin_dB", c.gain_margin_dB),
        overshoot_pct=("overshoot_pct", c.overshoot_pct),
        method=("method", c.method),
        servo_period_s=("speed_sample_time_s", c.servo_period_s),
        servo_period_s_=("position_sample_time_s", c.servo_period_s),
        current_sample_time_s=("current_sample_time_s", c.current_sample_time_s),
        n_inertia_samples=("n_inertia_samples", c.n_inertia_samples),
        seed=("seed", ctx.spec.study.seed),
    )
    ctx.gains = gains
    return {"status": "ok", **_jsonable(gains.summary())}


def stage_tracking(ctx: StudyContext) -> dict:
    """Closed-loop simulation of the arm tracking the plan with the tuned cascades."""
    _needs_drives(ctx)
    if ctx.trajectory is None or ctx.gains is None:
        raise NotAvailable("needs a trajectory and gains")
    t = ctx.spec.tracking
    sim = api("armlab.control", "simulate_tracking")
    ff = t.feedforward if t.feedforward is None or t.feedforward == "none" else tuple(t.feedforward)
    res = _call(
        sim,
        "tracking",
        ctx.robot,
        ctx.trajectory,
        ctx.gains,
        feedforward=("feedforward", ff),
        quantise=("quantise", None if t.quantise else False),
        t_after_s=("t_after_s", t.t_after_s),
        accuracy_m=("accuracy_m", t.accuracy_m),
    )
    ctx.tracking = res
    return {"status": "ok", **_to_dict(res)}


# ---------------------------------------------------------------------------- export
def controller_profile(ctx: StudyContext):
    """The controller profile with the study's cycle period / pulse limit applied."""
    c = ctx.spec.controller
    load = api("armlab.deploy", "load_profile")
    prof = load(None if c.profile is None else ctx.spec.resolve(c.profile))
    if c.cycle_s is not None:
        prof = prof.with_cycle(c.cycle_s)
    if c.pulse_limit is not None:
        prof = prof.replace(max_pulses_per_cycle=c.pulse_limit)
    return prof


def stage_export(ctx: StudyContext) -> dict:
    """Set-point table (with the deploy pre-flight checks), gains JSON and the trajectory file.

    Without an output folder (sweeps) the table is still built -- its checks run -- but nothing
    is written.
    """
    if ctx.trajectory is None:
        raise NotAvailable("needs a trajectory")
    from armlab.deploy.provenance import file_sha256

    prof = controller_profile(ctx)
    if ctx.robot.drives is None and prof.counts_per_joint_rev is None:
        raise NotApplicable(
            f"{ctx.robot.name} has no drives.toml and controller profile "
            f"{prof.name!r} gives no counts_per_joint_rev"
        )
    table = _call(
        api("armlab.deploy", "setpoint_table"),
        "export",
        ctx.robot,
        ctx.trajectory,
        prof,
        source=("source", {"study": ctx.spec.source, "study_sha256": ctx.spec.hash}),
    )
    ctx.setpoints = table
    block: dict[str, Any] = {
        "status": "ok",
        "profile": prof.name,
        "cycle_s": prof.cycle_s,
        "n_cycles": _n_rows(table),
        "files": {},
    }
    preflight = getattr(table, "meta", {}).get("preflight")
    if preflight is not None:
        block["preflight"] = _jsonable(preflight)
    out = ctx.out_dir
    if out is None:
        return block
    paths = {"setpoints.csv": None, "gains.json": None, "trajectory.npz": None}
    table.write(out / "setpoints.csv", format="csv")
    paths["setpoints.csv"] = out / "setpoints.csv"
    if ctx.gains is not None:
        api("armlab.deploy", "write_gains")(out / "gains.json", ctx.gains, format="json")
        paths["gains.json"] = out / "gains.json"
    api("armlab.deploy", "save_trajectory")(out / "trajectory.npz", ctx.trajectory, ctx.robot)
    paths["trajectory.npz"] = out / "trajectory.npz"
    for name, path in paths.items():
        if path is not None:
            block["files"][name] = {"path": name, "sha256": file_sha256(path)}
            ctx.files[name] = str(path)
    return block


def _n_rows(table) -> int | None:
    for attr in ("n_cycles", "n_rows"):
        if hasattr(table, attr):
            return int(getattr(table, attr))
    try:
        return len(table)
    except TypeError:
        return None


STAGE_FUNCTIONS = {
    "kinematics": stage_kinematics,
    "plan": stage_plan,
    "static_load": stage_static_load,
    "sizing": stage_sizing,
    "tuning": stage_tuning,
    "tracking": stage_tracking,
    "export": stage_export,
}

#: What a stage needs from the stages before it.
NEEDS = {
    "plan": ("kinematics",),
    "sizing": ("plan",),
    "tracking": ("plan", "tuning"),
    "export": ("plan",),
}
