"""Meshes read by their content: files of the same bytes give one mesh, a parse's arrays kept in
the store rebuild the very mesh trimesh's load gives, and a part's own checks are measured once
per file's bytes, remembered across runs, while each part keeps its own check records."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh

from hwgen import cache
from hwgen.cad.manifest import manifest_parts, read_manifest
from hwgen.checks import meshes, parts as parts_mod, printing as printing_mod
from hwgen.checks.parts import LoadedPart, mass_summary, mesh_checks
from hwgen.checks.printing import printing_checks

# what the checks and the renders read of a loaded mesh: each must be the same, array for array
ARRAYS = ("vertices", "faces", "face_normals", "face_adjacency", "face_adjacency_edges", "face_adjacency_angles",
          "edges_unique", "edges_sorted", "bounds", "triangles", "center_mass", "vertex_normals")
SCALARS = ("is_watertight", "is_winding_consistent", "volume", "area", "euler_number")


def _stl(path: Path, mesh) -> Path:
    path.write_bytes(mesh.export(file_type="stl"))
    return path


def _ring() -> trimesh.Trimesh:
    """A closed part with a hole and sharp edges (an annulus), as an STL holds it: three vertices
    per triangle, merged again on reading."""
    return trimesh.creation.annulus(r_min=3.0, r_max=8.0, height=2.0, sections=40)


def _same_mesh(a, b) -> None:
    for name in ARRAYS:
        x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
        assert x.dtype == y.dtype and np.array_equal(x, y), name
    for name in SCALARS:
        assert getattr(a, name) == getattr(b, name), name


def _count_parses(monkeypatch) -> list:
    calls = []
    real = meshes._parsed

    def counted(data, kind):
        calls.append(kind)
        return real(data, kind)
    monkeypatch.setattr(meshes, "_parsed", counted)
    return calls


# ---------------------------------------------------------------- arrays kept in the store

def test_kept_arrays_come_back_as_they_were_and_a_damaged_object_is_made_again(tmp_path):
    made = []

    def compute():
        made.append(1)
        return {"v": np.arange(12.0).reshape(4, 3) / 7, "f": np.arange(6, dtype=np.int64).reshape(2, 3),
                "b": np.array([True, False])}
    store = cache.Store(tmp_path)
    with cache.using(store):
        first = cache.kept_arrays("test arrays", ("x", 1), compute)
        again = cache.kept_arrays("test arrays", ("x", 1), compute)
    assert len(made) == 1
    for k, v in first.items():
        assert again[k].dtype == v.dtype and again[k].shape == v.shape and np.array_equal(again[k], v)
        again[k][...] = again[k][::-1] if again[k].ndim == 1 else again[k]      # each is writable, its own
    obj = [p for p in (tmp_path / cache.LAYOUT / "objects").rglob("*") if p.is_file()]
    assert len(obj) == 1
    obj[0].write_bytes(obj[0].read_bytes()[:-8] + b"\0" * 8)        # damaged: found by its hash, made again
    with cache.using(store):
        third = cache.kept_arrays("test arrays", ("x", 1), compute)
    assert len(made) == 2 and np.array_equal(third["v"], first["v"])
    with cache.using(cache.Store(None)):                            # no store: made every time
        cache.kept_arrays("test arrays", ("x", 1), compute)
    assert len(made) == 3


# ---------------------------------------------------------------- one mesh per content

def test_a_mesh_rebuilt_from_its_kept_arrays_is_the_mesh_trimesh_loads(tmp_path, monkeypatch):
    stl = _stl(tmp_path / "ring.stl", _ring())
    loaded = trimesh.load_mesh(str(stl), process=True)
    parses = _count_parses(monkeypatch)
    with cache.using(cache.Store(tmp_path / "store")):
        fresh = meshes.load_mesh(stl)
        kept = meshes.load_mesh(stl)
    assert parses == ["stl"]                        # the second came from the kept arrays
    _same_mesh(loaded, fresh)
    _same_mesh(loaded, kept)
    assert kept is not fresh                        # outside a check run each caller has its own


def test_files_of_the_same_bytes_share_one_mesh_in_a_check_run(tmp_path, monkeypatch):
    a = _stl(tmp_path / "a.stl", _ring())
    b = tmp_path / "b.stl"
    shutil.copyfile(a, b)
    c = _stl(tmp_path / "c.stl", trimesh.creation.box((4.0, 5.0, 6.0)))
    parses = _count_parses(monkeypatch)
    no_store = cache.using(cache.Store(None))       # (the session's store is active otherwise)
    no_store.__enter__()
    with meshes.one_load_per_mesh():               # no store: parsed once per content all the same
        ma, mb, mc = (meshes.load_mesh(p) for p in (a, b, c))
        assert ma is mb and mc is not ma
        assert meshes.load_mesh(a) is ma
    assert parses == ["stl", "stl"]
    # read early (a build's thread while the parts are made): one mesh per content, taken by the run
    early: dict = {}
    with meshes.reading_early(early):
        for p in (a, b, c):
            meshes.read_early(p)
        assert len(parses) == 4 and early[meshes._file_key(a)][1] is early[meshes._file_key(b)][1]
        read = early[meshes._file_key(a)][1]
        with meshes.one_load_per_mesh():
            assert meshes.load_mesh(b) is meshes.load_mesh(a) is read
        assert meshes._file_key(a) not in early and meshes._file_key(b) not in early    # taken, let go of
    assert len(parses) == 4
    # the outputs' reading (part_meshes) shares them outside a check run too
    from hwgen.cad.manifest import ManifestPart
    ps = [ManifestPart.of({"name": p.stem, "role": "disk", "placement": np.eye(4).tolist(),
                           "bbox_mm": {"min": [0, 0, 0], "max": [1, 1, 1]},
                           "files": {"stl": {"path": p.name, "sha256": cache.sha256(p.read_bytes())}}})
          for p in (a, b, c)]
    got = meshes.part_meshes(tmp_path, ps)
    assert got[0][1] is got[1][1] and got[2][1] is not got[0][1]
    no_store.__exit__(None, None, None)


# ---------------------------------------------------------------- a part's own checks, once per file

def _parts(folder: Path, names_files: list[tuple[str, Path]]) -> list[LoadedPart]:
    out = []
    for name, path in names_files:
        sha, mesh = meshes.read_mesh(path)
        out.append(LoadedPart(name, "disk", mesh, np.eye(4), 500.0, {"density_g_cm3": 1.2}, sha))
    return out


def _count_measures(monkeypatch) -> list:
    """Every measurement of one mesh the part checks make, counted by name."""
    calls = []
    for mod, name in ((parts_mod, "soundness"), (printing_mod, "closed_voids"), (printing_mod, "cups")):
        def counted(*args, _real=getattr(mod, name), _name=name):
            calls.append(_name)
            return _real(*args)
        monkeypatch.setattr(mod, name, counted)
    return calls


def _checks(ps: list[LoadedPart]) -> list[dict]:
    from hwgen.cad.manifest import Manifest, ManifestPart
    entries = [{"name": p.name, "placement": p.placement.tolist(), "files": {}, **p.entry,
                "bbox_mm": {"min": p.mesh.bounds[0].tolist(), "max": p.mesh.bounds[1].tolist()}} for p in ps]
    manifest = Manifest("test", "0", "", "", [], {}, {}, tuple(map(ManifestPart.of, entries)), {"stations_mm": [0.0]})
    return ([c.to_json() for c in mesh_checks(ps) + printing_checks(ps, "SLA")]
            + [mass_summary(ps, manifest)[0]])


def test_a_parts_own_checks_are_measured_once_per_file_and_remembered(tmp_path, monkeypatch):
    a = _stl(tmp_path / "a.stl", _ring())
    b = tmp_path / "b.stl"
    shutil.copyfile(a, b)
    c = _stl(tmp_path / "c.stl", trimesh.creation.box((4.0, 5.0, 6.0)))
    files = [("ring_1", a), ("ring_2", b), ("box", c)]
    with cache.using(cache.Store(None)), meshes.one_load_per_mesh():    # no store: every part measured
        plain = _checks([LoadedPart(p.name, p.role, p.mesh, p.placement, p.volume_mm3, p.entry)
                         for p in _parts(tmp_path, files)])
    calls = _count_measures(monkeypatch)
    store = cache.Store(tmp_path / "store")
    with cache.using(store), meshes.one_load_per_mesh():
        first = _checks(_parts(tmp_path, files))
    assert first == plain                                    # the same records, numbers and messages
    assert sorted(calls) == sorted(["soundness"] * 2 + ["closed_voids"] * 2 + ["cups"] * 2)   # two files' bytes
    assert [c["where"].get("part") for c in first[:-1] if c["id"] == "part.mesh"] == ["ring_1", "ring_2", "box"]
    calls.clear()
    with cache.using(store), meshes.one_load_per_mesh():   # a later run: the files did not change
        again = _checks(_parts(tmp_path, files))
    assert again == plain and calls == []
    _stl(c, trimesh.creation.box((4.0, 5.0, 7.0)))          # one file changes: it alone is measured
    with cache.using(store), meshes.one_load_per_mesh():
        changed = _checks(_parts(tmp_path, files))
    assert sorted(calls) == ["closed_voids", "cups", "soundness"]
    box = [ch for ch in changed[:-1] if ch["id"] == "part.mesh" and ch["where"]["part"] == "box"][0]
    assert box["measured"] == pytest.approx(4 * 5 * 7)


# ---------------------------------------------------------------- a real design's files

def test_every_file_of_a_build_rebuilt_from_its_kept_arrays_is_the_mesh_trimesh_loads(built, tmp_path):
    folder = built("prototype")
    store = cache.Store(tmp_path / "store")
    listed = manifest_parts(read_manifest(folder))
    seen = set()
    for p in listed:
        stl = p.stl_in(folder)
        loaded = trimesh.load_mesh(str(stl), process=True)
        with cache.using(store):
            sha, first = meshes.read_mesh(stl)
            _, kept = meshes.read_mesh(stl)
        _same_mesh(loaded, first)
        _same_mesh(loaded, kept)
        seen.add(sha)
    assert len(seen) < len(listed)             # the tensioner's channels share their files' bytes
