"""The two backends the double S formulas are evaluated by: numpy arrays and CasADi SX.

The kernels of :mod:`.timing` and the synchronised engine of :mod:`.batch` are written once,
against an ``ops`` object: :data:`NP` evaluates them on numpy arrays (batches, the public
vectorised primitives, trapezoids), :func:`sx` builds them as CasADi SX expressions (the graph of
one problem, :mod:`.graph`). Arithmetic (``+ - * / **``) and comparisons are the operands' own:
an SX column of ``n`` joints is element-wise like a numpy ``(n,)`` array, an SX ``(7, n)``
matrix like a numpy ``(7, n)`` phase table. The operations with a name differ between the two:

* ``select(cond, new, old)``: ``new`` where ``cond``, else ``old``. numpy writes ``new`` into
  ``old`` in place (``np.copyto``; ``old`` must be a fresh temporary of the caller: a new array
  costs more than the selection on a small problem); SX is ``if_else``, which never lets the
  untaken branch's NaN through (``if_else_zero(0, NaN) = 0``), so ``0 / 0`` of a joint at rest
  stays in the branch not taken, as ``np.where`` does;
* ``argmax_first(values, times)``: the largest of the rows (axis 0) and the time of the first
  row holding it (numpy's ``argmax`` on ties); SX scans the rows with a strict ``>``;
* ``rows`` / ``concat`` / ``accumulate``: a phase table from its seven rows, rows stacked, and
  the running sum from 0 (``out[0] = 0``, ``out[k+1] = out[k] + x[k]``).
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab._lazy import lazy_import

if TYPE_CHECKING:
    import casadi as ca
else:
    ca = lazy_import("casadi")

__all__ = ["NP", "NumpyOps", "SXOps", "sx"]


class NumpyOps:
    """The numpy backend (arrays of any shape; phase tables ``(7, ...)``)."""

    symbolic = False
    sqrt = staticmethod(np.sqrt)
    asin = staticmethod(np.arcsin)
    cos = staticmethod(np.cos)
    sin = staticmethod(np.sin)
    fmin = staticmethod(np.minimum)
    fmax = staticmethod(np.maximum)
    where = staticmethod(np.where)

    @staticmethod
    def select(cond, new, old):
        np.copyto(old, new, where=cond)
        return old

    @staticmethod
    def and_(x, y):
        return x & y

    @staticmethod
    def any(x) -> bool:
        return bool(x.any())

    @staticmethod
    def zero(x) -> float:
        return 0.0

    @staticmethod
    def joint_max(x: np.ndarray) -> np.ndarray:
        return x.max(axis=-1) if x.shape[-1] else np.zeros(x.shape[:-1])

    @staticmethod
    def per_joint(T: np.ndarray, like: np.ndarray):
        """``T`` (...) against every joint of ``like`` (..., n): a float for one problem (no
        broadcasting: it costs more than the arithmetic on a small problem), else an array
        of ``like``'s shape."""
        if T.size == 1:
            return float(T.reshape(-1)[0])
        out = np.empty(like.shape)
        out[...] = T[..., None]
        return out

    @staticmethod
    def rows(xs, out=None) -> np.ndarray:
        if out is None:
            return np.stack(xs)
        for i, x in enumerate(xs):
            out[i] = x
        return out

    @staticmethod
    def concat(xs) -> np.ndarray:
        return np.concatenate(xs)

    @staticmethod
    def accumulate(x: np.ndarray, out=None) -> np.ndarray:
        if out is None:
            out = np.empty_like(x)
        out[0] = 0.0
        np.add.accumulate(x[:-1], axis=0, out=out[1:])  # cumsum, without its wrapper
        return out

    @staticmethod
    def row_min(x: np.ndarray) -> np.ndarray:
        return x.min(axis=0)

    @staticmethod
    def argmax_first(values: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        col = np.arange(values.shape[1])
        i = values.argmax(axis=0)
        return values[i, col], times[i, col]


class SXOps:
    """The CasADi SX backend (joint columns ``(n, 1)``; phase tables ``(7, n)``)."""

    symbolic = True

    def __init__(self) -> None:
        # CasADi's own element-wise functions (casadi is imported here, by the first graph);
        # select(cond, new, old) is if_else(cond, new, old): a graph holds both branches
        self.sqrt, self.asin, self.cos, self.sin = ca.sqrt, ca.asin, ca.cos, ca.sin
        self.fmin, self.fmax, self.and_ = ca.fmin, ca.fmax, ca.logic_and
        self.where = self.select = ca.if_else

    @staticmethod
    def any(x) -> bool:
        return True  # a graph holds every branch

    @staticmethod
    def zero(x) -> Any:
        return ca.SX.zeros(x.shape)

    @staticmethod
    def joint_max(x) -> Any:
        return ca.mmax(x)

    @staticmethod
    def per_joint(T, like) -> Any:
        return T  # a 1 x 1 SX broadcasts

    @staticmethod
    def rows(xs, out=None) -> Any:
        return ca.vertcat(*[x.T for x in xs])

    @staticmethod
    def concat(xs) -> Any:
        return ca.vertcat(*xs)

    @staticmethod
    def accumulate(x, out=None) -> Any:
        return ca.vertcat(ca.SX.zeros(1, x.shape[1]), ca.cumsum(x[:-1, :], 0))

    @staticmethod
    def row_min(x) -> Any:
        out = x[0, :]
        for r in range(1, x.shape[0]):
            out = ca.fmin(out, x[r, :])
        return out

    @staticmethod
    def argmax_first(values, times) -> tuple[Any, Any]:
        best, at = values[0, :], times[0, :]
        for r in range(1, values.shape[0]):
            up = values[r, :] > best
            # the value by fmax (the same number, one instruction), its time by a selection
            best, at = ca.fmax(best, values[r, :]), ca.if_else(up, times[r, :], at)
        return best, at


NP = NumpyOps()


@functools.cache
def sx() -> SXOps:
    """The CasADi SX backend (made on first use: it imports casadi)."""
    return SXOps()
