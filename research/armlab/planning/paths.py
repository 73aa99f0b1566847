"""Geometric paths that know their arc length: joint line, Cartesian line, arc, blended chain.

A path maps an arc length ``s`` in ``[0, length]`` to a point: a joint vector for
:class:`JointPath`, a tool pose (4, 4) in the world for the Cartesian paths. Cartesian paths
also give the derivatives the planners need to map a speed profile ``s(t)`` into joint space::

    p(s), dp/ds, d2p/ds2                 (position of the tool centre point, [m])
    R(s), w_s = omega / sdot, dw_s/ds    (orientation; angular velocity per unit s, world axes)

Geometry:

* **line** (Jiang 1987, eq. 6-9; HEU thesis, 6.3.3): ``p(s) = p0 + (p1 - p0) s / L``;
  orientation held or turned about one fixed axis at a constant rate (slerp, thesis 6.3.6
  "simultaneous").
  If the rotation is large for the distance, the path length is ``max(|p1 - p0|, rho theta)``
  with ``rho = rotation_radius_m``: the orientation then moves like a point at distance
  ``rho`` from the tool centre point (a pure reorientation is a path of length ``rho theta``).
* **arc through three points** (Jiang 1987, eq. 10-24; HEU thesis, 6.3.4-6.3.5): the thesis'
  frame (origin P1, ``x'`` along P1P3, ``z'`` along P1P3 x P1P2, ``y' = z' x x'``) makes the arc
  planar; the circle ``X'^2 + Y'^2 - 2 m X' - 2 n Y' + q = 0`` through the three points solves
  the 3 x 3 system of Jiang 1987, eq. 18 (Cramer's rule, eq. 19) and ``R`` follows from eq. 20.
  The polar angle advances by ``ds / R`` (eq. 21).
* **tangent-arc corner blend** (SHU controller paper, §2.2 (2)): at a corner P2 between P1P2
  and P2P3 with turning angle ``beta`` (corner angle ``gamma = pi - beta``), the arc of radius
  ``R`` touches both lines at ``Q1 = P2 - R tan(beta/2) u_in`` and
  ``Q2 = P2 + R tan(beta/2) u_out``; its centre lies on the bisector at ``R / sin(gamma/2)``
  from P2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from armlab.errors import InputError

__all__ = [
    "JointPath",
    "CartesianPath",
    "LinePath",
    "ArcPath",
    "BlendPath",
    "PathSample",
    "Circle",
    "circle_through",
    "OrientationLaw",
]


# ---------------------------------------------------------------------- joint space
class JointPath:
    """Straight line in joint space; ``s`` is the Euclidean joint distance in [rad].

    Parameters
    ----------
    q_start, q_goal : array (n_joints,)
        End points in [rad].
    """

    is_cartesian = False

    def __init__(self, q_start, q_goal) -> None:
        self.q_start = np.asarray(q_start, float).reshape(-1)
        self.q_goal = np.asarray(q_goal, float).reshape(-1)
        if self.q_start.shape != self.q_goal.shape or not (
            np.all(np.isfinite(self.q_start)) and np.all(np.isfinite(self.q_goal))
        ):
            raise InputError("JointPath: q_start and q_goal must be finite and of equal shape")
        delta = self.q_goal - self.q_start
        self.length = float(np.linalg.norm(delta))
        self.direction = delta / self.length if self.length > 0 else np.zeros_like(delta)

    def point(self, s) -> np.ndarray:
        """Joint positions at ``s``: (n_joints,) for a scalar, (n, n_joints) for an array."""
        s_arr = np.clip(np.asarray(s, float), 0.0, self.length)
        q = self.q_start + np.multiply.outer(s_arr, self.direction)
        end = s_arr >= self.length
        if np.ndim(s_arr) == 0:
            return self.q_goal.copy() if end else q
        q[end] = self.q_goal
        return q

    def speed_limits(self, v_max, a_max) -> tuple[float, float]:
        """Largest path speed [rad/s] and acceleration [rad/s^2] keeping every joint within
        ``v_max``, ``a_max`` (n_joints,): ``min_j v_j / |u_j|`` with ``u`` the unit direction."""
        u = np.abs(self.direction)
        m = u > 0
        if not np.any(m):
            return math.inf, math.inf
        return (
            float(np.min(np.asarray(v_max)[m] / u[m])),
            float(np.min(np.asarray(a_max)[m] / u[m])),
        )


# ---------------------------------------------------------------------- orientation
def _skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def _rotations(axis_w: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rodrigues: (n, 3, 3) rotations by ``angles`` about the unit world axis."""
    K = _skew(axis_w)
    s, c = np.sin(angles)[:, None, None], np.cos(angles)[:, None, None]
    return np.eye(3) + s * K + (1 - c) * (K @ K)


