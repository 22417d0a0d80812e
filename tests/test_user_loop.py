"""The user's loop: every fault of a file at once, designs that build on a base, failing checks on
the terminal with what to change, and pictures that point at what fails.

The input tests run the CLI in this process (`hwgen routing`: load, schema, feasibility, plan; no
CAD). The build of the README's own robot (params/twenty-disks.yaml, built on the prototype) is
the slow one: its terminal, its manifest's base and its marked pictures are read back.
"""
from __future__ import annotations

import ast
import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from .conftest import PARAMS, ROOT

PROTO = (PARAMS / "prototype.yaml").read_text()


def run_cli(*args: str):
    from typer.testing import CliRunner

    from hwgen.cli import app
    r = CliRunner().invoke(app, list(args))
    assert r.exception is None or isinstance(r.exception, SystemExit), repr(r.exception)
    return r.exit_code, r.stdout, r.stderr


def based(tmp_path: Path, body: str, name: str = "mine.yaml", base: str | Path = PARAMS / "prototype.yaml") -> Path:
    f = tmp_path / name
    f.write_text(f"base: {base}\n{body}", encoding="utf-8")
    return f


def problems(stderr: str) -> dict[str, str]:
    """field -> message of each problem in an error block (or the one-line error)."""
    lines = stderr.strip().splitlines()
    if lines[0].endswith(" problems:"):
        return {ln[4:].split(": ", 1)[0]: ln[4:].split(": ", 1)[1] for ln in lines[1:] if ln.startswith("  - ")}
    _, _, field, message = lines[0].split(": ", 3)
    return {field: message}


# ---------------------------------------------------------------- every error at once

def test_a_misspelled_key_names_itself_and_the_right_one(tmp_path):
    f = tmp_path / "typo.yaml"
    f.write_text(PROTO.replace("  outer_diameter: 72 ", "  outer_diamter: 72 ")
                 .replace("  extra_tip: 15 ", "  extra_tipp: 15 "), encoding="utf-8")
    code, _, err = run_cli("routing", str(f))
    assert code == 2 and "Traceback" not in err
    found = problems(err)
    # the misspelt required key is one problem, not "missing" beside "unknown"
    assert found == {"backbone.extra_tipp": "unknown key; did you mean extra_tip?",
                     "disks.outer_diamter": "unknown key; did you mean outer_diameter (required, and missing)?"}, err
    assert err.startswith(f"error: {f}: 2 problems:")


def test_a_key_in_the_wrong_section_says_where_it_belongs(tmp_path):
    code, _, err = run_cli("routing", str(based(tmp_path, "design: mine\ndisks:\n  extra_tip: 3\n")))
    assert code == 2 and problems(err) == {"disks.extra_tip": "unknown key here; did you mean backbone.extra_tip?"}


def test_a_file_with_two_errors_names_both(tmp_path):
    f = based(tmp_path, "design: two\nbackbone:\n  length: abc\ndisks:\n  count: -3\n")
    code, out, err = run_cli("routing", str(f))
    found = problems(err)
    assert code == 2 and set(found) == {"backbone.length", "disks.count"}, err
    assert "valid number" in found["backbone.length"] and "greater than or equal to 2" in found["disks.count"]
    assert "(and " not in err and out == ""


def test_a_file_of_many_faults_lists_the_first_25(tmp_path):
    f = tmp_path / "many.yaml"
    f.write_text(PROTO + "".join(f"\nextra{i}: {i}" for i in range(100)) + "\n", encoding="utf-8")
    code, _, err = run_cli("routing", str(f))
    lines = err.strip().splitlines()
    assert code == 2 and lines[0] == f"error: {f}: 100 problems:" and len(lines) == 27
    assert lines[-1] == "  ... and 75 more (fix these and run again)"


def test_a_length_in_metres_says_so(tmp_path):
    f = based(tmp_path, "design: metres\nbackbone:\n  length: 0.25\ndisks:\n  spacing: null\n")
    code, _, err = run_cli("routing", str(f))
    assert code == 2 and err.startswith(f"error: {f}: backbone.length: disk 0 and disk 1 overlap"), err
    assert "0.25 mm is under the usual 40-1500 mm: in metres (250 mm)?" in err


def test_a_strip_ten_times_too_thick_is_a_warning_that_builds(tmp_path):
    f = based(tmp_path, "design: thick\nbackbone:\n  thickness: 5\n")
    code, _, err = run_cli("routing", str(f))
    assert code == 0, err
    assert f"warning: {f}: backbone.thickness: 5 mm is over the usual 0.1-3 mm: a decimal point off (0.5 mm)?" in err


