"""The progress bars of studies and sweeps: ``tqdm.auto``, and on in Jupyter.

``tqdm(disable=None)`` switches a bar off when its stream is not a terminal (CI, a pipe). A
Jupyter kernel's streams are not terminals either, so there ``disable=None`` means *on*: a
widget bar (``tqdm.notebook``) when ipywidgets is installed, else a text bar on the cell's
stdout. tqdm's "IProgress not found" warning is never raised: without ipywidgets the text bar is
chosen before ``tqdm.auto`` is asked.
"""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["tqdm", "in_jupyter_kernel"]


def in_jupyter_kernel() -> bool:
    """True in a Jupyter kernel (IPython's ZMQ shell), False in a terminal or a script."""
    shell_module = sys.modules.get("IPython")
    if shell_module is None or "ipykernel" not in sys.modules:
        return False
    try:
        shell = shell_module.get_ipython()
    except AttributeError:  # pragma: no cover - a stub IPython module
        return False
    return shell is not None and type(shell).__name__ == "ZMQInteractiveShell"


def _has_ipywidgets() -> bool:
    try:
        from tqdm.notebook import IProgress
    except ImportError:  # pragma: no cover - tqdm without its notebook module
        return False
    return IProgress is not None


def tqdm(*args: Any, **kwargs: Any) -> Any:
    """A ``tqdm.auto.tqdm`` bar; in a Jupyter kernel ``disable=None`` shows it.

    Parameters
    ----------
    *args, **kwargs
        tqdm's own (``total``, ``desc``, ``unit``, ``disable``, ``file``, ...).
    """
    if in_jupyter_kernel():
        if kwargs.get("disable") is None:
            kwargs["disable"] = False
        if _has_ipywidgets():
            from tqdm.auto import tqdm as auto_bar  # the notebook widget in a kernel

            return auto_bar(*args, **kwargs)
        from tqdm.std import tqdm as text_bar

        if kwargs.get("file") in (None, sys.stderr):
            kwargs["file"] = sys.stdout  # the cell's output, not the red stderr block
        return text_bar(*args, **kwargs)
    from tqdm.auto import tqdm as auto_bar

    return auto_bar(*args, **kwargs)
