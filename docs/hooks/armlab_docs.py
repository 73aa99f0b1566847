"""MkDocs hook: the reference tables that must follow the code, generated from it at build time.

A page holds a marker ``<!-- armlab:NAME -->`` (on a line of its own for a table);
:func:`on_page_markdown` replaces it with :data:`GENERATORS` ``[NAME]()``. An unknown marker,
or a validator of ``armlab.study.spec`` this hook cannot describe, fails the build (``mkdocs
build --strict``), so a new study key or drives field cannot go undocumented.

Markers: ``study-keys`` (every table and key of the study file, from
``armlab.study.spec``), ``drives-keys`` (every field of ``drives.toml``, from
``armlab.robot.drives``), ``robots`` and ``profiles`` (the built-in names), ``stages`` (the
stages and their summary.json keys), ``key-figures`` (``armlab.study.runner.KEY_FIGURES``).
"""

from __future__ import annotations

import inspect
import math
import re
from collections.abc import Callable
from dataclasses import MISSING, fields

MARKER = re.compile(r"<!-- armlab:([a-z-]+) -->")


def _md(text: str) -> str:
    """reST inline literals and roles to Markdown code; one line; pipes escaped for tables."""
    text = re.sub(r":(?:func|class|mod|meth|attr|data):`~?([^`]+)`", r"`\1`", text)
    text = text.replace("``", "`")
    return " ".join(text.split()).replace("|", "\\|")


def _toml(value) -> str:
    if value is MISSING:
        return "**required**"
    if value is None:
        return "-"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, float) and math.isnan(value):
        return "-"
    if isinstance(value, (list, tuple)):
        return "`[" + ", ".join(_toml(v).strip("`") for v in value) + "]`"
    return f"`{value}`"


def _interval(lo, hi, lo_open: bool) -> str:
    left = "(" if lo_open else "["
    if hi is None:
        return f"> {lo:g}" if lo_open else f">= {lo:g}"
    return f"in {left}{lo:g}, {hi:g}]"


def _allowed(check: Callable) -> str:
    """What a study-file validator of ``armlab.study.spec`` accepts, in words."""
    kind = check.__qualname__.split(".")[0]
    nl = inspect.getclosurevars(check).nonlocals if check.__closure__ else {}
    if kind == "_bool":
        return "`true` or `false`"
    if kind == "_title":
        return "printable text on one line, <= 200 characters"
    if kind == "_joint_name":
        return "a name: letters, digits, `_ . -`, <= 64"
    if kind == "_drive_value":
        return _RULE_WORDS[nl["rule"]] + " (as in drives.toml)"
    if kind == "_amplifier":
        return "catalogue amplifier name, or a table of `[joint.amplifier]` keys (drives.toml)"
    if kind == "_raw":
        return "a shape key: see *Obstacles and collisions*"
    if kind == "_feedforward":
        return 'list of strings, or `"none"`'
    if kind == "_str":
        choices = nl.get("choices")
        return "string" if not choices else "one of " + ", ".join(f"`{c}`" for c in choices)
    if kind == "_str_list":
        choices = nl.get("choices")
        if not choices:
            return "list of strings"
        return "list, each one of " + ", ".join(f"`{c}`" for c in choices)
    if kind == "_int":
        lo, hi = nl.get("lo"), nl.get("hi")
        if lo is None:
            return "integer"
        return f"integer >= {lo}" if hi is None else f"integer in [{lo}, {hi}]"
    if kind == "_float":
        lo, hi = nl.get("lo"), nl.get("hi")
        return "number" if lo is None else "number " + _interval(lo, hi, nl.get("lo_open", False))
    if kind == "_number_or_list":
        sign = "> 0" if nl.get("lo_open_zero", True) else ">= 0"
        return f"number {sign} (every joint) or a list, one per joint"
    if kind == "_vector":
        n = nl.get("n")
        return f"list of {n} numbers" if n else "list of numbers (one per joint)"
    if kind == "_matrix":
        width = nl.get("width")
        return f"list of rows of {width} numbers" if width else "list of rows (one per waypoint)"
    raise ValueError(f"armlab_docs: cannot describe the study validator {check.__qualname__}")


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def _section_rows(cls) -> list[list[str]]:
    rows = []
    for f in fields(cls):
        default = f.default if f.default is not MISSING else MISSING
        rows.append(
            [f"`{f.name}`", _allowed(f.metadata["check"]), _toml(default), _md(f.metadata["doc"])]
        )
    return rows


