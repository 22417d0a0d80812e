"""Worm-gear tensioner checks measured from the exported meshes (the tendons' free spans to their
spools are measured in :mod:`hwgen.checks.tendon_runs`).

From the files (and each STL's manifest placement, nothing else of the manifest):
the axes of each worm and wheel fitted to their surfaces give the centre distance and the
shaft angle; the wheel's teeth and the worm's starts are counted in sections; the worm is
turned through one thread period and the wheel by the counted ratio, for the interference
and the closest gap. On one representative pair (the channel with the most tendons: every
channel has the same gear, one tensioner section) the wheel is turned until each flank
touches, for the backlash, and the zone where the closed flank lies within ZONE_GAP_MM of
the worm gives the face width that carries load; the wheel's mid-face section gives the
tooth's Lewis form factor.

Each distinct pair is measured once. Everything above is unchanged when a worm and its wheel
are moved together by one rigid motion: the axis fits (and their RMS), the centre distance and
shaft angle, the counts, the interference volume and the closest gap over the motion, the turns
that close each flank, the loaded face and the form factor. So the channels whose worm files
and wheel files have the same bytes and whose wheels lie the same way to their worms
(:func:`relative_pose`) share one measurement, made on the first channel's files, and each
check of another channel says so and names the channel measured. A pair is measured in its
worm's file frame (the wheel placed by inv(worm placement) @ wheel placement, rounded:
:func:`relative_pose`), never where the robot has it, so that its numbers are a function, to the
last bit, of what they are remembered under (:func:`hwgen.cache.remembered`: the files and that
pose): a measurement remembered for one place equals a fresh one at another, and a report does
not depend on what the cache held. The meshing motion's solids hold float64 vertices
(:func:`solid64`); as float32 (what manifold3d's Mesh takes) their rounding at the robot's 400 mm
moved the closest gap by up to 2e-4 of itself from one channel to the next.

From the design, and each message says so: the tendon break load, the winding radius, μ,
the module, pressure and lead angles, the resin's strength, modulus and Poisson ratio. Rules
that loading enforces (self-locking by γ < atan(μ / cos α_n), no undercut) are not checked
again here: a design that breaks them is never built.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..cache import as_json, remembered
from ..cad.manifest import ManifestPart
from ..model.gearing import hertz_allowable
from .axes import Axis, axes_angle, axes_distance, fit_axis
from .base import REBUILD, Check, Fix, fix_text
from .gear_walls import bore_check, bore_wall, drive_check, thread_tip, tip_checks, tip_planes, wheel_tip
from .meshes import part_mesh, placed_mesh, to_manifold
from .surface import SurfaceDistance, sample_surface

INTERFERENCE_TOL_MM3 = 0.01   # worm ∩ wheel counts as zero below this
GAP_TOL_MM = 0.02             # STL chordal tolerance is 0.01 mm on each part
GAP_MIN_SHARE = 0.25          # the closest gap must be this share of the flank clearance the offset gives:
#                               at the generating distance the flanks touch with no measurable overlap
CENTER_TOL_MM = 0.005         # axes fitted to STL crests at 0.01 mm chord: a few µm RMS
SHAFT_ANGLE_TOL_DEG = 0.02
GAP_SEARCH_MM = 1.0           # min_gap search length between worm and wheel, beyond the centre offset
NEAR_GAP_MM = 0.2             # searched first: a gap found within it is the one the longer search finds
#                               (the closest pair of triangles is among the pairs nearer than it), far fewer pairs
SWEEP_STEPS = 6               # worm angles over one thread period for interference and gap
SENSE_ANGLES = (math.pi / 3, 2 * math.pi / 3)   # worm angles at which the wheel's turning sense is told
ZONE_GAP_MM = 0.05            # a flank point this close to the worm carries load (≈ the Hertz approach at break load)
ZONE_STEPS = 3                # worm angles over one thread period for the loaded zone and the backlash
ZONE_SPACING_MM = 0.1         # sample spacing on the wheel's flanks
ZONE_REACH_MM = 0.6           # flank faces that come this near the worm's crest cylinder are sampled
ZONE_MARGIN_MM = 0.1          # closing a flank moves its points less than this (r·δ ≈ 0.03 mm for the prototype)
CLOSE_TOL_RAD = 2e-6          # the wheel's turn to close a flank is iterated to this
RING_WIDTH_MM = 0.05          # ring in a section where teeth (or starts) are counted
POSE_DECIMALS = (12, 11)      # a wheel's pose to its worm, rounded: rotation entries to 1e-12, translation to 1e-11 mm
#                               (its float64 product carries ~1e-13 mm at the robot's 400 mm; moving the wheel by
#                               the rounding, ≤ 5e-12 mm, moves the 0.024 mm gap by < 1e-9 of itself)


def toward(wheel: ManifestPart | dict, worm: ManifestPart | dict, distance: float) -> np.ndarray:
    """The wheel's placement moved ``distance`` mm toward the worm along the common normal of
    their file Z axes (a what-if for tests: the checks never read axes from placements)."""
    wheel, worm = ManifestPart.of(wheel), ManifestPart.of(worm)
    pa, da = (wheel.placement[:3, k] for k in (3, 2))
    pb, db = (worm.placement[:3, k] for k in (3, 2))
    n = np.cross(da, db)
    n /= np.linalg.norm(n)
    if np.dot(pb - pa, n) < 0:
        n = -n
    m = wheel.placement.copy()
    m[:3, 3] += distance * n
    return m


def mesh_measure(worm_m, wheel_m, search: float = GAP_SEARCH_MM) -> tuple[float, float]:
    """(interference volume mm³, closest gap mm) of two placed solids."""
    gap = worm_m.min_gap(wheel_m, min(NEAR_GAP_MM, search))
    if gap >= min(NEAR_GAP_MM, search):
        gap = worm_m.min_gap(wheel_m, search)
    return float((worm_m ^ wheel_m).volume()), float(gap)


# ---- teeth and tooth form from sections ---------------------------------------------------
def _section(mesh, axis: Axis, at: float):
    """The part cut normal to its axis at ``at`` (along it from axis.point): a manifold3d
    CrossSection in the plane's (x, y), the axis at the origin."""
    return to_manifold(mesh, axis.frame()).slice(at)


