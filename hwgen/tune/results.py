"""What a tune can maximise, minimise or bound: the results of the statics and of the checks, by name.

Statics (:func:`hwgen.model.stiffness.study`, the physics of ``hwgen stiffness``: the robot
horizontal under its own weight, the tendons of the state locked at their pre-tensions), of the
goal's ``state`` or of the one named after ``@`` (``tip_stiffness@A``):

- ``tip_stiffness``: N/mm, a small push at the tip disk along gravity;
- ``least_stiffness``: N/mm, the least of those pushes over the disks;
- ``tip_torsion``: N·mm/rad, torque over twist at the tip;
- ``tip_sag``: mm, the tip's drop under the robot's weight.

Checks (the sweep's row of the level, :mod:`hwgen.sweep.levels`): ``centre_mm`` (the worst
budgeted tendon's length change by eq. (2) through the hole centres), ``taut_mm`` (its nominal taut
path), ``robust_mm`` (as built, robust level and above), ``clearance_mm`` (the least wall around an
eyelet), ``mass_g`` (disks and strip), ``coupling`` (the actuating tension's rise, a share) and
``least_tension_n`` (the least stiffening tension as built; coupling level and above),
``checks_failed`` (build level). One tendon's: ``centre_mm.C1``, ``taut_mm.C1``, ``robust_mm.C1``.

``distance``: the trial's distance from the base (:func:`hwgen.tune.spec.distance`).

:func:`state_figures` is the one place that reads a state's result of the statics.
"""
from __future__ import annotations

import json
import re

from ..model import stiffness as sf

STATICS = {"tip_stiffness": "N/mm", "least_stiffness": "N/mm", "tip_torsion": "N·mm/rad", "tip_sag": "mm"}
ROW = {"centre_mm": ("mm", "lengths"), "taut_mm": ("mm", "lengths"), "robust_mm": ("mm", "robust"),
       "clearance_mm": ("mm", "lengths"), "mass_g": ("g", "lengths"), "coupling": ("share", "coupling"),
       "least_tension_n": ("N", "coupling"), "checks_failed": ("checks", "build")}
PER_TENDON = {"centre_mm": "lengths", "taut_mm": "lengths", "robust_mm": "robust"}
LEVELS = ("lengths", "robust", "coupling", "build")
CHECK_ID = re.compile(r"[a-z_]+(\.[a-z_]+)+")


def state_figures(result: dict) -> dict[str, float]:
    """The figures a tune reads from one state's result of :func:`hwgen.model.stiffness.study`."""
    return {"tip_stiffness": float(result["tip_stiffness_n_per_mm"]),
            "least_stiffness": float(min(d["stiffness_n_per_mm"] for d in result["disks"])),
            "tip_torsion": float(result["tip_torsion_nmm_per_rad"]),
            "tip_sag": float(result["tip_sag_mm"])}


def statics(plan, states: tuple[str, ...]) -> dict[str, float]:
    """Every statics figure of the named states of a plan, keyed ``name@state`` (the worker's hook:
    ``options["with_plan"]`` of :func:`hwgen.sweep.levels.evaluate_batch`)."""
    if not states:
        return {}
    report = sf.study(plan, list(states))
    return {"statics": {f"{k}@{r['state']}": v for r in report["states"] for k, v in state_figures(r).items()}}


def is_statics(name: str) -> bool:
    return name.partition("@")[0] in STATICS


def check_name(name: str, level: str, states: tuple[str, ...]) -> tuple[str | None, str | None]:
    """(why the name is no result this tune's level gives, or None; the state it names, or None)."""
    head, at, state = name.partition("@")
    if head in STATICS:
        if at and state not in states:
            return f"{state!r} is not a tendon state of the base: {', '.join(states)}", None
        return None, (state or None)
    if at:
        return f"only the statics' results ({', '.join(STATICS)}) are of a tendon state", None
    if name == "distance":
        return None, None
    stem, dot, tendon = name.partition(".")
    if dot:
        if stem not in PER_TENDON:
            return f"a tendon's figure is one of {', '.join(PER_TENDON)} then .NAME", None
        need = PER_TENDON[stem]
    elif name in ROW:
        need = ROW[name][1]
    else:
        known = [*STATICS, *ROW, *(f"{k}.TENDON" for k in PER_TENDON), "distance"]
        return f"{name!r} is not a result a tune knows: {', '.join(known)}", None
    if LEVELS.index(need) > LEVELS.index(level):
        return f"{name!r} is computed from the {need} level on; this tune's level is {level}", None
    return None, None


def value(name: str, row: dict, state: str) -> float | None:
    """The named result of an evaluated row (None where the row does not have it: bad input, an
    error, or a tendon the design does not have); statics of ``state`` unless the name says."""
    head, at, named = name.partition("@")
    if head in STATICS:
        return (row.get("statics") or {}).get(f"{head}@{named if at else state}")
    if name == "distance":
        return row.get("distance")
    stem, dot, tendon = name.partition(".")
    if dot:
        for t in json.loads(row.get("per_tendon") or "[]"):
            if t["name"] == tendon:
                return t.get(stem)
        return None
    v = row.get(name)
    return None if v is None else float(v)
