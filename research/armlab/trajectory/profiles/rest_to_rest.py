"""Rest-to-rest trapezoid and double S profiles, shortest or of a given duration, and the
time-synchronised set of several joints (Jiang 1987, eq. 1-5)."""

from __future__ import annotations

import math

import numpy as np

from armlab.errors import InfeasibleError, InputError
from armlab.trajectory.profiles.motion import MotionProfile, _positive, rest_profile
from armlab.trajectory.profiles.timing import (
    _floats,
    double_s_min_times,
    double_s_peak_speed,
    double_s_ramp,
    double_s_speed_for_duration,
    trapezoid_min_times,
    trapezoid_peak_speed,
    trapezoid_speed_for_duration,
)

__all__ = [
    "trapezoid_profile",
    "trapezoid_profile_for_duration",
    "double_s_profile",
    "double_s_profile_for_duration",
    "trapezoid_min_time",
    "double_s_min_time",
    "double_s_binding",
    "synchronised_profiles",
]


# ---------------------------------------------------------------------- trapezoid


def trapezoid_min_time(length: float, v: float, a_acc: float, a_dec: float | None = None) -> float:
    """Shortest duration [s] of a rest-to-rest trapezoid over ``length`` (>= 0): the scalar
    :func:`trapezoid_min_times`."""
    return float(trapezoid_min_times(length, v, a_acc, a_dec))


def _trapezoid_phases(
    length: float, v: float, a1: float, a2: float, duration: float | None = None
) -> MotionProfile:
    """The trapezoid cruising at ``v``; with ``duration`` the cruise absorbs the rounding so
    that the duration is exact."""
    t1, t2 = v / a1, v / a2
    t3 = max(length - v * v / (2 * a1) - v * v / (2 * a2), 0.0) / v
    if duration is not None and duration - t1 - t2 > 0:
        t3 = duration - t1 - t2
    return MotionProfile(
        np.array([t1, t3, t2]),
        np.array([a1, 0.0, -a2]),
        np.zeros(3),
        kind="trapezoid",
        params={"v": v, "a_acc": a1, "a_dec": a2, "length": length},
    )


def trapezoid_profile(
    length: float, v_max: float, a_acc: float, a_dec: float | None = None
) -> MotionProfile:
    """Shortest rest-to-rest trapezoid (triangle if the cruise speed is not reached).

    Parameters
    ----------
    length : float
        Distance >= 0.
    v_max : float
        Cruise speed limit > 0.
    a_acc, a_dec : float
        Acceleration and deceleration > 0 (``a_dec`` defaults to ``a_acc``).
    """
    length = float(length)
    if not math.isfinite(length) or length < 0:
        raise InputError(f"profile length must be finite and >= 0, not {length!r}")
    v_max = _positive(v_max, "v_max")
    a1 = _positive(a_acc, "a_acc")
    a2 = a1 if a_dec is None else _positive(a_dec, "a_dec")
    if length == 0:
        return rest_profile(0.0)
    return _trapezoid_phases(length, float(trapezoid_peak_speed(length, v_max, a1, a2)), a1, a2)


def trapezoid_profile_for_duration(
    length: float,
    duration: float,
    a_acc: float,
    a_dec: float | None = None,
    v_max: float = math.inf,
) -> MotionProfile:
    """The trapezoid with the given accelerations that takes exactly ``duration`` [s]
    (cruise speed from :func:`trapezoid_speed_for_duration`).

    Raises
    ------
    InfeasibleError
        ``duration`` is shorter than the fastest trapezoid within ``v_max``.
    """
    a1 = _positive(a_acc, "a_acc")
    a2 = a1 if a_dec is None else _positive(a_dec, "a_dec")
    if length <= 0:
        return rest_profile(duration)
    t_min = trapezoid_min_time(length, v_max, a1, a2)
    if duration < t_min * (1 - 1e-12):
        raise InfeasibleError(
            f"a trapezoid over {length:.6g} takes at least {t_min:.6g} s, not {duration:.6g} s"
        )
    v = float(trapezoid_speed_for_duration(length, duration, a1, a2, v_max))
    return _trapezoid_phases(length, v, a1, a2, duration)


# ---------------------------------------------------------------------- double S
def _double_s_phases(
    length: float, v: float, a: float, j: float, duration: float | None = None
) -> MotionProfile:
    """The symmetric double S with peak speed ``v`` (at most :func:`double_s_peak_speed`): the
    seven phases of Biagiotti & Melchiorri §3.4, the cruise ``L / v - Ta`` or, with
    ``duration``, ``duration - 2 Ta``. ``j = inf`` gives the trapezoid."""
    if math.isinf(j):
        return _trapezoid_phases(length, v, a, a, duration)
    tj, ta = (float(x) for x in double_s_ramp(v, a, j))
    ap = min(j * tj, a)  # peak acceleration: a where it is reached
    tc = ta - 2 * tj  # constant-acceleration time
    tv = max(length / v - ta if duration is None else duration - 2 * ta, 0.0)  # cruise
    d = np.array([tj, tc, tj, tv, tj, tc, tj])
    acc = np.array([0.0, ap, ap, 0.0, 0.0, -ap, -ap])
    jerk = np.array([j, 0.0, -j, 0.0, -j, 0.0, j])
    return MotionProfile(
        d, acc, jerk, kind="double_s", params={"v": v, "a": ap, "j": j, "length": length}
    )


