"""The part cache: every unit of parts (:mod:`hwgen.cad.families`) built, or copied from the cache
when its inputs did not change, and its files placed into the build's folder; assembly.step put
together from the units' solids; the strip's template.

A unit is kept under :func:`unit_key`: the frozen values its builder reads, the export settings,
the code that makes solids (``hwgen/cad``, ``hwgen/model``, ``hwgen/data``) and the CAD kernel's
version (:func:`hwgen.cache.entry_key`). Its record holds each part's description and
measurements and the sha256 of its STL, STEP and BREP, whose bytes are objects of the store.
Files from the cache are the bytes a fresh build writes.
"""
from __future__ import annotations

import tempfile
from contextlib import ExitStack, nullcontext
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__, cache
from ..cad import Part, export
from ..cad.families import build_unit, kernel_errors, part_count, units
from ..cad.manifest import Manifest, ManifestPart, describe, design_report, entry, measure, sha256
from ..cad.memo import KERNEL, Busy, kept_in, made_as, setting_aside
from ..errors import DesignError, InputError
from ..model.plan import Plan
from .concurrency import Workers
from .context import Build

TEMPLATE = "backbone_template.dxf"


def unit_key(kind: str, inputs) -> str:
    """The key of a unit, the assembly or a kept solid's files: what makes them (``inputs``), the
    export settings, the code that makes solids and the CAD kernel's version."""
    return cache.entry_key(kind, (inputs, export.settings()), code=cache.SOLID_CODE, libraries=KERNEL)


@dataclass(eq=False)
class Unit:
    """One unit of the plan's parts as a build makes it."""

    index: int
    family: object                  # hwgen.cad.families.Family
    first: int                      # the index of its first part in its family
    spec: object                    # hwgen.cad.families.UnitSpec: its parts' count and inputs
    key: str
    kept: dict | None               # its record from the cache (with its bytes), None: to be made
    record: dict | None = None      # once made or read: its record, with its bytes in this process
    parts: list | None = None       # its parts, when built in this process (their files are in the folder then)
    entries: list = field(default_factory=list)     # its parts' manifest entries, once placed


def base_manifest(b: Build, files: dict, entries: list[dict]) -> Manifest:
    """The manifest of the files written: the design, the whole design's files, each part's entry
    and the design report."""
    loaded = b.loaded
    return Manifest(name=loaded.name, hwgen_version=__version__, params_file=loaded.source,
                    params_sha256=loaded.sha256, params_base=list(loaded.bases),
                    design_resolved=loaded.design.model_dump(mode="json"), files=files,
                    parts=tuple(ManifestPart.of(e) for e in entries),
                    design_report=design_report(b.plan))


