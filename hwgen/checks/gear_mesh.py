"""Worm-gear tensioner checks: the mesh measured from the exported files, the formulas,
and the free span of every tendon from its tip eyelet to its spool.

Measured from files (placed by the manifest's placement): centre distance and shaft angle
of each worm/wheel pair from their axes (file Z of both), the interference volume of worm
and wheel at the nominal mesh and their closest gap (manifold3d), and each tendon's
clearance to every part it passes. Computed from the parameters (hwgen.gears): ratio, lead
angle, self-locking, undercut, Lewis tooth stress at the tendon break load and the torque
on the worm for that pull.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..model.gearing import worm_pair
from .base import Check
from .measure import load_mesh, to_manifold

INTERFERENCE_TOL_MM3 = 0.01   # worm ∩ wheel at the nominal mesh counts as zero below this
GAP_TOL_MM = 0.02             # STL chordal tolerance is 0.01 mm on each part
CENTER_TOL_MM = 1e-3
SHAFT_ANGLE_TOL_DEG = 1e-3
GAP_SEARCH_MM = 1.0           # min_gap search length between worm and wheel beyond the backlash
TENDON_SEARCH_MM = 5.0        # a tendon's nearest other part is reported up to this far
TENDON_SEGMENTS = 16          # facets of the tendon's cylinder


def manifold(folder: Path, entry: dict, placement: np.ndarray | None = None):
    """The part's STL as a manifold3d solid in robot coordinates (or under ``placement``)."""
    mesh = load_mesh(Path(folder) / entry["files"]["stl"]["path"])
    return to_manifold(mesh, entry["placement"] if placement is None else placement)


def axis(entry: dict) -> tuple[np.ndarray, np.ndarray]:
    """Rotation axis of a worm or wheel in robot coordinates: file Z through the file origin."""
    m = np.asarray(entry["placement"], dtype=float)
    return m[:3, 3].copy(), m[:3, 2] / np.linalg.norm(m[:3, 2])


