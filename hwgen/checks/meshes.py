"""The exported meshes read back by their content: every STL's bytes read and hashed, and parts
whose files hold the same bytes share one loaded mesh (within a check run, or one call of
:func:`part_meshes`); the arrays a parse gives are kept in the active store (:mod:`hwgen.cache`)
under the bytes' sha256, so a later build or check rebuilds the mesh from them instead of parsing
the file again. Each mesh is turned into a manifold3d solid once per placement."""
from __future__ import annotations

import io
import os
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

import numpy as np

from .. import cache
from ..cad.manifest import ManifestPart

_SHELF: ContextVar[dict | None] = ContextVar("hwgen_mesh_shelf", default=None)
_EARLY: ContextVar[dict | None] = ContextVar("hwgen_meshes_read_early", default=None)
MESH_ARRAYS = "stl mesh, vertices merged"     # what :func:`_parsed` keeps: trimesh's load with process=True


@contextmanager
def one_load_per_mesh() -> Iterator[None]:
    """Within: every STL is read once (as long as its file is unchanged), files of the same bytes
    give one mesh, and every mesh is turned into a manifold once per placement; each check gets
    the same objects, so none may change a mesh in place (copy it first). ``hwgen check`` runs all
    its checks inside one."""
    token = _SHELF.set({"meshes": {}, "files": {}, "manifolds": {}})
    try:
        yield
    finally:
        _SHELF.reset(token)


@contextmanager
def sharing_meshes() -> Iterator[None]:
    """Within: meshes shared as in :func:`one_load_per_mesh`, the check run's own when one is
    running (its meshes, solids and measurements), else a run of this block's."""
    if _SHELF.get() is not None:
        yield
        return
    with one_load_per_mesh():
        yield


def drop_solids() -> None:
    """Let go of the manifold3d solids made so far in this check run (the meshes stay): the checks
    that intersect whole parts are done, and the solids are most of the run's memory; a later check
    that asks again gets a new one."""
    shelf = _SHELF.get()
    if shelf is not None:
        shelf["manifolds"].clear()


@contextmanager
def reading_early(early: dict) -> Iterator[None]:
    """Within: :func:`read_early` keeps the meshes it reads in ``early`` (shared between the thread
    that reads them while the parts are being made and the checks), and the first
    :func:`one_load_per_mesh` run that asks for one of them takes it from there."""
    token = _EARLY.set(early)
    try:
        yield
    finally:
        _EARLY.reset(token)


def read_early(path: str | Path) -> None:
    """Read an STL the checks will read, before they ask (see :func:`reading_early`): ``early``
    holds (sha256, mesh) per file, one mesh for files of the same bytes."""
    early = _EARLY.get()
    if early is not None:
        key = _file_key(path)
        if key not in early:
            data = Path(path).read_bytes()
            sha = cache.sha256(data)
            same = next((m for s, m in early.values() if s == sha), None)
            early[key] = (sha, same if same is not None else _mesh_of(sha, data, _kind(path)))


def _file_key(path: str | Path) -> tuple:
    st = os.stat(path)
    return os.path.realpath(path), st.st_ino, st.st_size, st.st_mtime_ns


def _kind(path: str | Path) -> str:
    return Path(path).suffix.lstrip(".").lower()


def _parsed(data: bytes, kind: str) -> dict[str, np.ndarray]:
    """What trimesh's load (vertices merged) makes of a file's bytes: the arrays the mesh is (its
    vertices and faces: it keeps nothing else; every other array, the face normals too, it works
    out from them when asked)."""
    import trimesh
    m = trimesh.load_mesh(io.BytesIO(data), file_type=kind, process=True)
    return {"vertices": np.asarray(m.vertices), "faces": np.asarray(m.faces)}


def _mesh_of(sha: str, data: bytes, kind: str):
    """The mesh of a file's bytes (``sha``: their sha256), rebuilt from the arrays kept for them
    in the active store, or parsed (and its arrays kept)."""
    import trimesh
    arrays = cache.kept_arrays(MESH_ARRAYS, (sha, kind), lambda: _parsed(data, kind),
                               code=cache.NO_CODE, libraries=("trimesh", "numpy"))
    return trimesh.Trimesh(vertices=arrays["vertices"], faces=arrays["faces"], process=False, validate=False)


