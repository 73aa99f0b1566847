"""Bounded work: what a study may ask for, estimated before anything is allocated.

A study key can ask for more memory or time than any machine has (issue 24: ``plan.speed_scale
= 1e-6`` grew to 20 GB; ``check_dt_s = 1e-7``, ``workspace_samples = 1e10`` ended in
``MemoryError``). Each request is estimated from the study before the stage allocates, and one
above its bound is refused with one line (:class:`~armlab.SpecError`) naming the key(s) and the
estimate:

=====================================  ==================================================
request                                 bound
=====================================  ==================================================
time samples of one plan (its check     :data:`MAX_SAMPLES`: ``duration / check_dt_s``,
grid, the classical planners' samples,  the duration bounded below before planning by
the sizing grid)                        ``sum_segments max_j |dq_j| / (v_j s)``
set-point table rows                    :data:`MAX_SAMPLES`: ``duration / cycle_s``
closed-loop simulation steps            :data:`MAX_SAMPLES`: ``(duration + t_after_s) /
                                        servo_period_s``
Monte-Carlo samples (workspace,         :data:`MAX_MONTE_CARLO` each
accuracy)
inertia-range samples of the tuning     :data:`MAX_INERTIA_SAMPLES`
waypoints                               :data:`MAX_WAYPOINTS` (``optimal`` and ``path``:
                                        :data:`MAX_OPTIMAL_WAYPOINTS`: one NLP over all)
=====================================  ==================================================

A time sample of a six-joint arm holds about 40 numbers across the arrays a stage keeps
(positions, velocities, accelerations, jerks, torques, motor quantities): 2 million samples are
about 0.6 GB, 33 minutes of motion on the default 1 ms grid.
"""

from __future__ import annotations

import math

import numpy as np

from armlab.errors import SpecError

__all__ = [
    "MAX_SAMPLES",
    "MAX_MONTE_CARLO",
    "MAX_INERTIA_SAMPLES",
    "MAX_WAYPOINTS",
    "MAX_OPTIMAL_WAYPOINTS",
    "BYTES_PER_SAMPLE_JOINT",
    "min_duration_s",
    "check_samples",
    "check_waypoints",
]

#: Time samples one request may allocate (plan grid, set-point table, simulation steps).
MAX_SAMPLES = 2_000_000
#: Samples of one Monte-Carlo study (``kinematics.workspace_samples``, ``accuracy_samples``).
MAX_MONTE_CARLO = 1_000_000
#: Workspace samples of the tuning's inertia range (``control.n_inertia_samples``).
MAX_INERTIA_SAMPLES = 100_000
#: Waypoints of a study (classical planners: one solve per segment).
MAX_WAYPOINTS = 1_000
#: Waypoints of the ``optimal`` and ``path`` planners (one problem over every waypoint).
MAX_OPTIMAL_WAYPOINTS = 100
#: Bytes per time sample and joint across the arrays a stage keeps (about 40 float64).
BYTES_PER_SAMPLE_JOINT = 40 * 8


def _gb(samples: float, n_joints: int) -> str:
    return f"{samples * n_joints * BYTES_PER_SAMPLE_JOINT / 1e9:.3g} GB"


def min_duration_s(q_waypoints: np.ndarray, velocity_rad_s: np.ndarray | None) -> float:
    """A lower bound of a plan's duration through the waypoints [s]:
    ``sum over segments of max_j |q_{i+1,j} - q_{i,j}| / v_j`` (every joint moves at most at
    its velocity limit ``v_j``; a path through the waypoints moves each joint at least that
    far). 0 without velocity limits."""
    if velocity_rad_s is None or len(q_waypoints) < 2:
        return 0.0
    v = np.asarray(velocity_rad_s, dtype=float)
    dq = np.abs(np.diff(np.asarray(q_waypoints, dtype=float), axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(dq > 0, dq / v, 0.0)
    t = np.where(np.isfinite(t), t, 0.0)
    return float(np.sum(np.max(t, axis=1)))


def check_samples(samples: float, n_joints: int, keys: str, how: str) -> None:
    """Refuse a request of more than :data:`MAX_SAMPLES` time samples.

    Parameters
    ----------
    samples : float
        The estimate (may be a lower bound).
    n_joints : int
    keys : str
        The study keys that set it, for the message (``"plan.speed_scale = 1e-06"``).
    how : str
        How the estimate was made (``"duration >= 1.2e+06 s / check_dt_s 0.001 s"``).

    Raises
    ------
    SpecError
        One line naming the keys, the estimate and the bound.
    """
    if not math.isfinite(samples) or samples > MAX_SAMPLES:
        raise SpecError(
            f"{keys}: needs {samples:.3g} time samples ({how}; about "
            f"{_gb(samples, n_joints)}), above armlab's bound of {MAX_SAMPLES:.3g} "
            "(armlab.study.budget): ask for a shorter or coarser request"
        )


def check_waypoints(n_waypoints: int, planner: str, where: str) -> None:
    """Refuse more waypoints than the planner's bound (:data:`MAX_WAYPOINTS`,
    :data:`MAX_OPTIMAL_WAYPOINTS`) with one :class:`SpecError` naming ``where``."""
    bound = MAX_OPTIMAL_WAYPOINTS if planner in ("optimal", "path") else MAX_WAYPOINTS
    if n_waypoints > bound:
        raise SpecError(
            f"{where}: {n_waypoints} waypoints, above armlab's bound of {bound} for planner "
            f"{planner!r} (armlab.study.budget): split the motion into several studies"
        )


def check_table_rows(trajectory, controller, n_joints: int) -> None:
    """Refuse a set-point table of more than :data:`MAX_SAMPLES` cycles before it is made:
    the plan's duration over the controller's cycle (the run's export stage and
    ``armlab export`` ask this one check)."""
    check_samples(
        trajectory.duration / controller.cycle_s,
        n_joints,
        f"controller.cycle_s = {controller.cycle_s:g}",
        f"{trajectory.duration:.3g} s plan / {controller.cycle_s:g} s controller cycle",
    )
