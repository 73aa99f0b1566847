"""Drive-train arithmetic and the per-joint sizing checks, vectorised over candidate drives.

Everything here works on columns: a column is one (joint, drive) pair, so the same code sizes
the six joints of a robot (six columns) or a hundred catalogue combinations for one joint
(a hundred columns holding the same joint signals).

Motor side of a joint (rules used everywhere in :mod:`armlab.dynamics`)
-----------------------------------------------------------------------
With the joint (reducer output) torque ``tau`` from inverse dynamics, joint speed ``qd`` and
acceleration ``qdd``, reducer ratio ``N`` and efficiency ``eta``:

* motor speed ``w_m = N qd``;
* the reducer input torque is ``tau / (N eta)`` when the motor **drives** the load
  (``tau qd >= 0``, holding included) and ``tau eta / N`` when the load **back-drives** the motor
  (``tau qd < 0``, generating: the losses then help the motor). Holding counts as driving, which
  is the thesis rule of table 4.3 (available torque = stall torque x ratio x efficiency);
* the motor torque adds the rotor + reducer-input inertia and the motor's viscous friction:
  ``T_m = T_in + (J_rotor + J_reducer) N qdd + b_m w_m``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from armlab.errors import InputError
from armlab.robot.controller import ControllerProfile, load_profile
from armlab.robot.drives import Drive, available_torque_Nm

__all__ = [
    "Check",
    "DriveArrays",
    "SizingOptions",
    "CHECK_NAMES",
    "motor_side",
    "evaluate_checks",
    "checks_for_column",
    "binding",
    "Checked",
    "envelope_torque",
]

#: Check names, in report order, with their units.
CHECK_NAMES: dict[str, str] = {
    "thesis_rule": "N m",
    "thesis_power_rule": "W",
    "reducer_peak_torque": "N m",
    "reducer_average_torque": "N m",
    "reducer_input_speed": "rad/s",
    "motor_rms_torque": "N m",
    "motor_peak_torque": "N m",
    "motor_speed": "rad/s",
    "motor_envelope": "N m",
    "encoder_resolution": "rad",
    "encoder_pulse_rate": "counts/cycle",
}

_TINY = 1e-12

#: What a failed check against a zero limit means, in words (its margin is no number).
_NO_LIMIT_LEFT = {
    "motor_envelope": "above the motor's no-load speed at its supply voltage: no torque left",
}


@dataclass(frozen=True)
class Check:
    """One sizing check: ``ok`` when ``value <= limit``.

    ``margin = (limit - value) / limit`` is the fraction of the limit still free (negative when
    the check fails); ``unit`` names the unit of ``value`` and ``limit`` (SI).
    """

    name: str
    value: float
    limit: float
    margin: float
    ok: bool
    unit: str = ""
    note: str = ""

    def to_dict(self) -> dict:
        """JSON-able dict; a margin that is not a number (no limit left) is None, with a note."""
        return {
            "name": self.name,
            "value": float(self.value),
            "limit": float(self.limit),
            "margin": float(self.margin) if math.isfinite(self.margin) else None,
            "ok": bool(self.ok),
            "unit": self.unit,
            "note": self.note,
        }

    def describe(self) -> str:
        """One line: ``motor_speed 2390 > 2200 rad/s (margin -8.6 %)`` or the check's note."""
        rel = ">" if not self.ok else "<="
        text = f"{self.name} {self.value:.4g} {rel} {self.limit:.4g} {self.unit}".rstrip()
        if self.note:
            return f"{text} ({self.note})"
        return f"{text} (margin {100 * self.margin:+.1f} %)"


@dataclass(frozen=True)
class SizingOptions:
    """What the sizing checks need beyond the drive train.

    Attributes
    ----------
    tool_resolution_m : float
        Largest tool-point displacement one encoder count of a joint may cause, in [m], at the
        joint's largest lever arm to the tool point (default 0.1 mm, a tenth of the ~1 mm
        accuracy of HEU thesis ch. 3). ASSUMED.
    controller : ControllerProfile
        The controller the set-point table is written for: its cycle, pulse limit per cycle,
        decoding and counts per revolution are what the encoder checks use (the same function,
        :meth:`ControllerProfile.counts_per_rad`, as the table). Default: the reference
        controller (:func:`armlab.robot.load_profile`), the only controller default in armlab.
    """

    tool_resolution_m: float = 1e-4
    controller: ControllerProfile = field(default_factory=load_profile)

    @property
    def cycle_s(self) -> float:
        """Controller cycle in [s] (the profile's)."""
        return self.controller.cycle_s

    @property
    def max_counts_per_cycle(self) -> float:
        """Pulses one axis may receive per cycle (the profile's; inf when it sets none)."""
        m = self.controller.max_pulses_per_cycle
        return math.inf if m is None else float(m)


