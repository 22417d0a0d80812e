"""The tensioner as shipped: measured from the exported files of the prototype build."""
from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np
import pytest

from hwgen.cad.manifest import Manifest, ManifestPart
from hwgen.checks.axes import fit_axis
from hwgen.checks.gear_mesh import GAP_TOL_MM, INTERFERENCE_TOL_MM3, count_teeth, gear_checks, measure_pair, mesh_measure, toward
from hwgen.checks.meshes import load_mesh, placed_manifold, placed_mesh
from hwgen.checks.tendon_runs import tendon_checks
from hwgen.model.plan import make_plan
from hwgen.model.gearing import worm_pair
from hwgen.pipeline import load
from hwgen.model.tensioner_layout import layout

from .conftest import PARAMS


@pytest.fixture(scope="module")
def proto(built):
    folder = built("prototype")
    man = json.loads((folder / "manifest.json").read_text())
    return folder, man, make_plan(_design())


def _design():
    return load(PARAMS / "prototype.yaml").design


def _by_role(man, role):
    return {p["channel"]: p for p in man["parts"] if p["role"] == role}


def _rz(a):
    m = np.eye(4)
    m[:2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
    return m


def test_one_worm_drive_per_channel(proto):
    _, man, p = proto
    channels = set(p.tensioner.channels)
    assert set(_by_role(man, "tensioner_worm")) == channels
    assert set(_by_role(man, "tensioner_wheel")) == channels
    clamps = [q for q in man["parts"] if q["role"] == "tensioner_clamp"]
    # one clamp per tendon end: the actuating drum carries both A1 and A2
    assert sorted(q["channel"] for q in clamps) == sorted(t.channel for t in p.paths)
    assert len([q for q in man["parts"] if q["role"] == "tensioner_housing"]) == 1
    assert set(_by_role(man, "tensioner_drive")) == channels
    assert sorted(_by_role(man, "tensioner_wheel")["A"]["tendons"]) == ["A1", "A2"]


def test_worm_and_wheel_files_are_closed_solids(proto):
    folder, man, _ = proto
    for role in ("tensioner_worm", "tensioner_wheel", "tensioner_clamp", "tensioner_drive", "tensioner_housing"):
        of_role = [x for x in man["parts"] if x["role"] == role]
        assert of_role, role                # a renamed role must not pass with nothing measured
        for q in of_role:
            mesh = load_mesh(ManifestPart.of(q).stl_in(folder))
            assert mesh.is_watertight and mesh.is_winding_consistent and mesh.is_volume, q["name"]
            assert mesh.volume == pytest.approx(q["volume_mm3"], rel=0.01), q["name"]
            assert mesh.body_count == 1, q["name"]


def test_step_files_of_worm_and_wheel_are_valid_solids(proto):
    import cadquery as cq

    from hwgen.cad import mass_properties
    folder, man, _ = proto
    for role in ("tensioner_worm", "tensioner_wheel"):
        q = _by_role(man, role)["C1"]
        shape = cq.importers.importStep(str(folder / ManifestPart.of(q).step)).val()
        assert shape.isValid() and len(shape.Solids()) == 1
        assert mass_properties(shape)[0] == pytest.approx(q["volume_mm3"], rel=1e-4)


def test_worm_has_a_thread_and_wheel_has_teeth(proto):
    """Probe the files: along a line parallel to the worm's axis at the pitch radius, solid
    and space alternate every half pitch; the wheel's mid-plane section has one tip per tooth."""
    folder, man, p = proto
    pair = worm_pair(_design().tensioner)
    worm_q = _by_role(man, "tensioner_worm")["C1"]
    worm = load_mesh(ManifestPart.of(worm_q).stl_in(folder))
    z_mid = worm.bounds[1, 2] - pair.worm_length / 2          # the thread ends at the far end
    # the axial section (file plane Y = 0): turn file Y onto Z and slice with manifold3d
    turn = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0], [0, -1.0, 0, 0], [0, 0, 0, 1.0]])
    polys = placed_manifold(folder, worm_q, turn).slice(0.0).to_polygons()

    def inside(pts):
        hit = np.zeros(len(pts), bool)
        for poly in polys:
            x0, y0 = poly[:, 0], poly[:, 1]
            x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
            for px, py, k in zip(pts[:, 0], pts[:, 1], range(len(pts))):
                cross = (y0 > py) != (y1 > py)
                xs = x0 + (py - y0) * (x1 - x0) / np.where(y1 == y0, 1, y1 - y0)
                hit[k] ^= bool(np.count_nonzero(cross & (px < xs)) % 2)
        return hit
    zs = np.linspace(z_mid - pair.pitch * 2, z_mid + pair.pitch * 2, 400)
    # after the turn, file (X, Z) lies in the slice plane as (x, y)
    probe = inside(np.column_stack([np.full_like(zs, pair.r1), zs]))
    assert 7 <= np.count_nonzero(np.diff(probe.astype(int))) <= 9      # 4 pitches: 8 flanks
    assert not inside(np.array([[pair.ra1 + 0.05, z_mid]]))[0]
    assert inside(np.array([[pair.rf1 - 0.05, z_mid]]))[0]

    wheel_q = _by_role(man, "tensioner_wheel")["C1"]
    lay = layout(_design(), p.paths, p.disks[-1])
    unit = next(u for u in lay.units if u.channel == "C1")
    z_file = (lay.wheel_flip(unit) @ [0, 0, unit.z_wheel_mid - unit.z_part[0], 1])[2]
    sec = placed_manifold(folder, wheel_q, np.eye(4)).slice(z_file).to_polygons()
    pts = np.vstack(sec)
    r = np.hypot(pts[:, 0], pts[:, 1])
    assert r.max() == pytest.approx(pair.ra2, abs=0.02)
    tips = np.sort(np.mod(np.arctan2(pts[:, 1], pts[:, 0])[r > pair.ra2 - 0.05], 2 * np.pi))
    gaps = np.diff(np.r_[tips, tips[0] + 2 * np.pi])
    assert np.count_nonzero(gaps > math.pi / pair.teeth) == pair.teeth
    # the tooth on +X at mid-width: the worm meshes there (wheel placement maps it onto the worm)
    assert np.min(np.abs(np.angle(np.exp(1j * tips)))) < math.pi / (2 * pair.teeth)


