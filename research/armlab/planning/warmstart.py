"""Warm starts for the trajectory optimiser: time-synchronised S-curves on the node grid.

The classical plan the optimiser starts from is, per segment, every joint's symmetric
rest-to-rest double S, synchronised to the slowest joint (Jiang 1987, eq. 1-5, with the timing
of Biagiotti & Melchiorri §3.4; ``a = inf`` or ``j = inf`` give the jerk-only and trapezoidal
special cases). That timing is :func:`armlab.trajectory.profiles.synchronised_profiles`; what is
specific to the warm start lives here: the node grid that holds the profiles' switching
instants (:func:`phase_grid`), their samples on it (:func:`sample_profiles`), and the refit
that makes the warm start an exact solution of the optimiser's integration equations
(:func:`fit_piecewise`, :func:`integrate_piecewise`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from armlab.trajectory.profiles import MotionProfile

__all__ = [
    "sample_profiles",
    "phase_grid",
    "fit_piecewise",
    "integrate_piecewise",
]


def sample_profiles(
    profiles: Sequence[MotionProfile], signs, times
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position offsets, velocities, accelerations ``(n_times, n_joints)`` of the profiles.

    Parameters
    ----------
    profiles : sequence of MotionProfile (n_joints,)
        One rest-to-rest profile per joint (from
        :func:`~armlab.trajectory.profiles.synchronised_profiles`).
    signs : array (n_joints,)
        Direction of each joint's move (+1 or -1).
    times : array (n_times,)
        In [s].
    """
    times = np.asarray(times, float)
    signs = np.asarray(signs, float)
    q = np.zeros((times.size, len(profiles)))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for i, prof in enumerate(profiles):
        s, sd, sdd, _ = prof.evaluate(times)
        q[:, i], qd[:, i], qdd[:, i] = signs[i] * s, signs[i] * sd, signs[i] * sdd
    return q, qd, qdd


def phase_grid(
    profiles: Sequence[MotionProfile],
    T: float,
    n_intervals: int,
    h_min: float = 0.0,
    joints=None,
) -> np.ndarray:
    """Node times ``(n_intervals + 1,)`` on ``[0, T]`` holding the switching instants of some
    profiles.

    The phase boundaries (:attr:`MotionProfile.corners`) of the ``joints`` (default all; the
    first one's are kept longest) are kept (merged where closer than ``h_min`` [s]; thinned if
    there are more than ``n_intervals``), then the longest interval is halved until there are
    ``n_intervals`` — so those joints' S-curves are exact piecewise polynomials on the grid and
    no interval is much longer than the others.
    """
    if joints is None:
        joints = range(len(profiles))
    joints = list(joints)
    pts = [0.0, float(T)]
    first = set()
    for rank, i in enumerate(joints):
        t = profiles[i].corners
        pts += t.tolist()
        if rank == 0:
            first = set(t.tolist())
    # (a few dozen points: Python floats, the same arithmetic as numpy's, without the
    # per-call overhead of np.delete / np.insert)
    grid = sorted(set(pts))
    while len(grid) > 2:  # merge points closer than h_min
        d = [b - a for a, b in zip(grid[:-1], grid[1:], strict=True)]
        k = min(range(len(d)), key=d.__getitem__)  # the first smallest, as np.argmin
        if d[k] >= max(h_min, 1e-12):
            break
        del grid[k + 1 if k + 1 < len(grid) - 1 else k]
    while len(grid) - 1 > n_intervals:
        # drop the point whose neighbours are closest, sparing the first joint's switches
        span = [c - a for a, c in zip(grid[:-2], grid[2:], strict=True)]
        spare = [x in first for x in grid[1:-1]]
        if not all(spare):
            span = [math.inf if sp else x for x, sp in zip(span, spare, strict=True)]
        del grid[1 + min(range(len(span)), key=span.__getitem__)]
    while len(grid) - 1 < n_intervals:  # halve the longest interval (the first of equals)
        d = [b - a for a, b in zip(grid[:-1], grid[1:], strict=True)]
        k = max(range(len(d)), key=d.__getitem__)
        grid.insert(k + 1, 0.5 * (grid[k] + grid[k + 1]))
    return np.array(grid, dtype=float)


