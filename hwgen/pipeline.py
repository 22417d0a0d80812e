"""The order of the stages, and the one place that knows it.

    read (params) → feasibility (model) → plan (model) → parts (cad) → files and manifest (cad)
    → checks (report.json, summary.md; the tendon states' statics: stiffness.json, stiffness.png,
    gravity.png) → plots (lengths.png, tolerance.png, sag.png) → bill of materials
    → print plates (plates/) → pictures → assembly guide (guide/) → the build in the browser (view.html)

Every build writes into a fresh staging folder beside the target; only when every file is
complete is it swapped in for ``out/<design>/`` in one step (:func:`hwgen.atomic.new_folder`).
A failure or a kill at any point leaves the old outputs exactly as they were; two builds at
once both finish, and the last to finish is what the folder holds. ``hwgen check`` reads the
outputs as they are; ``hwgen render`` draws into a copy of them and swaps it in the same way;
both build first only when the outputs are missing or made from other parameters.

Every build goes through the cache (:mod:`hwgen.cache`, ``--cache-dir``, ``--no-cache``): each
unit of parts (:mod:`hwgen.cad.families`) is keyed by the frozen values its builder reads and
copied from the cache when they did not change (:mod:`hwgen.engine.units`); assembly.step by its
units' keys; each stage after the files by every file it reads, the manifest, the plan (every
value the stages read from the design, as the model resolved it), the environment it reads and
hwgen's code (:mod:`hwgen.engine.stagecache`). What comes from the cache has the bytes a fresh
build writes. How the work is spread over processes and threads is :mod:`hwgen.engine.concurrency`'s;
what the stages share is one :class:`hwgen.engine.context.Build`.

An output root that cannot be written (not a folder, no permission, a full disk) is bad input
naming ``--out`` (:class:`hwgen.errors.InputError`), like any other.
"""
from __future__ import annotations

import errno
import fnmatch
import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import ExitStack, contextmanager, suppress
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from . import __version__, cache, designfile, params
from .atomic import new_folder, snapshot, write_json
from .cad import export
from .cad.families import kernel_errors, part_count
from .cad.manifest import MANIFEST, Added, Manifest, manifest_files, read_manifest, write_manifest
from .checks.base import failing
from .checks.meshes import reading_early
from .checks.purpose import stiffening_checks
from .checks.report import REPORT, Report, read_report, write_report, write_summary
from .engine.concurrency import Ahead, Beside, default_jobs, start_beside
from .engine.context import Build, Hashes, StageInput, StageResult
from .engine.stagecache import cached_stage
from .engine.units import PartFiles
from .errors import InputError, clip
from .model import document, feasibility, materials
from .model.gravity import Gravity
from .model.plan import Plan, make_plan
from .options import BuildOptions
from .outputs import bom, guide, pictures, plates as print_plates, webview
from .outputs.plots import plot_lengths, plot_sag, plot_tolerance
from .outputs.stiffness import plot_gravity, plot_stiffness

__all__ = ["default_jobs"]      # a build's worker count unless told (hwgen.engine.concurrency), for the CLI

PLOT, SUMMARY, SAG, TOLERANCE = "lengths.png", "summary.md", "sag.png", "tolerance.png"
STIFFNESS, STIFFNESS_PLOT, GRAVITY_PLOT = "stiffness.json", "stiffness.png", "gravity.png"


def load(path: str | Path) -> params.LoadedDesign:
    """Read a design YAML (and its bases), check it against the schema, then check that it can be built.

    Raises :class:`hwgen.errors.InputError` naming, for every fault, the file and the field path.
    """
    try:
        loaded = params.read(path)
    except InputError as e:
        raise _material_too(e, path) from None
    return document.loaded_buildable(loaded)


