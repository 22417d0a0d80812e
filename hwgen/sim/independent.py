"""The independent reference: the robot of a build as a Cosserat rod (:mod:`hwgen.sim.cosserat`),
built from the files as the checks measured them, and where its tip comes to rest in the cases
sim.json's ``reference`` holds: state N under its own weight, and the actuating tendon that lifts
the robot pulled with a tension (the sim's bent case), under its own weight.

Why a second model: MuJoCo's hinges are sprung from the statics' own compliances, so the two agree
by construction. This rod shares neither: the strong-form Cosserat equations with shear and
extension against the statics' discrete Kirchhoff rod and energy minimisation; the hubs' bending
stiffness from their sections cut from the disks' STLs (the check report's gravity spans) against
the statics' sections from the plan; every disk's weight at its STL's centre of mass, off the
centre line where it is, against the statics' point weights on it; the tendon as the forces its
tension puts on the measured eyelets, recomputed from the deformed geometry.

Why not PyElastica (the issue's first choice): it integrates the rod explicitly in time, and on
this strip (60 × 0.59 mm, E 50 GPa, 60 elements) its PositionVerlet step was unstable at 20 µs and
1 µs and, with a damper near critical, at 0.5 µs; stable undamped at 0.2-0.5 µs it ran about
20 000-29 000 steps per CPU second here, so a static answer (a damped run to rest of a robot whose
first mode is 1.4 Hz: seconds of simulated time) costs minutes per case, before the disks and a
tendon recomputed every step. The boundary-value rod answers each case in about a second.

The rod (lengths mm): clamped at the end of the base disk's plate (the base disk is the clamp's);
the strip's section and weight per length from the report (its STL), E and G the design's
(``backbone.modulus_gpa``, ``shear_modulus_gpa``: the files cannot say), K_bt = (E·h·t³/12, G·J,
E·t·h³/12) with J = h·t³/3 (1 − 0.63 t/h), K_se = (κGA, EA, κGA), κ = 5/6; each disk's plate rigid
over its measured span carrying the disk's weight at its centre of mass and its eyelets where
they were measured; each hub's span of the strip stiffer in bending about x by the measured hub
(the report's gravity spans), in twist and sideways the strip's own (the two cases bend the
robot in its plane; only the tensioner's few millimetres across the strip twist it); the tip
disk's plate, the tensioner's parts, their bought metal and the strip they clamp one rigid body.
"""
from __future__ import annotations

import time

import numpy as np

from ..model.gravity import Gravity
from . import cosserat as co
from . import limits
from .parts import Printed, tip_masses

SHEAR_COEFFICIENT = 5.0 / 6.0     # Timoshenko's κ of a rectangle
GRAVITY = (0.0, 0.0, -1.0)        # robot.xml's world


def _sections(g: Gravity, shear_modulus_mpa: float) -> tuple[tuple, tuple, float]:
    """(K_bt, K_se, g/mm) of the bare strip from the report's gravity section."""
    E, h, t = g.E_mpa, g.height_mm, g.thickness_mm
    G, A = shear_modulus_mpa, h * t
    J = h * t ** 3 / 3 * (1 - 0.63 * t / h)
    return ((E * h * t ** 3 / 12, G * J, E * t * h ** 3 / 12),
            (SHEAR_COEFFICIENT * G * A, E * A, SHEAR_COEFFICIENT * G * A), g.strip.lambda_g_mm)


def _plate(printed: Printed, a: float, b: float, lam: float, extra=()) -> co.Rigid:
    """A disk's plate [a, b] (the disk whose station lies in it) with its weight and eyelets."""
    station = min(printed.stations_mm, key=lambda k: abs(printed.stations_mm[k] - (a + b) / 2))
    origin = np.array([0.0, a, 0.0])
    disk = printed.disks[station]
    masses = [(disk.mass_g, tuple(disk.com_mm - origin)), (lam * (b - a), (0.0, (b - a) / 2, 0.0)), *extra]
    eyelets = {t: tuple(e.centre_mm - origin) for e in printed.eyelets if e.station == station for t in e.tendons}
    return co.Rigid(a, b, tuple(masses), eyelets)


