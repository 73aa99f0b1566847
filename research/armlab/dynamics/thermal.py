r"""Winding temperature over a repeated duty cycle: the two-body thermal model of a motor.

The motor makers' thermal check (maxon, "Key information" of the data sheets: thermal resistance
winding-housing ``R_th1`` and housing-ambient ``R_th2``, thermal time constants of the winding
``tau_w`` and of the motor ``tau_m``, maximum winding temperature) is a two-body model: the
winding (heat capacity ``C_w``) and the housing with stator (``C_h``), coupled through ``R_th1``,
the housing to the ambient through ``R_th2``::

    C_w dT_w/dt = P(t) - (T_w - T_h) / R_th1
    C_h dT_h/dt = (T_w - T_h) / R_th1 - (T_h - T_a) / R_th2

with ``C_w = tau_w / R_th1`` and ``C_h = tau_m / R_th2`` (the makers' time constants read as the
time constants of each body alone, maxon's convention). The loss is the copper loss
``P = I^2 R(T_w)``, ``I = |T_m| / Kt`` from the motor torque of the drive-train model
(:func:`armlab.robot.drivetrain.motor_torque`: friction, efficiency by quadrant and reflected
inertia included), with the copper resistance rising with the winding temperature::

    R(T_w) = R_25 (1 + alpha_Cu (T_w - 25 degC)),     alpha_Cu = 0.00393 / K

(the resistance of the drives file is the data sheet's terminal resistance at 25 degC, maxon's
reference: ASSUMED for every motor; alpha_Cu of annealed copper). Iron and friction losses in
the motor are not heat sources here (the copper loss dominates at the low speeds of a reduced
joint), and ``Kt`` is held constant (its drop with the magnet temperature is neglected).

The duty cycle
--------------
Each sample of the cycle stands for its trapezoidal weight (:func:`~armlab.trajectory.sampling.
sample_weights`) at a constant current, as the RMS does; a dwell (``[sizing] dwell_s``) is the
arm at rest at the cycle's **last pose** (the end of its motion) for ``dwell_s`` before the
cycle repeats
(:func:`with_dwell`: every planner ends at rest there, while a plan through its waypoints need
not stop at them), the motor then giving the holding torque.

The cycle is repeated: with ``P`` affine in ``T_w`` the model is linear, so one pass of the
cycle is an affine map ``x -> Phi x + c`` of the temperature rises ``x = (T_w - T_a, T_h -
T_a)``. ``cycles`` = None (default) takes its fixed point ``x* = (I - Phi)^-1 c``: the
**periodic** state of the cycle repeated for ever (exact, no tolerance), which is what the RMS
check stands for without a dwell; ``cycles = n`` starts at ambient and runs ``n`` cycles. The
check is the peak winding temperature within the (last) cycle against the maximum. When the
copper loss grows with temperature faster than the motor sheds it (the fixed point does not
attract: an eigenvalue of ``Phi`` >= 1) the temperature runs away: infinite.

Integration: the trapezoidal rule (Crank-Nicolson, A-stable, second order) on steps of about
``tau_w / 50`` (each motor's own winding time constant, so a motor's figure does not depend on
the motors checked with it): longer
sample intervals (a dwell) split into equal steps, shorter ones merged with the time-weighted
mean of ``I^2`` (the winding cannot follow faster; the copper energy is kept exactly). The peak
is taken at the step ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from armlab.errors import InputError
from armlab.trajectory import Trajectory

__all__ = [
    "ALPHA_CU_PER_K",
    "RESISTANCE_REFERENCE_DEGC",
    "AMBIENT_DEGC",
    "ThermalModel",
    "ThermalResult",
    "winding_temperature",
    "with_dwell",
]

#: temperature coefficient of copper's resistance [1/K] (annealed copper, 20-25 degC)
ALPHA_CU_PER_K = 0.00393
#: temperature at which a data sheet states the terminal resistance [degC] (maxon: 25 degC)
RESISTANCE_REFERENCE_DEGC = 25.0
#: ambient temperature of the check unless the study sets one [degC]: ASSUMED, the makers'
#: rating condition (maxon rates at 25 degC ambient)
AMBIENT_DEGC = 25.0
#: the longest integration step, as a share of the winding time constant
_STEP_SHARE = 1.0 / 50.0
#: integration steps whose maps are built at once
_CHUNK = 512


@dataclass(frozen=True)
class ThermalModel:
    """The thermal data of motors as arrays ``(n_columns,)`` (one column per drive), SI.

    Attributes
    ----------
    r_wh_K_W, r_ha_K_W : thermal resistance winding-housing and housing-ambient [K/W]
    tau_w_s, tau_m_s : thermal time constants of the winding and of the motor [s]
    max_winding_degC : maximum permissible winding temperature [degC]
    resistance_ohm : terminal resistance at 25 degC [ohm]
    torque_constant_Nm_A : Kt [N m/A]
    """

    r_wh_K_W: np.ndarray
    r_ha_K_W: np.ndarray
    tau_w_s: np.ndarray
    tau_m_s: np.ndarray
    max_winding_degC: np.ndarray
    resistance_ohm: np.ndarray
    torque_constant_Nm_A: np.ndarray

    @classmethod
    def from_drives(cls, drives) -> ThermalModel:
        """The model of each :class:`~armlab.robot.drives.Drive`'s motor (NaN where its data
        sheet gives no thermal data)."""

        def arr(name):
            return np.array([float(getattr(d.motor, name)) for d in drives])

        return cls(
            r_wh_K_W=arr("thermal_resistance_winding_housing_K_W"),
            r_ha_K_W=arr("thermal_resistance_housing_ambient_K_W"),
            tau_w_s=arr("thermal_time_constant_winding_s"),
            tau_m_s=arr("thermal_time_constant_motor_s"),
            max_winding_degC=arr("max_winding_temperature_degC"),
            resistance_ohm=arr("resistance_ohm"),
            torque_constant_Nm_A=arr("torque_constant_Nm_A"),
        )

    @property
    def given(self) -> np.ndarray:
        """True where the motor's data sheet gives every thermal value the check needs."""
        vals = (self.r_wh_K_W, self.r_ha_K_W, self.tau_w_s, self.tau_m_s, self.max_winding_degC)
        return np.logical_and.reduce([np.isfinite(v) & (v > 0) for v in vals])


