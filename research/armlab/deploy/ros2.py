"""ros2_control exports: the controllers YAML ``controller_manager`` loads, and the plan as a
``control_msgs/action/FollowJointTrajectory`` goal.

Sources (parameter names, types and message fields; the tests check against copies of them in
``tests/data/ros2/``): ros2_controllers 6.9.0
``joint_trajectory_controller/src/joint_trajectory_controller_parameters.yaml`` and
``joint_trajectory_plugin.xml``; ros2_control 6.8.0
``controller_manager/src/controller_manager_parameters.yaml``; control_toolbox 6.3.0
``src/pid.cpp`` (the PID law below); control_msgs 6.8.0 ``action/FollowJointTrajectory.action``
and ``msg/JointTolerance.msg``; common_interfaces 5.4.2 ``trajectory_msgs/msg/JointTrajectory.msg``
and ``JointTrajectoryPoint.msg``.

Controllers YAML (:func:`ros2_controllers_yaml`)
-------------------------------------------------
``controller_manager: ros__parameters: update_rate`` [Hz] (the servo period of the gains) and
``<name>: type: joint_trajectory_controller/JointTrajectoryController``; then
``<name>: ros__parameters:`` with ``joints``, ``command_interfaces: [velocity]``,
``state_interfaces: [position, velocity]``, per joint ``gains`` and the ``constraints``.

With a velocity command interface the JointTrajectoryController (JTC) commands
``v = ff_velocity_scale v_d + PID(e, v_d - v)`` per joint; control_toolbox's PID is
``u = p e + i_term + d (v_d - v)``, ``u`` clamped to ``[u_clamp_min, u_clamp_max]``, ``i_term``
(forward Euler of ``i e``) clamped to ``[i_clamp_min, i_clamp_max]``. armlab's position loop
(thesis ch. 5) maps motor position error to motor speed; both scale with the reducer ratio, so
joint side:

* ``p`` = kp [1/s], ``i`` = ki [1/s^2], ``d`` = kd [1] (armlab's derivative filter has no JTC
  counterpart);
* ``u_clamp_max``/``u_clamp_min`` = the loop's output limits / reducer ratio [rad/s] (JTC clamps
  the PID part only; the velocity feed-forward is added after); left out when unlimited (the
  JTC default is +-inf);
* ``i_clamp_max``/``i_clamp_min`` = the same limits (rule: the integral alone never asks more
  than the loop may output);
* ``antiwindup_strategy``: ``conditional_integration`` when ``ki > 0`` (the incremental PID of
  armlab stops integrating at its output limit), else ``none``;
* ``ff_velocity_scale``: 1.0 when the study's tracking fed the planned velocity forward
  (armlab's default), else 0.0.

Constraints (:func:`jtc_constraints`), from the study's accuracy budget ``A`` (the TCP error
the tracking stage allowed, default 0.5 mm: half of the thesis' 1 mm, see
:mod:`armlab.control.simulate`) and each joint's lever arm ``L_j`` to the tool point
(:func:`armlab.dynamics.sizing.lever_arms_m`, an upper bound), first order ``|dx| <= sum L_j
|dq_j|``:

* ``trajectory`` (path) tolerance ``A / L_j``: a larger error of this joint alone can take the
  TCP out of the budget, so the JTC aborts;
* ``goal`` tolerance ``A / (n L_j)``: the budget shared equally by the n joints, so every joint
  inside its goal tolerance keeps the TCP inside ``A``;
* a joint with no lever arm (``L_j`` ~ 0) gets 0 (JTC: not checked);
* ``goal_time``: the slowest position loop's settling time (2 %, worst inertia, discrete if
  known; else ``4 / kp``), the time the servo needs after the last point;
* ``stopped_velocity_tolerance``: one encoder count per servo period of the coarsest joint,
  ``max_j 1 / (counts_per_rad_j T)`` -- a slower joint reads 0 or 1 count per period, i.e. is
  stopped as far as the servo can tell (JTC default 0.01 rad/s without encoders).

A goal tolerance below one encoder count is refused: the servo could never meet it.

Trajectory goal (:func:`render_follow_joint_trajectory`)
---------------------------------------------------------
JSON ``{"format", "meta", "action_type", "goal"}``; ``goal`` is the FollowJointTrajectory goal:
``trajectory`` (``trajectory_msgs/JointTrajectory``: ``header``, ``joint_names``, ``points`` with
``positions`` [rad], ``velocities`` [rad/s], ``accelerations`` [rad/s^2] and ``time_from_start``
``{sec, nanosec}``), ``path_tolerance``/``goal_tolerance`` (``JointTolerance``: name, position,
velocity, acceleration; 0 = the controller's default) and ``goal_time_tolerance``. The points
are the set-point table's rows (one per controller cycle, pre-flight checked); numbers are
fixed-point decimals, so the text is also YAML 1.1 (``ros2 action send_goal`` reads the
``goal`` object as written). The goal is checked as the JTC checks it before writing
(:func:`check_joint_trajectory`): joints and points present, times strictly increasing, all
arrays of the joints' length, finite, zero velocity at the last point.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab._keywords import renamed_keywords
from armlab.deploy.gains_export import _as_arm_gains, _provenance
from armlab.deploy.numtext import format_rows
from armlab.errors import InputError
from armlab.names import one_line

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "JTC_TYPE",
    "FOLLOW_JOINT_TRAJECTORY_FORMAT",
    "JtcConstraints",
    "jtc_constraints",
    "ros2_controllers_yaml",
    "render_follow_joint_trajectory",
    "check_joint_trajectory",
]

#: Plugin class of the JointTrajectoryController (ros2_controllers joint_trajectory_plugin.xml).
JTC_TYPE = "joint_trajectory_controller/JointTrajectoryController"
FOLLOW_JOINT_TRAJECTORY_FORMAT = "armlab.follow_joint_trajectory/1"
#: The JTC refuses a goal whose last velocity exceeds float epsilon (validate_trajectory_msg).
_FLOAT_EPS = float(np.finfo(np.float32).eps)
#: Lever arms below this [m] cannot move the tool point: tolerance not checked.
_TINY_LEVER_M = 1e-9
_DECIMALS = 9


# ---------------------------------------------------------------------- YAML text
def _yaml_float(x: float) -> str:
    """A YAML float both YAML 1.1 (PyYAML) and the ROS 2 parameter parser read as a double."""
    x = float(x)
    if math.isnan(x):
        return ".nan"
    if math.isinf(x):
        return ".inf" if x > 0 else "-.inf"
    s = repr(x)
    if "e" in s and "." not in s.split("e")[0]:  # 1e-05 is a string in YAML 1.1: write 1.0e-05
        mant, exp = s.split("e")
        s = f"{mant}.0e{exp}"
    return s


#: YAML 1.1 reads a mapping key (an implicit key) of at most 1024 characters
_YAML_MAX_KEY = 1024


def _yaml_key(s: str) -> str:
    """``s`` as a YAML scalar that reads back as exactly ``s`` (YAML 1.1 and 1.2): plain when it
    is an ASCII word that no YAML resolver turns into a bool, null or number, else a
    double-quoted scalar with every character outside printable ASCII escaped (``\\x``,
    ``\\u``, ``\\U``: no line break, no lone surrogate pair). Joint and controller names keep
    the name policy (:mod:`armlab.names`); this is the writer's own defence.

    Raises
    ------
    InputError
        ``s`` is longer than a YAML mapping key may be (1024 characters).
    """
    s = str(s)
    if len(s) > _YAML_MAX_KEY - 2:
        raise InputError(
            f"name {s[:40]!r}... ({len(s)} characters) is too long for a YAML key "
            f"(at most {_YAML_MAX_KEY - 2})"
        )
    plain = (
        s
        and all(c.isascii() and (c.isalnum() or c in "_-/") for c in s)
        and not s[0].isdigit()
        and s[0] != "-"
        and s.lower() not in ("true", "false", "yes", "no", "on", "off", "null", "y", "n")
    )
    if plain:
        return s
    out = []
    for c in s:
        o = ord(c)
        if c in '"\\':
            out.append("\\" + c)
        elif 0x20 <= o <= 0x7E:
            out.append(c)
        elif o <= 0xFF:
            out.append(f"\\x{o:02x}")
        elif o <= 0xFFFF:
            out.append(f"\\u{o:04x}")
        else:
            out.append(f"\\U{o:08x}")
    return '"' + "".join(out) + '"'


# ---------------------------------------------------------------------- constraints
@dataclass(frozen=True)
class JtcConstraints:
    """The JTC ``constraints`` of a design (rules in the module docstring).

    Attributes
    ----------
    goal_time_s : float
        Time tolerance after the last point in [s].
    stopped_velocity_tolerance_rad_s : float
        Speed below which a joint counts as stopped in [rad/s].
    trajectory_rad, goal_rad : dict of str to float
        Per joint path and goal position tolerance in [rad] (0: not checked).
    accuracy_m : float
        The accuracy budget (TCP error) in [m] the tolerances come from.
    rules : dict of str to str
        How each value was found (recorded in the files).
    """

    goal_time_s: float
    stopped_velocity_tolerance_rad_s: float
    trajectory_rad: dict[str, float]
    goal_rad: dict[str, float]
    accuracy_m: float
    rules: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return asdict(self)


def _goal_time_s(arm) -> tuple[float, str]:
    worst, how = 0.0, ""
    for cg in arm:
        pos = cg.position
        for key in ("settling_time_discrete_s", "settling_time_s"):
            v = float(getattr(pos, key))
            if math.isfinite(v) and v > 0:
                cand, rule = v, key
                break
        else:
            cand, rule = 4.0 / pos.kp, "4 / kp"
        if cand > worst:
            worst, how = cand, f"{cg.joint} position loop {rule}"
    return worst, how


@renamed_keywords(profile="controller=")
def jtc_constraints(
    robot: Robot,
    gains=None,
    *,
    accuracy_m: float,
    controller,
    accuracy_source: str = "",
) -> JtcConstraints:
    """The JTC constraints of ``robot`` from the accuracy budget (module docstring rules).

    Parameters
    ----------
    robot : Robot
        Lever arms from its model; encoder counts from its drives (or the controller's).
    gains : ArmGains, optional
        The position loops give ``goal_time`` (0 without gains: the JTC then waits unbounded).
    accuracy_m : float
        The TCP error budget in [m] (> 0).
    controller : ControllerProfile or str
        Counts per radian and servo period (:func:`armlab.robot.load_profile`).
    accuracy_source : str
        Where the budget comes from (recorded).

    Raises
    ------
    InputError
        A budget that is not > 0, or a goal tolerance below one encoder count.
    """
    from armlab.dynamics.sizing import lever_arms_m
    from armlab.robot.controller import load_profile

    A = float(accuracy_m)
    if not (math.isfinite(A) and A > 0):
        raise InputError(f"accuracy budget must be > 0 m, got {accuracy_m!r}")
    prof = load_profile(controller)
    names = list(robot.joint_names)
    n = len(names)
    lever = np.asarray(lever_arms_m(robot), dtype=float)
    moving = lever > _TINY_LEVER_M
    path = np.where(moving, A / np.where(moving, lever, 1.0), 0.0)
    goal = path / n
    try:
        cpr = prof.counts_per_rad(robot)
    except InputError:
        cpr = None
    if cpr is not None:
        bad = moving & (goal * cpr < 1.0)
        if bad.any():
            j = int(np.argmax(bad))
            raise InputError(
                f"accuracy budget {A * 1e3:.4g} mm gives joint {names[j]} a goal tolerance of "
                f"{goal[j]:.3g} rad, below one encoder count ({1 / cpr[j]:.3g} rad)"
            )
        stopped = float(np.max(1.0 / (cpr * prof.servo_period_s)))
        stopped_rule = (
            f"one encoder count per servo period ({prof.servo_period_s:g} s) of the coarsest joint"
        )
    else:
        stopped, stopped_rule = 0.01, "JTC default (no encoder counts known)"
    if gains is not None:
        goal_time, goal_time_rule = _goal_time_s(_as_arm_gains(gains))
    else:
        goal_time, goal_time_rule = 0.0, "no gains: 0 (JTC waits without limit)"
    return JtcConstraints(
        goal_time_s=goal_time,
        stopped_velocity_tolerance_rad_s=stopped,
        trajectory_rad=dict(zip(names, map(float, path), strict=True)),
        goal_rad=dict(zip(names, map(float, goal), strict=True)),
        accuracy_m=A,
        rules={
            "accuracy_m": accuracy_source or "given",
            "trajectory": "accuracy_m / lever arm of the joint",
            "goal": f"accuracy_m / ({n} joints x lever arm of the joint)",
            "goal_time": goal_time_rule,
            "stopped_velocity_tolerance": stopped_rule,
        },
    )


# ---------------------------------------------------------------------- controllers YAML
def _update_rate_hz(arm) -> int:
    periods = {cg.position.sample_time_s for cg in arm}
    if len(periods) != 1:
        raise InputError(f"the position loops have different sample times {sorted(periods)} s")
    T = periods.pop()
    rate = 1.0 / T
    if abs(rate - round(rate)) > 1e-6 * rate:
        raise InputError(f"servo period {T} s is not a whole number of Hz (update_rate is int)")
    return int(round(rate))


def ros2_controllers_yaml(
    gains,
    *,
    controller_name: str = "joint_trajectory_controller",
    joints: list[str] | None = None,
    update_rate_hz: int | None = None,
    constraints: JtcConstraints | None = None,
    ff_velocity_scale: float = 1.0,
    source: dict | None = None,
) -> str:
    """A ros2_control controllers YAML (module docstring): controller_manager + JTC.

    Parameters
    ----------
    gains : ArmGains or CascadeGains
        The position loop of each joint becomes its JTC ``gains`` entry.
    controller_name : str
    joints : list of str, optional
        Controller joints (default: the joints of ``gains``); each needs gains.
    update_rate_hz : int, optional
        controller_manager rate in [Hz]; default ``1 / sample time`` of the position loops.
    constraints : JtcConstraints, optional
        Written as the JTC ``constraints`` block.
    ff_velocity_scale : float
        Velocity feed-forward of every joint (1.0: the planned velocity).
    source : dict, optional
        Provenance (``file``, ``sha256``) recorded in a comment.

    Raises
    ------
    InputError
        A joint without gains, or a servo period that is not a whole number of Hz.
    """
    arm = _as_arm_gains(gains)
    prov = _provenance(arm, source)
    names = list(arm.joint_names) if joints is None else list(joints)
    missing = [j for j in names if j not in arm.joints]
    if missing:
        raise InputError(f"no gains for joint(s) {missing}: tune every controller joint")
    rate = _update_rate_hz(arm) if update_rate_hz is None else int(update_rate_hz)
    if rate < 1:
        raise InputError(f"update_rate must be >= 1 Hz, got {rate}")
    name = _yaml_key(controller_name)
    lines = [
        "# ros2_control controllers -- generated by armlab.deploy, do not edit.",
        f"# robot: {one_line(arm.robot or '?')}; gains sha256: {prov['gains_sha256']}; "
        f"armlab {prov['armlab_version']}",
    ]
    if source:
        lines.append(f"# source: {json.dumps(source)}")
    lines += [
        "# Keys: ros2_controllers 6.9.0 joint_trajectory_controller parameters. Gains: the",
        "# position loop of the cascade (thesis ch. 5), joint side: p [1/s], i [1/s^2], d [1];",
        "# u_clamp_*, i_clamp_* [rad/s] = position-loop output limits / reducer ratio.",
        "controller_manager:",
        "  ros__parameters:",
        f"    update_rate: {rate}  # [Hz]",
        f"    {name}:",
        f"      type: {json.dumps(JTC_TYPE)}",
        "",
        f"{name}:",
        "  ros__parameters:",
        "    joints:",
    ]
    lines += [f"      - {_yaml_key(j)}" for j in names]
    lines += [
        "    command_interfaces:",
        "      - velocity",
        "    state_interfaces:",
        "      - position",
        "      - velocity",
        "    gains:",
    ]
    for j in names:
        cg = arm.joints[j]
        pos = cg.position
        ratio = cg.plant.ratio if cg.plant is not None and cg.plant.ratio > 0 else 1.0
        lines += [
            f"      {_yaml_key(j)}:",
            f"        p: {_yaml_float(pos.kp)}",
            f"        i: {_yaml_float(pos.ki)}",
            f"        d: {_yaml_float(pos.kd)}",
            f"        ff_velocity_scale: {_yaml_float(ff_velocity_scale)}",
        ]
        for key, limit in (("max", pos.output_max), ("min", pos.output_min)):
            if math.isfinite(limit):
                lines += [
                    f"        u_clamp_{key}: {_yaml_float(limit / ratio)}",
                    f"        i_clamp_{key}: {_yaml_float(limit / ratio)}",
                ]
        strategy = "conditional_integration" if pos.ki > 0 else "none"
        lines.append(f"        antiwindup_strategy: {strategy}")
    if constraints is not None:
        c = constraints
        lines += [
            f"    # constraints from the accuracy budget {c.accuracy_m * 1e3:.6g} mm "
            f"({c.rules.get('accuracy_m', '')}):",
            f"    # trajectory = {c.rules.get('trajectory', '')};",
            f"    # goal = {c.rules.get('goal', '')};",
            f"    # goal_time = {c.rules.get('goal_time', '')}; stopped_velocity_tolerance = "
            f"{c.rules.get('stopped_velocity_tolerance', '')}",
            "    constraints:",
            f"      stopped_velocity_tolerance: {_yaml_float(c.stopped_velocity_tolerance_rad_s)}",
            f"      goal_time: {_yaml_float(c.goal_time_s)}",
        ]
        for j in names:
            if j not in c.trajectory_rad:
                raise InputError(f"constraints have no tolerance for joint {j}")
            lines += [
                f"      {_yaml_key(j)}:",
                f"        trajectory: {_yaml_float(c.trajectory_rad[j])}",
                f"        goal: {_yaml_float(c.goal_rad[j])}",
            ]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------- trajectory goal
def _check_arrays(
    joint_names: list[str], t_ns: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray
) -> None:
    """The JTC's validate_trajectory_msg rules on arrays (points x joints)."""
    if not joint_names:
        raise InputError("joint trajectory: no joint names")
    if len(set(joint_names)) != len(joint_names):
        raise InputError(f"joint trajectory: repeated joint names {joint_names}")
    if t_ns.size == 0:
        raise InputError("joint trajectory: no points")
    n = len(joint_names)
    for what, a in (("positions", q), ("velocities", qd), ("accelerations", qdd)):
        if a.shape != (t_ns.size, n):
            raise InputError(f"joint trajectory: {what} are not {n} values per point")
        if not np.all(np.isfinite(a)):
            k = int(np.argwhere(~np.isfinite(a))[0][0])
            raise InputError(f"joint trajectory: {what} of point {k} are not finite")
    step = np.diff(t_ns)
    if np.any(step <= 0):
        k = int(np.argmax(step <= 0)) + 1
        raise InputError(f"joint trajectory: time_from_start of point {k} is not increasing")
    last = np.abs(qd[-1])
    if np.any(last > _FLOAT_EPS):
        j = int(np.argmax(last > _FLOAT_EPS))
        raise InputError(
            f"joint trajectory: joint {joint_names[j]} ends at {float(qd[-1, j])!r} rad/s; the JTC "
            "refuses a last point that moves"
        )


def check_joint_trajectory(trajectory: dict) -> None:
    """Check a ``trajectory_msgs/JointTrajectory`` (as a dict) as the JTC does on receipt.

    Raises
    ------
    InputError
        No joints or points, point arrays of the wrong length or not finite, times not
        strictly increasing, or a last point with velocity.
    """
    try:
        names = [str(j) for j in trajectory["joint_names"]]
        pts = list(trajectory["points"])
        t_ns = np.array(
            [
                int(p["time_from_start"]["sec"]) * 10**9 + int(p["time_from_start"]["nanosec"])
                for p in pts
            ],
            dtype=np.int64,
        )
        arrays = []
        for key in ("positions", "velocities", "accelerations"):
            rows = [np.asarray(p[key], dtype=float).reshape(-1) for p in pts]
            for k, r in enumerate(rows):
                if r.size != len(names):
                    raise InputError(
                        f"joint trajectory: {key} of point {k} are not {len(names)} values per "
                        "point"
                    )
            arrays.append(np.array(rows).reshape(len(pts), len(names)))
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"joint trajectory: malformed ({exc!r})") from None
    _check_arrays(names, t_ns, *arrays)


