"""The 2-waypoint closed-form plan of :func:`~armlab.planning.optimal` as ONE CasADi graph per
joint count: the synchronised double S, its phase table and exact check, the switching
instants merged, and the samples at them, in one evaluation (issue 26).

:func:`~armlab.planning.optimal_closed.closed_form_optimal` of a rest-to-rest v/a/j problem is
a few hundred numpy calls on arrays of ``n`` values. This module evaluates the same functions
-- the engine's (``_synchronise``, ``_phase_table``, ``_peak_table`` of
:mod:`armlab.trajectory.profiles.batch`), the exact check
(:func:`~armlab.planning.optimal_closed.exact_check`), the knot merge
(:func:`~armlab.trajectory.sampling.merged_times`) and the Taylor samples with their gather
(``batch._taylor``), each written once against a backend (:mod:`armlab.trajectory.profiles.ops`)
-- given CasADi symbols instead of arrays: the engine, the check and the merge as an SX core
(the sets of times are sorting networks), the samples as vector MX operations around it (each
(slot, joint) gathers its phase row by an MX index: written in SX they would be 30-40 thousand
instructions, five times slower, /work/notes/floor2).

Inputs ``W`` (``2 n``: the start row, then the goal row: a C-ordered ``(2, n)`` array) and
``P`` (``7 n``: ``v, a, j, lo, hi, centre, half``, each ``n``; ``lo``/``hi`` include the
range tolerance :data:`~armlab.trajectory.waypoints.RANGE_TOL_RAD`). Output: one flat vector,
:func:`layout`:

* ``head`` (9): ``m`` (the number of knots), ``T``, ``valid``, ``exact_ok``, ``ok``, ``nbind``
  (the number of binding ratios), ``residual``, ``0.0``, ``T`` (the waypoint times);
* ``t`` (``S = 6 n + 2`` slots): the knots, ``0``, the merged switching instants, ``T``; the
  slots from ``m`` on are padding (``+inf`` in the graph);
* ``q``, ``qd``, ``qdd``, ``qddd`` (``S x n`` each, slot-major: row ``s`` is ``out[o + s n : o
  + (s + 1) n]``): the samples at the knots (right-continuous phase, :meth:`SCurveBatch.
  evaluate_jerk`; ``q`` from the start; the row of ``T`` the goal at rest exactly); rows from
  ``m`` on are padding;
* ``ratio``, ``at`` (``4 n`` each: position, velocity, acceleration, jerk rows): the exact
  report's ratios and their times [s];
* ``bind`` (``3 n``: velocity, acceleration, jerk): 1 where the ratio is ``>= 1 - 2e-3``.

``valid`` is 1 only where ``optimal()``'s own validation accepts the waypoints (every value
finite and inside ``[lo, hi]``, some joint moving by at least 1e-12 rad) and every ``v, a, j``
is finite and > 0; where it is 0, the other values may be anything (the caller takes the
ordinary path, which names the error). ``exact_ok``: :func:`exact_report` would not return
None; ``ok``: every ratio <= ``1 + CHECK_TOL``.

How the graph is run is :mod:`armlab._compiled`'s (``$ARMLAB_SCURVE_GRAPH``, as the S-curve
graph; ``off``: :func:`evaluate` fills the same layout by the numpy evaluation of the same
functions, :func:`evaluate_numpy`). The library is compiled with :data:`CFLAGS` (``-O3
-march=native -fno-semantic-interposition -ffp-contract=off``; the cache key holds the CPU)
and ``casadi_fmin``/``fmax`` as comparisons (:func:`_inline_minmax`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from armlab import _compiled
from armlab._compiled import reset
from armlab._lazy import lazy_import
from armlab.planning import (
    optimal_closed as _closed,  # (imports this module: attributes read at call time)
)
from armlab.planning.timescale import BINDING, CHECK_TOL
from armlab.trajectory.profiles import batch as _batch
from armlab.trajectory.profiles.ops import NP
from armlab.trajectory.sampling import merged_times
from armlab.trajectory.waypoints import COINCIDE_RAD

ca = lazy_import("casadi")

__all__ = [
    "CFLAGS",
    "GRAPH",
    "build",
    "compile_library",
    "evaluate",
    "evaluate_numpy",
    "layout",
    "prepare",
    "reset",
    "status",
]

#: the library's flags: ``-O3 -march=native`` (vectorised MX sample loops: 6.1 against 8.6 us
#: per 6-joint call at -O2; the cache key then holds the CPU, :func:`armlab._compiled.cpu_key`);
#: ``-fno-semantic-interposition`` (gcc inlines the exported casadi helpers of a -fPIC
#: library: 10.1 -> 6.6 us in a C harness, floor2); ``-ffp-contract=off`` (no fused
#: multiply-add: the library gives the VM's values)
CFLAGS = (
    "-O3",
    "-march=native",
    "-fPIC",
    "-shared",
    "-fno-semantic-interposition",
    "-ffp-contract=off",
)
#: the kinds of the ratio / at rows, and of the bind rows
KINDS = ("position", "velocity", "acceleration", "jerk")
BIND_KINDS = KINDS[1:]
_HERE = Path(__file__).parent
#: the files the graph is generated from, and those of the constants it holds (CHECK_TOL,
#: BINDING, COINCIDE_RAD): its cache key hashes them
_SOURCES = (
    _HERE / "closed_graph.py",
    _HERE / "optimal_closed.py",
    _HERE / "timescale.py",
    _HERE.parent / "trajectory" / "sampling.py",
    _HERE.parent / "trajectory" / "waypoints.py",
    *(
        _HERE.parent / "trajectory" / "profiles" / f
        for f in ("ops.py", "timing.py", "batch.py", "graph.py")
    ),
)


def layout(n: int) -> dict:
    """The output of ``n`` joints: ``{field: (start, stop)}`` for ``head, t, q, qd, qdd, qddd,
    ratio, at, bind`` (module docstring), ``"size"`` (the output's length) and ``"S"`` (the
    number of knot slots, ``6 n + 2``)."""
    S = 6 * n + 2
    off: dict = {}
    o = 0
    names = ("head", "t", "q", "qd", "qdd", "qddd", "ratio", "at", "bind")
    sizes = (9, S, S * n, S * n, S * n, S * n, 4 * n, 4 * n, 3 * n)
    for name, size in zip(names, sizes, strict=True):
        off[name] = (o, o + size)
        o += size
    off["size"] = o
    off["S"] = S
    return off


def _symbol(n: int) -> str:
    return f"armlab_closed_{n}"


def _valid(ops, w0, w1, v, a, j, lo, hi):
    """1 where ``optimal()`` accepts the waypoints ``w0``, ``w1`` (every value finite and
    inside ``[lo, hi]``, some joint moving by at least :data:`COINCIDE_RAD`) and every
    ``v, a, j`` is finite and > 0 (comparisons with NaN are false); written once against
    ``ops``: the graph's flag and :func:`evaluate_numpy`'s."""
    inside = [ops.and_(ops.and_(abs(x) < np.inf, x >= lo), x <= hi) for x in (w0, w1)]
    limits = [ops.and_(x > 0, x < np.inf) for x in (v, a, j)]
    return ops.and_(
        ops.all_of(ops.concat(inside + limits)), ops.any_of(abs(w1 - w0) >= COINCIDE_RAD)
    )


def _core(n: int):
    """The SX core of ``n`` joints: ``(W, P) -> head (7), t slots (S), signed phase table (7
    rows of 7 n, phase-major), ratio (4 n), at (4 n), bind (3 n)``."""
    from armlab.trajectory.profiles.graph import engine
    from armlab.trajectory.profiles.ops import sx

    SX = sx()
    W, P = ca.SX.sym("W", 2 * n), ca.SX.sym("P", 7 * n)
    w0, w1 = W[:n], W[n:]
    v, a, j, lo, hi, centre, half = (P[k * n : (k + 1) * n] for k in range(7))
    valid = _valid(SX, w0, w1, v, a, j, lo, hi)
    # the engine (synchronised_scurves), its phase table and peaks (columns of n joints)
    D = w1 - w0
    (T, *_), table, _, peaks = engine(D, v, a, j)
    pk = {key: x.T for key, x in peaks.items()}
    # the exact check (exact_report) and the verdict of closed_form_optimal
    exact_ok, residual, ratios, at_s = _closed.exact_check(
        SX, pk, D, v, a, j, w0, w1, centre, half, T
    )
    ratio = ca.vertcat(*(ratios[kind] for kind in KINDS))
    at = ca.vertcat(*(at_s[kind] for kind in KINDS))
    ok = ca.mmin(ratio <= 1.0 + CHECK_TOL)
    bind = ca.vertcat(*(ratios[kind] >= BINDING for kind in BIND_KINDS))
    # the knots (closed_form_optimal's _knots): 0, the merged switching instants, then +inf
    merged = merged_times(SX, ca.vec(table[0][1:, :].T), T)
    m = 1 + ca.sum1(merged < ca.inf)
    t = ca.vertcat(0.0, merged)
    # the signed phase table of evaluate_jerk (rows t0, s0, v0, d, a0, j0, a0 / 2)
    sgn = ca.repmat(ca.sign(D).T, 7, 1)
    rows = [table[0], table[1] * sgn, table[2] * sgn, table[3], table[4] * sgn, table[5] * sgn]
    rows.append(rows[4] * 0.5)
    head = [m, T, valid, exact_ok, ok, ca.sum1(bind), residual]
    out = ca.vertcat(*head, t, *(ca.vec(r.T) for r in rows), ratio, at, bind)
    return ca.Function(f"armlab_closed_core_{n}", [W, P], [out], ["W", "P"], ["out"])


def _build(n: int):
    """The graph of ``n`` joints: the SX core, and the samples at its knots as vector MX
    operations (:func:`armlab.trajectory.profiles.batch._taylor` with the MX backend)."""
    from armlab.trajectory.profiles.ops import mx

    S = 6 * n + 2
    core = _core(n)
    W, P = ca.MX.sym("W", 2 * n), ca.MX.sym("P", 7 * n)
    c = core(W, P)
    head, T, t = c[:7], c[1], c[7 : 7 + S]
    o = 7 + S
    tab = [c[o + r * 7 * n : o + (r + 1) * 7 * n] for r in range(7)]
    rest = c[o + 49 * n :]
    # evaluate_jerk at the knots: each (joint, slot) in phase k = the phase ends passed
    # (right-continuous; its comparison path), its row at k n + joint
    tt = ca.repmat(ca.fmin(ca.fmax(t, 0.0), T).T, n, 1)  # (n, S)
    k = ca.MX.zeros(n, S)
    for r in range(1, 7):
        k = k + (tt >= ca.repmat(tab[0][r * n : (r + 1) * n], 1, S))
    joint = ca.DM(np.repeat(np.arange(n, dtype=float)[:, None], S, axis=1))
    s, sv, sa, sj = _batch._taylor(mx(), tab, k * n + joint, tt)
    # q from the start; the knot T (and the padding) the goal at rest exactly
    end = ca.repmat((t >= T).T, n, 1)
    q = ca.if_else(end, ca.repmat(W[n:], 1, S), s + ca.repmat(W[:n], 1, S))
    samples = [q] + [ca.if_else(end, 0.0, x) for x in (sv, sa, sj)]
    out = ca.vertcat(head, 0.0, T, t, *(ca.vec(x) for x in samples), rest)
    return ca.Function(_symbol(n), [W, P], [out], ["W", "P"], ["out"])


def _inline_minmax(code: str) -> str:
    """``casadi_fmin``/``casadi_fmax`` of the generated C as a comparison and a selection
    (C99 ``fmin``/``fmax`` are libm calls, about 6 ns each; the two sorting networks make
    about 1100 of them: 9.7 -> 4.6 us for 6 joints, floor2).

    Safe: ``x < y ? x : y`` differs from ``fmin(x, y)`` only where ``y`` is NaN (``fmin``
    returns ``x``, the ternary NaN; for ``x`` NaN both return ``y``), and likewise for
    ``fmax``. With valid input (``valid = 1``: finite waypoints, finite limits > 0) the
    values that reach them are finite or ``+inf`` (the knots dropped), except where the
    engine's formulas make a NaN in a branch an ``if_else`` then discards (a joint at rest:
    ``0 / 0``); the residual's NaN is told by its sum, not by ``fmax``. The test
    (tests/planning/test_closed_graph.py) asserts the library gives the VM's values, joints
    at rest included; with ``valid = 0`` the values are anything (the caller does not read
    them)."""
    for old, new in (
        ("return fmin(x, y);", "return x<y ? x : y;"),
        ("return fmax(x, y);", "return x>y ? x : y;"),
    ):
        if old not in code:  # a casadi whose helpers changed: compile them as they are
            return code
        code = code.replace(old, new)
    return code


#: the closed-form graph family (:mod:`armlab._compiled`)
GRAPH = _compiled.Graph(
    _compiled.Spec(
        name="closed",
        build=_build,
        symbol=_symbol,
        sources=_SOURCES,
        cflags=CFLAGS,
        inputs=lambda n: ((2, n), (7 * n,)),
        output=lambda n: layout(n)["size"],
        patch=_inline_minmax,
        what="the closed-form plan's graph",
    )
)


def status(n: int) -> str:
    """How problems of ``n`` joints are evaluated: ``"compiled"``, ``"vm"`` (with the reason
    where the compile failed, or ``"vm, compiling"``), or ``"unused"``."""
    return GRAPH.status(n)


def prepare(n: int) -> str:
    """Make the graph of ``n`` joints ready now (the cached library, else the VM with the
    compile started in the background); its :func:`status`."""
    return GRAPH.prepare(n)


def build(n: int):
    """The graph of ``n`` joints run by CasADi's VM, built once per process."""
    return GRAPH.build(n)