def read_mesh(path: str | Path) -> tuple[str, object]:
    """(sha256 of the file's bytes, its mesh): shared within :func:`one_load_per_mesh` by every
    file of the same bytes; otherwise a mesh of the caller's own."""
    shelf = _SHELF.get()
    if shelf is None:
        data = Path(path).read_bytes()
        sha = cache.sha256(data)
        return sha, _mesh_of(sha, data, _kind(path))
    key = _file_key(path)
    sha = shelf["files"].get(key)
    if sha is None:
        early = _EARLY.get()
        got = early.pop(key, None) if early is not None else None
        if got is not None:
            sha, mesh = got
            shelf["meshes"].setdefault(sha, mesh)
        else:
            data = Path(path).read_bytes()
            sha = cache.sha256(data)
            if sha not in shelf["meshes"]:
                shelf["meshes"][sha] = _mesh_of(sha, data, _kind(path))
        shelf["files"][key] = sha
    return sha, shelf["meshes"][sha]


def load_mesh(path: str | Path):
    """An STL's mesh (vertices merged; see :func:`read_mesh`)."""
    return read_mesh(path)[1]


# a binary STL's triangle: its normal, three corners, an attribute word
_TRIANGLE = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


def stl_bounds(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """The lowest and highest corner of a binary STL's triangles, read straight from the file (the
    bounds of the mesh the checks read: merging vertices moves none); an ASCII STL is read whole."""
    data = Path(path).read_bytes()
    count = int.from_bytes(data[80:84], "little") if len(data) >= 84 else -1
    if count < 0 or len(data) != 84 + count * _TRIANGLE.itemsize:
        return tuple(load_mesh(path).bounds)
    corners = np.frombuffer(data, dtype=_TRIANGLE, count=count, offset=84)["corners"].reshape(-1, 3)
    if not len(corners):
        raise ValueError(f"{path}: no triangles")
    corners = corners.astype(np.float64)
    return corners.min(axis=0), corners.max(axis=0)


def to_manifold(mesh, placement=None):
    """A trimesh mesh (file coordinates) as a manifold3d solid, in robot coordinates under ``placement``."""
    shelf = _SHELF.get()
    if shelf is None:
        return _to_manifold(mesh, placement)
    key = (id(mesh), None if placement is None else np.asarray(placement, dtype=float).tobytes())
    if key not in shelf["manifolds"]:
        shelf["manifolds"][key] = (mesh, _to_manifold(mesh, placement))      # the mesh kept: its id stays its own
    return shelf["manifolds"][key][1]


def _to_manifold(mesh, placement=None):
    import manifold3d as m3d
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if placement is not None:
        P = np.asarray(placement, dtype=float)
        v = v @ P[:3, :3].T + P[:3, 3]
    return m3d.Manifold(m3d.Mesh(vert_properties=v.astype(np.float32),
                                 tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))


def part_mesh(folder: str | Path, part: ManifestPart):
    """A part's STL from its manifest entry, in file coordinates (vertices merged): the one way every
    check and output reads a part's mesh back (shared within :func:`one_load_per_mesh`)."""
    return load_mesh(part.stl_in(folder))


def part_meshes(folder: str | Path, parts: Iterable[ManifestPart]) -> list[tuple[ManifestPart, object]]:
    """Each part with its mesh (:func:`part_mesh`), in order; parts whose files hold the same bytes
    get one mesh (outside a check run too), which none may change in place."""
    with sharing_meshes():
        return [(p, part_mesh(folder, p)) for p in parts]


def placed_mesh(folder: str | Path, entry: ManifestPart | Mapping, placement: np.ndarray | None = None):
    """A part's STL as a trimesh in robot coordinates (or under ``placement``); a copy, free to change."""
    part = ManifestPart.of(entry)
    mesh = part_mesh(folder, part).copy()      # the loaded mesh may be shared
    mesh.apply_transform(part.placement if placement is None else np.asarray(placement, dtype=float))
    return mesh


def placed_manifold(folder: str | Path, entry: ManifestPart | Mapping, placement: np.ndarray | None = None):
    """A part's STL as a manifold3d solid in robot coordinates (or under ``placement``)."""
    part = ManifestPart.of(entry)
    return to_manifold(part_mesh(folder, part), part.placement if placement is None else placement)


def measured_by_file(sha: str, kind: str, values, compute):
    """``compute()`` (a measurement of one file's mesh alone, as JSON gives it back) for the file
    of bytes ``sha`` and the design ``values`` it also reads: made once per check run for every file
    of those bytes (:func:`one_load_per_mesh`), and remembered in the active store
    (:func:`hwgen.cache.remembered`: under ``kind``, ``sha``, ``values`` and hwgen's code), so a
    build that leaves a file unchanged does not measure it again. The checks made of it are each
    part's own, as before: only the measurement is shared."""
    shelf = _SHELF.get()
    if shelf is None:
        return cache.remembered(kind, (sha, values), compute)
    done = shelf.setdefault("measured", {})
    k = (kind, sha, cache.key(values))
    if k not in done:
        done[k] = cache.remembered(kind, (sha, values), compute)
    return done[k]