def fit_piecewise(h, u_ref, target, mode: str = "jerk", start=None) -> np.ndarray:
    """Piecewise-constant inputs closest to ``u_ref`` that reach ``target`` from a start state.

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
        End state relative to the start position (speeds and accelerations absolute).
    start : (qd0, qdd0), optional
        Start speeds [rad/s] and accelerations [rad/s^2] (n_joints,) each (default rest; the
        acceleration is not used in ``"acceleration"`` mode). Their free motion over the grid
        (``qd0 T + qdd0 T^2/2``, ...) is taken off the target.
    """
    h = np.asarray(h, float)
    R = np.concatenate([np.cumsum(h[::-1])[::-1][1:], [0.0]])  # time left after interval k
    if mode == "jerk":
        Phi = np.vstack([h**3 / 6 + h**2 / 2 * R + h * R**2 / 2, h**2 / 2 + h * R, h])
    else:
        Phi = np.vstack([h**2 / 2 + h * R, h])
    Winv = 1.0 / h
    G = (Phi * Winv) @ Phi.T
    target = np.asarray(target, float)
    if start is not None:
        v0, a0 = (np.asarray(x, float) for x in start)
        T = float(h.sum())
        if mode == "jerk":
            free = np.vstack([v0 * T + a0 * T**2 / 2, v0 + a0 * T, a0])
        else:
            free = np.vstack([v0 * T, v0])
        target = target - free
    r = target - Phi @ u_ref
    return u_ref + (Winv[:, None] * Phi.T) @ np.linalg.solve(G, r)


def integrate_piecewise(
    h, u, x0, mode: str = "jerk", start=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node states ``q, qd, qdd`` (each (N+1, n)) of piecewise-constant jerk (or acceleration)
    from position ``x0`` and the start speeds and accelerations ``start = (qd0, qdd0)``
    (default rest; in ``"acceleration"`` mode ``qdd`` at a node is the input that follows it).

    The exact integration over each interval (jerk mode; acceleration mode drops ``qdd``)::

        q_{k+1}   = q_k + h_k qd_k + h_k^2/2 qdd_k + h_k^3/6 u_k
        qd_{k+1}  = qd_k + h_k qdd_k + h_k^2/2 u_k
        qdd_{k+1} = qdd_k + h_k u_k

    evaluated as running sums (:func:`_running_sum`): the terms of every interval in the order
    above, added one after the other -- the same floating-point operations as a loop over the
    intervals, without one.
    """
    h = np.asarray(h, float)
    u = np.asarray(u, float)
    N, n = u.shape
    v0, a0 = (np.zeros(n), np.zeros(n)) if start is None else start
    hc = h[:, None]
    h2 = _powers(h, 2)[:, None] / 2  # as the loop's h_k**2 / 2
    if mode == "jerk":
        a = _running_sum(a0, hc * u)
        v = _running_sum(v0, hc * a[:-1], h2 * u)
        q = _running_sum(x0, hc * v[:-1], h2 * a[:-1], _powers(h, 3)[:, None] / 6 * u)
        return q, v, a
    v = _running_sum(v0, hc * u)
    q = _running_sum(x0, hc * v[:-1], h2 * u)
    a = np.vstack([u[:1], u])  # the input that follows each node (the last: the last input)
    return q, v, a


def _powers(h: np.ndarray, p: int) -> np.ndarray:
    """``h_k ** p`` of every element, each a float's own power (as ``float(h_k) ** p``)."""
    return np.array([x**p for x in h.tolist()], dtype=float).reshape(h.shape)


def _running_sum(x0, *terms: np.ndarray) -> np.ndarray:
    """``(N + 1, n)``: ``x0`` then ``x_{k+1} = ((x_k + t1_k) + t2_k) + ...`` for the terms
    ``(N, n)`` each, left to right (``np.add.accumulate`` adds in sequence, so every value is
    the same float a loop would give)."""
    N, n = terms[0].shape
    m = len(terms)
    seq = np.empty((1 + m * N, n))
    seq[0] = x0
    for i, t in enumerate(terms):
        seq[1 + i :: m] = t
    return np.add.accumulate(seq, axis=0)[::m]
