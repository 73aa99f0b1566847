"""Sweep files, parameter sets, the result store and local sweeps (armlab.sweep)."""

from __future__ import annotations

import math
import os
import re
import signal
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from armlab.errors import SpecError
from armlab.sweep import ResultStore, load_sweep, parse_sweep, run_sweep_spec
from armlab.sweep.spec import parameter_key, parameter_sets
from armlab.sweep.task import run_parameter_set
from cases import quick_study
from conftest import start_sweep, sweep_env

# A cheap study: teachbot6, joint waypoints, the kinematics checks and a short classical plan.
QUICK_STUDY = quick_study()


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def sweep_doc(**sweep) -> dict:
    return {
        "sweep": {"study": "demo", **sweep},
        "parameter": [
            {"key": "payload.mass_kg", "values": [0.0, 0.5, 1.0]},
            {"key": "drives.joint2.ratio", "low": 300, "high": 500, "num": 3},
        ],
    }


# ---------------------------------------------------------------------------- spec
def test_grid_is_the_cartesian_product():
    spec = parse_sweep(sweep_doc())
    sets = parameter_sets(spec)
    assert len(sets) == 9
    assert sets[0] == {"payload.mass_kg": 0.0, "drives.joint2.ratio": 300.0}
    assert sets[-1] == {"payload.mass_kg": 1.0, "drives.joint2.ratio": 500.0}
    assert sorted({s["drives.joint2.ratio"] for s in sets}) == [300.0, 400.0, 500.0]
    assert len({parameter_key(s) for s in sets}) == 9


def test_random_and_lhs_draws_are_seeded_and_in_range():
    doc = sweep_doc(mode="lhs", samples=8, seed=3)
    doc["parameter"][1]["log"] = True
    a, b = (parameter_sets(parse_sweep(doc)) for _ in range(2))
    assert a == b  # reproducible from the file
    ratios = np.array([s["drives.joint2.ratio"] for s in a])
    assert np.all((ratios >= 300) & (ratios <= 500))
    # Latin hypercube: one sample in each of the 8 equal-probability strata (log scale)
    u = (np.log(ratios) - np.log(300)) / (np.log(500) - np.log(300))
    assert sorted(np.floor(u * 8).astype(int)) == list(range(8))
    doc = sweep_doc(mode="random", samples=50, seed=1)
    r1 = parameter_sets(parse_sweep(doc))
    doc["sweep"]["seed"] = 2
    r2 = parameter_sets(parse_sweep(doc))
    assert r1 != r2
    assert {s["payload.mass_kg"] for s in r1} <= {0.0, 0.5, 1.0}


def test_parameter_key_is_stable():
    a = {"payload.mass_kg": 0.5, "drives.joint2.ratio": 300}
    b = {"drives.joint2.ratio": 300.0, "payload.mass_kg": 0.5}
    assert parameter_key(a) == parameter_key(b)
    assert parameter_key(a) != parameter_key({**a, "payload.mass_kg": 0.25})
    assert len(parameter_key(a)) == 16


@pytest.mark.parametrize(
    "mutate, key",
    [
        (lambda d: d["sweep"].update(mode="sobol"), "sweep.mode"),
        (lambda d: d["sweep"].update(mode="random"), "sweep.samples"),
        (lambda d: d["sweep"].update(workers=3), "sweep.workers"),
        (lambda d: d["sweep"].update(figures=["speed"]), "sweep.figures"),
        (lambda d: d["parameter"][0].update(key="payload.mass"), "payload.mass"),
        (lambda d: d["parameter"][0].update(low=1), "parameter[0].low"),
        (lambda d: d["parameter"][1].pop("num"), "parameter[1].num"),
        (lambda d: d["parameter"][1].update(high=100), "parameter[1].high"),
        (lambda d: d["parameter"][0].update(values=[1, 1]), "parameter[0].values"),
        (lambda d: d["parameter"][0].update(values=[1, "a"]), "parameter[0].values"),
        (lambda d: d["parameter"].append({"key": "payload.mass_kg", "values": [2]}), "parameter"),
        (lambda d: d.update(set={"plan": {"planer": "ptp"}}), "plan.planer"),
        (lambda d: d["sweep"].update(study="nowhere.toml"), "sweep.study"),
        (lambda d: d.update(parameter=[]), "parameter"),
    ],
)
def test_bad_sweep_names_the_key(mutate, key):
    doc = sweep_doc()
    mutate(doc)
    with pytest.raises(SpecError) as err:
        parse_sweep(doc)
    assert str(err.value).startswith(key), str(err.value)


