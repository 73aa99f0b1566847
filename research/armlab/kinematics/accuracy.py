"""Positioning accuracy: Monte-Carlo of reducer angle errors and link-length tolerances
(HEU thesis, 3.7).

Method (thesis 3.7.1-3.7.3): the joint angles are drawn uniformly inside their ranges; each
reducer transmits its angle with an error drawn uniformly in ``+-e`` (the encoder sits on the
motor shaft, so its error, 0.0001-0.001 deg after the >100:1 reducers, is negligible — thesis
3.7.1); each machined length is off by a value drawn uniformly within its tolerance (3.7.2);
twist (``alpha``) errors are neglected (axis concentricity 0.02 mm gives < 0.0005 deg, 3.7.3).
The position error of a point is ``dp = p(theta + dtheta, a + da, d + dd) - p(theta, a, d)``,
evaluated with the closed-form modified-DH chain (:func:`armlab.robot.dh.mdh_transforms`), per
axis (x, y, z of the base) and in total ``|dp|``. Three error sets come from the same draws:
angle errors alone, length errors alone, and both together (3.7.3).

Values and their sources
------------------------
* Reducer angle error ``e``: the OCR of the thesis' value is unreadable ("9，，"). We take
  **e = 5 arcmin = 1.454e-3 rad** (:data:`REDUCER_ANGLE_ERROR_RAD`): with the thesis' own
  evaluation (``point="wrist_centre"``: position of eq. 3-8, a function of ``theta_1..3``
  only, 3000 samples) it reproduces the thesis' conclusion — single-axis errors within
  about +-0.8 mm (max |dx|, |dy|, |dz| = 0.85-0.87 mm, 99th percentile 0.6 mm) and a total of
  about 1 mm (max 1.04 mm). The thesis also says 0.01 deg (< 1 arcmin) is hard to reach for a
  reducer, consistent with a few arcmin.
* Length tolerances (thesis 3.7.2, :data:`LINK_TOLERANCES_M`): ``a1 +-0.2 mm``,
  ``a2 +-0.2 mm``, ``a3 +-0.1 mm`` and ``d4 +-0.2 mm`` — **d4 uncertain** (OCR "士。加m").
  Thesis names follow the DH table: ``a1 = a_1 = 120 mm`` (row 2), ``a2 = 220 mm``,
  ``a3 = 80 mm``, ``d4 = 202 mm``.

``point="tool"`` (default) evaluates the tool centre point with errors on all six joints — the
figure the controller's tracking is judged against (:attr:`AccuracyResult.total_p95_m`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import ArmlabError, InputError
from armlab.robot.dh import mdh_transforms

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "AccuracyResult",
    "accuracy_study",
    "REDUCER_ANGLE_ERROR_RAD",
    "LINK_TOLERANCES_M",
    "PERCENTILES",
]

#: reducer transmission error bound ``e`` (uniform in ``+-e``), 5 arcmin in [rad] (chosen, see
#: the module docstring: reproduces the thesis' 3.7.1 conclusion)
REDUCER_ANGLE_ERROR_RAD = math.radians(5.0 / 60.0)

#: machining tolerances of thesis 3.7.2 in [m] (``d4`` uncertain OCR)
LINK_TOLERANCES_M = {"a1": 0.2e-3, "a2": 0.2e-3, "a3": 0.1e-3, "d4": 0.2e-3}

#: percentiles reported by :meth:`AccuracyResult.summary`
PERCENTILES = (50.0, 95.0, 99.0)

_SOURCES = ("angle", "length", "combined")


def _param_index(name: str, n: int) -> tuple[str, int]:
    """("a" or "d", 0-based row) of a thesis parameter name: ``a1`` is a_1 (row 2), ``d4`` d_4."""
    if len(name) < 2 or name[0] not in "ad" or not name[1:].isdigit():
        raise InputError(f"unknown length parameter {name!r} (use a0..a{n - 1} or d1..d{n})")
    k = int(name[1:])
    if name[0] == "a":
        if not 0 <= k <= n - 1:
            raise InputError(f"length parameter {name!r}: a index must be 0..{n - 1}")
        return "a", k
    if not 1 <= k <= n:
        raise InputError(f"length parameter {name!r}: d index must be 1..{n}")
    return "d", k - 1


@dataclass
class AccuracyResult:
    """Monte-Carlo positioning errors.

    Attributes
    ----------
    robot : str
    n_samples, seed : int
    point : str
        ``"tool"`` or ``"wrist_centre"``.
    angle_error_rad : ndarray (n_joints,)
        Bound ``e`` of the uniform angle error per joint in [rad] (0 for joints left out).
    length_tolerances_m : dict of str to float
        Tolerance (uniform ``+-``) per DH length, thesis names, in [m].
    q : ndarray (n_samples, n_joints)
        Sampled configurations in [rad].
    error_angle_m, error_length_m, error_combined_m : ndarray (n_samples, 3)
        Position error (base x, y, z) in [m] from the angle errors alone, the length errors
        alone, and both.
    dtheta_rad : ndarray (n_samples, n_joints)
        The drawn joint angle errors in [rad].
    dlength_m : dict of str to ndarray (n_samples,)
        The drawn length errors in [m], per parameter.
    """

    robot: str
    n_samples: int
    seed: int
    point: str
    angle_error_rad: np.ndarray
    length_tolerances_m: dict
    q: np.ndarray = field(repr=False)
    error_angle_m: np.ndarray = field(repr=False)
    error_length_m: np.ndarray = field(repr=False)
    error_combined_m: np.ndarray = field(repr=False)
    dtheta_rad: np.ndarray = field(repr=False, default_factory=lambda: np.zeros((0, 0)))
    dlength_m: dict = field(repr=False, default_factory=dict)

    def errors(self, source: str = "combined") -> np.ndarray:
        """Errors (n_samples, 3) in [m] of one source: ``angle``, ``length`` or ``combined``."""
        if source not in _SOURCES:
            raise InputError(f"unknown error source {source!r} (use {', '.join(_SOURCES)})")
        return {
            "angle": self.error_angle_m,
            "length": self.error_length_m,
            "combined": self.error_combined_m,
        }[source]

    def total_m(self, source: str = "combined") -> np.ndarray:
        """Total position error ``|dp|`` (n_samples,) in [m]."""
        return np.linalg.norm(self.errors(source), axis=1)

    @property
    def total_p95_m(self) -> float:
        """95th percentile of the total error from both sources, in [m]: "the positioning
        accuracy" used to judge tracking."""
        return float(np.percentile(self.total_m("combined"), 95.0))

    @property
    def total_max_m(self) -> float:
        """Largest total error from both sources among the samples, in [m]."""
        return float(self.total_m("combined").max())

    def summary(self, source: str = "combined") -> dict:
        """Per axis (``|dx|``, ``|dy|``, ``|dz|``) and total: percentiles, max, rms, in [m]."""
        e = self.errors(source)
        out = {}
        for k, axis in enumerate("xyz"):
            a = np.abs(e[:, k])
            out[axis] = {f"p{p:g}_m": float(np.percentile(a, p)) for p in PERCENTILES}
            out[axis]["max_m"] = float(a.max())
            out[axis]["rms_m"] = float(np.sqrt(np.mean(e[:, k] ** 2)))
        t = np.linalg.norm(e, axis=1)
        out["total"] = {f"p{p:g}_m": float(np.percentile(t, p)) for p in PERCENTILES}
        out["total"]["max_m"] = float(t.max())
        out["total"]["rms_m"] = float(np.sqrt(np.mean(t**2)))
        return out

    def to_dict(self) -> dict:
        return {
            "robot": self.robot,
            "n_samples": int(self.n_samples),
            "seed": int(self.seed),
            "point": self.point,
            "angle_error_rad": [float(x) for x in self.angle_error_rad],
            "angle_error_arcmin": [float(math.degrees(x) * 60.0) for x in self.angle_error_rad],
            "length_tolerances_m": {k: float(v) for k, v in self.length_tolerances_m.items()},
            "total_p95_m": self.total_p95_m,
            "total_max_m": self.total_max_m,
            "errors": {s: self.summary(s) for s in _SOURCES},
            "assumptions": [
                "reducer angle error bound 5 arcmin chosen (thesis value unreadable) to "
                "reproduce thesis 3.7.1 (+-0.8 mm per axis, ~1 mm total at the wrist centre)",
                "d4 tolerance +-0.2 mm uncertain (OCR)",
                "uniform distributions (thesis 3.7.1, 3.7.2); alpha errors neglected (3.7.3)",
            ],
        }


