"""The robot's own weight: state N of Sect. III-B, the base mount's stiffness, and the strip's
stress when the actuating pair bends it (:mod:`hwgen.model.sag` does the mechanics).

State N: the robot straight and horizontal, its flexible direction (z) along gravity, no tendon
tensioned. The loads are measured from the files: each part's volume and centroid from its STL,
its density from the manifest (design data: the files do not say what they are made of). The
strip (E from ``backbone.modulus_gpa``, I = h t³/12 from the strip's STL) is clamped at the base
disk's mid-plane; the base disk and everything bolted to the table are the clamp's. Every other
disk is a point weight at its centre of mass; everything beyond the tip station (the tensioner,
and the strip it clamps) is the tip assembly, fixed to the tip frame at its centre of mass.
Where a disk holds the strip (its plate and its hub, measured from its STL) the strip is
stiffer: the plate holds it straight, the hub, glued on, adds its walls' E·I (E of the printed
material from hwgen/data/materials.csv). Gravity is taken along -z and along +z and the worse
kept. The verdict is the largest stress in the strip against ``backbone.allowable_stress_mpa``.

Base mount: its thinnest section (about the axis across the robot), cut from its STL between the
table and the strip, taken over the whole height as a cantilever under the base moment and the
carried weight; the tip drops by the rotation this gives times the tip's reach.
"""
from __future__ import annotations

import math

import numpy as np

from ..cad.manifest import Manifest
from ..model import sag, steel
from .base import REBUILD, Check, Fix, fix_text
from .polygons import section_moments
from .sections import chain_loops, section_robot
from .seating import SlotFit

CURVE_POINTS = 300           # the deformed shape is reported at about this many points
MOUNT_CUTS = 24              # sections of the base mount between the table and the strip
GROUNDED_ROLES = ("base_mount", "base_clamp")


