"""One-dimensional motion profiles ``s(t)``: trapezoid, jerk-limited double S, resting.

A profile moves a scalar ``s`` (a joint angle in [rad], an arc length in [m], a normalised path
parameter) from ``0`` to ``length`` in ``duration`` [s], starting and ending at rest. It is a
sequence of phases of constant jerk; each phase starts with a given acceleration, so a
trapezoid (acceleration steps) and a double S (continuous acceleration) share one evaluator.

Shapes (SHU controller paper, table 1; Biagiotti & Melchiorri "Trajectory Planning for
Automatic Machines and Robots" §3.2 and §3.4 for the double S):

* trapezoid, acceleration ``a1``, cruise ``v``, deceleration ``a2``::

      S1 = v^2 / (2 a1),  S2 = v^2 / (2 a2),  S3 = L - S1 - S2 >= 0
      L < S1 + S2  ->  no cruise, peak v_p = sqrt(2 L a1 a2 / (a1 + a2))

* double S with jerk ``j``, acceleration ``a``, peak speed ``v`` (symmetric)::

      v j >= a^2:  Tj = a / j,       Ta = Tj + v / a
      v j <  a^2:  Tj = sqrt(v / j), Ta = 2 Tj          (peak acceleration j Tj < a)
      Tv = L / v - Ta >= 0,   duration = 2 Ta + Tv

A profile stretched in time by ``k`` is the profile built with ``(v / k, a / k^2, j / k^3)``:
every regime test above is invariant under that scaling, so :meth:`MotionProfile.stretched`
is exact.

This module is the one implementation of that timing. The primitives are vectorised (arguments
broadcast, ``inf`` switches a limit off): :func:`trapezoid_peak_speed`,
:func:`trapezoid_min_times`, :func:`trapezoid_speed_for_duration` and :func:`double_s_ramp`,
:func:`double_s_peak_speed`, :func:`double_s_min_times`, :func:`double_s_speed_for_duration`
(``j = inf`` is the trapezoid). The scalar entry points (:func:`trapezoid_min_time`,
:func:`double_s_min_time`), the profile builders, the time-synchronised set of
:func:`synchronised_profiles` (Jiang 1987, eq. 1-5: PTP motion and the optimiser's warm start),
the SHU step table (:mod:`armlab.planning.steps`) and the requirement moves of the drive sizing
(:mod:`armlab.dynamics.requirements`) all call them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from armlab.errors import InfeasibleError, InputError

__all__ = [
    "MotionProfile",
    "trapezoid_profile",
    "trapezoid_profile_for_duration",
    "double_s_profile",
    "double_s_profile_for_duration",
    "rest_profile",
    "trapezoid_min_time",
    "double_s_min_time",
    "double_s_binding",
    "synchronised_profiles",
    "trapezoid_ramp_length",
    "trapezoid_peak_speed",
    "trapezoid_min_times",
    "trapezoid_speed_for_duration",
    "double_s_ramp",
    "double_s_peak_speed",
    "double_s_min_times",
    "double_s_speed_for_duration",
    "time_grid",
]

_EPS = 1e-12


def _positive(x, name: str) -> float:
    x = float(x)
    if not math.isfinite(x) or x <= 0:
        raise InputError(f"{name} must be a finite number > 0, not {x!r}")
    return x


CORNER_GAP = 1e-4  # width of the knot pair at a corner, as a fraction of dt


def time_grid(
    duration: float, dt: float, corners=(), *, ends: bool = False, knots=()
) -> np.ndarray:
    """Sample times ``0, dt, 2 dt, ..., duration`` in [s]; the last step may be shorter.

    ``corners`` are interior times where the acceleration steps (trapezoid phases, a path's
    curvature). Each gets the knots ``t_c - delta`` and ``t_c`` (``delta = 1e-4 dt``), and with
    ``ends`` (the acceleration steps at the start and the end too) the ends get ``delta`` and
    ``duration - delta``. A :class:`Trajectory` stores one acceleration per knot and
    interpolates between knots with quintic Hermite polynomials, so an interval that spans a
    step would overshoot it (up to 1.5 times) when resampled; with the knot pairs only the
    ``delta`` windows do — also where :meth:`Trajectory.concat` joins two motions.
    ``knots`` are times added as they are (where only the jerk steps: the Hermite
    interpolation is then exact on both sides). A zero duration gives ``[0.0]``.
    """
    dt = _positive(dt, "dt")
    if duration <= 0:
        return np.zeros(1)
    n = int(math.floor(duration / dt + 1e-9))
    t = dt * np.arange(n + 1)
    if duration - t[-1] > 1e-9 * dt or n == 0:
        t = np.append(t, duration)
    else:
        t[-1] = duration
    delta = CORNER_GAP * dt
    if duration <= 8 * delta:
        return t
    c = np.unique(np.asarray(corners, float).reshape(-1))
    c = c[(c > 3 * delta) & (c < duration - 3 * delta)]
    if c.size:
        c = c[np.concatenate([[True], np.diff(c) > 3 * delta])]
    k = np.asarray(knots, float).reshape(-1)
    k = k[(k > 3 * delta) & (k < duration - 3 * delta)]
    added = np.unique(np.concatenate([[delta, duration - delta] if ends else [], c - delta, c, k]))
    if added.size == 0:
        return t
    added = added[np.concatenate([[True], np.diff(added) >= 0.5 * delta])]
    near = np.min(np.abs(t[:, None] - added[None, :]), axis=1) < 0.5 * delta
    near[[0, -1]] = False
    return np.union1d(t[~near], added)


@dataclass
class MotionProfile:
    """A rest-to-rest scalar motion made of constant-jerk phases.

    Parameters
    ----------
    durations : array (k,)
        Phase durations in [s] (zero-length phases are dropped).
    accels : array (k,)
        Acceleration at the start of each phase in [unit/s^2] (steps allowed).
    jerks : array (k,)
        Constant jerk of each phase in [unit/s^3].
    kind : str
        ``"trapezoid"``, ``"double_s"`` or ``"rest"``.
    params : dict
        The parameters the profile was built from (peak speed, acceleration, ...), for reports.

    Attributes
    ----------
    t_knots : array (k + 1,)
        Phase boundaries in [s].
    s_knots, v_knots : array (k + 1,)
        Position and speed at the phase boundaries.
    """

    durations: np.ndarray
    accels: np.ndarray
    jerks: np.ndarray
    kind: str = "trapezoid"
    params: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        d = np.asarray(self.durations, float).reshape(-1)
        a = np.asarray(self.accels, float).reshape(-1)
        j = np.asarray(self.jerks, float).reshape(-1)
        keep = d > 0
        self.durations, self.accels, self.jerks = d[keep], a[keep], j[keep]
        k = self.durations.size
        self.t_knots = np.concatenate([[0.0], np.cumsum(self.durations)])
        s = np.zeros(k + 1)
        v = np.zeros(k + 1)
        for i in range(k):
            h, a0, jj = self.durations[i], self.accels[i], self.jerks[i]
            s[i + 1] = s[i] + v[i] * h + a0 * h * h / 2 + jj * h**3 / 6
            v[i + 1] = v[i] + a0 * h + jj * h * h / 2
        if k and "length" in self.params:  # the nominal end point, free of rounding
            s[-1] = float(self.params["length"])
        self.s_knots, self.v_knots = s, v

    # ------------------------------------------------------------------ facts
    @property
    def duration(self) -> float:
        """Duration in [s]."""
        return float(self.t_knots[-1])

    @property
    def length(self) -> float:
        """Distance covered, in the unit of ``s``."""
        return float(self.s_knots[-1])

    @property
    def v_peak(self) -> float:
        """Largest speed (reached at a phase boundary: the acceleration only changes sign
        there)."""
        return float(np.abs(self.v_knots).max())

    @property
    def corners(self) -> np.ndarray:
        """Interior phase boundaries [s] (where the acceleration or the jerk steps)."""
        return self.t_knots[1:-1].copy()

    def time_at(self, s) -> np.ndarray:
        """Times [s] at which the profile reaches positions ``s`` (n,) (bisection; ``s`` is
        non-decreasing in time)."""
        s = np.asarray(s, float).reshape(-1)
        lo = np.zeros(s.size)
        hi = np.full(s.size, self.duration)
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            below = self.evaluate(mid)[0] < s
            lo = np.where(below, mid, lo)
            hi = np.where(below, hi, mid)
        return hi

    def to_dict(self) -> dict:
        """Kind, duration and parameters, JSON-able."""
        return {
            "kind": self.kind,
            "duration_s": self.duration,
            "length": self.length,
            **{k: float(v) for k, v in self.params.items()},
        }

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(s, sd, sdd, sddd)`` at times ``t`` (n,) in [s].

        Right-continuous at interior phase boundaries (the value of the phase that starts
        there); at ``t >= duration`` the left limit (the end of the last phase); times outside
        ``[0, duration]`` are clamped, so the profile rests at its ends.
        """
        t = np.asarray(t, float).reshape(-1)
        k = self.durations.size
        if k == 0:
            z = np.zeros(t.size)
            return z, z.copy(), z.copy(), z.copy()
        tc = np.clip(t, 0.0, self.duration)
        i = np.clip(np.searchsorted(self.t_knots, tc, side="right") - 1, 0, k - 1)
        tau = np.clip(tc - self.t_knots[i], 0.0, self.durations[i])
        a0, jj = self.accels[i], self.jerks[i]
        s = self.s_knots[i] + self.v_knots[i] * tau + a0 * tau**2 / 2 + jj * tau**3 / 6
        v = self.v_knots[i] + a0 * tau + jj * tau**2 / 2
        a = a0 + jj * tau
        j = jj.copy()
        end = tc >= self.duration
        s[end] = self.length
        return s, v, a, j

    def stretched(self, k: float) -> MotionProfile:
        """The same motion ``k`` times slower: ``s_k(t) = s(t / k)``."""
        k = _positive(k, "stretch factor")
        params = dict(self.params)
        for name, p in (("v", 1), ("a", 2), ("a_acc", 2), ("a_dec", 2), ("j", 3)):
            if name in params:
                params[name] = params[name] / k**p
        return MotionProfile(
            self.durations * k, self.accels / k**2, self.jerks / k**3, kind=self.kind, params=params
        )


