"""Drive-train arithmetic and the per-joint sizing checks, vectorised over candidate drives.

Everything here works on columns: a column is one (joint, drive) pair, so the same code sizes
the six joints of a robot (six columns) or a hundred catalogue combinations for one joint
(a hundred columns holding the same joint signals).

Motor side of a joint
---------------------
One model, :mod:`armlab.robot.drivetrain` (its docstring has the equations): joint friction,
reducer efficiency by quadrant (motoring ``/ eta``, back-driven ``x eta_b``; holding counts as
motoring, the thesis rule of table 4.3), reflected rotor + reducer inertia and motor friction;
the envelope is ``derating x min(T_peak, Kt (U - Ke |w|) / R)`` in both quadrants (no credit
for regeneration unless the drive's amplifier regenerates: then ``Kt (U + Ke |w|) / R`` while
braking), all from :mod:`armlab.robot.drivetrain`. The winding temperature is
:mod:`armlab.dynamics.thermal`'s, the braking energy :mod:`armlab.dynamics.regeneration`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from armlab.dynamics import reducer_life
from armlab.dynamics.regeneration import regeneration
from armlab.dynamics.thermal import AMBIENT_DEGC, ThermalModel, winding_temperature
from armlab.errors import InputError
from armlab.robot import drivetrain
from armlab.robot.controller import ControllerProfile
from armlab.robot.drivetrain import DriveTrain

__all__ = [
    "Check",
    "SizingOptions",
    "CHECK_NAMES",
    "evaluate_checks",
    "checks_for_column",
    "binding",
    "Checked",
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
    "winding_temperature_rise": "K",
    "inertia_ratio": "",
    "amplifier_peak_current": "A",
    "amplifier_continuous_current": "A",
    "bus_capacitor_energy": "J",
    "brake_resistor_power": "W",
    "brake_resistor_peak_power": "W",
    **reducer_life.REDUCER_CHECKS,
}

_TINY = 1e-12

#: What a failed check against a zero limit means, in words (its margin is no number).
_NO_LIMIT_LEFT = {
    "motor_envelope": "above the motor's no-load speed at its supply voltage: no torque left",
}

#: Checks whose limit is NaN where a part lacks the data (not infinite: no such rating), what
#: the check then says instead of passing, and the part whose source it names.
_NOT_CHECKED = {
    "winding_temperature_rise": ("not checked: no thermal data", "motor"),
    "bus_capacitor_energy": ("not checked: no bus capacitance or threshold voltage", "amplifier"),
    "brake_resistor_power": ("not checked: no brake resistor power rating", "amplifier"),
    "brake_resistor_peak_power": ("not checked: no brake threshold voltage", "amplifier"),
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
    checked: bool = True

    def to_dict(self) -> dict:
        """JSON-able dict; a margin that is not a number (no limit left) is None, with a note;
        a check that could not be made (``checked`` false: the part lacks the data) has
        ``ok``, ``value``, ``limit`` and ``margin`` None and says why in ``note``."""
        if not self.checked:
            return {
                "name": self.name,
                "value": None,
                "limit": None,
                "margin": None,
                "ok": None,
                "unit": self.unit,
                "note": self.note,
                "checked": False,
            }
        return {
            "name": self.name,
            "value": float(self.value) if math.isfinite(self.value) else None,
            "limit": float(self.limit) if math.isfinite(self.limit) else None,
            "margin": float(self.margin) if math.isfinite(self.margin) else None,
            "ok": bool(self.ok),
            "unit": self.unit,
            "note": self.note,
        }

    def describe(self) -> str:
        """One line: ``motor_speed 2390 > 2200 rad/s (margin -8.6 %)`` or the check's note."""
        if not self.checked:
            return f"{self.name} {self.note}"
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
    required_life_h : float
        Life the reducers must reach over the duty cycle, [h] (``[sizing] required_life_h``;
        default 7000 h, the CSF L_10 rating: ASSUMED; :mod:`armlab.dynamics.reducer_life`).
    momentary_load : str
        Load case of the momentary-torque check: ``"plan"`` (the plan's worst sample, default)
        or ``"stop"`` (also an emergency stop at the current limit) (``[sizing]
        momentary_load``).
    controller : ControllerProfile
        The controller the set-point table is written for: its cycle, pulse limit per cycle,
        decoding and counts per revolution are what the encoder checks use (the same function,
        :meth:`ControllerProfile.counts_per_rad`, as the table). :func:`size` and
        :func:`select_drives` build it from their ``controller=``.

    dwell_s : float
        Rest at the cycle's last pose before it repeats, in [s] (default 0): part of the duty
        cycle (:func:`armlab.dynamics.thermal.with_dwell`), so of the RMS and the thermal check.
    cycles : int or None
        Cycles of the thermal check from ambient; None (default): the periodic state of the
        cycle repeated for ever (:func:`armlab.dynamics.thermal.winding_temperature`).
    ambient_degC : float
        Ambient temperature of the thermal check in [degC]; default 25 degC, ASSUMED: the
        motor makers' rating condition.
    max_inertia_ratio : float
        Largest load-to-motor inertia ratio allowed (check ``inertia_ratio``); inf (default):
        no rule, the ratios are reported only.
    """

    controller: ControllerProfile
    tool_resolution_m: float = 1e-4
    required_life_h: float = reducer_life.DEFAULT_REQUIRED_LIFE_H
    momentary_load: str = "plan"
    dwell_s: float = 0.0
    cycles: int | None = None
    ambient_degC: float = AMBIENT_DEGC
    max_inertia_ratio: float = math.inf

    def __post_init__(self) -> None:
        if not (math.isfinite(self.dwell_s) and self.dwell_s >= 0):
            raise InputError(f"sizing.dwell_s: {self.dwell_s!r} is not a time >= 0 s")
        if self.cycles is not None and (isinstance(self.cycles, bool) or self.cycles < 1):
            raise InputError(f"sizing.cycles: {self.cycles!r} is not a count >= 1")
        if not (math.isfinite(self.ambient_degC) and -50.0 <= self.ambient_degC <= 150.0):
            raise InputError(f"sizing.ambient_degC: {self.ambient_degC!r} is not in [-50, 150]")
        if not self.max_inertia_ratio > 0:
            raise InputError(f"sizing.max_inertia_ratio: {self.max_inertia_ratio!r} is not > 0")

    @property
    def cycle_s(self) -> float:
        """Controller cycle in [s] (the profile's)."""
        return self.controller.cycle_s

    @property
    def max_counts_per_cycle(self) -> float:
        """Pulses one axis may receive per cycle (the profile's; inf when it sets none)."""
        m = self.controller.max_pulses_per_cycle
        return math.inf if m is None else float(m)


def counts_per_joint_rev_of(drives: DriveTrain, controller: ControllerProfile) -> np.ndarray:
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
    return drives.counts_per_joint_rev(controller.decoding)


def _margin(value, limit):
    limit = np.asarray(limit, float)
    safe = np.where(np.abs(limit) > _TINY, limit, _TINY)
    return (limit - value) / np.abs(safe)


def evaluate_checks(
    tau,
    qd,
    qdd,
    weights,
    drives: DriveTrain,
    lever_m,
    options: SizingOptions,
    *,
    joint_inertia_kg_m2=None,
    figures: dict[str, np.ndarray] | None = None,
    tilt_Nm=None,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Every sizing check for every column: ``{name: (value, limit)}``, arrays (n_columns,).

    Parameters
    ----------
    tau, qd, qdd : array (n_samples, n_columns) or (n_samples, 1)
        Joint torque [N m], speed [rad/s], acceleration [rad/s^2] of a duty cycle (one column
        broadcasts over all drives: one joint, many candidate drives).
    weights : array (n_samples,)
        Time each sample stands for, in [s] (trapezoidal; they sum to the cycle time).
    drives : DriveTrain
    lever_m : array (n_columns,)
        Largest distance from each joint's axis to the tool point, in [m].
    options : SizingOptions
    joint_inertia_kg_m2 : array (n_samples, n_columns) or (n_samples, 1), optional
        The arm's inertia at each joint along the cycle, ``M_jj(q)`` [kg m^2] (the inertia
        ratio; without it no ratio is computed).
    figures : dict, optional
        Filled with what the checks computed beside their values, arrays (n_columns,):
        ``winding_peak_temperature_degC``, ``housing_temperature_degC`` (end of the cycle),
        ``inertia_ratio_min`` and ``inertia_ratio_max`` (NaN where not computed),
        ``braking_energy_J``, ``peak_regenerated_power_W``, ``largest_braking_stretch_J``.
    tilt_Nm : array (n_columns,), optional
        Peak tilting moment on each output bearing
        (:func:`armlab.dynamics.reducer_life.tilting_moments_Nm`); None: not computed.

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
      (:func:`armlab.robot.drivetrain.envelope_torque`); value and limit are those of the
      worst point (largest ``|T_m| / T_max``).
    * ``encoder_resolution``: joint angle per count ``2 pi / (pulses x decoding x N)`` <=
      ``tool_resolution_m / lever_m``.
    * ``encoder_pulse_rate``: peak counts per controller cycle <= the controller's pulse limit
      (``options.controller``: cycle, decoding and limit of the profile the table is written for).
    * ``winding_temperature_rise``: peak winding temperature over the cycle repeated (with its
      dwell, from ``options.ambient_degC``; :func:`armlab.dynamics.thermal.winding_temperature`)
      minus the ambient <= maximum winding temperature minus the ambient [K] (the margin is the
      share of the allowed rise still free). Not checked where the motor has no thermal data.
    * ``inertia_ratio``: largest load-to-motor inertia ratio over the cycle's samples,
      ``J_load / J_motor_side`` with ``J_load`` the arm's ``M_jj`` seen at the motor
      (:meth:`~armlab.robot.drives.Drive.load_inertia_at_motor_kg_m2`, motoring: ``/ (eta
      N^2)``) <= ``options.max_inertia_ratio`` (off by default). The smallest ratio uses the
      back-driven ``eta_b M_jj / N^2`` (the range the tuning sees, :mod:`armlab.control.plant`).
    * ``amplifier_peak_current``: peak ``|T_m| / Kt`` <= the amplifier's peak current;
      ``amplifier_continuous_current``: RMS ``T_m / Kt`` <= its continuous current (both only
      where the drive has an amplifier, :attr:`~armlab.robot.drives.Drive.amplifier`).
    * ``bus_capacitor_energy``, ``brake_resistor_power``, ``brake_resistor_peak_power``: the
      cycle's braking energy against the bus capacitor and the brake resistor of an amplifier
      that regenerates (:mod:`armlab.dynamics.regeneration`).
    * ``motor_envelope`` is four-quadrant for an amplifier that regenerates: braking samples
      are bounded by ``Kt (U + Ke |w_m|) / R`` (:func:`armlab.robot.drivetrain.envelope_torque`).
    * ``reducer_life``, ``reducer_momentary_torque``, ``reducer_bearing_moment``: the
      wave-generator bearing's life against ``options.required_life_h``, the plan's worst
      sample against the momentary torque, the output bearing's tilting moment against its
      rating (:mod:`armlab.dynamics.reducer_life`, which has the formulas and sources).
    """
    t_m, w_m, _ = drivetrain.motor_side(tau, qd, qdd, drives)
    abs_tau, abs_qd = np.abs(tau), np.abs(qd)
    peak_tau = abs_tau.max(axis=0)
    # (value, limit) per check: arrays per column or scalars, broadcast on return
    out: dict[str, tuple[np.ndarray | float, np.ndarray | float]] = {}
    out["thesis_rule"] = (
        peak_tau,
        drives.available_joint_torque_Nm,
    )
    power_limit = np.where(np.isfinite(drives.power_W), drives.power_W, np.inf)
    out["thesis_power_rule"] = (peak_tau * abs_qd.max(axis=0), power_limit)
    out["reducer_peak_torque"] = (peak_tau, drives.reducer_peak_torque_Nm)
    out["reducer_average_torque"] = (
        reducer_life.average_torque_Nm(tau, qd, weights),
        drives.reducer_rated_torque_Nm,
    )
    peak_wm = np.abs(w_m).max(axis=0)
    out["reducer_input_speed"] = (peak_wm, drives.reducer_max_input_speed_rad_s)
    rms = drivetrain.rms_torque(t_m, np.asarray(weights, float))
    out["motor_rms_torque"] = (rms, drives.continuous_motor_torque_Nm)
    out["motor_peak_torque"] = (np.abs(t_m).max(axis=0), drives.peak_motor_torque_Nm)
    out["motor_speed"] = (peak_wm, drives.rated_speed_rad_s)
    t_env = drivetrain.envelope_torque(w_m, drives, t_m)
    ratio = drivetrain.envelope_ratio(t_m, w_m, drives)
    k = np.argmax(ratio, axis=0)
    cols = np.arange(ratio.shape[1])
    out["motor_envelope"] = (np.abs(t_m[k, cols]), np.maximum(t_env[k, cols], 0.0))
    counts_per_joint_rev = counts_per_joint_rev_of(drives, options.controller)
    angle = 2.0 * np.pi / counts_per_joint_rev
    out["encoder_resolution"] = (angle, options.tool_resolution_m / np.maximum(lever_m, _TINY))
    counts = abs_qd.max(axis=0) * counts_per_joint_rev / (2.0 * np.pi) * options.cycle_s
    out["encoder_pulse_rate"] = (counts, options.max_counts_per_cycle)
    out.update(
        reducer_life.reducer_checks(
            tau,
            qd,
            weights,
            drives,
            options.required_life_h,
            tilt_Nm,
            options.momentary_load,
        )
    )
    n_col = drives.ratio.size
    figs = _thermal_and_inertia(t_m, weights, drives, options, joint_inertia_kg_m2, out)
    figs.update(_amplifier_checks(t_m, w_m, weights, drives, out))
    if figures is not None:
        figures.update(figs)
    return {
        name: (
            np.broadcast_to(np.asarray(v, float), (n_col,)),
            np.broadcast_to(np.asarray(lim, float), (n_col,)),
        )
        for name, (v, lim) in out.items()
    }


def _thermal_and_inertia(t_m, weights, drives, options, joint_inertia_kg_m2, out) -> dict:
    """The ``winding_temperature_rise`` and ``inertia_ratio`` checks into ``out``; returns
    the figures beside them (:func:`evaluate_checks`)."""
    thermal = ThermalModel.from_drives(drives.drives)
    heat = winding_temperature(
        t_m, weights, thermal, ambient_degC=options.ambient_degC, cycles=options.cycles
    )
    amb = options.ambient_degC
    out["winding_temperature_rise"] = (
        heat.peak_winding_degC - amb,
        np.where(thermal.given, thermal.max_winding_degC - amb, np.nan),
    )
    r_min, r_max = _inertia_ratios(joint_inertia_kg_m2, drives)
    out["inertia_ratio"] = (r_max, options.max_inertia_ratio)
    return {
        "winding_peak_temperature_degC": heat.peak_winding_degC,
        "housing_temperature_degC": heat.end_housing_degC,
        "inertia_ratio_min": r_min,
        "inertia_ratio_max": r_max,
    }


def _amplifier_checks(t_m, w_m, weights, drives: DriveTrain, out) -> dict:
    """The amplifier's current checks and the braking-energy checks
    (:mod:`armlab.dynamics.regeneration`) into ``out`` (limit inf: no amplifier, or one that
    does not regenerate; NaN: it regenerates but the data sheet lacks the value); returns the
    braking figures."""
    kt = drives.torque_constant_Nm_A
    amps = [d.amplifier for d in drives.drives]

    def amp_value(name: str, regen_only: bool = False) -> np.ndarray:
        return np.array(
            [
                np.inf
                if a is None or (regen_only and not a.regenerates)
                else float(getattr(a, name))
                for a in amps
            ]
        )

    w = np.asarray(weights, float)
    out["amplifier_peak_current"] = (np.abs(t_m).max(axis=0) / kt, amp_value("peak_current_A"))
    out["amplifier_continuous_current"] = (
        drivetrain.rms_torque(t_m, w) / kt,
        np.array([d.continuous_current_limit_A for d in drives.drives]),
    )
    regen, stretches = regeneration(t_m, w_m, w, drives.resistance_ohm, kt)
    cap = amp_value("bus_energy_J", regen_only=True)
    resistor = amp_value("brake_resistor_ohm", regen_only=True)
    has_resistor = np.isfinite(resistor)
    # without a resistor the capacitor takes every stretch; with one, the excess goes to it
    out["bus_capacitor_energy"] = (regen.largest_stretch_J, np.where(has_resistor, np.inf, cap))
    beyond = regen.beyond_J(stretches, np.nan_to_num(cap, nan=0.0, posinf=0.0))
    cycle_s = max(float(w.sum()), _TINY)
    out["brake_resistor_power"] = (
        beyond / cycle_s,
        np.where(has_resistor, amp_value("brake_resistor_power_W", regen_only=True), np.inf),
    )
    out["brake_resistor_peak_power"] = (
        regen.peak_power_W,
        np.where(has_resistor, amp_value("brake_peak_power_W", regen_only=True), np.inf),
    )
    return {
        "braking_energy_J": regen.energy_J,
        "peak_regenerated_power_W": regen.peak_power_W,
        "largest_braking_stretch_J": regen.largest_stretch_J,
    }


def _inertia_ratios(joint_inertia_kg_m2, drives: DriveTrain) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest load-to-motor inertia ratio of each column over the samples:
    the arm's ``M_jj`` seen at the motor (the drive's
    :meth:`~armlab.robot.drives.Drive.load_inertia_at_motor_kg_m2`, back-driven for the
    smallest, motoring for the largest) over the motor-side inertia (rotor + reducer input).
    NaN without the inertias; inf where the motor-side inertia is zero."""
    n_col = drives.ratio.size
    if joint_inertia_kg_m2 is None:
        return np.full(n_col, np.nan), np.full(n_col, np.nan)
    m = np.asarray(joint_inertia_kg_m2, float)
    if m.ndim == 1:
        m = m[:, None]
    m = np.broadcast_to(m, (m.shape[0], n_col))
    lo, hi = m.min(axis=0), m.max(axis=0)
    r_min, r_max = np.empty(n_col), np.empty(n_col)
    for c, d in enumerate(drives.drives):
        own = d.motor_side_inertia_kg_m2
        load_lo = d.load_inertia_at_motor_kg_m2(lo[c], motoring=False)
        load_hi = d.load_inertia_at_motor_kg_m2(hi[c], motoring=True)
        r_min[c] = load_lo / own if own > 0 else math.inf
        r_max[c] = load_hi / own if own > 0 else math.inf
    return r_min, r_max


def checks_for_column(
    results: dict[str, tuple[np.ndarray, np.ndarray]],
    c: int,
    rtol: float = 1e-9,
    drives: DriveTrain | None = None,
) -> list[Check]:
    """The :class:`Check` list of column ``c`` of :func:`evaluate_checks`'s output.

    A check without a rating (limit inf) is left out; one the part lacks the data for (limit
    NaN: :data:`_NOT_CHECKED`, and the reducer checks of
    :data:`armlab.dynamics.reducer_life.REDUCER_CHECKS` without a rating) is kept as "not
    checked" with the reason (and the part's source, when ``drives`` is given), neither passing
    nor failing. A reducer that never turns or carries no torque passes its life check (``no
    wear``)."""
    checks = []
    for name, (value, limit) in results.items():
        v, lim = float(value[c]), float(limit[c])
        if name in reducer_life.REDUCER_CHECKS and not (math.isfinite(lim) and math.isfinite(v)):
            if math.isinf(lim) and lim > 0 and math.isfinite(v):  # a reducer at rest
                note = "no wear: the reducer does not turn or carries no torque"
                checks.append(Check(name, v, lim, 1.0, True, CHECK_NAMES[name], note))
                continue
            if math.isfinite(lim):  # a rating, but no load computed (the tilting moment)
                note = "not checked: the load was not computed"
            else:
                source = drives.drives[c].reducer.source if drives is not None else ""
                note = reducer_life.not_checked_note(name, source)
            checks.append(Check(name, v, lim, math.nan, True, CHECK_NAMES[name], note, False))
            continue
        if math.isnan(lim) and name in _NOT_CHECKED:
            note, part = _NOT_CHECKED[name]
            src = getattr(getattr(drives.drives[c], part), "source", "") if drives else ""
            note += f" ({src or 'no source given'})"
            checks.append(Check(name, v, lim, math.nan, True, CHECK_NAMES[name], note, False))
            continue
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
    """The check with the smallest margin (the one that binds, or fails worst); checks that
    could not be made (``checked`` false) are not candidates."""
    made = [ch for ch in checks if ch.checked] or checks
    return min(made, key=lambda ch: ch.margin)


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
