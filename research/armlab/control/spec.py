"""What a tuned joint cascade must meet (:class:`TuningSpec`) and where the controller's share
of it comes from (:func:`controller_spec`)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from armlab.errors import SpecError
from armlab.robot.controller import ControllerProfile

__all__ = ["TuningSpec", "controller_spec"]


@dataclass
class TuningSpec:
    """What the tuned cascade must meet.

    Attributes
    ----------
    position_bandwidth_rad_s : float or None
        Target crossover of the position loop in [rad/s] (nominal inertia); None: the highest
        the margins and separations allow.
    rise_time_s : float or None
        Alternative to the bandwidth: 10-90 % rise time of the position loop in [s]
        (``w_c = 2.2 / t_r``, first-order approximation).
    phase_margin_deg : float
        Minimum phase margin, every loop, every inertia, continuous and discrete (0 < pm < 90).
    gain_margin_dB : float
        Minimum gain margin (> 0).
    overshoot_pct : float
        Position-loop step overshoot limit in [%].
    inner_overshoot_pct : float or None
        Optional limit for the current and speed loops' step overshoot (PI loops overshoot by
        design, ~20-50 %; the position loop filters it).
    separation_current_speed, separation_speed_position : float
        Minimum crossover ratios (>= 1).
    current_sample_time_s, speed_sample_time_s, position_sample_time_s : float
        Loop periods in [s] (defaults: 20 kHz amplifier, 1 kHz card).
    delay_samples : int
        Computation delay in samples (1: output written at the next sample).
    method : {"tustin", "backward", "zoh"}
        Integral discretisation of the incremental PID.
    da_range_V, da_bits : float, int
        D/A of the card (+-10 V, 12 bit).
    n_inertia_samples, seed : int
        Workspace samples for the inertia range.
    compliant : bool
        Tune on the two-mass joint (reducer stiffness K1, :mod:`armlab.control.plant`) where
        the drive gives one; default False (the rigid joint of the thesis).
    """

    position_bandwidth_rad_s: float | None = None
    rise_time_s: float | None = None
    phase_margin_deg: float = 50.0
    gain_margin_dB: float = 6.0
    overshoot_pct: float = 5.0
    inner_overshoot_pct: float | None = None
    separation_current_speed: float = 5.0
    separation_speed_position: float = 4.0
    current_sample_time_s: float = 5e-5
    speed_sample_time_s: float = 1e-3
    position_sample_time_s: float = 1e-3
    delay_samples: int = 1
    method: str = "tustin"
    da_range_V: float = 10.0
    da_bits: int = 12
    n_inertia_samples: int = 400
    seed: int = 0
    compliant: bool = False

    def validate(self, joint: str = "") -> TuningSpec:
        """Raise :class:`SpecError` naming the joint and the spec if anything is impossible."""
        who = f"{joint}: " if joint else ""

        def bad(name, why):
            raise SpecError(f"{who}spec {name}={getattr(self, name)!r} {why}")

        if not (0.0 < self.phase_margin_deg < 90.0):
            bad("phase_margin_deg", "must be in (0, 90) deg")
        if not (self.gain_margin_dB > 0.0 and math.isfinite(self.gain_margin_dB)):
            bad("gain_margin_dB", "must be a finite number > 0 dB")
        if not (self.overshoot_pct >= 0.0):
            bad("overshoot_pct", "must be >= 0 %")
        if self.inner_overshoot_pct is not None and not self.inner_overshoot_pct >= 0.0:
            bad("inner_overshoot_pct", "must be >= 0 %")
        for name in ("separation_current_speed", "separation_speed_position"):
            if not (getattr(self, name) >= 1.0 and math.isfinite(getattr(self, name))):
                bad(name, "must be a finite ratio >= 1")
        for name in ("current_sample_time_s", "speed_sample_time_s", "position_sample_time_s"):
            if not (getattr(self, name) > 0.0 and math.isfinite(getattr(self, name))):
                bad(name, "must be > 0 s")
        if abs(self.position_sample_time_s - self.speed_sample_time_s) > 1e-12:
            bad("position_sample_time_s", "must equal speed_sample_time_s (same interrupt)")
        if self.position_bandwidth_rad_s is not None and self.rise_time_s is not None:
            bad("rise_time_s", "cannot be given together with position_bandwidth_rad_s")
        if self.position_bandwidth_rad_s is not None and not (
            self.position_bandwidth_rad_s > 0 and math.isfinite(self.position_bandwidth_rad_s)
        ):
            bad("position_bandwidth_rad_s", "must be a finite number > 0 rad/s")
        if self.rise_time_s is not None and not (
            self.rise_time_s > 0 and math.isfinite(self.rise_time_s)
        ):
            bad("rise_time_s", "must be > 0 s")
        if int(self.delay_samples) != self.delay_samples or self.delay_samples < 0:
            bad("delay_samples", "must be a whole number >= 0")
        if self.method not in ("tustin", "backward", "zoh"):
            bad("method", "must be tustin, backward or zoh")
        return self

    @property
    def target_bandwidth_rad_s(self) -> float | None:
        if self.position_bandwidth_rad_s is not None:
            return float(self.position_bandwidth_rad_s)
        if self.rise_time_s is not None:
            return 2.2 / float(self.rise_time_s)
        return None

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_kwargs(cls, joint: str = "", **spec) -> TuningSpec:
        names = set(cls.__dataclass_fields__)
        unknown = sorted(set(spec) - names)
        if unknown:
            raise SpecError(
                f"{joint + ': ' if joint else ''}unknown tuning spec "
                f"{', '.join(unknown)} (known: {', '.join(sorted(names))})"
            )
        return cls(**spec).validate(joint)


def controller_spec(controller: ControllerProfile, spec: dict) -> dict:
    """``spec`` with the controller's servo period (speed and position loops) and D/A.

    The controller profile is the one home of the servo period and the D/A converter: a spec
    that names another value for them is refused (:class:`SpecError`), so the gains are tuned
    and discretised for the controller the tables are written for.
    """
    from_profile = {
        "speed_sample_time_s": controller.servo_period_s,
        "position_sample_time_s": controller.servo_period_s,
        "da_range_V": controller.dac_range_V,
        "da_bits": int(controller.dac_bits),
    }
    out = dict(spec)
    for key, value in from_profile.items():
        given = out.get(key)
        if given is not None and not math.isclose(float(given), float(value), rel_tol=1e-12):
            raise SpecError(
                f"{key}={given} differs from controller profile {controller.name!r} "
                f"({value}): set it in the controller profile ([controller] in a study)"
            )
        out[key] = value
    return out
