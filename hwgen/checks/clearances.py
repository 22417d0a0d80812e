"""Clearances measured on the exported geometry: walls around eyelets, hole size against the
process and against the tendon's angle, tendon-to-tendon distance, and backbone crossings.

Walls are measured between the loops of three disk cuts (the mid-plane and the two axis cuts
either side of it, inside the cylindrical part of the bores; rims broken by chamfers are not
walls). Section polygons are inscribed in the true circles, so a hole's polygon is smaller
than the hole by up to the STL's chordal tolerance: walls beside holes are reduced and hole
diameters enlarged by that much before they are compared.
"""
from __future__ import annotations

import math
import re
from itertools import combinations
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..cad.export import STL_TOLERANCE_MM
from ..model import kinematics as kin
from ..model.crossings import crossing_angles, strip_crossings
from ..model.holes import AXIS_CUT_FRACTION, hole_diameter
from ..model.plan import STRIP_HOLE_SHARE
from .base import REBUILD, Check, Screen
from .eyelets import EyeletMap, joined_holes
from .lengths import sweep_angles
from .polygons import inside, loop_gap, num, points_to_polyline

SAG_MM = STL_TOLERANCE_MM      # chordal deviation of the STL: section polygons sit this far inside holes


def _hole_names(emap: EyeletMap, report: dict) -> dict[int, dict[int, str]]:
    """disk station -> {id(mid-plane hole loop): name} for every measured hole."""
    names: dict[int, dict[int, str]] = {}
    for e in emap.eyelets:
        if e.hole is not None:
            names.setdefault(e.station, {})
            key = id(e.hole.loop)
            prev = names[e.station].get(key)
            label = f"eyelet {'+'.join(e.tendons)}"
            names[e.station][key] = label if prev is None else f"{prev} / {'+'.join(e.tendons)}"
    for disk in emap.disks:
        rd = next(r for r in report["disks"] if r["index"] == disk.station)
        for mh in disk.holes:
            if id(mh.loop) in names.get(disk.station, {}):
                continue
            for m in rd.get("mount_holes", []):
                if inside(mh.loop.points, m[:2]):
                    names.setdefault(disk.station, {})[id(mh.loop)] = f"mount hole ({m[0]:g}, {m[1]:g})"
                    break
            else:
                x, z = mh.centre
                names.setdefault(disk.station, {})[id(mh.loop)] = f"hole at ({num(x, 2)}, {num(z, 2)})"
    return names


def wall_checks(emap: EyeletMap, report: dict, min_wall: float, driven: set[str] = frozenset()) -> list[Check]:
    """Eyelet-to-edge, eyelet-to-eyelet and eyelet-to-slot walls, one check of each per disk.
    ``driven``: the tendons the drive slides, which no fix routes into another's eyelet."""
    out = []
    names = _hole_names(emap, report)
    for disk in emap.disks:
        mids = {id(mh.loop): mh for mh in disk.holes}
        nm = names.get(disk.station, {})
        edge, pair, slot = [], [], []       # (wall, place, section y)
        for y, outline, inner in disk.sections:
            s_loop = next((lp for lp in inner if inside(lp.points, (0.0, 0.0))), None)
            holes = [lp for lp in inner if lp is not s_loop]
            label = {}
            for lp in holes:
                c = np.asarray(lp.centroid)
                near = min(mids.values(), key=lambda mh: np.hypot(*(mh.centre - c)), default=None)
                label[id(lp)] = nm.get(id(near.loop), "hole") if near is not None else "hole"
            for lp in holes:
                edge.append((loop_gap(lp.points, outline.points) - SAG_MM,
                             label[id(lp)], y))
                if s_loop is not None:
                    slot.append((loop_gap(lp.points, s_loop.points) - SAG_MM, label[id(lp)], y))
            for a, b in combinations(holes, 2):
                pair.append((loop_gap(a.points, b.points) - 2 * SAG_MM, f"{label[id(a)]} and {label[id(b)]}", y))
        # holes that the geometry merged: no wall at all
        for st, part, ta, tb, kind in emap.merged_pairs:
            if st != disk.station:
                continue
            other = {"slot": "the backbone slot", "mount": "a mount hole"}.get(kind, f"eyelet {'+'.join(tb)}")
            what = f"eyelet {'+'.join(ta)} and {other}"
            (slot if kind == "slot" else pair).append((0.0, f"{what} (merged into one opening)", disk.y_mid))
        for cid, kind, items in (("eyelet.wall.edge", "to the outer edge", edge),
                                 ("eyelet.wall.eyelet", "between holes", pair),
                                 ("eyelet.wall.slot", "to the backbone slot", slot)):
            where = {"part": disk.part, "station": disk.station}
            if not items:
                out.append(Check(cid, "error", True, f"{disk.part}: no hole near enough to measure a wall {kind}",
                                 None, min_wall, where))
                continue
            w, place, _y = min(items, key=lambda it: it[0])
            bad = sorted({p for v, p, _ in items if v < min_wall})
            ok = not bad
            if ok:
                msg = f"{disk.part}: thinnest wall {kind} {w:.3f} mm ({place}), process minimum {min_wall:g} mm"
            else:
                msg = (f"{disk.part}: wall {kind} {w:.3f} mm at {place} is under the process minimum "
                       f"{min_wall:g} mm" + (f"; also thin: {', '.join(p for p in bad if p != place)}"
                                             if len(bad) > 1 else ""))
            rd = next((r for r in report["disks"] if r["index"] == disk.station), {})
            fix = "" if ok else _wall_fix(cid, place, min_wall - w, disk.station, rd.get("outer_diameter_mm"),
                                          driven)
            out.append(Check(cid, "error", ok, msg, max(w, 0.0), min_wall, {**where, "at": place}, fix=fix))
    return out


