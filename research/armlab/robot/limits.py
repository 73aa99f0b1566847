"""Joint limits: the one :class:`Limits` type and the one resolver, :func:`resolve_limits`.

Every limit a planner, a checker, the limit report or the set-point pre-flight uses is a
:class:`Limits`; every :class:`Limits` that is not the description's own comes out of
:func:`resolve_limits`, which applies these layers in order (each optional):

1. **description** (:func:`description_limits`): the URDF's joint range, ``<limit velocity>`` and
   ``<limit effort>``; a URDF holds no acceleration or jerk limit.
2. **drive train** (``drives.toml``): velocity = min(URDF velocity, motor speed limit / ratio,
   reducer max input speed / ratio) -- the motor speed limit is the one the sizing check
   ``motor_speed`` uses (:attr:`Motor.speed_limit_rad_s <armlab.robot.drives.Motor>`: the rated
   table speed, else the no-load speed ``U / Ke``), so that a plan inside the limits passes the
   motor- and reducer-speed checks; acceleration and jerk from drives.toml; torque = the
   available torque (stall x ratio x efficiency x derating, thesis table 4.3) in place of the
   URDF effort. A drive that gives no acceleration or jerk (``NaN``: left out of the drives
   file) has them **derived** after layer 3 when the study gives none either
   (:func:`drive_train_limits`: peak torque, reflected and link inertia; the source says so).
3. **study overrides** (``[limits]`` of a study: ``velocity_rad_s``, ``acceleration_rad_s2``,
   ``jerk_rad_s3``, ``effort_Nm``): may only *tighten* a limit the hardware gives; a value above
   it is a :class:`~armlab.SpecError` naming the key, the joint and the hardware limit. Where the
   hardware gives none (a plain URDF's acceleration), the override supplies it.
4. **speed scale** ``s`` in (0, 1]: velocity x s, acceleration x s^2, jerk x s^3 (the same motion
   slowed down in time by 1 / s).
5. **per-call keywords** of the planners, ``v_max, a_max, j_max, tau_max``: ``None`` keeps the
   limit resolved so far (the robot's), ``False`` switches that kind off, a number or a
   ``(n_joints,)`` array replaces it (all ``inf`` is off too; not checked against the
   hardware: the request states its own limits). A planner names the kinds it
   ``need``-s; any of them missing is reported at once (:meth:`Limits.require`).

``Limits.sources`` says, per kind and joint, where each value came from.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from armlab.errors import InputError, SpecError

__all__ = [
    "Limits",
    "LIMIT_KEYS",
    "description_limits",
    "resolve_limits",
    "drive_train_limits",
]

#: kind -> (field, unit, planner keyword, study key of ``[limits]``)
LIMIT_KEYS: dict[str, tuple[str, str, str, str]] = {
    "velocity": ("velocity_rad_s", "rad/s", "v_max", "velocity_rad_s"),
    "acceleration": ("acceleration_rad_s2", "rad/s^2", "a_max", "acceleration_rad_s2"),
    "jerk": ("jerk_rad_s3", "rad/s^3", "j_max", "jerk_rad_s3"),
    "torque": ("torque_Nm", "N m", "tau_max", "effort_Nm"),
}
_FIELD_KIND = {v[0]: k for k, v in LIMIT_KEYS.items()}
_STUDY_KIND = {v[3]: k for k, v in LIMIT_KEYS.items()}
_SOURCE_KINDS = ("position",) + tuple(LIMIT_KEYS)

SRC_URDF_RANGE = "urdf <limit lower/upper>"
SRC_URDF_VELOCITY = "urdf <limit velocity>"
SRC_URDF_EFFORT = "urdf <limit effort>"
SRC_MOTOR_RATED = "motor rated speed / ratio (drives.toml)"
SRC_MOTOR_NO_LOAD = "motor no-load speed U/Ke / ratio (drives.toml)"
SRC_REDUCER = "reducer max input speed / ratio (drives.toml)"
SRC_AVAILABLE = "available torque (stall x ratio x efficiency x derating, drives.toml)"
SRC_DERIVED_ACCELERATION = (
    "derived from the drive train: (peak joint torque - max gravity torque) / "
    "(reflected inertia + max link inertia)"
)
SRC_DERIVED_JERK = (
    "derived from the drive train: motor torque slew Kt U / L x ratio x efficiency / "
    "(reflected inertia + max link inertia)"
)
#: Source of a drive value left out of the drives file, until it is derived or overridden.
_TO_DERIVE = "not in the drives file (derived unless the study gives it)"
_UNKNOWN = "unknown"
_OFF = "off"


#: the key in a :class:`Limits`' ``__dict__`` of what is derived from its fields
#: (:meth:`Limits.derived`): never copied to another Limits
_CACHE = "_derived_cache"


class _ReadOnlyDict(dict):
    """A dict that refuses every change: :attr:`Limits.sources`, so that a Limits is
    immutable as a whole (what is derived from it can be kept, :meth:`Limits.derived`)."""

    def _refuse(self, *args, **kwargs):
        raise TypeError(
            "Limits.sources is read-only; make a new Limits (Limits.with_values, resolve_limits)"
        )

    __setitem__ = __delitem__ = __ior__ = _refuse
    clear = pop = popitem = setdefault = update = _refuse

    def __reduce__(self):
        return (_ReadOnlyDict, (dict(self),))


def _readonly(a) -> np.ndarray:
    if isinstance(a, np.ndarray) and a.dtype == np.float64 and not a.flags.writeable:
        return a  # already one (another Limits' array): nobody can change it
    out = np.array(a, dtype=float)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class Limits:
    """Joint limits of a robot or a request, arrays ``(n_joints,)`` in SI units (read-only).

    Attributes
    ----------
    joint_names : tuple of str
    lower_rad, upper_rad : ndarray
        Joint range in [rad] ([m] for prismatic joints).
    velocity_rad_s, acceleration_rad_s2, jerk_rad_s3, torque_Nm : ndarray or None
        Bounds on ``|qd|`` [rad/s], ``|qdd|`` [rad/s^2], ``|qddd|`` [rad/s^3], ``|tau|`` [N m];
        values > 0 (``inf``: no bound on that joint); None where the kind is unknown (a plain
        URDF has no acceleration or jerk limit) or switched off.
    sources : dict of str to tuple of str
        Per kind (``position``, ``velocity``, ``acceleration``, ``jerk``, ``torque``), per joint:
        where the value came from (``"motor rated speed / ratio (drives.toml)"``,
        ``"study [limits] velocity_rad_s x speed_scale 0.8"``, ``"unknown"``,
        ``"off (j_max=False)"``); read-only (a change is a new Limits).

    Build one with :func:`resolve_limits` (or :func:`description_limits`). A Limits is
    immutable, so what a planner derives from it per call (the JSON form, the centre and half
    range, a request's limits) is made once and kept with it (:meth:`derived`).
    """

    joint_names: tuple[str, ...]
    lower_rad: np.ndarray
    upper_rad: np.ndarray
    velocity_rad_s: np.ndarray | None = None
    acceleration_rad_s2: np.ndarray | None = None
    jerk_rad_s3: np.ndarray | None = None
    torque_Nm: np.ndarray | None = None
    sources: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        names = tuple(str(n) for n in self.joint_names)
        n = len(names)
        set_ = object.__setattr__
        set_(self, "joint_names", names)
        lo, hi = _readonly(self.lower_rad), _readonly(self.upper_rad)
        # one test of a valid range (an unbounded joint, a continuous joint without range,
        # has -inf / +inf); where it fails, the checks in turn name the first problem
        valid = lo.shape == hi.shape == (n,) and bool(
            ((lo <= hi) & (lo != np.inf) & (hi != -np.inf) & (np.isinf(lo) == np.isinf(hi))).all()
        )
        if not valid:
            for name, a, bad in (("lower_rad", lo, np.inf), ("upper_rad", hi, -np.inf)):
                if a.shape != (n,) or np.any(np.isnan(a)) or np.any(a == bad):
                    raise InputError(f"limits {name} must be {n} numbers, not {a.tolist()}")
            if np.any(np.isinf(lo) != np.isinf(hi)):
                j = int(np.argmax(np.isinf(lo) != np.isinf(hi)))
                raise InputError(f"limits of {names[j]}: a range unbounded on one side only")
            j = int(np.argmax(lo > hi))
            raise InputError(f"limits of {names[j]}: lower_rad is above upper_rad")
        set_(self, "lower_rad", lo)
        set_(self, "upper_rad", hi)
        for kind, (name, unit, _, _) in LIMIT_KEYS.items():
            a = getattr(self, name)
            if a is None:
                continue
            a = _readonly(a)
            if a.shape != (n,):
                raise InputError(f"limits {name} has shape {a.shape}, expected ({n},)")
            if not (a > 0).all():  # NaN fails too
                j = int(np.argmax(~(a > 0)))
                raise InputError(f"{kind} limit of {names[j]} is {a[j]!r}; it must be > 0 {unit}")
            set_(self, name, a)
        src = {}
        for kind in _SOURCE_KINDS:
            given = self.sources.get(kind)
            if given is None:
                known = kind == "position" or getattr(self, LIMIT_KEYS[kind][0]) is not None
                given = ("given" if known else _UNKNOWN,) * n
            given = tuple(str(s) for s in given)
            if len(given) != n:
                raise InputError(f"limits sources[{kind!r}]: {len(given)} entries for {n} joints")
            src[kind] = given
        set_(self, "sources", _ReadOnlyDict(src))

    # ------------------------------------------------------------------ derived data, once
    def derived(self, key, make):
        """``make(self)``, computed once per Limits and kept with it (a planner's per-call data:
        the centre and half range, the JSON form, the limits of a request).

        A Limits is immutable -- arrays read-only, names a tuple, ``sources`` a read-only
        dict of tuples, a frozen dataclass -- so a value derived from its fields holds as long
        as the object; a changed limit is a new Limits (:func:`resolve_limits`,
        :meth:`with_values`, ``robot.limits = ...``), which starts without any. Kept in
        ``__dict__`` under its own key, which no copy takes over (:meth:`_with`, ``copy``,
        ``pickle``). ``make`` must return a value nobody changes (read-only arrays, a
        Limits, tuples; a dict is copied by its reader) and depend on the Limits only (the
        key names everything else it depends on).
        """
        cache = self.__dict__.get(_CACHE)
        if cache is None:
            cache = self.__dict__[_CACHE] = {}  # frozen: not through __setattr__
        try:
            return cache[key]
        except KeyError:
            value = cache[key] = make(self)
            return value

    def __getstate__(self) -> dict:
        """The fields, without the derived data (:meth:`derived`): a copy or an unpickled
        Limits makes its own."""
        state = dict(self.__dict__)
        state.pop(_CACHE, None)
        return state

    def centre_half_rad(self) -> tuple[np.ndarray, np.ndarray]:
        """(:attr:`centre_rad`, half range ``(upper - lower) / 2``) in [rad], read-only, made
        once (:meth:`derived`): the position ratio ``|q - centre| / half`` of a limit check
        (``inf`` half range for an unbounded joint: ratio 0)."""

        return self.derived("centre_half", _centre_half)

    # ------------------------------------------------------------------ access
    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    @property
    def effort_Nm(self) -> np.ndarray | None:
        """:attr:`torque_Nm` under the URDF's (and the study key's) name."""
        return self.torque_Nm

    def get(self, kind: str) -> np.ndarray | None:
        """The array of limit ``kind`` (``velocity``, ``acceleration``, ``jerk``, ``torque``)."""
        if kind not in LIMIT_KEYS:
            raise InputError(f"unknown limit kind {kind!r} (kinds: {', '.join(LIMIT_KEYS)})")
        return getattr(self, LIMIT_KEYS[kind][0])

    def is_off(self, kind: str) -> bool:
        """True when ``kind`` was switched off on purpose (``False``), not merely unknown."""
        return self.get(kind) is None and self.sources[kind][0].startswith(_OFF)

    # ------------------------------------------------------------------ derived sets
    def _with(self, values: dict, notes: dict) -> Limits:
        """A copy with ``{field: array or None}`` replaced and ``{kind: sources}`` set."""
        if all(v is None and k not in _RANGE_FIELDS for k, v in values.items()) and all(
            len(v) == self.n_joints for v in notes.values()
        ):
            # kinds switched off only: every value left was checked when ``self`` was made
            # (a copy without the checks of __post_init__: a planner's call with tau_max=False)
            out = object.__new__(Limits)
            out.__dict__.update(self.__dict__)
            out.__dict__.pop(_CACHE, None)  # derived from self: made again for out
            out.__dict__.update(values)
            src = {k: tuple(str(s) for s in v) for k, v in notes.items()}
            out.__dict__["sources"] = _ReadOnlyDict({**self.sources, **src})
            return out
        kw = {name: getattr(self, name) for name in _LIMITS_FIELDS}
        kw.update(values)
        kw["sources"] = {**self.sources, **notes}
        return Limits(**kw)

    def scaled(self, speed_scale: float) -> Limits:
        """Velocity x s, acceleration x s^2, jerk x s^3 (``s`` in (0, 1]); torque unchanged."""
        s = float(speed_scale)
        if not (0.0 < s <= 1.0):
            raise InputError(f"speed_scale must be in (0, 1], not {speed_scale!r}")
        if s == 1.0:
            return self
        values, notes = {}, {}
        for kind, power in (("velocity", 1), ("acceleration", 2), ("jerk", 3)):
            a = self.get(kind)
            if a is not None:
                values[LIMIT_KEYS[kind][0]] = a * s**power
                notes[kind] = tuple(f"{x} x speed_scale {s:g}" for x in self.sources[kind])
        return self._with(values, notes)

    def tightened(self, kind: str, factor, why: str) -> Limits:
        """Limit ``kind`` multiplied by ``factor`` <= 1 (scalar or (n_joints,)), noting ``why``
        in the sources of the joints it changes (a planner's back-off)."""
        a = self.get(kind)
        if a is None:
            return self
        f = np.broadcast_to(np.asarray(factor, float), a.shape)
        if not np.all((f > 0) & (f <= 1.0 + 1e-12)):
            raise InputError(f"a {kind} limit may only be tightened (factor in (0, 1])")
        src = tuple(
            s if fj == 1.0 else f"{s} x {why}" for s, fj in zip(self.sources[kind], f, strict=True)
        )
        return self._with({LIMIT_KEYS[kind][0]: a * f}, {kind: src})

    def with_values(self, source: str, **changes) -> Limits:
        """A copy with fields replaced (``velocity_rad_s=...``, ``lower_rad=...``; None: unknown);
        ``source`` is recorded for every joint of each changed kind. No check against the
        hardware: use :func:`resolve_limits` for that."""
        values, notes = {}, {}
        n = self.n_joints
        for name, value in changes.items():
            if name in ("lower_rad", "upper_rad"):
                kind = "position"
            elif name == "effort_Nm":
                name, kind = "torque_Nm", "torque"
            elif name in _FIELD_KIND:
                kind = _FIELD_KIND[name]
            else:
                raise InputError(f"no limit field {name!r} (fields: {', '.join(_fields())})")
            if value is not None:
                value = np.asarray(value, float)
                value = np.full(n, float(value)) if value.ndim == 0 else value
            values[name] = value
            notes[kind] = ((source if value is not None else _UNKNOWN),) * n
        return self._with(values, notes)

    def subset(self, index) -> Limits:
        """The limits of the joints ``index`` (an index array, in that order)."""
        idx = np.asarray(index, dtype=int).reshape(-1)
        kw: dict[str, Any] = {"joint_names": tuple(self.joint_names[i] for i in idx)}
        for name in _fields():
            a = getattr(self, name)
            kw[name] = None if a is None else a[idx]
        kw["sources"] = {k: tuple(v[i] for i in idx) for k, v in self.sources.items()}
        return Limits(**kw)

    # ------------------------------------------------------------------ checks and output
    def require(self, kinds: Sequence[str], *, where: str = "") -> Limits:
        """``self`` if every kind in ``kinds`` is known, else one :class:`~armlab.InputError`
        naming every missing limit with the study key and the keyword that supply it.

        Parameters
        ----------
        kinds : sequence of str
            Limit kinds (``velocity``, ``acceleration``, ``jerk``, ``torque``).
        where : str
            What needs them (``"optimal on ur5_robot"``), the head of the message.
        """
        missing = [k for k in kinds if k != "position" and self.get(k) is None]
        if not missing:
            return self
        parts = []
        for kind in missing:
            _, unit, kw, key = LIMIT_KEYS[kind]
            if self.is_off(kind):
                parts.append(f"{kind} (switched off by {kw}=False; give {kw}=<{unit}>)")
            else:
                parts.append(f"{kind} ([limits] {key} in a study, {kw}=<{unit}> in a call)")
        head = f"{where}: " if where else ""
        plural = "s" if len(missing) > 1 else ""
        why = ""
        if any(k in ("acceleration", "jerk") and not self.is_off(k) for k in missing):
            why = " (a plain URDF has no acceleration or jerk limit; drives.toml gives them)"
        raise InputError(
            f"{head}missing {' and '.join(missing)} limit{plural}{why}: {'; '.join(parts)}"
        )

    @property
    def unbounded(self) -> np.ndarray:
        """True for a joint without position limit (a continuous joint without range), (n,)."""
        return np.isinf(self.lower_rad)

    @property
    def sample_lower_rad(self) -> np.ndarray:
        """Lower end of the range random poses and seeds are drawn from [rad]: the joint range,
        one turn (-pi) for an unbounded joint (every pose of a revolute joint is in one turn)."""
        return np.where(self.unbounded, -np.pi, self.lower_rad)

    @property
    def sample_upper_rad(self) -> np.ndarray:
        """Upper end of :attr:`sample_lower_rad`'s range [rad] (+pi for an unbounded joint)."""
        return np.where(self.unbounded, np.pi, self.upper_rad)

    @property
    def centre_rad(self) -> np.ndarray:
        """Middle of each joint range [rad] (0 for an unbounded joint): the default seed/pose."""
        return 0.5 * (self.sample_lower_rad + self.sample_upper_rad)

    def to_dict(self) -> dict:
        """JSON-able: ``{field: {joint: value} or None, "sources": {kind: {joint: source}}}``
        (a new dict each call; made once, :meth:`derived`, and copied)."""
        return _copy_dict(self.derived("to_dict", Limits._make_dict))

    def _make_dict(self) -> dict:
        def arr(x):
            return None if x is None else dict(zip(self.joint_names, x.tolist(), strict=True))

        out: dict = {"joint_names": list(self.joint_names)}
        for name in _fields():
            out[name] = arr(getattr(self, name))
        out["sources"] = {
            k: dict(zip(self.joint_names, v, strict=True)) for k, v in self.sources.items()
        }
        return out


def _centre_half(lim: Limits) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`Limits.centre_half_rad`, made once."""
    c, h = lim.centre_rad, 0.5 * (lim.upper_rad - lim.lower_rad)
    c.flags.writeable = h.flags.writeable = False
    return c, h


def _copy_dict(d: dict) -> dict:
    """A copy of a :meth:`Limits.to_dict` dict down to its leaves (strings, floats, None):
    its lists and dicts, and the dicts in ``sources``."""
    out = d.copy()
    for k, v in out.items():  # (values replaced in place: the keys stay)
        if v is not None:
            out[k] = v.copy()
    src = out["sources"]
    for k, v in src.items():
        src[k] = v.copy()
    return out


_LIMITS_FIELDS = tuple(f.name for f in fields(Limits))
#: the range: never None (a kind switched off is one of the other fields)
_RANGE_FIELDS = ("lower_rad", "upper_rad")


def _fields() -> tuple[str, ...]:
    return ("lower_rad", "upper_rad") + tuple(v[0] for v in LIMIT_KEYS.values())


# ----------------------------------------------------------------------------- layers
def description_limits(model, joint_names: Sequence[str] | None = None) -> Limits:
    """The URDF's own limits (a Pinocchio model built from it): range, velocity, effort.

    A ``<limit velocity>`` or ``effort`` of 0 means unknown (the kind is None if any joint's is).
    """
    names = list(model.names[1:]) if joint_names is None else list(joint_names)
    n = len(names)
    values, sources = {}, {"position": (SRC_URDF_RANGE,) * n}
    for kind, arr, src in (
        ("velocity", model.velocityLimit, SRC_URDF_VELOCITY),
        ("torque", model.effortLimit, SRC_URDF_EFFORT),
    ):
        a = np.asarray(arr, float).copy()
        known = np.isfinite(a) & (a > 0)
        values[LIMIT_KEYS[kind][0]] = a if np.all(known) else None
        sources[kind] = tuple(
            src if ok else f"{_UNKNOWN} ({src} is {x:g})" for ok, x in zip(known, a, strict=True)
        )
    return Limits(
        joint_names=tuple(names),
        lower_rad=np.asarray(model.lowerPositionLimit, float),
        upper_rad=np.asarray(model.upperPositionLimit, float),
        sources=sources,
        **values,
    )


def _per_joint(value, n: int, what: str, error=InputError) -> np.ndarray:
    """A scalar or (n,) positive value as an (n,) array (NaN, <= 0, True: ``error``)."""
    if value is True or isinstance(value, str):
        raise error(f"{what}: {value!r} is not a limit; give a number, None or False")
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise error(f"{what}: {value!r} is not a number or a list of numbers") from None
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,):
        raise error(f"{what}: {a.size} values, the robot has {n} joints")
    if not np.all(a > 0):
        raise error(f"{what}: {a.tolist()} must be > 0 for every joint")
    return a


def _drive_list(drives, names: Sequence[str]) -> list:
    if isinstance(drives, Mapping):
        missing = [n for n in names if n not in drives]
        if missing:
            raise InputError(f"no drive for joint(s) {missing}")
        return [drives[n] for n in names]
    out = list(drives)
    if len(out) != len(names):
        raise InputError(f"{len(out)} drives for {len(names)} joints")
    return out


def _owner(source: str) -> str:
    if source.startswith("urdf"):
        return "URDF's"
    if "drives.toml" in source:
        return "drive train's"
    return "robot's"


def _apply_drives(cur: dict, src: dict, drives, names) -> None:
    """Layer 2 (module docstring), in place on ``cur`` (kind -> (n,) with NaN = unknown)."""
    for j, d in enumerate(_drive_list(drives, names)):
        # the drive's speed limit (Drive.motor_speed_limit_rad_s) over the ratio, named by
        # what binds: the reducer's input limit, else the motor's rated or no-load speed
        motor = d.motor
        drive_v = d.motor_speed_limit_rad_s / d.reducer.ratio
        if d.motor_speed_limit_rad_s < motor.speed_limit_rad_s:
            drive_src = SRC_REDUCER
        elif math.isfinite(motor.rated_speed_rpm) and motor.rated_speed_rpm > 0:
            drive_src = SRC_MOTOR_RATED
        else:
            drive_src = SRC_MOTOR_NO_LOAD
        cands = [(cur["velocity"][j], src["velocity"][j]), (drive_v, drive_src)]
        best = min((c for c in cands if c[0] > 0), key=lambda c: c[0], default=None)
        if best is not None:
            cur["velocity"][j], src["velocity"][j] = best
        for kind, value in (("acceleration", d.acceleration_rad_s2), ("jerk", d.jerk_rad_s3)):
            if not math.isnan(cur[kind][j]):
                raise InputError(
                    f"{names[j]}: the {kind} limit is already set ({src[kind][j]}); drives apply "
                    "to the description's limits only"
                )
            if math.isnan(value):  # left out of the drives file: derived after the overrides
                src[kind][j] = _TO_DERIVE
                continue
            cur[kind][j], src[kind][j] = value, f"drives.toml {LIMIT_KEYS[kind][0]}"
        cur["torque"][j], src["torque"][j] = d.available_torque_Nm, SRC_AVAILABLE


def _apply_overrides(cur: dict, src: dict, overrides: Mapping, names) -> None:
    """Layer 3: tighten-only study overrides (SpecError naming the key)."""
    n = len(names)
    for key, value in overrides.items():
        if value is None:
            continue
        if key not in _STUDY_KIND:
            raise SpecError(f"limits.{key}: not a limit key (keys: {', '.join(_STUDY_KIND)})")
        kind = _STUDY_KIND[key]
        unit = LIMIT_KEYS[kind][1]
        new = _per_joint(value, n, f"limits.{key}", SpecError)
        for j in range(n):
            hw = cur[kind][j]
            if not math.isnan(hw) and new[j] > hw * (1 + 1e-9):
                raise SpecError(
                    f"limits.{key} of {names[j]}: {new[j]:.4g} {unit} is above the "
                    f"{_owner(src[kind][j])} {hw:.4g} {unit} ({src[kind][j]}); a study may only "
                    "tighten a limit"
                )
            cur[kind][j], src[kind][j] = new[j], f"study [limits] {key}"


def _joint_loads(model, n_samples: int = 256, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(largest link inertia ``M_jj`` [kg m^2], largest ``|gravity torque|`` [N m]) per joint
    over ``n_samples`` uniform random poses in the joint ranges (seeded: reproducible)."""
    import pinocchio as pin

    rng = np.random.default_rng(seed)
    lo = np.asarray(model.lowerPositionLimit, float)
    hi = np.asarray(model.upperPositionLimit, float)
    data = model.createData()
    inertia = np.zeros(model.nv)
    gravity = np.zeros(model.nv)
    for q in rng.uniform(lo, hi, size=(n_samples, model.nq)):
        inertia = np.maximum(inertia, np.diag(pin.crba(model, data, q)))
        gravity = np.maximum(gravity, np.abs(pin.computeGeneralizedGravity(model, data, q)))
    return inertia, gravity


def drive_train_limits(drives, names: Sequence[str], model) -> tuple[np.ndarray, np.ndarray]:
    """Acceleration [rad/s^2] and jerk [rad/s^3] limits per joint derived from the drive train,
    for a robot whose description and drives file give none.

    With joint-side peak torque ``T_pk = min(motor peak x derating x N x eta, reducer peak)``
    (motor peak: the peak rating, else the stall torque), reflected inertia
    ``J_r = (J_rotor + J_reducer) N^2``, and, over 256 seeded random poses, the largest link
    inertia ``M_jj`` and gravity torque ``|g_j|``::

        a_max = (T_pk - max |g_j|) / (J_r + max M_jj)
        j_max = Kt U / L x N x eta x derating / (J_r + max M_jj)

    (the joint accelerates from rest at its worst pose against gravity; the torque can rise no
    faster than the armature current, ``di/dt <= U / L``, HEU thesis ch. 5 armature equation).

    Raises
    ------
    InputError
        A joint whose peak torque cannot hold its worst gravity torque (nothing to derive).
    """
    inertia, gravity = _joint_loads(model)
    acc, jerk = [], []
    for j, d in enumerate(_drive_list(drives, names)):
        m, r = d.motor, d.reducer
        peak = min(d.peak_motor_torque_Nm * r.ratio * r.efficiency, r.peak_torque_Nm)
        gain = r.ratio * r.efficiency * d.derating
        total = d.reflected_inertia_kg_m2 + float(inertia[j])
        if peak <= gravity[j] or total <= 0:
            raise InputError(
                f"{names[j]}: cannot derive an acceleration limit from the drive train: peak "
                f"torque {peak:.4g} N m <= worst gravity torque {gravity[j]:.4g} N m; give "
                "[limits] acceleration_rad_s2 in the study or acceleration_rad_s2 in the drives "
                "file"
            )
        acc.append((peak - gravity[j]) / total)
        slew = m.torque_constant_Nm_A * d.supply_voltage_V / m.inductance_H
        jerk.append(slew * gain / total)
    return np.array(acc), np.array(jerk)


def _apply_derived(cur: dict, src: dict, drives, names, model) -> None:
    """Acceleration and jerk the drives file leaves out and the study does not give: derived
    (:func:`drive_train_limits`), in place."""
    todo = {
        kind: [j for j in range(len(names)) if src[kind][j] == _TO_DERIVE]
        for kind in ("acceleration", "jerk")
    }
    if not any(todo.values()):
        return
    acc, jerk = drive_train_limits(drives, names, model)
    for kind, values, note in (
        ("acceleration", acc, SRC_DERIVED_ACCELERATION),
        ("jerk", jerk, SRC_DERIVED_JERK),
    ):
        for j in todo[kind]:
            cur[kind][j], src[kind][j] = float(values[j]), note


def resolve_limits(
    limits,
    drives=None,
    *,
    overrides: Mapping[str, object] | None = None,
    speed_scale: float = 1.0,
    v_max=None,
    a_max=None,
    j_max=None,
    tau_max=None,
    need: Sequence[str] = (),
    where: str = "",
    model=None,
) -> Limits:
    """The effective :class:`Limits`: description -> drive train -> study overrides -> speed
    scale -> per-call keywords (module docstring).

    Parameters
    ----------
    limits : Limits or Robot
        The starting point: :func:`description_limits` of a model when building a robot, or a
        robot's resolved ``robot.limits`` (a Robot stands for its ``limits``) for a request.
    drives : dict of joint name to Drive, or list of Drive, optional
        Combine this drive train (onto the description's limits only): velocity = min(URDF,
        motor speed limit / ratio, reducer max input speed / ratio) with the motor speed limit
        of the sizing check ``motor_speed`` (rated table speed, else no-load speed ``U / Ke``);
        acceleration and jerk from drives.toml; torque = available torque.
    overrides : mapping, optional
        Study ``[limits]`` keys (``velocity_rad_s``, ``acceleration_rad_s2``, ``jerk_rad_s3``,
        ``effort_Nm``) to a number or a per-joint list; may only tighten (None: unchanged).
    speed_scale : float
        ``s`` in (0, 1]: velocity x s, acceleration x s^2, jerk x s^3.
    v_max, a_max, j_max, tau_max : None, False, float or array (n_joints,)
        Per-call limits in [rad/s], [rad/s^2], [rad/s^3], [N m]: None keeps the limit resolved
        so far, False switches it off, a value (> 0; all ``inf`` = off) replaces it -- without a
        hardware check: a call states the limits of its own request (what-if studies), and the
        plan is checked against them; only study overrides are tighten-only.
    need : sequence of str, or "unset"
        Kinds the caller cannot work without; any missing ones raise one error. ``"unset"``:
        every kind whose keyword is left None (the caller then takes the robot's own, so it
        must be there).
    where : str
        What is asking, for the messages (``"ptp_sync on teachbot6"``).
    model : pinocchio.Model, optional
        The robot's model: with it, an acceleration or jerk limit that neither the drives nor
        the overrides give is derived from the drive train (:func:`drive_train_limits`);
        without it such a limit stays unknown.

    Returns
    -------
    Limits
        With ``sources`` naming each value's origin.

    Raises
    ------
    SpecError
        An override above the hardware limit, of the wrong length, or <= 0 (names the key).
    InputError
        A per-call value of the wrong shape, <= 0, NaN or True; kinds in ``need`` missing.
    """
    base = limits if isinstance(limits, Limits) else getattr(limits, "limits", None)
    if not isinstance(base, Limits):
        raise InputError(f"resolve_limits needs a Limits or a Robot, not {type(limits).__name__}")
    names, n = base.joint_names, base.n_joints
    if drives is not None or overrides:
        cur = {
            k: (np.full(n, np.nan) if base.get(k) is None else np.array(base.get(k), float))
            for k in LIMIT_KEYS
        }
        src = {k: list(base.sources[k]) for k in LIMIT_KEYS}
        if drives is not None:
            _apply_drives(cur, src, drives, names)
        if overrides:
            _apply_overrides(cur, src, overrides, names)
        if drives is not None and model is not None:
            _apply_derived(cur, src, drives, names, model)
        values = {LIMIT_KEYS[k][0]: (None if np.any(np.isnan(a)) else a) for k, a in cur.items()}
        base = base._with(values, {k: tuple(v) for k, v in src.items()})
    base = base.scaled(speed_scale)
    asked = (v_max, a_max, j_max, tau_max)
    off = (v_max is False, a_max is False, j_max is False, tau_max is False)
    unset = (v_max is None, a_max is None, j_max is None, tau_max is None)
    if True in off and sum(off) + sum(unset) == 4:
        # kinds switched off only (a planner's tau_max=False): the same (immutable) Limits for
        # every such call, made once per base (Limits.derived)
        base = base.derived(("keywords off", off), lambda lim: _keyword_layer(lim, asked))
    else:
        base = _keyword_layer(base, asked)
    if need == "unset":
        need = [k for k, u in zip(LIMIT_KEYS, unset, strict=True) if u]
    return base.require(need, where=where)


def _keyword_layer(base: Limits, asked: tuple) -> Limits:
    """Layer 5 (module docstring): ``asked = (v_max, a_max, j_max, tau_max)`` onto ``base``."""
    n = base.n_joints
    values: dict[str, np.ndarray | None] = {}
    notes: dict[str, tuple[str, ...]] = {}
    for kind, value in zip(LIMIT_KEYS, asked, strict=True):
        if value is None:
            continue
        name, _, kw, _ = LIMIT_KEYS[kind]
        if value is False:
            values[name], notes[kind] = None, (f"{_OFF} ({kw}=False)",) * n
            continue
        a = _per_joint(value, n, kw)
        if np.all(np.isinf(a)):
            values[name], notes[kind] = None, (f"{_OFF} ({kw}=inf)",) * n
        else:
            values[name], notes[kind] = a, (f"{kw} argument",) * n
    return base._with(values, notes) if values else base
