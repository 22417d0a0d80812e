"""Print plates: every printed part on exactly one plate, inside it, overlapping no other
(manifold3d on the 3MF read back), in its print orientation; and the plates open and slice in
PrusaSlicer (--info on every plate, an FDM slice of one) with each object's own name."""
from __future__ import annotations

import json
import locale
from itertools import combinations

import numpy as np
import pytest

from hwgen.cad.manifest import ManifestPart
from hwgen.outputs import plates
from tests import clients

INSIDE_MM = 1e-3          # float32 vertices in the 3MF
OVERLAP_MM3 = 1e-6


def _manifold(V, F):
    import manifold3d
    return manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.asarray(V, np.float32),
                                               tri_verts=np.asarray(F, np.uint32)))


def _trimesh(V, F):
    import trimesh
    return trimesh.Trimesh(V, F, process=True)


# --------------------------------------------------------------------------- no CAD

def test_orientation_by_the_face_on_the_plate():
    """A box stands on a whole face (flat, SLA); a plate on a small post touches the plate with a
    fifth of its footprint (tilted 30° about its long side, SLA); FDM keeps both as the file has them."""
    import trimesh
    from types import SimpleNamespace
    settings = SimpleNamespace(flat_contact_fraction=0.5, sla_tilt_deg=30.0, edge_margin_mm=2.0)
    box = trimesh.creation.box((40, 20, 5))
    post = trimesh.creation.box((8, 20, 6))
    post.apply_translation([0, 0, 3])
    top = trimesh.creation.box((40, 20, 3))
    top.apply_translation([0, 0, 7.5])
    mushroom = trimesh.boolean.union([post, top], engine="manifold")
    bed = (160, 100, 180)
    flat = plates.orient("box", "x", box.vertices, box.faces, box.volume, "SLA", settings, bed)
    tilted = plates.orient("m", "x", mushroom.vertices, mushroom.faces, mushroom.volume, "SLA", settings, bed)
    assert flat.how == "flat" and "100%" in flat.reason
    assert np.allclose(flat.size, [40, 20, 5])
    assert tilted.how == "tilted" and "30°" in tilted.reason and "20%" in tilted.reason
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    assert np.allclose(tilted.size, [40, 20 * c + 9 * s, 20 * s + 9 * c], atol=1e-6)    # about x, the long side
    assert tilted.vertices[:, 2].min() == pytest.approx(0, abs=1e-9)
    fdm = plates.orient("m", "x", mushroom.vertices, mushroom.faces, mushroom.volume, "FDM", settings, bed)
    assert fdm.how == "flat" and np.allclose(fdm.size, [40, 20, 9])


def test_packing_fills_plates_without_overlap():
    rng = np.random.default_rng(3)
    sizes = {f"p{i}": tuple(rng.uniform(10, 70, 2)) for i in range(30)}
    sizes["huge"] = (200.0, 10.0)
    bed, gap, margin = (163.84, 102.4), 3.0, 2.0
    laid, nowhere = plates.pack(sizes, bed, gap, margin)
    assert nowhere == ["huge"]
    assert sorted(n for p in laid for n in p) == sorted(n for n in sizes if n != "huge")
    area = sum(w * h for n, (w, h) in sizes.items() if n != "huge")
    assert len(laid) >= area / (bed[0] * bed[1])
    for p in laid:
        boxes = []
        for n, (x, y, turned) in p.items():
            w, h = sizes[n][::-1] if turned else sizes[n]
            assert x >= margin - 1e-9 and y >= margin - 1e-9
            assert x + w <= bed[0] - margin + 1e-9 and y + h <= bed[1] - margin + 1e-9
            boxes.append((x, y, x + w, y + h))
        for a, b in combinations(boxes, 2):
            apart = max(b[0] - a[2], a[0] - b[2], b[1] - a[3], a[1] - b[3])     # the gap along x or y
            assert apart >= gap - 0.02, (a, b)


def test_3mf_round_trip_is_named_and_repeatable(tmp_path):
    import trimesh
    box = trimesh.creation.box((10, 20, 5))
    objects = [("left", box.vertices + 10, box.faces), ("right", box.vertices + [40, 10, 2.5], box.faces)]
    before = locale.getpreferredencoding(False)
    a, b = tmp_path / "a" / "plate_01.3mf", tmp_path / "b" / "plate_01.3mf"
    for p in (a, b):
        p.parent.mkdir()
        plates.write_3mf(p, objects)
    assert a.read_bytes() == b.read_bytes()
    back = plates.read_3mf(a)
    assert locale.getpreferredencoding(False) == before        # lib3mf's "C" locale does not leak out
    assert [n for n, _, _ in back] == ["left", "right"]
    for (_, V, F), (_, V0, _) in zip(back, objects):
        assert np.allclose(V, V0, atol=1e-5)
        assert _trimesh(V, F).volume == pytest.approx(1000, rel=1e-6)


# --------------------------------------------------------------------------- the prototype's plates

@pytest.fixture(scope="module")
def laid_out(built):
    folder = built("prototype")
    manifest = json.loads((folder / "manifest.json").read_text())
    return folder, manifest


