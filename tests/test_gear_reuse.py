"""The gear checks measure each distinct worm and wheel once, and remember it under what it depends
on (the files' bytes, the wheel's pose to its worm, the design values it reads), not where the
robot has the pair: measured on the prototype's files."""
from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

from hwgen import cache
from hwgen.checks import gear_mesh
from hwgen.checks.gear_mesh import Meshing, distinct_pairs, gear_checks, gear_pairs, measure_pair, toward
from hwgen.model.plan import make_plan
from hwgen.pipeline import load

from .conftest import PARAMS

SHARED = ("gear.center_distance", "gear.shaft_angle", "gear.teeth", "gear.starts", "gear.interference", "gear.gap")


@pytest.fixture(scope="module")
def proto(built):
    folder = built("prototype")
    man = json.loads((folder / "manifest.json").read_text())
    return folder, man, make_plan(load(PARAMS / "prototype.yaml").design)


@pytest.fixture
def counted(monkeypatch):
    """How often a pair's meshes are read and fitted, and a flank turned into contact."""
    calls = {"measure_pair": 0, "contact": 0}
    real_pair, real_contact = gear_mesh.measure_pair, Meshing.contact

    def pair(*a, **k):
        calls["measure_pair"] += 1
        return real_pair(*a, **k)

    def contact(self, *a, **k):
        calls["contact"] += 1
        return real_contact(self, *a, **k)
    monkeypatch.setattr(gear_mesh, "measure_pair", pair)
    monkeypatch.setattr(Meshing, "contact", contact)
    return calls


def _stl_sha(part):
    return part.files["stl"].sha256


def _by_channel(checks):
    out = {}
    for c in checks:
        out.setdefault(c.where.get("channel"), {})[c.id] = c
    return out


def _rigid(angle: float, axis, shift) -> np.ndarray:
    """4×4: a turn by ``angle`` about ``axis`` through the origin, then a shift (mm)."""
    d = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    k = np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])
    m = np.eye(4)
    m[:3, :3] = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)
    m[:3, 3] = shift
    return m


def test_channels_with_the_same_files_and_pose_share_one_measurement(proto, counted, tmp_path):
    """The prototype's C1, C2 and H have one worm file and one wheel file between them, posed alike:
    measured once, on C1's files, and their checks say so; A's wheel is a file of its own: measured
    on its own. What C2 is given is what C2's own files give where the robot has them (the claim
    that the measurement does not move with the pair), to 1e-9 of itself."""
    folder, man, p = proto
    pairs = gear_pairs(man["parts"])
    wheels = {c: _stl_sha(pw["wheel"]) for c, pw in pairs.items()}
    worms = {c: _stl_sha(pw["worm"]) for c, pw in pairs.items()}
    assert wheels["C1"] == wheels["C2"] == wheels["H"] != wheels["A"] and len(set(worms.values())) == 1
    groups = distinct_pairs(folder, pairs)
    assert sorted(d.channels for d in groups) == [["A"], ["C1", "C2", "H"]]
    with cache.using(cache.Store(tmp_path / "cache")):
        checks = gear_checks(folder, man["parts"], p)
    assert counted == {"measure_pair": 2, "contact": 2}      # two distinct pairs; both flanks of one
    by = _by_channel(checks)
    for ch in ("C2", "H"):
        for cid in SHARED:
            c = by[ch][cid]
            assert c.where == {"channel": ch, "measured_on": "C1"}
            assert c.message.startswith(f"channel {ch} (measured on channel C1's files, which equal {ch}'s up to a "
                                        f"rigid motion): ")
            assert c.measured == by["C1"][cid].measured and c.passed
    for ch in ("A", "C1"):
        assert all(by[ch][cid].where == {"channel": ch} and by[ch][cid].message.startswith(f"channel {ch}: ")
                   for cid in SHARED)
    # C2 measured on its own files where the robot has them: the same numbers
    own = measure_pair(folder, pairs["C2"]["worm"], pairs["C2"]["wheel"])
    vol, gap = own["meshing"].sweep(gear_mesh.SWEEP_STEPS, p.require_tensioner_layout().pair.center_offset
                                    + gear_mesh.GAP_SEARCH_MM)
    c2 = by["C2"]
    assert own["center_distance"] == pytest.approx(c2["gear.center_distance"].measured, rel=1e-9)
    assert own["shaft_angle"] == pytest.approx(c2["gear.shaft_angle"].measured, rel=1e-9)
    assert gap == pytest.approx(c2["gear.gap"].measured, rel=1e-9)
    assert vol == pytest.approx(c2["gear.interference"].measured, rel=1e-9, abs=1e-9)


