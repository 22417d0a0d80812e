"""The base mount and the assembly jig, laid out as plain numbers (numpy only).

Robot coordinates throughout (mm): y along the backbone from the base disk's mid-plane, x across
the strip, z through it. For the own-weight test of Sect. III-B the robot lies horizontal with its
flexible direction (z) along gravity, so the mount stands on a table with z up.

Base mount. Two printed jaws clamp the strip's base length (``backbone.extra_base`` less half the
base disk) between them; the lower jaw stands on a column and a foot that bolts to the table, the
upper jaw is screwed down onto the strip, and the base disk bolts to the front of both jaws. The
column stands back from the base disk (ACCESS_MM) so the seats on its outer face stay within reach;
the foot's holes are on the table's grid. The jaws are never shorter than their two rows of screws
need (JAW_LEAST): a shorter ``extra_base`` is honoured, the strip ends inside them, and the check
``mount.clamp`` fails naming the least that clamps. Under a small disk (the table close to the
strip) the column shrinks to nothing and the lower jaw sits on the foot; where even that leaves
the jaw too thin for its nut traps, ``mount.foot`` fails naming the table clearance that works.

Jig. A floor with two comb walls, one each side of the disks: each disk drops into a slot in both
walls, the floor under its rim, so it stands square at its station while the adhesive cures. The
jig is split between two disks into pieces that fit the printer, joined by dovetails in the floor.
The walls take JIG_ENGAGE of each disk's rim beside the strip; where the strip or the hubs reach
that far out (a disk barely wider than its strip), the walls stop under them instead, and hold the
disk's lower rim (``jig.hold`` measures how much of each disk's face the walls cover).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..params import Design
from . import hardware
from .fixing import disk_thicknesses

# Bolt patterns of the tables the mount stands on: pitch, clearance hole, screw.
#   M6 on 25 mm: metric optical breadboards; ISO 273 normal clearance for M6 is 6.6 mm.
#   1/4-20 on 1 in: imperial breadboards; ASME B18.2.8 normal clearance for 1/4 in is 0.281 in (7.1 mm).
BOLT_PATTERNS = {
    "M6_25mm": (25.0, 6.6, "M6"),
    "quarter20_1in": (25.4, 7.1, "1/4-20 UNC"),
}
FOOT_PITCHES_X = 4          # foot holes this many pitches apart across the robot (clear of the jaws)
FOOT_PITCHES_Y = 1          # and this many along it: two rows
FOOT_THICKNESS = 10.0       # mm: under an M6 washer a 10 mm resin plate does not dish
FOOT_EDGE = 8.0             # mm from a foot hole's centre to the foot's edge
ACCESS_MM = 10.0            # the column and foot stand this far back from the base disk: room to reach its seats
JAW_MARGIN = 4.0            # jaw screws this far outside the strip's edges (centre), mm
JAW_EDGE = 3.0              # jaw edge beyond a jaw screw hole, mm
JAW_BOTTOM = -18.0          # the lower jaw reaches down to this z; below it, only the column (set back)
UPPER_JAW = 12.0            # height of the upper jaw above the strip, mm
JAW_BEYOND_STRIP = 2.0      # the jaws run this far past the strip's base end, mm
STRIP_RECESS_FRACTION = 0.5  # the strip lies in a recess this share of its thickness deep in the lower jaw
STRIP_RECESS_CLEARANCE = 0.1  # per side, strip to recess, mm
JAW_STANDOFF = 0.01         # each jaw stands this far off the strip until the jaw screws close them on it, mm
JAW_SCREW_FROM_END = 7.0    # jaw screws this far from the jaws' front and back faces, mm
NUT_AF, NUT_THICK = hardware.nut("M3")                       # ISO 4032 M3 nut (data/fasteners.csv)
NUT_PLAY = hardware.NUT_PLAY                                 # the room it slides in with
JAW_NUT_WALL = 1.0          # resin between the two rows of jaw screws' nut traps, mm
# the least strip the jaws clamp beyond the base disk: two rows of screws whose nut traps keep a wall between them, mm
JAW_LEAST = math.ceil(2 * JAW_SCREW_FROM_END + NUT_AF + NUT_PLAY + JAW_NUT_WALL - JAW_BEYOND_STRIP)
NUT_DEPTH = 3.5             # nut traps this far below the lower jaw's top face, mm
# the lower jaw's least depth under its top face: the nut traps (with their play) and a wall under them, mm
LOWER_JAW_LEAST = NUT_DEPTH + NUT_THICK + NUT_PLAY + JAW_NUT_WALL
MOUNT_SLIVER = 0.5          # where the table leaves no room at all, foot and jaw keep this much each (mount.foot fails), mm
M3_HEAD = hardware.size("socket head cap screw", "M3", "head_diameter")   # for access around the disk screws

JIG_ENGAGE = 3.0            # a disk's rim enters each comb wall this deep (x), mm
JIG_CLEAR = 1.0             # the comb walls stand this far clear of the strip's edges and the hubs' sides, mm
JIG_CUT_CLEAR = 8.0           # a cut between jig pieces stays this far from a disk's slot (a dovetail and a wall), mm
JIG_WALL_ABOVE = 2.0        # walls rise this far above where the disk's rim leaves them, mm
JIG_END_TOOTH = 6.0         # comb tooth beyond each end disk, mm
DOVETAIL = (8.0, 12.0, 6.0)  # neck width, end width, depth of each dovetail key, mm
DOVETAIL_X = 20.0           # two keys at x = ±this, mm
DOVETAIL_PLAY = 0.1         # per side, key in its socket, mm
PRINT_MARGIN = 2.0          # a jig piece stays this far inside the printer's longest axis, mm
JIG_PIECES_MAX = 40         # the jig is cut into at most this many pieces


@dataclass(frozen=True, kw_only=True)
class MountRules:
    """What the checks of the base mount judge it by and name in their fixes (none of it is geometry)."""

    max_tip_share: float        # base_mount.max_tip_share: the share of the tip's sag the mount's give may add
    least_clamp: float          # the least strip the jaws clamp beyond the base disk (JAW_LEAST)
    extra_base: float | None    # backbone.extra_base as the YAML gives it (None: derived; the checks name it)
    table_clearance: float      # base_mount.table_clearance (the checks name it)
    least_below_strip: float    # table to the strip's underside that a full foot under a lower jaw deep
    #                             enough for its nut traps needs


@dataclass(frozen=True, kw_only=True)
class MountLayout:
    """Where the base mount's jaws, column and foot go (what the CAD builds), and ``rules``: what its
    checks judge it by."""

    y_face: float               # base disk's outer face: the jaws' front
    y_back: float               # the jaws' back face
    y_column_front: float       # the column and foot stand behind this
    y_foot_back: float
    jaw_half_x: float
    z_table: float              # the foot's underside
    z_foot_top: float
    z_jaw_bottom: float
    z_lower_top: float          # the lower jaw's top face (beside the strip's recess)
    z_recess: float             # floor of the strip's recess: the strip's underside
    z_upper_bottom: float       # the upper jaw's underside: the strip's top
    z_upper_top: float
    recess_half_x: float
    jaw_screws: tuple[tuple[float, float], ...]      # (x, y), vertical M3 through both jaws
    disk_screws: tuple[tuple[float, float], ...]     # (x, z), along y through the jaws
    screw_hole: float
    foot_holes: tuple[tuple[float, float], ...]      # (x, y), vertical
    foot_hole: float
    bolt: str                   # what goes in the foot holes
    pitch: float
    foot_half_x: float
    bolt_pattern: str           # the table's grid, as the YAML names it (base_mount.bolt_pattern)
    disk_thickness: float       # the base disk's thickness: the disk screws' grip with the jaws
    rules: MountRules


def base_length(d: Design) -> float:
    """The strip's length below the base disk's mid-plane: ``backbone.extra_base``, else half the base
    disk and the least the jaws clamp (JAW_LEAST), to the next whole mm."""
    if d.backbone.extra_base is not None:
        return d.backbone.extra_base
    return float(math.ceil(disk_thicknesses(d)[0] / 2 + JAW_LEAST))


def mount_layout(d: Design, disk_screws=()) -> MountLayout:
    """The mount for design ``d``, with the base disk's screws at ``disk_screws`` ((x, z) each: the
    base disk's mount holes as the plan placed them)."""
    bm, bb = d.base_mount, d.backbone
    pitch, hole, bolt = BOLT_PATTERNS[bm.bolt_pattern]
    base_t = disk_thicknesses(d)[0]
    y_face = -base_t / 2
    # the jaws run past the strip's end, and are never shorter than their two rows of screws need
    y_back = min(-base_length(d), y_face - JAW_LEAST) - JAW_BEYOND_STRIP
    y_col = y_face - ACCESS_MM
    t = bb.thickness
    jaw_x = bb.height / 2 + JAW_MARGIN
    half_x = jaw_x + bm.screw_hole / 2 + JAW_EDGE
    z_table = -(d.disks.outer_diameter / 2 + bm.table_clearance)
    z_lower_top = -t / 2 + STRIP_RECESS_FRACTION * t
    z_recess = -t / 2 - JAW_STANDOFF
    z_foot_top, z_jaw_bottom = _foot_and_jaw(z_table, z_lower_top, z_recess)
    fx = FOOT_PITCHES_X * pitch / 2
    rows = (y_col - FOOT_EDGE, y_col - FOOT_EDGE - FOOT_PITCHES_Y * pitch)
    feet = tuple((sx * fx, y) for y in rows for sx in (-1, 1))
    screws = tuple((sx * jaw_x, y) for y in (y_back + JAW_SCREW_FROM_END, y_face - JAW_SCREW_FROM_END)
                   for sx in (-1, 1))
    return MountLayout(
        y_face=y_face, y_back=y_back, y_column_front=y_col, y_foot_back=min(rows) - FOOT_EDGE,
        jaw_half_x=half_x, z_table=z_table, z_foot_top=z_foot_top, z_jaw_bottom=z_jaw_bottom,
        z_lower_top=z_lower_top, z_recess=z_recess, z_upper_bottom=t / 2 + JAW_STANDOFF,
        z_upper_top=t / 2 + JAW_STANDOFF + UPPER_JAW, recess_half_x=bb.height / 2 + STRIP_RECESS_CLEARANCE,
        jaw_screws=screws, disk_screws=tuple((float(x), float(z)) for x, z in disk_screws),
        screw_hole=bm.screw_hole, foot_holes=feet, foot_hole=hole, bolt=bolt, pitch=pitch,
        foot_half_x=fx + FOOT_EDGE, bolt_pattern=bm.bolt_pattern, disk_thickness=base_t,
        rules=MountRules(max_tip_share=bm.max_tip_share, least_clamp=float(JAW_LEAST), extra_base=bb.extra_base,
                         table_clearance=bm.table_clearance,
                         least_below_strip=(-t / 2 - z_lower_top) + LOWER_JAW_LEAST + FOOT_THICKNESS))