def _outline_root(polys: list[np.ndarray]) -> tuple[float, float]:
    """(root, tip) radii of a toothed section: the outer loop's smallest and largest radius."""
    r = [np.hypot(p[:, 0], p[:, 1]) for p in polys]
    outer = max(range(len(polys)), key=lambda i: r[i].max())
    return float(r[outer].min()), float(r[outer].max())


def count_teeth(mesh, axis: Axis) -> int:
    """Teeth of a wheel, or thread starts of a worm: the pieces of its section (normal to the
    axis, midway along its crest) in a thin ring midway between root and tip."""
    import manifold3d as m3d
    cs = _section(mesh, axis, sum(axis.crest) / 2)
    root, tip = _outline_root([np.asarray(p) for p in cs.to_polygons()])
    r = (root + tip) / 2
    ring = m3d.CrossSection.circle(r + RING_WIDTH_MM / 2, 2048) - m3d.CrossSection.circle(r - RING_WIDTH_MM / 2, 2048)
    return len((cs ^ ring).decompose())


def tooth_form_factor(mesh, axis: Axis, module: float, n: int = 40) -> float:
    """Lewis Y of one wheel tooth as exported, loaded at its tip: the chordal thickness s at
    n radii of the mid-face section (root to tip), Y = min s² / (6 l m) with l the lever to
    the tip (a cantilever without stress concentration)."""
    import manifold3d as m3d
    cs = _section(mesh, axis, sum(axis.crest) / 2)
    polys = [np.asarray(p) for p in cs.to_polygons()]
    root, tip = _outline_root(polys)
    pts = np.vstack(polys)
    ref = pts[np.argmax(np.hypot(pts[:, 0], pts[:, 1]))]
    ref_ang = math.atan2(ref[1], ref[0])
    radii = np.linspace(root + 0.02, tip - 0.005, n)
    thick = []
    for rad in radii:
        ring = m3d.CrossSection.circle(rad + 0.001, 4096) - m3d.CrossSection.circle(rad - 0.001, 4096)
        best, width = math.inf, math.nan
        for piece in (cs ^ ring).decompose():
            q = np.vstack([np.asarray(p) for p in piece.to_polygons()])
            a = np.arctan2(q[:, 1], q[:, 0])
            c = math.atan2(np.sin(a).mean(), np.cos(a).mean())
            off = abs(math.remainder(c - ref_ang, 2 * math.pi))
            if off < best:
                best, width = off, float(np.ptp(np.angle(np.exp(1j * (a - c)))))
        thick.append(2 * rad * math.sin(width / 2))
    lever = tip - radii
    ok = lever > 0.05
    return float(np.min(np.asarray(thick)[ok] ** 2 / (6 * lever[ok] * module)))


