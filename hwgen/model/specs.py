"""Frozen specifications of the parts, as plain data: what the CAD stage builds from.

The plan (:mod:`hwgen.model.plan`) fills these in; the tensioner layout reads the tip disk's.
"""
from __future__ import annotations

from dataclasses import dataclass

SAME_HOLE_MM = 1e-6      # strip holes closer than this are one hole


@dataclass(frozen=True, kw_only=True)
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
class HubSpec:
    """The sleeve around a disk's slot that holds the disk square to the strip.

    It runs from one face of the disk (``side`` +1: the face toward the tip, -1: toward the
    base) for ``length`` mm along the backbone, with a wall of ``wall`` mm around the slot. It is
    cut away over the x ranges in ``windows`` wherever a tendon passes through it, and has a glue
    port through its +z wall into the slot.
    """

    side: int
    length: float                              # beyond the disk's face, mm
    wall: float
    windows: tuple[tuple[float, float], ...]   # x intervals where the hub is cut away for a tendon
    port: tuple[float, float, float] | None    # glue port: x, distance beyond the face, diameter


@dataclass(frozen=True)
class Seat:
    """Where one tendon ends: a hole through the base disk's seat plate, smaller than what it holds."""

    tendon: str
    x: float
    z: float
    diameter: float          # the opening
    termination: float       # the knot's size or the crimp sleeve's outer diameter it holds


@dataclass(frozen=True, kw_only=True)
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
    mount_holes: tuple[tuple[float, float, float], ...] = ()          # (x, z, diameter), through
    hub: HubSpec | None = None
    seats: tuple[Seat, ...] = ()             # base disk: one per tendon, in a plate on its outer face
    seat_plate: float = 0.0                  # thickness of that plate, mm
    seat_chambers: tuple[tuple[float, float, float, float], ...] = ()  # (x, z, diameter, height) above the plate

    @property
    def engagement(self) -> float:
        """Length along the backbone over which the slot holds the strip: the disk and its hub, mm."""
        return self.thickness + (self.hub.length if self.hub else 0.0)

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


@dataclass(frozen=True, kw_only=True)
class BackboneSpec:
    height: float
    thickness: float
    y_start: float           # robot y of the strip's base end (negative: clamping length)
    y_end: float
    holes: tuple[BackboneHole, ...]
    density_g_cm3: float     # of the laminate
    length: float            # backbone.length: base to tip disk mid-plane
    extra_tip: float         # backbone.extra_tip: beyond the tip disk, for the tensioner's clamp
    modulus_gpa: float       # backbone.modulus_gpa: the laminate's E in bending
    shear_modulus_gpa: float
    allowable_stress_mpa: float
    loss_factor: float = 0.01  # backbone.loss_factor: the laminate's in bending (the sim's damping)
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


def slot_size(strip_height: float, strip_thickness: float, clearance: float) -> tuple[float, float]:
    """A disk's slot for the strip (its width along the strip's height, and across its thickness),
    mm: the strip with ``clearance`` (``disks.slot_clearance``) on each side."""
    return strip_height + 2 * clearance, strip_thickness + 2 * clearance
