"""Each tendon's seat on the base disk, measured from the disk's STL.

The base disk is cut by planes parallel to its outer face, every PLANE_STEP_MM from the face
inward. A seat is the loop that holds its tendon's design position (the manifest's design report
says where each tendon is meant to end): it must be a loop of its own (shared with no other
tendon), its smallest opening (the largest circle that fits in it, over the depth where it is
its own loop) smaller than what the tendon ends in, that depth (the plate the termination bears
on) and the walls around it at least the process's minimum wall. What a tendon ends in (a knot's
size, a crimp sleeve's outer diameter) is design data: the files cannot show it.
"""
from __future__ import annotations

import math

import numpy as np

from ..cad.export import STL_TOLERANCE_MM
from ..model.settings import Termination
from .base import REBUILD, Check, Screen
from .eyelets import DiskSections
from .polygons import area_centroid, inside, inside_many, loop_gap, points_to_polyline
from .sections import chain_loops, section_robot

PLANE_STEP_MM = 0.1         # depth between cuts
INSCRIBED_STEPS = 40        # grid across a loop for its largest inscribed circle, per zoom
INSCRIBED_ZOOMS = 4         # each zoom refines ±4 cells around the best point so far
SAME_SHAPE = 1e-3           # a loop whose area is within this share of the last one's is the same hole
SEAT_SEARCH_FRACTION = 3 / 8    # cuts reach this share of the disk's thickness in from its outer face (a plate
#                                 thicker than that is measured as this deep: the least it holds)
SAG_MM = STL_TOLERANCE_MM   # the STL's chordal error: section polygons lie this far inside round holes


def inscribed_diameter(loop: np.ndarray) -> float:
    """Diameter of the largest circle inside a closed polygon: what must pass for something round
    to pull through. A grid over the loop, then finer grids around the best point."""
    lo, hi = loop.min(axis=0), loop.max(axis=0)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    best = 0.0
    for _ in range(INSCRIBED_ZOOMS):
        xs = np.linspace(centre[0] - half[0], centre[0] + half[0], INSCRIBED_STEPS)
        zs = np.linspace(centre[1] - half[1], centre[1] + half[1], INSCRIBED_STEPS)
        pts = np.array(np.meshgrid(xs, zs)).reshape(2, -1).T
        pts = pts[inside_many(loop, pts)]
        if len(pts) == 0:
            break
        d = points_to_polyline(pts, loop)
        k = int(np.argmax(d))
        if d[k] > best:
            best, centre = float(d[k]), pts[k]
        half = half * 8 / INSCRIBED_STEPS            # zoom to ±4 cells around the best point
    return 2 * best


