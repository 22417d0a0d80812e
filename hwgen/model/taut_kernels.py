"""The compiled part of :mod:`.taut` (numba): one chain's projected Newton and the parallel sweep.

2-vectors are tuples (v0, v1), 2×2 matrices tuples (m00, m01, m10, m11): nothing is allocated
inside the loops; each task allocates its workspace once.
"""
from __future__ import annotations

import math

import numba
import numpy as np

TOL_REST = 1e-13    # the straight pose, solved cold: every ΔL is measured from it
MAX_ITER = 60
LINE_SEARCH = 40    # halvings of a Newton step before a solve is declared stalled
F_SLACK = 1e-12     # a trial step may raise F by this much (rounding) and still count as descent
# No fastmath: with contraction or reciprocal approximation allowed, LLVM fuses differently when the
# kernel is compiled fresh and when it is loaded from numba's cache, and the as-built bands moved
# at 1e-13 mm between a build that compiled and one that did not (CI's reproducibility test failed).
JIT = dict(cache=True, nogil=True, error_model="numpy")


@numba.njit(**JIT)
def _mm(A, B):
    return (A[0] * B[0] + A[1] * B[2], A[0] * B[1] + A[1] * B[3], A[2] * B[0] + A[3] * B[2], A[2] * B[1] + A[3] * B[3])


@numba.njit(**JIT)
def _tr(A):
    return (A[0], A[2], A[1], A[3])


@numba.njit(**JIT)
def _mv(A, v):
    return (A[0] * v[0] + A[1] * v[1], A[2] * v[0] + A[3] * v[1])


@numba.njit(**JIT)
def _inv(A):
    det = A[0] * A[3] - A[1] * A[2]
    return (A[3] / det, -A[1] / det, -A[2] / det, A[0] / det)


@numba.njit(**JIT)
def _et(E, j, v0, v1, v2):
    """E_j^T v."""
    return (E[j, 0, 0] * v0 + E[j, 1, 0] * v1 + E[j, 2, 0] * v2, E[j, 0, 1] * v0 + E[j, 1, 1] * v1 + E[j, 2, 1] * v2)


@numba.njit(**JIT)
def _ete(E, i, j):
    """E_i^T E_j."""
    return (E[i, 0, 0] * E[j, 0, 0] + E[i, 1, 0] * E[j, 1, 0] + E[i, 2, 0] * E[j, 2, 0],
            E[i, 0, 0] * E[j, 0, 1] + E[i, 1, 0] * E[j, 1, 1] + E[i, 2, 0] * E[j, 2, 1],
            E[i, 0, 1] * E[j, 0, 0] + E[i, 1, 1] * E[j, 1, 0] + E[i, 2, 1] * E[j, 2, 0],
            E[i, 0, 1] * E[j, 0, 1] + E[i, 1, 1] * E[j, 1, 1] + E[i, 2, 1] * E[j, 2, 1])


@numba.njit(**JIT)
def _length(a, b, C, E, w, l, t):
    """Polyline a → P_0 … P_{N−1} → b: segment lengths l (N+1), unit directions t (N+1, 3); returns the sum."""
    N = C.shape[0]
    F = 0.0
    px, py, pz = a[0], a[1], a[2]
    for m in range(N + 1):
        if m < N:
            qx = C[m, 0] + E[m, 0, 0] * w[m, 0] + E[m, 0, 1] * w[m, 1]
            qy = C[m, 1] + E[m, 1, 0] * w[m, 0] + E[m, 1, 1] * w[m, 1]
            qz = C[m, 2] + E[m, 2, 0] * w[m, 0] + E[m, 2, 1] * w[m, 1]
        else:
            qx, qy, qz = b[0], b[1], b[2]
        dx, dy, dz = qx - px, qy - py, qz - pz
        lm = math.sqrt(dx * dx + dy * dy + dz * dz)
        l[m] = lm
        t[m, 0], t[m, 1], t[m, 2] = dx / lm, dy / lm, dz / lm
        F += lm
        px, py, pz = qx, qy, qz
    return F


