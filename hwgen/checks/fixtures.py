"""The base mount and the jig, measured from their files against the strip and the disks they hold.

``mount.clamp``: how much of the strip the mount's jaws clamp beyond the base disk's outer face
(the strip's file against the upper jaw's), against what the jaws' two rows of screws need.
``mount.foot``: the height from the table (the mount's underside) to the strip's underside, against
what a full foot under a lower jaw deep enough for its nut traps needs. ``jig.hold``: how much of
each disk's face the jig's walls cover just beyond the disk's slot, on both sides: what keeps the
disk at its station while the adhesive cures. Each failing check names the YAML value to change
and the least value that works; the least sizes are the model's (design data).
"""
from __future__ import annotations

import math

import numpy as np

from ..model.fixtures import FOOT_THICKNESS, JIG_CLEAR, JIG_ENGAGE
from .base import REBUILD, Check
from .sections import chain_loops, section_robot

CHEEK_MM = 0.25          # the jig is cut this far beyond each end of a disk's slot in it
JIG_HOLD_MM2 = JIG_ENGAGE ** 2   # the least face area each side of a disk a wall must cover, mm²


def _one(parts, role: str):
    return next((p for p in parts if p.role == role), None)


def mount_checks(parts, disks, plan) -> list[Check]:
    """``mount.clamp`` and ``mount.foot`` of the built mount (none when it, the strip or the base
    disk is missing). ``disks``: the measured disks (:class:`hwgen.checks.eyelets.DiskSections`)."""
    clamp, mount, strip = _one(parts, "base_clamp"), _one(parts, "base_mount"), _one(parts, "backbone")
    base = next((dk for dk in disks if dk.station == 0), None)
    if clamp is None or mount is None or strip is None or base is None:
        return []
    lay = plan.mount.rules
    sb, cb, mb = strip.robot_bounds(), clamp.robot_bounds(), mount.robot_bounds()
    face = base.y_mid - base.thickness / 2                      # the base disk's outer face
    held = max(0.0, min(face, float(cb[1, 1])) - max(float(sb[0, 1]), float(cb[0, 1])))
    need = lay.least_clamp
    least = need - face
    where = {"part": clamp.name}
    text = (f"{clamp.name}: the jaws clamp {held:.2f} mm of the strip beyond the base disk; their two rows "
            f"of screws need {need:g} mm")
    ok = held >= need - 1e-6
    fix = ""
    if not ok:
        given = f" (it is {lay.extra_base:g})" if lay.extra_base is not None else ""
        fix = (f"a longer strip below the base disk: backbone.extra_base ≥ {least:.2f} mm{given}, "
               f"{need - held:.2f} mm more")
    out = [Check("mount.clamp", "error", ok, text, held, need, where, fix=fix)]
    below = float(sb[0, 2]) - float(mb[0, 2])                     # table to the strip's underside
    need = lay.least_below_strip
    text = (f"{mount.name}: {below:.2f} mm from the table to the strip's underside; a {FOOT_THICKNESS:g} mm foot "
            f"under a lower jaw deep enough for its nut traps needs {need:.2f} mm")
    ok = below >= need - 1e-6
    fix = "" if ok else (f"the table farther below the disks: base_mount.table_clearance ≥ "
                         f"{lay.table_clearance + need - below:.2f} mm (it is {lay.table_clearance:g}), "
                         f"{need - below:.2f} mm more")
    out.append(Check("mount.foot", "error", ok, text, below, need, {"part": mount.name}, fix=fix))
    return out


def _area(loops: list[np.ndarray]) -> object:
    import manifold3d as m3d
    return m3d.CrossSection([np.ascontiguousarray(lp, dtype=float) for lp in loops], m3d.FillRule.EvenOdd)


def jig_checks(parts, disks, plan) -> list[Check]:
    """``jig.hold``: the least face area the jig's walls cover on either side of any disk, from the
    jig pieces' sections just beyond each disk's slot and the disk's measured outline.
    ``disks``: the measured disks (:class:`hwgen.checks.eyelets.DiskSections`); from the plan, the
    y range of each station's slot in the jig (design data: where its cheeks begin) and, for the
    fix, where the walls stand and what they keep clear of."""
    pieces = [p for p in parts if p.role == "jig"]
    if not pieces or not disks:
        return []
    slots = plan.jig.slots
    bounds = [p.robot_bounds() for p in pieces]
    worst = None
    for dk in disks:
        disk = _area([dk.outline.points])
        covered = []
        lo, hi = slots[dk.station]
        for y in (lo - CHEEK_MM, hi + CHEEK_MM):
            loops = []
            for p, b in zip(pieces, bounds):
                if b[0, 1] < y < b[1, 1]:
                    segs = section_robot(p.mesh, p.placement, 1, y)
                    loops += chain_loops(segs[:, :, [0, 2]]) if len(segs) else []
            covered.append((disk ^ _area(loops)).area() if loops else 0.0)
        least = min(covered)
        if worst is None or least < worst[0]:
            worst = (least, dk.part)
    least, part = worst
    ok = least >= JIG_HOLD_MM2
    text = (f"jig: its walls cover at least {least:.1f} mm² of each disk's face either side of its slot "
            f"(least: {part}; a wall needs {JIG_HOLD_MM2:g} mm² to hold a disk square)")
    if not ok:
        text += "; the strip and its hubs leave the walls no room beside or under them"
    return [Check("jig.hold", "error", ok, text, least, JIG_HOLD_MM2, {"part": part},
                  fix="" if ok else _jig_fix(plan))]


def _jig_fix(plan) -> str:
    """What puts the walls beside the disks' rims (JIG_ENGAGE of each, clear of the strip and the
    hubs by JIG_CLEAR): the least disk diameter, or the thickest hub wall, that leaves them room."""
    lay = plan.jig
    if not lay.low:                    # the walls already take JIG_ENGAGE of every rim beside the strip
        return f"hwgen stands the jig's walls {JIG_ENGAGE:g} mm into each disk's rim: {REBUILD}"
    spec = next((s for s in plan.disks if s.hub is not None), plan.disks[0])
    wall = spec.hub.wall if spec.hub is not None else 0.0
    hub_x = spec.slot_width / 2 + wall                  # the hubs' sides (the strip's edges lie inside them)
    od = spec.outer_diameter
    least_od = math.ceil(2 * (hub_x + JIG_CLEAR + JIG_ENGAGE) * 10 - 1e-6) / 10
    fix = (f"a wider disk, so the walls stand beside the strip and the hubs: disks.outer_diameter ≥ "
           f"{least_od:.1f} mm (it is {od:g}), {least_od - od:.1f} mm more")
    thickest = lay.x_inner - JIG_CLEAR - spec.slot_width / 2     # the hub wall that leaves them room
    if thickest >= plan.min_wall:                      # and still a wall the process prints
        fix += f"; or thinner hubs: disks.hub.wall ≤ {thickest:.2f} mm (it is {wall:g})"
    return fix
