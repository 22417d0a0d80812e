"""Offscreen pictures of a built design: exploded, assembled and bent (VTK, no display, no GPU).

Everything starts from the files in ``out/<design>/``: each part's STL, placed in robot
coordinates by the placement the manifest records, coloured by its family (the manifest
``role``). Nothing here knows how a part was built, so new families (the tensioner's worm,
wheel, housing, ...) appear in the pictures as soon as they are in the manifest.

The pictures are drawn in a child process (``python -m hwgen.render``): an OpenGL driver
that is missing or crashes then costs the pictures, never the build. The build step writes
the bill of materials first, then asks the child for the pictures and the SVG drawing; if
no backend works it records a message saying what to install and carries on.

Views (parallel projection, robot coordinates: y along the backbone, bending toward +z):

* exploded: disks spread along y by ``render.explode_mm`` per gap, the strip pulled out
  toward the base, the tensioner lifted clear of the tip disk and its parts moved out of
  the housing along their own offsets (see :func:`exploded_placements`);
* assembled: every part where the manifest places it, tendons drawn through their eyelets;
* bent: the constant-curvature pose of eq. (1) at ``render.bend_deg``: disks moved rigidly
  to their frames T_i, the strip bent point by point, each tendon a tube through its eyelets.

Each family keeps its manifest colour unless it could be taken for another family's once
lit (:func:`confusable`); then it gets the next colour of FAMILY_PALETTE that cannot.
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import kinematics as kin

BACKEND_ENV = "HWGEN_RENDER_BACKEND"   # "none": behave as if no OpenGL backend worked (tests, CI)
CHILD_TIMEOUT_S = 300
INSTALL_HINT = (
    "Offscreen pictures need an OpenGL backend for VTK without a display: Mesa's EGL with the "
    "llvmpipe software rasteriser (Debian/Ubuntu: apt-get install libegl1 libgl1-mesa-dri; "
    "Fedora: dnf install mesa-libEGL mesa-dri-drivers), or VTK's OSMesa build "
    "(pip install --extra-index-url https://wheels.vtk.org vtk-osmesa). "
    "The parts, checks and bill of materials were written without the pictures.")

FEATURE_ANGLE_DEG = 30.0    # a mesh edge sharper than this is drawn (rims, hole edges, chamfers)
SMOOTH_ANGLE_DEG = 20.0     # shading is smooth across edges flatter than this (STL facets are 11.5°)
BEND_PITCH_MM = 3.0         # the strip is cut this finely along y before it is bent (sagitta < 0.01 mm at 90°)
TENDON_TUBE_MM = 0.7        # drawn radius of a tendon (the real 0.075 mm would be invisible)
OWN_EXPLODE_FACTOR = 2.0    # parts off the backbone move this many explode distances from their group
OWN_EXPLODE_SCALE = 1.0     # ... plus this many times their own distance from the housing centre
STRIP_PULL_GAPS = 3.0       # the strip is drawn pulled out toward the base by this many explode distances
MIN_LIGHTNESS = 0.28        # a family colour darker than this is lifted so its shading still reads
BACKGROUND = (1.0, 1.0, 1.0)
TEXT_COLOUR = (0.12, 0.12, 0.12)

# Qualitative colours (colour-blind friendly, after Okabe & Ito) for families whose own colour
# clashes with one already used, and for tendons.
FAMILY_PALETTE = [(0.00, 0.62, 0.45), (0.80, 0.47, 0.65), (0.34, 0.71, 0.91), (0.90, 0.62, 0.00),
                  (0.84, 0.37, 0.00), (0.00, 0.45, 0.70), (0.60, 0.60, 0.60), (0.55, 0.35, 0.20)]
TENDON_PALETTE = [(0.85, 0.10, 0.10), (0.10, 0.35, 0.85), (0.05, 0.60, 0.20), (0.60, 0.15, 0.70),
                  (0.95, 0.50, 0.00), (0.00, 0.65, 0.70), (0.75, 0.60, 0.00), (0.95, 0.35, 0.60)]
LABEL_GAP_MM = 6.0          # disk numbers sit this far above the disk's top on screen
SAME_COLOUR = 0.12          # RGB distance (0..1) below which two lit colours look the same
CONFUSE_SHADES = (0.6, 1.2)  # the range of lighting a face of the pictures gets, as a factor on its colour


class RenderUnavailable(RuntimeError):
    """No offscreen OpenGL backend: the message says what failed and what to install."""


class RenderFailed(RuntimeError):
    """The renderer ran but stopped on an error of its own (a bad file, a bug): not a backend problem."""


OUTPUTS = ("exploded.png", "assembled.png", "bent.png", "exploded.svg")
EXIT_NO_BACKEND = 3      # the child's exit code for RenderUnavailable


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
    _mesh: object = None

    @property
    def mesh(self):
        """trimesh.Trimesh in file coordinates (vertices merged, so edges have two faces)."""
        if self._mesh is None:
            import trimesh
            self._mesh = trimesh.Trimesh(self.vertices, self.faces, process=False)
        return self._mesh

    def feature_edges(self) -> np.ndarray:
        """(k, 2) vertex pairs of edges sharper than FEATURE_ANGLE_DEG."""
        m = self.mesh
        sharp = m.face_adjacency_angles > math.radians(FEATURE_ANGLE_DEG)
        return m.face_adjacency_edges[sharp]

    def silhouette_edges(self, rotation: np.ndarray, view_dir: np.ndarray) -> np.ndarray:
        """(k, 2) vertex pairs between a face turned toward the viewer and one turned away."""
        m = self.mesh
        n = m.face_normals @ rotation.T @ view_dir
        a, b = m.face_adjacency.T
        return m.face_adjacency_edges[(n[a] > 0) != (n[b] > 0)]

    def centre(self) -> np.ndarray:
        """Bounding-box centre in robot coordinates (straight, assembled)."""
        c = (self.vertices.min(axis=0) + self.vertices.max(axis=0)) / 2
        return self.placement[:3, :3] @ c + self.placement[:3, 3]

    def world_bounds(self) -> np.ndarray:
        w = transform(self.vertices, self.placement)
        return np.array([w.min(axis=0), w.max(axis=0)])


def transform(points: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def load_parts(folder: Path, manifest: dict) -> list[ScenePart]:
    """Every part of the manifest, read back from its STL (vertices merged)."""
    import trimesh
    out = []
    keep = {"name", "role", "station", "files", "placement", "color", "volume_mm3", "bbox_mm"}
    for e in manifest["parts"]:
        mesh = trimesh.load_mesh(str(Path(folder) / e["files"]["stl"]["path"]), process=True)
        out.append(ScenePart(e["name"], e["role"], np.asarray(mesh.vertices), np.asarray(mesh.faces),
                             np.asarray(e["placement"], dtype=float), e.get("station"),
                             {k: v for k, v in e.items() if k not in keep} | {"color": e.get("color")}))
    return out


def families(manifest: dict) -> list[str]:
    """Part families (the manifest roles) in order of first appearance."""
    seen: list[str] = []
    for e in manifest["parts"]:
        if e["role"] not in seen:
            seen.append(e["role"])
    return seen


def confusable(a, b) -> bool:
    """Two colours a person could take for one another once lit: some shades of them nearly meet."""
    sh = np.linspace(*CONFUSE_SHADES, 13)[:, None]
    A, B = sh * np.asarray(a, float)[:3], sh * np.asarray(b, float)[:3]
    return bool(np.min(np.linalg.norm(A[:, None] - B[None], axis=2)) < SAME_COLOUR)


def family_colours(manifest: dict) -> dict[str, tuple[float, float, float]]:
    """One colour per family: the family's own manifest colour unless it is confusable with one
    already used (or the background), then the next palette colour that is not."""
    out: dict[str, tuple[float, float, float]] = {}
    candidates = list(FAMILY_PALETTE) + [tuple(c) for c in np.random.default_rng(0).uniform(0.1, 0.9, (64, 3))]
    for role in families(manifest):
        first = next(e for e in manifest["parts"] if e["role"] == role)
        rgb = np.asarray((first.get("color") or (0.7, 0.7, 0.7))[:3], dtype=float)
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
    other parts (the tensioner) ride with the disk nearest along y, clear of the tip disk;
    the largest of them (the housing) stays put among them and every other one moves away
    from its centre along its own offset, by OWN_EXPLODE_FACTOR explode distances plus half
    the housing's width, so it comes out of the housing. Given the view, the offsets lie in
    the picture plane: a part is moved beside the housing on the screen, not behind it.
    """
    st = np.asarray(stations, dtype=float)
    e = float(explode_mm)
    loose = [p for p in parts if p.station is None and not _runs_along_backbone(p, st)]
    anchor = max(loose, key=lambda p: np.prod(np.ptp(p.world_bounds(), axis=0)), default=None)
    # a large group (the tensioner housing) needs more room than a gap to clear the tip disk on screen
    loose_width = max((np.ptp(p.world_bounds()[:, [0, 2]], axis=0).max() for p in loose), default=0.0)
    d = None if toward_camera is None else np.asarray(toward_camera, float) / np.linalg.norm(toward_camera)
    out = {}
    for p in parts:
        shift = np.zeros(3)
        if p.station is not None:
            shift[1] = p.station * e
        elif _runs_along_backbone(p, st):
            shift[1] = -STRIP_PULL_GAPS * e
        else:
            c = p.centre()
            shift[1] = e * float(np.interp(c[1], st, np.arange(len(st))))
            if c[1] > st[-1]:               # beyond the tip (the tensioner): clear of the tip disk
                shift[1] += max(OWN_EXPLODE_FACTOR * e, loose_width)
            elif c[1] < st[0]:
                shift[1] -= OWN_EXPLODE_FACTOR * e
            own = c - anchor.centre()
            if d is not None:
                own = own - d * (own @ d)
                ahead = np.array([0.0, 1.0, 0.0]) - d * d[1]      # the robot's +y on the screen
                ahead /= np.linalg.norm(ahead)
                if own @ ahead < 0:            # never back toward the disks: sideways instead
                    own = own - ahead * (own @ ahead)
            n = np.linalg.norm(own)
            if p is not anchor and n > 1.0:
                # farther parts go farther (a worm and its wheel separate), and all clear the housing
                shift += OWN_EXPLODE_SCALE * own + (OWN_EXPLODE_FACTOR * e + loose_width / 2) * own / n
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
    """One part as drawn: world triangles and world edge segments."""

    part: ScenePart
    vertices: np.ndarray
    faces: np.ndarray
    edges: np.ndarray           # (k, 2, 3) world segments


