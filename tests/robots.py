"""Random robots as a lab writes them, for the stability runs.

:func:`random_robot` is the stability draw: a lab starts from params/prototype.yaml and writes its
own values: the backbone, the disks (count, even or listed stations, diameter, both thicknesses),
the strip it leaves beyond both end disks, its printer and material, and its tendons (straight,
cosines along x or z, helices, any k, mirrored, or a table of the positions it measured on its
disks). Every range is stated below; nothing is tuned to dodge a refusal or a failed check: what
hwgen cannot take shows up in the stability table.

:func:`classic_robot` is the first draw (issue 16: the prototype's disks, processes and strip ends
with a random backbone and tendons), kept so the tests that name its robots by index still find them.
"""
from __future__ import annotations

import copy
import math

import numpy as np
import yaml

from hwgen.model.materials import table as material_table

from .conftest import PARAMS

BASE = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
# without the prototype's bench (its base frame and rig): the draws test the robot a lab writes;
# tests/test_bench_hardware.py tests the bench
BASE.update(base_frame={"enabled": False}, rig={"enabled": False})

# ---- the stability draw: the ranges a lab writes its own robot in --------------------------------
LENGTH_MM = (150.0, 450.0)        # backbone.length, rounded to 5 mm
DISKS = (4, 25)                   # disks.count (fewer where its disks would touch: DISK_GAP_MM)
STRIP_HEIGHT_MM = (20.0, 80.0)    # backbone.height, to 0.1 mm
STRIP_THICKNESS_MM = (0.3, 1.5)   # backbone.thickness, to 0.01 mm
DISK_OVER_STRIP_MM = 4.0          # disks.outer_diameter from the strip's height + this ...
DISK_MAX_MM = 120.0               # ... to this, to 0.5 mm
DISK_THICKNESS_MM = (1.5, 5.0)    # disks.thickness, to 0.1 mm
END_THICKNESS_MM = (3.0, 10.0)    # disks.end_thickness, to 0.1 mm
EXTRA_BASE_MM = (10.0, 40.0)      # backbone.extra_base, to 0.5 mm
EXTRA_TIP_MM = (10.0, 30.0)       # backbone.extra_tip, to 0.5 mm
LISTED_STATIONS = 0.4             # share of robots that list their stations (else disks.spacing, or neither)
STATION_SPREAD = (0.5, 1.5)       # listed stations: each gap this share of the mean gap, to 0.1 mm
DISK_GAP_MM = 1.0                 # a lab's disks do not touch: the count drops until every gap keeps this
TENDONS = (1, 6)                  # tendons written, one channel each; an actuating pair (a straight tendon
ACTUATING_PAIR = 0.6              # and its mirror on one channel) in this share of robots
KINDS = ("straight", "cosine z", "cosine x", "helix")   # equally likely
MIRRORED = 0.3                    # share of the other tendons routed with their mirror (z -> -z) too
MEASURED = 0.25                   # share of the tendons written as a table of measured positions
MEASURE_NOISE_MM = 0.2            # ... each the drawn path's, off by up to ± this in x and z, to 0.01 mm
WHOLE_K = 0.5                     # share of cosines and helices with whole k (1 to 4); the rest any k
K_RANGE = (0.25, 4.0)             # ... to 0.05
PHASED = 0.25                     # share of cosines and helices given a phase, a multiple of 15°
RIM_MM = 3.0                      # an eyelet's centre at least this far inside the disk's rim
STRIP_FACE_MM = 2.0               # and, over the strip, at least this far off its faces
# Processes: a printer of each technology, the material a row of hwgen/data/materials.csv.
SLA = dict(BASE["process"])       # the prototype's Photon M3 (params/prototype.yaml gives the reasons)
FDM = {"name": "FDM, 0.4 mm nozzle, Prusa MK3S", "technology": "FDM",
       "min_wall": 0.8,           # two 0.4 mm perimeters
       "min_hole": 1.0,           # smaller holes close up with the nozzle's ooze
       "hole_clearance": 0.3,     # an FDM hole comes out 0.1-0.3 mm small: the line must still slide
       "build_volume": [250, 210, 210],   # Prusa MK3S
       "position_sigma": 0.1,     # an FDM printer holds about ±0.1 mm
       "diameter_sigma": 0.1}
