"""The paper's bench as printed parts (issue 46): the rotating base frame (``base_frame_*``: cradle,
front and back uprights, base plate, worm wheel, worm and its drive shaft) and the stiffness rig
(``rig_*``: the load cell's bracket, the push block, the support), built in robot coordinates from
:class:`hwgen.model.bench_frame.FrameLayout` and :class:`hwgen.model.bench_rig.RigLayout`.

Each part's file is its solid set on a flat face it can rest on, square to its bores and seats
where one can carry it (:func:`_resting`; the cradle stands on its foot), its lowest point on
Z = 0 (the gear's wheel, worm and drive shaft keep the tensioner's file frames: axis on Z); the
placement maps it back. The worm pair's solids are the tensioner's, kept under the same keys
(:mod:`hwgen.cad.memo`), so a frame whose pair is the tensioner's makes no gear again.
"""
from __future__ import annotations

import math
from collections.abc import Iterator

import cadquery as cq
import numpy as np
from OCP.BRepAdaptor import BRepAdaptor_Surface
from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
from OCP.gp import gp_Trsf

from ..model import bench_frame as bf
from ..model import bench_parts as bp
from ..model import hardware as stock
from ..model.bench_frame import FrameLayout
from ..model.bench_rig import ARM, COLUMN, DISC, LEDGE, LEDGE_Y, PAD, SPIGOT, WALL, RigLayout, bp_screw_head
from ..model.gearing import WORM_TO_MESH
from ..model.tensioner_layout.sizes import AXIAL_PLAY, DRIVE_FLANGE, DRIVE_HEX, DRIVE_SHAFT, POST
from . import Part, placement
from .memo import kept
from .primitives import TOOL, box, cylinder, hardware, hex_prism, one

FRAME_COLOR = (0.30, 0.34, 0.40, 1.0)      # the fixed frame: dark slate, as the mount
CRADLE_COLOR = (0.62, 0.50, 0.30, 1.0)     # what turns with the robot
GEAR_COLOR = (0.85, 0.55, 0.15, 1.0)
RIG_COLOR = (0.45, 0.60, 0.45, 1.0)
NUT_PLAY = stock.NUT_PLAY
BEARING_PRESS = 0.05        # a bearing's seat is this much under its outside diameter: pressed in, mm
SHAFT_CLEAR = 2.0           # the shaft's hole through a bearing seat's shoulder is this much over it, mm
TAP_M3 = 2.5                # the pilot an M3 screw cuts its thread into cured resin in, mm
UPRIGHT_SCREWS_X = 20.0     # the uprights' two screws up from the base plate, ±x, mm
CELL_THREAD = 4.0           # a screw's thread in the load cell's tapped end hole, mm
BLOCK_THREAD = 6.0          # and in the push block's pilot, mm
POINTER = (2.0, 2.0)        # the front upright's pointer fin the flange's marks are read at: its width, and how far
#                             it stops short of the flange's rim, mm
UPRIGHT_TOP = 8.0           # resin above the upper bearing's seat, mm
R_Y = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]])   # gear mesh frame -> robot (see _mesh_to_robot)


def _resting(solid: cq.Solid) -> np.ndarray:
    """The rotation (robot -> file) that sets the solid on a flat face it can rest on (nothing of the
    part beyond the face's plane: a flange with a hub standing out of it cannot rest), its outward
    normal turned to -Z: the largest such face square to the part's round features (:func:`_round_axis`:
    bearing seats, bores, bosses print round with their axis upright), else the largest such face."""
    points = np.array([v.toTuple() for v in solid.tessellate(0.05)[0]])
    resting = []
    for face in solid.Faces():
        if face.geomType() != "PLANE":
            continue
        n = np.array(face.normalAt().toTuple())
        if (points @ n).max() <= np.dot(face.Center().toTuple(), n) + 1e-6:
            resting.append((round(face.Area(), 6), tuple(np.round(n, 9)), n))
    if not resting:
        return np.eye(3)
    axis = _round_axis(solid)
    square = [f for f in resting if axis is not None and abs(f[2] @ axis) > 1 - 1e-9]
    _, _, n = max(square or resting, key=lambda f: f[:2])
    return _turning(n, np.array([0.0, 0.0, -1.0]))


