"""A study's report: ``report.md`` with its PNG plots, and the one-screen text summary.

Plots are the package's own plot functions, drawn inside :func:`armlab.plots.offscreen` (object
API and an Agg canvas: the caller's matplotlib backend is never switched) and saved beside
``report.md``.
"""

from __future__ import annotations

import functools
import math
import os
import pickle
import queue
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from armlab._fork import SILENCE_S, SideProcess, can_fork, die_with, start_forked
from armlab.io import atomic_open, atomic_write

__all__ = ["write_report", "summary_text"]


# ---------------------------------------------------------------------------- plots
def _weakest_joint(gains) -> str | None:
    """The joint whose loops have the smallest phase margin (continuous or discrete)."""
    worst, joint = math.inf, None
    for name, loops in gains.summary().items():
        for fig in loops.values():
            for key in ("phase_margin_deg", "phase_margin_discrete_deg"):
                v = fig.get(key)
                if isinstance(v, (int, float)) and v < worst:
                    worst, joint = v, name
    return joint


def _plant(ctx, joint):
    """A factory of the joint's plant with the inertia range the tuning used."""

    def make():
        from armlab.control import joint_plant

        n = ctx.spec.control.n_inertia_samples
        kw = {} if n is None else {"n_samples": n}
        return joint_plant(ctx.robot, joint, seed=ctx.spec.study.seed, **kw)

    return make


def _figures(
    ctx, variants: _VariantPrefetch | None = None
) -> list[tuple[str, str, Callable[[], Any]]]:
    """(file name, caption, figure factory) of every plot the study can draw; ``variants``:
    the drive-model variants being simulated beside the tracking stage, if they are."""
    from armlab.kinematics.forward import tool_positions
    from armlab.plots import (
        bode_figure,
        plot_accuracy,
        plot_joint_loads,
        plot_joints,
        plot_limit_profiles,
        plot_operating_points,
        plot_phase_plane,
        plot_tcp_path,
        plot_torque_ratio,
        plot_workspace,
        step_figure,
        tracking_figure,
    )

    out: list[tuple[str, str, Callable[[], Any]]] = []  # (file name, caption, draw)
    traj, robot = ctx.trajectory, ctx.robot
    for kind, plot, caption in (
        ("workspace", plot_workspace, "Monte-Carlo workspace"),
        ("accuracy", plot_accuracy, "Monte-Carlo positioning error"),
    ):
        res = ctx.figures.get(kind)
        if res is not None:
            out.append((f"kinematics_{kind}.png", caption, functools.partial(plot, res)))
    if traj is not None:
        optimised = ctx.spec.plan.planner in ("optimal", "path")
        joints = plot_limit_profiles if optimised else plot_joints
        out.append(
            (
                "plan_profiles.png",
                "Joint profiles with the limits (dashed)",
                lambda: joints(traj, robot),
            )
        )
        if ctx.spec.plan.planner == "path":
            out.append(
                (
                    "plan_phase_plane.png",
                    "Path parameterisation: phase plane with its limit curves",
                    lambda: plot_phase_plane(traj),
                )
            )
        points = tool_positions(robot, ctx.waypoints_q)
        out.append(
            (
                "plan_tool_path.png",
                "Tool path and waypoints",
                lambda: plot_tcp_path(robot, traj, points),
            )
        )
        if robot.limits.torque_Nm is not None:
            dt = max(traj.duration / 2000, 1e-3)
            out.append(
                (
                    "plan_torque_ratio.png",
                    "Torque / effort limit along the plan",
                    lambda: plot_torque_ratio(traj, robot, dt=dt),
                )
            )
    if ctx.gains is not None:
        joint = _weakest_joint(ctx.gains)
        if joint is not None:
            plant = _plant(ctx, joint)
            g = ctx.gains[joint]
            out.append(
                (
                    f"control_bode_{joint}.png",
                    f"Speed-loop Bode plot of {joint} (smallest phase margin) over its "
                    "inertia range",
                    lambda: bode_figure(plant(), g, "speed"),
                )
            )
            out.append(
                (
                    f"control_steps_{joint}.png",
                    f"Step responses of the {joint} loops",
                    lambda: step_figure(plant(), g),
                )
            )
    if ctx.tracking is not None and hasattr(ctx.tracking, "tcp_error_m"):
        out.append(
            (
                "tracking_error.png",
                "Closed-loop tracking error (joints and TCP)",
                lambda: tracking_figure(ctx.tracking),
            )
        )
        out.append(
            (
                "tracking_drive_model.png",
                "TCP error with and without the reducer's efficiency and friction and the "
                "amplifier's supply limit (the verdict uses both), and with their feed-forward; "
                "below, the full model's armature voltages against the supply",
                lambda: _drive_model_figure(ctx, variants),
            )
        )
    loads = getattr(ctx.sizing, "loads", None)
    if loads is not None:
        for plot_loads, name, caption in (
            (
                plot_joint_loads,
                "sizing_loads.png",
                "Joint torque, speed and power along the plan, with the limits",
            ),
            (
                plot_operating_points,
                "sizing_operating_points.png",
                "Motor operating points on the speed-torque plane",
            ),
        ):
            out.append((name, caption, functools.partial(plot_loads, loads, robot)))
    return out


