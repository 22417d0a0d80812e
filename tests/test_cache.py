"""The part cache: files from it are the bytes a fresh build writes; a damaged entry is found and
made again; an edit rebuilds exactly the parts whose specs changed; a cache that cannot be written
costs the reuse, not the build."""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from hwgen import cache
from hwgen.cad.manifest import manifest_parts
from hwgen.model.specs import Hole

from .conftest import PARAMS


# ---------------------------------------------------------------- the store (no CAD)

def test_keys_are_canonical_and_refuse_what_has_no_value():
    h = Hole(x=1.0, z=2.0, axis=(0.0, 1.0, 0.0), diameter=0.8, tendons=("A1",), worst_angle_deg=3.0, in_slot=False)
    assert cache.key(h) == cache.key(Hole(x=1.0, z=2.0, axis=(0.0, 1.0, 0.0), diameter=0.8, tendons=("A1",), worst_angle_deg=3.0, in_slot=False))
    assert cache.key(h) != cache.key(dataclasses.replace(h, x=1.0 + 1e-12))       # floats are exact
    assert cache.key({"b": 1, "a": np.arange(3.0)}) == cache.key({"a": np.array([0.0, 1.0, 2.0]), "b": 1})
    assert cache.key(np.arange(3.0)) != cache.key(np.arange(3))                     # dtype counts
    assert cache.key(float("nan")) == cache.key(float("nan"))
    from hwgen.pipeline import load
    d = load(PARAMS / "prototype.yaml").design
    assert cache.key(d.tensioner) == cache.key(d.tensioner.model_copy())
    with pytest.raises(TypeError):
        cache.key(object())


def test_store_verifies_what_it_reads_and_writes_whole_entries(tmp_path):
    store = cache.Store(tmp_path)
    name = store.put_bytes(b"solid part\n")
    assert name == hashlib.sha256(b"solid part\n").hexdigest()
    assert store.get_bytes(name) == b"solid part\n"
    store.put_record("k" * 64, {"parts": [{"name": "disk_00", "x": 0.1}]})
    assert store.get_record("k" * 64) == {"parts": [{"name": "disk_00", "x": 0.1}]}
    assert not [p for p in tmp_path.rglob(".tmp-*")]                  # no temp file left behind

    obj = next(p for p in tmp_path.rglob("*") if p.is_file() and p.name == name)
    obj.write_bytes(b"solid pbrt\n")                                  # one byte flipped
    assert store.get_bytes(name) is None and not obj.exists()         # found, and removed
    rec = next(tmp_path.rglob("*.json"))
    text = rec.read_text()
    rec.write_text(text.replace("0.1", "0.2"))                        # valid JSON, wrong content
    assert store.get_record("k" * 64) is None and not rec.exists()
    store.put_record("j" * 64, {"a": 1})
    next(tmp_path.rglob("j*.json")).write_text('{"record": {"a"')     # cut short
    assert store.get_record("j" * 64) is None
    assert len(store.corrupt) == 3

    off = cache.Store(None)
    assert off.put_bytes(b"x") == hashlib.sha256(b"x").hexdigest() and off.get_bytes(off.put_bytes(b"x")) is None


def test_an_entry_being_made_by_another_process_is_locked_until_it_ends(tmp_path):
    """While another process holds an entry's lock, try_lock says so (None) and lock() waits;
    the lock frees when its holder ends, even killed; trim() removes the lock files nobody holds."""
    store = cache.Store(tmp_path)
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time\nfrom hwgen import cache\n"
        "with cache.Store(sys.argv[1]).lock('ab12'):\n    print('held', flush=True)\n    time.sleep(60)\n"),
        str(tmp_path)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        assert store.try_lock("ab12") is None
        with store.try_lock("cd34"):                    # another entry is free
            pass
    finally:
        holder.kill()
        holder.wait()
    with store.lock("ab12"):                            # the killed holder let it go
        assert cache.Store(tmp_path).try_lock("ab12") is None       # held here now, by another descriptor
    assert list((tmp_path / cache.LAYOUT / "locks").rglob("*.lock"))
    store.trim(10 ** 9)
    assert not list((tmp_path / cache.LAYOUT / "locks").rglob("*.lock"))
    assert cache.Store(None).try_lock("ab12") is not None              # no store, nothing to share


