"""Offscreen VTK drawing (no display, no GPU): one window reused for every picture of a
process, parallel projections, shaded parts with their edges, tendon tubes and text."""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .. import heap
from ..options import BACKEND_ENV
from .scene import Posed, transform

SMOOTH_ANGLE_DEG = 20.0     # shading is smooth across edges flatter than this (STL facets are 11.5°)
TENDON_TUBE_MM = 0.7        # drawn radius of a tendon (the real 0.075 mm would be invisible)
BACKGROUND = (1.0, 1.0, 1.0)
TEXT_COLOUR = (0.12, 0.12, 0.12)


class RenderUnavailable(RuntimeError):
    """No offscreen OpenGL backend: the message says what failed and what to install."""


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


def _surface(V, F):
    """A part's triangles with their normals, split along edges sharper than SMOOTH_ANGLE_DEG:
    what a surface actor draws. The filter runs once here; the result can be drawn again."""
    _, dm, filters, _ = _vtk()
    normals = filters.vtkPolyDataNormals()
    normals.SetInputData(_polydata(V, F))
    normals.SetFeatureAngle(SMOOTH_ANGLE_DEG)
    normals.SplittingOn()
    normals.ConsistencyOff()
    normals.Update()
    out = dm.vtkPolyData()
    out.ShallowCopy(normals.GetOutput())
    return out


def _moved(surface, matrix: np.ndarray):
    """A surface (points, normals, triangles) moved rigidly by a 4x4 matrix: its points and normals
    turned, its triangles and the split along its sharp edges as they were."""
    from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
    core, dm, _, _ = _vtk()
    R = matrix[:3, :3]
    out = dm.vtkPolyData()
    out.ShallowCopy(surface)
    pts = core.vtkPoints()
    pts.SetData(numpy_to_vtk(transform(vtk_to_numpy(surface.GetPoints().GetData()), matrix), deep=True))
    out.SetPoints(pts)
    n0 = surface.GetPointData().GetNormals()
    n = numpy_to_vtk(np.ascontiguousarray(vtk_to_numpy(n0).astype(np.float64) @ R.T, dtype=np.float32), deep=True)
    n.SetName(n0.GetName())
    out.GetPointData().SetNormals(n)        # the copy's own point data: the part's surface keeps its normals
    return out


def _is_rotation(R: np.ndarray) -> bool:
    return bool(np.allclose(R.T @ R, np.eye(3), atol=1e-9) and np.linalg.det(R) > 0)


def _posed_surface(ps: Posed):
    """The surface a pose is drawn with, made once per pose; a rigid pose's is the part's own
    (made once per part, in its file's coordinates) moved."""
    if "surface" not in ps.drawn:
        if ps.matrix is not None and _is_rotation(ps.matrix[:3, :3]):
            own = ps.part.drawn.get("surface")
            if own is None:
                own = ps.part.drawn["surface"] = _surface(ps.part.vertices, ps.part.faces)
            ps.drawn["surface"] = _moved(own, ps.matrix)
        else:
            ps.drawn["surface"] = _surface(ps.vertices, ps.faces)
    return ps.drawn["surface"]


def _surface_actor(surface, rgb, shading: bool = True):
    _, _, _, rc = _vtk()
    mapper = rc.vtkPolyDataMapper()
    mapper.SetInputData(surface)
    actor = rc.vtkActor()
    actor.SetMapper(mapper)
    prop = actor.GetProperty()
    # a part's faces turned away from the camera are never seen: its mesh is closed and wound
    # outward (checks/parts.py fails any part that is open or inside out), so its near side covers
    # them. They are not rasterised; the pixels and the SVG's depth buffer are the same
    prop.BackfaceCullingOn()
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


