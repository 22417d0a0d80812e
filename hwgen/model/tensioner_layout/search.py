"""The search over arrangements: each one's lower bound from its stacks alone, the best few solved
in that order (branch and bound on the estimated load of the tensioner's weight), the winner
assembled into a :class:`TensionerLayout`, or a refusal that names the closest miss."""
from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass

import numpy as np

from ...params import Design, Tensioner
from ..routing import TendonPath
from ..specs import DiskSpec
from .arrangement import (CLAMP_MIN, GEAR_RULES, Arrangement, Eyelets, arrangements, clamp_blockers, meets_clamp,
                          pin_length, strip_clamp, strip_keepout, tip_eyelets, turned_over, unit_stack)
from .housing import housing_members
from .placement import Failure, Frame, Infeasible, lifted, solve, x_floor
from .result import Member, TendonRun, TensionerLayout
from .sizes import MAX_SOLVES, POST, STRIP_CLAMP_Z, NoFit, Sizes


@dataclass
class _Best:
    arrangement: Arrangement
    x_u: float
    frame: Frame
    clamp: tuple
    sz: Sizes
    members: list
    cuts: list
    load: float


@dataclass(frozen=True)
class _Candidate:
    bound: float                 # the load at the narrowest x_u and no lift: no placement of it loads less
    arrangement: Arrangement
    eyelets: Eyelets
    stacks: dict
    clamp: tuple
    mounts: list


def layout(design: Design, paths: list[TendonPath], tip: DiskSpec, chosen: dict | None = None) -> TensionerLayout:
    """Where every part of the tensioner goes, on the tip disk ``tip``: of the arrangements that
    keep every tendon clear, the one that loads the strip least. NoFit (a ValueError) names the
    tendon, what it hits and the parameter that would free it when none does.

    The load is the tip deflection the tensioner's weight causes on a cantilever of the
    backbone's length, up to a constant: estimated volume × (2L + 3d), d the distance of its
    centre of mass beyond the tip face (a weight P at d beyond the tip of a cantilever L
    deflects it by P·L²·(L/3 + d/2)/EI). Arrangements are solved in order of a lower bound
    on that load, so most are never solved.

    ``chosen``: the ``search`` record of a layout made before from this very design (what a build's
    manifest keeps): only the arrangement it names is laid out again, and the layout keeps that
    record; it is searched afresh when no candidate matches it.
    """
    if chosen is not None:
        # not this design's record after all: searched afresh below
        with contextlib.suppress(NoFit, KeyError, IndexError, TypeError, ValueError):
            return _search(design, paths, tip, _named(chosen), chosen)
    return _search(design, paths, tip, None, None)


def _named(record: dict):
    """Whether an arrangement is the one a layout's ``search`` record names."""
    turn = -1 if record["turned_over"] else 1
    up = turn * (1 if record["set_screws_from"] == "+z" else -1)
    key = (turn < 0, up < 0, record["gear_rule"], tuple(record["order"]), tuple(record["columns"]))
    return lambda arr: arr.key == key


