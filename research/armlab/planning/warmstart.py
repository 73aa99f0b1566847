"""Warm starts for the trajectory optimiser: time-synchronised rest-to-rest S-curves.

One joint moving a distance ``D`` from rest to rest under ``|qd| <= v``, ``|qdd| <= a``,
``|qddd| <= j`` follows the symmetric 7-segment S-curve (jerk ``+j, 0, -j`` up to the peak
velocity ``vp``, cruise, mirror image down). With ``t_acc(vp)`` the time to reach ``vp``::

    t_acc = vp / a + a / j          if vp >= a^2 / j    (acceleration plateau)
    t_acc = 2 sqrt(vp / j)          otherwise            (triangular acceleration)

its duration is ``T(vp) = D / vp + t_acc(vp)``, decreasing in ``vp`` up to the largest peak
velocity that still fits (``vp t_acc(vp) <= D`` and ``vp <= v``). ``a = inf`` or ``j = inf``
give the jerk-only and trapezoidal special cases. Synchronisation (Jiang 1987,
eq. 1-5, "time-synchronised PTP"): every joint of a segment gets the slowest joint's duration by
lowering its own ``vp`` until ``T(vp)`` equals it — the classical plan the optimiser starts
from.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "scurve_min_duration",
    "sync_scurves",
    "scurve_phases",
    "eval_scurves",
    "phase_grid",
    "fit_piecewise",
    "integrate_piecewise",
]


def _t_acc(vp, a, j):
    vp = np.asarray(vp, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        plateau = vp / a + np.where(np.isinf(j), 0.0, a / j)
        tri = 2.0 * np.sqrt(vp / j)
        use_plateau = np.isinf(j) | (np.isfinite(a) & (vp * j >= a * a))
        out = np.where(use_plateau, plateau, tri)
    return np.where(vp > 0, out, 0.0)


def _vp_max(D, v, a, j, iters: int = 80):
    """Largest peak velocity with ``vp t_acc(vp) <= D`` and ``vp <= v``, by bisection."""
    D = np.asarray(D, float)
    hi = np.where(np.isfinite(v), v, 1.0)
    # grow the bracket where v is infinite
    for _ in range(200):
        grow = np.isinf(v) & (hi * _t_acc(hi, a, j) < D)
        if not np.any(grow):
            break
        hi = np.where(grow, hi * 4.0, hi)
    fits = hi * _t_acc(hi, a, j) <= D
    lo = np.zeros_like(D)
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        ok = mid * _t_acc(mid, a, j) <= D
        lo = np.where(ok, mid, lo)
        hi = np.where(ok, hi, mid)
    return np.where(fits, np.where(np.isfinite(v), v, hi), lo)


def scurve_min_duration(D, v, a, j) -> np.ndarray:
    """Minimum rest-to-rest duration in [s] of each joint (arrays broadcast).

    Parameters
    ----------
    D : array
        Distances ``|q_goal - q_start|`` in [rad].
    v, a, j : array
        Limits in [rad/s], [rad/s^2], [rad/s^3]; ``inf`` where off (not all three).
    """
    D = np.abs(np.asarray(D, float))
    v, a, j = (np.broadcast_to(np.asarray(x, float), D.shape) for x in (v, a, j))
    vp = _vp_max(D, v, a, j)
    with np.errstate(divide="ignore", invalid="ignore"):
        T = np.where(D > 0, D / vp + _t_acc(vp, a, j), 0.0)
    return T


def sync_scurves(D, T, v, a, j, iters: int = 80) -> np.ndarray:
    """Peak velocities ``vp`` (signed like ``D``) giving every joint the duration ``T`` [s].

    ``T`` must be at least :func:`scurve_min_duration` of every joint.
    """
    Ds = np.asarray(D, float)
    D = np.abs(Ds)
    v, a, j = (np.broadcast_to(np.asarray(x, float), D.shape) for x in (v, a, j))
    hi = _vp_max(D, v, a, j)
    lo = np.zeros_like(D)
    for _ in range(iters):  # T(vp) decreases in vp on (0, vp_max]
        mid = 0.5 * (lo + hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            Tm = D / mid + _t_acc(mid, a, j)
        slow = Tm > T  # too slow: raise vp
        lo = np.where(slow, mid, lo)
        hi = np.where(slow, hi, mid)
    return np.sign(Ds) * hi


def scurve_phases(D, vp, T, a, j) -> list[list[tuple[float, float, float]]]:
    """Per joint, the phases ``(duration [s], start acceleration, jerk)`` of its S-curve.

    Signed like ``D``; zero-length phases dropped; an infinite jerk limit gives acceleration
    jumps (the next phase's start acceleration differs from the previous end).
    """
    D = np.asarray(D, float)
    out = []
    for i in range(D.size):
        if D[i] == 0 or vp[i] == 0:
            out.append([(float(T), 0.0, 0.0)])
            continue
        sgn, p = float(np.sign(D[i])), abs(float(vp[i]))
        ai, ji = float(a[i]), float(j[i])
        if np.isinf(ji):
            tj, ta, apk = 0.0, p / ai, ai
        elif np.isfinite(ai) and p * ji >= ai * ai:
            tj, ta = ai / ji, p / ai - ai / ji
            apk = ai
        else:
            tj, ta = np.sqrt(p / ji), 0.0
            apk = ji * tj
        tv = max(T - 2.0 * (2.0 * tj + ta), 0.0)
        jj = 0.0 if np.isinf(ji) else ji
        phases = [
            (tj, 0.0, jj),
            (ta, apk, 0.0),
            (tj, apk, -jj),
            (tv, 0.0, 0.0),
            (tj, 0.0, -jj),
            (ta, -apk, 0.0),
            (tj, -apk, jj),
        ]
        out.append([(float(d), sgn * a0, sgn * jk) for d, a0, jk in phases if d > 0])
    return out


def eval_scurves(D, vp, T, a, j, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions offsets, velocities, accelerations ``(n_times, n_joints)`` of the S-curves.

    Parameters
    ----------
    D, vp : array (n_joints,)
        Signed distances [rad] and peak velocities [rad/s] (from :func:`sync_scurves`).
    T : float
        Common duration [s].
    a, j : array (n_joints,)
        Acceleration and jerk limits (``inf`` where off).
    times : array (n_times,)
        In [0, T].
    """
    D = np.asarray(D, float)
    n = D.size
    times = np.asarray(times, float)
    q = np.zeros((times.size, n))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for i, phases in enumerate(scurve_phases(D, vp, T, a, j)):
        if D[i] == 0:
            continue
        t0, q0, v0 = 0.0, 0.0, 0.0
        for dur, a0, jk in phases:
            m = (times >= t0) & (times <= t0 + dur)
            tau = times[m] - t0
            q[m, i] = q0 + v0 * tau + a0 * tau**2 / 2 + jk * tau**3 / 6
            qd[m, i] = v0 + a0 * tau + jk * tau**2 / 2
            qdd[m, i] = a0 + jk * tau
            q0 += v0 * dur + a0 * dur**2 / 2 + jk * dur**3 / 6
            v0 += a0 * dur + jk * dur**2 / 2
            t0 += dur
        m = times > t0
        q[m, i] = q0
        # scale the (tiny) end error of the bisection onto the exact distance
        if q0 != 0:
            q[:, i] *= D[i] / q0
    return q, qd, qdd


def phase_grid(D, vp, T, a, j, n_intervals: int, h_min: float = 0.0, joints=None) -> np.ndarray:
    """Node times ``(n_intervals + 1,)`` holding the switching instants of some S-curves.

    The switching instants of the ``joints`` (default all; the first one's are kept longest)
    are kept (merged where closer than ``h_min``; thinned if there are more than
    ``n_intervals``), then the longest interval is
    halved until there are ``n_intervals`` — so those joints' S-curves are exact piecewise
    polynomials on the grid and no interval is much longer than the others.
    """
    phases = scurve_phases(D, vp, T, a, j)
    if joints is None:
        joints = range(len(phases))
    joints = list(joints)
    pts = [0.0, float(T)]
    first = set()
    for rank, i in enumerate(joints):
        t = np.cumsum([d for d, _, _ in phases[i]])[:-1]
        pts += list(t)
        if rank == 0:
            first = set(t.tolist())
    grid = np.unique(np.array(pts))
    while grid.size > 2:  # merge points closer than h_min
        d = np.diff(grid)
        k = int(np.argmin(d))
        if d[k] >= max(h_min, 1e-12):
            break
        grid = np.delete(grid, k + 1 if k + 1 < grid.size - 1 else k)
    while grid.size - 1 > n_intervals:
        # drop the point whose neighbours are closest, sparing the first joint's switches
        span = grid[2:] - grid[:-2]
        spare = np.array([x in first for x in grid[1:-1]])
        if not np.all(spare):
            span = np.where(spare, np.inf, span)
        grid = np.delete(grid, 1 + int(np.argmin(span)))
    while grid.size - 1 < n_intervals:
        k = int(np.argmax(np.diff(grid)))
        grid = np.insert(grid, k + 1, 0.5 * (grid[k] + grid[k + 1]))
    return grid


def fit_piecewise(h, u_ref, target, mode: str = "jerk") -> np.ndarray:
    """Piecewise-constant inputs closest to ``u_ref`` that reach ``target`` from rest.

    Minimises ``sum_k h_k (u_k - u_ref,k)^2`` subject to the end state (``(q, qd, qdd)`` for
    ``mode="jerk"``, ``u`` the jerk; ``(q, qd)`` for ``"acceleration"``, ``u`` the acceleration)
    equal to ``target`` — a closed-form weighted minimum-norm correction, so a warm start is an
    exact solution of the optimiser's integration equations on any grid.

    Parameters
    ----------
    h : array (N,)
        Interval durations [s].
    u_ref : array (N, n_joints)
    target : array (3 or 2, n_joints)
        End state relative to the (resting) start state.
    """
    h = np.asarray(h, float)
    R = np.concatenate([np.cumsum(h[::-1])[::-1][1:], [0.0]])  # time left after interval k
    if mode == "jerk":
        Phi = np.vstack([h**3 / 6 + h**2 / 2 * R + h * R**2 / 2, h**2 / 2 + h * R, h])
    else:
        Phi = np.vstack([h**2 / 2 + h * R, h])
    Winv = 1.0 / h
    G = (Phi * Winv) @ Phi.T
    r = np.asarray(target, float) - Phi @ u_ref
    return u_ref + (Winv[:, None] * Phi.T) @ np.linalg.solve(G, r)


def integrate_piecewise(h, u, x0, mode: str = "jerk") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node states ``q, qd, qdd`` (each (N+1, n)) of piecewise-constant jerk (or acceleration)."""
    N, n = u.shape
    q = np.empty((N + 1, n))
    v = np.empty((N + 1, n))
    a = np.empty((N + 1, n))
    q[0], v[0] = x0, 0.0
    a[0] = 0.0
    for k in range(N):
        hk, uk = h[k], u[k]
        if mode == "jerk":
            q[k + 1] = q[k] + hk * v[k] + hk**2 / 2 * a[k] + hk**3 / 6 * uk
            v[k + 1] = v[k] + hk * a[k] + hk**2 / 2 * uk
            a[k + 1] = a[k] + hk * uk
        else:
            q[k + 1] = q[k] + hk * v[k] + hk**2 / 2 * uk
            v[k + 1] = v[k] + hk * uk
            a[k + 1] = uk
    if mode != "jerk":
        a[0] = u[0]
    return q, v, a
