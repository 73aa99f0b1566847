"""armlab's exceptions: one base class, one subclass per kind of problem.

The command line prints ``str(error)`` on one line and exits non-zero; no traceback.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "ArmlabError",
    "RobotDescriptionError",
    "UnreachableError",
    "InfeasibleError",
    "LimitViolation",
    "SpecError",
    "InputError",
    "DesignFailure",
]


class ArmlabError(Exception):
    """Base class of every error armlab raises on purpose."""


class RobotDescriptionError(ArmlabError):
    """A robot description (URDF, MDH table, drives.toml) is missing, malformed or inconsistent."""


class InputError(ArmlabError, ValueError):
    """An argument has the wrong shape, a NaN, an unknown name or an out-of-range value."""


class UnreachableError(ArmlabError):
    """A pose cannot be reached (outside the workspace, outside the joint ranges, or singular)."""


class InfeasibleError(ArmlabError):
    """A planning or tuning request cannot meet its limits; the message names the binding limit."""


class LimitViolation(ArmlabError):
    """A result would break a limit (joint range, speed, torque, controller pulse rate)."""

    #: details of the failing check where the raiser attaches them (the deploy pre-flight
    #: attaches a :class:`~armlab.deploy.checks.PreflightFailure`); unset otherwise
    failure: Any


class SpecError(ArmlabError, ValueError):
    """A specification (control spec, study file, sweep file) is invalid or impossible."""


class DesignFailure(ArmlabError):
    """The design fails checks (sizing, tracking budget, controller limits) and the requested
    action needs a passing design (exporting tables); the message names the failed checks.
    The command line exits with status 1 for it, as for a study whose design fails."""
