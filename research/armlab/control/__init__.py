"""Joint servo control: plant, cascaded PID tuning, discretisation, arm simulation, force loop.

Sources: HEU thesis, ch. 5 (DC-motor joint model, cascaded current/speed/position loops,
incremental PID, feed-forward 5.2) and Kong et al. 1998, §2.2 (outer force loop).

The modules of the package:

    gains       LoopGains / CascadeGains / ArmGains and their JSON (gains.json)
    plant       JointPlant: motor + reducer + reflected arm inertia range (min/nominal/max)
    lti         small state-space systems as numpy matrices (series, feedback, ZOH)
    loops       CascadeModel: the three loops, continuous and discrete, over the inertia cases
    margins     phase and gain margins from a sampled frequency response
    steps       step-response overshoot and settling time
    spec        TuningSpec: what the tuned cascade must meet
    robust      the per-loop searches robust over the inertia range
    check       check_cascade: every loop's figures over the inertia range
    tuning      tune_cascade, tune_arm
    discrete    incremental PID with anti-windup, D/A and encoder quantisers
    simulate    closed-loop simulation of all joints on the nonlinear arm (Pinocchio ABA)
    force       Kong et al. 1998's outer force loop and its robustness study

(figures: armlab.plots.servo -- Bode, steps, root loci, tracking error, force responses)
"""

from armlab.control.check import check_cascade
from armlab.control.force import ForceLoopResult, ForceRobustness, force_loop, force_robustness
from armlab.control.gains import ArmGains, CascadeGains, LoopGains
from armlab.control.loops import CascadeModel
from armlab.control.margins import Margins, margins
from armlab.control.plant import InertiaRange, JointPlant, inertia_range, joint_plant
from armlab.control.result import TrackingResult
from armlab.control.simulate import simulate_tracking
from armlab.control.spec import TuningSpec
from armlab.control.tuning import tune_arm, tune_cascade

__all__ = [
    "ArmGains",
    "CascadeGains",
    "CascadeModel",
    "ForceLoopResult",
    "ForceRobustness",
    "InertiaRange",
    "JointPlant",
    "LoopGains",
    "Margins",
    "TrackingResult",
    "TuningSpec",
    "check_cascade",
    "force_loop",
    "force_robustness",
    "inertia_range",
    "joint_plant",
    "margins",
    "simulate_tracking",
    "tune_arm",
    "tune_cascade",
]
