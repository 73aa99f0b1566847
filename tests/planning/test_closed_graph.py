"""The 2-waypoint closed-form plan as one CasADi graph (armlab.planning.closed_graph): the
graph (VM and compiled) gives the numpy evaluation's layout to round-off, the numpy evaluation
is closed_form_optimal's result, invalid input is flagged, and the graph runs in threads,
without a compiler and not at all (``$ARMLAB_SCURVE_GRAPH=off``)."""

from __future__ import annotations

import multiprocessing
import time

import numpy as np
import pytest

from armlab.planning import closed_graph as cg
from armlab.planning import optimal
from armlab.trajectory.waypoints import RANGE_TOL_RAD
from cases import compiled_into_tmp, graph_mode, in_threads

#: |graph - numpy| <= TOL x the scale of the quantity (its largest magnitude in the problem)
TOL = 1e-13
#: the head's exact fields: m, valid, exact_ok, ok, nbind
FLAGS = (0, 2, 3, 4, 5)


def params(robot) -> np.ndarray:
    """The parameter vector ``P`` of ``robot`` (module docstring of closed_graph)."""
    L = robot.limits
    centre, half = L.centre_half_rad()
    return np.concatenate(
        [
            L.velocity_rad_s,
            L.acceleration_rad_s2,
            L.jerk_rad_s3,
            L.lower_rad - RANGE_TOL_RAD,
            L.upper_rad + RANGE_TOL_RAD,
            centre,
            half,
        ]
    )


def problems(robot, N, seed):
    """Random waypoint pairs inside 70 % of the ranges; every 10th with one joint still, every
    15th with all but one still, every 20th a 1e-6 rad move of every joint."""
    L = robot.limits
    lo, hi = L.lower_rad, L.upper_rad
    n = robot.n_joints
    r = np.random.default_rng(seed)
    out = []
    for i in range(N):
        W = (lo + hi) / 2 + (hi - lo) / 2 * 0.7 * (2 * r.random((2, n)) - 1)
        if i % 10 == 3:
            k = r.integers(n)
            W[1, k] = W[0, k]
        if i % 15 == 4:
            W[1, 1:] = W[0, 1:]
        if i % 20 == 5:
            W[1] = W[0] + 1e-6 * np.sign(r.standard_normal(n))
        out.append(W)
    return out


def fields(out, n):
    """The used part of every field of one output: name -> array (``t`` and the samples cut
    to ``m`` rows)."""
    lay = cg.layout(n)
    m = int(out[0])
    got = {}
    for name in ("t", "q", "qd", "qdd", "qddd", "ratio", "at", "bind"):
        x = out[slice(*lay[name])]
        if name == "t":
            x = x[:m]
        elif name in ("q", "qd", "qdd", "qddd"):
            x = x[: m * n]
        got[name] = x
    got["T"] = out[1:2]
    got["residual"] = out[6:7]
    return got


def assert_layout_close(got, ref, n, what=""):
    """Flags and m equal; every quantity within TOL of its scale (times on T, the samples on
    their largest magnitude, the residual absolutely)."""
    np.testing.assert_array_equal(got[list(FLAGS)], ref[list(FLAGS)], err_msg=what)
    assert ref[2] == 1, what  # only valid problems are compared value by value
    a, b = fields(got, n), fields(ref, n)
    T = float(ref[1])
    for name, y in b.items():
        x = a[name]
        scale = T if name in ("t", "at", "T") else 1.0 if name == "residual" else np.abs(y).max()
        err = np.abs(x - y).max()
        assert err <= TOL * max(scale, 1e-300), (what, name, err, scale)


@pytest.fixture
def mode(monkeypatch):
    """Set ``$ARMLAB_SCURVE_GRAPH`` for one test (:func:`cases.graph_mode`)."""
    yield from graph_mode(monkeypatch)


def test_layout_sizes():
    """6 joints: 38 slots; 9 + 38 + 4 x 38 x 6 + 4 x 6 + 4 x 6 + 3 x 6 = 1025 values."""
    lay = cg.layout(6)
    assert lay["S"] == 38 and lay["size"] == 1025
    assert lay["head"] == (0, 9) and lay["t"] == (9, 47) and lay["bind"] == (1007, 1025)


