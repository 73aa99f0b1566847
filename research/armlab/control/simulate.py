"""Closed-loop simulation of all joints' cascades on the nonlinear arm, like the drive hardware.

What runs each servo period ``T`` (the controller profile's ``servo_period_s``: 1 ms on the card
of the SHU controller paper, §1), all joints at once (vectorised):

1. encoder: ``theta_m = floor(theta counts_per_rad) / counts_per_rad`` on the motor shaft, with
   the profile's decoding (:meth:`armlab.robot.controller.ControllerProfile.counts_per_rad`);
   speed ``w_m = (theta_m,k - theta_m,k-1) / T``;
2. position loop (incremental P/PI/PID): ``w* = C_p(N q_d - theta_m) [+ N qd_d]``, limited to the
   motor's speed limit;
3. speed loop (incremental PI): ``i* = C_w(w* - w_m) + i_ff``, limited to the peak current, then
   the profile's D/A (``dac_bits`` over ``+-dac_range_V``; ``quantise=True``); the value reaches
   the amplifier one period later (the computation delay the tuning assumed);
4. current loop (amplifier): the tuned **discrete** PI at its own sample time (50 us, 20 kHz),
   with its computation delay, run ``T / T_i`` times per servo period; its output voltage is
   limited to the supply ``+-U`` (``voltage_limit=True``) -- the incremental form's saturation is
   the anti-windup the tuner assumed (:mod:`armlab.control.discrete`). The armature circuit
   ``L di/dt = u - R i - Ke w_m`` is integrated exactly over each sub-step (``u`` held by the
   PWM, ``w_m`` held over the servo period): the back-EMF eats the voltage the current needs;
5. drive train (``losses=True``): the motor torque ``Kt i`` reaches the joint through
   :mod:`armlab.robot.drivetrain` -- motor viscous friction, reducer efficiency by quadrant
   (motoring ``eta``, back-driven ``1/eta_b`` at any back-driving speed: the physical
   reducer, whose holding band at rest contains the drive model's passage through standstill,
   :func:`~armlab.robot.drivetrain.quadrant_share`), joint Coulomb and viscous friction. The
   rotor
   inertia is solved implicitly: the Pinocchio model gets the armature ``k J N^2`` with
   ``k = eta`` (motoring) to ``1/eta_b`` (back-driven), the torque ``k N (T_m - b_m w_m) -
   tau_f`` -- the same equation as :func:`~armlab.robot.drivetrain.joint_torque_delivered`,
   solved for the acceleration (an explicit rotor term would be unstable: the reflected rotor
   inertia is up to 15 x the arm's). At rest the reducer's static friction holds: the joint
   gets the torque it needs to stay put (its bias torque ``C qd + g``) if that lies inside the
   band the reducer can transmit, ``[eta N T, N T / eta_b] -+ F_c``, else the nearer edge; for
   ``|qd| < v_s`` the torque blends linearly from that to the moving one (a regularised
   stiction; ``v_s`` is the speed the difference stops in one period, so the explicit step
   stays stable);
6. arm: Pinocchio's ABA; ``q += qd T + qdd T^2 / 2``, ``qd += qdd T``.

Where the efficiency applies matters: the torque that accelerates the rotor never passes the
reducer's mesh. On the demo cycle, applying ``eta`` to the whole motor torque instead would
give a TCP error of 0.54 mm instead of 0.37 mm (measured for issue 14).

Speed: sub-steps in which no joint's amplifier reaches its supply are linear in the state at
their start; the simulation jumps over them with precomputed maps
(:func:`armlab.control.amplifier.linear_period`) and
runs the 20 kHz sub-steps one by one only from a sub-step that saturates (the same result to
round-off, ``tests/control/test_simulation_hw.py``). The drive-model variants of one motion
(:func:`tracking_variants`) run in one time loop, every operation element-wise over the
variants' joints laid end to end, each variant jumping over its own linear sub-steps: each gets,
bit for bit, what it gets alone; on the demo cycle three variants take 1.43 s of CPU together
against 3.0 s apart, and one run 0.79 s against 1.0 s before (measured, loaded machine).

``losses=False, voltage_limit=False`` is the ideal drive (no efficiency, no friction besides the
motor's viscous term, an amplifier with unlimited voltage): the model of the simulation before
issue 14, kept to measure what each effect costs.

Feed-forward (thesis 5.2), any combination of:
``"velocity"`` (w* += N qd_d), ``"acceleration"`` (nominal arm inertia x qdd_d at the joint and
the rotor's ``J N qdd_d`` at the motor), ``"gravity"`` (g(q_d) at the joint), ``"friction"``
(the drive-train friction: joint Coulomb + viscous, motor viscous), ``"efficiency"`` (the joint
torque of the other terms goes through the reducer's efficiency by quadrant,
:func:`~armlab.robot.drivetrain.motor_torque`, instead of ``/ N``), ``"computed_torque"``
(``tau = D(q) qdd_d + C + G`` of thesis 5.2 at the joint + the rotor's inertia, the feedback left
to the cascade).

Positioning accuracy: the thesis' Monte-Carlo accuracy analysis (HEU thesis, ch. 3) concludes
that about 1 mm total is achievable; the servo is given half of that budget
(:data:`SERVO_SHARE`), the rest being geometric errors, reducer backlash and compliance. A
tracking simulation passes when its TCP error stays within 0.5 mm along the whole motion.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from armlab.control import amplifier
from armlab.control.discrete import IncrementalPID
from armlab.control.feedforward import feedforward_current, feedforwards
from armlab.control.gains import ArmGains, CascadeGains
from armlab.control.result import POSITIONING_ACCURACY_M, SERVO_SHARE, TrackingResult
from armlab.errors import InputError
from armlab.robot import drivetrain as dtm
from armlab.robot import rigid_body
from armlab.robot.controller import ControllerProfile, load_profile

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["simulate_tracking"]


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


def _whole(x: float, what: str) -> int:
    k = int(round(x))
    if k < 0 or abs(x - k) > 1e-6:
        raise InputError(f"{what} must be a whole number >= 0, got {x}")
    return k


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
    controller: ControllerProfile | str,
    voltage_limit: bool = True,
    losses: bool = True,
    compliant: bool = False,
) -> TrackingResult:
    """Simulate every joint's cascade tracking ``trajectory`` on the nonlinear arm.

    Parameters
    ----------
    robot : Robot
        With drives; its model (payload included) is copied and given the rotor armature.
    trajectory : Trajectory
        Set-points, evaluated at the servo period.
    gains : ArmGains or dict of str to CascadeGains
        Tuned at the controller's servo period (checked).
    feedforward : str or iterable of str
        Subset of :data:`armlab.control.feedforward.FEEDFORWARDS`, or ``"none"``.
    quantise : bool
        The profile's D/A resolution and the encoder's counts.
    t_after_s : float
        Time simulated after the trajectory ends (settling), in [s].
    accuracy_m : float, optional
        TCP tolerance; default ``POSITIONING_ACCURACY_M * SERVO_SHARE`` (0.5 mm).
    tcp : bool
        Compute the TCP error (forward kinematics of every sample).
    controller : ControllerProfile or str
        The joint controller the gains were tuned for (:func:`armlab.robot.load_profile`):
        servo period, D/A and encoder decoding; recorded in :attr:`TrackingResult.model`.
    voltage_limit : bool
        Limit the amplifier's output to the supply voltage (with the back-EMF).
    losses : bool
        Reducer efficiency and friction of the drive-train model.
    compliant : bool
        The compliant joint: motor and link coupled by the reducer's spring (and hysteresis)
        where the reducer gives its stiffness (:mod:`armlab.control.compliant`); default False,
        the rigid joint.

    Returns
    -------
    TrackingResult

    Raises
    ------
    InputError
        No drives, wrong joint count, unknown feed-forward, gains tuned at another servo period
        than the controller's, a current-loop period that does not divide the servo period.
    """
    variant = (feedforwards(feedforward), bool(voltage_limit), bool(losses))
    return _simulate_many(
        robot,
        trajectory,
        gains,
        [variant],
        quantise=quantise,
        t_after_s=t_after_s,
        accuracy_m=accuracy_m,
        tcp=tcp,
        controller=controller,
        compliant=compliant,
    )[0]


def _simulate_many(
    robot: Robot,
    trajectory,
    gains,
    variants: list[tuple[tuple[str, ...], bool, bool]],
    *,
    quantise: bool = True,
    t_after_s: float = 0.2,
    accuracy_m: float | None = None,
    tcp: bool = True,
    controller: ControllerProfile | str,
    compliant: bool = False,
) -> list[TrackingResult]:
    """:func:`simulate_tracking` of one motion under several ``(feedforward, voltage_limit,
    losses)`` variants, simulated together (:func:`_run_variants`): each result is the one
    :func:`simulate_tracking` gives for that variant alone."""
    if robot.drives is None:
        raise InputError(f"{robot.name}: no drives (drives.toml): cannot simulate the servo")
    if trajectory.n_joints != robot.n_joints:
        raise InputError(
            f"trajectory has {trajectory.n_joints} joints, robot {robot.name} has {robot.n_joints}"
        )
    cas = _cascades(robot, gains)
    prof = load_profile(controller)
    T = float(prof.servo_period_s)
    for g in cas:
        for lg in (g.speed, g.position):
            if abs(lg.sample_time_s - T) > 1e-12:
                raise InputError(
                    f"{g.joint}: {lg.loop} loop tuned at {lg.sample_time_s:g} s, controller "
                    f"{prof.name!r} servo_period_s is {T:g} s: retune at the servo period"
                )
    Ti = cas[0].current.sample_time_s
    n_sub = _whole(T / Ti, f"servo period / current-loop sample time ({T:g} / {Ti:g})")
    if n_sub < 1 or any(abs(g.current.sample_time_s - Ti) > 1e-15 for g in cas):
        raise InputError("every joint's current loop must share one sample time <= servo period")
    d_cur = [_whole(g.current.delay_samples, f"{g.joint} current delay_samples") for g in cas]
    # variants with and without the voltage limit part ways at every saturating sub-step:
    # each group runs in its own loop, in step within it
    raws: dict[int, dict] = {}
    for limited in (True, False):
        group = [k for k, v in enumerate(variants) if v[1] == limited]
        if group:
            runs = _run_variants(
                robot,
                trajectory,
                cas,
                prof,
                [variants[k] for k in group],
                quantise=quantise,
                t_after_s=t_after_s,
                n_sub=n_sub,
                d_cur=d_cur,
                compliant=compliant,
            )
            raws.update(zip(group, runs, strict=True))
    p_ref = None  # the set-points' tool positions: one for every variant
    if tcp:
        from armlab.kinematics import fk_batch

        p_ref = fk_batch(robot, raws[0]["q_ref"])[:, :3, 3]
    return [
        _result(robot, raws[k], prof, controller, quantise, p_ref, accuracy_m)
        for k in range(len(variants))
    ]


def _result(robot, raw: dict, prof, controller, quantise, p_ref, accuracy_m) -> TrackingResult:
    """The :class:`TrackingResult` of one run of :func:`_run_variants`; ``p_ref``: the tool
    positions of the set-points (None: no TCP error)."""
    q_d, out_q = raw["q_ref"], raw["q"]
    n = out_q.shape[0]
    if not np.all(np.isfinite(out_q)):
        raise InputError("simulation diverged (non-finite joint positions): check the gains")
    tcp_err = np.full(n, np.nan)
    if p_ref is not None:
        from armlab.kinematics import fk_batch

        p = fk_batch(robot, out_q)[:, :3, 3]
        tcp_err = np.linalg.norm(p - p_ref, axis=1)
    acc = POSITIONING_ACCURACY_M * SERVO_SHARE if accuracy_m is None else float(accuracy_m)
    return TrackingResult(
        t=raw["t"],
        q_ref=q_d,
        q=out_q,
        qd=raw["qd"],
        current_A=raw["current_A"],
        da_V=raw["da_V"],
        tcp_error_m=tcp_err,
        joint_names=list(robot.joint_names),
        feedforward=raw["feedforward"],
        accuracy_m=acc,
        wall_time_s=raw["wall_time_s"],
        meta={"quantise": quantise, "n_steps": n},
        voltage_V=raw["voltage_V"],
        saturated_share=raw["saturated_share"],
        peak_voltage_demand_V=raw["peak_u"],
        peak_current_A=raw["peak_i"],
        supply_voltage_V=raw["supply_V"],
        model={
            "voltage_limit": raw["voltage_limit"],
            "losses": raw["losses"],
            "quantise": bool(quantise),
            "controller": prof.name,
            "controller_source": "given",  # controller= is required: no silent default
            "servo_period_s": float(prof.servo_period_s),
            "current_sample_time_s": raw["current_sample_time_s"],
            "dac_bits": int(prof.dac_bits),
            "dac_range_V": float(prof.dac_range_V),
            "compliant": raw["compliant"],
        },
    )


def _run_variants(
    robot, trajectory, cas, prof, variants, *, quantise, t_after_s, n_sub, d_cur, compliant=False
) -> list[dict]:
    """Simulate the same motion under several ``(feedforward, voltage_limit, losses)``
    variants in one time loop (module docstring); each variant's numbers are those it gets
    alone: every operation is element-wise over the variants' joints laid end to end (one
    flat array, the same shape everywhere: no broadcasting), the linear maps are the same
    products, and each variant jumps over its own linear sub-steps."""
    from time import perf_counter

    T = float(prof.servo_period_s)
    Ti = cas[0].current.sample_time_s
    nv, nj = len(variants), robot.n_joints
    nvj = nv * nj

    def flat(x) -> np.ndarray:  # a per-joint value for every variant's joints
        return np.tile(np.asarray(x, float), nv)

    dt = dtm.drive_train(robot)
    N_j = dt.ratio
    N, Kt, Ke = flat(N_j), flat(dt.torque_constant_Nm_A), flat(dt.back_emf_V_s_rad)
    R = flat(dt.resistance_ohm)
    L = flat([robot.drives[n].motor.inductance_H for n in robot.joint_names])
    U = dt.supply_voltage_V
    bm = flat(dt.viscous_Nm_s_rad)
    cpr = flat(prof.counts_per_rad(robot) / N_j)  # counts per motor radian
    per_volt = flat([g.speed.output_per_volt or (g.speed.output_max / 10.0) for g in cas])
    da_range, da_bits = float(prof.dac_range_V), int(prof.dac_bits)

    part = [slice(k * nj, (k + 1) * nj) for k in range(nv)]

    # ---------------------------------------------------------------- set-points
    t_end = trajectory.t[0] + trajectory.duration + max(0.0, t_after_s)
    n = int(math.floor((t_end - trajectory.t[0]) / T + 1e-9)) + 1
    t = trajectory.t[0] + T * np.arange(n)
    q_d, qd_d, qdd_d, _ = trajectory.at(t)
    i_ff = np.zeros((n, nvj))
    w_ff = np.zeros((n, nvj))
    for k, (ff, _, _) in enumerate(variants):
        if ff:
            i_ff[:, part[k]] = feedforward_current(robot, dt, cas, ff, q_d, qd_d, qdd_d)
        if "velocity" in ff or "computed_torque" in ff:
            w_ff[:, part[k]] = N_j * qd_d
    vlim = np.repeat([v[1] for v in variants], nj)
    loss = np.repeat([v[2] for v in variants], nj)

    # ---------------------------------------------------------------- controllers
    # incremental PIDs, u = sat(u1 + q0 e + q1 e1 + q2 e2) + u_ff (thesis ch. 5)
    def pid(loops) -> IncrementalPID:
        one = IncrementalPID.from_gains(loops)
        return IncrementalPID(*(flat(x) for x in (one.q0, one.q1, one.q2, one.lo, one.hi)))

    pos = pid([g.position for g in cas])
    spd = pid([g.speed for g in cas])
    cq0_j = np.array([g.current.q0 for g in cas])
    cq1_j = np.array([g.current.q1 for g in cas])
    cq2_j = np.array([g.current.q2 for g in cas])
    lo_j = np.maximum(np.array([g.current.output_min for g in cas]), -U)
    hi_j = np.minimum(np.array([g.current.output_max for g in cas]), U)
    # exact armature circuit over a current-loop sub-step of length Ti, u and w_m held:
    # i+ = x + (i - x) a, mean = x + (i - x) c, x = (u - Ke w_m) / R
    tau_e = L / R
    a_sub = np.exp(-Ti / tau_e)
    c_sub = tau_e / Ti * (1.0 - a_sub)
    d_arr = np.array(d_cur)
    one_delay = bool(np.all(d_arr == 1))
    # a servo period with no sub-step at the voltage limit is linear in the state at its start:
    # precomputed maps (amplifier.linear_period) replace the sub-step loop there
    fast = amplifier.LINEAR_PERIODS and one_delay
    if not fast and nv > 1:  # the sub-step loop below keeps one history: one variant at a time
        return [
            _run_variants(
                robot,
                trajectory,
                cas,
                prof,
                [v],
                quantise=quantise,
                t_after_s=t_after_s,
                n_sub=n_sub,
                d_cur=d_cur,
                compliant=compliant,
            )[0]
            for v in variants
        ]
    if fast:
        W_j = amplifier.linear_period(cq0_j, cq1_j, cq2_j, a_sub[:nj], c_sub[:nj], R[:nj], n_sub)
        W = np.tile(W_j, (nv, 1, 1, 1))
    else:
        W = np.zeros(0)

    # ---------------------------------------------------------------- initial state
    q = flat(q_d[0])
    v = flat(qd_d[0])
    g0 = flat(rigid_body.gravity_torques(robot, q_d[0]))
    w0 = N * v
    # the motor torque that holds or moves the arm at the start: at rest the reducer's static
    # friction holds any torque inside its loss band, the ideal one included (module docstring)
    tm0 = g0 / N + bm * w0
    tm_moving = flat(dtm.motor_torque(g0[None, :nj], qd_d[0][None], np.zeros((1, nj)), dt)[0][0])
    # at rest the controller starts from its feed-forward if the reducer holds with it
    b1, b2 = g0 * flat(dt.back_efficiency) / N, g0 / (N * flat(dt.efficiency))
    t_ff = Kt * i_ff[0]
    held = (t_ff >= np.minimum(b1, b2) - 1e-12) & (t_ff <= np.maximum(b1, b2) + 1e-12)
    tm0 = np.where(loss, np.where(v != 0.0, tm_moving, np.where(held, t_ff, tm0)), tm0)
    i = tm0 / Kt
    i_cmd = i.copy()  # applied during the first period
    amps = amplifier.Amplifiers(
        cq=(flat(cq0_j), flat(cq1_j), flat(cq2_j)),
        u_lo=np.where(vlim, flat(lo_j), -np.inf),
        u_hi=np.where(vlim, flat(hi_j), np.inf),
        R=R,
        a_sub=a_sub,
        c_sub=c_sub,
        W=W,
        d_arr=d_arr,
        fast=fast,
        n_sub=n_sub,
        nv=nv,
        nj=nj,
        i=i,
        u0=R * i + Ke * w0,  # the current PI's output that holds i
    )
    joints = _Joints(robot, dt, flat, nv, loss, T)
    soft = None
    if compliant:  # motor and link apart where the reducer is a spring (armlab.control.compliant)
        from armlab.control.compliant import CompliantJoints

        soft = CompliantJoints(robot, dt, flat, nv, loss, T, n_sub, q, g0)
    spd.reset(u0=i - i_ff[0])
    x0 = q if soft is None else soft.motor_angle(q)
    th_prev = N * (x0 - v * T)  # the reading one period before: the start speed is measured
    if quantise:
        th_prev = np.floor(th_prev * cpr) / cpr
    Nq_d = np.tile(N_j * q_d, (1, nv))
    inv_cpr = 1.0 / cpr
    inv_T = 1.0 / T
    da_scale = 2**da_bits / (2 * da_range)
    da_lsb = 1.0 / da_scale
    v_lo, v_hi = -da_range, da_range - da_lsb
    inv_pv = 1.0 / per_volt
    hT2 = 0.5 * T * T
    a_prev = np.zeros(nvj)

    out_q = np.empty((n, nvj))
    out_v = np.empty((n, nvj))
    out_i = np.empty((n, nvj))
    out_u = np.empty((n, nvj))
    out_sat = np.zeros((n, nvj))
    out_da = np.empty((n, nvj))
    pos_step, spd_step = pos.step, spd.step
    mn, mx, floor, rint = np.minimum, np.maximum, np.floor, np.rint
    inv_sub = 1.0 / n_sub
    t0 = perf_counter()
    for k in range(n):
        out_q[k] = q
        out_v[k] = v
        th = N * (q if soft is None else soft.motor_angle(q))
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
        # current loop at its own rate over the period, with the previous command
        # (computation delay of the speed loop); the back-EMF of the period's speed
        emf = Ke * (N * (v if soft is None else soft.motor_speed(v)))
        i_sum, u_sum, sat_n = amps.period(i_cmd, emf)
        i_mean = i_sum * inv_sub
        out_i[k] = i_mean
        out_u[k] = u_sum * inv_sub
        out_sat[k] = sat_n * inv_sub
        i_cmd = volts * per_volt
        if soft is not None:
            q, v = soft.period(i_mean, q, v)
            continue
        a = joints.acceleration(i_mean, q, v, a_prev)
        a_prev = a
        q = q + v * T + hT2 * a
        v = v + a * T
    wall = perf_counter() - t0
    return [
        {
            "t": t,
            "q_ref": q_d,
            "q": out_q[:, part[k]],
            "qd": out_v[:, part[k]],
            "current_A": out_i[:, part[k]],
            "da_V": out_da[:, part[k]],
            "voltage_V": out_u[:, part[k]],
            "saturated_share": out_sat[:, part[k]],
            "peak_u": amps.peak_u[part[k]],
            "peak_i": amps.peak_i[part[k]],
            "supply_V": U.copy(),
            "feedforward": variants[k][0],
            "voltage_limit": variants[k][1],
            "losses": variants[k][2],
            "wall_time_s": wall,
            "current_sample_time_s": Ti,
            "compliant": bool(compliant),
        }
        for k in range(nv)
    ]


class _Joints:
    """The drive trains and the arm of every variant: the motor current through the reducer
    to the joints (module docstring, step 5) and Pinocchio's ABA (step 6), one model per
    variant (its armature follows that variant's quadrant)."""

    def __init__(self, robot, dt, flat, nv, loss, T):
        nj = robot.n_joints
        self.N, self.Kt, self.bm = (
            flat(dt.ratio),
            flat(dt.torque_constant_Nm_A),
            flat(dt.viscous_Nm_s_rad),
        )
        self.Jm = flat(dt.inertia_motor_side_kg_m2)
        self.eta, self.eta_b = flat(dt.efficiency), flat(dt.back_efficiency)
        self.Fc, self.Fv = flat(dt.coulomb_friction_Nm), flat(dt.joint_viscous_Nm_s_rad)
        self.arm0_j = robot.model.armature.copy()
        self.refl_j = dt.reflected_inertia_kg_m2
        self.arm0, self.refl = flat(self.arm0_j), flat(self.refl_j)
        self.models = []
        for _ in range(nv):
            model = robot.model.copy()  # gravity in the base frame, as robot.model's
            model.armature = self.arm0_j + self.refl_j
            self.models.append((model, model.createData()))
        self.part = [slice(k * nj, (k + 1) * nj) for k in range(nv)]
        self.loss, self.T = loss, T
        self.lossy = [bool(x) for x in loss[::nj]]
        self.any_loss, self.all_loss = any(self.lossy), all(self.lossy)
        self.bias = np.zeros(nv * nj)

    def acceleration(self, i_mean, q, v, a_prev) -> np.ndarray:
        """Joint accelerations [rad/s^2] of the period's mean motor current ``i_mean`` [A] at
        ``q``, ``v`` (``a_prev``: the last period's, for the reducer's quadrant)."""
        N, Kt, bm, Jm, eta, eta_b = self.N, self.Kt, self.bm, self.Jm, self.eta, self.eta_b
        Fc, Fv, arm0, refl, arm0_j, refl_j = (
            self.Fc,
            self.Fv,
            self.arm0,
            self.refl,
            self.arm0_j,
            self.refl_j,
        )
        models, part, lossy, loss, bias, T = (
            self.models,
            self.part,
            self.lossy,
            self.loss,
            self.bias,
            self.T,
        )
        any_loss, all_loss = self.any_loss, self.all_loss
        aba, nle = pin.aba, pin.nonLinearEffects
        mn, mx, absf = np.minimum, np.maximum, np.abs
        nvj = N.size
        # drive train -> joint torque, the rotor inertia implicit in the armature
        t_in = Kt * i_mean - bm * (N * v)
        if any_loss:
            # quadrant of the reducer input torque left after the rotor's acceleration
            # the physical reducer: back-driven efficiency at any back-driving speed, static
            # friction at rest (below); the drive model's passage through rest
            # (drivetrain.quadrant_share) lies inside this holding band
            kq = np.where((t_in - Jm * N * a_prev) * v >= 0.0, eta, 1.0 / eta_b)
            moving = kq * N * t_in - Fv * v - Fc * np.sign(v)
            # at rest: static friction holds the torque the joint needs (bias, qdd = 0) if it
            # lies inside the band the reducer can transmit, [eta N T, N T / eta_b] -+ F_c
            b1, b2 = eta * N * t_in, N * t_in / eta_b
            for j, (model, data) in enumerate(models):
                if lossy[j]:
                    bias[part[j]] = nle(model, data, q[part[j]], v[part[j]])
            rest = mn(mx(bias, mn(b1, b2) - Fc), mx(b1, b2) + Fc) - Fv * v
            m_eff = arm0 + kq * refl + 1e-12
            v_s = mx(absf(moving - rest) * T / m_eff, 1e-9)
            fade = mn(absf(v) / v_s, 1.0)
            tau = rest + (moving - rest) * fade
            if not all_loss:
                tau = np.where(loss, tau, N * t_in)
            for j, (model, _) in enumerate(models):
                if lossy[j]:
                    model.armature = arm0_j + kq[part[j]] * refl_j
        else:
            tau = N * t_in
        a = np.empty(nvj)
        for j, (model, data) in enumerate(models):
            sl = part[j]
            a[sl] = aba(model, data, q[sl], v[sl], tau[sl])
        return a
