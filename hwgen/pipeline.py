"""The order of the stages, and the one place that knows it.

    read (params) → feasibility (model) → plan (model) → parts (cad) → files and manifest (cad)
    → checks (report.json, summary.md; the tendon states' statics: stiffness.json, stiffness.png,
    gravity.png) → plots (lengths.png, tolerance.png, sag.png) → bill of materials
    → print plates (plates/) → pictures → assembly guide (guide/)

Every build writes into a fresh staging folder beside the target; only when every file is
complete is it swapped in for ``out/<design>/`` in one step (:func:`hwgen.atomic.new_folder`).
A failure or a kill at any point leaves the old outputs exactly as they were; two builds at
once both finish, and the last to finish is what the folder holds. ``hwgen check`` reads the
outputs as they are; ``hwgen render`` draws into a copy of them and swaps it in the same way;
both build first only when the outputs are missing or made from other parameters.

Every build goes through the cache (:mod:`hwgen.cache`, ``--cache-dir``, ``--no-cache``): each
unit of parts (:mod:`hwgen.cad.families`) is keyed by the frozen values its builder reads and
copied from the cache when they did not change; assembly.step by its units' keys; each stage
after the files by every file it reads, the manifest, the plan (every value the stages read from
the design, as the model resolved it), the environment it reads and hwgen's code. What comes
from the cache has the bytes a fresh build writes.

An output root that cannot be written (not a folder, no permission, a full disk) is bad input
naming ``--out`` (:class:`hwgen.errors.InputError`), like any other.
"""
from __future__ import annotations

import contextvars
import errno
import fnmatch
import hashlib
import json
import os
import queue
import shutil
import tempfile
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import ExitStack, contextmanager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import __version__, cache, heap, params, processes
from .atomic import new_folder, side_folder, snapshot, write_json
from .cad import Part, export
from .cad.families import build_unit, kernel_errors, part_count, units
from .errors import DesignError, InputError, clip
from .cad.manifest import (MANIFEST, ManifestPart, describe, design_report, entry, manifest_files, measure,
                           read_manifest, sha256, write_manifest)
from .cad.memo import Busy, kept_in, made_as, setting_aside
from .checks.meshes import reading_early
from .checks.report import REPORT, read_report, write_report, write_summary
from .model import feasibility
from .model.plan import Plan, make_plan
from .outputs import bom, guide, pictures, plates as print_plates
from .outputs.plots import plot_lengths, plot_sag, plot_tolerance
from .outputs.stiffness import plot_gravity, plot_stiffness

PLOT, SUMMARY, SAG, TOLERANCE = "lengths.png", "summary.md", "sag.png", "tolerance.png"
STIFFNESS, STIFFNESS_PLOT, GRAVITY_PLOT = "stiffness.json", "stiffness.png", "gravity.png"


def load(path: str | Path) -> params.LoadedDesign:
    """Read a design YAML (and its bases), check it against the schema, then check that it can be built.

    Raises :class:`hwgen.errors.InputError` naming, for every fault, the file and the field path.
    """
    loaded = params.read(path)
    found = feasibility.problems(loaded.design)
    if found:
        raise params.refuse(found, loaded.layers)
    return loaded


def design_plan(loaded: params.LoadedDesign, tensioner_record: dict | None = None) -> Plan:
    """The plan of a loaded design, with everything its part families need to be built (holes
    the disks and the strip can take, the tensioner's layout); raises
    :class:`hwgen.errors.DesignError` naming the field.
    Every command starts from it, so they all refuse the same designs the same way."""
    plan = make_plan(loaded.design, tensioner_record)
    feasibility.check_plan(plan, loaded.design)
    part_count(plan)       # every part family can be made from it (the tensioner needs its layout)
    return plan


WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EIO, errno.EFBIG}


def _related(path, root: Path) -> bool:
    p = Path(os.path.abspath(path))
    return p == root or root in p.parents or p in root.parents


@contextmanager
def output_errors(out_root: Path) -> Iterator[None]:
    """An OS error writing under ``out_root`` (or making it) is bad input naming ``--out``."""
    try:
        yield
    except OSError as e:
        root = Path(os.path.abspath(out_root))
        if not (_related(e.filename, root) if e.filename else e.errno in WRITE_ERRNOS):
            raise
        if isinstance(e, (FileExistsError, NotADirectoryError)) and not root.is_dir():
            what = "is a file, not a folder" if root.exists() else "lies below a file, not a folder"
            raise InputError(out_root, "--out", what) from None
        raise InputError(out_root, "--out", f"cannot write the outputs here ({e.strerror or e})") from None


# ---------------------------------------------------------------- stages after the files

def run_checks(folder: Path, manifest: dict, plan: Plan) -> dict:
    """:func:`checked`'s report."""
    return checked(folder, manifest, plan)[0]


def checked(folder: Path, manifest: dict, plan: Plan) -> tuple[dict, dict]:
    """:func:`hwgen.checks.run.run_checks`, imported when the checks run: it brings scipy's
    optimisers (about a second), which a build whose stages all come from the cache never needs.
    In a build, with what the work ahead measured on these very files while assembly.step was
    written (:meth:`_Ahead.measure`), when it did. Then the tendon states' statics
    (:func:`statics`), whose stiffening joins the report. Returns (report, statics)."""
    from .checks.run import run_checks as run
    ahead = _MEASURED_AHEAD.get()
    report = run(folder, manifest, plan, ahead.measured(folder, manifest) if ahead is not None else None)
    try:
        study = statics(plan, report.get("gravity"))
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as e:      # the statics says why, the rest stands
        study = {"skipped": f"the tendon states' statics was not computed: {e}"}
    report["stiffening"] = study.get("stiffening") or ({"skipped": study["skipped"]} if "skipped" in study else None)
    return report, study


def statics(plan: Plan, measured: dict | None, which: list[str] | None = None) -> dict:
    """The statics of the plan's tendon states (or those named; :func:`hwgen.model.stiffness.study`)
    with the weights the checks measured (a report's ``gravity`` section, else the plan's
    estimate): stiffness.json's content, remembered in the active cache by what it reads (the
    described robot, its states and orientations, the code)."""
    from .model import stiffness as sf      # scipy's optimisers: only the checks and `hwgen stiffness`
    todo = [s for s in sf.states(plan) if not which or s.name in which]
    inputs = (sf.describe(plan, measured), todo, sf.ORIENTATIONS, sf.STUDY_H_MAX)
    return cache.remembered("stiffness study", inputs, lambda: sf.study(plan, which, measured=measured))


def checks_stage(plan: Plan, folder: Path, manifest: dict, no_report: None) -> dict:
    """Measure the fresh files: report.json, summary.md, lengths.png, tolerance.png and sag.png; the checks go
    into the manifest. And the tendon states' statics: stiffness.json, stiffness.png, gravity.png."""
    report, study = checked(folder, manifest, plan)
    manifest["checks"] = report["checks"]
    manifest["checks_ok"] = report["ok"]
    write_report(report, folder)
    write_summary(report, folder / SUMMARY)
    plot_lengths(report, folder / PLOT)
    plot_tolerance(report, folder / TOLERANCE)
    plot_sag(report, manifest["design_report"], folder / SAG)
    write_json(folder / STIFFNESS, study)
    if "skipped" not in study:
        plot_stiffness(study, folder / STIFFNESS_PLOT)
        plot_gravity(study, folder / GRAVITY_PLOT)
    return report


