"""check_motion against the coal oracle on random plans: what it passes keeps the clearance on
a fine grid, what it refuses really comes too close."""

from __future__ import annotations

import numpy as np
import pytest

from armlab.collision import CollisionError, CollisionScene, Shape, check_motion
from armlab.kinematics import fk
from armlab.planning import ptp_sync
from armlab.robot.model import load_robot
from oracles.clearance_grid import config_distances, grid_distances

GRID_S = 0.005  # the oracle's grid: 5 ms


@pytest.fixture(scope="module")
def bot():
    return load_robot("teachbot6")


def _random_case(bot, rng):
    """A ptp move between two random configurations and a sphere obstacle near the tool's
    path (centre the tool point at a random instant, shifted 0-0.15 m: from clear misses to
    deep hits), a 30 mm payload sphere and a floor."""
    lim = bot.limits
    lo, hi = 0.6 * lim.lower_rad, 0.6 * lim.upper_rad
    q0 = lo + (hi - lo) * rng.random(6)
    q1 = np.clip(q0 + rng.uniform(-0.35, 0.35, 6), lim.lower_rad, lim.upper_rad)
    traj = ptp_sync(bot, q0, q1, profile="trapezoid", dt=0.01)
    s = rng.random()
    q_s = traj.at(np.array([s * traj.duration]))[0][0]
    centre = fk(bot, q_s)[:3, 3] + rng.normal(size=3) * 0.08
    ball = Shape("ball", "sphere", (float(rng.uniform(0.02, 0.06)),), tuple(centre))
    scene = CollisionScene.from_robot(
        bot, [ball], payload=Shape("payload", "sphere", (0.03,)), floor_z_m=-0.6
    )
    return scene, traj


def test_random_plans_agree_with_the_coal_grid_oracle(bot):
    """16 random plans, clearance 0 or 20 mm: a plan reported clear keeps the clearance (to
    tol_m) at every point of the oracle's 5 ms grid; a plan reported failing really comes
    closer than the clearance at the reported time (the oracle's distance of the named pair);
    and the reported minimum is a certified lower bound of the grid minimum (to tol_m)."""
    rng = np.random.default_rng(7)
    outcomes = {True: 0, False: 0}
    for case in range(16):
        scene, traj = _random_case(bot, rng)
        c = 0.02 if case % 2 else 0.0
        rep = check_motion(scene, traj, c)
        _, D = grid_distances(scene, traj, GRID_S)
        grid_min = float(D.min())
        assert grid_min >= rep.min_distance_m - rep.tol_m, case  # certified lower bound
        if rep.ok:
            assert grid_min >= c - rep.tol_m, case
        else:
            q = traj.at(np.array([traj.t[0] + rep.time_s]))[0][0]
            d = config_distances(scene, q)
            names = [rp.pair for rp in rep.pairs]
            k = scene.pair_names().index(_names_of(scene, names[0]))
            assert d[k] < c, case
            assert d[k] == pytest.approx(rep.min_distance_m, abs=1e-6)
            assert grid_min < c + 5e-3  # the grid sees it too (within a 5 ms step's travel)
        outcomes[rep.ok] += 1
    assert outcomes[True] >= 3 and outcomes[False] >= 3, outcomes  # both kinds were drawn


def _names_of(scene, pair: str) -> tuple[str, str]:
    for a, b in scene.pair_names():
        la, lb = scene.link_of[a], scene.link_of[b]
        sa = a if la == a else f"{a} ({la})"
        sb = b if lb == b else f"{b} ({lb})"
        if f"{sa} and {sb}" == pair:
            return a, b
    raise AssertionError(pair)


def test_between_samples_a_thin_wall_is_not_missed(bot):
    """A 2 mm thin plate crossed by the tool between two knots 0.5 s apart (a coarse
    trajectory): no knot is near it, the check still finds the crossing (the bound refines)."""
    q0 = np.radians([-40.0, 20.0, 30.0, 0.0, 40.0, 0.0])
    q1 = np.radians([40.0, 20.0, 30.0, 0.0, 40.0, 0.0])
    fine = ptp_sync(bot, q0, q1, profile="trapezoid", dt=0.5)
    assert fine.n_samples <= 12
    mid = fk(bot, np.radians([0.0, 20.0, 30.0, 0.0, 40.0, 0.0]))[:3, 3]
    wall = Shape("wall", "box", (0.3, 0.002, 0.3), tuple(mid))
    scene = CollisionScene.from_robot(bot, [wall])
    at_knots = np.array([config_distances(scene, q) for q in fine.q])
    assert at_knots.min() > 0.0  # every knot is clear: the crossing is between them
    rep = check_motion(scene, fine, 0.0, initial_step_s=0.5)
    assert not rep.ok and rep.min_distance_m < 0
    assert "wall" in rep.pair
    with pytest.raises(CollisionError, match=r"wall.* at t = "):
        rep.raise_if_failed()


def test_report_lists_every_pair_closest_first(bot):
    rng = np.random.default_rng(3)
    scene, traj = _random_case(bot, rng)
    rep = check_motion(scene, traj)
    assert len(rep.pairs) == scene.n_pairs
    d = [p.min_distance_m for p in rep.pairs]
    assert d == sorted(d)
    assert rep.min_distance_m == pytest.approx(d[0], abs=0.0)
    assert 0.0 <= rep.time_s <= traj.duration
