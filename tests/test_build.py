"""The shipped designs build into real, printable files: measured from the files themselves."""
from __future__ import annotations

import json

import numpy as np
import pytest

from hwgen.cad.manifest import ManifestPart
from hwgen.checks.meshes import load_mesh
from hwgen.checks.sections import disk_mid_section, section_loops
from hwgen.pipeline import load
from hwgen.model.routing import tendon_paths

from .conftest import PARAMS

DESIGNS = ["prototype", "paper-table2"]
CENTRE_TOL_MM = 0.02


def _manifest(folder):
    return json.loads((folder / "manifest.json").read_text())


def _disks(man):
    return sorted((p for p in man["parts"] if p["role"] == "disk"), key=lambda p: p["station"])


@pytest.mark.parametrize("name", DESIGNS)
def test_eyelet_centres_match_routing(built, name):
    """Section every disk STL at its mid-plane, map through placement, find each tendon's hole."""
    folder = built(name)
    d = load(PARAMS / f"{name}.yaml").design
    paths = tendon_paths(d)
    half_slot = (d.backbone.height / 2 + d.disks.slot_clearance, d.backbone.thickness / 2 + d.disks.slot_clearance)
    disks = _disks(_manifest(folder))
    assert [p["station"] for p in disks] == list(range(d.disks.count))
    worst, in_slot = 0.0, []
    for part in disks:
        i = part["station"]
        sec = disk_mid_section(ManifestPart.of(part).stl_in(folder), np.array(part["placement"]))
        assert sec.y_mid == pytest.approx(d.stations[i], abs=1e-6)
        slot = max(sec.inner, key=lambda lp: lp.extent[0])
        holes = [lp for lp in sec.inner if lp is not slot]
        for p in paths:
            x, z = p.points[i]
            if abs(x) <= half_slot[0] and abs(z) <= half_slot[1]:
                in_slot.append((p.name, i))   # the eyelet opens into the backbone slot
                continue
            dist = min(np.hypot(h.centroid[0] - x, h.centroid[1] - z) for h in holes)
            assert dist < CENTRE_TOL_MM, f"{p.name} at disk {i}: nearest hole {dist:.4f} mm from ({x}, {z})"
            worst = max(worst, dist)
    # the only unmeasurable eyelets are the recorded backbone crossings
    recorded = {(h["tendon"], int(h["station"])) for h in _manifest(folder)["design_report"]["backbone_holes"]
                if float(h["station"]).is_integer()}
    assert set(in_slot) == recorded
    assert worst < CENTRE_TOL_MM


@pytest.mark.parametrize("name", DESIGNS)
def test_slot_and_thickness_measured(built, name):
    folder = built(name)
    d = load(PARAMS / f"{name}.yaml").design
    c = d.disks.slot_clearance
    for part in _disks(_manifest(folder)):
        i = part["station"]
        sec = disk_mid_section(ManifestPart.of(part).stl_in(folder), np.array(part["placement"]))
        end = i in (0, d.disks.count - 1)
        assert sec.thickness == pytest.approx(d.disks.end_thickness if end else d.disks.thickness, abs=1e-6)
        assert sec.outline.extent[0] == pytest.approx(d.disks.outer_diameter, abs=0.02)
        slot = max(sec.inner, key=lambda lp: lp.extent[0])
        assert slot.extent[0] == pytest.approx(d.backbone.height + 2 * c, abs=1e-4)
        # an eyelet inside the slot widens it locally; measure the slot's narrowest span
        at_end = slot.points[np.abs(slot.points[:, 0]) > d.backbone.height / 2 - 0.5]
        assert np.ptp(at_end[:, 1]) == pytest.approx(d.backbone.thickness + 2 * c, abs=1e-4)


@pytest.mark.parametrize("name", DESIGNS)
def test_meshes_watertight_and_print_oriented(built, name):
    folder = built(name)
    for part in _manifest(folder)["parts"]:
        mesh = load_mesh(ManifestPart.of(part).stl_in(folder))
        assert mesh.is_watertight and mesh.is_volume, part["name"]
        assert mesh.volume == pytest.approx(part["volume_mm3"], rel=2e-3), part["name"]
        # a flat face rests on the plate: the largest one that can (nothing of the part beyond its
        # plane: the base frame's cradle's flange face has the hub standing out of it), but for the
        # housing, which stands on the face that bolts to the tip disk (its walls upright, its
        # windows' roofs at 45°)
        assert mesh.bounds[0, 2] == pytest.approx(0, abs=1e-6), part["name"]
        areas, normals = mesh.facets_area, mesh.facets_normal
        on_plate = [a for a, n, f in zip(areas, normals, mesh.facets)
                    if n[2] < -0.999999 and abs(mesh.vertices[mesh.faces[f[0]]][:, 2]).max() < 1e-6]
        assert on_plate, part["name"]
        if part["role"] == "tensioner_housing":
            to_robot = np.asarray(part["placement"])
            assert np.allclose(to_robot[:3, 2], [0, 1, 0])                  # file +Z is robot +y: away from the tip
        elif part.get("bench"):
            # the bench's parts rest on a face square to their bearing seats and bores
            # (test_bench_hardware), which need not be their largest
            continue
        else:
            # every larger face has the part standing out beyond its plane
            for i in np.flatnonzero(areas > max(on_plate) / 0.999):
                plane = mesh.vertices[mesh.faces[mesh.facets[i][0]][0]] @ normals[i]
                assert (mesh.vertices @ normals[i]).max() > plane + 1e-6, (part["name"], areas[i])


