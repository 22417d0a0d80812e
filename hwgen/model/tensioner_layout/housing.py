"""The housing as members (boxes, cylinders, hex bosses, prisms with windows) to fuse, and the
cuts (screw holes, nut traps or insert bores, the strip's slot), so the search can weigh it and
the CAD stage only turns it into a solid."""
from __future__ import annotations

import math

from ..hardware import NUT_PLAY
from ..intervals import interval_difference
from .placement import Frame
from .result import Member, Unit
from .sizes import (BOSS, DRIVE_FLANGE, GAP, INSERT, M3_CLEARANCE, MOUNT_BAR, NUT, POST, SHELF, STRIP_CLAMP_Z,
                    STRIP_SLOT_CLEARANCE, TENDON_HOLE, Sizes, tip_joint)

FRAME = 3.0              # material left around a window and beside every feature a plate carries
WINDOW_MIN = 6.0         # narrower openings are not worth cutting


def housing_members(fr: Frame, clamp, sz: Sizes, mounts, fast: str, shaft_diameter: float, press_fit: float,
                    with_cuts: bool = True) -> tuple[list[Member], list[Member]]:
    """The housing's members and cuts: base bars on the tip disk (through its screw rows and
    the strip clamp), a spine foot per column, one spine pad per unit stacked from the foot
    (each overlapping the one before, so the wall is one piece), per unit an upper shelf with
    the pin boss, a lower bar and the far worm post; dowel bores (``shaft_diameter`` less the
    ``press_fit``), worm holes, fastener holes
    with nut traps or insert bores, the strip's slot and the tendons' passages."""
    pair = sz.pair
    sp0, sp1 = fr.spine
    yb0, yb1 = sz.y_face, sz.y_face + sz.base_t
    members: list[Member] = []
    cuts: list[Member] = []
    for x, z in mounts:           # from each tip-disk screw out to the spine on its side
        sx = 1.0 if x >= 0 else -1.0
        members.append(Member(f"base bar ({x:g}, {z:g})", "box", (sx * (abs(x) - MOUNT_BAR / 2), sx * sp1, yb0, yb1,
                                                                 z - MOUNT_BAR / 2, z + MOUNT_BAR / 2)))
    cz = _cross_bar(clamp, _passages(fr, sz), sp1)
    members.append(Member("cross bar", "box", (-sp1, sp1, yb0, yb1, *cz)))     # joins the columns
    if clamp is not None:
        members.append(Member("strip clamp", "box", clamp))
    base_z = [v for _, z in mounts for v in (z - MOUNT_BAR / 2, z + MOUNT_BAR / 2)] + list(cz)
    reach = max(pair.ra1, DRIVE_FLANGE[0] / 2, POST / 2)
    for s in (1, -1):
        col = sorted((u for u in fr.units if u.side == s), key=lambda u: u.center[1])
        x0, x1 = s * sp0, s * sp1
        z_lo, z_hi = min(base_z), max(base_z)
        if col:
            z_lo, z_hi = min(z_lo, col[0].lower_bar[0]), max(z_hi, col[0].upper_shelf[1])
        members.append(Member(f"spine foot {'+' if s > 0 else '-'}x", "box", (x0, x1, yb0, yb1, z_lo, z_hi)))
        y_from, prev = yb0, (z_lo, z_hi)
        for u in col:
            top = max(u.center[1] + pair.outside_radius, u.worm_y + reach)
            z0, z1 = u.lower_bar[0], u.upper_shelf[1]
            if z1 < prev[0] + SHELF or z0 > prev[1] - SHELF:     # no shared z with the pad below: reach it
                z0, z1 = min(z0, prev[0]), max(z1, prev[1])
            members.append(Member(f"{u.channel} spine", "box", (x0, x1, y_from, top, z0, z1)))
            if not with_cuts:
                y_from, prev = top - SHELF, (z0, z1)
                continue
            r_boss = max(DRIVE_FLANGE[0] / 2, pair.ra1) + FRAME      # the worm's thrust face and the shaft's flange
            # a tip-disk screw under the spine runs its hole into it: solid around that too
            under = [(yb0, yb1 + 1 + FRAME, z - M3_CLEARANCE / 2 - FRAME, z + M3_CLEARANCE / 2 + FRAME)
                     for x, z in mounts if min(x0, x1) - M3_CLEARANCE / 2 < x < max(x0, x1) + M3_CLEARANCE / 2]
            cuts += _windows(f"{u.channel} spine", 0, x0 - s, x1 + s, (y_from, top), (z0, z1),
                             [(y_from, y_from + SHELF + FRAME, z0, z1),
                              (u.worm_y - r_boss, u.worm_y + r_boss, u.worm_z - r_boss, u.worm_z + r_boss),
                              (y_from, top, z0, u.lower_bar[1] + FRAME), (y_from, top, u.upper_shelf[0] - FRAME, z1)]
                             + under)
            y_from, prev = top - SHELF, (z0, z1)
    for u in fr.units:
        _unit_members(u, fr, sz, members, cuts if with_cuts else None,
                      (shaft_diameter - press_fit) / 2)
    if with_cuts:
        _base_cuts(fr, clamp, sz, mounts, fast, members, cuts)
    return members, cuts if with_cuts else []


