"""The result of a tracking simulation (:func:`armlab.control.simulate.simulate_tracking`) and
the positioning budget it is judged against.

Positioning accuracy: the thesis' Monte-Carlo accuracy analysis (HEU thesis, ch. 3) concludes
that about 1 mm total is achievable; the servo is given half of that budget
(:data:`SERVO_SHARE`), the rest being geometric errors, reducer backlash and compliance. A
tracking simulation passes when its TCP error stays within 0.5 mm along the whole motion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["TrackingResult", "POSITIONING_ACCURACY_M", "SERVO_SHARE"]

#: Total positioning accuracy the thesis' Monte-Carlo analysis finds achievable, in [m].
POSITIONING_ACCURACY_M = 1.0e-3
#: Share of that budget given to the servo tracking error.
SERVO_SHARE = 0.5


@dataclass
class TrackingResult:
    """Result of :func:`simulate_tracking`.

    Attributes
    ----------
    t : ndarray (n_samples,)
        Servo sample times in [s].
    q_ref, q : ndarray (n_samples, n_joints)
        Set-point and simulated joint positions in [rad].
    qd : ndarray (n_samples, n_joints)
        Simulated joint speeds in [rad/s].
    current_A : ndarray (n_samples, n_joints)
        Mean motor current over each servo period in [A].
    da_V : ndarray (n_samples, n_joints)
        D/A output (current set-point) in [V].
    tcp_error_m : ndarray (n_samples,)
        Distance between the tool positions of ``q`` and ``q_ref`` in [m].
    joint_names : list of str
    feedforward : tuple of str
    accuracy_m : float
        Tolerance on the TCP error in [m] (servo share of the positioning accuracy).
    wall_time_s : float
        Time the simulation loop took in [s].
    voltage_V : ndarray (n_samples, n_joints)
        Mean armature voltage the amplifier applied over each servo period in [V].
    saturated_share : ndarray (n_samples, n_joints)
        Share of each servo period the amplifier spent at its voltage limit (0..1).
    peak_voltage_demand_V : ndarray (n_joints,)
        Largest |voltage| the current loop asked for (before the supply limit) in [V].
    peak_current_A : ndarray (n_joints,)
        Largest |current| at any current-loop sample in [A].
    supply_voltage_V : ndarray (n_joints,)
        The amplifier's supply (voltage limit) per joint in [V].
    model : dict
        What the simulation included (``voltage_limit``, ``losses``, ``quantise``, the
        controller profile, periods).
    """

    t: np.ndarray
    q_ref: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    current_A: np.ndarray
    da_V: np.ndarray
    tcp_error_m: np.ndarray
    joint_names: list
    feedforward: tuple
    accuracy_m: float
    wall_time_s: float = math.nan
    meta: dict = field(default_factory=dict)
    voltage_V: np.ndarray | None = None
    saturated_share: np.ndarray | None = None
    peak_voltage_demand_V: np.ndarray | None = None
    peak_current_A: np.ndarray | None = None
    supply_voltage_V: np.ndarray | None = None
    model: dict = field(default_factory=dict)

    @property
    def error_rad(self) -> np.ndarray:
        """``q_ref - q`` (n_samples, n_joints) in [rad]."""
        return self.q_ref - self.q

    @property
    def max_error_rad(self) -> np.ndarray:
        """Per-joint max |error| (n_joints,) in [rad]."""
        return np.abs(self.error_rad).max(axis=0)

    @property
    def tcp_max_error_m(self) -> float:
        return float(self.tcp_error_m.max())

    @property
    def final_error_rad(self) -> np.ndarray:
        return self.error_rad[-1]

    @property
    def within_accuracy(self) -> bool:
        """True if the TCP error stays within :attr:`accuracy_m` the whole time."""
        return self.tcp_max_error_m <= self.accuracy_m

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return float((self.t[-1] - self.t[0]) / self.wall_time_s)

    @property
    def sample_time_s(self) -> float:
        return float(self.t[1] - self.t[0]) if self.t.size > 1 else math.nan

    @property
    def saturation_time_s(self) -> np.ndarray:
        """Time each joint's amplifier spent at its voltage limit, (n_joints,) in [s]."""
        if self.saturated_share is None:
            return np.zeros(len(self.joint_names))
        return self.saturated_share.sum(axis=0) * self.sample_time_s

    @property
    def peak_voltage_V(self) -> np.ndarray:
        """Largest |mean armature voltage| over a servo period, (n_joints,) in [V]."""
        if self.voltage_V is None:
            return np.full(len(self.joint_names), math.nan)
        return np.abs(self.voltage_V).max(axis=0)

    def to_dict(self) -> dict:
        """summary.json "tracking": per joint max_error_rad, peak voltage and current, time in
        saturation; tcp max_error_m (+ context)."""
        n = len(self.joint_names)

        def per(x, k):
            return float(x[k]) if x is not None else None

        sat = self.saturation_time_s
        dur = float(self.t[-1] - self.t[0]) if self.t.size > 1 else math.nan
        joints = {}
        for k, name in enumerate(self.joint_names):
            joints[name] = {
                "max_error_rad": float(self.max_error_rad[k]),
                "final_error_rad": float(self.final_error_rad[k]),
                "peak_voltage_V": per(self.peak_voltage_V, k),
                "peak_voltage_demand_V": per(self.peak_voltage_demand_V, k),
                "supply_voltage_V": per(self.supply_voltage_V, k),
                "peak_current_A": per(self.peak_current_A, k),
                "time_in_saturation_s": float(sat[k]),
                "saturation_share": float(sat[k] / dur) if dur > 0 else 0.0,
            }
        assert len(joints) == n
        return {
            "joints": joints,
            "tcp": {
                "max_error_m": self.tcp_max_error_m,
                "final_error_m": float(self.tcp_error_m[-1]),
                "accuracy_m": self.accuracy_m,
                "within_accuracy": self.within_accuracy,
            },
            "feedforward": list(self.feedforward),
            "duration_s": dur,
            "sample_time_s": self.sample_time_s,
            "quantise": bool(self.meta.get("quantise", True)),
            "model": dict(self.model),
        }
