"""`hwgen sim`: write OUT/<design>/sim/ (robot.xml and its meshes, sim.json, sim.png) from a
build, and check the MuJoCo model against hwgen's own statics and against an independent rod.

What is compared (sim.json): for N, the actuating channel alone and the state with every channel,
the tip stiffness pushed along z (and, beside it, normal to the strip's face at the tip) and the
tip's sag, MuJoCo's equilibrium against the statics' (the build's stiffness.json, ``hwgen
stiffness``: tensioned by the paper's protocol, gravity toward −z, frictionless eyelets), each
tendon locked exactly where the statics locks it; the same states again from their keyframes as
written (a drum that winds two tendons sets one length for both); state N's sag against the
own-weight model of the checks (the report's gravity section); the bent robot at the most a
tendon may carry. ``reference``: state N and the bent robot against an independent Cosserat rod
built from the files (:mod:`hwgen.sim.independent`). What the statics cannot say: ``modes``, each
state's first bending mode from robot.xml's linearisation, checked by a ring-down
(:mod:`hwgen.sim.modes`), the hinges damped from the strip's loss factor; ``driven``, the
actuating pair driven to the sweep's angle with the stiffening tendons locked and slack
(:mod:`hwgen.sim.drive`); and the model stepped for 2 s under gravity from each keyframe (finite,
and how much faster than real time, on one core). The gates: :mod:`hwgen.sim.limits`.
"""
from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np

from ..cad.manifest import Manifest
from ..atomic import write_json
from ..checks.studies import TensionStudy, tendon_reaches
from ..model import steel, stiffness
from ..model.gravity import Gravity
from . import chain, drive, independent, limits, measure, mjcf, modes, parts, reference
from .plot import plot_sim

ROBOT, SIM_JSON, SIM_PNG = "robot.xml", "sim.json", "sim.png"
AGREEMENT = limits.STATICS
SITE_TOL_MM = 0.05                # an eyelet site this close to the measured eyelet, robot straight
OFF_CENTRE_MM = 0.5               # a tip assembly's centre of mass this far across the strip is worth a word
TENSION_TOL_N = 0.05              # a locked tendon's tension this far from the statics' is worth a word


def _mujoco_version() -> str:
    import mujoco
    return mujoco.__version__


def _set_locks(sim: measure.Sim, written: mjcf.Written, state: str, exact: bool) -> None:
    """Each tendon's rest length as written, or moved so it is locked exactly where the statics
    locks it in ``state`` (what the state's drum setting leaves it off by)."""
    m = sim.model
    for t, rest in written.rest_mm.items():
        miss = written.residual_mm.get(state, {}).get(t, 0.0) if exact else 0.0
        m.tendon_lengthspring[m.tendon(t).id, 1] = (rest - miss) * mjcf.MM


def _tensions(sim: measure.Sim) -> dict:
    """Each spatial tendon's tension now, N (the drives' fixed tendons carry none)."""
    m, d = sim.model, sim.data
    out = {}
    for i in range(m.ntendon):
        if m.tendon_stiffness[i] > 0:
            stretch = d.ten_length[i] - m.tendon_lengthspring[i, 1]
            out[m.tendon(i).name] = float(max(stretch, 0.0) * m.tendon_stiffness[i])
    return out


def _state(sim: measure.Sim, written: mjcf.Written, ref_state: dict, exact: bool, q0=None) -> dict:
    """One state at rest, locked exactly as the statics locks it or as its keyframe does: from its
    keyframe with gravity brought in, or by Newton's method from ``q0`` (a nearby equilibrium)."""
    name = ref_state["state"]
    sim.keyframe(name)
    _set_locks(sim, written, name, exact)
    try:
        if q0 is None:
            eq = measure.equilibrium(sim, sim.data.qpos.copy())
            q, its, left = eq["q"], eq["iterations"], eq["residual"]
        else:
            q, its, left = measure.settle(sim, q0)
        normal = sim.data.site_xmat[sim.tip].reshape(3, 3)[:, 2].copy()
        k, k_normal = measure.tip_stiffnesses(sim, q, [stiffness.PUSH, normal])
        return {"tip_n_per_mm": k, "tip_normal_n_per_mm": k_normal, "tip_mm": measure.tip_mm(sim),
                "tensions_n": _tensions(sim), "curve": measure.centre_line(sim), "q": q,
                "newton": {"iterations": its, "residual": left}}
    finally:
        _set_locks(sim, written, name, False)


