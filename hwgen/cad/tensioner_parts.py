"""Tensioner solids: worm, drive shaft, wheel with spool, tendon clamp and housing.

The numbers come from :mod:`hwgen.model.gearing` (tooth and thread forms) and
:mod:`hwgen.model.tensioner_layout` (where everything sits); this module only turns them into
CadQuery solids. Identical geometry is built once: one worm, one drive shaft and one clamp for
every channel, one wheel per distinct spool layout.

Print orientations (each part's file is in it; see the README): worm and drive shaft stand on
an end face, axis along file Z, every bore open at both ends; the wheel stands on its gear's
face; the clamp plate lies flat; the housing stands on its base bars (the face that bolts to
the tip disk), file (X, Y, Z) = robot (x, -z, y - y_face), its windows' roofs at 45°.

Assembly, as the geometry allows it: nuts into their traps (resin) or inserts melted in
(thermoplastic); each worm dropped in between its far post and the spine, its dowel pressed
through the post into the worm's far bore, the drive shaft pushed from outside through the
spine into the worm's hex bore; each wheel between its shelf and bar, its two dowels pressed
in from outside; housing onto the tip disk (M3 screws from the disk's inner face) with the
strip's tip in its slot, set screws down on the strip; tendons wound, led through the anchor
hole and pinched under the clamp plate by its M2 screw.
"""
from __future__ import annotations

import math
from collections.abc import Iterator
from functools import lru_cache

import cadquery as cq
import numpy as np
from OCP.BRep import BRep_Tool
from OCP.BRepBuilderAPI import (BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakeSolid,
                                BRepBuilderAPI_MakeWire, BRepBuilderAPI_Sewing)
from OCP.BRepFill import BRepFill
from OCP.Geom import Geom_BSplineSurface
from OCP.gp import gp_Pnt
from OCP.ShapeFix import ShapeFix_Solid
from OCP.TColgp import TColgp_Array2OfPnt
from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal
from OCP.TopExp import TopExp
from OCP.TopoDS import TopoDS

from ..model.gearing import GearDesignError, WormPair
from ..model.tensioner_layout import Fastening, TensionerLayout, Unit, joint, tip_joint
from ..model.tensioner_layout.sizes import (ANCHOR_HOLE, AXIAL_PLAY, CAP, CLAMP_PLATE, CLAMP_SCREW, DRIVE_FLANGE,
                                            DRIVE_HEX, DRIVE_HEX_LENGTH, DRIVE_SHAFT, NUT, NUT_PLAY, PIN_ENGAGE, POST,
                                            WORM_END)
from . import DISK_ROTATION, Part, location, placement
from .memo import kept

WORM_COLOR = (0.75, 0.76, 0.78, 1.0)
WHEEL_COLOR = (0.30, 0.55, 0.85, 1.0)
CLAMP_COLOR = (0.90, 0.45, 0.20, 1.0)
HOUSING_COLOR = (0.55, 0.58, 0.52, 1.0)
DRIVE_COLOR = (0.80, 0.40, 0.60, 1.0)
ROOT_OVERLAP = 0.05      # thread root sunk into the worm core so the fuse has no seam, mm
HEX_DEPTH = 5.0          # depth of the hex key's socket, mm (a 2.5 mm key engages fully at 5 mm)
FAR_CHAMFER = 1.0        # 45° chamfer on the worm's far end, mm
VENT = 1.2               # through every blind bore: resin drains and no cup forms while printing, mm
HEX_CLEARANCE = 0.1      # across flats over the key, mm
TOOL = 1.0               # cutting tools overrun faces by this much, mm
CLAMP_ANGLE = 90.0       # where on the wheel face the clamp sits, deg from the tooth on +X


def _wire(points) -> cq.Wire:
    return cq.Wire.makePolygon([cq.Vector(*p) for p in points], close=True)


