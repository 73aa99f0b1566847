"""TEMPORARY stand-in (lead's shell work): the closed-form graph's layout filled by today's
numpy functions. Replaced by the cfgraph helper's module."""

from __future__ import annotations

import numpy as np

from armlab.planning.timescale import CHECK_TOL


def layout(n: int) -> dict:
    S = 6 * n + 2
    off, o = {}, 0
    for name, size in (
        ("head", 9),
        ("t", S),
        ("q", S * n),
        ("qd", S * n),
        ("qdd", S * n),
        ("qddd", S * n),
        ("ratio", 4 * n),
        ("at", 4 * n),
        ("bind", 3 * n),
    ):
        off[name] = (o, o + size)
        o += size
    off["size"] = o
    off["S"] = S
    return off


def evaluate(W, P):
    from armlab.planning.optimal_closed import ARRIVAL_TOL, _knots  # noqa: F401
    from armlab.trajectory.profiles import synchronised_scurves
    from armlab.trajectory.sampling import LimitReport

    W = np.asarray(W, float).reshape(2, -1)
    n = W.shape[1]
    v, a, j, lo, hi, cen, half = P.reshape(7, n)
    L = layout(n)
    out = np.zeros(L["size"])
    valid = bool(np.isfinite(W).all() and ((W >= lo) & (W <= hi)).all()) and any(
        abs(y - x) >= 1e-12 for x, y in zip(W[0].tolist(), W[1].tolist())
    )
    if not valid:
        return out
    batch = synchronised_scurves((W[1] - W[0])[None], v, a, j)
    T = float(batch.duration[0])
    t = _knots(batch.boundaries()[0, :, 0], T)
    q, qd, qdd, J = (x[:, 0] for x in batch.evaluate_jerk(t))
    q += W[0]
    q[-1], qd[-1], qdd[-1], J[-1] = W[-1], 0.0, 0.0, 0.0
    m = t.size

    class _L:
        velocity_rad_s, acceleration_rad_s2, jerk_rad_s3 = v, a, j

        @staticmethod
        def centre_half_rad():
            return cen, half

    from armlab.planning.optimal_closed import exact_report

    ex = exact_report(batch, W[0], W[1], _L, [f"j{i}" for i in range(n)])
    exact_ok = ex is not None
    S = L["S"]
    out[L["t"][0] : L["t"][0] + m] = t
    for name, x in (("q", q), ("qd", qd), ("qdd", qdd), ("qddd", J)):
        o = L[name][0]
        out[o : o + m * n] = x.reshape(-1)
    ok = False
    resid = 0.0
    nb = 0
    if exact_ok:
        rep, resid = ex
        assert isinstance(rep, LimitReport)
        ok = rep.ok(CHECK_TOL)
        for k, kind in enumerate(("position", "velocity", "acceleration", "jerk")):
            out[L["ratio"][0] + k * n : L["ratio"][0] + (k + 1) * n] = rep.ratios[kind]
            out[L["at"][0] + k * n : L["at"][0] + (k + 1) * n] = rep.at_s[kind]
        b = out[L["ratio"][0] + n : L["ratio"][0] + 4 * n] >= 1 - 2e-3
        out[L["bind"][0] : L["bind"][1]] = b
        nb = int(b.sum())
    out[:9] = [m, T, 1.0, float(exact_ok), float(ok), nb, resid, 0.0, T]
    del S
    return out
