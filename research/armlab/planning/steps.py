"""Trapezoidal motion as per-step lengths: SHU controller paper (1998), §2.1, table 1.

The controller sends, every interpolation period ``T``, the length of the next step along the
path (a line length in [m], an arc angle in [rad]). Table 1 of the SHU controller paper::

    phase          length               time          steps      length of step k
    acceleration   S1 = V^2 / (2 a1)    t1 = V / a1   n1 = t1/T  (2k - 1) a1 T^2 / 2
    deceleration   S2 = V^2 / (2 a2)    t2 = V / a2   n2 = t2/T  V T - (2k - 1) a2 T^2 / 2
    cruise         S3 = L - S1 - S2     t3 = n3 T     n3 = S3/(V T)   V T

If ``L < S1 + S2`` there is no cruise (a triangle with a lower peak); the remainder ``dL`` that
does not fill a whole step is inserted once into the deceleration steps, where it keeps them
decreasing: before step 1 if ``dL >= S2_1``, else between steps ``k - 1`` and ``k`` with
``S2_{k-1} >= dL >= S2_k`` (the paper's two cases).

Where the paper is silent we decide (documented in :func:`trapezoid_steps`):

* the table assumes ``t1/T`` and ``t2/T`` whole. We round the step counts up,
  ``n_i = ceil(V / (a_i T))``, and use the effective accelerations ``a_i' = V / (n_i T) <= a_i``
  in the table's formulas — exactly the table when ``t_i / T`` is whole, never above the limit
  otherwise, and the ramps then end exactly at ``V``;
* a short move gets the triangle's peak ``V_p = sqrt(2 L a1 a2 / (a1 + a2))``; if the rounded
  ramps overshoot ``L`` the peak is lowered to ``V_p = 2 L / ((n1 + n2) T)`` so that they fill
  ``L`` exactly (then no left-over step is needed);
* a remainder smaller than the last deceleration step goes after it (a third case the paper
  does not list).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from armlab.errors import InputError
from armlab.trajectory.profiles import trapezoid_peak_speed, trapezoid_ramp_length

__all__ = ["StepPlan", "trapezoid_steps"]


@dataclass
class StepPlan:
    """Per-period step lengths of a trapezoidal move (SHU controller paper, table 1).

    Attributes
    ----------
    lengths : ndarray (n_steps,)
        Length of each step, in the unit of ``length`` (sums to ``length``).
    phases : ndarray (n_steps,) of str
        ``"acc"``, ``"cruise"``, ``"dec"`` or ``"extra"`` (the left-over step).
    length : float
        Total length ``L``.
    period_s : float
        Interpolation period ``T`` in [s].
    v_peak : float
        Cruise (or triangle peak) speed ``V`` in [unit/s].
    a_acc, a_dec : float
        Effective acceleration and deceleration ``a1', a2'`` used in the formulas
        (``<=`` the requested ones).
    n_acc, n_cruise, n_dec : int
        ``n1, n3, n2`` of the table.
    leftover : float
        The remainder ``dL`` inserted as one extra step (0 if none).
    leftover_index : int or None
        Index of the extra step in ``lengths``.
    cruise : bool
        False for a short move (no cruise phase).
    """

    lengths: np.ndarray
    phases: np.ndarray
    length: float
    period_s: float
    v_peak: float
    a_acc: float
    a_dec: float
    n_acc: int
    n_cruise: int
    n_dec: int
    leftover: float
    leftover_index: int | None
    cruise: bool

    @property
    def n_steps(self) -> int:
        return int(self.lengths.size)

    @property
    def duration(self) -> float:
        """``n_steps * T`` in [s]."""
        return self.n_steps * self.period_s

    @property
    def positions(self) -> np.ndarray:
        """Cumulative position after each step, ``(n_steps + 1,)`` starting at 0."""
        return np.concatenate([[0.0], np.cumsum(self.lengths)])

    @property
    def speeds(self) -> np.ndarray:
        """Mean speed of each step, ``lengths / T``."""
        return self.lengths / self.period_s

    def to_dict(self) -> dict:
        return {
            "length": self.length,
            "period_s": self.period_s,
            "v_peak": self.v_peak,
            "a_acc": self.a_acc,
            "a_dec": self.a_dec,
            "n_acc": self.n_acc,
            "n_cruise": self.n_cruise,
            "n_dec": self.n_dec,
            "leftover": self.leftover,
            "leftover_index": self.leftover_index,
            "cruise": self.cruise,
            "n_steps": self.n_steps,
        }


def _positive(x, name: str) -> float:
    x = float(x)
    if not math.isfinite(x) or x <= 0:
        raise InputError(f"trapezoid_steps: {name} must be a finite number > 0, not {x!r}")
    return x


def trapezoid_steps(length: float, v: float, a_acc: float, a_dec: float, period: float) -> StepPlan:
    """Per-step lengths of a trapezoidal move, SHU controller paper, table 1.

    Parameters
    ----------
    length : float
        Path length ``L`` >= 0 (a line in [m], an arc angle in [rad], ...).
    v : float
        Cruise speed ``V`` > 0 in [unit/s].
    a_acc, a_dec : float
        Acceleration ``a1`` and deceleration ``a2`` > 0 in [unit/s^2] (may differ).
    period : float
        Interpolation period ``T`` > 0 in [s].

    Returns
    -------
    StepPlan
        ``lengths`` with ``sum(lengths) == L`` (to rounding), steps of the acceleration phase
        ``(2k - 1) a1' T^2 / 2``, cruise ``V T``, deceleration ``V T - (2k - 1) a2' T^2 / 2``,
        plus at most one left-over step. Consecutive steps differ by at most ``a_i' T^2``
        (the discrete acceleration never exceeds ``a_acc``/``a_dec``).

    Notes
    -----
    See the module docstring for the choices where the paper is silent (whole step counts,
    short moves, a remainder smaller than the last step). ``L = 0`` gives no steps.
    """
    L = float(length)
    if not math.isfinite(L) or L < 0:
        raise InputError(f"trapezoid_steps: length must be finite and >= 0, not {length!r}")
    V = _positive(v, "v")
    a1 = _positive(a_acc, "a_acc")
    a2 = _positive(a_dec, "a_dec")
    T = _positive(period, "period")
    if L == 0:
        empty = np.zeros(0)
        return StepPlan(
            empty, np.zeros(0, dtype="<U6"), 0.0, T, 0.0, a1, a2, 0, 0, 0, 0.0, None, False
        )
    # S1 + S2 = V^2 / (2 a1) + V^2 / (2 a2) <= L: a cruise; else the triangle's peak
    vp = float(trapezoid_peak_speed(L, V, a1, a2))
    cruise = L >= float(trapezoid_ramp_length(V, a1, a2))
    n1 = max(1, math.ceil(vp / (a1 * T) - 1e-9))
    n2 = max(1, math.ceil(vp / (a2 * T) - 1e-9))
    if vp * T * (n1 + n2) / 2 > L:  # the rounded ramps overshoot: lower the peak
        vp = 2 * L / ((n1 + n2) * T)
        cruise = False
    a1e, a2e = vp / (n1 * T), vp / (n2 * T)
    k1 = np.arange(1, n1 + 1)
    k2 = np.arange(1, n2 + 1)
    acc = (2 * k1 - 1) * a1e * T * T / 2
    dec = vp * T - (2 * k2 - 1) * a2e * T * T / 2
    S3 = L - acc.sum() - dec.sum()
    step = vp * T
    n3 = max(0, math.floor(S3 / step + 1e-12))
    dL = S3 - n3 * step
    if dL < 1e-12 * max(L, step):
        dL = 0.0
    if n3 > 0 and not cruise:
        cruise = True
    lengths = [acc, np.full(n3, step)]
    phases = ["acc"] * n1 + ["cruise"] * n3
    leftover_index = None
    if dL > 0:
        # seed: (1) before deceleration step 1, (2) between steps k-1 and k; (3) after the last
        pos = int(np.searchsorted(-dec, -dL, side="left"))  # first k with dec[k] <= dL
        dec_list = list(dec)
        dec_list.insert(pos, dL)
        dec_phases = ["dec"] * n2
        dec_phases.insert(pos, "extra")
        leftover_index = n1 + n3 + pos
        lengths.append(np.array(dec_list))
        phases += dec_phases
    else:
        lengths.append(dec)
        phases += ["dec"] * n2
    out = np.concatenate(lengths)
    return StepPlan(
        out, np.array(phases), L, T, vp, a1e, a2e, n1, n3, n2, float(dL), leftover_index, cruise
    )
