"""The :class:`MotionProfile` (phases of constant jerk) and the resting profile."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from armlab.errors import InputError

__all__ = ["MotionProfile", "rest_profile"]


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
        d = np.asarray(self.durations, float).reshape(-1).tolist()
        a = np.asarray(self.accels, float).reshape(-1).tolist()
        j = np.asarray(self.jerks, float).reshape(-1).tolist()
        # the phases of positive length, integrated in Python floats (the same IEEE
        # arithmetic as numpy's, without its per-scalar cost)
        rows = [(h, a0, jj) for h, a0, jj in zip(d, a, j, strict=True) if h > 0]
        t, s, v = [0.0], [0.0], [float(self.v_start)]
        for h, a0, jj in rows:
            t.append(t[-1] + h)
            s.append(s[-1] + v[-1] * h + a0 * h * h / 2 + jj * h**3 / 6)
            v.append(v[-1] + a0 * h + jj * h * h / 2)
        if rows and "length" in self.params:  # the nominal end point, free of rounding
            s[-1] = float(self.params["length"])
        cols = list(zip(*rows, strict=True)) if rows else [(), (), ()]
        self.durations, self.accels, self.jerks = (np.array(c, float) for c in cols)
        self.t_knots, self.s_knots, self.v_knots = np.array(t), np.array(s), np.array(v)

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


def rest_profile(duration: float = 0.0) -> MotionProfile:
    """Stand still for ``duration`` [s] (a zero-length move)."""
    return MotionProfile(
        np.array([max(duration, 0.0)]), np.zeros(1), np.zeros(1), kind="rest", params={"v": 0.0}
    )