# ---------------------------------------------------------------------------- one task
def test_task_rows_never_raise():
    spec = parse_sweep(sweep_doc())
    doc = spec.study_document
    bad = run_parameter_set(doc, str(spec.study_dir), "demo", {"drives.joint2.ratio": -1.0}, "k")
    assert bad["status"] == "error" and bad["error"].startswith("SpecError: drives.joint2.ratio")
    assert bad["key"] == "k" and bad["drives.joint2.ratio"] == -1.0
    duration_recorded = bad["elapsed_s"] >= 0  # a column of the row, not a speed goal
    assert duration_recorded and bad["worker"].endswith(f":{os.getpid()}")


# ---------------------------------------------------------------------------- store
def test_store_resumes_and_refuses_another_study(tmp_path):
    meta = {"study_hash": "a" * 64, "parameters": ["x"]}
    store = ResultStore(tmp_path, meta, consolidate_s=0.0)
    store.add({"key": "k1", "x": 1.0, "status": "done", "error": "", "f": 2.0})
    store.add({"key": "k2", "x": "motor-b", "status": "error", "error": "boom", "f": math.nan})
    again = ResultStore(tmp_path, meta)
    assert len(again) == 2 and again.status("k2") == "error"
    assert again.rows["k1"]["f"] == 2.0
    # the consolidated table is gone (crash before a flush): the part files are the record
    (tmp_path / "results.parquet").unlink()
    assert len(ResultStore(tmp_path, meta)) == 2
    with pytest.raises(SpecError, match="another base study"):
        ResultStore(tmp_path, {**meta, "study_hash": "b" * 64})
    with pytest.raises(SpecError, match="a sweep over"):
        ResultStore(tmp_path, {**meta, "parameters": ["y"]})


# ---------------------------------------------------------------------------- sweeps
def quick_sweep(tmp_path: Path, ratios: list[float], payloads=(0.0, 1.0)) -> Path:
    write(tmp_path / "quick_study.toml", QUICK_STUDY)
    params = ", ".join(repr(r) for r in ratios)
    masses = ", ".join(repr(m) for m in payloads)
    return write(
        tmp_path / "sweep.toml",
        f"""
[sweep]
name = "quick"
study = "quick_study.toml"
figures = ["duration_s", "max_static_torque_Nm"]
[[parameter]]
key = "payload.mass_kg"
values = [{masses}]
[[parameter]]
key = "drives.joint2.ratio"
values = [{params}]
""",
    )


def test_impossible_set_is_an_error_row_and_the_rest_are_done(tmp_path, client, capsys):
    # no motor of teachbot6 can hold 25 kg: the plan stage refuses that set (gravity alone
    # needs more than the torque limits; the message names the joint furthest over its limit);
    # the sweep goes on
    path = quick_sweep(tmp_path, [410.0], payloads=[0.0, 0.5, 1.0, 25.0])
    spec = load_sweep(path)
    out = tmp_path / "out"
    df = run_sweep_spec(spec, out, client=client)
    assert len(df) == 4
    err = df[df["status"] == "error"]
    assert list(err["payload.mass_kg"]) == [25.0]
    msg = err["error"].iloc[0]
    assert msg.startswith("LimitViolation: plan: ") and "gravity alone" in msg
    named = re.search(r"needs ([\d.]+) N m at (joint\d).*torque limit ([\d.]+) N m", msg)
    assert named and float(named[1]) > float(named[3])  # the named joint is really over it
    done = df[df["status"] == "done"]
    assert len(done) == 3 and (done["error"] == "").all()
    assert (done["stage_plan"] == "ok").all() and (done["stage_static_load"] == "ok").all()
    assert done["duration_s"].notna().all()
    # the table on disk is the same rows, and a part file per row
    disk = pd.read_parquet(out / "results.parquet")
    assert sorted(disk["key"]) == sorted(df["key"])
    assert len(list((out / "results.parts").glob("*.parquet"))) == 4
    text = capsys.readouterr().out
    assert "3 done, 1 error; 4 run now" in text and "payload.mass_kg=25" in text
    assert (out / "summary.txt").read_text().startswith("armlab sweep 'quick'")
    # a heavier payload never lowers the worst static torque
    assert done["max_static_torque_Nm"].is_monotonic_increasing
    # run again: nothing to do, the same rows
    df2 = run_sweep_spec(spec, out, client=client, quiet=True)
    pd.testing.assert_series_equal(df2["finished_at"], df["finished_at"])


