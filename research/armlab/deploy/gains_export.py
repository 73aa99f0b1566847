"""Servo gains for the real controller: JSON (source of truth), ros2_control YAML, C header.

Input is an :class:`armlab.control.ArmGains` (a study's ``gains.json``): per joint the current,
speed and position loops of the thesis' cascade (ch. 5), each with continuous parallel-form
gains ``C(s) = kp + ki/s + kd s/(Tf s + 1)``, the incremental (velocity-form) PID coefficients
``u_k = u_{k-1} + q0 e_k + q1 e_{k-1} + q2 e_{k-2}``, sample time, output saturation, D/A
scaling, units and signal names (see :mod:`armlab.control.gains`).

* JSON: ``ArmGains.to_dict()`` plus a ``provenance`` block (sha256 of the gains' canonical JSON,
  armlab version, source file); :func:`load_gains` reads it (or a plain ``gains.json``) back
  into the control objects and verifies the checksum.
* YAML (ros2_control ``joint_trajectory_controller``): per joint ``p, i, d, i_clamp`` of the
  position loop, which maps the joint position error [rad] to a joint velocity command [rad/s]
  (the same numbers motor side and joint side, because error and command both scale with the
  reducer ratio); ``i_clamp`` is the loop's output limit over the ratio, in [rad/s]. Written by
  hand (no YAML dependency).
* C header: a ``armlab_pid_t`` struct per joint and loop with continuous and incremental gains,
  sample time, saturation, derivative filter and D/A scaling; units and signal names as strings.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from armlab.deploy.formats import c_identifier, c_string
from armlab.deploy.provenance import armlab_version, gains_sha256
from armlab.errors import InputError
from armlab.io import atomic_write

if TYPE_CHECKING:
    from armlab.control import ArmGains

__all__ = [
    "GAINS_FORMATS",
    "gains_to_json",
    "gains_to_ros2_yaml",
    "gains_to_c_header",
    "render_gains",
    "write_gains",
    "load_gains",
]

GAINS_FORMATS = {"json": ".json", "ros2": ".yaml", "yaml": ".yaml", "c": ".h"}
_LOOPS = ("current", "speed", "position")


def _as_arm_gains(gains):
    from armlab.control import ArmGains, CascadeGains

    if isinstance(gains, ArmGains):
        return gains
    if isinstance(gains, CascadeGains):
        return ArmGains(joints={gains.joint: gains})
    if isinstance(gains, dict):
        return ArmGains.from_dict(gains)
    raise InputError(f"expected ArmGains or CascadeGains, got {type(gains).__name__}")


def _provenance(arm, source: dict | None) -> dict:
    out: dict[str, Any] = {"gains_sha256": gains_sha256(arm), "armlab_version": armlab_version()}
    if source:
        out["source"] = dict(source)
    return out


def gains_to_json(gains, *, source: dict | None = None) -> str:
    """The gains JSON: ``ArmGains.to_dict()`` plus ``provenance`` (sha256, version, source)."""
    arm = _as_arm_gains(gains)
    d = arm.to_dict()
    d["provenance"] = _provenance(arm, source)
    return json.dumps(d, indent=2, allow_nan=False) + "\n"


def load_gains(path: str | os.PathLike) -> ArmGains:
    """Read gains JSON (ours or a study's ``gains.json``) into an :class:`armlab.control.ArmGains`.

    Raises
    ------
    InputError
        Missing file, not gains JSON, or a ``provenance.gains_sha256`` that does not match.
    """
    from armlab.control import ArmGains

    path = Path(path)
    if not path.is_file():
        raise InputError(f"gains file {path} not found")
    try:
        d = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not JSON ({exc.msg} at line {exc.lineno})") from None
    if not isinstance(d, dict):
        raise InputError(f"{path}: not a gains JSON object")
    arm = ArmGains.from_dict(d)
    want = (d.get("provenance") or {}).get("gains_sha256")
    if want is not None and gains_sha256(arm) != want:
        raise InputError(f"{path}: gains checksum mismatch: the file was edited or is corrupt")
    return arm


# ---------------------------------------------------------------------- YAML
def _yaml_float(x: float) -> str:
    x = float(x)
    if math.isnan(x):
        return ".nan"
    if math.isinf(x):
        return ".inf" if x > 0 else "-.inf"
    s = repr(x)
    if "e" in s and "." not in s.split("e")[0]:  # 1e-05 is a string in YAML 1.1: write 1.0e-05
        mant, exp = s.split("e")
        s = f"{mant}.0e{exp}"
    return s


def _yaml_key(s: str) -> str:
    s = str(s)
    plain = (
        s
        and all(c.isalnum() or c in "_-/" for c in s)
        and not s[0].isdigit()
        and s.lower() not in ("true", "false", "yes", "no", "on", "off", "null", "y", "n")
    )
    return s if plain else json.dumps(s)


def gains_to_ros2_yaml(
    gains, *, controller: str = "joint_trajectory_controller", source: dict | None = None
) -> str:
    """ros2_control ``joint_trajectory_controller`` parameters with the position-loop gains.

    Per joint: ``p`` [1/s] (rad/s per rad), ``i`` [1/s^2], ``d`` [1], ``i_clamp`` [rad/s]
    (position-loop output limit / reducer ratio; ``.inf`` if unlimited) and
    ``ff_velocity_scale: 1.0`` (the planned velocity is fed forward). JTC control law
    ``u = k_ff v_d + p e + i sum(e dt) + d (v_d - v)`` with a velocity command interface.
    """
    arm = _as_arm_gains(gains)
    prov = _provenance(arm, source)
    lines = [
        "# ros2_control joint_trajectory_controller gains -- generated by armlab.deploy, "
        "do not edit.",
        f"# robot: {arm.robot or '?'}; gains sha256: {prov['gains_sha256']}; "
        f"armlab {prov['armlab_version']}",
    ]
    if source:
        lines.append(f"# source: {json.dumps(source)}")
    lines += [
        "# Position loop of the cascade (thesis ch. 5), joint side: p [1/s], i [1/s^2], d [1];",
        "# i_clamp [rad/s] = position-loop output limit (motor speed) / reducer ratio.",
        f"{_yaml_key(controller)}:",
        "  ros__parameters:",
        "    joints:",
    ]
    lines += [f"      - {_yaml_key(j)}" for j in arm.joint_names]
    lines += [
        "    command_interfaces:",
        "      - velocity",
        "    state_interfaces:",
        "      - position",
        "      - velocity",
        "    gains:",
    ]
    for name, cg in arm.joints.items():
        pos = cg.position
        ratio = cg.plant.ratio if cg.plant is not None and cg.plant.ratio > 0 else 1.0
        clamp = max(abs(pos.output_min), abs(pos.output_max)) / ratio
        lines += [
            f"      {_yaml_key(name)}:",
            f"        p: {_yaml_float(pos.kp)}",
            f"        i: {_yaml_float(pos.ki)}",
            f"        d: {_yaml_float(pos.kd)}",
            f"        i_clamp: {_yaml_float(clamp)}",
            "        ff_velocity_scale: 1.0",
        ]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------- C header
def _c_double(x) -> str:
    x = float(x) if x is not None else math.nan
    if math.isnan(x):
        return "NAN"
    if math.isinf(x):
        return "INFINITY" if x > 0 else "-INFINITY"
    return repr(x)


_PID_FIELDS = (
    "kp",
    "ki",
    "kd",
    "q0",
    "q1",
    "q2",
    "sample_time_s",
    "output_min",
    "output_max",
    "derivative_filter_s",
    "output_per_volt",
)


def gains_to_c_header(gains, *, prefix: str = "ARMLAB_GAINS", source: dict | None = None) -> str:
    """A C header with every joint's three loops (see the module docstring)."""
    arm = _as_arm_gains(gains)
    prov = _provenance(arm, source)
    P = c_identifier(prefix)
    n = len(arm)
    from armlab.control import LOOP_UNITS

    lines = [
        "/* armlab servo gains -- generated by armlab.deploy, do not edit.",
        f" * robot {arm.robot or '?'}; joints {', '.join(arm.joint_names)}.",
        " * Cascade per joint (thesis ch. 5): position -> speed -> current, all motor side.",
        " * Continuous:  C(s) = kp + ki/s + kd s / (derivative_filter_s s + 1)",
        " * Incremental: u_k = u_{k-1} + q0 e_k + q1 e_{k-1} + q2 e_{k-2}, then",
        " *              clamp u_k to [output_min, output_max] (every sample_time_s).",
        " * output_per_volt: loop output per D/A volt (0: the loop does not drive the D/A).",
        " */",
        f"#ifndef {P}_H",
        f"#define {P}_H",
        "",
        "#include <math.h>",
        "#include <stdint.h>",
        "",
        f'#define {P}_FORMAT "armlab.gains.h/1"',
        f"#define {P}_ROBOT {c_string(arm.robot)}",
        f"#define {P}_SHA256 {c_string(prov['gains_sha256'])}",
        f"#define {P}_ARMLAB_VERSION {c_string(prov['armlab_version'])}",
    ]
    if prov.get("source"):
        lines += [
            f"#define {P}_SOURCE_FILE {c_string(prov['source'].get('file', ''))}",
            f"#define {P}_SOURCE_SHA256 {c_string(prov['source'].get('sha256', ''))}",
        ]
    lines += [
        f"#define {P}_N_JOINTS {n}",
        f"#define {P}_N_LOOPS 3",
        f"#define {P}_LOOP_CURRENT 0",
        f"#define {P}_LOOP_SPEED 1",
        f"#define {P}_LOOP_POSITION 2",
    ]
    da = next(
        (lg for cg in arm for lg in cg.loops().values() if lg.output_per_volt is not None), None
    )
    if da is not None:
        lines += [
            f"#define {P}_DA_BITS {int(da.da_bits)}",
            f"#define {P}_DA_RANGE_V {_c_double(da.da_range_V)}",
        ]
    lines += [
        "",
        "#ifndef ARMLAB_PID_T_DEFINED",
        "#define ARMLAB_PID_T_DEFINED",
        "typedef struct {",
        "    double kp, ki, kd;          /* continuous parallel-form gains (units below) */",
        "    double q0, q1, q2;          /* incremental PID coefficients */",
        "    double sample_time_s;       /* [s] */",
        "    double output_min, output_max; /* saturation, in the loop's output unit */",
        "    double derivative_filter_s; /* [s], 0: none */",
        "    double output_per_volt;     /* D/A scaling [output unit / V], 0 if none */",
        "} armlab_pid_t;",
        "#endif",
        "",
        f"static const char *const {P}_LOOP_NAME[3] = "
        + "{"
        + ", ".join(c_string(lp) for lp in _LOOPS)
        + "};",
    ]
    for key in ("input", "output", "kp", "ki", "kd"):
        lines.append(
            f"static const char *const {P}_UNIT_{key.upper()}[3] = "
            + "{"
            + ", ".join(c_string(LOOP_UNITS[lp][key]) for lp in _LOOPS)
            + "};"
        )
    lines.append(
        f"static const char *const {P}_JOINT[{P}_N_JOINTS] = "
        + "{"
        + ", ".join(c_string(j) for j in arm.joint_names)
        + "};"
    )
    ratios = [cg.plant.ratio if cg.plant is not None else 1.0 for cg in arm]
    lines.append(
        f"static const double {P}_REDUCER_RATIO[{P}_N_JOINTS] = "
        + "{"
        + ", ".join(_c_double(r) for r in ratios)
        + "};"
    )
    for key, attr in (("INPUT_SIGNAL", "input_signal"), ("OUTPUT_SIGNAL", "output_signal")):
        rows = [
            "{" + ", ".join(c_string(getattr(cg.loops()[lp], attr)) for lp in _LOOPS) + "}"
            for cg in arm
        ]
        lines.append(
            f"static const char *const {P}_{key}[{P}_N_JOINTS][3] = {{" + ", ".join(rows) + "};"
        )
    lines += ["", f"static const armlab_pid_t {P}[{P}_N_JOINTS][3] = {{"]
    for j, cg in enumerate(arm):
        lines.append(f"    {{ /* {cg.joint} */")
        for lp in _LOOPS:
            lg = cg.loops()[lp]
            vals = []
            for f in _PID_FIELDS:
                v = getattr(lg, f)
                vals.append(_c_double(0.0 if (f == "output_per_volt" and v is None) else v))
            lines.append(
                f"        {{{', '.join(vals)}}}, /* {lp}: {lg.kind}, {lg.method}, "
                f"{lg.input_signal} -> {lg.output_signal} */"
            )
        lines[-1] = lines[-1].replace("}, /*", "}  /*", 1)
        lines.append("    }" + ("," if j < n - 1 else ""))
    lines += ["};", "", f"#endif /* {P}_H */", ""]
    return "\n".join(lines)


# ---------------------------------------------------------------------- files
def render_gains(gains, fmt: str, *, source: dict | None = None) -> str:
    """The text of the gains in ``fmt`` (json, ros2/yaml, c)."""
    fmt = str(fmt).lower()
    if fmt == "json":
        return gains_to_json(gains, source=source)
    if fmt in ("ros2", "yaml"):
        return gains_to_ros2_yaml(gains, source=source)
    if fmt == "c":
        return gains_to_c_header(gains, source=source)
    raise InputError(f"unknown gains format {fmt!r} (json, ros2, c)")


def write_gains(
    path: str | os.PathLike, gains, format: str | None = None, *, source: dict | None = None
) -> Path:
    """Write gains to ``path`` atomically (argument order as :func:`save_trajectory`).

    Parameters
    ----------
    path : path
    gains : ArmGains or CascadeGains
    format : {"json", "ros2", "c"}, optional
        Default from the suffix: .json, .yaml/.yml (ros2_control), .h; else json.
    source : dict, optional
        Provenance recorded in the file (e.g. ``{"file": "gains.json", "sha256": ...}``).
    """
    path = Path(path)
    if format is None:
        format = {".json": "json", ".yaml": "ros2", ".yml": "ros2", ".h": "c"}.get(
            path.suffix.lower(), "json"
        )
    return atomic_write(path, render_gains(gains, format, source=source))
