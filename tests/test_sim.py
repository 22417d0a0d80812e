"""`hwgen sim`: the MuJoCo model of the printed robot, read back with MuJoCo and measured.

The quick tests build no part: the hinge chain springs the strip exactly as the statics does and
bends as a cantilever, and the statics the sim is checked against is ``hwgen stiffness``'s. The
slow ones run ``hwgen sim`` on a copy of each shipped design's session build and read what it
wrote: robot.xml loaded by MuJoCo, its eyelet sites against the report's measured eyelets, its
tendons against the YAML, its keyframes, 2 s of dynamics, the tip stiffness against the statics
and against pushing robot.xml's tip."""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from hwgen import params
from hwgen.model import statics as st
from hwgen.model import stiffness
from hwgen.model.gravity import Gravity, PointWeight, StripWeight, TipWeight
from hwgen.model.plan import make_plan
from hwgen.sim import chain, limits, measure, reference

from .clirunner import hwgen

ROOT = Path(__file__).resolve().parents[1]
DESIGNS = ["prototype", "paper-table2"]


def _plan(name: str):
    return make_plan(params.read(ROOT / "params" / f"{name}.yaml").design)


# ------------------------------------------------------------------ quick: no build

def test_the_chain_springs_the_strip_as_the_statics_does():
    """Summed over each stretch between two rigid plates, the chain's hinges have the statics'
    compliance about every axis, at the sim's link length; no hinge sits inside a plate."""
    desc = stiffness.describe(_plan("prototype"))
    model = st.Model(desc.robot, chain.SIM_H_MAX)
    hinges = chain.hinges(desc.robot)
    comp = model.compliance[model.joint_seg]
    flex = sum(1.0 / h.flex for h in hinges if h.flex)
    twist = sum(1.0 / h.twist for h in hinges if h.twist)
    side = sum(1.0 / h.side for h in hinges if h.side)
    assert flex == pytest.approx(comp[:, 0].sum(), rel=1e-12)
    assert twist == pytest.approx(comp[:, 1].sum(), rel=1e-12)
    assert side == pytest.approx(comp[:, 2].sum(), rel=1e-12)
    assert sum(h.flex is not None for h in hinges) == len(model.joint_seg)
    assert max(np.diff([0.0] + [h.s for h in hinges])) <= 22.5          # the links are shorter than a disk gap
    plates = [sp for sp in desc.robot.stiffening.flex if math.isinf(sp.ei)]
    assert not [h.s for h in hinges for sp in plates if sp.start < h.s < sp.end]
    n_twist = sum(h.twist is not None for h in hinges)
    assert n_twist == sum(h.side is not None for h in hinges) == len(_plan("prototype").disks) - 1


def _bare_strip_xml(robot: st.Robot) -> str:
    """A bare strip as robot.xml chains it (no disks), clamped at the base, weightless."""
    hs = chain.hinges(robot)
    L = robot.length
    parts = ['<mujoco><option gravity="0 0 0"/><worldbody>']
    origins = [0.0] + [h.s for h in hs]
    ends = [h.s for h in hs] + [L]
    sec = robot.section
    for i, (o, b) in enumerate(zip(origins, ends)):
        parts.append(f'<body pos="0 {(o - (origins[i - 1] if i else 0.0)) * 1e-3} 0">')
        if i:
            h = hs[i - 1]
            for axis, k in (("1 0 0", h.flex), ("0 1 0", h.twist), ("0 0 1", h.side)):
                if k:
                    parts.append(f'<joint type="hinge" axis="{axis}" stiffness="{k * 1e-3}"/>')
        parts.append(f'<geom type="box" size="{sec.height / 2e3} {(b - o) / 2e3} {sec.thickness / 2e3}" '
                     f'pos="0 {(b - o) / 2e3} 0" mass="{1e-3 * 0.05 * (b - o)}"/>')
        if i == len(origins) - 1:
            parts.append(f'<site name="tip" pos="0 {(b - o) * 1e-3} 0"/>')
    parts.append("</body>" * len(origins) + "</worldbody></mujoco>")
    return "".join(parts)


def _chain_sim(robot: st.Robot) -> measure.Sim:
    m = mujoco.MjModel.from_xml_string(_bare_strip_xml(robot))
    return measure.Sim(m, mujoco.MjData(m), m.site("tip").id, np.zeros(3))


