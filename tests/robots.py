"""Random but reasonable robots for the stability runs: the prototype's materials, process and
gears with a random backbone, disk count and set of tendons (straight, cosine, helix)."""
from __future__ import annotations

import copy
import math

import numpy as np
import yaml

from .conftest import PARAMS

BASE = yaml.safe_load((PARAMS / "prototype.yaml").read_text())


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


def _at(f: dict, s: float, length: float) -> tuple[float, float]:
    """(x, z) of a routing function at arc length s."""
    from hwgen.model.routing import sample_function
    from hwgen.params import RoutingFunction
    return tuple(sample_function(RoutingFunction(**f), [s], length)[0])


def random_robot(rng: np.random.Generator, name: str) -> dict:
    """A design document (as from YAML) with 1-6 tendons on 4-25 disks."""
    doc = copy.deepcopy(BASE)
    doc["design"] = name
    length = float(rng.choice([180, 220, 270, 320]))
    count = int(rng.integers(4, int(length // 22.5) + 2))   # ≥ 22.5 mm apart, as the prototype: room for the hubs
    doc["backbone"]["length"] = length
    doc["disks"]["count"] = count
    doc["disks"]["spacing"] = length / (count - 1)
    r_max = doc["disks"]["outer_diameter"] / 2 - 6
    tendons = []
    n = int(rng.integers(1, 7))
    pair = rng.random() < 0.5 and n >= 2
    for i in range(n - (1 if pair else 0)):
        f = _function(rng, r_max)
        while abs(_at(f, 0.0, length)[1]) < 8:     # a tendon starting in the strip's slot has no seat there
            f = _function(rng, r_max)
        tendons.append({"name": f"T{i}", "channel": f"K{i}", "routing": {"function": f}})
    if pair:          # an actuating pair on one channel, mirrored through the strip plane
        tendons[0] = {"name": "A1", "channel": "K0",
                      "routing": {"function": {"kind": "straight", "z0": round(float(rng.uniform(15, r_max)), 1)},
                                  "mirror": True, "mirror_name": "A2"}}
    doc["tendons"] = tendons
    # a designer whose tendon leaves the tip in the strip's plane ends the strip inside the tip
    # disk: nothing to clamp there, and nothing in the tendon's way
    if any(abs(_at(t["routing"]["function"], length, length)[1]) < 8 for t in tendons):
        doc["backbone"]["extra_tip"] = 2
    doc["tensioner"]["channels"] = sorted({t["channel"] for t in tendons})
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
