"""Servo gains for the real controller: JSON (source of truth), ros2_control YAML, C.

Input is an :class:`armlab.control.ArmGains` (a study's ``gains.json``): per joint the current,
speed and position loops of the thesis' cascade (ch. 5), each with continuous parallel-form
gains ``C(s) = kp + ki/s + kd s/(Tf s + 1)``, the incremental (velocity-form) PID coefficients
``u_k = u_{k-1} + q0 e_k + q1 e_{k-1} + q2 e_{k-2}``, sample time, output saturation, D/A
scaling, units and signal names (see :mod:`armlab.control.gains`).

* JSON: ``ArmGains.to_dict()`` plus a ``provenance`` block (sha256 of the gains' canonical JSON,
  armlab version, source file), with numbers only: an infinite value (a gain margin without
  phase crossover, an unlimited output) is ``null`` plus a flag, ``"gain_margin_dB": null,
  "gain_margin_dB_infinite": true`` (``..._negative_infinite`` for -inf); NaN (unknown) is a
  plain ``null``. :func:`load_gains` reads it (or a study's plain ``gains.json``, whose
  infinities are the strings ``"inf"``) back into the control objects -- infinities as ``inf``
  -- and verifies the checksum.
* YAML: the ros2_control controllers file of :func:`armlab.deploy.ros2.ros2_controllers_yaml`
  (``controller_manager`` block, ``joint_trajectory_controller`` parameters with the position
  loop as per-joint ``p, i, d, u_clamp_*, i_clamp_*, antiwindup_strategy, ff_velocity_scale``).
* C: a header (``#define`` metadata, the ``armlab_pid_f64_t`` or ``armlab_pid_f32_t`` struct,
  ``extern`` declarations) and one data file ``.c`` defining the arrays once: per joint and loop
  the continuous and incremental gains, sample time, saturation, derivative filter and D/A
  scaling in ``double`` or ``float`` (``real=``); units and signal names as strings.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab.deploy.formats import c_comment, c_identifier, c_source_lines, c_string
from armlab.deploy.provenance import armlab_version, gains_sha256
from armlab.errors import InputError
from armlab.io import atomic_write_many

if TYPE_CHECKING:
    from armlab.control import ArmGains

__all__ = [
    "GAINS_FORMATS",
    "C_REAL_TYPES",
    "gains_to_json",
    "gains_to_ros2_yaml",
    "gains_to_c_header",
    "gains_to_c_files",
    "render_gains",
    "gains_files",
    "write_gains",
    "load_gains",
]

GAINS_FORMATS = {"json": ".json", "ros2": ".yaml", "yaml": ".yaml", "c": ".h"}
#: C floating types of the gains: ``real=`` -> (C type, bits).
C_REAL_TYPES = {"double": ("double", 64), "float": ("float", 32)}
_LOOPS = ("current", "speed", "position")
_INF_FLAG = "_infinite"
_NEG_INF_FLAG = "_negative_infinite"


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


def _flag_infinities(x: Any) -> Any:
    """``{"k": "inf"}`` -> ``{"k": None, "k_infinite": True}`` (``"-inf"``:
    ``k_negative_infinite``), through nested dicts and lists: strict JSON with numbers only."""
    if isinstance(x, dict):
        out: dict[str, Any] = {}
        for k, v in x.items():
            if isinstance(v, str) and v in ("inf", "-inf"):
                out[k] = None
                out[f"{k}{_INF_FLAG if v == 'inf' else _NEG_INF_FLAG}"] = True
            else:
                out[k] = _flag_infinities(v)
        return out
    if isinstance(x, list):
        return [_flag_infinities(v) for v in x]
    return x


def _unflag_infinities(x: Any) -> Any:
    """Inverse of :func:`_flag_infinities`: ``null`` + flag -> ``"inf"`` / ``"-inf"`` (the form
    ``ArmGains.from_dict`` reads as ``inf``)."""
    if isinstance(x, dict):
        out = {k: _unflag_infinities(v) for k, v in x.items()}
        for k in list(out):
            for flag, value in ((_NEG_INF_FLAG, "-inf"), (_INF_FLAG, "inf")):
                base = k[: -len(flag)]
                if k.endswith(flag) and out[k] is True and base in out and out[base] is None:
                    out[base] = value
                    del out[k]
                    break
        return out
    if isinstance(x, list):
        return [_unflag_infinities(v) for v in x]
    return x


def gains_to_json(gains, *, source: dict | None = None) -> str:
    """The gains JSON: ``ArmGains.to_dict()`` (infinities as ``null`` + flag, see the module
    docstring) plus ``provenance`` (sha256, version, source)."""
    arm = _as_arm_gains(gains)
    d = _flag_infinities(arm.to_dict())
    d["provenance"] = _provenance(arm, source)
    return json.dumps(d, indent=2, allow_nan=False) + "\n"


def load_gains(path: str | os.PathLike) -> ArmGains:
    """Read gains JSON (ours or a study's ``gains.json``) into an :class:`armlab.control.ArmGains`.

    Infinite values come back as ``inf`` from both encodings (``null`` + ``<key>_infinite``, or
    the string ``"inf"``).

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
    arm = ArmGains.from_dict(_unflag_infinities(d))
    want = (d.get("provenance") or {}).get("gains_sha256")
    if want is not None and gains_sha256(arm) != want:
        raise InputError(f"{path}: gains checksum mismatch: the file was edited or is corrupt")
    return arm


# ---------------------------------------------------------------------- YAML
def gains_to_ros2_yaml(
    gains,
    *,
    controller_name: str = "joint_trajectory_controller",
    source: dict | None = None,
    **kw,
) -> str:
    """The ros2_control controllers YAML of ``gains``
    (:func:`armlab.deploy.ros2.ros2_controllers_yaml`; ``kw``: its ``update_rate_hz``,
    ``constraints``, ``joints``, ``ff_velocity_scale``)."""
    from armlab.deploy.ros2 import ros2_controllers_yaml

    return ros2_controllers_yaml(gains, controller_name=controller_name, source=source, **kw)


# ---------------------------------------------------------------------- C
def _c_real(x, real: str) -> str:
    """A C literal of ``x`` for the type ``real`` (``float``: shortest float32 text + ``f``)."""
    x = float(x) if x is not None else math.nan
    if real == "float" and math.isfinite(x):
        with np.errstate(over="ignore"):
            x = float(np.float32(x))  # beyond float's range: INFINITY
    if math.isnan(x):
        return "NAN"
    if math.isinf(x):
        return "INFINITY" if x > 0 else "-INFINITY"
    return f"{np.float32(x)}f" if real == "float" else repr(x)


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


def gains_to_c_files(
    gains,
    *,
    prefix: str = "ARMLAB_GAINS",
    real: str = "double",
    header_name: str = "gains.h",
    source: dict | None = None,
) -> tuple[str, str]:
    """``(header, data file)`` of every joint's three loops (see the module docstring).

    Parameters
    ----------
    gains : ArmGains or CascadeGains
    prefix : str
        Prefix of every C name (upper-cased identifier).
    real : {"double", "float"}
        C type of the gains and limits (struct ``armlab_pid_f64_t`` or ``armlab_pid_f32_t``).
    header_name : str
        File name of the header, included by the data file.
    source : dict, optional
        Provenance (``file``, ``sha256``) recorded as ``#define``.
    """
    if real not in C_REAL_TYPES:
        raise InputError(f"unknown C real type {real!r} (one of {', '.join(C_REAL_TYPES)})")
    ctype, bits = C_REAL_TYPES[real]
    struct = f"armlab_pid_f{bits}_t"
    arm = _as_arm_gains(gains)
    prov = _provenance(arm, source)
    P = c_identifier(prefix)
    guard = c_identifier(Path(header_name).name)
    n = len(arm)
    if n == 0:
        raise InputError("no joints in the gains (C has no empty arrays)")
    from armlab.control.gains import LOOP_UNITS

    h = [
        "/* armlab servo gains -- generated by armlab.deploy, do not edit.",
        f" * robot {c_comment(arm.robot or '-')}; joints {c_comment(', '.join(arm.joint_names))}.",
        " * Cascade per joint (thesis ch. 5): position -> speed -> current, all motor side.",
        " * Continuous:  C(s) = kp + ki/s + kd s / (derivative_filter_s s + 1)",
        " * Incremental: u_k = u_{k-1} + q0 e_k + q1 e_{k-1} + q2 e_{k-2}, then",
        " *              clamp u_k to [output_min, output_max] (every sample_time_s).",
        " * output_per_volt: loop output per D/A volt (0: the loop does not drive the D/A).",
        f" * Values in {ctype}; defined once, in {c_comment(Path(header_name).stem)}.c.",
        " */",
        f"#ifndef {guard}",
        f"#define {guard}",
        "",
        f'#define {P}_FORMAT "armlab.gains.h/2"',
        f"#define {P}_ROBOT {c_string(arm.robot)}",
        f"#define {P}_SHA256 {c_string(prov['gains_sha256'])}",
        f"#define {P}_ARMLAB_VERSION {c_string(prov['armlab_version'])}",
    ]
    h += c_source_lines(P, prov.get("source"))
    h += [
        f"#define {P}_N_JOINTS {n}",
        f"#define {P}_N_LOOPS 3",
        f"#define {P}_LOOP_CURRENT 0",
        f"#define {P}_LOOP_SPEED 1",
        f"#define {P}_LOOP_POSITION 2",
        f"#define {P}_REAL_BITS {bits}",
    ]
    da = next(
        (lg for cg in arm for lg in cg.loops().values() if lg.output_per_volt is not None), None
    )
    if da is not None:
        h += [
            f"#define {P}_DA_BITS {int(da.da_bits)}",
            f"#define {P}_DA_RANGE_V {_c_real(da.da_range_V, 'double')}",
        ]
    h += [
        "",
        f"#ifndef {struct.upper()}_DEFINED",
        f"#define {struct.upper()}_DEFINED",
        "typedef struct {",
        f"    {ctype} kp, ki, kd;          /* continuous parallel-form gains (units below) */",
        f"    {ctype} q0, q1, q2;          /* incremental PID coefficients */",
        f"    {ctype} sample_time_s;       /* [s] */",
        f"    {ctype} output_min, output_max; /* saturation, in the loop's output unit */",
        f"    {ctype} derivative_filter_s; /* [s], 0: none */",
        f"    {ctype} output_per_volt;     /* D/A scaling [output unit / V], 0 if none */",
        f"}} {struct};",
        "#endif",
        "",
        f"extern const char *const {P}_LOOP_NAME[3];",
    ]
    h += [f"extern const char *const {P}_UNIT_{k.upper()}[3];" for k in LOOP_UNITS["speed"]]
    h += [
        f"extern const char *const {P}_JOINT[{P}_N_JOINTS];",
        f"extern const {ctype} {P}_REDUCER_RATIO[{P}_N_JOINTS];",
        f"extern const char *const {P}_INPUT_SIGNAL[{P}_N_JOINTS][3];",
        f"extern const char *const {P}_OUTPUT_SIGNAL[{P}_N_JOINTS][3];",
        f"extern const {struct} {P}[{P}_N_JOINTS][3];",
        "",
        f"#endif /* {guard} */",
        "",
    ]

    c = [
        f"/* armlab servo gains data -- generated by armlab.deploy, do not edit "
        f"(declarations: {header_name}). */",
        f'#include "{header_name}"',
    ]
    include_at = len(c)
    c += [
        "",
        f"const char *const {P}_LOOP_NAME[3] = " + "{" + ", ".join(map(c_string, _LOOPS)) + "};",
    ]
    for key in LOOP_UNITS["speed"]:
        c.append(
            f"const char *const {P}_UNIT_{key.upper()}[3] = "
            + "{"
            + ", ".join(c_string(LOOP_UNITS[lp][key]) for lp in _LOOPS)
            + "};"
        )
    c.append(
        f"const char *const {P}_JOINT[{P}_N_JOINTS] = "
        + "{"
        + ", ".join(c_string(j) for j in arm.joint_names)
        + "};"
    )
    ratios = [cg.plant.ratio if cg.plant is not None else 1.0 for cg in arm]
    c.append(
        f"const {ctype} {P}_REDUCER_RATIO[{P}_N_JOINTS] = "
        + "{"
        + ", ".join(_c_real(r, real) for r in ratios)
        + "};"
    )
    for key, attr in (("INPUT_SIGNAL", "input_signal"), ("OUTPUT_SIGNAL", "output_signal")):
        rows = [
            "{" + ", ".join(c_string(getattr(cg.loops()[lp], attr)) for lp in _LOOPS) + "}"
            for cg in arm
        ]
        c.append(f"const char *const {P}_{key}[{P}_N_JOINTS][3] = {{" + ", ".join(rows) + "};")
    c += ["", f"const {struct} {P}[{P}_N_JOINTS][3] = {{"]
    for j, cg in enumerate(arm):
        c.append(f"    {{ /* {c_comment(cg.joint)} */")
        for lp in _LOOPS:
            lg = cg.loops()[lp]
            vals = []
            for f in _PID_FIELDS:
                v = getattr(lg, f)
                vals.append(_c_real(0.0 if (f == "output_per_volt" and v is None) else v, real))
            c.append(
                f"        {{{', '.join(vals)}}}, /* {lp}: {lg.kind}, {lg.method}, "
                f"{lg.input_signal} -> {lg.output_signal} */"
            )
        c[-1] = c[-1].replace("}, /*", "}  /*", 1)
        c.append("    }" + ("," if j < n - 1 else ""))
    c += ["};", ""]
    if any("INFINITY" in line or "NAN" in line for line in c):
        c.insert(include_at, "#include <math.h> /* INFINITY, NAN */")
    return "\n".join(h), "\n".join(c)


def gains_to_c_header(gains, *, prefix: str = "ARMLAB_GAINS", source: dict | None = None) -> str:
    """The header of :func:`gains_to_c_files` (``double``); the data are in its ``.c`` file."""
    return gains_to_c_files(gains, prefix=prefix, source=source)[0]


# ---------------------------------------------------------------------- files
def render_gains(gains, fmt: str, *, source: dict | None = None) -> str:
    """The text of the gains in ``fmt`` (json, ros2/yaml; c: the header, ``double``)."""
    fmt = str(fmt).lower()
    if fmt == "json":
        return gains_to_json(gains, source=source)
    if fmt in ("ros2", "yaml"):
        return gains_to_ros2_yaml(gains, source=source)
    if fmt == "c":
        return gains_to_c_header(gains, source=source)
    raise InputError(f"unknown gains format {fmt!r} (json, ros2, c)")


def gains_files(
    path: str | os.PathLike,
    gains,
    format: str | None = None,
    *,
    source: dict | None = None,
    real: str = "double",
    **ros2,
) -> list[tuple[Path, str]]:
    """``(path, text)`` of every file :func:`write_gains` writes (C: ``.h`` and ``.c``).

    ``ros2`` keywords go to :func:`armlab.deploy.ros2.ros2_controllers_yaml`.
    """
    path = Path(path)
    if format is None:
        format = {".json": "json", ".yaml": "ros2", ".yml": "ros2", ".h": "c"}.get(
            path.suffix.lower(), "json"
        )
    fmt = str(format).lower()
    if fmt == "c":
        header, data = gains_to_c_files(gains, real=real, header_name=path.name, source=source)
        return [(path, header), (path.with_suffix(".c"), data)]
    if fmt in ("ros2", "yaml"):
        return [(path, gains_to_ros2_yaml(gains, source=source, **ros2))]
    return [(path, render_gains(gains, fmt, source=source))]


def write_gains(
    path: str | os.PathLike,
    gains,
    format: str | None = None,
    *,
    source: dict | None = None,
    real: str = "double",
) -> Path:
    """Write gains to ``path`` atomically (argument order as :func:`save_trajectory`).

    Parameters
    ----------
    path : path
    gains : ArmGains or CascadeGains
    format : {"json", "ros2", "c"}, optional
        Default from the suffix: .json, .yaml/.yml (ros2_control), .h; else json. C writes the
        header at ``path`` and the data file with suffix ``.c`` next to it.
    source : dict, optional
        Provenance recorded in the file (e.g. ``{"file": "gains.json", "sha256": ...}``).
    real : {"double", "float"}
        C type of the gains (C only).

    Returns
    -------
    Path
        ``path`` (C: the header).
    """
    return atomic_write_many(gains_files(path, gains, format, source=source, real=real))[0]
