"""Worm gear math and solids: formulas, what is refused, and a seeded stability run of
random gear parameters, each built and measured in a spawned process with a time bound."""
from __future__ import annotations

import math
import multiprocessing as mp
import tempfile
from pathlib import Path

import numpy as np
import pytest
import yaml

from hwgen.model.gearing import WormPair, engagement_length
from hwgen.errors import InputError
from hwgen.pipeline import load

from .conftest import PARAMS

MU = 0.1
MIN_WALL = 0.8
INTERFERENCE_TOL_MM3 = 0.01
GAP_TOL_MM = 0.02
CASE_TIMEOUT_S = 60
RANDOM_CASES = 20
SEED = 20261121


def _pair(**kw) -> WormPair:
    base = dict(module=1.25, starts=1, teeth=24, worm_pitch_diameter=14.0, pressure_angle_deg=20.0,
                face_width=8.0, worm_length=24.0, backlash=0.1)
    base.update(kw)
    return WormPair(**base)


def test_basic_dimensions():
    p = _pair()
    assert p.center_distance == pytest.approx((14.0 + 1.25 * 24) / 2 + 0.1)
    assert p.ratio == 24
    assert math.degrees(p.lead_angle) == pytest.approx(math.degrees(math.atan(1.25 / 14)))
    assert p.lead == pytest.approx(math.pi * 1.25)
    assert _pair(starts=2).lead == pytest.approx(2 * math.pi * 1.25)
    # the wheel's teeth follow the thread: a right-hand helix at the lead angle
    assert p.twist_per_mm * p.r2 == pytest.approx(math.tan(p.lead_angle))


def test_tooth_thickness_at_pitch_is_half_the_pitch():
    """The generated flank passes the pitch circle at a quarter pitch from the tooth centre."""
    p = _pair()
    fl = p.flank_points()
    r = np.hypot(fl[:, 0], fl[:, 1])
    half = np.arctan2(fl[:, 1], fl[:, 0])
    at_pitch = np.interp(p.r2, r, half)
    assert 2 * p.r2 * at_pitch == pytest.approx(p.pitch / 2, rel=2e-3)
    assert 2 * p.thread_half_width(p.r1) == pytest.approx(p.pitch / 2)


# Lewis form factors, 20° full depth, load at the tip (Shigley, Table 14-2). Our Y comes from
# the tooth as built (generated root, no fillet radius), so it must be lower, but not absurdly.
SHIGLEY_Y = {20: 0.322, 30: 0.359, 50: 0.409}


def test_lewis_form_factor_is_conservative_and_rises_with_teeth():
    ys = {z: _pair(teeth=z).lewis_form_factor() for z in SHIGLEY_Y}
    for z, y in ys.items():
        assert 0.55 * SHIGLEY_Y[z] < y < SHIGLEY_Y[z], (z, y)
    assert ys[20] < ys[30] < ys[50]


def test_lewis_stress_and_worm_torque_formulas():
    p = _pair()
    t2 = 44.5 * 5.075
    sigma = p.lewis_stress(t2)
    assert sigma == pytest.approx(t2 / p.r2 / (p.effective_face_width * p.module * p.lewis_form_factor()))
    # torque on the worm: axial force × r1 × tan(γ + φ'); with μ → 0 it is the ideal T2 / ratio
    assert p.worm_torque(t2, 1e-12) == pytest.approx(t2 / p.ratio, rel=1e-6)
    assert p.worm_torque(t2, MU) > t2 / p.ratio
    assert 0 < p.efficiency(MU) < 0.5        # self-locking worms are below 50 %


def test_generated_root_undercuts_small_wheels_only():
    assert _pair(teeth=10).undercut_depth > 0
    assert _pair(teeth=24).undercut_depth == 0
    assert _pair(teeth=17).min_teeth_no_undercut == pytest.approx(2 / math.sin(math.radians(20)) ** 2)


def test_problems_name_the_field():
    assert _pair().problems(MU, MIN_WALL) == []
    fields = [f for f, _ in _pair(worm_pitch_diameter=8.0).problems(MU, MIN_WALL)]
    assert "worm_pitch_diameter" in fields                 # γ = 8.9° > atan 0.1
    msgs = dict(_pair(teeth=12).problems(MU, MIN_WALL))
    assert "undercut" in msgs["wheel_teeth"]
    assert "thinner" in dict(_pair(module=0.8).problems(MU, MIN_WALL))["module"]


