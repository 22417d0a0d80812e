"""Plane geometry of closed polylines (n, 2): area and centroid, point in polygon, distances
between loops, second moments of a section; and coordinates written for messages."""
from __future__ import annotations

import numpy as np


def num(v: float, digits: int = 3) -> str:
    """A coordinate for a message: fixed decimals, never "-0.000"."""
    t = f"{v:.{digits}f}"
    return t[1:] if t.startswith("-") and float(t) == 0 else t


def _after(v: np.ndarray, axis: int = 0) -> np.ndarray:
    """Each vertex's successor around the loop, as ``np.roll(v, -1, axis)`` gives it (the same
    new array, without np.roll's general handling)."""
    if axis == 0:
        return np.concatenate((v[1:], v[:1]))
    return np.concatenate((v[:, 1:], v[:, :1]), axis=1)


def signed_area(p: np.ndarray) -> float:
    """Area of a closed polygon (n, 2), positive when it winds counter-clockwise (shoelace)."""
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, _after(y)) - np.dot(y, _after(x)))


def area_centroid(p: np.ndarray) -> tuple[float, tuple[float, float]]:
    """Unsigned area and centroid of a closed polygon (n, 2)."""
    x, y = p[:, 0], p[:, 1]
    xn, yn = _after(x), _after(y)
    cross = x * yn - xn * y
    a = cross.sum() / 2
    cx = ((x + xn) * cross).sum() / (6 * a)
    cy = ((y + yn) * cross).sum() / (6 * a)
    return abs(float(a)), (float(cx), float(cy))


def inside(poly: np.ndarray, pt) -> bool:
    """Point in polygon (even-odd rule) for a closed (n, 2) polyline."""
    x, y = float(pt[0]), float(pt[1])
    px, py = poly[:, 0], poly[:, 1]
    qx, qy = _after(px), _after(py)
    crosses = (py > y) != (qy > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = px + (y - py) * (qx - px) / (qy - py)
    return bool(np.count_nonzero(crosses & (x < xi)) % 2)


def inside_many(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Point in polygon (even-odd rule) for many points (n, 2) at once: (n,) bool."""
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    x, y = pts[:, 0:1], pts[:, 1:2]
    px, py = poly[None, :, 0], poly[None, :, 1]
    qx, qy = _after(px, 1), _after(py, 1)
    crosses = (py > y) != (qy > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = px + (y - py) * (qx - px) / (qy - py)
    return (np.count_nonzero(crosses & (x < xi), axis=1) % 2).astype(bool)


def _point_segment_distance(pts: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) distance from each point to the nearest of the segments a[i]-b[i]. Written out per
    coordinate (plain products and sums, no (n, m, 2) temporaries), the same arithmetic in the
    same order as the dot products it stands for."""
    ab = b - a
    ax, ay = ab[:, 0], ab[:, 1]
    ll = ax * ax + ay * ay
    ll = np.where(ll == 0, 1.0, ll)
    apx = pts[:, 0:1] - a[None, :, 0]
    apy = pts[:, 1:2] - a[None, :, 1]
    t = np.clip((apx * ax + apy * ay) / ll, 0.0, 1.0)
    dx = apx - t * ax
    dy = apy - t * ay
    return np.sqrt(dx * dx + dy * dy).min(axis=1)


def points_to_polyline(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance from each point (n, 2) to a closed polyline (m, 2): (n,)."""
    return _point_segment_distance(pts, poly, _after(poly))


def _one_side(pts: np.ndarray, poly: np.ndarray, bound: float) -> float:
    """Closest distance from the vertices ``pts`` to the closed polyline ``poly``, knowing it is
    at most ``bound``: only points and segments within reach of each other are compared."""
    lo, hi = poly.min(axis=0) - bound, poly.max(axis=0) + bound
    P = pts[np.all((pts >= lo) & (pts <= hi), axis=1)]
    if len(P) == 0:
        return float("inf")
    a, b = poly, _after(poly)
    reach = bound + float(np.sqrt(((b - a) ** 2).sum(axis=1)).max())
    plo, phi = P.min(axis=0) - reach, P.max(axis=0) + reach
    keep = np.all((a >= plo) & (a <= phi), axis=1)
    if not keep.any():
        return float("inf")
    return float(_point_segment_distance(P, a[keep], b[keep]).min())


def loop_gap(a: np.ndarray, b: np.ndarray) -> float:
    """Closest distance between two closed polylines (material between two holes' edges).

    Exact: the closest pair of two polylines that do not cross always has a vertex of one of
    them at one end, so both vertex sets are measured against the other polyline. A pair of
    vertices gives an upper bound first, which prunes everything out of reach.
    """
    k = int(np.argmin(((a - b.mean(axis=0)) ** 2).sum(axis=1)))
    j = int(np.argmin(((b - a[k]) ** 2).sum(axis=1)))
    bound = float(np.hypot(*(a[k] - b[j])))
    return min(bound, _one_side(a, b, bound), _one_side(b, a, bound))


def section_moments(loops: list[np.ndarray]) -> dict:
    """Area, centroid and second moments of the material bounded by closed (u, v) loops, nested by
    the even-odd rule (a loop inside an odd number of others is a hole): ``i_v0`` = ∫ v² dA about
    v = 0, ``i_vc`` = ∫ (v - v̄)² dA about the centroid, mm⁴."""
    area = su = sv = svv = 0.0
    for k, lp in enumerate(loops):
        depth = sum(inside(o, lp[0]) for j, o in enumerate(loops) if j != k)
        u, v = lp[:, 0], lp[:, 1]
        un, vn = _after(u), _after(v)
        cross = u * vn - un * v
        a = cross.sum() / 2
        sign = (-1.0 if depth % 2 else 1.0) * np.sign(a)      # material counts positive whatever the winding
        area += sign * a
        su += sign * float(((u + un) * cross).sum() / 6)
        sv += sign * float(((v + vn) * cross).sum() / 6)
        svv += sign * float((cross * (v * v + v * vn + vn * vn)).sum() / 12)
    if area <= 0:
        return {"area": 0.0, "cu": 0.0, "cv": 0.0, "i_v0": 0.0, "i_vc": 0.0}
    cu, cv = su / area, sv / area
    return {"area": float(area), "cu": float(cu), "cv": float(cv), "i_v0": float(svv),
            "i_vc": float(svv - area * cv * cv)}