def _foot_and_jaw(z_table: float, z_lower_top: float, z_recess: float) -> tuple[float, float]:
    """(the foot's top, the lower jaw's bottom): the foot FOOT_THICKNESS thick on the table, the jaw
    down to JAW_BOTTOM, the column between them. Where the table is nearer the strip, the column
    goes and the jaw sits on the foot; nearer still, the jaw keeps the depth its nut traps need
    (LOWER_JAW_LEAST) and the foot thins, and with no room for either each keeps MOUNT_SLIVER:
    always table < foot top <= jaw bottom < the strip's recess."""
    foot_top = z_table + FOOT_THICKNESS
    jaw_bottom = max(JAW_BOTTOM, foot_top)
    if jaw_bottom > z_lower_top - LOWER_JAW_LEAST:
        jaw_bottom = z_lower_top - LOWER_JAW_LEAST
        foot_top = min(foot_top, jaw_bottom)
    room = z_recess - z_table
    if foot_top - z_table < MOUNT_SLIVER or z_recess - jaw_bottom < MOUNT_SLIVER:
        foot_top = jaw_bottom = z_table + min(MOUNT_SLIVER, room / 2)
    return foot_top, jaw_bottom


def disk_screw_region(d: Design) -> tuple[tuple[tuple[float, float], tuple[float, float]], float]:
    """Where a base-disk screw may go in the jaws: its z band in the upper jaw and in the lower one
    (a wall around its hole inside the jaw, clear of the strip), and the largest |x| (a wall inside
    the jaw's side, clear of the jaw screws and their nut traps)."""
    lay = mount_layout(d)
    h = lay.screw_hole / 2 + d.process.min_wall
    bands = ((lay.z_upper_bottom + h, lay.z_upper_top - h), (lay.z_jaw_bottom + h, lay.z_recess - h))
    jaw_x = abs(lay.jaw_screws[0][0])
    nut = (NUT_AF + NUT_PLAY) / math.sqrt(3)           # the nut trap's half width across corners
    x_max = min(lay.jaw_half_x - h, jaw_x - max(lay.screw_hole / 2, nut) - h)
    return bands, x_max


