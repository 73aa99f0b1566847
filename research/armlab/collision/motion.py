"""The clearance of a whole motion: :func:`check_motion` and its :class:`ClearanceReport`.

Between samples: a conservative bound, refined where it is not conclusive
--------------------------------------------------------------------------
A point of a geometry carried by joint ``k`` moves at most at

    v_max = sum over the joints j on the chain to k of |qd_j|_max * rho_j       (revolute j)
            + |qd_j|_max                                                        (prismatic j)

where ``rho_j`` bounds the distance of any point of the geometry from joint ``j``'s origin,
independently of the configuration: the lengths of the joint placements from ``j`` to ``k``
(plus the strokes of prismatic joints between them), the geometry's offset on its joint and its
bounding radius (coal's local AABB). ``|qd_j|_max`` is the trajectory's own largest speed, taken
at its knots and at the interior velocity extremes of every piece
(:meth:`~armlab.trajectory.Trajectory.critical_times`: exact for its piecewise polynomials). The
signed distance of a pair whose shapes move at most at ``v_a`` and ``v_b`` changes at most at
``V = v_a + v_b``, so on an interval ``[t_a, t_b]`` of length ``h``, from its values at both ends
(a Lipschitz function's minimum),

    d(t) >= (d(t_a) + d(t_b) - V h) / 2.

:func:`check_motion` runs branch and bound on these intervals: it starts from a grid of at most
``initial_step_s``, splits every interval whose bound is inconclusive at its midpoint (all of a
round's midpoints in one batch), and stops when no interval's bound lies below
``min(clearance, smallest sampled distance) - tol_m``. An interval shorter than
``2 tol_m / V`` is never split (its bound is then within ``tol_m`` of its ends'). The result is
**certified**: the smallest distance over the whole motion is at least
``min_distance_m - tol_m``, and a motion reported clear keeps ``clearance_m - tol_m`` at every
instant, not only at samples; a motion reported colliding has a sample that does (its time and
pair are the deepest found, to ``tol_m``).

Why not coal's continuous collision detection (``coal.continuousCollide``): it answers "do two
shapes moving on a screw motion between two poses touch", not "what is their smallest distance",
so it gives neither the clearance nor its time, and each link moves on a screw only
approximately between two configurations of a serial chain (a conservative bound like the one
above is what such a check needs for articulated motion anyway: Schwarzer, Saha, Latombe, IEEE
T-RO 21(3), 2005, "adaptive dynamic collision checking"). The bound here is that method's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from armlab.collision.scene import CollisionError, CollisionScene

if TYPE_CHECKING:
    from armlab.trajectory import Trajectory

__all__ = ["ClearanceReport", "PairClearance", "check_motion", "speed_bounds", "TOL_M"]

#: Default tolerance of the certified clearance, [m] (0.1 mm).
TOL_M = 1e-4
#: Default longest interval of the initial grid, [s].
INITIAL_STEP_S = 0.05


@dataclass(frozen=True)
class PairClearance:
    """One pair's smallest sampled signed distance over a motion.

    Attributes
    ----------
    pair : str
        ``"link2_0 (link2) and table"``.
    links : (str, str)
        The pair's links (obstacle, payload and floor names for those).
    min_distance_m : float
        Smallest signed distance at the evaluated times, [m].
    time_s : float
        When, [s] from the start of the motion.
    """

    pair: str
    links: tuple[str, str]
    min_distance_m: float
    time_s: float


@dataclass
class ClearanceReport:
    """The clearance of a motion (module docstring).

    Attributes
    ----------
    clearance_m : float
        The clearance asked for, [m] (0: contact only).
    ok : bool
        The motion keeps ``clearance_m - tol_m`` at every instant (certified).
    min_distance_m : float
        Smallest signed distance over the motion, [m] (inf: no pairs); the certified minimum
        is at least ``min_distance_m - tol_m``.
    time_s : float
        When it happens, [s].
    pair : str
        Which pair (``""``: none).
    pairs : list of PairClearance
        Every checked pair, closest first.
    n_evaluations : int
        Configurations evaluated.
    tol_m : float
        The tolerance of the certificate, [m].
    source : str
        Where the robot's shapes come from (``"collision"`` or ``"visual"`` URDF elements).
    """

    clearance_m: float
    ok: bool
    min_distance_m: float
    time_s: float
    pair: str
    pairs: list[PairClearance] = field(default_factory=list)
    n_evaluations: int = 0
    tol_m: float = TOL_M
    source: str = ""

    @property
    def depth_m(self) -> float:
        """How far the closest approach is inside the clearance, [m] (<= 0: clear)."""
        return self.clearance_m - self.min_distance_m

    def message(self, what: str = "the plan") -> str:
        """One line: the pair, the time and the depth (of a failing report)."""
        if self.min_distance_m < 0:
            how = f"collides: {self.pair} penetrate {1e3 * -self.min_distance_m:.3g} mm"
        else:
            how = (
                f"comes within {1e3 * self.min_distance_m:.3g} mm "
                f"({1e3 * self.depth_m:.3g} mm inside the clearance of "
                f"{1e3 * self.clearance_m:.3g} mm) between {self.pair}"
            )
        return f"{what} {how} at t = {self.time_s:.4g} s"

    def raise_if_failed(self, what: str = "the plan") -> None:
        """Raise :class:`~armlab.collision.scene.CollisionError` (:meth:`message`) unless ok."""
        if not self.ok:
            raise CollisionError(self.message(what))

    def to_dict(self) -> dict:
        """JSON-able summary (the plan block's ``clearance``)."""
        return {
            "clearance_m": self.clearance_m,
            "ok": self.ok,
            "min_distance_m": self.min_distance_m,
            "time_s": self.time_s,
            "pair": self.pair,
            "tol_m": self.tol_m,
            "n_evaluations": self.n_evaluations,
            "geometry": self.source,
            "pairs": [
                {"pair": p.pair, "min_distance_m": p.min_distance_m, "time_s": p.time_s}
                for p in self.pairs[:10]
            ],
        }


def _chain(model: pin.Model, joint: int) -> list[int]:
    out = []
    while joint > 0:
        out.append(joint)
        joint = model.parents[joint]
    return out[::-1]


def speed_bounds(scene: CollisionScene, qd_max: np.ndarray) -> np.ndarray:
    """Largest speed of any point of each geometry of ``scene`` (n_objects,), [m/s], for joint
    speeds at most ``qd_max`` (n_joints,) [rad/s or m/s] (module docstring)."""
    model = scene.robot.model
    lim = scene.robot.limits
    stroke = np.maximum(np.abs(lim.lower_rad), np.abs(lim.upper_rad))
    out = np.zeros(len(scene.geometry.geometryObjects))
    for k, obj in enumerate(scene.geometry.geometryObjects):
        if obj.parentJoint == 0:
            continue
        geom = obj.geometry
        geom.computeLocalAABB()
        reach = float(np.linalg.norm(obj.placement.translation)) + float(
            geom.aabb_radius + np.linalg.norm(geom.aabb_center)
        )
        chain = _chain(model, obj.parentJoint)
        speed = 0.0
        for pos, j in enumerate(chain):
            rho = reach
            for i in chain[pos + 1 :]:
                rho += float(np.linalg.norm(model.jointPlacements[i].translation))
                if model.joints[i].shortname().startswith("JointModelP"):
                    rho += float(stroke[i - 1])
            prismatic = model.joints[j].shortname().startswith("JointModelP")
            speed += float(abs(qd_max[j - 1])) * (1.0 if prismatic else rho)
        out[k] = speed
    return out


def _max_speeds(traj: Trajectory) -> np.ndarray:
    times = np.union1d(traj.t, traj.critical_times())
    _, qd, _, _ = traj.at(times)
    return np.max(np.abs(qd), axis=0)


def check_motion(
    scene: CollisionScene,
    trajectory: Trajectory,
    clearance_m: float | None = None,
    *,
    tol_m: float = TOL_M,
    initial_step_s: float = INITIAL_STEP_S,
) -> ClearanceReport:
    """The certified clearance of ``trajectory`` in ``scene`` (module docstring).

    Parameters
    ----------
    scene : CollisionScene
    trajectory : Trajectory
    clearance_m : float, optional
        Required clearance in [m]; default the scene's (``[plan] clearance_m``).
    tol_m : float
        Tolerance of the certificate in [m].
    initial_step_s : float
        Longest interval of the starting grid in [s].

    Returns
    -------
    ClearanceReport
    """
    c = scene.clearance_m if clearance_m is None else float(clearance_m)
    pairs = scene.geometry.collisionPairs
    n = len(pairs)
    t0, t1 = float(trajectory.t[0]), float(trajectory.t[-1])
    if n == 0:
        return ClearanceReport(c, True, math.inf, t0, "", [], 0, tol_m, scene.source)
    s = speed_bounds(scene, _max_speeds(trajectory))
    V = np.array([s[p.first] + s[p.second] for p in pairs])
    v_top = float(V.max())
    h_min = 2.0 * tol_m / v_top if v_top > 0 else math.inf
    seen_t: list[np.ndarray] = []
    seen_d: list[np.ndarray] = []

    def evaluate(times: np.ndarray) -> np.ndarray:
        q = trajectory.at(times)[0]  # one batched evaluation per round
        D = np.array([scene.distance_values(row) for row in q]).reshape(len(times), n)
        seen_t.append(times)
        seen_d.append(D)
        return D

    m = max(1, math.ceil((t1 - t0) / initial_step_s))
    grid = np.linspace(t0, t1, m + 1)
    Dg = evaluate(grid)
    best = float(Dg.min())
    a, b, Da, Db = grid[:-1], grid[1:], Dg[:-1], Dg[1:]
    while len(a):  # breadth-first branch and bound: split every inconclusive interval
        h = b - a
        lb = np.min(0.5 * (Da + Db - V[None, :] * h[:, None]), axis=1)
        split = (lb < min(c, best) - tol_m) & (h > h_min)
        if not split.any():
            break
        a, b, Da, Db = a[split], b[split], Da[split], Db[split]
        mid = 0.5 * (a + b)
        Dm = evaluate(mid)
        best = min(best, float(Dm.min()))
        a, b = np.concatenate([a, mid]), np.concatenate([mid, b])
        Da, Db = np.concatenate([Da, Dm]), np.concatenate([Dm, Db])
    times = np.concatenate(seen_t)
    D = np.concatenate(seen_d)  # (n_times, n_pairs)
    k_t = np.argmin(D, axis=0)
    names = scene.pair_names()
    link_of = scene.link_of
    per = [
        PairClearance(
            _pair_name(names[p], link_of),
            (link_of[names[p][0]], link_of[names[p][1]]),
            float(D[k_t[p], p]),
            float(times[k_t[p]] - t0),
        )
        for p in range(n)
    ]
    per.sort(key=lambda x: x.min_distance_m)
    low = per[0]
    ok = low.min_distance_m >= c
    return ClearanceReport(
        c, ok, low.min_distance_m, low.time_s, low.pair, per, len(times), tol_m, scene.source
    )


def _pair_name(pair: tuple[str, str], link_of: dict[str, str]) -> str:
    a, b = pair
    sa = a if link_of[a] == a else f"{a} ({link_of[a]})"
    sb = b if link_of[b] == b else f"{b} ({link_of[b]})"
    return f"{sa} and {sb}"
