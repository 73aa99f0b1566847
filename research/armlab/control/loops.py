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
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab._lazy import lazy_import
from armlab.control.gains import CascadeGains, LoopGains
from armlab.control.plant import INERTIA_CASES, JointPlant
from armlab.errors import SpecError

if TYPE_CHECKING:
    import control as ct  # the real module for the type checker
else:
    ct = lazy_import("control")  # python-control loads at the first model built

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


def pid_tf_discrete(lg: LoopGains, dt: float | None = None) -> ct.TransferFunction:
    """Incremental PID ``(q0 z^2 + q1 z + q2) / (z^2 - z)`` as a discrete TF (dt = sample time)."""
    dt = lg.sample_time_s if dt is None else dt
    num, den = _pid_discrete_coeffs(lg)
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
        self._dd = ct.ss(*_encoder_drive(G.A, G.B, G.C, G.D, dt), dt)
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


def _encoder_drive(GA, GB, GC, GD, dt: float) -> tuple:
    """``(A, B, C, D)`` of the discrete drive ``i* -> (theta_k, speed_k)`` from the continuous
    ``i* -> w`` system ``(GA, GB, GC, GD)``: x and theta = int w discretised with a ZOH of step
    ``dt`` [s], and the measured speed ``(theta_k - theta_{k-1}) / dt`` as an extra state
    (:meth:`CascadeModel._discrete_drive`)."""
    n = GA.shape[0]
    A = np.zeros((n + 1, n + 1))
    A[:n, :n] = GA
    A[n, :n] = GC[0]
    B = np.zeros((n + 1, 1))
    B[:n] = GB
    B[n, 0] = GD[0, 0]
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
    return Ax, Bx, C, np.zeros((2, 1))


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


# ---------------------------------------------------------------------------- closed form (numpy)
# The same loops evaluated with numpy, batched over inertia cases: the frequency responses in
# closed form (continuous: the transfer functions of the module docstring multiplied pointwise;
# discrete: the two ZOH plants -- current plant and the speed loop's drive -- from the exact
# block-exponential discretisation, everything after them pointwise), the closed loops as small
# state-space matrices for the step responses and the poles. python-control's
# :class:`CascadeModel` stays the reference (tests compare the two); this twin is what the
# tuner runs, ~20 x faster because it builds no python-control objects.
_SS = tuple  # (A, B, C, D) numpy arrays of a SISO (C, D may have several output rows) system


def _ss_static(k: float) -> _SS:
    return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[float(k)]])


def _ss_series(outer: _SS, inner: _SS) -> _SS:
    """``outer(inner(u))``; ``inner`` single-output, ``outer`` may have several outputs."""
    A1, B1, C1, D1 = inner
    A2, B2, C2, D2 = outer
    n1, n2 = A1.shape[0], A2.shape[0]
    A = np.zeros((n1 + n2, n1 + n2))
    A[:n1, :n1] = A1
    A[n1:, :n1] = B2 @ C1
    A[n1:, n1:] = A2
    return A, np.vstack([B1, B2 @ D1]), np.hstack([D2 @ C1, C2]), D2 @ D1


def _ss_feedback(sys: _SS, row: int = 0) -> _SS:
    """Negative feedback of output ``row`` to the input: ``u = r - y[row]``."""
    A, B, C, D = sys
    c, g = C[row : row + 1], 1.0 / (1.0 + D[row, 0])
    return A - g * (B @ c), g * B, C - g * (D @ c), g * D


def _ss_tf(num, den) -> _SS:
    """Controllable canonical form of a proper SISO transfer function (descending powers)."""
    num, den = np.asarray(num, float), np.asarray(den, float)
    num, den = num / den[0], den / den[0]
    n = den.size - 1
    if n == 0:
        return _ss_static(num[-1])
    num = np.concatenate([np.zeros(n + 1 - num.size), num])
    d = num[0]
    A = np.zeros((n, n))
    A[0] = -den[1:]
    A[1:, :-1] = np.eye(n - 1)
    B = np.zeros((n, 1))
    B[0, 0] = 1.0
    C = (num[1:] - d * den[1:])[None, :]
    return A, B, C, np.array([[d]])


