"""Importing the light packages pulls in neither CasADi, matplotlib nor Dask (fresh interpreter)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("casadi", "matplotlib", "dask")
LIGHT = ("armlab", "armlab.robot", "armlab.kinematics", "armlab.dynamics")


def _loaded_after(modules) -> list[str]:
    code = (
        "import json, sys\n"
        + "".join(f"import {m}\n" for m in modules)
        + f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def test_light_packages_do_not_import_heavy_dependencies():
    assert _loaded_after(LIGHT) == []


@pytest.mark.parametrize("module", ["armlab.trajectory", "armlab.io"])
def test_trajectory_and_io_do_not_import_casadi_or_matplotlib(module):
    assert _loaded_after([module]) == []


def test_lazy_names_still_work():
    """The optimisers keep their stable names (armlab.trajectory.optimal), the plots import no
    matplotlib until drawn, CasADi loads on the first symbolic build."""
    code = (
        "import sys\n"
        "from armlab.trajectory import optimal\n"
        "from armlab.robot.symbolic import inverse_dynamics_function\n"
        "from armlab.plots import plot_joints, plot_workspace, plot_joint_loads\n"
        "assert callable(optimal) and 'casadi' not in sys.modules\n"
        "import armlab, numpy as np\n"
        "r = armlab.load_robot('teachbot6')\n"
        "f = inverse_dynamics_function(r)\n"
        "assert 'casadi' in sys.modules\n"
        "print(float(np.asarray(f(np.zeros(6), np.zeros(6), np.zeros(6))).ravel()[1]))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert float(out.strip().splitlines()[-1]) != 0.0  # gravity on the shoulder


@pytest.mark.parametrize("module", ["armlab", "armlab.dynamics"])
def test_package_import_alone_loads_no_heavy_dependency(module):
    """Each alone, in a fresh interpreter: no CasADi, matplotlib or Dask, and no
    ``scipy.optimize`` (~0.3 s; the static-load search imports it when it runs)."""
    code = (
        "import json, sys\n"
        f"import {module}\n"
        f"print(json.dumps([m for m in {HEAVY + ('scipy.optimize',)!r} if m in sys.modules]))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert json.loads(out.strip().splitlines()[-1]) == []


PACKAGES = (
    "collision",
    "control",
    "deploy",
    "dynamics",
    "io",
    "kinematics",
    "planning",
    "plots",
    "robot",
    "study",
    "sweep",
    "trajectory",
)


def test_import_armlab_loads_no_pinocchio():
    """The front door resolves its verbs on first use: ``import armlab`` alone loads neither
    Pinocchio nor numpy (it did both before issue 23: ~0.2 s)."""
    code = (
        "import json, sys\nimport armlab\n"
        "print(json.dumps([m for m in ('pinocchio', 'numpy', 'casadi') if m in sys.modules]))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert json.loads(out.strip().splitlines()[-1]) == []


def test_front_door_names_are_their_packages():
    """Every name of ``armlab.__all__`` resolves, and a verb is the very object its package
    exports; the type checkers' imports name the same packages as the lazy table."""
    import ast
    import importlib
    from pathlib import Path

    import armlab

    for name in armlab.__all__:
        assert getattr(armlab, name) is not None, name
    for name, package in armlab._VERBS.items():
        home = importlib.import_module(package)
        assert name in home.__all__, (name, package)
        assert getattr(armlab, name) is getattr(home, name)
    tree = ast.parse(Path(armlab.__file__).read_text())
    typed = {
        a.name: n.module
        for node in tree.body
        if isinstance(node, ast.If)  # if TYPE_CHECKING:
        for n in node.body
        if isinstance(n, ast.ImportFrom)
        for a in n.names
    }
    assert set(typed) == set(armlab._VERBS)
    assert all(typed[k].startswith(v) for k, v in armlab._VERBS.items())
    assert set(armlab._VERBS) <= set(armlab.__all__)
    assert armlab.study is importlib.import_module("armlab.study")  # subpackages on first use
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        armlab.nonsense  # noqa: B018