SLOT_CLEARANCE_MM = {"SLA": (0.03, 0.1), "FDM": (0.1, 0.2)}   # per side, to 0.001 mm: what each holds
JIG_CLEARANCE_MM = {"SLA": 0.05, "FDM": 0.15}                 # disk in its jig slot, per side


def _round(v: float, step: float) -> float:
    return round(round(v / step) * step, 6)


def _stations(rng: np.random.Generator, length: float, count: int) -> list[float]:
    w = rng.uniform(*STATION_SPREAD, count - 1)
    st = [_round(v, 0.1) for v in np.concatenate([[0.0], np.cumsum(w) / w.sum() * length])]
    st[-1] = length
    return st


def _disk_layout(rng: np.random.Generator, doc: dict, length: float) -> None:
    """disks.count and where they stand, equally spaced or listed, dropping disks until none touches."""
    dk = doc["disks"]
    count = int(rng.integers(DISKS[0], DISKS[1] + 1))
    listed = rng.random() < LISTED_STATIONS
    spaced = rng.random() < 0.5
    while True:
        st = _stations(rng, length, count) if listed else [i * length / (count - 1) for i in range(count)]
        th = [dk["end_thickness"]] + [dk["thickness"]] * (count - 2) + [dk["end_thickness"]]
        gaps = [b - a - (ta + tb) / 2 for a, b, ta, tb in zip(st, st[1:], th, th[1:])]
        if count == 2 or min(gaps) >= DISK_GAP_MM:
            break
        count -= 1
    dk["count"] = count
    dk.pop("spacing", None)
    if listed:
        dk["stations"] = st
    elif spaced:
        dk["spacing"] = length / (count - 1)


def _path(rng: np.random.Generator, kind: str, r: tuple[float, float], strip: tuple[float, float]) -> dict:
    """An eq. (3) function of the given kind whose eyelets stay within radii ``r`` (and clear of the
    strip's faces where they stand over it)."""
    lo, hi = r
    a = _round(float(rng.uniform(lo, hi)), 0.1)
    if kind == "straight":
        ang = float(rng.uniform(0, 2 * math.pi))
        x0, z0 = _round(a * math.sin(ang), 0.1), _round(a * math.cos(ang), 0.1)
        if abs(x0) < strip[0] / 2 + STRIP_FACE_MM and abs(z0) < strip[1] / 2 + STRIP_FACE_MM:
            x0, z0 = 0.0, math.copysign(a, z0 or 1.0)       # it would run inside the strip: above or below it
        return {"kind": "straight", "x0": x0, "z0": z0}
    f: dict = {"kind": "helix" if kind == "helix" else "cosine"}
    f["k"] = (int(rng.integers(1, 5)) if rng.random() < WHOLE_K else _round(float(rng.uniform(*K_RANGE)), 0.05))
    if rng.random() < PHASED:
        f["phase_deg"] = float(15 * rng.integers(1, 24))
    if kind == "cosine x":          # across the strip, above or below it
        z0 = _round(float(rng.uniform(lo, max(lo, 0.7 * hi))), 0.1) * (1 if rng.random() < 0.5 else -1)
        f.update(axis="x", z0=z0, a=_round(float(rng.uniform(0.3, 1.0)) * math.sqrt(max(hi**2 - z0**2, 0.0)), 0.1))
    elif kind == "cosine z":        # through the strip (as the paper's C1, C2), or beside its middle
        x0 = 0.0 if rng.random() < 0.5 else _round(float(rng.uniform(-0.5, 0.5)) * hi, 0.1)
        f.update(axis="z", a=_round(float(rng.uniform(lo, max(lo, math.sqrt(max(hi**2 - x0**2, 0.0))))), 0.1))
        if x0:
            f["x0"] = x0
    else:
        f["a"] = a
    return f


def _measured(rng: np.random.Generator, f: dict, stations, length: float) -> list[list[float]]:
    """The function's positions at the stations as a lab measures them on its printed disks."""
    from hwgen.model.routing import sample_function
    from hwgen.params import RoutingFunction
    pts = sample_function(RoutingFunction(**f), stations, length)
    pts = pts + rng.uniform(-MEASURE_NOISE_MM, MEASURE_NOISE_MM, pts.shape)
    return [[_round(float(x), 0.01), _round(float(z), 0.01)] for x, z in pts]


