"""Parameters that pass the schema but describe no buildable robot: found before anything is
built, each with the field path to change (the CLI reports them as bad input, exit 2).

:func:`check` runs on the parameters alone; :func:`check_plan` on the plan, for what only the
sized holes tell (a tendon that crosses the strip or a disk so obliquely that no hole fits).
"""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from ..errors import DesignError, InputError, Problem
from ..params import Design
from .fixing import disk_gaps, disk_thicknesses, seat_diameter
from .fixtures import mount_problems
from .gear_choice import pin_bore
from .gearing import worm_pair
from .holes import straight_hole
from .materials import material_problem
from .routing import sample_function
from .specs import slot_size
from .tensioner_layout import spool_wall_problem
from .tensioner_layout.sizes import DRIVE_HEX, DRIVE_SHAFT, KEY_SOCKET_CLEARANCE, key_socket


SLOT = "the slot"       # the cause the problems of what stands in or around the strip's slot follow from


def problems(d: Design) -> list[tuple[str | tuple[str, ...], str] | Problem]:
    """(field path, what is wrong) for every reason this design cannot be built, in YAML order; a
    rule over several fields gives their paths, the one to change first. A slot that does not fit
    its disk is a :class:`Problem` whose ``cause`` the problems of what it leaves no room for
    (the eyelets between it and the rim, seats, screws) follow from."""
    out = []
    material = material_problem(d.process)
    if material:
        out.append(("process.material", material))
    out += _slot_problems(d) + _tendon_size_problems(d) + _mount_problems(d)
    ts = d.tensioner
    out += [(f"tensioner.{f}", m) for f, m in _gear_problems(worm_pair(ts, d.process.min_wall),
                                                             ts.friction_coefficient)]
    wall = spool_wall_problem(ts, d.process.min_wall)
    if wall:
        out.append(("tensioner.spool_diameter", wall))
    out += _drive_problems(d)
    out += _eyelets_outside(d)
    out += _spacing_problems(d)
    out += _anchor_problems(d)
    out += [Problem(p, m, follows=SLOT) for p, m in mount_problems(d)]    # its jaws hold the strip
    return out


@functools.lru_cache(maxsize=256)
def _gear_problems(pair, mu: float) -> tuple[tuple[str, str], ...]:
    """What the worm pair must not be built with, remembered per pair (a design sweep asks it of the
    same pair thousands of times). Tips thinner than the process's wall are not among them: that gear
    is built and its checks (``gear.tooth_tip``, ``gear.thread_tip``) fail."""
    return tuple(pair.refusals(mu))


def _drive_problems(d: Design) -> list[tuple[str, str]]:
    """Bores that break through what holds them: the key's socket through the drive shaft, the
    worm's bores (the shaft's hex end, the dowel's) through its core. A wall thinner than the
    process's is built, and ``gear.drive_wall`` and ``gear.bore_wall`` measure it."""
    ts = d.tensioner
    out = []
    socket = key_socket(ts.hex_key)
    if socket >= DRIVE_SHAFT:
        largest = math.ceil((DRIVE_SHAFT * math.sqrt(3) / 2 - KEY_SOCKET_CLEARANCE) * 10 - 1) / 10
        out.append(("tensioner.hex_key", f"a {ts.hex_key:g} mm key's socket ({socket:.2f} mm across corners) breaks "
                                         f"through the Ø{DRIVE_SHAFT:g} mm drive shaft it is cut in; use a key of at "
                                         f"most {largest:g} mm"))
    pair = worm_pair(ts, d.process.min_wall)
    if pair.rf1 > 0 and pair.bore_wall(DRIVE_HEX, pin_bore(ts)) <= 0:
        out.append(("tensioner.worm_pitch_diameter",
                    f"the worm's core (root Ø{2 * pair.rf1:.2f} mm) is smaller than the bores it takes: the drive "
                    f"shaft's {DRIVE_HEX:g} mm hex end ({2 * DRIVE_HEX / math.sqrt(3):.2f} mm across corners) and "
                    f"the Ø{pin_bore(ts):g} mm bore of the dowel it turns on; use a larger worm_pitch_diameter"))
    return out


def _spacing_problems(d: Design) -> list[tuple[str, str]]:
    """Neighbouring disks must not overlap (a hub cut short is a finding of the checks, not this)."""
    for i, gap in enumerate(disk_gaps(d)):
        if gap <= 0:
            where = (f"disks.stations[{i + 1}]" if d.disks.stations is not None else
                     "disks.spacing" if d.disks.spacing is not None else "disks.count")
            return [((where, "backbone.length", "disks.thickness", "disks.end_thickness"), f"disk {i} and disk {i + 1} overlap: their stations are "
                            f"{d.stations[i + 1] - d.stations[i]:g} mm apart and they are "
                            f"{disk_thicknesses(d)[i] / 2 + disk_thicknesses(d)[i + 1] / 2:g} mm thick "
                            f"between their mid-planes (disks.thickness, disks.end_thickness)")]
    return []


