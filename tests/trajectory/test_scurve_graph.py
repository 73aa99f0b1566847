"""The S-curve engine of one problem as a CasADi graph (armlab.trajectory.profiles.graph): the
same numbers as the numpy evaluation of the same formulas, by CasADi's VM and compiled, in
threads, and where no compiler exists."""

from __future__ import annotations

import multiprocessing
import time

import numpy as np
import pytest

from armlab.errors import InputError
from armlab.trajectory.profiles import graph, synchronised_scurves
from cases import compiled_into_tmp, graph_mode, in_threads

JOINT = ("t_min", "v", "a", "tj", "ta", "tv")
TABLE = ("t0", "s0", "v0", "d", "acc", "jrk")
#: the physical scale each output is measured on: durations on the problem's duration T,
#: speeds on its largest peak speed, and so on (per problem, over its joints)
SCALE = {
    "T": "T", "t_min": "T", "tj": "T", "ta": "T", "tv": "T", "t0": "T", "d": "T",
    "velocity_at_s": "T", "acceleration_at_s": "T", "jerk_at_s": "T",
    "v": "v", "v0": "v", "velocity": "v", "reverse": "v", "end_velocity": "v",
    "a": "a", "acc": "a", "acceleration": "a", "end_acceleration": "a",
    "jrk": "j", "jerk": "j", "s0": "s", "end_position": "s",
}  # fmt: skip
#: scaled tolerance: |graph - numpy| <= TOL x the scale of that quantity in that problem
#: (element-wise relative fails on round-off-sized values: a clamp like
#: tv = max(T - 2 ta, 0) gives 2e-16 in one evaluation and 0 in the other)
TOL = 1e-14


def problems(N, n, seed):
    """Random problems: moves over nine decades (tiny moves), 20 % joints at rest, 3 % whole
    problems at rest; limits such that some joints reach a_max, some cruise, some set T."""
    r = np.random.default_rng(seed)
    D = r.uniform(-2, 2, (N, n)) * 10.0 ** r.uniform(-9, 0, (N, n))
    D[r.random((N, n)) < 0.2] = 0.0
    D[r.random(N) < 0.03] = 0.0
    v = r.uniform(0.3, 3, (N, n))
    a = r.uniform(0.5, 10, (N, n))
    j = r.uniform(2, 300, (N, n))
    return D, v, a, j


def quantities(b):
    """Every output of a batch by quantity, problems first: name -> (N, joints) (the phase
    table's rows (N, 7 x joints))."""
    n = b.distance.shape[-1]
    out = {"T": np.reshape(b.duration, (-1, 1))}
    for name in JOINT:
        out[name] = getattr(b, name).reshape(-1, n)
    table = b.boundaries().reshape(6, 7, -1, n)
    for r, name in enumerate(TABLE):
        out[name] = np.moveaxis(table[r], 1, 0).reshape(-1, 7 * n)
    for k, x in b.peaks_flat().items():
        out[k] = x.reshape(-1, n)
    assert set(out) == set(SCALE)
    return out


def assert_close(got, ref):
    """The scaled comparison (``TOL``, ``SCALE``) of every problem; NaN in both or in neither."""
    scales = {
        "T": np.abs(ref["T"]).max(axis=1),
        "v": np.abs(ref["velocity"]).max(axis=1),
        "a": np.abs(ref["acceleration"]).max(axis=1),
        "j": np.abs(ref["jerk"]).max(axis=1),
        "s": np.abs(ref["end_position"]).max(axis=1),
    }
    for name, y in ref.items():
        x = got[name]
        assert x.shape == y.shape, name
        assert np.array_equal(np.isnan(x), np.isnan(y)), name
        err = np.nanmax(np.abs(x - y), axis=1, initial=0.0)
        bad = err > TOL * scales[SCALE[name]]
        assert not bad.any(), (name, np.flatnonzero(bad)[:5], err[bad][:5])


def singles(D, v, a, j):
    """Every problem alone (the graph), stacked like a batch's quantities."""
    got = []
    for i in range(D.shape[0]):
        one = synchronised_scurves(D[i] if i % 2 else D[i : i + 1], v[i], a[i], j[i])
        assert one.jerk_finite
        got.append(quantities(one))
    return {k: np.concatenate([g[k] for g in got]) for k in got[0]}


@pytest.fixture
def mode(monkeypatch):
    """Set ``$ARMLAB_SCURVE_GRAPH`` for one test (:func:`cases.graph_mode`)."""
    yield from graph_mode(monkeypatch)


def compare_singles(D, v, a, j):
    """Every problem alone (the graph) against the batch (the numpy evaluation)."""
    assert_close(singles(D, v, a, j), quantities(synchronised_scurves(D, v, a, j)))


