r"""Reducer life, momentary torque and output-bearing tilting moment over a duty cycle.

The checks a harmonic-reducer maker's selection procedure adds to the rated / peak torque and
input-speed limits (Harmonic Drive CSF/CSG catalogue, "Selection procedure" and "Technical
terms, life"; the same steps in Harmonic Drive AG's engineering data, "Torque based
dimensioning", equations of load limits 1-3 and the operating life):

* **Average output torque** (load limit 1; one home: :func:`average_torque_Nm`)::

      T_av = ( sum_k |n_k| t_k |T_k|^3 / sum_k |n_k| t_k )^(1/3)

  the cubic mean of the output torque weighted by output speed x time (the time-weighted
  cubic mean when the joint never moves).
* **Average input speed** (:func:`average_input_speed_rpm`)::

      n_av = N sum_k |n_k| t_k / sum_k t_k            (pauses count in sum t_k)

* **Life** of the wave-generator bearing (:meth:`armlab.robot.drives.Reducer.life_h`)::

      L_h = L_n (T_r / T_av)^3 (n_r / n_av)

  ``L_n`` the catalogue's rated life (L_10: 7000 h CSF, 10000 h CSG) at the rated torque
  ``T_r`` and rated input speed ``n_r`` (2000 rpm). The check ``reducer_life`` holds the
  required life (``[sizing] required_life_h``, default 7000 h: the CSF's own L_10 rating, i.e.
  a reducer at its rated torque and rated speed just passes; ASSUMED) against it.
* **Momentary torque** (load limit 3, ``T_k <= T_M``): the catalogue's momentary torque is the
  limit for an emergency stop or a collision. Load case (``[sizing] momentary_load``, decided
  for issue 28): ``"plan"`` (default, as the issue asks) the **plan's worst sample**, the
  cycle's largest ``|T|``; ``"stop"`` an **emergency stop at the current limit**: the larger of
  that and the torque the drive puts through the reducer when it brakes at its current limit,
  :attr:`armlab.robot.drives.Drive.stop_torque_Nm` ``= N T_m,peak / eta_b`` (back-driven: the
  reducer's losses add to the braking torque at the output; an upper bound, since the rotor's
  own deceleration takes part of the motor torque). A collision's torque depends on a contact
  stiffness the study does not know: this is the floor of the collision case, not all of it.
  With ``"plan"`` the check passes whenever ``reducer_peak_torque`` does (the repeated peak
  limit is below the momentary one): it matters for a reducer rated without a repeated peak
  margin; ``"stop"`` catches a motor too strong for its reducer.
* **Output bearing tilting moment** (cross-roller bearing "permissible moment load" M_c):
  the link loads at the reducer output are the spatial force pinocchio's RNEA transmits
  through the joint (``data.f[i]``, in the joint frame: moment about the joint origin, the
  output flange). The tilting moment is the part of its moment perpendicular to the joint axis
  plus the radial force x ``bearing_offset_m`` (the bearing's centre plane lies that far behind
  the flange; the magnitudes add, as Harmonic Drive's ``M = F_r (L_r + R) + F_a L_a``,
  conservative); the check takes its largest value over the cycle.

A reducer without the rating a check needs gets the check "not checked: no rating" (with the
reducer's source), which passes: missing data is reported, not failed.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from armlab.robot.drives import RPM_TO_RAD_S

if TYPE_CHECKING:
    from armlab.dynamics.inverse import JointLoads
    from armlab.robot.drivetrain import DriveTrain
    from armlab.robot.model import Robot

__all__ = [
    "DEFAULT_REQUIRED_LIFE_H",
    "REDUCER_CHECKS",
    "MOMENTARY_LOADS",
    "average_torque_Nm",
    "average_input_speed_rpm",
    "reducer_life_h",
    "reducer_checks",
    "tilting_moments_Nm",
    "not_checked_note",
]

#: required reducer life when the study sets none, [h]: the CSF L_10 rating (ASSUMED)
DEFAULT_REQUIRED_LIFE_H = 7000.0

#: the load cases of the momentary-torque check (``[sizing] momentary_load``)
MOMENTARY_LOADS = ("plan", "stop")

#: the checks of this module, with their units (``value <= limit`` each)
REDUCER_CHECKS: dict[str, str] = {
    "reducer_life": "h",
    "reducer_momentary_torque": "N m",
    "reducer_bearing_moment": "N m",
}

#: the reducer field each check needs, for the "not checked" note
_RATING_FIELD = {
    "reducer_life": "rated_life_h, rated_input_speed_rpm",
    "reducer_momentary_torque": "momentary_torque_Nm",
    "reducer_bearing_moment": "bearing_moment_rating_Nm",
}

_TINY = 1e-12


def average_torque_Nm(tau, qd, weights) -> np.ndarray:
    """Harmonic Drive's average output torque per column, in [N m]::

        T_av = (sum |qd_k| t_k |tau_k|^3 / sum |qd_k| t_k)^(1/3)

    (speed x time weighted cubic mean; time-weighted where the column never moves).
    ``tau``, ``qd`` (n_samples, n_columns) or (n_samples, 1); ``weights`` (n_samples,) [s]."""
    w = np.asarray(weights, float)[:, None]
    wn = np.abs(np.asarray(qd, float)) * w
    swn = wn.sum(axis=0)
    cube = np.abs(np.asarray(tau, float)) ** 3
    by_speed = (wn * cube).sum(axis=0) / np.where(swn > 0, swn, 1.0)
    by_time = (w * cube).sum(axis=0) / max(float(w.sum()), _TINY)
    return np.cbrt(np.where(swn > 0, by_speed, by_time))


def average_input_speed_rpm(qd, weights, ratio) -> np.ndarray:
    """Mean reducer input speed per column, ``N sum |qd_k| t_k / sum t_k``, in [rpm]."""
    w = np.asarray(weights, float)[:, None]
    mean_qd = (np.abs(np.asarray(qd, float)) * w).sum(axis=0) / max(float(w.sum()), _TINY)
    return mean_qd * np.asarray(ratio, float) / RPM_TO_RAD_S


def reducer_life_h(tau, qd, weights, drives: DriveTrain) -> np.ndarray:
    """Life of each column's reducer over the duty cycle, [h]
    (:meth:`armlab.robot.drives.Reducer.life_h` of :func:`average_torque_Nm` and
    :func:`average_input_speed_rpm`); NaN where the reducer has no life rating."""
    t_av = np.broadcast_to(average_torque_Nm(tau, qd, weights), drives.ratio.shape)
    n_av = np.broadcast_to(average_input_speed_rpm(qd, weights, drives.ratio), drives.ratio.shape)
    return np.array(
        [
            d.reducer.life_h(float(t), float(n))
            for d, t, n in zip(drives.drives, t_av, n_av, strict=True)
        ]
    )


def reducer_checks(
    tau,
    qd,
    weights,
    drives: DriveTrain,
    required_life_h: float,
    tilt_Nm=None,
    momentary_load: str = "plan",
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``{name: (value, limit)}`` of the checks of :data:`REDUCER_CHECKS`, (n_columns,) each.

    ``reducer_life``: value the required life, limit the computed life (so ``value <= limit``
    reads "required <= expected"); ``reducer_momentary_torque``: the largest ``|tau|`` (with
    ``momentary_load="stop"``: at least the drive's stop torque) against
    ``momentary_torque_Nm``; ``reducer_bearing_moment``: ``tilt_Nm`` (the peak tilting moment
    of each column, :func:`tilting_moments_Nm`; NaN when not computed) against
    ``bearing_moment_rating_Nm``. A limit is NaN where the reducer has no rating.
    """
    n = drives.ratio.shape
    life = reducer_life_h(tau, qd, weights, drives)

    def rating(f):
        return np.array([float(f(d.reducer)) for d in drives.drives])

    peak = np.broadcast_to(np.abs(np.asarray(tau, float)).max(axis=0), n)
    if momentary_load == "stop":
        peak = np.maximum(peak, [d.stop_torque_Nm for d in drives.drives])
    tilt = np.full(n, math.nan) if tilt_Nm is None else np.broadcast_to(tilt_Nm, n)
    return {
        "reducer_life": (np.full(n, float(required_life_h)), life),
        "reducer_momentary_torque": (peak, rating(lambda r: r.momentary_torque_Nm)),
        "reducer_bearing_moment": (
            np.asarray(tilt, float),
            rating(lambda r: r.bearing_moment_rating_Nm),
        ),
    }


