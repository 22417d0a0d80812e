"""The rotating base frame of the paper's Fig. 3 (① worm gear, ② worm, ③④ base frame, ⑤ supporting
shaft, ⑥ timing pulley and belt, ⑦ lower shaft) laid out as plain numbers (numpy only), and the
statics its checks evaluate.

Robot coordinates (mm), the robot at roll angle 0 as the mount holds it: y along the backbone, z up.
The base mount (:mod:`hwgen.model.fixtures`) is not changed: its foot bolts with its own screws
(on its table grid) to a cradle, a plate under the foot and a round flange behind it, whose hub
sits on the supporting shaft ⑤ along the robot's axis (x = z = 0). The shaft turns in a ball bearing
in each of two uprights (front ④, back ③) behind the flange. A GT2 belt ⑥ (1:1) joins it to the
lower shaft ⑦, which carries the worm wheel ①; the worm ② lies across x under the wheel on a drive
shaft and a dowel, as the tensioner's worms do, and is turned with the tensioner's hex key. The
uprights and the worm's posts stand on a base plate that screws to a breadboard (M6 on 25 mm) or is
clamped to a table's edge. The robot's axis stands the turning envelope (the cradle's corners, the
disks, the tensioner) plus ``clearance_mm`` above the plate, so the robot turns through a full turn.

The cradle's flange carries an engraved mark every ``mark_step_deg`` and two index holes (0° and
90°): a Ø4 dowel through the front upright's index hole into one of them holds the robot at that
angle against anything the worm's backlash would let it do.

The worm pair is the tensioner's machinery (:class:`hwgen.model.gearing.WormPair`), its numbers
the tensioner's unless ``base_frame`` gives its own.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..params import Design
from . import bench_parts as bp
from .fixtures import BOLT_PATTERNS, MountLayout
from .gearing import WormPair, worm_pair
from .tensioner_layout.sizes import AXIAL_PLAY, DRIVE_FLANGE, GAP, POST, WORM_END

PLATE = 10.0                # the cradle's plate under the mount's foot, mm
FLANGE = 8.0                # the cradle's flange, along y, mm
HUB_RADIUS = 11.0           # the cradle's hub on the shaft, mm: a wall of 7 mm round an Ø8 shaft
HUB_GAP = 0.5               # the hub stops this short of the front upright (the bearing's inner ring turns), mm
UPRIGHT = 12.0              # each upright, along y: a 7 mm bearing and a 5 mm shoulder, mm
UPRIGHT_HALF_X = 30.0       # half the uprights' width, mm
BEARING_LIP = 1.0           # the bearing's seat stops this far short of the upright's other face (a shoulder), mm
PLATE_HOLE_EDGE = 8.0       # an M6 hole's centre from the base plate's edge, mm
BASE_PLATE = 8.0            # the base plate, mm
BETWEEN = 4.0               # between a pulley, the wheel's hub and an upright, mm
WHEEL_HUB = 6.0             # the wheel's hub beside its gear, along y, mm
WHEEL_HUB_RADIUS = 9.0
SHAFT_FLAT = 0.5            # depth of the ground flat on a shaft a part is fixed to by its D bore, mm
PRESS_FIT = 0.05            # diametral interference of a printed D bore on a ground shaft, mm
RUNNING_FIT = 0.2           # diametral clearance of a printed part turning on a dowel, mm
POST_Y = 12.0               # the worm's posts, along y, mm
WORM_CLEAR = 3.0            # the worm's thread stands this far above the base plate, mm
POST_WALL = 3.0             # resin round the worm's drive shaft and dowel in their posts, mm
MARK = (0.8, 0.6, 6.0)      # angle mark: width, depth, length (radial), mm; 0° and 90° twice as long
INDEX_PIN = 4.0             # ISO 2338 Ø4 dowel that indexes the cradle at 0° and 90°, mm
INDEX_ANGLES = (0.0, 90.0)  # the cradle's index holes, deg of roll
INDEX_RADIUS = 24.0         # the index pin's radius about the axis: inside the front upright, clear of its bearing, mm
DOWEL_PIN = 3.0             # ISO 2338 Ø3 dowel the worm's far end turns on (the tensioner's), mm
DOWEL_LENGTH = 12.0
M6_HEAD = 10.0              # ISO 4762 M6 head, mm: the plate's screws stand clear of the uprights by it
FOOT_NUTS = {"M6": (10.0, 5.2),           # ISO 4032 M6: across flats, height, mm
             "1/4-20 UNC": (11.11, 5.56)}  # ASME B18.2.2 1/4 in hex nut: 7/16 in across flats, 7/32 in high
RESIN_HOLD_N = 500.0        # what one hand-tight M6 through a resin plate is counted to clamp with: a 2 N·m
#                             tightening (K = 0.2) gives 1.7 kN, taken at under a third for the resin's creep, N
RESIN_FRICTION = 0.3        # μ of resin on resin (the mount's foot on the cradle), dry
EDGE_CLAMP_N = 500.0        # what one hand-tight G-clamp is counted to press with, N
G = 9.81e-3                 # N per gram


@dataclass(frozen=True, kw_only=True)
class FrameLayout:
    pair: WormPair
    mu: float
    bearing: str
    bearing_od: float
    bearing_width: float
    bearing_c0_n: float
    shaft_d: float
    shaft_e_mpa: float
    pulley_teeth: int
    pulley_pd: float            # pitch diameter of both pulleys, mm
    pulley_flange: float
    pulley_length: float
    belt_length: float          # pitch length, mm (stock)
    # cradle
    foot: tuple[float, float, float, float, float]   # x half, y back, y front, z bottom (the table), z top of the mount's foot
    foot_holes: tuple[tuple[float, float], ...]      # the mount's foot holes (x, y)
    foot_hole: float
    foot_bolt: str
    y_flange: tuple[float, float]                    # back, front face
    flange_radius: float
    z_plate: float                                   # the cradle plate's underside
    hub: tuple[float, float]                         # y back, front
    index_radius: float
    # uprights and shafts
    front: tuple[float, float]                       # y back, front face of the front upright
    back: tuple[float, float]
    upright_half_x: float
    z_base: float                                    # the base plate's top
    z_table: float                                   # its underside: the table
    z_lower: float                                   # the lower shaft's axis (x = 0)
    y_belt: float                                    # the belt's mid-plane
    y_wheel: float                                   # the wheel's mid-plane = the worm's axis y
    z_worm: float
    upper_shaft: tuple[float, float]                 # y range of shaft ⑤
    lower_shaft: tuple[float, float]
    worm_near_end: float                             # worm file Z of the thread's start (the tensioner's convention)
    worm_x0: float                                   # x of the worm's near face
    near_post: tuple[float, float]                   # x range
    far_post: tuple[float, float]
    plate: tuple[float, float, float, float]         # base plate x0, x1, y0, y1
    plate_holes: tuple[tuple[float, float], ...]     # M6 on the 25 mm grid (x, y)
    mounting: str
    envelope_radius: float                           # the turning parts' radius the axis height is set from
    clearance: float
    mark_step_deg: float
    push_n: float
    safety_factor: float
    max_tip_shift_mm: float
    tip_y: float                                     # the robot's tip (the push's place), mm
    disk_radius: float
    teeth_given: bool                                # base_frame.wheel_teeth was given (a fix names it)
    hex_key: float                                   # the drive shaft's socket: tensioner.hex_key, mm


def frame_pair(d: Design, teeth: int | None = None) -> WormPair:
    """The frame's worm pair: base_frame's numbers, the tensioner's where it gives none."""
    bf, t = d.base_frame, d.tensioner
    upd = {"module": bf.module, "worm_starts": bf.worm_starts, "wheel_teeth": teeth or bf.wheel_teeth,
           "worm_pitch_diameter": bf.worm_pitch_diameter, "face_width": bf.face_width}
    merged = t.model_copy(update={k: v for k, v in upd.items() if v is not None})
    return worm_pair(merged, d.process.min_wall)