def test_vm_matches_the_numpy_evaluation(mode):
    mode("vm")
    assert graph.prepare(6) == "vm"
    D, v, a, j = problems(2000, 6, seed=1)
    compare_singles(D, v, a, j)
    assert graph.status(6) == "vm"
    # the regimes the set covers (else the comparison would prove less than it says)
    b = synchronised_scurves(D, v, a, j)
    moving = b.v > 0
    assert (moving & (b.a >= b.a_max * (1 - 1e-12))).mean() > 0.05  # a_max reached
    assert (moving & (b.a < b.a_max * (1 - 1e-6))).mean() > 0.05  # not reached
    assert (moving & (b.tv > 0)).mean() > 0.3  # cruise
    assert np.isclose(b.t_min, b.duration[:, None], rtol=0, atol=0).mean() > 0.1  # set T
    assert (b.duration == 0).any()  # whole problems at rest


def test_vm_on_other_joint_counts(mode):
    mode("vm")
    for n in (1, 2, 7):
        assert graph.prepare(n) == "vm"
        compare_singles(*problems(200, n, seed=n))


def test_hand_checked_problem(mode):
    """One joint, 1 rad, v 1, a 2, j 10: a/j = 0.2 s, the plateau is reached (v j = 10 >= a^2
    = 4), Ta = 0.2 + 1/2 = 0.7 s, T = L / v + Ta = 1.7 s (Biagiotti & Melchiorri §3.4), the
    cruise T - 2 Ta = 0.3 s; the peaks are v, a, j, and the end is at 1 rad at rest."""
    mode("vm")
    graph.prepare(1)
    b = synchronised_scurves([1.0], [1.0], [2.0], [10.0])
    assert graph.status(1) == "vm"
    assert b.duration == pytest.approx(1.7, abs=1e-14)
    assert (b.tj[0], b.ta[0], b.tv[0]) == pytest.approx((0.2, 0.7, 0.3), abs=1e-14)
    pk = b.peaks_flat()
    assert (pk["velocity"][0], pk["acceleration"][0], pk["jerk"][0]) == pytest.approx(
        (1.0, 2.0, 10.0), abs=1e-13
    )
    assert pk["velocity_at_s"][0] == pytest.approx(0.7, abs=1e-14)  # the cruise starts
    assert pk["end_position"][0] == pytest.approx(1.0, abs=1e-14)
    assert abs(pk["end_velocity"][0]) < 1e-14


def test_trapezoids_and_bad_input_take_the_numpy_path(mode):
    mode("vm")
    graph.prepare(2)
    graph.prepare(1)
    b = synchronised_scurves([1.0, 0.5], [1.0, 1.0], [2.0, 2.0], [np.inf, 10.0])
    assert not b.jerk_finite
    assert b.duration == pytest.approx(1.5, abs=1e-14)  # the trapezoid: L / v + v / a
    with pytest.raises(InputError, match="distances must be finite"):
        synchronised_scurves([np.nan, 1.0], 1.0, 1.0, 1.0)
    with pytest.raises(InputError, match="j_max must be > 0"):
        synchronised_scurves([1.0, 1.0], [1.0, 1.0], [1.0, 1.0], [1.0, -1.0])
    with pytest.raises(InputError, match="a_max must be > 0 and finite"):
        synchronised_scurves([1.0], [1.0], [np.inf], [1.0])


def run_in_threads(n):
    """Four threads evaluating different problems of ``n`` joints at once: each gets its own
    results (a shared buffer would hand one thread another's problem)."""
    D, v, a, j = problems(40, n, seed=7)
    want = quantities(synchronised_scurves(D, v, a, j))

    def work(k):
        for _ in range(20):
            assert_close(singles(D, v, a, j), want)

    in_threads(work, 4)


def test_threads_get_their_own_buffers(mode):
    mode("vm")
    graph.prepare(6)
    run_in_threads(6)


def wait_status(n, busy=("vm, compiling",), timeout=60.0):
    """The status of ``n`` joints once it is no longer one of ``busy``."""
    end = time.monotonic() + timeout
    while graph.status(n) in busy and time.monotonic() < end:
        time.sleep(0.05)
    return graph.status(n)


def test_without_a_compiler_the_vm_is_used(mode, tmp_path):
    mode("auto", CC=str(tmp_path / "no-such-cc"), ARMLAB_CACHE_DIR=str(tmp_path / "cache"))
    assert graph.prepare(3).startswith("vm")  # the compile fails in the background
    D, v, a, j = problems(50, 3, seed=3)
    compare_singles(D, v, a, j)
    status = wait_status(3)
    assert status.startswith("vm (no C compiler"), status
    compare_singles(D, v, a, j)
    assert not (tmp_path / "cache" / "scurve").exists() or not any(
        (tmp_path / "cache" / "scurve").iterdir()
    )


