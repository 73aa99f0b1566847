"""The ``armlab`` command line: ``info``, ``run``, ``drives``, ``sweep``, ``export``.

Exit status: 0 the design passes (or the command succeeded), 1 the study ran and the design fails
(the failed checks on stderr; also an export refused for a failing design), 2 bad input or usage:
every other :class:`armlab.ArmlabError` becomes one line on stderr, no traceback; 3 the file
system refused (an :class:`OSError`: permission denied, disk full, file too large, read-only,
``--out`` a file): one line naming the path; 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import sys
from typing import TYPE_CHECKING

from armlab.errors import ArmlabError, DesignFailure

if TYPE_CHECKING:
    from armlab.study.verdict import DesignVerdict

__all__ = ["main", "console", "info_text", "build_parser"]

#: ``armlab --help``'s description: plain text (the module docstring is reST for the API docs).
SUMMARY = (
    "armlab: design, sizing, motion planning and servo tuning of serial robot arms. "
    "Commands: info (a robot's data), run (one study), drives (select a drive train from the "
    "catalogue), sweep (many studies on Dask), export (set-point tables and gains of a "
    "finished study)."
)

EXIT_STATUS = """\
exit status:
  0  the design passes (or the command succeeded)
  1  the study ran and the design fails a check (the failed checks on stderr), or an export
     was refused for a failing design
  2  bad input or usage (one line on stderr, no traceback), another armlab client
     writes the output folder (its lock names the pid and host), or an export folder
     holds files export did not write (without --overwrite)
  3  the file system refused: permission denied, disk full, file too large, read-only,
     --out is a file (one line naming the path)
  130 interrupted (Ctrl-C)"""


def info_text(
    robot_name: str,
    *,
    tool_frame: str | None = None,
    lock_joints: list[str] | tuple[str, ...] = (),
    drives: str | None = None,
) -> str:
    """The text ``armlab info ROBOT`` prints: joints, ranges, limits, drives, reach, mass, the
    collision model (:func:`armlab.collision.collision_summary`: shapes from the URDF's
    ``<collision>`` or ``<visual>`` elements, checked and disabled pairs).

    ``tool_frame``, ``lock_joints`` and ``drives`` (a drives file) are the study's ``[robot]``
    keys of the same names. Ranges of revolute joints are in [deg], of prismatic joints in [m];
    columns widen to the longest joint and part names.
    """
    from armlab.collision import collision_summary
    from armlab.kinematics import max_reach_m
    from armlab.robot import load_robot
    from armlab.robot.drives_file import read_drives
    from armlab.robot.limits import description_limits, resolve_limits

    robot = load_robot(robot_name, tool_frame=tool_frame, lock_joints=list(lock_joints))
    if drives is not None:
        robot.drives = read_drives(drives, robot.joint_names)
        robot.limits = resolve_limits(
            description_limits(robot.model, robot.joint_names), robot.drives, model=robot.model
        )
    lim = robot.limits
    prismatic = _prismatic(robot)
    w = max(10, *(len(n) + 2 for n in robot.joint_names))
    lines = [
        f"robot      {robot.name}  ({robot.urdf_path})",
        f"joints     {robot.n_joints}; tool frame {robot.tool_frame}"
        + ("" if robot.tool_frame_from == "given" else f" ({robot.tool_frame_from})")
        + "; "
        f"payload {robot.payload.mass_kg:g} kg",
        f"mass       {robot.total_mass_kg:.3f} kg moving (payload included)",
        f"reach      {max_reach_m(robot) * 1000:.1f} mm max radius of the tool point from the "
        "base axis",
        f"collision  {collision_summary(robot)}",
        "",
        f"{'joint':<{w}}{'type':<6}{'range':>20}{'velocity':>13}{'acceleration':>14}"
        f"{'jerk':>14}{'effort':>10}",
        f"{'':<{w}}{'R|P|C':<6}{'[deg | m]':>20}{'[rad|m /s]':>13}{'[rad|m /s2]':>14}"
        f"{'[rad|m /s3]':>14}{'[Nm | N]':>10}",
    ]

    def cell(values, i: int, width: int) -> str:
        return f"{'-':>{width}}" if values is None else f"{values[i]:>{width}.4g}"

    for i, name in enumerate(robot.joint_names):
        if prismatic[i]:
            kind, rng = "P", f"{lim.lower_rad[i]:.4g} .. {lim.upper_rad[i]:.4g} m"
        else:
            deg = (math.degrees(lim.lower_rad[i]), math.degrees(lim.upper_rad[i]))
            kind, rng = "R", f"{deg[0]:.0f} .. {deg[1]:.0f} deg"
            if name in robot.continuous_joints:  # continuous in the URDF (revolute_continuous)
                kind = "C"
                rng = rng if robot.continuous_joints[name] else "unbounded"
        lines.append(
            f"{name:<{w}}{kind:<6}{rng:>20}{cell(lim.velocity_rad_s, i, 13)}"
            f"{cell(lim.acceleration_rad_s2, i, 14)}{cell(lim.jerk_rad_s3, i, 14)}"
            f"{cell(lim.torque_Nm, i, 10)}"
        )
    lines += ["", "limit sources (acceleration): " + _sources(lim.sources.get("acceleration"))]
    if robot.continuous_joints:
        lines.append(
            "C: continuous in the URDF, loaded as revolute over its <limit> range, or unbounded "
            "(no position limit in plans and tables) without one"
        )
    if robot.drives is not None:
        mw = max(8, *(len(d.motor.model) + 2 for d in robot.drives.values()))
        rw = max(9, *(len(d.reducer.model) + 2 for d in robot.drives.values()))
        lines += [
            "",
            f"{'joint':<{w}}{'motor':<{mw}}{'stall [Nm]':>11}{'speed [rpm]':>12}  "
            f"{'reducer':<{rw}}{'ratio':>7}{'eta':>6}{'counts/rev':>12}",
        ]
        for name in robot.joint_names:
            d = robot.drives[name]
            lines.append(
                f"{name:<{w}}{d.motor.model:<{mw}}{d.motor.stall_torque_Nm:>11.4g}"
                f"{d.motor.rated_speed_rpm:>12.0f}  {d.reducer.model:<{rw}}"
                f"{d.reducer.ratio:>7g}{d.reducer.efficiency:>6.2f}"
                f"{d.counts_per_motor_rev() * d.reducer.ratio:>12.0f}"
            )
    return "\n".join(lines)


def _prismatic(robot) -> list[bool]:
    """True for each prismatic joint (Pinocchio ``JointModelP*``: PX, PY, PZ, unaligned)."""
    joints = robot.model.joints
    return [joints[j].shortname().startswith("JointModelP") for j in range(1, len(joints))]


def _sources(sources) -> str:
    if not sources:
        return "-"
    unique = list(dict.fromkeys(sources))
    return "; ".join(unique)


def _cmd_info(args) -> int:
    print(
        info_text(
            args.robot,
            tool_frame=args.tool_frame,
            lock_joints=_split(args.lock_joints),
            drives=args.drives,
        )
    )
    return 0


def _split(text: str | None) -> list[str]:
    """``"a,b c"`` -> ``["a", "b", "c"]`` (comma or space separated names)."""
    if not text:
        return []
    return [x for x in text.replace(",", " ").split() if x]


def _cmd_drives(args) -> int:
    """``armlab drives ROBOT STUDY --out drives.toml``: select the drive train of ROBOT from
    the catalogue against STUDY's planned motion and worst static poses; write it as a drives
    file (nothing is written when any joint has no passing entry)."""
    from pathlib import Path

    from armlab.io import atomic_write
    from armlab.robot.drives_file import drives_toml
    from armlab.study.spec import load_study
    from armlab.study.stages import selection_for_study

    robot = args.robot
    if Path(robot).exists():  # a path on the command line is relative to the shell's folder
        robot = str(Path(robot).resolve())
    spec = load_study(args.study, {"robot.name": robot})
    ctx = selection_for_study(spec)
    sel = ctx.selection
    assert sel is not None and ctx.robot.drives is not None  # installed by the selection
    text = drives_toml(ctx.robot.drives, header=_drives_header(ctx, args.study))
    out = Path(args.out)
    if out.exists() and not args.overwrite:
        print(
            f"armlab: error: --out {out}: exists (pass --overwrite to replace it)", file=sys.stderr
        )
        return 2
    atomic_write(out, text)
    print(sel.to_markdown())
    print(f"drives file: {out}")
    return 0


def _drives_header(ctx, study) -> str:
    """The comment block of a drives file written by ``armlab drives``: provenance, the chosen
    parts with their binding checks and runners-up, the assumptions, the limit sources."""
    import armlab

    sel = ctx.selection
    lim = ctx.robot.limits
    lines = [
        f"Drive train of {ctx.robot.name} selected by armlab {armlab.__version__} "
        f"(armlab drives) from the catalogue {sel.catalogue_path}",
        f"against the study {study}: its planned motion plus a 1 s hold at each joint's worst",
        "static pose; lightest motor + reducer per joint that passes sizing on the plan made "
        "with their",
        f"own limits ({sel.rounds} select -> limits -> plan rounds), tunes, and tracks "
        "(docs/drives.md).",
        "Every value below is the catalogue's (see its sources); edit freely.",
        "",
    ]
    for joint, why in sel.skipped.items():
        lines += [f"{joint}: passed over {line}" for line in why]
    lines += list(sel.notes)
    for js in sel.joints:
        c = js.chosen
        if c is None:
            continue
        ru = js.runner_up
        lines.append(
            f"{js.joint}: {c.motor.model} + {c.reducer.model}; binding {c.binding.describe()}; "
            f"runner-up {'none' if ru is None else ru.motor.model + ' + ' + ru.reducer.model}"
        )
    for a in sel.assumptions:
        lines.append(f"ASSUMED: {a}")
    for kind in ("acceleration", "jerk"):
        lines.append(
            f"{kind}_rad_s{'2' if kind == 'acceleration' else '3'}: "
            + _sources(lim.sources.get(kind))
        )
    return "\n".join(lines) + "\n"


def _cmd_run(args) -> int:
    """``armlab run``: the study (:func:`armlab.study.run_spec`), its one-screen summary, and
    the exit status from the design's verdict."""
    from armlab.errors import InputError
    from armlab.study import load_study, run_spec
    from armlab.study.decisions import print_decisions
    from armlab.study.report import summary_text

    if args.workers is not None:  # the option of armlab <= issue 23, refused on one line
        raise InputError(
            "run --workers: a study runs in one process; studies run in parallel with "
            "armlab sweep --workers N"
        )
    if args.remedies < 0:
        raise InputError(f"run --remedies: {args.remedies} (a count: 0 or more)")
    spec = load_study(args.study)
    result = run_spec(
        spec,
        args.out,
        progress=None,
        force=args.force,
        overwrite=args.overwrite,
        announce=print_decisions,
        remedies=args.remedies,
    )
    print(summary_text(result))
    return _verdict_status(result.design)


