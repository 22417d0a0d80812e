"""The compiled part of :mod:`.push` (numba): one stroke of a push followed from event to event.

Each event's rate problem is a few dozen unknowns, and a push has a few hundred events: in plain
numpy the calls around each small solve cost ten times the solve (the bench's experiment row
measures it). Arrays in, arrays out; the state (slips x, eyelet modes, slack tendons) is updated
in place. The meaning of every array is :mod:`.push`'s.
"""
from __future__ import annotations

import math

import numba
import numpy as np

JIT = dict(cache=True, nogil=True, error_model="numpy")
RATE_TOL = 1e-12           # rates under this are zero
RATIO_TOL = 1e-9           # an eyelet this near its ratio (relative to the largest tension) is at it
BLOCK_PIVOTS = 4           # pivots that turn every disagreeing eyelet at once before turning one at a time
MAX_PIVOTS = 500           # pivots of one rate problem (finite for the P-matrices of a stable robot)
MAX_EVENTS = 20_000        # events of one stroke before it gives up (never reached)

END, SLIP, SLACK, TAUT, OPEN, TARGET = 0, 1, 2, 3, 4, 5


@numba.njit(**JIT)
def _solve(system, eyes, state, s, xdot, tdot):
    """The rates per unit of u moved in direction s with the modes as they stand: each slipping
    eyelet holds its ratio, each slack tendon's segments keep their tension. Fills xdot and tdot."""
    M, v, _, _, _, seg_tendon = system
    eye_a, eye_b, ratio, free, eye_tendon = eyes
    _, mode, slack, _ = state
    m, nx = M.shape
    e = len(eye_a)
    idx = np.empty(nx, np.int64)
    n = 0
    for i in range(e):
        if mode[i] != 0 or free[i] or slack[eye_tendon[i]]:
            idx[n] = i
            n += 1
    for t in range(len(slack)):
        if slack[t]:
            idx[n] = e + t
            n += 1
    xdot[:] = 0.0
    if n == 0:
        for j in range(m):
            tdot[j] = v[j] * s
        return
    A = np.empty((n, n))
    y = np.empty(n)
    r = 0
    for i in range(e):
        if (mode[i] != 0 or free[i]) and not slack[eye_tendon[i]]:
            q = 1.0 if free[i] else ratio[i]
            hi, lo = (eye_b[i], eye_a[i]) if mode[i] >= 0 else (eye_a[i], eye_b[i])
            for k in range(n):
                A[r, k] = M[hi, idx[k]] - q * M[lo, idx[k]]
            y[r] = -(v[hi] - q * v[lo]) * s
            r += 1
    for j in range(m):
        if slack[seg_tendon[j]]:
            for k in range(n):
                A[r, k] = M[j, idx[k]]
            y[r] = -v[j] * s
            r += 1
    ok = True
    try:
        sol = np.linalg.solve(A, y)
    except:  # noqa: E722  (numba catches no named exception): a singular system, solved in the least-squares sense
        ok = False
    if not ok:
        sol = np.linalg.lstsq(A, y)[0]
    for k in range(n):
        xdot[idx[k]] = sol[k]
    for j in range(m):
        acc = v[j] * s
        for k in range(n):
            acc += M[j, idx[k]] * sol[k]
        tdot[j] = acc


@numba.njit(**JIT)
def _rates(system, eyes, state, s, tau, xdot, tdot):
    """:func:`_solve` with the modes that agree with the rates (the eyelets' linear complementarity
    problem: an eyelet at its ratio slips if holding would take it past the ratio, and holds if
    slipping would slide the line back), every disagreeing eyelet turned at once while that
    converges, then by Murty's least-index pivoting."""
    eye_a, eye_b, ratio, free, eye_tendon = eyes
    _, mode, slack, _ = state
    e = len(eye_a)
    big = 0.0
    for j in range(len(tau)):
        big = max(big, abs(tau[j]))
    scale = RATIO_TOL * (1.0 + big)
    turn = np.zeros(e, np.int64)
    for n in range(MAX_PIVOTS):
        _solve(system, eyes, state, s, xdot, tdot)
        bad = 0
        for i in range(e):
            turn[i] = 0
            if free[i] or slack[eye_tendon[i]]:
                continue
            a, b = eye_a[i], eye_b[i]
            if mode[i] != 0:
                if mode[i] * xdot[i] < -RATE_TOL:
                    turn[i] = 2                                  # it would slide back: it holds
            elif tau[b] - ratio[i] * tau[a] >= -scale and tdot[b] - ratio[i] * tdot[a] > RATE_TOL:
                turn[i] = 1
            elif tau[a] - ratio[i] * tau[b] >= -scale and tdot[a] - ratio[i] * tdot[b] > RATE_TOL:
                turn[i] = -1
            if turn[i] != 0:
                bad += 1
        if bad == 0:
            return
        for i in range(e):
            if turn[i] != 0:
                mode[i] = 0 if turn[i] == 2 else turn[i]
                if n >= BLOCK_PIVOTS:
                    break