# ---------------------------------------------------------------------- timing primitives
# The one implementation of trapezoid and double-S timing. Vectorised: arguments broadcast,
# results are arrays (0-d for scalars); the scalar entry points and the profile builders below,
# the PTP synchroniser and the optimiser's warm start all call these.
def _floats(*xs) -> list[np.ndarray]:
    return [np.asarray(x, float) for x in np.broadcast_arrays(*xs)]


def trapezoid_ramp_length(v, a_acc, a_dec=None) -> np.ndarray:
    """Distance [unit] of the two ramps of a rest-to-rest trapezoid cruising at ``v`` [unit/s]:
    ``S1 + S2 = v^2 / 2 (1/a1 + 1/a2)`` (SHU controller paper, table 1); arrays broadcast."""
    v, a1, a2 = _floats(v, a_acc, a_acc if a_dec is None else a_dec)
    with np.errstate(invalid="ignore"):
        return v * v / 2 * (1 / a1 + 1 / a2)


def trapezoid_peak_speed(length, v_max, a_acc, a_dec=None) -> np.ndarray:
    """Peak speed [unit/s] of the shortest rest-to-rest trapezoid over ``length`` >= 0.

    ``v_p = v_max`` if ``L >= S1 + S2`` (:func:`trapezoid_ramp_length`), else the triangle's
    ``v_p = sqrt(2 L a1 a2 / (a1 + a2))`` (SHU controller paper, table 1). Arrays broadcast;
    an infinite acceleration gives the pure velocity step.
    """
    L, v, a1, a2 = _floats(length, v_max, a_acc, a_acc if a_dec is None else a_dec)
    with np.errstate(invalid="ignore", divide="ignore"):
        triangle = np.sqrt(2 * L * a1 * a2 / (a1 + a2))
    return np.where(L >= trapezoid_ramp_length(v, a1, a2), v, triangle)


