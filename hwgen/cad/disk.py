"""Tendon-support disks: one 2D face (outline, slot, holes normal to the disk) extruded once, the
hub (one face: the sleeve around the slot, with its tendon windows) extruded and fused to it,
then every slanted eyelet, rim chamfer, glue port and (base disk) seat removed in a single cut.

Every disk file has its flat face on Z = 0 and the hub standing up from Z = T: the tip disk,
whose hub runs toward the base, is turned over for printing. On the base disk the eyelet bores
stop at the seat plate on its outer face (Z = 0 to the plate's thickness), which has a seat per
tendon."""
from __future__ import annotations

import dataclasses
import itertools
import math

import cadquery as cq
import numpy as np

from ..model.fixing import seat_reach
from ..model.holes import AXIS_CUT_FRACTION
from ..model.specs import DiskSpec, Hole, HubSpec
from . import DISK_ROTATION, Part, disk_placement

COLOR = (0.93, 0.86, 0.62, 1.0)     # resin yellow
NORMAL_AXIS_TOL = 1e-9              # an eyelet this close to the disk normal is drilled in the 2D face
TOOL_OVERRUN = 1.0                  # tools run this far past the faces, mm
CONE_HALF_ANGLE_DEG = 45.0          # the chamfer cones around the eyelet axes
CONE_FLOOR_DEG = 5.0                # ... are narrowed on axes steeper than 90° - this - 45°, so their lowest line rises
CONE_MIN_DEG = 10.0                 # narrower than this, a slanted eyelet gets no chamfer
MIN_EDGE = 0.05                     # a chamfer smaller than this (mm) is left off
MEET_VOLUME = 1e-6                  # two eyelets' tools sharing more than this (mm³) inside the disk meet


def sketch_xy(x: float, z: float) -> tuple[float, float]:
    """A point of the disk's plane (x, z) in its sketch's coordinates (the bench's OpenSCAD disks use them too)."""
    return x, -z


def _revolved(profile: list[tuple[float, float]], origin, axis) -> cq.Solid:
    """Solid of revolution of a closed (radius, height) profile around a line in space."""
    pts = [cq.Vector(r, 0, h) for r, h in profile]
    face = cq.Face.makeFromWires(cq.Wire.makePolygon(pts, close=True))
    solid = cq.Solid.revolve(face, 360, cq.Vector(0, 0, 0), cq.Vector(0, 0, 1))
    # rotate local +Z onto the axis, then move to the origin
    z = np.array([0.0, 0.0, 1.0])
    a = np.asarray(axis, dtype=float)
    a /= np.linalg.norm(a)
    c = float(np.dot(z, a))
    if c < 1 - 1e-12:
        rot_axis = np.cross(z, a)
        ang = math.degrees(math.acos(max(-1.0, min(1.0, c))))
        solid = solid.rotate(cq.Vector(0, 0, 0), cq.Vector(*rot_axis), ang)
    return solid.translate(cq.Vector(*origin))


