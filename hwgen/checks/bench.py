"""The rotating base frame (``base_frame.*``) and the rig (``rig.*``), measured from their files.

What turns about the robot's axis is read from the STLs: the robot's printed parts (disks, strip,
tensioner, base mount) and the frame's cradle, each part's mass from its closed mesh's volume and
the manifest's density and its centre of mass from the mesh, plus the tensioner's bought metal
(:func:`hwgen.model.steel.tip_pieces`, as the gravity checks weigh it). Their resultant centre of
mass off the axis gives the largest gravity torque about the shaft (the worst roll angle puts it
level); the push adds ``base_frame.push_n`` at a disk's rim (a push tangent to the rim: the most
a lab's push can turn the robot by). Against that torque:

- ``base_frame.self_locking``: the worm's lead angle below the friction angle atan(μ / cos α_n), so
  no torque turns the wheel back; the worm's holding torque is reported.
- ``base_frame.tooth_stress``: the wheel's Lewis factor of safety against the resin's strength.
- ``base_frame.shaft``: the supporting shaft on its two bearings (the uprights' mid-planes, from the
  files) under the turning weight and the push at the tip: the tip's shift.
- ``base_frame.bearing``: the front bearing's static load against its rating C0 / safety factor.
- ``base_frame.clamp``: the mount's foot screws' friction grip on the cradle against the torque.
- ``base_frame.tipping``: the whole bench about the base plate's front edge: the frame's weight and
  its screws (or clamps) against the robot's overhanging weight and the push.
- ``base_frame.clearance``: every fixed part of the frame from the solid the turning parts sweep
  about the axis (so at every angle), and that solid from the table; surfaces sampled.

``rig.push_clear``: the push block's lowest point above the highest tendon of the disk it pushes.
The model's figures (the bearing's rating, the resin's grip per screw) are design data; each
failing check names the value to change, and its fix is evaluated again before it is given.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..model import bench_frame as bf
from ..model import steel
from .base import Check, Fix

G = 9.81e-3                 # N per gram
BIN_MM = 0.5                # the turning solid's profile is kept per this much of the axis
SAMPLES = 20_000            # surface points per part for the clearance
NEAR_MM = 30.0              # a turning part this near the frame along the axis has its surface sampled, mm


def _bench(e: dict) -> str:
    return e.get("bench", "")


def _mass(p, e) -> tuple[float, np.ndarray] | None:
    closed = None if "density_g_cm3" not in e or p.fixture else p.volume_and_centroid()
    if closed is None:
        return None
    volume, com = closed
    return volume / 1000 * e["density_g_cm3"], com


def _points(p, n: int = SAMPLES) -> np.ndarray:
    """Surface points of a part (its vertices and n sampled, seeded), robot coordinates."""
    import trimesh
    pts, _ = trimesh.sample.sample_surface(p.mesh, n, seed=0)
    v = np.vstack([np.asarray(p.mesh.vertices), pts])
    return v @ p.placement[:3, :3].T + p.placement[:3, 3]


def _vertices(p) -> np.ndarray:
    return np.asarray(p.mesh.vertices) @ p.placement[:3, :3].T + p.placement[:3, 3]


def _group(rows) -> tuple[float, np.ndarray]:
    m = sum(r[0] for r in rows)
    c = sum(r[0] * r[1] for r in rows) / m if m else np.zeros(3)
    return m, c


def bench_checks(parts, plan) -> tuple[dict, list[Check]]:
    """(report section, checks) of the base frame and the rig; nothing when neither is built."""
    lay = plan.frame
    out: list[Check] = []
    report: dict = {}
    if plan.rig is not None:
        out += _push_clear(parts, plan)
    if lay is None:
        return report, out
    by = {p.name: p for p in parts}
    if "base_frame_cradle" not in by:
        return report, out
    turning, fixed = [], []
    for p in parts:
        e = p.entry
        m = _mass(p, e)
        if m is None:
            continue
        if not _bench(e) or e.get("turns") and p.role == "base_frame":
            turning.append(m)
        elif _bench(e) == "base_frame" or p.name == "rig_support":
            fixed.append((m, p))
    metal = steel.total(steel.tip_pieces(plan))
    if metal[0] > 0:
        turning.append((metal[0], np.asarray(metal[1], float)))
    m_turn, c_turn = _group(turning)
    m_fix, c_fix = _group([m for m, _ in fixed])
    off = float(math.hypot(c_turn[0], c_turn[2]))
    t_gravity = m_turn * G * off
    t_push = lay.push_n * lay.disk_radius
    torque = t_gravity + t_push
    report = {"turning_mass_g": m_turn, "turning_center_of_mass_mm": c_turn.tolist(), "off_axis_mm": off,
              "gravity_torque_nmm": t_gravity, "push_torque_nmm": t_push, "frame_mass_g": m_fix,
              "wheel_teeth": lay.pair.teeth, "belt_mm": lay.belt_length, "axis_above_plate_mm": -lay.z_base}
    out.append(_self_locking(lay, torque, t_gravity))
    out.append(_teeth(lay, torque, float(plan.tensioner.resin_strength)))
    yf = _mid_y(by.get("base_frame_front"), sum(lay.front) / 2)
    yb = _mid_y(by.get("base_frame_back"), sum(lay.back) / 2)
    shaft = bf.shaft_statics(replace(lay, front=(yf, yf), back=(yb, yb)), m_turn * G, float(c_turn[1]),
                             lay.push_n, lay.tip_y)
    report["shaft"] = shaft
    out += _shaft(lay, shaft)
    out.append(_clamp(lay, torque))
    out.append(_tipping(lay, parts, m_turn, c_turn, m_fix, c_fix, by))
    out.append(_clearance(lay, parts, by))
    return report, out


def _mid_y(p, default: float) -> float:
    if p is None:
        return default
    b = p.robot_bounds()
    return float((b[0, 1] + b[1, 1]) / 2)


def _self_locking(lay, torque: float, t_gravity: float) -> Check:
    p = lay.pair
    lead, phi = math.degrees(p.lead_angle), math.degrees(p.friction_angle(lay.mu))
    ok = lead < phi
    hold = bf.holding_torque(lay, torque)
    msg = (f"base frame worm: lead angle {lead:.2f}° {'<' if ok else '≥'} friction angle {phi:.2f}° "
           f"(μ {lay.mu:g}): under the robot's largest gravity torque {t_gravity:.0f} N·mm and the push's "
           f"{torque - t_gravity:.0f} N·mm the wheel {'stays put' if ok else 'turns the worm back'}"
           f"{f' (the worm would need {-hold:.0f} N·mm to hold it)' if not ok else ''}")
    fixes, fix = (), ""
    if not ok:
        d1 = p.worm_pitch_diameter
        while d1 < 40 and math.degrees(replace(p, worm_pitch_diameter=d1).lead_angle) >= phi:
            d1 += 0.5
        q = replace(p, worm_pitch_diameter=d1)
        passed = math.degrees(q.lead_angle) < phi
        fixes = (Fix({"base_frame.worm_pitch_diameter": d1},
                     {"measured": math.degrees(q.lead_angle), "passed": passed},
                     note="a larger worm lowers its lead angle"),)
        fix = (f"base_frame.worm_pitch_diameter: {d1:g} (lead angle {math.degrees(q.lead_angle):.2f}°)" if passed
               else "base_frame.worm_starts: 1 and a larger base_frame.worm_pitch_diameter")
    return Check("base_frame.self_locking", "error", ok, msg, lead, phi, {"part": "base_frame_worm"}, fix=fix,
                 fixes=fixes)


def _teeth(lay, torque: float, strength: float) -> Check:
    """``strength``: the resin's tensile strength the tensioner's teeth are judged on too, MPa."""
    p = lay.pair
    sf = bf.lewis_factor(p, torque, strength)
    ok = sf >= lay.safety_factor
    fixes, fix = (), ""
    if not ok:
        z = bf.least_teeth(p, torque, strength, lay.safety_factor)
        then = bf.lewis_factor(replace(p, teeth=z), torque, strength)
        fixes = (Fix({"base_frame.wheel_teeth": z}, {"measured": then, "passed": then >= lay.safety_factor},
                     note="a larger wheel: a longer lever, less force on each tooth"),)
        fix = f"base_frame.wheel_teeth: {z} (Lewis safety {then:.2f})"
    return Check("base_frame.tooth_stress", "error", ok,
                 f"base frame wheel ({p.teeth} teeth, module {p.module:g} mm): Lewis factor of safety {sf:.2f} "
                 f"{'≥' if ok else '<'} {lay.safety_factor:g} under {torque:.0f} N·mm", sf, lay.safety_factor,
                 {"part": "base_frame_wheel"}, fix=fix, fixes=fixes)


def _shaft(lay, s: dict) -> list[Check]:
    shift_ok = s["tip_shift_mm"] <= lay.max_tip_shift_mm
    limit = lay.bearing_c0_n / lay.safety_factor
    load = max(s["front_n"], s["back_n"])
    bear_ok = load <= limit
    fix_s = "" if shift_ok else (f"a stiffer shaft: base_frame.bearing: '608' (Ø8 shaft), or accept more: "
                                 f"base_frame.max_tip_shift_mm: {math.ceil(s['tip_shift_mm'] * 10) / 10:g}")
    fixes = () if shift_ok else (Fix({"base_frame.max_tip_shift_mm": math.ceil(s["tip_shift_mm"] * 10) / 10},
                                     {"measured": s["tip_shift_mm"], "passed": True}, relax=True,
                                     note="accepts the shift the shaft gives"),)
    return [
        Check("base_frame.shaft", "error", shift_ok,
              f"supporting shaft Ø{lay.shaft_d:g} on bearings {s['span_mm']:.0f} mm apart, {s['overhang_mm']:.0f} mm "
              f"overhang: the robot's weight and a {lay.push_n:g} N push at the tip shift the tip by "
              f"{s['tip_shift_mm']:.3f} mm ({'≤' if shift_ok else '>'} {lay.max_tip_shift_mm:g})",
              s["tip_shift_mm"], lay.max_tip_shift_mm, {"part": "base_frame_front"}, fix=fix_s, fixes=fixes),
        Check("base_frame.bearing", "error", bear_ok,
              f"{lay.bearing} bearings carry {s['front_n']:.1f} N (front) and {s['back_n']:.1f} N (back): "
              f"{'within' if bear_ok else 'over'} C0 / {lay.safety_factor:g} = {limit:.0f} N",
              load, limit, {"part": "base_frame_front"},
              fix="" if bear_ok else "base_frame.bearing: '608' (C0 1.37 kN)"),
    ]


def _clamp(lay, torque: float) -> Check:
    fx, _, _, _, _ = lay.foot
    r = float(np.mean([math.hypot(x, lay.foot[3]) for x, _ in lay.foot_holes])) if lay.foot_holes else 0.0
    grip = bf.RESIN_FRICTION * len(lay.foot_holes) * bf.RESIN_HOLD_N * r
    sf = grip / torque if torque > 0 else math.inf
    ok = sf >= lay.safety_factor
    return Check("base_frame.clamp", "error", ok,
                 f"the base mount's {len(lay.foot_holes)} foot screws grip the cradle with {grip / 1000:.1f} N·m "
                 f"(μ {bf.RESIN_FRICTION:g}, {bf.RESIN_HOLD_N:g} N each at {r:.0f} mm) against {torque:.0f} N·mm: "
                 f"a factor {sf:.1f}", sf, lay.safety_factor, {"part": "base_frame_cradle"},
                 fix="" if ok else "base_mount.bolt_pattern with more or larger screws; a lighter robot")


def _tipping(lay, parts, m_turn, c_turn, m_fix, c_fix, by) -> Check:
    base = by.get("rig_support") or by.get("base_frame_base")
    edge = float(base.robot_bounds()[1, 1]) if base is not None else lay.plate[3]
    over = m_turn * G * (float(c_turn[1]) - edge) + lay.push_n * (lay.tip_y - edge)
    holes = lay.plate_holes
    if lay.mounting == "table_edge":
        hold = 2 * bf.EDGE_CLAMP_N * (edge - (lay.plate[2] + lay.plate[3]) / 2)
        how = f"2 G-clamps at {bf.EDGE_CLAMP_N:g} N"
    else:
        hold = sum(bf.RESIN_HOLD_N * (edge - y) for _, y in holes)
        how = f"{len(holes)} M6 screws at {bf.RESIN_HOLD_N:g} N"
    own = m_fix * G * (edge - float(c_fix[1]))
    margin = (own + hold) / over if over > 0 else math.inf
    ok = margin >= lay.safety_factor
    return Check("base_frame.tipping", "error", ok,
                 f"about the frame's front edge (y = {edge:.0f} mm) the robot and the push overturn with "
                 f"{over:.0f} N·mm; the frame's weight holds {own:.0f} N·mm and its {how} {hold:.0f} N·mm: a margin "
                 f"of {margin:.1f}{'' if own >= over else ' (unfastened, it tips: fasten it before turning)'}",
                 margin, lay.safety_factor, {"part": "base_frame_base"},
                 fix="" if ok else "base_frame.mounting: breadboard (four M6 screws)")


def _clearance(lay, parts, by) -> Check:
    """The frame's fixed parts from the solid of revolution the turning parts sweep, and that
    solid from the table (the lowest fixed part's underside)."""
    turning = [p for p in parts if not p.fixture and (not _bench(p.entry) or p.name == "base_frame_cradle")]
    fixed = [p for p in parts if _bench(p.entry) == "base_frame" and not p.entry.get("turns")
             or p.name == "rig_support"]
    if not turning or not fixed:
        return Check("base_frame.clearance", "error", True, "base frame: nothing fixed to measure against", None,
                     lay.clearance)
    reach = max(float(p.robot_bounds()[1, 1]) for p in fixed) + NEAR_MM
    # the farthest a part reaches from the axis is at a vertex (the radius is convex); surfaces are
    # sampled on the parts that come near the frame along the axis
    tp = np.vstack([_points(p) if p.robot_bounds()[0, 1] < reach else _vertices(p) for p in turning])
    ty, tr = tp[:, 1], np.hypot(tp[:, 0], tp[:, 2])
    y0 = ty.min()
    k = ((ty - y0) // BIN_MM).astype(int)
    rmax = np.full(k.max() + 1, -1.0)
    np.maximum.at(rmax, k, tr)
    keep = rmax >= 0
    keep[(y0 + np.arange(len(rmax)) * BIN_MM) > reach] = False     # farther along the axis than NEAR_MM: not nearer
    lo = y0 + np.arange(len(rmax))[keep] * BIN_MM
    hi, rm = lo + BIN_MM, rmax[keep]
    fp = np.vstack([_points(p) for p in fixed])
    fy, fr = fp[:, 1], np.hypot(fp[:, 0], fp[:, 2])
    # the hub runs HUB_GAP off the front upright by design, inside the bearing's reach: not a clearance
    hub = (fr < bf.HUB_RADIUS + lay.clearance) & (fy > lay.front[0] - 1.0) & (fy <= lay.front[1] + 1.0)
    fy, fr = fy[~hub], fr[~hub]
    best = np.inf
    for s in range(0, len(fy), 4000):
        y, r = fy[s:s + 4000, None], fr[s:s + 4000, None]
        dy = np.maximum(0.0, np.maximum(lo[None, :] - y, y - hi[None, :]))
        dr = np.maximum(0.0, r - rm[None, :])
        best = min(best, float(np.sqrt(dy ** 2 + dr ** 2).min()))
    table = float(min(p.robot_bounds()[0, 2] for p in fixed))
    swing = float(tr.max())
    to_table = -table - swing
    measured = min(best, to_table)
    ok = measured >= lay.clearance - 1e-6
    fixes, fix = (), ""
    if not ok:
        new = math.ceil((lay.clearance + (lay.clearance - measured)) * 2) / 2
        fixes = (Fix({"base_frame.clearance_mm": new}, {"measured": measured + new - lay.clearance, "passed": True},
                     note="the axis rises and the uprights stand back by as much more"),)
        fix = f"base_frame.clearance_mm: {new:g}"
    return Check("base_frame.clearance", "error", ok,
                 f"the turning robot, mount and cradle (swing radius {swing:.1f} mm) stay {best:.1f} mm from the "
                 f"frame and {to_table:.1f} mm from the table at every angle (≥ {lay.clearance:g})",
                 measured, lay.clearance, {"part": "base_frame_front"}, fix=fix, fixes=fixes)


def _push_clear(parts, plan) -> list[Check]:
    rig = plan.rig
    block = next((p for p in parts if p.name == "rig_push_block"), None)
    disk = next((p for p in parts if p.role == "disk" and p.entry.get("station") == rig.station), None)
    if block is None or disk is None:
        return []
    b = block.robot_bounds()
    low = float(b[0, 2])
    holes = [h for d in plan.disks if d.index == rig.station for h in d.holes]
    top = max((h.z + h.diameter / 2 for h in holes), default=0.0)
    gap = low - top
    ok = gap > 0
    d = disk.robot_bounds()
    rim = float(d[1, 2])
    return [Check("rig.push_clear", "error", ok,
                  f"the push block's pad (lowest at z = {low:.2f} mm, {low - rim:.2f} mm above disk "
                  f"{rig.station + 1}'s rim before the push) stays {gap:.2f} mm above that disk's highest eyelet and "
                  f"its tendon", gap, 0.0, {"part": "rig_push_block"},
                  fix="" if ok else "rig.push_gap_mm, or push a disk whose eyelets lie lower: experiment.first_disk")]
