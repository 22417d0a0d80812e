"""Layout of the worm-gear tensioner at the tip (numpy only, no CAD kernel).

Robot frame as everywhere: the backbone along +y, the tip disk's outer face at
y = y_face, x across the strip, z through it. The tensioner sits on that face.

One *unit* per channel: a wheel part (gear + spool drum) turning on two dowel stubs along
z, and a worm along x meshing on the wheel's +y side (-y in the left column). The worm
enters from outside through a hole in the spine, turns on a dowel in the far post and in
a bearing cap screwed over that hole, whose bore leaves its hex socket open to the key.

Every tendon runs in its own plane z = z_e (its tip eyelet's z) in one straight line from
the tip eyelet to the tangent point on the side of its channel's drum that faces x = 0,
so it touches nothing on the way; the drum's winding zones sit at those z, the gear at one
end of the drum, the housing's shelves above and below. Units alternate between a right
column (+x) and a left one (a right unit turned 180° about z); both share one wheel-axis
|x| (X_u) and a spine wall on their outer side that carries the worms. Units are stacked
along +y; those whose parts would reach the strip's clamp go beyond it. X_u is the
smallest value for which every tendon clears every other part of the layout by the
margin below, and the stack is lifted off the tip until no tendon turns by more than
MAX_EXIT_DEG at its tip eyelet (the exported meshes are measured again by the checks).

The actuating pair (channel A: A1 at z = +30, A2 at z = -30) winds on one drum in the
same sense: turning the worm shortens both equally, which is how the paper pre-tensions
the pair so the beam stays straight (Sect. III-A, IV). Wound in opposite senses the
worm would bend the robot instead of tensioning it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..params import Design, Tensioner
from .gearing import WORM_TO_MESH, WormPair, worm_pair
from .routing import TendonPath
from .specs import DiskSpec

# Spool and wheel part (mm)
WIND_WIDTH = 3.0         # axial length of one tendon's winding zone
FLANGE_HEIGHT = 2.5      # flange radius above the drum core: holds a few turns of 0.15 mm line
FLANGE = 1.2             # flange thickness (≥ 0.8 mm process wall)
CLAMP_GAP = 3.5          # axial gap between the inner flange and the wheel face, room for the clamp
WORM_CLEAR = 1.5         # least z distance from a worm to its own unit's tendon planes
HUB_WALL = 2.0           # radial wall of the drum around the pin bore
# Tendon clamp: an M2 screw into a heat-set insert in the wheel face (standard M2 insert sizes)
CLAMP_SCREW = 2.0        # M2
CLAMP_INSERT_BORE = 3.2  # bore for an M2 × 4 heat-set insert
CLAMP_INSERT_DEPTH = 4.0
CLAMP_PLATE = (6.0, 5.0, 1.5)   # clamp plate x, y, thickness
CLAMP_HEAD = 1.4         # M2 low head (ISO 7380) height above the plate
ANCHOR_HOLE = 1.0        # axial hole through the inner flange the tendon leaves the drum by
CAP = 5.0                # end cap at the far end of a two-zone drum, holds the second clamp insert
# Housing (mm)
GAP = 0.5                # axial gap between a turning part and a housing face
SHELF = 4.0              # shelf and bar thickness
SPINE = 7.0              # spine wall thickness (x): holds the M3 inserts of the worm caps
WORM_CAP = 4.0           # flange of the bearing cap that closes each worm's spine hole, x
CAP_WALL = 1.5           # resin between the spine hole, the cap's screw inserts and the flange's edge
COLLAR = 1.5             # thrust collar on the worm between its thread and hex journal, length
COLLAR_STEP = 1.0        # its radial step over the journal (a small face: the worm prints on its end)
AXIAL_PLAY = 0.25        # worm end play between the far post and the cap's spigot
BASE = 6.0               # base plate thickness (y), on the tip disk
POST = 7.0               # far worm bearing post, square section
BOSS = 3.5               # radius of the pin bosses and bars around a dowel
UNIT_GAP = 2.0           # y gap between neighbouring units' parts
PIN_ENGAGE = 5.0         # dowel length inside a turning part's bore
PIN_LENGTHS = (8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30)   # ISO 2338 lengths for Ø3, mm
STRIP_CLAMP_Z = (-1.5, 6.0)   # strip clamp block, z range (set screws from +z)
STRIP_CLAMP_X = 2.0       # block beyond the strip's edges, x
STRIP_SLOT_CLEARANCE = 0.05   # per side, strip in its slot
SET_SCREW_INSERT = 4.0    # M3 heat-set insert bore for the strip's set screws
MOUNT_INSERT = 4.0        # M3 heat-set insert bore for the tip-disk screws
M3_INSERT = 4.0           # M3 x 5.7 heat-set insert bore (worm caps)
M3_INSERT_DEPTH = 6.0
M3_CLEARANCE = 3.4        # ISO 273 normal
TENDON_HOLE = 3.0         # minimum hole through the base plate around a tendon
# Layout search
TENDON_MARGIN = 0.5       # layout clearance from a tendon to any other part (tests require ≥ d)
X_STEP = 0.5
MAX_EXIT_DEG = 20.0      # largest turn of a tendon at its tip eyelet (the shared C hole is sized for 28°)
X_SEARCH = 80.0


@dataclass(frozen=True)
class TendonRun:
    """A tendon's free span: from its tip eyelet (on the tip face) to its spool's tangent point."""

    tendon: str
    channel: str
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    exit_angle_deg: float           # angle to +y at the tip face

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.subtract(self.end, self.start)))


@dataclass(frozen=True)
class Unit:
    """One channel's worm drive, in robot coordinates (mm)."""

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
class TensionerLayout:
    pair: WormPair
    y_face: float
    x_u: float
    spine: tuple[float, float]                  # |x| range of both spines
    post: tuple[float, float]                   # |x| range of every far post
    worm_x: tuple[float, float]                 # |x| range of every worm (far end, spine outer face)
    worm_file_to_mesh: np.ndarray               # 4x4 worm file -> mesh frame
    hex_journal: float                          # length of the journal carrying the hex socket
    spine_hole: float                           # diameter of the hole each worm enters the spine by
    cap_spigot: float                           # cap spigot length from the flange's inner face, |x|
    cap_half: float                             # half-size of the square cap flange
    cap_screw: float                            # cap screws at worm_y ± this
    worm_pin: float                             # dowel the worm's far end turns on, pressed into the post
    units: tuple[Unit, ...]
    runs: tuple[TendonRun, ...]
    spool_radius: float
    winding_radius: float
    flange_radius: float
    hub_radius: float
    strip: tuple[float, float, float, float]    # strip x half-width, z half-thickness, y start of clamp, y end
    clamp_block: tuple[float, float, float, float, float, float]   # x0, x1, y0, y1, z0, z1
    base: tuple[float, float, float, float, float, float]          # x0, x1, y0, y1, z0, z1
    mount_holes: tuple[tuple[float, float, float], ...]            # (x, z, bore) on the base plate
    tendon_holes: tuple[tuple[float, float, float], ...]           # (x, z, diameter) through the base plate
    params: Tensioner                                              # the YAML's tensioner section

    def unit(self, channel: str) -> Unit:
        return next(u for u in self.units if u.channel == channel)

    # --- placements: part file -> robot --------------------------------------------------
    def mesh_to_robot(self, unit: Unit) -> np.ndarray:
        """Mesh frame of :mod:`hwgen.gears` -> robot: mesh X -> side·y (toward the worm),
        mesh Y (worm axis) -> -side·x, mesh Z (wheel axis) -> +z; origin at the wheel's mid-plane."""
        m = np.eye(4)
        s = unit.side
        m[:3, :3] = np.array([[0.0, -s, 0.0], [s, 0.0, 0.0], [0.0, 0.0, 1.0]])
        m[:3, 3] = [unit.center[0], unit.center[1], unit.z_wheel_mid]
        return m

    def stack_placement(self, unit: Unit) -> np.ndarray:
        """The wheel part with its axis on Z and its lowest robot z at Z = 0 -> robot."""
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
        return self.mesh_to_robot(unit) @ self.worm_file_to_mesh


