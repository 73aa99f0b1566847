"""The amplifiers of the tracking simulation (:mod:`armlab.control.simulate`, step 4): each
joint's current loop, the incremental PI at its own rate over a servo period with its
computation delay and the supply limit, and the armature circuit ``L di/dt = u - R i - Ke w_m``
integrated exactly over each sub-step. Servo periods in which no sub-step reaches the supply
are linear in the state at their start: precomputed maps jump over them
(:func:`linear_period`)."""

from __future__ import annotations

import numpy as np

__all__: list[str] = []

#: use the precomputed linear maps over servo periods without voltage saturation (tests turn
#: it off to compare with the sub-step loop)
LINEAR_PERIODS = True


def linear_period(q0, q1, q2, a, c, R, n_sub: int) -> np.ndarray:
    """The current loop over up to ``n`` sub-steps as linear maps, per joint ``(nj, n, 6, 6)``.

    One sub-step (PI with a one-sample delay, exact armature circuit), state
    ``z = (i, u_prev, e1, e2, i*, emf)`` (the last two constant over a servo period)::

        e = i* - i;  u = u_prev + q0 e + q1 e1 + q2 e2;  x = (u_prev - emf) / R
        i+ = a i + (1 - a) x;  mean current += c i + (1 - c) x;  mean voltage += u_prev

    Row ``j`` maps a start state to the state after ``j + 1`` sub-steps with the last two
    entries replaced by the sums of the sub-steps' mean currents and applied voltages (exact
    while no sub-step reaches the voltage limit; ``u_prev`` is the voltage the PI asked for).
    """
    nj = len(q0)
    out = np.zeros((nj, n_sub, 6, 6))
    for j in range(nj):
        M = np.eye(6)
        M[0] = [a[j], (1 - a[j]) / R[j], 0, 0, 0, -(1 - a[j]) / R[j]]
        M[1] = [-q0[j], 1.0, q1[j], q2[j], q0[j], 0.0]
        M[2] = [-1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        M[3] = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
        r_i = np.array([c[j], (1 - c[j]) / R[j], 0, 0, 0, -(1 - c[j]) / R[j]])
        r_u = np.array([0.0, 1.0, 0, 0, 0, 0])
        P = np.eye(6)
        s_i, s_u = np.zeros(6), np.zeros(6)
        for k in range(n_sub):
            s_i = s_i + r_i @ P
            s_u = s_u + r_u @ P
            P = M @ P
            out[j, k, :4] = P[:4]
            out[j, k, 4] = s_i
            out[j, k, 5] = s_u
    return out


def delayed(hist: list, d: np.ndarray) -> np.ndarray:
    """The voltage each joint applies now: its output ``d`` current-loop samples ago
    (``hist[-1]`` is the newest); drops outputs no joint needs any more."""
    out = np.array([hist[-1 - dj][j] for j, dj in enumerate(d)])
    while len(hist) > int(d.max()) + 1:
        hist.pop(0)
    return out


class Amplifiers:
    """The current loops of every (variant, joint), laid end to end: the incremental PI at its
    own rate over one servo period with its computation delay, the supply limit and the exact
    armature circuit (module docstring, step 4); servo periods that stay linear are jumped over
    with the precomputed maps ``W`` (:func:`linear_period`)."""

    def __init__(self, *, cq, u_lo, u_hi, R, a_sub, c_sub, W, d_arr, fast, n_sub, nv, nj, i, u0):
        self.cq0, self.cq1, self.cq2 = cq
        self.u_lo, self.u_hi, self.R = u_lo, u_hi, R
        self.a_sub, self.c_sub, self.W = a_sub, c_sub, W
        self.d_arr, self.one_delay = d_arr, bool(np.all(d_arr == 1))
        self.fast, self.n_sub, self.nv, self.nj = fast, n_sub, nv, nj
        nvj = nv * nj
        self.rows, self.elems = np.arange(n_sub), np.arange(nvj)
        self.every_todo = np.ones(nv, dtype=bool)
        self.z0 = np.empty((nvj, 1, 6, 1))
        # state: current, last output, last two errors, outputs waiting for their delay, peaks
        self.i, self.u_prev = i, u0
        self.ce1, self.ce2 = np.zeros(nvj), np.zeros(nvj)
        self.u_hist = [u0.copy() for _ in range(int(d_arr.max()))]
        self.peak_u, self.peak_i = np.abs(u0), np.abs(i)

    def period(self, i_cmd: np.ndarray, emf: np.ndarray):
        """One servo period with current set-point ``i_cmd`` [A] and back-EMF ``emf`` [V]
        held: the sums over its sub-steps of the current [A] and voltage [V], and the number
        of sub-steps at the supply limit, each ``(n_variants x n_joints,)``."""
        cq0, cq1, cq2, u_lo, u_hi, R = self.cq0, self.cq1, self.cq2, self.u_lo, self.u_hi, self.R
        a_sub, c_sub, W, d_arr, one_delay = (
            self.a_sub,
            self.c_sub,
            self.W,
            self.d_arr,
            self.one_delay,
        )
        fast, n_sub, nv, nj = self.fast, self.n_sub, self.nv, self.nj
        rows, elems, every_todo, z0 = self.rows, self.elems, self.every_todo, self.z0
        i, u_prev, ce1, ce2, u_hist = self.i, self.u_prev, self.ce1, self.ce2, self.u_hist
        peak_u, peak_i = self.peak_u, self.peak_i
        mn, mx, absf = np.minimum, np.maximum, np.abs
        nvj = nv * nj
        i_sum = np.zeros(nvj)
        u_sum = np.zeros(nvj)
        sat_n = np.zeros(nvj)
        # sub-steps done: k_c by every variant, or per variant (k_arr) once they part ways
        k_c, k_arr = 0, None
        todo = every_todo
        while True:
            if k_arr is None:
                if k_c >= n_sub:
                    break
                every = True
            else:
                todo = k_arr < n_sub
                if not todo.any():
                    break
                every = bool(todo.all())
            # the next sub-step as the amplifier runs it (the PI's kick after a new set-point
            # usually reaches the supply: then it is stepped, not mapped)
            e = i_cmd - i
            u = u_prev + cq0 * e + cq1 * ce1 + cq2 * ce2
            over = (u > u_hi) | (u < u_lo)
            stepped = k_arr is None and bool(
                over.any() if nv == 1 else over.reshape(nv, nj).any(axis=1).all()
            )
            if fast and not stepped:
                # the next sub-steps if linear (no voltage limit reached): jump to the first
                # sub-step that reaches the limit, or to the end of the period
                m = n_sub - (k_c if k_arr is None else int(k_arr[todo].min()))
                z0[:, 0, 0, 0] = i
                z0[:, 0, 1, 0] = u_prev
                z0[:, 0, 2, 0] = ce1
                z0[:, 0, 3, 0] = ce2
                z0[:, 0, 4, 0] = i_cmd
                z0[:, 0, 5, 0] = emf
                lin = (W[:, :m] @ z0)[..., 0]  # (nvj, m, 6)
                u_dem = lin[..., 1]
                viol_e = (u_dem > u_hi[:, None]) | (u_dem < u_lo[:, None])  # (nvj, m)
                if k_arr is None and not viol_e.any():
                    # every variant runs linearly to the end of the period (the usual case)
                    peak_u = mx(peak_u, absf(u_dem).max(axis=1))
                    peak_i = mx(peak_i, absf(lin[..., 0]).max(axis=1))
                    last = lin[:, m - 1]
                    i, u_prev, ce1, ce2 = last[:, 0], last[:, 1], last[:, 2], last[:, 3]
                    i_sum = i_sum + last[:, 4]
                    u_sum = u_sum + last[:, 5]
                    u_hist = [u_prev]
                    break
                if k_arr is None:
                    k_arr, todo = np.full(nv, k_c), every_todo
                viol = viol_e.reshape(nv, nj, m).any(axis=1)  # (nv, m)
                left = (n_sub - k_arr)[:, None]  # (nv, 1): sub-steps each variant has left
                viol &= rows[None, :m] < left
                jump = np.where(viol.any(axis=1), np.argmax(viol, axis=1), left[:, 0])
                jump = np.where(todo, jump, 0)
                moved = jump > 0
                if moved.any():
                    jump_e = np.repeat(jump, nj)
                    upto = rows[None, :m] < jump_e[:, None]  # (nvj, m)
                    pu = np.where(upto, absf(u_dem), 0.0).max(axis=1)
                    pi_ = np.where(upto, absf(lin[..., 0]), 0.0).max(axis=1)
                    mv = np.repeat(moved, nj)
                    peak_u = np.where(mv, mx(peak_u, pu), peak_u)
                    peak_i = np.where(mv, mx(peak_i, pi_), peak_i)
                    last = lin[elems, np.maximum(jump_e - 1, 0)]  # (nvj, 6)
                    i = np.where(mv, last[:, 0], i)
                    u_prev = np.where(mv, last[:, 1], u_prev)
                    ce1 = np.where(mv, last[:, 2], ce1)
                    ce2 = np.where(mv, last[:, 3], ce2)
                    i_sum = np.where(mv, i_sum + last[:, 4], i_sum)
                    u_sum = np.where(mv, u_sum + last[:, 5], u_sum)
                    u_hist = [u_prev]
                    k_arr = k_arr + jump
                    todo = k_arr < n_sub
                    if not todo.any():
                        break
                    every = bool(todo.all())
                    e = i_cmd - i  # the sub-step from the state the jump reached
                    u = u_prev + cq0 * e + cq1 * ce1 + cq2 * ce2
                    over = (u > u_hi) | (u < u_lo)
            # one sub-step as the amplifier runs it, with the voltage limit (variants done
            # with the period keep their state)
            if k_arr is None:
                k_c += 1
            else:
                k_arr = k_arr + todo
            u_new = mn(mx(u, u_lo), u_hi)
            if every:
                peak_u = mx(peak_u, absf(u))
                sat_n = sat_n + over
                ce2, ce1, u_prev = ce1, e, u_new
            else:
                act = np.repeat(todo, nj)
                peak_u = np.where(act, mx(peak_u, absf(u)), peak_u)
                sat_n = np.where(act, sat_n + over, sat_n)
                ce2 = np.where(act, ce1, ce2)
                ce1 = np.where(act, e, ce1)
                u_prev = np.where(act, u_new, u_prev)
            u_hist.append(u_prev)
            ua = u_hist.pop(0) if one_delay else delayed(u_hist, d_arr)
            x = (ua - emf) / R
            if every:
                i_sum = i_sum + (x + (i - x) * c_sub)
                u_sum = u_sum + ua
                i = x + (i - x) * a_sub
                peak_i = mx(peak_i, absf(i))
            else:
                i_sum = np.where(act, i_sum + (x + (i - x) * c_sub), i_sum)
                u_sum = np.where(act, u_sum + ua, u_sum)
                i = np.where(act, x + (i - x) * a_sub, i)
                peak_i = np.where(act, mx(peak_i, absf(i)), peak_i)
        self.i, self.u_prev, self.ce1, self.ce2, self.u_hist = i, u_prev, ce1, ce2, u_hist
        self.peak_u, self.peak_i = peak_u, peak_i
        return i_sum, u_sum, sat_n