def test_files_hashed_in_manifest(built):
    import hashlib
    folder = built("prototype")
    man = _manifest(folder)
    assert man["params_sha256"] == hashlib.sha256((PARAMS / "prototype.yaml").read_bytes()).hexdigest()
    for part in man["parts"]:
        for f in part["files"].values():
            assert hashlib.sha256((folder / f["path"]).read_bytes()).hexdigest() == f["sha256"]
        assert np.allclose(np.array(part["placement"])[3], [0, 0, 0, 1])


def test_step_files_reimport_as_valid_solids(built):
    import cadquery as cq

    from hwgen.cad import mass_properties
    folder = built("prototype")
    for part in _manifest(folder)["parts"]:
        shape = cq.importers.importStep(str(folder / ManifestPart.of(part).step)).val()
        assert shape.isValid(), part["name"]
        assert len(shape.Solids()) == 1, part["name"]
        assert mass_properties(shape)[0] == pytest.approx(part["volume_mm3"], rel=1e-6), part["name"]


def test_assembly_holds_every_part_by_name(built):
    import cadquery as cq
    folder = built("prototype")
    man = _manifest(folder)
    assy = cq.Assembly.importStep(str(folder / "assembly.step"))
    names = {name.split("/")[-1] for name, _ in assy.traverse()}
    assert {p["name"] for p in man["parts"]} <= names
    # parts sit in robot coordinates: the tip disk's outer face lies half its thickness beyond y = L
    # (its hub runs toward the base)
    tip = assy.objects[max((p for p in man["parts"] if p["role"] == "disk"), key=lambda p: p["station"])["name"]]
    bb = tip.toCompound().BoundingBox()  # toCompound applies the child location
    assert bb.ymax - 6.0 / 2 == pytest.approx(270.0, abs=1e-6)


def test_backbone_template_and_strip_have_every_crossing(built):
    """Crossings computed here from the routing must be holes in the DXF and in the strip STL."""
    import ezdxf
    folder = built("prototype")
    d = load(PARAMS / "prototype.yaml").design
    expected = set()
    for p in tendon_paths(d):
        for i, (x, z) in enumerate(p.points):
            if abs(z) < 1e-9 and abs(x) < d.backbone.height / 2:
                expected.add((round(x, 3), round(d.stations[i], 3)))
    assert len(expected) == 6  # C1+C2 share (0, 135); C2 at y = 45, 225; H at x = ±25
    circles = {(round(c.dxf.center.x, 3), round(c.dxf.center.y, 3))
               for c in ezdxf.readfile(folder / "backbone_template.dxf").modelspace().query("CIRCLE")}
    assert circles == expected
    part = next(p for p in _manifest(folder)["parts"] if p["role"] == "backbone")
    mesh = load_mesh(ManifestPart.of(part).stl_in(folder))
    loops = section_loops(mesh, np.array(part["placement"]), [0, 0, mesh.bounds[:, 2].mean()], [0, 0, 1],
                          axes=(0, 1))
    holes = {(round(lp.centroid[0], 3), round(lp.centroid[1], 3)) for lp in loops[1:]}
    assert holes == expected
    outline = loops[0]
    assert outline.extent == pytest.approx((d.backbone.height, d.backbone.length + d.backbone.extra_base
                                            + d.backbone.extra_tip), abs=1e-6)


@pytest.mark.slow
def test_failed_build_leaves_previous_outputs(tmp_path, monkeypatch):
    from hwgen import pipeline as build_mod
    loaded = load(PARAMS / "prototype.yaml")
    first = build_mod.build(loaded, tmp_path, post_build=False).folder
    before = {p.relative_to(tmp_path): p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}

    def boom(given):
        raise RuntimeError("simulated failure after the parts were written")

    monkeypatch.setattr(build_mod, "AFTER_FILES", [("boom", boom)])
    with pytest.raises(RuntimeError):
        build_mod.build(loaded, tmp_path)
    after = {p.relative_to(tmp_path): p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    assert after == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [first.name]


def test_masses_are_volume_times_density(built):
    """Every part's mass is its volume times its material's density; the report sums the STLs."""
    folder = built("prototype")
    m = json.loads((folder / "manifest.json").read_text())
    d = load(PARAMS / "prototype.yaml").design
    for p in m["parts"]:
        rho = d.backbone.density_g_cm3 if p["role"] == "backbone" else 1.15   # standard_resin in materials.csv
        assert p["density_g_cm3"] == pytest.approx(rho), p["name"]
        assert p["mass_g"] == pytest.approx(p["volume_mm3"] / 1000 * rho, rel=1e-9), p["name"]
        mesh = load_mesh(ManifestPart.of(p).stl_in(folder))
        com = np.asarray(p["placement"])[:3, :3] @ mesh.center_mass + np.asarray(p["placement"])[:3, 3]
        assert np.allclose(com, p["center_of_mass_mm"], atol=0.05), p["name"]
    mass = json.loads((folder / "report.json").read_text())["mass"]
    free = [p for p in m["parts"] if p["role"].startswith("tensioner")]
    assert sorted(mass["free_end"]["parts"]) == sorted(p["name"] for p in free)
    assert mass["free_end"]["mass_g"] == pytest.approx(sum(p["mass_g"] for p in free), rel=0.01)
    robot = [p for p in m["parts"] if not p.get("fixture") and not p.get("bench")]   # nor the jig, the frame, the rig
    assert len(robot) < len(m["parts"]) - 2
    assert mass["total"]["mass_g"] == pytest.approx(sum(p["mass_g"] for p in robot), rel=0.01)
    assert mass["free_end"]["center_of_mass_mm"][1] > d.backbone.length