def _downsample(arrs, n):
    k = max(1, len(arrs[0]) // n)
    return [np.r_[a[::k], a[-1:]] if (len(a) - 1) % k else a[::k] for a in arrs]


def _spans(fits: list[SlotFit], length: float, ei_strip: float, e_print: float) -> list[sag.Span]:
    """Where each disk holds the strip: its plate straight, its hub glued on (strip + hub walls)."""
    spans = []
    for f in fits:
        a, b = f.slab
        if min(b, length) > max(a, 0.0):
            spans.append(sag.Span(max(a, 0.0), min(b, length), math.inf))
        if f.hub_i:
            ei = ei_strip + e_print * f.hub_i
            for lo, hi in ((f.engaged[0], a), (b, f.engaged[1])):
                lo, hi = max(lo, 0.0), min(hi, length)
                if hi - lo > 1e-6:
                    spans.append(sag.Span(lo, hi, ei))
    return spans


def loads(parts, manifest: Manifest, length: float, bought=()):
    """(strip mass per mm in g/mm and its record, [(part, s, mass)], tip assembly record) from the
    STLs (volume, centroid) and the manifest's densities, and the tip assembly's bought metal
    ``bought`` (:func:`hwgen.model.steel.tip_pieces`: design data, the files hold no steel)."""
    entries = {p.name: p for p in manifest.parts}
    strip, points, tip = None, [], []
    for p in parts:
        e = entries.get(p.name)
        closed = None if e is None or e.density_g_cm3 is None or e.fixture else p.volume_and_centroid()
        if closed is None:
            continue
        volume, com = closed
        m = volume / 1000 * e.density_g_cm3
        if p.role == "backbone":
            lo, hi = p.robot_bounds()[:, 1]
            strip = {"part": p.name, "mass_g": m, "y_mm": [float(lo), float(hi)], "lambda_g_mm": m / (hi - lo)}
            continue
        if p.role in GROUNDED_ROLES or e.meta.get("grounded") or (p.role == "disk" and e.station == 0):
            continue
        if com[1] > length:
            tip.append((p.name, m, com))
        else:
            points.append((p.name, float(com[1]), m))
    if strip is not None and strip["y_mm"][1] > length:
        beyond = strip["y_mm"][1] - length
        tip.append((f"{strip['part']} beyond the tip", strip["lambda_g_mm"] * beyond,
                    np.array([0.0, length + beyond / 2, 0.0])))
    printed = [n for n, _, _ in tip]
    metal = steel.total(bought)
    if metal[0] > 0:
        tip.append(("bought metal", metal[0], metal[1]))
    mt = sum(m for _, m, _ in tip)
    c = sum(m * c for _, m, c in tip) / mt if mt else np.array([0.0, length, 0.0])
    return strip, points, {"parts": printed, "mass_g": mt, "center_of_mass_mm": c.tolist(),
                           "a_mm": float(c[1] - length), "z_mm": float(c[2]),
                           "bought_metal": {"mass_g": metal[0], "center_of_mass_mm": metal[1].tolist(),
                                            "pieces": len(bought)}}


def _case(r: sag.SagResult) -> dict:
    return {"tip_sag_mm": r.tip_sag, "tip_angle_deg": -r.tip_angle_deg, "tip_y_mm": r.tip_y,
            "base_moment_nmm": abs(r.base_moment), "max_stress_mpa": r.max_stress, "s_max_stress_mm": r.s_max_stress,
            "carried_weight_n": r.total_weight,
            "linear": {"tip_sag_mm": r.linear.tip_sag, "tip_angle_deg": -math.degrees(r.linear.tip_angle),
                       "base_moment_nmm": abs(r.linear.base_moment)}}


def gravity_checks(parts, manifest: Manifest, plan, fits: list[SlotFit], strip_h: float | None,
                   strip_t: float | None, length: float) -> tuple[dict, list[Check]]:
    """State N, the mount's stiffness and the strip under the actuating pair: (report, checks)."""
    bb = plan.backbone
    h = strip_h if strip_h else bb.height
    t = strip_t if strip_t else bb.thickness
    E = bb.modulus_gpa * 1000.0
    I = sag.second_moment(h, t)
    e_print, e_why = plan.process.modulus_gpa, plan.process.modulus_reason
    e_print *= 1000.0
    strip, points, tip = loads(parts, manifest, length, steel.tip_pieces(plan))
    if strip is None:
        return {}, [Check("gravity.strip_stress", "error", False, "no strip to load: the backbone STL is missing",
                          fix=REBUILD)]
    spans = _spans(fits, length, E * I, e_print)
    st = [s for _, s, _ in points]
    ms = [m for _, _, m in points]
    section = sag.Strip(E, I, t, strip["lambda_g_mm"])
    cases = {}
    for down, sign in (("-z", 1.0), ("+z", -1.0)):
        cases[down] = sag.solve_sag(length, st, ms, section, tip=sag.Tip(tip["mass_g"], (tip["a_mm"], sign * tip["z_mm"])),
                                    spans=spans)
    worst_key = max(cases, key=lambda k: cases[k].max_stress)
    r = cases[worst_key]
    bare = sag.solve_sag(length, st, ms, section,
                         tip=sag.Tip(tip["mass_g"], (tip["a_mm"], (1 if worst_key == "-z" else -1) * tip["z_mm"])))
    allow = bb.allowable_stress_mpa
    s, y, z, stress = _downsample([r.s, r.y, r.z, r.stress], CURVE_POINTS)
    report = {
        "model": "planar elastica of the strip clamped at the base disk's mid-plane, robot horizontal, z along "
                 "gravity, no tendon tensioned (state N); solved by shooting (hwgen.model.sag)",
        "assumptions": [
            "masses: STL volumes × the manifest's densities (design data); centres of mass from the STLs",
            "the tip assembly carries the bought metal the bill of materials lists for it (dowels, screws, nuts, set "
            "screws: hwgen.model.steel, design data), each piece where the layout puts it",
            "the base disk and the base mount are the clamp's; other disks are point weights at their centres of mass",
            "everything beyond the tip station (tensioner, clamped strip) is rigid on the tip frame",
            "disk plates hold the strip straight; glued hubs add E_print·I_hub (E_print: " + e_why + ")",
            "tendons slack and weightless; the strip's width does not curl (anticlastic factor ≈ 1.01)",
            "the clamp is rigid; its own give is the mount check's"],
        "E_mpa": E, "I_mm4": I, "EI_nmm2": E * I, "thickness_mm": t, "height_mm": h, "length_mm": length,
        "print_modulus_mpa": e_print,
        "strip": strip,
        "disks": [{"part": n, "s_mm": s_, "mass_g": m} for n, s_, m in points],
        "tip_assembly": tip,
        "spans": [{"start_mm": sp.start, "end_mm": sp.end, "ei_nmm2": None if math.isinf(sp.ei) else sp.ei}
                  for sp in spans],
        "cases": {k: _case(v) for k, v in cases.items()},
        "gravity": worst_key,
        "uniform_strip": _case(bare),
        "allowable_stress_mpa": allow,
        "curve": {"s_mm": s.tolist(), "y_mm": y.tolist(), "z_mm": z.tolist(), "stress_mpa": stress.tolist(),
                  "psi_deg": np.degrees(np.interp(s, r.s, r.psi)).tolist(),
                  "tip_com_mm": list(r.tip_com), "tip_angle_deg": r.tip_angle_deg},
    }
    checks = []
    ok = r.max_stress <= allow
    sev = plan.check.overstress
    strip_study = _StripStudy(r, fits, E, h, e_print, plan.check.max_angle_deg, allow)
    text = (f"state N (no tendon tensioned, horizontal, gravity along {worst_key}): tip sags {r.tip_sag:.1f} mm, "
            f"tip {-r.tip_angle_deg:.1f}° below horizontal; the strip's largest bending stress "
            f"{r.max_stress:.1f} MPa at s = {r.s_max_stress:.1f} mm "
            f"({'under' if ok else 'over'} the allowable {allow:g} MPa), base moment {abs(r.base_moment):.0f} N·mm; "
            f"carries {tip['mass_g']:.1f} g at {tip['a_mm']:.1f} mm beyond the tip "
            f"({tip['bought_metal']['mass_g']:.1f} g of it bought metal: pins, screws, nuts), "
            f"{sum(ms):.1f} g of disks and {strip['mass_g']:.1f} g of strip (printed masses from the STLs and the "
            f"manifest's densities; E = {E / 1000:g} GPa); as a bare strip without hubs "
            f"{bare.tip_sag:.1f} mm and {bare.max_stress:.1f} MPa")
    own = () if ok else tuple(strip_study.own_weight_fixes(r.max_stress))
    checks.append(Check("gravity.strip_stress", sev if not ok else "error", ok, text, r.max_stress, allow,
                        {"part": strip["part"], "gravity": worst_key, "s_mm": r.s_max_stress},
                        fix="" if ok else _fix_text(own, OWN_WEIGHT_ELSE), fixes=own,
                        lowered_by="check.overstress" if not ok and sev == "warning" else ""))
    checks.append(Check("gravity.sag", "info", True, f"state N: tip sag {r.tip_sag:.1f} mm (small-deflection "
                        f"theory: {r.linear.tip_sag:.1f} mm)", r.tip_sag, None, {"gravity": worst_key}))
    mount, c = _mount_check(parts, plan.mount.rules.max_tip_share, r, e_print, e_why)
    report["mount"] = mount
    checks += c
    bend, c = _bend_check(strip_study, spans, I, strip["part"])
    report["bend"] = bend
    checks += c
    return report, checks


def _mount_check(parts, limit: float, r: sag.SagResult, e_print: float, e_why: str) -> tuple[dict, list[Check]]:
    """``limit``: the largest share of the tip's sag the mount's give may add (base_mount.max_tip_share)."""
    mount = next((p for p in parts if p.role == "base_mount"), None)
    if mount is None:
        return {}, []
    lo, hi = mount.robot_bounds()[:, 2]
    top = min(hi, 0.0)
    zs = np.linspace(lo, top, MOUNT_CUTS + 2)[1:-1]
    best = None
    for zc in zs:
        segs = section_robot(mount.mesh, mount.placement, 2, float(zc))
        loops = chain_loops(segs[:, :, [0, 1]]) if len(segs) else []
        if not loops:
            continue
        mo = section_moments(loops)
        if best is None or mo["i_vc"] < best[1]["i_vc"]:
            best = (float(zc), mo)
    if best is None:
        return {}, [Check("mount.stiffness", "error", False, f"{mount.name}: no section between table and strip",
                          fix=REBUILD)]
    zc, mo = best
    H = 0.0 - lo                                      # table to the strip's plane
    M, W = abs(r.base_moment), r.total_weight
    theta = (M + W * H / 2) * H / (e_print * mo["i_vc"])
    drop = theta * r.tip_y
    share = drop / r.tip_sag if r.tip_sag > 0 else 0.0
    ok = share <= limit
    strip_k = r.loads.EI / r.loads.L
    mount_k = e_print * mo["i_vc"] / H
    rep = {"part": mount.name, "height_mm": H, "thinnest_section_z_mm": zc, "section_area_mm2": mo["area"],
           "section_i_mm4": mo["i_vc"], "modulus_mpa": e_print, "rotation_rad": theta, "tip_drop_mm": drop,
           "share_of_sag": share, "limit": limit, "rotational_stiffness_nmm_rad": mount_k,
           "strip_rotational_stiffness_nmm_rad": strip_k,
           "model": "cantilever column from the table to the strip, its thinnest section over the whole height, "
                    "under the base moment and the carried weight; foot bolts and table rigid; E: " + e_why}
    msg = (f"{mount.name}: thinnest section {mo['area']:.0f} mm², I = {mo['i_vc']:.3g} mm⁴ (at z = {zc:.1f} mm), "
           f"{H:.0f} mm from table to strip: under the state-N base moment {M:.0f} N·mm it turns "
           f"{theta * 1e3:.3f} mrad, "
           f"dropping the tip {drop:.3f} mm, {share * 100:.2f} % of the {r.tip_sag:.1f} mm sag (limit "
           f"{limit * 100:g} %); {mount_k / strip_k:.0f}× the strip's EI/L")
    fix = "" if ok else (
        f"a shorter mount: a lower base_mount.table_clearance (its column, {H:.0f} mm from table to strip, turns "
        f"about as its height squared); or a stiffer printed material (process.material); or, if "
        f"{share * 100:.1f} % of the sag is acceptable, base_mount.max_tip_share")
    return rep, [Check("mount.stiffness", "error", ok, msg, share, limit, {"part": mount.name}, fix=fix)]


MARGIN = 0.005     # a fix aims this share inside the allowable: the built strip is measured, not the plan's


OWN_WEIGHT_ELSE = ("lighter or fewer disks (disks.count, disks.thickness, disks.outer_diameter) or a lighter tensioner "
                   "(not tried): the weight beyond the base is what loads it")


def _bend_else(stress: float, bare: float) -> str:
    """What else bears on the bend's stress, untried."""
    if stress <= 1.2 * bare:
        return ""
    return (f"shorter hubs (disks.hub.length) or fewer disks (not tried): the disks' plates and hubs hold the strip "
            f"straight over part of its length, so the rest curves {stress / bare:.1f}× as much as a bare strip would")


def _fix_text(fixes: list[Fix], also: str) -> str:
    """The tried fixes in words, then what else bears on it (untried, said so)."""
    text = fix_text(fixes)
    return f"{text}. Also: {also}" if also else text


def _bend_check(study: _StripStudy, spans, I: float, part: str) -> tuple[dict, list[Check]]:
    """The strip bent to the check's sweep end against its allowable stress, MPa (``study``: the
    strip, its sweep and allowable)."""
    ang, allow, E, t, length = study.ang, study.allow, study.E, study.t, study.length
    stress, kappa = sag.bending_stress_under_uniform_moment(length, math.radians(ang), E, I, t, spans)
    bare = E * t / 2 * math.radians(ang) / length
    ok = stress <= allow
    msg = (f"bent {ang:g}° by the actuating pair (a moment uniform along the strip), the strip between the disks' "
           f"plates and hubs (measured) curves at {kappa * 1000:.2f} /m: {stress:.1f} MPa, "
           f"{'under' if ok else 'over'} the allowable {allow:g} MPa (a strip without hubs: {bare:.1f} MPa)")
    fixes = () if ok else tuple(study.bend_fixes(stress))
    return ({"angle_deg": ang, "stress_mpa": stress, "curvature_per_mm": kappa, "bare_stress_mpa": bare},
            [Check("backbone.bend_stress", "error", ok, msg, stress, allow, {"part": part, "angle_deg": ang},
                   fix="" if ok else _fix_text(fixes, _bend_else(stress, bare)), fixes=fixes)])


class _StripStudy:
    """The strip's two stress checks solved again at another strip (thickness, width) to say how far
    to change it: the own-weight stress (state N, :func:`sag.solve_sag`, the disks and the tip
    assembly as measured, the strip's own weight scaled with its section, the hubs as they are)
    falls as the strip thickens or widens; the stress of the bend to the sweep's end rises with
    the thickness and does not depend on the width. A few solves of the elastica: milliseconds."""

    def __init__(self, r: sag.SagResult, fits, E: float, h: float, e_print: float, ang: float, allow: float):
        """``r``: the worse own-weight case as solved (its loads, strip and gravity's direction)."""
        self.r, self.fits, self.E, self.h, self.e_print = r, fits, E, h, e_print
        self.length, self.t = r.loads.L, r.loads.strip.thickness
        self.ang, self.allow = ang, allow
        self.solved: dict[tuple[float, float], float] = {(self.t, h): r.max_stress}

    def own_weight(self, t: float, h: float | None = None) -> float:
        """The largest own-weight stress (MPa) with a strip ``t`` thick and ``h`` wide."""
        h = self.h if h is None else h
        if (t, h) not in self.solved:
            self.solved[(t, h)] = self._own_weight(t, h)
        return self.solved[(t, h)]

    def _own_weight(self, t: float, h: float) -> float:
        I = sag.second_moment(h, t)
        ld = self.r.loads
        section = sag.Strip(self.E, I, t, ld.strip.lin_density * t * h / (ld.strip.thickness * self.h))
        return sag.solve_sag(ld.L, ld.stations, ld.point_masses, section, tip=ld.tip,
                             spans=_spans(self.fits, self.length, self.E * I, self.e_print)).max_stress

    def bend(self, t: float, ang: float | None = None) -> float:
        """The largest stress (MPa) of the strip ``t`` thick bent ``ang``° (the sweep's end)."""
        I = sag.second_moment(self.h, t)
        return sag.bending_stress_under_uniform_moment(
            self.length, math.radians(self.ang if ang is None else ang), self.E, I, t,
            _spans(self.fits, self.length, self.E * I, self.e_print))[0]

    @staticmethod
    def _reach(stress, x: float, s: float, target: float, p: float, lo: float, hi: float) -> float | None:
        """Where ``stress(x)`` (monotone) comes down to ``target``, within [lo, hi], from ``x`` where
        it is ``s``: steps along the local power law stress ∝ x^p (``p`` guessed, then measured
        between the last two solves), to within 0.2 %; None when the range does not reach it."""
        for _ in range(8):
            nxt = min(max(x * (target / s) ** (1 / p), lo), hi)
            got = stress(nxt)
            if abs(got - target) <= 0.002 * target:
                return nxt
            if nxt in (lo, hi) and (got > target) == (s > target):
                return None                           # the end of the range does not get there
            if abs(math.log(nxt / x)) > 1e-9 and got > 0 and abs(math.log(got / s)) > 1e-9:
                p = math.log(got / s) / math.log(nxt / x)
            x, s = nxt, got
        return x

    def own_weight_fixes(self, stress: float) -> list[Fix]:
        """The own-weight stress over the allowable: a thicker or a taller strip, each solved again
        (the elastica with the disks' spans), with what the thicker one costs the bend."""
        a = self.allow
        target = a * (1 - MARGIN)
        t_need = self._reach(self.own_weight, self.t, stress, target, -2.0, self.t, 4 * self.t)
        h_need = self._reach(lambda h: self.own_weight(self.t, h), self.h, stress, target, -1.0, self.h, 4 * self.h)
        out = []
        if t_need is not None:
            t_need = math.ceil(t_need * 100) / 100
            got, bend = self.own_weight(t_need), self.bend(t_need)
            out.append(Fix({"backbone.thickness": t_need}, {"measured": got, "passed": got <= a, "limit": a},
                           ("backbone.bend_stress",) if bend > a >= self.bend(self.t) else (),
                           f"from {self.t:g} mm, solved again: {got:.1f} MPa; the bend to {self.ang:g}° then "
                           f"stresses it {bend:.0f} MPa (backbone.bend_stress)"))
        if h_need is not None:
            h_need = float(math.ceil(h_need))
            got = self.own_weight(self.t, h_need)
            out.append(Fix({"backbone.height": h_need}, {"measured": got, "passed": got <= a, "limit": a}, (),
                           f"from {self.h:g} mm, solved again: {got:.1f} MPa (the bend's stress does not depend on "
                           f"the width; the disks must hold the wider slot)"))
        return out

    def bend_fixes(self, stress: float) -> list[Fix]:
        """The bend's stress over the allowable: a thinner strip, or (a relaxation) a smaller sweep
        or a higher allowable, each solved again, with what the thinner one costs the own weight."""
        a = self.allow
        out = []
        t_max = self._reach(self.bend, self.t, stress, a * (1 - MARGIN), 1.0, self.t / 4, self.t)
        if t_max is not None:
            t_max = math.floor(t_max * 100) / 100
            got, weight = self.bend(t_max), self.own_weight(t_max)
            out.append(Fix({"backbone.thickness": t_max}, {"measured": got, "passed": got <= a, "limit": a},
                           ("gravity.strip_stress",) if weight > a >= self.r.max_stress else (),
                           f"from {self.t:g} mm, solved again: {got:.1f} MPa; its own weight then stresses it "
                           f"{weight:.0f} MPa (gravity.strip_stress)"))
        ang = float(math.floor(self.ang * a / stress))
        for _ in range(5):                   # the stress falls about as the angle: a step or two below
            got = self.bend(self.t, ang)
            if got <= a or ang <= 1:
                break
            ang = float(math.floor(ang * a / got)) if ang * a / got < ang else ang - 1
        out.append(Fix({"check.max_angle_deg": ang, "disks.eyelets.sweep_deg": ang},
                       {"measured": got, "passed": got <= a, "limit": a}, (),
                       f"bend it no further than ±{ang:g}° (from ±{self.ang:g}°), solved again: {got:.1f} MPa",
                       relax=True))
        out.append(Fix({"backbone.allowable_stress_mpa": float(math.ceil(stress * (1 + MARGIN)))},
                       {"measured": stress, "passed": True, "limit": float(math.ceil(stress * (1 + MARGIN)))}, (),
                       "only for a laminate of measured higher strength", relax=True))
        return out
