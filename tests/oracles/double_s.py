"""Oracle of the double S's peak speed for a given duration: bisection to the last bit.

The package solves ``T = L / v + Ta(v)`` (Biagiotti & Melchiorri §3.4) for the peak speed ``v``
in closed form (:func:`armlab.trajectory.profiles.double_s_speed_for_duration`, a quadratic or
a cubic). This is the independent reference: the duration decreases with ``v`` on ``(0, v_p]``
(``v_p`` the fastest profile's peak, :func:`~armlab.trajectory.profiles.double_s_peak_speed`),
so halving the bracket until it cannot shrink finds ``v`` to the last bit. It was the
package's own engine before issue 23 (planning and the warm start now use the closed form).
"""

from __future__ import annotations

import numpy as np

from armlab.trajectory.profiles import (
    double_s_min_times,
    double_s_peak_speed,
    double_s_ramp,
    trapezoid_speed_for_duration,
)


def double_s_speed_bisection(length, duration, a_max, j_max, v_max=np.inf) -> np.ndarray:
    """Peak speeds [unit/s] of the symmetric double S profiles lasting ``duration`` [s], by
    bisection on ``(0, v_p]``; ``v_p`` where ``duration`` is not above the minimum, the
    trapezoid's closed form where ``j = inf``, 0 for ``L <= 0`` (arrays broadcast)."""
    L, T, a, j, v = (
        np.asarray(x, float) for x in np.broadcast_arrays(length, duration, a_max, j_max, v_max)
    )
    v_hi = double_s_peak_speed(L, v, a, j)
    lo, hi = np.zeros_like(v_hi), v_hi.copy()
    for _ in range(200):  # halve until the bracket cannot shrink (~55 halvings near T_min)
        mid = 0.5 * (lo + hi)
        if np.all((mid <= lo) | (mid >= hi)):
            break
        with np.errstate(invalid="ignore", divide="ignore"):
            slow = L / mid + double_s_ramp(mid, a, j)[1] > T  # too slow: raise the speed
        lo, hi = np.where(slow, mid, lo), np.where(slow, hi, mid)
    vT = np.where(T <= double_s_min_times(L, v, a, j), v_hi, hi)
    vT = np.where(np.isinf(j), trapezoid_speed_for_duration(L, T, a, a, v), vT)
    return np.where(L > 0, vT, 0.0)
