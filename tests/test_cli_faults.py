"""Errors of the file system are one line and exit status 3 (issue 24, item 8): ``--out``
naming a file, disk full, a file-size limit, a read-only folder. (``armlab export`` refusing a
folder holding files it did not write: tests/study/test_export_outdir.py.)"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
import textwrap

import pytest

from armlab.cli import main, os_error_line
from cases import one_line, quick_study
from conftest import sweep_env

STAGES = ("kinematics", "plan", "export")


@pytest.fixture
def study_dir(tmp_path):
    """A finished quick study (plan + set-point table) that export accepts."""
    study = tmp_path / "q.toml"
    study.write_text(quick_study("q", STAGES))
    out = tmp_path / "q"
    assert main(["run", str(study), "--out", str(out)]) == 0
    return out


def test_out_naming_a_file_is_exit_3_and_leaves_the_file(tmp_path, study_dir, capsys):
    target = tmp_path / "notes.txt"
    target.write_text("mine\n")
    capsys.readouterr()
    assert main(["export", str(study_dir), "--out", str(target)]) == 3
    line = one_line(capsys)
    assert str(target) in line and "not a folder" in line
    study = tmp_path / "q.toml"
    assert main(["run", str(study), "--out", str(target)]) == 3
    assert str(target) in one_line(capsys)
    assert target.read_text() == "mine\n"


def test_disk_full_is_one_line_and_exit_3(tmp_path, study_dir, capsys, monkeypatch):
    import armlab.study.export as export

    def full(items):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp_path / "e" / "x.tmp"))

    monkeypatch.setattr(export, "atomic_write_many", full)
    capsys.readouterr()
    assert main(["export", str(study_dir), "--out", str(tmp_path / "e")]) == 3
    line = one_line(capsys)
    assert "no space left" in line and "x.tmp" in line


def test_os_error_line_is_one_line_with_the_paths():
    line = os_error_line(OSError(errno.EACCES, "Permission denied", "/a\nb", None, "/c"))
    assert line == "/a b -> /c: permission denied: choose a folder you can write"
    assert os_error_line(OSError("odd\nthing")) == "odd thing"


#: a study run in a process whose file-size limit is 2 kB (summary.json is larger)
FSIZE_RUN = textwrap.dedent(
    """
    import resource, signal, sys
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write over the limit fails with EFBIG
    from armlab.cli import main
    resource.setrlimit(resource.RLIMIT_FSIZE, (2000, 2000))
    sys.exit(main(["run", sys.argv[1], "--out", sys.argv[2]]))
    """
)


def test_a_file_size_limit_is_one_line_and_exit_3(tmp_path):
    study = tmp_path / "q.toml"
    study.write_text(quick_study("q", STAGES))
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-c", FSIZE_RUN, str(study), str(out)],
        capture_output=True,
        text=True,
        env=sweep_env(),
        timeout=600,
    )
    assert proc.returncode == 3, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "file too large" in lines[0] and "Traceback" not in proc.stderr
    assert not list(out.glob(".*.tmp"))  # no partial file left


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_read_only_out_is_one_line_and_exit_3(tmp_path, capsys):
    study = tmp_path / "q.toml"
    study.write_text(quick_study("q", STAGES))
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["run", str(study), "--out", str(ro / "out")]) == 3
        assert "permission denied" in one_line(capsys)
    finally:
        ro.chmod(0o755)


def test_ctrl_c_while_the_libraries_load_is_one_line_and_130(monkeypatch, capsys):
    """A Ctrl-C before the command runs (the parser imports the robot and profile lists, main
    imports numpy) is status 130 and one line, as during a command (it was a traceback)."""
    import armlab.cli as cli

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    assert main(["info", "teachbot6"]) == 130
    assert one_line(capsys) == "armlab: interrupted"


def test_a_sweep_into_a_file_is_exit_3(tmp_path, capsys):
    target = tmp_path / "results"
    target.write_text("mine\n")
    assert main(["sweep", "demo", "--out", str(target)]) == 3
    line = one_line(capsys)
    assert str(target) in line and "not a folder" in line
    assert target.read_text() == "mine\n"
