"""One arrangement placed: the units along y, the wheel-axis |x| (x_u) widened until every
tendon clears every part by the clearance asked for, and the stack lifted off the tip until no
tendon turns by more than ``tensioner.max_exit_deg`` at its tip eyelet."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..gearing import WORM_TO_MESH
from .arrangement import Arrangement, Eyelets, Stack, meets_clamp, strip_keepout
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
    strip clamp (or, with none, the strip's tip) goes beyond it."""
    pair = sz.pair
    wheel_reach = max(pair.outside_radius, sz.r_f, BOSS) + UNIT_GAP / 2
    worm_reach = pair.center_distance + max(pair.ra1, DRIVE_FLANGE[0] / 2, POST / 2) + UNIT_GAP / 2
    centers_y: dict[str, float] = {}
    y_next = {1: sz.y_face + sz.base_t + GAP + lift, -1: sz.y_face + sz.base_t + GAP + lift}
    for c, s in zip(arr.order, arr.sides):
        below, above = (wheel_reach, worm_reach) if s > 0 else (worm_reach, wheel_reach)
        keep = strip_keepout(sz, clamp)
        floor = keep[3] + GAP if meets_clamp(stacks[c], keep) else y_next[s]
        yc = max(y_next[s], floor) + below
        centers_y[c] = yc
        y_next[s] = yc + above
    return centers_y


@dataclass(frozen=True)
class Frame:
    """The units placed at one wheel-axis |x| (x_u), with the worms, spines and posts that follow."""

    x_u: float
    spine: tuple[float, float]
    near_end: float
    worm_file_to_mesh: np.ndarray
    worm_x: tuple[float, float]
    post: tuple[float, float]
    units: tuple[Unit, ...]
    runs: tuple[TendonRun, ...]              # layout frame


@dataclass(frozen=True)
class _AlongX:
    """Where the worms, spines and posts stand across x at wheel-axis |x| = x_u (|x|, mm): floats
    for one x_u, or arrays over candidate x_u (the same arithmetic, element by element)."""

    thread: object           # the thread's spine-side end
    near: object             # the worm's spine-side face
    far: object              # the worm's far face
    spine: tuple             # the spine's inner and outer faces
    post: tuple              # the far post's inner and outer faces


def _along_x(x_u, sz: Sizes) -> _AlongX:
    """The worm runs along x from the spine inward, its thread centred on the wheel (a whole number
    n of pitches from the wheel's axis to the thread's spine-side end); its near face stands on the
    spine's inner face, which stands clear of the wheel's tips; the far post holds its dowel.
    Every part keeps its end play (AXIAL_PLAY, half at each end)."""
    pair = sz.pair
    n = round(-pair.worm_length / (2 * pair.pitch))
    x_thread = x_u - n * pair.pitch
    x_near = np.maximum(x_thread + WORM_END, x_u + pair.outside_radius + GAP)
    x_far = x_thread - pair.worm_length - WORM_END
    return _AlongX(thread=x_thread, near=x_near, far=x_far,
                   spine=(x_near + AXIAL_PLAY / 2, x_near + AXIAL_PLAY / 2 + sz.spine_t),
                   post=(x_far - AXIAL_PLAY / 2 - POST, x_far - AXIAL_PLAY / 2))


def _tangent_point(p: np.ndarray, c: np.ndarray, r: float, toward: int) -> np.ndarray:
    """Tangent point on circle (c, r) of a line from p: on the side of smaller x when
    ``toward`` is -1, of larger x when +1."""
    d = c - p
    dist = np.sqrt(d.dot(d))                 # what np.linalg.norm(d) computes, without its checks
    if dist <= r:
        raise NoFit("tendon eyelet inside its spool")
    base = math.atan2(d[1], d[0])
    off = math.asin(r / dist)
    tlen = math.sqrt(dist ** 2 - r ** 2)
    pts = [(p[0] + tlen * math.cos(base + s * off), p[1] + tlen * math.sin(base + s * off)) for s in (1, -1)]
    return np.array(min(pts, key=lambda t: -toward * t[0]))