def frame_layout(d: Design, mount: MountLayout, envelope: float, torque_nmm: float) -> FrameLayout:
    """The frame for design ``d`` around its base mount ``mount``; ``envelope``: the robot's own
    turning radius (its disks and tensioner, from the plan); ``torque_nmm``: the torque about the
    shaft it is sized for (:func:`torque_estimate`): a wheel not given gets the teeth that carry it."""
    bf = d.base_frame
    pair = frame_pair(d)
    if bf.wheel_teeth is None:
        pair = frame_pair(d, least_teeth(pair, torque_nmm, d.tensioner.resin_strength, bf.safety_factor))
    mu = bf.friction_coefficient or d.tensioner.friction_coefficient
    b = bf.bearing
    shaft_d = bp.size("ball bearing", b, "bore")
    bod, bw = bp.size("ball bearing", b, "outer_diameter"), bp.size("ball bearing", b, "width")
    z_pulley = str(bf.pulley_teeth)             # a stock size of the table (the schema allows no other)
    pitch = bp.size("GT2 belt", "any", "pitch")
    pd = bf.pulley_teeth * pitch / math.pi
    pfl, plen = bp.size("GT2 pulley", z_pulley, "flange_diameter"), bp.size("GT2 pulley", z_pulley, "length")

    # the cradle: a plate under the mount's foot, a flange behind it with the hub on the shaft
    fx = mount.foot_half_x
    y_fb, y_ff = mount.y_foot_back, mount.y_column_front
    z_plate = mount.z_table - PLATE
    flange_r = math.ceil(-z_plate)
    y_flange = (y_fb - FLANGE, y_fb)
    corner = math.hypot(fx, z_plate)
    env = max(corner, flange_r, envelope)

    # the uprights, behind the flange by the clearance; the hub reaches to within HUB_GAP of the front one
    front = (y_flange[0] - bf.clearance_mm - UPRIGHT, y_flange[0] - bf.clearance_mm)
    hub = (front[1] + HUB_GAP, y_flange[0])
    y_belt = front[0] - BETWEEN - plen / 2
    y_wheel = y_belt - plen / 2 - BETWEEN - WHEEL_HUB - pair.face_width / 2
    back_front = y_wheel - max(pair.face_width / 2, pair.ra1, POST_Y / 2) - BETWEEN   # the worm and its posts too
    back = (back_front - UPRIGHT, back_front)

    # heights: the axis clears the base plate by the envelope and the clearance; the worm stands on the plate
    z_base = -(env + bf.clearance_mm)
    z_worm_least = z_base + WORM_CLEAR + pair.ra1
    z_lower_least = z_worm_least + pair.center_distance
    c_max = -z_lower_least                                   # the belt's centre distance, at most
    c_min = max(pfl, 2 * pair.outside_radius) / 2 + pfl / 2 + BETWEEN
    stock = bp.lengths("GT2 belt")
    fits = [L for L in stock if c_min <= (L - bf.pulley_teeth * pitch) / 2 <= c_max]
    belt = max(fits) if fits else min(stock, key=lambda L: abs((L - bf.pulley_teeth * pitch) / 2 - c_max))
    c = (belt - bf.pulley_teeth * pitch) / 2
    z_lower = -c
    z_worm = z_lower - pair.center_distance

    # the worm across x, its thread centred under the wheel (the tensioner's convention, mesh Y = world x)
    n = round(-pair.worm_length / (2 * pair.pitch))
    near_end = max(WORM_END, pair.outside_radius + GAP + n * pair.pitch)      # as the tensioner's: its very worm
    worm_x0 = n * pair.pitch - near_end
    worm_far = n * pair.pitch + pair.worm_length + WORM_END
    near_post = (worm_x0 - AXIAL_PLAY / 2 - POST, worm_x0 - AXIAL_PLAY / 2)
    far_post = (worm_far + AXIAL_PLAY / 2, worm_far + AXIAL_PLAY / 2 + POST)

    # the base plate under the uprights and posts: two rows of M6 holes on the 25 mm grid, one behind
    # the back upright, one between the uprights, outside the worm's posts
    pitch_grid, _, _ = BOLT_PATTERNS["M6_25mm"]
    need = max(UPRIGHT_HALF_X, far_post[1], -near_post[0] + DRIVE_FLANGE[1]) + M6_HEAD / 2 + 1.0
    hx = pitch_grid / 2 + pitch_grid * math.ceil((need - pitch_grid / 2) / pitch_grid)
    px = hx + PLATE_HOLE_EDGE
    y_row = back[0] - PLATE_HOLE_EDGE
    plate = (-px, px, y_row - PLATE_HOLE_EDGE, front[1])
    holes = tuple((sx * hx, y) for y in (y_row, y_row + 2 * pitch_grid) for sx in (-1, 1))
    return FrameLayout(
        pair=pair, mu=mu, bearing=b, bearing_od=bod, bearing_width=bw,
        bearing_c0_n=bp.size("ball bearing", b, "static_load_n"), shaft_d=shaft_d,
        shaft_e_mpa=1000 * bp.size("shaft", str(int(shaft_d)), "modulus_gpa"),
        pulley_teeth=bf.pulley_teeth, pulley_pd=pd, pulley_flange=pfl, pulley_length=plen, belt_length=belt,
        foot=(fx, y_fb, y_ff, mount.z_table, mount.z_foot_top), foot_holes=mount.foot_holes,
        foot_hole=mount.foot_hole, foot_bolt=mount.bolt, y_flange=y_flange, flange_radius=float(flange_r),
        z_plate=z_plate, hub=hub, index_radius=INDEX_RADIUS, front=front, back=back,
        upright_half_x=UPRIGHT_HALF_X, z_base=z_base, z_table=z_base - BASE_PLATE, z_lower=z_lower, y_belt=y_belt,
        y_wheel=y_wheel, z_worm=z_worm, upper_shaft=(back[0] - 1.0, y_flange[1] - 2.0),
        lower_shaft=(back[0] - 1.0, front[1] - 1.0), worm_near_end=near_end, worm_x0=worm_x0,
        near_post=near_post, far_post=far_post, plate=plate, plate_holes=holes, mounting=bf.mounting,
        envelope_radius=env, clearance=bf.clearance_mm, mark_step_deg=bf.mark_step_deg,
        push_n=bf.push_n or d.experiment.load_cell_range_n, safety_factor=bf.safety_factor,
        max_tip_shift_mm=bf.max_tip_shift_mm, tip_y=d.backbone.length, disk_radius=d.disks.outer_diameter / 2,
        teeth_given=bf.wheel_teeth is not None, hex_key=d.tensioner.hex_key)


