"""Drives files and drive tables: what each drive value may hold, reading and writing.

One validator for a drive value (:func:`value_problem`, :func:`drive_value_rule`), whether it
comes from a drives file (:func:`read_drives`), the catalogue, a study or a design record (the
``*_from_dict`` builders); :func:`drives_toml` writes a drives file back. The parts and the
drive themselves are :mod:`armlab.robot.drives`.
"""

from __future__ import annotations

import json
import math
from dataclasses import MISSING, asdict, fields
from pathlib import Path
from typing import Any

from armlab.errors import RobotDescriptionError
from armlab.names import check_name
from armlab.robot.drives import Amplifier, Drive, Encoder, Motor, Reducer
from armlab.tomlfile import read_toml

__all__ = [
    "read_drives",
    "drives_toml",
    "value_problem",
    "drive_value_rule",
    "motor_from_dict",
    "reducer_from_dict",
    "amplifier_from_dict",
]


# ----------------------------------------------------------------------------- validation
# What each numeric field may hold, by its meaning: "pos" > 0, "nonneg" >= 0, "unit" in (0, 1],
# "count" a positive integer, "decoding" one of 1, 2, 4. Every value must be a finite number
# (TOML's nan/inf are refused); a field whose default is NaN ("not given": the motor's
# power_W and peak torque, masses, prices) may be left out, or be None in a JSON design record.
_RULES: dict[str, dict[str, str]] = {
    "Motor": {
        "stall_torque_Nm": "pos",
        "rated_speed_rpm": "pos",
        "current_A": "pos",
        "torque_constant_Nm_A": "pos",
        "back_emf_V_s_rad": "pos",
        "resistance_ohm": "pos",
        "inductance_H": "pos",
        "rotor_inertia_kg_m2": "nonneg",
        "viscous_friction_Nm_s_rad": "nonneg",
        "supply_voltage_V": "pos",
        "power_W": "pos",
        "peak_torque_Nm": "pos",
        "mass_kg": "nonneg",
        "price": "nonneg",
        "thermal_resistance_winding_housing_K_W": "pos",
        "thermal_resistance_housing_ambient_K_W": "pos",
        "thermal_time_constant_winding_s": "pos",
        "thermal_time_constant_motor_s": "pos",
        "max_winding_temperature_degC": "pos",
    },
    "Reducer": {
        "ratio": "pos",
        "efficiency": "unit",
        "rated_torque_Nm": "pos",
        "peak_torque_Nm": "pos",
        "max_input_speed_rpm": "pos",
        "inertia_kg_m2": "nonneg",
        "mass_kg": "nonneg",
        "price": "nonneg",
        "back_efficiency": "unit",
        "coulomb_friction_Nm": "nonneg",
        "viscous_friction_Nm_s_rad": "nonneg",
        "rated_input_speed_rpm": "pos",
        "rated_life_h": "pos",
        "momentary_torque_Nm": "pos",
        "stiffness_Nm_rad": "pos_list",
        "stiffness_torque_Nm": "pos_list",
        "hysteresis_rad": "nonneg",
        "bearing_dynamic_load_N": "pos",
        "bearing_moment_rating_Nm": "pos",
        "bearing_pitch_diameter_m": "pos",
        "bearing_offset_m": "nonneg",
    },
    "Encoder": {"pulses_per_rev": "count", "decoding": "decoding"},
    "Drive": {"acceleration_rad_s2": "pos", "jerk_rad_s3": "pos", "derating": "unit"},
    "Amplifier": {
        "continuous_current_A": "pos",
        "peak_current_A": "pos",
        "bus_voltage_V": "pos",
        "bus_capacitance_F": "pos",
        "brake_resistor_ohm": "pos",
        "brake_resistor_power_W": "pos",
        "brake_threshold_V": "pos",
    },
}
_BOOL_FIELDS = ("regenerates",)
_TEXT_FIELDS = ("model", "source", "integrated")
_DECODINGS = (1, 2, 4)


