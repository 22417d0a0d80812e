"""The paper's bench as printable hardware (issue 46): the rotating base frame (``base_frame:``) and
the stiffness rig (``rig:``). Fast tests check the layout and the statics against textbook results
and the checks' tried fixes; slow ones measure the built files of the prototype, which stands in its bench (params/prototype.yaml)."""
from __future__ import annotations

import csv
import functools
import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hwgen import params
from hwgen.model import bench_frame as bf
from hwgen.model import bench_parts as bp
from hwgen.model.plan import make_plan

ROOT = Path(__file__).resolve().parents[1]


@functools.cache
def _design():
    return params.read(ROOT / "params" / "prototype.yaml").design


@functools.cache
def _plan():
    return make_plan(_design())


def test_the_frame_and_rig_are_left_out_unless_enabled():
    d = _design()
    off = d.model_copy(update={"base_frame": d.base_frame.model_copy(update={"enabled": False}),
                               "rig": d.rig.model_copy(update={"enabled": False})})
    from hwgen.cad.families import FAMILIES
    from hwgen.model.plan import _bench
    plan = _bench(off, replace(_plan(), frame=None, rig=None))     # what make_plan ends with
    assert plan.frame is None and plan.rig is None
    counts = {f.name: f.count(plan) for f in FAMILIES}
    assert counts["base frame"] == 0 and counts["rig"] == 0
    on = _plan()
    assert {f.name: f.count(on) for f in FAMILIES}["base frame"] >= 4


def test_the_belt_is_stock_and_its_centre_distance_is_the_shafts():
    lay = _plan().frame
    assert lay.belt_length in bp.lengths("GT2 belt")
    pitch = bp.size("GT2 belt", "any", "pitch")
    # closed belt on two equal pulleys: L = 2C + z p
    assert 2 * (0.0 - lay.z_lower) + lay.pulley_teeth * pitch == pytest.approx(lay.belt_length)
    assert lay.pulley_pd == pytest.approx(lay.pulley_teeth * pitch / math.pi)


def test_the_axis_clears_the_plate_and_the_worm_stands_on_it():
    lay = _plan().frame
    assert -lay.z_base >= lay.envelope_radius + lay.clearance - 1e-9
    assert lay.z_worm - lay.pair.ra1 >= lay.z_base + bf.WORM_CLEAR - 1e-9
    assert lay.z_lower - lay.z_worm == pytest.approx(lay.pair.center_distance)
    # the cradle's corner is the farthest thing that turns, and it sets the envelope
    fx, _, _, _, _ = lay.foot
    assert lay.envelope_radius >= math.hypot(fx, lay.z_plate) - 1e-9
    assert lay.pair.self_locking(lay.mu)


def _beam(span, c, force, moment, ei, n=40001):
    """The shaft integrated numerically: supports at y = 0 and y = span, the load (force and moment)
    at y = span + c; returns (deflection, slope) at the end."""
    y = np.linspace(0.0, span + c, n)
    r_far = (force * (span + c) + moment) / span       # reaction at y = span (up), from moments about y = 0
    r_near = force - r_far
    m = np.where(y <= span, r_near * y, r_near * y + r_far * (y - span))      # bending moment from the near end
    curv = m / ei
    slope = np.concatenate([[0.0], np.cumsum((curv[1:] + curv[:-1]) / 2 * np.diff(y))])
    w = np.concatenate([[0.0], np.cumsum((slope[1:] + slope[:-1]) / 2 * np.diff(y))])
    # add the rigid rotation that puts w = 0 at the far support
    k = np.searchsorted(y, span)
    theta0 = -w[k] / y[k]
    w = w + theta0 * y
    s = slope + theta0
    return -w[-1], -s[-1]


def test_the_shaft_statics_match_a_numerical_beam():
    lay = _plan().frame
    s = bf.shaft_statics(lay, 2.0, lay.hub[0] + 100.0, 5.0, lay.tip_y)
    ei = lay.shaft_e_mpa * math.pi * lay.shaft_d ** 4 / 64
    force = 7.0
    moment = 2.0 * 100.0 + 5.0 * (lay.tip_y - lay.hub[0])
    w, th = _beam(s["span_mm"], s["overhang_mm"], force, moment, ei)
    assert s["end_deflection_mm"] == pytest.approx(w, rel=2e-3)
    assert s["end_slope_rad"] == pytest.approx(th, rel=2e-3)
    # the reactions balance the load
    assert s["front_n"] - s["back_n"] == pytest.approx(force)


def test_a_heavier_robot_gets_a_larger_wheel_as_a_tried_fix():
    from hwgen.checks.bench import _teeth
    plan = _plan()
    lay = plan.frame
    ok = _teeth(lay, 200.0, plan.tensioner.resin_strength)
    assert ok.passed
    heavy = _teeth(lay, 2_000.0, plan.tensioner.resin_strength)          # ten times the prototype's torque
    assert not heavy.passed and heavy.fixes
    fix = heavy.fixes[0]
    assert fix.set["base_frame.wheel_teeth"] > lay.pair.teeth and fix.then["passed"]
    # the fix is true: that wheel under that torque holds
    p = replace(lay.pair, teeth=fix.set["base_frame.wheel_teeth"])
    assert bf.lewis_factor(p, 2_000.0, plan.tensioner.resin_strength) >= lay.safety_factor


