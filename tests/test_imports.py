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