# ---------------------------------------------------------------------------------------- statics

def shaft_statics(lay: FrameLayout, weight_n: float, y_weight: float, push_n: float, y_push: float) -> dict:
    """The supporting shaft ⑤ as a beam on two bearings (the uprights' mid-planes) loaded at its front
    end (the cradle's hub) by the turning parts' weight at ``y_weight`` and the push at ``y_push``,
    both across the shaft: bearing loads (N), the shaft's deflection and slope at its end and the
    robot's tip shift they give (mm). Euler-Bernoulli, the shaft's full round section."""
    yf, yb = sum(lay.front) / 2, sum(lay.back) / 2
    span = yf - yb
    y_end = lay.hub[0]
    c = y_end - yf
    force = weight_n + push_n
    moment = weight_n * (y_weight - y_end) + push_n * (y_push - y_end)
    ei = lay.shaft_e_mpa * math.pi * lay.shaft_d ** 4 / 64
    defl = force * c ** 2 * (span + c) / (3 * ei) + moment * c * (2 * span + 3 * c) / (6 * ei)
    slope = force * c * (2 * span + 3 * c) / (6 * ei) + moment * (span + 3 * c) / (3 * ei)
    r_front = (force * (span + c) + moment) / span
    r_back = (force * c + moment) / span
    return {"front_n": abs(r_front), "back_n": abs(r_back), "end_deflection_mm": defl, "end_slope_rad": slope,
            "tip_shift_mm": abs(defl + slope * (lay.tip_y - y_end)), "span_mm": span, "overhang_mm": c}


