"""The :class:`Trajectory`: the one currency between planners and consumers.

A trajectory is stored at its knots: times ``t`` (n_samples,) in [s] and joint positions ``q``,
velocities ``qd``, accelerations ``qdd`` (and jerks ``qddd`` where the planner defines them),
each ``(n_samples, n_joints)`` in [rad], [rad/s], [rad/s^2], [rad/s^3].

Evaluation between knots (:meth:`Trajectory.at`, :meth:`~Trajectory.sample`,
:meth:`~Trajectory.check_limits`)
------------------------------------------------------------------------------------------
Convention: the values at a knot are those of the piece that *starts* there (right limits):
where the acceleration steps (a trapezoid's corner) the knot carries the acceleration of the
phase that begins at it, where the jerk steps the jerk of that phase. The last knot carries
the end of the motion. On ``[t_k, t_k+1)``, with ``tau = t - t_k``, ``h = t_k+1 - t_k`` and
``s = tau / h``, every joint follows the Taylor polynomial of the left knot plus a closure
onto the right knot's position and velocity -- the values continuous at every knot -- and, for
a trajectory with jerks (whose acceleration is continuous), its acceleration (Biagiotti &
Melchiorri §2.1: polynomials fixed by boundary conditions)::

    q(t) = q_k + qd_k tau + qdd_k tau^2 / 2 + qddd_k tau^3 / 6 + K3 s^3 + K4 s^4 + K5 s^5

    d = q_k+1 - T(1),  e = h (qd_k+1 - T'(1) / h),  f = h^2 (qdd_k+1 - T''(1) / h^2)
    (T: the Taylor part, in s; the residuals of the knot data)
    without qddd (qddd_k = 0 above; quartic, onto q and qd):
        r = d - e / 3,                  K3 = e / 3 + 4 r,         K4 = -3 r,   K5 = 0
    with qddd (the acceleration is continuous; quintic, onto q, qd and qdd):
        e' = e - f / 2,  r = d - f / 6 - e' / 2,
        K3 = f / 6 + e' + 10 r,         K4 = -e' / 2 - 15 r,      K5 = 6 r

and ``qd``, ``qdd``, ``qddd`` are its derivatives. It is **exact** for every piecewise
polynomial whose breakpoints are knots -- constant acceleration (trapezoids), constant jerk
(S-curves, the optimiser's jerk mode), cubics (via points) without ``qddd``; quintics with
it -- since these satisfy the closure conditions themselves; it is continuous in position and
velocity for any other data (Cartesian and TOPP plans: a smooth interpolant). Each derivative
is the piece's own: nothing is interpolated across a step of the acceleration, and no rounding
noise is divided by a tiny interval -- the residuals are taken in order of derivative (each
basis polynomial leaves the lower residuals' conditions alone: ``s^3 / 6``, ``s^3 - s^4 / 2``,
``10 s^3 - 15 s^4 + 6 s^5``), and one within the rounding noise propagated from the knot data
(``_NOISE`` times each joint's largest values and time) is taken as zero, so a knot pair a
microsecond apart is evaluated by its exact Taylor polynomial and a position rounding is never
divided by ``h^2``. Times outside ``[t[0], t[-1]]`` are clamped; at a knot the stored values
are returned (the jerk of the piece that starts there).

Limits are checked where the evaluation can peak (:meth:`Trajectory.limit_samples`): at the
knots, at the left limits of every piece, at the interior extremes of position, velocity,
acceleration and jerk of each piece (roots of the next derivative: exact), on an optional
uniform grid, and for torques at interior points of each piece refined by parabolic
interpolation around every local peak (RNEA at each point).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from armlab.errors import InputError
from armlab.robot import rigid_body
from armlab.robot.limits import Limits
from armlab.trajectory.sampling import (
    REFINE_STEPS,
    TORQUE_GRID,
    LimitReport,
    LimitSamples,
    drop_noise,
    merge_rows,
    peak_vertices,
    sample_times,
    unit_roots,
)

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["Trajectory"]

#: relative rounding noise of knot data: a closure coefficient within this times the
#: magnitudes that enter it is taken as zero (module docstring)
_NOISE = 256 * np.finfo(float).eps


def _as_series(x, n: int, name: str, n_joints: int | None) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim == 1 and n_joints in (None, 1) and a.shape[0] == n:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] != n or (n_joints is not None and a.shape[1] != n_joints):
        want = f"({n}, {n_joints if n_joints is not None else 'n_joints'})"
        raise InputError(f"Trajectory {name} has shape {a.shape}, expected {want}")
    if not np.isfinite(a).all():
        bad = np.argwhere(~np.isfinite(a))[0]
        raise InputError(f"Trajectory {name} is not finite at sample {bad[0]}, joint {bad[1]}")
    return a


class Trajectory:
    """Sampled joint trajectory.

    Parameters
    ----------
    t : array (n_samples,)
        Strictly increasing sample times in [s] (shifted so that ``t[0]`` may be nonzero).
    q, qd, qdd : array (n_samples, n_joints)
        Positions [rad], velocities [rad/s], accelerations [rad/s^2].
    qddd : array (n_samples, n_joints), optional
        Jerks [rad/s^3] where the planner defines them.
    joint_names : list of str, optional
    method : str
        Which planner made it (reported in summaries).

    Attributes
    ----------
    report : LimitReport or None
        Set by planners that check feasibility on a fine grid.
    stats : dict
        Solver statistics (iterations, solve time, ...) set by optimisers.
    meta : dict
        Anything else a planner records (waypoints, profile, ...).
    """

    def __init__(self, t, q, qd, qdd, qddd=None, *, joint_names=None, method: str = ""):
        t = np.asarray(t, dtype=float).reshape(-1)
        if t.size < 1 or not np.isfinite(t).all():
            raise InputError("Trajectory t must be a non-empty finite (n_samples,) array")
        if t.size > 1 and not (t[1:] > t[:-1]).all():
            raise InputError("Trajectory t must be strictly increasing")
        n = t.size
        self.t = t
        self.q = _as_series(q, n, "q", None)
        nj = self.q.shape[1]
        self.qd = _as_series(qd, n, "qd", nj)
        self.qdd = _as_series(qdd, n, "qdd", nj)
        self.qddd = None if qddd is None else _as_series(qddd, n, "qddd", nj)
        if joint_names is not None and len(joint_names) != nj:
            raise InputError(f"Trajectory has {nj} joints but {len(joint_names)} joint names")
        self.joint_names = (
            list(joint_names) if joint_names is not None else [f"joint{i + 1}" for i in range(nj)]
        )
        self.method = method
        self.report: LimitReport | None = None
        self.stats: dict[str, Any] = {}
        self.meta: dict[str, Any] = {}

    @classmethod
    def _from_checked(
        cls,
        t: np.ndarray,
        q: np.ndarray,
        qd: np.ndarray,
        qdd: np.ndarray,
        qddd: np.ndarray | None,
        joint_names,
        method: str,
    ) -> Trajectory:
        """The :class:`Trajectory` of arrays a planner of this package built itself and knows
        to be valid, without the constructor's checks (a closed-form plan's knots: issue 26).

        The caller guarantees what the constructor would check: ``t`` a float64 array
        ``(n,)``, finite and strictly increasing; ``q``, ``qd``, ``qdd`` (and ``qddd`` unless
        None) float64 arrays ``(n, n_joints)``, finite; ``joint_names`` a sequence of
        ``n_joints`` names. The result is then the constructor's on the same arrays (tested);
        anything from outside the package goes through the constructor.
        """
        self = cls.__new__(cls)
        self.t, self.q, self.qd, self.qdd, self.qddd = t, q, qd, qdd, qddd
        self.joint_names = list(joint_names)
        self.method = method
        self.report = None
        self.stats = {}
        self.meta = {}
        return self

    # ------------------------------------------------------------------ facts
    @property
    def n_samples(self) -> int:
        return self.t.size

    @property
    def n_joints(self) -> int:
        return self.q.shape[1]

    @property
    def duration(self) -> float:
        """Duration in [s]."""
        return float(self.t[-1] - self.t[0])

    def __repr__(self) -> str:
        return (
            f"Trajectory(method={self.method!r}, duration={self.duration:.4g} s, "
            f"n_samples={self.n_samples}, n_joints={self.n_joints})"
        )

    # ------------------------------------------------------------------ evaluation
    def _pieces(self):
        """Per piece ``[t_k, t_k+1)`` (n_samples - 1, n_joints): ``h`` (n - 1, 1) in [s], the
        Taylor jerk ``j`` and the closure coefficients ``K3, K4, K5`` of the module docstring."""
        t = self.t
        h = np.diff(t)[:, None]
        q0, q1 = self.q[:-1], self.q[1:]
        v0, v1 = self.qd[:-1], self.qd[1:]
        a0 = self.qdd[:-1]
        j = self.qddd[:-1] if self.qddd is not None else np.zeros_like(q0)
        d = q1 - (q0 + h * (v0 + h * (a0 / 2 + h * j / 6)))
        e = h * (v1 - (v0 + h * (a0 + h * j / 2)))
        # rounding noise of the knot data: each joint's largest values (a planner's sums can
        # cancel: q = q0 + delta s), and the rounding of the times they were evaluated at
        t_abs = np.abs(t[1:])[:, None] + h
        # (each joint's maximum along a contiguous row: numpy's fast reduction)
        Q, V, A = (np.abs(x.T).copy().max(axis=1) for x in (self.q, self.qd, self.qdd))
        J = np.abs(j.T).copy().max(axis=1) if j.size else 0.0
        nd = _NOISE * (Q + V * t_abs + A * h * h + J * h**3)  # noise of d
        ne = _NOISE * h * (V + A * t_abs + J * h * h)  # noise of e
        if self.qddd is None:  # quartic closure onto the right knot's q and qd
            # e (s^3 / 3: the velocity) first, then what the position still misses
            # (4 s^3 - 3 s^4: no velocity); each within its noise is zero
            e = drop_noise(e, ne)
            r = drop_noise(d - e / 3, nd + ne / 3)
            return h, j, e / 3 + 4 * r, -3 * r, np.zeros_like(d)
        # quintic closure onto the right knot's q, qd and qdd (continuous with a jerk): the
        # acceleration residual (s^3 / 6), then the velocity's (s^3 - s^4 / 2: no acceleration),
        # then the position's (10 s^3 - 15 s^4 + 6 s^5: neither)
        nf = _NOISE * h * h * (A + J * t_abs)  # noise of f
        f = drop_noise(h * h * (self.qdd[1:] - (a0 + h * j)), nf)
        e = drop_noise(e - f / 2, ne + nf / 2)
        r = drop_noise(d - f / 6 - e / 2, nd + nf / 6 + (ne + nf / 2) / 2)
        return h, j, f / 6 + e + 10 * r, -e / 2 - 15 * r, 6 * r

    def _evaluate(
        self, k: np.ndarray, tau: np.ndarray, pieces, jerk: bool = True
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """(q, qd, qdd, qddd) of pieces ``k`` (m,) at ``tau`` (m,) [s] after their left knots
        (``qddd`` None unless ``jerk``).

        The polynomial of the module docstring in Horner form; what depends on the piece only
        (its knot values, ``a0 / 2`` and the closure coefficients times their integer
        factors) is computed once per piece and gathered in one ``np.take`` -- each value the
        same float as when computed per point."""
        tau = tau[:, None]
        h = np.take(pieces[0], k, axis=0)
        s = tau / h
        if self.qddd is None and not jerk:  # j = K5 = 0 (quartic): the same values, fewer terms
            q0, v0, a0, A2, K3, K4, K3_3, K4_4, K3_6, K4_12 = self._gather(k, pieces, False)
            q = q0 + tau * (v0 + tau * A2) + s**3 * (K3 + s * K4)
            qd = v0 + tau * a0 + s * s * (K3_3 + s * K4_4) / h
            qdd = a0 + s * (K3_6 + s * K4_12) / h**2
            return q, qd, qdd, None
        q0, v0, a0, A2, K3, K4, K3_3, K4_4, K3_6, K4_12, j, K5, K4_24 = self._gather(
            k, pieces, True
        )
        tj = tau * j
        q = q0 + tau * (v0 + tau * (A2 + tj / 6)) + s**3 * (K3 + s * (K4 + s * K5))
        qd = v0 + tau * (a0 + tj / 2) + s * s * (K3_3 + s * (K4_4 + 5 * s * K5)) / h
        qdd = a0 + tj + s * (K3_6 + s * (K4_12 + 20 * s * K5)) / h**2
        if not jerk:
            return q, qd, qdd, None
        qddd = j + (K3_6 + s * (K4_24 + 60 * s * K5)) / h**3
        return q, qd, qdd, qddd

    def _gather(self, k: np.ndarray, pieces, jerk: bool) -> np.ndarray:
        """Per piece ``k`` (m,): ``q0, v0, a0, a0 / 2, K3, K4, 3 K3, 4 K4, 6 K3, 12 K4`` and
        with ``jerk`` also ``j, K5, 24 K4``, stacked ``(c, m, n_joints)`` (each contiguous)."""
        m = self.n_samples - 1
        _, j, K3, K4, K5 = pieces
        a0 = self.qdd[:m]
        cols = [self.q[:m], self.qd[:m], a0, a0 / 2, K3, K4, 3 * K3, 4 * K4, 6 * K3, 12 * K4]
        if jerk:
            cols += [j, K5, 24 * K4]
        return np.take(np.stack(cols), k, axis=1)

    def at(self, times) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Evaluate (q, qd, qdd, qddd) at ``times`` (n,) in [s] from the piecewise definition
        (module docstring: the left knot's Taylor polynomial closed onto the right knot).

        Right-continuous: at a knot the values of the piece that starts there (the stored
        ones). Times outside ``[t[0], t[-1]]`` are clamped (the arm rests at its end points).
        Without ``qddd`` the jerk returned is that of the evaluation (0 for constant
        acceleration).
        """
        return self._at(times, self._pieces())

    def _at(self, times, pieces) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`at` with this trajectory's :meth:`_pieces` given (computed once by a caller
        that evaluates several times)."""
        times = np.clip(np.asarray(times, dtype=float).reshape(-1), self.t[0], self.t[-1])
        if self.n_samples == 1:
            z = np.zeros((times.size, self.n_joints))
            return np.repeat(self.q, times.size, 0), z, z.copy(), z.copy()
        k = np.clip(np.searchsorted(self.t, times, side="right") - 1, 0, self.n_samples - 2)
        q, qd, qdd, qddd = self._evaluate(k, times - self.t[k], pieces)
        assert qddd is not None
        end = times >= self.t[-1]  # the end of the motion: its stored values
        q[end], qd[end], qdd[end] = self.q[-1], self.qd[-1], self.qdd[-1]
        if self.qddd is not None:
            qddd[end] = self.qddd[-1]
        return q, qd, qdd, qddd

    def left_limits(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(q, qd, qdd, qddd) at ``t[1:]`` approached from the left (each piece at its end),
        (n_samples - 1, n_joints) each; q and qd equal the knots' up to rounding noise."""
        if self.n_samples == 1:
            z = np.zeros((0, self.n_joints))
            return z, z.copy(), z.copy(), z.copy()
        k = np.arange(self.n_samples - 1)
        q, qd, qdd, qddd = self._evaluate(k, np.diff(self.t), self._pieces())
        assert qddd is not None
        return q, qd, qdd, qddd

    def critical_times(self) -> np.ndarray:
        """Sorted times [s] strictly inside pieces where some joint's position, velocity,
        acceleration or (with ``qddd``) jerk has a stationary point: the roots of the next
        derivative of each piece's polynomial (module docstring), so that the evaluation's
        peaks are among the knots, the left limits and these times."""
        if self.n_samples == 1:
            return np.zeros(0)
        return self._critical_times(self._pieces())

    def _critical_times(self, pieces) -> np.ndarray:
        """:meth:`critical_times` with this trajectory's :meth:`_pieces` given."""
        h, j, K3, K4, K5 = pieces
        C1 = self.qd[:-1] * h
        C2 = self.qdd[:-1] * h * h / 2
        C3 = j * h**3 / 6 + K3
        polys = [
            [C1, 2 * C2, 3 * C3, 4 * K4, 5 * K5],  # velocity: position extremes
            [2 * C2, 6 * C3, 12 * K4, 20 * K5],  # acceleration: velocity extremes
            [6 * C3, 24 * K4, 60 * K5],  # jerk: acceleration extremes
        ]
        if self.qddd is not None:
            polys.append([24 * K4, 120 * K5])  # snap: jerk extremes
        row, s = unit_roots(*polys)
        piece = row // self.n_joints
        times = np.unique(self.t[piece] + s * h[piece, 0])
        return times[(times > self.t[0]) & (times < self.t[-1])]

    def limit_samples(self, dt: float | None = None, *, robot: Robot | None = None) -> LimitSamples:
        """The points where the evaluation can peak: every knot, every piece's left limit, the
        :meth:`critical_times`, a uniform grid of step ``dt`` [s] if given, and with ``robot``
        the torques (RNEA, :func:`armlab.robot.rigid_body.inverse_dynamics`) at those points,
        at the middle of every piece and at most ``duration / TORQUE_GRID`` apart inside a
        longer piece,
        refined by :data:`REFINE_STEPS` steps of successive
        parabolic interpolation around every local peak of ``|tau|`` of each joint inside a
        piece.

        Position, velocity, acceleration and jerk peaks are exact (up to root rounding);
        torque peaks are those of the refined samples.
        """
        n = self.n_samples
        if robot is not None:
            self._check_robot(robot)
        if n == 1:
            out = LimitSamples(self.t.copy(), self.q.copy(), self.qd.copy(), self.qdd.copy())
            out.qddd = None if self.qddd is None else self.qddd.copy()
            if robot is not None:
                out.tau = rigid_body.inverse_dynamics(robot, out.q, out.qd, out.qdd)
            return out
        pieces = self._pieces()  # once: every evaluation below reads them
        extra = [self._critical_times(pieces)]
        if dt is not None:
            extra.append(self.t[0] + sample_times(self.duration, dt))
        if robot is not None:  # the middle of every piece, and a piece longer than
            # duration / TORQUE_GRID cut into equal parts no longer than that: a peak inside a
            # long piece (a rise and fall between its middle and a knot) has points
            h = np.diff(self.t)
            extra.append(self.t[:-1] + h / 2)
            long = np.flatnonzero(h > 2 * self.duration / TORQUE_GRID)
            if long.size:
                parts = np.ceil(h[long] * TORQUE_GRID / self.duration).astype(int)
                k = np.repeat(long, parts - 1)
                i = np.arange(k.size) - np.repeat(np.cumsum(parts - 1) - (parts - 1), parts - 1)
                extra.append(self.t[k] + h[k] * (i + 1) / np.repeat(parts, parts - 1))
        times = np.unique(np.concatenate(extra))
        times = times[(times > self.t[0]) & (times < self.t[-1])]
        k_t = np.searchsorted(self.t, times, "right") - 1  # the piece of each: 0 .. n - 2
        inside = self.t[k_t] != times  # not at a knot (its values are below)
        times, k_t = times[inside], k_t[inside]
        jerk = self.qddd is not None  # without qddd: acceleration steps, no jerk defined
        # the left limits (each piece at its end: left_limits()) and the points inside, in
        # one evaluation
        left_ev = self._evaluate(
            np.concatenate([np.arange(n - 1), k_t]),
            np.concatenate([np.diff(self.t), times - self.t[k_t]]),
            pieces,
            jerk,
        )
        # the stored values (the evaluation at a knot returns them); with qddd, the jerk of
        # the piece that starts there
        own = (self.q, self.qd, self.qdd, None) if not jerk else self._at(self.t, pieces)
        # sorted by time; at a knot its left limit first, then its own value: knot i's own
        # row follows the i left limits and i own rows before it and the c_i inside points
        # before t_i; an inside point j of piece k follows 2 k + 1 knot rows and j points
        c = np.searchsorted(times, self.t)
        i = np.arange(n)
        rows = np.concatenate(
            [2 * i[1:] - 1 + c[1:], 2 * i + c, 2 * k_t + 1 + np.arange(times.size)]
        )
        order = np.empty(rows.size, dtype=int)
        order[rows] = np.arange(rows.size)  # row r of the output comes from entry order[r]
        t_all = np.concatenate([self.t[1:], self.t, times])
        piece = np.concatenate([np.arange(n - 1), np.arange(n), k_t])[order]
        # (the last knot is a piece of its own)

        def merged(i: int) -> np.ndarray:
            ev, kn = left_ev[i], own[i]
            assert ev is not None and kn is not None
            return np.take(np.concatenate([ev[: n - 1], kn, ev[n - 1 :]]), order, 0)

        q, qd, qdd = merged(0), merged(1), merged(2)
        out = LimitSamples(t_all[order], q, qd, qdd, merged(3) if jerk else None)
        if robot is None:
            return out
        t_s = out.t
        tau = rigid_body.inverse_dynamics(robot, out.q, out.qd, out.qdd)
        tau_max = np.ascontiguousarray(np.abs(tau).T).max(axis=1)  # across rows: fast
        added: list[tuple[np.ndarray, tuple[np.ndarray | None, ...]]] = []
        new_rows: np.ndarray | None = None  # the rows the last step added
        for step in range(REFINE_STEPS):  # successive parabolic interpolation to each peak
            vertex = peak_vertices(
                t_s, np.abs(tau), piece, any_triple=step == 0, near=new_rows, y_max=tau_max
            )
            # not at a sample's time (t_s is sorted)
            hit = np.searchsorted(t_s, vertex)
            vertex = vertex[t_s[np.minimum(hit, t_s.size - 1)] != vertex]
            if not vertex.size:
                break
            new_piece = np.clip(np.searchsorted(self.t, vertex, "right") - 1, 0, n - 2)
            # inside a piece (between two of its samples): its polynomial, as at() gives it
            state = self._evaluate(new_piece, vertex - self.t[new_piece], pieces, jerk)
            new_tau = rigid_body.inverse_dynamics(robot, *state[:3])
            tau_max = np.maximum(tau_max, np.abs(new_tau).max(axis=0))
            # sorted, and at no sample's time: merged in place, the order stays by time
            at = np.searchsorted(t_s, vertex) + np.arange(vertex.size)  # their rows
            old = np.ones(t_s.size + vertex.size, bool)
            old[at] = False
            t_s = merge_rows(t_s, vertex, old, at)
            piece = merge_rows(piece, new_piece, old, at)
            tau = merge_rows(tau, new_tau, old, at)
            added.append((vertex, state))
            new_rows = at
        if added:  # the states of the refined points, merged once
            vertex = np.concatenate([v for v, _ in added])
            k = np.argsort(vertex)
            at = np.searchsorted(t_s, vertex[k])
            old = np.ones(t_s.size, bool)
            old[at] = False
            out.t = t_s
            for name, i in (("q", 0), ("qd", 1), ("qdd", 2), ("qddd", 3)):
                if i < 3 or jerk:
                    new = np.concatenate([x[i] for _, x in added])[k]
                    setattr(out, name, merge_rows(getattr(out, name), new, old, at))
        out.tau = tau
        return out

    def sample(self, dt: float) -> Trajectory:
        """The trajectory on a uniform grid of step ``dt`` [s] from ``t[0]`` and its end point
        (:func:`sample_times`: a last regular sample within ``MERGE_FRACTION dt`` of the end
        merges into it), each value from the piecewise definition (:meth:`at`). Jerk is kept
        only if this trajectory has one."""
        if not np.isfinite(dt) or dt <= 0:
            raise InputError(f"sample step dt must be a positive number of seconds, not {dt!r}")
        times = self.t[0] + sample_times(self.duration, dt)
        times[-1] = self.t[-1]
        q, qd, qdd, qddd = self.at(times)
        jerk = qddd if self.qddd is not None else None
        out = Trajectory(times, q, qd, qdd, jerk, joint_names=self.joint_names, method=self.method)
        out.report, out.stats, out.meta = self.report, dict(self.stats), dict(self.meta)
        return out

    def stretched(self, k: float) -> Trajectory:
        """The same motion ``k`` times slower, ``q_k(t) = q(t0 + (t - t0) / k)``: times from
        ``t[0]`` times ``k``, velocities over ``k``, accelerations over ``k^2``, jerks over
        ``k^3`` -- exact for the evaluation (each piece's polynomial is stretched). Method,
        stats and meta are copied (times in ``meta`` are the caller's to scale); no report."""
        k = float(k)
        if not np.isfinite(k) or k <= 0:
            raise InputError(f"stretch factor must be a finite number > 0, not {k!r}")
        jerk = None if self.qddd is None else self.qddd / k**3
        out = Trajectory(
            self.t[0] + (self.t - self.t[0]) * k,
            self.q,
            self.qd / k,
            self.qdd / k**2,
            jerk,
            joint_names=self.joint_names,
            method=self.method,
        )
        out.stats, out.meta = dict(self.stats), dict(self.meta)
        return out

    def concat(self, other: Trajectory, *, tol: float = 1e-9) -> Trajectory:
        """This trajectory followed by ``other`` (shifted in time to start where this one ends).

        The join must be continuous in q and qd to ``tol``; the knot there keeps this
        trajectory's q and qd and takes the acceleration (and jerk) of ``other``'s start: the
        piece that starts at the join is ``other``'s (module docstring).
        """
        if other.n_joints != self.n_joints:
            raise InputError("cannot concatenate trajectories with different joint counts")
        jump = max(np.abs(other.q[0] - self.q[-1]).max(), np.abs(other.qd[0] - self.qd[-1]).max())
        if jump > tol:
            raise InputError(f"trajectories do not join: jump of {jump:.3g} in q or qd")
        t2 = other.t[1:] - other.t[0] + self.t[-1]
        starts = other.n_samples > 1  # a one-sample other is a rest point: nothing starts

        def join(a: np.ndarray, b: np.ndarray, from_other: bool) -> np.ndarray:
            last = b[:1] if from_other and starts else a[-1:]
            return np.vstack([a[:-1], last, b[1:]])

        t = np.concatenate([self.t, t2])
        # knots that the time shift rounds onto one instant: the later one starts the piece
        keep = np.append(np.diff(t) > 0, True)
        jerk = None
        if self.qddd is not None and other.qddd is not None:
            jerk = join(self.qddd, other.qddd, True)[keep]
        out = Trajectory(
            t[keep],
            join(self.q, other.q, False)[keep],
            join(self.qd, other.qd, False)[keep],
            join(self.qdd, other.qdd, True)[keep],
            jerk,
            joint_names=self.joint_names,
            method=self.method if self.method == other.method else f"{self.method}+{other.method}",
        )
        return out

    # ------------------------------------------------------------------ limits
    def torques(self, robot: Robot) -> np.ndarray:
        """Inverse-dynamics joint torques (n_samples, n_joints) in [N m] (Pinocchio RNEA,
        :func:`armlab.robot.rigid_body.inverse_dynamics`; gravity follows the robot's base)."""
        self._check_robot(robot)
        return rigid_body.inverse_dynamics(robot, self.q, self.qd, self.qdd)

    def _check_robot(self, robot) -> None:
        if robot.n_joints != self.n_joints:
            raise InputError(
                f"trajectory has {self.n_joints} joints, robot {robot.name} has {robot.n_joints}"
            )

    def check_limits(
        self,
        robot: Robot,
        *,
        dt: float | None = None,
        torque: bool = True,
        limits=None,
        samples: LimitSamples | None = None,
    ) -> LimitReport:
        """Peak ratio to each of the robot's limits per joint, on the evaluation.

        The peaks are taken over :meth:`limit_samples`: the knots, the left limit of every
        piece and each piece's interior extremes (exact for position, velocity, acceleration and
        jerk), and for torques interior points of every piece refined towards each peak.

        Parameters
        ----------
        robot : Robot
        dt : float, optional
            Also evaluate on a uniform grid of this step [s] (see :func:`sample_times`).
        torque : bool
            Include the torque ratio (RNEA, payload included).
        limits : Limits, optional
            Use these limits instead of ``robot.limits`` (e.g. a request's, from
            :func:`armlab.robot.resolve_limits`); kinds that are None are not reported.
        samples : LimitSamples, optional
            This trajectory's :meth:`limit_samples` at ``dt`` (with the torques when they are
            checked), if the caller has them already: used instead of computing them again.
        """
        self._check_robot(robot)
        lim = robot.limits if limits is None else limits
        if not isinstance(lim, Limits) or lim.n_joints != self.n_joints:
            raise InputError(f"limits must be a Limits of {self.n_joints} joints, not {lim!r}")
        with_tau = torque and lim.torque_Nm is not None
        smp = samples
        if smp is None:
            smp = self.limit_samples(dt, robot=robot if with_tau else None)
        if with_tau and smp.tau is None:
            raise InputError("check_limits: the samples given have no torques")
        report = LimitReport(list(robot.joint_names))
        centre, half = lim.centre_half_rad()  # inf half range for an unbounded joint: ratio 0

        def put(kind: str, signal: np.ndarray | None, scale) -> None:
            if signal is None or scale is None:
                return
            r = np.abs(signal) / np.asarray(scale, dtype=float)
            k = np.argmax(np.ascontiguousarray(r.T), axis=1)  # along rows: numpy's fast case
            report.ratios[kind] = r[k, np.arange(r.shape[1])]
            report.at_s[kind] = smp.t[k]

        put("position", smp.q - centre, half)
        put("velocity", smp.qd, lim.velocity_rad_s)
        put("acceleration", smp.qdd, lim.acceleration_rad_s2)
        put("jerk", smp.qddd, lim.jerk_rad_s3)
        if with_tau:
            put("torque", smp.tau, lim.torque_Nm)
        return report
