"""How each disk sits on the strip, measured from its STL: the tilt and play its slot allows, and
whether its hub keeps clear of every tendon.

Tilt and play. The disk is cut by planes across the strip (x = const, 5 mm apart over the
strip's height) and along its mid-plane (z = const). On each cut, the material nearest the
strip's plane above and below it (or beside its edges) is found line by line along the backbone;
the strip, a flat plate of the measured thickness and height, may take any position and angle
that keeps it between the two. The largest angle about x (the disk pitching along the backbone,
which moves eyelets along y by r·tan θ), about z (yaw: the edges against the slot's ends) and
about y (roll: the faces over the strip's height) and the free travel in x and z at zero angle
are what the slot allows; the length over which both faces of the slot come within
ENGAGED_MM of the strip is its engagement. These numbers feed the as-built tolerance study.

Hub and tendons. Each disk is cut by planes across the backbone beyond its plate, where only its
hub is (its own eyelet bores lie inside the plate). Every tendon's line through that disk,
from the measured eyelets over the bending sweep, meets each plane at a point; its distance to
the hub's material, projected across the line, must be at least the tendon's radius.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import kinematics as kin
from ..model.fixing import HUB_GAP_MM
from .base import Check, Fix, fix_text
from .eyelets import DiskSections, EyeletMap
from .polygons import inside_many, points_to_polyline, section_moments
from .sections import chain_loops, section_robot

X_STEP_MM = 5.0             # cuts across the strip for the pitch and roll (the slot and hub are prisms along x)
Y_STEP_MM = 0.02            # lines along the backbone on each cut
EDGE_MM = 0.05              # the outermost cuts this far inside the strip's edges
ENGAGED_MM = 0.25           # the slot engages the strip where each face is within this of it
MAX_ANGLE_DEG = 30.0        # tilts are sought up to this
ANGLE_TOL_DEG = 1e-4        # and found to this
HUB_PLANE_STEP_MM = 0.5     # planes across the backbone beyond a disk's plate
HUB_SWEEP_STEP_DEG = 5.0    # the bending sweep, coarsened for the hub's clearance
FACE_OFFSET_MM = 0.05       # the first plane this far off the plate's face


@dataclass
class SlotFit:
    """What the slot of one disk lets the strip do (angles in degrees, lengths in mm)."""

    part: str
    station: int
    y_mid: float
    tilt_x: tuple[float, float]      # (most negative, most positive) pitch
    tilt_z: tuple[float, float]      # yaw
    tilt_y: tuple[float, float]      # roll
    play_x: float                    # free travel across the strip's height at zero angle
    play_z: float                    # through its thickness
    centre_x: float                  # where the slot centres the strip
    centre_z: float
    engaged: tuple[float, float]     # robot y range over which the slot holds the strip
    slab: tuple[float, float]        # robot y range of the disk's plate
    hub_i: float | None = None       # second moment of the hub's section about the strip's plane, mm⁴

    @property
    def engagement(self) -> float:
        return self.engaged[1] - self.engaged[0]

    def to_json(self) -> dict:
        return {"part": self.part, "station": self.station, "y_mid_mm": self.y_mid,
                "tilt_x_deg": list(self.tilt_x), "tilt_z_deg": list(self.tilt_z), "tilt_y_deg": list(self.tilt_y),
                "play_x_mm": self.play_x, "play_z_mm": self.play_z,
                "centre_x_mm": self.centre_x, "centre_z_mm": self.centre_z,
                "engagement_mm": self.engagement, "engaged_y_mm": list(self.engaged),
                "plate_y_mm": list(self.slab), "hub_second_moment_mm4": self.hub_i}


def fit_angles(u: np.ndarray, lo: np.ndarray, hi: np.ndarray, width: float) -> tuple[float, float, float, float]:
    """A plate of this width between the bounds lo(u) and hi(u) (±inf: none there): its largest
    negative and positive angle (deg), its free travel at zero angle and the centre of that travel.

    At angle θ the plate covers c + u tan θ ± width / (2 cos θ); it fits if some c keeps it
    between the bounds everywhere. The fitting (c, tan θ) form a convex set, so each side's limit
    is found by bisection from θ = 0.
    """
    def room(theta: float) -> float:
        k = math.tan(theta)
        a = np.max(lo - u * k, initial=-np.inf)
        b = np.min(hi - u * k, initial=np.inf)
        return b - a - width / math.cos(theta)

    r0 = room(0.0)
    a0, b0 = np.max(lo, initial=-np.inf), np.min(hi, initial=np.inf)
    centre = float((a0 + b0) / 2) if np.isfinite(a0) and np.isfinite(b0) else 0.0
    if r0 < 0:
        return 0.0, 0.0, float(r0), centre
    limits = []
    for sign in (-1, 1):
        lo_t, hi_t = 0.0, math.radians(MAX_ANGLE_DEG)
        if room(sign * hi_t) >= 0:
            limits.append(sign * MAX_ANGLE_DEG)
            continue
        while math.degrees(hi_t - lo_t) > ANGLE_TOL_DEG:
            mid = (lo_t + hi_t) / 2
            lo_t, hi_t = (mid, hi_t) if room(sign * mid) >= 0 else (lo_t, mid)
        limits.append(sign * math.degrees(lo_t))
    return limits[0], limits[1], float(r0), centre


def _nearest(segs: np.ndarray, along: int, across: int, grid: np.ndarray, centre: float):
    """On lines {along = g} of a cut (``grid`` ascending): the nearest material boundary above and
    below ``centre`` in the ``across`` coordinate, (len(grid),) each (±inf where there is none).
    Only the lines a segment spans (min <= g < max of its ends) are met, found by bisection."""
    if len(segs) == 0:
        return np.full(len(grid), np.inf), np.full(len(grid), -np.inf)
    a0, a1 = segs[:, 0, along], segs[:, 1, along]
    c0, c1 = segs[:, 0, across], segs[:, 1, across]
    first = np.searchsorted(grid, np.minimum(a0, a1), side="left")
    count = np.maximum(np.searchsorted(grid, np.maximum(a0, a1), side="left") - first, 0)
    i = np.repeat(np.arange(len(segs)), count)                          # (segment, line) pairs
    j = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count) + np.repeat(first, count)
    c = c0[i] + (grid[j] - a0[i]) / (a1[i] - a0[i]) * (c1[i] - c0[i])
    above = np.full(len(grid), np.inf)
    below = np.full(len(grid), -np.inf)
    up, down = c > centre, c < centre
    np.minimum.at(above, j[up], c[up])
    np.maximum.at(below, j[down], c[down])
    return above, below


def measure_fit(disk: DiskSections, mesh, placement, strip_h: float, strip_t: float) -> SlotFit:
    """The tilt and play one disk's slot allows the strip, from its mesh."""
    P = np.asarray(placement, dtype=float)
    corners = np.array([[x, y, z] for x in mesh.bounds[:, 0] for y in mesh.bounds[:, 1] for z in mesh.bounds[:, 2]])
    ys = corners @ P[:3, :3].T[:, 1] + P[1, 3]
    grid = np.arange(ys.min() - Y_STEP_MM, ys.max() + Y_STEP_MM, Y_STEP_MM)
    # across the whole height, its edges included (less EDGE_MM): the roll is the faces' over the full width
    xs = np.linspace(-strip_h / 2 + EDGE_MM, strip_h / 2 - EDGE_MM, max(3, math.ceil(strip_h / X_STEP_MM) + 1))
    hi = np.full(len(grid), np.inf)
    lo = np.full(len(grid), -np.inf)
    hi_x, lo_x = np.full(len(xs), np.inf), np.full(len(xs), -np.inf)
    for k, x in enumerate(xs):
        segs = section_robot(mesh, P, 0, float(x))
        a, b = _nearest(segs, 1, 2, grid, 0.0)
        hi, lo = np.minimum(hi, a), np.maximum(lo, b)
        hi_x[k], lo_x[k] = a.min(), b.max()
    right = np.full(len(grid), np.inf)
    left = np.full(len(grid), -np.inf)
    for z in (-strip_t / 4, 0.0, strip_t / 4):
        segs = section_robot(mesh, P, 2, z)
        a, b = _nearest(segs, 1, 0, grid, 0.0)
        right, left = np.minimum(right, a), np.maximum(left, b)
    u = grid - disk.y_mid
    tx = fit_angles(u, lo, hi, strip_t)
    tz = fit_angles(u, left, right, strip_h)
    ty = fit_angles(xs, lo_x, hi_x, strip_t)
    held = np.flatnonzero(hi - lo <= strip_t + 2 * ENGAGED_MM)
    engaged = (float(grid[held[0]]), float(grid[held[-1]] + Y_STEP_MM)) if len(held) else (disk.y_mid, disk.y_mid)
    slab = (disk.y_mid - disk.thickness / 2, disk.y_mid + disk.thickness / 2)
    fit = SlotFit(part=disk.part, station=disk.station, y_mid=disk.y_mid, tilt_x=tx[:2], tilt_z=tz[:2],
                  tilt_y=ty[:2], play_x=tz[2], play_z=tx[2], centre_x=tz[3], centre_z=tx[3], engaged=engaged,
                  slab=slab)
    beyond = [(max(engaged[0], slab[1]), engaged[1]), (engaged[0], min(engaged[1], slab[0]))]
    a, b = max(beyond, key=lambda ab: ab[1] - ab[0])
    if b - a > 2 * FACE_OFFSET_MM:
        segs = section_robot(mesh, P, 1, (a + b) / 2)
        loops = chain_loops(segs[:, :, [0, 2]]) if len(segs) else []
        fit.hub_i = section_moments(loops)["i_v0"] if loops else 0.0
    return fit


