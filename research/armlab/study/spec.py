"""The study file: one TOML describing a whole study, parsed into a validated :class:`StudySpec`.

A study file has these tables (every key optional unless marked; units in the key names)::

    [study]      name, seed, stages (subset of STAGES, in chain order), report (bool)
    [robot]      name (required: built-in name, URDF path or erd:<path in example-robot-data>),
                 drives (drives file path), tool_frame, lock_joints,
                 base_xyz_m, base_rpy_deg (mounting of the base in the world),
                 floor_z_m (the floor's height in the world; default none),
                 collision_pairs (a disabled-pairs TOML, armlab.collision.pairs)
    [payload]    mass_kg, com_m (centre of mass in the tool frame); its shape for the collision
                 check: one of box_m, sphere_m, cylinder_m, capsule_m, mesh (+ mesh_scale),
                 placed by shape_xyz_m, shape_rpy_deg in the tool frame (armlab.collision.shapes)
    [[obstacle]] name, one of box_m, sphere_m, cylinder_m, capsule_m, mesh (+ mesh_scale),
                 xyz_m (centre in the world), rpy_deg: the environment of the collision check
    [waypoints]  unit ("deg" | "rad"), joint (n x n_joints) OR cartesian (n x 6: x, y, z in m,
                 roll, pitch, yaw in `unit`), ik_seed (n_joints, in `unit`)
    [limits]     velocity_rad_s, acceleration_rad_s2, jerk_rad_s3, effort_Nm: a number for every
                 joint or a list (n_joints,) -- the robot's limits for the whole study
    [plan]       planner, profile, objective, duration_s, speed_scale, torque_limits,
                 jerk_limits, check_dt_s, speed_m_s, blend_radius_m, clearance_m
    [drives.<joint>]  ratio, motor, reducer, efficiency, derating, pulses_per_rev, decoding,
                 amplifier (catalogue name or table)
                 (catalogue names; a robot without drives: motor, reducer, pulses_per_rev
                 for every joint build its drive train)
    [kinematics] workspace_samples, accuracy_samples
    [sizing]     catalogue, select (true: choose motor + reducer per joint from the catalogue;
                 a robot without a drive train then runs the later stages on the selection),
                 dwell_s, cycles, ambient_degC (the thermal check), max_inertia_ratio
    [control]    position_bandwidth_rad_s | rise_time_s, phase_margin_deg, gain_margin_dB,
                 overshoot_pct, method, current_sample_time_s, n_inertia_samples
    [tracking]   feedforward, quantise, t_after_s, accuracy_m
    [controller] profile, cycle_s, pulse_limit, servo_period_s (the one home of the controller:
                 the table, sizing's encoder checks, the tuning's discretisation, the simulation)

Anything else -- an unknown table, an unknown key, a value of the wrong type or out of range --
raises :class:`armlab.SpecError` naming the key (``plan.speed_scale``). Values that need the robot
(joint names under ``drives``, the length of a per-joint list, waypoints in range) are checked
when the study runs, with the same kind of message.

Sweeps change a study through dotted keys (``drives.joint2.ratio``): :func:`apply_overrides`
sets them in the parsed TOML document and :func:`check_key` tells whether a key exists.
"""

from __future__ import annotations

import copy
import hashlib
import json
from dataclasses import MISSING, asdict, dataclass, fields
from importlib import resources
from pathlib import Path
from typing import Any

from armlab.collision.shapes import SHAPE_KEYS, Shape, shape_from_table
from armlab.errors import SpecError
from armlab.study.budget import MAX_INERTIA_SAMPLES, MAX_MONTE_CARLO, check_waypoints
from armlab.study.spec_values import (
    _bool,
    _drive_value,
    _float,
    _int,
    _joint_name,
    _key,
    _matrix,
    _number_or_list,
    _raw,
    _str,
    _str_list,
    _title,
    _vector,
)
from armlab.tomlfile import read_toml

__all__ = [
    "STAGES",
    "PLANNERS",
    "StudySpec",
    "StudyOptions",
    "RobotSpec",
    "PayloadSpec",
    "WaypointSpec",
    "LimitsSpec",
    "PlanSpec",
    "DriveOverride",
    "KinematicsSpec",
    "SizingSpec",
    "ControlSpec",
    "TrackingSpec",
    "ControllerSpec",
    "load_study",
    "parse_study",
    "read_study_document",
    "apply_overrides",
    "check_key",
    "demo_study_path",
    "document_hash",
]

