"""Drive trains: motor, reducer and encoder of each joint (``drives.toml``).

SI inside; the only non-SI fields are named with their unit (``rated_speed_rpm``).
"""

from __future__ import annotations

import math
from dataclasses import MISSING, asdict, dataclass, fields
from pathlib import Path
from typing import Any

from armlab.errors import RobotDescriptionError
from armlab.tomlfile import read_toml

__all__ = [
    "Motor",
    "Reducer",
    "Encoder",
    "Drive",
    "read_drives",
    "RPM_TO_RAD_S",
    "available_torque_Nm",
]

RPM_TO_RAD_S = 2.0 * math.pi / 60.0


def available_torque_Nm(stall_torque_Nm, ratio, efficiency, derating=1.0) -> Any:
    """Thesis rule (table 4.3): available joint torque = stall torque x ratio x efficiency
    x derating, in [N m]. Scalars or numpy arrays (one value per joint); the result is a float
    or an array accordingly (hence ``Any``)."""
    return stall_torque_Nm * ratio * efficiency * derating


@dataclass(frozen=True)
class Motor:
    """A DC motor.

    Attributes
    ----------
    model : str
    stall_torque_Nm : float
        Continuous stall torque in [N m] (thesis table 4.3 "stall torque").
    rated_speed_rpm : float
        Rated (table) speed in [rpm].
    current_A : float
        Rated current in [A].
    torque_constant_Nm_A, back_emf_V_s_rad : float
        Kt in [N m/A] and Ke in [V s/rad].
    resistance_ohm, inductance_H : float
        Armature Ra in [ohm] and La in [H].
    rotor_inertia_kg_m2 : float
        Rotor inertia in [kg m^2].
    viscous_friction_Nm_s_rad : float
        Viscous friction on the motor shaft in [N m s/rad].
    supply_voltage_V : float
        Amplifier supply voltage in [V].
    power_W : float
        Table power in [W].
    peak_torque_Nm : float
        Peak (momentary) torque in [N m]; NaN when the data sheet gives none (sizing then
        limits the peak to the stall torque, conservatively).
    """

    model: str
    stall_torque_Nm: float
    rated_speed_rpm: float
    current_A: float
    torque_constant_Nm_A: float
    back_emf_V_s_rad: float
    resistance_ohm: float
    inductance_H: float
    rotor_inertia_kg_m2: float
    viscous_friction_Nm_s_rad: float = 0.0
    supply_voltage_V: float = 24.0
    power_W: float = math.nan
    peak_torque_Nm: float = math.nan
    mass_kg: float = math.nan
    price: float = math.nan
    source: str = ""

    @property
    def rated_speed_rad_s(self) -> float:
        """Rated speed in [rad/s]."""
        return self.rated_speed_rpm * RPM_TO_RAD_S

    @property
    def no_load_speed_rad_s(self) -> float:
        """No-load speed at the supply voltage, ``U / Ke``, in [rad/s]."""
        return self.supply_voltage_V / self.back_emf_V_s_rad

    @property
    def speed_limit_rad_s(self) -> float:
        """The speed the motor may run at, in [rad/s]: the rated (table) speed if the data sheet
        gives one, else the no-load speed ``U / Ke``. The sizing check ``motor_speed`` and the
        joint velocity limit (:func:`armlab.robot.resolve_limits`) both use it."""
        s = self.rated_speed_rpm
        return s * RPM_TO_RAD_S if math.isfinite(s) and s > 0 else self.no_load_speed_rad_s


@dataclass(frozen=True)
class Reducer:
    """A speed reducer (harmonic or planetary).

    ``ratio`` is motor speed / joint speed; torques at the output in [N m]; ``inertia_kg_m2``
    at the input shaft.
    """

    model: str
    ratio: float
    efficiency: float
    rated_torque_Nm: float
    peak_torque_Nm: float
    max_input_speed_rpm: float
    inertia_kg_m2: float = 0.0
    mass_kg: float = math.nan
    price: float = math.nan
    source: str = ""

    @property
    def max_input_speed_rad_s(self) -> float:
        """Maximum input (motor-side) speed in [rad/s]."""
        return self.max_input_speed_rpm * RPM_TO_RAD_S


@dataclass(frozen=True)
class Encoder:
    """An incremental encoder on the motor shaft."""

    pulses_per_rev: int
    decoding: int = 4

    def counts_per_joint_rev(self, ratio: float) -> float:
        """Counts per joint revolution: pulses x decoding x reducer ratio."""
        return self.pulses_per_rev * self.decoding * ratio


