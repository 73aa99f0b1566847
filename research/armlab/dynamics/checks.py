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
for regeneration), all from :mod:`armlab.robot.drivetrain`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from armlab.dynamics import reducer_life
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
    **reducer_life.REDUCER_CHECKS,
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
            "value": float(self.value) if math.isfinite(self.value) else None,
            "limit": float(self.limit) if math.isfinite(self.limit) else None,
            "margin": float(self.margin) if math.isfinite(self.margin) else None,
            "ok": bool(self.ok),
            "unit": self.unit,
            "note": self.note,
        }

    @property
    def checked(self) -> bool:
        """False for a check the part has no rating for (``not checked: no rating``)."""
        return math.isfinite(self.value) and math.isfinite(self.limit)

    def describe(self) -> str:
        """One line: ``motor_speed 2390 > 2200 rad/s (margin -8.6 %)`` or the check's note."""
        if not self.checked:
            return f"{self.name} ({self.note})"
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
    """

    controller: ControllerProfile
    tool_resolution_m: float = 1e-4
    required_life_h: float = reducer_life.DEFAULT_REQUIRED_LIFE_H
    momentary_load: str = "plan"

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
    tau, qd, qdd, weights, drives: DriveTrain, lever_m, options: SizingOptions, tilt_Nm=None
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
    t_env = drivetrain.envelope_torque(w_m, drives)
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
    return {
        name: (
            np.broadcast_to(np.asarray(v, float), (n_col,)),
            np.broadcast_to(np.asarray(lim, float), (n_col,)),
        )
        for name, (v, lim) in out.items()
    }


def checks_for_column(
    results: dict[str, tuple[np.ndarray, np.ndarray]],
    c: int,
    rtol: float = 1e-9,
    drives: DriveTrain | None = None,
) -> list[Check]:
    """The :class:`Check` list of column ``c`` of :func:`evaluate_checks`'s output.

    A check of :data:`armlab.dynamics.reducer_life.REDUCER_CHECKS` whose rating is not given
    stays in the list, passing, with the note ``not checked: no rating (<field>; <source>)``
    (``drives``: the columns' drives, for the reducer's source); any other check without a
    limit is left out (nothing to check)."""
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
            checks.append(Check(name, v, lim, math.inf, True, CHECK_NAMES[name], note))
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
