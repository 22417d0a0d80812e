"""Plane sections of exported meshes: closed loops in robot coordinates, a disk's plate and its
mid-plane section (outline, slot, holes). Everything starts from a file on disk and the placement
recorded in the manifest."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .meshes import load_mesh
from .polygons import area_centroid

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


def chain_loops(segments: np.ndarray) -> list[np.ndarray]:
    """Chain (m, 2, d) line segments sharing endpoints into closed polylines.

    Endpoints are welded by their coordinates rounded to ``WELD_DECIMALS``; a welded point is
    given the coordinates of its last occurrence among the segments' ends. Each loop starts at
    the first segment not yet used and goes on, at each point, by its lowest-numbered unused
    segment; a chain that does not close is dropped."""
    keys = np.round(segments, WELD_DECIMALS)
    flat = np.ascontiguousarray(keys.reshape(-1, keys.shape[-1]))
    if flat.shape[1] == 2 and flat.dtype == np.float64:   # (x, z) as complex: one sort of plain values, same order
        _, ids = np.unique(flat.view(np.complex128)[:, 0], return_inverse=True)
    else:
        _, ids = np.unique(flat, axis=0, return_inverse=True)
    ids = ids.reshape(-1)
    n_ends = len(ids)
    # each welded point's last occurrence among the ends (segment s's ends are 2s and 2s + 1)
    last_end = np.full(int(ids.max()) + 1 if n_ends else 0, -1, dtype=np.intp)
    np.maximum.at(last_end, ids, np.arange(n_ends))
    ends = segments.reshape(n_ends, segments.shape[-1])
    pairs = ids.reshape(-1, 2).tolist()      # plain ints: the walk below is Python
    adj: list[list[int]] = [[] for _ in range(len(last_end))]     # each point's segments, in order
    for s, (a, b) in enumerate(pairs):
        if a != b:
            adj[a].append(s)
            adj[b].append(s)
    used = [False] * len(pairs)
    loops = []
    for start, (first, cur) in enumerate(pairs):
        if used[start] or first == cur:
            continue
        used[start] = True
        chain = [first, cur]
        while cur != first:
            for nxt in adj[cur]:
                if not used[nxt]:
                    break
            else:
                break  # open chain: not a closed loop, dropped
            used[nxt] = True
            a, b = pairs[nxt]
            cur = b if a == cur else a
            chain.append(cur)
        if cur == first and len(chain) > 3:
            loops.append(ends[last_end[chain[:-1]]])
    return loops


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