def lewis_factor(pair: WormPair, torque_nmm: float, strength_mpa: float) -> float:
    """The wheel's Lewis factor of safety under ``torque_nmm``: strength over the tooth root stress."""
    s = pair.lewis_stress(torque_nmm, pair.face_width, pair.lewis_form_factor())
    return strength_mpa / s if s > 0 else math.inf


def least_teeth(pair: WormPair, torque_nmm: float, strength_mpa: float, need: float, most: int = 120) -> int:
    """The least tooth count from the pair's up to ``most`` whose Lewis factor meets ``need`` (it grows
    with the teeth: bisected); ``most`` when none does."""
    lo, hi = pair.teeth, most
    if lewis_factor(pair, torque_nmm, strength_mpa) >= need:
        return pair.teeth
    if lewis_factor(replace(pair, teeth=hi), torque_nmm, strength_mpa) < need:
        return hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if lewis_factor(replace(pair, teeth=mid), torque_nmm, strength_mpa) >= need else (mid, hi)
    return hi


def torque_estimate(d: Design, tensioner, metal: tuple[float, np.ndarray], density_g_cm3: float) -> float:
    """The largest torque about the shaft the frame is laid out for, N·mm, before any file exists: the
    tensioner's housing members and wheels as solid resin (overlaps counted twice: an upper bound)
    and its bought metal ``metal`` (mass g, centre mm) off the axis, and the push at a disk's rim.
    The checks measure it again from the files."""
    bfs = d.base_frame
    push = (bfs.push_n or d.experiment.load_cell_range_n) * d.disks.outer_diameter / 2
    moment = np.asarray(metal[1], float)[[0, 2]] * metal[0]
    if tensioner is not None:
        turn = np.asarray(tensioner.turn, float)
        for m in tensioner.members:
            c = _member_centre(m)
            if c is None:
                continue
            w = turn[:3, :3] @ c + turn[:3, 3]
            moment = moment + m.volume / 1000 * density_g_cm3 * w[[0, 2]]
        r = tensioner.pair.outside_radius
        for u in tensioner.units:
            vol = math.pi * r ** 2 * (u.z_part[1] - u.z_part[0])
            w = turn[:3, :3] @ np.array([u.center[0], u.center[1], sum(u.z_part) / 2]) + turn[:3, 3]
            moment = moment + vol / 1000 * density_g_cm3 * w[[0, 2]]
    return float(np.hypot(*moment)) * G + push


