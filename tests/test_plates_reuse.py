"""Print plates kept between builds: a part's orientation decision is remembered by its STL's bytes
and a plate's 3MF by everything it is made of, so a build through the store writes the plates a
build without it writes, byte for byte, while measuring and writing only what changed. The fast
tests lay out small meshes of their own; the slow one lays out the prototype's parts."""
from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from hwgen import cache
from hwgen.outputs import plates

# a small resin printer: the six parts below go two to a plate, the two boxes together
PROC = SimpleNamespace(technology="SLA", name="test printer", build_volume=(60.0, 50.0, 60.0))
SETTINGS = SimpleNamespace(flat_contact_fraction=0.5, sla_tilt_deg=30.0, edge_margin_mm=2.0, gap_mm=3.0)


def _box(size, at=(0, 0, 0)):
    import trimesh
    m = trimesh.creation.box(size)
    m.apply_translation(np.asarray(size) / 2 + at)
    return m


def _mushroom(height=6.0):
    """A plate on a post: a fifth of its footprint on the plate, so SLA tilts it."""
    import trimesh
    post, top = _box((8, 20, height), (16, 0, 0)), _box((40, 20, 3), (0, 0, height))
    return trimesh.boolean.union([post, top], engine="manifold")


def _design(folder: Path, meshes: dict) -> dict:
    """STLs of ``meshes`` (name -> trimesh) in ``folder/stl`` and the manifest the plates read."""
    (folder / "stl").mkdir(parents=True, exist_ok=True)
    parts = []
    for name, mesh in meshes.items():
        path = folder / "stl" / f"{name}.stl"
        mesh.export(path)
        lo, hi = mesh.bounds
        parts.append({"name": name, "role": "disk", "station": None, "volume_mm3": float(mesh.volume),
                      "files": {"stl": {"path": f"stl/{name}.stl", "sha256": cache.sha256(path.read_bytes())}},
                      "placement": np.eye(4).tolist(), "bbox_mm": {"min": lo.tolist(), "max": hi.tolist()}})
    return {"design": "reuse", "parts": parts}


def _parts(tall_box: float = 5.0) -> dict:
    """Six parts, two of each of three kinds (two files of the same bytes each): three plates."""
    return {"box_a": _box((40, 20, tall_box)), "box_b": _box((40, 20, tall_box)),
            "mush_a": _mushroom(), "mush_b": _mushroom(),
            "slab_a": _box((30, 30, 4)), "slab_b": _box((30, 30, 4))}


@pytest.fixture
def counted(monkeypatch):
    """Which plates lib3mf wrote, how many orientations were measured and how many times the
    footprints were packed, per call of ``run``."""
    seen = {"written": [], "decided": 0, "packed": 0}
    write, decide, pack = plates._write_3mf, plates.decide, plates.pack

    def writing(path, objects):
        seen["written"].append(Path(path).name)
        return write(path, objects)

    def deciding(*a, **k):
        seen["decided"] += 1
        return decide(*a, **k)

    def packing(*a, **k):
        seen["packed"] += 1
        return pack(*a, **k)

    monkeypatch.setattr(plates, "_write_3mf", writing)
    monkeypatch.setattr(plates, "pack", packing)
    monkeypatch.setattr(plates, "decide", deciding)

    def run(folder: Path, manifest: dict, store: cache.Store | None, proc=PROC, settings=SETTINGS):
        seen.update(written=[], decided=0, packed=0)
        m = json.loads(json.dumps(manifest))
        if store is None:
            summary = plates.write_plates(folder, m, proc, settings)
        else:
            with cache.using(store):
                summary = plates.write_plates(folder, m, proc, settings)
        files = {p.name: p.read_bytes() for p in sorted((folder / plates.FOLDER).iterdir())}
        return summary, files, dict(seen)
    return run


def test_a_kept_plate_is_the_plate_written_afresh(tmp_path, counted):
    manifest = _design(tmp_path / "d", _parts())
    store = cache.Store(tmp_path / "cache")
    fresh, fresh_files, seen = counted(tmp_path / "d", manifest, None)
    assert len(fresh["plates"]) == 3 and seen["written"] == [f"plate_0{k}.3mf" for k in (1, 2, 3)]
    assert {o["orientation"] for o in fresh["parts"].values()} == {"flat", "tilted"}
    first, first_files, seen = counted(tmp_path / "d", manifest, store)
    assert len(seen["written"]) == 3 and seen["decided"] == 3       # one measurement per file content
    again, again_files, seen = counted(tmp_path / "d", manifest, store)
    assert seen == {"written": [], "decided": 0, "packed": 0}      # every plate, decision and place from the store
    assert again_files == first_files == fresh_files                # plates.md too
    assert again == first == fresh