class Look(NamedTuple):
    """How :meth:`Renderer.draw` frames and draws a picture."""

    aspect_range: tuple[float, float] = (0.45, 1.3)   # height over width, clipped to this
    margin: float = 0.04            # around the drawn points, of their extent
    edges: bool = True              # the parts' sharp edges drawn as lines
    shading: bool = True            # lit faces (else flat colour, no anti-aliasing)
    width: int | None = None        # pixels (None: the renderer's)


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
             tubes: dict[str, tuple[np.ndarray, tuple]] | None = None, texts=(), labels=(), look: Look = Look()):
        """Draw posed parts (and tendon tubes), write a PNG when a path is given.

        Returns (renderer, width, height) so a caller can read the depth buffer.
        """
        aspect_range, margin, edges, shading, width = look
        rc = self.rc
        self.release()                  # the last picture's scene goes before this one is built
        ren = rc.vtkRenderer()
        ren.SetBackground(*BACKGROUND)
        lw = max(1.0, self.width / 1000)
        for ps in posed:
            rgb = colours[ps.part.role]
            ren.AddActor(_surface_actor(_posed_surface(ps), rgb, shading))
            if edges and len(ps.edges):
                ren.AddActor(_line_actor(ps.edges, edge_colour(rgb), lw))
        for pts, rgb in (tubes or {}).values():
            ren.AddActor(_tube_actor(pts, rgb, TENDON_TUBE_MM))
        allpts = np.vstack([ps.vertices for ps in posed] + [pts for pts, _ in (tubes or {}).values()]
                           + [np.asarray([lb[1] for lb in labels]).reshape(-1, 3)])
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
        self.window.AddRenderer(ren)
        self.window.SetSize(W, H)
        if labels:
            # the camera (set by _fit) and the window's size map world points to the screen: no
            # render is needed before (the labels land on the same pixels)
            for text, point, *rgb in labels:
                # (text, point): centred on it; (text, point, colour): a callout starting there, on white
                ren.SetWorldPoint(*point, 1.0)
                ren.WorldToDisplay()
                x, y, _ = ren.GetDisplayPoint()
                t = rc.vtkTextActor()
                t.SetInput(text)
                t.GetTextProperty().SetColor(*(rgb[0] if rgb else TEXT_COLOUR))
                t.GetTextProperty().SetFontSize(int(24 * self.width / 1800))
                t.GetTextProperty().BoldOn()
                if rgb:
                    t.GetTextProperty().SetJustificationToLeft()
                    t.GetTextProperty().SetBackgroundColor(*BACKGROUND)
                    t.GetTextProperty().SetBackgroundOpacity(0.8)
                else:
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
        heap.trim()                     # what building and drawing the scene freed
        return ren, W, H

    def release(self) -> None:
        """Drop the scene of the last picture (its actors, meshes and the driver's copies of them)
        and hand the freed heap back to the system: a process that draws one picture after another
        then holds one scene at a time, not the largest it ever drew plus what the heap kept."""
        self.window.GetRenderers().RemoveAllItems()
        heap.trim()

    def rgb(self, W: int, H: int) -> np.ndarray:
        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkCommonCore import vtkUnsignedCharArray
        arr = vtkUnsignedCharArray()
        self.window.GetPixelData(0, 0, W - 1, H - 1, 0, arr, 0)
        img = vtk_to_numpy(arr).reshape(H, W, -1)[:, :, :3]
        return img[::-1].copy()     # OpenGL rows run bottom-up

    def depth(self, W: int, H: int, rows_up: bool = False) -> np.ndarray:
        """Depth buffer (H, W), rows top-down (``rows_up``: bottom-up, as OpenGL reads them, and
        not copied), values 0 (near) .. 1 (far/background)."""
        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkCommonCore import vtkFloatArray
        arr = vtkFloatArray()
        self.window.GetZbufferData(0, 0, W - 1, H - 1, arr)
        z = vtk_to_numpy(arr).reshape(H, W)
        return z if rows_up else z[::-1].copy()




# zlib's level for the PNGs: on the shipped designs' pictures, level 9 (Pillow's optimize=True)
# made files a few per cent smaller for about four times the CPU. The pixels are the same at any level.
PNG_COMPRESS_LEVEL = 6


def write_png(img: np.ndarray, path: Path) -> None:
    from PIL import Image
    Image.fromarray(img).save(path, compress_level=PNG_COMPRESS_LEVEL)
