"""Oracle for :mod:`armlab.control.loops`: one joint's cascade built with python-control.

Independent of the package's numpy engine (``armlab.control.lti``/``loops``): every block is a
python-control transfer function (the formulas of :mod:`armlab.control.loops`' docstring,
written again from the plant's constants), the interconnections are python-control's
``*``/``feedback``, the ZOH is python-control's ``sample_system`` and the step figures its
``step_info``. Only the frequency-response evaluation of the resulting state-space system is a
plain linear solve (python-control's own evaluation loops in Python, ~50 x slower).
"""

from __future__ import annotations

import control as ct
import numpy as np


def _pid(lg, discrete: bool):
    """C(s) = kp + ki/s + kd s/(Tf s + 1); C(z) = (q0 + q1 z^-1 + q2 z^-2)/(1 - z^-1) with the
    poles a P or PI controller cancels removed (python-control's ``minreal``)."""
    if discrete:
        c = ct.tf([lg.q0, lg.q1, lg.q2], [1.0, -1.0, 0.0], lg.sample_time_s)
        return ct.minreal(c, verbose=False)
    s = ct.tf("s")
    c = ct.tf([lg.kp], [1.0])
    if lg.ki:
        c = c + lg.ki / s
    if lg.kd:
        c = c + lg.kd * s / (lg.derivative_filter_s * s + 1.0)
    return c


def _delay(lg):
    d = int(round(lg.delay_samples))
    return ct.tf([1.0], [1.0] + [0.0] * d, lg.sample_time_s)


class Cascade:
    """The open and closed loops of one joint at one inertia (``plant.at(case)``)."""

    def __init__(self, plant, gains):
        self.p = plant
        self.g = gains.loops() if hasattr(gains, "loops") else dict(gains)

    # plant blocks, from the motor equations L di/dt = U - R i - Ke w, J dw/dt = Kt i - B w
    def _Pi(self):
        p, J = self.p, self.p.J
        return ct.tf([J, p.B], [p.L * J, p.L * p.B + p.R * J, p.R * p.B + p.Kt * p.Ke])

    def _mech(self):
        return ct.tf([self.p.Kt], [self.p.J, self.p.B])

    def _current_lagged(self):
        lg = self.g["current"]
        num, den = ct.pade((round(lg.delay_samples) + 0.5) * lg.sample_time_s, 1)
        return ct.feedback(ct.ss(_pid(lg, False)) * ct.ss(ct.tf(num, den)) * ct.ss(self._Pi()))

    def _theta(self):
        """i* -> sampled motor angle: the lagged current loop, mechanics and 1/s, ZOH."""
        G = self._current_lagged() * ct.ss(self._mech()) * ct.ss(ct.tf([1.0], [1.0, 0.0]))
        return ct.sample_system(G, self.g["speed"].sample_time_s, "zoh")

    def _speed_measured(self):
        """i* -> (theta_k - theta_{k-1}) / T without the theta integrator that the difference
        cancels: with the ZOH of (x, theta), ``theta_k - theta_{k-1} = a x_{k-1} + b u_{k-1}``
        (the theta row of the sampled system), so the measured speed is ``z^-1`` times the
        system (Ad_xx, Bd_x, a / T, b / T)."""
        G = self._current_lagged() * ct.ss(self._mech())
        n, dt = G.nstates, self.g["speed"].sample_time_s
        A = np.block([[G.A, np.zeros((n, 1))], [G.C, np.zeros((1, 1))]])
        B = np.vstack([G.B, G.D])
        d = ct.sample_system(ct.ss(A, B, np.eye(n + 1)[n:], 0.0), dt, "zoh")
        S = ct.ss(d.A[:n, :n], d.B[:n], d.A[n:, :n] / dt, d.B[n:] / dt, dt)
        return ct.ss(ct.tf([1.0], [1.0, 0.0], dt)) * S

    def _encoder(self):
        """(1 - z^-1) / T: the speed measured by differencing the encoder."""
        dt = self.g["speed"].sample_time_s
        return ct.tf([1.0, -1.0], [dt, 0.0], dt)

    def open_loop(self, loop: str, discrete: bool):
        lg = self.g[loop]
        C = ct.ss(_pid(lg, discrete))
        if loop == "current":
            if discrete:
                Pd = ct.sample_system(ct.ss(self._Pi()), lg.sample_time_s, "zoh")
                return C * ct.ss(_delay(lg)) * Pd
            return C * ct.ss(self._Pi())
        if loop == "speed":
            if discrete:
                return C * ct.ss(_delay(lg)) * self._speed_measured()
            return C * ct.feedback(self.open_loop("current", False)) * ct.ss(self._mech())
        if discrete:  # position: the speed loop closed on the measured speed
            lw = self.g["speed"]
            fwd = ct.ss(_pid(lw, True)) * ct.ss(_delay(lw)) * self._theta()
            return C * ct.feedback(fwd, ct.ss(self._encoder()))
        return C * ct.feedback(self.open_loop("speed", False)) * ct.ss(ct.tf([1.0], [1.0, 0.0]))

    def closed_loop(self, loop: str, discrete: bool):
        """Set-point -> output."""
        return ct.feedback(self.open_loop(loop, discrete), 1)

    def stable(self, loop: str, discrete: bool) -> bool:
        p = ct.poles(self.closed_loop(loop, discrete))
        return bool(np.all(np.abs(p) < 1.0 - 1e-9)) if discrete else bool(np.all(p.real < 0.0))


def response(sys, w: np.ndarray) -> np.ndarray:
    """``C (x I - A)^-1 B + D`` at ``x = jw`` (continuous) or ``e^{jw dt}`` (discrete)."""
    x = np.exp(1j * w * sys.dt) if sys.dt else 1j * w
    A, B, C, D = (np.asarray(m) for m in (sys.A, sys.B, sys.C, sys.D))
    n = A.shape[0]
    M = x[:, None, None] * np.eye(n)[None] - A[None]
    sol = np.linalg.solve(M, np.broadcast_to(B[:, :1].astype(complex), (x.size, n, 1)))
    return sol[:, :, 0] @ C[0] + D[0, 0]


def step_figures(sys, t_final: float) -> tuple[float, float]:
    """(overshoot [%], 2 % settling time [s]) of the unit-step response, python-control's
    ``step_info`` on the package's sample times (continuous: 1500 points; discrete: every
    sample up to ``t_final``)."""
    dt = sys.dt if sys.isdtime(strict=True) else None
    T = np.arange(0.0, t_final + dt, dt) if dt else np.linspace(0.0, t_final, 1500)
    info = ct.step_info(sys, T=T, SettlingTimeThreshold=0.02)
    return float(info["Overshoot"]), float(info["SettlingTime"])