def compare_states(sim: measure.Sim, written: mjcf.Written, ref: reference.Reference,
                   start: dict | None = None) -> list[dict]:
    """MuJoCo against the statics, state by state (see the module's docstring); each entry's
    ``keyframe`` holds the state's equilibrium as its keyframe locks it (``q``, dropped from
    sim.json), found from the exact one; ``start``: state -> an equilibrium already found."""
    out = []
    for r in ref.states:
        exact = _state(sim, written, r, True, (start or {}).get(r["state"]))
        as_key = _state(sim, written, r, False, exact["q"])
        k_mj, k_st = exact["tip_n_per_mm"], r["tip_stiffness_n_per_mm"]
        out.append({
            "state": r["state"], "mujoco_tip_n_per_mm": k_mj, "statics_tip_n_per_mm": k_st,
            "mujoco_tip_normal_n_per_mm": exact["tip_normal_n_per_mm"],
            "ratio": k_mj / k_st, "within": abs(k_mj / k_st - 1) <= AGREEMENT,
            "mujoco_tip_sag_mm": -exact["tip_mm"][2], "statics_tip_sag_mm": r["tip_sag_mm"],
            "mujoco_tip_mm": exact["tip_mm"], "statics_tip_mm": r["tip_mm"],
            "mujoco_tensions_n": exact["tensions_n"], "statics_tensions_n": r["tensions_n"],
            "keyframe": {"tip_n_per_mm": as_key["tip_n_per_mm"], "tip_sag_mm": -as_key["tip_mm"][2],
                         "tensions_n": as_key["tensions_n"], "q": as_key["q"],
                         "lock_missed_by_mm": written.residual_mm.get(r["state"], {})},
            "newton": exact["newton"], "mujoco_curve": exact["curve"],
            "statics_curve": reference.downsample(r["curve"])})
    return out


def bent(sim: measure.Sim, ref: reference.Reference) -> dict:
    """The bent case of the reference in MuJoCo: from keyframe N, the tendon pulled with its tension."""
    b = ref.bent
    if not b:
        return {}
    sim.keyframe("N")
    eq = measure.equilibrium(sim, sim.data.qpos.copy(), measure.Extra(pulls=((b["tendon"], b["tension_n"]),)))
    tip = measure.tip_mm(sim)
    return {"tendon": b["tendon"], "tension_n": b["tension_n"], "mujoco_tip_mm": tip, "statics_tip_mm": b["tip_mm"],
            "distance_mm": float(np.linalg.norm(np.subtract(tip, b["tip_mm"]))),
            "in_plane_distance_mm": float(np.hypot(tip[1] - b["tip_mm"][1], tip[2] - b["tip_mm"][2])),
            "mujoco_curve": measure.centre_line(sim), "statics_curve": reference.downsample(b["curve"]),
            "newton": {"iterations": eq["iterations"], "residual": eq["residual"]}}


def eyelet_offsets(sim: measure.Sim, printed: parts.Printed) -> dict:
    """Each eyelet site in the straight robot (the model's default pose) against the measured eyelet, mm."""
    import mujoco
    m, d = sim.model, sim.data
    mujoco.mj_resetData(m, d)
    mujoco.mj_forward(m, d)
    off = [float(np.linalg.norm(d.site(mjcf.eyelet_site(e)).xpos / mjcf.MM - e.centre_mm)) for e in printed.eyelets]
    return {"sites": len(off), "measured": sum(e.measured for e in printed.eyelets),
            "max_offset_mm": max(off) if off else None, "tolerance_mm": SITE_TOL_MM}