def test_a_kept_solid_another_build_is_making_is_set_aside_not_made(tmp_path):
    """Under setting_aside(), a kept solid whose lock another process holds raises Busy without
    making it (the pipeline then builds its other units first and comes back)."""
    from hwgen.cad.memo import Busy, key_of, kept, kept_in, setting_aside
    store = cache.Store(tmp_path)
    k = key_of("gear", 7)
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time\nfrom hwgen import cache\n"
        "with cache.Store(sys.argv[1]).lock(sys.argv[2]):\n    print('held', flush=True)\n    time.sleep(60)\n"),
        str(tmp_path), k], stdout=subprocess.PIPE, text=True)
    made = []
    try:
        assert holder.stdout.readline().strip() == "held"
        with kept_in(store), setting_aside(), pytest.raises(Busy):
            kept("gear", 7, lambda: made.append(1))
    finally:
        holder.kill()
        holder.wait()
    assert made == []


@pytest.mark.slow
def test_a_tensioner_unit_whose_gear_another_build_is_making_is_set_aside(tmp_path):
    """The real path: building the prototype's tensioner unit while another process holds its
    wheel gear's lock raises Busy out of the unit's builder (not a kernel failure), under
    setting_aside(); the pipeline then makes the other units first."""
    from hwgen import pipeline
    from hwgen.cad.families import build_unit, units
    from hwgen.cad.memo import Busy, key_of, kept_in, setting_aside
    plan = pipeline.design_plan(pipeline.load(PARAMS / "prototype.yaml"))
    store = cache.Store(tmp_path)
    k = key_of("throated wheel gear", plan.tensioner_layout.pair)
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time\nfrom hwgen import cache\n"
        "with cache.Store(sys.argv[1]).lock(sys.argv[2]):\n    print('held', flush=True)\n    time.sleep(120)\n"),
        str(tmp_path), k], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        family, first, unit = next(u for u in units(plan) if u[0].name == "tensioner")
        with kept_in(store), setting_aside(), pytest.raises(Busy):
            list(build_unit(plan, family, first, unit))
    finally:
        holder.kill()
        holder.wait()


def test_a_cache_that_cannot_be_written_turns_itself_off(tmp_path):
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder")
    store = cache.Store(a_file / "below")
    store.put_bytes(b"x")
    assert not store.enabled and "a_file" in store.unwritable


