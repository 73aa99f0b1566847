"""Robust inside-out tuning of a joint cascade (current PI -> speed PI -> position P).

Method (thesis 5.3-5.4 designs one loop at a time at the workspace centre; we keep the rules
and make the result hold over the whole inertia range):

1. **Current loop, PI, pole placement** (technical optimum): the PI zero cancels the armature
   pole, ``Ti = L / R``, so ``L_i(s) ~ kp / (L s)`` and the crossover is ``w_ci = kp / L``. The
   refinement searches the zero in ``Ti = r L / R`` (r in 0.5..2) and the largest kp.
2. **Speed loop, PI, symmetric optimum** (Kessler): around the small lag ``T_sum`` of the current
   loop and of the 1 kHz sampling, ``w_cw = 1 / (a T_sum)``, ``Ti = a^2 T_sum``,
   ``kp = J w_cw / Kt``. The refinement searches the zero position ``w_z = ki / kp = beta w_J``
   (``w_J = kp Kt / J_max``, beta in 0.05..0.5) and the largest kp; among the shapes within
   15 % of the best worst-case bandwidth it keeps the strongest integral (largest beta), which
   rejects gravity and friction loads fastest.
3. **Position loop, P** (the thesis' position controller; SIMC rule for an integrating plant
   with lag ``T_w``: ``kp = 1 / (tau_c + T_w)``): the largest kp (or the requested bandwidth).

Numerical refinement: for each candidate shape the gain is bisected to the largest value for
which **every** inertia case (min, nominal, max) meets the phase margin and gain margin, for the
continuous loop **and** the discrete loop (ZOH + computation delay + encoder-differenced speed,
see :mod:`armlab.control.loops`), and the bandwidth separation to the inner loop holds (worst
case over the inertia range); the shape with the highest worst-case crossover wins. The
position loop's step overshoot is then checked (all cases, both models) and kp reduced until it
meets the limit. Figures reported by :class:`LoopGains` are recomputed on the python-control
models of the final design.

Bandwidth separation (defaults): current >= 5 x speed, speed >= 4 x position crossovers — the
inner loop then adds < ~15 deg of lag at the outer crossover, and an inner loop whose inertia
changes (speed loop, joint 1: x4) still stays above the outer one at its worst.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab._lazy import lazy_import
from armlab.control.gains import ArmGains, CascadeGains, LoopGains, PlantSummary
from armlab.control.loops import (
    CascadeArrays,
    CascadeModel,
    _response,
    freq_grid,
    margins,
    margins_from_log,
    pid_response,
    step_figures,
)
from armlab.control.plant import INERTIA_CASES, JointPlant, inertia_range, joint_plant
from armlab.errors import ArmlabError, SpecError
from armlab.robot.controller import ControllerProfile, load_profile

if TYPE_CHECKING:
    import control as ct  # the real module for the type checker
else:
    ct = lazy_import("control")  # python-control loads at the first model built

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["TuningSpec", "tune_cascade", "tune_arm", "check_cascade"]


@dataclass
class TuningSpec:
    """What the tuned cascade must meet.

    Attributes
    ----------
    position_bandwidth_rad_s : float or None
        Target crossover of the position loop in [rad/s] (nominal inertia); None: the highest
        the margins and separations allow.
    rise_time_s : float or None
        Alternative to the bandwidth: 10-90 % rise time of the position loop in [s]
        (``w_c = 2.2 / t_r``, first-order approximation).
    phase_margin_deg : float
        Minimum phase margin, every loop, every inertia, continuous and discrete (0 < pm < 90).
    gain_margin_dB : float
        Minimum gain margin (> 0).
    overshoot_pct : float
        Position-loop step overshoot limit in [%].
    inner_overshoot_pct : float or None
        Optional limit for the current and speed loops' step overshoot (PI loops overshoot by
        design, ~20-50 %; the position loop filters it).
    separation_current_speed, separation_speed_position : float
        Minimum crossover ratios (>= 1).
    current_sample_time_s, speed_sample_time_s, position_sample_time_s : float
        Loop periods in [s] (defaults: 20 kHz amplifier, 1 kHz card).
    delay_samples : int
        Computation delay in samples (1: output written at the next sample).
    method : {"tustin", "backward", "zoh"}
        Integral discretisation of the incremental PID.
    da_range_V, da_bits : float, int
        D/A of the card (+-10 V, 12 bit).
    n_inertia_samples, seed : int
        Workspace samples for the inertia range.
    """

    position_bandwidth_rad_s: float | None = None
    rise_time_s: float | None = None
    phase_margin_deg: float = 50.0
    gain_margin_dB: float = 6.0
    overshoot_pct: float = 5.0
    inner_overshoot_pct: float | None = None
    separation_current_speed: float = 5.0
    separation_speed_position: float = 4.0
    current_sample_time_s: float = 5e-5
    speed_sample_time_s: float = 1e-3
    position_sample_time_s: float = 1e-3
    delay_samples: int = 1
    method: str = "tustin"
    da_range_V: float = 10.0
    da_bits: int = 12
    n_inertia_samples: int = 400
    seed: int = 0

    def validate(self, joint: str = "") -> TuningSpec:
        """Raise :class:`SpecError` naming the joint and the spec if anything is impossible."""
        who = f"{joint}: " if joint else ""

        def bad(name, why):
            raise SpecError(f"{who}spec {name}={getattr(self, name)!r} {why}")

        if not (0.0 < self.phase_margin_deg < 90.0):
            bad("phase_margin_deg", "must be in (0, 90) deg")
        if not (self.gain_margin_dB > 0.0 and math.isfinite(self.gain_margin_dB)):
            bad("gain_margin_dB", "must be a finite number > 0 dB")
        if not (self.overshoot_pct >= 0.0):
            bad("overshoot_pct", "must be >= 0 %")
        if self.inner_overshoot_pct is not None and not self.inner_overshoot_pct >= 0.0:
            bad("inner_overshoot_pct", "must be >= 0 %")
        for name in ("separation_current_speed", "separation_speed_position"):
            if not (getattr(self, name) >= 1.0 and math.isfinite(getattr(self, name))):
                bad(name, "must be a finite ratio >= 1")
        for name in ("current_sample_time_s", "speed_sample_time_s", "position_sample_time_s"):
            if not (getattr(self, name) > 0.0 and math.isfinite(getattr(self, name))):
                bad(name, "must be > 0 s")
        if abs(self.position_sample_time_s - self.speed_sample_time_s) > 1e-12:
            bad("position_sample_time_s", "must equal speed_sample_time_s (same interrupt)")
        if self.position_bandwidth_rad_s is not None and self.rise_time_s is not None:
            bad("rise_time_s", "cannot be given together with position_bandwidth_rad_s")
        if self.position_bandwidth_rad_s is not None and not (
            self.position_bandwidth_rad_s > 0 and math.isfinite(self.position_bandwidth_rad_s)
        ):
            bad("position_bandwidth_rad_s", "must be a finite number > 0 rad/s")
        if self.rise_time_s is not None and not (
            self.rise_time_s > 0 and math.isfinite(self.rise_time_s)
        ):
            bad("rise_time_s", "must be > 0 s")
        if int(self.delay_samples) != self.delay_samples or self.delay_samples < 0:
            bad("delay_samples", "must be a whole number >= 0")
        if self.method not in ("tustin", "backward", "zoh"):
            bad("method", "must be tustin, backward or zoh")
        return self

    @property
    def target_bandwidth_rad_s(self) -> float | None:
        if self.position_bandwidth_rad_s is not None:
            return float(self.position_bandwidth_rad_s)
        if self.rise_time_s is not None:
            return 2.2 / float(self.rise_time_s)
        return None

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_kwargs(cls, joint: str = "", **spec) -> TuningSpec:
        names = set(cls.__dataclass_fields__)
        unknown = sorted(set(spec) - names)
        if unknown:
            raise SpecError(
                f"{joint + ': ' if joint else ''}unknown tuning spec "
                f"{', '.join(unknown)} (known: {', '.join(sorted(names))})"
            )
        return cls(**spec).validate(joint)


# ---------------------------------------------------------------------------- helpers
_PM_PAD = 0.5  # [deg] kept in the search so the final python-control check passes
_GM_PAD = 0.2  # [dB]


@dataclass
class _Case:
    """Sampled open-loop plant responses of one loop at one inertia case."""

    w_c: np.ndarray
    P_c: np.ndarray
    w_d: np.ndarray
    P_d: np.ndarray
    extra: dict = field(default_factory=dict)


def _resp(sys, w, dt=None):
    return _response(ct.ss(sys), w, dt)


def _worst(cases: list[_Case], lg: LoopGains, spec: TuningSpec):
    """(ok, worst pm, worst gm, min crossover, max crossover) over cases, cont + disc."""
    pm, gm, wmin, wmax = math.inf, math.inf, math.inf, 0.0
    for c in cases:
        for w, P, disc in ((c.w_c, c.P_c, False), (c.w_d, c.P_d, True)):
            m = margins(w, pid_response(lg, w, disc) * P)
            wc = 0.0 if math.isnan(m.crossover_rad_s) else m.crossover_rad_s  # no crossover
            pm, gm = min(pm, m.phase_margin_deg), min(gm, m.gain_margin_dB)
            if not disc:
                wmin, wmax = min(wmin, wc), max(wmax, wc)
    ok = pm >= spec.phase_margin_deg + _PM_PAD and gm >= spec.gain_margin_dB + _GM_PAD
    return ok, pm, gm, wmin, wmax


def _bisect_max(feasible, lo: float, hi: float, n: int = 40) -> float | None:
    """Largest x in [lo, hi] (log scale) with feasible(x), assuming monotone; None if none."""
    if not feasible(lo):
        return None
    if feasible(hi):
        return hi
    a, b = math.log(lo), math.log(hi)
    for _ in range(n):
        m = 0.5 * (a + b)
        if feasible(math.exp(m)):
            a = m
        else:
            b = m
        if b - a < 1e-3:
            break
    return math.exp(a)


def _log_polar(R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(log|R|, unwrapped phase) along the last axis."""
    with np.errstate(divide="ignore"):
        return np.log(np.abs(R)), np.unwrap(np.angle(R), axis=-1)


