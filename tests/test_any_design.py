"""Any design the schema accepts is planned, or refused as a robot that cannot be described: never a
crash. Hypothesis draws whole design documents over the schema's own bounds (hwgen/params.py) and
each goes through what every command starts with: the schema and the checks across fields, the
feasibility rules, the plan (routing, eyelets, hubs, seats, screws, mount, jig, tensioner layout)
and the plan's own rules. No CAD. An InputError or a DesignError (exit 2, one line naming the field)
is a clean refusal; any other exception is a bug in the model.

The draws mix two scales: every number anywhere in its schema range (tiny, huge, at its bounds),
and numbers in proportion to one another (a strip inside its disks, tendons between the strip and
the rim), so that most designs get past the early refusals and through the whole plan.

Every division of the model is sound: a numpy RuntimeWarning (0/0, an overflow) is an error here.

HWGEN_HYPOTHESIS_EXAMPLES sets how many designs the fast tier draws (FAST_EXAMPLES, about 6 s of
CPU); the slow tier adds a run of SLOW_EXAMPLES more, from another seed (HWGEN_ANY_DESIGN_EXAMPLES:
1 500 in `make test`, about 40 s of CPU; `make stability` runs the same stream to 5 000).
"""
from __future__ import annotations

import math
import os

import pytest
from hypothesis import HealthCheck, event, given, seed, settings
from hypothesis import strategies as st

from hwgen.errors import DesignError, InputError
from hwgen.model import feasibility
from hwgen.model import kinematics as kin
from hwgen.model.materials import table as materials
from hwgen.model.plan import make_plan
from hwgen.params import MAX_MM, validate

FAST_EXAMPLES = int(os.environ.get("HWGEN_HYPOTHESIS_EXAMPLES", "200"))
SLOW_EXAMPLES = int(os.environ.get("HWGEN_ANY_DESIGN_EXAMPLES", "1500"))
FILE = "hypothesis.yaml"

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")


class _Numbers:
    """Numbers for one design, each in its schema range [lo, hi]: in the ``typical`` range a lab
    writes (clipped to the schema's), but anywhere in the schema's range for the ``wild`` ones
    (every one, or only the one drawn in that place, or none)."""

    def __init__(self, draw, wild):
        self.draw, self.wild, self.n = draw, wild, 0

    def __call__(self, lo: float, hi: float, typical: tuple[float, float], open_lo: bool = False) -> float:
        self.n += 1
        if self.wild is True or self.wild == self.n:
            return self.draw(st.floats(lo, hi, exclude_min=open_lo, allow_nan=False, allow_infinity=False))
        a, b = max(typical[0], lo), min(typical[1], hi)
        a, b = min(a, b), max(a, b)
        return self.draw(st.floats(a, b, exclude_min=open_lo and a <= lo, allow_nan=False, allow_infinity=False)
                         if b > a else st.just(b))

    def length(self, typical: tuple[float, float]) -> float:
        return self(0.0, MAX_MM, typical, open_lo=True)

    def coord(self, typical: tuple[float, float]) -> float:
        return self(-MAX_MM, MAX_MM, typical)


def _routing(draw, num: _Numbers, r: tuple[float, float], count: int) -> dict:
    """A tendon's routing: an eq. (3) function or a table of ``count`` rows (rarely one too few or
    many), its eyelets mostly between the strip and the rim (radii ``r``)."""
    kind = draw(st.sampled_from(["straight", "cosine", "helix"]))
    f = {"kind": kind, "a": num.coord(r), "k": num(-1000, 1000, (-5, 5)), "phase_deg": num(-3600, 3600, (-360, 360))}
    ang = draw(st.floats(0, 2 * math.pi))
    rr = num.coord(r)
    if kind == "straight" or draw(st.sampled_from([False] * 3 + [True])):
        f.update(x0=rr * math.sin(ang), z0=rr * math.cos(ang))
    if kind == "cosine":
        f["axis"] = draw(st.sampled_from(["x", "z"]))
    out: dict = {}
    if draw(st.sampled_from([False] * 4 + [True])):
        rows = count + draw(st.sampled_from([0] * 18 + [-1, 1]))
        table = []
        for _ in range(max(rows, 0)):
            a, rad = draw(st.floats(0, 2 * math.pi)), num.coord(r)
            table.append([rad * math.sin(a), rad * math.cos(a)])
        out["table"] = table
        if draw(st.booleans()):
            out["function"] = f
    else:
        out["function"] = f
    if draw(st.sampled_from([False] * 3 + [True])):
        out["mirror"] = True
    return out


