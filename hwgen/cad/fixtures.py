"""The base mount (two jaws that clamp the strip's base and bolt to a table) and the assembly jig.

Solids are built in robot coordinates from :mod:`hwgen.model.fixtures` and moved to their print
orientation (the largest flat face on Z = 0) for their files; the placement maps them back.
"""
from __future__ import annotations

import math
from collections.abc import Iterator

import cadquery as cq
import numpy as np

from ..model import hardware as stock
from ..model.fixtures import NUT_AF, NUT_DEPTH, NUT_PLAY, NUT_THICK, JigLayout, MountLayout
from . import Part, placement
from .primitives import TOOL, box, cylinder, hardware, one

MOUNT_COLOR = (0.35, 0.40, 0.48, 1.0)     # slate: it stays on the table
CLAMP_COLOR = (0.55, 0.62, 0.72, 1.0)
JIG_COLOR = (0.80, 0.80, 0.78, 1.0)
SCREW_LENGTHS = stock.lengths("socket head cap screw", "any")   # ISO 4762 stock lengths, mm
WASHER = stock.size("washer", "M3", "thickness")                 # ISO 7089 M3 washer, mm
M6_WASHER = stock.size("washer", "M6", "thickness")              # ISO 7089 M6 washer, mm
TABLE_THREAD = 8.0                         # engagement of the foot bolts in the table's tapped holes, mm


def _screw(length_needed: float) -> int:
    """The shortest stock screw that reaches through its nut."""
    return stock.shortest_reaching(SCREW_LENGTHS, length_needed)


def _nut_trap(x: float, y: float, z_top: float, outward: float, x_out: float) -> list[cq.Solid]:
    """An M3 nut pocket (hexagon, flats along y) with its top at z_top, and the slot it slides in
    through from the side at x_out."""
    af = NUT_AF + NUT_PLAY
    th = NUT_THICK + NUT_PLAY
    r = af / math.sqrt(3)
    pts = [(x + r * math.cos(math.radians(60 * k)), y + r * math.sin(math.radians(60 * k))) for k in range(6)]
    wire = cq.Wire.makePolygon([cq.Vector(px, py, z_top - th) for px, py in pts], close=True)
    hexagon = cq.Solid.extrudeLinear(cq.Face.makeFromWires(wire), cq.Vector(0, 0, th))
    x0, x1 = sorted((x, x_out + outward * TOOL))
    return [hexagon, box(x0, x1, y - af / 2, y + af / 2, z_top - th, z_top)]


def mount_solids(lay: MountLayout) -> tuple[cq.Solid, cq.Solid]:
    """(lower jaw with its column and foot, upper jaw), in robot coordinates."""
    hx = lay.jaw_half_x
    lower = box(-hx, hx, lay.y_back, lay.y_face, lay.z_jaw_bottom, lay.z_lower_top)
    column = box(-hx, hx, lay.y_back, lay.y_column_front, lay.z_foot_top - TOOL, lay.z_jaw_bottom + TOOL)
    foot = box(-lay.foot_half_x, lay.foot_half_x, lay.y_foot_back, lay.y_column_front, lay.z_table, lay.z_foot_top)
    body = lower.fuse(column, foot).clean()
    r = lay.screw_hole / 2
    tools = [box(-lay.recess_half_x, lay.recess_half_x, lay.y_back - TOOL, lay.y_face + TOOL, lay.z_recess,
                  lay.z_lower_top + TOOL)]
    for x, z in lay.disk_screws:
        if z < 0:
            tools.append(cylinder(r, (x, lay.y_face + TOOL, z), (x, lay.y_back - TOOL, z)))
    z_nut = lay.z_lower_top - NUT_DEPTH
    for x, y in lay.jaw_screws:
        side = 1.0 if x > 0 else -1.0
        # through to the table: a blind hole would be a cup of resin on a resin print; open, it drains
        tools.append(cylinder(r, (x, y, lay.z_lower_top + TOOL), (x, y, lay.z_table - TOOL)))
        tools += _nut_trap(x, y, z_nut, side, side * hx)
    for x, y in lay.foot_holes:
        tools.append(cylinder(lay.foot_hole / 2, (x, y, lay.z_table - TOOL), (x, y, lay.z_foot_top + TOOL)))
    lower = one(body.cut(*tools))
    upper = box(-hx, hx, lay.y_back, lay.y_face, lay.z_upper_bottom, lay.z_upper_top)
    tools = [cylinder(r, (x, y, lay.z_upper_top + TOOL), (x, y, lay.z_upper_bottom - TOOL)) for x, y in lay.jaw_screws]
    tools += [cylinder(r, (x, lay.y_face + TOOL, z), (x, lay.y_back - TOOL, z)) for x, z in lay.disk_screws if z > 0]
    return lower, one(upper.cut(*tools))


# a quarter turn about Z: file (X, Y) = robot (y, -x), so a part long along the backbone lies along
# the file's X (the printer's long axis; slicers place a part as its file has it)
ALONG_X = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def _to_file(solid: cq.Solid, shift, along_x: bool = False) -> tuple[cq.Solid, np.ndarray]:
    """Move a robot-frame solid into its file (translated by -shift, and turned a quarter about Z
    when ``along_x``); the placement moves it back."""
    s = np.asarray(shift, float)
    moved = solid.translate(cq.Vector(*(-s)))
    if along_x:
        moved = moved.rotate(cq.Vector(0, 0, 0), cq.Vector(0, 0, 1), -90)
        return moved, placement(ALONG_X, s)
    return moved, placement(np.eye(3), s)


