"""Fixes tried before they are printed (issue 43): on the user's robots (params/) and labs' robots
(tests/labs/: FDM, small disks, two or three stiffening tendons), each failing check's first
``fixes`` entry, applied to the design's file with nothing else changed and the file loaded again
as a user's is, makes that check pass at that place in at least 9 of 10 tries; what the stiffening
tendons are for is a check; the fix text never begins with "or".

At the plan level (no CAD): the tension checks (the weightless bending sweep through the eyelet
centres) and the stiffening (the tendon states' statics), which is where these checks' models
live; the checks measured from files (tilt, strip stress, gears) compute their fixes with the same
model they judged by, tested where those checks are."""
from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

from hwgen import pipeline
from hwgen.checks import purpose
from hwgen.checks.base import Check, Fix, fix_text
from hwgen.checks.tension import tension_checks
from hwgen.tried import run as tried
from hwgen.tried.trial import Trial, ident, put

ROOT = Path(__file__).resolve().parents[1]
LABS = sorted((ROOT / "tests" / "labs").glob("*.yaml"))
ROBOTS = [ROOT / "params" / "prototype.yaml", *LABS]


def _checks(plan, trial: Trial, tension: bool = True, stiffening: bool = True) -> list[dict]:
    """The plan-level checks: the tension sweep's (no as-built excess) and the stiffening's."""
    fig = trial.stiffening({}) if stiffening else None
    return (([c.to_json() for c in tension_checks(plan, {}, {})[1]] if tension else [])
            + ([c.to_json() for c in purpose.judge(plan, fig)] if fig else []))


def _report(path: Path) -> tuple[dict, Trial]:
    loaded = pipeline.load(path)
    plan = pipeline.design_plan(loaded)
    report = {"checks": [], "tendons": [], "as_built": {}}
    report["checks"] = _checks(plan, Trial(loaded, plan, report, {}))
    trial = Trial(loaded, plan, report, {})
    return tried.attach(report, trial), trial


def _applied(trial: Trial, fix: dict, folder: Path, cid: str) -> dict[tuple, dict]:
    """The plan-level checks of ``cid``'s model of the design's file with ``fix`` applied, written
    and loaded again."""
    doc = copy.deepcopy(trial.loaded.layers.doc)
    for path, value in fix["set"].items():
        put(doc, path, value)
    f = folder / "fixed.yaml"
    f.write_text(yaml.safe_dump(doc, sort_keys=False))
    loaded = pipeline.load(f)
    plan = pipeline.design_plan(loaded)
    purpose_ = cid.startswith("stiffening.")
    return {ident(c): c for c in _checks(plan, Trial(loaded, plan, {"checks": []}, {}), not purpose_, purpose_)}


@pytest.fixture(scope="module")
def reports():
    """Each robot's plan-level report with its tried fixes, made once for this module's tests."""
    return {path: _report(path) for path in ROBOTS}


@pytest.mark.slow
def test_each_failing_checks_first_fix_makes_it_pass_at_that_place(reports, tmp_path):
    tries, passed, failed = 0, 0, []
    for path in ROBOTS:
        report, trial = reports[path]
        for c in report["checks"]:
            if c["passed"]:
                continue
            assert c.get("fixes"), (path.name, c["id"])
            first = c["fixes"][0]
            assert not c["fix"].lower().startswith("or"), c["fix"]
            assert "stiffening" in first["then"], (path.name, c["id"])      # what it does to the stiffening
            again = _applied(trial, first, tmp_path, c["id"]).get(ident(c))
            tries += 1
            if again is not None and again["passed"]:
                passed += 1
            else:
                failed.append((path.name, c["id"], first["set"], again and again["measured"]))
    assert tries >= 10
    assert passed >= 0.9 * tries, (passed, tries, failed)
    print(f"{passed} of {tries} first fixes pass their check")