#: The stages of a study, in chain order (DESIGN.md "The flow").
STAGES = ("kinematics", "plan", "static_load", "sizing", "tuning", "tracking", "export")

#: Planners a study may name: joint-space (``optimal``, ``ptp``, ``cubic``, ``path`` = time-optimal
#: parameterisation of the joint spline through the waypoints) and Cartesian (``line``, ``arc3``,
#: ``blend``, which need ``waypoints.cartesian``).
PLANNERS = ("optimal", "ptp", "cubic", "path", "line", "arc3", "blend")


# ---------------------------------------------------------------------------- sections
@dataclass(frozen=True)
class StudyOptions:
    """``[study]``: name, random seed, the stages to run, and whether to write the report."""

    name: str = _key(_title, "study", "study name (report title; printable, one line, <= 200)")
    seed: int = _key(_int(0), 0, "seed of every random draw in the study")
    stages: tuple[str, ...] = _key(_str_list(STAGES), STAGES, "stages to run, subset of STAGES")
    report: bool = _key(_bool, True, "write report.md and its PNG plots")


@dataclass(frozen=True)
class RobotSpec:
    """``[robot]``: which arm (built-in name or URDF path, relative to the study file)."""

    name: str = _key(_str(), doc="built-in robot name, URDF path or erd:<example-robot-data path>")
    drives: str | None = _key(
        _str(),
        None,
        "drives file (docs/drives.md), relative to the study file; replaces the "
        "drives.toml beside the URDF",
    )
    tool_frame: str | None = _key(
        _str(), None, "tool frame (default tool0, else one named like a tool)"
    )
    lock_joints: tuple[str, ...] = _key(_str_list(), (), "joints locked at 0")
    base_xyz_m: tuple[float, ...] | None = _key(
        _vector(3), None, "position of the base in the world, m (default 0 0 0)"
    )
    base_rpy_deg: tuple[float, ...] | None = _key(
        _vector(3), None, "roll, pitch, yaw of the base in the world, deg (e.g. 90 0 0: wall)"
    )
    floor_z_m: float | None = _key(
        _float(), None, "height of the floor in the world, m (default: no floor)"
    )
    collision_pairs: str | None = _key(
        _str(),
        None,
        "disabled collision pairs TOML (armlab.collision.pairs), relative to the study file "
        "(default: the description's or the cached sampled analysis)",
    )


@dataclass(frozen=True)
class PayloadSpec:
    """``[payload]``: payload mass in [kg] and centre of mass in the tool frame in [m]."""

    mass_kg: float | None = _key(_float(0.0), None, "payload mass in kg (default: description's)")
    com_m: tuple[float, ...] | None = _key(_vector(3), None, "centre of mass in the tool frame, m")
    # the payload's shape (armlab.collision.shapes): checked together in parse_study
    box_m: Any = _key(_raw, None, "payload shape: box full sides x, y, z, m")
    sphere_m: Any = _key(_raw, None, "payload shape: sphere radius, m")
    cylinder_m: Any = _key(_raw, None, "payload shape: cylinder radius, length (along z), m")
    capsule_m: Any = _key(_raw, None, "payload shape: capsule radius, length (along z), m")
    mesh: Any = _key(_raw, None, "payload shape: mesh file, relative to the study file")
    mesh_scale: Any = _key(_raw, None, "payload shape: mesh scale factors x, y, z")
    shape_xyz_m: Any = _key(_raw, None, "payload shape: centre in the tool frame, m")
    shape_rpy_deg: Any = _key(_raw, None, "payload shape: roll, pitch, yaw in the tool frame")


@dataclass(frozen=True)
class WaypointSpec:
    """``[waypoints]``: joint waypoints or Cartesian poses (through IK), angles in ``unit``."""

    unit: str = _key(_str(("deg", "rad")), "deg", "unit of every angle in this table")
    joint: tuple[tuple[float, ...], ...] | None = _key(_matrix(), None, "joint waypoints")
    cartesian: tuple[tuple[float, ...], ...] | None = _key(
        _matrix(6), None, "tool poses x, y, z [m], roll, pitch, yaw [unit]"
    )
    ik_seed: tuple[float, ...] | None = _key(_vector(), None, "IK seed configuration [unit]")


