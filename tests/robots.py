"""Random but reasonable robots for the stability runs: the prototype's materials, process and
gears with a random backbone, disk count and set of tendons (straight, cosine, helix)."""
from __future__ import annotations

import copy
import math

import numpy as np
import yaml

from .conftest import PARAMS

BASE = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
MIN_SPACING = 12.0        # mm: two hubs of the shortest length (glue port and walls) and a disk fit one gap


def _function(rng: np.random.Generator, r_max: float) -> dict:
    kind = str(rng.choice(["straight", "cosine", "helix"]))
    if kind == "straight":
        r = float(rng.uniform(8, r_max))
        a = float(rng.uniform(0, 2 * math.pi))
        return {"kind": "straight", "x0": round(r * math.sin(a), 1), "z0": round(r * math.cos(a), 1)}
    f = {"kind": kind, "a": round(float(rng.uniform(10, r_max)), 1), "k": int(rng.integers(1, 4)),
         "phase_deg": float(rng.choice([0, 90, 180, 270]))}
    if kind == "cosine":
        f["axis"] = str(rng.choice(["x", "z"]))
        if f["axis"] == "x":          # off the strip plane, or it would run inside the strip
            f["a"] = round(float(rng.uniform(10, 0.7 * r_max)), 1)
            f["z0"] = round(float(rng.choice([-1, 1]) * rng.uniform(8, math.sqrt(r_max ** 2 - f["a"] ** 2))), 1)
    return f


def _starts_in_slot(f: dict, length: float) -> bool:
    """A tendon must start off the strip at the base disk: its knot needs a seat there."""
    from hwgen.model.routing import sample_function
    from hwgen.params import RoutingFunction
    x, z = sample_function(RoutingFunction(**f), [0.0], length)[0]
    return abs(x) < BASE["backbone"]["height"] / 2 + 2 and abs(z) < 3


def _hub_tilt(doc: dict) -> float:
    """The tilt a designer allows so that every hub ends short of the next disk: the default 0.5°
    where the disks are far enough apart, more on a dense robot."""
    from hwgen.model.feasibility import _hub_problems
    from hwgen.params import Design
    tilt = doc["disks"]["hub"]["max_tilt_deg"]
    while tilt < 10 and _hub_problems(Design.model_validate(doc)):
        tilt = round(tilt + 0.25, 2)
        doc["disks"]["hub"]["max_tilt_deg"] = tilt
    return tilt


def random_robot(rng: np.random.Generator, name: str) -> dict:
    """A design document (as from YAML) with 1-6 tendons on 4-25 disks, at least 12 mm apart (closer,
    two disks' hubs cannot both fit one gap), each tendon starting off the strip, and the hubs' tilt
    allowance what the spacing leaves room for."""
    doc = copy.deepcopy(BASE)
    doc["design"] = name
    length = float(rng.choice([180, 220, 270, 320]))
    count = min(int(rng.integers(4, 26)), int(length // MIN_SPACING) + 1)
    doc["backbone"]["length"] = length
    doc["disks"]["count"] = count
    doc["disks"]["spacing"] = length / (count - 1)
    r_max = doc["disks"]["outer_diameter"] / 2 - 6
    tendons = []
    n = int(rng.integers(1, 7))
    pair = rng.random() < 0.5 and n >= 2
    for i in range(n - (1 if pair else 0)):
        f = _function(rng, r_max)
        while _starts_in_slot(f, length):
            f = _function(rng, r_max)
        t = {"name": f"T{i}", "channel": f"K{i}", "routing": {"function": f}}
        tendons.append(t)
    if pair:          # an actuating pair on one channel, mirrored through the strip plane
        tendons[0] = {"name": "A1", "channel": "K0",
                      "routing": {"function": {"kind": "straight", "z0": round(float(rng.uniform(15, r_max)), 1)},
                                  "mirror": True, "mirror_name": "A2"}}
    doc["tendons"] = tendons
    # a designer whose tendon leaves the tip in the strip's plane ends the strip inside the tip
    # disk: nothing to clamp there, and nothing in the tendon's way
    from hwgen.model.routing import sample_function
    from hwgen.params import RoutingFunction
    tips = [sample_function(RoutingFunction(**t["routing"]["function"]), [length], length)[0] for t in tendons]
    if any(abs(z) < 8 for _, z in tips):
        doc["backbone"]["extra_tip"] = 2
    doc["tensioner"]["channels"] = sorted({t["channel"] for t in tendons})
    doc["tensioner"]["actuating_channel"] = tendons[0]["channel"]
    _hub_tilt(doc)
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
