"""Layout of the worm-gear tensioner at the tip (numpy only, no CAD kernel).

Robot frame as everywhere: the backbone along +y, the tip disk's outer face at
y = y_face, x across the strip, z through it. The tensioner sits on that face.

One *unit* per channel: a wheel part (gear + spool drum) turning on two dowel stubs along
z, and a worm along x meshing on the wheel's +y side (-y in the left column). The worm sits
between the spine and a far post: it turns on a dowel pressed through the post at its far
end, and at its near end on a drive shaft that goes through a small hole in the spine into
the worm's hex bore; the shaft's flange outside the spine carries the socket for the hex
key. The worm's end faces bear on the spine and the post (its thrust).

Every tendon runs in its own plane z = z_e (its tip eyelet's z) in one straight line from
the tip eyelet to a tangent point of its channel's drum, where it winds in its own groove;
the drum's winding zones sit at those z, the gear at one end of the drum, the housing's
shelves above and below. Units stand in a right column (+x) and a left one (a right unit
turned 180° about z); both share one wheel-axis |x| (x_u) and a spine wall on their outer
side that carries the worms. Units are stacked along +y; those whose parts would reach the
strip's clamp go beyond it.

The layout is a search over arrangements: the whole tensioner as designed or turned over
(180° about y), the order of the units along y and the column each stands in, and which end
of its drum each gear takes. For each arrangement x_u is the smallest value at which every
tendon clears every other part by ``tensioner.tendon_clearance`` beyond its own diameter,
and the stack is lifted off the tip until no tendon turns by more than
``tensioner.max_exit_deg`` at its tip eyelet. The lightest arrangement that fits wins (the
housing's material estimated from its members); the candidates are generated from the
geometry alone, so listing the channels in another order or turning the robot over gives
the same verdict. The exported meshes are measured again by the checks.

A channel with two tendons winds them in the same sense by default (``tensioner.winding``):
turning the worm then shortens both equally, which is how the paper pre-tensions the
actuating pair so the beam stays straight (Sect. III-A, IV). Wound in opposite senses the
worm hauls one in as it pays the other out, and bends the robot.

The housing is described here as data (boxes and cylinders to fuse, and to cut), so the
search can weigh it and the CAD stage only turns it into a solid. Fasteners follow the
process: resin (SLA) is brittle and cracks around a melted-in insert, so it takes hex nuts
in traps; FDM thermoplastics take heat-set inserts.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from itertools import permutations

import numpy as np

from ..params import Design, Tensioner
from .gearing import WORM_TO_MESH, WormPair, worm_pair
from .intervals import interval_difference
from .routing import TendonPath
from .specs import DiskSpec

# Spool and wheel part (mm)
WIND_WIDTH = 3.0         # axial length of one tendon's winding zone
FLANGE_HEIGHT = 2.5      # flange radius above the drum core: holds a few turns of 0.15 mm line
FLANGE = 1.2             # flange thickness (≥ 0.8 mm process wall)
CLAMP_GAP = 3.5          # axial gap between the inner flange and the wheel face, room for the clamp
WORM_CLEAR = 1.5         # least z distance from a worm to its own unit's tendon planes
HUB_WALL = 2.0           # radial wall of the drum around the pin bore
CLAMP_SCREW = 2.0        # M2: pinches the tendon under the clamp plate
CLAMP_PLATE = (6.0, 5.0, 1.5)   # clamp plate x, y, thickness
CLAMP_HEAD = 1.4         # M2 low head (ISO 7380) height above the plate
ANCHOR_HOLE = 1.0        # axial hole through the inner flange the tendon leaves the drum by
CAP = 5.0                # end cap at the far end of a two-zone drum, holds the second clamp
# Housing (mm)
GAP = 0.5                # axial gap between a turning part and a housing face
SHELF = 3.0              # shelf and bar thickness
WORM_END = 1.5           # plain core beyond the thread at each end of the worm (no knife edge at a face)
DRIVE_SHAFT = 7.0        # drive shaft through the spine: Ø, holds the hex key's socket with walls
DRIVE_HEX = 5.0          # its hex end, across flats, pressed into the worm's hex bore
DRIVE_HEX_LENGTH = 7.5   # ... and how far it goes in
DRIVE_FLANGE = (11.0, 2.0)   # its flange outside the spine: Ø, thickness (stops it going further in)
AXIAL_PLAY = 0.25        # worm end play between the far post and the spine
POST = 6.0               # far worm bearing post, square section
BOSS = 3.5               # radius of the pin bosses and bars around a dowel
UNIT_GAP = 2.0           # y gap between neighbouring units' parts
PIN_ENGAGE = 5.0         # dowel length inside a turning part's bore
PIN_LENGTHS = (8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30)   # ISO 2338 lengths for Ø3, mm
STRIP_CLAMP_Z = (-1.5, 6.0)   # strip clamp block, z range (set screws from +z)
STRIP_CLAMP_X = 2.0       # block beyond the strip's edges, x
STRIP_SLOT_CLEARANCE = 0.05   # per side, strip in its slot
M3_CLEARANCE = 3.4        # ISO 273 normal
M2_CLEARANCE = 2.4
MOUNT_BAR = 9.0           # z height of the base bar through a row of tip-disk screws
TENDON_HOLE = 3.0         # minimum hole through a base bar around a tendon
# Fasteners by process: (hole it needs). Resin: hex nuts (ISO 4032) in traps, 0.2 mm over the
# nut (SLA holds ±0.05 mm; the nut must slide in); thermoplastic: heat-set inserts.
NUT = {"M2": (4.0, 1.6), "M3": (5.5, 2.4)}      # across flats, height
NUT_PLAY = 0.2
INSERT = {"M2": (3.2, 4.0), "M3": (4.0, 5.7)}   # bore, length (M2 × 4, M3 × 5.7)
SPINE = 4.0              # spine wall: the drive shaft's bearing and the worm's thrust face
BASE = {"nut": 5.0, "insert": 7.0}    # base bars on the tip disk (y)
SCREW_LENGTHS = {"M2": (4, 5, 6, 8, 10, 12, 16, 20), "M3": (6, 8, 10, 12, 16, 20, 25)}
# Layout search
X_STEP = 0.5
X_COARSE = 2.0
X_SEARCH = 80.0
MAX_LIFTS = 30
EVERY_ORDER_UP_TO = 3     # channels up to which every order along y is tried; beyond, orders by geometry
MAX_SOLVES = 32           # arrangements solved at most, in order of their lower bound (each takes ~0.2 s)


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


@dataclass(frozen=True)
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


@dataclass(frozen=True)
class TensionerLayout:
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
    clamp_block: tuple[float, float, float, float, float, float]   # x0, x1, y0, y1, z0, z1
    members: tuple[Member, ...]                 # housing pieces to fuse
    cuts: tuple[Member, ...]                    # and to cut away
    turn: np.ndarray                            # 4x4 layout frame -> robot: identity, or 180° about y
    fastening: str                              # "nut" (resin) or "insert" (thermoplastic)
    base_t: float                               # base bars' depth along y, on the tip disk
    params: Tensioner                           # the YAML's tensioner section
    search: dict = field(default_factory=dict)  # what was tried and why this arrangement won

    def unit(self, channel: str) -> Unit:
        return next(u for u in self.units if u.channel == channel)

    @property
    def housing_volume_estimate(self) -> float:
        """Sum of the housing members' volumes, mm³ (overlaps counted twice, cuts ignored)."""
        return float(sum(m.volume for m in self.members))

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


