"""Collision checking of the demo plan at 1 ms: armlab's path vs a plain loop over coal's calls.

The demo study's plan (teachbot6, the optimal planner through the demo cycle) with a table under
it (the collision tests' table: top 0.20 m below the base) and the 30 mm payload sphere: the
scene of :class:`armlab.collision.CollisionScene` (the URDF's collision primitives, the pairs the
shipped analysis leaves, payload and table).

- armlab: :func:`armlab.collision.check_motion` -- the certified minimum clearance of the whole
  motion (conservative bound between samples, refined where not conclusive; tolerance 0.1 mm);
- armlab on the 1 ms grid: the scene's ``distance_values`` (Pinocchio's ``computeDistances``)
  at every sample, the same answer as the peer's;
- peer: a plain Python loop over the 1 ms grid, Pinocchio's forward kinematics and one
  ``coal.distance`` call per pair (the pose of each shape computed once per sample): what a user
  writes without armlab -- and, unlike ``check_motion``, blind between the samples.

Times: wall, the fastest of ``REPEATS`` runs each (alternating), in one process.

Run:  ``.venv/bin/python benchmarks/bench_collision.py``
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import time  # noqa: E402

import coal  # noqa: E402
import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402
from _readme import readme_row, sig  # noqa: E402

from armlab.collision import CollisionScene, Shape, check_motion  # noqa: E402
from armlab.planning import optimal  # noqa: E402
from armlab.robot.model import load_robot  # noqa: E402

DT = 0.001
REPEATS = 3
DEMO_DEG = [
    [0, 0, 0, 0, 0, 0],
    [45, 20, 30, 0, 40, 0],
    [90, 35, 10, 60, -30, 90],
    [0, 0, 0, 0, 0, 0],
]


def plain_loop(scene: CollisionScene, Q: np.ndarray) -> float:
    """Smallest signed distance over the configurations ``Q`` by coal.distance per pair."""
    model = scene.robot.model
    data = model.createData()
    objs = list(scene.geometry.geometryObjects)
    pairs = [(cp.first, cp.second) for cp in scene.geometry.collisionPairs]
    req = coal.DistanceRequest()
    best = np.inf
    for q in Q:
        pin.forwardKinematics(model, data, q)
        poses = []
        for obj in objs:
            M = data.oMi[obj.parentJoint] * obj.placement
            poses.append(coal.Transform3s(M.rotation, M.translation))
        for i, j in pairs:
            res = coal.DistanceResult()
            d = coal.distance(objs[i].geometry, poses[i], objs[j].geometry, poses[j], req, res)
            best = min(best, d)
    return float(best)


def main() -> None:
    robot = load_robot("teachbot6", payload_kg=0.5)
    traj = optimal(robot, np.radians(DEMO_DEG))
    table = Shape("table", "box", (1.2, 1.4, 0.04), (0.3, 0.2, -0.22))
    scene = CollisionScene.from_robot(robot, [table], payload=Shape("payload", "sphere", (0.03,)))
    t = np.append(np.arange(traj.t[0], traj.t[-1], DT), traj.t[-1])
    Q = traj.at(t)[0]
    print(f"demo plan: {traj.duration:.3f} s, {len(t)} samples at 1 ms, {scene.n_pairs} pairs")
    times: dict[str, float] = {"check": np.inf, "grid": np.inf, "plain": np.inf}
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        rep = check_motion(scene, traj)
        times["check"] = min(times["check"], time.perf_counter() - t0)
        t0 = time.perf_counter()
        grid_min = min(float(scene.distance_values(q).min()) for q in Q)
        times["grid"] = min(times["grid"], time.perf_counter() - t0)
        t0 = time.perf_counter()
        plain_min = plain_loop(scene, Q)
        times["plain"] = min(times["plain"], time.perf_counter() - t0)
    print(
        f"armlab check_motion   {times['check'] * 1e3:9.1f} ms  {rep.n_evaluations:6d} configs"
        f"  min {rep.min_distance_m * 1e3:.3f} mm at {rep.time_s:.3f} s ({rep.pair}),"
        f" certified >= {(rep.min_distance_m - rep.tol_m) * 1e3:.3f} mm"
    )
    print(
        f"armlab 1 ms grid      {times['grid'] * 1e3:9.1f} ms  {len(t):6d} configs"
        f"  min {grid_min * 1e3:.3f} mm"
    )
    print(
        f"plain coal loop       {times['plain'] * 1e3:9.1f} ms  {len(t):6d} configs"
        f"  min {plain_min * 1e3:.3f} mm"
    )
    readme_row(
        __file__,
        f"collision check of the demo plan (teachbot6 over a table, {scene.n_pairs} pairs,"
        f" {sig(traj.duration)} s) at 1 ms",
        f"`check_motion` {sig(times['check'] * 1e3)} ms ({rep.n_evaluations} configurations,"
        f" certified between samples), min clearance {sig(rep.min_distance_m * 1e3)} mm;"
        f" the scene on the 1 ms grid {sig(times['grid'] * 1e3)} ms",
        f"plain loop of `coal.distance` on the 1 ms grid {sig(times['plain'] * 1e3)} ms"
        f" ({len(t)} configurations, blind between samples), min {sig(plain_min * 1e3)} mm",
    )


if __name__ == "__main__":
    main()
