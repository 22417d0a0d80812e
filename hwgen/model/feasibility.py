"""Parameters that pass the schema but describe no buildable robot: found before anything is
built, each with the field path to change (the CLI reports them as bad input, exit 2)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..params import Design
from .gearing import worm_pair
from .materials import material_problem
from .routing import sample_function
from .tensioner_layout import spool_wall_problem


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
