"""armlab.io: the one atomic write and strict JSON."""

import json
import math
import os
import stat

import numpy as np
import pytest

from armlab.errors import InputError
from armlab.io import atomic as atomic_mod
from armlab.io import atomic_open, atomic_write, atomic_write_many, write_json
from armlab.io.atomic import json_safe


@pytest.fixture
def umask022():
    old = os.umask(0o022)
    try:
        yield
    finally:
        os.umask(old)


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def test_mode_is_0644_under_umask_022(tmp_path, umask022):
    for i, write in enumerate(
        [
            lambda p: atomic_write(p, b"x"),
            lambda p: write_json(p, {"a": 1}),
            lambda p: atomic_write_many([(p, "x")]),
        ]
    ):
        path = tmp_path / f"f{i}"
        write(path)
        assert _mode(path) == 0o644
    with atomic_open(tmp_path / "g", "w") as f:
        f.write("x")
    assert _mode(tmp_path / "g") == 0o644


def test_mode_follows_umask(tmp_path):
    old = os.umask(0o077)
    try:
        atomic_write(tmp_path / "private", "x")
    finally:
        os.umask(old)
    assert _mode(tmp_path / "private") == 0o600


def test_round_trip_bytes_text_and_open(tmp_path):
    data = bytes(range(256))
    assert atomic_write(tmp_path / "b", data) == tmp_path / "b"
    assert (tmp_path / "b").read_bytes() == data
    atomic_write(tmp_path / "t", "äöü — ok\n")
    assert (tmp_path / "t").read_text(encoding="utf-8") == "äöü — ok\n"
    with atomic_open(tmp_path / "o", "wb") as f:
        f.write(data)
    assert (tmp_path / "o").read_bytes() == data
    # overwrite
    atomic_write(tmp_path / "b", b"new")
    assert (tmp_path / "b").read_bytes() == b"new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b", "o", "t"]


def test_exception_mid_write_leaves_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "data.txt"
    path.write_text("old\n")
    with pytest.raises(RuntimeError, match="mid-write"):
        with atomic_open(path, "w") as f:
            f.write("half of the new con")
            # the temporary file exists while writing, beside the target
            assert len(list(tmp_path.glob(".data.txt.*.tmp"))) == 1
            raise RuntimeError("mid-write")
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["data.txt"]


def test_keyboard_interrupt_mid_write_cleans_up(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        with atomic_open(tmp_path / "new.bin", "wb") as f:
            f.write(b"x")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_failed_fsync_leaves_old_file(tmp_path, monkeypatch):
    path = tmp_path / "a.json"
    write_json(path, {"v": 1})

    def boom(fd):
        raise OSError("disk full")

    monkeypatch.setattr(atomic_mod.os, "fsync", boom)
    with pytest.raises(OSError, match="disk full"):
        write_json(path, {"v": 2})
    with pytest.raises(OSError, match="disk full"):
        atomic_write_many([(tmp_path / "x", "1"), (path, "2")])
    monkeypatch.undo()
    assert json.loads(path.read_text()) == {"v": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]


def test_unserialisable_json_leaves_nothing(tmp_path):
    with pytest.raises(TypeError):
        write_json(tmp_path / "x.json", {"a": object()})
    assert list(tmp_path.iterdir()) == []


def test_bad_mode_is_refused(tmp_path):
    with pytest.raises(InputError, match="mode"):
        with atomic_open(tmp_path / "x", "a"):
            pass
    assert list(tmp_path.iterdir()) == []


def test_write_json_strict_nan_and_inf(tmp_path):
    data = {
        "nan": math.nan,
        "inf": math.inf,
        "ninf": -math.inf,
        "list": [1.0, math.nan, (2, math.inf)],
        "np": np.float32(1.5),
        "arr": np.array([1.0, np.nan]),
        "i": np.int64(3),
        "s": "text",
    }
    path = write_json(tmp_path / "s.json", data)
    text = path.read_text()
    assert "NaN" not in text and "Infinity" not in text and text.endswith("\n")
    back = json.loads(text)
    assert back == {
        "nan": None,
        "inf": "inf",
        "ninf": "-inf",
        "list": [1.0, None, [2, "inf"]],
        "np": 1.5,
        "arr": [1.0, None],
        "i": 3,
        "s": "text",
    }
    assert json_safe(back) == back


def test_study_write_json_is_the_same_function():
    from armlab.study.runner import write_json as study_write_json

    assert study_write_json is write_json