def _search(design: Design, paths: list[TendonPath], tip: DiskSpec, wanted, record: dict | None) -> TensionerLayout:
    """The search of :func:`layout` over the arrangements ``wanted`` accepts (None: all)."""
    ts = design.tensioner
    sz = Sizes.of(design, tip)
    fast = sz.fast
    robot_eyelets = tip_eyelets(paths, ts.channels)
    x_min = x_floor(robot_eyelets, sz)
    candidates = []
    blockers: list = []
    for turn in (1, -1):
        eyelets = turned_over(robot_eyelets, turn)
        mounts = [(turn * x, turn * z) for x, z, _ in tip.mount_holes]
        stack_sets: set = set()
        for gear_rule in GEAR_RULES:
            stacks = {c: unit_stack([z for _, _, z in eyelets[c]], sz.pair, gear_rule) for c in ts.channels}
            sig = tuple((c, stacks[c].z_part, stacks[c].gear) for c in sorted(stacks))
            if sig in stack_sets:            # another rule already gave every unit this stack
                continue
            stack_sets.add(sig)
            clamp_sets: set = set()
            sides = []
            for up in (1, -1):
                clamp = strip_clamp(sz, up)
                blocked = clamp_blockers(eyelets, clamp, sz)
                if blocked:                   # some tendon would run through the clamp on this side
                    blockers.append(blocked[0])
                    continue
                sides.append((up, clamp))
            if not sides:                     # a tendon is in the clamp's way either side: the tip disk alone holds
                sides = [(1, None)]           # the housing on the strip, and the layout says so
            for up, clamp in sides:
                # which units and tendons the clamp side can touch: the same for both sides, one is enough
                touch = None if clamp is None else (
                    tuple(sorted(c for c in stacks if meets_clamp(stacks[c], clamp))),
                    tuple(sorted(n for v in eyelets.values() for n, _, z in v
                                 if clamp[4] - 2 * sz.need < z < clamp[5] + 2 * sz.need)))
                if touch in clamp_sets:
                    continue
                clamp_sets.add(touch)
                for arr in arrangements(turn, up, gear_rule, eyelets, stacks, strip_keepout(sz, clamp)):
                    if wanted is not None and not wanted(arr):
                        continue
                    fr = lifted(x_min, arr, stacks, eyelets, ts.winding, clamp, sz)
                    members, _ = housing_members(fr, clamp, sz, mounts, fast, ts.shaft_diameter, ts.press_fit,
                                                  with_cuts=False)
                    candidates.append(_Candidate(_load(members, fr, sz, design.backbone.length), arr, eyelets,
                                                 stacks, clamp, mounts))
    if not candidates:
        n, x, z = blockers[0]
        short = sz.y_face + sz.base_t + CLAMP_MIN - design.backbone.length
        raise NoFit(f"tendon {n} leaves the tip at x = {x:g}, z = {z:g} mm, in the strip's plane, where the "
                    f"block that clamps the strip's tip stands ({STRIP_CLAMP_Z[0]:g} to {STRIP_CLAMP_Z[1]:g} mm "
                    f"from the strip plane, the thick side either way): move its tip "
                    f"eyelet off the strip plane (its routing at the last station), or make backbone.extra_tip "
                    f"less than {short:.0f} mm so the strip ends before any clamp")
    candidates.sort(key=lambda c: (c.bound, c.arrangement.key))
    best: _Best | None = None
    failures: list[Failure] = []
    solved = 0
    for c in candidates:
        if best is not None and c.bound >= best.load or solved >= MAX_SOLVES:
            break
        solved += 1
        try:
            x_u, fr = solve(c.arrangement, c.stacks, c.eyelets, ts.winding, c.clamp, sz)
        except Infeasible as e:
            failures.append(e.failure)
            continue
        members, cuts = housing_members(fr, c.clamp, sz, c.mounts, fast, ts.shaft_diameter, ts.press_fit)
        load = _load(members, fr, sz, design.backbone.length)
        if best is None or (load, c.arrangement.key) < (best.load, best.arrangement.key):
            best = _Best(c.arrangement, x_u, fr, c.clamp, sz, members, cuts, load)
    if best is None:
        raise NoFit(_explain(failures, len(candidates), ts))
    note = None
    if best.clamp is None and blockers:
        n, x, z = blockers[0]
        note = (f"left off: tendon {n} leaves the tip at x = {x:g}, z = {z:g} mm, where the block that clamps the "
                f"strip's tip would stand either side; the tensioner is held by its screws into the tip disk alone "
                f"(backbone.extra_tip of strip runs into the housing unclamped)")
    return _assemble(best, ts, fast, len(candidates), solved, note, record)


