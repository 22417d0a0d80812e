"""A gear that prints thinner than the process's wall is a design (issue 45): the prototype copied
to a lab's own file with only its process switched to FDM builds, and the wheel's tooth tip (the
worm's thread tip), measured from its file, fails with a tried fix that names the gear to write."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

import pytest
import yaml

from hwgen.checks.gear_walls import TIP_TOL_MM, drive_check, drive_wall_model, thread_tip, tip_checks, tip_planes, wheel_tip
from hwgen.checks.screens import plan_screens
from hwgen.errors import InputError
from hwgen.model.gearing import WormPair, worm_pair
from hwgen.pipeline import design_plan, load

from .conftest import PARAMS

FDM = {"name": "FDM, 0.4 mm nozzle", "technology": "FDM", "material": "PETG", "min_wall": 0.9, "min_hole": 1.0,
       "hole_clearance": 0.3, "build_volume": [250, 210, 210], "position_sigma": 0.1, "diameter_sigma": 0.1}


def fdm_copy(tmp_path, **process):
    """params/prototype.yaml copied to a lab's own file (every key its own), only its process FDM."""
    data = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
    data["process"] = {**FDM, **process}
    f = tmp_path / "fdm-copy.yaml"
    f.write_text(yaml.safe_dump(data, sort_keys=False))
    return f


def _pair(module=1.25, d1=14.0, length=24.0, min_tip=0.8) -> WormPair:
    return WormPair(module=module, starts=1, teeth=24, worm_pitch_diameter=d1, pressure_angle_deg=20.0,
                    face_width=8.0, worm_length=length, center_offset=0.1, min_tip=min_tip)


def test_a_tip_thinner_than_the_wall_is_not_a_refusal():
    pair = _pair(min_tip=0.9)
    assert [f for f, _ in pair.problems(0.1, 0.9)] == ["module"]        # the gear derived elsewhere avoids it
    assert pair.refusals(0.1) == [] and [f for f, _ in pair.wall_problems(0.9)] == ["module"]
    assert [f for f, _ in _pair(module=1.0, d1=12.0, length=20.0).wall_problems(0.9)] == ["pressure_angle_deg",
                                                                                          "module"]
    # the outside radius is cut where the tip is the wall thick; a module too fine leaves 90 % of the throat's
    assert _pair(min_tip=0.8).thinnest_tip() == pytest.approx(0.8, abs=1e-6)
    # a wall the mid-face tip (0.894 mm) reaches but 90 % of it does not: the gear derived for it prints
    assert not _pair(min_tip=0.85).wall_problems(0.85)
    assert _pair(min_tip=0.85).thinnest_tip() == pytest.approx(0.85, abs=1e-6)
    assert _pair(min_tip=0.9).thinnest_tip() == pytest.approx(0.9 * pair.tip_thickness(), abs=1e-6)
    assert _pair().thread_tip == pytest.approx(math.pi * 1.25 / 2 - 2 * 1.25 * math.tan(math.radians(20)))


def test_the_fdm_copy_loads_and_lays_out(tmp_path):
    loaded = load(fdm_copy(tmp_path))
    ts = loaded.design.tensioner
    assert (ts.module, ts.worm_pitch_diameter) == (1.25, 14)             # the file's own gear, honoured
    plan = design_plan(loaded)
    assert plan.tensioner_layout.pair.wall_problems(0.9)
    # a sweep or a tune foresees the check on the plan (the build's check: measured 0.806 mm, fails)
    assert [s.id for s in plan_screens(plan)] == ["gear.tooth_tip"]


def test_the_tip_checks_fix_is_tried_and_applies(tmp_path):
    """The measured tips of the FDM copy's gear (as its build measures them): the wheel's fails, its
    first fix is the gear the derivation finds, whose tip (the model's, scaled as measured) passes, and
    the design with that fix written plans, its pair free of every rule; the worm's passes."""
    pair = _pair(min_tip=0.9)
    lay = SimpleNamespace(friction_coefficient=0.1, hex_key=2.5, shaft_diameter=3.0, running_fit=0.2)
    measured = {"wheel": {"tip_mm": pair.thinnest_tip() - 0.004, "plane_mm": 1.63},
                "worm": {"tip_mm": pair.thread_tip - 0.004}}
    tooth, thread = tip_checks(measured, pair, lay, 0.9, "A")
    assert thread.passed and not tooth.passed and tooth.limit == pytest.approx(0.9 - TIP_TOL_MM)
    first, relax = tooth.fixes
    assert first.then["passed"] and not first.relax and first.set["tensioner.module"] > 1.25
    assert relax.relax and relax.set["process.min_wall"] < 0.9 and relax.then["passed"]
    assert "tensioner.module" in tooth.fix and "tried" in tooth.fix
    lost = tip_checks({"wheel": {"tip_mm": math.inf, "plane_mm": None}, "worm": measured["worm"]}, pair, lay, 0.9, "A")
    assert not lost[0].passed and "could not be cut" in lost[0].message and lost[0].fix    # never a pass unmeasured
    data = yaml.safe_load(fdm_copy(tmp_path).read_text())
    data["tensioner"].update({k.split(".")[1]: v for k, v in first.set.items()})
    fixed = tmp_path / "fixed.yaml"
    fixed.write_text(yaml.safe_dump(data, sort_keys=False))
    loaded = load(fixed)
    ts = loaded.design.tensioner
    assert not worm_pair(ts, 0.9).problems(ts.friction_coefficient, 0.9)
    design_plan(loaded)


