"""Shared study cases: the small studies many tests run, written once.

``quick_study`` is teachbot6 (or another robot) moving between two joint waypoints with the
classical PTP planner: cheap enough to run dozens of times in a sweep test.
"""

from __future__ import annotations

import json

#: the two joint waypoints of the quick study, in degrees
QUICK_WAYPOINTS_DEG = [[0, 0, 0, 0, 0, 0], [20, 10, 10, 0, 20, 0]]


def quick_study(
    name: str = "quick",
    stages: tuple[str, ...] = ("kinematics", "plan", "static_load"),
    *,
    robot: str = "teachbot6",
    report: bool = False,
    check_dt_s: float | None = 0.01,
    accuracy_samples: int | None = None,
) -> str:
    """The TOML text of the quick study (study file reference: docs/study-file.md)."""
    lines = [
        "[study]",
        f"name = {json.dumps(name)}",
        f"stages = {json.dumps(list(stages))}",
        f"report = {'true' if report else 'false'}",
        "[robot]",
        f"name = {json.dumps(robot)}",
        "[waypoints]",
        'unit = "deg"',
        f"joint = {json.dumps(QUICK_WAYPOINTS_DEG)}",
        "[plan]",
        'planner = "ptp"',
    ]
    if check_dt_s is not None:
        lines.append(f"check_dt_s = {check_dt_s!r}")
    if accuracy_samples is not None:
        lines += ["[kinematics]", f"accuracy_samples = {accuracy_samples}"]
    return "\n".join(lines) + "\n"
