"""Eyelets found in the exported disks and matched to the tendons.

Every disk STL is cut at its mid-plane and at two planes a little above and below it; the
closed loops of each cut are the outline, the backbone slot (the loop around the disk
centre) and the holes. A hole's centre is the centroid of its mid-plane loop, its axis the
line through the centroids of the two off-centre cuts, and its diameter (perpendicular to
that axis) follows from the area of the mid-plane loop, an ellipse of area πD²/(4 cos θ).

Eyelets that lie inside the slot (recorded backbone crossings) open into the slot loop and
cannot be seen in the disk; their x is read from the matching hole of the backbone STL.
"""
from __future__ import annotations

import math
from itertools import combinations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..model.holes import AXIS_CUT_FRACTION
from .base import REBUILD, Check, Screen
from .meshes import load_mesh
from .polygons import area_centroid, inside, num
from .sections import Loop, chain_loops, disk_slab, section_loops

OFF_PLANE_FRACTION = AXIS_CUT_FRACTION   # the axis cuts sit this fraction of the thickness either side of the mid-plane,
CLEAR_FRACTION = 1 / 2       # or this fraction of the way from the mid-plane to a recess floor, if nearer
NEAR_FACTOR = 3.0            # an unmatched hole within this many design diameters is "moved", not "missing"


# ---------------------------------------------------------------- disks

@dataclass
class MeasuredHole:
    loop: Loop                       # mid-plane loop, robot (x, z)
    centre: np.ndarray               # (2,) centroid, robot (x, z) = disk frame (x, z)
    axis: np.ndarray | None          # (3,) unit, disk frame, +y; None when an off cut missed it
    diameter: float                  # perpendicular to the axis, from the mid-plane area


@dataclass
class DiskSections:
    """One disk measured from its STL."""

    part: str
    station: int
    y_mid: float
    thickness: float                 # of the plate (a hub standing on it not included)
    sections: list[tuple[float, Loop, list[Loop]]]   # (robot y, outline, inner loops): mid first
    slot: Loop | None
    holes: list[MeasuredHole]

    @property
    def outline(self) -> Loop:
        return self.sections[0][1]


def _robot_y(placement: np.ndarray, z_file: float) -> float:
    return float((placement @ [0.0, 0.0, z_file, 1.0])[1])


def measure_disk(stl: Path, placement, part: str, station: int, mesh=None, recess: float = 0.0) -> DiskSections:
    """Cut one disk file (or its already loaded ``mesh``) and find its outline, slot and holes.

    ``recess``: the depth of the deepest recess in either face (the base disk's knot pockets,
    from the design report). The axis cuts stay clear of it: a cut on a pocket's floor, or
    through the pocket, finds the pocket's outline instead of the bore's and tilts the axis.
    """
    mesh = load_mesh(stl) if mesh is None else mesh
    P = np.asarray(placement, dtype=float)
    zmin, zmax = disk_slab(mesh)
    T = zmax - zmin
    mid = (zmin + zmax) / 2
    h = T * OFF_PLANE_FRACTION
    if recess > 0:
        h = min(h, CLEAR_FRACTION * (T / 2 - recess))
    if h <= 0:
        raise ValueError(f"{part}: a {recess:g} mm recess reaches the mid-plane of a {T:g} mm disk")
    sections = []
    for off in (0.0, -h, h):
        loops = section_loops(mesh, P, [0.0, 0.0, mid + off], [0.0, 0.0, 1.0])
        if not loops:
            raise ValueError(f"{part}: the cut at {off:+.3f} mm from the mid-plane is empty")
        sections.append((_robot_y(P, mid + off), loops[0], loops[1:]))
    y_mid, _outline, inner = sections[0]
    slot = next((lp for lp in inner if inside(lp.points, (0.0, 0.0))), None)
    holes = []
    (ya, _, lower), (yb, _, upper) = sections[1], sections[2]
    for lp in inner:
        if lp is slot:
            continue
        c = np.asarray(lp.centroid)
        size = max(lp.extent)
        pa = _nearest(lower, c, size)
        pb = _nearest(upper, c, size)
        axis = None
        if pa is not None and pb is not None:
            v = np.array([pb[0] - pa[0], yb - ya, pb[1] - pa[1]])
            axis = v / np.linalg.norm(v)
            if axis[1] < 0:
                axis = -axis
        cos_t = abs(axis[1]) if axis is not None else 1.0
        dia = float(2 * np.sqrt(lp.area * cos_t / np.pi))
        holes.append(MeasuredHole(lp, c, axis, dia))
    return DiskSections(part, station, y_mid, T, sections, slot, holes)


