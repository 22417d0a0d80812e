"""The carbon-fibre strip as a solid, with a hole wherever a tendon crosses it."""
from __future__ import annotations

import cadquery as cq
import numpy as np

from ..model.specs import BackboneSpec
from . import Part, placement

COLOR = (0.12, 0.12, 0.13, 1.0)   # carbon black


def build_backbone(spec: BackboneSpec) -> Part:
    """File coordinates: X = x, Y = y - y_start, Z = z + t/2 (the strip lies flat on Z = 0)."""
    length = spec.y_end - spec.y_start
    sk = cq.Sketch().push([(0, length / 2)]).rect(spec.height, length)
    for x, y, dia, _ in spec.merged_holes():
        sk = sk.push([(x, y - spec.y_start)]).circle(dia / 2, mode="s")
    solid = cq.Workplane("XY").placeSketch(sk.reset().clean()).extrude(spec.thickness).val()
    return Part(spec.name, "backbone", solid,
                placement(np.eye(3), [0.0, spec.y_start, -spec.thickness / 2]), COLOR,
                material=f"carbon-fibre/epoxy laminate, {spec.thickness:g} mm", density_g_cm3=spec.density_g_cm3)