def _pid_ss(lg: LoopGains) -> _SS:
    """Continuous ``kp + ki/s + kd s/(Tf s + 1)`` (the terms :func:`pid_tf` builds)."""
    A, B, C, D = _ss_static(lg.kp)
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


def _pid_ss_discrete(lg: LoopGains) -> _SS:
    return _ss_tf(*_pid_discrete_coeffs(lg))


def _delay_ss(d: int) -> _SS:
    if d == 0:
        return _ss_static(1.0)
    A = np.eye(d, k=-1)
    B = np.zeros((d, 1))
    B[0, 0] = 1.0
    C = np.zeros((1, d))
    C[0, -1] = 1.0
    return A, B, C, np.zeros((1, 1))


def _current_plant_ss(p: JointPlant, J: float) -> _SS:
    """U [V] -> i [A], states (i, w): the motor equations of :mod:`armlab.control.plant`."""
    A = np.array([[-p.R / p.L, -p.Ke / p.L], [p.Kt / J, -p.B / J]])
    return A, np.array([[1.0 / p.L], [0.0]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))


def _mech_ss(p: JointPlant, J: float) -> _SS:
    """i [A] -> w [rad/s]: ``Kt / (J s + B)``."""
    return np.array([[-p.B / J]]), np.ones((1, 1)), np.array([[p.Kt / J]]), np.zeros((1, 1))


def _pade_ss(tau: float) -> _SS:
    """First-order Pade of ``e^{-tau s}``: ``(2/tau - s) / (2/tau + s)``."""
    return np.array([[-2.0 / tau]]), np.ones((1, 1)), np.array([[4.0 / tau]]), -np.ones((1, 1))


_INTEGRATOR: _SS = (np.zeros((1, 1)), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)))


