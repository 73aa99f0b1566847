"""``armlab export --out`` never replaces files it did not write (issue 24 item 8): a folder
holding another program's ``setpoints.csv`` (or anything else) is refused with one line unless
``--overwrite``, which replaces only the export's own files; a folder of earlier exports is
written again; an ``--out`` naming a file is one line (exit status 3)."""

from __future__ import annotations

import zipfile

import pytest

from armlab.cli import main as cli_main
from armlab.deploy import read_setpoints
from armlab.errors import InputError
from armlab.study import export_study
from cases import cosine_motion
from conftest import make_study_folder


@pytest.fixture(scope="module")
def study(teachbot6, tmp_path_factory):
    tr = cosine_motion(teachbot6, duration_s=2.0, n=201)
    return make_study_folder(tmp_path_factory.mktemp("outdir") / "study", teachbot6, tr)


def _export(study, out, *extra) -> int:
    return cli_main(["export", str(study), "--out", str(out), *extra])


def test_a_foreign_setpoints_csv_is_refused_and_kept(study, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "setpoints.csv").write_text("cycle,pulses\n0,1\n")  # another program's table
    (out / "notes.txt").write_text("mine")
    assert _export(study, out) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert "holds files armlab export did not write (notes.txt, setpoints.csv)" in err
    assert "--overwrite" in err
    assert (out / "setpoints.csv").read_text() == "cycle,pulses\n0,1\n"
    # --overwrite: the export's file is replaced, the others kept
    assert _export(study, out, "--overwrite") == 0
    assert read_setpoints(out / "setpoints.csv").n_cycles > 0
    assert (out / "notes.txt").read_text() == "mine"


def test_a_look_alike_is_not_an_export(study, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    with zipfile.ZipFile(out / "setpoints.npz", "w") as z:  # a zip, not armlab's
        z.writestr("data.npy", b"x")
    (out / "setpoints.h").write_text("/* vendor table */\n")
    with pytest.raises(InputError, match=r"\(setpoints\.h, setpoints\.npz\)"):
        export_study(study, "npz", out_dir=out)


def test_earlier_exports_are_written_again(study, tmp_path, capsys):
    out = tmp_path / "out"
    for fmt in ("csv", "json", "npz", "c", "trajectory", "cia402", "csv", "c"):
        assert _export(study, out, "--format", fmt) == 0, capsys.readouterr().err
    names = sorted(p.name for p in out.iterdir())
    assert "setpoints.csv" in names and "setpoints.c" in names and "cia402_objects.csv" in names


def test_out_naming_a_file_is_one_line(study, tmp_path, capsys):
    target = tmp_path / "setpoints.csv"
    target.write_text("keep\n")
    assert _export(study, target) == 3  # an error of the file system (README exit status)
    err = capsys.readouterr().err.strip()
    assert err == f"armlab: error: {target}: export --out is a file, not a folder"
    assert target.read_text() == "keep\n"