def robot_rod(printed: Printed, g: Gravity, shear_modulus_mpa: float) -> tuple[co.Rod, int, tuple]:
    """The rod of a build (see the module's docstring): (the rod, the tip body's piece, the tip
    site's point in that piece's frame); ``g``: the check report's gravity section."""
    L = g.length_mm
    bending, shear, lam = _sections(g, shear_modulus_mpa)
    spans = sorted((s.start_mm, s.end_mm, s.ei_nmm2) for s in g.spans)
    y_end = float(printed.strip["y_mm"][1])
    tip_station = max(printed.disks)
    start = spans[0][1] if spans and spans[0][2] is None and spans[0][0] <= 0.0 else 0.0
    pieces, at = [], start
    for a, b, ei in spans:
        if b <= start + 1e-9:
            continue
        if a > at + 1e-9:
            pieces.append(co.Flexible(at, a, bending, shear, lam))
        if ei is not None:
            pieces.append(co.Flexible(a, b, (float(ei), *bending[1:]), shear, lam))
        elif b >= L - 1e-9:
            origin = np.array([0.0, a, 0.0])
            tip = [(m, tuple(np.asarray(c) - origin)) for m, c, _ in tip_masses(printed)]
            tip.append((lam * (y_end - L), (0.0, (L + y_end) / 2 - a, 0.0)))
            pieces.append(_plate(printed, a, L, lam, tip))
        else:
            pieces.append(_plate(printed, a, b, lam))
        at = b
    base = {t: [tuple(e.centre_mm)] for e in printed.eyelets if e.station == 0 for t in e.tendons}
    tip_local = (0.0, printed.stations_mm[tip_station] - pieces[-1].start, 0.0)
    return co.Rod(tuple(pieces), base), len(pieces) - 1, tip_local


def _case(rod: co.Rod, tip: tuple, loads: co.Loads) -> dict:
    t0 = time.perf_counter()
    sol = co.solve(rod, loads)
    k, local = tip
    curve = {"y_mm": sol.p[:, 1].tolist(), "z_mm": sol.p[:, 2].tolist(), "x_mm": sol.p[:, 0].tolist()}
    return {"tip_mm": [float(v) for v in sol.point(k, local)], "iterations": sol.iterations,
            "residual": sol.residual, "seconds": time.perf_counter() - t0, "curve": curve}


def reference(printed: Printed, gravity: Gravity, shear_modulus_mpa: float, mujoco: dict,
              pulled: tuple[str, float] | None) -> dict:
    """sim.json's ``reference``: the rod's tip against MuJoCo's (``mujoco``: case -> tip, mm) in state
    N and with ``pulled`` = (tendon, N) pulled, both under gravity."""
    rod, k, local = robot_rod(printed, gravity, shear_modulus_mpa)
    L = gravity.length_mm
    cases = {"N": co.Loads(gravity=GRAVITY)}
    if pulled is not None:
        cases[f"{pulled[0]}_pulled"] = co.Loads(gravity=GRAVITY, tensions={pulled[0]: pulled[1]})
    out = {"model": "Cosserat rod (Rucker & Webster 2011) with shear and extension, tendons as the forces their "
                    "tension puts on the measured eyelets, solved as a boundary-value problem by shooting "
                    "(hwgen.sim.cosserat); built from the files (hwgen.sim.independent)",
           "length_mm": L, "limit_share_of_length": limits.REFERENCE}
    for key, loads in cases.items():
        got = _case(rod, (k, local), loads)
        mj = mujoco[key]
        dist = float(np.linalg.norm(np.subtract(mj, got["tip_mm"])))
        out[key] = {"mujoco_tip_mm": list(mj), "cosserat_tip_mm": got["tip_mm"], "distance_mm": dist,
                    "share_of_length": dist / L, "within": dist <= limits.REFERENCE * L,
                    "solver": {k_: got[k_] for k_ in ("iterations", "residual", "seconds")}, "curve": got["curve"]}
        if key != "N":
            out[key].update(tendon=pulled[0], tension_n=pulled[1])
    out["within"] = all(v["within"] for v in out.values() if isinstance(v, dict) and "within" in v)
    return out
