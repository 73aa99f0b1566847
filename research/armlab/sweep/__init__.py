"""Sweeps: many studies over a parameter grid (or a seeded random / Latin-hypercube draw), run on
Dask -- a local process cluster by default, any cluster through its scheduler address -- into one
Parquet table that grows row by row and resumes where it stopped.

``armlab sweep SWEEP.toml --out DIR [--workers N] [--scheduler tcp://host:port]`` calls
:func:`run_sweep`.
"""

from armlab.sweep.report import by_parameter, plot_figure_vs_parameter, sweep_summary_text
from armlab.sweep.runner import open_client, run_sweep, run_sweep_spec
from armlab.sweep.spec import (
    MODES,
    Parameter,
    SweepSpec,
    demo_sweep_path,
    load_sweep,
    parameter_key,
    parameter_sets,
    parse_sweep,
)
from armlab.sweep.store import ResultStore
from armlab.sweep.task import run_parameter_set

__all__ = [
    "MODES",
    "Parameter",
    "ResultStore",
    "SweepSpec",
    "by_parameter",
    "demo_sweep_path",
    "load_sweep",
    "open_client",
    "parameter_key",
    "parameter_sets",
    "parse_sweep",
    "plot_figure_vs_parameter",
    "run_parameter_set",
    "run_sweep",
    "run_sweep_spec",
    "sweep_summary_text",
]
