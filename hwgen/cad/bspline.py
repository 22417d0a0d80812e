"""Bicubic B-spline surfaces that interpolate a grid of points (numpy for the system, OCCT for
the surface): the generated wheel's tooth-space flanks."""
from __future__ import annotations

import numpy as np
from OCP.Geom import Geom_BSplineSurface
from OCP.gp import gp_Pnt
from OCP.TColgp import TColgp_Array2OfPnt
from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal

BSPLINE_DEGREE = 3


def _knots(t: np.ndarray, degree: int) -> np.ndarray:
    """Clamped knot vector for interpolation at parameters t (de Boor's averaging)."""
    inner = [float(np.mean(t[j:j + degree])) for j in range(1, len(t) - degree)]
    return np.concatenate([np.zeros(degree + 1), inner, np.ones(degree + 1)])


def _basis(knots: np.ndarray, degree: int, t: np.ndarray) -> np.ndarray:
    """(len(t), n) B-spline basis functions at t (Cox-de Boor), the last knot span closed."""
    spans = len(knots) - 1
    N = np.zeros((len(t), spans))
    for i in range(spans):
        if knots[i] < knots[i + 1]:
            N[:, i] = (t >= knots[i]) & (t < knots[i + 1])
    last = max(i for i in range(spans) if knots[i] < knots[i + 1])
    N[t >= knots[-1]] = 0.0
    N[t >= knots[-1], last] = 1.0
    for k in range(1, degree + 1):
        M = np.zeros((len(t), spans - k))
        for i in range(spans - k):
            d1, d2 = knots[i + k] - knots[i], knots[i + k + 1] - knots[i + 1]
            M[:, i] = ((t - knots[i]) / d1 * N[:, i] if d1 > 0 else 0.0) + \
                      ((knots[i + k + 1] - t) / d2 * N[:, i + 1] if d2 > 0 else 0.0)
        N = M
    return N[:, :len(knots) - degree - 1]


def _occ_knots(knots: np.ndarray):
    vals, mult = np.unique(np.round(knots, 12), return_counts=True)
    k, m = TColStd_Array1OfReal(1, len(vals)), TColStd_Array1OfInteger(1, len(vals))
    for i, (x, c) in enumerate(zip(vals, mult)):
        k.SetValue(i + 1, float(x))
        m.SetValue(i + 1, int(c))
    return k, m


def interpolating_surface(P: np.ndarray, u: np.ndarray, v: np.ndarray):
    """Bicubic B-spline surface through the grid P (nu, nv, 3) at parameters u × v (poles
    solved with numpy: OCCT's own lofts re-approximate to degree 5 and cut 6× slower)."""
    d = BSPLINE_DEGREE
    ku, kv = _knots(u, d), _knots(v, d)
    nu, nv = len(u), len(v)
    C = np.linalg.solve(_basis(ku, d, u), P.reshape(nu, -1)).reshape(nu, nv, 3)
    C = np.linalg.solve(_basis(kv, d, v), C.transpose(1, 0, 2).reshape(nv, -1)).reshape(nv, nu, 3).transpose(1, 0, 2)
    poles = TColgp_Array2OfPnt(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            poles.SetValue(i + 1, j + 1, gp_Pnt(*map(float, C[i, j])))
    (uk, um), (vk, vm) = _occ_knots(ku), _occ_knots(kv)
    return Geom_BSplineSurface(poles, uk, vk, um, vm, d, d)