def test_a_worm_that_does_not_lock_fails_with_a_tried_fix():
    from hwgen.checks.bench import _self_locking
    lay = _plan().frame
    steep = replace(lay, pair=replace(lay.pair, starts=2, worm_pitch_diameter=10.0))
    c = _self_locking(steep, 500.0, 300.0)
    assert not c.passed and c.fixes
    d1 = c.fixes[0].set["base_frame.worm_pitch_diameter"]
    assert c.fixes[0].then["passed"]
    assert replace(steep.pair, worm_pitch_diameter=d1).self_locking(steep.mu)
    assert not replace(steep.pair, worm_pitch_diameter=d1 - 0.5).self_locking(steep.mu)
    assert _self_locking(lay, 500.0, 300.0).passed


def test_the_rig_bolts_to_the_ur5e_flange():
    rig = _plan().rig
    cx, cy = rig.flange_centre
    r = [math.hypot(x - cx, y - cy) for x, y in rig.flange_holes]
    assert len(r) == 4 and np.allclose(r, 25.0)              # ISO 9409-1-50-4-M6: 4 × M6 on Ø50
    assert rig.flange_hole == pytest.approx(6.6)
    assert rig.z_pad > rig.disk_radius                        # it starts above the rim
    assert sum(rig.free_holes) / 2 == pytest.approx(0.0)      # the cell is loaded where the pad meets the disk (x = 0)


# ----------------------------------------------------------------------------------- the build