@pytest.mark.parametrize("layout", ["based", "copied"])
def test_a_rule_over_two_keys_blames_the_one_written(tmp_path, layout):
    """Disks 0.3 mm thick break the rule edge_size < thickness / 2: the user wrote the thickness."""
    if layout == "based":
        f = based(tmp_path, "design: thin\ndisks:\n  thickness: 0.3\n")
    else:
        f = tmp_path / "thin.yaml"
        f.write_text(PROTO.replace("  thickness: 3.0 ", "  thickness: 0.3 "), encoding="utf-8")
    code, _, err = run_cli("routing", str(f))
    assert code == 2 and err.startswith(f"error: {f}: disks.thickness: "), err
    assert "disks.eyelets.edge_size" in err          # the message names the other key of the rule


# ---------------------------------------------------------------- a design built on a base

def test_base_merges_mappings_replaces_lists_and_null_removes(tmp_path):
    from hwgen import params
    f = based(tmp_path, "design: mine\nbackbone:\n  length: 300\ndisks:\n  count: 20\n  spacing: null\n"
                        "  hub:\n    wall: 1.5\ntendons:\n  - name: A1\n    channel: A\n"
                        "    routing: {function: {kind: straight, z0: 30}, mirror: true, mirror_name: A2}\n"
                        "tensioner:\n  channels: [A]\n  actuating_channel: A\n")
    loaded = params.read(f)
    d, proto = loaded.design, params.read(PARAMS / "prototype.yaml").design
    assert d.disks.spacing is None and d.stations[1] == pytest.approx(300 / 19)      # null: derived again
    assert d.disks.hub.wall == 1.5 and d.disks.hub.max_tilt_deg == proto.disks.hub.max_tilt_deg   # merged
    assert [t.name for t in d.tendons] == ["A1"]                                      # the list whole
    assert d.disks.outer_diameter == proto.disks.outer_diameter and d.process == proto.process
    assert loaded.bases == (str(PARAMS / "prototype.yaml"),)


def test_a_base_may_have_a_base_and_a_cycle_is_refused(tmp_path):
    from hwgen import params
    mid = based(tmp_path, "design: mid\ndisks:\n  count: 20\n  spacing: null\n", name="mid.yaml")
    top = based(tmp_path, "design: top\nbackbone:\n  length: 300\n", name="top.yaml", base="mid.yaml")
    d = params.read(top).design
    assert (d.disks.count, d.backbone.length, d.disks.thickness) == (20, 300, 3.0)
    one = tmp_path / "one.yaml"
    one.write_text("base: two.yaml\ndesign: one\n")
    (tmp_path / "two.yaml").write_text("base: one.yaml\ndesign: two\n")
    code, _, err = run_cli("routing", str(one))
    assert code == 2 and "two.yaml: base:" in err and "a cycle" in err, err
    code, _, err = run_cli("routing", str(based(tmp_path, "design: x\n", name="x.yaml", base="nowhere.yaml")))
    assert code == 2 and f"x.yaml: base: nowhere.yaml: no such file (looked for at {tmp_path / 'nowhere.yaml'})" in err


def test_a_bad_value_is_named_in_the_file_that_wrote_it(tmp_path):
    base = tmp_path / "lab.yaml"
    base.write_text(PROTO.replace("  count: 13 ", "  count: 1 "))
    f = based(tmp_path, "design: mine\nbackbone:\n  height: 0\n", base="lab.yaml")
    code, _, err = run_cli("routing", str(f))
    assert code == 2 and err.startswith(f"error: {f}: 2 problems:"), err
    assert f"  - {base}: disks.count: Input should be greater than or equal to 2" in err     # the base's value
    assert "  - backbone.height: Input should be greater than 0" in err                    # this file's


def test_a_design_on_a_base_needs_its_own_name(tmp_path):
    f = based(tmp_path, "disks:\n  count: 12\n  spacing: null\n", name="twelve.yaml")
    code, _, err = run_cli("routing", str(f))
    assert code == 2 and err.startswith(f"error: {f}: design: a design built on a base needs a name of its own")
    assert "e.g. design: twelve" in err