def test_hand_checked_problem(mode):
    """One joint, 1 rad, v 1, a 2, j 10 (test_scurve_graph's problem): a/j = 0.2 s, Ta = 0.7 s,
    T = 1.7 s; the knots 0, 0.2, 0.5, 0.7, 1.0, 1.2, 1.5, 1.7 (m = 8); at 0.7 s the cruise
    starts at v = 1 with a = 0 from q = v Ta / 2 = 0.35 rad; ratios 1 for v, a, j (binding:
    3), position |1 - 0| / 2 = 0.5 at T (range [-2, 2])."""
    mode("vm")
    W = np.array([[0.0], [1.0]])
    P = np.array([1.0, 2.0, 10.0, -2.0, 2.0, 0.0, 2.0])
    for out in (cg.evaluate(W, P), cg.evaluate_numpy(W, P)):
        assert out[0] == 8 and out[2:6].tolist() == [1.0, 1.0, 1.0, 3.0]
        assert out[1] == pytest.approx(1.7, abs=1e-14)
        f = fields(out, 1)
        np.testing.assert_allclose(f["t"], [0, 0.2, 0.5, 0.7, 1.0, 1.2, 1.5, 1.7], atol=1e-14)
        assert (f["q"][3], f["qd"][3], f["qdd"][3]) == pytest.approx((0.35, 1.0, 0.0), abs=1e-14)
        assert (f["q"][-1], f["qd"][-1], f["qddd"][-1]) == (1.0, 0.0, 0.0)  # the goal at rest
        np.testing.assert_allclose(f["ratio"], [0.5, 1.0, 1.0, 1.0], atol=1e-13)
        assert f["at"][0] == out[1] and f["bind"].tolist() == [1.0, 1.0, 1.0]
    assert cg.status(1) == "vm"


def test_numpy_layout_is_the_closed_form_result(teachbot6):
    """The numpy evaluation fills the layout with closed_form_optimal's own result (what
    optimal() returns for a 2-waypoint rest-to-rest plan without torque limit): the knots,
    the samples, the report, the residual, the binding count."""
    P = params(teachbot6)
    for W in problems(teachbot6, 25, seed=3):
        out = cg.evaluate_numpy(W, P)
        traj = optimal(teachbot6, W, tau_max=False)
        assert traj.stats["method"] == "closed_form"
        f = fields(out, 6)
        m = int(out[0])
        assert m == traj.t.size
        for name in ("t", "q", "qd", "qdd", "qddd"):
            np.testing.assert_allclose(f[name], getattr(traj, name).reshape(-1), atol=1e-15)
        ratios = np.concatenate([traj.report.ratios[k] for k in cg.KINDS])
        np.testing.assert_allclose(f["ratio"], ratios, atol=1e-15)
        at = np.concatenate([traj.report.at_s[k] for k in cg.KINDS])
        np.testing.assert_allclose(f["at"], at, atol=1e-15)
        assert out[5] == len(traj.stats["binding"])
        assert out[6] == pytest.approx(traj.stats["arrival_residual"], abs=1e-15)
        assert out[3] == out[4] == 1 and traj.stats["ok"]


def test_vm_matches_the_numpy_evaluation(mode, teachbot6):
    mode("vm")
    P = params(teachbot6)
    ws = problems(teachbot6, 300, seed=1)
    for i, W in enumerate(ws):
        assert_layout_close(cg.evaluate(W, P), cg.evaluate_numpy(W, P), 6, f"problem {i}")
    assert cg.status(6) == "vm"


def test_other_joint_counts(mode):
    """1, 2 and 7 joints under random limits, against the numpy evaluation."""
    mode("vm")
    r = np.random.default_rng(8)
    for n in (1, 2, 7):
        for i in range(40):
            v, a, j = r.uniform(0.3, 3, n), r.uniform(0.5, 10, n), r.uniform(2, 300, n)
            lo, hi = -np.full(n, 3.0), np.full(n, 3.0)
            P = np.concatenate([v, a, j, lo, hi, np.zeros(n), np.full(n, 3.0)])
            W = r.uniform(-2.5, 2.5, (2, n))
            still = r.random(n) < 0.2
            still[0] = False  # one joint moves at least
            W[1, still] = W[0, still]
            assert_layout_close(cg.evaluate(W, P), cg.evaluate_numpy(W, P), n, f"{n} {i}")


@pytest.mark.parametrize(
    "change",
    ["nan", "inf", "below", "above", "coincide", "near", "v0", "jinf"],
)
def test_invalid_input_is_flagged(mode, teachbot6, change):
    """valid = 0 where optimal() would refuse the waypoints (not finite, outside the range plus
    its tolerance, coinciding within 1e-12 rad in every joint) or a limit is not finite and
    > 0; no exception, in the graph and the numpy evaluation."""
    mode("vm")
    P = params(teachbot6)
    W = problems(teachbot6, 1, seed=4)[0]
    lo = teachbot6.limits.lower_rad
    if change == "nan":
        W[1, 3] = np.nan
    elif change == "inf":
        W[0, 2] = np.inf
    elif change == "below":
        W[0, 0] = lo[0] - 2 * RANGE_TOL_RAD
    elif change == "above":
        W[1, 4] = teachbot6.limits.upper_rad[4] + 1e-3
    elif change == "coincide":
        W[1] = W[0]
    elif change == "near":
        W[1] = W[0] + 5e-13
    elif change == "v0":
        P[1] = 0.0
    else:
        P[2 * 6 + 1] = np.inf
    for out in (cg.evaluate(W, P), cg.evaluate_numpy(W, P)):
        assert out.shape == (cg.layout(6)["size"],)
        assert out[2] == 0
    if change in ("nan", "inf", "below", "above", "coincide", "near"):
        with pytest.raises(Exception) as err:  # noqa: PT011 - optimal()'s own error, named
            optimal(teachbot6, W, tau_max=False)
        assert type(err.value).__name__ == "InputError"