def pose_rigid(p: ScenePart, matrix: np.ndarray, view_dir: np.ndarray) -> Posed:
    V = transform(p.vertices, matrix)
    pairs = np.vstack([p.feature_edges(), p.silhouette_edges(matrix[:3, :3], view_dir)])
    return Posed(p, V, p.faces, V[pairs])


def pose_bent(p: ScenePart, stations, kappa: float, view_dir: np.ndarray) -> Posed:
    """A part placed on the bent robot: rigid for disks and parts off the backbone, bent for the strip."""
    st = np.asarray(stations, dtype=float)
    if not _runs_along_backbone(p, st):
        s = st[p.station] if p.station is not None else float(np.clip(p.centre()[1], st[0], st[-1]))
        return pose_rigid(p, rigid_bend(st, kappa, s) @ p.placement, view_dir)
    W = transform(p.vertices, p.placement)
    lo, hi = W[:, 1].min(), W[:, 1].max()
    cuts = np.arange(lo + BEND_PITCH_MM, hi, BEND_PITCH_MM)
    V, F = slice_along_y(W, p.faces, cuts)
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


# --------------------------------------------------------------------------- VTK

def _vtk():
    """Import the VTK modules used here (rendering backends register themselves on import)."""
    import vtkmodules.vtkRenderingFreeType  # noqa: F401  (text)
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (the OpenGL backend factory)
    from vtkmodules import vtkCommonCore, vtkCommonDataModel, vtkFiltersCore, vtkRenderingCore
    return vtkCommonCore, vtkCommonDataModel, vtkFiltersCore, vtkRenderingCore


