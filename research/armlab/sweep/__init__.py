"""Sweeps: many studies over a parameter grid (or a seeded random / Latin-hypercube draw), run on
Dask -- a local process cluster by default, any cluster through its scheduler address -- into one
Parquet table that grows row by row and resumes where it stopped.

``armlab sweep SWEEP.toml --out DIR [--workers N] [--scheduler tcp://host:port] [--overwrite]``
calls :func:`run_sweep`. Every row records what it was computed from (armlab's version, the
sha256 of the study and of every file it reads); a resume re-runs the rows whose inputs changed;
one client writes a folder at a time (``DIR/.sweep.lock``), and a folder holds one sweep.
"""

from armlab.sweep.report import by_parameter, plot_figure_vs_parameter, sweep_summary_text
from armlab.sweep.runner import run_sweep, run_sweep_spec
from armlab.sweep.spec import SweepSpec, demo_sweep_path, load_sweep, parse_sweep
from armlab.sweep.store import ResultStore

__all__ = [
    "ResultStore",
    "SweepSpec",
    "by_parameter",
    "demo_sweep_path",
    "load_sweep",
    "parse_sweep",
    "plot_figure_vs_parameter",
    "run_sweep",
    "run_sweep_spec",
    "sweep_summary_text",
]
