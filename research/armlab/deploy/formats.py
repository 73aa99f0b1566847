"""File formats of a set-point table: CSV, JSON, NumPy ``.npz`` and C (a header and a data file).

All formats carry the same metadata (robot, cycle period, counts per joint revolution, axis order
and sign, the trajectory's sha256, armlab's version, the controller profile). CSV, JSON and NPZ
carry every column: integers exactly, ``q``/``qd``/``qdd``/``t`` to 1e-9 (the table is stored at
that resolution, so they read back equal). C carries what the controller plays, the integer
counts: ``setpoints.h`` declares them ``extern`` and ``setpoints.c`` defines them once, each
array in the narrowest ``<stdint.h>`` type holding its values (:func:`c_int_type`). Text is built
with :mod:`armlab.deploy.numtext` (vectorised NumPy).

Format ``armlab.setpoints/2`` added the accelerations ``qdd_<joint>_rad_s2``; files of format
``armlab.setpoints/1`` (no accelerations) still read, giving a table whose ``qdd_rad_s2`` is None.
"""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

import numpy as np

from armlab.deploy.numtext import format_list, format_rows
from armlab.errors import InputError
from armlab.names import identifier_key, one_line

#: Format tag of every set-point file written.
SETPOINTS_FORMAT = "armlab.setpoints/2"
#: Format tags read back (``/1``: before accelerations).
READABLE_SETPOINT_FORMATS = ("armlab.setpoints/1", SETPOINTS_FORMAT)
#: q, qd, qdd, t_s resolution in every format: 1e-9 rad, rad/s, rad/s^2, s.
DECIMALS = 9

