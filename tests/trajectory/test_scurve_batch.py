"""Batched, closed-form time-synchronised S-curves (armlab.trajectory.profiles).

References: the bisection oracle of the peak speed for a duration
(``tests/oracles/double_s.py``, to the last bit) and the per-problem
:func:`synchronised_profiles` (Jiang 1987 eq. 1-5 with Biagiotti & Melchiorri §3.4's double S);
the profiles themselves are sampled and checked against their limits.
"""

from __future__ import annotations

import numpy as np
import pytest

from armlab.errors import InputError
from armlab.trajectory.profiles import (
    double_s_min_times,
    double_s_speed_for_duration,
    synchronised_profiles,
    synchronised_scurves,
)
from oracles.double_s import double_s_speed_bisection

V = np.array([2.0, 2.0, 2.5, 3.0, 3.0, 4.0])
A = np.array([5.0, 6.0, 5.0, 8.0, 9.0, 12.0])
J = np.array([50.0, 40.0, 60.0, 80.0, 100.0, np.inf])  # the last joint: a trapezoid


def _decades(rng, lo, hi, n):
    return 10 ** rng.uniform(lo, hi, n)


def test_closed_form_speed_is_the_bisection():
    """Over decades of length and limits, both regimes (acceleration limit reached or not),
    the trapezoid, durations from the minimum (1 + 1e-9) to 10 x."""
    rng = np.random.default_rng(7)
    n = 20000
    L, v, a, j = (
        _decades(rng, -4, 1, n),
        _decades(rng, -1, 1, n),
        _decades(rng, -1, 2, n),
        _decades(rng, 0, 4, n),
    )
    j[::9] = np.inf
    T = double_s_min_times(L, v, a, j) * (1 + _decades(rng, -9, 1, n))
    T[::5] = double_s_min_times(L, v, a, j)[::5]
    ours = double_s_speed_for_duration(L, T, a, j, v)
    ref = double_s_speed_bisection(L, T, a, j, v)
    np.testing.assert_allclose(ours, ref, rtol=1e-9)  # the oracle's last bit, 1e-16, with room
    assert np.all(double_s_speed_for_duration(0.0, 1.0, 1.0, 1.0, 1.0) == 0.0)
    # the velocity step (no acceleration nor jerk limit): v = L / T
    np.testing.assert_allclose(
        double_s_speed_for_duration([1.0, 2.0], 4.0, np.inf, np.inf, 1.0), [0.25, 0.5], rtol=1e-15
    )


def test_batch_is_synchronised_profiles_problem_by_problem():
    """Durations, shortest joint times and peak speeds of 300 random 6-joint problems (some
    joints not moving) equal the per-problem profiles; the batch and the one-problem paths
    agree."""
    rng = np.random.default_rng(11)
    D = rng.uniform(-2.5, 2.5, (300, 6))
    D[::4, 2] = 0.0
    batch = synchronised_scurves(D, V, A, J)
    assert batch.duration.shape == (300,) and batch.v.shape == (300, 6)
    for i in range(0, 300, 3):
        T, t_min, profiles = synchronised_profiles(np.abs(D[i]), V, A, J)
        assert batch.duration[i] == pytest.approx(T, rel=1e-14)
        np.testing.assert_allclose(batch.t_min[i], t_min, rtol=1e-14)
        vp = [p.params["v"] if p.kind != "rest" else 0.0 for p in profiles]
        np.testing.assert_allclose(batch.v[i], vp, rtol=1e-9, atol=1e-12)
        one = synchronised_scurves(D[i], V, A, J)
        for key in ("t_min", "v", "a", "tj", "ta", "tv"):
            np.testing.assert_allclose(getattr(one, key), getattr(batch, key)[i], rtol=1e-12)


def test_sampled_profiles_keep_the_limits_and_arrive_together():
    """Sampled on a fine grid: every joint within v, a, j, ends at its distance at the common
    duration and at rest; the batch evaluation equals each joint's MotionProfile."""
    rng = np.random.default_rng(5)
    D = rng.uniform(-2.0, 2.0, (40, 6))
    batch = synchronised_scurves(D, V, A, J)
    t = np.linspace(0.0, batch.duration.max(), 4001)
    q, qd, qdd = batch.evaluate(t)
    assert q.shape == (t.size, 40, 6)
    tol = 1 + 1e-9
    assert np.all(np.abs(qd) <= V * tol) and np.all(np.abs(qdd) <= A * tol)
    np.testing.assert_allclose(q[-1], D, atol=1e-12)
    assert np.abs(qd[-1]).max() < 1e-9
    jerk = np.diff(qdd, axis=0) / np.diff(t)[:, None, None]
    finite_j = np.isfinite(J)
    assert np.all(np.abs(jerk[..., finite_j]) <= J[finite_j] * (1 + 1e-6))
    for p, k in ((0, 0), (3, 5), (17, 2)):
        prof = batch.profile((p, k))
        assert prof.duration == pytest.approx(batch.duration[p], rel=1e-12)
        s, sd, sdd, _ = prof.evaluate(t)
        sgn = np.sign(D[p, k])
        np.testing.assert_allclose(q[:, p, k], sgn * s, atol=1e-12)
        np.testing.assert_allclose(qd[:, p, k], sgn * sd, atol=1e-10)


