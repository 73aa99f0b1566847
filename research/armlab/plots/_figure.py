"""Where armlab's figures come from: pyplot (they show in Jupyter) or, for files, the object API.

Every ``plot_*``/``*_figure`` function asks :func:`new_figure` for its figure:

* by default the figure is made with :func:`matplotlib.pyplot.figure`, so it belongs to pyplot's
  figure manager: Jupyter's inline backend shows it at the end of the cell, ``plt.show()``
  shows it in a script, an interactive IPython session draws it at once. The backend is
  whatever the caller has; armlab never switches it. Close figures you no longer need with
  ``plt.close(fig)`` (pyplot keeps them alive until then, as for any pyplot figure).
* inside ``with offscreen():`` the figure is a bare :class:`matplotlib.figure.Figure` with its
  own Agg canvas, unknown to pyplot: nothing is shown, nothing needs closing, no GUI toolkit is
  touched (safe in worker threads and processes). The study report and the sweep plots draw
  their PNG files this way.

The choice is a :class:`contextvars.ContextVar`: it holds for the thread (or task) that entered
:func:`offscreen` and leaves every other one alone.
"""

from __future__ import annotations

import contextvars
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # matplotlib is imported when a figure is made, not with the package
    from matplotlib.figure import Figure

__all__ = ["new_figure", "offscreen"]

_OFFSCREEN: contextvars.ContextVar[bool] = contextvars.ContextVar(
    "armlab_plots_offscreen", default=False
)


@contextmanager
def offscreen() -> Iterator[None]:
    """Make the figures of this block for files only: object API and an Agg canvas, no pyplot.

    Examples
    --------
    >>> from armlab.plots import offscreen, plot_workspace
    >>> with offscreen():  # doctest: +SKIP
    ...     plot_workspace(result).savefig("workspace.png")
    """
    token = _OFFSCREEN.set(True)
    try:
        yield
    finally:
        _OFFSCREEN.reset(token)


def is_offscreen() -> bool:
    """True inside :func:`offscreen` (in this thread or task)."""
    return _OFFSCREEN.get()


def new_figure(**kwargs: Any) -> Figure:
    """A new figure: ``matplotlib.pyplot.figure(**kwargs)``, or inside :func:`offscreen` a
    :class:`matplotlib.figure.Figure` with a ``FigureCanvasAgg``.

    Parameters
    ----------
    **kwargs
        Passed to the figure (``figsize``, ``layout``, ...).
    """
    if _OFFSCREEN.get():
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(**kwargs)
        FigureCanvasAgg(fig)
        return fig
    import matplotlib.pyplot as plt

    return plt.figure(**kwargs)


def fixed_layout(
    fig: Figure,
    nrows: int,
    ncols: int,
    *,
    left: float = 0.9,
    right: float = 0.2,
    top: float = 0.6,
    bottom: float = 0.55,
    wgap: float = 0.8,
    hgap: float = 0.55,
) -> None:
    """Place a grid of subplots by margins and gaps in [inch] (``subplots_adjust``): for the
    many-panel figures, where a layout engine's text measuring costs more than the drawing."""
    w, h = fig.get_size_inches()
    aw = max((w - left - right - (ncols - 1) * wgap) / ncols, 1e-3)
    ah = max((h - top - bottom - (nrows - 1) * hgap) / nrows, 1e-3)
    fig.subplots_adjust(
        left=left / w,
        right=1.0 - right / w,
        top=1.0 - top / h,
        bottom=bottom / h,
        wspace=wgap / aw,
        hspace=hgap / ah,
    )