# ---- worm and its drive shaft -------------------------------------------------------------
def worm_solid(pair: WormPair, near_end: float, hex_bore: float, pin_bore: float, pin_depth: float) -> cq.Solid:
    """Worm along file Z: plain core from Z = 0 (the face that bears on the spine) to the
    thread, the threaded length, a plain far end bored for the dowel it turns on. A hex bore
    from Z = 0 takes the drive shaft; a small vent joins it to the dowel bore, so no blind
    hole traps resin. The thread is the trapezoid axial profile swept along a helix (right
    hand), one sweep per start."""
    L = pair.worm_length
    z0 = near_end
    length = near_end + L + WORM_END
    prof = pair.worm_axial_profile(ROOT_OVERLAP)
    start = z0 + pair.pitch / 2
    wire = _wire([(r, 0, start + dz) for r, dz in prof])
    helix = cq.Wire.makeHelix(pair.lead, L - pair.pitch, pair.r1, center=cq.Vector(0, 0, start))
    thread = cq.Solid.sweep(wire, [], helix, makeSolid=True, isFrenet=True)
    threads = [thread] + [thread.rotate(cq.Vector(), cq.Vector(0, 0, 1), 360.0 * j / pair.starts)
                          for j in range(1, pair.starts)]
    # the far end is chamfered: it bears on the post, and the face that prints on the plate
    # (Z = 0) stays the largest flat face
    c = FAR_CHAMFER
    core = cq.Solid.makeCylinder(pair.rf1, length - c, cq.Vector(0, 0, 0)).fuse(
        cq.Solid.makeCone(pair.rf1, pair.rf1 - c, c, cq.Vector(0, 0, length - c)))
    body = core.fuse(*threads)
    socket = _hex(hex_bore, (0, 0, -TOOL), (0, 0, DRIVE_HEX_LENGTH + 0.5), (1, 0, 0))
    bore = cq.Solid.makeCylinder(pin_bore / 2, pin_depth + TOOL, cq.Vector(0, 0, length - pin_depth))
    vent = cq.Solid.makeCylinder(VENT / 2, length, cq.Vector(0, 0, 0))
    return _one(body.cut(socket, bore, vent))


def drive_solid(lay: TensionerLayout) -> cq.Solid:
    """The drive shaft, file Z from its flange's outer face: the flange (it stops the shaft
    against the spine) with the hex key's socket, the shaft that turns in the spine's hole,
    and the hex end pressed into the worm."""
    fd, ft = DRIVE_FLANGE
    shaft_len = lay.spine[1] - lay.spine[0] + AXIAL_PLAY / 2
    # pieces overlap 0.01 mm inside each other so they fuse into one solid, never past the worm's face
    flange = cq.Solid.makeCylinder(fd / 2, ft, cq.Vector(0, 0, 0))
    shaft = cq.Solid.makeCylinder(DRIVE_SHAFT / 2, shaft_len + 0.01, cq.Vector(0, 0, ft - 0.01))
    hexa = _hex(DRIVE_HEX, (0, 0, ft + shaft_len - 0.01), (0, 0, ft + shaft_len + DRIVE_HEX_LENGTH), (1, 0, 0))
    socket = _hex(lay.hex_key + HEX_CLEARANCE, (0, 0, -TOOL), (0, 0, HEX_DEPTH), (1, 0, 0))
    vent = cq.Solid.makeCylinder(VENT / 2, ft + shaft_len + DRIVE_HEX_LENGTH + TOOL, cq.Vector(0, 0, 0))
    return _one(flange.fuse(shaft, hexa).cut(socket, vent))


# ---- wheel ------------------------------------------------------------------------------
# The throated wheel: a blank of revolution minus one tooth-space tool per tooth, cut in one
# boolean. A tool's flanks and root are one bicubic B-spline surface through the tooth-space
# outlines that :meth:`WormPair.level_outline` generates plane by plane (the same points and
# parameters at every level), closed by a ruled top above the blank and two planar caps.
GEAR_LEVELS = 11          # transverse planes interpolated over the face (+ TOOL_OVERRUN each side)
GEAR_FLANK_POINTS = 16    # outline points per flank and level (≤ 2.6 µm from the envelope)
GEAR_ROOT_POINTS = 7      # outline points on the root arc
TOOL_OVERRUN = 0.4        # the tooth-space tool reaches this far beyond each face, mm
TOOL_TOP_MARGIN = 0.2     # the tool's top above the outside radius, mm (halved until neighbours stay apart)
TOOL_MIN_LAND = 0.05      # tooth left between two neighbouring tools at their top, mm
SURFACE_TOL = 1e-7        # face made on the interpolated surface, mm
SEWING_TOL = 1e-6         # sewing the tool's faces into a shell, mm
BSPLINE_DEGREE = 3


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