class PartFiles:
    """Every part's STL and STEP, assembly.step, the strip's template and the manifest of a build
    (:meth:`write`). A unit whose key is in the cache is copied from it, the others are built (and
    kept): in worker processes when the build has ``jobs`` (:class:`~.concurrency.Workers`: as many as
    there are units to build, at most ``jobs``, started only when there is something to make),
    else in this process. ``b.scratch`` is where the solids several units share (the tensioner's
    worm and gear) are kept, so that each is made once whichever process needs it."""

    def __init__(self, b: Build):
        self.b = b
        self.todo = []
        for i, (family, first, spec) in enumerate(units(b.plan)):
            key = unit_key("unit", (family.name, spec.inputs))
            self.todo.append(Unit(i, family, first, spec, key, unit_from_cache(b.store, key)))
        self.asm_key = unit_key("assembly", (b.loaded.name, [u.key for u in self.todo]))
        self.built: list[str] = []      # the parts made afresh
        self.count = 0                  # parts placed so far
        self.total = part_count(b.plan)
        self.workers: Workers | None = None

    def write(self, placed=None, measurable=None) -> tuple[Manifest, list[str]]:
        """The files and the manifest; (the manifest, the names of the parts built afresh). With
        ``b.select``, only the parts it takes get their files, and the assembly and the template are
        not written. ``placed`` is called with the manifest as it stands once every part's files are
        in the folder (the template is drawn before the parts; no assembly in its files yet), then
        ``measurable`` with the same."""
        b = self.b
        (b.folder / "stl").mkdir()
        (b.folder / "step").mkdir()
        assembly = _assembly_from_cache(b.store, self.asm_key) if b.whole else None
        with ExitStack() as stack:
            to_make = sum(u.kept is None for u in self.todo)
            if b.jobs >= 1 and (to_make or (b.whole and assembly is None)):
                self.workers = stack.enter_context(Workers(max(1, min(b.jobs, to_make)), b.ahead))
            if b.whole:
                # drawn while the workers' server starts (it imports CadQuery first): the checks'
                # measurement needs it, and starts as soon as the parts are in
                backbone_dxf(b.store, b.plan, b.folder / TEMPLATE)
            with kept_in(b.scratch):
                self._place_all()
            entries = [e for u in self.todo for e in u.entries]
            if placed is not None:
                placed(base_manifest(b, {}, entries))
            job = None
            if b.whole and assembly is None and self.workers is not None:
                breps = {sha: data for u in self.todo for sha, data in u.record.get("breps", {}).items()}
                done = [(u.key, _record(u.record)) for u in self.todo]
                job = self.workers.submit(assembly_in_worker, b.loaded.name, b.plan, done, breps, b.store, b.scratch)
            if b.whole and measurable is not None:
                measurable(base_manifest(b, {}, entries))
            if b.whole and assembly is None:
                assembly = self._assembly(job)
            if b.whole:
                (b.folder / "assembly.step").write_bytes(assembly)
        files = {}
        if b.whole:
            files = {"assembly": {"path": "assembly.step", "sha256": sha256(b.folder / "assembly.step")},
                     "backbone_template": {"path": TEMPLATE, "sha256": sha256(b.folder / TEMPLATE)}}
        return base_manifest(b, files, entries), self.built

    def _assembly(self, job) -> bytes:
        """assembly.step's bytes, from the worker ``job`` or written here, and kept."""
        b = self.b
        if job is not None:
            data = _result(job.result())
        else:
            with kept_in(b.scratch):
                assemble(b.loaded.name, b.plan, b.folder / "assembly.step", b.store, [u.record for u in self.todo])
            data = (b.folder / "assembly.step").read_bytes()
        b.store.put_record(self.asm_key, {"step": b.store.put_bytes(data)})
        return data

    def _place_all(self) -> None:
        """Each unit's files into the folder and its parts' entries (in build order, whatever order
        the units were made in): from the cache, from a worker, or built here.

        A unit not in the cache is made under its lock (:meth:`hwgen.cache.Store.try_lock`), taken
        when its turn comes. A unit whose lock another build holds (it is making that unit now)
        waits until every other unit is done; this build then waits for the lock, which frees once
        the other has kept the unit, and reads it from the cache (or makes it, when the other did
        not finish). So is a unit that needs a kept solid another build is making (the throated
        wheel's gear).

        The first of the tensioner's units to make goes first: it makes the worm and the throated
        gear every channel shares (most of the parts' time), while the other workers make the
        other families' units. The tensioner's other units come last and wait for the shared
        solids instead of being set aside: by then the gear is made, or nearly."""
        todo = self.todo
        tensioner = [u for u in todo if u.family.name == "tensioner"]
        first = [u for u in tensioner if u.kept is None][:1]
        order = first + [u for u in todo if u not in tensioner] + [u for u in tensioner if u not in first]
        later = [u for u in tensioner if u not in first]
        elsewhere = {u.index: self._submit(u, wait=u in later) for u in order
                     if u.kept is None and self.workers is not None}
        theirs = []
        for wait in (False, True):
            for u in theirs if wait else order:
                if not self._made(u, elsewhere.pop(u.index, None), wait):
                    theirs.append(u)
                    continue
                self._place(u)
                if self.b.ahead is not None and self.b.whole:
                    self.b.ahead.placed(u.index, u.family.name, self.b.folder, u.entries)

    def _submit(self, u: Unit, wait: bool):
        return self.workers.submit(unit_in_worker, self.b.plan, u.index, u.key, self.b.store, wait, self.b.scratch)

    def _made(self, u: Unit, future, wait: bool) -> bool:
        """``u``'s record (with its bytes) and, when built in this process, its parts: from the
        cache, from a worker (``future``, or one submitted now), or built here. False, without
        ``wait``, when another build is making it."""
        b = self.b
        if u.kept is not None:
            u.record = u.kept
            return True
        if self.workers is None:
            lock = b.store.lock(u.key) if wait else b.store.try_lock(u.key)
            if lock is None:
                return False
            with lock:
                rec = unit_from_cache(b.store, u.key)      # kept by another build while this one looked
                if rec is not None:
                    u.record = rec
                    return True
                try:
                    with nullcontext() if wait else setting_aside():
                        parts = list(build_unit(b.plan, u.family, u.first, u.spec))
                except Busy:
                    return False
                u.record = keep_unit(b.store, u.key, export_unit(b.plan, parts, b.folder, b.scratch))
                u.parts = parts
            self.built += [p["name"] for p in u.record["parts"]]
            return True
        rec = None
        while rec is None:
            if future is None:
                future = self._submit(u, wait)
            kind, value = future.result()
            future = None
            if kind == "busy":                          # only without wait
                return False
            if kind == "kept":
                rec = unit_from_cache(b.store, u.key)    # gone again (trimmed): made on the next turn
            else:
                rec = _result((kind, value))             # kept by the worker
                self.built += [p["name"] for p in rec["parts"]]
        u.record = rec
        return True

    def _place(self, u: Unit) -> None:
        """A unit's files written into the folder (unless it was built there), and its parts' entries."""
        b = self.b
        for p in u.record["parts"]:
            files = {"stl": b.folder / "stl" / f"{p['name']}.stl", "step": b.folder / "step" / f"{p['name']}.step"}
            hashes = {kind: p["files"][kind] for kind in files}
            for kind, path in files.items():
                if b.select is not None and not b.select(p["name"]):
                    path.unlink(missing_ok=True)        # built for the manifest, not asked for
                elif u.parts is None:
                    path.write_bytes(u.record["blobs"][hashes[kind]])
            u.entries.append(entry(p, p["measured"], files, b.folder, b.plan.process.material,
                                   b.plan.process.density_g_cm3, hashes))
            self.count += 1
            if b.progress:
                b.progress(p["name"], self.count, self.total)


