"""Drive selection: for each joint, the lightest (or cheapest) motor + reducer of a catalogue
that passes every sizing check along the given trajectories.

Every motor x reducer combination of the catalogue is sized for every joint with the checks of
:func:`armlab.dynamics.checks.evaluate_checks` (vectorised: one column per combination), using
the joint's encoder, acceleration and jerk limits from the robot. The joint loads come from the
robot's model as it is: the link masses (which include the described drives, thesis table 4.1)
are **not** updated for the chosen parts — a lighter drive would also unload the joints inboard
of it, which this one-pass selection does not iterate.

Per joint the result names the chosen pair, its binding check (smallest margin) and the
runner-up; when no pair passes, the checks every pair fails (:meth:`JointSelection.why_none`,
:meth:`Selection.require`). A study selecting for an arm without drives sizes the planned
motion plus a hold at each joint's worst static pose (:func:`hold_trajectories`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from armlab._keywords import renamed_keywords
from armlab.dynamics.checks import (
    CHECK_NAMES,
    Check,
    Checked,
    SizingOptions,
    checks_for_column,
    evaluate_checks,
)
from armlab.dynamics.inverse import as_trajectories, inverse_dynamics
from armlab.dynamics.reducer_life import DEFAULT_REQUIRED_LIFE_H
from armlab.dynamics.sizing import joint_inertias_kg_m2, lever_arms_m
from armlab.dynamics.thermal import AMBIENT_DEGC, with_dwell
from armlab.errors import InfeasibleError, InputError
from armlab.robot.catalogue import Catalogue, load_catalogue
from armlab.robot.controller import ControllerProfile, load_profile
from armlab.robot.drives import Drive, Encoder, Motor, Reducer, available_torque_Nm
from armlab.robot.drivetrain import DriveTrain
from armlab.trajectory import Trajectory

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "Candidate",
    "JointSelection",
    "Selection",
    "select_drives",
    "hold_trajectories",
    "ASSUMED_ENCODER",
]

OBJECTIVES = ("mass", "price")

#: The encoder of a selected drive when the robot has none to keep: ASSUMED, the thesis'
#: 1000 pulses per motor revolution with x4 decoding (HEU thesis table 4.3 note). A selection
#: states it (:attr:`Selection.assumptions`); the drives file it writes can be edited.
ASSUMED_ENCODER = Encoder(pulses_per_rev=1000, decoding=4)


@dataclass
class Candidate(Checked):
    """One motor + reducer for one joint, with its checks (``drive``: the joint's drive they
    make, the one installed when this candidate is chosen)."""

    motor: Motor
    reducer: Reducer
    derating: float
    checks: list[Check]
    drive: Drive | None = None

    @property
    def mass_kg(self) -> float:
        return float(self.motor.mass_kg + self.reducer.mass_kg)

    @property
    def price(self) -> float:
        return float(self.motor.price + self.reducer.price)

    @property
    def available_torque_Nm(self) -> float:
        """The thesis rule (table 4.3) of this motor + reducer: :func:`available_torque_Nm`,
        the rule :attr:`Drive.available_torque_Nm` answers for a joint."""
        return available_torque_Nm(
            self.motor.stall_torque_Nm, self.reducer.ratio, self.reducer.efficiency, self.derating
        )

    def to_dict(self) -> dict:
        return {
            "motor": self.motor.model,
            "reducer": self.reducer.model,
            "ratio": float(self.reducer.ratio),
            "mass_kg": self.mass_kg if math.isfinite(self.mass_kg) else None,
            "price": self.price if math.isfinite(self.price) else None,
            "available_torque_Nm": self.available_torque_Nm,
            "ok": self.ok,
            "binding_check": self.binding.name,
            "binding_margin": float(self.binding.margin),
            "failing_checks": [c.name for c in self.checks if not c.ok],
            "checks": [c.to_dict() for c in self.checks],
        }


@dataclass
class JointSelection:
    """The choice for one joint.

    ``chosen`` is the best passing candidate (None if none passes); ``runner_up`` the next
    passing one by the same objective (None if only one passes); ``closest`` the candidate
    whose worst check fails least when none passes; ``current`` the robot's own drive under
    the same loads (with catalogue mass/price when the catalogue tags it as this joint's
    thesis part); ``n_candidates`` / ``n_passing`` count the combinations;
    ``failed_by_all`` names the checks every candidate fails (empty when one passes).
    """

    joint: str
    chosen: Candidate | None
    closest: Candidate | None
    current: Candidate | None
    n_candidates: int
    n_passing: int
    runner_up: Candidate | None = None
    failed_by_all: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        return self.chosen is not None

    def why_none(self) -> str:
        """One line: why no catalogue entry passes for this joint ("" if one does)."""
        if self.ok:
            return ""
        head = f"no catalogue entry passes for {self.joint}"
        if not self.n_candidates:
            return head + ": no motor + reducer pair is left to check (the study's "
            f"[drives.{self.joint}] names, or every pair was passed over by a later stage)"
        if self.failed_by_all:
            head += f": all {self.n_candidates} motor + reducer pairs fail " + ", ".join(
                self.failed_by_all
            )
        else:
            head += f": each of the {self.n_candidates} pairs fails some check"
        c = self.closest
        if c is not None:
            worst = c.binding
            head += f" (closest {c.motor.model} + {c.reducer.model}: {worst.describe()})"
        return head

    def to_dict(self) -> dict:
        return {
            "ok": self.ok,
            "chosen": None if self.chosen is None else self.chosen.to_dict(),
            "runner_up": None if self.runner_up is None else self.runner_up.to_dict(),
            "closest": None if self.closest is None else self.closest.to_dict(),
            "current": None if self.current is None else self.current.to_dict(),
            "n_candidates": self.n_candidates,
            "n_passing": self.n_passing,
            "failed_by_all": list(self.failed_by_all),
            "why_none": self.why_none() or None,
        }


@dataclass
class Selection:
    """Result of :func:`select_drives`."""

    robot_name: str
    payload_kg: float
    objective: str
    joints: list[JointSelection]
    currency: str = ""
    catalogue_path: str = ""
    assumptions: tuple[str, ...] = ()
    #: select -> limits -> plan rounds until the choice was stable (1: one pass, no re-plan)
    rounds: int = 1
    #: per joint, the candidates passed over after the sizing checks and why (one line each:
    #: a current loop that cannot be tuned, a tracking miss on the limiting joint)
    skipped: dict[str, list[str]] = field(default_factory=dict)
    #: what the later stages' loop decided besides (e.g. the best measured tracking kept)
    notes: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        return all(j.ok for j in self.joints)

    def require(self) -> Selection:
        """``self`` when every joint has a passing entry, else :class:`InfeasibleError` naming
        the first joint without one and the check every candidate fails."""
        for js in self.joints:
            if not js.ok:
                raise InfeasibleError(f"drive selection: {js.why_none()}")
        return self

    def joint(self, name) -> JointSelection:
        for j in self.joints:
            if j.joint == name:
                return j
        raise InputError(f"no joint {name!r} in the selection")

    def drives(self, robot: Robot) -> dict[str, Drive]:
        """The chosen drives as ``{joint: Drive}`` (for :func:`size`); the robot's own drive
        where nothing passed (:class:`InfeasibleError` naming the joint and the check every
        candidate fails when the robot has none)."""
        out = {}
        for j, js in enumerate(self.joints):
            if js.chosen is None:
                if robot.drives is None:
                    raise InfeasibleError(f"drive selection: {js.why_none()}")
                out[js.joint] = robot.drive(js.joint)
            elif js.chosen.drive is not None:
                out[js.joint] = js.chosen.drive
            else:
                out[js.joint] = _drive(
                    robot, j, js.chosen.motor, js.chosen.reducer, js.chosen.derating
                )
        return out

    def to_dict(self) -> dict:
        return {
            "objective": self.objective,
            "payload_kg": self.payload_kg,
            "currency": self.currency,
            "catalogue": self.catalogue_path,
            "assumptions": list(self.assumptions),
            "rounds": self.rounds,
            "skipped": {j: list(v) for j, v in self.skipped.items()},
            "notes": list(self.notes),
            "ok": self.ok,
            "joints": {j.joint: j.to_dict() for j in self.joints},
        }

    def to_markdown(self) -> str:
        cur = f" [{self.currency}]" if self.currency else ""
        lines = [
            f"### Drive selection ({self.robot_name}, payload {self.payload_kg:g} kg, "
            f"lightest by {self.objective})",
            "",
            f"{_rounds_text(self.rounds)} Link masses are those of the description (not "
            "updated for the chosen parts).",
            "",
            f"| joint | chosen motor + reducer | mass [kg] | price{cur} | available [N m] |"
            f" binding check (margin) | runner-up | passing | current parts: ok? mass [kg] |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for js in self.joints:
            c = js.chosen
            if c is None:
                near = js.closest
                text = (
                    "none passes"
                    if near is None
                    else f"none passes; closest {near.motor.model} + {near.reducer.model} "
                    f"fails {', '.join(x.name for x in near.checks if not x.ok)}"
                )
                row = f"| {js.joint} | {text} | - | - | - | - | - |"
            else:
                row = (
                    f"| {js.joint} | {c.motor.model} + {c.reducer.model} | {c.mass_kg:.3g} |"
                    f" {c.price:.0f} | {c.available_torque_Nm:.3g} | {c.binding.name} "
                    f"({100 * c.binding.margin:+.0f} %) | {_runner_up_text(js.runner_up)} |"
                )
            now = js.current
            if now is None:
                tail = "-"
            else:
                failing = [x.name for x in now.checks if not x.ok]
                mass = f"{now.mass_kg:.3g}" if math.isfinite(now.mass_kg) else "?"
                tail = ("pass" if not failing else "fails " + ", ".join(failing)) + f"; {mass}"
            lines.append(f"{row} {js.n_passing}/{js.n_candidates} | {tail} |")
        skipped = [f"- {j}: skipped {line}" for j, v in self.skipped.items() for line in v]
        if skipped:
            lines += ["", "Candidates passed over after the sizing checks:", *skipped]
        if self.notes:
            lines += ["", *(f"- {n}" for n in self.notes)]
        if self.assumptions:
            lines += ["", *(f"- ASSUMED: {a}" for a in self.assumptions)]
        return "\n".join(lines) + "\n"


def _rounds_text(rounds: int) -> str:
    if rounds <= 1:
        return "One pass (the plan was not re-made with the chosen drives' limits)."
    return (
        f"Stable after {rounds} select -> limits -> plan rounds: the chosen drives pass on the "
        "plan made with their own limits."
    )


def _runner_up_text(c: Candidate | None) -> str:
    if c is None:
        return "none"
    return f"{c.motor.model} + {c.reducer.model} ({c.mass_kg:.3g} kg; {c.binding.name})"


def hold_trajectories(robot: Robot, static) -> list[Trajectory]:
    """One single-sample trajectory per joint: the arm held still at that joint's worst static
    pose (:func:`armlab.dynamics.static_load`), standing for 1 s of holding each
    (:func:`armlab.trajectory.sampling.sample_weights`). Added to a planned motion, they make the
    duty cycle a selection must carry: the motion and the worst-case static load."""
    out = []
    for x in static.joints:
        q = np.asarray(x.pose_rad, float).reshape(1, -1)
        zero = np.zeros_like(q)
        out.append(Trajectory(np.zeros(1), q, zero, zero, method=f"hold ({x.joint} worst pose)"))
    return out


def _checked(
    drives: list[Drive], loads, columns: slice, lever_m, options, joint_inertia_kg_m2
) -> list[Candidate]:
    """Each drive as a :class:`Candidate` with its sizing checks on one joint's loads (and the
    arm's inertia at the joint along them, for the inertia ratio)."""
    if not drives:
        return []
    train = DriveTrain.from_drives(drives)
    results = evaluate_checks(
        loads.torque_Nm[:, columns],
        loads.qd[:, columns],
        loads.qdd[:, columns],
        loads.weights,
        train,
        lever_m,
        options,
        joint_inertia_kg_m2=joint_inertia_kg_m2,
    )
    return [
        Candidate(d.motor, d.reducer, d.derating, checks_for_column(results, c, drives=train), d)
        for c, d in enumerate(drives)
    ]