@dataclass(frozen=True)
class ThermalResult:
    """Winding and housing temperatures of each column over the (last) cycle.

    Attributes
    ----------
    peak_winding_degC : array (n_columns,)
        Highest winding temperature within the cycle [degC] (NaN: no thermal data; inf:
        thermal runaway).
    end_housing_degC : array (n_columns,)
        Housing temperature at the end of the cycle [degC].
    ambient_degC : float
    cycles : int or None
        Cycles run from ambient; None: the periodic state.
    """

    peak_winding_degC: np.ndarray
    end_housing_degC: np.ndarray
    ambient_degC: float
    cycles: int | None


def with_dwell(trajectories: list[Trajectory], dwell_s: float) -> list[Trajectory]:
    """The duty cycle with a dwell: the arm at rest for ``dwell_s`` [s] at the last pose of the
    cycle's motion (a two-sample trajectory ``t = 0, dwell_s`` with zero speed: its trapezoidal
    weights sum to the dwell), inserted after the last trajectory that moves (several samples);
    held poses after it (a selection's single-sample holds at the worst static poses) stay
    after the dwell. ``dwell_s = 0``: the trajectories unchanged."""
    dwell_s = float(dwell_s)
    if not math.isfinite(dwell_s) or dwell_s < 0:
        raise InputError(f"sizing.dwell_s: {dwell_s!r} is not a time >= 0 s")
    trajs = list(trajectories)
    if dwell_s == 0.0 or not trajs:
        return trajs
    moving = [k for k, tr in enumerate(trajs) if tr.n_samples > 1]
    k = moving[-1] if moving else len(trajs) - 1
    q = np.repeat(trajs[k].q[-1:], 2, axis=0)
    zero = np.zeros_like(q)
    hold = Trajectory(np.array([0.0, dwell_s]), q, zero, zero, method=f"dwell {dwell_s:g} s")
    return [*trajs[: k + 1], hold, *trajs[k + 1 :]]