def trapezoid_min_times(length, v_max, a_acc, a_dec=None) -> np.ndarray:
    """Shortest durations [s] of rest-to-rest trapezoids over ``length`` >= 0 (arrays broadcast).

    ``T = L / v + v / (2 a1) + v / (2 a2)`` with a cruise phase, ``T = v_p / a1 + v_p / a2``
    without (SHU controller paper, table 1); ``T = 0`` for ``L <= 0``.
    """
    L, v, a1, a2 = _floats(length, v_max, a_acc, a_acc if a_dec is None else a_dec)
    vp = trapezoid_peak_speed(L, v, a1, a2)
    with np.errstate(invalid="ignore", divide="ignore"):
        cruise = L >= trapezoid_ramp_length(v, a1, a2)
        T = np.where(cruise, L / v + v / (2 * a1) + v / (2 * a2), vp / a1 + vp / a2)
    return np.where(L > 0, T, 0.0)


def trapezoid_speed_for_duration(length, duration, a_acc, a_dec=None, v_max=np.inf) -> np.ndarray:
    """Cruise speeds [unit/s] of the trapezoids with ramps ``(a1, a2)`` lasting ``duration`` [s]

    The smaller root of ``L = v T - v^2 h / 2``, ``h = 1/a1 + 1/a2`` (SHU controller paper,
    table 1, solved for ``v``), in the cancellation-free form ``v = 2 L / (T + sqrt(T^2 - 2 L h))``;
    at most ``v_max``, and the fastest trapezoid's peak where ``duration`` is not above its
    minimum. Arrays broadcast; ``0`` for ``L <= 0``.
    """
    L, T, a1, a2, v = _floats(length, duration, a_acc, a_acc if a_dec is None else a_dec, v_max)
    h = 1 / a1 + 1 / a2
    with np.errstate(invalid="ignore", divide="ignore"):
        vT = 2 * L / (T + np.sqrt(np.maximum(T * T - 2 * L * h, 0.0)))
    fastest = T <= trapezoid_min_times(L, v, a1, a2)
    vT = np.where(fastest, trapezoid_peak_speed(L, v, a1, a2), np.minimum(vT, v))
    return np.where(L > 0, vT, 0.0)