@dataclass(frozen=True)
class Fastening:
    """How a screw is held in a printed body: a nut in a trap (resin) or a heat-set insert
    (thermoplastic). Depths are from the face the screw enters the body by."""

    kind: str                # "nut" or "insert"
    thread: str              # "M2", "M3"
    screw_length: float      # standard length, mm
    hole: float              # clearance hole (nut) or insert bore (insert), mm
    nut_from: float          # nut: depth of the trap's near face; insert: 0
    depth: float             # nut: depth of the trap's far face; insert: the bore's depth
    body: float              # the printed body's thickness along the screw

    @property
    def screw(self) -> str:
        return f"{self.thread} × {self.screw_length:g}"

    def held_by(self, qty: int, notes: str) -> dict:
        """The bill-of-materials line for what holds ``qty`` of these screws."""
        if self.kind == "nut":
            return {"item": "hex nut ISO 4032", "size": self.thread, "qty": qty, "material": "steel",
                    "notes": f"{notes}, in a trap"}
        return {"item": "heat-set insert", "size": f"{self.thread} × {INSERT[self.thread][1]:g}", "qty": qty,
                "material": "brass", "notes": f"{notes}, melted in"}


def joint(fast: str, thread: str, grip: float, body: float) -> Fastening:
    """A screw of ``thread`` through ``grip`` mm of other parts into a printed body ``body`` mm
    thick: with a nut, the longest standard screw that stays inside the body, ending at the
    nut's far face; with an insert, the longest that ends inside the insert."""
    if fast == "nut":
        af, h = NUT[thread]
        screw = _screw_length(thread, grip + body)
        far = screw - grip                                     # the screw's end, deep in the body
        if far < h + 0.6:
            raise NoFit(f"a {thread} nut and its screw do not fit in {body:g} mm of resin")
        clear = M3_CLEARANCE if thread == "M3" else M2_CLEARANCE
        return Fastening("nut", thread, screw, clear, far - h - NUT_PLAY / 2, far + NUT_PLAY / 2, body)
    bore, length = INSERT[thread]
    depth = min(body, length + 0.5)
    return Fastening("insert", thread, _screw_length(thread, grip + depth - 0.5), bore, 0.0, depth, body)


class NoFit(ValueError):
    """No arrangement fits; the message names the tendon, what it hits and what would free it."""


@dataclass(frozen=True)
class _Failure:
    """Why one arrangement did not fit: the worst tendon clearance and what set it."""

    clearance: float
    tendon: str
    obstacle: str
    kind: str                # "part", "clamp", "exit", "space"


def spool_wall_problem(ts: Tensioner, min_wall: float) -> str | None:
    """Why the spool drum leaves too little wall around its pin's bore, or None."""
    if ts.spool_diameter < ts.shaft_diameter + ts.running_fit + 2 * min_wall:
        return (f"{ts.spool_diameter:g} mm leaves less than {min_wall:g} mm of wall around "
                f"the Ø{ts.shaft_diameter:g} mm pin's bore")
    return None


def fastening(technology: str) -> str:
    """Resin (SLA) takes nuts in traps; thermoplastic (FDM) takes heat-set inserts."""
    return "nut" if technology == "SLA" else "insert"


@dataclass(frozen=True)
class _Sizes:
    """Dimensions every unit shares, derived once from the parameters (mm)."""

    pair: WormPair
    y_face: float            # the tip disk's outer face
    tendon_d: float
    need: float              # least distance from a tendon's axis to another part's surface
    max_exit: float          # rad
    r_s: float               # spool core radius
    r_w: float               # winding radius: the tendon's centre on the drum
    r_f: float               # flange radius
    hub_r: float
    spine_hole: float        # the drive shaft's bearing
    spine_t: float
    base_t: float
    tip_t: float             # the tip disk's thickness (the tip screws' grip)
    strip_half_x: float
    strip_half_z: float
    y_end: float             # the strip's tip end

    @staticmethod
    def of(d: Design, tip: DiskSpec) -> _Sizes:
        ts = d.tensioner
        pair = worm_pair(ts, d.process.min_wall)
        r_s = ts.spool_diameter / 2
        problem = spool_wall_problem(ts, d.process.min_wall)
        if problem:
            raise NoFit(f"tensioner.spool_diameter {problem}")
        fast = fastening(d.process.technology)
        td = d.tendon_material.diameter
        return _Sizes(pair, tip.y + tip.thickness / 2, td, td / 2 + ts.tendon_clearance + td / 2,
                      math.radians(ts.max_exit_deg), r_s, r_s + td / 2, r_s + FLANGE_HEIGHT,
                      max(ts.shaft_diameter / 2 + ts.running_fit / 2 + HUB_WALL, r_s),
                      DRIVE_SHAFT + ts.running_fit,
                      SPINE, BASE[fast], tip.thickness, d.backbone.height / 2, d.backbone.thickness / 2,
                      d.backbone.length + d.backbone.extra_tip)


@dataclass(frozen=True)
class _Stack:
    """One unit's parts along z (layout frame, mm), before it is placed in x and y."""

    zones: tuple[tuple[float, float], ...]
    flanges: tuple[tuple[float, float], ...]
    caps: tuple[tuple[float, float], ...]
    gear: tuple[float, float]
    clamps: tuple[tuple[float, float], ...]
    z_part: tuple[float, float]
    z_wheel: float
    upper: tuple[float, float]
    lower: tuple[float, float]
    pins: tuple[float, float]

    @property
    def z_span(self) -> tuple[float, float]:
        return self.lower[0], self.upper[1]


# ---------------------------------------------------------------- tendons at the tip

Eyelets = dict[str, list[tuple[str, float, float]]]   # channel -> [(tendon, x, z)] at the tip


def _tip_eyelets(paths: list[TendonPath], channels) -> Eyelets:
    """(tendon, x, z) of every tendon at the tip disk, per channel; refuses what one drum cannot wind."""
    eyelets: Eyelets = {c: [] for c in channels}
    for p in paths:
        x, z = (float(v) for v in p.points[-1])
        eyelets[p.channel].append((p.name, x, z))
    for c, here in eyelets.items():
        if not here:
            raise NoFit(f"tensioner channel {c!r} has no tendon: give it one (tendons[].channel) or drop it "
                        f"from tensioner.channels")
    for c, here in eyelets.items():
        srt = sorted(here, key=lambda t: t[2])
        for (n0, _, z0), (n1, _, z1) in zip(srt, srt[1:]):
            if z1 - z0 < WIND_WIDTH + 2 * FLANGE:
                raise NoFit(f"channel {c!r}: tendons {n0} and {n1} leave the tip at z = {z0:g} and {z1:g}, too "
                            f"close to wind side by side on one drum ({WIND_WIDTH + 2 * FLANGE:g} mm apart needed, "
                            f"each in its own groove); put one on its own channel (tendons[].channel)")
    return eyelets


def _turned(eyelets: Eyelets, turn: int) -> Eyelets:
    """The tip eyelets seen from a tensioner turned 180° about y (turn = -1)."""
    return {c: [(n, turn * x, turn * z) for n, x, z in v] for c, v in eyelets.items()}


# ---------------------------------------------------------------- one unit along z

