"""Run a study: the chain of stages from a :class:`StudySpec` to an output folder.

``run_study(path, out_dir)`` is what ``armlab run`` calls; :func:`run_spec` is the same without
the file reading and printing (sweeps and notebooks use it). Outputs in ``out_dir``
(DESIGN.md): ``summary.json``, ``report.md`` with PNG plots beside it, ``setpoints.csv``,
``gains.json`` and ``trajectory.npz`` (the input of ``armlab export``).
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from armlab.errors import ArmlabError
from armlab.study.spec import STAGES, StudySpec, load_study
from armlab.study.stages import (
    NEEDS,
    STAGE_FUNCTIONS,
    SUMMARY_KEY,
    NotApplicable,
    NotAvailable,
    StudyContext,
    build_robot,
    robot_block,
)

__all__ = ["StudyResult", "run_study", "run_spec", "key_figures", "KEY_FIGURES", "write_json"]


@dataclass
class StudyResult:
    """What a study produced: the summary (summary.json content) and the objects behind it.

    Attributes
    ----------
    spec : StudySpec
    summary : dict
        The summary.json content (DESIGN.md keys; each block has a ``status``).
    context : StudyContext
        The robot, trajectory, sizing report, gains, tracking result... (None where a stage did
        not run).
    out_dir : Path or None
    files : list of Path
        Files written.
    """

    spec: StudySpec
    summary: dict[str, Any]
    context: StudyContext
    out_dir: Path | None
    files: list[Path]

    @property
    def robot(self):
        return self.context.robot

    @property
    def trajectory(self):
        return self.context.trajectory

    @property
    def gains(self):
        return self.context.gains

    def key_figures(self) -> dict[str, Any]:
        return key_figures(self.summary)


def _clean(x):
    """JSON-safe: NaN -> None, +-inf -> "inf"/"-inf" (strict JSON has neither)."""
    if isinstance(x, float):
        if math.isnan(x):
            return None
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return x
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    return x


def write_json(path: Path, data: Any) -> Path:
    """Write JSON atomically (temporary file in the same folder, then ``os.replace``)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(_clean(data), f, indent=2, allow_nan=False)
            f.write("\n")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _progress(total: int, enabled: bool | None, desc: str):
    from tqdm import tqdm

    # disable=None: tqdm switches itself off when stderr is not a terminal (CI)
    return tqdm(
        total=total,
        desc=desc,
        unit="stage",
        disable=None if enabled is None else not enabled,
        leave=False,
        file=sys.stderr,
    )


def run_spec(
    spec: StudySpec,
    out_dir: str | Path | None = None,
    *,
    workers: int | None = None,
    progress: bool | None = False,
    report: bool | None = None,
) -> StudyResult:
    """Run every stage of a study.

    Parameters
    ----------
    spec : StudySpec
    out_dir : str or Path, optional
        Output folder (created). None: run in memory and write nothing (sweeps); the export
        stage still builds the set-point table, so its pre-flight checks run.
    workers : int, optional
        Processes for the stages that can use several (reserved; None: one).
    progress : bool or None
        Progress bar over the stages: True, False, or None = only on a terminal.
    report : bool, optional
        Write report.md and its plots (default ``study.report``; never without ``out_dir``).

    Raises
    ------
    ArmlabError
        The first stage that fails, with the stage's name in front of its message; the
        summary.json written so far records it.
    """
    out = None if out_dir is None else Path(out_dir)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    ctx = StudyContext(spec=spec, out_dir=out, workers=workers)
    summary: dict[str, Any] = {
        "study": {
            "name": spec.study.name,
            "source": spec.source,
            "hash": spec.hash,
            "seed": spec.study.seed,
            "armlab_version": _version(),
            "stages": {},
        },
    }
    files: list[Path] = []
    bar = _progress(len(STAGES) + 1, progress, spec.study.name)

    def record(stage: str, key: str, block: dict, t0: float) -> None:
        summary[key] = block
        summary["study"]["stages"][stage] = {
            "status": block["status"],
            "time_s": round(time.perf_counter() - t0, 6),
        }

    def fail(stage: str, exc: ArmlabError):
        if out is not None:
            files.append(write_json(out / "summary.json", summary))
        bar.close()
        return type(exc)(f"{stage}: {exc}")

    try:
        t0 = time.perf_counter()
        bar.set_postfix_str("robot")
        try:
            ctx.robot = build_robot(spec)
        except ArmlabError as exc:
            record("robot", "robot", {"status": "error", "error": str(exc)}, t0)
            raise fail("robot", exc) from None
        record("robot", "robot", robot_block(ctx), t0)
        bar.update()
        for stage in STAGES:
            t0 = time.perf_counter()
            bar.set_postfix_str(stage)
            key = SUMMARY_KEY[stage]
            missing = [
                n
                for n in NEEDS.get(stage, ())
                if summary["study"]["stages"].get(n, {}).get("status") != "ok"
            ]
            if stage not in spec.study.stages:
                block = {"status": "skipped", "reason": "not in study.stages"}
            elif missing:
                why = ", ".join(
                    f"{n}: {summary['study']['stages'].get(n, {}).get('status')}" for n in missing
                )
                block = {"status": "skipped", "reason": f"needs {', '.join(missing)} ({why})"}
            else:
                try:
                    block = STAGE_FUNCTIONS[stage](ctx)
                except NotAvailable as exc:
                    block = {"status": "not available", "reason": str(exc)}
                except NotApplicable as exc:
                    block = {"status": "skipped", "reason": str(exc)}
                except ArmlabError as exc:
                    record(
                        stage,
                        key,
                        {"status": "error", "error": str(exc), "error_type": type(exc).__name__},
                        t0,
                    )
                    raise fail(stage, exc) from None
            record(stage, key, block, t0)
            bar.update()
        summary["key_figures"] = key_figures(summary)
        if out is not None:
            files += [Path(p) for p in ctx.files.values()]
            if spec.study.report if report is None else report:
                from armlab.study.report import write_report

                bar.set_postfix_str("report")
                files += write_report(ctx, summary, out)
            files.insert(0, write_json(out / "summary.json", summary))
    finally:
        bar.close()
    return StudyResult(spec=spec, summary=summary, context=ctx, out_dir=out, files=files)


