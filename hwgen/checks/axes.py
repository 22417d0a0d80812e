"""Axes of turned parts (worm, wheel) fitted to their meshes, and how two axes lie."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

AXIS_BAND_MM = (0.05, 0.01)   # crest vertices: within this of the largest radius, first pass then second
CREST_MIN_MM = 0.5            # a crest narrower than this along the axis found (a ring) does not fix the axis's tilt
NORMAL_BIN = 0.005            # triangles' normals binned this finely (about 0.3°) to find a part's largest flat area


def across(direction: np.ndarray) -> np.ndarray:
    """A unit vector square to ``direction`` (a unit vector): its cross product with x, or with
    y when it lies close to x."""
    v = np.cross(direction, [1.0, 0.0, 0.0] if abs(direction[0]) < 0.9 else [0.0, 1.0, 0.0])
    return v / np.linalg.norm(v)


@dataclass(frozen=True)
class Axis:
    """The rotation axis of a toothed or threaded part, fitted to its mesh (robot mm)."""

    point: np.ndarray          # on the axis: the foot of the part's centroid
    direction: np.ndarray      # unit vector
    radius: float              # of the crest cylinder fitted (tooth tips, thread crest)
    rms: float                 # RMS residual of that fit, mm
    crest: tuple[float, float]  # range of the crest vertices along the axis, from ``point``

    def radial(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(distance from the axis, position along it) of points (n, 3)."""
        rel = np.asarray(points, dtype=float) - self.point
        along = rel @ self.direction
        return np.linalg.norm(rel - np.outer(along, self.direction), axis=1), along

    def frame(self) -> np.ndarray:
        """4×4 taking robot coordinates into a frame whose Z is this axis, origin at ``point``."""
        z = self.direction
        x = across(z)
        m = np.eye(4)
        m[:3, :3] = np.vstack([x, np.cross(z, x), z])
        m[:3, 3] = -m[:3, :3] @ self.point
        return m

    def rotation(self, angle: float) -> np.ndarray:
        """4×4 rotation by ``angle`` (rad, right hand about ``direction``) about this axis line."""
        d = self.direction
        k = np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])
        r = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)
        m = np.eye(4)
        m[:3, :3] = r
        m[:3, 3] = self.point - r @ self.point
        return m


def fit_axis(mesh) -> Axis:
    """The axis of a turned part from its surface alone. First guess: the principal axis of
    inertia whose two companion moments agree best (a part with 3-fold or higher symmetry).
    Then the vertices at the largest radius (tooth tips, thread crest: tessellation puts
    vertices on the true surface) are fitted by a cylinder in least squares, twice. A part whose
    three moments nearly agree (a wheel as long as it is wide) has no good principal axis: a guess
    off by degrees finds its crest as a thin ring, whose cylinder fit cannot tell the axis's tilt.
    Where the crest spans less than :data:`CREST_MIN_MM` along the axis found, the fit starts
    again from the normal of the part's largest flat area (its faces and shoulders are square to
    its axis), and the fit whose crest spans more is kept."""
    v = np.asarray(mesh.vertices, dtype=float)
    c = np.asarray(mesh.center_mass, dtype=float)
    got = _crest_fit(v, c, _principal_guess(mesh))
    if got.crest[1] - got.crest[0] < CREST_MIN_MM:
        again = _crest_fit(v, c, _flat_normal(mesh))
        if again.crest[1] - again.crest[0] > got.crest[1] - got.crest[0]:
            return again
    return got


def _principal_guess(mesh) -> np.ndarray:
    comp = np.asarray(mesh.principal_inertia_components, dtype=float)
    vecs = np.asarray(mesh.principal_inertia_vectors, dtype=float)

    def spread(i):
        a, b = (comp[j] for j in range(3) if j != i)
        return abs(a - b) / max(a, b)
    d = vecs[min(range(3), key=spread)]
    return d / np.linalg.norm(d)


def _flat_normal(mesh) -> np.ndarray:
    """The normal of the largest flat area of a mesh: its triangles' normals (folded onto one
    hemisphere) binned at :data:`NORMAL_BIN`, the bin of most area, its area-weighted mean."""
    n = np.asarray(mesh.face_normals, dtype=float)
    area = np.asarray(mesh.area_faces, dtype=float)
    n = np.where((n @ np.array([0.27, 0.53, 0.80]))[:, None] < 0, -n, n)
    _, inverse = np.unique(np.round(n / NORMAL_BIN).astype(np.int64), axis=0, return_inverse=True)
    inverse = inverse.ravel()
    pick = inverse == np.bincount(inverse, weights=area).argmax()
    d = (n[pick] * area[pick, None]).sum(axis=0)
    return d / np.linalg.norm(d)


def _crest_fit(v: np.ndarray, c: np.ndarray, d: np.ndarray) -> Axis:
    """The cylinder through the vertices ``v`` at the largest radius about an axis first guessed
    along ``d`` through the centre of mass ``c``, in least squares (:data:`AXIS_BAND_MM`)."""
    from scipy.optimize import least_squares
    p, r, rms = c, 0.0, math.inf
    for band in AXIS_BAND_MM:
        rad = Axis(p, d, 0.0, 0.0, (0.0, 0.0)).radial(v)[0]
        sel = v[rad >= rad.max() - band]
        e1 = across(d)
        e2 = np.cross(d, e1)

        def unpack(x, p=p, d=d, e1=e1, e2=e2):
            dd = d + x[2] * e1 + x[3] * e2
            return p + x[0] * e1 + x[1] * e2, dd / np.linalg.norm(dd), x[4]

        def residual(x):
            q, dd, rr = unpack(x)
            return Axis(q, dd, 0.0, 0.0, (0.0, 0.0)).radial(sel)[0] - rr
        sol = least_squares(residual, [0, 0, 0, 0, float(rad.max())], x_scale=[0.1, 0.1, 0.01, 0.01, 1.0])
        p, d, r = unpack(sol.x)
        rms = float(np.sqrt(np.mean(sol.fun ** 2)))
    p = p + ((c - p) @ d) * d
    along = Axis(p, d, r, rms, (0.0, 0.0)).radial(sel)[1]
    return Axis(p, d, float(r), rms, (float(along.min()), float(along.max())))


def axes_distance(a: Axis, b: Axis) -> float:
    """Length of the common perpendicular of two axes (parallel axes: their distance)."""
    n = np.cross(a.direction, b.direction)
    w = b.point - a.point
    if np.linalg.norm(n) < 1e-9:
        return float(np.linalg.norm(w - (w @ a.direction) * a.direction))
    return float(abs(w @ n) / np.linalg.norm(n))


def axes_angle(a: Axis, b: Axis) -> float:
    """Angle between two axes, deg (0..90)."""
    return math.degrees(math.acos(min(1.0, abs(float(a.direction @ b.direction)))))