def test_a_bare_strip_chain_bends_as_a_cantilever_and_twists_as_its_section():
    """The chain of a bare strip, loaded in MuJoCo: tip stiffness 3EI/L³ in the flexible
    direction (a hinge every few millimetres), torque over twist GJ/L."""
    sec = st.Section(E=50000.0, G=4000.0, height=60.0, thickness=0.59, lin_density=0.05)
    robot = st.Robot(270.0, sec)
    sim = _chain_sim(robot)
    m, q, L = sim.model, sim.model.qpos0.copy(), robot.length
    assert measure.tip_stiffness(sim, q, (0, 0, 1)) == pytest.approx(3 * sec.ei_flex / L ** 3, rel=5e-3)
    K = measure.stiffness_matrix(sim, q, measure.NONE)
    twist = [m.jnt_dofadr[j] for j in range(m.njnt) if np.allclose(m.jnt_axis[j], (0, 1, 0))]
    assert 1.0 / np.linalg.inv(K)[np.ix_(twist, twist)].sum() == pytest.approx(sec.gj / L * 1e-3, rel=1e-9)


def test_a_chain_held_by_plates_every_disk_gap_bends_both_ways_as_the_statics():
    """With rigid plates every 22.5 mm, as the disks hold the strip, the chain's tip stiffness
    matches the statics' (1.5 mm segments) in the flexible and the stiff direction: one hinge
    about z per gap is enough where a gap is a twelfth of the strip (over the bare strip's
    whole length it would be 4EI/L³, not 3EI/L³)."""
    sec = st.Section(E=50000.0, G=4000.0, height=60.0, thickness=0.59, lin_density=0.05)
    plates = tuple(st.Span(max(0.0, y - 1.5), min(270.0, y + 1.5), math.inf) for y in np.arange(0, 270.1, 22.5))
    robot = st.Robot(270.0, sec, st.Stiffening(plates, plates, plates))
    sim = _chain_sim(robot)
    eq = st.solve(st.Model(robot), st.Loads())
    for u in ((0, 0, 1), (1, 0, 0)):
        assert measure.tip_stiffness(sim, sim.model.qpos0.copy(), u) == pytest.approx(
            eq.point_stiffness(270.0, u), rel=0.01)


@pytest.fixture(scope="module")
def prototype_study():
    """The prototype's plan and its statics in the sim's orientation (every state), solved once."""
    plan = _plan("prototype")
    return plan, stiffness.study(plan, orientations=[reference.ORIENTATION])


def test_the_reference_is_hwgen_stiffness(prototype_study):
    """What the sim is checked against is what `hwgen stiffness` reports in the orientation the
    sim's world has (gravity −z), frictionless: the same tip stiffness, sag and tensions per
    state, every state's locks; the bent case pulls the actuating tendon that lifts the robot."""
    plan, study = prototype_study
    ref = reference.statics_reference(plan, None, study, bend_tension_n=10.0)
    names = [s["state"] for s in ref.states]
    full = max(stiffness.states(plan), key=lambda s: len(s.channels)).name
    assert names == ["N", plan.tensioner.actuating_channel, full] and ref.all_tendons == full
    tips = stiffness.tip_stiffness(study)
    entries = {(e["state"], e["orientation"], e["friction"]): e for e in study["states"]}
    for s in ref.states:
        e = entries[(s["state"], "gravity -z", "none")]
        assert s["tip_stiffness_n_per_mm"] == tips[(s["state"], "gravity -z", "none")]
        assert s["tip_sag_mm"] == pytest.approx(-e["tip_z_mm"], abs=1e-9)
        assert s["tip_mm"][0] == pytest.approx(e["tip_x_mm"], abs=1e-9)
        assert s["tensions_n"] == e["tensions_n"]
    assert ref.locks == {s.name: entries[(s.name, "gravity -z", "none")]["locks_mm"] for s in stiffness.states(plan)}
    assert set(ref.locks[full]) == {p.name for p in plan.paths}
    b = ref.bent
    assert b["tendon"] in {p.name for p in plan.paths if p.channel == plan.tensioner.actuating_channel}
    assert b["tension_n"] == 10.0 and b["tip_mm"][2] > ref.states[0]["tip_mm"][2] + 50     # it lifts the tip
    assert stiffness.ORIENTATIONS[reference.ORIENTATION] == (0.0, 0.0, -1.0) == stiffness.ORIENTATIONS[
        stiffness.REFERENCE]                           # robot.xml's gravity, and the statics' headline orientation