def seat_checks(disk: DiskSections, mesh, placement, design_disk: dict, ends: dict[str, Termination],
                min_wall: float, tendon_break: float, resin_strength: float) -> tuple[list[Check], list[dict]]:
    """One check per seat of the base disk; and what was measured, for the report. ``ends``: what
    each tendon ends in (design data), by name."""
    seats = design_disk.get("seats", [])
    if not seats:
        return [], []
    face = disk.y_mid - disk.thickness / 2
    depths = np.arange(PLANE_STEP_MM / 2, disk.thickness * SEAT_SEARCH_FRACTION, PLANE_STEP_MM)
    pts = np.array([[s["x"], s["z"]] for s in seats])
    cuts = []
    for dpt in depths:
        segs = section_robot(mesh, placement, 1, face + float(dpt))
        cuts.append(chain_loops(segs[:, :, [0, 2]]) if len(segs) else [])
    out, rows = [], []
    for k, s in enumerate(seats):
        name = s["tendon"]
        term = ends[name]
        what = f"{term.diameter:g} mm knot" if term.kind == "knot" else f"crimp sleeve Ø{term.diameter:g} mm"
        openings, plate, alone, held = [], 0.0, True, []
        last = (None, 0.0)                                   # (area, inscribed diameter) of the last cut
        for dpt, loops in zip(depths, cuts):
            # the innermost loop around the seat's point: the hole it is in
            around = [lp for lp in loops if inside(lp, pts[k])]
            if not around:
                alone = alone and bool(openings)       # solid at the face: no seat at all
                break
            lp = min(around, key=lambda q: np.ptp(q, axis=0).prod())
            others = any(inside(lp, pts[j]) for j in range(len(seats)) if j != k)
            area = area_centroid(lp)[0]
            if last[0] is not None and abs(area - last[0]) <= SAME_SHAPE * last[0]:
                dia = last[1]                                # a straight hole: the same opening as above
            else:
                dia = inscribed_diameter(lp)
                last = (area, dia)
            if others or dia >= term.diameter:
                if not openings:                      # open or shared right at the face
                    alone = not others
                    openings.append(dia)
                break
            openings.append(dia)
            plate = float(dpt + PLANE_STEP_MM / 2)
            held.append((float(dpt), lp, loops))
        where = {"part": disk.part, "tendon": name}
        if not openings or not alone:
            msg = (f"{name}: no seat of its own on {disk.part}'s outer face"
                   + (" (it shares its opening with another tendon)" if openings else " (the face is solid there)"))
            out.append(Check("tendon.seat", "error", False, msg, None, term.diameter, where,
                             fix=f"route {name} to start clear of the other tendons and the strip at the base disk "
                                 f"(tendons[].routing at station 0), where its seat can be cut; else {REBUILD}"))
            rows.append({"tendon": name, "part": disk.part, "opening_mm": None, "termination_mm": term.diameter,
                         "termination": term.kind, "plate_mm": 0.0, "wall_mm": None, "ok": False})
            continue
        opening = min(openings)
        wall = math.inf
        if held:
            _, lp, loops = min(held, key=lambda h: abs(h[0] - plate / 2))
            # section polygons lie inside the true holes: the wall is thinner than between them by the chords
            wall = min((loop_gap(lp, o) for o in loops if o is not lp), default=math.inf) - 2 * SAG_MM
        holds = opening < term.diameter and plate > 0
        ok = holds and plate >= min_wall and wall >= min_wall
        shear = tendon_break / (math.pi * term.diameter * plate) if plate > 0 else math.inf
        text = (f"{name}: seat on {disk.part}'s outer face, smallest opening Ø{opening:.2f} mm through a "
                f"{plate:.2f} mm plate, for its {what} (design data); thinnest wall beside it {wall:.2f} mm; "
                f"at the tendon's {tendon_break:g} N break load the plate shears at {shear:.1f} MPa "
                f"(resin {resin_strength:g} MPa)")
        if not holds:
            text = (f"{name}: its {what} (design data) pulls through: the seat on {disk.part} opens to "
                    f"Ø{opening:.2f} mm")
        elif not ok:
            text += f"; under the process minimum wall {min_wall:g} mm"
        fix = "" if ok else (
            f"a larger termination than the Ø{opening:.2f} mm opening (tendon_material.termination.diameter, or "
            f"this tendon's termination), or a smaller hole (process.min_hole, process.hole_clearance)" if not holds
            else f"a thicker seat plate (disks.anchors.plate, now {plate:.2f} mm; the end disk must stay over twice "
                 f"it: disks.end_thickness), or route {name} to start farther from its neighbours (tendons[].routing "
                 f"at station 0)" if plate < min_wall else
            f"route {name} to start farther from its neighbours and the strip (tendons[].routing at station 0): the "
            f"wall beside its seat is {wall:.2f} mm; or a process that prints thinner walls (process.min_wall)")
        out.append(Check("tendon.seat", "error", ok, text, opening, term.diameter,
                         {**where, "plate_mm": plate, "wall_mm": wall}, fix=fix))
        rows.append({"tendon": name, "part": disk.part, "opening_mm": opening, "termination_mm": term.diameter,
                     "termination": term.kind, "plate_mm": plate, "wall_mm": wall, "ok": ok})
    return out, rows


# ---------------------------------------------------------------- on the plan alone

def seat_screen(plan) -> list[Screen]:
    """``tendon.seat`` foreseen on the plan: a seat on the base disk as wide as its knot or crimp
    (a steep tendon's slanted seat), so the termination pulls through."""
    return [Screen("tendon.seat", f"{seat.tendon}'s seat on the base disk opens to Ø{seat.diameter:.2f} "
                                  f"mm: its Ø{seat.termination:g} mm termination pulls through", "error",
                   seat.diameter, seat.termination, seat.tendon)
            for seat in plan.disks[0].seats if seat.termination and seat.diameter >= seat.termination]
