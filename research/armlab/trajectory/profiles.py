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

:func:`synchronised_scurves` is the batch form of :func:`synchronised_profiles`: many
problems (``(n_problems, n_joints)`` moves, or the segments of a path that stops at its
waypoints) at once, every step in closed form (the peak speed for a given duration from a
quadratic or a cubic instead of a bisection), for planners that need thousands of plans.

From a moving state (replanning, :func:`~armlab.planning.ptp_sync` with ``qd_start``):
:func:`trapezoid_min_time_from_state`, :func:`trapezoid_blocked_from_state`,
:func:`trapezoid_from_state` (bang-coast-bang from a speed), and the jerk-limited
:class:`JerkMove` from a speed and an acceleration to a goal speed (Berscheid & Kröger 2021,
"Jerk-limited Real-time Trajectory Generation with Arbitrary Target States", the method of
Ruckig: time-optimal move, blocked durations, a move of a given duration) with
:func:`synchronised_from_state`. A :class:`MotionProfile` then starts at ``v_start`` with the
acceleration of its first phase.
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
    "SCurveBatch",
    "synchronised_scurves",
    "trapezoid_min_time_from_state",
    "trapezoid_from_state",
    "trapezoid_blocked_from_state",
    "JerkMove",
    "scurve_min_time_from_state",
    "scurve_blocked_from_state",
    "scurve_from_state",
    "synchronised_from_state",
]

_EPS = 1e-12


def _positive(x, name: str) -> float:
    x = float(x)
    if not math.isfinite(x) or x <= 0:
        raise InputError(f"{name} must be a finite number > 0, not {x!r}")
    return x