def test_default_folder_is_outside_the_outputs(monkeypatch, tmp_path):
    monkeypatch.delenv(cache.ENV_DIR, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.default_dir() == tmp_path / "xdg" / "hwgen"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert cache.default_dir() == Path(os.path.expanduser("~")) / ".cache" / "hwgen"
    monkeypatch.setenv(cache.ENV_DIR, str(tmp_path / "c"))
    assert cache.default_dir() == tmp_path / "c"


# ---------------------------------------------------------------- builds through the cache

def _tree(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _records(root: Path, what: str) -> list[Path]:
    return [p for p in root.rglob("*.json") if what in json.loads(p.read_text())["record"]]


@pytest.fixture(scope="module")
def fresh(tmp_path_factory):
    """The prototype's parts and files built with an empty cache of their own: every part is built
    afresh (and kept)."""
    from hwgen.pipeline import build, load
    root = tmp_path_factory.mktemp("cache-test")
    loaded = load(PARAMS / "prototype.yaml")
    res = build(loaded, root / "fresh", post_build=False, cache_dir=root / "cache")
    assert sorted(res.built) == sorted(p.name for p in res.manifest.parts)
    return loaded, root, _tree(res.folder)


@pytest.mark.slow
def test_cached_build_has_the_bytes_of_a_fresh_one(fresh):
    from hwgen.pipeline import build
    loaded, root, first = fresh
    again = build(loaded, root / "again", post_build=False, cache_dir=root / "cache")
    assert again.built == []
    assert _tree(again.folder) == first                   # every STL, STEP, the assembly, DXF and manifest
    # the assembly put together from the cached parts' BREP when its own entry is gone
    for p in _records(root / "cache", "step"):
        p.unlink()
    third = build(loaded, root / "third", post_build=False, cache_dir=root / "cache")
    assert third.built == [] and _tree(third.folder) == first
    # the tensioner and the base frame's gearing built again (their units' entries gone) around the
    # solids kept from the first build: the throated gear, the worm, the drive shaft, the clamp plate
    # and a wheel per spool layout; the frame's own worm and drive shaft, and the tensioner's gear. A
    # solid read back from its BREP is what the first build had too (hwgen.cad.memo.kept): the frame's
    # worm, whose thread's end planes a BREP round trip writes differently, writes the same bytes
    def records(role):
        return [p for p in _records(root / "cache", "parts")
                if json.loads(p.read_text())["record"]["parts"][0]["role"].startswith(role)]

    def made_as(recs):
        return {q["made_as"] for p in recs for q in json.loads(p.read_text())["record"]["parts"] if q.get("made_as")}

    tensioner, frame = records("tensioner"), records("base_frame")
    assert frame, "the prototype stands in its base frame"
    names = [q["name"] for p in tensioner + frame for q in json.loads(p.read_text())["record"]["parts"]]
    wheels = {first[f"stl/{n}.stl"] for n in names if n.startswith("tensioner_wheel")}
    kept = {p.stem for p in _records(root / "cache", "brep")}
    assert len(made_as(tensioner)) == 3 + len(wheels)            # worm, drive shaft, clamp plate, wheels
    # and the throated gear, which the wheels (the frame's too) are cut from and no part is
    assert made_as(tensioner) | made_as(frame) < kept and len(kept) == len(made_as(tensioner) | made_as(frame)) + 1
    for p in tensioner + frame:
        p.unlink()
    fourth = build(loaded, root / "fourth", post_build=False, cache_dir=root / "cache")
    assert sorted(fourth.built) == sorted(names) and _tree(fourth.folder) == first


@pytest.mark.slow
def test_a_damaged_entry_is_found_and_rebuilt(fresh):
    from hwgen.pipeline import build
    loaded, root, first = fresh
    store = root / "cache"
    stl = next(p for p in store.rglob("*") if p.is_file() and p.name == first["stl/disk_03.stl"])
    data = bytearray(stl.read_bytes())
    data[200] ^= 0xFF
    stl.write_bytes(bytes(data))
    record = next(p for p in _records(store, "parts")
                  if [q["name"] for q in json.loads(p.read_text())["record"]["parts"]] == ["disk_05"])
    record.write_text(record.read_text()[:100])
    res = build(loaded, root / "repaired", post_build=False, cache_dir=store)
    assert sorted(res.built) == ["disk_03", "disk_05"]
    assert _tree(res.folder) == first


@pytest.mark.slow
def test_editing_one_tendon_rebuilds_exactly_the_parts_whose_specs_changed(tmp_path):
    """paper-table2's C1 is a table: moving one of its rows moves the eyelets near that station and
    nothing else; the build makes those disks (and whatever else's spec the move changed) again."""
    from hwgen.pipeline import build, design_plan, load
    doc = yaml.safe_load((PARAMS / "paper-table2.yaml").read_text())
    src = tmp_path / "paper-table2.yaml"
    src.write_text(yaml.safe_dump(doc, sort_keys=False))
    before = load(src)
    # through the session's cache: paper-table2's parts are in it once any test built the design
    # (the same specs, whatever the file), the edited design's never are
    first = build(before, tmp_path / "out", post_build=False)
    c1 = next(t for t in doc["tendons"] if t["name"] == "C1")
    c1["routing"]["table"][8][1] -= 0.5
    src.write_text(yaml.safe_dump(doc, sort_keys=False))
    after = load(src)
    second = build(after, tmp_path / "out", post_build=False)

    old, new = design_plan(before), design_plan(after)
    changed = [b.name for a, b in zip(old.disks, new.disks) if a != b]
    changed += [new.backbone.name] if old.backbone != new.backbone else []
    if cache.key(old.tensioner_layout) != cache.key(new.tensioner_layout):     # holds arrays: compared by value
        changed += [p.name for p in first.manifest.parts if p.role.startswith("tensioner")]
    assert "disk_08" in changed and len(changed) < len(new.disks)         # a local edit
    assert second.built == changed
    # the row is in the middle: the tip eyelets, the tendons' runs and the tensioner's layout stay,
    # so none of the tensioner's parts is made again
    assert old.disks[-1] == new.disks[-1] and cache.key(old.tensioner_layout) == cache.key(new.tensioner_layout)
    assert not [n for n in second.built if n.startswith("tensioner")]
    moved = {p.name for p, q in zip(manifest_parts(first.manifest), manifest_parts(second.manifest))
             if p.files["stl"].sha256 != q.files["stl"].sha256}
    assert moved <= set(changed)
    # what was reused is what a fresh build of the edited design makes: no unit's inputs miss
    # something its builder reads (for this edit)
    fresh = build(after, tmp_path / "fresh", post_build=False, cache_dir=None)
    assert _tree(second.folder) == _tree(fresh.folder)


def test_a_no_op_rebuild_reads_the_cache_without_the_cad_kernel(built, tmp_path):
    """Once the session's cache holds every part of the prototype, building it again (in a fresh
    process) builds nothing and never imports CadQuery or OCP."""
    built("prototype")
    code = ("import sys\nfrom hwgen.pipeline import build, load\n"
            "r = build(load(sys.argv[1]), sys.argv[2], post_build=False)\n"
            "print(len(r.built), 'cadquery' in sys.modules, 'OCP' in sys.modules)")
    r = subprocess.run([sys.executable, "-c", code, str(PARAMS / "prototype.yaml"), str(tmp_path / "o")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["0", "False", "False"]


@pytest.mark.slow
def test_the_stages_after_the_files_are_reused_with_the_same_bytes(built, tmp_path):
    """With every part and stage of the prototype in the session's cache, a whole build (checks,
    bill of materials, pictures) takes them all from it, and writes the session build's bytes;
    another number of Monte Carlo samples is another key: the checks run again."""
    from hwgen.pipeline import build, load
    first = _tree(built("prototype"))
    loaded = load(PARAMS / "prototype.yaml")
    again = build(loaded, tmp_path / "again")
    assert again.built == [] and again.reused == ["checks", "bom", "plates", "pictures", "marks", "guide", "view"]
    assert _tree(again.folder) == first
    assert again.report == json.loads((again.folder / "report.json").read_text())


def test_a_stage_is_reused_only_for_the_same_files_manifest_plan_and_options(tmp_path):
    """The stage memo on a stand-in stage: what it wrote and set comes back without running it;
    another input file, manifest, plan (a setting the stages read) or build option the stage reads
    (the checks' sample count) runs it again; an option it does not read (the pictures) does not."""
    from hwgen.options import BuildOptions
    from hwgen.cad.manifest import Added, Manifest
    from hwgen.engine.context import Hashes, StageInput, StageResult
    from hwgen.engine.stagecache import cached_stage
    from hwgen.model.plan import make_plan
    from hwgen.pipeline import load

    runs = []

    def stage(s):
        runs.append(1)
        (s.folder / "report.json").write_text(json.dumps({"n": len(runs)}))
        return StageResult(Added({"checks_ok": True}), {"n": len(runs)})

    design = load(PARAMS / "prototype.yaml").design
    P = make_plan(design)

    store = cache.Store(tmp_path / "cache")

    def run(files: dict, name: str, plan=P, options=BuildOptions()):
        folder = tmp_path / f"f{len(list(tmp_path.iterdir()))}"
        folder.mkdir()
        for path, text in files.items():
            (folder / path).write_text(text)
        reused = []
        manifest = Manifest(name, "0", "", "", [], {}, {}, (), {})
        out = cached_stage(store, Hashes(), "checks", stage, StageInput(plan, folder, manifest, options=options), reused)
        return out, manifest.adding(out.added), (folder / "report.json").read_text(), reused

    first = run({"a.stl": "x"}, "d")
    assert first[3] == [] and len(runs) == 1
    again = run({"a.stl": "x"}, "d")
    assert again == (first[0], first[1], first[2], ["checks"]) and len(runs) == 1
    run({"a.stl": "y"}, "d")
    run({"a.stl": "x"}, "e")

    Q = make_plan(design.model_copy(update={"bom": design.bom.model_copy(update={"spool_mm": 151.0})}))
    run({"a.stl": "x"}, "d", Q)
    run({"a.stl": "x"}, "d", options=BuildOptions(check_samples=32))
    assert len(runs) == 5
    run({"a.stl": "x"}, "d", options=BuildOptions(pictures=False))
    assert len(runs) == 5


@pytest.mark.slow
def test_parts_writes_only_the_parts_it_names_and_the_whole_manifest(built, tmp_path):
    """--parts 'disk_*' (the session's cache holds the prototype): the disks' files and nothing
    else, a manifest with every part as the whole build has it; a pattern that names no part is
    bad input naming --parts."""
    from hwgen.pipeline import build, load, stale_reason
    from .test_hostile import run_cli
    whole = json.loads((built("prototype") / "manifest.json").read_text())
    loaded = load(PARAMS / "prototype.yaml")
    res = build(loaded, tmp_path / "out", parts="disk_*")
    disks = sorted(p["name"] for p in whole["parts"] if p["name"].startswith("disk_"))
    assert sorted(_tree(res.folder)) == ["manifest.json"] + [f"step/{n}.step" for n in disks] + \
        [f"stl/{n}.stl" for n in disks]
    assert [p.to_json() for p in res.manifest.parts] == whole["parts"] and res.manifest.parts_written["names"] == disks
    for n in disks:
        assert _tree(res.folder)[f"stl/{n}.stl"] == _tree(built("prototype"))[f"stl/{n}.stl"]
    assert "missing" in stale_reason(res.folder, loaded)          # hwgen check builds it whole first
    code, stdout, stderr, escaped = run_cli("build", str(PARAMS / "prototype.yaml"), "--out", str(tmp_path / "o2"),
                                            "-q", "--parts", "tensioner_w*")
    n = sum(p["name"].startswith(("tensioner_worm", "tensioner_wheel")) for p in whole["parts"])
    assert escaped is None and code == 0 and f"{n} of {len(whole['parts'])} parts written" in stdout, stdout
    code, _, stderr, escaped = run_cli("build", str(PARAMS / "prototype.yaml"), "--out", str(tmp_path / "o3"),
                                       "-q", "--parts", "gear_*")
    assert escaped is None and code == 2 and "--parts: 'gear_*' matches none of the parts: disk_00" in stderr
    assert not (tmp_path / "o3" / "prototype").exists()


@pytest.mark.slow
def test_parts_built_in_worker_processes_have_the_bytes_of_a_serial_build(fresh, built, tmp_path, monkeypatch):
    """--jobs 2 into an empty cache of its own: every unit is built in a worker process (the
    tensioner's channels in both, around the solids they share), the assembly is put together
    in one of them (from its own solids and the other's BREP); every file has the bytes of the
    build in one process. The checks are measured once, in the build's own thread while a
    worker writes the assembly, the gear checks in a process of their own (never in this one),
    and their report has the bytes of a build's in one process."""
    import threading

    from hwgen.checks import gear_mesh, run
    from hwgen.outputs.pictures import BACKEND_ENV
    from hwgen.pipeline import build
    monkeypatch.setenv(BACKEND_ENV, "none")
    measured_in, gears_here = [], []
    real, real_gears = run.measure, gear_mesh.measure_pair
    monkeypatch.setattr(run, "measure", lambda *a: measured_in.append(threading.current_thread().name) or real(*a))
    monkeypatch.setattr(gear_mesh, "measure_pair", lambda *a: gears_here.append(1) or real_gears(*a))
    loaded, _, first = fresh
    res = build(loaded, tmp_path / "out", cache_dir=tmp_path / "cache", jobs=2)
    assert sorted(res.built) == sorted(p.name for p in res.manifest.parts)
    tree = _tree(res.folder)
    assert {f: tree.get(f) for f in first if f != "manifest.json"} == {f: first[f] for f in first if f != "manifest.json"}
    assert measured_in == ["hwgen-measure"] and gears_here == []
    assert (res.folder / "report.json").read_bytes() == (built("prototype") / "report.json").read_bytes()


@pytest.mark.slow
def test_hwgen_check_of_files_it_measured_before_answers_from_the_cache(built, tmp_path, monkeypatch):
    """The same files, manifest, design and environment: the report from the cache, not measured
    again; a file edited since: measured again (and the edit is reported)."""
    import shutil

    from hwgen import pipeline
    from hwgen.pipeline import load
    shutil.copytree(built("prototype"), tmp_path / "out" / "prototype")
    loaded = load(PARAMS / "prototype.yaml")
    runs = []
    real = pipeline.run_checks
    monkeypatch.setattr(pipeline, "run_checks", lambda *a: runs.append(1) or real(*a))
    first, _, why = pipeline.check(loaded, tmp_path / "out", cache_dir=tmp_path / "cache")
    again, _, _ = pipeline.check(loaded, tmp_path / "out", cache_dir=tmp_path / "cache")
    assert why is None and len(runs) == 1 and again == first
    stl = tmp_path / "out" / "prototype" / "stl" / "jig_2.stl"
    data = bytearray(stl.read_bytes())
    data[10] ^= 1                                         # in the STL's free-text header: the same mesh
    stl.write_bytes(bytes(data))
    edited, _, _ = pipeline.check(loaded, tmp_path / "out", cache_dir=tmp_path / "cache")
    assert len(runs) == 2
    assert any(c["id"] == "files.unchanged" and not c["passed"] for c in edited["checks"])


@pytest.mark.slow
def test_two_builds_sharing_one_empty_cache_at_once_both_finish_whole(tmp_path):
    """Two processes build the prototype at once into one empty cache, one in itself, one in a
    worker process (``jobs=1``, as the CLI does: it never imports CadQuery itself): both finish,
    with the same files, and between them they make each part once (a unit the other is making
    waits for its lock and is read from the cache); a third build then takes everything from the
    cache and writes those bytes again."""
    code = ("import json, sys\nfrom hwgen.pipeline import build, load\n"
            "if __name__ == '__main__':\n"
            "    r = build(load(sys.argv[1]), sys.argv[2], post_build=False, cache_dir=sys.argv[3], jobs=int(sys.argv[4]))\n"
            "    print(json.dumps(r.built), 'cadquery' in sys.modules)")
    runs = [subprocess.Popen([sys.executable, "-c", code, str(PARAMS / "prototype.yaml"), str(tmp_path / out),
                              str(tmp_path / "cache"), jobs], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for out, jobs in (("a", "0"), ("b", "1"))]
    imported, built = [], []
    for r in runs:
        stdout, stderr = r.communicate(timeout=600)
        assert r.returncode == 0, stderr
        made, cq = stdout.strip().splitlines()[-1].rsplit(" ", 1)
        imported.append(cq)
        built += json.loads(made)
    assert imported == ["True", "False"]
    a, b = _tree(tmp_path / "a" / "prototype"), _tree(tmp_path / "b" / "prototype")
    assert a == b
    assert sorted(built) == sorted(Path(f).stem for f in a if f.startswith("stl/"))
    assert not list((tmp_path / "cache").rglob(".tmp-*"))
    from hwgen.pipeline import build, load
    third = build(load(PARAMS / "prototype.yaml"), tmp_path / "c", post_build=False, cache_dir=tmp_path / "cache")
    assert third.built == [] and _tree(third.folder) == a


def test_the_cache_keeps_to_its_size_dropping_the_least_recently_used(tmp_path, monkeypatch):
    """trim() removes the entries used longest ago (a read counts as a use) until the store fits;
    sizes read as a person writes them; a bad size is bad input naming the flag or the variable."""
    store = cache.Store(tmp_path)
    names = [store.put_bytes(bytes([k]) * 1000) for k in range(5)]
    store.put_record("r" * 64, {"a": 1})
    paths = {n: next(p for p in tmp_path.rglob(n)) for n in names}
    for k, n in enumerate(names):                      # written in order, a second apart
        os.utime(paths[n], (1000 + k, 1000 + k))
    os.utime(next(tmp_path.rglob("r*.json")), (999, 999))
    assert store.get_bytes(names[0]) is not None      # read: now the most recently used
    removed, freed = store.trim(3000)
    assert removed == 3 and freed >= 2000
    assert [store.get_bytes(n) is not None for n in names] == [True, False, False, True, True]
    assert store.get_record("r" * 64) is None          # the oldest of all went first
    assert store.trim(10 ** 9) == (0, 0) and cache.Store(None).trim(0) == (0, 0)
    assert [cache.parse_size(t) for t in ("2G", "500M", "1.5GB", "300000", "64KiB")] == \
        [2 * 1024 ** 3, 500 * 1024 ** 2, int(1.5 * 1024 ** 3), 300000, 64 * 1024]
    from hwgen.options import BuildOptions
    monkeypatch.setenv(cache.ENV_SIZE, "100M")
    assert BuildOptions.from_environment().cache_size == 100 * 1024 ** 2
    assert BuildOptions.from_environment(cache_size=5).cache_size == 5        # the command line's, over it
    monkeypatch.delenv(cache.ENV_SIZE)
    assert BuildOptions.from_environment().cache_size == cache.DEFAULT_SIZE
    from .test_hostile import run_cli
    code, _, stderr, escaped = run_cli("build", str(PARAMS / "prototype.yaml"), "--out", str(tmp_path / "o"),
                                       "--cache-size", "lots")
    assert escaped is None and code == 2 and "--cache-size: lots is not a size" in stderr
    monkeypatch.setenv(cache.ENV_SIZE, "-3G")
    code, _, stderr, escaped = run_cli("build", str(PARAMS / "prototype.yaml"), "--out", str(tmp_path / "o"))
    assert escaped is None and code == 2 and "HWGEN_CACHE_SIZE" in stderr and not (tmp_path / "o").exists()


def test_work_done_ahead_that_fails_is_said_not_swallowed(monkeypatch, tmp_path):
    """The checks' measurement made ahead (beside assembly.step) that raises is done again by the
    checks, and what failed is kept for the build's notes rather than dropped (issue 49)."""
    import threading

    from hwgen import pipeline
    from hwgen.checks import run as checks_run
    from hwgen.engine.concurrency import Ahead

    plan = pipeline.design_plan(pipeline.load(PARAMS / "prototype.yaml"))

    def broken(*_):
        raise ValueError("a mesh with no faces")

    monkeypatch.setattr(checks_run, "measure", broken)
    ahead = Ahead(cache.Store(tmp_path / "store"), plan, threading.Event(), None)
    ahead._measure(tmp_path, None, "key")
    assert ahead.found is None
    assert ahead.failures == ["the checks' measurement: ValueError: a mesh with no faces"]
