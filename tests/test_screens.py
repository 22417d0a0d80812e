"""The plan-level screens (:mod:`hwgen.checks.screens`) agree with the checks that own their ids: on
a design's plan a screen fires exactly where ``hwgen check`` on the built files fails that check, in
the screen's scope (the tip disk's eyelets turned toward the drums for the openings; every disk's walls; the base disk's seats; the strip;
the tendons between the disks). Checked on the shipped designs, on robots drawn the way a lab
writes them (``tests/robots.py``), and on the tuned designs a sweep screens out (a seat wider than its
knot, an opening two tendons share, a crossing through the strip's edge)."""
from __future__ import annotations

import numpy as np
import pytest

from hwgen.checks.screens import SCREENS, plan_screens
from hwgen.model.plan import make_plan
from hwgen.params import Design, LoadedDesign
from hwgen.pipeline import build, design_plan, load

from .conftest import PARAMS
from .robots import lab_robot
from .stability import SEED

# each screen's id -> (the id of the check that owns it, whether only the tip disk's records count)
OWNER = {"eyelet.overlap": ("eyelet.overlap", True), "eyelet.wall": ("eyelet.wall.eyelet", False),
         "backbone.crossing": ("backbone.crossing", False), "eyelet.shared_sliding": ("eyelet.shared_sliding", False),
         "tendon.clearance": ("tendon.clearance", False), "tendon.seat": ("tendon.seat", False),
         "gear.tooth_tip": ("gear.tooth_tip", False), "gear.thread_tip": ("gear.thread_tip", False),
         "gear.bore_wall": ("gear.bore_wall", False), "gear.drive_wall": ("gear.drive_wall", False)}


def _failed(report: dict, tip: int) -> set[str]:
    """The screens' ids whose owning check fails in the report, within the screen's scope."""
    out = set()
    for screen_id, (check_id, tip_only) in OWNER.items():
        for c in report["checks"]:
            where = c.get("where") or {}
            if c["id"] == check_id and not c["passed"] and (not tip_only or where.get("station") == tip):
                out.add(screen_id)
    return out


def _agree(loaded: LoadedDesign, folder) -> None:
    import json
    plan = design_plan(loaded)
    report = json.loads((folder / "report.json").read_text())
    fired = {s.id for s in plan_screens(plan)}
    assert fired == _failed(report, plan.disks[-1].index), loaded.name


def test_every_screen_has_its_owner():
    """Every screen is listed with the check that owns its id, and the shipped designs fire none."""
    ids = set()
    for design in ("prototype", "paper-table2"):
        plan = make_plan(load(PARAMS / f"{design}.yaml").design)
        ids |= {s.id for s in plan_screens(plan)}
    assert ids == set()
    assert len(SCREENS) == len(OWNER)


def _tuned(**changed) -> Design:
    """The tune's stiffness trial that tests/test_tune.py screens (every screen but the rubbing one
    fires on one of its variants), with ``changed`` values."""
    from hwgen.sweep.spec import Variant, resolve
    from hwgen.tune import spec
    from .test_tune import screened_trial
    loaded = spec.load(PARAMS / "tune-stiffness.yaml")
    values = {**screened_trial(), **changed}
    r = resolve(loaded.base, loaded.names, Variant(0, tuple(values[n] for n in loaded.names)))
    assert r.design is not None, r.message
    return r.design


TUNED = {"seat": {}, "overlap": {"tendons[3].routing.function.a": 28},
         "crossing": {"tendons[1].routing.function.x0": -7.0, "tendons[2].routing.function.x0": 14.0,
                      "tendons[3].routing.function.a": 30}}


@pytest.mark.slow
@pytest.mark.parametrize("design", ["prototype", "paper-table2"])
def test_screens_agree_with_the_checks_on_the_shipped_designs(design, built):
    _agree(load(PARAMS / f"{design}.yaml"), built(design))


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(TUNED))
def test_screens_agree_with_the_checks_on_screened_trials(case, tmp_path, monkeypatch):
    monkeypatch.setenv("HWGEN_RENDER_BACKEND", "none")          # the report is compared, not the pictures
    d = _tuned(**TUNED[case]).model_copy(update={"design": f"screened-{case}"})
    loaded = LoadedDesign(design=d, source=f"screened {case}", sha256=case)
    assert plan_screens(design_plan(loaded))             # the sweep screens it out
    _agree(loaded, build(loaded, tmp_path).folder)


@pytest.mark.slow
@pytest.mark.parametrize("index", [12, 37])
def test_screens_agree_with_the_checks_on_drawn_robots(index, tmp_path, monkeypatch):
    """Two cheap robots (four or five disks) of `make stability`'s widened draw (tests/test_any_robot.py's)."""
    monkeypatch.setenv("HWGEN_RENDER_BACKEND", "none")          # the report is compared, not the pictures
    rng = np.random.default_rng(SEED)
    docs = [lab_robot(rng, f"robot{i:03d}") for i in range(index + 1)]
    f = tmp_path / "robot.yaml"
    import yaml
    f.write_text(yaml.safe_dump(docs[index], sort_keys=False))
    try:
        loaded = load(f)
        design_plan(loaded)
    except Exception as e:        # a drawn robot hwgen refuses is bad input, not a disagreement
        pytest.skip(f"drawn robot {index} is refused: {e}")
    _agree(loaded, build(loaded, tmp_path / "out").folder)