@dataclass(frozen=True)
class LimitsSpec:
    """``[limits]``: replace the robot's limits (a number for all joints or one per joint)."""

    velocity_rad_s: float | tuple[float, ...] | None = _key(_number_or_list(), None, "rad/s")
    acceleration_rad_s2: float | tuple[float, ...] | None = _key(_number_or_list(), None, "rad/s^2")
    jerk_rad_s3: float | tuple[float, ...] | None = _key(_number_or_list(), None, "rad/s^3")
    effort_Nm: float | tuple[float, ...] | None = _key(_number_or_list(), None, "N m")


@dataclass(frozen=True)
class PlanSpec:
    """``[plan]``: the planner and its options.

    ``speed_scale`` s in (0, 1] plans with the velocity, acceleration and jerk limits scaled by
    s, s^2 and s^3 (the same motion slowed down in time by 1/s); the plan is checked against the
    robot's full limits on a grid of ``check_dt_s``.
    """

    planner: str = _key(_str(PLANNERS), "optimal", "planner")
    profile: str = _key(_str(("trapezoid", "scurve", "velocity")), "trapezoid", "ptp profile")
    objective: str = _key(_str(), "time", "optimal: objective (time, jerk, energy, ...)")
    duration_s: float | None = _key(
        _float(0.0, lo_open=True), None, "fixed duration for fixed-time objectives / cubic"
    )
    speed_scale: float = _key(_float(0.0, 1.0, lo_open=True), 1.0, "time scaling in (0, 1]")
    torque_limits: bool = _key(_bool, True, "optimal/path: honour torque limits")
    drive_limits: bool = _key(
        _bool, False, "optimal/path: plan inside each motor's envelope (voltage line, peak, RMS)"
    )
    jerk_limits: bool | None = _key(
        _bool, None, "optimal/path: honour the jerk limits (default: the planner's own default)"
    )
    check_dt_s: float = _key(_float(0.0, 1.0, lo_open=True), 0.001, "limit-check grid")
    speed_m_s: float | None = _key(_float(0.0, lo_open=True), None, "Cartesian planners: speed")
    blend_radius_m: float | None = _key(_float(0.0, lo_open=True), None, "blend: corner radius")
    clearance_m: float = _key(
        _float(0.0),
        0.0,
        "smallest distance the plan keeps between the arm, its payload, the floor and the "
        "obstacles, m (0: no contact)",
    )


def _amplifier(v, where):
    """A catalogue amplifier name or an inline table (its fields are checked when the robot is
    built, as in a drives file)."""
    if isinstance(v, dict):
        return dict(v)
    return _str()(v, where)


@dataclass(frozen=True)
class DriveOverride:
    """``[drives.<joint>]``: change a joint's drive train (catalogue names or numbers).

    For a robot without a drive train, every joint needs ``motor`` and ``reducer`` (catalogue
    names) and ``pulses_per_rev``; they then build it (``decoding`` default 4, acceleration and
    jerk from ``[limits]`` or derived from the drive train, docs/drives.md).
    """

    ratio: float | None = _key(_drive_value("Reducer", "ratio"), None, "reducer ratio")
    motor: str | None = _key(_str(), None, "motor model (catalogue or the robot's)")
    reducer: str | None = _key(_str(), None, "reducer model (catalogue or the robot's)")
    efficiency: float | None = _key(
        _drive_value("Reducer", "efficiency"), None, "reducer efficiency"
    )
    derating: float | None = _key(_drive_value("Drive", "derating"), None, "torque derating")
    pulses_per_rev: int | None = _key(
        _drive_value("Encoder", "pulses_per_rev"), None, "encoder pulses per motor revolution"
    )
    decoding: int | None = _key(
        _drive_value("Encoder", "decoding"), None, "encoder decoding factor: 1, 2 or 4"
    )
    amplifier: str | dict | None = _key(
        _amplifier,
        None,
        "servo amplifier: catalogue model or a table of Amplifier fields (docs/drives.md)",
    )