def test_resume_runs_only_what_is_missing(tmp_path, client):
    path = quick_sweep(tmp_path, [300.0, 410.0])
    spec = load_sweep(path)
    out = tmp_path / "out"
    df = run_sweep_spec(spec, out, client=client, quiet=True)
    assert (df["status"] == "done").all()
    # as after a crash: two rows never made it to disk, the consolidated table is stale
    lost = list(df["key"][:2])
    for k in lost:
        (out / "results.parts" / f"{k}.parquet").unlink()
    (out / "results.parquet").unlink()
    df2 = run_sweep_spec(spec, out, client=client, quiet=True)
    changed = df2.set_index("key")["finished_at"] != df.set_index("key")["finished_at"]
    assert sorted(changed[changed].index) == sorted(lost)
    # the sweep with another base study refuses the folder
    write(
        tmp_path / "quick_study.toml",
        QUICK_STUDY.replace("check_dt_s = 0.01", "check_dt_s = 0.005"),
    )
    with pytest.raises(SpecError, match="another base study"):
        run_sweep_spec(load_sweep(path), out, client=client, quiet=True)


def test_ctrl_c_loses_nothing_and_the_same_command_resumes(tmp_path):
    """`armlab sweep` on its own local cluster, interrupted (SIGINT) after a few rows: exit 130,
    the rows done are on disk; the same command then runs only the rest, and plots."""
    write(
        tmp_path / "study.toml",
        QUICK_STUDY.replace(
            "report = false", "report = false\n[kinematics]\naccuracy_samples = 10000"
        ),
    )
    sweep = write(
        tmp_path / "sweep.toml",
        """
[sweep]
name = "interrupt"
study = "study.toml"
figures = ["duration_s"]
[[parameter]]
key = "payload.mass_kg"
values = [0.0, 0.25, 0.5, 0.75]
[[parameter]]
key = "drives.joint2.ratio"
values = [300, 410, 450]
""",
    )
    out = tmp_path / "out"
    proc = start_sweep([str(sweep), "--workers", "2"], out, rows=2)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and err.strip().endswith("armlab: interrupted")
    done = pd.read_parquet(out / "results.parquet")
    assert 2 <= len(done) < 12 and (done["status"] == "done").all()
    again = subprocess.run(proc.args, capture_output=True, text=True, env=sweep_env(), timeout=180)
    assert again.returncode == 0, again.stderr
    assert f"{12 - len(done)} run now" in again.stdout
    assert f"{len(done)} already in" in again.stdout
    df = pd.read_parquet(out / "results.parquet")
    assert len(df) == 12 and (df["status"] == "done").all()
    kept = df.set_index("key").loc[done["key"], "finished_at"]
    np.testing.assert_array_equal(kept.to_numpy(), done["finished_at"].to_numpy())
    assert df["worker"].nunique() >= 2  # two worker processes in each run
    plots = sorted(p.name for p in (out / "plots").glob("*.png"))
    assert plots == ["duration_s_vs_drives.joint2.ratio.png", "duration_s_vs_payload.mass_kg.png"]
