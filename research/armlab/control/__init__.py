"""Joint servo control: plant, cascaded PID tuning, discretisation, arm simulation, force loop.

Sources: HEU thesis, ch. 5 (DC-motor joint model, cascaded current/speed/position loops,
incremental PID, feed-forward 5.2) and Kong et al. 1998, §2.2 (outer force loop).

The modules of the package:

    gains       LoopGains / CascadeGains / ArmGains and their JSON (gains.json)
    plant       JointPlant: motor + reducer + reflected arm inertia range (min/nominal/max)
    loops       the three loops as python-control models, continuous and discrete; margins
    tuning      robust inside-out tuning (tune_cascade, tune_arm), check_cascade
    discrete    incremental PID with anti-windup, D/A and encoder quantisers
    simulate    closed-loop simulation of all joints on the nonlinear arm (Pinocchio ABA)
    force       Kong et al. 1998's outer force loop and its robustness study

(figures: armlab.plots.servo -- Bode, steps, root loci, tracking error, force responses)
"""

from armlab.control.force import ForceLoopResult, ForceRobustness, force_loop, force_robustness
from armlab.control.gains import ArmGains, CascadeGains, LoopGains
from armlab.control.loops import CascadeModel, Margins, margins
from armlab.control.plant import InertiaRange, JointPlant, inertia_range, joint_plant
from armlab.control.simulate import TrackingResult, simulate_tracking
from armlab.control.tuning import TuningSpec, check_cascade, tune_arm, tune_cascade

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