@dataclass(frozen=True)
class DriveArrays:
    """The numbers of several drives as arrays ``(n_columns,)`` (SI)."""

    ratio: np.ndarray
    efficiency: np.ndarray
    derating: np.ndarray
    inertia_motor_side_kg_m2: np.ndarray  # rotor + reducer input
    viscous_Nm_s_rad: np.ndarray
    stall_torque_Nm: np.ndarray
    peak_torque_Nm: np.ndarray  # peak rating if given, else the stall torque
    rated_speed_rad_s: np.ndarray  # table speed if given, else the no-load speed
    torque_constant_Nm_A: np.ndarray
    back_emf_V_s_rad: np.ndarray
    resistance_ohm: np.ndarray
    supply_voltage_V: np.ndarray
    power_W: np.ndarray
    reducer_rated_torque_Nm: np.ndarray
    reducer_peak_torque_Nm: np.ndarray
    reducer_max_input_speed_rad_s: np.ndarray
    counts_per_motor_rev: np.ndarray
    pulses_per_rev: np.ndarray

    @classmethod
    def from_drives(cls, drives: list[Drive]) -> DriveArrays:
        def arr(f):
            return np.array([float(f(d)) for d in drives])

        def peak(d: Drive) -> float:
            p = d.motor.peak_torque_Nm
            return p if math.isfinite(p) and p > 0 else d.motor.stall_torque_Nm

        return cls(
            ratio=arr(lambda d: d.reducer.ratio),
            efficiency=arr(lambda d: d.reducer.efficiency),
            derating=arr(lambda d: d.derating),
            inertia_motor_side_kg_m2=arr(
                lambda d: d.motor.rotor_inertia_kg_m2 + d.reducer.inertia_kg_m2
            ),
            viscous_Nm_s_rad=arr(lambda d: d.motor.viscous_friction_Nm_s_rad),
            stall_torque_Nm=arr(lambda d: d.motor.stall_torque_Nm),
            peak_torque_Nm=arr(peak),
            # the same motor speed bounds the joint velocity limit (armlab.robot.resolve_limits)
            rated_speed_rad_s=arr(lambda d: d.motor.speed_limit_rad_s),
            torque_constant_Nm_A=arr(lambda d: d.motor.torque_constant_Nm_A),
            back_emf_V_s_rad=arr(lambda d: d.motor.back_emf_V_s_rad),
            resistance_ohm=arr(lambda d: d.motor.resistance_ohm),
            supply_voltage_V=arr(lambda d: d.motor.supply_voltage_V),
            power_W=arr(lambda d: d.motor.power_W),
            reducer_rated_torque_Nm=arr(lambda d: d.reducer.rated_torque_Nm),
            reducer_peak_torque_Nm=arr(lambda d: d.reducer.peak_torque_Nm),
            reducer_max_input_speed_rad_s=arr(lambda d: d.reducer.max_input_speed_rad_s),
            counts_per_motor_rev=arr(lambda d: d.encoder.pulses_per_rev * d.encoder.decoding),
            pulses_per_rev=arr(lambda d: d.encoder.pulses_per_rev),
        )


def counts_per_joint_rev_of(drives: DriveArrays, controller: ControllerProfile) -> np.ndarray:
    """Counts per joint revolution the controller sees for each drive: the profile's
    ``counts_per_joint_rev`` if it sets them, else pulses x decoding (the profile's decoding if it
    sets one, else the encoder's) x ratio -- the rule of :meth:`ControllerProfile.counts_per_rad`
    written for drive arrays (candidate drives of a selection are not on a robot)."""
    if controller.counts_per_joint_rev is not None:
        c = np.asarray(controller.counts_per_joint_rev, float)
        if c.shape != drives.ratio.shape:
            raise InputError(
                f"controller profile {controller.name!r}: counts_per_joint_rev has {c.size} "
                f"entries for {drives.ratio.size} joints"
            )
        return c
    per_motor_rev = (
        drives.counts_per_motor_rev
        if controller.decoding is None
        else drives.pulses_per_rev * float(controller.decoding)
    )
    return per_motor_rev * drives.ratio


