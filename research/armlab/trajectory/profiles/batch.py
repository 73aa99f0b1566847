"""Time-synchronised rest-to-rest double S profiles of many problems at once, closed form
(:func:`synchronised_scurves`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from armlab.errors import InputError
from armlab.trajectory.profiles import graph
from armlab.trajectory.profiles.motion import MotionProfile, rest_profile
from armlab.trajectory.profiles.ops import NP
from armlab.trajectory.profiles.timing import (
    _DoubleSLimits,
    _ds_min_times,
    _ds_peak,
    _ds_ramp,
    _ds_speed_for_duration,
)

__all__ = ["SCurveBatch", "synchronised_scurves"]

#: the keys of SCurveBatch.peaks_flat(), in the graph's order
PEAK_KEYS = (
    "velocity",
    "velocity_at_s",
    "acceleration",
    "acceleration_at_s",
    "jerk",
    "jerk_at_s",
    "reverse",
    "end_position",
    "end_velocity",
    "end_acceleration",
)

#: how SCurveBatch.evaluate_jerk finds each time's phase: above _COMPARE_SIZE times x columns,
#: for one problem at times in order (a sampled plan) by counting the phase ends passed in
#: one pass, else (up to _SEARCH_COLUMNS joints x problems) by a binary search per column;
#: otherwise (a single plan's switching instants, or many columns) by one comparison with
#: every phase end
_SEARCH_COLUMNS = 16
_COMPARE_SIZE = 256


# ---------------------------------------------------------------------- batched, closed form
@dataclass(frozen=True)
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

    A result: frozen (a changed field is a new batch, :func:`dataclasses.replace`), so the
    phase data (:meth:`boundaries`) and the peaks, computed once on first use or given by the
    graph of one problem, always belong to its fields.
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
    _bounds: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)
    _steps: tuple = field(default=(), init=False, repr=False, compare=False)
    #: peaks_flat() when the graph computed it with the rest (one problem, finite jerks): its
    #: rows (10, n_joints), keys PEAK_KEYS
    _peaks: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)
    #: every jerk finite (no trapezoid): set by synchronised_scurves, else tested
    _jerk_finite: bool = field(default=False, init=False, repr=False, compare=False)

    @property
    def jerk_finite(self) -> bool:
        """Every joint's jerk is finite (no trapezoid): known from :func:`synchronised_scurves`,
        else tested."""
        return self._jerk_finite or bool(np.isfinite(self.j).all())

    def profile(self, index) -> MotionProfile:
        """The :class:`MotionProfile` of one joint of one problem, ``index`` into the
        ``(..., n_joints)`` arrays (e.g. ``(problem, joint)``), over ``|distance|``."""
        at = index if isinstance(index, tuple) else (index,)
        return self.profiles(at[:-1], joints=[at[-1]])[0]

    def profiles(self, problem=(), joints=None) -> list[MotionProfile]:
        """The :class:`MotionProfile` of every joint (or of ``joints``) of one problem,
        ``problem`` indexing the leading axes (``()`` for a batch of one joint axis), each
        over ``|distance|``, from the phase data (:meth:`boundaries`)."""
        at = problem if isinstance(problem, tuple) else (problem,)
        phases = self.boundaries()[(slice(3, None), slice(None), *at)]  # (3, 7, n_joints)
        cols = range(phases.shape[-1]) if joints is None else joints
        T = float(self.duration[at])
        # Python floats once (one conversion of the table, not one per value)
        L, v, j = (np.asarray(x[at])[cols].tolist() for x in (self.distance, self.v, self.j))
        table = phases.transpose(2, 0, 1)[cols].tolist()  # per joint: d, acc, jrk
        out = []
        for Li, vi, ji, (d, acc, jrk) in zip(L, v, j, table, strict=True):
            Li = abs(Li)
            if Li <= 0 or vi <= 0:
                out.append(rest_profile(T))
            elif math.isinf(ji):  # the trapezoid: its three phases
                params = {"v": vi, "a_acc": acc[1], "a_dec": acc[1], "length": Li}
                out.append(MotionProfile(d, acc, jrk, kind="trapezoid", params=params))
            else:
                params = {"v": vi, "a": acc[1], "j": ji, "length": Li}
                out.append(MotionProfile(d, acc, jrk, kind="double_s", params=params))
        return out

    def profile_dicts(self, problem=()) -> list[dict]:
        """``[p.to_dict() for p in self.profiles(problem)]`` (kind, duration, length and
        parameters of every joint's :class:`MotionProfile`) from the phase data, without
        building the profiles: the duration is the sum of the phases of positive length in
        their order, as :class:`MotionProfile` integrates them."""
        at = problem if isinstance(problem, tuple) else (problem,)
        b = self.boundaries()
        T = float(self.duration[at])
        d = b[(3, slice(None), *at)].T.tolist()  # per joint: the seven durations
        a1 = b[(4, 1, *at)].tolist()  # the acceleration of the ramp
        L, v, j = (np.asarray(x[at]).tolist() for x in (self.distance, self.v, self.j))
        out = []
        for Li, vi, ji, di, ai in zip(L, v, j, d, a1, strict=True):
            Li = abs(Li)
            if Li <= 0 or vi <= 0:  # rest_profile(T)
                out.append({"kind": "rest", "duration_s": max(T, 0.0), "length": 0.0, "v": 0.0})
                continue
            t = 0.0
            for h in di:
                if h > 0:
                    t += h
            if math.isinf(ji):
                params = {"v": vi, "a_acc": ai, "a_dec": ai, "length": Li}
                kind = "trapezoid"
            else:
                params, kind = {"v": vi, "a": ai, "j": ji, "length": Li}, "double_s"
            out.append({"kind": kind, "duration_s": t, "length": Li, **params})
        return out

    def phases(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The seven phases of every joint's double S (Biagiotti & Melchiorri §3.4), unsigned:
        ``(durations, start accelerations, jerks)``, each ``(7, ..., n_joints)`` in [s],
        [unit/s^2], [unit/s^3] -- durations ``tj, ta - 2 tj, tj, tv, tj, ta - 2 tj, tj``,
        accelerations ``0, a, a, 0, 0, -a, -a``, jerks ``j, 0, -j, 0, -j, 0, j`` (0 for a
        trapezoid, ``j = inf``)."""
        _, _, _, d, acc, jrk = self.boundaries()
        return d, acc, jrk

    def boundaries(self) -> np.ndarray:
        """Each phase's start ``(t0, s0, v0)`` and its data ``(d, acc, jrk)`` (:meth:`phases`):
        an array ``(6, 7, ..., n_joints)``, unsigned, integrated from rest with a constant jerk
        in each phase (computed once)::

            t0[k+1] = t0[k] + d_k,   v0[k+1] = v0[k] + a_k d_k + j_k d_k^2 / 2,
            s0[k+1] = s0[k] + v0[k] d_k + a_k d_k^2 / 2 + j_k d_k^3 / 6
        """
        if self._bounds is not None:
            return self._bounds
        jf = self.j
        if not self.jerk_finite:
            jf = np.where(np.isfinite(jf), jf, 0.0)  # a trapezoid has no jerk phases
        out = np.empty((6, 7) + self.a.shape)
        steps = _phase_table(NP, self.tj, self.ta, self.tv, self.a, jf, out)
        _cache(self, _bounds=out, _steps=steps)  # steps: each phase's dv, ds (peaks)
        return out

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, qd, qdd)`` displacements from the start at times ``t`` (m,) [s]: arrays
        ``(m, ..., n_joints)``; clamped to each problem's ``[0, duration]``."""
        return self.evaluate_jerk(t)[:3]

    def evaluate_jerk(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`evaluate` and the jerk ``(q, qd, qdd, qddd)``: each joint's phase of every
        time (right-continuous: at a phase boundary the phase that starts there; the last
        phase holds the end), its Taylor polynomial from the phase's start
        (:meth:`boundaries`)."""
        t = np.asarray(t, float).reshape(-1)
        b = self.boundaries()
        cols = self.distance.size
        ends = b[0, 1:].reshape(6, cols)  # phase k ends where phase k + 1 starts
        one = self.duration.size == 1
        if one:  # one problem: one time axis for every joint
            t1 = np.minimum(np.maximum(t, 0.0), float(self.duration.reshape(-1)[0]))
            tt = t1[:, None]
        else:
            shape = (t.size,) + (1,) * self.distance.ndim
            tt = np.maximum(np.minimum(t.reshape(shape), self.duration[..., None]), 0.0)
            tt = np.broadcast_to(tt, (t.size,) + self.distance.shape).reshape(t.size, cols)
        # the phase of each time: the phase ends passed (a zero-length phase is passed with
        # its predecessor), at most the last; a binary search per joint where there are few
        m = t.size
        if one and m * cols > _COMPARE_SIZE and (t1[1:] >= t1[:-1]).all():
            # one problem, many times in order (a sampled plan): time i has passed end r of
            # joint c where i >= the number of times before that end; counted for every
            # joint at once
            first = np.searchsorted(t1, ends.reshape(-1), "left") * cols
            first += np.arange(6 * cols) % cols
            k = np.bincount(first, minlength=(m + 1) * cols)[: m * cols].reshape(m, cols)
            k = k.cumsum(axis=0)
        elif cols <= _SEARCH_COLUMNS and m * cols > _COMPARE_SIZE:
            k = np.empty((cols, t.size), np.intp)
            for c in range(cols):
                k[c] = np.searchsorted(ends[:, c], tt[:, c if tt.shape[1] > 1 else 0], "right")
            k = k.T
        else:
            k = (tt[:, None] >= ends[None]).sum(axis=1)
        # the phase table with each joint's direction in it (a sign is exact through the
        # Taylor polynomials: no signed copy of every sample), and a0 / 2 (exact)
        tab = np.empty((7, 7, cols))
        tab[:6] = b.reshape(6, 7, cols)
        sgn = np.sign(self.distance).reshape(cols)
        tab[1:3] *= sgn
        tab[4:6] *= sgn
        np.multiply(tab[4], 0.5, out=tab[6])
        res = _taylor(NP, tab.reshape(7, 7 * cols), k * cols + np.arange(cols), tt)
        out = (t.size,) + self.distance.shape
        return tuple(x.reshape(out) for x in res)

    def peaks(self) -> dict[str, np.ndarray]:
        """Exact extremes of every joint's motion from its phase data (:meth:`boundaries`),
        each ``(..., n_joints)``, unsigned.

        Within a phase the jerk is constant, the acceleration linear (its extremes at the
        phase ends) and the speed quadratic, extreme at the ends or where the acceleration
        crosses zero inside (``v0 - a0^2 / 2 j``, taken where the acceleration changes sign).

        Returns
        -------
        dict
            ``velocity``, ``acceleration``, ``jerk``: the peak ``|qd|``, ``|qdd|``,
            ``|qddd|`` over the motion (phases of zero length left out), with ``*_at_s`` the
            time [s] of each (the first); ``reverse``: the most negative speed against the
            direction of the move (0 when the motion is monotone, so the position stays
            between start and goal); ``end_position``, ``end_velocity``,
            ``end_acceleration``: the state at the end of the last phase, to be compared
            with ``|distance|``, 0, 0 (a trapezoid's acceleration steps to 0 at its end: 0).
        """
        shape = self.distance.shape
        return {k: x.reshape(shape) for k, x in self.peaks_flat().items()}

    def peaks_flat(self) -> dict[str, np.ndarray]:
        """:meth:`peaks` with every array flat, ``(problems x n_joints,)``."""
        if self._peaks is not None:  # the graph's rows
            return dict(zip(PEAK_KEYS, self._peaks, strict=True))
        b = self.boundaries()
        cols = self.distance.size
        dv, ds = (x.reshape(7, cols) for x in self._steps)  # integrated by boundaries()
        t0, s0, v0, d, acc, jrk = b.reshape(6, 7, cols)
        return _peak_table(NP, t0, s0, v0, d, acc, jrk, dv, ds)


# ---------------------------------------------------------------------- the engine's formulas
# Written once against a backend ``ops`` (:mod:`.ops`): numpy (NP; batches, trapezoids) and
# CasADi SX (the graph of one problem, :mod:`.graph`). Per joint the arguments are numpy
# arrays (..., n_joints) or SX columns (n, 1); a phase table is (7, ...) or SX (7, n).
def _synchronise(L, v, a, j, k: _DoubleSLimits, moving) -> tuple:
    """``(T, t_min, v, a, tj, ta, tv)`` of the synchronised profiles (:func:`synchronised_scurves`):
    each joint's shortest time, the common duration ``T`` (their largest), each joint's peak
    speed for ``T`` and its ramps; ``L = |D|`` and ``moving = L > 0`` at the full shape."""
    ops = k.ops
    peak = _ds_peak(L, v, k)
    t_min = _ds_min_times(L, v, k, peak, moving)
    T = ops.joint_max(t_min)
    Tc = ops.per_joint(T, t_min)
    vp = _ds_speed_for_duration(L, Tc, v, k, peak, t_min, moving)
    tj, ta = _ds_ramp(vp, k)
    ap = ops.fmin(j * tj, a)  # a joint at rest: tj = 0, so ap = 0 (finite j)
    if not k.finite:
        ap = np.where(vp > 0, np.where(k.trap, a, ap), 0.0)
    tv = ops.fmax(Tc - 2 * ta, 0.0)  # a joint at rest: ta = 0, so tv = T
    return T, t_min, vp, ap, tj, ta, tv


def _phase_table(ops, tj, ta, tv, ap, jf, out=None) -> tuple:
    """The seven phases (:meth:`SCurveBatch.phases`) and their starts integrated from rest
    (:meth:`SCurveBatch.boundaries`): the rows ``t0, s0, v0, d, acc, jrk`` into ``out``
    (numpy: ``(6, 7, ...)``; SX: a list), and the steps ``(dv, ds)`` of each phase."""
    if out is None:
        out = [None] * 6
    zero = ops.zero(tj)
    c = ta - 2 * tj  # constant acceleration
    d = out[3] = ops.rows([tj, c, tj, tv, tj, c, tj], out[3])
    acc = out[4] = ops.rows([zero, ap, ap, zero, zero, -ap, -ap], out[4])
    jrk = out[5] = ops.rows([jf, zero, -jf, zero, -jf, zero, jf], out[5])
    out[0] = ops.accumulate(d, out[0])
    dv = d * (acc + d * jrk / 2)
    v0 = out[2] = ops.accumulate(dv, out[2])
    ds = d * (v0 + d * (acc / 2 + d * jrk / 6))
    out[1] = ops.accumulate(ds, out[1])
    return dv, ds


def _peak_table(ops, t0, s0, v0, d, acc, jrk, dv, ds) -> dict:
    """:meth:`SCurveBatch.peaks_flat` from the phase table ``(7, cols)`` and its steps."""
    live = d > 0
    a1 = acc + jrk * d  # the acceleration at each phase end
    v1 = v0 + dv
    cross = ops.and_(live, acc * a1 < 0)  # the speed's extreme inside the phase
    # candidates (21 or 14, cols): at the phase starts, the phase ends, the extremes inside
    # (where there are any: else their rows would be 0, never the first largest |speed|
    # nor a lower speed than v0 = 0 at the start)
    if ops.any(cross):
        jn = ops.where(cross, jrk, 1.0)
        ct = ops.concat([t0, t0 + d, t0 - acc / jn])
        cv = ops.concat([v0 * live, v1 * live, (v0 - acc * acc / (2 * jn)) * cross])
    else:
        ct = ops.concat([t0, t0 + d])
        cv = ops.concat([v0 * live, v1 * live])
    ca = abs(ops.concat([acc * live, a1 * live]))
    cj = abs(jrk * live)
    pv, pvt = ops.argmax_first(abs(cv), ct)
    pa, pat = ops.argmax_first(ca, ct)
    pj, pjt = ops.argmax_first(cj, t0)
    return {
        "velocity": pv,
        "velocity_at_s": pvt,
        "acceleration": pa,
        "acceleration_at_s": pat,
        "jerk": pj,
        "jerk_at_s": pjt,
        "reverse": ops.fmax(-ops.row_min(cv), 0.0),
        "end_position": s0[6, :] + ds[6, :],
        "end_velocity": v1[6, :],
        "end_acceleration": a1[6, :] * live[6, :],
    }


def _taylor(ops, tab, index, tt) -> tuple:
    """``(q, qd, qdd, qddd)`` from the start at the clamped times ``tt``: each sample's phase
    row gathered from the signed table ``tab`` (its seven rows ``t0, s0, v0, d, a0, j0,
    a0 / 2``, each phase-major ``phase x columns``) at ``index`` (``phase x columns +
    column``), then the phase's Taylor polynomial at ``h = clip(tt - t0, 0, d)``
    (:meth:`SCurveBatch.evaluate_jerk`; written once: numpy ``(m, cols)``, and the MX
    samples of :mod:`armlab.planning.closed_graph`, ``(n, slots)``)."""
    t0, s0, v0, d, a0, j0, a2 = ops.take(tab, index)
    h = ops.fmin(ops.fmax(tt - t0, 0.0), d)
    s = s0 + h * (v0 + h * (a2 + h * j0 / 6))
    v = v0 + h * (a0 + h * j0 / 2)
    return s, v, a0 + j0 * h, j0


def _full(x: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """``x`` broadcast to ``shape`` as its own contiguous array."""
    if x.shape == shape:
        return x
    out = np.empty(shape)
    out[...] = x
    return out


def _checked_shape(D: np.ndarray, v: np.ndarray, a: np.ndarray, j: np.ndarray) -> tuple:
    """The shape of the problems: ``D``'s, or that of the limits broadcast onto it; an
    :class:`InputError` for a distance that is not finite, a limit that is not > 0 (``j_max``
    may be inf) or limits that do not broadcast. The common case (every value valid, limits
    of one shape that ends ``D``'s) is one test; the rest names the first problem."""
    try:
        ok = (
            bool(np.isfinite(D).all())
            and bool((np.minimum(np.minimum(v, a), j) > 0).all())
            and bool(np.isfinite(np.maximum(v, a)).all())
        )
    except ValueError:  # the limits do not broadcast together: named below
        ok = False
    if ok and v.shape == a.shape == j.shape and v.shape == D.shape[D.ndim - v.ndim :]:
        return D.shape
    if not np.isfinite(D).all():
        raise InputError("synchronised_scurves: distances must be finite")
    for name, x, inf_ok in (("v_max", v, False), ("a_max", a, False), ("j_max", j, True)):
        if not (x > 0).all() or not (inf_ok or np.isfinite(x).all()):
            raise InputError(f"synchronised_scurves: {name} must be > 0 and finite")
    try:
        return np.broadcast_shapes(D.shape, v.shape, a.shape, j.shape)
    except ValueError:
        raise InputError(
            f"synchronised_scurves: limits do not broadcast to distances {D.shape}"
        ) from None


def synchronised_scurves(distances, v_max, a_max, j_max=math.inf) -> SCurveBatch:
    """Time-synchronised rest-to-rest double S profiles of many problems at once, closed form.

    The batch form of :func:`synchronised_profiles` (Jiang 1987, eq. 1-5 with a double S per
    joint, Biagiotti & Melchiorri §3.4): each joint's shortest duration in closed form
    (:func:`double_s_min_times`), the common duration the largest, and each joint's peak
    speed for it solved in closed form (a quadratic or a cubic, no iteration;
    :func:`double_s_speed_for_duration`). A rest-to-rest motion through waypoints where the arm
    stops (zero-velocity waypoints) is a batch of its segments:
    ``synchronised_scurves(np.diff(waypoints, axis=0), v, a, j)``.

    The formulas are written once (:mod:`.ops`) and evaluated by numpy for batches and
    trapezoids, and for ONE problem with finite jerks (``distances`` of shape ``(n,)`` or
    ``(1, n)``) as one CasADi graph (:mod:`.graph`: compiled once per joint count and cached,
    or CasADi's VM), which also gives the batch's :meth:`~SCurveBatch.boundaries` and
    :meth:`~SCurveBatch.peaks_flat` in the same evaluation: 13 us in all against 110 us with
    numpy (6 joints). The two agree within 1e-15 of each quantity's scale.

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
    v, a, j = np.asarray(v_max, float), np.asarray(a_max, float), np.asarray(j_max, float)
    shape = D.shape
    if (
        D.size == shape[-1] > 0
        and v.shape == a.shape == j.shape == shape[D.ndim - v.ndim :]
        and graph.available()
    ):  # one problem: the graph, unless it finds an invalid value or an infinite jerk
        if v.shape != shape:
            v, a, j = _full(v, shape), _full(a, shape), _full(j, shape)
        batch = _one_problem(D, v, a, j)
        if batch is not None:
            return batch
    return _numpy_batch(D, v, a, j, _checked_shape(D, v, a, j))


def _numpy_batch(D, v, a, j, shape: tuple[int, ...]) -> SCurveBatch:
    """:func:`synchronised_scurves` evaluated by numpy (valid arguments broadcasting to
    ``shape``): batches, trapezoids, ``$ARMLAB_SCURVE_GRAPH=off``, and the numpy evaluation of
    the closed form's layout (:mod:`armlab.planning.closed_graph`)."""
    # every argument at the full shape once: same-shape numpy operations, no broadcasting
    # (it costs more than the arithmetic on a single small problem)
    D, v, a, j = (_full(x, shape) for x in (D, v, a, j))
    finite = bool(np.isfinite(j).all())  # a is finite (checked)
    L = np.abs(D)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        # the quantities that depend on the limits alone, once
        k = _DoubleSLimits(a, j, finite)
        T, t_min, vp, ap, tj, ta, tv = _synchronise(L, v, a, j, k, L > 0)
    batch = SCurveBatch(
        duration=T, t_min=t_min, distance=D, v=vp, a=ap, j=j, tj=tj, ta=ta, tv=tv, a_max=a
    )
    return _cache(batch, _jerk_finite=k.finite)


def _cache(batch: SCurveBatch, **known) -> SCurveBatch:
    """``batch`` with what is known of it set (the private fields: the phase table, its steps,
    the peaks, finite jerks) -- computed from its own fields, so a frozen batch may hold it."""
    for name, value in known.items():
        object.__setattr__(batch, name, value)
    return batch


def _one_problem(D, v, a, j) -> SCurveBatch | None:
    """:func:`synchronised_scurves` of one problem (``D`` of ``n`` joints, any leading axes of
    size 1): every result, the phase table and the peaks by one evaluation of the graph
    (:func:`armlab.trajectory.profiles.graph.evaluate`); ``None`` where a value is not valid
    or a jerk is infinite (the graph's last output: the numpy path names the error or builds
    the trapezoid)."""
    shape = D.shape
    r = graph.evaluate(D, v, a, j)  # a fresh array: the batch's arrays are views of it
    if r is None or not r[-1]:  # a value the numpy path names (or the graph was reset)
        return None
    T, (t_min, vp, ap, tj, ta, tv), table, steps, peaks = graph.unpack(r, shape)
    batch = SCurveBatch(T, t_min, D, vp, ap, j, tj, ta, tv, a)
    return _cache(batch, _jerk_finite=True, _bounds=table, _steps=tuple(steps), _peaks=peaks)