def _version() -> str:
    import armlab

    return armlab.__version__


def run_study(
    study: str | Path | None,
    out_dir: str | Path,
    workers: int | None = None,
    *,
    overrides: dict[str, Any] | None = None,
    progress: bool | None = None,
    quiet: bool = False,
) -> dict[str, Any]:
    """Run a study file into ``out_dir`` and print a one-screen summary (``armlab run``).

    Parameters
    ----------
    study : str, Path or None
        STUDY.toml; None: the built-in teachbot6 demo study (``armlab/data/demo_study.toml``).
    out_dir : str or Path
        Output folder: summary.json, report.md + PNGs, setpoints.csv, gains.json, trajectory.npz.
    workers : int, optional
        Processes for the stages that can use several (reserved; None: one).
    overrides : dict, optional
        Dotted study keys to change (``{"payload.mass_kg": 1.0}``).
    progress : bool or None
        Stage progress bar; None: only on a terminal.
    quiet : bool
        Do not print the summary.

    Returns
    -------
    dict
        The summary (summary.json content).
    """
    spec = load_study(study, overrides)
    result = run_spec(spec, out_dir, workers=workers, progress=progress)
    if not quiet:
        from armlab.study.report import summary_text

        print(summary_text(result.summary, result.files, result.out_dir))
    return result.summary


# ---------------------------------------------------------------------------- key figures
def _get(d: Any, *path, default=math.nan):
    for p in path:
        if not isinstance(d, dict) or p not in d:
            return default
        d = d[p]
    return d


def _num(x) -> float:
    if isinstance(x, bool):
        return float(x)
    if isinstance(x, (int, float)):
        return float(x)
    if x == "inf":
        return math.inf
    return math.nan


def _walk_loops(control: dict):
    """(joint, loop, figures) of every loop in a summary's "control" block."""
    for joint, loops in control.items():
        if isinstance(loops, dict):
            for loop, fig in loops.items():
                if isinstance(fig, dict) and "phase_margin_deg" in fig:
                    yield joint, loop, fig


#: Names of the numeric key figures (the sweep's figures of merit).
KEY_FIGURES = (
    "max_reach_m",
    "duration_s",
    "peak_velocity_ratio",
    "peak_acceleration_ratio",
    "peak_jerk_ratio",
    "peak_torque_ratio",
    "max_static_torque_Nm",
    "sizing_ok",
    "sizing_min_margin",
    "min_phase_margin_deg",
    "min_gain_margin_dB",
    "position_crossover_min_rad_s",
    "tracking_max_error_rad",
    "tcp_max_error_m",
    "n_cycles",
)


