"""How the tendons' tensions swing when the actuating pair bends the robot: the statics behind
`hwgen check`'s verdict in newtons (:mod:`hwgen.checks.tension`; numpy and scipy only).

The robot is weightless here, bent from straight to ±max angle by hauling in the actuating tendon
on the inside of the bend (its drum turning), the other actuating tendons held by the drive at
their working tension, the stiffening tendons locked where each carries its working tension in
the weightless robot those tensions settle (tensioned on the bench), or slack. A working tension
is the tendon's ``pretension_n`` where the design gives one, else ``check.working_tension_n``:
the paper's tensioning protocol (:mod:`hwgen.model.protocol`) sets tensions for the straight
robot under its own weight (C1 carries most of it), which a weightless sweep cannot use.
"""
from __future__ import annotations

import math
import numpy as np

from . import statics as st

SWEEP_H_MAX = 3.0          # mm: the sweep's rod segments (tensions agree with 1.5 mm to 4 digits, for far fewer coordinates)
SWEEP_FIRST_DEG = 5.0      # the first haul-in aims at this angle; later ones a sweep step further
SWEEP_MAX_SOLVES = 24      # per side: a drive that stops bending the robot is not chased further
PROBE_N = 1e-3             # N at the tip: the push that tells which actuating tendon shortens which way


def _inner(robot: st.Robot, actuating, model: st.Model, sign: int) -> tuple[str | None, float]:
    """The actuating tendon that shortens most when the robot bends toward sign·z, and how many mm
    it shortens per degree there; (None, 0) if none shortens."""
    eq = st.solve(model, st.Loads(forces=((robot.length, (0.0, 0.0, sign * PROBE_N)),)))
    base = st.straight_lengths(model)
    turn = abs(math.degrees(eq.tip_angle()))
    if not actuating or turn == 0.0:
        return None, 0.0
    name = min(actuating, key=lambda n: eq.lengths[n] - base[n])
    per_deg = (base[name] - eq.lengths[name]) / turn
    return (name, per_deg) if per_deg > 1e-6 else (None, 0.0)


def inner_tendons(desc, model: st.Model) -> dict:
    """:func:`_inner` of either side (sign +1, -1): what a sweep hauls in there, whichever tendons it
    locks (a probe of the weightless robot alone: the sweeps with and without the stiffening
    tendons share it). ``desc``: :class:`hwgen.model.stiffness.Described`."""
    return {sign: _inner(desc.robot, desc.actuating, model, sign) for sign in (1, -1)}


def sweep(desc, model: st.Model, tensions: dict, max_deg: float, step_deg: float, locked: bool = True,
          inner_of: dict | None = None) -> dict:
    """Bend the weightless robot from straight to ±max_deg by hauling in the actuating tendon on the
    inside of the bend (displacement-controlled, its drum turning), the other actuating tendons
    held at their working tension (``tensions``, N per tendon) by the drive, the stiffening
    tendons locked where each carries its working tension in the weightless robot those tensions
    settle (``locked``) or slack. At each angle of the sweep: every tendon's tension, N.

    Each side is a continuation: each haul-in aims a step further by the last step's angle per
    millimetre, each solve starting from the last; the tensions are then interpolated (linearly)
    at the sweep's angles. A side no actuating tendon bends, or where hauling in stops bending the
    robot, ends where it got to (``reached_deg``). ``inner_of``: :func:`inner_tendons` of this robot,
    if already at hand."""
    stiff = [n for n in desc.stiffening if locked]
    angles = np.arange(0.0, max_deg + 1e-9, step_deg)
    if angles[-1] < max_deg - 1e-9:
        angles = np.r_[angles, max_deg]
    out = {}
    for sign in (1, -1):
        key = "+" if sign > 0 else "-"
        inner, per_deg = inner_of[sign] if inner_of else _inner(desc.robot, desc.actuating, model, sign)
        if inner is None:
            out[key] = {"inner": None, "angles_deg": [], "tensions_n": {}, "reached_deg": 0.0, "solves": 0}
            continue
        others = [n for n in desc.actuating if n != inner]
        base = {n: ("tension", tensions[n]) for n in others}
        held, eq = st.locked_settled(model, {n: tensions[n] for n in [inner, *stiff]}, st.Loads(tendons=base))
        ell0 = held[inner][1]
        start = sign * math.degrees(eq.tip_angle())
        rows = [(start, dict(eq.tensions))]
        q, delta, ang, per_mm = eq.q, 0.0, start, 1.0 / per_deg
        while len(rows) < SWEEP_MAX_SOLVES and ang < max_deg - 1e-6:
            target = min(max_deg, ang + (SWEEP_FIRST_DEG if len(rows) == 1 else step_deg))
            step = (target - ang) / per_mm * (1.02 if target >= max_deg else 1.0)
            eq = st.solve(model, st.Loads(tendons={**held, **base, inner: ("locked", ell0 - delta - step)}), q)
            new = sign * math.degrees(eq.tip_angle())
            if new <= ang + 1e-3:
                break                                 # hauling in no longer bends it this way
            per_mm = (new - ang) / step
            q, delta, ang = eq.q, delta + step, new
            rows.append((ang, dict(eq.tensions)))
        a = np.array([r[0] for r in rows])
        inside = angles[(angles > a[0] + 1e-9) & (angles < a[-1] - 1e-9)]
        reach = np.r_[a[0], inside, a[-1]] if len(a) > 1 else a
        table = {n: np.interp(reach, a, [r[1][n] for r in rows]).tolist() for n in rows[0][1]}
        out[key] = {"inner": inner, "angles_deg": (sign * reach).tolist(), "tensions_n": table,
                    "reached_deg": float(a[-1]), "solves": len(rows)}
    return out
