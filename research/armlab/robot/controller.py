"""Controller profiles: what the real controller accepts (a small TOML file each).

The default profile, ``reference_dda``, is the controller of the SHU controller paper (§1): an
industrial PC with two 3-axis position cards, DDA interpolation period settable from 1 ms to
2 s, at most 4095 pulses per axis per DDA period, quadrature counting with x2 or x4 decoding,
1 ms servo update, 12-bit +-10 V D/A. ``ethercat_cia402_csp`` is an EtherCAT master with CiA 402
drives in cyclic synchronous position mode (no pulse limit; home positions and modulo axes for
the CiA 402 export, :mod:`armlab.deploy.cia402`). ``dda_n_axis`` is the reference controller's
cards for any number of axes (a 7-axis arm); ``generic_1khz`` a generic 1 kHz position
interface, also without an axis count. Profiles live in
``armlab/data/profiles/<name>.toml``; any other TOML file with the same keys can be given by path.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import InputError
from armlab.names import check_name
from armlab.robot.drives_file import value_problem
from armlab.tomlfile import read_toml

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["ControllerProfile", "DEFAULT_PROFILE", "load_profile", "list_profiles", "profiles_dir"]

DEFAULT_PROFILE = "reference_dda"

#: The hint of an axis-count mismatch: the profiles that drive any number of axes.
_OTHER_AXIS_COUNT = (
    " (for another axis count: [controller] profile = dda_n_axis or generic_1khz, which take "
    "the robot's joint order)"
)


#: Rule of each numeric field (:func:`armlab.robot.drives_file.value_problem`: "pos" finite > 0,
#: "nonneg" finite >= 0, "count" a positive integer, "decoding" 1, 2 or 4).
_RULES = {
    "max_pulses_per_cycle": "count",
    "decoding": "decoding",
    "servo_period_s": "pos",
    "max_axes": "count",
    "dac_bits": "count",
    "dac_range_V": "pos",
    "start_tolerance_counts": "nonneg",
    "speed_tolerance": "nonneg",
    "continuity_tolerance": "nonneg",
}
_OPTIONAL = ("max_pulses_per_cycle", "decoding", "max_axes")
#: Upper bounds: a tolerance is slack for round-off, not a way to switch a check off.
_MAX = {
    "dac_bits": 32,
    "servo_period_s": 2.0,
    "start_tolerance_counts": 100.0,
    "speed_tolerance": 0.01,
    "continuity_tolerance": 0.5,
}
_MAX_WHY = {
    "dac_bits": "a D/A converter's resolution",
    "servo_period_s": "the slowest controller period armlab knows, SHU controller paper",
    "start_tolerance_counts": "the start pose, in counts: a larger offset is a jump, not round-off",
    "speed_tolerance": "1 % relative slack; to allow more speed, raise the limit itself",
    "continuity_tolerance": "50 % relative slack on the velocity change per cycle",
}


def profiles_dir() -> Path:
    """Folder of the built-in profiles (``armlab/data/profiles``)."""
    return Path(__file__).resolve().parents[1] / "data" / "profiles"


def list_profiles() -> list[str]:
    """Names of the built-in profiles."""
    return sorted(p.stem for p in profiles_dir().glob("*.toml"))


@dataclass(frozen=True)
class ControllerProfile:
    """What one real controller accepts.

    Attributes
    ----------
    name, description, source : str
    cycle_s : float
        Controller (DDA interpolation) period in [s]: one set-point row per cycle.
    cycle_range_s : (float, float)
        Periods the controller accepts in [s] (SHU controller paper: 1 ms .. 2 s).
    max_pulses_per_cycle : int or None
        Most position-command pulses (= encoder counts) per axis per cycle (SHU controller
        paper: 4095); None for no limit.
    decoding : int or None
        Counter decoding of the quadrature encoder (x2 or x4 on the SHU controller paper's
        card); None keeps the robot's ``drives.toml`` value.
    counts_per_joint_rev : tuple of float or None
        Counts per joint revolution per axis (axis order); overrides the drives (needed for a
        robot without ``drives.toml``).
    servo_period_s : float
        Servo update period in [s] (sample time of the card's position/speed loops).
    max_axes : int or None
        Axes the controller drives (SHU controller paper: 2 cards x 3).
    axis_order : tuple of (str or int) or None
        Joint driven by controller axis 1, 2, ... (joint names or 1-based joint numbers);
        None: the robot's joint order.
    axis_sign : tuple of int or None
        +1 or -1 per axis: counts = round(q x counts_per_rad x sign); None: all +1.
    dac_bits, dac_range_V : int, float
        D/A resolution and range (+-dac_range_V).
    start_tolerance_counts : float
        Largest allowed difference in [counts] between the first set-point and the current pose
        (0 .. 100).
    speed_tolerance : float
        Relative slack on the joint speed limits (planner round-off), e.g. 1e-6 (0 .. 0.01).
    continuity_tolerance : float
        Relative slack on the continuity check (velocity change per cycle <= a_max x cycle;
        0 .. 0.5).

    Every value is checked by its meaning when the profile is made (:class:`InputError`, one
    line naming the key): ``decoding`` 1, 2 or 4 and ``max_pulses_per_cycle``, ``max_axes``,
    ``dac_bits`` (<= 32) positive integers, with the drives file's validator
    (:func:`armlab.robot.drives_file.value_problem`: no truncation of ``1.5``); periods, ranges and
    ``dac_range_V`` finite and > 0 (``servo_period_s`` <= 2 s); tolerances finite, >= 0 and at
    most the bounds above (a tolerance is slack for round-off: ``1e300`` would switch the
    pre-flight off); ``name`` keeps the name policy (:mod:`armlab.names`).
    home_position_rad : tuple of float or None
        Joint angle in [rad] of each axis' homing reference (axis order; None: all at the
        joint zero). The CiA 402 export turns it into the home offset (object 0x607C).
    modulo_axes : tuple of (str or int) or None
        Axes the drive runs as modulo (rotary) axes, by joint name or 1-based joint number: the
        CiA 402 export wraps their target positions into one joint revolution (position range
        limit 0x607B). None: no modulo axes.
    """

    name: str
    description: str = ""
    source: str = ""
    cycle_s: float = 1e-3
    cycle_range_s: tuple[float, float] = (1e-3, 2.0)
    max_pulses_per_cycle: int | None = None
    decoding: int | None = None
    counts_per_joint_rev: tuple[float, ...] | None = None
    servo_period_s: float = 1e-3
    max_axes: int | None = None
    axis_order: tuple[str | int, ...] | None = None
    axis_sign: tuple[int, ...] | None = None
    dac_bits: int = 12
    dac_range_V: float = 10.0
    start_tolerance_counts: float = 1.0
    speed_tolerance: float = 1e-6
    continuity_tolerance: float = 0.05
    home_position_rad: tuple[float, ...] | None = None
    modulo_axes: tuple[str | int, ...] | None = None

    def __post_init__(self) -> None:
        check_name(self.name, "name", "controller profile", InputError)
        where = f"controller profile {self.name!r}"
        lo, hi = (float(x) for x in self.cycle_range_s)
        object.__setattr__(self, "cycle_range_s", (lo, hi))
        if not (0 < lo <= hi and math.isfinite(hi)):
            raise InputError(f"{where}: cycle_range_s must be 0 < min <= max, got {(lo, hi)}")
        c = float(self.cycle_s)
        if not (math.isfinite(c) and lo * (1 - 1e-12) <= c <= hi * (1 + 1e-12)):
            raise InputError(
                f"{where}: cycle_s {self.cycle_s!r} s is outside the controller's "
                f"range {lo:g} .. {hi:g} s"
            )
        object.__setattr__(self, "cycle_s", c)
        # values by meaning, with the drives file's validator (drives_file.value_problem)
        for key, rule in _RULES.items():
            v = getattr(self, key)
            if isinstance(v, np.integer):
                v = int(v)
                object.__setattr__(self, key, v)
            if v is None and key in _OPTIONAL:
                continue
            problem = value_problem(v, rule)
            if problem is None and key in _MAX and v > _MAX[key]:
                problem = f"is above {_MAX[key]:g} ({_MAX_WHY[key]})"
            if problem is not None:
                raise InputError(f"{where}: {key} {v!r} {problem}")
        for key in (
            "axis_order",
            "axis_sign",
            "counts_per_joint_rev",
            "home_position_rad",
            "modulo_axes",
        ):
            v = getattr(self, key)
            if v is not None:
                object.__setattr__(self, key, tuple(v))
        if self.home_position_rad is not None and not all(
            isinstance(x, (int, float)) and math.isfinite(x) for x in self.home_position_rad
        ):
            raise InputError(f"{where}: home_position_rad must be finite numbers [rad]")
        if self.modulo_axes is not None and len(set(self.modulo_axes)) != len(self.modulo_axes):
            raise InputError(f"{where}: modulo_axes repeats a joint: {self.modulo_axes}")
        if self.axis_sign is not None and any(s not in (1, -1) for s in self.axis_sign):
            raise InputError(f"{where}: axis_sign entries must be +1 or -1, got {self.axis_sign}")
        if self.counts_per_joint_rev is not None and not all(
            math.isfinite(x) and x > 0 for x in self.counts_per_joint_rev
        ):
            raise InputError(f"{where}: counts_per_joint_rev must be positive numbers")
        if self.axis_order is not None and len(set(self.axis_order)) != len(self.axis_order):
            raise InputError(f"{where}: axis_order repeats a joint: {self.axis_order}")

    # ------------------------------------------------------------------ derived
    @property
    def dac_volts_per_lsb(self) -> float:
        """One D/A step in [V]: 2 x range / 2^bits."""
        return 2.0 * self.dac_range_V / 2**self.dac_bits

    def with_cycle(self, cycle_s: float) -> ControllerProfile:
        """A copy with another controller period [s] (checked against ``cycle_range_s``)."""
        return replace(self, cycle_s=cycle_s)

    def replace(self, **changes) -> ControllerProfile:
        """A copy with some fields replaced (validated again)."""
        return replace(self, **changes)

    def axes(self, robot: Robot) -> tuple[np.ndarray, np.ndarray]:
        """(joint index per axis, sign per axis) for ``robot``, both ``(n_axes,)``.

        Raises
        ------
        InputError
            Unknown joint in ``axis_order``, a sign list of the wrong length, or more joints
            than the controller has axes.
        """
        where = f"controller profile {self.name!r}"
        if self.axis_order is None:
            index = np.arange(robot.n_joints)
        else:
            index = np.array([robot.joint_index(j) for j in self.axis_order], dtype=int)
            if len(index) != robot.n_joints:
                raise InputError(
                    f"{where}: axis_order names {len(index)} joints, robot "
                    f"{robot.name} has {robot.n_joints}{_OTHER_AXIS_COUNT}"
                )
        if self.max_axes is not None and len(index) > self.max_axes:
            raise InputError(
                f"{where}: the controller drives {self.max_axes} axes, robot "
                f"{robot.name} has {len(index)} joints{_OTHER_AXIS_COUNT}"
            )
        if self.axis_sign is None:
            sign = np.ones(len(index), dtype=np.int64)
        else:
            if len(self.axis_sign) != len(index):
                raise InputError(
                    f"{where}: axis_sign has {len(self.axis_sign)} entries for {len(index)} axes"
                )
            sign = np.asarray(self.axis_sign, dtype=np.int64)
        return index, sign

    def counts_per_rad(self, robot: Robot, index: np.ndarray | None = None) -> np.ndarray:
        """Encoder counts per joint radian of each controller axis, ``(n_axes,)``.

        ``pulses_per_rev x decoding x ratio / (2 pi)`` from the robot's drive train, with this
        profile's decoding if it sets one; or this profile's ``counts_per_joint_rev / (2 pi)``.
        The set-point table and the sizing's encoder checks both read this one function.

        Parameters
        ----------
        robot : Robot
        index : array of int, optional
            Joint index of each axis (:meth:`axes`); default the robot's joint order.

        Raises
        ------
        InputError
            The robot has no drives and the profile gives no counts.
        """
        if index is None:
            index = np.arange(robot.n_joints)
        if self.counts_per_joint_rev is not None:
            if len(self.counts_per_joint_rev) != len(index):
                raise InputError(
                    f"controller profile {self.name!r}: counts_per_joint_rev has "
                    f"{len(self.counts_per_joint_rev)} entries for {len(index)} axes"
                )
            return np.asarray(self.counts_per_joint_rev, dtype=float) / (2.0 * math.pi)
        if robot.drives is None:
            raise InputError(
                f"robot {robot.name} has no drive train (drives.toml): the controller profile "
                "must give counts_per_joint_rev"
            )
        drives = robot.drives
        return np.array(
            [drives[robot.joint_names[i]].counts_per_rad(self.decoding) for i in index],
            dtype=float,
        )

    def sendable_velocity_rad_s(self, robot: Robot, velocity_rad_s) -> np.ndarray:
        """The joint speed limits a plan may use so that the table's rounded counts keep
        ``velocity_rad_s``, ``(n_joints,)`` in the robot's joint order.

        The controller receives whole counts per cycle: a plan moving ``d`` counts in a cycle
        is sent ``floor(d)`` or ``ceil(d)`` counts, so a plan at the limit ``v`` can be sent
        ``ceil(v x counts_per_rad x T)`` counts, over it (issue 24: 45 counts per 1 ms are
        0.5655 rad/s against 0.56). A plan at most ``C - 0.01`` counts per cycle, ``C =
        floor(v x counts_per_rad x T)`` the whole counts within the limit, is always sent at
        most ``C``: the speed returned is ``(C - 0.01) / (counts_per_rad x T)`` (0.01 count of
        margin for the planners' round-off). A joint with ``C < 1`` (a limit below one count
        per cycle) keeps ``v``: no plan can move it within the limit in whole counts, and the
        pre-flight says so.

        Parameters
        ----------
        robot : Robot
        velocity_rad_s : array (n_joints,)
            The speed limits in [rad/s] (robot joint order), e.g. ``robot.limits.velocity_rad_s``.

        Raises
        ------
        InputError
            As :meth:`counts_per_rad` (no drives and no ``counts_per_joint_rev``) or
            :meth:`axes`.
        """
        v = np.array(velocity_rad_s, dtype=float)
        index, _ = self.axes(robot)
        per_cycle = self.counts_per_rad(robot, index) * self.cycle_s  # counts per (rad/s)
        whole = np.floor(v[index] * per_cycle)
        ok = np.isfinite(whole) & (whole >= 1)
        v[index] = np.where(ok, (whole - 0.01) / per_cycle, v[index])
        return v

    def robot_for_planning(self, robot: Robot) -> Robot:
        """``robot`` with the speed limits :meth:`sendable_velocity_rad_s` (a copy; ``robot``
        itself if nothing changes, or if it has no speed limit or no counts): plan with it, and
        the set-point table of the plan for this controller keeps the robot's own limits after
        rounding (``setpoint_table(robot, optimal(profile.robot_for_planning(robot), q),
        profile)``)."""
        v = robot.limits.velocity_rad_s
        if v is None or (robot.drives is None and self.counts_per_joint_rev is None):
            return robot
        sendable = self.sendable_velocity_rad_s(robot, v)
        if np.array_equal(sendable, v):
            return robot
        return robot.with_limits(velocity_rad_s=sendable)

    def home_positions_rad(self, n_axes: int) -> np.ndarray:
        """Joint angle of each axis' homing reference in [rad], ``(n_axes,)`` (zeros if unset).

        Raises
        ------
        InputError
            ``home_position_rad`` has another length than the controller's axes.
        """
        if self.home_position_rad is None:
            return np.zeros(n_axes)
        if len(self.home_position_rad) != n_axes:
            raise InputError(
                f"controller profile {self.name!r}: home_position_rad has "
                f"{len(self.home_position_rad)} entries for {n_axes} axes"
            )
        return np.asarray(self.home_position_rad, dtype=float)

    def modulo_mask(self, robot: Robot, index: np.ndarray | None = None) -> np.ndarray:
        """True for each controller axis the drive runs as a modulo axis, ``(n_axes,)`` bool.

        Parameters
        ----------
        robot : Robot
        index : array of int, optional
            Joint index of each axis (:meth:`axes`); default the robot's joint order.

        Raises
        ------
        InputError
            A joint of ``modulo_axes`` the robot does not have.
        """
        if index is None:
            index = np.arange(robot.n_joints)
        if self.modulo_axes is None:
            return np.zeros(len(index), dtype=bool)
        joints = {robot.joint_index(j) for j in self.modulo_axes}
        return np.array([int(i) in joints for i in index], dtype=bool)

    def to_dict(self) -> dict:
        """JSON-able dict of every field (tuples as lists)."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