def double_s_min_time(length: float, v_max: float, a_max: float, j_max: float) -> float:
    """Shortest duration [s] of a symmetric rest-to-rest double S over ``length``: the scalar
    :func:`double_s_min_times`."""
    return float(double_s_min_times(length, v_max, a_max, j_max))


def double_s_profile(length: float, v_max: float, a_max: float, j_max: float) -> MotionProfile:
    """Shortest symmetric rest-to-rest double-S (jerk-limited) profile.

    Parameters
    ----------
    length : float
        Distance >= 0.
    v_max, a_max, j_max : float
        Speed, acceleration and jerk limits > 0.
    """
    length = float(length)
    if not math.isfinite(length) or length < 0:
        raise InputError(f"profile length must be finite and >= 0, not {length!r}")
    v_max, a_max, j_max = (
        _positive(v_max, "v_max"),
        _positive(a_max, "a_max"),
        _positive(j_max, "j_max"),
    )
    if length == 0:
        return rest_profile(0.0)
    v = float(double_s_peak_speed(length, v_max, a_max, j_max))
    return _double_s_phases(length, v, a_max, j_max)


def double_s_profile_for_duration(
    length: float, duration: float, a_max: float, j_max: float, v_max: float = math.inf
) -> MotionProfile:
    """The double S with limits ``(a_max, j_max)`` that takes exactly ``duration`` [s]
    (peak speed from :func:`double_s_speed_for_duration`).

    Raises
    ------
    InfeasibleError
        ``duration`` is shorter than the fastest double S.
    """
    a_max, j_max = _positive(a_max, "a_max"), _positive(j_max, "j_max")
    if length <= 0:
        return rest_profile(duration)
    t_min = double_s_min_time(length, v_max, a_max, j_max)
    if duration < t_min * (1 - 1e-12):
        raise InfeasibleError(
            f"a double S over {length:.6g} takes at least {t_min:.6g} s, not {duration:.6g} s"
        )
    v = float(double_s_speed_for_duration(length, duration, a_max, j_max, v_max))
    return _double_s_phases(length, v, a_max, j_max, duration)


def double_s_binding(
    length: float, v_max: float, a_max: float, j_max: float = math.inf, *, peak=None
) -> str:
    """The limit that sets the shortest double S over ``length`` (a trapezoid if ``j_max`` is
    inf): ``"velocity"`` if it cruises at ``v_max``, else ``"acceleration"`` if it reaches
    ``a_max`` (``v_p j >= a^2``, Biagiotti & Melchiorri §3.4; always for the trapezoid), else
    ``"jerk"``. ``peak``: its :func:`double_s_peak_speed` if the caller has it."""
    if peak is None:
        peak = double_s_peak_speed(length, v_max, a_max, j_max)
    vp = float(peak)
    if vp >= v_max:
        return "velocity"
    if math.isinf(j_max) or vp * j_max >= a_max * a_max:
        return "acceleration"
    return "jerk"


# ---------------------------------------------------------------------- synchronisation
def synchronised_profiles(
    lengths, v_max, a_max, j_max=math.inf
) -> tuple[float, np.ndarray, list[MotionProfile]]:
    """Rest-to-rest profiles of several joints that all take the same time (Jiang 1987, eq. 1-5).

    Each joint alone needs ``t_i`` (eq. 3 with its fastest double S, :func:`double_s_min_times`;
    a trapezoid where ``j_max`` is inf); the common duration is ``T = max t_i`` and every
    joint keeps its acceleration and jerk and lowers its peak speed until it also takes ``T``
    (eq. 4; :func:`double_s_speed_for_duration`).

    Parameters
    ----------
    lengths : array (n,)
        Distances >= 0 (joint moves in [rad]).
    v_max, a_max, j_max : float or array (n,)
        Limits in [unit/s], [unit/s^2], [unit/s^3]; ``inf`` switches one off (not all three).

    Returns
    -------
    (T, t_min, profiles)
        The common duration [s], each joint's shortest duration (n,) [s] and the n profiles
        (a resting one for a zero length).
    """
    L, v, a, j = (x.reshape(-1) for x in _floats(lengths, v_max, a_max, j_max))
    peak = double_s_peak_speed(L, v, a, j)  # computed once for both (as the batch does)
    t_min = double_s_min_times(L, v, a, j, peak=peak)
    T = float(t_min.max()) if t_min.size else 0.0
    vp = double_s_speed_for_duration(L, T, a, j, v, peak=peak, t_min=t_min)
    profiles = [
        _double_s_phases(float(L[i]), float(vp[i]), float(a[i]), float(j[i]), T)
        if L[i] > 0 and vp[i] > 0
        else rest_profile(T)
        for i in range(L.size)
    ]
    return T, t_min, profiles