def tilt_checks(fits: list[SlotFit], max_tilt_deg: float, radius: dict[int, float], clearance: float = 0.0
                ) -> list[Check]:
    """One check per disk: the pitch its slot allows against the limit, naming the other freedoms
    and how far it moves the disk's outermost eyelet (at ``radius[station]``) along the backbone;
    ``clearance``: the design's slot clearance a side, which a tighter slot's fix starts from."""
    out = []
    # the two settings a disk's fix changes are the design's, one for every disk: each failing disk
    # is offered the value that holds them all (the tightest slot, the largest allowed pitch), so a
    # fix a user follows on one disk's advice does not leave the next disk failing
    failing = [(f, max(abs(v) for v in f.tilt_x)) for f in fits if f.play_z >= 0]
    failing = [(f, t) for f, t in failing if t > max_tilt_deg + ANGLE_TOL_DEG]
    shared = _shared_tilt_fix(failing, max_tilt_deg, clearance)
    for f in fits:
        where = {"part": f.part, "station": f.station}
        if f.play_z < 0:
            out.append(Check("disk.tilt", "error", False, f"{f.part}: the strip does not fit its slot "
                                                          f"({-f.play_z:.3f} mm too tight)", f.play_z, 0.0, where,
                             fix=f"a wider slot: disks.slot_clearance up by at least {-f.play_z / 2:.3f} mm a side"))
            continue
        tilt = max(abs(v) for v in f.tilt_x)
        ok = tilt <= max_tilt_deg + ANGLE_TOL_DEG        # the limit, to what the measurement resolves
        r = radius.get(f.station, 0.0)
        digits = 3                                       # as many as show a failing tilt above its limit
        while not ok and round(tilt, digits) <= max_tilt_deg and digits < 6:
            digits += 1
        over = "" if ok else (
            f", more than the {max_tilt_deg:g}° allowed: holding it needs "
            f"{f.play_z / math.tan(math.radians(max_tilt_deg)):.1f} mm of engagement (a hub stops {HUB_GAP_MM:g} mm "
            f"short of the next disk); change disks.spacing, disks.slot_clearance or disks.hub.max_tilt_deg")
        msg = (f"{f.part}: the slot holds the strip over {f.engagement:.2f} mm with {f.play_z:.3f} mm of play "
               f"through its thickness: the disk can pitch ±{tilt:.{digits}f}°{over} (an eyelet at r = {r:g} mm moves "
               f"{r * math.tan(math.radians(tilt)):.3f} mm along the backbone), yaw ±"
               f"{max(abs(v) for v in f.tilt_z):.3f}°, roll ±{max(abs(v) for v in f.tilt_y):.3f}°, slide "
               f"{f.play_x:.3f} mm across the strip")
        out.append(Check("disk.tilt", "error", ok, msg, tilt, max_tilt_deg, where,
                         fix="" if ok else _tilt_fix(f, tilt, max_tilt_deg, clearance, shared),
                         fixes=() if ok else _tilt_fixes(f, tilt, max_tilt_deg, clearance, shared)))
    return out


