"""Griffe extension: armlab's reST-flavoured docstrings read as Markdown in the API pages.

armlab's docstrings are numpy style with reST inline markup (the house style; they read well in
``help()``). mkdocstrings renders Markdown, so before rendering this extension rewrites, in the
docstring text only (the sources are untouched):

* roles ``:func:`~armlab.x.name``` / ``:class:`Name``` / ``:mod:`.kinematics``` ... to code
  spans (`` `name` ``; a leading ``~`` keeps the last component, as Sphinx shows it);
* reST *simple tables* (columns framed by ``=====  =====`` lines) to Markdown tables;
* a paragraph ending in ``::`` (a reST literal block follows) to one ending in ``:``.

Double-backtick literals need nothing: ````x```` is a code span in Markdown too.
"""

from __future__ import annotations

import re
from typing import Any

try:
    import griffe
except ImportError:  # the rewrites work without it (tests/test_docs.py); the extension needs it
    griffe = None

ROLE = re.compile(r":(?:func|class|mod|meth|attr|data|obj|exc|ref|term):`([^`]+)`")
BORDER = re.compile(r"^(\s*)(=+)((?:\s+=+)+)\s*$")


def _role(match: re.Match) -> str:
    target = match.group(1)
    if "<" in target and target.endswith(">"):  # :ref:`text <target>`
        target = target.split("<", 1)[0].strip()
    if target.startswith("~"):
        target = target[1:].rsplit(".", 1)[-1]
    return f"`{target}`"


def _columns(border: str) -> list[tuple[int, int]]:
    """(start, end) of each column of a simple-table border line."""
    return [(m.start(), m.end()) for m in re.finditer(r"=+", border)]


def _cells(line: str, cols: list[tuple[int, int]]) -> list[str]:
    cells = []
    for i, (start, _end) in enumerate(cols):
        stop = cols[i + 1][0] if i + 1 < len(cols) else len(line)
        cells.append(line[start:stop].strip().replace("|", "\\|"))
    return cells


def simple_tables_to_markdown(text: str) -> str:
    """Every reST simple table of ``text`` (border, header, border, rows, border) as Markdown."""
    lines = text.splitlines()
    out: list[str] = []
    i = 0
    while i < len(lines):
        m = BORDER.match(lines[i])
        ends = [j for j in range(i + 1, len(lines)) if lines[j].strip() == lines[i].strip()]
        if not m or len(ends) < 2:
            out.append(lines[i])
            i += 1
            continue
        indent, cols = m.group(1), _columns(lines[i])
        head_end, table_end = ends[0], ends[1]
        header = [_cells(x, cols) for x in lines[i + 1 : head_end]]
        head = [" ".join(parts).strip() for parts in zip(*header, strict=True)]
        rows: list[list[str]] = []
        for line in lines[head_end + 1 : table_end]:
            if not line.strip():
                continue
            cells = _cells(line, cols)
            if rows and not cells[0]:  # a continuation line: its text joins the row above
                rows[-1] = [f"{a} {b}".strip() for a, b in zip(rows[-1], cells, strict=True)]
            else:
                rows.append(cells)
        out.append(indent + "| " + " | ".join(head) + " |")
        out.append(indent + "|" + "---|" * len(cols))
        out += [indent + "| " + " | ".join(r) + " |" for r in rows]
        i = table_end + 1
    return "\n".join(out)


def rst_to_markdown(text: str) -> str:
    """The rewrites of the module docstring, tables first."""
    text = simple_tables_to_markdown(text)  # first: the roles would shift the columns
    text = ROLE.sub(_role, text)
    return re.sub(r"(\S)::\n", r"\1:\n", text)


if griffe is not None:

    class RstToMarkdown(griffe.Extension):
        """Rewrite every docstring of the loaded package before mkdocstrings renders it."""

        def on_object(self, *, obj: Any, **kwargs: Any) -> None:
            if obj.docstring is not None:
                obj.docstring.value = rst_to_markdown(obj.docstring.value)

        def on_package(self, *, pkg: Any, **kwargs: Any) -> None:
            """The root package (``armlab``, the front door page): griffe calls
            :meth:`on_object` for its members only. The rewrite is idempotent."""
            self.on_object(obj=pkg)
