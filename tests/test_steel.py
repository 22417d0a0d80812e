"""The bought metal the robot carries (hwgen.model.steel): each piece's mass from its sizes, where the
layout puts it, and its weight in the statics. No build (the bill of materials' own lines are
compared with the pieces on a build in tests/test_sim.py)."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from hwgen import params
from hwgen.model import stiffness, steel
from hwgen.model.plan import make_plan

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def plan():
    return make_plan(params.read(ROOT / "params" / "prototype.yaml").design)


def test_a_dowel_weighs_its_steel_cylinder_and_a_nut_its_hexagon_less_the_thread():
    rho = steel.densities()["hardened steel"] * 1e-3
    assert steel.volume(steel.DOWEL, "", 12.0, 3.0) * rho == pytest.approx(rho * math.pi * 1.5 ** 2 * 12.0)
    d2 = 3.0 - 0.649519 * 0.5                                     # ISO 724 pitch diameter of M3
    nut = (math.sqrt(3) / 2 * 5.5 ** 2 - math.pi * d2 ** 2 / 4) * 2.4
    assert steel.volume(steel.NUT_ITEM, "M3") == pytest.approx(nut)
    # a longer screw of the same head weighs more by its extra thread alone
    per_mm = steel.volume(steel.SHCS, "M3", 11.0) - steel.volume(steel.SHCS, "M3", 10.0)
    assert per_mm == pytest.approx(math.pi * d2 ** 2 / 4)


def test_the_prototypes_tip_carries_its_dowels_screws_and_nuts(plan):
    """Per channel three dowels and per clamp plate a screw and a nut; four tip screws with nuts; two
    set screws with nuts: 10 to 20 g of metal, the issue's ≈ 15 g."""
    pieces = steel.tip_pieces(plan)
    bill = steel.bill(pieces)
    lay = plan.tensioner_layout
    clamps = sum(len(u.clamps) for u in lay.units)
    assert sum(n for (item, _), n in bill.items() if item == steel.DOWEL) == 3 * len(lay.units)
    assert sum(n for (item, _), n in bill.items() if item == steel.BUTTON) == clamps
    assert sum(n for (item, _), n in bill.items() if item == steel.SHCS) == len(plan.disks[-1].mount_holes)
    assert sum(n for (item, _), n in bill.items() if item == steel.SET) == 2
    assert bill[(steel.NUT_ITEM, "M3")] == len(plan.disks[-1].mount_holes) + 2
    m, c, inertia = steel.total(pieces)
    assert 10.0 < m < 20.0
    assert np.all(np.linalg.eigvalsh(inertia) > 0)


def test_every_piece_sits_in_the_tensioner_beyond_the_tip_disks_inner_face(plan):
    """Where the layout puts them: beyond the tip disk's inner face, within the housing's reach
    across and along the robot, never on the base."""
    tip = plan.disks[-1]
    lay = plan.tensioner_layout
    ends = np.array([[*m.dims[0:2]] for m in lay.members if m.kind == "box"]).ravel()
    reach_x = float(np.abs(ends).max())
    for p in steel.tip_pieces(plan):
        x, y, z = p.centre_mm
        assert y > tip.y - tip.thickness / 2 - p.length_mm, p
        assert abs(x) <= reach_x and abs(z) < 80.0, p


def test_the_statics_carry_the_metal_at_its_centre(plan, monkeypatch):
    """describe(): the tip assembly is heavier by the metal's mass, its centre of mass moved toward
    the metal's; the robot sags further."""
    with_metal = stiffness.describe(plan)
    m_b, c_b, _ = steel.total(steel.tip_pieces(plan))
    monkeypatch.setattr(steel, "tip_pieces", lambda plan: ())
    without = stiffness.describe(plan)
    a, b = with_metal.masses["tip_assembly"], without.masses["tip_assembly"]
    assert a["mass_g"] == pytest.approx(b["mass_g"] + m_b)
    L = plan.backbone.length
    moment = a["mass_g"] * (a["a_mm"] + L)
    assert moment == pytest.approx(b["mass_g"] * (b["a_mm"] + L) + m_b * c_b[1])
    assert a["bought_metal_g"] == pytest.approx(m_b) and b["bought_metal_g"] == 0.0
    assert with_metal.robot.tip_mass > without.robot.tip_mass


def test_a_design_without_a_tensioner_layout_carries_no_metal(plan):
    assert steel.tip_pieces(dataclasses.replace(plan, tensioner_layout=None)) == ()
