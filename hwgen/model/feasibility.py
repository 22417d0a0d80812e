"""Parameters that pass the schema but describe no buildable robot: found before anything is
built, each with the field path to change (the CLI reports them as bad input, exit 2)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..params import Design
from .fixing import CHAMBER_HEIGHT_MM, hub_extension, hub_side, seat_diameter
from .fixtures import mount_problems
from .gearing import worm_pair
from .materials import material_problem
from .routing import sample_function
from .tensioner_layout import spool_wall_problem

HUB_GAP_MM = 1.0            # the least gap between a hub's end and the next disk
EYELET_CUT_FRACTION = 1 / 8  # the checks cut a disk this share of its thickness off its mid-plane (keep clear)


def problems(d: Design) -> list[tuple[str, str]]:
    """(field path, what is wrong) for every reason this design cannot be built, in YAML order."""
    out = []
    material = material_problem(d.process)
    if material:
        out.append(("process.material", material))
    ts = d.tensioner
    out += [(f"tensioner.{f}", m) for f, m in worm_pair(ts).problems(ts.friction_coefficient, d.process.min_wall)]
    wall = spool_wall_problem(ts, d.process.min_wall)
    if wall:
        out.append(("tensioner.spool_diameter", wall))
    core = ts.worm_pitch_diameter - 2.5 * ts.module
    if ts.hex_key / math.cos(math.pi / 6) + 2 * d.process.min_wall >= core:
        out.append(("tensioner.hex_key", f"a {ts.hex_key:g} mm hex socket does not fit in the worm's core "
                                         f"({core:g} mm) with {d.process.min_wall:g} mm walls"))
    out += _eyelets_outside(d)
    out += _hub_problems(d)
    out += _anchor_problems(d)
    out += mount_problems(d)
    return out


def _hub_problems(d: Design) -> list[tuple[str, str]]:
    """Each hub must end short of the next disk (or of that disk's own hub)."""
    st = d.stations
    n = len(st)
    thick = [d.disks.end_thickness if i in (0, n - 1) else d.disks.thickness for i in range(n)]
    reach = []
    for i in range(n):
        role = "base" if i == 0 else "tip" if i == n - 1 else "inner"
        side, ext = hub_side(role), hub_extension(d, thick[i])
        reach.append((st[i] - thick[i] / 2 - (ext if side < 0 else 0.0),
                      st[i] + thick[i] / 2 + (ext if side > 0 else 0.0)))
    field = "disks.hub.length" if d.disks.hub.length is not None else "disks.hub.max_tilt_deg"
    for i in range(n - 1):
        gap = reach[i + 1][0] - reach[i][1]
        if gap < HUB_GAP_MM:
            return [(field, f"disk {i} and disk {i + 1} with their hubs leave {gap:.2f} mm between them "
                            f"(at least {HUB_GAP_MM:g} mm): the hubs are {hub_extension(d, d.disks.thickness):.2f} mm "
                            f"long for a slot clearance of {d.disks.slot_clearance:g} mm")]
    return []


def _anchor_problems(d: Design) -> list[tuple[str, str]]:
    """Every termination larger than the smallest seat the process prints; the seat plate clear of the
    eyelets' measuring cuts; no tendon starting inside the strip's slot."""
    out = []
    seat = seat_diameter(d)
    terms = [("tendon_material.termination", d.tendon_material.termination)]
    terms += [(f"tendons[{i}].termination", t.termination) for i, t in enumerate(d.tendons) if t.termination]
    for path, t in terms:
        if t.diameter <= seat:
            out.append((f"{path}.diameter", f"a {t.diameter:g} mm {t.kind} pulls through the smallest seat the process "
                                            f"makes, Ø{seat:g} mm (process.min_hole, tendon and hole clearance)"))
    T = d.disks.end_thickness
    room = T / 2 - T * EYELET_CUT_FRACTION
    if d.disks.anchors.plate + CHAMBER_HEIGHT_MM >= room:
        out.append(("disks.anchors.plate", f"{d.disks.anchors.plate:g} mm of seat plate and the chamber over it reach "
                                           f"into the base disk's eyelets ({room:g} mm from its face are free)"))
    half_w = d.backbone.height / 2 + d.disks.slot_clearance
    half_t = d.backbone.thickness / 2 + d.disks.slot_clearance
    for i, t in enumerate(d.tendons):
        table = t.routing.table
        x, z = (table[0] if table is not None else sample_function(t.routing.function, d.stations,
                                                                   d.backbone.length)[0])
        for zz in {z, -z} if t.routing.mirror else {z}:
            if abs(x) <= half_w and abs(zz) <= half_t:
                out.append((f"tendons[{i}].routing", f"starts inside the strip's slot at the base disk "
                                                     f"(x={x:g}, z={zz:g}): it has no seat there"))
    return out


def _eyelets_outside(d: Design) -> list[tuple[str, str]]:
    """Eyelets (as the geometry will use them: table first, else the function) beyond the disk's rim."""
    r_out = d.disks.outer_diameter / 2
    out = []
    for i, t in enumerate(d.tendons):
        table = t.routing.table
        pts = np.asarray(table, dtype=float) if table is not None else sample_function(
            t.routing.function, d.stations, d.backbone.length)
        for j, (x, z) in enumerate(pts):
            if math.hypot(x, z) >= r_out:
                p = f"tendons[{i}].routing.table[{j}]" if table is not None else f"tendons[{i}].routing.function"
                out.append((p, f"eyelet at station {j} (x={x:g}, z={z:g}) lies outside the disk "
                               f"(radius {r_out:g} mm)"))
                break
    return out


def check(d: Design, file: str | Path) -> None:
    """Raise :class:`InputError` for the first problem (the order of :func:`problems`)."""
    for path, message in problems(d):
        raise InputError(file, path, message)
