"""Which link pairs a collision check skips: the sampled analysis of MoveIt's setup assistant.

Two links on the same rigid body (fixed joints between them: ``link6``, ``flange``, ``tool0``)
are never a pair. Of the others a pair is **disabled** when it is

* ``adjacent``: the two bodies are joined by one joint (a link and its parent link); their
  geometries touch at the joint by construction;
* ``always``: in contact (signed distance <= 0) in every sampled configuration -- a default
  overlap of the description that no motion changes;
* ``never``: never closer than :data:`NEVER_MARGIN_M` in any sampled configuration, so the pair
  cannot meet within the joint ranges (to the sampling's resolution: the margin covers the gaps
  between samples).

The samples are ``samples`` configurations drawn uniformly inside the joint ranges from a seeded
generator (``numpy.random.default_rng(seed)``), as MoveIt's "sampling density" (Sucan, Chitta,
MoveIt Setup Assistant, ``compute_default_collisions.cpp``: adjacent, always, never in
collision). The analysis is stored as a TOML file a user can read and edit (one ``[[disabled]]``
table per pair, with the reason and the smallest sampled distance) and is keyed by the URDF's
sha256: :func:`disabled_pairs` reads, in this order, the file a study names
(``[robot] collision_pairs``, taken as written), ``<urdf folder>/collision_pairs.toml`` and the
cache file ``<cache>/collision/<robot>-<sha256[:16]>.toml`` when their ``urdf_sha256`` is the
URDF's, and otherwise runs the analysis and writes the cache file (``<cache>`` is
``$ARMLAB_CACHE_DIR``, else ``$XDG_CACHE_HOME/armlab``, else ``~/.cache/armlab``; a cache that
cannot be written is skipped, never an error).

A ``never`` pair is re-enabled by a scene whose clearance reaches within the margin of the
pair's smallest sampled distance (:meth:`DisabledPairs.skipped`): a study asking for 50 mm of
clearance checks every pair that came within 60 mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from armlab._cache import cache_dir
from armlab.errors import InputError
from armlab.io import atomic_write
from armlab.tomlfile import read_toml

if TYPE_CHECKING:
    from armlab.collision.geometry import RobotGeometry
    from armlab.robot.model import Robot

__all__ = [
    "DEFAULT_SAMPLES",
    "NEVER_MARGIN_M",
    "DisabledPairs",
    "analyse_pairs",
    "cache_dir",
    "disabled_pairs",
    "read_pairs",
    "write_pairs",
]

#: Configurations sampled by the analysis (MoveIt's default density is 10000; 2000 keeps the
#: analysis of a mesh arm within seconds and is what the shipped teachbot6 file used).
DEFAULT_SAMPLES = 2000
#: A pair never closer than this in the samples is ``never`` in contact, in [m].
NEVER_MARGIN_M = 0.01
REASONS = ("adjacent", "always", "never")


@dataclass
class DisabledPairs:
    """The disabled link pairs of a robot (module docstring).

    Attributes
    ----------
    pairs : dict of (str, str) to (str, float)
        ``(link_a, link_b)`` (sorted) -> (reason, smallest sampled distance in [m]).
    urdf_sha256 : str
        The URDF the analysis was made for.
    path : str
        The file the pairs were read from or written to (``""``: not stored).
    origin : str
        ``"study"``, ``"description"``, ``"cache"`` or ``"computed"``.
    samples, seed : int
        The analysis' sample count and seed.
    """

    pairs: dict[tuple[str, str], tuple[str, float]] = field(default_factory=dict)
    urdf_sha256: str = ""
    path: str = ""
    origin: str = "computed"
    samples: int = DEFAULT_SAMPLES
    seed: int = 0

    def skipped(self, a: str, b: str, clearance_m: float = 0.0) -> bool:
        """Whether the pair of links ``a``, ``b`` is not checked at ``clearance_m``."""
        entry = self.pairs.get((a, b) if a <= b else (b, a))
        if entry is None:
            return False
        reason, dmin = entry
        return reason != "never" or dmin > clearance_m + NEVER_MARGIN_M

    def counts(self) -> dict[str, int]:
        """Number of pairs per reason."""
        return {r: sum(1 for v in self.pairs.values() if v[0] == r) for r in REASONS}


def _link_pairs(gm: pin.GeometryModel, link_of: dict[str, str]) -> dict[tuple[str, str], list[int]]:
    """Candidate link pairs (links on different joints) -> indices of their geometry pairs in
    a geometry model with every such pair added (the caller's ``addAllCollisionPairs``)."""
    out: dict[tuple[str, str], list[int]] = {}
    objs = gm.geometryObjects
    for k, cp in enumerate(gm.collisionPairs):
        a, b = link_of[objs[cp.first].name], link_of[objs[cp.second].name]
        out.setdefault((a, b) if a <= b else (b, a), []).append(k)
    return out


def analyse_pairs(
    robot: Robot, geom: RobotGeometry, *, samples: int = DEFAULT_SAMPLES, seed: int = 0
) -> DisabledPairs:
    """The sampled analysis (module docstring) of a robot's geometry.

    Parameters
    ----------
    robot : Robot
    geom : RobotGeometry
        :func:`armlab.collision.geometry.robot_geometry` of ``robot``.
    samples : int
        Random configurations inside the joint ranges.
    seed : int
        Seed of ``numpy.random.default_rng``.
    """
    model = robot.model
    gm = geom.geometry.copy()
    gm.addAllCollisionPairs()  # every pair of geometries on different joints
    gd = pin.GeometryData(gm)
    data = model.createData()
    pairs = _link_pairs(gm, geom.link_of)
    joint_of: dict[str, int] = {}
    for obj in gm.geometryObjects:
        joint_of[geom.link_of[obj.name]] = obj.parentJoint
    Q = robot.random_q(np.random.default_rng(seed), samples)
    keys = list(pairs)
    dmin = np.full(len(keys), np.inf)
    always = np.ones(len(keys), dtype=bool)
    for q in Q:
        pin.framesForwardKinematics(model, data, q)
        pin.updateGeometryPlacements(model, data, gm, gd)
        pin.computeDistances(gm, gd)
        d = np.array([r.min_distance for r in gd.distanceResults])
        per = np.array([d[pairs[k]].min() for k in keys])
        dmin = np.minimum(dmin, per)
        always &= per <= 0.0
    out: dict[tuple[str, str], tuple[str, float]] = {}
    for i, (a, b) in enumerate(keys):
        ja, jb = joint_of[a], joint_of[b]
        if model.parents[ja] == jb or model.parents[jb] == ja:
            out[(a, b)] = ("adjacent", float(dmin[i]))
        elif always[i]:
            out[(a, b)] = ("always", float(dmin[i]))
        elif dmin[i] > NEVER_MARGIN_M:
            out[(a, b)] = ("never", float(dmin[i]))
    return DisabledPairs(out, geom.urdf_sha256, "", "computed", samples, seed)


def _num(x: float) -> str:
    return repr(round(float(x), 6)) if math.isfinite(x) else '"inf"'


def write_pairs(path: str | Path, pairs: DisabledPairs, robot_name: str, source: str) -> Path:
    """Write the analysis as a TOML file a user can read and edit; returns the path."""
    lines = [
        f"# Disabled collision pairs of {robot_name}: armlab.collision.pairs (adjacent links,",
        f"# pairs always in contact, pairs never within {NEVER_MARGIN_M} m in {pairs.samples}",
        f"# random configurations, seed {pairs.seed}). Edit freely: delete a [[disabled]] table",
        "# to check that pair, add one to skip a pair (reason adjacent, always or never).",
        f'robot = "{robot_name}"',
        f'urdf_sha256 = "{pairs.urdf_sha256}"',
        f'geometry = "{source}"',
        f"samples = {pairs.samples}",
        f"seed = {pairs.seed}",
    ]
    for (a, b), (reason, dmin) in sorted(pairs.pairs.items()):
        lines += [
            "",
            "[[disabled]]",
            f'a = "{a}"',
            f'b = "{b}"',
            f'reason = "{reason}"',
            f"min_distance_m = {_num(dmin)}",
        ]
    return atomic_write(path, "\n".join(lines) + "\n")


def read_pairs(path: str | Path, links: set[str] | None = None) -> DisabledPairs:
    """Read a disabled-pairs file (:func:`write_pairs`' format).

    Raises
    ------
    InputError
        One line naming the file and the key: a missing or malformed entry, an unknown reason,
        a link the robot does not have (``links``).
    """
    doc = read_toml(path, "collision pairs file", InputError)
    where = str(path)
    out: dict[tuple[str, str], tuple[str, float]] = {}
    entries = doc.get("disabled", [])
    if not isinstance(entries, list):
        raise InputError(f"{where}: disabled: expected [[disabled]] tables")
    for i, e in enumerate(entries):
        at = f"{where}: disabled[{i}]"
        if not isinstance(e, dict):
            raise InputError(f"{at}: expected a table with a, b, reason")
        a, b, reason = e.get("a"), e.get("b"), e.get("reason", "never")
        for key, v in (("a", a), ("b", b)):
            if not isinstance(v, str) or (links is not None and v not in links):
                raise InputError(f"{at}.{key}: {v!r} is not a link of the robot")
        if reason not in REASONS:
            raise InputError(f"{at}.reason: expected one of {', '.join(REASONS)}, not {reason!r}")
        dmin = e.get("min_distance_m", math.inf)
        if isinstance(dmin, str) and dmin == "inf":
            dmin = math.inf
        if isinstance(dmin, bool) or not isinstance(dmin, (int, float)):
            raise InputError(f"{at}.min_distance_m: expected a number, not {dmin!r}")
        assert isinstance(a, str) and isinstance(b, str)
        out[(a, b) if a <= b else (b, a)] = (str(reason), float(dmin))
    samples, seed = doc.get("samples", 0), doc.get("seed", 0)
    return DisabledPairs(
        out,
        str(doc.get("urdf_sha256", "")),
        str(path),
        "study",
        int(samples) if isinstance(samples, int) else 0,
        int(seed) if isinstance(seed, int) else 0,
    )


def disabled_pairs(
    robot: Robot, geom: RobotGeometry, path: str | Path | None = None, *, seed: int = 0
) -> DisabledPairs:
    """The disabled pairs of ``robot``: the file a study names, else the description's or the
    cached analysis for this URDF, else a new analysis written to the cache (module docstring).
    """
    links = set(geom.link_of.values())
    if path is not None:
        return read_pairs(path, links)
    sha = geom.urdf_sha256
    shipped = Path(robot.urdf_path).parent / "collision_pairs.toml"
    cached = cache_dir() / "collision" / f"{robot.name}-{sha[:16]}.toml"
    for origin, candidate in (("description", shipped), ("cache", cached)):
        if candidate.is_file():
            try:
                found = read_pairs(candidate, links)
            except InputError:
                continue  # a damaged cache is recomputed
            if found.urdf_sha256 == sha:
                found.origin = origin
                return found
    result = analyse_pairs(robot, geom, seed=seed)
    try:
        cached.parent.mkdir(parents=True, exist_ok=True)
        write_pairs(cached, result, robot.name, geom.source)
        result.path, result.origin = str(cached), "computed"
    except OSError:
        pass
    return result