def _polydata(vertices: np.ndarray, cells: np.ndarray, lines: bool = False):
    from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
    core, dm, _, _ = _vtk()
    pts = core.vtkPoints()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(vertices, dtype=np.float64), deep=True))
    cells = np.ascontiguousarray(cells, dtype=np.int64)
    ca = dm.vtkCellArray()
    offsets = np.arange(0, cells.size + 1, cells.shape[1], dtype=np.int64)
    ca.SetData(numpy_to_vtkIdTypeArray(offsets, deep=True), numpy_to_vtkIdTypeArray(cells.ravel(), deep=True))
    pd = dm.vtkPolyData()
    pd.SetPoints(pts)
    if lines:
        pd.SetLines(ca)
    else:
        pd.SetPolys(ca)
    return pd


def _surface_actor(V, F, rgb, shading: bool = True):
    _, _, filters, rc = _vtk()
    normals = filters.vtkPolyDataNormals()
    normals.SetInputData(_polydata(V, F))
    normals.SetFeatureAngle(SMOOTH_ANGLE_DEG)
    normals.SplittingOn()
    normals.ConsistencyOff()
    mapper = rc.vtkPolyDataMapper()
    mapper.SetInputConnection(normals.GetOutputPort())
    actor = rc.vtkActor()
    actor.SetMapper(mapper)
    prop = actor.GetProperty()
    prop.SetColor(*rgb)
    if shading:
        prop.SetAmbient(0.45)
        prop.SetDiffuse(0.65)
        prop.SetSpecular(0.08)
        prop.SetSpecularPower(25)
    else:
        prop.LightingOff()
    return actor


