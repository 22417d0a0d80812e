"""`hwgen sim`: write OUT/<design>/sim/ (robot.xml and its meshes, sim.json, sim.png) from a
build, and check the MuJoCo model against hwgen's own statics.

What is compared (sim.json): for N, the actuating channel alone and the state with every channel,
the tip stiffness in the flexible direction and the tip's sag, MuJoCo's equilibrium against the
statics' (the build's stiffness.json, ``hwgen stiffness``: tensioned by the paper's protocol,
gravity toward −z, frictionless eyelets), each tendon locked exactly where the statics locks it; the same
states again from their keyframes as written (a drum that winds two tendons sets one length for
both); state N's sag against the own-weight model of the checks (the report's gravity section);
the bent robot at the most a tendon may carry; and the model stepped for 2 s under gravity from
each keyframe (finite, and how much faster than real time, on one core).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..cad.manifest import Manifest
from ..atomic import write_json
from ..model import stiffness
from . import chain, measure, mjcf, parts, reference
from .plot import plot_sim

ROBOT, SIM_JSON, SIM_PNG = "robot.xml", "sim.json", "sim.png"
AGREEMENT = 0.25                  # the issue's: MuJoCo's tip stiffness within 25 % of the statics'
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
    m, d = sim.model, sim.data
    out = {}
    for i in range(m.ntendon):
        stretch = d.ten_length[i] - m.tendon_lengthspring[i, 1]
        out[m.tendon(i).name] = float(max(stretch, 0.0) * m.tendon_stiffness[i])
    return out


def _state(sim: measure.Sim, written: mjcf.Written, ref_state: dict, exact: bool) -> dict:
    name = ref_state["state"]
    sim.keyframe(name)
    _set_locks(sim, written, name, exact)
    try:
        eq = measure.equilibrium(sim, sim.data.qpos.copy())
        k = measure.tip_stiffness(sim, eq["q"], stiffness.PUSH)
        return {"tip_n_per_mm": k, "tip_mm": measure.tip_mm(sim), "tensions_n": _tensions(sim),
                "curve": measure.centre_line(sim), "newton": {"iterations": eq["iterations"],
                                                               "residual": eq["residual"]}}
    finally:
        _set_locks(sim, written, name, False)


def compare_states(sim: measure.Sim, written: mjcf.Written, ref: reference.Reference) -> list[dict]:
    """MuJoCo against the statics, state by state (see the module's docstring)."""
    out = []
    for r in ref.states:
        exact = _state(sim, written, r, True)
        as_key = _state(sim, written, r, False)
        k_mj, k_st = exact["tip_n_per_mm"], r["tip_stiffness_n_per_mm"]
        out.append({
            "state": r["state"], "mujoco_tip_n_per_mm": k_mj, "statics_tip_n_per_mm": k_st,
            "ratio": k_mj / k_st, "within": abs(k_mj / k_st - 1) <= AGREEMENT,
            "mujoco_tip_sag_mm": -exact["tip_mm"][2], "statics_tip_sag_mm": r["tip_sag_mm"],
            "mujoco_tip_mm": exact["tip_mm"], "statics_tip_mm": r["tip_mm"],
            "mujoco_tensions_n": exact["tensions_n"], "statics_tensions_n": r["tensions_n"],
            "keyframe": {"tip_n_per_mm": as_key["tip_n_per_mm"], "tip_sag_mm": -as_key["tip_mm"][2],
                         "tensions_n": as_key["tensions_n"],
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
                       f"{s['ratio']:.2f}× the statics' {s['statics_tip_n_per_mm']:.4f} (limit ±{AGREEMENT:.0%})")
        miss = s["keyframe"]["lock_missed_by_mm"]
        if miss and max(abs(v) for v in miss.values()) > 0.01:
            worst = max(miss, key=lambda t: abs(miss[t]))
            out.append(f"state {s['state']}: its keyframe leaves {worst} {miss[worst]:+.2f} mm off the statics' lock "
                       f"(a drum winds its tendons together and sets one length for all; the statics' protocol locks "
                       f"each where it tensions it): from the keyframe, tip stiffness "
                       f"{s['keyframe']['tip_n_per_mm']:.4f} N/mm and sag {s['keyframe']['tip_sag_mm']:.1f} mm against {s['mujoco_tip_n_per_mm']:.4f} and "
                       f"{s['mujoco_tip_sag_mm']:.1f} with the statics' locks")
    m, c, _ = mjcf.combine([(b.mass_g, b.com_mm, b.inertia_g_mm2) for b in printed.tip]) if printed.tip \
        else (0.0, np.zeros(3), None)
    if abs(c[0]) > OFF_CENTRE_MM:
        out.append(f"the tensioner's {m:.0f} g sit {c[0]:+.1f} mm across the strip (x) from its centre line; the statics "
                   f"puts the tip assembly on the centre line, MuJoCo where the STLs put it, so MuJoCo's robot twists "
                   f"under its weight" + (f" (bent: the tip {bent_['mujoco_tip_mm'][0]:+.2f} mm in x)" if bent_ else ""))
    return out


def simulate(plan, folder: Path, manifest: Manifest, report: dict, out: Path, solve) -> dict:
    """Write ``out`` (robot.xml, meshes/, sim.json, sim.png) for the build in ``folder`` and return
    sim.json's content. ``solve()``: the statics of the plan's tendon states with the report's
    weights (:func:`hwgen.model.stiffness.study`), for when the build's stiffness.json cannot serve."""
    t0 = time.perf_counter()
    secs = {}
    study, source = reference.study_of(folder, plan, report.get("gravity"), solve)
    ref = reference.statics_reference(plan, report.get("gravity"), study, source=source)
    secs["statics"] = time.perf_counter() - t0
    printed = parts.read_build(folder, manifest, report)
    hinges = chain.hinges(ref.described.robot)
    springs = reference.tendon_springs(ref)
    hauled = reference.haul_in(ref)
    reach = {r["name"]: float(r.get("max_abs_delta_mm") or 0.0) for r in report.get("tendons", [])}
    for lock in hauled.values():
        for t, h in lock.items():
            reach[t] = max(reach.get(t, 0.0), abs(h))
    ratio = plan.tensioner_layout.pair.ratio if plan.tensioner_layout else 1.0
    drums = mjcf.drums_of(printed, list(plan.tensioner.channels), springs, reach, plan.tendon_material.break_load,
                          mjcf.reflected_inertia(printed, ratio), [p.name for p in plan.paths])
    states = [(s.name, s.channels) for s in stiffness.states(plan)]
    out.mkdir(parents=True, exist_ok=True)
    written = mjcf.write_robot(manifest.name, printed, hinges, drums, mjcf.Locks(states, hauled), springs,
                               folder, out)
    secs["written"] = time.perf_counter() - t0
    sim = measure.Sim.load(out / ROBOT)
    secs["loaded"] = time.perf_counter() - t0
    compared = compare_states(sim, written, ref)
    bent_ = bent(sim, ref)
    moving = [measure.dynamics(sim, s["state"]) for s in compared]
    secs["measured"] = time.perf_counter() - t0
    N = next((s for s in compared if s["state"] == "N"), None)
    g = report.get("gravity", {})
    facing = reference.orientation()
    sag_model = g.get("cases", {}).get("-z" if facing["gravity"][2] < 0 else "+z", {})
    m = sim.model
    result = {
        "design": manifest.name,
        "model": "the strip a chain of rigid links on elastic hinges sprung as hwgen's statics springs it "
                 f"(a hinge about x at most every {chain.SIM_H_MAX:g} mm, one about y and one about z between each "
                 "pair of disks); disks, tensioner and base as measured from their STLs; tendons as one-way "
                 "spatial-tendon springs through the measured eyelets; a drum per channel on a servo (MuJoCo "
                 f"{_mujoco_version()}, {m.opt.timestep * 1e3:g} ms Euler steps)",
        "assumptions": [
            facing["words"], "eyelets without friction (the statics' friction bound " + reference.FRICTION + ")",
            "each state tensioned and locked by the paper's protocol (hwgen.model.protocol) in that orientation; "
            "the statics from " + ref.source,
            "equilibria by Newton's method on MuJoCo's own forces (central differences); stiffness the tangent "
            "j K⁻¹ jᵀ at the tip site, as the statics takes it from its Hessian",
            "states compared with each tendon locked where the statics locks it; the keyframes' own figures beside",
            "strip: the report's measured height, thickness and grams per millimetre; E, G and the hubs' sections "
            "the statics'"],
        "orientation": facing, "friction": reference.FRICTION, "statics_from": ref.source,
        "agreement_limit": AGREEMENT,
        "mujoco": {"version": _mujoco_version(), "timestep_s": m.opt.timestep, "integrator": "Euler",
                   "nbody": m.nbody, "nv": m.nv, "ntendon": m.ntendon, "nu": m.nu, "nkey": m.nkey,
                   "hinges": {k: sum(getattr(h, k) is not None for h in hinges) for k in ("flex", "twist", "side")},
                   "longest_link_mm": chain.SIM_H_MAX, "rayleigh_s": mjcf.RAYLEIGH_S},
        "states": compared,
        "sag": {"state": "N", "mujoco_tip_sag_mm": N["mujoco_tip_sag_mm"] if N else None,
                "statics_tip_sag_mm": N["statics_tip_sag_mm"] if N else None,
                "sag_model_tip_sag_mm": sag_model.get("tip_sag_mm"),
                "sag_model": g.get("model")},
        "bent": bent_,
        "dynamics": moving,
        "eyelets": eyelet_offsets(sim, printed),
        "tendons": [{"name": t, "channel": printed.runs[t].channel if t in printed.runs else None,
                     "spring_n_per_mm": springs[t], "rest_length_mm": written.rest_mm.get(t),
                     "sites": mjcf.tendon_sites(printed, t)} for t in springs],
        "drums": [{"channel": d.channel, "tendons": list(d.tendons), "senses": list(d.senses),
                   "travel_mm": d.travel_mm, "kp_n_per_m": d.kp_n_per_m, "armature_kg": d.armature_kg}
                  for d in written.drums],
        "keyframes": written.keyframes,
        "keyframe_lock_missed_by_mm": written.residual_mm,
    }
    result["findings"] = _findings(compared, written, printed, bent_)
    result["ok"] = (all(s["within"] for s in compared) and all(d["finite"] for d in moving)
                    and (result["eyelets"]["max_offset_mm"] or 0.0) <= SITE_TOL_MM)
    result["seconds"] = {**secs, "total": time.perf_counter() - t0}
    write_json(out / SIM_JSON, result)
    plot_sim(result, out / SIM_PNG)
    return result
