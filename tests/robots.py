"""Random robots as a lab writes them, for the stability runs: the prototype's materials, process
and gears with a random backbone, disks and set of tendons (straight, cosine, helix)."""
from __future__ import annotations

import copy
import math

import numpy as np
import yaml

from .conftest import PARAMS

BASE = yaml.safe_load((PARAMS / "prototype.yaml").read_text())

# The ranges a lab writes its own robot in, starting from params/prototype.yaml and changing the
# backbone, the disks and the tendons; everything else is left as shipped. Nothing here is tuned
# to dodge a refusal: what hwgen cannot take shows up as exit 2 in the stability table.
LENGTH_MM = (150.0, 450.0)        # backbone.length, rounded to 5 mm
DISKS = (4, 25)                   # disks.count, equally spaced
STRIP_HEIGHT_MM = (20.0, 80.0)    # backbone.height, to 0.1 mm
STRIP_THICKNESS_MM = (0.3, 1.5)   # backbone.thickness, to 0.01 mm
SLOT_CLEARANCE_MM = (0.03, 0.1)   # disks.slot_clearance per side, to 0.001 mm
TENDONS = (1, 6)                  # straight, cosine (along z) or helical, one channel each; an actuating
                                  # pair (a straight tendon and its mirror on one channel) in 60 % of robots
RIM_MM = 6.0                      # tendons at most this far inside the disk's rim
DISK_MARGIN_MM = 12.0             # a lab draws the disk at least this much wider than its strip (72 mm at least)
WAVES = (1, 4)                    # k of a cosine or helix, whole half-waves


def _function(rng: np.random.Generator, r_max: float, strip: tuple[float, float]) -> dict:
    kind = str(rng.choice(["straight", "cosine", "helix"]))
    a = round(float(rng.uniform(8, r_max)), 1)
    if kind == "straight":
        ang = float(rng.uniform(0, 2 * math.pi))
        x0, z0 = round(a * math.sin(ang), 1), round(a * math.cos(ang), 1)
        if abs(x0) < strip[0] / 2 + 3 and abs(z0) < strip[1] / 2 + 3:     # it would run inside the strip
            x0, z0 = 0.0, math.copysign(a, z0 or 1.0)
        return {"kind": "straight", "x0": x0, "z0": z0}
    f = {"kind": kind, "a": a, "k": int(rng.integers(WAVES[0], WAVES[1] + 1))}
    if kind == "cosine":
        f["axis"] = "z"
    return f


def random_robot(rng: np.random.Generator, name: str) -> dict:
    """A design document (as from YAML): the prototype with a backbone, disks and tendons drawn
    from the ranges above."""
    doc = copy.deepcopy(BASE)
    doc["design"] = name
    length = float(round(rng.uniform(*LENGTH_MM) / 5) * 5)
    count = int(rng.integers(DISKS[0], DISKS[1] + 1))
    height = round(float(rng.uniform(*STRIP_HEIGHT_MM)), 1)
    thickness = round(float(rng.uniform(*STRIP_THICKNESS_MM)), 2)
    doc["backbone"].update(length=length, height=height, thickness=thickness)
    od = max(doc["disks"]["outer_diameter"], math.ceil(height + DISK_MARGIN_MM))
    doc["disks"].update(count=count, spacing=length / (count - 1), outer_diameter=od,
                        slot_clearance=round(float(rng.uniform(*SLOT_CLEARANCE_MM)), 3))
    r_max = od / 2 - RIM_MM
    n = int(rng.integers(TENDONS[0], TENDONS[1] + 1))
    tendons = []
    if n >= 2 and rng.random() < 0.6:
        tendons.append({"name": "A1", "channel": "A", "routing": {
            "function": {"kind": "straight", "z0": round(float(rng.uniform(10, r_max)), 1)},
            "mirror": True, "mirror_name": "A2"}})
    while len(tendons) < n:
        i = len(tendons)
        tendons.append({"name": f"T{i}", "channel": f"K{i}",
                        "routing": {"function": _function(rng, r_max, (height, thickness))}})
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