def _line_actor(segments: np.ndarray, rgb, width: float):
    _, _, _, rc = _vtk()
    pts = segments.reshape(-1, 3)
    cells = np.arange(len(pts)).reshape(-1, 2)
    mapper = rc.vtkPolyDataMapper()
    mapper.SetInputData(_polydata(pts, cells, lines=True))
    mapper.SetResolveCoincidentTopologyToPolygonOffset()
    mapper.SetRelativeCoincidentTopologyLineOffsetParameters(0, -4)
    actor = rc.vtkActor()
    actor.SetMapper(mapper)
    prop = actor.GetProperty()
    prop.SetColor(*rgb)
    prop.SetLineWidth(width)
    prop.LightingOff()
    return actor


def _tube_actor(points: np.ndarray, rgb, radius: float):
    _, _, filters, rc = _vtk()
    pd = _polydata(points, np.arange(len(points))[None, :], lines=True)
    tube = filters.vtkTubeFilter()
    tube.SetInputData(pd)
    tube.SetRadius(radius)
    tube.SetNumberOfSides(16)
    tube.CappingOn()
    mapper = rc.vtkPolyDataMapper()
    mapper.SetInputConnection(tube.GetOutputPort())
    actor = rc.vtkActor()
    actor.SetMapper(mapper)
    prop = actor.GetProperty()
    prop.SetColor(*rgb)
    prop.SetAmbient(0.35)
    prop.SetDiffuse(0.7)
    prop.SetSpecular(0.3)
    return actor


def edge_colour(rgb) -> tuple[float, float, float]:
    """Edges a darker shade of the part; on dark parts a lighter one, so rims still read."""
    c = np.asarray(rgb)
    return tuple(c * 0.35) if c.max() > 0.45 else tuple(np.minimum(1.0, c + 0.35))


@dataclass(frozen=True)
class View:
    """A parallel projection: the direction from the scene toward the camera, and screen up."""

    toward_camera: tuple[float, float, float]
    up: tuple[float, float, float]

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        d = np.asarray(self.toward_camera, float)
        d /= np.linalg.norm(d)
        u = np.asarray(self.up, float)
        u = u - d * (u @ d)
        u /= np.linalg.norm(u)
        return np.cross(u, d), u, d     # right, up, toward camera


