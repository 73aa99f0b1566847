"""Drive trains: motor, reducer, encoder and amplifier of each joint, and the drive that
answers every question about them (drives files: :mod:`armlab.robot.drives_file`).

SI inside; the only non-SI fields are named with their unit (``rated_speed_rpm``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

__all__ = [
    "Motor",
    "Reducer",
    "Encoder",
    "Amplifier",
    "Drive",
    "RPM_TO_RAD_S",
    "available_torque_Nm",
    "QUADRANT_BAND_SHARE",
]

RPM_TO_RAD_S = 2.0 * math.pi / 60.0

#: share of the joint speed limit over which the reducer passes from motoring to back-driven
#: efficiency through standstill (ASSUMED: :attr:`Drive.quadrant_band_rad_s`)
QUADRANT_BAND_SHARE = 0.01


def available_torque_Nm(stall_torque_Nm, ratio, efficiency, derating=1.0) -> Any:
    """Thesis rule (table 4.3): available joint torque = stall torque x ratio x efficiency
    x derating, in [N m]. Scalars or numpy arrays (one value per joint); the result is a float
    or an array accordingly (hence ``Any``).

    It is the drive-train model (:mod:`armlab.robot.drivetrain`) at rest in the motoring
    quadrant: holding a load counts as motoring (power would flow motor -> load), so the joint
    torque a motor torque ``T`` delivers at ``qd = qdd = 0`` is ``T x ratio x efficiency``
    (joint Coulomb friction is not counted at rest with no acceleration; reflected inertia and
    viscous terms vanish), with ``T`` the derated stall torque."""
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
    thermal_resistance_winding_housing_K_W, thermal_resistance_housing_ambient_K_W : float
        Thermal resistances winding-housing ``R_th1`` and housing-ambient ``R_th2`` in [K/W]
        (maxon data sheets, "thermal data"); NaN: not given.
    thermal_time_constant_winding_s, thermal_time_constant_motor_s : float
        Thermal time constants of the winding and of the motor in [s]; NaN: not given.
    max_winding_temperature_degC : float
        Maximum permissible winding temperature in [degC]; NaN: not given. Without these five
        the winding-temperature check (:mod:`armlab.dynamics.thermal`) is "not checked".
    integrated : str
        Model of the integrated smart servo (motor + gear + controller in one) this motor is
        part of, "" for a motor sold alone: it combines only with the reducer of that servo.
    estimated : tuple of str
        Fields whose value was not read from a published source (the entry's ``source`` says
        why and how it was estimated); selection skips such parts unless the study sets
        ``[sizing] allow_estimated = true``.
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
    thermal_resistance_winding_housing_K_W: float = math.nan
    thermal_resistance_housing_ambient_K_W: float = math.nan
    thermal_time_constant_winding_s: float = math.nan
    thermal_time_constant_motor_s: float = math.nan
    max_winding_temperature_degC: float = math.nan
    integrated: str = ""
    estimated: tuple[str, ...] = ()

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
    at the input shaft (default 0: not given, stated in drives.toml).

    Losses (the drive-train model, :mod:`armlab.robot.drivetrain`, is the one place they are
    used): ``efficiency`` is the motoring efficiency (power flows motor -> load: input torque
    = output torque / (ratio x efficiency)); ``back_efficiency`` the back-driven one (load ->
    motor: input torque = output torque x back_efficiency / ratio), NaN when not given: it is
    then **derived** equal to ``efficiency`` (:attr:`back_driven_efficiency` says so).
    ``coulomb_friction_Nm`` [N m] and ``viscous_friction_Nm_s_rad`` [N m s/rad] are friction at
    the **output** (joint side: reducer and joint bearings), default 0 (not given).
    ``integrated`` and ``estimated``: as :class:`Motor` (the gear of a smart servo; fields not
    read from a published source).

    Attributes
    ----------
    rated_input_speed_rpm : float
        n_r of the life rating: the input speed the rated torque is rated at, in [rpm]
        (Harmonic Drive: 2000); not given: the life is not checked.
    rated_life_h : float
        L_n: life of the wave-generator bearing at the rated torque and n_r, in [h] (L_10:
        7000 h CSF, 10000 h CSG); with ``rated_input_speed_rpm`` the ``reducer_life`` check.
    momentary_torque_Nm : float
        Limit for momentary (emergency stop, collision) output torque, in [N m]: the
        ``reducer_momentary_torque`` check.
    stiffness_Nm_rad : list of float
        Torsional stiffness K1, K2, K3 of the piecewise-linear torque-windup curve at the
        output, in [N m/rad] (Harmonic Drive "Torsional stiffness" table); K1 is the two-mass
        plant's spring. Not given: the joint is rigid.
    stiffness_torque_Nm : list of float
        Breakpoints T1, T2 of that curve (one fewer than ``stiffness_Nm_rad``), in [N m].
    hysteresis_rad : float
        Hysteresis loss: width of the torque-windup loop at zero torque, in [rad] (the compliant
        simulation's hysteresis element).
    bearing_dynamic_load_N : float
        Output (cross-roller) bearing's basic dynamic load rating C, in [N] (recorded; not
        checked yet).
    bearing_moment_rating_Nm : float
        Output bearing's permissible tilting moment M_c, in [N m]: the
        ``reducer_bearing_moment`` check.
    bearing_pitch_diameter_m : float
        Pitch-circle diameter d_p of the output bearing's rolling elements, in [m] (recorded).
    bearing_offset_m : float
        Offset R from the bearing's centre plane to the output flange (the joint frame), in
        [m]: the radial force's lever in the tilting moment (0 when not given).
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
    back_efficiency: float = math.nan
    coulomb_friction_Nm: float = 0.0
    viscous_friction_Nm_s_rad: float = 0.0
    integrated: str = ""
    estimated: tuple[str, ...] = ()
    # --- life, momentary torque, output bearing, torsional stiffness (issue 28; Harmonic Drive
    # CSF/CSG catalogue: rating table, "Life of a wave generator", "Torsional stiffness",
    # cross-roller bearing specifications). NaN / () = not given: the check says "not checked".
    #: n_r of the life rating: the input speed the rated torque is rated at, [rpm] (HD: 2000)
    rated_input_speed_rpm: float = math.nan
    #: L_n: life of the wave-generator bearing at rated torque and n_r, [h] (L_10: 7000 h CSF,
    #: 10000 h CSG)
    rated_life_h: float = math.nan
    #: limit for momentary torque (emergency stop, collision) at the output, [N m]
    momentary_torque_Nm: float = math.nan
    #: torsional stiffness K1, K2, K3 of the piecewise-linear curve at the output, [N m/rad]
    stiffness_Nm_rad: tuple[float, ...] = ()
    #: breakpoints T1, T2 of the stiffness curve (one fewer than stiffness_Nm_rad), [N m]
    stiffness_torque_Nm: tuple[float, ...] = ()
    #: hysteresis loss (width of the torque-windup loop at the output), [rad]
    hysteresis_rad: float = math.nan
    #: output (cross-roller) bearing's basic dynamic load rating C, [N]
    bearing_dynamic_load_N: float = math.nan
    #: output bearing's permissible tilting (moment) load M_c, [N m]
    bearing_moment_rating_Nm: float = math.nan
    #: pitch-circle diameter d_p of the output bearing's rolling elements, [m]
    bearing_pitch_diameter_m: float = math.nan
    #: offset R from the bearing's centre plane to the output flange (the joint frame), [m]
    bearing_offset_m: float = math.nan

    @property
    def max_input_speed_rad_s(self) -> float:
        """Maximum input (motor-side) speed in [rad/s]."""
        return self.max_input_speed_rpm * RPM_TO_RAD_S

    # ------------------------------------------------------------- life and stiffness
    @property
    def life_rated(self) -> bool:
        """True when the catalogue gives the life rating (``rated_life_h``,
        ``rated_input_speed_rpm``) and the rated torque it is rated at."""
        return all(
            math.isfinite(x) and x > 0
            for x in (self.rated_life_h, self.rated_input_speed_rpm, self.rated_torque_Nm)
        )

    def life_h(self, average_torque_Nm: float, average_input_speed_rpm: float) -> float:
        """Life of the wave-generator bearing in [h] (L_10 when ``rated_life_h`` is L_10).

        Harmonic Drive's rule (CSF/CSG catalogue, "Life of a wave generator", equation 8, and
        the selection procedure's "operating life")::

            L_h = L_n (T_r / T_av)^3 (n_r / n_av)

        with ``L_n`` = ``rated_life_h``, ``T_r`` = ``rated_torque_Nm`` (rated at ``n_r`` =
        ``rated_input_speed_rpm``), ``T_av`` the cubic-mean output torque weighted by output
        speed x time over the duty cycle and ``n_av`` the mean input speed (pauses included).
        NaN without the rating (:attr:`life_rated`); inf for a reducer that never turns or
        carries no torque."""
        if not self.life_rated:
            return math.nan
        if average_torque_Nm <= 0 or average_input_speed_rpm <= 0:
            return math.inf
        return (
            self.rated_life_h
            * (self.rated_torque_Nm / average_torque_Nm) ** 3
            * (self.rated_input_speed_rpm / average_input_speed_rpm)
        )

    @property
    def stiffness_given(self) -> bool:
        """True when the catalogue gives the torsional stiffness curve (K1 at least)."""
        return len(self.stiffness_Nm_rad) > 0

    def _segments(self):
        """(breakpoints T_0 = 0, T1, T2, ..., stiffnesses K1, K2, ..., windups at T_i)."""
        t = np.concatenate([[0.0], np.asarray(self.stiffness_torque_Nm, float)])
        k = np.asarray(self.stiffness_Nm_rad, float)
        theta = np.concatenate([[0.0], np.cumsum(np.diff(t) / k[:-1])])
        return t, k, theta

    def torsional_stiffness_Nm_rad(self, torque_Nm) -> Any:
        """Tangent torsional stiffness at the output at a load torque, in [N m/rad]: K1 for
        ``|T| <= T1``, K2 for ``T1 < |T| <= T2``, K3 above (Harmonic Drive catalogue,
        "Torsional stiffness": the torque-windup curve approximated by three straight lines).
        NaN without stiffness data. Scalars or arrays."""
        tq = np.abs(np.asarray(torque_Nm, float))
        if not self.stiffness_given:
            return np.full_like(tq, math.nan) if tq.ndim else math.nan
        t, k, _ = self._segments()
        out = k[np.searchsorted(t[1:], tq, side="left")]
        return out if tq.ndim else float(out)

    def windup_rad(self, torque_Nm) -> Any:
        """Windup (torsion angle) at the output under a load torque, in [rad], odd in the
        torque (Harmonic Drive catalogue, "Torsional stiffness")::

            theta = T / K1                                  |T| <= T1
            theta = T1 / K1 + (|T| - T1) / K2               T1 < |T| <= T2
            theta = T1 / K1 + (T2 - T1) / K2 + (|T| - T2) / K3   |T| > T2

        NaN without stiffness data. Scalars or arrays."""
        tq = np.asarray(torque_Nm, float)
        if not self.stiffness_given:
            return np.full_like(tq, math.nan) if tq.ndim else math.nan
        t, k, theta = self._segments()
        a = np.abs(tq)
        i = np.searchsorted(t[1:], a, side="left")
        out = np.sign(tq) * (theta[i] + (a - t[i]) / k[i])
        return out if tq.ndim else float(out)

    def spring_torque_Nm(self, windup_rad) -> Any:
        """The inverse of :meth:`windup_rad`: the output torque of a windup, in [N m] (the
        piecewise-linear spring of the compliant joint in the simulation)."""
        th = np.asarray(windup_rad, float)
        if not self.stiffness_given:
            return np.full_like(th, math.nan) if th.ndim else math.nan
        t, k, theta = self._segments()
        a = np.abs(th)
        i = np.searchsorted(theta[1:], a, side="left")
        out = np.sign(th) * (t[i] + (a - theta[i]) * k[i])
        return out if th.ndim else float(out)

    @property
    def back_driven_efficiency(self) -> float:
        """Efficiency when the load back-drives the motor: ``back_efficiency`` if given, else
        derived equal to the motoring ``efficiency``."""
        b = self.back_efficiency
        return float(b) if math.isfinite(b) else float(self.efficiency)


@dataclass(frozen=True)
class Amplifier:
    """A servo amplifier (drive electronics) feeding one motor from its DC bus.

    Attributes
    ----------
    model : str
    continuous_current_A, peak_current_A : float
        Continuous and peak output current in [A] (the data sheet's; the peak for the
        maker's stated time, typically a few seconds).
    bus_voltage_V : float
        DC bus (supply) voltage in [V]: the voltage the amplifier can apply to the motor
        (the envelope's ``U``; the PWM's few per cent of loss are not counted).
    regenerates : bool
        True when the amplifier is four-quadrant: it brakes the motor by returning the
        current to its bus (the braking quadrants may then use ``Kt (U + Ke |w|) / R``) and the
        cycle's braking energy is sized against the bus capacitor and the brake resistor.
    bus_capacitance_F : float
        Capacitance on the bus in [F]; NaN: not given.
    brake_resistor_ohm, brake_resistor_power_W : float
        Brake (shunt) resistor in [ohm] and its continuous power rating in [W]; NaN: none.
    brake_threshold_V : float
        Bus voltage at which the brake chopper switches the resistor on (or, without one, the
        highest bus voltage allowed) in [V]; NaN: not given.
    source : str
        The data sheet (document, page) the numbers come from.
    """

    model: str
    continuous_current_A: float
    peak_current_A: float
    bus_voltage_V: float
    regenerates: bool = False
    bus_capacitance_F: float = math.nan
    brake_resistor_ohm: float = math.nan
    brake_resistor_power_W: float = math.nan
    brake_threshold_V: float = math.nan
    source: str = ""

    @property
    def bus_energy_J(self) -> float:
        """Braking energy the bus capacitor takes from the bus voltage up to the brake
        threshold, ``C (U_max^2 - U_bus^2) / 2`` in [J]; NaN when either is not given."""
        c, u_max, u = self.bus_capacitance_F, self.brake_threshold_V, self.bus_voltage_V
        return 0.5 * c * (u_max**2 - u**2)

    @property
    def brake_peak_power_W(self) -> float:
        """The power the brake resistor sinks at the threshold voltage, ``U_max^2 / R`` in
        [W]; NaN without a resistor or a threshold."""
        return self.brake_threshold_V**2 / self.brake_resistor_ohm


@dataclass(frozen=True)
class Encoder:
    """An incremental encoder on the motor shaft (counts: :meth:`Drive.counts_per_rad`)."""

    pulses_per_rev: int
    decoding: int = 4


@dataclass(frozen=True)
class Drive:
    """One joint's drive train and the joint limits URDF cannot hold.

    Attributes
    ----------
    joint : str
    acceleration_rad_s2, jerk_rad_s3 : float
        Joint-side limits in [rad/s^2] and [rad/s^3]. Left out (NaN): derived from the drive
        train (peak torque, reflected and link inertia, current slew) unless the study's
        ``[limits]`` gives them; the limit sources say which.
    derating : float
        Extra factor on the available torque (0.8 for the thesis' joint 2).
    amplifier : Amplifier or None
        The joint's servo amplifier; None: not described (the motor's ``supply_voltage_V``
        stands for its bus, its current is not limited beyond the motor's peak torque, and
        braking takes no regeneration credit).
    """

    joint: str
    motor: Motor
    reducer: Reducer
    encoder: Encoder
    acceleration_rad_s2: float = math.nan
    jerk_rad_s3: float = math.nan
    derating: float = 1.0
    amplifier: Amplifier | None = None

    # ------------------------------------------------------------------ the one home
    # Every quantity of a joint's drive is answered here, with one rule each; the vectorised
    # DriveTrain (armlab.robot.drivetrain), the limits, sizing, the servo plant and the
    # simulation, the set-point table, CiA 402 and ros2 exports read these properties.
    @property
    def peak_torque_given(self) -> bool:
        """True when the motor data sheet gives a peak torque (else the stall torque stands
        in for it: :attr:`peak_motor_torque_Nm`)."""
        p = self.motor.peak_torque_Nm
        return p is not None and math.isfinite(p) and p > 0

    @property
    def peak_motor_torque_rating_Nm(self) -> float:
        """The motor's peak torque rating in [N m]: the data sheet's peak torque, else the
        continuous stall torque (conservative: a data sheet without a peak figure promises no
        more), before derating."""
        return float(
            self.motor.peak_torque_Nm if self.peak_torque_given else self.motor.stall_torque_Nm
        )

    @property
    def amplifier_torque_Nm(self) -> float:
        """The motor torque of the amplifier's peak current, ``Kt I_peak``, in [N m] (inf
        without an amplifier): the electronics cannot drive more current than that
        (``T_m = Kt i``, HEU thesis ch. 5)."""
        a = self.amplifier
        if a is None or not math.isfinite(a.peak_current_A):
            return math.inf
        return float(self.motor.torque_constant_Nm_A * a.peak_current_A)

    @property
    def peak_motor_torque_Nm(self) -> float:
        """The largest motor torque the drive may give, in [N m]: derating x the peak rating
        (:attr:`peak_motor_torque_rating_Nm`), at most the torque of the amplifier's peak
        current (:attr:`amplifier_torque_Nm`). Sizing's peak check, the envelope (so every
        planner's motor-envelope rows), the servo plant's current limit (hence the tuning and
        the simulation), the derived acceleration limit and CiA 402 0x6072 all use this one
        number."""
        return min(self.derating * self.peak_motor_torque_rating_Nm, self.amplifier_torque_Nm)

    @property
    def continuous_motor_torque_Nm(self) -> float:
        """The continuous (RMS) motor torque rating in [N m]: derating x stall torque."""
        return self.derating * self.motor.stall_torque_Nm

    @property
    def supply_voltage_V(self) -> float:
        """The voltage the amplifier can apply to the motor, in [V]: the amplifier's bus
        voltage when one is described, else the motor's ``supply_voltage_V`` (the drives
        file's estimate of it). The envelope, the no-load speed, the current slew and the servo
        plant use this one number."""
        a = self.amplifier
        return float(a.bus_voltage_V) if a is not None else float(self.motor.supply_voltage_V)

    @property
    def regenerates(self) -> bool:
        """True when the amplifier is four-quadrant (brakes by regeneration, see
        :class:`Amplifier`); False without an amplifier (no credit, conservative)."""
        return self.amplifier is not None and bool(self.amplifier.regenerates)

    @property
    def current_limit_A(self) -> float:
        """The amplifier's current limit in [A]: the current of the peak torque,
        ``peak_motor_torque_Nm / Kt`` (which holds the amplifier's peak current when one is
        described), at most the standstill current the supply can drive, ``U / R`` (armature
        equation ``U = R i + Ke w``, HEU thesis ch. 5)."""
        m = self.motor
        return min(
            self.peak_motor_torque_Nm / m.torque_constant_Nm_A,
            self.supply_voltage_V / m.resistance_ohm,
        )

    @property
    def continuous_current_limit_A(self) -> float:
        """The RMS current the amplifier may carry, in [A]: its continuous current (inf
        without an amplifier: the motor's RMS check alone applies)."""
        return math.inf if self.amplifier is None else float(self.amplifier.continuous_current_A)

    @property
    def available_torque_Nm(self) -> float:
        """Thesis rule: stall torque x ratio x efficiency x derating, in [N m] (table 4.3):
        the continuous rating delivered at rest in the motoring quadrant (holding counts as
        motoring)."""
        return available_torque_Nm(
            self.motor.stall_torque_Nm, self.reducer.ratio, self.reducer.efficiency, self.derating
        )

    @property
    def stop_torque_Nm(self) -> float:
        """Output torque of an emergency stop at the current limit, in [N m]: the peak motor
        torque braking through the back-driven reducer, ``N T_m,peak / eta_b`` (drive-train
        model: input torque = output torque x eta_b / N). An upper bound: the rotor's own
        deceleration takes part of the motor torque. The load case of the momentary-torque
        check (:mod:`armlab.dynamics.reducer_life`)."""
        r = self.reducer
        return self.peak_motor_torque_Nm * r.ratio / r.back_driven_efficiency

    @property
    def motor_side_inertia_kg_m2(self) -> float:
        """Rotor + reducer input inertia, on the motor shaft, in [kg m^2]."""
        return self.motor.rotor_inertia_kg_m2 + self.reducer.inertia_kg_m2

    @property
    def reflected_inertia_kg_m2(self) -> float:
        """(rotor + reducer input inertia) x ratio^2, seen at the joint, in [kg m^2]."""
        return self.motor_side_inertia_kg_m2 * self.reducer.ratio**2

    def load_inertia_at_motor_kg_m2(self, joint_inertia_kg_m2, motoring: bool):
        """A joint-side (arm) inertia seen at the motor shaft through the reducer, in [kg m^2].

        The reducer's losses act on the torque that accelerates the arm (drive-train model,
        :mod:`armlab.robot.drivetrain`): motoring, the motor supplies ``J qdd / (N eta)``, so the
        arm weighs ``J / (eta N^2)``; back-driven, ``J eta_b / N^2``. Scalars or arrays."""
        r = self.reducer
        k = 1.0 / r.efficiency if motoring else r.back_driven_efficiency
        return joint_inertia_kg_m2 * k / r.ratio**2

    # ------------------------------------------------------------------ compliant joint
    @property
    def small_signal_stiffness_Nm_rad(self) -> float:
        """The reducer's stiffness about zero load, K1, in [N m/rad] at the output (the
        spring of the two-mass servo plant); NaN without stiffness data."""
        r = self.reducer
        return float(r.stiffness_Nm_rad[0]) if r.stiffness_given else math.nan

    def torsional_stiffness_Nm_rad(self, torque_Nm) -> Any:
        """The reducer's tangent stiffness at a load torque, [N m/rad]
        (:meth:`Reducer.torsional_stiffness_Nm_rad`)."""
        return self.reducer.torsional_stiffness_Nm_rad(torque_Nm)

    def anti_resonance_rad_s(self, load_inertia_kg_m2: float) -> float:
        """Anti-resonance of the two-mass joint, ``sqrt(K1 / J_L)`` in [rad/s]: the link
        (inertia ``J_L`` at the joint) swinging on the reducer's spring with the motor held
        (Ellis, "Control System Design Guide", ch. 16, two-mass resonance). NaN without
        stiffness data."""
        return math.sqrt(self.small_signal_stiffness_Nm_rad / load_inertia_kg_m2)

    def first_resonance_rad_s(self, load_inertia_kg_m2: float) -> float:
        """First (locked-rotor free) resonance of the two-mass joint in [rad/s]::

            w_r = sqrt(K1 (J_M + J_L) / (J_M J_L))

        with ``J_M`` the motor-side inertia reflected to the joint
        (:attr:`reflected_inertia_kg_m2`), ``J_L`` the link inertia at the joint and ``K1``
        the reducer's small-signal stiffness at the output (Ellis, "Control System Design
        Guide", ch. 16). NaN without stiffness data."""
        jm, jl = self.reflected_inertia_kg_m2, float(load_inertia_kg_m2)
        return math.sqrt(self.small_signal_stiffness_Nm_rad * (jm + jl) / (jm * jl))

    def counts_per_motor_rev(self, decoding: int | None = None) -> float:
        """Encoder counts per motor revolution: ``pulses_per_rev x decoding``, with the
        controller's decoding when it sets one (``decoding``), else the encoder's."""
        dec = self.encoder.decoding if decoding is None else int(decoding)
        return float(self.encoder.pulses_per_rev * dec)

    def counts_per_rad(self, decoding: int | None = None) -> float:
        """Encoder counts per joint radian: ``pulses_per_rev x decoding x ratio / (2 pi)``
        (``decoding`` as :meth:`counts_per_motor_rev`)."""
        return self.counts_per_motor_rev(decoding) * self.reducer.ratio / (2.0 * math.pi)

    @property
    def motor_speed_limit_rad_s(self) -> float:
        """The motor shaft speed the drive may run at, in [rad/s]: the motor's speed limit
        (rated table speed, else no-load ``U / Ke``) and the reducer's maximum input speed,
        whichever is lower. The joint velocity limit is this over the ratio."""
        return self._within_reducer_input(self.motor.speed_limit_rad_s)

    @property
    def max_motor_speed_rad_s(self) -> float:
        """The fastest the motor shaft can physically turn, in [rad/s]: the no-load speed
        ``U / Ke`` (``U``: :attr:`supply_voltage_V`) and the reducer's maximum input speed,
        whichever is lower (the servo's speed command saturates here)."""
        return self._within_reducer_input(self.supply_voltage_V / self.motor.back_emf_V_s_rad)

    def _within_reducer_input(self, speed_rad_s: float) -> float:
        """``speed_rad_s`` at most the reducer's maximum input speed (where one is given)."""
        red = self.reducer.max_input_speed_rad_s
        return min(speed_rad_s, red) if math.isfinite(red) and red > 0 else speed_rad_s

    @property
    def quadrant_band_rad_s(self) -> float:
        """Joint speed over which the reducer passes from the motoring to the back-driven
        efficiency, in [rad/s] (:func:`armlab.robot.drivetrain.quadrant_share`).

        At rest the drive holds as in the motoring quadrant (thesis table 4.3); once the load
        back-drives the motor, the back-driven efficiency applies. Data sheets give no curve for
        the passage through standstill, so it is ASSUMED linear over 1 % of the joint speed
        limit (:data:`QUADRANT_BAND_SHARE`): the motor torque is then continuous through
        ``qd = 0`` (a set-point table's torque offset has no step at start and stop)."""
        return QUADRANT_BAND_SHARE * self.motor_speed_limit_rad_s / self.reducer.ratio

    def to_dict(self) -> dict:
        return asdict(self)
