"""The name policy: what a name that reaches an output file may hold, checked when it is read.

Names travel from the inputs (URDF, drives file, controller profile, study file) into every
export: C headers (string literals, comments), ``ros2_controllers.yaml`` (mapping keys),
CSV column headers and ``#`` comment lines, JSON. A name that holds a quote, a comment
delimiter, a line break or a trigraph can change the meaning of such a file (issue 24: a URDF
joint named ``c*/`` newline ``#define ...`` put a live ``#define`` into the set-point header).
So every **identifier** -- joint, link (tool frame), robot, controller profile -- must be

* ASCII letters, digits, ``_``, ``.`` and ``-`` only (``[A-Za-z0-9_.-]``),
* starting with a letter or ``_``,
* at most :data:`MAX_NAME_LENGTH` (64) characters,

which every export format carries verbatim (a C string literal and comment, a plain YAML
scalar, a CSV field without quoting, JSON). This covers the names of published arms (UR
``shoulder_pan_joint``, Panda ``panda_joint1``, every moving joint of the example-robot-data
URDFs) and armlab's own (``joint1``, ``reference_dda``). The joints of one robot must also stay
distinct under the transformations a format applies: :func:`identifier_key` (upper case,
``.``/``-`` to ``_``: a C identifier, a case-insensitive file system) of two joints must differ
(``wrist-1`` and ``wrist_1`` are refused together).

A **title** (``[study] name``, the report's heading) is free text: any printable characters
(no control, format, surrogate, private-use or unassigned code points, no line or paragraph
separators), at most :data:`MAX_TITLE_LENGTH` (200) characters.

A name breaking the policy is refused with one line naming the name (shortened if long), what
it is and where it came from (``robot.urdf: joint name 'a*/ int x; /*': only letters, digits,
_ . - allowed``). The writers escape for their own format as well (defence in depth:
:func:`armlab.deploy.formats.c_string`, :func:`armlab.deploy.formats.c_comment`, the YAML and
CSV writers), so a name that bypasses the readers still cannot change the structure of a file.
"""

from __future__ import annotations

import json
import re
import unicodedata
from collections.abc import Iterable

from armlab.errors import ArmlabError, InputError

__all__ = [
    "NAME_PATTERN",
    "MAX_NAME_LENGTH",
    "MAX_TITLE_LENGTH",
    "name_problem",
    "check_name",
    "check_names",
    "check_title",
    "identifier_key",
    "shown",
    "one_line",
]

#: Characters of an identifier (a leading letter or ``_``, then letters, digits, ``_ . -``).
NAME_PATTERN = r"[A-Za-z_][A-Za-z0-9_.-]*"
#: Longest identifier, in characters.
MAX_NAME_LENGTH = 64
#: Longest title (a study name), in characters.
MAX_TITLE_LENGTH = 200

_NAME_RE = re.compile(NAME_PATTERN)
#: Unicode categories a title may not hold: control, format, surrogate, private use,
#: unassigned, line and paragraph separators.
_BAD_TITLE_CATEGORIES = ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp")
_SHOWN = 40  # characters of a long name shown in a message


def shown(name: object) -> str:
    """``repr(name)``, shortened to its first 40 characters for a long name (one line:
    ``repr`` escapes line breaks)."""
    if isinstance(name, str) and len(name) > _SHOWN:
        return f"{name[:_SHOWN]!r}... ({len(name)} characters)"
    return repr(name)


def name_problem(name: object) -> str | None:
    """Why ``name`` breaks the identifier policy (a phrase), or None if it keeps it."""
    if not isinstance(name, str):
        return "is not a string"
    if not name:
        return "is empty"
    if len(name) > MAX_NAME_LENGTH:
        return f"is {len(name)} characters long (at most {MAX_NAME_LENGTH})"
    if not _NAME_RE.fullmatch(name):
        if name[0] not in "_" and not (name[0].isascii() and name[0].isalpha()):
            return "must start with an ASCII letter or _ (then letters, digits, _ . -)"
        return "may hold only ASCII letters, digits, _ . - (names reach C, YAML and CSV files)"
    return None


def check_name(name: object, what: str, where: str, error: type[ArmlabError] = InputError) -> str:
    """Return ``name`` if it keeps the identifier policy, else raise ``error``.

    Parameters
    ----------
    name : object
        The name as read.
    what : str
        What it names (``"joint name"``, ``"controller profile name"``).
    where : str
        Where it came from (a file, a key), the head of the message.
    error : ArmlabError subclass
        The class raised (:class:`~armlab.errors.RobotDescriptionError` for a robot
        description, :class:`~armlab.errors.SpecError` for a study, ...).

    Raises
    ------
    ArmlabError
        One line: ``<where>: <what> <name> <problem>``.
    """
    problem = name_problem(name)
    if problem is not None:
        raise error(f"{where}: {what} {shown(name)} {problem}")
    return str(name)


def identifier_key(name: str) -> str:
    """The form two names must not share: upper case with ``.`` and ``-`` as ``_`` -- the C
    identifier :func:`armlab.deploy.formats.c_identifier` makes of a policy name, and the
    file name on a case-insensitive file system."""
    return re.sub(r"[^0-9A-Za-z_]", "_", name).upper()


def check_names(
    names: Iterable[object], what: str, where: str, error: type[ArmlabError] = InputError
) -> list[str]:
    """:func:`check_name` for each name, then refuse two that are equal or share an
    :func:`identifier_key` (``wrist-1`` and ``wrist_1``, ``Joint1`` and ``joint1``)."""
    out = [check_name(n, what, where, error) for n in names]
    seen: dict[str, str] = {}
    for n in out:
        key = identifier_key(n)
        if key in seen:
            same = "twice" if seen[key] == n else f"and {seen[key]!r} (both {key} in C)"
            raise error(f"{where}: {what} {n!r} {same}: names must stay distinct in every format")
        seen[key] = n
    return out


def check_title(text: object, what: str, where: str, error: type[ArmlabError] = InputError) -> str:
    """Return ``text`` if it is a title (module docstring: printable, one line, at most 200
    characters), else raise ``error`` with one line."""
    if not isinstance(text, str) or not text:
        raise error(f"{where}: {what} {shown(text)} is not a non-empty string")
    if len(text) > MAX_TITLE_LENGTH:
        raise error(
            f"{where}: {what} {shown(text)} is {len(text)} characters long "
            f"(at most {MAX_TITLE_LENGTH})"
        )
    bad = next((c for c in text if unicodedata.category(c) in _BAD_TITLE_CATEGORIES), None)
    if bad is not None:
        raise error(
            f"{where}: {what} {shown(text)} holds the non-printable character U+{ord(bad):04X} "
            "(a title is printable text on one line)"
        )
    return text


def one_line(text: object) -> str:
    """``text`` for a comment line of a text format (``#`` of CSV and YAML): itself if it is
    printable ASCII, else its JSON string (quoted, escaped: one ASCII line whatever it holds)."""
    s = str(text)
    return s if all(" " <= c <= "~" for c in s) else json.dumps(s)
