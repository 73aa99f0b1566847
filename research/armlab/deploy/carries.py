"""What each export format carries of the controller the study verified.

The tracking stage verifies a controller: armlab's tuned cascade (position, speed and current
loops at the profile's periods) with the study's feed-forward terms
(:data:`armlab.control.feedforward.FEEDFORWARDS`). A format can carry only part of it, and the
controller that plays it runs only what it receives:

==================  =====================================================================
format              the controller that runs it, and what reaches it
==================  =====================================================================
csv, json, npz, c   the study's own controller (profile): the set-points per cycle with
                    their q, qd, qdd (and, json and c, the tuned gains). Feed-forward terms
                    are the controller's own computation from the table: the export lists
                    the ones the verdict assumed.
ros2, trajectory    a ros2_control JointTrajectoryController, velocity command interface
                    (:mod:`armlab.deploy.ros2`): the position PID and the velocity
                    feed-forward (``ff_velocity_scale``) only; no torque path, so no
                    acceleration, gravity, friction, efficiency or computed-torque term.
cia402              a CiA 402 drive in cyclic synchronous position mode
                    (:mod:`armlab.deploy.cia402`): the velocity offset 0x60B1 and the torque
                    offset 0x60B2, which is the plan's inverse dynamics through the drive
                    train (computed torque, reducer efficiency, rotor inertia, viscous
                    friction); the loops are the drive's own (armlab's gains are not in the
                    object list: the simulation stands in with them).
==================  =====================================================================

When the study's verdict depended on a term the target cannot run (or the target runs terms the
study did not verify), :func:`armlab.study.export.export_study` simulates the controller the
target will run and reports its verdict; a failing one refuses the export unless ``force``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from armlab.control.feedforward import FEEDFORWARDS

__all__ = ["Target", "target_of", "TARGETS", "COVERS"]

#: Terms a feed-forward term contains: the inverse dynamics hold the gravity and the arm's
#: inertia (:func:`armlab.control.feedforward.feedforward_current`).
COVERS = {"computed_torque": ("gravity", "acceleration")}


@dataclass(frozen=True)
class Target:
    """The controller an export format feeds.

    Attributes
    ----------
    name : str
        What runs the exported files.
    loops : str
        Whose loops close around the set-points.
    runs : tuple of str or None
        The feed-forward terms the target runs whatever the study verified (CiA 402's offsets
        always hold them); None: the study's own terms, as far as :attr:`can` allows.
    can : tuple of str
        The feed-forward terms the target can run at all.
    simulable : bool
        Whether armlab can simulate the target (a controller that computes its own terms from
        the table cannot be known: the export only lists them).
    """

    name: str
    loops: str
    runs: tuple[str, ...] | None
    can: tuple[str, ...]
    simulable: bool

    def feedforward(self, verified: tuple[str, ...]) -> tuple[str, ...]:
        """The terms the target runs when the study verified ``verified``."""
        if self.runs is not None:
            return self.runs
        return tuple(f for f in verified if f in self.can)

    def differences(self, verified: tuple[str, ...]) -> list[str]:
        """What the target runs differently from the verified controller (empty: the same)."""
        runs = self.feedforward(verified)
        covered = {c for f in runs for c in COVERS.get(f, ())}
        out = []
        missing = [f for f in verified if f not in runs and f not in covered]
        extra = [f for f in runs if f not in verified]
        if missing:
            out.append(f"it cannot run the feed-forward {', '.join(missing)}")
        if extra:
            out.append(f"it runs the feed-forward {', '.join(extra)}, which was not verified")
        return out

    def to_dict(self, verified: tuple[str, ...]) -> dict[str, Any]:
        """JSON-able: the target, its loops, the terms verified and run, what differs."""
        return {
            "target": self.name,
            "loops": self.loops,
            "feedforward_verified": list(verified),
            "feedforward_run": list(self.feedforward(verified)),
            "differences": self.differences(verified),
        }


_STUDY = Target(
    name="the study's controller profile (set-point table)",
    loops="armlab's tuned cascade (gains.json / gains.c where exported)",
    runs=None,
    can=FEEDFORWARDS,
    simulable=False,
)
_JTC = Target(
    name="ros2_control JointTrajectoryController (velocity command interface)",
    loops="position PID in the JTC (armlab's position-loop gains); speed and current loops in "
    "the drive (simulated with armlab's)",
    runs=None,
    can=("velocity",),
    simulable=True,
)
_CSP = Target(
    name="CiA 402 drive, cyclic synchronous position (0x60B1 velocity, 0x60B2 torque offsets)",
    loops="the drive's own position, speed and current loops (not in the object list; "
    "simulated with armlab's tuned gains)",
    runs=("velocity", "computed_torque", "friction", "efficiency"),
    can=("velocity", "computed_torque", "friction", "efficiency"),
    simulable=True,
)

#: The target of each export format.
TARGETS: dict[str, Target] = {
    "csv": _STUDY,
    "json": _STUDY,
    "npz": _STUDY,
    "c": _STUDY,
    "ros2": _JTC,
    "trajectory": _JTC,
    "cia402": _CSP,
}


def target_of(fmt: str) -> Target:
    """The :class:`Target` of an export format (``KeyError`` for an unknown one)."""
    return TARGETS[fmt]
