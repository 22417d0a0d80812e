"""The order of the stages, and the one place that knows it.

    read (params) → feasibility (model) → plan (model) → parts (cad) → files and manifest (cad)
    → checks (report.json, summary.md) → plots (lengths.png, tolerance.png, sag.png) → bill of materials → pictures

Every build writes into a fresh staging folder beside the target; only when every file is
complete is it swapped in for ``out/<design>/`` in one step (:func:`hwgen.atomic.new_folder`).
A failure or a kill at any point leaves the old outputs exactly as they were; two builds at
once both finish, and the last to finish is what the folder holds. ``hwgen check`` reads the
outputs as they are; ``hwgen render`` draws into a copy of them and swaps it in the same way;
both build first only when the outputs are missing or made from other parameters.

An output root that cannot be written (not a folder, no permission, a full disk) is bad input
naming ``--out`` (:class:`hwgen.errors.InputError`), like any other.
"""
from __future__ import annotations

import errno
import json
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from . import __version__, params
from .atomic import new_folder, snapshot, write_json
from .cad import export
from .cad.families import build_parts, kernel_errors, part_count
from .errors import InputError, clip
from .cad.manifest import design_report, part_entry, sha256
from .checks.measure import read_manifest
from .checks.report import write_summary
from .checks.run import run_checks
from .model import feasibility
from .model import stiffness as statics_study
from .model.materials import printed_density
from .model.plan import Plan, plan as make_plan
from .outputs import bom, pictures
from .outputs.plots import plot_lengths, plot_sag, plot_tolerance
from .outputs.stiffness import plot_gravity, plot_stiffness

REPORT, PLOT, SUMMARY, SAG, TOLERANCE = "report.json", "lengths.png", "summary.md", "sag.png", "tolerance.png"
STIFFNESS, STIFFNESS_PLOT, GRAVITY_PLOT = "stiffness.json", "stiffness.png", "gravity.png"


def load(path: str | Path) -> params.LoadedDesign:
    """Read a design YAML, check it against the schema, then check that it can be built.

    Raises :class:`hwgen.errors.InputError` naming the file and the field path.
    """
    loaded = params.read(path)
    feasibility.check(loaded.design, path)
    return loaded


def design_plan(loaded: params.LoadedDesign) -> Plan:
    """The plan of a loaded design, with everything its part families need to be built (holes
    the disks and the strip can take, the tensioner's layout); raises
    :class:`hwgen.errors.DesignError` naming the field.
    Every command starts from it, so they all refuse the same designs the same way."""
    plan = make_plan(loaded.design)
    feasibility.check_plan(plan)
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

def checks_stage(plan: Plan, folder: Path, manifest: dict) -> dict:
    """Measure the fresh files: report.json, summary.md, lengths.png, tolerance.png and sag.png; the checks go
    into the manifest."""
    report = run_checks(folder, manifest, plan)
    manifest["checks"] = report["checks"]
    manifest["checks_ok"] = report["ok"]
    write_json(folder / REPORT, report)
    write_summary(report, folder / SUMMARY)
    plot_lengths(report, folder / PLOT)
    plot_tolerance(report, folder / TOLERANCE)
    plot_sag(report, manifest["design_report"], folder / SAG)
    return report


def bom_stage(plan: Plan, folder: Path, manifest: dict) -> None:
    """bom.csv and bom.md, from the manifest and the checks' report.json."""
    bom.write_bom(folder, manifest, plan.design)


def pictures_stage(plan: Plan, folder: Path, manifest: dict) -> None:
    """exploded.png, assembled.png, bent.png and exploded.svg; a missing backend is recorded, not raised."""
    pictures.draw(folder, manifest, plan.design, bom.family_table(manifest, plan.design))


# (name, stage(plan, folder, manifest)) in the order a build runs them on its fresh files
AFTER_FILES: list[tuple[str, Callable[[Plan, Path, dict], object]]] = [
    ("checks", checks_stage), ("bom", bom_stage), ("pictures", pictures_stage)]
DRAWING_STAGES = ("bom", "pictures")     # what `hwgen render` runs on existing outputs


def draw(plan: Plan, folder: Path, manifest: dict) -> None:
    """The drawing stages (bill of materials, pictures) on a folder that has its files and report."""
    for name, stage in AFTER_FILES:
        if name in DRAWING_STAGES:
            stage(plan, folder, manifest)


# ---------------------------------------------------------------- build

@dataclass
class BuildResult:
    folder: Path
    manifest: dict
    plan: Plan
    report: dict | None = None        # the checks' report, when they ran


def build(loaded: params.LoadedDesign, out_root: Path, progress: Callable[[str, int, int], None] | None = None,
          post_build: bool = True) -> BuildResult:
    """Build every part and file of the design into ``out_root/<design>/``, then (``post_build``)
    run the stages after the files. ``progress(part_name, done, total)`` follows each part."""
    plan = design_plan(loaded)
    total = part_count(plan)
    out_root = Path(out_root)
    target = out_root / loaded.design.design
    with output_errors(out_root), new_folder(target) as tmp:
        manifest = _write_files(loaded, plan, tmp, total, progress)
        done = {}
        if post_build:
            for name, stage in AFTER_FILES:
                done[name] = stage(plan, tmp, manifest)
        write_json(tmp / "manifest.json", manifest)
    return BuildResult(target, manifest, plan, done.get("checks"))