def _pid_polar(case: _Case, lgs: list[LoopGains]):
    """(log|C|, phase of C) of candidate PI/P controllers (m, n) on the continuous and the
    discrete grid, from the gains directly (:func:`pid_response`'s ``C``)."""
    if any(lg.kd for lg in lgs):  # a derivative term: the general evaluation
        return (
            _log_polar(np.stack([pid_response(lg, case.w_c, False) for lg in lgs])),
            _log_polar(np.stack([pid_response(lg, case.w_d, True) for lg in lgs])),
        )
    kp = np.array([lg.kp for lg in lgs])[:, None]
    ki = np.array([lg.ki for lg in lgs])[:, None]
    im = -ki / case.w_c[None, :]  # C(jw) = kp - j ki / w
    cont = (0.5 * np.log(kp * kp + im * im), np.arctan2(im, kp))
    if "den_d" not in case.extra:
        th = case.w_d * case.extra["dt_d"]
        den = 1.0 - np.exp(-1j * th)
        case.extra["den_d"] = (np.cos(th), np.sin(th), np.cos(2 * th), np.sin(2 * th))
        case.extra["den_d"] += _log_polar(den)
    c1, s1, c2, s2, lden, pden = case.extra["den_d"]
    q0 = np.array([lg.q0 for lg in lgs])[:, None]
    q1 = np.array([lg.q1 for lg in lgs])[:, None]
    q2 = np.array([lg.q2 for lg in lgs])[:, None]
    re = q0 + q1 * c1 + q2 * c2  # q0 + q1 z^-1 + q2 z^-2 at z = e^{j w T}
    im = -(q1 * s1 + q2 * s2)
    with np.errstate(divide="ignore"):
        lnum = 0.5 * np.log(re * re + im * im)
    pnum = np.arctan2(im, re)
    if not (np.all(q2 == 0.0) and np.all(np.abs(q1) < q0)):  # else Re > 0: no wrap
        pnum = np.unwrap(pnum, axis=-1)
    return cont, (lnum - lden, pnum - pden)