@dataclass
class OrientationLaw:
    """Orientation along a path: ``R(s) = Rot(axis_w, rate s) R0`` (world axis).

    Holding (``rate = 0``), slerp from ``R0`` to ``R1`` over a length ``L``
    (``axis_w = R0 a``, ``rate = theta / L`` with ``R0^T R1 = Rot(a, theta)``) and turning
    with an arc (``axis_w`` = arc normal, ``rate = 1 / radius``) are all of this form, so the
    angular velocity per unit ``s`` is the constant ``w_s = rate axis_w`` and ``dw_s/ds = 0``.
    """

    R0: np.ndarray
    axis_w: np.ndarray
    rate: float
    mode: str

    @classmethod
    def hold(cls, R0) -> OrientationLaw:
        return cls(np.asarray(R0, float), np.array([0.0, 0.0, 1.0]), 0.0, "hold")

    @classmethod
    def slerp(cls, R0, R1, length: float) -> OrientationLaw:
        R0, R1 = np.asarray(R0, float), np.asarray(R1, float)
        aa = pin.log3(R0.T @ R1)
        theta = float(np.linalg.norm(aa))
        if theta < 1e-12 or length <= 0:
            return cls.hold(R0)
        return cls(R0, R0 @ (aa / theta), theta / length, "slerp")

    @classmethod
    def about(cls, R0, axis_w, rate: float, mode: str = "rotate") -> OrientationLaw:
        axis = np.asarray(axis_w, float)
        return cls(np.asarray(R0, float), axis / np.linalg.norm(axis), float(rate), mode)

    def evaluate(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s = np.asarray(s, float).reshape(-1)
        R = _rotations(self.axis_w, self.rate * s) @ self.R0
        w = np.broadcast_to(self.rate * self.axis_w, (s.size, 3)).copy()
        return R, w, np.zeros((s.size, 3))


# ---------------------------------------------------------------------- pieces
class _LinePiece:
    def __init__(self, p0, p1) -> None:
        self.p0, self.p1 = np.asarray(p0, float), np.asarray(p1, float)
        self.length = float(np.linalg.norm(self.p1 - self.p0))
        self.u = (self.p1 - self.p0) / self.length if self.length > 0 else np.zeros(3)

    def evaluate(self, u: np.ndarray):
        p = self.p0 + np.outer(u, self.u)
        dp = np.broadcast_to(self.u, p.shape).copy()
        return p, dp, np.zeros_like(p)


@dataclass
class Circle:
    """A circle in space: centre [m], radius [m], unit normal, in-plane unit axes ``e1``
    (centre to the first point) and ``e2 = normal x e1`` (direction of travel at it)."""

    centre: np.ndarray
    radius: float
    normal: np.ndarray
    e1: np.ndarray
    e2: np.ndarray

    def angle_of(self, p) -> float:
        """Polar angle of ``p`` in [0, 2 pi) about the normal, from ``e1``."""
        d = np.asarray(p, float) - self.centre
        return float(np.mod(math.atan2(d @ self.e2, d @ self.e1), 2 * math.pi))

    def point(self, phi) -> np.ndarray:
        phi = np.asarray(phi, float)
        return self.centre + self.radius * (
            np.multiply.outer(np.cos(phi), self.e1) + np.multiply.outer(np.sin(phi), self.e2)
        )


def _point3(p, name: str) -> np.ndarray:
    a = np.asarray(p, float)
    if a.shape == (4, 4):
        a = a[:3, 3]
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise InputError(
            f"{name} must be a finite (3,) position in [m] or a (4, 4) pose, "
            f"got shape {np.shape(p)}"
        )
    return a


def circle_through(p1, p2, p3, *, tol: float = 1e-9) -> Circle:
    """The circle through three points, oriented so that P1 -> P2 -> P3 runs positively.

    Jiang 1987, eq. 10-20 / HEU thesis, 6.3.5: in the frame with origin P1, ``x'`` along P1P3 and
    ``z'`` along P1P3 x P1P2, the circle ``X'^2 + Y'^2 - 2 m X' - 2 n Y' + q = 0`` solves
    ``[2X'_i  2Y'_i  1] [-m, -n, q]^T = -(X'_i^2 + Y'_i^2)`` (eq. 18); the centre is
    ``(m, n)`` (eq. 19) and ``R = sqrt((X'_1 - m)^2 + (Y'_1 - n)^2)`` (eq. 20).

    Raises
    ------
    InputError
        The points coincide or are collinear (relative tolerance ``tol``): no unique circle.
    """
    P1, P2, P3 = (_point3(p, f"arc point {i}") for i, p in enumerate((p1, p2, p3), 1))
    a, b = P3 - P1, P2 - P1
    cross = np.cross(a, b)
    scale = max(np.linalg.norm(a), np.linalg.norm(b), np.linalg.norm(P3 - P2))
    if scale == 0 or np.linalg.norm(cross) <= tol * scale * scale:
        raise InputError(
            f"arc points {P1.tolist()}, {P2.tolist()}, {P3.tolist()} coincide or are collinear:"
            " no unique circle through them"
        )
    x = a / np.linalg.norm(a)
    z = cross / np.linalg.norm(cross)
    y = np.cross(z, x)
    pts = np.array([[0.0, 0.0], [b @ x, b @ y], [a @ x, a @ y]])
    M = np.column_stack([2 * pts[:, 0], 2 * pts[:, 1], np.ones(3)])
    rhs = -(pts**2).sum(axis=1)
    minus_m, minus_n, _q = np.linalg.solve(M, rhs)
    m, n = -minus_m, -minus_n
    radius = math.hypot(pts[0, 0] - m, pts[0, 1] - n)
    centre = P1 + m * x + n * y
    # P2 lies at y' > 0 and P3 on +x': the travel P1 -> P2 -> P3 is clockwise about z',
    # i.e. positive about -z'
    normal = -z
    e1 = (P1 - centre) / np.linalg.norm(P1 - centre)
    e2 = np.cross(normal, e1)
    return Circle(centre, radius, normal, e1, e2)


class _ArcPiece:
    def __init__(self, circle: Circle, angle: float) -> None:
        self.circle, self.angle = circle, float(angle)
        self.length = circle.radius * self.angle

    def evaluate(self, u: np.ndarray):
        c = self.circle
        phi = u / c.radius
        cos, sin = np.cos(phi)[:, None], np.sin(phi)[:, None]
        radial = cos * c.e1 + sin * c.e2
        p = c.centre + c.radius * radial
        dp = -sin * c.e1 + cos * c.e2
        ddp = -radial / c.radius
        return p, dp, ddp


# ---------------------------------------------------------------------- Cartesian paths
@dataclass
class PathSample:
    """Path values at arc lengths ``s`` (n,): ``position`` (n, 3) [m], ``rotation`` (n, 3, 3),
    ``dp_ds`` (n, 3) [-], ``d2p_ds2`` (n, 3) [1/m], ``w_s`` (n, 3) [rad/m] (angular velocity per
    unit s, world axes), ``dw_s`` (n, 3) [rad/m^2]."""

    s: np.ndarray
    position: np.ndarray
    rotation: np.ndarray
    dp_ds: np.ndarray
    d2p_ds2: np.ndarray
    w_s: np.ndarray
    dw_s: np.ndarray

    def poses(self) -> np.ndarray:
        """(n, 4, 4) tool poses in the world."""
        T = np.zeros((self.s.size, 4, 4))
        T[:, :3, :3] = self.rotation
        T[:, :3, 3] = self.position
        T[:, 3, 3] = 1.0
        return T


class CartesianPath:
    """A chain of line and arc pieces (G1 where the pieces meet) with an orientation law.

    ``length`` is the arc length of the tool centre point in [m] (or longer than the pieces,
    for a line dominated by its rotation: then every piece is scaled, see :class:`LinePath`).
    """

    is_cartesian = True

    def __init__(
        self, pieces, orientation: OrientationLaw, length: float | None = None, kind: str = "path"
    ) -> None:
        self.pieces = [p for p in pieces if p.length > 0] or list(pieces[:1])
        self.cum = np.concatenate([[0.0], np.cumsum([p.length for p in self.pieces])])
        self.piece_length = float(self.cum[-1])
        self.length = self.piece_length if length is None else float(length)
        self._scale = self.piece_length / self.length if self.length > 0 else 0.0
        self.orientation = orientation
        self.kind = kind

    def evaluate(self, s) -> PathSample:
        """Position, orientation and their derivatives at ``s`` (n,) in [m] (clamped)."""
        s = np.clip(np.asarray(s, float).reshape(-1), 0.0, self.length)
        u = s * self._scale  # length along the pieces
        k = np.clip(np.searchsorted(self.cum, u, side="right") - 1, 0, len(self.pieces) - 1)
        p = np.empty((s.size, 3))
        dp = np.empty_like(p)
        ddp = np.empty_like(p)
        for i, piece in enumerate(self.pieces):
            m = k == i
            if np.any(m):
                p[m], dp[m], ddp[m] = piece.evaluate(np.clip(u[m] - self.cum[i], 0, piece.length))
        dp *= self._scale
        ddp *= self._scale**2
        R, w, dw = self.orientation.evaluate(s)
        return PathSample(s, p, R, dp, ddp, w, dw)

    @property
    def junctions(self) -> np.ndarray:
        """Arc lengths [m] where one piece meets the next (the curvature steps there)."""
        if self._scale <= 0:
            return np.zeros(0)
        return self.cum[1:-1] / self._scale

    def point(self, s) -> np.ndarray:
        """Tool pose(s) at ``s``: (4, 4) for a scalar, (n, 4, 4) for an array."""
        T = self.evaluate(s).poses()
        return T[0] if np.ndim(s) == 0 else T

    @property
    def start_pose(self) -> np.ndarray:
        return self.point(0.0)

    @property
    def end_pose(self) -> np.ndarray:
        return self.point(self.length)


def _pose(T, name: str) -> np.ndarray:
    T = np.asarray(T, float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise InputError(f"{name} must be a finite (4, 4) pose, got shape {T.shape}")
    R = T[:3, :3]
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0:
        raise InputError(f"{name} has no proper rotation matrix in its upper-left 3 x 3 block")
    return T


class LinePath(CartesianPath):
    """Straight line between two tool poses (Jiang 1987, eq. 6-9; HEU thesis, 6.3.3).

    Parameters
    ----------
    pose_start, pose_goal : array (4, 4)
        Tool poses in the world.
    orientation : {"slerp", "hold"}
        ``"slerp"``: the rotation turns at a constant rate about one axis from start to goal
        (thesis 6.3.6, simultaneous); ``"hold"``: the start orientation is kept (the goal's
        rotation is ignored).
    rotation_radius_m : float
        ``rho``: with ``"slerp"`` the length is ``max(|p1 - p0|, rho theta)`` (see the module
        docstring) so that a large rotation over a short distance is not infinitely fast.
    """

    def __init__(
        self, pose_start, pose_goal, orientation: str = "slerp", rotation_radius_m: float = 0.1
    ) -> None:
        T0, T1 = _pose(pose_start, "pose_start"), _pose(pose_goal, "pose_goal")
        if orientation not in ("slerp", "hold"):
            raise InputError(f"line orientation must be 'slerp' or 'hold', not {orientation!r}")
        if not rotation_radius_m > 0:
            raise InputError("rotation_radius_m must be > 0 [m]")
        piece = _LinePiece(T0[:3, 3], T1[:3, 3])
        theta = float(np.linalg.norm(pin.log3(T0[:3, :3].T @ T1[:3, :3])))
        if theta < 1e-12:
            theta = 0.0
        if piece.length < 1e-12:
            piece = _LinePiece(T0[:3, 3], T0[:3, 3])
        length = piece.length
        if orientation == "slerp":
            length = max(length, rotation_radius_m * theta)
        law = (
            OrientationLaw.slerp(T0[:3, :3], T1[:3, :3], length)
            if orientation == "slerp"
            else OrientationLaw.hold(T0[:3, :3])
        )
        super().__init__([piece], law, length, kind="line")
        self.pose_start, self.pose_goal = T0, T1
        self.rotation_angle = theta
        self.orientation_mode = orientation


class ArcPath(CartesianPath):
    """Arc (or full circle) through three points (Jiang 1987, eq. 10-24; HEU thesis, 6.3.4-6.3.5).

    Parameters
    ----------
    p1, p2, p3 : array (3,) or (4, 4)
        Positions in [m] (or poses: their translations; ``p1``'s rotation is the start
        orientation unless ``rotation`` is given).
    rotation : array (3, 3), optional
        Start orientation of the tool.
    orientation : {"hold", "rotate", "slerp"}
        ``"hold"``: constant; ``"rotate"``: the tool turns with the arc about its normal (keeps
        its attitude to the tangent); ``"slerp"``: from the start rotation to ``rotation_end``
        (or ``p3``'s rotation when ``p3`` is a pose) at a constant rate.
    full_circle : bool
        Go on past P3 back to P1 (angle ``2 pi``).
    """

    def __init__(
        self,
        p1,
        p2,
        p3,
        *,
        rotation=None,
        orientation: str = "hold",
        rotation_end=None,
        full_circle: bool = False,
    ) -> None:
        circle = circle_through(p1, p2, p3)
        self.circle = circle
        self.angle_p2 = circle.angle_of(_point3(p2, "p2"))
        self.angle_p3 = circle.angle_of(_point3(p3, "p3"))
        angle = 2 * math.pi if full_circle else self.angle_p3
        piece = _ArcPiece(circle, angle)
        R0 = (
            rotation
            if rotation is not None
            else (np.asarray(p1, float)[:3, :3] if np.shape(p1) == (4, 4) else None)
        )
        if R0 is None:
            raise InputError("arc: give the start orientation (rotation=..., or p1 as a pose)")
        R0 = _pose(
            np.block(
                [[np.asarray(R0, float), np.zeros((3, 1))], [np.zeros((1, 3)), np.ones((1, 1))]]
            ),
            "rotation",
        )[:3, :3]
        if orientation == "hold":
            law = OrientationLaw.hold(R0)
        elif orientation == "rotate":
            law = OrientationLaw.about(R0, circle.normal, 1.0 / circle.radius)
        elif orientation == "slerp":
            if full_circle:
                raise InputError(
                    "arc: orientation 'slerp' needs an end orientation; a full "
                    "circle ends where it starts (use 'hold' or 'rotate')"
                )
            R1 = (
                rotation_end
                if rotation_end is not None
                else (np.asarray(p3, float)[:3, :3] if np.shape(p3) == (4, 4) else None)
            )
            if R1 is None:
                raise InputError("arc: orientation 'slerp' needs rotation_end or p3 as a pose")
            law = OrientationLaw.slerp(R0, R1, piece.length)
        else:
            raise InputError(
                f"arc orientation must be 'hold', 'rotate' or 'slerp', not {orientation!r}"
            )
        super().__init__([piece], law, kind="circle" if full_circle else "arc")
        self.full_circle = full_circle
        self.orientation_mode = orientation

    @property
    def s_points(self) -> np.ndarray:
        """Arc lengths [m] at P1, P2, P3 (and back at P1 for a full circle)."""
        r = self.circle.radius
        out = [0.0, r * self.angle_p2, r * self.angle_p3]
        if self.full_circle:
            out.append(2 * math.pi * r)
        return np.array(out)


class BlendPath(CartesianPath):
    """Lines through a chain of points with every corner rounded by a tangent arc (FlyBy,
    SHU controller paper, §2.2 (2); Li, Meng, Chen).

    Parameters
    ----------
    points : array (n, 3) or (n, 4, 4)
        The taught points in [m] (n >= 2).
    radius : float or array (n - 2,)
        Blend radius of each interior corner in [m] (> 0; a straight-through corner needs
        none).
    rotation : array (3, 3), optional
        Start orientation (default: the first pose's, when points are poses).
    orientation : {"hold", "slerp"}
        Hold the start orientation, or turn at a constant rate over the whole length from the
        first to the last orientation (``rotation_end`` or the last pose's). The orientations
        of intermediate poses are not used.

    Raises
    ------
    InputError
        Fewer than two points, repeated points, a corner that turns back on itself, or a
        radius whose tangent points do not fit on a segment (the message names the segment
        and the room it has).
    """

    def __init__(
        self, points, radius, *, rotation=None, orientation: str = "hold", rotation_end=None
    ) -> None:
        pts_in = np.asarray(points, float)
        if pts_in.ndim == 3 and pts_in.shape[1:] == (4, 4):
            P = pts_in[:, :3, 3]
            if rotation is None:
                rotation = pts_in[0, :3, :3]
            if rotation_end is None:
                rotation_end = pts_in[-1, :3, :3]
        elif pts_in.ndim == 2 and pts_in.shape[1] == 3:
            P = pts_in
        else:
            raise InputError(
                f"blend points have shape {pts_in.shape}, expected (n, 3) or (n, 4, 4)"
            )
        n = P.shape[0]
        if n < 2 or not np.all(np.isfinite(P)):
            raise InputError("blend needs at least two finite points")
        seg = np.diff(P, axis=0)
        seg_len = np.linalg.norm(seg, axis=1)
        if np.any(seg_len < 1e-12):
            k = int(np.argmin(seg_len))
            raise InputError(f"blend points {k} and {k + 1} coincide")
        u = seg / seg_len[:, None]
        r = (
            np.broadcast_to(np.asarray(radius, float), (max(n - 2, 0),)).copy()
            if n > 2
            else np.zeros(0)
        )
        if r.size and (not np.all(np.isfinite(r)) or np.any(r < 0)):
            raise InputError(f"blend radius must be >= 0 [m], got {np.asarray(radius).tolist()}")
        tangent = np.zeros(max(n - 2, 0))
        arcs: list[_ArcPiece | None] = []
        for c in range(n - 2):
            cosb = float(np.clip(u[c] @ u[c + 1], -1.0, 1.0))
            beta = math.acos(cosb)
            if beta < 1e-9:  # straight through
                arcs.append(None)
                continue
            if beta > math.pi - 1e-9:
                raise InputError(
                    f"blend corner at point {c + 1} turns back on itself (180 deg):"
                    " no tangent arc exists"
                )
            if r[c] <= 0:
                raise InputError(
                    f"blend radius at point {c + 1} must be > 0 for a corner of "
                    f"{math.degrees(beta):.3g} deg (a sharp corner needs a stop)"
                )
            t = r[c] * math.tan(beta / 2)
            tangent[c] = t
            bis = u[c + 1] - u[c]
            bis /= np.linalg.norm(bis)
            centre = P[c + 1] + bis * (r[c] / math.cos(beta / 2))  # R / sin(gamma / 2)
            q1 = P[c + 1] - t * u[c]
            normal = np.cross(u[c], u[c + 1])
            normal /= np.linalg.norm(normal)
            e1 = (q1 - centre) / np.linalg.norm(q1 - centre)
            arcs.append(
                _ArcPiece(Circle(centre, float(r[c]), normal, e1, np.cross(normal, e1)), beta)
            )
        pieces: list[_LinePiece | _ArcPiece] = []
        for k in range(n - 1):
            t_in = tangent[k - 1] if k >= 1 else 0.0
            t_out = tangent[k] if k < n - 2 else 0.0
            room = seg_len[k] - t_in - t_out
            if room < -1e-12 * seg_len[k]:
                raise InputError(
                    f"blend radius too large for segment {k} (points {k} -> {k + 1}, "
                    f"{seg_len[k]:.6g} m long): its tangent points need {t_in + t_out:.6g} m"
                )
            a = P[k] + t_in * u[k]
            b = P[k + 1] - t_out * u[k]
            pieces.append(_LinePiece(a, b))
            arc = arcs[k] if k < n - 2 else None
            if arc is not None:
                pieces.append(arc)
        length = float(sum(p.length for p in pieces))
        if rotation is None:
            raise InputError("blend: give the start orientation (rotation=..., or poses)")
        R0 = np.asarray(rotation, float)
        if orientation == "hold":
            law = OrientationLaw.hold(R0)
        elif orientation == "slerp":
            if rotation_end is None:
                raise InputError("blend: orientation 'slerp' needs rotation_end or poses")
            law = OrientationLaw.slerp(R0, rotation_end, length)
        else:
            raise InputError(f"blend orientation must be 'hold' or 'slerp', not {orientation!r}")
        super().__init__(pieces, law, kind="blend")
        self.points = P
        self.radius = r
        self.tangent_lengths = tangent
        self.orientation_mode = orientation