def _verdict_status(design: DesignVerdict) -> int:
    """Exit status of a finished study: 0 the design passes, 1 it fails or was not judged
    (the failed checks, or what was not judged, on stderr)."""
    if design.verdict == "pass":
        return 0
    if design.verdict == "fail":
        failed = design.failed_checks
        print(f"armlab: the design fails {len(failed)} check(s):", file=sys.stderr)
        for line in failed:
            print(f"  {line}", file=sys.stderr)
    else:
        print(
            "armlab: the design was not judged: " + "; ".join(design.not_judged),
            file=sys.stderr,
        )
    return 1


def _cmd_sweep(args) -> int:
    """Exit status of a sweep: 0 every row done and its design passes; 1 error rows, failing
    designs or designs not judged (their counts on stderr); 2 bad input, a folder holding
    another sweep (without ``--overwrite``) or written by another client."""
    from armlab.sweep import run_sweep
    from armlab.sweep.runner import sweep_outcome

    frame = run_sweep(
        args.sweep,
        args.out,
        workers=args.workers,
        scheduler=args.scheduler,
        overwrite=args.overwrite,
    )
    n = sweep_outcome(frame)
    if n["errors"] == n["failing"] == n["not_judged"] == 0:
        return 0
    print(
        f"armlab: sweep: {n['errors']} of {n['rows']} rows are errors, {n['failing']} designs "
        f"fail, {n['not_judged']} not judged (columns status, error and verdict of "
        f"{args.out}/results.parquet)",
        file=sys.stderr,
    )
    return 1