def _worst_many(case: _Case, lgs: list[LoopGains], spec: TuningSpec):
    """:func:`_worst` of several candidate controllers at once; ``case`` holds the responses
    of every inertia case stacked, (k, n). Returns arrays (ok, pm, gm, wmin, wmax) (m,).

    ``log|C P| = log|C| + log|P|`` and the phases add: the plant's part is computed once per
    case (``case.extra``), only the controller's per candidate."""
    if "polar" not in case.extra:
        case.extra["polar"] = (
            _log_polar(case.P_c),
            _log_polar(case.P_d),
            np.log(case.w_c),
            np.log(case.w_d),
        )
    (lPc, pPc), (lPd, pPd), lwc, lwd = case.extra["polar"]
    m, k = len(lgs), case.P_c.shape[0]
    (lCc, pCc), (lCd, pCd) = _pid_polar(case, lgs)
    n_c, n_d = case.w_c.size, case.w_d.size
    pm_c, gm_c, wc, _ = margins_from_log(
        lwc,
        (lCc[:, None] + lPc[None]).reshape(m * k, n_c),
        (pCc[:, None] + pPc[None]).reshape(m * k, n_c),
    )
    pm_d, gm_d, _, _ = margins_from_log(
        lwd,
        (lCd[:, None] + lPd[None]).reshape(m * k, n_d),
        (pCd[:, None] + pPd[None]).reshape(m * k, n_d),
    )
    wc = np.where(np.isnan(wc), 0.0, wc).reshape(m, k)  # no crossover
    pm = np.minimum(pm_c.reshape(m, k).min(axis=1), pm_d.reshape(m, k).min(axis=1))
    gm = np.minimum(gm_c.reshape(m, k).min(axis=1), gm_d.reshape(m, k).min(axis=1))
    ok = (pm >= spec.phase_margin_deg + _PM_PAD) & (gm >= spec.gain_margin_dB + _GM_PAD)
    return ok, pm, gm, wc.min(axis=1), wc.max(axis=1)


def _bisect_max_many(feasible, lo: float, hi: float, m: int, n: int = 40) -> list[float | None]:
    """:func:`_bisect_max` for ``m`` candidate shapes in lockstep: ``feasible(xs, idx)`` tells
    for the values ``xs`` of the shapes ``idx`` (lists) whether each is feasible. The same
    steps as the scalar search, so the same results."""
    everyone = list(range(m))
    f_lo = feasible([lo] * m, everyone)
    f_hi = feasible([hi] * m, everyone)
    out: list[float | None] = [None if not f_lo[i] else (hi if f_hi[i] else None) for i in everyone]
    active = [i for i in everyone if f_lo[i] and not f_hi[i]]
    a = {i: math.log(lo) for i in active}
    b = {i: math.log(hi) for i in active}
    for _ in range(n):
        if not active:
            break
        mids = [0.5 * (a[i] + b[i]) for i in active]
        feas = feasible([math.exp(x) for x in mids], active)
        for i, x, f in zip(active, mids, feas, strict=True):
            if f:
                a[i] = x
            else:
                b[i] = x
        if all(b[i] - a[i] < 1e-3 for i in active):
            break
    for i in active:
        out[i] = math.exp(a[i])
    return out