def _profile_path(name_or_path: str | Path) -> Path:
    s = str(name_or_path)
    path = Path(s)
    if path.suffix.lower() == ".toml" or "/" in s or "\\" in s:
        if not path.is_file():
            raise InputError(f"controller profile file {path} not found")
        return path
    path = profiles_dir() / f"{s}.toml"
    if not path.is_file():
        raise InputError(
            f"unknown controller profile {s!r} (built-in: "
            f"{', '.join(list_profiles())}; or give a .toml path)"
        )
    return path


def load_profile(name_or_path: str | Path | ControllerProfile | None = None) -> ControllerProfile:
    """Load a controller profile by built-in name or TOML path.

    Parameters
    ----------
    name_or_path : str, path, ControllerProfile or None
        None: the reference controller of the SHU controller paper (``reference_dda``). A
        profile object is returned as is.

    Raises
    ------
    InputError
        Unknown name, missing file, invalid TOML, unknown or invalid keys.
    """
    if isinstance(name_or_path, ControllerProfile):
        return name_or_path
    path = _profile_path(DEFAULT_PROFILE if name_or_path is None else name_or_path)
    data = read_toml(path, "controller profile", InputError, prefix="controller profile ")
    known = {f.name for f in fields(ControllerProfile)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise InputError(f"controller profile {path}: unknown key(s) {unknown}")
    data.setdefault("name", path.stem)
    try:
        return ControllerProfile(**data)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise InputError(f"{exc} ({path})") from None
        raise InputError(f"controller profile {path}: {exc}") from None