def _wall_fix(cid: str, place: str, short: float, station: int, diameter: float | None,
              driven: set[str] = frozenset()) -> str:
    """What gives a wall under the process minimum the ``short`` mm it lacks, at ``place``; two
    holes are offered one shared eyelet only when neither holds a driven tendon (a driven line
    slides, and would rub the other: eyelet.shared_sliding)."""
    holes = place.split(" (")[0]
    thinner = "; or a process that prints thinner walls (process.min_wall)"
    if cid == "eyelet.wall.edge":
        grow = f"disks.outer_diameter from {diameter:g} to at least {math.ceil(2 * (diameter / 2 + short) * 2) / 2:g} mm, or " \
            if diameter else ""
        return (f"{grow}route the tendon of {holes} at least {short:.2f} mm further in at station {station} "
                f"(tendons[].routing){thinner}")
    if cid == "eyelet.wall.slot":
        return (f"route the tendon of {holes} at least {short:.2f} mm further from the strip at station {station} "
                f"(tendons[].routing: a larger |z| there), or a smaller disks.slot_clearance{thinner}")
    names = set(re.findall(r"[^\s+/]+", holes.replace("eyelet ", " ").replace(" and ", " ")))
    share = "" if names & set(driven) else ", or route them into one shared eyelet"
    return (f"route {holes} at least {short:.2f} mm further apart at station {station} (tendons[].routing)"
            f"{share}; or smaller eyelets (process.hole_clearance){thinner}")


