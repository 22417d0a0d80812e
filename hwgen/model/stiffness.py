"""The robot of a plan described for :mod:`hwgen.model.statics`, and what the statics says of it:
stiffness per tendon state (the paper's Fig. 8), shape under its own weight (Fig. 7), and how
the stiffening tendons' tensions swing when the actuating pair bends the robot (numpy and scipy
only; everything from the plan, no CAD).

Robot. The strip (E = backbone.modulus_gpa, G = backbone.shear_modulus_gpa, h × t) clamped at the
base disk's mid-plane, tip at the tip disk's. Each disk's plate holds the strip rigid over its
thickness; its glued hub adds the hub's section (E and G of the printed material; a hub cut by a
tendon window is an open section in torsion, an uncut one a closed tube). Masses are estimated
from the plan's numbers, not measured: each disk's plate and hub volumes (holes, slot and windows
taken out) × the printed density, at their centre of mass on the centre line; the tip assembly
is the tip disk's tensioner as the layout sizes it (housing members, each wheel part as its
flange's cylinder, each worm as its pitch cylinder) plus the strip beyond the tip, at its centre
of mass; the base disk is the clamp's. Tendons are the plan's eyelets (eq. (2)); each one's
spring is its free length (path plus run to the drum) over ``tendon_material.axial_stiffness_n``
in series with ``tendon_material.tie_off_compliance_mm_per_n``.

States. A state is the set of channels whose tendons are pre-tensioned and locked (the worm
self-locks); the others are slack. The paper's nine (Fig. 8) are N, the actuating channel alone,
and it with every combination of the stiffening channels, in the paper's order. Each locked
tendon is locked at the length that gives its ``pretension_n`` with the robot held straight and
weightless (as in the jig); let go, the robot settles under its weight and the tendons with it.

Stiffness. The robot horizontal, its flexible direction (z) along gravity; a small push at a
disk along gravity, force over displacement there (the tangent stiffness of the settled state:
one-way springs as they are there). Torsion: torque over twist at the tip, about its tangent.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
import time
from dataclasses import dataclass

import numpy as np

from .intervals import interval_difference
from .sag import Span
from . import statics as st

GRAVITY = (0.0, 0.0, -1.0)        # robot horizontal, its flexible direction along gravity (Fig. 7)
PUSH = (0.0, 0.0, 1.0)            # the push: along gravity's line (its sign does not change a tangent stiffness)
PAPER_ENDPOINT_RATIO = 4.85       # abstract and Sect. VI: AC1C2H over A at the endpoint
MAX_COMBINED = 4                  # more stiffening channels than this: each alone and all together only
CURVE_POINTS = 120


@dataclass(frozen=True)
class State:
    """A tendon state: its name (the paper's letters: the channels run together) and its channels."""

    name: str
    channels: tuple[str, ...]


@dataclass(frozen=True)
class Described:
    """A plan's robot for the statics, and where its numbers came from."""

    robot: st.Robot
    pretension: dict                 # tendon name -> N
    actuating: tuple[str, ...]       # tendons of the actuating channel
    stiffening: tuple[str, ...]      # tendons with a budget (stiffening)
    channel_of: dict                 # tendon name -> channel
    stations: tuple[float, ...]
    masses: dict                     # what the weights are, for the report


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
    m = m_t + m_s
    if m <= 0:
        return {"mass_g": 0.0, "a_mm": 0.0, "b_mm": 0.0, "tensioner_g": 0.0, "strip_g": 0.0}
    return {"mass_g": m, "a_mm": (m_t * y_t + m_s * y_s) / m - L, "b_mm": m_t * z_t / m,
            "tensioner_g": m_t, "strip_g": m_s}


# ------------------------------------------------------------------ the robot

def describe(plan, measured: dict | None = None) -> Described:
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
           "cylinders, worms as pitch cylinders) × densities: not measured from the files")
    if measured and measured.get("tip_assembly") and measured.get("strip"):
        disks = [(r["part"], min(float(r["s_mm"]), bb.length), float(r["mass_g"])) for r in measured["disks"]]
        mt = measured["tip_assembly"]
        tip = {"mass_g": float(mt["mass_g"]), "a_mm": float(mt["a_mm"]), "b_mm": float(mt["z_mm"])}
        lam = float(measured["strip"]["lambda_g_mm"])
        section = dataclasses.replace(section, lin_density=lam)
        how = "measured from the built files' STLs (the check report's gravity section)"
    runs = {r.tendon: r.length for r in plan.tensioner_layout.runs} if plan.tensioner_layout else {}
    tm = plan.tendon_material
    stations = tuple(float(s) for s in plan.stations)
    pre = {p.name: p.pretension_n for p in plan.paths}
    lines = []
    for p in plan.paths:
        P = np.column_stack([np.zeros(len(stations)), stations, np.zeros(len(stations))])
        P[:, 0], P[:, 2] = p.points[:, 0], p.points[:, 1]
        path = float(np.linalg.norm(np.diff(P, axis=0), axis=1).sum())
        k = 1.0 / ((path + runs.get(p.name, 0.0)) / tm.axial_stiffness_n + tm.tie_off_compliance_mm_per_n)
        lines.append(st.TendonLine(p.name, p.channel, stations, np.asarray(p.points, float), k))
    robot = st.Robot(bb.length, section, stiffening, tuple(lines), tuple((s, m) for _, s, m in disks),
                     tip["mass_g"], (tip["a_mm"], tip["b_mm"]))
    act = plan.tensioner.actuating_channel
    masses = {"disks": [{"part": n, "s_mm": s, "mass_g": m} for n, s, m in disks], "tip_assembly": tip,
              "strip_g_per_mm": lam, "printed_density_g_mm3": rho, "how": how}
    return Described(robot, pre, tuple(p.name for p in plan.paths if p.channel == act),
                     tuple(p.name for p in plan.paths if p.budget_mm is not None),
                     {p.name: p.channel for p in plan.paths}, stations, masses)