def test_peaks_from_the_phase_data_are_the_timing_of_each_profile():
    """SCurveBatch.peaks integrates the seven phases; the timing primitives give the same
    peaks independently: the peak speed ``v``, the peak acceleration ``a`` (Biagiotti &
    Melchiorri §3.4), jerk ``j`` where a joint moves on a double S, the end at ``|D|`` at rest,
    never a speed against the move; and no sample of the evaluation exceeds them."""
    rng = np.random.default_rng(17)
    D = rng.uniform(-2.0, 2.0, (30, 6))
    D[::3, 1] = 0.0
    D[1::5, 3] = 1e-4  # a short move: no cruise, no acceleration plateau
    batch = synchronised_scurves(D, V, A, J)
    pk = batch.peaks()
    moving = D != 0
    np.testing.assert_allclose(pk["velocity"], batch.v, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(pk["acceleration"], np.where(moving, batch.a, 0.0), rtol=1e-12)
    jerk = np.where(moving & np.isfinite(J), np.where(np.isfinite(J), J, 0.0), 0.0)
    np.testing.assert_allclose(pk["jerk"], jerk, rtol=1e-15)
    np.testing.assert_allclose(pk["end_position"], np.abs(D), rtol=1e-12, atol=1e-15)
    assert np.abs(pk["end_velocity"]).max() < 1e-12
    assert np.abs(pk["end_acceleration"]).max() < 1e-9
    assert pk["reverse"].max() < 1e-12
    t = np.linspace(0.0, batch.duration.max(), 2001)
    q, qd, qdd, qddd = batch.evaluate_jerk(t)
    assert np.all(np.abs(qd).max(axis=0) <= pk["velocity"] * (1 + 1e-12))
    assert np.all(np.abs(qdd).max(axis=0) <= pk["acceleration"] * (1 + 1e-12))
    assert np.all(np.abs(qddd).max(axis=0) <= pk["jerk"])
    # the jerk of the evaluation is the slope of its acceleration between samples
    slope = np.diff(qdd, axis=0) / np.diff(t)[:, None, None]
    assert np.all(np.abs(slope) <= np.where(np.isfinite(J), J, np.inf) * (1 + 1e-6))


def test_zero_velocity_waypoints_are_a_batch_of_segments():
    w = np.array([[0.0, 0.5, -1.0], [1.0, 0.5, 0.0], [0.2, -0.7, 0.4]])
    seg = synchronised_scurves(np.diff(w, axis=0), 2.0, 5.0, 50.0)
    for k in range(2):
        T, _, _ = synchronised_profiles(np.abs(w[k + 1] - w[k]), 2.0, 5.0, 50.0)
        assert seg.duration[k] == pytest.approx(T, rel=1e-14)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((np.ones((3, 2)), -1.0, 1.0, 1.0), "v_max"),
        ((np.ones(2), 1.0, np.inf, 1.0), "a_max"),
        ((np.ones((3, 2)), 1.0, 1.0, 0.0), "j_max"),
        ((np.array([1.0, np.nan]), 1.0, 1.0, 1.0), "finite"),
        ((np.ones((3, 2)), [1.0, 2.0, 3.0], 1.0, 1.0), "broadcast"),
        ((1.0, 1.0, 1.0, 1.0), "joint axis"),
    ],
)
def test_bad_input_is_one_line_error(args, match):
    with pytest.raises(InputError, match=match):
        synchronised_scurves(*args)


def test_profile_dicts_are_the_profiles_to_dict():
    """``SCurveBatch.profile_dicts`` (ptp_sync's ``meta["joint_profiles"]`` without building
    the profiles) equals ``MotionProfile.to_dict`` of each joint: double S, trapezoid (``j``
    inf), joints at rest, short moves without a plateau."""
    rng = np.random.default_rng(23)
    D = rng.uniform(-2.0, 2.0, (12, 6))
    D[::3, 1] = 0.0
    D[1::4, 3] = 1e-5
    batch = synchronised_scurves(D, V, A, J)
    for p in range(12):
        ours = batch.profile_dicts(p)
        ref = [prof.to_dict() for prof in batch.profiles(p)]
        assert [list(x) for x in ours] == [list(x) for x in ref]  # keys, in their order
        for x, y in zip(ours, ref, strict=True):
            assert x["kind"] == y["kind"]
            for key in x.keys() - {"kind"}:  # the duration: the same sum of the same phases
                assert x[key] == pytest.approx(y[key], rel=1e-15, abs=1e-300)
    assert {d["kind"] for p in range(12) for d in batch.profile_dicts(p)} == {
        "double_s",
        "trapezoid",
        "rest",
    }


def test_one_problem_evaluates_the_same_in_any_time_order():
    """One problem sampled at many times (in order: the counted phases of a sampled plan;
    shuffled: a search per joint; a few: one comparison) gives each joint's MotionProfile
    evaluation, signed by its move, at every time, including phase boundaries and the ends."""
    rng = np.random.default_rng(29)
    D = np.array([1.2, -0.7, 0.0, 2.0, -1e-4, 0.4])
    batch = synchronised_scurves(D, V, A, J)
    T = float(batch.duration)
    corners = batch.boundaries()[0].reshape(-1)
    t = np.sort(np.concatenate([np.linspace(-0.1, T + 0.1, 600), corners]))
    ref = np.stack(
        [np.sign(D[k]) * np.stack(batch.profile(k).evaluate(t)) for k in range(6)], axis=-1
    )
    shuffle = rng.permutation(t.size)
    for times, order in ((t, slice(None)), (t[shuffle], shuffle), (t[:40], slice(0, 40))):
        ours = np.stack(batch.evaluate_jerk(times))
        np.testing.assert_allclose(ours, ref[:, order], rtol=1e-12, atol=1e-12)
