"""Jerk-limited moves from a speed and an acceleration to a goal speed (Berscheid & Kröger
2021, the method of Ruckig): :class:`JerkMove` and the time-synchronised set."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from armlab.errors import InfeasibleError, InputError
from armlab.trajectory.profiles.motion import MotionProfile, _positive, rest_profile
from armlab.trajectory.profiles.timing import _floats

__all__ = [
    "JerkMove",
    "scurve_min_time_from_state",
    "scurve_blocked_from_state",
    "scurve_from_state",
    "synchronised_from_state",
]


# ---------------------------------------------------------------------- jerk-limited, from a state
# Berscheid & Kröger 2021 ("Jerk-limited Real-time Trajectory Generation with Arbitrary Target
# States", RSS XVII, Ruckig): a time-optimal move is at most seven constant-jerk phases (jerk
# +-j or 0); some longer durations may be blocked. Here the moves are built from the fastest
# speed change (one acceleration pulse) and searched over one parameter per family.
_GRID = 160  # parameter values scanned per family (plus the families' breakpoints)


def _root(f, lo: float, hi: float) -> float:
    """The root of ``f`` on a bracket ``[lo, hi]`` (``brentq``) to the last bits of its own
    size: no absolute tolerance, as small moves have their roots at tiny parameters."""
    from scipy.optimize import brentq

    return float(brentq(f, lo, hi, xtol=1e-300, maxiter=200, disp=False))


def _speed_change(v0, a0, vt, a: float, j: float):
    """Fastest jerk-limited change from speed ``v0`` and acceleration ``a0`` to speed ``vt`` at
    zero acceleration (arrays broadcast): one acceleration pulse of sign ``sg``, up at jerk
    ``sg j`` from ``a0`` to ``sg ap``, a plateau at ``sg a`` if ``ap`` would pass ``a``, down at
    ``-sg j`` to 0. The pulse points to ``vt`` from the speed ``v0 + a0 |a0| / 2j`` reached by
    bringing ``a0`` straight to 0; ``ap^2 = j |vt - v0| + a0^2 / 2`` without a plateau.

    Returns ``(t_up, t_hold, t_down, sg, ap, distance)``."""
    vstop = v0 + a0 * np.abs(a0) / (2 * j)
    sg = np.where(vt >= vstop, 1.0, -1.0)
    A0 = sg * a0
    dv = sg * (vt - v0)
    ap = np.sqrt(np.maximum(j * dv + A0 * A0 / 2, 0.0))
    plateau = ap > a
    ap = np.minimum(ap, a)
    tu = np.maximum((ap - A0) / j, 0.0)
    td = ap / j
    th = np.where(plateau, np.maximum((dv - (2 * a * a - A0 * A0) / (2 * j)) / a, 0.0), 0.0)
    J, A = sg * j, sg * ap
    d = v0 * tu + a0 * tu * tu / 2 + J * tu**3 / 6
    v1 = v0 + a0 * tu + J * tu * tu / 2
    d = d + v1 * th + A * th * th / 2
    v2 = v1 + A * th
    d = d + v2 * td + A * td * td / 2 - J * td**3 / 6
    return tu, th, td, sg, ap, d


def _speed_change_one(v0: float, a0: float, vt: float, a: float, j: float):
    """Scalar :func:`_speed_change` (the same steps with plain floats, for the root finders)."""
    sg = 1.0 if vt >= v0 + a0 * abs(a0) / (2 * j) else -1.0
    A0 = sg * a0
    dv = sg * (vt - v0)
    ap = math.sqrt(max(j * dv + A0 * A0 / 2, 0.0))
    th = 0.0
    if ap > a:
        ap = a
        th = max((dv - (2 * a * a - A0 * A0) / (2 * j)) / a, 0.0)
    tu = max((ap - A0) / j, 0.0)
    td = ap / j
    J, A = sg * j, sg * ap
    d = v0 * tu + a0 * tu * tu / 2 + J * tu**3 / 6
    v1 = v0 + a0 * tu + J * tu * tu / 2
    d = d + v1 * th + A * th * th / 2
    v2 = v1 + A * th
    d = d + v2 * td + A * td * td / 2 - J * td**3 / 6
    return tu, th, td, sg, ap, d


@dataclass
class _Move:
    """An extremal move: family (0 peak, 1 dip), its parameter ``x``, duration ``T`` [s]."""

    T: float
    family: int
    x: float


class JerkMove:
    """The jerk-limited moves of one joint over ``distance`` (signed) from speed ``v0`` and
    acceleration ``a0`` to speed ``v1`` at zero acceleration, within ``|v| <= v_max``,
    ``|a| <= a_max``, ``|j| <= j_max`` at every instant (Berscheid & Kröger 2021, step 1: the
    time-optimal profile and its blocked durations; step 2: a given duration).

    Two one-parameter families hold every time-optimal (UDDU) profile of the paper:

    * **peak** (parameter ``v_p``, ``|v_p| <= v_max``): the fastest speed change
      (``_speed_change``) to ``v_p``, a cruise at ``v_p``, the fastest change to ``v1`` --
      the acceleration passes zero where the speed peaks;
    * **dip** (parameter ``tau``, ``0 <= tau <= |a0| / j``; only if ``a0 != 0``): the
      acceleration first eases towards zero for ``tau`` at jerk ``-sign(a0) j`` without
      reaching it, then the fastest change to ``v1`` (then a cruise at ``v1``) -- a move that
      needs less than the direct speed change covers but no reversal.

    For a duration ``T`` the final positions a move can reach form an interval (linear
    dynamics, convex limits). Its ends are moves without a cruise or cruising at ``+-v_max``
    (a cruise at a lower speed loses to a short speed-up in its middle). So:

    * the **extremal moves** (:attr:`candidates`) are the roots of ``D(x) = distance`` of
      both families without a cruise (each scanned over its parameter range with its
      breakpoints; sign changes, and the grid's local extremes refined by a bounded
      minimisation, solved by ``brentq``) and the cruises at ``+-v_max``; the shortest is the
      minimum time :attr:`t_min`;
    * a duration between two consecutive extremal durations is reachable throughout or not at
      all: a test at the midpoint finds the **blocked intervals** :attr:`blocked`;
    * a move taking exactly ``T`` (:meth:`profile`) is the extremal one of that duration, else
      the family member whose cruise ``T - t(x)`` makes its distance right (``brentq``), else
      the convex combination of the farthest and the nearest member in ``T`` (its jerk is then
      within, not on, ``+-j``).

    The start state must let the limits hold from the first instant: ``|v0|, |v1| <= v_max``,
    ``|a0| <= a_max`` and the speed reached by bringing ``a0`` to zero,
    ``v0 + a0 |a0| / 2 j``, within ``v_max`` (else :class:`InputError`).
    """

    def __init__(self, distance, v0, a0, v1, v_max, a_max, j_max) -> None:
        D, v0, a0, v1 = (float(x) for x in (distance, v0, a0, v1))
        v, a, j = _positive(v_max, "v_max"), _positive(a_max, "a_max"), _positive(j_max, "j_max")
        if not all(math.isfinite(x) for x in (D, v0, a0, v1, v, a, j)):
            raise InputError("distance, start and end state and limits must be finite")
        tol = 1 + 1e-12
        if abs(v0) > v * tol or abs(v1) > v * tol:
            raise InputError(
                f"start speed {v0:.6g} and end speed {v1:.6g} must be within v_max = {v:.6g}"
            )
        if abs(a0) > a * tol:
            raise InputError(f"start acceleration {a0:.6g} must be within a_max = {a:.6g}")
        vstop = v0 + a0 * abs(a0) / (2 * j)
        if abs(vstop) > v * tol:
            raise InputError(
                f"start speed {v0:.6g} with acceleration {a0:.6g} passes v_max = {v:.6g} "
                f"before the jerk limit {j:.6g} can bring the acceleration to zero "
                f"(reaches {vstop:.6g})"
            )
        self.D, self.v, self.a, self.j = D, v, a, j
        self.v0, self.a0, self.v1 = min(max(v0, -v), v), min(max(a0, -a), a), min(max(v1, -v), v)
        self.rest = D == 0 and v0 == 0 and a0 == 0 and v1 == 0
        self.blocked: list[tuple[float, float]] = []
        self._scan: list = []
        if self.rest:
            self.candidates: list[_Move] = [_Move(0.0, 0, 0.0)]
            self.t_min = 0.0
            return
        self.grids = self._grids()
        self.candidates = self._extremal()
        if not self.candidates:  # the peak family always reaches: not for a valid state
            raise InfeasibleError(
                f"no jerk-limited move over {D:.6g} from ({v0:.6g}, {a0:.6g}) to {v1:.6g}"
            )
        self.t_min = self.candidates[0].T
        self.blocked = self._blocked()

    # ------------------------------------------------------------------ the two families
    def _one(self, fam: int, x: float) -> tuple[float, float, float]:
        """Scalar :meth:`_eval`."""
        if fam == 0:
            s1 = _speed_change_one(self.v0, self.a0, x, self.a, self.j)
            s2 = _speed_change_one(x, 0.0, self.v1, self.a, self.j)
            return s1[5] + s2[5], s1[0] + s1[1] + s1[2] + s2[0] + s2[1] + s2[2], x
        sg, a0, j = math.copysign(1.0, self.a0), self.a0, self.j
        v = self.v0 + a0 * x - sg * j * x * x / 2
        p = self.v0 * x + a0 * x * x / 2 - sg * j * x**3 / 6
        s = _speed_change_one(v, a0 - sg * j * x, self.v1, self.a, self.j)
        return p + s[5], x + s[0] + s[1] + s[2], self.v1

    def _eval(self, fam: int, x):
        """``(distance, duration, cruise speed)`` of family members ``x`` without a cruise."""
        x = np.asarray(x, float)
        if fam == 0:
            s1 = _speed_change(self.v0, self.a0, x, self.a, self.j)
            s2 = _speed_change(x, 0.0, self.v1, self.a, self.j)
            t = s1[0] + s1[1] + s1[2] + s2[0] + s2[1] + s2[2]
            return s1[5] + s2[5], t, x
        sg, a0, j = math.copysign(1.0, self.a0), self.a0, self.j
        a1 = a0 - sg * j * x
        v = self.v0 + a0 * x - sg * j * x * x / 2
        p = self.v0 * x + a0 * x * x / 2 - sg * j * x**3 / 6
        s = _speed_change(v, a1, self.v1, self.a, self.j)
        return p + s[5], x + s[0] + s[1] + s[2], np.full_like(x, self.v1)

    def _grids(self) -> list[np.ndarray]:
        v, a, j, v0, a0, v1 = self.v, self.a, self.j, self.v0, self.a0, self.v1
        brk = [
            v0 + a0 * abs(a0) / (2 * j),  # the first pulse changes sign
            v1,  # the second pulse changes sign
            v1 + a * a / j,  # the second pulse reaches its plateau
            v1 - a * a / j,
            v0 + (a * a - a0 * a0 / 2) / j,  # the first pulse reaches its plateau
            v0 - (a * a - a0 * a0 / 2) / j,
        ]
        # small moves from a small state live within a tiny range of peak speeds around the
        # pulses' sign changes: scan there on a log scale too, down to 1e-20 v
        near = v * np.logspace(-20, -1, 20)
        fine = np.concatenate([c + sg * near for c in brk[:2] for sg in (-1.0, 1.0)])
        x = np.concatenate([np.linspace(-v, v, _GRID), brk, fine])
        grids = [np.unique(np.clip(x, -v, v))]
        tau = abs(a0) / j
        grids.append(np.linspace(0.0, tau, _GRID // 2) if tau > 0 else np.zeros(0))
        return grids

    def _extremal(self) -> list[_Move]:
        from scipy.optimize import minimize_scalar

        D, v = self.D, self.v
        out: list[_Move] = []
        self._scan = [self._eval(fam, x) for fam, x in enumerate(self.grids)]
        for fam, x in enumerate(self.grids):
            if x.size < 2:
                continue

            def f(p: float, fam: int = fam) -> float:
                return self._one(fam, p)[0] - D

            y = self._scan[fam][0] - D
            roots: list[float] = list(x[y == 0])
            for k in np.flatnonzero(y[:-1] * y[1:] < 0):
                roots.append(_root(f, x[k], x[k + 1]))
            dy = np.diff(y)
            for k in np.flatnonzero(dy[:-1] * dy[1:] < 0) + 1:  # a local extreme of the grid
                if y[k - 1] * y[k] <= 0 or y[k] * y[k + 1] <= 0:
                    continue  # a root next to it is found already
                if abs(y[k]) > 4 * max(abs(dy[k - 1]), abs(dy[k])):
                    continue  # too far from zero for the extreme between the neighbours
                sgn = 1.0 if y[k] > 0 else -1.0  # refine towards zero: minimise sgn * f

                def g(p: float, sgn: float = sgn, f=f) -> float:
                    return sgn * f(p)

                res = minimize_scalar(
                    g,
                    bounds=(x[k - 1], x[k + 1]),
                    method="bounded",
                    options={"xatol": 1e-12 * (x[k + 1] - x[k - 1])},
                )
                xe, ye = float(res.x), f(float(res.x))
                if ye * y[k] < 0:
                    roots.append(_root(f, x[k - 1], xe))
                    roots.append(_root(f, xe, x[k + 1]))
                elif abs(ye) <= 1e-12 * (abs(D) + abs(dy[k - 1]) + abs(dy[k])):  # touches
                    roots.append(xe)
            out += [_Move(self._one(fam, float(r))[1], fam, float(r)) for r in roots]
        for vp in (v, -v):  # a cruise at the speed limit
            dd, tt, _ = self._one(0, vp)
            tc = (D - dd) / vp
            if tc > 0:
                out.append(_Move(tt + tc, 0, vp))
        out.sort(key=lambda c: c.T)
        return out

    def _reach(self, T: float):
        """Per family: the members that fit in ``T`` (grid, extremal parameters and the ends
        of the runs where the cruise vanishes), and their distances with the cruise filling
        ``T``: ``[(x, P, fits)]``."""

        def add(scan, fam: int, new):
            # the scan (parameters, distances, durations, cruise speeds) with members ``new``
            if len(new) == 0:
                return scan
            more = self._eval(fam, np.asarray(new, float))
            cat = [
                np.concatenate([a, b]) for a, b in zip(scan, (np.asarray(new), *more), strict=True)
            ]
            order = np.argsort(cat[0], kind="stable")
            return [c[order] for c in cat]

        out = []
        for fam, x in enumerate(self.grids):
            if x.size < 2:
                out.append((x, np.zeros(x.size), np.zeros(x.size, bool)))
                continue
            scan = add(
                [x, *self._scan[fam]], fam, [c.x for c in self.candidates if c.family == fam]
            )
            x, g = scan[0], scan[2] - T

            def h(p: float, fam: int = fam) -> float:
                return self._one(fam, p)[1] - T

            scan = add(
                scan, fam, [_root(h, x[k], x[k + 1]) for k in np.flatnonzero(g[:-1] * g[1:] < 0)]
            )
            x = scan[0]
            fits = scan[2] <= T * (1 + 1e-13)
            # a run of fitting members narrower than the grid: scan it finely
            edges = np.flatnonzero(np.diff(np.concatenate([[0], fits.astype(int), [0]])))
            fill = [
                np.linspace(x[i], x[k - 1], 33)[1:-1]
                for i, k in zip(edges[::2], edges[1::2], strict=True)
                if k - i < 8 and k - 1 > i
            ]
            x, dx, tx, cx = add(scan, fam, np.concatenate(fill) if fill else [])
            fits = tx <= T * (1 + 1e-13)
            out.append((x, dx + cx * np.maximum(T - tx, 0.0), fits))
        return out

    def reachable(self, duration: float) -> bool:
        """Whether some move takes exactly ``duration`` [s] (the members' distances in it
        bracket the goal)."""
        T = float(duration)
        if self.rest:
            return True
        if T < self.t_min * (1 - 1e-12):
            return False
        P = np.concatenate([p[f] for _, p, f in self._reach(T)])
        tol = 1e-12 * (abs(self.D) + self.v * T)
        return bool(P.size and P.max() >= self.D - tol and P.min() <= self.D + tol)

    def _blocked(self) -> list[tuple[float, float]]:
        Ts: list[float] = []
        for c in self.candidates:
            if not Ts or c.T > Ts[-1] * (1 + 1e-10):
                Ts.append(c.T)
        pairs = zip(Ts[:-1], Ts[1:], strict=True)
        return [(lo, hi) for lo, hi in pairs if not self.reachable(0.5 * (lo + hi))]

    # ------------------------------------------------------------------ profiles
    def _member(self, fam: int, x: float, T: float) -> MotionProfile:
        """The member ``x`` of a family, its cruise filling ``T``."""
        j = self.j
        if fam == 0:
            (u1, h1, d1, g1, p1, _), (u2, h2, d2, g2, p2, _) = (
                tuple(float(z) for z in s)
                for s in (
                    _speed_change(self.v0, self.a0, x, self.a, j),
                    _speed_change(x, 0.0, self.v1, self.a, j),
                )
            )
            tc = max(T - (u1 + h1 + d1 + u2 + h2 + d2), 0.0)
            d = [u1, h1, d1, tc, u2, h2, d2]
            acc = [self.a0, g1 * p1, g1 * p1, 0.0, 0.0, g2 * p2, g2 * p2]
            jerk = [g1 * j, 0.0, -g1 * j, 0.0, g2 * j, 0.0, -g2 * j]
            vp = x
        else:
            sg, a0 = math.copysign(1.0, self.a0), self.a0
            a1 = a0 - sg * j * x
            vx = self.v0 + a0 * x - sg * j * x * x / 2
            u, h, dd, g, p, _ = (float(z) for z in _speed_change(vx, a1, self.v1, self.a, j))
            tc = max(T - (x + u + h + dd), 0.0)
            d = [x, u, h, dd, tc]
            acc = [a0, a1, g * p, g * p, 0.0]
            jerk = [-sg * j, g * j, 0.0, -g * j, 0.0]
            vp = self.v1
        return MotionProfile(
            np.array(d),
            np.array(acc),
            np.array(jerk),
            kind="double_s",
            params=self._params(vp, "peak" if fam == 0 else "dip"),
            v_start=self.v0,
        )

    def _params(self, vp: float, family: str) -> dict:
        return {
            "v": vp,
            "a": self.a,
            "j": self.j,
            "v0": self.v0,
            "a0": self.a0,
            "v1": self.v1,
            "length": self.D,
            "family": family,
        }

    def _blend(self, p: MotionProfile, q: MotionProfile, lam: float, T: float) -> MotionProfile:
        """``lam p + (1 - lam) q``: a move within the limits (they are convex)."""
        t = np.union1d(p.t_knots, q.t_knots)
        t = t[(t > 1e-12 * T) & (t < T * (1 - 1e-12))]
        if t.size:
            t = t[np.concatenate([[True], np.diff(t) > 1e-12 * T])]
        t = np.concatenate([[0.0], t, [T]])
        mid = 0.5 * (t[:-1] + t[1:])
        acc = lam * p.evaluate(t[:-1])[2] + (1 - lam) * q.evaluate(t[:-1])[2]
        acc[0] = self.a0
        jerk = lam * p.evaluate(mid)[3] + (1 - lam) * q.evaluate(mid)[3]
        params = self._params(lam * p.params["v"] + (1 - lam) * q.params["v"], "blend")
        params["blend"] = lam
        return MotionProfile(np.diff(t), acc, jerk, kind="double_s", params=params, v_start=self.v0)

    def profile(self, duration: float) -> MotionProfile:
        """The move that takes exactly ``duration`` [s] (class docstring).

        Raises
        ------
        InfeasibleError
            ``duration`` is shorter than :attr:`t_min` or inside a blocked interval.
        """

        T = float(duration)
        if self.rest:
            return rest_profile(T)
        what = (
            f"a jerk-limited move over {self.D:.6g} from speed {self.v0:.6g} and acceleration "
            f"{self.a0:.6g} to speed {self.v1:.6g}"
        )
        if not T >= self.t_min * (1 - 1e-12):
            raise InfeasibleError(f"{what} takes at least {self.t_min:.6g} s, not {T:.6g} s")
        for lo, hi in self.blocked:
            if lo * (1 + 1e-12) < T < hi * (1 - 1e-12):
                raise InfeasibleError(
                    f"{what} cannot take {T:.6g} s (only up to {lo:.6g} s or from {hi:.6g} s)"
                )
        for c in self.candidates:  # the extremal move of this duration
            if abs(c.T - T) <= 1e-12 * T:
                return self._member(c.family, c.x, T)
        reach = self._reach(T)
        for fam, (x, P, fits) in enumerate(reach):
            if x.size < 2:
                continue
            y = P - self.D

            def f(p: float, fam: int = fam) -> float:
                dd, tt, cc = self._one(fam, p)
                return dd + cc * max(T - tt, 0.0) - self.D

            for k in np.flatnonzero(fits[:-1] & fits[1:] & (y[:-1] * y[1:] <= 0)):
                xr = x[k] if y[k] == 0 else _root(f, x[k], x[k + 1])
                if self._one(fam, float(xr))[1] <= T * (1 + 1e-13):
                    return self._member(fam, float(xr), T)
        best = [
            (float(P[i]), fam, float(x[i]))
            for fam, (x, P, fits) in enumerate(reach)
            for i in np.flatnonzero(fits)
        ]
        if best:
            far, near = max(best), min(best)
            if far[0] >= self.D >= near[0] and far[0] > near[0]:
                lam = (self.D - near[0]) / (far[0] - near[0])
                return self._blend(
                    self._member(far[1], far[2], T), self._member(near[1], near[2], T), lam, T
                )
        near_c = min(self.candidates, key=lambda c: abs(c.T - T))
        if abs(near_c.T - T) <= 1e-9 * T:  # an extremal move, off by the rounding of T
            return self._member(near_c.family, near_c.x, T)
        raise InfeasibleError(f"{what} found no move of {T:.6g} s")


def scurve_min_time_from_state(distance, v0, a0, v1, v_max, a_max, j_max) -> float:
    """Shortest duration [s] of a jerk-limited move over ``distance`` (signed) from speed ``v0``
    and acceleration ``a0`` to speed ``v1`` at zero acceleration (:class:`JerkMove`;
    Berscheid & Kröger 2021, step 1)."""
    return JerkMove(distance, v0, a0, v1, v_max, a_max, j_max).t_min


def scurve_blocked_from_state(
    distance, v0, a0, v1, v_max, a_max, j_max
) -> list[tuple[float, float]]:
    """The intervals of durations ``(T_a, T_b)`` [s] above the minimum that such a move cannot
    take (:class:`JerkMove`; Berscheid & Kröger 2021, step 1, blocked intervals)."""
    return list(JerkMove(distance, v0, a0, v1, v_max, a_max, j_max).blocked)


def scurve_from_state(distance, v0, a0, v1, v_max, a_max, j_max, duration) -> MotionProfile:
    """The jerk-limited move from ``(v0, a0)`` to ``(v1, 0)`` over ``distance`` that takes
    exactly ``duration`` [s] (:meth:`JerkMove.profile`; Berscheid & Kröger 2021, Ruckig's
    step 2)."""
    return JerkMove(distance, v0, a0, v1, v_max, a_max, j_max).profile(duration)


def synchronised_from_state(
    distances, v0, a0, v1, v_max, a_max, j_max
) -> tuple[float, list[JerkMove], list[MotionProfile], bool]:
    """Jerk-limited moves of several joints from a moving state that all take the same time
    (Berscheid & Kröger 2021, time synchronisation).

    Each joint's shortest duration and blocked intervals (:class:`JerkMove`); the common
    duration is the smallest ``T`` at or above every joint's minimum that lies in no joint's
    blocked interval (an interval's upper end is reachable), and each joint then takes exactly
    ``T`` (:meth:`JerkMove.profile`).

    Parameters
    ----------
    distances, v0, a0, v1 : array (n,)
        Signed moves, start speeds, start accelerations and goal speeds of the joints.
    v_max, a_max, j_max : float or array (n,)
        Limits > 0 in [unit/s], [unit/s^2], [unit/s^3].

    Returns
    -------
    (T, moves, profiles, blocked_moved)
        The common duration [s], each joint's :class:`JerkMove` and profile, and whether a
        blocked interval pushed ``T`` beyond the slowest joint's minimum.
    """
    D, s0, acc0, s1, v, a, j = (
        x.reshape(-1) for x in _floats(distances, v0, a0, v1, v_max, a_max, j_max)
    )
    moves = [JerkMove(D[i], s0[i], acc0[i], s1[i], v[i], a[i], j[i]) for i in range(D.size)]
    T = max((m.t_min for m in moves), default=0.0)
    moved = False
    for _ in range(sum(len(m.blocked) for m in moves) + 1):  # each interval pushes T once
        inside = [hi for m in moves for lo, hi in m.blocked if lo < T < hi]
        if not inside:
            break
        T = max(inside)
        moved = True
    return T, moves, [m.profile(T) for m in moves], moved
