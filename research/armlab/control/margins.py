"""Stability margins of open loops read from their sampled frequency response.

For an open loop ``L(jw)`` sampled on a logarithmic grid ``w`` (up to Nyquist ``pi / T`` for a
discrete loop, ``z = e^{jwT}``):

* gain crossovers: the grid intervals where ``log|L|`` changes sign; the crossing is located by
  linear interpolation in ``log|L|`` against ``log w``, the phase interpolated the same way;
  phase margin ``PM = 180 deg - |arg L(jw_c)|``, the angle from the crossing to the nearest
  ``-1`` along the unwrapped phase, the smallest over all gain crossovers; the bandwidth figure
  is the highest crossover. The unwrapped phase is taken absolute by placing its value at the
  lowest grid frequency in (-270, 90] deg (a cascade loop starts at 0, -90 or -180 deg: current,
  position, speed). For a phase in (-360, 0] -- every rigid loop -- this is the textbook
  ``180 deg + arg L``; a crossover in a phase-lead region (the compliant joint's
  anti-resonance, ``arg L`` in (0, 180) deg) is ``180 deg - arg L`` from ``-1`` the other way
  round, where the textbook formula, blind to the lead, would report a negative margin;
* phase crossovers: the intervals where the unwrapped phase passes ``-180 deg (mod 360)``;
  gain margin ``GM = -20 log10 |L(jw_pc)|`` over the crossings with ``|L| < 1``, the smallest
  (the gain increase the loop tolerates);
* a loop whose gain is still above 1 at the end of the grid (Nyquist) gets ``PM = -inf``: it
  has no usable margin.

These are the textbook definitions (Franklin, Powell & Emami-Naeini, *Feedback Control of
Dynamic Systems*, 6.4); python-control's ``stability_margins`` computes the same figures and
is the check in the tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Margins", "freq_grid", "margins", "margins_many", "margins_from_log"]


@dataclass(frozen=True)
class Margins:
    """Stability margins of an open loop.

    Attributes
    ----------
    phase_margin_deg : float
        Smallest phase margin over the gain crossovers (inf if |L| never crosses 1).
    gain_margin_dB : float
        Smallest gain-increase margin over the -180 deg crossings with |L| < 1 (inf if none).
    crossover_rad_s : float
        Highest gain crossover in [rad/s] (the loop's bandwidth figure).
    phase_crossover_rad_s : float
        The -180 deg crossing of the smallest gain margin in [rad/s] (nan if none).
    """

    phase_margin_deg: float
    gain_margin_dB: float
    crossover_rad_s: float
    phase_crossover_rad_s: float

    def ok(self, phase_margin_deg: float, gain_margin_dB: float) -> bool:
        return self.phase_margin_deg >= phase_margin_deg and self.gain_margin_dB >= gain_margin_dB


def freq_grid(
    dt: float | None = None, w_min: float = 1e-1, w_max: float = 1e6, n: int = 1500
) -> np.ndarray:
    """Log grid in [rad/s]; for a discrete loop it stops just below Nyquist ``pi / dt``."""
    if dt is not None:
        w_max = min(w_max, math.pi / dt * (1 - 1e-6))
    return np.logspace(math.log10(w_min), math.log10(w_max), n)


def margins(w: np.ndarray, L: np.ndarray) -> Margins:
    """Margins (module docstring) from a sampled open-loop response ``L`` at ``w`` [rad/s]."""
    pm, gm, wc, wpc = margins_many(w, np.asarray(L)[None, :])
    return Margins(float(pm[0]), float(gm[0]), float(wc[0]), float(wpc[0]))


def margins_many(w: np.ndarray, L: np.ndarray) -> tuple[np.ndarray, ...]:
    """:func:`margins` of many open loops at once: ``L`` (..., n) sampled at ``w`` (n,).

    Returns ``(phase_margin_deg, gain_margin_dB, crossover_rad_s, phase_crossover_rad_s)``,
    arrays of shape ``L.shape[:-1]``.
    """
    L = np.asarray(L)
    shape = L.shape[:-1]
    L = L.reshape(-1, L.shape[-1])
    with np.errstate(divide="ignore"):
        lm = np.log(np.abs(L))
    out = margins_from_log(np.log(w), lm, np.unwrap(np.angle(L), axis=-1))
    return tuple(x.reshape(shape) for x in out)


def margins_from_log(logw: np.ndarray, lm: np.ndarray, ph: np.ndarray) -> tuple[np.ndarray, ...]:
    """The margins from ``log|L|`` and the unwrapped phase (rows, n) at ``log w`` (n,).

    The phase may be offset by whole turns (a product's phases added): the figures only use
    it modulo 360 deg. Only the grid intervals where a crossing happens are interpolated.
    Returns ``(phase_margin_deg, gain_margin_dB, crossover_rad_s, phase_crossover_rad_s)``
    (rows,); of several crossings with the same smallest gain margin the first is reported.
    """
    rows = lm.shape[0]
    lo, hi = logw[:-1], logw[1:]
    # absolute phase: the first sample in (-270, 90] deg (module docstring)
    turns = np.ceil((ph[:, :1] - 0.5 * math.pi) / (2 * math.pi))
    ph = ph - 2 * math.pi * turns
    # gain crossovers
    s = np.sign(lm)
    r, k = np.divmod(np.flatnonzero(s[:, :-1] * s[:, 1:] < 0), lm.shape[1] - 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = lm[r, k] / (lm[r, k] - lm[r, k + 1])
    p = ph[r, k] + f * (ph[r, k + 1] - ph[r, k])
    m = 180.0 - np.abs(np.degrees(p))
    pm = np.full(rows, np.inf)
    np.minimum.at(pm, r, m)
    wc = np.full(rows, -np.inf)
    np.maximum.at(wc, r, np.exp(lo[k] + f * (hi[k] - lo[k])))
    wc[np.isinf(wc)] = np.nan
    end = lm[:, -1] > 0.0  # |L| > 1 at the end of the grid (Nyquist): no usable margin
    pm[end] = -np.inf
    wc[end] = math.exp(logw[-1])
    # phase crossovers: phase = -180 (mod 360)
    x = (ph + math.pi) / (2 * math.pi)
    nf = np.floor(x)
    r, k = np.divmod(np.flatnonzero(nf[:, :-1] != nf[:, 1:]), lm.shape[1] - 1)
    target = np.maximum(nf[r, k], nf[r, k + 1])
    f = (target - x[r, k]) / (x[r, k + 1] - x[r, k])
    with np.errstate(invalid="ignore"):
        lk = lm[r, k] + f * (lm[r, k + 1] - lm[r, k])
        valid = lk < 0
    r, k, f, g = r[valid], k[valid], f[valid], -20.0 * lk[valid] / math.log(10.0)
    gm = np.full(rows, np.inf)
    np.minimum.at(gm, r, g)
    wpc = np.full(rows, np.nan)
    first = g == gm[r]  # the first crossing with the smallest margin
    rr, i = np.unique(r[first], return_index=True)
    sel = np.flatnonzero(first)[i]
    wpc[rr] = np.exp(lo[k[sel]] + f[sel] * (hi[k[sel]] - lo[k[sel]]))
    return pm, gm, wc, wpc