def _drive_model_figure(ctx, variants: _VariantPrefetch | None = None):
    """The study's motion under each drive model: the tracking stage's result and its
    variants (:func:`armlab.control.diagnosis.tracking_variants`; those the stage's diagnosis
    ran or ``variants`` simulated beside the stage are reused, the others simulated when the
    report is drawn -- by another process when several draw, so the study's context keeps
    only the diagnosis's)."""
    from armlab.control.diagnosis import tracking_variants
    from armlab.plots.servo import drive_model_figure

    res = ctx.tracking
    known = {**(variants.take() if variants is not None else {}), **ctx.tracking_variants}
    v = tracking_variants(
        ctx.robot,
        ctx.trajectory,
        ctx.gains,
        DRIVE_MODEL_VARIANTS,
        known=known,
        **ctx.tracking_options,
    )
    ctx.tracking_variants.update(v)
    runs = {
        "ideal drive": v["ideal"],
        "+ efficiency and friction": v["no_voltage_limit"],
        "+ supply limit (full model)": res,
    }
    if "with_loss_feedforward" in v:
        extra = [f for f in ("friction", "efficiency") if f not in res.feedforward]
        runs[f"full model, feed-forward + {', '.join(extra)}"] = v["with_loss_feedforward"]
    return drive_model_figure(runs)


#: the drive models of the report's drive-model plot beside the study's full model
#: (:data:`armlab.control.diagnosis.DRIVE_VARIANTS`)
DRIVE_MODEL_VARIANTS = ("ideal", "no_voltage_limit", "with_loss_feedforward")
#: figures that take longest (simulations, many axes), started first so that the processes
#: drawing the others finish together (a scheduling hint: the files do not depend on it)
_SLOW_FIRST = ("tracking_drive_model.png", "kinematics_accuracy.png", "sizing_loads.png")
#: with its variants simulated beside the tracking stage (:class:`_VariantPrefetch`) the
#: drive-model plot is drawn last instead: its process may still have to wait for them
_WAITS_LAST = "tracking_drive_model.png"


def _figure_processes(n_jobs: int, workers: int | None) -> int:
    """How many processes draw the plots: ``workers`` (None: one), at most one per plot, and
    one where processes cannot be forked (the children inherit the study's state instead of
    receiving it pickled)."""
    n = 1 if workers is None else max(1, int(workers))
    if not can_fork():
        return 1
    return max(1, min(n, n_jobs))


#: resolution of the report's PNG plots
PLOT_DPI = 110
#: zlib level of the report's PNG files: 1 instead of PIL's 6 -- 13 % less time per plot for
#: files ~10 % larger (issue 15, measured on the 18-panel loads plot: 0.43 -> 0.37 s, 390 -> 432 kB)
PNG_COMPRESS_LEVEL = 1
#: a plot process that sends nothing for this long [s] is stopped and its plots are named as
#: not drawn (:data:`armlab._fork.SILENCE_S`)
PLOT_PROCESS_SILENCE_S = SILENCE_S


def _draw_one(name: str, make: Callable[[], Any], out_dir: Path, parent: int | None = None) -> Path:
    """Draw one plot and write it atomically; ``parent``: in a plot process, the study's
    process, without which nothing is written."""
    from armlab.plots import offscreen

    with offscreen():  # object API + Agg canvas: the caller's backend and pyplot untouched
        fig = make()
    if parent is not None and os.getppid() != parent:
        os._exit(0)
    path = out_dir / name
    fmt = path.suffix[1:] or "png"
    extra = {"pil_kwargs": {"compress_level": PNG_COMPRESS_LEVEL}} if fmt == "png" else {}
    with atomic_open(path, "wb") as f:
        fig.savefig(f, format=fmt, dpi=PLOT_DPI, **extra)
    return path


