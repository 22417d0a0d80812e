"""The exported meshes read back: every STL read once per check run (as long as its file is
unchanged), and turned into a manifold3d solid once per placement."""
from __future__ import annotations

import os
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

import numpy as np

from ..cad.manifest import ManifestPart

_SHELF: ContextVar[dict | None] = ContextVar("hwgen_mesh_shelf", default=None)
_EARLY: ContextVar[dict | None] = ContextVar("hwgen_meshes_read_early", default=None)


@contextmanager
def one_load_per_mesh() -> Iterator[None]:
    """Within: every STL is read once (as long as its file is unchanged) and every mesh is turned
    into a manifold once per placement; each check gets the same objects, so none may change a
    mesh in place (copy it first). ``hwgen check`` runs all its checks inside one."""
    token = _SHELF.set({"meshes": {}, "manifolds": {}})
    try:
        yield
    finally:
        _SHELF.reset(token)


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
    """Read an STL the checks will read, before they ask (see :func:`reading_early`)."""
    import trimesh
    early = _EARLY.get()
    if early is not None:
        key = _file_key(path)
        if key not in early:
            early[key] = trimesh.load_mesh(str(path), process=True)


def _file_key(path: str | Path) -> tuple:
    st = os.stat(path)
    return os.path.realpath(path), st.st_ino, st.st_size, st.st_mtime_ns


def load_mesh(path: str | Path):
    import trimesh
    shelf = _SHELF.get()
    if shelf is None:
        return trimesh.load_mesh(str(path), process=True)
    key = _file_key(path)
    if key not in shelf["meshes"]:
        early = _EARLY.get()
        got = early.pop(key, None) if early is not None else None
        shelf["meshes"][key] = got if got is not None else trimesh.load_mesh(str(path), process=True)
    return shelf["meshes"][key]


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
    """Each part with its mesh (:func:`part_mesh`), in order."""
    return [(p, part_mesh(folder, p)) for p in parts]


def placed_mesh(folder: str | Path, entry: Mapping, placement: np.ndarray | None = None):
    """A part's STL as a trimesh in robot coordinates (or under ``placement``); a copy, free to change."""
    part = ManifestPart.of(entry)
    mesh = part_mesh(folder, part).copy()      # the loaded mesh may be shared
    mesh.apply_transform(part.placement if placement is None else np.asarray(placement, dtype=float))
    return mesh


def placed_manifold(folder: str | Path, entry: Mapping, placement: np.ndarray | None = None):
    """A part's STL as a manifold3d solid in robot coordinates (or under ``placement``)."""
    part = ManifestPart.of(entry)
    return to_manifold(part_mesh(folder, part), part.placement if placement is None else placement)