def test_the_builds_statics_serve_only_when_they_hold_every_state_from_the_same_weights(tmp_path, prototype_study):
    """study_of reads stiffness.json when it has every state in the sim's orientation from the
    same weights, and solves the statics again when it has a state fewer, the other orientations
    only, other weights, a skipped statics or no file."""
    plan, full = prototype_study
    solved = []

    def solve():
        solved.append(1)
        return full

    def served(content, measured=None) -> str:
        path = tmp_path / reference.STUDY_FILE
        path.unlink(missing_ok=True)
        if content is not None:
            path.write_text(json.dumps(content))
        study, source = reference.study_of(tmp_path, plan, measured, solve)
        assert json.loads(json.dumps(study)) == json.loads(json.dumps(full))
        return source

    assert served(full) == "the build's stiffness.json" and not solved
    heavier = stiffness.describe(plan).masses
    heavier = {**heavier, "tip_assembly": {**heavier["tip_assembly"], "mass_g": 2 * heavier["tip_assembly"]["mass_g"]}}
    tip = heavier["tip_assembly"]
    # the weights the statics reads; the section's strip figures (its modulus, section, spans) are the sim's
    measured = Gravity(model="", E_mpa=0.0, height_mm=0.0, thickness_mm=0.0, length_mm=0.0, spans=(), cases={},
                       strip=StripWeight(part="backbone", mass_g=0.0, y_mm=(0.0, 0.0), lambda_g_mm=heavier["strip_g_per_mm"]),
                       disks=tuple(PointWeight(**d) for d in heavier["disks"]),
                       tip=TipWeight(mass_g=tip["mass_g"], a_mm=tip["a_mm"], z_mm=tip["b_mm"]), document={})
    for content, why, m in (({**full, "states": [e for e in full["states"] if e["state"] != "AC2"]}, "state AC2", None),
                            ({**full, "states": [{**e, "orientation": "weightless"} for e in full["states"]]},
                             "state N", None),
                            (full, "weights", measured),
                            ({"skipped": "too many coordinates"}, "too many coordinates", None),
                            (None, "cannot be read", None)):
        assert why in served(content, m)
    assert len(solved) == 5


def test_hwgen_sim_refuses_a_missing_file_in_one_line(tmp_path):
    r = hwgen("sim", str(tmp_path / "nope.yaml"), "--out", str(tmp_path / "out"))
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr and "nope.yaml" in r.stderr
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_the_sims_help_names_its_gates():
    """`hwgen sim --help` states the gates hwgen.sim.limits holds, as the docs do."""
    import os

    r = hwgen("sim", "--help", env={**os.environ, "COLUMNS": "400"})
    assert r.returncode == 0, r.stderr
    for gate in limits.words().values():
        assert gate in r.stdout


# ------------------------------------------------------------------ slow: on each shipped design's build

@pytest.fixture(scope="module")
def simulated(built, tmp_path_factory):
    """name -> (the folder `hwgen sim` wrote into, sim.json, the build's files' sha256 before)."""
    from hwgen.pipeline import load, sim

    out = {}
    root = tmp_path_factory.mktemp("sim")
    for name in DESIGNS:
        shutil.copytree(built(name), root / name)
        before = {str(p.relative_to(root / name)): hashlib.sha256(p.read_bytes()).hexdigest()
                  for p in (root / name).rglob("*") if p.is_file()}
        result, folder, rebuilt = sim(load(ROOT / "params" / f"{name}.yaml"), root)
        assert rebuilt is None
        out[name] = (folder, result, before)
    return out


