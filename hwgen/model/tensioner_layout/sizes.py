"""Fixed sizes of the tensioner's parts (mm, from data/tensioner_parts.csv, each row with its
reason), the fasteners each process takes (data/fasteners.csv), and :class:`Sizes`: what one
design's parameters make of them, shared by every unit."""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from importlib import resources

from ...params import Design, Tensioner
from .. import hardware
from ..hardware import NUT_PLAY
from ..gearing import WormPair, worm_pair
from ..specs import DiskSpec


def _table() -> dict[str, float | tuple[float, ...]]:
    """Every row of data/tensioner_parts.csv, each with its reason there: name -> mm (a tuple
    where the row gives several figures)."""
    text = resources.files("hwgen").joinpath(f"data/{TABLE}").read_text(encoding="utf-8")
    out: dict[str, float | tuple[float, ...]] = {}
    for r in csv.DictReader(text.splitlines()):
        words = r["value_mm"].split()
        if r["name"] in out:
            raise ValueError(f"data/{TABLE} gives {r['name']} twice")
        out[r["name"]] = float(words[0]) if len(words) == 1 else tuple(float(w) for w in words)
    return out


TABLE = "tensioner_parts.csv"      # the tensioner's part sizes (mm), beside fasteners.csv
_SIZE = _table()
# Spool and wheel part
WIND_WIDTH = _SIZE["wind_width"]
FLANGE_HEIGHT = _SIZE["flange_height"]
FLANGE = _SIZE["flange"]
CLAMP_BAY = _SIZE["clamp_bay"]
WORM_CLEAR = _SIZE["worm_clear"]
HUB_WALL = _SIZE["hub_wall"]
CLAMP_PLATE = _SIZE["clamp_plate"]           # x, y, thickness
CLAMP_HEAD = hardware.size("button head screw", "M2", "head_height")   # the clamp screw's head above the plate
ANCHOR_HOLE = _SIZE["anchor_hole"]
CAP = _SIZE["cap"]
# Housing
GAP = _SIZE["gap"]
SHELF = _SIZE["shelf"]
WORM_END = _SIZE["worm_end"]
DRIVE_SHAFT = _SIZE["drive_shaft"]
DRIVE_HEX = _SIZE["drive_hex"]
DRIVE_HEX_LENGTH = _SIZE["drive_hex_length"]
DRIVE_FLANGE = _SIZE["drive_flange"]         # Ø, thickness
KEY_SOCKET_CLEARANCE = 0.1   # the hex key's socket in the drive shaft, across flats over the key, mm
KEY_SOCKET_DEPTH = 5.0       # that socket's depth from the flange's face, mm (a 2.5 mm key engages fully at 5 mm)


def key_socket(hex_key: float) -> float:
    """The hex key's socket in the drive shaft across its corners, mm."""
    return (hex_key + KEY_SOCKET_CLEARANCE) * 2 / math.sqrt(3)


VENT = 1.2                   # through every blind bore of the worm and drive: resin drains and no cup forms while printing, mm
AXIAL_PLAY = _SIZE["axial_play"]
POST = _SIZE["post"]
BOSS = _SIZE["boss"]
UNIT_GAP = _SIZE["unit_gap"]
PIN_ENGAGE = _SIZE["pin_engage"]
PIN_LENGTHS = hardware.lengths("dowel pin", "Ø3")     # ISO 2338 stock lengths
STRIP_CLAMP_Z = _SIZE["strip_clamp_z"]       # z range
STRIP_CLAMP_X = _SIZE["strip_clamp_x"]
STRIP_SLOT_CLEARANCE = _SIZE["strip_slot_clearance"]
M3_CLEARANCE = hardware.clearance_hole("M3")        # ISO 273 normal
M2_CLEARANCE = hardware.clearance_hole("M2")
MOUNT_BAR = _SIZE["mount_bar"]
TENDON_HOLE = _SIZE["tendon_hole"]
# Fasteners by process (data/fasteners.csv). Resin: hex nuts (ISO 4032) in traps, with play over
# the nut; thermoplastic: heat-set inserts.
NUT = {t: hardware.nut(t) for t in ("M2", "M3")}          # across flats, height
INSERT = {t: hardware.insert(t) for t in ("M2", "M3")}    # bore, length
SET_SCREW = hardware.size("set screw", "M3", "length")    # the strip clamp's M3 set screws
SPINE = _SIZE["spine"]
BASE = {"nut": _SIZE["base_nut"], "insert": _SIZE["base_insert"]}    # base bars on the tip disk (y), or deeper: base_bars()
NUT_BACKING = _SIZE["nut_backing"]
# stock lengths: the clamps' M2 button head screws, the tip disk's M3 socket head cap screws
SCREW_LENGTHS = {"M2": hardware.lengths("button head screw", "M2"), "M3": hardware.lengths("socket head cap screw", "M3")}
# Layout search
X_STEP = 0.5
X_COARSE = 2.0
X_SEARCH = 80.0
MAX_LIFTS = 30
EVERY_ORDER_UP_TO = 3     # channels up to which every order along y is tried; beyond, orders by geometry
MAX_SOLVES = 32           # arrangements solved at most, in order of their lower bound (each takes a few ms)


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
        screw = standard_screw(thread, grip + body)
        far = screw - grip                                     # the screw's end, deep in the body
        if far < h + NUT_BACKING:
            raise NoFit(f"a {thread} nut and its screw do not fit in {body:g} mm of resin")
        clear = M3_CLEARANCE if thread == "M3" else M2_CLEARANCE
        return Fastening("nut", thread, screw, clear, far - h - NUT_PLAY / 2, far + NUT_PLAY / 2, body)
    bore, length = INSERT[thread]
    depth = min(body, length + 0.5)
    return Fastening("insert", thread, standard_screw(thread, grip + depth - 0.5), bore, 0.0, depth, body)


