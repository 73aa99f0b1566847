"""Benchmark: writing a 6-axis 1 kHz set-point table for a 60 s motion in every format.

60 001 cycles x 6 joints (360 006 joint set-points). Goal: CSV < 1 s on one core.
Peers side by side for the same numbers: ``numpy.savetxt`` (row-by-row formatting in C),
``pandas.DataFrame.to_csv``, ``json.dumps`` of the column lists.

Run: ``MPLBACKEND=Agg .venv/bin/python benchmarks/bench_deploy.py``
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one core

import io  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from _readme import readme_row, sig  # noqa: E402

# ---------------------------------------------------------------------- parameters
ROBOT = "teachbot6"
DURATION_S = 60.0
CYCLE_S = 1e-3
PLAN_SAMPLES = 6001  # knots of the planned motion (10 ms), sampled at CYCLE_S by the table
FORMATS = ("csv", "json", "npz", "c")
REPEATS = 3  # best of
PEERS = True


def cosine_motion(robot, duration_s, n, scale=0.9):
    from armlab.trajectory import Trajectory

    t = np.linspace(0.0, duration_s, n)
    lim = robot.limits
    q = np.zeros((n, robot.n_joints))
    qd, qdd = np.zeros_like(q), np.zeros_like(q)
    for j in range(robot.n_joints):
        for k, frac in ((3, 0.45), (7, 0.3)):
            w = 2 * math.pi * k / duration_s
            A = min(
                frac * scale * lim.velocity_rad_s[j] / w,
                frac * scale * lim.acceleration_rad_s2[j] / w**2,
            )
            q[:, j] += A * (1 - np.cos(w * t)) - A
            qd[:, j] += A * w * np.sin(w * t)
            qdd[:, j] += A * w * w * np.cos(w * t)
    return Trajectory(t, q, qd, qdd, joint_names=robot.joint_names, method="cosines")


def best(fn, repeats=REPEATS):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main() -> None:
    import armlab
    from armlab.deploy import read_setpoints, setpoint_table

    robot = armlab.load_robot(ROBOT)
    traj = cosine_motion(robot, DURATION_S, PLAN_SAMPLES)
    t_table, table = best(lambda: setpoint_table(robot, traj, "reference_dda"), 1)
    rows = [("setpoint_table (sample + counts + checks)", "-", t_table, None, None)]
    suffix = {"csv": ".csv", "json": ".json", "npz": ".npz", "c": ".h"}
    with tempfile.TemporaryDirectory() as tmp:
        for fmt in FORMATS:
            path = Path(tmp) / f"setpoints{suffix[fmt]}"
            t_render, data = best(lambda fmt=fmt: table.render(fmt))
            t_write, _ = best(lambda fmt=fmt, path=path: table.write(path, fmt))
            t_read = None
            if fmt != "c":
                t_read, back = best(lambda path=path: read_setpoints(path), 1)
                assert np.array_equal(back.counts, table.counts)
            rows.append((f"armlab {fmt}", f"{len(data) / 1e6:.1f}", t_render, t_write, t_read))
        if PEERS:
            cols = table.columns()
            mat = np.column_stack([c.astype(float) for c in cols.values()])
            fmt = ",".join("%d" if c.dtype.kind in "iu" else "%.9f" for c in cols.values())

            def savetxt():
                buf = io.StringIO()
                np.savetxt(buf, mat, fmt=fmt, delimiter=",")
                return buf.getvalue()

            t, text = best(savetxt)
            rows.append(("peer numpy.savetxt csv", f"{len(text) / 1e6:.1f}", t, None, None))
            try:
                import pandas as pd

                df = pd.DataFrame(cols)
                t, text = best(lambda: df.to_csv(index=False, float_format="%.9f"))
                rows.append(("peer pandas.to_csv csv", f"{len(text) / 1e6:.1f}", t, None, None))
            except ImportError:
                pass
            lists = {k: v.tolist() for k, v in cols.items()}
            t, text = best(lambda: json.dumps({"columns": lists}))
            rows.append(("peer json.dumps json", f"{len(text) / 1e6:.1f}", t, None, None))

    print(
        f"set-point table: {ROBOT}, {table.n_axes} axes, {table.n_cycles} cycles of "
        f"{CYCLE_S * 1e3:g} ms ({DURATION_S:g} s), {len(table.column_names())} columns; "
        f"best of {REPEATS}, one core"
    )
    print(f"{'what':<44}{'MB':>6}{'render [s]':>12}{'write [s]':>11}{'read [s]':>10}")
    for name, mb, tr, tw, trd in rows:
        f = lambda x: "-" if x is None else f"{x:.3f}"  # noqa: E731
        print(f"{name:<44}{mb:>6}{f(tr):>12}{f(tw):>11}{f(trd):>10}")
    csv_write = next(r[3] for r in rows if r[0] == "armlab csv")
    print(
        f"CSV goal < 1 s: {'met' if csv_write < 1.0 else 'NOT met'} ({csv_write:.3f} s written "
        "atomically, fsync included)"
    )
    write = {r[0]: r[3] for r in rows}
    render = {r[0]: r[2] for r in rows}
    names = {"csv": "CSV", "json": "JSON", "npz": "NPZ", "c": "C header"}
    peers = [
        ("numpy.savetxt", "peer numpy.savetxt csv"),
        ("pandas.to_csv", "peer pandas.to_csv csv"),
    ]
    readme_row(
        __file__,
        f"{table.n_axes}-axis {1 / CYCLE_S / 1e3:g} kHz {DURATION_S:g} s set-point table "
        f"({sig(table.n_cycles, 6)} cycles), goal CSV < 1 s",
        ", ".join(f"{names[f]} {write[f'armlab {f}']:.3f} s" for f in FORMATS)
        + " (written: atomic, fsync)",
        ", ".join(f"`{p}` {render[k]:.2f} s" for p, k in peers if k in render),
    )


if __name__ == "__main__":
    main()
