"""The paper's central claim in the sim: the stiffening tendons locked do not take away the range
of motion. The actuating pair driven (robot.xml's drive: one hauled in as the other pays out,
:mod:`hwgen.sim.mjcf`) by what eq. (2) says bends the robot to the design's sweep angle
(``check.max_angle_deg``) toward +z, against gravity, from two keyframes: the actuating channel
alone (the stiffening tendons slack: unlocked) and every channel (locked). Per case the tip's
angle before and after, and each locked tendon's tension before and after; beside them, the
check's bending sweep (report.json's ``tension``: weightless, the inner tendon hauled in, the
other held at its working tension, the stiffening tendons locked at theirs).

The drive is brought in over :data:`DRIVE_STEPS` equal steps, each an equilibrium by Newton's
method on MuJoCo's forces (:func:`hwgen.sim.measure.settle`) from the last.
"""
from __future__ import annotations

import math

import numpy as np

from ..checks.studies import TensionStudy
from ..model import kinematics
from . import measure, mjcf

DRIVE_STEPS = 6


def haul_for(plan, tendon: str, angle_deg: float) -> float:
    """How far eq. (2) says ``tendon`` shortens when the robot bends ``angle_deg`` toward +z, mm."""
    path = next(p for p in plan.paths if p.name == tendon)
    kappa = kinematics.kappas_for_angles([0.0, angle_deg], plan.backbone.length)
    lengths = kinematics.tendon_lengths(plan.stations, path.points, kappa)
    return float(lengths[0] - lengths[1])


def tip_angle_deg(sim: measure.Sim) -> float:
    """The tip's tangent (the tip disk's y axis) from +y toward +z, degrees."""
    R = sim.data.site_xmat[sim.tip].reshape(3, 3)
    return math.degrees(math.atan2(R[2, 1], R[1, 1]))


def _case(sim: measure.Sim, state: str, q: np.ndarray, drive: int, ctrl: float, tensions) -> dict:
    """From keyframe ``state`` at rest at ``q``, the drive (actuator ``drive``) brought to ``ctrl`` m."""
    sim.keyframe(state)
    q, _, _ = measure.settle(sim, q)
    start, before = tip_angle_deg(sim), tensions(sim)
    its = 0
    for k in range(1, DRIVE_STEPS + 1):
        sim.data.ctrl[drive] = ctrl * k / DRIVE_STEPS
        q, n, left = measure.settle(sim, q)
        its += n
    out = {"start_deg": start, "angle_deg": tip_angle_deg(sim), "tip_mm": measure.tip_mm(sim),
           "tensions_before_n": before, "tensions_n": tensions(sim), "newton": {"iterations": its, "residual": left}}
    sim.keyframe(state)
    return out


def driven(sim: measure.Sim, written: mjcf.Written, plan, lift: str, cases: dict, tensions) -> dict:
    """sim.json's ``driven`` (see the module's docstring); ``lift``: the actuating tendon that bends
    the robot toward +z; ``cases``: "locked" and "unlocked" -> (the state with every channel, and
    with the actuating channel alone; its keyframe's equilibrium); ``tensions(sim)``: every
    tendon's tension now, N."""
    d = next((d for d in written.drums if d.drive and lift in d.tendons), None)
    if d is None:
        return {}
    angle = plan.check.max_angle_deg
    haul = haul_for(plan, lift, angle)
    sign = 1.0 if d.tendons[0] == lift else -1.0
    drive = sim.model.actuator(f"{d.channel}_drive").id
    locked, unlocked = cases["locked"][0], cases["unlocked"][0]
    cases = {key: _case(sim, state, q, drive, sign * haul * measure.MM, tensions) for key, (state, q) in cases.items()}
    stiff = [t for t in cases["locked"]["tensions_n"] if t not in d.tendons
             and cases["locked"]["tensions_before_n"].get(t, 0.0) > 0.0]
    lo, un = cases["locked"], cases["unlocked"]
    return {"drive": f"{d.channel}_drive", "tendon": lift, "state_locked": locked, "state_unlocked": unlocked,
            "target_deg": angle, "haul_mm": haul,
            "locked_angle_deg": lo["angle_deg"], "unlocked_angle_deg": un["angle_deg"],
            "locked_start_deg": lo["start_deg"], "unlocked_start_deg": un["start_deg"],
            "locked_tension_change_n": {t: lo["tensions_n"][t] - lo["tensions_before_n"][t] for t in stiff},
            "actuating_tension_n": {"locked": lo["tensions_n"][lift], "unlocked": un["tensions_n"][lift]},
            "cases": cases}


def against_sweep(result: dict, tension: TensionStudy) -> dict:
    """The check's bending sweep beside ``result`` (:func:`driven`): on the side the same tendon is
    hauled in, each stiffening tendon's tension change from straight to the sweep's end, and the
    actuating tendon's rise with them locked (``actuation.coupling``)."""
    side = tension.side_hauling(result.get("tendon"))
    if side is None:
        return {}
    change = {t: float(v[-1] - v[0]) for t, v in side.tensions_n.items() if t in result["locked_tension_change_n"]}
    return {"side": side.side, "reached_deg": side.reached_deg, "tension_change_n": change,
            "coupling_rise": side.rise, "with_stiffening_n": side.with_stiffening_n, "without_n": side.without_n,
            "words": "hwgen check's sweep: weightless, the inner tendon hauled in, the other actuating tendons at their "
                     "working tension, the stiffening tendons locked at theirs (report.json's tension section); the "
                     "sim's: under gravity, from the keyframes, the pair driven against each other"}