def eyelet_profiles(h: Hole, thickness: float, edge: float, base_side: bool, tip_side: bool,
                    with_bore: bool) -> tuple[tuple[float, float, float], np.ndarray, list[list[tuple[float, float]]]]:
    """What is removed for one eyelet, as closed (radius, axial) profiles to revolve about its axis:
    (origin in file coordinates, unit axis in file coordinates, profiles). The bore (if slanted) and
    the chamfer cones at the rims, along the hole axis from the mid-plane crossing; the cones start
    where the rim on the steep side of a slanted hole meets the face, so the chamfer is ``edge``
    (smaller, or none, where a wide steep hole in a thin disk leaves no room clear of the checks'
    axis cuts, AXIS_CUT_FRACTION off the mid-plane) and never reaches the mid-plane.
    """
    ax = np.array([h.axis[0], -h.axis[2], h.axis[1]])   # robot disk axes -> file axes
    cos_t = abs(ax[2])
    r = h.diameter / 2
    tan_t = math.sqrt(max(0.0, 1 - cos_t**2)) / cos_t
    u_face = thickness / 2 / cos_t                     # axial distance mid-plane -> face
    # the cones start clear of where the checks cut the bore (a wide, steep hole in a thin disk
    # leaves less room than ``edge``: a smaller chamfer there, or none)
    room = (0.5 - AXIS_CUT_FRACTION) * thickness / cos_t - 2 * r * tan_t
    if room < edge:
        edge = room if room >= MIN_EDGE else 0.0
    u_cone = u_face - edge - r * tan_t                  # where the chamfer cone starts
    u_end = u_face + r * tan_t + TOOL_OVERRUN
    r_end = r + edge + (u_end - u_face) + r * tan_t     # 45° cone
    tilt = math.degrees(math.acos(min(1.0, cos_t)))
    if tilt + CONE_HALF_ANGLE_DEG > 90.0 - CONE_FLOOR_DEG:
        # a 45° cone around a steeper axis reaches below its own start on the downhill side: a
        # pocket closed below as the disk prints face down. Narrow it so its lowest line still
        # rises CONE_FLOOR_DEG; past CONE_MIN_DEG no chamfer is worth it.
        half = 90.0 - tilt - CONE_FLOOR_DEG
        if half < CONE_MIN_DEG:
            edge = 0.0
        else:
            r_end = r + (u_end - u_cone) * math.tan(math.radians(half))
    prof_top = [(r, u_cone), (r_end, u_end)] if (tip_side and edge > 0) else [(r, u_end)]
    prof_bot = [(r_end, -u_end), (r, -u_cone)] if (base_side and edge > 0) else [(r, -u_end)]
    x, y = sketch_xy(h.x, h.z)
    origin = (x, y, thickness / 2)
    if with_bore:
        return origin, ax, [[(0, -u_end)] + prof_bot + prof_top + [(0, u_end)]]
    cones = []
    if edge > 0 and base_side:
        cones.append([(0, -u_end), (r_end, -u_end), (r, -u_cone), (0, -u_cone)])
    if edge > 0 and tip_side:
        cones.append([(0, u_cone), (r, u_cone), (r_end, u_end), (0, u_end)])
    return origin, ax, cones


def _eyelet_tool(h: Hole, thickness: float, edge: float, base_side: bool, tip_side: bool,
                 with_bore: bool) -> cq.Solid | list[cq.Solid]:
    """The solid removed for one eyelet (``with_bore``), or its chamfer cones: the revolved
    :func:`eyelet_profiles`."""
    origin, ax, profiles = eyelet_profiles(h, thickness, edge, base_side, tip_side, with_bore)
    solids = [_revolved(p, origin, ax) for p in profiles]
    return solids[0] if with_bore else solids


def chamfer_edges(holes: list[Hole], thickness: float, edge: float, base_side: bool,
                  blank: cq.Shape) -> list[float]:
    """Each eyelet's chamfer: ``edge``, or none on two eyelets whose bores and chamfers meet inside
    the disk. Steep eyelets close together (a mirrored pair converging on a face) have chamfer
    cones that run into each other: the ridge left between them is a knife edge no printer makes
    and no tendon is eased over, and the cut leaves slivers of face, bounded by the cones' meeting
    curve, that the STL's mesher leaves open. Both are drilled plain; the wall between them is
    the ``eyelet.wall`` checks' to judge."""
    if edge <= 0 or len(holes) < 2:
        return [edge] * len(holes)
    # no tool reaches further from its eyelet's centre than its far rim: a pair further apart is not tried
    reach = []
    for h in holes:
        _, _, (profile,) = eyelet_profiles(h, thickness, edge, base_side, True, with_bore=True)
        reach.append(max(math.hypot(r, u) for r, u in profile))
    tools: dict[int, cq.Solid] = {}
    plain = set()
    for i, j in itertools.combinations(range(len(holes)), 2):
        if math.hypot(holes[i].x - holes[j].x, holes[i].z - holes[j].z) > reach[i] + reach[j]:
            continue
        a, b = (tools.setdefault(k, _eyelet_tool(holes[k], thickness, edge, base_side, True, with_bore=True))
                for k in (i, j))
        met = a.intersect(b)
        if met.Volume() > MEET_VOLUME and met.intersect(blank).Volume() > MEET_VOLUME:
            plain |= {i, j}
    return [0.0 if i in plain else edge for i in range(len(holes))]