def hole_checks(emap: EyeletMap, min_hole: float, tendon_d: float, angles_deg: np.ndarray,
                length: float, tip_exits: dict[str, np.ndarray] | None = None) -> list[Check]:
    """Smallest eyelet versus the process; tendon angle through each eyelet versus its size and axis.

    A tendon of diameter d crossing a wall of thickness T at angle α to the hole axis needs a
    hole of at least d/cos α + T tan α (the builder's rule without its clearance); less and
    the hole edge pinches it. α is taken over the whole sweep from the measured positions; at
    the tip disk the tendon's exit toward its spool (``tip_exits``, tip frame) counts too.
    """
    tip_exits = tip_exits or {}
    last = max(d.station for d in emap.disks)
    out = []
    for disk in emap.disks:
        ey = [e for e in emap.eyelets if e.station == disk.station and e.hole is not None]
        where = {"part": disk.part, "station": disk.station}
        if not ey:
            continue
        small = min(ey, key=lambda e: e.hole.diameter)
        d = small.hole.diameter + 2 * SAG_MM
        ok = d >= min_hole
        nm = "+".join(small.tendons)
        msg = (f"{disk.part}: smallest eyelet Ø{small.hole.diameter:.3f} mm ({nm}; the STL polygon, "
               f"{2 * SAG_MM:g} mm under the true hole at most), process minimum {min_hole:g} mm"
               if ok else f"{disk.part}: eyelet {nm} is Ø{small.hole.diameter:.3f} mm, under the process minimum "
                          f"{min_hole:g} mm; it may print closed")
        out.append(Check("eyelet.min_hole", "error", ok, msg, small.hole.diameter, min_hole, {**where, "tendon": nm},
                         fix="" if ok else f"hwgen cuts every eyelet at least process.min_hole wide: {REBUILD}"))

    kappa = kin.kappas_for_angles(angles_deg, length)
    T_of = {d.station: d.thickness for d in emap.disks}
    part_of = {d.station: d.part for d in emap.disks}
    for name, xz in emap.positions.items():
        into, outof = kin.segment_directions_local(emap.stations_y, xz, kappa)
        worst = None   # (margin, station, alpha, need, have)
        for e in emap.eyelets:
            if name not in e.tendons or e.hole is None or e.hole.axis is None:
                continue
            i = e.station
            ax = e.hole.axis
            dirs = np.concatenate([into[:, i], outof[:, i]])          # both segments, every bend
            bends = np.concatenate([angles_deg, angles_deg])
            if i == last and name in tip_exits:                        # on to the tensioner, at any bend
                dirs = np.concatenate([dirs, np.tile(tip_exits[name], (len(angles_deg), 1))])
                bends = np.concatenate([bends, angles_deg])
            valid = ~np.isnan(dirs[:, 0])                               # no segment before the base disk
            cos = np.clip(np.abs(dirs[valid] @ ax), 0, 1)
            k = int(np.argmin(cos))
            alpha = float(np.arccos(cos[k]))
            need = hole_diameter(tendon_d, T_of[i], alpha)
            margin = e.hole.diameter + 2 * SAG_MM - need
            if worst is None or margin < worst[0]:
                worst = (margin, i, np.degrees(alpha), need, e.hole.diameter, float(bends[valid][k]))
        if worst is None:
            continue
        margin, i, a, need, have, ang = worst
        where = {"tendon": name, "part": part_of.get(i, f"disk_{i:02d}"), "station": i, "angle_deg": ang}
        ok = margin >= 0
        if ok:
            msg = (f"{name}: tightest eyelet {where['part']}, Ø{have:.3f} mm for {need:.3f} mm needed at "
                   f"{a:.1f}° to its axis (bending {ang:+g}°)")
        else:
            msg = (f"{name} is pinched in {where['part']}: the eyelet is Ø{have:.3f} mm but at {a:.1f}° to "
                   f"its axis (bending {ang:+g}°) the tendon needs {need:.3f} mm")
        fix = "" if ok else (f"the eyelet needs Ø{need:.3f} mm; hwgen sizes each for the worst angle over "
                             f"disks.eyelets.sweep_deg (and tensioner.max_exit_deg at the tip): {REBUILD}")
        out.append(Check("eyelet.tendon_angle", "error", ok, msg, have, need, where, fix=fix))
    return out


