"""CasADi inverse dynamics (armlab.robot.symbolic) against pinocchio.rnea."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from armlab.errors import RobotDescriptionError
from armlab.robot.symbolic import (
    dynamic_parameters,
    dynamics_key,
    inverse_dynamics_function,
    kinematics_key,
    parametric_inverse_dynamics_function,
)


def _random_states(rng, model, n=5):
    for _ in range(n):
        q = (
            pin.randomConfiguration(model)
            if np.all(np.isfinite(model.upperPositionLimit))
            else rng.normal(size=model.nq)
        )
        yield q, rng.normal(size=model.nv) * 2.0, rng.normal(size=model.nv) * 5.0


def _check_against_pinocchio(model, rng, fn=None):
    fn = fn or inverse_dynamics_function(model)
    data = model.createData()
    for q, v, a in _random_states(rng, model):
        ours = np.asarray(fn(q, v, a)).ravel()
        ref = pin.rnea(model, data, q, v, a)
        np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-9)


def prismatic_tree() -> pin.Model:
    """Revolute and prismatic joints, aligned and unaligned axes, a branch, armature."""
    rng = np.random.default_rng(7)
    m = pin.Model()
    ids = {}
    specs = [
        ("rz", 0, pin.JointModelRZ()),
        ("px", "rz", pin.JointModelPX()),
        ("r_un", "px", pin.JointModelRevoluteUnaligned(np.array([0.0, 0.6, 0.8]))),
        ("p_un", "r_un", pin.JointModelPrismaticUnaligned(np.array([0.6, 0.0, 0.8]))),
        ("ry_branch", "rz", pin.JointModelRY()),
        ("pz", "ry_branch", pin.JointModelPZ()),
    ]
    for name, parent, joint in specs:
        pid = 0 if parent == 0 else ids[parent]
        placement = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3) * 0.3)
        jid = m.addJoint(pid, joint, placement, name)
        m.appendBodyToJoint(jid, pin.Inertia.Random(), pin.SE3.Identity())
        ids[name] = jid
    m.armature[:] = np.linspace(0.01, 0.06, m.nv)
    return m


def test_teachbot6_with_payload_matches_rnea(teachbot6):
    robot = teachbot6.with_payload(1.5)
    assert robot.payload.mass_kg == pytest.approx(1.5)
    _check_against_pinocchio(robot.model, np.random.default_rng(0))


def test_ur5_matches_rnea(ur5):
    _check_against_pinocchio(ur5.model, np.random.default_rng(1))


def test_prismatic_and_unaligned_joints_match_rnea():
    model = prismatic_tree()
    kinds = [model.joints[i].shortname() for i in range(1, model.njoints)]
    assert any("P" in k for k in kinds) and any("Unaligned" in k for k in kinds)
    _check_against_pinocchio(model, np.random.default_rng(2))


def test_parametric_function_serves_every_payload(teachbot6):
    """One function per kinematics; the payload enters through the inertial parameters."""
    heavy = teachbot6.with_payload(3.0)
    f_light = parametric_inverse_dynamics_function(teachbot6)
    f_heavy = parametric_inverse_dynamics_function(heavy)
    assert f_light is f_heavy
    assert kinematics_key(teachbot6) == kinematics_key(heavy)
    assert dynamics_key(teachbot6) != dynamics_key(heavy)
    rng = np.random.default_rng(3)
    for q, v, a in _random_states(rng, heavy.model, 3):
        tau = np.asarray(f_heavy(q, v, a, dynamic_parameters(heavy))).ravel()
        ref = pin.rnea(heavy.model, heavy.model.createData(), q, v, a)
        np.testing.assert_allclose(tau, ref, atol=1e-9)
        # tau is linear in the parameters: doubling them doubles it
        t2 = np.asarray(f_heavy(q, v, a, 2 * dynamic_parameters(heavy))).ravel()
        np.testing.assert_allclose(t2, 2 * tau, atol=1e-9)


def test_functions_are_cached(teachbot6):
    assert inverse_dynamics_function(teachbot6) is inverse_dynamics_function(teachbot6.copy())


def test_unsupported_joint_is_refused():
    m = pin.Model()
    m.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    with pytest.raises(RobotDescriptionError, match="ball"):
        inverse_dynamics_function(m)