def _drive(robot, j: int, motor: Motor, reducer: Reducer, derating: float) -> Drive:
    name = robot.joint_names[j]
    lim = robot.limits
    encoder = robot.drives[name].encoder if robot.drives is not None else ASSUMED_ENCODER
    # unknown (NaN): derived from the drive train when the robot's limits are resolved
    acc = math.nan if lim.acceleration_rad_s2 is None else float(lim.acceleration_rad_s2[j])
    jerk = math.nan if lim.jerk_rad_s3 is None else float(lim.jerk_rad_s3[j])
    return Drive(
        joint=name,
        motor=motor,
        reducer=reducer,
        encoder=encoder,
        acceleration_rad_s2=acc,
        jerk_rad_s3=jerk,
        derating=derating,
    )


@renamed_keywords(options="controller= (and tool_resolution_m=)")
def select_drives(
    robot: Robot,
    trajectories,
    catalogue: Catalogue | str | os.PathLike | None = None,
    *,
    controller: ControllerProfile | str,
    objective: str = "mass",
    tool_resolution_m: float = SizingOptions.tool_resolution_m,
    dt: float | None = None,
    threads: int = 1,
    dwell_s: float = 0.0,
    cycles: int | None = None,
    ambient_degC: float = AMBIENT_DEGC,
    max_inertia_ratio: float = math.inf,
    allow_estimated: bool = False,
    required_life_h: float = DEFAULT_REQUIRED_LIFE_H,
    momentary_load: str = "plan",
    candidates: Mapping[str, Callable[[Drive], Drive | None]] | None = None,
) -> Selection:
    """Choose each joint's lightest (or cheapest) catalogue motor + reducer passing every check.

    Parameters
    ----------
    robot : Robot
        Payload included; its drives (if any) are evaluated too, as the "current" parts.
    trajectories : Trajectory or sequence of Trajectory
        The duty cycle the drives must carry (e.g. :func:`requirement_moves`).
    catalogue : Catalogue or path, optional
        Default: :func:`load_catalogue` ().
    controller : ControllerProfile or str
        The joint controller (:func:`armlab.robot.load_profile`): the encoder checks of
        :func:`size`.
    objective : {"mass", "price"}
        Sort key (the other one breaks ties).
    tool_resolution_m : float
        Largest tool-point displacement of one encoder count [m] (:class:`SizingOptions`).
    dt : float, optional
        Resample the trajectories on this grid [s] first.
    dwell_s, cycles, ambient_degC, max_inertia_ratio
        As :func:`~armlab.dynamics.size`: the winding-temperature and inertia-ratio checks.
    required_life_h, momentary_load
        As :func:`~armlab.dynamics.size`: the reducer life and momentary-torque checks.
    allow_estimated : bool
        Also combine parts with values not read from a published source
        (:meth:`Catalogue.combinations`; ``[sizing] allow_estimated``).
    candidates : mapping of joint name to callable, optional
        Per joint, a rule applied to each catalogue drive before it is checked: it returns the
        drive to check (changed, e.g. a study's ``[drives.<joint>]`` encoder or efficiency) or
        None to leave the pair out (another model named, a pair passed over by a later stage).

    Notes
    -----
    A part of an integrated servo (``integrated`` set on the motor or the reducer: motor, gear
    and controller in one) combines only with the other part of the same servo.

    Returns
    -------
    Selection
        Per joint: the chosen parts and the check that binds them (smallest margin), or, when
        nothing passes, the closest candidate and its failing checks.
    """
    if objective not in OBJECTIVES:
        raise InputError(f"objective must be one of {OBJECTIVES}, not {objective!r}")
    if not isinstance(catalogue, Catalogue):  # None or a path: read it
        catalogue = load_catalogue(catalogue)
    options = SizingOptions(
        load_profile(controller),
        tool_resolution_m,
        dwell_s=dwell_s,
        cycles=cycles,
        ambient_degC=ambient_degC,
        max_inertia_ratio=max_inertia_ratio,
        required_life_h=float(required_life_h),
        momentary_load=momentary_load,
    )
    trajs = as_trajectories(trajectories, robot)
    if dt is not None:
        trajs = [tr.sample(dt) for tr in trajs]
    trajs = with_dwell(trajs, options.dwell_s)
    loads = inverse_dynamics(robot, trajs, threads=threads)
    inertias = joint_inertias_kg_m2(robot, loads.q)
    levers = lever_arms_m(robot)
    combos = catalogue.combinations(allow_estimated)
    rules = candidates or {}

    def key(c: Candidate):
        a, b = (c.mass_kg, c.price) if objective == "mass" else (c.price, c.mass_kg)
        return (a, b, c.motor.model, c.reducer.model)

    joints = []
    for j, name in enumerate(robot.joint_names):
        drives = [_drive(robot, j, m, r, catalogue.derating.get(m.model, 1.0)) for m, r in combos]
        rule = rules.get(name)
        if rule is not None:
            drives = [d for d in map(rule, drives) if d is not None]
        columns = slice(j, j + 1)
        cands = _checked(drives, loads, columns, levers[j], options, inertias[:, columns])
        passing = sorted((c for c in cands if c.ok), key=key)
        closest = max(cands, key=lambda c: c.binding.margin) if cands and not passing else None
        failed_by_all: tuple[str, ...] = ()
        if cands and not passing:  # the checks no candidate passes (a check a part has no
            # rating for: not failed)
            failing = [{ch.name for ch in c.checks if not ch.ok} for c in cands]
            failed_by_all = tuple(n for n in CHECK_NAMES if all(n in f for f in failing))
        current = None
        if robot.drives is not None:
            d = robot.drives[name]
            own = DriveTrain.from_drives([d])
            res = evaluate_checks(
                loads.torque_Nm[:, columns],
                loads.qd[:, columns],
                loads.qdd[:, columns],
                loads.weights,
                own,
                levers[j],
                options,
                joint_inertia_kg_m2=inertias[:, columns],
            )
            motor, reducer = d.motor, d.reducer
            tagged = catalogue.thesis_parts.get(name)
            if tagged and tagged[0] and tagged[1]:  # catalogue mass and price of the same parts
                cm, cr = catalogue.motor(tagged[0]), catalogue.reducer(tagged[1])
                if math.isclose(cr.ratio, reducer.ratio) and math.isclose(
                    cm.stall_torque_Nm, motor.stall_torque_Nm
                ):
                    motor = replace(motor, mass_kg=cm.mass_kg, price=cm.price)
                    reducer = replace(reducer, mass_kg=cr.mass_kg, price=cr.price)
            current = Candidate(motor, reducer, d.derating, checks_for_column(res, 0, drives=own))
        joints.append(
            JointSelection(
                joint=name,
                chosen=passing[0] if passing else None,
                closest=closest,
                current=current,
                n_candidates=len(cands),
                n_passing=len(passing),
                runner_up=passing[1] if len(passing) > 1 else None,
                failed_by_all=failed_by_all,
            )
        )
    assumptions = []
    if robot.drives is None:
        assumptions.append(
            f"encoder {ASSUMED_ENCODER.pulses_per_rev} pulses/rev x{ASSUMED_ENCODER.decoding} "
            "decoding on every motor (the thesis' encoder; the robot has none to keep)"
        )
    return Selection(
        robot_name=robot.name,
        payload_kg=float(robot.payload.mass_kg),
        objective=objective,
        joints=joints,
        currency=catalogue.currency,
        catalogue_path=catalogue.path,
        assumptions=tuple(assumptions),
    )