def _wheel_stack(zs: list[float], b: float, worm_radius: float, gear_low: bool):
    """Winding zones, flanges, end caps, gear and clamp faces along z for tendons at heights zs.

    The gear goes at one end of the stack (its face is the part's largest flat face and prints
    on the plate): below the lowest zone when ``gear_low``, else above the top one. A tendon
    whose zone is next to the gear is clamped on the gear's face; one at the far end on an end
    cap there.
    """
    zs = sorted(zs)
    half = WIND_WIDTH / 2
    zones = tuple((z - half, z + half) for z in zs)
    flanges = []
    for lo, hi in zones:
        flanges += [(lo - FLANGE, lo), (hi, hi + FLANGE)]
    reach = CLAMP_PLATE[2] + CLAMP_HEAD
    caps, clamps = [], []
    if gear_low:
        top = min(zones[0][0] - FLANGE - CLAMP_GAP, zs[0] - WORM_CLEAR - worm_radius + b / 2)
        gear = (top - b, top)
        clamps.append((gear[1], 1.0))
        if len(zones) > 1:
            caps.append((zones[-1][1], zones[-1][1] + CAP))
            clamps.append((caps[-1][1], 1.0))
    else:
        bot = max(zones[-1][1] + FLANGE + CLAMP_GAP, zs[-1] + WORM_CLEAR + worm_radius - b / 2)
        gear = (bot, bot + b)
        clamps.append((gear[0], -1.0))
        if len(zones) > 1:
            caps.append((zones[0][0] - CAP, zones[0][0]))
            clamps.append((caps[-1][0], -1.0))
    lo = min([gear[0], zones[0][0] - FLANGE] + [c[0] for c in caps])
    hi = max([gear[1], zones[-1][1] + FLANGE] + [c[1] for c in caps])
    z_part = (lo, hi)
    ends = [z + s * reach for z, s in clamps]
    span = (min([lo] + ends), max([hi] + ends))
    return zones, tuple(flanges), tuple(caps), gear, tuple(clamps), z_part, span


def _pin_length(span: float) -> float:
    """Shortest standard dowel covering a pressed span plus PIN_ENGAGE in the turning part."""
    need = span + GAP + PIN_ENGAGE
    for n in PIN_LENGTHS:
        if n >= need:
            return float(n)
    raise NoFit(f"no standard Ø3 dowel is {need:.1f} mm long (longest {PIN_LENGTHS[-1]} mm)")


def _unit_stack(zs: list[float], pair: WormPair, gear_rule: str) -> _Stack:
    """The z stack of one unit: wheel part, shelf above, bar below, and the dowels between.

    ``gear_rule`` is "<one side>-<both sides>": for a unit whose tendons are all on one side of
    the strip plane, "toward" puts the gear on the strip's side of its drum and "away" on the
    other; for a unit with tendons on both sides, "low" puts it below and "high" above. The
    four rules map onto one another when the robot is mirrored through its strip plane.
    """
    one_side, both = gear_rule.split("-")
    if min(zs) >= 0:
        gear_low = one_side == "toward"
    elif max(zs) <= 0:
        gear_low = one_side == "away"
    else:
        gear_low = both == "low"
    zones, flanges, caps, gear, clamps, z_part, span = _wheel_stack(zs, pair.face_width, pair.ra1, gear_low)
    zw = (gear[0] + gear[1]) / 2
    hi = max(span[1], zw + pair.ra1)
    lo = min(span[0], zw - pair.ra1)
    upper = (hi + GAP, hi + GAP + SHELF)
    lower = (lo - GAP - SHELF, lo - GAP)
    pins = (_pin_length(z_part[0] - GAP - lower[0]), _pin_length(upper[1] - (z_part[1] + GAP)))
    return _Stack(zones, flanges, caps, gear, clamps, z_part, zw, upper, lower, pins)


GEAR_RULES = ("toward-high", "toward-low", "away-high", "away-low")


CLAMP_MIN = 5.0           # strip beyond the base bars that is worth clamping, mm


def _strip_clamp(sz: _Sizes, up: int) -> tuple[float, float, float, float, float, float] | None:
    """The block that clamps the strip's tip end, in the layout frame: x0, x1, y0, y1, z0, z1;
    its set screws come from +z (``up`` = 1) or -z, the side where it is thick. None when the
    strip ends too soon beyond the tip disk to be clamped (``backbone.extra_tip``)."""
    if sz.y_end - (sz.y_face + sz.base_t) < CLAMP_MIN:
        return None
    z0, z1 = STRIP_CLAMP_Z if up > 0 else (-STRIP_CLAMP_Z[1], -STRIP_CLAMP_Z[0])
    return (-sz.strip_half_x - STRIP_CLAMP_X, sz.strip_half_x + STRIP_CLAMP_X, sz.y_face + sz.base_t,
            sz.y_end + 2.0, z0, z1)


def _clamp_blockers(eyelets: Eyelets, clamp, sz: _Sizes) -> list[tuple[str, float, float]]:
    """Tendons that leave the tip inside the strip clamp's outline (beside the strip, within its
    thickness): they would have to pass through it, whatever the arrangement."""
    if clamp is None:
        return []
    return [(n, x, z) for v in eyelets.values() for n, x, z in v
            if abs(x) < clamp[1] + sz.need and clamp[4] - sz.need < z < clamp[5] + sz.need]


def _meets_clamp(stack: _Stack, clamp) -> bool:
    if clamp is None:
        return False
    z0, z1 = stack.z_span
    return z0 < clamp[5] + GAP and z1 > clamp[4] - GAP


# ---------------------------------------------------------------- arrangements

@dataclass(frozen=True)
class _Arrangement:
    turn: int
    clamp_up: int                           # the strip clamp's set screws from layout +z (1) or -z
    gear_rule: str
    order: tuple[str, ...]                  # along +y
    sides: tuple[int, ...]                  # per unit in that order

    @property
    def key(self) -> tuple:
        return (self.turn < 0, self.clamp_up < 0, self.gear_rule, self.order, self.sides)


def _arrangements(turn: int, clamp_up: int, gear_rule: str, eyelets: Eyelets, stacks: dict[str, _Stack], clamp):
    """Candidate orders along y and columns, from the geometry alone (names break ties only).

    Up to four channels every order is tried with alternating columns (both starts); beyond,
    orders by the units' z and by their tendons' x. Columns: alternating, or each unit in the
    column its tendons lean toward, or the column that is shorter so far.
    """
    names = sorted(eyelets)
    zmid = {c: sum(stacks[c].z_span) / 2 for c in names}
    xmean = {c: float(np.mean([x for _, x, _ in eyelets[c]])) for c in names}
    late = {c: _meets_clamp(stacks[c], clamp) for c in names}
    if len(names) <= EVERY_ORDER_UP_TO:
        orders = [tuple(p) for p in permutations(names)]
    else:
        keys = [lambda c: (late[c], zmid[c], c), lambda c: (late[c], -zmid[c], c),
                lambda c: (late[c], abs(zmid[c]), c), lambda c: (late[c], xmean[c], zmid[c], c),
                lambda c: (late[c], -abs(xmean[c]), zmid[c], c)]
        orders = [tuple(sorted(names, key=k)) for k in keys]
    seen = set()
    for order in orders:
        order = tuple(sorted(order, key=lambda c: late[c]))      # units meeting the clamp go beyond it
        patterns = [tuple(1 if i % 2 == 0 else -1 for i in range(len(order))),
                    tuple(-1 if i % 2 == 0 else 1 for i in range(len(order))),
                    tuple(1 if xmean[c] >= 0 else -1 for c in order)]
        for sides in patterns:
            columns = tuple(tuple(c for c, sd in zip(order, sides) if sd == side) for side in (1, -1))
            if columns not in seen:                 # the same columns in the same order are one layout
                seen.add(columns)
                yield _Arrangement(turn, clamp_up, gear_rule, order, sides)


# ---------------------------------------------------------------- placing the units