@pytest.mark.parametrize("name", DESIGNS)
def test_mujoco_loads_robot_xml_and_every_mesh_it_names_is_beside_it(simulated, name):
    folder, result, _ = simulated[name]
    xml = folder / "sim" / "robot.xml"
    m = mujoco.MjModel.from_xml_path(str(xml))
    import xml.etree.ElementTree as ET
    root = ET.parse(xml).getroot()
    assert m.nmesh > 0 and len(list(root.iter("spatial"))) == len(result["tendons"]) and m.nkey == len(result["keyframes"])
    for mesh in root.iter("mesh"):
        assert (xml.parent / mesh.get("file")).is_file()
    assert (folder / "sim" / "sim.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("name", DESIGNS)
def test_every_eyelet_site_is_on_its_measured_eyelet_when_straight(simulated, name):
    """Each eyelet the checks measured in the STLs (report.json), at the disk's measured
    mid-plane, against its site in robot.xml with the robot straight."""
    folder, _, _ = simulated[name]
    report = json.loads((folder / "report.json").read_text())
    mid = {d["station"]: d["y_mid_mm"] for d in report["as_built"]["disks"]}
    m = mujoco.MjModel.from_xml_path(str(folder / "sim" / "robot.xml"))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    measured = [e for e in report["eyelets"] if e.get("measured_xz_mm") is not None]
    assert len(measured) >= 0.8 * len(report["eyelets"])
    worst = 0.0
    for e in measured:
        x, z = e["measured_xz_mm"]
        site = d.site(f"e{e['station']:02d}_{'+'.join(e['tendons'])}")
        worst = max(worst, float(np.linalg.norm(site.xpos * 1e3 - (x, mid[e["station"]], z))))
        if e.get("axis") is not None:
            assert site.xmat.reshape(3, 3)[:, 2] == pytest.approx(np.asarray(e["axis"]) / np.linalg.norm(e["axis"]),
                                                                    abs=1e-6)
    assert worst <= 0.05


@pytest.mark.parametrize("name", DESIGNS)
def test_the_tendons_carry_the_yamls_names_and_run_seat_eyelets_drum(simulated, name):
    folder, _, _ = simulated[name]
    design = params.read(ROOT / "params" / f"{name}.yaml").design
    names = [n for t in design.tendons for n in ([t.name, t.routing.mirror_name or f"{t.name}_m"]
                                                   if t.routing.mirror else [t.name])]
    import xml.etree.ElementTree as ET
    assert sorted(sp.get("name") for sp in ET.parse(folder / "sim" / "robot.xml").getroot().iter("spatial")) == \
        sorted(names)
    n_stations = len(_plan(name).stations)
    for sp in ET.parse(folder / "sim" / "robot.xml").getroot().iter("spatial"):
        sites = [s.get("site") for s in sp.iter("site")]
        assert sites[0] == f"{sp.get('name')}_seat" and sites[-1] == f"{sp.get('name')}_drum"
        stations = [int(s[1:3]) for s in sites if s.startswith("e")]
        assert stations == list(range(n_stations))


@pytest.mark.parametrize("name", DESIGNS)
def test_every_state_is_a_keyframe_its_drums_can_reach(simulated, name):
    """A keyframe per tendon state; its drum settings inside the actuators' range; in N no
    tendon pulls, in the state with every channel every tendon does (robot straight)."""
    folder, result, _ = simulated[name]
    plan = _plan(name)
    m = mujoco.MjModel.from_xml_path(str(folder / "sim" / "robot.xml"))
    d = mujoco.MjData(m)
    states = stiffness.states(plan)
    assert [m.key(i).name for i in range(m.nkey)] == [s.name for s in states]
    for i in range(m.nkey):
        ctrl = m.key_ctrl[i]
        assert np.all(ctrl >= m.actuator_ctrlrange[:, 0]) and np.all(ctrl <= m.actuator_ctrlrange[:, 1])
    drive = [d_["channel"] for d_ in result["drums"] if d_["drive"]]
    assert drive == [plan.tensioner.actuating_channel]               # the pair's drive (hwgen.sim.mjcf)
    assert sorted(m.actuator(i).name for i in range(m.nu)) == sorted([*plan.tensioner.channels, f"{drive[0]}_drive"])
    mujoco.mj_resetDataKeyframe(m, d, m.key("N").id)
    mujoco.mj_forward(m, d)
    spatial = [m.tendon(t["name"]).id for t in result["tendons"]]
    assert np.all(d.ten_length[spatial] < m.tendon_lengthspring[spatial, 1])        # in N no tendon pulls
    # in every other state, robot straight, each locked tendon stretched by its haul-in from the
    # statics' lock in the build's stiffness.json (ℓ_straight − ℓ₀), less what its drum misses it by
    study = json.loads((folder / "stiffness.json").read_text())
    straight = st.straight_lengths(st.Model(stiffness.describe(plan).robot, stiffness.STUDY_H_MAX))
    missed = result["keyframe_lock_missed_by_mm"]
    for e in study["states"]:
        if e["orientation"] != reference.ORIENTATION or e["friction"] != "none" or e["state"] == "N":
            continue
        mujoco.mj_resetDataKeyframe(m, d, m.key(e["state"]).id)
        mujoco.mj_forward(m, d)
        for t, lock in e["locks_mm"].items():
            i = m.tendon(t).id
            stretch_mm = (d.ten_length[i] - m.tendon_lengthspring[i, 1]) * 1e3
            miss = missed.get(e["state"], {}).get(t, 0.0)
            assert stretch_mm == pytest.approx(straight[t] - lock - miss, abs=1e-6), (e["state"], t)
    full = result["states"][-1]                     # and taut at MuJoCo's equilibrium under gravity
    assert all(full["mujoco_tensions_n"][t] > 0 for t in full["statics_tensions_n"])


@pytest.mark.parametrize("name", DESIGNS)
def test_two_seconds_under_gravity_stay_finite_from_every_keyframe(simulated, name):
    folder, _, _ = simulated[name]
    m = mujoco.MjModel.from_xml_path(str(folder / "sim" / "robot.xml"))
    d = mujoco.MjData(m)
    for i in range(m.nkey):
        mujoco.mj_resetDataKeyframe(m, d, i)
        mujoco.mj_step(m, d, nstep=int(round(2.0 / m.opt.timestep)))
        assert np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all(), m.key(i).name
        assert abs(d.site("tip").xpos[2]) < 0.4          # the tip stays within reach of the strip


@pytest.mark.parametrize("name", DESIGNS)
def test_tip_stiffness_agrees_with_the_statics_and_with_pushing_the_tip(simulated, name):
    """N, A and the all-tendon state within the sim's gate (hwgen.sim.limits.STATICS) of `hwgen
    stiffness` (sim.json); the statics' figures there are the study's on the same build; and
    MuJoCo's figure is what pushing robot.xml's tip gives (two equilibria ±5 mN apart), measured
    here on the file."""
    folder, result, _ = simulated[name]
    from hwgen.checks.report import read_report
    plan = _plan(name)
    o = reference.ORIENTATION
    tips = stiffness.tip_stiffness(stiffness.study(plan, [s["state"] for s in result["states"]], orientations=[o],
                                                   measured=read_report(folder)["gravity"]))
    assert [s["state"] for s in result["states"]][:2] == ["N", plan.tensioner.actuating_channel]
    assert result["statics_from"] == "the build's stiffness.json" and result["orientation"]["name"] == o
    m = mujoco.MjModel.from_xml_path(str(folder / "sim" / "robot.xml"))
    assert m.opt.gravity / np.linalg.norm(m.opt.gravity) == pytest.approx(result["orientation"]["gravity"])
    for s in result["states"]:
        assert abs(s["mujoco_tip_n_per_mm"] / s["statics_tip_n_per_mm"] - 1) <= limits.STATICS
        assert s["statics_tip_n_per_mm"] == pytest.approx(tips[(s["state"], o, "none")], rel=1e-9)
    assert result["agreement_limit"] == limits.STATICS
    sim = measure.Sim.load(folder / "sim" / "robot.xml")
    s = result["states"][1]                             # the actuating pair alone: its locks are the keyframe's
    assert max(map(abs, s["keyframe"]["lock_missed_by_mm"].values()), default=0.0) < 1e-6
    sim.keyframe(s["state"])
    q0 = sim.data.qpos.copy()
    tips = []
    for f in (-5e-3, 5e-3):
        measure.equilibrium(sim, q0, measure.Extra(push=(0.0, 0.0, f)))
        tips.append(measure.tip_mm(sim)[2])
    secant = 1e-2 / (tips[1] - tips[0])
    assert secant == pytest.approx(s["mujoco_tip_n_per_mm"], rel=0.02)


@pytest.mark.parametrize("name", DESIGNS)
def test_state_N_sags_as_the_own_weight_model_and_the_bent_tip_lands_where_the_statics_puts_it(simulated, name):
    _, result, _ = simulated[name]
    sag = result["sag"]
    assert sag["mujoco_tip_sag_mm"] == pytest.approx(sag["sag_model_tip_sag_mm"], rel=0.01)
    b = result["bent"]
    assert b["in_plane_distance_mm"] < 0.01 * abs(b["statics_tip_mm"][1])
    assert all(d["finite"] for d in result["dynamics"]) and result["ok"]


@pytest.mark.parametrize("name", DESIGNS)
def test_hwgen_sim_adds_its_folder_and_leaves_every_built_file_as_it_was(simulated, name):
    folder, _, before = simulated[name]
    after = {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
             for p in folder.rglob("*") if p.is_file()}
    assert {k: v for k, v in after.items() if not k.startswith("sim/")} == before
    assert {"sim/robot.xml", "sim/sim.json", "sim/sim.png"} <= set(after)


def test_a_robot_without_a_tensioner_still_loads_with_its_tendons_just_taut(simulated, tmp_path):
    """A design whose tensioner could not be laid out has no drums: robot.xml still loads, each
    tendon ends at its tip eyelet, just taut in the straight robot, and the model says so."""
    import dataclasses

    from hwgen.cad.manifest import read_manifest
    from hwgen.checks.report import read_report
    from hwgen.sim import mjcf, parts

    folder, _, _ = simulated["prototype"]
    printed = parts.read_build(folder, read_manifest(folder), read_report(folder))
    bare = dataclasses.replace(printed, tip=[], runs={})
    plan = _plan("prototype")
    study = json.loads((folder / "stiffness.json").read_text())
    ref = reference.statics_reference(plan, read_report(folder)["gravity"], study, ["N"], 10.0)
    states = [(s.name, s.channels) for s in stiffness.states(plan)]
    written = mjcf.write_robot("bare", bare, mjcf.Rig(chain.hinges(ref.described.robot), [], mjcf.TIMESTEP),
                               mjcf.Locks(states, reference.haul_in(ref)), reference.tendon_springs(ref),
                               folder, tmp_path)
    assert written.notes and not written.drums
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "robot.xml"))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    assert m.nu == 0 and m.nkey == len(states)
    assert d.ten_length == pytest.approx(m.tendon_lengthspring[:, 1], abs=1e-9)