def _process(rng: np.random.Generator, doc: dict) -> str:
    rows = material_table()
    name = str(rng.choice(sorted(rows)))
    tech = rows[name].technology
    proc = dict(SLA if tech == "SLA" else FDM)
    proc.update(material=name, technology=tech)
    if tech == "SLA":
        proc["name"] = f"SLA {name}, Anycubic Photon M3"
    doc["process"] = proc
    doc["jig"]["clearance"] = JIG_CLEARANCE_MM[tech]
    return tech


def random_robot(rng: np.random.Generator, name: str) -> dict:
    """A design document (as from YAML): the prototype with the values a lab writes drawn from the
    ranges above."""
    doc = copy.deepcopy(BASE)
    doc["design"] = name
    tech = _process(rng, doc)
    length = float(round(rng.uniform(*LENGTH_MM) / 5) * 5)
    height = _round(float(rng.uniform(*STRIP_HEIGHT_MM)), 0.1)
    thickness = _round(float(rng.uniform(*STRIP_THICKNESS_MM)), 0.01)
    doc["backbone"].update(length=length, height=height, thickness=thickness,
                           extra_base=_round(float(rng.uniform(*EXTRA_BASE_MM)), 0.5),
                           extra_tip=_round(float(rng.uniform(*EXTRA_TIP_MM)), 0.5))
    od = _round(float(rng.uniform(height + DISK_OVER_STRIP_MM, DISK_MAX_MM)), 0.5)
    dk = doc["disks"]
    dk.update(outer_diameter=od, thickness=_round(float(rng.uniform(*DISK_THICKNESS_MM)), 0.1),
              end_thickness=_round(float(rng.uniform(*END_THICKNESS_MM)), 0.1),
              slot_clearance=_round(float(rng.uniform(*SLOT_CLEARANCE_MM[tech])), 0.001))
    _disk_layout(rng, doc, length)
    stations = dk.get("stations") or [i * length / (dk["count"] - 1) for i in range(dk["count"])]
    r = (thickness / 2 + STRIP_FACE_MM, od / 2 - RIM_MM)
    n = int(rng.integers(TENDONS[0], TENDONS[1] + 1))
    tendons = []
    if n >= 2 and rng.random() < ACTUATING_PAIR:
        tendons.append({"name": "A1", "channel": "A", "routing": {
            "function": {"kind": "straight", "z0": _round(float(rng.uniform(*r)), 0.1)},
            "mirror": True, "mirror_name": "A2"}})
    while len(tendons) < n:
        i = len(tendons)
        f = _path(rng, str(rng.choice(KINDS)), r, (height, thickness))
        routing: dict = {"function": f}
        if rng.random() < MEASURED:
            routing = {"table": _measured(rng, f, stations, length)}
        if rng.random() < MIRRORED:
            routing.update(mirror=True, mirror_name=f"T{i}m")
        tendons.append({"name": f"T{i}", "channel": f"K{i}", "routing": routing})
    doc["tendons"] = tendons
    doc["tensioner"]["channels"] = [t["channel"] for t in tendons]
    doc["tensioner"]["actuating_channel"] = tendons[0]["channel"]
    return doc


# ---- the widened draw (issue 45): what the robots that broke the generator wrote -----------------
# :func:`lab_robot` is :func:`random_robot` (so the robots the tests name by index are unchanged)
# and, drawn after it from the same stream, what the repro robots of issue 45 showed the first draw
# never writes: several tendons on one channel, tables measured with Gaussian noise, disks only as
# large as the tendons need, tendons with a length budget, and FDM walls the prototype's gear does
# not print with (the gear left to hwgen).
SHARED_CHANNELS = 0.35            # share of robots with two or more tendons whose tendons share channels ...
#                                   (channel count drawn from 1 to one fewer than the tendons)
NOISY_TABLES = 0.15               # share of the function-routed tendons written instead as a table measured ...
TABLE_SIGMA_MM = (0.02, 0.05, 0.1)  # ... with Gaussian noise of one of these σ in x and z, to 0.01 mm
TIGHT_DISKS = 0.3                 # share of robots whose disks are only as large as their eyelets need ...
TIGHT_MARGIN_MM = (0.0, 3.0)      # ... plus RIM_MM and this much, to 0.5 mm (never under the strip + DISK_OVER_STRIP_MM)
BUDGETED = 0.15                   # share of the tendons given a length budget ...
BUDGET_MM = (5.0, 20.0, 50.0)     # ... one of these, mm
FDM_MIN_WALL_MM = (0.8, 0.9, 1.0, 1.2)   # an FDM lab's walls: two 0.4 mm perimeters, or what its slicer holds
GEAR_LEFT = ("module", "worm_pitch_diameter", "worm_length", "worm_starts")   # an FDM lab does not write these