def bom_stage(plan: Plan, folder: Path, manifest: dict, report: dict | None) -> None:
    """bom.csv and bom.md, from the manifest and the checks' report."""
    bom.write_bom(folder, manifest, plan, report)


def plates_stage(plan: Plan, folder: Path, manifest: dict, report: dict | None) -> dict:
    """plates/plate_NN.3mf and plates/plates.md: the printed parts on the printer's plates."""
    return print_plates.write_plates(folder, manifest, plan.process, plan.plates)


def pictures_stage(plan: Plan, folder: Path, manifest: dict, report: dict | None) -> None:
    """exploded.png, assembled.png, bent.png, exploded.svg and the guide's step pictures; a missing
    backend is recorded, not raised."""
    pictures.draw(folder, manifest, plan.render, bom.family_table(manifest, plan.process.name),
                  guide.picture_jobs(folder, manifest, plan))


def marks_stage(plan: Plan, folder: Path, manifest: dict, report: dict | None) -> None:
    """exploded.png and bent.png drawn again with what fails marked (the pictures stage ran beside
    the checks, before their verdict); nothing when every check passes."""
    pictures.mark_failures(folder, manifest, plan.render)


def guide_stage(plan: Plan, folder: Path, manifest: dict, report: dict | None) -> dict:
    """guide/assembly.md and guide/assembly.html, from bom.csv, the manifest and the step pictures."""
    return guide.write_guide(folder, manifest, plan)


# (name, stage(plan, folder, manifest, report)) in the order a build runs them on its fresh files; ``report``
# is the checks' (None for the checks themselves, and for a stage that runs beside them)
AFTER_FILES: list[tuple[str, Callable[[Plan, Path, dict, dict | None], object]]] = [
    ("checks", checks_stage), ("bom", bom_stage), ("plates", plates_stage), ("pictures", pictures_stage),
    ("marks", marks_stage), ("guide", guide_stage)]
DRAWING_STAGES = ("bom", "pictures", "guide")     # what `hwgen render` runs on existing outputs


def draw(plan: Plan, folder: Path, manifest: dict) -> None:
    """The drawing stages (bill of materials, pictures) on a folder that has its files and report."""
    report = read_report(folder)
    for name, stage in AFTER_FILES:
        if name in DRAWING_STAGES:
            stage(plan, folder, manifest, report)


# ---------------------------------------------------------------- build

@dataclass
class BuildResult:
    folder: Path
    manifest: dict
    plan: Plan
    report: dict | None = None        # the checks' report, when they ran
    built: list[str] = field(default_factory=list)     # the parts made afresh (the others came from the cache)
    reused: list[str] = field(default_factory=list)    # the stages after the files taken from the cache
    cache_notes: list[str] = field(default_factory=list)   # damaged entries found (and rebuilt), a cache turned off


def build(loaded: params.LoadedDesign, out_root: Path, progress: Callable[[str, int, int], None] | None = None,
          post_build: bool = True, cache_dir: Path | None | bool = True, parts: str | None = None,
          jobs: int = 0) -> BuildResult:
    """Build every part and file of the design into ``out_root/<design>/``, then (``post_build``)
    run the stages after the files. ``progress(part_name, done, total)`` follows each part.
    ``cache_dir``: the part cache's folder (True: :func:`hwgen.cache.default_dir`; None or False:
    build everything afresh and keep nothing).

    ``parts``: a shell pattern (``disk_*``); only the parts whose names match get their STL and
    STEP written. The manifest still lists every part as a whole build would (the others' entries
    from the cache, or built for it and not written); the assembly, the DXF and the stages after
    the files describe the whole robot and are left out, so ``hwgen check`` sees the folder as
    incomplete and builds it whole first. A pattern that matches no part is bad input.

    ``jobs``: worker processes that build the parts not in the cache and the assembly (0: all in
    this process, which then holds the CAD kernel's memory through the checks)."""
    store = cache.Store(cache.default_dir() if cache_dir is True else (cache_dir or None))
    layout_key = cache.key("tensioner layout", loaded.design, __version__, cache.code())
    plan = design_plan(loaded, _kept_layout(store, layout_key))
    total = part_count(plan)
    out_root = Path(out_root)
    target = out_root / loaded.name
    limit = _limit()                    # bad input before anything is written
    select = None if parts is None else (lambda name: fnmatch.fnmatchcase(name, parts))
    measured = threading.Event()        # the checks' measurement is over (its meshes let go of)
    with output_errors(out_root), new_folder(target) as tmp, _hashing_once(), ExitStack() as stack:
        # what this build's processes and threads hand each other (the solids its units share,
        # the values its work ahead finds for the checks): the cache, or without one a store of the
        # build's own that goes with it (it starts empty: every value is made afresh)
        scratch = store if store.enabled else cache.Store(
            Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="hwgen-scratch-"))))
        ahead = _Ahead(scratch, plan, measured) if post_build and select is None else None
        side: dict[str, tuple] = {}

        def placed(early: dict) -> None:
            # every part's files are in: the stages beside the others start now, while the
            # assembly is written and the checks' work ahead finishes
            pool = stack.enter_context(ThreadPoolExecutor(max_workers=max(1, len(BESIDE))))
            side.update(_start_beside(store, plan, tmp, target, early, stack, pool, measured))

        def measurable(early: dict) -> None:
            # and the strip's template: the checks measure them while the assembly is written
            ahead.measure(tmp, early)

        token = _WHILE_WORKERS_BUILD.set(ahead)
        try:
            whole = ahead is not None           # every part written and the stages after them to run
            manifest, built = _write_files(loaded, plan, tmp, total, progress, store, scratch, select, jobs,
                                           placed if whole else None, measurable if whole else None)
        except BaseException:
            if ahead is not None:
                ahead.abandon()
            raise
        finally:
            _WHILE_WORKERS_BUILD.reset(token)
        if select is not None:
            written = [p["name"] for p in manifest["parts"] if select(p["name"])]
            if not written:
                names = ", ".join(p["name"] for p in manifest["parts"])
                raise InputError(loaded.source, "--parts",
                                 f"{clip(parts)!r} matches none of the parts: {clip(names, 200)}")
            manifest["parts_written"] = {"pattern": parts, "names": written}
            post_build = False
        done, reused = {}, []
        try:
            if post_build:
                ahead_token = _MEASURED_AHEAD.set(ahead)
                try:
                    with cache.using(store), reading_early(ahead.meshes if ahead is not None else {}):
                        _after_files(store, plan, tmp, manifest, done, reused, side, measured)
                finally:
                    _MEASURED_AHEAD.reset(ahead_token)
        finally:
            measured.set()
            if ahead is not None:
                ahead.join()        # the checks met what it did (waiting for the entry it was making), or did it
                ahead.meshes.clear()
        write_manifest(tmp, manifest)
    chosen = tensioner_record(manifest)
    if chosen is not None:
        store.put_record(layout_key, {"search": chosen})
    _trim(store, limit)
    notes = [f"damaged entries rebuilt: {', '.join(store.corrupt)}"] if store.corrupt else []
    notes += [f"not written, so not used: {store.unwritable}"] if store.unwritable else []
    return BuildResult(target, manifest, plan, done.get("checks"), built, reused, notes)


@contextmanager
def _hashing_once() -> Iterator[None]:
    token = _HASHED.set({})
    try:
        yield
    finally:
        _HASHED.reset(token)