@numba.njit(**JIT)
def _onto_disc(w, act, r):
    """Active points back onto their rim, free points that left their disc projected onto it."""
    for j in range(r.shape[0]):
        if r[j] <= 0.0:
            w[j, 0] = 0.0
            w[j, 1] = 0.0
            act[j] = 0
            continue
        rho = math.sqrt(w[j, 0] * w[j, 0] + w[j, 1] * w[j, 1])
        if act[j] != 0 or rho > r[j]:
            if rho > 0.0:
                w[j, 0] *= r[j] / rho
                w[j, 1] *= r[j] / rho
            act[j] = 1


@numba.njit(**JIT)
def cold_start(a, b, C, E, r, w, act):
    """Each aperture's point where the line through its neighbours' centres crosses its plane,
    clipped to the rim: displaced toward the local turn."""
    N = C.shape[0]
    for j in range(N):
        p = a if j == 0 else C[j - 1]
        q = b if j == N - 1 else C[j + 1]
        n0 = E[j, 1, 0] * E[j, 2, 1] - E[j, 2, 0] * E[j, 1, 1]
        n1 = E[j, 2, 0] * E[j, 0, 1] - E[j, 0, 0] * E[j, 2, 1]
        n2 = E[j, 0, 0] * E[j, 1, 1] - E[j, 1, 0] * E[j, 0, 1]
        s = (n0 * (C[j, 0] - p[0]) + n1 * (C[j, 1] - p[1]) + n2 * (C[j, 2] - p[2])) / \
            (n0 * (q[0] - p[0]) + n1 * (q[1] - p[1]) + n2 * (q[2] - p[2]))
        h = _et(E, j, p[0] + s * (q[0] - p[0]) - C[j, 0], p[1] + s * (q[1] - p[1]) - C[j, 1],
                p[2] + s * (q[2] - p[2]) - C[j, 2])
        w[j, 0], w[j, 1] = _mv(_inv(_ete(E, j, j)), h)      # least squares: E need not be orthonormal
        act[j] = 0
    _onto_disc(w, act, r)


@numba.njit(**JIT)
def workspace(N):
    """The arrays one chain's Newton works in, allocated once per task, not per solve:
    segment lengths and directions (current and trial), the inverses of the Schur complements of
    the reduced diagonal blocks, the reduced couplings of j−1 (rows) and j (columns), the columns
    of w_j's directions (active: tangent, then the pinned radial), which reduced coordinates move,
    the gradient, the eliminated right-hand side, the step, the trial point and its active set."""
    return (np.empty(N + 1), np.empty((N + 1, 3)), np.empty(N + 1), np.empty((N + 1, 3)),
            np.empty((N, 4)), np.empty((N, 4)), np.empty((N, 4)), np.empty((N, 2)),
            np.empty((N, 2)), np.empty((N, 2)), np.empty((N, 2)), np.empty((N, 2)), np.empty(N, np.int8))


