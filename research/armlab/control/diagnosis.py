"""Why a tracking simulation misses its budget: the same motion under drive-model variants
(no supply limit, no losses, the losses fed forward), simulated in shared time loops."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from armlab.control.feedforward import feedforwards
from armlab.control.result import TrackingResult
from armlab.control.simulate import _simulate_many

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["DRIVE_VARIANTS", "variant_loops", "tracking_variants", "diagnose_tracking"]


#: the drive-model variants of a tracking result: the :func:`simulate_tracking` switches of
#: each (``with_loss_feedforward``: the full model with friction and efficiency fed forward)
DRIVE_VARIANTS: dict[str, dict[str, bool]] = {
    "ideal": {"voltage_limit": False, "losses": False},
    "no_voltage_limit": {"voltage_limit": False},
    "no_losses": {"losses": False},
    "with_loss_feedforward": {},
}


def _switches(name: str) -> dict[str, bool]:
    """The :func:`simulate_tracking` switches of a :data:`DRIVE_VARIANTS` name."""
    return {"voltage_limit": True, "losses": True, **DRIVE_VARIANTS[name]}


def variant_loops(names) -> list[tuple[str, ...]]:
    """``names`` (:data:`DRIVE_VARIANTS`) grouped by the time loop :func:`tracking_variants`
    runs them in: those with the supply limit, then those without (they part ways at every
    saturating sub-step). Each group gives the same numbers simulated apart."""
    groups = [
        tuple(n for n in names if _switches(n)["voltage_limit"] is lim) for lim in (True, False)
    ]
    return [g for g in groups if g]


def _loss_feedforward(ff: tuple[str, ...]) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """``(feed-forward with friction and efficiency, what that adds)``; a result without
    feed-forward gets the usual velocity, acceleration and gravity terms as well."""
    extra = tuple(f for f in ("friction", "efficiency") if f not in ff)
    return (ff or ("velocity", "acceleration", "gravity")) + extra, extra


def tracking_variants(
    robot: Robot, trajectory, gains, names, *, controller, known=None, **options
) -> dict[str, TrackingResult]:
    """The motion :func:`simulate_tracking` gives with ``options`` (the full drive model)
    simulated under each named :data:`DRIVE_VARIANTS` instead; those in ``known`` are reused,
    ``with_loss_feedforward`` is left out when both are already fed forward. It needs no
    full-model result, so it can run beside that simulation."""
    opts = {k: v for k, v in options.items() if k not in ("voltage_limit", "losses", "tcp")}
    ff = feedforwards(opts.pop("feedforward", ("velocity",)))
    out = {n: known[n] for n in names if known and n in known}
    todo: dict[str, tuple[tuple[str, ...], bool, bool]] = {}
    for name in names:
        if name in out:
            continue
        switches = _switches(name)
        ff_v = ff
        if name == "with_loss_feedforward":
            ff_v, extra = _loss_feedforward(ff)
            if not extra:
                continue
        todo[name] = (ff_v, switches["voltage_limit"], switches["losses"])
    if todo:  # simulated together, each as it would be alone
        runs = _simulate_many(
            robot, trajectory, gains, list(todo.values()), controller=controller, **opts
        )
        out.update(zip(todo, runs, strict=True))
    return out


def diagnose_tracking(
    robot: Robot,
    trajectory,
    gains,
    result: TrackingResult,
    *,
    controller,
    cache: dict | None = None,
    **options,
) -> dict:
    """Why a tracking simulation misses its budget, and what fixes it -- measured, not asserted.

    Re-simulates the same motion with one effect removed at a time (the supply-voltage limit,
    the reducer's efficiency and friction) and once with the feed-forward of friction and
    efficiency added (a fix that needs no hardware change).

    Parameters
    ----------
    robot, trajectory, gains :
        As given to :func:`simulate_tracking`.
    result : TrackingResult
        The full-model result to diagnose.
    cache : dict, optional
        Variants already simulated (:func:`tracking_variants` names); the ones run here are
        added to it.
    **options :
        The other :func:`simulate_tracking` options of ``result`` (feed-forward, quantise,
        controller, ...).

    Returns
    -------
    dict
        ``tcp_max_error_m`` per variant (``full``, ``no_voltage_limit``, ``no_losses``,
        ``with_loss_feedforward``), ``limiting_factor`` (a phrase naming the effect and the
        joints), ``offer`` (the measured effect of the feed-forward). Other remedies are offered
        only once measured (:mod:`armlab.study.remedies`): advice that was not tried is not
        given.
    """
    ff = tuple(result.feedforward)
    variants = tracking_variants(
        robot,
        trajectory,
        gains,
        ("no_voltage_limit", "no_losses", "with_loss_feedforward"),
        controller=controller,
        known=cache,
        **options,
    )
    if cache is not None:
        cache.update(variants)
    extra = _loss_feedforward(ff)[1]
    err = {"full": result.tcp_max_error_m}
    err.update({k: r.tcp_max_error_m for k, r in variants.items()})
    budget = result.accuracy_m
    gain_v = err["full"] - err["no_voltage_limit"]
    gain_l = err["full"] - err["no_losses"]
    sat = result.saturation_time_s
    sat_joints = [n for n, s in zip(result.joint_names, sat, strict=True) if s > 0]
    worst = result.joint_names[int(np.argmax(result.max_error_rad))]
    feedback_limited = max(gain_v, gain_l) < 0.1 * err["full"]
    if feedback_limited:
        factor = (
            f"the feedback itself (an ideal drive tracks within "
            f"{min(err['no_voltage_limit'], err['no_losses']) * 1e3:.3g} mm too; largest joint "
            f"error on {worst}): servo bandwidth or feed-forward"
        )
    elif gain_v >= gain_l:
        factor = (
            f"amplifier supply voltage (saturated on {', '.join(sat_joints) or 'no joint'}; "
            f"{err['no_voltage_limit'] * 1e3:.3g} mm without the limit)"
        )
    else:
        factor = (
            f"reducer efficiency and friction ({err['no_losses'] * 1e3:.3g} mm with an "
            f"ideal reducer; largest joint error on {worst})"
        )
    if "with_loss_feedforward" in err:
        e = err["with_loss_feedforward"]
        verdict = "within" if e <= budget else "still above"
        offer = (
            f"feed-forward of friction and efficiency measured: {e * 1e3:.3g} mm ({verdict} "
            f"the {budget * 1e3:.3g} mm budget; [tracking] feedforward += {list(extra)})"
        )
    else:
        offer = "feed-forward of friction and efficiency is already on"
    return {
        "tcp_max_error_m": err,
        "accuracy_m": budget,
        "limiting_factor": factor,
        "offer": offer,
        "saturation_time_s": {n: float(s) for n, s in zip(result.joint_names, sat, strict=True)},
    }
