"""A driven tendon that slides through one opening with another tendon (``eyelet.shared_sliding``).

When the robot is driven, a tendon of the actuating channel slides through its eyelets at every
bend. Where another tendon passes the same opening of a disk, the two lines press on each other
there: the driven line saws across the other, wears it, and its friction on the other line couples
the actuation into it, the coupling the paper's independent tendons exist to avoid. No model here
says how much (the statics, the tension checks and the Monte Carlo treat each line in its own
hole), so the design must not rely on it: the check fails, naming both tendons and the disk. A
design may state it as a warning (``check.shared_sliding: warning``) with its reason in its file.

Seats where lines end (the base disk's seats, :mod:`hwgen.checks.anchors`) are not sliding: a
tendon seated on a disk does not count there. What counts as one opening is read from the files:
the measured hole each designed eyelet was matched to (:func:`hwgen.checks.eyelets.locate_eyelets`),
so eyelets routed into each other are one opening too.

The fix is tried on the measured holes: the other tendon's eyelets brought in toward the robot's
axis (the amplitude of a helix or of a cosine about it) until, at every disk, its hole clears
each driven tendon's by ``process.min_wall``; the check prints the radius that does so.
"""
from __future__ import annotations

import numpy as np

from .base import Check, Screen
from .eyelets import EyeletMap

SCALE_STEP = 0.005          # the tried fix's radial scale, in these steps down from 1
DRIVEN_RULE = "a tendon of the actuating channel (tensioner.actuating_channel)"


def driven_tendons(report: dict, actuating_channel: str) -> set[str]:
    """The tendons the drive moves: those of the actuating channel."""
    return {t["name"] for t in report["tendons"] if t["channel"] == actuating_channel}


def shared_openings(emap: EyeletMap, report: dict, driven: set[str]) -> list[tuple[int, str, str, str, float]]:
    """(station, part, driven tendon, other tendon, opening Ø) of every opening a driven tendon slides
    through with another sliding tendon, from the measured holes; a tendon seated on a disk is not
    sliding there."""
    out = []
    for disk in emap.disks:
        rd = next((r for r in report["disks"] if r["index"] == disk.station), {})
        seated = {s["tendon"] for s in rd.get("seats", [])}
        openings: dict[int, tuple[float, set[str]]] = {}
        for e in emap.eyelets:
            if e.station == disk.station and e.hole is not None:
                openings.setdefault(id(e.hole.loop), (e.hole.diameter, set()))[1].update(e.tendons)
        for dia, names in openings.values():
            sliding = names - seated
            for d in sorted(sliding & driven):
                for o in sorted(sliding - {d}):
                    if o in driven and o < d:
                        continue                  # two driven tendons: the pair named once
                    out.append((disk.station, disk.part, d, o, dia))
    return out


def _own_radius(emap: EyeletMap, name: str, station: int) -> float:
    """Half the designed diameter of a tendon's own eyelet at a disk (the hole it would have alone)."""
    ds = [e.design_diameter for e in emap.eyelets if e.station == station and name in e.tendons]
    return min(ds, default=0.0) / 2


def tried_radius(emap: EyeletMap, other: str, driven: set[str], min_wall: float) -> tuple[float, float] | None:
    """(the other tendon's largest eyelet radius now, the largest radius its eyelets may be brought
    in to so that at every disk its hole clears every driven tendon's by ``min_wall``), or None when
    no radius does (the route scaled toward the axis, measured positions, each hole at its designed
    size)."""
    stations = [d.station for d in emap.disks]
    p = emap.positions[other][stations]                                   # (n, 2)
    r_now = float(np.max(np.hypot(p[:, 0], p[:, 1])))
    if r_now <= 0:
        return None
    ro = np.array([_own_radius(emap, other, i) for i in stations])
    for f in np.arange(1.0 - SCALE_STEP, 0.0, -SCALE_STEP):
        q = p * f
        ok = True
        for d in driven - {other}:
            gap = np.hypot(*(q - emap.positions[d][stations]).T)
            need = ro + np.array([_own_radius(emap, d, i) for i in stations]) + min_wall
            if np.any(gap < need):
                ok = False
                break
        if ok:
            return r_now, float(r_now * f)
    return None


def sliding_checks(emap: EyeletMap, report: dict, actuating_channel: str, min_wall: float,
                   severity: str) -> list[Check]:
    """One failing check per disk and pair where a driven tendon shares an opening with another
    tendon that slides there; one passing check when there is none."""
    driven = driven_tendons(report, actuating_channel)
    found = shared_openings(emap, report, driven)
    if not found:
        return [Check("eyelet.shared_sliding", severity, True,
                      f"no driven tendon ({', '.join(sorted(driven)) or 'none'}) shares an opening with another "
                      f"tendon on any disk", 0, 0, {"tendons": sorted(driven)})]
    tried = {o: tried_radius(emap, o, driven, min_wall) for o in {f[3] for f in found}}
    out = []
    for station, part, d, o, dia in found:
        at = sorted({s for s, _, dd, oo, _ in found if (dd, oo) == (d, o)})
        t = tried[o]
        if t is None:
            fix = (f"route {o} clear of {d}'s eyelets (tendons[].routing: amplitude, phase or offset); no route of "
                   f"{o} brought in toward the axis clears them (tried on the measured holes)")
        else:
            fix = (f"route {o} clear of {d}: its eyelets brought in toward the robot's axis from r = {t[0]:.2f} to "
                   f"r ≤ {t[1]:.2f} mm (a helix's or a cosine's amplitude, tendons[].routing.function.a) clear every "
                   f"driven tendon's eyelet by process.min_wall {min_wall:g} mm at every disk (tried on the measured "
                   f"holes; rebuild and check the other walls); or another phase")
        if severity == "error":
            fix += "; or state it as a warning (check.shared_sliding: warning) with its reason in this design's file"
        msg = (f"{part}: {d} ({DRIVEN_RULE}) slides through one Ø{dia:.2f} mm opening with {o} (disks "
               f"{', '.join(map(str, at))}): the lines rub there and the rubbing couples actuation into {o}, "
               f"which no model here accounts for")
        out.append(Check("eyelet.shared_sliding", severity, False, msg, 2, 1,
                         {"part": part, "station": station, "tendons": [d, o]}, fix=fix,
                         lowered_by="check.shared_sliding" if severity == "warning" else ""))
    return out


# ---------------------------------------------------------------- on the plan alone

def sliding_screen(plan) -> list[Screen]:
    """``eyelet.shared_sliding`` foreseen on the plan: a driven tendon through one opening with
    another on the tip disk (its eyelets turned toward the drums), at the check's severity."""
    tip = plan.disks[-1]
    driven = {p.name for p in plan.paths if p.channel == plan.tensioner.actuating_channel}
    slide = [m for m in plan.merges if m.station == tip.index and driven & set(m.tendons) and len(m.tendons) > 1]
    if not slide:
        return []
    return [Screen("eyelet.shared_sliding", "a driven tendon slides through one opening with another on the "
                                            "tip disk (its eyelets turned toward the drums): "
                   + "; ".join("+".join(m.tendons) for m in slide), plan.check.shared_sliding, 2, 1)]