def test_inside_the_range_tolerance_is_valid(mode, teachbot6):
    """A waypoint within RANGE_TOL_RAD outside its range is accepted (as optimal() accepts it)."""
    mode("vm")
    P = params(teachbot6)
    W = problems(teachbot6, 1, seed=5)[0]
    W[0, 0] = teachbot6.limits.lower_rad[0] - 0.5 * RANGE_TOL_RAD
    assert cg.evaluate(W, P)[2] == 1
    optimal(teachbot6, W, tau_max=False)  # accepted


def test_threads_get_their_own_buffers(mode, teachbot6):
    mode("vm")
    P = params(teachbot6)
    ws = problems(teachbot6, 30, seed=7)
    want = [cg.evaluate(W, P) for W in ws]

    def work(k):
        for _ in range(10):
            for W, x in zip(ws, want, strict=True):
                np.testing.assert_array_equal(cg.evaluate(W, P), x)

    in_threads(work, 2)


def _child_head(args):
    return cg.evaluate(*args)[:9].tolist()


def test_a_forked_worker_evaluates_with_the_graph(mode, teachbot6):
    """A forked process evaluates with the graph it inherited: the parent's values."""
    mode("vm")
    args = (problems(teachbot6, 1, seed=10)[0], params(teachbot6))
    want = cg.evaluate(*args)[:9].tolist()
    with multiprocessing.get_context("fork").Pool(1) as pool:
        assert pool.map(_child_head, [args] * 2) == [want] * 2


def test_off_fills_the_layout_with_numpy(mode, teachbot6):
    mode("off")
    P = params(teachbot6)
    W = problems(teachbot6, 1, seed=6)[0]
    np.testing.assert_array_equal(cg.evaluate(W, P), cg.evaluate_numpy(W, P))
    assert cg.prepare(6) == "unused" and cg.status(6) == "unused"


def test_without_a_compiler_the_vm_is_used(mode, tmp_path, teachbot6):
    mode("auto", CC=str(tmp_path / "no-such-cc"), ARMLAB_CACHE_DIR=str(tmp_path / "cache"))
    assert cg.prepare(6).startswith("vm")
    P = params(teachbot6)
    end = time.monotonic() + 60
    while cg.status(6) == "vm, compiling" and time.monotonic() < end:
        time.sleep(0.05)
    assert cg.status(6).startswith("vm (no C compiler"), cg.status(6)
    for W in problems(teachbot6, 20, seed=9):
        assert_layout_close(cg.evaluate(W, P), cg.evaluate_numpy(W, P), 6)


@pytest.fixture(scope="module")
def compiled_cache(tmp_path_factory):
    """The graph of 6 joints compiled once into a temporary cache
    (:func:`cases.compiled_into_tmp`)."""
    yield from compiled_into_tmp(tmp_path_factory, cg.compile_library, 6)


def test_compiled_gives_the_vms_values_and_the_numpy_layout(compiled_cache, mode, teachbot6):
    """The library (ternary fmin/fmax, -ffp-contract=off) evaluates the VM's graph to the
    same values, padding and edge cases (joints at rest, 1e-6 rad moves) included; and so the
    numpy evaluation's layout to round-off."""
    P = params(teachbot6)
    ws = problems(teachbot6, 300, seed=12)
    mode("vm")
    vm = [cg.evaluate(W, P) for W in ws]
    mode("auto", ARMLAB_CACHE_DIR=str(compiled_cache.parent.parent))
    assert cg.prepare(6) == "compiled"
    for i, W in enumerate(ws):
        out = cg.evaluate(W, P)
        np.testing.assert_array_equal(out, vm[i], err_msg=f"problem {i}")
        assert_layout_close(out, cg.evaluate_numpy(W, P), 6, f"problem {i}")
    bad = ws[0].copy()
    bad[1, 2] = np.nan  # the library flags it too (and gathers within its table)
    assert cg.evaluate(bad, P)[2] == 0
    assert [p.name for p in compiled_cache.parent.iterdir()] == [compiled_cache.name]


def test_the_cache_key_holds_the_cpu(monkeypatch):
    """The library is tuned for the CPU (-march=native): another CPU, another file; so is
    the joint count and the compiler."""
    from armlab import _compiled

    path = cg.GRAPH.library_path(6, "gcc")
    assert "-march=native" in cg.CFLAGS
    assert path.parent.name == "closed" and cg.GRAPH.library_path(6, "gcc") == path
    monkeypatch.setattr(_compiled, "cpu_key", lambda: "another CPU")
    assert cg.GRAPH.library_path(6, "gcc") != path
    monkeypatch.undo()
    assert cg.GRAPH.library_path(7, "gcc") != path != cg.GRAPH.library_path(6, "cc")
