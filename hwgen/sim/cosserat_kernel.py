"""The compiled part of :mod:`.cosserat` (numba): the classical RK4 of the static Cosserat rod over
one flexible stretch, for a batch of states at once.

A state is 13 numbers: p (3), the frame as a unit quaternion (w, x, y, z), n (3), m (3); see
:mod:`.cosserat` for the equations. Nothing is allocated inside the step loop.
"""
from __future__ import annotations

import numba
import numpy as np

JIT = dict(cache=True, nogil=True, error_model="numpy")   # no fastmath: results the same compiled or cached


@numba.njit(**JIT)
def _rhs(y, out, bending, shear, f):
    """d/ds of the state y (13,) into out (13,)."""
    w, x, yq, z = y[3], y[4], y[5], y[6]
    r00, r01, r02 = 1 - 2 * (yq * yq + z * z), 2 * (x * yq - w * z), 2 * (x * z + w * yq)
    r10, r11, r12 = 2 * (x * yq + w * z), 1 - 2 * (x * x + z * z), 2 * (yq * z - w * x)
    r20, r21, r22 = 2 * (x * z - w * yq), 2 * (yq * z + w * x), 1 - 2 * (x * x + yq * yq)
    n0, n1, n2, m0, m1, m2 = y[7], y[8], y[9], y[10], y[11], y[12]
    # local n, m: R^T n
    ln0, ln1, ln2 = r00 * n0 + r10 * n1 + r20 * n2, r01 * n0 + r11 * n1 + r21 * n2, r02 * n0 + r12 * n1 + r22 * n2
    lm0, lm1, lm2 = r00 * m0 + r10 * m1 + r20 * m2, r01 * m0 + r11 * m1 + r21 * m2, r02 * m0 + r12 * m1 + r22 * m2
    v0, v1, v2 = ln0 / shear[0], 1.0 + ln1 / shear[1], ln2 / shear[2]
    u0, u1, u2 = lm0 / bending[0], lm1 / bending[1], lm2 / bending[2]
    dp0 = r00 * v0 + r01 * v1 + r02 * v2
    dp1 = r10 * v0 + r11 * v1 + r12 * v2
    dp2 = r20 * v0 + r21 * v1 + r22 * v2
    out[0], out[1], out[2] = dp0, dp1, dp2
    out[3] = -0.5 * (x * u0 + yq * u1 + z * u2)
    out[4] = 0.5 * (w * u0 + yq * u2 - z * u1)
    out[5] = 0.5 * (w * u1 + z * u0 - x * u2)
    out[6] = 0.5 * (w * u2 + x * u1 - yq * u0)
    out[7], out[8], out[9] = -f[0], -f[1], -f[2]
    out[10] = -(dp1 * n2 - dp2 * n1)
    out[11] = -(dp2 * n0 - dp0 * n2)
    out[12] = -(dp0 * n1 - dp1 * n0)


@numba.njit(**JIT)
def rk4(Y, length, steps, bending, shear, f, path):
    """Integrate every row of Y (B, 13) over ``length`` mm in ``steps`` RK4 steps, in place;
    ``path`` (steps, 3) gets row 0's centre line after each step."""
    h = length / steps
    k1, k2, k3, k4 = np.empty(13), np.empty(13), np.empty(13), np.empty(13)
    tmp = np.empty(13)
    for b in range(Y.shape[0]):
        y = Y[b]
        for s in range(steps):
            _rhs(y, k1, bending, shear, f)
            for i in range(13):
                tmp[i] = y[i] + 0.5 * h * k1[i]
            _rhs(tmp, k2, bending, shear, f)
            for i in range(13):
                tmp[i] = y[i] + 0.5 * h * k2[i]
            _rhs(tmp, k3, bending, shear, f)
            for i in range(13):
                tmp[i] = y[i] + h * k3[i]
            _rhs(tmp, k4, bending, shear, f)
            for i in range(13):
                y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            norm = np.sqrt(y[3] * y[3] + y[4] * y[4] + y[5] * y[5] + y[6] * y[6])
            for i in range(3, 7):
                y[i] /= norm
            if b == 0:
                path[s, 0], path[s, 1], path[s, 2] = y[0], y[1], y[2]