def value_problem(value: Any, rule: str) -> str | None:
    """Why ``value`` breaks ``rule`` (``"pos"``, ``"nonneg"``, ``"unit"``, ``"count"``,
    ``"decoding"``: the comment above ``_RULES``) -- a phrase after the value -- or None: the
    one validator of drive values, whether given in a drives file, a catalogue entry, a study's
    ``[drives.<joint>]`` or a controller profile (its ``decoding``, counts and periods)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return "is not a number"
    if not math.isfinite(value):
        return "is not a finite number"
    if rule in ("count", "decoding") and not isinstance(value, int):
        return "is not an integer"
    if rule == "decoding":
        return None if value in _DECODINGS else "is not one of 1, 2, 4 (x1, x2, x4 decoding)"
    if rule == "nonneg":
        return None if value >= 0 else "is not >= 0"
    if rule == "unit":
        return None if 0 < value <= 1 else "is not in (0, 1]"
    return None if value > 0 else "is not > 0"  # pos, count


def drive_value_rule(part: str, key: str) -> str:
    """The rule of a drive value: ``drive_value_rule("Encoder", "decoding") == "decoding"``."""
    return _RULES[part][key]


def _check_values(rules: dict[str, str], data: dict, where: str, optional=()) -> None:
    """One :class:`RobotDescriptionError` for the first value of ``data`` breaking its rule:
    ``<where> <key>: <value> is not > 0``. Keys in ``optional`` may be None (not given)."""
    for key, value in data.items():
        if key in _BOOL_FIELDS:
            continue  # checked by its reader (amplifier_from_dict)
        if key in _TEXT_FIELDS:
            if not isinstance(value, str):
                raise RobotDescriptionError(f"{where}{key}: {value!r} is not a string")
            continue
        rule = rules.get(key)
        if rule is None or (value is None and key in optional):
            continue
        if rule == "pos_list":  # a list of numbers > 0 (the reducer's stiffness curve)
            if not isinstance(value, (list, tuple)):
                raise RobotDescriptionError(f"{where}{key}: {value!r} is not a list of numbers")
            for v in value:
                problem = value_problem(v, "pos")
                if problem is not None:
                    raise RobotDescriptionError(f"{where}{key}: {v!r} {problem}")
            continue
        problem = value_problem(value, rule)
        if problem is not None:
            raise RobotDescriptionError(f"{where}{key}: {value!r} {problem}")


def _build(cls, data: dict, where: str, part: str = ""):
    """``cls(**data)`` after checking the fields: known, complete, values by their meaning
    (``_RULES``). Messages start with ``where`` and name the key as ``<part>.<key>``."""
    head = f"{where} {part}" if part else where
    names = {f.name for f in fields(cls)}
    unknown = set(data) - names
    if unknown:
        raise RobotDescriptionError(f"{head}: unknown field(s) {sorted(unknown)}")
    missing = [
        f.name
        for f in fields(cls)
        if f.default is MISSING and f.default_factory is MISSING and f.name not in data
    ]
    if missing:
        raise RobotDescriptionError(f"{head}: missing field(s) {missing}")
    not_given = [
        f.name for f in fields(cls) if isinstance(f.default, float) and math.isnan(f.default)
    ]
    prefix = f"{where} {part}." if part else f"{where} "
    _check_values(_RULES.get(cls.__name__, {}), data, prefix, optional=not_given)
    if "estimated" in data:
        data = {**data, "estimated": _estimated_fields(data["estimated"], names, prefix)}
    # lists (TOML arrays, JSON) become the tuples of the frozen dataclass
    data = {k: tuple(float(x) for x in v) if isinstance(v, list) else v for k, v in data.items()}
    try:
        return cls(**data)
    except TypeError as exc:
        raise RobotDescriptionError(f"{head}: {exc}") from None


def _estimated_fields(value: Any, names: set[str], prefix: str) -> tuple[str, ...]:
    """``estimated`` as a tuple of field names (a list in TOML/JSON), each a field of the part."""
    if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
        raise RobotDescriptionError(f"{prefix}estimated: {value!r} is not a list of field names")
    unknown = sorted(set(value) - names)
    if unknown:
        raise RobotDescriptionError(f"{prefix}estimated: unknown field(s) {unknown}")
    return tuple(value)


def motor_from_dict(data: dict, where: str = "motor", part: str = "") -> Motor:
    """A :class:`Motor` from a table, every value checked (:class:`RobotDescriptionError`
    naming ``where``, ``part`` and the key), and the supply voltage above the back-EMF at the
    rated speed (``U > Ke w_rated``: else the motor cannot reach its rated speed at all)."""
    motor = _build(Motor, data, where, part)
    emf = motor.back_emf_V_s_rad * motor.rated_speed_rad_s
    if motor.supply_voltage_V <= emf:
        prefix = f"{where} {part}." if part else f"{where} "
        raise RobotDescriptionError(
            f"{prefix}supply_voltage_V: {motor.supply_voltage_V:g} V is not above the back-EMF "
            f"at the rated speed (back_emf_V_s_rad x rated_speed_rpm = {emf:.4g} V)"
        )
    return motor


def reducer_from_dict(data: dict, where: str = "reducer", part: str = "") -> Reducer:
    """A :class:`Reducer` from a table, every value checked (as :func:`motor_from_dict`), and
    its stiffness curve whole: ``stiffness_Nm_rad`` K1..Kn with ``stiffness_torque_Nm`` the n-1
    breakpoints T1 < T2 < ... (Harmonic Drive's three segments: K1, K2, K3 and T1, T2)."""
    reducer = _build(Reducer, data, where, part)
    k, t = reducer.stiffness_Nm_rad, reducer.stiffness_torque_Nm
    prefix = f"{where} {part}." if part else f"{where} "
    if (k or t) and len(t) != len(k) - 1:
        raise RobotDescriptionError(
            f"{prefix}stiffness_torque_Nm: {len(t)} breakpoint(s) for {len(k)} stiffness "
            "segment(s) in stiffness_Nm_rad (one fewer breakpoint than segments: T1, T2 for "
            "K1, K2, K3)"
        )
    if any(b <= a for a, b in zip(t, t[1:], strict=False)):
        raise RobotDescriptionError(f"{prefix}stiffness_torque_Nm: {list(t)} is not increasing")
    return reducer


def read_drives(path: str | Path, joint_names: list[str] | tuple[str, ...]) -> dict[str, Drive]:
    """Read ``drives.toml`` for the given joints.

    The schema (required and optional keys, units, defaults) is documented in ``docs/drives.md``.
    Every value is checked by its meaning: torques, speeds, current, constants, resistance,
    inductance, supply voltage, ratio, accelerations > 0; inertias, friction (motor viscous,
    reducer Coulomb and viscous), masses, prices >= 0; efficiency, back_efficiency and derating
    in (0, 1]; ``pulses_per_rev`` a positive integer; ``decoding`` 1, 2 or 4; NaN and inf
    nowhere; the supply voltage above the back-EMF at the rated speed.

    ``motor`` and ``reducer`` may be a catalogue model name instead of a table
    (``motor = "maxon EC-i 40 70 W 36 V"``): the part of the drive catalogue (the file's
    top-level ``catalogue`` path, relative to the drives file, else armlab's), a motor with its
    derating. ``acceleration_rad_s2`` and ``jerk_rad_s3`` may be left out: they are then NaN
    here and derived from the drive train when the robot's limits are resolved
    (:func:`armlab.robot.limits.drive_train_limits`) unless the study gives them.

    Raises
    ------
    RobotDescriptionError
        If the file is malformed, a joint is missing, listed twice or unknown, a key unknown, or
        a value breaks its rule; one line naming the file, the joint and the key
        (``drives.toml joint 'joint1' encoder.pulses_per_rev: 0 is not > 0``).
    """
    path = Path(path)
    data = read_toml(path, "drives file")
    drives: dict[str, Drive] = {}
    rows = data.get("joint", [])
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise RobotDescriptionError(f"{path}: 'joint' must be an array of tables ([[joint]])")
    for row in rows:
        name = check_name(row.get("name"), "joint name", f"{path} [[joint]]", RobotDescriptionError)
        where = f"{path} joint {name!r}"
        if name not in joint_names:
            raise RobotDescriptionError(
                f"{where}: no such joint in the robot (joints: {', '.join(joint_names)})"
            )
        if name in drives:
            raise RobotDescriptionError(f"{where}: listed twice")
        named = {}
        for part in ("motor", "reducer", "encoder"):
            if part != "encoder" and isinstance(row.get(part), str):
                named[part] = _catalogue_part(path, data, part, row[part], f"{where} {part}")
            elif not isinstance(row.get(part), dict):
                raise RobotDescriptionError(f"{where}: no [{part}] table")
        motor, catalogue_derating = (
            named["motor"]
            if "motor" in named
            else (motor_from_dict(dict(row["motor"]), where, "motor"), 1.0)
        )
        reducer = (
            named["reducer"][0]
            if "reducer" in named
            else reducer_from_dict(dict(row["reducer"]), where, "reducer")
        )
        encoder = _build(Encoder, dict(row["encoder"]), where, "encoder")
        amplifier = _amplifier_of(path, data, row.get("amplifier"), where)
        own = {
            k: v
            for k, v in row.items()
            if k not in ("name", "motor", "reducer", "encoder", "amplifier")
        }
        unknown = sorted(set(own) - set(_RULES["Drive"]))
        if unknown:
            raise RobotDescriptionError(f"{where}: unknown key(s) {unknown}")
        _check_values(_RULES["Drive"], own, f"{where} ")
        drives[name] = Drive(
            joint=name,
            motor=motor,
            reducer=reducer,
            encoder=encoder,
            # left out: NaN, derived from the drive train unless the study gives it
            acceleration_rad_s2=float(row.get("acceleration_rad_s2", math.nan)),
            jerk_rad_s3=float(row.get("jerk_rad_s3", math.nan)),
            derating=float(row.get("derating", catalogue_derating)),
            amplifier=amplifier,
        )
    missing = [n for n in joint_names if n not in drives]
    if missing:
        raise RobotDescriptionError(f"{path}: no drive for joint(s) {missing}")
    return drives


def amplifier_from_dict(data: dict, where: str = "amplifier", part: str = "") -> Amplifier:
    """An :class:`Amplifier` from a table, every value checked (as :func:`motor_from_dict`):
    currents, voltages, capacitance and resistor > 0, ``regenerates`` true or false, the peak
    current not below the continuous one and the brake threshold above the bus voltage."""
    prefix = f"{where} {part}." if part else f"{where} "
    regen = data.get("regenerates", False)
    if not isinstance(regen, bool):
        raise RobotDescriptionError(f"{prefix}regenerates: {regen!r} is not true or false")
    amp = _build(Amplifier, data, where, part)
    if amp.peak_current_A < amp.continuous_current_A:
        raise RobotDescriptionError(
            f"{prefix}peak_current_A: {amp.peak_current_A:g} A is below the continuous current "
            f"({amp.continuous_current_A:g} A)"
        )
    if math.isfinite(amp.brake_threshold_V) and amp.brake_threshold_V <= amp.bus_voltage_V:
        raise RobotDescriptionError(
            f"{prefix}brake_threshold_V: {amp.brake_threshold_V:g} V is not above the bus "
            f"voltage ({amp.bus_voltage_V:g} V)"
        )
    return amp


def _amplifier_of(path: Path, data: dict, value: Any, where: str) -> Amplifier | None:
    """The amplifier a drives file's joint names (a catalogue model or an inline table)."""
    if value is None:
        return None
    if isinstance(value, str):
        from armlab.robot.catalogue import load_catalogue

        cat_key = data.get("catalogue")
        if cat_key is not None and not isinstance(cat_key, str):
            raise RobotDescriptionError(f"{path} catalogue: {cat_key!r} is not a path")
        catalogue = load_catalogue(None if cat_key is None else path.parent / cat_key)
        return catalogue.amplifier(value, f"{where} amplifier")
    if isinstance(value, dict):
        return amplifier_from_dict(dict(value), where, "amplifier")
    raise RobotDescriptionError(f"{where} amplifier: {value!r} is not a model name or a table")


def _catalogue_part(path: Path, data: dict, kind: str, model: str, where: str) -> tuple[Any, float]:
    """(part, derating) of a catalogue model named in a drives file (``motor = "..."``)."""
    from armlab.robot.catalogue import load_catalogue

    cat_key = data.get("catalogue")
    if cat_key is not None and not isinstance(cat_key, str):
        raise RobotDescriptionError(f"{path} catalogue: {cat_key!r} is not a path")
    catalogue = load_catalogue(None if cat_key is None else path.parent / cat_key)
    part = catalogue.motor(model, where) if kind == "motor" else catalogue.reducer(model, where)
    return part, catalogue.derating.get(model, 1.0) if kind == "motor" else 1.0


# ----------------------------------------------------------------------------- writing
def _toml_value(value: Any) -> str:
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)  # shortest text that reads back to the same float
    if isinstance(value, tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return json.dumps(str(value), ensure_ascii=False)  # a TOML basic string


def _given(value: Any) -> bool:
    """False for a number that is "not given" (NaN) or not a limit (inf), or an empty list:
    left out."""
    if isinstance(value, tuple):
        return len(value) > 0
    return not (isinstance(value, float) and not math.isfinite(value))


def drives_toml(drives: dict[str, Drive], header: str = "") -> str:
    """The text of a drives file (``docs/drives.md``) holding ``drives``: every field of each
    motor, reducer and encoder, floats written so that :func:`read_drives` reads back the same
    numbers exactly; a NaN field (not given) is left out. ``header`` lines become comments."""
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    lines += ["version = 1", ""]
    for name, drive in drives.items():
        data = asdict(drive)
        lines += ["[[joint]]", f"name = {_toml_value(name)}"]
        parts = ("motor", "reducer", "encoder", "amplifier")
        for key, value in data.items():
            if key not in ("joint", *parts) and _given(value):
                lines.append(f"{key} = {_toml_value(value)}")
        for part in parts:
            if data.get(part) is None:
                continue  # no amplifier described
            lines += ["", f"[joint.{part}]"]
            lines += [f"{k} = {_toml_value(v)}" for k, v in data[part].items() if _given(v)]
        lines.append("")
    return "\n".join(lines)