def _loop(
    loop: str, kind: str, kp: float, ki: float, dt: float, spec: TuningSpec, plant: JointPlant
) -> LoopGains:
    kw: dict[str, Any] = {}
    if loop == "current":
        lo, hi = -plant.supply_voltage_V, plant.supply_voltage_V
    elif loop == "speed":
        lo, hi = -plant.current_limit_A, plant.current_limit_A
        kw = {
            "output_per_volt": plant.current_limit_A / spec.da_range_V,
            "da_range_V": spec.da_range_V,
            "da_bits": spec.da_bits,
        }
    else:
        lo, hi = -plant.speed_limit_rad_s, plant.speed_limit_rad_s
    return LoopGains(
        loop=loop,
        kind=kind,
        kp=kp,
        ki=ki,
        sample_time_s=dt,
        method=spec.method,
        output_min=lo,
        output_max=hi,
        delay_samples=float(spec.delay_samples),
        **kw,
    )


# ---------------------------------------------------------------------------- per loop
def _tune_current(plants: dict[str, JointPlant], spec: TuningSpec, n_grid: int) -> LoopGains:
    p0 = plants["nominal"]
    dt = spec.current_sample_time_s
    cases = []
    for p in plants.values():
        m = CascadeModel(p, {"current": _loop("current", "PI", 1.0, 1.0, dt, spec, p)})
        Pc = p.voltage_to_current()
        Pd = m.current_plant(True)
        w_c = freq_grid(None, n=n_grid)
        w_d = freq_grid(dt, n=n_grid)
        zi = np.exp(-1j * w_d * dt) ** spec.delay_samples
        cases.append(_Case(w_c, _resp(Pc, w_c), w_d, _resp(Pd, w_d, dt) * zi))
    best = None
    for r in (0.5, 0.7, 1.0, 1.4, 2.0):
        Ti = r * p0.Te

        def feasible(kp, Ti=Ti):
            return _worst(cases, _loop("current", "PI", kp, kp / Ti, dt, spec, p0), spec)[0]

        kp = _bisect_max(feasible, p0.L * 1.0, p0.L * 10.0 / dt)
        if kp is None:
            continue
        lg = _loop("current", "PI", kp, kp / Ti, dt, spec, p0)
        wmin = _worst(cases, lg, spec)[3]
        if best is None or wmin > best[0]:
            best = (wmin, lg)
    if best is None:
        raise SpecError(
            f"{p0.joint}: no current-loop PI meets phase_margin_deg>="
            f"{spec.phase_margin_deg} and gain_margin_dB>={spec.gain_margin_dB} "
            f"at current_sample_time_s={spec.current_sample_time_s}"
        )
    return best[1]


def _tune_speed(plants, current: LoopGains, spec: TuningSpec, n_grid: int) -> LoopGains:
    p0 = plants["nominal"]
    dt = spec.speed_sample_time_s
    cases, wci_min = [], math.inf
    for p in plants.values():
        dummy = _loop("speed", "PI", 1.0, 1.0, dt, spec, p)
        m = CascadeModel(p, {"current": current, "speed": dummy})
        wci_min = min(wci_min, m.margins("current", False, n=n_grid).crossover_rad_s)
        w_c = freq_grid(None, n=n_grid)
        w_d = freq_grid(dt, n=n_grid)
        zi = np.exp(-1j * w_d * dt) ** spec.delay_samples
        cases.append(
            _Case(
                w_c, _resp(m.speed_plant(False), w_c), w_d, _resp(m.speed_plant(True), w_d, dt) * zi
            )
        )
    w_cap = wci_min / spec.separation_current_speed
    J_max = max(p.J for p in plants.values())
    found = []
    for beta in np.geomspace(0.05, 0.5, 8):

        def make(kp, beta=beta):
            return _loop("speed", "PI", kp, kp * beta * kp * p0.Kt / J_max, dt, spec, p0)

        def feasible(kp, make=make):
            ok, _, _, _, wmax = _worst(cases, make(kp), spec)
            return ok and wmax <= w_cap

        kp_lo = J_max * 1.0 / p0.Kt
        kp = _bisect_max(feasible, kp_lo, J_max * 10.0 / dt / p0.Kt)
        if kp is None:
            continue
        lg = make(kp)
        found.append((_worst(cases, lg, spec)[3], beta, lg))
    return _pick_speed_pi(found, p0, spec)


def _pick_speed_pi(found: list, p0, spec: TuningSpec) -> LoopGains:
    """Of the feasible speed-loop PIs ``(worst crossover, beta, gains)``, the strongest
    integral action (largest beta) within 15 % of the best bandwidth -- the speed loop's
    integral rejects the gravity and friction load; :class:`SpecError` if there is none."""
    if not found:
        raise SpecError(
            f"{p0.joint}: no speed-loop PI meets phase_margin_deg>="
            f"{spec.phase_margin_deg}, gain_margin_dB>={spec.gain_margin_dB} and "
            f"separation_current_speed={spec.separation_current_speed} over the "
            f"inertia range at speed_sample_time_s={spec.speed_sample_time_s}"
        )
    w_best = max(f[0] for f in found)
    return max((f for f in found if f[0] >= 0.85 * w_best), key=lambda f: f[1])[2]