def _hub_solid(spec: DiskSpec, hub: HubSpec) -> cq.Solid:
    """The sleeve around the slot, in file coordinates of the unflipped disk (Z = robot y - y0):
    from the tip-side face up (side +1) or from the base-side face down (side -1); cut away over
    its tendon windows, which cross it from top to bottom."""
    w, h = spec.slot_width + 2 * hub.wall, spec.slot_height + 2 * hub.wall
    sk = cq.Sketch().rect(w, h).push([(0, 0)]).rect(spec.slot_width, spec.slot_height, mode="s")
    for a, b in hub.windows:
        sk = sk.push([((a + b) / 2, 0)]).rect(b - a, h + 2 * TOOL_OVERRUN, mode="s")
    z0 = spec.thickness if hub.side > 0 else -hub.length
    return cq.Workplane("XY").workplane(offset=z0).placeSketch(sk.reset().clean()).extrude(hub.length).val()


def _port_tool(spec: DiskSpec, hub: HubSpec) -> cq.Solid:
    """The glue port: a hole from inside the slot out through the hub's +z wall (file -Y)."""
    x, off, dia = hub.port
    z = spec.thickness + off if hub.side > 0 else -off
    reach = spec.slot_height / 2 + hub.wall + TOOL_OVERRUN
    return cq.Solid.makeCylinder(dia / 2, reach, cq.Vector(x, 0, z), cq.Vector(0, -1, 0))


def _truncated(tool: cq.Solid, z_from: float, spec: DiskSpec) -> cq.Solid:
    """The part of a tool above the file plane Z = z_from (the seat plate's top)."""
    big = spec.outer_diameter + 4 * TOOL_OVERRUN
    box = cq.Solid.makeBox(big, big, spec.thickness + 2 * TOOL_OVERRUN - z_from,
                           cq.Vector(-big / 2, -big / 2, z_from))
    return tool.intersect(box)


def _blank(spec: DiskSpec, normal: list[Hole]) -> cq.Solid:
    """The disk body: outline, slot, the ``normal`` holes and bolt holes extruded, the hub fused on."""
    sk = cq.Sketch().circle(spec.outer_diameter / 2)
    sk = sk.push([(0, 0)]).rect(spec.slot_width, spec.slot_height, mode="s")
    for h in normal:
        sk = sk.push([sketch_xy(h.x, h.z)]).circle(h.diameter / 2, mode="s")
    for x, z, dia in spec.mount_holes:
        sk = sk.push([sketch_xy(x, z)]).circle(dia / 2, mode="s")
    blank = cq.Workplane("XY").placeSketch(sk.reset().clean()).extrude(spec.thickness).val()
    if spec.hub is not None:
        blank = blank.fuse(_hub_solid(spec, spec.hub)).clean()
    return blank


def _normal_holes(spec: DiskSpec) -> list[Hole]:
    """The eyelets drilled along the disk's normal (extruded with the plate): none on the base disk."""
    return [h for h in spec.holes if abs(abs(h.axis[1]) - 1) < NORMAL_AXIS_TOL and not spec.seats]


def _drilled(spec: DiskSpec, normal: list[Hole]) -> list[Hole]:
    """Every eyelet as drilled: the normal ones along the normal exactly, their chamfers too (an axis
    2e-5 rad off it left them meeting the bore nearly tangent, a bore face the STL's mesher left open)."""
    return [dataclasses.replace(h, axis=(0.0, math.copysign(1.0, h.axis[1]), 0.0)) if h in normal else h
            for h in spec.holes]


def eyelet_edges(spec: DiskSpec) -> list[float]:
    """Each eyelet's chamfer as the disk is cut (:func:`chamfer_edges`), in the order of ``spec.holes``:
    what another writer of the same disk (the bench's OpenSCAD) needs to make the same eyelets."""
    normal = _normal_holes(spec)
    return chamfer_edges(_drilled(spec, normal), spec.thickness, spec.edge_size, not spec.seats,
                         _blank(spec, normal))


