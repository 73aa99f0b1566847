"""The synchronised double S engine of ONE problem as a CasADi SX graph, run by CasADi's virtual
machine or, where a C compiler exists, compiled once per joint count and cached on disk.

:func:`armlab.trajectory.profiles.synchronised_scurves` of one problem (``n`` joints, every
jerk finite) is a few hundred numpy calls on arrays of ``n`` values: about 100 us with the
phase table and the peak check, for a few microseconds of arithmetic. This module evaluates the
same formulas -- the engine's own functions (``_synchronise``, ``_phase_table``,
``_peak_table`` of :mod:`.batch`, the kernels of :mod:`.timing`), written once against a
backend (:mod:`.ops`) and here given CasADi SX symbols instead of arrays -- as one
:class:`casadi.Function` per ``n``, through :meth:`casadi.Function.buffer` (bound numpy arrays,
no conversion per call).

Input ``x (4, n)``: ``D, v_max, a_max, j_max``. Output, one flat array of ``2 + 72 n``:

* ``T`` (1); ``t_min, v, a, tj, ta, tv`` (``6 n``);
* the phase table of :meth:`.SCurveBatch.boundaries` (``6 x 7 x n``, C order);
* the steps ``dv, ds`` of each phase (``2 x 7 x n``);
* :meth:`.SCurveBatch.peaks_flat` (``10 x n``, keys in :data:`.batch.PEAK_KEYS` order);
* 1 if every input is valid (``D`` finite, limits finite and > 0), else 0 (the caller then
  takes the numpy path, which names the error, or builds the trapezoids of ``j = inf``).

The numbers equal the numpy evaluation's to round-off (within 1e-15 of each quantity's scale
in the tests, not bit for bit: glibc's ``pow`` and ``asin`` differ from numpy's by an ulp at
times).

How the graph is run (``$ARMLAB_SCURVE_GRAPH``, read at import and by :func:`reset`):

* ``auto`` (default): the compiled library of ``n`` joints if the cache holds it; else the
  graph run by CasADi's VM (about 10 us per problem), while its C code is generated and
  compiled (``gcc -O1``, about 1.1 s for 6 joints, once per machine, the gcc process beside the
  caller), after which calls use the library (about 4 us);
* ``vm``: the VM only (no compile);
* ``off``: no graph; the numpy evaluation for one problem too.

Every problem of ``n`` joints with finite jerks is evaluated by the graph, the first one too,
so a result never depends on when it was asked for: the first problem of ``n`` joints in a
process makes the graph ready in the call -- it loads the compiled library (about 1 ms: the
key, ``dlopen`` through :func:`casadi.external`) or builds the graph for the VM (20-25 ms for 6
joints, once per process) and starts the compile in a background thread, after which calls use
the library. The VM and the library give the same values (measured: 2000 random 6-joint
problems, every output equal, signed zeros aside), so the switch changes no number. An
earlier version evaluated the first problems by numpy while the graph loaded: the same
formulas, but equal only to round-off, so two runs of one study could differ in the last bits
depending on a thread's timing. :func:`prepare` makes the graph ready ahead of a first call
(benchmarks).

Where no compiler exists (:func:`armlab._cache.compiler`) or the compile fails, the VM stays in
use (:func:`status` says why). The library is keyed by everything its code depends on (the
source of the formulas' modules, the casadi version, the compiler, the flags, the platform,
``n``) and written atomically (compiled into a temporary folder in the cache, then renamed), so
parallel processes never load a half-written file.

Each thread has its own bound buffers (a ``threading.local``): Dask's threads may call at once.
The activation, the cache key, the compile, the status, the buffers and the fork handling are
:mod:`armlab._compiled`'s (shared with the closed-form plan's graph,
:mod:`armlab.planning.closed_graph`); this module is the S-curve graph's
:class:`~armlab._compiled.Spec`.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from armlab import _compiled
from armlab._compiled import available, reset
from armlab._lazy import lazy_import

ca = lazy_import("casadi")

__all__ = [
    "CFLAGS",
    "GRAPH",
    "available",
    "build",
    "compile_library",
    "engine",
    "evaluate",
    "library_path",
    "load_compiled",
    "prepare",
    "reset",
    "status",
    "unpack",
]

#: compiler flags of the graph's library: -O2/-O3 measured no faster than -O1 (3.2/3.3 us
#: against 2.8 us per 6-joint problem); ``-fno-semantic-interposition`` lets the shared
#: library call its own functions directly (a third less time in a C harness of the graph);
#: ``-ffp-contract=off`` keeps every multiply and add separately rounded, as the VM does, so
#: the library gives the VM's values (no fused multiply-add where the target has one)
CFLAGS = ("-O1", "-fPIC", "-shared", "-fno-semantic-interposition", "-ffp-contract=off")
#: the modules whose source the graph is generated from (its cache key hashes them)
_SOURCES = ("ops.py", "timing.py", "batch.py", "graph.py")


def engine(D, v, a, j) -> tuple:
    """The engine of one problem on SX columns of ``n`` joints (every jerk finite): the
    results of :func:`synchronised_scurves` ``(T, t_min, v, a, tj, ta, tv)``, the phase table
    (six ``(7, n)`` rows, :meth:`.SCurveBatch.boundaries`), its steps ``(dv, ds)`` and the
    peaks (:meth:`.SCurveBatch.peaks_flat`, ``(1, n)`` each): the engine's own functions of
    :mod:`.batch` given symbols. This graph and the closed-form plan's
    (:mod:`armlab.planning.closed_graph`) are built on it."""
    from armlab.trajectory.profiles.batch import _peak_table, _phase_table, _synchronise
    from armlab.trajectory.profiles.ops import sx
    from armlab.trajectory.profiles.timing import _DoubleSLimits

    L = ca.fabs(D)
    SX = sx()
    results = _synchronise(L, v, a, j, _DoubleSLimits(a, j, True, SX), L > 0)
    _, _, _, ap, tj, ta, tv = results
    table: list = [None] * 6
    steps = _phase_table(SX, tj, ta, tv, ap, j, table)
    return results, table, steps, _peak_table(SX, *table, *steps)


def _build(n: int):
    from armlab.trajectory.profiles.batch import PEAK_KEYS

    x = ca.SX.sym("x", n, 4)  # column-major: the rows of a C-ordered (4, n) array
    D, v, a, j = (x[:, c] for c in range(4))
    results, table, steps, peaks = engine(D, v, a, j)
    out = list(results)
    out += [ca.vec(m.T) for m in (*table, *steps)]  # (7, n) in C order
    out += [peaks[key].T for key in PEAK_KEYS]
    # 1 where every value is valid and every jerk finite (comparisons with NaN are false)
    inf = ca.inf
    ok = [ca.fabs(D) < inf] + [ca.logic_and(x > 0, x < inf) for x in (v, a, j)]
    out.append(ca.mmin(ca.vertcat(*ok)))
    return ca.Function(_symbol(n), [x], [ca.vertcat(*out)], ["x"], ["out"])


def _symbol(n: int) -> str:
    return f"armlab_scurve_{n}"


#: the S-curve graph family (:mod:`armlab._compiled`)
GRAPH = _compiled.Graph(
    _compiled.Spec(
        name="scurve",
        build=_build,
        symbol=_symbol,
        sources=tuple(Path(__file__).parent / name for name in _SOURCES),
        cflags=CFLAGS,
        inputs=lambda n: ((4, n),),
        output=lambda n: 2 + 72 * n,
        what="the S-curve graph",
    )
)


def status(n: int) -> str:
    """How problems of ``n`` joints are evaluated: ``"compiled"``, ``"vm"`` (with the reason
    where the compile failed, or ``"vm, compiling"``), or ``"unused"``."""
    return GRAPH.status(n)


def prepare(n: int) -> str:
    """Make the graph of ``n`` joints ready now (the compiled library if the cache holds it,
    else the VM, with the compile started in the background); its :func:`status`. The first
    problem of ``n`` joints of a process does this too (module docstring)."""
    return GRAPH.prepare(n)


def build(n: int):
    """The graph of ``n`` joints (module docstring) run by CasADi's VM, built once per process."""
    return GRAPH.build(n)