# ------------------------------------------------------------------ slow: what the statics cannot say

@pytest.mark.parametrize("name", DESIGNS)
def test_the_independent_rod_puts_the_tip_where_mujoco_does(simulated, name):
    """sim.json's reference: state N and the lifting tendon pulled, MuJoCo's tip within 2 % of the
    robot's length of the Cosserat rod's, and the rod's tip is the rod built here from the build's
    files and solved again; it is not the statics' (another model: they differ, if by little)."""
    from hwgen.cad.manifest import read_manifest
    from hwgen.checks.report import read_report
    from hwgen.model import steel
    from hwgen.sim import cosserat, independent, parts

    folder, result, _ = simulated[name]
    ref = result["reference"]
    L = ref["length_mm"]
    pulled = next(k for k in ref if k.endswith("_pulled"))
    assert ref["limit_share_of_length"] == limits.REFERENCE and ref["within"]
    for key in ("N", pulled):
        assert ref[key]["distance_mm"] <= limits.REFERENCE * L
        assert ref[key]["distance_mm"] == pytest.approx(
            np.linalg.norm(np.subtract(ref[key]["mujoco_tip_mm"], ref[key]["cosserat_tip_mm"])))
    assert ref["N"]["mujoco_tip_mm"] == result["states"][0]["mujoco_tip_mm"]
    assert ref[pulled]["mujoco_tip_mm"] == result["bent"]["mujoco_tip_mm"]
    plan = _plan(name)
    report = read_report(folder)
    printed = dataclasses.replace(parts.read_build(folder, read_manifest(folder), report),
                                  bought=steel.tip_pieces(plan))
    rod, k, local = independent.robot_rod(printed, Gravity.of(report["gravity"]), plan.backbone.shear_modulus_gpa * 1e3)
    sol = cosserat.solve(rod, cosserat.Loads(gravity=(0.0, 0.0, -1.0)))
    assert sol.point(k, local) == pytest.approx(ref["N"]["cosserat_tip_mm"], abs=1e-6)
    assert ref["N"]["cosserat_tip_mm"] != pytest.approx(result["states"][0]["statics_tip_mm"], abs=1e-3)


