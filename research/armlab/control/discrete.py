"""Runtime pieces of the discrete controllers: incremental PID, D/A and encoder quantisers.

The incremental (velocity-form) PID of the thesis (ch. 5)::

    u_k = sat(u_{k-1} + q0 e_k + q1 e_{k-1} + q2 e_{k-2})

Saturating ``u_k`` itself is the anti-windup: the stored ``u_{k-1}`` never leaves the output
range, so no integral builds up while the output is limited. A feed-forward ``u_ff`` is added
outside the increment: ``y_k = u_k + u_ff`` with ``u_k`` limited to ``[lo - u_ff, hi - u_ff]``.
All classes are vectorised over joints (arrays ``(n_joints,)``).
"""

from __future__ import annotations

import numpy as np

from armlab.control.gains import LoopGains

__all__ = ["IncrementalPID", "quantise_da", "quantise_encoder"]


class IncrementalPID:
    """Vectorised incremental PID with output saturation (anti-windup by construction).

    Parameters
    ----------
    q0, q1, q2 : array (n,)
        Coefficients (:func:`armlab.control.gains.incremental_coefficients`).
    lo, hi : array (n,)
        Output limits in the loop's output unit.
    u0 : array (n,), optional
        Initial output (e.g. the holding current).
    """

    def __init__(self, q0, q1, q2, lo, hi, u0=None):
        self.q0, self.q1, self.q2 = (np.asarray(x, float).copy() for x in (q0, q1, q2))
        self.lo, self.hi = np.asarray(lo, float).copy(), np.asarray(hi, float).copy()
        n = self.q0.shape[0]
        self.e1 = np.zeros(n)
        self.e2 = np.zeros(n)
        self.u = np.zeros(n) if u0 is None else np.asarray(u0, float).copy()

    @classmethod
    def from_gains(cls, loops: list[LoopGains], u0=None) -> IncrementalPID:
        """One controller per joint from their :class:`LoopGains`."""
        return cls(
            [g.q0 for g in loops],
            [g.q1 for g in loops],
            [g.q2 for g in loops],
            [g.output_min for g in loops],
            [g.output_max for g in loops],
            u0,
        )

    def reset(self, e0=None, u0=None) -> None:
        """Set the stored errors to ``e0`` (default 0) and the output to ``u0``."""
        if e0 is not None:
            self.e1[:] = e0
            self.e2[:] = e0
        if u0 is not None:
            self.u[:] = u0

    def step(self, e: np.ndarray, u_ff: np.ndarray | float = 0.0) -> np.ndarray:
        """One sample: error ``e`` (n,) -> output ``u + u_ff`` (n,), both limited to [lo, hi]."""
        u = self.u + self.q0 * e + self.q1 * self.e1 + self.q2 * self.e2
        u = np.minimum(np.maximum(u, self.lo - u_ff), self.hi - u_ff)
        self.u = u
        self.e2 = self.e1
        self.e1 = e
        return u + u_ff


def quantise_da(volts: np.ndarray, range_V: float = 10.0, bits: int = 12) -> np.ndarray:
    """12-bit bipolar D/A: codes -2^(bits-1) .. 2^(bits-1)-1, LSB = 2 range / 2^bits [V]."""
    lsb = 2.0 * range_V / 2**bits
    half = 2 ** (bits - 1)
    code = np.clip(np.rint(np.asarray(volts) / lsb), -half, half - 1)
    return code * lsb


def quantise_encoder(theta_rad: np.ndarray, counts_per_rad) -> np.ndarray:
    """Incremental encoder reading: ``floor(theta counts_per_rad) / counts_per_rad`` [rad]."""
    c = np.asarray(counts_per_rad)
    return np.floor(np.asarray(theta_rad) * c) / c
