"""The optimiser's warm-start primitives (:mod:`armlab.planning.warmstart`): the running-sum
integration of piecewise-constant inputs against the interval recurrence written out here,
the node grid that holds a profile's switching instants, and the optimiser's energy stat
read from its limit samples against the sampled plan's own torques."""

from __future__ import annotations

import numpy as np
import pytest

from armlab.planning.optimal_bounds import _energy_weights
from armlab.planning.warmstart import integrate_piecewise, phase_grid
from armlab.trajectory import optimal
from armlab.trajectory.profiles import synchronised_profiles


def _recurrence(h, u, x0, mode, start):
    """The exact integration over each interval, one interval after the other (the
    optimiser's integration equations, module docstring of armlab.planning.optimiser)."""
    N, n = u.shape
    q, v, a = np.zeros((N + 1, n)), np.zeros((N + 1, n)), np.zeros((N + 1, n))
    q[0], v[0], a[0] = x0, start[0], start[1]
    for k in range(N):
        hk, uk = h[k], u[k]
        if mode == "jerk":
            q[k + 1] = q[k] + hk * v[k] + hk**2 / 2 * a[k] + hk**3 / 6 * uk
            v[k + 1] = v[k] + hk * a[k] + hk**2 / 2 * uk
            a[k + 1] = a[k] + hk * uk
        else:
            q[k + 1] = q[k] + hk * v[k] + hk**2 / 2 * uk
            v[k + 1] = v[k] + hk * uk
            a[k + 1] = uk
    if mode != "jerk":
        a[0] = u[0]
    return q, v, a


@pytest.mark.parametrize("mode", ["jerk", "acceleration"])
@pytest.mark.parametrize("moving", [False, True], ids=["rest", "moving"])
def test_integrate_piecewise_is_the_interval_recurrence(mode, moving):
    rng = np.random.default_rng(7)
    for N in (1, 2, 17, 300):
        h = rng.uniform(1e-3, 0.5, N)
        u = rng.normal(scale=50.0, size=(N, 3))
        x0 = rng.normal(size=3)
        start = (rng.normal(size=3), rng.normal(size=3)) if moving else (np.zeros(3),) * 2
        got = integrate_piecewise(h, u, x0, mode, start=start if moving else None)
        want = _recurrence(h, u, x0, mode, start)
        for g, w in zip(got, want, strict=True):
            assert g.shape == (N + 1, 3)
            np.testing.assert_allclose(g, w, rtol=1e-13, atol=1e-13 * np.abs(w).max())


def test_integrate_piecewise_of_a_constant_jerk_is_the_cubic():
    """One joint, jerk 6 for 1 s cut into 10 unequal intervals from rest: q = t^3."""
    h = np.array([0.05, 0.15, 0.1, 0.1, 0.2, 0.05, 0.05, 0.1, 0.1, 0.1])
    q, v, a = integrate_piecewise(h, np.full((10, 1), 6.0), np.zeros(1))
    t = np.concatenate([[0.0], np.cumsum(h)])
    np.testing.assert_allclose(q[:, 0], t**3, atol=1e-15)
    np.testing.assert_allclose(v[:, 0], 3 * t**2, atol=1e-14)
    np.testing.assert_allclose(a[:, 0], 6 * t, atol=1e-14)


def test_phase_grid_holds_the_switching_instants_and_halves_the_longest():
    """A double S (7 phases, 6 corners) on 16 intervals: every corner is a node, each phase
    is cut into pieces of its length over a power of two, and since the longest interval is
    always the one halved, no interval is longer than twice a halved piece."""
    T, _, profiles = synchronised_profiles(np.array([1.0]), 1.0, 2.0, 10.0)
    grid = phase_grid(profiles, T, 16)
    corners = np.concatenate([[0.0], profiles[0].corners, [T]])
    assert grid.size == 17 and grid[0] == 0.0 and abs(grid[-1] - T) <= 1e-15 * T
    assert np.all(np.diff(grid) > 0)
    for c in corners:
        assert np.min(np.abs(grid - c)) <= 1e-15 * T
    halved = []
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        inside = np.diff(grid[(grid >= a - 1e-15) & (grid <= b + 1e-15)])
        powers = np.log2((b - a) / inside)
        np.testing.assert_allclose(powers, np.round(powers), atol=1e-9)
        if inside.size > 1:
            halved += list(inside)
    assert halved and np.diff(grid).max() <= 2 * min(halved) * (1 + 1e-12)


def test_phase_grid_merges_close_corners_and_thins_to_the_interval_count():
    """Corners closer than h_min merge; more corners than intervals are thinned to it."""
    T, _, profiles = synchronised_profiles(np.array([1.0, 0.3]), 1.0, 2.0, 10.0)
    fine = phase_grid(profiles, T, 4, joints=[0, 1])
    assert fine.size == 5 and np.all(np.diff(fine) > 0)
    merged = phase_grid(profiles, T, 16, h_min=T)  # everything closer than T: the ends only
    assert merged.size == 17
    np.testing.assert_allclose(np.diff(merged), T / 16, rtol=1e-12)


def test_the_energy_stat_is_the_trapezoid_of_the_sampled_plans_torques(teachbot6):
    """stats["energy"] (read from the final limit samples) against the plan sampled on its
    report grid and its torques computed there."""
    w = np.array([[0.0, -0.3, 0.8, 0.0, 0.6, 0.0], [0.6, 0.2, 0.1, 0.8, -0.2, 0.5]])
    tr = optimal(teachbot6, w, n_intervals=12)
    fine = tr.sample(tr.stats["report_dt_s"])
    ew, unit = _energy_weights(teachbot6)
    want = float(np.trapezoid(fine.torques(teachbot6) ** 2 @ ew, fine.t))
    assert tr.stats["energy_unit"] == unit
    assert tr.stats["energy"] == pytest.approx(want, rel=1e-12)