def _ring_down_outside(xml: Path, key: str, hz: float) -> tuple[float, float]:
    """robot.xml's first mode from keyframe ``key`` with MuJoCo and scipy alone: settled with its
    joints damped 100 times over, let go, its tip pushed along z for 50 ms, the tip's z fitted with
    a decaying cosine over ten periods of ``hz``; (frequency Hz, damping ratio)."""
    from scipy.optimize import curve_fit

    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key(key).id)
    damping = m.dof_damping.copy()
    m.dof_damping[:] = 100 * damping
    mujoco.mj_step(m, d, nstep=int(4.0 / m.opt.timestep))
    m.dof_damping[:] = damping
    tip = m.site("tip").id
    body = m.site_bodyid[tip]
    d.xfrc_applied[body, 2] = 0.05
    mujoco.mj_step(m, d, nstep=int(0.05 / m.opt.timestep))
    d.xfrc_applied[body, 2] = 0.0
    steps = int(10 / hz / m.opt.timestep)
    z = np.empty(steps)
    for i in range(steps):
        mujoco.mj_step(m, d)
        z[i] = d.site_xpos[tip][2]
    t = np.arange(steps) * m.opt.timestep
    w = 2 * math.pi * hz

    def decay(t, c, a, s, om, ph):
        return c + a * np.exp(-s * t) * np.cos(om * t + ph)

    (c, a, s, om, ph), _ = curve_fit(decay, t, z, p0=(z.mean(), z.max() - z.mean(), 0.005 * w, w, 0.0), maxfev=20000)
    return math.hypot(om, s) / (2 * math.pi), s / math.hypot(om, s)