class _FigureDrawing:
    """Draw the report's plots while the ``with`` block runs: forked processes take the next
    plot from a shared counter (slowest first), this process draws its share when the block
    ends, then waits for the others. A plot that fails raises its error here, after every
    process has stopped (the files the others wrote stay)."""

    def __init__(
        self,
        jobs,
        out_dir: Path,
        processes: int,
        *,
        parent_draws: bool = True,
        prefetched: bool = False,
    ) -> None:
        rank = {name: k for k, name in enumerate(_SLOW_FIRST)}
        if prefetched:  # the drive-model plot waits for its simulations: last
            rank[_WAITS_LAST] = len(rank) + 1
        self.jobs = sorted(jobs, key=lambda job: rank.get(job[0], len(_SLOW_FIRST)))
        self.out_dir = out_dir
        self.processes = processes
        self.parent_draws = parent_draws  # False: the parent only waits (it has stages to run)
        self.paths: list[Path] = []
        self._children: list = []
        self._sent: list[Path] = []

    def _next(self) -> int:
        with self._counter.get_lock():
            k = self._counter.value
            self._counter.value += 1
        return k

    def _work(self, send, parent: int | None = None) -> None:
        while (k := self._next()) < len(self.jobs):
            name, _, make = self.jobs[k]
            try:
                fig_path = _draw_one(name, make, self.out_dir, parent)
                send((k, None, fig_path))
            except Exception as exc:  # reported to the parent, which raises it
                send((k, exc, None))
                return

    def __enter__(self) -> _FigureDrawing:
        if self.processes <= 1:
            return self
        import multiprocessing

        mp = multiprocessing.get_context("fork")
        self._counter = mp.Value("i", 0)
        self._queue = mp.Queue()
        self._children = [
            mp.Process(target=self._child, daemon=True) for _ in range(self.processes - 1)
        ]
        start_forked(self._children)
        return self

    def _child(self) -> None:
        def send(item) -> None:
            k, exc, path = item
            if exc is not None:  # the exception crosses as itself if it pickles
                try:
                    pickle.dumps(exc)
                except Exception:
                    exc = RuntimeError(f"{self.jobs[k][0]}: {type(exc).__name__}: {exc}")
            self._queue.put((k, exc, path))

        parent = os.getppid()
        die_with(parent)
        try:
            self._work(send, parent)
        finally:
            self._queue.put(None)  # this process is done

    def finish(self) -> list[Path]:
        """Draw what is left, wait for the other processes; the files drawn."""
        self.parent_draws = True
        self.__exit__(None, None, None)
        return self.paths

    def abort(self) -> None:
        """Stop handing out plots, wait for the processes and remove the files they wrote."""
        if self.processes <= 1:
            return
        self.__exit__(RuntimeError, None, None)
        for path in self._sent:
            Path(path).unlink(missing_ok=True)

    def __exit__(self, exc_type, exc, tb) -> None:
        if self.processes <= 1:
            if exc_type is None:
                self.paths = [_draw_one(name, make, self.out_dir) for name, _, make in self.jobs]
            return
        results: list = []
        if exc_type is None and self.parent_draws:
            self._work(results.append)
        else:  # the block failed: stop handing out plots
            with self._counter.get_lock():
                self._counter.value = len(self.jobs)
        done, last = 0, time.monotonic()
        while done < len(self._children):
            try:
                item = self._queue.get(timeout=0.5)
            except queue.Empty:
                alive = [child for child in self._children if child.is_alive()]
                if alive and time.monotonic() - last < PLOT_PROCESS_SILENCE_S:
                    continue
                for child in alive:  # silent too long (a hang): its plot is missing below
                    child.terminate()
                break  # a process died without saying so: its plot is missing below
            last = time.monotonic()
            if item is None:
                done += 1
            else:
                results.append(item)
        for child in self._children:
            child.join()
        self._sent = [path for _, _, path in results if path is not None]
        if exc_type is not None:
            return
        results.sort(key=lambda r: r[0])
        for _, error, _ in results:
            if error is not None:
                raise error
        missing = set(range(len(self.jobs))) - {k for k, _, _ in results}
        if missing:
            names = sorted(self.jobs[k][0] for k in missing)
            raise RuntimeError(f"the report's plots {names} were not drawn (a process died)")
        self.paths = [path for _, _, path in results]


