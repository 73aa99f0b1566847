"""Fast, exact decimal text of numeric columns, built with NumPy (no per-row Python).

Each value is turned into a fixed-point integer ``m = round(x 10^d)``; its digits are written
right-aligned into a ``(n_rows, width)`` byte matrix by vectorised integer division, with NUL
bytes where the number has no character (leading padding, trailing fractional zeros). Putting
the fields and separators of a row side by side and dropping the NUL bytes of the row-major
matrix gives the text of the whole table at once.

A float written with ``d`` decimals reads back (``float(text)``) as the double nearest to
``m / 10^d`` — exactly ``round(x, d)``; integers are written exactly.
"""

from __future__ import annotations

import numpy as np

from armlab.errors import InputError

__all__ = ["format_rows", "format_list"]

_POW10 = 10 ** np.arange(19, dtype=np.int64)  # 1 .. 1e18
_LIMIT = 2.0**53  # |m| above this is not an exact integer in float64


def _field(x: np.ndarray, decimals: int, name: str) -> np.ndarray:
    """Text of one column as bytes ``(n, width)`` uint8, right-aligned, unused bytes 0."""
    x = np.asarray(x)
    if x.ndim != 1:
        raise InputError(f"column {name} must be 1-D, got shape {x.shape}")
    if np.issubdtype(x.dtype, np.integer):
        m = x.astype(np.int64)
        decimals = 0
    else:
        x = x.astype(np.float64)
        if not np.all(np.isfinite(x)):
            bad = int(np.flatnonzero(~np.isfinite(x))[0])
            raise InputError(f"column {name} is not finite at row {bad}")
        scaled = x * float(10**decimals)
        if x.size and np.abs(scaled).max() >= _LIMIT:
            raise InputError(f"column {name}: |value| too large to write with {decimals} decimals")
        m = np.rint(scaled).astype(np.int64)
    n = m.size
    neg = m < 0
    a = np.abs(m)
    if decimals:
        ip, fp = np.divmod(a, _POW10[decimals])
    else:
        ip, fp = a, None
    nd = np.maximum(1, np.searchsorted(_POW10, ip, side="right"))
    max_nd = int(nd.max()) if n else 1
    width = 1 + max_nd + (1 + decimals if decimals else 0)
    buf = np.zeros((n, width), dtype=np.uint8)
    last_int = width - 1
    # unsigned 32-bit digit arithmetic where it fits: NumPy divides by a scalar with libdivide
    if fp is not None:  # decimals > 0
        f, ten32 = fp.astype(np.uint32), np.uint32(10)  # fp < 10^decimals <= 10^9
        zero_run = np.ones(n, dtype=bool)  # trailing zeros so far (become padding)
        for k in range(decimals):
            q = f // ten32
            d = f - q * ten32
            f = q
            zero_run &= d == 0
            buf[:, width - 1 - k] = (d + 48) * ~zero_run
        buf[:, width - 1 - decimals] = ord(".") * ~zero_run
        last_int = width - 2 - decimals
    small = n == 0 or ip.max() < 2**32
    i: np.ndarray = ip.astype(np.uint32 if small else np.uint64)
    ten = np.uint32(10) if small else np.uint64(10)
    for k in range(max_nd):
        q = i // ten
        d = i - q * ten
        buf[:, last_int - k] = (d + 48) if k == 0 else (d + 48) * (i != 0)
        i = q
    rows = np.flatnonzero(neg)
    buf[rows, (last_int - nd)[rows]] = ord("-")
    return buf


def format_rows(
    columns, decimals, *, sep: str = ",", prefix: str = "", suffix: str = "\n", names=None
) -> bytes:
    """Text of a table, one line per row.

    Parameters
    ----------
    columns : sequence of arrays (n_rows,)
        Integer columns are written exactly; float columns with ``decimals`` places.
    decimals : int or sequence of int
        Decimal places per column (ignored for integer columns).
    sep, prefix, suffix : str
        Between fields, before the first and after the last field of each row (no NUL bytes).
    names : sequence of str, optional
        Column names for error messages.

    Returns
    -------
    bytes
        ASCII text.
    """
    columns = list(columns)
    if not columns:
        return b""
    n = np.asarray(columns[0]).shape[0]
    if isinstance(decimals, int):
        decimals = [decimals] * len(columns)
    names = list(names) if names is not None else [str(i) for i in range(len(columns))]

    def const(text: str) -> list[np.ndarray]:
        b = np.frombuffer(text.encode(), dtype=np.uint8)
        return [np.broadcast_to(b, (n, b.size))] if b.size else []

    blocks = const(prefix)
    for k, (col, d, name) in enumerate(zip(columns, decimals, names, strict=True)):
        if np.asarray(col).shape != (n,):
            raise InputError(f"column {name} has shape {np.asarray(col).shape}, expected ({n},)")
        blocks.append(_field(col, int(d), name))
        if k < len(columns) - 1:
            blocks += const(sep)
    blocks += const(suffix)
    flat = np.concatenate(blocks, axis=1).ravel()
    return flat[flat != 0].tobytes()


def format_list(values, decimals: int, *, sep: str = ",", name: str = "") -> bytes:
    """``v0,v1,...`` of one column (no brackets), same number format as :func:`format_rows`."""
    values = np.asarray(values)
    if values.size == 0:
        return b""
    return format_rows([values.reshape(-1)], decimals, sep="", suffix=sep, names=[name])[
        : -len(sep) or None
    ]