@pytest.mark.parametrize("name", DESIGNS)
def test_a_ring_down_of_robot_xml_outside_hwgen_reproduces_the_modes(simulated, name):
    """sim.json's modes (the linearisation of robot.xml, checked by hwgen's own ring-down) against a
    ring-down of robot.xml done here with MuJoCo and scipy alone: frequency and damping ratio
    within the sim's gate (hwgen.sim.limits.RING_DOWN), every state; and the damping is the
    loss factor's, β = η/ω₁ of state N."""
    folder, result, _ = simulated[name]
    assert set(result["modes"]) == {s["state"] for s in result["states"]}
    for state, mode in result["modes"].items():
        assert mode["agree"] and 0 < mode["damping_ratio"] < 0.05
        hz, zeta = _ring_down_outside(folder / "sim" / "robot.xml", state, mode["frequency_hz"])
        assert hz == pytest.approx(mode["frequency_hz"], rel=limits.RING_DOWN), state
        assert zeta == pytest.approx(mode["damping_ratio"], rel=limits.RING_DOWN), state
    damp = result["damping"]
    assert damp["beta_s"] == pytest.approx(damp["loss_factor"] / (2 * math.pi * damp["first_mode_hz"]))
    assert damp["first_mode_hz"] == pytest.approx(result["modes"]["N"]["undamped_hz"], rel=1e-6)
    m = mujoco.MjModel.from_xml_path(str(folder / "sim" / "robot.xml"))
    flex = [j for j in range(m.njnt) if m.joint(j).name.startswith("flex_")]
    assert m.dof_damping[m.jnt_dofadr[flex]] == pytest.approx(damp["beta_s"] * m.jnt_stiffness[flex], rel=1e-9)


@pytest.mark.parametrize("name", DESIGNS)
def test_the_drive_hauls_one_of_the_pair_in_as_it_pays_the_other_out(simulated, name):
    """robot.xml's drive: its take-ups moved apart by δ (the drive's fixed tendon at δ, the haul's at
    0) lengthen the first of the pair's path by δ and shorten the other's by δ, robot held straight;
    sim.json's driven holds both angles, past their start toward the sweep, and each locked
    stiffening tendon's change."""
    folder, result, _ = simulated[name]
    plan = _plan(name)
    drum = next(d for d in result["drums"] if d["drive"])
    a, b = drum["tendons"]
    m = mujoco.MjModel.from_xml_path(str(folder / "sim" / "robot.xml"))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    before = d.ten_length.copy()
    delta = 2e-3
    ja, jb = (m.joint(f"drum_{drum['channel']}_{t}") for t in (a, b))
    d.qpos[ja.qposadr[0]] = drum["senses"][0] * delta
    d.qpos[jb.qposadr[0]] = -drum["senses"][1] * delta
    mujoco.mj_forward(m, d)
    change = d.ten_length - before
    assert change[m.tendon(a).id] == pytest.approx(delta, abs=1e-9)
    assert change[m.tendon(b).id] == pytest.approx(-delta, abs=1e-9)
    assert d.ten_length[m.tendon(f"drive_{drum['channel']}").id] == pytest.approx(delta)
    assert d.ten_length[m.tendon(f"haul_{drum['channel']}").id] == pytest.approx(0.0, abs=1e-12)
    dr = result["driven"]
    assert dr["target_deg"] == plan.check.max_angle_deg and dr["tendon"] in (a, b)
    assert dr["locked_angle_deg"] > dr["locked_start_deg"] + 45 and dr["unlocked_angle_deg"] > dr["unlocked_start_deg"] + 45
    stiffening = {p.name for p in plan.paths if p.budget_mm is not None}
    assert set(dr["locked_tension_change_n"]) <= stiffening and dr["locked_tension_change_n"]
    lo = dr["cases"]["locked"]
    for t, v in dr["locked_tension_change_n"].items():
        assert v == pytest.approx(lo["tensions_n"][t] - lo["tensions_before_n"][t])
    assert set(dr["sweep"]["tension_change_n"]) == set(dr["locked_tension_change_n"])


