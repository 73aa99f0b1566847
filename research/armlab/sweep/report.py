"""The end of a sweep: a summary table and plots of each figure of merit vs each parameter."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from armlab.io import atomic_open
from armlab.sweep.spec import SweepSpec

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["plot_figure_vs_parameter", "write_sweep_plots", "sweep_summary_text", "by_parameter"]


def _is_numeric(series: pd.Series) -> bool:
    return pd.api.types.is_numeric_dtype(series) and not pd.api.types.is_bool_dtype(series)


def plot_figure_vs_parameter(frame: pd.DataFrame, figure: str, parameter: str) -> Figure:
    """One figure of merit against one parameter: a point per finished study; studies that ended
    in an error are red crosses on the bottom edge; for a grid, the mean over the other
    parameters as a line. Categorical parameters (motor names) are spread on the x axis.

    The figure is made by pyplot (Jupyter shows it), or inside :func:`armlab.plots.offscreen`
    with the object API for files only."""
    from armlab.plots._figure import new_figure

    fig = new_figure(figsize=(6, 4))
    ax = fig.subplots()
    ok = frame[frame["status"] == "done"]
    err = frame[frame["status"] != "done"]
    x_all = frame[parameter]
    if _is_numeric(x_all):
        pos = lambda s: s.astype(float)  # noqa: E731
        ticks = None
    else:
        cats = list(dict.fromkeys(x_all.astype(str)))
        pos = lambda s: s.astype(str).map({c: i for i, c in enumerate(cats)})  # noqa: E731
        ticks = cats
    y = pd.to_numeric(ok[figure], errors="coerce") if figure in ok else pd.Series(dtype=float)
    ax.plot(pos(ok[parameter]), y, "o", ms=5, alpha=0.7, label="done")
    if len(ok) and y.notna().any():
        mean = pd.DataFrame({"x": pos(ok[parameter]), "y": y}).groupby("x")["y"].mean()
        if len(mean) < len(ok):
            ax.plot(mean.index, mean.values, "-", color="C0", lw=1, label="mean")
    if len(err):
        bottom = float(np.nanmin(y)) if y.notna().any() else 0.0
        ax.plot(
            pos(err[parameter]),
            np.full(len(err), bottom),
            "x",
            color="C3",
            ms=8,
            mew=2,
            label=f"error ({len(err)})",
        )
    if ticks is not None:
        ax.set_xticks(range(len(ticks)))
        ax.set_xticklabels(ticks, rotation=20, fontsize=8)
    ax.set_xlabel(parameter)
    ax.set_ylabel(figure)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"{figure} vs {parameter}")
    fig.tight_layout()
    return fig


def write_sweep_plots(frame: pd.DataFrame, spec: SweepSpec, out_dir: Path) -> list[Path]:
    """``out_dir/plots/<figure>_vs_<parameter>.png`` for every figure of merit and parameter.

    Drawn inside :func:`armlab.plots.offscreen` (object API, Agg canvas): the caller's
    matplotlib backend is never switched and pyplot keeps no figure."""
    from armlab.plots._figure import offscreen

    folder = Path(out_dir) / "plots"
    folder.mkdir(exist_ok=True)
    paths = []
    for figure in spec.figures:
        if figure not in frame or not pd.to_numeric(frame[figure], errors="coerce").notna().any():
            continue
        for p in spec.parameter_keys:
            with offscreen():
                fig = plot_figure_vs_parameter(frame, figure, p)
            path = folder / f"{figure}_vs_{p}.png"
            with atomic_open(path, "wb") as f:
                fig.savefig(f, format="png", dpi=100)
            paths.append(path)
    return paths


def by_parameter(frame: pd.DataFrame, parameter: str, figures: list[str]) -> pd.DataFrame:
    """Per value of a parameter: number of sets, errors, and the mean of each figure over the
    finished sets (numeric parameters with many values are cut into 5 equal-count bins)."""
    x = frame[parameter]
    if _is_numeric(x) and x.nunique() > 8:
        x = pd.qcut(x.astype(float), 5, duplicates="drop")
    ok = frame["status"] == "done"
    g = pd.DataFrame({parameter: x, "error": ~ok})
    for f in figures:
        g[f] = pd.to_numeric(frame[f], errors="coerce").where(ok)
    out = g.groupby(parameter, observed=True, sort=True).agg(
        n=("error", "size"), errors=("error", "sum"), **{f: (f, "mean") for f in figures}
    )
    return out


def sweep_summary_text(
    frame: pd.DataFrame,
    spec: SweepSpec,
    *,
    ran: int,
    before: int,
    elapsed_s: float,
    plots: list[Path],
    out_dir: Path,
) -> str:
    """The table ``armlab sweep`` prints at the end."""
    n = len(frame)
    counts = frame["status"].value_counts().to_dict() if n else {}
    rate = f" ({ran / elapsed_s:.2f} studies/s)" if ran and elapsed_s > 0 else ""
    lines = [
        f"armlab sweep {spec.name!r}: {n} parameter sets over "
        f"{', '.join(spec.parameter_keys)} ({spec.mode}); base study {spec.study_source}",
        f"  {counts.get('done', 0)} done, {counts.get('error', 0)} error; {ran} run now in "
        f"{elapsed_s:.1f} s{rate}, {before} already in {out_dir}",
    ]
    errors = frame[frame["status"] == "error"] if n else frame
    if len(errors):
        lines.append("errors:")
        for _, r in errors.head(5).iterrows():
            ps = ", ".join(f"{p}={_short(r[p])}" for p in spec.parameter_keys)
            msg = str(r["error"])
            lines.append(f"  {ps}: {msg[:110] + '...' if len(msg) > 110 else msg}")
        if len(errors) > 5:
            lines.append(f"  ... and {len(errors) - 5} more (column 'error' of results.parquet)")
    figures = [
        f
        for f in spec.figures
        if f in frame and pd.to_numeric(frame[f], errors="coerce").notna().any()
    ]
    missing = [f for f in spec.figures if f not in figures]
    if missing:
        lines.append(
            f"figures without values (stage not run or not available): {', '.join(missing)}"
        )
    done = frame[frame["status"] == "done"] if n else frame
    for f in figures:
        y = pd.to_numeric(done[f], errors="coerce")
        if y.notna().any():
            lo, hi = done.loc[y.idxmin()], done.loc[y.idxmax()]
            lines.append(
                f"{f}: min {_short(y.min())} at "
                + ", ".join(f"{p}={_short(lo[p])}" for p in spec.parameter_keys)
                + f"; max {_short(y.max())} at "
                + ", ".join(f"{p}={_short(hi[p])}" for p in spec.parameter_keys)
            )
    if n and figures:
        with pd.option_context(
            "display.width",
            110,
            "display.max_columns",
            12,
            "display.float_format",
            lambda v: f"{v:.4g}",
        ):
            for p in spec.parameter_keys:
                lines.append("")
                lines += by_parameter(frame, p, figures).to_string().splitlines()
    if plots:
        lines.append("")
        lines.append(
            f"plots: {len(plots)} in {Path(out_dir) / 'plots'}; table: "
            f"{Path(out_dir) / 'results.parquet'}"
        )
    return "\n".join(lines)


def _short(v) -> str:
    if isinstance(v, float):
        return "nan" if math.isnan(v) else f"{v:.4g}"
    return str(v)
