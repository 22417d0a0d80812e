"""`hwgen build`: parameters -> plan -> parts -> files, written atomically.

Everything is written into a fresh temporary folder beside the target; only when every
file is complete does it replace ``out/<design>/``. A failure at any point leaves the old
outputs exactly as they were.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from . import __version__, export
from .assembly import build_parts, part_count
from .design import Plan, plan as make_plan
from .params import LoadedDesign

# Steps run on the finished files before they are published: (name, step(plan, folder, manifest)).
# Later stages (checks, renders) add themselves here; each may add entries to the manifest.
POST_BUILD: list[tuple[str, Callable[[Plan, Path, dict], None]]] = []


def _checks(plan: Plan, folder: Path, manifest: dict) -> None:
    """Measure the fresh files; manifest["checks"], report.json, lengths.png, summary.md."""
    from .checks.run import post_build
    post_build(plan, folder, manifest)


POST_BUILD.append(("checks", _checks))


def _render(plan: Plan, folder: Path, manifest: dict) -> None:
    """After the checks (the BOM reads their report.json): bom.csv, bom.md, PNG pictures, exploded.svg."""
    from .render import step
    step(plan, folder, manifest)


POST_BUILD.append(("render", _render))


@dataclass
class BuildResult:
    folder: Path
    manifest: dict
    plan: Plan


def build(loaded: LoadedDesign, out_root: Path, progress: Callable[[str, int, int], None] | None = None,
          post_build: bool = True) -> BuildResult:
    """Build every part and file of the design into ``out_root/<design>/``.

    ``progress(part_name, done, total)`` is called after each part is written.
    """
    plan = make_plan(loaded.design)
    total = part_count(plan)  # raises DesignError for a part family that cannot be made, before any write
    out_root.mkdir(parents=True, exist_ok=True)
    target = out_root / loaded.design.design
    tmp = Path(tempfile.mkdtemp(prefix=f".{loaded.design.design}.", suffix=".tmp", dir=out_root))
    try:
        manifest = _write_all(loaded, plan, tmp, total, progress)
        if post_build:
            for _name, step in POST_BUILD:
                step(plan, tmp, manifest)
        export.write_json(manifest, tmp / "manifest.json")
        _publish(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return BuildResult(target, manifest, plan)


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


def _write_all(loaded: LoadedDesign, plan: Plan, folder: Path, total: int, progress) -> dict:
    (folder / "stl").mkdir()
    (folder / "step").mkdir()
    parts, entries = [], []
    for part in build_parts(plan):
        files = {"stl": folder / "stl" / f"{part.name}.stl", "step": folder / "step" / f"{part.name}.step"}
        export.write_stl(part.solid, files["stl"])
        export.write_step(part.solid, files["step"])
        entries.append(export.part_entry(part, files, folder))
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
            "assembly": {"path": "assembly.step", "sha256": export.sha256(folder / "assembly.step")},
            "backbone_template": {"path": "backbone_template.dxf",
                                  "sha256": export.sha256(folder / "backbone_template.dxf")},
        },
        "parts": entries,
        "design_report": export.design_report(plan),
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