@pytest.mark.slow
def test_tips_measured_from_the_files_match_the_generated_gear(tmp_path):
    """The wheels and worms of the prototype's module at SLA's and FDM's walls, and of the fix's gear,
    built and exported: each tip as measured is the generated gear's within the tessellation, so the
    check fails the FDM copy's wheel and passes the others."""
    import trimesh

    from hwgen.cad.wheel import gear_solid
    from hwgen.cad.worm import worm_solid
    from hwgen.checks.axes import fit_axis
    for pair, wall, passes in ((_pair(min_tip=0.8), 0.8, True), (_pair(min_tip=0.9), 0.9, False),
                               (_pair(1.5, 15.0, 26.0, 0.9), 0.9, True)):
        files = {}
        for name, solid in (("wheel", gear_solid(pair)), ("worm", worm_solid(pair, 4.0, 2.5, 3.2, 3.0))):
            files[name] = tmp_path / f"{name}-{pair.module}-{wall}.stl"
            solid.exportStl(str(files[name]), tolerance=0.01, angularTolerance=0.2)
        wheel, worm = (trimesh.load_mesh(str(files[k])) for k in ("wheel", "worm"))
        tooth = wheel_tip(wheel, fit_axis(wheel), tip_planes(pair))["tip_mm"]
        thread = thread_tip(worm, fit_axis(worm), pair.pitch)["tip_mm"]
        assert tooth == pytest.approx(pair.thinnest_tip(), abs=TIP_TOL_MM), (pair, wall)
        assert thread == pytest.approx(pair.thread_tip, abs=TIP_TOL_MM), (pair, wall)
        assert (tooth >= wall - TIP_TOL_MM) == passes, (pair, wall, tooth)


# ---- the worm's core round its bores (gear.bore_wall) -----------------------------------------

_LAY = SimpleNamespace(friction_coefficient=0.15, shaft_diameter=3.0, running_fit=0.2, hex_key=2.5)


