"""Pre-flight checks of a set-point table: the 1987 controller's run-time faults made preventive.

The 1987 welding controller (HR SJ-1 control-software paper, §8 "fault handling") clears the
D/A output buffer and brakes when it sees over-speed, over-limit or a controller error. A table
that would trigger one of those is refused here, before any file is written. Every check runs
on every cycle ``k`` of the table (positions ``q_k`` at ``t_k = t_0 + k T``, ``T`` the controller
period):

What the controller receives are the rounded integer counts ``counts_k = round(q_k x
counts_per_rad x sign)``, not the planned positions; the checks of a position, a start pose and
a speed run on them (``q_sent_k = counts_k / (counts_per_rad x sign)``), so a table whose
rounding carries a joint over a limit is refused (issue 24: 45 counts per 1 ms cycle are
0.5655 rad/s against a 0.56 rad/s limit, although the plan keeps it):

* ``finite``        q_k, qd_k (and qdd_k when given) are finite numbers.
* ``start pose``    ``|counts_0 - q_current x counts_per_rad x sign| <= start_tolerance_counts``
                    (cycle 0).
* ``joint range``   ``lower <= q_k <= upper`` for the planned and the sent positions (1e-9 rad
                    slack).
* ``counter range`` ``|counts_k| <= 2^31 - 1`` (the int32 registers and C arrays).
* ``speed``         ``max(|qd_k|, |dcounts_k| / (counts_per_rad T)) <= v_max (1 +
                    speed_tolerance)``: the planned speed and the speed the counts of the cycle
                    command (what the controller runs).
* ``pulse rate``    ``|dcounts_k| = |counts_k - counts_{k-1}| <= max_pulses_per_cycle``
                    (SHU controller paper, §1: 0..4095 pulses per axis per DDA period).
* ``continuity``    no jump: the velocity change entering cycle k,
                    ``|q_k - 2 q_{k-1} + q_{k-2}| / T``, is at most what the acceleration limit
                    allows in one cycle, ``a_max T (1 + continuity_tolerance)``. The arm is at rest
                    before cycle 0 and after the last cycle (``q_{-1} = q_0``, ``q_{n} = q_{n-1}``):
                    a table must start and end at rest. Skipped for robots without an
                    acceleration limit (the speed check then bounds jumps). On the planned
                    positions: the rounding of integer counts changes the velocity of a cycle by
                    up to one count per cycle, a quantisation the servo filters, not a jump.

The report keeps the first failing (cycle, joint) of each check; the error names the earliest.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from armlab.errors import LimitViolation
from armlab.robot.limits import Limits

__all__ = ["CHECKS", "PreflightFailure", "PreflightReport", "preflight"]

#: Check names in the order they are reported when two fail on the same cycle and joint.
CHECKS = (
    "finite",
    "start pose",
    "joint range",
    "counter range",
    "speed",
    "pulse rate",
    "continuity",
)

INT32_MAX = 2**31 - 1
RANGE_TOL_RAD = 1e-9


@dataclass(frozen=True)
class PreflightFailure:
    """The first cycle and joint at which one check fails.

    Attributes
    ----------
    check : str
        One of :data:`CHECKS`.
    cycle : int
        Controller cycle (row of the table, 0-based).
    t_s : float
        Time of that cycle in [s].
    joint : str
    value, limit : float
        The offending value and the limit it breaks, in ``unit``.
    unit : str
    detail : str
        One human sentence (what, by how much).
    """

    check: str
    cycle: int
    t_s: float
    joint: str
    value: float
    limit: float
    unit: str
    detail: str

    def message(self) -> str:
        """One line naming cycle, joint and limit."""
        return (
            f"pre-flight check failed at cycle {self.cycle} (t = {self.t_s:.6g} s), "
            f"joint {self.joint}, {self.check} limit: {self.detail}; nothing written"
        )

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class PreflightReport:
    """Outcome of :func:`preflight`.

    Attributes
    ----------
    checks : list of str
        The checks that ran.
    failures : list of PreflightFailure
        First failure of each failing check, earliest cycle first.
    n_cycles : int
    peak_ratio : dict of str to dict of str to float or None
        ``{check: {joint: peak value / limit}}`` for speed, pulse rate and continuity (None
        where not finite, e.g. a zero limit).
    """

    checks: list[str]
    failures: list[PreflightFailure] = field(default_factory=list)
    n_cycles: int = 0
    peak_ratio: dict[str, dict[str, float | None]] = field(default_factory=dict)

    def ok(self) -> bool:
        return not self.failures

    def first(self) -> PreflightFailure | None:
        """The earliest failure (cycle, then joint order, then :data:`CHECKS` order)."""
        return self.failures[0] if self.failures else None

    def raise_if_failed(self) -> None:
        """Raise :class:`~armlab.LimitViolation` naming the first failing cycle, joint and limit.

        The exception carries the failure as its ``failure`` attribute.
        """
        first = self.first()
        if first is not None:
            exc = LimitViolation(first.message())
            exc.failure = first
            raise exc

    def to_dict(self) -> dict:
        return {
            "ok": self.ok(),
            "checks": list(self.checks),
            "n_cycles": self.n_cycles,
            "failures": [f.to_dict() for f in self.failures],
            "peak_ratio": self.peak_ratio,
        }


def _first(bad: np.ndarray) -> tuple[int, int] | None:
    """(row, column) of the first True in row-major order, or None."""
    rows = bad.any(axis=1)
    if not rows.any():
        return None
    k = int(np.argmax(rows))
    return k, int(np.argmax(bad[k]))


def _peak(ratio: np.ndarray, names: list[str]) -> dict[str, float | None]:
    """Largest ratio per joint (None where not finite, e.g. a zero limit)."""
    if ratio.size == 0:
        return {n: 0.0 for n in names}
    return {
        n: (float(r) if np.isfinite(r) else None)
        for n, r in zip(names, ratio.max(axis=0), strict=True)
    }


def preflight(
    *,
    t_s: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    counts_exact: np.ndarray,
    dcounts: np.ndarray | None,
    limits: Limits,
    counts_per_rad: np.ndarray,
    cycle_s: float,
    max_pulses_per_cycle: int | None,
    q_current: np.ndarray | None = None,
    start_tolerance_counts: float = 1.0,
    speed_tolerance: float = 1e-6,
    continuity_tolerance: float = 0.05,
    qdd: np.ndarray | None = None,
) -> PreflightReport:
    """Run every check on every cycle (see the module docstring for the rules).

    Parameters
    ----------
    t_s : array (n_cycles,)
        Cycle times in [s].
    q, qd : arrays (n_cycles, n_axes)
        Exact (unrounded) positions [rad] and velocities [rad/s] per axis.
    counts_exact : array (n_cycles, n_axes)
        ``q x counts_per_rad x sign`` before rounding.
    dcounts : int array (n_cycles, n_axes) or None
        Counts per cycle (None when counts could not be formed: non-finite input).
    limits : Limits
        The limits of the axes, in axis order (``robot.limits.subset(axis index)``): joint
        names, range, velocity (required) and acceleration (the continuity check, if known).
    counts_per_rad : array (n_axes,)
    cycle_s : float
        Controller period T in [s].
    max_pulses_per_cycle : int or None
    q_current : array (n_axes,), optional
        The robot's current pose per axis [rad].
    start_tolerance_counts, speed_tolerance, continuity_tolerance : float
        From the controller profile.
    qdd : array (n_cycles, n_axes), optional
        Planned accelerations [rad/s^2] (the tables' feed-forward): checked finite.

    Returns
    -------
    PreflightReport

    Raises
    ------
    InputError
        ``limits`` has no velocity limit (the controller's over-speed check needs one).
    """
    limits.require(("velocity",), where="set-point pre-flight")
    joint_names = list(limits.joint_names)
    lower_rad, upper_rad = limits.lower_rad, limits.upper_rad
    velocity_rad_s, acceleration_rad_s2 = limits.velocity_rad_s, limits.acceleration_rad_s2
    n = q.shape[0]
    T = float(cycle_s)
    found: list[tuple[int, int, int, PreflightFailure]] = []
    report = PreflightReport(checks=[], n_cycles=n)

    def add(check: str, bad: np.ndarray, make) -> None:
        hit = _first(bad)
        if hit is not None:
            k, j = hit
            value, limit, unit, detail = make(k, j)
            found.append(
                (
                    k,
                    j,
                    CHECKS.index(check),
                    PreflightFailure(
                        check,
                        k,
                        float(t_s[k]),
                        joint_names[j],
                        float(value),
                        float(limit),
                        unit,
                        detail,
                    ),
                )
            )

    report.checks.append("finite")
    finite = np.isfinite(q) & np.isfinite(qd)
    acc = np.zeros_like(q) if qdd is None else np.asarray(qdd, dtype=float)
    finite_all = finite & np.isfinite(acc)
    add(
        "finite",
        ~finite_all,
        lambda k, j: (
            next(x for x in (q[k, j], qd[k, j], acc[k, j]) if not np.isfinite(x)),
            math.inf,
            "",
            f"q = {q[k, j]!r} rad, qd = {qd[k, j]!r} rad/s, qdd = {acc[k, j]!r} rad/s^2 "
            "are not all finite numbers",
        ),
    )
    qs = np.where(finite, q, 0.0)
    qds = np.where(finite, qd, 0.0)

    # what the controller receives: the rounded counts, as joint positions (the planned ones
    # where no counts could be formed: such a table fails "finite" or "counter range")
    cs = np.where(finite, counts_exact, 0.0)
    # rint(q cpr sign) / (cpr sign) = rint(q cpr) / cpr: rounding is symmetric about zero
    sent = qs if dcounts is None else np.rint(qs * counts_per_rad) / counts_per_rad

    if q_current is not None:
        report.checks.append("start pose")
        off = np.abs(sent[0] - q_current) * counts_per_rad  # = |counts_0 - q_current cpr sign|
        bad = np.zeros_like(qs, dtype=bool)
        bad[0] = ~(off <= start_tolerance_counts)
        add(
            "start pose",
            bad,
            lambda k, j: (
                off[j],
                start_tolerance_counts,
                "counts",
                f"the table starts at {sent[0, j]:.6g} rad, {off[j]:.4g} counts from the current "
                f"pose {q_current[j]:.6g} rad (tolerance {start_tolerance_counts:g} counts)",
            ),
        )

    report.checks.append("joint range")
    lo, hi = np.minimum(qs, sent), np.maximum(qs, sent)  # planned and sent
    below, above = lo < lower_rad - RANGE_TOL_RAD, hi > upper_rad + RANGE_TOL_RAD
    planned_out = (qs < lower_rad - RANGE_TOL_RAD) | (qs > upper_rad + RANGE_TOL_RAD)

    def range_failure(k: int, j: int):
        value = qs[k, j] if planned_out[k, j] else (lo[k, j] if below[k, j] else hi[k, j])
        return (
            value,
            lower_rad[j] if below[k, j] else upper_rad[j],
            "rad",
            f"position {value:.9g} rad ({'planned' if planned_out[k, j] else 'sent as counts'}) "
            f"is outside the range [{lower_rad[j]:.9g}, {upper_rad[j]:.9g}] rad",
        )

    add("joint range", below | above, range_failure)

    report.checks.append("counter range")
    add(
        "counter range",
        np.abs(cs) > INT32_MAX,
        lambda k, j: (
            cs[k, j],
            INT32_MAX,
            "counts",
            f"{cs[k, j]:.0f} counts do not fit a 32-bit counter (limit {INT32_MAX})",
        ),
    )

    report.checks.append("speed")
    sent_speed = np.zeros_like(qs)  # what the counts of cycle k command
    sent_speed[1:] = np.abs(np.diff(sent, axis=0)) / T
    speed = np.maximum(np.abs(qds), sent_speed)
    vlim = np.asarray(velocity_rad_s, dtype=float)
    report.peak_ratio["speed"] = _peak(speed / vlim, joint_names)

    def speed_failure(k: int, j: int):
        how = "planned "
        if dcounts is not None and k > 0 and sent_speed[k, j] >= abs(qds[k, j]):
            how = f"{abs(int(dcounts[k, j]))} counts in one {T:g} s cycle command "
        return (
            speed[k, j],
            vlim[j],
            "rad/s",
            f"{how}speed {speed[k, j]:.6g} rad/s exceeds {vlim[j]:.6g} rad/s "
            f"({100 * speed[k, j] / vlim[j]:.2f} % of the limit)",
        )

    add("speed", speed > vlim * (1.0 + speed_tolerance), speed_failure)

    if max_pulses_per_cycle is not None and dcounts is not None:
        report.checks.append("pulse rate")
        pulses = np.abs(dcounts)
        report.peak_ratio["pulse rate"] = _peak(pulses / max_pulses_per_cycle, joint_names)
        add(
            "pulse rate",
            pulses > max_pulses_per_cycle,
            lambda k, j: (
                pulses[k, j],
                max_pulses_per_cycle,
                "pulses",
                f"{pulses[k, j]} pulses in one {T:g} s cycle exceed the controller's "
                f"{max_pulses_per_cycle} pulses per cycle",
            ),
        )

    if acceleration_rad_s2 is not None and n > 0:
        report.checks.append("continuity")
        inc = np.zeros_like(qs)  # position increment of cycle k (the arm rests before 0)
        inc[1:] = np.diff(qs, axis=0)
        dv = np.zeros_like(qs)  # velocity change entering cycle k
        dv[1:] = np.abs(np.diff(inc, axis=0)) / T
        stop = np.abs(inc[-1]) / T  # the arm rests after the last cycle
        stops = stop > dv[-1]
        dv[-1] = np.maximum(dv[-1], stop)
        allowed = np.asarray(acceleration_rad_s2, dtype=float) * T
        report.peak_ratio["continuity"] = _peak(dv / allowed, joint_names)
        add(
            "continuity",
            dv > allowed * (1.0 + continuity_tolerance) + 1e-12,
            lambda k, j: (
                dv[k, j],
                allowed[j],
                "rad/s",
                ("abrupt stop after the last cycle" if k == n - 1 and stops[j] else "velocity jump")
                + f" of {dv[k, j]:.6g} rad/s in one cycle, more than the acceleration limit "
                f"allows ({allowed[j]:.6g} rad/s = a_max x {T:g} s)",
            ),
        )

    found.sort(key=lambda x: (x[0], x[1], x[2]))
    report.failures = [f for *_, f in found]
    return report
