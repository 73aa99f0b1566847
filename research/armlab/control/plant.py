"""Joint plant: DC motor + reducer + the arm inertia reflected to the motor (thesis 5.4).

Motor equations (thesis eq. 5-1 .. 5-5), motor side, SI::

    L di/dt + R i + Ke w = U          armature circuit
    J dw/dt + B w = Kt i - tau_L      shaft (tau_L: load torque at the motor)
    theta_motor = N theta_joint       reducer of ratio N

Neglecting B, the voltage-to-speed transfer function is the thesis' eq. 5-8::

    W(s) = w(s) / U(s) = (1/Ke) / (Tm Te s^2 + Tm s + 1),   Te = L / R,   Tm = R J / (Kt Ke)

(joint 6: Te = 4.85e-5 s, Tm = 0.0248 s, 1/Ce = 1613 rpm/V). The thesis prints Tm = 0.2364 s:
that figure uses Ce in V/rpm as if it were V s/rad (a factor 60 / 2 pi = 9.55); in SI it is
0.0248 s, as the HEU thesis (ch. 5) says.

Inertia at the motor::

    J = J_rotor + J_reducer_input + k M_jj(q) / N^2

with ``M_jj(q)`` the diagonal of Pinocchio's joint-space mass matrix (armature excluded) over the
workspace: ``min`` and ``max`` over uniform random configurations in the joint ranges (with and
without the payload), ``nominal`` at the centre of the joint ranges with the payload (the thesis
tunes at the workspace centre, 5.3). The reducer's efficiency acts on the torque that
accelerates the arm, as in the drive-train model the simulation runs
(:meth:`armlab.robot.drives.Drive.load_inertia_at_motor_kg_m2`): the motor feels the arm as
``M_jj / (eta N^2)`` while it drives it and ``eta_b M_jj / N^2`` while the arm back-drives it.
The tuned range spans both: ``min`` uses ``k = eta_b`` with the smallest ``M_jj``, ``max``
``k = 1 / eta`` with the largest; ``nominal`` (and an inertia given as a number) is the ideal
gear, ``k = 1``.

Every other drive number of the plant (current limit, speed limit) is the joint's
:class:`~armlab.robot.drives.Drive`'s answer: the tuning and the simulation see the motor sizing
sized.

The compliant joint (two-mass plant, issue 28)
----------------------------------------------
With ``compliant=True`` and a reducer with stiffness data, the mechanics between the motor
current and the motor speed is the two-mass joint: the motor side ``J_M`` (rotor + reducer
input) and the arm ``J_L' = J - J_M`` (at the motor) coupled by the reducer's small-signal
stiffness ``K' = K1 / N^2`` (K1 at the output, the catalogue's first segment) and a damping
``c' = 2 zeta sqrt(K' J_M J_L' / (J_M + J_L'))``, ``zeta`` = :data:`RESONANCE_DAMPING_RATIO`
(ASSUMED 0.05: the catalogues give the hysteresis loss, not a damping)::

    J_M dw_M/dt = Kt i - B w_M - K' phi - c' (w_M - w_L)
    J_L' dw_L/dt = K' phi + c' (w_M - w_L),     dphi/dt = w_M - w_L

    w_M / i = Kt / (J_M s + B + Z J_L' s / (J_L' s + Z)),    Z = K' / s + c'

Undamped, its zeros are the anti-resonance ``sqrt(K1 / J_L)`` and its poles the resonance
``sqrt(K1 (J_M + J_L) / (J_M J_L))`` (joint-side inertias; Ellis, "Control System Design Guide",
ch. 16): :meth:`~armlab.robot.drives.Drive.anti_resonance_rad_s`,
:meth:`~armlab.robot.drives.Drive.first_resonance_rad_s`. The encoder is on the motor: the speed
and position loops close on ``w_M``; the current loop's back-EMF sees the total inertia (rigid:
the resonance enters the cascade through the speed loop).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from armlab._lazy import lazy_import
from armlab.errors import SpecError
from armlab.robot import rigid_body
from armlab.robot.drives import RPM_TO_RAD_S, Drive

if TYPE_CHECKING:
    import control as ct  # the real module for the type checker
else:
    ct = lazy_import("control")  # python-control loads at the first model built

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "JointPlant",
    "InertiaRange",
    "inertia_range",
    "joint_plant",
    "motor_speed_tf",
    "INERTIA_CASES",
]

INERTIA_CASES = ("min", "nominal", "max")

#: damping ratio of the two-mass joint's resonance (ASSUMED: catalogues give none)
RESONANCE_DAMPING_RATIO = 0.05


@dataclass(frozen=True)
class InertiaRange:
    """Arm inertia seen by each joint (mass-matrix diagonal, joint side, armature excluded).

    Attributes
    ----------
    joint_names : list of str
    min_kg_m2, nominal_kg_m2, max_kg_m2 : ndarray (n_joints,)
        In [kg m^2] at the joint.
    payload_kg : float
        Payload included in ``nominal`` and ``max``.
    n_samples, seed : int
        Random configurations used.
    """

    joint_names: list
    min_kg_m2: np.ndarray
    nominal_kg_m2: np.ndarray
    max_kg_m2: np.ndarray
    payload_kg: float
    n_samples: int
    seed: int

    def of(self, joint_index: int) -> dict[str, float]:
        return {
            "min": float(self.min_kg_m2[joint_index]),
            "nominal": float(self.nominal_kg_m2[joint_index]),
            "max": float(self.max_kg_m2[joint_index]),
        }


def _mass_diag(robot, Q: np.ndarray) -> np.ndarray:
    """Diagonal of the rigid-body mass matrix without armature, (n, n_joints) [kg m^2]."""
    M = rigid_body.mass_matrix(robot, Q)
    return np.diagonal(M, axis1=1, axis2=2) - robot.model.armature


def inertia_range(robot: Robot, *, n_samples: int = 400, seed: int = 0) -> InertiaRange:
    """Min / nominal / max of the mass-matrix diagonal over the workspace, in [kg m^2].

    Parameters
    ----------
    robot : Robot
    n_samples : int
        Uniform random configurations in the joint ranges (seeded); ``M_jj`` depends only on the
        outboard joints, so a few hundred samples bound it well. The extremes found are widened
        by nothing: the robust tuning adds its own margin.
    seed : int

    Returns
    -------
    InertiaRange
        ``min`` over the samples without payload and with it, ``max`` with the payload,
        ``nominal`` at the centre of the joint ranges with the payload.
    """
    rng = np.random.default_rng(seed)
    Q = robot.random_q(rng, n_samples)
    centre = robot.limits.centre_rad
    Q = np.vstack([centre, Q])
    with_payload = _mass_diag(robot, Q)
    empty = _mass_diag(robot.with_payload(0.0), Q) if robot.payload.mass_kg > 0 else with_payload
    return InertiaRange(
        joint_names=list(robot.joint_names),
        min_kg_m2=np.minimum(with_payload.min(0), empty.min(0)),
        nominal_kg_m2=with_payload[0],
        max_kg_m2=np.maximum(with_payload.max(0), empty.max(0)),
        payload_kg=float(robot.payload.mass_kg),
        n_samples=int(n_samples),
        seed=int(seed),
    )


def motor_speed_tf(
    motor, inertia_kg_m2: float | None = None, *, friction: bool = False
) -> ct.TransferFunction:
    """Thesis eq. 5-8: armature voltage [V] -> motor speed [rad/s], as a python-control TF.

    ``W(s) = Kt / ((L s + R)(J s + B) + Kt Ke)``; with B = 0 this is
    ``(1/Ke) / (Tm Te s^2 + Tm s + 1)``. ``inertia_kg_m2`` defaults to the rotor inertia.
    """
    J = motor.rotor_inertia_kg_m2 if inertia_kg_m2 is None else float(inertia_kg_m2)
    B = motor.viscous_friction_Nm_s_rad if friction else 0.0
    L, R, Kt, Ke = (
        motor.inductance_H,
        motor.resistance_ohm,
        motor.torque_constant_Nm_A,
        motor.back_emf_V_s_rad,
    )
    return ct.tf([Kt], [L * J, L * B + R * J, R * B + Kt * Ke], inputs="U_V", outputs="w_rad_s")


_REQUIRED = (
    "torque_constant_Nm_A",
    "back_emf_V_s_rad",
    "resistance_ohm",
    "inductance_H",
    "rotor_inertia_kg_m2",
    "supply_voltage_V",
)


@dataclass
class JointPlant:
    """One joint's drive at the motor shaft, with its inertia range.

    Attributes
    ----------
    joint : str
    drive : Drive
        The joint's drive (after study overrides): the one home of every drive number.
    ratio : float
        Reducer ratio N (motor / joint speed).
    Kt, Ke : float
        Torque constant [N m/A] and back-EMF constant [V s/rad].
    R, L : float
        Armature resistance [ohm] and inductance [H].
    B : float
        Viscous friction at the motor [N m s/rad].
    J_arm : dict
        Arm inertia at the joint [kg m^2] for ``min``/``nominal``/``max``.
    inertia : str or float
        The case this plant object stands for (its :attr:`J`).
    supply_voltage_V, current_limit_A, speed_limit_rad_s : float
        Amplifier voltage; current limit (:attr:`Drive.current_limit_A`: the derated peak
        torque / Kt, at most supply / R); max motor speed (:attr:`Drive.max_motor_speed_rad_s`:
        no-load speed and reducer input limit).
    payload_kg : float
    estimated : bool
        Motor constants ESTIMATED in drives.toml (not from the maker).
    compliant : bool
        The mechanics is the two-mass joint (module docstring) where the reducer gives its
        stiffness; False: the rigid joint.
    """

    joint: str
    drive: Drive
    ratio: float
    Kt: float
    Ke: float
    R: float
    L: float
    B: float
    J_arm: dict
    inertia: str | float = "nominal"
    supply_voltage_V: float = 24.0
    current_limit_A: float = math.inf
    speed_limit_rad_s: float = math.inf
    payload_kg: float = 0.0
    estimated: bool = False
    extra: dict = field(default_factory=dict)
    compliant: bool = False

    @classmethod
    def of_drive(
        cls,
        drive: Drive,
        J_arm: dict[str, float],
        *,
        inertia: str | float = "nominal",
        payload_kg: float = 0.0,
    ) -> JointPlant:
        """The plant of a drive (every number its answer) with the arm inertia range ``J_arm``
        (``min``/``nominal``/``max`` at the joint, in [kg m^2])."""
        motor, reducer = drive.motor, drive.reducer
        return cls(
            joint=drive.joint,
            drive=drive,
            ratio=float(reducer.ratio),
            Kt=motor.torque_constant_Nm_A,
            Ke=motor.back_emf_V_s_rad,
            R=motor.resistance_ohm,
            L=motor.inductance_H,
            B=float(motor.viscous_friction_Nm_s_rad or 0.0),
            J_arm=dict(J_arm),
            inertia=inertia,
            supply_voltage_V=drive.supply_voltage_V,
            current_limit_A=drive.current_limit_A,
            speed_limit_rad_s=drive.max_motor_speed_rad_s,
            payload_kg=float(payload_kg),
            estimated="ESTIMATED" in (motor.source or "").upper(),
        )

    # ------------------------------------------------------------------ inertia
    def J_motor(self, case: str | float | None = None) -> float:
        """Total inertia at the motor [kg m^2] for a case (``min``/``nominal``/``max``, the
        reducer efficiency included at the two ends: module docstring) or an arm inertia at the
        joint in [kg m^2] (float, ideal gear)."""
        case = self.inertia if case is None else case
        d = self.drive
        if not isinstance(case, str):
            return d.motor_side_inertia_kg_m2 + float(case) / self.ratio**2
        arm = self.J_arm[case]
        if case == "nominal":
            return d.motor_side_inertia_kg_m2 + arm / self.ratio**2
        return d.motor_side_inertia_kg_m2 + d.load_inertia_at_motor_kg_m2(
            arm, motoring=case == "max"
        )

    @property
    def J(self) -> float:
        """Total inertia at the motor for this plant's case, in [kg m^2]."""
        return self.J_motor()

    def cases(self) -> dict[str, float]:
        """Total motor inertia for min, nominal and max, in [kg m^2]."""
        return {c: self.J_motor(c) for c in INERTIA_CASES}

    def at(self, inertia: str | float) -> JointPlant:
        """The same drive at another inertia case."""
        from dataclasses import replace

        return replace(self, inertia=inertia)

    # ------------------------------------------------------------------ two-mass joint
    @property
    def two_mass(self) -> bool:
        """True when the plant is the two-mass joint: ``compliant`` and a reducer stiffness."""
        return self.compliant and math.isfinite(self.drive.small_signal_stiffness_Nm_rad)

    def two_mass_parameters(self, J: float) -> tuple[float, float, float, float]:
        """``(J_M, J_L', K', c')`` at the motor shaft for a total motor inertia ``J``."""
        jm = self.drive.motor_side_inertia_kg_m2
        jl = max(float(J) - jm, 1e-12 * jm)
        k = self.drive.small_signal_stiffness_Nm_rad / self.ratio**2
        c = 2.0 * RESONANCE_DAMPING_RATIO * math.sqrt(k * jm * jl / (jm + jl))
        return jm, jl, k, c

    def mechanics_response(self, w: np.ndarray, J) -> np.ndarray:
        """Motor current [A] -> motor speed [rad/s] at ``w`` [rad/s] for total motor inertias
        ``J`` (k,): ``Kt / (J s + B)`` rigid, the two-mass response (module docstring) when
        :attr:`two_mass`; (k, n)."""
        s = 1j * np.asarray(w, float)[None, :]
        Jc = np.asarray(J, float)[:, None]
        if not self.two_mass:
            return self.Kt / (Jc * s + self.B)
        rows = []
        for Jk in np.asarray(J, float):
            jm, jl, k, c = self.two_mass_parameters(Jk)
            z = k / s[0] + c
            rows.append(self.Kt / (jm * s[0] + self.B + z * jl * s[0] / (jl * s[0] + z)))
        return np.stack(rows)

    def mechanics_ss(self, J: float):
        """Motor current [A] -> motor speed [rad/s] as ``(A, B, C, D)``: one state ``w`` rigid,
        ``(w_M, phi, w_L)`` for the two-mass joint."""
        if not self.two_mass:
            return (
                np.array([[-self.B / J]]),
                np.ones((1, 1)),
                np.array([[self.Kt / J]]),
                np.zeros((1, 1)),
            )
        jm, jl, k, c = self.two_mass_parameters(J)
        A = np.array(
            [
                [-(self.B + c) / jm, -k / jm, c / jm],
                [1.0, 0.0, -1.0],
                [c / jl, k / jl, -c / jl],
            ]
        )
        B = np.array([[self.Kt / jm], [0.0], [0.0]])
        return A, B, np.array([[1.0, 0.0, 0.0]]), np.zeros((1, 1))

    def resonances_rad_s(self) -> dict[str, dict[str, float]]:
        """The joint's anti-resonance and first resonance in [rad/s] per inertia case
        (:meth:`~armlab.robot.drives.Drive.first_resonance_rad_s` of the arm inertia the case
        puts at the joint, ``J_L' N^2``); NaN without stiffness data."""
        out: dict[str, dict[str, float]] = {"anti": {}, "first": {}}
        for case in INERTIA_CASES:
            jl_joint = (self.J_motor(case) - self.drive.motor_side_inertia_kg_m2) * self.ratio**2
            jl_joint = max(jl_joint, 1e-12)
            out["anti"][case] = self.drive.anti_resonance_rad_s(jl_joint)
            out["first"][case] = self.drive.first_resonance_rad_s(jl_joint)
        return out

    # ------------------------------------------------------------------ time constants
    @property
    def Te(self) -> float:
        """Electrical time constant L / R in [s]."""
        return self.L / self.R

    @property
    def Tm(self) -> float:
        """Mechanical time constant R J / (Kt Ke) in [s] (thesis 5.4.1)."""
        return self.R * self.J / (self.Kt * self.Ke)

    @property
    def speed_per_volt_rpm(self) -> float:
        """Static gain 1/Ce in [rpm/V]."""
        return 1.0 / (self.Ke * RPM_TO_RAD_S)

    # ------------------------------------------------------------------ LTI models
    def voltage_to_current(self) -> ct.TransferFunction:
        """U [V] -> i [A] with the back-EMF loop: ``(J s + B) / ((L s + R)(J s + B) + Kt Ke)``."""
        J, B = self.J, self.B
        return ct.tf(
            [J, B],
            [self.L * J, self.L * B + self.R * J, self.R * B + self.Kt * self.Ke],
            inputs="U_V",
            outputs="i_A",
        )

    def current_to_speed(self) -> ct.TransferFunction:
        """i [A] -> motor speed w [rad/s]: ``Kt / (J s + B)``."""
        return ct.tf([self.Kt], [self.J, self.B], inputs="i_A", outputs="w_rad_s")

    def speed_to_position(self) -> ct.TransferFunction:
        """w [rad/s] -> motor angle [rad]: ``1 / s``."""
        return ct.tf([1.0], [1.0, 0.0], inputs="w_rad_s", outputs="theta_rad")

    def voltage_to_speed(self) -> ct.TransferFunction:
        """Thesis eq. 5-8 with friction, U [V] -> w [rad/s]:
        ``Kt / ((L s + R)(J s + B) + Kt Ke)``."""
        return ct.tf(
            [self.Kt],
            [
                self.L * self.J,
                self.L * self.B + self.R * self.J,
                self.R * self.B + self.Kt * self.Ke,
            ],
            inputs="U_V",
            outputs="w_rad_s",
        )

    def state_space(self) -> ct.StateSpace:
        """States (i, w, theta) at the motor; inputs (U [V], tau_L [N m]); outputs (i, w, theta)."""
        J, L = self.J, self.L
        A = [[-self.R / L, -self.Ke / L, 0.0], [self.Kt / J, -self.B / J, 0.0], [0.0, 1.0, 0.0]]
        Bm = [[1.0 / L, 0.0], [0.0, -1.0 / J], [0.0, 0.0]]
        return ct.ss(
            A,
            Bm,
            np.eye(3),
            np.zeros((3, 2)),
            inputs=["U_V", "tau_load_Nm"],
            outputs=["i_A", "w_rad_s", "theta_rad"],
            states=["i", "w", "theta"],
        )

    def summary(self) -> dict:
        """JSON-able summary for :class:`armlab.control.PlantSummary`."""
        return {
            "ratio": self.ratio,
            "inertia_motor_kg_m2": self.cases(),
            "inertia_joint_kg_m2": dict(self.J_arm),
            "payload_kg": self.payload_kg,
            "torque_constant_Nm_A": self.Kt,
            "back_emf_V_s_rad": self.Ke,
            "resistance_ohm": self.R,
            "inductance_H": self.L,
            "estimated": self.estimated,
            "compliant": self.two_mass,
            **{f"{k}_resonance_rad_s": v for k, v in self.resonances_rad_s().items()},
        }


