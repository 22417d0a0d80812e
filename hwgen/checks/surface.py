"""Distance from points to a closed triangle mesh, exact and signed, and points sampled on a
mesh's surface."""
from __future__ import annotations

import numpy as np


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
        """Signed distances; with ``max_dist``, points certainly that far or farther get max_dist
        itself, a lower bound of their distance (counted as outside)."""
        points = np.asarray(points, dtype=float)
        n = len(points)
        dist, best, close = np.full(n, np.inf), np.zeros(n, int), points.copy()
        todo = np.arange(n)
        if max_dist is not None:
            # a point with no bucket's centroid nearer than max_dist + that bucket's reach is at least
            # max_dist from every triangle; the k-d trees stop looking beyond that
            far = np.ones(n, bool)
            for sel, tree, reach in self.buckets:
                far &= np.isinf(tree.query(points, k=1, distance_upper_bound=max_dist + reach)[0])
            dist[far] = max_dist
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