def _tangent_points(p: np.ndarray, c: np.ndarray, r: float, toward: np.ndarray) -> np.ndarray:
    """:func:`_tangent_point` over arrays: p and c (..., 2), toward (...). numpy's trigonometry may
    round differently from the math module's in the last bits, so these points are the same only
    to rounding (which is why :class:`_Scan` trusts them only beyond SCAN_TOLERANCE). Which of the
    two tangent points is taken is never in doubt: they are mirror images in the line from p to c,
    which rises in y by at least the base bars' depth (the wheels stand beyond them), so their x
    differ by a finite amount, not by rounding."""
    d = c - p
    dist = np.hypot(d[..., 0], d[..., 1])
    base = np.arctan2(d[..., 1], d[..., 0])
    off = np.arcsin(r / dist)
    tlen = np.sqrt(dist ** 2 - r ** 2)
    plus, minus = (p + tlen[..., None] * np.stack([np.cos(base + s * off), np.sin(base + s * off)], axis=-1)
                   for s in (1, -1))
    take_plus = -toward * plus[..., 0] <= -toward * minus[..., 0]      # min(): the first on a tie, as above
    return np.where(take_plus[..., None], plus, minus)


def _frame(x_u: float, arr: Arrangement, centers_y, stacks, eyelets: Eyelets, winding: dict, sz: Sizes) -> Frame:
    """Everything at wheel-axis |x| = x_u (the worm, spine and post as :func:`_along_x` puts them),
    each tendon's run from its tip eyelet to its drum's tangent point, the worm's thread placed so
    a thread space sits on the wheel's tooth."""
    pair = sz.pair
    a = pair.center_distance
    n = round(-pair.worm_length / (2 * pair.pitch))
    ax = _along_x(x_u, sz)
    x_thread, x_near = float(ax.thread), float(ax.near)
    near_end = x_near - x_thread                     # worm file Z of the thread's start
    spine = (float(ax.spine[0]), float(ax.spine[1]))
    ty = -near_end + n * pair.pitch                  # a thread space on the wheel's tooth at mesh y = 0
    wf = np.eye(4)
    wf[:3, :3] = WORM_TO_MESH
    wf[:3, 3] = [a, ty, 0.0]
    x_far = float(ax.far)
    post = (float(ax.post[0]), float(ax.post[1]))
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
    return Frame(x_u, spine, near_end, wf, (x_far, x_near), post, tuple(units), tuple(runs))


# ---------------------------------------------------------------- clearance of the tendon runs

# The positions across x that the parts' outlines stand at (|x|, before their column's sign): each
# one moves with x_u, by the arithmetic of _along_x, element by element.
POSITIONS = ("axis", "bar", "worm far", "worm near", "spine in", "spine out", "flange", "spine far", "post in",
             "post out", "clamp x0", "clamp x1")


def _across(x_u: np.ndarray, clamp, sz: Sizes) -> np.ndarray:
    """The POSITIONS at each x_u (N,): (len(POSITIONS), N). "spine far" stands for the spine's
    unbounded outer side (ten times its outer face); the strip clamp's ends do not move."""
    ax = _along_x(x_u, sz)
    c0, c1 = (clamp[0], clamp[1]) if clamp is not None else (0.0, 0.0)
    return np.stack(np.broadcast_arrays(x_u, np.abs(x_u) - BOSS, ax.far, ax.near, ax.spine[0], ax.spine[1],
                                        ax.spine[1] + DRIVE_FLANGE[1], ax.spine[1] * 10, ax.post[0], ax.post[1],
                                        c0, c1))