def _channels(rng: np.random.Generator, doc: dict) -> None:
    """Several tendons on one channel: the tendons dealt over fewer channels, each channel one at least."""
    tendons = doc["tendons"]
    if len(tendons) < 2 or rng.random() >= SHARED_CHANNELS:
        return
    count = int(rng.integers(1, len(tendons)))
    deal = np.concatenate([np.arange(count), rng.integers(0, count, len(tendons) - count)])
    rng.shuffle(deal)
    for t, c in zip(tendons, deal):
        t["channel"] = f"C{int(c)}"
    doc["tensioner"]["channels"] = [f"C{c}" for c in range(count)]
    doc["tensioner"]["actuating_channel"] = tendons[0]["channel"]


def _noisy_tables(rng: np.random.Generator, doc: dict, stations, length: float) -> None:
    from hwgen.model.routing import sample_function
    from hwgen.params import RoutingFunction
    for t in doc["tendons"]:
        f = t["routing"].get("function")
        if f is None or rng.random() >= NOISY_TABLES:
            continue
        sigma = float(rng.choice(TABLE_SIGMA_MM))
        pts = sample_function(RoutingFunction(**f), stations, length)
        pts = pts + rng.normal(0.0, sigma, pts.shape)
        t["routing"]["table"] = [[_round(float(x), 0.01), _round(float(z), 0.01)] for x, z in pts]
        del t["routing"]["function"]


def _reach(doc: dict, stations, length: float) -> float:
    """The largest distance of any tendon's eyelet from the disks' centre (mirrors included), mm."""
    from hwgen.model.routing import sample_function
    from hwgen.params import RoutingFunction
    r = 0.0
    for t in doc["tendons"]:
        table = t["routing"].get("table")
        pts = (np.asarray(table, dtype=float) if table is not None else
               sample_function(RoutingFunction(**t["routing"]["function"]), stations, length))
        r = max(r, float(np.max(np.hypot(pts[:, 0], pts[:, 1]))))
    return r


def lab_robot(rng: np.random.Generator, name: str) -> dict:
    """The stability draw: :func:`random_robot`, widened by the ranges above."""
    doc = random_robot(rng, name)
    bb, dk = doc["backbone"], doc["disks"]
    length = bb["length"]
    stations = dk.get("stations") or [i * length / (dk["count"] - 1) for i in range(dk["count"])]
    _channels(rng, doc)
    _noisy_tables(rng, doc, stations, length)
    if rng.random() < TIGHT_DISKS:
        need = 2 * (_reach(doc, stations, length) + RIM_MM + float(rng.uniform(*TIGHT_MARGIN_MM)))
        dk["outer_diameter"] = max(math.ceil(need * 2) / 2, bb["height"] + DISK_OVER_STRIP_MM)
    for t in doc["tendons"]:
        if rng.random() < BUDGETED:
            t["budget_mm"] = float(rng.choice(BUDGET_MM))
    if doc["process"]["technology"] == "FDM":
        doc["process"]["min_wall"] = float(rng.choice(FDM_MIN_WALL_MM))
        for key in GEAR_LEFT:              # the gear left to hwgen: it follows the walls
            doc["tensioner"].pop(key, None)
    return doc


# ---- the first draw (issue 16), for the tests that name its robots ----------------------------------
class Classic:
    """The first draw's ranges: the prototype's disks (Ø at least the strip + 12 mm, 72 mm at least),
    processes and strip ends, with a random backbone and one to six straight, cosine (along z) or
    helical tendons of whole k, at least 8 mm from the centre and 6 mm inside the rim."""
    LENGTH_MM = (150.0, 450.0)
    DISKS = (4, 25)
    STRIP_HEIGHT_MM = (20.0, 80.0)
    STRIP_THICKNESS_MM = (0.3, 1.5)
    SLOT_CLEARANCE_MM = (0.03, 0.1)
    TENDONS = (1, 6)
    RIM_MM = 6.0
    DISK_MARGIN_MM = 12.0
    WAVES = (1, 4)