@dataclass(frozen=True)
class KinematicsSpec:
    """``[kinematics]``: the Monte-Carlo sizes of the workspace and accuracy studies (0: skip)."""

    workspace_samples: int = _key(_int(0, MAX_MONTE_CARLO), 0, "workspace cloud size")
    accuracy_samples: int = _key(_int(0, MAX_MONTE_CARLO), 0, "accuracy Monte-Carlo size")


@dataclass(frozen=True)
class SizingSpec:
    """``[sizing]``: the drive catalogue (built-in name or TOML path) and whether to select."""

    catalogue: str | None = _key(_str(), None, "catalogue name or TOML path")
    select: bool = _key(
        _bool,
        False,
        "choose motor + reducer per joint from the catalogue (a robot without a drive train: "
        "the selection becomes its drive train for tuning, tracking and export)",
    )
    dwell_s: float = _key(
        _float(0.0, 3600.0),
        0.0,
        "rest at the cycle's last pose before it repeats, s (in the RMS and the thermal check)",
    )
    cycles: int | None = _key(
        _int(1, 100000),
        None,
        "cycles of the thermal check from ambient (left out: the periodic state)",
    )
    ambient_degC: float = _key(
        _float(-50.0, 150.0),
        25.0,
        "ambient of the thermal check, degC (25: ASSUMED, the makers' rating condition)",
    )
    max_inertia_ratio: float | None = _key(
        _float(0.0, lo_open=True),
        None,
        "largest load-to-motor inertia ratio (check inertia_ratio; left out: reported only)",
    )
    allow_estimated: bool = _key(
        _bool,
        False,
        "let selection use catalogue parts with values not read from a published source "
        "(each entry's `estimated` fields, docs/catalogue.md)",
    )
    required_life_h: float = _key(
        _float(0.0, lo_open=True),
        7000.0,
        "life the reducers must reach over the duty cycle, h (default: the CSF L_10 rating)",
    )
    momentary_load: str = _key(
        _str(("plan", "stop")),
        "plan",
        "load case of the reducers' momentary-torque check: the plan's worst sample, or also "
        "an emergency stop at the current limit",
    )


@dataclass(frozen=True)
class ControlSpec:
    """``[control]``: specs of the robust cascade tuning (None: the tuner's defaults).

    Keys are those of :class:`armlab.control.TuningSpec`. The speed and position loops' sample
    time and the D/A are the controller's (``[controller] servo_period_s``, the profile's DAC).
    """

    position_bandwidth_rad_s: float | None = _key(
        _float(0.0, lo_open=True), None, "position-loop crossover target, rad/s"
    )
    rise_time_s: float | None = _key(
        _float(0.0, lo_open=True), None, "position-loop rise time (instead of the bandwidth)"
    )
    phase_margin_deg: float | None = _key(_float(0.0, 90.0, lo_open=True), None, "deg")
    gain_margin_dB: float | None = _key(_float(0.0, lo_open=True), None, "dB")
    overshoot_pct: float | None = _key(_float(0.0, 100.0), None, "position-loop step, %")
    method: str | None = _key(
        _str(("tustin", "backward", "zoh")), None, "integral discretisation of the incremental PID"
    )
    current_sample_time_s: float | None = _key(
        _float(0.0, 0.01, lo_open=True), None, "current loop sample time, s"
    )
    n_inertia_samples: int | None = _key(
        _int(1, MAX_INERTIA_SAMPLES), None, "workspace samples of the inertia range"
    )
    compliant: bool | None = _key(
        _bool,
        None,
        "tune on the two-mass joint (reducer stiffness K1) where the drive gives one (default: "
        "as [tracking] compliant)",
    )


def _feedforward(v, where):
    if v == "none":
        return "none"
    return _str_list()(v, where)


@dataclass(frozen=True)
class TrackingSpec:
    """``[tracking]``: options of the closed-loop simulation."""

    feedforward: tuple[str, ...] | str | None = _key(
        _feedforward,
        None,
        'list of velocity, acceleration, gravity, friction, efficiency, computed_torque; or "none"',
    )
    quantise: bool = _key(_bool, True, "12-bit D/A and encoder quantisation")
    t_after_s: float | None = _key(_float(0.0), None, "time simulated after the end, s")
    accuracy_m: float | None = _key(_float(0.0, lo_open=True), None, "TCP tolerance, m")
    compliant: bool = _key(
        _bool,
        False,
        "the compliant joint: reducer spring (and hysteresis) between motor and link in the "
        "simulation, the two-mass plant in the tuning (default false: the rigid joint)",
    )


