"""Figures of the servo design: Bode with margins, step responses, root loci, tracking error.

Every function returns a :class:`matplotlib.figure.Figure` made by pyplot (Jupyter shows it;
:func:`armlab.plots.offscreen` for files only).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from armlab._lazy import lazy_import
from armlab.control.gains import LOOPS, CascadeGains
from armlab.control.loops import CascadeModel
from armlab.control.margins import freq_grid, margins
from armlab.control.plant import JointPlant
from armlab.plots._figure import new_figure

if TYPE_CHECKING:
    import control as ct  # the real module for the type checker
else:
    ct = lazy_import("control")  # python-control loads at the first model built

if TYPE_CHECKING:  # matplotlib is imported when a plot is drawn, not with the package
    from matplotlib.figure import Figure

__all__ = ["bode_figure", "step_figure", "root_locus_figure", "tracking_figure", "force_figure"]

_COLORS = {"min": "tab:blue", "nominal": "tab:green", "max": "tab:red"}


def bode_figure(
    plant: JointPlant, gains: CascadeGains, loop: str = "speed", *, discrete: bool = True
) -> Figure:
    """Open-loop Bode plot of one loop at min/nominal/max inertia, continuous (dashed) and
    discrete (solid), gain crossover and -180 deg marked, margins in the legend."""
    fig = new_figure(figsize=(8, 6))
    ax_m, ax_p = fig.subplots(2, 1, sharex=True)
    dt = getattr(gains, loop).sample_time_s
    arr = CascadeModel(plant, gains)  # the tuning's own closed-form responses, every case
    for disc, ls in ((False, "--"), (True, "-")):
        if disc and not discrete:
            continue
        w = freq_grid(dt if disc else None, n=800)
        for case, L in zip(arr.cases, arr.open_response(loop, w, disc), strict=True):
            mg = margins(w, L)
            label = (
                f"{case} {'disc' if disc else 'cont'}: PM {mg.phase_margin_deg:.0f} deg, "
                f"GM {mg.gain_margin_dB:.1f} dB, wc {mg.crossover_rad_s:.3g} rad/s"
            )
            ax_m.semilogx(w, 20 * np.log10(np.abs(L)), ls, color=_COLORS[case], label=label)
            ax_p.semilogx(w, np.degrees(np.unwrap(np.angle(L))), ls, color=_COLORS[case])
            if math.isfinite(mg.crossover_rad_s):
                ax_m.axvline(mg.crossover_rad_s, color=_COLORS[case], lw=0.5, ls=ls)
    ax_m.axhline(0.0, color="k", lw=0.8)
    ax_p.axhline(-180.0, color="k", lw=0.8)
    ax_m.set_ylabel("|L| [dB]")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_xlabel("frequency [rad/s]")
    ax_m.set_title(f"{gains.joint}: {loop} loop, open loop")
    ax_m.legend(fontsize=6)
    ax_m.grid(True, which="both", alpha=0.3)
    ax_p.grid(True, which="both", alpha=0.3)
    return fig


def step_figure(plant: JointPlant, gains: CascadeGains) -> Figure:
    """Closed-loop unit-step responses of the current, speed and position loops at min/nominal/
    max inertia (discrete solid, continuous dashed)."""
    fig = new_figure(figsize=(11, 3.5))
    axes = fig.subplots(1, 3)
    arr = CascadeModel(plant, gains)  # the tuning's own state-space loops, every case
    for ax, loop in zip(axes, LOOPS, strict=True):
        lg = getattr(gains, loop)
        wc = lg.crossover_rad_s if math.isfinite(lg.crossover_rad_s) else 1.0 / lg.sample_time_s
        t_end = (12.0 if loop == "position" else 25.0) / wc
        for disc, ls in ((False, "--"), (True, "-")):
            T, Y = arr.step_responses(loop, disc, t_end)
            for case, t, y in zip(arr.cases, T, Y, strict=True):
                if disc:
                    ax.step(t, y, ls, where="post", color=_COLORS[case], lw=1, label=f"{case}")
                else:
                    ax.plot(t, y, ls, color=_COLORS[case], lw=0.8)
        ax.set_title(f"{loop} loop (OS {lg.overshoot_discrete_pct:.0f} %)", fontsize=9)
        ax.set_xlabel("t [s]")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("output / set-point")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{gains.joint}: closed-loop steps")
    fig.tight_layout()
    return fig


def root_locus_figure(
    plant: JointPlant, gains: CascadeGains, loop: str = "speed", *, discrete: bool = False
) -> Figure:
    """Root locus of ``1 + k L`` for one loop at the nominal inertia; the tuned gain (k = 1)
    marked. Discrete loops are drawn with the unit circle."""
    fig = new_figure(figsize=(6, 5))
    ax = fig.subplots()
    L = CascadeModel(plant, gains).open_loop(loop, discrete, "nominal")
    ks = np.concatenate([np.logspace(-3, 0, 120), np.logspace(0, 1.5, 60)[1:]])
    data = ct.root_locus_map(L, gains=ks)
    loci = np.asarray(data.loci)
    for j in range(loci.shape[1]):
        ax.plot(loci[:, j].real, loci[:, j].imag, "-", lw=0.8, color="tab:blue")
    cl = ct.poles(ct.feedback(L, 1))
    ax.plot(cl.real, cl.imag, "o", color="tab:red", label="tuned gain (k = 1)")
    ax.plot(np.real(data.poles), np.imag(data.poles), "x", color="k", label="open-loop poles")
    z = np.asarray(data.zeros)
    if z.size:
        ax.plot(z.real, z.imag, "o", mfc="none", color="k", label="zeros")
    if discrete:
        th = np.linspace(0, 2 * np.pi, 200)
        ax.plot(np.cos(th), np.sin(th), "k", lw=0.5)
        ax.set_xlim(-1.5, 1.5)
        ax.set_ylim(-1.5, 1.5)
    else:
        wc = getattr(gains, loop).crossover_rad_s
        r = 6.0 * (wc if math.isfinite(wc) else max(1.0, np.max(np.abs(cl))))
        ax.set_xlim(-r, 0.3 * r)
        ax.set_ylim(-r, r)
    ax.set_aspect("equal", adjustable="box")
    ax.set_title(
        f"{gains.joint}: root locus of the {loop} loop "
        f"({'discrete' if discrete else 'continuous'}, nominal inertia)",
        fontsize=9,
    )
    ax.legend(fontsize=7)
    ax.grid(True, alpha=0.3)
    return fig


def tracking_figure(result) -> Figure:
    """Joint tracking errors and the TCP error over time, with the accuracy tolerance."""
    fig = new_figure(figsize=(9, 6))
    ax_j, ax_t = fig.subplots(2, 1, sharex=True)
    err = result.error_rad
    for j, name in enumerate(result.joint_names):
        ax_j.plot(result.t, err[:, j], lw=0.8, label=name)
    ax_j.set_ylabel("joint error [rad]")
    ax_j.legend(fontsize=7, ncol=3)
    ax_j.grid(True, alpha=0.3)
    ax_t.plot(result.t, result.tcp_error_m * 1e3, color="k", lw=0.8, label="TCP error")
    ax_t.axhline(
        result.accuracy_m * 1e3,
        color="tab:red",
        ls="--",
        label=f"tolerance {result.accuracy_m * 1e3:.2g} mm",
    )
    ax_t.set_ylabel("TCP error [mm]")
    ax_t.set_xlabel("t [s]")
    ax_t.legend(fontsize=7)
    ax_t.grid(True, alpha=0.3)
    ax_j.set_title(f"tracking, feed-forward: {', '.join(result.feedforward) or 'none'}")
    return fig


def drive_model_figure(results: dict) -> Figure:
    """TCP error of one motion under several drive models, and the full model's armature
    voltages against the supply.

    Parameters
    ----------
    results : dict of str to TrackingResult
        Label -> result; the entry whose ``model`` has both ``losses`` and ``voltage_limit``
        (the full model) is the one whose voltages are drawn.
    """
    fig = new_figure(figsize=(9, 6.5))
    ax_t, ax_u = fig.subplots(2, 1, sharex=True)
    full = None
    for label, r in results.items():
        e = r.tcp_max_error_m * 1e3
        ax_t.plot(r.t, r.tcp_error_m * 1e3, lw=0.8, label=f"{label}: max {e:.3g} mm")
        if r.model.get("losses") and r.model.get("voltage_limit") and full is None:
            full = r
    if results:
        acc = next(iter(results.values())).accuracy_m * 1e3
        ax_t.axhline(acc, color="tab:red", ls="--", lw=0.8, label=f"budget {acc:.2g} mm")
    ax_t.set_ylabel("TCP error [mm]")
    ax_t.legend(fontsize=7)
    ax_t.grid(True, alpha=0.3)
    ax_t.set_title("tracking under the drive model (efficiency, friction, supply voltage)")
    if full is not None and full.voltage_V is not None and full.supply_voltage_V is not None:
        for j, name in enumerate(full.joint_names):
            sat = full.saturation_time_s[j]
            ax_u.plot(
                full.t,
                full.voltage_V[:, j] / full.supply_voltage_V[j],
                lw=0.7,
                label=f"{name} (U = {full.supply_voltage_V[j]:g} V, saturated {sat:.3g} s)",
            )
        for y in (-1.0, 1.0):
            ax_u.axhline(y, color="k", ls="--", lw=0.6)
        ax_u.legend(fontsize=6, ncol=2)
    ax_u.set_ylabel("armature voltage / supply\n(mean over each servo period)")
    ax_u.set_xlabel("t [s]")
    ax_u.grid(True, alpha=0.3)
    return fig


def force_figure(results) -> Figure:
    """Force step responses (list of :class:`ForceLoopResult`) on one axis."""
    fig = new_figure(figsize=(7, 4))
    ax = fig.subplots()
    for r in results:
        ax.plot(
            r.t,
            r.force_N,
            lw=0.8,
            label=f"K_E={r.environment_stiffness_N_m:g} N/m, "
            f"w_n={r.natural_frequency_rad_s:.0f}, zeta={r.damping:.2f}",
        )
    if results:
        ax.axhline(results[0].setpoint_N, color="k", lw=0.5)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("force [N]")
    ax.legend(fontsize=6)
    ax.grid(True, alpha=0.3)
    return fig
