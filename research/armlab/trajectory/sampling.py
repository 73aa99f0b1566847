"""Where a :class:`~armlab.trajectory.core.Trajectory` is evaluated for its limits: the
sample grids (:func:`sample_times`, :func:`sample_weights`), the samples a limit check uses
(:class:`LimitSamples`: knots, left limits, the exact interior extremes of every piece found
as roots of its derivative polynomial in the Bernstein basis, refined torque peaks) and the
report a check returns (:class:`LimitReport`). The module docstring of
:mod:`armlab.trajectory.core` states where limits are checked and why that is exact.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from armlab.errors import InputError
from armlab.trajectory.profiles.ops import NP

__all__ = [
    "LimitReport",
    "LimitSamples",
    "LIMIT_KINDS",
    "MERGE_FRACTION",
    "fixed_times",
    "merged_times",
    "sample_times",
    "sample_weights",
]

LIMIT_KINDS = ("position", "velocity", "acceleration", "jerk", "torque")

#: a regular sample closer than this fraction of the step to a knot or to the end is dropped
MERGE_FRACTION = 1e-2
#: relative rounding of the times: fixed times closer than this times the duration merge
ROUNDING = 8 * float(np.finfo(float).eps)
#: steps of successive parabolic interpolation towards each torque peak inside a piece
REFINE_STEPS = 3
#: a piece longer than duration / TORQUE_GRID gets torque points at most that far apart before
#: the peak refinement
TORQUE_GRID = 1024


def sample_weights(t: np.ndarray) -> np.ndarray:
    """Time each sample stands for, in [s]: trapezoidal weights summing to the duration
    (a single sample stands for 1 s, a held pose)."""
    t = np.asarray(t, float)
    if t.size == 1:
        return np.ones(1)
    dt = np.diff(t)
    w = np.zeros_like(t)
    w[:-1] += 0.5 * dt
    w[1:] += 0.5 * dt
    return w


def sample_times(duration: float, dt: float, knots=()) -> np.ndarray:
    """Sample times [s] from 0 to ``duration``: the regular grid ``0, dt, 2 dt, ...``, the end
    and the ``knots`` (a planner's switching times, kept exactly).

    A regular sample closer than ``MERGE_FRACTION * dt`` to a knot or to the end is dropped, so
    there are no near-duplicate samples: the last regular step may be up to
    ``(1 + MERGE_FRACTION) dt`` long. Knots outside ``(0, duration)`` are ignored; knots closer
    than the rounding of the times (``8 eps duration``) to each other or to an end merge into
    the later one (the end); a zero duration gives ``[0.0]``.
    """
    dt = float(dt)
    if not np.isfinite(dt) or dt <= 0:
        raise InputError(f"sample step dt must be a positive number of seconds, not {dt!r}")
    duration = float(duration)
    if not np.isfinite(duration):
        raise InputError(f"duration must be a finite number of seconds, not {duration!r}")
    if duration <= 0:
        return np.zeros(1)
    n = int(np.floor(duration / dt + 1e-9))
    grid = dt * np.arange(n + 1)
    fixed = fixed_times(knots, duration)
    # a regular sample within MERGE_FRACTION dt of a fixed time: the grid is dt apart, so
    # only the one nearest to each fixed time can be (at most n: the grid ends there)
    j = np.rint(fixed / dt).astype(np.intp)
    np.minimum(j, n, out=j)
    near = np.zeros(n + 1, bool)
    near[j[np.abs(grid[j] - fixed) < MERGE_FRACTION * dt]] = True
    near[0] = False
    # disjoint sorted sets (a regular sample at a fixed time is "near" it, and 0 is never
    # fixed): their union is the sorted concatenation
    out = np.concatenate((grid[~near], fixed))
    out.sort(kind="stable")  # two sorted runs: the stable sort merges them in one pass
    return out


def fixed_times(knots, duration: float) -> np.ndarray:
    """The ``knots`` inside ``(0, duration)`` and the end, sorted, as :func:`sample_times`
    keeps them: knots within the rounding of the times (``ROUNDING * duration``) of each other
    or of an end (a phase shorter than the times' own noise) merge into the later one (the
    end); ``duration > 0`` (:func:`merged_times` with numpy)."""
    return merged_times(NP, np.asarray(knots, dtype=float).reshape(-1), duration)


def merged_times(ops, k, duration):
    """:func:`fixed_times` of the flat knots ``k``, written once against a backend ``ops``
    (:mod:`armlab.trajectory.profiles.ops`): numpy (the kept times) or CasADi SX (the closed
    form's graph, :mod:`armlab.planning.closed_graph`: a column of ``k.size + 1`` values, the
    kept times sorted, then ``+inf``). The knots inside ``(tiny, duration - tiny)`` and the
    end, sorted; each dropped where the next one is within ``tiny = ROUNDING * duration``
    (equal or closer: the later one stays; an equal pair is one time)."""
    tiny = ROUNDING * duration
    inside = ops.and_(k > tiny, k < duration - tiny)
    fixed = ops.sort(ops.append(ops.compress(k, inside), duration))
    return ops.compress(fixed, ops.gaps_above(fixed, tiny), sort=True)


@dataclass
class LimitSamples:
    """The points where a trajectory's limits are checked (:meth:`Trajectory.limit_samples`).

    Arrays as a :class:`Trajectory`'s -- ``t`` (n,) in [s], ``q``, ``qd``, ``qdd``, ``qddd``
    (n, n_joints) in [rad], [rad/s], [rad/s^2], [rad/s^3] -- except that ``t`` may repeat (a
    knot's left limit and its own value) and is not a time grid; ``qddd`` is None when the
    trajectory defines no jerk; ``tau`` (n, n_joints) in [N m] the RNEA torques when a robot was
    given. Anything that reads samples of a trajectory (e.g.
    :func:`armlab.planning.timescale.stretch_needed`) reads these too.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    qddd: np.ndarray | None = None
    tau: np.ndarray | None = None


@functools.cache
def to_bernstein(D: int) -> np.ndarray:
    """The matrix taking the power coefficients of a degree-``D`` polynomial on [0, 1] to its
    Bernstein coefficients (``b = c @ M.T``)."""
    return np.array(
        [
            [math.comb(k, i) / math.comb(D, i) if i <= k else 0.0 for i in range(D + 1)]
            for k in range(D + 1)
        ]
    )


def unit_roots(*polys: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Real roots in (0, 1) of the polynomials ``sum_i coeffs[i] s^i`` of every ``coeffs`` in
    ``polys`` (each coefficient an array of one shape, one polynomial per element): (flat
    element index, root) arrays, all of them together (unordered).

    The degree of each polynomial is its highest coefficient above ``1e-12`` times the sum of
    their magnitudes; roots from the closed forms up to degree 2, else from the eigenvalues of
    the companion matrix."""
    width = max(len(coeffs) for coeffs in polys)
    kept: list[tuple[np.ndarray, np.ndarray]] = []
    for coeffs in polys:
        c = np.stack([np.asarray(x, dtype=float).reshape(-1) for x in coeffs], axis=1)
        # no root in [0, 1] where the Bernstein coefficients share one strict sign (convex
        # hull; Farouki, CAGD 29 2012): most pieces, whose derivative does not vanish inside
        D = c.shape[1] - 1
        # one coefficient per row (contiguous): the sign tests reduce across rows, not along
        # each short one (numpy's slow case)
        b = np.ascontiguousarray((c @ to_bernstein(D).T).T)
        index = np.flatnonzero(~(np.all(b > 0, axis=0) | np.all(b < 0, axis=0)))
        # the rest on the few rows left, of all the polynomials at once (zero coefficients
        # above their degree change nothing below)
        padded = np.zeros((index.size, width))
        padded[:, : D + 1] = c[index]
        kept.append((index, padded))
    index = np.concatenate([i for i, _ in kept])
    c = np.concatenate([x for _, x in kept])
    scale = np.abs(c).sum(axis=1)
    big = np.abs(c) > 1e-12 * scale[:, None]
    deg = np.where(big.any(axis=1), c.shape[1] - 1 - np.argmax(big[:, ::-1], axis=1), 0)
    rows: list[np.ndarray] = []
    roots: list[np.ndarray] = []
    m = np.flatnonzero(deg == 1)
    rows.append(m)
    roots.append(-c[m, 0] / c[m, 1])
    m = np.flatnonzero(deg == 2)
    if m.size:
        a, b, cc = c[m, 2], c[m, 1], c[m, 0]
        disc = b * b - 4 * a * cc
        ok = disc >= 0
        m, a, b, cc, disc = m[ok], a[ok], b[ok], cc[ok], disc[ok]
        qq = -0.5 * (b + np.where(b >= 0, 1.0, -1.0) * np.sqrt(disc))
        with np.errstate(divide="ignore", invalid="ignore"):
            r1, r2 = qq / a, np.where(qq != 0, cc / qq, np.nan)
        rows += [m, m]
        roots += [r1, r2]
    for d in range(3, c.shape[1]):
        m = np.flatnonzero(deg == d)
        if not m.size:
            continue
        comp = np.zeros((m.size, d, d))
        comp[:, np.arange(1, d), np.arange(d - 1)] = 1.0
        comp[:, :, -1] = -c[m, :d] / c[m, d, None]
        ev = np.linalg.eigvals(comp)
        real = np.abs(ev.imag) <= 1e-7 * np.maximum(1.0, np.abs(ev.real))
        rows.append(np.repeat(m, d)[real.reshape(-1)])
        roots.append(ev.real[real])
    row, root = np.concatenate(rows).astype(int), np.concatenate(roots)
    inside = np.isfinite(root) & (root > 0) & (root < 1)
    return index[row[inside]], root[inside]


@dataclass
class LimitReport:
    """Peak ratio of a trajectory to each limit, per joint (``<= 1`` means within the limit).

    ``ratios[kind]`` is an array ``(n_joints,)`` for kind in :data:`LIMIT_KINDS` (absent when the
    robot has no such limit or the trajectory has no such signal). For ``position`` the ratio is
    ``|q - centre| / half range``. ``at_s[kind]`` holds the time of each peak in [s].
    """

    joint_names: list[str]
    ratios: dict[str, np.ndarray] = field(default_factory=dict)
    at_s: dict[str, np.ndarray] = field(default_factory=dict)

    def worst(self) -> tuple[str, str, float]:
        """(kind, joint, ratio) of the largest ratio over all kinds and joints."""
        best = ("", "", -np.inf)
        for kind, r in self.ratios.items():
            j = int(np.argmax(r))
            if r[j] > best[2]:
                best = (kind, self.joint_names[j], float(r[j]))
        return best

    def ok(self, tol: float = 1e-9) -> bool:
        """True if every ratio is <= 1 + tol (NaN is not)."""
        top = 1.0 + tol
        # a few values per kind (one per joint): as Python floats, not a numpy call each
        for r in self.ratios.values():
            for x in r.ravel().tolist():
                if not x <= top:
                    return False
        return True

    def violations(self, tol: float = 1e-9) -> list[tuple[str, str, float, float]]:
        """(kind, joint, ratio, time in [s]) of every ratio above 1 + tol."""
        out = []
        top = 1.0 + tol
        for kind, r in self.ratios.items():
            # a few values per kind (one per joint): as Python floats
            for j, x in enumerate(r.ravel().tolist()):
                if x > top:
                    out.append((kind, self.joint_names[j], x, float(self.at_s[kind][j])))
        return out

    def to_dict(self) -> dict[str, dict[str, float]]:
        """``{kind: {joint: ratio}}`` for JSON."""
        return {
            k: dict(zip(self.joint_names, map(float, r), strict=True))
            for k, r in self.ratios.items()
        }


def drop_noise(x: np.ndarray, tol: np.ndarray) -> np.ndarray:
    """``x`` with the entries within ``tol`` (rounding noise) set to zero."""
    return np.where(np.abs(x) <= tol, 0.0, x)


def peak_vertices(
    t: np.ndarray,
    y: np.ndarray,
    piece: np.ndarray,
    *,
    any_triple: bool = False,
    near: np.ndarray | None = None,
    y_max: np.ndarray | None = None,
) -> np.ndarray:
    """Times [s] of the maxima of the parabolas through three consecutive samples of ``y``
    (n, n_joints) over ``t`` (n,) that lie in one piece (no knot between them: the signal is
    smooth there) -- one step of successive parabolic interpolation towards each peak.

    Triples whose middle sample is a local peak; with ``any_triple`` every concave triple whose
    parabola peaks between its ends (a peak next to a knot, whose samples fall on one side of
    it). Only triples reaching 0.9 of the joint's largest ``y`` (``y_max`` (n_joints,) if the
    caller has it) are refined. With ``near`` (sample indices), only the triples that contain
    one of those samples (the points a previous step added: every other triple gave its
    vertex then).
    """
    if t.size < 3:
        return np.zeros(0)
    if y_max is None:
        y_max = np.ascontiguousarray(y.T).max(axis=1)  # across rows: numpy's fast reduction
    if near is None:  # every triple: views
        first = np.arange(t.size - 2)
        y0, y1, y2 = y[:-2], y[1:-1], y[2:]
        p0, p1, p2 = piece[:-2], piece[1:-1], piece[2:]
        ta, tb, tc = t[:-2], t[1:-1], t[2:]
    else:
        first = np.unique(np.clip(np.concatenate([near - 2, near - 1, near]), 0, t.size - 3))
        y0, y1, y2 = (np.take(y, first + d, axis=0) for d in range(3))
        p0, p1, p2 = (piece[first + d] for d in range(3))
        ta, tb, tc = (t[first + d] for d in range(3))
    ok = np.maximum(np.maximum(y0, y1), y2) >= 0.9 * y_max
    if not any_triple:
        ok &= (y1 >= y0) & (y1 >= y2) & ((y1 > y0) | (y1 > y2))
    ok &= ((p0 == p1) & (p1 == p2) & (ta < tb) & (tb < tc))[:, None]
    # the (triple, joint) pairs left, in row-major order: the vertices of those only
    k, j = np.divmod(np.flatnonzero(ok), y.shape[1])
    i = first[k]
    t0, t1, t2 = t[i], t[i + 1], t[i + 2]
    y0, y1, y2 = y[i, j], y[i + 1, j], y[i + 2, j]
    num = (t1 - t0) ** 2 * (y1 - y2) - (t1 - t2) ** 2 * (y1 - y0)
    den = (t1 - t0) * (y1 - y2) - (t1 - t2) * (y1 - y0)
    with np.errstate(divide="ignore", invalid="ignore"):
        tv = t1 - 0.5 * num / den
        concave = (y2 - y1) / (t2 - t1) < (y1 - y0) / (t1 - t0)
    keep = concave & np.isfinite(tv) & (tv > t0) & (tv < t2)
    return np.unique(tv[keep])


def merge_rows(a: np.ndarray, b: np.ndarray, old: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Rows of ``a`` where ``old`` is True and rows of ``b`` at the indices ``at`` (sorted)."""
    out = np.empty((old.size,) + a.shape[1:], dtype=a.dtype)
    if at.size > 16:
        out[old], out[at] = a, b
        return out
    # a few rows (the peak refinement): slices of a around them, not a boolean mask
    src = dst = 0
    for r, row in zip(at.tolist(), b, strict=True):
        out[dst:r] = a[src : src + r - dst]
        src += r - dst
        out[r] = row
        dst = r + 1
    out[dst:] = a[src:]
    return out
