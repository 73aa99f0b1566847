"""Collisions in a study: the obstacle keys, the plan stage's check, the key figure, the CLI."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from armlab.cli import main
from armlab.collision import CollisionError
from armlab.errors import InputError, SpecError
from armlab.study import run_spec
from armlab.study.figures import KEY_FIGURES
from armlab.study.spec import parse_study
from cases import one_line

DEMO_WAYPOINTS_DEG = [
    [0, 0, 0, 0, 0, 0],
    [45, 20, 30, 0, 40, 0],
    [90, 35, 10, 60, -30, 90],
    [0, 0, 0, 0, 0, 0],
]
#: under the whole demo cycle: the pick's tool point is at z = -0.097 m and the optimal plan
#: dips to about -0.14 m with the 30 mm payload sphere; the table top at -0.20 m (the arm on
#: a riser)
TABLE = {"name": "table", "box_m": [1.2, 1.4, 0.04], "xyz_m": [0.3, 0.2, -0.22]}
#: where the tool passes halfway from the pick to the place under the ptp planner
BOX = {"name": "box", "box_m": [0.08, 0.08, 0.08], "xyz_m": [0.199, 0.503, -0.057]}


def _doc(planner: str = "ptp", obstacles=(TABLE,), stages=("kinematics", "plan"), **plan):
    return {
        "study": {"name": "collision", "stages": list(stages), "report": False},
        "robot": {"name": "teachbot6"},
        "payload": {"mass_kg": 0.5, "sphere_m": 0.03},
        "waypoints": {"unit": "deg", "joint": DEMO_WAYPOINTS_DEG},
        "plan": {"planner": planner, **plan},
        "obstacle": [dict(o) for o in obstacles],
    }


def _toml(doc: dict) -> str:
    lines = []
    for table in ("study", "robot", "payload", "waypoints", "plan"):
        lines.append(f"[{table}]")
        lines += [f"{k} = {json.dumps(v)}" for k, v in doc[table].items()]
    for o in doc["obstacle"]:
        lines.append("[[obstacle]]")
        lines += [f"{k} = {json.dumps(v)}" for k, v in o.items()]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------- the keys
@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"obstacle": [{"box_m": [1, 1, 1]}]}, "obstacle[0].name"),
        ({"obstacle": [{"name": "a", "box_m": [1, 1, 1], "sphere_m": 1}]}, "obstacle[0]: give"),
        ({"obstacle": [{"name": "a", "box_m": [1, -1, 1]}]}, "obstacle[0].box_m[1]"),
        ({"obstacle": [{"name": "a", "sphere_m": float("nan")}]}, "obstacle[0].sphere_m"),
        ({"obstacle": [{"name": "a", "cylinder_m": [0.1]}]}, "obstacle[0].cylinder_m"),
        ({"obstacle": [{"name": "a", "sphere_m": 1, "colour": "red"}]}, "obstacle[0].colour"),
        ({"obstacle": [{"name": "a", "sphere_m": 1, "xyz_m": [0, 0]}]}, "obstacle[0].xyz_m"),
        ({"obstacle": [{"name": "a", "sphere_m": 1, "rpy_deg": [0, 0, "x"]}]}, "rpy_deg[2]"),
        ({"obstacle": [{"name": "a", "mesh": "nowhere.stl"}]}, "obstacle[0].mesh"),
        ({"obstacle": [{"name": "a", "sphere_m": 1, "mesh_scale": [1, 1, 1]}]}, "mesh_scale"),
        ({"obstacle": [{"name": "a*/ #define X", "sphere_m": 1}]}, "obstacle[0].name"),
        ({"obstacle": [{"name": "floor", "sphere_m": 1}]}, "obstacle[0].name"),
        ({"obstacle": [TABLE, TABLE]}, "obstacle[1].name"),
        ({"obstacle": {"name": "a"}}, "obstacle"),
        ({"payload": {"sphere_m": -0.1}}, "payload.sphere_m"),
        ({"payload": {"box_m": [0.1, 0.1, 0.1], "capsule_m": [0.1, 0.1]}}, "payload"),
        ({"payload": {"sphere_m": 0.1, "shape_xyz_m": [0, 0]}}, "payload.shape_xyz_m"),
        ({"plan": {"clearance_m": -0.01}}, "plan.clearance_m"),
        ({"robot": {"name": "teachbot6", "floor_z_m": "low"}}, "robot.floor_z_m"),
    ],
)
def test_bad_collision_keys_are_one_line_naming_the_key(change, key):
    doc = _doc()
    doc.update(change)
    with pytest.raises(SpecError) as err:
        parse_study(doc)
    msg = str(err.value)
    assert key in msg and "\n" not in msg, msg


def test_shapes_are_parsed_with_their_units():
    spec = parse_study(
        _doc(
            obstacles=[
                TABLE,
                {
                    "name": "post",
                    "cylinder_m": [0.05, 0.4],
                    "xyz_m": [0.5, 0, 0],
                    "rpy_deg": [90, 0, 0],
                },
            ]
        )
    )
    table, post = spec.obstacles
    assert (table.kind, table.size_m, table.xyz_m) == ("box", (1.2, 1.4, 0.04), (0.3, 0.2, -0.22))
    assert (post.kind, post.size_m, post.rpy_deg) == ("cylinder", (0.05, 0.4), (90.0, 0.0, 0.0))
    assert spec.payload_shape is not None and spec.payload_shape.size_m == (0.03,)
    assert spec.plan.clearance_m == 0.0 and spec.robot.floor_z_m is None  # the defaults


# ---------------------------------------------------------------------------- the plan stage
def test_demo_cycle_over_a_table_passes_with_its_clearance_as_a_key_figure():
    """The demo cycle (its optimal planner) with a table under it and a 10 mm clearance: the
    plan stage passes, the plan block records the certified clearance and the key figure
    ``min_clearance_m`` is that minimum."""
    res = run_spec(parse_study(_doc("optimal", clearance_m=0.01)))
    block = res.summary["trajectory"]
    assert block["status"] == "ok", block
    clear = block["clearance"]
    assert clear["ok"] and clear["min_distance_m"] >= 0.01
    assert block["collision"]["obstacles"] == ["table"]
    assert block["collision"]["geometry"] == "collision"
    assert "min_clearance_m" in KEY_FIGURES
    assert res.summary["key_figures"]["min_clearance_m"] == pytest.approx(
        clear["min_distance_m"], abs=0.0
    )


def test_a_box_between_two_waypoints_fails_the_plan_naming_the_pair():
    """A box where the ptp plan's tool passes between the pick and the place: the plan stage
    refuses it (CollisionError) naming the box, the pair's other shape, the time and the
    depth."""
    with pytest.raises(CollisionError) as err:
        run_spec(parse_study(_doc("ptp", obstacles=[TABLE, BOX])))
    msg = str(err.value)
    assert "box" in msg and " and " in msg and "t = " in msg and "mm" in msg, msg
    assert "\n" not in msg


def test_waypoint_in_collision_is_bad_input():
    """A box around the pick's tool point: waypoints.joint[1] is in collision -- bad input, one
    line naming the waypoint and the pair."""
    box = {"name": "crate", "box_m": [0.1, 0.1, 0.1], "xyz_m": [0.273, 0.273, -0.097]}
    with pytest.raises(InputError) as err:
        run_spec(parse_study(_doc("ptp", obstacles=[box])))
    msg = str(err.value)
    assert "waypoints.joint[1]" in msg and "crate" in msg and "in collision" in msg, msg


def test_armlab_run_exports_only_a_clear_plan(tmp_path, capsys):
    """``armlab run`` with plan + export: over the table the set-point table is written; with
    the box in the way the run stops at the plan (exit 2, one line naming the box), writes no
    table, and its summary.json keeps the clearance as a key figure (negative: penetration)."""
    stages = ("kinematics", "plan", "export")
    clear, blocked = tmp_path / "clear.toml", tmp_path / "blocked.toml"
    clear.write_text(_toml(_doc("ptp", stages=stages)))
    blocked.write_text(_toml(_doc("ptp", obstacles=[TABLE, BOX], stages=stages)))
    assert main(["run", str(clear), "--out", str(tmp_path / "a")]) in (0, 1)
    capsys.readouterr()
    assert (tmp_path / "a" / "setpoints.csv").is_file()
    assert main(["run", str(blocked), "--out", str(tmp_path / "b")]) == 2
    line = one_line(capsys)
    assert "box" in line and "t = " in line
    assert not Path(tmp_path / "b" / "setpoints.csv").exists()
    summary = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert summary["trajectory"]["error_type"] == "CollisionError"
    assert summary["key_figures"]["min_clearance_m"] < 0.0
