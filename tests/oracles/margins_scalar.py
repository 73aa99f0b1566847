"""Oracle for :mod:`armlab.control.margins`: the margins read one crossing at a time.

The package reads every crossing of many loops at once (index arrays); this is the plain loop
over the crossings of one response (the package's reader before it was batched): the same
definitions, an independent implementation.
"""

from __future__ import annotations

import math

import numpy as np

from armlab.control.margins import Margins


def margins_scalar(w: np.ndarray, L: np.ndarray) -> Margins:
    """Margins from a sampled open-loop response ``L`` at frequencies ``w`` [rad/s].

    Crossings are located by linear interpolation in log|L| and unwrapped phase. A loop whose
    gain is still above 1 at the end of the grid (Nyquist for a discrete loop) gets a phase
    margin of -inf: it has no usable margin.
    """
    mag = np.abs(L)
    with np.errstate(divide="ignore"):
        lm = np.log(mag)
    ph = np.unwrap(np.angle(L))
    # gain crossovers
    s = np.sign(lm)
    idx = np.flatnonzero(s[:-1] * s[1:] < 0)
    pm, wc = math.inf, math.nan
    for k in idx:
        f = lm[k] / (lm[k] - lm[k + 1])
        p = ph[k] + f * (ph[k + 1] - ph[k])
        m = math.degrees(p) + 180.0
        m = (m + 180.0) % 360.0 - 180.0
        pm = min(pm, m)
        wk = math.exp(math.log(w[k]) + f * (math.log(w[k + 1]) - math.log(w[k])))
        wc = wk if math.isnan(wc) else max(wc, wk)
    if lm[-1] > 0.0:  # |L| > 1 at the end of the grid (Nyquist): no usable margin
        pm, wc = -math.inf, float(w[-1])
    # phase crossovers: phase = -180 (mod 360)
    x = (ph + math.pi) / (2 * math.pi)
    n = np.floor(x)
    idx = np.flatnonzero(n[:-1] != n[1:])
    gm, wpc = math.inf, math.nan
    for k in idx:
        target = max(n[k], n[k + 1])
        f = (target - x[k]) / (x[k + 1] - x[k])
        lk = lm[k] + f * (lm[k + 1] - lm[k])
        if lk < 0:
            g = -20.0 * lk / math.log(10.0)
            if g < gm:
                gm = g
                wpc = math.exp(math.log(w[k]) + f * (math.log(w[k + 1]) - math.log(w[k])))
    return Margins(float(pm), float(gm), float(wc), float(wpc))
