r"""Braking energy of a duty cycle: where the energy of braking goes (bus capacitor, resistor).

While the load drives the motor (braking: ``T_m w_m < 0``) the motor is a generator. The
power it returns to the amplifier's bus is the mechanical power it absorbs less its copper
loss::

    P_reg = max(0, -(T_m w_m) - I^2 R),     I = |T_m| / Kt

``T_m`` is the electromagnetic torque of the drive-train model
(:func:`armlab.robot.drivetrain.motor_torque`): the reducer's losses (back-driven efficiency),
the joint and motor friction are already inside it, so the friction losses are subtracted
there; ``R`` is the terminal resistance at 25 degC (the cold, smallest value: the most energy
returned, conservative). Iron losses and the amplifier's own losses are not counted
(conservative too).

A servo amplifier (:class:`armlab.robot.drives.Amplifier`) that regenerates takes each braking
stretch (samples in a row with ``P_reg > 0``) into its bus capacitor, from the bus voltage up to
the brake threshold, ``E_C = C (U_max^2 - U_bus^2) / 2``; what a stretch returns beyond that
goes to the brake resistor (the common servo-sizing procedure, e.g. the drive makers'
regeneration calculations). Each joint has its own amplifier and bus (ASSUMED: no shared DC
bus, which would let one joint's braking feed another's motoring -- conservative). The checks
(:func:`armlab.dynamics.checks.evaluate_checks`):

* ``bus_capacitor_energy`` (an amplifier that regenerates and has no brake resistor): the
  largest stretch's energy <= ``E_C``;
* ``brake_resistor_power``: the energy beyond ``E_C`` of every stretch per cycle time (with its
  dwell) <= the resistor's continuous power;
* ``brake_resistor_peak_power``: peak ``P_reg`` <= ``U_max^2 / R_brake``, what the resistor
  sinks at the threshold voltage.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Regeneration", "regeneration"]


@dataclass(frozen=True)
class Regeneration:
    """Braking of each column over a duty cycle, arrays ``(n_columns,)``.

    Attributes
    ----------
    peak_power_W : peak regenerated power [W]
    energy_J : energy returned over the cycle [J]
    largest_stretch_J : energy of the largest braking stretch [J]
    """

    peak_power_W: np.ndarray
    energy_J: np.ndarray
    largest_stretch_J: np.ndarray

    def beyond_J(self, stretch_energies: list[np.ndarray], capacity_J: np.ndarray) -> np.ndarray:
        """Energy per cycle beyond ``capacity_J`` of each stretch (what the resistor takes)."""
        return np.array(
            [
                float(np.maximum(e - c, 0.0).sum())
                for e, c in zip(stretch_energies, capacity_J, strict=True)
            ]
        )


def regenerated_power_W(t_m, w_m, resistance_ohm, torque_constant_Nm_A) -> np.ndarray:
    """``max(0, -(T_m w_m) - (T_m / Kt)^2 R)`` per sample [W] (module docstring)."""
    t_m, w_m = np.asarray(t_m, float), np.asarray(w_m, float)
    copper = (t_m / torque_constant_Nm_A) ** 2 * resistance_ohm
    return np.maximum(-(t_m * w_m) - copper, 0.0)


def stretch_energies_J(p_reg, weights) -> list[np.ndarray]:
    """Energy of each braking stretch (samples in a row with ``P_reg > 0``) of each column:
    one array per column [J]."""
    p = np.atleast_2d(np.asarray(p_reg, float))
    w = np.asarray(weights, float).reshape(-1)
    out: list[np.ndarray] = []
    for c in range(p.shape[1]):
        on = p[:, c] > 0.0
        if not on.any():
            out.append(np.zeros(0))
            continue
        starts = on & ~np.concatenate([[False], on[:-1]])
        ids = np.cumsum(starts) - 1
        out.append(np.bincount(ids[on], weights=(p[:, c] * w)[on]).astype(float))
    return out


def regeneration(
    t_m, w_m, weights, resistance_ohm, torque_constant_Nm_A
) -> tuple[Regeneration, list[np.ndarray]]:
    """The braking figures of a cycle and the energies of its stretches (one array per
    column). ``t_m``, ``w_m`` (n_samples, n_columns) motor torque [N m] and speed [rad/s];
    ``weights`` (n_samples,) [s]; ``resistance_ohm``, ``torque_constant_Nm_A`` (n_columns,)."""
    p = regenerated_power_W(t_m, w_m, resistance_ohm, torque_constant_Nm_A)
    stretches = stretch_energies_J(p, weights)
    w = np.asarray(weights, float).reshape(-1, 1)
    res = Regeneration(
        peak_power_W=p.max(axis=0) if p.size else np.zeros(p.shape[1]),
        energy_J=(p * w).sum(axis=0),
        largest_stretch_J=np.array([float(e.max()) if e.size else 0.0 for e in stretches]),
    )
    return res, stretches