def _tune_position(
    plants, current: LoopGains, speed: LoopGains, spec: TuningSpec, n_grid: int
) -> LoopGains:
    p0 = plants["nominal"]
    dt = spec.position_sample_time_s
    cases, models, ww_min = [], [], math.inf
    for p in plants.values():
        dummy = _loop("position", "P", 1.0, 0.0, dt, spec, p)
        m = CascadeModel(p, {"current": current, "speed": speed, "position": dummy})
        models.append(m)
        ww_min = min(ww_min, m.margins("speed", False, n=n_grid).crossover_rad_s)
        w_c = freq_grid(None, n=n_grid)
        w_d = freq_grid(dt, n=n_grid)
        cases.append(
            _Case(
                w_c,
                _resp(m.position_plant(False), w_c),
                w_d,
                _resp(m.position_plant(True), w_d, dt),
            )
        )
    w_cap = ww_min / spec.separation_speed_position

    def make(kp):
        return _loop("position", "P", kp, 0.0, dt, spec, p0)

    def feasible(kp):
        ok, _, _, _, wmax = _worst(cases, make(kp), spec)
        return ok and wmax <= w_cap

    kp_max = _bisect_max(feasible, 1e-2, 10.0 / dt)
    target = spec.target_bandwidth_rad_s
    if kp_max is None:
        raise SpecError(
            f"{p0.joint}: no position-loop gain meets phase_margin_deg>="
            f"{spec.phase_margin_deg} and gain_margin_dB>={spec.gain_margin_dB}"
        )
    nominal = cases[list(plants).index("nominal")]

    def wc_nominal(kp):
        return margins(nominal.w_c, kp * nominal.P_c).crossover_rad_s

    kp = _position_target(p0, spec, target, kp_max, wc_nominal)

    def overshoot(lg: LoopGains) -> float:
        worst = 0.0
        for m in models:
            m.gains["position"] = lg
            for disc in (False, True):
                os_, _ = step_figures(m.position_closed(disc), 12.0 / lg.kp)
                worst = max(worst, os_ if math.isfinite(os_) else math.inf)
        return worst

    return _within_overshoot(p0, spec, target, kp, make, overshoot)


def _within_overshoot(p0, spec: TuningSpec, target, kp: float, make, overshoot) -> LoopGains:
    """The position loop ``make(kp)``, its gain lowered by 10 % steps until ``overshoot(lg)``
    (worst over the inertia cases, continuous and discrete) meets the spec; a requested
    bandwidth (``target``) is not lowered: SpecError then."""
    for _ in range(30):
        lg = make(kp)
        worst = overshoot(lg)
        if worst <= spec.overshoot_pct:
            return lg
        if target is not None:
            raise SpecError(
                f"{p0.joint}: spec overshoot_pct={spec.overshoot_pct} cannot be met "
                f"at position_bandwidth_rad_s={target:.4g} (overshoot "
                f"{worst:.3g} %)"
            )
        kp *= 0.9
    raise SpecError(f"{p0.joint}: spec overshoot_pct={spec.overshoot_pct} cannot be met")


# ---------------------------------------------------------------------------- per loop, numpy
# The searches above, on the closed-form responses of :class:`CascadeArrays` (all inertia
# cases stacked) and with every candidate shape bisected in lockstep (:func:`_bisect_max_many`):
# the same decisions, so the same gains, without building python-control objects.
def _stacked(ca: CascadeArrays, loop: str, dt: float, n_grid: int) -> _Case:
    w_c = freq_grid(None, n=n_grid)
    w_d = freq_grid(dt, n=n_grid)
    return _Case(
        w_c,
        ca.plant_response(loop, w_c, False),
        w_d,
        ca.plant_response(loop, w_d, True),
        extra={"dt_d": dt},
    )


def _tune_current_fast(plants: dict[str, JointPlant], spec: TuningSpec, n_grid: int) -> LoopGains:
    p0 = plants["nominal"]
    dt = spec.current_sample_time_s
    ca = CascadeArrays(p0, {"current": _loop("current", "PI", 1.0, 1.0, dt, spec, p0)}, plants)
    case = _stacked(ca, "current", dt, n_grid)
    ratios = (0.5, 0.7, 1.0, 1.4, 2.0)

    def make(kp, r):
        Ti = r * p0.Te
        return _loop("current", "PI", kp, kp / Ti, dt, spec, p0)

    def feasible(kps, idx):
        return _worst_many(
            case, [make(kp, ratios[i]) for kp, i in zip(kps, idx, strict=True)], spec
        )[0]

    kps = _bisect_max_many(feasible, p0.L * 1.0, p0.L * 10.0 / dt, len(ratios))
    cand = [make(kp, r) for kp, r in zip(kps, ratios, strict=True) if kp is not None]
    best = None
    if cand:
        wmins = _worst_many(case, cand, spec)[3]
        for wmin, lg in zip(wmins, cand, strict=True):
            if best is None or wmin > best[0]:
                best = (wmin, lg)
    if best is None:
        raise SpecError(
            f"{p0.joint}: no current-loop PI meets phase_margin_deg>="
            f"{spec.phase_margin_deg} and gain_margin_dB>={spec.gain_margin_dB} "
            f"at current_sample_time_s={spec.current_sample_time_s}"
        )
    return best[1]