def _knots(t: np.ndarray, degree: int) -> np.ndarray:
    """Clamped knot vector for interpolation at parameters t (de Boor's averaging)."""
    inner = [float(np.mean(t[j:j + degree])) for j in range(1, len(t) - degree)]
    return np.concatenate([np.zeros(degree + 1), inner, np.ones(degree + 1)])


def _basis(knots: np.ndarray, degree: int, t: np.ndarray) -> np.ndarray:
    """(len(t), n) B-spline basis functions at t (Cox-de Boor), the last knot span closed."""
    spans = len(knots) - 1
    N = np.zeros((len(t), spans))
    for i in range(spans):
        if knots[i] < knots[i + 1]:
            N[:, i] = (t >= knots[i]) & (t < knots[i + 1])
    last = max(i for i in range(spans) if knots[i] < knots[i + 1])
    N[t >= knots[-1]] = 0.0
    N[t >= knots[-1], last] = 1.0
    for k in range(1, degree + 1):
        M = np.zeros((len(t), spans - k))
        for i in range(spans - k):
            d1, d2 = knots[i + k] - knots[i], knots[i + k + 1] - knots[i + 1]
            M[:, i] = ((t - knots[i]) / d1 * N[:, i] if d1 > 0 else 0.0) + \
                      ((knots[i + k + 1] - t) / d2 * N[:, i + 1] if d2 > 0 else 0.0)
        N = M
    return N[:, :len(knots) - degree - 1]


def _occ_knots(knots: np.ndarray):
    vals, mult = np.unique(np.round(knots, 12), return_counts=True)
    k, m = TColStd_Array1OfReal(1, len(vals)), TColStd_Array1OfInteger(1, len(vals))
    for i, (x, c) in enumerate(zip(vals, mult)):
        k.SetValue(i + 1, float(x))
        m.SetValue(i + 1, int(c))
    return k, m