@dataclass
class MotionProfile:
    """A scalar motion made of constant-jerk phases (rest to rest unless ``v_start`` or the
    first phase's acceleration is not zero).

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
    v_start : float
        Speed at ``t = 0`` (0: from rest; a replanned motion starts moving,
        :func:`trapezoid_from_state`, :class:`JerkMove`).

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
    v_start: float = 0.0

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
        v[0] = self.v_start
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
            **{k: v if isinstance(v, str) else float(v) for k, v in self.params.items()},
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
            return z, z + self.v_start, z.copy(), z.copy()
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
            self.durations * k,
            self.accels / k**2,
            self.jerks / k**3,
            kind=self.kind,
            params=params,
            v_start=self.v_start / k,
        )


# ---------------------------------------------------------------------- timing primitives
# The one implementation of trapezoid and double-S timing. Vectorised: arguments broadcast,
# results are arrays (0-d for scalars); the scalar entry points and the profile builders below,
# the PTP synchroniser and the optimiser's warm start all call these.
def _floats(*xs) -> list[np.ndarray]:
    arrs = [np.asarray(x, float) for x in xs]
    if all(x.shape == arrs[0].shape for x in arrs[1:]):  # the common case, without its cost
        return arrs
    return [np.asarray(x, float) for x in np.broadcast_arrays(*arrs)]


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
    vp = np.minimum(vp, v)
    trap = np.isinf(j)
    return np.where(trap, trapezoid_peak_speed(L, v, a), vp) if np.any(trap) else vp


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
    trap = np.isinf(j)
    return np.where(trap, trapezoid_min_times(L, v, a), T) if np.any(trap) else T


def double_s_speed_for_duration(
    length, duration, a_max, j_max, v_max=np.inf, *, peak=None, t_min=None
) -> np.ndarray:
    """Peak speeds [unit/s] of the symmetric double S profiles lasting ``duration`` [s], in
    closed form (arrays broadcast).

    The duration ``T = L / v + Ta(v)`` (Biagiotti & Melchiorri §3.4) is solved for the peak
    speed ``v`` on ``(0, v_p]``:

    * acceleration limit reached (``v j >= a^2``, ``Ta = a / j + v / a``): the quadratic
      ``v^2 / a - b v + L = 0``, ``b = T - a / j``, smaller root
      ``v = 2 L / (b + sqrt(b^2 - 4 L / a))``;
    * not reached (``Tj = sqrt(v / j)``, ``Ta = 2 Tj``): with ``u = Tj`` the cubic
      ``2 u^3 - T u^2 + L / j = 0``, whose middle root is wanted. Its largest root is
      ``u0 = T/6 + T/3 cos(phi/3)``, ``phi = 2 asin(sqrt(27 L / (j T^3)))``; the other two
      solve ``x^2 - s x - L / (2 j u0) = 0`` with ``s = T/2 - u0 = 2T/3 sin^2(phi/6)``
      (Vieta), and the middle one is its positive root -- no cancellation at any length.

    The regime is the one whose root satisfies its own condition (the duration is monotone
    in ``v``, so there is one). ``j = inf`` is the trapezoid,
    :func:`trapezoid_speed_for_duration` (with ``a = inf`` too, the velocity step
    ``v = L / T``); ``v_p`` itself where ``duration`` is not above the minimum; ``0`` for
    ``L <= 0``. Checked against a bisection to the last bit (``tests/oracles/double_s.py``)
    within 1e-9 relative. ``peak`` and ``t_min``: :func:`double_s_peak_speed` and
    :func:`double_s_min_times` of the same arguments when the caller has them.
    """
    L, T, a, j, v = _floats(length, duration, a_max, j_max, v_max)
    v_hi = double_s_peak_speed(L, v, a, j) if peak is None else peak
    t_min = double_s_min_times(L, v, a, j) if t_min is None else t_min
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        aj = np.where(np.isinf(j), 0.0, a / j)  # 0 for the trapezoid
        b = T - aj
        disc = b * b - 4 * L / a
        va = 2 * L / (b + np.sqrt(np.maximum(disc, 0.0)))
        phi = 2 * np.arcsin(np.sqrt(np.minimum(27 * L / (j * T**3), 1.0)))
        u0 = T / 6 + T / 3 * np.cos(phi / 3)
        sv = 2 * T / 3 * np.sin(phi / 6) ** 2
        u = (sv + np.sqrt(sv * sv + 2 * L / (j * u0))) / 2
        vb = j * u * u
        plateau = (disc >= 0) & (b > 0) & (va * j >= a * a)  # j = inf: always
        vT = np.where(plateau, va, vb)
    vT = np.where(T <= t_min, v_hi, np.minimum(vT, v_hi))
    trap = np.isinf(j)
    if np.any(trap):  # the trapezoid's own closed form (and the velocity step, a = inf)
        vT = np.where(trap, trapezoid_speed_for_duration(L, T, a, a, v), vT)
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


# ---------------------------------------------------------------------- batched, closed form
@dataclass
class SCurveBatch:
    """Time-synchronised rest-to-rest double S profiles of many problems (see
    :func:`synchronised_scurves`). Shapes: ``(..., n_joints)`` per joint, ``(...)`` per
    problem.

    Attributes
    ----------
    duration : array (...)
        Common duration of each problem [s].
    t_min : array (..., n_joints)
        Each joint's own shortest duration [s].
    distance : array (..., n_joints)
        Signed joint moves.
    v, a, j : array (..., n_joints)
        Peak speed, peak acceleration (``a_max`` where it is reached) and jerk of each joint's
        profile (unsigned; ``v = 0`` for a joint that does not move).
    tj, ta, tv : array (..., n_joints)
        Jerk phase, acceleration ramp (both jerk phases and the constant part) and cruise
        durations [s]: the seven phases are ``tj, ta - 2 tj, tj, tv, tj, ta - 2 tj, tj``.
    a_max : array (..., n_joints)
        The acceleration limit of each joint.
    """

    duration: np.ndarray
    t_min: np.ndarray
    distance: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray
    tj: np.ndarray
    ta: np.ndarray
    tv: np.ndarray
    a_max: np.ndarray

    def profile(self, index) -> MotionProfile:
        """The :class:`MotionProfile` of one joint of one problem, ``index`` into the
        ``(..., n_joints)`` arrays (e.g. ``(problem, joint)``), over ``|distance|``."""
        L = abs(float(self.distance[index]))
        T = float(self.duration[index[:-1]] if isinstance(index, tuple) else self.duration)
        v = float(self.v[index])
        if L <= 0 or v <= 0:
            return rest_profile(T)
        return _double_s_phases(L, v, float(self.a_max[index]), float(self.j[index]), T)

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, qd, qdd)`` displacements from the start at times ``t`` (m,) [s]: arrays
        ``(m, ..., n_joints)``; clamped to each problem's ``[0, duration]``."""
        t = np.asarray(t, float).reshape(-1)
        shape = (t.size,) + (1,) * self.distance.ndim
        tt = np.minimum(t.reshape(shape), self.duration[..., None])
        tt = np.maximum(tt, 0.0)
        sgn = np.sign(self.distance)
        ap, jj, tj, ta, tv = self.a, self.j, self.tj, self.ta, self.tv
        tc = ta - 2 * tj
        z = np.zeros_like(ap)
        jf = np.where(np.isfinite(jj), jj, 0.0)  # a trapezoid has no jerk phases
        d = np.stack([tj, tc, tj, tv, tj, tc, tj])  # (7, ..., n)
        acc = np.stack([z, ap, ap, z, z, -ap, -ap])
        jrk = np.stack([jf, z, -jf, z, -jf, z, jf])
        s = np.zeros_like(tt * ap)
        v = np.zeros_like(s)
        a = np.zeros_like(s)
        t0 = np.zeros_like(ap)
        s0, v0 = np.zeros_like(ap), np.zeros_like(ap)
        for k in range(7):
            h = np.clip(tt - t0, 0.0, d[k])
            a0, j0 = acc[k], jrk[k]
            inside = (tt >= t0) & ((tt < t0 + d[k]) | (k == 6))
            s = np.where(inside, s0 + v0 * h + a0 * h * h / 2 + j0 * h**3 / 6, s)
            v = np.where(inside, v0 + a0 * h + j0 * h * h / 2, v)
            a = np.where(inside, a0 + j0 * h, a)
            hk = d[k]
            s0 = s0 + v0 * hk + a0 * hk * hk / 2 + j0 * hk**3 / 6
            v0 = v0 + a0 * hk + j0 * hk * hk / 2
            t0 = t0 + hk
        return sgn * s, sgn * v, sgn * a


