"""Tensioner solids: worm, wheel with spool, tendon clamp and housing.

The numbers come from :mod:`hwgen.model.gearing` (tooth and thread forms) and
:mod:`hwgen.model.tensioner_layout` (where everything sits); this module only turns them into
CadQuery solids. Identical geometry is built once: one worm and one clamp for every
channel, one wheel per distinct spool layout (the three single-tendon channels share
theirs).

Print orientations: worm and wheel stand on an end face with their axis along file Z;
the clamp plate lies flat; the worm's bearing cap on its flange; the housing stands on
its base plate (the face that bolts to the tip disk), file (X, Y, Z) = robot (x, -z, y - y_face).

Assembly, as the geometry allows it: heat-set inserts into the housing (base plate, strip
clamp, spine) and the wheels (clamp faces); housing onto the tip disk (4 × M3 from the
disk's inner face) with the strip's tip in its slot, set screws down on the strip; each
wheel between its shelf and bar, its two dowels pressed in from outside; each worm dowel
pressed into its far post, the worm slid in through the spine onto it, the cap screwed
over; tendons through the base plate holes, wound, led through the anchor hole and
pinched under the clamp plate around its M2 screw.
"""
from __future__ import annotations

import math
from collections.abc import Iterator

import cadquery as cq
import numpy as np

from ..model.gearing import GearDesignError, WormPair
from ..model.plan import Plan
from ..model.tensioner_layout import (ANCHOR_HOLE, BOSS, CLAMP_INSERT_BORE, CLAMP_INSERT_DEPTH, CLAMP_PLATE, CLAMP_SCREW,
                         COLLAR, COLLAR_STEP, GAP, M3_CLEARANCE, M3_INSERT, M3_INSERT_DEPTH, POST,
                         SET_SCREW_INSERT, SHELF, STRIP_SLOT_CLEARANCE, WORM_CAP, TensionerLayout, Unit)
from . import DISK_ROTATION, Part, location, placement

WORM_COLOR = (0.75, 0.76, 0.78, 1.0)
WHEEL_COLOR = (0.30, 0.55, 0.85, 1.0)
CLAMP_COLOR = (0.90, 0.45, 0.20, 1.0)
HOUSING_COLOR = (0.55, 0.58, 0.52, 1.0)
ROOT_OVERLAP = 0.05      # thread root sunk into the worm core so the fuse has no seam, mm
HEX_DEPTH = 6.0          # depth of the hex socket, mm (a 2.5 mm key engages fully at 5 mm)
HEX_CLEARANCE = 0.1      # across flats over the key, mm
TOOL = 1.0               # cutting tools overrun faces by this much, mm
CLAMP_ANGLE = 90.0       # where on the wheel face the clamp sits, deg from the tooth on +X


def _wire(points) -> cq.Wire:
    return cq.Wire.makePolygon([cq.Vector(*p) for p in points], close=True)


# ---- worm -------------------------------------------------------------------------------
def worm_solid(pair: WormPair, hex_journal: float, hex_key: float, pin_bore: float, pin_depth: float) -> cq.Solid:
    """Worm along file Z: the hex journal from Z = 0, a thrust collar, the threaded length,
    then the far end with a blind bore for the dowel it turns on. The thread is the
    trapezoid axial profile swept along a helix (right hand), one sweep per start."""
    L = pair.worm_length
    z0 = hex_journal
    prof = pair.worm_axial_profile(ROOT_OVERLAP)
    start = z0 + pair.pitch / 2
    wire = _wire([(r, 0, start + dz) for r, dz in prof])
    helix = cq.Wire.makeHelix(pair.lead, L - pair.pitch, pair.r1, center=cq.Vector(0, 0, start))
    thread = cq.Solid.sweep(wire, [], helix, makeSolid=True, isFrenet=True)
    threads = [thread] + [thread.rotate(cq.Vector(), cq.Vector(0, 0, 1), 360.0 * j / pair.starts)
                          for j in range(1, pair.starts)]
    core = cq.Solid.makeCylinder(pair.rf1, hex_journal + L, cq.Vector(0, 0, 0))
    collar = cq.Solid.makeCylinder(pair.rf1 + COLLAR_STEP, COLLAR, cq.Vector(0, 0, hex_journal - COLLAR))
    body = core.fuse(collar, *threads)
    af = hex_key + HEX_CLEARANCE
    r_hex = af / math.sqrt(3)
    hexagon = _wire([(r_hex * math.cos(math.radians(60 * k)), r_hex * math.sin(math.radians(60 * k)), -TOOL)
                     for k in range(6)])
    socket = cq.Solid.extrudeLinear(cq.Face.makeFromWires(hexagon), cq.Vector(0, 0, HEX_DEPTH + TOOL))
    bore = cq.Solid.makeCylinder(pin_bore / 2, pin_depth + TOOL, cq.Vector(0, 0, hex_journal + L - pin_depth))
    return _one(body.cut(socket, bore))