def _yaml_with(tmp_path: Path, **tensioner) -> Path:
    data = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
    data["tensioner"].update(tensioner)
    p = tmp_path / "variant.yaml"
    p.write_text(yaml.safe_dump(data))
    return p


@pytest.mark.parametrize("change, field, words", [
    ({"worm_pitch_diameter": 8}, "tensioner.worm_pitch_diameter", "not self-locking"),
    ({"worm_starts": 2}, "tensioner.worm_pitch_diameter", "not self-locking"),
    ({"wheel_teeth": 12}, "tensioner.wheel_teeth", "undercut"),
    ({"worm_length": 12}, "tensioner.worm_length", "does not cover"),
    ({"spool_diameter": 4}, "tensioner.spool_diameter", "wall"),
])
def test_load_refuses_unsound_gears(tmp_path, change, field, words):
    with pytest.raises(InputError) as e:
        load(_yaml_with(tmp_path, **change))
    assert e.value.path == field
    assert words in e.value.message


def test_lowering_friction_makes_the_design_not_self_locking(tmp_path):
    load(_yaml_with(tmp_path, friction_coefficient=0.1))
    with pytest.raises(InputError, match="not self-locking"):
        load(_yaml_with(tmp_path, friction_coefficient=0.08))


# ---- solids: built and measured in spawned processes ---------------------------------
def _mesh_case(params: dict, mu: float) -> dict:
    """Build worm and wheel, export STL, measure the mesh; runs in a spawned worker."""
    import time

    import manifold3d as m3d
    import trimesh

    from hwgen.model.gearing import WORM_TO_MESH, GearDesignError, WormPair
    t0 = time.time()
    pair = WormPair(**params)
    problems = pair.problems(mu, MIN_WALL)
    if problems:
        return {"status": "rejected", "message": "; ".join(f"{f}: {m}" for f, m in problems)}
    from hwgen.cad.tensioner_parts import gear_solid, worm_solid
    core = 2 * pair.rf1
    hex_key = min(2.5, round((core - 2 * MIN_WALL) * math.cos(math.pi / 6) - 0.2, 1))
    try:
        worm = worm_solid(pair, 4.0, hex_key, 1.6, 3.0)
        gear = gear_solid(pair)
    except GearDesignError as e:
        return {"status": "rejected", "message": str(e)}
    out = {"status": "built", "valid": worm.isValid() and gear.isValid(),
           "volumes": (worm.Volume(), gear.Volume())}
    tmp = Path(tempfile.mkdtemp())
    meshes = []
    for name, s in (("worm", worm), ("wheel", gear)):
        s.exportStl(str(tmp / f"{name}.stl"), tolerance=0.01, angularTolerance=0.2)
        meshes.append(trimesh.load_mesh(str(tmp / f"{name}.stl")))
    out["watertight"] = all(m.is_watertight and m.is_volume for m in meshes)

    def man(mesh, m):
        v = np.asarray(mesh.vertices) @ m[:3, :3].T + m[:3, 3]
        return m3d.Manifold(m3d.Mesh(vert_properties=v.astype(np.float32),
                                     tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))

    def rz(a):
        m = np.eye(4)
        m[:2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
        return m
    n = round(-pair.worm_length / (2 * pair.pitch))
    wp = np.eye(4)
    wp[:3, :3] = WORM_TO_MESH
    wp[:3, 3] = [pair.center_distance, -4.0 + n * pair.pitch, 0.0]
    hp = np.eye(4)
    hp[2, 3] = -pair.face_width / 2
    vols, gaps = [], []
    for psi in np.linspace(0, 2 * math.pi / pair.starts, 3, endpoint=False):
        w = man(meshes[0], wp @ rz(psi))
        h = man(meshes[1], hp @ rz(-psi / pair.ratio))
        vols.append((w ^ h).volume())
        gaps.append(w.min_gap(h, pair.backlash + 1.0))
    moved = hp.copy()
    moved[0, 3] += pair.backlash + 0.1
    out.update(interference=max(vols), gap=max(gaps),
               moved=(man(meshes[0], wp) ^ man(meshes[1], moved)).volume(), seconds=time.time() - t0)
    return out


def _random_cases(n: int, seed: int) -> list[tuple[dict, float]]:
    """Gear sets a designer might try: lead angles drawn around the friction angle, tooth
    counts around the undercut limit, so both outcomes occur."""
    rng = np.random.default_rng(seed)
    cases = []
    for _ in range(n):
        m = float(rng.choice([1.25, 1.5, 2.0]))
        starts = int(rng.choice([1, 1, 2, 3]))
        gamma = math.radians(rng.uniform(2.5, 12.0))
        pair = dict(module=m, starts=starts, teeth=int(rng.integers(14, 51)),
                    worm_pitch_diameter=float(np.round(min(40.0, starts * m / math.tan(gamma)), 2)),
                    pressure_angle_deg=float(rng.choice([20.0, 20.0, 25.0])),
                    face_width=float(np.round(rng.uniform(5, 12), 1)),
                    worm_length=1.0, backlash=float(np.round(rng.uniform(0.02, 0.2), 3)))
        probe = WormPair(**pair)
        pair["worm_length"] = float(np.round(engagement_length(probe) + 2 * probe.pitch, 1))
        cases.append((pair, float(np.round(rng.uniform(0.08, 0.3), 3))))
    return cases


# Other modules, tooth counts and thread starts that must build meshing pairs.
FIXED_CASES = [
    (dict(module=1.5, starts=1, teeth=30, worm_pitch_diameter=18.0, pressure_angle_deg=20.0, face_width=10.0,
          worm_length=30.0, backlash=0.1), 0.1),
    (dict(module=2.0, starts=1, teeth=20, worm_pitch_diameter=24.0, pressure_angle_deg=20.0, face_width=12.0,
          worm_length=36.0, backlash=0.15), 0.1),
    (dict(module=1.5, starts=2, teeth=40, worm_pitch_diameter=20.0, pressure_angle_deg=25.0, face_width=8.0,
          worm_length=34.0, backlash=0.05), 0.3),
    (dict(module=1.25, starts=3, teeth=36, worm_pitch_diameter=22.0, pressure_angle_deg=20.0, face_width=8.0,
          worm_length=28.0, backlash=0.1), 0.3),
]


@pytest.fixture(scope="module")
def stability_run():
    """Every case in its own task of a spawned pool (fork hangs once CadQuery geometry
    exists in the parent); a case that does not answer within CASE_TIMEOUT_S is a failure."""
    cases = FIXED_CASES + _random_cases(RANDOM_CASES, SEED)
    ctx = mp.get_context("spawn")
    results = []
    with ctx.Pool(2) as pool:
        jobs = [pool.apply_async(_mesh_case, c) for c in cases]
        for c, j in zip(cases, jobs):
            try:
                results.append((c, j.get(timeout=CASE_TIMEOUT_S)))
            except mp.TimeoutError:
                results.append((c, {"status": "timeout"}))
            except Exception as e:     # noqa: BLE001 - sorted by kind below
                results.append((c, {"status": "error", "message": repr(e)}))
    return results


def _assert_meshes(case, r):
    assert r["valid"], (case, "not a valid solid")
    assert r["watertight"], (case, "STL not watertight")
    assert min(r["volumes"]) > 0
    assert r["interference"] <= INTERFERENCE_TOL_MM3, (case, r)
    assert r["gap"] <= case[0]["backlash"] + GAP_TOL_MM, (case, r)
    assert r["moved"] > INTERFERENCE_TOL_MM3, (case, "moving the wheel in does not collide: check is blind")


def test_other_modules_teeth_and_starts_mesh(stability_run):
    for case, r in stability_run[:len(FIXED_CASES)]:
        assert r["status"] == "built", (case, r)
        _assert_meshes(case, r)


def test_random_gear_parameters_build_or_are_refused_clearly(stability_run):
    random_part = stability_run[len(FIXED_CASES):]
    kinds = {"built": 0, "rejected": 0}
    for case, r in random_part:
        assert r["status"] in kinds, (case, r)      # no timeouts, no exceptions
        kinds[r["status"]] += 1
        if r["status"] == "rejected":
            assert any(w in r["message"] for w in ("self-locking", "undercut", "thinner", "core", "cover")), r
        else:
            _assert_meshes(case, r)
            assert r["seconds"] < CASE_TIMEOUT_S
    print(f"random gear cases: {kinds}, slowest build {max(r.get('seconds', 0) for _, r in random_part):.1f} s")
    # the seed draws both kinds, so both paths are exercised
    assert kinds["built"] >= 5 and kinds["rejected"] >= 5, kinds
