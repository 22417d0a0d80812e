"""The calibration coupon: each hole and slot is where its label is and as large as its label
says, measured from the coupon's STL; the labels are engraved where coupon.json puts them."""
from __future__ import annotations

import json

import numpy as np
import pytest

from tests.conftest import PARAMS

SIZE_MM = 0.01             # a hole's diameter and a slot's width as measured, against the label's number
PLACE_MM = 0.05            # a feature's centre against where coupon.json puts it


def test_coupon_spec_steps_around_the_design():
    from hwgen.model.coupon import coupon_spec
    from hwgen.pipeline import design_plan, load

    loaded = load(PARAMS / "prototype.yaml")
    spec = coupon_spec(design_plan(loaded), loaded.design)
    c = loaded.design.coupon
    holes = [f for f in spec.features if f.kind == "hole"]
    slots = [f for f in spec.features if f.kind == "slot"]
    assert len(holes) == 2 * c.steps + 1
    assert [f.value for f in holes] == pytest.approx(spec.design_hole + c.hole_step_mm * np.arange(-c.steps, c.steps + 1))
    assert spec.design_clearance == loaded.design.disks.slot_clearance
    assert min(f.value for f in slots) >= 0 and spec.design_clearance in [f.value for f in slots]
    assert all(float(f.label) == pytest.approx(f.value) for f in spec.features)


def _rings(mesh, z):
    """The closed outlines of the section at height z, largest first: (centre, area, size along x and y)."""
    from hwgen.checks.sections import section_loops
    return [((lp.points.min(axis=0) + lp.points.max(axis=0)) / 2, lp.area, np.ptp(lp.points, axis=0))
            for lp in section_loops(mesh, np.eye(4), [0, 0, z], [0, 0, 1], axes=(0, 1))]


@pytest.mark.slow
def test_coupon_features_are_where_their_labels_say(tmp_path):
    import trimesh
    from hwgen.pipeline import coupon, load

    info, folder = coupon(load(PARAMS / "prototype.yaml"), tmp_path)
    assert json.loads((folder / "coupon" / "coupon.json").read_text()) == json.loads(json.dumps(info))
    mesh = trimesh.load_mesh(str(folder / "coupon" / "coupon.stl"))
    assert mesh.is_watertight
    w, h, t = info["size_mm"]
    assert np.allclose(mesh.bounds, [[0, 0, 0], [w, h, t]], atol=1e-3)
    mid = _rings(mesh, t / 2)                    # below the engraving: the plate, its holes and slots
    openings = mid[1:]                           # the largest is the coupon's outline
    assert len(openings) == len(info["features"])
    for f in info["features"]:
        centre, area, size = min(openings, key=lambda r: np.linalg.norm(r[0] - [f["x"], f["y"]]))
        assert np.linalg.norm(centre - [f["x"], f["y"]]) < PLACE_MM, f
        value = float(f["label"])
        if f["kind"] == "hole":
            measured = 2 * np.sqrt(area / np.pi)             # the circle of the same area
            assert measured == pytest.approx(value, abs=SIZE_MM), f
        else:
            across, along = sorted(size)
            assert (across - info["strip_thickness_mm"]) / 2 == pytest.approx(value, abs=SIZE_MM / 2), f
            assert along == pytest.approx(f["length"], abs=SIZE_MM)
    # the steps run in order along x, each row its own way up
    for kind in ("hole", "slot"):
        row = [f for f in info["features"] if f["kind"] == kind]
        assert [f["x"] for f in row] == sorted(f["x"] for f in row)
        assert [f["value"] for f in row] == sorted(f["value"] for f in row)
    # each label is engraved: in the engraving's depth, outlines (the glyphs) lie in the label's box
    top = _rings(mesh, t - info["engrave_mm"] / 2)
    glyphs = top[1:]
    for f in info["features"]:
        box_y = (f["label_y"], f["label_y"] + info["text_mm"])
        inside = [g for g in glyphs if abs(g[0][0] - f["x"]) < 5 and box_y[0] - 0.5 < g[0][1] < box_y[1] + 0.5]
        assert len(inside) >= len(f["label"].replace(".", "")), f
