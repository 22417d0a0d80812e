"""view.html without a browser and without the CAD kernel: a small robot's files written with
trimesh, the page read back (its static HTML, its JSON and its GLB, parsed as a glTF reader would).
The page in a real browser: tests/test_browser.py."""
from __future__ import annotations

import base64
import io
import json
import re

import numpy as np
import pytest
import trimesh

from hwgen.cad.manifest import Manifest, ManifestPart, manifest_parts, sha256
from hwgen.outputs import scene, webview

UP_Y = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])     # file z -> robot y (a disk's)
STATIONS = [0.0, 50.0, 100.0]
FAILING = {"id": "eyelet.wall.edge", "severity": "error", "passed": False, "message": "disk_01: 0.4 mm wall",
           "measured": 0.4, "limit": 0.8, "where": {"part": "disk_01", "station": 1}, "fix": "move the eyelet in"}
CHECKS = [
    FAILING,
    {"id": "tendon.clearance", "severity": "error", "passed": False, "message": "A1 and A2 rub </script> here",
     "measured": 0.1, "limit": 0.2, "where": {"tendons": ["A1+A2"], "segment": [0, 1]}, "fix": "spread them"},
    {"id": "part.mesh", "severity": "error", "passed": True, "message": "disk_00: watertight", "measured": None,
     "limit": None, "where": {"part": "disk_00"}, "fix": ""},
    {"id": "gear.backlash", "severity": "warning", "passed": True, "message": "backlash 0.07 mm", "measured": 0.07,
     "limit": 0.2, "where": {"channel": "all", "measured_on": "A"}, "fix": ""},
]


def _place(m: np.ndarray, y: float) -> list:
    out = np.array(m, float)
    out[1, 3] += y
    return out.tolist()


def _robot(folder, missing: str | None = None, garbled: bool = False) -> Manifest:
    """Three disks on a strip, a tensioner part beyond the tip, a jig; each an STL in ``folder``
    (``missing``: that part's not, or, ``garbled``, not an STL)."""
    shapes = [(f"disk_{i:02d}", "disk", trimesh.creation.cylinder(radius=20.0, height=3.0, sections=48),
               _place(UP_Y, y), i, {}) for i, y in enumerate(STATIONS)]
    shapes += [("backbone", "backbone", trimesh.creation.box(bounds=[[-15, 0, -0.3], [15, 100, 0.3]]), np.eye(4).tolist(),
                None, {}),
               ("tensioner_wheel_A", "tensioner_wheel", trimesh.creation.icosphere(subdivisions=3, radius=8.0),
                _place(np.eye(4), 130.0), None, {"channel": "A"}),
               ("jig_1", "jig", trimesh.creation.box(bounds=[[-30, -10, -30], [30, 110, -25]]), np.eye(4).tolist(),
                None, {"fixture": True})]
    (folder / "stl").mkdir(parents=True, exist_ok=True)
    parts = []
    for name, role, mesh, placement, station, extra in shapes:
        path = folder / "stl" / f"{name}.stl"
        if name != missing:
            mesh.export(path)
        elif garbled:
            path.write_bytes(b"solid nothing in it")
        entry = {"name": name, "role": role, "placement": placement, "color": [0.9, 0.8, 0.6, 1.0],
                 "files": {"stl": {"path": f"stl/{name}.stl", "sha256": sha256(path) if path.exists() else ""}},
                 "bbox_mm": {"min": mesh.bounds[0].tolist(), "max": mesh.bounds[1].tolist()}, **extra}
        if station is not None:
            entry["station"] = station
        parts.append(entry)
    design = {"stations_mm": STATIONS,
              "tendons": [{"name": n, "eyelets_xz_mm": [[x, 0.0]] * 3} for n, x in (("A1", 12.0), ("A2", -12.0))]}
    return Manifest("little", "0", "", "", [], {}, {}, tuple(map(ManifestPart.of, parts)), design, checks=CHECKS,
                    checks_ok=False)


STUDY = {"stiffening": {"reference": "gravity -z", "headline": "stiffening AA/N at the tip: 2×"},
         "states": [{"state": s, "orientation": o, "friction": f, "tip_stiffness_n_per_mm": k * (2 if f == "stuck" else 1),
                     "tip_torsion_nmm_per_rad": 100.0 * k}
                    for s, k in (("AA", 0.2), ("N", 0.1)) for o in ("gravity -z", "weightless") for f in ("none", "stuck")]}