# ---------------------------------------------------------------------------- report.md
def _fmt(x, nd: int = 4) -> str:
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, (int, float)):
        if isinstance(x, float) and math.isnan(x):
            return "-"
        return f"{x:.{nd}g}"
    return str(x)


def _table(header: list[str], rows: list[list[Any]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_fmt(c) for c in r) + " |" for r in rows]
    return lines + [""]


#: the plots each stage makes final (file-name prefixes): drawn from that stage's results and
#: earlier ones, which no later stage changes. The plan's plots wait for the sizing stage,
#: which may give the robot its drive train (and so its torque limits).
_STAGE_PLOTS = {
    "kinematics": ("kinematics_",),
    "sizing": ("plan_", "sizing_"),
    "tuning": ("control_",),
    "tracking": ("tracking_",),
}


class _VariantPrefetch:
    """The drive-model plot's variants (:data:`DRIVE_MODEL_VARIANTS`) simulated by forked
    processes while the tracking stage runs: they need the plan, the gains and the study's
    tracking options, not the stage's result, and were the report's longest job (issue 15:
    ~2 s of CPU that could only start once the stage had ended). One process per time loop
    of :func:`~armlab.control.diagnosis.tracking_variants` (the variants with the supply
    limit, and those without), so that they end together with the other work.

    :meth:`take` is called once, by the process that draws the plot; a process that failed
    or fell silent gives nothing, and the plot then simulates those variants itself (the same
    numbers, the error raised where it would have been)."""

    def __init__(self, ctx) -> None:
        from armlab.control.diagnosis import tracking_variants, variant_loops
        from armlab.study.stages import tracking_options

        options = tracking_options(ctx)
        self.sides = [
            SideProcess(tracking_variants, ctx.robot, ctx.trajectory, ctx.gains, g, **options)
            for g in variant_loops(DRIVE_MODEL_VARIANTS)
        ]

    def take(self) -> dict:
        """The simulated variants by name (those of a failed process missing)."""
        out: dict = {}
        for side in self.sides:
            out.update(side.result() or {})
        return out

    def close(self) -> None:
        for side in self.sides:
            side.close()


def _preload_plotting() -> None:
    """Import matplotlib and the plot modules in the study's process before its stages, so
    that every plot process forked later inherits them instead of importing them (~0.3 s of
    CPU each; the study's own process would import them for its share of the plots anyway)."""
    import matplotlib.backends.backend_agg  # noqa: F401
    import matplotlib.figure  # noqa: F401

    import armlab.plots.dynamics  # noqa: F401
    import armlab.plots.kinematics  # noqa: F401
    import armlab.plots.optimal  # noqa: F401
    import armlab.plots.servo  # noqa: F401


class StagePlots:
    """With several ``workers``, the report's plots drawn while the later stages run: when a
    stage ends, its final plots (:data:`_STAGE_PLOTS`, with any still waiting) go to a forked
    process if none is busy (one at a time beside the stages); :func:`write_report` draws
    the rest and collects them. :meth:`abort` when the study stops before its report."""

    def __init__(self, out_dir: Path, workers: int | None) -> None:
        self.out_dir = Path(out_dir)
        self.on = _figure_processes(2, workers) >= 2
        self.drawings: list[_FigureDrawing] = []
        self.waiting: list[str] = []  # prefixes of final plots not started yet
        self.variants: _VariantPrefetch | None = None
        self.motion: SideProcess | None = None  # the 3D animation, once the plan is final
        if self.on:  # before the first stage: the core beside it has nothing to draw yet
            _preload_plotting()

    def stage_done(self, ctx, stage: str) -> None:
        if not self.on:
            return
        if stage == "tuning" and "tracking" in ctx.spec.study.stages:
            self.variants = _VariantPrefetch(ctx)  # beside the tracking stage
        if stage == "sizing" and ctx.trajectory is not None:  # after its drives, as plan_*
            self.motion = SideProcess(_motion_file, ctx.robot, ctx.trajectory, self.out_dir)
        self.waiting += _STAGE_PLOTS.get(stage, ())
        busy = any(c.is_alive() for d in self.drawings for c in d._children)
        if not busy and self.waiting:
            jobs = _figures(ctx, self.variants)
            jobs = [job for job in jobs if job[0].startswith(tuple(self.waiting))]
            self.waiting = []
            if jobs:
                drawing = _FigureDrawing(
                    jobs, self.out_dir, 2, parent_draws=False, prefetched=self.variants is not None
                )
                self.drawings.append(drawing.__enter__())

    def names(self) -> set[str]:
        return {job[0] for d in self.drawings for job in d.jobs}

    def finish(self) -> list[Path]:
        try:
            return [path for d in self.drawings for path in d.finish()]
        finally:
            self._close_sides()

    def abort(self) -> None:
        for d in self.drawings:
            d.abort()
        self.drawings = []
        if self.motion is not None:  # its file goes with the plots
            self.motion.result()  # let it finish writing
            (self.out_dir / MOTION_FILE).unlink(missing_ok=True)
        self._close_sides()

    def _close_sides(self) -> None:
        for side in (self.variants, self.motion):
            if side is not None:
                side.close()
        self.variants = self.motion = None


