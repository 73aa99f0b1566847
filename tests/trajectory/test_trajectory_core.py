"""The Trajectory's two ways in (armlab.trajectory.core): the public constructor checks every
array it is given; the trusted one (Trajectory._from_checked, a planner's own arrays, issue 26)
gives the same object on valid arrays, and the planners built on it still hand out finite,
increasing samples."""

from __future__ import annotations

import numpy as np
import pytest

from armlab.errors import InputError
from armlab.planning import optimal, ptp_sync
from armlab.trajectory.core import Trajectory


def _arrays(n=5, nj=3, seed=0):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.1, 0.5, n)) - 0.1
    return t, *(rng.standard_normal((n, nj)) for _ in range(4))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda a: a.__setitem__(0, a[0][::-1].copy()), "strictly increasing"),
        (lambda a: a[0].__setitem__(2, np.nan), "non-empty finite"),
        (lambda a: a[1].__setitem__((3, 1), np.inf), "q is not finite at sample 3, joint 1"),
        (lambda a: a[2].__setitem__((0, 2), np.nan), "qd is not finite at sample 0, joint 2"),
        (lambda a: a.__setitem__(3, a[3][:, :2]), r"qdd has shape \(5, 2\), expected \(5, 3\)"),
        (lambda a: a.__setitem__(4, a[4][:4]), r"qddd has shape \(4, 3\), expected \(5, 3\)"),
    ],
)
def test_the_public_constructor_still_refuses_bad_arrays(change, message):
    arrays = list(_arrays())
    change(arrays)
    with pytest.raises(InputError, match=message):
        Trajectory(*arrays)


def test_the_public_constructor_refuses_a_wrong_number_of_joint_names():
    with pytest.raises(InputError, match="3 joints but 2 joint names"):
        Trajectory(*_arrays(), joint_names=["a", "b"])


@pytest.mark.parametrize("jerk", [True, False])
def test_the_trusted_constructor_equals_the_public_one_on_valid_arrays(jerk):
    t, q, qd, qdd, qddd = _arrays(seed=3)
    names = ("j1", "j2", "j3")
    a = Trajectory(t, q, qd, qdd, qddd if jerk else None, joint_names=names, method="m")
    b = Trajectory._from_checked(t, q, qd, qdd, qddd if jerk else None, names, "m")
    assert type(b) is Trajectory
    for name in ("t", "q", "qd", "qdd"):
        assert getattr(b, name) is getattr(a, name) or np.array_equal(
            getattr(b, name), getattr(a, name)
        )
    assert (b.qddd is None) == (not jerk)
    if jerk:
        np.testing.assert_array_equal(b.qddd, a.qddd)
    assert b.joint_names == a.joint_names == ["j1", "j2", "j3"]
    assert isinstance(b.joint_names, list)
    assert (b.method, b.report, b.stats, b.meta) == (a.method, a.report, a.stats, a.meta)
    # its own containers: a change to one trajectory's stats or meta is not another's
    b.stats["x"] = 1
    assert "x" not in Trajectory._from_checked(t, q, qd, qdd, None, names, "m").stats
    # and it evaluates as the public one does (every method reads the same arrays)
    times = np.linspace(t[0], t[-1], 37)
    for x, y in zip(a.at(times), b.at(times), strict=True):
        np.testing.assert_array_equal(x, y)


def _valid(traj):
    """What the public constructor would have checked, on a planner's result."""
    n = traj.t.size
    assert traj.t.dtype == np.float64 and traj.t.shape == (n,)
    assert np.isfinite(traj.t).all() and (np.diff(traj.t) > 0).all()
    for x in (traj.q, traj.qd, traj.qdd, traj.qddd):
        if x is not None:
            assert x.dtype == np.float64 and x.shape == (n, len(traj.joint_names))
            assert np.isfinite(x).all()
    # the public constructor takes the same arrays without complaint
    Trajectory(traj.t, traj.q, traj.qd, traj.qdd, traj.qddd, joint_names=traj.joint_names)


@pytest.mark.parametrize("seed", range(3))
def test_the_planners_on_the_trusted_path_hand_out_valid_arrays(teachbot6, seed):
    lo, hi = teachbot6.limits.lower_rad, teachbot6.limits.upper_rad
    rng = np.random.default_rng(seed)
    w = lo + (hi - lo) * (0.1 + 0.8 * rng.random((2, teachbot6.n_joints)))
    w[1, seed] = w[0, seed]  # one joint at rest
    plan = optimal(teachbot6, w, tau_max=False)
    assert plan.stats["method"] == "closed_form"
    _valid(plan)
    for profile, sync in [("scurve", "time"), ("trapezoid", "time"), ("scurve", "phase")]:
        _valid(ptp_sync(teachbot6, w[0], w[1], profile, sync=sync, tau_max=False))


def test_sample_times_equals_the_straightforward_form_bit_for_bit():
    from armlab.trajectory.sampling import sample_times
    from oracles.sample_times_unique import sample_times as reference

    rng = np.random.default_rng(26)
    for i in range(600):
        T = float(10 ** rng.uniform(-4, 1.5)) if i % 50 else [0.0, 1e-12, 0.3][i % 3]
        dt = float(10 ** rng.uniform(-3, 0)) if i % 7 else max(T, 1e-3) / rng.integers(1, 40)
        k = rng.uniform(-0.2, 1.2, rng.integers(0, 40)) * T
        if i % 5 == 0 and k.size:  # repeated knots, knots a rounding apart, at the ends
            k = np.concatenate([k, k[:3], k[:2] + 1e-17, [T, 0.0, T * (1 - 1e-16)]])
        if i % 11 == 0 and k.size > 2:
            k[1] = np.nan
        if i % 13 == 0:  # knots on the regular grid
            k = np.round(k / dt) * dt
        if i % 17 == 0:  # knots near it
            k = k + dt * 1e-3 * rng.standard_normal(k.size)
        got, want = sample_times(T, dt, k), reference(T, dt, k)
        assert got.shape == want.shape and np.array_equal(got, want), (i, T, dt)
        assert got.size == 1 or (np.diff(got) > 0).all()