def _material_too(e: InputError, path: str | Path) -> InputError:
    """A refusal by the schema or its rules with the process's material named too when hwgen does
    not know it (the feasibility checks, which name it otherwise, run only once these pass): every
    fault of a file in one run."""
    if any(p.path.startswith("process") and "material" in p.message for p in e.problems):
        return e
    try:
        layers = designfile.read_layers(path)
    except InputError:
        return e                        # the file itself cannot be read: that is the news
    process = layers.doc.get("process")
    material = process.get("material") if isinstance(process, dict) else None
    technology = process.get("technology") if isinstance(process, dict) else None
    why = materials.name_problem(material, technology if isinstance(technology, str) else None) \
        if isinstance(material, str) else None
    if why is None:
        return e
    return InputError.of([*e.problems, InputError(layers.file_of("process.material"), "process.material", why)],
                         e.notes)


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

def run_checks(folder: Path, manifest: Manifest, plan: Plan, loaded: params.LoadedDesign | None = None) -> Report:
    """:func:`checked`'s report."""
    return checked(folder, manifest, plan, loaded=loaded)[0]


def checked(folder: Path, manifest: Manifest, plan: Plan, ahead: Ahead | None = None,
            loaded: params.LoadedDesign | None = None) -> tuple[Report, dict]:
    """:func:`hwgen.checks.run.run_checks`, imported when the checks run: it brings scipy's
    optimisers, which a build whose stages all come from the cache never needs. In a build, with
    what the work ahead (``ahead``) measured on these very files while assembly.step was written,
    when it did. Then the tendon states' statics (:func:`statics`), whose stiffening joins the
    report. Returns (report, statics)."""
    from .checks.run import run_checks as run
    report = run(folder, manifest, plan, ahead.measured(folder, manifest) if ahead is not None else None)
    try:
        study = statics(plan, Gravity.of(report.get("gravity")))
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as e:      # the statics says why, the rest stands
        study = {"skipped": f"the tendon states' statics was not computed: {e}"}
    report["stiffening"] = study.get("stiffening") or ({"skipped": study["skipped"]} if "skipped" in study else None)
    purpose = [c.to_json() for c in stiffening_checks(plan, study)]
    report["checks"] = report["checks"] + purpose
    report["ok"] = report["ok"] and not failing(purpose)
    if loaded is not None and not all(c["passed"] for c in report["checks"]):
        from .tried import run as tried      # the models again: only where a check fails
        try:
            report = tried.attach(report, tried.Trial(loaded, plan, report, study))
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as e:    # the checks stand, untried
            report["tried"] = {"skipped": f"the fixes were not tried: {e}"}
    return report, study


def statics(plan: Plan, measured: Gravity | Mapping | None, which: list[str] | None = None) -> dict:
    """The statics of the plan's tendon states (or those named; :func:`hwgen.model.stiffness.study`)
    with the weights the checks measured (a report's ``gravity`` section, else the plan's
    estimate): stiffness.json's content, remembered in the active cache by what it reads (the
    described robot, its states and orientations, the code)."""
    from .model import stiffness as sf      # scipy's optimisers: only the checks and `hwgen stiffness`
    todo = [s for s in sf.states(plan) if not which or s.name in which]
    inputs = (sf.describe(plan, measured), todo, sf.ORIENTATIONS, sf.STUDY_H_MAX)
    return cache.remembered("stiffness study", inputs, lambda: sf.study(plan, which, measured=measured))


def checks_stage(s: StageInput) -> StageResult:
    """Measure the fresh files: report.json, summary.md, lengths.png, tolerance.png and sag.png; the
    checks go into the manifest. And the tendon states' statics: stiffness.json, stiffness.png,
    gravity.png."""
    folder = s.folder
    report, study = checked(folder, s.manifest, s.plan, s.ahead, s.loaded)
    write_report(report, folder)
    write_summary(report, folder / SUMMARY)
    plot_lengths(report, folder / PLOT)
    plot_tolerance(report, folder / TOLERANCE)
    plot_sag(report, s.manifest.design_report, folder / SAG)
    write_json(folder / STIFFNESS, study)
    if "skipped" not in study:
        plot_stiffness(study, folder / STIFFNESS_PLOT)
        plot_gravity(study, folder / GRAVITY_PLOT)
    return StageResult(Added({"checks": report["checks"], "checks_ok": report["ok"]}), report)