@pytest.mark.parametrize("channel", ["A", "C1", "C2", "H"])
def test_nominal_mesh_no_interference_gap_within_backlash(proto, channel):
    folder, man, p = proto
    pair = worm_pair(_design().tensioner)
    worm, wheel = _by_role(man, "tensioner_worm")[channel], _by_role(man, "tensioner_wheel")[channel]
    vol, gap = mesh_measure(placed_manifold(folder, worm), placed_manifold(folder, wheel), pair.center_offset + 1.0)
    assert vol <= INTERFERENCE_TOL_MM3
    assert gap <= pair.center_offset + GAP_TOL_MM
    assert gap > 0.0         # teeth do not touch: the backlash is real


def test_wheel_moved_toward_worm_interferes(proto):
    folder, man, _ = proto
    worm, wheel = _by_role(man, "tensioner_worm")["C1"], _by_role(man, "tensioner_wheel")["C1"]
    wm = placed_manifold(folder, worm)
    moved = placed_manifold(folder, wheel, toward(wheel, worm, 0.2))
    vol, _ = mesh_measure(wm, moved)
    assert vol > INTERFERENCE_TOL_MM3 * 10
    _, nominal = mesh_measure(wm, placed_manifold(folder, wheel))
    away = placed_manifold(folder, wheel, toward(wheel, worm, -0.2))
    _, gap = mesh_measure(wm, away)
    # 0.2 mm more centre distance opens each flank by about 0.2 sin α (less where the throated
    # wheel's flank normals lean toward its axis)
    assert gap > nominal + 0.5 * 0.2 * math.sin(math.radians(20))