def mount_problems(d: Design) -> list[tuple[str, str]]:
    """Why the base disk's screws the YAML gives (``base_mount.disk_screws``) cannot be used:
    (field path, message). What the mount derives never refuses: a short ``backbone.extra_base``
    or a table close to the strip is built and fails its check (``mount.clamp``, ``mount.foot``)."""
    out = []
    lay = mount_layout(d, d.base_mount.disk_screws or ())
    r = d.disks.outer_diameter / 2
    for k, (x, z) in enumerate(lay.disk_screws):
        h = lay.screw_hole / 2
        if not (lay.z_upper_bottom + h + d.process.min_wall <= z <= lay.z_upper_top - h - d.process.min_wall
                or lay.z_jaw_bottom + h + d.process.min_wall <= z <= lay.z_recess - h - d.process.min_wall):
            out.append((f"base_mount.disk_screws[{k}]", f"z = {z:g} mm is not inside a jaw with a wall around "
                                                        f"the screw (upper jaw {lay.z_upper_bottom:.2f} to "
                                                        f"{lay.z_upper_top:.2f}, lower {lay.z_jaw_bottom:g} to "
                                                        f"{lay.z_recess:.2f} mm)"))
        elif math.hypot(x, z) + M3_HEAD / 2 > r or abs(x) + h + d.process.min_wall > lay.jaw_half_x:
            out.append((f"base_mount.disk_screws[{k}]", f"({x:g}, {z:g}) is not inside the base disk and the jaws"))
    return out