def _nearest(loops: list[Loop], c: np.ndarray, within: float):
    best, bd = None, within
    for lp in loops:
        d = float(np.hypot(*(np.asarray(lp.centroid) - c)))
        if d < bd:
            best, bd = lp.centroid, d
    return best


def backbone_section(stl: Path, placement) -> tuple[Loop, list[Loop], float]:
    """The strip cut halfway through its thickness: outline and holes in robot (x, y), and its thickness."""
    import trimesh
    mesh = load_mesh(stl)
    zmin, zmax = (float(v) for v in mesh.bounds[:, 2])
    segs = trimesh.intersections.mesh_plane(mesh, plane_normal=[0, 0, 1], plane_origin=[0, 0, (zmin + zmax) / 2])
    P = np.asarray(placement, dtype=float)
    robot = (np.c_[segs.reshape(-1, 3), np.ones(len(segs) * 2)] @ P.T)[:, :3].reshape(-1, 2, 3)
    loops = [Loop(pts, *area_centroid(pts)) for pts in chain_loops(robot[:, :, [0, 1]])]
    loops.sort(key=lambda lp: -lp.area)
    return loops[0], loops[1:], zmax - zmin


# ---------------------------------------------------------------- matching eyelets to tendons

@dataclass
class Eyelet:
    """One designed eyelet hole of one disk and what was found for it."""

    station: int
    part: str
    tendons: tuple[str, ...]
    design_xz: np.ndarray
    design_diameter: float
    in_slot: bool
    hole: MeasuredHole | None = None      # the disk hole it was matched to
    status: str = "missing"               # "ok", "moved", "merged", "in_slot", "into_slot", "missing"
    offset: float = float("nan")          # centre distance from design intent, mm
    measured_xz: np.ndarray | None = None


@dataclass
class EyeletMap:
    stations_y: np.ndarray                        # measured y of every disk mid-plane
    eyelets: list[Eyelet]
    positions: dict[str, np.ndarray]              # tendon -> (N, 2) measured (x, z), design where unmeasurable
    unmeasured: dict[str, list[int]]              # tendon -> stations filled from design intent
    via_backbone: dict[str, list[int]]            # tendon -> stations read from the strip's holes
    disks: list[DiskSections]
    extra_holes: list[tuple[DiskSections, MeasuredHole]] = field(default_factory=list)
    merged_pairs: list[tuple[int, str, tuple[str, ...], tuple[str, ...], str]] = field(default_factory=list)


