"""File formats of a set-point table: CSV, JSON, NumPy ``.npz`` and a C header.

All four carry the same metadata (robot, cycle period, counts per joint revolution, axis order
and sign, the trajectory's sha256, armlab's version, the controller profile) and the same values:
integers exactly, ``q``/``qd``/``t`` to 1e-9 (the table is stored at that resolution, so CSV, JSON
and NPZ read back equal). Text is built with :mod:`armlab.deploy.numtext` (vectorised NumPy).
"""

from __future__ import annotations

import io
import json
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from armlab.deploy.numtext import format_list, format_rows
from armlab.errors import InputError

if TYPE_CHECKING:
    pass

#: Format tag of every set-point file.
SETPOINTS_FORMAT = "armlab.setpoints/1"
#: q, qd, t_s resolution in every format: 1e-9 rad, rad/s, s.
DECIMALS = 9

__all__ = [
    "SETPOINT_FORMATS",
    "setpoints_format",
    "render_setpoints",
    "read_setpoints_file",
    "c_identifier",
    "c_string",
]

SETPOINT_FORMATS = {"csv": ".csv", "json": ".json", "npz": ".npz", "c": ".h"}
_SUFFIX_TO_FORMAT = {v: k for k, v in SETPOINT_FORMATS.items()}


def setpoints_format(path: Path, format: str | None) -> str:
    """The format to write: ``format`` if given, else from the suffix of ``path``, else csv."""
    if format is None:
        return _SUFFIX_TO_FORMAT.get(path.suffix.lower(), "csv")
    fmt = str(format).lower()
    if fmt not in SETPOINT_FORMATS:
        raise InputError(
            f"unknown set-point format {format!r} (one of {', '.join(SETPOINT_FORMATS)})"
        )
    return fmt


def _decimals(table) -> list[int]:

    return [0, DECIMALS] + [DECIMALS, DECIMALS, 0, 0] * table.n_axes


def render_setpoints(table, fmt: str) -> bytes:
    """The bytes of ``table`` in ``fmt`` (csv, json, npz, c)."""
    fmt = setpoints_format(Path(""), fmt)
    return {"csv": _csv, "json": _json, "npz": _npz, "c": _c_header}[fmt](table)


# ---------------------------------------------------------------------- CSV
def _csv(table) -> bytes:
    meta = table.header_meta()
    cpr = " ".join(f"{j}={c:.10g}" for j, c in meta["counts_per_joint_rev"].items())
    pulses = meta.get("max_pulses_per_cycle")
    signs = " ".join(f"{j}={s:+d}" for j, s in zip(meta["joints"], meta["axis_sign"], strict=True))
    lines = [
        f"# armlab set-point table ({meta['format']}): one row per controller cycle",
        f"# robot: {meta['robot']}",
        f"# cycle_s: {meta['cycle_s']!r}",
        f"# n_cycles: {meta['n_cycles']}",
        f"# counts_per_joint_rev: {cpr}",
        f"# axis_sign: {signs}",
        f"# profile: {meta.get('profile', '')} (max pulses per cycle: "
        f"{'none' if pulses is None else pulses})",
        f"# trajectory_sha256: {meta.get('trajectory_sha256', '')}",
        f"# armlab_version: {meta.get('armlab_version', '')}",
        f"# meta: {json.dumps(meta, allow_nan=False)}",
        ",".join(table.column_names()),
    ]
    head = ("\n".join(lines) + "\n").encode()
    cols = table.columns()
    body = format_rows(list(cols.values()), _decimals(table), names=list(cols))
    return head + body