@pytest.fixture(scope="module")
def compiled_cache(tmp_path_factory):
    """The graph of 4 joints compiled once into a temporary cache
    (:func:`cases.compiled_into_tmp`)."""
    yield from compiled_into_tmp(tmp_path_factory, graph.compile_library, 4)


def test_compiled_matches_the_numpy_evaluation(compiled_cache, mode, monkeypatch):
    mode("auto", ARMLAB_CACHE_DIR=str(compiled_cache.parent.parent))
    assert graph.prepare(4) == "compiled"  # loaded from the cache, not built again
    D, v, a, j = problems(1000, 4, seed=11)
    compare_singles(D, v, a, j)


def test_compiled_gives_the_vms_values(compiled_cache, mode):
    """The VM and the library evaluate the same graph: equal values (signed zeros aside), so
    the switch from the VM to the library when its compile ends changes no result (no
    floating-point contraction in the library: ``-ffp-contract=off``)."""
    D, v, a, j = problems(300, 4, seed=12)
    mode("vm")
    vm = [graph.evaluate(*x) for x in zip(D, v, a, j, strict=True)]
    mode("auto", ARMLAB_CACHE_DIR=str(compiled_cache.parent.parent))
    assert graph.prepare(4) == "compiled"
    for i, x in enumerate(zip(D, v, a, j, strict=True)):
        np.testing.assert_array_equal(graph.evaluate(*x), vm[i], err_msg=f"problem {i}")


def test_threads_on_the_compiled_graph(compiled_cache, mode):
    mode("auto", ARMLAB_CACHE_DIR=str(compiled_cache.parent.parent))
    assert graph.prepare(4) == "compiled"
    run_in_threads(4)


def test_the_cache_holds_one_finished_library(compiled_cache, monkeypatch):
    """The library is where its key says, written once (a second request reuses it), and no
    temporary file of the build is left beside it."""
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(compiled_cache.parent.parent))
    stamp = compiled_cache.stat().st_mtime_ns
    assert graph.compile_library(4) == compiled_cache
    assert compiled_cache.stat().st_mtime_ns == stamp
    assert [p.name for p in compiled_cache.parent.iterdir()] == [compiled_cache.name]
    # the key follows the compiler and the joint count
    from armlab._cache import compiler

    assert graph.library_path(4, compiler()) == compiled_cache
    assert graph.library_path(5, compiler()) != compiled_cache
    assert graph.library_path(4, compiler() + "x") != compiled_cache


def test_first_problem_by_the_graph_too(mode):
    """Unprepared, the first problem of a joint count is evaluated by the graph as every
    later one (the graph is made ready in the call): a result does not depend on when it
    was asked for. The same problem first and again gives the same values; both within
    round-off of the numpy evaluation of the batch."""
    mode("vm")
    D, v, a, j = problems(20, 5, seed=5)
    ref = quantities(synchronised_scurves(D, v, a, j))
    first = quantities(synchronised_scurves(D[0], v[0], a[0], j[0]))
    assert graph.status(5) == "vm"
    again = quantities(synchronised_scurves(D[0], v[0], a[0], j[0]))
    for k, x in first.items():
        np.testing.assert_array_equal(x, again[k], err_msg=k)
    assert_close(singles(D, v, a, j), ref)


def _child_duration(args):
    return float(synchronised_scurves(*args).duration)


def test_a_forked_worker_evaluates_with_the_graph(mode):
    """A forked process (multiprocessing, Dask's process workers) evaluates with the graph
    it inherited and gets the same numbers."""
    mode("vm")
    args = ([1.0, 0.3], [1.0, 1.0], [2.0, 2.0], [10.0, 10.0])
    synchronised_scurves(*args)  # makes the graph ready in the call
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(1) as pool:
        T = pool.map(_child_duration, [args] * 3)
    assert T == pytest.approx([1.7] * 3, abs=1e-14)  # as test_hand_checked_problem


def test_off_evaluates_one_problem_with_numpy(mode):
    mode("off")
    b = synchronised_scurves([1.0], [1.0], [2.0], [10.0])
    assert graph.status(1) == "unused"
    assert b.duration == pytest.approx(1.7, abs=1e-14)


def test_no_joints_and_scalar_limits(mode):
    """No joints: the numpy path's empty profiles (duration 0); scalar limits broadcast onto
    the joints as in a batch (two joints of 1 and 2 rad at v = a = j = 1: the 2-rad joint sets
    T = L / v + Ta, Ta = a / j + v / a = 2 s, so T = 4 s)."""
    mode("vm")
    graph.prepare(2)
    b = synchronised_scurves(np.zeros((1, 0)), 1.0, 1.0, 1.0)
    assert b.duration.shape == (1,) and b.duration[0] == 0.0
    b = synchronised_scurves([1.0, 2.0], 1.0, 1.0, 1.0)
    assert b.duration == pytest.approx(4.0, abs=1e-14)
    assert b.j.shape == b.a_max.shape == (2,)
