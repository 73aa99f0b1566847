"""Dynamics and drive sizing (thesis ch. 4): inverse dynamics along trajectories, worst-case
static load, drive sizing checks, catalogue selection, holding checks (figures:
:mod:`armlab.plots.dynamics`).

Stable names (DESIGN.md): :func:`inverse_dynamics`, :func:`static_load`, :func:`size`,
:func:`select_drives`, :func:`load_catalogue`, :func:`hold_check`.
"""

from armlab.dynamics.checks import CHECK_NAMES, Check, SizingOptions
from armlab.dynamics.holding import HoldReport, hold_check
from armlab.dynamics.inverse import JointLoads, inverse_dynamics, joint_torques
from armlab.dynamics.reference import THESIS_TABLE_4_2, THESIS_TABLE_4_3
from armlab.dynamics.requirements import requirement_moves
from armlab.dynamics.selection import Selection, select_drives
from armlab.dynamics.sizing import JointSizing, SizingReport, size
from armlab.dynamics.static_load import (
    JointStaticLoad,
    StaticLoadReport,
    build_static_load,
    static_load,
)
from armlab.robot.catalogue import Catalogue, load_catalogue

__all__ = [
    "inverse_dynamics",
    "joint_torques",
    "JointLoads",
    "static_load",
    "build_static_load",
    "StaticLoadReport",
    "JointStaticLoad",
    "size",
    "SizingReport",
    "JointSizing",
    "SizingOptions",
    "Check",
    "CHECK_NAMES",
    "requirement_moves",
    "select_drives",
    "Selection",
    "load_catalogue",
    "Catalogue",
    "hold_check",
    "HoldReport",
    "THESIS_TABLE_4_2",
    "THESIS_TABLE_4_3",
]