@dataclass(frozen=True)
class JigPiece:
    index: int
    y0: float                   # the piece's ends along the backbone (its floor and walls)
    y1: float
    key_out: bool               # dovetails stand out of its +y end (into the next piece)
    key_in: bool                # sockets for the previous piece's dovetails at its -y end


@dataclass(frozen=True, kw_only=True)
class JigLayout:
    pieces: tuple[JigPiece, ...]
    slots: tuple[tuple[float, float], ...]    # y ranges of the comb slots (one per disk)
    x_inner: float              # comb walls from |x| = x_inner ...
    x_outer: float              # ... to x_outer
    x_slot: float               # slot bottoms at |x| = x_slot
    z_floor_bottom: float
    z_floor_top: float
    z_top: float
    dovetail: tuple[float, float, float]
    dovetail_x: tuple[float, ...]
    play: float
    station_tolerance_mm: float  # how far the jig may set a disk off its station (design data for the checks)
    low: bool = False           # the walls stop under the strip and the hubs (z_top below them)


def jig_inner_floor(d: Design) -> float:
    """The least |x| the comb walls may start at: clear of the strip's edges and the hubs' sides
    (both run through the walls' length between the disks) by JIG_CLEAR."""
    hub = d.backbone.height / 2 + d.disks.slot_clearance + d.disks.hub.wall
    return max(d.backbone.height / 2, hub) + JIG_CLEAR