def _round_axis(solid: cq.Solid) -> np.ndarray | None:
    """The direction the part's cylindrical faces (holes, seats, bosses) run along, weighted by their
    area; None for a part with none."""
    area: dict[tuple, float] = {}
    for face in solid.Faces():
        if face.geomType() == "CYLINDER":
            d = BRepAdaptor_Surface(face.wrapped).Cylinder().Axis().Direction()
            key = tuple(np.round(np.abs([d.X(), d.Y(), d.Z()]), 9))
            area[key] = area.get(key, 0.0) + face.Area()
    if not area:
        return None
    key = max(area, key=lambda k: (round(area[k], 6), k))
    return np.array(key) / np.linalg.norm(key)


def _turning(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rotation taking unit vector a to b (a half turn about x where they are opposite), with
    entries that are whole numbers kept exact."""
    c, axis = float(a @ b), np.cross(a, b)
    if c < -1 + 1e-12:
        r = np.diag([1.0, -1.0, -1.0])
    else:
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        r = np.eye(3) + k + k @ k / (1 + c)
    snapped = np.round(r)
    return np.where(np.abs(r - snapped) < 1e-12, snapped, r)


QUARTER = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])     # a quarter turn about Z: (x, y) -> (y, -x)


def _file(solid: cq.Solid, as_on_bench: bool = False) -> tuple[cq.Solid, np.ndarray]:
    """A robot-frame solid set on a flat face it can rest on (:func:`_resting`; with ``as_on_bench``,
    on the part's own base, robot -z, as it stands on the bench), turned a
    quarter about Z where it is then longer along Y than X (the printer's long axis is X; slicers
    place a part as its file has it), and moved so its box's lowest corner is at the origin:
    (file solid, placement file -> robot)."""
    r = np.eye(3) if as_on_bench else _resting(solid)
    turned = _turned(solid, r)
    bb = turned.BoundingBox()
    if bb.ylen > bb.xlen + 1e-6:
        r = QUARTER @ r
        turned = _turned(solid, r)
        bb = turned.BoundingBox()
    shift = np.array([bb.xmin, bb.ymin, bb.zmin])
    return turned.translate(cq.Vector(*(-shift))), placement(r.T, r.T @ shift)


def _turned(solid: cq.Solid, r: np.ndarray) -> cq.Solid:
    """The solid turned by the rotation r about the origin."""
    t = gp_Trsf()
    t.SetValues(*r[0], 0.0, *r[1], 0.0, *r[2], 0.0)
    return cq.Solid(BRepBuilderAPI_Transform(solid.wrapped, t, True).Shape())


def _mesh_to_robot(lay: FrameLayout) -> np.ndarray:
    """The gear's mesh frame (:mod:`hwgen.model.gearing`: wheel axis Z, worm axis along Y at X = a)
    -> robot: wheel axis along -y at the lower shaft, the worm below it (mesh X -> -z), along x."""
    return placement(R_Y, (0.0, lay.y_wheel, lay.z_lower))


def _d_bore(r: float, y0: float, y1: float, x: float = 0.0, z: float = 0.0) -> cq.Solid:
    """A D-shaped bore along y round (x, z): radius r, flat SHAFT_FLAT deep on +z."""
    c = cylinder(r, (x, y0, z), (x, y1, z))
    return c.intersect(box(x - r - 1, x + r + 1, min(y0, y1) - 1, max(y0, y1) + 1, z - r - 1, z + r - bf.SHAFT_FLAT))


def cradle_solid(lay: FrameLayout) -> cq.Solid:
    fx, y_fb, y_ff, z_foot, _ = lay.foot
    y0, y1 = lay.y_flange
    body = box(-fx, fx, y0, y_ff, lay.z_plate, z_foot).fuse(
        cylinder(lay.flange_radius, (0, y0, 0), (0, y1, 0)),
        cylinder(bf.HUB_RADIUS, (0, lay.hub[0], 0), (0, y0 + TOOL, 0))).clean()
    r = (lay.shaft_d - bf.PRESS_FIT) / 2
    tools = [_d_bore(r, lay.hub[0] - TOOL, y1 + TOOL)]
    af, th = bf.FOOT_NUTS[lay.foot_bolt]
    for x, y in lay.foot_holes:
        tools.append(cylinder(lay.foot_hole / 2, (x, y, lay.z_plate - TOOL), (x, y, z_foot + TOOL)))
        tools.append(hex_prism(af + NUT_PLAY, (x, y, lay.z_plate - TOOL), (x, y, lay.z_plate + th + NUT_PLAY), (1, 0, 0)))
    w, depth, length = bf.MARK
    steps = int(round(360.0 / lay.mark_step_deg))
    for k in range(steps):
        a = k * lay.mark_step_deg
        long = any(abs(((a - i + 180) % 360) - 180) < 1e-6 for i in bf.INDEX_ANGLES)
        ln = 2 * length if long else length
        rr = lay.flange_radius - 1.0
        mark = box(-w / 2, w / 2, y0 - TOOL, y0 + depth, -rr, -rr + ln)
        tools.append(mark.rotate(cq.Vector(0, 0, 0), cq.Vector(0, 1, 0), a))
    for a in bf.INDEX_ANGLES:
        # the hole that lies at the upright's index (robot +x) when the robot is turned by a
        t = math.radians(a)
        x, z = lay.index_radius * math.cos(t), lay.index_radius * math.sin(t)
        tools.append(cylinder((bf.INDEX_PIN + bf.RUNNING_FIT) / 2, (x, y0 - TOOL, z), (x, y1 + TOOL, z)))
    return one(body.cut(*tools))


def _upright(lay: FrameLayout, y_out: float, y_in: float, front: bool) -> cq.Solid:
    """An upright between its outer face ``y_out`` and inner face ``y_in`` (toward the other):
    the two bearings' seats pressed in from the inner face, a shoulder on the outer."""
    top = lay.bearing_od / 2 + UPRIGHT_TOP
    hx = lay.upright_half_x
    body = box(-hx, hx, y_out, y_in, lay.z_base, top)
    if front:
        body = body.fuse(box(-POINTER[0] / 2, POINTER[0] / 2, y_out, y_in, top - TOOL,
                             lay.flange_radius - POINTER[1])).clean()
    s = 1.0 if y_in > y_out else -1.0
    lip = y_out + s * bf.BEARING_LIP
    tools = []
    for z in (0.0, lay.z_lower):
        tools.append(cylinder((lay.bearing_od - BEARING_PRESS) / 2, (0, lip, z), (0, y_in + s * TOOL, z)))
        tools.append(cylinder((lay.shaft_d + SHAFT_CLEAR) / 2, (0, y_out - s * TOOL, z), (0, lip + s * TOOL, z)))
    if front:
        tools.append(cylinder((bf.INDEX_PIN + bf.RUNNING_FIT) / 2, (lay.index_radius, y_out - s * TOOL, 0),
                              (lay.index_radius, y_in + s * TOOL, 0)))
    ym = (y_out + y_in) / 2
    for x in (-UPRIGHT_SCREWS_X, UPRIGHT_SCREWS_X):
        # through to the top: no blind cup of resin
        tools.append(cylinder(TAP_M3 / 2, (x, ym, lay.z_base - TOOL), (x, ym, top + TOOL)))
    return one(body.cut(*tools))


def base_solid(lay: FrameLayout) -> cq.Solid:
    """The base plate with the worm's two posts: the near one carries the drive shaft, the far one
    the dowel the worm's far end turns on."""
    x0, x1, y0, y1 = lay.plate
    z0, z1 = lay.z_table, lay.z_base
    body = box(x0, x1, y0, y1, z0, z1)
    zt = lay.z_worm + max(DRIVE_SHAFT, bf.DOWEL_PIN) / 2 + bf.POST_WALL + 3.0
    posts = [box(*lay.near_post, lay.y_wheel - bf.POST_Y / 2, lay.y_wheel + bf.POST_Y / 2, z1 - TOOL, zt),
             box(*lay.far_post, lay.y_wheel - bf.POST_Y / 2, lay.y_wheel + bf.POST_Y / 2, z1 - TOOL, zt)]
    body = body.fuse(*posts).clean()
    m6 = stock.clearance_hole("M6")
    m3 = stock.clearance_hole("M3")
    tools = [cylinder(m6 / 2, (x, y, z0 - TOOL), (x, y, z1 + TOOL)) for x, y in lay.plate_holes]
    for ya, yb in (lay.front, lay.back):
        for x in (-UPRIGHT_SCREWS_X, UPRIGHT_SCREWS_X):
            tools.append(cylinder(m3 / 2, (x, (ya + yb) / 2, z0 - TOOL), (x, (ya + yb) / 2, z1 + TOOL)))
    y, z = lay.y_wheel, lay.z_worm
    tools.append(cylinder((DRIVE_SHAFT + bf.RUNNING_FIT) / 2, (lay.near_post[0] - TOOL, y, z),
                          (lay.near_post[1] + TOOL, y, z)))
    tools.append(cylinder((bf.DOWEL_PIN - bf.PRESS_FIT) / 2, (lay.far_post[0] - TOOL, y, z),
                          (lay.far_post[1] + TOOL, y, z)))
    return one(body.cut(*tools))


def frame_wheel_solid(lay: FrameLayout, gear: cq.Solid) -> cq.Solid:
    """The tensioner's generated gear (file Z 0 to the face width) with a hub on its -Z side and a
    D bore; file Z from the hub's end."""
    p = lay.pair
    hub = cq.Solid.makeCylinder(bf.WHEEL_HUB_RADIUS, bf.WHEEL_HUB + TOOL, cq.Vector(0, 0, -bf.WHEEL_HUB))
    body = gear.fuse(hub).clean()
    r = (lay.shaft_d - bf.PRESS_FIT) / 2
    bore = cq.Solid.makeCylinder(r, p.face_width + bf.WHEEL_HUB + 2, cq.Vector(0, 0, -bf.WHEEL_HUB - 1)).intersect(
        cq.Solid.makeBox(2 * r + 2, 2 * r + 2, p.face_width + bf.WHEEL_HUB + 4,
                         cq.Vector(-r - 1 + bf.SHAFT_FLAT, -r - 1, -bf.WHEEL_HUB - 2)))
    return one(body.cut(bore)).translate(cq.Vector(0, 0, bf.WHEEL_HUB))


def frame_parts(lay: FrameLayout) -> Iterator[Part]:
    """The base frame's printed parts, each with the bought parts it takes."""
    from .wheel import gear_solid
    from .worm import drive_solid, worm_solid
    p, hex_key = lay.pair, lay.hex_key
    nm, pin_depth = lay.worm_near_end, bf.DOWEL_LENGTH - POST + 0.5
    worm_inputs = (p, nm, DRIVE_HEX, bf.DOWEL_PIN + bf.RUNNING_FIT, pin_depth)
    worm = kept("worm", worm_inputs, lambda: worm_solid(*worm_inputs))
    gear = kept("throated wheel gear", p, lambda: gear_solid(p))
    drive_inputs = (float(POST), float(hex_key))
    drive = kept("drive shaft", drive_inputs, lambda: drive_solid(*drive_inputs))

    upper = stock.shortest_reaching(bp.lengths("shaft"), lay.upper_shaft[1] - lay.upper_shaft[0])
    lower = stock.shortest_reaching(bp.lengths("shaft"), lay.lower_shaft[1] - lay.lower_shaft[0])
    d = f"Ø{lay.shaft_d:g}"
    foot_len = stock.shortest_reaching(stock.lengths("socket head cap screw", "any"),
                                       lay.foot[4] - lay.z_plate + stock.size("washer", "M6", "thickness") + 0.5)
    bought = [
        hardware("ground shaft h6 with a flat", f"{d} × {upper:g}", 1, notes="⑤ the supporting shaft, on the robot's axis"),
        hardware("ground shaft h6 with a flat", f"{d} × {lower:g}", 1, notes="⑦ the lower shaft, under the wheel"),
        hardware("deep-groove ball bearing", lay.bearing, 4, notes="pressed into the uprights"),
        hardware("GT2 pulley", f"{lay.pulley_teeth}T, {d} bore, 6 mm belt", 2, material="aluminium",
                 notes="⑥ one on each shaft, set screws on the flats"),
        hardware("GT2 closed-loop belt", f"2GT-6, {lay.belt_length:g} mm", 1, material="rubber, glass fibre",
                 notes=f"⑥ centre distance {-lay.z_lower:.1f} mm"),
        hardware("dowel pin ISO 2338", f"Ø{bf.INDEX_PIN:g} × 20", 1, notes="the index at 0° and 90°"),
        hardware("dowel pin ISO 2338", f"Ø{bf.DOWEL_PIN:g} × {bf.DOWEL_LENGTH:g}", 1,
                 notes="the worm's far end turns on it, pressed into the far post"),
        hardware("socket head cap screw ISO 4762", "M3 × 16", 4, notes="the uprights onto the base plate"),
        hardware("socket head cap screw ISO 4762", "M6 × 16", len(lay.plate_holes), notes="the base plate to the breadboard" if lay.mounting == "breadboard"
                 else "the base plate to the rig's support"),
        hardware("socket head cap screw ISO 4762", f"M6 × {foot_len:g}" if lay.foot_bolt == "M6" else
                 f"1/4-20 × {math.ceil(foot_len / 25.4 * 4) / 4:g} in", len(lay.foot_holes),
                 notes="the mount's foot onto the cradle (in place of its screws to the table)"),
        hardware("hex nut ISO 4032" if lay.foot_bolt == "M6" else "hex nut ASME B18.2.2", lay.foot_bolt, len(lay.foot_holes),
                 notes="the mount's foot screws, in the cradle's nut traps"),
    ]
    if lay.mounting == "table_edge":
        bought.append(hardware("G-clamp", "75 mm throat", 2, notes="the base plate at the table's edge"))
    common = {"grounded": True, "bench": "base_frame"}

    # the cradle stands on its foot: on its flange's outer face (square to its bore) the index
    # marks on the face toward the pointer would open upward, cups that hold resin (print.cup)
    solid, place = _file(cradle_solid(lay), as_on_bench=True)
    yield Part("base_frame_cradle", "base_frame", solid, place, CRADLE_COLOR,
               meta={**common, "turns": True, "hardware": bought, "mark_step_deg": lay.mark_step_deg,
                     "index_deg": list(bf.INDEX_ANGLES), "axis": [0.0, 1.0, 0.0]})
    solid, place = _file(_upright(lay, lay.front[1], lay.front[0], True))
    yield Part("base_frame_front", "base_frame", solid, place, FRAME_COLOR, meta=common)
    solid, place = _file(_upright(lay, lay.back[0], lay.back[1], False))
    yield Part("base_frame_back", "base_frame", solid, place, FRAME_COLOR, meta=common)
    solid, place = _file(base_solid(lay))
    yield Part("base_frame_base", "base_frame", solid, place, FRAME_COLOR, meta=common)

    m2r = _mesh_to_robot(lay)
    t = np.eye(4)
    t[2, 3] = -(p.face_width / 2 + bf.WHEEL_HUB)
    yield Part("base_frame_wheel", "base_frame_gear", frame_wheel_solid(lay, gear), m2r @ t, GEAR_COLOR,
               meta={**common, "turns": True, "mesh_with": "base_frame_worm", "teeth": p.teeth})
    n = round(-p.worm_length / (2 * p.pitch))
    wf = np.eye(4)
    wf[:3, :3] = WORM_TO_MESH
    wf[:3, 3] = [p.center_distance, -nm + n * p.pitch, 0.0]
    yield Part("base_frame_worm", "base_frame_gear", worm, m2r @ wf, GEAR_COLOR,
               meta={**common, "hex_key_mm": hex_key})
    td = np.eye(4)
    td[2, 3] = -(POST + AXIAL_PLAY / 2 + DRIVE_FLANGE[1])
    yield Part("base_frame_drive", "base_frame_gear", drive, m2r @ wf @ td, GEAR_COLOR,
               meta={**common, "hex_key_mm": hex_key})


# ------------------------------------------------------------------------------------------- rig

def push_block_solid(lay: RigLayout) -> cq.Solid:
    """Under the cell's free end: a block the cell's screws come down into (through its end holes,
    cutting their thread in the block's pilots, open through the pad so no cup forms), the pad below
    it over the disk, centred under the holes where the cell is loaded."""
    w = lay.cell[1]
    y = lay.y_disk
    xa = min(lay.free_holes) - 4.0
    xb = lay.cell_x[1]
    z_body = lay.z_pad + 4.0
    body = box(xa, xb, y - w / 2, y + w / 2, z_body, lay.cell_z)
    pad = box(-PAD[1] / 2, PAD[1] / 2, y - PAD[0] / 2, y + PAD[0] / 2, lay.z_pad, z_body + TOOL)
    body = body.fuse(pad).clean()
    tools = [cylinder(TAP_M3 / 2 if lay.screw == "M3" else lay.screw_hole / 2 - 0.45, (x, y, lay.z_pad - TOOL),
                      (x, y, lay.cell_z + TOOL)) for x in lay.free_holes]
    return one(body.cut(*tools))


def bracket_solid(lay: RigLayout) -> cq.Solid:
    """Over the cell's fixed end: an arm, a column up to the flange's disc, the spigot."""
    w = lay.cell[1] + 6.0
    y = lay.y_disk
    x0 = lay.cell_x[0]
    z_top = lay.cell_z + lay.cell[2]
    xe = max(lay.fixed_holes) + bp_screw_head(lay.screw) / 2 + 2.0
    cx, cy = lay.flange_centre
    zf = lay.z_flange
    parts = [box(x0 - COLUMN, xe, y - w / 2, y + w / 2, z_top, z_top + ARM),
             box(x0 - COLUMN, x0, y - w / 2, y + w / 2, z_top + ARM - TOOL, zf - DISC + TOOL),
             cylinder(lay.flange_diameter / 2, (cx, cy, zf - DISC), (cx, cy, zf))]
    if lay.spigot:
        parts.append(cylinder(lay.spigot / 2, (cx, cy, zf - TOOL), (cx, cy, zf + SPIGOT)))
    body = parts[0].fuse(*parts[1:]).clean()
    head = bp_screw_head(lay.screw) + 0.5
    tools = []
    for x in lay.fixed_holes:
        tools.append(cylinder(lay.screw_hole / 2, (x, y, z_top - TOOL), (x, y, z_top + ARM + TOOL)))
        tools.append(cylinder(head / 2, (x, y, z_top + 3.0), (x, y, z_top + ARM + TOOL)))
    for x, yy in lay.flange_holes:
        tools.append(cylinder(lay.flange_hole / 2, (x, yy, zf - DISC - TOOL), (x, yy, zf + SPIGOT + TOOL)))
    if lay.pin is not None:
        px, py = lay.pin
        tools.append(cylinder((lay.pin_diameter + 0.1) / 2, (px, py, zf - DISC - TOOL), (px, py, zf + TOOL)))
    tools.append(cylinder(3.0, (cx, cy, zf - DISC - TOOL), (cx, cy, zf + SPIGOT + TOOL)))   # drains the spigot
    return one(body.cut(*tools))


def support_solid(lay: RigLayout) -> cq.Solid:
    """Under the base frame's plate: a hollow block with a ledge front and back for its own screws."""
    x0, x1, y0, y1, z0, z1 = lay.support
    yi0, yi1 = y0 + (y1 - y0 - _plate_len(lay)) / 2, y1 - (y1 - y0 - _plate_len(lay)) / 2
    body = box(x0, x1, yi0, yi1, z0, z1).fuse(box(x0, x1, y0, yi0 + TOOL, z0, z0 + LEDGE),
                                              box(x0, x1, yi1 - TOOL, y1, z0, z0 + LEDGE)).clean()
    tools = [box(x0 + WALL, x1 - WALL, yi0 + WALL, yi1 - WALL, z0 - TOOL, z1 - WALL)]
    tools += [cylinder(lay.bolt_hole / 2, (x, y, z1 - WALL - TOOL), (x, y, z1 + TOOL)) for x, y in lay.support_holes]
    tools += [cylinder(lay.bolt_hole / 2, (x, y, z0 - TOOL), (x, y, z0 + LEDGE + TOOL)) for x, y in lay.support_feet]
    return one(body.cut(*tools))


def _plate_len(lay: RigLayout) -> float:
    return lay.support[3] - lay.support[2] - 2 * LEDGE_Y


def rig_parts(lay: RigLayout) -> Iterator[Part]:
    common = {"grounded": True, "bench": "rig"}
    lengths = stock.lengths("socket head cap screw", "any")
    fixed_len = stock.shortest_reaching(lengths, 3.0 + CELL_THREAD)               # the arm under the head, then the cell
    free_len = stock.shortest_reaching(lengths, lay.cell[2] + BLOCK_THREAD)       # through the cell into the block
    bought = [
        hardware("beam load cell", f"{lay.cell_name}, 0-{lay.range_n:g} N", 1, material="aluminium",
                 notes=f"{lay.cell[0]:g} × {lay.cell[1]:g} × {lay.cell[2]:g} mm"),
        hardware("socket head cap screw ISO 4762", f"{lay.screw} × {fixed_len:g}", 2,
                 notes="down through the bracket's arm into the cell's fixed end"),
        hardware("socket head cap screw ISO 4762", f"{lay.screw} × {free_len:g}", 2,
                 notes="down through the cell's free end into the push block's pilots"),
        hardware("socket head cap screw ISO 4762", "M6 × 16", len(lay.flange_holes),
                 notes="the bracket to the " + ("arm's flange" if lay.pin else "stage's carriage")),
        hardware("socket head cap screw ISO 4762", "M6 × 20", len(lay.support_feet), notes="the support to the table"),
        hardware("hex nut ISO 4032", "M6", len(lay.support_holes), notes="the frame's plate screws, inside the support"),
    ]
    if lay.pin is not None:
        bought.append(hardware("dowel pin ISO 2338", f"Ø{lay.pin_diameter:g} × 10", 1, notes="the flange's locating pin"))
    solid, place = _file(bracket_solid(lay))
    yield Part("rig_bracket", "rig", solid, place, RIG_COLOR, meta={**common, "hardware": bought,
                                                                     "flange": lay.flange})
    solid, place = _file(push_block_solid(lay))
    yield Part("rig_push_block", "rig", solid, place, RIG_COLOR,
               meta={**common, "pushes_station": lay.station, "pushes": "down, on the disk's rim"})
    solid, place = _file(support_solid(lay))
    yield Part("rig_support", "rig", solid, place, RIG_COLOR, meta=common)


__all__ = ["frame_parts", "rig_parts"]