def _interpolating_surface(P: np.ndarray, u: np.ndarray, v: np.ndarray):
    """Bicubic B-spline surface through the grid P (nu, nv, 3) at parameters u × v (poles
    solved with numpy: OCCT's own lofts re-approximate to degree 5 and cut 6× slower)."""
    d = BSPLINE_DEGREE
    ku, kv = _knots(u, d), _knots(v, d)
    nu, nv = len(u), len(v)
    C = np.linalg.solve(_basis(ku, d, u), P.reshape(nu, -1)).reshape(nu, nv, 3)
    C = np.linalg.solve(_basis(kv, d, v), C.transpose(1, 0, 2).reshape(nv, -1)).reshape(nv, nu, 3).transpose(1, 0, 2)
    poles = TColgp_Array2OfPnt(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            poles.SetValue(i + 1, j + 1, gp_Pnt(*map(float, C[i, j])))
    (uk, um), (vk, vm) = _occ_knots(ku), _occ_knots(kv)
    return Geom_BSplineSurface(poles, uk, vk, um, vm, d, d)


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
    surf = _interpolating_surface(np.ascontiguousarray(P.transpose(1, 0, 2)), u, (zs + h) / (2 * h))
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
    width, a tooth centred on +X at mid-width. Built once per distinct pair (a few seconds:
    one boolean of the blank and all tooth-space tools); one valid solid (loose chips of the
    tooth spaces' tops dropped) or :class:`GearDesignError`."""
    tool = _tooth_space_tool(pair)
    step = 360.0 / pair.teeth
    tools = [tool] + [tool.rotate(_v(0, 0, 0), _v(0, 0, 1), k * step) for k in range(1, pair.teeth)]
    pieces = sorted(_blank(pair).cut(*tools).Solids(), key=lambda s: s.Volume())
    # The tool's top is a chord between its corners; where the tooth tips leave little room
    # above the outside radius, the chord dips under it mid-space and leaves a loose chip of
    # the outside band on each side of the throat. Chips lie wholly beyond the throat radius
    # and belong to the space anyway; a loose piece reaching further in (a lost tooth) is an error.
    loose = pieces[:-1]
    if not pieces or any(min(math.hypot(v.X, v.Y) for v in s.Vertices()) <= pair.ra2 for s in loose):
        raise GearDesignError(f"the wheel came out in {len(pieces)} pieces, expected one solid")
    wheel = pieces[-1]
    if not wheel.isValid():
        raise GearDesignError("the wheel is not a valid solid")
    return wheel.translate(_v(0, 0, pair.face_width / 2))


def clamp_site(lay: TensionerLayout) -> float:
    """Radius on the wheel face of the clamp's screw, mm: midway between flange and tooth root,
    or nearer the flange if the nut trap would otherwise reach the root."""
    e = (NUT["M2"][0] + NUT_PLAY) / math.sqrt(3)
    return min((lay.flange_radius + lay.pair.rf2) / 2, lay.pair.rf2 - e - 1.0)


def clamp_joint(lay: TensionerLayout, unit: Unit, zc: float) -> Fastening:
    """The clamp's M2 screw: through the plate into the gear, or into the end cap it sits on."""
    on_cap = any(c[0] - 1e-9 <= zc <= c[1] + 1e-9 for c in unit.caps)
    return joint(lay.fastening, "M2", CLAMP_PLATE[2], CAP if on_cap else lay.pair.face_width)


def wheel_solid(lay: TensionerLayout, unit: Unit, gear: cq.Solid, pin_bore: float) -> cq.Solid:
    """Gear + spool drum + flanges (+ end cap), bored for the pins, the clamps' screws (a nut
    trap from the far face, or an insert bore) and the tendons' anchor holes. Built with
    Z = robot z - unit.z_part[0], then turned over when the gear is on top so that its face
    rests on the plate."""
    z_lo = unit.z_part[0]
    pair = lay.pair
    height = unit.z_part[1] - z_lo
    pieces = [gear.translate(cq.Vector(0, 0, unit.z_gear[0] - z_lo))]
    pieces.append(cq.Solid.makeCylinder(lay.hub_radius, height, cq.Vector(0, 0, 0)))
    for f0, f1 in unit.flanges:
        pieces.append(cq.Solid.makeCylinder(lay.flange_radius, f1 - f0, cq.Vector(0, 0, f0 - z_lo)))
    for c0, c1 in unit.caps:
        pieces.append(cq.Solid.makeCylinder(pair.rf2, c1 - c0, cq.Vector(0, 0, c0 - z_lo)))
    body = pieces[0].fuse(*pieces[1:])
    tools = [cq.Solid.makeCylinder(pin_bore / 2, height + 2 * TOOL, cq.Vector(0, 0, -TOOL))]
    rc = clamp_site(lay)
    ang = math.radians(CLAMP_ANGLE)
    at = np.array([rc * math.cos(ang), rc * math.sin(ang)])
    for zc, s in unit.clamps:
        zf = zc - z_lo
        j = clamp_joint(lay, unit, zc)
        if j.kind == "nut":
            # through the body, and a trap from its far face (where the nut goes in) to the nut's near face
            tools.append(_cyl(j.hole / 2, (*at, zf + s * TOOL), (*at, zf - s * (j.body + TOOL))))
            tools.append(_hex(NUT["M2"][0] + NUT_PLAY, (*at, zf - s * (j.body + TOOL)), (*at, zf - s * j.nut_from),
                              (math.cos(ang), math.sin(ang), 0.0)))
        else:
            tools.append(_cyl(j.hole / 2, (*at, zf + s * TOOL), (*at, zf - s * j.depth)))
    tools += _lightening(lay, unit, height)
    # anchor holes: through the flange between each winding zone and its clamp face
    r_anchor = lay.spool_radius + ANCHOR_HOLE / 2 + 0.3
    for zc, s in unit.clamps:
        # on an end cap: through the cap; on the gear's face: through the flange nearest to it
        f = next((c for c in unit.caps if c[0] - 1e-9 <= zc <= c[1] + 1e-9), None) or \
            min(unit.flanges, key=lambda f: abs((f[0] + f[1]) / 2 - zc))
        tools.append(cq.Solid.makeCylinder(ANCHOR_HOLE / 2, f[1] - f[0] + 2 * TOOL,
                                           cq.Vector(r_anchor * math.cos(ang), r_anchor * math.sin(ang),
                                                     f[0] - z_lo - TOOL)))
    solid = _one(body.cut(*tools))
    if unit.gear_on_top:
        solid = _one(solid.moved(location(lay.wheel_flip(unit))))
    return solid


LIGHTENING_WALL = 1.2        # resin left around a lightening hole or inside a hollow drum, mm
LIGHTENING_HOLE = 6.0        # Ø of the holes through the gear between its hub and its root, mm


def _lightening(lay: TensionerLayout, unit: Unit, height: float) -> list[cq.Solid]:
    """Material the wheel does not need: the drum core hollow between the dowels' ends (the
    hollow opens into the pin bore at both ends, so resin drains), and holes through the gear
    between hub and tooth root, away from the clamp's nut and the anchor hole."""
    out = []
    engaged = PIN_ENGAGE + 1.0
    r_in = lay.hub_radius - LIGHTENING_WALL
    if height > 2 * engaged + 2 and r_in > (lay.shaft_diameter + lay.running_fit) / 2 + 0.5:
        out.append(cq.Solid.makeCylinder(r_in, height - 2 * engaged, cq.Vector(0, 0, engaged)))
    r0 = lay.hub_radius + LIGHTENING_WALL + LIGHTENING_HOLE / 2
    if r0 + LIGHTENING_HOLE / 2 + LIGHTENING_WALL <= lay.pair.rf2:
        z0 = unit.z_gear[0] - unit.z_part[0]
        for deg in (CLAMP_ANGLE + 90, CLAMP_ANGLE + 180, CLAMP_ANGLE + 270):      # the clamp is at CLAMP_ANGLE
            a = math.radians(deg)
            out.append(cq.Solid.makeCylinder(LIGHTENING_HOLE / 2, lay.pair.face_width + 2 * TOOL,
                                              cq.Vector(r0 * math.cos(a), r0 * math.sin(a), z0 - TOOL)))
    return out


def clamp_solid() -> cq.Solid:
    """Clamp plate: the tendon, led out of the anchor hole, is pinched under it by an M2 screw."""
    x, y, t = CLAMP_PLATE
    plate = cq.Solid.makeBox(x, y, t, cq.Vector(-x / 2, -y / 2, 0))
    hole = cq.Solid.makeCylinder((CLAMP_SCREW + 0.4) / 2, t + 2 * TOOL, cq.Vector(0, 0, -TOOL))
    return _one(plate.cut(hole))


# ---- housing ----------------------------------------------------------------------------
def _box(x0, x1, y0, y1, z0, z1) -> cq.Solid:
    xs, ys, zs = sorted((x0, x1)), sorted((y0, y1)), sorted((z0, z1))
    return cq.Solid.makeBox(xs[1] - xs[0], ys[1] - ys[0], zs[1] - zs[0], cq.Vector(xs[0], ys[0], zs[0]))


def _cyl(r, p0, p1) -> cq.Solid:
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    return cq.Solid.makeCylinder(r, float(np.linalg.norm(d)), cq.Vector(*p0), cq.Vector(*d))


def _hex(across_flats: float, p0, p1, flat_normal) -> cq.Solid:
    """Hexagonal prism from p0 to p1, one pair of flats facing ``flat_normal`` (made square to the axis)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    ax = (p1 - p0) / np.linalg.norm(p1 - p0)
    n = np.asarray(flat_normal, float)
    n = n - ax * (n @ ax)
    if np.linalg.norm(n) < 1e-9:
        n = np.cross(ax, [1.0, 0.0, 0.0] if abs(ax[0]) < 0.9 else [0.0, 1.0, 0.0])
    n /= np.linalg.norm(n)
    m = np.cross(ax, n)
    r = across_flats / math.sqrt(3)                        # corner radius
    corners = [p0 + r * (math.cos(a) * m + math.sin(a) * n) for a in np.radians(np.arange(0, 360, 60))]
    face = cq.Face.makeFromWires(_wire(corners))
    return cq.Solid.extrudeLinear(face, cq.Vector(*(p1 - p0)))


def _prism(axis: int, lo: float, hi: float, outline) -> cq.Solid:
    """An outline of (y, v) points (v = z for an x normal, x for a z normal) extruded from lo to hi."""
    pts = np.asarray(outline, float).reshape(-1, 2)
    if axis == 0:
        corners = [(lo, y, v) for y, v in pts]
        step = cq.Vector(hi - lo, 0, 0)
    else:
        corners = [(v, y, lo) for y, v in pts]
        step = cq.Vector(0, 0, hi - lo)
    return cq.Solid.extrudeLinear(cq.Face.makeFromWires(_wire(corners)), step)


def member_solid(m) -> cq.Solid:
    """A :class:`hwgen.model.tensioner_layout.Member` as a solid."""
    d = m.dims
    if m.kind == "box":
        return _box(*d)
    if m.kind == "cyl":
        return _cyl(d[0], d[1:4], d[4:7])
    if m.kind == "prism":
        return _prism(int(d[0]), d[1], d[2], d[3:])
    return _hex(d[0], d[1:4], d[4:7], d[7:10])


def housing_solid(lay: TensionerLayout) -> cq.Solid:
    """The housing in robot coordinates, from the layout's members (fused) and cuts (one cut)."""
    solids = [member_solid(m) for m in lay.members]
    body = solids[0].fuse(*solids[1:]).clean()
    body = _one(body.cut(*(member_solid(m) for m in lay.cuts)))
    return body.moved(location(lay.turn))


def _one(shape) -> cq.Solid:
    solids = shape.Solids() if not isinstance(shape, cq.Solid) else [shape]
    if len(solids) != 1:
        raise GearDesignError(f"expected one solid, got {len(solids)}")
    return solids[0]


# ---- parts ------------------------------------------------------------------------------
def housing_placement(lay: TensionerLayout) -> np.ndarray:
    return placement(DISK_ROTATION, [0.0, lay.y_face, 0.0])


def build_tensioner(lay: TensionerLayout, *, min_wall: float, tendon_diameter: float, tip_screws: int,
                    tip_thickness: float) -> Iterator[Part]:
    """The tensioner's parts as ``lay`` places them: the process's ``min_wall`` (the gears'
    thinnest tip), the tendon's diameter, and the tip disk's screw count and thickness (the
    screws' grip)."""
    pair = lay.pair
    problems = pair.problems(lay.friction_coefficient, min_wall)
    if problems:
        raise GearDesignError("; ".join(f"tensioner.{f}: {m}" for f, m in problems))
    running = lay.shaft_diameter + lay.running_fit
    # the drive's hex goes into the worm's line to line: the resin's own scatter (±0.05 mm) makes
    # it snug; modelled without overlap so the parts' interference check stays meaningful
    worm = worm_solid(pair, lay.worm_near_end, DRIVE_HEX, running, lay.worm_pin - POST + 0.5)
    drive = drive_solid(lay)
    gear = kept("throated wheel gear", pair, lambda: gear_solid(pair))      # the costly boolean, kept between builds
    clamp = clamp_solid()
    wheels: dict[tuple, cq.Solid] = {}
    for u in lay.units:
        key = tuple(np.round(np.array([*u.z_part, *u.z_gear, *np.ravel(u.zones), *np.ravel(u.clamps)])
                             - u.z_part[0], 6))
        if key not in wheels:
            wheels[key] = wheel_solid(lay, u, gear, running)
        meta = {"channel": u.channel, "tendons": list(u.tendons)}
        wp = lay.worm_placement(u)
        yield Part(f"tensioner_worm_{u.channel}", "tensioner_worm", worm, wp, WORM_COLOR,
                   meta={**meta, "mesh_with": f"tensioner_wheel_{u.channel}", "hex_key_mm": lay.hex_key,
                         "hardware": [_dowel(lay.shaft_diameter, lay.worm_pin, "pressed into the far post")],
                         **pair.summary()})
        yield Part(f"tensioner_drive_{u.channel}", "tensioner_drive", drive, lay.drive_placement(u), DRIVE_COLOR,
                   meta={"channel": u.channel, "hex_key_mm": lay.hex_key,
                         "drives": f"tensioner_worm_{u.channel}"})
        yield _wheel_part(lay, u, wheels[key], meta, tendon_diameter)
        yield from _clamp_parts(lay, u, clamp, meta)
    hp = housing_placement(lay)
    inv = np.linalg.inv(hp)
    n_tip = tip_screws
    tip = tip_joint(lay.fastening, tip_thickness, lay.base_t)
    set_screw = {"nut": _hw("hex nut ISO 4032", "M3", 2, STEEL, "for the strip's set screws, in a side slot"),
                 "insert": _hw("heat-set insert", "M3 × 5.7", 2, BRASS, "for the strip's set screws, melted in")}
    yield Part("tensioner_housing", "tensioner_housing", housing_solid(lay).moved(location(inv)), hp, HOUSING_COLOR,
               meta={"channel": "all", "channels": [u.channel for u in lay.units], "layout_search": lay.search,
                     "hardware": [
                         {**_hw("socket head cap screw ISO 4762", tip.screw, n_tip, STEEL,
                                "through the tip disk into the housing"), "tip_mount": True},
                         tip.held_by(n_tip, "takes the tip-disk screws, in a side slot"),
                         _hw("set screw ISO 4026", "M3 × 6", 2, STEEL, "clamps the strip's tip"),
                         set_screw[lay.fastening]]})


def _wheel_part(lay: TensionerLayout, u: Unit, solid, meta: dict, tendon_d: float) -> Part:
    # the run meets its own drum tangentially: the last stretch, where it is closer to the
    # drum than 1.5 tendon diameters, is where it is meant to touch and is not checked
    trim = math.sqrt((lay.winding_radius + 1.5 * tendon_d) ** 2 - lay.winding_radius ** 2)
    runs = [{"tendon": r.tendon, "start": list(r.start), "end": list(r.end), "sense": r.sense,
             "exit_angle_deg": r.exit_angle_deg, "own_part_trim_mm": trim}
            for r in lay.runs if r.channel == u.channel]
    return Part(f"tensioner_wheel_{u.channel}", "tensioner_wheel", solid, lay.wheel_placement(u), WHEEL_COLOR,
                meta={**meta, "tendon_runs": runs, "winding_radius_mm": lay.winding_radius,
                      "winding": lay.windings[u.channel],
                      "flange_radius_mm": lay.flange_radius, "spool_diameter_mm": 2 * lay.spool_radius,
                      "winding_zones_z_mm": [list(z) for z in u.zones],
                      "hardware": [_dowel(lay.shaft_diameter, n, "pressed into the housing") for n in u.pins]})


def _clamp_parts(lay: TensionerLayout, u: Unit, clamp, meta: dict) -> Iterator[Part]:
    rc = clamp_site(lay)
    ang = math.radians(CLAMP_ANGLE)
    for k, (zc, s) in enumerate(u.clamps):
        zf = zc - u.z_part[0]
        t = placement(np.eye(3), [rc * math.cos(ang), rc * math.sin(ang), zf if s > 0 else zf - CLAMP_PLATE[2]])
        j = clamp_joint(lay, u, zc)
        name = f"tensioner_clamp_{u.channel}" + (f"_{k + 1}" if len(u.clamps) > 1 else "")
        yield Part(name, "tensioner_clamp", clamp, lay.stack_placement(u) @ t, CLAMP_COLOR,
                   meta={**meta, "hardware": [_hw("button head screw ISO 7380", j.screw, 1, STEEL),
                                              j.held_by(1, "in the wheel")]})


STEEL, BRASS = "steel", "brass"


def _hw(item: str, size: str, qty: int, material: str, notes: str = "") -> dict:
    """One line of purchased hardware, as the bill of materials sums it (by item and size)."""
    return {"item": item, "size": size, "qty": qty, "material": material, "notes": notes}


def _dowel(diameter: float, length: float, notes: str) -> dict:
    return _hw("dowel pin ISO 2338", f"Ø{diameter:g} × {length:g}", 1, "hardened steel", notes)
