"""Step-response figures of closed loops: overshoot and settling time.

The unit-step response of a (stacked) state-space system is simulated exactly at its samples
(continuous: 1500 points on ``[0, t_final]`` with the ZOH-exact transition, exact for a step;
discrete: every sample); the figures follow python-control's ``step_info`` definitions
(Astrom & Murray, *Feedback Systems*, 2nd ed., 5.3): overshoot ``100 (y_max - y_inf) / y_inf``
with ``y_inf`` the DC gain, settling time the first sample after the last one outside the
``+-2 %`` band.
"""

from __future__ import annotations

import math

import numpy as np

from armlab.control.lti import SS, zoh
from armlab.errors import InputError

__all__ = ["step_many", "dcgain", "step_metrics", "MAX_STEP_SAMPLES"]

#: Samples of one discrete step response (``t_final / dt``): a larger one is refused before
#: it is allocated (the tuning's position-loop steps last ~12 / kp s; at a 1 ms servo period
#: that is a few hundred samples, at 1e-9 s it was 1.7e8 and a MemoryError, issue 24).
MAX_STEP_SAMPLES = 1_000_000


def step_many(
    systems: list[SS], t_final: np.ndarray, dt: float | None
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Unit-step responses of stacked SISO systems of one shape, as python-control's
    ``step_response`` samples them (continuous: 1500 points on ``[0, t_final]``, exact for a
    step; discrete: every sample up to ``t_final``). All the time steps of all systems in one
    go: the state after ``k`` steps is ``M^k z0`` with the augmented ``M = [[Ad, Bd], [0, 1]]``,
    its powers by doubling.

    Raises
    ------
    InputError
        A discrete response of more than :data:`MAX_STEP_SAMPLES` samples.
    """
    A = np.stack([s[0] for s in systems])
    B = np.stack([s[1] for s in systems])
    C = np.stack([s[2] for s in systems])
    D = np.stack([s[3] for s in systems])
    k, n = A.shape[0], A.shape[1]
    if dt is None:
        T = [np.linspace(0.0, tf, 1500) for tf in t_final]
        AB = [zoh(A[i], B[i], T[i][1] - T[i][0]) for i in range(k)]
        Ad = np.stack([ab[0] for ab in AB])
        Bd = np.stack([ab[1] for ab in AB])
    else:
        n_samples = float(np.max(t_final)) / dt
        if not n_samples <= MAX_STEP_SAMPLES:
            raise InputError(
                f"servo_period_s = {dt:g} s: a discrete step response over "
                f"{float(np.max(t_final)):.3g} s needs {n_samples:.3g} samples per loop, above "
                f"the bound of {MAX_STEP_SAMPLES:.3g} (armlab.control.steps.MAX_STEP_SAMPLES)"
            )
        T = [np.arange(0.0, tf + dt, dt) for tf in t_final]
        Ad, Bd = A, B
    N = max(t.size for t in T)
    M = np.zeros((k, n + 1, n + 1))
    M[:, :n, :n] = Ad
    M[:, :n, n:] = Bd
    M[:, n, n] = 1.0
    Z = np.zeros((k, n + 1, 1))
    Z[:, n, 0] = 1.0
    P = M
    with np.errstate(over="ignore", invalid="ignore"):
        while Z.shape[-1] < N:
            Z = np.concatenate([Z, P @ Z], axis=-1)
            P = P @ P
        Caug = np.concatenate([C[:, :1, :], D[:, :1, :]], axis=-1)
        Y = (Caug @ Z[:, :, :N])[:, 0, :]
    return T, [Y[i, : T[i].size] for i in range(k)]


def dcgain(sys: SS, discrete: bool) -> float:
    """Final value of the unit-step response: ``D + C (-A)^-1 B`` (continuous),
    ``D + C (I - A)^-1 B`` (discrete); inf if singular."""
    A, B, C, D = sys
    n = A.shape[0]
    if n == 0:
        return float(D[0, 0])
    try:
        x = np.linalg.solve((np.eye(n) - A) if discrete else -A, B)
    except np.linalg.LinAlgError:
        return math.inf
    return float((C[:1] @ x + D[:1])[0, 0])


def step_metrics(T: np.ndarray, y: np.ndarray, final: float, threshold: float = 0.02):
    """(overshoot [%], settling time [s]) of a step response, python-control's ``step_info``
    definitions (final value: the DC gain; settling: the first sample after the last one
    outside the ``threshold`` band; nan if it never settles)."""
    if math.isnan(final) or math.isinf(final):
        return math.nan, math.nan
    outside = np.nonzero(np.abs(y / final - 1) >= threshold)[0]
    settled = 0 if outside.size == 0 else outside[-1] + 1
    settling = float(T[settled]) if settled < len(T) else math.nan
    y_os = (np.sign(final) * y).max()
    dy = abs(y_os) - abs(final)
    overshoot = float(abs(100.0 * dy / final)) if dy > 0 else 0.0
    return overshoot, settling