def study_keys() -> str:
    """One table per study-file table, every key with what it accepts, its default, meaning."""
    from armlab.study import spec

    out = []
    sections = list(spec._SECTIONS.items())
    sections.insert(6, ("drives.<joint>", spec.DriveOverride))  # after [plan], as in the file
    for name, cls in sections:
        summary = _md((inspect.getdoc(cls) or "").split("\n\n")[0])
        out += [
            f"### `[{name}]`",
            "",
            summary,
            "",
            _table(["key", "accepts", "default", "meaning"], _section_rows(cls)),
            "",
        ]
    return "\n".join(out)


_RULE_WORDS = {
    "pos": "number > 0",
    "nonneg": "number >= 0",
    "unit": "number in (0, 1]",
    "count": "integer > 0",
    "decoding": "1, 2 or 4",
    "pos_list": "list of numbers > 0",
}


def _attribute_docs(cls) -> dict[str, str]:
    """``{name: description}`` from a numpy-style ``Attributes`` section of a class docstring."""
    doc = inspect.getdoc(cls) or ""
    out: dict[str, str] = {}
    if "Attributes\n----------" not in doc:
        return out
    body = doc.split("Attributes\n----------", 1)[1]
    current: list[str] = []
    for line in body.splitlines():
        if line and not line.startswith(" "):
            current = [n.strip() for n in line.split(":")[0].split(",")]
            for n in current:
                out.setdefault(n, "")
        elif line.strip():
            for n in current:
                out[n] = (out[n] + " " + line.strip()).strip()
    return out


#: Meanings of the drives.toml fields whose class docstring does not describe them.
_FIELD_MEANING = {
    "joint": "the URDF joint this drive moves",
    "model": "model name (reports, catalogue look-up)",
    "mass_kg": "mass in [kg] (catalogue selection; optional)",
    "price": "price (catalogue selection; optional)",
    "source": "where the values come from (data sheet, thesis table; free text)",
    "ratio": "motor speed / joint speed",
    "efficiency": "torque efficiency",
    "rated_torque_Nm": "rated (continuous) output torque in [N m]",
    "max_input_speed_rpm": "maximum input (motor-side) speed in [rpm]",
    "peak_torque_Nm": "peak (momentary) output torque in [N m]",
    "inertia_kg_m2": "inertia at the input shaft in [kg m^2]",
    "integrated": "model of the integrated smart servo this part belongs to (combines only with "
    "the other half of that servo; docs/catalogue.md), empty for a part sold alone",
    "estimated": "fields whose value was not read from a published source (selection skips "
    "such parts unless `[sizing] allow_estimated = true`)",
    "pulses_per_rev": "encoder pulses per motor revolution",
    "decoding": "quadrature decoding factor (x1, x2, x4)",
}


def drives_keys() -> str:
    """The tables of one ``[[joint]]`` entry of drives.toml and what each field accepts."""
    from armlab.robot import drives, drives_file

    out = []
    parts = (
        ("[[joint]]", drives.Drive, "name (the URDF joint), the joint-side limits, derating"),
        ("[joint.motor]", drives.Motor, "the DC motor"),
        ("[joint.reducer]", drives.Reducer, "the reducer (ratio = motor speed / joint speed)"),
        ("[joint.encoder]", drives.Encoder, "the incremental encoder on the motor shaft"),
        (
            "[joint.amplifier]",
            drives.Amplifier,
            'the servo amplifier (optional; or `amplifier = "<catalogue model>"`)',
        ),
    )
    for title, cls, what in parts:
        rules = drives_file._RULES.get(cls.__name__, {})
        docs = _attribute_docs(cls)
        rows = []
        for f in fields(cls):
            if f.name in ("motor", "reducer", "encoder"):
                continue
            name = "name" if f.name == "joint" else f.name
            if f.name in (*drives_file._TEXT_FIELDS, "joint"):
                accepts = "string"
            elif f.name == "amplifier":
                accepts = "catalogue amplifier name, or the `[joint.amplifier]` table below"
            elif f.name == "regenerates":
                accepts = "true or false"
            elif f.name in rules:
                accepts = _RULE_WORDS[rules[f.name]]
            else:  # a tuple field, e.g. `estimated`: a TOML list
                accepts = "list of field names" if f.name == "estimated" else "list of numbers"
            default = f.default if f.default is not MISSING else MISSING
            meaning = docs.get(f.name) or _FIELD_MEANING.get(f.name, "")
            rows.append([f"`{name}`", accepts, _toml(default), _md(meaning)])
        out += [
            f"### `{title}`",
            "",
            what + ".",
            "",
            _table(["key", "accepts", "default", "meaning"], rows),
            "",
        ]
    return "\n".join(out)