def test_a_changed_file_writes_its_plate_again_and_keeps_the_others(tmp_path, counted):
    store = cache.Store(tmp_path / "cache")
    before = _design(tmp_path / "d", _parts())
    _, files_before, _ = counted(tmp_path / "d", before, store)
    after = _design(tmp_path / "d", _parts(tall_box=6.0))          # the boxes grow up: same footprint, new files
    summary, files, seen = counted(tmp_path / "d", after, store)
    on = {n: p["file"].split("/")[-1] for p in summary["plates"] for n in p["parts"]}
    assert seen["written"] == [on["box_a"]] and on["box_b"] == on["box_a"]
    assert seen["decided"] == 1 and seen["packed"] == 0              # the boxes' one new content; same places
    changed = {f for f in files if files[f] != files_before[f]}
    assert changed == {on["box_a"], plates.SUMMARY_MD}
    _, fresh_files, _ = counted(tmp_path / "d", after, None)
    assert files == fresh_files


def test_a_corrupt_kept_plate_is_found_and_written_afresh(tmp_path, counted):
    store = cache.Store(tmp_path / "cache")
    manifest = _design(tmp_path / "d", _parts())
    summary, files, _ = counted(tmp_path / "d", manifest, store)
    damaged = summary["plates"][1]["sha256"]
    kept = store.root / "objects" / damaged[:2] / damaged
    data = bytearray(kept.read_bytes())
    data[len(data) // 2] ^= 0xFF
    kept.write_bytes(bytes(data))
    _, again, seen = counted(tmp_path / "d", manifest, store)
    assert seen["written"] == ["plate_02.3mf"]
    assert store.corrupt == [f"object {damaged[:12]}"]
    assert again == files and kept.read_bytes() == files["plate_02.3mf"]     # and the store mended


def test_remembered_orientations_are_the_fresh_ones(tmp_path, counted):
    manifest = _design(tmp_path / "d", _parts())
    store = cache.Store(tmp_path / "cache")
    with cache.using(store):
        plates.layout(tmp_path / "d", manifest, PROC, SETTINGS)
        kept, kept_plates, _ = plates.layout(tmp_path / "d", manifest, PROC, SETTINGS)
    fresh, fresh_plates, _ = plates.layout(tmp_path / "d", manifest, PROC, SETTINGS)
    assert kept_plates == fresh_plates
    for k, f in zip(kept, fresh):
        assert (k.name, k.how, k.reason, k.tilt, k.sha256) == (f.name, f.how, f.reason, f.tilt, f.sha256)
        assert k.vertices.tobytes() == f.vertices.tobytes() and np.array_equal(k.faces, f.faces)
    assert {o.tilt for o in kept} == {None, ("x", 30.0)}
    # and what orient() makes of the mesh alone
    mush = _mushroom()
    alone = plates.orient("mush_a", "disk", mush.vertices, mush.faces, mush.volume, "SLA", SETTINGS,
                          PROC.build_volume)
    ours = next(o for o in fresh if o.name == "mush_a")
    assert alone.how == ours.how == "tilted" and alone.reason == ours.reason


def test_a_remembered_decision_follows_the_settings_it_reads(tmp_path, counted):
    """A tilt of another angle is measured again (its reason and its fit change with it); the gap
    between parts, which no orientation reads, is not."""
    manifest = _design(tmp_path / "d", _parts())
    store = cache.Store(tmp_path / "cache")
    counted(tmp_path / "d", manifest, store)
    wider = SimpleNamespace(**{**vars(SETTINGS), "gap_mm": 4.0})
    steeper = SimpleNamespace(**{**vars(SETTINGS), "sla_tilt_deg": 40.0})
    with cache.using(store):
        plates.layout(tmp_path / "d", manifest, PROC, wider)
        tilted = plates.layout(tmp_path / "d", manifest, PROC, steeper)[0]
    assert {o.tilt for o in tilted} == {None, ("x", 40.0)}
    assert all("40°" in o.reason for o in tilted if o.how == "tilted")


# --------------------------------------------------------------------------- the prototype's plates

@pytest.mark.slow
def test_the_prototypes_plates_from_the_store_are_the_builds(built, tmp_path, counted):
    import shutil
    folder = built("prototype")
    work = tmp_path / "prototype"
    shutil.copytree(folder / "stl", work / "stl")
    manifest = json.loads((folder / "manifest.json").read_text())
    from hwgen import params
    from hwgen.pipeline import design_plan, tensioner_record
    plan = design_plan(params.read(Path(__file__).parents[1] / "params" / "prototype.yaml"),
                       tensioner_record(manifest))
    store = cache.Store(tmp_path / "cache")
    built_files = {p.name: p.read_bytes() for p in (folder / plates.FOLDER).iterdir()}
    first, files, seen = counted(work, manifest, store, plan.process, plan.plates)
    assert len(seen["written"]) == len(manifest["plates"]["plates"])
    assert seen["decided"] < len(first["parts"])                  # like parts (wheels, worms) measured once
    again, again_files, seen = counted(work, manifest, store, plan.process, plan.plates)
    assert seen == {"written": [], "decided": 0, "packed": 0}
    assert files == again_files == built_files and first == again == manifest["plates"]
