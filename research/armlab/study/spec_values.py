"""What a study key may hold: the value checks of :mod:`armlab.study.spec`.

Each section's dataclass field carries its check and its documentation (:func:`_key`); a check
``check(value, where)`` returns the value (normalised) or raises :class:`SpecError` naming the
dotted key. A drive value is checked by the drives file's own rule
(:func:`armlab.robot.drives_file.value_problem`): one validator wherever it is given.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, field

from armlab.errors import SpecError
from armlab.names import check_name, check_title
from armlab.robot.drives_file import drive_value_rule, value_problem


def _fail(where: str, what: str, value) -> SpecError:
    return SpecError(f"{where}: {what}, not {value!r}")


def _str(choices: tuple[str, ...] | None = None):
    def check(v, where):
        if not isinstance(v, str) or not v:
            raise _fail(where, "expected a non-empty string", v)
        if choices is not None and v not in choices:
            raise _fail(where, f"expected one of {', '.join(choices)}", v)
        return v

    return check


def _title(v, where):
    return check_title(v, "title", where, SpecError)


def _joint_name(v, where):
    return check_name(v, "joint name", where, SpecError)


def _drive_value(part: str, key: str):
    """The drives file's rule for ``part.key`` (:func:`armlab.robot.drives_file.value_problem`):
    one validator for a drive value given in a study, a drives file or a catalogue entry."""
    rule = drive_value_rule(part, key)

    def check(v, where):
        problem = value_problem(v, rule)
        if problem is not None:
            raise SpecError(f"{where}: {v!r} {problem} (as in a drives file)")
        return v if rule in ("count", "decoding") else float(v)

    return check


def _bool(v, where):
    if not isinstance(v, bool):
        raise _fail(where, "expected true or false", v)
    return v


def _int(lo: int | None = None, hi: int | None = None):
    def check(v, where):
        if isinstance(v, bool) or not isinstance(v, int):
            raise _fail(where, "expected an integer", v)
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            raise _fail(
                where, f"expected an integer in [{lo}, {hi if hi is not None else 'inf'}]", v
            )
        return v

    return check


def _float(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False):
    def check(v, where):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise _fail(where, "expected a finite number", v)
        v = float(v)
        bad_lo = lo is not None and (v <= lo if lo_open else v < lo)
        if bad_lo or (hi is not None and v > hi):
            left = "(" if lo_open else "["
            top = hi if hi is not None else "inf"
            raise _fail(where, f"expected a number in {left}{lo}, {top}]", v)
        return v

    return check


def _number_or_list(lo_open_zero: bool = True):
    """A positive number for every joint, or a list of positive numbers (one per joint)."""

    def check(v, where):
        if isinstance(v, list):
            if not v:
                raise _fail(where, "expected a positive number or a non-empty list of them", v)
            return tuple(
                _float(0.0, lo_open=lo_open_zero)(x, f"{where}[{i}]") for i, x in enumerate(v)
            )
        return _float(0.0, lo_open=lo_open_zero)(v, where)

    return check


def _vector(n: int | None = None):
    def check(v, where):
        if not isinstance(v, list) or (n is not None and len(v) != n) or not v:
            raise _fail(where, f"expected a list of {n if n is not None else 'some'} numbers", v)
        return tuple(_float()(x, f"{where}[{i}]") for i, x in enumerate(v))

    return check


def _matrix(width: int | None = None):
    def check(v, where):
        if not isinstance(v, list) or not v or not all(isinstance(r, list) for r in v):
            raise _fail(where, "expected a list of rows (a list of lists of numbers)", v)
        rows = tuple(_vector(width)(r, f"{where}[{i}]") for i, r in enumerate(v))
        if len({len(r) for r in rows}) != 1:
            raise SpecError(f"{where}: every row must have the same length")
        return rows

    return check


def _str_list(choices: tuple[str, ...] | None = None):
    def check(v, where):
        if not isinstance(v, list):
            raise _fail(where, "expected a list of strings", v)
        return tuple(_str(choices)(x, f"{where}[{i}]") for i, x in enumerate(v))

    return check


def _raw(v, where):
    """A value checked with the other keys of its table (the payload's shape)."""
    return v


def _key(check, default=MISSING, doc: str = ""):
    """A dataclass field that carries its value check and documentation."""
    if default is MISSING:
        return field(metadata={"check": check, "doc": doc})
    return field(default=default, metadata={"check": check, "doc": doc})