def _findings(states: list, written: mjcf.Written, printed: parts.Printed, bent_: dict) -> list[str]:
    out = list(written.notes)
    for s in states:
        off = {t: (s["mujoco_tensions_n"].get(t, 0.0), v) for t, v in s["statics_tensions_n"].items()
               if abs(s["mujoco_tensions_n"].get(t, 0.0) - v) > TENSION_TOL_N}
        if off:
            out.append(f"state {s['state']}: MuJoCo's locked tendons carry " + ", ".join(
                f"{t} {mj:.2f} N against the statics' {v:.2f}" for t, (mj, v) in off.items()))
        if not s["within"]:
            out.append(f"state {s['state']}: MuJoCo's tip stiffness {s['mujoco_tip_n_per_mm']:.4f} N/mm is "
                       f"{s['ratio']:.3f}× the statics' {s['statics_tip_n_per_mm']:.4f} (limit ±{AGREEMENT:.0%})")
        miss = s["keyframe"]["lock_missed_by_mm"]
        if miss and max(abs(v) for v in miss.values()) > 0.01:
            worst = max(miss, key=lambda t: abs(miss[t]))
            out.append(f"state {s['state']}: its keyframe leaves {worst} {miss[worst]:+.2f} mm off the statics' lock "
                       f"(a drum winds its tendons together and sets one length for all; the statics' protocol locks "
                       f"each where it tensions it): from the keyframe, tip stiffness "
                       f"{s['keyframe']['tip_n_per_mm']:.4f} N/mm and sag {s['keyframe']['tip_sag_mm']:.1f} mm against {s['mujoco_tip_n_per_mm']:.4f} and "
                       f"{s['mujoco_tip_sag_mm']:.1f} with the statics' locks")
    m, c, _ = mjcf.combine(parts.tip_masses(printed)) if printed.tip else (0.0, np.zeros(3), None)
    if abs(c[0]) > OFF_CENTRE_MM:
        out.append(f"the tensioner's {m:.0f} g (its bought metal included) sit {c[0]:+.1f} mm across the strip (x) "
                   f"from its centre line; the statics puts the tip assembly on the centre line, MuJoCo where the "
                   f"STLs put it, so MuJoCo's robot twists under its weight"
                   + (f" (bent: the tip {bent_['mujoco_tip_mm'][0]:+.2f} mm in x)" if bent_ else ""))
    return out


def _drive_findings(d: dict) -> list[str]:
    """What the drive shows that the statics' sweep does not (see :mod:`hwgen.sim.drive`)."""
    if not d:
        return []
    lo = d["cases"]["locked"]
    slack = [t for t in d["locked_tension_change_n"] if lo["tensions_n"][t] <= 1e-9]
    out = []
    if slack:
        before = ", ".join(f"{t} {lo['tensions_before_n'][t]:.2f} N" for t in slack)
        out.append(f"driven to {d['locked_angle_deg']:.0f}°, {', '.join(slack)} {'goes' if len(slack) == 1 else 'go'} "
                   f"slack: locked by the protocol "
                   f"under the robot's weight at {before}, less than their paths shorten times their springs (the "
                   f"check's weightless sweep locks them at their working tension)")
    return out


def _rig(plan, printed: parts.Printed, ref: reference.Reference, report: dict) -> tuple[mjcf.Rig, mjcf.Locks, dict]:
    """What robot.xml is made of (its damping still to be set): (rig, locks, springs)."""
    springs = reference.tendon_springs(ref)
    hauled = reference.haul_in(ref)
    reach = {t.name: t.max_abs_delta_mm for t in tendon_reaches(report)}
    for lock in hauled.values():
        for t, h in lock.items():
            reach[t] = max(reach.get(t, 0.0), abs(h))
    ratio = plan.tensioner_layout.pair.ratio if plan.tensioner_layout else 1.0
    drums = mjcf.drums_of(printed, list(plan.tensioner.channels), springs, reach, plan.tendon_material.break_load,
                          mjcf.reflected_inertia(printed, ratio), [p.name for p in plan.paths],
                          plan.tensioner.actuating_channel)
    states = [(s.name, s.channels) for s in stiffness.states(plan)]
    rig = mjcf.Rig(chain.hinges(ref.described.robot), drums, mjcf.TIMESTEP / 2)
    return rig, mjcf.Locks(states, hauled), springs