def write_report(
    ctx, summary: dict, out_dir: Path, *, workers: int | None = None, early=None
) -> list[Path]:
    """Write ``report.md`` and its PNG plots into ``out_dir``; returns the files written.

    ``workers``: processes that draw the plots (:func:`_figure_processes`; None or 1: this
    one); ``early``: the :class:`StagePlots` of the run, finished here. The files are the
    same whichever number draws them.
    """
    out_dir = Path(out_dir)
    files: list[Path] = []
    spec = ctx.spec
    lines = [
        f"# Study: {spec.study.name}",
        "",
        f"Source `{spec.source}` (sha256 `{spec.hash[:12]}`), seed {spec.study.seed}, "
        f"armlab {summary['study']['armlab_version']}.",
        "",
        "## Design verdict",
        "",
        *design_lines(summary),
        "",
        "## Stages",
        "",
    ]
    lines += _table(
        ["stage", "status", "verdict", "time [s]", "note"],
        [
            [
                s,
                info["status"],
                info.get("verdict") or "-",
                info["time_s"],
                _note(summary.get(_key(s), {})),
            ]
            for s, info in summary["study"]["stages"].items()
        ],
    )
    r = summary["robot"]
    lines += [
        "## Robot",
        "",
        f"{r.get('name')}: {r.get('n_joints')} joints, payload "
        f"{_fmt(r.get('payload_kg'))} kg, moving mass {_fmt(r.get('total_mass_kg'))} kg.",
        "",
    ]
    if "drives" in r:
        lines += _table(
            ["joint", "motor", "reducer", "ratio", "available torque [N m]"],
            [
                [j, d["motor"], d["reducer"], d["ratio"], d["available_torque_Nm"]]
                for j, d in r["drives"].items()
            ],
        )
    kin = summary.get("kinematics", {})
    if kin.get("status") == "ok":
        lines += [
            "## Kinematics",
            "",
            f"{kin['n_waypoints']} waypoints ({kin['waypoints_from']}),"
            f" all inside the joint ranges; max reach {kin['max_reach_m'] * 1000:.1f} mm.",
            "",
        ]
        lines += _table(
            ["waypoint", "x [mm]", "y [mm]", "z [mm]"],
            [
                [k, *(f"{x:.1f}" for x in 1000 * np.asarray(p) + 0.0)]
                for k, p in enumerate(kin["tcp_positions_m"])
            ],
        )
    tr = summary.get("trajectory", {})
    if tr.get("status") == "ok":
        lines += [
            "## Trajectory",
            "",
            f"Planner `{tr['planner']}` ({tr['method']}): "
            f"{tr['duration_s']:.4f} s through {tr['n_waypoints']} waypoints, speed scale "
            f"{tr['speed_scale']:g}; checked every {tr['check_dt_s'] * 1000:g} ms.",
            "",
            "Peak ratio to each limit (<= 1 is feasible):",
            "",
        ]
        kinds = list(tr["ratios"])
        joints = list(next(iter(tr["ratios"].values()), {}))
        lines += _table(
            ["joint", *kinds], [[j, *(tr["ratios"][k][j] for k in kinds)] for j in joints]
        )
    for key, title in (
        ("static_load", "Static load"),
        ("sizing", "Drive sizing"),
        ("control", "Servo tuning"),
        ("tracking", "Closed-loop tracking"),
        ("export", "Export"),
    ):
        block = summary.get(key, {})
        lines += [f"## {title}", ""]
        if block.get("status") != "ok":
            why = block.get("reason", block.get("error", ""))
            lines += [f"Status: {block.get('status')} ({why}).", ""]
            continue
        obj = {"static_load": ctx.static_load, "sizing": ctx.sizing}.get(key)
        if obj is not None and hasattr(obj, "to_markdown"):
            lines += [obj.to_markdown(), ""]  # with the thesis' table beside ours (teachbot6)
        else:
            lines += _section_lines(key, block)
        if key == "sizing" and ctx.requirement_sizing is not None:
            lines += [
                "**Against each joint's worst case (the thesis' requirements).**",
                "",
                "Each joint alone from its worst static pose, accelerating at its maximum "
                "acceleration to its maximum speed and back (`armlab.dynamics."
                "requirement_moves`): the load case of thesis tables 4.2 and 4.3.",
                "",
                ctx.requirement_sizing.to_markdown(),
                "",
            ]
        if key == "sizing" and ctx.selection is not None and hasattr(ctx.selection, "to_markdown"):
            lines += [ctx.selection.to_markdown(), ""]
    kf = summary.get("key_figures", {})
    lines += ["## Key figures", ""]
    lines += _table(
        ["figure", "value"], [[k, v] for k, v in kf.items() if not k.startswith("stage_")]
    )
    variants = early.variants if early is not None else None
    jobs = _figures(ctx, variants)
    if jobs:
        lines += ["## Plots", ""]
    for name, caption, _ in jobs:
        lines += [f"![{caption}]({name})", "", f"*{caption}*", ""]
    # the figures in `processes` processes; the parent draws its share and the 3D motion
    started = early.names() if early is not None else set()
    rest = [job for job in jobs if job[0] not in started]
    processes = _figure_processes(len(jobs), workers)
    summary["study"]["plot_processes"] = processes
    motion = None  # (report lines, whether the file was written)
    if early is not None and early.motion is not None:  # written beside the stages
        motion = early.motion.result()
    with _FigureDrawing(rest, out_dir, processes, prefetched=variants is not None) as drawing:
        if motion is None and ctx.trajectory is not None:
            motion = _motion_file(ctx.robot, ctx.trajectory, out_dir)
    if motion is not None:
        lines += motion[0]
        files += [out_dir / MOTION_FILE] if motion[1] else []
    files += drawing.paths
    if early is not None:
        files += early.finish()
    if processes > 1:
        lines += [f"The {len(jobs)} plots were drawn by {processes} processes.", ""]
    report = out_dir / "report.md"
    atomic_write(report, "\n".join(lines))
    return [report, *files]