# ---------------------------------------------------------------- units in the store

def unit_from_cache(store: cache.Store, key: str) -> dict | None:
    """The cached record of a unit with every file of it present and sound, else None."""
    rec = store.get_record(key)
    if rec is None:
        return None
    try:
        blobs = {}
        for p in rec["parts"]:
            for kind in ("stl", "step"):
                data = store.get_bytes(p["files"][kind])
                if data is None:
                    return None
                blobs[p["files"][kind]] = data
        rec["blobs"] = blobs
        return rec
    except (KeyError, TypeError):
        return None


def export_unit(plan: Plan, parts, where: Path, solids: cache.Store) -> list[dict]:
    """Each part of a freshly built unit: its description and measurements, its STL and STEP
    (written under ``where``) as bytes, and its solid as BREP bytes, once per solid (what the
    cache keeps to put the assembly together, and by which it knows parts of one solid). A solid
    kept in ``solids`` (:func:`hwgen.cad.memo.made_as`) whose STL and measurements another unit
    has kept there gets those (every channel of one spool layout has the same wheel), and its STEP
    when a unit kept one for the same part name (an edit that moves the tensioner writes no
    wheel's STEP again)."""
    out = []
    for k, part in enumerate(parts):
        stl, step = where / "stl" / f"{part.name}.stl", where / "step" / f"{part.name}.step"
        kept_as = made_as(part.solid)
        with kernel_errors(plan, part, "write the files of"):
            same = next((j for j in range(k) if parts[j].solid is part.solid), None)
            mesh_key = unit_key("kept solid's mesh", kept_as) if kept_as and same is None else None
            got = _kept_mesh(solids, mesh_key) if mesh_key else None
            if got is not None:
                stl.write_bytes(got[0])
            else:
                export.write_stl(part.solid, stl)
            step_key = unit_key("kept solid's step", (kept_as, part.name)) if kept_as else None    # it names the part
            step_bytes = _kept_bytes(solids, step_key, "step") if step_key else None
            if step_bytes is not None:
                step.write_bytes(step_bytes)
            else:
                export.write_step(part.solid, step, part.name)
            # a solid measured once (the throated wheels of one size)
            measured = out[same]["measured"] if same is not None else got[1] if got is not None else \
                cache.as_json(measure(part))
            solid = export.write_brep(part.solid) if same is None else None
        if mesh_key and got is None:
            solids.put_record(mesh_key, {"stl": solids.put_bytes(stl.read_bytes()), "measured": measured})
        if step_key and step_bytes is None:
            solids.put_record(step_key, {"step": solids.put_bytes(step.read_bytes())})
        out.append({"part": cache.as_json(describe(part)), "measured": measured, "same_solid_as": same,
                    "made_as": kept_as, "stl": stl.read_bytes(), "step": step.read_bytes(), "brep": solid})
    return out