def test_every_printed_part_on_one_plate_inside_without_overlap(laid_out):
    folder, manifest = laid_out
    summary = manifest["plates"]
    w, d, h = summary["bed_mm"]
    printed = {e["name"]: e for e in manifest["parts"] if e["role"] != "backbone"}
    seen: list[str] = []
    for plate in summary["plates"]:
        objects = plates.read_3mf(folder / plate["file"])
        assert sorted(n for n, _, _ in objects) == plate["parts"]
        solids = []
        for name, V, F in objects:
            seen.append(name)
            lo, hi = V.min(axis=0), V.max(axis=0)
            assert lo[2] == pytest.approx(0, abs=INSIDE_MM), name                 # on the plate
            assert (lo[:2] >= summary["edge_margin_mm"] - INSIDE_MM).all(), name
            assert hi[0] <= w - summary["edge_margin_mm"] + INSIDE_MM and hi[1] <= d - summary["edge_margin_mm"] + INSIDE_MM
            assert hi[2] <= h, name
            mesh = _trimesh(V, F)
            assert mesh.is_watertight, name
            # the part itself: its volume as the manifest measured it from the solid
            assert mesh.volume == pytest.approx(printed[name]["volume_mm3"], rel=2e-3), name
            solids.append((name, _manifold(mesh.vertices, mesh.faces)))
        for (na, a), (nb, b) in combinations(solids, 2):
            assert (a ^ b).volume() < OVERLAP_MM3, (plate["file"], na, nb)
        heights = {name: np.ptp(V[:, 2]) for name, V, _ in objects}
        assert heights[plate["tallest"]["part"]] == pytest.approx(max(heights.values()), abs=0.01)
        assert plate["tallest"]["height_mm"] == pytest.approx(max(heights.values()), abs=0.01)
        assert plate["volume_ml"] == pytest.approx(sum(printed[n]["volume_mm3"] for n in plate["parts"]) / 1000,
                                                   abs=0.01)
    assert sorted(seen) == sorted(printed) and len(seen) == len(set(seen))    # each exactly once
    assert summary["not_placed"] == []


def test_flat_parts_lie_on_their_face_and_tilted_parts_are_tilted(laid_out):
    """A disk prints flat on its face (its STL's lowest face is on the plate, whole); a part
    said to print tilted stands in the 3MF at the tilt from its file's orientation."""
    import trimesh
    folder, manifest = laid_out
    summary = manifest["plates"]
    kinds = {n: o["orientation"] for n, o in summary["parts"].items()}
    assert kinds["disk_00"] == "flat" and "tilted" in kinds.values()
    for plate in summary["plates"]:
        for name, V, F in plates.read_3mf(folder / plate["file"]):
            entry = next(e for e in manifest["parts"] if e["name"] == name)
            stl = trimesh.load_mesh(str(ManifestPart.of(entry).stl_in(folder)))
            if kinds[name] == "flat":       # the same heights as in the file: on the same face
                assert np.ptp(V[:, 2]) == pytest.approx(np.ptp(stl.vertices[:, 2]), abs=1e-3), name
            else:
                assert np.ptp(V[:, 2]) != pytest.approx(np.ptp(stl.vertices[:, 2]), abs=0.5), name


def test_plates_open_and_slice_in_prusaslicer(laid_out, tmp_path):
    folder, manifest = laid_out
    summary = manifest["plates"]
    w, d, h = summary["bed_mm"]
    files = [folder / p["file"] for p in summary["plates"]]
    info = clients.prusa_info(files)
    assert len(info) == sum(len(p["parts"]) for p in summary["plates"])
    for obj in info:
        assert obj["manifold"] == "yes", obj
        assert float(obj["min_x"]) >= -INSIDE_MM and float(obj["min_y"]) >= -INSIDE_MM, obj
        assert float(obj["max_x"]) <= w + INSIDE_MM and float(obj["max_y"]) <= d + INSIDE_MM, obj
        assert float(obj["min_z"]) == pytest.approx(0, abs=INSIDE_MM) and float(obj["max_z"]) <= h, obj
    # the cheapest plate of several parts to slice (fewest facets), as laid out, names kept in the G-code
    # (PrusaSlicer names the only object of a plate after the file)
    several = [p for p in summary["plates"] if len(p["parts"]) > 1] or summary["plates"]
    cheapest = min(several, key=lambda p: sum(int(o["number_of_facets"]) for o in info
                                              if o["file"] == p["file"].split("/")[-1]))
    gcode = clients.fdm_slice(folder / cheapest["file"], summary["bed_mm"], tmp_path / "plate.gcode")
    labelled = {line.split()[3] for line in gcode.splitlines() if line.startswith("; printing object ")}
    assert labelled == set(cheapest["parts"])


def test_plates_and_coupon_report_bad_input_like_every_command(tmp_path):
    """One clear line, exit 2, the same as `hwgen routing` gives, and nothing written."""
    from tests.test_hostile import CASES, _write, assert_one_clear_line, run_cli
    case = CASES["value-bool-disks.thickness"]
    f = _write(tmp_path, case)
    out = tmp_path / "out"
    lines = set()
    for cmd in (["routing"], ["plates", "-q", "--out", str(out)], ["coupon", "-q", "--out", str(out)]):
        code, stdout, stderr, escaped = run_cli(cmd[0], str(f), *cmd[1:])
        assert_one_clear_line(code, stdout, stderr, escaped, case, f)
        lines.add(stderr.strip())
    assert len(lines) == 1, lines
    assert not out.exists()
