"""The throated wheel with its spool drum, and the clamp plate that pinches a tendon on it.

The throated wheel: a blank of revolution minus one tooth-space tool per tooth. A tool's
flanks and root are one bicubic B-spline surface through the tooth-space outlines that
:meth:`WormPair.level_outline` generates plane by plane (the same points and parameters at
every level), closed by a ruled top above the blank and two planar caps. Every tooth space is
the same, so the cut is made once, in one tooth's sector of the blank, and the sector turned
round (the blank minus every tool in one boolean, ten times the work, only where that fails).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import cadquery as cq
import numpy as np
from OCP.BOPAlgo import BOPAlgo_GlueFull
from OCP.BRep import BRep_Tool
from OCP.BRepAlgoAPI import BRepAlgoAPI_Fuse
from OCP.BRepBuilderAPI import (BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakeSolid,
                                BRepBuilderAPI_MakeWire, BRepBuilderAPI_Sewing)
from OCP.BRepFill import BRepFill
from OCP.ShapeFix import ShapeFix_Solid
from OCP.ShapeUpgrade import ShapeUpgrade_UnifySameDomain
from OCP.TopExp import TopExp
from OCP.TopTools import TopTools_ListOfShape
from OCP.TopoDS import TopoDS

from ..model.gearing import GearDesignError, WormPair
from ..model.tensioner_layout import Fastening, TensionerLayout, Unit
from ..model.hardware import NUT_PLAY
from ..model.tensioner_layout import sizes
from ..model.tensioner_layout.sizes import ANCHOR_HOLE, CLAMP_PLATE, M2_CLEARANCE, NUT, PIN_ENGAGE
from . import location
from .bspline import interpolating_surface
from .primitives import TOOL, cylinder, hex_prism, one

CLAMP_ANGLE = 90.0       # where on the wheel face the clamp sits, deg from the tooth on +X
GEAR_LEVELS = 11          # transverse planes interpolated over the face (+ TOOL_OVERRUN each side)
GEAR_FLANK_POINTS = 16    # outline points per flank and level (≤ 2.6 µm from the envelope)
GEAR_ROOT_POINTS = 7      # outline points on the root arc
TOOL_OVERRUN = 0.4        # the tooth-space tool reaches this far beyond each face, mm
TOOL_TOP_MARGIN = 0.2     # the tool's top above the outside radius, mm (halved until neighbours stay apart)
TOOL_MIN_LAND = 0.05      # tooth left between two neighbouring tools at their top, mm
SURFACE_TOL = 1e-7        # face made on the interpolated surface, mm
SEWING_TOL = 1e-6         # sewing the tool's faces into a shell, mm


def _v(x, y, z=0.0) -> cq.Vector:
    return cq.Vector(float(x), float(y), float(z))



def _blank(pair: WormPair) -> cq.Solid:
    """The wheel's blank, mid-plane at Z = 0: throat torus about the worm axis, outside
    cylinder, 45° rim chamfers; its half-section in the XZ plane revolved about Z."""
    h, ch, ro = pair.face_width / 2, pair.rim_chamfer, pair.outside_radius
    zo = pair.z_outside
    band = zo < h - ch                       # the outside cylinder is reached inside the face
    if band and zo < 1e-3:
        raise GearDesignError("wheel throat never rises: the outside radius equals the throat radius")
    throat = _v(pair.ra2, 0, 0)
    if band:
        edge = ro
        rim = [cq.Edge.makeLine(_v(edge - ch, 0, -h), _v(edge, 0, -h + ch)),
               cq.Edge.makeLine(_v(edge, 0, -h + ch), _v(ro, 0, -zo)),
               cq.Edge.makeThreePointArc(_v(ro, 0, -zo), throat, _v(ro, 0, zo)),
               cq.Edge.makeLine(_v(ro, 0, zo), _v(edge, 0, h - ch)),
               cq.Edge.makeLine(_v(edge, 0, h - ch), _v(edge - ch, 0, h))]
    else:                                    # the face edge lies on the torus: chamfer down to it
        edge, zc = float(pair.tip_radius(h)), h - ch
        rc = float(pair.tip_radius(zc))
        rim = [cq.Edge.makeLine(_v(edge - ch, 0, -h), _v(rc, 0, -zc)),
               cq.Edge.makeThreePointArc(_v(rc, 0, -zc), throat, _v(rc, 0, zc)),
               cq.Edge.makeLine(_v(rc, 0, zc), _v(edge - ch, 0, h))]
    edges = [cq.Edge.makeLine(_v(0, 0, -h), _v(edge - ch, 0, -h)), *rim,
             cq.Edge.makeLine(_v(edge - ch, 0, h), _v(0, 0, h)), cq.Edge.makeLine(_v(0, 0, h), _v(0, 0, -h))]
    face = cq.Face.makeFromWires(cq.Wire.assembleEdges(edges))
    return cq.Solid.revolve(face, 360.0, _v(0, 0, 0), _v(0, 0, 1))


def _tool_top(pair: WormPair, levels: np.ndarray) -> float:
    """The tool's top radius, the same at every level (a top that followed the throat would
    kink the outlines' radial spacing where throat and cylinder meet, and the interpolation
    would carry the kink into the flanks): TOOL_TOP_MARGIN above the outside radius, halved
    until the tooth left between two tools is TOOL_MIN_LAND thick there at every level."""
    margin = TOOL_TOP_MARGIN
    while margin > 0.02:
        top = pair.outside_radius + margin
        if all(2 * top * pair.tooth_half_angles(float(z), [top])[1][0] > TOOL_MIN_LAND for z in levels[::2]):
            break
        margin /= 2
    return pair.outside_radius + margin



def _tooth_space_tool(pair: WormPair) -> cq.Solid:
    """One tooth-space tool (the space centred near π/z2, mid-plane at Z = 0), a closed solid."""
    h = pair.face_width / 2 + TOOL_OVERRUN
    zs = np.linspace(-h, h, GEAR_LEVELS)
    top = _tool_top(pair, zs)
    outlines = np.array([pair.level_outline(z, top, GEAR_FLANK_POINTS, GEAR_ROOT_POINTS) for z in zs])
    seg = np.linalg.norm(np.diff(outlines, axis=1), axis=2)         # one chord-length parameter set for all
    u = np.concatenate([np.zeros((len(zs), 1)), np.cumsum(seg, axis=1)], axis=1)
    u = (u / u[:, -1:]).mean(axis=0)
    P = np.concatenate([outlines, np.broadcast_to(zs[:, None, None], outlines.shape[:2] + (1,))], axis=2)
    surf = interpolating_surface(np.ascontiguousarray(P.transpose(1, 0, 2)), u, (zs + h) / (2 * h))
    u0, u1, v0, v1 = surf.Bounds()

    def iso(along_u: bool, val: float):
        return BRepBuilderAPI_MakeEdge(surf.UIso(val) if along_u else surf.VIso(val)).Edge()
    sew = BRepBuilderAPI_Sewing(SEWING_TOL)
    sew.Add(BRepBuilderAPI_MakeFace(surf, SURFACE_TOL).Face())
    sew.Add(BRepFill.Face_s(iso(True, u0), iso(True, u1)))          # the ruled top
    for val in (v0, v1):                                              # planar caps beyond the faces
        e = iso(False, val)
        a, b = BRep_Tool.Pnt_s(TopExp.FirstVertex_s(e)), BRep_Tool.Pnt_s(TopExp.LastVertex_s(e))
        sew.Add(BRepBuilderAPI_MakeFace(BRepBuilderAPI_MakeWire(e, BRepBuilderAPI_MakeEdge(b, a).Edge()).Wire(),
                                        True).Face())
    sew.Perform()
    fix = ShapeFix_Solid(BRepBuilderAPI_MakeSolid(TopoDS.Shell_s(sew.SewedShape())).Solid())
    fix.Perform()
    tool = cq.Solid(fix.Solid())
    if tool.Volume() < 0:
        tool = cq.Solid(tool.wrapped.Reversed())
    if not tool.isValid():
        raise GearDesignError("the wheel's tooth-space tool is not a valid solid")
    return tool


@lru_cache(maxsize=8)
def gear_solid(pair: WormPair) -> cq.Solid:
    """Throated worm wheel generated by the pair's worm thread, file Z from 0 to the face
    width, a tooth centred on +X at mid-width. Built once per distinct pair: one tooth's
    sector cut by one tooth-space tool and turned round (:func:`_by_sectors`), or, where the
    tool reaches past its sector's sides, the blank minus every tool in one boolean
    (:func:`_whole_cut`, far costlier). One valid solid (loose chips of the
    tooth spaces' tops dropped) or :class:`GearDesignError`."""
    tool = _tooth_space_tool(pair)
    wheel = _by_sectors(pair, tool)
    if wheel is None:
        wheel = _whole_cut(pair, tool)
    return wheel.translate(_v(0, 0, pair.face_width / 2))


def _one_piece(pieces: list[cq.Solid], pair: WormPair, what: str) -> cq.Solid:
    """The largest of what a cut left. The tool's top is a chord between its corners; where
    the tooth tips leave little room above the outside radius, the chord dips under it
    mid-space and leaves a loose chip of the outside band on each side of the throat. Chips
    lie wholly beyond the throat radius and belong to the space anyway; a loose piece reaching
    further in (a lost tooth) is an error."""
    pieces = sorted(pieces, key=lambda s: s.Volume())
    if not pieces or any(min(math.hypot(v.X, v.Y) for v in s.Vertices()) <= pair.ra2 for s in pieces[:-1]):
        raise GearDesignError(f"{what} came out in {len(pieces)} pieces, expected one solid")
    return pieces[-1]


def _whole_cut(pair: WormPair, tool: cq.Solid) -> cq.Solid:
    """The blank minus all the tooth-space tools in one boolean, mid-plane at Z = 0."""
    step = 360.0 / pair.teeth
    tools = [tool] + [tool.rotate(_v(0, 0, 0), _v(0, 0, 1), k * step) for k in range(1, pair.teeth)]
    wheel = _one_piece(_blank(pair).cut(*tools).Solids(), pair, "the wheel")
    if not wheel.isValid():
        raise GearDesignError("the wheel is not a valid solid")
    return wheel


SECTOR_AREA_TOL = 1e-9     # relative: a sector's sides are untouched by its tool when their area is
SECTOR_MAX_SLABS = 9       # most slabs a sector's sides are stepped in to follow the teeth's twist
SECTOR_SIDE_ROOM = 0.75    # a side keeps within this fraction of the tooth's half-angle of its centre
SECTOR_SAMPLES = 5         # levels per slab (ends included) at which that is required


def _by_sectors(pair: WormPair, tool: cq.Solid) -> cq.Solid | None:
    """The wheel as teeth copies of one sector: the blank between two sides that pass through
    neighbouring teeth, minus the one tool between them, turned round and glued face to face,
    the faces on one surface then made one again (no seams between sectors). Its tooth spaces
    are the very ones the whole cut makes. The teeth twist across the face by the lead angle,
    so a side is stepped: in slabs along Z, each a half-plane through the axis at the angle
    that keeps it in the tooth's middle over its slab (:func:`_slabs`). None where this does
    not hold: no few slabs keep inside the teeth, the tool still reaches a side (the sides
    lose area in the cut), or the glued copies are not one valid solid."""
    slabs = _slabs(pair)
    if slabs is None:
        return None
    step = 360.0 / pair.teeth
    blank = _blank(pair).rotate(_v(0, 0, 0), _v(0, 0, 1), 180.0)     # its seams away from the sector
    sector = blank.intersect(_wedge(pair, slabs, step))
    piece = _one_piece(sector.cut(tool).Solids(), pair, "a tooth's sector")
    sides = _side_area(sector, pair)
    if abs(_side_area(piece, pair) - sides) > SECTOR_AREA_TOL * sides:
        return None
    copies = [piece.rotate(_v(0, 0, 0), _v(0, 0, 1), k * step) for k in range(pair.teeth)]
    glue = BRepAlgoAPI_Fuse()
    glue.SetArguments(_shapes(copies[:1]))
    glue.SetTools(_shapes(copies[1:]))
    glue.SetGlue(BOPAlgo_GlueFull)              # neighbours share whole faces and nothing else
    glue.Build()
    if not glue.IsDone():
        return None
    unify = ShapeUpgrade_UnifySameDomain(glue.Shape(), True, True, False)
    unify.Build()
    solids = cq.Shape.cast(unify.Shape()).Solids()
    if len(solids) != 1 or not solids[0].isValid():
        return None
    return solids[0]


def _slabs(pair: WormPair) -> list[tuple[float, float, float]] | None:
    """(z from, z to, angle in degrees) of the fewest equal slabs (an odd count, at most
    SECTOR_MAX_SLABS) across the face in each of which one half-plane through the axis stays
    within SECTOR_SIDE_ROOM of the tooth's half-angle of its centre, at the pitch and tip radii
    of SECTOR_SAMPLES levels; the angle is the middle of what every level allows. The end
    slabs reach TOOL beyond the faces. None if no count does."""
    h = pair.face_width / 2
    for n in range(1, SECTOR_MAX_SLABS + 1, 2):
        edges = np.linspace(-h, h, n + 1)
        slabs = []
        for z0, z1 in zip(edges[:-1], edges[1:]):
            lo, hi = -math.inf, math.inf
            for z in np.linspace(z0, z1, SECTOR_SAMPLES):
                centre, half = pair.tooth_half_angles(float(z), [pair.r2, float(pair.tip_radius(z))])
                lo = max(lo, float(np.max(centre - SECTOR_SIDE_ROOM * half)))
                hi = min(hi, float(np.min(centre + SECTOR_SIDE_ROOM * half)))
            if lo > hi:
                break
            slabs.append((float(z0), float(z1), math.degrees((lo + hi) / 2)))
        else:
            z0, z1, angle = slabs[0]
            slabs[0] = (z0 - TOOL, z1, angle)
            z0, z1, angle = slabs[-1]
            slabs[-1] = (z0, z1 + TOOL, angle)
            return slabs
    return None


def _wedge(pair: WormPair, slabs: list[tuple[float, float, float]], step: float) -> cq.Solid:
    """The sector's room: per slab, a prism between the half-planes at its angle and ``step``
    degrees on (a triangle whose far side stays outside the blank, extruded), stacked."""
    r = 2 * pair.outside_radius / math.cos(math.radians(step / 2))
    prisms = []
    for z0, z1, angle in slabs:
        a, b = math.radians(angle), math.radians(angle + step)
        base = cq.Face.makeFromWires(cq.Wire.makePolygon(
            [_v(0, 0, z0), _v(r * math.cos(a), r * math.sin(a), z0), _v(r * math.cos(b), r * math.sin(b), z0)], close=True))
        prisms.append(cq.Solid.extrudeLinear(base, _v(0, 0, z1 - z0)))
    return prisms[0] if len(prisms) == 1 else prisms[0].fuse(*prisms[1:])


def _side_area(solid: cq.Shape, pair: WormPair) -> float:
    """Area of the solid's faces on its sector's sides: the planes through the Z axis, and the
    planes across it between the faces (where the sides step)."""
    h = pair.face_width / 2
    total = 0.0
    for f in solid.Faces():
        if f.geomType() != "PLANE":
            continue
        n, c = f.normalAt(), f.Center()
        through_axis = abs(n.z) < 1e-9 and abs(n.x * c.x + n.y * c.y) < 1e-7
        across = abs(abs(n.z) - 1) < 1e-9 and abs(c.z) < h - 1e-6
        if through_axis or across:
            total += f.Area()
    return total


def _shapes(solids: list[cq.Solid]) -> TopTools_ListOfShape:
    out = TopTools_ListOfShape()
    for s in solids:
        out.Append(s.wrapped)
    return out


def clamp_site(lay: TensionerLayout) -> float:
    """Radius on the wheel face of the clamp's screw, mm: midway between flange and tooth root,
    or nearer the flange if the nut trap would otherwise reach the root."""
    return _clamp_radius(lay.flange_radius, lay.pair.rf2)


def _clamp_radius(flange_radius: float, rf2: float) -> float:
    e = (NUT["M2"][0] + NUT_PLAY) / math.sqrt(3)
    return min((flange_radius + rf2) / 2, rf2 - e - 1.0)


def clamp_joint(lay: TensionerLayout, unit: Unit, zc: float) -> Fastening:
    """The clamp's M2 screw: through the plate into the gear, or into the end cap it sits on."""
    return sizes.clamp_joint(lay.fastening, sizes.clamp_on_cap(unit.caps, zc), lay.pair.face_width)


@dataclass(frozen=True)
class WheelSpec:
    """Everything a throated wheel is made from (:func:`wheel_solid`), along its axis from its own
    end (Z = robot z - unit.z_part[0]) and nothing of where the layout puts it: the key it is kept
    under (:func:`hwgen.cad.memo.kept`), so that an edit that moves the tensioner but not a
    channel's stack of drum, flanges and clamps finds its wheel made. Each length is the very
    difference the wheel was built from when it read the layout (f0 - z_lo, f1 - f0, ...), so
    the solid is the same to the last bit."""
    pair: WormPair
    fastening: str
    hub_radius: float
    flange_radius: float
    spool_radius: float
    pin_bore: float
    height: float                                  # z_part[1] - z_part[0]
    gear_at: float                                 # z_gear[0] - z_part[0]
    flanges: tuple[tuple[float, float], ...]       # (start from the end, length)
    caps: tuple[tuple[float, float], ...]          # (start from the end, length)
    clamps: tuple[tuple[float, int, bool, tuple[float, float]], ...]
    #                                                (face from the end, side, on an end cap, the flange
    #                                                 or cap its anchor hole goes through)
    gear_on_top: bool

    def alike(self) -> WheelSpec:
        """The spec with every length rounded to 1e-6 mm: channels whose stacks differ only in the
        rounding of their positions (the same drum, flanges and clamps) have one wheel, made from the
        spec of whichever comes first, in whichever process; the key it is kept and shared under."""
        def mm(x):
            return round(float(x), 6) + 0.0

        return WheelSpec(pair=self.pair, fastening=self.fastening, hub_radius=mm(self.hub_radius),
                         flange_radius=mm(self.flange_radius), spool_radius=mm(self.spool_radius),
                         pin_bore=mm(self.pin_bore), height=mm(self.height), gear_at=mm(self.gear_at),
                         flanges=tuple((mm(a), mm(b)) for a, b in self.flanges),
                         caps=tuple((mm(a), mm(b)) for a, b in self.caps),
                         clamps=tuple((mm(z), s, cap, (mm(a), mm(b))) for z, s, cap, (a, b) in self.clamps),
                         gear_on_top=self.gear_on_top)


def wheel_spec(lay: TensionerLayout, unit: Unit, pin_bore: float) -> WheelSpec:
    """The wheel of ``unit`` as ``lay`` lays it out, bored for pins of ``pin_bore``."""
    z_lo = unit.z_part[0]
    flanges = tuple((float(f0 - z_lo), float(f1 - f0)) for f0, f1 in unit.flanges)
    caps = tuple((float(c0 - z_lo), float(c1 - c0)) for c0, c1 in unit.caps)
    clamps = []
    for zc, s in unit.clamps:
        # the anchor hole: on an end cap through the cap; on the gear's face through the flange nearest to it
        cap = next((k for k, c in enumerate(unit.caps) if c[0] - 1e-9 <= zc <= c[1] + 1e-9), None)
        anchor = caps[cap] if cap is not None else \
            flanges[min(range(len(unit.flanges)), key=lambda k: abs((unit.flanges[k][0] + unit.flanges[k][1]) / 2 - zc))]
        clamps.append((float(zc - z_lo), int(s), cap is not None, anchor))
    return WheelSpec(pair=lay.pair, fastening=lay.fastening, hub_radius=float(lay.hub_radius),
                     flange_radius=float(lay.flange_radius), spool_radius=float(lay.spool_radius),
                     pin_bore=float(pin_bore), height=float(unit.z_part[1] - z_lo),
                     gear_at=float(unit.z_gear[0] - z_lo), flanges=flanges, caps=caps, clamps=tuple(clamps),
                     gear_on_top=bool(unit.gear_on_top))


def wheel_solid(spec: WheelSpec, gear: cq.Solid) -> cq.Solid:
    """Gear + spool drum + flanges (+ end cap), bored for the pins, the clamps' screws (a nut
    trap from the far face, or an insert bore) and the tendons' anchor holes. Built with
    Z from the wheel's own end, then turned over when the gear is on top so that its face
    rests on the plate."""
    pair = spec.pair
    height = spec.height
    pieces = [gear.translate(cq.Vector(0, 0, spec.gear_at))]
    pieces.append(cq.Solid.makeCylinder(spec.hub_radius, height, cq.Vector(0, 0, 0)))
    for at, length in spec.flanges:
        pieces.append(cq.Solid.makeCylinder(spec.flange_radius, length, cq.Vector(0, 0, at)))
    for at, length in spec.caps:
        pieces.append(cq.Solid.makeCylinder(pair.rf2, length, cq.Vector(0, 0, at)))
    body = pieces[0].fuse(*pieces[1:])
    tools = [cq.Solid.makeCylinder(spec.pin_bore / 2, height + 2 * TOOL, cq.Vector(0, 0, -TOOL))]
    rc = _clamp_radius(spec.flange_radius, pair.rf2)
    ang = math.radians(CLAMP_ANGLE)
    at = np.array([rc * math.cos(ang), rc * math.sin(ang)])
    for zf, s, on_cap, _ in spec.clamps:
        j = sizes.clamp_joint(spec.fastening, on_cap, pair.face_width)
        if j.kind == "nut":
            # through the body, and a trap from its far face (where the nut goes in) to the nut's near face
            tools.append(cylinder(j.hole / 2, (*at, zf + s * TOOL), (*at, zf - s * (j.body + TOOL))))
            tools.append(hex_prism(NUT["M2"][0] + NUT_PLAY, (*at, zf - s * (j.body + TOOL)), (*at, zf - s * j.nut_from),
                              (math.cos(ang), math.sin(ang), 0.0)))
        else:
            tools.append(cylinder(j.hole / 2, (*at, zf + s * TOOL), (*at, zf - s * j.depth)))
    tools += _lightening(spec)
    # anchor holes: through the flange between each winding zone and its clamp face
    r_anchor = spec.spool_radius + ANCHOR_HOLE / 2 + 0.3
    for _, _, _, (f_at, f_length) in spec.clamps:
        tools.append(cq.Solid.makeCylinder(ANCHOR_HOLE / 2, f_length + 2 * TOOL,
                                           cq.Vector(r_anchor * math.cos(ang), r_anchor * math.sin(ang),
                                                     f_at - TOOL)))
    solid = one(body.cut(*tools), GearDesignError)
    if spec.gear_on_top:
        flip = np.eye(4)            # TensionerLayout.wheel_flip: 180° about X, back onto Z = 0
        flip[1, 1] = flip[2, 2] = -1.0
        flip[2, 3] = height
        solid = one(solid.moved(location(flip)), GearDesignError)
    return solid


LIGHTENING_WALL = 1.2        # resin left around a lightening hole or inside a hollow drum, mm
LIGHTENING_HOLE = 6.0        # Ø of the holes through the gear between its hub and its root, mm


def _lightening(spec: WheelSpec) -> list[cq.Solid]:
    """Material the wheel does not need: the drum core hollow between the dowels' ends (the
    hollow opens into the pin bore at both ends, so resin drains), and holes through the gear
    between hub and tooth root, away from the clamp's nut and the anchor hole."""
    out = []
    engaged = PIN_ENGAGE + 1.0
    height = spec.height
    r_in = spec.hub_radius - LIGHTENING_WALL
    if height > 2 * engaged + 2 and r_in > spec.pin_bore / 2 + 0.5:
        out.append(cq.Solid.makeCylinder(r_in, height - 2 * engaged, cq.Vector(0, 0, engaged)))
    r0 = spec.hub_radius + LIGHTENING_WALL + LIGHTENING_HOLE / 2
    if r0 + LIGHTENING_HOLE / 2 + LIGHTENING_WALL <= spec.pair.rf2:
        z0 = spec.gear_at
        for deg in (CLAMP_ANGLE + 90, CLAMP_ANGLE + 180, CLAMP_ANGLE + 270):      # the clamp is at CLAMP_ANGLE
            a = math.radians(deg)
            out.append(cq.Solid.makeCylinder(LIGHTENING_HOLE / 2, spec.pair.face_width + 2 * TOOL,
                                              cq.Vector(r0 * math.cos(a), r0 * math.sin(a), z0 - TOOL)))
    return out


def clamp_solid() -> cq.Solid:
    """Clamp plate: the tendon, led out of the anchor hole, is pinched under it by an M2 screw."""
    x, y, t = CLAMP_PLATE
    plate = cq.Solid.makeBox(x, y, t, cq.Vector(-x / 2, -y / 2, 0))
    hole = cq.Solid.makeCylinder(M2_CLEARANCE / 2, t + 2 * TOOL, cq.Vector(0, 0, -TOOL))
    return one(plate.cut(hole), GearDesignError)

