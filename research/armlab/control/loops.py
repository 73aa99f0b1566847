"""The three loops of a joint cascade, continuous and discrete, over the inertia cases.

Continuous loops (the design model, no sampling)::

    current   L_i(s) = C_i(s) P_i(s)      P_i = i/U = (J s + B) / ((L s + R)(J s + B) + Kt Ke)
    speed     L_w(s) = C_w(s) T_i(s) Kt / (J s + B)     T_i = L_i / (1 + L_i)
    position  L_p(s) = C_p(s) T_w(s) / s                T_w = L_w / (1 + L_w)

Discrete loops (what the controllers run; "ZOH with computation delay")::

    current   L_i(z) = C_i(z) z^-d ZOH{P_i}(z)                          T = 50 us (20 kHz amplifier)
    speed     L_w(z) = C_w(z) z^-d (1 - z^-1)/T ZOH{T_i' Kt / ((J s + B) s)}(z)   T = 1 ms
    position  L_p(z) = C_p(z) S(z),  S = C_w z^-d P_th / (1 + C_w z^-d (1 - z^-1)/T P_th)

* ``C(z) = (q0 + q1 z^-1 + q2 z^-2) / (1 - z^-1)``: the thesis' incremental PID (ch. 5).
* ``z^-d``: computation delay of d samples (output written one period after the sample).
* ZOH: the D/A (speed loop) and the PWM (current loop) hold their output over a period.
* The speed is measured by differencing the motor encoder, ``(theta_k - theta_{k-1}) / T``
  — this adds the half-sample lag a real card has; it is part of the discrete check.
* ``T_i'`` is the current loop seen by the 1 kHz loops: the continuous current loop with its own
  sampling lag ``(d + 1/2) T_i`` as a first-order Pade inside the loop (the 20 kHz loop is 20 x
  faster than the 1 kHz loops; this keeps its phase lag without mixing sample rates).
* The position loop runs in the same interrupt as the speed loop (no extra delay).

:class:`CascadeModel` is the one evaluation of these loops: frequency responses in closed form
(the two ZOH plants -- current plant and the speed loop's drive -- from the exact
block-exponential discretisation, everything after them pointwise), batched over the inertia
cases; the closed loops as small state-space matrices (:mod:`armlab.control.lti`) for the step
responses and the poles. Margins: :mod:`armlab.control.margins`; step figures:
:mod:`armlab.control.steps`. ``open_loop``/``closed_loop`` hand the same matrices over as
python-control systems (root loci, users' own analysis); the tests check every figure against
the loops built independently with python-control (``tests/oracles``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from armlab._lazy import lazy_import
from armlab.control.gains import CascadeGains, LoopGains
from armlab.control.lti import (
    INTEGRATOR,
    SS,
    delay_ss,
    pade_ss,
    ss_feedback,
    ss_response,
    ss_series,
    ss_static,
    ss_tf,
    zoh,
)
from armlab.control.margins import Margins, freq_grid, margins_many
from armlab.control.plant import INERTIA_CASES, JointPlant
from armlab.control.steps import dcgain, step_many, step_metrics
from armlab.errors import SpecError

if TYPE_CHECKING:
    import control as ct  # the real module for the type checker
else:
    ct = lazy_import("control")  # python-control loads when a system is handed over

__all__ = ["CascadeModel", "pid_response"]


# ---------------------------------------------------------------------------- controllers
def pid_response(lg: LoopGains, w: np.ndarray, discrete: bool) -> np.ndarray:
    """Frequency response of the controller at ``w`` [rad/s]: continuous
    ``kp + ki/(jw) + kd jw/(Tf jw + 1)``, discrete ``(q0 + q1 z^-1 + q2 z^-2)/(1 - z^-1)`` at
    ``z = e^{jwT}``."""
    if discrete:
        zi = np.exp(-1j * w * lg.sample_time_s)  # z^-1
        return (lg.q0 + lg.q1 * zi + lg.q2 * zi**2) / (1.0 - zi)
    s = 1j * w
    out = lg.kp + lg.ki / s
    if lg.kd:
        out = out + lg.kd * s / (lg.derivative_filter_s * s + 1.0)
    return out


def _pid_discrete_coeffs(lg: LoopGains) -> tuple[list[float], list[float]]:
    """Numerator and denominator of C(z) (descending powers of z) with the cancelled poles
    removed: no integral -> the pole at z = 1 cancels; ``q2 = 0`` -> the pole at z = 0."""
    num, den = lg.discrete_tf()
    if lg.ki == 0.0:  # no integral: the incremental form's pole at z = 1 cancels
        quotient, _ = np.polydiv(num, [1.0, -1.0])
        num, den = list(quotient), [1.0, 0.0]
        if num[-1] == 0.0 or len(num) == 1:
            num, den = [num[0]], [1.0]
    elif lg.q2 == 0.0:
        num, den = num[:2], den[:2]
    return [float(x) for x in num], [float(x) for x in den]


def _pid_ss(lg: LoopGains) -> SS:
    """Continuous ``kp + ki/s + kd s/(Tf s + 1)`` as a state-space system."""
    A, B, C, D = ss_static(lg.kp)
    if lg.ki:
        A, B, C = np.zeros((1, 1)), np.ones((1, 1)), np.array([[lg.ki]])
    if lg.kd:
        tf = lg.derivative_filter_s
        if not tf > 0.0:
            raise SpecError(
                f"{lg.loop} loop: kd={lg.kd} needs derivative_filter_s > 0 "
                f"(an unfiltered derivative is improper)"
            )
        n = A.shape[0]
        A2 = np.zeros((n + 1, n + 1))
        A2[:n, :n] = A
        A2[n, n] = -1.0 / tf
        A, B = A2, np.vstack([B, [[1.0]]])
        C = np.hstack([C, [[-lg.kd / tf**2]]])
        D = D + lg.kd / tf
    return A, B, C, D


def _pid_ss_discrete(lg: LoopGains) -> SS:
    return ss_tf(*_pid_discrete_coeffs(lg))


def _int_delay(lg: LoopGains) -> int:
    d = lg.delay_samples
    if d < 0 or abs(d - round(d)) > 1e-9:
        raise SpecError(f"{lg.loop} loop: delay_samples must be a whole number >= 0, got {d}")
    return int(round(d))


# ---------------------------------------------------------------------------- plant pieces
def _current_plant_ss(p: JointPlant, J: float) -> SS:
    """U [V] -> i [A], states (i, w): ``L di/dt = U - R i - Ke w``, ``J dw/dt = Kt i - B w``
    (thesis 5.4.1, :mod:`armlab.control.plant`)."""
    A = np.array([[-p.R / p.L, -p.Ke / p.L], [p.Kt / J, -p.B / J]])
    return A, np.array([[1.0 / p.L], [0.0]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))


def _mech_ss(p: JointPlant, J: float) -> SS:
    """i [A] -> w [rad/s]: ``Kt / (J s + B)``, or the two-mass joint
    (:meth:`JointPlant.mechanics_ss`)."""
    return p.mechanics_ss(J)


def _encoder_drive(GA, GB, GC, GD, dt: float) -> SS:
    """The discrete drive ``i* -> (theta_k, speed_k)`` from the continuous ``i* -> w`` system
    ``(GA, GB, GC, GD)``: x and ``theta = int w`` discretised with a ZOH of step ``dt`` [s];
    as theta is a pure integrator, ``theta_{k+1} = theta_k + a x_k + b u_k``, and the measured
    speed ``(theta_k - theta_{k-1}) / dt`` is the extra state ``s_{k+1} = (a x_k + b u_k) / dt``.
    States (x, theta, s); outputs (theta, s). No unobservable pole at z = 1."""
    n = GA.shape[0]
    A = np.zeros((n + 1, n + 1))
    A[:n, :n] = GA
    A[n, :n] = GC[0]
    B = np.zeros((n + 1, 1))
    B[:n] = GB
    B[n, 0] = GD[0, 0]
    Ad, Bd = zoh(A, B, dt)
    Ax = np.zeros((n + 2, n + 2))
    Ax[: n + 1, : n + 1] = Ad
    Ax[n + 1, :n] = Ad[n, :n] / dt
    Bx = np.zeros((n + 2, 1))
    Bx[: n + 1] = Bd
    Bx[n + 1, 0] = Bd[n, 0] / dt
    C = np.zeros((2, n + 2))
    C[0, n] = 1.0
    C[1, n + 1] = 1.0
    return Ax, Bx, C, np.zeros((2, 1))


# ---------------------------------------------------------------------------- the cascade
class CascadeModel:
    """One joint's cascade (module docstring) evaluated over several inertia cases at once.

    Parameters
    ----------
    plant : JointPlant
    gains : CascadeGains or dict of LoopGains
        Loops may be missing from a dict while tuning inside-out (``{"current": lg}``).
    cases : sequence of str or float
        Inertia cases (:meth:`JointPlant.at`); the arrays of every method are stacked in this
        order (``(len(cases), n)``).
    """

    def __init__(self, plant: JointPlant, gains, cases=INERTIA_CASES):
        self.plant = plant
        self.cases = list(cases)
        self.J = np.array([plant.J_motor(c) for c in self.cases])
        self.gains = gains.loops() if isinstance(gains, CascadeGains) else dict(gains)
        self._drive_cache: dict[float, SS] = {}
        self._ptheta: dict = {}
        self._closed_cache: dict = {}

    def _g(self, loop: str) -> LoopGains:
        if loop not in self.gains:
            raise SpecError(f"{self.plant.joint}: the {loop} loop has no gains yet")
        return self.gains[loop]

    def dt(self, loop: str) -> float:
        return self._g(loop).sample_time_s

    # ------------------------------------------------------------------ frequency responses
    def current_plant_response(self, w: np.ndarray, discrete: bool) -> np.ndarray:
        """U -> i at ``w`` (k, n); discrete: the ZOH plant (no delay)."""
        p = self.plant
        if not discrete:
            s = 1j * w[None, :]
            J = self.J[:, None]
            return (J * s + p.B) / ((p.L * s + p.R) * (J * s + p.B) + p.Kt * p.Ke)
        dt = self.dt("current")
        AB = [zoh(_current_plant_ss(p, J)[0], _current_plant_ss(p, J)[1], dt) for J in self.J]
        A = np.stack([ab[0] for ab in AB])
        B = np.stack([ab[1] for ab in AB])
        C = np.broadcast_to(np.array([[[1.0, 0.0]]]), (len(AB), 1, 2))
        return ss_response(A, B, C, np.exp(1j * w * dt))

    def _delay(self, loop: str, w: np.ndarray) -> np.ndarray:
        lg = self._g(loop)
        return np.exp(-1j * w * lg.sample_time_s) ** _int_delay(lg)

    def theta_response(self, w: np.ndarray) -> np.ndarray:
        """Discrete i* -> sampled motor angle (ZOH at the speed loop's period), (k, n)."""
        key = (w.size, float(w[0]), float(w[-1]))
        if key not in self._ptheta:
            drives = [self._drive(J) for J in self.J]
            A = np.stack([d[0] for d in drives])
            B = np.stack([d[1] for d in drives])
            C = np.stack([d[2][:1] for d in drives])
            self._ptheta[key] = ss_response(A, B, C, np.exp(1j * w * self.dt("speed")))
        return self._ptheta[key]

    def speed_plant_response(self, w: np.ndarray, discrete: bool) -> np.ndarray:
        """i* -> (measured) motor speed, (k, n); discrete: without the computation delay."""
        if discrete:
            dt = self.dt("speed")
            return (1.0 - np.exp(-1j * w * dt)) / dt * self.theta_response(w)
        Li = pid_response(self._g("current"), w, False) * self.current_plant_response(w, False)
        return Li / (1.0 + Li) * self.plant.mechanics_response(w, self.J)

    def position_plant_response(self, w: np.ndarray, discrete: bool) -> np.ndarray:
        """w* -> motor angle (speed loop closed), (k, n)."""
        lg = self._g("speed")
        if discrete:
            cz = pid_response(lg, w, True) * self._delay("speed", w)
            dt = lg.sample_time_s
            P_th = self.theta_response(w)
            return cz * P_th / (1.0 + cz * (1.0 - np.exp(-1j * w * dt)) / dt * P_th)
        Lw = pid_response(lg, w, False) * self.speed_plant_response(w, False)
        return Lw / (1.0 + Lw) / (1j * w[None, :])

    def plant_response(self, loop: str, w: np.ndarray, discrete: bool) -> np.ndarray:
        """What the loop's controller drives, computation delay included, (k, n)."""
        P = getattr(self, f"{loop}_plant_response")(w, discrete)
        if discrete and loop != "position":
            P = P * self._delay(loop, w)
        return P

    def open_response(self, loop: str, w: np.ndarray, discrete: bool) -> np.ndarray:
        """The open loop ``C P`` at ``w`` [rad/s], (k, n)."""
        return pid_response(self._g(loop), w, discrete) * self.plant_response(loop, w, discrete)

    def margins(self, loop: str, discrete: bool = False, n: int = 1500) -> list[Margins]:
        """The loop's margins per case on :func:`freq_grid` of ``n`` points."""
        w = freq_grid(self.dt(loop) if discrete else None, n=n)
        pm, gm, wc, wpc = margins_many(w, self.open_response(loop, w, discrete))
        return [
            Margins(float(a), float(b), float(c), float(d))
            for a, b, c, d in zip(pm, gm, wc, wpc, strict=True)
        ]

    # ------------------------------------------------------------------ state space
    def _current_closed_lagged(self, J: float) -> SS:
        """The current loop as the 1 kHz loops see it: continuous, its sampling lag
        ``(d + 1/2) T`` as a first-order Pade inside the loop."""
        lg = self._g("current")
        tau = (_int_delay(lg) + 0.5) * lg.sample_time_s
        chain = ss_series(_pid_ss(lg), ss_series(pade_ss(tau), _current_plant_ss(self.plant, J)))
        return ss_feedback(chain)

    def _drive(self, J: float) -> SS:
        """The discrete drive i* -> (theta_k, speed_k) at inertia ``J`` (:func:`_encoder_drive`
        of the lagged current loop and the mechanics)."""
        J = float(J)
        if J not in self._drive_cache:
            GA, GB, GC, GD = ss_series(_mech_ss(self.plant, J), self._current_closed_lagged(J))
            self._drive_cache[J] = _encoder_drive(GA, GB, GC, GD, self.dt("speed"))
        return self._drive_cache[J]

    def _open(self, loop: str, discrete: bool, J: float) -> SS:
        """The forward path ``C P`` of a loop (unity feedback closes it)."""
        p = self.plant
        if loop == "current":
            lg = self._g("current")
            if discrete:
                Ac, Bc, _, _ = _current_plant_ss(p, J)
                Pd = zoh(Ac, Bc, lg.sample_time_s)
                P = (Pd[0], Pd[1], np.array([[1.0, 0.0]]), np.zeros((1, 1)))
                return ss_series(_pid_ss_discrete(lg), ss_series(delay_ss(_int_delay(lg)), P))
            return ss_series(_pid_ss(lg), _current_plant_ss(p, J))
        lw = self._g("speed")
        if loop == "speed":
            if discrete:
                A, B, C, D = self._drive(J)
                keep = [k for k in range(A.shape[0]) if k != A.shape[0] - 2]  # theta unobserved
                P = (A[np.ix_(keep, keep)], B[keep], C[1:2, keep], D[1:2])
                return ss_series(_pid_ss_discrete(lw), ss_series(delay_ss(_int_delay(lw)), P))
            P = ss_series(_mech_ss(p, J), ss_feedback(self._open("current", False, J)))
            return ss_series(_pid_ss(lw), P)
        lp = self._g("position")
        if discrete:
            if abs(lp.sample_time_s - lw.sample_time_s) > 1e-12:
                raise SpecError(
                    f"{p.joint}: position and speed loops must share a sample time "
                    f"({lp.sample_time_s} s != {lw.sample_time_s} s)"
                )
            fwd = ss_series(
                self._drive(J), ss_series(delay_ss(_int_delay(lw)), _pid_ss_discrete(lw))
            )
            A, B, C, D = ss_feedback(fwd, row=1)  # the speed loop closed on the measured speed
            return ss_series(_pid_ss_discrete(lp), (A, B, C[:1], D[:1]))
        P = ss_series(INTEGRATOR, ss_feedback(self._open("speed", False, J)))
        return ss_series(_pid_ss(lp), P)

    def closed_systems(self, loop: str, discrete: bool) -> list[SS]:
        """The closed loop (set-point -> output) per case, as numpy matrices."""
        key = (
            loop,
            discrete,
            *(id(self.gains.get(name)) for name in ("current", "speed", "position")),
        )
        if key not in self._closed_cache:
            self._closed_cache[key] = [ss_feedback(self._open(loop, discrete, J)) for J in self.J]
        return self._closed_cache[key]

    def step_responses(
        self, loop: str, discrete: bool, t_final
    ) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """Closed-loop unit-step responses ``(times, outputs)`` per case, one batched
        simulation (continuous: 1500 points on ``[0, t_final]``; discrete: every sample)."""
        systems = self.closed_systems(loop, discrete)
        tf = np.broadcast_to(np.asarray(t_final, float), (len(systems),))
        return step_many(systems, tf, self.dt(loop) if discrete else None)

    def step_figures(self, loop: str, discrete: bool, t_final) -> list[tuple[float, float]]:
        """(overshoot [%], 2 % settling time [s]) per case, one batched simulation."""
        systems = self.closed_systems(loop, discrete)
        T, Y = self.step_responses(loop, discrete, t_final)
        return [step_metrics(T[i], Y[i], dcgain(systems[i], discrete)) for i in range(len(systems))]

    def stable(self, loop: str, discrete: bool) -> list[bool]:
        """Closed-loop stability per case: every pole in the open left half-plane
        (continuous) or strictly inside the unit circle (discrete, by 1e-9)."""
        out = []
        for A, *_ in self.closed_systems(loop, discrete):
            p = np.linalg.eigvals(A) if A.size else np.zeros(0)
            out.append(
                bool(np.all(np.abs(p) < 1.0 - 1e-9)) if discrete else bool(np.all(p.real < 0.0))
            )
        return out

    # ------------------------------------------------------------------ python-control
    def _lti(self, sys: SS, loop: str, discrete: bool) -> ct.StateSpace:
        A, B, C, D = sys
        return ct.ss(A, B, C[:1], D[:1], self.dt(loop) if discrete else 0)

    def open_loop(
        self, loop: str, discrete: bool = False, case: str | float | None = None
    ) -> ct.StateSpace:
        """The open loop at one inertia case (default: the plant's own) as a python-control
        system: the matrices this model evaluates, handed over (root loci, own analysis)."""
        J = self.plant.J_motor(case)
        return self._lti(self._open(loop, discrete, J), loop, discrete)

    def closed_loop(
        self, loop: str, discrete: bool = False, case: str | float | None = None
    ) -> ct.StateSpace:
        """The closed loop (set-point -> output) at one case, as a python-control system."""
        J = self.plant.J_motor(case)
        return self._lti(ss_feedback(self._open(loop, discrete, J)), loop, discrete)