def test_a_lowered_severity_is_not_inherited_and_the_design_hash_follows_its_base(tmp_path):
    from hwgen import params
    base = tmp_path / "lab.yaml"
    base.write_text(PROTO)
    f = based(tmp_path, "design: mine\n", base="lab.yaml")
    loaded = params.read(f)
    assert params.read(PARAMS / "prototype.yaml").design.check.robust_severity == "warning"
    assert loaded.design.check.robust_severity == "error"
    assert any("check.robust_severity: warning is not taken from the base" in w for w in loaded.warnings)
    own = based(tmp_path, "design: mine\ncheck:\n  robust_severity: warning   # our reason\n", base="lab.yaml")
    assert params.read(own).design.check.robust_severity == "warning"
    before = loaded.sha256
    base.write_text(PROTO.replace("  count: 13 ", "  count: 12 ").replace("  spacing: 22.5 ", "  spacing: null "))
    assert params.read(f).sha256 != before                     # an edit to the base is another design


def test_a_sweep_starts_from_a_design_built_on_a_base(tmp_path):
    from hwgen.sweep import spec
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump({"sweep": "s", "base": str(PARAMS / "twenty-disks.yaml"),
                                 "axes": [{"path": "backbone.length", "values": [280, 320]}]}))
    loaded = spec.load(f)
    assert loaded.base["disks"]["count"] == 20 and "spacing" not in loaded.base["disks"]
    r = spec.resolve(loaded.base, loaded.names, spec.variants(loaded.spec)[0])
    assert r.message == "" and r.design.stations[-1] == 280


# ---------------------------------------------------------------- every failure says what to change

def test_every_check_that_can_fail_carries_its_fix():
    """Each Check(...) in hwgen/checks whose verdict is not a literal pass names its fix."""
    missing = []
    for f in sorted((ROOT / "hwgen" / "checks").glob("*.py")):
        for node in ast.walk(ast.parse(f.read_text())):
            if not (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "Check"):
                continue
            if any(k.arg is None for k in node.keywords):         # Check(**record): rebuilt from JSON
                continue
            passed = node.args[2] if len(node.args) > 2 else None
            if isinstance(passed, ast.Constant) and passed.value is True:
                continue
            if not any(k.arg == "fix" for k in node.keywords):
                missing.append(f"{f.name}:{node.lineno} {ast.unparse(node.args[0])}")
    assert missing == []


def test_the_verdict_lines_say_what_failed_and_what_to_change():
    from hwgen.checks.report import verdict_lines
    checks = [
        {"id": "disk.tilt", "severity": "error", "passed": False, "message": "tilts", "measured": 0.5966,
         "limit": 0.5, "where": {"part": "disk_18", "station": 18}, "fix": "disks.slot_clearance to at most 0.042 mm",
         "lowered_by": ""},
        {"id": "tendon.robust", "severity": "warning", "passed": False, "message": "C1 fails", "measured": 0.54,
         "limit": 0.2, "where": {"tendon": "C1", "channel": "C1"}, "fix": "tighter eyelets",
         "lowered_by": "check.robust_severity"},
        {"id": "eyelet.position", "severity": "error", "passed": True, "message": "ok", "measured": 0.0,
         "limit": 0.01, "where": {}, "fix": "", "lowered_by": ""}]
    lines = verdict_lines({"design": "d", "ok": False, "checks": checks}, "out/d/summary.md",
                          {"check.robust_severity": "params/d.yaml"})
    assert lines[0] == ("failed:", "disk.tilt disk_18 station 18: 0.5966° against 0.5°; fix: disks.slot_clearance "
                                   "to at most 0.042 mm")
    assert lines[1] == ("warning:", "tendon.robust C1: 0.54 mm against 0.2 mm (stated as a warning: "
                                    "check.robust_severity); fix: tighter eyelets")
    assert lines[2] == ("verdict", "FAIL: 3 checks, 1 failed, 1 warning(s); severity lowered by the design: "
                                   "check.robust_severity: warning (in params/d.yaml) states failing checks as "
                                   "warnings (1 tendon.robust); see out/d/summary.md")


def _tension(tmp_path, body: str):
    from hwgen.checks.tension import tension_checks
    from hwgen.pipeline import design_plan, load
    plan = design_plan(load(based(tmp_path, "design: t\n" + body)))
    _, checks = tension_checks(plan, {}, {})
    return next(c for c in checks if c.id == "actuation.tension")