def _write_damped(name: str, printed: parts.Printed, made: tuple, loss_factor: float, folder: Path,
                  out: Path) -> tuple[measure.Sim, mjcf.Written, mjcf.Rig, dict, np.ndarray]:
    """robot.xml written twice: once to find state N's first bending mode as the model has it, then
    with its hinges damped at β = η/ω₁ (:mod:`hwgen.sim.mjcf`). Returns the loaded model, what was
    written, the rig, sim.json's ``damping`` and state N at rest (the damping moves no equilibrium)."""
    rig, locks, springs = made
    mjcf.write_robot(name, printed, rig, locks, springs, folder, out)
    sim = measure.Sim.load(out / ROBOT)
    sim.keyframe("N")
    q = measure.equilibrium(sim, sim.data.qpos.copy())["q"]
    hz = modes.undamped_hz(sim, q)
    rig = rig.settled(loss_factor / (2 * math.pi * hz))
    written = mjcf.write_robot(name, printed, rig, locks, springs, folder, out)
    damping = {"loss_factor": loss_factor, "from": "backbone.loss_factor", "state": "N", "first_mode_hz": hz,
               "beta_s": rig.beta_s, "timestep_s": rig.timestep_s,
               "words": "each strip hinge damped β = η/ω₁ times its stiffness: at state N's first bending mode a "
                        "viscous hinge dissipates per cycle what the laminate's loss factor η says; tendons and "
                        "gravity undamped, so a mode's damping ratio is βω/2 times the share of its stiffness the "
                        "strip holds (η/2 times it at ω₁)"}
    return measure.Sim.load(out / ROBOT), written, rig, damping, q


def state_modes(sim: measure.Sim, compared: list) -> dict:
    """sim.json's ``modes``: per compared state, its first bending mode about its keyframe's
    equilibrium, and the ring-down that checks it."""
    out = {}
    for s in compared:
        sim.keyframe(s["state"])
        q = s["keyframe"]["q"]
        mode = modes.first_bending(sim, q)
        ring = modes.ring_down(sim, q, mode)
        agree = all(ring[k] is not None and abs(ring[k] / mode[k] - 1) <= limits.RING_DOWN
                    for k in ("frequency_hz", "damping_ratio"))
        out[s["state"]] = {"frequency_hz": mode["frequency_hz"], "damping_ratio": mode["damping_ratio"],
                           "undamped_hz": mode["undamped_hz"], "ring_down": ring, "agree": agree}
        sim.keyframe(s["state"])
    return out


def _driven(sim: measure.Sim, written: mjcf.Written, plan, ref: reference.Reference, report: dict,
            compared: list) -> dict:
    if not ref.bent:
        return {}
    act = [s.name for s in stiffness.states(plan) if s.channels == (plan.tensioner.actuating_channel,)]
    if not act or act[0] == ref.all_tendons:
        return {}
    at = {s["state"]: s["keyframe"]["q"] for s in compared}
    if ref.all_tendons not in at or act[0] not in at:
        return {}
    cases = {"locked": (ref.all_tendons, at[ref.all_tendons]), "unlocked": (act[0], at[act[0]])}
    out = drive.driven(sim, written, plan, ref.bent["tendon"], cases, _tensions)
    if out:
        out["sweep"] = drive.against_sweep(out, TensionStudy.of(report.get("tension")))
    return out


