"""Small linear systems as numpy matrices: the building blocks of the loop models.

A system is a tuple ``(A, B, C, D)`` (single input; ``C``, ``D`` may have several output rows),
continuous ``x' = A x + B u`` or discrete ``x_{k+1} = A x_k + B u_k``, ``y = C x + D u``.
Series and unity feedback are the textbook state-space interconnections (Franklin, Powell &
Emami-Naeini, *Feedback Control of Dynamic Systems*, 7.4); a transfer function is realised in
controllable canonical form; the zero-order hold is the exact block-exponential
discretisation ``exp([[A, B], [0, 0]] T) = [[Ad, Bd], [0, I]]`` (Franklin, Powell & Workman,
*Digital Control of Dynamic Systems*, 4.3). python-control builds the same objects (the tests
use it as the reference); these build none, which is what makes the tuner fast.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import control as ct

__all__ = [
    "SS",
    "ss_static",
    "ss_series",
    "ss_feedback",
    "ss_tf",
    "delay_ss",
    "pade_ss",
    "INTEGRATOR",
    "zoh",
    "ss_response",
    "response",
]

SS = tuple  # (A, B, C, D) numpy arrays of a single-input system


def ss_static(k: float) -> SS:
    """The static gain ``y = k u`` (no state)."""
    return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[float(k)]])


def ss_series(outer: SS, inner: SS) -> SS:
    """``outer(inner(u))``; ``inner`` single-output, ``outer`` may have several outputs."""
    A1, B1, C1, D1 = inner
    A2, B2, C2, D2 = outer
    n1, n2 = A1.shape[0], A2.shape[0]
    A = np.zeros((n1 + n2, n1 + n2))
    A[:n1, :n1] = A1
    A[n1:, :n1] = B2 @ C1
    A[n1:, n1:] = A2
    return A, np.vstack([B1, B2 @ D1]), np.hstack([D2 @ C1, C2]), D2 @ D1


def ss_feedback(sys: SS, row: int = 0) -> SS:
    """Negative unity feedback of output ``row`` to the input: ``u = r - y[row]``, with
    ``g = 1 / (1 + D[row])``: ``A - g B c``, ``g B``, ``C - g D c``, ``g D``."""
    A, B, C, D = sys
    c, g = C[row : row + 1], 1.0 / (1.0 + D[row, 0])
    return A - g * (B @ c), g * B, C - g * (D @ c), g * D


def ss_tf(num, den) -> SS:
    """Controllable canonical form of a proper SISO transfer function (descending powers)."""
    num, den = np.asarray(num, float), np.asarray(den, float)
    num, den = num / den[0], den / den[0]
    n = den.size - 1
    if n == 0:
        return ss_static(num[-1])
    num = np.concatenate([np.zeros(n + 1 - num.size), num])
    d = num[0]
    A = np.zeros((n, n))
    A[0] = -den[1:]
    A[1:, :-1] = np.eye(n - 1)
    B = np.zeros((n, 1))
    B[0, 0] = 1.0
    C = (num[1:] - d * den[1:])[None, :]
    return A, B, C, np.array([[d]])


def delay_ss(d: int) -> SS:
    """``z^-d``: a shift register of ``d`` samples."""
    if d == 0:
        return ss_static(1.0)
    A = np.eye(d, k=-1)
    B = np.zeros((d, 1))
    B[0, 0] = 1.0
    C = np.zeros((1, d))
    C[0, -1] = 1.0
    return A, B, C, np.zeros((1, 1))


def pade_ss(tau: float) -> SS:
    """First-order Pade of ``e^{-tau s}``: ``(2/tau - s) / (2/tau + s)``."""
    return np.array([[-2.0 / tau]]), np.ones((1, 1)), np.array([[4.0 / tau]]), -np.ones((1, 1))


INTEGRATOR: SS = (np.zeros((1, 1)), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)))


def zoh(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact ZOH discretisation ``(Ad, Bd)`` via the block matrix exponential (balanced
    first: companion-form states span many decades, which makes an unbalanced ``expm``
    slow)."""
    from scipy.linalg import expm, matrix_balance

    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n] = A * dt
    M[:n, n:] = B * dt
    Mb, (sc, perm) = matrix_balance(M, permute=False, separate=True)
    E = expm(Mb) * (sc[:, None] / sc[None, :])
    return E[:n, :n], E[:n, n:]


def ss_response(A: np.ndarray, B: np.ndarray, C: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``C (x I - A)^-1 B`` for stacked systems A (k, n, n), B (k, n, 1), C (k, 1, n) at the
    points x (m,): (k, m), one batched solve."""
    k, n = A.shape[0], A.shape[1]
    M = x[None, :, None, None] * np.eye(n) - A[:, None]
    rhs = np.broadcast_to(B[:, None].astype(complex), (k, x.size, n, 1))
    sol = np.linalg.solve(M, rhs)[..., 0]  # (k, m, n)
    return np.einsum("kmn,kn->km", sol, C[:, 0, :])


def response(sys: ct.StateSpace, w: np.ndarray, dt: float | None) -> np.ndarray:
    """SISO frequency response ``C (x I - A)^-1 B + D`` of a python-control state-space
    system at ``x = jw`` or ``e^{jw dt}``, one batched linear solve over all frequencies."""
    x = np.exp(1j * w * dt) if dt else 1j * w
    A, B, C, D = sys.A, sys.B, sys.C, sys.D
    n = A.shape[0]
    if n == 0:
        return np.full(x.shape, complex(D[0, 0]))
    M = x[:, None, None] * np.eye(n)[None] - A[None]
    rhs = np.broadcast_to(B[:, :1].astype(complex), (x.size, n, 1))
    sol = np.linalg.solve(M, rhs)[:, :, 0]
    return sol @ C[0] + D[0, 0]
