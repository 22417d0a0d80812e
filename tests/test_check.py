"""`hwgen check`: each check passes on the prototype and fails, naming the place, on a design or
a file made to break it. Faults the YAML cannot express are made in copies of the built files."""
from __future__ import annotations

import dataclasses
import json
import re
import math
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import yaml

from hwgen.cad import families as assembly
from hwgen.pipeline import build
from hwgen.checks.clearances import segment_distance
from hwgen.pipeline import stale_reason
from hwgen.checks.run import run_checks
from hwgen.model.plan import make_plan
from hwgen.cad.manifest import Manifest, sha256
from hwgen.pipeline import load

from .conftest import PARAMS


def _run(*args, timeout=300):
    return subprocess.run([sys.executable, "-m", "hwgen.cli", *args], capture_output=True, text=True,
                          timeout=timeout)


def _copy(built, tmp_path, name="prototype"):
    """A copy of the built design under tmp_path/out/<name>, safe to modify."""
    root = tmp_path / "out"
    shutil.copytree(built(name), root / name)
    return root, root / name


def _check(folder, params="prototype"):
    manifest = json.loads((folder / "manifest.json").read_text())
    return run_checks(folder, Manifest.of(manifest), make_plan(load(PARAMS / f"{params}.yaml").design))


def _failed(rep, cid):
    return [c for c in rep["checks"] if c["id"] == cid and not c["passed"]]


def _drawn(ax):
    """The labelled lines of an axes (matplotlib names the unlabelled ones "_child…")."""
    return [ln for ln in ax.get_lines() if not ln.get_label().startswith("_")]


def _levels(ax) -> set[float]:
    """The heights of the horizontal lines drawn across an axes (axhline)."""
    return {round(float(ln.get_ydata()[0]), 9) for ln in ax.get_lines()
            if ln.get_label().startswith("_") and len(set(ln.get_ydata())) == 1}


def _assert_lengths_figure(rep):
    """lengths.png as drawn: every tendon's ΔL over the sweep on top, labelled; the budgeted ones
    below, over budget said in their label, with their ±budget lines; the axes named."""
    import matplotlib.pyplot as plt

    from hwgen.outputs.plots import lengths_figure
    fig = lengths_figure(rep)
    try:
        stiff = [t for t in rep["tendons"] if t["budget_mm"] is not None]
        assert stiff and len(fig.axes) == 2
        top, bot = fig.axes
        assert [ln.get_label() for ln in _drawn(top)] == [t["name"] for t in rep["tendons"]]
        for ln, t in zip(_drawn(top), rep["tendons"]):
            assert np.allclose(ln.get_xdata(), rep["sweep"]["angles_deg"]) and np.allclose(ln.get_ydata(), t["delta_mm"])
        assert [ln.get_label() for ln in _drawn(bot)] == [t["name"] + ("" if t["passed"] else " (over budget)")
                                                         for t in stiff]
        assert {round(s * t["budget_mm"], 9) for t in stiff for s in (1, -1)} | {0.0} == _levels(bot)
        assert top.get_ylabel() == bot.get_ylabel() == "ΔL (mm)"
        assert bot.get_xlabel() == "constant-curvature bending angle (deg)"
        assert top.get_title().startswith(rep["design"])
    finally:
        plt.close(fig)


