"""The one trapezoid / double-S timing (armlab.trajectory.profiles) against closed forms.

200 fixed random cases (distance, v, a, j, stretch). The references are written out here
independently of the module: the trapezoid of the SHU controller paper, table 1 (symmetric:
``T = L/v + v/a`` when ``L >= v^2/a``, else ``2 sqrt(L/a)``) and the rest-to-rest double S of
Biagiotti & Melchiorri §3.4 in its own case split (cruise or not, ``a_max`` reached or not).
The vectorised primitives, the scalar entry points and the profile objects must agree with them
and with each other.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from armlab.trajectory.profiles import (
    double_s_binding,
    double_s_min_time,
    double_s_min_times,
    double_s_peak_speed,
    double_s_profile,
    double_s_profile_for_duration,
    double_s_ramp,
    double_s_speed_for_duration,
    synchronised_profiles,
    trapezoid_min_time,
    trapezoid_min_times,
    trapezoid_peak_speed,
    trapezoid_profile,
    trapezoid_profile_for_duration,
    trapezoid_speed_for_duration,
)
from tolerances import assert_close_ulps

N = 200
RNG = np.random.default_rng(20240607)
L = 10 ** RNG.uniform(-4, 1, N)  # distance
V = 10 ** RNG.uniform(-1.5, 0.7, N)  # speed limit
A = 10 ** RNG.uniform(-1, 1.5, N)  # acceleration limit
J = 10 ** RNG.uniform(-0.5, 3, N)  # jerk limit
K = 1 + RNG.uniform(0, 2, N) * (RNG.uniform(size=N) < 0.8)  # stretch (1 for a fifth)
CASES = list(zip(L, V, A, J, K, strict=True))
REL = 1e-12
# the scalar profile objects and the vectorised primitives evaluate one closed form in a different
# order of operations (a quadratic's root, a max over joints): they agree to a few ulps, not bit
# for bit (3 ulps at most over these cases on the development machine, 4e-17 on a fresh install)
ULPS = 16


# ---------------------------------------------------------------------- references
def trapezoid_ref(d, v, a):
    """(T, peak speed) of the symmetric rest-to-rest trapezoid (SHU controller paper, table 1)."""
    if d >= v * v / a:
        return d / v + v / a, v
    return 2 * math.sqrt(d / a), math.sqrt(a * d)


def double_s_ref(d, v, a, j):
    """(T, peak speed, case) of the rest-to-rest double S (Biagiotti & Melchiorri §3.4)."""
    if v * j >= a * a:  # a_max reached on the way to v_max
        tj, ta = a / j, a / j + v / a
    else:
        tj = math.sqrt(v / j)
        ta = 2 * tj
    tv = d / v - ta
    if tv >= 0:
        return 2 * ta + tv, v, "cruise"
    # no cruise (v0 = v1 = 0): Tj = a/j, Ta = (a^2/j + sqrt(a^4/j^2 + 4 a L)) / (2 a)
    tj = a / j
    ta = (a * a / j + math.sqrt(a**4 / j**2 + 4 * a * d)) / (2 * a)
    if ta >= 2 * tj:
        return 2 * ta, a * (ta - tj), "a reached"
    tj = (d / (2 * j)) ** (1 / 3)  # jerk only: L = 2 j Tj^3
    return 4 * tj, j * tj * tj, "jerk only"


def rel(x, y):
    return abs(x - y) / abs(y)


def test_the_cases_cover_every_regime():
    kinds = {double_s_ref(d, v, a, j)[2] for d, v, a, j, _ in CASES}
    assert kinds == {"cruise", "a reached", "jerk only"}
    tri = sum(d < v * v / a for d, v, a, _, _ in CASES)
    assert 20 < tri < N - 20  # triangles and trapezoids with a cruise


# ---------------------------------------------------------------------- trapezoid
def test_trapezoid_minimum_times_and_peak_speeds_are_the_closed_forms():
    Tv = trapezoid_min_times(L, V, A)
    vp = trapezoid_peak_speed(L, V, A)
    for i, (d, v, a, _, _) in enumerate(CASES):
        T_ref, v_ref = trapezoid_ref(d, v, a)
        assert rel(trapezoid_min_time(d, v, a), T_ref) < REL
        assert rel(Tv[i], T_ref) < REL and rel(vp[i], v_ref) < REL
        prof = trapezoid_profile(d, v, a)
        assert rel(prof.duration, T_ref) < REL and rel(prof.v_peak, v_ref) < REL
    # vectorised and scalar entry points: the same numbers
    scalar = np.array([trapezoid_min_time(d, v, a) for d, v, a, _, _ in CASES])
    np.testing.assert_allclose(Tv, scalar, rtol=REL, atol=0)
    # asymmetric ramps: T = L/v + v/(2 a1) + v/(2 a2), or v_p (1/a1 + 1/a2)
    for d, v, a, _, _ in CASES:
        a2 = 1.7 * a
        if d >= v * v / 2 * (1 / a + 1 / a2):
            T_ref = d / v + v / (2 * a) + v / (2 * a2)
        else:
            T_ref = math.sqrt(2 * d * (1 / a + 1 / a2))
        assert rel(trapezoid_min_time(d, v, a, a2), T_ref) < REL


def test_trapezoid_for_a_duration():
    T = K * trapezoid_min_times(L, V, A)
    vT = trapezoid_speed_for_duration(L, T, A, v_max=V)
    for i, (d, v, a, _, k) in enumerate(CASES):
        # the smaller root of v^2 / a - T v + L = 0
        v_ref = (a * T[i] - math.sqrt(max(a * a * T[i] ** 2 - 4 * a * d, 0.0))) / 2
        if k == 1:  # the fastest one: its peak (the root is ill-conditioned there)
            v_ref = trapezoid_ref(d, v, a)[1]
        assert rel(vT[i], v_ref) < 1e-9
        assert rel(d / vT[i] + vT[i] / a, T[i]) < REL  # it takes T
        prof = trapezoid_profile_for_duration(d, T[i], a, v_max=v)
        assert rel(prof.duration, T[i]) < REL
        assert_close_ulps(prof.params["v"], vT[i], ULPS)


# ---------------------------------------------------------------------- double S
def test_double_s_minimum_times_and_peak_speeds_are_the_closed_forms():
    Tv = double_s_min_times(L, V, A, J)
    vp = double_s_peak_speed(L, V, A, J)
    for i, (d, v, a, j, _) in enumerate(CASES):
        T_ref, v_ref, _ = double_s_ref(d, v, a, j)
        assert rel(double_s_min_time(d, v, a, j), T_ref) < REL
        assert rel(Tv[i], T_ref) < REL and rel(vp[i], v_ref) < REL
        prof = double_s_profile(d, v, a, j)
        assert rel(prof.duration, T_ref) < REL and rel(prof.v_peak, v_ref) < REL
        assert rel(prof.length, d) < REL
        assert prof.params["a"] <= a and abs(prof.jerks).max() == j
    scalar = np.array([double_s_min_time(d, v, a, j) for d, v, a, j, _ in CASES])
    np.testing.assert_allclose(Tv, scalar, rtol=REL, atol=0)


def test_double_s_for_a_duration():
    T = K * double_s_min_times(L, V, A, J)
    vT = double_s_speed_for_duration(L, T, A, J, V)
    for i, (d, v, a, j, k) in enumerate(CASES):
        p = vT[i]
        ta = a / j + p / a if p * j >= a * a else 2 * math.sqrt(p / j)  # ramp to p
        assert rel(d / p + ta, T[i]) < REL  # it takes T
        if k == 1:
            assert rel(vT[i], double_s_ref(d, v, a, j)[1]) < REL
        elif vT[i] * j >= a * a:  # a reached: v^2 / a - (T - a/j) v + L = 0, smaller root
            c = T[i] - a / j
            v_ref = a * (c - math.sqrt(c * c - 4 * d / a)) / 2
            assert rel(vT[i], v_ref) < 1e-9
        prof = double_s_profile_for_duration(d, T[i], a, j, v_max=v)
        assert rel(prof.duration, T[i]) < REL
        assert_close_ulps(prof.params["v"], vT[i], ULPS)
        assert rel(prof.length, d) < 1e-12


def test_infinite_limits_give_the_special_cases():
    inf = np.full(N, np.inf)
    # no jerk limit: the trapezoid
    assert_close_ulps(double_s_min_times(L, V, A, inf), trapezoid_min_times(L, V, A), ULPS)
    assert_close_ulps(double_s_peak_speed(L, V, A, inf), trapezoid_peak_speed(L, V, A), ULPS)
    # no acceleration limit: jerk only up to v, T = L/v + 2 sqrt(v/j) or 4 (L / 2j)^(1/3)
    T = double_s_min_times(L, V, inf, J)
    for i, (d, v, _, j, _) in enumerate(CASES):
        if d >= 2 * v * math.sqrt(v / j):
            T_ref = d / v + 2 * math.sqrt(v / j)
        else:
            T_ref = 4 * (d / (2 * j)) ** (1 / 3)
        assert rel(T[i], T_ref) < REL
    # no speed limit: never a cruise
    T = double_s_min_times(L, inf, A, J)
    for i, (d, _, a, j, _) in enumerate(CASES):
        assert rel(T[i], double_s_ref(d, 1e300, a, j)[0]) < REL
    # zero distance: no time
    assert (
        double_s_min_times(0.0, 1.0, 2.0, 3.0) == 0.0 and trapezoid_min_time(0.0, 1.0, 2.0) == 0.0
    )
    tj, ta = double_s_ramp(0.0, 2.0, 3.0)
    assert tj == 0.0 and ta == 0.0


def test_binding_limit():
    for d, v, a, j, _ in CASES:
        kind = double_s_ref(d, v, a, j)[2]
        want = {"cruise": "velocity", "a reached": "acceleration", "jerk only": "jerk"}[kind]
        assert double_s_binding(d, v, a, j) == want
        assert double_s_binding(d, v, a) == ("velocity" if d >= v * v / a else "acceleration")


# ---------------------------------------------------------------------- synchronisation
@pytest.mark.parametrize("jerk", [True, False])
def test_synchronised_profiles_match_the_scalar_profiles(jerk):
    """Jiang 1987, eq. 3-4: T = max t_i, each joint lowered to T; the vectorised set is the
    scalar for_duration profile of every joint."""
    for start in range(0, N, 6):
        d, v, a = L[start : start + 6], V[start : start + 6], A[start : start + 6]
        j = J[start : start + 6] if jerk else np.full(d.size, np.inf)
        T, t_min, profs = synchronised_profiles(d, v, a, j)
        assert T == t_min.max()
        for i, p in enumerate(profs):
            assert rel(p.duration, T) < REL
            if jerk:
                assert rel(t_min[i], double_s_ref(d[i], v[i], a[i], j[i])[0]) < REL
                ref = double_s_profile_for_duration(d[i], T, a[i], j[i], v_max=v[i])
            else:
                assert rel(t_min[i], trapezoid_ref(d[i], v[i], a[i])[0]) < REL
                ref = trapezoid_profile_for_duration(d[i], T, a[i], v_max=v[i])
            assert p.kind == ref.kind
            assert_close_ulps(p.params["v"], ref.params["v"], ULPS)
            np.testing.assert_allclose(p.durations, ref.durations, rtol=REL, atol=1e-15)
            tt = np.linspace(0.0, T, 57)
            for x, y in zip(p.evaluate(tt), ref.evaluate(tt), strict=True):
                np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-15)
    T, t_min, profs = synchronised_profiles([0.0, 1.0], 1.0, 2.0, 10.0)
    assert profs[0].kind == "rest" and profs[0].duration == T and t_min[0] == 0.0