def double_s_ramp(v, a_max, j_max) -> tuple[np.ndarray, np.ndarray]:
    """``(Tj, Ta)`` [s] of a symmetric double S accelerating from rest to ``v`` (arrays broadcast).

    Biagiotti & Melchiorri §3.4: ``Tj = a / j``, ``Ta = Tj + v / a`` if ``v j >= a^2`` (the
    acceleration limit is reached); else ``Tj = sqrt(v / j)``, ``Ta = 2 Tj``. ``j = inf`` gives
    the trapezoid's ``(0, v / a)``, ``a = inf`` the jerk-only ramp; ``v = 0`` gives ``(0, 0)``.
    """
    v, a, j = _floats(v, a_max, j_max)
    with np.errstate(invalid="ignore", divide="ignore"):
        plateau = np.isinf(j) | (np.isfinite(a) & (v * j >= a * a))
        tj = np.where(plateau, np.where(np.isinf(j), 0.0, a / j), np.sqrt(v / j))
        ta = np.where(plateau, tj + v / a, 2 * tj)
    moving = v > 0
    return np.where(moving, tj, 0.0), np.where(moving, ta, 0.0)


def double_s_peak_speed(length, v_max, a_max, j_max) -> np.ndarray:
    """Peak speed [unit/s] of the shortest symmetric rest-to-rest double S over ``length`` >= 0.

    The largest ``v <= v_max`` whose ramps fit, ``v Ta(v) <= L`` (Biagiotti & Melchiorri §3.4):
    ``v^2 / a + v a / j = L`` where the acceleration limit is reached (``v >= a^2 / j``), else
    ``2 v sqrt(v / j) = L``, i.e. ``v = (L sqrt(j) / 2)^(2/3)``. ``j = inf`` is the trapezoid
    (:func:`trapezoid_peak_speed`). Arrays broadcast; ``a`` and ``j`` may be ``inf``.
    """
    L, v, a, j = _floats(length, v_max, a_max, j_max)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        plateau = a * (-a / j + np.sqrt(a * a / (j * j) + 4 * L / a)) / 2
        vp = np.where(plateau >= a * a / j, plateau, (L * np.sqrt(j) / 2) ** (2 / 3))
    return np.where(np.isinf(j), trapezoid_peak_speed(L, v, a), np.minimum(vp, v))