def jig_low_top(d: Design) -> float:
    """The highest z low walls may rise to: JIG_CLEAR under the strip and the hubs."""
    hub = d.backbone.thickness / 2 + d.disks.slot_clearance + d.disks.hub.wall
    return -(max(d.backbone.thickness / 2, hub) + JIG_CLEAR)


def _free_cuts(y0: float, y1: float, longest: float, slots, gaps: list[float]) -> list[float]:
    """Piece ends from y0 to y1, none longer than ``longest``, each cut JIG_CUT_CLEAR clear of every
    slot: the remaining length shared equally among the pieces it needs, each cut moved back
    toward the base out of any slot's reach."""
    ends = [y0]
    while y1 - ends[-1] > longest:
        start = ends[-1]
        cut = start + (y1 - start) / math.ceil((y1 - start) / longest)
        for a, b in sorted(slots, reverse=True):
            if a - JIG_CUT_CLEAR < cut < b + JIG_CUT_CLEAR:
                cut = a - JIG_CUT_CLEAR
        if cut <= start:            # slots too close to cut clear of them: the furthest gap middle that fits
            mids = [g for g in gaps if g > start + 1e-9]
            fits = [g for g in mids if g <= start + longest]
            cut = max(fits) if fits else min(mids, default=y1)
        ends.append(cut)
    return ends + [y1] if ends[-1] < y1 else ends


def jig_layout(d: Design) -> JigLayout:
    jg = d.jig
    st = d.stations
    r = d.disks.outer_diameter / 2
    thick = disk_thicknesses(d)
    slots = tuple((y - t / 2 - jg.clearance, y + t / 2 + jg.clearance) for y, t in zip(st, thick))
    y0 = slots[0][0] - JIG_END_TOOTH
    y1 = slots[-1][1] + JIG_END_TOOTH
    # pieces the printer takes; never more than JIG_PIECES_MAX (a printer too small for them: part.build_volume)
    longest = max(max(d.process.build_volume[:2]) - PRINT_MARGIN - DOVETAIL[2], (y1 - y0) / JIG_PIECES_MAX)
    n = max(1, math.ceil((y1 - y0) / longest))
    # cut in the middle of the gap between two disks nearest each equal division; where that makes
    # a piece too long for the printer (disks far apart), as near each division as the slots allow
    gaps = [(slots[i][1] + slots[i + 1][0]) / 2 for i in range(len(st) - 1)]
    targets = [y0 + k * (y1 - y0) / n for k in range(1, n)]
    ends = [y0, *sorted({min(gaps, key=lambda g: abs(g - t)) for t in targets}), y1]
    if max(b - a for a, b in zip(ends, ends[1:])) > longest:
        ends = _free_cuts(y0, y1, longest, slots, gaps)
    pieces = tuple(JigPiece(k, a, b, k < len(ends) - 2, k > 0) for k, (a, b) in enumerate(zip(ends, ends[1:])))
    x_in = max(r - JIG_ENGAGE, 0.0)
    z_floor_top = -r - jg.clearance
    # walls beside the disks while the strip and hubs leave them their JIG_ENGAGE, else under them
    low = jig_inner_floor(d) > x_in
    z_top = jig_low_top(d) if low else math.sqrt(max(r**2 - x_in**2, 0.0)) + JIG_WALL_ABOVE
    z_top = max(z_top, z_floor_top + JIG_WALL_ABOVE)          # a wall however small the disk
    return JigLayout(pieces=pieces, slots=slots, x_inner=x_in, x_outer=x_in + jg.wall, x_slot=r + jg.clearance,
                     z_floor_bottom=z_floor_top - jg.floor, z_floor_top=z_floor_top,
                     z_top=z_top, dovetail=DOVETAIL, dovetail_x=(-DOVETAIL_X, DOVETAIL_X), play=DOVETAIL_PLAY,
                     station_tolerance_mm=jg.station_tolerance_mm, low=low)