def _anchor_problems(d: Design) -> list[tuple[str, str]]:
    """Every termination larger than the smallest seat the process prints; no tendon starting inside
    the strip's slot. (The seat plate is less than half the base disk (:mod:`hwgen.params`); the
    chambers over it are laid out short of the mid-plane: :func:`hwgen.model.fixing.chamber_height`.)"""
    out = []
    seat = seat_diameter(d)
    terms = [("tendon_material.termination", "", d.tendon_material.termination)]
    terms += [(f"tendons[{i}].termination", f"{t.name}: ", t.termination) for i, t in enumerate(d.tendons)
              if t.termination]
    for path, whose, t in terms:
        if t.diameter <= seat:
            out.append((f"{path}.diameter", f"{whose}a {t.diameter:g} mm {t.kind} pulls through the smallest seat the "
                                            f"process makes, Ø{seat:g} mm (process.min_hole, tendon and hole clearance)"))
    half_w = d.backbone.height / 2 + d.disks.slot_clearance
    half_t = d.backbone.thickness / 2 + d.disks.slot_clearance
    for i, t in enumerate(d.tendons):
        table = t.routing.table
        x, z = (table[0] if table is not None else sample_function(t.routing.function, d.stations,
                                                                   d.backbone.length)[0])
        for name, zz in zip(t.names, (z, -z)):
            if abs(x) <= half_w and abs(zz) <= half_t:
                out.append(Problem(f"tendons[{i}].routing", f"{name} starts inside the strip's slot at the base disk "
                                                            f"(x={x:g}, z={zz:g}): it has no seat there", follows=SLOT))
    return out


def _eyelets_outside(d: Design) -> list[tuple[str, str]]:
    """Eyelets (as the geometry will use them: table first, else the function) beyond the disk's rim."""
    r_out = d.disks.outer_diameter / 2
    hole = straight_hole(d.tendon_material.diameter, d.process.hole_clearance, d.process.min_hole)
    out = []
    for i, t in enumerate(d.tendons):
        table = t.routing.table
        pts = np.asarray(table, dtype=float) if table is not None else sample_function(
            t.routing.function, d.stations, d.backbone.length)
        r = np.hypot(pts[:, 0], pts[:, 1])
        over = np.flatnonzero(r + hole / 2 >= r_out)        # the first eyelet outside, or whose hole breaks out
        if not over.size:
            continue
        j = int(over[0])
        x, z = (float(v) for v in pts[j])
        p = f"tendons[{i}].routing.table[{j}]" if table is not None else f"tendons[{i}].routing.function"
        p = (p, "disks.outer_diameter")
        eyelet = f"{t.name}'s eyelet at station {j} (x={x:g}, z={z:g})"
        if r[j] >= r_out:
            out.append((p, f"{eyelet} lies outside the disk (radius {r_out:g} mm)"))
        else:
            out.append((p, f"{eyelet} needs a hole of at least Ø{hole:g} mm "
                           f"for the Ø{d.tendon_material.diameter:g} mm tendon, which breaks through the rim "
                           f"(radius {r_out:g} mm)"))
    return out


MAX_MOUNT_HOLES = 32


def _slot_problems(d: Design) -> list[tuple[str, str]]:
    """The strip's slot (strip plus clearance) must leave a wall all round inside the disk: the one
    rule that the slot fits the disk."""
    dk, wall = d.disks, d.process.min_wall
    w, h = slot_size(d.backbone.height, d.backbone.thickness, dk.slot_clearance)
    r = dk.outer_diameter / 2
    if math.hypot(w / 2, h / 2) + wall <= r:
        return []
    if w / 2 >= r:
        return [Problem(("disks.outer_diameter", "backbone.height"),
                        f"{dk.outer_diameter} mm does not enclose the backbone slot ({w:g} mm)", cause=SLOT)]
    field = "backbone.thickness" if w / 2 + wall < r else "disks.outer_diameter"
    return [Problem((field, "disks.outer_diameter", "backbone.height", "disks.slot_clearance"),
                    f"the backbone slot ({w:g} × {h:g} mm: the strip and disks.slot_clearance) reaches past "
                    f"the rim of the Ø{dk.outer_diameter:g} mm disk, or leaves less than "
                    f"process.min_wall = {wall:g} mm of it", cause=SLOT)]


