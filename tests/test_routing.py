"""Routing math: eq. (3) sampled at the stations against the paper's Table II."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from hwgen.model.plan import make_plan
from hwgen.errors import InputError
from hwgen.pipeline import load
from hwgen.model.routing import tendon_paths

from .conftest import PARAMS


def test_eq3_functions_reproduce_table2_to_its_rounding():
    """C1 and H of Table II are eq. (3) rounded to 0.1 mm; C2 is not (19.4 typed for 17.68)."""
    table = {p.name: p for p in tendon_paths(load(PARAMS / "paper-table2.yaml").design)}
    fn = {p.name: p for p in tendon_paths(load(PARAMS / "prototype.yaml").design)}
    for name in ("C1", "H"):
        assert np.abs(table[name].points - fn[name].points).max() < 0.1
    dev = np.abs(table["C2"].points - fn["C2"].points).max()
    assert dev == pytest.approx(19.4 - 25 * np.cos(np.pi / 4), abs=1e-9)
    # the actuating pair is straight at z = ±30 everywhere
    assert np.allclose(fn["A1"].points, [0, 30]) and np.allclose(fn["A2"].points, [0, -30])


def test_helix_stays_on_its_circle_and_turns_one_and_a_half_times():
    h = next(p for p in tendon_paths(load(PARAMS / "prototype.yaml").design) if p.name == "H")
    assert np.allclose(np.hypot(*h.points.T), 25)
    ang = np.unwrap(np.arctan2(h.points[:, 0], h.points[:, 1]))
    assert ang[-1] - ang[0] == pytest.approx(3 * np.pi)


def test_explicit_stations_are_used_and_checked(tmp_path):
    doc = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
    st = [0, 15, 40, 67.5, 90, 112.5, 135, 157.5, 180, 202.5, 225, 250, 270]
    del doc["disks"]["spacing"]
    doc["disks"]["stations"] = st
    f = tmp_path / "st.yaml"
    f.write_text(yaml.safe_dump(doc))
    p = make_plan(load(f).design)
    assert [d.y for d in p.disks] == st
    c1 = next(t for t in p.paths if t.name == "C1")
    assert np.allclose(c1.points[:, 1], 25 * np.cos(np.pi * np.array(st) / 270))
    doc["disks"]["stations"] = st[:-1] + [260]
    f.write_text(yaml.safe_dump(doc))
    with pytest.raises(InputError) as e:
        load(f)
    assert e.value.path == "disks.stations"


def test_shared_and_overlapping_eyelets_are_reported(tmp_path):
    doc = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
    # a second straight tendon 0.5 mm from A1: the holes overlap
    doc["tendons"].append({"name": "B", "channel": "A", "routing": {"function": {"kind": "straight", "z0": 29.5}}})
    f = tmp_path / "ov.yaml"
    f.write_text(yaml.safe_dump(doc))
    merges = make_plan(load(f).design).merges
    assert {m.station for m in merges if m.kind == "overlap" and set(m.tendons) == {"A1", "B"}} == set(range(13))
