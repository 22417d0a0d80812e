"""Bill of materials: rows against the manifest, tendon lengths against the validator's report."""
from __future__ import annotations

import csv
import json
import shutil
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from hwgen.checks.report import read_report
from hwgen.outputs import bom
from hwgen.model import kinematics as kin
from hwgen.model.plan import make_plan
from hwgen.pipeline import load
from hwgen.cad.manifest import Manifest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def proto(built):
    folder = built("prototype")
    m = json.loads((folder / "manifest.json").read_text())
    with open(folder / "bom.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    return folder, m, rows, load(ROOT / "params" / "prototype.yaml").design


def test_counts_match_the_manifest(proto):
    _, m, rows, _ = proto
    parts = [r for r in rows if r["family"] not in ("tendon", "hardware", "consumable")]
    assert sorted(r["part"] for r in parts) == sorted(p["name"] for p in m["parts"])
    per_family = Counter()
    for r in parts:
        per_family[r["family"]] += int(r["qty"])
    assert per_family == Counter(p["role"] for p in m["parts"])
    printed = [r for r in rows if r["category"] == "printed"]
    assert {r["family"] for r in printed} == {p["role"] for p in m["parts"] if not bom.is_purchased(p)}
    assert m["bom"]["printed_parts"] == len(printed)
    vol = {p["name"]: p["volume_mm3"] for p in m["parts"]}
    for r in printed:
        assert float(r["volume_mm3"]) == pytest.approx(vol[r["part"]], abs=0.05)
        assert r["material"] == "SLA resin, Anycubic Photon M3"


def test_strip_row_has_cut_size_and_template(proto):
    _, m, rows, d = proto
    (strip,) = [r for r in rows if r["family"] == "backbone"]
    assert strip["category"] == "purchased"
    length = d.backbone.length + d.backbone.extra_base + d.backbone.extra_tip
    size = [float(v) for v in strip["size"].removesuffix(" mm").split(" × ")]
    assert size == pytest.approx([length, d.backbone.height, d.backbone.thickness], abs=0.01)
    holes = {(round(h["x_mm"], 6), round(h["y_mm"], 6)) for h in m["design_report"]["backbone_holes"]}
    assert f"drill {len(holes)} holes from backbone_template.dxf" in strip["notes"]


def test_tendon_cut_lengths_follow_the_validator(proto):
    folder, m, rows, d = proto
    report = json.loads((folder / "report.json").read_text())
    rest = {t["name"]: t["rest_length_mm"] for t in report["tendons"]}
    tendons = {r["part"].removeprefix("tendon "): r for r in rows if r["family"] == "tendon"}
    assert set(tendons) == {t["name"] for t in m["design_report"]["tendons"]}
    allowance = d.bom.tie_off_mm + d.bom.spool_mm
    for name, r in tendons.items():
        assert float(r["rest_length_mm"]) == pytest.approx(rest[name], abs=0.005)
        assert float(r["cut_length_mm"]) == pytest.approx(rest[name] + allowance, abs=0.06)
    assert m["bom"]["tendon_rest_length_source"].startswith("report.json")
    md = (folder / "bom.md").read_text()
    assert "report.json" in md and all(f"| {n} |" in md for n in tendons)


def _copy(folder: Path, dst: Path) -> dict:
    shutil.copytree(folder / "stl", dst / "stl")
    shutil.copy(folder / "backbone_template.dxf", dst)
    return json.loads((folder / "manifest.json").read_text())


def test_rest_lengths_come_from_the_report_when_there_is_one(proto, tmp_path):
    folder, _, _, d = proto
    m = _copy(folder, tmp_path)
    # no report: eq. (2) at zero curvature on the design's eyelets
    rows, source = bom.bom_rows(tmp_path, Manifest.of(m), make_plan(d), read_report(tmp_path))
    assert source.startswith("eq. (2)")
    st = m["design_report"]["stations_mm"]
    for t in m["design_report"]["tendons"]:
        (r,) = [r for r in rows if r["part"] == f"tendon {t['name']}"]
        expect = kin.tendon_lengths(st, np.asarray(t["eyelets_xz_mm"]), 0.0)[0]
        assert float(r["rest_length_mm"]) == pytest.approx(expect, abs=0.005)
    # a report with other numbers: the BOM follows the report, not the design
    fake = {"tendons": [{"name": t["name"], "rest_length_mm": 100.0 + i}
                        for i, t in enumerate(m["design_report"]["tendons"])]}
    (tmp_path / "report.json").write_text(json.dumps(fake))
    rows, source = bom.bom_rows(tmp_path, Manifest.of(m), make_plan(d), read_report(tmp_path))
    assert source.startswith("report.json")
    cut = [float(r["cut_length_mm"]) for r in rows if r["family"] == "tendon"]
    allowance = d.bom.tie_off_mm + d.bom.spool_mm
    assert cut == pytest.approx([100.0 + i + allowance for i in range(len(cut))])


def test_allowances_are_parameters(proto, tmp_path):
    folder, _, rows0, d = proto
    m = _copy(folder, tmp_path)
    shutil.copy(folder / "report.json", tmp_path)
    d2 = d.model_copy(update={"bom": d.bom.model_copy(update={"tie_off_mm": 10.0, "spool_mm": 5.0})})
    rows, _ = bom.bom_rows(tmp_path, Manifest.of(m), make_plan(d2), read_report(tmp_path))
    before = {r["part"]: float(r["rest_length_mm"]) for r in rows0 if r["family"] == "tendon"}
    for r in rows:
        if r["family"] == "tendon":
            assert float(r["cut_length_mm"]) == pytest.approx(before[r["part"]] + 15.0, abs=0.06)


def test_fasteners_from_the_tip_mount_and_part_hardware(proto, tmp_path):
    folder, m0, rows, d = proto
    n = len(m0["design_report"]["disks"][-1]["mount_holes"])
    screws = [r for r in rows if r["family"] == "hardware" and r["part"] == bom.TIP_SCREW
              and not any(w in r["notes"] for w in ("base_mount", "base_frame_", "rig_"))]
    # the base mount's, the base frame's and the rig's screws are other sizes
    assert len(screws) == 1 and int(screws[0]["qty"]) >= n and screws[0]["size"].startswith("M3")
    m = _copy(folder, tmp_path)
    for p, k in zip(m["parts"][:3], (1, 2, 3)):
        p["hardware"] = [{"item": "dowel pin", "size": "Ø3 × 16", "qty": k, "material": "steel"}]
    rows2, _ = bom.bom_rows(tmp_path, Manifest.of(m), make_plan(d), read_report(tmp_path))
    (pins,) = [r for r in rows2 if r["part"] == "dowel pin"]
    assert int(pins["qty"]) == 6 and pins["size"] == "Ø3 × 16"


def test_thread_from_clearance_hole():
    assert bom.thread_for_hole(3.4) == "M3"
    assert bom.thread_for_hole(4.5) == "M4"
    assert bom.thread_for_hole(3.2) == "M3"
    assert bom.thread_for_hole(12.0) is None


def test_tensioner_hardware_matches_its_parts(proto, tmp_path):
    """Counts follow from which parts exist: a dowel per worm and two per wheel, an M2 screw and
    its nut per clamp, the housing's screws into the tip disk with a nut each, two set screws
    with their nuts. The prototype is printed in resin (SLA): nuts in traps, never heat-set
    inserts, which crack brittle resin."""
    folder, m, rows, d = proto
    roles = [p["role"] for p in m["parts"]]
    worms, wheels, drives, clamps = (roles.count(f"tensioner_{r}") for r in ("worm", "wheel", "drive", "clamp"))
    assert worms == wheels == drives == len(d.tensioner.channels) and clamps >= wheels
    hw: dict[tuple[str, str], int] = {}
    for r in rows:
        if r["family"] == "hardware":
            hw[(r["part"], r["size"])] = hw.get((r["part"], r["size"]), 0) + int(r["qty"])
    assert len(hw) == len([r for r in rows if r["family"] == "hardware"])   # one row per item and size
    dowels = sum(q for (item, _), q in hw.items() if item.startswith("dowel pin"))
    bench = sum(int(h["qty"]) for p in m["parts"] if p.get("bench") for h in p.get("hardware", [])
                if h["item"].startswith("dowel pin"))        # the base frame's and the rig's (issue 46)
    assert dowels == worms + 2 * wheels + bench
    n_tip = len(m["design_report"]["disks"][-1]["mount_holes"])
    # the bill sums what the parts list; the tensioner's own lines follow from its parts
    listed: dict[tuple[str, str], int] = {}
    tens: dict[tuple[str, str], int] = {}
    for p in m["parts"]:
        for h in p.get("hardware", []):
            k = (h["item"], h["size"])
            listed[k] = listed.get(k, 0) + h["qty"]
            if p["role"].startswith("tensioner"):
                tens[k] = tens.get(k, 0) + h["qty"]
    assert all(hw[k] == q for k, q in listed.items())
    (tip_size,) = [size for (item, size), q in tens.items() if item == bom.TIP_SCREW]
    assert tens[(bom.TIP_SCREW, tip_size)] == n_tip
    length = float(tip_size.split("×")[1])     # through the tip disk, ending in the nut inside the base bar
    assert d.disks.end_thickness < length <= d.disks.end_thickness + 5.0
    m2 = [k for k in tens if k[0] == "button head screw ISO 7380"]
    assert sum(tens[k] for k in m2) == clamps and all(size.startswith("M2") for _, size in m2)
    assert tens[("hex nut ISO 4032", "M2")] == clamps
    assert tens[("hex nut ISO 4032", "M3")] == n_tip + 2                 # tip screws, strip set screws
    assert not any("insert" in item for item, _ in hw)

    # without the parts' lists, the tip screws are listed from the bolt pattern, with nuts
    m2_ = _copy(folder, tmp_path)
    for p in m2_["parts"]:
        p.pop("hardware", None)
    rows2, _ = bom.bom_rows(tmp_path, Manifest.of(m2_), make_plan(d), read_report(tmp_path))
    assert any("nut" in r["part"] for r in rows2 if r["family"] == "hardware")


def test_sizes_are_the_bounds_of_the_meshes_the_checks_read(proto, tmp_path):
    """The size column reads each STL's corners straight from the file: the same bounds as the
    mesh the checks load (vertices merged), for every part; an ASCII STL is read whole."""
    import trimesh

    from hwgen.cad.manifest import ManifestPart
    from hwgen.checks.meshes import stl_bounds
    folder, m, _, _ = proto
    for entry in m["parts"]:
        path = ManifestPart.of(entry).stl_in(folder)
        lo, hi = stl_bounds(path)
        mesh = trimesh.load_mesh(str(path), process=True)
        assert np.array_equal(lo, mesh.bounds[0]) and np.array_equal(hi, mesh.bounds[1]), entry["name"]
    box = trimesh.creation.box(extents=(3.0, 5.0, 7.0))
    ascii_stl = tmp_path / "box.stl"
    ascii_stl.write_text(trimesh.exchange.stl.export_stl_ascii(box))
    lo, hi = stl_bounds(ascii_stl)
    assert np.allclose(hi - lo, (3.0, 5.0, 7.0))
