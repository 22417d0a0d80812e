"""What the simulation is checked against: hwgen's own statics (:mod:`hwgen.model.stiffness`),
reached through one function, :func:`statics_reference`.

Everything the sim takes from the statics' tendon states passes through here: each state's
locked rest lengths (which set the drums in its keyframe), the tensions it settles at, its tip
stiffness and sag, and the bent shape at a given actuating tension. The states are the statics'
own, as ``hwgen build`` writes them into stiffness.json (:func:`hwgen.model.stiffness.study`):
each tensioned by the paper's protocol (:mod:`hwgen.model.protocol`) with the robot horizontal,
its flexible direction along gravity, gravity toward −z (:data:`ORIENTATION`, the paper's and
the MuJoCo model's world), frictionless eyelets (:data:`FRICTION`), a small push at the tip
along z. :func:`study_of` takes them from the build's stiffness.json when it holds them (every
state in that orientation, from the same weights), else from the statics solved again. The bent
case is the actuating tendon that lifts the robot (:func:`hwgen.model.bending.inner_tendons`)
pulled with the most a tendon may carry, every other tendon slack, under gravity.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..cache import as_json
from ..model import bending
from ..model import statics as st
from ..model import stiffness
from ..model.gravity import Gravity

ORIENTATION = "gravity -z"        # the statics' REFERENCE orientation, and robot.xml's gravity (−z)
FRICTION = "none"                 # eyelets without friction, the statics' frictionless bound
STUDY_FILE = "stiffness.json"     # the build's statics, beside report.json


def orientation() -> dict:
    """sim.json's account of the orientation compared in."""
    return {"name": ORIENTATION, "gravity": list(stiffness.ORIENTATIONS[ORIENTATION]), "push": list(stiffness.PUSH),
            "words": "robot horizontal, its flexible direction (z) along gravity, gravity toward −z (C1's base eyelet "
                     "up: the statics' reference orientation, taken as the paper's); pushed along z"}


@dataclass(frozen=True)
class Reference:
    """The statics of one design, as the sim reads it (lengths mm, forces N)."""

    described: stiffness.Described          # the statics' robot: sections, spans, tendon springs, weights
    straight_mm: dict                       # tendon -> eq. (2) length through the plan's eyelets, robot straight
    locks: dict                             # state -> {tendon: locked rest length, mm} (its locked tendons only)
    states: list                            # the compared states: {state, tip stiffness, sag, tip, tensions, curve}
    bent: dict                              # the bent case: {tendon, tension_n, tip_mm, curve}
    all_tendons: str                        # the name of the state that locks every channel
    source: str                             # where the states came from, in words


def _curve(eq: st.Equilibrium) -> dict:
    return {"s_mm": eq.s.tolist(), "y_mm": eq.p[:, 1].tolist(), "z_mm": eq.p[:, 2].tolist(),
            "x_mm": eq.p[:, 0].tolist()}


def _entries(study: dict) -> dict:
    """state -> the study's entry for it in :data:`ORIENTATION`, frictionless."""
    return stiffness.entries_by_state(study, ORIENTATION, FRICTION)


def unusable(study, plan, desc: stiffness.Described) -> str | None:
    """Why ``study`` (a stiffness.json's content) cannot be the reference for ``plan`` described as
    ``desc`` (None: it can): it must hold every state in :data:`ORIENTATION`, frictionless, with
    each locked tendon's lock, its tip stiffness and its curve, from the same weights and springs."""
    if not isinstance(study, dict) or "skipped" in study:
        return "it holds no statics" + (f" ({study['skipped']})" if isinstance(study, dict) else "")
    entries = _entries(study)
    for s in stiffness.states(plan):
        e = entries.get(s.name)
        locked = [t.name for t in desc.robot.tendons if t.channel in s.channels]
        if e is None or not {"tip_stiffness_n_per_mm", "tensions_n", "curve"} <= set(e) \
                or set(e.get("locks_mm", {})) != set(locked):
            return f"it has no {ORIENTATION} frictionless entry with its locks for state {s.name}"
    if study.get("masses") != as_json(desc.masses):
        return "its weights are not this build's"
    springs = {t["name"]: t["spring_n_per_mm"] for t in study.get("tendons", [])}
    if springs != {t.name: float(t.stiffness) for t in desc.robot.tendons}:
        return "its tendons' springs are not this plan's"
    return None


