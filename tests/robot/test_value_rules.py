"""One validator per input kind (issue 24 item 5): a drive value is held to the drives file's
rule wherever it is given (a study's ``[drives.<joint>]``, a drives file), and a controller
profile's fields are checked by their meaning (no truncation, no infinity, no tolerance that
switches the pre-flight off)."""

from __future__ import annotations

import math
import re

import pytest

from armlab.errors import InputError, RobotDescriptionError, SpecError
from armlab.robot.controller import ControllerProfile, list_profiles, load_profile
from armlab.robot.drives_file import read_drives
from armlab.robot.model import robot_desc_dir
from armlab.study.spec import parse_study

JOINTS = [f"joint{i}" for i in range(1, 7)]
DOC = {"robot": {"name": "teachbot6"}, "waypoints": {"joint": [[0.0] * 6, [0.1] * 6]}}


def _toml(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, float) and math.isnan(v):
        return "nan"
    if isinstance(v, float) and math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return repr(v)


def _drives_file_refuses(tmp_path, key: str, value) -> str | None:
    """The message of teachbot6's drives.toml with joint 1's ``key`` set to ``value``, or None
    if it reads."""
    text = (robot_desc_dir() / "teachbot6" / "drives.toml").read_text()
    text, n = re.subn(rf"^{key} = .*$", f"{key} = {_toml(value)}", text, count=1, flags=re.M)
    assert n == 1, key
    path = tmp_path / "drives.toml"
    path.write_text(text)
    try:
        read_drives(path, JOINTS)
    except RobotDescriptionError as exc:
        return str(exc)
    return None


def _study_refuses(key: str, value) -> str | None:
    try:
        parse_study({**DOC, "drives": {"joint1": {key: value}}})
    except SpecError as exc:
        return str(exc)
    return None


VALUES = [3, 4, 2, 1, 0, -1, 1.5, 4.0, 0.6, 1.0, 1.2, 410, 1e300, math.nan, math.inf, True, "4"]


@pytest.mark.parametrize("key", ["decoding", "pulses_per_rev", "ratio", "efficiency", "derating"])
def test_a_drive_value_is_refused_in_a_study_exactly_when_the_drives_file_refuses_it(tmp_path, key):
    for value in VALUES:
        by_file = _drives_file_refuses(tmp_path, key, value)
        by_study = _study_refuses(key, value)
        assert (by_file is None) == (by_study is None), (key, value, by_file, by_study)
        if by_study is not None:
            assert "\n" not in by_study and by_study.startswith(f"drives.joint1.{key}: ")
            # the same words for the same problem
            assert by_file.split(": ")[-1] in by_study, (by_file, by_study)


def test_study_decoding_3_is_refused():
    msg = _study_refuses("decoding", 3)
    assert msg == (
        "drives.joint1.decoding: 3 is not one of 1, 2, 4 (x1, x2, x4 decoding) (as in a drives "
        "file)"
    )


BAD_PROFILE_VALUES = [
    ("decoding", 1.5, "is not an integer"),
    ("decoding", 3, "is not one of 1, 2, 4"),
    ("max_pulses_per_cycle", math.inf, "is not a finite number"),
    ("max_pulses_per_cycle", 4095.5, "is not an integer"),
    ("max_pulses_per_cycle", 0, "is not > 0"),
    ("speed_tolerance", 1e300, "is above 0.01"),
    ("continuity_tolerance", 1e300, "is above 0.5"),
    ("start_tolerance_counts", 1e300, "is above 100"),
    ("speed_tolerance", -1e-6, "is not >= 0"),
    ("max_axes", "x", "is not a number"),
    ("max_axes", 2.5, "is not an integer"),
    ("servo_period_s", math.inf, "is not a finite number"),
    ("servo_period_s", 0.0, "is not > 0"),
    ("dac_bits", 12.5, "is not an integer"),
    ("dac_bits", 64, "is above 32"),
    ("dac_range_V", math.nan, "is not a finite number"),
]


@pytest.mark.parametrize(("key", "value", "why"), BAD_PROFILE_VALUES)
def test_profile_fields_are_checked_by_meaning(tmp_path, key, value, why):
    with pytest.raises(InputError) as exc:
        ControllerProfile(name="p", **{key: value})
    assert str(exc.value).startswith(f"controller profile 'p': {key} {value!r} {why}")
    path = tmp_path / "p.toml"
    path.write_text(f'name = "p"\n{key} = {_toml(value)}\n')
    with pytest.raises(InputError) as exc:
        load_profile(path)
    msg = str(exc.value)
    assert "\n" not in msg and key in msg and why in msg and str(path) in msg


def test_builtin_profiles_and_bounds_still_load():
    for name in list_profiles():
        assert load_profile(name).name == name
    p = ControllerProfile(
        name="edge",
        decoding=2,
        max_pulses_per_cycle=1,
        speed_tolerance=0.01,
        continuity_tolerance=0.5,
        start_tolerance_counts=100.0,
        dac_bits=32,
        servo_period_s=2.0,
    )
    assert (p.decoding, p.max_pulses_per_cycle, p.dac_bits) == (2, 1, 32)