def locate_eyelets(disks: list[DiskSections], report: dict, backbone_holes: list[Loop] | None,
                   tol: float) -> tuple[EyeletMap, list[Check]]:
    """Match measured holes to the design report's eyelets; checks for position and presence.

    Three steps: match each disk's holes to its designed eyelets; read the eyelets that lie in
    the backbone slot from the strip's holes; gather every tendon's positions station by
    station, from the design where nothing was measured.
    """
    by_station = {d.station: d for d in disks}
    ys = np.array(report["stations_mm"], dtype=float)
    eyelets: list[Eyelet] = []
    extra: list[tuple[DiskSections, MeasuredHole]] = []
    merged_pairs: list = []
    for rd in report["disks"]:
        i = rd["index"]
        disk = by_station.get(i)
        here = [Eyelet(i, disk.part if disk else f"disk {i}", tuple(h["tendons"]), np.array([h["x"], h["z"]]),
                       h["diameter_mm"], h["in_slot"]) for h in rd["holes"]]
        eyelets.extend(here)
        if disk is not None:
            ys[i] = disk.y_mid
            unmatched = _match_disk(disk, here, [np.array(m[:2]) for m in rd.get("mount_holes", [])], tol,
                                    merged_pairs)
            extra += [(disk, mh) for mh in unmatched]
    via_backbone = _read_from_strip(eyelets, ys, backbone_holes, [t["name"] for t in report["tendons"]])
    # An opening the plan made around eyelets the routing ran into each other is found like any
    # hole, but says nothing of where each tendon lies in it: those stay at their routing, and
    # there is no wall between them.
    joined = joined_holes(report)
    for e in eyelets:
        if (e.station, e.tendons) in joined:
            if e.measured_xz is not None:
                merged_pairs += [(e.station, e.part, (a,), (b,), "eyelet") for a, b in combinations(e.tendons, 2)]
            e.measured_xz = None
    positions, unmeasured = _positions(eyelets, report)
    checks = _position_checks(report, eyelets, tol) + [_unexpected(disk, mh) for disk, mh in extra]
    return EyeletMap(ys, eyelets, positions, unmeasured, via_backbone, disks, extra, merged_pairs), checks


def _match_disk(disk: DiskSections, here: list[Eyelet], mounts: list[np.ndarray], tol: float,
                merged_pairs: list) -> list[MeasuredHole]:
    """Give each designed eyelet of one disk its measured hole and a status; returns the holes
    no eyelet or mount hole claims. Holes shared by several eyelets, or run into the slot or a
    mount hole, are recorded in ``merged_pairs``."""
    i = disk.station
    claimed: dict[int, list[Eyelet]] = {}
    for e in here:
        if e.in_slot:
            e.status = "in_slot"
            continue
        if disk.slot is not None and inside(disk.slot.points, e.design_xz):
            e.status = "into_slot"
            continue
        for k, mh in enumerate(disk.holes):
            if inside(mh.loop.points, e.design_xz):
                claimed.setdefault(k, []).append(e)
                e.hole = mh
                break
    mount_claimed = {k for k, mh in enumerate(disk.holes) if any(inside(mh.loop.points, m) for m in mounts)}
    for k, group in claimed.items():
        if k in mount_claimed:      # an eyelet run into a mount hole
            for e in group:
                e.status = "merged"
                merged_pairs.append((i, disk.part, e.tendons, ("mount hole",), "mount"))
        elif len(group) == 1:
            e = group[0]
            e.measured_xz = e.hole.centre
            e.offset = float(np.hypot(*(e.hole.centre - e.design_xz)))
            e.status = "moved" if e.offset > tol else "ok"
        else:
            for e in group:
                e.status = "merged"
            for a in range(len(group)):
                for b in range(a + 1, len(group)):
                    merged_pairs.append((i, disk.part, group[a].tendons, group[b].tendons, "eyelet"))
    for e in here:
        if e.status != "missing":
            continue
        # not inside any hole: the nearest free hole close by is this eyelet, moved
        free = [(float(np.hypot(*(mh.centre - e.design_xz))), k) for k, mh in enumerate(disk.holes)
                if k not in claimed and k not in mount_claimed]
        if free:
            d, k = min(free)
            if d <= NEAR_FACTOR * max(e.design_diameter, 1.0):
                e.hole, e.measured_xz, e.offset, e.status = disk.holes[k], disk.holes[k].centre, d, "moved"
                claimed[k] = [e]
    merged_pairs += [(i, disk.part, e.tendons, ("backbone slot",), "slot") for e in here if e.status == "into_slot"]
    return [mh for k, mh in enumerate(disk.holes) if k not in claimed and k not in mount_claimed]