__all__ = [
    "SETPOINT_FORMATS",
    "SETPOINTS_FORMAT",
    "READABLE_SETPOINT_FORMATS",
    "setpoints_format",
    "render_setpoints",
    "setpoint_files",
    "read_setpoints_file",
    "c_identifier",
    "c_string",
    "c_source_lines",
    "c_comment",
    "c_int_type",
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
    """Decimals of each column, in the order of ``table.columns()``."""
    per = [DECIMALS, DECIMALS] + ([DECIMALS] if table.qdd_rad_s2 is not None else []) + [0, 0]
    return [0, DECIMALS] + per * table.n_axes


def render_setpoints(table, fmt: str) -> bytes:
    """The bytes of ``table`` in ``fmt`` (csv, json, npz; c: the header ``setpoints.h``)."""
    fmt = setpoints_format(Path(""), fmt)
    if fmt == "c":
        return _c_files(table, "setpoints.h")[0]
    return {"csv": _csv, "json": _json, "npz": _npz}[fmt](table)


def setpoint_files(table, path: Path, fmt: str) -> list[tuple[Path, bytes]]:
    """The files of ``table`` in ``fmt`` to write at ``path``: one, or for C the header at
    ``path`` and its data file ``path`` with suffix ``.c``."""
    if fmt == "c":
        header, data = _c_files(table, path.name)
        return [(path, header), (path.with_suffix(".c"), data)]
    return [(path, render_setpoints(table, fmt))]


# ---------------------------------------------------------------------- CSV
def _csv(table) -> bytes:
    meta = table.header_meta()
    cpr = " ".join(f"{j}={c:.10g}" for j, c in meta["counts_per_joint_rev"].items())
    pulses = meta.get("max_pulses_per_cycle")
    signs = " ".join(f"{j}={s:+d}" for j, s in zip(meta["joints"], meta["axis_sign"], strict=True))
    names = table.column_names()
    bad = next((n for n in names if not all(" " <= c <= "~" and c not in ',"' for c in n)), None)
    if bad is not None or len(set(names)) != len(names):
        raise InputError(
            f"CSV column {bad if bad is not None else 'names'!r}: a column name holds a comma, "
            "quote or non-printable character, or repeats (joint names: armlab.names)"
        )
    lines = [
        f"# armlab set-point table ({meta['format']}): one row per controller cycle",
        f"# robot: {one_line(meta['robot'])}",
        f"# cycle_s: {meta['cycle_s']!r}",
        f"# n_cycles: {meta['n_cycles']}",
        f"# counts_per_joint_rev: {one_line(cpr)}",
        f"# axis_sign: {one_line(signs)}",
        f"# profile: {one_line(meta.get('profile', ''))} (max pulses per cycle: "
        f"{'none' if pulses is None else pulses})",
        f"# trajectory_sha256: {meta.get('trajectory_sha256', '')}",
        f"# armlab_version: {meta.get('armlab_version', '')}",
        f"# meta: {json.dumps(meta, allow_nan=False)}",
        ",".join(names),
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
        **({} if table.qdd_rad_s2 is None else {"qdd_rad_s2": table.qdd_rad_s2}),
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
        if "qdd_rad_s2" in arrays:
            cols[f"qdd_{j}_rad_s2"] = arrays["qdd_rad_s2"][:, a]
        cols[f"counts_{j}"] = arrays["counts"][:, a]
        cols[f"dcounts_{j}"] = arrays["dcounts"][:, a]
    return meta, cols


# ---------------------------------------------------------------------- C header
def c_identifier(text: str) -> str:
    """An upper-case C identifier from any text (``joint-1`` -> ``JOINT_1``)."""
    s = identifier_key(str(text))
    return s if s and not s[0].isdigit() else f"_{s}"


def c_string(text: str) -> str:
    """A C string literal holding exactly the UTF-8 bytes of ``text``.

    Printable ASCII stays as it is except ``"``, ``\\`` and ``?`` (escaped: ``\\?`` keeps a
    ``??/`` from being read as a trigraph under ``-std=c99``); every other byte (control
    characters, line breaks, the bytes of non-ASCII characters) is a three-digit octal escape,
    which never runs into the next character. Names reaching here already keep the name policy
    (:mod:`armlab.names`); this is the writer's own defence.
    """
    out = []
    for b in str(text).encode("utf-8", "surrogatepass"):
        c = chr(b)
        if c in '"\\?':
            out.append("\\" + c)
        elif 0x20 <= b <= 0x7E:
            out.append(c)
        else:
            out.append(f"\\{b:03o}")
    return '"' + "".join(out) + '"'


def c_comment(text: str) -> str:
    """``text`` safe inside a C block comment: printable ASCII only (anything else becomes
    ``?``), no ``*/`` or ``/*`` (spaced apart) and no ``??`` (a trigraph ``??/`` before a line
    end would splice lines). Not reversible: comments are for the reader."""
    s = "".join(c if " " <= c <= "~" and c != "\\" else "?" for c in str(text))
    while True:
        t = s.replace("*/", "* /").replace("/*", "/ *").replace("??", "? ?")
        if t == s:
            return s
        s = t


def c_source_lines(prefix: str, source) -> list[str]:
    """The provenance lines of a C header: where its values come from and what a forced export
    was forced past.

    ``PREFIX_SOURCE_FILE`` and ``PREFIX_SOURCE_SHA256`` name the file (``source["file"]``
    and ``["sha256"]``, or a study's ``["study"]`` and ``["study_sha256"]``; written when
    ``source`` is given). ``PREFIX_FORCED`` is 1 when the export was forced past failed checks
    (``source["forced_despite"]``), else 0; then ``PREFIX_N_FAILED_CHECKS`` counts them,
    ``PREFIX_FAILED_CHECKS`` holds them in one string ("; " between them) and a comment lists
    one per line, so that firmware can refuse a forced table with ``#if PREFIX_FORCED``.
    """
    src = dict(source or {})
    failed = [str(c) for c in src.get("forced_despite") or []]
    lines = []
    if src:
        file = src.get("file", src.get("study")) or ""
        sha = src.get("sha256", src.get("study_sha256")) or ""
        lines += [
            f"#define {prefix}_SOURCE_FILE {c_string(file)}",
            f"#define {prefix}_SOURCE_SHA256 {c_string(sha)}",
        ]
    lines.append(f"#define {prefix}_FORCED {1 if failed else 0}")
    if failed:
        lines += [
            f"/* FORCED EXPORT: the design fails {len(failed)} check(s):",
            *(" *   " + c_comment(c) for c in failed),
            " */",
            f"#define {prefix}_N_FAILED_CHECKS {len(failed)}",
            f"#define {prefix}_FAILED_CHECKS {c_string('; '.join(failed))}",
        ]
    return lines


#: ``<stdint.h>`` types from the narrowest, with their ranges.
_C_INT_TYPES = (
    ("int8_t", -(2**7), 2**7 - 1),
    ("uint8_t", 0, 2**8 - 1),
    ("int16_t", -(2**15), 2**15 - 1),
    ("uint16_t", 0, 2**16 - 1),
    ("int32_t", -(2**31), 2**31 - 1),
    ("uint32_t", 0, 2**32 - 1),
    ("int64_t", -(2**63), 2**63 - 1),
)


def c_int_type(values) -> str:
    """The narrowest ``<stdint.h>`` type holding every integer of ``values`` (``int8_t`` for
    none): signed before unsigned of the same width.

    Raises
    ------
    InputError
        A value beyond int64.
    """
    a = np.asarray(values)
    lo = int(a.min()) if a.size else 0
    hi = int(a.max()) if a.size else 0
    for name, tmin, tmax in _C_INT_TYPES:
        if tmin <= lo and hi <= tmax:
            return name
    raise InputError(f"integers {lo} .. {hi} do not fit a C integer type")


def _c_array_2d(ctype: str, name: str, values: np.ndarray) -> bytes:
    head = f"const {ctype} {name}[ARMLAB_SP_N_CYCLES][ARMLAB_SP_N_AXES] = {{\n".encode()
    body = format_rows(
        [values[:, a] for a in range(values.shape[1])],
        0,
        sep=", ",
        prefix="    {",
        suffix="},\n",
        names=[name] * values.shape[1],
    )
    return head + body[:-2] + b"\n};\n"


def _check_c_file_name(header_name: str) -> None:
    """Refuse a header file name ``#include "..."`` cannot carry (C has no escapes there)."""
    name = Path(header_name).name
    if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]*", name):
        raise InputError(
            f"C header name {name!r}: only letters, digits, _ . - (it is written into "
            '#include "...")'
        )


def _c_files(table, header_name: str) -> tuple[bytes, bytes]:
    """``(header, data file)`` of the table; the data file includes ``header_name``."""
    meta = table.header_meta()
    if table.n_cycles == 0 or table.n_axes == 0:
        raise InputError("an empty set-point table has no C arrays (C has no empty arrays)")
    if np.abs(table.counts).max(initial=0) > 2**31 - 1:
        raise InputError("counts do not fit int32 for the C arrays")
    T = table.cycle_s
    pulses = meta.get("max_pulses_per_cycle")
    t_counts, t_dcounts = c_int_type(table.counts), c_int_type(table.dcounts)
    _check_c_file_name(header_name)
    guard = c_identifier(Path(header_name).name)
    lines = [
        "/* armlab set-point table -- generated by armlab.deploy, do not edit.",
        f" * robot {c_comment(meta['robot'])}, {table.n_cycles} cycles of {T:g} s, axes "
        f"{c_comment(', '.join(table.joint_names))} (profile "
        f"{c_comment(meta.get('profile', ''))}).",
        " * ARMLAB_SP_COUNTS[k][a]:  absolute motor-encoder counts of axis a at the end of cycle k",
        " *                          (round(q x counts_per_rad x sign); 0 = joint zero).",
        " * ARMLAB_SP_DCOUNTS[k][a]: pulses axis a moves during cycle k (COUNTS[k] - COUNTS[k-1];",
        " *                          0 on cycle 0, which is the start pose).",
        f" * The data are defined once, in {Path(header_name).stem}.c; each array has the",
        " * narrowest <stdint.h> type that holds its values (armlab_sp_counts_t, ..._dcounts_t).",
        " */",
        f"#ifndef {guard}",
        f"#define {guard}",
        "",
        "#include <stdint.h>",
        "",
        f"#define ARMLAB_SP_FORMAT {c_string(meta['format'])}",
        f"#define ARMLAB_SP_ROBOT {c_string(meta['robot'])}",
        f"#define ARMLAB_SP_PROFILE {c_string(meta.get('profile', ''))}",
        f"#define ARMLAB_SP_TRAJECTORY_SHA256 {c_string(meta.get('trajectory_sha256', ''))}",
        f"#define ARMLAB_SP_ARMLAB_VERSION {c_string(meta.get('armlab_version', ''))}",
    ]
    lines += c_source_lines("ARMLAB_SP", meta.get("source"))
    lines += [
        f"#define ARMLAB_SP_N_CYCLES {table.n_cycles}",
        f"#define ARMLAB_SP_N_AXES {table.n_axes}",
        f"#define ARMLAB_SP_CYCLE_S {T!r}",
        f"#define ARMLAB_SP_CYCLE_US {round(T * 1e6)}",
        f"#define ARMLAB_SP_MAX_PULSES_PER_CYCLE {-1 if pulses is None else int(pulses)}"
        + ("  /* -1: no limit */" if pulses is None else ""),
        "",
        f"typedef {t_counts} armlab_sp_counts_t;",
        f"typedef {t_dcounts} armlab_sp_dcounts_t;",
        "",
        "extern const char *const ARMLAB_SP_AXIS_JOINT[ARMLAB_SP_N_AXES];",
        "extern const int8_t ARMLAB_SP_AXIS_SIGN[ARMLAB_SP_N_AXES];",
        "/* encoder counts per joint revolution (pulses x decoding x reducer ratio) */",
        "extern const double ARMLAB_SP_COUNTS_PER_JOINT_REV[ARMLAB_SP_N_AXES];",
        "extern const int32_t ARMLAB_SP_START_COUNTS[ARMLAB_SP_N_AXES];",
        "extern const armlab_sp_counts_t ARMLAB_SP_COUNTS[ARMLAB_SP_N_CYCLES][ARMLAB_SP_N_AXES];",
        "extern const armlab_sp_dcounts_t ARMLAB_SP_DCOUNTS[ARMLAB_SP_N_CYCLES][ARMLAB_SP_N_AXES];",
        "",
        f"#endif /* {guard} */",
        "",
    ]
    header = "\n".join(lines).encode()
    joints = ", ".join(c_string(j) for j in table.joint_names)
    data = [
        f"/* armlab set-point table data -- generated by armlab.deploy, do not edit "
        f"(declarations: {header_name}). */",
        f'#include "{header_name}"',
        "",
        f"const char *const ARMLAB_SP_AXIS_JOINT[ARMLAB_SP_N_AXES] = {{{joints}}};",
        "const int8_t ARMLAB_SP_AXIS_SIGN[ARMLAB_SP_N_AXES] = {"
        + ", ".join(str(int(s)) for s in table.axis_sign)
        + "};",
        "const double ARMLAB_SP_COUNTS_PER_JOINT_REV[ARMLAB_SP_N_AXES] = {"
        + ", ".join(repr(float(c)) for c in table.counts_per_joint_rev)
        + "};",
        "const int32_t ARMLAB_SP_START_COUNTS[ARMLAB_SP_N_AXES] = {"
        + ", ".join(str(int(c)) for c in table.counts[0])
        + "};",
        "",
    ]
    body = ("\n".join(data) + "\n").encode()
    body += _c_array_2d("armlab_sp_counts_t", "ARMLAB_SP_COUNTS", table.counts) + b"\n"
    body += _c_array_2d("armlab_sp_dcounts_t", "ARMLAB_SP_DCOUNTS", table.dcounts)
    return header, body


# ---------------------------------------------------------------------- reading
def read_setpoints_file(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    """Read a CSV, JSON or NPZ set-point file: ``(metadata, named columns)``, format checked
    (:func:`armlab.deploy.read_setpoints` builds the table from them).

    Raises
    ------
    InputError
        Missing file, unknown suffix, unreadable content, a format tag not in
        :data:`READABLE_SETPOINT_FORMATS`.
    """
    if not path.is_file():
        raise InputError(f"set-point file {path} not found")
    fmt = _SUFFIX_TO_FORMAT.get(path.suffix.lower())
    readers = {"csv": _read_csv, "json": _read_json, "npz": _read_npz}
    if fmt not in readers:
        raise InputError(
            f"{path}: cannot read set-points from {path.suffix!r} files (.csv, .json, .npz)"
        )
    meta, cols = readers[fmt](path)
    if meta.get("format") not in READABLE_SETPOINT_FORMATS:
        raise InputError(
            f"{path}: format {meta.get('format')!r} is not one of "
            f"{', '.join(READABLE_SETPOINT_FORMATS)}"
        )
    return meta, cols