def key_figures(summary: dict[str, Any]) -> dict[str, Any]:
    """The figures a sweep keeps per study (one flat row; NaN where a stage did not run).

    ``duration_s``; ``peak_<kind>_ratio`` (max over joints of the plan's ratio to each limit);
    ``max_static_torque_Nm``; ``sizing_ok`` and ``sizing_min_margin`` (smallest margin of every
    drive check) with ``sizing_binding`` (``joint:check``); ``min_phase_margin_deg``,
    ``min_gain_margin_dB`` (every loop, continuous and discrete), ``position_crossover_min_rad_s``;
    ``tracking_max_error_rad``, ``tcp_max_error_m``; ``n_cycles`` of the set-point table; and the
    status of each stage (``stage_<name>``).
    """
    out: dict[str, Any] = {}
    out["max_reach_m"] = _num(_get(summary, "kinematics", "max_reach_m"))
    traj = summary.get("trajectory", {})
    out["duration_s"] = _num(traj.get("duration_s"))
    for kind in ("velocity", "acceleration", "jerk", "torque"):
        out[f"peak_{kind}_ratio"] = _num(_get(traj, "peak_ratio", kind))
    # static load: per joint {torque_Nm, ...}
    static = summary.get("static_load", {})
    torques = [_num(_get(v, "torque_Nm")) for v in _joint_blocks(static)]
    out["max_static_torque_Nm"] = max(torques) if torques else math.nan
    # sizing: per joint {checks: [{name, value, limit, margin, ok}]}
    sizing = summary.get("sizing", {})
    margins, ok_all, binding = [], True, ""
    for joint, block in _joint_items(sizing):
        for check in block.get("checks", []) if isinstance(block, dict) else []:
            m = _num(check.get("margin"))
            if not check.get("ok", True):
                ok_all = False
            if not math.isnan(m) and (not margins or m < min(margins)):
                binding = f"{joint}:{check.get('name', '?')}"
            margins.append(m)
    out["sizing_ok"] = ok_all if margins else None
    finite = [m for m in margins if not math.isnan(m)]
    out["sizing_min_margin"] = min(finite) if finite else math.nan
    out["sizing_binding"] = binding
    control = summary.get("control", {})
    pm, gm, wc = [], [], []
    for _joint, loop, fig in _walk_loops(control):
        pm += [_num(fig.get("phase_margin_deg")), _num(fig.get("phase_margin_discrete_deg"))]
        gm += [_num(fig.get("gain_margin_dB")), _num(fig.get("gain_margin_discrete_dB"))]
        if loop == "position":
            wc.append(_num(fig.get("crossover_rad_s")))
    out["min_phase_margin_deg"] = _nanmin(pm)
    out["min_gain_margin_dB"] = _nanmin(gm)
    out["position_crossover_min_rad_s"] = _nanmin(wc)
    tracking = summary.get("tracking", {})
    errs = [_num(_get(v, "max_error_rad")) for v in _joint_blocks(tracking)]
    out["tracking_max_error_rad"] = _nanmax(errs)
    out["tcp_max_error_m"] = _num(_get(tracking, "tcp", "max_error_m"))
    if math.isnan(out["tcp_max_error_m"]):
        out["tcp_max_error_m"] = _num(tracking.get("tcp_max_error_m"))
    n = _get(summary, "export", "n_cycles", default=None)
    out["n_cycles"] = math.nan if n is None else float(n)
    for stage, info in summary.get("study", {}).get("stages", {}).items():
        out[f"stage_{stage}"] = info.get("status", "")
    return out


def _joint_items(block: dict):
    """(joint, dict) entries of a per-joint block (``{"joints": {...}}`` or joints at top)."""
    if not isinstance(block, dict):
        return []
    inner = block.get("joints", block)
    if isinstance(inner, list):
        return [(b.get("joint", str(i)), b) for i, b in enumerate(inner) if isinstance(b, dict)]
    return [(k, v) for k, v in inner.items() if isinstance(v, dict)]


def _joint_blocks(block: dict):
    return [v for _, v in _joint_items(block)]


def _nanmin(xs) -> float:
    xs = [x for x in xs if not math.isnan(x)]
    return min(xs) if xs else math.nan


def _nanmax(xs) -> float:
    xs = [x for x in xs if not math.isnan(x)]
    return max(xs) if xs else math.nan
