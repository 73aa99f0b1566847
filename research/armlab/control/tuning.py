"""Robust inside-out tuning of a joint cascade (current PI -> speed PI -> position P).

:func:`tune_cascade` builds the joint's tuning plant (:func:`~armlab.control.plant.joint_plant`:
the drive at the motor shaft with its min/nominal/max inertia), tunes the three loops robustly
over that range
(:mod:`armlab.control.robust`), recomputes every figure on a finer grid
(:func:`armlab.control.check.check_cascade`) and refuses a result that misses the spec
(:class:`armlab.control.spec.TuningSpec`). :func:`tune_arm` does it for every joint with one
inertia-range computation.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from armlab.control.check import check_cascade
from armlab.control.gains import ArmGains, CascadeGains, PlantSummary
from armlab.control.plant import InertiaRange, inertia_range, joint_plant
from armlab.control.robust import tune_loops
from armlab.control.spec import TuningSpec, controller_spec
from armlab.errors import ArmlabError, SpecError
from armlab.robot.controller import ControllerProfile, load_profile

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["TuningSpec", "tune_cascade", "tune_arm", "check_cascade"]


def tuning_inertias(robot: Robot, sp: TuningSpec) -> InertiaRange:
    """The arm's inertia range the tuning holds over: the one call that computes it
    (``sp.n_inertia_samples`` workspace samples, ``sp.seed``)."""
    return inertia_range(robot, n_samples=sp.n_inertia_samples, seed=sp.seed)


def tune_cascade(
    robot: Robot, joint, *, inertias: InertiaRange | None = None, n_grid: int = 600, **spec
) -> CascadeGains:
    """Tune one joint's current, speed and position loops, robust over its inertia range.

    Parameters
    ----------
    robot : Robot
        With drives (drives.toml).
    joint : str or int
        Joint name or 1-based number.
    inertias : InertiaRange, optional
        Precomputed :func:`tuning_inertias` (shared by :func:`tune_arm`).
    n_grid : int
        Frequency points of the search (the final check uses 1500).
    **spec
        Fields of :class:`TuningSpec` (``position_bandwidth_rad_s``, ``phase_margin_deg``, ...).

    Returns
    -------
    CascadeGains
        Gains with their checked figures (worst case over min/nominal/max inertia, continuous
        and discrete) and the plant summary.

    Raises
    ------
    SpecError
        Invalid or impossible spec, or missing motor data; the message names joint and spec.
    """
    name = robot.joint_names[robot.joint_index(joint)]
    sp = TuningSpec.from_kwargs(name, **spec)
    if inertias is None:
        inertias = tuning_inertias(robot, sp)
    base = joint_plant(robot, name, inertias=inertias)  # the drive: current limit, inertias
    if sp.compliant:  # the two-mass joint where the reducer gives its stiffness
        base = replace(base, compliant=True)
    try:
        cur, spd, pos = tune_loops(base, sp, n_grid)
    except ArmlabError:
        raise
    except (np.linalg.LinAlgError, ValueError, ZeroDivisionError) as e:
        raise SpecError(f"{name}: tuning failed numerically ({e})") from None
    summary = PlantSummary(**base.summary())
    g = CascadeGains(
        joint=name, current=cur, speed=spd, position=pos, plant=summary, spec=sp.to_dict()
    )
    g = check_cascade(base, g)
    _assert_meets(g, sp)
    return g


def _assert_meets(g: CascadeGains, sp: TuningSpec) -> None:
    for name, lg in g.loops().items():
        for sfx in ("", "_discrete"):
            pm = getattr(lg, f"phase_margin{sfx}_deg")
            gm = getattr(lg, f"gain_margin{sfx}_dB")
            if pm < sp.phase_margin_deg - 1e-6 or gm < sp.gain_margin_dB - 1e-6:
                raise SpecError(
                    f"{g.joint}: the {name} loop ends at phase margin {pm:.3g} deg, "
                    f"gain margin {gm:.3g} dB ({'discrete' if sfx else 'continuous'}"
                    f") < spec phase_margin_deg={sp.phase_margin_deg}, "
                    f"gain_margin_dB={sp.gain_margin_dB}"
                )
        for row in lg.robustness:
            if not (row["stable"] and row["stable_discrete"]):
                raise SpecError(
                    f"{g.joint}: the {name} loop is unstable at the {row['label']} inertia"
                )
        if sp.inner_overshoot_pct is not None and name != "position":
            os_ = max(lg.overshoot_pct, lg.overshoot_discrete_pct)
            if os_ > sp.inner_overshoot_pct:
                raise SpecError(
                    f"{g.joint}: spec inner_overshoot_pct={sp.inner_overshoot_pct} "
                    f"not met by the {name} loop ({os_:.3g} %)"
                )


def tune_arm(
    robot: Robot,
    *,
    controller: ControllerProfile | str,
    known: Mapping[str, CascadeGains] | None = None,
    **spec,
) -> ArmGains:
    """:func:`tune_cascade` for every joint (one inertia-range computation shared).

    Parameters
    ----------
    robot : Robot
    controller : ControllerProfile or str
        The joint controller (:func:`armlab.robot.load_profile`): its servo period is the speed
        and position loops' sample time and its D/A range and bits are the speed loop's output
        (:func:`controller_spec`).
    known : mapping of joint name to CascadeGains, optional
        Joints already tuned by :func:`tune_cascade` for this robot's drive, with this
        controller's spec and the same inertia samples (a drive selection that tuned its
        candidates): kept, not tuned again.
    **spec
        Fields of :class:`TuningSpec`.

    Returns
    -------
    ArmGains
        ``.joints[name]`` in joint order; ``to_json()`` is a study's ``gains.json``.
    """
    spec = controller_spec(load_profile(controller), spec)
    sp = TuningSpec.from_kwargs("", **spec)
    inertias = tuning_inertias(robot, sp)
    known = known or {}
    joints = {
        name: known[name] if name in known else tune_cascade(robot, name, inertias=inertias, **spec)
        for name in robot.joint_names
    }
    return ArmGains(joints=joints, robot=robot.name, spec=sp.to_dict())