def _kept_bytes(solids: cache.Store, key: str, name: str) -> bytes | None:
    """The file kept for a kept solid under ``key`` (its record's field ``name``), None if there is none."""
    rec = solids.get_record(key)
    return solids.get_bytes(rec[name]) if isinstance(rec, dict) and isinstance(rec.get(name), str) else None


def _kept_mesh(solids: cache.Store, key: str) -> tuple[bytes, dict] | None:
    """(STL bytes, measurements) kept for a kept solid by the unit that exported it first."""
    rec = solids.get_record(key)
    if not isinstance(rec, dict) or not isinstance(rec.get("stl"), str) or not isinstance(rec.get("measured"), dict):
        return None
    data = solids.get_bytes(rec["stl"])
    return None if data is None else (data, rec["measured"])


def keep_unit(store: cache.Store, key: str, exported: list[dict]) -> dict:
    """The record of a freshly exported unit, kept in the cache with its files and solids; the
    bytes stay with it in memory (``blobs``, ``breps``) for this build."""
    records, blobs, breps = [], {}, {}
    for e in exported:
        files = {kind: store.put_bytes(e[kind]) for kind in ("stl", "step")}
        blobs.update({files[kind]: e[kind] for kind in ("stl", "step")})
        if e["brep"] is not None:
            files["brep"] = store.put_bytes(e["brep"])
            breps[files["brep"]] = e["brep"]
        records.append({**e["part"], "measured": e["measured"], "files": files, "same_solid_as": e["same_solid_as"],
                        "made_as": e["made_as"]})
    rec = {"parts": records}
    store.put_record(key, rec)
    return {**rec, "blobs": blobs, "breps": breps}


def _record(rec: dict) -> dict:
    """A unit's record without the bytes it carries in this process."""
    return {k: v for k, v in rec.items() if k not in ("blobs", "breps")}


def _solids(store: cache.Store, rec: dict) -> list | None:
    """The solids of a unit not built in this process, from their BREP (parts that shared a
    solid share it again)."""
    out = []
    for p in rec["parts"]:
        if p["same_solid_as"] is not None:
            out.append(out[p["same_solid_as"]])
            continue
        sha = p["files"].get("brep", "")
        data = rec.get("breps", {}).get(sha) or store.get_bytes(sha)
        if data is None:
            return None
        out.append(export.read_brep(data))
    return out


def _assembly_from_cache(store: cache.Store, key: str) -> bytes | None:
    rec = store.get_record(key)
    return store.get_bytes(rec["step"]) if isinstance(rec, dict) and isinstance(rec.get("step"), str) else None