def _read_from_strip(eyelets: list[Eyelet], ys: np.ndarray, backbone_holes: list[Loop] | None,
                     tendon_names: list[str]) -> dict[str, list[int]]:
    """Eyelets inside the slot: x from the strip's hole at that station, z as designed (the strip
    plane). Returns tendon -> the stations read this way."""
    via_backbone: dict[str, list[int]] = {k: [] for k in tendon_names}
    for e in eyelets:
        if e.status != "in_slot" or not backbone_holes:
            continue
        y = ys[e.station]
        best = min(backbone_holes, key=lambda lp: np.hypot(lp.centroid[0] - e.design_xz[0], lp.centroid[1] - y))
        d = float(np.hypot(best.centroid[0] - e.design_xz[0], best.centroid[1] - y))
        if d <= NEAR_FACTOR * max(e.design_diameter, 1.0):
            e.measured_xz = np.array([best.centroid[0], e.design_xz[1]])
            e.offset = d
            for t in e.tendons:
                via_backbone[t].append(e.station)
    return via_backbone


def _positions(eyelets: list[Eyelet], report: dict) -> tuple[dict[str, np.ndarray], dict[str, list[int]]]:
    """Every tendon's (N, 2) measured positions, design intent where none was measured, and
    which stations those are."""
    n = len(report["stations_mm"])
    positions = {t["name"]: np.full((n, 2), np.nan) for t in report["tendons"]}
    for e in eyelets:
        if e.measured_xz is None:
            continue
        for t in e.tendons:
            positions[t][e.station] = e.measured_xz
    unmeasured = {}
    for t in report["tendons"]:
        pos = positions[t["name"]]
        miss = np.isnan(pos[:, 0])
        unmeasured[t["name"]] = [int(j) for j in np.flatnonzero(miss)]
        pos[miss] = np.asarray(t["eyelets_xz_mm"], dtype=float)[miss]
    return positions, unmeasured


def joined_holes(report: dict) -> set[tuple[int, tuple[str, ...]]]:
    """(station, tendons) of each opening the plan made around eyelets whose holes ran into each
    other (its "overlap" merges): one hole, but not shared by design."""
    return {(m["station"], tuple(m["tendons"])) for m in report.get("merges", []) if m["kind"] == "overlap"}


def _unexpected(disk: DiskSections, mh: MeasuredHole) -> Check:
    x, z = mh.centre
    return Check("eyelet.unexpected", "warning", False,
                 f"{disk.part}: a hole at x={num(x)}, z={num(z)} mm (Ø{mh.diameter:.2f}) "
                 f"matches no eyelet or mount hole of the design",
                 float(mh.diameter), None, {"part": disk.part, "station": disk.station, "x": float(x), "z": float(z)},
                 fix=f"if {disk.part}'s file was edited since the build, rebuild; else {REBUILD}")


def _footprint(rd: dict, hole: dict) -> float:
    """The radius a designed hole takes on the disk's faces: its own, its chamfer and the drift of a
    slanted axis over half the disk's thickness."""
    ax, ay, az = hole["axis"]
    drift = rd["thickness_mm"] / 2 * math.hypot(ax, az) / max(abs(ay), 1e-9)
    return hole["diameter_mm"] / 2 + rd.get("edge_mm", 0.0) + drift


def _crowded(rd: dict, tendons) -> bool:
    """Whether the design's own hole for ``tendons`` reaches another designed eyelet of the disk
    (their footprints on the faces overlap): two tendons routed too close, not a fault of the part."""
    mine = [h for h in rd["holes"] if tuple(h["tendons"]) == tuple(tendons)]
    return any(math.hypot(h["x"] - m["x"], h["z"] - m["z"]) < _footprint(rd, h) + _footprint(rd, m)
               for m in mine for h in rd["holes"] if h is not m)


def _reaches_slot(rd: dict, tendons) -> bool:
    """Whether the design's own hole for ``tendons`` (its footprint on the faces: its circle, its
    chamfer and a slanted axis's drift, :func:`_footprint`) reaches the slot."""
    w, h = rd["slot_mm"]
    for hole in rd["holes"]:
        if tuple(hole["tendons"]) == tuple(tendons):
            r = _footprint(rd, hole)
            dx, dz = max(abs(hole["x"]) - w / 2, 0.0), max(abs(hole["z"]) - h / 2, 0.0)
            return math.hypot(dx, dz) < r
    return False


