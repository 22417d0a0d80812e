"""The stiffness rig of Sect. IV-C laid out as plain numbers (numpy only): a beam load cell on a
bracket that bolts to the arm's ISO 9409-1-50-4-M6 flange (the UR5e's) or to a linear stage's
carriage, a push block on the cell's free end that meets the top of a disk's rim (the push goes
down, along the strip's flexible direction), and a support that raises the base frame on the arm's
table. Robot coordinates at roll angle 0, placed before the push: the block ``push_gap_mm`` above
the first pushed disk (experiment.first_disk).

The cell is a bar along x: its free end over the disk's top (x = 0), its fixed end toward -x,
screwed under the bracket's arm; the push block is screwed under the free end. Its default
dimensions are of an LSP-class beam (rig.load_cell, with the reason beside each in the YAML).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..params import Design
from . import bench_parts as bp
from .fixtures import BOLT_PATTERNS

PAD = (10.0, 12.0)          # the push block's contact pad: along y, across x, mm
ARM = 8.0                   # the bracket's arm over the cell's fixed end, mm
COLUMN = 14.0               # the bracket's column, along x, mm
DISC = 8.0                  # the flange disc's thickness, mm
SPIGOT = 3.0                # the spigot into the flange's Ø31.5 H7 recess, mm high
SPIGOT_PLAY = 0.1           # under the recess's diameter, mm
WALL = 6.0                  # the support's walls, mm
LEDGE = 8.0                 # the support's ledges, mm
LEDGE_Y = 20.0              # their length along y: an M6 head and washer with room for the key, mm
BLOCK_END = 2.0             # the push block reaches this far past the free end's holes, mm


@dataclass(frozen=True, kw_only=True)
class RigLayout:
    cell_name: str
    cell: tuple[float, float, float]              # length (x), width (y), height (z)
    cell_x: tuple[float, float]                   # the bar's x range
    cell_z: float                                 # its underside
    screw: str
    screw_hole: float
    free_holes: tuple[float, float]               # x of the free end's holes
    fixed_holes: tuple[float, float]
    y_disk: float                                 # the pushed disk's mid-plane
    disk_thickness: float
    disk_radius: float
    station: int                                  # index of the pushed disk
    z_pad: float                                  # the pad's underside: the rim + the gap
    flange: str
    flange_centre: tuple[float, float]            # x, y
    z_flange: float                               # the flange face (the bracket's top)
    flange_holes: tuple[tuple[float, float], ...]
    flange_hole: float
    flange_diameter: float
    spigot: float                                 # its diameter (0: none)
    pin: tuple[float, float] | None               # the locating pin's hole (x, y)
    pin_diameter: float
    range_n: float
    support: tuple[float, float, float, float, float, float]   # x0, x1, y0, y1, z0 (table), z1
    support_holes: tuple[tuple[float, float], ...]             # through its top: the frame's plate holes
    support_feet: tuple[tuple[float, float], ...]              # through its ledges, to the table
    bolt_hole: float


def rig_layout(d: Design, stations, disk_thickness: float, frame) -> RigLayout:
    """The rig for design ``d``: ``stations`` (mm), the pushed disk's thickness, and the base frame's
    layout (:class:`hwgen.model.bench_frame.FrameLayout`) its support goes under (None: under
    where the base mount's table is)."""
    r = d.rig
    lc = r.load_cell
    k = min(d.experiment.first_disk, len(stations)) - 1
    radius = d.disks.outer_diameter / 2
    z_pad = radius + r.push_gap_mm
    block_h = max(12.0, 2 * bp_screw_head(lc.screw))
    cell_z = z_pad + block_h
    x1 = lc.end_hole_inset + lc.screw_spacing / 2     # the free end's holes either side of x = 0
    x0 = x1 - lc.length
    free = (x1 - lc.end_hole_inset, x1 - lc.end_hole_inset - lc.screw_spacing)
    fixed = (x0 + lc.end_hole_inset, x0 + lc.end_hole_inset + lc.screw_spacing)
    z_face = cell_z + lc.height / 2 + r.reach_mm
    y = float(stations[k])
    if r.flange.startswith("ISO"):
        pcd = bp.size("ISO 9409-1-50-4-M6", "any", "pitch_circle")
        fd = bp.size("ISO 9409-1-50-4-M6", "any", "flange_diameter")
        cx = x0 - COLUMN + fd / 2
        holes = tuple((cx + pcd / 2 * math.cos(math.radians(45 + 90 * i)),
                       y + pcd / 2 * math.sin(math.radians(45 + 90 * i))) for i in range(4))
        spigot = bp.size("ISO 9409-1-50-4-M6", "any", "centring_diameter") - SPIGOT_PLAY
        pin = (cx + pcd / 2, y)
        pin_d = bp.size("ISO 9409-1-50-4-M6", "any", "pin_diameter")
    else:
        pitch = BOLT_PATTERNS["M6_25mm"][0]
        fd = 2 * pitch + 2 * 10.0
        cx = x0 - COLUMN + fd / 2
        holes = tuple((cx + sx * pitch, y + sy * pitch) for sx in (-1, 1) for sy in (-1, 1))
        spigot, pin, pin_d = 0.0, None, 0.0
    return RigLayout(
        cell_name=lc.name, cell=(lc.length, lc.width, lc.height), cell_x=(x0, x1), cell_z=cell_z, screw=lc.screw,
        screw_hole=_clearance(lc.screw), free_holes=free, fixed_holes=fixed, y_disk=y, disk_thickness=disk_thickness,
        disk_radius=radius, station=k, z_pad=z_pad, flange=r.flange, flange_centre=(cx, y), z_flange=z_face,
        flange_holes=holes, flange_hole=_clearance("M6"), flange_diameter=fd, spigot=spigot, pin=pin,
        pin_diameter=pin_d, range_n=lc.range_n or d.experiment.load_cell_range_n,
        support=_support(frame, r.support_height_mm), support_holes=tuple(frame.plate_holes) if frame else (),
        support_feet=_feet(frame), bolt_hole=_clearance("M6"))


def _clearance(thread: str) -> float:
    from .hardware import clearance_hole
    return clearance_hole(thread)


def bp_screw_head(thread: str) -> float:
    """Head diameter of an ISO 4762 screw of ``thread`` (1.5 × the thread, the standard's
    proportion where the fastener table has no row), mm."""
    from .hardware import table
    row = table().get(("socket head cap screw", thread, "head_diameter"))
    return row.value if row else 1.5 * float(thread[1:]) + 1.0


def _support(frame, height: float) -> tuple[float, float, float, float, float, float]:
    if frame is None:
        return (-50.0, 50.0, -120.0, -20.0, -height - 60.0, -60.0)
    x0, x1, y0, y1 = frame.plate
    return (x0, x1, y0 - LEDGE_Y, y1 + LEDGE_Y, frame.z_table - height, frame.z_table)


def _feet(frame) -> tuple[tuple[float, float], ...]:
    if frame is None:
        return ()
    x0, x1, y0, y1 = frame.plate
    hx = max(x for x, _ in frame.plate_holes)
    return tuple((sx * hx, y) for y in (y0 - LEDGE_Y / 2, y1 + LEDGE_Y / 2) for sx in (-1, 1))