#: The planned motion's 3D animation, written beside report.md (:func:`_motion_file`).
MOTION_FILE = "motion.html"


def _motion_file(robot, trajectory, out_dir: Path) -> tuple[list[str], bool]:
    """Write the planned motion as a self-contained 3D animation (:data:`MOTION_FILE`, see
    :func:`armlab.viz.animate`): the report's lines linking it, and whether it was written;
    when meshcat is missing or fails, one line saying so (never an error). With several
    workers a process forked when the sizing stage ends writes it (:class:`StagePlots`)."""
    lines = ["## 3D motion", ""]
    try:
        import warnings

        from armlab.viz import animate

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene = animate(robot, trajectory, out_dir / MOTION_FILE)
    except Exception as exc:  # the study never fails for its 3D view
        why = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        return lines + [f"3D animation not written: {why}", ""], False
    notes = "; ".join(str(w.message) for w in caught)
    lines.append(
        f"[3D animation of the planned motion]({MOTION_FILE}) (open in a browser; "
        f"{scene.n_frames} frames at {scene.fps:g} fps)" + (f"; {notes}" if notes else ".")
    )
    return lines + [""], True


def _key(stage: str) -> str:
    from armlab.study.stages import SUMMARY_KEY

    return SUMMARY_KEY.get(stage, stage)


def _note(block: dict) -> str:
    if block.get("status") in ("not available", "skipped"):
        return block.get("reason", "")
    if block.get("status") == "error":
        return block.get("error", "")
    return ""


