"""One waypoint validation (armlab.trajectory.validate_waypoints), one error class everywhere."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from armlab.errors import InputError
from armlab.trajectory import (
    cubic_via,
    optimal,
    ptp_sync,
    quintic_via,
    time_optimal_path,
    validate_waypoints,
)

Q0 = np.zeros(6)
Q1 = np.array([1.0, -0.5, 0.8, 2.0, -1.0, 0.3])


def test_valid_waypoints_come_back_as_float_arrays(teachbot6):
    W = validate_waypoints(teachbot6, [[0, 0, 0, 0, 0, 0], Q1.tolist()])
    assert W.dtype == float and W.shape == (2, 6)
    np.testing.assert_array_equal(W[1], Q1)
    q = validate_waypoints(teachbot6, Q1, where="goal", min_rows=None)
    assert q.shape == (6,)
    # on the range limit (within RANGE_TOL_RAD) is fine
    edge = np.vstack([teachbot6.limits.lower_rad, teachbot6.limits.upper_rad + 1e-10])
    validate_waypoints(teachbot6, edge)


def test_shape_errors_name_the_shape(teachbot6):
    with pytest.raises(
        InputError, match=r"waypoints has shape \(1, 6\), expected \(n_waypoints >= 2, 6\)"
    ):
        validate_waypoints(teachbot6, [Q0])
    with pytest.raises(InputError, match=r"has shape \(2, 5\)"):
        validate_waypoints(teachbot6, np.zeros((2, 5)))
    with pytest.raises(InputError, match=r"goal has shape \(1, 6\), expected \(6,\)"):
        validate_waypoints(teachbot6, [Q0], where="goal", min_rows=None)
    validate_waypoints(teachbot6, [Q0], min_rows=1)
    with pytest.raises(InputError, match="not an array of numbers"):
        validate_waypoints(teachbot6, [["a"] * 6, Q0])


def test_non_finite_names_row_and_joint(teachbot6):
    W = np.zeros((3, 6))
    W[2, 4] = math.nan
    with pytest.raises(
        InputError, match=r"^waypoints\[2\]: joint5 is nan \(not a finite number\)$"
    ):
        validate_waypoints(teachbot6, W)


def test_range_error_names_row_joint_value_range_and_unit(teachbot6):
    lo, hi = teachbot6.limits.lower_rad[2], teachbot6.limits.upper_rad[2]
    W = np.zeros((3, 6))
    W[1, 2] = 3.0
    with pytest.raises(InputError) as err:
        validate_waypoints(teachbot6, W, where="waypoints.joint")
    assert str(err.value) == (
        f"waypoints.joint[1]: joint3 = 3 rad is outside its range [{lo:.6g}, {hi:.6g}] rad"
    )
    W[1, 2] = math.radians(170.0)
    with pytest.raises(InputError) as err:
        validate_waypoints(teachbot6, W, where="waypoints.joint", unit="deg")
    assert str(err.value) == (
        "waypoints.joint[1]: joint3 = 170 deg is outside its range [-90, 160] deg"
    )
    with pytest.raises(InputError, match="unit"):
        validate_waypoints(teachbot6, W, unit="grad")


def test_every_planner_raises_the_same_error(teachbot6):
    far = Q1.copy()
    far[2] = 3.0  # joint3 range is -90 .. 160 deg
    W = np.array([Q0, far, Q0])
    pattern = r"joint3 = 3 rad is outside its range \[-1\.5708, 2\.79253\] rad"
    calls = {
        "ptp_sync q_goal": lambda: ptp_sync(teachbot6, Q0, far),
        "ptp_sync q_start": lambda: ptp_sync(teachbot6, far, Q0),
        "cubic_via waypoints[1]": lambda: cubic_via(teachbot6, W),
        "quintic_via waypoints[1]": lambda: quintic_via(teachbot6, W),
        "optimal waypoints[1]": lambda: optimal(teachbot6, W),
        "time_optimal_path points[1]": lambda: time_optimal_path(teachbot6, W, a_max=5.0),
    }
    for where, call in calls.items():
        with pytest.raises(InputError, match="^" + re.escape(where) + ": " + pattern + "$"):
            call()
