"""Eyelets found in the exported disks, matched to the tendons, and tendon lengths from them.

Every disk STL is cut at its mid-plane and at two planes a little above and below it; the
closed loops of each cut are the outline, the backbone slot (the loop around the disk
centre) and the holes. A hole's centre is the centroid of its mid-plane loop, its axis the
line through the centroids of the two off-centre cuts, and its diameter (perpendicular to
that axis) follows from the area of the mid-plane loop, an ellipse of area πD²/(4 cos θ).

Eyelets that lie inside the slot (recorded backbone crossings) open into the slot loop and
cannot be seen in the disk; their x is read from the matching hole of the backbone STL.

Lengths are eq. (1)-(2) (:mod:`hwgen.kinematics`) applied to the measured positions.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import kinematics as kin
from .base import Check
from .measure import Loop, chain_loops, load_mesh, section_loops

OFF_PLANE_FRACTION = 1 / 8   # the axis cuts sit this fraction of the thickness either side of the mid-plane
NEAR_FACTOR = 3.0            # an unmatched hole within this many design diameters is "moved", not "missing"


# ---------------------------------------------------------------- plane geometry helpers

def num(v: float, digits: int = 3) -> str:
    """A coordinate for a message: fixed decimals, never "-0.000"."""
    t = f"{v:.{digits}f}"
    return t[1:] if t.startswith("-") and float(t) == 0 else t


def inside(poly: np.ndarray, pt) -> bool:
    """Point in polygon (even-odd rule) for a closed (n, 2) polyline."""
    x, y = float(pt[0]), float(pt[1])
    px, py = poly[:, 0], poly[:, 1]
    qx, qy = np.roll(px, -1), np.roll(py, -1)
    crosses = (py > y) != (qy > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = px + (y - py) * (qx - px) / (qy - py)
    return bool(np.count_nonzero(crosses & (x < xi)) % 2)


def _point_segment_distance(pts: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) distance from each point to the nearest of the segments a[i]-b[i]."""
    ab = b - a
    ll = np.einsum("ij,ij->i", ab, ab)
    ll = np.where(ll == 0, 1.0, ll)
    ap = pts[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("nmj,mj->nm", ap, ab) / ll, 0.0, 1.0)
    d = ap - t[..., None] * ab[None]
    return np.sqrt(np.einsum("nmj,nmj->nm", d, d)).min(axis=1)