class NoFit(ValueError):
    """No arrangement fits; the message names the tendon, what it hits and what would free it."""


def spool_wall_problem(ts: Tensioner, min_wall: float) -> str | None:
    """Why the spool drum leaves too little wall around its pin's bore, or None."""
    if ts.spool_diameter < ts.shaft_diameter + ts.running_fit + 2 * min_wall:
        return (f"{ts.spool_diameter:g} mm leaves less than {min_wall:g} mm of wall around "
                f"the Ø{ts.shaft_diameter:g} mm pin's bore")
    return None


def fastening(technology: str) -> str:
    """Resin (SLA) takes nuts in traps; thermoplastic (FDM) takes heat-set inserts."""
    return "nut" if technology == "SLA" else "insert"


@dataclass(frozen=True, kw_only=True)
class Sizes:
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
    fast: str                # "nut" or "insert": what the housing's screws go into

    @property
    def clamp_room(self) -> float:
        """The least x from the strip clamp's end to a spine's inner face. With nuts, the set
        screws' nuts slide into the clamp from its ends, flat, corners first along their slots:
        a nut's width across corners, with its play. With inserts the spine only stays clear."""
        if self.fast == "nut":
            af, _ = NUT["M3"]
            return af / math.cos(math.radians(30)) + NUT_PLAY
        return GAP

    @staticmethod
    def of(d: Design, tip: DiskSpec) -> Sizes:
        ts = d.tensioner
        pair = worm_pair(ts, d.process.min_wall)
        r_s = ts.spool_diameter / 2
        problem = spool_wall_problem(ts, d.process.min_wall)
        if problem:
            raise NoFit(f"tensioner.spool_diameter {problem}")
        fast = fastening(d.process.technology)
        td = d.tendon_material.diameter
        return Sizes(pair=pair, y_face=tip.y + tip.thickness / 2, tendon_d=td,
                     need=td / 2 + ts.tendon_clearance + td / 2, max_exit=math.radians(ts.max_exit_deg),
                     r_s=r_s, r_w=r_s + td / 2, r_f=r_s + FLANGE_HEIGHT,
                     hub_r=max(ts.shaft_diameter / 2 + ts.running_fit / 2 + HUB_WALL, r_s),
                     spine_hole=DRIVE_SHAFT + ts.running_fit, spine_t=SPINE, base_t=base_bars(fast, tip.thickness),
                     tip_t=tip.thickness,
                     strip_half_x=d.backbone.height / 2, strip_half_z=d.backbone.thickness / 2,
                     y_end=d.backbone.length + d.backbone.extra_tip, fast=fast)


def standard_screw(kind: str, reach: float) -> float:
    """Longest standard screw of this size no longer than ``reach``: it ends inside the body."""
    n = hardware.longest_within(SCREW_LENGTHS[kind], reach)
    if n is None:
        raise NoFit(f"no standard {kind} screw is as short as {reach:.1f} mm")
    return float(n)


def base_bars(fast: str, tip_thickness: float) -> float:
    """The base bars' depth along y: BASE, or deeper where no standard screw through a tip disk
    this thick would end inside them past its nut: as deep as the shortest screw that does, with its
    nut trap and NUT_BACKING of resin behind it."""
    base = BASE[fast]
    if fast != "nut":
        return base
    need = tip_thickness + NUT["M3"][1] + NUT_BACKING           # as joint() asks of the screw's far end
    screw = float(hardware.shortest_reaching(SCREW_LENGTHS["M3"], need))
    return max(base, screw - tip_thickness + NUT_PLAY / 2 + NUT_BACKING)


def clamp_joint(fast: str, on_cap: bool, face_width: float) -> Fastening:
    """A clamp plate's M2 screw: through the plate into the gear, or into the end cap it sits on."""
    return joint(fast, "M2", CLAMP_PLATE[2], CAP if on_cap else face_width)


def clamp_on_cap(caps, zc: float) -> bool:
    """Whether a clamp at the wheel face ``zc`` sits on one of the end caps (z ranges) ``caps``."""
    return any(c[0] - 1e-9 <= zc <= c[1] + 1e-9 for c in caps)


def tip_joint(fast: str, tip_thickness: float, base_t: float) -> Fastening:
    """The screws that hold the housing to the tip disk, through the disk into the base bars."""
    return joint(fast, "M3", tip_thickness, base_t)
