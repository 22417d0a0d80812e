"""Frozen specifications of the parts, as plain data: what the CAD stage builds from.

The plan (:mod:`hwgen.model.plan`) fills these in; the tensioner layout reads the tip disk's.
"""
from __future__ import annotations

from dataclasses import dataclass

SAME_HOLE_MM = 1e-6      # strip holes closer than this are one hole


@dataclass(frozen=True)
class Hole:
    """An eyelet hole: centre (x, z) on the disk mid-plane, axis in disk coordinates (x, y, z)."""

    x: float
    z: float
    axis: tuple[float, float, float]
    diameter: float
    tendons: tuple[str, ...]
    worst_angle_deg: float   # largest tendon angle to the axis over the sweep
    in_slot: bool            # the centre lies inside the backbone slot: the strip needs a hole here


@dataclass(frozen=True)
class DiskSpec:
    """One tendon-support disk, ready to build."""

    index: int
    y: float
    role: str                # "base", "inner" or "tip"
    thickness: float
    outer_diameter: float
    slot_width: float        # along x
    slot_height: float       # along z
    holes: tuple[Hole, ...]
    edge_size: float         # chamfer at hole rims, 0 for none
    knot_pockets: tuple[tuple[float, float, float, float], ...] = ()  # (x, z, diameter, depth), base side
    mount_holes: tuple[tuple[float, float, float], ...] = ()          # (x, z, diameter), through

    @property
    def name(self) -> str:
        return f"disk_{self.index:02d}"


@dataclass(frozen=True)
class BackboneHole:
    tendon: str
    station: float           # disk index, or a fraction between two disks
    x: float
    y: float
    diameter: float


@dataclass(frozen=True)
class BackboneSpec:
    height: float
    thickness: float
    y_start: float           # robot y of the strip's base end (negative: clamping length)
    y_end: float
    holes: tuple[BackboneHole, ...]
    density_g_cm3: float     # of the laminate
    name: str = "backbone"

    def merged_holes(self) -> list[tuple[float, float, float, tuple[str, ...]]]:
        """Holes merged by position: (x, y, largest diameter, tendons through it)."""
        out: list[list] = []
        for h in self.holes:
            for u in out:
                if abs(u[0] - h.x) < SAME_HOLE_MM and abs(u[1] - h.y) < SAME_HOLE_MM:
                    u[2] = max(u[2], h.diameter)
                    u[3] += (h.tendon,)
                    break
            else:
                out.append([h.x, h.y, h.diameter, (h.tendon,)])
        return [tuple(u) for u in out]


@dataclass(frozen=True)
class Merge:
    station: int
    tendons: tuple[str, ...]
    kind: str                # "shared": same position, one hole; "overlap": holes intersect