@numba.njit(**JIT)
def newton(a, b, C, E, r, w, act, tol, ws):
    """Projected Newton on one chain, in place on (w, act). Returns (length, converged)."""
    N = C.shape[0]
    l, t, lt, tt, Si, U, Q, keep, g, y, d, wt, at = ws
    F = _length(a, b, C, E, w, l, t)
    for _ in range(MAX_ITER):
        changed = 0
        be_prev = (0.0, 0.0)
        for j in range(N):
            al = _et(E, j, t[j, 0], t[j, 1], t[j, 2])              # E_j^T t_j
            be = _et(E, j, t[j + 1, 0], t[j + 1, 1], t[j + 1, 2])  # E_j^T t_{j+1}
            gj = (al[0] - be[0], al[1] - be[1])
            i0, i1 = 1.0 / l[j], 1.0 / l[j + 1]
            G = _ete(E, j, j)
            B = (G[0] * (i0 + i1) - al[0] * al[0] * i0 - be[0] * be[0] * i1,
                 G[1] * (i0 + i1) - al[0] * al[1] * i0 - be[0] * be[1] * i1,
                 G[2] * (i0 + i1) - al[1] * al[0] * i0 - be[1] * be[0] * i1,
                 G[3] * (i0 + i1) - al[1] * al[1] * i0 - be[1] * be[1] * i1)
            Qj = (1.0, 0.0, 0.0, 1.0)
            k0, k1, mu = 1.0, 1.0, 0.0
            if r[j] <= 0.0:
                k0, k1 = 0.0, 0.0
            elif act[j] != 0:
                rho = math.sqrt(w[j, 0] ** 2 + w[j, 1] ** 2)
                u0, u1 = w[j, 0] / rho, w[j, 1] / rho
                gu = gj[0] * u0 + gj[1] * u1
                if gu > 0.0:                    # the rim no longer pushes: release
                    act[j] = 0
                    changed += 1
                else:
                    Qj = (-u1, u0, u0, u1)
                    k1, mu = 0.0, -gu / r[j]
            Bq = _mm(_tr(Qj), _mm(B, Qj))
            gq = _mv(_tr(Qj), gj)
            Q[j, 0], Q[j, 1], Q[j, 2], Q[j, 3] = Qj
            keep[j, 0], keep[j, 1] = k0, k1
            g[j, 0], g[j, 1] = gq[0] * k0, gq[1] * k1
            A = (Bq[0] * k0 + mu * k0 + (1.0 - k0), Bq[1] * k0 * k1, Bq[2] * k0 * k1, Bq[3] * k1 + (1.0 - k1))
            y[j, 0], y[j, 1] = -g[j, 0], -g[j, 1]
            if j > 0:
                G = _ete(E, j - 1, j)
                Uj = (-(G[0] - be_prev[0] * al[0]) * i0, -(G[1] - be_prev[0] * al[1]) * i0,
                      -(G[2] - be_prev[1] * al[0]) * i0, -(G[3] - be_prev[1] * al[1]) * i0)
                Qp = (Q[j - 1, 0], Q[j - 1, 1], Q[j - 1, 2], Q[j - 1, 3])
                Uj = _mm(_tr(Qp), _mm(Uj, Qj))
                Uj = (Uj[0] * keep[j - 1, 0] * k0, Uj[1] * keep[j - 1, 0] * k1,
                      Uj[2] * keep[j - 1, 1] * k0, Uj[3] * keep[j - 1, 1] * k1)
                U[j, 0], U[j, 1], U[j, 2], U[j, 3] = Uj
                # forward elimination: A −= Uᵀ S⁻¹ U, y −= Uᵀ S⁻¹ y
                Sp = (Si[j - 1, 0], Si[j - 1, 1], Si[j - 1, 2], Si[j - 1, 3])
                X = _mm(Sp, Uj)
                Ut = _tr(Uj)
                R = _mm(Ut, X)
                A = (A[0] - R[0], A[1] - R[1], A[2] - R[2], A[3] - R[3])
                z = _mv(Ut, _mv(Sp, (y[j - 1, 0], y[j - 1, 1])))
                y[j, 0] -= z[0]
                y[j, 1] -= z[1]
            Si[j, 0], Si[j, 1], Si[j, 2], Si[j, 3] = _inv(A)
            be_prev = be
        dec = 0.0
        for j in range(N - 1, -1, -1):      # back substitution, and the step in w
            v = (y[j, 0], y[j, 1])
            if j < N - 1:
                z = _mv((U[j + 1, 0], U[j + 1, 1], U[j + 1, 2], U[j + 1, 3]), (d[j + 1, 0], d[j + 1, 1]))
                v = (v[0] - z[0], v[1] - z[1])
            e = _mv((Si[j, 0], Si[j, 1], Si[j, 2], Si[j, 3]), v)
            d[j, 0], d[j, 1] = e
            dec -= g[j, 0] * e[0] + g[j, 1] * e[1]
        for j in range(N):
            e = _mv((Q[j, 0], Q[j, 1], Q[j, 2], Q[j, 3]), (d[j, 0], d[j, 1]))
            d[j, 0], d[j, 1] = e
        step, ok, Ft = 1.0, False, F
        for _ls in range(LINE_SEARCH):
            for j in range(N):
                wt[j, 0] = w[j, 0] + step * d[j, 0]
                wt[j, 1] = w[j, 1] + step * d[j, 1]
                at[j] = act[j]
            _onto_disc(wt, at, r)
            Ft = _length(a, b, C, E, wt, lt, tt)
            if Ft <= F + F_SLACK:
                ok = True
                break
            step *= 0.5
        if not ok:
            return F, False
        for j in range(N):
            changed += at[j] != act[j]
            act[j] = at[j]
            w[j, 0], w[j, 1] = wt[j, 0], wt[j, 1]
        l, lt = lt, l
        t, tt = tt, t
        F = Ft
        if dec / 2 < tol and changed == 0:
            return F, True
    return F, False