def _wheel_stack(zs: list[float], b: float, worm_radius: float):
    """Winding zones, flanges, end caps, gear and clamp faces along z for tendons at heights zs.

    The gear goes at one end of the stack (its face is the part's largest flat face and
    prints on the plate): toward the strip plane when every tendon is on one side of it,
    else above the top zone. A tendon whose zone is next to the gear is clamped on the
    gear's face; one at the far end on an end cap there.
    """
    zs = sorted(zs)
    half = WIND_WIDTH / 2
    zones = tuple((z - half, z + half) for z in zs)
    flanges = []
    for lo, hi in zones:
        flanges += [(lo - FLANGE, lo), (hi, hi + FLANGE)]
    reach = CLAMP_PLATE[2] + CLAMP_HEAD
    caps, clamps = [], []
    if zs[0] >= 0:          # all above the strip plane: the gear goes below, toward it
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
    raise ValueError(f"no standard Ø3 dowel is {need:.1f} mm long (longest {PIN_LENGTHS[-1]} mm)")


def _seg_point_dist(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> float:
    ab = b - a
    t = np.clip(np.dot(p - a, ab) / max(np.dot(ab, ab), 1e-12), 0, 1)
    return float(np.linalg.norm(a + t * ab - p))


def _seg_rect_dist(a, b, x0, x1, y0, y1) -> float:
    t = np.linspace(0, 1, max(2, int(np.linalg.norm(b - a) / 0.25) + 1))[:, None]
    pts = a + t * (b - a)
    dx = np.maximum.reduce([x0 - pts[:, 0], np.zeros(len(pts)), pts[:, 0] - x1])
    dy = np.maximum.reduce([y0 - pts[:, 1], np.zeros(len(pts)), pts[:, 1] - y1])
    return float(np.min(np.hypot(dx, dy)))


def _tangent_point(p: np.ndarray, c: np.ndarray, r: float, side: int) -> np.ndarray:
    """Tangent point on circle (c, r) of the line from p, on the drum's side facing x = 0
    (-x for the right column, +x for the left)."""
    d = c - p
    dist = np.linalg.norm(d)
    if dist <= r:
        raise ValueError("tendon eyelet inside its spool")
    base = math.atan2(d[1], d[0])
    off = math.asin(r / dist)
    best = None
    for s in (1, -1):
        ang = base + s * off
        tlen = math.sqrt(dist ** 2 - r ** 2)
        t = p + tlen * np.array([math.cos(ang), math.sin(ang)])
        if best is None or side * t[0] < side * best[0]:
            best = t
    return best


def spool_wall_problem(ts: Tensioner, min_wall: float) -> str | None:
    """Why the spool drum leaves too little wall around its pin's bore, or None."""
    if ts.spool_diameter < ts.shaft_diameter + ts.running_fit + 2 * min_wall:
        return (f"{ts.spool_diameter:g} mm leaves less than {min_wall:g} mm of wall around "
                f"the Ø{ts.shaft_diameter:g} mm pin's bore")
    return None


@dataclass(frozen=True)
class _Sizes:
    """Dimensions every unit shares, derived once from the parameters (mm)."""

    pair: WormPair
    y_face: float            # the tip disk's outer face
    tendon_d: float
    r_s: float               # spool core radius
    r_w: float               # winding radius: the tendon's centre on the drum
    r_f: float               # flange radius
    hub_r: float
    spine_hole: float        # the worm and its collar pass through
    cap_screw: float
    cap_half: float
    strip_half_x: float
    strip_half_z: float
    y_end: float             # the strip's tip end

    @staticmethod
    def of(d: Design, tip: DiskSpec) -> _Sizes:
        ts = d.tensioner
        pair = worm_pair(ts)
        r_s = ts.spool_diameter / 2
        problem = spool_wall_problem(ts, d.process.min_wall)
        if problem:
            raise ValueError(f"tensioner.spool_diameter {problem}")
        spine_hole = 2 * pair.ra1 + 1.0
        cap_screw = spine_hole / 2 + M3_INSERT / 2 + CAP_WALL
        return _Sizes(pair, tip.y + tip.thickness / 2, d.tendon_material.diameter, r_s,
                      r_s + d.tendon_material.diameter / 2, r_s + FLANGE_HEIGHT,
                      max(ts.shaft_diameter / 2 + ts.running_fit / 2 + HUB_WALL, r_s),
                      spine_hole, cap_screw, cap_screw + M3_CLEARANCE / 2 + CAP_WALL,
                      d.backbone.height / 2, d.backbone.thickness / 2,
                      d.backbone.length + d.backbone.extra_tip)


@dataclass(frozen=True)
class _Stack:
    """One unit's parts along z (robot z, mm), before it is placed in x and y."""

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


def _tip_eyelets(paths: list[TendonPath], channels) -> dict[str, list[tuple[str, float, float]]]:
    """(tendon, x, z) of every tendon at the tip disk, per channel; refuses what one drum cannot wind."""
    eyelets: dict[str, list[tuple[str, float, float]]] = {c: [] for c in channels}
    for p in paths:
        x, z = (float(v) for v in p.points[-1])
        eyelets[p.channel].append((p.name, x, z))
    for c, here in eyelets.items():
        if not here:
            raise ValueError(f"tensioner channel {c!r} has no tendon")
        xs = {round(x, 6) for _, x, _ in here}
        if len(xs) > 1:
            raise ValueError(f"channel {c!r}: its tendons leave the tip at different x {sorted(xs)}; a drum "
                             f"winds tendons lying in planes z = const that share one tangent line")
    for c, here in eyelets.items():
        zs = sorted(z for _, _, z in here)
        for z0, z1 in zip(zs, zs[1:]):
            if z1 - z0 < WIND_WIDTH + 2 * FLANGE:
                raise ValueError(f"channel {c!r}: tendons at z = {z0:g} and {z1:g} are too close to wind "
                                 f"side by side ({WIND_WIDTH + 2 * FLANGE:g} mm needed)")
    return eyelets


def _unit_stack(zs: list[float], pair: WormPair) -> _Stack:
    """The z stack of one unit: wheel part, shelf above, bar below, and the dowels between."""
    b = pair.face_width
    zones, flanges, caps, gear, clamps, z_part, span = _wheel_stack(zs, b, pair.ra1)
    zw = (gear[0] + gear[1]) / 2
    hi = max(span[1], zw + pair.ra1)
    lo = span[0]
    upper = (hi + GAP, hi + GAP + SHELF)
    lower = (lo - GAP - SHELF, lo - GAP)
    pins = (_pin_length(z_part[0] - GAP - lower[0]), _pin_length(upper[1] - (z_part[1] + GAP)))
    return _Stack(zones, flanges, caps, gear, clamps, z_part, zw, upper, lower, pins)


def _strip_clamp(sz: _Sizes) -> tuple[float, float, float, float, float, float]:
    """The block that clamps the strip's tip end: x0, x1, y0, y1, z0, z1."""
    return (-sz.strip_half_x - STRIP_CLAMP_X, sz.strip_half_x + STRIP_CLAMP_X, sz.y_face + BASE, sz.y_end + 2.0,
            STRIP_CLAMP_Z[0], STRIP_CLAMP_Z[1])


def _place_units(order: list[str], stacks: dict[str, _Stack], clamp, sz: _Sizes, lift: float):
    """Columns and wheel-axis heights y: units alternate right (+x) and left, stacked along +y;
    a unit whose z span meets the strip clamp goes beyond it. Returns (side, centre y) per channel."""
    pair = sz.pair
    side = {c: (1 if i % 2 == 0 else -1) for i, c in enumerate(order)}
    wheel_reach = max(pair.ra2, sz.r_f, BOSS) + UNIT_GAP / 2
    worm_reach = pair.center_distance + max(sz.cap_half, POST / 2) + UNIT_GAP / 2
    centers_y: dict[str, float] = {}
    y_next = {1: sz.y_face + BASE + GAP + lift, -1: sz.y_face + BASE + GAP + lift}
    for c in order:
        s = side[c]
        below, above = (wheel_reach, worm_reach) if s > 0 else (worm_reach, wheel_reach)
        floor = clamp[3] + GAP if _meets_clamp(stacks[c], clamp) else y_next[s]
        yc = max(y_next[s], floor) + below
        centers_y[c] = yc
        y_next[s] = yc + above
    return side, centers_y


def _meets_clamp(stack: _Stack, clamp) -> bool:
    z0, z1 = stack.z_span
    return z0 < clamp[5] + GAP and z1 > clamp[4] - GAP


@dataclass(frozen=True)
class _Frame:
    """The units placed at one wheel-axis |x| (x_u), with the worms, spines and posts that follow."""

    spine: tuple[float, float]
    hex_journal: float
    worm_file_to_mesh: np.ndarray
    worm_x: tuple[float, float]
    post: tuple[float, float]
    units: tuple[Unit, ...]
    runs: tuple[TendonRun, ...]


def _frame(x_u: float, order, side, centers_y, stacks, eyelets, sz: _Sizes) -> _Frame:
    """Everything at wheel-axis |x| = x_u. The worm runs along x from the spine inward, its
    thread centred on the wheel; it goes in from outside through a hole in the spine that its
    collar passes, and a bearing cap (spigot in that hole, flange screwed to the spine)
    carries the hex journal and holds the worm against the far post."""
    pair = sz.pair
    a = pair.center_distance
    L = pair.worm_length
    n = round(-L / (2 * pair.pitch))
    x_thread = x_u - n * pair.pitch                  # |x| of the thread's spine-side end
    spine_in = max(x_thread + COLLAR, x_u + pair.ra2 + GAP) + GAP
    spine = (spine_in, spine_in + SPINE)
    x_cap = spine[1] + WORM_CAP                      # |x| of the cap's and the worm's outer face
    hex_journal = x_cap - x_thread                   # worm file Z from the outer end to the thread
    ty = -hex_journal + n * pair.pitch               # a thread space on the wheel's tooth at mesh y = 0
    wf = np.eye(4)
    wf[:3, :3] = WORM_TO_MESH
    wf[:3, 3] = [a, ty, 0.0]
    x_outer = x_u - ty                               # |x| of worm file Z = 0 (= x_cap)
    x_far = x_outer - (hex_journal + L)
    post = (x_far - AXIAL_PLAY / 2 - POST, x_far - AXIAL_PLAY / 2)
    units = []
    for c in order:
        st, s = stacks[c], side[c]
        units.append(Unit(c, tuple(n_ for n_, _, _ in eyelets[c]), s, (s * x_u, centers_y[c]), st.z_part,
                          st.zones, st.flanges, st.caps, st.gear, st.clamps, centers_y[c] + s * a, st.z_wheel,
                          st.upper, st.lower, st.pins))
    runs = []
    for u in units:
        for name, x, z in eyelets[u.channel]:
            p0 = np.array([x, sz.y_face])
            t = _tangent_point(p0, np.array(u.center), sz.r_w, u.side)
            ang = math.degrees(math.atan2(abs(t[0] - x), t[1] - sz.y_face))
            runs.append(TendonRun(name, u.channel, (x, sz.y_face, z), (float(t[0]), float(t[1]), z), ang))
    return _Frame(spine, hex_journal, wf, (x_far, x_outer), post, tuple(units), tuple(runs))


def _zin(z: float, need: float, z0: float, z1: float) -> bool:
    return z0 - need < z < z1 + need


def _obstacles(run: TendonRun, fr: _Frame, clamp, sz: _Sizes) -> list[tuple[str, str, tuple]]:
    """Every part outline in the tendon's plane z: (name, "circle" (x, y, r) | "rect" (x0, x1, y0, y1))."""
    pair = sz.pair
    z = run.start[2]
    need = sz.tendon_d / 2 + TENDON_MARGIN
    shapes = []
    for u in fr.units:
        cx, cy = u.center
        s = u.side

        def zin(z0, z1):
            return _zin(z, need, z0, z1)

        def rect(x0, x1, y0, y1):
            xs = sorted((s * x0, s * x1))
            return (xs[0], xs[1], min(y0, y1), max(y0, y1))
        if u.channel != run.channel:
            if zin(*u.z_part):
                shapes.append((f"{u.channel} spool", "circle", (cx, cy, max(sz.r_f, sz.hub_r))))
            if zin(*u.z_gear):
                shapes.append((f"{u.channel} wheel", "circle", (cx, cy, pair.ra2)))
            for cap in u.caps:
                if zin(*cap):
                    shapes.append((f"{u.channel} cap", "circle", (cx, cy, pair.rf2)))
        reach = CLAMP_PLATE[2] + CLAMP_HEAD
        for zc, sg in u.clamps:
            if zin(min(zc, zc + sg * reach), max(zc, zc + sg * reach)):
                shapes.append((f"{u.channel} clamp", "circle", (cx, cy, pair.rf2)))
        if zin(u.worm_z - pair.ra1, u.worm_z + pair.ra1):
            shapes.append((f"{u.channel} worm", "rect", rect(fr.worm_x[0], fr.worm_x[1], u.worm_y - pair.ra1,
                                                             u.worm_y + pair.ra1)))
        if zin(u.worm_z - POST / 2, u.upper_shelf[1]):
            shapes.append((f"{u.channel} post", "rect", rect(fr.post[0], fr.post[1], u.worm_y - POST / 2,
                                                             u.worm_y + POST / 2)))
        if zin(*u.upper_shelf):
            shapes.append((f"{u.channel} shelf", "rect", rect(fr.post[0], fr.spine[1], cy - s * BOSS,
                                                              u.worm_y + s * POST / 2)))
            shapes.append((f"{u.channel} boss", "circle", (cx, cy, BOSS)))
        if zin(u.z_part[1], u.upper_shelf[0]):
            shapes.append((f"{u.channel} boss", "circle", (cx, cy, BOSS)))
        if zin(u.lower_bar[1], u.z_part[0]):
            shapes.append((f"{u.channel} boss", "circle", (cx, cy, BOSS)))
        if zin(*u.lower_bar):
            shapes.append((f"{u.channel} bar", "rect", rect(abs(cx) - BOSS, fr.spine[1], cy - BOSS, cy + BOSS)))
    for s in (1, -1):
        xs = sorted((s * fr.spine[0], s * fr.spine[1] * 10))
        shapes.append(("spine", "rect", (xs[0], xs[1], sz.y_face, math.inf)))
    if _zin(z, need, clamp[4], clamp[5]):
        shapes.append(("strip clamp", "rect", tuple(clamp[:4])))
    return shapes


def _clearance(fr: _Frame, clamp, sz: _Sizes) -> tuple[float, str]:
    """The smallest distance from any tendon's free span to a part it must not touch, and which."""
    worst, what = math.inf, ""
    for r in fr.runs:
        p0, p1 = np.array(r.start[:2]), np.array(r.end[:2])
        for name, kind, g in _obstacles(r, fr, clamp, sz):
            if kind == "circle":
                dist = _seg_point_dist(p0, p1, np.array(g[:2])) - g[2]
            else:
                dist = _seg_rect_dist(p0, p1, *g)
            if dist < worst:
                worst, what = dist, f"tendon {r.tendon} passes {name} at {dist:.2f} mm"
    return worst, what


def _widen(order, side, centers_y, stacks, eyelets, clamp, sz: _Sizes) -> tuple[float, _Frame]:
    """The smallest wheel-axis |x| at which every tendon clears every other part by the margin."""
    x_min = max(abs(x) for v in eyelets.values() for _, x, _ in v) + sz.r_w + TENDON_MARGIN
    x_u = x_min
    last = ""
    while x_u < x_min + X_SEARCH:
        fr = _frame(x_u, order, side, centers_y, stacks, eyelets, sz)
        worst, last = _clearance(fr, clamp, sz)
        # the far posts stay on their own side of x = 0, clear of the other column
        if worst >= sz.tendon_d + TENDON_MARGIN and fr.post[0] >= UNIT_GAP / 2:
            return x_u, fr
        x_u += X_STEP
    raise ValueError(f"no tensioner layout keeps every tendon clear: {last}")


def _lift_until_exits_fit(order, stacks, eyelets, clamp, sz: _Sizes) -> tuple[float, _Frame]:
    """Lift the stack off the tip until no tendon turns by more than MAX_EXIT_DEG at its tip eyelet."""
    lift = 0.0
    for _ in range(30):
        side, centers_y = _place_units(order, stacks, clamp, sz, lift)
        x_u, fr = _widen(order, side, centers_y, stacks, eyelets, clamp, sz)
        need = max((abs(r.end[0] - r.start[0]) / math.tan(math.radians(MAX_EXIT_DEG)) - (r.end[1] - r.start[1])
                    for r in fr.runs), default=0.0)
        if need <= 1e-6:
            return x_u, fr
        lift += need + X_STEP
    raise ValueError(f"no tensioner layout turns every tendon by less than {MAX_EXIT_DEG}° at the tip")


def _base_plate(fr: _Frame, tip: DiskSpec, sz: _Sizes):
    """The plate on the tip disk under everything; its tendon passages and the tip disk's screw inserts."""
    z_all = [v for u in fr.units for v in (u.lower_bar[0], u.upper_shelf[1])]
    r_tip = tip.outer_diameter / 2
    base = (-fr.spine[1], fr.spine[1], sz.y_face, sz.y_face + BASE,
            min(min(z_all), -r_tip), max(max(z_all), r_tip))
    holes: dict[tuple[float, float], float] = {}
    for r in fr.runs:
        drift = BASE * math.tan(math.radians(r.exit_angle_deg))
        key = (round(r.start[0], 6), round(r.start[2], 6))
        holes[key] = max(holes.get(key, 0.0), TENDON_HOLE + 2 * drift)
    tendon_holes = tuple((x, z, dia) for (x, z), dia in holes.items())
    mount = tuple((x, z, MOUNT_INSERT) for x, z, _ in tip.mount_holes)
    return base, tendon_holes, mount


def layout(design: Design, paths: list[TendonPath], tip: DiskSpec) -> TensionerLayout:
    """Where every part of the tensioner goes, on the tip disk ``tip``; ValueError when nothing fits."""
    ts = design.tensioner
    sz = _Sizes.of(design, tip)
    eyelets = _tip_eyelets(paths, ts.channels)
    stacks = {c: _unit_stack([z for _, _, z in eyelets[c]], sz.pair) for c in ts.channels}
    clamp = _strip_clamp(sz)
    order = ([c for c in ts.channels if not _meets_clamp(stacks[c], clamp)]
             + [c for c in ts.channels if _meets_clamp(stacks[c], clamp)])
    x_u, fr = _lift_until_exits_fit(order, stacks, eyelets, clamp, sz)
    base, tendon_holes, mount = _base_plate(fr, tip, sz)
    cap_spigot = fr.spine[1] - (fr.worm_x[1] - fr.hex_journal + COLLAR + AXIAL_PLAY / 2)
    return TensionerLayout(sz.pair, sz.y_face, x_u, fr.spine, fr.post, fr.worm_x, fr.worm_file_to_mesh,
                           fr.hex_journal, sz.spine_hole, cap_spigot, sz.cap_half, sz.cap_screw, _pin_length(POST),
                           fr.units, fr.runs, sz.r_s, sz.r_w, sz.r_f, sz.hub_r,
                           (sz.strip_half_x, sz.strip_half_z, sz.y_face, sz.y_end), clamp, base, mount,
                           tendon_holes, ts)
