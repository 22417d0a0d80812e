"""Names and extents that survive into the programs people open the files in: FreeCAD shows
each of assembly.step's instances under its own part's name (identical parts share one
geometry), and the strip's DXF template carries its drawing's extents."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from hwgen.cad.manifest import Manifest, manifest_parts
from tests import clients
from tests.conftest import PARAMS


def test_dxf_extents_are_the_drawing(tmp_path):
    """$EXTMIN/$EXTMAX (header and modelspace, as read back) enclose exactly the outline, the disk
    lines and the holes, measured here from the entities in the file."""
    import ezdxf
    from hwgen.cad.export import write_backbone_dxf
    from hwgen.pipeline import design_plan, load

    plan = design_plan(load(PARAMS / "prototype.yaml"))
    path = tmp_path / "t.dxf"
    write_backbone_dxf(plan.backbone, plan.stations, path)
    doc = ezdxf.readfile(path)
    msp = doc.modelspace()
    pts = [(p[0], p[1]) for e in msp.query("LWPOLYLINE") for p in e.get_points()]
    pts += [(v.x, v.y) for e in msp.query("LINE") for v in (e.dxf.start, e.dxf.end)]
    for c in msp.query("CIRCLE"):
        pts += [(c.dxf.center.x - c.dxf.radius, c.dxf.center.y - c.dxf.radius),
                (c.dxf.center.x + c.dxf.radius, c.dxf.center.y + c.dxf.radius)]
    lo, hi = np.min(pts, axis=0), np.max(pts, axis=0)
    for extmin, extmax in ((doc.header["$EXTMIN"], doc.header["$EXTMAX"]), (msp.dxf.extmin, msp.dxf.extmax)):
        assert all(math.isfinite(v) for v in (*extmin, *extmax))
        assert np.allclose(tuple(extmin)[:2], lo, atol=1e-9) and np.allclose(tuple(extmax)[:2], hi, atol=1e-9)
    # the strip's own outline is inside: height across x, the length along y
    assert hi[0] - lo[0] == pytest.approx(plan.backbone.height)
    assert not doc.audit().has_errors


def test_freecad_shows_every_instance_under_its_own_name(built, tmp_path):
    folder = built("prototype")
    manifest = json.loads((folder / "manifest.json").read_text())
    names = [p["name"] for p in manifest["parts"]]
    labels = clients.freecad_labels(folder / "assembly.step", tmp_path)
    assert sorted(labels) == sorted(names)
    # identical parts still share one geometry: fewer products than instances
    text = (folder / "assembly.step").read_text(errors="replace")
    products = text.count("= PRODUCT(") - 1                     # less the assembly's own
    shared = {p.files["stl"].sha256 for p in manifest_parts(Manifest.of(manifest))}      # identical parts, identical meshes
    assert products == len(shared) < len(names)
