"""How each disk is held on the strip, and how each tendon ends at the base disk (numpy only).

Hub. A disk on the strip can tilt about x (pitch along the backbone) until the strip touches
the slot's top and bottom: with g the slot's height over the strip's thickness and ℓ the length
along the backbone over which the slot holds the strip, the tilt is atan(g / ℓ). A 3 mm disk
alone lets the strip rock; a hub (a sleeve around the slot on one face of the disk) makes ℓ as
long as the chosen tilt needs. It sits on the disk's tip-side face, except on the tip disk,
whose tip-side face carries the tensioner, so that each disk prints on its flat face.

Each hub is sized to the gap it stands in (:func:`hub_lengths`): as long as the tilt allowance
asks, or, where the next disk is closer than that, the longest that leaves HUB_GAP_MM before it
(the last gap holds two hubs, the tip disk's and its neighbour's, and they share it so that both
disks are held over the same length). A hub cut short is not a refusal: the disk is built with it, and
``hwgen check`` measures the tilt its slot then allows and fails ``disk.tilt`` naming what to
change. One-sided hubs were kept rather than splitting each hub over both faces: a split hub
holds the same length in the same gaps (every gap still holds one hub's worth), but the disk
would no longer print flat on one face. A hub shorter than its glue port with a wall either side
has no port (the adhesive wicks in from the slot's open ends); one shorter than a wall is left off.

Wherever a tendon passes through the hub's envelope (the strip crossings in the slot, and any
tendon close to it over the bending sweep) the hub is cut away over the x range the tendon
occupies: bending is about x, so a tendon's x at a given distance from the disk does not depend
on the bend.

Seats. Each tendon ends on its own seat: a hole through a plate on the base disk's outer face,
smaller than its knot or crimp sleeve. The eyelet bore stops at the plate, so the routing point
(the eyelet's centre at the disk's mid-plane) stays where the design puts it; tendons that share
an eyelet get seats spaced around the bore's exit, at least a wall and at least a termination
apart, in the angular order in which the tendons would leave the eyelet backwards, joined to the
bore by a chamber over the plate. The plate is as thick as the YAML says (less than half the disk);
the chamber is lower on a thin base disk (:func:`chamber_height`), so plate and chamber always end
short of the mid-plane and the eyelet is a bore there, whatever the disk's thickness.
"""
from __future__ import annotations

import math

import numpy as np

from ..params import MAX_MM, Design, Termination
from .holes import straight_hole
from .intervals import interval_difference
from .specs import Hole, HubSpec, Seat

LENGTH_STEP_MM = 0.1        # hub engagement lengths are rounded up to this
HUB_GAP_MM = 1.0            # the least gap a derived hub leaves before the next disk (or that disk's hub)
HUB_SAMPLES = 9             # planes across the hub at which each tendon's path is tested
SEAT_MARGIN_MM = 0.2        # a chamber over the plate reaches this far beyond the outermost seat
CHAMBER_HEIGHT_MM = 0.6     # height of that chamber above the plate ...
SEAT_OVERLAP_MM = 0.3       # a seat hole runs this far past the plate into the bore or chamber above it
CHAMBER_ROOM_SHARE = 0.5    # ... or this share of what the plate leaves below the mid-plane, if less: the bore
#                             stays open at the mid-plane, where the routing puts the eyelet and the checks cut it
SEAT_STEP_MM = 0.1          # a single seat differs from a slanted bore it continues by at least this (diameter)
SLANT_TOL = 1e-9            # a bore whose axis is this close to the disk's normal is not slanted
AXIS_FLOOR = 1e-9           # the least axial share of a bore's axis the seat's geometry divides by
SEAT_WALL_MARGIN = 0.1      # over the minimum wall between two seats: the STL's chords and the printer's ±0.05 mm


def engagement_length(design: Design) -> float:
    """ℓ: the length along the backbone over which the slot holds the strip, disk included, mm.

    ``disks.hub.length`` when given; otherwise the shortest (to LENGTH_STEP_MM) over which the
    slot's clearance allows no more than ``disks.hub.max_tilt_deg``: ℓ = g / tan θ.
    """
    hub = design.disks.hub
    if hub.length is not None:
        return float(hub.length)
    g = 2 * design.disks.slot_clearance
    tan = math.tan(math.radians(hub.max_tilt_deg))
    # no play holds at any length; a tilt so small its tangent is 0 asks for more than any robot is long
    ell = 0.0 if g <= 0 else MAX_MM if tan <= g / MAX_MM else g / tan
    return math.ceil(ell / LENGTH_STEP_MM - 1e-9) * LENGTH_STEP_MM


