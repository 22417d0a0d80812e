"""What the layout hands on: the units, the tendons' free runs, the housing's members, and
:class:`TensionerLayout` with the placements that take each part file into the robot's frame."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..gearing import WormPair
from .sizes import AXIAL_PLAY, DRIVE_FLANGE


@dataclass(frozen=True)
class TendonRun:
    """A tendon's free span: from its tip eyelet (on the tip face) to its spool's tangent point,
    robot coordinates."""

    tendon: str
    channel: str
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    exit_angle_deg: float           # angle to +y at the tip face
    sense: int = 1                  # +1: on the drum's side facing x = 0; -1: the far side

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.subtract(self.end, self.start)))


@dataclass(frozen=True, kw_only=True)
class Unit:
    """One channel's worm drive, in the layout's own frame (see ``TensionerLayout.turn``)."""

    channel: str
    tendons: tuple[str, ...]
    side: int                                    # +1: right column (+x), -1: left column, turned 180° about z
    center: tuple[float, float]                  # wheel axis (x, y)
    z_part: tuple[float, float]                  # wheel part: drum + gear, along z
    zones: tuple[tuple[float, float], ...]       # winding zones
    flanges: tuple[tuple[float, float], ...]     # flange slabs (z ranges)
    caps: tuple[tuple[float, float], ...]        # end caps (z ranges), radius of the gear's root
    z_gear: tuple[float, float]                  # gear face width
    clamps: tuple[tuple[float, float], ...]      # (z of the wheel face, direction -1 below / +1 above)
    worm_y: float
    worm_z: float
    upper_shelf: tuple[float, float]
    lower_bar: tuple[float, float]
    pins: tuple[float, float]                    # dowel lengths: lower, upper (wheel)

    @property
    def gear_on_top(self) -> bool:
        """The gear ends the stack at +z: the part prints upside down (gear face on the plate)."""
        return self.z_gear[1] >= self.z_part[1] - 1e-9

    @property
    def z_wheel_mid(self) -> float:
        return (self.z_gear[0] + self.z_gear[1]) / 2


@dataclass(frozen=True)
class Member:
    """A piece of the housing in the layout's frame: ``box`` (x0, x1, y0, y1, z0, z1),
    ``cyl`` (radius, x0, y0, z0, x1, y1, z1), ``hex`` (across flats, x0, y0, z0, x1, y1, z1,
    and a unit vector one pair of flats faces), or ``prism`` (the normal's axis, 0 for x or 2
    for z, its extent lo, hi, then the outline's points as y, v pairs, v being z for an x
    normal and x for a z normal)."""

    name: str
    kind: str
    dims: tuple[float, ...]

    @property
    def centre_y(self) -> float:
        d = self.dims
        if self.kind == "box":
            return (d[2] + d[3]) / 2
        if self.kind == "prism":
            return float(np.mean(d[3::2]))
        return (d[2] + d[5]) / 2

    @property
    def volume(self) -> float:
        d = self.dims
        if self.kind == "box":
            return abs((d[1] - d[0]) * (d[3] - d[2]) * (d[5] - d[4]))
        if self.kind == "prism":
            u, v = np.array(d[3::2]), np.array(d[4::2])
            return abs(float(np.dot(u, np.roll(v, -1)) - np.dot(v, np.roll(u, -1)))) / 2 * abs(d[2] - d[1])
        length = float(np.linalg.norm(np.subtract(d[4:7], d[1:4])))
        if self.kind == "cyl":
            return math.pi * d[0] ** 2 * length
        return math.sqrt(3) / 2 * d[0] ** 2 * length


@dataclass(frozen=True, kw_only=True)
class TensionerLayout:
    """Where every part of the tensioner goes, and the values of the YAML's tensioner section its
    parts are made from, resolved (the CAD stage reads nothing else)."""

    pair: WormPair
    y_face: float
    x_u: float
    spine: tuple[float, float]                  # |x| range of both spines
    post: tuple[float, float]                   # |x| range of every far post
    worm_x: tuple[float, float]                 # |x| range of every worm (far end, spine outer face)
    worm_file_to_mesh: np.ndarray               # 4x4 worm file -> mesh frame
    worm_near_end: float                        # plain core from the worm's spine-side face to its thread
    spine_hole: float                           # the drive shaft's bearing hole through the spine
    worm_pin: float                             # dowel the worm's far end turns on, pressed into the post
    units: tuple[Unit, ...]
    runs: tuple[TendonRun, ...]                 # robot coordinates
    spool_radius: float
    winding_radius: float
    flange_radius: float
    hub_radius: float
    strip: tuple[float, float, float, float]    # strip x half-width, z half-thickness, y start of clamp, y end
    clamp_block: tuple[float, float, float, float, float, float] | None   # x0, x1, y0, y1, z0, z1; None: no clamp
    members: tuple[Member, ...]                 # housing pieces to fuse
    cuts: tuple[Member, ...]                    # and to cut away
    turn: np.ndarray                            # 4x4 layout frame -> robot: identity, or 180° about y
    fastening: str                              # "nut" (resin) or "insert" (thermoplastic)
    base_t: float                               # base bars' depth along y, on the tip disk
    hex_key: float                              # the drive shaft's socket takes this hex key, across flats
    shaft_diameter: float                       # the dowels the worms and wheels turn on
    running_fit: float                          # diametral clearance of a part turning on a dowel
    friction_coefficient: float                 # μ of the worm on the wheel
    windings: dict[str, str]                    # channel -> "same" or "opposite": how its tendons wind
    search: dict = field(default_factory=dict)  # what was tried and why this arrangement won

    # --- placements: part file -> robot --------------------------------------------------
    def mesh_to_robot(self, unit: Unit) -> np.ndarray:
        """Mesh frame of :mod:`hwgen.model.gearing` -> robot: mesh X -> side·y (toward the worm),
        mesh Y (worm axis) -> -side·x, mesh Z (wheel axis) -> +z; origin at the wheel's mid-plane;
        then the layout frame's turn."""
        m = np.eye(4)
        s = unit.side
        m[:3, :3] = np.array([[0.0, -s, 0.0], [s, 0.0, 0.0], [0.0, 0.0, 1.0]])
        m[:3, 3] = [unit.center[0], unit.center[1], unit.z_wheel_mid]
        return self.turn @ m

    def stack_placement(self, unit: Unit) -> np.ndarray:
        """The wheel part with its axis on Z and its lowest z at Z = 0 -> robot."""
        t = np.eye(4)
        t[2, 3] = -(unit.z_wheel_mid - unit.z_part[0])
        return self.mesh_to_robot(unit) @ t

    @staticmethod
    def wheel_flip(unit: Unit) -> np.ndarray:
        """Stack frame -> file frame: turned over (180° about X) when the gear is on top, so
        the gear's face is on the build plate; identity otherwise. Its own inverse."""
        f = np.eye(4)
        if unit.gear_on_top:
            f[1, 1] = f[2, 2] = -1.0
            f[2, 3] = unit.z_part[1] - unit.z_part[0]
        return f

    def wheel_placement(self, unit: Unit) -> np.ndarray:
        """Wheel files: axis = file Z, the gear's face on Z = 0."""
        return self.stack_placement(unit) @ self.wheel_flip(unit)

    def worm_placement(self, unit: Unit) -> np.ndarray:
        """Worm files: axis = file Z from the spine-side face (Z = 0) to the far end."""
        return self.mesh_to_robot(unit) @ self.worm_file_to_mesh

    def drive_placement(self, unit: Unit) -> np.ndarray:
        """Drive shaft files: on the worm's axis, file Z = 0 at the flange's outer face."""
        t = np.eye(4)
        t[2, 3] = -(self.spine[1] - self.spine[0] + AXIAL_PLAY / 2 + DRIVE_FLANGE[1])
        return self.worm_placement(unit) @ t
