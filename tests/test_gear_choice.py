"""The tensioner's gear follows the process where the design's own file leaves it to hwgen
(issue 43, item 4): a lab that switches the prototype to FDM walls and writes nothing about the
gear gets a gear that prints, not three refusals blamed on the base file."""
from __future__ import annotations

import re

from hwgen.model.gear_choice import GEAR_KEYS, follow_process
from hwgen.model.gearing import worm_pair
from hwgen.pipeline import design_plan, load

from .conftest import PARAMS

BASE = PARAMS / "prototype.yaml"


def _file(tmp_path, text: str):
    f = tmp_path / "lab.yaml"
    f.write_text(f"base: {BASE}\ndesign: lab\n{text}")
    return f


def test_fdm_walls_alone_get_a_gear_that_prints(tmp_path):
    proto = load(BASE).design.tensioner
    loaded = load(_file(tmp_path, "process:\n  min_wall: 0.9\n"))
    ts, wall = loaded.design.tensioner, loaded.design.process.min_wall
    assert worm_pair(proto, wall).problems(proto.friction_coefficient, wall)        # the base's gear would not print
    assert not worm_pair(ts, wall).problems(ts.friction_coefficient, wall)
    assert ts.module > proto.module
    changed = {k for k in GEAR_KEYS if getattr(ts, k) != getattr(proto, k)}
    note = next(w for w in loaded.warnings if "gear follows the process" in w)
    assert changed and all(f"tensioner.{k} {getattr(proto, k):g} → {getattr(ts, k):g}" in note for k in changed)
    for k in ("wheel_teeth", "face_width", "pressure_angle_deg", "friction_coefficient"):
        assert getattr(ts, k) == getattr(proto, k)                  # the lab's statements are kept
    design_plan(loaded)                                             # and it lays out


def test_a_gear_the_file_states_is_its_own(tmp_path):
    """The keys the design's own file writes are never derived: a gear that then prints thinner
    than the wall is built as stated (its tip checks fail, gear.tooth_tip), not refused."""
    loaded = load(_file(tmp_path, "process:\n  min_wall: 0.9\ntensioner:\n  module: 1.25\n"))
    ts = loaded.design.tensioner
    pair = worm_pair(ts, 0.9)
    assert ts.module == 1.25 and [f for f, _ in pair.wall_problems(0.9)] == ["module"]
    assert not pair.refusals(ts.friction_coefficient)
    design_plan(loaded)                                             # and it lays out
    # a module stated that prints: the worm the file leaves to hwgen is derived for it
    loaded = load(_file(tmp_path, "process:\n  min_wall: 0.9\ntensioner:\n  module: 1.5\n"))
    ts = loaded.design.tensioner
    assert ts.module == 1.5 and not worm_pair(ts, 0.9).problems(ts.friction_coefficient, 0.9)


def test_a_wall_no_gear_prints_with_keeps_the_gear_and_names_a_wall_that_works(tmp_path):
    """No gear within the schema prints with 2.5 mm walls: the base's gear is built (its tip checks
    fail) and the warning names the wall with which hwgen derives one that prints."""
    loaded = load(_file(tmp_path, "process:\n  min_wall: 2.5\n"))
    ts, proto = loaded.design.tensioner, load(BASE).design.tensioner
    assert _pair(ts) == _pair(proto)
    note = next(w for w in loaded.warnings if "no worm gear" in w)
    works = float(re.search(r"process.min_wall ([0-9.]+) mm or less", note)[1])
    assert works < 2.5
    assert load(_file(tmp_path, f"process:\n  min_wall: {works}\n")).design.tensioner.module > 1.25


def test_a_gear_that_prints_is_kept():
    """The prototype states its gear and it prints: nothing is derived (its files stay the same)."""
    d = load(BASE).design
    assert follow_process(d.tensioner, d.process.min_wall, set(GEAR_KEYS)).values == {}


# ---------------------------------------------------------------- one way from a document to a design

def _pair(ts) -> tuple:
    return tuple(getattr(ts, k) for k in GEAR_KEYS)


def _laid_out_pair(plan) -> tuple:
    p = plan.tensioner_layout.pair
    return p.module, p.worm_pitch_diameter, p.worm_length, p.starts


def test_a_sweeps_variant_gets_the_gear_its_build_gets(tmp_path):
    """A sweep over an FDM lab's file: each variant is the design a build of the same document
    makes, the gear derived where the file (or the variant) leaves it to hwgen."""
    from hwgen.sweep import spec as sweep_spec
    lab = _file(tmp_path, "process:\n  min_wall: 0.9\n")
    built = load(lab).design.tensioner
    (tmp_path / "s.yaml").write_text(f"sweep: s\nbase: {lab}\nlevel: lengths\naxes:\n"
                                     "  - path: tensioner.module\n    values: [null, 1.5]\n")
    loaded = sweep_spec.load(tmp_path / "s.yaml")
    # no module set: the base's file leaves the gear to hwgen, as in its build
    same = sweep_spec.resolve(loaded.base, (), sweep_spec.Variant(0, ()))
    assert same.design is not None and _pair(same.design.tensioner) == _pair(built) != _pair(load(BASE).design.tensioner)
    # the module the variant sets is its own; the worm it leaves is derived for it, as a file saying so builds
    own = sweep_spec.resolve(loaded.base, ("tensioner.module",), sweep_spec.Variant(1, (1.5,)))
    stated = load(_file(tmp_path, "process:\n  min_wall: 0.9\ntensioner:\n  module: 1.5\n")).design.tensioner
    assert own.design is not None and _pair(own.design.tensioner) == _pair(stated)


def test_a_tried_fix_gets_the_gear_its_build_gets(tmp_path):
    """A tried fix's trial of an FDM lab's file is planned with the gear a build of the changed file
    derives (a thicker wall still: the gear a build of it derives), not the base's."""
    from hwgen.tried.trial import Trial
    loaded = load(_file(tmp_path, "process:\n  min_wall: 0.9\n"))
    trial = Trial(loaded, design_plan(loaded), {"checks": []}, {})
    plan = trial.plan_with({"process.min_wall": 1.0})
    changed = load(_file(tmp_path, "process:\n  min_wall: 1.0\n")).design.tensioner
    assert plan is not None and _laid_out_pair(plan) == _pair(changed)
    assert _pair(changed) != _pair(load(BASE).design.tensioner)           # the base gear would not print
