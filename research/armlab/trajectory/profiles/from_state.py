"""Trapezoids from a moving state: bang-coast-bang from a start speed to an end speed over a
distance, shortest, blocked durations and a given duration."""

from __future__ import annotations

import math

import numpy as np

from armlab.errors import InfeasibleError, InputError
from armlab.trajectory.profiles.motion import MotionProfile, _positive

__all__ = ["trapezoid_min_time_from_state", "trapezoid_from_state", "trapezoid_blocked_from_state"]


# ---------------------------------------------------------------------- from a moving state
def _check_state(distance, v0, v1, v_max, a_max) -> tuple[float, ...]:
    D, v0, v1 = float(distance), float(v0), float(v1)
    v, a = _positive(v_max, "v_max"), _positive(a_max, "a_max")
    if not all(math.isfinite(x) for x in (D, v0, v1)):
        raise InputError("distance, start and end speeds must be finite")
    if abs(v0) > v * (1 + 1e-12) or abs(v1) > v * (1 + 1e-12):
        raise InputError(
            f"start speed {v0:.6g} and end speed {v1:.6g} must be within v_max = {v:.6g}"
        )
    return D, min(max(v0, -v), v), min(max(v1, -v), v), v, a


def _ramps_distance(vc: float, v0: float, v1: float, T: float, a: float) -> float:
    """Distance of the motion ``v0 -> vc`` (at ``a``), cruise at ``vc``, ``vc -> v1`` (at
    ``a``) in ``T``: ``vc T - (vc - v0)|vc - v0| / 2a - (vc - v1)|vc - v1| / 2a``."""
    return vc * T - ((vc - v0) * abs(vc - v0) + (vc - v1) * abs(vc - v1)) / (2 * a)


def trapezoid_min_time_from_state(distance, v0, v1, v_max, a_max) -> float:
    """Shortest duration [s] of a move over ``distance`` (signed) that starts at speed ``v0``
    and ends at ``v1`` (``|v0|, |v1| <= v_max``), accelerations within ``a_max``.

    The time-optimal motion of a double integrator with bounded speed is bang-coast-bang
    (Biagiotti & Melchiorri §3.2 with non-zero end speeds): from ``v0`` at ``+-a`` to a peak
    ``v_c`` and at ``-+a`` to ``v1``. The single ramp ``v0 -> v1`` covers
    ``D0 = (v0 + v1) |v1 - v0| / 2a``; a longer move (``D >= D0``) peaks at
    ``v_c = sqrt(a D + (v0^2 + v1^2) / 2)`` (at most ``v_max``, then it cruises), a shorter one
    is the mirror image (``D, v0, v1 -> -D, -v0, -v1``).
    """
    D, v0, v1, v, a = _check_state(distance, v0, v1, v_max, a_max)
    D0 = (v0 + v1) * abs(v1 - v0) / (2 * a)
    if D < D0:
        D, v0, v1 = -D, -v0, -v1
    vc = math.sqrt(max(a * D + (v0 * v0 + v1 * v1) / 2, 0.0))  # >= max(v0, v1) as D >= D0
    if vc <= v:
        return max((2 * vc - v0 - v1) / a, abs(v1 - v0) / a)
    ramps = (2 * v * v - v0 * v0 - v1 * v1) / (2 * a)
    return (2 * v - v0 - v1) / a + (D - ramps) / v