def robots() -> str:
    from armlab.robot import list_robots

    return ", ".join(f"`{n}`" for n in list_robots())


def profiles() -> str:
    from armlab.robot import list_profiles

    return ", ".join(f"`{n}`" for n in list_profiles())


def stages() -> str:
    from armlab.study.spec import STAGES
    from armlab.study.stages import SUMMARY_KEY

    rows = [[f"`{s}`", f"`{SUMMARY_KEY[s]}`"] for s in STAGES]
    return _table(["stage (`study.stages`)", "its block in summary.json"], rows)


def key_figures() -> str:
    from armlab.study.figures import KEY_FIGURES

    return ", ".join(f"`{k}`" for k in KEY_FIGURES)


def demo_study() -> str:
    """The built-in study file, verbatim."""
    from armlab.study.spec import demo_study_path

    return "```toml\n" + demo_study_path().read_text().rstrip() + "\n```"


def sweep_format() -> str:
    """The sweep file format: the text block of ``armlab.sweep.spec``'s docstring."""
    from armlab.sweep import spec

    doc = inspect.getdoc(spec) or ""
    lines = []
    for line in doc.split("Format (TOML)::", 1)[1].splitlines()[1:]:
        if line and not line.startswith("    "):  # the literal block ends at the next paragraph
            break
        lines.append(line[4:])
    return "```toml\n" + "\n".join(lines).strip("\n") + "\n```"


def sweep_columns() -> str:
    """The bookkeeping (and, where the sweep records them, provenance) columns of a sweep row."""
    from armlab.sweep.task import ROW_FIELDS

    names = list(ROW_FIELDS)
    try:
        from armlab.sweep.provenance import PROVENANCE_FIELDS
    except ImportError:
        provenance: list[str] = []
    else:
        provenance = list(PROVENANCE_FIELDS)
    text = ", ".join(f"`{n}`" for n in names)
    if provenance:
        text += "; provenance: " + ", ".join(f"`{n}`" for n in provenance)
    return text


def output_files() -> str:
    """The files (patterns) a study run writes and clears: ``armlab.study.record.OUTPUT_FILES``."""
    from armlab.study.record import OUTPUT_FILES

    return ", ".join(f"`{n}`" for n in OUTPUT_FILES)


def export_formats() -> str:
    """The format table of ``armlab export`` (the simple table of ``armlab.study.export``)."""
    import sys
    from pathlib import Path

    from armlab.study import export

    sys.path.insert(0, str(Path(__file__).parent))
    from griffe_rst import rst_to_markdown

    text = rst_to_markdown(inspect.getdoc(export) or "")
    table = [line for line in text.splitlines() if line.startswith("|")]
    if not table:
        raise ValueError("armlab_docs: armlab.study.export's docstring has no format table")
    return "\n".join(table)


GENERATORS: dict[str, Callable[[], str]] = {
    "export-formats": export_formats,
    "sweep-columns": sweep_columns,
    "output-files": output_files,
    "demo-study": demo_study,
    "sweep-format": sweep_format,
    "study-keys": study_keys,
    "drives-keys": drives_keys,
    "robots": robots,
    "profiles": profiles,
    "stages": stages,
    "key-figures": key_figures,
}


def expand(markdown: str) -> str:
    """``markdown`` with every marker replaced by its generated text."""

    def sub(match: re.Match) -> str:
        name = match.group(1)
        if name not in GENERATORS:
            raise ValueError(f"armlab_docs: unknown marker <!-- armlab:{name} -->")
        return GENERATORS[name]()

    return MARKER.sub(sub, markdown)


def on_page_markdown(markdown: str, **kwargs) -> str:
    """MkDocs event: expand the markers of every page."""
    return expand(markdown)