@dataclass(frozen=True)
class ControllerSpec:
    """``[controller]``: the controller profile of the set-point table and its overrides."""

    profile: str | None = _key(
        _str(),
        None,
        "profile name or TOML path (default: reference; dda_n_axis for other axis counts)",
    )
    cycle_s: float | None = _key(_float(0.0, 2.0, lo_open=True), None, "cycle period in s")
    pulse_limit: int | None = _key(_int(1), None, "pulses per cycle limit")
    servo_period_s: float | None = _key(
        _float(0.0, 0.1, lo_open=True), None, "servo (speed/position loop) period, s"
    )


_SECTIONS: dict[str, type] = {
    "study": StudyOptions,
    "robot": RobotSpec,
    "payload": PayloadSpec,
    "waypoints": WaypointSpec,
    "limits": LimitsSpec,
    "plan": PlanSpec,
    "kinematics": KinematicsSpec,
    "sizing": SizingSpec,
    "control": ControlSpec,
    "tracking": TrackingSpec,
    "controller": ControllerSpec,
}


@dataclass(frozen=True)
class StudySpec:
    """A validated study (see the module docstring for the file format).

    ``base_dir`` is the folder relative paths are resolved against (the study file's);
    ``source`` names the file (or ``"<built-in demo>"``); ``document`` keeps the parsed TOML
    (with overrides applied) and ``hash`` its sha256, so a study is reproducible from it.
    """

    study: StudyOptions
    robot: RobotSpec
    payload: PayloadSpec
    waypoints: WaypointSpec
    limits: LimitsSpec
    plan: PlanSpec
    drives: dict[str, DriveOverride]
    kinematics: KinematicsSpec
    sizing: SizingSpec
    control: ControlSpec
    tracking: TrackingSpec
    controller: ControllerSpec
    base_dir: Path
    source: str
    document: dict[str, Any]
    hash: str
    #: the ``[[obstacle]]`` tables and the payload's shape (armlab.collision.shapes)
    obstacles: tuple[Shape, ...] = ()
    payload_shape: Shape | None = None

    def resolve(self, name_or_path: str) -> str:
        """A path relative to the study file made absolute; a bare name stays as it is."""
        p = Path(name_or_path)
        if (
            name_or_path.startswith("erd:")
            or p.is_absolute()
            or ("/" not in name_or_path and "\\" not in name_or_path and not p.suffix)
        ):
            return name_or_path
        return str((self.base_dir / p).resolve())

    def to_dict(self) -> dict[str, Any]:
        """The normalised spec as JSON-able data."""
        out = {name: _jsonable(asdict(getattr(self, name))) for name in _SECTIONS}
        out["drives"] = {j: _jsonable(asdict(d)) for j, d in self.drives.items()}
        out["obstacle"] = [_jsonable(asdict(o)) for o in self.obstacles]
        out["source"] = self.source
        out["hash"] = self.hash
        return out


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    return x


def _build(cls, table, where: str):
    if not isinstance(table, dict):
        raise SpecError(f"{where}: expected a table, not {table!r}")
    known = {f.name: f for f in fields(cls)}
    unknown = sorted(set(table) - set(known))
    if unknown:
        raise SpecError(f"{where}.{unknown[0]}: unknown key (known: {', '.join(known)})")
    values = {}
    for name, f in known.items():
        if name in table:
            values[name] = f.metadata["check"](table[name], f"{where}.{name}")
        elif f.default is MISSING:
            raise SpecError(f"{where}.{name}: missing (required)")
    return cls(**values)