def hub_side(role: str) -> int:
    """+1: the hub runs from the disk's tip-side face toward the tip; -1 (the tip disk) toward the base."""
    return -1 if role == "tip" else 1


def hub_extension(design: Design, thickness: float) -> float:
    """How far the hub would stand off the disk's face with room to spare: the engagement beyond
    the disk, and never less than its glue port with a wall either side."""
    return max(engagement_length(design) - thickness, least_hub(design))


def least_hub(design: Design) -> float:
    """The shortest hub that holds its glue port with a wall either side, mm."""
    return design.disks.hub.glue_port_diameter + 2 * design.process.min_wall


def disk_role(i: int, n: int) -> str:
    """"base" (i = 0), "tip" (i = n - 1) or "inner"."""
    return "base" if i == 0 else "tip" if i == n - 1 else "inner"


def disk_thicknesses(design: Design) -> tuple[float, ...]:
    """Each disk's thickness along y: the end disks ``end_thickness``, the rest ``thickness``."""
    n = len(design.stations)
    return tuple(design.disks.thickness if disk_role(i, n) == "inner" else design.disks.end_thickness
                 for i in range(n))


def disk_gaps(design: Design) -> tuple[float, ...]:
    """The clear length between each disk and the next (face to face), mm; negative where they overlap."""
    st, th = design.stations, disk_thicknesses(design)
    return tuple((st[i + 1] - th[i + 1] / 2) - (st[i] + th[i] / 2) for i in range(len(st) - 1))


def hub_lengths(design: Design) -> tuple[float, ...]:
    """Each disk's hub length beyond its face, mm (0: no hub).

    ``disks.hub.length`` given: honoured on every disk as given (the checks measure what it does).
    Otherwise each hub is :func:`hub_extension` long, cut to the gap it stands in less HUB_GAP_MM;
    two hubs in one gap (the tip disk's, facing the base, and its neighbour's) share it so that
    both disks are held over the same length. A hub thinner than a wall is left off.
    """
    th = disk_thicknesses(design)
    n = len(th)
    want = [hub_extension(design, t) for t in th]
    if design.disks.hub.length is not None:
        return tuple(want)
    out = list(want)
    for g, gap in enumerate(disk_gaps(design)):
        room = max(gap - HUB_GAP_MM, 0.0)
        here = [i for i in (g, g + 1) if (i == g) == (hub_side(disk_role(i, n)) > 0)]
        if sum(want[i] for i in here) <= room:
            continue
        if len(here) == 1:
            out[g] = min(out[g], room)
            continue
        # two hubs share the gap: split it so both disks are held over the same length (the worse
        # tilt of the two is then as small as the gap allows), neither beyond what it asks
        a, b = here
        share = min(max((room + th[b] - th[a]) / 2, room - want[b], 0.0), want[a], room)
        wall = design.process.min_wall
        if room - share < wall:               # the other's share would be left off: this one takes the gap
            share = min(want[a], room)
        elif share < wall:
            share = 0.0
        out[a], out[b] = share, min(room - share, want[b])
    wall = design.process.min_wall
    return tuple(round(math.floor(v / LENGTH_STEP_MM + 1e-9) * LENGTH_STEP_MM, 6) if v >= wall else 0.0
                 for v in out)