def bom_stage(s: StageInput) -> StageResult:
    """bom.csv and bom.md, from the manifest and the checks' report."""
    return StageResult(bom.write_bom(s.folder, s.manifest, s.plan, s.report))


def plates_stage(s: StageInput) -> StageResult:
    """plates/plate_NN.3mf and plates/plates.md: the printed parts on the printer's plates."""
    return StageResult(print_plates.write_plates(s.folder, s.manifest, s.plan.process, s.plan.plates))


def pictures_stage(s: StageInput) -> StageResult:
    """exploded.png, assembled.png, bent.png, exploded.svg and the guide's step pictures; a missing
    backend is recorded, not raised."""
    return StageResult(pictures.draw(s.folder, s.manifest, s.plan.render,
                                     bom.family_table(s.manifest, s.plan.process.name),
                                     guide.picture_jobs(s.folder, s.manifest, s.plan), enabled=s.options.pictures))


def marks_stage(s: StageInput) -> StageResult:
    """exploded.png and bent.png drawn again with what fails marked (the pictures stage ran beside
    the checks, before their verdict); nothing when every check passes."""
    return StageResult(pictures.mark_failures(s.folder, s.manifest, s.plan.render, enabled=s.options.pictures))


def guide_stage(s: StageInput) -> StageResult:
    """guide/assembly.md and guide/assembly.html, from bom.csv, the manifest and the step pictures."""
    return StageResult(guide.write_guide(s.folder, s.manifest, s.plan))


def view_stage(s: StageInput) -> StageResult:
    """view.html: the assembly in the browser with the checks on it and the tendon states'
    stiffness (stiffness.json, when the checks wrote it), the viewer inlined."""
    try:
        study = json.loads((s.folder / STIFFNESS).read_text())
    except (OSError, ValueError):
        study = None
    return StageResult(webview.write_view(s.folder, s.manifest, s.report, study, s.plan.render.explode_mm,
                                          s.plan.check.max_angle_deg, viewer=s.options.viewer))


# (name, stage) in the order a build runs them on its fresh files; each is given the files so far,
# the manifest with what the stages before it added, and the checks' report (None for the checks
# themselves, and for a stage that runs beside them)
AFTER_FILES: list[tuple[str, Callable[[StageInput], StageResult]]] = [
    ("checks", checks_stage), ("bom", bom_stage), ("plates", plates_stage), ("pictures", pictures_stage),
    ("marks", marks_stage), ("guide", guide_stage), ("view", view_stage)]
DRAWING_STAGES = ("bom", "pictures", "guide", "view")     # what `hwgen render` runs on existing outputs
BESIDE = ("plates", "pictures")     # stages that read only the parts' files and the manifest's parts and design
#                                     report: run in threads beside the others (the renderer is a child process)
AFTER_MEASURED = ("plates",)        # ... once the checks' measurement is over: its meshes and theirs, read from
#                                     the same files, would be in memory at once


def draw(plan: Plan, folder: Path, manifest: Manifest, options: BuildOptions) -> Manifest:
    """The drawing stages (bill of materials, pictures, guide) on a folder that has its files and
    report; the manifest with what they added."""
    report = read_report(folder)
    for name, stage in AFTER_FILES:
        if name in DRAWING_STAGES:
            manifest = manifest.adding(stage(StageInput(plan, folder, manifest, report, options=options)).added)
    return manifest


def sampled(plan: Plan, options: BuildOptions) -> Plan:
    """The plan with the as-built samples the build's options ask for (``--check-samples``,
    ``$HWGEN_CHECK_SAMPLES``) in place of the design's ``check.samples``: what the checks draw, and
    what every key that holds the plan is made with."""
    if options.check_samples is None or options.check_samples == plan.check.samples:
        return plan
    return replace(plan, check=replace(plan.check, samples=options.check_samples))


# ---------------------------------------------------------------- build

@dataclass
class BuildResult:
    folder: Path
    manifest: Manifest
    plan: Plan
    report: Report | None = None      # the checks' report, when they ran
    built: list[str] = field(default_factory=list)     # the parts made afresh (the others came from the cache)
    reused: list[str] = field(default_factory=list)    # the stages after the files taken from the cache
    notes: list[str] = field(default_factory=list)   # damaged entries found (and rebuilt), a cache turned off, work ahead that failed