def double_s_min_times(length, v_max, a_max, j_max) -> np.ndarray:
    """Shortest durations [s] of symmetric rest-to-rest double S profiles (arrays broadcast).

    ``T = L / v_p + Ta(v_p)`` with ``v_p`` from :func:`double_s_peak_speed` (Biagiotti &
    Melchiorri §3.4); the trapezoid's :func:`trapezoid_min_times` where ``j = inf``;
    ``0`` for ``L <= 0``. ``inf`` switches a limit off (not all three).
    """
    L, v, a, j = _floats(length, v_max, a_max, j_max)
    vp = double_s_peak_speed(L, v, a, j)
    with np.errstate(invalid="ignore", divide="ignore"):
        T = np.where(L > 0, L / vp + double_s_ramp(vp, a, j)[1], 0.0)
    return np.where(np.isinf(j), trapezoid_min_times(L, v, a), T)


def double_s_speed_for_duration(length, duration, a_max, j_max, v_max=np.inf) -> np.ndarray:
    """Peak speeds [unit/s] of the symmetric double S profiles lasting ``duration`` [s].

    The duration ``L / v + Ta(v)`` decreases with the peak speed ``v`` on ``(0, v_p]``
    (:func:`double_s_peak_speed`; Biagiotti & Melchiorri §3.4), so ``v`` is found by bisection
    to the last bit; ``v_p`` itself where ``duration`` is not above the minimum; the closed
    form :func:`trapezoid_speed_for_duration` where ``j = inf``; ``0`` for ``L <= 0``. Arrays
    broadcast.
    """
    L, T, a, j, v = _floats(length, duration, a_max, j_max, v_max)
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


# ---------------------------------------------------------------------- trapezoid
def rest_profile(duration: float = 0.0) -> MotionProfile:
    """Stand still for ``duration`` [s] (a zero-length move)."""
    return MotionProfile(
        np.array([max(duration, 0.0)]), np.zeros(1), np.zeros(1), kind="rest", params={"v": 0.0}
    )


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


def double_s_binding(length: float, v_max: float, a_max: float, j_max: float = math.inf) -> str:
    """The limit that sets the shortest double S over ``length`` (a trapezoid if ``j_max`` is
    inf): ``"velocity"`` if it cruises at ``v_max``, else ``"acceleration"`` if it reaches
    ``a_max`` (``v_p j >= a^2``, Biagiotti & Melchiorri §3.4; always for the trapezoid), else
    ``"jerk"``."""
    vp = float(double_s_peak_speed(length, v_max, a_max, j_max))
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
    t_min = double_s_min_times(L, v, a, j)
    T = float(t_min.max()) if t_min.size else 0.0
    vp = double_s_speed_for_duration(L, T, a, j, v)
    profiles = [
        _double_s_phases(float(L[i]), float(vp[i]), float(a[i]), float(j[i]), T)
        if L[i] > 0 and vp[i] > 0
        else rest_profile(T)
        for i in range(L.size)
    ]
    return T, t_min, profiles