def _own_clearance(f: SlotFit, limit: float, clearance: float) -> float:
    """The slot clearance a side under which this disk's pitch over its engagement holds the limit."""
    tan = math.tan(math.radians(limit))
    return math.floor((clearance - (f.play_z - 0.98 * f.engagement * tan) / 2) * 1000) / 1000


def _shared_tilt_fix(failing: list[tuple[SlotFit, float]], limit: float, clearance: float
                     ) -> tuple[float | None, int, float, int]:
    """(the clearance that holds every failing disk that a clearance can hold, or None; how many
    disks it holds; the pitch to allow that covers them all; how many disks fail)."""
    own = [c for c in (_own_clearance(f, limit, clearance) for f, _ in failing) if c >= 0]
    allow = max((math.ceil(t * 100) / 100 for _, t in failing), default=limit)
    return (min(own) if own else None), len(own), allow, len(failing)


def _tilt_fix(f: SlotFit, tilt: float, limit: float, clearance: float, shared) -> str:
    """How far each of the three settings that hold a disk's pitch must move for this disk: the
    clearance and the allowed tilt tried (:func:`_tilt_fixes`), the engagement in words."""
    need = f.play_z / math.tan(math.radians(limit))
    return (f"{fix_text(_tilt_fixes(f, tilt, limit, clearance, shared))}. Also (not tried): {need:.1f} mm of "
            f"engagement, for which the hubs need more room between the disks (a larger disks.spacing, or fewer "
            f"disks: disks.count)")