def segment_distance(p0, p1, q0, q1) -> np.ndarray:
    """Closest distance between segments p0-p1 and q0-q1 (arrays (..., 3)), clamped to the ends."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("...i,...i", d1, d1)
    e = np.einsum("...i,...i", d2, d2)
    b = np.einsum("...i,...i", d1, d2)
    c = np.einsum("...i,...i", d1, r)
    f = np.einsum("...i,...i", d2, r)
    den = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(den > 1e-12 * a * e, np.clip((b * f - c * e) / den, 0, 1), 0.0)
        t = (b * s + f) / e
        s = np.where(t < 0, np.clip(-c / a, 0, 1), np.where(t > 1, np.clip((b - c) / a, 0, 1), s))
    t = np.clip(t, 0, 1)
    diff = p0 + d1 * s[..., None] - (q0 + d2 * t[..., None])
    return np.sqrt(np.einsum("...i,...i", diff, diff))


def tendon_pair_checks(emap: EyeletMap, report: dict, tendon_d: float, angles_deg: np.ndarray,
                       length: float, driven: set[str] = frozenset()) -> list[Check]:
    """Closest approach of every two tendons over the sweep, away from the eyelets they share.
    ``driven``: the tendons the drive slides; a pair with one of them is never offered a shared
    eyelet as a fix (the driven line would rub the other there: eyelet.shared_sliding).

    Segments are compared bay by bay (between the same two disks): lines in different bays
    have a disk between them. A segment that ends in an eyelet both tendons share touches the
    other there by design; those segments are left out and the shared eyelets are listed.
    """
    kappa = kin.kappas_for_angles(angles_deg, length)
    pts = {n: kin.points_in_space(emap.stations_y, xz, kappa) for n, xz in emap.positions.items()}
    shared: dict[tuple[str, str], list[int]] = {}
    joined = joined_holes(report)
    for rd in report["disks"]:
        for h in rd["holes"]:
            if (rd["index"], tuple(h["tendons"])) in joined:
                continue            # one opening around eyelets routed into each other: not shared by design
            for a, b in combinations(h["tendons"], 2):
                shared.setdefault(tuple(sorted((a, b))), []).append(rd["index"])
    out = []
    for a, b in combinations(pts, 2):
        key = tuple(sorted((a, b)))
        sh = set(shared.get(key, []))
        P, Q = pts[a], pts[b]
        n = P.shape[1]
        keep = [j for j in range(n - 1) if j not in sh and j + 1 not in sh]
        where = {"tendons": [a, b]}
        if sh:
            out.append(Check("tendon.contact", "info", True,
                             f"{a} and {b} share eyelets at stations {sorted(sh)}: they touch there by design",
                             None, None, {**where, "stations": sorted(sh)}))
        if not keep:
            continue
        j = np.array(keep)
        dist = segment_distance(P[:, j], P[:, j + 1], Q[:, j], Q[:, j + 1])   # (K, len(keep))
        k, m = np.unravel_index(int(np.argmin(dist)), dist.shape)
        dmin = float(dist[k, m])
        seg = int(j[m])
        ang = float(angles_deg[k])
        ok = dmin >= tendon_d
        span = f"between stations {seg} and {seg + 1}"
        msg = (f"{a} and {b}: closest {dmin:.3f} mm {span} at {ang:+g}° (tendon Ø{tendon_d:g} mm)" if ok else
               f"{a} and {b} rub: {dmin:.3f} mm apart {span} at {ang:+g}° bending, less than the tendon "
               f"diameter {tendon_d:g} mm")
        fix = "" if ok else clearance_fix(a, b, tendon_d - dmin, seg, driven)
        out.append(Check("tendon.clearance", "error", ok, msg, dmin, tendon_d,
                         {**where, "segment": [seg, seg + 1], "angle_deg": ang}, fix=fix))
    return out


def clearance_fix(a: str, b: str, short: float, seg: int, driven: set[str] = frozenset()) -> str:
    """What parts two tendons that rub ``short`` mm too close between stations ``seg`` and ``seg + 1``;
    meeting in one eyelet is offered only when neither is driven (eyelet.shared_sliding fails it)."""
    meet = "" if {a, b} & set(driven) else ", or route them to meet at a disk, where they share one eyelet"
    return (f"route {a} and {b} at least {short:.2f} mm further apart between stations {seg} and {seg + 1} "
            f"(their tendons[].routing: amplitude, phase or an x or z offset){meet}; the stations decide where the "
            f"lines between eyelets run (disks.count, disks.spacing)")


def dxf_holes(path: Path) -> list[tuple[float, float, float]]:
    """Circles on the HOLES layer of the backbone template: (x, y, radius) in robot mm."""
    import ezdxf
    doc = ezdxf.readfile(str(path))
    return [(float(c.dxf.center.x), float(c.dxf.center.y), float(c.dxf.radius))
            for c in doc.modelspace().query('CIRCLE[layer=="HOLES"]')]


def crossings(emap: EyeletMap, half_height: float) -> list[tuple[str, float, float, float]]:
    """Where each tendon meets the backbone plane within the strip, straight robot: (tendon, station, x, y)."""
    in_slot = {(t, e.station) for e in emap.eyelets if e.status == "in_slot" for t in e.tendons}
    return [(name, st, x, y) for name, xz in emap.positions.items()
            for st, x, y in strip_crossings(emap.stations_y, xz, half_height,
                                            {i for t, i in in_slot if t == name})]


def _breaks_through(x: float, y: float, r: float, outline) -> str:
    """Where a strip hole of radius ``r`` at (x, y) opens the strip's outline: its side or its end."""
    (x0, y0), (x1, y1) = outline.points.min(axis=0), outline.points.max(axis=0)
    if y + r >= y1 or y - r <= y0:
        end = y1 if y + r >= y1 else y0
        return (f"so near the strip's end that its Ø{2 * r:.2f} hole (reaching y = {y + r if end == y1 else y - r:.2f} "
                f"mm, the strip ends at y = {end:.2f} mm) breaks through it")
    edge = x1 if x >= 0 else x0
    return (f"so near the strip's edge that its Ø{2 * r:.2f} hole (reaching x = {x + r if x >= 0 else x - r:.2f} mm, "
            f"the edge is at x = {edge:.2f} mm) breaks through it")


