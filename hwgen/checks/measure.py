"""Measure exported meshes: plane sections into closed loops, holes and their centres.

Used by the validation checks and by the tests; everything here starts from a file on disk
and the placement recorded in the manifest.
"""
from __future__ import annotations

import json
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


def load_mesh(path: str | Path):
    import trimesh
    return trimesh.load_mesh(str(path), process=True)


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
    import manifold3d as m3d
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if placement is not None:
        P = np.asarray(placement, dtype=float)
        v = v @ P[:3, :3].T + P[:3, 3]
    return m3d.Manifold(m3d.Mesh(vert_properties=v.astype(np.float32),
                                 tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))


def read_manifest(folder: str | Path) -> dict:
    return json.loads((Path(folder) / "manifest.json").read_text())
