"""Timing primitives of rest-to-rest trapezoids and double S profiles (vectorised): the one
implementation of that timing (Biagiotti & Melchiorri §3.2, §3.4; SHU controller paper, table 1)."""

from __future__ import annotations

from typing import Any

import numpy as np

from armlab.trajectory.profiles.ops import NP

__all__ = [
    "trapezoid_ramp_length",
    "trapezoid_peak_speed",
    "trapezoid_min_times",
    "trapezoid_speed_for_duration",
    "double_s_ramp",
    "double_s_peak_speed",
    "double_s_min_times",
    "double_s_speed_for_duration",
]


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


# ---------------------------------------------------------------------- double S kernels
# The double S timing below is written once, as kernels on a _DoubleSLimits (the limits and
# the quantities that depend on them alone, computed once): the public primitives build one
# per call (their arguments broadcast to one shape by _floats); synchronised_scurves builds one
# per batch, at the batch's full shape (a numpy operation on equal shapes costs less than one
# that broadcasts, on a single small problem more than the arithmetic), and calls the kernels
# under one errstate. Each kernel is one path: the special limits fall out of the same
# expressions (``j = inf``, the trapezoid: ``v / j = 0`` and ``aj = 0``; ``a = inf``, the
# jerk-only ramp: no plateau), except where the trapezoid has a closed form of its own, which
# replaces the values of its joints only where there are any (``finite``: none). The kernels
# are written against a backend (``k.ops``, :mod:`.ops`): numpy arrays here, and CasADi SX
# columns in the graph of one problem (:mod:`.graph`; finite jerks only, so the trapezoid
# branches, numpy-only, never run there).


#: the trapezoid mask of limits whose jerks are all finite (never read: ``traps()`` is False)
_NONE = np.zeros(0, bool)


def _flat(*xs) -> tuple[tuple[int, ...], list[np.ndarray]]:
    """The arguments broadcast (:func:`_floats`) and raveled, with their common shape: the
    kernels select in place, which needs arrays, not the scalars a 0-d operation returns."""
    arrs = _floats(*xs)
    return arrs[0].shape, [x.reshape(-1) for x in arrs]


def _given(x, shape: tuple[int, ...]) -> np.ndarray:
    """A caller's precomputed ``peak`` / ``t_min`` of the arguments' ``shape``, raveled."""
    return np.broadcast_to(np.asarray(x, float), shape).reshape(-1)


class _DoubleSLimits:
    """``a``, ``j``, ``a / j`` (``aj_raw``; ``aj``: 0 for ``j = inf``), ``a^2``, ``a^2 / j``,
    ``a^2 / j^2``, ``sqrt(j)``; ``finite``: every ``j`` finite (no trapezoid); ``trap``:
    ``j = inf`` (an empty mask when ``finite``); ``ops``: the backend (:mod:`.ops`; the SX
    graph is built for finite jerks only)."""

    __slots__ = ("a", "j", "aj_raw", "aj", "a2", "a2j", "a2jj", "sj", "finite", "trap", "ops")

    def __init__(self, a, j, finite: bool | None = None, ops=NP):
        self.a, self.j, self.ops = a, j, ops
        if finite is None:
            finite = ops.symbolic or bool(np.isfinite(j).all())
        self.finite = finite
        self.trap = _NONE if finite else np.isinf(j)
        self.aj_raw = aj = a / j
        self.aj = aj if finite else np.where(self.trap, 0.0, aj)  # a = j = inf: inf / inf
        self.a2 = a * a
        self.a2j = self.a2 / j
        self.a2jj = self.a2 / (j * j)
        self.sj = ops.sqrt(j)

    def traps(self) -> bool:
        """Some joint is a trapezoid (``j = inf``)."""
        return not self.finite and bool(self.trap.any())


def _ds_ramp(v, k: _DoubleSLimits) -> tuple[Any, Any]:
    """:func:`double_s_ramp` on a :class:`_DoubleSLimits` (errors ignored by the caller), for
    ``v >= 0``: the plateau ``(a / j, a / j + v / a)`` where ``v j >= a^2``, else ``(sqrt(v /
    j), 2 sqrt(v / j))`` -- ``j = inf`` gives the trapezoid's ``(0, v / a)``, ``a = inf`` the
    jerk-only ramp, ``v = 0`` ``(0, 0)``."""
    ops = k.ops
    plateau = v * k.j >= k.a2
    tj = ops.select(plateau, k.aj, ops.sqrt(v / k.j))
    ta = ops.select(plateau, tj + v / k.a, 2 * tj)
    return tj, ta


def _ds_peak(L, v, k: _DoubleSLimits) -> Any:
    """:func:`double_s_peak_speed` on a :class:`_DoubleSLimits`."""
    ops, a = k.ops, k.a
    plateau = a * (ops.sqrt(k.a2jj + 4 * L / a) - k.aj_raw) / 2
    vp = ops.select(plateau >= k.a2j, plateau, (L * k.sj / 2) ** (2 / 3))
    vp = ops.fmin(vp, v)
    if k.traps():
        return np.where(k.trap, trapezoid_peak_speed(L, v, a), vp)
    return vp