def test_mesh_holds_through_the_motion_and_only_with_the_right_sense(proto):
    """Turn the worm through one pitch and the wheel by 1/ratio of that: no interference.
    Turning the wheel the wrong way collides, so the pose above is not luck."""
    folder, man, p = proto
    pair = worm_pair(_design().tensioner)
    worm, wheel = _by_role(man, "tensioner_worm")["H"], _by_role(man, "tensioner_wheel")["H"]
    wm_mesh = load_mesh(ManifestPart.of(worm).stl_in(folder))
    wh_mesh = load_mesh(ManifestPart.of(wheel).stl_in(folder))
    import manifold3d as m3d

    def man3(mesh, m):
        v = np.asarray(mesh.vertices) @ m[:3, :3].T + m[:3, 3]
        return m3d.Manifold(m3d.Mesh(vert_properties=v.astype(np.float32),
                                     tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))
    pw, ph = np.asarray(worm["placement"]), np.asarray(wheel["placement"])
    right, wrong = [], []
    # turning the worm +ψ about its axis turns the wheel -ψ/ratio about robot +z; the wheel's
    # file Z is robot ±z (files of gear-on-top wheels are turned over)
    sense = ph[2, 2]
    for psi in np.linspace(0, 2 * math.pi, 5, endpoint=False)[1:]:
        w = man3(wm_mesh, pw @ _rz(psi))
        right.append((w ^ man3(wh_mesh, ph @ _rz(-sense * psi / pair.ratio))).volume())
        wrong.append((w ^ man3(wh_mesh, ph @ _rz(sense * psi / pair.ratio))).volume())
    assert max(right) <= INTERFERENCE_TOL_MM3
    assert max(wrong) > 1.0


def test_centre_distance_shaft_angle_and_counts_come_from_the_meshes(proto):
    """Axes fitted to each worm's and wheel's crests (not read from the placements) meet at
    (d1 + d2)/2 + center_offset and 90°; 24 teeth and 1 start counted in their sections."""
    folder, man, p = proto
    pair = worm_pair(_design().tensioner)
    for ch, worm in _by_role(man, "tensioner_worm").items():
        m = measure_pair(folder, worm, _by_role(man, "tensioner_wheel")[ch])
        assert m["worm_axis"].rms < 0.005 and m["wheel_axis"].rms < 0.005
        assert m["center_distance"] == pytest.approx(pair.center_distance, abs=0.002)
        assert m["shaft_angle"] == pytest.approx(90.0, abs=0.01)
        assert (m["teeth"], m["starts"]) == (pair.teeth, pair.starts)


def _tip_radii(mesh, axis, bands):
    """Largest radius of the STL's vertices in bands along the fitted axis (from mid-crest)."""
    rad, along = axis.radial(mesh.vertices)
    mid = sum(axis.crest) / 2
    return [float(rad[(along >= mid + lo) & (along < mid + hi)].max()) for lo, hi in bands]


def test_wheel_tip_is_throated(proto):
    """Measured on the exported STL: the tip radius at mid-face is the throat radius, smaller
    than toward the face edges (the wheel wraps round the worm)."""
    folder, man, p = proto
    pair = worm_pair(_design().tensioner)
    mesh = placed_mesh(folder, _by_role(man, "tensioner_wheel")["C1"])
    ax = fit_axis(mesh)
    h = pair.face_width / 2
    centre, lo, hi = _tip_radii(mesh, ax, [(-0.2, 0.2), (-0.8 * h, -0.5 * h), (0.5 * h, 0.8 * h)])
    assert centre == pytest.approx(pair.ra2, abs=0.01)
    assert lo > centre + 0.1 and hi > centre + 0.1
    assert ax.radius == pytest.approx(pair.outside_radius, abs=0.005)


def _gear_checks_of(checks, channel=None):
    return {c.id: c for c in checks if c.id.startswith("gear.") and c.where.get("channel") in (channel, "all")}