def study_of(folder: Path, plan, measured: Gravity | None, solve) -> tuple[dict, str]:
    """The statics to compare with: the build's stiffness.json in ``folder`` when it holds what
    :func:`unusable` asks, else ``solve()`` (the statics of ``plan`` with the weights
    ``measured``). Returns (the study, where it came from in words)."""
    desc = stiffness.describe(plan, measured)
    try:
        study = json.loads((Path(folder) / STUDY_FILE).read_text(encoding="utf-8"))
        why = unusable(study, plan, desc)
    except (OSError, ValueError) as e:
        why = f"it cannot be read ({type(e).__name__})"
    if why is None:
        return study, f"the build's {STUDY_FILE}"
    return solve(), f"the statics solved again ({STUDY_FILE}: {why})"


def _result(desc: stiffness.Described, e: dict) -> dict:
    c = e["curve"]
    tip = [float(c["x_mm"][-1]), float(c["y_mm"][-1]), float(c["z_mm"][-1])]
    if not math.isclose(c["s_mm"][-1], desc.robot.length, abs_tol=1e-6):
        raise ValueError(f"state {e['state']}: the statics' curve ends at s = {c['s_mm'][-1]} mm, not at the tip")
    return {"state": e["state"], "tip_stiffness_n_per_mm": float(e["tip_stiffness_n_per_mm"]),
            "tip_sag_mm": -tip[2], "tip_mm": tip, "tensions_n": dict(e["tensions_n"]), "curve": c}


def statics_reference(plan, measured: Gravity | None, study: dict, compare: list[str] | None = None,
                      bend_tension_n: float | None = None, source: str = "") -> Reference:
    """The statics of ``plan`` (weights ``measured`` as ``hwgen stiffness`` takes them: the check
    report's gravity section, else None for the plan's estimate) read from ``study`` (what
    :func:`hwgen.model.stiffness.study` returns, at least :data:`ORIENTATION`): every state's
    locks, the ``compare`` states (default N, the actuating channel alone and the state with
    every channel), and the bent case: the actuating tendon that lifts the robot against gravity
    pulled with ``bend_tension_n`` (default: the most a tendon may carry, the protocol's
    ceiling), tension-controlled, every other tendon slack, under gravity."""
    desc = stiffness.describe(plan, measured)
    why = unusable(study, plan, desc)
    if why is not None:
        raise ValueError(f"the statics given cannot be the sim's reference: {why}")
    entries = _entries(study)
    every = stiffness.states(plan)
    full = max(every, key=lambda s: len(s.channels)).name
    names = compare or list(dict.fromkeys([s.name for s in every[:2]] + [full]))
    locks = {s.name: {n: float(v) for n, v in entries[s.name]["locks_mm"].items()} for s in every}
    compared = [_result(desc, entries[n]) for n in names]
    model = st.Model(desc.robot, stiffness.STUDY_H_MAX)
    gravity = stiffness.ORIENTATIONS[ORIENTATION]
    lift = 1 if gravity[2] < 0 else -1                   # bending toward −gravity lifts the robot
    inner = bending.inner_tendons(desc, model)[lift][0]
    bent = {}
    if inner is not None:
        pull = desc.rules.allowable_n if bend_tension_n is None else bend_tension_n
        eq = st.solve(model, st.Loads(tendons={inner: ("tension", pull)}, gravity=gravity))
        tip = eq.at(desc.robot.length)
        bent = {"tendon": inner, "tension_n": pull, "tip_mm": [float(v) for v in tip],
                "tip_angle_deg": math.degrees(eq.tip_angle()), "curve": _curve(eq)}
    return Reference(desc, st.straight_lengths(model), locks, compared, bent, full, source)


def haul_in(ref: Reference) -> dict:
    """state -> {tendon: how far its drum hauled it in from just taut in the straight robot, mm}:
    ℓ_straight − ℓ₀ for each locked tendon (positive: stretched when straight)."""
    return {name: {t: ref.straight_mm[t] - l0 for t, l0 in lk.items()} for name, lk in ref.locks.items()}


def tendon_springs(ref: Reference) -> dict:
    """tendon -> its locked spring, N/mm (the statics' own: free length over EA in series with the tie-off)."""
    return {t.name: float(t.stiffness) for t in ref.described.robot.tendons}


def downsample(curve: dict, n: int = 150) -> dict:
    """A curve's lists cut to about ``n`` points (its ends kept), for sim.json."""
    m = len(curve["s_mm"])
    idx = np.unique(np.r_[np.linspace(0, m - 1, min(n, m)).round().astype(int), m - 1])
    return {k: [v[i] for i in idx] for k, v in curve.items()}
