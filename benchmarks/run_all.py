"""Run every benchmark; regenerate README.md's benchmark table from their output (make bench).

Every ``benchmarks/bench_*.py`` (sorted by name) runs in its own process with
``OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg`` (``bench_topp.py`` with ``--full``: ``SCRIPT_ARGS``);
its output goes to the console and to ``out/bench/<script>.txt``. Each script ends by printing
its README row(s) (``benchmarks/_readme.py``:
``README-ROW<TAB>script<TAB>what<TAB>armlab<TAB>peer``), computed from that run. The rows, in
script order, make the table written to ``out/bench/readme_table.md`` and, with
``--update-readme``, the table in README.md between ``<!-- bench-table:start -->`` and
``<!-- bench-table:end -->`` (replaced atomically). The README is only touched when every script
ran without error and printed at least one row; otherwise the exit status is 1, the README is
unchanged and the scripts at fault are named. With ``--only``, only the named scripts run and
only their rows are replaced; the other scripts keep the rows the README has.

Usage::

    .venv/bin/python benchmarks/run_all.py [--update-readme] [--quick] [--only bench_deploy ...]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from _readme import MARKER, NO_PEER  # noqa: E402

START = "<!-- bench-table:start -->"
END = "<!-- bench-table:end -->"
HEADER = ("script", "what", "armlab", "peer (same process, same cases)")
ENV = {"OPENBLAS_NUM_THREADS": "1", "MPLBACKEND": "Agg", "PYTHONUNBUFFERED": "1"}
#: arguments a script always gets from ``make bench``: its README row compares the convex pass
SCRIPT_ARGS = {"bench_topp.py": ["--full"]}

Row = tuple[str, str, str, str]  # script file name, what, armlab, peer


@dataclass
class ScriptRun:
    """One script's run: its file name, exit status and the README rows it printed."""

    script: str
    returncode: int
    rows: list[Row] = field(default_factory=list)
    seconds: float = 0.0


# ------------------------------------------------------------------------- the collector
def parse_rows(text: str) -> list[Row]:
    """The README rows in a script's output, in the order printed."""
    rows = []
    for line in text.splitlines():
        parts = line.rstrip("\r\n").split("\t")
        if parts[0] == MARKER and len(parts) == 5:
            rows.append((parts[1], parts[2], parts[3], parts[4] or NO_PEER))
    return rows


def table_markdown(rows: list[Row]) -> str:
    """The whole markdown table: header, then the rows; a script's name is written on its first
    row only (its further rows leave the cell empty)."""
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    previous = None
    for script, what, armlab, peer in rows:
        name = f" `{script}` " if script != previous else " "
        previous = script
        lines.append(f"|{name}| {what} | {armlab} | {peer} |")
    return "\n".join(lines) + "\n"


_SPLIT = re.compile(r"(?<!\\)\|")


def parse_table(block: str) -> list[Row]:
    """The rows of a table made by :func:`table_markdown` (an empty script cell continues the
    script above it); the header and separator lines are skipped."""
    rows: list[Row] = []
    script = ""
    for line in block.splitlines():
        line = line.strip()
        if not line.startswith("|"):
            continue
        cells = [c.strip() for c in _SPLIT.split(line)[1:-1]]
        if len(cells) != 4 or cells[0] == HEADER[0] or re.fullmatch(r":?-+:?", cells[0]):
            continue
        script = cells[0].strip("`") or script
        rows.append((script, cells[1], cells[2], cells[3]))
    return rows


def merge_rows(old: list[Row], new: list[Row], rerun: set[str], scripts: set[str]) -> list[Row]:
    """The table after a run: the new rows of the scripts that ran (``rerun``), the old rows of
    the other existing ``scripts``; rows of scripts that no longer exist are dropped. Ordered
    by script name, each script's rows in the order it printed them."""
    kept = [r for r in old if r[0] not in rerun and r[0] in scripts]
    ran = [r for r in new if r[0] in rerun]
    rows = kept + ran
    order = sorted({r[0] for r in rows})
    return [r for name in order for r in rows if r[0] == name]


def problems(runs: list[ScriptRun]) -> list[str]:
    """Why the README must not be updated: scripts that failed or printed no row."""
    out = []
    for run in runs:
        if run.returncode != 0:
            out.append(f"{run.script} failed (exit status {run.returncode})")
        elif not run.rows:
            out.append(f"{run.script} printed no README row (benchmarks/_readme.py)")
    return out


def table_block(readme: str) -> str:
    """The text between the two markers of README.md."""
    if readme.count(START) != 1 or readme.count(END) != 1 or readme.find(START) > readme.find(END):
        raise SystemExit(f"README.md: expected one {START} ... {END} block")
    return readme.split(START, 1)[1].split(END, 1)[0]


