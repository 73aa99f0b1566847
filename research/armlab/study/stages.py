"""The stages of a study: plain functions from the :class:`StudyContext` to a summary block.

Chain (DESIGN.md): robot -> kinematics checks -> plan -> static load -> sizing -> tuning ->
closed-loop tracking -> export. Each stage calls the package's public functions directly and
stores its typed result on the context (``ctx.trajectory``, ``ctx.sizing``, ``ctx.gains``, ...);
the block it returns is what summary.json holds for it.

Two facts are kept apart in every block (issue "status is not a verdict"):

* ``status``: whether the stage ran (``ok``), was ``skipped`` (with the reason) or stopped with an
  ``error``;
* ``verdict``: whether the design passes what the stage checks (``pass`` / ``fail``; ``None``
  where the stage checks nothing), with ``failed_checks``: one line per failed check.

A stage raises an :class:`armlab.ArmlabError` when its input is impossible (a waypoint out of
range, an infeasible plan, an impossible control spec); the runner records it and stops.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab.errors import InputError, LimitViolation, SpecError, UnreachableError
from armlab.study.build import (  # the robot and controller the stages share
    _per_joint,
    build_robot,
    controller_profile,
    rpy_to_matrix,
)
from armlab.study.context import NotApplicable, StudyContext, jsonable, jsonable_block
from armlab.study.drive_stages import (
    select_and_install,
    stage_sizing,
    stage_static_load,
    stage_tracking,
    stage_tuning,
)
from armlab.study.spec import StudySpec
from armlab.study.verdict import StageOutput

if TYPE_CHECKING:
    from armlab.collision import CollisionScene
    from armlab.robot.model import Robot
    from armlab.trajectory import Trajectory

__all__ = ["STAGE_FUNCTIONS", "NEEDS", "SUMMARY_KEY"]

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


# ---------------------------------------------------------------------------- robot
def selection_for_study(spec: StudySpec) -> StudyContext:
    """Plan a study's motion and select its drive train from the catalogue (``armlab drives``):
    the robot, kinematics, plan and static-load stages, then :func:`select_and_install` -- also
    for a robot that has drives (their encoders are kept) -- which selects, re-plans, tunes and
    simulates as the study's later stages will (:mod:`armlab.study.drive_choice`). The context
    holds the robot with the selected drives, the plan made with them, the selection and the
    sizing on the selection's duty cycle.

    Raises
    ------
    ArmlabError
        Bad input (names the study key), an infeasible plan, or a joint without a passing
        catalogue entry (:class:`armlab.InfeasibleError` naming the joint and the check).
    """
    from armlab.dynamics import size

    robot = build_robot(spec)
    ctx = StudyContext(spec, robot=robot, controller=controller_profile(spec, robot))
    for stage in ("kinematics", "plan", "static_load"):
        STAGE_FUNCTIONS[stage](ctx)
    duty = select_and_install(ctx)
    ctx.sizing = size(
        ctx.robot,
        duty,
        dt=spec.plan.check_dt_s,
        controller=ctx.controller,
        required_life_h=spec.sizing.required_life_h,
        momentary_load=spec.sizing.momentary_load,
    )
    return ctx


def robot_block(ctx: StudyContext) -> dict:
    """summary.json "robot" (besides its status): name, joints, payload, mass, drives."""
    r = ctx.robot
    block = {
        "name": r.name,
        "n_joints": r.n_joints,
        "joint_names": list(r.joint_names),
        "urdf": str(r.urdf_path),
        "tool_frame": r.tool_frame,
        "payload_kg": r.payload.mass_kg,
        "total_mass_kg": r.total_mass_kg,
        "transform_base_to_world": np.asarray(r.transform_base_to_world).tolist(),
        "limits": jsonable(r.limits.to_dict()),
        "controller": ctx.controller.name if ctx.controller is not None else None,
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
        T[:3, :3] = rpy_to_matrix(*_angles(row[3:], wp.unit))
        T[:3, 3] = row[:3]
        out.append(T)
    return np.array(out)


def _solve_ik(ctx: StudyContext, poses: np.ndarray) -> np.ndarray:
    """Joint waypoints from poses, keeping the IK branch continuous: the analytic solution
    nearest to the previous waypoint's (HEU thesis 3.4.2, 6.3.1) on arms that have one, numerical
    IK seeded with the previous waypoint otherwise. The first reference is ``waypoints.ik_seed``
    (default: the middle of the joint ranges)."""
    from armlab.kinematics import has_analytic_ik, ik, ik_nearest

    robot, wp = ctx.robot, ctx.spec.waypoints
    lim = robot.limits
    seed = (
        lim.centre_rad
        if wp.ik_seed is None
        else _per_joint(list(_angles(wp.ik_seed, wp.unit)), robot.n_joints, "waypoints.ik_seed")
    )
    if has_analytic_ik(robot):
        try:
            return np.atleast_2d(ik_nearest(robot, poses, seed, sequential=True))
        except UnreachableError as exc:
            raise UnreachableError(f"waypoints.cartesian: {exc}") from None
    out = []
    for k, pose in enumerate(poses):
        try:
            q = np.asarray(ik(robot, pose, seed, rng=np.random.default_rng(ctx.spec.study.seed)))
        except UnreachableError as exc:
            raise UnreachableError(f"waypoints.cartesian[{k}]: {exc}") from None
        out.append(q)
        seed = q
    return np.array(out)


def stage_kinematics(ctx: StudyContext) -> StageOutput:
    """Waypoints to joint space (IK for Cartesian ones), range check, TCP positions, reach, and
    the optional Monte-Carlo workspace and accuracy studies."""
    from armlab.kinematics import fk, max_reach_m
    from armlab.trajectory.waypoints import validate_waypoints

    spec, robot = ctx.spec, ctx.robot
    wp = spec.waypoints
    ctx.waypoint_poses = waypoint_poses(spec)
    if wp.joint is not None:
        q = _angles(wp.joint, wp.unit)
        where, source = "waypoints.joint", "joint"
    else:
        assert ctx.waypoint_poses is not None  # the spec gives joint or Cartesian waypoints
        q = _solve_ik(ctx, ctx.waypoint_poses)
        where, source = "waypoints.cartesian", "cartesian (IK)"
    q = validate_waypoints(robot, q, where=where, min_rows=1, unit=wp.unit)
    ctx.waypoints_q, ctx.waypoints_from = q, source
    ctx.tcp_positions_m = np.array([fk(robot, row)[:3, 3] for row in q])
    ctx.max_reach_m = max_reach_m(robot, seed=spec.study.seed)
    block = {
        "waypoints_from": source,
        "n_waypoints": int(len(q)),
        "waypoints_rad": q.tolist(),
        "tcp_positions_m": ctx.tcp_positions_m.tolist(),
        "max_reach_m": ctx.max_reach_m,
    }
    ks = spec.kinematics
    if ks.workspace_samples:
        from armlab.kinematics import workspace_cloud

        res = workspace_cloud(robot, n_samples=ks.workspace_samples, seed=spec.study.seed)
        ctx.workspace = res
        block["workspace"] = {"status": "ok", **jsonable_block(res)}
    if ks.accuracy_samples:
        if robot.dh is None:
            block["accuracy"] = {"status": "skipped", "reason": f"{robot.name} has no DH table"}
        else:
            from armlab.kinematics import accuracy_study

            acc = accuracy_study(robot, n_samples=ks.accuracy_samples, seed=spec.study.seed)
            ctx.accuracy = acc
            block["accuracy"] = {"status": "ok", **jsonable_block(acc)}
    return StageOutput(block)


# ---------------------------------------------------------------------------- plan
def planning_robot(ctx: StudyContext) -> Robot:
    """The robot with its velocity/acceleration/jerk limits scaled by s, s^2, s^3
    (:meth:`armlab.robot.Limits.scaled`, ``plan.speed_scale``), then its speeds held to whole
    encoder counts per controller cycle (:meth:`armlab.robot.ControllerProfile.robot_for_planning`),
    so that the set-point table's rounded counts keep the limits."""
    s = ctx.spec.plan.speed_scale
    robot = ctx.robot if s == 1.0 else ctx.robot.with_limits(ctx.robot.limits.scaled(s))
    return _in_whole_counts(ctx, robot)