def _measure(sim: measure.Sim, made: tuple, plan, ref: reference.Reference, report: dict,
             printed: parts.Printed) -> dict:
    """Every measurement of the loaded model (see the module's docstring); ``made``: what was
    written, and state N at rest."""
    written, q_n = made
    compared = compare_states(sim, written, ref, {"N": q_n})
    bent_ = bent(sim, ref)
    N = next((s for s in compared if s["state"] == "N"), None)
    mujoco_tips = {"N": N["mujoco_tip_mm"]} if N else {}
    if bent_:
        mujoco_tips[f"{bent_['tendon']}_pulled"] = bent_["mujoco_tip_mm"]
    ref_ = independent.reference(printed, Gravity.of(report["gravity"]), plan.backbone.shear_modulus_gpa * 1e3,
                                 mujoco_tips,
                                 (bent_["tendon"], bent_["tension_n"]) if bent_ else None) if N else {}
    return {"states": compared, "bent": bent_, "reference": ref_, "modes": state_modes(sim, compared),
            "driven": _driven(sim, written, plan, ref, report, compared),
            "dynamics": [measure.dynamics(sim, s["state"]) for s in compared]}


def _sag(N: dict | None, report: dict) -> dict:
    g = Gravity.of(report.get("gravity"))
    facing = reference.orientation()
    sag_model = g.cases.get("-z" if facing["gravity"][2] < 0 else "+z", {}) if g else {}
    return {"state": "N", "mujoco_tip_sag_mm": N["mujoco_tip_sag_mm"] if N else None,
            "statics_tip_sag_mm": N["statics_tip_sag_mm"] if N else None,
            "sag_model_tip_sag_mm": sag_model.get("tip_sag_mm"), "sag_model": g.model if g else None}


def _mass(sim: measure.Sim, printed: parts.Printed) -> dict:
    """robot.xml's mass against the printed parts' it holds (the STLs' and the strip's links'): the
    difference is the bought metal (and 1 mg per take-up)."""
    m = sim.model
    total = float(m.body_mass.sum()) / mjcf.KG
    strip = float(sum(m.body_mass[i] for i in range(m.nbody) if m.body(i).name.startswith("strip_"))) / mjcf.KG
    printed_g = sum(b.mass_g for b in (*printed.base, *printed.disks.values(), *printed.tip)) + strip
    return {"total_g": total, "printed_g": printed_g, "over_printed_g": total - printed_g,
            "bought_metal_g": sum(p.mass_g for p in printed.bought), "bought_metal_pieces": len(printed.bought)}


def _ok(result: dict) -> bool:
    ref_ = result["reference"]
    return (all(s["within"] for s in result["states"]) and all(d["finite"] for d in result["dynamics"])
            and (result["eyelets"]["max_offset_mm"] or 0.0) <= SITE_TOL_MM
            and (not ref_ or ref_["within"]) and all(m["agree"] for m in result["modes"].values()))


