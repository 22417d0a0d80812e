"""The order of the stages, and the one place that knows it.

    read (params) → feasibility (model) → plan (model) → parts (cad) → files and manifest (cad)
    → checks (report.json, summary.md) → plots (lengths.png, sag.png) → bill of materials → pictures

Every build writes into a fresh temporary folder beside the target; only when every file is
complete does it replace ``out/<design>/``. A failure at any point leaves the old outputs
exactly as they were. ``hwgen check`` and ``hwgen render`` run their stages on the outputs as
they are, and build first only when the outputs are missing or made from other parameters.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from . import __version__, params
from .atomic import write_json
from .cad import export
from .cad.families import build_parts, part_count
from .cad.manifest import design_report, part_entry, sha256
from .checks.measure import read_manifest
from .checks.report import write_summary
from .checks.run import run_checks
from .model import feasibility
from .model.materials import printed_density
from .model.plan import Plan, plan as make_plan
from .outputs import bom, pictures
from .outputs.plots import plot_lengths, plot_sag

REPORT, PLOT, SUMMARY, SAG = "report.json", "lengths.png", "summary.md", "sag.png"


def load(path: str | Path) -> params.LoadedDesign:
    """Read a design YAML, check it against the schema, then check that it can be built.

    Raises :class:`hwgen.errors.InputError` naming the file and the field path.
    """
    loaded = params.read(path)
    feasibility.check(loaded.design, path)
    return loaded


# ---------------------------------------------------------------- stages after the files

def checks_stage(plan: Plan, folder: Path, manifest: dict) -> dict:
    """Measure the fresh files: report.json, summary.md, lengths.png and sag.png; the checks go into the manifest."""
    report = run_checks(folder, manifest, plan)
    manifest["checks"] = report["checks"]
    manifest["checks_ok"] = report["ok"]
    write_json(folder / REPORT, report)
    write_summary(report, folder / SUMMARY)
    plot_lengths(report, folder / PLOT)
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


def build(loaded: params.LoadedDesign, out_root: Path, progress: Callable[[str, int, int], None] | None = None,
          post_build: bool = True) -> BuildResult:
    """Build every part and file of the design into ``out_root/<design>/``, then (``post_build``)
    run the stages after the files. ``progress(part_name, done, total)`` follows each part."""
    plan = make_plan(loaded.design)
    total = part_count(plan)  # raises DesignError for a part family that cannot be made, before any write
    out_root.mkdir(parents=True, exist_ok=True)
    target = out_root / loaded.design.design
    tmp = Path(tempfile.mkdtemp(prefix=f".{loaded.design.design}.", suffix=".tmp", dir=out_root))
    try:
        manifest = _write_files(loaded, plan, tmp, total, progress)
        if post_build:
            for _name, stage in AFTER_FILES:
                stage(plan, tmp, manifest)
        write_json(tmp / "manifest.json", manifest)
        _publish(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return BuildResult(target, manifest, plan)


def _write_files(loaded: params.LoadedDesign, plan: Plan, folder: Path, total: int, progress) -> dict:
    (folder / "stl").mkdir()
    (folder / "step").mkdir()
    parts, entries = [], []
    density, _ = printed_density(plan.design.process)
    for part in build_parts(plan):
        files = {"stl": folder / "stl" / f"{part.name}.stl", "step": folder / "step" / f"{part.name}.step"}
        export.write_stl(part.solid, files["stl"])
        export.write_step(part.solid, files["step"])
        entries.append(part_entry(part, files, folder, plan.design.process.material, density))
        parts.append(part)
        if progress:
            progress(part.name, len(parts), total)
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


def _publish(tmp: Path, target: Path) -> None:
    """Swap the finished folder in: rename the old one aside, rename the new one in, drop the old."""
    os.chmod(tmp, 0o755)
    old = None
    if target.exists():
        old = target.with_name(f".{target.name}.old-{os.getpid()}")
        shutil.rmtree(old, ignore_errors=True)
        os.rename(target, old)
    try:
        os.rename(tmp, target)
    except BaseException:
        if old is not None:
            os.rename(old, target)
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


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
    if m.get("params_sha256") != loaded.sha256:
        return "built from other parameters"
    if m.get("hwgen_version") != __version__:
        return f"built by hwgen {m.get('hwgen_version')}, this is {__version__}"
    for p in m.get("parts", []):
        for f in p.get("files", {}).values():
            if not (folder / f["path"]).exists():
                return f"{f['path']} is missing"
    for f in m.get("files", {}).values():
        if not (folder / f["path"]).exists():
            return f"{f['path']} is missing"
    return None


def check(loaded: params.LoadedDesign, out_root: Path, progress=None) -> tuple[dict, Path, str | None]:
    """`hwgen check`: build if needed, then measure. Returns (report, folder, why it was rebuilt or None)."""
    folder = Path(out_root) / loaded.design.design
    why = stale_reason(folder, loaded)
    if why is not None:
        build(loaded, Path(out_root), progress)
        return json.loads((folder / REPORT).read_text()), folder, why
    return run_checks(folder, read_manifest(folder), make_plan(loaded.design)), folder, None


def render(loaded: params.LoadedDesign, out_root: Path) -> tuple[dict, Path, str | None]:
    """`hwgen render`: the bill of materials, pictures and drawing of ``out_root/<design>/``.

    Builds first (which draws) when the outputs are missing or stale; otherwise draws into the
    existing folder and rewrites its manifest. Returns (the manifest's render entry, the
    folder, why it was rebuilt or None).
    """
    folder = Path(out_root) / loaded.design.design
    why = stale_reason(folder, loaded)
    if why is not None:
        result = build(loaded, Path(out_root))
        return result.manifest.get("render", {}), folder, why
    manifest = read_manifest(folder)
    draw(make_plan(loaded.design), folder, manifest)
    write_json(folder / "manifest.json", manifest)
    return manifest["render"], folder, None
