"""eyelet.shared_sliding: a driven tendon does not slide through one opening with another tendon.

The prototype shares no driven eyelet; its helix at 30 mm, four half turns and phase 0 passes
through A1's and A2's eyelets at disks 3, 6, 9 and the tip (the stiffness tune's old best did the
same): the sweep's lengths level fails it, and measured from exported disks the check fails,
naming both tendons and the disk."""
from __future__ import annotations

import copy

import pytest
import yaml

from hwgen.model.plan import make_plan
from hwgen.params import Design
from hwgen.sweep import lengths

from .conftest import PARAMS


def _shared(severity: str | None = None) -> Design:
    doc = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
    doc = copy.deepcopy(doc)
    doc["tendons"][3]["routing"]["function"].update(a=30, k=4, phase_deg=0)
    if severity:
        doc["check"]["shared_sliding"] = severity
    return Design.model_validate(doc)


def test_the_lengths_level_fails_a_helix_through_the_actuating_eyelets():
    proto = Design.model_validate(yaml.safe_load((PARAMS / "prototype.yaml").read_text()))
    rows = lengths.evaluate([proto, _shared(), _shared("warning")])
    assert rows[0]["shared_sliding"] == []
    assert "eyelet.shared_sliding" not in {f.id for f in lengths.failures(rows[0])}
    assert rows[1]["shared_sliding"] == ["A2+H@3", "A1+H@6", "A2+H@9", "A1+H@12"]
    (f,) = [f for f in lengths.failures(rows[1]) if f.id == "eyelet.shared_sliding"]
    assert f.severity == "error" and f.fails and lengths.verdict(rows[1])[0] == "fail"
    # stated as a warning: still listed, the verdict no longer fails on it
    (w,) = [f for f in lengths.failures(rows[2]) if f.id == "eyelet.shared_sliding"]
    assert w.severity == "warning" and not w.fails
    assert "shared_sliding" not in lengths.verdict(rows[2])[1]


@pytest.mark.slow
def test_the_check_reads_a_shared_opening_from_the_exported_disks(tmp_path, built):
    """Disks 3 (H in A2's eyelet) and 4 (apart) built and measured from their STLs; the seats of the
    base disk, where lines end, do not count. The tried fix's radius clears A's eyelets."""
    import json

    import trimesh

    from hwgen.cad.disk import build_disk
    from hwgen.cad.export import write_stl
    from hwgen.cad.manifest import design_report
    from hwgen.checks.eyelets import locate_eyelets, measure_disk
    from hwgen.checks.sliding import sliding_checks

    plan = make_plan(_shared())
    report = design_report(plan)
    disks = []
    for station in (3, 4):
        part = build_disk(plan.disks[station])
        stl = tmp_path / f"{part.name}.stl"
        write_stl(part.solid, stl)
        disks.append(measure_disk(stl, part.placement, part.name, station, trimesh.load(stl)))
    emap, _ = locate_eyelets(disks, report, None, plan.check.position_tol_mm)
    checks = sliding_checks(emap, report, plan.tensioner.actuating_channel, plan.process.min_wall, "error")
    (c,) = checks
    assert not c.passed and c.severity == "error"
    assert c.where["station"] == 3 and c.where["tendons"] == ["A2", "H"]
    assert "A2" in c.message and "H" in c.message and "disk_03" in c.message
    assert "r ≤" in c.fix and "route them into one shared eyelet" not in c.fix
    r_fix = float(c.fix.split("r ≤ ")[1].split(" mm")[0])
    assert r_fix < 30 - plan.process.min_wall
    # the prototype, as the session built it: no driven tendon shares an opening
    rep = json.loads((built("prototype") / "report.json").read_text())
    (p,) = [c for c in rep["checks"] if c["id"] == "eyelet.shared_sliding"]
    assert p["passed"]


def test_no_fix_routes_a_driven_tendon_into_a_shared_eyelet():
    """tendon.clearance's and eyelet.wall.eyelet's fixes offer one shared eyelet only to two tendons
    neither of which the drive slides (eyelet.shared_sliding fails the other case)."""
    from hwgen.checks.clearances import _wall_fix, clearance_fix

    driven = {"A1", "A2"}
    assert "share one eyelet" in clearance_fix("C1", "H", 0.2, 4, driven)
    assert "share one eyelet" not in clearance_fix("A1", "H", 0.2, 4, driven)
    assert "shared eyelet" in _wall_fix("eyelet.wall.eyelet", "eyelet C1 and eyelet H", 0.2, 4, 50.0, driven)
    assert "shared eyelet" not in _wall_fix("eyelet.wall.eyelet", "eyelet A2 and eyelet H", 0.2, 4, 50.0, driven)