def build(loaded: params.LoadedDesign, out_root: Path, progress: Callable[[str, int, int], None] | None = None,
          post_build: bool = True, cache_dir: Path | None | bool = True, parts: str | None = None,
          jobs: int | None = None, options: BuildOptions | None = None) -> BuildResult:
    """Build every part and file of the design into ``out_root/<design>/``, then (``post_build``)
    run the stages after the files. ``progress(part_name, done, total)`` follows each part.
    ``cache_dir``: the part cache's folder (True: :func:`hwgen.cache.default_dir`; None or False:
    build everything afresh and keep nothing).

    ``parts``: a shell pattern (``disk_*``); only the parts whose names match get their STL and
    STEP written. The manifest still lists every part as a whole build would (the others' entries
    from the cache, or built for it and not written); the assembly, the DXF and the stages after
    the files describe the whole robot and are left out, so ``hwgen check`` sees the folder as
    incomplete and builds it whole first. A pattern that matches no part is bad input.

    ``options``: how the build is run (None: as the environment says,
    :meth:`hwgen.options.BuildOptions.from_environment`; bad input before anything is written);
    ``jobs``, when given, in place of its worker processes that build the parts not in the cache
    and the assembly (0: all in this process, which then holds the CAD kernel's memory through the
    checks)."""
    options = (options or BuildOptions.from_environment()).with_jobs(jobs)
    store = _store(cache_dir)
    layout_key = cache.entry_key("tensioner layout", loaded.design)
    plan = sampled(design_plan(loaded, _kept_layout(store, layout_key)), options)
    out_root = Path(out_root)
    target = out_root / loaded.name
    select = None if parts is None else (lambda name: fnmatch.fnmatchcase(name, parts))
    with output_errors(out_root), new_folder(target) as tmp, ExitStack() as stack:
        # without a cache, the build's processes and threads hand each other what they make (the
        # solids its units share, the values its work ahead finds for the checks) in a store of
        # the build's own that goes with it (it starts empty: every value is made afresh)
        scratch = store if store.enabled else cache.Store(
            Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="hwgen-scratch-"))))
        b = Build(loaded, plan, tmp, target, store, scratch, stack, select=select, options=options, progress=progress)
        if post_build and b.whole:
            b.ahead = Ahead(scratch, plan, b.measured, b.hashes)
        manifest, built, side = _files_stage(b)
        if not b.whole:
            manifest = _written(b, manifest, parts)
        report, reused = None, []
        try:
            if post_build and b.whole:
                with cache.using(store), reading_early(b.ahead.meshes):
                    manifest, report = _after_files(b, manifest, side, reused)
        finally:
            b.measured.set()
            if b.ahead is not None:
                b.ahead.join()      # the checks met what it did (waiting for the entry it was making), or did it
                b.ahead.meshes.clear()
        write_manifest(tmp, manifest)
        if post_build and b.whole:
            _keep_added(target, tmp, manifest)
    chosen = tensioner_record(manifest)
    if chosen is not None:
        store.put_record(layout_key, {"search": chosen})
    store.trim(options.cache_size)
    notes = [f"part cache: damaged entries rebuilt: {', '.join(store.corrupt)}"] if store.corrupt else []
    notes += [f"part cache: not written, so not used: {store.unwritable}"] if store.unwritable else []
    notes += [f"work done ahead of the checks failed, and the checks did it again: {f}"
              for f in (b.ahead.failures if b.ahead is not None else [])]
    return BuildResult(target, manifest, plan, report, built, reused, notes)