def test_a_tendon_at_its_break_load_fails(tmp_path):
    """The prototype's A2 pulls about 23.5 N at 90°: over 44.5 N / 3 (a warning); a line that
    breaks at 20 N breaks (an error that fails the design, with the line that would hold)."""
    warn = _tension(tmp_path, "")
    assert (warn.severity, warn.passed, warn.limit) == ("warning", False, pytest.approx(44.5 / 3))
    broken = _tension(tmp_path, "tendon_material:\n  break_load: 20\n")
    assert (broken.severity, broken.passed, broken.limit) == ("error", False, 20.0)
    assert broken.measured == pytest.approx(warn.measured) and broken.measured >= 20
    assert "break load: the line breaks" in broken.message
    assert f"break_load of at least {broken.measured * 3:.0f} N" in broken.fix


# ---------------------------------------------------------------- the README's own robot, built

WARNING_RGB = np.array([255, 0, 140])          # pictures.WARNING_COLOUR, lit: its hue in the PNG


def _warning_pixels(png: Path) -> int:
    from PIL import Image
    img = np.asarray(Image.open(png).convert("RGB")).astype(int)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return int(np.count_nonzero((r > 150) & (g < 40) & (b > 70) & (b < 0.8 * r)))


@pytest.mark.slow
def test_the_readmes_own_robot_builds_from_params_and_says_what_fails(tmp_path):
    assert "base: prototype.yaml" in (PARAMS / "twenty-disks.yaml").read_text()
    code, out, err = run_cli("build", str(PARAMS / "twenty-disks.yaml"), "--out", str(tmp_path), "-q")
    folder = tmp_path / "twenty-disks"
    assert code == 1, err
    report = json.loads((folder / "report.json").read_text())
    failed = [c for c in report["checks"] if not c["passed"] and c["severity"] == "error"]
    assert failed and all(c["fix"] for c in failed)
    lines = out.strip().splitlines()
    shown = [ln for ln in lines if ln.startswith("failed: ")]
    assert [ln.split()[1] for ln in shown] == [c["id"] for c in failed]           # every one, in order
    assert all("; fix: " in ln for ln in shown)
    assert lines[-1] == (f"twenty-disks: FAIL: {len(report['checks'])} checks, {len(failed)} failed, "
                         f"{sum(not c['passed'] and c['severity'] == 'warning' for c in report['checks'])} "
                         f"warning(s); see {folder / 'summary.md'}")
    # every fix tried (issue 43): the model's checks carry their fixes, each with what it does to the
    # stiffening; no fix text begins with "or"
    assert not [c["fix"] for c in report["checks"] if c["fix"].lower().startswith("or")]
    tried = {c["id"] for c in failed if c.get("fixes")}
    assert {"disk.tilt", "gravity.strip_stress", "backbone.bend_stress", "stiffening.tip"} <= tried, tried
    assert all("stiffening" in f["then"] for c in failed for f in c.get("fixes", ()) if not f["then"].get("refused"))
    # the strip's two stresses each say what the other costs
    fix = {c["id"]: c["fix"] for c in failed}
    assert "backbone.bend_stress" in fix["gravity.strip_stress"] and "gravity.strip_stress" in fix["backbone.bend_stress"]
    # the prototype's lowered severity is not the twenty-disk robot's: its tendon.robust failures count
    assert any(c["id"] == "tendon.robust" for c in failed) and "not taken from the base" in err
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["params_base"] == [str(PARAMS / "prototype.yaml")]
    assert manifest["design_resolved"]["disks"]["count"] == 20 and manifest["design_resolved"]["disks"]["spacing"] is None
    # the pictures point at what fails: every marked part and tendon is one a failed check names
    marked = manifest["render"]["failing"]
    assert "disk_18" in marked["parts"] and "C1" in marked["tendons"]
    for png in ("bent.png", "exploded.png"):
        assert _warning_pixels(folder / png) > 1000, png
        assert manifest["render"]["files"][png]["sha256"] == __import__("hashlib").sha256(
            (folder / png).read_bytes()).hexdigest()
    summary = (folder / "summary.md").read_text()
    assert summary.count("**Fix:**") >= len(failed)


def test_a_passing_design_has_no_warning_colour(built):
    folder = built("prototype")
    manifest = json.loads((folder / "manifest.json").read_text())
    assert "failing" not in manifest["render"]
    for png in ("bent.png", "exploded.png"):
        assert _warning_pixels(folder / png) == 0, png
    assert re.search(r"check\.robust_severity: warning \(in .*prototype\.yaml\)|Severity lowered by the design",
                     (folder / "summary.md").read_text())