def test_thin_walls_round_the_bores_fail_with_tried_fixes_and_only_a_bore_that_breaks_through_is_refused(tmp_path):
    """A worm of Ø10 at the prototype's module leaves 0.55 mm round the drive's 5 mm hex: measured so,
    the check fails at an FDM wall, and its first fix (a larger worm, the derivation's search) has a
    core that passes on the model; the prototype's worm passes. The key's socket is judged in the
    drive shaft it is cut in: a 6 mm key breaks through it and is refused, naming the largest that
    fits; a 4.5 mm key leaves 0.84 mm there, builds, and fails ``gear.drive_wall`` with a smaller key."""
    from hwgen.checks.gear_walls import BORE_TOL_MM, bore_check
    from hwgen.model.tensioner_layout.sizes import DRIVE_HEX
    thin = _pair(d1=10.0, min_tip=0.9)
    check = bore_check({"wall_mm": thin.bore_wall(DRIVE_HEX) - 0.005, "from_end_mm": 7.8, "bore": "hex"},
                       thin, _LAY, 0.9, "A")
    assert not check.passed and check.limit == pytest.approx(0.9 - BORE_TOL_MM)
    assert "hex end" in check.message and "tensioner.worm_pitch_diameter" in check.fix and "tried" in check.fix
    first = check.fixes[0]
    assert first.then["passed"] and first.set["tensioner.worm_pitch_diameter"] > 10.0
    fixed = WormPair(**{**{k: getattr(thin, k) for k in ("module", "starts", "teeth", "pressure_angle_deg",
                                                          "face_width", "worm_length", "center_offset")},
                        "worm_pitch_diameter": first.set["tensioner.worm_pitch_diameter"],
                        "module": first.set.get("tensioner.module", thin.module), "min_tip": 0.9})
    assert fixed.bore_wall(DRIVE_HEX, 3.2) >= 0.9
    proto = _pair()
    assert bore_check({"wall_mm": proto.bore_wall(DRIVE_HEX) - 0.005, "from_end_mm": 1.3, "bore": "hex"},
                      proto, _LAY, 0.9, "A").passed
    data = yaml.safe_load(fdm_copy(tmp_path).read_text())
    data["tensioner"]["hex_key"] = 6.0
    (tmp_path / "key.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    with pytest.raises(InputError, match=r"tensioner.hex_key: .*breaks through the Ø7 mm drive shaft.*at most 5.9 mm"):
        load(tmp_path / "key.yaml")
    data["tensioner"]["hex_key"] = 4.5          # walls of 0.84 mm in the shaft: built, and the check fails
    (tmp_path / "key.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    plan = design_plan(load(tmp_path / "key.yaml"))
    assert [s.id for s in plan_screens(plan)] == ["gear.tooth_tip", "gear.drive_wall"]
    drive = drive_check({"wall_mm": drive_wall_model(4.5) - 0.005, "from_end_mm": 2.0, "bore": "hex"}, 4.5, 0.9, "A")
    assert not drive.passed and "key's socket" in drive.message
    key, relax = drive.fixes
    assert key.set == {"tensioner.hex_key": 4.4} and key.then["passed"] and relax.relax
    assert drive_check({"wall_mm": drive_wall_model(2.5), "from_end_mm": 2.0, "bore": "round"}, 2.5, 0.9, "A").passed


@pytest.mark.slow
def test_the_bore_wall_measured_from_the_file_is_the_generated_cores(tmp_path):
    """Worms exported as the build exports them: the thinnest wall round their bores, cut from the
    file, is the generated core's within the tessellation, round the hex (the prototype's, a thin Ø10
    worm's) or round a wide dowel bore where that is the thinner."""
    import trimesh

    from hwgen.cad.worm import worm_solid
    from hwgen.checks.axes import fit_axis
    from hwgen.checks.gear_walls import BORE_TOL_MM, bore_wall
    from hwgen.model.tensioner_layout.sizes import DRIVE_HEX
    for pair, pin, kind in ((_pair(), 3.2, "hex"), (_pair(d1=10.0), 3.2, "hex"), (_pair(), 6.6, "round")):
        f = tmp_path / f"worm-{pair.worm_pitch_diameter}-{pin}.stl"
        worm_solid(pair, 4.0, DRIVE_HEX, pin, 3.0).exportStl(str(f), tolerance=0.01, angularTolerance=0.2)
        mesh = trimesh.load_mesh(str(f))
        got = bore_wall(mesh, fit_axis(mesh))
        assert got["wall_mm"] == pytest.approx(pair.bore_wall(DRIVE_HEX, pin), abs=BORE_TOL_MM), (pair, pin, got)
        assert got["bore"].startswith(kind), got
    from hwgen.cad.worm import drive_solid
    from hwgen.checks.gear_mesh import FILE_Z
    from hwgen.checks.gear_walls import drive_wall_model
    for key, kind in ((2.5, "round"), (4.5, "hex")):        # the vent in the hex end, then the key's socket
        f = tmp_path / f"drive-{key}.stl"
        drive_solid(4.0, key).exportStl(str(f), tolerance=0.01, angularTolerance=0.2)
        got = bore_wall(trimesh.load_mesh(str(f)), FILE_Z)
        assert got["wall_mm"] == pytest.approx(drive_wall_model(key), abs=BORE_TOL_MM), (key, got)
        assert got["bore"].startswith(kind), got


def test_the_axis_of_a_wheel_as_long_as_it_is_wide_is_found():
    """Robot 93's wheel A (its drum as long as the wheel is wide): its three moments of inertia nearly
    agree, the principal axis is off by degrees, and the crest fit from it found a thin ring whose
    tilt it could not tell (gear.shaft_angle measured 89.84°). A toothed drum of that shape, one
    bore off its axis, turned through a known rotation: the axis is found within 0.001°."""
    import trimesh

    from hwgen.checks.axes import _principal_guess, fit_axis
    r = 20.0
    body = trimesh.creation.cylinder(radius=r, height=r * math.sqrt(3), sections=96)
    teeth = [trimesh.creation.box((1.0, 1.0, 6.0)).apply_translation((r * math.cos(a), r * math.sin(a), 0.0))
             for a in np.linspace(0, 2 * math.pi, 24, endpoint=False)]
    lump = trimesh.creation.box((4.0, 4.0, 8.0)).apply_translation((8.0, 0.0, 10.0))    # a clamp's boss, off the axis
    part = trimesh.util.concatenate([body, lump, *teeth])
    turn = trimesh.transformations.rotation_matrix(0.7, (0.3, 1.0, 0.2))
    part.apply_transform(turn)
    axis = turn[:3, :3] @ np.array([0.0, 0.0, 1.0])
    assert math.degrees(math.acos(min(1.0, abs(_principal_guess(part) @ axis)))) > 1.0     # the first guess is off
    got = fit_axis(part)
    assert math.degrees(math.acos(min(1.0, abs(got.direction @ axis)))) < 1e-3