def _kept_layout(store: cache.Store, key: str) -> dict | None:
    """The tensioner layout's search record a build of this very design (and code) kept: the plan
    lays out the arrangement it names instead of searching again (as ``hwgen check`` does from the
    manifest; the same layout and record), a fifth of a second of a rebuild with nothing changed."""
    rec = store.get_record(key)
    return rec["search"] if isinstance(rec, dict) and isinstance(rec.get("search"), dict) else None


MAX_DEFAULT_JOBS = 4     # workers a build starts unless told: each holds the CAD kernel (0.4-0.8 GB)


def default_jobs() -> int:
    """Worker processes a build uses unless told: one per core this process may run on (at most
    :data:`MAX_DEFAULT_JOBS`); a build starts no more than it has units to build."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return max(1, min(cores, MAX_DEFAULT_JOBS))


def _limit() -> int:
    try:
        return cache.size_limit()
    except ValueError:
        raise InputError("environment", cache.ENV_SIZE, f"{clip(os.environ.get(cache.ENV_SIZE, ''))} is not a size "
                                                        f"(2G, 500M, bytes)") from None


def _trim(store: cache.Store, limit: int) -> None:
    """The cache back within ``limit`` bytes (:func:`_limit`), least recently used first."""
    store.trim(limit)


class _Ahead:
    """What the checks need from the plan alone, or from a few parts' files, worked out in a thread
    of this process while worker processes build the parts (this process would only wait for
    them): the tension checks' statics sweeps (:func:`hwgen.checks.tension.sweeps`), then, as
    each unit's files come into the folder (:meth:`placed`), its STLs read for the checks
    (:func:`hwgen.checks.meshes.read_early`). Once every part's files and the strip's template
    are in (:meth:`measure`), a second thread measures every check that reads them
    (:func:`hwgen.checks.run.measure`) while a worker writes assembly.step, and the gear checks
    of the tensioner's worms and wheels are made beside it in a process of their own (seconds of
    meshes and manifold3d, and a few hundred MB that would add to the measurement's here), which
    the measurement meets in the cache.
    The sweeps and the gear checks are kept in the cache as the checks remember them, so the
    checks find them there, or wait for the one being made (:func:`hwgen.cache.remembered` computes under the entry's lock):
    the values are the ones the checks would compute themselves. A build without a cache
    (``--no-cache``) hands them over in a store of its own, which starts empty. The threads go on beside the
    stages after the files; the build joins them at its end. A failure here is left for the checks
    to meet and report."""

    def __init__(self, store: cache.Store, plan: Plan, taken: threading.Event):
        self.store, self.plan, self.thread = store, plan, None
        self.taken = taken              # set once the checks took the measurement (:meth:`measured`)
        self.jobs: queue.SimpleQueue = queue.SimpleQueue()
        self.meshes: dict = {}          # the parts' STLs read early, for the checks (checks.meshes.reading_early)
        self.tensioner: dict[int, list] = {}    # the tensioner's units placed so far (their parts), and its parts
        self.tensioner_parts = sum(u.count for f, _, u in units(plan) if f.name == "tensioner")
        self.measuring: threading.Thread | None = None     # the measurement (:meth:`measure`), once asked for
        self.started = threading.Event()                    # ... and started
        self.found: tuple[str, object] | None = None      # (key of the files measured, checks.run.Measured)

    def start(self) -> None:
        if self.thread is None:
            self.thread = threading.Thread(target=self._run, name="hwgen-ahead", daemon=True)
            self.thread.start()

    def placed(self, index: int, family: str, folder: Path, entries: list[dict]) -> None:
        """The ``index``-th unit's files are in ``folder`` (its manifest ``entries``): its STLs read
        for the checks (and a tensioner unit's entries kept for its gear checks, which read the
        worms' and wheels' files and entries alone)."""
        if self.thread is not None:
            self.jobs.put(("meshes", folder, [dict(e) for e in entries]))
            if family == "tensioner":
                self.tensioner[index] = [dict(e) for e in entries]

    def measure(self, folder: Path, manifest: dict) -> None:
        """Every part's files and the strip's template are in ``folder`` (``manifest``: the parts'
        entries and the design report, as the checks will read them): every check that reads
        them, measured in a thread of its own (when this one runs: parts were built), started once
        this thread has read the STLs placed so far (each is read once), which then has the
        tensioner's gear checks made beside it in a process of their own; the checks take the
        measurement (:meth:`measured`) when their files and manifest give the same key."""
        if self.thread is None:
            return
        key = _measure_key(folder, manifest)
        self.measuring = threading.Thread(target=self._measure, args=(folder, _json(manifest), key),
                                          name="hwgen-measure", daemon=True)
        self.jobs.put(("measure", folder, None))
        gears = [e for i in sorted(self.tensioner) for e in self.tensioner[i]]
        if self.store.enabled and len(gears) == self.tensioner_parts:
            self.jobs.put(("gears", folder, {"parts": gears}))

    def _measure(self, folder: Path, manifest: dict, key: str) -> None:
        from .checks.run import measure
        with cache.using(self.store), reading_early(self.meshes):
            try:
                self.found = (key, measure(folder, manifest, self.plan))
            except Exception:       # the checks measure again and report what fails
                pass

    def measured(self, folder: Path, manifest: dict):
        """What :meth:`measure` found (waiting for it), when it measured the files now in
        ``folder`` against ``manifest`` (:func:`_measure_key`); None when it measured others, was
        not asked, or failed."""
        if self.measuring is None:
            return None
        while not self.started.wait(1.0):
            if not self.thread.is_alive():
                return None
        self.measuring.join()
        self.taken.set()
        found, self.found = self.found, None       # let go of it with the report (its measured disks are large)
        return found[1] if found is not None and found[0] == _measure_key(folder, manifest) else None

    def _run(self) -> None:
        from .checks import run as _      # the checks' modules and libraries, imported while this process waits
        from .checks.meshes import read_early
        from .checks.tension import sweeps
        from .outputs.plots import _pyplot
        _pyplot()                           # and the checks' plots' (a fifth of a second)
        with cache.using(self.store):
            if self.store.enabled:
                try:
                    sweeps(self.plan)
                except Exception:       # the checks run it again and report what it raises
                    pass
                heap.trim()
            with reading_early(self.meshes):
                while (job := self.jobs.get()) is not None:
                    kind, folder, what = job
                    try:
                        if kind == "meshes":
                            for e in what:
                                read_early(ManifestPart.of(e).stl_in(folder))
                        elif kind == "measure":
                            self.measuring.start()
                            self.started.set()
                        elif not _gear_checks_remembered(folder, what, self.plan):
                            _elsewhere(_gear_checks_in_child, folder, what, self.plan, self.store)
                    except Exception:
                        pass

    def join(self) -> None:
        if self.thread is not None:
            self.jobs.put(None)
            self.thread.join()
        if self.started.is_set():
            self.measuring.join()

    def abandon(self) -> None:
        """The build failed: the threads end after what they are doing, unwaited for."""
        self.jobs.put(None)


def _gear_checks_in_child(folder: Path, manifest: dict, plan: Plan, store: cache.Store) -> None:
    """The gear checks of ``manifest``'s worms and wheels, made and kept in ``store`` as the checks
    remember them (:func:`hwgen.checks.gear_mesh.gear_checks`), in a process of their own."""
    from .checks.gear_mesh import gear_checks
    with cache.using(store):
        gear_checks(folder, manifest, plan)


def _gear_checks_remembered(folder: Path, manifest: dict, plan: Plan) -> bool:
    """Whether the active store holds every measurement the gear checks of ``manifest``'s worms and
    wheels make (an edit that moved the tensioner but kept its gearing): then no process is started
    to make them (a second of imports for nothing)."""
    from .checks.gear_mesh import gear_checks
    try:
        with cache.recalling_only():
            gear_checks(folder, manifest, plan)
    except cache.NotRemembered:
        return False
    return True


def _elsewhere(job, *args) -> None:
    """``job(*args)`` in a process of its own (:func:`hwgen.processes.elsewhere`), waited for: work
    whose result the cache hands over, whose memory (meshes, their copies posed, manifold3d solids)
    then never adds to this process's while it measures the rest."""
    processes.elsewhere(job, *args, name="hwgen-gears").join()


def _measure_key(folder: Path, manifest: dict) -> str:
    """What :func:`hwgen.checks.run.measure` reads: every file in the folder but assembly.step (which
    only the files' own checks read), the manifest but its ``files`` (of which it reads only the
    strip template's path) and the environment the checks read."""
    from .checks.run import backbone_template
    return cache.key("measured", {p: sha for p, sha in _files(folder).items() if p != "assembly.step"},
                     {k: v for k, v in manifest.items() if k != "files"}, backbone_template(manifest),
                     {e: os.environ.get(e) for e in STAGE_ENV["checks"]})


# set by a build for its checks: the work ahead that measured its files while assembly.step was written
_MEASURED_AHEAD: contextvars.ContextVar[_Ahead | None] = contextvars.ContextVar("hwgen_measured_ahead", default=None)


# set by a build whose checks will run: started by the worker pool (:class:`_Workers`) when there are parts to build
_WHILE_WORKERS_BUILD: contextvars.ContextVar[_Ahead | None] = contextvars.ContextVar("hwgen_while_workers_build",
                                                                                       default=None)


# ---------------------------------------------------------------- the stages after the files, through the cache

BESIDE = ("plates", "pictures")     # stages that read only the parts' files and the manifest's parts and design
#                                     report: run in threads beside the others (the renderer is a child process)
AFTER_MEASURED = ("plates",)        # ... once the checks' measurement is over: its meshes and theirs, read from
#                                     the same files, would be in memory at once


def _start_beside(store: cache.Store, plan: Plan, folder: Path, target: Path, manifest: dict, stack: ExitStack,
                  pool: ThreadPoolExecutor, measured: threading.Event) -> dict[str, tuple]:
    """The stages in :data:`BESIDE` started in ``pool``, each in a folder of hard links to the part
    files with a copy of the manifest (a build starts them as soon as every part's files are in
    ``folder``: they read nothing else; those in :data:`AFTER_MEASURED` wait for ``measured``);
    :func:`_after_files` takes what they made."""
    side: dict[str, tuple] = {}
    for name, stage in AFTER_FILES:
        if name in BESIDE:
            where = stack.enter_context(side_folder(folder, target))
            m, got = _json(manifest), []
            with cache.using(store):
                job = contextvars.copy_context().run
            gate = measured if name in AFTER_MEASURED else None
            side[name] = (where, _files(where), _json(m), m, got,
                          pool.submit(job, _gated, gate, _cached_stage, store, name, stage, plan, where, m, got, None))
    return side


def _gated(gate: threading.Event | None, fn, *args):
    if gate is not None:
        gate.wait()
    return fn(*args)


def _after_files(store: cache.Store, plan: Plan, folder: Path, manifest: dict, done: dict, reused: list[str],
                 side: dict[str, tuple], measured: threading.Event) -> None:
    """The stages after the files, in the order of :data:`AFTER_FILES`; those in :data:`BESIDE`
    were started before (``side``: :func:`_start_beside`), and their new files and manifest fields
    (and the files they list in its ``files``) join ``folder`` and ``manifest`` at their place in
    the order, so the outputs are those of the stages run one after the other. ``measured`` is
    set once the checks are done (or the work ahead's measurement taken, sooner)."""
    for name, stage in AFTER_FILES:
        if name not in side:
            done[name] = _cached_stage(store, name, stage, plan, folder, manifest, reused, done.get("checks"))
            if name == "checks":
                measured.set()
            continue
        where, before, original, m, got, future = side[name]
        done[name] = future.result()
        for path in _files(where):
            if path not in before:
                (folder / path).parent.mkdir(parents=True, exist_ok=True)
                os.replace(where / path, folder / path)
        for k, v in m.items():
            if k in original and original[k] == v:
                continue
            if k == "files":        # the files it added join the folder's own
                manifest.setdefault(k, {}).update({f: e for f, e in v.items() if original.get(k, {}).get(f) != e})
            else:
                manifest[k] = v
        reused += got


# the stages the cache keeps, and what each reads besides the folder, the manifest and the plan
STAGE_ENV = {"checks": ("HWGEN_CHECK_SAMPLES",), "bom": (), "plates": (), "guide": (), "pictures": ("HWGEN_RENDER_BACKEND", "DISPLAY"),
             "marks": ("HWGEN_RENDER_BACKEND", "DISPLAY")}
STAGE_REWRITES = {"marks": pictures.MARKED}   # files a stage draws again over an earlier stage's (kept in the cache)
STAGE_RESULT = {"checks": REPORT}       # a stage whose return value is this file of its outputs (read back by read_report)


def _files(folder: Path) -> dict[str, str]:
    """Every file in ``folder`` (relative path) with its sha256."""
    return {str(p.relative_to(folder)): _hashed(p) for p in sorted(folder.rglob("*")) if p.is_file()}


# within one build: (device, inode, size, mtime, ctime) -> sha256 of a file hashed before
_HASHED: contextvars.ContextVar[dict | None] = contextvars.ContextVar("hwgen_hashed", default=None)


def _hashed(path: Path) -> str:
    """The file's sha256; within a build, read again only when its inode, size or times changed
    since the build last hashed it (every stage keys on every file in the folder: the STEP files
    are read once, not once per stage)."""
    seen = _HASHED.get()
    if seen is None:
        return sha256(path)
    st = path.stat()
    k = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
    if k not in seen:
        seen[k] = sha256(path)
    return seen[k]


def _cached_stage(store: cache.Store, name: str, stage, plan: Plan, folder: Path, manifest: dict,
                  reused: list[str], report: dict | None):
    """Run a stage after the files, or take what it wrote last time from the cache: the files it
    added to the folder and the manifest fields it set, keyed by every file in the folder, the
    manifest, the plan (the design's values as the stages read them), the environment it reads and
    hwgen's code. Pictures that could not be
    drawn are not kept (another try may find a renderer)."""
    if not store.enabled or name not in STAGE_ENV:
        return stage(plan, folder, manifest, report)
    before = _files(folder)
    key = cache.key("stage", name, before, manifest, plan, {e: os.environ.get(e) for e in STAGE_ENV[name]},
                    __version__, cache.code())
    rec = store.get_record(key)
    if isinstance(rec, dict):
        try:
            blobs = {path: store.get_bytes(sha) for path, sha in rec["files"].items()}
            if all(b is not None for b in blobs.values()):
                for path, data in blobs.items():
                    (folder / path).parent.mkdir(parents=True, exist_ok=True)
                    (folder / path).write_bytes(data)
                manifest.update(_json(rec["manifest"]))
                reused.append(name)
                if name not in STAGE_RESULT:
                    return None
                kept = read_report(folder)
                if kept is None:
                    raise ValueError(f"{STAGE_RESULT[name]} cannot be read back")
                return kept
        except (KeyError, TypeError, AttributeError, ValueError):
            pass
    fields = {k: json.dumps(v, sort_keys=True) for k, v in manifest.items()}
    out = stage(plan, folder, manifest, report)
    after = _files(folder)
    redrawn = STAGE_REWRITES.get(name, ())
    if any(after.get(path) != sha for path, sha in before.items() if path not in redrawn):
        return out                              # it changed a file it was given: not kept
    if name in ("pictures", "marks") and (manifest.get("render", {}).get("status") != "ok"
                                         or "message" in manifest["render"].get("failing", {})):
        return out                              # another try may find a renderer
    files = {path: store.put_bytes((folder / path).read_bytes()) for path in after
             if path not in before or (path in redrawn and after[path] != before[path])}
    changed = {k: v for k, v in manifest.items() if fields.get(k) != json.dumps(v, sort_keys=True)}
    store.put_record(key, {"files": files, "manifest": changed})
    return out


# ---------------------------------------------------------------- the parts, through the cache

def _sources() -> list[Path]:
    """The files that make the solids: the code in hwgen/cad and hwgen/model and the tables in
    hwgen/data they read (a nut's size in fasteners.csv shapes its trap as much as code does)."""
    root = Path(__file__).resolve().parent
    return sorted([*root.glob("cad/*.py"), *root.glob("model/**/*.py"), *root.glob("data/*.csv")])


def _sources_digest() -> str:
    """The sha256 of :func:`_sources`: a cached part made by other code or other tables is not
    reused, even under the same version number."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for f in _sources():
        h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def _kernel_version() -> dict:
    from importlib.metadata import PackageNotFoundError, version
    out = {}
    for dist in ("cadquery", "cadquery-ocp"):
        try:
            out[dist] = version(dist)
        except PackageNotFoundError:
            out[dist] = None
    return out


def _salt() -> dict:
    """What every cached file also depends on besides its unit's inputs."""
    return {"hwgen": __version__, "kernel": _kernel_version(), "export": export.settings(), "code": _sources_digest()}


def _json(obj):
    """``obj`` as JSON gives it back: a part's entry is the same whether it was just built or
    read from the cache."""
    return json.loads(json.dumps(obj))


def _unit_from_cache(store: cache.Store, key: str) -> dict | None:
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


def _export_unit(plan: Plan, parts, where: Path, solids: cache.Store) -> list[dict]:
    """Each part of a freshly built unit: its description and measurements, its STL and STEP
    (written under ``where``) as bytes, and its solid as BREP bytes, once per solid (what the
    cache keeps to put the assembly together, and by which it knows parts of one solid). A solid
    kept in ``solids`` (:func:`hwgen.cad.memo.made_as`) whose STL and measurements another unit
    has kept there gets those (a throated wheel's are a second of tessellation and MASS_EPS
    integration; every channel of one spool layout has the same), and its STEP when a unit kept
    one for the same part name (an edit that moves the tensioner writes no wheel's STEP again)."""
    out = []
    for k, part in enumerate(parts):
        stl, step = where / "stl" / f"{part.name}.stl", where / "step" / f"{part.name}.step"
        kept_as = made_as(part.solid)
        with kernel_errors(plan, part, "write the files of"):
            same = next((j for j in range(k) if parts[j].solid is part.solid), None)
            mesh_key = cache.key("kept solid's mesh", kept_as) if kept_as and same is None else None
            got = _kept_mesh(solids, mesh_key) if mesh_key else None
            if got is not None:
                stl.write_bytes(got[0])
            else:
                export.write_stl(part.solid, stl)
            # its STEP names the part: kept per kept solid and name (a wheel's is 0.2 s of writing)
            step_key = cache.key("kept solid's step", kept_as, part.name) if kept_as else None
            step_bytes = _kept_bytes(solids, step_key, "step") if step_key else None
            if step_bytes is not None:
                step.write_bytes(step_bytes)
            else:
                export.write_step(part.solid, step, part.name)
            # a solid measured once (the throated wheels of one size: a second each, to MASS_EPS)
            measured = out[same]["measured"] if same is not None else got[1] if got is not None else \
                _json(measure(part))
            solid = export.write_brep(part.solid) if same is None else None
        if mesh_key and got is None:
            solids.put_record(mesh_key, {"stl": solids.put_bytes(stl.read_bytes()), "measured": measured})
        if step_key and step_bytes is None:
            solids.put_record(step_key, {"step": solids.put_bytes(step.read_bytes())})
        out.append({"part": _json(describe(part)), "measured": measured, "same_solid_as": same,
                    "made_as": kept_as, "stl": stl.read_bytes(), "step": step.read_bytes(), "brep": solid})
    return out


def _kept_bytes(solids: cache.Store, key: str, field: str) -> bytes | None:
    """The file kept for a kept solid under ``key`` (its record's ``field``), None if there is none."""
    rec = solids.get_record(key)
    return solids.get_bytes(rec[field]) if isinstance(rec, dict) and isinstance(rec.get(field), str) else None


def _kept_mesh(solids: cache.Store, key: str) -> tuple[bytes, dict] | None:
    """(STL bytes, measurements) kept for a kept solid by the unit that exported it first."""
    rec = solids.get_record(key)
    if not isinstance(rec, dict) or not isinstance(rec.get("stl"), str) or not isinstance(rec.get("measured"), dict):
        return None
    data = solids.get_bytes(rec["stl"])
    return None if data is None else (data, rec["measured"])


def _keep_unit(store: cache.Store, key: str, exported: list[dict]) -> dict:
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


# ---------------------------------------------------------------- parts built in worker processes

_BUILT_HERE: dict[str, list] = {}     # in a worker process: the solids of the units it built, by unit key


def _unit_in_worker(plan: Plan, index: int, key: str, store: cache.Store, salt: dict,
                    wait: bool, solids: cache.Store) -> tuple[str, object]:
    """Build and export the ``index``-th unit of the plan in a worker process (its solids stay
    there for :func:`_assembly_in_worker`) and keep it in the cache, under the unit's lock:
    ("ok", its record with its bytes, as :func:`_keep_unit` gives it); ("busy", None), unless ``wait``, when another build holds it or a solid it needs (it is making
    that now), ("kept", None) when another build has kept it meanwhile. A DesignError or
    InputError comes back as its fields (they do not pickle as themselves)."""
    try:
        lock = store.lock(key) if wait else store.try_lock(key)
        if lock is None:
            return "busy", None
        with lock:
            if _unit_from_cache(store, key) is not None:
                return "kept", None                  # by another build, while this one looked
            family, first, unit = list(units(plan))[index]
            with kept_in(solids, salt), (nullcontext() if wait else setting_aside()):
                parts = list(build_unit(plan, family, first, unit))
            _BUILT_HERE[key] = [p.solid for p in parts]
            with tempfile.TemporaryDirectory(prefix="hwgen-unit-") as tmp:
                (Path(tmp) / "stl").mkdir()
                (Path(tmp) / "step").mkdir()
                exported = _export_unit(plan, parts, Path(tmp), solids)
            # kept before the lock goes (a build waiting for it reads it); the record, with its
            # bytes, is what the calling process places
            return "ok", _keep_unit(store, key, exported)
    except Busy:
        return "busy", None
    except DesignError as e:
        return "design", (e.path, e.message)
    except InputError as e:
        return "input", (e.file, e.path, e.message)


def _assembly_in_worker(loaded, plan: Plan, done: list[tuple[str, dict]], breps: dict[str, bytes], store: cache.Store,
                        salt: dict, solids: cache.Store) -> tuple[str, object]:
    """assembly.step's bytes, written in a worker from the units ``done`` ((key, record) in build
    order): the solids this worker built, else read back from their BREP (``breps`` or the
    cache), else built again."""
    try:
        with tempfile.TemporaryDirectory(prefix="hwgen-assembly-") as tmp:
            path = Path(tmp) / "assembly.step"
            with kept_in(solids, salt):
                _assemble(loaded, plan, path, store, [(k, {**r, "breps": breps}, _BUILT_HERE.get(k)) for k, r in done])
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


class _Workers:
    """Worker processes for the CAD kernel (``jobs`` of them, forks of the server that imported
    CadQuery once: :mod:`hwgen.processes`). This process then never imports CadQuery: its memory
    holds the checks alone, and the workers' memory is returned as they end, while the checks
    start (their exit is not waited for)."""

    def __init__(self, jobs: int, solids: cache.Store):
        self.pool = processes.pool(jobs)
        self.solids = solids        # where the workers keep and find the solids units share (cad.memo.kept)

    def __enter__(self):
        ahead = _WHILE_WORKERS_BUILD.get()
        if ahead is not None:
            ahead.start()           # this process waits for the workers meanwhile
        return self

    def __exit__(self, *exc):
        # not waited for: a worker's exit (the CAD kernel's memory handed back) takes a second or
        # more, and nothing after needs it; the workers end on their own
        self.pool.shutdown(wait=False, cancel_futures=True)

    def unit(self, plan: Plan, index: int, key: str, store: cache.Store, salt: dict, wait: bool = False):
        return self.pool.submit(_unit_in_worker, plan, index, key, store, salt, wait, self.solids)

    def assembly(self, loaded, plan: Plan, done, breps, store: cache.Store, salt: dict):
        return self.pool.submit(_assembly_in_worker, loaded, plan, done, breps, store, salt, self.solids)


def _write_files(loaded: params.LoadedDesign, plan: Plan, folder: Path, total: int, progress,
                 store: cache.Store, solids: cache.Store, select: Callable[[str], bool] | None = None,
                 jobs: int = 0, placed: Callable[[dict], None] | None = None,
                 measurable: Callable[[dict], None] | None = None) -> tuple[dict, list[str]]:
    """Every part's STL and STEP, assembly.step, backbone_template.dxf and the manifest; a unit
    whose key is in the cache is copied from it, the others are built (and kept). Returns the
    manifest and the names of the parts built afresh. With ``select``, only the parts it takes
    get their files, and the assembly and the DXF are not written. ``solids``: where the solids
    several units share (the tensioner's worm and gear) are kept, so that each is made once
    whichever process needs it (the cache, or a build's own store). ``placed`` is called with the
    manifest as it stands once every part's files are in the folder (the strip's template is
    drawn before the parts; no assembly in its files yet), then ``measurable`` with the same. With ``jobs`` ≥ 1, the units
    to build and the assembly are made in worker processes (:class:`_Workers`): as many as there
    are units to build, at most ``jobs``, started only when there is something to make; 0: in this
    process."""
    (folder / "stl").mkdir()
    (folder / "step").mkdir()
    entries, built, units_done = [], [], []
    density = plan.process.density_g_cm3
    salt = _salt()
    todo = []
    for family, first, unit in units(plan):
        key = cache.key("unit", family.name, unit.inputs, salt)
        todo.append((family, first, unit, key, _unit_from_cache(store, key)))
    asm_key = cache.key("assembly", loaded.name, [t[3] for t in todo], salt)
    assembly = None if select is not None else _assembly_from_cache(store, asm_key)
    with ExitStack() as stack:
        workers = None
        to_make = sum(t[4] is None for t in todo)
        if jobs >= 1 and (to_make or (select is None and assembly is None)):
            workers = stack.enter_context(_Workers(max(1, min(jobs, to_make)), solids))
        if select is None:
            # drawn while the workers' server starts (it imports CadQuery first): the checks' measurement
            # needs it, and starts as soon as the parts are in
            _backbone_dxf(store, plan, folder / "backbone_template.dxf", salt)
        with kept_in(solids, salt):
            _place_units(plan, folder, todo, workers, store, salt, select, entries, built, units_done, density,
                         total, progress, solids)
        if placed is not None:
            placed(_manifest(loaded, plan, {}, entries))
        job = None
        if select is None and assembly is None and workers is not None:
            breps = {sha: rec["breps"][sha] for _, rec, _ in units_done for sha in rec.get("breps", {})}
            job = workers.assembly(loaded, plan, [(k, _record(r)) for k, r, _ in units_done], breps, store, salt)
        if select is None and measurable is not None:
            measurable(_manifest(loaded, plan, {}, entries))
        if select is None and assembly is None:
            if job is not None:
                assembly = _result(job.result())
            else:
                with kept_in(solids, salt):
                    _assemble(loaded, plan, folder / "assembly.step", store,
                              [(k, r, None if ps is None else [p.solid for p in ps]) for k, r, ps in units_done])
                assembly = (folder / "assembly.step").read_bytes()
            store.put_record(asm_key, {"step": store.put_bytes(assembly)})
        if select is None:
            (folder / "assembly.step").write_bytes(assembly)
    files = {}
    if select is None:
        files = {"assembly": {"path": "assembly.step", "sha256": sha256(folder / "assembly.step")},
                 "backbone_template": {"path": "backbone_template.dxf",
                                       "sha256": sha256(folder / "backbone_template.dxf")}}
    return _manifest(loaded, plan, files, entries), built


def _manifest(loaded: params.LoadedDesign, plan: Plan, files: dict, entries: list[dict]) -> dict:
    """The manifest of the files written: the design, the whole design's files, each part's entry and
    the design report."""
    return {
        "design": loaded.name,
        "hwgen_version": __version__,
        "params_file": loaded.source,
        "params_sha256": loaded.sha256,
        "params_base": list(loaded.bases),          # the file's base, its base's base, ...: merged under it
        "design_resolved": loaded.design.model_dump(mode="json"),    # the design as read, bases merged
        "files": files,
        "parts": entries,
        "design_report": design_report(plan),
    }


def _backbone_dxf(store: cache.Store, plan: Plan, path: Path, salt: dict) -> None:
    """backbone_template.dxf, from the cache when the strip and the stations did not change (ezdxf
    and the drawing cost a fifth of a second, most of a rebuild with nothing changed)."""
    key = cache.key("backbone_dxf", plan.backbone, list(plan.stations), salt,
                    cache.code()["libraries"]["ezdxf"])
    rec = store.get_record(key)
    data = store.get_bytes(rec["dxf"]) if isinstance(rec, dict) and isinstance(rec.get("dxf"), str) else None
    if data is not None:
        path.write_bytes(data)
        return
    export.write_backbone_dxf(plan.backbone, plan.stations, path)
    store.put_record(key, {"dxf": store.put_bytes(path.read_bytes())})


def _record(rec: dict) -> dict:
    """A unit's record without the bytes it carries in this process."""
    return {k: v for k, v in rec.items() if k not in ("blobs", "breps")}


def _place_units(plan: Plan, folder: Path, todo, workers: _Workers | None, store: cache.Store, salt: dict, select,
                 entries: list, built: list, units_done: list, density: float, total: int, progress,
                 solids: cache.Store) -> None:
    """Each unit's files into the folder and its parts' entries (in build order, whatever order
    the units were made in): from the cache, from a worker, or built here.

    A unit not in the cache is made under its lock (:meth:`cache.Store.try_lock`), taken when its
    turn comes. A unit whose lock another build holds (it is making that unit now) waits until
    every other unit is done; this build then waits for the lock, which frees once the other has
    kept the unit, and reads it from the cache (or makes it, when the other did not finish). So
    is a unit that needs a kept solid another build is making (the throated wheel's gear).

    The first of the tensioner's units to make goes first: it makes the worm and the throated
    gear every channel shares (most of the parts' time), while the other workers make the other
    families' units. The tensioner's other units come last and wait for the shared solids
    instead of being set aside: by then the gear is made, or nearly (a build that finds it being
    made by another has had the other units to make meanwhile)."""
    tensioner = [i for i in range(len(todo)) if todo[i][0].name == "tensioner"]
    first = [i for i in tensioner if todo[i][4] is None][:1]
    order = first + [i for i in range(len(todo)) if i not in tensioner] + [i for i in tensioner if i not in first]
    ahead = _WHILE_WORKERS_BUILD.get()
    elsewhere = {i: workers.unit(plan, i, todo[i][3], store, salt, wait=i in tensioner and i not in first)
                 for i in order if todo[i][4] is None} if workers else {}
    done: dict[int, tuple[dict, list | None]] = {}     # unit -> (record with its bytes, parts built here)
    placed: dict[int, list] = {}                       # unit -> its parts' entries
    count = [0]
    theirs = []
    for wait in (False, True):
        for i in theirs if wait else order:
            made = _made(plan, folder, todo[i], elsewhere.pop(i, None), workers, i, store, salt, built, wait, solids)
            if made is None:
                theirs.append(i)
                continue
            done[i] = made
            placed[i] = _place(plan, folder, made, select, density, count, total, progress)
            if ahead is not None and select is None:
                ahead.placed(i, todo[i][0].name, folder, placed[i])
    entries += [e for i in range(len(todo)) for e in placed[i]]
    units_done += [(todo[i][3], *done[i]) for i in range(len(todo))]


def _made(plan: Plan, folder: Path, t, future, workers: _Workers | None, index: int, store: cache.Store, salt: dict,
          built: list, wait: bool, solids: cache.Store) -> tuple[dict, list | None] | None:
    """A unit's record (with its bytes) and, when built in this process, its parts (their files
    are then in the folder already): from the cache, from a worker (``future``, or one submitted
    now), or built here. None, without ``wait``, when another build is making it."""
    family, first, unit, key, rec = t
    if rec is not None:
        return rec, None
    if workers is None:
        lock = store.lock(key) if wait else store.try_lock(key)
        if lock is None:
            return None
        with lock:
            rec = _unit_from_cache(store, key)      # kept by another build while this one looked
            if rec is not None:
                return rec, None
            try:
                with nullcontext() if wait else setting_aside():
                    parts = list(build_unit(plan, family, first, unit))
            except Busy:
                return None
            rec = _keep_unit(store, key, _export_unit(plan, parts, folder, solids))
        built += [p["name"] for p in rec["parts"]]
        return rec, parts
    while rec is None:
        if future is None:
            future = workers.unit(plan, index, key, store, salt, wait)
        kind, value = future.result()
        future = None
        if kind == "busy":                          # only without wait
            return None
        if kind == "kept":
            rec = _unit_from_cache(store, key)      # gone again (trimmed): made on the next turn
        else:
            rec = _result((kind, value))            # kept by the worker
            built += [p["name"] for p in rec["parts"]]
    return rec, None


def _place(plan: Plan, folder: Path, unit: tuple[dict, list | None], select, density: float, count: list,
           total: int, progress) -> list[dict]:
    """A unit's files written into the folder (unless it was built there), and its parts' entries."""
    rec, parts = unit
    out = []
    for p in rec["parts"]:
        files = {"stl": folder / "stl" / f"{p['name']}.stl", "step": folder / "step" / f"{p['name']}.step"}
        hashes = {kind: p["files"][kind] for kind in files}
        for kind, path in files.items():
            if select is not None and not select(p["name"]):
                path.unlink(missing_ok=True)        # built for the manifest, not asked for
            elif parts is None:
                path.write_bytes(rec["blobs"][hashes[kind]])
        out.append(entry(p, p["measured"], files, folder, plan.process.material, density, hashes))
        count[0] += 1
        if progress:
            progress(p["name"], count[0], total)
    return out


def _assembly_from_cache(store: cache.Store, key: str) -> bytes | None:
    rec = store.get_record(key)
    return store.get_bytes(rec["step"]) if isinstance(rec, dict) and isinstance(rec.get("step"), str) else None


def _assemble(loaded, plan: Plan, path: Path, store: cache.Store, units_done) -> None:
    """assembly.step put together from the units' solids (built now, or read back from the
    cache's BREP; built again if that is gone). Parts of one solid (a unit's parts sharing one;
    solids kept under one key, :func:`hwgen.cad.memo.made_as`: the tensioner's worms, drive
    shafts, clamps, its wheels of one spool layout, in whichever unit or process they were made)
    are given one solid, which the file holds once and places once per part."""
    parts, one = [], {}         # one: kept key -> the solid every part of that key is given
    for (family, first, unit), (_, rec, solids) in zip(units(plan), units_done):
        solids = solids if solids is not None else _solids(store, rec)
        if solids is None:
            solids = [p.solid for p in build_unit(plan, family, first, unit)]
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
        export.write_assembly(parts, loaded.name, path)


# ---------------------------------------------------------------- on existing outputs

def stale_reason(folder: Path, loaded) -> str | None:
    """Why the outputs in ``folder`` cannot be checked as they are (None: they can)."""
    if not (folder / MANIFEST).exists():
        return "no outputs yet"
    try:
        m = read_manifest(folder)
    except (OSError, ValueError):
        return "manifest.json is unreadable"
    try:
        if m.get("params_sha256") != loaded.sha256:
            return "built from other parameters"
        if m.get("hwgen_version") != __version__:
            return f"built by hwgen {m.get('hwgen_version')}, this is {__version__}"
        m["files"], m["design_report"]["disks"]       # raise for a manifest hwgen did not write
        files = [f.path for f in manifest_files(m)]
    except (AttributeError, KeyError, TypeError, ValueError):
        return "manifest.json is not one hwgen wrote"
    for path in files:
        if not isinstance(path, str) or not (folder / path).is_file():
            return f"{path} is missing"
    return None


def check(loaded: params.LoadedDesign, out_root: Path, progress=None,
          cache_dir: Path | None | bool = True) -> tuple[dict, Path, str | None]:
    """`hwgen check`: build if needed, then measure. Returns (report, folder, why it was rebuilt or None).

    Outputs measured before, with every file as it was then (same bytes, same manifest, plan,
    environment and code), get that report back from the cache instead of being measured again."""
    folder = Path(out_root) / loaded.name
    limit = _limit()
    with output_errors(Path(out_root)), snapshot(folder) as view:
        why = stale_reason(view, loaded)
        if why is None:
            manifest = read_manifest(view)
            # these files were built from these very parameters: their tensioner is laid out again
            # in the arrangement the build chose (its manifest says which), not searched for again
            plan = design_plan(loaded, tensioner_record(manifest))
            store = cache.Store(cache.default_dir() if cache_dir is True else (cache_dir or None))
            report = _measured(store, view, manifest, plan)
            _trim(store, limit)
            return report, folder, None
    return build(loaded, Path(out_root), progress, cache_dir=cache_dir).report, folder, why


def tensioner_record(manifest: dict) -> dict | None:
    """The tensioner layout's search record a build kept in its manifest (None: none there)."""
    for p in manifest.get("parts", []):
        if p.get("role") == "tensioner_housing" and isinstance(p.get("layout_search"), dict):
            return p["layout_search"]
    return None


def _measured(store: cache.Store, folder: Path, manifest: dict, plan: Plan) -> dict:
    """run_checks on the folder, or its report from the last time these very files were measured."""
    if not store.enabled:
        return run_checks(folder, manifest, plan)
    key = cache.key("check", _files(folder), manifest, plan, {e: os.environ.get(e) for e in STAGE_ENV["checks"]},
                    __version__, cache.code())
    rec = store.get_record(key)
    data = store.get_bytes(rec["report"]) if isinstance(rec, dict) and isinstance(rec.get("report"), str) else None
    if data is not None:
        try:
            return json.loads(data)
        except ValueError:
            pass
    with cache.using(store):
        report = _json(run_checks(folder, manifest, plan))
    store.put_record(key, {"report": store.put_bytes(json.dumps(report).encode())})
    return report


def render(loaded: params.LoadedDesign, out_root: Path,
           cache_dir: Path | None | bool = True) -> tuple[dict, Path, str | None]:
    """`hwgen render`: the bill of materials, pictures and drawing of ``out_root/<design>/``.

    Builds first (which draws) when the outputs are missing or stale; otherwise draws into the
    existing folder and rewrites its manifest. Returns (the manifest's render entry, the
    folder, why it was rebuilt or None).
    """
    folder = Path(out_root) / loaded.name
    why = stale_reason(folder, loaded)
    if why is not None:
        result = build(loaded, Path(out_root), cache_dir=cache_dir)
        return result.manifest.get("render", {}), folder, why
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp:
        manifest = read_manifest(tmp)
        draw(design_plan(loaded, tensioner_record(manifest)), tmp, manifest)     # current files: as check does
        write_manifest(tmp, manifest)
    return manifest["render"], folder, None


def plates(loaded: params.LoadedDesign, out_root: Path,
           cache_dir: Path | None | bool = True) -> tuple[dict, Path, str | None]:
    """`hwgen plates`: the print plates of ``out_root/<design>/``, laid out again into the
    existing outputs (a build lays them out too; builds first when the outputs are missing or
    stale). Returns (the plate summary, the folder, why it was rebuilt or None)."""
    folder = Path(out_root) / loaded.name
    why = stale_reason(folder, loaded)
    if why is not None:
        result = build(loaded, Path(out_root), cache_dir=cache_dir)
        return result.manifest["plates"], folder, why
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp:
        manifest = read_manifest(tmp)
        shutil.rmtree(tmp / print_plates.FOLDER, ignore_errors=True)
        summary = plates_stage(design_plan(loaded, tensioner_record(manifest)), tmp, manifest, None)
        write_manifest(tmp, manifest)
    return summary, folder, None


COUPON = "coupon"          # the folder of `hwgen coupon`'s files inside out/<design>/


def coupon(loaded: params.LoadedDesign, out_root: Path) -> tuple[dict, Path]:
    """`hwgen coupon`: the calibration coupon of the design (:mod:`hwgen.model.coupon`), written
    as coupon/coupon.stl, coupon.step and coupon.json (each feature, its label and where it is)
    into ``out_root/<design>/``, added to what is there (a later build replaces the folder and
    drops it, as it does the stiffness files). Returns (coupon.json's content, the folder)."""
    from .cad.coupon import build_coupon
    from .model.coupon import coupon_spec

    plan = design_plan(loaded)
    spec = coupon_spec(plan, loaded.design)
    with kernel_errors(plan, None, "build the calibration coupon"):
        solid = build_coupon(spec)
    folder = Path(out_root) / loaded.name
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp:
        where = tmp / COUPON
        shutil.rmtree(where, ignore_errors=True)
        where.mkdir()
        export.write_stl(solid, where / "coupon.stl")
        export.write_step(solid, where / "coupon.step", f"{loaded.name}_coupon")
        info = {"design": loaded.name, "params_sha256": loaded.sha256, "size_mm": list(spec.size),
                "design_hole_mm": spec.design_hole, "design_slot_clearance_mm": spec.design_clearance,
                "strip_thickness_mm": spec.strip_thickness, "text_mm": spec.text_mm, "engrave_mm": spec.engrave_mm,
                "volume_mm3": solid.Volume(),
                "features": [f.__dict__ for f in spec.features]}
        write_json(where / "coupon.json", info)
    return info, folder


def stiffness(loaded: params.LoadedDesign, out_root: Path, which: list[str] | None = None,
              cache_dir: Path | None | bool = True) -> tuple[dict, Path]:
    """`hwgen stiffness`: the statics of every tendon state (or those named) from the plan, the
    weights measured from the built files when ``out_root/<design>/`` holds a current build (its
    report's gravity section), else estimated from the plan; written as stiffness.json,
    stiffness.png and gravity.png into that folder (replacing what a build wrote there: the same
    files when every state is asked for). Returns (report, folder)."""
    from .model import stiffness as statics_study       # scipy's optimisers: only this command and the checks
    folder = Path(out_root) / loaded.name
    measured, record = None, None
    with output_errors(Path(out_root)), snapshot(folder) as view:
        if stale_reason(view, loaded) is None:
            measured = (read_report(view) or {}).get("gravity")
            record = tensioner_record(read_manifest(view))     # the build's layout, as `hwgen check` takes it
    plan = design_plan(loaded, record)
    if which:
        known = [s.name for s in statics_study.states(plan)]
        for name in which:
            if name not in known:
                raise InputError(loaded.source, "--states", f"unknown state {clip(name)!r}; this design's are "
                                                            f"{', '.join(known)}")
    store = cache.Store(cache.default_dir() if cache_dir is True else (cache_dir or None))
    with cache.using(store):
        report = statics(plan, measured, which)
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp:
        write_json(tmp / STIFFNESS, report)
        plot_stiffness(report, tmp / STIFFNESS_PLOT)
        plot_gravity(report, tmp / GRAVITY_PLOT)
    return report, folder


SIM = "sim"                # the folder of `hwgen sim`'s files inside out/<design>/


def sim(loaded: params.LoadedDesign, out_root: Path,
        cache_dir: Path | None | bool = True) -> tuple[dict, Path, str | None]:
    """`hwgen sim`: the MuJoCo model of the built robot (:mod:`hwgen.sim`), written as sim/robot.xml,
    its meshes, sim.json and sim.png into ``out_root/<design>/`` (added to what is there; a later
    build replaces the folder and drops it). Builds first when the outputs are missing or stale.
    Checked against the build's stiffness.json, else :func:`statics` (remembered in the cache).
    Returns (sim.json's content, the folder, why it was rebuilt or None)."""
    from .sim.run import simulate            # MuJoCo: only this command
    folder = Path(out_root) / loaded.name
    why = stale_reason(folder, loaded)
    if why is None and not (folder / REPORT).is_file():
        why = f"{REPORT} is missing"
    if why is not None:
        build(loaded, Path(out_root), cache_dir=cache_dir)
    store = cache.Store(cache.default_dir() if cache_dir is True else (cache_dir or None))
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp, cache.using(store):
        manifest, report = read_manifest(tmp), read_report(tmp)
        shutil.rmtree(tmp / SIM, ignore_errors=True)
        plan = design_plan(loaded, tensioner_record(manifest))
        result = simulate(plan, tmp, manifest, report, tmp / SIM, lambda: statics(plan, report.get("gravity")))
    return result, folder, why
