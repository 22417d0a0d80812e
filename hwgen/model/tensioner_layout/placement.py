"""One arrangement placed: the units along y, the wheel-axis |x| (x_u) widened until every
tendon clears every part by the clearance asked for, and the stack lifted off the tip until no
tendon turns by more than ``tensioner.max_exit_deg`` at its tip eyelet."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..gearing import WORM_TO_MESH
from .arrangement import Arrangement, Eyelets, Stack, meets_clamp
from .result import TendonRun, Unit
from .sizes import (AXIAL_PLAY, BOSS, CLAMP_HEAD, CLAMP_PLATE, DRIVE_FLANGE, GAP, MAX_LIFTS, POST, UNIT_GAP, WORM_END,
                    X_COARSE, X_SEARCH, X_STEP, NoFit, Sizes)


@dataclass(frozen=True)
class Failure:
    """Why one arrangement did not fit: the worst tendon clearance and what set it."""

    clearance: float
    tendon: str
    obstacle: str
    kind: str                # "part", "clamp", "exit", "space"


# ---------------------------------------------------------------- placing the units

def place_units(arr: Arrangement, stacks: dict[str, Stack], clamp, sz: Sizes, lift: float) -> dict[str, float]:
    """Wheel-axis heights y: in each column units stack along +y; a unit whose z span meets the
    strip clamp goes beyond it."""
    pair = sz.pair
    wheel_reach = max(pair.outside_radius, sz.r_f, BOSS) + UNIT_GAP / 2
    worm_reach = pair.center_distance + max(pair.ra1, DRIVE_FLANGE[0] / 2, POST / 2) + UNIT_GAP / 2
    centers_y: dict[str, float] = {}
    y_next = {1: sz.y_face + sz.base_t + GAP + lift, -1: sz.y_face + sz.base_t + GAP + lift}
    for c, s in zip(arr.order, arr.sides):
        below, above = (wheel_reach, worm_reach) if s > 0 else (worm_reach, wheel_reach)
        floor = clamp[3] + GAP if meets_clamp(stacks[c], clamp) else y_next[s]
        yc = max(y_next[s], floor) + below
        centers_y[c] = yc
        y_next[s] = yc + above
    return centers_y


@dataclass(frozen=True)
class Frame:
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


def _frame(x_u: float, arr: Arrangement, centers_y, stacks, eyelets: Eyelets, winding: dict, sz: Sizes) -> Frame:
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
        u = Unit(channel=c, tendons=tuple(n_ for n_, _, _ in eyelets[c]), side=s, center=(s * x_u, centers_y[c]),
                 z_part=st.z_part, zones=st.zones, flanges=st.flanges, caps=st.caps, z_gear=st.gear,
                 clamps=st.clamps, worm_y=centers_y[c] + s * a, worm_z=st.z_wheel, upper_shelf=st.upper,
                 lower_bar=st.lower, pins=st.pins)
        units.append(u)
        opposite = winding.get(c, "same") == "opposite"
        for k, (name, x, z) in enumerate(sorted(eyelets[c], key=lambda t: (t[2], t[0]))):
            sense = -1 if opposite and k % 2 == 1 else 1
            p0 = np.array([x, sz.y_face])
            t = _tangent_point(p0, np.array(u.center), sz.r_w, -s * sense)
            ang = math.degrees(math.atan2(abs(t[0] - x), t[1] - sz.y_face))
            runs.append(TendonRun(name, c, (x, sz.y_face, z), (float(t[0]), float(t[1]), z), ang, sense))
    return Frame(spine, near_end, wf, (x_far, x_near), post, tuple(units), tuple(runs))


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


def _obstacles(fr: Frame, clamp, sz: Sizes) -> _Obstacles:
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


def _clearance(fr: Frame, clamp, sz: Sizes) -> Failure:
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
    worst = Failure(math.inf, "", "", "part")
    if dc.size and np.isfinite(dc).any():
        i, k = np.unravel_index(int(np.argmin(dc)), dc.shape)
        worst = Failure(float(dc[i, k]), fr.runs[i].tendon, ob.c_names[k], "part")
    if dr.size and np.isfinite(dr).any():
        i, k = np.unravel_index(int(np.argmin(dr)), dr.shape)
        if dr[i, k] < worst.clearance:
            name = ob.r_names[k]
            worst = Failure(float(dr[i, k]), fr.runs[i].tendon, name, "clamp" if name == "strip clamp" else "part")
    return worst


def x_floor(eyelets: Eyelets, sz: Sizes) -> float:
    """The least wheel-axis |x| worth trying: every drum beyond its tendons' eyelets, and the far
    worm posts (x_u - n p - L - play - POST from the axis) on their own side of x = 0."""
    pair = sz.pair
    n = round(-pair.worm_length / (2 * pair.pitch))
    posts = UNIT_GAP / 2 + POST + AXIAL_PLAY / 2 + WORM_END + pair.worm_length + n * pair.pitch
    return max(max(abs(x) for v in eyelets.values() for _, x, _ in v) + sz.r_w + sz.need, posts)


def _widen(arr, centers_y, stacks, eyelets, winding, clamp, sz: Sizes) -> tuple[float, Frame]:
    """The smallest wheel-axis |x| at which every tendon clears every other part, scanned coarse
    then refined; NoFit-carrying Failure when none within X_SEARCH."""
    x_min = x_floor(eyelets, sz)

    def ok(x_u):
        fr = _frame(x_u, arr, centers_y, stacks, eyelets, winding, sz)
        fail = _clearance(fr, clamp, sz)
        # the far posts stay on their own side of x = 0, clear of the other column; the spines
        # leave room at the strip clamp's ends for its nuts to go in
        good = (fail.clearance >= 0 and fr.post[0] >= UNIT_GAP / 2
                and (clamp is None or fr.spine[0] >= clamp[1] + sz.clamp_room))
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
    raise Infeasible(best_fail)


class Infeasible(Exception):
    def __init__(self, failure: Failure):
        self.failure = failure


def solve(arr: Arrangement, stacks, eyelets, winding, clamp, sz: Sizes):
    """Place one arrangement: widen until clear, lift until every exit angle is allowed."""
    lift = 0.0
    for _ in range(MAX_LIFTS):
        centers_y = place_units(arr, stacks, clamp, sz, lift)
        x_u, fr = _widen(arr, centers_y, stacks, eyelets, winding, clamp, sz)
        need = exit_lift(fr, sz)
        if need <= 1e-6:
            return x_u, fr
        lift += need + X_STEP
    worst = max(fr.runs, key=lambda r: r.exit_angle_deg)
    raise Infeasible(Failure(-worst.exit_angle_deg, worst.tendon, f"a {worst.exit_angle_deg:.0f}° turn", "exit"))


# ---------------------------------------------------------------- lifting off the tip

def lifted(x_u: float, arr, stacks, eyelets, winding, clamp, sz: Sizes) -> Frame:
    """The frame at this x_u lifted until every exit angle is allowed, ignoring clearance: at
    the narrowest x_u, the least lift any placement of the arrangement needs."""
    lift = 0.0
    for _ in range(MAX_LIFTS):
        fr = _frame(x_u, arr, place_units(arr, stacks, clamp, sz, lift), stacks, eyelets, winding, sz)
        need = exit_lift(fr, sz)
        if need <= 1e-6:
            break
        lift += need
    return fr


def exit_lift(fr: Frame, sz: Sizes) -> float:
    """How much further along y the units must go for every tendon to turn by at most max_exit."""
    return max((abs(r.end[0] - r.start[0]) / math.tan(sz.max_exit) - (r.end[1] - r.start[1]) for r in fr.runs),
               default=0.0)