# Exploded and assembled: the robot runs from the base (lower left) to the tip (upper right),
# seen from +x, +z and the base side, so every disk shows its face and holes as an ellipse
# and the strip reads as a band, not an edge.
ISOMETRIC = View((0.62, -0.58, 0.55), (0.0, 0.25, 1.0))
# Bent: mostly across the bending plane (the paper's Fig. 5), a little from the base and above.
BENT = View((1.0, -0.25, 0.35), (0.0, 0.0, 1.0))


class Renderer:
    """One offscreen window reused for every picture of the process."""

    def __init__(self, width: int):
        if os.environ.get(BACKEND_ENV, "").lower() == "none":
            raise RenderUnavailable(f"{BACKEND_ENV}=none: offscreen rendering switched off")
        try:
            _, _, _, rc = _vtk()
        except ImportError as e:
            raise RenderUnavailable(f"VTK could not be imported ({e})") from None
        self.rc = rc
        self.window = rc.vtkRenderWindow()
        self.window.SetOffScreenRendering(1)
        self.window.SetMultiSamples(0)
        self.width = int(width)
        self.backend = self.window.GetClassName()

    def _fit(self, ren, view: View, points: np.ndarray, margin: float, aspect_range, W: int) -> tuple[int, int]:
        right, up, d = view.axes()
        centre = (points.min(axis=0) + points.max(axis=0)) / 2
        rel = points - centre
        xr, yr = rel @ right, rel @ up
        w_world = (xr.max() - xr.min()) * (1 + 2 * margin)
        h_world = (yr.max() - yr.min()) * (1 + 2 * margin)
        aspect = float(np.clip(h_world / w_world, *aspect_range))
        H = int(round(W * aspect))
        mid = centre + right * (xr.max() + xr.min()) / 2 + up * (yr.max() + yr.min()) / 2
        cam = ren.GetActiveCamera()
        cam.ParallelProjectionOn()
        cam.SetFocalPoint(*mid)
        cam.SetPosition(*(mid + d * 2000.0))
        cam.SetViewUp(*up)
        cam.SetParallelScale(max(h_world, w_world * aspect) / 2)
        ren.ResetCameraClippingRange()
        return W, H

    def draw(self, posed: list[Posed], colours: dict[str, tuple], view: View, path: Path | None,
             tubes: dict[str, tuple[np.ndarray, tuple]] | None = None, texts=(),
             labels=(), aspect_range=(0.45, 1.3), margin=0.04, edges: bool = True, shading: bool = True,
             width: int | None = None):
        """Draw posed parts (and tendon tubes), write a PNG when a path is given.

        Returns (renderer, width, height) so a caller can read the depth buffer.
        """
        rc = self.rc
        ren = rc.vtkRenderer()
        ren.SetBackground(*BACKGROUND)
        lw = max(1.0, self.width / 1000)
        for ps in posed:
            rgb = colours[ps.part.role]
            ren.AddActor(_surface_actor(ps.vertices, ps.faces, rgb, shading))
            if edges and len(ps.edges):
                ren.AddActor(_line_actor(ps.edges, edge_colour(rgb), lw))
        for pts, rgb in (tubes or {}).values():
            ren.AddActor(_tube_actor(pts, rgb, TENDON_TUBE_MM))
        allpts = np.vstack([ps.vertices for ps in posed] + [pts for pts, _ in (tubes or {}).values()]
                           + [np.asarray([pt for _, pt in labels]).reshape(-1, 3)])
        W, H = self._fit(ren, view, allpts, margin, aspect_range, width or self.width)
        if shading:
            kit = rc.vtkLightKit()
            kit.SetKeyLightIntensity(1.0)
            kit.SetKeyLightAngle(35, 15)     # closer to the view than the default, so disk faces are lit
            kit.AddLightsToRenderer(ren)
            ren.UseFXAAOn()
        for text, rgb, (fx, fy), size, swatch in texts:
            px = int(size * self.width / 1800)
            x, y = int(fx * W), int(fy * H)
            if swatch is not None:      # a coloured block: spaces on the swatch colour
                sw = rc.vtkTextActor()
                sw.SetInput("    ")
                sw.GetTextProperty().SetFontSize(px)
                sw.GetTextProperty().SetBackgroundColor(*swatch)
                sw.GetTextProperty().SetBackgroundOpacity(1.0)
                sw.SetDisplayPosition(x, y)
                ren.AddViewProp(sw)
                x += int(2.2 * px)
            t = rc.vtkTextActor()
            t.SetInput(text)
            t.GetTextProperty().SetColor(*rgb)
            t.GetTextProperty().SetFontSize(px)
            t.GetTextProperty().BoldOn()
            t.SetDisplayPosition(x, y)
            ren.AddViewProp(t)
        rens = self.window.GetRenderers()
        rens.RemoveAllItems()
        self.window.AddRenderer(ren)
        self.window.SetSize(W, H)
        if labels:
            self.window.Render()        # places the camera, so world points map to the screen
            for text, point in labels:
                ren.SetWorldPoint(*point, 1.0)
                ren.WorldToDisplay()
                x, y, _ = ren.GetDisplayPoint()
                t = rc.vtkTextActor()
                t.SetInput(text)
                t.GetTextProperty().SetColor(*TEXT_COLOUR)
                t.GetTextProperty().SetFontSize(int(24 * self.width / 1800))
                t.GetTextProperty().BoldOn()
                t.GetTextProperty().SetJustificationToCentered()
                t.GetTextProperty().SetVerticalJustificationToCentered()
                t.SetDisplayPosition(int(x), int(y))
                ren.AddViewProp(t)
        self.window.Render()
        if path is not None:
            img = self.rgb(W, H)
            if img.min() == img.max():
                raise RenderUnavailable(f"the offscreen {self.backend} drew nothing (no working OpenGL context)")
            write_png(img, path)
        return ren, W, H

    def rgb(self, W: int, H: int) -> np.ndarray:
        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkCommonCore import vtkUnsignedCharArray
        arr = vtkUnsignedCharArray()
        self.window.GetPixelData(0, 0, W - 1, H - 1, 0, arr, 0)
        img = vtk_to_numpy(arr).reshape(H, W, -1)[:, :, :3]
        return img[::-1].copy()     # OpenGL rows run bottom-up

    def depth(self, W: int, H: int) -> np.ndarray:
        """Depth buffer (H, W), rows top-down, values 0 (near) .. 1 (far/background)."""
        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkCommonCore import vtkFloatArray
        arr = vtkFloatArray()
        self.window.GetZbufferData(0, 0, W - 1, H - 1, arr)
        return vtk_to_numpy(arr).reshape(H, W)[::-1].copy()