class StripBend(NamedTuple):
    """The strip's thickness (mm) and the sweep (bending angles, °; the robot's length, mm) a
    crossing's hole is sized against."""

    thickness: float
    angles_deg: np.ndarray
    length: float


def _hole_angle_fix(name: str, at: str, need: float, height: float) -> str:
    """What lets a tendon through the strip untouched: where the hole it needs is wider than the plan
    cuts any strip hole (STRIP_HOLE_SHARE of the strip), a squarer crossing or a wider strip; else
    hwgen cut it too small."""
    if need <= STRIP_HOLE_SHARE * height:
        return (f"drill the strip's hole Ø{need:.2f} mm; hwgen sizes it for the steepest crossing over "
                f"disks.eyelets.sweep_deg: {REBUILD}")
    return (f"route {name} across the strip more squarely {at} (tendons[].routing: the hole it needs grows as "
            f"1/cos of its angle to the strip's normal; a smaller disks.eyelets.sweep_deg bends it less), or a "
            f"wider strip, whose hole may take {STRIP_HOLE_SHARE:.0%} of it: backbone.height ≥ "
            f"{math.ceil(need / STRIP_HOLE_SHARE * 10) / 10:.1f} mm (it is {height:.1f})")


def backbone_checks(emap: EyeletMap, dxf_path: Path, bb_outline, bb_holes, tendon_d: float, tol: float,
                    findings: list[str], bend: StripBend | None = None) -> list[Check]:
    """Every crossing of the strip has a hole in the DXF template and in the strip's STL, and
    (given ``bend``) the hole is wide enough for the steepest angle the tendon crosses the strip at."""
    strip_t, angles_deg, length = bend if bend is not None else (None, None, None)
    out = []
    half_h = float(bb_outline.extent[0]) / 2 if bb_outline is not None else float("inf")
    circles = dxf_holes(dxf_path) if dxf_path.exists() else []
    r_t = tendon_d / 2
    for name, st, x, y in crossings(emap, half_h):
        where = {"tendon": name, "station": round(st, 4), "x": round(x, 4), "y": round(y, 4)}
        at = f"at station {st:g}" if float(st).is_integer() else f"between stations {int(st)} and {int(st) + 1}"
        place = f"{name} crosses the backbone {at} (x={num(x, 2)}, y={num(y, 2)} mm)"
        fit_dxf = [r - (np.hypot(cx - x, cy - y) + r_t) for cx, cy, r in circles]
        best_dxf = max(fit_dxf, default=-np.inf)
        in_dxf = best_dxf >= -tol
        dia = [2 * circles[int(np.argmax(fit_dxf))][2]] if in_dxf else []
        stl_fit = -np.inf
        for lp in bb_holes or []:
            if inside(lp.points, (x, y)):
                stl_fit = float(points_to_polyline(np.array([[x, y]]), lp.points)[0]) + SAG_MM - r_t
                dia.append(lp.equivalent_diameter + 2 * SAG_MM)
        in_stl = stl_fit >= -tol
        missing = [w for w, ok in (("backbone_template.dxf", in_dxf), ("the backbone STL", in_stl)) if not ok]
        # no hole loop around the crossing, and the crossing outside the strip's outline: the
        # hole was cut, but it runs into the strip's edge and made a notch of it
        notched = (not in_stl and bb_outline is not None and abs(x) < half_h
                   and not inside(bb_outline.points, (x, y)))
        if notched:
            msg = (f"{place}, {_breaks_through(x, y, dia[0] / 2 if dia else r_t, bb_outline)}: the strip is "
                   f"notched there, not drilled" + (" (and backbone_template.dxf has no hole it passes)"
                                                    if not in_dxf else ""))
        elif missing:
            msg = f"{place} but {' and '.join(missing)} {'has' if len(missing) == 1 else 'have'} no hole it passes"
        else:
            msg = f"{place} through a hole in the template and the strip"
        measured = float(min(best_dxf, stl_fit)) if np.isfinite(min(best_dxf, stl_fit)) else None
        fix = "" if not missing else (
            f"route {name} to cross the strip farther from its {'end' if 'end' in msg else 'edge'} "
            f"(tendons[].routing), or a wider strip (backbone.height)" if notched else REBUILD)
        out.append(Check("backbone.crossing", "error", not missing, msg, measured, 0.0, where, fix=fix))
        if dia and strip_t is not None and angles_deg is not None:
            beta = crossing_angles(emap.stations_y, emap.positions[name], st,
                                   kin.kappas_for_angles(angles_deg, length))
            k = int(np.argmax(beta))
            b = float(beta[k])
            need = hole_diameter(tendon_d, strip_t, b)
            have = float(min(dia))
            ok = have >= need
            txt = (f"{name} crosses the {strip_t:.2f} mm strip {at} at up to {np.degrees(b):.0f}° to its normal "
                   f"(bending {angles_deg[k]:+g}°): a hole drilled square to the strip needs Ø{need:.2f} mm")
            msg = (f"{txt}; it is Ø{have:.2f} mm" if ok else
                   f"{txt} to let it through untouched, it is Ø{have:.2f} mm: the line bears on the hole's edge")
            fix = "" if ok else _hole_angle_fix(name, at, need, 2 * half_h)
            out.append(Check("backbone.hole_angle", "error", ok, msg, have, float(need),
                             {**where, "angle_deg": float(angles_deg[k])}, fix=fix))
    for f in findings:
        out.append(Check("backbone.in_plane", "error", False, f"{f}: it would have to run through the strip",
                         None, None, {}, fix="route the tendon off the strip's plane there (tendons[].routing: its z "
                                             "beyond the strip's half thickness and disks.slot_clearance), or across "
                                             "the strip at a station"))
    return out