def _keep_added(target: Path, tmp: Path, manifest: Manifest) -> None:
    """Into a new build's folder, the folders the other commands added to the one it replaces
    (:data:`ADDED`: `hwgen sim`'s, `hwgen experiment`'s, `hwgen coupon`'s), when that one is the
    same build: the same design's bytes, the same hwgen, every file the same bytes (an unchanged
    rebuild keeps them, issue 43; a changed one drops them, as they describe another robot)."""
    def files(m: Manifest) -> dict:
        return {f.path: f.sha256 for f in manifest_files(m)}

    with snapshot(target) as view:
        try:
            old = read_manifest(view)
            same = (old.params_sha256 == manifest.params_sha256 and old.hwgen_version == manifest.hwgen_version
                    and files(old) == files(manifest))
        except (OSError, ValueError, AttributeError, KeyError, TypeError):
            return                  # nothing there, or no build hwgen wrote: nothing to keep
        for name in ADDED if same else ():
            if (view / name).is_dir() and not (tmp / name).exists():
                shutil.copytree(view / name, tmp / name)


def _files_stage(b: Build) -> tuple[Manifest, list[str], dict[str, Beside]]:
    """Every part's files, the assembly, the strip's template and the manifest
    (:class:`hwgen.engine.units.PartFiles`); in a whole build whose checks will run, the stages
    that read only the parts' files start as soon as those are in (returned: they run on), and
    the checks' measurement once the template is in too, while the assembly is written. Returns
    the manifest, the names of the parts built afresh and the stages started beside."""
    side: dict = {}

    def placed(early: Manifest) -> None:
        side.update(start_beside(b, early, [(n, s) for n, s in AFTER_FILES if n in BESIDE], AFTER_MEASURED))

    def measurable(early: Manifest) -> None:
        b.ahead.measure(b.folder, early)

    try:
        manifest, built = PartFiles(b).write(placed if b.ahead else None, measurable if b.ahead else None)
        return manifest, built, side
    except BaseException:
        if b.ahead is not None:
            b.ahead.abandon()
        raise


def _written(b: Build, manifest: Manifest, pattern: str) -> Manifest:
    """A --parts build's manifest, saying which parts it wrote; bad input when the pattern matches none."""
    written = [p.name for p in manifest.parts if b.select(p.name)]
    if not written:
        names = ", ".join(p.name for p in manifest.parts)
        raise InputError(b.loaded.source, "--parts", f"{clip(pattern)!r} matches none of the parts: {clip(names, 200)}")
    return replace(manifest, parts_written={"pattern": pattern, "names": written})


def _after_files(b: Build, manifest: Manifest, side: dict[str, Beside], reused: list[str]
                 ) -> tuple[Manifest, Report | None]:
    """The stages after the files, in the order of :data:`AFTER_FILES`, each given the manifest with
    what the stages before it added; those in :data:`BESIDE` were started before
    (:func:`_files_stage`), and what they made joins the folder and the manifest at their place in
    the order (``side``), so the outputs are those of the stages run one after the other. ``b.measured`` is
    set once the checks are done (or the work ahead's measurement taken, sooner). Returns the
    manifest and the checks' report."""
    report = None
    for name, stage in AFTER_FILES:
        if name in side:
            beside = side[name]
            manifest = manifest.adding(beside.join(b.folder))
            reused += beside.reused
            continue
        given = StageInput(b.plan, b.folder, manifest, report, b.ahead if name == "checks" else None,
                           b.loaded if name == "checks" else None, options=b.options)
        done = cached_stage(b.store, b.hashes, name, stage, given, reused)
        manifest = manifest.adding(done.added)
        if name == "checks":
            report = done.report
            b.measured.set()
    return manifest, report


def _store(cache_dir: Path | None | bool) -> cache.Store:
    return cache.Store(cache.default_dir() if cache_dir is True else (cache_dir or None))


def _kept_layout(store: cache.Store, key: str) -> dict | None:
    """The tensioner layout's search record a build of this very design (and code) kept: the plan
    lays out the arrangement it names instead of searching again (as ``hwgen check`` does from the
    manifest; the same layout and record)."""
    rec = store.get_record(key)
    return rec["search"] if isinstance(rec, dict) and isinstance(rec.get("search"), dict) else None


# ---------------------------------------------------------------- on existing outputs

