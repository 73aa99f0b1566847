"""Tolerances for comparing two float computations (``from tolerances import assert_close_ulps``).

Two code paths that evaluate the same formula in a different order (a vectorised and a scalar
entry point, one engine and another, BLAS on one machine and on another) agree to a few units in
the last place (ulps), not bit for bit: ``==`` between them passes on one machine and fails on
the next. Exact equality stays right for a true invariant of one computation (a round trip
through a file, integers and counts, the same function called twice on the same input).

A tolerance in ulps is relative: ``|a - b| <= ulps * spacing(max(|a|, |b|))``, where
``numpy.spacing(x)`` is the gap between ``x`` and the next float64 (``2.2e-16 |x|`` up to a
factor 2). ``atol`` covers values that should be zero and come out as round-off
(``spacing(0)`` is 5e-324, so no count of ulps does).
"""

from __future__ import annotations

import numpy as np


def ulps_apart(actual, desired) -> np.ndarray:
    """Distance between ``actual`` and ``desired`` in float64 spacings of the larger magnitude.

    Equal values (infinities of one sign, NaN against NaN included) are 0 apart.
    """
    a, b = np.broadcast_arrays(np.asarray(actual, float), np.asarray(desired, float))
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    with np.errstate(invalid="ignore", over="ignore"):
        gap = np.abs(a - b) / np.spacing(np.maximum(np.abs(a), np.abs(b)))
    return np.where(same, 0.0, np.where(np.isnan(gap), np.inf, gap))


def assert_close_ulps(actual, desired, ulps: float, atol: float = 0.0, err_msg: str = "") -> None:
    """Assert ``|actual - desired| <= ulps * spacing(max(|actual|, |desired|)) + atol``.

    Parameters
    ----------
    actual, desired : array_like
        The two computations (broadcast against each other).
    ulps : float
        Allowed distance in units in the last place of the larger magnitude; state in the
        caller why that many (how many operations separate the two paths).
    atol : float, optional
        Absolute allowance for values that should be zero, by default none.
    err_msg : str, optional
        Prefix of the failure message.
    """
    a, b = np.broadcast_arrays(np.asarray(actual, float), np.asarray(desired, float))
    apart = ulps_apart(a, b)
    ok = (apart <= ulps) | (np.abs(a - b) <= atol)
    if not np.all(ok):
        worst = np.unravel_index(np.argmax(np.where(ok, -np.inf, apart)), apart.shape)
        raise AssertionError(
            f"{err_msg}{' ' if err_msg else ''}{int(np.size(ok) - np.count_nonzero(ok))} of "
            f"{np.size(ok)} value(s) more than {ulps} ulps (atol {atol:g}) apart; worst at "
            f"{tuple(int(i) for i in worst)}: {a[worst]!r} vs {b[worst]!r} "
            f"({apart[worst]:.3g} ulps)"
        )