# ---- wheel ------------------------------------------------------------------------------
def gear_solid(pair: WormPair) -> cq.Solid:
    """Helical involute wheel, file Z from 0 to the face width; at mid-width a tooth is
    centred on +X. Each tooth: two generated flanks (splines), tip and root arcs; the
    section turns by twist_per_mm · Z so the teeth follow the worm's thread."""
    n, b = pair.teeth, pair.face_width
    fl = pair.flank_points()
    lower = fl * [1, -1]
    step = 2 * math.pi / n
    theta0 = -pair.twist_per_mm * b / 2

    def rot(p, a):
        c, s = math.cos(a), math.sin(a)
        return cq.Vector(p[0] * c - p[1] * s, p[0] * s + p[1] * c, 0)
    edges = []
    for k in range(n):
        a = theta0 + k * step
        lo = [rot(p, a) for p in lower]
        up = [rot(p, a) for p in fl[::-1]]
        edges.append(cq.Edge.makeSpline(lo))
        edges.append(cq.Edge.makeThreePointArc(lo[-1], rot((pair.ra2, 0), a), up[0]))
        edges.append(cq.Edge.makeSpline(up))
        mid = rot((pair.rf2 * math.cos(step / 2), pair.rf2 * math.sin(step / 2)), a)
        edges.append(cq.Edge.makeThreePointArc(up[-1], mid, rot(lower[0], a + step)))
    wire = cq.Wire.assembleEdges(edges)
    return cq.Solid.extrudeLinearWithRotation(wire, [], cq.Vector(0, 0, 0), cq.Vector(0, 0, b),
                                              math.degrees(pair.twist_per_mm * b))


def clamp_site(lay: TensionerLayout) -> float:
    """Radius on the wheel face of the clamp's screw, mm: midway between flange and tooth root."""
    return (lay.flange_radius + lay.pair.rf2) / 2


def wheel_solid(lay: TensionerLayout, unit: Unit, gear: cq.Solid, pin_bore: float) -> cq.Solid:
    """Gear + spool drum + flanges (+ end cap), bored for the pins, the clamps' heat-set
    inserts and the tendons' anchor holes. Built with Z = robot z - unit.z_part[0], then
    turned over when the gear is on top so that its face rests on the plate."""
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
    for zc, s in unit.clamps:
        zf = zc - z_lo
        # heat-set insert bore into the gear (or end cap) from the face the clamp sits on
        z_from = zf - CLAMP_INSERT_DEPTH if s > 0 else zf - TOOL
        tools.append(cq.Solid.makeCylinder(CLAMP_INSERT_BORE / 2, CLAMP_INSERT_DEPTH + TOOL,
                                           cq.Vector(rc * math.cos(ang), rc * math.sin(ang), z_from)))
    # anchor holes: through the flange between each winding zone and its clamp face
    r_anchor = lay.spool_radius + ANCHOR_HOLE / 2 + 0.3
    for zc, s in unit.clamps:
        # on an end cap: through the cap; on the gear's face: through the flange nearest to it
        slab = next((c for c in unit.caps if c[0] - 1e-9 <= zc <= c[1] + 1e-9), None) or \
            min(unit.flanges, key=lambda f: abs((f[0] + f[1]) / 2 - zc))
        f = slab
        tools.append(cq.Solid.makeCylinder(ANCHOR_HOLE / 2, f[1] - f[0] + 2 * TOOL,
                                           cq.Vector(r_anchor * math.cos(ang), r_anchor * math.sin(ang),
                                                     f[0] - z_lo - TOOL)))
    solid = _one(body.cut(*tools))
    if unit.gear_on_top:
        solid = _one(solid.moved(location(lay.wheel_flip(unit))))
    return solid


