"""Time-synchronised rest-to-rest double S profiles of many problems at once, closed form
(:func:`synchronised_scurves`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from armlab.errors import InputError
from armlab.trajectory.profiles.motion import MotionProfile, rest_profile
from armlab.trajectory.profiles.rest_to_rest import _double_s_phases
from armlab.trajectory.profiles.timing import (
    _floats,
    double_s_min_times,
    double_s_peak_speed,
    double_s_ramp,
    double_s_speed_for_duration,
)

__all__ = ["SCurveBatch", "synchronised_scurves"]


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
    t_min = double_s_min_times(L, v, a, j, peak=peak)
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
