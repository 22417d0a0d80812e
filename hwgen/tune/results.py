"""What a tune can maximise, minimise or bound: the results of the statics and of the checks, by name.

Statics: :func:`hwgen.model.stiffness.study`, the physics of ``hwgen stiffness`` (each tendon state
tensioned by the paper's protocol, a tendon's own ``pretension_n`` instead where the design gives
one; the plan's estimated masses), read through :func:`statics` only, in the goal's
``orientation`` (default ``gravity -z``, the orientation ``hwgen stiffness`` headlines) and
``friction`` bound (default ``none``, frictionless eyelets, its headline too; ``stuck``: every
segment held at its eyelets), of the goal's ``state`` or of the one named after ``@``
(``tip_stiffness@A``):

- ``tip_stiffness``: N/mm, a small push at the tip disk along z;
- ``least_stiffness``: N/mm, the least of those pushes over the disks;
- ``tip_torsion``: N·mm/rad, torque over twist at the tip;
- ``tip_sag``: mm, how far the tip lies off the straight line along z in that state (|z|).

Checks (the sweep's row of the level, :mod:`hwgen.sweep.levels`): ``centre_mm`` (the worst
budgeted tendon's length change by eq. (2) through the hole centres), ``taut_mm`` (its nominal taut
path), ``robust_mm`` (as built, robust level and above), ``clearance_mm`` (the least wall around an
eyelet), ``mass_g`` (disks and strip), ``coupling`` (the actuating tension's rise, a share) and
``least_tension_n`` (the least stiffening tension as built; coupling level and above),
``checks_failed`` (build level). One tendon's: ``centre_mm.C1``, ``taut_mm.C1``, ``robust_mm.C1``.

``distance``: the trial's distance from the base (:func:`hwgen.tune.spec.distance`).
"""
from __future__ import annotations

import json
import re
from dataclasses import replace

from ..checks.purpose import stiffening_checks
from ..errors import nearest
from ..model import stiffness as sf
from ..sweep.records import Failure

STATICS = {"tip_stiffness": "N/mm", "least_stiffness": "N/mm", "tip_torsion": "N·mm/rad", "tip_sag": "mm"}
ROW = {"centre_mm": ("mm", "lengths"), "taut_mm": ("mm", "lengths"), "robust_mm": ("mm", "robust"),
       "clearance_mm": ("mm", "lengths"), "mass_g": ("g", "lengths"), "coupling": ("share", "coupling"),
       "least_tension_n": ("N", "coupling"), "checks_failed": ("checks", "build")}
PER_TENDON = {"centre_mm": "lengths", "taut_mm": "lengths", "robust_mm": "robust"}
LEVELS = ("lengths", "robust", "coupling", "build")
CHECK_ID = re.compile(r"[a-z_]+(\.[a-z_]+)+")


ORIENTATIONS = tuple(sf.ORIENTATIONS)          # gravity -z, gravity +z, weightless
FRICTIONS = ("none", "stuck")                 # the friction bounds every disk's stiffness is given for
ORIENTATION, FRICTION = sf.REFERENCE, "none"  # hwgen stiffness's headline: gravity -z, frictionless


def state_figures(entry: dict) -> dict[str, float]:
    """The figures a tune reads from one entry (a state in one orientation, one friction bound) of
    :func:`hwgen.model.stiffness.study`."""
    return {"tip_stiffness": float(entry["tip_stiffness_n_per_mm"]),
            "least_stiffness": float(min(d["stiffness_n_per_mm"] for d in entry["disks"])),
            "tip_torsion": float(entry["tip_torsion_nmm_per_rad"]),
            "tip_sag": abs(float(entry["tip_z_mm"]))}


def by_state(report: dict, orientation: str = ORIENTATION, friction: str = FRICTION) -> dict[str, dict]:
    """state -> its figures in ``orientation`` with ``friction``, from a study's report (stiffness.json)."""
    return {state: state_figures(e) for state, e in sf.entries_by_state(report, orientation, friction).items()}


def figures(plan, states: tuple[str, ...] | None = None, orientation: str = ORIENTATION,
            friction: str = FRICTION) -> dict[str, dict]:
    """state -> its figures, for the named states (None: every state) of a plan: the one adapter
    from the study ``hwgen stiffness`` runs (:func:`hwgen.model.stiffness.study`, the plan's
    estimated masses) to a tune's figures."""
    report = sf.study(plan, list(states) if states else None, [orientation])
    return by_state(report, orientation, friction)


def statics(plan, states: tuple[str, ...] | None, orientation: str = ORIENTATION, friction: str = FRICTION,
            judge: bool = False) -> dict:
    """Every statics figure of the named states of a plan, keyed ``name@state`` (the worker's hook:
    ``EvalOptions.with_plan`` of :func:`hwgen.sweep.levels.evaluate_batch`), and ``set_n``: state ->
    tendon -> the tension each is set to (the protocol's, or its own ``pretension_n``). ``judge``: also the
    failing checks of what the stiffening tendons are for (``stiffening.tip``, ``stiffening.torsion``:
    :func:`hwgen.checks.purpose.stiffening_checks`, which ``hwgen check`` fails on the build), as the
    row's ``statics_failures``: every tendon locked and the actuating pair alone, in hwgen stiffness's
    reference orientation, are then computed too."""
    if states is not None and not states and not judge:
        return {}
    extra, orientations = [], [orientation]
    if judge:
        every = sf.states(plan)
        extra = [max(every, key=lambda s: len(s.channels)).name, plan.tensioner.actuating_channel]
        orientations += [sf.REFERENCE] if orientation != sf.REFERENCE else []
    which = None if states is None else list(dict.fromkeys([*states, *extra]))
    report = sf.study(plan, which, orientations)
    entries = sf.entries_by_state(report, orientation, friction)
    out = {"statics": {f"{k}@{s}": v for s, e in entries.items() for k, v in state_figures(e).items()},
           "set_n": {s: e["set_n"] for s, e in entries.items()}}
    if judge:
        out["statics_failures"] = [
            replace(Failure.of_check(c, f"{c.id}: {c.message}"), where=None)
            for c in stiffening_checks(plan, report) if not c.passed]
    return out


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
            close = nearest(stem, PER_TENDON)
            meant = f"; did you mean {close}.{tendon}?" if close else ""
            return f"a tendon's figure is one of {', '.join(PER_TENDON)} then .NAME{meant}", None
        need = PER_TENDON[stem]
    elif name in ROW:
        need = ROW[name][1]
    else:
        known = [*STATICS, *ROW, *(f"{k}.TENDON" for k in PER_TENDON), "distance"]
        close = nearest(name, [*STATICS, *ROW, "distance"])
        meant = f"; did you mean {close}?" if close else ""
        return f"{name!r} is not a result a tune knows{meant} (they are {', '.join(known)})", None
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