def simulate(plan, folder: Path, manifest: Manifest, report: dict, out: Path, solve) -> dict:
    """Write ``out`` (robot.xml, meshes/, sim.json, sim.png) for the build in ``folder`` and return
    sim.json's content. ``solve()``: the statics of the plan's tendon states with the report's
    weights (:func:`hwgen.model.stiffness.study`), for when the build's stiffness.json cannot serve."""
    t0 = time.perf_counter()
    secs = {}
    weighed = Gravity.of(report.get("gravity"))
    study, source = reference.study_of(folder, plan, weighed, solve)
    ref = reference.statics_reference(plan, weighed, study, source=source)
    secs["statics"] = time.perf_counter() - t0
    printed = dataclasses.replace(parts.read_build(folder, manifest, report), bought=steel.tip_pieces(plan))
    out.mkdir(parents=True, exist_ok=True)
    made = _rig(plan, printed, ref, report)
    sim, written, rig, damping, q_n = _write_damped(manifest.name, printed, made, plan.backbone.loss_factor,
                                                    folder, out)
    secs["written"] = time.perf_counter() - t0
    measured = _measure(sim, (written, q_n), plan, ref, report, printed)
    secs["measured"] = time.perf_counter() - t0
    N = next((s for s in measured["states"] if s["state"] == "N"), None)
    m = sim.model
    facing = reference.orientation()
    result = {
        "design": manifest.name,
        "model": "the strip a chain of rigid links on elastic hinges sprung as hwgen's statics springs it "
                 f"(a hinge about x at most every {chain.SIM_H_MAX:g} mm, one about y and one about z between each "
                 "pair of disks), damped from the strip's loss factor; disks, tensioner and base as measured from "
                 "their STLs, the tensioner's bought metal added (hwgen.model.steel); tendons as one-way "
                 "spatial-tendon springs through the measured eyelets; a drum per channel on a servo, the actuating "
                 "pair's with a drive; a table the disks collide with (MuJoCo "
                 f"{_mujoco_version()}, {m.opt.timestep * 1e3:g} ms Euler steps)",
        "assumptions": [
            facing["words"], "eyelets without friction (the statics' friction bound " + reference.FRICTION + ")",
            "each state tensioned and locked by the paper's protocol (hwgen.model.protocol) in that orientation; "
            "the statics from " + ref.source,
            "equilibria by Newton's method on MuJoCo's own forces (central differences); stiffness the tangent "
            "j K⁻¹ jᵀ at the tip site, as the statics takes it from its Hessian",
            "states compared with each tendon locked where the statics locks it; the keyframes' own figures beside",
            "strip: the report's measured height, thickness and grams per millimetre; E, G and the hubs' sections "
            "the statics'",
            "damping: the strip's hinges only, β = η/ω₁ (backbone.loss_factor at state N's first bending mode); "
            "tendons, servos' positions and gravity undamped",
            "the tensioner's bought metal (dowels, screws, nuts) from the model (hwgen.model.steel: design data, the "
            "files hold no steel), each piece where the layout puts it",
            "the table where the mount's foot stands, its edge at the foot's front (the robot overhanging it)"],
        "orientation": facing, "push": {"direction": list(stiffness.PUSH), "words": stiffness.PUSH_WORDS},
        "friction": reference.FRICTION, "statics_from": ref.source,
        "agreement_limit": AGREEMENT,
        "mujoco": {"version": _mujoco_version(), "timestep_s": m.opt.timestep, "integrator": "Euler",
                   "nbody": m.nbody, "nv": m.nv, "ntendon": m.ntendon, "nu": m.nu, "nkey": m.nkey,
                   "hinges": {k: sum(getattr(h, k) is not None for h in rig.hinges) for k in ("flex", "twist", "side")},
                   "longest_link_mm": chain.SIM_H_MAX, "mass": _mass(sim, printed),
                   "table": {"z_mm": printed.table[0], "edge_y_mm": printed.table[4]} if printed.table else None},
        "damping": damping,
        **{k: v for k, v in measured.items() if k not in ("states", "dynamics")},
        "states": [{**s, "keyframe": {k: v for k, v in s["keyframe"].items() if k != "q"}} for s in measured["states"]],
        "sag": _sag(N, report),
        "dynamics": measured["dynamics"],
        "eyelets": eyelet_offsets(sim, printed),
        "tendons": [{"name": t, "channel": printed.runs[t].channel if t in printed.runs else None,
                     "spring_n_per_mm": made[2][t], "rest_length_mm": written.rest_mm.get(t),
                     "sites": mjcf.tendon_sites(printed, t)} for t in made[2]],
        "drums": [{"channel": d.channel, "tendons": list(d.tendons), "senses": list(d.senses),
                   "travel_mm": d.travel_mm, "kp_n_per_m": d.kp_n_per_m, "armature_kg": d.armature_kg,
                   "drive": d.drive} for d in written.drums],
        "keyframes": written.keyframes,
        "keyframe_lock_missed_by_mm": written.residual_mm,
    }
    result["findings"] = (_findings(measured["states"], written, printed, measured["bent"])
                          + _drive_findings(measured["driven"]))
    result["ok"] = _ok(result)
    result["seconds"] = {**secs, "total": time.perf_counter() - t0}
    write_json(out / SIM_JSON, result)
    plot_sim(result, out / SIM_PNG)
    return result