def _ss_response(A: np.ndarray, B: np.ndarray, C: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``C (x I - A)^-1 B`` for stacked systems A (k, n, n), B (k, n, 1), C (k, 1, n) at the
    points x (m,): (k, m), one batched solve."""
    k, n = A.shape[0], A.shape[1]
    M = x[None, :, None, None] * np.eye(n) - A[:, None]
    rhs = np.broadcast_to(B[:, None].astype(complex), (k, x.size, n, 1))
    sol = np.linalg.solve(M, rhs)[..., 0]  # (k, m, n)
    return np.einsum("kmn,kn->km", sol, C[:, 0, :])


def margins_many(w: np.ndarray, L: np.ndarray) -> tuple[np.ndarray, ...]:
    """:func:`margins` of many open loops at once: ``L`` (..., n) sampled at ``w`` (n,).

    Returns ``(phase_margin_deg, gain_margin_dB, crossover_rad_s, phase_crossover_rad_s)``,
    arrays of shape ``L.shape[:-1]``, the same figures as :func:`margins` row by row.
    """
    L = np.asarray(L)
    shape = L.shape[:-1]
    L = L.reshape(-1, L.shape[-1])
    with np.errstate(divide="ignore"):
        lm = np.log(np.abs(L))
    out = margins_from_log(np.log(w), lm, np.unwrap(np.angle(L), axis=-1))
    return tuple(x.reshape(shape) for x in out)


def margins_from_log(logw: np.ndarray, lm: np.ndarray, ph: np.ndarray) -> tuple[np.ndarray, ...]:
    """:func:`margins` from ``log|L|`` and the unwrapped phase (rows, n) at ``log w`` (n,).

    The phase may be offset by whole turns (a product's phases added): the figures only use
    it modulo 360 deg. Only the grid intervals where a crossing happens are interpolated.
    """
    rows = lm.shape[0]
    lo, hi = logw[:-1], logw[1:]
    # gain crossovers
    s = np.sign(lm)
    r, k = np.divmod(np.flatnonzero(s[:, :-1] * s[:, 1:] < 0), lm.shape[1] - 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = lm[r, k] / (lm[r, k] - lm[r, k + 1])
    p = ph[r, k] + f * (ph[r, k + 1] - ph[r, k])
    m = np.degrees(p) + 180.0
    m = (m + 180.0) % 360.0 - 180.0
    pm = np.full(rows, np.inf)
    np.minimum.at(pm, r, m)
    wc = np.full(rows, -np.inf)
    np.maximum.at(wc, r, np.exp(lo[k] + f * (hi[k] - lo[k])))
    wc[np.isinf(wc)] = np.nan
    end = lm[:, -1] > 0.0  # |L| > 1 at the end of the grid (Nyquist): no usable margin
    pm[end] = -np.inf
    wc[end] = math.exp(logw[-1])
    # phase crossovers: phase = -180 (mod 360)
    x = (ph + math.pi) / (2 * math.pi)
    nf = np.floor(x)
    r, k = np.divmod(np.flatnonzero(nf[:, :-1] != nf[:, 1:]), lm.shape[1] - 1)
    target = np.maximum(nf[r, k], nf[r, k + 1])
    f = (target - x[r, k]) / (x[r, k + 1] - x[r, k])
    with np.errstate(invalid="ignore"):
        lk = lm[r, k] + f * (lm[r, k + 1] - lm[r, k])
        valid = lk < 0
    r, k, f, g = r[valid], k[valid], f[valid], -20.0 * lk[valid] / math.log(10.0)
    gm = np.full(rows, np.inf)
    np.minimum.at(gm, r, g)
    wpc = np.full(rows, np.nan)
    first = g == gm[r]  # the first crossing with the smallest margin, as margins() keeps
    rr, i = np.unique(r[first], return_index=True)
    sel = np.flatnonzero(first)[i]
    wpc[rr] = np.exp(lo[k[sel]] + f[sel] * (hi[k[sel]] - lo[k[sel]]))
    return pm, gm, wc, wpc


def _step_many(
    systems: list[_SS], t_final: np.ndarray, dt: float | None
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Unit-step responses of stacked SISO systems of one shape, as python-control's
    ``step_response`` samples them (continuous: 1500 points on ``[0, t_final]``, exact for a
    step; discrete: every sample up to ``t_final``). All the time steps of all systems in one
    go: the state after ``k`` steps is ``M^k z0`` with the augmented ``M = [[Ad, Bd], [0, 1]]``,
    its powers by doubling."""
    A = np.stack([s[0] for s in systems])
    B = np.stack([s[1] for s in systems])
    C = np.stack([s[2] for s in systems])
    D = np.stack([s[3] for s in systems])
    k, n = A.shape[0], A.shape[1]
    if dt is None:
        T = [np.linspace(0.0, tf, 1500) for tf in t_final]
        AB = [_zoh(A[i], B[i], T[i][1] - T[i][0]) for i in range(k)]
        Ad = np.stack([ab[0] for ab in AB])
        Bd = np.stack([ab[1] for ab in AB])
    else:
        T = [np.arange(0.0, tf + dt, dt) for tf in t_final]
        Ad, Bd = A, B
    N = max(t.size for t in T)
    M = np.zeros((k, n + 1, n + 1))
    M[:, :n, :n] = Ad
    M[:, :n, n:] = Bd
    M[:, n, n] = 1.0
    Z = np.zeros((k, n + 1, 1))
    Z[:, n, 0] = 1.0
    P = M
    with np.errstate(over="ignore", invalid="ignore"):
        while Z.shape[-1] < N:
            Z = np.concatenate([Z, P @ Z], axis=-1)
            P = P @ P
        Caug = np.concatenate([C[:, :1, :], D[:, :1, :]], axis=-1)
        Y = (Caug @ Z[:, :, :N])[:, 0, :]
    return T, [Y[i, : T[i].size] for i in range(k)]


def _dcgain(sys: _SS, discrete: bool) -> float:
    A, B, C, D = sys
    n = A.shape[0]
    if n == 0:
        return float(D[0, 0])
    try:
        x = np.linalg.solve((np.eye(n) - A) if discrete else -A, B)
    except np.linalg.LinAlgError:
        return math.inf
    return float((C[:1] @ x + D[:1])[0, 0])


def step_metrics(T: np.ndarray, y: np.ndarray, final: float, threshold: float = 0.02):
    """(overshoot [%], settling time [s]) of a step response, python-control's ``step_info``
    definitions (final value: the DC gain; settling: the first sample after the last one
    outside the ``threshold`` band; nan if it never settles)."""
    if math.isnan(final) or math.isinf(final):
        return math.nan, math.nan
    outside = np.nonzero(np.abs(y / final - 1) >= threshold)[0]
    settled = 0 if outside.size == 0 else outside[-1] + 1
    settling = float(T[settled]) if settled < len(T) else math.nan
    y_os = (np.sign(final) * y).max()
    dy = abs(y_os) - abs(final)
    overshoot = float(abs(100.0 * dy / final)) if dy > 0 else 0.0
    return overshoot, settling


class CascadeArrays:
    """:class:`CascadeModel`'s loops evaluated with numpy over several inertia cases at once.

    Parameters
    ----------
    plant : JointPlant
    gains : CascadeGains or dict of LoopGains
        Loops may be missing while tuning inside-out.
    cases : sequence of str or float
        Inertia cases (:meth:`JointPlant.at`).

    The frequency responses follow the transfer functions of the module docstring; the
    closed-loop state-space systems have the structure of :class:`CascadeModel`'s (the same
    poles, including the cancelled ones), so the stability check agrees with it.
    """

    def __init__(self, plant: JointPlant, gains, cases=INERTIA_CASES):
        self.plant = plant
        self.cases = list(cases)
        self.plants = [plant.at(c) for c in self.cases]
        self.J = np.array([p.J for p in self.plants])
        self.gains = gains.loops() if isinstance(gains, CascadeGains) else dict(gains)
        self._drive: list | None = None
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
        AB = [_zoh(_current_plant_ss(p, J)[0], _current_plant_ss(p, J)[1], dt) for J in self.J]
        A = np.stack([ab[0] for ab in AB])
        B = np.stack([ab[1] for ab in AB])
        C = np.broadcast_to(np.array([[[1.0, 0.0]]]), (len(AB), 1, 2))
        return _ss_response(A, B, C, np.exp(1j * w * dt))

    def _delay(self, loop: str, w: np.ndarray) -> np.ndarray:
        lg = self._g(loop)
        return np.exp(-1j * w * lg.sample_time_s) ** _int_delay(lg)

    def theta_response(self, w: np.ndarray) -> np.ndarray:
        """Discrete i* -> sampled motor angle (ZOH at the speed loop's period), (k, n)."""
        key = (w.size, float(w[0]), float(w[-1]))
        if key not in self._ptheta:
            drives = self._drives()
            A = np.stack([d[0] for d in drives])
            B = np.stack([d[1] for d in drives])
            C = np.stack([d[2][:1] for d in drives])
            self._ptheta[key] = _ss_response(A, B, C, np.exp(1j * w * self.dt("speed")))
        return self._ptheta[key]

    def speed_plant_response(self, w: np.ndarray, discrete: bool) -> np.ndarray:
        """i* -> (measured) motor speed, (k, n); discrete: without the computation delay."""
        if discrete:
            dt = self.dt("speed")
            return (1.0 - np.exp(-1j * w * dt)) / dt * self.theta_response(w)
        Li = pid_response(self._g("current"), w, False) * self.current_plant_response(w, False)
        s = 1j * w[None, :]
        return Li / (1.0 + Li) * self.plant.Kt / (self.J[:, None] * s + self.plant.B)

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
        return pid_response(self._g(loop), w, discrete) * self.plant_response(loop, w, discrete)

    def margins(self, loop: str, discrete: bool = False, n: int = 1500) -> list[Margins]:
        """:meth:`CascadeModel.margins` for every case."""
        w = freq_grid(self.dt(loop) if discrete else None, n=n)
        pm, gm, wc, wpc = margins_many(w, self.open_response(loop, w, discrete))
        return [
            Margins(float(a), float(b), float(c), float(d))
            for a, b, c, d in zip(pm, gm, wc, wpc, strict=True)
        ]

    # ------------------------------------------------------------------ state space
    def _current_closed_lagged(self, J: float) -> _SS:
        lg = self._g("current")
        tau = (_int_delay(lg) + 0.5) * lg.sample_time_s
        chain = _ss_series(_pid_ss(lg), _ss_series(_pade_ss(tau), _current_plant_ss(self.plant, J)))
        return _ss_feedback(chain)

    def _drives(self) -> list:
        """Per case the discrete drive i* -> (theta_k, speed_k) of
        :meth:`CascadeModel._discrete_drive`, the same construction."""
        if self._drive is not None:
            return self._drive
        dt = self.dt("speed")
        out = []
        for J in self.J:
            GA, GB, GC, GD = _ss_series(_mech_ss(self.plant, J), self._current_closed_lagged(J))
            out.append(_encoder_drive(GA, GB, GC, GD, dt))
        self._drive = out
        return out

    def closed_systems(self, loop: str, discrete: bool) -> list[_SS]:
        """The closed loop of :meth:`CascadeModel.closed_loop` per case, as numpy matrices."""
        key = (
            loop,
            discrete,
            *(id(self.gains.get(name)) for name in ("current", "speed", "position")),
        )
        if key not in self._closed_cache:
            self._closed_cache[key] = [
                self._closed(loop, discrete, i) for i in range(len(self.cases))
            ]
        return self._closed_cache[key]

    def _closed(self, loop: str, discrete: bool, i: int) -> _SS:
        p, J = self.plant, float(self.J[i])
        if loop == "current":
            lg = self._g("current")
            if discrete:
                Ac, Bc, _, _ = _current_plant_ss(p, J)
                Pd = _zoh(Ac, Bc, lg.sample_time_s)
                P = (Pd[0], Pd[1], np.array([[1.0, 0.0]]), np.zeros((1, 1)))
                fwd = _ss_series(_pid_ss_discrete(lg), _ss_series(_delay_ss(_int_delay(lg)), P))
            else:
                fwd = _ss_series(_pid_ss(lg), _current_plant_ss(p, J))
            return _ss_feedback(fwd)
        lw = self._g("speed")
        if loop == "speed":
            if discrete:
                A, B, C, D = self._drives()[i]
                keep = [k for k in range(A.shape[0]) if k != A.shape[0] - 2]
                P = (A[np.ix_(keep, keep)], B[keep], C[1:2, keep], D[1:2])
                fwd = _ss_series(_pid_ss_discrete(lw), _ss_series(_delay_ss(_int_delay(lw)), P))
            else:
                P = _ss_series(_mech_ss(p, J), self._closed("current", False, i))
                fwd = _ss_series(_pid_ss(lw), P)
            return _ss_feedback(fwd)
        lp = self._g("position")
        if discrete:
            fwd = _ss_series(
                self._drives()[i],
                _ss_series(_delay_ss(_int_delay(lw)), _pid_ss_discrete(lw)),
            )
            A, B, C, D = _ss_feedback(fwd, row=1)
            P = (A, B, C[:1], D[:1])
            return _ss_feedback(_ss_series(_pid_ss_discrete(lp), P))
        P = _ss_series(_INTEGRATOR, self._closed("speed", False, i))
        return _ss_feedback(_ss_series(_pid_ss(lp), P))

    def step_responses(
        self, loop: str, discrete: bool, t_final
    ) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """Closed-loop unit-step responses ``(times, outputs)`` per case, one batched
        simulation (continuous: 1500 points on ``[0, t_final]``; discrete: every sample)."""
        systems = self.closed_systems(loop, discrete)
        tf = np.broadcast_to(np.asarray(t_final, float), (len(systems),))
        return _step_many(systems, tf, self.dt(loop) if discrete else None)

    def step_figures(self, loop: str, discrete: bool, t_final) -> list[tuple[float, float]]:
        """(overshoot [%], 2 % settling time [s]) per case, one batched simulation."""
        systems = self.closed_systems(loop, discrete)
        T, Y = self.step_responses(loop, discrete, t_final)
        return [
            step_metrics(T[i], Y[i], _dcgain(systems[i], discrete)) for i in range(len(systems))
        ]

    def stable(self, loop: str, discrete: bool) -> list[bool]:
        out = []
        for A, *_ in self.closed_systems(loop, discrete):
            p = np.linalg.eigvals(A) if A.size else np.zeros(0)
            out.append(
                bool(np.all(np.abs(p) < 1.0 - 1e-9)) if discrete else bool(np.all(p.real < 0.0))
            )
        return out