def _position_checks(report: dict, eyelets: list[Eyelet], tol: float) -> list[Check]:
    """One check per disk: every eyelet found, none further than ``tol`` from design intent."""
    out = []
    joined = joined_holes(report)
    for rd in report["disks"]:
        i = rd["index"]
        mine = [e for e in eyelets if e.station == i and e.status != "in_slot"]
        part = mine[0].part if mine else f"disk_{i:02d}"
        bad, overlaps = [], []
        worst = 0.0
        for e in mine:
            name = "+".join(e.tendons)
            x, z = e.design_xz
            if (i, e.tendons) in joined:
                overlaps.append(f"{' and '.join(e.tendons)} share one opening at x={num(x)}, z={num(z)} "
                                f"(Ø{e.design_diameter:.2f}): their routings put their holes into each other")
            if e.status == "merged" and _crowded(rd, e.tendons):     # (overlapping mid-plane circles are crowded too)
                overlaps.append(f"{name} at x={num(x)}, z={num(z)} runs into another eyelet")
            elif e.status == "into_slot" and _reaches_slot(rd, e.tendons):
                overlaps.append(f"{name} at x={num(x)}, z={num(z)} opens into the backbone slot")
            elif e.status == "ok":
                worst = max(worst, e.offset)
            elif e.status == "moved":
                worst = max(worst, e.offset)
                mx, mz = e.measured_xz
                bad.append(f"{name} eyelet is at x={num(mx)}, z={num(mz)}, {e.offset:.3f} mm from its design "
                           f"position x={num(x)}, z={num(z)}")
            elif e.status == "merged":
                worst = float("inf")
                bad.append(f"{name} eyelet at x={num(x)}, z={num(z)} runs into another hole and cannot be located")
            elif e.status == "into_slot":
                worst = float("inf")
                bad.append(f"{name} eyelet at x={num(x)}, z={num(z)} opens into the backbone slot")
            else:
                worst = float("inf")
                bad.append(f"{name} eyelet at x={num(x)}, z={num(z)} is missing")
        where = {"part": part, "station": i}
        if overlaps:
            # the design itself puts these eyelets into one opening (the plan's "overlap" merges)
            out.append(Check("eyelet.overlap", "error", False,
                             f"{part}: the routing puts eyelets where their holes open into another hole or the "
                             f"slot, so they cannot hold their tendons apart: {'; '.join(overlaps)}; move these "
                             f"tendons (tendons[].routing) at station {i}", None, None, where,
                             fix=f"route these tendons apart at station {i} (tendons[].routing), so each eyelet keeps a "
                                 f"process.min_wall to the next hole and the slot, or into one eyelet they share"))
        if bad:
            out.append(Check("eyelet.position", "error", False, f"{part}: " + "; ".join(bad),
                             None if not np.isfinite(worst) else worst, tol, where, fix=REBUILD))
        else:
            out.append(Check("eyelet.position", "error", True,
                             f"{part}: {len(mine)} eyelet(s) found within {tol:g} mm of design intent "
                             f"(largest offset {worst * 1000:.1f} µm)", worst, tol, where))
    return out


# ---------------------------------------------------------------- on the plan alone

def overlap_screen(plan) -> list[Screen]:
    """``eyelet.overlap`` foreseen on the plan: tendons whose holes run into one opening on the tip
    disk, its eyelets turned toward the drums (the plan's "overlap" merges there)."""
    tip = plan.disks[-1]
    hit = [m for m in plan.merges if m.kind == "overlap" and m.station == tip.index]
    if not hit:
        return []
    return [Screen("eyelet.overlap", "tendons routed into each other share one opening on the tip disk "
                                     "(its eyelets turned toward the drums): "
                   + "; ".join(" and ".join(m.tendons) for m in hit))]
