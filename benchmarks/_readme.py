"""The README's benchmark rows: how a benchmark script hands its row(s) to ``run_all.py``.

A script computes each row of README.md's "## Benchmarks" table from its own run and calls
:func:`readme_row` at its end; the row is printed as one machine-readable line::

    README-ROW<TAB>script<TAB>what<TAB>armlab<TAB>peer

which ``benchmarks/run_all.py`` collects from the script's output (in the order printed) and
writes into the table. Import it from a script as ``from _readme import readme_row`` (a script
run as ``python benchmarks/bench_x.py`` has ``benchmarks/`` on its path).
"""

from __future__ import annotations

from pathlib import Path

MARKER = "README-ROW"
NO_PEER = "—"


def _cell(text: str) -> str:
    """One table cell: no tab or newline (they split the line), no bare ``|`` (splits the cell)."""
    text = " ".join(str(text).split())
    return text.replace("|", "\\|")


def row_line(script: str, what: str, armlab: str, peer: str = NO_PEER) -> str:
    """The machine-readable line of one row; ``script`` is a path or a file name."""
    cells = (Path(script).name, what, armlab, peer or NO_PEER)
    return "\t".join([MARKER, *(_cell(c) for c in cells)])


def readme_row(script: str, what: str, armlab: str, peer: str = NO_PEER) -> None:
    """Print one README row of ``script`` (pass ``__file__``): what was measured, armlab's
    figures and the peer's (``—`` when there is none), each already formatted from the run."""
    print(row_line(script, what, armlab, peer), flush=True)


def sig(x: float, digits: int = 3) -> str:
    """``x`` to ``digits`` significant figures, thousands split by spaces as in the README
    (``280 000``, ``2 210``, ``0.385``, ``14.2``)."""
    if x != x or x in (float("inf"), float("-inf")):
        return str(x)
    if x == 0:
        return "0"
    if abs(x) < 1e-3:
        return f"{x:.{digits - 1}e}"
    text = f"{float(f'{x:.{digits}g}'):f}".rstrip("0").rstrip(".")
    whole, _, frac = text.partition(".")
    sign = "-" if whole.startswith("-") else ""
    whole = whole.lstrip("-")
    if len(whole) > 3:
        groups = []
        while whole:
            groups.insert(0, whole[-3:])
            whole = whole[:-3]
        whole = " ".join(groups)
    return sign + whole + (f".{frac}" if frac else "")


def sci(x: float, digits: int = 2) -> str:
    """``x`` in scientific notation as in the README (``3.1e4``, ``1.4e7``, ``4.6e-15``)."""
    mantissa, _, exponent = f"{x:.{digits - 1}e}".partition("e")
    return f"{mantissa}e{int(exponent)}"