# ---------------------------------------------------------------- the sweep (compiled, parallel)

@numba.njit(**JIT)
def _frame(y, kappa):
    """Disk frame at arc length y, eq. (1): cos, sin of κy and the origin (oy, oz)."""
    if kappa == 0.0:
        return 1.0, 0.0, y, 0.0
    th = kappa * y
    c, sn = math.cos(th), math.sin(th)
    # 1 − cos θ without cancellation: sin²θ / (1 + cos θ) while cos θ > 0
    return c, sn, sn / kappa, (sn * sn / (1.0 + c) if c > 0.0 else 1.0 - c) / kappa


@numba.njit(**JIT)
def _place(p, c, sn, oy, oz, out):
    """A point of a disk frame (local, y = 0 at its mid-plane) in robot coordinates."""
    out[0] = p[0]
    out[1] = c * p[1] - sn * p[2] + oy
    out[2] = sn * p[1] + c * p[2] + oz


@numba.njit(**dict(JIT, parallel=True))
def sweep_kernel(stations, kappas, up, down, C, E, r, hole_disk, dy, chain, anchor, end, tol, L, L0, bad):
    S, T, N, ND = C.shape[0], chain.shape[0], chain.shape[1], stations.shape[0]
    for s in numba.prange(S):
        fr = np.empty((ND, 4))
        ws = workspace(N)
        Cw, Ew, rr = np.empty((N, 3)), np.empty((N, 3, 2)), np.empty(N)
        aw, bw = np.empty(3), np.empty(3)
        W0, A0 = np.empty((T, N, 2)), np.empty((T, N), np.int8)
        W, Wp, A = np.empty((T, N, 2)), np.empty((T, N, 2)), np.empty((T, N), np.int8)
        for walk in range(3):                   # 0: θ = 0 (cold); 1: upward; 2: downward
            order = up if walk == 1 else down
            n_k = 1 if walk == 0 else order.shape[0]
            for ii in range(n_k):
                kap = 0.0 if walk == 0 else kappas[order[ii]]
                for i in range(ND):
                    fr[i, 0], fr[i, 1], fr[i, 2], fr[i, 3] = _frame(stations[i] + dy[s, i], kap)
                for tn in range(T):
                    for j in range(N):
                        h = chain[tn, j]
                        i = hole_disk[h]
                        _place(C[s, h], fr[i, 0], fr[i, 1], fr[i, 2], fr[i, 3], Cw[j])
                        for q in range(2):
                            Ew[j, 0, q] = E[s, h, 0, q]
                            Ew[j, 1, q] = fr[i, 0] * E[s, h, 1, q] - fr[i, 1] * E[s, h, 2, q]
                            Ew[j, 2, q] = fr[i, 1] * E[s, h, 1, q] + fr[i, 0] * E[s, h, 2, q]
                        rr[j] = r[s, h]
                    _place(anchor[s, tn], fr[0, 0], fr[0, 1], fr[0, 2], fr[0, 3], aw)
                    _place(end[s, tn], fr[ND - 1, 0], fr[ND - 1, 1], fr[ND - 1, 2], fr[ND - 1, 3], bw)
                    w, act = W[tn], A[tn]
                    if walk == 0:
                        cold_start(aw, bw, Cw, Ew, rr, w, act)
                    elif ii == 0:                 # first step out: from the straight pose
                        w[:] = W0[tn]
                        act[:] = A0[tn]
                        Wp[tn] = W0[tn]
                    else:                         # linear extrapolation of the last two angles
                        for j in range(N):
                            for q in range(2):
                                x = 2.0 * w[j, q] - Wp[tn, j, q]
                                Wp[tn, j, q] = w[j, q]
                                w[j, q] = x
                    _onto_disc(w, act, rr)
                    F, ok = newton(aw, bw, Cw, Ew, rr, w, act, TOL_REST if walk == 0 else tol, ws)
                    if not ok:
                        bad[s] += 1
                    if walk == 0:
                        L0[s, tn] = F
                        W0[tn] = w
                        A0[tn] = act
                    else:
                        L[s, tn, order[ii]] = F