def clamp_solid() -> cq.Solid:
    """Clamp plate: the tendon, led out of the anchor hole, is pinched under it by an M2 screw."""
    x, y, t = CLAMP_PLATE
    plate = cq.Solid.makeBox(x, y, t, cq.Vector(-x / 2, -y / 2, 0))
    hole = cq.Solid.makeCylinder((CLAMP_SCREW + 0.4) / 2, t + 2 * TOOL, cq.Vector(0, 0, -TOOL))
    return _one(plate.cut(hole))


# ---- worm bearing cap ----------------------------------------------------------------
def cap_solid(lay: TensionerLayout, screws_file: list[tuple[float, float]]) -> cq.Solid:
    """Square flange (file Z from 0, the face outside the spine) with a spigot that locates
    in the spine hole and ends at the worm's collar; bored for the hex journal and two M3
    screws. Shares the worm's file frame."""
    ts = lay.params
    h = lay.cap_half
    flange = cq.Solid.makeBox(2 * h, 2 * h, WORM_CAP, cq.Vector(-h, -h, 0))
    spigot = cq.Solid.makeCylinder((lay.spine_hole - ts.running_fit) / 2, lay.cap_spigot,
                                   cq.Vector(0, 0, WORM_CAP))
    body = flange.fuse(spigot)
    length = WORM_CAP + lay.cap_spigot
    tools = [cq.Solid.makeCylinder((2 * lay.pair.rf1 + ts.running_fit) / 2, length + 2 * TOOL,
                                   cq.Vector(0, 0, -TOOL))]
    for x, y in screws_file:
        tools.append(cq.Solid.makeCylinder(M3_CLEARANCE / 2, WORM_CAP + 2 * TOOL, cq.Vector(x, y, -TOOL)))
    return _one(body.cut(*tools))


def cap_screws(lay: TensionerLayout, unit: Unit) -> tuple[tuple[float, float], ...]:
    """(X, Y) of the cap's two screws in the worm's file frame (the same for every unit)."""
    inv = np.linalg.inv(lay.worm_placement(unit))
    s = unit.side
    out = []
    for dy in (-lay.cap_screw, lay.cap_screw):
        p = inv @ [s * lay.worm_x[1], unit.worm_y + dy, unit.worm_z, 1.0]
        out.append((round(float(p[0]), 6), round(float(p[1]), 6)))
    return tuple(sorted(out))


# ---- housing ----------------------------------------------------------------------------
def _box(x0, x1, y0, y1, z0, z1) -> cq.Solid:
    xs, ys, zs = sorted((x0, x1)), sorted((y0, y1)), sorted((z0, z1))
    return cq.Solid.makeBox(xs[1] - xs[0], ys[1] - ys[0], zs[1] - zs[0], cq.Vector(xs[0], ys[0], zs[0]))


def _cyl(r, p0, p1) -> cq.Solid:
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    return cq.Solid.makeCylinder(r, float(np.linalg.norm(d)), cq.Vector(*p0), cq.Vector(*d))