@pytest.mark.slow
def test_the_labs_robots_say_what_their_stiffening_tendons_add(reports):
    """Every lab robot's stiffening is judged against the floor its file states (or inherits), and a
    fix that takes a passing stiffening under it says so in ``breaks``."""
    for path in LABS:
        report, trial = reports[path]
        got = {c["id"]: c for c in report["checks"] if c["id"].startswith("stiffening.")}
        assert set(got) == {"stiffening.tip", "stiffening.torsion"}, path.name
        base = trial.stiffening({})
        # the same statics (to the protocol search's tolerance: a trial may keep a robot's stiffening
        # found under another ceiling of the protocol's tensions, hwgen.tried.trial)
        assert got["stiffening.tip"]["measured"] == pytest.approx(base["tip"], rel=1e-3)
        assert got["stiffening.tip"]["passed"] == (base["tip"] >= trial.plan.check.min_stiffening)
        for c in report["checks"]:
            for f in c.get("fixes", ()):
                s = f["then"]["stiffening"]
                if s < trial.plan.check.min_stiffening and got["stiffening.tip"]["passed"]:
                    assert "stiffening.tip" in f["breaks"], (path.name, c["id"], f)


def test_the_stiffening_check_fails_under_its_floor_and_names_it():
    class Plan:
        class check:
            min_stiffening, min_torsion_stiffening = 2.5, 2.0

        class tensioner:
            actuating_channel = "A"

        paths = ()

    got = {c.id: c for c in purpose.judge(Plan, {"states": ["AC1C2H", "A"], "tip": 1.0, "torsion": 3.0})}
    assert not got["stiffening.tip"].passed and "check.min_stiffening" in got["stiffening.tip"].message
    assert got["stiffening.torsion"].passed
    assert purpose.stiffening_checks(Plan, {"stiffening": None}) == []


def test_the_fix_text_prints_only_what_passes_and_says_when_nothing_does():
    good = Fix({"tendons[2].pretension_n": 5.7}, {"measured": 0.61, "passed": True, "stiffening": 2.9}, (), "lock C1")
    relax = Fix({"check.max_coupling": 0.3}, {"measured": 0.25, "passed": True}, (), "accept", relax=True)
    bad = Fix({"process.hole_clearance": 0.0}, {"measured": 0.35, "passed": False}, (), "the FDM hole alone")
    text = fix_text([good, bad, relax])
    assert text.startswith("(1) tendons[2].pretension_n: 5.7") and "(2) check.max_coupling" in text
    assert "hole_clearance" not in text and "relaxes a requirement" in text and "2.90×" in text
    none = fix_text([bad])
    assert none.startswith("no change tried") and "0.35" in none and "still fails" in none
    c = Check("tendon.taut", "error", False, "m", fixes=(good,))
    assert c.to_json()["fixes"][0]["set"] == {"tendons[2].pretension_n": 5.7}


@pytest.mark.parametrize("hertz", [False, True])
def test_a_weak_gear_tooth_is_fixed_by_the_law_its_check_applies(hertz):
    """gear.lewis's safety goes as the face, gear.hertz's as its square root; both as the resin's
    strength: the first fix (a wider face) reaches the safety factor, and says by how much."""
    from types import SimpleNamespace

    from hwgen.checks.gear_mesh import _strength_fix, _strength_fixes
    ts = SimpleNamespace(resin_strength=35.0, safety_factor=2.0)        # the settings hold no gear sizes
    pair = SimpleNamespace(face_width=8.0, teeth=24, module=1.25)       # the built pair's
    face, resin = _strength_fixes(ts, pair, 1.5, hertz)
    k = face.set["tensioner.face_width"] / 8.0
    assert face.then["passed"] and face.then["measured"] == pytest.approx(1.5 * (k ** 0.5 if hertz else k))
    assert face.then["measured"] >= 2.0 and (face.set["tensioner.face_width"] - 0.1) / 8.0 < (4 / 2.25 if hertz
                                                                                              else 2 / 1.5)
    assert resin.then["passed"] and resin.set["tensioner.resin_strength"] == 47.0
    text = _strength_fix(ts, pair, 2.0 / 1.5, hertz)
    assert text.startswith("(1) tensioner.face_width") and "Also (not tried): tensioner.wheel_teeth" in text