def compile_library(n: int, environ: Mapping[str, str] | None = None) -> Path:
    """The compiled graph of ``n`` joints, built now unless the cache holds it; its path.

    Raises
    ------
    armlab._cache.CompilerUnavailable
        No C compiler, or the compile failed.
    """
    return GRAPH.compile_library(n, environ)


def evaluate(W: np.ndarray, P: np.ndarray) -> np.ndarray:
    """The output (:func:`layout`) of the waypoints ``W`` (a ``(2, n)`` float array: start,
    goal) under the parameters ``P`` (``7 n`` floats), a fresh array: by the graph (VM or
    compiled; the graph of ``n`` joints made ready first if it is not), or with
    ``$ARMLAB_SCURVE_GRAPH=off`` by :func:`evaluate_numpy`."""
    slot = GRAPH.bound(W.shape[-1]) if _compiled.available() else None
    if slot is None:
        return evaluate_numpy(W, P)
    trigger, (w, p), out = slot
    w[...] = W
    p[...] = P
    trigger()
    return out.copy()


def evaluate_numpy(W, P) -> np.ndarray:
    """:func:`evaluate` by numpy: the same functions as the graph, on arrays, in
    :func:`~armlab.planning.optimal_closed.closed_form_optimal`'s steps (the engine always by
    numpy, whatever ``$ARMLAB_SCURVE_GRAPH`` says); padding rows 0."""
    W = np.asarray(W, float).reshape(2, -1)
    n = W.shape[1]
    v, a, j, lo, hi, centre, half = np.asarray(P, float).reshape(7, n)
    lay = layout(n)
    out = np.zeros(lay["size"])
    with np.errstate(invalid="ignore"):
        valid = bool(_valid(NP, W[0], W[1], v, a, j, lo, hi))
    out[2] = valid
    if not valid:
        return out
    D = W[1:] - W[:-1]
    b = _batch._numpy_batch(D, v, a, j, D.shape)
    T = float(b.duration[0])
    t = _closed._knots(b.boundaries()[0, :, 0], T)
    q, qd, qdd, J = (x[:, 0] for x in b.evaluate_jerk(t))
    q += W[0]
    q[-1], qd[-1], qdd[-1], J[-1] = W[1], 0.0, 0.0, 0.0
    arrived, residual, ratios, at_s = _closed.exact_check(
        NP, b.peaks_flat(), D.reshape(-1), v, a, j, W[0], W[1], centre, half, T
    )
    residual = float(residual)
    ratio = np.concatenate([ratios[kind] for kind in KINDS])
    bind = np.concatenate([ratios[kind] >= BINDING for kind in BIND_KINDS])
    m = t.size
    ok = bool((ratio <= 1.0 + CHECK_TOL).all())
    out[:9] = (m, T, valid, bool(arrived), ok, bind.sum(), residual, 0.0, T)
    for name, x in (("t", t), ("q", q), ("qd", qd), ("qdd", qdd), ("qddd", J)):
        o = lay[name][0]
        out[o : o + x.size] = x.reshape(-1)
    out[slice(*lay["ratio"])] = ratio
    out[slice(*lay["at"])] = np.concatenate([at_s[kind] for kind in KINDS])
    out[slice(*lay["bind"])] = bind
    return out
