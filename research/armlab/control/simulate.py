"""Closed-loop simulation of all joints' cascades on the nonlinear arm (Pinocchio ABA).

What runs each servo period T (1 ms, the card of the SHU controller paper, §1), all joints at
once (vectorised):

1. encoder: ``theta_m = floor(N q counts_per_rad) / counts_per_rad`` (motor side, x4 decoding);
   speed ``w_m = (theta_m,k - theta_m,k-1) / T``;
2. position loop (incremental P/PI/PID): ``w* = C_p(N q_d - theta_m) [+ N qd_d]``, limited to the
   motor's speed limit;
3. speed loop (incremental PI): ``i* = C_w(w* - w_m) + i_ff``, limited to the peak current, then
   the 12-bit +-10 V D/A (``quantise=True``); the value is applied one period later (the
   computation delay the tuning assumed);
4. current loop (amplifier, 20 kHz in reality): its **closed-loop continuous model** with the
   back-EMF, ``L di/dt = kp (i* - i) + x_I - R i - Ke w``, ``dx_I/dt = ki (i* - i)``, integrated
   exactly (matrix exponential) over the period with i* and w held, giving the period's mean
   current; the supply voltage limits the current to ``(+-U - Ke w) / R``;
5. arm: ``tau = N (Kt i_mean - B N qd)`` and Pinocchio's ABA on a copy of the model whose
   ``armature`` holds the reflected rotor + reducer inertia ``(J_rotor + J_reducer) N^2``;
   ``q += qd T + qdd T^2 / 2``, ``qd += qdd T`` (exact for the period's constant acceleration).

Why the current loop is not sub-stepped: its crossover is ~10^4 rad/s (period 50 us), it settles
in < 0.5 ms, i.e. inside one 1 ms period, and it is 30-40 x faster than the speed loop; the
exact integration of its linear closed loop keeps its lag and its back-EMF coupling at the
1 kHz rate while the 20 kHz sampling itself (a 75 us lag) is negligible for the outer loops.
Sub-stepping it would cost 20 ABA calls per period; this way one ABA per period is enough and
six joints run at well over 10 x real time.

Feed-forward (thesis 5.2), any combination of:
``"velocity"`` (w* += N qd_d), ``"acceleration"`` (i_ff += J_nominal N qdd_d / Kt),
``"gravity"`` (i_ff += g(q_d) / (N Kt)), ``"friction"`` (viscous), ``"computed_torque"``
(i_ff = (M(q_d) qdd_d + C qd_d + g + armature + viscous) / (N Kt): the model-based
``tau = D(q) qdd_d + C + F + G`` of thesis 5.2 with the feedback left to the cascade).

Positioning accuracy: the thesis' Monte-Carlo accuracy analysis (HEU thesis, ch. 3) concludes
that about 1 mm total is achievable; the servo is given half of that budget
(:data:`SERVO_SHARE`), the rest being geometric errors, reducer backlash and compliance. A
tracking simulation passes when its TCP error stays within 0.5 mm along the whole motion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin
from scipy.linalg import expm

from armlab.control.discrete import IncrementalPID
from armlab.control.gains import ArmGains, CascadeGains
from armlab.errors import InputError
from armlab.robot import rigid_body

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "TrackingResult",
    "simulate_tracking",
    "POSITIONING_ACCURACY_M",
    "SERVO_SHARE",
    "FEEDFORWARDS",
]

#: Total positioning accuracy the thesis' Monte-Carlo analysis finds achievable, in [m].
POSITIONING_ACCURACY_M = 1.0e-3
#: Share of that budget given to the servo tracking error.
SERVO_SHARE = 0.5
FEEDFORWARDS = ("velocity", "acceleration", "gravity", "friction", "computed_torque")


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
        Mean motor current over each period in [A].
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

    def to_dict(self) -> dict:
        """summary.json "tracking": per joint max_error_rad; tcp max_error_m (+ context)."""
        return {
            "joints": {
                n: {"max_error_rad": float(e), "final_error_rad": float(f)}
                for n, e, f in zip(
                    self.joint_names, self.max_error_rad, self.final_error_rad, strict=True
                )
            },
            "tcp": {
                "max_error_m": self.tcp_max_error_m,
                "final_error_m": float(self.tcp_error_m[-1]),
                "accuracy_m": self.accuracy_m,
                "within_accuracy": self.within_accuracy,
            },
            "feedforward": list(self.feedforward),
            "duration_s": float(self.t[-1] - self.t[0]),
            "sample_time_s": float(self.t[1] - self.t[0]) if self.t.size > 1 else math.nan,
            "quantise": bool(self.meta.get("quantise", True)),
        }


def _feedforwards(feedforward) -> tuple[str, ...]:
    if feedforward is None or feedforward == "none":
        return ()
    ff = (feedforward,) if isinstance(feedforward, str) else tuple(feedforward)
    bad = [f for f in ff if f not in FEEDFORWARDS]
    if bad:
        raise InputError(f"unknown feedforward {bad}; choose from {FEEDFORWARDS} or 'none'")
    return ff


def _cascades(robot, gains) -> list[CascadeGains]:
    if isinstance(gains, ArmGains):
        table = gains.joints
    elif isinstance(gains, dict):
        table = gains
    else:
        raise InputError("gains must be ArmGains or a dict of joint name -> CascadeGains")
    missing = [n for n in robot.joint_names if n not in table]
    if missing:
        raise InputError(f"no gains for joints {missing}")
    return [table[n] for n in robot.joint_names]


def simulate_tracking(
    robot: Robot,
    trajectory,
    gains,
    *,
    feedforward=("velocity",),
    quantise: bool = True,
    t_after_s: float = 0.2,
    accuracy_m: float | None = None,
    tcp: bool = True,
) -> TrackingResult:
    """Simulate every joint's cascade tracking ``trajectory`` on the nonlinear arm.

    Parameters
    ----------
    robot : Robot
        With drives; its model (payload included) is copied and given the armature.
    trajectory : Trajectory
        Set-points, evaluated at the servo period of the gains (speed loop sample time).
    gains : ArmGains or dict of str to CascadeGains
    feedforward : str or iterable of str
        Subset of :data:`FEEDFORWARDS`, or ``"none"``.
    quantise : bool
        12-bit D/A and encoder quantisation.
    t_after_s : float
        Time simulated after the trajectory ends (settling), in [s].
    accuracy_m : float, optional
        TCP tolerance; default ``POSITIONING_ACCURACY_M * SERVO_SHARE`` (0.5 mm).
    tcp : bool
        Compute the TCP error (forward kinematics of every sample).

    Returns
    -------
    TrackingResult
    """
    from time import perf_counter

    if robot.drives is None:
        raise InputError(f"{robot.name}: no drives (drives.toml): cannot simulate the servo")
    if trajectory.n_joints != robot.n_joints:
        raise InputError(
            f"trajectory has {trajectory.n_joints} joints, robot {robot.name} has {robot.n_joints}"
        )
    ff = _feedforwards(feedforward)
    cas = _cascades(robot, gains)
    T = cas[0].speed.sample_time_s
    for g in cas:
        for lg in (g.speed, g.position):
            if abs(lg.sample_time_s - T) > 1e-12:
                raise InputError(
                    f"{g.joint}: {lg.loop} loop sample time {lg.sample_time_s} s "
                    f"differs from {T} s: one servo period for all joints"
                )
    nj = robot.n_joints
    drives = [robot.drives[n] for n in robot.joint_names]
    N = np.array([d.reducer.ratio for d in drives], float)
    Kt = np.array([d.motor.torque_constant_Nm_A for d in drives])
    Ke = np.array([d.motor.back_emf_V_s_rad for d in drives])
    R = np.array([d.motor.resistance_ohm for d in drives])
    L = np.array([d.motor.inductance_H for d in drives])
    Bm = np.array([d.motor.viscous_friction_Nm_s_rad or 0.0 for d in drives])
    U = np.array([d.motor.supply_voltage_V for d in drives])
    cpr = np.array([d.encoder.pulses_per_rev * d.encoder.decoding / (2 * math.pi) for d in drives])
    J_rot = np.array(
        [d.motor.rotor_inertia_kg_m2 + (d.reducer.inertia_kg_m2 or 0.0) for d in drives]
    )
    per_volt = np.array([g.speed.output_per_volt or (g.speed.output_max / 10.0) for g in cas])
    da_range = cas[0].speed.da_range_V
    da_bits = cas[0].speed.da_bits

    model = robot.model.copy()  # gravity in the base frame, as robot.model's
    model.armature = J_rot * N**2
    data = model.createData()
    # rigid_body evaluates robot.model: add the armature the simulated model has on top of it
    d_armature = model.armature - robot.model.armature

    # ---------------------------------------------------------------- set-points
    t_end = trajectory.t[0] + trajectory.duration + max(0.0, t_after_s)
    n = int(math.floor((t_end - trajectory.t[0]) / T + 1e-9)) + 1
    t = trajectory.t[0] + T * np.arange(n)
    q_d, qd_d, qdd_d, _ = trajectory.at(t)
    i_ff = np.zeros((n, nj))
    if ff:
        if "computed_torque" in ff:
            tau = rigid_body.inverse_dynamics(robot, q_d, qd_d, qdd_d) + d_armature * qdd_d
            tau += Bm * N**2 * qd_d
            i_ff += tau / (N * Kt)
        else:
            if "gravity" in ff:
                i_ff += rigid_body.gravity_torques(robot, q_d) / (N * Kt)
            if "acceleration" in ff:
                Jn = np.array(
                    [
                        c.plant.inertia_motor_kg_m2["nominal"] if c.plant else J_rot[j]
                        for j, c in enumerate(cas)
                    ]
                )
                i_ff += Jn * N * qdd_d / Kt
            if "friction" in ff:
                i_ff += Bm * N * qd_d / Kt
    w_ff = N * qd_d if ("velocity" in ff or "computed_torque" in ff) else np.zeros((n, nj))

    # ---------------------------------------------------------------- controllers
    # incremental PIDs, u = sat(u1 + q0 e + q1 e1 + q2 e2) + u_ff (thesis ch. 5)
    pos = IncrementalPID.from_gains([g.position for g in cas])
    spd = IncrementalPID.from_gains([g.speed for g in cas])
    kp_i = np.array([g.current.kp for g in cas])
    ki_i = np.array([g.current.ki for g in cas])
    # exact discretisation of the closed current loop, per joint states (i, x_I, int i) and
    # inputs (i*, w_m = N v): coef[r, c, j] maps S = (i, x_I, i*, v) of joint j to
    # r = (i_next, x_I_next, mean current over the period); an elementwise product and a sum
    # update all joints (no BLAS call in the loop: tiny BLAS calls cost more than they do)
    coef = np.zeros((3, 4, nj))
    for j in range(nj):
        A = np.array(
            [[-(kp_i[j] + R[j]) / L[j], 1.0 / L[j], 0.0], [-ki_i[j], 0.0, 0.0], [1.0, 0.0, 0.0]]
        )
        B = np.array([[kp_i[j] / L[j], -Ke[j] / L[j]], [ki_i[j], 0.0], [0.0, 0.0]])
        M = np.zeros((5, 5))
        M[:3, :3], M[:3, 3:] = A * T, B * T
        E = expm(M)
        coef[:, :2, j] = E[:3, :2]
        coef[:, 2, j] = E[:3, 3]
        coef[:, 3, j] = E[:3, 4] * N[j]
        coef[2, :, j] /= T  # integral of i over the period -> mean current

    # ---------------------------------------------------------------- initial state
    q = q_d[0].copy()
    v = qd_d[0].copy()
    g0 = rigid_body.gravity_torques(robot, q)
    i_hold = (g0 + Bm * N**2 * v) / (N * Kt)
    i_cmd = i_hold.copy()  # applied during the first period
    S = np.zeros((4, nj))  # (i, x_I, i*, v) of every joint
    S[0] = i_hold
    S[1] = R * i_hold + Ke * N * v
    spd.reset(u0=i_hold - i_ff[0])
    th_prev = N * q
    if quantise:
        th_prev = np.floor(th_prev * cpr) / cpr
    Nq_d = N * q_d
    inv_cpr = 1.0 / cpr
    inv_T = 1.0 / T
    da_scale = 2**da_bits / (2 * da_range)
    da_lsb = 1.0 / da_scale
    v_lo, v_hi = -da_range, da_range - da_lsb
    inv_pv = 1.0 / per_volt
    U_R, Ke_R = U / R, Ke * N / R  # voltage limit on the current: +-U/R - Ke N v/R
    NKt, NBmN = N * Kt, N * Bm * N
    hT2 = 0.5 * T * T

    out_q = np.empty((n, nj))
    out_v = np.empty((n, nj))
    out_i = np.empty((n, nj))
    out_da = np.empty((n, nj))
    aba = pin.aba
    pos_step, spd_step = pos.step, spd.step
    mn, mx, floor, rint = np.minimum, np.maximum, np.floor, np.rint
    t0 = perf_counter()
    for k in range(n):
        out_q[k] = q
        out_v[k] = v
        th = N * q
        if quantise:
            th = floor(th * cpr) * inv_cpr
        w_meas = (th - th_prev) * inv_T
        th_prev = th
        # position loop -> speed set-point (+ velocity feed-forward), speed loop -> current
        # set-point (+ current feed-forward); both limited, without windup
        w_star = pos_step(Nq_d[k] - th, w_ff[k])
        volts = spd_step(w_star - w_meas, i_ff[k]) * inv_pv
        if quantise:
            volts = mn(mx(rint(volts * da_scale) * da_lsb, v_lo), v_hi)
        out_da[k] = volts
        # current loop over the period with the previous command (computation delay)
        S[2] = i_cmd
        S[3] = v
        nxt = (coef * S).sum(axis=1)
        i_hi = U_R - Ke_R * v
        i_lo = i_hi - 2.0 * U_R
        i_mean = mn(mx(nxt[2], i_lo), i_hi)
        S[0] = mn(mx(nxt[0], i_lo), i_hi)
        S[1] = mn(mx(nxt[1], -U), U)  # amplifier PI anti-windup
        out_i[k] = i_mean
        i_cmd = volts * per_volt
        # arm
        a = aba(model, data, q, v, NKt * i_mean - NBmN * v)
        q = q + v * T + hT2 * a
        v = v + a * T
    wall = perf_counter() - t0
    if not np.all(np.isfinite(out_q)):
        raise InputError("simulation diverged (non-finite joint positions): check the gains")
    tcp_err = np.full(n, np.nan)
    if tcp:
        from armlab.kinematics import fk_batch

        p_ref = fk_batch(robot, q_d)[:, :3, 3]
        p = fk_batch(robot, out_q)[:, :3, 3]
        tcp_err = np.linalg.norm(p - p_ref, axis=1)
    acc = POSITIONING_ACCURACY_M * SERVO_SHARE if accuracy_m is None else float(accuracy_m)
    return TrackingResult(
        t=t,
        q_ref=q_d,
        q=out_q,
        qd=out_v,
        current_A=out_i,
        da_V=out_da,
        tcp_error_m=tcp_err,
        joint_names=list(robot.joint_names),
        feedforward=ff,
        accuracy_m=acc,
        wall_time_s=wall,
        meta={"quantise": quantise, "n_steps": n},
    )