def _tune_speed_fast(
    plants, current: LoopGains, spec: TuningSpec, n_grid: int, ca: CascadeArrays
) -> LoopGains:
    p0 = plants["nominal"]
    dt = spec.speed_sample_time_s
    ca.gains["current"] = current
    ca.gains["speed"] = _loop("speed", "PI", 1.0, 1.0, dt, spec, p0)
    wci_min = math.inf
    for m in ca.margins("current", False, n=n_grid):
        wci_min = min(wci_min, m.crossover_rad_s)
    case = _stacked(ca, "speed", dt, n_grid)
    w_cap = wci_min / spec.separation_current_speed
    J_max = max(p.J for p in plants.values())
    betas = list(np.geomspace(0.05, 0.5, 8))

    def make(kp, beta):
        return _loop("speed", "PI", kp, kp * beta * kp * p0.Kt / J_max, dt, spec, p0)

    def feasible(kps, idx):
        ok, _, _, _, wmax = _worst_many(
            case, [make(kp, betas[i]) for kp, i in zip(kps, idx, strict=True)], spec
        )
        return ok & (wmax <= w_cap)

    kp_lo = J_max * 1.0 / p0.Kt
    kps = _bisect_max_many(feasible, kp_lo, J_max * 10.0 / dt / p0.Kt, len(betas))
    found = [(beta, make(kp, beta)) for kp, beta in zip(kps, betas, strict=True) if kp is not None]
    rows = []
    if found:
        wmins = _worst_many(case, [f[1] for f in found], spec)[3]
        rows = [(float(w), beta, lg) for w, (beta, lg) in zip(wmins, found, strict=True)]
    return _pick_speed_pi(rows, p0, spec)


def _tune_position_fast(
    plants, speed: LoopGains, spec: TuningSpec, n_grid: int, ca: CascadeArrays
) -> LoopGains:
    """``ca``: the speed search's arrays (its discrete drive depends on the current loop
    only, and is reused)."""
    p0 = plants["nominal"]
    dt = spec.position_sample_time_s
    ca.gains["speed"] = speed
    ca.gains["position"] = _loop("position", "P", 1.0, 0.0, dt, spec, p0)
    ww_min = math.inf
    for m in ca.margins("speed", False, n=n_grid):
        ww_min = min(ww_min, m.crossover_rad_s)
    case = _stacked(ca, "position", dt, n_grid)
    w_cap = ww_min / spec.separation_speed_position

    def make(kp):
        return _loop("position", "P", kp, 0.0, dt, spec, p0)

    def feasible(kps, idx):
        ok, _, _, _, wmax = _worst_many(case, [make(kp) for kp in kps], spec)
        return ok & (wmax <= w_cap)

    kp_max = _bisect_max_many(feasible, 1e-2, 10.0 / dt, 1)[0]
    target = spec.target_bandwidth_rad_s
    if kp_max is None:
        raise SpecError(
            f"{p0.joint}: no position-loop gain meets phase_margin_deg>="
            f"{spec.phase_margin_deg} and gain_margin_dB>={spec.gain_margin_dB}"
        )
    P_nom = case.P_c[list(plants).index("nominal")]

    def wc_nominal(kp):
        return margins(case.w_c, kp * P_nom).crossover_rad_s

    kp = _position_target(p0, spec, target, kp_max, wc_nominal)

    def overshoot(lg: LoopGains) -> float:
        ca.gains["position"] = lg
        worst = 0.0
        for disc in (False, True):
            for os_, _ in ca.step_figures("position", disc, 12.0 / lg.kp):
                worst = max(worst, os_ if math.isfinite(os_) else math.inf)
        return worst

    return _within_overshoot(p0, spec, target, kp, make, overshoot)


def _position_target(p0, spec: TuningSpec, target, kp_max: float, wc_nominal) -> float:
    """kp for the requested position bandwidth (bisection on the nominal crossover), or
    ``kp_max`` without one; :class:`SpecError` if the bandwidth is out of reach."""
    if target is None:
        return kp_max
    w_best = wc_nominal(kp_max)
    if target > w_best * (1 + 1e-3):
        name = (
            "position_bandwidth_rad_s"
            if spec.position_bandwidth_rad_s is not None
            else "rise_time_s"
        )
        val = getattr(spec, name)
        raise SpecError(
            f"{p0.joint}: spec {name}={val!r} is impossible: the position loop reaches at "
            f"most {w_best:.4g} rad/s with phase_margin_deg>={spec.phase_margin_deg}, "
            f"gain_margin_dB>={spec.gain_margin_dB} and separation_speed_position="
            f"{spec.separation_speed_position} over the inertia range"
        )
    a, b = math.log(1e-3), math.log(kp_max)
    for _ in range(60):
        mid = 0.5 * (a + b)
        if wc_nominal(math.exp(mid)) < target:
            a = mid
        else:
            b = mid
    return math.exp(b)


# ---------------------------------------------------------------------------- checks
ENGINES = ("numpy", "python-control")


def _check_rows_numpy(plant: JointPlant, loops: dict, n_grid: int) -> dict[str, list[dict]]:
    """Per loop the robustness rows of :func:`check_cascade` from :class:`CascadeArrays`."""
    ca = CascadeArrays(plant, loops, INERTIA_CASES)
    out = {}
    for name in loops:
        rows: list[dict[str, Any]] = [
            {"label": case, "inertia_kg_m2": plant.J_motor(case)} for case in INERTIA_CASES
        ]
        for disc in (False, True):
            sfx = "_discrete" if disc else ""
            mgs = ca.margins(name, disc, n=n_grid)
            span = 12.0 if name == "position" else 40.0
            t_end = [
                span / m.crossover_rad_s
                if math.isfinite(m.crossover_rad_s) and m.crossover_rad_s > 0
                else 1.0
                for m in mgs
            ]
            figs = ca.step_figures(name, disc, t_end)
            stable = ca.stable(name, disc)
            for row, mg, (os_, ts), st in zip(rows, mgs, figs, stable, strict=True):
                row.update(
                    {
                        f"crossover{sfx}_rad_s": mg.crossover_rad_s,
                        f"phase_margin{sfx}_deg": mg.phase_margin_deg,
                        f"gain_margin{sfx}_dB": mg.gain_margin_dB,
                        f"overshoot{sfx}_pct": os_,
                        f"settling_time{sfx}_s": ts,
                        f"stable{sfx}": st,
                    }
                )
        out[name] = rows
    return out