def test_each_name_is_exported_by_one_package():
    """No subpackage re-exports another's names (``Limits`` and ``resolve_limits`` are
    :mod:`armlab.robot`'s alone), and every ``__all__`` entry exists."""
    import importlib

    seen: dict[str, str] = {}
    for p in PACKAGES:
        module = importlib.import_module(f"armlab.{p}")
        for name in module.__all__:
            assert hasattr(module, name), f"armlab.{p}.{name}"
            assert name not in seen, f"{name}: exported by armlab.{seen[name]} and armlab.{p}"
            seen[name] = p
    assert seen["Limits"] == seen["resolve_limits"] == "robot"
    assert seen["load_profile"] == "robot"


def test_controller_is_handed_over_one_way():
    """Every public function that takes the joint controller calls it ``controller`` and needs
    it (no silent default profile; ``export_study``'s None is the study's own controller); a
    parameter named ``profile`` is a motion-profile shape (a string), never the controller; an
    old keyword fails with one line naming the new one."""
    import importlib
    import inspect

    import armlab

    takers = []
    for p in PACKAGES:
        module = importlib.import_module(f"armlab.{p}")
        for name in module.__all__:
            obj = getattr(module, name)
            if not inspect.isfunction(obj):
                continue
            params = inspect.signature(obj).parameters
            if "controller" in params:
                takers.append(name)
                default = params["controller"].default
                if name == "export_study":
                    assert default is None
                else:
                    assert default is inspect.Parameter.empty, name
            if "profile" in params:
                assert isinstance(params["profile"].default, str), name
    assert set(takers) >= {
        "cia402_csp",
        "jtc_constraints",
        "select_drives",
        "setpoint_table",
        "simulate_tracking",
        "size",
        "tune_arm",
    }
    robot = armlab.load_robot("teachbot6")
    with pytest.raises(TypeError, match=r"^setpoint_table\(\): profile= is now controller=$"):
        armlab.setpoint_table(robot, None, profile="reference_dda")
    with pytest.raises(TypeError, match=r"size\(\): options= is now controller="):
        armlab.size(robot, None, options=None)
    with pytest.raises(TypeError, match="controller"):
        armlab.simulate_tracking(robot, None, None)  # type: ignore[call-arg]


def test_planners_take_the_torque_limit_as_tau_max():
    """Every planner with joint limits takes the torque limit as ``tau_max`` (None the robot's,
    False off, a value replaces it), as ``optimal`` does; ``torque=`` fails naming it."""
    import inspect

    import armlab
    import armlab.planning

    with_limits = []
    for name in armlab.planning.__all__:
        obj = getattr(armlab.planning, name)
        if inspect.isfunction(obj) and "v_max" in inspect.signature(obj).parameters:
            params = inspect.signature(obj).parameters
            assert "torque" not in params and params["tau_max"].default is None, name
            with_limits.append(name)
    assert {"ptp_sync", "cubic_via", "quintic_via", "follow_path", "optimal"} <= set(with_limits)
    robot = armlab.load_robot("teachbot6")
    with pytest.raises(TypeError, match=r"ptp_sync\(\): torque= is now tau_max="):
        armlab.ptp_sync(robot, [0.0] * 6, [0.1] * 6, torque=False)


@pytest.mark.parametrize("profile", ["trapezoid", "scurve"])
def test_ptp_sync_tau_max_value_replaces_the_robots(profile):
    """A ``tau_max`` value is the torque limit the plan keeps (joint 1 at a fifth of its own:
    a slower motion whose inverse-dynamics torque stays within it; 1e-6 relative: the
    stretch's bisection tolerance), not the robot's."""
    import numpy as np

    import armlab
    from armlab.robot import resolve_limits

    robot = armlab.load_robot("teachbot6")
    q0, q1 = np.zeros(6), np.radians([90, 35, 10, 60, -30, 90])
    tau = robot.limits.torque_Nm.copy()
    tau[0] *= 0.2
    own = armlab.ptp_sync(robot, q0, q1, profile)
    assert own.check_limits(robot, torque=True).ratios["torque"][0] > 0.3  # binds below 0.2
    slow = armlab.ptp_sync(robot, q0, q1, profile, tau_max=tau)
    ratios = slow.check_limits(robot, torque=True, limits=resolve_limits(robot, tau_max=tau))
    assert ratios.ratios["torque"].max() <= 1 + 1e-6
    assert slow.duration > 1.1 * own.duration