def _cmd_export(args) -> int:
    from armlab.study import export_study

    result = export_study(
        args.study_dir,
        fmt=args.format,
        controller=args.profile,
        out_dir=args.out,
        force=args.force,
        overwrite=args.overwrite,
    )
    for note in result.notes:
        print(f"armlab: {note}", file=sys.stderr)
    for path in result.files:
        print(path)
    return 0


class _HelpFormatter(argparse.HelpFormatter):
    """Wraps descriptions to the terminal; keeps a text with line breaks (the exit-status table)
    as written."""

    def _fill_text(self, text, width, indent):
        if "\n" in text:
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


def _names(names: list[str]) -> str:
    return ", ".join(names) if names else "none found"


def build_parser() -> argparse.ArgumentParser:
    """The ``armlab`` argument parser: every argument has a help text; ``--version``."""
    from armlab import __version__
    from armlab.robot.controller import DEFAULT_PROFILE, list_profiles
    from armlab.robot.model import list_robots
    from armlab.study.remedies import MAX_REMEDIES

    robots, profiles = _names(list_robots()), _names(list_profiles())
    fmt = _HelpFormatter
    p = argparse.ArgumentParser(
        prog="armlab", description=SUMMARY, epilog=EXIT_STATUS, formatter_class=fmt
    )
    p.add_argument(
        "--version",
        action="version",
        version=f"armlab {__version__}",
        help="print the armlab version and exit",
    )
    sub = p.add_subparsers(
        dest="command", required=True, metavar="COMMAND", title="commands", help="one of:"
    )
    s = sub.add_parser(
        "info",
        formatter_class=fmt,
        help="joints, limits, drives, reach and mass of a robot",
        description="Print a robot's joints, joint ranges and limits, drives (motor, reducer, "
        f"encoder), maximum reach and moving mass. Built-in robots: {robots}.",
    )
    s.add_argument(
        "robot",
        metavar="ROBOT",
        help=f"built-in robot name ({robots}), the path of a URDF (a drives.toml and an "
        "mdh.toml beside it are read too) or erd:<path> for a URDF of example-robot-data",
    )
    s.add_argument(
        "--tool-frame",
        default=None,
        metavar="FRAME",
        help="tool frame (study: [robot] tool_frame; default tool0, else one named like a tool)",
    )
    s.add_argument(
        "--lock-joints",
        default=None,
        metavar="NAMES",
        help="joints locked at 0, comma separated (a study's [robot] lock_joints)",
    )
    s.add_argument(
        "--drives",
        default=None,
        metavar="FILE",
        help="drives file instead of the drives.toml beside the URDF (a study's [robot] drives)",
    )
    s.set_defaults(func=_cmd_info)
    s = sub.add_parser(
        "drives",
        formatter_class=fmt,
        help="select a drive train from the catalogue and write it as a drives file",
        description="Plan STUDY's motion on ROBOT, then choose for every joint the lightest "
        "catalogue motor + reducer that passes every sizing check on that motion plus a 1 s "
        "hold at the joint's worst static pose; print the choice with its binding check and "
        "runner-up, and write it as a drives file (docs/drives.md) to edit and name in a "
        "study ([robot] drives). Nothing is written if a joint has no passing entry: the "
        "error names the joint and the check every candidate fails.",
        epilog=EXIT_STATUS,
    )
    s.add_argument(
        "robot",
        metavar="ROBOT",
        help="built-in robot name, URDF path or erd:<path> (replaces the study's [robot] name)",
    )
    s.add_argument("study", metavar="STUDY.toml", help="the study whose motion the drives carry")
    s.add_argument("--out", required=True, metavar="FILE", help="the drives file to write")
    s.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    s.set_defaults(func=_cmd_drives)
    s = sub.add_parser(
        "run",
        help="run one study (default: the built-in teachbot6 study)",
        description="Run every stage of a study file (kinematics, plan, static load, sizing, "
        "tuning, tracking, export) and write summary.json, design.json, the report and the "
        "exports into the output folder. Without a study file, runs the built-in teachbot6 "
        "demo study.",
        epilog=EXIT_STATUS,
        formatter_class=fmt,
    )
    s.add_argument(
        "study",
        nargs="?",
        default=None,
        metavar="STUDY.toml",
        help="the study file (default: the built-in teachbot6 demo study)",
    )
    s.add_argument("--out", required=True, metavar="DIR", help="output folder")
    s.add_argument(
        "--force",
        action="store_true",
        help="write setpoints.csv even if the design fails a check (recorded in the file)",
    )
    s.add_argument(
        "--overwrite",
        action="store_true",
        help="clear an output folder that holds another study's outputs",
    )
    s.add_argument(
        "--remedies",
        type=int,
        default=MAX_REMEDIES,
        metavar="N",
        help="for a failing design, measure up to N remedies, each a modified study run "
        f"(default {MAX_REMEDIES}; 0: none)",
    )
    # refused with one line (a study runs in one process; sweeps run studies in parallel)
    s.add_argument("--workers", type=int, default=None, help=argparse.SUPPRESS)
    s.set_defaults(func=_cmd_run)
    s = sub.add_parser(
        "sweep",
        formatter_class=fmt,
        help="run a parameter sweep of studies",
        description="Run one study per parameter set of a sweep file on a Dask cluster (a "
        "local process cluster by default) and write one row per study to results.parquet, "
        "with summary.txt and plots/. Running the same command again resumes: only the "
        "missing parameter sets run.",
    )
    s.add_argument(
        "sweep", metavar="SWEEP.toml", help="the sweep file, or 'demo' for the shipped example"
    )
    s.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="output folder (results.parquet, summary.txt, plots/)",
    )
    s.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="worker processes of the local cluster (default: one per CPU)",
    )
    s.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="address of a running Dask scheduler, tcp://host:port (instead of a local "
        "cluster; its workers need armlab installed)",
    )
    s.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the results of another sweep in the output folder",
    )
    s.set_defaults(func=_cmd_sweep)
    s = sub.add_parser(
        "export",
        help="set-point tables and gains of a finished study",
        description="Write the set-point table of a finished study's plan for a controller "
        "profile, and its tuned gains, into a new folder; a design that fails a check is "
        f"refused unless --force. Built-in controller profiles: {profiles} (a study without a "
        f"[controller] profile uses {DEFAULT_PROFILE}).",
        epilog=EXIT_STATUS,
        formatter_class=fmt,
    )
    s.add_argument("study_dir", metavar="STUDY_DIR", help="folder written by armlab run")
    s.add_argument(
        "--format",
        default="csv",
        choices=["csv", "json", "npz", "c", "ros2", "trajectory", "cia402"],
        help="csv|json|npz: set-point table (json: + gains.json); c: C header + data file of "
        "set-points and gains; ros2: ros2_control controllers YAML (controller_manager + "
        "joint_trajectory_controller gains and constraints); trajectory: the plan as a "
        "FollowJointTrajectory goal (JSON); cia402: CiA 402 cyclic synchronous position "
        "set-points and object dictionary values",
    )
    s.add_argument(
        "--profile",
        default=None,
        metavar="PROFILE",
        help=f"built-in controller profile ({profiles}) or the path of a profile TOML "
        "(default: the study's own controller)",
    )
    s.add_argument(
        "--out", required=True, metavar="DIR", help="output folder (not the study folder)"
    )
    s.add_argument(
        "--force",
        action="store_true",
        help="export a design that fails a check (the file records the failed checks)",
    )
    s.add_argument(
        "--overwrite",
        action="store_true",
        help="write into a folder holding files armlab export did not write (same-named ones "
        "are replaced, the others kept); without it such a folder is refused",
    )
    s.set_defaults(func=_cmd_export)
    return p


