"""Robust tuning of each loop over the inertia range (the search of :func:`tune_cascade`).

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

For each candidate shape the gain is bisected to the largest value for which **every** inertia
case (min, nominal, max) meets the phase margin and gain margin, for the continuous loop **and**
the discrete loop (ZOH + computation delay + encoder-differenced speed, see
:mod:`armlab.control.loops`), and the bandwidth separation to the inner loop holds (worst case
over the inertia range); the shape with the highest worst-case crossover wins. All candidate
shapes are bisected in lockstep on the stacked responses of :class:`CascadeModel`
(``log|C P| = log|C| + log|P|``: the plant's part once per case, the controller's per
candidate). The position loop's step overshoot is then checked (all cases, both models) and kp
reduced until it meets the limit.

Bandwidth separation (defaults): current >= 5 x speed, speed >= 4 x position crossovers -- the
inner loop then adds < ~15 deg of lag at the outer crossover, and an inner loop whose inertia
changes (speed loop, joint 1: x4) still stays above the outer one at its worst.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from armlab.control.gains import LoopGains
from armlab.control.loops import CascadeModel, pid_response
from armlab.control.margins import freq_grid, margins, margins_from_log
from armlab.control.plant import INERTIA_CASES, JointPlant
from armlab.control.spec import TuningSpec
from armlab.errors import SpecError

__all__ = ["tune_loops", "tune_current", "tune_speed", "tune_position"]

_PM_PAD = 0.5  # [deg] kept in the search so the final check on a finer grid passes
_GM_PAD = 0.2  # [dB]


@dataclass
class _Case:
    """Sampled open-loop plant responses of one loop at one inertia case."""

    w_c: np.ndarray
    P_c: np.ndarray
    w_d: np.ndarray
    P_d: np.ndarray
    extra: dict = field(default_factory=dict)


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
    """Worst case over the inertia cases of several candidate controllers at once: ``case``
    holds the plant responses of every inertia case stacked, (k, n). Returns arrays
    ``(ok, pm, gm, wmin, wmax)`` (m,): spec met (margins with the pads, continuous and
    discrete), worst phase and gain margins, smallest and largest continuous crossover
    (0 where there is none).

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
    """Largest ``x`` in ``[lo, hi]`` (bisection in ``log x``, assuming feasibility is
    monotone, to ``1e-3`` in ``log x`` or ``n`` steps) for ``m`` candidate shapes in lockstep:
    ``feasible(xs, idx)`` tells for the values ``xs`` of the shapes ``idx`` (lists) whether
    each is feasible. ``hi`` if feasible there, None if not even ``lo`` is."""
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
def _stacked(ca: CascadeModel, loop: str, dt: float, n_grid: int) -> _Case:
    """The plant responses of ``loop`` at every case, continuous and discrete grids."""
    w_c = freq_grid(None, n=n_grid)
    w_d = freq_grid(dt, n=n_grid)
    return _Case(
        w_c,
        ca.plant_response(loop, w_c, False),
        w_d,
        ca.plant_response(loop, w_d, True),
        extra={"dt_d": dt},
    )


def tune_loops(
    plant: JointPlant, spec: TuningSpec, n_grid: int
) -> tuple[LoopGains, LoopGains, LoopGains]:
    """The current, speed and position loops of one joint, inside out (module docstring),
    each robust over the plant's min/nominal/max inertia."""
    plants = {c: plant.at(c) for c in INERTIA_CASES}
    if plant.two_mass:  # the resonance's narrow notch and peak: the final check's grid
        n_grid = max(n_grid, 1500)
    cur = tune_current(plants, spec, n_grid)
    ca = CascadeModel(plant, {}, plants)
    spd = tune_speed(plants, cur, spec, n_grid, ca)
    pos = tune_position(plants, spd, spec, n_grid, ca)
    return cur, spd, pos


def tune_current(plants: dict[str, JointPlant], spec: TuningSpec, n_grid: int) -> LoopGains:
    """Current-loop PI: zero at ``Ti = r L / R`` (r in 0.5..2), the largest robust kp per r;
    the r with the highest worst-case crossover."""
    p0 = plants["nominal"]
    dt = spec.current_sample_time_s
    ca = CascadeModel(p0, {"current": _loop("current", "PI", 1.0, 1.0, dt, spec, p0)}, plants)
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


def tune_speed(
    plants, current: LoopGains, spec: TuningSpec, n_grid: int, ca: CascadeModel
) -> LoopGains:
    """Speed-loop PI: ``ki = beta kp^2 Kt / J_max`` (beta in 0.05..0.5), the largest robust kp
    per beta with the worst speed crossover at most the worst current crossover / separation;
    :func:`_pick_speed_pi` chooses. ``ca`` holds the cascade (reused by the position loop)."""
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


def tune_position(
    plants, speed: LoopGains, spec: TuningSpec, n_grid: int, ca: CascadeModel
) -> LoopGains:
    """Position-loop P: the largest robust kp with the worst position crossover at most the
    worst speed crossover / separation (or the requested bandwidth at nominal inertia), lowered
    until the step overshoot meets the spec. ``ca``: the speed search's model (its discrete
    drive depends on the current loop only, and is reused)."""
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
