"""Pictures and the exploded drawing: measured from the files the build wrote."""
from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from hwgen import pipeline
from hwgen.cad.manifest import Manifest
from hwgen.outputs import pictures, scene
from hwgen.pipeline import load

ROOT = Path(__file__).resolve().parents[1]
PNGS = ("exploded.png", "assembled.png", "bent.png")
JIG = "jig.png"          # the disks and the strip in the assembly jig
SVG = "{http://www.w3.org/2000/svg}"
WHITE = 0.97          # a pixel whose every channel is above this is background
SHADE = (0.5, 1.3)    # lit colours are the family colour times a shade in this range
NEAR = 0.07           # ... give or take this RGB distance (0..1)


def _manifest(folder: Path) -> dict:
    return json.loads((folder / "manifest.json").read_text())


def _image(path: Path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB"), dtype=float) / 255


def fractions(img: np.ndarray, palette: dict) -> dict[str, float]:
    """Share of all pixels that are background, and that are nearest to each palette colour
    in some shade (pixels near none of them, such as edges and text, count for nothing)."""
    p = img.reshape(-1, 3)
    bg = p.min(axis=1) > WHITE
    names = list(palette)
    dist = np.empty((len(names), len(p)))
    for i, name in enumerate(names):
        c = np.asarray(palette[name], float)
        s = np.clip(p @ c / (c @ c), *SHADE)
        dist[i] = np.linalg.norm(p - s[:, None] * c, axis=1)
    best = dist.argmin(axis=0)
    near = (dist.min(axis=0) < NEAR) & ~bg
    out = {"background": float(bg.mean())}
    for i, name in enumerate(names):
        out[name] = float((near & (best == i)).mean())
    return out


@pytest.fixture(scope="module")
def proto(built):
    folder = built("prototype")
    m = _manifest(folder)
    assert m["render"]["status"] == "ok", m["render"].get("message")
    return folder, m


def test_pictures_exist_at_the_stated_size(proto):
    folder, m = proto
    width = load(ROOT / "params" / "prototype.yaml").design.render.width_px
    assert width >= 1600
    for name in PNGS:
        im = Image.open(folder / name)
        rec = m["render"]["files"][name]
        assert im.size == (width, rec["height"]) == (rec["width"], rec["height"]), name
        assert 0.4 * width <= im.size[1] <= 1.4 * width


def test_pictures_are_not_blank_and_show_each_family(proto):
    folder, m = proto
    pal = m["render"]["palette"]
    roles = {p["role"] for p in m["parts"] if not p.get("fixture")}     # the jig has a picture of its own
    assert set(pal) == roles
    for name in PNGS:
        img = _image(folder / name)
        assert img.std() > 0.1, f"{name} is flat"
        f = fractions(img, pal)
        assert 0.3 < f["background"] < 0.95, (name, f)
        assert f["disk"] > 0.02 and f["backbone"] > 0.005, (name, f)   # the robot itself is in every picture
        assert sum(f.values()) > 0.95, (name, f)    # background and family colours explain almost every pixel
    # exploded: every part is out in the open, so every family shows; 13 disks outweigh one strip
    f = fractions(_image(folder / "exploded.png"), pal)
    for role in roles:
        n = sum(p["role"] == role for p in m["parts"] if not p.get("fixture"))
        assert f[role] > 5e-5 * n, (role, f)
    assert f["disk"] > 1.5 * f["backbone"], f      # 1.86× with the base frame and the rig in the picture


def test_jig_picture_shows_the_disks_in_the_jig(proto):
    """jig.png: the assembly jig with the parts it holds, and nothing else."""
    folder, m = proto
    rec = m["render"]["files"][JIG]
    assert Image.open(folder / JIG).size == (rec["width"], rec["height"])
    pal = scene.family_colours(Manifest.of(m), fixtures=True)
    f = fractions(_image(folder / JIG), {k: pal[k] for k in ("jig", "disk", "backbone", "tensioner_housing")})
    assert f["jig"] > 0.05 and f["disk"] > 0.05 and f["backbone"] > 1e-3, f
    assert f["tensioner_housing"] < 1e-4, f


def test_family_colours_are_distinct(proto):
    _, m = proto
    cols = list(m["render"]["palette"].values())
    for i, a in enumerate(cols):
        for b in cols[i + 1:]:
            assert not scene.confusable(a, b), (a, b)
    assert scene.confusable((0.75, 0.76, 0.78), (0.27, 0.27, 0.28)) is False   # light and dark grey differ
    assert scene.confusable((0.75, 0.76, 0.78), (0.55, 0.58, 0.52))            # two mid greys do not


def test_bent_picture_shows_every_tendon(proto):
    folder, m = proto
    f = fractions(_image(folder / "bent.png"), m["render"]["tendon_colours"])
    for name in m["render"]["tendon_colours"]:
        assert f[name] > 5e-4, (name, f)


def _foreground(path: Path, size=(400, 400)) -> np.ndarray:
    img = np.asarray(Image.open(path).convert("L").resize(size)) / 255
    return img < WHITE


def test_bent_differs_from_straight(proto, tmp_path):
    """The same view at 0° and at the design's angle: the silhouettes barely overlap."""
    folder, m = proto
    for name in ("manifest.json",):
        shutil.copy(folder / name, tmp_path / name)
    shutil.copytree(folder / "stl", tmp_path / "stl")
    s = m["render"]["settings"]
    straight = pictures.render_pictures(tmp_path, Manifest.of(m), pictures.Settings(s["width_px"], s["explode_mm"], 0.0))
    a = _foreground(tmp_path / "bent.png")
    b = _foreground(folder / "bent.png")
    iou = (a & b).sum() / (a | b).sum()
    assert iou < 0.6, iou
    # and the straight pose is the assembled robot: the tendons run straight along y
    assert straight["images"]["bent.png"]["width"] == s["width_px"]


def test_bend_points_follow_eq1():
    st = np.linspace(0, 270, 13)
    kappa = np.pi / 2 / 270
    tip = scene.bend_points(np.array([[0.0, 270.0, 0.0]]), st, kappa)[0]
    r = 1 / kappa
    assert tip == pytest.approx([0.0, r, r], abs=1e-9)        # a quarter circle toward +z
    below = scene.bend_points(np.array([[5.0, -20.0, 1.0]]), st, kappa)[0]
    assert below == pytest.approx([5.0, -20.0, 1.0])          # the clamped end stays put
    beyond = scene.bend_points(np.array([[0.0, 290.0, 0.0]]), st, kappa)[0]
    assert beyond == pytest.approx([0.0, r, r + 20.0], abs=1e-9)   # straight on along the tip tangent


def test_svg_has_a_balloon_and_a_row_per_family(proto):
    folder, m = proto
    root = ET.parse(folder / "exploded.svg").getroot()
    robot = [p for p in m["parts"] if not p.get("fixture")]        # the jig is not drawn with the robot
    roles = []
    for p in robot:
        if p["role"] not in roles:
            roles.append(p["role"])
    groups = root.iter(f"{SVG}g")
    by_class: dict[str, list] = {}
    for g in groups:
        by_class.setdefault(g.get("class"), []).append(g)
    balloons, rows = by_class.get("balloon", []), by_class.get("bom-row", [])
    assert [b.get("data-family") for b in sorted(balloons, key=lambda g: int(g.get("data-item")))] == roles
    assert [r.get("data-family") for r in rows] == roles
    assert sorted(b.get("data-item") for b in balloons) == sorted(r.get("data-item") for r in rows)
    for b in balloons:       # the number in the balloon is its row's item number
        assert "".join(b.find(f"{SVG}text").itertext()) == b.get("data-item")
    for r in rows:           # each row names its quantity as the manifest counts it
        cells = ["".join(t.itertext()) for t in r.iter(f"{SVG}text")]
        assert int(cells[2]) == sum(p["role"] == r.get("data-family") for p in robot)
    drawn = {g.get("data-part") for g in by_class["part"] if g.find(f"{SVG}path") is not None}
    assert {g.get("data-part") for g in by_class["part"]} == {p["name"] for p in robot}
    assert len(drawn) >= 0.9 * len(robot)                   # (almost) every part has visible lines
    assert {p["role"] for p in robot if p["name"] in drawn} == set(roles)


def test_hidden_lines_are_removed():
    """A segment passing behind a nearer surface is cut where it is covered."""
    from hwgen.outputs.drawing import visible_runs
    W, H = 100, 20
    zbuf = np.ones((H, W))
    zbuf[:, 40:60] = 0.2                         # a wall in front, columns 40..59
    project = lambda P: P.copy()                 # world = display pixels, z = depth  # noqa: E731
    seg = np.array([[[5.0, 10.0, 0.5], [95.0, 10.0, 0.5]]])
    runs, _ = visible_runs(seg, project, zbuf, 1e-3)
    assert len(runs) == 2
    assert runs[0][1][0] == pytest.approx(40, abs=1.5) and runs[1][0][0] == pytest.approx(60, abs=1.5)
    front = seg.copy()
    front[..., 2] = 0.1
    assert len(visible_runs(front, project, zbuf, 1e-3)[0]) == 1


def test_new_families_are_drawn_without_code_changes(proto, tmp_path):
    """Parts of an unknown role (a tensioner) get their own colour, balloon and table row."""
    import trimesh

    from hwgen.outputs import bom
    folder, m = proto
    shutil.copytree(folder / "stl", tmp_path / "stl")
    m = json.loads(json.dumps(m))
    for i, (x, z) in enumerate([(-20, 15), (20, -15)]):
        name = f"worm_{i}"
        trimesh.creation.cylinder(4, 30, sections=24).export(tmp_path / "stl" / f"{name}.stl")
        place = np.eye(4)
        place[:3, 3] = [x, 300, z]
        m["parts"].append({"name": name, "role": "worm", "channel": f"C{i}", "placement": place.tolist(),
                           "color": m["parts"][0]["color"], "volume_mm3": 1500.0,
                           "bbox_mm": {"min": [-4, -4, -15], "max": [4, 4, 15]},
                           "files": {"stl": {"path": f"stl/{name}.stl", "sha256": ""},
                                     "step": {"path": f"step/{name}.step", "sha256": ""}}})
    design = load(ROOT / "params" / "prototype.yaml").design
    table = bom.family_table(Manifest.of(m), design.process.name)
    res = pictures.render_pictures(tmp_path, Manifest.of(m), pictures.Settings(1600, 20.0, 90.0), table)
    assert set(res["palette"]) == {p["role"] for p in m["parts"] if not p.get("fixture")} and "worm" in res["palette"]
    for role, c in res["palette"].items():      # the disk's manifest colour, yet a colour of its own
        assert role == "worm" or not scene.confusable(res["palette"]["worm"], c)
    f = fractions(_image(tmp_path / "exploded.png"), res["palette"])
    assert f["worm"] > 5e-4, f          # (the picture also holds the base mount now: every part is smaller)
    assert res["svg"]["balloons"] == res["svg"]["rows"] == len(table) == len(res["palette"])


@pytest.mark.slow
def test_no_backend_still_builds(tmp_path, monkeypatch):
    """With rendering forced off, the build succeeds, writes the BOM and says what to install."""
    from hwgen.pipeline import build
    monkeypatch.setenv(pictures.BACKEND_ENV, "none")
    res = build(load(ROOT / "params" / "prototype.yaml"), tmp_path)
    entry = res.manifest.render
    assert entry["status"] == "unavailable"
    assert "apt-get install" in entry["message"] and "vtk-osmesa" in entry["message"]
    assert (res.folder / "bom.csv").exists() and (res.folder / "stl" / "disk_00.stl").exists()
    assert not any((res.folder / n).exists() for n in PNGS + ("exploded.svg",))
    assert json.loads((res.folder / "manifest.json").read_text())["render"]["status"] == "unavailable"


@pytest.mark.parametrize("child, status, words", [
    ("#!/bin/sh\nkill -SEGV $$\n", "unavailable", ("crashed (signal 11)", "apt-get install")),
    ("#!/bin/sh\necho 'ValueError: bad mesh' >&2\nexit 1\n", "failed", ("ValueError: bad mesh",)),
])
def test_a_failing_renderer_is_reported(proto, tmp_path, monkeypatch, child, status, words):
    """The child process crashing (a broken driver) or stopping on an error costs the pictures, not the step."""
    folder, m = proto
    fake = tmp_path / "python"
    fake.write_text(child)
    fake.chmod(0o755)
    monkeypatch.setattr(pictures.sys, "executable", str(fake))
    out = tmp_path / "out"
    shutil.copytree(folder / "stl", out / "stl")
    (out / "bent.png").write_bytes(b"an old picture")
    m = json.loads(json.dumps(m))
    from hwgen.model.plan import make_plan
    from hwgen.options import BuildOptions
    m = pipeline.draw(make_plan(load(ROOT / "params" / "prototype.yaml").design), out, Manifest.of(m),
                      BuildOptions()).to_json()
    assert m["render"]["status"] == status
    for w in words:
        assert w in m["render"]["message"]
    assert (out / "bom.md").exists() and not (out / "bent.png").exists()


def test_hwgen_render_command(proto, tmp_path, monkeypatch):
    """`hwgen render` on up-to-date outputs draws in place; without a backend it says so and exits 1."""
    from typer.testing import CliRunner

    from hwgen.cli import app
    folder, _ = proto
    shutil.copytree(folder, tmp_path / folder.name)
    params = str(ROOT / "params" / "prototype.yaml")
    res = CliRunner().invoke(app, ["render", params, "--out", str(tmp_path), "-q"])
    assert res.exit_code == 0, res.output
    assert "bent.png (1800 × 1800 px)" in res.output and "built" not in res.output
    monkeypatch.setenv(pictures.BACKEND_ENV, "none")
    res = CliRunner().invoke(app, ["render", params, "--out", str(tmp_path), "-q"])
    assert res.exit_code == 1
    assert "vtk-osmesa" in res.output
    m = json.loads((tmp_path / folder.name / "manifest.json").read_text())
    assert m["render"]["status"] == "unavailable" and (tmp_path / folder.name / "bom.csv").exists()


def test_bent_picture_says_whether_the_hardware_reaches_the_pose(proto):
    """The prototype's drum winds A1 and A2 in the same sense: its picture says it is the model only;
    a drum that winds them in opposite senses bends the robot."""
    _, m = proto
    assert m["render"]["bent_note"].startswith("model only") and "A1 and A2" in m["render"]["bent_note"]
    m2 = json.loads(json.dumps(m))
    for p in m2["parts"]:
        if p["role"] == "tensioner_wheel" and p["channel"] == "A":
            p["winding"] = "opposite"
    assert pictures.reachable_note(Manifest.of(m2)).startswith("the worm of channel A bends the robot")


def test_chain_joins_segments_into_polylines():
    """Every segment lands in exactly one polyline, its ends consecutive there; segments that meet
    (given either way round and in any order) are one line."""
    from hwgen.outputs.drawing import chain
    square = np.array([[[0, 0], [10, 0]], [[10, 10], [10, 0]], [[0, 10], [10, 10]], [[0, 0], [0, 10]]], float)
    lines = chain(square[[2, 0, 3, 1]])
    assert len(lines) == 1 and len(lines[0]) == 5
    assert tuple(lines[0][0]) == tuple(lines[0][-1])        # closed
    rng = np.random.default_rng(3)
    grid = rng.integers(0, 6, (300, 2, 2)).astype(float) + rng.normal(0, 1e-4, (300, 2, 2))   # within rounding
    grid = grid[np.linalg.norm(np.round(grid[:, 0]) - np.round(grid[:, 1]), axis=1) > 0]
    lines = chain(grid)
    pieces = sorted(tuple(sorted(map(tuple, np.round(ln[i:i + 2], 2)))) for ln in lines for i in range(len(ln) - 1))
    assert pieces == sorted(tuple(sorted(map(tuple, np.round(s, 2)))) for s in grid)
    assert len(lines) < len(grid) / 3                       # and they do join


def _cylinder_part(name="c", role="disk"):
    import trimesh
    m = trimesh.creation.cylinder(10, 4, sections=48)
    return scene.ScenePart(name, role, np.asarray(m.vertices), np.asarray(m.faces), np.eye(4))


def _rigid(angle_deg, axis, shift):
    from scipy.spatial.transform import Rotation
    M = np.eye(4)
    M[:3, :3] = Rotation.from_rotvec(np.radians(angle_deg) * np.asarray(axis, float) / np.linalg.norm(axis)).as_matrix()
    M[:3, 3] = shift
    return M


def test_a_moved_surface_is_the_surface_made_in_place():
    """A part's surface made once in its file's coordinates and moved rigidly has the points,
    normals and triangles of the one vtkPolyDataNormals makes from the moved triangles."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    from hwgen.outputs import view
    p = _cylinder_part()
    M = _rigid(37.0, (1, 2, 0.5), (5.0, -80.0, 12.0))
    own = view._surface(p.vertices, p.faces)
    n_own = vtk_to_numpy(own.GetPointData().GetNormals()).copy()
    moved = view._moved(own, M)
    here = view._surface(scene.transform(p.vertices, M), p.faces)
    assert np.array_equal(vtk_to_numpy(own.GetPointData().GetNormals()), n_own)     # the part's own is kept
    assert moved.GetNumberOfPoints() == here.GetNumberOfPoints() > len(p.vertices)     # split at the rims
    assert np.array_equal(vtk_to_numpy(moved.GetPolys().GetConnectivityArray()),
                          vtk_to_numpy(here.GetPolys().GetConnectivityArray()))
    assert np.allclose(vtk_to_numpy(moved.GetPoints().GetData()), vtk_to_numpy(here.GetPoints().GetData()), atol=1e-9)
    n_moved = vtk_to_numpy(moved.GetPointData().GetNormals())
    assert np.allclose(n_moved, vtk_to_numpy(here.GetPointData().GetNormals()), atol=1e-6)
    assert moved.GetPointData().GetNormals().GetName() == here.GetPointData().GetNormals().GetName()


def test_a_pose_drawn_again_looks_the_same(tmp_path):
    """Drawn a second time (its surface kept), as another family (the surface shared) or moved from
    the part's own surface rather than made in the pose: the same picture, and the PNG holds it."""
    from hwgen.outputs import view
    try:
        r = view.Renderer(400)
    except view.RenderUnavailable as e:
        pytest.skip(str(e))
    p = _cylinder_part()
    M = _rigid(50.0, (0.3, 1, 0.2), (0.0, 0.0, 0.0))
    d = np.asarray(view.ISOMETRIC.toward_camera, float)
    d /= np.linalg.norm(d)
    colours = {"disk": (0.8, 0.6, 0.2), "grey": (0.8, 0.6, 0.2)}

    def picture(posed, name):
        r.draw([posed], colours, view.ISOMETRIC, tmp_path / name)
        return np.asarray(Image.open(tmp_path / name).convert("RGB"), dtype=int)

    posed = scene.pose_rigid(p, M, d)
    first = picture(posed, "a.png")
    assert "surface" in posed.drawn and "surface" in p.drawn        # the pose's, moved from the part's own
    assert np.array_equal(picture(posed, "b.png"), first)
    again = posed.as_role("grey")
    assert again.drawn is posed.drawn
    assert np.array_equal(picture(again, "c.png"), first)
    in_place = scene.Posed(p, posed.vertices, posed.faces, posed.edges)      # no matrix: the filter in the pose
    diff = np.abs(picture(in_place, "d.png") - first).max(axis=2)
    assert diff.max() <= 1 and (diff > 0).mean() < 1e-3
    assert (first.min(axis=2) < 200).mean() > 0.05                  # the part is there
    r.release()
