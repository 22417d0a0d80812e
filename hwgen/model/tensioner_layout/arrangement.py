"""What is arranged, before anything is placed: the tendons at the tip, one unit's parts along z,
the strip's clamp, and the arrangements the search tries (the whole tensioner turned over or not,
the order of the units along y, the column each stands in, the end of its drum each gear takes)."""
from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations

import numpy as np

from ..gearing import WormPair
from ..routing import TendonPath
from .sizes import (CAP, CLAMP_BAY, CLAMP_HEAD, CLAMP_PLATE, EVERY_ORDER_UP_TO, FLANGE, GAP, PIN_ENGAGE, PIN_LENGTHS,
                    SHELF, STRIP_CLAMP_X, STRIP_CLAMP_Z, WIND_WIDTH, WORM_CLEAR, NoFit, Sizes)


@dataclass(frozen=True)
class Stack:
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


def tip_eyelets(paths: list[TendonPath], channels) -> Eyelets:
    """(tendon, x, z) of every tendon at the tip disk, per channel; refuses a channel with none."""
    eyelets: Eyelets = {c: [] for c in channels}
    for p in paths:
        x, z = (float(v) for v in p.points[-1])
        eyelets[p.channel].append((p.name, x, z))
    for c, here in eyelets.items():
        if not here:
            raise NoFit(f"tensioner channel {c!r} has no tendon: give it one (tendons[].channel) or drop it "
                        f"from tensioner.channels")
    return eyelets


def winding_zones(zs: list[float]) -> tuple[tuple[float, float], ...]:
    """The drum's winding zones (z ranges) for tendons that wind at heights ``zs``: one groove
    WIND_WIDTH wide around each, between flanges; tendons of one channel that leave the tip closer
    than a groove and its flanges (a mirrored pair near the strip's plane, two tendons through one
    tip eyelet) share one groove as wide as they need, side by side at their own heights."""
    half = WIND_WIDTH / 2
    groups: list[list[float]] = []
    for z in sorted(zs):
        if groups and z - groups[-1][-1] < WIND_WIDTH + 2 * FLANGE:
            groups[-1].append(z)
        else:
            groups.append([z])
    return tuple((g[0] - half, g[-1] + half) for g in groups)


def turned_over(eyelets: Eyelets, turn: int) -> Eyelets:
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
    zones = winding_zones(zs)
    flanges = []
    for lo, hi in zones:
        flanges += [(lo - FLANGE, lo), (hi, hi + FLANGE)]
    reach = CLAMP_PLATE[2] + CLAMP_HEAD
    caps, clamps = [], []
    if gear_low:
        top = min(zones[0][0] - FLANGE - CLAMP_BAY, zs[0] - WORM_CLEAR - worm_radius + b / 2)
        gear = (top - b, top)
        clamps.append((gear[1], 1.0))
        if len(zones) > 1:
            caps.append((zones[-1][1], zones[-1][1] + CAP))
            clamps.append((caps[-1][1], 1.0))
    else:
        bot = max(zones[-1][1] + FLANGE + CLAMP_BAY, zs[-1] + WORM_CLEAR + worm_radius - b / 2)
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


def pin_length(span: float) -> float:
    """Shortest standard dowel covering a pressed span plus PIN_ENGAGE in the turning part."""
    need = span + GAP + PIN_ENGAGE
    for n in PIN_LENGTHS:
        if n >= need:
            return float(n)
    raise NoFit(f"no standard Ø3 dowel is {need:.1f} mm long (longest {PIN_LENGTHS[-1]} mm)")


def unit_stack(zs: list[float], pair: WormPair, gear_rule: str) -> Stack:
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
    pins = (pin_length(z_part[0] - GAP - lower[0]), pin_length(upper[1] - (z_part[1] + GAP)))
    return Stack(zones=zones, flanges=flanges, caps=caps, gear=gear, clamps=clamps, z_part=z_part, z_wheel=zw,
                 upper=upper, lower=lower, pins=pins)


GEAR_RULES = ("toward-high", "toward-low", "away-high", "away-low")


CLAMP_MIN = 5.0           # strip beyond the base bars that is worth clamping, mm


def strip_clamp(sz: Sizes, up: int) -> tuple[float, float, float, float, float, float] | None:
    """The block that clamps the strip's tip end, in the layout frame: x0, x1, y0, y1, z0, z1;
    its set screws come from +z (``up`` = 1) or -z, the side where it is thick. None when the
    strip ends too soon beyond the tip disk to be clamped (``backbone.extra_tip``)."""
    if sz.y_end - (sz.y_face + sz.base_t) < CLAMP_MIN:
        return None
    z0, z1 = STRIP_CLAMP_Z if up > 0 else (-STRIP_CLAMP_Z[1], -STRIP_CLAMP_Z[0])
    return (-sz.strip_half_x - STRIP_CLAMP_X, sz.strip_half_x + STRIP_CLAMP_X, sz.y_face + sz.base_t,
            sz.y_end + 2.0, z0, z1)


def clamp_blockers(eyelets: Eyelets, clamp, sz: Sizes) -> list[tuple[str, float, float]]:
    """Tendons that leave the tip inside the strip clamp's outline (beside the strip, within its
    thickness): they would have to pass through it, whatever the arrangement."""
    if clamp is None:
        return []
    return [(n, x, z) for v in eyelets.values() for n, x, z in v
            if abs(x) < clamp[1] + sz.need and clamp[4] - sz.need < z < clamp[5] + sz.need]


def strip_keepout(sz: Sizes, clamp):
    """What the units keep clear of along y, in the strip clamp's form (x0, x1, y0, y1, z0, z1): the
    clamp, or where there is none (left off, or too little strip to clamp) the strip's own tip
    beyond the base bars; None when the strip ends within them."""
    if clamp is not None:
        return clamp
    y0 = sz.y_face + sz.base_t
    if sz.y_end <= y0:
        return None
    return (-sz.strip_half_x - STRIP_CLAMP_X, sz.strip_half_x + STRIP_CLAMP_X, y0, sz.y_end + 2.0,
            -sz.strip_half_z, sz.strip_half_z)


def meets_clamp(stack: Stack, clamp) -> bool:
    if clamp is None:
        return False
    z0, z1 = stack.z_span
    return z0 < clamp[5] + GAP and z1 > clamp[4] - GAP


# ---------------------------------------------------------------- arrangements

@dataclass(frozen=True)
class Arrangement:
    turn: int
    clamp_up: int                           # the strip clamp's set screws from layout +z (1) or -z
    gear_rule: str
    order: tuple[str, ...]                  # along +y
    sides: tuple[int, ...]                  # per unit in that order

    @property
    def key(self) -> tuple:
        return (self.turn < 0, self.clamp_up < 0, self.gear_rule, self.order, self.sides)


def arrangements(turn: int, clamp_up: int, gear_rule: str, eyelets: Eyelets, stacks: dict[str, Stack], clamp):
    """Candidate orders along y and columns, from the geometry alone (names break ties only).

    Up to four channels every order is tried with alternating columns (both starts); beyond,
    orders by the units' z and by their tendons' x. Columns: alternating, or each unit in the
    column its tendons lean toward, or the column that is shorter so far.
    """
    names = sorted(eyelets)
    zmid = {c: sum(stacks[c].z_span) / 2 for c in names}
    xmean = {c: float(np.mean([x for _, x, _ in eyelets[c]])) for c in names}
    late = {c: meets_clamp(stacks[c], clamp) for c in names}
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
                yield Arrangement(turn, clamp_up, gear_rule, order, sides)