def _passages(fr: Frame, sz: Sizes) -> dict[tuple[float, float], float]:
    """Each tendon's passage through the base bars: (x, z) of its tip eyelet -> the hole's diameter
    (TENDON_HOLE, and its drift over the bars at its exit angle)."""
    holes: dict[tuple[float, float], float] = {}
    for r in fr.runs:
        drift = sz.base_t * math.tan(math.radians(r.exit_angle_deg))
        key = (round(r.start[0], 6), round(r.start[2], 6))
        holes[key] = max(holes.get(key, 0.0), TENDON_HOLE + 2 * drift)
    return holes


def _cross_bar(clamp, passages: dict[tuple[float, float], float], half_x: float) -> tuple[float, float]:
    """The cross bar's z range: the strip clamp's (STRIP_CLAMP_Z without one), reaching FRAME past
    every tendon passage through it, so the bar keeps a whole band beyond them and still joins the
    columns (passages either side of the strip's slot would cut a bar of the clamp's height). A bar
    grown past one passage may reach the next one out (a 73.7 mm strip with passages at 3.7 and
    10.7 mm from it once left no band at all: the housing came out in two pieces): it grows until
    no passage it reaches is left."""
    z0, z1 = (clamp[4], clamp[5]) if clamp is not None else STRIP_CLAMP_Z
    while True:
        through = [(z, dia / 2) for (x, z), dia in passages.items()
                   if abs(x) < half_x + dia / 2 and z0 - dia / 2 < z < z1 + dia / 2]
        if not through:
            return z0, z1
        grown = (min(z0, min(z - r for z, r in through) - FRAME), max(z1, max(z + r for z, r in through) + FRAME))
        if grown == (z0, z1):
            return grown
        z0, z1 = grown