def _read_csv(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    meta = None
    with open(path, "rb") as f:
        n_comment = 0
        while True:
            line = f.readline()
            if not line:
                raise InputError(f"{path}: no column header line")
            s = line.decode("utf-8", errors="replace").rstrip("\r\n")
            if s.startswith("#"):
                n_comment += 1
                if s.startswith("# meta: "):
                    try:
                        meta = json.loads(s[len("# meta: ") :])
                    except json.JSONDecodeError:
                        raise InputError(f"{path}: unreadable '# meta:' line") from None
                continue
            names = s.split(",")
            break
        if meta is None:
            raise InputError(f"{path}: not an armlab set-point CSV (no '# meta:' line)")
        try:
            data = np.loadtxt(f, delimiter=",", dtype=np.float64, ndmin=2)
        except ValueError as exc:
            raise InputError(f"{path}: unreadable numbers ({str(exc).splitlines()[0]})") from None
    if data.size == 0:
        data = np.zeros((0, len(names)))
    if data.shape[1] != len(names):
        raise InputError(f"{path}: {data.shape[1]} values per row for {len(names)} columns")
    return meta, {name: data[:, i] for i, name in enumerate(names)}


# ---------------------------------------------------------------------- JSON
def _json(table) -> bytes:
    meta = table.header_meta()
    parts = [
        b'{"format": ',
        json.dumps(meta["format"]).encode(),
        b', "meta": ',
        json.dumps(meta, allow_nan=False).encode(),
        b', "columns": {',
    ]
    cols = table.columns()
    for i, ((name, values), d) in enumerate(zip(cols.items(), _decimals(table), strict=True)):
        parts += [
            b"\n  " if i == 0 else b",\n  ",
            json.dumps(name).encode(),
            b": [",
            format_list(values, d, sep=", ", name=name),
            b"]",
        ]
    parts.append(b"\n}}\n")
    return b"".join(parts)


def _read_json(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    try:
        d = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not JSON ({exc.msg} at line {exc.lineno})") from None
    if not isinstance(d, dict) or "meta" not in d or "columns" not in d:
        raise InputError(f"{path}: not an armlab set-point JSON (no meta/columns)")
    cols = {}
    for name, values in d["columns"].items():
        a = np.asarray(values)
        cols[name] = a if a.dtype.kind in "iu" else a.astype(float)
    return d["meta"], cols


# ---------------------------------------------------------------------- NPZ
def _npz(table) -> bytes:
    buf = io.BytesIO()
    np.savez(
        buf,
        meta_json=np.array(json.dumps(table.header_meta(), allow_nan=False)),
        joint_names=np.array(table.joint_names),
        cycle=table.cycle,
        t_s=table.t_s,
        q_rad=table.q_rad,
        qd_rad_s=table.qd_rad_s,
        counts=table.counts,
        dcounts=table.dcounts,
        counts_per_rad=table.counts_per_rad,
        axis_sign=table.axis_sign,
    )
    return buf.getvalue()


def _read_npz(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: not a readable .npz ({exc})") from None
    if "meta_json" not in arrays:
        raise InputError(f"{path}: not an armlab set-point .npz (no meta_json)")
    meta = json.loads(str(arrays["meta_json"]))
    cols = {"cycle": arrays["cycle"], "t_s": arrays["t_s"]}
    for a, j in enumerate(meta["joints"]):
        cols[f"q_{j}_rad"] = arrays["q_rad"][:, a]
        cols[f"qd_{j}_rad_s"] = arrays["qd_rad_s"][:, a]
        cols[f"counts_{j}"] = arrays["counts"][:, a]
        cols[f"dcounts_{j}"] = arrays["dcounts"][:, a]
    return meta, cols


# ---------------------------------------------------------------------- C header
def c_identifier(text: str) -> str:
    """An upper-case C identifier from any text (``joint-1`` -> ``JOINT_1``)."""
    s = re.sub(r"[^0-9A-Za-z_]", "_", str(text)).upper()
    return s if s and not s[0].isdigit() else f"_{s}"


def c_string(text: str) -> str:
    """A C string literal (quotes and backslashes escaped, non-ASCII dropped)."""
    s = str(text).encode("ascii", "ignore").decode()
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", " ") + '"'


def _c_array_2d(name: str, values: np.ndarray) -> bytes:
    head = f"static const int32_t {name}[ARMLAB_SP_N_CYCLES][ARMLAB_SP_N_AXES] = {{\n".encode()
    if values.size == 0:
        return head + b"    {0}\n};\n"
    body = format_rows(
        [values[:, a] for a in range(values.shape[1])],
        0,
        sep=", ",
        prefix="    {",
        suffix="},\n",
        names=[name] * values.shape[1],
    )
    return head + body[:-2] + b"\n};\n"


def _c_header(table) -> bytes:
    meta = table.header_meta()
    if np.abs(table.counts).max(initial=0) > 2**31 - 1:
        raise InputError("counts do not fit int32 for the C header")
    T = table.cycle_s
    pulses = meta.get("max_pulses_per_cycle")
    joints = ", ".join(c_string(j) for j in table.joint_names)
    lines = [
        "/* armlab set-point table -- generated by armlab.deploy, do not edit.",
        f" * robot {meta['robot']}, {table.n_cycles} cycles of {T:g} s, axes "
        f"{', '.join(table.joint_names)} (profile {meta.get('profile', '')}).",
        " * ARMLAB_SP_COUNTS[k][a]:  absolute motor-encoder counts of axis a at the end of cycle k",
        " *                          (round(q x counts_per_rad x sign); 0 = joint zero).",
        " * ARMLAB_SP_DCOUNTS[k][a]: pulses axis a moves during cycle k (COUNTS[k] - COUNTS[k-1];",
        " *                          0 on cycle 0, which is the start pose).",
        " */",
        "#ifndef ARMLAB_SETPOINTS_H",
        "#define ARMLAB_SETPOINTS_H",
        "",
        "#include <stdint.h>",
        "",
        f"#define ARMLAB_SP_FORMAT {c_string(meta['format'])}",
        f"#define ARMLAB_SP_ROBOT {c_string(meta['robot'])}",
        f"#define ARMLAB_SP_PROFILE {c_string(meta.get('profile', ''))}",
        f"#define ARMLAB_SP_TRAJECTORY_SHA256 {c_string(meta.get('trajectory_sha256', ''))}",
        f"#define ARMLAB_SP_ARMLAB_VERSION {c_string(meta.get('armlab_version', ''))}",
    ]
    src = meta.get("source") or {}
    if src:
        lines += [
            f"#define ARMLAB_SP_SOURCE_FILE {c_string(src.get('file', ''))}",
            f"#define ARMLAB_SP_SOURCE_SHA256 {c_string(src.get('sha256', ''))}",
        ]
    lines += [
        f"#define ARMLAB_SP_N_CYCLES {table.n_cycles}",
        f"#define ARMLAB_SP_N_AXES {table.n_axes}",
        f"#define ARMLAB_SP_CYCLE_S {T!r}",
        f"#define ARMLAB_SP_CYCLE_US {round(T * 1e6)}",
        f"#define ARMLAB_SP_MAX_PULSES_PER_CYCLE {-1 if pulses is None else int(pulses)}"
        + ("  /* -1: no limit */" if pulses is None else ""),
        "",
        f"static const char *const ARMLAB_SP_AXIS_JOINT[ARMLAB_SP_N_AXES] = {{{joints}}};",
        "static const int32_t ARMLAB_SP_AXIS_SIGN[ARMLAB_SP_N_AXES] = {"
        + ", ".join(str(int(s)) for s in table.axis_sign)
        + "};",
        "/* encoder counts per joint revolution (pulses x decoding x reducer ratio) */",
        "static const double ARMLAB_SP_COUNTS_PER_JOINT_REV[ARMLAB_SP_N_AXES] = {"
        + ", ".join(repr(float(c)) for c in table.counts_per_joint_rev)
        + "};",
        "static const int32_t ARMLAB_SP_START_COUNTS[ARMLAB_SP_N_AXES] = {"
        + ", ".join(
            str(int(c))
            for c in (table.counts[0] if table.n_cycles else np.zeros(table.n_axes, int))
        )
        + "};",
        "",
    ]
    out = ("\n".join(lines) + "\n").encode()
    out += _c_array_2d("ARMLAB_SP_COUNTS", table.counts) + b"\n"
    out += _c_array_2d("ARMLAB_SP_DCOUNTS", table.dcounts)
    out += b"\n#endif /* ARMLAB_SETPOINTS_H */\n"
    return out


# ---------------------------------------------------------------------- reading
def read_setpoints_file(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    """Read a CSV, JSON or NPZ set-point file: ``(metadata, named columns)``, format checked
    (:func:`armlab.deploy.read_setpoints` builds the table from them)."""
    if not path.is_file():
        raise InputError(f"set-point file {path} not found")
    fmt = _SUFFIX_TO_FORMAT.get(path.suffix.lower())
    readers = {"csv": _read_csv, "json": _read_json, "npz": _read_npz}
    if fmt not in readers:
        raise InputError(
            f"{path}: cannot read set-points from {path.suffix!r} files (.csv, .json, .npz)"
        )
    meta, cols = readers[fmt](path)
    if meta.get("format") != SETPOINTS_FORMAT:
        raise InputError(f"{path}: format {meta.get('format')!r} is not {SETPOINTS_FORMAT!r}")
    return meta, cols