def _tilt_fixes(f: SlotFit, tilt: float, limit: float, clearance: float, shared) -> tuple[Fix, ...]:
    """A tighter slot, its pitch worked out again from the measured play less the clearance taken
    off both sides, over the measured engagement (the slot's own model of the pitch, not a new
    build); and (a relaxation) the tilt it has, allowed. Both at the values ``shared`` holds for
    every failing disk (:func:`_shared_tilt_fix`)."""
    out = []
    new, held, allow, count = shared
    every = (f" (the slot that holds all {held} disks that pitch too far)" if held == count > 1 else
             f" (the slot that holds the {held} of the {count} disks that pitch too far a slot can hold)" if held > 1
             else "")
    if new is not None and _own_clearance(f, limit, clearance) >= 0:
        play = f.play_z - 2 * (clearance - new)
        got = math.degrees(math.atan2(max(play, 0.0), f.engagement))
        out.append(Fix({"disks.slot_clearance": new}, {"measured": got, "passed": got <= limit + ANGLE_TOL_DEG,
                                                       "limit": limit}, (),
                       f"from {clearance:g} mm a side: {max(play, 0.0):.3f} mm of play over the {f.engagement:.2f} mm "
                       f"the slot holds the strip{every}"))
    out.append(Fix({"disks.hub.max_tilt_deg": allow}, {"measured": tilt, "passed": tilt <= allow + ANGLE_TOL_DEG,
                                                         "limit": allow}, (),
                   (f"allow the {allow:.2f}° the {count} disks pitch at most" if count > 1
                    else f"allow the {tilt:.2f}° this disk can pitch"),
                   relax=True))
    return tuple(out)