@pytest.mark.slow
def test_the_prototype_builds_its_frame_and_rig(built):
    import trimesh
    folder = built("prototype")
    manifest = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))
    parts = {p["name"]: p for p in manifest["parts"]}
    frame = [n for n in parts if n.startswith("base_frame_")]
    rig = [n for n in parts if n.startswith("rig_")]
    assert len(frame) >= 4 and len(rig) >= 2
    for n in frame + rig:
        mesh = trimesh.load(folder / parts[n]["files"]["stl"]["path"])
        assert mesh.is_watertight, n
    report = json.loads((folder / "report.json").read_text(encoding="utf-8"))
    ids = {c["id"]: c for c in report["checks"] if c["id"].startswith(("base_frame.", "rig."))}
    for cid in ("base_frame.self_locking", "base_frame.tooth_stress", "base_frame.shaft", "base_frame.bearing",
                "base_frame.clamp", "base_frame.tipping", "base_frame.clearance", "rig.push_clear"):
        assert cid in ids and ids[cid]["passed"], (cid, ids.get(cid))
    # the clearance is measured, not the layout's: the swing is the cradle's corner, as the model lays it
    lay = _plan().frame
    assert ids["base_frame.clearance"]["measured"] >= lay.clearance
    with open(folder / "bom.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    items = " ".join(r["part"] + " " + r["size"] for r in rows)
    for word in ("ground shaft", "ball bearing", "GT2 closed-loop belt", "GT2 pulley", "beam load cell"):
        assert word in items, word
    guide = (folder / "guide" / "assembly.md").read_text(encoding="utf-8")
    assert "rotating base frame" in guide.lower() and "stiffness rig" in guide.lower()


def _round_axes(shape) -> dict:
    """The cylindrical faces' area per axis direction (|x|, |y|, |z|), read from a STEP solid."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    area: dict = {}
    for face in shape.Faces():
        if face.geomType() == "CYLINDER":
            d = BRepAdaptor_Surface(face.wrapped).Cylinder().Axis().Direction()
            key = tuple(round(abs(c), 6) for c in (d.X(), d.Y(), d.Z()))
            area[key] = area.get(key, 0.0) + face.Area()
    return area


def test_the_bench_parts_print_their_bearing_seats_and_bores_upright(built):
    """Each of the bench's printed parts lies in its file on a flat face with its round features
    (the uprights' bearing seats, the rig's screw holes) upright, where a
    face square to them can rest; read from the STEP files."""
    import cadquery as cq
    folder = built("prototype")
    manifest = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))
    parts = {p["name"]: p for p in manifest["parts"] if p.get("bench") and p["role"] != "base_frame_gear"}
    upright = 0
    for name, part in parts.items():
        shape = cq.importers.importStep(str(folder / part["files"]["step"]["path"])).val()
        if name == "base_frame_cradle":
            continue        # stands on its foot: its flange's marks would face up as resin cups (cad/bench.py)
        axes = _round_axes(shape)
        main = max(axes, key=axes.get)
        bb = shape.BoundingBox()
        assert bb.zmin == pytest.approx(0, abs=1e-6), name
        if main == (0.0, 0.0, 1.0):
            upright += 1
            continue
        # not upright: then no flat face square to the main axis can carry the part
        points = np.array([v.toTuple() for v in shape.tessellate(0.05)[0]])
        for face in shape.Faces():
            n = np.array(face.normalAt().toTuple())
            if face.geomType() == "PLANE" and abs(abs(n @ np.array(main)) - 1) < 1e-9:
                assert (points @ n).max() > np.dot(face.Center().toTuple(), n) + 1e-6, (name, main)
    # the uprights' four bearing seats and the rig's screws among them
    assert {"base_frame_front", "base_frame_back", "rig_bracket"} <= set(parts)
    assert upright >= 5, upright


def test_a_heavier_tensioner_is_laid_out_with_a_larger_wheel():
    d, plan = _design(), _plan()
    lay = plan.frame
    assert lay.pair.teeth == d.tensioner.wheel_teeth          # the prototype's torque needs no more
    from hwgen.model import steel
    torque = 10 * bf.torque_estimate(d, plan.tensioner_layout, steel.total(steel.tip_pieces(plan))[:2],
                                     plan.process.density_g_cm3)
    heavy = bf.frame_layout(d, plan.mount, lay.envelope_radius, torque)
    assert heavy.pair.teeth > lay.pair.teeth
    assert bf.lewis_factor(heavy.pair, torque, d.tensioner.resin_strength) >= lay.safety_factor
    assert bf.lewis_factor(replace(heavy.pair, teeth=heavy.pair.teeth - 1), torque,
                           d.tensioner.resin_strength) < lay.safety_factor


def test_a_bad_bench_value_names_its_field(tmp_path):
    from hwgen.errors import InputError
    f = tmp_path / "mine.yaml"
    f.write_text(f"base: {ROOT / 'params' / 'prototype.yaml'}\ndesign: mine\nbase_frame:\n  pulley_teeth: 25\n"
                 f"rig:\n  load_cell:\n    length: -3\n", encoding="utf-8")
    with pytest.raises(InputError) as e:
        params.read(f)
    paths = {p.path for p in e.value.problems}
    assert "base_frame.pulley_teeth" in paths and "rig.load_cell.length" in paths


def _robot(tmp_path, body: str):
    f = tmp_path / "mine.yaml"
    f.write_text(f"base: {ROOT / 'params' / 'prototype.yaml'}\ndesign: mine\n{body}", encoding="utf-8")
    d = params.read(f).design
    return d, make_plan(d)


def _torque(d, plan) -> float:
    from hwgen.model import steel
    return bf.torque_estimate(d, plan.tensioner_layout, steel.total(steel.tip_pieces(plan))[:2],
                              plan.process.density_g_cm3)


def test_a_robot_that_loads_the_frame_more_gets_a_larger_wheel_or_a_failing_check_with_a_tried_fix(tmp_path):
    """Issue 46's done-when, from a design file: a robot whose frame carries more torque about the
    shaft gets a larger worm wheel; with its wheel fixed in the file, the tooth check fails and its
    tried fix is that wheel. The tensioner's weight is in the torque (it grows with the tensioner's
    density), but the prototype's tensioner hangs nearly on the axis: the push at a disk's rim is most
    of the torque, so the robot here is the prototype pushed with a 50 N cell."""
    d0, p0 = _design(), _plan()
    # a heavier tensioner (the same parts, denser) turns the frame harder under gravity
    d1, p1 = _robot(tmp_path, "process:\n  density_g_cm3: 2.3\n")
    push0 = d0.experiment.load_cell_range_n * d0.disks.outer_diameter / 2
    assert _torque(d1, p1) - push0 > _torque(d0, p0) - push0 > 0
    # a robot pushed harder: the wheel that carries it, and no smaller one does
    d2, p2 = _robot(tmp_path, "experiment:\n  load_cell_range_n: 50\n")
    torque = _torque(d2, p2)
    strength = d2.tensioner.resin_strength
    lay = p2.frame
    assert lay.pair.teeth > p0.frame.pair.teeth
    assert bf.lewis_factor(lay.pair, torque, strength) >= lay.safety_factor
    assert bf.lewis_factor(replace(lay.pair, teeth=lay.pair.teeth - 1), torque, strength) < lay.safety_factor
    # the same robot with the prototype's wheel written in its file: the check fails, and its tried
    # fix is the wheel the layout chose
    from hwgen.checks.bench import _teeth
    d3, p3 = _robot(tmp_path, f"experiment:\n  load_cell_range_n: 50\nbase_frame:\n  wheel_teeth: {p0.frame.pair.teeth}\n")
    assert p3.frame.pair.teeth == p0.frame.pair.teeth
    c = _teeth(p3.frame, _torque(d3, p3), strength)
    assert not c.passed and c.fixes and c.fixes[0].then["passed"]
    assert c.fixes[0].set["base_frame.wheel_teeth"] == lay.pair.teeth