def state_loads(desc: Described, model: st.Model, state: State, gravity=GRAVITY,
                forces=()) -> tuple[st.Loads, np.ndarray]:
    """The loads of a tendon state: its channels' tendons locked where each carries its pre-tension
    with the robot weightless (tensioned on the bench), then the weight and the forces; and the
    weightless shape (a start for the solver)."""
    names = [t.name for t in desc.robot.tendons if t.channel in state.channels]
    locks, settled = st.locked_settled(model, {n: desc.pretension[n] for n in names})
    return st.Loads(tendons=locks, gravity=gravity, forces=tuple(forces)), settled.q


def _curve(eq: st.Equilibrium) -> dict:
    k = max(1, len(eq.s) // CURVE_POINTS)
    idx = np.r_[np.arange(0, len(eq.s), k), len(eq.s) - 1] if (len(eq.s) - 1) % k else np.arange(0, len(eq.s), k)
    return {"s_mm": eq.s[idx].tolist(), "y_mm": eq.p[idx, 1].tolist(), "z_mm": eq.p[idx, 2].tolist(),
            "x_mm": eq.p[idx, 0].tolist()}


def state_result(desc: Described, model: st.Model, state: State, q0=None) -> tuple[dict, st.Equilibrium]:
    """One state settled under its weight: shape, tensions, stiffness at every disk, tip torsion."""
    loads, settled = state_loads(desc, model, state)
    eq = st.solve(model, loads, settled if q0 is None else q0)
    k = eq.point_stiffnesses(desc.stations[1:], PUSH)
    disks = [{"disk": i, "s_mm": s, "stiffness_n_per_mm": float(v)}
             for i, (s, v) in enumerate(zip(desc.stations[1:], k), start=1)]
    L = desc.robot.length
    tip = eq.at(L)
    return ({"state": state.name, "channels": list(state.channels),
             "locked": [t.name for t in desc.robot.tendons if t.channel in state.channels],
             "tensions_n": {k: v for k, v in eq.tensions.items() if k in
                            [t.name for t in desc.robot.tendons if t.channel in state.channels]},
             "disks": disks,
             "tip_stiffness_n_per_mm": disks[-1]["stiffness_n_per_mm"],
             "tip_torsion_nmm_per_rad": eq.twist_stiffness(),
             "tip_sag_mm": float(-tip[2]), "tip_angle_deg": math.degrees(eq.tip_angle()),
             "curve": _curve(eq), "solver": {"iterations": eq.iterations, "residual_nmm": eq.residual,
                                             "seconds": eq.solve_time, "dof": model.n_dof}}, eq)


def study(plan, which: list[str] | None = None, h_max: float = st.H_MAX, measured: dict | None = None) -> dict:
    """Every state (or those named) of a plan: the stiffness report (see the module's docstring);
    ``measured``: as :func:`describe` takes it."""
    t0 = time.perf_counter()
    desc = describe(plan, measured)
    model = st.Model(desc.robot, h_max)
    todo = states(plan)
    if which:
        todo = [s for s in todo if s.name in which]
    out = []
    for s in todo:
        res, _ = state_result(desc, model, s)
        out.append(res)
    by = {r["state"]: r for r in out}
    act = plan.tensioner.actuating_channel
    full = max(todo, key=lambda s: len(s.channels)).name if todo else None
    ratio = None
    if act in by and full in by and full != act:
        ratio = by[full]["tip_stiffness_n_per_mm"] / by[act]["tip_stiffness_n_per_mm"]
    sec = desc.robot.section
    return {
        "model": "discrete elastic rod (a joint per ≤ %.2g mm segment: E·I both ways, G·J), rigid disks at their "
                 "stations, tendons as eq. (2) chords through the eyelets, one-way springs locked at their "
                 "pre-tension; energy minimisation (hwgen.model.statics)" % h_max,
        "assumptions": [
            "robot horizontal, its flexible direction (z) along gravity; pushes along gravity; tangent stiffness",
            "each locked tendon carries its pre-tension in the weightless robot as those tensions settle it "
            "(tensioned on the bench, then locked: ℓ0 = ℓ − τ/k); then turned horizontal under its weight",
            "strip inextensible and unshearable; disks' plates rigid, hubs glued and as their sections say",
            "eyelets without play or friction (the taut-path study covers play); tendons weightless",
            "masses " + desc.masses["how"],
            "the base disk and its mount are a rigid clamp"],
        "section": {"E_mpa": sec.E, "G_mpa": sec.G, "EI_flex_nmm2": sec.ei_flex, "EI_stiff_nmm2": sec.ei_stiff,
                    "GJ_nmm2": sec.gj},
        "tendons": [{"name": t.name, "channel": t.channel, "spring_n_per_mm": t.stiffness,
                     "pretension_n": desc.pretension[t.name]} for t in desc.robot.tendons],
        "masses": desc.masses,
        "states": out,
        "endpoint_ratio": {"states": [full, act], "ratio": ratio, "paper": PAPER_ENDPOINT_RATIO},
        "dof": model.n_dof,
        "seconds": time.perf_counter() - t0,
    }


# ------------------------------------------------------------------ the bending sweep

SWEEP_H_MAX = 3.0          # mm: the sweep's rod segments (tensions agree with 1.5 mm to 4 digits; 4× faster)
SWEEP_FIRST_DEG = 5.0      # the first haul-in aims at this angle; later ones a sweep step further
SWEEP_MAX_SOLVES = 24      # per side: a drive that stops bending the robot is not chased further
PROBE_N = 1e-3             # N at the tip: the push that tells which actuating tendon shortens which way


def _inner(desc: Described, model: st.Model, sign: int) -> tuple[str | None, float]:
    """The actuating tendon that shortens most when the robot bends toward sign·z, and how many mm
    it shortens per degree there; (None, 0) if none shortens."""
    eq = st.solve(model, st.Loads(forces=((desc.robot.length, (0.0, 0.0, sign * PROBE_N)),)))
    base = st.straight_lengths(model)
    turn = abs(math.degrees(eq.tip_angle()))
    if not desc.actuating or turn == 0.0:
        return None, 0.0
    name = min(desc.actuating, key=lambda n: eq.lengths[n] - base[n])
    per_deg = (base[name] - eq.lengths[name]) / turn
    return (name, per_deg) if per_deg > 1e-6 else (None, 0.0)


def inner_tendons(desc: Described, model: st.Model) -> dict:
    """:func:`_inner` of either side (sign +1, -1): what a sweep hauls in there, whichever tendons it
    locks (a probe of the weightless robot alone: the sweeps with and without the stiffening
    tendons share it)."""
    return {sign: _inner(desc, model, sign) for sign in (1, -1)}


def sweep(desc: Described, model: st.Model, max_deg: float, step_deg: float, locked: bool = True,
          inner_of: dict | None = None) -> dict:
    """Bend the weightless robot from straight to ±max_deg by hauling in the actuating tendon on the
    inside of the bend (displacement-controlled, its drum turning), the other actuating tendons
    held at their pre-tension by the drive, the stiffening tendons locked where they carry their
    pre-tension (``locked``) or slack. At each angle of the sweep: every tendon's tension, N.

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
        inner, per_deg = inner_of[sign] if inner_of else _inner(desc, model, sign)
        if inner is None:
            out[key] = {"inner": None, "angles_deg": [], "tensions_n": {}, "reached_deg": 0.0, "solves": 0}
            continue
        others = [n for n in desc.actuating if n != inner]
        base = {n: ("tension", desc.pretension[n]) for n in others}
        held, eq = st.locked_settled(model, {n: desc.pretension[n] for n in [inner, *stiff]}, st.Loads(tendons=base))
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
