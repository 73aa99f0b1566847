"""The three loops of a joint cascade as python-control LTI models, continuous and discrete.

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

Margins are read from the frequency response on a dense logarithmic grid (up to Nyquist for the
discrete loops): phase margin at every gain crossover (the worst is kept), gain margin at every
phase crossover of -180 deg where |L| < 1 (the gain increase the loop tolerates).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np

from armlab.control.gains import CascadeGains, LoopGains
from armlab.control.plant import JointPlant
from armlab.errors import SpecError

__all__ = [
    "Margins",
    "margins",
    "freq_grid",
    "pid_tf",
    "pid_tf_discrete",
    "pid_response",
    "CascadeModel",
    "step_figures",
]


# ---------------------------------------------------------------------------- controllers
def pid_tf(lg: LoopGains) -> ct.TransferFunction:
    """Continuous ``C(s) = kp + ki/s + kd s/(Tf s + 1)`` as a python-control TF."""
    s = ct.tf("s")
    c = ct.tf([lg.kp], [1.0])
    if lg.ki:
        c = c + lg.ki / s
    if lg.kd:
        c = c + lg.kd * s / (lg.derivative_filter_s * s + 1.0)
    return ct.tf(c, inputs="e", outputs="u")


def pid_tf_discrete(lg: LoopGains, dt: float | None = None) -> ct.TransferFunction:
    """Incremental PID ``(q0 z^2 + q1 z + q2) / (z^2 - z)`` as a discrete TF (dt = sample time)."""
    dt = lg.sample_time_s if dt is None else dt
    num, den = lg.discrete_tf()
    if lg.ki == 0.0:  # no integral: the incremental form's pole at z = 1 cancels
        quotient, _ = np.polydiv(num, [1.0, -1.0])
        num, den = list(quotient), [1.0, 0.0]
        if num[-1] == 0.0 or len(num) == 1:
            num, den = [num[0]], [1.0]
    elif lg.q2 == 0.0:
        num, den = num[:2], den[:2]
    return ct.tf(list(num), list(den), dt, inputs="e", outputs="u")


def pid_response(lg: LoopGains, w: np.ndarray, discrete: bool) -> np.ndarray:
    """Frequency response of the controller at ``w`` [rad/s] (fast, for the tuner)."""
    if discrete:
        zi = np.exp(-1j * w * lg.sample_time_s)  # z^-1
        return (lg.q0 + lg.q1 * zi + lg.q2 * zi**2) / (1.0 - zi)
    s = 1j * w
    out = lg.kp + lg.ki / s
    if lg.kd:
        out = out + lg.kd * s / (lg.derivative_filter_s * s + 1.0)
    return out


def _delay_z(d: int, dt: float):
    if d == 0:
        return ct.tf([1.0], [1.0], dt)
    return ct.tf([1.0], [1.0] + [0.0] * d, dt)


def _int_delay(lg: LoopGains) -> int:
    d = lg.delay_samples
    if d < 0 or abs(d - round(d)) > 1e-9:
        raise SpecError(f"{lg.loop} loop: delay_samples must be a whole number >= 0, got {d}")
    return int(round(d))


# ---------------------------------------------------------------------------- margins
@dataclass(frozen=True)
class Margins:
    """Stability margins of an open loop.

    Attributes
    ----------
    phase_margin_deg : float
        Smallest phase margin over the gain crossovers (inf if |L| never crosses 1).
    gain_margin_dB : float
        Smallest gain-increase margin over the -180 deg crossings with |L| < 1 (inf if none).
    crossover_rad_s : float
        Highest gain crossover in [rad/s] (the loop's bandwidth figure).
    phase_crossover_rad_s : float
    """

    phase_margin_deg: float
    gain_margin_dB: float
    crossover_rad_s: float
    phase_crossover_rad_s: float

    def ok(self, phase_margin_deg: float, gain_margin_dB: float) -> bool:
        return self.phase_margin_deg >= phase_margin_deg and self.gain_margin_dB >= gain_margin_dB


def freq_grid(
    dt: float | None = None, w_min: float = 1e-1, w_max: float = 1e6, n: int = 1500
) -> np.ndarray:
    """Log grid in [rad/s]; for a discrete loop it stops just below Nyquist ``pi / dt``."""
    if dt is not None:
        w_max = min(w_max, math.pi / dt * (1 - 1e-6))
    return np.logspace(math.log10(w_min), math.log10(w_max), n)


def margins(w: np.ndarray, L: np.ndarray) -> Margins:
    """Margins from a sampled open-loop response ``L`` at frequencies ``w`` [rad/s].

    Crossings are located by linear interpolation in log|L| and unwrapped phase. A loop whose
    gain is still above 1 at the end of the grid (Nyquist for a discrete loop) gets a phase
    margin of -inf: it has no usable margin.
    """
    mag = np.abs(L)
    with np.errstate(divide="ignore"):
        lm = np.log(mag)
    ph = np.unwrap(np.angle(L))
    # gain crossovers
    s = np.sign(lm)
    idx = np.flatnonzero(s[:-1] * s[1:] < 0)
    pm, wc = math.inf, math.nan
    for k in idx:
        f = lm[k] / (lm[k] - lm[k + 1])
        p = ph[k] + f * (ph[k + 1] - ph[k])
        m = math.degrees(p) + 180.0
        m = (m + 180.0) % 360.0 - 180.0
        pm = min(pm, m)
        wk = math.exp(math.log(w[k]) + f * (math.log(w[k + 1]) - math.log(w[k])))
        wc = wk if math.isnan(wc) else max(wc, wk)
    if lm[-1] > 0.0:  # |L| > 1 at the end of the grid (Nyquist): no usable margin
        pm, wc = -math.inf, float(w[-1])
    # phase crossovers: phase = -180 (mod 360)
    x = (ph + math.pi) / (2 * math.pi)
    n = np.floor(x)
    idx = np.flatnonzero(n[:-1] != n[1:])
    gm, wpc = math.inf, math.nan
    for k in idx:
        target = max(n[k], n[k + 1])
        f = (target - x[k]) / (x[k + 1] - x[k])
        lk = lm[k] + f * (lm[k + 1] - lm[k])
        if lk < 0:
            g = -20.0 * lk / math.log(10.0)
            if g < gm:
                gm = g
                wpc = math.exp(math.log(w[k]) + f * (math.log(w[k + 1]) - math.log(w[k])))
    return Margins(float(pm), float(gm), float(wc), float(wpc))


def step_figures(sys, t_final: float) -> tuple[float, float]:
    """(overshoot in [%], 2 % settling time in [s]) of a closed loop's unit-step response."""
    dt = sys.dt if sys.isdtime(strict=True) else None
    if dt:
        T = np.arange(0.0, t_final + dt, dt)
    else:
        T = np.linspace(0.0, t_final, 1500)
    info = ct.step_info(sys, T=T, SettlingTimeThreshold=0.02)
    return float(info["Overshoot"]), float(info["SettlingTime"])


# ---------------------------------------------------------------------------- cascade models
class CascadeModel:
    """LTI models of one joint's cascade at one inertia case.

    Parameters
    ----------
    plant : JointPlant
        At the inertia case wanted (``plant.at("max")``).
    gains : CascadeGains or dict of LoopGains
        Loops may be missing from a dict while tuning inside-out (``{"current": lg}``).
    """

    def __init__(self, plant: JointPlant, gains):
        self.plant = plant
        self.gains = gains.loops() if isinstance(gains, CascadeGains) else dict(gains)
        self._dd: Any = None  # discrete speed-loop drive (ct.StateSpace), built on first use

    def _g(self, loop: str) -> LoopGains:
        if loop not in self.gains:
            raise SpecError(f"{self.plant.joint}: the {loop} loop has no gains yet")
        return self.gains[loop]

    # ------------------------------------------------------------------ current loop
    def current_plant(self, discrete: bool = False) -> ct.StateSpace:
        P = ct.ss(self.plant.voltage_to_current())
        if not discrete:
            return P
        lg = self._g("current")
        return ct.sample_system(P, lg.sample_time_s, "zoh")

    def current_open(self, discrete: bool = False) -> ct.StateSpace:
        lg = self._g("current")
        if discrete:
            dt = lg.sample_time_s
            return (
                ct.ss(pid_tf_discrete(lg))
                * ct.ss(_delay_z(_int_delay(lg), dt))
                * self.current_plant(True)
            )
        return ct.ss(pid_tf(lg)) * self.current_plant(False)

    def current_closed(self, discrete: bool = False) -> ct.StateSpace:
        """i* [A] -> i [A]."""
        return ct.feedback(self.current_open(discrete), 1)

    def current_closed_lagged(self) -> ct.StateSpace:
        """The current loop as the 1 kHz loops see it: continuous, its sampling lag
        ``(d + 1/2) T`` as a first-order Pade inside the loop."""
        lg = self._g("current")
        tau = (_int_delay(lg) + 0.5) * lg.sample_time_s
        num, den = ct.pade(tau, 1)
        L = ct.ss(pid_tf(lg)) * ct.ss(ct.tf(num, den)) * self.current_plant(False)
        return ct.feedback(L, 1)

    # ------------------------------------------------------------------ speed loop
    def _mech(self):
        p = self.plant
        return ct.ss(ct.tf([p.Kt], [p.J, p.B]))

    def _discrete_drive(self):
        """Discrete plant i* -> (theta_k, speed_k) at the speed loop's period, minimal.

        Continuous states x (current loop + w) and theta are discretised with a ZOH; as theta is
        a pure integrator, ``theta_{k+1} = theta_k + a x_k + b u_k``; the measured speed
        ``(theta_k - theta_{k-1}) / T`` is the extra state ``s_{k+1} = (a x_k + b u_k) / T``.
        States (x, theta, s); outputs (theta, s). No unobservable pole at z = 1.
        """
        if getattr(self, "_dd", None) is not None:
            return self._dd
        lg = self._g("speed")
        dt = lg.sample_time_s
        G = ct.ss(self.current_closed_lagged() * self._mech())  # i* -> w
        n = G.nstates
        A = np.zeros((n + 1, n + 1))
        A[:n, :n] = G.A
        A[n, :n] = G.C[0]
        B = np.zeros((n + 1, 1))
        B[:n] = G.B
        B[n, 0] = G.D[0, 0]
        Ad, Bd = _zoh(A, B, dt)
        Ax = np.zeros((n + 2, n + 2))
        Ax[: n + 1, : n + 1] = Ad
        Ax[n + 1, :n] = Ad[n, :n] / dt
        Bx = np.zeros((n + 2, 1))
        Bx[: n + 1] = Bd
        Bx[n + 1, 0] = Bd[n, 0] / dt
        C = np.zeros((2, n + 2))
        C[0, n] = 1.0
        C[1, n + 1] = 1.0
        self._dd = ct.ss(Ax, Bx, C, np.zeros((2, 1)), dt)
        return self._dd

    def speed_plant(self, discrete: bool = False) -> ct.StateSpace:
        """i* [A] -> (measured) motor speed [rad/s]; discrete: without the theta state."""
        if not discrete:
            return self.current_closed(False) * self._mech()
        d = self._discrete_drive()
        keep = [k for k in range(d.nstates) if k != d.nstates - 2]
        return ct.ss(d.A[np.ix_(keep, keep)], d.B[keep], d.C[1:2, keep], d.D[1:2], d.dt)

    def speed_position_plant_discrete(self) -> ct.StateSpace:
        """i* [A] -> sampled motor angle [rad] (ZOH at the speed loop's period)."""
        return self._discrete_drive()[0, 0]

    def speed_open(self, discrete: bool = False) -> ct.StateSpace:
        lg = self._g("speed")
        if discrete:
            dt = lg.sample_time_s
            return (
                ct.ss(pid_tf_discrete(lg))
                * ct.ss(_delay_z(_int_delay(lg), dt))
                * self.speed_plant(True)
            )
        return ct.ss(pid_tf(lg)) * self.speed_plant(False)

    def speed_closed(self, discrete: bool = False) -> ct.StateSpace:
        """w* [rad/s] -> (measured) motor speed [rad/s]."""
        return ct.feedback(self.speed_open(discrete), 1)

    # ------------------------------------------------------------------ position loop
    def position_plant(self, discrete: bool = False) -> ct.StateSpace:
        """w* [rad/s] -> motor angle [rad] (speed loop closed)."""
        if not discrete:
            return self.speed_closed(False) * ct.ss(ct.tf([1.0], [1.0, 0.0]))
        lg = self._g("speed")
        dt = lg.sample_time_s
        fwd = (
            self._discrete_drive()
            * ct.ss(_delay_z(_int_delay(lg), dt))
            * ct.ss(pid_tf_discrete(lg))
        )
        pick = ct.ss(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), [[0.0, 1.0]], dt)
        return ct.feedback(fwd, pick)[0, 0]

    def position_open(self, discrete: bool = False) -> ct.StateSpace:
        lg = self._g("position")
        if discrete:
            if abs(lg.sample_time_s - self._g("speed").sample_time_s) > 1e-12:
                raise SpecError(
                    f"{self.plant.joint}: position and speed loops must share a "
                    f"sample time ({lg.sample_time_s} s != "
                    f"{self._g('speed').sample_time_s} s)"
                )
            return ct.ss(pid_tf_discrete(lg)) * self.position_plant(True)
        return ct.ss(pid_tf(lg)) * self.position_plant(False)

    def position_closed(self, discrete: bool = False) -> ct.StateSpace:
        """theta* [rad] -> theta [rad] (motor side; the same ratio at the joint)."""
        return ct.feedback(self.position_open(discrete), 1)

    # ------------------------------------------------------------------ generic
    def open_loop(self, loop: str, discrete: bool = False) -> ct.StateSpace:
        return getattr(self, f"{loop}_open")(discrete)

    def closed_loop(self, loop: str, discrete: bool = False) -> ct.StateSpace:
        return getattr(self, f"{loop}_closed")(discrete)

    def margins(self, loop: str, discrete: bool = False, n: int = 1500) -> Margins:
        L = self.open_loop(loop, discrete)
        dt = self._g(loop).sample_time_s if discrete else None
        w = freq_grid(dt, n=n)
        return margins(w, _response(L, w, dt))

    def stable(self, loop: str, discrete: bool = False) -> bool:
        p = ct.poles(self.closed_loop(loop, discrete))
        if discrete:
            return bool(np.all(np.abs(p) < 1.0 - 1e-9))
        return bool(np.all(p.real < 0.0))