def document_hash(document: dict[str, Any]) -> str:
    """sha256 of a TOML document in canonical JSON form (sorted keys)."""
    text = json.dumps(document, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def parse_study(
    document: dict[str, Any], *, base_dir: str | Path = ".", source: str = "<dict>"
) -> StudySpec:
    """Validate a parsed study document (a dict as ``tomllib`` returns it).

    Raises
    ------
    SpecError
        Unknown table or key, missing ``robot.name`` or waypoints, a value of the wrong type or
        out of range; the message starts with the dotted key.
    """
    if not isinstance(document, dict):
        raise SpecError(f"{source}: a study must be a TOML table")
    allowed = set(_SECTIONS) | {"drives", "obstacle"}
    unknown = sorted(set(document) - allowed)
    if unknown:
        raise SpecError(f"{unknown[0]}: unknown table (known: {', '.join(sorted(allowed))})")
    if "robot" not in document:
        raise SpecError("robot.name: missing (required)")
    parts = {name: _build(cls, document.get(name, {}), name) for name, cls in _SECTIONS.items()}
    drives_doc = document.get("drives", {})
    if not isinstance(drives_doc, dict):
        raise SpecError(f"drives: expected tables [drives.<joint>], not {drives_doc!r}")
    drives = {
        _joint_name(j, "drives"): _build(DriveOverride, t, f"drives.{j}")
        for j, t in drives_doc.items()
    }
    wp: WaypointSpec = parts["waypoints"]
    if (wp.joint is None) == (wp.cartesian is None):
        raise SpecError(
            "waypoints.joint: give exactly one of waypoints.joint and waypoints.cartesian"
        )
    n_wp = len(wp.joint) if wp.joint is not None else len(wp.cartesian or ())
    if n_wp < 2 and "plan" in parts["study"].stages:
        raise SpecError(f"waypoints: at least 2 waypoints needed to plan, got {n_wp}")
    plan: PlanSpec = parts["plan"]
    check_waypoints(n_wp, plan.planner, "waypoints.joint" if wp.joint else "waypoints.cartesian")
    if plan.planner in ("line", "arc3", "blend") and wp.cartesian is None:
        raise SpecError(f"plan.planner: {plan.planner!r} needs waypoints.cartesian")
    if plan.planner == "arc3" and n_wp != 3:
        raise SpecError(f"plan.planner: 'arc3' needs exactly 3 Cartesian waypoints, got {n_wp}")
    if plan.planner == "blend" and plan.blend_radius_m is None:
        raise SpecError("plan.blend_radius_m: missing (required by planner 'blend')")
    if plan.drive_limits and plan.planner not in ("optimal", "path"):
        raise SpecError(
            f"plan.drive_limits: only the 'optimal' and 'path' planners plan inside the motor "
            f"envelope, not {plan.planner!r}"
        )
    obstacles, payload_shape = _shapes(document, Path(base_dir))
    stages = parts["study"].stages
    order = [s for s in STAGES if s in stages]
    if list(stages) != order or len(set(stages)) != len(stages):
        raise SpecError(f"study.stages: list each stage once, in chain order ({', '.join(STAGES)})")
    return StudySpec(
        **parts,
        drives=drives,
        base_dir=Path(base_dir).resolve(),
        source=source,
        document=copy.deepcopy(document),
        hash=document_hash(document),
        obstacles=obstacles,
        payload_shape=payload_shape,
    )


def parse_sizing(table: Any) -> SizingSpec:
    """A ``[sizing]`` table on its own, validated (:class:`SpecError` naming the key): what
    ``armlab export`` re-checks a recorded design's sizing with."""
    return _build(SizingSpec, table, "sizing")


#: The name of the payload's shape in the collision check.
PAYLOAD_SHAPE_NAME = "payload"
_RESERVED_SHAPE_NAMES = (PAYLOAD_SHAPE_NAME, "floor")


def _shapes(document: dict[str, Any], base_dir: Path) -> tuple[tuple[Shape, ...], Shape | None]:
    """The ``[[obstacle]]`` tables and the ``[payload]`` shape (armlab.collision.shapes)."""
    raw = document.get("obstacle", [])
    if not isinstance(raw, list):
        raise SpecError("obstacle: expected [[obstacle]] tables (an array of tables)")
    known = {"name", "xyz_m", "rpy_deg", "mesh_scale", *SHAPE_KEYS}
    obstacles: list[Shape] = []
    for i, table in enumerate(raw):
        where = f"obstacle[{i}]"
        if not isinstance(table, dict):
            raise SpecError(f"{where}: expected a table, not {table!r}")
        unknown = sorted(set(table) - known)
        if unknown:
            raise SpecError(
                f"{where}.{unknown[0]}: unknown key (known: {', '.join(sorted(known))})"
            )
        if "name" not in table:
            raise SpecError(f"{where}.name: missing (required)")
        shape = shape_from_table(table, table["name"], where, base_dir)
        if shape.name in _RESERVED_SHAPE_NAMES or shape.name in [o.name for o in obstacles]:
            raise SpecError(
                f"{where}.name: {shape.name!r} is taken (names must be distinct, not "
                f"{' or '.join(_RESERVED_SHAPE_NAMES)})"
            )
        obstacles.append(shape)
    payload = document.get("payload", {})
    keys = (*SHAPE_KEYS, "mesh_scale", "shape_xyz_m", "shape_rpy_deg")
    given = {k: payload[k] for k in keys if isinstance(payload, dict) and k in payload}
    payload_shape: Shape | None = None
    if given:
        payload_shape = shape_from_table(
            given,
            PAYLOAD_SHAPE_NAME,
            "payload",
            base_dir,
            pose_keys=("shape_xyz_m", "shape_rpy_deg"),
        )
    return tuple(obstacles), payload_shape


def demo_study_path() -> Path:
    """The built-in teachbot6 demo study (``armlab/data/demo_study.toml``)."""
    return Path(str(resources.files("armlab") / "data" / "demo_study.toml"))


def read_study_document(path: str | Path | None) -> tuple[dict[str, Any], Path, str]:
    """(document, base folder, source name) of a study file; None = the built-in demo."""
    if path is None or str(path) == "demo":
        path, source = demo_study_path(), "<built-in demo>"
    else:
        source = str(path)
    path = Path(path)
    document = read_toml(path, "study file", SpecError)
    return document, path.resolve().parent, source


def load_study(
    path: str | Path | None = None, overrides: dict[str, Any] | None = None
) -> StudySpec:
    """Read and validate a study file (None: the built-in teachbot6 demo study).

    Parameters
    ----------
    path : str or Path, optional
        The STUDY.toml; relative paths inside it are relative to its folder.
    overrides : dict, optional
        Dotted keys set before validation, e.g. ``{"payload.mass_kg": 1.0}``
        (see :func:`apply_overrides`).
    """
    document, base_dir, source = read_study_document(path)
    if overrides:
        document = apply_overrides(document, overrides)
    return parse_study(document, base_dir=base_dir, source=source)


def check_key(dotted: str) -> None:
    """Raise :class:`SpecError` unless ``dotted`` names a key a study file may hold
    (``payload.mass_kg``, ``drives.joint2.ratio``)."""
    parts = dotted.split(".")
    if parts[0] == "drives":
        names = [f.name for f in fields(DriveOverride)]
        if len(parts) != 3 or parts[2] not in names:
            raise SpecError(
                f"{dotted}: not a study key (drives keys are drives.<joint>.<key>, "
                f"key one of {', '.join(names)})"
            )
        return
    if len(parts) != 2 or parts[0] not in _SECTIONS:
        raise SpecError(f"{dotted}: not a study key (tables: {', '.join(_SECTIONS)}, drives)")
    names = [f.name for f in fields(_SECTIONS[parts[0]])]
    if parts[1] not in names:
        raise SpecError(f"{dotted}: unknown key (known in [{parts[0]}]: {', '.join(names)})")


def apply_overrides(document: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """A copy of a study document with dotted keys set (tables created as needed).

    ``{"drives.joint2.ratio": 300, "plan.planner": "ptp"}`` sets ``[drives.joint2] ratio`` and
    ``[plan] planner``. Keys are checked with :func:`check_key`; values when the copy is parsed.
    """
    out = copy.deepcopy(document)
    for dotted, value in overrides.items():
        check_key(dotted)
        node = out
        *tables, last = dotted.split(".")
        for t in tables:
            node = node.setdefault(t, {})
            if not isinstance(node, dict):
                raise SpecError(f"{dotted}: {t} is not a table in the study")
        node[last] = _plain(value)
    return out


def _plain(value):
    """numpy scalars and tuples to plain Python (TOML-like) values."""
    if hasattr(value, "item") and not isinstance(value, (list, tuple, dict, str)):
        return value.item()
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value