def _place_units(arr: _Arrangement, stacks: dict[str, _Stack], clamp, sz: _Sizes, lift: float) -> dict[str, float]:
    """Wheel-axis heights y: in each column units stack along +y; a unit whose z span meets the
    strip clamp goes beyond it."""
    pair = sz.pair
    wheel_reach = max(pair.outside_radius, sz.r_f, BOSS) + UNIT_GAP / 2
    worm_reach = pair.center_distance + max(pair.ra1, DRIVE_FLANGE[0] / 2, POST / 2) + UNIT_GAP / 2
    centers_y: dict[str, float] = {}
    y_next = {1: sz.y_face + sz.base_t + GAP + lift, -1: sz.y_face + sz.base_t + GAP + lift}
    for c, s in zip(arr.order, arr.sides):
        below, above = (wheel_reach, worm_reach) if s > 0 else (worm_reach, wheel_reach)
        floor = clamp[3] + GAP if _meets_clamp(stacks[c], clamp) else y_next[s]
        yc = max(y_next[s], floor) + below
        centers_y[c] = yc
        y_next[s] = yc + above
    return centers_y


@dataclass(frozen=True)
class _Frame:
    """The units placed at one wheel-axis |x| (x_u), with the worms, spines and posts that follow."""

    spine: tuple[float, float]
    near_end: float
    worm_file_to_mesh: np.ndarray
    worm_x: tuple[float, float]
    post: tuple[float, float]
    units: tuple[Unit, ...]
    runs: tuple[TendonRun, ...]              # layout frame


def _tangent_point(p: np.ndarray, c: np.ndarray, r: float, toward: int) -> np.ndarray:
    """Tangent point on circle (c, r) of a line from p: on the side of smaller x when
    ``toward`` is -1, of larger x when +1."""
    d = c - p
    dist = np.linalg.norm(d)
    if dist <= r:
        raise NoFit("tendon eyelet inside its spool")
    base = math.atan2(d[1], d[0])
    off = math.asin(r / dist)
    tlen = math.sqrt(dist ** 2 - r ** 2)
    pts = [p + tlen * np.array([math.cos(base + s * off), math.sin(base + s * off)]) for s in (1, -1)]
    return min(pts, key=lambda t: -toward * t[0])


def _frame(x_u: float, arr: _Arrangement, centers_y, stacks, eyelets: Eyelets, winding: dict, sz: _Sizes) -> _Frame:
    """Everything at wheel-axis |x| = x_u. The worm runs along x from the spine inward, its
    thread centred on the wheel (a thread space on the wheel's tooth), its near face on the
    spine's inner face, which stands clear of the wheel's tips; the far post holds its dowel."""
    pair = sz.pair
    a = pair.center_distance
    L = pair.worm_length
    n = round(-L / (2 * pair.pitch))
    x_thread = x_u - n * pair.pitch                  # |x| of the thread's spine-side end
    x_near = max(x_thread + WORM_END, x_u + pair.outside_radius + GAP)    # the worm's spine-side face
    near_end = x_near - x_thread                     # worm file Z of the thread's start
    spine = (x_near + AXIAL_PLAY / 2, x_near + AXIAL_PLAY / 2 + sz.spine_t)
    ty = -near_end + n * pair.pitch                  # a thread space on the wheel's tooth at mesh y = 0
    wf = np.eye(4)
    wf[:3, :3] = WORM_TO_MESH
    wf[:3, 3] = [a, ty, 0.0]
    x_far = x_thread - L - WORM_END
    post = (x_far - AXIAL_PLAY / 2 - POST, x_far - AXIAL_PLAY / 2)
    units, runs = [], []
    for c, s in zip(arr.order, arr.sides):
        st = stacks[c]
        u = Unit(c, tuple(n_ for n_, _, _ in eyelets[c]), s, (s * x_u, centers_y[c]), st.z_part,
                 st.zones, st.flanges, st.caps, st.gear, st.clamps, centers_y[c] + s * a, st.z_wheel,
                 st.upper, st.lower, st.pins)
        units.append(u)
        opposite = winding.get(c, "same") == "opposite"
        for k, (name, x, z) in enumerate(sorted(eyelets[c], key=lambda t: (t[2], t[0]))):
            sense = -1 if opposite and k % 2 == 1 else 1
            p0 = np.array([x, sz.y_face])
            t = _tangent_point(p0, np.array(u.center), sz.r_w, -s * sense)
            ang = math.degrees(math.atan2(abs(t[0] - x), t[1] - sz.y_face))
            runs.append(TendonRun(name, c, (x, sz.y_face, z), (float(t[0]), float(t[1]), z), ang, sense))
    return _Frame(spine, near_end, wf, (x_far, x_near), post, tuple(units), tuple(runs))


# ---------------------------------------------------------------- clearance of the tendon runs

@dataclass(frozen=True)
class _Obstacles:
    """Every part outline of a frame that a tendon in a plane z may meet, as arrays: circles
    (x, y, r) and rectangles (x0, x1, y0, y1), each with the z range it occupies, the channel
    it belongs to (its own tendons may pass it only when ``foreign``) and a name."""

    circles: np.ndarray          # (n, 3)
    c_z: np.ndarray              # (n, 2)
    c_owner: list[str]
    c_foreign: np.ndarray        # (n,) bool: an obstacle only to other channels' tendons
    c_names: list[str]
    rects: np.ndarray            # (m, 4)
    r_z: np.ndarray              # (m, 2)
    r_names: list[str]


def _obstacles(fr: _Frame, clamp, sz: _Sizes) -> _Obstacles:
    pair = sz.pair
    C, R = [], []            # (name, geometry, z0, z1, owner, foreign)
    reach = CLAMP_PLATE[2] + CLAMP_HEAD
    for u in fr.units:
        cx, cy = u.center
        s = u.side
        ch = u.channel

        def rect(name, x0, x1, y0, y1, z0, z1):
            xs = sorted((s * x0, s * x1))
            R.append((f"{ch} {name}", (xs[0], xs[1], min(y0, y1), max(y0, y1)), z0, z1))
        C.append((f"{ch} spool", (cx, cy, max(sz.r_f, sz.hub_r)), *u.z_part, ch, True))
        C.append((f"{ch} wheel", (cx, cy, pair.outside_radius), *u.z_gear, ch, True))
        C += [(f"{ch} cap", (cx, cy, pair.rf2), *cap, ch, True) for cap in u.caps]
        C += [(f"{ch} clamp", (cx, cy, pair.rf2), min(zc, zc + sg * reach), max(zc, zc + sg * reach), ch, False)
              for zc, sg in u.clamps]
        C.append((f"{ch} boss", (cx, cy, BOSS), u.z_part[1], u.upper_shelf[1], ch, False))
        C.append((f"{ch} boss", (cx, cy, BOSS), u.lower_bar[0], u.z_part[0], ch, False))
        rect("worm", fr.worm_x[0], fr.worm_x[1], u.worm_y - pair.ra1, u.worm_y + pair.ra1,
             u.worm_z - pair.ra1, u.worm_z + pair.ra1)
        rf = DRIVE_FLANGE[0] / 2
        rect("drive shaft", fr.spine[1], fr.spine[1] + DRIVE_FLANGE[1], u.worm_y - rf, u.worm_y + rf,
             u.worm_z - rf, u.worm_z + rf)
        rect("post", fr.post[0], fr.post[1], u.worm_y - POST / 2, u.worm_y + POST / 2,
             u.worm_z - POST / 2, u.upper_shelf[1])
        rect("shelf", fr.post[0], fr.spine[1], cy - s * BOSS, u.worm_y + s * POST / 2, *u.upper_shelf)
        rect("bar", abs(cx) - BOSS, fr.spine[1], cy - BOSS, cy + BOSS, *u.lower_bar)
    for s in (1, -1):
        xs = sorted((s * fr.spine[0], s * fr.spine[1] * 10))
        R.append(("spine", (xs[0], xs[1], sz.y_face, 1e9), -1e9, 1e9))
    if clamp is not None:
        R.append(("strip clamp", tuple(clamp[:4]), clamp[4], clamp[5]))
    return _Obstacles(np.array([c[1] for c in C], float).reshape(-1, 3), np.array([c[2:4] for c in C], float).reshape(-1, 2),
                      [c[4] for c in C], np.array([c[5] for c in C], bool), [c[0] for c in C],
                      np.array([r[1] for r in R], float).reshape(-1, 4), np.array([r[2:4] for r in R], float).reshape(-1, 2),
                      [r[0] for r in R])