def unpack(r: np.ndarray, shape: tuple[int, ...]) -> tuple:
    """The graph's output ``r`` (:func:`evaluate`, laid out as :func:`build` makes it) for a
    problem of ``shape`` (``(..., n)``, leading axes of size 1) as views: ``T``
    (``shape[:-1]``), the six per-joint arrays ``t_min, v, a, tj, ta, tv`` (``(6,) + shape``),
    the phase table (``(6, 7) + shape``), the steps ``dv, ds`` (``(2, 7) + shape``), the peak
    rows (``(10, n)``, :data:`.batch.PEAK_KEYS`). The last value, the validity flag, is
    ``r[-1]``."""
    n = shape[-1]
    return (
        r[0:1].reshape(shape[:-1]),
        r[1 : 1 + 6 * n].reshape((6,) + shape),
        r[1 + 6 * n : 1 + 48 * n].reshape((6, 7) + shape),
        r[1 + 48 * n : 1 + 62 * n].reshape((2, 7) + shape),
        r[1 + 62 * n : 1 + 72 * n].reshape(10, n),
    )


def library_path(n: int, cc: str, root: Path | None = None) -> Path:
    """Where the compiled graph of ``n`` joints built by ``cc`` lives in the cache (``root``:
    :func:`armlab._cache.cache_dir`)."""
    return GRAPH.library_path(n, cc, root)


def compile_library(n: int, environ: Mapping[str, str] | None = None) -> Path:
    """The compiled graph of ``n`` joints, built now unless the cache holds it (about 1.2 s
    for 6 joints); the path of the library. ``environ``: the environment whose compiler and
    cache folder are used (default the process').

    Raises
    ------
    armlab._cache.CompilerUnavailable
        No C compiler, or the compile failed.
    """
    return GRAPH.compile_library(n, environ)


def load_compiled(n: int, so: Path):
    """The compiled graph of ``n`` joints from its library ``so``."""
    return GRAPH.load_compiled(n, so)


def evaluate(D, v, a, j) -> np.ndarray | None:
    """The graph's output (module docstring) for one problem, a fresh array of ``2 + 72 n``;
    ``D, v, a, j`` float arrays of ``n`` joints (leading axes of size 1 allowed); the graph
    of ``n`` joints made ready first if it is not (:func:`prepare`). None where a
    :func:`reset` came between (tests): the caller evaluates with numpy this once."""
    slot = GRAPH.bound(D.shape[-1])
    if slot is None:
        return None
    trigger, (x,), out = slot
    x[0], x[1], x[2], x[3] = D, v, a, j
    trigger()
    return out.copy()