def _in_whole_counts(ctx: StudyContext, robot: Robot) -> Robot:
    """``robot`` with speed limits whose set-point counts keep them after rounding
    (:meth:`armlab.robot.ControllerProfile.sendable_velocity_rad_s`; issue 24 item 6)."""
    return robot if ctx.controller is None else ctx.controller.robot_for_planning(robot)


def _concat(parts):
    out = parts[0]
    for p in parts[1:]:
        out = out.concat(p, tol=1e-6)
    return out


def plan_trajectory(ctx: StudyContext) -> Trajectory:
    """Run the planner the study names; returns a Trajectory.

    The jerk limits are honoured by ``optimal`` and ``path`` unless ``plan.jerk_limits = false``
    and by the S-curve ``ptp`` profile; the other classical planners do not limit jerk
    (``ctx.jerk_limited`` records which, so the plan check enforces only what was planned for).
    """
    from armlab import planning as T

    plan, robot = ctx.spec.plan, planning_robot(ctx)
    Q = ctx.waypoints_q
    assert Q is not None  # set by stage_kinematics, which runs first
    tau_max = None if plan.torque_limits else False
    if plan.planner in ("optimal", "path"):
        ctx.jerk_limited = True if plan.jerk_limits is None else plan.jerk_limits
        limits: dict[str, Any] = {
            "tau_max": tau_max,
            "j_max": None if ctx.jerk_limited else False,
            "drive_limits": plan.drive_limits,  # the envelope replaces the torque box
        }
        if plan.planner == "path":  # the cubic spline through the waypoints, time-optimally
            return T.time_optimal_path(robot, Q, **limits)
        opts: dict[str, Any] = {"objective": plan.objective}
        if plan.duration_s is not None:
            opts["duration"] = plan.duration_s
        # issue 27: optimal plans around what the plan stage's collision check would refuse
        opts["clearance"] = ctx.collision_scene
        return T.optimal(robot, Q, **opts, **limits)
    # classical planners sample at the check step (the controller cycle by default), so the
    # set-point table hits their samples and never interpolates across a profile corner
    dt = plan.check_dt_s
    if plan.planner == "ptp":
        ctx.jerk_limited = plan.profile == "scurve"
        return _concat(
            [
                T.ptp_sync(robot, Q[i], Q[i + 1], profile=plan.profile, dt=dt, tau_max=tau_max)
                for i in range(len(Q) - 1)
            ]
        )
    ctx.jerk_limited = False
    if plan.planner == "cubic":
        durations = None
        if plan.duration_s is not None:
            d = np.linalg.norm(np.diff(Q, axis=0), axis=1)
            durations = plan.duration_s * d / d.sum()
        return T.cubic_via(robot, Q, durations=durations, dt=dt, tau_max=tau_max)
    poses = ctx.waypoint_poses
    speed = plan.speed_m_s
    if speed is None:
        raise SpecError(f"plan.speed_m_s: missing (required by planner {plan.planner!r})")
    if poses is None:
        raise SpecError(f"waypoints.cartesian: required by planner {plan.planner!r}")
    # the IK branch of the first waypoint starts the path; each line starts where the last ended
    if plan.planner == "line":
        parts, q0 = [], Q[0]
        for i in range(len(poses) - 1):
            parts.append(
                T.line(robot, poses[i], poses[i + 1], speed, q_start=q0, dt=dt, tau_max=tau_max)
            )
            q0 = parts[-1].q[-1]
        return _concat(parts)
    if plan.planner == "arc3":
        return T.arc3(
            robot, poses[0], poses[1], poses[2], speed, q_start=Q[0], dt=dt, tau_max=tau_max
        )
    return T.blend(robot, poses, plan.blend_radius_m, speed, q_start=Q[0], dt=dt, tau_max=tau_max)