def test_moved_wheels_and_an_edited_mesh_are_caught(proto, tmp_path):
    """In a copy of the design: channel C1's wheel placed 0.2 mm toward its worm (overlap),
    C2's 0.1 mm (back at the generating distance: flanks touch, no measurable overlap, the gap
    check sees it), and H's wheel STL moved 0.05 mm away from its worm in its own file (placement untouched):
    each fails on the measured centre distance; A, untouched, passes."""
    import copy
    import shutil
    folder, man, p = proto
    work = tmp_path / "design"
    shutil.copytree(folder, work)
    moved = copy.deepcopy(man)
    worms, wheels = _by_role(moved, "tensioner_worm"), _by_role(moved, "tensioner_wheel")
    wheels["C1"]["placement"] = toward(wheels["C1"], worms["C1"], 0.2).tolist()
    wheels["C2"]["placement"] = toward(wheels["C2"], worms["C2"], 0.1).tolist()
    ph = np.asarray(wheels["H"]["placement"])
    away = toward(wheels["H"], worms["H"], -1.0)[:3, 3] - ph[:3, 3]      # unit vector from the worm, robot frame
    stl = ManifestPart.of(wheels["H"]).stl_in(work)
    mesh = load_mesh(stl)
    mesh.apply_translation(0.05 * ph[:3, :3].T @ away)                  # the same move, in the file's frame
    mesh.export(stl)
    checks = gear_checks(work, moved["parts"], p)
    a, c1, c2, h = (_gear_checks_of(checks, ch) for ch in ("A", "C1", "C2", "H"))
    assert all(c.passed for c in a.values() if c.severity == "error")
    for ch in (c1, c2, h):
        assert not ch["gear.center_distance"].passed
    assert not c1["gear.interference"].passed and c1["gear.interference"].measured > 0.1
    assert c2["gear.interference"].passed and not c2["gear.gap"].passed and c2["gear.gap"].measured < 0.005
    nominal = worm_pair(_design().tensioner).center_distance
    assert h["gear.center_distance"].measured == pytest.approx(nominal + 0.05, abs=0.002)
    assert c1["gear.center_distance"].measured == pytest.approx(nominal - 0.2, abs=0.002)


def test_counts_are_read_from_the_sections(proto):
    """The design says 25 teeth (module 1.2, so the pitch circle stays): the 24 teeth counted
    in the wheel's section fail the check."""
    import dataclasses
    folder, man, p = proto
    ts = _design().tensioner.model_copy(update={"wheel_teeth": 25, "module": 1.2})
    lay = dataclasses.replace(p.tensioner_layout, pair=worm_pair(ts, p.min_wall))
    one = [_by_role(man, "tensioner_worm")["C1"], _by_role(man, "tensioner_wheel")["C1"]]
    checks = gear_checks(folder, one, dataclasses.replace(p, tensioner_layout=lay))
    teeth = next(c for c in checks if c.id == "gear.teeth")
    assert not teeth.passed and teeth.measured == 24 and teeth.limit == 25
    assert next(c for c in checks if c.id == "gear.starts").passed
    worm = placed_mesh(folder, _by_role(man, "tensioner_worm")["C1"])
    assert count_teeth(worm, fit_axis(worm)) == 1


def test_every_tendon_clears_every_other_part(proto):
    folder, man, p = proto
    checks = tendon_checks(folder, Manifest.of(man), p)
    clear = [c for c in checks if c.id == "tensioner.tendon_clearance"]
    assert sorted(c.where["tendon"] for c in clear) == sorted(t.name for t in p.paths)
    d = p.tendon_material.diameter
    for c in clear:
        assert c.passed and c.measured >= d, c.message


def test_a_stronger_line_fails_the_default_gear_with_the_face_that_holds_it(proto):
    """A lab that chose only a 90 N line on the default 8 mm face: the gear checks once crashed
    writing the fix (they read the face, teeth and module off the tensioner's settings, which hold
    none); the fix now names the built pair's values, scaled by the safety it lacks."""
    folder, man, p = proto
    strong = dataclasses.replace(p, tendon_material=dataclasses.replace(p.tendon_material, break_load=90.0))
    checks = gear_checks(folder, man["parts"], strong)
    pair = worm_pair(_design().tensioner)
    lewis = [c for c in checks if c.id == "gear.lewis" and not c.passed]
    assert lewis
    for c in lewis:
        first = c.to_json()["fixes"][0]                      # tried: the Lewis law on the measured tooth
        face = first["set"]["tensioner.face_width"]
        assert first["then"]["passed"] and f"from {pair.face_width:g} mm" in first["note"]
        assert face == pytest.approx(pair.face_width * c.limit / c.measured, abs=0.1)
        assert f"tensioner.wheel_teeth from {pair.teeth} " in c.fix and f"module from {pair.module:g} " in c.fix


