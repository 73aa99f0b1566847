"""Work done by forked processes beside a study (``armlab run --workers N``).

A forked process inherits the study's objects as they are (robot, plan, gains: nothing is
pickled on the way in) and ends with the study's process, also when that one is killed
(:func:`die_with`). :class:`SideProcess` runs one function ahead of the stage that needs its
result -- the servo tuning beside the plan, the drive-model simulations beside the tracking
stage -- and sends the result back pickled; whoever needs it takes it, or does the work itself
when the process failed. The report's plot processes (:mod:`armlab.study.report`) use the same
start and end.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["SILENCE_S", "SideProcess", "can_fork", "die_with", "start_forked"]

#: a forked process that sends nothing for this long [s] is given up on (a fork can inherit a
#: lock another thread held; no study waits forever for it)
SILENCE_S = 600.0


def can_fork() -> bool:
    """Whether processes can be forked here (the children inherit the study's objects)."""
    import multiprocessing

    return "fork" in multiprocessing.get_all_start_methods()


def die_with(parent: int) -> None:
    """In a forked process: end with the study's process ``parent``, also when that one is
    killed (-9), so that nothing is written into a folder a new run may own by then. Linux
    asks the kernel (``PR_SET_PDEATHSIG``); elsewhere the plot processes check the parent
    before they write."""
    try:
        import ctypes

        ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass
    if os.getppid() != parent:  # it died before the request took effect
        os._exit(0)


def start_forked(processes: Sequence[Any]) -> None:
    """Start forked processes with the study's objects frozen out of their garbage collector
    (:func:`gc.freeze`): a collection in a child would otherwise touch, and so copy, every
    page of the objects it inherited."""
    import gc

    gc.freeze()
    try:
        for process in processes:
            process.start()
    finally:
        gc.unfreeze()


class SideProcess:
    """``fn(*args, **kwargs)`` run by a forked process beside the study; its result comes back
    pickled.

    :meth:`result` is asked once, by whichever process needs it; it is None when ``fn``
    raised, the process died or stayed silent for ``silence_s``, and the caller then does the
    work itself (the same result, any error raised where it would have been)."""

    def __init__(self, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> None:
        import multiprocessing

        mp = multiprocessing.get_context("fork")
        self._receive, send = mp.Pipe(duplex=False)
        target_args = (fn, args, kwargs, send)
        self._process = mp.Process(target=self._run, args=target_args, daemon=True)
        start_forked([self._process])
        send.close()
        self._asked = False
        self._result: Any = None

    @staticmethod
    def _run(fn: Callable[..., Any], args: tuple, kwargs: dict, send) -> None:
        die_with(os.getppid())
        try:
            result = fn(*args, **kwargs)
        except Exception:  # the caller does the work again and raises the error there
            result = None
        send.send(result)
        send.close()

    def result(self, silence_s: float = SILENCE_S) -> Any:
        """``fn``'s result, or None (see the class)."""
        if not self._asked:
            self._asked = True
            try:
                if self._receive.poll(silence_s):
                    self._result = self._receive.recv()
            except (EOFError, OSError):  # the process died
                pass
        return self._result

    def close(self) -> None:
        """Stop the process if nobody took its result (a failed stage, no plot)."""
        if self._process.is_alive():
            self._process.terminate()
        self._process.join()
        self._receive.close()