def _tendon_size_problems(d: Design) -> list[tuple[str, str]]:
    """A tendon whose straight eyelet, with walls, does not fit between the slot and the rim."""
    dk = d.disks
    room = dk.outer_diameter / 2 - (d.backbone.thickness / 2 + dk.slot_clearance)
    hole = straight_hole(d.tendon_material.diameter, d.process.hole_clearance, d.process.min_hole)
    if hole + 2 * d.process.min_wall <= room:
        return []
    return [Problem(("tendon_material.diameter", "disks.outer_diameter", "process.hole_clearance"),
                    f"a Ø{d.tendon_material.diameter:g} mm tendon needs eyelets of at least Ø{hole:g} mm "
                    f"(with process.hole_clearance); with {d.process.min_wall:g} mm walls they do not fit between "
                    f"the backbone slot and the rim of a Ø{dk.outer_diameter:g} mm disk", follows=SLOT)]


def _mount_problems(d: Design) -> list[tuple[str, str]]:
    """The tip disk's bolt holes must lie inside the disk and clear of the backbone slot."""
    dk, tm = d.disks, d.disks.tip_mount
    if tm.positions is None:
        return []                       # derived by the plan, clear of the slot
    if len(tm.positions) > MAX_MOUNT_HOLES:
        return [("disks.tip_mount.positions", f"{len(tm.positions)} holes; at most {MAX_MOUNT_HOLES}")]
    r_out = dk.outer_diameter / 2
    half_w = d.backbone.height / 2 + dk.slot_clearance
    half_h = d.backbone.thickness / 2 + dk.slot_clearance
    r = tm.hole_diameter / 2
    for i, (x, z) in enumerate(tm.positions):
        where = f"disks.tip_mount.positions[{i}]"
        if math.hypot(x, z) + r >= r_out:
            return [(where, f"a Ø{tm.hole_diameter:g} mm hole at (x={x:g}, z={z:g}) breaks through the rim of "
                            f"the Ø{dk.outer_diameter:g} mm tip disk")]
        if math.hypot(max(abs(x) - half_w, 0.0), max(abs(z) - half_h, 0.0)) < r:
            return [Problem(where, f"a Ø{tm.hole_diameter:g} mm hole at (x={x:g}, z={z:g}) cuts into the backbone "
                                   f"slot", follows=SLOT)]
    return []


def tendon_field(d: Design, name: str) -> str:
    """The YAML field that places tendon ``name`` (its table if it has one, else its function);
    a mirrored tendon is placed by the tendon it mirrors."""
    for i, t in enumerate(d.tendons):
        if name in t.names:
            return f"tendons[{i}].routing.{'table' if t.routing.table is not None else 'function'}"
    return "tendons"


def plan_problems(plan, d: Design) -> list[tuple[str, str]]:
    """(field path, what is wrong) for holes the plan sized but no part can take: an eyelet
    that breaks through its disk's rim (a tendon that meets the disk almost edge-on: its hole
    grows as 1/cos α), a strip hole as wide as the strip (a strip narrower than the straight hole
    the tendon passes: the plan cuts an oblique crossing's hole at most half the strip, and
    backbone.hole_angle fails). ``d``: the design the plan was made from (the fields to name)."""
    out = []
    for disk in plan.disks:
        r_out = disk.outer_diameter / 2
        for h in disk.holes:
            if not math.isfinite(h.diameter) or math.hypot(h.x, h.z) + h.diameter / 2 >= r_out:
                dia = f"Ø{h.diameter:.3g} mm" if math.isfinite(h.diameter) else "endless"
                out.append((tendon_field(d, h.tendons[0]),
                            f"{'+'.join(h.tendons)} at station {disk.index} meets the disk at up to "
                            f"{h.worst_angle_deg:.0f}° to its eyelet's axis over the ±{d.disks.eyelets.sweep_deg:g}° "
                            f"sweep: the eyelet must be {dia} and breaks through the rim of the "
                            f"Ø{disk.outer_diameter:g} mm disk"))
                return out
    height = plan.backbone.height
    for h in plan.backbone.holes:          # the plan cuts them at most half the strip, but never below the
        if not math.isfinite(h.diameter) or h.diameter >= height:       # straight hole the tendon passes
            dia = f"a Ø{h.diameter:.3g} mm" if math.isfinite(h.diameter) else "an endless"
            out.append((tendon_field(d, h.tendon),
                        f"{h.tendon} crosses the backbone at station {h.station:g}, where the strip would need "
                        f"{dia} hole to let it through, wider than the {height:g} mm strip: route it "
                        f"not through the strip, or make the strip wider"))
            return out
    return out


def check_plan(plan, d: Design) -> None:
    """Raise :class:`DesignError` for the first of :func:`plan_problems`."""
    for path, message in plan_problems(plan, d):
        raise DesignError(path, message)


def check(d: Design, file: str | Path) -> None:
    """Raise one :class:`InputError` carrying every problem (in the order of :func:`problems`; a
    rule over several fields named by the first of them)."""
    found = problems(d)
    if found:
        found = [Problem(*p) for p in found]
        raise InputError.of([InputError(file, p.paths if isinstance(p.paths, str) else p.paths[0], p.message,
                                        p.cause, p.follows) for p in found])