def _plan_budget(ctx: StudyContext) -> None:
    """Refuse a plan whose check grid would exceed :data:`armlab.study.budget.MAX_SAMPLES`
    before planning: its duration is at least :func:`~armlab.study.budget.min_duration_s` at the
    scaled limits (and the fixed ``plan.duration_s``, the Cartesian path length over
    ``plan.speed_m_s``)."""
    from armlab.study.budget import check_samples, min_duration_s

    plan, Q = ctx.spec.plan, ctx.waypoints_q
    assert Q is not None  # set by stage_kinematics
    duration = min_duration_s(Q, planning_robot(ctx).limits.velocity_rad_s)
    keys = [f"plan.speed_scale = {plan.speed_scale:g}", f"plan.check_dt_s = {plan.check_dt_s:g}"]
    if plan.duration_s is not None:
        duration = max(duration, plan.duration_s)
        keys.append(f"plan.duration_s = {plan.duration_s:g}")
    poses = ctx.waypoint_poses
    if plan.speed_m_s is not None and poses is not None and len(poses) > 1:
        path = float(np.sum(np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1)))
        duration = max(duration, path / plan.speed_m_s)
        keys.append(f"plan.speed_m_s = {plan.speed_m_s:g}")
    check_samples(
        duration / plan.check_dt_s,
        ctx.robot.n_joints,
        ", ".join(keys),
        f"the plan lasts at least {duration:.3g} s, checked every {plan.check_dt_s:g} s",
    )