def _fixed(x: float) -> str:
    return format_rows([np.array([float(x)])], _DECIMALS, suffix="").decode()


def _duration(seconds: float) -> dict:
    ns = int(round(float(seconds) * 1e9))
    return {"sec": ns // 10**9, "nanosec": ns % 10**9}


def render_follow_joint_trajectory(
    table, constraints: JtcConstraints | None = None, *, source: dict | None = None
) -> bytes:
    """The FollowJointTrajectory goal of a set-point table as JSON (module docstring).

    Parameters
    ----------
    table : SetpointTable
        Its rows become the points (it must have accelerations).
    constraints : JtcConstraints, optional
        Path and goal tolerances and ``goal_time_tolerance``; without: none (the controller's).
    source : dict, optional
        Provenance recorded in ``meta``.

    Raises
    ------
    InputError
        A table without accelerations, or a goal the JTC would refuse.
    """
    if table.qdd_rad_s2 is None:
        raise InputError("the set-point table has no accelerations (format armlab.setpoints/1)")
    names = list(table.joint_names)
    if table.n_cycles == 0:
        raise InputError("joint trajectory: no points")
    t_ns = np.rint((table.t_s - table.t_s[0]) * 1e9).astype(np.int64)
    _check_arrays(names, t_ns, table.q_rad, table.qd_rad_s, table.qdd_rad_s2)
    meta: dict[str, Any] = {
        "robot": table.robot,
        "profile": table.meta.get("profile", ""),
        "cycle_s": table.cycle_s,
        "n_points": int(t_ns.size),
        "units": {"positions": "rad", "velocities": "rad/s", "accelerations": "rad/s^2"},
        "trajectory_sha256": table.trajectory_sha256,
        "armlab_version": table.meta.get("armlab_version", ""),
    }
    if source:
        meta["source"] = dict(source)
    goal_extra = []
    if constraints is not None:
        c = constraints
        meta["constraints"] = {"accuracy_m": c.accuracy_m, "rules": c.rules}

        def tol(pos: dict[str, float], vel: float) -> str:
            rows = [
                f'{{"name": {json.dumps(j)}, "position": {_fixed(pos[j])}, '
                f'"velocity": {_fixed(vel)}, "acceleration": 0.0}}'
                for j in names
            ]
            return "[" + ", ".join(rows) + "]"

        gt = _duration(c.goal_time_s)
        goal_extra = [
            f'    "path_tolerance": {tol(c.trajectory_rad, 0.0)},\n',
            f'    "goal_tolerance": {tol(c.goal_rad, c.stopped_velocity_tolerance_rad_s)},\n',
            f'    "goal_time_tolerance": {{"sec": {gt["sec"]}, "nanosec": {gt["nanosec"]}}}\n',
        ]
    n = len(names)

    def block(a: np.ndarray) -> list[bytes]:
        return format_rows(
            [a[:, j] for j in range(n)], _DECIMALS, sep=", ", names=names
        ).splitlines()

    pos, vel, acc = block(table.q_rad), block(table.qd_rad_s), block(table.qdd_rad_s2)
    sec, nsec = np.divmod(t_ns, 10**9)
    times = format_rows([sec, nsec], 0, sep=", ").splitlines()
    rows = [
        b'      {"positions": ['
        + p
        + b'], "velocities": ['
        + v
        + b'], "accelerations": ['
        + a
        + b'], "time_from_start": {"sec": '
        + tm.replace(b", ", b', "nanosec": ', 1)
        + b"}}"
        for p, v, a, tm in zip(pos, vel, acc, times, strict=True)
    ]
    head = (
        f'{{"format": {json.dumps(FOLLOW_JOINT_TRAJECTORY_FORMAT)},\n'
        f' "meta": {json.dumps(meta, allow_nan=False)},\n'
        ' "action_type": "control_msgs/action/FollowJointTrajectory",\n'
        ' "goal": {\n'
        '    "trajectory": {\n'
        '      "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},\n'
        f'      "joint_names": {json.dumps(names)},\n'
        '      "points": [\n'
    ).encode()
    tail = "\n      ]\n    }" + (",\n" + "".join(goal_extra) if goal_extra else "\n") + "  }\n}\n"
    return head + b",\n".join(rows) + tail.encode()