def test_the_gear_process_keeps_what_it_raises_to_itself(monkeypatch, capsys):
    """The gear checks made beside the build in a process of their own: what they raise is not
    printed there (the build's own process makes the same measurement and reports it, with its
    traceback only under HWGEN_DEBUG)."""
    import hwgen.checks.gear_mesh as gm
    from hwgen.cache import Store
    from hwgen.engine.concurrency import gear_checks_in_child

    def broken(*args):
        raise AttributeError("no such setting")
    monkeypatch.setattr(gm, "gear_checks", broken)
    gear_checks_in_child(None, [], None, Store(None))
    assert capsys.readouterr() == ("", "")


def test_tendon_runs_start_at_the_tip_eyelets(proto):
    """The free spans start where the routing puts each tendon at the tip disk."""
    _, man, p = proto
    tip = p.disks[-1]
    y_face = tip.y + tip.thickness / 2
    runs = {r["tendon"]: r for q in man["parts"] for r in q.get("tendon_runs", [])}
    for t in p.paths:
        x, z = t.points[-1]
        assert runs[t.name]["start"] == pytest.approx([x, y_face, z])
        # each run lies in its plane z = const and ends on its own channel's wheel
        assert runs[t.name]["end"][2] == pytest.approx(z)


def test_gear_checks_pass_on_the_prototype(proto):
    folder, man, p = proto
    checks = gear_checks(folder, man["parts"], p)
    failed = [c.message for c in checks if c.severity == "error" and not c.passed]
    assert not failed
    ids = {c.id for c in checks}
    assert {"gear.center_distance", "gear.shaft_angle", "gear.teeth", "gear.starts", "gear.interference", "gear.gap",
            "gear.backlash", "gear.loaded_face", "gear.lewis", "gear.hertz", "gear.worm_torque", "gear.ratio",
            "gear.lead_angle"} <= ids
    # loading refuses what is not self-locking or undercut: no check that could never fail
    assert not {"gear.self_locking", "gear.undercut"} & ids
    pair = worm_pair(_design().tensioner)
    face = next(c for c in checks if c.id == "gear.loaded_face")
    assert 0.95 * pair.face_width < face.measured <= pair.face_width + 0.01      # throated: the whole face
    lash = next(c for c in checks if c.id == "gear.backlash")
    assert 0.5 * lash.limit < lash.measured < lash.limit       # less than the rack formula: normals lean off-plane
    lewis = [c for c in checks if c.id == "gear.lewis"]
    assert all(c.where["face_mm"] == face.measured for c in lewis)
    # the actuating drum carries two tendons: twice the stress of a single-tendon channel
    sa = next(c for c in lewis if c.where["channel"] == "A").where["stress_mpa"]
    sc = next(c for c in lewis if c.where["channel"] == "C1").where["stress_mpa"]
    assert sa == pytest.approx(2 * sc)
    hz = {c.where["channel"]: c.where["p0_mpa"] for c in checks if c.id == "gear.hertz"}
    assert hz["A"] == pytest.approx(math.sqrt(2) * hz["C1"])          # p0 ∝ √F


def test_tensioner_parts_fit_the_printer(proto):
    folder, man, p = proto
    vol = np.asarray(p.process.build_volume)
    for q in man["parts"]:
        if q["role"].startswith("tensioner"):
            b = load_mesh(ManifestPart.of(q).stl_in(folder)).bounds
            assert np.all(b[1] - b[0] <= vol), (q["name"], b)
            assert b[0, 2] == pytest.approx(0.0, abs=1e-3), q["name"]   # rests on the build plate