def _seg_point_dist(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Distance from segments a-b (r, 2) to points p (n, 2): (r, n)."""
    ab = (b - a)[:, None, :]
    ap = p[None, :, :] - a[:, None, :]
    t = np.clip(np.sum(ap * ab, axis=2) / np.maximum(np.sum(ab * ab, axis=2), 1e-12), 0, 1)
    return np.linalg.norm(ap - t[..., None] * ab, axis=2)


def _seg_rect_dist(a: np.ndarray, b: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Exact distance from segments a-b (k, 2) to axis-aligned rectangles r (n, 4: x0, x1, y0, y1):
    (k, n), 0 where a segment enters a rectangle (Liang-Barsky clipping)."""
    d = b - a
    t0, t1 = np.zeros((len(a), len(r))), np.ones((len(a), len(r)))
    for k, (lo, hi) in enumerate(((0, 1), (2, 3))):
        dk = d[:, k:k + 1]
        ak = a[:, k:k + 1]
        flat = np.abs(dk) < 1e-12
        with np.errstate(divide="ignore", invalid="ignore"):
            ta, tb = (r[None, :, lo] - ak) / dk, (r[None, :, hi] - ak) / dk
        outside = flat & ((ak < r[None, :, lo]) | (ak > r[None, :, hi]))
        t0 = np.where(flat, np.where(outside, 2.0, t0), np.maximum(t0, np.minimum(ta, tb)))
        t1 = np.where(flat, t1, np.minimum(t1, np.maximum(ta, tb)))
    hit = t0 <= t1

    def point_rect(p):
        dx = np.maximum(np.maximum(r[None, :, 0] - p[:, :1], 0), p[:, :1] - r[None, :, 1])
        dy = np.maximum(np.maximum(r[None, :, 2] - p[:, 1:], 0), p[:, 1:] - r[None, :, 3])
        return np.hypot(dx, dy)
    dist = np.minimum(point_rect(a), point_rect(b))
    corners = np.concatenate([r[:, [0, 2]], r[:, [0, 3]], r[:, [1, 2]], r[:, [1, 3]]])
    dc = _seg_point_dist(a, b, corners).reshape(len(a), 4, len(r)).min(axis=1)
    return np.where(hit, 0.0, np.minimum(dist, dc))


def _clearance(fr: _Frame, clamp, sz: _Sizes) -> _Failure:
    """The smallest distance from any tendon's free span to a part it must not touch, beyond
    what it needs, and which (every run against every obstacle at once)."""
    ob = _obstacles(fr, clamp, sz)
    need = sz.need
    a = np.array([r.start[:2] for r in fr.runs])
    b = np.array([r.end[:2] for r in fr.runs])
    z = np.array([r.start[2] for r in fr.runs])[:, None]
    own = np.array([[o == r.channel for o in ob.c_owner] for r in fr.runs]).reshape(len(fr.runs), -1)
    cm = (ob.c_z[None, :, 0] - need < z) & (z < ob.c_z[None, :, 1] + need) & ~(ob.c_foreign[None, :] & own)
    dc = np.where(cm, _seg_point_dist(a, b, ob.circles[:, :2]) - ob.circles[None, :, 2] - need, np.inf)
    rm = (ob.r_z[None, :, 0] - need < z) & (z < ob.r_z[None, :, 1] + need)
    dr = np.where(rm, _seg_rect_dist(a, b, ob.rects) - need, np.inf)
    worst = _Failure(math.inf, "", "", "part")
    if dc.size and np.isfinite(dc).any():
        i, k = np.unravel_index(int(np.argmin(dc)), dc.shape)
        worst = _Failure(float(dc[i, k]), fr.runs[i].tendon, ob.c_names[k], "part")
    if dr.size and np.isfinite(dr).any():
        i, k = np.unravel_index(int(np.argmin(dr)), dr.shape)
        if dr[i, k] < worst.clearance:
            name = ob.r_names[k]
            worst = _Failure(float(dr[i, k]), fr.runs[i].tendon, name, "clamp" if name == "strip clamp" else "part")
    return worst


def _x_floor(eyelets: Eyelets, sz: _Sizes) -> float:
    """The least wheel-axis |x| worth trying: every drum beyond its tendons' eyelets, and the far
    worm posts (x_u - n p - L - play - POST from the axis) on their own side of x = 0."""
    pair = sz.pair
    n = round(-pair.worm_length / (2 * pair.pitch))
    posts = UNIT_GAP / 2 + POST + AXIAL_PLAY / 2 + WORM_END + pair.worm_length + n * pair.pitch
    return max(max(abs(x) for v in eyelets.values() for _, x, _ in v) + sz.r_w + sz.need, posts)


def _widen(arr, centers_y, stacks, eyelets, winding, clamp, sz: _Sizes) -> tuple[float, _Frame]:
    """The smallest wheel-axis |x| at which every tendon clears every other part, scanned coarse
    then refined; NoFit-carrying _Failure when none within X_SEARCH."""
    x_min = _x_floor(eyelets, sz)

    def ok(x_u):
        fr = _frame(x_u, arr, centers_y, stacks, eyelets, winding, sz)
        fail = _clearance(fr, clamp, sz)
        # the far posts stay on their own side of x = 0, clear of the other column
        good = fail.clearance >= 0 and fr.post[0] >= UNIT_GAP / 2
        return good, fr, fail
    best_fail = None
    x = x_min
    while x < x_min + X_SEARCH:
        good, fr, fail = ok(x)
        if good:
            lo = max(x_min, x - X_COARSE)
            for xf in np.arange(lo, x, X_STEP):       # refine downward from the coarse hit
                g2, fr2, _ = ok(float(xf))
                if g2:
                    return float(xf), fr2
            return x, fr
        if best_fail is None or fail.clearance > best_fail.clearance:
            best_fail = fail
        x += X_COARSE
    raise _Infeasible(best_fail)


class _Infeasible(Exception):
    def __init__(self, failure: _Failure):
        self.failure = failure


def _solve(arr: _Arrangement, stacks, eyelets, winding, clamp, sz: _Sizes):
    """Place one arrangement: widen until clear, lift until every exit angle is allowed."""
    lift = 0.0
    for _ in range(MAX_LIFTS):
        centers_y = _place_units(arr, stacks, clamp, sz, lift)
        x_u, fr = _widen(arr, centers_y, stacks, eyelets, winding, clamp, sz)
        need = _exit_lift(fr, sz)
        if need <= 1e-6:
            return x_u, fr
        lift += need + X_STEP
    worst = max(fr.runs, key=lambda r: r.exit_angle_deg)
    raise _Infeasible(_Failure(-worst.exit_angle_deg, worst.tendon, f"a {worst.exit_angle_deg:.0f}° turn", "exit"))


# ---------------------------------------------------------------- the housing as members

def _screw_length(kind: str, reach: float) -> float:
    """Longest standard screw of this size no longer than ``reach``."""
    fits = [n for n in SCREW_LENGTHS[kind] if n <= reach + 1e-9]
    if not fits:
        raise NoFit(f"no standard {kind} screw is as short as {reach:.1f} mm")
    return float(max(fits))


def _housing(fr: _Frame, clamp, sz: _Sizes, mounts, fast: str, ts: Tensioner,
             with_cuts: bool = True) -> tuple[list[Member], list[Member]]:
    """The housing's members and cuts: base bars on the tip disk (through its screw rows and
    the strip clamp), a spine foot per column, one spine pad per unit stacked from the foot
    (each overlapping the one before, so the wall is one piece), per unit an upper shelf with
    the pin boss, a lower bar and the far worm post; dowel bores, worm holes, fastener holes
    with nut traps or insert bores, the strip's slot and the tendons' passages."""
    pair = sz.pair
    sp0, sp1 = fr.spine
    yb0, yb1 = sz.y_face, sz.y_face + sz.base_t
    members: list[Member] = []
    cuts: list[Member] = []
    for x, z in mounts:           # from each tip-disk screw out to the spine on its side
        sx = 1.0 if x >= 0 else -1.0
        members.append(Member(f"base bar ({x:g}, {z:g})", "box", (sx * (abs(x) - MOUNT_BAR / 2), sx * sp1, yb0, yb1,
                                                                 z - MOUNT_BAR / 2, z + MOUNT_BAR / 2)))
    cz = (clamp[4], clamp[5]) if clamp is not None else STRIP_CLAMP_Z
    members.append(Member("cross bar", "box", (-sp1, sp1, yb0, yb1, *cz)))     # joins the columns
    if clamp is not None:
        members.append(Member("strip clamp", "box", clamp))
    base_z = [v for _, z in mounts for v in (z - MOUNT_BAR / 2, z + MOUNT_BAR / 2)] + list(cz)
    reach = max(pair.ra1, DRIVE_FLANGE[0] / 2, POST / 2)
    for s in (1, -1):
        col = sorted((u for u in fr.units if u.side == s), key=lambda u: u.center[1])
        x0, x1 = s * sp0, s * sp1
        z_lo, z_hi = min(base_z), max(base_z)
        if col:
            z_lo, z_hi = min(z_lo, col[0].lower_bar[0]), max(z_hi, col[0].upper_shelf[1])
        members.append(Member(f"spine foot {'+' if s > 0 else '-'}x", "box", (x0, x1, yb0, yb1, z_lo, z_hi)))
        y_from, prev = yb0, (z_lo, z_hi)
        for u in col:
            top = max(u.center[1] + pair.outside_radius, u.worm_y + reach)
            z0, z1 = u.lower_bar[0], u.upper_shelf[1]
            if z1 < prev[0] + SHELF or z0 > prev[1] - SHELF:     # no shared z with the pad below: reach it
                z0, z1 = min(z0, prev[0]), max(z1, prev[1])
            members.append(Member(f"{u.channel} spine", "box", (x0, x1, y_from, top, z0, z1)))
            if not with_cuts:
                y_from, prev = top - SHELF, (z0, z1)
                continue
            r_boss = max(DRIVE_FLANGE[0] / 2, pair.ra1) + FRAME      # the worm's thrust face and the shaft's flange
            cuts += _windows(f"{u.channel} spine", 0, x0 - s, x1 + s, (y_from, top), (z0, z1),
                             [(y_from, y_from + SHELF + FRAME, z0, z1),
                              (u.worm_y - r_boss, u.worm_y + r_boss, u.worm_z - r_boss, u.worm_z + r_boss),
                              (y_from, top, z0, u.lower_bar[1] + FRAME), (y_from, top, u.upper_shelf[0] - FRAME, z1)])
            y_from, prev = top - SHELF, (z0, z1)
    for u in fr.units:
        _unit_members(u, fr, sz, members, cuts if with_cuts else None, ts)
    if with_cuts:
        _base_cuts(fr, clamp, sz, mounts, fast, members, cuts)
    return members, cuts if with_cuts else []


FRAME = 3.0              # material left around a window and beside every feature a plate carries
WINDOW_MIN = 6.0         # narrower openings are not worth cutting


def _free(lo: float, hi: float, keep: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The parts of [lo, hi] outside every kept band, each at least WINDOW_MIN long."""
    return [(a, b) for a, b in interval_difference(lo, hi, keep) if b - a >= WINDOW_MIN]


def _windows(name: str, axis: int, lo: float, hi: float, ys: tuple[float, float], vs: tuple[float, float],
             keep: list[tuple[float, float, float, float]]) -> list[Member]:
    """Openings through a plate (normal along x for axis 0, z for axis 2; its other in-plane axis
    is v) wherever it carries nothing: ``keep`` lists the rectangles (y0, y1, v0, v1) that must
    stay solid (a FRAME-wide band is kept along every edge too). Each opening is a hexagon whose
    roof and floor slope at 45° in y, the plate's upright direction when the housing stands on
    its base to print, so it builds without supports; one too wide for its height is split by
    ribs FRAME wide."""
    keep = keep + [(ys[0], ys[0] + FRAME, *vs), (ys[1] - FRAME, ys[1], *vs),
                   (*ys, vs[0], vs[0] + FRAME), (*ys, vs[1] - FRAME, vs[1])]
    out = []
    # strips in v between the edges of every kept rectangle; in each, the y spans free of them
    cuts_v = sorted({vs[0], vs[1], *(k[2] for k in keep), *(k[3] for k in keep)})
    for va, vb in zip(cuts_v, cuts_v[1:]):
        if vb - va < WINDOW_MIN or vb <= vs[0] or va >= vs[1]:
            continue
        blocking = [(k[0], k[1]) for k in keep if k[2] < vb - 1e-9 and k[3] > va + 1e-9]
        for y0, y1 in _free(ys[0], ys[1], blocking):
            out += _hexagons(name, axis, lo, hi, y0, y1, va, vb)
    return out


def _hexagons(name, axis, lo, hi, y0, y1, v0, v1) -> list[Member]:
    n = max(1, math.ceil((v1 - v0 + FRAME) / (y1 - y0 + FRAME)))
    w = (v1 - v0 - (n - 1) * FRAME) / n
    if w < WINDOW_MIN or y1 - y0 < w:
        return []
    out = []
    for k in range(n):
        a = v0 + k * (w + FRAME)
        c, h = a + w / 2, w / 2
        pts = [(y0 + h, a), (y0, c), (y0 + h, a + w), (y1 - h, a + w), (y1, c), (y1 - h, a)]
        out.append(Member(f"{name} window", "prism", (axis, lo, hi, *[q for pt in pts for q in pt])))
    return out


def _unit_members(u: Unit, fr: _Frame, sz: _Sizes, members, cuts, ts: Tensioner) -> None:
    """The unit's shelf, bosses, lower bar and far post; and, unless ``cuts`` is None, its bores
    and the shelf's windows."""
    s = u.side
    cx, cy = u.center
    wy, wz = u.worm_y, u.worm_z
    p0, p1 = fr.post
    sp0, sp1 = fr.spine
    c = u.channel
    members += [
        Member(f"{c} shelf", "box", (s * p0, s * sp1, cy - s * BOSS, wy + s * POST / 2, *u.upper_shelf)),
        Member(f"{c} upper boss", "cyl", (BOSS, cx, cy, u.z_part[1] + GAP, cx, cy, u.upper_shelf[1])),
        Member(f"{c} lower bar", "box", (cx, s * sp1, cy - BOSS, cy + BOSS, *u.lower_bar)),
        Member(f"{c} lower boss", "cyl", (BOSS, cx, cy, u.lower_bar[0], cx, cy, u.z_part[0] - GAP)),
        Member(f"{c} post", "box", (s * p0, s * p1, wy - POST / 2, wy + POST / 2, wz - POST / 2, u.upper_shelf[1])),
    ]
    if cuts is None:
        return
    y_boss, y_post = sorted((cy - s * BOSS, cy + s * BOSS)), sorted((wy - POST / 2, wy + POST / 2))
    shelf_y = (min(y_boss[0], y_post[0]), max(y_boss[1], y_post[1]))
    xs = tuple(sorted((s * p0, s * sp1)))
    cuts += _windows(f"{c} shelf", 2, u.upper_shelf[0] - 1, u.upper_shelf[1] + 1, shelf_y, xs,
                     [(y_boss[0] - FRAME, y_boss[1] + FRAME, *xs), (y_post[0] - FRAME, y_post[1] + FRAME, *xs),
                      (*shelf_y, *sorted((s * p0, s * (p1 + FRAME)))), (*shelf_y, cx - BOSS - FRAME, cx + BOSS + FRAME),
                      (*shelf_y, *sorted((s * (sp0 - FRAME), s * sp1)))])
    press = (ts.shaft_diameter - ts.press_fit) / 2
    cuts += [
        # dowel bores (press fit): wheel pins along z, worm pin along x through the post
        Member(f"{c} upper pin", "cyl", (press, cx, cy, u.z_part[1], cx, cy, u.upper_shelf[1] + 1.0)),
        Member(f"{c} lower pin", "cyl", (press, cx, cy, u.lower_bar[0] - 1.0, cx, cy, u.z_part[0])),
        Member(f"{c} worm pin", "cyl", (press, s * (p0 - 1.0), wy, wz, s * (p1 + 1.0), wy, wz)),
        # the drive shaft's bearing through the spine
        Member(f"{c} drive hole", "cyl", (sz.spine_hole / 2, s * (sp0 - 1.0), wy, wz, s * (sp1 + 1.0), wy, wz)),
    ]


def tip_joint(fast: str, tip_thickness: float, base_t: float) -> Fastening:
    """The screws that hold the housing to the tip disk, through the disk into the base bars."""
    return joint(fast, "M3", tip_thickness, base_t)


def _set_screws(clamp, sz: _Sizes, fast: str, cuts) -> None:
    """Two M3 set screws press the strip in its slot from the clamp's thick side: through a nut
    that slides into a side slot from the block's end (resin), or an insert (thermoplastic)."""
    hx, hz = sz.strip_half_x, sz.strip_half_z
    ym = (clamp[2] + clamp[3]) / 2
    up = 1.0 if clamp[5] > abs(clamp[4]) else -1.0          # the set screws come from the thick side
    face = clamp[5] if up > 0 else clamp[4]
    for x in (-hx / 2, hx / 2):
        if fast == "nut":
            af, h = NUT["M3"]
            w, t = af + NUT_PLAY, h + NUT_PLAY
            zn = up * (hz + abs(face)) / 2                  # nut halfway between strip and face
            cuts.append(Member("set screw", "cyl", (M3_CLEARANCE / 2, x, ym, up * hz, x, ym, face + up)))
            # side-entry slot from the block's end along x: the nut slides in, its flats held
            sx = 1.0 if x > 0 else -1.0
            x_end = (clamp[1] if x > 0 else clamp[0]) + sx
            cuts.append(Member("set screw nut slot", "box", (*sorted((x - sx * w / 2, x_end)),
                                                             ym - w / 2, ym + w / 2, zn - t / 2, zn + t / 2)))
        else:
            bore, depth = INSERT["M3"]
            cuts.append(Member("set screw insert", "cyl", (bore / 2, x, ym, face - up * depth, x, ym, face + up)))


def _tip_screws(sz: _Sizes, mounts, fast: str, cuts) -> None:
    """The screws through the tip disk into the base bars: nuts in side slots, or inserts."""
    yb0, yb1 = sz.y_face, sz.y_face + sz.base_t
    j = tip_joint(fast, sz.tip_t, sz.base_t)
    for x, z in mounts:
        if j.kind == "nut":
            w = NUT["M3"][0] + NUT_PLAY
            cuts.append(Member("tip screw", "cyl", (j.hole / 2, x, yb0 - 1, z, x, yb1 + 1, z)))
            sgn = 1.0 if z >= 0 else -1.0                   # the nut slides in from the bar's outer side
            cuts.append(Member("tip screw nut slot", "box", (x - w / 2, x + w / 2, yb0 + j.nut_from, yb0 + j.depth,
                                                            *sorted((z - sgn * w / 2, z + sgn * MOUNT_BAR)))))
        else:
            cuts.append(Member("tip screw insert", "cyl", (j.hole / 2, x, yb0 - 1, z, x, yb0 + j.depth, z)))


def _base_cuts(fr: _Frame, clamp, sz: _Sizes, mounts, fast: str, members, cuts) -> None:
    """The strip's slot and set screws, the tip-disk screws and the tendons' passages."""
    hx, hz = sz.strip_half_x, sz.strip_half_z
    c = STRIP_SLOT_CLEARANCE
    yb0, yb1 = sz.y_face, sz.y_face + sz.base_t
    if sz.y_end + c > yb0 - 1:
        cuts.append(Member("strip slot", "box", (-hx - c, hx + c, yb0 - 1, sz.y_end + c, -hz - c, hz + c)))
    if clamp is not None:
        _set_screws(clamp, sz, fast, cuts)
    _tip_screws(sz, mounts, fast, cuts)
    holes: dict[tuple[float, float], float] = {}
    for r in fr.runs:
        drift = sz.base_t * math.tan(math.radians(r.exit_angle_deg))
        key = (round(r.start[0], 6), round(r.start[2], 6))
        holes[key] = max(holes.get(key, 0.0), TENDON_HOLE + 2 * drift)
    for (x, z), dia in holes.items():
        in_base = any(m.kind == "box" and m.dims[2] <= yb0 + 1e-9 and m.dims[0] - dia / 2 < x < m.dims[1] + dia / 2
                      and m.dims[4] - dia / 2 < z < m.dims[5] + dia / 2 for m in members)
        if in_base:
            cuts.append(Member("tendon passage", "cyl", (dia / 2, x, yb0 - 1, z, x, yb1 + 1, z)))


# ---------------------------------------------------------------- the search

@dataclass
class _Best:
    arrangement: _Arrangement
    x_u: float
    frame: _Frame
    clamp: tuple
    sz: _Sizes
    members: list
    cuts: list
    load: float


@dataclass(frozen=True)
class _Candidate:
    bound: float                 # the load at the narrowest x_u and no lift: no placement of it loads less
    arrangement: _Arrangement
    eyelets: Eyelets
    stacks: dict
    clamp: tuple
    mounts: list


def layout(design: Design, paths: list[TendonPath], tip: DiskSpec) -> TensionerLayout:
    """Where every part of the tensioner goes, on the tip disk ``tip``: of the arrangements that
    keep every tendon clear, the one that loads the strip least. NoFit (a ValueError) names the
    tendon, what it hits and the parameter that would free it when none does.

    The load is the tip deflection the tensioner's weight causes on a cantilever of the
    backbone's length, up to a constant: estimated volume × (2L + 3d), d the distance of its
    centre of mass beyond the tip face (a weight P at d beyond the tip of a cantilever L
    deflects it by P·L²·(L/3 + d/2)/EI). Arrangements are solved in order of a lower bound
    on that load, so most are never solved.
    """
    ts = design.tensioner
    sz = _Sizes.of(design, tip)
    fast = fastening(design.process.technology)
    robot_eyelets = _tip_eyelets(paths, ts.channels)
    x_min = _x_floor(robot_eyelets, sz)
    candidates = []
    blockers: list = []
    for turn in (1, -1):
        eyelets = _turned(robot_eyelets, turn)
        mounts = [(turn * x, turn * z) for x, z, _ in tip.mount_holes]
        stack_sets: set = set()
        for gear_rule in GEAR_RULES:
            stacks = {c: _unit_stack([z for _, _, z in eyelets[c]], sz.pair, gear_rule) for c in ts.channels}
            sig = tuple((c, stacks[c].z_part, stacks[c].gear) for c in sorted(stacks))
            if sig in stack_sets:            # another rule already gave every unit this stack
                continue
            stack_sets.add(sig)
            clamp_sets: set = set()
            for up in (1, -1):
                clamp = _strip_clamp(sz, up)
                blocked = _clamp_blockers(eyelets, clamp, sz)
                if blocked:                   # some tendon would run through the clamp on this side
                    blockers.append(blocked[0])
                    continue
                # which units and tendons the clamp side can touch: the same for both sides, one is enough
                touch = None if clamp is None else (
                    tuple(sorted(c for c in stacks if _meets_clamp(stacks[c], clamp))),
                    tuple(sorted(n for v in eyelets.values() for n, _, z in v
                                 if clamp[4] - 2 * sz.need < z < clamp[5] + 2 * sz.need)))
                if touch in clamp_sets:
                    continue
                clamp_sets.add(touch)
                for arr in _arrangements(turn, up, gear_rule, eyelets, stacks, clamp):
                    fr = _lifted(x_min, arr, stacks, eyelets, ts.winding, clamp, sz)
                    members, _ = _housing(fr, clamp, sz, mounts, fast, ts, with_cuts=False)
                    candidates.append(_Candidate(_load(members, fr, sz, design.backbone.length), arr, eyelets,
                                                 stacks, clamp, mounts))
    if not candidates:
        n, x, z = blockers[0]
        short = sz.y_face + sz.base_t + CLAMP_MIN - design.backbone.length
        raise NoFit(f"tendon {n} leaves the tip at x = {x:g}, z = {z:g} mm, in the strip's plane, where the "
                    f"block that clamps the strip's tip stands ({STRIP_CLAMP_Z[0]:g} to {STRIP_CLAMP_Z[1]:g} mm "
                    f"from the strip plane, the thick side either way): move its tip "
                    f"eyelet off the strip plane (its routing at the last station), or make backbone.extra_tip "
                    f"less than {short:.0f} mm so the strip ends before any clamp")
    candidates.sort(key=lambda c: (c.bound, c.arrangement.key))
    best: _Best | None = None
    failures: list[_Failure] = []
    solved = 0
    for c in candidates:
        if best is not None and c.bound >= best.load or solved >= MAX_SOLVES:
            break
        solved += 1
        try:
            x_u, fr = _solve(c.arrangement, c.stacks, c.eyelets, ts.winding, c.clamp, sz)
        except _Infeasible as e:
            failures.append(e.failure)
            continue
        members, cuts = _housing(fr, c.clamp, sz, c.mounts, fast, ts)
        load = _load(members, fr, sz, design.backbone.length)
        if best is None or (load, c.arrangement.key) < (best.load, best.arrangement.key):
            best = _Best(c.arrangement, x_u, fr, c.clamp, sz, members, cuts, load)
    if best is None:
        raise NoFit(_explain(failures, len(candidates), ts))
    return _assemble(best, ts, fast, len(candidates), solved)


def _lifted(x_u: float, arr, stacks, eyelets, winding, clamp, sz: _Sizes) -> _Frame:
    """The frame at this x_u lifted until every exit angle is allowed, ignoring clearance: at
    the narrowest x_u, the least lift any placement of the arrangement needs."""
    lift = 0.0
    for _ in range(MAX_LIFTS):
        fr = _frame(x_u, arr, _place_units(arr, stacks, clamp, sz, lift), stacks, eyelets, winding, sz)
        need = _exit_lift(fr, sz)
        if need <= 1e-6:
            break
        lift += need
    return fr


def _exit_lift(fr: _Frame, sz: _Sizes) -> float:
    """How much further along y the units must go for every tendon to turn by at most max_exit."""
    return max((abs(r.end[0] - r.start[0]) / math.tan(sz.max_exit) - (r.end[1] - r.start[1]) for r in fr.runs),
               default=0.0)


def _load(members: list[Member], fr: _Frame, sz: _Sizes, length: float) -> float:
    """Estimated volume × (2L + 3d): proportional to the tip deflection the tensioner's weight
    causes (members and wheels by their envelopes; worms and caps are the same in every
    arrangement and only shift d a little)."""
    vols = [m.volume for m in members] + [math.pi * sz.r_f ** 2 * (u.z_part[1] - u.z_part[0]) for u in fr.units]
    ys = [m.centre_y for m in members] + [u.center[1] for u in fr.units]
    v = float(sum(vols))
    d = float(np.dot(vols, ys)) / v - sz.y_face
    return v * (2 * length + 3 * d)


def _explain(failures: list[_Failure], tried: int, ts: Tensioner) -> str:
    """The closest miss among the arrangements tried, and what would free it."""
    f = max(failures, key=lambda f: f.clearance)
    if f.kind == "exit":
        return (f"no tensioner layout turns every tendon by at most tensioner.max_exit_deg = {ts.max_exit_deg:g}° "
                f"at the tip ({tried} arrangements tried): tendon {f.tendon} needs {f.obstacle}; allow a larger "
                f"turn (tensioner.max_exit_deg) or fewer channels")
    if f.kind == "clamp":
        return (f"no tensioner layout keeps every tendon clear ({tried} arrangements tried): tendon {f.tendon} "
                f"leaves the tip beside the strip's tip clamp and passes it {-f.clearance:.2f} mm too close; move "
                f"its tip eyelet off the strip plane (its routing at the last station) or shorten "
                f"backbone.extra_tip so the clamp ends sooner")
    return (f"no tensioner layout keeps every tendon clear ({tried} arrangements tried): at best tendon "
            f"{f.tendon} passes the {f.obstacle} {-f.clearance:.2f} mm closer than tensioner.tendon_clearance "
            f"= {ts.tendon_clearance:g} mm allows; smaller gears (tensioner.module, tensioner.wheel_teeth, "
            f"tensioner.worm_pitch_diameter), a smaller tendon_clearance or fewer channels would free it")


def _assemble(b: _Best, ts: Tensioner, fast: str, tried: int, solved: int) -> TensionerLayout:
    sz, fr, arr = b.sz, b.frame, b.arrangement
    turn = np.diag([float(arr.turn), 1.0, float(arr.turn), 1.0])
    runs = tuple(TendonRun(r.tendon, r.channel, tuple(float(v) for v in turn[:3, :3] @ r.start),
                           tuple(float(v) for v in turn[:3, :3] @ r.end), r.exit_angle_deg, r.sense)
                 for r in fr.runs)
    search = {"arrangements": tried, "solved": solved, "turned_over": arr.turn < 0,
              "set_screws_from": "+z" if arr.turn * arr.clamp_up > 0 else "-z", "gear_rule": arr.gear_rule,
              "order": list(arr.order), "columns": list(arr.sides),
              "housing_members_mm3": round(sum(m.volume for m in b.members), 1), "load_estimate": round(b.load)}
    return TensionerLayout(sz.pair, sz.y_face, b.x_u, fr.spine, fr.post, fr.worm_x, fr.worm_file_to_mesh,
                           fr.near_end, sz.spine_hole, _pin_length(POST),
                           fr.units, runs, sz.r_s, sz.r_w, sz.r_f, sz.hub_r,
                           (sz.strip_half_x, sz.strip_half_z, sz.y_face, sz.y_end), b.clamp,
                           tuple(b.members), tuple(b.cuts), turn, fast, sz.base_t, ts, search)