@numba.njit(**JIT)
def follow(system, eyes, state, motion, out_u, out_f):
    """Move the push point as ``motion`` = (u, u_to, s, target, until_open) says: from u in direction
    s (±1) to u_to (nan: no end); target (nan: none): stop once F reaches it; until_open: stop once
    F falls to zero. ``system`` = (M, v, a, c, τ₀, each segment's tendon), ``eyes`` = (base-side
    segment, tip-side segment, ratio, free, tendon) per eyelet, ``state`` = (x, mode, slack,
    slackened), updated in place. Writes each event's (u, F) into ``out_u``, ``out_f``. Returns
    (events written, where it stopped, why: END, OPEN or TARGET)."""
    M, v, a, c, tau0, seg_tendon = system
    eye_a, eye_b, ratio, free, eye_tendon = eyes
    x, mode, slack, slackened = state
    u, u_to, s, target, until_open = motion
    m, nx = M.shape
    e = len(eye_a)
    xdot = np.zeros(nx)
    tdot = np.zeros(m)
    tau = np.zeros(m)
    count = 0
    why = END
    for _ in range(MAX_EVENTS):
        for j in range(m):
            acc = tau0[j] + v[j] * u
            for k in range(nx):
                acc += M[j, k] * x[k]
            tau[j] = acc
        F = u
        for k in range(nx):
            F -= a[k] * x[k]
        F /= c
        if count < len(out_u):
            out_u[count] = u
            out_f[count] = F
            count += 1
        _rates(system, eyes, state, s, tau, xdot, tdot)
        Fdot = s
        for k in range(nx):
            Fdot -= a[k] * xdot[k]
        Fdot /= c
        step = math.inf if math.isnan(u_to) else max(0.0, (u_to - u) * s)
        kind, which = END, -1
        for i in range(e):                                      # a held eyelet reaches its ratio
            if mode[i] != 0 or free[i] or slack[eye_tendon[i]]:
                continue
            for sign in (1, -1):
                hi, lo = (eye_b[i], eye_a[i]) if sign > 0 else (eye_a[i], eye_b[i])
                gd = tdot[hi] - ratio[i] * tdot[lo]
                if gd > RATE_TOL:
                    d = max(0.0, ratio[i] * tau[lo] - tau[hi]) / gd
                    if d < step:
                        step, kind, which = d, SLIP, sign * (i + 1)
        for j in range(m):                                      # a taut tendon goes slack
            if not slack[seg_tendon[j]] and tdot[j] < -RATE_TOL:
                d = max(tau[j], 0.0) / -tdot[j]
                if d < step:
                    step, kind, which = d, SLACK, seg_tendon[j]
        for t in range(len(slack)):                             # a slack one's path has taken up its line
            if slack[t] and xdot[e + t] > RATE_TOL:
                d = max(-x[e + t], 0.0) / xdot[e + t]
                if d < step:
                    step, kind, which = d, TAUT, t
        if until_open and Fdot < -RATE_TOL and max(F, 0.0) / -Fdot < step:
            step, kind = max(F, 0.0) / -Fdot, OPEN
        if not math.isnan(target) and Fdot > RATE_TOL and (target - F) / Fdot < step:
            step, kind = max(0.0, (target - F) / Fdot), TARGET
        if not math.isfinite(step):
            break                                               # nothing ends it: the robot gives way without bound
        u += s * step
        for k in range(nx):
            x[k] += xdot[k] * step
        if kind == SLIP:
            mode[abs(which) - 1] = 1 if which > 0 else -1
        elif kind == SLACK:
            slack[which] = True
            slackened[which] = True
            for i in range(e):
                if eye_tendon[i] == which:
                    mode[i] = 0
        elif kind == TAUT:
            slack[which] = False
            for i in range(e):
                if eye_tendon[i] == which:
                    mode[i] = 0
        else:
            why = kind
            F = u
            for k in range(nx):
                F -= a[k] * x[k]
            if count < len(out_u):
                out_u[count] = u
                out_f[count] = F / c
                count += 1
            break
    mode[:] = 0                                                 # the stroke ends: every eyelet holds
    return count, u, why