def test_worm_is_turned_from_outside(proto):
    """A straight line along each worm's axis from its drive shaft's hex socket outward meets no part."""
    folder, man, _ = proto
    drives = _by_role(man, "tensioner_drive")
    solids = [placed_manifold(folder, q) for q in man["parts"] if q["role"] not in ("tensioner_worm", "tensioner_drive")]
    import manifold3d as m3d
    for ch, q in drives.items():
        m = np.asarray(q["placement"])
        worm = np.asarray(_by_role(man, "tensioner_worm")[ch]["placement"])
        assert np.allclose(m[:3, 2], worm[:3, 2]) and np.linalg.norm(np.cross(m[:3, 3] - worm[:3, 3], m[:3, 2])) < 1e-9
        p0 = m[:3, 3]                       # the socket's face centre (file origin)
        out = -m[:3, 2]                     # file -Z leaves the shaft at its socket
        key_r = 1.2                         # a 2.5 mm key's inscribed radius
        x = np.cross(out, [0, 0, 1.0])
        x /= np.linalg.norm(x)
        y = np.cross(out, x)
        shaft = m3d.Manifold.cylinder(40.0, key_r, key_r, 16).transform(
            np.column_stack([x, y, out, p0 + 0.05 * out]).tolist())
        for s in solids:
            assert (shaft ^ s).volume() < 1e-6, ch


def test_turning_parts_clear_the_housing_at_every_angle(proto):
    """Wheel (with its clamps) and worm turned about their own axes never touch the housing."""
    folder, man, p = proto
    housing = placed_manifold(folder, next(q for q in man["parts"] if q["role"] == "tensioner_housing"))
    for ch, wheel in _by_role(man, "tensioner_wheel").items():
        worm = _by_role(man, "tensioner_worm")[ch]
        ph, pw = np.asarray(wheel["placement"]), np.asarray(worm["placement"])
        clamps = [q for q in man["parts"] if q["role"] == "tensioner_clamp" and q["channel"] == ch]
        drive = placed_manifold(folder, _by_role(man, "tensioner_drive")[ch])
        assert drive.min_gap(housing, 0.3) < 1e-6 and (drive ^ housing).volume() < 1e-3   # seated, not sunk
        assert (drive ^ placed_manifold(folder, worm)).volume() < 1e-3                           # in the worm's bore
        for a in np.linspace(0, 2 * math.pi, 6, endpoint=False):
            turn = ph @ _rz(a) @ np.linalg.inv(ph)          # about the wheel's axis, in robot space
            for q in [wheel] + clamps:
                s = placed_manifold(folder, q, turn @ np.asarray(q["placement"]))
                assert s.min_gap(housing, 0.3) >= 0.05, (ch, q["name"], a)
            w = placed_manifold(folder, worm, pw @ _rz(a))
            assert w.min_gap(housing, 0.3) >= 0.05, (ch, a)
            d = placed_manifold(folder, _by_role(man, "tensioner_drive")[ch], pw @ _rz(a) @ np.linalg.inv(pw)
                         @ np.asarray(_by_role(man, "tensioner_drive")[ch]["placement"]))
            assert (d ^ housing).volume() < 1e-3, (ch, a)    # the shaft turns in the spine's hole


def test_hex_socket_for_the_key(proto):
    folder, man, p = proto
    key = _design().tensioner.hex_key
    drive_q = _by_role(man, "tensioner_drive")["A"]
    polys = placed_manifold(folder, drive_q, np.eye(4)).slice(2.0).to_polygons()
    areas = sorted(abs(0.5 * np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1]))
                   for q in polys)
    hexagon = math.sqrt(3) / 2 * (key + 0.1) ** 2            # across flats: key + clearance
    assert len(polys) == 2
    assert areas[0] == pytest.approx(hexagon, rel=0.02)
    assert areas[0] > math.sqrt(3) / 2 * key ** 2             # the key itself fits


