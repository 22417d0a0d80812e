"""The scene the pictures are drawn from, as numpy: every part's STL placed by its manifest
placement, each family's colour, and the poses (assembled, exploded, bent by eq. (1)).

Everything starts from the files in ``out/<design>/``: each part's STL, placed in robot
coordinates by the placement the manifest records, coloured by its family (the manifest
``role``). Nothing here knows how a part was built, so a new family appears in the pictures
as soon as it is in the manifest.

Each family keeps its manifest colour unless it could be taken for another family's once
lit (:func:`confusable`); then it gets the next colour of FAMILY_PALETTE that cannot.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..cad.manifest import Manifest, ManifestPart, manifest_parts
from ..checks.meshes import part_meshes
from ..model import kinematics as kin

FEATURE_ANGLE_DEG = 30.0    # a mesh edge sharper than this is drawn (rims, hole edges, chamfers)
BEND_PITCH_MM = 3.0         # the strip is cut this finely along y before it is bent (sagitta < 0.01 mm at 90°)
OWN_EXPLODE_FACTOR = 2.0    # parts off the backbone move this many explode distances from their group
OWN_EXPLODE_SCALE = 1.0     # ... plus this many times their own distance from the housing centre
STRIP_PULL_GAPS = 3.0       # the strip is drawn pulled out toward the base by this many explode distances
MIN_LIGHTNESS = 0.28        # a family colour darker than this is lifted so its shading still reads

# Qualitative colours (colour-blind friendly, after Okabe & Ito) for families whose own colour
# clashes with one already used, and for tendons.
FAMILY_PALETTE = [(0.00, 0.62, 0.45), (0.80, 0.47, 0.65), (0.34, 0.71, 0.91), (0.90, 0.62, 0.00),
                  (0.84, 0.37, 0.00), (0.00, 0.45, 0.70), (0.60, 0.60, 0.60), (0.55, 0.35, 0.20)]
TENDON_PALETTE = [(0.85, 0.10, 0.10), (0.10, 0.35, 0.85), (0.05, 0.60, 0.20), (0.60, 0.15, 0.70),
                  (0.95, 0.50, 0.00), (0.00, 0.65, 0.70), (0.75, 0.60, 0.00), (0.95, 0.35, 0.60)]
SAME_COLOUR = 0.12          # RGB distance (0..1) below which two lit colours look the same
CONFUSE_SHADES = (0.6, 1.2)  # the range of lighting a face of the pictures gets, as a factor on its colour


# --------------------------------------------------------------------------- scene data

@dataclass
class ScenePart:
    name: str
    role: str
    vertices: np.ndarray            # (n, 3) file coordinates
    faces: np.ndarray               # (m, 3)
    placement: np.ndarray           # 4x4 file -> robot
    station: int | None = None
    meta: dict = field(default_factory=dict)
    _edges: "EdgeData | None" = None
    # centre() and world_bounds(), worked out once (the exploded view asks for them part by part, many times)
    _centre: np.ndarray | None = field(default=None, repr=False, compare=False)
    _bounds: np.ndarray | None = field(default=None, repr=False, compare=False)
    # what the renderer made of the part in its file's coordinates (its surface with normals): every
    # rigid pose of it is drawn from that, moved, not worked out again
    drawn: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def mesh(self):
        """trimesh.Trimesh in file coordinates (vertices merged, so edges have two faces)."""
        import trimesh
        return trimesh.Trimesh(self.vertices, self.faces, process=False)

    @property
    def edge_data(self) -> "EdgeData":
        """What the edges are drawn from, worked out once from :attr:`mesh` (whose many other
        cached arrays, most of a part's memory in the renderer, then go), and kept with what the
        renderer made of the part (:attr:`drawn`: shared by parts of the same file's bytes)."""
        if self._edges is None:
            self._edges = self.drawn.get("edges")
        if self._edges is None:
            m = self.mesh
            self._edges = self.drawn["edges"] = EdgeData(
                np.asarray(m.face_normals), np.asarray(m.face_adjacency), np.asarray(m.face_adjacency_edges),
                m.face_adjacency_edges[m.face_adjacency_angles > math.radians(FEATURE_ANGLE_DEG)])
        return self._edges

    def feature_edges(self) -> np.ndarray:
        """(k, 2) vertex pairs of edges sharper than FEATURE_ANGLE_DEG."""
        return self.edge_data.feature

    def silhouette_edges(self, rotation: np.ndarray, view_dir: np.ndarray) -> np.ndarray:
        """(k, 2) vertex pairs between a face turned toward the viewer and one turned away."""
        e = self.edge_data
        n = e.face_normals @ rotation.T @ view_dir
        a, b = e.face_adjacency.T
        return e.adjacency_edges[(n[a] > 0) != (n[b] > 0)]

    def centre(self) -> np.ndarray:
        """Bounding-box centre in robot coordinates (straight, assembled)."""
        if self._centre is None:
            c = (self.vertices.min(axis=0) + self.vertices.max(axis=0)) / 2
            self._centre = self.placement[:3, :3] @ c + self.placement[:3, 3]
        return self._centre

    def world_bounds(self) -> np.ndarray:
        """The box of the part in robot coordinates (straight, assembled): [lowest, highest] corner."""
        if self._bounds is None:
            w = transform(self.vertices, self.placement)
            self._bounds = np.array([w.min(axis=0), w.max(axis=0)])
        return self._bounds


class EdgeData(NamedTuple):
    """A part's faces' normals and adjacency (trimesh's), and its feature edges."""
    face_normals: np.ndarray        # (m, 3)
    face_adjacency: np.ndarray      # (j, 2) faces that share an edge
    adjacency_edges: np.ndarray     # (j, 2) the vertices of that edge
    feature: np.ndarray             # (k, 2) vertex pairs of edges sharper than FEATURE_ANGLE_DEG


def transform(points: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def is_fixture(part: ManifestPart | dict) -> bool:
    """An assembly aid (the jig): drawn on its own, never in the robot's pictures."""
    return ManifestPart.of(part).fixture


def load_parts(folder: Path, manifest: Manifest, fixtures: bool = False) -> list[ScenePart]:
    """The robot's parts (or, with ``fixtures``, only the assembly aids), read back from their STLs
    (vertices merged): :func:`scene_parts` of their meshes."""
    return scene_parts(part_meshes(folder, [p for p in manifest_parts(manifest) if p.fixture == fixtures]))


def scene_parts(meshes: list[tuple[ManifestPart, object]]) -> list[ScenePart]:
    """Each part with its mesh (file coordinates) as a :class:`ScenePart`. Parts given one mesh
    (their files hold the same bytes) share its arrays and what the renderer makes of them in file
    coordinates (:attr:`ScenePart.drawn`: its surface, its edges)."""
    out = []
    keep = {"name", "role", "station", "files", "placement", "color", "volume_mm3", "bbox_mm"}
    drawn: dict[int, dict] = {}         # per mesh (one per file content), what is drawn of it
    for p, mesh in meshes:
        e = p.entry
        out.append(ScenePart(p.name, p.role, np.asarray(mesh.vertices), np.asarray(mesh.faces), p.placement, p.station,
                             {k: v for k, v in e.items() if k not in keep} | {"color": e.get("color")},
                             drawn=drawn.setdefault(id(mesh), {})))
    return out


def families(manifest: Manifest, fixtures: bool = False) -> list[str]:
    """Part families (the manifest roles) in order of first appearance; the assembly aids' too
    with ``fixtures``."""
    seen: list[str] = []
    for e in manifest.parts:
        if is_fixture(e) and not fixtures:
            continue
        if e.role not in seen:
            seen.append(e.role)
    return seen


def confusable(a, b) -> bool:
    """Two colours a person could take for one another once lit: some shades of them nearly meet."""
    sh = np.linspace(*CONFUSE_SHADES, 13)[:, None]
    A, B = sh * np.asarray(a, float)[:3], sh * np.asarray(b, float)[:3]
    return bool(np.min(np.linalg.norm(A[:, None] - B[None], axis=2)) < SAME_COLOUR)


def family_colours(manifest: Manifest, fixtures: bool = False) -> dict[str, tuple[float, float, float]]:
    """One colour per family: the family's own manifest colour unless it is confusable with one
    already used (or the background), then the next palette colour that is not."""
    out: dict[str, tuple[float, float, float]] = {}
    candidates = list(FAMILY_PALETTE) + [tuple(c) for c in np.random.default_rng(0).uniform(0.1, 0.9, (64, 3))]
    for role in families(manifest, fixtures):
        first = next(e for e in manifest.parts if e.role == role)
        rgb = np.asarray((first.color or (0.7, 0.7, 0.7))[:3], dtype=float)
        if rgb.max() < MIN_LIGHTNESS:
            rgb = rgb + (MIN_LIGHTNESS - rgb.max())
        taken = list(out.values())
        for cand in [tuple(rgb)] + candidates:
            if not any(confusable(cand, c) for c in taken) and np.linalg.norm(np.asarray(cand) - 1.0) > 0.3:
                break
        out[role] = tuple(float(v) for v in cand)
    return out


def tendon_colours(report: dict) -> dict[str, tuple[float, float, float]]:
    names = [t["name"] for t in report["tendons"]]
    return {n: TENDON_PALETTE[i % len(TENDON_PALETTE)] for i, n in enumerate(names)}


# --------------------------------------------------------------------------- poses

def _runs_along_backbone(p: ScenePart, stations: np.ndarray) -> bool:
    """A part without a station that spans several disk gaps (the strip): it bends with the robot."""
    if p.station is not None or len(stations) < 2:
        return False
    lo, hi = p.world_bounds()[:, 1]
    overlap = min(hi, stations[-1]) - max(lo, stations[0])
    return overlap > 1.5 * np.max(np.diff(stations))


def exploded_placements(parts: list[ScenePart], stations, explode_mm: float,
                        toward_camera=None) -> dict[str, np.ndarray]:
    """4x4 file -> exploded robot coordinates for every part.

    Disks move along y by station · explode; the strip is pulled out toward the base. The
    other parts ride with the disk nearest along y, in groups: beyond the tip (the tensioner),
    clear of the tip disk, and below the base (the base mount), clear of the base disk. The
    largest part of a group (the housing, the mount) stays put among them and every other one
    moves away from its centre along its own offset, by OWN_EXPLODE_FACTOR explode distances
    plus half the group's width, so it comes out of it. Given the view, the offsets lie in the
    picture plane: a part is moved beside its group's anchor on the screen, not behind it.
    """
    st = np.asarray(stations, dtype=float)
    e = float(explode_mm)
    loose = [p for p in parts if p.station is None and not _runs_along_backbone(p, st)]

    def side(p: ScenePart) -> int:
        y = p.centre()[1]
        return 1 if y > st[-1] else -1 if y < st[0] else 0

    groups: dict[int, list[ScenePart]] = {}
    for p in loose:
        groups.setdefault(side(p), []).append(p)
    anchor = {k: max(g, key=lambda p: np.prod(np.ptp(p.world_bounds(), axis=0))) for k, g in groups.items()}
    # a large group (the tensioner housing) needs more room than a gap to clear its end disk on screen
    width = {k: max(np.ptp(p.world_bounds()[:, [0, 2]], axis=0).max() for p in g) for k, g in groups.items()}
    d = None if toward_camera is None else np.asarray(toward_camera, float) / np.linalg.norm(toward_camera)
    out = {}
    for p in parts:
        shift = np.zeros(3)
        if p.station is not None:
            shift[1] = p.station * e
        elif _runs_along_backbone(p, st):
            shift[1] = -STRIP_PULL_GAPS * e
        else:
            k = side(p)
            c = p.centre()
            shift[1] = e * float(np.interp(c[1], st, np.arange(len(st))))
            if k:                               # beyond an end disk: clear of it
                shift[1] += k * max(OWN_EXPLODE_FACTOR * e, width[k])
            own = c - anchor[k].centre()
            if d is not None:
                own = own - d * (own @ d)
                away = np.array([0.0, float(k or 1), 0.0]) - d * d[1] * (k or 1)   # away from the disks, on screen
                away /= np.linalg.norm(away)
                if own @ away < 0:              # never back toward the disks: sideways instead
                    own = own - away * (own @ away)
            n = np.linalg.norm(own)
            if p is not anchor[k] and n > 1.0:
                # farther parts go farther (a worm and its wheel separate), and all clear the anchor
                shift += OWN_EXPLODE_SCALE * own + (OWN_EXPLODE_FACTOR * e + width[k] / 2) * own / n
        m = p.placement.copy()
        m[:3, 3] += shift
        out[p.name] = m
    return out


def bend_points(points: np.ndarray, stations, kappa: float) -> np.ndarray:
    """Map robot points of the straight robot to the bent one, point by point (eq. (1)).

    A point at height y between the base and the tip is carried by the frame at arc length y;
    below the base it stays put (the clamp), beyond the tip it follows the tip frame.
    """
    st = np.asarray(stations, dtype=float)
    y = points[:, 1]
    s = np.clip(y, st[0], st[-1])
    R, p = kin.frames(s, kappa)
    R, p = R[0], p[0]
    local = points - np.column_stack([np.zeros_like(s), s, np.zeros_like(s)])
    return p + np.einsum("nij,nj->ni", R, local)


def rigid_bend(stations, kappa: float, s: float) -> np.ndarray:
    """4x4 moving the straight robot's frame at arc length s to its bent pose."""
    R, p = kin.frames([s], kappa)
    m = np.eye(4)
    m[:3, :3] = R[0, 0]
    m[:3, 3] = p[0, 0] - R[0, 0] @ np.array([0.0, s, 0.0])
    return m


def slice_along_y(vertices: np.ndarray, faces: np.ndarray, ys) -> tuple[np.ndarray, np.ndarray]:
    """Cut a mesh by the planes y = ys so that no triangle spans two slabs (for bending)."""
    from trimesh.intersections import slice_faces_plane
    ys = np.sort(np.asarray(ys, dtype=float))
    V, F, off = [], [], 0
    edges = np.concatenate([[-np.inf], ys, [np.inf]])
    for lo, hi in zip(edges[:-1], edges[1:]):
        v, f = vertices, faces
        if np.isfinite(lo):
            v, f = slice_faces_plane(v, f, plane_normal=[0, 1, 0], plane_origin=[0, lo, 0])[:2]
        if np.isfinite(hi) and len(f):
            v, f = slice_faces_plane(v, f, plane_normal=[0, -1, 0], plane_origin=[0, hi, 0])[:2]
        if len(f):
            V.append(v)
            F.append(f + off)
            off += len(v)
    return np.vstack(V), np.vstack(F)


def subdivide_segments(a: np.ndarray, b: np.ndarray, pitch: float) -> tuple[np.ndarray, np.ndarray]:
    """Split segments (a[i], b[i]) into pieces no longer than pitch."""
    n = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / pitch).astype(int))
    idx = np.repeat(np.arange(len(a)), n)
    k = np.concatenate([np.arange(m) for m in n]) if len(n) else np.zeros(0, int)
    t0 = (k / n[idx])[:, None]
    t1 = ((k + 1) / n[idx])[:, None]
    d = b[idx] - a[idx]
    return a[idx] + t0 * d, a[idx] + t1 * d


@dataclass
class Posed:
    """One part as drawn: world triangles and world edge segments. A pose drawn in several
    pictures (the assembled one: the guide's steps, the jig) is made once and handed to each."""

    part: ScenePart
    vertices: np.ndarray
    faces: np.ndarray
    edges: np.ndarray           # (k, 2, 3) world segments
    silhouette: np.ndarray | None = None    # (j, 2) vertex pairs of the silhouette edges (a rigid pose's)
    matrix: np.ndarray | None = None        # 4x4 file -> world of a rigid pose (None: the part was bent)
    # what the renderer made of this pose (its surface with normals), kept as long as the pose
    drawn: dict = field(default_factory=dict, repr=False, compare=False)

    def as_role(self, role: str) -> "Posed":
        """The same pose drawn as another family (a guide step's context parts): what the renderer
        made of it is shared, not made again."""
        return replace(self, part=replace(self.part, role=role))


def pose_rigid(p: ScenePart, matrix: np.ndarray, view_dir: np.ndarray) -> Posed:
    V = transform(p.vertices, matrix)
    silhouette = p.silhouette_edges(matrix[:3, :3], view_dir)
    pairs = np.vstack([p.feature_edges(), silhouette])
    return Posed(p, V, p.faces, V[pairs], silhouette, np.asarray(matrix, dtype=float))


def bent_placement(p: ScenePart, stations, kappa: float) -> np.ndarray | None:
    """4x4 file -> bent robot coordinates of a part that moves rigidly on the bent robot (a disk with
    its frame, a part off the backbone with the frame nearest along y); None for a part that runs
    along the backbone (the strip), which bends with it (:func:`pose_bent`)."""
    st = np.asarray(stations, dtype=float)
    if _runs_along_backbone(p, st):
        return None
    s = st[p.station] if p.station is not None else float(np.clip(p.centre()[1], st[0], st[-1]))
    return rigid_bend(st, kappa, s) @ p.placement


def sliced(p: ScenePart, pitch: float) -> tuple[np.ndarray, np.ndarray]:
    """A part that bends with the robot (the strip) in straight robot coordinates, cut across y every
    ``pitch`` mm so that :func:`bend_points` can bend it (vertices, faces)."""
    W = transform(p.vertices, p.placement)
    lo, hi = W[:, 1].min(), W[:, 1].max()
    return slice_along_y(W, p.faces, np.arange(lo + pitch, hi, pitch))


def pose_bent(p: ScenePart, stations, kappa: float, view_dir: np.ndarray) -> Posed:
    """A part placed on the bent robot: rigid for disks and parts off the backbone, bent for the strip."""
    st = np.asarray(stations, dtype=float)
    rigid = bent_placement(p, st, kappa)
    if rigid is not None:
        return pose_rigid(p, rigid, view_dir)
    V, F = sliced(p, BEND_PITCH_MM)
    W = transform(p.vertices, p.placement)
    # edges: feature edges only (a flat strip's silhouette is its rim), split along the bend
    pairs = p.feature_edges()
    a, b = subdivide_segments(W[pairs[:, 0]], W[pairs[:, 1]], BEND_PITCH_MM)
    edges = np.stack([bend_points(a, st, kappa), bend_points(b, st, kappa)], axis=1)
    return Posed(p, bend_points(V, st, kappa), F, edges)


def tendon_polylines(report: dict, kappa: float) -> dict[str, np.ndarray]:
    """Each tendon's eyelet points in robot coordinates at this curvature: name -> (N, 3)."""
    st = report["stations_mm"]
    return {t["name"]: kin.points_in_space(st, np.asarray(t["eyelets_xz_mm"]), kappa)[0]
            for t in report["tendons"]}
