"""The calibration coupon, as numbers: the design's eyelet hole and its strip slot, each in
steps around the design value, with where each feature and its label go (numpy only).

Print it first, on the same printer and resin: a tendon through each hole, the strip's edge in
each slot, say which fit, and set the YAML from that (README, "The calibration coupon").

Holes step around the design's most used eyelet diameter (on the prototype the 0.8 mm that
``process.min_hole`` sets); slots around ``disks.slot_clearance`` a side, each as wide as the
strip's thickness plus twice its clearance. A step that would make a hole or a clearance of
zero or less is left out. The coupon is as thick as an inner disk, so its holes print through
the same resin depth as the eyelets.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

PITCH_MM = 11.0          # between neighbouring features (and their labels) along x
MARGIN_MM = 3.0          # from the coupon's edge
LABEL_GAP_MM = 2.0       # between a feature and the label below it


@dataclass(frozen=True)
class CouponFeature:
    kind: str            # "hole" or "slot"
    label: str           # the number engraved below it: a hole's diameter, a slot's clearance a side, mm
    value: float         # that number
    x: float             # the feature's centre on the coupon, mm
    y: float
    diameter: float = 0.0       # hole
    width: float = 0.0          # slot: across (the strip's thickness plus twice the clearance)
    length: float = 0.0         # slot: along y
    label_y: float = 0.0        # bottom of the label's text


@dataclass(frozen=True)
class CouponSpec:
    size: tuple[float, float, float]     # x, y, thickness, mm
    features: tuple[CouponFeature, ...]
    text_mm: float
    engrave_mm: float
    design_hole: float
    design_clearance: float
    strip_thickness: float


def label(v: float) -> str:
    """A number as short as it reads exactly (0.8, 0.75, 0.025)."""
    return f"{v:.3f}".rstrip("0").rstrip(".")


def coupon_spec(plan, d) -> CouponSpec:
    """The coupon of a plan (its eyelet holes) and the design it was made from (``d``: its coupon,
    process, disks and backbone sections)."""
    c = d.coupon
    diameters = Counter(round(h.diameter, 3) for disk in plan.disks for h in disk.holes)
    hole = max(diameters, key=lambda v: (diameters[v], -v)) if diameters else d.process.min_hole
    clearance, t = d.disks.slot_clearance, d.backbone.thickness
    ks = range(-c.steps, c.steps + 1)
    holes = [round(hole + k * c.hole_step_mm, 3) for k in ks if hole + k * c.hole_step_mm > 0]
    clears = [round(clearance + k * c.slot_step_mm, 4) for k in ks if clearance + k * c.slot_step_mm >= 0]
    n = max(len(holes), len(clears))
    width = 2 * MARGIN_MM + n * PITCH_MM
    slot_label_y = MARGIN_MM
    slot_y = slot_label_y + c.text_mm + LABEL_GAP_MM + c.slot_length_mm / 2
    hole_label_y = slot_y + c.slot_length_mm / 2 + LABEL_GAP_MM
    hole_y = hole_label_y + c.text_mm + LABEL_GAP_MM + max(holes) / 2
    height = hole_y + max(holes) / 2 + MARGIN_MM
    x0 = MARGIN_MM + PITCH_MM / 2
    feats = [CouponFeature("hole", label(v), v, x0 + i * PITCH_MM, hole_y, diameter=v, label_y=hole_label_y)
             for i, v in enumerate(holes)]
    feats += [CouponFeature("slot", label(v), v, x0 + i * PITCH_MM, slot_y, width=t + 2 * v, length=c.slot_length_mm,
                            label_y=slot_label_y) for i, v in enumerate(clears)]
    thickness = min((disk.thickness for disk in plan.disks if disk.role == "inner"), default=d.disks.thickness)
    return CouponSpec((width, height, thickness), tuple(feats), c.text_mm, c.engrave_mm, hole, clearance, t)