@st.composite
def designs(draw) -> dict:
    """A design document as a YAML file would give it."""
    mode = draw(st.sampled_from(["typical", "one wild", "typical", "typical", "one wild", "all wild"]))
    num = _Numbers(draw, True if mode == "all wild" else draw(st.integers(1, 60)) if mode == "one wild" else None)
    od = num.length((5, 150))
    height = num.length((0.05 * od, 0.8 * od))
    thickness = num.length((0.005 * od, 0.04 * od))
    length = num.length((20, 600))
    count = draw(st.sampled_from([None] * 11 + [200])) or draw(st.integers(2, 16))
    if count == 200:
        count = draw(st.integers(2, 200))
    gap = length / (count - 1)
    thick, end = num.length((0.05 * gap, 0.45 * gap)), num.length((0.1 * gap, 0.6 * gap))
    clearance = num(0.0, MAX_MM, (0, 0.3))
    disks: dict = {"count": count, "thickness": thick, "end_thickness": end, "outer_diameter": od,
                   "slot_clearance": clearance}
    layout = draw(st.sampled_from(["none", "spacing", "stations", "stations"]))
    if layout == "spacing":
        disks["spacing"] = length / (count - 1)
    elif layout == "stations":
        gaps = [draw(st.floats(0.3, 1.0)) for _ in range(count - 1)]
        at = [0.0]
        for g in gaps:
            at.append(at[-1] + g / sum(gaps) * length)
        at[-1] = length
        disks["stations"] = at
    disks["eyelets"] = {"axis": draw(st.sampled_from(["bisector", "normal"])),
                        "edge": draw(st.sampled_from(["chamfer", "none"])),
                        "edge_size": num(0.0, MAX_MM, (0, 0.45 * thick)),
                        "sweep_deg": num(0.0, 360.0, (1, 120), open_lo=True)}
    disks["hub"] = {"max_tilt_deg": num(0.0, 10.0, (0.05, 5), open_lo=True), "wall": num.length((0.5, 3)),
                    "glue_port_diameter": num.length((0.5, 3))}
    if draw(st.sampled_from([False] * 4 + [True])):
        disks["hub"]["length"] = num.length((1, 40))
    disks["anchors"] = {"plate": num.length((0.1 * end, 0.49 * end))}
    if draw(st.sampled_from([False] * 7 + [True])):
        disks["tip_mount"] = {"positions": [[num.coord((-od / 2, od / 2)), num.coord((-od / 2, od / 2))]
                                            for _ in range(draw(st.integers(0, 6)))]}
    backbone = {"length": length, "height": height, "thickness": thickness, "extra_tip": num(0.0, MAX_MM, (0, 40))}
    if draw(st.booleans()):
        backbone["extra_base"] = num(0.0, MAX_MM, (0, 50))
    material = draw(st.sampled_from(sorted(materials())))
    process = {"name": "drawn", "technology": materials()[material].technology, "material": material,
               "min_wall": num.length((0.3, 0.8)), "min_hole": num.length((0.3, 1.5)),
               "hole_clearance": num(0.0, MAX_MM, (0, 0.4)), "build_volume": [num.length((50, 300)) for _ in range(3)]}
    term = {"kind": draw(st.sampled_from(["knot", "crimp"])), "diameter": num.length((1, 4))}
    if term["kind"] == "crimp":
        term["length"] = num.length((1, 6))
    r = (thickness / 2 + clearance + 1.5, max(od / 2 - 2.0, thickness / 2 + clearance + 1.5))
    tendons = [{"name": f"T{i}", "channel": f"C{i}", "routing": _routing(draw, num, r, count),
                "pretension_n": num(0.0, 10_000.0, (0, 20))}
               for i in range(draw(st.sampled_from([1, 1, 2, 2, 3, 3, 4] * 2 + [6])))]
    tensioner = {"channels": [t["channel"] for t in tendons], "actuating_channel": tendons[0]["channel"]}
    if draw(st.sampled_from([False] * 7 + [True])):
        tensioner.update(module=num(0.3, 3.0, (0.8, 2)), wheel_teeth=draw(st.integers(6, 120)),
                         worm_pitch_diameter=num(0.0, 40.0, (8, 20), open_lo=True),
                         spool_diameter=num(0.0, 40.0, (6, 20), open_lo=True),
                         face_width=num(0.0, 30.0, (4, 12), open_lo=True))
    base_mount = {"table_clearance": num.length((0.5, 20)),
                  "bolt_pattern": draw(st.sampled_from(["M6_25mm", "quarter20_1in"]))}
    jig = {"clearance": num(0.0, MAX_MM, (0, 0.3)), "wall": num.length((2, 10)), "floor": num.length((2, 10))}
    return {"design": "drawn", "backbone": backbone, "disks": disks,
            "tendon_material": {"name": "line", "diameter": num.length((0.05, 0.3)),
                                "break_load": num.length((5, 200)), "termination": term},
            "process": process, "tensioner": tensioner, "tendons": tendons, "base_mount": base_mount, "jig": jig}


