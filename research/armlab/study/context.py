"""What the stages of a study share: the :class:`StudyContext` (the spec, the resolved design
and each stage's typed result) and the JSON form of a stage's block."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab.robot.controller import ControllerProfile
from armlab.study.spec import StudySpec

if TYPE_CHECKING:
    from armlab.collision.motion import ClearanceReport
    from armlab.collision.scene import CollisionScene
    from armlab.control.gains import ArmGains
    from armlab.control.result import TrackingResult
    from armlab.deploy.table import SetpointTable
    from armlab.dynamics.selection import Selection
    from armlab.dynamics.sizing import SizingReport
    from armlab.dynamics.static_load import StaticLoadReport
    from armlab.kinematics.accuracy import AccuracyResult
    from armlab.kinematics.workspace import WorkspaceResult
    from armlab.robot.model import Robot
    from armlab.study.decisions import Decision
    from armlab.study.verdict import StageOutput, StageRecord
    from armlab.trajectory import Trajectory
    from armlab.trajectory.sampling import LimitReport

__all__ = ["StudyContext", "NotApplicable", "jsonable", "jsonable_block"]


class NotApplicable(Exception):
    """A stage that does not apply to this robot (no drive data): the stage is skipped."""


@dataclass
class StudyContext:
    """Everything the stages share: the spec, the resolved design and each stage's typed result
    (None until the stage that makes it has run)."""

    spec: StudySpec
    #: the robot (:func:`build_robot`; the sizing stage may give it its drive train) and the
    #: controller (:func:`controller_profile`)
    robot: Robot
    controller: ControllerProfile
    out_dir: Path | None = None
    force: bool = False
    #: what was decided before the first stage (:mod:`armlab.study.decisions`)
    decisions: tuple[Decision, ...] = ()
    #: kinematics: the joint waypoints (n, n_joints) [rad or m], the Cartesian ones as poses,
    #: where the joint ones come from, the tool positions (n, 3) [m] and the reach [m]
    waypoints_q: np.ndarray | None = None
    waypoint_poses: np.ndarray | None = None
    waypoints_from: str = ""
    tcp_positions_m: np.ndarray | None = None
    max_reach_m: float = math.nan
    #: the kinematics stage's Monte-Carlo studies (``kinematics.workspace_samples``,
    #: ``accuracy_samples``; None when the study asks for none)
    workspace: WorkspaceResult | None = None
    accuracy: AccuracyResult | None = None
    #: plan: the trajectory and its check against the robot's full limits
    trajectory: Trajectory | None = None
    limit_report: LimitReport | None = None
    jerk_limited: bool = True
    #: plan: the collision scene (robot, payload shape, floor, obstacles; built before the
    #: planner runs) and the plan's certified clearance (:func:`armlab.collision.check_motion`;
    #: set also when the plan is refused for it)
    collision_scene: CollisionScene | None = None
    clearance: ClearanceReport | None = None
    #: static load
    static_load: StaticLoadReport | None = None
    #: sizing: the planned duty cycle's, the worst-case requirement moves', the selection
    sizing: SizingReport | None = None
    requirement_sizing: SizingReport | None = None
    selection: Selection | None = None
    drives_selected: bool = False
    #: the plan stage's output again and its time [s] when the selection re-planned with the
    #: chosen drives' limits (:func:`armlab.study.drive_choice.choose_drives`; the runner
    #: records it)
    replanned: tuple[StageOutput, float] | None = None
    #: the gains and tracking result the selection verified, for the drives they were made
    #: with (``{"drives", "gains", "tracking"}``): the tuning and tracking stages reuse them
    verified: dict[str, Any] | None = None
    #: tuning
    gains: ArmGains | None = None
    #: tracking: the result, the diagnosis of a miss (:func:`~armlab.control.simulate.
    #: diagnose_tracking`), its simulate_tracking options and the drive-model variants so far
    tracking: TrackingResult | None = None
    diagnosis: dict[str, Any] | None = None
    tracking_options: dict[str, Any] = field(default_factory=dict)
    tracking_variants: dict[str, TrackingResult] = field(default_factory=dict)
    #: remedies of a failing design, measured and ranked (:mod:`armlab.study.remedies`)
    remedies: list[Any] = field(default_factory=list)
    #: export: the set-point table (None: it breaks a controller limit) and the sha256 of each
    #: file the stage wrote, by name
    setpoints: SetpointTable | None = None
    exported: dict[str, str] = field(default_factory=dict)
    #: each stage's record so far (the runner's own dict: the records are the one home of
    #: what failed)
    records: dict[str, StageRecord] = field(default_factory=dict)
    files: dict[str, str] = field(default_factory=dict)

    @property
    def failed_so_far(self) -> list[str]:
        """The failed checks of the stages recorded so far, in stage order."""
        return [f for rec in self.records.values() for f in rec.failed_checks]

    @property
    def rng(self) -> np.random.Generator:
        return np.random.default_rng(self.spec.study.seed)


def jsonable_block(obj) -> dict:
    if hasattr(obj, "to_dict"):
        return jsonable(obj.to_dict())
    if isinstance(obj, dict):
        return jsonable(obj)
    raise TypeError(f"{type(obj).__name__} has no to_dict()")


def jsonable(x):
    """Plain JSON values (numpy arrays/scalars to lists/floats; NaN/inf kept for the writer)."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path):
        return str(x)
    return x
