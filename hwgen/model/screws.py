"""Where the screws that hold an end disk go: derived for the robot at hand (numpy only).

The base disk bolts to the base mount's jaws and the tip disk to the tensioner's base bars, each
with four M3 screws along the backbone. The prototype's YAML once fixed their (x, z); on another
robot those places can fall on an eyelet, a seat or the hub. Here they are searched for instead:
one screw per quadrant of the disk face (x < 0 or > 0, above or below the strip), each at the
grid point of its quadrant's allowed band that keeps the most clearance from everything the disk
carries (up to MARGIN_CAP_MM; beyond that, clearance buys nothing), then the widest stance along x
(four screws far apart hold the disk against roll and yaw), then the middle of its band in z.

A quadrant with no point that keeps every clearance still gets its best point: the disk is built
with it and the checks that measure the files (eyelet walls, rim, interference) fail naming the
part. The YAML may still give the positions (``base_mount.disk_screws``, ``disks.tip_mount.positions``):
then they are used as given.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import hardware

GRID_MM = 0.5            # the search grid on the disk face ...
GRID_POINTS = 400        # ... coarser where a band is longer than this many steps (a disk over 200 mm across)
MARGIN_CAP_MM = 1.0      # clearance beyond what is required that still counts toward a better place
MARGIN_STEP_MM = 0.05    # clearances this close count as equal, and the wider stance decides
WASHER_OD = hardware.size("washer", "M3", "outer_diameter")   # ISO 7089 M3 washer under each head: what must clear
#                                                               the eyelets and the hub


@dataclass(frozen=True)
class Keepout:
    """What a screw must stay clear of on a disk face, as circles and centred rectangles.

    ``circles``: (x, z, radius, gap), a screw's centre must stay radius + gap away from (x, z);
    ``boxes``: (half_x, half_z, gap), a centred rectangle (the slot, the hub) the centre keeps gap
    outside of.
    """

    circles: tuple[tuple[float, float, float, float], ...]
    boxes: tuple[tuple[float, float, float], ...]

    def margin(self, x: np.ndarray, z: np.ndarray) -> np.ndarray:
        """How far each point is beyond every required clearance, mm (negative: too close)."""
        m = np.full(np.shape(x), np.inf)
        for cx, cz, r, gap in self.circles:
            m = np.minimum(m, np.hypot(x - cx, z - cz) - r - gap)
        for hx, hz, gap in self.boxes:
            dx, dz = np.abs(x) - hx, np.abs(z) - hz
            outside = np.hypot(np.maximum(dx, 0), np.maximum(dz, 0))
            inside = np.minimum(np.maximum(dx, dz), 0)         # negative inside the rectangle
            m = np.minimum(m, outside + inside - gap)
        return m


def place(keep: Keepout, bands: tuple[tuple[float, float], tuple[float, float]], x_max: float,
          rim: float) -> tuple[tuple[float, float], ...]:
    """Four screw centres (x, z): in each of the two z ``bands`` (one above the strip, one below),
    one at x > 0 and one at x < 0, with |x| ≤ ``x_max`` and within ``rim`` of the disk's centre."""
    out = []
    for z0, z1 in bands:
        for sx in (1.0, -1.0):
            step = max(GRID_MM, max(x_max, z1 - z0, 0.0) / GRID_POINTS)
            xs = np.arange(0.0, max(x_max, 0.0) + 1e-9, step) * sx
            zs = np.arange(math.ceil(z0 / step) * step, z1 + 1e-9, step)
            if len(zs) == 0:
                zs = np.array([(z0 + z1) / 2])
            X, Z = np.meshgrid(xs, zs)
            margin = np.minimum(keep.margin(X, Z), rim - np.hypot(X, Z))
            score = np.minimum(margin, MARGIN_CAP_MM)
            mid = (z0 + z1) / 2
            # lexicographic: clearance (to the grid's resolution), then the widest x, then nearest mid-band
            key = np.round(score / MARGIN_STEP_MM) * 1e6 + np.abs(X) * 1e2 - np.abs(Z - mid)
            k = np.unravel_index(int(np.argmax(key)), key.shape)
            out.append((float(X[k]), float(Z[k])))
    return tuple(out)


def disk_keepout(holes, chamfer: float, seats, chambers, slot: tuple[float, float],
                 hub: tuple[float, float] | None, screw_hole: float, wall: float) -> Keepout:
    """The keep-out of an end disk's face for screws with heads on the hub's face.

    ``holes``: the disk's eyelets (:class:`hwgen.model.specs.Hole`); ``seats`` the base disk's
    :class:`hwgen.model.specs.Seat` and ``chambers`` its (x, z, diameter, height); ``slot`` and ``hub`` half sizes (x, z)
    of the strip's slot and the hub's outline. A washer must not cover an eyelet's chamfered
    mouth or press on the hub; a screw hole keeps a wall from every other opening.
    """
    bore = screw_hole / 2 + wall
    head = max(WASHER_OD / 2, bore)
    circles = [(h.x, h.z, h.diameter / 2 + chamfer, head) for h in holes]
    circles += [(s.x, s.z, s.diameter / 2, bore) for s in seats]
    circles += [(x, z, dia / 2, bore) for x, z, dia, _ in chambers]
    boxes = [(slot[0], slot[1], bore)]
    if hub is not None:
        boxes.append((hub[0], hub[1], WASHER_OD / 2))
    return Keepout(tuple(circles), tuple(boxes))


def head_rim(outer_diameter: float, screw_hole: float, wall: float) -> float:
    """How far from the disk's centre a screw's centre may be: its washer, and a wall around its hole, inside the rim."""
    return outer_diameter / 2 - max(WASHER_OD / 2, screw_hole / 2 + wall)
