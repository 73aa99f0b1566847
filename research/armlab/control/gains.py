"""Servo gains of the joint cascades: dataclasses with a JSON round trip (``gains.json``).

This module is pure Python + the standard library on purpose: the deployment/export code reads
and writes gains without importing python-control or Pinocchio.

Signal chain of one joint (HEU thesis ch. 5; SHU controller paper §1: 1 ms servo, 12-bit +-10 V D/A)
----------------------------------------------------------------------------------------------------
::

    position loop (1 kHz, card)    speed loop (1 kHz, card)      current loop (amplifier, 20 kHz)
    e_theta [rad] --P/PI--> omega* [rad/s] --PI--> i* [A] ==D/A==> --PI--> u_a [V] --> motor
                      (motor side)        (motor side)   +-10 V

* ``current`` loop: input current error in [A] at the motor, output armature voltage in [V];
  gains kp in [V/A], ki in [V/(A s)], kd in [V s/A]. Output limited to the supply voltage.
* ``speed`` loop: input motor-shaft speed error in [rad/s], output current set-point in [A];
  kp in [A/(rad/s)], ki in [A/rad], kd in [A s^2/rad]. Its output crosses the 12-bit +-10 V D/A
  to the amplifier (``output_per_volt`` in [A/V]); limited to the motor peak current.
* ``position`` loop: input motor-shaft position error in [rad] (= joint error x reducer ratio),
  output motor speed set-point in [rad/s]; kp in [(rad/s)/rad] = [1/s] (the same number on the
  joint side), ki in [1/s^2], kd dimensionless. Limited to the motor's maximum speed.

Continuous controller (parallel form, derivative filtered with ``derivative_filter_s``)::

    C(s) = kp + ki / s + kd s / (derivative_filter_s s + 1)

Discrete incremental (velocity-form) PID, thesis ch. 5::

    u_k = u_{k-1} + q0 e_k + q1 e_{k-1} + q2 e_{k-2}
    C(z) = (q0 + q1 z^-1 + q2 z^-2) / (1 - z^-1)

with, for a sample time T and the ``method`` of the integral term (derivative: backward
difference, as the thesis' incremental PID)::

    "backward" (thesis):   q0 = kp + ki T     + kd/T,  q1 = -kp          - 2 kd/T,  q2 = kd/T
    "tustin":              q0 = kp + ki T/2   + kd/T,  q1 = -kp + ki T/2 - 2 kd/T,  q2 = kd/T
    "zoh" (forward Euler): q0 = kp            + kd/T,  q1 = -kp + ki T   - 2 kd/T,  q2 = kd/T

JSON layout (``ArmGains.to_json()``; a study's ``gains.json``)
----------------------------------------------------------------
::

    {
      "format": "armlab.gains/1",
      "robot": "teachbot6",
      "spec": {...},                       # the tuning spec used (see armlab.control.tuning)
      "joints": {
        "joint1": {                        # CascadeGains.to_dict()
          "joint": "joint1",
          "plant": {                       # PlantSummary.to_dict()
            "ratio": 125.0,
            "inertia_motor_kg_m2": {"min": .., "nominal": .., "max": ..},   # total at the motor
            "inertia_joint_kg_m2": {"min": .., "nominal": .., "max": ..},   # arm only, joint side
            "payload_kg": 0.5, "torque_constant_Nm_A": .., "back_emf_V_s_rad": ..,
            "resistance_ohm": .., "inductance_H": .., "estimated": true
          },
          "current":  {LoopGains.to_dict()},
          "speed":    {LoopGains.to_dict()},
          "position": {LoopGains.to_dict()}
        }, ...
      }
    }

``LoopGains.to_dict()`` holds every dataclass field (names below) plus ``gains``
({kp, ki, kd}, a copy, for the summary.json "control" block of DESIGN.md) and ``gain_units``.
Infinite
gain margins (no phase crossover) are written as the string ``"inf"`` (strict JSON has no
infinity) and read back as ``inf``; unknown figures (NaN) are written as ``null``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from dataclasses import dataclass, field, fields, replace
from typing import Any

from armlab.errors import InputError

__all__ = [
    "LOOPS",
    "LOOP_UNITS",
    "GAINS_FORMAT",
    "LoopGains",
    "PlantSummary",
    "CascadeGains",
    "ArmGains",
    "incremental_coefficients",
]

GAINS_FORMAT = "armlab.gains/1"
LOOPS = ("current", "speed", "position")
_KINDS = ("P", "PI", "PD", "PID")
_METHODS = ("tustin", "backward", "zoh")

#: Units of (input, output, kp, ki, kd) per loop; all motor side.
LOOP_UNITS: dict[str, dict[str, str]] = {
    "current": {"input": "A", "output": "V", "kp": "V/A", "ki": "V/(A s)", "kd": "V s/A"},
    "speed": {"input": "rad/s", "output": "A", "kp": "A/(rad/s)", "ki": "A/rad", "kd": "A s^2/rad"},
    "position": {"input": "rad", "output": "rad/s", "kp": "1/s", "ki": "1/s^2", "kd": "1"},
}

_DEFAULT_SIGNALS = {
    "current": ("motor_current_error_A", "armature_voltage_V"),
    "speed": ("motor_speed_error_rad_s", "current_setpoint_A"),
    "position": ("motor_position_error_rad", "motor_speed_setpoint_rad_s"),
}


def incremental_coefficients(
    kp: float, ki: float, kd: float, sample_time_s: float, method: str = "tustin"
) -> tuple[float, float, float]:
    """Coefficients (q0, q1, q2) of the incremental PID.

    ``u_k = u_{k-1} + q0 e_k + q1 e_{k-1} + q2 e_{k-2}`` (thesis ch. 5).

    Parameters
    ----------
    kp, ki, kd : float
        Continuous parallel-form gains (units per loop: :data:`LOOP_UNITS`).
    sample_time_s : float
        Sample time T in [s].
    method : {"tustin", "backward", "zoh"}
        Discretisation of the integral term: trapezoidal, backward Euler (the thesis' incremental
        PID, ch. 5) or forward Euler (the ZOH equivalent of 1/s). The derivative is a backward
        difference in every case.

    Returns
    -------
    q0, q1, q2 : float
    """
    if not sample_time_s > 0.0:
        raise InputError(f"sample_time_s must be > 0, got {sample_time_s}")
    if method not in _METHODS:
        raise InputError(f"method must be one of {_METHODS}, got {method!r}")
    T = float(sample_time_s)
    d = kd / T
    if method == "tustin":
        return kp + ki * T / 2 + d, -kp + ki * T / 2 - 2 * d, d
    if method == "backward":
        return kp + ki * T + d, -kp - 2 * d, d
    return kp + d, -kp + ki * T - 2 * d, d


def _num(x):
    """Float for strict JSON: nan -> None, +-inf -> "inf" / "-inf"."""
    if x is None:
        return None
    x = float(x)
    if math.isnan(x):
        return None
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return x


def _unnum(x):
    """Inverse of :func:`_num`."""
    if x is None:
        return math.nan
    return float(x)  # float("inf") and float("-inf") parse the strings


@dataclass
class LoopGains:
    """Gains and checked figures of one loop of a joint cascade.

    Attributes
    ----------
    loop : {"current", "speed", "position"}
    kind : {"P", "PI", "PD", "PID"}
    kp, ki, kd : float
        Continuous gains, motor side, SI (units in :data:`LOOP_UNITS`).
    sample_time_s : float
        Sample period T of the discrete loop in [s].
    method : {"tustin", "backward", "zoh"}
        Discretisation of the integral term (see :func:`incremental_coefficients`).
    q0, q1, q2 : float
        Incremental PID coefficients; filled from kp, ki, kd, T and method if left NaN.
    output_min, output_max : float
        Output saturation in the loop's output unit (V, A or rad/s).
    input_signal, output_signal : str
        Names of the loop's input (error) and output signals with their unit.
    derivative_filter_s : float
        Time constant of the derivative filter in [s] (0: none).
    delay_samples : float
        Computation delay assumed in the discrete check, in samples (1 = one-period delay).
    output_per_volt : float or None
        For the loop whose output crosses the D/A: output units per volt (e.g. [A/V]); None else.
    da_range_V, da_bits : float, int
        D/A range (+-10 V) and resolution (12 bit) for that loop.
    crossover_rad_s : float
        Gain crossover of the open loop at the nominal inertia in [rad/s] (continuous).
    phase_margin_deg, gain_margin_dB : float
        Worst case over the inertia range, continuous open loop (inner loops closed).
    overshoot_pct, settling_time_s : float
        Worst case over the inertia range, closed-loop step of this loop (2 % settling), continuous.
    crossover_discrete_rad_s, phase_margin_discrete_deg, gain_margin_discrete_dB,
    overshoot_discrete_pct, settling_time_discrete_s : float
        The same re-checked on the discrete loop (ZOH plant, computation delay, C(z)).
    robustness : list of dict
        Per inertia case: ``label`` (min/nominal/max), ``inertia_kg_m2`` (motor side, total),
        ``crossover_rad_s``, ``phase_margin_deg``, ``gain_margin_dB``, ``overshoot_pct``,
        ``settling_time_s`` and their ``*_discrete`` twins.
    """

    loop: str
    kind: str
    kp: float
    ki: float = 0.0
    kd: float = 0.0
    sample_time_s: float = 1e-3
    method: str = "tustin"
    q0: float = math.nan
    q1: float = math.nan
    q2: float = math.nan
    output_min: float = -math.inf
    output_max: float = math.inf
    input_signal: str = ""
    output_signal: str = ""
    derivative_filter_s: float = 0.0
    delay_samples: float = 1.0
    output_per_volt: float | None = None
    da_range_V: float = 10.0
    da_bits: int = 12
    crossover_rad_s: float = math.nan
    phase_margin_deg: float = math.nan
    gain_margin_dB: float = math.nan
    overshoot_pct: float = math.nan
    settling_time_s: float = math.nan
    crossover_discrete_rad_s: float = math.nan
    phase_margin_discrete_deg: float = math.nan
    gain_margin_discrete_dB: float = math.nan
    overshoot_discrete_pct: float = math.nan
    settling_time_discrete_s: float = math.nan
    robustness: list = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.loop not in LOOPS:
            raise InputError(f"loop must be one of {LOOPS}, got {self.loop!r}")
        if self.kind not in _KINDS:
            raise InputError(f"{self.loop} loop: kind must be one of {_KINDS}, got {self.kind!r}")
        if self.method not in _METHODS:
            raise InputError(
                f"{self.loop} loop: method must be one of {_METHODS}, got {self.method!r}"
            )
        if not self.sample_time_s > 0.0:
            raise InputError(
                f"{self.loop} loop: sample_time_s must be > 0, got {self.sample_time_s}"
            )
        for name in ("kp", "ki", "kd"):
            v = float(getattr(self, name))
            if not math.isfinite(v) or v < 0.0:
                raise InputError(f"{self.loop} loop: {name} must be finite and >= 0, got {v}")
            setattr(self, name, v)
        self.output_min, self.output_max = float(self.output_min), float(self.output_max)
        self.sample_time_s = float(self.sample_time_s)
        if not self.output_min < self.output_max:
            raise InputError(
                f"{self.loop} loop: output_min {self.output_min} must be < "
                f"output_max {self.output_max}"
            )
        if any(math.isnan(q) for q in (self.q0, self.q1, self.q2)):
            self.q0, self.q1, self.q2 = incremental_coefficients(
                self.kp, self.ki, self.kd, self.sample_time_s, self.method
            )
        if not self.input_signal or not self.output_signal:
            i, o = _DEFAULT_SIGNALS[self.loop]
            self.input_signal = self.input_signal or i
            self.output_signal = self.output_signal or o

    # ------------------------------------------------------------------ derived
    @property
    def units(self) -> dict[str, str]:
        """Units of input, output, kp, ki, kd (see :data:`LOOP_UNITS`)."""
        return dict(LOOP_UNITS[self.loop])

    @property
    def da_lsb(self) -> float | None:
        """One D/A step in the output unit (``2 range / 2^bits x output_per_volt``), or None."""
        if self.output_per_volt is None:
            return None
        return 2.0 * self.da_range_V / 2**self.da_bits * self.output_per_volt

    def discrete_tf(self) -> tuple[list[float], list[float]]:
        """Numerator and denominator of C(z), descending powers of z:
        ``(q0 z^2 + q1 z + q2) / (z^2 - z)``."""
        return [self.q0, self.q1, self.q2], [1.0, -1.0, 0.0]

    def with_gains(self, kp: float, ki: float = 0.0, kd: float = 0.0) -> LoopGains:
        """Copy with new continuous gains; q0..q2 recomputed, checked figures cleared."""
        keep = {
            f.name: getattr(self, f.name)
            for f in fields(self)
            if f.name
            in (
                "loop",
                "kind",
                "sample_time_s",
                "method",
                "output_min",
                "output_max",
                "input_signal",
                "output_signal",
                "derivative_filter_s",
                "delay_samples",
                "output_per_volt",
                "da_range_V",
                "da_bits",
            )
        }
        return LoopGains(kp=kp, ki=ki, kd=kd, **keep)

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict:
        """JSON-able dict: every field (nan -> null, inf -> "inf"), ``gains``, ``gain_units``."""
        out: dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "robustness":
                out[f.name] = [
                    {
                        k: (
                            _num(x)
                            if isinstance(x, (int, float)) and not isinstance(x, bool)
                            else x
                        )
                        for k, x in row.items()
                    }
                    for row in v
                ]
            elif isinstance(v, float):
                out[f.name] = _num(v)
            else:
                out[f.name] = v
        out["gains"] = {"kp": self.kp, "ki": self.ki, "kd": self.kd}
        out["gain_units"] = self.units
        return out

    @classmethod
    def from_dict(cls, d: dict) -> LoopGains:
        """Inverse of :meth:`to_dict` (unknown keys ignored; null -> nan, "inf" -> inf)."""
        names = {f.name for f in fields(cls)}
        kw = {k: v for k, v in d.items() if k in names}
        missing = {"loop", "kind", "kp"} - kw.keys()
        if missing:
            raise InputError(f"loop gains: missing keys {sorted(missing)}")
        for f in fields(cls):
            if f.type == "float" and f.name in kw:
                kw[f.name] = _unnum(kw[f.name])
        if "robustness" in kw:
            kw["robustness"] = [
                {
                    k: (
                        _unnum(x)
                        if (x is None or x in ("inf", "-inf") or isinstance(x, (int, float)))
                        and not isinstance(x, bool)
                        else x
                    )
                    for k, x in row.items()
                }
                for row in kw["robustness"]
            ]
        return cls(**kw)

    def summary(self) -> dict:
        """The summary.json "control" entry of this loop (DESIGN.md)."""
        return {
            "kind": self.kind,
            "gains": {"kp": self.kp, "ki": self.ki, "kd": self.kd, "units": self.units},
            "q": [self.q0, self.q1, self.q2],
            "crossover_rad_s": _num(self.crossover_rad_s),
            "phase_margin_deg": _num(self.phase_margin_deg),
            "gain_margin_dB": _num(self.gain_margin_dB),
            "overshoot_pct": _num(self.overshoot_pct),
            "settling_time_s": _num(self.settling_time_s),
            "crossover_discrete_rad_s": _num(self.crossover_discrete_rad_s),
            "phase_margin_discrete_deg": _num(self.phase_margin_discrete_deg),
            "gain_margin_discrete_dB": _num(self.gain_margin_discrete_dB),
            "overshoot_discrete_pct": _num(self.overshoot_discrete_pct),
            "settling_time_discrete_s": _num(self.settling_time_discrete_s),
            "sample_time_s": self.sample_time_s,
            "method": self.method,
            "output_min": _num(self.output_min),
            "output_max": _num(self.output_max),
        }


@dataclass
class PlantSummary:
    """What a cascade was tuned on.

    Attributes
    ----------
    ratio : float
        Reducer ratio (motor speed / joint speed).
    inertia_motor_kg_m2 : dict
        Total inertia at the motor shaft (rotor + reducer + arm / ratio^2) in [kg m^2] for
        ``min``, ``nominal``, ``max``.
    inertia_joint_kg_m2 : dict
        Arm-only inertia at the joint (mass-matrix diagonal) in [kg m^2], same keys.
    payload_kg : float
    torque_constant_Nm_A, back_emf_V_s_rad, resistance_ohm, inductance_H : float
        Motor constants used.
    estimated : bool
        True when the motor constants are ESTIMATED (drives.toml), not measured.
    compliant : bool
        Tuned on the two-mass joint (:mod:`armlab.control.plant`).
    anti_resonance_rad_s, first_resonance_rad_s : dict
        The joint's anti-resonance ``sqrt(K1/J_L)`` and first resonance
        ``sqrt(K1 (J_M + J_L)/(J_M J_L))`` in [rad/s] per inertia case (NaN: no stiffness data).
    """

    ratio: float
    inertia_motor_kg_m2: dict
    inertia_joint_kg_m2: dict
    payload_kg: float = 0.0
    torque_constant_Nm_A: float = math.nan
    back_emf_V_s_rad: float = math.nan
    resistance_ohm: float = math.nan
    inductance_H: float = math.nan
    estimated: bool = False
    compliant: bool = False
    anti_resonance_rad_s: dict = field(default_factory=dict)
    first_resonance_rad_s: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        def value(v):
            if isinstance(v, float):
                return _num(v)
            if isinstance(v, dict):  # per inertia case; NaN (no stiffness) -> null
                return {k: _num(x) if isinstance(x, float) else x for k, x in v.items()}
            return v

        return {f.name: value(getattr(self, f.name)) for f in fields(self)}

    @classmethod
    def from_dict(cls, d: dict) -> PlantSummary:
        names = {f.name for f in fields(cls)}
        kw = {k: v for k, v in d.items() if k in names}
        for f in fields(cls):
            if f.type == "float" and f.name in kw:
                kw[f.name] = _unnum(kw[f.name])
        return cls(**kw)


@dataclass
class CascadeGains:
    """The three loops of one joint.

    Attributes
    ----------
    joint : str
    current, speed, position : LoopGains
    plant : PlantSummary
    spec : dict
        The tuning spec used (JSON-able).
    """

    joint: str
    current: LoopGains
    speed: LoopGains
    position: LoopGains
    plant: PlantSummary | None = None
    spec: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in LOOPS:
            lg = getattr(self, name)
            if lg.loop != name:
                raise InputError(f"{self.joint}: the {name} slot holds a {lg.loop} loop")

    def loops(self) -> dict[str, LoopGains]:
        return {name: getattr(self, name) for name in LOOPS}

    def replace_loop(self, loop: LoopGains) -> CascadeGains:
        changes: dict[str, Any] = {loop.loop: loop}
        return replace(self, **changes)

    def to_dict(self) -> dict:
        """Full JSON-able dict (the gains.json entry of the joint)."""
        return {
            "joint": self.joint,
            "plant": None if self.plant is None else self.plant.to_dict(),
            "spec": self.spec,
            **{name: getattr(self, name).to_dict() for name in LOOPS},
        }

    def summary(self) -> dict:
        """The summary.json "control" block of the joint: per loop gains and checked figures,
        and ``resonance``: the joint's first resonance and anti-resonance in [rad/s] per
        inertia case beside them (null without reducer stiffness data) and whether the loops
        were tuned on the two-mass joint (``compliant``)."""
        out = {name: getattr(self, name).summary() for name in LOOPS}
        if self.plant is not None:
            p = self.plant.to_dict()
            out["resonance"] = {
                "compliant": bool(p["compliant"]),
                "first_rad_s": p["first_resonance_rad_s"],
                "anti_rad_s": p["anti_resonance_rad_s"],
            }
        return out

    @classmethod
    def from_dict(cls, d: dict) -> CascadeGains:
        try:
            return cls(
                joint=d["joint"],
                current=LoopGains.from_dict(d["current"]),
                speed=LoopGains.from_dict(d["speed"]),
                position=LoopGains.from_dict(d["position"]),
                plant=None if d.get("plant") is None else PlantSummary.from_dict(d["plant"]),
                spec=dict(d.get("spec") or {}),
            )
        except KeyError as e:
            raise InputError(f"cascade gains: missing key {e.args[0]!r}") from None

    def to_json(self, indent: int | None = 2) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    @classmethod
    def from_json(cls, text: str) -> CascadeGains:
        try:
            return cls.from_dict(json.loads(text))
        except json.JSONDecodeError as e:
            raise InputError(f"cascade gains: not JSON ({e.msg} at line {e.lineno})") from None


@dataclass
class ArmGains:
    """Gains of every joint of an arm (a study's ``gains.json``; layout in the module docstring).

    Attributes
    ----------
    joints : dict[str, CascadeGains]
        In joint order.
    robot : str
    spec : dict
    """

    joints: dict[str, CascadeGains]
    robot: str = ""
    spec: dict = field(default_factory=dict)

    def __getitem__(self, joint: str) -> CascadeGains:
        try:
            return self.joints[joint]
        except KeyError:
            raise InputError(f"no gains for joint {joint!r}; have {list(self.joints)}") from None

    def __iter__(self) -> Iterator[CascadeGains]:
        return iter(self.joints.values())

    def __len__(self) -> int:
        return len(self.joints)

    @property
    def joint_names(self) -> list[str]:
        return list(self.joints)

    def to_dict(self) -> dict:
        return {
            "format": GAINS_FORMAT,
            "robot": self.robot,
            "spec": self.spec,
            "joints": {name: g.to_dict() for name, g in self.joints.items()},
        }

    def summary(self) -> dict:
        """summary.json "control" block: ``{joint: {loop: figures}}``."""
        return {name: g.summary() for name, g in self.joints.items()}

    @classmethod
    def from_dict(cls, d: dict) -> ArmGains:
        fmt = d.get("format", GAINS_FORMAT)
        if fmt != GAINS_FORMAT:
            raise InputError(f"gains: format {fmt!r} is not {GAINS_FORMAT!r}")
        if "joints" not in d:
            raise InputError("gains: missing key 'joints'")
        return cls(
            joints={k: CascadeGains.from_dict(v) for k, v in d["joints"].items()},
            robot=d.get("robot", ""),
            spec=dict(d.get("spec") or {}),
        )

    def to_json(self, indent: int | None = 2) -> str:
        return json.dumps(self.to_dict(), indent=indent)

    @classmethod
    def from_json(cls, text: str) -> ArmGains:
        try:
            return cls.from_dict(json.loads(text))
        except json.JSONDecodeError as e:
            raise InputError(f"gains: not JSON ({e.msg} at line {e.lineno})") from None
