"""The documentation follows the code: every study key, every output file's keys and columns.

``make docs`` (CI) builds the pages with ``mkdocs build --strict``; these tests need no MkDocs.
They expand the pages' generated tables with the build's own hook (docs/hooks/armlab_docs.py)
and compare the pages with what a real (small) study writes: a summary.json key, a design.json
key, a set-point column or a gains.json field that the pages do not name fails here.
"""

from __future__ import annotations

import csv
import importlib
import importlib.util
import json
import re
from dataclasses import fields
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
API_PACKAGES = (
    "robot",
    "kinematics",
    "trajectory",
    "planning",
    "dynamics",
    "control",
    "deploy",
    "plots",
    "study",
    "sweep",
)


def _hook():
    spec = importlib.util.spec_from_file_location("armlab_docs", DOCS / "hooks" / "armlab_docs.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _page(name: str) -> str:
    return _hook().expand((DOCS / name).read_text())


def _documented(text: str) -> set[str]:
    """Every `code span` of a page (table cells, lists)."""
    return set(re.findall(r"`([^`]+)`", text))


def test_nav_pages_exist_and_every_api_package_has_a_page():
    nav = re.findall(r":\s*([\w/.-]+\.md)\s*$", (REPO / "mkdocs.yml").read_text(), re.MULTILINE)
    assert nav and all((DOCS / page).is_file() for page in nav), nav
    for package in API_PACKAGES:
        assert f"api/{package}.md" in nav
        assert f"::: armlab.{package}" in (DOCS / "api" / f"{package}.md").read_text()
    assert {"architecture.md", "references.md", "study-file.md", "outputs.md"} <= set(nav)
    assert "api/armlab.md" in nav and "::: armlab\n" in (DOCS / "api" / "armlab.md").read_text()


def test_a_public_name_that_is_also_a_submodule_is_rendered_from_its_module():
    """Issue 23: a function imported over the submodule of its name is listed by mkdocstrings
    as that submodule and so left out of the package's page; its page renders it from the
    module (``::: armlab.dynamics.static_load.static_load``). ``armlab.planning.optimal`` has no
    submodule of its name any more (``planning/optimiser.py``): the package's page lists it."""
    clashes = []
    for package in API_PACKAGES:
        module = importlib.import_module(f"armlab.{package}")
        folder = REPO / "research" / "armlab" / package
        for name in module.__all__:
            if (folder / f"{name}.py").is_file() or (folder / name / "__init__.py").is_file():
                clashes.append((package, name))
                page = (DOCS / "api" / f"{package}.md").read_text()
                assert f"::: armlab.{package}.{name}.{name}" in page, (package, name)
    assert ("dynamics", "static_load") in clashes  # what it tests
    import armlab.planning

    assert callable(armlab.planning.optimal) and ("planning", "optimal") not in clashes


def test_study_file_page_names_every_table_and_key():
    from armlab.study import spec

    text = _page("study-file.md")
    assert "armlab:" not in text  # every marker expanded
    for table, cls in [*spec._SECTIONS.items(), ("drives.<joint>", spec.DriveOverride)]:
        assert f"### `[{table}]`" in text, table
        section = text.split(f"### `[{table}]`", 1)[1].split("\n### ", 1)[0]
        for f in fields(cls):
            assert f"| `{f.name}` |" in section, (table, f.name)
    assert "`payload.mass_kg`" in text and "[[parameter]]" in text  # the sweep file too


def test_bring_your_own_arm_names_every_drives_field():
    from armlab.robot import drives

    text = _page("bring-your-own-arm.md")
    for cls in (drives.Motor, drives.Reducer, drives.Encoder, drives.Drive):
        for f in fields(cls):
            if f.name not in ("motor", "reducer", "encoder", "joint"):
                assert f"| `{f.name}` |" in text, (cls.__name__, f.name)
    assert "teachbot6" in text


@pytest.fixture(scope="module")
def study_folder(tmp_path_factory) -> Path:
    """A small real study that writes every data file: plan, sizing, tuning, tracking, export."""
    from armlab.study import load_study, run_spec

    out = tmp_path_factory.mktemp("study")
    spec = load_study(
        None,
        {
            "study.report": False,
            "study.stages": ["kinematics", "plan", "sizing", "tuning", "tracking", "export"],
            "plan.planner": "ptp",
            "kinematics.workspace_samples": 0,
            "kinematics.accuracy_samples": 0,
            "control.n_inertia_samples": 20,
        },
    )
    run_spec(spec, out)
    return out


def test_outputs_page_names_every_summary_and_design_key(study_folder):
    from armlab.study.spec import STAGES
    from armlab.study.stages import SUMMARY_KEY

    documented = _documented(_page("outputs.md"))
    summary = json.loads((study_folder / "summary.json").read_text())
    missing = [k for k in summary if k not in documented]
    assert not missing, f"summary.json keys not in docs/outputs.md: {missing}"
    for key in ("study", "design"):
        missing = [k for k in summary[key] if k not in documented]
        assert not missing, f"summary.json {key}.* not in docs/outputs.md: {missing}"
    for stage in STAGES:  # each stage block's own keys (joint names aside)
        block = summary[SUMMARY_KEY[stage]]
        joints = set(summary["robot"]["joint_names"])
        missing = [k for k in block if k not in documented and k not in joints]
        assert not missing, f"summary.json {SUMMARY_KEY[stage]}.* not documented: {missing}"
    assert "incomplete" in documented and set(summary["files"]) <= documented
    kf = [k for k in summary["key_figures"] if not k.startswith("stage_")]
    assert not [k for k in kf if k not in documented], kf
    design = json.loads((study_folder / "design.json").read_text())
    for key, block in (("", design), ("robot.", design["robot"])):
        missing = [k for k in block if k not in documented]
        assert not missing, f"design.json {key}* not in docs/outputs.md: {missing}"


def test_outputs_page_names_every_setpoint_column_and_gains_field(study_folder):
    documented = _documented(_page("outputs.md"))
    with open(study_folder / "setpoints.csv") as f:
        header = next(row for row in csv.reader(f) if row and not row[0].startswith("#"))
    joints = json.loads((study_folder / "design.json").read_text())["robot"]["joint_names"]
    generic = {re.sub("|".join(map(re.escape, joints)), "<joint>", c) for c in header}
    assert len(generic) == 7 and not generic - documented, sorted(generic - documented)
    gains = json.loads((study_folder / "gains.json").read_text())
    assert not [k for k in gains if k not in documented]
    joint = next(iter(gains["joints"].values()))
    assert not [k for k in joint if k not in documented and k not in ("current", "speed")]
    loop = joint["position"]
    names = " ".join(sorted(documented))
    missing = [k for k in loop if k not in documented and k.replace("_discrete", "") not in names]
    assert not missing, f"gains.json loop fields not in docs/outputs.md: {missing}"


def test_hook_refuses_an_unknown_marker_and_an_unknown_validator():
    hook = _hook()
    with pytest.raises(ValueError, match="unknown marker"):
        hook.expand("<!-- armlab:no-such-table -->")

    def _oddity(value, where):  # a validator kind the hook has never seen
        return value

    with pytest.raises(ValueError, match="cannot describe"):
        hook._allowed(_oddity)


def test_rst_tables_and_roles_read_as_markdown():
    spec = importlib.util.spec_from_file_location("griffe_rst", DOCS / "hooks" / "griffe_rst.py")
    assert spec is not None and spec.loader is not None
    rst = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(rst)
    text = (
        "Figures (:func:`~armlab.plots.plot_workspace`)::\n\n"
        "===========  ==================\n"
        "module       figures\n"
        "===========  ==================\n"
        ":mod:`.kin`  workspace cloud,\n"
        "             accuracy\n"
        "servo        Bode\n"
        "===========  ==================\n"
    )
    out = rst.rst_to_markdown(text)
    assert out.splitlines()[0] == "Figures (`plot_workspace`):"
    assert "| module | figures |" in out
    assert "| `.kin` | workspace cloud, accuracy |" in out
    assert "| servo | Bode |" in out and "====" not in out