def motor_side(tau, qd, qdd, drives: DriveArrays) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Motor torque and speed from joint signals (rules in the module docstring).

    Parameters
    ----------
    tau, qd, qdd : array (n_samples, n_columns)
        Joint torque [N m], speed [rad/s], acceleration [rad/s^2].
    drives : DriveArrays
        ``n_columns`` drives.

    Returns
    -------
    motor_torque_Nm, motor_speed_rad_s : array (n_samples, n_columns)
    motoring : bool array (n_samples, n_columns)
        True where the motor drives the load (``tau qd >= 0``).
    """
    N, eta = drives.ratio, drives.efficiency
    motoring = tau * qd >= 0.0
    t_in = np.where(motoring, tau / (N * eta), tau * (eta / N))
    w_m = N * qd
    t_m = t_in + (drives.inertia_motor_side_kg_m2 * N) * qdd + drives.viscous_Nm_s_rad * w_m
    return t_m, w_m, motoring


def envelope_torque(w_m, t_m, drives: DriveArrays) -> np.ndarray:
    """Torque the DC motor can give at each operating point, in [N m] (>= 0 or negative
    beyond the no-load speed).

    ``T_max = derating x min(T_peak, Kt (U -+ Ke |w|) / R)``: ``-`` while driving
    (``T w >= 0``: the back-EMF eats the supply voltage), ``+`` while generating. The armature
    equation ``U = R i + Ke w`` with ``T = Kt i`` (HEU thesis, ch. 5).
    """
    kt, ke, r, u = (
        drives.torque_constant_Nm_A,
        drives.back_emf_V_s_rad,
        drives.resistance_ohm,
        drives.supply_voltage_V,
    )
    sign = np.where(t_m * w_m >= 0.0, -1.0, 1.0)
    volt = kt * (u + sign * ke * np.abs(w_m)) / r
    return drives.derating * np.minimum(drives.peak_torque_Nm, volt)


def _margin(value, limit):
    limit = np.asarray(limit, float)
    safe = np.where(np.abs(limit) > _TINY, limit, _TINY)
    return (limit - value) / np.abs(safe)


def evaluate_checks(
    tau, qd, qdd, weights, drives: DriveArrays, lever_m, options: SizingOptions
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Every sizing check for every column: ``{name: (value, limit)}``, arrays (n_columns,).

    Parameters
    ----------
    tau, qd, qdd : array (n_samples, n_columns) or (n_samples, 1)
        Joint torque [N m], speed [rad/s], acceleration [rad/s^2] of a duty cycle (one column
        broadcasts over all drives: one joint, many candidate drives).
    weights : array (n_samples,)
        Time each sample stands for, in [s] (trapezoidal; they sum to the cycle time).
    drives : DriveArrays
    lever_m : array (n_columns,)
        Largest distance from each joint's axis to the tool point, in [m].
    options : SizingOptions

    Notes
    -----
    * ``thesis_rule`` (thesis 4.2.3 and table 4.3 note 1): peak ``|tau|`` <= stall torque x
      ratio x efficiency x derating.
    * ``thesis_power_rule`` (thesis 4.2.2-4.2.3): peak ``|tau|`` x peak ``|qd|`` (the thesis'
      "torque x max speed") <= motor table power. Skipped (limit inf) when the motor has none.
    * ``reducer_peak_torque``: peak ``|tau|`` <= reducer peak (momentary) torque.
    * ``reducer_average_torque``: the harmonic-drive makers' average load torque
      ``T_av = (sum |n_k| t_k |T_k|^3 / sum |n_k| t_k)^(1/3)`` (speed-weighted cubic mean; the
      time-weighted cubic mean when the joint never moves) <= reducer rated torque.
    * ``reducer_input_speed``: peak motor speed <= reducer max input speed.
    * ``motor_rms_torque``: ``sqrt(sum t_k T_m,k^2 / sum t_k)`` <= stall torque x derating.
    * ``motor_peak_torque``: peak ``|T_m|`` <= (peak rating, else stall torque) x derating.
    * ``motor_speed``: peak ``|w_m|`` <= table (rated) speed, else no-load speed ``U / Ke``.
    * ``motor_envelope``: every operating point inside the speed-torque envelope
      (:func:`envelope_torque`); value and limit are those of the worst point
      (largest ``|T_m| / T_max``).
    * ``encoder_resolution``: joint angle per count ``2 pi / (pulses x decoding x N)`` <=
      ``tool_resolution_m / lever_m``.
    * ``encoder_pulse_rate``: peak counts per controller cycle <= the controller's pulse limit
      (``options.controller``: cycle, decoding and limit of the profile the table is written for).
    """
    w = np.asarray(weights, float)[:, None]
    t_m, w_m, _ = motor_side(tau, qd, qdd, drives)
    abs_tau, abs_qd = np.abs(tau), np.abs(qd)
    peak_tau = abs_tau.max(axis=0)
    # (value, limit) per check: arrays per column or scalars, broadcast on return
    out: dict[str, tuple[np.ndarray | float, np.ndarray | float]] = {}
    out["thesis_rule"] = (
        peak_tau,
        available_torque_Nm(
            drives.stall_torque_Nm, drives.ratio, drives.efficiency, drives.derating
        ),
    )
    power_limit = np.where(np.isfinite(drives.power_W), drives.power_W, np.inf)
    out["thesis_power_rule"] = (peak_tau * abs_qd.max(axis=0), power_limit)
    out["reducer_peak_torque"] = (peak_tau, drives.reducer_peak_torque_Nm)
    wn = abs_qd * w
    swn = wn.sum(axis=0)
    cube = abs_tau**3
    by_speed = (wn * cube).sum(axis=0) / np.where(swn > 0, swn, 1.0)
    by_time = (w * cube).sum(axis=0) / max(float(w.sum()), _TINY)
    out["reducer_average_torque"] = (
        np.cbrt(np.where(swn > 0, by_speed, by_time)),
        drives.reducer_rated_torque_Nm,
    )
    peak_wm = np.abs(w_m).max(axis=0)
    out["reducer_input_speed"] = (peak_wm, drives.reducer_max_input_speed_rad_s)
    rms = np.sqrt((w * t_m**2).sum(axis=0) / max(float(w.sum()), _TINY))
    if float(w.sum()) <= _TINY:
        rms = np.abs(t_m).max(axis=0)
    out["motor_rms_torque"] = (rms, drives.stall_torque_Nm * drives.derating)
    out["motor_peak_torque"] = (np.abs(t_m).max(axis=0), drives.peak_torque_Nm * drives.derating)
    out["motor_speed"] = (peak_wm, drives.rated_speed_rad_s)
    t_env = envelope_torque(w_m, t_m, drives)
    ratio = np.abs(t_m) / np.maximum(t_env, _TINY)
    k = np.argmax(ratio, axis=0)
    cols = np.arange(ratio.shape[1])
    out["motor_envelope"] = (np.abs(t_m[k, cols]), np.maximum(t_env[k, cols], 0.0))
    counts_per_joint_rev = counts_per_joint_rev_of(drives, options.controller)
    angle = 2.0 * np.pi / counts_per_joint_rev
    out["encoder_resolution"] = (angle, options.tool_resolution_m / np.maximum(lever_m, _TINY))
    counts = abs_qd.max(axis=0) * counts_per_joint_rev / (2.0 * np.pi) * options.cycle_s
    out["encoder_pulse_rate"] = (counts, options.max_counts_per_cycle)
    n_col = drives.ratio.size
    return {
        name: (
            np.broadcast_to(np.asarray(v, float), (n_col,)),
            np.broadcast_to(np.asarray(lim, float), (n_col,)),
        )
        for name, (v, lim) in out.items()
    }