class _Parts:
    """Every part outline that a tendon in a plane z may meet: circles (x, y, r) and rectangles
    (x0, x1, y0, y1), each with the z range it occupies, the channel it belongs to (its own
    tendons may pass it only when ``foreign``) and a name; for units stacked in y and z as
    ``units`` stack them (their x is not read). Only the outlines' x move with x_u: a circle's
    centre is its unit's wheel axis, a rectangle's ends are two of the POSITIONS, each on its
    unit's side of x = 0."""

    def __init__(self, units: tuple[Unit, ...], clamp, sz: Sizes):
        pair = sz.pair
        C, R = [], []       # (name, side, y, r, z0, z1, owner, foreign); (name, side, ends, y0, y1, z0, z1)
        reach = CLAMP_PLATE[2] + CLAMP_HEAD
        for u in units:
            s, cy, ch = u.side, u.center[1], u.channel

            def rect(name, ends, y0, y1, z0, z1):
                R.append((f"{ch} {name}", s, ends, min(y0, y1), max(y0, y1), z0, z1))
            C.append((f"{ch} spool", s, cy, max(sz.r_f, sz.hub_r), *u.z_part, ch, True))
            C.append((f"{ch} wheel", s, cy, pair.outside_radius, *u.z_gear, ch, True))
            C += [(f"{ch} cap", s, cy, pair.rf2, *cap, ch, True) for cap in u.caps]
            C += [(f"{ch} clamp", s, cy, pair.rf2, min(zc, zc + sg * reach), max(zc, zc + sg * reach), ch, False)
                  for zc, sg in u.clamps]
            C.append((f"{ch} boss", s, cy, BOSS, u.z_part[1], u.upper_shelf[1], ch, False))
            C.append((f"{ch} boss", s, cy, BOSS, u.lower_bar[0], u.z_part[0], ch, False))
            rect("worm", ("worm far", "worm near"), u.worm_y - pair.ra1, u.worm_y + pair.ra1,
                 u.worm_z - pair.ra1, u.worm_z + pair.ra1)
            rf = DRIVE_FLANGE[0] / 2
            rect("drive shaft", ("spine out", "flange"), u.worm_y - rf, u.worm_y + rf, u.worm_z - rf, u.worm_z + rf)
            rect("post", ("post in", "post out"), u.worm_y - POST / 2, u.worm_y + POST / 2,
                 u.worm_z - POST / 2, u.upper_shelf[1])
            rect("shelf", ("post in", "spine out"), cy - s * BOSS, u.worm_y + s * POST / 2, *u.upper_shelf)
            rect("bar", ("bar", "spine out"), cy - BOSS, cy + BOSS, *u.lower_bar)
        for s in (1, -1):
            R.append(("spine", s, ("spine in", "spine far"), sz.y_face, 1e9, -1e9, 1e9))
        if clamp is not None:
            R.append(("strip clamp", 1, ("clamp x0", "clamp x1"), clamp[2], clamp[3], clamp[4], clamp[5]))
        self.clamp, self.sz = clamp, sz
        self.c_names, self.c_owner = [c[0] for c in C], [c[6] for c in C]
        self.c_side = np.array([c[1] for c in C], float)
        self.c_yr = np.array([c[2:4] for c in C], float).reshape(-1, 2)
        self.c_z = np.array([c[4:6] for c in C], float).reshape(-1, 2)
        self.c_foreign = np.array([c[7] for c in C], bool)
        self.r_names = [r[0] for r in R]
        self.r_side = np.array([r[1] for r in R], float)
        self.r_ends = np.array([[POSITIONS.index(e) for e in r[2]] for r in R], int).reshape(-1, 2)
        self.r_y = np.array([r[3:5] for r in R], float).reshape(-1, 2)
        self.r_z = np.array([r[5:7] for r in R], float).reshape(-1, 2)

    def at(self, x_u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The circles (N, n, 3) and rectangles (N, m, 4) at each wheel-axis |x| in ``x_u`` (N,)."""
        n = len(x_u)
        circles = np.empty((n, len(self.c_side), 3))
        circles[..., 0] = x_u[:, None] * self.c_side                  # the wheel axis on its unit's side
        circles[..., 1:] = self.c_yr
        ends = self.r_side[:, None, None] * _across(x_u, self.clamp, self.sz)[self.r_ends]    # (m, 2, N)
        rects = np.empty((n, len(self.r_side), 4))
        rects[..., 0] = np.minimum(ends[:, 0], ends[:, 1]).T
        rects[..., 1] = np.maximum(ends[:, 0], ends[:, 1]).T
        rects[..., 2:] = self.r_y
        return circles, rects

    def pairs(self, z: np.ndarray, channels: list[str]) -> tuple[np.ndarray, ...]:
        """Which runs (in the planes z, of the channels named) must clear which outlines: those whose
        z range, widened by what a tendon needs, holds the run's plane, but not the run's own drum.
        (run, circle) and (run, rectangle) index pairs, run by run: jc, kc, jr, kr."""
        need = self.sz.need
        zc = np.asarray(z, float)[:, None]
        own = np.array([[o == ch for o in self.c_owner] for ch in channels], bool).reshape(len(channels), -1)
        cm = (self.c_z[None, :, 0] - need < zc) & (zc < self.c_z[None, :, 1] + need) & ~(self.c_foreign & own)
        rm = (self.r_z[None, :, 0] - need < zc) & (zc < self.r_z[None, :, 1] + need)
        return (*np.nonzero(cm), *np.nonzero(rm))


def _seg_point_dist(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Distance from segments a-b to points p, pair by pair: arrays (..., 2) that broadcast; (...)."""
    ab = b - a
    ap = p - a
    t = np.clip(np.sum(ap * ab, axis=-1) / np.maximum(np.sum(ab * ab, axis=-1), 1e-12), 0, 1)
    return np.linalg.norm(ap - t[..., None] * ab, axis=-1)


def _seg_rect_dist(a: np.ndarray, b: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Exact distance from segments a-b (..., 2) to axis-aligned rectangles r (..., 4: x0, x1, y0,
    y1), pair by pair: (...), 0 where a segment enters its rectangle (Liang-Barsky clipping)."""
    d = b - a
    t0, t1 = np.zeros(d.shape[:-1]), np.ones(d.shape[:-1])
    for k, (lo, hi) in enumerate(((0, 1), (2, 3))):
        dk, ak = d[..., k], a[..., k]
        r_lo, r_hi = r[..., lo], r[..., hi]
        flat = np.abs(dk) < 1e-12
        with np.errstate(divide="ignore", invalid="ignore"):
            ta, tb = (r_lo - ak) / dk, (r_hi - ak) / dk
        outside = flat & ((ak < r_lo) | (ak > r_hi))
        t0 = np.where(flat, np.where(outside, 2.0, t0), np.maximum(t0, np.minimum(ta, tb)))
        t1 = np.where(flat, t1, np.minimum(t1, np.maximum(ta, tb)))
    hit = t0 <= t1

    def point_rect(p):
        dx = np.maximum(np.maximum(r[..., 0] - p[..., 0], 0), p[..., 0] - r[..., 1])
        dy = np.maximum(np.maximum(r[..., 2] - p[..., 1], 0), p[..., 1] - r[..., 3])
        return np.hypot(dx, dy)
    dist = np.minimum(point_rect(a), point_rect(b))
    corners = r[..., [[0, 2], [0, 3], [1, 2], [1, 3]]]                # (..., 4, 2)
    dc = _seg_point_dist(a[..., None, :], b[..., None, :], corners).min(axis=-1)
    return np.where(hit, 0.0, np.minimum(dist, dc))


@dataclass(frozen=True)
class _Nearest:
    """Per candidate: the smallest clearance of any tendon run to a part it must not touch (inf
    when none is near its plane), and which run and which outline set it."""

    clearance: np.ndarray        # (N,)
    circle: np.ndarray           # (N,) bool: a circle's (else a rectangle's)
    run: np.ndarray              # (N,) index into the runs
    obstacle: np.ndarray         # (N,) index into the circles or the rectangles


def _nearest(parts: _Parts, pairs: tuple[np.ndarray, ...], a: np.ndarray, b: np.ndarray, x_u: np.ndarray) -> _Nearest:
    """For each candidate x_u (N,), its runs (a to b, (N, r, 2)) against the outlines of ``parts``
    each must clear (``pairs``, from :meth:`_Parts.pairs`). Ties go to the first run, then the
    first outline, circles before rectangles, in the order :class:`_Parts` lists them."""
    circles, rects = parts.at(x_u)
    jc, kc, jr, kr = pairs
    need = parts.sz.need
    dc = _seg_point_dist(a[:, jc], b[:, jc], circles[:, kc, :2]) - circles[:, kc, 2] - need     # (N, pairs)
    dr = _seg_rect_dist(a[:, jr], b[:, jr], rects[:, kr]) - need
    vc, ic = _least(dc)
    vr, ir = _least(dr)
    circle = ~(vr < vc)                                                # a rectangle only when strictly nearer
    clearance = np.where(np.isnan(vc) | np.isnan(vr), np.nan, np.where(circle, vc, vr))
    return _Nearest(clearance, circle, np.where(circle, _pick(jc, ic), _pick(jr, ir)),
                    np.where(circle, _pick(kc, ic), _pick(kr, ir)))


def _least(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per row of d (N, pairs): the least value (inf when there are no pairs) and the first pair
    that holds it."""
    if d.shape[1] == 0:
        return np.full(len(d), np.inf), np.zeros(len(d), int)
    i = np.argmin(d, axis=1)
    return d[np.arange(len(d)), i], i


def _pick(index: np.ndarray, i: np.ndarray) -> np.ndarray:
    """index[i], or 0 where there are no pairs (their value is inf, and nothing is named)."""
    return index[i] if len(index) else np.zeros_like(i)


def _failure(near: _Nearest, i: int, parts: _Parts, tendons: list[str]) -> Failure:
    """Candidate i's nearest miss as a :class:`Failure`."""
    value = float(near.clearance[i])
    if not math.isfinite(value):
        return Failure(math.inf, "", "", "part")
    tendon = tendons[int(near.run[i])]
    if near.circle[i]:
        return Failure(value, tendon, parts.c_names[int(near.obstacle[i])], "part")
    name = parts.r_names[int(near.obstacle[i])]
    return Failure(value, tendon, name, "clamp" if name == "strip clamp" else "part")


def _clearance(fr: Frame, clamp, sz: Sizes) -> Failure:
    """The smallest distance from any tendon's free span to a part it must not touch, beyond
    what it needs, and which (every run against every part at once)."""
    parts = _Parts(fr.units, clamp, sz)
    pairs = parts.pairs([r.start[2] for r in fr.runs], [r.channel for r in fr.runs])
    a = np.array([r.start[:2] for r in fr.runs], float).reshape(1, -1, 2)
    b = np.array([r.end[:2] for r in fr.runs], float).reshape(1, -1, 2)
    return _failure(_nearest(parts, pairs, a, b, np.array([fr.x_u])), 0, parts, [r.tendon for r in fr.runs])


def x_floor(eyelets: Eyelets, sz: Sizes) -> float:
    """The least wheel-axis |x| worth trying: every drum beyond its tendons' eyelets, and the far
    worm posts (x_u - n p - L - play - POST from the axis) on their own side of x = 0."""
    pair = sz.pair
    n = round(-pair.worm_length / (2 * pair.pitch))
    posts = UNIT_GAP / 2 + POST + AXIAL_PLAY / 2 + WORM_END + pair.worm_length + n * pair.pitch
    return max(max(abs(x) for v in eyelets.values() for _, x, _ in v) + sz.r_w + sz.need, posts)


SCAN_TOLERANCE = 1e-6    # mm: a scanned clearance nearer than this to what decides is worked out again exactly


class _Scan:
    """The rule of :func:`_widen` judged for many candidate x_u at once.

    At a candidate x_u an arrangement fits when every tendon run clears every part it must not
    touch (:func:`_clearance` >= 0), the far posts stay on their own side of x = 0 (clear of the
    other column), and the spines leave room at the strip clamp's ends for its nuts to go in.
    The last two are the same arithmetic as one frame's, element by element, so they are exact.
    The clearances come from the same outlines and distances (:func:`_nearest`, element by
    element too), but with the runs' tangent points computed by numpy (:func:`_tangent_points`),
    which may round differently in the last bits: a few 1e-13 mm on coordinates of a few hundred
    mm. So where a scanned clearance is within SCAN_TOLERANCE of what decides (zero, or the
    largest miss), the candidate's runs are laid out again by :func:`_tangent_point`, as
    :func:`_frame` lays them out, and its clearance worked out from those: every verdict is the
    one-frame-at-a-time rule's, bit for bit.
    """

    def __init__(self, base: Frame, clamp, sz: Sizes):
        self.clamp, self.sz = clamp, sz
        unit = {u.channel: u for u in base.units}      # their y and z, and the runs' eyelets: the same at every x_u
        runs = base.runs
        self.parts = _Parts(base.units, clamp, sz)
        self.pairs = self.parts.pairs([r.start[2] for r in runs], [r.channel for r in runs])
        self.start = np.array([r.start[:2] for r in runs], float).reshape(-1, 2)
        self.side = [unit[r.channel].side for r in runs]
        self.center_y = [unit[r.channel].center[1] for r in runs]
        self.toward = [-unit[r.channel].side * r.sense for r in runs]
        self.tendons = [r.tendon for r in runs]

    def _nearest(self, xs: np.ndarray, exact: bool = False) -> _Nearest:
        """The nearest miss at each x_u in ``xs``; ``exact``: with the runs as :func:`_frame` lays them out."""
        start = np.broadcast_to(self.start, (len(xs), *self.start.shape))
        if exact:
            ends = np.array([[_tangent_point(self.start[j], np.array((s * x, cy)), self.sz.r_w, t)
                              for j, (s, cy, t) in enumerate(zip(self.side, self.center_y, self.toward))]
                             for x in xs.tolist()]).reshape(start.shape)
        else:
            centres = np.stack(np.broadcast_arrays(np.multiply.outer(xs, self.side), np.array(self.center_y)),
                               axis=-1)
            ends = _tangent_points(start, centres, self.sz.r_w, np.array(self.toward, float))
        return _nearest(self.parts, self.pairs, start, ends, xs)

    def good(self, xs) -> np.ndarray:
        """Whether the arrangement fits at each of the x_u in ``xs``: (N,) bool."""
        xs = np.asarray(xs, float)
        sz, clamp = self.sz, self.clamp
        ax = _along_x(xs, sz)
        placed = ax.post[0] >= UNIT_GAP / 2
        if clamp is not None:
            placed &= ax.spine[0] >= clamp[1] + sz.clamp_room
        near = self._nearest(xs)
        clear = near.clearance >= 0
        doubt = np.flatnonzero(placed & ~(np.abs(near.clearance) > SCAN_TOLERANCE))    # near zero, or undefined
        if len(doubt):
            clear[doubt] = self._nearest(xs[doubt], exact=True).clearance >= 0
        return placed & clear

    def closest_miss(self, xs) -> Failure:
        """Of the x_u in ``xs``, the one whose nearest miss is the largest (the first of equals),
        and that miss."""
        xs = np.asarray(xs, float)
        c = self._nearest(xs).clearance
        top = np.max(np.where(np.isnan(c), -np.inf, c))
        doubt = np.flatnonzero(~(c < top - 2 * SCAN_TOLERANCE))     # could be the largest, or undefined
        near = self._nearest(xs[doubt], exact=True)
        c = np.where(np.isnan(near.clearance), -np.inf, near.clearance)
        return _failure(near, int(np.argmax(c)), self.parts, self.tendons)      # argmax: the first of equals


def _widen(arr, centers_y, stacks, eyelets, winding, clamp, sz: Sizes) -> tuple[float, Frame]:
    """The smallest wheel-axis |x| at which the arrangement fits (:class:`_Scan`): the first of the
    coarse steps X_COARSE apart from x_floor that fits, then refined downward from the step before
    in steps of X_STEP; Infeasible with the closest miss when none within X_SEARCH."""
    def frame_at(x_u: float) -> Frame:
        return _frame(x_u, arr, centers_y, stacks, eyelets, winding, sz)
    x_min = x_floor(eyelets, sz)
    scan = _Scan(frame_at(x_min), clamp, sz)
    coarse = []
    x = x_min
    while x < x_min + X_SEARCH:                # summed step by step: the x the scalar search tried, bit for bit
        coarse.append(x)
        x += X_COARSE
    hit = np.flatnonzero(scan.good(coarse))
    if not len(hit):
        raise Infeasible(scan.closest_miss(coarse))
    x = coarse[hit[0]]
    fine = np.arange(max(x_min, x - X_COARSE), x, X_STEP)      # refine downward from the coarse hit
    hit = np.flatnonzero(scan.good(fine)) if len(fine) else []
    if len(hit):
        x = float(fine[hit[0]])
    return x, frame_at(x)


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