def axes_distance(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> float:
    n = np.cross(a[1], b[1])
    if np.linalg.norm(n) < 1e-12:
        return float(np.linalg.norm(np.cross(b[0] - a[0], a[1])))
    return float(abs(np.dot(b[0] - a[0], n)) / np.linalg.norm(n))


def toward(wheel: dict, worm: dict, distance: float) -> np.ndarray:
    """The wheel's placement moved ``distance`` mm toward the worm along their common normal."""
    (pa, da), (pb, db) = axis(wheel), axis(worm)
    n = np.cross(da, db)
    n /= np.linalg.norm(n)
    if np.dot(pb - pa, n) < 0:
        n = -n
    m = np.asarray(wheel["placement"], dtype=float).copy()
    m[:3, 3] += distance * n
    return m


def mesh_measure(worm_m, wheel_m, search: float = GAP_SEARCH_MM) -> tuple[float, float]:
    """(interference volume mm³, closest gap mm) of two placed solids."""
    return float((worm_m ^ wheel_m).volume()), float(worm_m.min_gap(wheel_m, search))


def tendon_cylinder(p0, p1, radius: float):
    """A cylinder of the tendon's diameter from p0 to p1 (robot mm), as a manifold."""
    import manifold3d as m3d
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    length = float(np.linalg.norm(d))
    z = d / length
    x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.column_stack([x, y, z, p0])
    return m3d.Manifold.cylinder(length, radius, radius, TENDON_SEGMENTS).transform(m.tolist())


def _pairs(manifest: dict) -> dict[str, dict[str, dict]]:
    out: dict[str, dict[str, dict]] = {}
    for p in manifest.get("parts", []):
        if p.get("role") in ("tensioner_worm", "tensioner_wheel"):
            out.setdefault(p["channel"], {})[p["role"].split("_")[1]] = p
    return out


def gear_checks(folder: Path, manifest: dict, plan) -> list[Check]:
    folder = Path(folder)
    d = plan.design
    ts = d.tensioner
    pair = worm_pair(ts)
    mu = ts.friction_coefficient
    load = d.tendon_material.break_load
    out: list[Check] = []
    pairs = _pairs(manifest)
    if not pairs:
        return [Check("gear.parts", "error", False, "no tensioner worm/wheel parts in the manifest")]
    phi = math.degrees(math.atan(mu))
    gamma = math.degrees(pair.lead_angle)
    for channel, pw in sorted(pairs.items()):
        where = {"channel": channel}
        if set(pw) != {"worm", "wheel"}:
            out.append(Check("gear.parts", "error", False, f"channel {channel}: worm or wheel missing", None, None,
                             where))
            continue
        worm, wheel = pw["worm"], pw["wheel"]
        aw, ah = axis(worm), axis(wheel)
        a_meas = axes_distance(aw, ah)
        a_nom = pair.center_distance
        out.append(Check("gear.center_distance", "error", abs(a_meas - a_nom) <= CENTER_TOL_MM,
                         f"channel {channel}: worm and wheel axes {a_meas:.4f} mm apart, (d1 + d2)/2 + backlash = "
                         f"{a_nom:.4f} mm", a_meas, a_nom, where))
        ang = math.degrees(math.acos(min(1.0, abs(float(np.dot(aw[1], ah[1]))))))
        out.append(Check("gear.shaft_angle", "error", abs(ang - 90) <= SHAFT_ANGLE_TOL_DEG,
                         f"channel {channel}: worm and wheel axes at {ang:.4f}° (90° wanted)", ang, 90.0, where))
        wm, hm = manifold(folder, worm), manifold(folder, wheel)
        vol, gap = mesh_measure(wm, hm, pair.backlash + GAP_SEARCH_MM)
        out.append(Check("gear.interference", "error", vol <= INTERFERENCE_TOL_MM3,
                         f"channel {channel}: worm and wheel overlap by {vol:.4f} mm³ at the nominal mesh",
                         vol, INTERFERENCE_TOL_MM3, where))
        out.append(Check("gear.gap", "error", gap <= pair.backlash + GAP_TOL_MM,
                         f"channel {channel}: closest gap between worm and wheel {gap:.4f} mm "
                         f"(backlash {pair.backlash:g} mm)", gap, pair.backlash + GAP_TOL_MM, where))
        n_tendons = len(wheel.get("tendons", [])) or 1
        r_w = wheel.get("winding_radius_mm", ts.spool_diameter / 2 + d.tendon_material.diameter / 2)
        torque2 = n_tendons * load * r_w
        sigma = pair.lewis_stress(torque2)
        sf = ts.resin_strength / sigma
        out.append(Check("gear.lewis", "error", sf >= ts.safety_factor,
                         f"channel {channel}: {n_tendons} × {load:g} N at r = {r_w:.3f} mm gives {torque2:.0f} N·mm on "
                         f"the wheel, Lewis tooth stress {sigma:.1f} MPa (Y = {pair.lewis_form_factor():.3f}, "
                         f"b = {pair.effective_face_width:g} mm): safety factor {sf:.2f} against "
                         f"{ts.resin_strength:g} MPa", sf, ts.safety_factor, {**where, "stress_mpa": sigma}))
        t1 = pair.worm_torque(torque2, mu)
        out.append(Check("gear.worm_torque", "info", True,
                         f"channel {channel}: {t1:.1f} N·mm on the worm's hex key to hold the tendon break load "
                         f"(tightening, μ = {mu:g}, efficiency {pair.efficiency(mu):.2f})", t1, None, where))
    common = {"channel": "all"}
    out.append(Check("gear.ratio", "info", True, f"ratio {pair.ratio:g}:1 ({pair.teeth} teeth, {pair.starts} start"
                     f"{'s' if pair.starts > 1 else ''})", pair.ratio, None, common))
    out.append(Check("gear.lead_angle", "info", True, f"lead angle {gamma:.3f}° (d1 = {pair.worm_pitch_diameter:g} mm, "
                     f"m = {pair.module:g} mm)", gamma, None, common))
    out.append(Check("gear.self_locking", "error", pair.self_locking(mu),
                     f"lead angle {gamma:.3f}° {'<' if pair.self_locking(mu) else '≥'} friction angle atan({mu:g}) = "
                     f"{phi:.3f}°: the tendon {'cannot' if pair.self_locking(mu) else 'can'} turn the worm back",
                     gamma, phi, common))
    zmin = pair.min_teeth_no_undercut
    out.append(Check("gear.undercut", "error", pair.teeth >= zmin,
                     f"{pair.teeth} wheel teeth, {math.ceil(zmin)} the fewest without undercut at "
                     f"{pair.pressure_angle_deg:g}°", float(pair.teeth), zmin, common))
    out += tendon_checks(folder, manifest, plan)
    return out


def tendon_checks(folder: Path, manifest: dict, plan) -> list[Check]:
    """Each tendon's free span (tip face to spool) against every part but its own start disk
    and, over the last stretch where it enters between the flanges, its own spool."""
    folder = Path(folder)
    d = plan.design.tendon_material.diameter
    runs = []
    for p in manifest.get("parts", []):
        for r in p.get("tendon_runs", []):
            runs.append((p["name"], r))
    if not runs:
        return [Check("tensioner.tendon_clearance", "error", False, "no tendon runs in the manifest")]
    parts = [p for p in manifest["parts"] if not (p.get("role") == "disk" and p.get("disk_role") == "tip")]
    solids = {}
    out = []
    for own, r in runs:
        start, end = np.asarray(r["start"], float), np.asarray(r["end"], float)
        lo, hi = np.minimum(start, end) - TENDON_SEARCH_MM, np.maximum(start, end) + TENDON_SEARCH_MM
        worst, worst_part, own_gap = math.inf, None, math.inf
        for p in parts:
            bmin = np.asarray(p["bbox_mm"]["min"])
            bmax = np.asarray(p["bbox_mm"]["max"])
            m = np.asarray(p["placement"], dtype=float)
            corners = np.array([[x, y, z] for x in (bmin[0], bmax[0]) for y in (bmin[1], bmax[1])
                                for z in (bmin[2], bmax[2])]) @ m[:3, :3].T + m[:3, 3]
            if np.any(corners.max(axis=0) < lo) or np.any(corners.min(axis=0) > hi):
                continue
            s0, s1 = start, end
            if p["name"] == own:
                trim = r["own_part_trim_mm"]
                s1 = end - trim * (end - start) / np.linalg.norm(end - start)
            if p["name"] not in solids:
                solids[p["name"]] = manifold(folder, p)
            g = float(tendon_cylinder(s0, s1, d / 2).min_gap(solids[p["name"]], TENDON_SEARCH_MM))
            if p["name"] == own:
                own_gap = g
            elif g < worst:
                worst, worst_part = g, p["name"]
        ok = min(worst, own_gap) >= d
        if worst >= TENDON_SEARCH_MM - 1e-9:
            worst_part = None
        near = (f"nearest other part {worst_part} at {worst:.3f} mm" if worst_part else
                f"no other part within {TENDON_SEARCH_MM:g} mm")
        out.append(Check("tensioner.tendon_clearance", "error", ok,
                         f"tendon {r['tendon']}: free span from its tip eyelet to its spool: {near}, its own wheel "
                         f"{own_gap:.3f} mm short of the winding point (needs ≥ the tendon diameter {d:g} mm)",
                         min(worst, own_gap), d,
                         {"tendon": r["tendon"], "part": own if own_gap <= worst else worst_part,
                          "nearest_other_part": worst_part, "nearest_other_mm": min(worst, TENDON_SEARCH_MM)}))
        out.append(Check("tensioner.exit_angle", "info", True,
                         f"tendon {r['tendon']}: turns {r['exit_angle_deg']:.1f}° at its tip eyelet toward its spool",
                         r["exit_angle_deg"], None, {"tendon": r["tendon"]}))
    return out
