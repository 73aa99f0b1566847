"""optimal() on fatrop (compiled stage functions) against IPOPT, the reference, on teachbot6.

The stage library is compiled once for this module into a temporary cache (about 17 s of gcc);
where no compiler is found the compiled-path tests are skipped and the fallback tests still run.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import armlab
from armlab.planning import fatrop_backend, fatrop_stages
from armlab.planning.optimiser import build_optimal
from armlab.planning.transcription import structure
from armlab.trajectory import optimal

# waypoints inside teachbot6's ranges (the scaling cases of bench_trajectory.py are random;
# these are fixed so that the test is the same everywhere)
W3 = np.array(
    [[0, 0, 0, 0, 0, 0], [0.5, -0.3, 0.4, 0.2, -0.6, 0.9], [1.0, 0.2, -0.2, 0.4, 0.3, -0.5]]
)
W2 = np.array([[0.1, -0.2, 0.3, 0.0, 0.2, -0.4], [1.2, 0.3, -0.5, 0.6, -0.4, 1.1]])


@pytest.fixture(scope="module")
def robot():
    return armlab.load_robot("teachbot6")


@pytest.fixture(scope="module")
def compiled(robot, tmp_path_factory):
    """The fatrop path on, with teachbot6's library compiled once into a temporary cache."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("ARMLAB_CACHE_DIR", str(tmp_path_factory.mktemp("armlab-cache")))
        mp.setenv("ARMLAB_SOLVER", "fatrop")
        try:
            so, _ = fatrop_stages.compiled_library(robot)
        except fatrop_stages.FatropUnavailable as exc:
            pytest.skip(f"no fatrop here: {exc}")
        yield so


def _ipopt(mp, robot, w, **kw):
    mp.setenv("ARMLAB_SOLVER", "ipopt")
    traj = optimal(robot, w, **kw)
    mp.setenv("ARMLAB_SOLVER", "fatrop")
    return traj


def _pinocchio_ratios(robot, traj) -> dict[str, float]:
    """Peak |x| / limit on a uniform grid of T/6000 plus every knot, torque from
    pinocchio.rnea (independent of armlab's symbolic dynamics and its own check)."""
    t = np.union1d(np.linspace(traj.t[0], traj.t[-1], 6001), traj.t)
    q, qd, qdd, qddd = traj.at(t)
    data = robot.model.createData()
    tau = np.array([pin.rnea(robot.model, data, q[i], qd[i], qdd[i]) for i in range(t.size)])
    lim = robot.limits
    return {
        "torque": float(np.max(np.abs(tau) / lim.effort_Nm)),
        "velocity": float(np.max(np.abs(qd) / lim.velocity_rad_s)),
        "acceleration": float(np.max(np.abs(qdd) / lim.acceleration_rad_s2)),
        "jerk": float(np.max(np.abs(qddd) / lim.jerk_rad_s3)),
        "range": float(max(np.max(lim.lower_rad - q), np.max(q - lim.upper_rad))),
    }


@pytest.mark.parametrize(
    ("w", "kw"),
    [
        (W2, {}),
        (W3, {}),
        (W3, {"objective": "time+smooth"}),
        (W3, {"via_tolerance": 0.05, "payload_kg": 1.0}),
        (W2, {"qd_start": [0.2, 0, -0.1, 0, 0.3, 0], "qdd_start": [0, 0.5, 0, 0, 0, 0]}),
        (W3, {"hessian": "exact"}),
    ],
)
def test_fatrop_plans_as_ipopt_within_every_limit(compiled, robot, w, kw):
    with pytest.MonkeyPatch.context() as mp:
        fat = optimal(robot, w, **kw)
        ref = _ipopt(mp, robot, w, **kw)
    assert fat.stats["solver"] == "fatrop" and fat.stats["fallback"] == ""
    assert ref.stats["solver"] == "ipopt"
    assert fat.stats["duration_s"] == pytest.approx(ref.stats["duration_s"], rel=1e-6)
    ratios = _pinocchio_ratios(robot, fat)
    for kind in ("torque", "velocity", "acceleration", "jerk"):
        assert ratios[kind] <= 1 + 1e-6, (kind, ratios[kind])
    assert ratios["range"] <= 1e-9
    np.testing.assert_allclose(fat.q[-1], w[-1], atol=1e-9)


