"""The ulps tolerance of tests/tolerances.py fails where it should (a helper that cannot fail
would make every test that uses it vacuous)."""

from __future__ import annotations

import numpy as np
import pytest

from tolerances import assert_close_ulps, ulps_apart


def test_ulps_are_counted_in_the_spacing_of_the_larger_magnitude():
    x = 0.07022952193624012  # the pair of issue 23: a scalar and a vectorised profile speed
    y = 0.07022952193624016
    assert ulps_apart(x, y) == pytest.approx(abs(x - y) / np.spacing(y))
    assert 1 < ulps_apart(x, y) < 16
    assert ulps_apart(1.0, np.nextafter(1.0, 2.0)) == 1.0
    np.testing.assert_array_equal(ulps_apart([np.inf, np.nan, 0.0], [np.inf, np.nan, 0.0]), 0.0)
    assert ulps_apart(np.inf, 1e308) == np.inf and ulps_apart(np.nan, 1.0) == np.inf


def test_assert_close_ulps_passes_within_and_fails_beyond():
    a = np.array([1.0, 1e-3, -2.5e6])
    b = a + 3 * np.spacing(np.abs(a)) * np.sign(a)
    assert_close_ulps(a, b, ulps=3)
    with pytest.raises(AssertionError, match=r"3 of 3 value\(s\) more than 2 ulps"):
        assert_close_ulps(a, b, ulps=2)
    with pytest.raises(AssertionError, match="ulps"):
        assert_close_ulps(0.0, 1e-17, ulps=1e6)  # no count of ulps covers a zero
    assert_close_ulps(0.0, 1e-17, ulps=0, atol=1e-16)