def _member_centre(m) -> np.ndarray | None:
    d = m.dims
    if m.kind == "box":
        return np.array([(d[0] + d[1]) / 2, (d[2] + d[3]) / 2, (d[4] + d[5]) / 2])
    if m.kind in ("cyl", "hex"):
        return (np.asarray(d[1:4], float) + np.asarray(d[4:7], float)) / 2
    return None


def holding_torque(lay: FrameLayout, torque_nmm: float, mu: float | None = None) -> float:
    """The worm torque that keeps the wheel from turning back under ``torque_nmm`` (positive:
    self-locking, the worm holds with none), N·mm: F_t2 · r1 · tan(φ' − γ)."""
    p = lay.pair
    phi = p.friction_angle(lay.mu if mu is None else mu)
    return p.wheel_tangential_force(torque_nmm) * p.r1 * math.tan(phi - p.lead_angle)


def robot_envelope(disk_radius: float, tensioner) -> float:
    """The robot's own turning radius about its axis (y), mm: its disks' and, where it is laid
    out, the tensioner's housing members and wheels (a box's farthest corner, a cylinder's end
    circle); prisms by their outline."""
    r = disk_radius
    if tensioner is None:
        return r
    for m in tensioner.members:
        d = m.dims
        if m.kind == "box":
            r = max(r, max(math.hypot(x, z) for x in d[0:2] for z in d[4:6]))
        elif m.kind in ("cyl", "hex"):
            r = max(r, math.hypot(d[1], d[3]) + d[0], math.hypot(d[4], d[6]) + d[0])
        elif m.kind == "prism":
            lo, hi, pts = d[1], d[2], d[3:]
            vs = pts[1::2]
            r = max(r, max(math.hypot(a, v) for a in (lo, hi) for v in vs))
    for u in tensioner.units:
        r = max(r, math.hypot(abs(u.center[0]) + tensioner.pair.outside_radius,
                              max(abs(u.z_part[0]), abs(u.z_part[1]))))
    return float(r)