def build_mount(lay: MountLayout) -> Iterator[Part]:
    """The base mount's two parts, as ``lay`` lays them out."""
    lower, upper = mount_solids(lay)
    t_disk = lay.disk_thickness
    depth = lay.y_face - lay.y_back
    jaw_len = _screw(_jaw_grip(lay) + NUT_DEPTH + NUT_THICK + 0.5)
    disk_len = _screw(t_disk + depth + WASHER + NUT_THICK + 0.5)
    foot_len = _screw(lay.z_foot_top - lay.z_table + M6_WASHER + TABLE_THREAD)
    foot_size = (f"{lay.bolt} × {foot_len}" if lay.bolt == "M6" else
                 f"{lay.bolt} × {math.ceil(foot_len / 25.4 * 4) / 4:g} in")
    bought = [
        hardware("socket head cap screw ISO 4762", foot_size, len(lay.foot_holes),
            notes=f"to the table, on its {lay.pitch:g} mm grid, with washers"),
        hardware("washer ISO 7089", lay.bolt, len(lay.foot_holes)),
        hardware("socket head cap screw ISO 4762", f"M3 × {jaw_len}", len(lay.jaw_screws),
            notes="upper jaw onto the strip"),
        hardware("socket head cap screw ISO 4762", f"M3 × {disk_len}", len(lay.disk_screws),
            notes="base disk to the jaws, from the disk's inner face"),
        hardware("hex nut ISO 4032", "M3", len(lay.jaw_screws) + len(lay.disk_screws),
            notes="jaw screws in the lower jaw's nut traps; disk screws on the jaws' back face"),
        hardware("washer ISO 7089", "M3", len(lay.disk_screws)),
    ]
    solid, place = _to_file(lower, (0.0, 0.0, lay.z_table))
    yield Part("base_mount", "base_mount", solid, place, MOUNT_COLOR,
               meta={"hardware": bought, "bolt_pattern": lay.bolt_pattern, "grounded": True})
    solid, place = _to_file(upper, (0.0, 0.0, lay.z_upper_bottom))
    yield Part("base_clamp", "base_clamp", solid, place, CLAMP_COLOR, meta={"grounded": True})


def _jaw_grip(lay: MountLayout) -> float:
    """Screw length above the lower jaw's top face: the upper jaw and the gap beside the strip."""
    return lay.z_upper_top - lay.z_lower_top


def _dovetail(lay: JigLayout, y: float, z0: float, z1: float, play: float, x: float) -> cq.Solid:
    """A dovetail key (play 0) whose neck is at y and which widens toward +y, or the socket for
    one (play > 0, every edge that much further out); it starts TOOL behind y so a key fuses to its
    piece and a socket opens out of its piece's end."""
    neck, end, depth = lay.dovetail
    n, e, p = neck / 2 + play, end / 2 + play, play
    pts = [(x - n, y - TOOL), (x + n, y - TOOL), (x + n, y), (x + e, y + depth + p), (x - e, y + depth + p), (x - n, y)]
    wire = cq.Wire.makePolygon([cq.Vector(px, py, z0) for px, py in pts], close=True)
    return cq.Solid.extrudeLinear(cq.Face.makeFromWires(wire), cq.Vector(0, 0, z1 - z0))


def jig_solid(lay: JigLayout, k: int) -> cq.Solid:
    """One piece of the jig, in robot coordinates: a U (floor and two comb walls) along y, slots
    where the disks go, dovetail keys out of its +y end and sockets in its -y end."""
    pc = lay.pieces[k]
    xi, xo = lay.x_inner, lay.x_outer
    zb, zf, zt = lay.z_floor_bottom, lay.z_floor_top, lay.z_top
    profile = [(-xo, zb), (xo, zb), (xo, zt), (xi, zt), (xi, zf), (-xi, zf), (-xi, zt), (-xo, zt)]
    wire = cq.Wire.makePolygon([cq.Vector(x, pc.y0, z) for x, z in profile], close=True)
    body = cq.Solid.extrudeLinear(cq.Face.makeFromWires(wire), cq.Vector(0, pc.y1 - pc.y0, 0))
    if pc.key_out:
        body = body.fuse(*[_dovetail(lay, pc.y1, zb, zf, 0.0, x) for x in lay.dovetail_x]).clean()
    tools = []
    for a, b in lay.slots:
        if b < pc.y0 or a > pc.y1:
            continue
        for s in (-1, 1):
            x0, x1 = sorted((s * (xi - TOOL), s * lay.x_slot))
            tools.append(box(x0, x1, a, b, zf, zt + TOOL))
    if pc.key_in:
        tools += [_dovetail(lay, pc.y0, zb - TOOL, zf + TOOL, lay.play, x) for x in lay.dovetail_x]
    return one(body.cut(*tools)) if tools else one(body)


def build_jig(lay: JigLayout, holds: list[str]) -> Iterator[Part]:
    """The jig's pieces, as ``lay`` lays them out; ``holds``: the parts it holds (disks, then the strip)."""
    for k, pc in enumerate(lay.pieces):
        solid, place = _to_file(jig_solid(lay, k), (0.0, pc.y0, lay.z_floor_bottom), along_x=True)
        yield Part(f"jig_{k + 1}", "jig", solid, place, JIG_COLOR,
                   meta={"fixture": True, "holds": holds, "piece": k + 1, "pieces": len(lay.pieces),
                         "station_tolerance_mm": lay.station_tolerance_mm})


__all__ = ["build_mount", "build_jig"]