def joint_plant(
    robot: Robot,
    joint,
    *,
    inertia: str | float = "nominal",
    inertias: InertiaRange | None = None,
    n_samples: int = 400,
    seed: int = 0,
) -> JointPlant:
    """The drive of one joint as a :class:`JointPlant` (python-control LTI models on demand).

    Parameters
    ----------
    robot : Robot
        With drives (drives.toml); payload taken from the robot.
    joint : str or int
        Joint name or 1-based number.
    inertia : {"nominal", "min", "max"} or float
        The case the plant's :attr:`JointPlant.J` stands for; a float is an arm inertia at the
        joint in [kg m^2].
    inertias : InertiaRange, optional
        Precomputed :func:`inertia_range` (shared by all joints of a robot).
    n_samples, seed : int
        For :func:`inertia_range` when ``inertias`` is None.

    Raises
    ------
    SpecError
        No drives, or a motor constant missing, zero or not finite (names joint and field).
    """
    j = robot.joint_index(joint)
    name = robot.joint_names[j]
    if robot.drives is None or name not in robot.drives:
        raise SpecError(
            f"{name}: no drive data (drives.toml) for robot {robot.name!r}: "
            f"cannot build the servo plant"
        )
    drive = robot.drives[name]
    motor, reducer = drive.motor, drive.reducer
    for f in _REQUIRED:
        v = getattr(motor, f, None)
        if v is None or not math.isfinite(float(v)) or float(v) <= 0.0:
            raise SpecError(f"{name}: motor data {f} = {v!r} is missing or not > 0 (drives.toml)")
    if not (math.isfinite(reducer.ratio) and reducer.ratio > 0):
        raise SpecError(f"{name}: reducer ratio = {reducer.ratio!r} is missing or not > 0")
    if isinstance(inertia, str) and inertia not in INERTIA_CASES:
        raise SpecError(
            f"{name}: inertia must be one of {INERTIA_CASES} or a float, got {inertia!r}"
        )
    if not isinstance(inertia, str) and not (math.isfinite(float(inertia)) and float(inertia) >= 0):
        raise SpecError(f"{name}: inertia = {inertia!r} must be >= 0 [kg m^2]")
    rng = inertias if inertias is not None else inertia_range(robot, n_samples=n_samples, seed=seed)
    return JointPlant.of_drive(drive, rng.of(j), inertia=inertia, payload_kg=rng.payload_kg)