def hub_spec(design: Design, role: str, ext: float, thickness: float, slot: tuple[float, float],
             holes: tuple[Hole, ...], points: dict[str, np.ndarray], sweep: dict[str, tuple]) -> HubSpec | None:
    """The hub of one disk, ``ext`` mm beyond its face (from :func:`hub_lengths`; None when 0):
    its side and length, and a window wherever a tendon passes through it. ``slot``: the disk's
    slot for the strip, width and height (:func:`hwgen.model.specs.slot_size`).

    ``points``: each tendon's (x, z) at this disk; ``sweep``: each tendon's (into, out_of)
    directions in this disk's frame over the bending sweep, (K, 3) each.
    """
    if ext <= 0:
        return None
    side = hub_side(role)
    slot_w, slot_h = slot
    wall = design.disks.hub.wall
    proc, td = design.process, design.tendon_material
    half_x, half_z = slot_w / 2 + wall, slot_h / 2 + wall
    ys = side * np.linspace(thickness / 2, thickness / 2 + ext, HUB_SAMPLES)
    own_hole = {t: h for h in holes for t in h.tendons}
    cuts = []
    for name, (into, out) in sweep.items():
        u = out if side > 0 else -into                       # along the tendon, away from the disk
        if np.isnan(u).any():
            continue
        h = own_hole.get(name)
        w = max((h.diameter / 2 + design.disks.eyelets.edge_size) if h else 0.0,
                td.diameter / 2 + proc.hole_clearance)
        x0, z0 = points[name]
        t = ys[None, :] / u[:, 1:2]                         # (K, S) distance along the line
        x = x0 + u[:, 0:1] * t
        z = z0 + u[:, 2:3] * t
        near = (np.abs(x) < half_x + w) & (np.abs(z) < half_z + w)
        if near.any():
            cuts.append((float(x[near].min() - w), float(x[near].max() + w)))
    solid = interval_difference(-half_x, half_x, cuts)
    # a sliver of hub between two windows is no wall: drop what is thinner than two walls
    solid = [(a, b) for a, b in solid if b - a >= 2 * proc.min_wall]
    windows = tuple(interval_difference(-half_x, half_x, solid))
    port = None
    d_port = design.disks.hub.glue_port_diameter
    over_slot = [(max(a, -slot_w / 2), min(b, slot_w / 2)) for a, b in solid]
    over_slot = [(a, b) for a, b in over_slot if b - a >= d_port + 2 * proc.min_wall]
    if over_slot and ext >= least_hub(design) - 1e-9:
        a, b = max(over_slot, key=lambda ab: ab[1] - ab[0])
        port = ((a + b) / 2, ext / 2, d_port)
    return HubSpec(side, ext, wall, windows, port)


def termination_of(design: Design, tendon: str) -> Termination:
    """How a tendon (or the mirror of one) ends: its own termination, else the material's."""
    for t in design.tendons:
        if tendon in t.names and t.termination is not None:
            return t.termination
    return design.tendon_material.termination


def seat_diameter(design: Design) -> float:
    """The opening of a seat: the hole the tendon passes straight (:func:`hwgen.model.holes.straight_hole`)."""
    p = design.process
    return straight_hole(design.tendon_material.diameter, p.hole_clearance, p.min_hole)


def chamber_height(design: Design, thickness: float) -> float:
    """Height of a seat chamber over the plate of a base disk ``thickness`` mm thick:
    CHAMBER_HEIGHT_MM, or CHAMBER_ROOM_SHARE of the room the plate leaves below the mid-plane."""
    room = max(thickness / 2 - design.disks.anchors.plate, 0.0)
    return min(CHAMBER_HEIGHT_MM, CHAMBER_ROOM_SHARE * room)


def seat_overlap(thickness: float, plate: float) -> float:
    """How far a seat hole runs past the plate into the chamber or bore above it, mm: SEAT_OVERLAP_MM,
    or half the least chamber (:func:`chamber_height`), if less: never up to where the checks cut
    the bore."""
    return min(SEAT_OVERLAP_MM, CHAMBER_ROOM_SHARE * max(thickness / 2 - plate, 0.0) / 2)


SEAT_TANGENT_MM = 0.01      # a seat's rim this near its bore's wall where the seat's cut ends leaves faces of no area


def seat_reach(seat, hole, thickness: float, plate: float) -> float:
    """How far a seat's cut runs above the plate into its eyelet's ``hole`` (None: no eyelet of its
    own): :func:`seat_overlap`, or less where the seat's rim would end within
    :data:`SEAT_TANGENT_MM` of the bore's wall (a slanted bore moves across the seat as it rises and
    can graze its rim there): the cut would leave a sliver face that the STL's mesher leaves open.
    The seat through the plate is the same either way. A seat as wide as a bore along the normal, on
    its axis, is one surface with it, not a graze: kept as it is."""
    overlap = seat_overlap(thickness, plate)
    if hole is None or rim_to_wall(seat, hole, thickness, plate) is None:
        return overlap
    for reach in (overlap, 0.75 * overlap, 0.5 * overlap, 0.25 * overlap):
        if rim_to_wall(seat, hole, thickness, plate + reach) >= SEAT_TANGENT_MM:
            return reach
    return overlap