@pytest.mark.parametrize("change", [
    {"module": 1.5, "wheel_teeth": 30, "worm_pitch_diameter": 17, "worm_length": 30},
    {"worm_starts": 2, "worm_pitch_diameter": 20, "friction_coefficient": 0.3},
    {"wheel_teeth": 40, "face_width": 6, "spool_diameter": 14, "worm_length": 30},
])
def test_layout_adapts_to_other_gears(tmp_path, change):
    """Bigger gears and worms: the layout keeps the units apart, the worms off their own
    tendons' planes and the tendons' turn at the tip within its limit (numpy only)."""
    import yaml

    from hwgen.model.tensioner_layout.sizes import WORM_CLEAR
    data = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
    data["tensioner"].update(change)
    f = tmp_path / "v.yaml"
    f.write_text(yaml.safe_dump(data))
    d = load(f).design
    p = make_plan(d)
    lay = layout(d, p.paths, p.disks[-1])
    pair = lay.pair
    assert pair.center_distance == pytest.approx(lay.units[0].worm_y - lay.units[0].center[1]
                                                 if lay.units[0].side > 0 else
                                                 lay.units[0].center[1] - lay.units[0].worm_y)
    for u in lay.units:
        zs = [t.points[-1][1] for t in p.paths if t.channel == u.channel]
        assert min(abs(u.worm_z - z) for z in zs) >= pair.ra1 + WORM_CLEAR - 1e-9
    assert max(r.exit_angle_deg for r in lay.runs) <= d.tensioner.max_exit_deg + 1e-6
    # units in one column do not overlap along y
    for s in (1, -1):
        col = sorted((u for u in lay.units if u.side == s), key=lambda u: u.center[1])
        for u, v in zip(col, col[1:]):
            top = max(u.center[1] + pair.ra2, u.worm_y + pair.ra1) if s > 0 else u.center[1] + pair.ra2
            bottom = min(v.center[1] - pair.ra2, v.worm_y - pair.ra1) if s < 0 else v.center[1] - pair.ra2
            assert bottom > top


def test_tendon_clearance_check_sees_a_part_in_the_way(proto):
    """Shift the housing along z (in a copy of the manifest) until its strip-clamp bar lies
    across a tendon's exit: the check must fail, naming the housing."""
    import copy
    folder, man, p = proto
    moved = copy.deepcopy(man)
    h = next(q for q in moved["parts"] if q["role"] == "tensioner_housing")
    z_run = min((r["start"][2] for q in man["parts"] for r in q.get("tendon_runs", [])), key=abs)
    h["placement"][2][3] += z_run - 2.0          # the bar spans z -1.5..6 about the strip
    failed = [c for c in tendon_checks(folder, Manifest.of(moved), p) if c.id == "tensioner.tendon_clearance" and not c.passed]
    assert failed and all(c.where["part"] == "tensioner_housing" for c in failed)


def test_a_wheel_is_kept_under_its_own_stack_not_where_the_layout_puts_it(tmp_path):
    """C2's amplitude 25 → 24.5 mm moves its tip eyelet and so the tensioner's layout (its runs, C2's
    unit), but no channel's stack of drum, flanges, caps and clamps: every wheel's spec, the key it
    is kept under, is the same, so the edit finds its wheels made. A stack that changes changes it."""
    import dataclasses

    from hwgen import cache
    from hwgen.cad.wheel import wheel_spec

    text = (PARAMS / "prototype.yaml").read_text()
    edited = text.replace("function: {kind: cosine, a: 25, k: 3, axis: z}", "function: {kind: cosine, a: 24.5, k: 3, axis: z}")
    assert edited != text
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    (tmp_path / "a" / "prototype.yaml").write_text(text)
    (tmp_path / "b" / "prototype.yaml").write_text(edited)
    la, lb = (make_plan(load(tmp_path / d / "prototype.yaml").design).require_tensioner_layout() for d in "ab")
    assert cache.key(la) != cache.key(lb)                      # the layout moved
    ua, ub = {u.channel: u for u in la.units}, {u.channel: u for u in lb.units}
    bore = la.shaft_diameter + la.running_fit
    for c in ua:
        assert wheel_spec(la, ua[c], bore) == wheel_spec(lb, ub[c], bore)
    u = ua["C1"]
    taller = dataclasses.replace(u, z_part=(u.z_part[0], u.z_part[1] + 1.0))
    assert wheel_spec(la, taller, bore) != wheel_spec(la, u, bore)