# ---------------------------------------------------------------- on the plan alone

ELLIPSE_POINTS = 90         # points on each hole's section for the wall between two: 2° apart, within 0.02 mm on
                            # a Ø3 mm hole's polygon of the files (the checks' chordal tolerance is taken off as they do)


def _section(h, y: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bore of a plan hole on the plane ``y`` mm off the disk's mid-plane: its centre drifted along
    the slanted axis, an ellipse 1/cos θ longer along the slant; (outline (ELLIPSE_POINTS, 2), centre,
    the map taking a point's offset from the centre to the unit circle)."""
    ax = np.asarray(h.axis, float)
    ay = max(abs(ax[1]), 1e-6)
    c = np.array([h.x, h.z]) + y * ax[[0, 2]] / ay
    r = h.diameter / 2
    lean = ax[[0, 2]]
    n = np.linalg.norm(lean)
    u = lean / n if n > 1e-12 else np.array([1.0, 0.0])
    v = np.array([-u[1], u[0]])
    t = np.linspace(0, 2 * np.pi, ELLIPSE_POINTS, endpoint=False)
    outline = c + np.outer(np.cos(t) * r / ay, u) + np.outer(np.sin(t) * r, v)
    return outline, c, np.stack([u * ay / r, v / r])


def _gap(a: tuple, b: tuple) -> float:
    """The least distance between two sections' outlines (0 where they overlap)."""
    (p, cp, mp), (q, cq, mq) = a, b
    inside = (np.linalg.norm((p - cq) @ mq.T, axis=1) <= 1).any() or (np.linalg.norm((q - cp) @ mp.T, axis=1) <= 1).any()
    if inside:
        return 0.0
    return float(np.sqrt(((p[:, None] - q[None]) ** 2).sum(-1)).min())


def thinnest_wall(plan, min_wall: float):
    """(wall, hole, hole, disk) of the thinnest wall under ``min_wall`` between two eyelet holes of
    any disk, as ``eyelet.wall.eyelet`` measures it from the files: on the mid-plane and on the two
    cuts :data:`hwgen.model.holes.AXIS_CUT_FRACTION` of the thickness either side, where a slanted
    bore's section has drifted along its axis and is an ellipse (the holes' circles on the mid-plane
    alone missed walls of 0.45 mm the build then failed), less the files' chordal tolerance; None
    when every wall is thick enough."""
    worst = None
    for disk in plan.disks:
        holes = disk.holes
        h = disk.thickness * AXIS_CUT_FRACTION
        for i, a in enumerate(holes):
            for b in holes[i + 1:]:
                ra = a.diameter / 2 / max(abs(a.axis[1]), 1e-6)
                rb = b.diameter / 2 / max(abs(b.axis[1]), 1e-6)
                drift = h * (math.hypot(a.axis[0], a.axis[2]) / max(abs(a.axis[1]), 1e-6)
                             + math.hypot(b.axis[0], b.axis[2]) / max(abs(b.axis[1]), 1e-6))
                if math.hypot(a.x - b.x, a.z - b.z) - ra - rb - drift >= min_wall + 2 * SAG_MM:
                    continue            # thick enough wherever the cuts fall
                w = min(_gap(_section(a, y), _section(b, y)) for y in (0.0, -h, h)) - 2 * SAG_MM
                if w < min_wall and (worst is None or w < worst[0]):
                    worst = (max(w, 0.0), a, b, disk)
    return worst


def wall_screen(plan) -> list[Screen]:
    """``eyelet.wall`` (between holes) foreseen on the plan: the thinnest wall between two eyelets of
    any disk, on the cuts the check measures (:func:`thinnest_wall`), under the process's minimum wall."""
    thin = thinnest_wall(plan, plan.min_wall)
    if thin is None:
        return []
    w, a, b, disk = thin
    return [Screen("eyelet.wall", f"wall {w:.2f} mm between disk {disk.index}'s eyelets for {'+'.join(a.tendons)} "
                                  f"and {'+'.join(b.tendons)} (on its axis cuts, where a slanted bore drifts), under "
                                  f"process.min_wall {plan.min_wall:g} mm", "error", w, plan.min_wall)]


def crossing_screen(plan) -> list[Screen]:
    """``backbone.crossing`` foreseen on the plan: the first hole for a crossing that breaks through
    the strip's edge or end (the helix of 30 mm at 5 half turns lies on the 60 mm strip's edge at the
    middle disk)."""
    bb = plan.backbone
    for h in bb.holes:
        r = h.diameter / 2
        over = max(abs(h.x) + r - bb.height / 2, bb.y_start - (h.y - r), h.y + r - bb.y_end)   # mm past the outline
        if over >= 0:
            return [Screen("backbone.crossing", f"{h.tendon} crosses the strip at x = {h.x:.2f}, y = {h.y:.2f} mm, "
                                                f"where its Ø{h.diameter:.2f} hole breaks through the strip's "
                                                f"outline (a notch, not a hole)", "error",
                           bb.height / 2 + over, bb.height / 2, h.tendon)]
    return []


def rubbing_screen(plan) -> list[Screen]:
    """``tendon.clearance`` foreseen on the plan's eyelet positions: the closest two tendons come
    between two disks over the check's sweep, bay by bay, leaving out the bays that end in an eyelet
    they share by design; a screen when it is under the tendon's diameter."""
    ang = sweep_angles(plan.check.max_angle_deg, plan.check.step_deg)
    kappa = kin.kappas_for_angles(ang, plan.backbone.length)
    st = np.asarray(plan.stations, float)
    pts = {p.name: kin.points_in_space(st, p.points, kappa) for p in plan.paths}
    shared: dict[tuple[str, str], set[int]] = {}
    for m in plan.merges:
        if m.kind == "shared":
            for a, b in combinations(m.tendons, 2):
                shared.setdefault(tuple(sorted((a, b))), set()).add(m.station)
    d = plan.tendon_material.diameter
    worst = None
    for a, b in combinations(pts, 2):
        sh = shared.get(tuple(sorted((a, b))), set())
        keep = np.array([j for j in range(len(st) - 1) if j not in sh and j + 1 not in sh], int)
        if keep.size == 0:
            continue
        P, Q = pts[a], pts[b]
        gap = float(segment_distance(P[:, keep], P[:, keep + 1], Q[:, keep], Q[:, keep + 1]).min())
        if worst is None or gap < worst[0]:
            worst = (gap, a, b)
    if worst is None or worst[0] >= d:
        return []
    gap, a, b = worst
    return [Screen("tendon.clearance", f"{a} and {b} rub between two disks: {gap:.3f} mm apart over the sweep, "
                                       f"less than the tendon diameter {d:g} mm", "error", gap, d)]