#: environment variables that choose the BLAS thread count; when one is set, it is obeyed
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def one_blas_thread() -> bool:
    """Run numpy's BLAS on one thread in this process unless the environment chooses
    (:data:`BLAS_THREAD_VARIABLES`); True when it was set here.

    armlab's matrices are small (state-space loops, 6 x 6 dynamics): a second BLAS thread
    does not speed them up, and beside another busy process (a sweep's workers, other jobs on
    the machine) it slows them down (the demo's tuning stage, one study in one process on a
    loaded 2-core machine: 1.05 s on one thread, 5.0 s on two; measured in issue 23). The
    numbers do not change (the demo's files are the same bit for bit on one thread and on two).

    Two steps, because scipy brings its own OpenBLAS, loaded at the first use of
    ``scipy.linalg``: the limit covers the libraries loaded so far, and
    ``OPENBLAS_NUM_THREADS=1`` in the environment the ones loaded later (without it the demo's
    tuning stage ran a second BLAS thread: 0.75-1.3 s of CPU in 0.42 s, measured).
    """
    if any(os.environ.get(name) for name in BLAS_THREAD_VARIABLES):
        return False
    from threadpoolctl import threadpool_limits

    os.environ["OPENBLAS_NUM_THREADS"] = "1"  # read by each OpenBLAS when it loads
    threadpool_limits(1, user_api="blas")
    return True