def _section_lines(key: str, block: dict) -> list[str]:
    """A table for the per-joint blocks; a key/value table otherwise."""
    from armlab.study.figures import joint_items as _joint_items

    items = _joint_items(block)
    if key == "tracking":
        tcp = block.get("tcp", {})
        lines = [
            f"Feed-forward {', '.join(block.get('feedforward', [])) or 'none'}; "
            f"{_fmt(block.get('duration_s'))} s simulated at "
            f"{_fmt(1e3 * block.get('sample_time_s', math.nan))} ms"
            f"{' with D/A and encoder quantisation' if block.get('quantise') else ''}.",
            "",
        ]
        if tcp:
            ok = tcp.get("within_accuracy")
            lines += [
                f"TCP error: max {_fmt(1e3 * tcp.get('max_error_m', math.nan))} mm, final "
                f"{_fmt(1e3 * tcp.get('final_error_m', math.nan))} mm; servo budget "
                f"{_fmt(1e3 * tcp.get('accuracy_m', math.nan))} mm -> "
                f"{'within' if ok else 'OUTSIDE'} the budget.",
                "",
            ]
        model = block.get("model", {})
        if model:
            lines += [
                "Drive model: "
                + ", ".join(
                    [
                        "supply-voltage limit with back-EMF"
                        if model.get("voltage_limit")
                        else "NO supply-voltage limit",
                        "reducer efficiency and friction"
                        if model.get("losses")
                        else "NO reducer losses",
                        f"controller `{model.get('controller')}` "
                        f"({model.get('dac_bits')}-bit +-{_fmt(model.get('dac_range_V'))} V D/A, "
                        "current loop every "
                        f"{_fmt(1e6 * model.get('current_sample_time_s', 0))} us)",
                    ]
                )
                + ".",
                "",
            ]
        diag = block.get("diagnosis")
        if isinstance(diag, dict):
            lines += [
                f"Limiting factor: {diag.get('limiting_factor')}.",
                f"What fixes it: {diag.get('offer')}.",
                "",
            ]
        return lines + _table(
            [
                "joint",
                "max error [rad]",
                "final error [rad]",
                "peak voltage [V]",
                "asked [V]",
                "supply [V]",
                "saturated [s]",
                "peak current [A]",
            ],
            [
                [
                    j,
                    b.get("max_error_rad"),
                    b.get("final_error_rad"),
                    b.get("peak_voltage_V"),
                    b.get("peak_voltage_demand_V"),
                    b.get("supply_voltage_V"),
                    b.get("time_in_saturation_s"),
                    b.get("peak_current_A"),
                ]
                for j, b in items
            ],
        )
    if key == "export":
        cycle_ms = 1e3 * block.get("cycle_s", math.nan)
        lines = [
            f"{_fmt(block.get('n_cycles'))} cycles of {_fmt(cycle_ms)} ms "
            f"for controller profile `{block.get('profile')}`; every cycle passed the "
            "pre-flight checks (range, speed, pulses per cycle, continuity).",
            "",
        ]
        files = block.get("files", {})
        if files:
            lines += _table(["file", "sha256"], [[n, f"`{f['sha256']}`"] for n, f in files.items()])
        return lines
    if key == "control":
        rows = []
        for joint, loops in block.items():
            if not isinstance(loops, dict):
                continue
            for loop, f in loops.items():
                if isinstance(f, dict) and "phase_margin_deg" in f:
                    g = f.get("gains", {})
                    rows.append(
                        [
                            joint,
                            loop,
                            g.get("kp"),
                            g.get("ki"),
                            f.get("crossover_rad_s"),
                            f.get("phase_margin_deg"),
                            f.get("gain_margin_dB"),
                            f.get("phase_margin_discrete_deg"),
                            f.get("overshoot_pct"),
                            f.get("sample_time_s"),
                        ]
                    )
        return _table(
            [
                "joint",
                "loop",
                "kp",
                "ki",
                "crossover [rad/s]",
                "PM [deg]",
                "GM [dB]",
                "PM discrete [deg]",
                "overshoot [%]",
                "T [s]",
            ],
            rows,
        )
    if items:
        scalars = sorted(
            {
                k
                for _, b in items
                for k, v in b.items()
                if isinstance(v, (int, float, str, bool)) or v is None
            }
        )
        scalars = [s for s in scalars if s != "joint"][:8]
        rows = [[j, *(b.get(s) for s in scalars)] for j, b in items]
        lines = _table(["joint", *scalars], rows)
        failed = [
            f"{j}: {c.get('name')}"
            for j, b in items
            for c in b.get("checks", [])
            if isinstance(c, dict) and not c.get("ok", True)
        ]
        if failed:
            lines += ["Failing checks: " + "; ".join(failed), ""]
        return lines
    return _table(
        ["item", "value"],
        [[k, v] for k, v in block.items() if isinstance(v, (int, float, str, bool))],
    )


