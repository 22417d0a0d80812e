"""The assembly guide: a picture for every step, every count, size and length it gives equal to
the bill of materials' row it cites, and the tensioning step's take-up per worm turn equal to
what the drum measured from its STL gives."""
from __future__ import annotations

import base64
import csv
import json
import math
import re

import numpy as np
import pytest

from hwgen.cad.manifest import ManifestPart
from hwgen.outputs.guide import CITATION

REST = re.compile(r"rest ([\d.]+) mm \[BOM #(\d+)\]")
TAKE_UP = re.compile(r"Channel (\S+) \((\S+)\): .*?\*\*([\d.]+) mm per worm turn\*\*")


@pytest.fixture(scope="module")
def guide(built):
    folder = built("prototype")
    manifest = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))
    with open(folder / "bom.csv", newline="", encoding="utf-8") as f:
        bom = {r["item"]: r for r in csv.DictReader(f)}
    return folder, manifest, bom, (folder / "guide" / "assembly.md").read_text(encoding="utf-8")


def test_every_step_has_its_picture(guide):
    folder, manifest, _, md = guide
    from PIL import Image
    steps = manifest["guide"]["steps"]
    assert [s["title"] for s in steps][:2] == ["The strip into the jig", "Disks on and glued"]
    bench = {p.get("bench") for p in manifest["parts"]}
    last = "The stiffness rig" if "rig" in bench else "Tensioning"
    assert steps[-1]["title"] == last and len(steps) == 8 + ("base_frame" in bench) + ("rig" in bench)
    page = (folder / "guide" / "assembly.html").read_text(encoding="utf-8")
    for s in steps:
        png = folder / s["picture"]
        img = np.asarray(Image.open(png).convert("RGB"))
        assert img.shape[1] == 1000 and img.min() < 100        # drawn, not a blank window
        assert f"]({png.relative_to(folder / 'guide').as_posix()})" in md    # linked from guide/, where the page is
        assert base64.b64encode(png.read_bytes()).decode() in page          # embedded, the same bytes
    assert "<img" in page and 'src="guide/' not in page                      # nothing points outside the page
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    assert len(links) == len(steps) and all((folder / "guide" / link).is_file() for link in links), links


def test_the_guides_numbers_are_the_bill_of_materials(guide):
    _, manifest, bom, md = guide
    cited = CITATION.findall(md)
    assert len(cited) + len(REST.findall(md)) == len(re.findall(r"\[BOM #\d+\]", md))     # all in one of the forms
    for qty, part, detail, item in cited:
        row = bom[item]
        assert (qty, part) == (row["qty"], row["part"])
        assert detail == (f"cut {row['cut_length_mm']} mm" if row["family"] == "tendon" else row["size"])
    for rest, item in REST.findall(md):
        assert rest == bom[item]["rest_length_mm"]
    # every purchased row is in the guide: the strip, each tendon, the hardware and the adhesive
    purchased = {i for i, r in bom.items() if r["category"] == "purchased"}
    assert purchased <= {item for *_, item in cited}


def _drum_radius(folder, wheel: dict) -> float:
    """The drum's radius measured from the wheel's STL: its section across the axis in the middle
    of the first winding zone, as the circle of the same area."""
    import trimesh
    from hwgen.checks.sections import section_loops
    mesh = trimesh.load_mesh(str(ManifestPart.of(wheel).stl_in(folder)))
    P = np.asarray(wheel["placement"], float)
    assert abs(abs(P[2, 2]) - 1) < 1e-9                 # the file's z is the wheel's axis, robot z
    z_robot = float(np.mean(wheel["winding_zones_z_mm"][0]))
    z_file = (z_robot - P[2, 3]) / P[2, 2]
    loops = section_loops(mesh, np.eye(4), [0, 0, z_file], [0, 0, 1], axes=(0, 1))
    return math.sqrt(loops[0].area / math.pi)


def test_take_up_per_worm_turn_from_the_measured_drum(guide):
    folder, manifest, _, md = guide
    parts = {p["name"]: p for p in manifest["parts"]}
    found = TAKE_UP.findall(md)
    channels = {p["channel"] for p in parts.values() if p["role"] == "tensioner_worm"}
    assert {ch for ch, _, _ in found} == channels
    from hwgen.pipeline import load
    from tests.conftest import PARAMS
    tendon = load(PARAMS / "prototype.yaml").design.tendon_material.diameter
    for channel, worm_name, value in found:
        worm = parts[worm_name]
        wheel = parts[worm["mesh_with"]]
        r = _drum_radius(folder, wheel)
        assert r == pytest.approx(wheel["spool_diameter_mm"] / 2, abs=0.01)      # the drum is the drum
        expected = 2 * math.pi * (r + tendon / 2) * worm["starts"] / worm["teeth"]
        assert float(value) == pytest.approx(expected, abs=0.002), (channel, r)
