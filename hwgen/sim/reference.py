"""What the simulation is checked against: hwgen's own statics (:mod:`hwgen.model.stiffness`),
reached through one function, :func:`statics_reference`.

Everything the sim takes from the statics' tendon states passes through here: each state's
locked rest lengths (which set the drums in its keyframe), the tensions it settles at, its tip
stiffness and sag, and the bent shape at a given actuating tension. The protocol is the
statics' own (``hwgen stiffness``): each locked tendon locked where it carries its
``pretension_n`` in the weightless robot; the robot horizontal, its flexible direction along
gravity; frictionless eyelets; a small push at the tip along gravity. When the statics' states
change (their pre-tensions, orientation or friction bounds), this is the one function to
reconnect.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import statics as st
from ..model import stiffness

ORIENTATION = {"gravity": list(stiffness.GRAVITY), "push": list(stiffness.PUSH),
               "words": "robot horizontal, its flexible direction (z) along gravity, pushed along gravity "
                        "(the statics' default)"}
FRICTION = "none"                 # eyelets without friction, as the statics takes them


@dataclass(frozen=True)
class Reference:
    """The statics of one design, as the sim reads it (lengths mm, forces N)."""

    described: stiffness.Described          # the statics' robot: sections, spans, tendon springs, weights
    straight_mm: dict                       # tendon -> eq. (2) length through the plan's eyelets, robot straight
    locks: dict                             # state -> {tendon: locked rest length, mm} (its locked tendons only)
    states: list                            # the compared states: {state, tip stiffness, sag, tip, tensions, curve}
    bent: dict                              # the bent case: {tendon, tension_n, tip_mm, curve}
    all_tendons: str                        # the name of the state that locks every channel


def _curve(eq: st.Equilibrium) -> dict:
    return {"s_mm": eq.s.tolist(), "y_mm": eq.p[:, 1].tolist(), "z_mm": eq.p[:, 2].tolist(),
            "x_mm": eq.p[:, 0].tolist()}


def _result(desc: stiffness.Described, eq: st.Equilibrium, name: str) -> dict:
    L = desc.robot.length
    tip = eq.at(L)
    k = eq.point_stiffness(L, stiffness.PUSH)
    return {"state": name, "tip_stiffness_n_per_mm": float(k), "tip_sag_mm": float(-tip[2]),
            "tip_mm": [float(v) for v in tip], "tensions_n": dict(eq.tensions), "curve": _curve(eq)}


def statics_reference(plan, measured: dict | None, compare: list[str] | None, bend_tension_n: float) -> Reference:
    """The statics of ``plan`` (weights ``measured`` as ``hwgen stiffness`` takes them: the check
    report's gravity section, else None for the plan's estimate): every state's locks, the
    ``compare`` states solved in full (default N, the actuating channel alone and the state with
    every channel), and the bent case: the actuating tendon that lifts the robot against gravity
    pulled with ``bend_tension_n`` (tension-controlled), every other tendon slack, under gravity."""
    desc = stiffness.describe(plan, measured)
    model = st.Model(desc.robot)
    every = stiffness.states(plan)
    full = max(every, key=lambda s: len(s.channels)).name
    names = compare or [s.name for s in every[:2]] + ([full] if full not in [s.name for s in every[:2]] else [])
    locks, out = {}, []
    for s in every:
        if s.name in names:
            res, eq = stiffness.state_result(desc, model, s)
            out.append(_result(desc, eq, s.name))
            locks[s.name] = {n: float(v[1]) for n, v in eq.loads.tendons.items()}
        else:
            loads, _ = stiffness.state_loads(desc, model, s)
            locks[s.name] = {n: float(v[1]) for n, v in loads.tendons.items()}
    inner = stiffness.inner_tendons(desc, model)[int(math.copysign(1, -stiffness.GRAVITY[2]))][0]
    bent = {}
    if inner is not None:
        eq = st.solve(model, st.Loads(tendons={inner: ("tension", bend_tension_n)}, gravity=stiffness.GRAVITY))
        tip = eq.at(desc.robot.length)
        bent = {"tendon": inner, "tension_n": bend_tension_n, "tip_mm": [float(v) for v in tip],
                "tip_angle_deg": math.degrees(eq.tip_angle()), "curve": _curve(eq)}
    return Reference(desc, st.straight_lengths(model), locks, out, bent, full)


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