def checks_for_column(
    results: dict[str, tuple[np.ndarray, np.ndarray]], c: int, rtol: float = 1e-9
) -> list[Check]:
    """The :class:`Check` list of column ``c`` of :func:`evaluate_checks`'s output."""
    checks = []
    for name, (value, limit) in results.items():
        v, lim = float(value[c]), float(limit[c])
        if not math.isfinite(lim):  # no such rating: nothing to check
            continue
        ok = bool(v <= lim * (1.0 + rtol) + _TINY)
        note = ""
        if lim <= _TINY and not ok:
            # a relative margin against a zero limit is no number: say what happened instead
            margin = -math.inf
            note = _NO_LIMIT_LEFT.get(name, "the limit is zero")
        else:
            margin = float(_margin(v, lim))
        checks.append(Check(name, v, lim, margin, ok, CHECK_NAMES[name], note))
    return checks


def binding(checks: list[Check]) -> Check:
    """The check with the smallest margin (the one that binds, or fails worst)."""
    return min(checks, key=lambda ch: ch.margin)


class Checked:
    """Mixin of a result that holds ``checks: list[Check]``: its verdict and binding check."""

    checks: list[Check]

    @property
    def ok(self) -> bool:
        """True if every check passes."""
        return all(c.ok for c in self.checks)

    @property
    def binding(self) -> Check:
        """The check with the smallest margin (binds if all pass, fails worst otherwise)."""
        return binding(self.checks)