def housing_solid(lay: TensionerLayout, plan: Plan) -> cq.Solid:
    """The housing in robot coordinates: base plate on the tip disk, strip clamp, two
    spines with the worms' hex journal bores, and per unit an upper shelf with the pin
    boss, a lower bar and the far worm post."""
    ts = lay.params
    pin_press = ts.shaft_diameter - ts.press_fit
    bx0, bx1, by0, by1, bz0, bz1 = lay.base
    sp0, sp1 = lay.spine
    p0, p1 = lay.post
    solids = [_box(bx0, bx1, by0, by1, bz0, bz1)]
    cb = lay.clamp_block
    solids.append(_box(*cb))
    # each column's spine: one pad per unit over its y band and z span, stacked from the base
    # plate (consecutive pads overlap by a shelf thickness so they fuse into one wall)
    reach = max(lay.cap_half, POST / 2)
    y_from = {1: by0, -1: by0}
    for u in sorted(lay.units, key=lambda u: u.center[1]):
        s = u.side
        top = max(u.center[1] + lay.pair.ra2, u.worm_y + reach)
        solids.append(_box(s * sp0, s * sp1, y_from[s], top, u.lower_bar[0], u.upper_shelf[1]))
        y_from[s] = top - SHELF
    cuts = []
    for u in lay.units:
        s = u.side
        cx, cy = u.center
        wy, wz = u.worm_y, u.worm_z
        solids.append(_box(s * p0, s * sp1, cy - s * BOSS, wy + s * POST / 2, *u.upper_shelf))
        solids.append(_cyl(BOSS, (cx, cy, u.z_part[1] + GAP), (cx, cy, u.upper_shelf[1])))
        solids.append(_box(cx, s * sp1, cy - BOSS, cy + BOSS, *u.lower_bar))
        solids.append(_cyl(BOSS, (cx, cy, u.lower_bar[0]), (cx, cy, u.z_part[0] - GAP)))
        solids.append(_box(s * p0, s * p1, wy - POST / 2, wy + POST / 2, wz - POST / 2, u.upper_shelf[1]))
        # dowel bores (press fit): wheel pins along z, worm pin along x through the post
        cuts.append(_cyl(pin_press / 2, (cx, cy, u.z_part[1]), (cx, cy, u.upper_shelf[1] + TOOL)))
        cuts.append(_cyl(pin_press / 2, (cx, cy, u.lower_bar[0] - TOOL), (cx, cy, u.z_part[0])))
        cuts.append(_cyl(pin_press / 2, (s * (p0 - TOOL), wy, wz), (s * (p1 + TOOL), wy, wz)))
        # the hole the worm enters by (the cap's spigot locates in it) and the cap's inserts
        cuts.append(_cyl(lay.spine_hole / 2, (s * (sp0 - TOOL), wy, wz), (s * (sp1 + TOOL), wy, wz)))
        for dy in (-lay.cap_screw, lay.cap_screw):
            cuts.append(_cyl(M3_INSERT / 2, (s * (sp1 - M3_INSERT_DEPTH), wy + dy, wz),
                             (s * (sp1 + TOOL), wy + dy, wz)))
    # strip slot through the base plate into the clamp block, set-screw inserts from +z
    hx, hz, _, y_end = lay.strip
    c = STRIP_SLOT_CLEARANCE
    cuts.append(_box(-hx - c, hx + c, by0 - TOOL, y_end + c, -hz - c, hz + c))
    ym = (cb[2] + cb[3]) / 2
    for x in (-hx / 2, hx / 2):
        cuts.append(_cyl(SET_SCREW_INSERT / 2, (x, ym, 0.0), (x, ym, cb[5] + TOOL)))
    # tendon passages and the tip disk's screw inserts through the base plate
    for x, z, dia in lay.tendon_holes:
        cuts.append(_cyl(dia / 2, (x, by0 - TOOL, z), (x, by1 + TOOL, z)))
    for x, z, dia in lay.mount_holes:
        cuts.append(_cyl(dia / 2, (x, by0 - TOOL, z), (x, by1 + TOOL, z)))
    body = solids[0].fuse(*solids[1:]).clean()
    return _one(body.cut(*cuts))


def _one(shape) -> cq.Solid:
    solids = shape.Solids() if not isinstance(shape, cq.Solid) else [shape]
    if len(solids) != 1:
        raise GearDesignError(f"expected one solid, got {len(solids)}")
    return solids[0]


# ---- parts ------------------------------------------------------------------------------
def housing_placement(lay: TensionerLayout) -> np.ndarray:
    return placement(DISK_ROTATION, [0.0, lay.y_face, 0.0])


