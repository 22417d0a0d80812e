"""Measure exported meshes: plane sections into closed loops, holes and their centres.

Used by the validation checks and by the tests; everything here starts from a file on disk
and the placement recorded in the manifest.
"""
from __future__ import annotations

import json
import math
import os
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path

import numpy as np

WELD_DECIMALS = 6   # section endpoints are welded after rounding to this many mm decimals


@dataclass(frozen=True)
class Loop:
    """A closed section loop in robot coordinates, projected onto the disk's (x, z) plane."""

    points: np.ndarray          # (n, 2) x, z
    area: float                 # unsigned, mm²
    centroid: tuple[float, float]

    @property
    def extent(self) -> tuple[float, float]:
        return tuple(self.points.max(axis=0) - self.points.min(axis=0))

    @property
    def equivalent_diameter(self) -> float:
        return float(2 * np.sqrt(self.area / np.pi))


_SHELF: ContextVar[dict | None] = ContextVar("hwgen_mesh_shelf", default=None)


@contextmanager
def one_load_per_mesh() -> Iterator[None]:
    """Within: every STL is read once (as long as its file is unchanged) and every mesh is turned
    into a manifold once per placement; each check gets the same objects, so none may change a
    mesh in place (copy it first). ``hwgen check`` runs all its checks inside one."""
    token = _SHELF.set({"meshes": {}, "manifolds": {}})
    try:
        yield
    finally:
        _SHELF.reset(token)


def load_mesh(path: str | Path):
    import trimesh
    shelf = _SHELF.get()
    if shelf is None:
        return trimesh.load_mesh(str(path), process=True)
    st = os.stat(path)
    key = (os.path.realpath(path), st.st_ino, st.st_size, st.st_mtime_ns)
    if key not in shelf["meshes"]:
        shelf["meshes"][key] = trimesh.load_mesh(str(path), process=True)
    return shelf["meshes"][key]


def chain_loops(segments: np.ndarray) -> list[np.ndarray]:
    """Chain (m, 2, d) line segments sharing endpoints into closed polylines."""
    keys = np.round(segments, WELD_DECIMALS)
    flat = keys.reshape(-1, keys.shape[-1])
    _, ids = np.unique(flat, axis=0, return_inverse=True)
    ids = ids.reshape(-1, 2)
    adj: dict[int, list[int]] = {}
    for s, (a, b) in enumerate(ids):
        if a == b:
            continue
        adj.setdefault(a, []).append(s)
        adj.setdefault(b, []).append(s)
    used = np.zeros(len(ids), bool)
    pts_of = {}
    for s, (a, b) in enumerate(ids):
        pts_of[a] = segments[s, 0]
        pts_of[b] = segments[s, 1]
    loops = []
    for start in range(len(ids)):
        if used[start] or ids[start, 0] == ids[start, 1]:
            continue
        used[start] = True
        first, cur = ids[start]
        chain = [first, cur]
        while cur != first:
            nxt = next((s for s in adj.get(cur, []) if not used[s]), None)
            if nxt is None:
                break  # open chain: not a closed loop, dropped
            used[nxt] = True
            a, b = ids[nxt]
            cur = b if a == cur else a
            chain.append(cur)
        if cur == first and len(chain) > 3:
            loops.append(np.array([pts_of[k] for k in chain[:-1]]))
    return loops


def signed_area(p: np.ndarray) -> float:
    """Area of a closed polygon (n, 2), positive when it winds counter-clockwise (shoelace)."""
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def area_centroid(p: np.ndarray) -> tuple[float, tuple[float, float]]:
    """Unsigned area and centroid of a closed polygon (n, 2)."""
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    a = cross.sum() / 2
    cx = ((x + xn) * cross).sum() / (6 * a)
    cy = ((y + yn) * cross).sum() / (6 * a)
    return abs(float(a)), (float(cx), float(cy))


def section_loops(mesh, placement: np.ndarray, origin, normal, axes=(0, 2)) -> list[Loop]:
    """Section a mesh (file coordinates) by a plane and return its closed loops, largest first.

    ``origin`` and ``normal`` are in file coordinates; the loops are mapped through
    ``placement`` and projected on the robot ``axes`` (default x and z: the disk plane).
    """
    import trimesh
    segs = trimesh.intersections.mesh_plane(mesh, plane_normal=normal, plane_origin=origin)
    if len(segs) == 0:
        return []
    h = np.c_[segs.reshape(-1, 3), np.ones(len(segs) * 2)] @ np.asarray(placement).T
    robot = h[:, :3].reshape(-1, 2, 3)
    out = []
    for loop in chain_loops(robot[:, :, list(axes)]):
        area, c = area_centroid(loop)
        out.append(Loop(loop, area, c))
    return sorted(out, key=lambda lp: -lp.area)