def _steps(weights: np.ndarray, current_sq: np.ndarray, h_max: float):
    """Integration steps of at most about ``h_max``: sample intervals (their weights) longer
    than ``h_max`` split into equal steps, shorter ones merged into blocks whose midpoints fall
    in one ``h_max`` window, with the time-weighted mean of the current squared (the copper
    energy of the block kept exactly). Returns ``(h (n_steps,), current squared (n_steps,
    n_columns))``."""
    n_sub = np.maximum(1, np.ceil(weights / h_max).astype(int))
    h, i2 = weights, current_sq
    if np.any(n_sub > 1):  # split the long intervals (index arrays: no copy of the rest)
        h = np.repeat(weights / n_sub, n_sub)
        i2 = current_sq[np.repeat(np.arange(weights.size), n_sub)]
    if not np.all(h > 0.0):
        keep = h > 0.0
        h, i2 = h[keep], i2[keep]
    if h.size == 0:
        return h, i2
    bucket = np.floor((np.cumsum(h) - 0.5 * h) / h_max).astype(np.int64)
    starts = np.flatnonzero(np.diff(bucket, prepend=bucket[0] - 1))
    h_b = np.add.reduceat(h, starts)
    e_b = np.add.reduceat(h[:, None] * i2, starts, axis=0)
    return h_b, e_b / h_b[:, None]


def _step_maps(h, i2, m: ThermalModel, ambient: float):
    """The trapezoidal (Crank-Nicolson) step of the two-body model as affine maps of the
    temperature rises, ``x1 = P x0 + q``, for every step at once: ``(P11, P12, P21, P22, q1,
    q2)``, each (n_steps, n_columns); ``h`` (n_steps,) [s], ``i2`` current squared [A^2]."""
    c_w = m.tau_w_s / m.r_wh_K_W
    c_h = m.tau_m_s / m.r_ha_K_W
    g1, g2 = 1.0 / m.r_wh_K_W, 1.0 / m.r_ha_K_W
    r0 = m.resistance_ohm * (1.0 + ALPHA_CU_PER_K * (ambient - RESISTANCE_REFERENCE_DEGC))
    p0 = i2 * r0  # loss at the ambient temperature [W]
    p1 = i2 * m.resistance_ohm * ALPHA_CU_PER_K  # its rise per kelvin of the winding [W/K]
    # x' = A x + b
    a11, a12 = (p1 - g1) / c_w, g1 / c_w
    a21, a22 = g1 / c_h, -(g1 + g2) / c_h
    b1 = p0 / c_w
    k = 0.5 * np.asarray(h, float)[:, None]
    # (I - k A) x1 = (I + k A) x0 + 2 k b
    m11, m12, m21, m22 = 1.0 - k * a11, -k * a12, -k * a21, 1.0 - k * a22
    det = m11 * m22 - m12 * m21
    n11, n12, n21, n22 = 1.0 + k * a11, k * a12, k * a21, 1.0 + k * a22
    P11 = (m22 * n11 - m12 * n21) / det
    P12 = (m22 * n12 - m12 * n22) / det
    P21 = (m11 * n21 - m21 * n11) / det
    P22 = (m11 * n22 - m21 * n12) / det
    q1 = m22 * (2.0 * k * b1) / det
    q2 = -m21 * (2.0 * k * b1) / det
    return P11, P12, P21, P22, q1, q2


def _cycle(x_w, x_h, h, i2s, m: ThermalModel, ambient: float):
    """Run the temperature rises ``x_w, x_h`` (k, n_columns) through the steps; returns the
    end state and the highest winding rise of the first start on the way (start included).
    The step maps are built a chunk of steps at a time (memory stays small for many columns)."""
    top = x_w[0].copy()
    for start in range(0, h.size, _CHUNK):
        P11, P12, P21, P22, q1, q2 = _step_maps(
            h[start : start + _CHUNK], i2s[start : start + _CHUNK], m, ambient
        )
        for k in range(P11.shape[0]):
            x_w, x_h = P11[k] * x_w + P12[k] * x_h + q1[k], P21[k] * x_w + P22[k] * x_h + q2[k]
            top = np.maximum(top, x_w[0])
    return x_w, x_h, top