def _ds_min_times(L, v, k: _DoubleSLimits, vp, moving) -> Any:
    """:func:`double_s_min_times` on a :class:`_DoubleSLimits`, ``vp`` the peak speeds,
    ``moving`` ``L > 0`` (``L / vp`` is ``0 / 0`` at rest: in the branch not taken)."""
    T = k.ops.where(moving, L / vp + _ds_ramp(vp, k)[1], 0.0)
    if k.traps():
        return np.where(k.trap, trapezoid_min_times(L, v, k.a), T)
    return T


def _ds_speed_for_duration(L, T, v, k: _DoubleSLimits, v_hi, t_min, moving) -> Any:
    """:func:`double_s_speed_for_duration` on a :class:`_DoubleSLimits`: ``v_hi``, ``t_min``
    the peak speeds and shortest times, ``moving`` ``L > 0``."""
    ops, a, j = k.ops, k.a, k.j
    b = T - k.aj
    L2 = 2 * L
    disc = b * b - (L2 + L2) / a  # 4 L / a: doubling is exact
    va = L2 / (b + ops.sqrt(ops.fmax(disc, 0.0)))
    # T = 0 only where no joint moves (then 'moving' masks the result)
    phi = 2 * ops.asin(ops.sqrt(ops.fmin(27 * L / (j * T**3), 1.0)))
    u0 = T / 6 + T / 3 * ops.cos(phi / 3)
    sv = 2 * T / 3 * ops.sin(phi / 6) ** 2
    u = (sv + ops.sqrt(sv * sv + L2 / (j * u0))) / 2
    plateau = ops.and_(ops.and_(disc >= 0, b > 0), va * j >= k.a2)  # j = inf: always
    vT = ops.select(plateau, va, j * u * u)
    vT = ops.fmin(vT, v_hi)
    vT = ops.select(T <= t_min, v_hi, vT)
    if k.traps():  # the trapezoid's own closed form (a = inf: v = L / T)
        vT = np.where(k.trap, trapezoid_speed_for_duration(L, T, a, a, v), vT)
    return ops.where(moving, vT, 0.0)


def double_s_ramp(v, a_max, j_max) -> tuple[np.ndarray, np.ndarray]:
    """``(Tj, Ta)`` [s] of a symmetric double S accelerating from rest to ``v`` (arrays broadcast).

    Biagiotti & Melchiorri §3.4: ``Tj = a / j``, ``Ta = Tj + v / a`` if ``v j >= a^2`` (the
    acceleration limit is reached); else ``Tj = sqrt(v / j)``, ``Ta = 2 Tj``. ``j = inf`` gives
    the trapezoid's ``(0, v / a)``, ``a = inf`` the jerk-only ramp; ``v = 0`` gives ``(0, 0)``.
    """
    shape, (v, a, j) = _flat(v, a_max, j_max)
    v = np.where(v > 0, v, 0.0)  # not moving: (0, 0)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        tj, ta = _ds_ramp(v, _DoubleSLimits(a, j))
    return tj.reshape(shape), ta.reshape(shape)


def double_s_peak_speed(length, v_max, a_max, j_max) -> np.ndarray:
    """Peak speed [unit/s] of the shortest symmetric rest-to-rest double S over ``length`` >= 0.

    The largest ``v <= v_max`` whose ramps fit, ``v Ta(v) <= L`` (Biagiotti & Melchiorri §3.4):
    ``v^2 / a + v a / j = L`` where the acceleration limit is reached (``v >= a^2 / j``), else
    ``2 v sqrt(v / j) = L``, i.e. ``v = (L sqrt(j) / 2)^(2/3)``. ``j = inf`` is the trapezoid
    (:func:`trapezoid_peak_speed`). Arrays broadcast; ``a`` and ``j`` may be ``inf``.
    """
    shape, (L, v, a, j) = _flat(length, v_max, a_max, j_max)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return _ds_peak(L, v, _DoubleSLimits(a, j)).reshape(shape)


def double_s_min_times(length, v_max, a_max, j_max, *, peak=None) -> np.ndarray:
    """Shortest durations [s] of symmetric rest-to-rest double S profiles (arrays broadcast).

    ``T = L / v_p + Ta(v_p)`` with ``v_p`` from :func:`double_s_peak_speed` (Biagiotti &
    Melchiorri §3.4; ``peak`` if the caller has it); the trapezoid's
    :func:`trapezoid_min_times` where ``j = inf``; ``0`` for ``L <= 0``. ``inf`` switches a
    limit off (not all three).
    """
    shape, (L, v, a, j) = _flat(length, v_max, a_max, j_max)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        k = _DoubleSLimits(a, j)
        vp = _ds_peak(L, v, k) if peak is None else _given(peak, shape)
        return _ds_min_times(L, v, k, vp, L > 0).reshape(shape)


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
    shape, (L, T, a, j, v) = _flat(length, duration, a_max, j_max, v_max)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        k = _DoubleSLimits(a, j)
        v_hi = _ds_peak(L, v, k) if peak is None else _given(peak, shape)
        moving = L > 0
        t_min = _ds_min_times(L, v, k, v_hi, moving) if t_min is None else _given(t_min, shape)
        return _ds_speed_for_duration(L, T, v, k, v_hi, t_min, moving).reshape(shape)
