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


# ---------------------------------------------------------------------- trapezoid
def rest_profile(duration: float = 0.0) -> MotionProfile:
    """Stand still for ``duration`` [s] (a zero-length move)."""
    return MotionProfile(
        np.array([max(duration, 0.0)]), np.zeros(1), np.zeros(1), kind="rest", params={"v": 0.0}
    )


def trapezoid_min_time(length: float, v: float, a_acc: float, a_dec: float | None = None) -> float:
    """Shortest duration [s] of a rest-to-rest trapezoid over ``length`` (>= 0)."""
    a_dec = a_acc if a_dec is None else a_dec
    if length <= 0:
        return 0.0
    if length >= v * v / 2 * (1 / a_acc + 1 / a_dec):
        return length / v + v / (2 * a_acc) + v / (2 * a_dec)
    vp = math.sqrt(2 * length * a_acc * a_dec / (a_acc + a_dec))
    return vp / a_acc + vp / a_dec


def _trapezoid_phases(length: float, v: float, a1: float, a2: float) -> MotionProfile:
    t1, t2 = v / a1, v / a2
    t3 = max(length - v * v / (2 * a1) - v * v / (2 * a2), 0.0) / v
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
    v = v_max
    if length < v * v / 2 * (1 / a1 + 1 / a2):
        v = math.sqrt(2 * length * a1 * a2 / (a1 + a2))
    return _trapezoid_phases(length, v, a1, a2)


def trapezoid_profile_for_duration(
    length: float,
    duration: float,
    a_acc: float,
    a_dec: float | None = None,
    v_max: float = math.inf,
) -> MotionProfile:
    """The trapezoid with the given accelerations that takes exactly ``duration`` [s].

    The cruise speed solves ``L = v T - v^2 / 2 (1/a1 + 1/a2)`` (the smaller root):
    ``v = (T - sqrt(T^2 - 2 L h)) / h`` with ``h = 1/a1 + 1/a2``.

    Raises
    ------
    InfeasibleError
        ``duration`` is shorter than the fastest trapezoid within ``v_max``.
    """
    a1 = _positive(a_acc, "a_acc")
    a2 = a1 if a_dec is None else _positive(a_dec, "a_dec")
    if length <= 0:
        return rest_profile(duration)
    t_min = (
        trapezoid_min_time(length, v_max, a1, a2)
        if math.isfinite(v_max)
        else math.sqrt(2 * length * (1 / a1 + 1 / a2))
    )
    if duration < t_min * (1 - 1e-12):
        raise InfeasibleError(
            f"a trapezoid over {length:.6g} takes at least {t_min:.6g} s, not {duration:.6g} s"
        )
    h = 1 / a1 + 1 / a2
    disc = max(duration * duration - 2 * length * h, 0.0)
    v = (duration - math.sqrt(disc)) / h
    v = min(v, v_max)
    prof = _trapezoid_phases(length, v, a1, a2)
    # absorb rounding in the cruise phase so the duration is exact
    cruise = duration - v / a1 - v / a2
    if cruise > 0:
        prof = MotionProfile(
            np.array([v / a1, cruise, v / a2]),
            np.array([a1, 0.0, -a2]),
            np.zeros(3),
            kind="trapezoid",
            params={"v": v, "a_acc": a1, "a_dec": a2, "length": length},
        )
    return prof


# ---------------------------------------------------------------------- double S
def _double_s_ta(v: float, a: float, j: float) -> tuple[float, float]:
    """(Tj, Ta) of the acceleration phase reaching speed ``v`` from rest."""
    if v * j >= a * a:
        tj = a / j
        return tj, tj + v / a
    tj = math.sqrt(v / j)
    return tj, 2 * tj


def _double_s_vlim(length: float, v_max: float, a: float, j: float) -> float:
    """Largest peak speed with a cruise phase of length >= 0: ``L >= v Ta(v)``."""
    # a reached: L = v (a/j + v/a)  ->  v^2 / a + v a / j - L = 0
    v = a * (-a / j + math.sqrt(a * a / (j * j) + 4 * length / a)) / 2
    if v < a * a / j:  # a not reached: L = 2 v sqrt(v / j)
        v = (length * math.sqrt(j) / 2) ** (2 / 3)
    return min(v, v_max)


def _double_s_from_v(length: float, v: float, a: float, j: float) -> MotionProfile:
    tj, ta = _double_s_ta(v, a, j)
    ap = j * tj  # peak acceleration
    tc = ta - 2 * tj  # constant-acceleration time
    tv = max(length / v - ta, 0.0)
    d = np.array([tj, tc, tj, tv, tj, tc, tj])
    acc = np.array([0.0, ap, ap, 0.0, 0.0, -ap, -ap])
    jerk = np.array([j, 0.0, -j, 0.0, -j, 0.0, j])
    return MotionProfile(
        d, acc, jerk, kind="double_s", params={"v": v, "a": ap, "j": j, "length": length}
    )


def double_s_min_time(length: float, v_max: float, a_max: float, j_max: float) -> float:
    """Shortest duration [s] of a symmetric rest-to-rest double S over ``length``."""
    if length <= 0:
        return 0.0
    v = _double_s_vlim(length, v_max, a_max, j_max)
    _, ta = _double_s_ta(v, a_max, j_max)
    return length / v + ta


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
    return _double_s_from_v(length, _double_s_vlim(length, v_max, a_max, j_max), a_max, j_max)


def double_s_profile_for_duration(
    length: float, duration: float, a_max: float, j_max: float, v_max: float = math.inf
) -> MotionProfile:
    """The double S with limits ``(a_max, j_max)`` that takes exactly ``duration`` [s].

    The duration ``L / v + Ta(v)`` decreases monotonically with the peak speed ``v`` while a
    cruise phase exists, so ``v`` is found by bisection.

    Raises
    ------
    InfeasibleError
        ``duration`` is shorter than the fastest double S.
    """
    a_max, j_max = _positive(a_max, "a_max"), _positive(j_max, "j_max")
    if length <= 0:
        return rest_profile(duration)
    v_hi = _double_s_vlim(length, v_max, a_max, j_max)
    t_min = length / v_hi + _double_s_ta(v_hi, a_max, j_max)[1]
    if duration < t_min * (1 - 1e-12):
        raise InfeasibleError(
            f"a double S over {length:.6g} takes at least {t_min:.6g} s, not {duration:.6g} s"
        )
    if duration <= t_min:
        return _double_s_from_v(length, v_hi, a_max, j_max)
    lo, hi = 0.0, v_hi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= 0:
            break
        t_mid = length / mid + _double_s_ta(mid, a_max, j_max)[1]
        if t_mid > duration:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-15 * hi:
            break
    # hi is the smallest speed found whose duration is <= the target (relative error 1e-15)
    return _double_s_from_v(length, hi, a_max, j_max)
