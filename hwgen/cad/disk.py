"""Tendon-support disks: one 2D face (outline, slot, holes normal to the disk) extruded once,
then every slanted eyelet, rim chamfer and knot pocket removed in a single cut."""
from __future__ import annotations

import math

import cadquery as cq
import numpy as np

from ..model.specs import DiskSpec, Hole
from . import DISK_ROTATION, Part, disk_placement

COLOR = (0.93, 0.86, 0.62, 1.0)     # resin yellow
NORMAL_AXIS_TOL = 1e-9              # an eyelet this close to the disk normal is drilled in the 2D face
TOOL_OVERRUN = 1.0                  # tools run this far past the faces, mm


def _to_file(x: float, z: float) -> tuple[float, float]:
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


def _eyelet_tool(h: Hole, thickness: float, edge: float, base_side: bool, tip_side: bool,
                 with_bore: bool) -> cq.Solid | None:
    """The solid removed for one eyelet: its bore (if slanted) and chamfer cones at the rims.

    Built along the hole axis from the mid-plane crossing; the cones start where the
    rim on the steep side of a slanted hole meets the face, so the chamfer is never
    smaller than ``edge`` and never reaches the mid-plane.
    """
    ax = np.array([h.axis[0], -h.axis[2], h.axis[1]])   # robot disk axes -> file axes
    cos_t = abs(ax[2])
    r = h.diameter / 2
    tan_t = math.sqrt(max(0.0, 1 - cos_t**2)) / cos_t
    u_face = thickness / 2 / cos_t                     # axial distance mid-plane -> face
    u_cone = u_face - edge - r * tan_t                  # where the chamfer cone starts
    u_end = u_face + r * tan_t + TOOL_OVERRUN
    r_end = r + edge + (u_end - u_face) + r * tan_t     # 45° cone
    prof_top = [(r, u_cone), (r_end, u_end)] if (tip_side and edge > 0) else [(r, u_end)]
    prof_bot = [(r_end, -u_end), (r, -u_cone)] if (base_side and edge > 0) else [(r, -u_end)]
    x, y = _to_file(h.x, h.z)
    origin = (x, y, thickness / 2)
    if with_bore:
        profile = [(0, -u_end)] + prof_bot + prof_top + [(0, u_end)]
        return _revolved(profile, origin, ax)
    cones = []
    if edge > 0 and base_side:
        cones.append(_revolved([(0, -u_end), (r_end, -u_end), (r, -u_cone), (0, -u_cone)], origin, ax))
    if edge > 0 and tip_side:
        cones.append(_revolved([(0, u_cone), (r, u_cone), (r_end, u_end), (0, u_end)], origin, ax))
    return cones


def blank_and_tools(spec: DiskSpec) -> tuple[cq.Solid, list[cq.Solid]]:
    """The extruded face (outline, slot, normal holes, bolt holes) and every solid still to cut."""
    T = spec.thickness
    sk = cq.Sketch().circle(spec.outer_diameter / 2)
    sk = sk.push([(0, 0)]).rect(spec.slot_width, spec.slot_height, mode="s")
    normal = [h for h in spec.holes if abs(abs(h.axis[1]) - 1) < NORMAL_AXIS_TOL]
    slanted = [h for h in spec.holes if h not in normal]
    for h in normal:
        sk = sk.push([_to_file(h.x, h.z)]).circle(h.diameter / 2, mode="s")
    for x, z, dia in spec.mount_holes:
        sk = sk.push([_to_file(x, z)]).circle(dia / 2, mode="s")
    blank = cq.Workplane("XY").placeSketch(sk.reset().clean()).extrude(T).val()

    # The base disk's outer face (file Z = 0) carries knot pockets instead of chamfers.
    base_side = spec.role != "base"
    tools: list[cq.Solid] = []
    for h in slanted:
        tools.append(_eyelet_tool(h, T, spec.edge_size, base_side, True, with_bore=True))
    for h in normal:
        tools.extend(_eyelet_tool(h, T, spec.edge_size, base_side, True, with_bore=False))
    for x, z, dia, depth in spec.knot_pockets:
        fx, fy = _to_file(x, z)
        tools.append(cq.Solid.makeCylinder(dia / 2, depth + TOOL_OVERRUN, cq.Vector(fx, fy, -TOOL_OVERRUN)))
    return blank, tools


def build_disk(spec: DiskSpec) -> Part:
    T = spec.thickness
    body, tools = blank_and_tools(spec)
    if tools:
        body = body.cut(*tools)  # one boolean with every tool
    solid = body if isinstance(body, cq.Solid) else body.Solids()[0]
    place = disk_placement(spec.y, T)
    if spec.knot_pockets:
        # print with the pocketed face up, so the largest flat face rests on the plate
        solid = solid.rotate(cq.Vector(0, 0, 0), cq.Vector(1, 0, 0), 180).translate(cq.Vector(0, 0, T))
        place = place @ flip_about_x(T)
    return Part(spec.name, "disk", solid, place, COLOR, station=spec.index,
                meta={"disk_role": spec.role, "thickness_mm": T})


def flip_about_x(thickness: float) -> np.ndarray:
    """Inverse of the print flip (half turn about X, lifted by the thickness); it is its own inverse."""
    m = np.diag([1.0, -1.0, -1.0, 1.0])
    m[2, 3] = thickness
    return m


__all__ = ["build_disk", "DISK_ROTATION"]