def _page(tmp_path, monkeypatch, bundle: bool = True, missing: str | None = None, budget: int | None = None,
          garbled: bool = False):
    folder = tmp_path / "little"
    manifest = _robot(folder, missing, garbled)
    if bundle:
        js = tmp_path / "viewer.js"
        js.write_text("/* hwgen viewer: a test's stand-in */\nwindow.stand_in = 1;\n")
        monkeypatch.setenv(webview.VIEWER_ENV, str(js))
    else:
        monkeypatch.setenv(webview.VIEWER_ENV, "none")
    if budget is not None:
        monkeypatch.setattr(webview, "MAX_TRIANGLES", budget)
    added = webview.write_view(folder, manifest, {"ok": False, "checks": CHECKS}, STUDY, 20.0, 90.0)
    return folder, manifest, added, (folder / webview.PAGE).read_text()


def _script(page: str, ident: str) -> str:
    m = re.search(rf'<script type="[^"]+" id="{ident}">(.*?)</script>', page, re.S)
    assert m, f"no #{ident} in the page"
    return m.group(1)


def _glb(page: str) -> trimesh.Scene:
    return trimesh.load(io.BytesIO(base64.b64decode(_script(page, "hwgen-glb"))), file_type="glb")


def _data(page: str) -> dict:
    return json.loads(_script(page, "hwgen-data"))


def test_the_glb_holds_every_part_as_a_named_node_in_its_placement_and_colour(tmp_path, monkeypatch):
    folder, manifest, added, page = _page(tmp_path, monkeypatch)
    glb = _glb(page)
    placements = {p.name: p.placement for p in manifest_parts(manifest)}
    nodes = {n for n in glb.graph.nodes_geometry}
    assert nodes == set(placements)
    for name, placement in placements.items():
        matrix, geometry = glb.graph[name]
        assert np.allclose(matrix, placement, atol=1e-6), name
        mesh = glb.geometry[geometry]
        stl = trimesh.load(folder / "stl" / f"{name}.stl")
        assert len(mesh.faces) == len(stl.faces)
        assert np.allclose(mesh.bounds, stl.bounds, atol=1e-4)
        rgba = np.asarray(mesh.visual.material.baseColorFactor, float) / 255
        assert np.allclose(rgba[:3], webview._linear([0.9, 0.8, 0.6])[:3], atol=2 / 255)   # sRGB 0.9 is linear 0.79
    assert added.sections["view"]["status"] == "ok" and added.files[webview.PAGE]["sha256"] == sha256(folder / "view.html")


def test_the_page_names_every_part_and_marks_the_failing_ones(tmp_path, monkeypatch):
    _, manifest, _, page = _page(tmp_path, monkeypatch)
    tree = re.search(r"<nav id=tree>(.*?)</nav>", page, re.S).group(1)
    for e in manifest.parts:
        assert f">{e.name}</button>" in tree
    failing = re.findall(r'<li data-part="([^"]+)" class=failing>.*?<span class=ids>([^<]*)</span>', tree)
    assert failing == [("disk_01", "eyelet.wall.edge")]
    tendons = re.findall(r'<li data-tendon="([^"]+)" class=failing>.*?<span class=ids>([^<]*)</span>', tree)
    assert tendons == [("A1", "tendon.clearance"), ("A2", "tendon.clearance")]
    assert 'data-group="jig"><' not in tree and re.search(r'data-group="jig">', tree)   # the jig starts hidden
    assert "window.stand_in = 1" in page                     # the viewer's bundle inlined
    assert "</script> here" not in page                       # a message cannot end a script early
    data = _data(page)
    assert data["checks"][1]["message"] == "A1 and A2 rub </script> here"
    by_name = {p["name"]: p for p in data["parts"]}
    assert [data["checks"][i]["id"] for i in by_name["disk_01"]["checks"]] == ["eyelet.wall.edge"]
    assert [data["checks"][i]["id"] for i in by_name["tensioner_wheel_A"]["checks"]] == ["gear.backlash"]   # "all"
    assert by_name["disk_01"]["failing"] == ["eyelet.wall.edge"] and data["warning_colour"] == "#ff008c"