def points_to_polyline(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance from each point (n, 2) to a closed polyline (m, 2): (n,)."""
    return _point_segment_distance(pts, poly, np.roll(poly, -1, axis=0))


def _one_side(pts: np.ndarray, poly: np.ndarray, bound: float) -> float:
    """Closest distance from the vertices ``pts`` to the closed polyline ``poly``, knowing it is
    at most ``bound``: only points and segments within reach of each other are compared."""
    lo, hi = poly.min(axis=0) - bound, poly.max(axis=0) + bound
    P = pts[np.all((pts >= lo) & (pts <= hi), axis=1)]
    if len(P) == 0:
        return float("inf")
    a, b = poly, np.roll(poly, -1, axis=0)
    reach = bound + float(np.sqrt(((b - a) ** 2).sum(axis=1)).max())
    plo, phi = P.min(axis=0) - reach, P.max(axis=0) + reach
    keep = np.all((a >= plo) & (a <= phi), axis=1)
    if not keep.any():
        return float("inf")
    return float(_point_segment_distance(P, a[keep], b[keep]).min())


def loop_gap(a: np.ndarray, b: np.ndarray) -> float:
    """Closest distance between two closed polylines (material between two holes' edges).

    Exact: the closest pair of two polylines that do not cross always has a vertex of one of
    them at one end, so both vertex sets are measured against the other polyline. A pair of
    vertices gives an upper bound first, which prunes everything out of reach.
    """
    k = int(np.argmin(((a - b.mean(axis=0)) ** 2).sum(axis=1)))
    j = int(np.argmin(((b - a[k]) ** 2).sum(axis=1)))
    bound = float(np.hypot(*(a[k] - b[j])))
    return min(bound, _one_side(a, b, bound), _one_side(b, a, bound))


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
    thickness: float
    sections: list[tuple[float, Loop, list[Loop]]]   # (robot y, outline, inner loops): mid first
    slot: Loop | None
    holes: list[MeasuredHole]

    @property
    def outline(self) -> Loop:
        return self.sections[0][1]


def _robot_y(placement: np.ndarray, z_file: float) -> float:
    return float((placement @ [0.0, 0.0, z_file, 1.0])[1])


def measure_disk(stl: Path, placement, part: str, station: int, mesh=None) -> DiskSections:
    """Cut one disk file (or its already loaded ``mesh``) and find its outline, slot and holes."""
    mesh = load_mesh(stl) if mesh is None else mesh
    P = np.asarray(placement, dtype=float)
    zmin, zmax = (float(v) for v in mesh.bounds[:, 2])
    T = zmax - zmin
    mid = (zmin + zmax) / 2
    h = T * OFF_PLANE_FRACTION
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
    loops = []
    for pts in chain_loops(robot[:, :, [0, 1]]):
        x, y = pts[:, 0], pts[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        cr = x * yn - xn * y
        a = cr.sum() / 2
        c = (float(((x + xn) * cr).sum() / (6 * a)), float(((y + yn) * cr).sum() / (6 * a)))
        loops.append(Loop(pts, abs(float(a)), c))
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
    """Match measured holes to the design report's eyelets; checks for position and presence."""
    checks: list[Check] = []
    by_station = {d.station: d for d in disks}
    tendon_names = [t["name"] for t in report["tendons"]]
    n = len(report["stations_mm"])
    design_pos = {t["name"]: np.asarray(t["eyelets_xz_mm"], dtype=float) for t in report["tendons"]}
    positions = {k: np.full((n, 2), np.nan) for k in tendon_names}
    eyelets: list[Eyelet] = []
    extra: list[tuple[DiskSections, MeasuredHole]] = []
    merged_pairs = []
    ys = np.array(report["stations_mm"], dtype=float)

    for rd in report["disks"]:
        i = rd["index"]
        disk = by_station.get(i)
        here = [Eyelet(i, disk.part if disk else f"disk {i}", tuple(h["tendons"]), np.array([h["x"], h["z"]]),
                       h["diameter_mm"], h["in_slot"]) for h in rd["holes"]]
        eyelets.extend(here)
        if disk is None:
            continue
        ys[i] = disk.y_mid
        mounts = [np.array(m[:2]) for m in rd.get("mount_holes", [])]
        claimed: dict[int, list[Eyelet]] = {}
        mount_claimed: set[int] = set()
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
        for k, mh in enumerate(disk.holes):
            if any(inside(mh.loop.points, m) for m in mounts):
                mount_claimed.add(k)
        for k, group in claimed.items():
            if k in mount_claimed:      # an eyelet run into a mount hole
                for e in group:
                    e.status = "merged"
                    merged_pairs.append((i, disk.part, e.tendons, ("mount hole",), "mount"))
            elif len(group) == 1:
                e = group[0]
                e.status = "ok"
                e.measured_xz = e.hole.centre
                e.offset = float(np.hypot(*(e.hole.centre - e.design_xz)))
                if e.offset > tol:
                    e.status = "moved"
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
        for k, mh in enumerate(disk.holes):
            if k not in claimed and k not in mount_claimed:
                extra.append((disk, mh))
        for e in here:
            if e.status == "into_slot":
                merged_pairs.append((i, disk.part, e.tendons, ("backbone slot",), "slot"))

    # eyelets inside the slot: x from the strip's hole at that station, z as designed (the strip plane)
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

    for e in eyelets:
        if e.measured_xz is None:
            continue
        for t in e.tendons:
            positions[t][e.station] = e.measured_xz
    unmeasured = {}
    for t in tendon_names:
        miss = np.isnan(positions[t][:, 0])
        unmeasured[t] = [int(j) for j in np.flatnonzero(miss)]
        positions[t][miss] = design_pos[t][miss]

    checks += _position_checks(report, eyelets, tol)
    for disk, mh in extra:
        x, z = mh.centre
        checks.append(Check("eyelet.unexpected", "warning", False,
                            f"{disk.part}: a hole at x={num(x)}, z={num(z)} mm (Ø{mh.diameter:.2f}) "
                            f"matches no eyelet or mount hole of the design",
                            float(mh.diameter), None, {"part": disk.part, "station": disk.station,
                                                       "x": float(x), "z": float(z)}))
    return EyeletMap(ys, eyelets, positions, unmeasured, via_backbone, disks, extra, merged_pairs), checks


def _position_checks(report: dict, eyelets: list[Eyelet], tol: float) -> list[Check]:
    """One check per disk: every eyelet found, none further than ``tol`` from design intent."""
    out = []
    for rd in report["disks"]:
        i = rd["index"]
        mine = [e for e in eyelets if e.station == i and e.status != "in_slot"]
        part = mine[0].part if mine else f"disk_{i:02d}"
        bad = []
        worst = 0.0
        for e in mine:
            name = "+".join(e.tendons)
            x, z = e.design_xz
            if e.status == "ok":
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
        if bad:
            out.append(Check("eyelet.position", "error", False, f"{part}: " + "; ".join(bad),
                             None if not np.isfinite(worst) else worst, tol, where))
        else:
            out.append(Check("eyelet.position", "error", True,
                             f"{part}: {len(mine)} eyelet(s) found within {tol:g} mm of design intent "
                             f"(largest offset {worst * 1000:.1f} µm)", worst, tol, where))
    return out


# ---------------------------------------------------------------- lengths

@dataclass
class TendonLengths:
    name: str
    channel: str
    angles_deg: np.ndarray
    lengths: np.ndarray               # (K,) at each angle
    rest: float
    budget: float | None

    @property
    def delta(self) -> np.ndarray:
        return self.lengths - self.rest

    @property
    def max_abs_delta(self) -> float:
        return float(np.abs(self.delta).max())

    @property
    def passed(self) -> bool:
        return self.budget is None or self.max_abs_delta <= self.budget


def sweep_angles(max_deg: float, step_deg: float) -> np.ndarray:
    """-max .. +max in steps of ``step``, always including 0 and both ends."""
    k = int(np.floor(max_deg / step_deg + 1e-9))
    half = np.arange(1, k + 1) * step_deg
    if half.size == 0 or half[-1] < max_deg - 1e-9:
        half = np.append(half, max_deg)
    return np.concatenate([-half[::-1], [0.0], half])


def tendon_lengths(emap: EyeletMap, report: dict, angles: np.ndarray, length: float) -> list[TendonLengths]:
    kappa = kin.kappas_for_angles(angles, length)
    i0 = int(np.flatnonzero(angles == 0)[0])
    out = []
    for t in report["tendons"]:
        L = kin.tendon_lengths(emap.stations_y, emap.positions[t["name"]], kappa)
        out.append(TendonLengths(t["name"], t["channel"], angles, L, float(L[i0]), t["budget_mm"]))
    return out


def pair_take_up(tls: list[TendonLengths], channel: str) -> dict | None:
    """Slack an antagonistic pair on one channel develops: -(ΔL1 + ΔL2), worst over the sweep."""
    pair = [t for t in tls if t.channel == channel]
    if len(pair) != 2:
        return None
    s = pair[0].delta + pair[1].delta
    k = int(np.argmax(np.abs(s)))
    return {"channel": channel, "tendons": [pair[0].name, pair[1].name], "take_up_mm": float(-s[k]),
            "at_angle_deg": float(pair[0].angles_deg[k]),
            "sum_delta_at_max_mm": float(s[-1]), "sum_delta_at_min_mm": float(s[0])}


def length_checks(tls: list[TendonLengths], emap: EyeletMap, deviations: dict[str, list],
                  function_deltas: dict[str, float]) -> list[Check]:
    """Budget per tendon; a failing tendon whose table departs from its named function says so.

    ``deviations``: tendon -> [(station, distance mm)] where its table departs from the eq. (3)
    function it names; ``function_deltas``: tendon -> max |ΔL| if its eyelets sampled that function.
    """
    out = []
    for t in tls:
        k = int(np.argmax(np.abs(t.delta)))
        ang = float(t.angles_deg[k])
        where = {"tendon": t.name, "channel": t.channel, "angle_deg": ang}
        src = ""
        if emap.unmeasured.get(t.name):
            src = f" (stations {emap.unmeasured[t.name]} not found in the geometry: design positions used)"
        if t.budget is None:
            out.append(Check("tendon.length", "info", True,
                             f"{t.name} (actuating, channel {t.channel}): rest length {t.rest:.3f} mm, changes by "
                             f"{t.delta[-1]:+.3f} mm at {t.angles_deg[-1]:+g}° and {t.delta[0]:+.3f} mm at "
                             f"{t.angles_deg[0]:+g}°{src}", t.max_abs_delta, None, where))
            continue
        verdict = "exceeds its coupling budget: its" if not t.passed else ":"
        msg = (f"{t.name} (channel {t.channel}) {verdict} length changes by up to {t.max_abs_delta:.4f} mm "
               f"(at {ang:+g}°) over ±{t.angles_deg[-1]:g}°, budget {t.budget:g} mm{src}").replace(") :", "):")
        if not t.passed:
            devs = [(j, d) for j, d in deviations.get(t.name, []) if d > 1e-3]
            if devs:
                big = max(d for _, d in devs)
                at = [j for j, d in devs if d > 0.5 * big]
                msg += (f". Its eyelet table does not sample the eq. (3) function it names: it departs by up to "
                        f"{big:.2f} mm at stations {at}")
                if t.name in function_deltas:
                    fd = function_deltas[t.name]
                    msg += (f"; eyelets on the named function would change by {fd:.4f} mm, "
                            f"{'within' if fd <= t.budget else 'also over'} the budget")
        out.append(Check("tendon.length", "error", t.passed, msg, t.max_abs_delta, t.budget, where))
    return out