def hub_checks(emap: EyeletMap, fits: list[SlotFit], meshes: dict, placements: dict, tendon_d: float,
               angles_deg: np.ndarray, length: float) -> list[Check]:
    """Each disk's hub against every tendon's line through that disk over the bending sweep."""
    steps = max(1, int(round((angles_deg[-1] - angles_deg[0]) / HUB_SWEEP_STEP_DEG)))
    angles = np.linspace(angles_deg[0], angles_deg[-1], steps + 1)   # the sweep's ends and every few degrees
    kappa = kin.kappas_for_angles(angles, length)
    dirs = {n: kin.segment_directions_local(emap.stations_y, xz, kappa) for n, xz in emap.positions.items()}
    by_part = {d.part: d for d in emap.disks}
    out = []
    for f in fits:
        disk = by_part[f.part]
        mesh, P = meshes[f.part], np.asarray(placements[f.part], dtype=float)
        worst = (math.inf, None, None)
        planes = 0
        for side, (a, b) in ((1, (f.slab[1], f.engaged[1])), (-1, (f.engaged[0], f.slab[0]))):
            if b - a <= 2 * FACE_OFFSET_MM:
                continue
            ys = np.arange(a + FACE_OFFSET_MM, b - FACE_OFFSET_MM + 1e-9, HUB_PLANE_STEP_MM)
            lines = []                                   # (tendon, direction (K, 3)) leaving on this side
            for name, (into, outof) in dirs.items():
                u = outof[:, disk.station] if side > 0 else -into[:, disk.station]
                if not np.isnan(u).any():
                    lines.append((name, u))
            if not lines:
                continue
            names = [n for n, _ in lines for _ in range(len(angles))]
            U = np.vstack([u for _, u in lines])                          # (T·K, 3)
            X0 = np.vstack([np.tile(emap.positions[n][disk.station], (len(angles), 1)) for n, _ in lines])
            for y in ys:
                segs = section_robot(mesh, P, 1, float(y))
                loops = chain_loops(segs[:, :, [0, 2]]) if len(segs) else []
                if not loops:
                    continue
                planes += 1
                t = (y - disk.y_mid) / U[:, 1]
                pts = X0 + U[:, [0, 2]] * t[:, None]
                d = np.min([points_to_polyline(pts, lp) for lp in loops], axis=0)
                solid = np.sum([inside_many(lp, pts) for lp in loops], axis=0) % 2 == 1
                gap = np.where(solid, -d, d) * np.abs(U[:, 1])
                k = int(np.argmin(gap))
                if gap[k] < worst[0]:
                    worst = (float(gap[k]), names[k], float(angles[k % len(angles)]))
        where = {"part": f.part, "station": f.station}
        if planes == 0:
            out.append(Check("hub.tendon_clearance", "info", True, f"{f.part}: no hub beyond its plate", None,
                             tendon_d / 2, where))
            continue
        gap, name, ang = worst
        ok = gap >= tendon_d / 2
        if ok:
            msg = (f"{f.part}: every tendon clears the hub by at least {gap - tendon_d / 2:.3f} mm "
                   f"(closest {name} at {ang:+g}° bending), {planes} cuts across it")
        else:
            msg = (f"{f.part}: the hub is in tendon {name}'s way at {ang:+g}° bending: its line passes "
                   f"{'inside the hub' if gap < 0 else f'{gap:.3f} mm from it'}, less than the tendon's radius "
                   f"{tendon_d / 2:g} mm")
        fix = "" if ok else (
            f"route {name} at least {tendon_d / 2 - gap:.2f} mm further from the strip at station {f.station} "
            f"(tendons[].routing), or shorter hubs (disks.hub.length, disks.hub.max_tilt_deg) or a thinner hub "
            f"wall (disks.hub.wall)")
        out.append(Check("hub.tendon_clearance", "error", ok, msg, gap, tendon_d / 2,
                         {**where, "tendon": name, "angle_deg": ang}, fix=fix))
    return out