def not_checked_note(name: str, source: str) -> str:
    """The note of a check the reducer has no rating for: ``not checked: no rating
    (momentary_torque_Nm; thesis table 4.3)``."""
    where = f"{_RATING_FIELD[name]}; {source}" if source else _RATING_FIELD[name]
    return f"not checked: no rating ({where})"


def tilting_moments_Nm(robot: Robot, loads: JointLoads, offsets_m=None) -> np.ndarray:
    """Peak tilting moment on each joint's output bearing over the loads' samples, [N m].

    Pinocchio's RNEA gives the spatial force ``f_i`` each joint transmits to its child link
    (``data.f[i]``, joint frame, moment about the joint origin). With ``a`` the joint axis (its
    motion subspace's angular part), the tilting moment is ``|m - (m . a) a|`` plus
    ``offset x |f - (f . a) a|`` (radial force on the lever from the flange to the bearing's
    centre plane, ``bearing_offset_m``; 0 when not given).

    Parameters
    ----------
    robot : Robot
        Its model carries the payload.
    loads : JointLoads
        The duty cycle (q, qd, qdd per sample).
    offsets_m : array (n_joints,), optional
        Bearing offsets; default each drive's ``reducer.bearing_offset_m`` (NaN -> 0).

    Returns
    -------
    array (n_joints,)
    """
    import pinocchio as pin

    model = robot.model
    data = model.createData()
    nj = model.njoints - 1
    if offsets_m is None:
        drives = robot.drives or {}
        offsets_m = [
            drives[n].reducer.bearing_offset_m if n in drives else 0.0 for n in robot.joint_names
        ]
    off = np.nan_to_num(np.asarray(offsets_m, float), nan=0.0)
    axes = _axes(model, data)
    peak = np.zeros(nj)
    for q, v, a in zip(loads.q, loads.qd, loads.qdd, strict=True):
        pin.rnea(model, data, q, v, a)
        for i in range(1, model.njoints):
            f = data.f[i]
            ax = axes[i - 1]
            m, lin = np.asarray(f.angular), np.asarray(f.linear)
            m_t = np.linalg.norm(m - (m @ ax) * ax)
            f_r = np.linalg.norm(lin - (lin @ ax) * ax)
            peak[i - 1] = max(peak[i - 1], m_t + off[i - 1] * f_r)
    return peak


def _axes(model, data) -> np.ndarray:
    """Unit axis of each joint in its own frame, (n_joints, 3): the angular part of its motion
    subspace (the LOCAL joint Jacobian's column of the joint's own velocity)."""
    import pinocchio as pin

    q0 = pin.neutral(model)
    pin.computeJointJacobians(model, data, q0)
    out = np.zeros((model.njoints - 1, 3))
    for i in range(1, model.njoints):
        jac = pin.getJointJacobian(model, data, i, pin.ReferenceFrame.LOCAL)
        jac = np.asarray(jac).reshape(6, model.nv)  # one joint: eigenpy returns a vector
        w = jac[3:, model.joints[i].idx_v]
        norm = np.linalg.norm(w)
        out[i - 1] = w / norm if norm > _TINY else 0.0
    return out
