"""Keywords that were renamed: a call with the old name fails with one line naming the new one.

The joint controller is handed to every function that depends on it one way, ``controller=``
(issue 23); ``profile=`` (the set-point table, CiA 402, ros2, export) and ``options=`` (sizing)
were the other ways.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

from armlab.errors import InputError

__all__ = ["renamed_keywords", "RenamedKeywordError"]

P = ParamSpec("P")
R = TypeVar("R")


class RenamedKeywordError(InputError, TypeError):
    """A call used a keyword armlab renamed: an armlab input error (one line on the command
    line) that is also the ``TypeError`` Python raises for an unknown keyword."""


def renamed_keywords(**renamed: str) -> Callable[[Callable[P, R]], Callable[P, R]]:
    """Decorator: ``old=value`` in a call raises :class:`RenamedKeywordError`
    (``"f(): old= is now new"``).

    ``renamed`` maps each old keyword to the text naming its replacement.
    """

    def wrap(fn: Callable[P, R]) -> Callable[P, R]:
        @functools.wraps(fn)
        def call(*args: P.args, **kwargs: P.kwargs) -> R:
            for old, new in renamed.items():
                if old in kwargs:
                    raise RenamedKeywordError(f"{fn.__name__}(): {old}= is now {new}")
            return fn(*args, **kwargs)

        return call

    return wrap