def write_png(img: np.ndarray, path: Path) -> None:
    from PIL import Image
    Image.fromarray(img).save(path, optimize=True)


# --------------------------------------------------------------------------- pictures

@dataclass(frozen=True)
class Settings:
    width_px: int
    explode_mm: float
    bend_deg: float


def _legend(names_colours, title: str):
    """Title, then one coloured swatch and a dark label per entry: (text, rgb, (fx, fy), size, swatch)."""
    texts = [(title, TEXT_COLOUR, (0.015, 0.955), 30, None)]
    for i, (name, rgb) in enumerate(names_colours):
        texts.append((name, TEXT_COLOUR, (0.015, 0.91 - 0.035 * i), 24, rgb))
    return texts


def station_labels(posed: list[Posed], view: View) -> list[tuple[str, np.ndarray]]:
    """Disk numbers (the station index) just above each disk on the screen."""
    right, up, d = view.axes()
    out = []
    for ps in posed:
        if ps.part.station is None:
            continue
        top = ps.vertices[np.argmax(ps.vertices @ up)]
        out.append((str(ps.part.station), top + up * LABEL_GAP_MM))
    return out


def render_pictures(folder: Path, manifest: dict, settings: Settings, svg_table: list[dict] | None = None,
                    renderer: Renderer | None = None) -> dict:
    """exploded.png, assembled.png, bent.png (and exploded.svg when a parts table is given)."""
    folder = Path(folder)
    timings = {}
    t0 = time.perf_counter()
    r = renderer or Renderer(settings.width_px)
    parts = load_parts(folder, manifest)
    report = manifest["design_report"]
    st = np.asarray(report["stations_mm"], dtype=float)
    colours = family_colours(manifest)
    tcol = tendon_colours(report)
    timings["load_s"] = time.perf_counter() - t0
    from .bom import family_label
    fam_legend = [(f"{family_label(role)} ({sum(p.role == role for p in parts)})", colours[role]) for role in colours]
    images = {}

    t = time.perf_counter()
    d = np.asarray(ISOMETRIC.toward_camera, float)
    d /= np.linalg.norm(d)
    ex = exploded_placements(parts, st, settings.explode_mm, ISOMETRIC.toward_camera)
    posed = [pose_rigid(p, ex[p.name], d) for p in parts]
    _, W, H = r.draw(posed, colours, ISOMETRIC, folder / "exploded.png", labels=station_labels(posed, ISOMETRIC),
                     texts=_legend(fam_legend, f"{manifest['design']}: exploded, "
                                               f"{settings.explode_mm:g} mm between disks"))
    images["exploded.png"] = {"width": W, "height": H}
    timings["exploded_s"] = time.perf_counter() - t

    t = time.perf_counter()
    posed = [pose_rigid(p, p.placement, d) for p in parts]
    straight = {n: (pts, tcol[n]) for n, pts in tendon_polylines(report, 0.0).items()}
    _, W, H = r.draw(posed, colours, ISOMETRIC, folder / "assembled.png", tubes=straight,
                     texts=_legend(fam_legend + [(n, tcol[n]) for n in straight], f"{manifest['design']}: assembled"))
    images["assembled.png"] = {"width": W, "height": H}
    timings["assembled_s"] = time.perf_counter() - t

    t = time.perf_counter()
    kappa = float(kin.kappas_for_angles([settings.bend_deg], st[-1] - st[0])[0])
    b = np.asarray(BENT.toward_camera, float)
    b /= np.linalg.norm(b)
    posed = [pose_bent(p, st, kappa, b) for p in parts]
    bent = {n: (pts, tcol[n]) for n, pts in tendon_polylines(report, kappa).items()}
    _, W, H = r.draw(posed, colours, BENT, folder / "bent.png", tubes=bent, aspect_range=(0.6, 1.0),
                     texts=_legend([(n, tcol[n]) for n in bent],
                                   f"{manifest['design']}: bent {settings.bend_deg:g}° (constant curvature, eq. 1)"))
    images["bent.png"] = {"width": W, "height": H}
    timings["bent_s"] = time.perf_counter() - t

    result = {"backend": r.backend, "images": images, "timings_s": timings,
              "palette": {k: list(v) for k, v in colours.items()},
              "tendon_colours": {k: list(v) for k, v in tcol.items()},
              "explode_mm": settings.explode_mm, "bend_deg": settings.bend_deg}
    if svg_table is not None:
        from .drawing import write_exploded_svg
        t = time.perf_counter()
        result["svg"] = write_exploded_svg(r, parts, ex, colours, svg_table, folder / "exploded.svg",
                                           title=f"{manifest['design']}: exploded assembly")
        timings["svg_s"] = time.perf_counter() - t
    return result