#: What to do about an error of the file system, by errno (the one line of exit status 3).
_OS_ERROR_HINTS = {
    errno.EACCES: "permission denied: choose a folder you can write",
    errno.EPERM: "not permitted: choose a folder you can write",
    errno.EROFS: "read-only file system: choose another folder",
    errno.ENOSPC: "no space left on the device: free space or choose another disk",
    errno.EDQUOT: "disk quota exceeded: free space or choose another disk",
    errno.EFBIG: "file too large for the file system or the process's file-size limit",
}


def os_error_line(exc: OSError) -> str:
    """One line for an error of the file system: the path(s), what the system said, and what
    to do (:data:`_OS_ERROR_HINTS`), never a traceback (exit status 3)."""
    paths = [str(p) for p in (exc.filename, exc.filename2) if p is not None]
    what = _OS_ERROR_HINTS.get(exc.errno or 0) or exc.strerror or str(exc) or type(exc).__name__
    text = (" -> ".join(paths) + ": " if paths else "") + what
    return " ".join(text.split())  # one line whatever the message held


def main(argv: list[str] | None = None) -> int:
    """Run the ``armlab`` command line; returns the exit status (:data:`EXIT_STATUS`).

    Everything after the argument parsing -- numpy's and the command's imports included -- runs
    inside the error handling, so a Ctrl-C while the libraries load is status 130 on one line.
    """
    try:
        args = build_parser().parse_args(argv)
        import numpy as np

        np.set_printoptions(precision=4, suppress=True)
        one_blas_thread()
        return int(args.func(args) or 0)
    except DesignFailure as exc:
        print(f"armlab: {exc}", file=sys.stderr)
        return 1
    except ArmlabError as exc:
        print(f"armlab: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"armlab: error: {os_error_line(exc)}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        print("armlab: interrupted", file=sys.stderr)
        return 130


def console() -> None:
    """The ``armlab`` console script: :func:`main`, then the process ends without tearing down
    the interpreter.

    The exit handlers run (``atexit``: multiprocessing's, Dask's, the open files' finalizers)
    and the output is flushed; what is skipped is the destruction of every object, which
    took 0.35 s after the demo study (CasADi's expression graphs of the optimiser's compiled
    problems, measured) -- 6 % of the study's time, spent on memory the system frees at once.
    """
    code = main()
    import atexit

    atexit._run_exitfuncs()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    console()