def _write_files(loaded: params.LoadedDesign, plan: Plan, folder: Path, total: int, progress) -> dict:
    (folder / "stl").mkdir()
    (folder / "step").mkdir()
    parts, entries = [], []
    density, _ = printed_density(plan.design.process)
    for part in build_parts(plan):
        files = {"stl": folder / "stl" / f"{part.name}.stl", "step": folder / "step" / f"{part.name}.step"}
        with kernel_errors(plan, part, "write the files of"):
            export.write_stl(part.solid, files["stl"])
            export.write_step(part.solid, files["step"], part.name)
            entries.append(part_entry(part, files, folder, plan.design.process.material, density))
        parts.append(part)
        if progress:
            progress(part.name, len(parts), total)
    with kernel_errors(plan, None, "write assembly.step"):
        export.write_assembly(parts, loaded.design.design, folder / "assembly.step")
    export.write_backbone_dxf(plan.backbone, plan.stations, folder / "backbone_template.dxf")
    return {
        "design": loaded.design.design,
        "hwgen_version": __version__,
        "params_file": loaded.source,
        "params_sha256": loaded.sha256,
        "files": {
            "assembly": {"path": "assembly.step", "sha256": sha256(folder / "assembly.step")},
            "backbone_template": {"path": "backbone_template.dxf",
                                  "sha256": sha256(folder / "backbone_template.dxf")},
        },
        "parts": entries,
        "design_report": design_report(plan),
    }


# ---------------------------------------------------------------- on existing outputs

def stale_reason(folder: Path, loaded) -> str | None:
    """Why the outputs in ``folder`` cannot be checked as they are (None: they can)."""
    mpath = folder / "manifest.json"
    if not mpath.exists():
        return "no outputs yet"
    try:
        m = json.loads(mpath.read_text())
    except (OSError, ValueError):
        return "manifest.json is unreadable"
    try:
        if m.get("params_sha256") != loaded.sha256:
            return "built from other parameters"
        if m.get("hwgen_version") != __version__:
            return f"built by hwgen {m.get('hwgen_version')}, this is {__version__}"
        files = [f["path"] for p in m["parts"] for f in p["files"].values()]
        files += [f["path"] for f in m["files"].values()]
        m["design_report"]["disks"]
    except (AttributeError, KeyError, TypeError):
        return "manifest.json is not one hwgen wrote"
    for path in files:
        if not isinstance(path, str) or not (folder / path).is_file():
            return f"{path} is missing"
    return None


def check(loaded: params.LoadedDesign, out_root: Path, progress=None) -> tuple[dict, Path, str | None]:
    """`hwgen check`: build if needed, then measure. Returns (report, folder, why it was rebuilt or None)."""
    folder = Path(out_root) / loaded.design.design
    plan = design_plan(loaded)
    with output_errors(Path(out_root)), snapshot(folder) as view:
        why = stale_reason(view, loaded)
        if why is None:
            return run_checks(view, read_manifest(view), plan), folder, None
    return build(loaded, Path(out_root), progress).report, folder, why


def render(loaded: params.LoadedDesign, out_root: Path) -> tuple[dict, Path, str | None]:
    """`hwgen render`: the bill of materials, pictures and drawing of ``out_root/<design>/``.

    Builds first (which draws) when the outputs are missing or stale; otherwise draws into the
    existing folder and rewrites its manifest. Returns (the manifest's render entry, the
    folder, why it was rebuilt or None).
    """
    folder = Path(out_root) / loaded.design.design
    plan = design_plan(loaded)
    why = stale_reason(folder, loaded)
    if why is not None:
        result = build(loaded, Path(out_root))
        return result.manifest.get("render", {}), folder, why
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp:
        manifest = read_manifest(tmp)
        draw(plan, tmp, manifest)
        write_json(tmp / "manifest.json", manifest)
    return manifest["render"], folder, None


def stiffness(loaded: params.LoadedDesign, out_root: Path, which: list[str] | None = None) -> tuple[dict, Path]:
    """`hwgen stiffness`: the statics of every tendon state (or those named) from the plan, the
    weights measured from the built files when ``out_root/<design>/`` holds a current build (its
    report's gravity section), else estimated from the plan; written as stiffness.json,
    stiffness.png and gravity.png into that folder (added to what is there; a later build replaces
    the folder and drops them). Returns (report, folder)."""
    plan = design_plan(loaded)
    if which:
        known = [s.name for s in statics_study.states(plan.design)]
        for name in which:
            if name not in known:
                raise InputError(loaded.source, "--states", f"unknown state {clip(name)!r}; this design's are "
                                                            f"{', '.join(known)}")
    folder = Path(out_root) / loaded.design.design
    measured = None
    with output_errors(Path(out_root)), snapshot(folder) as view:
        if stale_reason(view, loaded) is None and (view / REPORT).is_file():
            try:
                measured = json.loads((view / REPORT).read_text()).get("gravity")
            except (OSError, ValueError):
                measured = None
    report = statics_study.study(plan, which, measured=measured)
    with output_errors(Path(out_root)), new_folder(folder, copy_current=True) as tmp:
        write_json(tmp / STIFFNESS, report)
        plot_stiffness(report, tmp / STIFFNESS_PLOT)
        plot_gravity(report, tmp / GRAVITY_PLOT)
    return report, folder