def replace_block(readme: str, table: str) -> str:
    """README text with the marked block's content replaced by ``table``."""
    table_block(readme)  # checks the markers
    head, rest = readme.split(START, 1)
    _, tail = rest.split(END, 1)
    return f"{head}{START}\n{table.rstrip()}\n{END}{tail}"


def new_table(readme: str, runs: list[ScriptRun], scripts: set[str]) -> str:
    """The table for README.md after ``runs``: their rows, the README's rows for the others."""
    new = [r for run in runs for r in run.rows]
    rerun = {run.script for run in runs}
    return table_markdown(merge_rows(parse_table(table_block(readme)), new, rerun, scripts))


def update_readme(path: Path, runs: list[ScriptRun], scripts: set[str]) -> list[str]:
    """Replace the table in the README at ``path`` (atomically) if every run succeeded and
    printed a row; returns the problems that kept it unchanged (empty when updated)."""
    bad = problems(runs)
    if bad:
        return bad
    readme = path.read_text(encoding="utf-8")
    text = replace_block(readme, new_table(readme, runs, scripts))
    if text != readme:
        from armlab.io import atomic_write

        atomic_write(path, text)
    return []


# ------------------------------------------------------------------------- running scripts
def discover(folder: Path = HERE) -> list[Path]:
    return sorted(folder.glob("bench_*.py"))


def select(scripts: list[Path], only: list[str] | None) -> list[Path]:
    """The scripts named in ``only`` (``bench_deploy``, ``bench_deploy.py``), all without it."""
    if not only:
        return scripts
    wanted = {Path(n).stem for n in only}
    by_stem = {p.stem: p for p in scripts}
    unknown = sorted(wanted - set(by_stem))
    if unknown:
        raise SystemExit(f"--only: no benchmark named {', '.join(unknown)} in {HERE}")
    return [by_stem[n] for n in sorted(wanted)]


def accepts_quick(path: Path) -> bool:
    """Whether the script's argument parser has a ``--quick`` flag."""
    return re.search(r"add_argument\(\s*[\"']--quick[\"']", path.read_text()) is not None


def run_script(path: Path, quick: bool, out_dir: Path) -> ScriptRun:
    """Run one script, streaming its output (stdout and stderr) to the console and to
    ``out_dir/<script>.txt``; collect its rows."""
    cmd = [sys.executable, str(path), *SCRIPT_ARGS.get(path.name, [])]
    cmd += ["--quick"] if quick and accepts_quick(path) else []
    print(f"\n==> {' '.join(cmd[1:])}", flush=True)
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    lines = []
    with (
        (out_dir / f"{path.stem}.txt").open("w", encoding="utf-8") as log,
        subprocess.Popen(
            cmd,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            bufsize=1,
            cwd=ROOT,
            env={**os.environ, **ENV},
        ) as proc,
    ):
        assert proc.stdout is not None
        for line in proc.stdout:
            sys.stdout.write(line)
            log.write(line)
            lines.append(line)
        rc = proc.wait()
    seconds = time.perf_counter() - t0
    rows = [r for r in parse_rows("".join(lines)) if r[0] == path.name]
    return ScriptRun(path.name, rc, rows, seconds)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--update-readme", action="store_true", help="replace README.md's table")
    ap.add_argument("--quick", action="store_true", help="--quick to the scripts that take it")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="run these scripts only")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "bench", help="raw outputs")
    ap.add_argument("--readme", type=Path, default=ROOT / "README.md", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    all_scripts = discover()
    runs = [run_script(p, args.quick, args.out) for p in select(all_scripts, args.only)]
    names = {p.name for p in all_scripts}

    print("\n==> benchmarks")
    for run in runs:
        print(f"{run.script:<26} exit {run.returncode}  {len(run.rows)} rows  {run.seconds:.1f} s")
    readme = args.readme.read_text(encoding="utf-8")
    if START in readme:  # with --only, the README's rows of the other scripts
        table = new_table(readme, runs, names)
    else:
        table = table_markdown([r for run in runs for r in run.rows])
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "readme_table.md").write_text(table, encoding="utf-8")
    print(f"table: {args.out / 'readme_table.md'}; raw outputs: {args.out}/<script>.txt")

    sys.stdout.flush()
    bad = problems(runs)
    if args.update_readme:
        bad = update_readme(args.readme, runs, names)
        if not bad:
            print(f"{args.readme}: benchmark table regenerated")
    if bad:
        unchanged = f"; {args.readme} NOT updated" if args.update_readme else ""
        print(f"benchmarks failed{unchanged}:", file=sys.stderr)
        for b in bad:
            print(f"  {b}", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