def _free(lo: float, hi: float, keep: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The parts of [lo, hi] outside every kept band, each at least WINDOW_MIN long."""
    return [(a, b) for a, b in interval_difference(lo, hi, keep) if b - a >= WINDOW_MIN]


def _windows(name: str, axis: int, lo: float, hi: float, ys: tuple[float, float], vs: tuple[float, float],
             keep: list[tuple[float, float, float, float]]) -> list[Member]:
    """Openings through a plate (normal along x for axis 0, z for axis 2; its other in-plane axis
    is v) wherever it carries nothing: ``keep`` lists the rectangles (y0, y1, v0, v1) that must
    stay solid (a FRAME-wide band is kept along every edge too). Each opening is a hexagon whose
    roof and floor slope at 45° in y, the plate's upright direction when the housing stands on
    its base to print, so it builds without supports; one too wide for its height is split by
    ribs FRAME wide."""
    keep = keep + [(ys[0], ys[0] + FRAME, *vs), (ys[1] - FRAME, ys[1], *vs),
                   (*ys, vs[0], vs[0] + FRAME), (*ys, vs[1] - FRAME, vs[1])]
    out = []
    # strips in v between the edges of every kept rectangle; in each, the y spans free of them
    cuts_v = sorted({vs[0], vs[1], *(k[2] for k in keep), *(k[3] for k in keep)})
    for va, vb in zip(cuts_v, cuts_v[1:]):
        if vb - va < WINDOW_MIN or vb <= vs[0] or va >= vs[1]:
            continue
        blocking = [(k[0], k[1]) for k in keep if k[2] < vb - 1e-9 and k[3] > va + 1e-9]
        for y0, y1 in _free(ys[0], ys[1], blocking):
            out += _hexagons(name, axis, lo, hi, y0, y1, va, vb)
    return out


def _hexagons(name, axis, lo, hi, y0, y1, v0, v1) -> list[Member]:
    n = max(1, math.ceil((v1 - v0 + FRAME) / (y1 - y0 + FRAME)))
    w = (v1 - v0 - (n - 1) * FRAME) / n
    if w < WINDOW_MIN or y1 - y0 < w:
        return []
    out = []
    for k in range(n):
        a = v0 + k * (w + FRAME)
        c, h = a + w / 2, w / 2
        pts = [(y0 + h, a), (y0, c), (y0 + h, a + w), (y1 - h, a + w), (y1, c), (y1 - h, a)]
        out.append(Member(f"{name} window", "prism", (axis, lo, hi, *[q for pt in pts for q in pt])))
    return out


def _unit_members(u: Unit, fr: Frame, sz: Sizes, members, cuts, press_radius: float) -> None:
    """The unit's shelf, bosses, lower bar and far post; and, unless ``cuts`` is None, its bores
    and the shelf's windows."""
    s = u.side
    cx, cy = u.center
    wy, wz = u.worm_y, u.worm_z
    p0, p1 = fr.post
    sp0, sp1 = fr.spine
    c = u.channel
    members += [
        Member(f"{c} shelf", "box", (s * p0, s * sp1, cy - s * BOSS, wy + s * POST / 2, *u.upper_shelf)),
        Member(f"{c} upper boss", "cyl", (BOSS, cx, cy, u.z_part[1] + GAP, cx, cy, u.upper_shelf[1])),
        Member(f"{c} lower bar", "box", (cx, s * sp1, cy - BOSS, cy + BOSS, *u.lower_bar)),
        Member(f"{c} lower boss", "cyl", (BOSS, cx, cy, u.lower_bar[0], cx, cy, u.z_part[0] - GAP)),
        Member(f"{c} post", "box", (s * p0, s * p1, wy - POST / 2, wy + POST / 2, wz - POST / 2, u.upper_shelf[1])),
    ]
    if cuts is None:
        return
    y_boss, y_post = sorted((cy - s * BOSS, cy + s * BOSS)), sorted((wy - POST / 2, wy + POST / 2))
    shelf_y = (min(y_boss[0], y_post[0]), max(y_boss[1], y_post[1]))
    xs = tuple(sorted((s * p0, s * sp1)))
    cuts += _windows(f"{c} shelf", 2, u.upper_shelf[0] - 1, u.upper_shelf[1] + 1, shelf_y, xs,
                     [(y_boss[0] - FRAME, y_boss[1] + FRAME, *xs), (y_post[0] - FRAME, y_post[1] + FRAME, *xs),
                      (*shelf_y, *sorted((s * p0, s * (p1 + FRAME)))), (*shelf_y, cx - BOSS - FRAME, cx + BOSS + FRAME),
                      (*shelf_y, *sorted((s * (sp0 - FRAME), s * sp1)))])
    press = press_radius
    cuts += [
        # dowel bores (press fit): wheel pins along z, worm pin along x through the post
        Member(f"{c} upper pin", "cyl", (press, cx, cy, u.z_part[1], cx, cy, u.upper_shelf[1] + 1.0)),
        Member(f"{c} lower pin", "cyl", (press, cx, cy, u.lower_bar[0] - 1.0, cx, cy, u.z_part[0])),
        Member(f"{c} worm pin", "cyl", (press, s * (p0 - 1.0), wy, wz, s * (p1 + 1.0), wy, wz)),
        # the drive shaft's bearing through the spine
        Member(f"{c} drive hole", "cyl", (sz.spine_hole / 2, s * (sp0 - 1.0), wy, wz, s * (sp1 + 1.0), wy, wz)),
    ]


def _set_screws(clamp, sz: Sizes, fast: str, cuts) -> None:
    """Two M3 set screws press the strip in its slot from the clamp's thick side: through a nut
    that slides into a side slot from the block's end (resin), or an insert (thermoplastic)."""
    hx, hz = sz.strip_half_x, sz.strip_half_z
    ym = (clamp[2] + clamp[3]) / 2
    up = 1.0 if clamp[5] > abs(clamp[4]) else -1.0          # the set screws come from the thick side
    face = clamp[5] if up > 0 else clamp[4]
    for x in (-hx / 2, hx / 2):
        if fast == "nut":
            af, h = NUT["M3"]
            w, t = af + NUT_PLAY, h + NUT_PLAY
            zn = up * (hz + abs(face)) / 2                  # nut halfway between strip and face
            cuts.append(Member("set screw", "cyl", (M3_CLEARANCE / 2, x, ym, up * hz, x, ym, face + up)))
            # side-entry slot from the block's end along x: the nut slides in, its flats held
            sx = 1.0 if x > 0 else -1.0
            x_end = (clamp[1] if x > 0 else clamp[0]) + sx
            cuts.append(Member("set screw nut slot", "box", (*sorted((x - sx * w / 2, x_end)),
                                                             ym - w / 2, ym + w / 2, zn - t / 2, zn + t / 2)))
        else:
            bore, depth = INSERT["M3"]
            cuts.append(Member("set screw insert", "cyl", (bore / 2, x, ym, face - up * depth, x, ym, face + up)))


def _tip_screws(sz: Sizes, mounts, fast: str, cuts) -> None:
    """The screws through the tip disk into the base bars: nuts in side slots, or inserts."""
    yb0, yb1 = sz.y_face, sz.y_face + sz.base_t
    j = tip_joint(fast, sz.tip_t, sz.base_t)
    for x, z in mounts:
        if j.kind == "nut":
            w = NUT["M3"][0] + NUT_PLAY
            cuts.append(Member("tip screw", "cyl", (j.hole / 2, x, yb0 - 1, z, x, yb1 + 1, z)))
            sgn = 1.0 if z >= 0 else -1.0                   # the nut slides in from the bar's outer side
            cuts.append(Member("tip screw nut slot", "box", (x - w / 2, x + w / 2, yb0 + j.nut_from, yb0 + j.depth,
                                                            *sorted((z - sgn * w / 2, z + sgn * MOUNT_BAR)))))
        else:
            cuts.append(Member("tip screw insert", "cyl", (j.hole / 2, x, yb0 - 1, z, x, yb0 + j.depth, z)))


def _base_cuts(fr: Frame, clamp, sz: Sizes, mounts, fast: str, members, cuts) -> None:
    """The strip's slot and set screws, the tip-disk screws and the tendons' passages."""
    hx, hz = sz.strip_half_x, sz.strip_half_z
    c = STRIP_SLOT_CLEARANCE
    yb0, yb1 = sz.y_face, sz.y_face + sz.base_t
    if sz.y_end + c > yb0 - 1:
        cuts.append(Member("strip slot", "box", (-hx - c, hx + c, yb0 - 1, sz.y_end + c, -hz - c, hz + c)))
    if clamp is not None:
        _set_screws(clamp, sz, fast, cuts)
    _tip_screws(sz, mounts, fast, cuts)
    for (x, z), dia in _passages(fr, sz).items():
        in_base = any(m.kind == "box" and m.dims[2] <= yb0 + 1e-9 and m.dims[0] - dia / 2 < x < m.dims[1] + dia / 2
                      and m.dims[4] - dia / 2 < z < m.dims[5] + dia / 2 for m in members)
        if in_base:
            cuts.append(Member("tendon passage", "cyl", (dia / 2, x, yb0 - 1, z, x, yb1 + 1, z)))