def _check_rows_reference(plant: JointPlant, loops: dict, n_grid: int) -> dict[str, list[dict]]:
    """The same rows from python-control's models (:class:`CascadeModel`): the reference."""
    models = {case: CascadeModel(plant.at(case), loops) for case in INERTIA_CASES}
    out = {}
    for name in loops:
        rows = []
        for case in INERTIA_CASES:
            m = models[case]
            row: dict[str, Any] = {"label": case, "inertia_kg_m2": plant.J_motor(case)}
            for disc in (False, True):
                sfx = "_discrete" if disc else ""
                mg = m.margins(name, disc, n=n_grid)
                wc = mg.crossover_rad_s
                t_end = 40.0 / wc if math.isfinite(wc) and wc > 0 else 1.0
                if name == "position":
                    t_end = 12.0 / wc if math.isfinite(wc) and wc > 0 else 1.0
                os_, ts = step_figures(m.closed_loop(name, disc), t_end)
                row.update(
                    {
                        f"crossover{sfx}_rad_s": wc,
                        f"phase_margin{sfx}_deg": mg.phase_margin_deg,
                        f"gain_margin{sfx}_dB": mg.gain_margin_dB,
                        f"overshoot{sfx}_pct": os_,
                        f"settling_time{sfx}_s": ts,
                        f"stable{sfx}": m.stable(name, disc),
                    }
                )
            rows.append(row)
        out[name] = rows
    return out


def _engine(engine: str) -> str:
    if engine not in ENGINES:
        raise SpecError(f"engine={engine!r} is not one of {ENGINES}")
    return engine


def check_cascade(
    plant: JointPlant,
    gains: CascadeGains,
    *,
    n_grid: int = 1500,
    inner_overshoot_pct: float | None = None,
    engine: str = "numpy",
) -> CascadeGains:
    """Recompute every loop's figures over the inertia range.

    For each loop and each inertia case (min, nominal, max): crossover, phase and gain margins,
    step overshoot and 2 % settling time, continuous and discrete, and closed-loop stability.
    The headline figures are the worst case (crossover: at the nominal inertia).
    ``engine="numpy"`` evaluates the loops in closed form (:class:`CascadeArrays`, all cases at
    once); ``"python-control"`` on python-control's models (:class:`CascadeModel`), the
    reference.

    Returns
    -------
    CascadeGains
        A copy with the figures and ``robustness`` rows filled in.
    """
    loops = {name: LoopGains.from_dict(lg.to_dict()) for name, lg in gains.loops().items()}
    if _engine(engine) == "numpy":
        all_rows = _check_rows_numpy(plant, loops, n_grid)
    else:
        all_rows = _check_rows_reference(plant, loops, n_grid)
    for name, lg in loops.items():
        rows = all_rows[name]
        nom = rows[INERTIA_CASES.index("nominal")]
        lg.crossover_rad_s = nom["crossover_rad_s"]
        lg.crossover_discrete_rad_s = nom["crossover_discrete_rad_s"]
        for key in ("phase_margin", "gain_margin"):
            for sfx, unit in (
                ("", "_deg" if key == "phase_margin" else "_dB"),
                ("_discrete", "_deg" if key == "phase_margin" else "_dB"),
            ):
                k = f"{key}{sfx}{unit}"
                setattr(lg, k, min(r[k] for r in rows))
        for sfx in ("", "_discrete"):
            setattr(lg, f"overshoot{sfx}_pct", max(r[f"overshoot{sfx}_pct"] for r in rows))
            setattr(lg, f"settling_time{sfx}_s", max(r[f"settling_time{sfx}_s"] for r in rows))
        lg.robustness = rows
    return CascadeGains(joint=gains.joint, plant=gains.plant, spec=gains.spec, **loops)