def blank_and_tools(spec: DiskSpec) -> tuple[cq.Solid, list[cq.Solid]]:
    """The disk body (outline, slot, normal holes and bolt holes extruded, the hub fused on) and
    every solid still to cut."""
    T = spec.thickness
    seated = bool(spec.seats)               # the base disk: bores stop at the seat plate
    normal = _normal_holes(spec)
    slanted = [h for h in spec.holes if h not in normal]
    blank = _blank(spec, normal)

    # The base disk's outer face (file Z = 0) is the seat plate: no bore or chamfer reaches it.
    base_side = not seated
    drilled = _drilled(spec, normal)
    edges = chamfer_edges(drilled, T, spec.edge_size, base_side, blank)
    tools: list[cq.Solid] = []
    for h, drill, edge in zip(spec.holes, drilled, edges):
        if h in slanted:
            tool = _eyelet_tool(h, T, edge, base_side, True, with_bore=True)
            tools.append(_truncated(tool, spec.seat_plate, spec) if seated and not h.in_slot else tool)
        else:
            tools.extend(_eyelet_tool(drill, T, edge, base_side, True, with_bore=False))
    for s in spec.seats:
        fx, fy = sketch_xy(s.x, s.z)
        reach = seat_reach(s, next((h for h in spec.holes if s.tendon in h.tendons), None), T, spec.seat_plate)
        tools.append(cq.Solid.makeCylinder(s.diameter / 2, spec.seat_plate + reach + TOOL_OVERRUN,
                                           cq.Vector(fx, fy, -TOOL_OVERRUN)))
    for x, z, dia, height in spec.seat_chambers:
        fx, fy = sketch_xy(x, z)
        tools.append(cq.Solid.makeCylinder(dia / 2, height, cq.Vector(fx, fy, spec.seat_plate)))
    if spec.hub is not None and spec.hub.port is not None:
        tools.append(_port_tool(spec, spec.hub))
    return blank, tools


def build_disk(spec: DiskSpec) -> Part:
    T = spec.thickness
    blank, tools = blank_and_tools(spec)
    body = blank.cut(*tools) if tools else blank  # one boolean with every tool
    if tools and not _sound_cut(body, blank):
        # two slanted bores that nearly coincide (tendons routed almost together) can make OCCT's
        # one multi-tool cut come out inverted (a negative volume): cut them one at a time instead
        body = blank
        for tool in tools:
            body = body.cut(tool)
    if spec.seat_chambers:
        body = _one_floor(body, blank)
    solid = body if isinstance(body, cq.Solid) else body.Solids()[0]
    place = disk_placement(spec.y, T)
    if spec.hub is not None and spec.hub.side < 0:
        # the hub runs toward the base: turn the disk over so its flat face rests on the plate
        solid = solid.rotate(cq.Vector(0, 0, 0), cq.Vector(1, 0, 0), 180).translate(cq.Vector(0, 0, T))
        place = place @ flip_about_x(T)
    meta = {"disk_role": spec.role, "thickness_mm": T, "engagement_mm": spec.engagement}
    return Part(spec.name, "disk", solid, place, COLOR, station=spec.index, meta=meta)


def _one_floor(body: cq.Shape, blank: cq.Shape) -> cq.Shape:
    """A seat chamber's floor and the eyelet bores cut short at the seat plate lie in one plane, the
    plate's top: the cut leaves it as several faces, two outlines that nearly meet (seats 1.7 mm
    apart) making faces of no area whose edges the STL's tessellation leaves open. Merged into one
    face (OCCT's unify-same-domain), with the volume checked: the body as cut where that fails."""
    merged = body.clean()
    return merged if _sound_cut(merged, blank) and abs(merged.Volume() - body.Volume()) < 1e-6 * blank.Volume() \
        else body


def _sound_cut(body: cq.Shape, blank: cq.Shape) -> bool:
    """Whether a cut came out a valid solid with no more than the blank's volume and some of it left."""
    return body.isValid() and 0 < body.Volume() <= blank.Volume() + 1e-6


def flip_about_x(thickness: float) -> np.ndarray:
    """Inverse of the print flip (half turn about X, lifted by the thickness); it is its own inverse."""
    m = np.diag([1.0, -1.0, -1.0, 1.0])
    m[2, 3] = thickness
    return m


__all__ = ["build_disk", "DISK_ROTATION"]
