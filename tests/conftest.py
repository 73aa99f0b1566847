"""Shared fixtures. Plots go to a non-interactive backend; robots are loaded once per session."""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")
# one BLAS thread: small matrices (python-control, 10x10 expm) are 10-50x faster on 2 cores
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
# optimal() solves with IPOPT in the suite (the reference; no per-robot compile in every test
# that plans): tests/planning/test_fatrop.py runs the compiled fatrop path against it, once
# compiled into a temporary cache. ARMLAB_SOLVER=fatrop make test runs every plan on fatrop.
os.environ.setdefault("ARMLAB_SOLVER", "ipopt")

import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402

import armlab  # noqa: E402

# ``make test`` is reproducible: every hypothesis test draws the same examples on every run and
# machine (no example database); ``HYPOTHESIS_PROFILE=explore`` draws new ones
settings.register_profile("ci", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

REPO = Path(__file__).resolve().parents[1]


def example_robot_data_dir() -> Path:
    """Folder of the URDFs shipped by the ``example-robot-data`` wheel (data only)."""
    return (
        Path(sys.prefix)
        / "lib"
        / f"python{sys.version_info.major}.{sys.version_info.minor}"
        / "site-packages"
        / "cmeel.prefix"
        / "share"
        / "example-robot-data"
        / "robots"
    )


def _erd(rel: str) -> Path:
    path = example_robot_data_dir() / rel
    if not path.is_file():  # fall back to any site-packages on the path
        for p in sys.path:
            cand = Path(p) / "cmeel.prefix" / "share" / "example-robot-data" / "robots" / rel
            if cand.is_file():
                return cand
    return path


def sweep_env() -> dict:
    """Environment of an ``armlab sweep`` subprocess (headless plots)."""
    return {**os.environ, "MPLBACKEND": "Agg"}


def start_sweep(args: list[str], out: Path, rows: int, timeout_s: float = 120.0):
    """Start ``armlab sweep ARGS --out OUT`` as a subprocess and return it once at least
    ``rows`` result rows are on disk (one Parquet part file per finished row)."""
    import subprocess
    import time

    cmd = [sys.executable, "-m", "armlab.cli", "sweep", *args, "--out", str(out)]
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=sweep_env()
    )
    parts = out / "results.parts"
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        done = len(list(parts.glob("*.parquet"))) if parts.is_dir() else 0
        if done >= rows:
            return proc
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.02)
    proc.kill()
    raise AssertionError(f"fewer than {rows} sweep rows after {timeout_s} s")


UR5_URDF = _erd("ur_description/urdf/ur5_robot.urdf")
PANDA_URDF = _erd("panda_description/urdf/panda.urdf")
PANDA_FINGERS = ("panda_finger_joint1", "panda_finger_joint2")


@pytest.fixture(scope="session")
def teachbot6():
    """The thesis arm with its 0.5 kg payload. Do not mutate: use .copy() first."""
    return armlab.load_robot("teachbot6")


@pytest.fixture(scope="session")
def ur5():
    return armlab.load_robot(UR5_URDF)


@pytest.fixture(scope="session")
def panda():
    return armlab.load_robot(PANDA_URDF, lock_joints=PANDA_FINGERS, tool_frame="panda_hand")


@pytest.fixture(scope="session")
def inertias(teachbot6):
    """teachbot6's inertia range on 200 workspace samples (the tests/control modules)."""
    from armlab.control import inertia_range

    return inertia_range(teachbot6, n_samples=200, seed=0)


@pytest.fixture(scope="session")
def arm_gains(teachbot6):
    """teachbot6's gains tuned to the default spec on 200 inertia samples."""
    from armlab.control import tune_arm

    return tune_arm(teachbot6, n_inertia_samples=200, controller="reference_dda")


def make_study_folder(folder: Path, robot, trajectory, gains=None, profile=None) -> Path:
    """A study folder as ``armlab run`` leaves it for a design that passed, assembled from
    objects (for export tests whose trajectory no planner would produce): design.json,
    trajectory.npz, gains.json and a summary.json with the design verdict, the stage results it
    follows from (plan and export passed) and checksums."""
    from armlab.deploy import save_trajectory, write_gains
    from armlab.deploy.provenance import file_sha256
    from armlab.io import write_json
    from armlab.robot import load_profile
    from armlab.study.record import design_record

    folder.mkdir(parents=True, exist_ok=True)
    controller = load_profile(profile)
    write_json(folder / "design.json", design_record(robot, controller))
    save_trajectory(folder / "trajectory.npz", trajectory, robot)
    names = ["design.json", "trajectory.npz"]
    if gains is not None:
        write_gains(folder / "gains.json", gains, format="json")
        names.append("gains.json")
    passed = {"status": "ok", "verdict": "pass", "failed_checks": []}
    summary = {
        "study": {"stages": {"plan": passed, "export": passed}},
        "trajectory": passed,  # the plan stage's block
        "export": passed,
        "design": {"verdict": "pass", "failed_checks": [], "advisories": []},
        "files": {n: file_sha256(folder / n) for n in names},
    }
    write_json(folder / "summary.json", summary)
    return folder


@pytest.fixture(scope="module")
def client():
    """One local Dask cluster per test module (the same kind run_sweep starts): the sweep tests."""
    from distributed import Client, LocalCluster

    cluster = LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
    )
    with Client(cluster) as c:
        yield c
    cluster.close()