def winding_temperature(
    motor_torque_Nm,
    weights,
    model: ThermalModel,
    *,
    ambient_degC: float = AMBIENT_DEGC,
    cycles: int | None = None,
) -> ThermalResult:
    """Peak winding temperature of each motor over its duty cycle repeated (module docstring).

    Parameters
    ----------
    motor_torque_Nm : array (n_samples, n_columns)
        Motor torque along the cycle [N m] (a dwell included: :func:`with_dwell`).
    weights : array (n_samples,)
        Time each sample stands for [s].
    model : ThermalModel
    ambient_degC : float
        Ambient temperature [degC].
    cycles : int, optional
        Cycles run from ambient; None: the periodic state of the cycle repeated for ever.

    Returns
    -------
    ThermalResult
        NaN for the columns without thermal data.
    """
    t_m = np.atleast_2d(np.asarray(motor_torque_Nm, float))
    w = np.asarray(weights, float).reshape(-1)
    n_col = t_m.shape[1]
    ok = model.given & np.isfinite(model.resistance_ohm)
    peak = np.full(n_col, np.nan)
    housing = np.full(n_col, np.nan)
    if not ok.any():
        return ThermalResult(peak, housing, float(ambient_degC), cycles)
    # one step grid per winding time constant: a motor's temperature does not depend on which
    # other motors are checked with it (a selection's batch, a study's six drives)
    taus = np.asarray(model.tau_w_s, float)
    for tau in np.unique(taus[ok]):
        cols = ok & (taus == tau)
        peak[cols], housing[cols] = _periodic(t_m[:, cols], w, model, cols, ambient_degC, cycles)
    return ThermalResult(peak, housing, float(ambient_degC), cycles)


def _periodic(t_m, w, model: ThermalModel, cols, ambient_degC: float, cycles: int | None):
    """(peak winding, end housing) temperatures [degC] of the columns ``cols`` of ``model``,
    which share one winding time constant (:func:`winding_temperature`)."""
    sub = ThermalModel(**{k: np.asarray(v)[cols] for k, v in vars(model).items()})
    i2 = (t_m / sub.torque_constant_Nm_A) ** 2
    h, i2s = _steps(w, i2, _STEP_SHARE * float(sub.tau_w_s.min()))
    # one pass from three starts (0, e_w, e_h) gives the affine cycle map x -> Phi x + c
    x_w = np.zeros((3, sub.tau_w_s.size))
    x_h = np.zeros_like(x_w)
    x_w[1], x_h[2] = 1.0, 1.0
    x_w, x_h, _ = _cycle(x_w, x_h, h, i2s, sub, ambient_degC)
    c_w, c_h = x_w[0], x_h[0]
    f11, f21 = x_w[1] - c_w, x_h[1] - c_h
    f12, f22 = x_w[2] - c_w, x_h[2] - c_h
    if cycles is None:
        # periodic state: x = Phi x + c
        det = (1.0 - f11) * (1.0 - f22) - f12 * f21
        s_w = ((1.0 - f22) * c_w + f12 * c_h) / det
        s_h = ((1.0 - f11) * c_h + f21 * c_w) / det
        # the fixed point attracts iff both eigenvalues of Phi lie inside the unit circle
        tr, dp = f11 + f22, f11 * f22 - f12 * f21
        stable = (np.abs(dp) < 1.0) & (np.abs(tr) < 1.0 + dp)
    else:
        s_w, s_h = np.zeros_like(c_w), np.zeros_like(c_h)
        for _ in range(int(cycles) - 1):
            s_w, s_h = f11 * s_w + f12 * s_h + c_w, f21 * s_w + f22 * s_h + c_h
        stable = np.ones(c_w.size, bool)
    # the (last) cycle from its start state, its peak winding temperature
    x_w, x_h, top = _cycle(s_w[None, :], s_h[None, :], h, i2s, sub, ambient_degC)
    return (
        np.where(stable, ambient_degC + top, np.inf),
        np.where(stable, ambient_degC + x_h[0], np.inf),
    )
