"""The feed-forward terms of the tracking simulation's cascade (module docstring of
:mod:`armlab.control.simulate`): which exist, and the current they command."""

from __future__ import annotations

import numpy as np

from armlab.errors import InputError
from armlab.robot import drivetrain as dtm
from armlab.robot import rigid_body

__all__ = ["FEEDFORWARDS", "feedforwards", "feedforward_current"]

FEEDFORWARDS = (
    "velocity",
    "acceleration",
    "gravity",
    "friction",
    "efficiency",
    "computed_torque",
)


def feedforwards(feedforward) -> tuple[str, ...]:
    if feedforward is None or feedforward == "none":
        return ()
    ff = (feedforward,) if isinstance(feedforward, str) else tuple(feedforward)
    bad = [f for f in ff if f not in FEEDFORWARDS]
    if bad:
        raise InputError(f"unknown feedforward {bad}; choose from {FEEDFORWARDS} or 'none'")
    return ff


def feedforward_current(robot, dt, cas, ff, q_d, qd_d, qdd_d) -> np.ndarray:
    """Feed-forward current (n, n_joints) [A] from the selected terms (module docstring)."""
    n, nj = q_d.shape
    N, Kt = dt.ratio, dt.torque_constant_Nm_A
    tau = np.zeros((n, nj))  # joint side, through the reducer
    t_motor = np.zeros((n, nj))  # motor side, before the reducer
    if "computed_torque" in ff:
        tau += rigid_body.inverse_dynamics(robot, q_d, qd_d, qdd_d)
    else:
        if "gravity" in ff:
            tau += rigid_body.gravity_torques(robot, q_d)
        if "acceleration" in ff:
            J_arm = np.array(
                [c.plant.inertia_joint_kg_m2["nominal"] if c.plant else 0.0 for c in cas]
            )
            tau += J_arm * qdd_d
    if "computed_torque" in ff or "acceleration" in ff:
        t_motor += dt.inertia_motor_side_kg_m2 * N * qdd_d
    if "friction" in ff:
        t_motor += dt.viscous_Nm_s_rad * N * qd_d
        fric = dtm.joint_friction(qd_d, qdd_d, dt)
    else:
        fric = np.zeros((n, nj))
    if "efficiency" in ff:
        # the joint torque (with the friction if selected) through the reducer by quadrant
        t_in = dtm.reducer_input_torque(tau + fric, qd_d, dt)
    else:
        t_in = (tau + fric) / N
    return (t_in + t_motor) / Kt