def stale_reason(folder: Path, loaded) -> str | None:
    """Why the outputs in ``folder`` cannot be checked as they are (None: they can)."""
    if not (folder / MANIFEST).exists():
        return "no outputs yet"
    try:
        m = read_manifest(folder)
    except (OSError, ValueError):
        return "manifest.json is unreadable"
    except (AttributeError, KeyError, TypeError):
        return "manifest.json is not one hwgen wrote"
    try:
        if m.params_sha256 != loaded.sha256:
            return "built from other parameters"
        if m.hwgen_version != __version__:
            return f"built by hwgen {m.hwgen_version}, this is {__version__}"
        m.design_report["disks"]        # raise for a manifest hwgen did not write
        files = [f.path for f in manifest_files(m)]
    except (AttributeError, KeyError, TypeError, ValueError):
        return "manifest.json is not one hwgen wrote"
    for path in files:
        if not isinstance(path, str) or not (folder / path).is_file():
            return f"{path} is missing"
    return None


def check(loaded: params.LoadedDesign, out_root: Path, progress=None,
          cache_dir: Path | None | bool = True, options: BuildOptions | None = None) -> tuple[Report, Path, str | None]:
    """`hwgen check`: build if needed, then measure. Returns (report, folder, why it was rebuilt or None).

    Outputs measured before, with every file as it was then (same bytes, same manifest, plan,
    sample count and code), get that report back from the cache instead of being measured again.
    ``options``: as :func:`build`'s."""
    folder = Path(out_root) / loaded.name
    options = options or BuildOptions.from_environment()
    with output_errors(Path(out_root)), snapshot(folder) as view:
        why = stale_reason(view, loaded)
        if why is None:
            manifest = read_manifest(view)
            # these files were built from these very parameters: their tensioner is laid out again
            # in the arrangement the build chose (its manifest says which), not searched for again
            plan = sampled(design_plan(loaded, tensioner_record(manifest)), options)
            store = _store(cache_dir)
            report = _measured(store, view, manifest, plan, loaded)
            store.trim(options.cache_size)
            return report, folder, None
    return build(loaded, Path(out_root), progress, cache_dir=cache_dir, options=options).report, folder, why


def tensioner_record(manifest: Manifest) -> dict | None:
    """The tensioner layout's search record a build kept in its manifest (None: none there)."""
    for p in manifest.parts:
        if p.role == "tensioner_housing" and isinstance(p.meta.get("layout_search"), dict):
            return p.meta["layout_search"]
    return None


def _measured(store: cache.Store, folder: Path, manifest: Manifest, plan: Plan,
              loaded: params.LoadedDesign | None = None) -> Report:
    """run_checks on the folder, or its report from the last time these very files were measured."""
    if not store.enabled:
        return run_checks(folder, manifest, plan, loaded)
    key = cache.entry_key("check", (Hashes().files(folder), manifest, plan), libraries=cache.LIBRARIES)
    rec = store.get_record(key)
    data = store.get_bytes(rec["report"]) if isinstance(rec, dict) and isinstance(rec.get("report"), str) else None
    if data is not None:
        with suppress(ValueError):     # a damaged record: the checks run again below
            return json.loads(data)
    with cache.using(store):
        report = cache.as_json(run_checks(folder, manifest, plan, loaded))
    store.put_record(key, {"report": store.put_bytes(json.dumps(report).encode())})
    return report


def render(loaded: params.LoadedDesign, out_root: Path, cache_dir: Path | None | bool = True,
           options: BuildOptions | None = None) -> tuple[dict, Path, str | None]:
    """`hwgen render`: the bill of materials, pictures and drawing of ``out_root/<design>/``.

    Builds first (which draws) when the outputs are missing or stale; otherwise draws into the
    existing folder and rewrites its manifest. Returns (the manifest's render entry, the
    folder, why it was rebuilt or None). ``options``: as :func:`build`'s.
    """
    folder = Path(out_root) / loaded.name
    options = options or BuildOptions.from_environment()
    why = stale_reason(folder, loaded)
    if why is not None:
        result = build(loaded, Path(out_root), cache_dir=cache_dir, options=options)
        return result.manifest.render or {}, folder, why
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp:
        manifest = read_manifest(tmp)
        plan = sampled(design_plan(loaded, tensioner_record(manifest)), options)     # current files: as check does
        manifest = draw(plan, tmp, manifest, options)
        write_manifest(tmp, manifest)
    return manifest.render, folder, None


