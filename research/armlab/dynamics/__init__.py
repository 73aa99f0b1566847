"""Dynamics and drive sizing (thesis ch. 4): inverse dynamics along trajectories, worst-case
static load, drive sizing checks, catalogue selection, holding checks (figures:
:mod:`armlab.plots.dynamics`).

Stable names (DESIGN.md): :func:`inverse_dynamics`, :func:`static_load`, :func:`size`,
:func:`select_drives`, :func:`load_catalogue`, :func:`hold_check`.
"""

from armlab.dynamics.holding import HoldReport, hold_check
from armlab.dynamics.inverse import JointLoads, inverse_dynamics
from armlab.dynamics.requirements import requirement_moves
from armlab.dynamics.selection import Selection, select_drives
from armlab.dynamics.sizing import SizingReport, size
from armlab.dynamics.static_load import StaticLoadReport, static_load
from armlab.robot.catalogue import Catalogue, load_catalogue

__all__ = [
    "Catalogue",
    "HoldReport",
    "JointLoads",
    "Selection",
    "SizingReport",
    "StaticLoadReport",
    "hold_check",
    "inverse_dynamics",
    "load_catalogue",
    "requirement_moves",
    "select_drives",
    "size",
    "static_load",
]
