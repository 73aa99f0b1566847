"""Every figure armlab draws, in one place (matplotlib is imported inside each function).

Each function takes the result objects of the computing packages (a ``WorkspaceResult``, a
``Trajectory``, ``JointLoads``, ``CascadeGains``...) and returns a ``matplotlib`` Figure.

The figures are made with ``matplotlib.pyplot``, under whatever backend the caller has (armlab
never switches it): Jupyter's inline backend shows every figure a cell makes, a script shows them
with ``plt.show()`` or saves them with ``fig.savefig(path)``. Inside ``with offscreen():`` they
are made with the object API and an Agg canvas instead, for files only (no pyplot, nothing to
close); the study report and the sweep plots draw that way.

=============================  =========================================================
module                         figures
=============================  =========================================================
:mod:`.kinematics`             workspace cloud, Monte-Carlo accuracy (HEU thesis 3.6, 3.7)
:mod:`.motion`                 joint profiles, TCP path, online interpolation
:mod:`.optimal`                profiles against their limits, torque ratio, TOPP phase plane
:mod:`.dynamics`               joint loads along a motion, motor operating points
:mod:`.servo`                  Bode, steps, root loci, tracking error, force loop
=============================  =========================================================
"""

from armlab.plots._figure import offscreen
from armlab.plots.dynamics import plot_joint_loads, plot_operating_points
from armlab.plots.kinematics import plot_accuracy, plot_accuracy_scatter, plot_workspace
from armlab.plots.motion import plot_joints, plot_online, plot_tcp_path
from armlab.plots.optimal import plot_limit_profiles, plot_phase_plane, plot_torque_ratio
from armlab.plots.servo import (
    bode_figure,
    force_figure,
    root_locus_figure,
    step_figure,
    tracking_figure,
)

__all__ = [
    "offscreen",
    "plot_workspace",
    "plot_accuracy",
    "plot_accuracy_scatter",
    "plot_joints",
    "plot_tcp_path",
    "plot_online",
    "plot_limit_profiles",
    "plot_torque_ratio",
    "plot_phase_plane",
    "plot_joint_loads",
    "plot_operating_points",
    "bode_figure",
    "step_figure",
    "root_locus_figure",
    "tracking_figure",
    "force_figure",
]
