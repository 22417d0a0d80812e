"""The carbon-fibre strip as a solid, with a hole wherever a tendon crosses it."""
from __future__ import annotations

import cadquery as cq
import numpy as np

from ..design import BackboneSpec
from . import Part, placement

COLOR = (0.12, 0.12, 0.13, 1.0)   # carbon black
SAME_HOLE_MM = 1e-6


def unique_holes(spec: BackboneSpec) -> list[tuple[float, float, float, tuple[str, ...]]]:
    """Holes merged by position: (x, y, largest diameter, tendons)."""
    out: list[list] = []
    for h in spec.holes:
        for u in out:
            if abs(u[0] - h.x) < SAME_HOLE_MM and abs(u[1] - h.y) < SAME_HOLE_MM:
                u[2] = max(u[2], h.diameter)
                u[3] += (h.tendon,)
                break
        else:
            out.append([h.x, h.y, h.diameter, (h.tendon,)])
    return [tuple(u) for u in out]


def build_backbone(spec: BackboneSpec) -> Part:
    """File coordinates: X = x, Y = y - y_start, Z = z + t/2 (the strip lies flat on Z = 0)."""
    length = spec.y_end - spec.y_start
    sk = cq.Sketch().push([(0, length / 2)]).rect(spec.height, length)
    for x, y, dia, _ in unique_holes(spec):
        sk = sk.push([(x, y - spec.y_start)]).circle(dia / 2, mode="s")
    solid = cq.Workplane("XY").placeSketch(sk.reset().clean()).extrude(spec.thickness).val()
    return Part(spec.name, "backbone", solid,
                placement(np.eye(3), [0.0, spec.y_start, -spec.thickness / 2]), COLOR)
