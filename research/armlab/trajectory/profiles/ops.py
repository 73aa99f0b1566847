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
  the running sum from 0 (``out[0] = 0``, ``out[k+1] = out[k] + x[k]``);
* sets of times (:func:`armlab.trajectory.sampling.merged_times`): numpy holds the kept values
  (``compress`` is ``x[mask]``), a graph a fixed-size column whose dropped values are
  ``+inf`` (``compress`` is ``if_else(mask, x, inf)``), so a sorted set is its values in order
  and then ``+inf``; ``sort`` is ``ndarray.sort`` / Batcher's odd-even merge sorting network
  (:func:`batcher_pairs`); ``append`` one value, ``gaps_above(x, tiny)`` (``x[k+1] - x[k] >
  tiny``, the last True);
* ``nanmax`` (the largest value, NaN if any is NaN), ``any_of`` (any element true);
* ``take(rows, index)``: each row gathered at ``index`` (numpy ``np.take(..., axis=1)``; the MX
  backend, :func:`mx`, indexes each row with an MX index: the samples of the closed-form
  graph, :mod:`armlab.planning.closed_graph`).
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab._lazy import lazy_import

if TYPE_CHECKING:
    import casadi as ca
else:
    ca = lazy_import("casadi")

__all__ = ["NP", "MXOps", "NumpyOps", "SXOps", "batcher_pairs", "mx", "sx"]


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
    def not_(x) -> bool:
        return not x

    @staticmethod
    def all_of(x: np.ndarray) -> bool:
        return bool(x.all())

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

    @staticmethod
    def sort(x: np.ndarray) -> np.ndarray:
        x.sort()  # in place: x is a fresh array of the caller
        return x

    @staticmethod
    def append(x: np.ndarray, value) -> np.ndarray:
        return np.concatenate((x, (value,)))

    @staticmethod
    def compress(x: np.ndarray, mask: np.ndarray, sort: bool = False) -> np.ndarray:
        return x[mask]  # in order: sorted stays sorted

    @staticmethod
    def gaps_above(x: np.ndarray, tiny) -> np.ndarray:
        keep = np.empty(x.size, bool)
        keep[-1] = True
        np.greater(x[1:] - x[:-1], tiny, out=keep[:-1])
        return keep

    @staticmethod
    def nanmax(x: np.ndarray):
        return x.max()

    @staticmethod
    def any_of(x: np.ndarray) -> bool:
        return bool(x.any())

    @staticmethod
    def take(rows: np.ndarray, index: np.ndarray) -> np.ndarray:
        return np.take(rows, index, axis=1)


class SXOps:
    """The CasADi SX backend (joint columns ``(n, 1)``; phase tables ``(7, n)``)."""

    symbolic = True

    def __init__(self) -> None:
        # CasADi's own element-wise functions (casadi is imported here, by the first graph);
        # select(cond, new, old) is if_else(cond, new, old): a graph holds both branches
        self.sqrt, self.asin, self.cos, self.sin = ca.sqrt, ca.asin, ca.cos, ca.sin
        self.fmin, self.fmax, self.and_ = ca.fmin, ca.fmax, ca.logic_and
        self.not_, self.all_of = ca.logic_not, ca.mmin
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

    @staticmethod
    def sort(x) -> Any:
        """Batcher's odd-even merge sort of the column ``x`` (``fmin``/``fmax`` comparators:
        one VM instruction each; :mod:`armlab.planning.closed_graph` compiles them as
        ternaries)."""
        xs = [x[i] for i in range(x.shape[0])]
        for i, k in batcher_pairs(len(xs)):
            xs[i], xs[k] = ca.fmin(xs[i], xs[k]), ca.fmax(xs[i], xs[k])
        return ca.vertcat(*xs)

    @staticmethod
    def append(x, value) -> Any:
        return ca.vertcat(x, value)

    def compress(self, x, mask, sort: bool = False) -> Any:
        out = ca.if_else(mask, x, ca.inf)
        return self.sort(out) if sort else out

    @staticmethod
    def gaps_above(x, tiny) -> Any:
        return ca.vertcat(x[1:] - x[:-1] > tiny, 1)

    @staticmethod
    def nanmax(x) -> Any:
        # fmax drops a NaN: the sum of the values (NaN if any is) tells
        total, best = x[0], x[0]
        for i in range(1, x.shape[0]):
            total, best = total + x[i], ca.fmax(best, x[i])
        return ca.if_else(total == total, best, math.nan)

    @staticmethod
    def any_of(x) -> Any:
        out = x[0]
        for i in range(1, x.numel()):
            out = ca.logic_or(out, x[i])
        return out


class MXOps:
    """The CasADi MX backend of the samples of a graph (vector operations on matrices; a
    gather by an MX index)."""

    symbolic = True

    def __init__(self) -> None:
        self.fmin, self.fmax, self.where = ca.fmin, ca.fmax, ca.if_else

    @staticmethod
    def take(rows, index) -> tuple:
        return tuple(r[index] for r in rows)


def batcher_pairs(N: int) -> list[tuple[int, int]]:
    """The comparators ``(i, k)``, ``i < k``, of Batcher's odd-even merge sort of ``N`` values
    (Knuth, TAOCP vol. 3, §5.3.4): the network of the next power of two with the comparators
    that touch the values past ``N`` left out (those values would be ``+inf``: such a
    comparator changes nothing)."""
    P = 1
    while P < N:
        P *= 2
    out = []
    p = 1
    while p < P:
        k = p
        while k >= 1:
            for j in range(k % p, P - k, 2 * k):
                for i in range(min(k, P - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p) and i + j + k < N:
                        out.append((i + j, i + j + k))
            k //= 2
        p *= 2
    return out


NP = NumpyOps()


@functools.cache
def sx() -> SXOps:
    """The CasADi SX backend (made on first use: it imports casadi)."""
    return SXOps()


@functools.cache
def mx() -> MXOps:
    """The CasADi MX backend of the samples (made on first use: it imports casadi)."""
    return MXOps()