def build_tensioner(plan: Plan) -> Iterator[Part]:
    lay = plan.require_tensioner_layout()
    ts = lay.params
    pair = lay.pair
    problems = pair.problems(ts.friction_coefficient, plan.design.process.min_wall)
    if problems:
        raise GearDesignError("; ".join(f"tensioner.{f}: {m}" for f, m in problems))
    running = ts.shaft_diameter + ts.running_fit
    worm = worm_solid(pair, lay.hex_journal, ts.hex_key, running, lay.worm_pin - POST + 0.5)
    gear = gear_solid(pair)
    clamp = clamp_solid()
    wheels: dict[tuple, cq.Solid] = {}
    caps: dict[tuple, cq.Solid] = {}
    for u in lay.units:
        key = tuple(np.round(np.array([*u.z_part, *u.z_gear, *np.ravel(u.zones), *np.ravel(u.clamps)])
                             - u.z_part[0], 6))
        if key not in wheels:
            wheels[key] = wheel_solid(lay, u, gear, running)
        meta = {"channel": u.channel, "tendons": list(u.tendons)}
        wp = lay.worm_placement(u)
        yield Part(f"tensioner_worm_{u.channel}", "tensioner_worm", worm, wp, WORM_COLOR,
                   meta={**meta, "mesh_with": f"tensioner_wheel_{u.channel}", "hex_key_mm": ts.hex_key,
                         "hardware": [_dowel(ts.shaft_diameter, lay.worm_pin, "pressed into the far post")],
                         **pair.summary()})
        screws = cap_screws(lay, u)
        if screws not in caps:
            caps[screws] = cap_solid(lay, list(screws))
        yield Part(f"tensioner_cap_{u.channel}", "tensioner_cap", caps[screws], wp, HOUSING_COLOR,
                   meta={"channel": u.channel,
                         "hardware": [_hw("socket head cap screw ISO 4762", "M3 × 10", 2, STEEL),
                                      _hw("heat-set insert", "M3 × 5.7", 2, BRASS, "melted into the spine")]})
        hp = lay.wheel_placement(u)
        d = plan.design.tendon_material.diameter
        # the run meets its own drum tangentially: the last stretch, where it is closer to the
        # drum than 1.5 tendon diameters, is where it is meant to touch and is not checked
        trim = math.sqrt((lay.winding_radius + 1.5 * d) ** 2 - lay.winding_radius ** 2)
        runs = [{"tendon": r.tendon, "start": list(r.start), "end": list(r.end),
                 "exit_angle_deg": r.exit_angle_deg, "own_part_trim_mm": trim}
                for r in lay.runs if r.channel == u.channel]
        yield Part(f"tensioner_wheel_{u.channel}", "tensioner_wheel", wheels[key], hp, WHEEL_COLOR,
                   meta={**meta, "tendon_runs": runs, "winding_radius_mm": lay.winding_radius,
                         "flange_radius_mm": lay.flange_radius, "spool_diameter_mm": 2 * lay.spool_radius,
                         "winding_zones_z_mm": [list(z) for z in u.zones],
                         "hardware": [_dowel(ts.shaft_diameter, n, "pressed into the housing") for n in u.pins]})
        rc = clamp_site(lay)
        ang = math.radians(CLAMP_ANGLE)
        for k, (zc, s) in enumerate(u.clamps):
            zf = zc - u.z_part[0]
            t = placement(np.eye(3), [rc * math.cos(ang), rc * math.sin(ang),
                                      zf if s > 0 else zf - CLAMP_PLATE[2]])
            name = f"tensioner_clamp_{u.channel}" + (f"_{k + 1}" if len(u.clamps) > 1 else "")
            yield Part(name, "tensioner_clamp", clamp, lay.stack_placement(u) @ t, CLAMP_COLOR,
                       meta={**meta, "hardware": [
                           _hw("button head screw ISO 7380", "M2 × 6", 1, STEEL),
                           _hw("heat-set insert", "M2 × 4", 1, BRASS, "melted into the wheel face")]})
    hp = housing_placement(lay)
    robot_solid = housing_solid(lay, plan)
    inv = np.linalg.inv(hp)
    yield Part("tensioner_housing", "tensioner_housing", robot_solid.moved(location(inv)), hp, HOUSING_COLOR,
               meta={"channel": "all", "channels": [u.channel for u in lay.units],
                     "hardware": [
                         {**_hw("heat-set insert", "M3 × 5.7", len(lay.mount_holes), BRASS,
                                "takes the tip-disk screws"), "tip_mount": True, "thread_depth_mm": 5.7},
                         _hw("set screw ISO 4026", "M3 × 6", 2, STEEL, "clamps the strip's tip"),
                         _hw("heat-set insert", "M3 × 5.7", 2, BRASS, "for the strip's set screws")]})


STEEL, BRASS = "steel", "brass"


def _hw(item: str, size: str, qty: int, material: str, notes: str = "") -> dict:
    """One line of purchased hardware, as the bill of materials sums it (by item and size)."""
    return {"item": item, "size": size, "qty": qty, "material": material, "notes": notes}


def _dowel(diameter: float, length: float, notes: str) -> dict:
    return _hw("dowel pin ISO 2338", f"Ø{diameter:g} × {length:g}", 1, "hardened steel", notes)