def synchronised_scurves(distances, v_max, a_max, j_max=math.inf) -> SCurveBatch:
    """Time-synchronised rest-to-rest double S profiles of many problems at once, closed form.

    The batch form of :func:`synchronised_profiles` (Jiang 1987, eq. 1-5 with a double S per
    joint, Biagiotti & Melchiorri §3.4): each joint's shortest duration in closed form
    (:func:`double_s_min_times`), the common duration the largest, and each joint's peak
    speed for it solved in closed form (a quadratic or a cubic, no iteration;
    :func:`double_s_speed_for_duration`). A rest-to-rest motion through waypoints where the arm
    stops (zero-velocity waypoints) is a batch of its segments:
    ``synchronised_scurves(np.diff(waypoints, axis=0), v, a, j)``.

    Parameters
    ----------
    distances : array (..., n_joints)
        Signed joint moves of each problem (e.g. ``(n_problems, n_joints)``).
    v_max, a_max, j_max : float or array broadcasting to ``distances``
        Limits > 0 in [unit/s], [unit/s^2], [unit/s^3]; ``j_max = inf`` gives trapezoids.

    Returns
    -------
    SCurveBatch

    Raises
    ------
    InputError
        A distance that is not finite, or a limit that is not > 0 (``j_max`` may be inf).
    """
    D = np.asarray(distances, float)
    if D.ndim == 0:
        raise InputError("synchronised_scurves: distances must have a joint axis (..., n_joints)")
    if not np.all(np.isfinite(D)):
        raise InputError("synchronised_scurves: distances must be finite")
    v, a, j = (np.asarray(x, float) for x in (v_max, a_max, j_max))
    for name, x, inf_ok in (("v_max", v, False), ("a_max", a, False), ("j_max", j, True)):
        if not np.all(x > 0) or not (inf_ok or np.all(np.isfinite(x))):
            raise InputError(f"synchronised_scurves: {name} must be > 0 and finite")
    try:
        L, v, a, j = _floats(np.abs(D), v, a, j)
    except ValueError:
        raise InputError(
            f"synchronised_scurves: limits do not broadcast to distances {D.shape}"
        ) from None
    peak = double_s_peak_speed(L, v, a, j)
    t_min = double_s_min_times(L, v, a, j)
    T = t_min.max(axis=-1) if t_min.shape[-1] else np.zeros(t_min.shape[:-1])
    vp = double_s_speed_for_duration(L, T[..., None], a, j, v, peak=peak, t_min=t_min)
    tj, ta = double_s_ramp(vp, a, j)
    with np.errstate(invalid="ignore", over="ignore"):
        ap = np.where(np.isinf(j), a, np.minimum(j * tj, a))
        ap = np.where(vp > 0, ap, 0.0)
    tv = np.where(vp > 0, np.maximum(T[..., None] - 2 * ta, 0.0), T[..., None])
    return SCurveBatch(
        duration=T, t_min=t_min, distance=D, v=vp, a=ap, j=j, tj=tj, ta=ta, tv=tv, a_max=a
    )


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