def test_the_payload_is_run_time_data(compiled, robot):
    """A payload changes the inertias, not the kinematics: the same library plans it (one
    library in the cache) and the payload slows the plan down."""
    light = optimal(robot, W3)
    heavy = optimal(robot, W3, payload_kg=1.5)
    assert heavy.stats["solver"] == "fatrop"
    assert heavy.stats["duration_s"] > light.stats["duration_s"]
    assert len(list(compiled.parent.glob("fatrop-stages-*.so"))) == 1


def test_layout_is_the_transcriptions(robot):
    """fatrop's light layout repeats build_structure's variable slices and row order."""
    prob = build_optimal(robot, W3, n_intervals=4)
    prob.make_warm_start()
    real = structure(robot, 6, prob.segment_intervals, "jerk", "time", True, False, 100)
    light = fatrop_backend.layout_structure(prob, True)
    assert light.slices == real.slices and light.nx == real.nx
    np.testing.assert_array_equal(light.g_kind, real.g_kind)
    np.testing.assert_array_equal(light.g_joint, real.g_joint)


def test_no_compiler_falls_back_to_ipopt(robot, tmp_path):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("ARMLAB_CACHE_DIR", str(tmp_path))
        mp.setenv("ARMLAB_SOLVER", "fatrop")
        mp.setenv("CC", "/nonexistent/cc")
        traj = optimal(robot, W2)
        ref = _ipopt(mp, robot, W2)
    assert traj.stats["solver"] == "ipopt"
    assert "no C compiler" in traj.stats["fallback"]
    assert traj.stats["duration_s"] == pytest.approx(ref.stats["duration_s"], rel=1e-9)
    assert not list(tmp_path.iterdir())  # nothing half-built left behind


def test_forced_ipopt_and_uncovered_variants_say_so(robot, monkeypatch):
    monkeypatch.setenv("ARMLAB_SOLVER", "ipopt")
    assert optimal(robot, W2).stats["fallback"] == "ARMLAB_SOLVER=ipopt"
    monkeypatch.setenv("ARMLAB_SOLVER", "fatrop")
    acc = optimal(robot, W2, j_max=False)
    assert acc.stats["solver"] == "ipopt" and "acceleration mode" in acc.stats["fallback"]


def test_watchdog_hands_the_solve_to_ipopt(compiled, robot, monkeypatch):
    """A budget the solve cannot meet: fatrop stops, IPOPT plans, stats say why; the next
    call with the normal budget is fatrop's again (the aborted instance is not reused)."""
    monkeypatch.setattr(fatrop_backend, "WATCHDOG_BASE_S", 1e-9)
    monkeypatch.setattr(fatrop_backend, "WATCHDOG_PER_INTERVAL_S", 0.0)
    slow = optimal(robot, W3)
    assert slow.stats["solver"] == "ipopt" and "watchdog" in slow.stats["fallback"]
    monkeypatch.undo()
    again = optimal(robot, W3)
    assert again.stats["solver"] == "fatrop"
    assert again.stats["duration_s"] == pytest.approx(slow.stats["duration_s"], rel=1e-6)


def test_cache_key_follows_the_kinematics(compiled, robot, monkeypatch):
    """Same kinematics, same key (payload included); another tree or casadi, another key."""
    key = fatrop_stages.library_key(robot)
    assert fatrop_stages.library_key(robot.with_payload(2.0)) == key
    other = armlab.load_robot("erd:z1_description/urdf/z1.urdf")
    assert fatrop_stages.library_key(other) != key
    monkeypatch.setattr(fatrop_stages.ca, "__version__", "0.0.0-test", raising=False)
    assert fatrop_stages.library_key(robot) != key
    monkeypatch.undo()
    monkeypatch.setattr(fatrop_stages, "_glue_source", lambda: "/* another glue */")
    assert fatrop_stages.library_key(robot) != key


def test_cache_dir_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv("ARMLAB_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert fatrop_stages.cache_dir() == tmp_path / "armlab"
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path / "own"))
    assert fatrop_stages.cache_dir() == tmp_path / "own"