def test_prototype_passes_every_check_and_build_writes_report(built):
    folder = built("prototype")
    rep = json.loads((folder / "report.json").read_text())
    assert rep["ok"] and rep["design"] == "prototype"
    ids = {c["id"] for c in rep["checks"]}
    for cid in ("eyelet.position", "eyelet.wall.edge", "eyelet.wall.eyelet", "eyelet.wall.slot", "eyelet.min_hole",
                "eyelet.tendon_angle", "tendon.clearance", "tendon.contact", "backbone.crossing", "part.mesh",
                "part.interference", "part.build_volume", "tendon.length", "tendon.take_up"):
        assert cid in ids, cid
    for c in rep["checks"]:
        assert set(c) >= {"id", "severity", "passed", "message", "measured", "limit", "where"}
        assert c["severity"] in ("error", "warning", "info")
    # measured values, not placeholders: eyelets within a micrometre, the thinnest edge wall the rim
    # less the outermost hole (an eyelet or a screw hole) as the design places it, to the mesh's chords
    pos = [c["measured"] for c in rep["checks"] if c["id"] == "eyelet.position"]
    assert len(pos) == 13 and max(pos) < 1e-3
    edge = min(c["measured"] for c in rep["checks"] if c["id"] == "eyelet.wall.edge")
    disks = json.loads((folder / "manifest.json").read_text())["design_report"]["disks"]
    designed = min(d["outer_diameter_mm"] / 2 - math.hypot(x, z) - dia / 2 for d in disks
                   for x, z, dia in [(h["x"], h["z"], h["diameter_mm"]) for h in d["holes"]] + d["mount_holes"])
    assert designed - 0.05 < edge < designed + 0.01
    # every disk is intersected with the strip through it; nothing is shared
    inter = {tuple(sorted(c["where"]["parts"])): c for c in rep["checks"] if c["id"] == "part.interference"}
    assert {("backbone", f"disk_{i:02d}") for i in range(13)} <= set(inter)
    assert all(c["passed"] and c["measured"] < 1e-3 for c in inter.values())
    contacts = {tuple(c["where"]["tendons"]): c["where"]["stations"]
                for c in rep["checks"] if c["id"] == "tendon.contact"}
    assert contacts[("C1", "C2")] == [0, 6, 12]
    # the build published the checks with the files
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["checks"] == rep["checks"]
    assert (folder / "lengths.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    _assert_lengths_figure(rep)
    summary = (folder / "summary.md").read_text()
    assert summary.startswith("# prototype: PASS") and "| C2 | C2 |" in summary


def test_report_json_has_the_keys_its_type_names(built):
    """report.json as both shipped designs write it, read back through read_report: every key the
    Report type names and no other, and each check, tendon, eyelet and the sweep with their
    records' keys (the writer and the type cannot drift apart)."""
    from typing import get_type_hints

    from hwgen.checks.report import CheckRecord, EyeletRecord, Report, SweepRecord, TendonRecord, read_report
    for name in ("prototype", "paper-table2"):
        rep = read_report(built(name))
        assert set(Report.__required_keys__) <= set(rep) <= set(get_type_hints(Report)), name
        assert ("bench" in rep) == (name == "prototype"), name     # the optional section: the prototype stands in its bench
        assert set(rep["sweep"]) == set(get_type_hints(SweepRecord))
        for records, kind in ((rep["checks"], CheckRecord), (rep["tendons"], TendonRecord),
                              (rep["eyelets"], EyeletRecord)):
            need, may = set(kind.__required_keys__), set(kind.__optional_keys__)     # a check's tried fixes may be absent
            assert records and all(need <= set(r) <= need | may for r in records), (name, kind.__name__)


def test_paper_table2_build_and_check_exit_1(built, tmp_path):
    root, folder = _copy(built, tmp_path, "paper-table2")
    assert "## Failed" in (folder / "summary.md").read_text()
    manifest = json.loads((folder / "manifest.json").read_text())      # what makes `hwgen build` exit 1
    assert manifest["checks_ok"] is False
    failed = [c for c in manifest["checks"] if not c["passed"] and c["severity"] == "error"]
    assert [(c["id"], c["where"]["tendon"]) for c in failed] == [("tendon.robust", "C1"), ("tendon.robust", "C2")]
    r = _run("check", str(PARAMS / "paper-table2.yaml"), "--out", str(root), "--junit", str(tmp_path / "j.xml"))
    assert r.returncode == 1, r.stderr
    assert "built" not in r.stderr           # outputs were current: measured, not rebuilt
    assert "paper-table2: FAIL" in r.stdout and "coupling budget" in r.stdout
    suite = ET.parse(tmp_path / "j.xml").getroot().find("testsuite")
    cases = suite.findall("testcase")
    failures = [c for c in cases if c.find("failure") is not None]
    assert int(suite.get("tests")) == len(cases) > 100
    assert len(failures) == int(suite.get("failures")) == 2
    assert {f.get("classname") for f in failures} == {"hwgen.paper-table2.tendon.robust"}
    assert failures[1].find("failure").get("message").startswith("C2: 0.213 mm through the hole centres")


def test_check_exit_codes_and_report(built, tmp_path):
    root, _ = _copy(built, tmp_path)
    out = tmp_path / "r.json"
    r = _run("check", str(PARAMS / "prototype.yaml"), "--out", str(root), "--report", str(out))
    assert r.returncode == 0, r.stdout + r.stderr
    rep = json.loads(out.read_text())
    assert rep["ok"] and {t["name"] for t in rep["tendons"]} == {"A1", "A2", "C1", "C2", "H"}
    for t in rep["tendons"]:
        assert set(t) >= {"name", "source", "rest_length_mm", "delta_at_max_mm", "delta_at_min_mm",
                          "max_abs_delta_mm", "budget_mm", "passed"}
    bad = tmp_path / "bad.yaml"
    bad.write_text((PARAMS / "prototype.yaml").read_text().replace("count: 13", "count: -1"))
    r = _run("check", str(bad), "--out", str(root))
    assert r.returncode == 2 and "disks.count" in r.stderr


def test_staleness_is_inputs_not_outputs(built, tmp_path):
    loaded = load(PARAMS / "prototype.yaml")
    root, folder = _copy(built, tmp_path)
    assert stale_reason(folder, loaded) is None
    (folder / "stl" / "disk_03.stl").write_bytes(b"edited")          # changed file: measured, not rebuilt
    assert stale_reason(folder, loaded) is None
    (folder / "step" / "disk_03.step").unlink()
    assert "disk_03.step" in stale_reason(folder, loaded)
    other = load(PARAMS / "paper-table2.yaml")
    assert stale_reason(folder, other) is not None
    assert stale_reason(tmp_path / "nothing", loaded) == "no outputs yet"


def test_moved_eyelet_in_exported_disk_is_caught(built, tmp_path):
    """A fault the YAML cannot show: disk_05's C2 eyelet drilled 0.05 mm off, its STL replaced."""
    from hwgen.cad.export import write_stl
    from hwgen.cad.disk import build_disk

    root, folder = _copy(built, tmp_path)
    plan = make_plan(load(PARAMS / "prototype.yaml").design)
    spec = plan.disks[5]
    holes = tuple(dataclasses.replace(h, x=h.x + 0.05) if h.tendons == ("C2",) else h for h in spec.holes)
    stl = folder / "stl" / "disk_05.stl"
    write_stl(build_disk(dataclasses.replace(spec, holes=holes)).solid, stl)
    edited = sha256(stl)
    # and disk_07 printed without its H eyelet
    spec = plan.disks[7]
    holes = tuple(h for h in spec.holes if h.tendons != ("H",))
    write_stl(build_disk(dataclasses.replace(spec, holes=holes)).solid, folder / "stl" / "disk_07.stl")
    r = _run("check", str(PARAMS / "prototype.yaml"), "--out", str(root), "--report", str(tmp_path / "r.json"))
    assert r.returncode == 1, r.stdout
    assert sha256(stl) == edited                      # not rebuilt over
    rep = json.loads((tmp_path / "r.json").read_text())
    bad = {c["where"]["part"]: c for c in _failed(rep, "eyelet.position")}
    assert set(bad) == {"disk_05", "disk_07"}
    assert bad["disk_05"]["message"].startswith("disk_05: C2 eyelet is at x=0.050")
    assert bad["disk_05"]["measured"] == pytest.approx(0.05, abs=2e-3)
    assert bad["disk_07"]["message"] == "disk_07: H eyelet at x=-17.678, z=17.678 is missing"
    assert {t["name"]: t["stations_from_design"] for t in rep["tendons"]}["H"] == [7]
    assert any("stl/disk_05.stl" in c["message"] for c in _failed(rep, "files.unchanged"))
    ey = [e for e in rep["eyelets"] if e["station"] == 5 and e["tendons"] == ["C2"]][0]
    assert ey["measured_xz_mm"][0] == pytest.approx(0.05, abs=2e-3)
    # the lengths are computed from where the hole is, not where it should be
    base = {t["name"]: t for t in json.loads((built("prototype") / "report.json").read_text())["tendons"]}
    now = {t["name"]: t for t in rep["tendons"]}
    assert now["C2"]["rest_length_mm"] != base["C2"]["rest_length_mm"]
    assert now["C1"]["rest_length_mm"] == pytest.approx(base["C1"]["rest_length_mm"], abs=1e-9)


def test_hole_too_small_for_tendon_angle(built, tmp_path):
    """disk_01's C2 eyelet (sized Ø1.15 for 16° of tendon angle) made Ø0.85: above the process
    minimum, too small for the angle."""
    from hwgen.cad.export import write_stl
    from hwgen.cad.disk import build_disk

    _, folder = _copy(built, tmp_path)
    plan = make_plan(load(PARAMS / "prototype.yaml").design)
    spec = plan.disks[1]
    holes = tuple(dataclasses.replace(h, diameter=0.85) if h.tendons == ("C2",) else h for h in spec.holes)
    write_stl(build_disk(dataclasses.replace(spec, holes=holes)).solid, folder / "stl" / "disk_01.stl")
    rep = _check(folder)
    assert not rep["ok"]
    bad = _failed(rep, "eyelet.tendon_angle")
    assert [c["where"]["tendon"] for c in bad] == ["C2"]
    assert bad[0]["where"]["part"] == "disk_01" and "pinched in disk_01" in bad[0]["message"]
    assert bad[0]["measured"] == pytest.approx(0.85, abs=0.02) and bad[0]["limit"] > 0.9
    assert not _failed(rep, "eyelet.min_hole") and not _failed(rep, "eyelet.position")

    # and a hole under the process minimum: disk_03's C1 eyelet made Ø0.5
    spec = plan.disks[3]
    holes = tuple(dataclasses.replace(h, diameter=0.5) if h.tendons == ("C1",) else h for h in spec.holes)
    write_stl(build_disk(dataclasses.replace(spec, holes=holes)).solid, folder / "stl" / "disk_03.stl")
    bad = _failed(_check(folder), "eyelet.min_hole")
    assert len(bad) == 1 and bad[0]["where"] == {"part": "disk_03", "station": 3, "tendon": "C1"}
    assert "eyelet C1 is Ø0.50" in bad[0]["message"] and bad[0]["limit"] == 0.8


def test_overlapping_parts_named_with_volume(built, tmp_path):
    _, folder = _copy(built, tmp_path)
    s1, s2 = make_plan(load(PARAMS / "prototype.yaml").design).disks[1:3]
    into = 1.5
    m = json.loads((folder / "manifest.json").read_text())
    d1 = next(p for p in m["parts"] if p["name"] == "disk_01")
    d1["placement"][1][3] += (s2.y - s2.thickness / 2) - (s1.y + s1.thickness / 2) + into   # 1.5 mm into disk_02
    (folder / "manifest.json").write_text(json.dumps(m))
    rep = _check(folder)
    bad = {tuple(sorted(c["where"]["parts"])): c for c in _failed(rep, "part.interference")}
    # it runs into disk_02, and out of its slot in the jig into the jig's comb
    assert set(bad) == {("disk_01", "disk_02"), ("disk_01", "jig_1")}
    c = bad[("disk_01", "disk_02")]
    assert "disk_01 and disk_02 interfere" in c["message"]
    # two disks overlapping by 1.5 mm of their faces, less the slot and holes; and disk_01's hub
    # (its wall around the slot, over its length) in disk_02 and its hub
    w = s1.hub.wall
    hub = s1.hub.length * ((s1.slot_width + 2 * w) * (s1.slot_height + 2 * w) - s1.slot_width * s1.slot_height)
    face = np.pi * (s1.outer_diameter / 2) ** 2
    assert into * face * 0.9 < c["measured"] < into * face + hub
    assert any(c["where"]["part"] == "disk_01" for c in _failed(rep, "disk.station"))


def test_crossing_without_a_hole(built, tmp_path):
    import ezdxf

    from hwgen.cad.export import write_stl
    from hwgen.cad.backbone import build_backbone

    _, folder = _copy(built, tmp_path)
    dxf = folder / "backbone_template.dxf"
    doc = ezdxf.readfile(dxf)
    msp = doc.modelspace()
    gone = [c for c in msp.query('CIRCLE[layer=="HOLES"]')
            if abs(c.dxf.center.y - 45) < 1e-6 and abs(c.dxf.center.x) < 1e-6]
    assert len(gone) == 1
    msp.delete_entity(gone[0])
    doc.saveas(dxf)
    rep = _check(folder)
    bad = _failed(rep, "backbone.crossing")
    assert len(bad) == 1 and bad[0]["where"]["tendon"] == "C2" and bad[0]["where"]["station"] == 2
    assert "C2 crosses the backbone at station 2 (x=0.00, y=45.00 mm)" in bad[0]["message"]
    assert "backbone_template.dxf" in bad[0]["message"] and "STL" not in bad[0]["message"]

    # and the strip itself without the hole at station 10
    plan = make_plan(load(PARAMS / "prototype.yaml").design)
    spec = plan.backbone
    spec = dataclasses.replace(spec, holes=tuple(h for h in spec.holes if not (h.tendon == "C2" and h.station == 10)))
    write_stl(build_backbone(spec).solid, folder / "stl" / "backbone.stl")
    rep = _check(folder)
    bad = {c["where"]["station"]: c["message"] for c in _failed(rep, "backbone.crossing")}
    assert set(bad) == {2, 10}
    assert "the backbone STL" in bad[10] and "backbone_template.dxf" not in bad[10]


def test_strip_holes_checked_against_crossing_angle(built, tmp_path):
    """The strip is 0.59 mm thick and C2 crosses it at up to 57° to its normal: the shipped
    strip's holes are sized for that; a square Ø0.8 hole (the disk's eyelet size) is an error."""
    from hwgen.cad.export import write_stl
    from hwgen.cad.backbone import build_backbone

    rep = json.loads((built("prototype") / "report.json").read_text())
    ang = {(c["where"]["tendon"], c["where"]["station"]): c for c in rep["checks"] if c["id"] == "backbone.hole_angle"}
    assert len(ang) == 7 and all(c["severity"] == "error" and c["passed"] for c in ang.values())
    beta = np.radians(57.0)   # at ±90° of bending
    need = 0.15 / np.cos(beta) + 0.59 * np.tan(beta)
    assert ang[("C2", 2)]["limit"] == pytest.approx(need, abs=0.02)

    _, folder = _copy(built, tmp_path)
    plan = make_plan(load(PARAMS / "prototype.yaml").design)
    spec = plan.backbone
    spec = dataclasses.replace(spec, holes=tuple(dataclasses.replace(h, diameter=0.8)
                                                 if (h.tendon, h.station) == ("C2", 2) else h for h in spec.holes))
    write_stl(build_backbone(spec).solid, folder / "stl" / "backbone.stl")
    bad = _failed(_check(folder), "backbone.hole_angle")
    assert [(c["where"]["tendon"], c["where"]["station"]) for c in bad] == [("C2", 2)]
    assert bad[0]["measured"] == pytest.approx(0.8, abs=0.02)
    assert f"C2 crosses the {plan.backbone.thickness:g} mm strip at station 2" in bad[0]["message"]
    assert "bears on the hole's edge" in bad[0]["message"]


def test_broken_mesh_and_build_volume(built, tmp_path):
    import trimesh

    _, folder = _copy(built, tmp_path)
    stl = folder / "stl" / "disk_07.stl"
    mesh = trimesh.load_mesh(stl)
    mesh.update_faces(np.arange(len(mesh.faces)) >= 5)      # five triangles gone: a hole in the skin
    mesh.export(stl)
    rep = _check(folder)
    bad = _failed(rep, "part.mesh")
    assert [c["where"]["part"] for c in bad] == ["disk_07"] and "not watertight" in bad[0]["message"]

    small = load(PARAMS / "prototype.yaml").design
    small = small.model_copy(update={"process": small.process.model_copy(update={"build_volume": (70, 70, 50)})})
    m = json.loads((built("prototype") / "manifest.json").read_text())
    rep = run_checks(built("prototype"), Manifest.of(m), make_plan(small))
    bad = _failed(rep, "part.build_volume")
    assert {f"disk_{i:02d}" for i in range(13)} <= {c["where"]["part"] for c in bad}
    # the base disk is 6 mm thick, its hub stands 5.5 mm on it
    assert ("disk_00: 72.0 × 72.0 × 11.5 mm does not fit the build volume 70 × 70 × 50 mm"
            in [c["message"] for c in bad])


@pytest.fixture(scope="module")
def broken_walls(tmp_path_factory):
    """A design whose YAML makes thin walls: A1/A2 at 35 mm on a Ø72 disk (0.6 mm of rim left by
    their Ø0.8 eyelets; less at the tip, where they turn toward the tensioner's drum and the eyelet
    is wider), two straight tendons X, Y 0.5 mm apart (their Ø0.8 eyelets run into one another),
    and V weaving ±1 mm about X so that it passes through X between stations 5 and 6."""
    doc = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
    doc["design"] = "thin-walls"
    doc["tendons"][0]["routing"]["function"]["z0"] = 35.0
    doc["tendons"] = doc["tendons"][:1] + [
        {"name": "X", "channel": "A", "routing": {"function": {"kind": "straight", "x0": 20, "z0": 20}}},
        {"name": "Y", "channel": "A", "routing": {"function": {"kind": "straight", "x0": 20.5, "z0": 20}}},
        {"name": "V", "channel": "A", "routing": {"function": {
            "kind": "cosine", "axis": "x", "a": 1, "k": 1, "phase_deg": 7.5, "x0": 20, "z0": 20}}}]
    doc["tensioner"]["channels"] = ["A"]
    root = tmp_path_factory.mktemp("thin")
    src = root / "thin-walls.yaml"
    src.write_text(yaml.safe_dump(doc, sort_keys=False))
    # the disks and the strip are what is broken; the tensioner is not what these tests look
    # at, so only those two families are built (its layout still sizes the tip's eyelets); these
    # tests read the report, so no pictures are drawn (as without an OpenGL backend)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(assembly, "FAMILIES", [f for f in assembly.FAMILIES if f[0] in ("disks", "backbone")])
        mp.setenv("HWGEN_RENDER_BACKEND", "none")
        folder = build(load(src), root / "out").folder
    return dict(json.loads((folder / "report.json").read_text()), _source=src)


@pytest.mark.slow
def test_eyelet_near_edge_fails_and_names_it(broken_walls):
    bad = _failed(broken_walls, "eyelet.wall.edge")
    assert {c["where"]["part"] for c in bad} == {f"disk_{i:02d}" for i in range(13)}
    for c in bad:
        assert c["message"].startswith(c["where"]["part"] + ": wall to the outer edge")
        assert "eyelet A1" in c["message"] or "eyelet A2" in c["message"]
        assert c["limit"] == 0.8 and c["measured"] < 0.8
    # measured from the files: within 0.05 mm under the wall the plan designed (the STL's facets
    # cut the circle), for the plain eyelets and for the tip's wider ones alike
    plan = make_plan(load(broken_walls["_source"]).design)
    for c in bad:
        disk = plan.disks[int(c["where"]["part"].split("_")[1])]
        designed = min(disk.outer_diameter / 2 - math.hypot(h.x, h.z) - h.diameter / 2
                       for h in disk.holes if set(h.tendons) & {"A1", "A2"})
        assert designed - 0.05 < c["measured"] < designed + 0.01


@pytest.mark.slow
def test_merging_eyelets_fail_and_are_named(broken_walls):
    bad = _failed(broken_walls, "eyelet.wall.eyelet")
    assert len(bad) == 13
    for c in bad:
        assert "at eyelet X and eyelet Y (merged into one opening)" in c["message"] and c["measured"] == 0
    # the routing itself puts them into one opening: the plan makes it one bore around both, and the
    # overlap check names them, not the position check
    pos = _failed(broken_walls, "eyelet.overlap")
    assert len(pos) == 13 and all(re.search(r"X and Y( and V)? share one opening", c["message"]) for c in pos)
    assert not _failed(broken_walls, "eyelet.position")
    # 0.5 mm apart is still clear of each other for a Ø0.15 line
    xy = [c for c in broken_walls["checks"] if c["id"] == "tendon.clearance" and c["where"]["tendons"] == ["X", "Y"]]
    assert xy[0]["passed"] and xy[0]["measured"] == pytest.approx(0.5, abs=1e-6)
    assert not broken_walls["ok"]


@pytest.mark.slow
def test_tendons_passing_through_each_other(broken_walls):
    bad = {tuple(c["where"]["tendons"]): c for c in _failed(broken_walls, "tendon.clearance")}
    assert ("X", "V") in bad
    c = bad[("X", "V")]
    # V crosses x = 20 where πs/L + 7.5° = 90°: s = 123.75 mm, between stations 5 and 6
    assert c["where"]["segment"] == [5, 6] and c["measured"] < 1e-6
    assert "X and V rub" in c["message"] and "between stations 5 and 6" in c["message"]


def test_segment_distance_against_sampling():
    rng = np.random.default_rng(4)
    p0, p1, q0, q1 = (rng.normal(size=(60, 3)) for _ in range(4))
    got = segment_distance(p0, p1, q0, q1)
    s = np.linspace(0, 1, 301)
    a = p0[:, None] + s[None, :, None] * (p1 - p0)[:, None]
    b = q0[:, None] + s[None, :, None] * (q1 - q0)[:, None]
    # pair by pair: 301 x 301 sample distances each, not all 60 pairs' in one array (130 MB)
    brute = np.array([np.linalg.norm(ai[:, None] - bi[None, :], axis=2).min() for ai, bi in zip(a, b)])
    assert np.all(got <= brute + 1e-12) and np.all(brute - got < 1e-2)
    # parallel and touching end to end
    z = np.zeros(3)
    assert segment_distance(z, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([1.0, 1, 0])) == pytest.approx(1)
    assert segment_distance(z, np.array([1.0, 0, 0]), np.array([2.0, 0, 0]), np.array([3.0, 0, 0])) == pytest.approx(1)


def test_loop_gap_is_exact():
    from hwgen.checks.polygons import loop_gap, points_to_polyline

    rng = np.random.default_rng(1)
    for _ in range(200):
        loops = []
        for n in rng.integers(3, 60, 2):
            t = np.sort(rng.uniform(0, 2 * np.pi, n))
            loops.append(np.c_[np.cos(t), np.sin(t)] * rng.uniform(0.3, 2, (n, 1)) + rng.normal(0, 3, 2))
        a, b = loops
        brute = min(points_to_polyline(a, b).min(), points_to_polyline(b, a).min())
        assert loop_gap(a, b) == pytest.approx(brute, abs=1e-12)
    # two unit circles 3 apart: a wall of 1 (polygons inscribed: a little more)
    t = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    c = np.c_[np.cos(t), np.sin(t)]
    assert 1.0 <= loop_gap(c, c + [3, 0]) < 1.0 + 2 * (1 - np.cos(np.pi / 64)) + 1e-12


def test_tip_eyelets_checked_against_the_exit_to_the_tensioner(built, tmp_path):
    """The line turns at the tip eyelet toward its spool; a tip disk sized for the incoming
    segment alone (as the builder once did) pinches the actuating pair there."""
    from hwgen.model.plan import _disk_spec, _rest_axes
    from hwgen.cad.export import write_stl
    from hwgen.cad.disk import build_disk

    d = load(PARAMS / "prototype.yaml").design
    plan = make_plan(d)
    tip = plan.disks[-1]
    a1 = next(h for h in tip.holes if h.tendons == ("A1",))
    exit_deg = next(r.exit_angle_deg for r in plan.tensioner_layout.runs if r.tendon == "A1")
    assert exit_deg > 5 and a1.worst_angle_deg > 0.4 * exit_deg   # the exit sets the axis and size

    rest = {p.name: _rest_axes(d, p) for p in plan.paths}
    blind, _ = _disk_spec(d, tip.index, plan.paths, rest)          # no exits: incoming segment only
    _, folder = _copy(built, tmp_path)
    write_stl(build_disk(blind).solid, folder / "stl" / f"{tip.name}.stl")
    bad = _failed(_check(folder), "eyelet.tendon_angle")
    assert {c["where"]["tendon"] for c in bad} >= {"A1", "A2"}
    msg = next(c["message"] for c in bad if c["where"]["tendon"] == "A1")
    assert msg.startswith(f"A1 is pinched in {tip.name}")


def test_a_cup_in_the_print_orientation_is_caught():
    """A block with a blind pocket opening upward (its floor toward the plate) holds resin when
    printed bottom-up; the same pocket vented through its floor does not."""
    import trimesh

    from hwgen.checks.parts import LoadedPart
    from hwgen.checks.printing import printing_checks
    block = trimesh.creation.box((20, 20, 10), trimesh.transformations.translation_matrix((0, 0, 5)))
    pocket = trimesh.creation.cylinder(3.0, 8.0, transform=trimesh.transformations.translation_matrix((0, 0, 7)))
    vent = trimesh.creation.cylinder(0.8, 12.0, transform=trimesh.transformations.translation_matrix((0, 0, 5)))
    cup = block.difference(pocket)
    vented = cup.difference(vent)

    def run(mesh, tech="SLA"):
        return [c for c in printing_checks([LoadedPart("part", "disk", mesh, np.eye(4), None)], tech)
                if c.id == "print.cup"]
    (bad,) = run(cup)
    assert not bad.passed and bad.measured == pytest.approx(np.pi * 9, rel=0.05) and "Z = 3." in bad.message
    (ok,) = run(vented)
    assert ok.passed
    assert run(cup, "FDM") == []          # an FDM nozzle does not peel from a film


def test_a_closed_void_is_counted_shell_by_shell():
    """A block holding a sealed cavity (an inner shell wound inward) has one void; two of them two;
    a part of two separate solid shells has none. The count is the shells of negative volume that
    splitting the mesh into its connected pieces gives."""
    import trimesh

    from hwgen.checks.parts import LoadedPart
    from hwgen.checks.printing import closed_voids, printing_checks

    def cavity(at):
        c = trimesh.creation.box((3, 3, 3), trimesh.transformations.translation_matrix(at))
        c.invert()
        return c
    block = trimesh.creation.box((20, 20, 10))
    one = trimesh.util.concatenate([block, cavity((-4, 0, 0))])
    two = trimesh.util.concatenate([block, cavity((-4, 0, 0)), cavity((4, 0, 0))])
    apart = trimesh.util.concatenate([block, trimesh.creation.box((2, 2, 2),
                                                                  trimesh.transformations.translation_matrix((30, 0, 0)))])
    for mesh, voids in ((block, 0), (one, 1), (two, 2), (apart, 0)):
        assert closed_voids(mesh) == voids
        assert voids == sum(s.volume < 0 for s in mesh.split(only_watertight=False))
        found = [c for c in printing_checks([LoadedPart("part", "disk", mesh, np.eye(4), None)], "FDM")
                 if c.id == "print.void"]
        assert [c.measured for c in found] == ([float(voids)] if voids else [])


def test_section_segments_chain_into_their_closed_loops():
    """Segments in any order and direction, welded at shared ends, come back as closed loops that
    walk each polygon's edges in turn; an open chain and a zero-length segment are dropped."""
    from hwgen.checks.polygons import signed_area
    from hwgen.checks.sections import chain_loops
    square = np.array([[0, 0], [4, 0], [4, 4], [0, 4]], float)
    tri = np.array([[10, 0], [12, 0], [11, 3]], float)
    segs = [[p[i], p[(i + 1) % len(p)]] for p in (square, tri) for i in range(len(p))]
    segs += [[[20, 0], [21, 0]], [[21, 0], [21, 1]], [[5, 5], [5, 5]]]
    rng = np.random.default_rng(3)
    segs = [s[::-1] if rng.random() < 0.5 else s for s in np.array(segs)]
    segs = np.array(segs)[rng.permutation(len(segs))] + 1e-9          # welded below the rounding
    loops = chain_loops(segs)
    assert len(loops) == 2
    for lp in loops:
        ref = square if len(lp) == 4 else tri
        assert len(lp) == len(ref) and np.allclose(sorted(map(tuple, lp)), sorted(map(tuple, ref + 1e-9)))
        steps = np.linalg.norm(np.diff(np.vstack([lp, lp[:1]]), axis=0), axis=1)
        assert np.allclose(sorted(steps), sorted(np.linalg.norm(np.diff(np.vstack([ref, ref[:1]]), axis=0), axis=1)))
        assert abs(signed_area(lp)) == pytest.approx(abs(signed_area(ref)))
    assert chain_loops(segs[:0].reshape(0, 2, 2)) == []


def test_a_tilt_a_hair_over_its_limit_is_printed_over_it():
    """disk.tilt prints as many digits as show a failing pitch above the limit (a drawn robot's 0.5004°
    read "±0.500°, more than the 0.5° allowed"); a passing one keeps three."""
    from hwgen.checks.seating import SlotFit, tilt_checks
    fit = SlotFit("disk_03", 3, 67.5, (-0.5004, 0.5004), (-0.1, 0.1), (-0.2, 0.2), 0.1, 0.1, 0.0, 0.0,
                  (60.0, 75.0), (66.0, 69.0))
    (over,) = tilt_checks([fit], 0.5, {3: 30.0})
    assert not over.passed and "±0.5004°, more than the 0.5° allowed" in over.message
    (ok,) = tilt_checks([dataclasses.replace(fit, tilt_x=(-0.4, 0.4))], 0.5, {3: 30.0})
    assert ok.passed and "±0.400°" in ok.message