# ---- the meshing motion -----------------------------------------------------------------
def solid64(mesh):
    """A trimesh mesh as a manifold3d solid with float64 vertices, where it lies: the meshing motion's
    gap and interference then do not depend on where the pair sits (float32 vertices, as
    :func:`hwgen.checks.meshes.to_manifold` makes them, move the gap by ~5e-6 mm between channels
    400 mm apart in the robot)."""
    import manifold3d as m3d
    return m3d.Manifold(m3d.Mesh64(vert_properties=np.asarray(mesh.vertices, dtype=np.float64),
                                   tri_verts=np.asarray(mesh.faces, dtype=np.uint64)))


class Meshing:
    """A worm and its wheel as placed in the files (robot mm). The worm turns by ψ about its
    fitted axis and the wheel by sense·ψ/ratio about its own; the ratio is counted from the
    meshes, the sense is the one that does not collide."""

    def __init__(self, worm, wheel, worm_axis: Axis, wheel_axis: Axis, teeth: int, starts: int):
        self.worm, self.wheel = worm, wheel
        self.worm_axis, self.wheel_axis = worm_axis, wheel_axis
        self.ratio = teeth / starts
        self.period = 2 * math.pi / starts           # the worm's turn that moves the wheel one tooth
        self._worm_m, self._wheel_m = solid64(worm), solid64(wheel)
        self._distance = None
        self._near = None
        self.sense = 1
        vols = {}
        for s in (1, -1):
            self.sense = s
            vols[s] = max(self.interference(psi) for psi in SENSE_ANGLES)
        self.sense = min(vols, key=vols.get)

    def poses(self, psi: float, extra: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(worm, wheel) 4×4 motions at worm angle ψ, the wheel turned ``extra`` further."""
        return (self.worm_axis.rotation(psi),
                self.wheel_axis.rotation(self.sense * psi / self.ratio + extra))

    def _placed(self, psi: float):
        wm, hm = self.poses(psi)
        return (self._worm_m.transform(np.ascontiguousarray(wm[:3, :4])),
                self._wheel_m.transform(np.ascontiguousarray(hm[:3, :4])))

    def interference(self, psi: float) -> float:
        w, h = self._placed(psi)
        return float((w ^ h).volume())

    def sweep(self, steps: int, search: float) -> tuple[float, float]:
        """(largest interference mm³, smallest gap mm) over one thread period."""
        vols, gaps = [], []
        for psi in np.linspace(0, self.period, steps, endpoint=False):
            v, g = mesh_measure(*self._placed(psi), search)
            vols.append(v)
            gaps.append(g)
        return max(vols), min(gaps)

    def _flank_samples(self, flank: int, spacing: float):
        """Points on the wheel's flanks that lead when it turns by flank·δ, on faces that come
        within ZONE_REACH_MM of the worm's crest cylinder during the motion: (points, their
        radius from the wheel axis, the cosine between normal and motion, position along the axis)."""
        ha = self.wheel_axis
        near, facing = self._near_faces()
        pts, nrm = sample_surface(self.wheel, spacing, near & (facing * flank > 0.2))
        rr, along = ha.radial(pts)
        motion = np.cross(ha.direction, pts - ha.point) / rr[:, None]
        cos_t = np.maximum((nrm * motion).sum(axis=1) * flank, 0.2)
        return pts, rr, cos_t, along

    def _near_faces(self) -> tuple[np.ndarray, np.ndarray]:
        """(the wheel's faces that come within ZONE_REACH_MM of the worm's crest cylinder during
        the motion, each face's normal · its direction of motion): the same for both flanks, so
        worked out once."""
        if self._near is None:
            ha, wa = self.wheel_axis, self.worm_axis
            c = np.asarray(self.wheel.triangles_center)
            motion = np.cross(ha.direction, c - ha.point)
            motion /= np.linalg.norm(motion, axis=1)[:, None]
            facing = (np.asarray(self.wheel.face_normals) * motion).sum(axis=1)
            near = np.zeros(len(c), bool)
            for psi in np.linspace(0, self.period, 4 * ZONE_STEPS + 1):
                hm = self.poses(psi)[1]
                near |= wa.radial(c @ hm[:3, :3].T + hm[:3, 3])[0] < wa.radius + ZONE_REACH_MM
            self._near = near, facing
        return self._near

    def contact(self, flank: int, steps: int = ZONE_STEPS, gap: float = ZONE_GAP_MM,
                spacing: float = ZONE_SPACING_MM) -> dict:
        """The wheel turned by flank·δ (δ ≥ 0 when it starts clear) until that flank touches the
        worm, at ``steps`` worm angles over a thread period; then the flank's points within
        ``gap`` of the worm form the contact zone. Returns the turns (deg) and the zone's
        extent along the wheel axis (mm) at each angle."""
        if self._distance is None:
            self._distance = SurfaceDistance(self.worm)
        pts, rr, cos_t, along = self._flank_samples(flank, spacing)
        turns, extents = [], []
        for psi in np.linspace(0, self.period, steps, endpoint=False):
            wm, hm = self.poses(psi)
            inv_w = np.linalg.inv(wm)

            def gaps(extra, idx):
                m = inv_w @ self.wheel_axis.rotation(flank * extra) @ hm
                return self._distance(pts[idx] @ m[:3, :3].T + m[:3, 3], max_dist=gap + ZONE_MARGIN_MM)
            idx = np.arange(len(pts))
            idx = idx[gaps(0.0, idx) < gap + ZONE_MARGIN_MM]     # only these can close or enter the zone
            extra = 0.0
            for _ in range(8):
                # first-order turn that closes each point's gap: gap / (r · normal·motion)
                step = float(np.min(gaps(extra, idx) / (rr[idx] * cos_t[idx]))) if len(idx) else 0.0
                extra += step
                if abs(step) < CLOSE_TOL_RAD:
                    break
            zone = idx[gaps(extra, idx) <= gap]
            turns.append(math.degrees(extra))
            extents.append(float(np.ptp(along[zone])) if len(zone) else 0.0)
        return {"turn_deg": turns, "extent_mm": extents, "points": int(len(pts))}


def gear_pairs(parts) -> dict[str, dict[str, ManifestPart]]:
    """The tensioner's worm and wheel of ``parts`` (manifest records or entries), per channel."""
    out: dict[str, dict[str, ManifestPart]] = {}
    for p in map(ManifestPart.of, parts):
        if p.role in ("tensioner_worm", "tensioner_wheel"):
            out.setdefault(p.channel, {})[p.role.split("_")[1]] = p
    return out


def relative_pose(worm: ManifestPart, wheel: ManifestPart) -> np.ndarray:
    """Where the wheel's file lies in its worm's file: inv(worm placement) @ wheel placement, its
    rotation rounded to POSE_DECIMALS[0] places and its translation (mm) to POSE_DECIMALS[1], -0.0
    made 0.0: pairs placed apart by a rigid motion give the same array, not ones that differ in
    their last digits (the product's rounding depends on where each pair sits)."""
    pw, ph = ManifestPart.of(worm).placement, ManifestPart.of(wheel).placement
    rel = np.linalg.solve(pw, ph)
    out = np.eye(4)
    out[:3, :3] = np.round(rel[:3, :3], POSE_DECIMALS[0])
    out[:3, 3] = np.round(rel[:3, 3], POSE_DECIMALS[1])
    return out + 0.0


def measure_pair(folder: Path, worm: ManifestPart, wheel: ManifestPart, relative: np.ndarray | None = None) -> dict:
    """Axes, counts and the meshing motion of one worm and wheel, from their files: placed by their
    manifest placements (robot mm), or, with ``relative``, the worm as its file has it and the wheel
    under ``relative`` (the worm's file frame, where :func:`gear_checks` measures)."""
    if relative is None:
        wm, hm = placed_mesh(folder, worm), placed_mesh(folder, wheel)
    else:
        wm, hm = placed_mesh(folder, worm, np.eye(4)), placed_mesh(folder, wheel, relative)
    wa, ha = fit_axis(wm), fit_axis(hm)
    out = {"worm": wm, "wheel": hm, "worm_axis": wa, "wheel_axis": ha,
           "center_distance": axes_distance(wa, ha), "shaft_angle": axes_angle(wa, ha),
           "teeth": count_teeth(hm, ha), "starts": count_teeth(wm, wa)}
    if out["teeth"] and out["starts"]:
        out["meshing"] = Meshing(wm, hm, wa, ha, out["teeth"], out["starts"])
    return out


@dataclass
class DistinctPair:
    """The channels whose worm and wheel files have the same bytes and lie the same way to each
    other (:func:`relative_pose`): one measurement serves them all, made on the first's files."""

    channels: list[str]                  # sorted; the first is the one measured
    worm: ManifestPart                   # the first channel's parts
    wheel: ManifestPart
    files: tuple[str | None, str | None]  # sha256 of the worm's and the wheel's STL (None: unreadable)
    pose: np.ndarray                     # :func:`relative_pose`

    @property
    def measured_on(self) -> str:
        return self.channels[0]

    def measure(self, folder: Path) -> dict:
        """:func:`measure_pair` of the first channel's files, in its worm's file frame."""
        return measure_pair(folder, self.worm, self.wheel, self.pose)


def distinct_pairs(folder: Path, pairs: dict[str, dict[str, ManifestPart]]) -> list[DistinctPair]:
    """The channels that have both a worm and a wheel, grouped by their files' bytes and the pose of
    the wheel to its worm; in the order of each group's first channel."""
    groups: dict[tuple, DistinctPair] = {}
    for channel, pw in sorted(pairs.items()):
        if set(pw) != {"worm", "wheel"}:
            continue
        files = tuple(_file_sha(pw[r].stl_in(folder)) for r in ("worm", "wheel"))
        pose = relative_pose(pw["worm"], pw["wheel"])
        k = (files, pose.tobytes())
        if k in groups:
            groups[k].channels.append(channel)
        else:
            groups[k] = DistinctPair([channel], pw["worm"], pw["wheel"], files, pose)
    return list(groups.values())


def gear_checks(folder: Path, parts, plan) -> list[Check]:
    """Every distinct worm and wheel of ``parts`` (manifest records; :func:`distinct_pairs`) measured from its files, once. What
    the measuring finds (most of a check's time) is remembered (:func:`hwgen.cache.remembered`) per
    distinct pair under what it depends on: the two files' bytes, the wheel's pose to its worm and
    the design values it reads (the center offset, beyond which the gap is not searched; for the
    representative pair's contact and form factor, the module); not the placements in the robot nor
    the channels' names. The checks are made from those numbers on every call (their messages name
    each channel, and its loads: tendons × break load × winding radius)."""
    folder = Path(folder)
    pairs = gear_pairs(parts)
    if not pairs:
        return [Check("gear.parts", "error", False, "no tensioner worm/wheel parts in the manifest", fix=REBUILD)]
    checks = _pair_checks(folder, plan, pairs) + _drive_checks(folder, parts, plan)
    return [Check(**c) for c in as_json([c.to_json() for c in checks])]


FILE_Z = Axis(np.zeros(3), np.array([0.0, 0.0, 1.0]), 0.0, 0.0, (0.0, 0.0))    # a drive shaft's axis in its file


def _drive_checks(folder: Path, parts, plan) -> list[Check]:
    """``gear.drive_wall`` measured on the first channel's drive shaft (one shaft serves every channel),
    remembered under its file's bytes; ``parts`` manifest records or entries."""
    drives = sorted((p for p in map(ManifestPart.of, parts) if p.role == "tensioner_drive"),
                    key=lambda p: p.channel or "")
    if not drives:
        return []
    drive = drives[0]
    got = remembered("drive walls", (_file_sha(drive.stl_in(folder)),),
                     lambda: bore_wall(part_mesh(folder, drive), FILE_Z))
    return [drive_check(got, plan.require_tensioner_layout().hex_key, plan.min_wall, drive.channel or "")]


def _file_sha(path: Path) -> str | None:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


class _Measurer:
    """The remembered measurements of one call's distinct pairs; a pair measured here (its meshes,
    axes and manifold3d solids) is kept for its contact, which then needs no second fit."""

    def __init__(self, folder: Path):
        self.folder, self.live = folder, {}

    def _measured(self, d: DistinctPair) -> dict:
        k = (d.files, d.pose.tobytes())
        if k not in self.live:
            self.live[k] = d.measure(self.folder)
        return self.live[k]

    def pair(self, d: DistinctPair, center_offset: float) -> dict:
        """Centre distance, shaft angle, the fits' RMS, counts, and over one thread period the
        largest interference and the smallest gap (searched to center_offset + GAP_SEARCH_MM)."""
        return remembered("gear pair", (d.files, d.pose, center_offset),
                          lambda: measure_distinct_pair(self._measured(d), center_offset + GAP_SEARCH_MM))

    def contact(self, d: DistinctPair, module: float) -> dict:
        """Each flank turned into contact (:meth:`Meshing.contact`), and the Lewis form factor."""
        return remembered("gear contact", (d.files, d.pose, module),
                          lambda: measure_contact(self._measured(d), module))

    def tips(self, d: DistinctPair, pair) -> dict:
        """The wheel's thinnest tooth tip in the planes the model looks at, the worm's thread tip
        (:mod:`hwgen.checks.gear_walls`)."""
        planes = tip_planes(pair)

        def measure():
            m = self._measured(d)
            return {"wheel": wheel_tip(m["wheel"], m["wheel_axis"], planes),
                    "worm": thread_tip(m["worm"], m["worm_axis"], pair.pitch)}
        return remembered("gear tips", (d.files, d.pose, planes, pair.pitch), measure)

    def bore(self, d: DistinctPair) -> dict:
        """The worm's thinnest wall round the bores on its axis (:func:`hwgen.checks.gear_walls.bore_wall`)."""
        def measure():
            m = self._measured(d)
            return bore_wall(m["worm"], m["worm_axis"])
        return remembered("worm bore", (d.files, d.pose), measure)


def measure_distinct_pair(m: dict, search: float) -> dict:
    """The numbers the per-channel checks read, of a pair measured by :func:`measure_pair`."""
    out = {"center_distance": m["center_distance"], "shaft_angle": m["shaft_angle"],
           "worm_rms": m["worm_axis"].rms, "wheel_rms": m["wheel_axis"].rms,
           "teeth": m["teeth"], "starts": m["starts"]}
    if "meshing" in m:
        out["interference"], out["gap"] = m["meshing"].sweep(SWEEP_STEPS, search)
    return out


def measure_contact(m: dict, module: float) -> dict:
    """Both flanks' contact (turns and loaded extents at ZONE_STEPS worm angles) and the wheel's
    Lewis form factor, of a pair measured by :func:`measure_pair` (with its meshing motion)."""
    return {"flanks": [m["meshing"].contact(f) for f in (1, -1)],
            "form_factor": tooth_form_factor(m["wheel"], m["wheel_axis"], module)}


def _pair_checks(folder: Path, plan, pairs: dict) -> list[Check]:
    pair = plan.require_tensioner_layout().pair
    measurer = _Measurer(folder)
    distinct = distinct_pairs(folder, pairs)
    of = {c: d for d in distinct for c in d.channels}
    found = {d.measured_on: measurer.pair(d, pair.center_offset) for d in distinct}
    out: list[Check] = []
    flank_gap = pair.backlash()["normal_mm"] / 2
    for channel, pw in sorted(pairs.items()):
        where = {"channel": channel}
        if channel not in of:
            out.append(Check("gear.parts", "error", False, f"channel {channel}: worm or wheel missing", None, None,
                             where, fix=REBUILD))
            continue
        on = of[channel].measured_on
        m = found[on]
        name = f"channel {channel}"
        if on != channel:
            name += f" (measured on channel {on}'s files, which equal {channel}'s up to a rigid motion)"
            where = {"channel": channel, "measured_on": on}
        a, a_nom = m["center_distance"], pair.center_distance
        fit = f"axes fitted to the crests, RMS {1e6 * m['worm_rms']:.1f} / {1e6 * m['wheel_rms']:.1f} nm"
        out.append(Check("gear.center_distance", "error", abs(a - a_nom) <= CENTER_TOL_MM,
                         f"{name}: worm and wheel axes {a:.4f} mm apart ({fit}); design (d1 + d2)/2 + "
                         f"center_offset = {a_nom:.4f} mm", a, a_nom, where,
                         fix="" if abs(a - a_nom) <= CENTER_TOL_MM else REBUILD))
        out.append(Check("gear.shaft_angle", "error", abs(m["shaft_angle"] - 90) <= SHAFT_ANGLE_TOL_DEG,
                         f"{name}: worm and wheel axes at {m['shaft_angle']:.4f}° (90° wanted)",
                         m["shaft_angle"], 90.0, where,
                         fix="" if abs(m["shaft_angle"] - 90) <= SHAFT_ANGLE_TOL_DEG else REBUILD))
        for what, n, want in (("teeth", m["teeth"], pair.teeth), ("starts", m["starts"], pair.starts)):
            part = "wheel" if what == "teeth" else "worm"
            out.append(Check(f"gear.{what}", "error", n == want,
                             f"{name}: {n} {what if part == 'wheel' else 'thread starts'} counted in the "
                             f"{part}'s section, the design has {want}", float(n), float(want), where,
                             fix="" if n == want else REBUILD))
        if "gap" not in m:
            continue
        vol, gap = m["interference"], m["gap"]
        out.append(Check("gear.interference", "error", vol <= INTERFERENCE_TOL_MM3,
                         f"{name}: worm and wheel overlap by at most {vol:.4f} mm³ over one thread "
                         f"period ({SWEEP_STEPS} positions)", vol, INTERFERENCE_TOL_MM3, where,
                         fix="" if vol <= INTERFERENCE_TOL_MM3 else f"a larger tensioner.center_offset; {REBUILD}"))
        lo, hi = GAP_MIN_SHARE * flank_gap, pair.center_offset + GAP_TOL_MM
        out.append(Check("gear.gap", "error", lo <= gap <= hi,
                         f"{name}: closest gap between worm and wheel {gap:.4f} mm over one thread period "
                         f"(from {lo:.4f} to {hi:.4f} mm wanted: the design's center_offset {pair.center_offset:g} mm "
                         f"leaves {flank_gap:.4f} mm per flank by the rack formula)", gap, lo, where,
                         fix="" if lo <= gap <= hi else REBUILD))
    measured = {c: found[d.measured_on] for c, d in of.items()}
    out += _strength_checks(measured, of, measurer, pairs, plan, pair)
    return out


def _strength_checks(measured: dict, of: dict, measurer: _Measurer, pairs: dict, plan, pair) -> list[Check]:
    """Backlash and loaded face on the representative pair (the channel with the most tendons, measured
    on the files of the first channel of its distinct pair); Lewis and Hertz on every channel."""
    lay, ts, proc = plan.require_tensioner_layout(), plan.tensioner, plan.process
    mu, load = lay.friction_coefficient, plan.tendon_material.break_load
    wheels = {c: pw["wheel"] for c, pw in pairs.items() if "wheel" in pw}
    usable = [c for c, m in measured.items() if "gap" in m]
    if not usable:
        return []
    rep = max(usable, key=lambda c: (len(wheels[c].tendons), c))
    m, on = measured[rep], of[rep].measured_on
    found = measurer.contact(of[rep], pair.module)
    contact = dict(zip((1, -1), found["flanks"]))
    face = min(min(c["extent_mm"]) for c in contact.values())
    turn = float(np.mean(np.add(contact[1]["turn_deg"], contact[-1]["turn_deg"])))
    jt = math.radians(turn) * pair.r2
    formula = pair.backlash()
    y = found["form_factor"]
    common = {"channel": "all", "measured_on": on}
    out = [Check("gear.backlash", "info", True,
                 f"measured on channel {on}'s files: the wheel turns {turn:.3f}° from one flank touching the worm to "
                 f"the other (mean of {ZONE_STEPS} worm angles), j_t = {jt:.4f} mm at its pitch circle (design r2 = "
                 f"{pair.r2:g} mm); the rack formula 2·center_offset·tan α gives {formula['circumferential_mm']:.4f} mm "
                 f"({formula['wheel_deg']:.3f}°)", jt, formula["circumferential_mm"],
                 {**common, "wheel_turn_deg": turn, "formula_mm": formula["circumferential_mm"]}),
           Check("gear.loaded_face", "info", True,
                 f"measured on channel {on}'s files: with each flank turned into contact, the wheel lies within "
                 f"{ZONE_GAP_MM:g} mm of the worm over {face:.2f} mm of its {pair.face_width:g} mm face (least of "
                 f"{ZONE_STEPS} worm angles and both flanks); Lewis and Hertz use this face",
                 face, pair.face_width, {**common, "form_factor": y}),
           Check("gear.ratio", "info", True,
                 f"ratio {m['teeth'] / m['starts']:g}:1 ({m['teeth']} teeth, {m['starts']} start"
                 f"{'s' if m['starts'] > 1 else ''}, counted on channel {on}'s files)", m["teeth"] / m["starts"],
                 None, common)]
    gamma, phi = math.degrees(pair.lead_angle), math.degrees(pair.friction_angle(mu))
    out.append(Check("gear.lead_angle", "info", True,
                     f"lead angle {gamma:.3f}° (design: d1 = {pair.worm_pitch_diameter:g} mm, m = {pair.module:g} mm), "
                     f"{phi - gamma:.2f}° below the friction angle atan(μ / cos α_n) = {phi:.3f}° (design μ = {mu:g}; "
                     f"loading refuses a pair that is not self-locking)", gamma, phi, common))
    out += tip_checks(measurer.tips(of[rep], pair), pair, lay, plan.min_wall, on)
    out.append(bore_check(measurer.bore(of[rep]), pair, lay, plan.min_wall, on))
    e_mpa, nu, why = proc.contact_modulus_mpa, proc.poisson, proc.contact_reason
    allow = hertz_allowable(ts.resin_strength)
    for channel in sorted(measured):
        where = {"channel": channel}
        n = len(wheels[channel].tendons) or 1
        r_w = wheels[channel].meta.get("winding_radius_mm", lay.winding_radius)
        t2 = n * load * r_w
        loading = (f"{n} × {load:g} N (design: tendon break load) at r = {r_w:.3f} mm: {t2:.0f} N·mm on the wheel, "
                   f"F_t2 = {pair.wheel_tangential_force(t2):.1f} N")
        sigma = pair.lewis_stress(t2, face, y)
        sf = ts.resin_strength / sigma
        out.append(Check("gear.lewis", "error", sf >= ts.safety_factor,
                         f"channel {channel}: {loading}; Lewis tooth stress {sigma:.1f} MPa on the loaded face "
                         f"{face:.2f} mm with Y = {y:.3f} (both measured on channel {on}'s files), m = "
                         f"{pair.module:g} mm: safety {sf:.2f} against the design's resin_strength "
                         f"{ts.resin_strength:g} MPa (need {ts.safety_factor:g})", sf, ts.safety_factor,
                         {**where, "stress_mpa": sigma, "face_mm": face, "form_factor": y},
                         fix="" if sf >= ts.safety_factor else _strength_fix(ts, pair, ts.safety_factor / sf, False),
                         fixes=() if sf >= ts.safety_factor else _strength_fixes(ts, pair, sf, False)))
        hz = pair.hertz_line(t2, face, mu, e_mpa, nu)
        sh = allow / hz["p0_mpa"]
        out.append(Check("gear.hertz", "error", sh >= ts.safety_factor,
                         f"channel {channel}: {loading}; Hertz line contact over {hz['length_mm']:.2f} mm "
                         f"(the measured face / cos γ) on the flank's radius {hz['radius_mm']:.2f} mm at the pitch "
                         f"point, normal force {hz['force_n']:.1f} N (μ = {mu:g}): peak pressure "
                         f"{hz['p0_mpa']:.1f} MPa, safety {sh:.2f} "
                         f"against {allow:.1f} MPa = 1.67 × the design's resin_strength (onset of yield below the "
                         f"surface; E = {e_mpa:g} MPa, ν = {nu:g} from the materials table, {proc.material}) "
                         f"(need {ts.safety_factor:g})", sh, ts.safety_factor,
                         {**where, "p0_mpa": hz["p0_mpa"], "allowable_mpa": allow, "elasticity": why},
                         fix="" if sh >= ts.safety_factor else _strength_fix(ts, pair, ts.safety_factor / sh, True),
                         fixes=() if sh >= ts.safety_factor else _strength_fixes(ts, pair, sh, True)))
        t1 = pair.worm_torque(t2, mu)
        out.append(Check("gear.worm_torque", "info", True,
                         f"channel {channel}: {t1:.1f} N·mm on the worm's hex key to hold the tendon break load "
                         f"(design data; tightening, μ = {mu:g}, efficiency {pair.efficiency(mu):.2f})", t1, None, where))
    return out


def _strength_fix(ts, pair, k: float, hertz: bool) -> str:
    """How far the tensioner's settings move a tooth stress whose safety is ``k`` times short. Lewis:
    σ = T / (r2 b m Y) with r2 = m z2 / 2, so face, teeth and module² each by k; Hertz: p0 goes as
    1 / (m z2 √b) (the force as 1 / r2, the flank's radius as r2), so face by k², teeth and module by k.
    The face and the resin are tried (:func:`_strength_fixes`); the teeth and the module, which lay
    the tensioner out again, are not. The gear's sizes are the pair's (``pair``, what was built: the
    settings hold none of them); the strength figures the settings' (``ts``)."""
    _, teeth, module = (k * k, k, k) if hertz else (k, k, math.sqrt(k))
    return (f"{fix_text(_strength_fixes(ts, pair, ts.safety_factor / k, hertz))}. Also (not tried): "
            f"tensioner.wheel_teeth from {pair.teeth} to about {math.ceil(pair.teeth * teeth)} (a larger wheel "
            f"pushes its teeth less for the same tendon pull), or tensioner.module from {pair.module:g} to about "
            f"{pair.module * module:.2f} mm, each with the tensioner laid out again")


def _strength_fixes(ts, pair, safety: float, hertz: bool) -> tuple[Fix, ...]:
    """A stronger resin (the safety goes as the strength) and a wider face (Lewis: as the face;
    Hertz: as its square root), each evaluated by the law the check applied to the measured
    tooth, not by a new build; the face is the built pair's."""
    need = ts.safety_factor
    k = need / safety
    out = []
    face = math.ceil(pair.face_width * (k * k if hertz else k) * 10 + 1e-9) / 10
    got = safety * (math.sqrt(face / pair.face_width) if hertz else face / pair.face_width)
    out.append(Fix({"tensioner.face_width": face}, {"measured": got, "passed": got >= need, "limit": need}, (),
                   f"from {pair.face_width:g} mm: the safety scaled from the measured tooth by the "
                   f"{'Hertz' if hertz else 'Lewis'} law"))
    strength = float(math.ceil(ts.resin_strength * k))
    got = safety * strength / ts.resin_strength
    out.append(Fix({"tensioner.resin_strength": strength}, {"measured": got, "passed": got >= need, "limit": need},
                   (), f"from {ts.resin_strength:g} MPa: a tougher resin, if it has it"))
    return tuple(out)