def trapezoid_blocked_from_state(distance, v0, v1, v_max, a_max) -> tuple[float, float] | None:
    """The durations ``(T_a, T_b)`` [s] a move from speed ``v0`` to ``v1`` over ``distance``
    cannot take although shorter ones can (None if there is no such gap).

    With both speeds forward (``min(v0, v1) > 0``) the shortest reachable distance in ``T``
    first grows with ``T`` (the move cannot stop sooner), up to ``(v0^2 + v1^2) / 2a`` when
    it just touches speed 0, then shrinks (it reverses). A distance between the single ramp's
    ``D0`` and that peak is covered fast (``T <= T_a``) or after a reversal (``T >= T_b``),
    not in between: ``v_c = +-sqrt((v0^2 + v1^2) / 2 - a D)`` at ``T = (v0 + v1 - 2 v_c) / a``
    (a cruise at ``-v_max`` if ``v_c`` would pass it). Backward speeds are the mirror image.
    """
    D, v0, v1, v, a = _check_state(distance, v0, v1, v_max, a_max)
    if max(v0, v1) < 0:
        D, v0, v1 = -D, -v0, -v1
    if not min(v0, v1) > 0:
        return None
    D0 = (v0 + v1) * abs(v1 - v0) / (2 * a)
    peak = (v0 * v0 + v1 * v1) / (2 * a)
    if not D0 <= D < peak:
        return None
    vc = math.sqrt(max((v0 * v0 + v1 * v1) / 2 - a * D, 0.0))
    ta = (v0 + v1 - 2 * vc) / a
    if vc <= v:
        tb = (v0 + v1 + 2 * vc) / a
    else:  # reverses at -v_max and cruises there
        tb = (((v0 + v) ** 2 + (v1 + v) ** 2) / (2 * a) - D) / v
    return ta, tb


def trapezoid_from_state(distance, v0, v1, v_max, a_max, duration) -> MotionProfile:
    """The move over ``distance`` from speed ``v0`` to ``v1`` that takes ``duration`` [s]
    (at least :func:`trapezoid_min_time_from_state`): ``v0 -> v_c`` at ``a_max``, a cruise at
    ``v_c``, ``v_c -> v1`` at ``a_max``.

    For a duration ``T`` the distance of that family grows monotonically with ``v_c`` (its
    derivative is the cruise time), between the peaks where the cruise vanishes,
    ``v_c = (v0 + v1 +- a T) / 2`` clipped to ``+-v_max``; ``v_c`` is found by bisection on
    that bracket (to the last bit) and the cruise takes up the remainder. Every duration from
    the minimum on is reachable (the bracket only widens with ``T``): no blocked intervals.
    A negative ``v_c`` means the move reverses (a start speed away from the goal).

    Raises
    ------
    InfeasibleError
        ``duration`` is shorter than the minimum or in the gap of
        :func:`trapezoid_blocked_from_state`.
    """
    D, v0, v1, v, a = _check_state(distance, v0, v1, v_max, a_max)
    T = float(duration)
    t_min = trapezoid_min_time_from_state(D, v0, v1, v, a)
    if not T >= t_min * (1 - 1e-12):
        raise InfeasibleError(
            f"a move over {D:.6g} from speed {v0:.6g} to {v1:.6g} takes at least "
            f"{t_min:.6g} s, not {T:.6g} s"
        )
    gap = trapezoid_blocked_from_state(D, v0, v1, v, a)
    if gap is not None and gap[0] * (1 + 1e-12) < T < gap[1] * (1 - 1e-12):
        raise InfeasibleError(
            f"a move over {D:.6g} from speed {v0:.6g} to {v1:.6g} cannot take "
            f"{T:.6g} s (only up to {gap[0]:.6g} s or from {gap[1]:.6g} s)"
        )
    T = max(T, abs(v1 - v0) / a)
    lo = max((v0 + v1 - a * T) / 2, -v)
    hi = min((v0 + v1 + a * T) / 2, v)
    if _ramps_distance(hi, v0, v1, T, a) <= D:
        vc = hi
    elif _ramps_distance(lo, v0, v1, T, a) >= D:
        vc = lo
    else:
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if mid <= lo or mid >= hi:
                break
            if _ramps_distance(mid, v0, v1, T, a) < D:
                lo = mid
            else:
                hi = mid
        vc = 0.5 * (lo + hi)
    t1, t3 = abs(vc - v0) / a, abs(vc - v1) / a
    t2 = max(T - t1 - t3, 0.0)
    a1 = math.copysign(a, vc - v0) if t1 > 0 else 0.0
    a3 = math.copysign(a, v1 - vc) if t3 > 0 else 0.0
    return MotionProfile(
        np.array([t1, t2, t3]),
        np.array([a1, 0.0, a3]),
        np.zeros(3),
        kind="trapezoid",
        params={"v": vc, "a_acc": a, "a_dec": a, "v0": v0, "v1": v1, "length": D},
        v_start=v0,
    )