def test_moving_every_pair_by_a_rigid_motion_measures_nothing_again(proto, counted, tmp_path):
    """Each channel's worm and wheel moved together by a rigid motion of its own (the files
    untouched, as when an edit of the routing moves the tensioner's units): every measurement comes
    from the cache, and the checks are the same; measured afresh, without a cache, they are the same
    again, to the last bit (a report does not depend on what the cache held)."""
    folder, man, p = proto
    store = cache.Store(tmp_path / "cache")
    with cache.using(store):
        before = gear_checks(folder, man["parts"], p)
    moved = copy.deepcopy(man)
    motions = {"A": _rigid(0.7, (1, 2, 3), (5.0, -40.0, 12.5)), "C1": _rigid(-2.1, (0, 0, 1), (0.3, 0.0, -7.0)),
               "C2": _rigid(math.pi, (1, 0, 0), (-100.0, 25.0, 0.0)), "H": _rigid(0.01, (3, -1, 0.5), (0.0, 0.5, 0.0))}
    for q in moved["parts"]:
        if q.get("role") in ("tensioner_worm", "tensioner_wheel"):
            q["placement"] = (motions[q["channel"]] @ np.asarray(q["placement"])).tolist()
    assert [q["placement"] for q in moved["parts"]] != [q["placement"] for q in man["parts"]]
    n = dict(counted)
    with cache.using(store):
        after = gear_checks(folder, moved["parts"], p)
    assert counted == n                        # nothing measured
    assert [c.to_json() for c in after] == [c.to_json() for c in before]
    with cache.using(cache.Store(None)):
        fresh = gear_checks(folder, moved["parts"], p)
    assert counted["measure_pair"] == n["measure_pair"] + 2
    assert [c.to_json() for c in fresh] == [c.to_json() for c in before]


def test_a_wheel_moved_toward_its_worm_is_measured_again(proto, counted, tmp_path):
    """C2's wheel 0.1 mm toward its worm (the flanks back at the generating distance): C2 is a
    distinct pair now, measured on its own files, and its gap fails; C1 and H keep the measurement
    they share, from the cache; A's is unchanged."""
    folder, man, p = proto
    store = cache.Store(tmp_path / "cache")
    with cache.using(store):
        before = _by_channel(gear_checks(folder, man["parts"], p))
    moved = copy.deepcopy(man)
    pairs = gear_pairs(moved["parts"])
    (entry,) = [e for e in moved["parts"] if e["name"] == pairs["C2"]["wheel"].name]
    entry["placement"] = toward(pairs["C2"]["wheel"], pairs["C2"]["worm"], 0.1).tolist()
    n = dict(counted)
    with cache.using(store):
        after = _by_channel(gear_checks(folder, moved["parts"], p))
    assert counted == {"measure_pair": n["measure_pair"] + 1, "contact": n["contact"]}
    c2 = after["C2"]
    assert all(c2[cid].where == {"channel": "C2"} for cid in SHARED)
    assert not c2["gear.center_distance"].passed and not c2["gear.gap"].passed
    assert c2["gear.gap"].measured < 0.005 < before["C2"]["gear.gap"].measured
    assert c2["gear.center_distance"].measured == pytest.approx(before["C2"]["gear.center_distance"].measured - 0.1,
                                                                abs=0.002)
    assert after["H"]["gear.gap"].where == {"channel": "H", "measured_on": "C1"}
    for ch in ("A", "C1", "H"):
        assert {k: c.to_json() for k, c in after[ch].items()} == {k: c.to_json() for k, c in before[ch].items()}


def test_the_gear_process_is_started_only_for_what_is_not_remembered(proto, counted, tmp_path):
    """A build's work ahead asks whether every gear measurement is in the store before it starts a
    process to make them: asking measures nothing; with the measurements kept (also after the
    channels moved, as a routing edit moves them) the answer is yes, with an empty store no."""
    from hwgen.engine.concurrency import gears_remembered
    folder, man, p = proto
    store = cache.Store(tmp_path / "cache")
    with cache.using(store):
        assert not gears_remembered(folder, man["parts"], p)
    with cache.using(cache.Store(None)):
        assert not gears_remembered(folder, man["parts"], p)
    assert counted == {"measure_pair": 0, "contact": 0}
    with cache.using(store):
        gear_checks(folder, man["parts"], p)
    moved = copy.deepcopy(man)
    for q in moved["parts"]:
        if q.get("role") in ("tensioner_worm", "tensioner_wheel") and q["channel"] == "C2":
            q["placement"] = (_rigid(0.3, (0, 1, 0), (12.0, 0.0, -3.0)) @ np.asarray(q["placement"])).tolist()
    n = dict(counted)
    with cache.using(store):
        assert gears_remembered(folder, man["parts"], p)
        assert gears_remembered(folder, moved["parts"], p)
    assert counted == n
