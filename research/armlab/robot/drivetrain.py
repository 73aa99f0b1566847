r"""The drive-train model: the one place a joint torque becomes a motor torque and back.

Every torque computed for a drive (inverse dynamics and sizing, the planners' ``drive_limits``,
the tracking simulation, computed torque) goes through the functions of this module; the data
come from ``drives.toml`` (:mod:`armlab.robot.drives`) resolved into per-joint arrays by
:func:`drive_train`.

The model (per joint, SI; HEU thesis ch. 5 for the DC motor, thesis table 4.3 for the
efficiency rule)
---------------------------------------------------------------------------------------------
With the rigid-body joint torque ``tau`` (:func:`armlab.robot.rigid_body.inverse_dynamics`,
``M qdd + C qd + g``), joint speed ``qd`` and acceleration ``qdd``, reducer ratio ``N``:

* **joint friction** (reducer output and joint bearings; ``drives.toml`` ``reducer.
  coulomb_friction_Nm`` ``F_c`` and ``reducer.viscous_friction_Nm_s_rad`` ``F_v``, default 0)::

      tau_f = F_c s + F_v qd,    s = sign(qd) where qd != 0, else sign(qdd)

  At rest the Coulomb term points along the acceleration (break-away: to start moving the drive
  overcomes it) and is 0 when ``qdd = 0`` too (holding: static friction is counted as neither
  help nor load). The torque the reducer must deliver is ``tau_out = tau + tau_f``.
* **reducer efficiency by quadrant**: the motor **drives** (motoring, power flows motor -> load)
  where ``tau_out qd >= 0`` -- holding (``qd = 0``) included, the thesis' rule of table 4.3 --
  and the input torque is ``tau_out / (N eta)``; the load **back-drives** the motor where
  ``tau_out qd < 0`` and the input torque is ``tau_out eta_b / N`` (the losses help the motor).
  ``eta_b`` is ``reducer.back_efficiency``, derived equal to ``eta`` when not given.
  **Through standstill** the data sheets give no curve; the back-driven share rises linearly
  with ``|qd|`` over the drive's quadrant band (ASSUMED 1 % of the joint speed limit,
  :func:`quadrant_share`), so the motor torque is continuous in time through every start,
  stop and reversal: one rule for holding (motoring) and for moving, used by sizing, the
  planners' checks, the feed-forward of the simulation and every exported torque.
* **reflected inertia and motor friction** on the motor shaft::

      T_m = T_in + (J_rotor + J_reducer_input) N qdd + b_m w_m,     w_m = N qd

  (``motor.rotor_inertia_kg_m2``, ``reducer.inertia_kg_m2``, ``motor.viscous_friction_Nm_s_rad``).
  The rotor inertia is counted here only: the Pinocchio model's ``armature`` must be zero
  (robot_desc arms load so), or it would be counted twice.

:func:`motor_torque` is this map; :func:`joint_torque_delivered` its exact inverse (the joint
torque a motor torque delivers at a given motion, for the simulation).

The envelope (what the motor can give)
--------------------------------------
From the armature equation ``U = R i + Ke w`` and ``T = Kt i`` (HEU thesis ch. 5) with the
amplifier's supply voltage ``U``::

    |T_m| <= min(T_max, derating x Kt (U - Ke |w_m|) / R)        (voltage line, both quadrants)
    |w_m| <= motor speed limit (rated table speed, else U / Ke)   (maximum speed)
    sqrt(mean over the cycle of T_m^2) <= derating x T_stall      (continuous rating, RMS)

``T_max = min(derating x T_peak, Kt I_amp)``: ``T_peak`` the data sheet's peak torque (the
stall torque when it gives none, conservative), ``I_amp`` the amplifier's peak current when one
is described (:attr:`armlab.robot.drives.Drive.peak_motor_torque_Nm`, the one home of it).
**Regeneration**: without a described amplifier (teachbot6's is not in the thesis) the same
voltage line bounds the braking quadrants (no credit, ASSUMED, conservative): the envelope is
symmetric in torque. A drive whose amplifier regenerates (:class:`armlab.robot.drives.Amplifier`
``regenerates = true``: four-quadrant, it sinks the braking current into its bus) brakes with up
to ``Kt (U + Ke |w|) / R`` where ``T_m w_m < 0`` (:func:`envelope_torque` given the torque);
``U`` is the amplifier's bus voltage when one is described
(:attr:`armlab.robot.drives.Drive.supply_voltage_V`). The planners' CasADi rows keep the
symmetric line (conservative); their fine-grid check and sizing use the four-quadrant one.
The old four-quadrant rule of ``armlab.dynamics.checks.envelope_torque`` is replaced by this one.

:func:`envelope_torque` gives the bound per sample, :func:`envelope_ratio` ``|T_m| / bound``
per sample, :func:`drive_ratios` the peak ratios of a motion to each part of the envelope (the
planners' fine-grid check of ``drive_limits``).

The CasADi twin
---------------
The optimisers know the direction of motion ``sigma`` of each joint in advance (per segment, from
the waypoints: :mod:`armlab.planning.optimal` keeps each joint monotone within a segment when
``drive_limits`` is on; along a TOPP path ``sign(qd) = sign(q'(s))``). With it the quadrant
switch is the only non-smooth part, and it is convex: for ``sigma > 0`` the motor torque is
``max(T_motoring, T_backdriven)``, for ``sigma < 0`` ``min(...)``, both branches affine in
``tau`` (:func:`motor_torque_branches`, plain arithmetic that evaluates numpy arrays and CasADi
expressions alike). An upper bound on a max (a lower bound on a min) is exact as two rows; the
other side is imposed on the back-driven branch, which is exact where the bound can bind and
conservative elsewhere. The final fine-grid check is the exact numeric model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab.errors import InputError, RobotDescriptionError

if TYPE_CHECKING:
    from armlab.robot.drives import Drive
    from armlab.robot.model import Robot

__all__ = [
    "DriveTrain",
    "drive_train",
    "planning_drive_train",
    "motor_speed",
    "friction_direction",
    "joint_friction",
    "motor_torque",
    "quadrant_share",
    "reducer_input_torque",
    "transmission_efficiency",
    "motor_side",
    "joint_torque_delivered",
    "voltage_line_torque",
    "envelope_torque",
    "envelope_ratio",
    "rms_torque",
    "drive_ratios",
    "DRIVE_KINDS",
    "motor_torque_branches",
    "motor_torque_symbolic",
]

_TINY = 1e-12

#: the kinds of :func:`drive_ratios` (planners report them beside velocity, torque, ...)
DRIVE_KINDS = ("motor_envelope", "motor_speed", "motor_rms")


@dataclass(frozen=True)
class DriveTrain:
    """The drive-train numbers of several drives as arrays ``(n_columns,)`` in SI.

    A column is one joint's drive (:func:`drive_train` of a robot: one per joint, in joint
    order) or one candidate drive (sizing's selection tries many for one joint).

    Attributes
    ----------
    ratio : reducer ratio N (motor speed / joint speed)
    efficiency, back_efficiency : motoring and back-driven reducer efficiency in (0, 1]
    derating : extra factor on every motor torque rating
    inertia_motor_side_kg_m2 : rotor + reducer input inertia in [kg m^2]
    viscous_Nm_s_rad : motor-shaft viscous friction b_m in [N m s/rad]
    coulomb_friction_Nm, joint_viscous_Nm_s_rad : joint-side friction F_c [N m], F_v [N m s/rad]
    stall_torque_Nm : continuous rating in [N m] (the RMS bound)
    peak_torque_Nm : peak rating if given, else the stall torque, in [N m]
    rated_speed_rad_s : motor speed limit (table speed, else no-load ``U / Ke``) in [rad/s]
    torque_constant_Nm_A, back_emf_V_s_rad, resistance_ohm, supply_voltage_V : Kt, Ke, R, U
    power_W : table power in [W] (NaN when not given)
    reducer_rated_torque_Nm, reducer_peak_torque_Nm, reducer_max_input_speed_rad_s
    peak_motor_torque_Nm, continuous_motor_torque_Nm : the drive's largest motor torque
        (derated peak rating, capped by the amplifier's peak current) and the derated
        continuous one in [N m] (:attr:`~armlab.robot.drives.Drive.peak_motor_torque_Nm`,
        :attr:`~armlab.robot.drives.Drive.continuous_motor_torque_Nm`)
    quadrant_band_rad_s : joint speed over which the reducer passes from motoring to
        back-driven efficiency through standstill [rad/s] (:func:`quadrant_share`)
    reflected_inertia_kg_m2 : ``(J_rotor + J_reducer) N^2`` seen at the joint [kg m^2]
    regenerates : 1.0 where the amplifier is four-quadrant (brakes by regeneration), else 0.0
    drives : the :class:`~armlab.robot.drives.Drive` of each column, whose answers these are
    """

    def counts_per_joint_rev(self, decoding: int | None = None) -> np.ndarray:
        """Encoder counts per joint revolution of each column, ``(n_columns,)``:
        :meth:`~armlab.robot.drives.Drive.counts_per_rad` x 2 pi (``decoding``: the
        controller's, if it sets one)."""
        return np.array([2.0 * math.pi * d.counts_per_rad(decoding) for d in self.drives])

    ratio: np.ndarray
    efficiency: np.ndarray
    back_efficiency: np.ndarray
    derating: np.ndarray
    inertia_motor_side_kg_m2: np.ndarray
    viscous_Nm_s_rad: np.ndarray
    coulomb_friction_Nm: np.ndarray
    joint_viscous_Nm_s_rad: np.ndarray
    stall_torque_Nm: np.ndarray
    peak_torque_Nm: np.ndarray
    rated_speed_rad_s: np.ndarray
    torque_constant_Nm_A: np.ndarray
    back_emf_V_s_rad: np.ndarray
    resistance_ohm: np.ndarray
    supply_voltage_V: np.ndarray
    power_W: np.ndarray
    reducer_rated_torque_Nm: np.ndarray
    reducer_peak_torque_Nm: np.ndarray
    reducer_max_input_speed_rad_s: np.ndarray
    peak_motor_torque_Nm: np.ndarray
    continuous_motor_torque_Nm: np.ndarray
    quadrant_band_rad_s: np.ndarray
    reflected_inertia_kg_m2: np.ndarray
    drives: tuple[Drive, ...]
    regenerates: np.ndarray | None = None

    @classmethod
    def from_drives(cls, drives: list[Drive]) -> DriveTrain:
        """The arrays of a list of :class:`~armlab.robot.drives.Drive` (one column each)."""

        def arr(f):
            return np.array([float(f(d)) for d in drives])

        # every number is the Drive's own answer (armlab.robot.drives.Drive): one rule each
        return cls(
            ratio=arr(lambda d: d.reducer.ratio),
            efficiency=arr(lambda d: d.reducer.efficiency),
            back_efficiency=arr(lambda d: d.reducer.back_driven_efficiency),
            derating=arr(lambda d: d.derating),
            inertia_motor_side_kg_m2=arr(lambda d: d.motor_side_inertia_kg_m2),
            viscous_Nm_s_rad=arr(lambda d: d.motor.viscous_friction_Nm_s_rad),
            coulomb_friction_Nm=arr(lambda d: d.reducer.coulomb_friction_Nm),
            joint_viscous_Nm_s_rad=arr(lambda d: d.reducer.viscous_friction_Nm_s_rad),
            stall_torque_Nm=arr(lambda d: d.motor.stall_torque_Nm),
            peak_torque_Nm=arr(lambda d: d.peak_motor_torque_rating_Nm),
            # the same motor speed bounds the joint velocity limit (armlab.robot.resolve_limits)
            rated_speed_rad_s=arr(lambda d: d.motor.speed_limit_rad_s),
            torque_constant_Nm_A=arr(lambda d: d.motor.torque_constant_Nm_A),
            back_emf_V_s_rad=arr(lambda d: d.motor.back_emf_V_s_rad),
            resistance_ohm=arr(lambda d: d.motor.resistance_ohm),
            supply_voltage_V=arr(lambda d: d.supply_voltage_V),
            power_W=arr(lambda d: d.motor.power_W),
            reducer_rated_torque_Nm=arr(lambda d: d.reducer.rated_torque_Nm),
            reducer_peak_torque_Nm=arr(lambda d: d.reducer.peak_torque_Nm),
            reducer_max_input_speed_rad_s=arr(lambda d: d.reducer.max_input_speed_rad_s),
            peak_motor_torque_Nm=arr(lambda d: d.peak_motor_torque_Nm),
            continuous_motor_torque_Nm=arr(lambda d: d.continuous_motor_torque_Nm),
            quadrant_band_rad_s=arr(lambda d: d.quadrant_band_rad_s),
            reflected_inertia_kg_m2=arr(lambda d: d.reflected_inertia_kg_m2),
            drives=tuple(drives),
            regenerates=arr(lambda d: d.regenerates),
        )

    @property
    def n_columns(self) -> int:
        return int(self.ratio.size)

    @property
    def no_load_speed_rad_s(self) -> np.ndarray:
        """``U / Ke``: where the voltage line reaches zero torque, in [rad/s]."""
        return self.supply_voltage_V / self.back_emf_V_s_rad

    @property
    def standstill_torque_Nm(self) -> np.ndarray:
        """Where the voltage line meets zero speed, derated: ``derating Kt U / R`` in [N m]
        (the envelope's bound at standstill before the peak rating caps it)."""
        return (
            self.derating * self.torque_constant_Nm_A * self.supply_voltage_V / self.resistance_ohm
        )

    @property
    def available_joint_torque_Nm(self) -> np.ndarray:
        """Thesis table 4.3 rule, the model at rest in the motoring quadrant:
        ``T_stall x derating x N x eta`` in [N m]
        (:func:`armlab.robot.drives.available_torque_Nm`)."""
        from armlab.robot.drives import available_torque_Nm

        return available_torque_Nm(self.stall_torque_Nm, self.ratio, self.efficiency, self.derating)

    def symbolic_coefficients(self) -> np.ndarray:
        """``(n_columns, 9)``: per column ``N, eta, eta_b, J_motor_side, b_m, F_c, F_v, Kt/R,
        Kt Ke / R`` -- the parameters :func:`motor_torque_branches` and the envelope rows of the
        planners read (:mod:`armlab.planning.transcription`), in that order."""
        return np.column_stack(
            [
                self.ratio,
                self.efficiency,
                self.back_efficiency,
                self.inertia_motor_side_kg_m2,
                self.viscous_Nm_s_rad,
                self.coulomb_friction_Nm,
                self.joint_viscous_Nm_s_rad,
                self.torque_constant_Nm_A / self.resistance_ohm,
                self.torque_constant_Nm_A * self.back_emf_V_s_rad / self.resistance_ohm,
            ]
        )


def drive_train(robot: Robot, drives=None) -> DriveTrain:
    """The :class:`DriveTrain` of a robot: its drives (``robot.drives``, after study
    overrides) in joint order, or the ``drives`` given (dict by joint name or list).

    Raises
    ------
    RobotDescriptionError
        The robot has no drives file and no drives are given.
    InputError
        ``drives`` given for the wrong joints or the wrong number of joints.
    """
    if drives is None:
        if robot.drives is None:
            raise RobotDescriptionError(
                f"{robot.name}: no drives file (drives.toml): the drive-train model needs motor "
                "and reducer data"
            )
        return DriveTrain.from_drives([robot.drives[n] for n in robot.joint_names])
    if isinstance(drives, dict):
        missing = [n for n in robot.joint_names if n not in drives]
        if missing:
            raise InputError(f"drives given for {sorted(drives)} but not for {missing}")
        return DriveTrain.from_drives([drives[n] for n in robot.joint_names])
    dl = list(drives)
    if len(dl) != robot.n_joints:
        raise InputError(f"{len(dl)} drives given for {robot.n_joints} joints")
    return DriveTrain.from_drives(dl)


# ----------------------------------------------------------------------------- numeric model
def _arrays(*xs) -> list[np.ndarray]:
    out = [np.asarray(x, dtype=float) for x in xs]
    shape = out[0].shape
    for name, a in zip(("qd", "qdd"), out[1:], strict=False):
        if a.shape != shape:
            raise InputError(f"{name} has shape {a.shape}, expected {shape} like the torque")
    return out


def planning_drive_train(robot: Robot, drive_limits, tau_max, *, where: str):
    """``(train, tau_max)`` for a planner's ``drive_limits`` option: the robot's
    :class:`DriveTrain` (None without ``drive_limits``) and the torque limit argument, switched
    off (``False``) when ``drive_limits`` replaces the robot's torque box and the caller gave
    none (``None``).

    Raises
    ------
    InputError
        ``drive_limits`` is not a bool, or the robot has no drives file (``where`` names the
        planner).
    """
    if not isinstance(drive_limits, bool):
        raise InputError(f"{where}: drive_limits must be true or false, not {drive_limits!r}")
    if not drive_limits:
        return None, tau_max
    if robot.drives is None:
        raise InputError(
            f"{where}: drive_limits: {robot.name} has no drives file (drives.toml) with the "
            "motor data"
        )
    return drive_train(robot), (False if tau_max is None else tau_max)


def motor_speed(qd, dt: DriveTrain) -> np.ndarray:
    """Motor shaft speed ``w_m = N qd`` in [rad/s]; ``qd`` (n_samples, n_columns) in [rad/s]."""
    return np.asarray(qd, float) * dt.ratio


def friction_direction(qd, qdd) -> np.ndarray:
    """``sign(qd)`` where ``qd != 0``, else ``sign(qdd)`` (break-away; 0 when both are 0)."""
    qd, qdd = np.asarray(qd, float), np.asarray(qdd, float)
    return np.where(qd != 0.0, np.sign(qd), np.sign(qdd))


def joint_friction(qd, qdd, dt: DriveTrain) -> np.ndarray:
    """Joint-side friction torque ``F_c s + F_v qd`` in [N m] (module docstring)."""
    qd = np.asarray(qd, float)
    return dt.coulomb_friction_Nm * friction_direction(qd, qdd) + dt.joint_viscous_Nm_s_rad * qd


def quadrant_share(tau_out, qd, band_rad_s) -> np.ndarray:
    """Share ``a`` in [0, 1] of the back-driven efficiency in the reducer's transmission.

    ``a = 0`` where the motor drives the load or holds it (``tau_out qd >= 0``: power flows
    motor -> load, holding included, thesis table 4.3); where the load back-drives the motor
    (``tau_out qd < 0``) ``a = min(|qd| / v_b, 1)`` with ``v_b = band_rad_s`` the drive's
    quadrant band (:attr:`armlab.robot.drives.Drive.quadrant_band_rad_s`, ASSUMED 1 % of the
    joint speed limit; :attr:`DriveTrain.quadrant_band_rad_s`). The transmission
    (:func:`transmission_efficiency`) is then continuous through ``qd = 0``, and exactly the
    back-driven one beyond the band. Since the input and output torques have one sign,
    ``tau_out`` may be either of them.
    """
    tau_out, qd = np.asarray(tau_out, float), np.asarray(qd, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.minimum(np.abs(qd) / band_rad_s, 1.0)
    return np.where(tau_out * qd < 0.0, np.nan_to_num(frac, nan=1.0), 0.0)


def transmission_efficiency(share, efficiency, back_efficiency) -> np.ndarray:
    """``k = 1 / ((1 - a) / eta + a eta_b)``: output torque = ``k N`` x input torque, with the
    quadrant share ``a`` (:func:`quadrant_share`): ``eta`` motoring and holding, ``1 / eta_b``
    back-driven. The one rule of the reducer's losses: the drive-train model, its inverse and
    the simulated reducer use it."""
    return 1.0 / ((1.0 - share) / efficiency + share * back_efficiency)


def reducer_input_torque(tau_out, qd, dt: DriveTrain) -> np.ndarray:
    """The reducer input (motor-side) torque of an output torque ``tau_out`` [N m] at joint
    speed ``qd`` [rad/s]: ``tau_out / (k N)`` (:func:`transmission_efficiency` with the
    quadrant share of :func:`quadrant_share`: efficiency by quadrant, continuous through rest)."""
    tau_out = np.asarray(tau_out, float)
    share = quadrant_share(tau_out, qd, dt.quadrant_band_rad_s)
    k = transmission_efficiency(share, dt.efficiency, dt.back_efficiency)
    return tau_out / (k * dt.ratio)


def motor_torque(tau, qd, qdd, dt: DriveTrain) -> tuple[np.ndarray, np.ndarray]:
    """Motor torque needed for a motion, and where the motor drives the load.

    Parameters
    ----------
    tau : array (n_samples, n_columns)
        Rigid-body joint torque ``M qdd + C qd + g`` in [N m] (friction is added here).
    qd, qdd : array (n_samples, n_columns)
        Joint speed [rad/s] and acceleration [rad/s^2].
    dt : DriveTrain

    Returns
    -------
    motor_torque_Nm : array (n_samples, n_columns)
        ``T_m = T_in + J N qdd + b_m N qd`` with ``T_in = tau_out / (N eta)`` motoring or
        holding, ``tau_out eta_b / N`` back-driven, passing from one to the other over the
        quadrant band (:func:`quadrant_share`); ``tau_out = tau + tau_f`` (module docstring).
    motoring : bool array (n_samples, n_columns)
        True where ``tau_out qd >= 0`` (the motor drives the load; holding included).
    """
    tau, qd, qdd = _arrays(tau, qd, qdd)
    N = dt.ratio
    tau_out = tau + joint_friction(qd, qdd, dt)
    t_in = reducer_input_torque(tau_out, qd, dt)
    t_m = t_in + (dt.inertia_motor_side_kg_m2 * N) * qdd + dt.viscous_Nm_s_rad * (N * qd)
    return t_m, tau_out * qd >= 0.0


def motor_side(tau, qd, qdd, dt: DriveTrain) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Motor torque [N m], motor speed [rad/s] and motoring flags from joint signals
    (n_samples, n_columns): :func:`motor_torque` and :func:`motor_speed` together (``tau`` the
    rigid-body joint torque; joint friction is added by the model). ``motoring`` is True where
    the motor drives the load (``(tau + friction) qd >= 0``)."""
    t_m, motoring = motor_torque(tau, qd, qdd, dt)
    return t_m, motor_speed(qd, dt), motoring


def joint_torque_delivered(t_m, qd, qdd, dt: DriveTrain) -> np.ndarray:
    """The rigid-body joint torque a motor torque delivers at a motion: the exact inverse of
    :func:`motor_torque` (``motor_torque(joint_torque_delivered(T, ...), ...) == T``).

    ``T_in = T_m - J N qdd - b_m N qd``; ``tau_out = T_in N eta`` where ``T_in qd >= 0``
    (motoring), ``T_in N / eta_b`` back-driven beyond the quadrant band, the inverse of the
    blend inside it (:func:`quadrant_share`); minus the joint friction ``tau_f``. At rest
    (``qd = 0``) the Coulomb term follows ``sign(qdd)`` as in :func:`joint_friction`; a
    simulation that resolves stiction itself passes the acceleration it has in mind.

    Parameters
    ----------
    t_m, qd, qdd : array (n_samples, n_columns)
        Motor torque [N m], joint speed [rad/s] and acceleration [rad/s^2].
    dt : DriveTrain

    Returns
    -------
    array (n_samples, n_columns) in [N m]
    """
    t_m, qd, qdd = _arrays(t_m, qd, qdd)
    N = dt.ratio
    t_in = t_m - (dt.inertia_motor_side_kg_m2 * N) * qdd - dt.viscous_Nm_s_rad * (N * qd)
    # sign(T_in) = sign(tau_out), so the quadrant (and the band share) follows from T_in
    share = quadrant_share(t_in, qd, dt.quadrant_band_rad_s)
    tau_out = t_in * N * transmission_efficiency(share, dt.efficiency, dt.back_efficiency)
    return tau_out - joint_friction(qd, qdd, dt)


def voltage_line_torque(w_m, dt: DriveTrain) -> np.ndarray:
    """``Kt (U - Ke |w_m|) / R`` in [N m]: the torque the supply voltage allows at motor speed
    ``w_m`` [rad/s] (both quadrants; negative beyond the no-load speed ``U / Ke``)."""
    w = np.abs(np.asarray(w_m, float))
    return (
        dt.torque_constant_Nm_A
        * (dt.supply_voltage_V - dt.back_emf_V_s_rad * w)
        / (dt.resistance_ohm)
    )


def envelope_torque(w_m, dt: DriveTrain, t_m=None) -> np.ndarray:
    """The motor torque bound at each speed, in [N m]:
    ``min(T_peak,drive, derating Kt (U - Ke |w_m|) / R)`` with ``T_peak,drive`` the drive's
    largest torque (:attr:`~armlab.robot.drives.Drive.peak_motor_torque_Nm`: derating x the
    peak rating, at most ``Kt`` x the amplifier's peak current); negative beyond the no-load
    speed: no torque left there.

    With the motor torque ``t_m`` given, the **braking** samples (``T_m w_m < 0``: quadrants II
    and IV) of a drive whose amplifier regenerates (:attr:`DriveTrain.regenerates`) are bounded
    by the four-quadrant line ``Kt (U + Ke |w_m|) / R`` instead: the back-EMF then drives the
    braking current with the bus (armature equation ``U = R i + Ke w`` with ``i`` and ``w`` of
    opposite signs). Without ``t_m``, or for an amplifier that does not regenerate, the
    conservative symmetric bound (the planners' rows use it)."""
    line = voltage_line_torque(w_m, dt)
    if t_m is not None and dt.regenerates is not None and np.any(dt.regenerates):
        braking = (np.asarray(t_m, float) * np.asarray(w_m, float) < 0.0) & (dt.regenerates > 0)
        four_q = (
            dt.torque_constant_Nm_A
            * (dt.supply_voltage_V + dt.back_emf_V_s_rad * np.abs(np.asarray(w_m, float)))
            / dt.resistance_ohm
        )
        line = np.where(braking, four_q, line)
    return np.minimum(dt.peak_motor_torque_Nm, dt.derating * line)


def envelope_ratio(t_m, w_m, dt: DriveTrain) -> np.ndarray:
    """``|T_m| / envelope_torque(w_m, t_m)`` per sample (> 1: outside the envelope; inf where
    the speed leaves no torque and some is needed; four-quadrant where the amplifier
    regenerates: :func:`envelope_torque`)."""
    env = envelope_torque(w_m, dt, t_m)
    t_m = np.abs(np.asarray(t_m, float))
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(env > _TINY, t_m / np.maximum(env, _TINY), np.where(t_m > 0, np.inf, 0.0))
    return r


def rms_torque(t_m, weights) -> np.ndarray:
    """Time-weighted RMS over the samples, ``sqrt(sum w_k T_k^2 / sum w_k)``, per column [N m].

    ``weights`` (n_samples,) in [s]: the time each sample stands for (trapezoidal,
    :func:`armlab.trajectory.sampling.sample_weights`); with zero total weight, the peak ``|T|``.
    """
    t_m = np.atleast_2d(np.asarray(t_m, float))
    w = np.asarray(weights, float).reshape(-1, 1)
    total = float(w.sum())
    if total <= _TINY:
        return np.abs(t_m).max(axis=0)
    return np.sqrt((w * t_m**2).sum(axis=0) / total)


def drive_ratios(tau, qd, qdd, weights, dt: DriveTrain) -> dict[str, np.ndarray]:
    """Peak ratio of a motion to each part of the motor envelope, per column.

    Parameters
    ----------
    tau, qd, qdd : array (n_samples, n_columns)
        Rigid-body joint torque [N m], speed [rad/s], acceleration [rad/s^2] (a fine grid, or
        :meth:`~armlab.trajectory.Trajectory.limit_samples`).
    weights : array (n_samples,)
        Time each sample stands for in [s] (for the RMS).
    dt : DriveTrain

    Returns
    -------
    dict
        ``motor_envelope``: peak ``|T_m| / envelope`` (voltage line and peak torque);
        ``motor_speed``: peak ``|w_m|`` / motor speed limit; ``motor_rms``: RMS ``T_m`` /
        continuous rating. Each ``(n_columns,)``; <= 1 inside the envelope.
    """
    t_m, _ = motor_torque(tau, qd, qdd, dt)
    w_m = motor_speed(qd, dt)
    return {
        "motor_envelope": envelope_ratio(t_m, w_m, dt).max(axis=0),
        "motor_speed": np.abs(w_m).max(axis=0) / dt.rated_speed_rad_s,
        "motor_rms": rms_torque(t_m, weights) / dt.continuous_motor_torque_Nm,
    }


# ----------------------------------------------------------------------------- symbolic twin
def motor_torque_branches(tau, qd, qdd, direction, coeffs) -> tuple[Any, Any]:
    """The two quadrant branches of :func:`motor_torque` for a known direction of motion.

    Plain arithmetic: evaluates numpy arrays and CasADi expressions alike (this is the CasADi
    twin the optimisers use).

    Parameters
    ----------
    tau, qd, qdd : array or casadi expression
        Rigid-body joint torque [N m], joint speed [rad/s] and acceleration [rad/s^2].
    direction : array or expression of -1, 0, +1
        The friction direction ``s`` (:func:`friction_direction`): the sign of ``qd`` where the
        joint moves, of ``qdd`` at rest.
    coeffs : sequence of 9
        ``N, eta, eta_b, J, b_m, F_c, F_v, Kt/R, Kt Ke/R`` broadcastable to ``tau``
        (:meth:`DriveTrain.symbolic_coefficients`).

    Returns
    -------
    (motoring, backdriven)
        ``tau_out / (N eta) + r`` and ``tau_out eta_b / N + r`` with ``tau_out = tau + F_c s +
        F_v qd`` and ``r = J N qdd + b_m N qd``. The motor torque is the first where
        ``tau_out qd >= 0``, the second elsewhere: ``max`` of the two for ``qd > 0``, ``min``
        for ``qd < 0``, the first for ``qd = 0``.
    """
    N, eta, eta_b, J, b_m, f_c, f_v = coeffs[:7]
    tau_out = tau + f_c * direction + f_v * qd
    r = J * N * qdd + b_m * N * qd
    return tau_out / (N * eta) + r, tau_out * eta_b / N + r


def motor_torque_symbolic(tau, qd, qdd, direction, coeffs, band):
    """The exact motor torque as a CasADi expression: the twin of :func:`motor_torque` for a
    known ``direction``, with the drive's quadrant band ``band`` [rad/s]
    (:func:`quadrant_share`; tests compare the two). The two branches of
    :func:`motor_torque_branches` bound it: it lies between them (a convex blend)."""
    import casadi as ca

    mot, back = motor_torque_branches(tau, qd, qdd, direction, coeffs)
    N, eta, eta_b, J, b_m, f_c, f_v = coeffs[:7]
    tau_out = tau + f_c * direction + f_v * qd
    share = ca.if_else(tau_out * qd < 0, ca.fmin(ca.fabs(qd) / band, 1.0), 0.0)
    return (1.0 - share) * mot + share * back