FLAT_NORMAL = 0.999999      # a face whose normal is this close to ±Z is flat in the file
FLAT_DECIMALS = 4           # flat faces are grouped by their Z rounded to this many mm decimals


def disk_slab(mesh) -> tuple[float, float]:
    """The file Z range of a disk's plate: between its largest face turned down and its largest
    face turned up. A hub standing on one face (or a seat plate's holes in the other) does not
    move these: the disk's two annular faces are by far its largest flat faces."""
    n = mesh.face_normals[:, 2]
    z = np.round(mesh.triangles_center[:, 2], FLAT_DECIMALS)
    area = mesh.area_faces
    out = []
    for sign in (-1, 1):
        sel = sign * n > FLAT_NORMAL
        levels, inv = np.unique(z[sel], return_inverse=True)
        out.append(float(levels[np.argmax(np.bincount(inv, weights=area[sel]))]))
    return out[0], out[1]


def section_robot(mesh, placement, axis: int, value: float) -> np.ndarray:
    """Cut a mesh (file coordinates) by the robot plane {axis = value}: (m, 2, 3) segments in robot
    coordinates."""
    import trimesh
    P = np.asarray(placement, dtype=float)
    R, t = P[:3, :3], P[:3, 3]
    e = np.zeros(3)
    e[axis] = 1.0
    normal = R.T @ e                                   # the plane's normal in the file
    origin = R.T @ (value * e - t)
    segs = trimesh.intersections.mesh_plane(mesh, plane_normal=normal, plane_origin=origin)
    if len(segs) == 0:
        return np.zeros((0, 2, 3))
    return (segs.reshape(-1, 3) @ R.T + t).reshape(-1, 2, 3)


@dataclass(frozen=True)
class DiskSection:
    """A disk cut at its mid-plane: the outline, the backbone slot and every hole."""

    outline: Loop
    inner: list[Loop]         # all inner loops: slot (possibly with merged eyelets) and holes
    thickness: float          # measured from the mesh along the disk normal
    y_mid: float              # robot y of the mid-plane


def disk_mid_section(stl_path: str | Path, placement) -> DiskSection:
    """Cut a disk file halfway through its plate (disk files lie flat: thickness along file Z)."""
    mesh = load_mesh(stl_path)
    zmin, zmax = disk_slab(mesh)
    mid = (zmin + zmax) / 2
    loops = section_loops(mesh, placement, [0, 0, mid], [0, 0, 1])
    y_mid = float((np.asarray(placement) @ [0, 0, mid, 1])[1])
    return DiskSection(loops[0], loops[1:], float(zmax - zmin), y_mid)


# ---------------------------------------------------------------- plane geometry

def num(v: float, digits: int = 3) -> str:
    """A coordinate for a message: fixed decimals, never "-0.000"."""
    t = f"{v:.{digits}f}"
    return t[1:] if t.startswith("-") and float(t) == 0 else t


