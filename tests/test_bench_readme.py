"""The benchmark collector (benchmarks/run_all.py): rows from script output, the README table,
and its update between the markers -- without running any benchmark."""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, BENCH / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


_readme = _load("_readme")
run_all = _load("run_all")

SAMPLE = """\
set-point table: teachbot6, 6 axes
armlab csv        17.7   0.104   0.133
README-ROW\tbench_deploy.py\t6-axis table, goal CSV < 1 s\tCSV 0.133 s\t`numpy.savetxt` 0.49 s
a line that mentions README-ROW but is not one
README-ROW\tbench_deploy.py\tsecond row\t1 | 2 s\t
"""


def test_rows_parsed_from_output_in_order():
    rows = run_all.parse_rows(SAMPLE)
    assert rows == [
        (
            "bench_deploy.py",
            "6-axis table, goal CSV < 1 s",
            "CSV 0.133 s",
            "`numpy.savetxt` 0.49 s",
        ),
        ("bench_deploy.py", "second row", "1 | 2 s", "—"),  # an empty peer is the dash
    ]


def test_row_line_round_trips_and_escapes_cells(capsys):
    _readme.readme_row("/x/benchmarks/bench_a.py", "what\twith tab", "1 | 2\nlines", "")
    (row,) = run_all.parse_rows(capsys.readouterr().out)
    assert row == ("bench_a.py", "what with tab", "1 \\| 2 lines", "—")
    table = run_all.table_markdown([row])
    assert run_all.parse_table(table) == [row]  # the escaped bar stays inside its cell


def test_sig_formats_like_the_readme():
    assert [_readme.sig(x) for x in (280_123, 2_210.4, 0.3851, 14.23, 799.4)] == [
        "280 000",
        "2 210",
        "0.385",
        "14.2",
        "799",
    ]
    assert _readme.sig(60_001, 6) == "60 001"


def test_table_names_a_script_on_its_first_row_only():
    rows = [("a.py", "w1", "x1", "p1"), ("a.py", "w2", "x2", "—"), ("b.py", "w3", "x3", "p3")]
    text = run_all.table_markdown(rows)
    lines = text.splitlines()
    assert lines[0] == "| script | what | armlab | peer (same process, same cases) |"
    assert lines[1] == "|---|---|---|---|"
    assert lines[2:] == [
        "| `a.py` | w1 | x1 | p1 |",
        "| | w2 | x2 | — |",
        "| `b.py` | w3 | x3 | p3 |",
    ]
    assert run_all.parse_table(text) == rows


def test_readme_table_round_trips():
    """The README's marked table parses into rows that rebuild it exactly."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block = run_all.table_block(readme)
    rows = run_all.parse_table(block)
    assert len(rows) > 0
    assert run_all.table_markdown(rows).strip() == block.strip()
    assert run_all.replace_block(readme, run_all.table_markdown(rows)) == readme


def _runs(*specs):
    return [run_all.ScriptRun(name, rc, rows) for name, rc, rows in specs]


@pytest.fixture
def readme(tmp_path):
    path = tmp_path / "README.md"
    shutil.copy(ROOT / "README.md", path)
    return path


def _outside(text: str) -> tuple[str, str]:
    head, rest = text.split(run_all.START, 1)
    return head, rest.split(run_all.END, 1)[1]


def test_update_replaces_exactly_the_marked_block_and_keeps_other_rows(readme):
    before = readme.read_text(encoding="utf-8")
    old_rows = run_all.parse_table(run_all.table_block(before))
    scripts = {r[0] for r in old_rows}
    assert "bench_deploy.py" in scripts and "bench_kinematics.py" in scripts
    new = [("bench_deploy.py", "new what", "CSV 0.001 s", "—")]
    assert run_all.update_readme(readme, _runs(("bench_deploy.py", 0, new)), scripts) == []
    after = readme.read_text(encoding="utf-8")
    assert _outside(after) == _outside(before)  # nothing outside the markers changed
    rows = run_all.parse_table(run_all.table_block(after))
    assert [r for r in rows if r[0] == "bench_deploy.py"] == new  # only the rerun rows replaced
    kept = [r for r in old_rows if r[0] != "bench_deploy.py"]
    assert sorted(r for r in rows if r[0] != "bench_deploy.py") == sorted(kept)
    names = [r[0] for r in rows]
    assert names == sorted(names)  # in script order


def test_full_update_drops_rows_of_scripts_that_no_longer_exist(readme):
    runs = _runs(("bench_a.py", 0, [("bench_a.py", "w", "x", "p")]))
    assert run_all.update_readme(readme, runs, {"bench_a.py"}) == []
    rows = run_all.parse_table(run_all.table_block(readme.read_text(encoding="utf-8")))
    assert rows == [("bench_a.py", "w", "x", "p")]


@pytest.mark.parametrize(
    ("returncode", "rows", "reason"),
    [(0, [], "printed no README row"), (1, [("bench_deploy.py", "w", "x", "—")], "failed")],
)
def test_failed_or_silent_script_leaves_readme_untouched(readme, returncode, rows, reason):
    before = readme.read_bytes()
    good = ("bench_dynamics.py", 0, [("bench_dynamics.py", "w", "x", "—")])
    bad = run_all.update_readme(readme, _runs(good, ("bench_deploy.py", returncode, rows)), set())
    assert len(bad) == 1 and "bench_deploy.py" in bad[0] and reason in bad[0]
    assert readme.read_bytes() == before


def test_main_with_failing_script_exits_nonzero_and_keeps_readme(readme, tmp_path, monkeypatch):
    """main() end to end on two fake scripts, one of which fails (tiny, no benchmark)."""
    folder = tmp_path / "benchmarks"
    folder.mkdir()
    ok = "from _readme import readme_row\nreadme_row(__file__, 'w', 'x')\n"
    (folder / "bench_ok.py").write_text(ok)
    (folder / "bench_boom.py").write_text("raise SystemExit(3)\n")
    shutil.copy(BENCH / "_readme.py", folder / "_readme.py")
    monkeypatch.setattr(run_all, "discover", lambda: sorted(folder.glob("bench_*.py")))
    before = readme.read_bytes()
    out = tmp_path / "out"
    status = run_all.main(["--update-readme", "--out", str(out), "--readme", str(readme)])
    assert status == 1
    assert readme.read_bytes() == before
    assert (out / "bench_ok.txt").read_text().startswith("README-ROW\tbench_ok.py")
    assert "| `bench_ok.py` | w | x | — |" in (out / "readme_table.md").read_text()
    # the working script alone: the README table is its row
    status = run_all.main(
        ["--update-readme", "--only", "bench_ok", "--out", str(out), "--readme", str(readme)]
    )
    assert status == 0
    rows = run_all.parse_table(run_all.table_block(readme.read_text(encoding="utf-8")))
    assert rows == [("bench_ok.py", "w", "x", "—")]


def test_accepts_quick_reads_the_argument_parser(tmp_path):
    assert run_all.accepts_quick(BENCH / "bench_drive_limits.py")
    assert not run_all.accepts_quick(BENCH / "bench_deploy.py")
    every = run_all.discover()
    assert all(p.name.startswith("bench_") for p in every) and every == sorted(every)