@pytest.mark.parametrize("name", DESIGNS)
def test_robot_xml_has_a_table_at_the_mounts_foot_that_the_disks_hit(simulated, name):
    """A table geom whose top is the base mount's lowest face (measured on its STL) and whose edge is
    the foot's front; the robot straight touches nothing; bent down at its first hinge a disk
    meets the table."""
    from hwgen.cad.manifest import read_manifest
    from hwgen.checks.meshes import placed_mesh

    folder, result, _ = simulated[name]
    entry = next(p for p in read_manifest(folder).parts if p.role == "base_mount")
    v = np.asarray(placed_mesh(folder, entry).vertices)
    m = mujoco.MjModel.from_xml_path(str(folder / "sim" / "robot.xml"))
    d = mujoco.MjData(m)
    table = m.geom("table")
    top = (table.pos[2] + table.size[2]) * 1e3
    assert top == pytest.approx(v[:, 2].min(), abs=1e-6)
    assert (table.pos[1] + table.size[1]) * 1e3 == pytest.approx(v[v[:, 2] < v[:, 2].min() + 0.5, 1].max(), abs=1e-6)
    disks = [g for g in range(m.ngeom) if m.geom(g).name.startswith("disk_") and m.geom(g).name.endswith("_collision")]
    assert all(m.geom_contype[g] & table.conaffinity[0] for g in disks)
    mujoco.mj_forward(m, d)
    assert d.ncon == 0
    d.qpos[m.joint("flex_01").qposadr[0]] = -math.radians(85)
    mujoco.mj_forward(m, d)
    hits = {(d.contact[i].geom1, d.contact[i].geom2) for i in range(d.ncon)}
    assert any(table.id in pair and (set(pair) & set(disks)) for pair in hits)


@pytest.mark.parametrize("name", DESIGNS)
def test_robot_xml_weighs_the_bought_metal_the_bill_of_materials_lists(simulated, name):
    """robot.xml's mass over every printed part's of the robot (not its bench) is at least 10 g (the tip's dowels,
    screws and nuts); and the model's pieces are the bill of materials' lines of the tip's parts."""
    from hwgen.cad.manifest import read_manifest
    from hwgen.model import steel

    folder, result, _ = simulated[name]
    manifest = read_manifest(folder)
    from hwgen.sim.parts import BENCH_ROLES
    printed = sum(p.mass_g for p in manifest.parts if not p.fixture and p.role not in BENCH_ROLES)
    m = mujoco.MjModel.from_xml_path(str(folder / "sim" / "robot.xml"))
    assert m.body_mass.sum() * 1e3 - printed >= 10.0
    listed: dict = {}
    for p in manifest.parts:
        if p.role.startswith("tensioner_"):
            for h in p.hardware:
                listed[(h["item"], h["size"])] = listed.get((h["item"], h["size"]), 0) + h["qty"]
    assert steel.bill(steel.tip_pieces(_plan(name))) == listed


def test_the_push_is_stated_in_sim_json_and_stiffness_json(simulated):
    folder, result, _ = simulated["prototype"]
    study = json.loads((folder / "stiffness.json").read_text())
    assert result["push"]["direction"] == study["push"]["direction"] == list(stiffness.PUSH)
    assert result["push"]["words"] == study["push"]["words"]
    N = result["states"][0]
    assert N["mujoco_tip_normal_n_per_mm"] < N["mujoco_tip_n_per_mm"]     # the sagged tip is softer across its face


def test_the_docs_give_the_modes_and_the_gates_as_measured(simulated):
    """docs/simulation.md's modes table is the prototype's sim.json (to its printed digits), and the
    gates it names are hwgen.sim.limits'."""
    import re

    _, result, _ = simulated["prototype"]
    text = (ROOT / "docs" / "simulation.md").read_text(encoding="utf-8")
    for state, mode in result["modes"].items():
        row = re.search(rf"^\| prototype \| {state} \| ([0-9.]+) \| ([0-9.]+) % \|", text, re.M)
        assert row, state
        assert float(row.group(1)) == pytest.approx(mode["frequency_hz"], abs=0.0015)
        assert float(row.group(2)) == pytest.approx(100 * mode["damping_ratio"], abs=0.015)
    for gate in limits.words().values():
        assert gate in text
