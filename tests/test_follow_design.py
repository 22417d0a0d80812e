"""Outputs that follow the design, not its base (issue 43, item 5): the bent picture at the
design's own sweep angle, no base's words about a value the design changed, one wording for a
tendon's set and locked tensions, and an unchanged rebuild that keeps what other commands added."""
from __future__ import annotations

import csv
import json
import re
import shutil
from pathlib import Path
from types import SimpleNamespace

import pytest

from hwgen import params
from hwgen.model.settings import render_settings

from .conftest import PARAMS

PROTO = PARAMS / "prototype.yaml"


def _based(tmp_path: Path, body: str) -> params.LoadedDesign:
    f = tmp_path / "lab.yaml"
    f.write_text(f"base: {PROTO}\ndesign: lab\n{body}", encoding="utf-8")
    return params.read(f)


@pytest.mark.parametrize("body, angle", [
    ("", 90.0),                                                  # the prototype: its ±90° sweep
    ("check:\n  max_angle_deg: 65\n", 65.0),                     # checked to ±65°: drawn at 65°
    ("disks:\n  eyelets:\n    sweep_deg: 70\n", 70.0),           # sized (and so checked) to ±70°
    ("check:\n  max_angle_deg: 65\nrender:\n  bend_deg: 30\n", 30.0),   # a picture angle of its own
])
def test_the_bent_picture_is_drawn_at_the_designs_own_angle(tmp_path, body, angle):
    d = _based(tmp_path, body).design
    assert render_settings(d).bend_deg == angle
    if "bend_deg" not in body:
        assert render_settings(d).bend_deg == d.check_angle_deg


def test_the_adhesive_gap_is_written_from_the_slot_clearance_not_the_bases_words(tmp_path):
    from hwgen.cad.manifest import design_report
    from hwgen.model.plan import make_plan
    from hwgen.outputs.bom import _slot_gap
    d = _based(tmp_path, "disks:\n  slot_clearance: 0.1\n").design          # the base's is 0.05
    plan = make_plan(d)
    gap = _slot_gap(SimpleNamespace(design_report=design_report(plan)), plan.backbone.thickness)
    assert gap == pytest.approx(0.1)
    # the base's free text speaks of no value: the gap is the bill of materials' own sentence
    assert not re.search(r"\d", plan.anchors.adhesive), plan.anchors.adhesive


@pytest.mark.slow             # the statics of two tendon states: about 3 s with its imports
def test_a_tendons_set_and_locked_tensions_are_said_apart(tmp_path):
    """summary.md said "C1 8.54 N (its pretension_n)" for a pretension_n of 5.6: the locked tension
    in the words of the set one."""
    from hwgen.model import stiffness as sf
    from hwgen.model.plan import make_plan
    d = _based(tmp_path, "").design
    tendons = tuple(t.model_copy(update={"pretension_n": 5.6}) if t.name == "C1" else t for t in d.tendons)
    report = sf.study(make_plan(d.model_copy(update={"tendons": tendons})), ["A", "AC1C2H"], ["gravity -z"])
    line = next(ln for ln in report["stiffening"]["lines"] if ln.startswith("Set in AC1C2H"))
    assert "C1 to 5.60 N (its pretension_n)" in line, line
    locked = re.search(r"locked, the tendons carry (.*?); protocol", line).group(1)
    c1 = float(re.search(r"C1 (\d+\.\d+) N", locked).group(1))
    assert c1 != pytest.approx(5.6, abs=0.01)        # locked, it carries what the others' locking leaves it
    assert "pretension_n" not in locked


def test_the_bill_of_materials_says_the_gap_the_design_has(built):
    with open(built("prototype") / "bom.csv", newline="", encoding="utf-8") as f:
        glue = next(r for r in csv.DictReader(f) if r["part"] == "adhesive")
    assert "0.05 mm a side (disks.slot_clearance)" in glue["notes"]
    assert "0.05" not in glue["material"]


def test_an_unchanged_rebuild_keeps_what_other_commands_added(built, tmp_path):
    from hwgen.pipeline import ADDED, build, load
    root = tmp_path / "out"
    shutil.copytree(built("prototype"), root / "prototype")
    for name in ADDED:                           # as `hwgen sim`, `experiment` and `coupon` leave them
        (root / "prototype" / name).mkdir()
        (root / "prototype" / name / "kept.txt").write_text(name)
    build(load(PROTO), root)                     # the same bytes: every part from the session's cache
    for name in ADDED:
        assert (root / "prototype" / name / "kept.txt").read_text() == name
    # a folder whose files were others (one part's bytes, as its manifest says) describes another robot
    manifest = root / "prototype" / "manifest.json"
    doc = json.loads(manifest.read_text())
    first = next(iter(doc["parts"][0]["files"].values()))
    first["sha256"] = "0" * 64
    manifest.write_text(json.dumps(doc))
    build(load(PROTO), root)
    assert not any((root / "prototype" / name).exists() for name in ADDED)
