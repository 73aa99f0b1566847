r"""The compliant joint in the tracking simulation: motor and link coupled by the reducer's spring.

:func:`armlab.control.simulate_tracking` with ``compliant=True`` replaces, for every joint whose
reducer gives its torsional stiffness (``reducer.stiffness_Nm_rad``), the rigid drive train of
steps 5-6 of :mod:`armlab.control.simulate` by two bodies (joint units: the motor angle over
the ratio, ``x_m = theta_m / N``)::

    motor   J_M N dv_m/dt = Kt i - b_m N v_m - T_in(tau_s, v_m)
    spring  tau_s = S(x_m - q) + T_h
    link    M(q) qdd + C qd + g = tau_s - F_v qd - F_c sat(qd / v_c)     (Pinocchio)

* ``S`` is the catalogue's piecewise-linear spring (K1/K2/K3 with breakpoints T1/T2, Harmonic
  Drive "Torsional stiffness": :meth:`armlab.robot.drives.Reducer.spring_torque_Nm`);
* ``T_h`` the hysteresis, a stated simple model: one Maxwell-slip element of stiffness ``K1``
  that slips at ``+-K1 h / 2`` (``h`` = ``reducer.hysteresis_rad``, 0 when not given), so that
  the torque-windup loop is ``h`` wide at zero torque, as the catalogue's hysteresis loss;
  inside the loop the joint is stiffer (``2 K1``) -- the simplification this model makes;
* ``T_in`` the reducer's input torque of the output torque ``tau_s`` at the motor speed, with
  the efficiency by quadrant of the drive-train model
  (:func:`armlab.robot.drivetrain.reducer_input_torque`; ``tau_s / N`` without losses);
* joint Coulomb friction is regularised over ``v_c`` = 1 mrad/s (the rigid model's static
  friction band is not modelled here); joints without stiffness data stay rigid (their rotor in
  the link's armature, as the rigid model).

The encoder reads the motor (``N x_m``), the back-EMF follows the motor speed, the tool error is
the link's. Integration: the motor current is the servo period's mean (the amplifier's
sub-steps); the mechanics takes ``n_sub`` semi-implicit Euler steps per servo period (the
current loop's rate, 50 us on the reference card) with the link's inverse mass matrix and bias
torque ``C qd + g`` frozen over the period: the link-side resonances of teachbot6 reach
2700 rad/s, 0.13 rad per step.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from armlab.robot import drivetrain as dtm

__all__ = ["CompliantJoints", "COULOMB_BAND_RAD_S"]

#: joint speed over which the compliant model's Coulomb friction is regularised, rad/s (ASSUMED)
COULOMB_BAND_RAD_S = 1e-3


class CompliantJoints:
    """The two-body drive trains of every variant's joints, laid end to end (``flat``)."""

    def __init__(self, robot, dt, flat, nv: int, loss, T: float, n_sub: int, q0, tau0):
        nj = robot.n_joints
        self.drives = [robot.drives[n] for n in robot.joint_names]
        self.soft_j = np.array([d.reducer.stiffness_given for d in self.drives])
        self.soft = np.tile(self.soft_j, nv)
        self.N, self.Kt, self.bm = (
            flat(dt.ratio),
            flat(dt.torque_constant_Nm_A),
            flat(dt.viscous_Nm_s_rad),
        )
        self.Jm = flat(dt.inertia_motor_side_kg_m2)
        self.Fc, self.Fv = flat(dt.coulomb_friction_Nm), flat(dt.joint_viscous_Nm_s_rad)
        self.eta, self.eta_b = flat(dt.efficiency), flat(dt.back_efficiency)
        self.band = flat(dt.quadrant_band_rad_s)
        k1 = np.array(
            [
                d.small_signal_stiffness_Nm_rad if s else 0.0
                for d, s in zip(self.drives, self.soft_j, strict=True)
            ]
        )
        hyst = np.array(
            [
                d.reducer.hysteresis_rad if s and np.isfinite(d.reducer.hysteresis_rad) else 0.0
                for d, s in zip(self.drives, self.soft_j, strict=True)
            ]
        )
        self.k_h, self.f_h = flat(k1), flat(0.5 * k1 * hyst)
        self.loss = np.asarray(loss, bool)
        self.nv, self.nj, self.T, self.n_sub = nv, nj, T, n_sub
        self.h = T / n_sub
        self.part = [slice(k * nj, (k + 1) * nj) for k in range(nv)]
        # the rigid joints keep their rotor in the armature (motoring efficiency: ASSUMED for
        # the rigid joints of a compliant run); the compliant ones carry the arm only
        refl = np.where(self.soft_j, 0.0, dt.reflected_inertia_kg_m2)
        self.models = []
        for _ in range(nv):
            model = robot.model.copy()
            model.armature = robot.model.armature + refl / dt.efficiency
            self.models.append((model, model.createData()))
        # the spring curves as arrays (three segments; fewer padded with the last stiffness)
        t_bp, k_seg, th_bp = np.zeros((nj, 3)), np.zeros((nj, 3)), np.zeros((nj, 3))
        for j, d in enumerate(self.drives):
            if self.soft_j[j]:  # (rigid joints: all zero, a spring of no torque)
                t, k, th = d.reducer._segments()
                m = min(3, k.size)
                k_seg[j, :m], t_bp[j, :m], th_bp[j, :m] = k[:m], t[:m], th[:m]
                k_seg[j, m:], th_bp[j, m:] = k[m - 1], np.inf
        self.t_bp, self.k_seg, self.th_bp = (np.tile(x, (nv, 1)) for x in (t_bp, k_seg, th_bp))
        self.rows = np.arange(nv * nj)
        q0 = np.asarray(q0, float)
        # at the start the springs hold the start torque (wound up by it), the element unloaded
        self.x_m = q0 + np.where(self.soft, self._windup(np.asarray(tau0, float)), 0.0)
        self.v_m = np.zeros_like(q0)
        self.t_h = np.zeros_like(q0)

    def _each(self, fn, x):
        """``fn(drive, values)`` joint by joint for the compliant joints (0 elsewhere)."""
        out = np.zeros_like(x)
        for j, d in enumerate(self.drives):
            if self.soft_j[j]:
                sl = slice(j, x.size, self.nj)
                out[sl] = fn(d.reducer, x[sl])
        return out

    def _windup(self, tau):
        return self._each(lambda r, t: r.windup_rad(t), tau)

    def _spring(self, phi):
        """:meth:`Reducer.spring_torque_Nm` of every joint at once (0 for rigid joints)."""
        a = np.abs(phi)
        i = (a > self.th_bp[:, 1]).astype(int) + (a > self.th_bp[:, 2])
        r = self.rows
        return np.sign(phi) * (self.t_bp[r, i] + (a - self.th_bp[r, i]) * self.k_seg[r, i])

    def motor_angle(self, q) -> np.ndarray:
        """Motor angle over the ratio (joint units) the encoder reads, [rad]."""
        return np.where(self.soft, self.x_m, q)

    def motor_speed(self, v) -> np.ndarray:
        """Motor speed over the ratio, [rad/s] (the back-EMF's)."""
        return np.where(self.soft, self.v_m, v)

    def period(self, i_mean, q, v) -> tuple[np.ndarray, np.ndarray]:
        """Advance one servo period with the mean motor current ``i_mean`` [A]; returns the
        link's ``(q, v)``. (The rigid joints' motor state follows their link.)"""
        nvj = q.size
        minv = np.zeros((nvj, nvj))
        bias = np.empty(nvj)
        for k, (model, data) in enumerate(self.models):
            sl = self.part[k]
            minv[sl, sl] = pin.computeMinverse(model, data, q[sl])
            bias[sl] = pin.nonLinearEffects(model, data, q[sl], v[sl])
        c = self._c
        h, softf, rigidf = self.h, c["soft"], c["rigid"]
        x_m, v_m, t_h = np.where(self.soft, self.x_m, q), np.where(self.soft, self.v_m, v), self.t_h
        # the rigid joints' reducer quadrant of the period's start (as the rigid model)
        share = dtm.quadrant_share(self.Kt * i_mean, v, self.band)
        k_rigid = np.where(self.loss, dtm.transmission_efficiency(share, self.eta, self.eta_b), 1.0)
        drive = rigidf * k_rigid * self.N  # rigid joints: joint torque per motor torque
        kt_i = self.Kt * i_mean
        mn, mx, ab, sg = np.minimum, np.maximum, np.abs, np.sign
        th_bp, t_bp, k_seg, base = c["th"], c["t"], c["k"], c["base"]
        th1, th2 = c["th1"], c["th2"]
        for _ in range(self.n_sub):
            phi = x_m - q
            a_ = ab(phi)
            idx = base + (a_ > th1) + (a_ > th2)
            tau_s = sg(phi) * (t_bp[idx] + (a_ - th_bp[idx]) * k_seg[idx]) + t_h
            t_m = kt_i - c["bmN"] * v_m
            fric = c["Fv"] * v + c["Fc"] * mn(mx(v * c["inv_vc"], -1.0), 1.0)
            a = minv @ (softf * tau_s + drive * t_m - fric - bias)
            # the motor: its torque less the reducer's input torque of the spring's
            # (drivetrain.quadrant_share / transmission_efficiency, written out: the inner loop)
            back = (tau_s * v_m < 0.0) * mn(ab(v_m) * c["inv_band"], 1.0)
            t_in = tau_s * (c["A0"] + back * c["A1"]) * c["invN"]
            a_m = softf * (t_m - t_in) * c["inv_JmN"] + rigidf * a
            v = v + a * h
            q = q + v * h
            v_m = v_m + a_m * h
            x_m = x_m + v_m * h
            # the hysteresis element: elastic (K1) until it slips at +-K1 h / 2
            t_h = mn(mx(t_h + c["k_h"] * (v_m - v) * h, c["-f_h"]), c["f_h"])
        self.x_m, self.v_m, self.t_h = x_m, v_m, t_h
        return q, v

    @property
    def _c(self) -> dict:
        """Constant arrays of the inner loop (built once)."""
        if not hasattr(self, "_consts"):
            lossf, softf = self.loss.astype(float), self.soft.astype(float)
            n3 = self.th_bp.shape[0]
            self._consts = {
                "soft": softf,
                "rigid": 1.0 - softf,
                "bmN": self.bm * self.N,
                "Fv": self.Fv * lossf,
                "Fc": self.Fc * lossf,
                "inv_vc": 1.0 / COULOMB_BAND_RAD_S,
                "inv_band": 1.0 / self.band,
                "A0": lossf / self.eta + (1.0 - lossf),
                "A1": lossf * (self.eta_b - 1.0 / self.eta),
                "invN": 1.0 / self.N,
                "inv_JmN": 1.0 / (self.Jm * self.N),
                "k_h": self.k_h,
                "f_h": self.f_h,
                "-f_h": -self.f_h,
                "th": self.th_bp.ravel(),
                "t": self.t_bp.ravel(),
                "k": self.k_seg.ravel(),
                "base": 3 * np.arange(n3),
                "th1": self.th_bp[:, 1].copy(),
                "th2": self.th_bp[:, 2].copy(),
            }
        return self._consts