def plates(loaded: params.LoadedDesign, out_root: Path,
           cache_dir: Path | None | bool = True) -> tuple[dict, Path, str | None]:
    """`hwgen plates`: the print plates of ``out_root/<design>/``, laid out again into the
    existing outputs (a build lays them out too; builds first when the outputs are missing or
    stale). Returns (the plate summary, the folder, why it was rebuilt or None)."""
    folder = Path(out_root) / loaded.name
    why = stale_reason(folder, loaded)
    if why is not None:
        result = build(loaded, Path(out_root), cache_dir=cache_dir)
        return result.manifest.plates, folder, why
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp:
        manifest = read_manifest(tmp)
        shutil.rmtree(tmp / print_plates.FOLDER, ignore_errors=True)
        done = plates_stage(StageInput(design_plan(loaded, tensioner_record(manifest)), tmp, manifest))
        write_manifest(tmp, manifest.adding(done.added))
    return done.added.sections["plates"], folder, None


COUPON = "coupon"          # the folder of `hwgen coupon`'s files inside out/<design>/


def coupon(loaded: params.LoadedDesign, out_root: Path) -> tuple[dict, Path]:
    """`hwgen coupon`: the calibration coupon of the design (:mod:`hwgen.model.coupon`), written
    as coupon/coupon.stl, coupon.step and coupon.json (each feature, its label and where it is)
    into ``out_root/<design>/``, added to what is there (an unchanged rebuild keeps it; a build of
    changed files drops it: :func:`_keep_added`). Returns (coupon.json's content, the folder)."""
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
        unknown = [clip(name) for name in which if name not in known]
        if unknown:
            raise InputError(loaded.source, "--states", f"unknown state{'s' if len(unknown) > 1 else ''} "
                                                        f"{', '.join(map(repr, unknown))}; this design's are "
                                                        f"{', '.join(known)}")
    with cache.using(_store(cache_dir)):
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
    its meshes, sim.json and sim.png into ``out_root/<design>/`` (added to what is there; an
    unchanged rebuild keeps it, a build of changed files drops it: :func:`_keep_added`). Builds first when the outputs are missing or stale.
    Checked against the build's stiffness.json, else :func:`statics` (remembered in the cache).
    Returns (sim.json's content, the folder, why it was rebuilt or None)."""
    from .sim.run import simulate            # MuJoCo: only this command
    folder = Path(out_root) / loaded.name
    why = stale_reason(folder, loaded)
    if why is None and not (folder / REPORT).is_file():
        why = f"{REPORT} is missing"
    if why is not None:
        build(loaded, Path(out_root), cache_dir=cache_dir)
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp, cache.using(_store(cache_dir)):
        manifest, report = read_manifest(tmp), read_report(tmp)
        shutil.rmtree(tmp / SIM, ignore_errors=True)
        plan = design_plan(loaded, tensioner_record(manifest))
        result = simulate(plan, tmp, manifest, report, tmp / SIM, lambda: statics(plan, report.get("gravity")))
    return result, folder, why


EXPERIMENT = "experiment"  # the folder of `hwgen experiment`'s and `hwgen compare`'s files inside out/<design>/
# the folders other commands add to a build's: an unchanged rebuild keeps them (:func:`_keep_added`)
ADDED = (SIM, EXPERIMENT, COUPON)


def _current_weights(loaded: params.LoadedDesign, out_root: Path) -> tuple[dict | None, dict | None]:
    """The weights a current build of the design measured (its report's gravity section) and its
    tensioner's layout record, as `hwgen stiffness` takes them; (None, None) without one."""
    folder = Path(out_root) / loaded.name
    with output_errors(Path(out_root)), snapshot(folder) as view:
        if stale_reason(view, loaded) is None:
            return (read_report(view) or {}).get("gravity"), tensioner_record(read_manifest(view))
    return None, None


def experiment(loaded: params.LoadedDesign, out_root: Path, cache_dir: Path | None | bool = True) -> tuple[dict, Path]:
    """`hwgen experiment`: the paper's push test predicted for the design (:mod:`hwgen.model.experiment`;
    the weights of a current build when there is one, as `hwgen stiffness`), remembered in the
    cache by what it reads, written as experiment/ (protocol.md, predicted.csv, experiment.json,
    template.csv, experiment.png) into ``out_root/<design>/``, added to what is there. Returns
    (experiment.json's content, the folder)."""
    from .model import experiment as ex          # scipy and numba: only these commands
    from .model import stiffness as sf
    from .outputs import experiment as ox
    weights, record = _current_weights(loaded, out_root)
    plan = design_plan(loaded, record)
    ex.disks_pushed(plan)
    inputs = (sf.describe(plan, weights), [s.name for s in sf.states(plan)], plan.experiment,
              None if plan.tensioner_layout is None else (plan.tensioner_layout.pair.ratio,
                                                          plan.tensioner_layout.winding_radius))
    with cache.using(_store(cache_dir)):
        result = cache.remembered("experiment", inputs, lambda: ex.experiment(plan, weights))
    result = {"design": loaded.name, "params_sha256": loaded.sha256,
              "weights": "measured from the current build's files" if weights else "estimated from the plan",
              **result}
    folder = Path(out_root) / loaded.name
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp:
        where = tmp / EXPERIMENT
        shutil.rmtree(where, ignore_errors=True)         # a comparison with an earlier prediction goes with it
        where.mkdir()
        write_json(where / "experiment.json", result)
        ox.write_predicted(result, where / "predicted.csv")
        ox.write_template(result, where / "template.csv")
        ox.write_protocol(result, where / "protocol.md")
        ox.plot_experiment(result, where / "experiment.png")
    return result, folder


def compare(loaded: params.LoadedDesign, measured_csv: Path, out_root: Path) -> tuple[dict, Path]:
    """`hwgen compare`: a lab's pushes (:mod:`hwgen.model.calibration`) fitted by eq. (4), measured
    against predicted with its band, and the ranged values fitted to them, written as
    experiment/compare.json, compare.png and calibrated.yaml (the design file with the fitted
    values) into ``out_root/<design>/``. Returns (compare.json's content, the folder)."""
    from .designfile import rewritten
    from .model import calibration as cal
    from .model.experiment import Bench
    from .outputs import experiment as ox
    weights, record = _current_weights(loaded, out_root)
    plan = design_plan(loaded, record)
    raw = cal.read_bytes(measured_csv)
    pushes = cal.read_measured(measured_csv, raw, plan)
    measured = cal.fit_measured(pushes, plan.experiment.fit_window_samples)
    bench = Bench(plan, weights)
    result = {"design": loaded.name, "params_sha256": loaded.sha256, "measurement": str(measured_csv),
              "measurement_sha256": hashlib.sha256(raw).hexdigest(), **cal.compared(plan, measured, bench)}
    result["calibration"] = cal.calibrate(plan, measured, bench)
    result["fitted"] = result["calibration"].pop("fitted")
    name = f"{loaded.name}-calibrated" if params.SAFE_NAME.match(f"{loaded.name}-calibrated") else "calibrated"
    head = (f"hwgen compare: {loaded.name} with {', '.join(result['fitted']) or 'nothing'} fitted by least squares to "
            f"the pushes measured in {Path(measured_csv).name} (sha256 {result['measurement_sha256'][:16]}); "
            f"renamed {name} so that its build does not replace the design's")
    yaml_text = rewritten(loaded.source, {f: (round(v["value"], 6), f"fitted by hwgen compare to "
                                          f"{Path(measured_csv).name}: 95 % {v['low']:.4g}-{v['high']:.4g}; the "
                                          f"design had {v['design']:g}") for f, v in result["fitted"].items()},
                          name, head)
    folder = Path(out_root) / loaded.name
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp:
        where = tmp / EXPERIMENT
        where.mkdir(exist_ok=True)
        write_json(where / "compare.json", result)
        (where / "calibrated.yaml").write_text(yaml_text)
        ox.plot_experiment(result["prediction"], where / "compare.png", result)
    return result, folder
