"""hwgen tune: the tune file, a tune with a known answer, resuming without evaluating a design twice,
best.yaml's round trip, the statics it reads against `hwgen stiffness`, and the shipped examples."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from functools import partial
from pathlib import Path

import pyarrow.parquet as pq
import pytest
import yaml

from hwgen import bench
from hwgen.errors import InputError
from hwgen.sweep import levels
from hwgen.sweep.records import EvalOptions
from hwgen.tune import report, results, run as tune_run, spec

from .clirunner import hwgen, hwgen_process
from .conftest import PARAMS

PROTOTYPE = PARAMS / "prototype.yaml"
K = "tendons[1].routing.function.k"


_cli = hwgen            # in this process: `--scheduler inline` runs the tune here


def _tune_file(tmp_path: Path, body: dict, name: str = "t.yaml") -> Path:
    doc = {"tune": "t", "base": str(PROTOTYPE), "level": "lengths",
           "free": [{"path": K, "low": 0.5, "high": 4}], "goal": {"minimize": "centre_mm.C1"}, **body}
    p = tmp_path / name
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    return p


def _trials(out: Path, name: str = "t") -> list[dict]:
    return pq.read_table(out / "tunes" / name / "trials.parquet").to_pylist()


# ---------------------------------------------------------------- the tune file

@pytest.mark.parametrize("body, field, words", [
    ({"free": [{"path": "tendons[1].routing.function.kk", "low": 1, "high": 2}]}, "free[0].path", "not a field"),
    ({"free": [{"path": "tendons[9].routing.function.k", "low": 1, "high": 2}]}, "free[0].path", "has 4 item"),
    ({"free": [{"path": K, "low": 3, "high": 2}]}, "free[0]", "must be above low"),
    ({"free": [{"path": K, "low": 1}]}, "free[0]", "give 'low' and 'high'"),
    ({"free": [{"path": K, "low": 1, "high": 2, "choices": [1, 2]}]}, "free[0]", "not both"),
    ({"free": [{"path": K, "low": 1.5, "high": 4, "integer": True}]}, "free[0]", "whole numbers"),
    ({"free": [{"path": K, "low": 1, "high": 2}, {"path": K, "low": 1, "high": 3}]}, "free[1].path", "already free"),
    ({"free": [{"path": "tendons[1].routing.function.axis", "low": 1, "high": 2}]}, "free[0].path", "give 'choices'"),
    ({"goal": {"maximize": "stiffness"}}, "goal.maximize", "not a result a tune knows"),
    ({"goal": {"minimize": ["centre_mm.C1", "coupling"]}}, "goal.minimize[1]", "from the coupling level on"),
    ({"goal": {"maximize": "tip_stiffness@AX"}}, "goal.maximize", "not a tendon state"),
    ({"goal": {"maximize": "tip_stiffness", "state": "AX"}}, "goal.state", "not a tendon state"),
    ({"goal": {"maximize": "tip_stiffness", "at_least": {"tip_torsion": "twice"}}}, "goal.at_least.tip_torsion",
     "base"),
    ({"goal": {"maximize": "tip_stiffness", "require": ["Taut"]}}, "goal.require[0]", "not a check id"),
    ({"goal": {"pass": True, "maximize": "tip_stiffness"}}, "goal", "not both"),
    ({"goal": {"maximize": "tip_stiffness", "orientation": "upside down"}}, "goal.orientation", "gravity -z"),
    ({"goal": {"maximize": "tip_stiffness", "friction": "capstan"}}, "goal.friction", "stuck"),
    ({"base": "nowhere.yaml"}, "base", "nowhere.yaml: no such file (looked for at "),
    ({"goal": {}}, "goal", "give 'maximize'"),
    ({"set": {"disks.cont": 20}}, "set.disks.cont", "not a field"),
    ({"set": {"disks.count": 1}}, "set", "not a design"),
    ({"tune": "../x"}, "tune", "not a safe file name"),
    ({"budgt": 3}, "budgt", "unknown key"),
])
def test_bad_tune_file_names_file_and_field(tmp_path, body, field, words):
    f = _tune_file(tmp_path, body)
    with pytest.raises(InputError) as e:
        spec.load(f)
    assert (str(e.value.file), e.value.path or "<document>") == (str(f), field) and words in e.value.message, e.value


def test_bad_tune_file_exits_2_and_writes_nothing(tmp_path):
    f = _tune_file(tmp_path, {"free": [{"path": "tendons[1].routing.function.kk", "low": 1, "high": 2}]})
    r = _cli("tune", str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline")
    assert r.returncode == 2, r.stdout + r.stderr
    assert r.stderr.strip() == (f"error: {f}: free[0].path: tendons[1].routing.function.kk: not a field of the "
                                f"design; did you mean tendons[1].routing.function.k? (see `hwgen schema`)")
    assert not (tmp_path / "out").exists()


def test_the_shipped_tune_files_load():
    for name in ("tune-stiffness.yaml", "tune-fix-twenty-disks.yaml"):
        loaded = spec.load(PARAMS / name)
        assert loaded.names and loaded.objectives
    twenty = spec.load(PARAMS / "tune-fix-twenty-disks.yaml")
    assert twenty.base_path == PARAMS / "twenty-disks.yaml"          # main's robot, not a copy
    assert twenty.base["disks"]["count"] == 20 and "spacing" not in twenty.base["disks"]
    assert twenty.base_values[twenty.names.index("disks.count")] == 20


# ---------------------------------------------------------------- a known answer

def test_a_tune_with_a_known_answer_finds_a_whole_k(tmp_path):
    """Minimise C1's largest length change by eq. (2) over ±90° for k in 0.5-4 (no check in the way):
    to first order a cosine keeps its length for whole k only, so the best k is a whole number
    (the sweep's table: 0.18-0.2 mm there, 3-25 mm at half-integers). The base starts at k 2.6,
    the first trial: the search has to leave it."""
    f = _tune_file(tmp_path, {"budget": 60, "seed": 3, "set": {K: 2.6},
                              "goal": {"minimize": "centre_mm.C1", "checks": "required"}})
    r = _cli("tune", str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline", "--no-build")
    assert r.returncode == 0, r.stdout + r.stderr
    rows = [t for t in _trials(tmp_path / "out") if t["trial"] >= 0]
    assert len(rows) == 60
    best = min(rows, key=lambda t: t["centre_mm.C1"])
    k = best[K]
    assert best["trial"] != 0 and abs(k - round(k)) < 0.01 and best["centre_mm.C1"] < 0.3, (k, best)
    worst_half = min(t["centre_mm.C1"] for t in rows if abs(t[K] - round(t[K])) > 0.25)
    assert worst_half > 3 * best["centre_mm.C1"]
    text = (tmp_path / "out" / "tunes" / "t" / "best.yaml").read_text()
    assert f"k: {round(k, 6)}" in text
    # the figures the terminal prints, for the bench and scripts: the best it names is the trials' best
    run = json.loads((tmp_path / "out" / "tunes" / "t" / "run.json").read_text())
    assert run["command"] == "tune" and run["evaluated"] + run["repeated"] == 60 and run["seconds"] > 0
    assert run["best"]["trial"] == best["trial"]
    assert run["best"]["objectives"]["centre_mm.C1"] == pytest.approx(best["centre_mm.C1"], rel=1e-12)
    assert f"at trial {best['trial']}" in bench._tune_note(run)


# ---------------------------------------------------------------- resuming, repeats

def _evaluated(rows: list[dict]) -> list[str]:
    return [t["hash"] for t in rows if t["trial"] >= 0 and t["same_as"] is None]


def test_a_design_is_evaluated_once_and_a_rerun_goes_on(tmp_path):
    """Whole k in 1-4: four designs, so of ten trials six are told an earlier trial's result; a rerun
    with a larger budget goes on from the ten told and evaluates no design again."""
    f = _tune_file(tmp_path, {"budget": 10, "free": [{"path": K, "low": 1, "high": 4, "integer": True}],
                              "goal": {"minimize": "centre_mm.C1", "checks": "required"}})
    loaded = spec.load(f)
    out = tmp_path / "out"
    o1, _ = tune_run.run(loaded, out, "inline")
    assert o1.evaluated + o1.repeated == 10 and o1.evaluated <= 4
    o2, study = tune_run.run(loaded, out, "inline", budget=14)
    assert o2.done_before == 10 and o2.evaluated + o2.repeated == 4 and o1.evaluated + o2.evaluated <= 4
    report.write(loaded, study, out / "tunes" / "t")
    rows = _trials(out)
    assert len(rows) == 15 and len(set(_evaluated(rows))) == len(_evaluated(rows)) <= 4
    for t in rows:
        if t["same_as"] is not None:
            twin = next(s for s in rows if s["trial"] == t["same_as"])
            assert (t["hash"], t["centre_mm.C1"]) == (twin["hash"], twin["centre_mm.C1"])


def test_a_changed_tune_file_does_not_mix_with_the_old_trials(tmp_path):
    f = _tune_file(tmp_path, {"budget": 2})
    tune_run.run(spec.load(f), tmp_path / "out", "inline")
    g = _tune_file(tmp_path, {"budget": 2, "free": [{"path": K, "low": 0.5, "high": 3}]})
    with pytest.raises(InputError) as e:
        tune_run.run(spec.load(g), tmp_path / "out", "inline")
    assert "another tune" in e.value.message


@pytest.mark.slow
def test_an_interrupted_tune_resumes_evaluating_no_trial_twice(tmp_path):
    """Killed (SIGKILL) mid-run, then run again: the trials told before are read back, those in
    flight are asked again, and no design is evaluated twice."""
    f = _tune_file(tmp_path, {"budget": 400, "seed": 1})
    out = tmp_path / "out"
    journal = out / "tunes" / "t" / tune_run.JOURNAL
    p = subprocess.Popen([sys.executable, "-m", "hwgen.cli", "tune", str(f), "--out", str(out), "--scheduler",
                          "inline", "-q", "--no-build"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while (not journal.exists() or journal.stat().st_size < 30_000) and p.poll() is None \
                and time.monotonic() < deadline:
            time.sleep(0.01)
    finally:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
    loaded = spec.load(f)
    study = tune_run.open_study(loaded, out / "tunes" / "t")
    told = len([t for t in study.trials if t.state.name == "COMPLETE"])
    assert 0 < told < 400
    budget = told + 15
    r = _cli("tune", str(f), "--out", str(out), "--scheduler", "inline", "--budget", str(budget), "--no-build")
    assert r.returncode in (0, 1), r.stderr
    assert f"{told} trials told before" in r.stdout
    rows = [t for t in _trials(out) if t["trial"] >= 0]
    assert len(rows) == budget
    assert len(set(_evaluated(rows))) == len(_evaluated(rows))


# ---------------------------------------------------------------- best.yaml, the statics

def test_best_yaml_is_the_base_with_only_the_tuned_values_changed(tmp_path):
    f = _tune_file(tmp_path, {"budget": 6, "set": {"tendons[2].pretension_n": 6},
                              "free": [{"path": K, "low": 1, "high": 4, "integer": True},
                                       {"path": "tendons[1].routing.function.phase_deg", "choices": [0, 180]}],
                              "goal": {"minimize": "centre_mm.C1", "checks": "required"}})
    r = _cli("tune", str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline", "--no-build")
    assert r.returncode == 0, r.stderr
    folder = tmp_path / "out" / "tunes" / "t"
    text = (folder / "best.yaml").read_text()
    best = yaml.safe_load(text)
    base = yaml.safe_load(PROTOTYPE.read_text())
    chosen = next(t for t in _trials(tmp_path / "out") if t["trial"] >= 0 and t["feasible"]
                  and t["centre_mm.C1"] == min(s["centre_mm.C1"] for s in _trials(tmp_path / "out") if s["trial"] >= 0))
    base["design"] = "prototype-t"
    base["tendons"][2]["pretension_n"] = 6
    base["tendons"][1]["routing"]["function"]["k"] = chosen[K]
    if chosen["tendons[1].routing.function.phase_deg"] != 0:          # a value the same as the base's is left alone
        base["tendons"][1]["routing"]["function"]["phase_deg"] = chosen["tendons[1].routing.function.phase_deg"]
    assert best == base
    # every comment line of the base is still there, and its lines are as they were but the changed ones
    old = PROTOTYPE.read_text().splitlines()
    new = text.splitlines()[1:]
    assert [l for l in old if l.lstrip().startswith("#")] == [l for l in new if l.lstrip().startswith("#")]
    removed, added = [l for l in old if l not in set(new)], [l for l in new if l not in set(old)]
    assert len(removed) <= 3 and len(added) <= 4, (removed, added)     # design, k, phase; C2's pretension_n added
    assert (folder / "summary.md").exists() and (folder / "convergence.png").stat().st_size > 1000


def test_best_yaml_of_a_design_with_a_base_keeps_its_chain(tmp_path):
    """params/twenty-disks.yaml builds on prototype.yaml: best.yaml is that file with the tuned values
    written in (a mapping merged with its base's), its base named where it is, and it reads back
    as the trial's design."""
    from hwgen import params
    loaded = spec.load(PARAMS / "tune-fix-twenty-disks.yaml")
    values = (0.8, 52.0, 16, 2.5, 0.7, 20.0, -2.5)
    text = report.best_yaml(loaded, {"trial": 3, "values": list(values)})
    doc = yaml.safe_load(text)
    assert Path(doc["base"]) == (PARAMS / "prototype.yaml").resolve()
    assert doc["disks"]["hub"] == {"max_tilt_deg": 0.7} and doc["disks"]["spacing"] is None
    assert doc["check"] == {"robust_severity": "warning"}              # the tune's `set`, stated in the file
    (tmp_path / "best.yaml").write_text(text)
    d = params.read(tmp_path / "best.yaml").design
    assert (d.backbone.thickness, d.backbone.height, d.disks.count, d.disks.thickness,
            d.disks.hub.max_tilt_deg, d.tendons[2].routing.function.a, d.tendons[2].routing.function.x0,
            d.backbone.length) == (*values, 300)
    assert d.check.robust_severity == "warning"
    before = params.read(PARAMS / "twenty-disks.yaml").design.tendons
    assert d.tendons[:2] == before[:2] and d.tendons[3:] == before[3:]
    assert d.tendons[2].routing.function.model_copy(update={"a": 25.0, "x0": 0.0}) == before[2].routing.function


def test_the_statics_a_tune_reads_are_hwgen_stiffness(tmp_path):
    """The tune's figures of a design are `hwgen stiffness`'s (its stiffness.json: the same study of
    the plan, no stand-in) in the orientation and friction the goal names, gravity -z frictionless
    by default; a worker's row carries the same."""
    from hwgen import params, pipeline
    from hwgen.model.plan import make_plan
    loaded = params.read(PROTOTYPE)
    rep, folder = pipeline.stiffness(loaded, tmp_path, ["AC1C2H"], cache_dir=False)
    written = json.loads((folder / "stiffness.json").read_text())
    plan = make_plan(loaded.design)
    for orientation, friction in (("gravity -z", "none"), ("weightless", "stuck")):
        got = results.statics(plan, ("AC1C2H",), orientation, friction)["statics"]
        for state in ("AC1C2H",):
            e = next(e for e in written["states"] if e["state"] == state and e["orientation"] == orientation
                     and e["friction"] == friction)
            assert got[f"tip_stiffness@{state}"] == pytest.approx(e["tip_stiffness_n_per_mm"], rel=1e-9)
            assert got[f"tip_torsion@{state}"] == pytest.approx(e["tip_torsion_nmm_per_rad"], rel=1e-9)
            assert got[f"least_stiffness@{state}"] == pytest.approx(
                min(d["stiffness_n_per_mm"] for d in e["disks"]), rel=1e-9)
    default = next(e for e in written["states"] if e["state"] == "AC1C2H" and e["orientation"] == "gravity -z"
                   and e["friction"] == "none")
    doc = yaml.safe_load(PROTOTYPE.read_text())
    rows = levels.evaluate_batch([(0, (1.0,))], doc, (K,), "lengths",
                                 options=EvalOptions(with_plan=partial(results.statics, states=("AC1C2H",))))
    assert rows[0].figures["statics"]["tip_stiffness@AC1C2H"] == pytest.approx(default["tip_stiffness_n_per_mm"], rel=1e-9)


def test_a_screened_trial_still_measures_its_bounds():
    """A trial that fails eq. (2) stops before the checks after it, but its statics are measured: the
    optimiser learns how far it is from each bound, not a stand-in worse than any trial."""
    doc = yaml.safe_load(PROTOTYPE.read_text())
    opts = EvalOptions(screen=True, with_plan=partial(results.statics, states=("AC1C2H",)), robust_samples=10)
    off, whole = levels.evaluate_batch([(0, (2.5,)), (1, (1.0,))], doc, (K,), "coupling", options=opts)
    assert off.screened and any(f.id == "tendon.length" and f.fails for f in off.failures)
    assert off.coupling is None                                          # the tension checks were not run
    statics = off.figures["statics"]
    assert statics["tip_stiffness@AC1C2H"] > 0 and statics["tip_torsion@AC1C2H"] > 0
    assert not whole.screened and whole.coupling is not None
    assert "screened" not in whole.to_json() and off.to_json()["statics"] == statics   # a tune's stored row


def test_constraints_count_failing_checks_and_bounds():
    loaded = spec.load(PARAMS / "tune-stiffness.yaml")
    base = {"verdict": "pass", "failures": [], "statics": {"tip_stiffness@AC1C2H": 0.1, "tip_torsion@AC1C2H": 700,
                                                           "least_stiffness@AC1C2H": 0.1}}
    row = {"verdict": "pass", "failures": [{"id": "tendon.taut", "severity": "warning", "measured": 0.25,
                                            "limit": 0.5}],
           "statics": {"tip_stiffness@AC1C2H": 0.2, "tip_torsion@AC1C2H": 350, "least_stiffness@AC1C2H": 0.12}}
    values, cons, ok = tune_run.score(loaded, row, base)
    assert values == [0.2] and not ok
    assert cons == [pytest.approx(0.5), pytest.approx(0.5), 0.0]       # taut required: 50 % short; torsion half
    row["failures"].append({"id": "eyelet.overlap", "severity": "error", "measured": None, "limit": None})
    row["failures"].append({"id": "eyelet.wall", "severity": "error", "measured": 0.8, "limit": 0.8})
    assert tune_run.score(loaded, row, base)[1][0] == pytest.approx(0.5 + 1.0 + 1e-3)   # unmeasured: one; at the limit: a little
    row["failures"] = [{"id": "actuation.tension", "severity": "warning", "measured": 20, "limit": 14.8}]
    row["statics"]["tip_torsion@AC1C2H"] = 800
    assert tune_run.score(loaded, row, base)[2]                          # a warning not required does not bind


# ---------------------------------------------------------------- the shipped examples, on a small budget

@pytest.mark.slow
def test_the_shipped_stiffness_tune_builds_its_best(tmp_path):
    """params/tune-stiffness.yaml on 16 trials: the base (trial -1) is the prototype as `hwgen stiffness`
    sees it, the first trial its routing (the pre-tensions, which the prototype leaves to the protocol,
    drawn); the best feasible trial keeps the tip's torsion and the least disk stiffness, the actuating
    pair is as it was, and it builds and passes `hwgen check`; with none feasible, the summary names
    what binds. (The done-when, 1.5× on the full budget, is measured by running the tune, not here.)"""
    r = hwgen_process("tune", str(PARAMS / "tune-stiffness.yaml"), "--out", str(tmp_path), "--budget", "16",
                      "--scheduler", "inline", "-q")
    assert r.returncode in (0, 1), r.stdout + r.stderr
    rows = _trials(tmp_path, "stiffness")
    assert len(rows) == 17 and [t["trial"] for t in rows[:2]] == [-1, 0]
    base, first = rows[0], rows[1]
    loaded = spec.load(PARAMS / "tune-stiffness.yaml")
    dists = tune_run.distributions(loaded)
    for name, value in zip(loaded.names, loaded.base_values):
        if tune_run._within(dists[name], value):     # a value the base leaves unset: drawn
            assert first[name] == pytest.approx(value), name
    folder = tmp_path / "tunes" / "stiffness"
    summary = (folder / "summary.md").read_text()
    assert "gravity -z, eyelets frictionless" in summary
    ok = [t for t in rows if t["feasible"]]             # the base among them: a candidate like any trial
    if not ok:
        assert r.returncode == 1 and "No trial passes. Of 16 infeasible trials:" in summary
        return
    assert r.returncode == 0, r.stdout + r.stderr
    best = max(ok, key=lambda t: (t["tip_stiffness"], -t["trial"]))
    assert best["tip_torsion ≥ base"] >= base["tip_torsion ≥ base"]
    assert best["least_stiffness ≥ base"] >= base["least_stiffness ≥ base"]
    tuned = yaml.safe_load((folder / "best.yaml").read_text())
    proto = yaml.safe_load(PROTOTYPE.read_text())
    assert tuned["tendons"][0] == proto["tendons"][0]
    report_json = json.loads((folder / "build" / tuned["design"] / "report.json").read_text())
    assert report_json["ok"], [c["id"] for c in report_json["checks"] if not c["passed"]]
    assert "## The best, built" in summary


@pytest.mark.slow
def test_the_shipped_twenty_disk_tune_builds_every_trial(tmp_path):
    """params/tune-fix-twenty-disks.yaml on 2 trials: each built and checked whole (the build level:
    hwgen check's verdict), the base (params/twenty-disks.yaml) first, then a drawn trial; what fails
    is named in the summary."""
    r = hwgen_process("tune", str(PARAMS / "tune-fix-twenty-disks.yaml"), "--out", str(tmp_path), "--budget", "2",
                      "--scheduler", "inline", "-q", "--no-build")
    assert r.returncode in (0, 1), r.stdout + r.stderr
    rows = _trials(tmp_path, "fix-twenty-disks")
    assert [t["trial"] for t in rows] == [-1, 0, 1]
    base = rows[0]
    assert not base["feasible"] and base["distance"] == 0
    failed = {f["id"] for f in json.loads(base["failed_checks"]) if f["severity"] == "error"}
    assert failed
    assert rows[1]["same_as"] == -1                 # the base as the first trial, not built again
    summary = (tmp_path / "tunes" / "fix-twenty-disks" / "summary.md").read_text()
    assert all(i in summary for i in failed), (failed, summary)


def screened_trial() -> dict:
    """A trial of the shipped stiffness tune (its free parameters' values by path) that the full
    plan's screens judge, here and in tests/test_screens.py: steep helices of 5 half turns."""
    c1, c2, h = (f"tendons[{i}].routing.function." for i in (1, 2, 3))
    return {"tendons[1].pretension_n": 10.5, c1 + "a": 31.6, c1 + "k": 1, c1 + "x0": -4.3,
            "tendons[2].pretension_n": 8.2, c2 + "a": 29.1, c2 + "k": 1, c2 + "x0": 9.3,
            "tendons[3].pretension_n": 4.0, h + "a": 26, h + "k": 5, h + "phase_deg": 0,
            c1 + "phase_deg": 0, c2 + "phase_deg": 0,
            **{f"tendons[{i}].termination.diameter": 1.5 for i in (1, 2, 3)}}


def test_the_full_plan_screens_what_hwgen_check_fails():
    """The robust level and above screen the full plan for what the lengths level cannot see: the
    prototype passes; a helix steep at the base disk (a 26 mm, 5 half turns) has a seat wider than
    its 1.5 mm knot (hwgen check's tendon.seat); one ending on A2's eyelet at the tip (a 28 mm, 5
    half turns) shares its opening there (eyelet.overlap); one of 30 mm, 5 half turns, lies on the
    strip's edge at the middle disk, where its hole would notch the strip (backbone.crossing)."""
    from hwgen.model.plan import make_plan
    from hwgen.sweep.spec import Variant, resolve
    loaded = spec.load(PARAMS / "tune-stiffness.yaml")
    tuned = screened_trial()
    assert set(tuned) == set(loaded.names)

    def screens(values: dict) -> dict:
        d = resolve(loaded.base, loaded.names, Variant(0, tuple(values[n] for n in loaded.names))).design
        return {f.id: f for f in levels._plan_screens(make_plan(d))}

    prototype = dict(zip(loaded.names, loaded.base_values))
    assert screens({**prototype, **{f"tendons[{i}].pretension_n": 6.0 for i in (1, 2, 3)}}) == {}
    seat = screens(tuned)
    assert set(seat) == {"tendon.seat"} and seat["tendon.seat"].measured > 1.5 == seat["tendon.seat"].limit
    assert "eyelet.overlap" in screens({**tuned, "tendons[3].routing.function.a": 28})
    edge = screens({**tuned, "tendons[1].routing.function.x0": -7.0, "tendons[2].routing.function.x0": 14.0,
                    "tendons[3].routing.function.a": 30})       # on the strip's edge (x = 30 mm) at the middle disk
    assert edge["backbone.crossing"].measured > 30 == edge["backbone.crossing"].limit
