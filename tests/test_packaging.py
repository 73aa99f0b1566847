"""Packaging: every package listed in pyproject.toml, robot descriptions found without a repo."""

from __future__ import annotations

import tomllib
from pathlib import Path

from armlab.robot.model import list_robots, robot_desc_dir

REPO = Path(__file__).resolve().parents[1]


def test_pyproject_lists_every_package():
    conf = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert conf["package-dir"] == {"": "research", "armlab.robot_desc": "robot_desc"}
    listed = set(conf["packages"])
    research = REPO / "research"
    found = {
        ".".join(init.parent.relative_to(research).parts)
        for init in research.glob("armlab/**/__init__.py")
    }
    assert listed == {*found, "armlab.robot_desc"}
    assert (REPO / "robot_desc" / "teachbot6" / "teachbot6.urdf").is_file()


def test_robot_desc_dir_order(tmp_path, monkeypatch):
    monkeypatch.setenv("ARMLAB_ROBOT_DESC", str(tmp_path))
    assert robot_desc_dir() == tmp_path and list_robots() == []
    (tmp_path / "arm").mkdir()
    (tmp_path / "arm" / "arm.urdf").write_text("<robot name='arm'/>")
    assert list_robots() == ["arm"]
    monkeypatch.delenv("ARMLAB_ROBOT_DESC")
    assert "teachbot6" in list_robots()
    assert (robot_desc_dir() / "teachbot6" / "drives.toml").is_file()


def test_the_console_script_runs_the_exit_handlers_and_flushes_its_output(tmp_path):
    """``armlab`` (:func:`armlab.cli.console`) ends the process without tearing the interpreter
    down: the exit handlers still run, the output is all there and the exit status is
    main's."""
    import subprocess
    import sys

    marker = tmp_path / "atexit_ran"
    code = (
        "import atexit, pathlib, sys; "
        f"atexit.register(pathlib.Path({str(marker)!r}).write_text, 'yes'); "
        "from armlab.cli import console; sys.argv = ['armlab'] + sys.argv[1:]; console()"
    )
    ok = subprocess.run(
        [sys.executable, "-c", code, "info", "teachbot6"], capture_output=True, text=True
    )
    assert ok.returncode == 0, ok.stderr
    assert "teachbot6" in ok.stdout and ok.stdout.endswith("\n")
    assert marker.read_text() == "yes"
    marker.unlink()
    bad = subprocess.run(
        [sys.executable, "-c", code, "info", "no_such_robot"], capture_output=True, text=True
    )
    assert bad.returncode == 2
    assert bad.stderr.startswith("armlab: error:") and "no_such_robot" in bad.stderr
    assert marker.read_text() == "yes"