def _positions(a, alpha, d, theta, upto: int, T_end: np.ndarray) -> np.ndarray:
    """Positions (n, 3) of ``T_0,upto @ T_end`` for per-sample DH parameters."""
    F = mdh_transforms(a, alpha, d, theta)
    T = F[:, 0]
    for i in range(1, upto):
        T = T @ F[:, i]
    return (T @ T_end)[:, :3, 3]


def accuracy_study(
    robot: Robot,
    n_samples: int = 3000,
    seed: int = 0,
    *,
    angle_error_rad=REDUCER_ANGLE_ERROR_RAD,
    length_tolerances_m: dict | None = None,
    point: str = "tool",
) -> AccuracyResult:
    """Monte-Carlo positioning accuracy (thesis 3.7).

    Parameters
    ----------
    robot : Robot
        A robot with a DH table (``robot.dh``; teachbot6).
    n_samples : int
        Random configurations (thesis: 3000).
    seed : int
        Seed of ``numpy.random.default_rng``; same seed, same result.
    angle_error_rad : float or array (n_joints,)
        Bound ``e`` of the uniform reducer angle error in [rad] (default 5 arcmin on every joint;
        see the module docstring).
    length_tolerances_m : dict, optional
        ``{"a1": 0.2e-3, ...}`` uniform ``+-`` tolerances in [m] on DH lengths (thesis names:
        ``a_k`` = the ``a`` of row ``k + 1``, ``d_k`` of row ``k``); default
        :data:`LINK_TOLERANCES_M`.
    point : {"tool", "wrist_centre"}
        ``"tool"``: the tool centre point, errors on all joints. ``"wrist_centre"``: the
        thesis' evaluation of 3.7 — the origin of DH frame 4 (eq. 3-8), which only joints 1-3
        and the lengths before it move.

    Returns
    -------
    AccuracyResult
    """
    dh = getattr(robot, "dh", None)
    if dh is None:
        raise ArmlabError(f"accuracy study of {robot.name}: needs a DH table (robot.dh is None)")
    n = int(n_samples)
    if n < 1:
        raise InputError(f"n_samples must be >= 1, not {n_samples!r}")
    nj = dh.n_joints
    e = np.broadcast_to(np.asarray(angle_error_rad, dtype=float), (nj,)).copy()
    if not np.all(np.isfinite(e)) or np.any(e < 0):
        raise InputError(f"angle_error_rad must be finite and >= 0, got {angle_error_rad!r}")
    tolerances = dict(LINK_TOLERANCES_M if length_tolerances_m is None else length_tolerances_m)
    for name, tol in tolerances.items():
        _param_index(name, nj)
        if not (math.isfinite(float(tol)) and float(tol) >= 0):
            raise InputError(f"tolerance of {name} must be finite and >= 0, got {tol!r}")
    if point == "tool":
        upto = nj
        T_end = robot.model.frames[robot.tool_frame_id].placement.homogeneous
        if robot.model.frames[robot.tool_frame_id].parentJoint != nj:
            T_end = dh.transform_tool_to_last
    elif point == "wrist_centre":
        upto, T_end = 4, np.eye(4)
        e[3:] = 0.0  # joints 4.. do not move the wrist centre
    else:
        raise InputError(f"point must be 'tool' or 'wrist_centre', not {point!r}")

    rng = np.random.default_rng(seed)
    q = robot.random_q(rng, n)
    dtheta = rng.uniform(-1.0, 1.0, (n, nj)) * e
    a = np.broadcast_to(dh.a_m, (n, nj)).copy()
    d = np.broadcast_to(dh.d_m, (n, nj)).copy()
    a_err, d_err = a.copy(), d.copy()
    dlength = {}
    for name in sorted(tolerances):  # sorted: the draw order does not depend on dict order
        kind, k = _param_index(name, nj)
        delta = rng.uniform(-1.0, 1.0, n) * float(tolerances[name])
        (a_err if kind == "a" else d_err)[:, k] += delta
        dlength[name] = delta
    alpha = dh.alpha_rad
    theta = q + dh.offset_rad
    p0 = _positions(a, alpha, d, theta, upto, T_end)
    err_angle = _positions(a, alpha, d, theta + dtheta, upto, T_end) - p0
    err_length = _positions(a_err, alpha, d_err, theta, upto, T_end) - p0
    err_both = _positions(a_err, alpha, d_err, theta + dtheta, upto, T_end) - p0
    return AccuracyResult(
        robot=robot.name,
        n_samples=n,
        seed=int(seed),
        point=point,
        angle_error_rad=e,
        length_tolerances_m={k: float(v) for k, v in tolerances.items()},
        q=q,
        error_angle_m=err_angle,
        error_length_m=err_length,
        error_combined_m=err_both,
        dtheta_rad=dtheta,
        dlength_m=dlength,
    )
