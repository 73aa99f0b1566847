"""The optimiser's NLP (armlab.planning.transcription): the constraint Jacobian IPOPT gets from
the inverse dynamics' own Jacobian mapped over the nodes (issue 26) is casadi's AD of the
whole constraint graph, value for value."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from armlab.planning import transcription
from armlab.robot.symbolic import dynamic_parameters, parametric_inverse_dynamics_function


@pytest.mark.parametrize("mode", ["jerk", "acceleration"])
def test_torque_row_jacobian_is_the_ad_jacobian(teachbot6, mode):
    rnea = parametric_inverse_dynamics_function(teachbot6)
    n_pi = rnea.size1_in(3)
    st = transcription.build_structure(
        rnea, n_pi, 6, (3, 4), mode, "time", True, False, 50, False, "partial"
    )
    jac_g = st.solver.get_function("nlp_jac_g")
    # the reference: casadi's AD of the constraint function st.g_fun (an SX graph)
    x = ca.SX.sym("x", st.nx)
    p = ca.SX.sym("p", st.g_fun.size1_in(1))
    ref = ca.Function("ref", [x, p], [ca.jacobian(st.g_fun(x, p), x)])
    rng = np.random.default_rng(26)
    pv = rng.uniform(0.5, 2.0, p.numel())
    pv[-n_pi:] = dynamic_parameters(teachbot6)  # the inertial parameters come last
    for _ in range(3):
        xv = rng.uniform(-1.0, 1.0, st.nx)
        got = jac_g(xv, pv)
        g_ref = np.asarray(st.g_fun(xv, pv)).ravel()
        np.testing.assert_allclose(np.asarray(got[0]).ravel(), g_ref, rtol=1e-12, atol=1e-12)
        J, J_ref = got[1].full(), ref(xv, pv).full()
        assert np.any(st.g_kind == "torque")  # the case has torque rows
        np.testing.assert_allclose(J, J_ref, rtol=1e-10, atol=1e-10 * np.max(np.abs(J_ref)))