def collision_scene(ctx: StudyContext) -> CollisionScene:
    """The study's collision scene (``ctx.collision_scene``, built once), with its waypoints
    checked: a waypoint in collision or closer than ``plan.clearance_m`` is bad input
    (:class:`~armlab.errors.InputError`, one line naming the waypoint, the pair and the depth).
    """
    from armlab.collision import CollisionScene

    if ctx.collision_scene is None:
        ctx.collision_scene = CollisionScene.from_study(ctx.spec, ctx.robot)
    scene = ctx.collision_scene
    assert ctx.waypoints_q is not None  # set by stage_kinematics
    where = "waypoints.joint" if ctx.spec.waypoints.joint is not None else "waypoints.cartesian"
    c = scene.clearance_m
    for k, q in enumerate(ctx.waypoints_q):
        dist = scene.distances(q)
        i = dist.closest()
        if i >= 0 and dist.distance_m[i] < c:
            d = float(dist.distance_m[i])
            how = (
                f"in collision: {dist.pair_name(i)} penetrate {1e3 * -d:.3g} mm"
                if d < 0
                else f"{1e3 * d:.3g} mm from {dist.pair_name(i)}, inside plan.clearance_m = "
                f"{1e3 * c:.3g} mm"
            )
            raise InputError(f"{where}[{k}]: {how}")
    return scene


def stage_plan(ctx: StudyContext) -> StageOutput:
    """Plan, then check the plan on a fine grid against the robot's full limits and for
    collisions.

    A plan that breaks a kinematic limit it was planned for (range, velocity, acceleration, and
    jerk where ``ctx.jerk_limited``) is refused with :class:`LimitViolation` naming the limit,
    joint and time: that is a planner error, not a design property. A torque ratio above 1 (with
    ``plan.torque_limits = false``) or a jerk ratio above 1 of a planner that does not limit jerk
    is a failed check of the design (verdict ``fail``).

    Collisions (:mod:`armlab.collision`): the waypoints are checked first (one in collision or
    closer than ``plan.clearance_m`` is bad input), the whole plan after it is made
    (:func:`~armlab.collision.check_motion`, certified between samples); a plan that collides
    or comes closer than ``plan.clearance_m`` is refused with
    :class:`~armlab.collision.CollisionError` naming the pair, the time and the depth, so no
    later stage runs and no table is written.
    """
    spec = ctx.spec
    _plan_budget(ctx)
    scene = collision_scene(ctx)
    traj = plan_trajectory(ctx)
    assert ctx.waypoints_q is not None  # plan_trajectory needs them
    ctx.trajectory = traj
    robot = ctx.robot
    # with plan.drive_limits the motor envelope replaces the torque box (checked below)
    torque = robot.limits.torque_Nm is not None and not spec.plan.drive_limits
    # a trajectory already sampled at least as finely as the check step is checked at its own
    # samples: they are the planner's exact values (resampling would interpolate across the
    # acceleration steps of a trapezoid)
    fine = traj.n_samples > 1 and np.max(np.diff(traj.t)) <= spec.plan.check_dt_s * (1 + 1e-9)
    report = traj.check_limits(robot, dt=None if fine else spec.plan.check_dt_s, torque=torque)
    ctx.limit_report = report
    enforced = [k for k in _KINEMATIC if k != "jerk" or ctx.jerk_limited]
    failed = []
    for kind, joint, ratio, at in report.violations(tol=1e-6):
        if kind in enforced:
            raise LimitViolation(
                f"the {traj.method or spec.plan.planner} plan breaks the "
                f"{kind} limit of {joint} ({ratio:.4g} x the limit at "
                f"t = {at:.4g} s)"
            )
        failed.append(f"plan: {kind} of {joint} is {ratio:.4g} x its limit at t = {at:.4g} s")
    drive: dict[str, list[float]] = {}
    if spec.plan.drive_limits:  # the independent per-sample check of the motor envelope
        from armlab.planning.timescale import drive_check
        from armlab.robot.drivetrain import drive_train

        ratios = drive_check(traj, planning_robot(ctx), drive_train(robot), spec.plan.check_dt_s)
        drive = {k: r.tolist() for k, r in ratios.items()}
        for k, r in ratios.items():
            for j in np.flatnonzero(r > 1 + 1e-6):
                failed.append(f"plan: {k} of {robot.joint_names[j]} is {r[j]:.4g} x its limit")
    from armlab.collision import check_motion

    peak = report.ratios.get("velocity")  # exact peaks (knots and interior extremes)
    qd_max = None if peak is None else peak * robot.limits.velocity_rad_s * (1 + 1e-9)
    ctx.clearance = clearance = check_motion(scene, traj, qd_max=qd_max)
    clearance.raise_if_failed(f"the {traj.method or spec.plan.planner} plan")
    kind, joint, ratio = report.worst()
    block = {
        "planner": spec.plan.planner,
        "method": traj.method,
        "duration_s": traj.duration,
        "n_waypoints": int(len(ctx.waypoints_q)),
        "n_samples": traj.n_samples,
        "speed_scale": spec.plan.speed_scale,
        "check_dt_s": spec.plan.check_dt_s,
        "jerk_limited": ctx.jerk_limited,
        "peak_ratio": {k: float(np.max(r)) for k, r in report.ratios.items()},
        "peak_joint": {k: report.joint_names[int(np.argmax(r))] for k, r in report.ratios.items()},
        "ratios": report.to_dict(),
        "feasible": report.ok(tol=1e-6),
        "drive_ratios": drive,
        "worst": {"kind": kind, "joint": joint, "ratio": ratio},
        "stats": jsonable(getattr(traj, "stats", {})),
        "clearance": jsonable(clearance.to_dict()),
        "collision": {
            "geometry": scene.source,
            "n_pairs": scene.n_pairs,
            "disabled_pairs": scene.disabled.path or scene.disabled.origin,
            "obstacles": [o.name for o in scene.obstacles],
            "floor_z_m": scene.floor_z_m,
        },
    }
    return StageOutput(block, failed_checks=failed)