def _classic_function(rng: np.random.Generator, r_max: float, strip: tuple[float, float]) -> dict:
    kind = str(rng.choice(["straight", "cosine", "helix"]))
    a = round(float(rng.uniform(8, r_max)), 1)
    if kind == "straight":
        ang = float(rng.uniform(0, 2 * math.pi))
        x0, z0 = round(a * math.sin(ang), 1), round(a * math.cos(ang), 1)
        if abs(x0) < strip[0] / 2 + 3 and abs(z0) < strip[1] / 2 + 3:     # it would run inside the strip
            x0, z0 = 0.0, math.copysign(a, z0 or 1.0)
        return {"kind": "straight", "x0": x0, "z0": z0}
    f = {"kind": kind, "a": a, "k": int(rng.integers(Classic.WAVES[0], Classic.WAVES[1] + 1))}
    if kind == "cosine":
        f["axis"] = "z"
    return f


def classic_robot(rng: np.random.Generator, name: str) -> dict:
    """A robot of the first draw (:class:`Classic`'s ranges); the same robots for the same seed as before."""
    c = Classic
    doc = copy.deepcopy(BASE)
    doc["design"] = name
    length = float(round(rng.uniform(*c.LENGTH_MM) / 5) * 5)
    count = int(rng.integers(c.DISKS[0], c.DISKS[1] + 1))
    height = round(float(rng.uniform(*c.STRIP_HEIGHT_MM)), 1)
    thickness = round(float(rng.uniform(*c.STRIP_THICKNESS_MM)), 2)
    doc["backbone"].update(length=length, height=height, thickness=thickness)
    od = max(doc["disks"]["outer_diameter"], math.ceil(height + c.DISK_MARGIN_MM))
    doc["disks"].update(count=count, spacing=length / (count - 1), outer_diameter=od,
                        slot_clearance=round(float(rng.uniform(*c.SLOT_CLEARANCE_MM)), 3))
    r_max = od / 2 - c.RIM_MM
    n = int(rng.integers(c.TENDONS[0], c.TENDONS[1] + 1))
    tendons = []
    if n >= 2 and rng.random() < 0.6:
        tendons.append({"name": "A1", "channel": "A", "routing": {
            "function": {"kind": "straight", "z0": round(float(rng.uniform(10, r_max)), 1)},
            "mirror": True, "mirror_name": "A2"}})
    while len(tendons) < n:
        i = len(tendons)
        tendons.append({"name": f"T{i}", "channel": f"K{i}",
                        "routing": {"function": _classic_function(rng, r_max, (height, thickness))}})
    doc["tendons"] = tendons
    doc["tensioner"]["channels"] = [t["channel"] for t in tendons]
    doc["tensioner"]["actuating_channel"] = tendons[0]["channel"]
    return doc


def reordered(doc: dict) -> dict:
    """The same robot with its channels listed in the opposite order."""
    out = copy.deepcopy(doc)
    out["tensioner"]["channels"] = list(reversed(out["tensioner"]["channels"]))
    return out


def turned_over(doc: dict) -> dict:
    """The same robot mirrored through its strip plane (z -> -z): routing and tip bolt pattern."""
    out = copy.deepcopy(doc)
    for t in out["tendons"]:
        table = t["routing"].get("table")
        if table is not None:
            t["routing"]["table"] = [[x, -z] for x, z in table]
        f = t["routing"].get("function")
        if f is None:
            continue
        if f["kind"] == "helix":
            # x = a sin(kπs/L + φ), z = a cos(...): z -> -z with x kept is the helix of the other hand
            f["k"] = -f.get("k", 1.0)
            f["phase_deg"] = (-f.get("phase_deg", 0.0) - 180.0) % 360.0
        elif f["kind"] == "cosine" and f.get("axis", "z") == "z":
            f["phase_deg"] = (f.get("phase_deg", 0.0) + 180.0) % 360.0      # a cos(θ + φ + π) = -a cos(θ + φ)
        f["z0"] = -f.get("z0", 0.0)
    pos = out["disks"].get("tip_mount", {}).get("positions")
    if pos:
        out["disks"]["tip_mount"]["positions"] = [[x, -z] for x, z in pos]
    return out