# ---------------------------------------------------------------------------- text
def _stage_line(stage: str, summary: dict) -> str:
    key = _key(stage)
    block = summary.get(key, {})
    status = block.get("status", "?")
    kf = summary.get("key_figures", {})
    if status == "ok":
        note = {
            "kinematics": lambda: (
                f"{block['n_waypoints']} waypoints in range; reach "
                f"{block['max_reach_m'] * 1000:.0f} mm"
            ),
            "plan": lambda: (
                f"{block['method'] or block['planner']} {block['duration_s']:.3f} s;"
                f" worst {block['worst']['kind']} {block['worst']['ratio']:.3f}"
                f" ({block['worst']['joint']})"
            ),
            "static_load": lambda: "max {1:.4g} N m ({0})".format(
                *max(
                    (
                        (j, b["torque_Nm"])
                        for j, b in block.items()
                        if isinstance(b, dict) and "torque_Nm" in b
                    ),
                    key=lambda x: x[1],
                )
            ),
            "sizing": lambda: (
                ("all checks pass" if kf.get("sizing_ok") else "CHECKS FAIL")
                + f"; min margin {_fmt(kf.get('sizing_min_margin'), 3)}"
                + f" ({kf.get('sizing_binding')})"
            ),
            "tuning": lambda: (
                f"min PM {_fmt(kf.get('min_phase_margin_deg'), 3)} deg, min GM "
                f"{_fmt(kf.get('min_gain_margin_dB'), 3)} dB"
            ),
            "tracking": lambda: (
                f"max joint error {_fmt(1e3 * kf['tracking_max_error_rad'], 3)} "
                f"mrad; TCP {_fmt(1e3 * kf['tcp_max_error_m'], 3)} mm (budget "
                f"{_fmt(1e3 * block['tcp']['accuracy_m'], 3)} mm)"
            ),
            "export": lambda: (
                f"{_fmt(block.get('n_cycles'))} cycles of "
                f"{block.get('cycle_s', 0) * 1000:g} ms ({block.get('profile')})"
            ),
        }[stage]
        try:
            text = note()
        except (KeyError, TypeError, ValueError):
            text = ""
    else:
        text = block.get("reason", block.get("error", ""))
    if len(text) > 56:
        text = text[:53] + "..."
    verdict = block.get("verdict") or "-"
    return f"  {stage:<12}{status:<9}{verdict.upper():<6}{text}"


def design_lines(summary: dict) -> list[str]:
    """The design's verdict in words, its failed checks and advisories (one line each)."""
    d = summary.get("design", {})
    verdict = d.get("verdict", "?")
    failed = d.get("failed_checks", [])
    words = {
        "pass": "the design PASSES every check the study ran",
        "fail": f"the design FAILS {len(failed)} check(s)",
        "incomplete": "the design is NOT JUDGED: " + "; ".join(d.get("not_judged", [])),
    }.get(verdict, f"design verdict {verdict}")
    lines = [f"design: {words}"]
    lines += [f"  FAILED  {f}" for f in failed]
    lines += [f"  advisory  {a}" for a in d.get("advisories", [])]
    return lines


def summary_text(
    summary: dict, files: list[Path] | None = None, out_dir: Path | None = None
) -> str:
    """The one-screen summary ``armlab run`` prints: each stage, its key figures, the files."""
    r = summary.get("robot", {})
    st = summary.get("study", {})
    lines = [
        f"armlab study {st.get('name')!r}: robot {r.get('name')} ({r.get('n_joints')} "
        f"joints), payload {_fmt(r.get('payload_kg'))} kg",
        f"  {'stage':<12}{'status':<9}{'check':<6}key figures",
    ]
    from armlab.study.spec import STAGES

    lines += [_stage_line(s, summary) for s in STAGES]
    lines += design_lines(summary)
    if files:
        names = list(dict.fromkeys(Path(f).name for f in files))
        pngs = [n for n in names if n.endswith(".png")]
        names = [n for n in names if not n.endswith(".png")]
        if pngs:
            names.append(f"{len(pngs)} PNG plots")
        where = f"{out_dir}/" if out_dir is not None else ""
        lines.append(f"files in {where}: " + ", ".join(names))
    return "\n".join(lines)