def rim_to_wall(seat, hole, thickness: float, height: float) -> float | None:
    """How near the seat's rim comes to grazing its eyelet's bore at ``height`` above the base
    disk's outer face, mm (from inside or outside, where the rim lies most inside or most outside
    the bore): the bore's section there is an ellipse, r across the slant and r / |a_y| along it,
    centred where the bore's axis meets that plane. None where the rim is the wall all round."""
    ax, ay, az = hole.axis
    t = (height - thickness / 2) / ay
    centre = np.array([hole.x + t * ax, hole.z + t * az])
    r = hole.diameter / 2
    slant = np.array([ax, az])
    d = slant / np.linalg.norm(slant) if np.linalg.norm(slant) > 1e-12 else np.array([1.0, 0.0])
    a = np.linspace(0.0, 2 * np.pi, 720, endpoint=False)
    rim = np.array([seat.x, seat.z]) + seat.diameter / 2 * np.column_stack([np.cos(a), np.sin(a)]) - centre
    rho = np.hypot(rim @ d / (r / abs(ay)), rim @ np.array([-d[1], d[0]]) / r)   # 1 on the bore's wall
    if np.ptp(rho) < 1e-9 and abs(rho[0] - 1) < 1e-9:
        return None
    return float(r * min(abs(1 - rho.max()), abs(1 - rho.min())))


def seats_for(design: Design, hole: Hole, thickness: float, directions: dict[str, np.ndarray]
              ) -> tuple[list[Seat], tuple[float, float, float, float] | None]:
    """Seats for the tendons of one base-disk eyelet, and the chamber over the plate that joins
    them to the eyelet's bore when they reach beyond it (None when the bore covers them).

    ``directions``: each tendon's direction leaving the base disk in the straight robot (local
    frame, +y toward the tip); the seats follow the order in which they would leave backwards.
    """
    plate = design.disks.anchors.plate
    dia = seat_diameter(design)
    ax = np.asarray(hole.axis, dtype=float)
    depth = -thickness / 2 + plate                       # local y of the plate's top face
    ay = max(abs(float(ax[1])), AXIS_FLOOR)              # an axis in the disk's plane: no bore to speak of
    c = np.array([hole.x, hole.z]) + ax[[0, 2]] * depth / math.copysign(ay, ax[1])
    terms = {t: termination_of(design, t) for t in hole.tendons}
    n = len(hole.tendons)
    if n == 1:
        (t,) = hole.tendons
        if abs(abs(ax[1]) - 1) > SLANT_TOL and abs(hole.diameter - dia) < SEAT_STEP_MM:
            # a slanted bore the seat's own size would meet the seat's wall tangentially where it
            # enters the plate (a seam no mesher closes): the seat steps out past the bore instead,
            # past its oblique width and its drift over the seat's overlap into it
            cos = ay
            drift = 2 * seat_overlap(thickness, plate) * math.sqrt(max(1 - cos**2, 0.0)) / cos
            dia = max(hole.diameter / cos + drift, hole.diameter) + SEAT_STEP_MM
        return [Seat(t, float(c[0]), float(c[1]), dia, terms[t].diameter)], None
    s = max(dia + design.process.min_wall + SEAT_WALL_MARGIN, max(tm.diameter for tm in terms.values()))
    rho = s / (2 * math.sin(math.pi / n))
    ang = {}
    for t in hole.tendons:
        u = np.asarray(directions[t], dtype=float)
        back = -u[[0, 2]] / u[1]
        ang[t] = math.atan2(back[1], back[0]) if np.hypot(*back) > 1e-9 else 0.0
    order = sorted(hole.tendons, key=lambda t: ang[t])
    phi0 = ang[order[0]]
    seats = []
    for j, t in enumerate(order):
        phi = phi0 + 2 * math.pi * j / n
        p = c + rho * np.array([math.cos(phi), math.sin(phi)])
        seats.append(Seat(t, float(p[0]), float(p[1]), dia, terms[t].diameter))
    reach = rho + dia / 2 + SEAT_MARGIN_MM
    chamber = (None if reach <= hole.diameter / 2 else
               (float(c[0]), float(c[1]), 2 * reach, chamber_height(design, thickness)))
    return seats, chamber