@dataclass(frozen=True)
class Drive:
    """One joint's drive train and the joint limits URDF cannot hold.

    Attributes
    ----------
    joint : str
    acceleration_rad_s2, jerk_rad_s3 : float
        Joint-side limits in [rad/s^2] and [rad/s^3].
    derating : float
        Extra factor on the available torque (0.8 for the thesis' joint 2).
    """

    joint: str
    motor: Motor
    reducer: Reducer
    encoder: Encoder
    acceleration_rad_s2: float
    jerk_rad_s3: float
    derating: float = 1.0

    @property
    def available_torque_Nm(self) -> float:
        """Thesis rule: stall torque x ratio x efficiency x derating, in [N m] (table 4.3)."""
        return available_torque_Nm(
            self.motor.stall_torque_Nm, self.reducer.ratio, self.reducer.efficiency, self.derating
        )

    @property
    def reflected_inertia_kg_m2(self) -> float:
        """(rotor + reducer input inertia) x ratio^2, seen at the joint, in [kg m^2]."""
        return (self.motor.rotor_inertia_kg_m2 + self.reducer.inertia_kg_m2) * self.reducer.ratio**2

    @property
    def counts_per_rad(self) -> float:
        """Encoder counts per joint radian."""
        return self.encoder.counts_per_joint_rev(self.reducer.ratio) / (2.0 * math.pi)

    def to_dict(self) -> dict:
        return asdict(self)


def _build(cls, data: dict, where: str):
    names = {f.name for f in fields(cls)}
    unknown = set(data) - names
    if unknown:
        raise RobotDescriptionError(f"{where}: unknown field(s) {sorted(unknown)}")
    missing = [
        f.name
        for f in fields(cls)
        if f.default is MISSING and f.default_factory is MISSING and f.name not in data
    ]
    if missing:
        raise RobotDescriptionError(f"{where}: missing field(s) {missing}")
    for k, v in data.items():
        if isinstance(v, float) and math.isnan(v):
            raise RobotDescriptionError(f"{where}: {k} is NaN")
    try:
        return cls(**data)
    except TypeError as exc:
        raise RobotDescriptionError(f"{where}: {exc}") from None


def motor_from_dict(data: dict, where: str = "motor") -> Motor:
    return _build(Motor, data, where)


def reducer_from_dict(data: dict, where: str = "reducer") -> Reducer:
    return _build(Reducer, data, where)


def read_drives(path: str | Path, joint_names: list[str] | tuple[str, ...]) -> dict[str, Drive]:
    """Read ``drives.toml`` for the given joints.

    Raises
    ------
    RobotDescriptionError
        If the file is malformed, a joint is missing, or a joint is unknown.
    """
    path = Path(path)
    data = read_toml(path, "drives file")
    drives: dict[str, Drive] = {}
    for row in data.get("joint", []):
        name = row.get("name")
        where = f"{path} joint {name!r}"
        if name not in joint_names:
            raise RobotDescriptionError(
                f"{where}: no such joint in the robot (joints: {', '.join(joint_names)})"
            )
        for part in ("motor", "reducer", "encoder"):
            if part not in row:
                raise RobotDescriptionError(f"{where}: no [{part}] table")
        motor = motor_from_dict(dict(row["motor"]), f"{where} motor")
        reducer = reducer_from_dict(dict(row["reducer"]), f"{where} reducer")
        encoder = _build(Encoder, dict(row["encoder"]), f"{where} encoder")
        for key in ("acceleration_rad_s2", "jerk_rad_s3"):
            v = row.get(key)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise RobotDescriptionError(f"{where}: {key} must be a positive number, not {v!r}")
        if not 0 < reducer.efficiency <= 1:
            raise RobotDescriptionError(f"{where}: reducer efficiency must be in (0, 1]")
        if reducer.ratio <= 0:
            raise RobotDescriptionError(f"{where}: reducer ratio must be positive")
        drives[name] = Drive(
            joint=name,
            motor=motor,
            reducer=reducer,
            encoder=encoder,
            acceleration_rad_s2=float(row["acceleration_rad_s2"]),
            jerk_rad_s3=float(row["jerk_rad_s3"]),
            derating=float(row.get("derating", 1.0)),
        )
    missing = [n for n in joint_names if n not in drives]
    if missing:
        raise RobotDescriptionError(f"{path}: no drive for joint(s) {missing}")
    return drives