# ---------------------------------------------------------------------------- export
def stage_export(ctx: StudyContext) -> StageOutput:
    """Set-point table for the study's controller (with the deploy pre-flight checks), gains JSON
    and the trajectory file.

    The table is always built, so its pre-flight checks run; a table that breaks a controller
    limit is a failed check of the design. Files are written only into an output folder and only
    for a design that passes every stage (``ctx.failed_so_far`` empty), unless ``ctx.force``;
    a forced export records the failed checks in the table's header.
    """
    from armlab.deploy import save_trajectory, setpoint_table, write_gains
    from armlab.deploy.provenance import file_sha256

    prof = ctx.controller
    if ctx.robot.drives is None and prof.counts_per_joint_rev is None:
        raise NotApplicable(
            f"{ctx.robot.name} has no drives.toml and controller profile "
            f"{prof.name!r} gives no counts_per_joint_rev"
        )
    from armlab.study.budget import check_table_rows

    assert ctx.trajectory is not None  # NEEDS: plan
    check_table_rows(ctx.trajectory, prof, ctx.robot.n_joints)
    source: dict[str, Any] = {"study": ctx.spec.source, "study_sha256": ctx.spec.hash}
    if ctx.failed_so_far:
        source["forced_despite"] = list(ctx.failed_so_far)
    from armlab.study.export_target import carried_block

    tracked = ctx.records.get("tracking")
    verified = (
        tuple(ctx.tracking.feedforward)
        if ctx.tracking is not None and tracked is not None and tracked.status == "ok"
        else None
    )
    source["controller"] = carried_block("csv", verified)  # what the table's controller runs
    try:
        table = setpoint_table(ctx.robot, ctx.trajectory, prof, source=source)
    except LimitViolation as exc:
        refused = {"profile": prof.name, "cycle_s": prof.cycle_s, "written": False, "files": {}}
        return StageOutput(refused, failed_checks=[f"export: {exc}"])
    ctx.setpoints = table
    block: dict[str, Any] = {
        "profile": prof.name,
        "cycle_s": prof.cycle_s,
        "n_cycles": table.n_cycles,
        "files": {},
        "written": False,
    }
    preflight = table.meta.get("preflight")
    if preflight is not None:
        block["preflight"] = jsonable(preflight)
    out = ctx.out_dir
    if out is None:
        return StageOutput(block, failed_checks=[])
    paths: dict[str, Path] = {}
    save_trajectory(out / "trajectory.npz", ctx.trajectory, ctx.robot)
    paths["trajectory.npz"] = out / "trajectory.npz"
    if ctx.gains is not None:
        write_gains(out / "gains.json", ctx.gains, format="json")
        paths["gains.json"] = out / "gains.json"
    if ctx.failed_so_far and not ctx.force:
        block["reason"] = (
            "setpoints.csv not written: the design fails "
            f"{len(ctx.failed_so_far)} check(s) (armlab run --force writes it anyway)"
        )
    else:
        table.write(out / "setpoints.csv", format="csv")
        paths["setpoints.csv"] = out / "setpoints.csv"
        block["written"] = True
        block["forced"] = bool(ctx.failed_so_far)
    for name, path in paths.items():
        ctx.exported[name] = file_sha256(path)
        block["files"][name] = {"path": name, "sha256": ctx.exported[name]}
        ctx.files[name] = str(path)
    return StageOutput(block, failed_checks=[])


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
