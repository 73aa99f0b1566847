"""Outer force loop that corrects the position set-point (Kong et al. 1998, §2.2).

Structure (Kong et al. 1998, fig. 3, one force-controlled direction of the compliance frame; the
paper aligns the tool frame with the compliance frame so each direction is an independent loop)::

    f_d --(+)--> PID --> K^-1 --> dx --(+ x_d)--> position loop / actuator G_a --> x
          (-)                                                                      |
           f <--------------- K_F (sensor) <---- K_E (environment) <--------------+

* force regulator: discrete PID with per-sample gains (Kp, Ki, Kd) at ``sample_time_s``::

      u_k = Kp e_k + Ki sum_{i<=k} e_i + Kd (e_k - e_{k-1})     [N]

* stiffness matrix (one diagonal element) K turns the force command into a position correction
  ``dx = u / K`` [m] added to the desired position ``x_d``;
* actuator: the existing position loop, second order ``w_n^2 / (s^2 + 2 zeta w_n s + w_n^2)``
  (the paper's hydraulic drive: w_n in [290, 350] rad/s, zeta in [0.1, 0.3]), held (ZOH) over the
  force period;
* environment: ``f = K_E max(x - x_surface, 0)`` (contact is lost if the tool backs off);
  sensor gain K_F = 1.

What Kong et al. 1998 give (§3): K_E = 700, 5000, 30000 (unit not printed; N/m taken) with
(Kp, Ki, Kd) = (0.55, 0.0062, 0.0041), (0.282, 0.0036, 0.0023), (0.142, 0.0043, 0.0017)
(figs. 6-8), and the robustness study (fig. 9): w_n, zeta random in their ranges with the
K_E = 700 design -- the force response barely changes; fig. 10: a design used on another
stiffness changes its dynamics markedly.

Every assumption beside the source's value
-------------------------------------------
============================  ===========================================  =====================
quantity                      Kong et al. 1998                             here
============================  ===========================================  =====================
force-loop period T_F         not given: the C30 DSP samples the wrist     1 ms, ASSUMED
                              sensor "at fixed times" (§2.2.2)
transport delay               the correction goes to the motion            none, ASSUMED (one
                              controller over RS-232 "at uniform times"    period would cost
                              (§2.2.2): at least one period                 ~24 deg at 416 rad/s)
stiffness matrix K            named (fig. 3), no value                     5000 N/m, ASSUMED
sensor coefficient K_F        named (fig. 3), no value                     1
regulator                     "PD" in §3's text, three gains with K_I      discrete PID, gains
                              in figs. 6-8                                 per sample at T_F
actuator                      hydraulic cylinder, w_n in [290, 350] rad/s  2nd order, ZOH at
                              and damping in [0.1, 0.3] (§3)               T_F; 320 rad/s, 0.2
environment                   K_E = 700, 5000, 30000                       linear spring,
                                                                           contact one-sided
============================  ===========================================  =====================

The source's findings, and ours under these assumptions (:func:`force_margins`,
:func:`force_loop`; ``tests/control/test_control.py`` checks the directions):

1. *Each design is stable on its environment* -- reproduced (all three settle, no overshoot).
2. *"As the stiffness rises, the control performance tends to get worse"* -- reproduced in the
   stability margins: gain margin 30.0, 18.7, 8.2 dB, and the K_E = 30000 design's loop crosses
   over at 416 rad/s, on the actuator's resonance (phase margin 21 deg there). **Not** in the
   settling time, which improves (4.8, 1.3, 0.24 s): with T_F = 1 ms and K = 5000 N/m the
   published integral gains act as ``K_i K_E / (K T_F)`` = 0.87, 3.6, 25.8 1/s, so the stiffer
   the environment, the faster the (integral-dominated) response. The paper's figs. 6-8 are
   not legible, so which measure its sentence means cannot be read off; a longer T_F or a
   transport delay (the RS-232 link) would shrink the stiff design's margin further and make
   its response oscillate, the likelier reading. Other K, T_F pairs were searched (T_F 0.5-10
   ms, K 100-100 000 N/m, gains per sample or per second, no delay): none keeps all three
   designs stable with the settling time growing with K_E.
3. *The actuator's spread barely changes the response* (K_E = 700 design) -- reproduced
   (largest deviation well under 5 % of the set-point).
4. *A design on another stiffness changes markedly* -- reproduced (the K_E = 700 design is
   unstable on K_E = 30000; on 5000 it settles 5 x faster).

T_F and K are assumptions; a study that depends on them must say so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from armlab._lazy import lazy_import
from armlab.errors import InputError, SpecError

if TYPE_CHECKING:
    import control as ct  # the real module for the type checker
else:
    ct = lazy_import("control")  # python-control loads at the first model built

__all__ = [
    "SEED_DESIGNS",
    "ForceLoopResult",
    "ForceRobustness",
    "force_loop",
    "force_loop_model",
    "force_robustness",
    "STIFFNESS_N_M",
    "FORCE_SAMPLE_TIME_S",
    "force_open_loop",
    "force_margins",
]

#: The paper's designs: environment stiffness [N/m] -> (Kp, Ki, Kd) per sample
#: (Kong et al. 1998, figs. 6-8).
SEED_DESIGNS: dict[float, tuple[float, float, float]] = {
    700.0: (0.55, 0.0062, 0.0041),
    5000.0: (0.282, 0.0036, 0.0023),
    30000.0: (0.142, 0.0043, 0.0017),
}
#: Stiffness-matrix element K [N/m] (ASSUMED, see the module docstring).
STIFFNESS_N_M = 5000.0
#: Force-loop period [s] (ASSUMED).
FORCE_SAMPLE_TIME_S = 1e-3


def _gains(environment_stiffness_N_m: float, gains) -> tuple[float, float, float]:
    if gains is None:
        key = float(environment_stiffness_N_m)
        if key not in SEED_DESIGNS:
            raise SpecError(
                f"force loop: no seed design for K_E={environment_stiffness_N_m} N/m "
                f"(seed designs: {sorted(SEED_DESIGNS)}); pass gains=(Kp, Ki, Kd)"
            )
        return SEED_DESIGNS[key]
    g = tuple(float(x) for x in gains)
    if len(g) != 3 or not all(math.isfinite(x) and x >= 0 for x in g):
        raise SpecError(
            f"force loop: gains must be three finite numbers >= 0 (Kp, Ki, Kd), got {gains!r}"
        )
    return g


def _check(name, x, lo=0.0):
    if not (math.isfinite(x) and x > lo):
        raise SpecError(f"force loop: {name}={x!r} must be a finite number > {lo}")


@dataclass
class ForceLoopResult:
    """A force step response.

    Attributes
    ----------
    t : ndarray (n,)
        Times in [s].
    force_N, correction_m, position_m : ndarray (n,)
        Contact force [N], position correction dx [m] and tool position [m].
    setpoint_N : float
    environment_stiffness_N_m, natural_frequency_rad_s, damping : float
    gains : tuple (Kp, Ki, Kd)
    """

    t: np.ndarray
    force_N: np.ndarray
    correction_m: np.ndarray
    position_m: np.ndarray
    setpoint_N: float
    environment_stiffness_N_m: float
    natural_frequency_rad_s: float
    damping: float
    gains: tuple
    meta: dict = field(default_factory=dict)

    @property
    def overshoot_pct(self) -> float:
        return float(max(0.0, (self.force_N.max() - self.setpoint_N) / self.setpoint_N * 100.0))

    @property
    def settling_time_s(self) -> float:
        """2 % settling time in [s] (inf if not settled within the simulation)."""
        out = np.flatnonzero(np.abs(self.force_N - self.setpoint_N) > 0.02 * self.setpoint_N)
        if out.size == 0:
            return 0.0
        if out[-1] + 1 >= self.t.size:
            return math.inf
        return float(self.t[out[-1] + 1])

    @property
    def final_error_N(self) -> float:
        return float(self.setpoint_N - self.force_N[-1])

    @property
    def stable(self) -> bool:
        """Bounded and settling (within 2 % by the end)."""
        return bool(np.all(np.isfinite(self.force_N)) and math.isfinite(self.settling_time_s))

    def to_dict(self) -> dict:
        return {
            "environment_stiffness_N_m": self.environment_stiffness_N_m,
            "gains": list(self.gains),
            "setpoint_N": self.setpoint_N,
            "natural_frequency_rad_s": self.natural_frequency_rad_s,
            "damping": self.damping,
            "overshoot_pct": self.overshoot_pct,
            "settling_time_s": self.settling_time_s
            if math.isfinite(self.settling_time_s)
            else None,
            "final_error_N": self.final_error_N,
            "stable": self.stable,
        }


def force_open_loop(
    environment_stiffness_N_m: float,
    gains=None,
    *,
    stiffness_N_m: float = STIFFNESS_N_M,
    natural_frequency_rad_s: float = 320.0,
    damping: float = 0.2,
    sample_time_s: float = FORCE_SAMPLE_TIME_S,
) -> ct.TransferFunction:
    """Open force loop ``L(z) = C(z) K_E / K ZOH{G_a}(z)`` (contact kept), discrete TF."""
    kp, ki, kd = _gains(environment_stiffness_N_m, gains)
    for name, x in (
        ("environment_stiffness_N_m", environment_stiffness_N_m),
        ("stiffness_N_m", stiffness_N_m),
        ("natural_frequency_rad_s", natural_frequency_rad_s),
        ("damping", damping),
        ("sample_time_s", sample_time_s),
    ):
        _check(name, float(x))
    T = sample_time_s
    C = (
        ct.tf([kp], [1.0], T)
        + ki * ct.tf([1.0, 0.0], [1.0, -1.0], T)
        + kd * ct.tf([1.0, -1.0], [1.0, 0.0], T)
    )
    wn, z = natural_frequency_rad_s, damping
    Ga = ct.sample_system(ct.tf([wn**2], [1.0, 2 * z * wn, wn**2]), T, "zoh")
    return C * (environment_stiffness_N_m / stiffness_N_m) * Ga


def force_margins(environment_stiffness_N_m: float, gains=None, **model):
    """Stability margins of the force loop (:class:`armlab.control.margins.Margins`): phase and
    gain margin, crossover in [rad/s], from its frequency response up to Nyquist. ``model``:
    the keywords of :func:`force_open_loop`."""
    from armlab.control.lti import response
    from armlab.control.margins import freq_grid, margins

    L = force_open_loop(environment_stiffness_N_m, gains, **model)
    w = freq_grid(L.dt, w_min=1e-3, n=6000)
    return margins(w, response(ct.ss(L), w, L.dt))


def force_loop_model(
    environment_stiffness_N_m: float,
    gains=None,
    *,
    stiffness_N_m: float = STIFFNESS_N_M,
    natural_frequency_rad_s: float = 320.0,
    damping: float = 0.2,
    sample_time_s: float = FORCE_SAMPLE_TIME_S,
) -> ct.TransferFunction:
    """Linear (contact kept) closed force loop f_d -> f as a discrete python-control TF.

    ``L(z) = C(z) K_E / K ZOH{G_a}(z)`` with ``C(z) = Kp + Ki z/(z - 1) + Kd (z - 1)/z``.
    """
    L = force_open_loop(
        environment_stiffness_N_m,
        gains,
        stiffness_N_m=stiffness_N_m,
        natural_frequency_rad_s=natural_frequency_rad_s,
        damping=damping,
        sample_time_s=sample_time_s,
    )
    return ct.feedback(L, 1)


def force_loop(
    environment_stiffness_N_m: float,
    gains=None,
    *,
    force_setpoint_N: float = 10.0,
    stiffness_N_m: float = STIFFNESS_N_M,
    natural_frequency_rad_s: float = 320.0,
    damping: float = 0.2,
    sample_time_s: float = FORCE_SAMPLE_TIME_S,
    duration_s: float = 8.0,
) -> ForceLoopResult:
    """Simulate a force step on the Kong et al. 1998 loop (contact nonlinearity included).

    Parameters
    ----------
    environment_stiffness_N_m : float
        K_E in [N/m].
    gains : (Kp, Ki, Kd), optional
        Per-sample PID gains; default the paper's design for this K_E.
    force_setpoint_N : float
        Step of desired force in [N] (the tool starts touching the surface, f = 0).
    stiffness_N_m : float
        Stiffness-matrix element K in [N/m].
    natural_frequency_rad_s, damping : float
        Actuator (inner position loop) parameters.
    sample_time_s, duration_s : float

    Returns
    -------
    ForceLoopResult
    """
    kp, ki, kd = _gains(environment_stiffness_N_m, gains)
    for name, value in (
        ("environment_stiffness_N_m", environment_stiffness_N_m),
        ("stiffness_N_m", stiffness_N_m),
        ("force_setpoint_N", force_setpoint_N),
        ("natural_frequency_rad_s", natural_frequency_rad_s),
        ("damping", damping),
        ("sample_time_s", sample_time_s),
        ("duration_s", duration_s),
    ):
        _check(name, float(value))
    T = float(sample_time_s)
    n = int(round(duration_s / T)) + 1
    wn, zeta = float(natural_frequency_rad_s), float(damping)
    A = np.array([[0.0, 1.0], [-wn * wn, -2 * zeta * wn]])
    B = np.array([0.0, wn * wn])
    from scipy.linalg import expm

    M = np.zeros((3, 3))
    M[:2, :2], M[:2, 2] = A * T, B * T
    E = expm(M)
    Ad, Bd = E[:2, :2], E[:2, 2]
    KE, K, fd = float(environment_stiffness_N_m), float(stiffness_N_m), float(force_setpoint_N)
    x = np.zeros(2)  # tool position (0 = surface) and speed
    s_e, e1 = 0.0, 0.0
    f_out = np.empty(n)
    dx_out = np.empty(n)
    x_out = np.empty(n)
    for k in range(n):
        f = KE * max(x[0], 0.0)
        e = fd - f
        s_e += e
        u = kp * e + ki * s_e + kd * (e - e1)
        e1 = e
        dx = u / K
        f_out[k], dx_out[k], x_out[k] = f, dx, x[0]
        x = Ad @ x + Bd * dx
        if not math.isfinite(x[0]) or abs(x[0]) > 1e3:
            f_out[k + 1 :] = np.nan
            dx_out[k + 1 :] = np.nan
            x_out[k + 1 :] = np.nan
            break
    return ForceLoopResult(
        t=T * np.arange(n),
        force_N=f_out,
        correction_m=dx_out,
        position_m=x_out,
        setpoint_N=fd,
        environment_stiffness_N_m=KE,
        natural_frequency_rad_s=wn,
        damping=zeta,
        gains=(kp, ki, kd),
        meta={"stiffness_N_m": K, "sample_time_s": T},
    )


@dataclass
class ForceRobustness:
    """Force responses with the actuator drawn at random (Kong et al. 1998, fig. 9).

    Attributes
    ----------
    nominal : ForceLoopResult
        At the range centres (w_n = 320 rad/s, zeta = 0.2).
    runs : list of ForceLoopResult
    natural_frequency_rad_s, damping : ndarray (n,)
        The draws.
    max_deviation_N : float
        Largest |f_run(t) - f_nominal(t)| over runs and time, in [N].
    """

    nominal: ForceLoopResult
    runs: list
    natural_frequency_rad_s: np.ndarray
    damping: np.ndarray

    @property
    def max_deviation_N(self) -> float:
        return float(max(np.nanmax(np.abs(r.force_N - self.nominal.force_N)) for r in self.runs))

    @property
    def all_stable(self) -> bool:
        return all(r.stable for r in self.runs)

    def to_dict(self) -> dict:
        return {
            "nominal": self.nominal.to_dict(),
            "n_runs": len(self.runs),
            "max_deviation_N": self.max_deviation_N,
            "all_stable": self.all_stable,
            "max_overshoot_pct": max(r.overshoot_pct for r in self.runs),
            "max_settling_time_s": max(r.settling_time_s for r in self.runs),
        }


def force_robustness(
    environment_stiffness_N_m: float,
    gains=None,
    *,
    n_runs: int = 20,
    seed: int = 0,
    natural_frequency_range_rad_s=(290.0, 350.0),
    damping_range=(0.1, 0.3),
    **kwargs,
) -> ForceRobustness:
    """Kong et al. 1998's robustness study: w_n and zeta uniform in their ranges (seeded).

    ``kwargs`` go to :func:`force_loop`.
    """
    if int(n_runs) < 1:
        raise InputError(f"n_runs must be >= 1, got {n_runs}")
    rng = np.random.default_rng(seed)
    (w0, w1), (z0, z1) = natural_frequency_range_rad_s, damping_range
    if not (0 < w0 <= w1 and 0 < z0 <= z1):
        raise SpecError(
            f"force robustness: bad ranges {natural_frequency_range_rad_s}, {damping_range}"
        )
    wn = rng.uniform(w0, w1, int(n_runs))
    zeta = rng.uniform(z0, z1, int(n_runs))
    nominal = force_loop(
        environment_stiffness_N_m,
        gains,
        natural_frequency_rad_s=0.5 * (w0 + w1),
        damping=0.5 * (z0 + z1),
        **kwargs,
    )
    runs = [
        force_loop(environment_stiffness_N_m, gains, natural_frequency_rad_s=w, damping=z, **kwargs)
        for w, z in zip(wn, zeta, strict=True)
    ]
    return ForceRobustness(nominal=nominal, runs=runs, natural_frequency_rad_s=wn, damping=zeta)