# --------------------------------------------------------------------------- the build step

def run_child(folder: Path, manifest: dict, settings: Settings, svg_table: list[dict] | None) -> dict:
    """Draw the pictures in a fresh Python process; raise RenderUnavailable if it cannot."""
    if os.environ.get(BACKEND_ENV, "").lower() == "none":
        raise RenderUnavailable(f"{BACKEND_ENV}=none: offscreen rendering switched off")
    job = json.dumps({"folder": str(folder), "manifest": manifest, "settings": settings.__dict__,
                      "svg_table": svg_table})
    attempts = [dict(os.environ)]
    attempts[0].pop("DISPLAY", None)            # offscreen: EGL first, never a stale X display
    if os.environ.get("DISPLAY"):
        attempts.append(dict(os.environ))       # then the display's own OpenGL, if there is one
    errors, backend = [], True
    for env in attempts:
        try:
            proc = subprocess.run([sys.executable, "-m", "hwgen.render"], input=job, capture_output=True,
                                  text=True, env=env, timeout=CHILD_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            errors.append(f"the renderer did not finish in {CHILD_TIMEOUT_S} s")
            continue
        lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
        if proc.returncode == 0 and lines:
            return json.loads(lines[-1])
        tail = (proc.stderr.strip().splitlines() or [""])[-1][:300]
        if proc.returncode < 0:          # killed by a signal: the OpenGL driver crashed
            errors.append(f"the renderer crashed (signal {-proc.returncode}) {tail}".strip())
        else:
            errors.append(tail or f"the renderer stopped with exit code {proc.returncode}")
            backend = proc.returncode == EXIT_NO_BACKEND
    raise (RenderUnavailable if backend else RenderFailed)("; ".join(errors))


def _child_main() -> int:
    job = json.loads(sys.stdin.read())
    try:
        result = render_pictures(Path(job["folder"]), job["manifest"], Settings(**job["settings"]),
                                 job.get("svg_table"))
    except RenderUnavailable as e:
        print(f"RenderUnavailable: {e}", file=sys.stderr)
        return EXIT_NO_BACKEND
    print(json.dumps(result))
    return 0


def step(plan, folder: Path, manifest: dict) -> None:
    """POST_BUILD: bill of materials, then pictures and drawing; a missing backend is a warning."""
    from . import bom
    from .export import sha256

    design = plan.design
    rows = bom.write_bom(folder, manifest, design)
    settings = Settings(design.render.width_px, design.render.explode_mm, design.render.bend_deg)
    entry: dict = {"settings": settings.__dict__}
    for name in OUTPUTS:                 # never leave pictures of an earlier design beside this one
        (Path(folder) / name).unlink(missing_ok=True)
    t = time.perf_counter()
    try:
        result = run_child(folder, manifest, settings, bom.family_table(manifest, design, rows))
    except RenderUnavailable as e:
        entry |= {"status": "unavailable", "message": f"pictures not drawn: {e}. {INSTALL_HINT}"}
    except RenderFailed as e:
        entry |= {"status": "failed", "message": f"pictures not drawn, the renderer stopped: {e}"}
    else:
        files = {}
        for name, size in result.pop("images").items():
            files[name] = {"path": name, "sha256": sha256(folder / name)} | size
        if (folder / "exploded.svg").exists():
            files["exploded.svg"] = {"path": "exploded.svg", "sha256": sha256(folder / "exploded.svg")}
        entry |= {"status": "ok", "files": files} | result
    entry["seconds"] = round(time.perf_counter() - t, 2)
    manifest["render"] = entry


def render_design(loaded, out_root: Path) -> tuple[dict, Path, str | None]:
    """`hwgen render`: pictures, drawing and BOM of ``out_root/<design>/``.

    Builds first (which renders) when the outputs are missing or were made from other
    parameters or another hwgen version; otherwise draws into the existing folder and rewrites
    its manifest. Returns (the manifest's render entry, the folder, why it was rebuilt or None).
    """
    from .build import stale_reason
    from .design import plan as make_plan
    from .export import write_json

    folder = Path(out_root) / loaded.design.design
    why = stale_reason(folder, loaded)
    if why is not None:
        from .build import build
        result = build(loaded, Path(out_root))
        return result.manifest.get("render", {}), folder, why
    manifest = json.loads((folder / "manifest.json").read_text())
    step(make_plan(loaded.design), folder, manifest)
    tmp = folder / f".manifest.json.{os.getpid()}.tmp"
    write_json(manifest, tmp)
    os.replace(tmp, folder / "manifest.json")
    return manifest["render"], folder, None


if __name__ == "__main__":
    sys.exit(_child_main())