def plan_or_refuse(doc: dict):
    """What every command starts with, without reading a file: the plan, or the refusal."""
    try:
        design = validate(doc, FILE)
        feasibility.check(design, FILE)
        plan = make_plan(design)
        feasibility.check_plan(plan, design)
        plan.require_tensioner_layout()
        return plan
    except (InputError, DesignError) as e:
        return e


def _sound(plan) -> None:
    """What the plan hands the CAD is finite and in order: no NaN the model let through."""
    for d in plan.disks:
        assert math.isfinite(d.thickness) and d.thickness > 0
        assert all(math.isfinite(h.diameter) and h.diameter > 0 for h in d.holes)
        if d.hub is not None:
            assert d.hub.length > 0 and all(a <= b for a, b in d.hub.windows)
    m, j = plan.mount, plan.jig
    assert m.z_table < m.z_foot_top <= m.z_jaw_bottom < m.z_recess < m.z_lower_top < m.z_upper_top
    assert m.y_back < m.y_face and all(math.isfinite(v) for v in (m.z_table, m.y_back))
    assert j.z_floor_bottom <= j.z_floor_top < j.z_top and 0 <= j.x_inner <= j.x_outer
    assert all(p.y0 < p.y1 for p in j.pieces)


SETTINGS = dict(deadline=None, database=None, derandomize=True, print_blob=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@settings(max_examples=FAST_EXAMPLES, **SETTINGS)
@given(designs())
def test_any_design_is_planned_or_refused_never_a_crash(doc):
    out = plan_or_refuse(doc)
    event("planned" if not isinstance(out, Exception) else f"refused at {out.path.split('[')[0]}: {out.message[:25]}")
    if not isinstance(out, Exception):
        _sound(out)


@pytest.mark.slow
@seed(20261128)
@settings(max_examples=SLOW_EXAMPLES, **{**SETTINGS, "derandomize": False})
@given(designs())
def test_many_more_designs_are_planned_or_refused(doc):
    out = plan_or_refuse(doc)
    if not isinstance(out, Exception):
        _sound(out)


def test_the_kinematics_divide_soundly_where_a_draw_finds_nothing_to_divide_by():
    """What the draws met as RuntimeWarnings, at their causes: a strip so short its curvature's square
    overflows (in the series the frames do not use at that curvature); two eyelets a gap apart whose
    square is no double (a segment of no length: no direction, NaN as at the chain's ends), so that
    a disk's rest axis has no segment to follow (the disk's normal)."""
    import numpy as np

    from hwgen.model.plan import _rest_axes
    _, p = kin.frames([0.0, 1e-300], [1e300, 0.0])
    assert np.isfinite(p).all() and p[0, 1, 1] == pytest.approx(np.sin(1.0) * 1e-300, rel=1e-12)
    stations, xz = (0.0, 1e-170), np.zeros((2, 2))
    into, out = kin.segment_directions_local(stations, xz, [0.0])
    assert np.isnan(into).all() and np.isnan(out).all()

    class Design:
        class disks:
            class eyelets:
                axis = "bisector"

    Design.stations = stations
    assert (_rest_axes(Design, type("Path", (), {"points": xz})) == [[0.0, 1.0, 0.0]] * 2).all()
