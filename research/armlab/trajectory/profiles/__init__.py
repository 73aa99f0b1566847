"""One-dimensional motion profiles ``s(t)``: trapezoid, jerk-limited double S, resting.

A profile moves a scalar ``s`` (a joint angle in [rad], an arc length in [m], a normalised path
parameter) from ``0`` to ``length`` in ``duration`` [s], starting and ending at rest. It is a
sequence of phases of constant jerk; each phase starts with a given acceleration, so a
trapezoid (acceleration steps) and a double S (continuous acceleration) share one evaluator.

Shapes (SHU controller paper, table 1; Biagiotti & Melchiorri "Trajectory Planning for
Automatic Machines and Robots" §3.2 and §3.4 for the double S):

* trapezoid, acceleration ``a1``, cruise ``v``, deceleration ``a2``::

      S1 = v^2 / (2 a1),  S2 = v^2 / (2 a2),  S3 = L - S1 - S2 >= 0
      L < S1 + S2  ->  no cruise, peak v_p = sqrt(2 L a1 a2 / (a1 + a2))

* double S with jerk ``j``, acceleration ``a``, peak speed ``v`` (symmetric)::

      v j >= a^2:  Tj = a / j,       Ta = Tj + v / a
      v j <  a^2:  Tj = sqrt(v / j), Ta = 2 Tj          (peak acceleration j Tj < a)
      Tv = L / v - Ta >= 0,   duration = 2 Ta + Tv

A profile stretched in time by ``k`` is the profile built with ``(v / k, a / k^2, j / k^3)``:
every regime test above is invariant under that scaling, so :meth:`MotionProfile.stretched`
is exact.

This package is the one implementation of that timing, a module per concept: :mod:`.motion`
(the profile type), :mod:`.timing` (the primitives), :mod:`.rest_to_rest` (profiles and their
synchronisation), :mod:`.batch` (many problems at once), :mod:`.from_state` and
:mod:`.jerk_move` (from a moving state). The primitives are vectorised (arguments
broadcast, ``inf`` switches a limit off): :func:`trapezoid_peak_speed`,
:func:`trapezoid_min_times`, :func:`trapezoid_speed_for_duration` and :func:`double_s_ramp`,
:func:`double_s_peak_speed`, :func:`double_s_min_times`, :func:`double_s_speed_for_duration`
(``j = inf`` is the trapezoid). The scalar entry points (:func:`trapezoid_min_time`,
:func:`double_s_min_time`), the profile builders, the time-synchronised set of
:func:`synchronised_profiles` (Jiang 1987, eq. 1-5: PTP motion and the optimiser's warm start),
the SHU step table (:mod:`armlab.planning.steps`) and the requirement moves of the drive sizing
(:mod:`armlab.dynamics.requirements`) all call them.

:func:`synchronised_scurves` is the batch form of :func:`synchronised_profiles`: many
problems (``(n_problems, n_joints)`` moves, or the segments of a path that stops at its
waypoints) at once, on the same primitives, for planners that need thousands of plans. Every
step is in closed form: the peak speed for a given duration from a quadratic or a cubic
(:func:`double_s_speed_for_duration`; the bisection it replaced is the tests' oracle,
``tests/oracles/double_s.py``). Its result, an :class:`SCurveBatch`, holds each joint's seven
phases (:meth:`SCurveBatch.boundaries`, integrated once), evaluates them with the jerk
(:meth:`SCurveBatch.evaluate_jerk`), gives each joint's exact peaks, end state and direction
from them (:meth:`SCurveBatch.peaks`: the closed forms' limit check) and each joint's
:class:`MotionProfile` from the same phases (:meth:`SCurveBatch.profile`; its
``to_dict`` without building it, :meth:`SCurveBatch.profile_dicts`).

From a moving state (replanning, :func:`~armlab.planning.ptp_sync` with ``qd_start``):
:func:`trapezoid_min_time_from_state`, :func:`trapezoid_blocked_from_state`,
:func:`trapezoid_from_state` (bang-coast-bang from a speed), and the jerk-limited
:class:`JerkMove` from a speed and an acceleration to a goal speed (Berscheid & Kröger 2021,
"Jerk-limited Real-time Trajectory Generation with Arbitrary Target States", the method of
Ruckig: time-optimal move, blocked durations, a move of a given duration) with
:func:`synchronised_from_state`. A :class:`MotionProfile` then starts at ``v_start`` with the
acceleration of its first phase.
"""

from __future__ import annotations

from armlab.trajectory.profiles.batch import (
    SCurveBatch,
    synchronised_scurves,
)
from armlab.trajectory.profiles.from_state import (
    trapezoid_blocked_from_state,
    trapezoid_from_state,
    trapezoid_min_time_from_state,
)
from armlab.trajectory.profiles.jerk_move import (
    JerkMove,
    scurve_blocked_from_state,
    scurve_from_state,
    scurve_min_time_from_state,
    synchronised_from_state,
)
from armlab.trajectory.profiles.motion import (
    MotionProfile,
    rest_profile,
)
from armlab.trajectory.profiles.rest_to_rest import (
    double_s_binding,
    double_s_min_time,
    double_s_profile,
    double_s_profile_for_duration,
    synchronised_profiles,
    trapezoid_min_time,
    trapezoid_profile,
    trapezoid_profile_for_duration,
)
from armlab.trajectory.profiles.timing import (
    double_s_min_times,
    double_s_peak_speed,
    double_s_ramp,
    double_s_speed_for_duration,
    trapezoid_min_times,
    trapezoid_peak_speed,
    trapezoid_ramp_length,
    trapezoid_speed_for_duration,
)

__all__ = [
    "MotionProfile",
    "trapezoid_profile",
    "trapezoid_profile_for_duration",
    "double_s_profile",
    "double_s_profile_for_duration",
    "rest_profile",
    "trapezoid_min_time",
    "double_s_min_time",
    "double_s_binding",
    "synchronised_profiles",
    "trapezoid_ramp_length",
    "trapezoid_peak_speed",
    "trapezoid_min_times",
    "trapezoid_speed_for_duration",
    "double_s_ramp",
    "double_s_peak_speed",
    "double_s_min_times",
    "double_s_speed_for_duration",
    "SCurveBatch",
    "synchronised_scurves",
    "trapezoid_min_time_from_state",
    "trapezoid_from_state",
    "trapezoid_blocked_from_state",
    "JerkMove",
    "scurve_min_time_from_state",
    "scurve_blocked_from_state",
    "scurve_from_state",
    "synchronised_from_state",
]