def test_the_poses_are_the_pictures_own(tmp_path, monkeypatch):
    """The exploded offsets and the bent placements the page is given are those of the pictures'
    scene (the same functions), and the bent strip is the strip bent by eq. (1)."""
    folder, manifest, _, page = _page(tmp_path, monkeypatch)
    data = _data(page)
    parts = scene.load_parts(folder, manifest)
    ex = scene.exploded_placements(parts, STATIONS, 20.0, webview.ISOMETRIC.toward_camera)
    shift = {p["name"]: p["shift"] for p in data["parts"]}
    for p in parts:
        assert np.allclose(shift[p.name], ex[p.name][:3, 3] - p.placement[:3, 3], atol=1e-3), p.name
    assert shift["disk_02"] == pytest.approx([0.0, 40.0, 0.0])
    assert shift["jig_1"] == [0.0, 0.0, 0.0]
    plus = next(pose for pose in data["poses"] if pose["key"] == "plus")
    assert plus["label"] == "bent +90°" and set(plus["vertices"]) == {"backbone"}
    tip = np.asarray(plus["matrices"]["disk_02"]).reshape(4, 4).T
    assert np.allclose(tip, scene.bent_placement(parts[2], STATIONS, plus["kappa"]), atol=1e-5)
    assert np.degrees(np.arccos(tip[1, 2])) == pytest.approx(90.0, abs=1e-3)     # the tip disk's axis turned 90°
    bent = np.frombuffer(base64.b64decode(plus["vertices"]["backbone"]), "<f4").reshape(-1, 3)
    radius = 100.0 / np.radians(90.0)
    # every point of the strip lies on the arc of eq. (1) (give or take half its thickness)
    assert np.allclose(np.hypot(bent[:, 1], bent[:, 2] - radius), radius, atol=0.31)
    assert "jig_1" not in plus["matrices"]
    a1 = next(t for t in data["tendons"] if t["name"] == "A1")
    assert a1["straight"] == [[12.0, y, 0.0] for y in STATIONS] and a1["shift"][2] == [0.0, 40.0, 0.0]


def test_without_the_viewer_the_page_lists_everything_and_says_why(tmp_path, monkeypatch):
    _, manifest, added, page = _page(tmp_path, monkeypatch, bundle=False)
    assert "<script" not in page
    assert "The 3D view is not in this page" in page and "make viewer" in page
    for e in manifest.parts:
        assert f">{e.name}</button>" in page
    assert "eyelet.wall.edge" in page and "<table id=stiffness>" in page
    assert added.sections["view"]["status"] == "no viewer"


@pytest.mark.parametrize("garbled, why", [(False, "it could not be read (FileNotFoundError"),
                                          (True, "it holds no triangles")])
def test_a_part_without_its_stl_is_drawn_as_its_box_and_said(tmp_path, monkeypatch, garbled, why):
    _, manifest, added, page = _page(tmp_path, monkeypatch, missing="tensioner_wheel_A", garbled=garbled)
    assert f"tensioner_wheel_A: its STL (stl/tensioner_wheel_A.stl): {why}" in page
    glb = _glb(page)
    box = glb.geometry[glb.graph["tensioner_wheel_A"][1]]
    assert len(box.faces) == 12 and np.allclose(box.extents, [16.0, 16.0, 16.0], atol=0.2)
    assert added.sections["view"]["boxes"] == ["tensioner_wheel_A"]


def test_an_assembly_over_the_budget_draws_its_largest_parts_as_boxes(tmp_path, monkeypatch):
    _, _, added, page = _page(tmp_path, monkeypatch, budget=1000)
    glb = _glb(page)
    faces = {n: len(glb.geometry[glb.graph[n][1]].faces) for n in glb.graph.nodes_geometry}
    assert sum(faces.values()) <= 1000
    boxed = added.sections["view"]["boxes"]
    assert "tensioner_wheel_A" in boxed and all(faces[n] == 12 for n in boxed)        # the sphere, 1280 triangles
    assert "over this page's 1,000" in page


def test_the_stiffness_table(tmp_path, monkeypatch):
    *_, page = _page(tmp_path, monkeypatch)
    rows = re.findall(r"<tr><td>(\w+)</td><td>([\d.]+)</td><td>([\d.]+)</td><td>([\d.]+)</td></tr>", page)
    assert rows == [("AA", "0.2", "0.4", "20"), ("N", "0.1", "0.2", "10")]
    assert webview.stiffness_table({"skipped": "no tendons"}) == {"skipped": "no tendons"}
    assert "skipped" in webview.stiffness_table(None)


def test_groups_follow_the_families():
    assert [webview.group_of(r) for r in ("disk", "backbone", "tensioner_wheel", "base_mount", "jig", "frame_post")] \
        == ["disk", "backbone", "tensioner", "base", "jig", "frame"]


def test_the_view_stage_is_kept_under_its_viewer(tmp_path):
    """The page inlines the viewer's bundle, which is no .py file of hwgen's: the stage's key holds
    its bytes, so a page from the cache never carries another viewer."""
    from hwgen.engine.context import Hashes, StageInput
    from hwgen.engine.stagecache import stage_key
    from hwgen.options import BuildOptions
    folder = tmp_path / "little"
    given = StageInput(None, folder, _robot(folder), options=BuildOptions(viewer=str(tmp_path / "viewer.js")))
    keys = []
    for text in ("/* hwgen viewer: one */", "/* hwgen viewer: one */", "/* hwgen viewer: two */"):
        (tmp_path / "viewer.js").write_text(text)
        keys.append(stage_key(Hashes(), "view", given))
    assert keys[0] == keys[1] != keys[2]
    assert stage_key(Hashes(), "guide", given) != keys[0]