def _zoh(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact ZOH discretisation via the block matrix exponential (balanced first: the
    companion-form states python-control builds span many decades, which makes an unbalanced
    ``expm`` slow)."""
    from scipy.linalg import expm, matrix_balance

    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n] = A * dt
    M[:n, n:] = B * dt
    Mb, (sc, perm) = matrix_balance(M, permute=False, separate=True)
    E = expm(Mb) * (sc[:, None] / sc[None, :])
    return E[:n, :n], E[:n, n:]


def _response(sys, w: np.ndarray, dt: float | None) -> np.ndarray:
    """SISO frequency response ``C (x I - A)^-1 B + D`` at ``x = jw`` or ``e^{jw dt}``,
    one batched linear solve over all frequencies (python-control's own evaluation loops in
    Python, ~50 x slower on these 10-state loops)."""
    x = np.exp(1j * w * dt) if dt else 1j * w
    if not isinstance(sys, ct.StateSpace):
        return np.asarray(sys(x, warn_infinite=False)).reshape(-1)
    A, B, C, D = sys.A, sys.B, sys.C, sys.D
    n = A.shape[0]
    if n == 0:
        return np.full(x.shape, complex(D[0, 0]))
    M = x[:, None, None] * np.eye(n)[None] - A[None]
    rhs = np.broadcast_to(B[:, :1].astype(complex), (x.size, n, 1))
    sol = np.linalg.solve(M, rhs)[:, :, 0]
    return sol @ C[0] + D[0, 0]