def assemble(name: str, plan: Plan, path: Path, store: cache.Store, made: list[dict]) -> None:
    """assembly.step put together from the units' solids (``made``: per unit in build order, its
    record), each read back from its BREP (the bytes the unit's record carries in this process,
    else the cache's; built again and read back from its BREP if that is gone): never the solid a
    unit made in memory, which may write a last digit differently from the same solid read back
    (:mod:`hwgen.cad.memo`), so a fresh build, a cached one and one whose assembly entry is gone
    write the same bytes. Parts of one solid (a unit's parts sharing one; solids kept
    under one key, :func:`hwgen.cad.memo.made_as`: the tensioner's worms, drive shafts, clamps,
    its wheels of one spool layout, in whichever unit or process they were made) are given one
    solid, which the file holds once and places once per part."""
    parts, one = [], {}         # one: kept key -> the solid every part of that key is given
    for (family, first, spec), rec in zip(units(plan), made):
        solids = _solids(store, rec)
        if solids is None:
            solids = [export.read_brep(export.write_brep(p.solid)) for p in build_unit(plan, family, first, spec)]
        mine = []
        for p, s in zip(rec["parts"], solids):
            if p.get("same_solid_as") is not None:
                s = mine[p["same_solid_as"]]
            elif p.get("made_as"):
                s = one.setdefault(p["made_as"], s)
            mine.append(s)
        parts += [Part(p["name"], p["role"], s, np.asarray(p["placement"], float), tuple(p["color"]))
                  for p, s in zip(rec["parts"], mine)]
    with kernel_errors(plan, None, "write assembly.step"):
        export.write_assembly(parts, name, path)


def backbone_dxf(store: cache.Store, plan: Plan, path: Path) -> None:
    """backbone_template.dxf, from the cache when the strip and the stations did not change (a
    rebuild with nothing changed then imports no ezdxf and draws nothing)."""
    key = cache.entry_key("backbone template", (plan.backbone, list(plan.stations)), code=cache.SOLID_CODE,
                          libraries=("ezdxf",))
    rec = store.get_record(key)
    data = store.get_bytes(rec["dxf"]) if isinstance(rec, dict) and isinstance(rec.get("dxf"), str) else None
    if data is not None:
        path.write_bytes(data)
        return
    export.write_backbone_dxf(plan.backbone, plan.stations, path)
    store.put_record(key, {"dxf": store.put_bytes(path.read_bytes())})


# ---------------------------------------------------------------- in a worker process

def unit_in_worker(plan: Plan, index: int, key: str, store: cache.Store, wait: bool,
                   solids: cache.Store) -> tuple[str, object]:
    """Build and export the ``index``-th unit of the plan in a worker process and keep it in the cache, under the unit's lock: ("ok",
    its record with its bytes, as :func:`keep_unit` gives it); ("busy", None), unless ``wait``, when
    another build holds it or a solid it needs (it is making that now); ("kept", None) when another
    build has kept it meanwhile. A DesignError or InputError comes back as its fields (they do not
    pickle as themselves)."""
    try:
        lock = store.lock(key) if wait else store.try_lock(key)
        if lock is None:
            return "busy", None
        with lock:
            if unit_from_cache(store, key) is not None:
                return "kept", None                  # by another build, while this one looked
            family, first, spec = list(units(plan))[index]
            with kept_in(solids), (nullcontext() if wait else setting_aside()):
                parts = list(build_unit(plan, family, first, spec))
            with tempfile.TemporaryDirectory(prefix="hwgen-unit-") as tmp:
                (Path(tmp) / "stl").mkdir()
                (Path(tmp) / "step").mkdir()
                exported = export_unit(plan, parts, Path(tmp), solids)
            # kept before the lock goes (a build waiting for it reads it); the record, with its
            # bytes, is what the calling process places
            return "ok", keep_unit(store, key, exported)
    except Busy:
        return "busy", None
    except DesignError as e:
        return "design", (e.path, e.message)
    except InputError as e:
        return "input", (e.file, e.path, e.message)


def assembly_in_worker(name: str, plan: Plan, done: list[tuple[str, dict]], breps: dict[str, bytes],
                       store: cache.Store, solids: cache.Store) -> tuple[str, object]:
    """assembly.step's bytes, written in a worker from the units ``done`` ((key, record) in build
    order): their solids read back from their BREP (``breps`` or the cache), else built again."""
    try:
        with tempfile.TemporaryDirectory(prefix="hwgen-assembly-") as tmp:
            path = Path(tmp) / "assembly.step"
            with kept_in(solids):
                assemble(name, plan, path, store, [{**r, "breps": breps} for _, r in done])
            return "ok", path.read_bytes()
    except DesignError as e:
        return "design", (e.path, e.message)


def _result(kind_value):
    kind, value = kind_value
    if kind == "design":
        raise DesignError(*value)
    if kind == "input":
        raise InputError(*value)
    return value
