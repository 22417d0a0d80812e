"""The robot of a plan described for :mod:`hwgen.model.statics`, and what the statics says of it:
stiffness per tendon state as the paper measured it (its Fig. 8), per orientation of the robot
and between the bounds eyelet friction sets, and the shape under its own weight (Fig. 7)
(numpy and scipy only; everything from the plan, no CAD).

Robot. The strip (E = backbone.modulus_gpa, G = backbone.shear_modulus_gpa, h × t) clamped at the
base disk's mid-plane, tip at the tip disk's. Each disk's plate holds the strip rigid over its
thickness; its glued hub adds the hub's section (E and G of the printed material; a hub cut by a
tendon window is an open section in torsion, an uncut one a closed tube). Masses are estimated
from the plan's numbers, not measured: each disk's plate and hub volumes (holes, slot and windows
taken out) × the printed density, at their centre of mass on the centre line; the tip assembly
is the tip disk's tensioner as the layout sizes it (housing members, each wheel part as its
flange's cylinder, each worm as its pitch cylinder) plus the strip beyond the tip and the bought
metal the tensioner carries (dowels, screws, nuts: :mod:`hwgen.model.steel`, about 17 g on the
prototype), at its centre of mass; the base disk is the clamp's. Tendons are the plan's eyelets (eq. (2)); each one's
spring is its free length (path plus run to the drum) over ``tendon_material.axial_stiffness_n``
in series with ``tendon_material.tie_off_compliance_mm_per_n`` (half at the knot, half at the
drum, for the friction bounds: :mod:`hwgen.model.friction`).

States. A state is the set of channels whose tendons are tensioned and locked (the worm
self-locks); the others are slack. The paper's nine (Fig. 8) are N, the actuating channel alone,
and it with every combination of the stiffening channels, in the paper's order. Each state is
tensioned by the paper's protocol (:mod:`hwgen.model.protocol`) in each orientation: the
actuating pair straight with the strip on edge, at the least tension that keeps it taut once
turned; each further channel at the least tension that holds the backbone (nearly) straightest;
a tendon's ``pretension_n``, where the design gives one, instead.

Orientations (:data:`ORIENTATIONS`). The robot horizontal with its flexible direction (z) along
gravity, gravity toward −z (C1's base eyelet up: the way the paper's protocol can hold the robot
straight with C1, so taken as the paper's, :data:`REFERENCE`) and toward +z (turned over), and
weightless.

Stiffness. A small push at a disk along z, force over displacement there: the tangent stiffness
of the locked state (one-way springs as they are there), between two bounds of eyelet friction,
``none`` (frictionless chords) and ``stuck`` (each segment between eyelets its own spring), and,
when the design gives ``tendon_material.eyelet_friction``, the capstan model between them for a
push of ``check.stiffness_push_n`` at the tip either way (:mod:`hwgen.model.friction`). Torsion:
torque over twist at the tip, about its tangent.

For another model to compare with (a simulation): :func:`study` returns every result as a plain
dict; ``study(plan)["states"]`` holds one entry per state, orientation and friction, each with
``"state"``, ``"orientation"``, ``"gravity"`` (the unit vector in the base frame, or None),
``"friction"`` (and for capstan ``"push"``: "+z" or "-z"), ``"tensions_n"`` (every locked
tendon's tension in that equilibrium, N), ``"locks_mm"`` (each one's rest length ℓ₀) and
``"tip_stiffness_n_per_mm"``; :func:`tip_stiffness` indexes them.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from . import friction as fr
from . import protocol
from . import statics as st
from . import steel
from .gravity import Gravity
from .intervals import interval_difference
from .sag import Span

ORIENTATIONS = {"gravity -z": (0.0, 0.0, -1.0),     # horizontal, flexible direction along gravity (Fig. 7)
                "gravity +z": (0.0, 0.0, 1.0),      # ... turned over
                "weightless": None}
REFERENCE = "gravity -z"          # the orientation the headline ratio and the bending sweep's locks are of
PUSH = (0.0, 0.0, 1.0)            # the push: along z, the flexible direction
PUSH_WORDS = ("a small push at each disk along the robot's z (the flexible direction of the straight robot, fixed "
              "in space as the paper's pusher moved): not normal to a sagged strip's face, which is softer where "
              "the robot sags (at state N's tip about a third softer)")
PAPER_ENDPOINT_RATIO = 4.85       # abstract and Sect. VI: AC1C2H over A at the endpoint
MAX_COMBINED = 4                  # more stiffening channels than this: each alone and all together only
CURVE_POINTS = 120
STUDY_H_MAX = 3.0                 # mm: the study's rod segments (tip stiffness within 1e-4 of 1.5 mm's)
STUDY_MAX_DOF = 1500              # a longer robot than this resolves is not studied (a ValueError says so)


@dataclass(frozen=True)
class State:
    """A tendon state: its name (the paper's letters: the channels run together) and its channels."""

    name: str
    channels: tuple[str, ...]


@dataclass(frozen=True)
class Described:
    """A plan's robot for the statics, where its numbers came from, and how it is tensioned."""

    robot: st.Robot
    pretension: dict                 # tendon name -> N given by the design, None: the protocol finds it
    actuating: tuple[str, ...]       # tendons of the actuating channel
    stiffening: tuple[str, ...]      # tendons with a budget (stiffening)
    channel_of: dict                 # tendon name -> channel
    stations: tuple[float, ...]
    masses: dict                     # what the weights are, for the report
    rules: protocol.Rules            # the tensioning protocol's floor, ceiling and straightness
    eyelet_friction: float | None    # μ; None: the friction bounds only
    push_n: float                    # the capstan push at the tip, N
    channels: tuple[str, ...]        # the channels that have tendons, actuating first, then the tensioner's order


def states(plan) -> list[State]:
    """N, the actuating channel alone, then with each combination of the stiffening channels in the
    paper's order (without the first stiffening channel first; by count; by channel order)."""
    act = plan.tensioner.actuating_channel
    used = {p.channel for p in plan.paths}
    stiff = [c for c in plan.tensioner.channels if c != act and c in used]
    if len(stiff) > MAX_COMBINED:
        combos = [(c,) for c in stiff] + [tuple(stiff)]
    else:
        combos = [c for r in range(1, len(stiff) + 1) for c in itertools.combinations(stiff, r)]
        combos.sort(key=lambda c: (stiff[0] in c, len(c), [stiff.index(x) for x in c]))
    out = [State("N", ())]
    if act in used:
        out.append(State(act, (act,)))
    out += [State(act + "".join(c), (act, *c) if act in used else c) for c in combos]
    return out


# ------------------------------------------------------------------ the hub's section

def _hub_section(disk, wall: float) -> tuple[float, float, float, float]:
    """(I about x, I about z, J, area) of a disk's hub around its slot, windows cut away, mm⁴ and mm²."""
    hw, hh = disk.slot_width / 2, disk.slot_height / 2
    X, Z = hw + wall, hh + wall
    windows = list(disk.hub.windows)
    Ix = Iz = area = 0.0
    open_pieces = 0.0
    for a, b in interval_difference(-X, X, windows):
        # split each piece where the slot's side lies: inside, top and bottom walls; outside, the full side wall
        for lo, hi, full in ((a, min(b, -hw), True), (max(a, -hw), min(b, hw), False), (max(a, hw), b, True)):
            if hi <= lo:
                continue
            w = hi - lo
            if full:
                Ix += w * 2 * Z ** 3 / 3
                Iz += (hi ** 3 - lo ** 3) / 3 * 2 * Z
                area += w * 2 * Z
                open_pieces += 2 * Z * min(w, wall) ** 3 / 3 if w < 2 * Z else w * (2 * Z) ** 3 / 3
            else:
                Ix += w * 2 * (Z ** 3 - hh ** 3) / 3
                Iz += (hi ** 3 - lo ** 3) / 3 * 2 * wall
                area += 2 * w * wall
                open_pieces += 2 * w * wall ** 3 / 3
    if not windows:
        am = (2 * hw + wall) * (2 * hh + wall)                   # Bredt: a closed thin-walled tube
        J = 4 * am ** 2 * wall / (2 * (2 * hw + wall) + 2 * (2 * hh + wall))
    else:
        J = open_pieces
    return Ix, Iz, J, area


def _stiffening(plan, section: st.Section, e_print: float, g_print: float) -> st.Stiffening:
    L = plan.backbone.length
    wall = plan.hub.wall
    flex, tors, stiff = [], [], []
    for dk in plan.disks:
        a, b = max(dk.y - dk.thickness / 2, 0.0), min(dk.y + dk.thickness / 2, L)
        if b > a:
            for lst in (flex, tors, stiff):
                lst.append(Span(a, b, math.inf))
        if dk.hub is None or dk.hub.length <= 0:
            continue
        face = dk.y + dk.hub.side * dk.thickness / 2
        lo, hi = sorted((face, face + dk.hub.side * dk.hub.length))
        lo, hi = max(lo, 0.0), min(hi, L)
        if hi - lo <= 1e-9:
            continue
        Ix, Iz, J, _ = _hub_section(dk, wall)
        flex.append(Span(lo, hi, section.ei_flex + e_print * Ix))
        tors.append(Span(lo, hi, section.gj + g_print * J))
        stiff.append(Span(lo, hi, section.ei_stiff + e_print * Iz))
    return st.Stiffening(tuple(flex), tuple(tors), tuple(stiff))


# ------------------------------------------------------------------ weights

def _disk_masses(plan, rho: float) -> list[tuple[str, float, float]]:
    """(name, s of the centre of mass, g) of every disk but the base (the clamp holds it)."""
    wall = plan.hub.wall
    out = []
    for dk in plan.disks[1:]:
        holes = sum(math.pi * h.diameter ** 2 / 4 for h in dk.holes) + sum(math.pi * d ** 2 / 4
                                                                             for _, _, d in dk.mount_holes)
        plate = (math.pi * dk.outer_diameter ** 2 / 4 - dk.slot_width * dk.slot_height - holes) * dk.thickness
        m_plate, s_plate = rho * plate, dk.y
        m_hub = s_hub = 0.0
        if dk.hub is not None and dk.hub.length > 0:
            m_hub = rho * _hub_section(dk, wall)[3] * dk.hub.length
            s_hub = dk.y + dk.hub.side * (dk.thickness + dk.hub.length) / 2
        m = m_plate + m_hub
        s = (m_plate * s_plate + m_hub * s_hub) / m
        out.append((dk.name, min(s, plan.backbone.length), m))
    return out


def _member_centre(mb) -> tuple[float, float]:
    """(y, z) of a housing member's centre, layout frame."""
    d = mb.dims
    if mb.kind == "box":
        return (d[2] + d[3]) / 2, (d[4] + d[5]) / 2
    if mb.kind == "prism":
        if d[0] == 0:                                  # outline in (y, z)
            return float(np.mean(d[3::2])), float(np.mean(d[4::2]))
        return float(np.mean(d[3::2])), (d[1] + d[2]) / 2
    return (d[2] + d[5]) / 2, (d[3] + d[6]) / 2


def _tip_assembly(plan, rho: float, lam: float) -> dict:
    """The tensioner as its layout sizes it, and the strip beyond the tip: mass (g), centre of mass
    beyond the tip along y (a) and along z (b)."""
    L = plan.backbone.length
    parts = []                                           # (name, volume mm³, y, z) layout frame
    lay = plan.tensioner_layout
    zsign = 1.0
    if lay is not None:
        zsign = float(lay.turn[2, 2])
        for mb in lay.members:
            y, z = _member_centre(mb)
            parts.append((mb.name, mb.volume, y, z))
        for u in lay.units:
            h = u.z_part[1] - u.z_part[0]
            parts.append((f"wheel {u.channel}", math.pi * lay.flange_radius ** 2 * h, u.center[1],
                          (u.z_part[0] + u.z_part[1]) / 2))
            r = lay.pair.worm_pitch_diameter / 2
            parts.append((f"worm {u.channel}", math.pi * r ** 2 * lay.pair.worm_length, u.worm_y, u.worm_z))
    vol = sum(v for _, v, _, _ in parts)
    m_t = rho * vol
    y_t = sum(v * y for _, v, y, _ in parts) / vol if vol else L
    z_t = zsign * sum(v * z for _, v, _, z in parts) / vol if vol else 0.0
    m_s = lam * plan.backbone.extra_tip
    y_s = L + plan.backbone.extra_tip / 2
    m_b, c_b, _ = steel.total(steel.tip_pieces(plan))
    m = m_t + m_s + m_b
    if m <= 0:
        return {"mass_g": 0.0, "a_mm": 0.0, "b_mm": 0.0, "tensioner_g": 0.0, "strip_g": 0.0, "bought_metal_g": 0.0}
    return {"mass_g": m, "a_mm": (m_t * y_t + m_s * y_s + m_b * c_b[1]) / m - L, "b_mm": (m_t * z_t + m_b * c_b[2]) / m,
            "tensioner_g": m_t, "strip_g": m_s, "bought_metal_g": m_b}


# ------------------------------------------------------------------ the robot

def describe(plan, measured: Gravity | Mapping | None = None) -> Described:
    """The plan's robot for :mod:`hwgen.model.statics` (see the module's docstring). ``measured``:
    the ``gravity`` section of a check report of this design (masses and centres of mass from
    its STLs), used for the weights instead of the plan's estimate."""
    bb, proc = plan.backbone, plan.process
    rho = proc.density_g_cm3 * 1e-3          # g/mm³
    lam = bb.density_g_cm3 * 1e-3 * bb.height * bb.thickness
    section = st.Section(E=bb.modulus_gpa * 1e3, G=bb.shear_modulus_gpa * 1e3, height=bb.height,
                         thickness=bb.thickness, lin_density=lam)
    e_print = proc.modulus_gpa * 1e3
    nu = proc.poisson
    g_print = e_print / (2 * (1 + nu))
    stiffening = _stiffening(plan, section, e_print, g_print)
    disks = _disk_masses(plan, rho)
    tip = _tip_assembly(plan, rho, lam)
    how = ("estimated from the plan (plate and hub volumes, the tensioner layout's members, wheels as flange "
           "cylinders, worms as pitch cylinders) × densities, and the bought metal at the tip (hwgen.model.steel): "
           "not measured from the files")
    weighed = Gravity.of(measured)
    if weighed is not None:
        disks = [(d.part, min(d.s_mm, bb.length), d.mass_g) for d in weighed.disks]
        tip = {"mass_g": weighed.tip.mass_g, "a_mm": weighed.tip.a_mm, "b_mm": weighed.tip.z_mm}
        lam = weighed.strip.lambda_g_mm
        section = dataclasses.replace(section, lin_density=lam)
        how = ("measured from the built files' STLs (the check report's gravity section), with the bought metal at "
               "the tip (hwgen.model.steel)")
    runs = {r.tendon: r for r in plan.tensioner_layout.runs} if plan.tensioner_layout else {}
    tm = plan.tendon_material
    stations = tuple(float(s) for s in plan.stations)
    pre = {p.name: p.pretension_n for p in plan.paths}
    lines = [_tendon_line(p, stations, runs.get(p.name), tm) for p in plan.paths]
    robot = st.Robot(bb.length, section, stiffening, tuple(lines), tuple((s, m) for _, s, m in disks),
                     tip["mass_g"], (tip["a_mm"], tip["b_mm"]))
    act = plan.tensioner.actuating_channel
    masses = {"disks": [{"part": n, "s_mm": s, "mass_g": m} for n, s, m in disks], "tip_assembly": tip,
              "strip_g_per_mm": lam, "printed_density_g_mm3": rho, "how": how}
    chk = plan.check
    rules = protocol.Rules(act, chk.taut_floor_n, tm.break_load / chk.tendon_safety_factor, chk.straight_within_mm)
    return Described(robot=robot, pretension=pre, actuating=tuple(p.name for p in plan.paths if p.channel == act),
                     stiffening=tuple(p.name for p in plan.paths if p.budget_mm is not None),
                     channel_of={p.name: p.channel for p in plan.paths}, stations=stations, masses=masses,
                     rules=rules, eyelet_friction=tm.eyelet_friction, push_n=chk.stiffness_push_n,
                     channels=_channels(plan))


def _channels(plan) -> tuple[str, ...]:
    act = plan.tensioner.actuating_channel
    used = {p.channel for p in plan.paths}
    return tuple(dict.fromkeys(c for c in (act, *plan.tensioner.channels) if c in used))


def _tendon_line(p, stations, run, tm) -> st.TendonLine:
    """A plan's tendon for the statics: its spring (path plus run over EA, with the tie-off), and its
    segments' and run's compliances (the tie-off half at the knot, half at the drum) and the run's
    direction off the tip eyelet (+y where the design has no tensioner layout)."""
    P = np.column_stack([p.points[:, 0], stations, p.points[:, 1]])
    chords = np.linalg.norm(np.diff(P, axis=0), axis=1)
    ea, tie = tm.axial_stiffness_n, tm.tie_off_compliance_mm_per_n
    run_mm = run.length if run is not None else 0.0
    comp = np.r_[chords / ea, run_mm / ea + tie / 2]
    comp[0] += tie / 2
    k = 1.0 / ((float(chords.sum()) + run_mm) / ea + tie)
    exit_dir = None
    if run is not None and run_mm > 0:
        exit_dir = tuple(float(v) for v in np.subtract(run.end, run.start) / run_mm)
    return st.TendonLine(p.name, p.channel, stations, np.asarray(p.points, float), k, tuple(float(c) for c in comp),
                         exit_dir)


# ------------------------------------------------------------------ one state in one orientation

def _curve(eq: st.Equilibrium) -> dict:
    k = max(1, len(eq.s) // CURVE_POINTS)
    idx = np.r_[np.arange(0, len(eq.s), k), len(eq.s) - 1] if (len(eq.s) - 1) % k else np.arange(0, len(eq.s), k)
    return {"s_mm": eq.s[idx].tolist(), "y_mm": eq.p[idx, 1].tolist(), "z_mm": eq.p[idx, 2].tolist(),
            "x_mm": eq.p[idx, 0].tolist()}


def push_rows(model: st.Model, eq: st.Equilibrium, stations) -> np.ndarray:
    """(K, n_dof): the displacement along :data:`PUSH` of the centre of each disk at ``stations``."""
    kin = tuple(x[0] for x in model.forward(eq.q[None, :]))
    nodes = protocol.station_nodes(model, stations)
    move, _ = fr.point_rows(model, kin, nodes, kin[0][nodes])
    return move @ np.asarray(PUSH, float)


def _slack_push(b: fr.Bounds, jtip: np.ndarray, friction: str) -> dict:
    """The tip push (N, either way along z) at which the first locked segment would go slack, as the
    tangent stiffness has it (None: none slackens that way)."""
    rates = b.tension_rates(jtip, friction)
    out = {}
    for key, sign in (("+z", 1.0), ("-z", -1.0)):
        r = sign * rates
        falling = r < -1e-12
        out[key] = float(np.min(b.tension[falling] / -r[falling])) if np.any(falling) else None
    return out


def _largest(values: np.ndarray) -> float:
    """The value of largest magnitude (a stuck tendon's segments each change by their own)."""
    return float(values[np.argmax(np.abs(values))])


def evaluate(desc: Described, model: st.Model, state: State, orientation: str, memo: dict | None = None) -> list[dict]:
    """One state in one orientation (a key of :data:`ORIENTATIONS`): tensioned by the protocol, then
    its entries: friction ``none`` and ``stuck`` (stiffness at every disk, tip torsion, the push
    that would slacken a tendon, per locked tendon its tension and its tension's change per newton
    of tip push), and ``capstan`` toward +z and −z when the design gives a friction coefficient.
    ``memo``: shared by the states of one orientation (and model)."""
    gravity = ORIENTATIONS[orientation]
    done = protocol.tension_state(model, state.channels, gravity, desc.pretension, desc.rules, desc.stations, memo)
    eq = done.equilibrium
    b = fr.bounds(eq)
    rows = push_rows(model, eq, desc.stations[1:])
    twist = model.rotation_jacobian(eq.q, desc.robot.length, (0.0, 1.0, 0.0))
    locked = [t.name for t in desc.robot.tendons if t.channel in state.channels]
    tip = eq.at(desc.robot.length)
    common = {"state": state.name, "channels": list(state.channels), "orientation": orientation,
              "gravity": None if gravity is None else list(gravity), "locked": locked,
              "tensions_n": {n: eq.tensions[n] for n in locked}, "set_n": {n: done.set_n.get(n) for n in locked},
              "tension_from": {n: done.source[n] for n in locked},
              "locks_mm": {n: done.locks[n][1] for n in locked}, "notes": list(done.notes)}
    out = []
    for friction in fr.FRICTIONS:
        k = 1.0 / b.compliance(rows, friction)
        rates = b.tension_rates(rows[-1], friction)
        per_tendon = {n: _largest(rates[[o == n for o in b.owner]]) if n in b.tendons else 0.0 for n in locked}
        entry = {**common, "friction": friction,
                 "disks": [{"disk": i, "s_mm": s, "stiffness_n_per_mm": float(v)}
                           for i, (s, v) in enumerate(zip(desc.stations[1:], k), start=1)],
                 "tip_stiffness_n_per_mm": float(k[-1]),
                 "tip_torsion_nmm_per_rad": float(1.0 / b.compliance(twist, friction)[0]),
                 "tension_per_tip_n": per_tendon, "slack_at_tip_push_n": _slack_push(b, rows[-1], friction),
                 "tip_x_mm": float(tip[0]), "tip_z_mm": float(tip[2]), "tip_angle_deg": math.degrees(eq.tip_angle())}
        if friction == "none":
            entry["curve"] = _curve(eq)
            entry["solver"] = {"iterations": eq.iterations, "residual_nmm": eq.residual, "dof": model.n_dof}
        out.append(entry)
    if desc.eyelet_friction is not None:
        for key, sign in (("+z", 1.0), ("-z", -1.0)):
            p = fr.capstan_push(b, sign * rows[-1], desc.push_n, desc.eyelet_friction)
            out.append({**common, "friction": "capstan", "push": key, "push_n": desc.push_n,
                        "eyelet_friction": desc.eyelet_friction, "tip_stiffness_n_per_mm": p.stiffness,
                        "reached_n": p.reached_n, "slack_within_push": p.slack, "slipped": p.slipped,
                        "eyelets": p.eyelets, "first_slip_n": p.first_slip_n})
    return out


def tip_stiffness(report: dict) -> dict:
    """{(state, orientation, friction): tip stiffness N/mm} of a :func:`study` report; a capstan
    entry's key is (state, orientation, "capstan +z") or ("capstan -z")."""
    return {(e["state"], e["orientation"], e["friction"] + (" " + e["push"] if "push" in e else "")):
            e["tip_stiffness_n_per_mm"] for e in report["states"]}


# ------------------------------------------------------------------ every state, and what they say together

LOW_STIFFENING = 1.2       # under this (all tendons over the actuating pair at the tip), the report says why
IDLE_SHARE = 0.05          # a locked tendon whose tension changes less than this share of the actuating one's is idle
SOFTER = 1e-3              # a state this much under one with a channel fewer is named in the notes


def study(plan, which: list[str] | None = None, orientations: list[str] | None = None, h_max: float = STUDY_H_MAX,
          measured: Gravity | Mapping | None = None) -> dict:
    """Every state (or those named) of a plan in every orientation (or those named): the stiffness
    report (see the module's docstring); ``measured``: as :func:`describe` takes it."""
    desc = describe(plan, measured)
    model = st.Model(desc.robot, h_max)
    if model.n_dof > STUDY_MAX_DOF:
        raise ValueError(f"{model.n_dof} joint coordinates, more than the {STUDY_MAX_DOF} the statics is run with")
    todo = [s for s in states(plan) if not which or s.name in which]
    names = list(orientations or ORIENTATIONS)
    entries = []
    for o in names:
        memo: dict = {}
        for s in todo:
            entries += evaluate(desc, model, s, o, memo)
    act = plan.tensioner.actuating_channel
    full = max(todo, key=lambda s: len(s.channels)).name if todo else None
    pair = [full, act] if act in {s.name for s in todo} and full != act else None
    ratios = _ratios(entries, pair) if pair else []
    sec = desc.robot.section
    report = {
        "model": "discrete elastic rod (a joint per ≤ %.2g mm segment: E·I both ways, G·J), rigid disks at their "
                 "stations, tendons as eq. (2) chords through the eyelets, one-way springs locked by the paper's "
                 "tensioning protocol; energy minimisation (hwgen.model.statics); eyelet friction as bounds "
                 "(hwgen.model.friction)" % h_max,
        "protocol": protocol.SUMMARY,
        "orientations": {o: ORIENTATIONS[o] and list(ORIENTATIONS[o]) for o in names},
        "push": {"direction": list(PUSH), "words": PUSH_WORDS},
        "frictions": {"none": "frictionless eyelets: each tendon one spring over its whole length",
                      "stuck": "every segment held at its eyelets: each its own spring (the small-push limit of "
                               "static friction)",
                      "capstan": (f"μ {desc.eyelet_friction:g} at every eyelet, a {desc.push_n:g} N push at the tip "
                                  "followed through each eyelet's slip (e^(μθ)); secant stiffness"
                                  if desc.eyelet_friction is not None else "not reported: no "
                                  "tendon_material.eyelet_friction")},
        "assumptions": [
            "robot horizontal, its flexible direction (z) along gravity (either way), or weightless; pushes along z",
            "tensions by the protocol (hwgen.model.protocol), or a tendon's pretension_n at its turn; tangent "
            "stiffness (capstan: a secant over its push)",
            "strip inextensible and unshearable; disks' plates rigid, hubs glued and as their sections say",
            "eyelets without play (the taut-path study covers play); tendons weightless",
            "masses " + desc.masses["how"],
            "the base disk and its mount are a rigid clamp"],
        "rules": {"taut_floor_n": desc.rules.floor_n, "allowable_n": desc.rules.allowable_n,
                  "straight_within_mm": desc.rules.within_mm},
        "section": {"E_mpa": sec.E, "G_mpa": sec.G, "EI_flex_nmm2": sec.ei_flex, "EI_stiff_nmm2": sec.ei_stiff,
                    "GJ_nmm2": sec.gj},
        "tendons": [{"name": t.name, "channel": t.channel, "spring_n_per_mm": t.stiffness,
                     "segment_springs_n_per_mm": [1.0 / c if c > 0 else None for c in t.compliances],
                     "pretension_n": desc.pretension[t.name]} for t in desc.robot.tendons],
        "masses": desc.masses,
        "states": entries,
        "ratios": ratios,
        "endpoint_ratio": _endpoint(ratios, pair, names),
        "notes": _softer(entries, todo, act),
        "dof": model.n_dof,
    }
    report["stiffening"] = stiffening(report, desc) if pair else None
    return report


def entries_by_state(report: dict, orientation: str, friction: str) -> dict[str, dict]:
    """state -> its entry of a :func:`study` report (stiffness.json) in ``orientation`` with
    ``friction``, without the capstan pushes' entries."""
    return {e["state"]: e for e in report.get("states", [])
            if e.get("orientation") == orientation and e.get("friction") == friction and "push" not in e}


def _entry(entries, state, orientation, friction, push=None):
    return next((e for e in entries if e["state"] == state and e["orientation"] == orientation
                 and e["friction"] == friction and e.get("push") == push), None)


def _ratios(entries, pair) -> list[dict]:
    """Per orientation and friction: the first state of ``pair`` over the second at the tip, and
    (frictionless and stuck) the least over the disks and where."""
    out = []
    for o in dict.fromkeys(e["orientation"] for e in entries):
        for friction, push in (("none", None), ("stuck", None), ("capstan", "+z"), ("capstan", "-z")):
            a, b = (_entry(entries, s, o, friction, push) for s in pair)
            if a is None or b is None:
                continue
            row = {"orientation": o, "friction": friction, "states": list(pair),
                   "tip": a["tip_stiffness_n_per_mm"] / b["tip_stiffness_n_per_mm"]}
            if push:
                row["push"] = push
            if "disks" in a:
                r = [x["stiffness_n_per_mm"] / y["stiffness_n_per_mm"] for x, y in zip(a["disks"], b["disks"])]
                i = int(np.argmin(r))
                row["least_over_disks"] = {"ratio": r[i], "disk": a["disks"][i]["disk"]}
            out.append(row)
    return out


BOUNDS_NOTE = ("Each is a ratio of tangents for a small push; the friction bounds (frictionless, every eyelet stuck) "
               "bound each state's stiffness, not the ratio of two: one state's eyelets can slip while another's "
               "hold, and a bench's push of newtons slackens tendons the tangent keeps taut.")


def _endpoint(ratios, pair, orientations) -> dict:
    """The headline: the first state of ``pair`` over the second at the tip in the reference
    orientation (or the first studied), frictionless (``ratio``) and at each friction's tangent
    (``by_friction``; ``band``, their least and most, is no band of the ratio: :data:`BOUNDS_NOTE`),
    and the paper's 4.85× placed against them (`hwgen experiment` predicts what a bench measures)."""
    o = REFERENCE if REFERENCE in orientations else orientations[0]
    rows = [r for r in ratios if r["orientation"] == o]
    if not pair or not rows:
        return {"states": pair, "orientation": o, "ratio": None, "paper": PAPER_ENDPOINT_RATIO}
    tips = [r["tip"] for r in rows]
    band = [min(tips), max(tips)]
    return {"states": pair, "orientation": o, "ratio": next(r["tip"] for r in rows if r["friction"] == "none"),
            "by_friction": {r["friction"] + (" " + r["push"] if "push" in r else ""): r["tip"] for r in rows},
            "band": band, "paper": PAPER_ENDPOINT_RATIO,
            "paper_inside": band[0] <= PAPER_ENDPOINT_RATIO <= band[1], "note": BOUNDS_NOTE}


def _softer(entries, todo, actuating) -> list[str]:
    """States under the state with one stiffening channel fewer at the tip, in words."""
    notes = []
    names = {s.name: s for s in todo}
    for e in entries:
        if e["friction"] not in fr.FRICTIONS:
            continue
        s = names[e["state"]]
        for c in s.channels:
            if c == actuating:
                continue
            fewer = next((t for t in todo if set(t.channels) == set(s.channels) - {c}), None)
            f = fewer and _entry(entries, fewer.name, e["orientation"], e["friction"])
            if f and e["tip_stiffness_n_per_mm"] < (1 - SOFTER) * f["tip_stiffness_n_per_mm"]:
                drop = 1 - e["tip_stiffness_n_per_mm"] / f["tip_stiffness_n_per_mm"]
                notes.append(f"{s.name} is {100 * drop:.1f} % less stiff at the tip than {fewer.name} ({e['orientation']}, "
                             f"friction {e['friction']}): {c}'s tension, carried by the strip, softens it against this push "
                             f"more than {c}'s own spring stiffens it (the compression the paper names, Sect. V)")
    return notes


def stiffening(report: dict, desc: Described) -> dict:
    """What locking every tendon adds over the actuating pair alone, per orientation: at the tip and
    the least over the disks, frictionless and stuck (and capstan); each locked stiffening tendon's
    share of the push's load in the reference orientation (frictionless); and, when the tip gains
    under :data:`LOW_STIFFENING` there, why. ``lines``: the same in words (summary.md)."""
    ep = report["endpoint_ratio"]
    full, act = ep["states"]
    ref = ep["orientation"]
    rows = {(r["orientation"], r["friction"] + (" " + r["push"] if "push" in r else "")): r for r in report["ratios"]}
    by = []
    for o in report["orientations"]:
        got = {f: rows[(o, f)] for f in ("none", "stuck", "capstan +z", "capstan -z") if (o, f) in rows}
        by.append({"orientation": o, "tip": {f: r["tip"] for f, r in got.items()},
                   "least_over_disks": {f: r["least_over_disks"] for f, r in got.items() if "least_over_disks" in r}})
    entry = _entry(report["states"], full, ref, "none")
    tendons = _shares(entry, desc)
    tip = next(b["tip"]["none"] for b in by if b["orientation"] == ref)
    low = tip < LOW_STIFFENING
    why = _why(tendons, desc) if low else []
    lines = [f"Stiffening, {full} over {act} at the tip (and the least over the disks, counted from 1 at the clamped "
             f"base as the paper does; `stiffness.json`, `stiffness.png`), tensioned by the paper's protocol:", ""]
    lines += [f"- {b['orientation']}: {_words(b, desc)}" for b in by]
    lines += ["", f"Set in {full}, {ref}: " + ", ".join(
        protocol.set_words(n, entry["set_n"].get(n), entry["tension_from"][n]) for n in entry["tensions_n"])
        + f"; locked, the tendons carry {protocol.locked_words(entry['tensions_n'])}; protocol: {protocol.SUMMARY}."]
    if low:
        lines += ["", f"Under {LOW_STIFFENING:g}× ({ref}, frictionless): " + " ".join(why)]
    b = next(b for b in by if b["orientation"] == ref)
    headline = (f"stiffening {full}/{act} at the tip ({ref}): {b['tip']['none']:.2f}× frictionless to "
                f"{b['tip']['stuck']:.2f}× with the eyelets stuck" + (f"; under {LOW_STIFFENING:g}×: " + " ".join(why)
                                                                      if low else ""))
    return {"states": [full, act], "reference": ref, "by_orientation": by, "tendons": tendons, "low": low,
            "why": why, "headline": headline, "lines": lines}


def _words(b: dict, desc: Described) -> str:
    t, d = b["tip"], b["least_over_disks"]

    def least(f):
        return f" ({d[f]['ratio']:.2f}× at disk {d[f]['disk'] + 1})" if f in d else ""

    out = f"{t['none']:.2f}×{least('none')} frictionless to {t['stuck']:.2f}×{least('stuck')} with every eyelet stuck"
    if "capstan +z" in t:
        out += (f"; with eyelet friction μ {desc.eyelet_friction:g} over a {desc.push_n:g} N push at the tip "
                f"{t['capstan +z']:.2f}× pushed toward +z, {t['capstan -z']:.2f}× toward −z")
    return out


def _shares(entry: dict, desc: Described) -> list[dict]:
    """Per locked stiffening tendon of ``entry``: its tension, its tension's change per newton of tip
    push, that as a share of the most an actuating tendon's changes, and how far its eyelets lie
    off the strip's neutral plane for the push (|z|, the largest)."""
    per = entry["tension_per_tip_n"]
    act = max((abs(per[n]) for n in desc.actuating if n in per), default=0.0)
    out = []
    for n in entry["locked"]:
        if n in desc.actuating:
            continue
        z = float(np.abs(desc.robot.tendon(n).points[:, 1]).max())
        out.append({"name": n, "tension_n": entry["tensions_n"][n], "tension_per_tip_n": per[n],
                    "share": abs(per[n]) / act if act > 0 else None, "eyelet_offset_mm": z})
    return out


def _why(tendons: list[dict], desc: Described) -> list[str]:
    """Why the stiffening tendons add little: which carries no change of load, and the routing
    property behind it."""
    floor = desc.rules.floor_n
    act_z = max((float(np.abs(desc.robot.tendon(n).points[:, 1]).max()) for n in desc.actuating), default=0.0)
    out = []
    for t in tendons:
        if t["tension_n"] <= fr.SLACK_N:
            out.append(f"{t['name']} is slack in this state (it carries nothing, so it holds nothing).")
        elif t["share"] is not None and t["share"] < IDLE_SHARE:
            if t["eyelet_offset_mm"] <= IDLE_SHARE * act_z:
                out.append(f"{t['name']} carries no change of load: its eyelets lie on the neutral plane of the pushed "
                           f"direction (|z| ≤ {t['eyelet_offset_mm']:.2f} mm), so bending the strip that way does "
                           f"not change its length.")
            else:
                out.append(f"{t['name']} carries almost no change of load ({100 * t['share']:.1f} % of the actuating "
                           f"tendon's): its eyelets change side of the strip along its length, so what its path gains "
                           f"where the push bends the strip one way it gives back where they lie on the other.")
        elif t["tension_n"] < floor:
            out.append(f"{t['name']} is barely taut ({t['tension_n']:.2f} N, under the {floor:g} N floor).")
    if not out:
        springs = ", ".join(f"{t['name']} {desc.robot.tendon(t['name']).stiffness:.2f} N/mm" for t in tendons)
        out.append(f"every stiffening tendon takes load, but their springs ({springs}) are soft against the strip "
                   f"(E·I {desc.robot.section.ei_flex:.0f} N·mm²): a stiffer line or shorter free length would add more.")
    return out

