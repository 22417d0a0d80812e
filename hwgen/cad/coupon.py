"""The calibration coupon's solid (:mod:`hwgen.model.coupon` says what is on it): a plate with
a row of holes and a row of slots cut in one sketch, each with its value engraved below it
(CadQuery's text, cut in one boolean: the glyphs' curves make it the costly step)."""
from __future__ import annotations

from ..model.coupon import CouponSpec

ENGRAVE_OVERSHOOT_MM = 0.1     # the glyphs stand this far above the top face, so the cut leaves no skin


def build_coupon(spec: CouponSpec):
    """The coupon as a cadquery.Solid, its bottom on z = 0 (its print orientation)."""
    import cadquery as cq

    w, h, t = spec.size
    sketch = cq.Sketch().push([(w / 2, h / 2)]).rect(w, h)
    for f in spec.features:
        if f.kind == "hole":
            sketch = sketch.push([(f.x, f.y)]).circle(f.diameter / 2, mode="s")
        else:
            sketch = sketch.push([(f.x, f.y)]).rect(f.width, f.length, mode="s")
    body = cq.Workplane("XY").placeSketch(sketch.reset()).extrude(t).val()
    glyphs = []
    for f in spec.features:
        glyphs += (cq.Workplane("XY").workplane(offset=t - spec.engrave_mm).center(f.x, f.label_y)
                   .text(f.label, spec.text_mm, spec.engrave_mm + ENGRAVE_OVERSHOOT_MM, halign="center",
                         valign="bottom", combine=False).vals())
    return body.cut(*glyphs) if glyphs else body
