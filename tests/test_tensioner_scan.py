"""The tensioner layout's widening scan (placement._Scan) judges many candidate wheel-axis |x| at
once; these tests hold it to the rule it stands for, one frame at a time: the same verdict at
every x_u, the same x_u and frame chosen, the same closest miss when none fits, bit for bit."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from hwgen.model.plan import make_plan
from hwgen.model.tensioner_layout import placement
from hwgen.model.tensioner_layout.arrangement import (GEAR_RULES, arrangements, clamp_blockers, strip_clamp,
                                                      tip_eyelets, turned_over, unit_stack)
from hwgen.model.tensioner_layout.placement import (UNIT_GAP, X_COARSE, X_SEARCH, X_STEP, Infeasible, _clearance,
                                                    _frame, _Scan, _tangent_point, _tangent_points, _widen,
                                                    place_units, x_floor)
from hwgen.model.tensioner_layout.sizes import Sizes
from hwgen.params import Design

from .robots import BASE


def _doc(**tensioner) -> dict:
    doc = copy.deepcopy(BASE)
    doc["tensioner"].update(tensioner)
    return doc


# the prototype (every arrangement fits somewhere), and with a 3 mm tendon clearance (none does)
DESIGNS = {"prototype": _doc(), "clearance 3 mm": _doc(tendon_clearance=3.0)}


def _cases(doc: dict, count: int = 6):
    """The first ``count`` arrangements the search would try (either way up, two gear rules), each
    with its units stacked along y: (arrangement, centres y, stacks, eyelets, winding, clamp, sizes)."""
    design = Design.model_validate(doc)
    plan = make_plan(design)
    sz = Sizes.of(design, plan.disks[-1])
    ts = design.tensioner
    out = []
    for turn in (1, -1):
        eyelets = turned_over(tip_eyelets(plan.paths, ts.channels), turn)
        for rule in GEAR_RULES[:2]:
            stacks = {c: unit_stack([z for _, _, z in eyelets[c]], sz.pair, rule) for c in ts.channels}
            clamp = strip_clamp(sz, 1)
            if clamp_blockers(eyelets, clamp, sz):
                clamp = None
            for arr in list(arrangements(turn, 1, rule, eyelets, stacks, clamp))[:2]:
                out.append((arr, place_units(arr, stacks, clamp, sz, 0.0), stacks, eyelets, ts.winding, clamp, sz))
    return out[:count]


def _fits(x_u, arr, centers_y, stacks, eyelets, winding, clamp, sz):
    """The rule at one x_u, one frame: (fits, frame, its nearest miss)."""
    fr = _frame(x_u, arr, centers_y, stacks, eyelets, winding, sz)
    fail = _clearance(fr, clamp, sz)
    good = (fail.clearance >= 0 and fr.post[0] >= UNIT_GAP / 2
            and (clamp is None or fr.spine[0] >= clamp[1] + sz.clamp_room))
    return good, fr, fail


def _one_at_a_time(arr, centers_y, stacks, eyelets, winding, clamp, sz):
    """The search's widening as a loop over single frames: the coarse steps from x_floor, then the
    fine ones below the first that fits; ("fit", x_u, frame) or ("miss", the largest nearest miss)."""
    x_min = x_floor(eyelets, sz)
    best = None
    x = x_min
    while x < x_min + X_SEARCH:
        good, fr, fail = _fits(x, arr, centers_y, stacks, eyelets, winding, clamp, sz)
        if good:
            for xf in np.arange(max(x_min, x - X_COARSE), x, X_STEP):
                g2, fr2, _ = _fits(float(xf), arr, centers_y, stacks, eyelets, winding, clamp, sz)
                if g2:
                    return "fit", float(xf), fr2
            return "fit", x, fr
        if best is None or fail.clearance > best.clearance:
            best = fail
        x += X_COARSE
    return "miss", best


def _same_frame(a, b) -> bool:
    return (a.x_u == b.x_u and a.spine == b.spine and a.post == b.post and a.worm_x == b.worm_x
            and a.near_end == b.near_end and np.array_equal(a.worm_file_to_mesh, b.worm_file_to_mesh)
            and a.units == b.units and a.runs == b.runs)


@pytest.mark.parametrize("tolerance", [placement.SCAN_TOLERANCE, 1e9], ids=["as shipped", "everything judged again"])
@pytest.mark.parametrize("design", list(DESIGNS))
def test_the_scan_chooses_what_one_frame_at_a_time_chooses(design, tolerance, monkeypatch):
    """The x_u chosen and its frame, or the closest miss, equal the single-frame loop's exactly;
    with a tolerance so wide that every candidate is judged again, too (that path is exact)."""
    monkeypatch.setattr(placement, "SCAN_TOLERANCE", tolerance)
    cases = _cases(DESIGNS[design])
    outcomes = set()
    for case in cases:
        want = _one_at_a_time(*case)
        try:
            x_u, fr = _widen(*case)
            got = ("fit", x_u, fr)
        except Infeasible as e:
            got = ("miss", e.failure)
        outcomes.add(got[0])
        assert got[0] == want[0], (case[0], got, want)
        if got[0] == "fit":
            assert got[1] == want[1] and _same_frame(got[2], want[2]), (case[0], got[1], want[1])
        else:
            assert got[1] == want[1], (case[0], got[1], want[1])
    assert outcomes == ({"fit"} if design == "prototype" else {"miss"})


@pytest.mark.parametrize("design", list(DESIGNS))
def test_the_scans_verdict_at_every_x_is_the_single_frames(design):
    """Every half millimetre over the search's span: fits or not as one frame says, and the
    clearances the scan works out again (the runs as _frame lays them out) are the frame's to the bit."""
    for case in _cases(DESIGNS[design], count=3):
        arr, centers_y, stacks, eyelets, winding, clamp, sz = case
        x_min = x_floor(eyelets, sz)
        xs = np.arange(x_min, x_min + X_SEARCH, X_STEP)
        scan = _Scan(_frame(x_min, arr, centers_y, stacks, eyelets, winding, sz), clamp, sz)
        single = [_fits(float(x), *case) for x in xs]
        assert scan.good(xs).tolist() == [g for g, _, _ in single]
        assert scan._nearest(xs, exact=True).clearance.tolist() == [f.clearance for _, _, f in single]
        # the numpy tangent points differ from the exact ones by rounding alone
        approx = scan._nearest(xs).clearance
        assert np.max(np.abs(approx - [f.clearance for _, _, f in single])) < 1e-9


def test_tangent_points_over_arrays_match_one_at_a_time():
    rng = np.random.default_rng(7)
    p = rng.uniform(-40, 40, (200, 2))
    c = p + np.column_stack([rng.uniform(-60, 60, 200), rng.uniform(8, 90, 200)])   # centres beyond the eyelets
    toward = rng.choice([-1.0, 1.0], 200)
    got = _tangent_points(p, c, 3.2, toward)
    want = np.array([_tangent_point(p[i], c[i], 3.2, int(toward[i])) for i in range(200)])
    assert np.max(np.abs(got - want)) < 1e-9
