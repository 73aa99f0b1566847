"""The ``armlab`` command line: ``info``, ``run``, ``sweep``, ``export``.

Every :class:`armlab.ArmlabError` becomes one line on stderr and exit status 2; no traceback.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from armlab.errors import ArmlabError

__all__ = ["main", "info_text"]


def info_text(robot_name: str) -> str:
    """The text ``armlab info ROBOT`` prints: joints, ranges, limits, drives, reach, mass."""
    from armlab.kinematics import max_reach_m
    from armlab.robot import load_robot

    robot = load_robot(robot_name)
    lim = robot.limits
    lines = [
        f"robot      {robot.name}  ({robot.urdf_path})",
        f"joints     {robot.n_joints}; tool frame {robot.tool_frame}; "
        f"payload {robot.payload.mass_kg:g} kg",
        f"mass       {robot.total_mass_kg:.3f} kg moving (payload included)",
        f"reach      {max_reach_m(robot) * 1000:.1f} mm max radius of the tool point from the "
        "base axis",
        "",
        f"{'joint':<10}{'range [deg]':>18}{'v [rad/s]':>11}{'a [rad/s2]':>12}{'j [rad/s3]':>12}"
        f"{'effort [Nm]':>13}",
    ]
    for i, name in enumerate(robot.joint_names):
        acc = "-" if lim.acceleration_rad_s2 is None else f"{lim.acceleration_rad_s2[i]:.3g}"
        jerk = "-" if lim.jerk_rad_s3 is None else f"{lim.jerk_rad_s3[i]:.3g}"
        rng = f"{math.degrees(lim.lower_rad[i]):.0f} .. {math.degrees(lim.upper_rad[i]):.0f}"
        lines.append(
            f"{name:<10}{rng:>18}{lim.velocity_rad_s[i]:>11.4g}{acc:>12}{jerk:>12}"
            f"{lim.effort_Nm[i]:>13.4g}"
        )
    if robot.drives is not None:
        lines += [
            "",
            f"{'joint':<10}{'motor':<22}{'stall [Nm]':>11}{'speed [rpm]':>12}"
            f"{'reducer':<16}{'ratio':>7}{'eta':>6}{'counts/rev':>12}",
        ]
        for name in robot.joint_names:
            d = robot.drives[name]
            lines.append(
                f"{name:<10}{d.motor.model[:21]:<22}{d.motor.stall_torque_Nm:>11.4g}"
                f"{d.motor.rated_speed_rpm:>12.0f}  {d.reducer.model[:14]:<14}"
                f"{d.reducer.ratio:>7g}{d.reducer.efficiency:>6.2f}"
                f"{d.encoder.counts_per_joint_rev(d.reducer.ratio):>12.0f}"
            )
    return "\n".join(lines)


def _cmd_info(args) -> int:
    print(info_text(args.robot))
    return 0


def _cmd_run(args) -> int:
    from armlab.study import run_study

    run_study(args.study, args.out, workers=None)
    return 0


def _cmd_sweep(args) -> int:
    from armlab.sweep import run_sweep

    run_sweep(args.sweep, args.out, workers=args.workers, scheduler=args.scheduler)
    return 0


def _cmd_export(args) -> int:
    from armlab.deploy import export_study

    for path in export_study(
        args.study_dir, fmt=args.format, profile=args.profile, out_dir=args.out
    ):
        print(path)
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="armlab", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)
    s = sub.add_parser("info", help="joints, limits, drives, reach and mass of a robot")
    s.add_argument("robot", help="name under robot_desc/ (teachbot6) or a URDF path")
    s.set_defaults(func=_cmd_info)
    s = sub.add_parser("run", help="run one study (default: the built-in teachbot6 study)")
    s.add_argument("study", nargs="?", default=None, help="STUDY.toml")
    s.add_argument("--out", required=True, help="output folder")
    s.set_defaults(func=_cmd_run)
    s = sub.add_parser("sweep", help="run a parameter sweep of studies")
    s.add_argument("sweep", help="SWEEP.toml (or 'demo': the shipped example)")
    s.add_argument("--out", required=True, help="output folder (results.parquet)")
    s.add_argument("--workers", type=int, default=None, help="local worker processes")
    s.add_argument("--scheduler", default=None, help="Dask scheduler address tcp://host:port")
    s.set_defaults(func=_cmd_sweep)
    s = sub.add_parser("export", help="set-point tables and gains of a finished study")
    s.add_argument("study_dir")
    s.add_argument("--format", default="csv", choices=["csv", "json", "npz", "c", "ros2"])
    s.add_argument("--profile", default=None, help="controller profile name or TOML path")
    s.add_argument("--out", required=True)
    s.set_defaults(func=_cmd_export)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    np.set_printoptions(precision=4, suppress=True)
    try:
        return int(args.func(args) or 0)
    except ArmlabError as exc:
        print(f"armlab: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("armlab: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
