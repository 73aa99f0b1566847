"""Figures of the workspace and accuracy studies (matplotlib Figures).

The figures are made by pyplot under the caller's backend (Jupyter shows them; nothing switches
the backend); save them with ``fig.savefig(path)``, or draw them inside
:func:`armlab.plots.offscreen` to keep them out of pyplot.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from armlab.kinematics.accuracy import AccuracyResult
from armlab.kinematics.workspace import WorkspaceResult
from armlab.plots._figure import fixed_layout, new_figure

if TYPE_CHECKING:  # matplotlib is imported when a plot is drawn, not with the package
    from matplotlib.figure import Figure

__all__ = ["plot_workspace", "plot_accuracy", "plot_accuracy_scatter"]


def plot_workspace(
    result: WorkspaceResult, *, max_points: int = 20000, required_reach_m: float | None = 0.7
) -> Figure:
    """Side view (radius from the base axis vs height) and top view (x-y) of the reach cloud.

    Parameters
    ----------
    result : WorkspaceResult
    max_points : int
        At most this many samples are drawn (the first ones).
    required_reach_m : float, optional
        Draw the required reach radius (thesis 2.2.2: 0.7 m); None to omit.
    """
    p = result.points_m[:max_points] * 1000.0
    r = np.hypot(p[:, 0], p[:, 1])
    fig = new_figure(figsize=(11, 5))
    side, top = fig.subplots(1, 2)
    fixed_layout(fig, 1, 2, left=0.85, right=0.2, top=0.8, bottom=0.6, wgap=1.0)
    side.scatter(r, p[:, 2], s=1, alpha=0.25, color="tab:blue", rasterized=True)
    side.axvline(
        result.max_reach_m * 1000,
        color="tab:red",
        lw=1,
        label=f"max reach {result.max_reach_m * 1000:.1f} mm",
    )
    if required_reach_m is not None:
        side.axvline(
            required_reach_m * 1000,
            color="k",
            ls="--",
            lw=1,
            label=f"required {required_reach_m * 1000:.0f} mm",
        )
    side.set_xlabel("radius from base axis [mm]")
    side.set_ylabel("height z [mm]")
    side.set_title("side view (r-z)")
    side.set_aspect("equal", adjustable="datalim")
    side.legend(loc="lower left", fontsize=8)
    top.scatter(p[:, 0], p[:, 1], s=1, alpha=0.25, color="tab:blue", rasterized=True)
    t = np.linspace(0, 2 * np.pi, 361)
    top.plot(
        result.max_reach_m * 1000 * np.cos(t),
        result.max_reach_m * 1000 * np.sin(t),
        color="tab:red",
        lw=1,
    )
    top.set_xlabel("x [mm]")
    top.set_ylabel("y [mm]")
    top.set_title("top view (x-y)")
    top.set_aspect("equal", adjustable="datalim")
    fig.suptitle(
        f"{result.robot}: tool-point workspace, {result.n_samples} random "
        f"configurations (seed {result.seed})"
    )
    return fig


_TITLES = {"angle": "reducer angle errors", "length": "link-length tolerances", "combined": "both"}


def plot_accuracy(result: AccuracyResult, *, bins: int = 60) -> Figure:
    """Histograms of the position error: one row per source (angle, length, both), columns
    dx, dy, dz and the total |dp|, in [mm]; the 95th percentile is marked."""
    fig = new_figure(figsize=(13, 8))
    axes = fig.subplots(3, 4)
    fixed_layout(fig, 3, 4, left=0.45, right=0.15, top=0.8, bottom=0.55, wgap=0.45, hgap=0.75)
    for row, source in enumerate(("angle", "length", "combined")):
        e = result.errors(source) * 1000.0
        cols = [e[:, 0], e[:, 1], e[:, 2], np.linalg.norm(e, axis=1)]
        for c, (data, label) in enumerate(zip(cols, ("dx", "dy", "dz", "|dp|"), strict=True)):
            ax = axes[row, c]
            color = "tab:blue" if c < 3 else "tab:orange"
            ax.hist(data, bins=bins, histtype="stepfilled", color=color)  # one patch, not 60
            p95 = np.percentile(np.abs(data), 95)
            for s in (1,) if c == 3 else (-1, 1):
                ax.axvline(s * p95, color="k", ls="--", lw=0.8)
            ax.set_title(f"{label}: {_TITLES[source]} (p95 {p95:.3f} mm)", fontsize=9)
            ax.set_xlabel(f"{label} [mm]")
    e_arcmin = np.degrees(result.angle_error_rad.max()) * 60
    fig.suptitle(
        f"{result.robot}: position error at the {result.point.replace('_', ' ')}, "
        f"{result.n_samples} samples (seed {result.seed})\nreducer error "
        f"+-{e_arcmin:.1f}'; tolerances "
        + ", ".join(f"{k} +-{v * 1000:g} mm" for k, v in result.length_tolerances_m.items())
    )
    return fig


def plot_accuracy_scatter(result: AccuracyResult, source: str = "combined") -> Figure:
    """Error per sample (the thesis' figures 3.3-3.10 style): dx, dy, dz and |dp| in [mm]
    against the sample number."""
    e = result.errors(source) * 1000.0
    fig = new_figure(figsize=(11, 6), layout="constrained")
    axes = fig.subplots(2, 2).ravel()
    data = [e[:, 0], e[:, 1], e[:, 2], np.linalg.norm(e, axis=1)]
    k = np.arange(1, e.shape[0] + 1)
    for ax, d, label in zip(axes, data, ("dx", "dy", "dz", "|dp|"), strict=True):
        ax.plot(k, d, ".", ms=2)
        ax.set_xlabel("sample")
        ax.set_ylabel(f"{label} [mm]")
    fig.suptitle(f"{result.robot}: {_TITLES[source]} at the {result.point.replace('_', ' ')}")
    return fig
