"""Sweeps: many studies over a parameter grid (or a seeded random / Latin-hypercube draw), run on
Dask -- a local process cluster by default, any cluster through its scheduler address -- into one
Parquet table that grows row by row and resumes where it stopped.

``armlab sweep SWEEP.toml --out DIR [--workers N] [--scheduler tcp://host:port] [--overwrite]``
calls :func:`run_sweep`. Every row records what it was computed from (armlab's version, the
sha256 of the study and of every file it reads); a resume re-runs the rows whose inputs changed;
one client writes a folder at a time (``DIR/.sweep.lock``), and a folder holds one sweep.
"""

from armlab.sweep.lock import SweepLock
from armlab.sweep.provenance import PROVENANCE_FIELDS, row_provenance
from armlab.sweep.report import by_parameter, plot_figure_vs_parameter, sweep_summary_text
from armlab.sweep.runner import open_client, run_sweep, run_sweep_spec, sweep_meta, sweep_outcome
from armlab.sweep.spec import (
    MODES,
    Parameter,
    SweepSpec,
    definition_sha256,
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
    "PROVENANCE_FIELDS",
    "Parameter",
    "ResultStore",
    "SweepLock",
    "SweepSpec",
    "by_parameter",
    "definition_sha256",
    "demo_sweep_path",
    "load_sweep",
    "open_client",
    "parameter_key",
    "parameter_sets",
    "parse_sweep",
    "plot_figure_vs_parameter",
    "row_provenance",
    "run_parameter_set",
    "run_sweep",
    "run_sweep_spec",
    "sweep_meta",
    "sweep_outcome",
    "sweep_summary_text",
]
