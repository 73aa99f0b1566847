"""Export what was verified (issue 25 item 4): each format says which parts of the simulated
controller it carries; a target that cannot run what the verdict assumed is simulated as it
will run, and its export is refused when that misses the budget (unless --force, recorded)."""

from __future__ import annotations

import json
import re

import pytest

from armlab.cli import main
from armlab.control import simulate_tracking
from armlab.deploy.carries import target_of
from armlab.errors import DesignFailure
from armlab.study import export_study, load_study, run_spec
from armlab.study.spec import demo_study_path

THESIS_FF = ("velocity", "acceleration", "gravity", "friction", "efficiency")


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """The demo study (thesis feed-forward + losses, PASS at 0.30 mm of 0.5 mm) in a folder."""
    out = tmp_path_factory.mktemp("demo") / "run"
    quick = {"kinematics.workspace_samples": 100, "kinematics.accuracy_samples": 100}
    result = run_spec(load_study(demo_study_path(), quick), out, report=False)
    assert result.design.verdict == "pass"
    assert tuple(result.summary["tracking"]["feedforward"]) == THESIS_FF
    return out, result


def test_what_each_target_runs_of_the_thesis_feedforward():
    jtc, csp, table = target_of("ros2"), target_of("cia402"), target_of("csv")
    assert jtc.feedforward(THESIS_FF) == ("velocity",)
    assert jtc.differences(("velocity",)) == []
    assert jtc.differences(THESIS_FF) == [
        "it cannot run the feed-forward acceleration, gravity, friction, efficiency"
    ]
    # the CiA 402 torque offset is the whole inverse dynamics: gravity and inertia are in it
    assert csp.differences(THESIS_FF) == [
        "it runs the feed-forward computed_torque, which was not verified"
    ]
    assert csp.differences(("velocity", "computed_torque", "friction", "efficiency")) == []
    assert table.differences(THESIS_FF) == [] and target_of("trajectory") == jtc


def test_a_jtc_export_of_a_design_that_needs_gravity_feedforward_is_refused(demo, tmp_path):
    out, result = demo
    ctx = result.context
    # independent: the demo's tracking with only the velocity term a JTC can feed forward
    alone = simulate_tracking(
        ctx.robot, ctx.trajectory, ctx.gains, feedforward=("velocity",), controller=ctx.controller
    )
    assert not alone.within_accuracy
    for fmt in ("ros2", "trajectory"):
        with pytest.raises(DesignFailure) as exc:
            export_study(out, fmt, out_dir=tmp_path / fmt)
        msg = str(exc.value)
        assert "\n" not in msg and "cannot run the feed-forward acceleration, gravity" in msg
        err_mm = float(re.search(r"TCP error ([0-9.]+) mm > budget", msg).group(1))
        assert err_mm == pytest.approx(alone.tcp_max_error_m * 1e3, rel=1e-3)
        assert not (tmp_path / fmt).exists() or not any((tmp_path / fmt).iterdir())


def test_a_forced_jtc_export_records_what_differs(demo, tmp_path, capsys):
    out, _ = demo
    assert main(["export", str(out), "--format", "ros2", "--out", str(tmp_path), "--force"]) == 0
    assert "forced export" in capsys.readouterr().err
    text = (tmp_path / "ros2_controllers.yaml").read_text()
    assert "ros2 target: simulated as it will run" in text  # the forced failure, recorded
    assert "ff_velocity_scale: 1.0" in text


def test_cia402_carries_the_torque_feedforward_and_its_simulation_passes(demo, tmp_path):
    out, _ = demo
    result = export_study(out, "cia402", out_dir=tmp_path)
    note = next(n for n in result.notes if "simulated as it will run" in n)
    assert note.endswith("PASS")
    header = (tmp_path / "cia402_csp.csv").read_text().splitlines()
    meta = json.loads(next(h for h in header if h.startswith("# meta: "))[len("# meta: ") :])
    block = meta["source"]["controller"]
    assert block["feedforward_verified"] == list(THESIS_FF)
    assert block["feedforward_run"] == ["velocity", "computed_torque", "friction", "efficiency"]
    assert block["target_tracking"]["verdict"] == "pass"
    assert block["target_tracking"]["tcp_max_error_m"] < block["target_tracking"]["accuracy_m"]


def test_the_run_and_export_tables_say_the_same_controller(demo, tmp_path):
    out, _ = demo
    export_study(out, "csv", out_dir=tmp_path)
    assert (tmp_path / "setpoints.csv").read_bytes() == (out / "setpoints.csv").read_bytes()
    header = (out / "setpoints.csv").read_text().splitlines()
    meta = json.loads(next(h for h in header if h.startswith("# meta: "))[len("# meta: ") :])
    block = meta["source"]["controller"]
    assert block["feedforward_run"] == list(THESIS_FF) and block["differences"] == []
