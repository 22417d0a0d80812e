"""The hole a tendon needs through a wall (numpy only): the one rule the plan sizes eyelets, strip
holes and seats by, and the checks measure them against."""
from __future__ import annotations

import numpy as np

AXIS_CUT_FRACTION = 1 / 8   # the checks find an eyelet's axis from cuts this share of the disk's thickness off
#                             its mid-plane (hwgen.checks.eyelets): the bore is plain there, no chamfer reaches in


def hole_diameter(d: float, thickness: float, alpha: float, clearance: float = 0.0, minimum: float = 0.0) -> float:
    """Smallest hole a tendon of diameter d passes at angle alpha (rad) to the hole's axis through a
    wall this thick without touching its edges, d/cos α + T tan α, plus ``clearance``; never under
    ``minimum``. The checks ask it without clearance or minimum: what the tendon itself needs.
    Elementwise over arrays of thickness and alpha (the sweep's lengths level sizes many at once)."""
    return np.maximum(minimum, d / np.cos(alpha) + thickness * np.tan(alpha) + clearance)


def straight_hole(d: float, clearance: float, minimum: float) -> float:
    """The hole a tendon of diameter d passes straight (α = 0): the smallest eyelet the plan makes,
    and a seat's opening."""
    return float(hole_diameter(d, 0.0, 0.0, clearance, minimum))
