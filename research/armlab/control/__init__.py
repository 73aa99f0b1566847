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

from armlab.control.discrete import IncrementalPID, quantise_da, quantise_encoder
from armlab.control.force import (
    SEED_DESIGNS,
    ForceLoopResult,
    ForceRobustness,
    force_loop,
    force_loop_model,
    force_robustness,
)
from armlab.control.gains import (
    GAINS_FORMAT,
    LOOP_UNITS,
    LOOPS,
    ArmGains,
    CascadeGains,
    LoopGains,
    PlantSummary,
    incremental_coefficients,
)
from armlab.control.loops import CascadeModel, Margins, margins
from armlab.control.plant import (
    INERTIA_CASES,
    InertiaRange,
    JointPlant,
    inertia_range,
    joint_plant,
    motor_speed_tf,
)
from armlab.control.simulate import (
    FEEDFORWARDS,
    POSITIONING_ACCURACY_M,
    SERVO_SHARE,
    TrackingResult,
    simulate_tracking,
)
from armlab.control.tuning import TuningSpec, check_cascade, tune_arm, tune_cascade

__all__ = [
    "GAINS_FORMAT",
    "LOOP_UNITS",
    "LOOPS",
    "ArmGains",
    "CascadeGains",
    "LoopGains",
    "PlantSummary",
    "incremental_coefficients",
    "INERTIA_CASES",
    "InertiaRange",
    "JointPlant",
    "inertia_range",
    "joint_plant",
    "motor_speed_tf",
    "CascadeModel",
    "Margins",
    "margins",
    "TuningSpec",
    "tune_cascade",
    "tune_arm",
    "check_cascade",
    "IncrementalPID",
    "quantise_da",
    "quantise_encoder",
    "FEEDFORWARDS",
    "POSITIONING_ACCURACY_M",
    "SERVO_SHARE",
    "TrackingResult",
    "simulate_tracking",
    "SEED_DESIGNS",
    "ForceLoopResult",
    "ForceRobustness",
    "force_loop",
    "force_loop_model",
    "force_robustness",
]
