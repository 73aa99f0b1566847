"""Real-time single-step interpolator with on-line speed override (Li, Meng, Chen).

Li, Meng, Chen, §1.2-1.3 (Kunshan-1 welding robot): the state is the arc length
``S_current`` and speed ``V_current``; every period ``Ts`` the next ``S_next, V_next`` follow
from the start and end speeds ``V_start, V_end``, the cruise speed ``velo`` and the
acceleration ``accel``. The final
ramp starts when the remaining distance ``S_CE`` is no longer above
``S_AECE = |V_current^2 - V_end^2| / (2 accel)`` (eq. 1); otherwise the speed goes towards
``velo`` at ``accel`` (eq. 2-9). The override ``Vrate`` (0-100 %) and the target may change
between cycles; any path whose length is known (joint PTP, line, arc, FlyBy chain) works.

Our reading, where the paper would break a limit or is silent:

* The paper scales the step by ``Vrate`` (eq. 13-14), which makes the speed jump when
  ``Vrate`` changes. Here the override scales the *cruise* speed, ``velo * Vrate``, and the
  speed follows at no more than ``accel`` — the acceleration limit holds through every
  override change.
* Each period is integrated exactly in continuous time (phases of constant acceleration
  ``+accel``, ``0`` or ``-accel`` with the switching instants solved in closed form), so the
  final ramp starts at the exact point of eq. 1 instead of at the next period boundary: the
  end is reached with exactly ``V_end``, possibly inside a period (``OnlineSample.t_end``).
* Near the end the commanded speed is clamped between the lower curve
  ``sqrt(V_end^2 - 2 accel S_CE)`` (still able to reach a higher ``V_end``) and the braking
  curve ``sqrt(V_end^2 + 2 accel S_CE)``: a zero override stops the motion unless the final
  ramp has begun.
* A new target is accepted only if the motion can still end there within ``accel``; otherwise
  :class:`InfeasibleError` names the distance needed and the state is unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from armlab.errors import InfeasibleError, InputError

__all__ = ["OnlineInterpolator", "OnlineSample", "OnlineRun"]


@dataclass
class OnlineSample:
    """State after one period.

    Attributes
    ----------
    t : float
        Time since the start in [s].
    s : float
        Arc length along the path (unit of the path: [m], [rad]).
    v : float
        Speed [unit/s].
    a_mean : float
        ``(v - v_previous) / period`` [unit/s^2].
    point : ndarray or None
        ``path.point(s)`` (joint vector or (4, 4) pose) when the path is an object.
    done : bool
        The end has been reached.
    t_end : float or None
        Time into this period at which the end was reached [s].
    """

    t: float
    s: float
    v: float
    a_mean: float
    point: np.ndarray | None
    done: bool
    t_end: float | None = None


@dataclass
class OnlineRun:
    """A whole run of :meth:`OnlineInterpolator.run`: arrays over the periods (index 0 is the
    initial state)."""

    t: np.ndarray
    s: np.ndarray
    v: np.ndarray
    override: np.ndarray
    points: list

    @property
    def a_mean(self) -> np.ndarray:
        return np.diff(self.v) / np.diff(self.t)


def _length_of(path) -> float:
    if hasattr(path, "length"):
        return float(path.length)
    try:
        return float(path)
    except (TypeError, ValueError):
        raise InputError(
            f"target must be a path with a .length or a length, not {path!r}"
        ) from None


class OnlineInterpolator:
    """Li, Meng, Chen's single-step interpolator along any path of known length.

    Parameters
    ----------
    path : path object or float
        Anything with ``.length`` (and ``.point(s)``): :class:`JointPath`, :class:`LinePath`,
        :class:`ArcPath`, :class:`BlendPath`; or a bare length.
    v_cruise : float
        Cruise speed ``velo`` > 0 [unit/s] at 100 % override.
    a_max : float
        Acceleration and deceleration limit ``accel`` > 0 [unit/s^2].
    v_start, v_end : float
        Speeds >= 0 at the start and at the end (FlyBy into the next segment).

    Raises
    ------
    InfeasibleError
        ``v_end`` cannot be reached from ``v_start`` within the length at ``a_max``.
    """

    def __init__(
        self, path, v_cruise: float, a_max: float, v_start: float = 0.0, v_end: float = 0.0
    ) -> None:
        for name, x, low in (("v_cruise", v_cruise, 0.0), ("a_max", a_max, 0.0)):
            if not (math.isfinite(float(x)) and float(x) > low):
                raise InputError(f"OnlineInterpolator: {name} must be a finite number > 0")
        for name, x in (("v_start", v_start), ("v_end", v_end)):
            if not (math.isfinite(float(x)) and float(x) >= 0):
                raise InputError(f"OnlineInterpolator: {name} must be a finite number >= 0")
        self.v_cruise, self.a_max = float(v_cruise), float(a_max)
        self.v_end = float(v_end)
        self.path = path
        self.length = _length_of(path)
        if not (math.isfinite(self.length) and self.length >= 0):
            raise InputError(f"OnlineInterpolator: path length must be >= 0, not {self.length}")
        self.s, self.v, self.t = 0.0, float(v_start), 0.0
        self._check_reachable(self.length, self.v_end, "start")
        self.done = self.length == 0
        if self.done:
            self.v = self.v_end

    # ------------------------------------------------------------------ feasibility
    def _check_reachable(self, length: float, v_end: float, what: str) -> None:
        d = length - self.s
        a = self.a_max
        if d < -1e-12 * max(1.0, length):
            raise InfeasibleError(
                f"OnlineInterpolator {what}: target at {length:.6g} lies "
                f"behind the current point s = {self.s:.6g}"
            )
        need = abs(self.v**2 - v_end**2) / (2 * a)
        if need > max(d, 0.0) * (1 + 1e-12) + 1e-15:
            verb = "stop at" if self.v > v_end else "reach"
            raise InfeasibleError(
                f"OnlineInterpolator {what}: from {self.v:.6g}/s to {v_end:.6g}/s at the "
                f"acceleration limit {a:.6g}/s^2 needs {need:.6g}, only {max(d, 0):.6g} left: "
                f"cannot {verb} the target"
            )

    def set_target(self, path, *, v_end: float | None = None, tol: float = 1e-9) -> None:
        """Move the target between cycles (Li, Meng, Chen: FlyBy, tracking corrections).

        Parameters
        ----------
        path : path object or float
            The new path (it must pass through the current point at the current ``s``) or a
            new total length along the current path.
        v_end : float, optional
            New end speed.

        Raises
        ------
        InfeasibleError
            The motion cannot end at the new target within ``a_max`` (state unchanged).
        InputError
            The new path does not pass through the current point.
        """
        length = _length_of(path)
        v_end = self.v_end if v_end is None else float(v_end)
        if not (math.isfinite(v_end) and v_end >= 0):
            raise InputError("v_end must be a finite number >= 0")
        self._check_reachable(length, v_end, "new target")
        if hasattr(path, "point") and hasattr(self.path, "point"):
            here_old = np.asarray(self.path.point(self.s))
            here_new = np.asarray(path.point(self.s))
            if here_old.shape != here_new.shape or np.abs(here_old - here_new).max() > tol:
                raise InputError(
                    "OnlineInterpolator: the new path does not pass through the "
                    f"current point at s = {self.s:.6g}"
                )
            self.path = path
        elif hasattr(path, "length"):
            self.path = path
        self.length, self.v_end = length, v_end
        self.done = self.length - self.s <= 0 and self.v == self.v_end

    # ------------------------------------------------------------------ one period
    def step(self, period: float, override: float = 1.0) -> OnlineSample:
        """Advance one interpolation period.

        Parameters
        ----------
        period : float
            ``Ts`` in [s].
        override : float
            Speed override in ``[0, 1]`` (0-100 %), may change every call.
        """
        T = float(period)
        if not (math.isfinite(T) and T > 0):
            raise InputError(f"period must be a positive number of seconds, not {period!r}")
        ov = float(override)
        if not (0.0 <= ov <= 1.0):
            raise InputError(f"override must lie in [0, 1] (0-100 %), not {override!r}")
        v_prev = self.v
        t_end = None
        if not self.done:
            used = self._advance(T, self.v_cruise * ov)
            if self.done:
                t_end = used
        self.t += T
        point = self.path.point(self.s) if hasattr(self.path, "point") else None
        return OnlineSample(self.t, self.s, self.v, (self.v - v_prev) / T, point, self.done, t_end)

    def _advance(self, T: float, vc: float) -> float:
        """Integrate ``T`` seconds exactly; returns the time used when the end is reached."""
        a, ve, L = self.a_max, self.v_end, self.length
        s, v = self.s, self.v
        tau = T
        eps = 1e-12 * max(self.v_cruise, ve, v, 1e-300)
        tol_d = 1e-13 * max(L, 1e-300)  # rounding of S_CE = L - s
        for _ in range(50):
            if tau <= 0:
                break
            d = L - s
            if d <= tol_d:
                s, v, self.done = L, ve, True
                break
            vb = math.sqrt(ve * ve + 2 * a * d)
            vlo = math.sqrt(max(0.0, ve * ve - 2 * a * d))
            # Li, Meng, Chen, eq. 1: the final ramp starts when
            # S_CE <= S_AECE = |V^2 - V_end^2| / 2a
            s_aece = abs(v * v - ve * ve) / (2 * a)
            if v > ve and d <= s_aece + tol_d:  # on the braking curve: -a to the end (eq. 6-7)
                h = (v - ve) / a
                if h <= tau:
                    tau -= h
                    s, v, self.done = L, ve, True
                    break
                v -= a * tau
                s = L - (v * v - ve * ve) / (2 * a)
                tau = 0.0
                break
            if v < ve and d <= s_aece + tol_d:  # on the lower curve: +a to the end (eq. 2-3)
                h = (ve - v) / a
                if h <= tau:
                    tau -= h
                    s, v, self.done = L, ve, True
                    break
                v += a * tau
                s = L - (ve * ve - v * v) / (2 * a)
                tau = 0.0
                break
            target = min(max(vc, vlo), vb)
            if v < target - eps:  # accelerate (eq. 2-3) to vc or onto the braking curve
                h_vc = (vc - v) / a if vc > v else math.inf
                h_b = (-v + math.sqrt(v * v / 2 + ve * ve / 2 + a * d)) / a
                h = min(h_vc, h_b, tau)
                s += v * h + a * h * h / 2
                v += a * h
                tau -= h
                if h == h_b:
                    v = math.sqrt(ve * ve + 2 * a * max(L - s, 0.0))
                elif h == h_vc:
                    v = vc
            elif v > target + eps:  # decelerate (eq. 6-7) to vc, or onto the lower curve
                h_vc = (v - vc) / a
                disc = v * v / 2 + ve * ve / 2 - a * d
                h_lo = (v - math.sqrt(disc)) / a if disc >= 0 and ve > 0 else math.inf
                h = min(h_vc, h_lo, tau)
                s += v * h - a * h * h / 2
                v = max(v - a * h, 0.0)
                tau -= h
                if h == h_lo:
                    v = math.sqrt(max(0.0, ve * ve - 2 * a * max(L - s, 0.0)))
                elif h == h_vc:
                    v = vc
            else:  # cruise at vc (eq. 8-9) until a curve or the end
                v = target
                if v <= 0:
                    tau = 0.0
                    break
                if v > ve:
                    h = (L - (v * v - ve * ve) / (2 * a) - s) / v
                elif v < ve:
                    h = (L - (ve * ve - v * v) / (2 * a) - s) / v
                else:
                    h = d / v
                h = max(h, 0.0)
                if h <= tau:
                    s += v * h
                    tau -= h
                    if v == ve:
                        s, self.done = L, True
                        break
                    # snap onto the curve just reached
                    s = L - abs(v * v - ve * ve) / (2 * a)
                else:
                    s += v * tau
                    tau = 0.0
        self.s, self.v = min(s, L), v
        return T - tau

    # ------------------------------------------------------------------ whole runs
    def run(
        self,
        period: float,
        override: float | Callable[[float], float] = 1.0,
        *,
        max_steps: int = 1_000_000,
        keep_points: bool = False,
    ) -> OnlineRun:
        """Step until the end. ``override`` may be a function of the time [s] (called before
        each period)."""
        ts, ss, vs, ovs, pts = [self.t], [self.s], [self.v], [np.nan], []
        for _ in range(max_steps):
            if self.done:
                break
            ov = override(self.t) if callable(override) else override
            smp = self.step(period, ov)
            ts.append(smp.t)
            ss.append(smp.s)
            vs.append(smp.v)
            ovs.append(ov)
            if keep_points:
                pts.append(smp.point)
        else:
            raise InfeasibleError(
                f"OnlineInterpolator: not at the end after {max_steps} periods (zero override?)"
            )
        return OnlineRun(np.array(ts), np.array(ss), np.array(vs), np.array(ovs), pts)