def _load(members: list[Member], fr: Frame, sz: Sizes, length: float) -> float:
    """Estimated volume × (2L + 3d): proportional to the tip deflection the tensioner's weight
    causes (members and wheels by their envelopes; worms and caps are the same in every
    arrangement and only shift d a little)."""
    vols = [m.volume for m in members] + [math.pi * sz.r_f ** 2 * (u.z_part[1] - u.z_part[0]) for u in fr.units]
    ys = [m.centre_y for m in members] + [u.center[1] for u in fr.units]
    v = float(sum(vols))
    d = float(np.dot(vols, ys)) / v - sz.y_face
    return v * (2 * length + 3 * d)


def _explain(failures: list[Failure], tried: int, ts: Tensioner) -> str:
    """The closest miss among the arrangements tried, and what would free it."""
    f = max(failures, key=lambda f: f.clearance)
    if f.kind == "exit":
        return (f"no tensioner layout turns every tendon by at most tensioner.max_exit_deg = {ts.max_exit_deg:g}° "
                f"at the tip ({tried} arrangements tried): tendon {f.tendon} needs {f.obstacle}; allow a larger "
                f"turn (tensioner.max_exit_deg) or fewer channels")
    if f.kind == "clamp":
        return (f"no tensioner layout keeps every tendon clear ({tried} arrangements tried): tendon {f.tendon} "
                f"leaves the tip beside the strip's tip clamp and passes it {-f.clearance:.2f} mm too close; move "
                f"its tip eyelet off the strip plane (its routing at the last station) or shorten "
                f"backbone.extra_tip so the clamp ends sooner")
    return (f"no tensioner layout keeps every tendon clear ({tried} arrangements tried): at best tendon "
            f"{f.tendon} passes the {f.obstacle} {-f.clearance:.2f} mm closer than tensioner.tendon_clearance "
            f"= {ts.tendon_clearance:g} mm allows; smaller gears (tensioner.module, tensioner.wheel_teeth, "
            f"tensioner.worm_pitch_diameter), a smaller tendon_clearance or fewer channels would free it")


def _assemble(b: _Best, ts: Tensioner, fast: str, tried: int, solved: int,
              clamp_note: str | None = None, record: dict | None = None) -> TensionerLayout:
    sz, fr, arr = b.sz, b.frame, b.arrangement
    turn = np.diag([float(arr.turn), 1.0, float(arr.turn), 1.0])
    runs = tuple(TendonRun(r.tendon, r.channel, tuple(float(v) for v in turn[:3, :3] @ r.start),
                           tuple(float(v) for v in turn[:3, :3] @ r.end), r.exit_angle_deg, r.sense)
                 for r in fr.runs)
    search = {"arrangements": tried, "solved": solved, "turned_over": arr.turn < 0,
              "set_screws_from": "+z" if arr.turn * arr.clamp_up > 0 else "-z", "gear_rule": arr.gear_rule,
              "order": list(arr.order), "columns": list(arr.sides),
              "housing_members_mm3": round(sum(m.volume for m in b.members), 1), "load_estimate": round(b.load)}
    if clamp_note:
        search["strip_clamp"] = clamp_note
    if record is not None:                # laid out again from a record: what the search found then
        search = dict(record)
    return TensionerLayout(
        pair=sz.pair, y_face=sz.y_face, x_u=b.x_u, spine=fr.spine, post=fr.post, worm_x=fr.worm_x,
        worm_file_to_mesh=fr.worm_file_to_mesh, worm_near_end=fr.near_end, spine_hole=sz.spine_hole,
        worm_pin=pin_length(POST), units=fr.units, runs=runs, spool_radius=sz.r_s, winding_radius=sz.r_w,
        flange_radius=sz.r_f, hub_radius=sz.hub_r, strip=(sz.strip_half_x, sz.strip_half_z, sz.y_face, sz.y_end),
        clamp_block=b.clamp, members=tuple(b.members), cuts=tuple(b.cuts), turn=turn, fastening=fast,
        base_t=sz.base_t, hex_key=ts.hex_key, shaft_diameter=ts.shaft_diameter, running_fit=ts.running_fit,
        friction_coefficient=ts.friction_coefficient,
        windings={c: ts.winding.get(c, "same") for c in ts.channels}, search=search)