# ---------------------------------------------------------------------------- public
def tune_cascade(
    robot: Robot, joint, *, inertias=None, n_grid: int = 600, engine: str = "numpy", **spec
) -> CascadeGains:
    """Tune one joint's current, speed and position loops, robust over its inertia range.

    Parameters
    ----------
    robot : Robot
        With drives (drives.toml).
    joint : str or int
        Joint name or 1-based number.
    inertias : InertiaRange, optional
        Precomputed :func:`armlab.control.plant.inertia_range` (shared by :func:`tune_arm`).
    n_grid : int
        Frequency points of the search (the final check uses 1500).
    engine : {"numpy", "python-control"}
        ``"numpy"``: the loops in closed form, every inertia case and candidate at once
        (:class:`armlab.control.loops.CascadeArrays`); ``"python-control"``: the original
        evaluation on python-control's models, kept as the reference (same gains to rounding).
    **spec
        Fields of :class:`TuningSpec` (``position_bandwidth_rad_s``, ``phase_margin_deg``, ...).

    Returns
    -------
    CascadeGains
        Gains with their checked figures (worst case over min/nominal/max inertia, continuous
        and discrete) and the plant summary.

    Raises
    ------
    SpecError
        Invalid or impossible spec, or missing motor data; the message names joint and spec.
    """
    name = robot.joint_names[robot.joint_index(joint)]
    sp = TuningSpec.from_kwargs(name, **spec)
    if inertias is None:
        inertias = inertia_range(robot, n_samples=sp.n_inertia_samples, seed=sp.seed)
    base = joint_plant(robot, name, inertias=inertias)
    plants = {c: base.at(c) for c in INERTIA_CASES}
    fast = _engine(engine) == "numpy"
    try:
        if fast:
            cur = _tune_current_fast(plants, sp, n_grid)
            ca = CascadeArrays(base, {}, plants)
            spd = _tune_speed_fast(plants, cur, sp, n_grid, ca)
            pos = _tune_position_fast(plants, spd, sp, n_grid, ca)
        else:
            cur = _tune_current(plants, sp, n_grid)
            spd = _tune_speed(plants, cur, sp, n_grid)
            pos = _tune_position(plants, cur, spd, sp, n_grid)
    except ArmlabError:
        raise
    except (np.linalg.LinAlgError, ValueError, ZeroDivisionError) as e:
        raise SpecError(f"{name}: tuning failed numerically ({e})") from None
    summary = PlantSummary(**base.summary())
    g = CascadeGains(
        joint=name, current=cur, speed=spd, position=pos, plant=summary, spec=sp.to_dict()
    )
    g = check_cascade(base, g, engine=engine)
    _assert_meets(g, sp)
    return g


def _assert_meets(g: CascadeGains, sp: TuningSpec) -> None:
    for name, lg in g.loops().items():
        for sfx in ("", "_discrete"):
            pm = getattr(lg, f"phase_margin{sfx}_deg")
            gm = getattr(lg, f"gain_margin{sfx}_dB")
            if pm < sp.phase_margin_deg - 1e-6 or gm < sp.gain_margin_dB - 1e-6:
                raise SpecError(
                    f"{g.joint}: the {name} loop ends at phase margin {pm:.3g} deg, "
                    f"gain margin {gm:.3g} dB ({'discrete' if sfx else 'continuous'}"
                    f") < spec phase_margin_deg={sp.phase_margin_deg}, "
                    f"gain_margin_dB={sp.gain_margin_dB}"
                )
        for row in lg.robustness:
            if not (row["stable"] and row["stable_discrete"]):
                raise SpecError(
                    f"{g.joint}: the {name} loop is unstable at the {row['label']} inertia"
                )
        if sp.inner_overshoot_pct is not None and name != "position":
            os_ = max(lg.overshoot_pct, lg.overshoot_discrete_pct)
            if os_ > sp.inner_overshoot_pct:
                raise SpecError(
                    f"{g.joint}: spec inner_overshoot_pct={sp.inner_overshoot_pct} "
                    f"not met by the {name} loop ({os_:.3g} %)"
                )


def controller_spec(controller: ControllerProfile, spec: dict) -> dict:
    """``spec`` with the controller's servo period (speed and position loops) and D/A.

    The controller profile is the one home of the servo period and the D/A converter: a spec
    that names another value for them is refused (:class:`SpecError`), so the gains are tuned
    and discretised for the controller the tables are written for.
    """
    from_profile = {
        "speed_sample_time_s": controller.servo_period_s,
        "position_sample_time_s": controller.servo_period_s,
        "da_range_V": controller.dac_range_V,
        "da_bits": int(controller.dac_bits),
    }
    out = dict(spec)
    for key, value in from_profile.items():
        given = out.get(key)
        if given is not None and not math.isclose(float(given), float(value), rel_tol=1e-12):
            raise SpecError(
                f"{key}={given} differs from controller profile {controller.name!r} "
                f"({value}): set it in the controller profile ([controller] in a study)"
            )
        out[key] = value
    return out


def tune_arm(robot: Robot, *, controller: ControllerProfile | str, **spec) -> ArmGains:
    """:func:`tune_cascade` for every joint (one inertia-range computation shared).

    Parameters
    ----------
    robot : Robot
    controller : ControllerProfile or str
        The joint controller (:func:`armlab.robot.load_profile`): its servo period is the speed
        and position loops' sample time and its D/A range and bits are the speed loop's output
        (:func:`controller_spec`).
    **spec
        Fields of :class:`TuningSpec`; and ``engine`` (``"numpy"``, the default, or
        ``"python-control"``: see :func:`tune_cascade`).

    Returns
    -------
    ArmGains
        ``.joints[name]`` in joint order; ``to_json()`` is a study's ``gains.json``.
    """
    engine: dict[str, Any] = {"engine": str(spec.pop("engine"))} if "engine" in spec else {}
    spec = controller_spec(load_profile(controller), spec)
    sp = TuningSpec.from_kwargs("", **spec)
    inertias = inertia_range(robot, n_samples=sp.n_inertia_samples, seed=sp.seed)
    joints = {
        name: tune_cascade(robot, name, inertias=inertias, **engine, **spec)
        for name in robot.joint_names
    }
    return ArmGains(joints=joints, robot=robot.name, spec=sp.to_dict())