def inside(poly: np.ndarray, pt) -> bool:
    """Point in polygon (even-odd rule) for a closed (n, 2) polyline."""
    x, y = float(pt[0]), float(pt[1])
    px, py = poly[:, 0], poly[:, 1]
    qx, qy = np.roll(px, -1), np.roll(py, -1)
    crosses = (py > y) != (qy > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = px + (y - py) * (qx - px) / (qy - py)
    return bool(np.count_nonzero(crosses & (x < xi)) % 2)


def inside_many(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Point in polygon (even-odd rule) for many points (n, 2) at once: (n,) bool."""
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    x, y = pts[:, 0:1], pts[:, 1:2]
    px, py = poly[None, :, 0], poly[None, :, 1]
    qx, qy = np.roll(px, -1, axis=1), np.roll(py, -1, axis=1)
    crosses = (py > y) != (qy > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = px + (y - py) * (qx - px) / (qy - py)
    return (np.count_nonzero(crosses & (x < xi), axis=1) % 2).astype(bool)


def _point_segment_distance(pts: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) distance from each point to the nearest of the segments a[i]-b[i]."""
    ab = b - a
    ll = np.einsum("ij,ij->i", ab, ab)
    ll = np.where(ll == 0, 1.0, ll)
    ap = pts[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("nmj,mj->nm", ap, ab) / ll, 0.0, 1.0)
    d = ap - t[..., None] * ab[None]
    return np.sqrt(np.einsum("nmj,nmj->nm", d, d)).min(axis=1)


def points_to_polyline(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance from each point (n, 2) to a closed polyline (m, 2): (n,)."""
    return _point_segment_distance(pts, poly, np.roll(poly, -1, axis=0))


def _one_side(pts: np.ndarray, poly: np.ndarray, bound: float) -> float:
    """Closest distance from the vertices ``pts`` to the closed polyline ``poly``, knowing it is
    at most ``bound``: only points and segments within reach of each other are compared."""
    lo, hi = poly.min(axis=0) - bound, poly.max(axis=0) + bound
    P = pts[np.all((pts >= lo) & (pts <= hi), axis=1)]
    if len(P) == 0:
        return float("inf")
    a, b = poly, np.roll(poly, -1, axis=0)
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
        un, vn = np.roll(u, -1), np.roll(v, -1)
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


# ---------------------------------------------------------------- solids

def to_manifold(mesh, placement=None):
    """A trimesh mesh (file coordinates) as a manifold3d solid, in robot coordinates under ``placement``."""
    shelf = _SHELF.get()
    if shelf is None:
        return _to_manifold(mesh, placement)
    key = (id(mesh), None if placement is None else np.asarray(placement, dtype=float).tobytes())
    if key not in shelf["manifolds"]:
        shelf["manifolds"][key] = (mesh, _to_manifold(mesh, placement))      # the mesh kept: its id stays its own
    return shelf["manifolds"][key][1]


def _to_manifold(mesh, placement=None):
    import manifold3d as m3d
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if placement is not None:
        P = np.asarray(placement, dtype=float)
        v = v @ P[:3, :3].T + P[:3, 3]
    return m3d.Manifold(m3d.Mesh(vert_properties=v.astype(np.float32),
                                 tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))


def read_manifest(folder: str | Path) -> dict:
    return json.loads((Path(folder) / "manifest.json").read_text())


# ---------------------------------------------------------------- axes of turned parts

AXIS_BAND_MM = (0.05, 0.01)   # crest vertices: within this of the largest radius, first pass then second


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
    vertices on the true surface) are fitted by a cylinder in least squares, twice."""
    from scipy.optimize import least_squares
    comp = np.asarray(mesh.principal_inertia_components, dtype=float)
    vecs = np.asarray(mesh.principal_inertia_vectors, dtype=float)

    def spread(i):
        a, b = (comp[j] for j in range(3) if j != i)
        return abs(a - b) / max(a, b)
    d = vecs[min(range(3), key=spread)]
    d = d / np.linalg.norm(d)
    c = np.asarray(mesh.center_mass, dtype=float)
    v = np.asarray(mesh.vertices, dtype=float)
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


# ---------------------------------------------------------------- distance to a surface

def closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Closest points on triangles (a, b, c) to points p, all (n, 3): the Voronoi regions of
    the triangle's vertices, edges and face (Ericson, Real-Time Collision Detection §5.1.5)."""
    ab, ac = b - a, c - a
    d1, d2 = np.einsum("ij,ij->i", ab, p - a), np.einsum("ij,ij->i", ac, p - a)
    d3, d4 = np.einsum("ij,ij->i", ab, p - b), np.einsum("ij,ij->i", ac, p - b)
    d5, d6 = np.einsum("ij,ij->i", ab, p - c), np.einsum("ij,ij->i", ac, p - c)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    den = va + vb + vc
    den = np.where(np.abs(den) < 1e-300, 1e-300, den)
    out = a + ab * (vb / den)[:, None] + ac * (vc / den)[:, None]

    def safe(x, y):
        return x / np.where(y == 0, 1, y)
    out = np.where(((vc <= 0) & (d1 >= 0) & (d3 <= 0))[:, None], a + ab * safe(d1, d1 - d3)[:, None], out)
    out = np.where(((vb <= 0) & (d2 >= 0) & (d6 <= 0))[:, None], a + ac * safe(d2, d2 - d6)[:, None], out)
    out = np.where(((va <= 0) & (d4 >= d3) & (d5 >= d6))[:, None],
                   b + (c - b) * safe(d4 - d3, (d4 - d3) + (d5 - d6))[:, None], out)
    out = np.where(((d1 <= 0) & (d2 <= 0))[:, None], a, out)
    out = np.where(((d3 >= 0) & (d4 <= d3))[:, None], b, out)
    return np.where(((d6 >= 0) & (d5 <= d6))[:, None], c, out)


class SurfaceDistance:
    """Exact signed distance from points to a closed triangle mesh (negative inside).

    Triangles are split until no edge exceeds ``max_edge`` and sorted by size into buckets,
    each with a k-d tree of centroids and its reach (largest centroid-to-corner distance).
    The exact closest points on the k nearest triangles of every bucket bound the distance d
    from above; a triangle that could be closer has its centroid within d + reach, so a bucket
    whose k-th centroid is nearer than that is asked again with 4k, until nothing can be missed."""

    SIZES = (0.01, 0.03, 0.1, 0.3)     # bucket limits of a triangle's reach, mm

    def __init__(self, mesh, k: int = 4, max_edge: float = 0.5):
        import trimesh
        from scipy.spatial import cKDTree
        v, f, idx = trimesh.remesh.subdivide_to_size(np.asarray(mesh.vertices), np.asarray(mesh.faces),
                                                     max_edge=max_edge, max_iter=20, return_index=True)
        self.tri = v[f]
        self.normals = np.asarray(mesh.face_normals, dtype=float)[idx]
        cen = self.tri.mean(axis=1)
        reach = np.linalg.norm(self.tri - cen[:, None, :], axis=2).max(axis=1)
        edges = (-1.0, *self.SIZES, np.inf)
        self.buckets = []
        for lo, hi in zip(edges[:-1], edges[1:]):
            sel = np.flatnonzero((reach > lo) & (reach <= hi))
            if len(sel):
                self.buckets.append((sel, cKDTree(cen[sel]), float(reach[sel].max())))
        self.k = k

    def _exact(self, points: np.ndarray, idx: np.ndarray):
        n, k = idx.shape
        rep = np.repeat(points, k, axis=0)
        t = self.tri[idx.ravel()]
        q = closest_on_triangles(rep, t[:, 0], t[:, 1], t[:, 2])
        d2 = np.einsum("ij,ij->i", rep - q, rep - q).reshape(n, k)
        j = np.argmin(d2, axis=1)
        rows = np.arange(n)
        return np.sqrt(d2[rows, j]), idx[rows, j], q.reshape(n, k, 3)[rows, j]

    def __call__(self, points: np.ndarray, max_dist: float | None = None) -> np.ndarray:
        """Signed distances; with ``max_dist``, points certainly farther get a lower bound of
        their distance (counted as outside)."""
        points = np.asarray(points, dtype=float)
        n = len(points)
        dist, best, close = np.full(n, np.inf), np.zeros(n, int), points.copy()
        todo = np.arange(n)
        if max_dist is not None:
            lower = np.full(n, np.inf)
            for sel, tree, reach in self.buckets:
                lower = np.minimum(lower, tree.query(points, k=1)[0] - reach)
            far = lower > max_dist
            dist[far] = lower[far]
            todo = np.flatnonzero(~far)
        pts = points[todo]
        pending = []
        for sel, tree, reach in self.buckets:
            k = min(self.k, len(sel))
            dk, ii = tree.query(pts, k=k)
            dk, ii = dk.reshape(len(pts), -1), ii.reshape(len(pts), -1)
            d, b, q = self._exact(pts, sel[ii])
            better = d < dist[todo]
            dist[todo[better]], best[todo[better]], close[todo[better]] = d[better], b[better], q[better]
            pending.append((sel, tree, reach, k, dk[:, -1]))
        for sel, tree, reach, k, kth in pending:
            again = np.flatnonzero(kth < dist[todo] + reach) if k < len(sel) else np.zeros(0, int)
            while len(again):
                k = min(4 * k, len(sel))
                dk, ii = tree.query(pts[again], k=k)
                dk, ii = dk.reshape(len(again), -1), ii.reshape(len(again), -1)
                d, b, q = self._exact(pts[again], sel[ii])
                t = todo[again]
                better = d < dist[t]
                dist[t[better]], best[t[better]], close[t[better]] = d[better], b[better], q[better]
                if k >= len(sel):
                    break
                again = again[dk[:, -1] < dist[todo[again]] + reach]
        inside = np.einsum("ij,ij->i", points - close, self.normals[best]) < 0
        return np.where(inside & np.isfinite(dist) & (dist >= 0), -dist, dist)


def sample_surface(mesh, spacing: float, mask: np.ndarray | None = None, seed: int = 0):
    """About one point per spacing² of area on the chosen faces, area-uniform and
    deterministic for a seed: (points (n, 3), their faces' normals)."""
    faces = np.arange(len(mesh.faces)) if mask is None else np.flatnonzero(mask)
    area = mesh.area_faces[faces]
    n = max(1, int(area.sum() / spacing ** 2))
    rng = np.random.default_rng(seed)
    pick = faces[rng.choice(len(faces), size=n, p=area / area.sum())]
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    tri = np.asarray(mesh.triangles)[pick]
    pts = tri[:, 0] + (tri[:, 1] - tri[:, 0]) * u[:, None] + (tri[:, 2] - tri[:, 0]) * v[:, None]
    return pts, np.asarray(mesh.face_normals)[pick]
